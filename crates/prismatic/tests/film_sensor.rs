//! pbrt-v4's pixel-sensor parameters end to end: `iso` and the camera's shutter interval scale the image by the
//! imaging ratio t · ISO / 100, `whitebalance` and `maxcomponentvalue` reach the film, measured camera sensors
//! render a grey card grey, and unknown sensors or bad values are errors naming the parameter with file:line:column.

use film::Film;
use render::BuiltScene;
use spectral::WavelengthStrategy;

mod support;
use support::{build_error, try_build};

fn scene(film_params: &str, camera_params: &str) -> String {
    format!(
        "LookAt 0 0 -5  0 0 0  0 1 0\n\
         Camera \"orthographic\" \"float screenwindow\" [ -1 1 -1 1 ] {camera_params}\n\
         Film \"rgb\" \"integer xresolution\" 4 \"integer yresolution\" 4 {film_params}\n\
         PixelFilter \"box\"\n\
         WorldBegin\n\
         LightSource \"infinite\" \"rgb L\" [ 0.3 0.6 0.9 ]\n\
         Material \"diffuse\" \"rgb reflectance\" [ 0.5 0.2 0.7 ]\n\
         Shape \"sphere\" \"float radius\" 0.8\n"
    )
}

fn render(built: &BuiltScene) -> Film {
    let mut spec = built.film.clone();
    spec.wavelengths = WavelengthStrategy::Hero;
    let mut film = Film::new(spec).unwrap();
    built.integrator.render(&built.scene, &mut film, 0..8, 7, &|_| {}).unwrap();
    film
}

#[test]
fn iso_and_shutter_scale_the_image_by_the_imaging_ratio() {
    let base = try_build(&scene("", ""), "sensor.pbrt").unwrap();
    assert_eq!(base.film.sensor.imaging_ratio, 1.0); // pbrt-v4 defaults: 1 s, ISO 100
    let reference = render(&base);
    // ISO 200 → ratio 2; ISO 100 with the shutter open 0.25 s (0.5 to 0.75) → ratio 0.25. Both are powers of two,
    // so the same samples give exactly scaled pixels.
    for (film, camera, k) in [
        ("\"float iso\" 200", "", 2.0),
        ("\"float iso\" 100", "\"float shutteropen\" 0.5 \"float shutterclose\" 0.75", 0.25),
        ("\"float iso\" 400", "\"float shutterclose\" 0.5", 2.0),
    ] {
        let built = try_build(&scene(film, camera), "sensor.pbrt").unwrap();
        assert!(built.warnings.is_empty(), "{:#?}", built.warnings); // the parameters are used
        assert_eq!(built.film.sensor.imaging_ratio, k);
        let scaled = render(&built);
        let (a, b) = (reference.to_rgb_image(), scaled.to_rgb_image());
        assert!(a.iter().any(|p| p[0] > 0.01)); // something was rendered
        for (p, q) in a.iter().zip(&b) {
            for c in 0..3 {
                assert_eq!(p[c] * k as f32, q[c], "{film} {camera}");
            }
        }
    }
}

#[test]
fn white_balance_and_max_component_value_reach_the_film() {
    let built =
        try_build(&scene("\"float whitebalance\" 5000 \"float maxcomponentvalue\" 10", ""), "sensor.pbrt").unwrap();
    assert!(built.warnings.is_empty(), "{:#?}", built.warnings);
    let want = spectral::daylight::white_balance_chromaticity(5000.0).unwrap();
    assert_eq!(built.film.sensor.white_balance_from, Some(want));
    assert_eq!(built.film.max_component_value, 10.0);
    // whitebalance 0 (the cie1931 default) means none; so does leaving it out.
    let none = try_build(&scene("\"float whitebalance\" 0", ""), "sensor.pbrt").unwrap();
    assert_eq!(none.film.sensor.white_balance_from, None);
    assert_eq!(try_build(&scene("", ""), "sensor.pbrt").unwrap().film.max_component_value, f64::INFINITY);
}

#[test]
fn unsupported_sensors_and_bad_values_are_errors_naming_the_parameter() {
    let e = build_error(&scene("\"string sensor\" \"canon_eos_100\"", ""), "sensor.pbrt");
    assert!(e.contains("'sensor'") && e.contains("canon_eos_100") && e.contains("cie1931"), "{e}");
    // The message lists every known sensor.
    for known in ["canon_eos_100d", "canon_eos_5d_mkiv", "hasselblad_l1d_20c", "nikon_d850", "sony_ilce_9"] {
        assert!(e.contains(known), "{e}");
    }
    assert!(e.contains("sensor.pbrt:3:"), "{e}"); // file:line:column of the parameter
    assert!(try_build(&scene("\"string sensor\" \"cie1931\"", ""), "sensor.pbrt").is_ok());
    let e = build_error(&scene("\"string sensor\" \"nikon_d810\" \"float whitebalance\" -5", ""), "sensor.pbrt");
    assert!(e.contains("whitebalance") && e.contains("sensor.pbrt:3:"), "{e}");
    for (film, camera, name) in [
        ("\"float iso\" 0", "", "'iso'"),
        ("\"float iso\" -100", "", "'iso'"),
        ("\"float whitebalance\" -10", "", "whitebalance"),
        ("\"float whitebalance\" 40000", "", "whitebalance"),
        ("\"float maxcomponentvalue\" 0", "", "maxcomponentvalue"),
        ("", "\"float shutteropen\" 1 \"float shutterclose\" 1", "'shutterclose'"),
    ] {
        let e = build_error(&scene(film, camera), "sensor.pbrt");
        assert!(e.contains(name) && e.contains("sensor.pbrt:"), "{film} {camera}: {e}");
    }
}

/// A grey (reflectance 0.5) sphere seen by an orthographic camera under a uniform environment light `light`: the
/// mean output sRGB of the 2×2 pixels at the centre of a 6×6 image.
fn grey_card(film_params: &str, light: &str) -> [f64; 3] {
    let text = format!(
        "LookAt 0 0 -5  0 0 0  0 1 0\n\
         Camera \"orthographic\" \"float screenwindow\" [ -1 1 -1 1 ]\n\
         Film \"rgb\" \"integer xresolution\" 6 \"integer yresolution\" 6 {film_params}\n\
         Sampler \"zsobol\" \"integer pixelsamples\" 256\n\
         PixelFilter \"box\"\n\
         WorldBegin\n\
         LightSource \"infinite\" {light}\n\
         Material \"diffuse\" \"spectrum reflectance\" [ 360 0.5 830 0.5 ]\n\
         Shape \"sphere\" \"float radius\" 3\n"
    );
    let built = try_build(&text, "sensor.pbrt").unwrap();
    assert!(built.warnings.is_empty(), "{:#?}", built.warnings);
    let mut film = Film::new(built.film.clone()).unwrap();
    built.integrator.render(&built.scene, &mut film, 0..built.spp, 7, &|_| {}).unwrap();
    let img = film.to_rgb_image();
    let mut mean = [0.0; 3];
    for (x, y) in [(2, 2), (3, 2), (2, 3), (3, 3)] {
        for c in 0..3 {
            mean[c] += img[y * 6 + x][c] as f64 / 4.0;
        }
    }
    mean
}

#[test]
fn measured_camera_sensors_render_a_grey_card_grey() {
    // A convex grey sphere of reflectance 0.5 under a uniform light of luminance 1 reflects radiance 0.5: in sRGB
    // (0.5, 0.5, 0.5) for a D65 light. A camera sensor is white-balanced for daylight at 6500 K by default (pbrt-v4)
    // and its fitted matrix keeps the luminance, so the card comes out grey at 0.5 — to the fit's residual (about
    // 1.3% of white) and the noise of 256 samples.
    let d65 = "\"spectrum L\" \"stdillum-D65\"";
    for sensor in ["canon_eos_5d_mkiv", "nikon_d850", "sony_ilce_9"] {
        let rgb = grey_card(&format!("\"string sensor\" \"{sensor}\""), d65);
        for c in 0..3 {
            assert!((rgb[c] - 0.5).abs() < 0.02, "{sensor}: {rgb:?}");
        }
    }
    // Under a 3000 K blackbody the cie1931 sensor without white balance sees the card orange; a camera balanced
    // with `whitebalance 3000` (a blackbody at 3000·1.4388/1.4380 K below 4000 K, as pbrt-v4) sees it grey.
    let warm = "\"blackbody L\" 3000";
    let plain = grey_card("", warm);
    assert!(plain[0] - plain[2] > 0.3, "{plain:?}");
    let balanced = grey_card("\"string sensor\" \"canon_eos_5d_mkiv\" \"float whitebalance\" 3000", warm);
    // (The fit's residual at 3000 K is about twice that at 6500 K: measured (0.488, 0.501, 0.485).)
    let mean = balanced.iter().sum::<f64>() / 3.0;
    for c in 0..3 {
        assert!((balanced[c] - mean).abs() < 0.03 * mean, "{balanced:?}");
    }
    assert!((mean - 0.5).abs() < 0.04, "{balanced:?}");
    // The imaging ratio applies to a camera sensor too: ISO 200 doubles the image.
    let iso = grey_card("\"string sensor\" \"canon_eos_5d_mkiv\" \"float iso\" 200", d65);
    let base = grey_card("\"string sensor\" \"canon_eos_5d_mkiv\"", d65);
    for c in 0..3 {
        assert!((iso[c] - 2.0 * base[c]).abs() < 1e-5, "{iso:?} vs {base:?}");
    }
}

//! A distant light with an angular size (Prismatic's `"float angle"`, the sun's 0.53°): it lights a surface as the
//! single direction of the same light does, in every integrator, and a mirror shows its disc at its size.

mod support;

use film::Film;
use render::BuiltScene;
use spectral::WavelengthStrategy;
use support::{build, build_error, image_xyz};

fn render(built: &BuiltScene, seed: u32) -> Film {
    let mut spec = built.film.clone();
    spec.wavelengths = WavelengthStrategy::Hero;
    let mut film = Film::new(spec).unwrap();
    built.integrator.render(&built.scene, &mut film, 0..built.spp, seed, &|_| {}).unwrap();
    film
}

/// A grey floor lit by a low sun (35° up), seen from above by a perspective camera, with `angle` degrees of disc.
fn lit_floor(integrator: &str, angle: f64, spp: u32) -> BuiltScene {
    let text = format!(
        r#"LookAt 0 0 5  0 0 0  0 1 0
Camera "perspective" "float fov" 30
Film "rgb" "integer xresolution" 16 "integer yresolution" 16
PixelFilter "box"
Sampler "zsobol" "integer pixelsamples" {spp}
Integrator {integrator}
WorldBegin
LightSource "distant" "point3 from" [ 0 -0.8192 0.5736 ] "point3 to" [ 0 0 0 ] "blackbody L" 5800 "float angle" {angle}
Material "diffuse" "rgb reflectance" [ 0.5 0.5 0.5 ]
Shape "bilinearmesh" "point3 P" [ -20 -20 0  20 -20 0  -20 20 0  20 20 0 ]
"#
    );
    build(&text, "sun.pbrt")
}

#[test]
fn a_sun_disc_gives_the_irradiance_of_its_single_direction_in_every_integrator() {
    // Irradiance of a disc of radiance L/(π sin²θ) is L·cos of the angle to its centre, exactly, while the disc is
    // above the horizon: the floor looks the same under the 0.53° sun and under its delta direction (and under a
    // 20° disc, whose rim stays above the floor). Each integrator against its own delta render, means of two seeds.
    for integrator in [
        r#""path" "integer maxdepth" 1"#,
        r#""volpath" "integer maxdepth" 1"#,
        r#""bdpt" "integer maxdepth" 1"#,
        r#""lightpath" "integer maxdepth" 1"#,
        r#""sppm" "integer maxdepth" 1 "integer iterations" 64 "float radius" 0.05"#,
    ] {
        let spp = 64;
        let delta = lit_floor(integrator, 0.0, spp);
        let (want, se_want) = image_xyz(&render(&delta, 1), &render(&delta, 2));
        for angle in [0.53, 20.0] {
            let disc = lit_floor(integrator, angle, spp);
            let (got, se) = image_xyz(&render(&disc, 1), &render(&disc, 2));
            let tolerance = 0.003 * want[1] + 4.0 * (se[1] * se[1] + se_want[1] * se_want[1]).sqrt();
            assert!(
                (got[1] - want[1]).abs() < tolerance,
                "{integrator}, {angle}°: Y {} against the delta light's {} (tolerance {tolerance})",
                got[1],
                want[1]
            );
        }
    }
}

#[test]
fn a_mirror_shows_the_sun_disc_at_its_size() {
    // Looking straight down at a horizontal mirror with the sun overhead: the reflected rays escape to the sun, whose
    // disc appears centred, 0.53° across. Its area in pixels is the image's sum over the disc's radiance (the box
    // filter and 16 samples a pixel spread the rim without changing the sum; the radiance is the inner pixels' mean,
    // since each pixel's hero wavelengths make its luminance noisy).
    let scene = |angle: f64| {
        build(
            &format!(
                r#"LookAt 0 0 1  0 0 0  0 1 0
Camera "perspective" "float fov" 2
Film "rgb" "integer xresolution" 101 "integer yresolution" 101
PixelFilter "box"
Sampler "zsobol" "integer pixelsamples" 16
Integrator "path" "integer maxdepth" 1
WorldBegin
LightSource "distant" "point3 from" [ 0 0 1 ] "point3 to" [ 0 0 0 ] "rgb L" [ 1 1 1 ] "float angle" {angle}
Material "conductor" "spectrum eta" [ 360 0 830 0 ] "spectrum k" [ 360 1e6 830 1e6 ] "float roughness" 0
Shape "bilinearmesh" "point3 P" [ -1 -1 0  1 -1 0  -1 1 0  1 1 0 ]
"#
            ),
            "mirror.pbrt",
        )
    };
    let film = render(&scene(0.53), 3);
    let (w, h) = (film.width(), film.height());
    let y: Vec<f64> = (0..h).flat_map(|j| (0..w).map(move |i| (i, j))).map(|(i, j)| film.pixel_xyz(i, j).y).collect();
    // The disc's radiance: the mean over its inner pixels (within 8 px of the centre), each fully inside it.
    let inner: Vec<f64> = (0..h)
        .flat_map(|j| (0..w).map(move |i| (i, j)))
        .filter(|&(i, j)| (i as f64 - 50.0).hypot(j as f64 - 50.0) < 8.0)
        .map(|(i, j)| y[(j * w + i) as usize])
        .collect();
    let peak = inner.iter().sum::<f64>() / inner.len() as f64;
    assert!(peak > 0.0);
    let area: f64 = y.iter().sum::<f64>() / peak;
    // Radius in pixels: tan(0.265°) / tan(1°) of the half-width of 50.5 pixels.
    let r = 0.265f64.to_radians().tan() / 1f64.to_radians().tan() * 50.5;
    let diameter = 2.0 * (area / std::f64::consts::PI).sqrt();
    assert!((diameter - 2.0 * r).abs() < 0.3, "disc {diameter} px across, expected {}", 2.0 * r);
    // The disc is round and centred: the centroid is the image's centre.
    let (mut cx, mut cy) = (0.0, 0.0);
    for j in 0..h {
        for i in 0..w {
            let v = y[(j * w + i) as usize];
            cx += v * (i as f64 + 0.5);
            cy += v * (j as f64 + 0.5);
        }
    }
    let sum: f64 = y.iter().sum();
    assert!((cx / sum - 50.5).abs() < 0.1 && (cy / sum - 50.5).abs() < 0.1, "{} {}", cx / sum, cy / sum);
    // A delta direction is never seen in a mirror.
    let delta = render(&scene(0.0), 3);
    assert!((0..h).all(|j| (0..w).all(|i| delta.pixel_xyz(i, j).y == 0.0)));
}

#[test]
fn a_bad_angle_is_an_error_naming_it() {
    for angle in ["-1", "180", "400"] {
        let e = build_error(
            &format!("WorldBegin\nLightSource \"distant\" \"float angle\" {angle}\nShape \"sphere\"\n"),
            "angle.pbrt",
        );
        assert!(e.contains("angle.pbrt:2:") && e.contains("'angle'"), "{angle}: {e}");
    }
}

//! Region rendering and the film's output parameters: pbrt-v4's `cropwindow` and `pixelbounds` (in the scene and
//! on the command line) render exactly the full render's pixels of the window and write them with the data window
//! inside the full display window; `savefp16` writes half floats; `Film "gbuffer"` writes pbrt-v4's AOV channels;
//! bad values are errors naming the parameter.

use std::path::PathBuf;
use std::process::Command;

use film::{Film, PixelBounds};
use render::{BuildOptions, BuiltScene};

mod support;
use support::{try_build, try_build_with};

/// A 12×8 scene: a glass sphere (dispersive) and a diffuse one on a floor under an area light and a dim sky.
fn scene(film: &str, integrator: &str) -> String {
    format!(
        "LookAt 0 1 -5  0 0.5 0  0 1 0\n\
         Camera \"perspective\" \"float fov\" 45\n\
         Film {film}\n\
         Sampler \"zsobol\" \"integer pixelsamples\" 4\n\
         Integrator {integrator}\n\
         WorldBegin\n\
         LightSource \"infinite\" \"rgb L\" [ 0.2 0.25 0.3 ]\n\
         AttributeBegin\n\
           AreaLightSource \"diffuse\" \"rgb L\" [ 8 8 8 ]\n\
           Translate 0 3 0 Rotate 90 1 0 0\n\
           Shape \"disk\" \"float radius\" 0.8\n\
         AttributeEnd\n\
         Material \"diffuse\" \"rgb reflectance\" [ 0.6 0.5 0.3 ]\n\
         Shape \"trianglemesh\" \"integer indices\" [ 0 1 2 0 2 3 ]\n\
             \"point3 P\" [ -5 0 -5  5 0 -5  5 0 5  -5 0 5 ]\n\
         AttributeBegin\n\
           Translate -0.7 0.6 0\n\
           Material \"dielectric\" \"spectrum eta\" \"glass-BK7\"\n\
           Shape \"sphere\" \"float radius\" 0.6\n\
         AttributeEnd\n\
         AttributeBegin\n\
           Translate 0.8 0.5 0.3\n\
           Shape \"sphere\" \"float radius\" 0.5\n\
         AttributeEnd\n"
    )
}

const RGB_FILM: &str = "\"rgb\" \"integer xresolution\" 12 \"integer yresolution\" 8";
const VOLPATH: &str = "\"volpath\" \"integer maxdepth\" 5";

fn render(built: &BuiltScene) -> Film {
    let mut film = Film::new(built.film.clone()).unwrap();
    built.integrator.render(&built.scene, &mut film, 0..built.spp, 3, &|_| {}).unwrap();
    film
}

/// Asserts that `crop`'s image is, bit for bit, the window `b` of `full`'s image, and its spectra too.
#[track_caller]
fn assert_same_pixels(full: &Film, crop: &Film, b: PixelBounds) {
    assert_eq!(crop.bounds(), b);
    let (fi, ci) = (full.to_rgb_image(), crop.to_rgb_image());
    assert_eq!(ci.len(), (b.width() * b.height()) as usize);
    let mut lit = 0;
    for y in b.y0..b.y1 {
        for x in b.x0..b.x1 {
            let f = fi[(y * full.width() + x) as usize];
            let c = ci[((y - b.y0) * b.width() + x - b.x0) as usize];
            assert_eq!(f.map(f32::to_bits), c.map(f32::to_bits), "pixel ({x}, {y})");
            assert_eq!(full.pixel_spectrum(x, y), crop.pixel_spectrum(x, y), "pixel ({x}, {y})");
            lit += (f[0] > 0.01) as usize;
        }
    }
    assert!(lit > 4, "the window should show the scene");
}

#[test]
fn a_crop_renders_exactly_the_full_renders_pixels() {
    let full = render(&try_build(&scene(RGB_FILM, VOLPATH), "crop.pbrt").unwrap());
    // cropwindow [0.25 0.75 0.3 0.9] of 12×8: columns ⌈3⌉..⌈9⌉, rows ⌈2.4⌉..⌈7.2⌉ (pbrt-v4's rounding).
    let b = PixelBounds { x0: 3, x1: 9, y0: 3, y1: 8 };
    let crop =
        try_build(&scene(&format!("{RGB_FILM} \"float cropwindow\" [ 0.25 0.75 0.3 0.9 ]"), VOLPATH), "crop.pbrt")
            .unwrap();
    assert!(crop.warnings.is_empty(), "{:?}", crop.warnings);
    assert_same_pixels(&full, &render(&crop), b);
    // pixelbounds [x0 x1 y0 y1], and the same window from the command line's options.
    let pb =
        try_build(&scene(&format!("{RGB_FILM} \"integer pixelbounds\" [ 3 9 3 8 ]"), VOLPATH), "crop.pbrt").unwrap();
    assert_same_pixels(&full, &render(&pb), b);
    let cli = BuildOptions { crop_window: Some([0.25, 0.75, 0.3, 0.9]), ..Default::default() };
    assert_same_pixels(&full, &render(&try_build_with(&scene(RGB_FILM, VOLPATH), "crop.pbrt", &cli).unwrap()), b);
    let cli = BuildOptions { pixel_bounds: Some([3, 9, 3, 8]), ..Default::default() };
    assert_same_pixels(&full, &render(&try_build_with(&scene(RGB_FILM, VOLPATH), "crop.pbrt", &cli).unwrap()), b);
    // The spectral film and the path integrator crop the same way.
    let spectral = "\"spectral\" \"integer xresolution\" 12 \"integer yresolution\" 8";
    let full = render(&try_build(&scene(spectral, "\"path\""), "crop.pbrt").unwrap());
    let crop =
        try_build(&scene(&format!("{spectral} \"integer pixelbounds\" [ 0 5 2 6 ]"), "\"path\""), "crop.pbrt").unwrap();
    assert_same_pixels(&full, &render(&crop), PixelBounds { x0: 0, x1: 5, y0: 2, y1: 6 });
}

#[test]
fn command_line_bounds_override_the_films_and_crop_windows_win() {
    let text = scene(&format!("{RGB_FILM} \"integer pixelbounds\" [ 0 4 0 4 ]"), VOLPATH);
    let cli = BuildOptions { pixel_bounds: Some([2, 6, 1, 3]), ..Default::default() };
    let built = try_build_with(&text, "crop.pbrt", &cli).unwrap();
    assert_eq!(built.film.pixel_bounds, Some(PixelBounds { x0: 2, x1: 6, y0: 1, y1: 3 }));
    assert!(built.warnings.iter().any(|w| w.contains("--pixelbounds")), "{:?}", built.warnings);
    // A crop window (film or command line) wins over pixel bounds, as in pbrt-v4.
    let text =
        scene(&format!("{RGB_FILM} \"integer pixelbounds\" [ 0 4 0 4 ] \"float cropwindow\" [ 0.5 1 0.5 1 ]"), VOLPATH);
    let built = try_build(&text, "crop.pbrt").unwrap();
    assert_eq!(built.film.pixel_bounds, Some(PixelBounds { x0: 6, x1: 12, y0: 4, y1: 8 }));
    assert!(built.warnings.iter().any(|w| w.contains("crop window")), "{:?}", built.warnings);
    let cli = BuildOptions { crop_window: Some([0.0, 0.5, 0.0, 0.25]), ..Default::default() };
    assert_eq!(
        try_build_with(&text, "crop.pbrt", &cli).unwrap().film.pixel_bounds,
        Some(PixelBounds { x0: 0, x1: 6, y0: 0, y1: 2 })
    );
    // Pixel bounds beyond the image are clamped with a warning; the whole image means no crop.
    let built =
        try_build(&scene(&format!("{RGB_FILM} \"integer pixelbounds\" [ -2 20 6 9 ]"), VOLPATH), "crop.pbrt").unwrap();
    assert_eq!(built.film.pixel_bounds, Some(PixelBounds { x0: 0, x1: 12, y0: 6, y1: 8 }));
    assert!(built.warnings.iter().any(|w| w.contains("clamped")), "{:?}", built.warnings);
    let whole =
        try_build(&scene(&format!("{RGB_FILM} \"float cropwindow\" [ 0 1 0 1 ]"), VOLPATH), "crop.pbrt").unwrap();
    assert_eq!(whole.film.pixel_bounds, None);
}

#[test]
fn bad_bounds_and_film_values_are_errors_naming_the_parameter() {
    for (extra, name) in [
        ("\"float cropwindow\" [ 0 0.5 0.2 ]", "cropwindow"),
        ("\"float cropwindow\" [ 0 1.5 0 1 ]", "cropwindow"),
        ("\"float cropwindow\" [ -0.1 0.5 0 1 ]", "cropwindow"),
        ("\"float cropwindow\" [ 0.5 0.5 0 1 ]", "cropwindow"),
        ("\"integer pixelbounds\" [ 0 4 0 ]", "pixelbounds"),
        ("\"integer pixelbounds\" [ 4 4 0 8 ]", "pixelbounds"),
        ("\"integer pixelbounds\" [ 20 30 0 8 ]", "pixelbounds"),
        ("\"float diagonal\" 0", "diagonal"),
    ] {
        let e = try_build(&scene(&format!("{RGB_FILM} {extra}"), VOLPATH), "crop.pbrt")
            .err()
            .unwrap_or_else(|| panic!("{extra}"));
        assert!(e.contains(name) && e.contains("crop.pbrt:3:"), "{extra}: {e}");
    }
    let e = try_build(&scene("\"gbuffer\" \"string filename\" \"g.png\"", VOLPATH), "crop.pbrt").err().unwrap();
    assert!(e.contains("gbuffer") && e.contains("EXR"), "{e}");
    let e =
        try_build(&scene("\"gbuffer\" \"string coordinatesystem\" \"screen\"", VOLPATH), "crop.pbrt").err().unwrap();
    assert!(e.contains("coordinatesystem"), "{e}");
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("prismatic-crop-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn cropped_exrs_keep_the_full_display_window_and_savefp16_writes_half_floats() {
    let dir = temp_dir("exr");
    let full = render(&try_build(&scene(RGB_FILM, VOLPATH), "crop.pbrt").unwrap());
    for fp16 in [false, true] {
        let film = format!("{RGB_FILM} \"integer pixelbounds\" [ 2 9 1 7 ] \"bool savefp16\" {fp16}");
        let crop = render(&try_build(&scene(&film, VOLPATH), "crop.pbrt").unwrap());
        let path = dir.join(format!("crop-{fp16}.exr"));
        film::write_image(&crop, &path).unwrap();
        // pbrt-v4: data window = the pixel bounds, display window = the full resolution.
        let layout = film::read_exr_layout(&path).unwrap();
        assert_eq!((layout.data_origin, layout.data_size), ((2, 1), (7, 6)));
        assert_eq!((layout.display_origin, layout.display_size), ((0, 0), (12, 8)));
        assert_eq!(layout.half, fp16);
        let (w, h, pixels) = film::read_exr_rgb(&path).unwrap();
        assert_eq!((w, h), (7, 6));
        let want = full.to_rgb_image();
        for y in 0..6 {
            for x in 0..7 {
                let (got, f) = (pixels[y * 7 + x], want[(y + 1) * 12 + x + 2]);
                for c in 0..3 {
                    // Half floats keep 11 significant bits: relative error at most 2⁻¹¹.
                    let tol = if fp16 { f[c].abs() * 4.9e-4 + 1e-7 } else { 0.0 };
                    assert!((got[c] - f[c]).abs() <= tol, "({x}, {y}) fp16 {fp16}: {got:?} vs {f:?}");
                }
            }
        }
    }
}

#[test]
fn gbuffer_film_writes_pbrt_v4_channel_names_in_camera_space() {
    let dir = temp_dir("gbuffer");
    // Looking down +z at a sphere: its normal at the image centre faces the camera, (0, 0, −1) in pbrt-v4's camera
    // space and (0, 0, −1) in world space too here; with the camera turned, world and camera space differ.
    for (look, system, want) in [
        ("LookAt 0 0 -5  0 0 0  0 1 0", "camera", [0.0, 0.0, -1.0]),
        ("LookAt -5 0 0  0 0 0  0 1 0", "camera", [0.0, 0.0, -1.0]),
        ("LookAt -5 0 0  0 0 0  0 1 0", "world", [-1.0, 0.0, 0.0]),
    ] {
        let path = dir.join(format!("g-{system}.exr"));
        let text = format!(
            "{look}\nCamera \"orthographic\" \"float screenwindow\" [ -1 1 -1 1 ]\n\
             Film \"gbuffer\" \"integer xresolution\" 5 \"integer yresolution\" 5 \"string filename\" \"{}\"\n\
                 \"string coordinatesystem\" \"{system}\"\n\
             Sampler \"zsobol\" \"integer pixelsamples\" 256\nPixelFilter \"box\" \"float xradius\" 0.5 \"float yradius\" 0.5\n\
             WorldBegin\nLightSource \"infinite\" \"rgb L\" [ 1 1 1 ]\n\
             Material \"diffuse\" \"rgb reflectance\" [ 0.2 0.4 0.6 ]\nShape \"sphere\" \"float radius\" 3\n",
            path.display()
        );
        let built = try_build(&text, "crop.pbrt").unwrap();
        assert!(built.warnings.is_empty(), "{:?}", built.warnings);
        let film = render(&built);
        film::write_image(&film, &path).unwrap();
        let aovs = film::read_exr_aovs(&path).unwrap();
        let n = aovs.normal[12];
        for c in 0..3 {
            assert!((n[c] as f64 - want[c]).abs() < 0.02, "{look} {system}: {n:?}");
        }
        // The albedo is the reflectance's colour (sRGB, under the colour space's white; 256 spectral samples).
        let a = aovs.albedo[12];
        assert!((a[0] - 0.2).abs() < 0.03 && (a[1] - 0.4).abs() < 0.03 && (a[2] - 0.6).abs() < 0.03, "{a:?}");
    }
}

#[test]
fn the_command_line_crops_as_pbrt_v4() {
    let dir = temp_dir("cli");
    std::fs::write(dir.join("s.pbrt"), scene(RGB_FILM, VOLPATH)).unwrap();
    let run = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_prismatic")).arg("render").args(args).current_dir(&dir).output().unwrap()
    };
    let out = run(&["s.pbrt", "--quiet", "--cropwindow", "0.25", "0.75", "0.3", "0.9", "-o", "c.exr"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let layout = film::read_exr_layout(&dir.join("c.exr")).unwrap();
    assert_eq!((layout.data_origin, layout.data_size, layout.display_size), ((3, 3), (6, 5), (12, 8)));
    let out = run(&["s.pbrt", "--quiet", "--pixelbounds", "1", "4", "2", "3", "-o", "p.png"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let (w, h, _) = film::read_rgb(&dir.join("p.png")).unwrap();
    assert_eq!((w, h), (3, 1));
    for bad in [["0.25", "1.5", "0", "1"], ["0.5", "0.5", "0", "1"]] {
        let out = run(&["s.pbrt", "--quiet", "--cropwindow", bad[0], bad[1], bad[2], bad[3], "-o", "x.exr"]);
        let e = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && !e.contains("panicked") && e.contains("cropwindow"), "{bad:?}: {e}");
    }
}

#[test]
fn every_pbrt_v4_sampler_name_is_accepted_with_its_sample_count() {
    let with = |sampler: &str| {
        let text = scene(RGB_FILM, VOLPATH).replace("Sampler \"zsobol\" \"integer pixelsamples\" 4", sampler);
        try_build(&text, "crop.pbrt")
    };
    for name in ["zsobol", "halton", "sobol", "paddedsobol", "pmj02bn", "independent"] {
        let built = with(&format!("Sampler \"{name}\" \"integer pixelsamples\" 8")).unwrap();
        assert_eq!(built.spp, 8, "{name}");
        assert!(built.warnings.is_empty(), "{name}: {:?}", built.warnings);
        assert_eq!(with(&format!("Sampler \"{name}\"")).unwrap().spp, 16, "{name}: pbrt-v4's default");
    }
    // stratified: xsamples × ysamples (default 4 × 4), jitter read.
    let built =
        with("Sampler \"stratified\" \"integer xsamples\" 3 \"integer ysamples\" 5 \"bool jitter\" false").unwrap();
    assert_eq!(built.spp, 15);
    assert!(built.warnings.is_empty(), "{:?}", built.warnings);
    assert_eq!(with("Sampler \"stratified\"").unwrap().spp, 16);
    // Unknown names and bad counts are errors naming them.
    let e = with("Sampler \"metropolis\"").err().unwrap();
    assert!(e.contains("metropolis") && e.contains("zsobol") && e.contains("stratified"), "{e}");
    let e = with("Sampler \"stratified\" \"integer xsamples\" 0").err().unwrap();
    assert!(e.contains("xsamples"), "{e}");
    let e = with("Sampler \"halton\" \"integer pixelsamples\" -4").err().unwrap();
    assert!(e.contains("pixelsamples"), "{e}");
}

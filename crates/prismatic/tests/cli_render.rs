//! End-to-end tests of `prismatic render` as a user runs it: the binary on scene files in a temporary directory.
//!
//! - the spectral EXR it writes reads back with the layout's channels and attributes, and holds exactly what an
//!   in-process render of the same scene with the same seed gives;
//! - malformed scenes and bad options are reported as errors (non-zero exit, `file:line:column` for scenes), never
//!   as panics, and leave no output behind;
//! - output files are replaced atomically.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use film::Film;
use render::{build_scene, BuildOptions};
use spectral::WavelengthStrategy;

/// A fresh, empty temporary directory for one test.
fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("prismatic-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs `prismatic render` with `args` in `dir`.
fn prismatic(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_prismatic")).arg("render").args(args).current_dir(dir).output().unwrap()
}

/// The names of the files in `dir`.
fn listing(dir: &Path) -> BTreeSet<String> {
    std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect()
}

fn names(list: &[&str]) -> BTreeSet<String> {
    list.iter().map(|s| s.to_string()).collect()
}

/// Asserts that the run failed with a message and without a panic.
#[track_caller]
fn assert_clean_failure(out: &Output, what: &str) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "{what}: succeeded\n{stderr}");
    assert!(out.status.code().is_some(), "{what}: killed by a signal\n{stderr}");
    assert!(!stderr.contains("panicked"), "{what}: panicked\n{stderr}");
    assert!(!stderr.trim().is_empty(), "{what}: no message");
    stderr
}

/// A small valid scene: a dispersive glass sphere on a diffuse floor under a disk light and a dim environment.
const SMALL_SCENE: &str = r#"# A small test scene
LookAt 0 0.8 -4  0 0.5 0  0 1 0
Camera "perspective" "float fov" 40
Film "spectral" "integer xresolution" 8 "integer yresolution" 8 "integer nbuckets" 16
    "string filename" "from-the-scene.exr"
Sampler "zsobol" "integer pixelsamples" 2
Integrator "path" "integer maxdepth" 5
WorldBegin
LightSource "infinite" "rgb L" [ 0.2 0.25 0.3 ]
AttributeBegin
  AreaLightSource "diffuse" "blackbody L" 4500 "float scale" 5
  Translate 0 3 0
  Rotate 90 1 0 0
  Shape "disk" "float radius" 1
AttributeEnd
AttributeBegin
  Material "diffuse" "rgb reflectance" [ 0.6 0.5 0.3 ]
  Shape "trianglemesh" "point3 P" [ -4 0 -4  4 0 -4  4 0 4  -4 0 4 ] "integer indices" [ 0 2 1 0 3 2 ]
AttributeEnd
AttributeBegin
  Material "dielectric" "string glass" "N-SF11"
  Translate 0 0.6 0
  Shape "sphere" "float radius" 0.6
AttributeEnd
"#;

/// `|a − b|` within a few units in the last place of f32.
fn f32_close(a: f32, b: f32) -> bool {
    (a - b).abs() <= 4.0 * f32::EPSILON * a.abs().max(b.abs()) || (a - b).abs() < f32::MIN_POSITIVE
}

#[test]
fn spectral_exr_round_trip_through_the_cli() {
    let dir = temp_dir("spectral-exr");
    let scene = dir.join("scene.pbrt");
    std::fs::write(&scene, SMALL_SCENE).unwrap();
    let out = dir.join("out.exr");
    // Every override differs from the scene's own setting, and the binary runs on one thread while the
    // in-process render below uses the default pool (two threads on CI).
    let run = prismatic(
        &dir,
        &[
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--spp",
            "4",
            "--seed",
            "7",
            "--resolution",
            "20x12",
            "--wavelengths",
            "rgb",
            "--threads",
            "1",
            "--quiet",
        ],
    );
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    assert!(run.stdout.is_empty(), "--quiet printed {}", String::from_utf8_lossy(&run.stdout));
    // `-o` replaces the film's filename, and nothing else was written.
    assert_eq!(listing(&dir), names(&["out.exr", "scene.pbrt"]));

    // The same render in process.
    let desc = pbrt::parse_file(&scene).unwrap();
    let options =
        BuildOptions { resolution: Some((20, 12)), spp: Some(4), output: Some(out.clone()), ..Default::default() };
    let built = build_scene(&desc, &options).unwrap();
    assert!(built.warnings.is_empty(), "{:?}", built.warnings);
    let mut spec = built.film.clone();
    spec.wavelengths = WavelengthStrategy::Rgb;
    let mut film = Film::new(spec).unwrap();
    built.integrator.render(&built.scene, &mut film, 0..built.spp, 7, &|_| {}).unwrap();

    let image = film::read_exr_spectral(&out).unwrap();
    assert_eq!((image.width, image.height), (20, 12));
    // Channels: one per bucket, named by the bucket centre in the Fichet et al. layout, ascending.
    let centres = built.film.kind.bucket_centres();
    assert_eq!(centres.len(), 16);
    assert_eq!(image.wavelengths_nm.len(), 16);
    for (b, &centre) in centres.iter().enumerate() {
        // Six decimals of the f32 centre are written: 1e-4 nm.
        assert!((image.wavelengths_nm[b] - centre).abs() < 1e-4, "{} vs {centre}", image.wavelengths_nm[b]);
        assert_eq!(image.channel_names[b], film::spectral_channel_name(centre));
    }
    assert_eq!(image.channel_names[0], "S0.374,687500nm"); // 360 + 470/32 nm
    assert_eq!(image.attributes.get("spectralLayoutVersion").map(String::as_str), Some("1.0"));
    assert_eq!(image.attributes.get("emissiveUnits").map(String::as_str), Some("W.m^-2.sr^-1"));
    // Values: the CLI's render is the in-process render, to f32 precision.
    let expected = film.to_spectral_image();
    assert_eq!(image.data.len(), expected.len());
    for (i, (a, b)) in image.data.iter().zip(&expected).enumerate() {
        assert!(f32_close(*a, *b), "value {i} (pixel {}, bucket {}): {a} vs {b}", i / 16, i % 16);
    }
    // Not a vacuous comparison: most pixels have energy, and every bucket of 400–700 nm received some somewhere
    // (at 4 spp a pixel gets at most 12 wavelengths, mostly where the eye is sensitive, so not every bucket of
    // every pixel can).
    let pixels: Vec<&[f32]> = expected.chunks(16).collect();
    assert!(pixels.iter().filter(|p| p.iter().any(|v| *v > 0.0)).count() > pixels.len() * 3 / 4, "mostly black");
    for (b, centre) in centres.iter().enumerate().filter(|(_, &c)| (400.0..700.0).contains(&c)) {
        assert!(pixels.iter().any(|p| p[b] > 0.0), "bucket {centre} nm is empty everywhere");
    }
    // The RGB channels of the same file.
    let (w, h, rgb) = film::read_exr_rgb(&out).unwrap();
    assert_eq!((w, h), (20, 12));
    for (i, (a, b)) in rgb.iter().zip(film.to_rgb_image()).enumerate() {
        assert!((0..3).all(|c| f32_close(a[c], b[c])), "pixel {i}: {a:?} vs {b:?}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn png_and_pfm_follow_the_extension() {
    let dir = temp_dir("formats");
    std::fs::write(dir.join("scene.pbrt"), SMALL_SCENE).unwrap();
    for file in ["a.exr", "b.PFM", "c.png"] {
        let run = prismatic(&dir, &["scene.pbrt", "-o", file, "--seed", "3", "--quiet"]);
        assert!(run.status.success(), "{file}: {}", String::from_utf8_lossy(&run.stderr));
    }
    let (w, h, exr) = film::read_exr_rgb(&dir.join("a.exr")).unwrap();
    assert_eq!((w, h), (8, 8));
    // PFM holds the same f32 RGB as the EXR (same seed).
    let (_, _, pfm) = film::read_pfm(&dir.join("b.PFM")).unwrap();
    assert_eq!(pfm, exr);
    // PNG: 8-bit sRGB with dither, so within one code value of the linear image through the default view.
    let (pw, ph, png) = film::read_png_linear(&dir.join("c.png")).unwrap();
    assert_eq!((pw, ph), (8, 8));
    let srgb = spectral::RgbColorSpace::srgb();
    let view = film::DisplayTransform::new(&srgb, &srgb, film::View::default());
    for (p, e) in png.iter().zip(&exr) {
        let shown = view.apply(*e);
        for c in 0..3 {
            let encode = |v: f64| spectral::color::srgb_encode(v);
            assert!((encode(p[c] as f64) - encode(shown[c])).abs() <= 1.0 / 255.0 + 1e-6, "{p:?} vs {shown:?}");
        }
    }
    assert_eq!(listing(&dir), names(&["a.exr", "b.PFM", "c.png", "scene.pbrt"]));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Malformed scenes, each with the line and column the error must name and a fragment of its message: parser
/// errors (lexical, syntactic, semantic) and errors found while building the scene.
const MALFORMED: &[(&str, u32, u32, &str)] = &[
    ("WorldBegin\n  Shape \"sphere\"\n  Sphere \"x\"\n", 3, 3, "unknown directive 'Sphere'"),
    ("WorldBegin\nShape \"sphere\n", 2, 7, "unterminated string"),
    ("WorldBegin\nShape \"sphere\" \"float radius\" [ 1.2.3 ]\n", 2, 33, "'1.2.3'"),
    ("WorldBegin\nShape \"sphere\" \"float radius\" [ 1\nShape \"disk\"\n", 2, 31, "']'"),
    ("WorldBegin\nAttributeBegin\nAttributeEnd\nAttributeEnd\n", 4, 1, "without a matching AttributeBegin"),
    ("WorldBegin\n\n   Include \"nowhere/x.pbrt\"\n", 3, 4, "nowhere/x.pbrt"),
    ("WorldBegin\nShape \"sphere\" \"float radius\" [ 1 \"two\" ]\n", 2, 35, "expects numbers"),
    ("WorldBegin\nNamedMaterial \"gold\"\nShape \"sphere\"\n", 2, 15, "'gold'"),
    ("WorldBegin\nMaterial \"conductor\" \"spectrum eta\" [ 400 1.5 500 ]\n", 2, 22, "odd"),
    ("WorldBegin\nShape \"sphere\" \"float radius\" nan\n", 2, 31, "'nan'"),
    ("Film \"rgb\"", 1, 6, "end of input before WorldBegin"),
    ("WorldBegin\n  WorldBegin\n", 2, 3, "WorldBegin given twice"),
    // Found by the scene builder.
    ("Integrator \"mlt\"\nWorldBegin\n", 1, 1, "integrator 'mlt' is not supported"),
    ("WorldBegin\nMaterial \"dielectric\" \"string glass\" \"N-XYZ\"\nShape \"sphere\"\n", 2, 23, "N-XYZ"),
    ("Film \"rgb\" \"integer xresolution\" 0\nWorldBegin\n", 1, 12, "xresolution"),
    ("WorldBegin\nShape \"sphere\" \"float zmin\" 0.5 \"float zmax\" 0.2\n", 2, 16, "'zmin'"),
    ("WorldBegin\nShape \"sphere\" \"float zmin\" 2 \"float zmax\" 3\n", 2, 16, "after clamping"),
    ("WorldBegin\nShape \"sphere\" \"float phimax\" 400\n", 2, 16, "'phimax'"),
    ("WorldBegin\nShape \"sphere\" \"float radius\" -1\n", 2, 16, "'radius'"),
    (
        "WorldBegin\nShape \"bilinearmesh\" \"point3 P\" [ 0 0 0 1 0 0 0 1 0 1 1 0 ] \"integer indices\" [ 0 1 2 ]\n",
        2,
        1,
        "not a multiple of 4",
    ),
    ("WorldBegin\nShape \"bilinearmesh\" \"point3 P\" [ 0 0 0 1 0 0 0 1 0 ]\n", 2, 1, "exactly 4 vertices"),
];

#[test]
fn malformed_scenes_name_file_line_and_column() {
    let dir = temp_dir("malformed");
    for (k, &(text, line, column, needle)) in MALFORMED.iter().enumerate() {
        let scene = dir.join(format!("bad{k}.pbrt"));
        std::fs::write(&scene, text).unwrap();
        let run = prismatic(&dir, &[scene.to_str().unwrap(), "-o", "out.exr", "--quiet"]);
        let stderr = assert_clean_failure(&run, text);
        assert_eq!(run.status.code(), Some(3), "{text:?}: a scene error's status\n{stderr}");
        let at = format!("{}:{line}:{column}: error", scene.display());
        assert!(stderr.contains(&at), "{text:?}: expected '{at}' in\n{stderr}");
        assert!(stderr.contains(needle), "{text:?}: expected '{needle}' in\n{stderr}");
        assert!(!dir.join("out.exr").exists(), "{text:?}: an image was written");
    }
    // A scene file that does not exist is named too.
    let run = prismatic(&dir, &["missing.pbrt", "--quiet"]);
    let stderr = assert_clean_failure(&run, "missing scene");
    assert!(stderr.contains("missing.pbrt"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The exit status says what failed (README.md, "Exit status"), from the error's type: 3 for an error in the scene
/// (found by the parser or the builder, or in a file the scene references), 4 for a file that cannot be read or
/// written (the scene file itself, the output and its directory), 2 for a command line that cannot be parsed, 1 for
/// anything else; a render stopped by SIGINT exits with 130.
#[test]
fn exit_status_says_what_failed() {
    let dir = temp_dir("exit-status");
    std::fs::write(dir.join("scene.pbrt"), SMALL_SCENE).unwrap();
    let scenes = [
        ("syntax.pbrt", "WorldBegin\nShape \"sphere\" \"float radius\" [ 1\nShape \"disk\"\n"),
        ("builder.pbrt", "Integrator \"mlt\"\nWorldBegin\n"),
        ("mesh.pbrt", "WorldBegin\nShape \"plymesh\" \"string filename\" \"nowhere.ply\"\n"),
    ];
    for (name, text) in scenes {
        std::fs::write(dir.join(name), text).unwrap();
    }
    std::fs::create_dir(dir.join("taken.exr")).unwrap();
    let cases: &[(&[&str], i32, &str)] = &[
        (&["syntax.pbrt", "-o", "out.exr"], 3, "syntax.pbrt:2:31: error"),
        (&["builder.pbrt", "-o", "out.exr"], 3, "builder.pbrt:1:1: error: integrator 'mlt'"),
        (&["mesh.pbrt", "-o", "out.exr"], 3, "nowhere.ply"),
        (&["missing.pbrt", "-o", "out.exr"], 4, "missing.pbrt"),
        (&["scene.pbrt", "-o", "no/such/dir/out.exr"], 4, "no/such/dir does not exist"),
        // The output path is a directory: found when the rendered image is written.
        (&["scene.pbrt", "-o", "taken.exr"], 4, "cannot write"),
        (&["scene.pbrt", "--no-such-option"], 2, "--no-such-option"),
        (&["scene.pbrt", "--spp", "0"], 1, "--spp"),
        (&["scene.pbrt", "-o", "out.jpg"], 1, "jpg"),
    ];
    for &(args, code, needle) in cases {
        let mut all = args.to_vec();
        all.push("--quiet");
        let run = prismatic(&dir, &all);
        let stderr = assert_clean_failure(&run, &format!("{args:?}"));
        assert_eq!(run.status.code(), Some(code), "{args:?}\n{stderr}");
        assert!(stderr.contains(needle), "{args:?}: expected '{needle}' in\n{stderr}");
        assert!(!dir.join("out.exr").exists(), "{args:?}: an image was written");
    }
    #[cfg(unix)]
    {
        let run = render_then_signal(&dir, &["scene.pbrt", "--spp", "10000000", "-o", "stopped.exr"], &["INT"]);
        assert_eq!(run.status.code(), Some(130), "{}", String::from_utf8_lossy(&run.stderr));
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_options_are_errors_not_panics() {
    let dir = temp_dir("options");
    std::fs::write(dir.join("scene.pbrt"), SMALL_SCENE).unwrap();
    let cases: &[(&[&str], &str)] = &[
        (&["--time", "NaN"], "--time"),
        (&["--time", "inf"], "--time"),
        (&["--time=-1"], "--time"),
        (&["--time", "0"], "--time"),
        (&["--spp", "0"], "--spp"),
        (&["--spp", "many"], "--spp"),
        (&["--resolution", "0x10"], "resolution"),
        (&["--resolution", "640"], "resolution"),
        (&["--resolution", "axb"], "resolution"),
        (&["--resolution", "10x-1"], "resolution"),
        (&["--threads", "0"], "--threads"),
        (&["--wavelengths", "spectral"], "wavelength"),
        (&["--seed", "-3"], "-3"),
    ];
    for (args, needle) in cases {
        let mut all = vec!["scene.pbrt", "-o", "out.exr", "--quiet"];
        all.extend_from_slice(args);
        let run = prismatic(&dir, &all);
        let stderr = assert_clean_failure(&run, &format!("{args:?}"));
        assert!(stderr.contains(needle), "{args:?}: expected '{needle}' in\n{stderr}");
        assert_eq!(listing(&dir), names(&["scene.pbrt"]), "{args:?} left files behind");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn unsupported_extension_and_missing_directory_leave_nothing_behind() {
    let dir = temp_dir("extension");
    std::fs::write(dir.join("scene.pbrt"), SMALL_SCENE).unwrap();
    let run = prismatic(&dir, &["scene.pbrt", "-o", "out.jpg", "--quiet"]);
    let stderr = assert_clean_failure(&run, ".jpg");
    assert!(stderr.contains("jpg") && stderr.contains("exr, png, pfm"), "{stderr}");
    // No image and no temporary file.
    assert_eq!(listing(&dir), names(&["scene.pbrt"]));

    let run = prismatic(&dir, &["scene.pbrt", "-o", "no/such/dir/out.exr", "--quiet"]);
    let stderr = assert_clean_failure(&run, "missing directory");
    assert!(stderr.contains("out.exr"), "{stderr}");
    assert_eq!(listing(&dir), names(&["scene.pbrt"]));
    let _ = std::fs::remove_dir_all(&dir);
}

#[cfg(unix)]
#[test]
fn existing_output_is_replaced_atomically() {
    use std::io::Read;
    use std::os::unix::fs::MetadataExt;

    let dir = temp_dir("atomic");
    std::fs::write(dir.join("scene.pbrt"), SMALL_SCENE).unwrap();
    let out = dir.join("out.exr");
    let first = prismatic(&dir, &["scene.pbrt", "-o", "out.exr", "--seed", "1", "--quiet"]);
    assert!(first.status.success(), "{}", String::from_utf8_lossy(&first.stderr));
    let old_bytes = std::fs::read(&out).unwrap();
    let old_inode = std::fs::metadata(&out).unwrap().ino();
    // A reader that opened the old image before it was replaced.
    let mut reader = std::fs::File::open(&out).unwrap();

    // Write again (another seed, so the content differs), this time with the summary printed.
    let second = prismatic(&dir, &["scene.pbrt", "-o", "out.exr", "--seed", "2"]);
    assert!(second.status.success(), "{}", String::from_utf8_lossy(&second.stderr));
    let summary = String::from_utf8_lossy(&second.stdout);
    assert!(summary.contains("wrote out.exr") && summary.contains("Mrays/s"), "{summary}");

    let new_bytes = std::fs::read(&out).unwrap();
    assert_ne!(new_bytes, old_bytes, "the second render did not replace the image");
    film::read_exr_rgb(&out).unwrap();
    // Replaced by renaming a complete new file over it, not rewritten in place: the path names a new inode, and the
    // reader that held the old file still reads the whole old image.
    assert_ne!(std::fs::metadata(&out).unwrap().ino(), old_inode);
    let mut seen = vec![];
    reader.read_to_end(&mut seen).unwrap();
    assert_eq!(seen, old_bytes);
    // No temporary file is left.
    assert_eq!(listing(&dir), names(&["out.exr", "scene.pbrt"]));
    let _ = std::fs::remove_dir_all(&dir);
}

/// `--time` renders in passes that continue each pixel's sample sequence (for `sppm`, the progressive photon map's
/// iterations), so the result equals a single render of the same number of samples (iterations).
#[test]
fn time_budget_renders_progressively_like_a_fixed_spp_render() {
    for (integrator, unit) in [("path", "spp"), ("sppm", "iterations")] {
        let dir = temp_dir(&format!("time-{integrator}"));
        let scene = SMALL_SCENE.replace(
            r#"Integrator "path" "integer maxdepth" 5"#,
            &format!(r#"Integrator "{integrator}" "integer maxdepth" 5"#),
        );
        std::fs::write(dir.join("scene.pbrt"), scene).unwrap();
        let run = prismatic(&dir, &["scene.pbrt", "-o", "timed.exr", "--time", "0.3", "--seed", "5"]);
        assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
        // "wrote timed.exr (8x8, N spp, hero wavelengths, path)"
        let summary = String::from_utf8_lossy(&run.stdout);
        let spp: u32 = summary
            .split_once("8x8, ")
            .and_then(|(_, rest)| rest.split_once(&format!(" {unit}")))
            .and_then(|(n, _)| n.parse().ok())
            .unwrap_or_else(|| panic!("no {unit} in {summary}"));
        assert!(spp >= 1, "{summary}");
        let fixed =
            prismatic(&dir, &["scene.pbrt", "-o", "fixed.exr", "--spp", &spp.to_string(), "--seed", "5", "--quiet"]);
        assert!(fixed.status.success(), "{}", String::from_utf8_lossy(&fixed.stderr));
        let timed = film::read_exr_spectral(&dir.join("timed.exr")).unwrap();
        let fixed = film::read_exr_spectral(&dir.join("fixed.exr")).unwrap();
        for (i, (a, b)) in timed.data.iter().zip(&fixed.data).enumerate() {
            assert!(f32_close(*a, *b), "{integrator}: value {i}: {a} vs {b} ({spp} {unit})");
        }
        assert!(timed.data.iter().any(|v| *v > 0.0));
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// Finite but huge numbers must not overflow into a panic: they are errors or render normally.
#[test]
fn huge_numbers_are_errors_not_panics() {
    let dir = temp_dir("huge");
    std::fs::write(dir.join("scene.pbrt"), SMALL_SCENE).unwrap();
    let run = prismatic(&dir, &["scene.pbrt", "-o", "out.exr", "--quiet", "--time", "1e300"]);
    assert_clean_failure(&run, "--time 1e300");
    // A light whose emission overflows f32 is an error at its line.
    let scene = dir.join("huge0.pbrt");
    std::fs::write(&scene, "WorldBegin\nLightSource \"point\" \"float scale\" 1e300\n").unwrap();
    let run = prismatic(&dir, &[scene.to_str().unwrap(), "-o", "out.exr", "--quiet"]);
    let stderr = assert_clean_failure(&run, "scale 1e300");
    assert!(stderr.contains(&format!("{}:2:", scene.display())), "{stderr}");
    // A huge (but representable) scene around an environment light renders: its light power is computed in f64.
    let scene = dir.join("huge1.pbrt");
    std::fs::write(
        &scene,
        "WorldBegin\nLightSource \"infinite\" \"rgb L\" [ 1 1 1 ]\nShape \"sphere\" \"float radius\" 1e19\n",
    )
    .unwrap();
    let run =
        prismatic(&dir, &[scene.to_str().unwrap(), "-o", "out.exr", "--quiet", "--resolution", "4x4", "--spp", "1"]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success() && !stderr.contains("panicked"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `--aovs` writes the first hit's albedo and normal: a diffuse quad of known reflectance facing the camera gives
/// that reflectance back and its normal. The albedo is a Monte Carlo estimate over the sampled wavelengths: at 256
/// spp its per-pixel rms error was 0.0005 when this test was written; 0.005 leaves room for the uplifting's
/// round-trip error (< 0.001) and is still far below what a wrong colour conversion would give.
#[test]
fn aovs_record_albedo_and_normal_of_the_first_hit() {
    let dir = temp_dir("aovs");
    let scene = r#"LookAt 0 0 -5  0 0 0  0 1 0
Camera "perspective" "float fov" 20
Film "rgb" "integer xresolution" 8 "integer yresolution" 8 "string filename" "x.exr"
WorldBegin
LightSource "infinite" "rgb L" [1 1 1]
Material "diffuse" "rgb reflectance" [0.2 0.5 0.8]
Shape "trianglemesh" "integer indices" [0 1 2 0 2 3] "point3 P" [-5 -5 0  5 -5 0  5 5 0  -5 5 0]
"#;
    std::fs::write(dir.join("aov.pbrt"), scene).unwrap();
    let run = prismatic(&dir, &["aov.pbrt", "--aovs", "--spp", "256", "--quiet", "-o", "aov.exr"]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let aov = film::read_exr_aovs(&dir.join("aov.exr")).unwrap();
    assert_eq!(aov.albedo.len(), 64);
    for (a, n) in aov.albedo.iter().zip(&aov.normal) {
        for (got, want) in a.iter().zip([0.2f32, 0.5, 0.8]) {
            assert!((got - want).abs() < 0.005, "albedo {a:?}");
        }
        // The quad's normal, (0, 0, ±1) by its winding; it must be a unit vector along z.
        assert!(n[0].abs() < 1e-5 && n[1].abs() < 1e-5 && (n[2].abs() - 1.0).abs() < 1e-5, "normal {n:?}");
    }
    // AOVs need EXR.
    let run = prismatic(&dir, &["aov.pbrt", "--aovs", "--quiet", "-o", "aov.png"]);
    assert_clean_failure(&run, "--aovs with png");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Starts `prismatic render` with `args` in `dir`, waits until it has rendered for a while (its output's temporary
/// file cannot tell, so: a fixed second and a half, far more than this tiny scene needs to start), then sends
/// `signals` (names for kill(1)) in a row and returns what it did.
#[cfg(unix)]
fn render_then_signal(dir: &Path, args: &[&str], signals: &[&str]) -> Output {
    let child = Command::new(env!("CARGO_BIN_EXE_prismatic"))
        .arg("render")
        .args(args)
        .current_dir(dir)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(1500));
    for sig in signals {
        let sent = Command::new("kill").args(["-s", sig, &child.id().to_string()]).status().unwrap();
        assert!(sent.success(), "kill -s {sig}");
    }
    child.wait_with_output().unwrap()
}

/// SIGINT and SIGTERM stop a render at the next pass boundary: the image of the samples done so far is written,
/// its EXR header says how many, stderr says so too, and the exit status is 128 + the signal. The image is exactly
/// (bit for bit) a render of that many samples, so no partial pass got in.
#[cfg(unix)]
#[test]
fn a_signal_stops_the_render_and_keeps_the_samples_done() {
    let dir = temp_dir("signal");
    std::fs::write(dir.join("scene.pbrt"), SMALL_SCENE).unwrap();
    for (sig, code) in [("INT", 130), ("TERM", 143)] {
        let out = format!("stopped-{sig}.exr");
        let run = render_then_signal(&dir, &["scene.pbrt", "--spp", "10000000", "-o", &out], &[sig]);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(code), "SIG{sig}: {stderr}");
        assert!(
            stderr.contains(&format!("interrupted by SIG{sig} after ")) && !stderr.contains("panicked"),
            "{stderr}"
        );
        let header = film::read_exr_text_attributes(&dir.join(&out)).unwrap();
        let spp: u32 = header["samplesPerPixel"].parse().unwrap();
        assert!(spp > 0 && spp < 10_000_000, "{header:?}");
        assert_eq!(header["samplesPerPixelRequested"], "10000000");
        assert_eq!(header["interruptedBy"], format!("SIG{sig}"));
        assert!(stderr.contains(&format!("after {spp} of 10000000 spp")), "{stderr}");
        // The same samples rendered without interruption.
        let whole = prismatic(&dir, &["scene.pbrt", "--spp", &spp.to_string(), "-o", "whole.exr", "--quiet"]);
        assert!(whole.status.success(), "{}", String::from_utf8_lossy(&whole.stderr));
        let (a, b) =
            (film::read_exr_rgb(&dir.join(&out)).unwrap(), film::read_exr_rgb(&dir.join("whole.exr")).unwrap());
        assert!(a.2.iter().zip(&b.2).all(|(p, q)| p.map(f32::to_bits) == q.map(f32::to_bits)), "SIG{sig}");
        assert!(!listing(&dir).iter().any(|n| n.contains(".tmp")), "{:?}", listing(&dir));
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A second signal ends the process at once (status 130), and an existing output file is never left half-written:
/// it is either the old file or a complete new one.
#[cfg(unix)]
#[test]
fn a_second_signal_exits_at_once_without_corrupting_the_output() {
    let dir = temp_dir("signal2");
    std::fs::write(dir.join("scene.pbrt"), SMALL_SCENE).unwrap();
    let first = prismatic(&dir, &["scene.pbrt", "-o", "out.exr", "--quiet"]);
    assert!(first.status.success());
    let before = std::fs::read(dir.join("out.exr")).unwrap();
    let run = render_then_signal(&dir, &["scene.pbrt", "--spp", "10000000", "-o", "out.exr"], &["INT", "INT"]);
    assert_eq!(run.status.code(), Some(130), "{}", String::from_utf8_lossy(&run.stderr));
    let after = std::fs::read(dir.join("out.exr")).unwrap();
    if after != before {
        // The first signal's image got written before the second arrived: it must be whole.
        let header = film::read_exr_text_attributes(&dir.join("out.exr")).unwrap();
        assert_eq!(header["interruptedBy"], "SIGINT");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

//! The display image as a user gets it: `--view`, `--colorspace`, the film's `view` and `colorspace`, and
//! `prismatic convert`, run as the binary.

use std::path::{Path, PathBuf};

use spectral::RgbColorSpace;

mod support;
use support::{ok, prismatic};

fn temp_dir(name: &str) -> PathBuf {
    support::temp_dir("display", name)
}

/// A camera looking into a uniform sky of an orange sRGB colour inside every gamut (and, with `film_extra`, more
/// film parameters).
fn sky_scene(film_extra: &str) -> String {
    format!(
        r#"LookAt 0 0 0  0 0 1  0 1 0
Camera "perspective" "float fov" 30
Film "rgb" "integer xresolution" 6 "integer yresolution" 4 "string filename" "sky.png" {film_extra}
Sampler "independent" "integer pixelsamples" 4
Integrator "path"
WorldBegin
LightSource "infinite" "rgb L" [ 0.45 0.2 0.08 ]
"#
    )
}

/// The PNG's chunks in order: (type, payload).
fn png_chunks(bytes: &[u8]) -> Vec<([u8; 4], Vec<u8>)> {
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    let mut at = 8;
    let mut out = Vec::new();
    while at + 8 <= bytes.len() {
        let len = u32::from_be_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
        let kind: [u8; 4] = bytes[at + 4..at + 8].try_into().unwrap();
        out.push((kind, bytes[at + 8..at + 8 + len].to_vec()));
        at += 12 + len;
    }
    out
}

/// The mean XYZ of a PNG's pixels, decoded with the sRGB curve and `space`'s matrix.
fn png_mean_xyz(path: &Path, space: &RgbColorSpace) -> [f64; 3] {
    let decoder = png::Decoder::new(std::fs::File::open(path).unwrap());
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    let px: Vec<[f64; 3]> = buf[..info.buffer_size()]
        .chunks(3)
        .map(|c| [0, 1, 2].map(|i| spectral::color::srgb_decode(c[i] as f64 / 255.0)))
        .collect();
    let n = px.len() as f64;
    let mean = [0, 1, 2].map(|i| px.iter().map(|p| p[i]).sum::<f64>() / n);
    space.to_xyz(mean).to_array()
}

/// Display P3 and Rec. 2020 PNGs carry cICP (before the image data) and an ICC profile, and decoded with their
/// own primaries they show the colour the sRGB PNG shows (to 8-bit quantisation); the EXR carries the chosen
/// chromaticities.
#[test]
fn wide_gamut_pngs_are_tagged_and_show_the_same_colour() {
    let dir = temp_dir("gamut");
    std::fs::write(dir.join("sky.pbrt"), sky_scene("")).unwrap();
    ok(prismatic(&dir, &["render", "sky.pbrt", "-o", "srgb.png", "--quiet"]));
    let reference = png_mean_xyz(&dir.join("srgb.png"), &RgbColorSpace::srgb());
    let srgb_chunks = png_chunks(&std::fs::read(dir.join("srgb.png")).unwrap());
    assert!(srgb_chunks.iter().any(|(k, _)| k == b"sRGB"));
    assert!(!srgb_chunks.iter().any(|(k, _)| k == b"cICP" || k == b"iCCP"));
    for (name, primaries) in [("dci-p3", 12u8), ("rec2020", 9u8)] {
        let png = format!("{name}.png");
        ok(prismatic(&dir, &["render", "sky.pbrt", "-o", &png, "--colorspace", name, "--quiet"]));
        let chunks = png_chunks(&std::fs::read(dir.join(&png)).unwrap());
        let kinds: Vec<&[u8; 4]> = chunks.iter().map(|(k, _)| k).collect();
        let cicp = kinds.iter().position(|k| *k == b"cICP").expect("a cICP chunk");
        let idat = kinds.iter().position(|k| *k == b"IDAT").unwrap();
        assert!(cicp < idat, "{name}: cICP after the image data");
        assert_eq!(chunks[cicp].1, vec![primaries, 13, 0, 1], "{name}");
        assert!(kinds.contains(&b"iCCP") && !kinds.contains(&b"sRGB"), "{name}: {kinds:?}");
        let space = RgbColorSpace::by_name(name).unwrap();
        let xyz = png_mean_xyz(&dir.join(&png), &space);
        for c in 0..3 {
            assert!((xyz[c] / reference[c] - 1.0).abs() < 0.03, "{name}: XYZ {xyz:?} vs sRGB's {reference:?}");
        }
        // The raw values differ: the P3 and Rec. 2020 images are not sRGB images with another label.
        let raw = png_mean_xyz(&dir.join(&png), &RgbColorSpace::srgb());
        let far = (0..3).map(|c| (raw[c] / reference[c] - 1.0).abs()).fold(0.0, f64::max);
        assert!(far > 0.1, "{name}: the values of the sRGB image ({raw:?} vs {reference:?})");
        let exr = format!("{name}.exr");
        ok(prismatic(&dir, &["render", "sky.pbrt", "-o", &exr, "--colorspace", name, "--quiet"]));
        assert_eq!(film::read_exr_color_space(&dir.join(&exr)).unwrap().name, name);
    }
}

/// `prismatic convert` of a render's EXR writes the very PNG the render writes, for both views; the film's own
/// `"string view"` and `"string colorspace"` act as the options do.
#[test]
fn convert_writes_what_render_writes_and_film_parameters_act_as_options() {
    let dir = temp_dir("convert");
    std::fs::write(dir.join("sky.pbrt"), sky_scene("")).unwrap();
    for view in ["oklab", "clip"] {
        let (png, exr, conv) = (format!("r-{view}.png"), format!("r-{view}.exr"), format!("c-{view}.png"));
        ok(prismatic(&dir, &["render", "sky.pbrt", "-o", &png, "--view", view, "--quiet"]));
        ok(prismatic(&dir, &["render", "sky.pbrt", "-o", &exr, "--quiet"]));
        ok(prismatic(&dir, &["convert", &exr, "-o", &conv, "--view", view]));
        assert_eq!(std::fs::read(dir.join(&png)).unwrap(), std::fs::read(dir.join(&conv)).unwrap(), "{view}");
    }
    std::fs::write(dir.join("p3.pbrt"), sky_scene(r#""string colorspace" "dci-p3" "string view" "clip""#)).unwrap();
    ok(prismatic(&dir, &["render", "p3.pbrt", "-o", "film.png", "--quiet"]));
    ok(prismatic(&dir, &["render", "sky.pbrt", "-o", "opts.png", "--colorspace", "p3", "--view", "clip", "--quiet"]));
    assert_eq!(std::fs::read(dir.join("film.png")).unwrap(), std::fs::read(dir.join("opts.png")).unwrap());
}

/// Unknown names are errors that list the valid ones: on the command line (usage, status 2) and in the scene
/// (status 3, at the parameter's file:line:column).
#[test]
fn unknown_views_and_colour_spaces_name_the_valid_ones() {
    let dir = temp_dir("bad");
    std::fs::write(dir.join("sky.pbrt"), sky_scene("")).unwrap();
    let out = prismatic(&dir, &["render", "sky.pbrt", "-o", "a.png", "--view", "agx"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("unknown view 'agx'") && err.contains("oklab, clip"), "{err}");
    let out = prismatic(&dir, &["render", "sky.pbrt", "-o", "a.png", "--colorspace", "adobe"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("srgb, dci-p3, rec2020, aces2065-1"), "{err}");
    std::fs::write(dir.join("bad.pbrt"), sky_scene(r#""string view" "filmic""#)).unwrap();
    let out = prismatic(&dir, &["render", "bad.pbrt", "-o", "a.png", "--quiet"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(3), "{err}");
    assert!(
        err.contains("bad.pbrt:3:") && err.contains("'view' \"filmic\" is not one of \"oklab\", \"clip\""),
        "{err}"
    );
    let out = prismatic(&dir, &["convert", "missing.exr", "-o", "a.png"]);
    assert!(!out.status.success() && !String::from_utf8_lossy(&out.stderr).contains("panicked"));
    assert!(!dir.join("a.png").exists());
}

//! `Material "measured"` end to end (scene file → `build_scene` → integrator → film): an RGL tensor file written by
//! the render crate's test writer from a rough GGX conductor renders as pbrt-v4's `conductor` material with the same
//! η, k and roughness does; file names resolve against the scene file's directory; bad parameters and bad files
//! are errors naming the parameter, the file and the place in the scene.

#[path = "../../render/src/tests/support/rgl.rs"]
mod rgl;

use std::path::{Path, PathBuf};

use film::Film;
use render::internals::Warp2D;
use render::{build_scene, BuildOptions, BuiltScene};
use rgl::{Facet, Ggx, Resolution};

mod support;

/// Allowed distance between two renders' means, in standard errors of the difference (fixed seeds: never flakes).
const K_SIGMA: f64 = 4.5;

/// η and k of a made-up metal whose colour varies, as (λ, value) pairs over the whole visible range.
const ETA: [(f64, f64); 6] = [(360.0, 1.5), (450.0, 1.2), (520.0, 0.9), (600.0, 0.5), (700.0, 0.3), (830.0, 0.25)];
const K: [(f64, f64); 6] = [(360.0, 2.0), (450.0, 2.3), (520.0, 2.6), (600.0, 3.0), (700.0, 3.8), (830.0, 5.0)];

fn lerp_pairs(pairs: &[(f64, f64)], l: f64) -> f64 {
    let i = pairs.windows(2).position(|w| l >= w[0].0 && l <= w[1].0).unwrap();
    let (a, b) = (pairs[i], pairs[i + 1]);
    a.1 + (b.1 - a.1) * (l - a.0) / (b.0 - a.0)
}

fn pbrt_pairs(pairs: &[(f64, f64)]) -> String {
    let inner: Vec<String> = pairs.iter().map(|(l, v)| format!("{l} {v}")).collect();
    format!("[ {} ]", inner.join("  "))
}

/// A fresh directory for this test's files.
fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("prismatic-measured-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The conductor tabulated every 10 nm (so that interpolating F between wavelengths costs less than 0.1%).
fn conductor_file(dir: &Path) -> PathBuf {
    let wavelengths: Vec<f32> = (0..48).map(|i| 360.0 + 10.0 * i as f32).collect();
    let eta = wavelengths.iter().map(|&l| lerp_pairs(&ETA, l as f64)).collect();
    let k = wavelengths.iter().map(|&l| lerp_pairs(&K, l as f64)).collect();
    let model = Ggx { alpha: 0.3, wavelengths, facet: Facet::Conductor { eta, k } };
    let path = dir.join("ggx-conductor.bsdf");
    std::fs::write(&path, model.file(Resolution::FINE)).unwrap();
    path
}

/// A unit sphere of `material` seen from 5 units away through a 24° lens (it fills the 12 × 12 image), in a uniform
/// environment and under a small bright sphere light up and to the right (a glossy highlight).
fn sphere_scene(integrator: &str, material: &str) -> String {
    format!(
        r#"LookAt 0 0 5  0 0 0  0 1 0
Camera "perspective" "float fov" 24
Film "rgb" "integer xresolution" 12 "integer yresolution" 12 "string filename" "measured.exr"
PixelFilter "box"
Integrator "{integrator}" "integer maxdepth" 3
WorldBegin
LightSource "infinite" "spectrum L" [ 360 0.5  830 0.5 ]
AttributeBegin
Material "diffuse" "rgb reflectance" [ 0 0 0 ]
AreaLightSource "diffuse" "spectrum L" [ 360 20  830 20 ]
Translate 2 2 4
Shape "sphere" "float radius" 0.3
AttributeEnd
AttributeBegin
{material}
Shape "sphere" "float radius" 1
AttributeEnd
"#
    )
}

fn build_file(path: &Path) -> BuiltScene {
    let desc = pbrt::parse_file(path).unwrap_or_else(|e| panic!("{e}"));
    let built = build_scene(&desc, &BuildOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert!(built.warnings.is_empty(), "{:#?}", built.warnings);
    built
}

fn render(built: &BuiltScene, spp: u32, seed: u32) -> Film {
    let mut film = Film::new(built.film.clone()).unwrap();
    built.integrator.render(&built.scene, &mut film, 0..spp, seed, &|_| {}).unwrap();
    film
}

/// [`support::image_xyz`] of two renders of `built` with seeds 1 and 2.
fn image_xyz(built: &BuiltScene, spp: u32) -> ([f64; 3], [f64; 3]) {
    support::image_xyz(&render(built, spp, 1), &render(built, spp, 2))
}

/// The measured file renders as the conductor it tabulates, through the camera-path integrators and BDPT: each XYZ
/// component of the image's mean within 4.5 standard errors of the difference plus 0.5% (the tables' interpolation:
/// 0.1% on average over directions, up to a few per cent at grazing angles).
#[test]
fn a_measured_conductor_renders_as_the_conductor_material() {
    let dir = temp_dir("render");
    let file = conductor_file(&dir);
    let conductor = format!(
        r#"Material "conductor" "spectrum eta" {} "spectrum k" {} "float roughness" 0.3 "bool remaproughness" false"#,
        pbrt_pairs(&ETA),
        pbrt_pairs(&K)
    );
    // A relative name, resolved against the scene file's directory (not the working directory).
    let measured =
        format!(r#"Material "measured" "string filename" "{}""#, file.file_name().unwrap().to_str().unwrap());
    for (integrator, spp) in [("path", 64), ("volpath", 64), ("bdpt", 32)] {
        let mut means = vec![];
        for (name, material) in [("conductor", &conductor), ("measured", &measured)] {
            let scene = dir.join(format!("{name}-{integrator}.pbrt"));
            std::fs::write(&scene, sphere_scene(integrator, material)).unwrap();
            means.push(image_xyz(&build_file(&scene), spp));
        }
        let ((a, sa), (b, sb)) = (means[0], means[1]);
        for c in 0..3 {
            let se = (sa[c] * sa[c] + sb[c] * sb[c]).sqrt();
            eprintln!(
                "{integrator}, XYZ[{c}]: conductor {:.5} ± {:.5}, measured {:.5} ± {:.5} ({:+.2}σ)",
                a[c],
                sa[c],
                b[c],
                sb[c],
                (b[c] - a[c]) / se
            );
            assert!(se < 0.01 * a[c], "{integrator}: too noisy ({se} for {})", a[c]);
            assert!((a[c] - b[c]).abs() <= K_SIGMA * se + 0.005 * a[c], "{integrator}, XYZ[{c}]: {a:?} vs {b:?}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

fn build_error(dir: &Path, text: &str) -> String {
    let path = dir.join("bad.pbrt");
    std::fs::write(&path, text).unwrap();
    let desc = pbrt::parse_file(&path).unwrap_or_else(|e| panic!("{e}"));
    match build_scene(&desc, &BuildOptions::default()) {
        Ok(_) => panic!("expected an error"),
        Err(e) => e.to_string(),
    }
}

/// Without `filename`, with a file that does not exist, or with a file that is not a valid tensor file, the scene is
/// an error naming the parameter (and the file and what is wrong with it) with the scene's file, line and column.
#[test]
fn bad_measured_materials_are_errors_with_their_place() {
    let dir = temp_dir("errors");
    let e = build_error(&dir, &sphere_scene("path", r#"Material "measured""#));
    assert!(e.contains("'string filename'") && e.contains("bad.pbrt:15:"), "{e}");
    let e = build_error(&dir, &sphere_scene("path", r#"Material "measured" "string filename" "nowhere.bsdf""#));
    assert!(e.contains("'filename'") && e.contains("nowhere.bsdf") && e.contains("bad.pbrt:15:"), "{e}");
    let good = Ggx { alpha: 0.3, wavelengths: vec![400.0, 700.0], facet: Facet::White }.file(Resolution::TINY);
    std::fs::write(dir.join("cut.bsdf"), &good[..good.len() - 1]).unwrap();
    let e = build_error(&dir, &sphere_scene("path", r#"Material "measured" "string filename" "cut.bsdf""#));
    assert!(e.contains("cut.bsdf") && e.contains("past the end") && e.contains("bad.pbrt:15:"), "{e}");
    std::fs::write(dir.join("scene.bsdf"), sphere_scene("path", "")).unwrap();
    let e = build_error(&dir, &sphere_scene("path", r#"Material "measured" "string filename" "scene.bsdf""#));
    assert!(e.contains("not a tensor file"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

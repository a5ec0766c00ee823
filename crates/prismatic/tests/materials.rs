//! Materials end to end (pbrt text → `build_scene` → integrator → film), against closed forms.
//!
//! `diffusetransmission`: a large thin sheet lit by a uniform disk emitter on one side and seen from the other
//! transmits T(λ)·L·sin²θ_max (θ_max the half-angle the emitter subtends on the axis), seen from the emitter's side it
//! reflects R(λ)·L·sin²θ_max, and with an absorbing medium between emitter and sheet the transmitted light is
//! T(λ)·L·2∫₀^θmax e^{−σa h/cos θ} cos θ sin θ dθ. Each is rendered by `path`, `volpath`, `bdpt` and `sppm`.
//!
//! Statistical tolerances come from the measured noise of each render (two seeds), never from earlier runs.

use film::Film;
use render::BuiltScene;
use spectral::{Observer, Spectrum, WavelengthSampler, WavelengthStrategy};

mod support;
use support::{build, build_error, image_xyz};

/// Allowed distance between an estimate and its closed form, in standard errors (fixed seeds: never flakes).
const K_SIGMA: f64 = 4.5;

fn render(built: &BuiltScene, spp: u32, seed: u32) -> Film {
    let mut film = Film::new(built.film.clone()).unwrap();
    built.integrator.render(&built.scene, &mut film, 0..spp, seed, &|_| {}).unwrap();
    film
}

/// A spectrum tabulated from `f` every 0.5 nm over 360–830 nm.
fn tabulate(f: impl Fn(f64) -> f64) -> Spectrum {
    let lambdas: Vec<f64> = (0..=940).map(|i| 360.0 + 0.5 * i as f64).collect();
    let values = lambdas.iter().map(|&l| f(l)).collect();
    Spectrum::piecewise_linear(lambdas, values).unwrap()
}

/// Linear interpolation in a list of (λ, value) pairs, as a `spectrum` parameter is read.
fn piecewise(pairs: &[(f64, f64)], l: f64) -> f64 {
    let i = pairs.windows(2).position(|w| l >= w[0].0 && l <= w[1].0).unwrap();
    let (a, b) = (pairs[i], pairs[i + 1]);
    a.1 + (b.1 - a.1) * (l - a.0) / (b.0 - a.0)
}

/// The same pairs written as a pbrt `spectrum` value.
fn pbrt_pairs(pairs: &[(f64, f64)]) -> String {
    let inner: Vec<String> = pairs.iter().map(|(l, v)| format!("{l} {v}")).collect();
    format!("[ {} ]", inner.join("  "))
}

/// Renders `built` twice and checks the image's mean XYZ against `radiance` integrated by the hero strategy's
/// colour matching functions: within K_SIGMA standard errors plus `rel` of the value, with the standard error
/// itself below 1% of the value (so the check has power).
fn matches_closed_form(built: &BuiltScene, radiance: &Spectrum, spp: u32, rel: f64, what: &str) {
    let (a, b) = (render(built, spp, 1), render(built, spp, 2));
    let (m, se) = image_xyz(&a, &b);
    let expected =
        WavelengthSampler::new(WavelengthStrategy::Hero, Observer::Cie1931).reference_xyz(radiance).to_array();
    for c in 0..3 {
        eprintln!(
            "{what}, XYZ[{c}]: rendered {:.5} ± {:.5}, closed form {:.5} ({:+.2}σ)",
            m[c],
            se[c],
            expected[c],
            (m[c] - expected[c]) / se[c]
        );
        assert!(se[c] < 0.01 * expected[c], "{what}: too noisy ({} ± {})", m[c], se[c]);
        assert!(
            (m[c] - expected[c]).abs() <= K_SIGMA * se[c] + rel * expected[c],
            "{what}, XYZ[{c}]: rendered {} ± {} vs closed form {}",
            m[c],
            se[c],
            expected[c]
        );
    }
}

/// The sheet's transmittance and reflectance (before `scale`), chromatic so that a mix-up of the two shows in colour.
const T_PAIRS: [(f64, f64); 3] = [(360.0, 0.2), (550.0, 0.6), (830.0, 0.3)];
const R_PAIRS: [(f64, f64); 2] = [(360.0, 0.5), (830.0, 0.1)];

/// A camera on the axis at z = 3 looking down at a `diffusetransmission` disk of radius 50 at z = 0 (its material
/// given by `sheet`), through a 1° lens, so every pixel sees the sheet within 0.03 of the axis (where the
/// irradiance differs from the axis' by less than 10⁻⁴). `emitter` places the emitter, a black disk with a
/// one-sided diffuse area light of constant L (luminance 1). `Integrator` and `maxdepth` 5 as given.
fn sheet_scene(integrator: &str, before_world: &str, sheet: &str, emitter: &str) -> String {
    format!(
        r#"{before_world}
LookAt 0 0 3  0 0 0  0 1 0
Camera "perspective" "float fov" 1
Film "rgb" "integer xresolution" 8 "integer yresolution" 8 "string filename" "sheet.exr"
PixelFilter "box"
Integrator "{integrator}" "integer maxdepth" 5
WorldBegin
AttributeBegin
{sheet}
Shape "disk" "float radius" 50
AttributeEnd
AttributeBegin
Material "diffuse" "rgb reflectance" [ 0 0 0 ]
AreaLightSource "diffuse" "spectrum L" [ 360 1 830 1 ]
{emitter}
AttributeEnd
"#
    )
}

/// The integrators and their passes. Here all light reaching the camera is direct light at the sheet, which `sppm`
/// finds by next-event estimation at its visible points (its photons count from their second bounce), so it checks
/// that estimate's transmission and medium crossing.
const INTEGRATORS: [(&str, u32); 4] = [("path", 256), ("volpath", 256), ("bdpt", 128), ("sppm", 256)];

/// An emitter of radius 2 at distance 1 behind the sheet (sin²θ_max = 0.8): the camera sees T(λ)·scale·0.8.
/// A `transmittance` lost (or taken for the reflectance) or `scale` ignored changes the colour or the level by far
/// more than the tolerance.
#[test]
fn a_diffusetransmission_sheet_transmits_its_transmittance() {
    let sheet = format!(
        r#"Material "diffusetransmission" "spectrum transmittance" {} "spectrum reflectance" {} "float scale" 1.5"#,
        pbrt_pairs(&T_PAIRS),
        pbrt_pairs(&R_PAIRS)
    );
    let emitter = r#"Shape "disk" "float radius" 2 "float height" -1"#;
    let expected = tabulate(|l| 1.5 * piecewise(&T_PAIRS, l) * 0.8);
    for (integrator, spp) in INTEGRATORS {
        let built = build(&sheet_scene(integrator, "", &sheet, emitter), "transmit.pbrt");
        matches_closed_form(&built, &expected, spp, 1e-3, &format!("{integrator}, transmitted"));
    }
}

/// pbrt-v4's defaults (reflectance 0.25, transmittance 0.25, scale 1), seen from the emitter's side: an emitter of
/// radius 4 at distance 4 in front of the sheet, facing it, behind the camera (sin²θ_max = 1/2), so the camera sees
/// 0.25·0.5.
#[test]
fn a_diffusetransmission_sheet_reflects_its_reflectance_with_pbrt_defaults() {
    let sheet = r#"Material "diffusetransmission""#;
    let emitter = r#"Translate 0 0 4
Rotate 180 1 0 0
Shape "disk" "float radius" 4"#;
    let expected = Spectrum::Constant(0.25 * 0.5);
    for (integrator, spp) in INTEGRATORS {
        let built = build(&sheet_scene(integrator, "", sheet, emitter), "reflect.pbrt");
        matches_closed_form(&built, &expected, spp, 1e-3, &format!("{integrator}, reflected"));
    }
}

/// The transmitted light crosses into the medium on the sheet's far side: an absorbing medium (σa(λ), no
/// scattering) fills the space between the sheet and an emitter of radius 2 at distance 1, vacuum is on the
/// camera's side. On the axis the irradiance over π is 2∫₀^θmax e^{−σa/cos θ} cos θ sin θ dθ (tan θ_max = 2), integrated
/// here by the midpoint rule. A path that stayed in the camera's medium after the transmission (or a connection
/// that started in it) would see the unattenuated 0.8: 30–60% more. The transmittance comes from a texture.
#[test]
fn light_transmitted_by_diffusetransmission_crosses_into_the_medium_behind() {
    let sigma = [(360.0, 0.9), (600.0, 0.3), (830.0, 0.5)];
    let before = format!(
        r#"MakeNamedMedium "ink" "string type" "homogeneous" "spectrum sigma_a" {} "rgb sigma_s" [ 0 0 0 ]"#,
        pbrt_pairs(&sigma)
    );
    let sheet = format!(
        r#"Texture "t" "spectrum" "constant" "spectrum value" {}
Material "diffusetransmission" "texture transmittance" "t" "spectrum reflectance" {}
MediumInterface "ink" """#,
        pbrt_pairs(&T_PAIRS),
        pbrt_pairs(&R_PAIRS)
    );
    let emitter = r#"MediumInterface "" "ink"
Shape "disk" "float radius" 2 "float height" -1"#;
    let theta_max = 2f64.atan();
    let irradiance = |s: f64| {
        let n = 2000;
        let d = theta_max / n as f64;
        (0..n)
            .map(|i| {
                let th = (i as f64 + 0.5) * d;
                2.0 * (-s / th.cos()).exp() * th.cos() * th.sin() * d
            })
            .sum::<f64>()
    };
    let expected = tabulate(|l| piecewise(&T_PAIRS, l) * irradiance(piecewise(&sigma, l)));
    for (integrator, spp) in INTEGRATORS {
        let built = build(&sheet_scene(integrator, &before, &sheet, emitter), "medium.pbrt");
        matches_closed_form(&built, &expected, spp, 1e-3, &format!("{integrator}, through the medium"));
    }
}

/// A negative `scale` is an error naming the parameter with its file, line and column.
#[test]
fn a_negative_diffusetransmission_scale_is_an_error() {
    let text = sheet_scene(
        "path",
        "",
        r#"Material "diffusetransmission" "float scale" -1"#,
        r#"Shape "disk" "float radius" 2 "float height" -1"#,
    );
    let e = build_error(&text, "bad.pbrt");
    assert!(e.contains("'scale'") && e.contains("bad.pbrt:9:"), "{e}");
}

/// Thin-film coatings on a conductor or a dielectric: each wrong form is an error naming the parameter at its file,
/// line and column; the right forms build.
#[test]
fn film_coating_parameters_are_checked() {
    let scene_of = |kind: &str, material: &str| {
        format!(
            "Camera \"perspective\"\nFilm \"rgb\" \"integer xresolution\" 4 \"integer yresolution\" 4\nWorldBegin\n\
             Material \"{kind}\" {material}\nShape \"sphere\"\n"
        )
    };
    for (material, param) in [
        (r#""float filmthickness" -5 "float filmeta" 1.5"#, "'filmthickness'"),
        (r#""float filmthickness" 100"#, "'filmeta' or 'filmmaterial'"),
        (r#""float filmeta" 1.5"#, "'filmthickness'"),
        (r#""float filmthickness" 100 "float filmeta" 1.5 "string filmmaterial" "N-BK7""#, "'filmmaterial'"),
        (r#""float filmthickness" 100 "string filmmaterial" "unobtainium""#, "'filmmaterial'"),
        (r#""float filmthicknesses" [ 100 50 ] "string filmmaterials" [ "N-BK7" ]"#, "'filmthicknesses'"),
        (r#""float filmthicknesses" [ 100 -1 ] "string filmmaterials" [ "N-BK7" "1.38" ]"#, "'filmthicknesses'"),
        (r#""float filmthicknesses" [ 100 ] "string filmmaterials" [ "N-BK8" ]"#, "'filmmaterials'"),
        (
            r#""float filmthickness" 100 "float filmeta" 1.5 "float filmthicknesses" [ 1 ] "string filmmaterials" [ "1.5" ]"#,
            "not both",
        ),
    ] {
        for kind in ["conductor", "dielectric"] {
            let e = build_error(&scene_of(kind, material), "film.pbrt");
            assert!(e.contains(param) && e.contains("film.pbrt:4:"), "{kind} {material}: {e}");
        }
    }
    for material in [
        r#""float filmthickness" 80 "float filmeta" 2.4"#,
        r#""float filmthickness" 80 "spectrum filmeta" [ 400 2.5 700 2.3 ]"#,
        r#""float filmthickness" 10 "string filmmaterial" "Cr""#,
        r#""float filmthicknesses" [ 99.6 130 ] "string filmmaterials" [ "1.38" "fused silica" ]"#,
    ] {
        build(&scene_of("conductor", material), "film.pbrt");
        build(&scene_of("dielectric", material), "film.pbrt");
    }
    // The free-standing film takes a thickness and a dielectric's index.
    for (material, param) in [
        (r#""float filmthickness" -3"#, "'filmthickness'"),
        (r#""float filmthickness" [ 1e40 ]"#, "'filmthickness'"),
        (r#""string glass" "unobtainium""#, "'glass'"),
    ] {
        let e = build_error(&scene_of("thinfilm", material), "film.pbrt");
        assert!(e.contains(param) && e.contains("film.pbrt:4:"), "thinfilm {material}: {e}");
    }
    build(&scene_of("thinfilm", r#""float filmthickness" 350 "string glass" "water""#), "film.pbrt");
}

/// The layers of `metallicroughness` (glTF's specular, iridescence, sheen and clearcoat extensions): each wrong form
/// is an error naming the parameter at its file, line and column; the right forms build.
#[test]
fn metallic_roughness_layer_parameters_are_checked() {
    let scene_of = |material: &str| {
        format!(
            "Camera \"perspective\"\nFilm \"rgb\" \"integer xresolution\" 4 \"integer yresolution\" 4\nWorldBegin\n\
             Texture \"noise\" \"spectrum\" \"marble\"\nMaterial \"metallicroughness\" {material}\nShape \"sphere\"\n"
        )
    };
    for (material, param) in [
        (r#""float ior" 0.5"#, "'ior'"),
        (r#""float specular" [ 1e40 ]"#, "'specular'"),
        (r#""texture specularcolor" "noise""#, "'specularcolor'"),
        (r#""texture sheencolor" "noise""#, "'sheencolor'"),
        (r#""float iridescence" 1 "float iridescencethickness" -5"#, "'iridescencethickness'"),
        (r#""float iridescence" 1 "float iridescenceeta" -1"#, "'iridescenceeta'"),
        (r#""float clearcoat" 1 "texture clearcoatnormalmap" "noise""#, "'clearcoatnormalmap'"),
        (r#""float clearcoat" 1 "float clearcoatroughness" [ 1e40 ]"#, "'clearcoatroughness'"),
        (r#""float anisotropy" 1.5"#, "'anisotropy'"),
        (r#""float anisotropy" 0.5 "float anisotropyrotation" [ 1e40 ]"#, "'anisotropyrotation'"),
        (r#""float anisotropy" 0.5 "texture anisotropytexture" "noise""#, "'anisotropytexture'"),
    ] {
        let e = build_error(&scene_of(material), "layers.pbrt");
        assert!(e.contains(param) && e.contains("layers.pbrt:5:"), "{material}: {e}");
    }
    for material in [
        r#""float ior" 0 "float specular" 0.5 "rgb specularcolor" [ 2 1 0.5 ]"#,
        r#""float iridescence" 0.8 "float iridescenceeta" 1.35 "float iridescencethickness" 320"#,
        r#""rgb sheencolor" [ 0.9 0.8 0.7 ] "float sheenroughness" 0.4"#,
        r#""float clearcoat" 1 "float clearcoatroughness" 0.05"#,
        r#""spectrum specularcolor" "metal-Au-eta""#,
        r#""float anisotropy" 0.7 "float anisotropyrotation" 0.5"#,
    ] {
        build(&scene_of(material), "layers.pbrt");
    }
}

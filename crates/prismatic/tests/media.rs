//! Participating media end to end (pbrt text → `build_scene` → `volpath` → film), against closed forms:
//!
//! - the light that crosses a chromatic medium without scattering is Beer–Lambert's exp(−∫σt(λ) ds), for a
//!   homogeneous medium and for a `uniformgrid` density profile, with every wavelength strategy (delta tracking
//!   with spectral MIS is unbiased at every wavelength, not only at the hero's);
//! - the single-scattering radiance of an optically thin slab under a distant light (`maxdepth 1` is exactly single
//!   scattering), with a chromatic σs and an anisotropic phase function;
//! - a white furnace: a non-absorbing scattering medium in an index-matched sphere under a uniform environment
//!   looks exactly like the environment;
//! - the light that crosses a cloud of Lorenz–Mie droplets (`mie`) without scattering follows N·C_ext(λ);
//! - `path` ignores scattering media with a warning, as pbrt-v4's does; bad medium parameters are errors naming
//!   the parameter, file, line and column; an optically enormous medium still renders in finite time.
//!
//! Statistical tolerances come from the measured noise of each render (two seeds), never from earlier runs.

use std::path::Path;

use film::Film;
use render::{build_scene, BuildOptions, BuiltScene};
use spectral::rgb_uplift::RgbIlluminantSpectrum;
use spectral::{Observer, Spectrum, WavelengthSampler, WavelengthStrategy};

mod support;
use support::{build, build_error, image_xyz};

/// Allowed distance between an estimate and its closed form, in standard errors (fixed seeds: never flakes).
const K_SIGMA: f64 = 4.5;

fn render(built: &BuiltScene, strategy: WavelengthStrategy, spp: u32, seed: u32) -> Film {
    let mut spec = built.film.clone();
    spec.wavelengths = strategy;
    let mut film = Film::new(spec).unwrap();
    built.integrator.render(&built.scene, &mut film, 0..spp, seed, &|_| {}).unwrap();
    film
}

/// A spectrum tabulated from `f` every 0.5 nm over 360–830 nm.
fn tabulate(f: impl Fn(f64) -> f64) -> Spectrum {
    let lambdas: Vec<f64> = (0..=940).map(|i| 360.0 + 0.5 * i as f64).collect();
    let values = lambdas.iter().map(|&l| f(l)).collect();
    Spectrum::piecewise_linear(lambdas, values).unwrap()
}

/// Renders `built` with every wavelength strategy and checks the image's mean XYZ against `radiance` integrated by
/// that strategy's colour matching functions: within K_SIGMA standard errors plus `rel` of the value (f32 and
/// tabulation), with the standard error itself below `max_se` of the value (so the check has power).
fn matches_closed_form(built: &BuiltScene, radiance: &Spectrum, spp: u32, rel: f64, max_se: f64, what: &str) {
    for (i, strategy) in WavelengthStrategy::ALL.into_iter().enumerate() {
        let seed = 10 * i as u32;
        let (a, b) = (render(built, strategy, spp, seed + 1), render(built, strategy, spp, seed + 2));
        let (m, se) = image_xyz(&a, &b);
        let expected = WavelengthSampler::new(strategy, Observer::Cie1931).reference_xyz(radiance).to_array();
        for c in 0..3 {
            eprintln!(
                "{what}, {strategy}, XYZ[{c}]: rendered {:.5} ± {:.5}, closed form {:.5} ({:+.2}σ)",
                m[c],
                se[c],
                expected[c],
                (m[c] - expected[c]) / se[c]
            );
            assert!(se[c] < max_se * expected[c], "{what}, {strategy}: too noisy ({} ± {})", m[c], se[c]);
            assert!(
                (m[c] - expected[c]).abs() <= K_SIGMA * se[c] + rel * expected[c],
                "{what}, {strategy}, XYZ[{c}]: rendered {} ± {} vs closed form {}",
                m[c],
                se[c],
                expected[c]
            );
        }
    }
}

/// σa(λ) and σs(λ) of the chromatic test medium, per unit length: σt rises from the red to the blue.
const SIGMA_A: &str = "[ 360 0.1  500 0.3  600 0.2  830 0.05 ]";
const SIGMA_S: &str = "[ 360 1.2  450 0.9  550 0.6  650 0.35  830 0.2 ]";

fn sigma_t(l: f64) -> f64 {
    let pl = |pairs: &[(f64, f64)]| {
        let i = pairs.windows(2).position(|w| l >= w[0].0 && l <= w[1].0).unwrap();
        let (a, b) = (pairs[i], pairs[i + 1]);
        a.1 + (b.1 - a.1) * (l - a.0) / (b.0 - a.0)
    };
    pl(&[(360.0, 0.1), (500.0, 0.3), (600.0, 0.2), (830.0, 0.05)])
        + pl(&[(360.0, 1.2), (450.0, 0.9), (550.0, 0.6), (650.0, 0.35), (830.0, 0.2)])
}

fn sigma_s(l: f64) -> f64 {
    let pairs = [(360.0, 1.2), (450.0, 0.9), (550.0, 0.6), (650.0, 0.35), (830.0, 0.2)];
    let i = pairs.windows(2).position(|w| l >= w[0].0 && l <= w[1].0).unwrap();
    let (a, b) = (pairs[i], pairs[i + 1]);
    a.1 + (b.1 - a.1) * (l - a.0) / (b.0 - a.0)
}

/// A camera at the origin looking along +z through a 2° lens at an emitter (constant L = 1) filling the view at
/// z = 2, all inside `medium` (declared by `medium_decl`); `volpath` with `maxdepth` 0, so only light that crosses
/// the medium without scattering arrives.
fn transmittance_scene(medium_decl: &str) -> String {
    format!(
        r#"{medium_decl}
MediumInterface "" "m"
LookAt 0 0 0  0 0 1  0 1 0
Camera "perspective" "float fov" 2
Film "rgb" "integer xresolution" 8 "integer yresolution" 8 "string filename" "t.exr"
PixelFilter "box"
Sampler "independent" "integer pixelsamples" 16
Integrator "volpath" "integer maxdepth" 0
WorldBegin
AreaLightSource "diffuse" "spectrum L" [ 360 1 830 1 ]
Shape "trianglemesh" "point3 P" [ -1 -1 2  -1 1 2  1 1 2  1 -1 2 ] "integer indices" [ 0 1 2 0 2 3 ]
"#
    )
}

#[test]
fn unscattered_light_through_a_chromatic_homogeneous_medium_follows_beer_lambert() {
    let scene = transmittance_scene(&format!(
        r#"MakeNamedMedium "m" "string type" "homogeneous" "spectrum sigma_a" {SIGMA_A} "spectrum sigma_s" {SIGMA_S} "float g" 0.4"#
    ));
    let built = build(&scene, "beer.pbrt");
    // Pixel rays are at most 1.4° off axis: their path lengths differ from 2 by less than 3·10⁻⁴.
    let expected = tabulate(|l| (-sigma_t(l) * 2.0).exp());
    matches_closed_form(&built, &expected, 4096, 1e-3, 0.01, "homogeneous");
}

/// A `mie` medium of 5 µm water drops (2.5·10⁹ per m³, everything scattered by less than 3° counted as
/// unscattered): the light that crosses 2 m without scattering is exp(−2·N·(C_abs + (1 − f)·C_sca)), with the
/// cross sections and the cut-off fraction f of the Lorenz–Mie series (tested against published values in the
/// optics crate). Checks the renderer's units (µm radius, particles per m³, m² cross sections) and the δ-cut-off.
#[test]
fn unscattered_light_through_mie_droplets_follows_their_cross_sections() {
    let n = 2.5e9;
    let scene = transmittance_scene(&format!(
        r#"MakeNamedMedium "m" "string type" "mie" "string particle" "water" "float radius" 5 "float density" {n}
    "float forwardcutoff" 3"#
    ));
    let built = build(&scene, "mie.pbrt");
    let table =
        optics::mie::MieSpectralTable::from_particle("water", 5.0, 0.0).unwrap().with_forward_cutoff(3.0).unwrap();
    let sigma_t = |l: f64| {
        let (c_sca, c_abs) = table.cross_sections(l);
        n * (c_abs + (1.0 - table.forward_cut_fraction(l)) * c_sca)
    };
    // Independently of the series: the extinction paradox (Q_ext ≈ 2 for x ≈ 57 at 550 nm) and a forward peak that
    // holds a sizeable part of the scattering.
    let geo = std::f64::consts::PI * 25e-12;
    let q_ext = table.cross_sections(550.0).0 / geo;
    assert!((q_ext - 2.0).abs() < 0.3, "Q_ext {q_ext}");
    let f = table.forward_cut_fraction(550.0);
    assert!(f > 0.2 && f < 0.8, "cut-off fraction {f}");
    let expected = tabulate(|l| (-sigma_t(l) * 2.0).exp());
    matches_closed_form(&built, &expected, 4096, 1e-3, 0.01, "mie");
}

/// A `uniformgrid` of two density samples along z (0.5 and 1.5 at the voxel centres z = 0.75 and 1.25 of the box
/// z ∈ [0.5, 1.5]), interpolated trilinearly and fading to zero half a voxel outside: its density integrates to
/// 0.875 along the axis (0.09375 + 0.5 + 0.28125 over the three linear pieces). The box is wide in x and y so
/// that pixel rays see the centre's profile.
#[test]
fn unscattered_light_through_a_density_grid_follows_beer_lambert() {
    let scene = transmittance_scene(&format!(
        r#"MakeNamedMedium "m" "string type" "uniformgrid" "spectrum sigma_a" {SIGMA_A} "spectrum sigma_s" {SIGMA_S}
    "integer nx" 1 "integer ny" 1 "integer nz" 2 "float density" [ 0.5 1.5 ] "float scale" 2
    "point3 p0" [ -50 -50 0.5 ] "point3 p1" [ 50 50 1.5 ]"#
    ));
    let built = build(&scene, "grid.pbrt");
    let expected = tabulate(|l| (-sigma_t(l) * 2.0 * 0.875).exp());
    matches_closed_form(&built, &expected, 4096, 1e-3, 0.01, "uniformgrid");
}

/// A slab z ∈ [1, 1 + h] of a chromatic medium (`interface` boundaries, vacuum outside) seen from below along +z,
/// lit from above by a distant light of irradiance E = 1 whose direction makes an angle α with the normal.
/// `maxdepth 1` counts one scattering event: the image is exactly the single-scattering radiance
/// L(λ) = σs p(θ) E e^{−σt h/μ} (1 − e^{−k h})/k, k = σt (1 − 1/μ), μ = cos α,
/// with θ the scattering angle between the light's direction of travel and the view ray reversed (cos θ = μ) and
/// p Henyey–Greenstein with g = 0.5. Light is sampled at the path's own collisions, and (`"bool forcedcollisions"
/// true`) at a forced collision on each segment.
#[test]
fn single_scattering_of_a_thin_slab_matches_its_closed_form() {
    for forced in ["false", "true"] {
        single_scattering_of_a_thin_slab(forced);
    }
}

fn single_scattering_of_a_thin_slab(forced: &str) {
    let (h, alpha, g) = (0.1f64, 40f64.to_radians(), 0.5f64);
    let (sa, ca) = alpha.sin_cos();
    let scene = format!(
        r#"LookAt 0 0 0  0 0 1  0 1 0
Camera "perspective" "float fov" 2
Film "rgb" "integer xresolution" 8 "integer yresolution" 8 "string filename" "slab.exr"
PixelFilter "box"
Integrator "volpath" "integer maxdepth" 1 "bool forcedcollisions" {forced}
WorldBegin
LightSource "distant" "point3 from" [ 0 {fy} {fz} ] "point3 to" [ 0 0 0 ] "spectrum L" [ 360 1 830 1 ]
MakeNamedMedium "slab" "string type" "homogeneous" "spectrum sigma_a" {SIGMA_A} "spectrum sigma_s" {SIGMA_S} "float g" {g}
Material "interface"
MediumInterface "slab" ""
Shape "trianglemesh" "point3 P" [ -100 -100 1  -100 100 1  100 100 1  100 -100 1 ] "integer indices" [ 0 1 2 0 2 3 ]
Shape "trianglemesh" "point3 P" [ -100 -100 {z1}  100 -100 {z1}  100 100 {z1}  -100 100 {z1} ] "integer indices" [ 0 1 2 0 2 3 ]
"#,
        fy = sa,
        fz = ca,
        z1 = 1.0 + h
    );
    let built = build(&scene, "slab.pbrt");
    let hg = (1.0 - g * g) / (4.0 * std::f64::consts::PI * (1.0 + g * g - 2.0 * g * ca).powf(1.5));
    let expected = tabulate(|l| {
        let st = sigma_t(l);
        let k = st * (1.0 - 1.0 / ca);
        sigma_s(l) * hg * (-st * h / ca).exp() * (1.0 - (-k * h).exp()) / k
    });
    matches_closed_form(&built, &expected, 8192, 2e-3, 0.01, &format!("single scattering, forced {forced}"));
}

/// A sphere of radius 1 with an `interface` boundary filled with a medium that scatters (chromatically) and
/// absorbs nothing, under a uniform environment, rendered by `integrator`: every path leaves the sphere with its
/// radiance unchanged, so every pixel sees exactly the environment (white furnace). The medium's optical radius is
/// 0.6–3 depending on λ, so most paths scatter several times.
fn white_furnace(integrator: &str, spp: u32, what: &str) {
    white_furnace_with(integrator, "", spp, what)
}

/// [`white_furnace`] with `params` added to the integrator's.
fn white_furnace_with(integrator: &str, params: &str, spp: u32, what: &str) {
    let scene = format!(
        r#"LookAt 0 0 -5  0 0 0  0 1 0
Camera "perspective" "float fov" 16
Film "rgb" "integer xresolution" 8 "integer yresolution" 8 "string filename" "furnace.exr"
PixelFilter "box"
Integrator "{integrator}" "integer maxdepth" 1000 {params}
WorldBegin
LightSource "infinite" "rgb L" [ 1 1 1 ]
MakeNamedMedium "white" "string type" "homogeneous" "rgb sigma_a" [ 0 0 0 ]
    "spectrum sigma_s" [ 360 3 500 1.5 830 0.6 ] "float g" 0.3
Material "interface"
MediumInterface "white" ""
Shape "sphere" "float radius" 1
"#
    );
    let built = build(&scene, "furnace.pbrt");
    let d65 = Spectrum::RgbIlluminant(RgbIlluminantSpectrum::new([1.0, 1.0, 1.0]).unwrap());
    let env = tabulate(|l| d65.eval(l));
    matches_closed_form(&built, &env, spp, 1e-3, 0.01, what);
}

/// The white furnace with the volumetric path tracer, light sampled at the path's collisions and at forced ones
/// (whose multiple importance weights against phase sampling must still sum to one at the environment).
#[test]
fn white_furnace_with_a_scattering_medium_in_an_index_matched_sphere() {
    white_furnace("volpath", 128, "furnace");
    white_furnace_with("volpath", r#""bool forcedcollisions" true"#, 128, "furnace, forced collisions");
}

/// The white furnace with bidirectional path tracing: camera and light subpaths (from the environment) scatter in
/// the medium and are joined through it, and whichever strategies a path is weighted over, every pixel must still
/// see exactly the environment, at every wavelength strategy.
#[test]
fn bdpt_white_furnace_with_a_scattering_medium_in_an_index_matched_sphere() {
    white_furnace("bdpt", 256, "bdpt furnace");
}

/// `path` renders a scene with a scattering medium as pbrt-v4's does: it warns, and the image is the image of the
/// scene without the medium, bit for bit.
#[test]
fn path_ignores_scattering_media_with_a_warning() {
    let scene = |with_medium: bool| {
        format!(
            r#"{decl}
LookAt 0 0 0  0 0 1  0 1 0
Camera "perspective" "float fov" 30
Film "rgb" "integer xresolution" 8 "integer yresolution" 8 "string filename" "p.exr"
Integrator "path"
WorldBegin
AreaLightSource "diffuse" "rgb L" [ 1 1 1 ]
Shape "trianglemesh" "point3 P" [ -1 -1 2  -1 1 2  1 1 2  1 -1 2 ] "integer indices" [ 0 1 2 0 2 3 ]
"#,
            decl = if with_medium {
                "MakeNamedMedium \"fog\" \"string type\" \"homogeneous\" \"rgb sigma_s\" [ 1 1 1 ]\nMediumInterface \"\" \"fog\""
            } else {
                ""
            }
        )
    };
    let desc = pbrt::parse_str(&scene(true), Path::new("fog.pbrt")).unwrap();
    let with = build_scene(&desc, &BuildOptions::default()).unwrap();
    assert!(
        with.warnings.iter().any(|w| w.contains("fog.pbrt:6:") && w.contains("ignores media")),
        "{:?}",
        with.warnings
    );
    let without = build(&scene(false), "nofog.pbrt");
    let (a, b) = (render(&with, WavelengthStrategy::Hero, 4, 1), render(&without, WavelengthStrategy::Hero, 4, 1));
    for y in 0..8 {
        for x in 0..8 {
            assert_eq!(a.pixel_xyz(x, y).to_array(), b.pixel_xyz(x, y).to_array());
        }
    }
    assert!(a.pixel_xyz(4, 4).y > 0.5);
}

fn medium_scene(decl: &str) -> String {
    format!(
        "{decl}\nLookAt 0 0 0  0 0 1  0 1 0\nCamera \"perspective\"\nFilm \"rgb\" \"integer xresolution\" 4 \
         \"integer yresolution\" 4 \"string filename\" \"e.exr\"\nIntegrator \"volpath\"\nWorldBegin\n"
    )
}

#[test]
fn bad_medium_parameters_are_errors_naming_the_parameter() {
    let cases = [
        (r#""rgb sigma_a" [ 1 1 1 ] "spectrum sigma_s" [ 400 1 700 -0.5 ]"#, "'sigma_s'"),
        (r#""float g" 1"#, "'g'"),
        (r#""float g" -1.5"#, "'g'"),
        (r#""float scale" -1"#, "'scale'"),
        (r#""spectrum sigma_a" [ 400 1e38 700 1e38 ]"#, "'sigma_a'"),
        (r#""string preset" "Chocolate""#, "unknown medium preset 'Chocolate'"),
    ];
    for (params, expected) in cases {
        let text = medium_scene(&format!("MakeNamedMedium \"m\" \"string type\" \"homogeneous\"\n    {params}"));
        let e = build_error(&text, "bad.pbrt");
        assert!(e.contains(expected) && e.contains("bad.pbrt:2:"), "{params}: {e}");
    }
    let grid_cases = [
        (r#""integer nx" 2 "float density" [ 1 2 3 ]"#, "'density' has 3 values"),
        (r#""float density" [ -1 ]"#, "'density'"),
        (r#""float density" [ 1 ] "point3 p0" [ 1 0 0 ] "point3 p1" [ 0 1 1 ]"#, "p0 < p1"),
        (r#""integer nx" 2 "float density" [ 1 2 ] "rgb Le" [ 1 1 1 ] "float Lescale" [ 1 2 3 ]"#, "'Lescale'"),
    ];
    for (params, expected) in grid_cases {
        let text = medium_scene(&format!("MakeNamedMedium \"m\" \"string type\" \"uniformgrid\"\n    {params}"));
        let e = build_error(&text, "bad.pbrt");
        assert!(e.contains(expected) && e.contains("bad.pbrt:"), "{params}: {e}");
    }
    let e = build_error(&medium_scene(r#"MakeNamedMedium "m" "string type" "uniformgrid""#), "nodensity.pbrt");
    assert!(e.contains("'density'") && e.contains("nodensity.pbrt:1:"), "{e}");
    let mie_cases = [
        (r#""string particle" "milk" "float radius" 5 "float density" 1e6"#, "'particle'"),
        (r#""float radius" 0 "float density" 1e6"#, "'radius'"),
        (r#""float radius" -2 "float density" 1e6"#, "'radius'"),
        (r#""float radius" 5 "float density" 0"#, "'density'"),
        (r#""float radius" 5 "float density" -1"#, "'density'"),
        (r#""float radius" 5 "float density" 1e6 "float radiusspread" -0.1"#, "'radiusspread'"),
        (r#""float radius" 5 "float density" 1e6 "float forwardcutoff" 30"#, "'forwardcutoff'"),
        (r#""float radius" 5 "float density" 1e6 "float g" 0.5"#, "'g'"),
        (r#""float radius" 1e6 "float density" 1e6"#, "'radius'"),
    ];
    for (params, expected) in mie_cases {
        let text = medium_scene(&format!("MakeNamedMedium \"m\" \"string type\" \"mie\"\n    {params}"));
        let e = build_error(&text, "bad.pbrt");
        assert!(e.contains(expected) && e.contains("bad.pbrt:2:"), "{params}: {e}");
    }
    let e = build_error(&medium_scene(r#"MakeNamedMedium "m" "string type" "mie" "float radius" 5"#), "nodens.pbrt");
    assert!(e.contains("'density'") && e.contains("nodens.pbrt:1:"), "{e}");
    let e = build_error(&medium_scene(r#"MakeNamedMedium "m" "string type" "cloud""#), "cloud.pbrt");
    assert!(e.contains("medium 'cloud' is not supported"), "{e}");
}

#[test]
fn measured_presets_build() {
    let text = medium_scene(r#"MakeNamedMedium "m" "string type" "homogeneous" "string preset" "Skin1""#);
    build(&text, "preset.pbrt");
}

/// An optically enormous medium (σs = 10²⁰ per unit, albedo 1) around the camera: every path scatters in place
/// until `maxdepth` ends it, and shadow rays are blocked at once; the render finishes and is black.
#[test]
fn an_optically_huge_medium_still_terminates() {
    let text = medium_scene(
        r#"MakeNamedMedium "m" "string type" "homogeneous" "rgb sigma_a" [ 0 0 0 ] "float scale" 1e20 "rgb sigma_s" [ 1 1 1 ]
MediumInterface "" "m""#,
    ) + "LightSource \"point\" \"point3 from\" [ 0 0 1 ] \"rgb I\" [ 1 1 1 ]\n";
    let built = build(&text, "huge.pbrt");
    let film = render(&built, WavelengthStrategy::Hero, 1, 1);
    assert_eq!(film.pixel_xyz(1, 1).y, 0.0);
}

/// A ball of fog of 10 µm drops (seen from outside) under a distant light from behind the camera, on a spectral film of 47 buckets 10 nm wide; `integrator`
/// adds parameters to `volpath`'s.
fn mie_fog_scene(medium_type: &str, spp: u32, integrator: &str) -> String {
    let medium = if medium_type == "mie" {
        r#""string type" "mie" "string particle" "water" "float radius" 10 "float density" 2e8"#
    } else {
        r#""string type" "homogeneous" "spectrum sigma_a" [ 360 0.02 830 0.05 ] "spectrum sigma_s" [ 360 0.2 830 0.1 ] "float g" 0.8"#
    };
    format!(
        r#"LookAt 0 0 -30  0 0 0  0 1 0
Camera "perspective" "float fov" 40
Film "spectral" "integer xresolution" 12 "integer yresolution" 8 "integer nbuckets" 47
    "float lambdamin" 360 "float lambdamax" 830 "string filename" "fog.exr"
Sampler "zsobol" "integer pixelsamples" {spp}
Integrator "volpath" "integer maxdepth" 4 {integrator}
WorldBegin
LightSource "distant" "point3 from" [ 0.3 1 -1 ] "point3 to" [ 0 0 0 ] "spectrum L" [ 360 1 830 1 ]
LightSource "infinite" "rgb L" [ 0.2 0.2 0.2 ]
MakeNamedMedium "fog" {medium}
MediumInterface "fog" ""
Material "interface"
Shape "sphere" "float radius" 20
"#
    )
}

/// In a scene with Mie drops, the pixels of a pass share a small set of wavelengths (so that the drops' optics are
/// computed a few times per pass, not four times per pixel): after one pass of a small image every pixel's light
/// falls in the same few buckets; a large image affords more hero quadruples per pass. With a Henyey–Greenstein
/// fog, pixels draw their own wavelengths. Renders split into parts, and
/// with one thread or two, are the same bit for bit.
#[test]
fn a_pass_through_mie_drops_shares_its_wavelengths_between_pixels() {
    let buckets_lit = |film: &Film, x: u32, y: u32| -> Vec<usize> {
        film.pixel_spectrum(x, y).iter().enumerate().filter(|(_, v)| **v != 0.0).map(|(k, _)| k).collect()
    };
    for (kind, shared) in [("mie", true), ("homogeneous", false)] {
        let built = build(&mie_fog_scene(kind, 1, ""), "fog.pbrt");
        let film = render(&built, WavelengthStrategy::Hero, 1, 3);
        let first = buckets_lit(&film, 0, 0);
        let all_alike = (0..8).all(|y| (0..12).all(|x| buckets_lit(&film, x, y) == first));
        assert!(!first.is_empty() && first.len() <= 4, "{kind}: pixel (0, 0) lit buckets {first:?}");
        assert_eq!(all_alike, shared, "{kind}: do all pixels share pixel (0, 0)'s buckets {first:?}?");
    }
    // An image of 300×300 pixels affords four hero quadruples per pass for these drops: each pixel's light still
    // falls in at most four buckets, the image's in more than four and at most sixteen.
    let big = mie_fog_scene("mie", 1, "").replace(
        r#""integer xresolution" 12 "integer yresolution" 8"#,
        r#""integer xresolution" 300 "integer yresolution" 300"#,
    );
    let film = render(&build(&big, "fog.pbrt"), WavelengthStrategy::Hero, 1, 3);
    let mut all = std::collections::BTreeSet::new();
    for y in (0..300).step_by(7) {
        for x in (0..300).step_by(7) {
            let lit = buckets_lit(&film, x, y);
            assert!(lit.len() <= 4, "pixel ({x}, {y}) lit buckets {lit:?}");
            all.extend(lit);
        }
    }
    assert!(all.len() > 4 && all.len() <= 16, "the image's lit buckets {all:?}");
    // 1100 passes: for so few pixels 64 passes share a set and 16 sets make a chunk, so the parts cut a set
    // (passes 0..7), span several, and cross the chunks' boundary at 1024.
    let spp = 1100;
    let built = build(&mie_fog_scene("mie", spp, ""), "fog.pbrt");
    let pool = |n: usize| rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap();
    let whole = pool(2).install(|| render(&built, WavelengthStrategy::Hero, spp, 5));
    let one_thread = pool(1).install(|| render(&built, WavelengthStrategy::Hero, spp, 5));
    let mut parts = Film::new(built.film.clone()).unwrap();
    for range in [0..7, 7..1030, 1030..spp] {
        built.integrator.render(&built.scene, &mut parts, range, 5, &|_| {}).unwrap();
    }
    for y in 0..8 {
        for x in 0..12 {
            let s = whole.pixel_spectrum(x, y);
            assert_eq!(s, one_thread.pixel_spectrum(x, y), "pixel ({x}, {y}): one thread against two");
            assert_eq!(s, parts.pixel_spectrum(x, y), "pixel ({x}, {y}): in three parts against in one");
        }
    }
}

/// `volpath` draws some scattering directions in Mie drops towards the sun (`"float sunguide"`), and samples light
/// at a forced collision on each segment (`"bool forcedcollisions"`, on by default in Mie drops): the image is the
/// same with either, both or neither, within the noise (each seed renders every way with the same wavelengths).
/// What they do to the noise is measured in BENCHMARKS.md, not here. A share outside [0, 0.9] is an error naming
/// the parameter.
#[test]
fn guiding_scattering_towards_the_sun_leaves_the_image_unchanged() {
    let spp = 2048;
    let renders = |params: &str| {
        let built = build(&mie_fog_scene("mie", spp, params), "guide.pbrt");
        let (a, b) =
            (render(&built, WavelengthStrategy::Hero, spp, 1), render(&built, WavelengthStrategy::Hero, spp, 2));
        image_xyz(&a, &b)
    };
    let (m0, se0) = renders(r#""float sunguide" 0 "bool forcedcollisions" false"#);
    for params in [r#""float sunguide" 0.5 "bool forcedcollisions" false"#, r#""float sunguide" 0.5"#] {
        let (m1, se1) = renders(params);
        for c in 0..3 {
            let se = (se0[c] * se0[c] + se1[c] * se1[c]).sqrt();
            eprintln!("XYZ[{c}]: plain {:.5} ± {:.5}, {params} {:.5} ± {:.5}", m0[c], se0[c], m1[c], se1[c]);
            assert!(se < 0.05 * m0[c], "too noisy to tell: ± {se}");
            assert!((m1[c] - m0[c]).abs() <= K_SIGMA * se, "{params}, XYZ[{c}]: {} against {}", m1[c], m0[c]);
        }
    }
    for bad in ["-0.1", "0.95", "2"] {
        let e = build_error(&mie_fog_scene("mie", 1, &format!(r#""float sunguide" {bad}"#)), "guide.pbrt");
        assert!(e.contains("sunguide") && e.contains("guide.pbrt:6"), "{e}");
    }
}

//! `Material "subsurface"` end to end: a dielectric boundary around a homogeneous scattering medium, which
//! `volpath` renders as a random walk.
//!
//! - It is wired exactly as the explicit scene it stands for (a `dielectric` of the same `eta` whose shape has the
//!   medium inside, via `MakeNamedMedium` and `MediumInterface`): the two render bit for bit the same image.
//! - A medium that only scatters loses no energy: a sphere of it in a uniform white environment ("furnace") looks
//!   exactly as bright as the environment, within stated standard errors. Absorption makes it darker.
//! - Each way of giving the coefficients (measured `name`, `sigma_a`/`sigma_s`, `reflectance`/`mfp`, defaults) and
//!   bad values, named with file:line:column.

use film::Film;
use render::BuiltScene;

mod support;
use support::{build, build_error};

fn render(built: &BuiltScene, spp: u32, seed: u32) -> Film {
    let mut film = Film::new(built.film.clone()).unwrap();
    built.integrator.render(&built.scene, &mut film, 0..spp, seed, &|_| {}).unwrap();
    film
}

/// A 12×12 view filled by a unit sphere (`material` and `medium_lines` before its Shape), under a uniform
/// environment of radiance `env`.
fn scene(material: &str, medium_lines: &str, env: f64) -> String {
    format!(
        "LookAt 0 0 -3.2  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 30\n\
         Film \"rgb\" \"integer xresolution\" 12 \"integer yresolution\" 12 \"string filename\" \"x.exr\"\n\
         PixelFilter \"box\" \"float xradius\" 0.5 \"float yradius\" 0.5\n\
         Sampler \"zsobol\" \"integer pixelsamples\" 4\nIntegrator \"volpath\" \"integer maxdepth\" 1000\n\
         WorldBegin\nLightSource \"infinite\" \"spectrum L\" [ 360 {env} 830 {env} ]\n\
         AttributeBegin\n{medium_lines}\n{material}\nShape \"sphere\" \"float radius\" 1\nAttributeEnd\n"
    )
}

/// Mean Y over the image of two seeds, and its standard error from their difference (box filter: pixels are
/// independent).
fn mean_y(built: &BuiltScene, spp: u32) -> (f64, f64) {
    let (a, b) = (render(built, spp, 1), render(built, spp, 2));
    let n = (a.width() * a.height()) as f64;
    let (mut m, mut d2) = (0.0, 0.0);
    for y in 0..a.height() {
        for x in 0..a.width() {
            let (va, vb) = (a.pixel_xyz(x, y).y, b.pixel_xyz(x, y).y);
            m += 0.5 * (va + vb) / n;
            d2 += (va - vb).powi(2);
        }
    }
    (m, d2.sqrt() / (2.0 * n))
}

#[test]
fn subsurface_renders_exactly_as_a_dielectric_filled_with_its_medium() {
    let sss = build(
        &scene(
            "Material \"subsurface\" \"float eta\" 1.4 \"rgb sigma_a\" [ 0.3 0.5 0.9 ] \"rgb sigma_s\" [ 4 3 2 ] \
         \"float scale\" 2 \"float g\" 0.3",
            "",
            1.0,
        ),
        "sss.pbrt",
    );
    let explicit = build(
        &scene(
            "Material \"dielectric\" \"float eta\" 1.4",
            "MakeNamedMedium \"inside\" \"string type\" \"homogeneous\" \"rgb sigma_a\" [ 0.3 0.5 0.9 ] \
         \"rgb sigma_s\" [ 4 3 2 ] \"float scale\" 2 \"float g\" 0.3\nMediumInterface \"inside\" \"\"",
            1.0,
        ),
        "sss.pbrt",
    );
    let (a, b) = (render(&sss, 16, 7), render(&explicit, 16, 7));
    let mut lit = 0;
    for y in 0..12 {
        for x in 0..12 {
            let (p, q) = (a.pixel_xyz(x, y).to_array(), b.pixel_xyz(x, y).to_array());
            assert!(p.iter().zip(&q).all(|(u, v)| u.to_bits() == v.to_bits()), "({x}, {y}): {p:?} vs {q:?}");
            lit += (p[1] > 0.0) as u32;
        }
    }
    assert!(lit > 100, "only {lit} pixels lit");
}

/// Energy conservation: a medium that scatters without absorbing, behind a dielectric boundary, in a uniform
/// environment of radiance 1 returns all the light that enters it (the white furnace), for any g and η; Y of a
/// unit-radiance environment is 1. With absorption it is visibly darker.
#[test]
fn a_scattering_only_subsurface_sphere_vanishes_in_a_white_furnace() {
    for (eta, g) in [(1.33, 0.0), (1.5, 0.6)] {
        let built = build(
            &scene(
                &format!(
                    "Material \"subsurface\" \"float eta\" {eta} \"float g\" {g} \"spectrum sigma_a\" [ 360 0 830 0 ] \
                 \"rgb sigma_s\" [ 3 2 1 ]"
                ),
                "",
                1.0,
            ),
            "sss.pbrt",
        );
        let (y, se) = mean_y(&built, 64);
        assert!(se < 0.01, "η {eta}, g {g}: standard error {se}");
        assert!((y - 1.0).abs() < 4.5 * se + 1e-3, "η {eta}, g {g}: Y {y} ± {se}");
    }
    let absorbing = build(
        &scene("Material \"subsurface\" \"rgb sigma_a\" [ 1 1 1 ] \"rgb sigma_s\" [ 3 2 1 ]", "", 1.0),
        "sss.pbrt",
    );
    let (y, se) = mean_y(&absorbing, 16);
    assert!(y < 0.7 && se < 0.02, "{y} ± {se}");
}

#[test]
fn bad_subsurface_parameters_are_errors_naming_them() {
    for (material, needle) in [
        ("Material \"subsurface\" \"string name\" \"Marmalade\"", "Marmalade"),
        ("Material \"subsurface\" \"rgb sigma_a\" [ 1 1 1 ]", "sigma_s"),
        ("Material \"subsurface\" \"float eta\" -1", "eta"),
        ("Material \"subsurface\" \"float g\" 1", "'g'"),
        ("Material \"subsurface\" \"float scale\" -2", "scale"),
        ("Material \"subsurface\" \"rgb reflectance\" [ 0.5 0.5 0.5 ] \"spectrum mfp\" [ 360 0 830 0 ]", "mfp"),
    ] {
        let e = build_error(&scene(material, "", 1.0), "sss.pbrt");
        assert!(e.contains(needle) && e.contains("sss.pbrt:"), "{material}: {e}");
    }
}

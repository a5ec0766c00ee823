//! Area lights on bilinear patches, end to end: a square `bilinearmesh` light over a white floor gives the floor
//! the closed-form radiance of a diffuse surface under a parallel rectangle, and so does the same square as a
//! `trianglemesh` (what `bilinearmesh` used to be split into).

use std::path::Path;

use film::Film;
use render::{build_scene, BuildOptions};

/// Height of the light above the floor and half its side.
const H: f64 = 1.0;
const A: f64 = 0.8;
/// Floor reflectance (constant spectrum) and half-width of the viewed floor window.
const RHO: f64 = 0.5;
const W: f64 = 0.1;

/// The scene: an orthographic camera between floor (z = 0) and light (z = H) looking down at the floor window
/// [−W, W]², a black-bodied emitter of constant radiance 1 (luminance 1) facing down.
fn scene(light: &str) -> String {
    format!(
        r#"LookAt 0 0 0.5  0 0 0  0 1 0
Camera "orthographic" "float screenwindow" [ -{W} {W} -{W} {W} ]
Film "rgb" "integer xresolution" 8 "integer yresolution" 8
PixelFilter "box"
Sampler "independent" "integer pixelsamples" 256
WorldBegin
AttributeBegin
  Material "diffuse" "spectrum reflectance" [ 360 {RHO} 830 {RHO} ]
  Shape "bilinearmesh" "point3 P" [ -50 -50 0  50 -50 0  -50 50 0  50 50 0 ]
AttributeEnd
AttributeBegin
  Material "diffuse" "spectrum reflectance" [ 360 0 830 0 ]
  AreaLightSource "diffuse" "spectrum L" [ 360 1 830 1 ]
  {light}
AttributeEnd
"#
    )
}

/// Mean luminance Y over all pixels of two renders with different seeds, and its standard error from their
/// per-pixel differences (pixels are independent: SE = √(Σ (aₚ − bₚ)²) / (2n)).
fn mean_y(text: &str) -> (f64, f64) {
    let desc = pbrt::parse_str(text, Path::new("light.pbrt")).unwrap_or_else(|e| panic!("{e}"));
    let built = build_scene(&desc, &BuildOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert!(built.warnings.is_empty(), "{:#?}", built.warnings);
    let renders: Vec<Film> = (1..=2)
        .map(|seed| {
            let mut film = Film::new(built.film.clone()).unwrap();
            built.integrator.render(&built.scene, &mut film, 0..256, seed, &|_| {}).unwrap();
            film
        })
        .collect();
    let (mut sum, mut d2, mut n) = (0.0, 0.0, 0.0);
    for y in 0..8 {
        for x in 0..8 {
            let (a, b) = (renders[0].pixel_xyz(x, y).to_array()[1], renders[1].pixel_xyz(x, y).to_array()[1]);
            sum += 0.5 * (a + b);
            d2 += (a - b).powi(2);
            n += 1.0;
        }
    }
    (sum / n, d2.sqrt() / (2.0 * n))
}

/// Form factor from a point to a parallel rectangle with one corner straight above it at height `H`, the other
/// corner offset by (a, b): F = (1/2π)·[X/√(1+X²)·atan(Y/√(1+X²)) + Y/√(1+Y²)·atan(X/√(1+Y²))], X = a/H, Y = b/H
/// (Howell's catalogue of configuration factors, C-11). Odd in a and in b, so signed corners combine by
/// superposition.
fn corner_factor(a: f64, b: f64) -> f64 {
    let (x, y) = (a / H, b / H);
    let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * std::f64::consts::PI)
}

/// Closed form: the floor radiance ρ/π·E with E = π·L·F (L = 1), averaged over the viewed window.
fn expected_y() -> f64 {
    let f_at = |px: f64, py: f64| {
        let mut f = 0.0;
        for (sx, x) in [(1.0, A - px), (-1.0, -A - px)] {
            for (sy, y) in [(1.0, A - py), (-1.0, -A - py)] {
                f += sx * sy * corner_factor(x, y);
            }
        }
        f
    };
    let n = 64;
    let mut sum = 0.0;
    for j in 0..n {
        for i in 0..n {
            let (x, y) = (-W + 2.0 * W * (i as f64 + 0.5) / n as f64, -W + 2.0 * W * (j as f64 + 0.5) / n as f64);
            sum += RHO * f_at(x, y);
        }
    }
    sum / (n * n) as f64
}

#[test]
fn square_light_gives_the_closed_form_irradiance() {
    let expect = expected_y();
    // Sanity of the closed form: below the centre of a 1.6 × 1.6 square at height 1, F = 4·Fc(0.8, 0.8) = 0.4441.
    assert!((4.0 * corner_factor(A, A) - 0.4441).abs() < 1e-4 && (expect / RHO - 0.4441).abs() < 0.01, "{expect}");
    // p00 p10 p01 p11 ordered so that ∂p/∂u × ∂p/∂v points down (−z), towards the floor.
    let bilinear =
        format!("Shape \"bilinearmesh\" \"point3 P\" [ -{A} -{A} {H}  -{A} {A} {H}  {A} -{A} {H}  {A} {A} {H} ]");
    // The same square as two triangles wound to face down.
    let triangles = format!(
        "Shape \"trianglemesh\" \"point3 P\" [ -{A} -{A} {H}  -{A} {A} {H}  {A} {A} {H}  {A} -{A} {H} ] \
         \"integer indices\" [ 0 1 2 0 2 3 ]"
    );
    for light in [bilinear, triangles] {
        let (y, se) = mean_y(&scene(&light));
        assert!(se < 0.005 * y, "{light}: too noisy ({y} ± {se})");
        // 4.5 standard errors plus 0.2% for f32 radiance and the quadrature of the reference.
        assert!((y - expect).abs() <= 4.5 * se + 2e-3 * expect, "{light}: rendered {y} ± {se} vs closed form {expect}");
    }
}

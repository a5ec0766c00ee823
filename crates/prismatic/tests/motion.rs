//! Motion blur end to end (pbrt text → `build_scene` → integrator → film), with pbrt-v4's semantics:
//! `ActiveTransform`, `TransformTimes`, the camera's `shutteropen`/`shutterclose`, and transforms interpolated by
//! pbrt-v4's decomposition.
//!
//! The moving-sphere tests compare pixels with the coverage a box filter sees, computed from the geometry of the
//! motion; their tolerances come from the measured noise of the renders (background pixels), never from earlier
//! runs.

use std::path::{Path, PathBuf};

use film::Film;
use render::{build_scene, BuildOptions, BuiltScene};

mod support;
use support::build;

/// Allowed distance between an estimate and its expected value, in standard errors (fixed seeds: never flakes).
const K_SIGMA: f64 = 4.5;

fn render(built: &BuiltScene, spp: u32, seed: u32) -> Film {
    let mut film = Film::new(built.film.clone()).unwrap();
    built.integrator.render(&built.scene, &mut film, 0..spp, seed, &|_| {}).unwrap();
    film
}

fn y(f: &Film, x: u32, y: u32) -> f64 {
    f.pixel_xyz(x, y).y
}

/// The strip the sphere tests look at: an orthographic view of world x ∈ [−6, 6], y ∈ [−1, 1] on 24 × 4 pixels of
/// 0.5 × 0.5 (box filter: each sample counts in its own pixel), looking down +z.
const STRIP_W: u32 = 24;
const STRIP_H: u32 = 4;
const SPP: u32 = 4096;
/// The sphere's radius.
const R: f64 = 0.8;

/// A black sphere of radius 0.8 at the origin, in front of a uniform white environment, seen by `camera` (the
/// directives up to and including `Camera`), with `motion` (directives right before the `Shape`) and `shutter` (the
/// camera's shutter parameters).
fn strip(camera_transform: &str, shutter: &str, before: &str, motion: &str) -> String {
    format!(
        r#"{before}
{camera_transform}
Camera "orthographic" "float screenwindow" [ -6 6 -1 1 ] {shutter}
Film "rgb" "integer xresolution" {STRIP_W} "integer yresolution" {STRIP_H} "string filename" "motion.exr"
PixelFilter "box"
Sampler "zsobol" "integer pixelsamples" {SPP}
Integrator "path" "integer maxdepth" 1
WorldBegin
LightSource "infinite" "rgb L" [ 1 1 1 ]
AttributeBegin
  Material "diffuse" "rgb reflectance" [ 0 0 0 ]
  {motion}
  Shape "sphere" "float radius" {R}
AttributeEnd
"#
    )
}

const STILL_CAMERA: &str = "LookAt 0 0 -5  0 0 0  0 1 0";
/// From x = −3 at the start time to x = 2 at the end time.
const SPHERE_MOTION: &str = "Translate -3 0 0 ActiveTransform EndTime Translate 5 0 0 ActiveTransform All";

/// ∫ over [a, b] of a function linear between consecutive `breaks` (exact trapezoids).
fn integrate_piecewise_linear(a: f64, b: f64, breaks: &[f64], f: impl Fn(f64) -> f64) -> f64 {
    let mut xs: Vec<f64> = breaks.iter().copied().filter(|&x| x > a && x < b).collect();
    xs.push(a);
    xs.push(b);
    xs.sort_by(f64::total_cmp);
    xs.windows(2).map(|w| 0.5 * (w[1] - w[0]) * (f(w[0]) + f(w[1]))).sum()
}

/// The fraction of pixel [xa, xb] × [ya, yb] × shutter that a disk of radius `R` covers while its centre moves
/// uniformly from (x0, 0) to (x1, 0): for a point at height y the disk covers it while the centre is within
/// h = √(R² − y²) of it, so the covered time is the overlap of [x − h, x + h] with [x0, x1] over x1 − x0, a
/// piecewise linear function of x integrated exactly; across y (where h has square-root ends) by the midpoint rule
/// on 20 000 rows (error below 1e-6).
fn coverage(xa: f64, xb: f64, ya: f64, yb: f64, x0: f64, x1: f64) -> f64 {
    let (lo, hi) = (ya.max(-R), yb.min(R));
    if lo >= hi {
        return 0.0;
    }
    let n = 20_000;
    let dy = (hi - lo) / n as f64;
    let mut sum = 0.0;
    for k in 0..n {
        let y = lo + (k as f64 + 0.5) * dy;
        let h = (R * R - y * y).sqrt();
        let overlap = |x: f64| ((x + h).min(x1) - (x - h).max(x0)).max(0.0);
        sum += integrate_piecewise_linear(xa, xb, &[x0 - h, x0 + h, x1 - h, x1 + h], overlap) * dy;
    }
    sum / ((x1 - x0) * (xb - xa) * (yb - ya))
}

/// The world rectangle of strip pixel (i, j).
fn pixel_rect(i: u32, j: u32) -> (f64, f64, f64, f64) {
    let xa = -6.0 + 0.5 * i as f64;
    let yb = 1.0 - 0.5 * j as f64;
    (xa, xa + 0.5, yb - 0.5, yb)
}

/// Checks two renders (seeds) of the strip against a disk sweeping from x0 to x1: each pixel is the background's
/// brightness B times (1 − coverage). B and the per-sample spectral noise come from the pixels the sphere never
/// reaches; a pixel's standard error is that of its samples, each B·(spectral estimate) or 0 (conservative: the
/// sampler stratifies coverage better than independent samples would).
fn check_streak(a: &Film, b: &Film, x0: f64, x1: f64, what: &str) {
    let (mut bg, mut streak) = (vec![], vec![]);
    for j in 0..STRIP_H {
        for i in 0..STRIP_W {
            let (xa, xb, ya, yb) = pixel_rect(i, j);
            let c = coverage(xa, xb, ya, yb, x0, x1);
            if xb <= x0.min(x1) - R || xa >= x0.max(x1) + R {
                assert_eq!(c, 0.0);
                bg.extend([y(a, i, j), y(b, i, j)]);
            } else {
                streak.push((i, j, c));
            }
        }
    }
    let n = bg.len() as f64;
    let bright = bg.iter().sum::<f64>() / n;
    let var_pixel = bg.iter().map(|v| (v - bright).powi(2)).sum::<f64>() / (n - 1.0);
    let se_bright = (var_pixel / n).sqrt();
    assert!(bright > 0.1 && se_bright < 1e-3 * bright, "{what}: background {bright} ± {se_bright}");
    let mut worst = 0.0f64;
    let mut deepest = 0.0f64;
    for (i, j, c) in streak {
        // Mean of the two seeds' pixels (2·SPP samples): spectral noise where uncovered, and coverage noise.
        let var = (1.0 - c) * var_pixel / 2.0 + c * (1.0 - c) * bright * bright / (2.0 * SPP as f64);
        let sigma = (var + ((1.0 - c) * se_bright).powi(2)).sqrt();
        let got = 0.5 * (y(a, i, j) + y(b, i, j));
        let want = (1.0 - c) * bright;
        assert!(K_SIGMA * sigma < 0.03 * bright, "{what}: pixel ({i}, {j}) too noisy to test ({sigma})");
        assert!(
            (got - want).abs() <= K_SIGMA * sigma,
            "{what}: pixel ({i}, {j}) is {:.4} of the background, coverage {c:.4} predicts {:.4} (± {:.4})",
            got / bright,
            1.0 - c,
            sigma / bright
        );
        worst = worst.max((got - want).abs() / sigma);
        deepest = deepest.max(c);
    }
    eprintln!("{what}: worst pixel {worst:.2}σ, deepest coverage {deepest:.3}");
    assert!(deepest > 0.2, "{what}: no pixel is much covered ({deepest})");
}

/// A black sphere moving along x in front of a white background leaves the streak whose per-pixel coverage follows
/// from the motion: for the default shutter [0, 1] and transform times [0, 1] it sweeps from x = −3 to x = 2; with
/// the shutter open over [0.25, 0.5] only a quarter of the way, from −1.75 to −0.5; with `TransformTimes 0 2` and
/// the default shutter, half the way. Every pixel of the streak agrees within 4.5 standard errors, each below 0.7%
/// of the background, so a sphere left at its start (coverage ~0.8 in place of ~0.3), a time drawn from the
/// wrong interval or non-uniformly over it, or an interpolation other than linear in time fails.
#[test]
fn a_moving_sphere_leaves_the_streak_of_its_coverage() {
    let cases = [
        ("", "", -3.0, 2.0, "shutter [0, 1]"),
        ("", r#""float shutteropen" 0.25 "float shutterclose" 0.5 "#, -1.75, -0.5, "shutter [0.25, 0.5]"),
        ("TransformTimes 0 2", "", -3.0, -0.5, "TransformTimes 0 2"),
    ];
    for (before, shutter, x0, x1, what) in cases {
        let built = build(&strip(STILL_CAMERA, shutter, before, SPHERE_MOTION), "streak.pbrt");
        check_streak(&render(&built, SPP, 1), &render(&built, SPP, 2), x0, x1, what);
    }
}

/// A still sphere seen by a camera moving the other way blurs as the moving sphere does: the camera goes from
/// x = 3 to x = −2 while the sphere stays at the origin, so relative to the camera the sphere sweeps from −3 to 2.
/// Both renders draw the same numbers (the same film positions, wavelengths and times), so the images agree pixel
/// by pixel up to samples on the sphere's edge that rounding sends the other way (each 1/4096 of a pixel).
#[test]
fn a_moving_camera_blurs_a_still_scene_as_the_scene_moving_the_other_way() {
    let moving_camera = "ActiveTransform StartTime LookAt 3 0 -5  3 0 0  0 1 0 \
                         ActiveTransform EndTime LookAt -2 0 -5  -2 0 0  0 1 0 ActiveTransform All";
    let camera = render(&build(&strip(moving_camera, "", "", ""), "camera.pbrt"), SPP, 1);
    let scene = render(&build(&strip(STILL_CAMERA, "", "", SPHERE_MOTION), "scene.pbrt"), SPP, 1);
    let bright = y(&scene, 0, 0);
    let mut largest = 0.0f64;
    for j in 0..STRIP_H {
        for i in 0..STRIP_W {
            largest = largest.max((y(&camera, i, j) - y(&scene, i, j)).abs() / bright);
        }
    }
    eprintln!("moving camera against moving sphere: largest pixel difference {largest:.2e} of the background");
    assert!(largest < 2e-3, "largest pixel difference {largest} of the background");
    check_streak(
        &camera,
        &render(&build(&strip(moving_camera, "", "", ""), "camera.pbrt"), SPP, 2),
        -3.0,
        2.0,
        "camera",
    );
}

/// An `ObjectInstance` of a black bar along +x turning 90° about the view axis between t = 0 and t = 1, seen with
/// the shutter open only around t = 0.5 ([0.5, 0.5001]; ISO 10⁶ keeps the exposure at 1): the bar is where a
/// bar turned by 45° is (pbrt-v4's slerp of the decomposed rotation). The renders draw the same film positions and
/// wavelengths, so they agree pixel by pixel up to the bar's 0.0045° of motion; turned by 0° or 90° the bar is
/// elsewhere.
#[test]
fn an_instance_turning_a_quarter_turn_is_at_45_degrees_halfway() {
    let scene = |turn: &str| {
        format!(
            r#"LookAt 0 0 -5  0 0 0  0 1 0
Camera "orthographic" "float screenwindow" [ -2 2 -2 2 ] "float shutteropen" 0.5 "float shutterclose" 0.5001
Film "rgb" "integer xresolution" 16 "integer yresolution" 16 "string filename" "turn.exr" "float iso" 1e6
PixelFilter "box"
Integrator "path" "integer maxdepth" 1
WorldBegin
LightSource "infinite" "rgb L" [ 1 1 1 ]
ObjectBegin "bar"
  Material "diffuse" "rgb reflectance" [ 0 0 0 ]
  Shape "trianglemesh" "point3 P" [ 0.2 -0.15 0  1.8 -0.15 0  1.8 0.15 0  0.2 0.15 0 ] "integer indices" [ 0 1 2 0 2 3 ]
ObjectEnd
AttributeBegin
  {turn}
  ObjectInstance "bar"
AttributeEnd
"#
        )
    };
    let turning =
        render(&build(&scene("ActiveTransform EndTime Rotate 90 0 0 1 ActiveTransform All"), "t.pbrt"), 64, 1);
    let at = |deg: f64| render(&build(&scene(&format!("Rotate {deg} 0 0 1")), "s.pbrt"), 64, 1);
    let (at45, at0, at90) = (at(45.0), at(0.0), at(90.0));
    let bright = y(&at45, 0, 15);
    let diff = |a: &Film, b: &Film| {
        let mut m = 0.0f64;
        for j in 0..16 {
            for i in 0..16 {
                m = m.max((y(a, i, j) - y(b, i, j)).abs() / bright);
            }
        }
        m
    };
    let (d45, d0, d90) = (diff(&turning, &at45), diff(&turning, &at0), diff(&turning, &at90));
    eprintln!("turning bar against 45°: {d45:.2e}, against 0°: {d0:.2}, against 90°: {d90:.2}");
    assert!(d45 < 5e-3, "the bar halfway is not at 45° ({d45})");
    assert!(d0 > 0.5 && d90 > 0.5, "the test cannot tell 0° or 90° from 45° ({d0}, {d90})");
}

/// `ActiveTransform` that leaves both ends equal records no motion (pbrt-v4 compares the two matrices), so the
/// scene renders bit for bit as without it: no time is drawn and the random numbers are those of a still scene.
#[test]
fn equal_ends_render_as_a_still_scene() {
    let still = render(&build(&strip(STILL_CAMERA, "", "", "Translate -3 0 0"), "a.pbrt"), 16, 1);
    let same = "Translate -3 0 0 ActiveTransform EndTime Translate 0 0 0 ActiveTransform All";
    let same = render(&build(&strip(STILL_CAMERA, "", "", same), "b.pbrt"), 16, 1);
    for j in 0..STRIP_H {
        for i in 0..STRIP_W {
            assert_eq!(still.pixel_xyz(i, j).to_array(), same.pixel_xyz(i, j).to_array(), "pixel ({i}, {j})");
        }
    }
    assert!(y(&still, 6, 1) < 0.5 * y(&still, 20, 1), "the sphere is not in view");
}

/// pbrt-v4 does not animate area lights: a moving emitter is an error at its `Shape`, with file, line and column.
#[test]
fn a_moving_area_light_is_an_error() {
    let text = "Camera \"perspective\"\nWorldBegin\nAttributeBegin\nAreaLightSource \"diffuse\"\n\
                ActiveTransform EndTime Translate 1 0 0 ActiveTransform All\nShape \"sphere\"\nAttributeEnd\n";
    let desc = pbrt::parse_str(text, Path::new("lamp.pbrt")).unwrap();
    let e = build_scene(&desc, &BuildOptions::default()).err().expect("an error").to_string();
    assert!(e.contains("lamp.pbrt:6:1") && e.contains("moving shape cannot be an area light"), "{e}");
}

fn killeroos() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../pbrt/tests/fixtures/killeroos")
}

/// The directive pattern of pbrt-v4's `killeroos/killeroo-moving.pbrt` (two killeroos under `ActiveTransform
/// StartTime`, one with an `ActiveTransform All` after it, inside nested attribute blocks), on the killeroo mesh of
/// the fixtures: it builds without warnings, both killeroos move, and the render differs from the same scene
/// frozen at its start time where the killeroos are.
#[test]
fn the_killeroo_moving_pattern_renders_with_both_killeroos_moving() {
    let scene = |motion: bool| {
        let start = if motion { "ActiveTransform StartTime" } else { "" };
        let all = if motion { "ActiveTransform All" } else { "" };
        format!(
            r#"LookAt 400 20 30  0 63 -110  0 0 1
Rotate -5 0 0 1
Camera "perspective" "float fov" 39
Film "rgb" "integer xresolution" 32 "integer yresolution" 32 "string filename" "killeroo-moving.exr"
Integrator "path" "integer maxdepth" 2
WorldBegin
AttributeBegin
  Material "diffuse" "rgb reflectance" [ 0 0 0 ]
  Translate 150 120 20
  AreaLightSource "diffuse" "rgb L" [ 2000 2000 2000 ]
  Shape "sphere" "float radius" 3
AttributeEnd
AttributeBegin
  Material "diffuse" "rgb reflectance" [ 0.5 0.5 0.8 ]
  Translate 0 0 -140
  Shape "trianglemesh" "point3 P" [ -1000 -1000 0  1000 -1000 0  1000 1000 0  -1000 1000 0 ] "integer indices" [ 0 1 2 2 3 0 ]
AttributeEnd
AttributeBegin
  Scale 0.5 0.5 0.5
  Rotate -60 0 0 1
  Material "coateddiffuse" "float roughness" 0.025 "rgb reflectance" [ 0.4 0.2 0.2 ]
  Translate 100 200 -140
  {start}
  Translate 35 35 35
  AttributeBegin
    Include "geometry/killeroo.pbrt"
  AttributeEnd
  Material "coateddiffuse" "float roughness" 0.15 "rgb reflectance" [ 0.4 0.5 0.4 ]
  AttributeBegin
    {start}
    Translate 30 0 0
    {all}
    Translate -200 0 0
    Include "geometry/killeroo.pbrt"
  AttributeEnd
AttributeEnd
"#
        )
    };
    let path = killeroos().join("moving-pattern.pbrt");
    let desc = pbrt::parse_str(&scene(true), &path).unwrap_or_else(|e| panic!("{e}"));
    let moving: Vec<_> = desc.shapes.iter().filter(|s| s.motion.is_some()).collect();
    assert_eq!(moving.len(), 2, "both killeroos move");
    for s in moving {
        // Both move back by the StartTime-only translation (35, 35, 35), plus (30, 0, 0) for the second, in the
        // scaled and rotated frame.
        let m = s.motion.unwrap();
        let d = s.render_from_object.point(glam::DVec3::ZERO) - m.end.point(glam::DVec3::ZERO);
        assert!(d.length() > 20.0, "{d:?}");
    }
    let (moving, frozen) = (build(&scene(true), &path), build(&scene(false), &path));
    let (a, b) = (render(&moving, 8, 1), render(&frozen, 8, 1));
    let changed = (0..32).flat_map(|j| (0..32).map(move |i| (i, j))).filter(|&(i, j)| {
        let (p, q) = (y(&a, i, j), y(&b, i, j));
        assert!(p.is_finite());
        (p - q).abs() > 0.2 * q.max(1e-3)
    });
    let changed = changed.count();
    eprintln!("killeroo-moving pattern: {changed} of 1024 pixels change by more than 20%");
    assert!(changed > 20, "only {changed} pixels change with the motion");
}

//! Alpha cut-outs end to end (pbrt text → `build_scene` → integrator → film), with pbrt-v4's semantics: alpha 0
//! is invisible, alpha 1 is opaque, and in between each ray passes a surface with probability 1 − alpha.
//!
//! Statistical tolerances come from the measured noise of each render (two seeds), never from earlier runs.

use film::Film;
use render::BuiltScene;

mod support;
use support::{build, build_error};

/// Allowed distance between an estimate and its expected value, in standard errors (fixed seeds: never flakes).
const K_SIGMA: f64 = 4.5;

fn render(built: &BuiltScene, spp: u32, seed: u32) -> Film {
    let mut film = Film::new(built.film.clone()).unwrap();
    built.integrator.render(&built.scene, &mut film, 0..spp, seed, &|_| {}).unwrap();
    film
}

fn assert_identical(a: &Film, b: &Film, what: &str) {
    for y in 0..a.height() {
        for x in 0..a.width() {
            assert_eq!(a.pixel_xyz(x, y).to_array(), b.pixel_xyz(x, y).to_array(), "{what}: pixel ({x}, {y})");
        }
    }
    assert!((0..a.height()).any(|y| (0..a.width()).any(|x| a.pixel_xyz(x, y).y > 0.01)), "{what}: black image");
}

/// Mean Y over the pixels `(x, y)` with `keep(x, y)` of two renders with different seeds, and its standard error
/// (pixels are independent with a box filter).
fn mean_y(a: &Film, b: &Film, keep: impl Fn(u32, u32) -> bool) -> (f64, f64) {
    let (mut m, mut d2, mut n) = (0.0, 0.0, 0.0);
    for y in 0..a.height() {
        for x in 0..a.width() {
            if keep(x, y) {
                let (va, vb) = (a.pixel_xyz(x, y).y, b.pixel_xyz(x, y).y);
                m += 0.5 * (va + vb);
                d2 += (va - vb).powi(2);
                n += 1.0;
            }
        }
    }
    (m / n, d2.sqrt() / (2.0 * n))
}

/// `ratio` = a/b of two estimates with standard errors, within K_SIGMA combined standard errors of `expected`,
/// with that error below `max_rel` of the expected ratio (so the check has power).
fn ratio_is(a: (f64, f64), b: (f64, f64), expected: f64, max_rel: f64, what: &str) {
    let r = a.0 / b.0;
    let se = r * ((a.1 / a.0).powi(2) + (b.1 / b.0).powi(2)).sqrt();
    eprintln!("{what}: ratio {r:.4} ± {se:.4}, expected {expected} ({:+.2}σ)", (r - expected) / se);
    assert!(se < max_rel * expected, "{what}: too noisy ({r} ± {se})");
    assert!((r - expected).abs() < K_SIGMA * se, "{what}: ratio {r} ± {se}, expected {expected}");
}

/// A floor (diffuse 0.5) lit by a small area light above it, seen from the side, and `extra` shapes.
fn room(integrator: &str, extra: &str) -> String {
    format!(
        r#"LookAt 0 -4 2  0 0 0.3  0 0 1
Camera "perspective" "float fov" 50
Film "rgb" "integer xresolution" 16 "integer yresolution" 16 "string filename" "alpha.exr"
PixelFilter "box"
Integrator "{integrator}" "integer maxdepth" 3
WorldBegin
Material "diffuse" "rgb reflectance" [ 0.5 0.5 0.5 ]
Shape "trianglemesh" "point3 P" [ -3 -3 0  3 -3 0  3 3 0  -3 3 0 ] "integer indices" [ 0 1 2 0 2 3 ]
AttributeBegin
Material "diffuse" "rgb reflectance" [ 0 0 0 ]
AreaLightSource "diffuse" "rgb L" [ 8 8 8 ]
Shape "trianglemesh" "point3 P" [ -0.5 -0.5 2.5  -0.5 0.5 2.5  0.5 0.5 2.5  0.5 -0.5 2.5 ] "integer indices" [ 0 1 2 0 2 3 ]
AttributeEnd
Texture "zero" "float" "constant" "float value" 0
Texture "ones" "float" "checkerboard" "float tex1" 1 "float tex2" 1 "float uscale" 4 "float vscale" 4
{extra}
"#
    )
}

/// A grey quad between the light and the floor, half in view.
fn blocker(alpha: &str) -> String {
    format!(
        r#"AttributeBegin
Material "diffuse" "rgb reflectance" [ 0.7 0.7 0.7 ]
Shape "trianglemesh" "point3 P" [ -1 -1 1.2  1 -1 1.2  1 1 1.2  -1 1 1.2 ] "integer indices" [ 0 1 2 0 2 3 ]
    "point2 uv" [ 0 0  1 0  1 1  0 1 ] {alpha}
AttributeEnd"#
    )
}

/// Alpha 0 (a constant, or a constant texture) is invisible: the image equals the image without the shape, bit
/// for bit, with a path tracer and with a bidirectional one (whose connections and light paths would meet it).
#[test]
fn alpha_zero_is_invisible() {
    for integrator in ["path", "bdpt"] {
        let without = render(&build(&room(integrator, ""), "without.pbrt"), 16, 1);
        for alpha in [r#""float alpha" 0"#, r#""texture alpha" "zero""#] {
            let with = render(&build(&room(integrator, &blocker(alpha)), "with.pbrt"), 16, 1);
            assert_identical(&with, &without, &format!("{integrator}, {alpha}"));
        }
    }
}

/// Alpha 1 is opaque: a constant 1 and a texture that is 1 everywhere (which goes through the alpha test at every
/// hit) render exactly as the shape without alpha; and the shape is there (the image differs from the room's).
#[test]
fn alpha_one_equals_no_alpha() {
    for integrator in ["path", "bdpt"] {
        let opaque = render(&build(&room(integrator, &blocker("")), "opaque.pbrt"), 16, 1);
        for alpha in [r#""float alpha" 1"#, r#""texture alpha" "ones""#] {
            let with = render(&build(&room(integrator, &blocker(alpha)), "with.pbrt"), 16, 1);
            assert_identical(&with, &opaque, &format!("{integrator}, {alpha}"));
        }
        let room_only = render(&build(&room(integrator, ""), "room.pbrt"), 16, 1);
        let (a, b) = (mean_y(&opaque, &opaque, |_, _| true).0, mean_y(&room_only, &room_only, |_, _| true).0);
        assert!(a < 0.8 * b, "{integrator}: the blocker changes nothing ({a} vs {b})");
    }
}

/// A black quad of alpha 0.5 in front of a uniform emitter passes half of it to the camera (camera rays), and a
/// grey quad of alpha 0.5 between a distant light and a floor casts a half shadow (shadow rays; `maxdepth` 1, so the
/// floor shows direct light only, and the camera sits under the quad). A pass probability of a² or √a, or a test
/// shared by all rays, would be far outside the tolerance.
#[test]
fn alpha_one_half_passes_half_the_light() {
    let see_through = |alpha: &str| {
        format!(
            r#"LookAt 0 0 3  0 0 0  0 1 0
Camera "perspective" "float fov" 20
Film "rgb" "integer xresolution" 16 "integer yresolution" 16 "string filename" "see.exr"
PixelFilter "box"
Integrator "path" "integer maxdepth" 5
WorldBegin
AttributeBegin
AreaLightSource "diffuse" "spectrum L" [ 360 1 830 1 ]
Shape "trianglemesh" "point3 P" [ -5 -5 -1  5 -5 -1  5 5 -1  -5 5 -1 ] "integer indices" [ 0 1 2 0 2 3 ]
AttributeEnd
Material "diffuse" "rgb reflectance" [ 0 0 0 ]
Shape "trianglemesh" "point3 P" [ -5 -5 0  5 -5 0  5 5 0  -5 5 0 ] "integer indices" [ 0 1 2 0 2 3 ] {alpha}
"#
        )
    };
    let (a, b) = (build(&see_through(r#""float alpha" 0.5"#), "half.pbrt"), build(&see_through(""), "clear.pbrt"));
    assert!(mean_y(&render(&b, 4, 1), &render(&b, 4, 2), |_, _| true).0 < 1e-9, "the opaque quad hides the light");
    let clear = build(&see_through(r#""float alpha" 0"#), "clear.pbrt");
    let half = mean_y(&render(&a, 64, 1), &render(&a, 64, 2), |_, _| true);
    let full = mean_y(&render(&clear, 64, 1), &render(&clear, 64, 2), |_, _| true);
    ratio_is(half, full, 0.5, 0.02, "camera rays through alpha 0.5");

    let shadow = |integrator: &str, alpha: &str| {
        format!(
            r#"LookAt 0 0 0.5  0 0 0  0 1 0
Camera "perspective" "float fov" 60
Film "rgb" "integer xresolution" 16 "integer yresolution" 16 "string filename" "shadow.exr"
PixelFilter "box"
Integrator "{integrator}" "integer maxdepth" 1
WorldBegin
LightSource "distant" "point3 from" [ 0.3 0.2 1 ] "point3 to" [ 0 0 0 ] "spectrum L" [ 360 1 830 1 ]
Material "diffuse" "rgb reflectance" [ 0.5 0.5 0.5 ]
Shape "trianglemesh" "point3 P" [ -5 -5 0  5 -5 0  5 5 0  -5 5 0 ] "integer indices" [ 0 1 2 0 2 3 ]
Shape "trianglemesh" "point3 P" [ -50 -50 1  50 -50 1  50 50 1  -50 50 1 ] "integer indices" [ 0 1 2 0 2 3 ] {alpha}
"#
        )
    };
    for (integrator, spp) in [("path", 64), ("bdpt", 64)] {
        let half = build(&shadow(integrator, r#""float alpha" 0.5"#), "half.pbrt");
        let none = build(&shadow(integrator, r#""float alpha" 0"#), "none.pbrt");
        let h = mean_y(&render(&half, spp, 1), &render(&half, spp, 2), |_, _| true);
        let n = mean_y(&render(&none, spp, 1), &render(&none, spp, 2), |_, _| true);
        ratio_is(h, n, 0.5, 0.02, &format!("{integrator}: shadow of alpha 0.5"));
    }
}

/// A quad filling the view exactly, with 4 × 4 checks of alpha 1 and 0 (a `checkerboard` float texture over its
/// (u, v)), each check 4 × 4 pixels: a black quad in front of an emitter leaves the emitter visible exactly in the
/// checks of alpha 0, and the same checks on an emitter itself (nothing behind it) emit exactly in the checks of
/// alpha 1 (pbrt-v4 masks an area light's emission with the shape's alpha), for `path` and for `bdpt`.
#[test]
fn a_checkerboard_alpha_cuts_the_expected_pattern() {
    let scene = |integrator: &str, cut_out_is_emitter: bool| {
        let (front, behind) = if cut_out_is_emitter {
            (r#"AreaLightSource "diffuse" "spectrum L" [ 360 1 830 1 ]"#, "")
        } else {
            (
                r#"Material "diffuse" "rgb reflectance" [ 0 0 0 ]"#,
                r#"AttributeBegin
AreaLightSource "diffuse" "spectrum L" [ 360 1 830 1 ]
Shape "trianglemesh" "point3 P" [ -9 -9 -1  9 -9 -1  9 9 -1  -9 9 -1 ] "integer indices" [ 0 1 2 0 2 3 ]
AttributeEnd"#,
            )
        };
        format!(
            r#"LookAt 0 0 1  0 0 0  0 1 0
Camera "perspective" "float fov" 90
Film "rgb" "integer xresolution" 16 "integer yresolution" 16 "string filename" "checks.exr"
PixelFilter "box"
Integrator "{integrator}" "integer maxdepth" 5
WorldBegin
Texture "checks" "float" "checkerboard" "float tex1" 1 "float tex2" 0 "float uscale" 4 "float vscale" 4
{behind}
AttributeBegin
{front}
Shape "trianglemesh" "point3 P" [ -1 -1 0  1 -1 0  1 1 0  -1 1 0 ] "integer indices" [ 0 1 2 0 2 3 ]
    "point2 uv" [ 0 0  1 0  1 1  0 1 ] "texture alpha" "checks"
AttributeEnd
"#
        )
    };
    for integrator in ["path", "bdpt"] {
        for emitter in [false, true] {
            let film = render(&build(&scene(integrator, emitter), "checks.pbrt"), 16, 1);
            for py in 0..16 {
                for px in 0..16 {
                    // u = (x + 1)/2 and v = (y + 1)/2 over the quad, and the check is even (tex1, alpha 1) when
                    // ⌊4u⌋ + ⌊4v⌋ is even. Row 0 of the image is the top (v near 1) and, pbrt's LookAt being
                    // left-handed, column 0 is at x = +1 (u near 1): ⌊4u⌋ = 3 − px/4, ⌊4v⌋ = 3 − py/4.
                    let opaque = (px / 4 + py / 4) % 2 == 0;
                    let lit = opaque == emitter;
                    let y = film.pixel_xyz(px, py).y;
                    let what = format!("{integrator}, emitter {emitter}: pixel ({px}, {py}) = {y}");
                    if lit {
                        assert!((y - 1.0).abs() < 0.1, "{what}, expected about 1");
                    } else {
                        assert_eq!(y, 0.0, "{what}, expected 0");
                    }
                }
            }
        }
    }
}

/// An emitter with 4 × 4 checks of alpha 1 and 0 lights the point of the floor below its centre with exactly half of
/// what the whole emitter gives: a quarter turn about the axis swaps the two kinds of checks and the diagonal
/// mirror keeps them, so the irradiance there splits evenly, and the small spot the camera sees (symmetric about
/// the plane of the camera) keeps that to second order. Light sampling, emitter hits and (for `bdpt`) light paths
/// all see the masked emission. (A light path starting on a masked point is empty; `bdpt` must still run its s = 1
/// strategies then, or it loses about half their light.)
#[test]
fn a_checkerboard_alpha_emitter_gives_half_its_light() {
    let scene = |integrator: &str, alpha: &str| {
        format!(
            r#"LookAt 1 0 3  0 0 0  0 0 1
Camera "perspective" "float fov" 2
Film "rgb" "integer xresolution" 8 "integer yresolution" 8 "string filename" "half.exr"
PixelFilter "box"
Integrator "{integrator}" "integer maxdepth" 1
WorldBegin
Texture "checks" "float" "checkerboard" "float tex1" 1 "float tex2" 0 "float uscale" 4 "float vscale" 4
Material "diffuse" "rgb reflectance" [ 0.5 0.5 0.5 ]
Shape "trianglemesh" "point3 P" [ -5 -5 0  5 -5 0  5 5 0  -5 5 0 ] "integer indices" [ 0 1 2 0 2 3 ]
AttributeBegin
Material "diffuse" "rgb reflectance" [ 0 0 0 ]
AreaLightSource "diffuse" "spectrum L" [ 360 1 830 1 ]
Shape "trianglemesh" "point3 P" [ -0.5 -0.5 2  -0.5 0.5 2  0.5 0.5 2  0.5 -0.5 2 ] "integer indices" [ 0 1 2 0 2 3 ]
    "point2 uv" [ 0 0  0 1  1 1  1 0 ] {alpha}
AttributeEnd
"#
        )
    };
    for (integrator, spp) in [("path", 256), ("volpath", 256), ("bdpt", 256)] {
        let half = build(&scene(integrator, r#""texture alpha" "checks""#), "checks.pbrt");
        let full = build(&scene(integrator, ""), "full.pbrt");
        let h = mean_y(&render(&half, spp, 1), &render(&half, spp, 2), |_, _| true);
        let f = mean_y(&render(&full, spp, 1), &render(&full, spp, 2), |_, _| true);
        ratio_is(h, f, 0.5, 0.02, &format!("{integrator}: checkerboard emitter"));
    }
}

/// An area light on a shape of alpha 0 is pbrt-v4's invisible light: the camera does not see it (the pixels it
/// would cover stay black), yet it lights the floor as the visible one does (found by light sampling only, as a
/// delta light for MIS), with `path` and `bdpt`.
#[test]
fn an_area_light_of_alpha_zero_is_invisible_but_lights_the_scene() {
    let scene = |integrator: &str, alpha: &str| {
        format!(
            r#"LookAt 0 -4 1  0 0 0.5  0 0 1
Camera "perspective" "float fov" 60
Film "rgb" "integer xresolution" 16 "integer yresolution" 16 "string filename" "invisible.exr"
PixelFilter "box"
Integrator "{integrator}" "integer maxdepth" 3
WorldBegin
Material "diffuse" "rgb reflectance" [ 0.5 0.5 0.5 ]
Shape "trianglemesh" "point3 P" [ -10 -10 0  10 -10 0  10 10 0  -10 10 0 ] "integer indices" [ 0 1 2 0 2 3 ]
AttributeBegin
Material "diffuse" "rgb reflectance" [ 0 0 0 ]
AreaLightSource "diffuse" "rgb L" [ 4 4 4 ]
Shape "trianglemesh" "point3 P" [ -0.5 -0.5 2  -0.5 0.5 2  0.5 0.5 2  0.5 -0.5 2 ] "integer indices" [ 0 1 2 0 2 3 ] {alpha}
AttributeEnd
"#
        )
    };
    // Rows 10–15 see the floor; rows 0–5 look above the floor's far edge, where only the light could be.
    let floor = |_: u32, y: u32| y >= 10;
    for integrator in ["path", "bdpt"] {
        let visible = build(&scene(integrator, ""), "visible.pbrt");
        let invisible = build(&scene(integrator, r#""float alpha" 0"#), "invisible.pbrt");
        let (v1, v2) = (render(&visible, 64, 1), render(&visible, 64, 2));
        let (i1, i2) = (render(&invisible, 64, 1), render(&invisible, 64, 2));
        let sky = |f: &Film| {
            let mut m = 0.0f64;
            for y in 0..6 {
                for x in 0..16 {
                    m = m.max(f.pixel_xyz(x, y).y);
                }
            }
            m
        };
        assert!(sky(&v1) > 1.0, "{integrator}: the visible light is seen");
        assert_eq!(sky(&i1), 0.0, "{integrator}: the invisible light is seen");
        ratio_is(mean_y(&i1, &i2, floor), mean_y(&v1, &v2, floor), 1.0, 0.02, &format!("{integrator}: floor"));
    }
}

/// The stochastic alpha test hashes the ray, not the thread: a scene with a cut-out of alpha 0.5 renders bit for bit
/// the same in pools of one and two threads, with `path` and with `bdpt` (whose light paths are splatted).
#[test]
fn alpha_images_do_not_depend_on_the_thread_count() {
    for integrator in ["path", "bdpt"] {
        let built = build(&room(integrator, &blocker(r#""float alpha" 0.5"#)), "threads.pbrt");
        let films: Vec<Film> = [1, 2]
            .into_iter()
            .map(|n| rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap().install(|| render(&built, 4, 7)))
            .collect();
        assert_identical(&films[0], &films[1], integrator);
    }
}

/// An alpha outside [0, 1] is an error naming the parameter with its file, line and column; so is an unknown
/// texture.
#[test]
fn bad_alpha_is_an_error() {
    for (alpha, expected) in [(r#""float alpha" 1.5"#, "'alpha'"), (r#""texture alpha" "nothing""#, "'nothing'")] {
        let e = build_error(&room("path", &blocker(alpha)), "bad.pbrt");
        assert!(e.contains(expected) && e.contains("bad.pbrt:19:"), "{alpha}: {e}");
    }
}

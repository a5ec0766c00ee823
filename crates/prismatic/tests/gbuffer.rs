//! pbrt-v4's `Film "gbuffer"` end to end, against closed forms:
//!
//! - position and depth derivatives of planes seen by a perspective camera (facing it: dz/dx = dz/dy = 0; tilted:
//!   the change of depth over one pixel, averaged over the pixel) and by an orthographic one (a constant slope);
//! - geometric and shading normals and the (u, v) of a bilinear quad, in camera and world coordinates;
//! - the variance of the samples' colour: 0 where every sample sees black, the colour noise of the wavelength
//!   sampling where every sample sees an emitter, and the compound Bernoulli variance where half of them do;
//! - every integrator writes the same geometry for the same camera samples, and the buffers do not depend on the
//!   number of threads;
//! - the command line's `--aovs` writes the same channels on an `rgb` and a `spectral` film, bit for bit those of
//!   `Film "gbuffer"`, with the depth, its change and the normal of a tilted plane.

use std::path::Path;

use film::{Film, GBufferPixel};
use render::BuiltScene;
use spectral::SampledSpectrum;

mod support;
use support::build;

fn render(built: &BuiltScene) -> Film {
    let mut film = Film::new(built.film.clone()).unwrap();
    built.integrator.render(&built.scene, &mut film, 0..built.spp, 1, &|_| {}).unwrap();
    film
}

/// A W×H gbuffer render with a box filter over the pixel (so a pixel's value is its mean over the pixel's area)
/// of `world` (after `WorldBegin`, under a white sky), seen by `camera` (LookAt and Camera lines), `spp` samples
/// per pixel (iterations for sppm).
fn scene(camera: &str, w: u32, h: u32, spp: u32, system: &str, integrator: &str, world: &str) -> String {
    // Photon mapping's passes are its iterations.
    let iterations = if integrator == "sppm" { format!(" \"integer iterations\" {spp}") } else { String::new() };
    format!(
        "{camera}\n\
         Film \"gbuffer\" \"integer xresolution\" {w} \"integer yresolution\" {h} \"string filename\" \"g.exr\"\n\
             \"string coordinatesystem\" \"{system}\"\n\
         PixelFilter \"box\" \"float xradius\" 0.5 \"float yradius\" 0.5\n\
         Sampler \"zsobol\" \"integer pixelsamples\" {spp}\n\
         Integrator \"{integrator}\" \"integer maxdepth\" 3{iterations}\n\
         WorldBegin\n\
         LightSource \"infinite\" \"rgb L\" [ 1 1 1 ]\n\
         {world}\n"
    )
}

fn pixel(film: &Film, x: u32, y: u32) -> GBufferPixel {
    film.pixel_gbuffer(x, y).unwrap()
}

/// Screen coordinates of the centre of pixel (x, y) of a W×H image with the screen window [−1, 1]², and the
/// width of a pixel on the screen.
fn screen(x: u32, y: u32, w: u32, h: u32) -> (f64, f64, f64, f64) {
    let (dx, dy) = (2.0 / w as f64, 2.0 / h as f64);
    (-1.0 + (x as f64 + 0.5) * dx, 1.0 - (y as f64 + 0.5) * dy, dx, dy)
}

/// Perspective camera at the origin looking down +z (camera space is world space), fov 60°: the ray through
/// screen point (sx, sy) is along (k·sx, k·sy, 1) with k = tan 30°.
const PERSPECTIVE: &str = "LookAt 0 0 0  0 0 1  0 1 0\nCamera \"perspective\" \"float fov\" 60";

/// The slope b of the plane z = 5 + b·y of [`tilted_quad`].
const TILT: f64 = 0.5;

/// A quad on the plane z = 5 + b·y, far wider than a 60° view of it.
fn tilted_quad(b: f64) -> String {
    format!(
        "Shape \"bilinearmesh\" \"point3 P\" [ -20 -20 {z0}  20 -20 {z0}  -20 20 {z1}  20 20 {z1} ]",
        z0 = 5.0 - 20.0 * b,
        z1 = 5.0 + 20.0 * b
    )
}

/// The mean depth over pixel row `y` of an H-row image of [`PERSPECTIVE`] looking at the plane z = 5 + b·y, and
/// its change to the next row, both averaged over the pixel.
///
/// Along the ray t·(k·sx, k·sy, 1) the depth is z(sy) = 5/(1 − c·sy) with c = b·k, the same for the pixel to the
/// right (dz/dx = 0), and one pixel down (sy − Δ) it changes by z(sy − Δ) − z(sy). The pixel's mean over
/// sy ∈ [s0, s1] is (5/c)·[ln(1 − c·s0) − ln(1 − c·s1)]/Δ.
fn tilted_depth_and_change(b: f64, y: u32, h: u32) -> (f64, f64) {
    let c = b * (30f64).to_radians().tan();
    let mean_depth = |s0: f64, s1: f64| (5.0 / c) * ((1.0 - c * s0).ln() - (1.0 - c * s1).ln()) / (s1 - s0);
    let (_, sy, _, d) = screen(0, y, h, h);
    let (s0, s1) = (sy - d / 2.0, sy + d / 2.0);
    let depth = mean_depth(s0, s1);
    (depth, mean_depth(s0 - d, s1 - d) - depth)
}

#[test]
fn depth_and_its_change_per_pixel_on_planes_seen_by_a_perspective_camera() {
    let k = (30f64).to_radians().tan();
    let (w, h) = (8, 8);
    // Facing the camera at z = 5: P = 5·(k·sx, k·sy, 1), linear over the pixel, so its mean is the value at the
    // centre; the neighbouring pixels' rays meet the plane at the same depth: dz/dx = dz/dy = 0.
    let quad = "Shape \"bilinearmesh\" \"point3 P\" [ -20 -20 5  20 -20 5  -20 20 5  20 20 5 ]";
    let film = render(&build(&scene(PERSPECTIVE, w, h, 64, "camera", "path", quad), "gbuffer.pbrt"));
    for y in 0..h {
        for x in 0..w {
            let (sx, sy, _, _) = screen(x, y, w, h);
            let px = pixel(&film, x, y);
            let want = [5.0 * k * sx, 5.0 * k * sy, 5.0];
            for c in 0..3 {
                // A pixel is 0.72 wide at z = 5: 0.01 is far below a pixel's offset.
                assert!((px.p[c] - want[c]).abs() < 0.01, "({x}, {y}): P {:?} vs {want:?}", px.p);
            }
            assert!(px.dz[0] < 1e-5 && px.dz[1] < 1e-5, "({x}, {y}): dz {:?}", px.dz);
        }
    }
    // Tilted about the x axis, z = 5 + b·y (see tilted_depth_and_change).
    let film = render(&build(&scene(PERSPECTIVE, w, h, 64, "camera", "path", &tilted_quad(TILT)), "gbuffer.pbrt"));
    for y in 0..h {
        for x in 0..w {
            let (depth, change) = tilted_depth_and_change(TILT, y, h);
            let px = pixel(&film, x, y);
            assert!((px.p[2] - depth).abs() < 1e-3 * depth, "({x}, {y}): z {} vs {depth}", px.p[2]);
            // pbrt-v4 writes |dz/dy|; the derivative at the centre (what a scaled differential would tend to)
            // differs from the change over a pixel by ~c·Δ ≈ 7%.
            assert!((px.dz[1] - change.abs()).abs() < 2e-3 * change.abs(), "({x}, {y}): {} vs {change}", px.dz[1]);
            assert!(px.dz[0] < 1e-5, "({x}, {y}): dz/dx {}", px.dz[0]);
        }
    }
}

#[test]
fn a_moving_cameras_space_is_the_one_at_each_samples_time() {
    // The camera slides 2 along x while the shutter is open, in front of a plane facing it. In camera space each
    // sample's point is where its ray meets the plane as seen from where the camera then was: 5·(k·sx, k·sy, 1),
    // as for a still camera. In world space the points of a pixel spread over the slide: their mean is shifted by
    // the camera's mean position, 1 (the start-time camera space would put them up to 2 off).
    let k = (30f64).to_radians().tan();
    let (w, h) = (6, 6);
    let quad = "Shape \"bilinearmesh\" \"point3 P\" [ -20 -20 5  20 -20 5  -20 20 5  20 20 5 ]";
    let moving = "ActiveTransform EndTime\nTranslate -2 0 0\nActiveTransform All\n".to_string() + PERSPECTIVE;
    for (system, shift) in [("camera", 0.0), ("world", 1.0)] {
        let film = render(&build(&scene(&moving, w, h, 64, system, "volpath", quad), "gbuffer.pbrt"));
        for y in 0..h {
            for x in 0..w {
                let (sx, sy, _, _) = screen(x, y, w, h);
                let px = pixel(&film, x, y);
                let want = [5.0 * k * sx + shift, 5.0 * k * sy, 5.0];
                for c in 0..3 {
                    assert!((px.p[c] - want[c]).abs() < 0.02, "{system} ({x}, {y}): P {:?} vs {want:?}", px.p);
                }
                assert!(px.dz[0] < 1e-5 && px.dz[1] < 1e-5, "{system} ({x}, {y}): dz {:?}", px.dz);
            }
        }
    }
}

#[test]
fn an_orthographic_camera_sees_a_constant_slope_and_world_coordinates_are_the_scenes() {
    // z = 5 + a·x under an orthographic camera: x is the screen x, so dz/dx = a·Δ and dz/dy = 0 everywhere.
    let (w, h, a) = (6, 4, 0.75);
    let quad = format!(
        "Shape \"bilinearmesh\" \"point3 P\" [ -3 -3 {z0}  3 -3 {z1}  -3 3 {z0}  3 3 {z1} ]",
        z0 = 5.0 - 3.0 * a,
        z1 = 5.0 + 3.0 * a
    );
    let ortho = "LookAt 0 0 0  0 0 1  0 1 0\nCamera \"orthographic\" \"float screenwindow\" [ -1 1 -1 1 ]";
    let film = render(&build(&scene(ortho, w, h, 16, "camera", "volpath", &quad), "gbuffer.pbrt"));
    for y in 0..h {
        for x in 0..w {
            let (sx, sy, dx, _) = screen(x, y, w, h);
            let px = pixel(&film, x, y);
            assert!((px.dz[0] - a * dx).abs() < 1e-5 && px.dz[1] < 1e-5, "({x}, {y}): {:?}", px.dz);
            let want = [sx, sy, 5.0 + a * sx];
            for c in 0..3 {
                assert!((px.p[c] - want[c]).abs() < 0.01, "({x}, {y}): {:?} vs {want:?}", px.p);
            }
        }
    }
    // The same plane seen from the side by a camera at (−10, 0, 5) looking down +x, in world coordinates: P is the
    // hit in the scene's coordinates, on the plane, and dz/dx is the world z's change per pixel (pbrt-v4 takes the
    // z of dp/dx in the output coordinate system).
    let side = "LookAt -10 0 5  0 0 5  0 1 0\nCamera \"orthographic\" \"float screenwindow\" [ -1 1 -1 1 ]";
    let wall = "Shape \"bilinearmesh\" \"point3 P\" [ 0 -3 -3  0 3 -3  0 -3 13  0 3 13 ]";
    let film = render(&build(&scene(side, w, h, 16, "world", "path", wall), "gbuffer.pbrt"));
    for y in 0..h {
        for x in 0..w {
            let (sx, sy, dx, _) = screen(x, y, w, h);
            let px = pixel(&film, x, y);
            // Camera x is world −z here (right = up × forward = y × x = −z).
            let want = [0.0, sy, 5.0 - sx];
            for c in 0..3 {
                assert!((px.p[c] - want[c]).abs() < 0.01, "({x}, {y}): {:?} vs {want:?}", px.p);
            }
            assert!((px.dz[0] - dx).abs() < 1e-5 && px.dz[1] < 1e-5, "({x}, {y}): {:?}", px.dz);
            // The geometric normal faces the camera: world −x.
            assert!((px.n[0] + 1.0).abs() < 1e-6 && px.n[1].abs() < 1e-6 && px.n[2].abs() < 1e-6, "{:?}", px.n);
        }
    }
}

#[test]
fn normals_and_uv_of_a_bilinear_quad() {
    // A quad filling an orthographic view, its per-vertex normals all tilted by atan(3/4) about y: the geometric
    // normal faces the camera, the shading normal is the tilted one; u runs from the left edge to the right one
    // and v from the bottom edge to the top, linear in the screen position, so a pixel's mean is its centre's.
    let (w, h) = (8, 6);
    let quad = "Shape \"bilinearmesh\" \"point3 P\" [ -1 -1 5  1 -1 5  -1 1 5  1 1 5 ]\n\
                \"normal N\" [ 0.6 0 -0.8  0.6 0 -0.8  0.6 0 -0.8  0.6 0 -0.8 ]";
    for (look, system, ng, ns) in [
        ("LookAt 0 0 0  0 0 1  0 1 0", "camera", [0.0, 0.0, -1.0], [0.6, 0.0, -0.8]),
        // The camera turned upside down about its axis: camera x and y are world −x and −y.
        ("LookAt 0 0 0  0 0 1  0 -1 0", "camera", [0.0, 0.0, -1.0], [-0.6, 0.0, -0.8]),
        ("LookAt 0 0 0  0 0 1  0 -1 0", "world", [0.0, 0.0, -1.0], [0.6, 0.0, -0.8]),
    ] {
        let camera = format!("{look}\nCamera \"orthographic\" \"float screenwindow\" [ -1 1 -1 1 ]");
        let built = build(&scene(&camera, w, h, 16, system, "path", quad), "gbuffer.pbrt");
        let film = render(&built);
        let aovs = film.to_aov_images().unwrap();
        let flipped = look.contains("0 -1 0");
        for y in 0..h {
            for x in 0..w {
                let (sx, sy, _, _) = screen(x, y, w, h);
                let (wx, wy) = if flipped { (-sx, -sy) } else { (sx, sy) };
                let px = pixel(&film, x, y);
                let uv = [(wx + 1.0) / 2.0, (wy + 1.0) / 2.0];
                // A pixel spans 1/8 of u and 1/6 of v.
                assert!((px.uv[0] - uv[0]).abs() < 0.005 && (px.uv[1] - uv[1]).abs() < 0.005, "{:?}", px.uv);
                let n_s = aovs.normal[(y * w + x) as usize];
                for c in 0..3 {
                    assert!((px.n[c] - ng[c]).abs() < 1e-6, "{look} {system}: N {:?}", px.n);
                    assert!((n_s[c] as f64 - ns[c]).abs() < 1e-5, "{look} {system}: Ns {n_s:?}");
                }
            }
        }
    }
}

/// The colour of an emitter of constant spectral radiance 1 as the film records one sample of it, over the
/// wavelength sampler's whole range: its mean and variance per channel (midpoint rule over u ∈ [0, 1)).
fn emitter_colour_statistics(film: &Film) -> ([f64; 3], [f64; 3]) {
    let n = 200_000;
    let l = SampledSpectrum::splat(1.0);
    let colours: Vec<[f64; 3]> = (0..n)
        .map(|i| {
            let wl = film.sample_wavelengths((i as f64 + 0.5) / n as f64);
            film.spec().color_space.to_rgb(film.conversion().xyz(&l, &wl))
        })
        .collect();
    let mean = [0, 1, 2].map(|c| colours.iter().map(|v| v[c]).sum::<f64>() / n as f64);
    let var = [0, 1, 2].map(|c| colours.iter().map(|v| (v[c] - mean[c]).powi(2)).sum::<f64>() / n as f64);
    (mean, var)
}

#[test]
fn variance_is_zero_on_black_the_colour_noise_on_an_emitter_and_bernoulli_across_its_edge() {
    // An orthographic 4×4 view of a black wall; a black emitter of constant radiance 1 covers the screen's
    // x < 0.25: columns 0 and 1 whole, column 2 half (its samples are uniform over the pixel: box filter), column 3
    // not at all. Every sample sees a surface; its colour is the emitter's colour c (random through the sampled
    // wavelengths: mean μ, variance σ²) or black. Per pixel, with p the fraction on the emitter, the colour's
    // variance is p·(σ² + μ²) − p²·μ²: σ² on the emitter, 0 beside it, σ²/2 + μ²/4 across the edge. (Counting only
    // the emitter's samples would give σ² there, and counting the filter weights would change nothing: they are
    // equal.)
    let world = "Material \"diffuse\" \"rgb reflectance\" [ 0 0 0 ]\n\
                 Shape \"bilinearmesh\" \"point3 P\" [ -9 -9 10  9 -9 10  -9 9 10  9 9 10 ]\n\
                 AttributeBegin\n\
                   AreaLightSource \"diffuse\" \"spectrum L\" [ 360 1 830 1 ] \"bool twosided\" true\n\
                   Shape \"bilinearmesh\" \"point3 P\" [ -3 -3 5  0.25 -3 5  -3 3 5  0.25 3 5 ]\n\
                 AttributeEnd";
    let ortho = "LookAt 0 0 0  0 0 1  0 1 0\nCamera \"orthographic\" \"float screenwindow\" [ -1 1 -1 1 ]";
    let built = build(&scene(ortho, 4, 4, 256, "camera", "path", world), "gbuffer.pbrt");
    let film = render(&built);
    let (mu, sigma2) = emitter_colour_statistics(&film);
    let n = 256.0;
    for y in 0..4 {
        for (x, p) in [(0, 1.0), (1, 1.0), (2, 0.5), (3, 0.0)] {
            let px = pixel(&film, x, y);
            assert_eq!(px.count, n, "({x}, {y}): every sample saw a surface");
            let rgb = film.to_rgb_image()[(y * 4 + x) as usize];
            for c in 0..3 {
                // The sample variance of n samples estimates n/(n−1) times the population's.
                let want = (p * (sigma2[c] + mu[c] * mu[c]) - p * p * mu[c] * mu[c]) * n / (n - 1.0);
                let got = px.variance[c];
                if p == 0.0 {
                    assert_eq!((got, px.relative_variance[c]), (0.0, 0.0), "({x}, {y}) black: {px:?}");
                    continue;
                }
                // The pixel's colour is the mean, μ·p (the wavelengths are stratified over the pixel's samples).
                assert!((rgb[c] as f64 - p * mu[c]).abs() < 0.01 * mu[c], "({x}, {y}) {c}: {rgb:?} vs {mu:?}");
                assert!((px.mean[c] - rgb[c] as f64).abs() < 1e-6 * mu[c], "({x}, {y}) {c}");
                // Statistical: each pixel's sample variance scatters about its expectation (by at most 1.5% over
                // these 12 pixels and 3 channels when this was written); 5% leaves room and still excludes σ²
                // alone at the edge (a quarter of the expectation there).
                assert!((got - want).abs() < 0.05 * want, "({x}, {y}) {c}: variance {got} vs {want}");
                let rel = want / (p * mu[c]);
                assert!((px.relative_variance[c] - rel).abs() < 0.05 * rel.abs(), "({x}, {y}) {c}: {px:?}");
            }
        }
    }
    // The colour noise is real here (the test would not tell σ² from 0 otherwise), and the edge's Bernoulli term
    // is not a small correction.
    for c in 0..3 {
        assert!(sigma2[c] > 1e-3 * mu[c] * mu[c], "σ² {sigma2:?} μ {mu:?}");
    }
}

/// A small room: a diffuse floor and back wall, a sphere with per-vertex-free geometry, a disk light.
const ROOM: &str = "Material \"diffuse\" \"rgb reflectance\" [ 0.6 0.5 0.4 ]\n\
    Shape \"bilinearmesh\" \"point3 P\" [ -12 -1 -4  12 -1 -4  -12 -1 8  12 -1 8 ]\n\
    Shape \"bilinearmesh\" \"point3 P\" [ -12 -1 6  12 -1 6  -12 12 6  12 12 6 ]\n\
    AttributeBegin\n\
      Translate 0.3 0 3\n\
      Material \"coateddiffuse\" \"rgb reflectance\" [ 0.2 0.4 0.7 ]\n\
      Shape \"sphere\" \"float radius\" 0.8\n\
    AttributeEnd\n\
    AttributeBegin\n\
      AreaLightSource \"diffuse\" \"rgb L\" [ 6 6 6 ]\n\
      Translate 0 3.5 3 Rotate 90 1 0 0\n\
      Shape \"disk\" \"float radius\" 0.7\n\
    AttributeEnd";

#[test]
fn every_integrator_writes_the_same_geometry_and_no_thread_count_changes_the_buffers() {
    let camera = "LookAt 0 1 -3  0 0.5 3  0 1 0\nCamera \"perspective\" \"float fov\" 50";
    let mut reference: Option<film::GBufferImages> = None;
    for integrator in ["path", "volpath", "bdpt", "lightpath", "sppm"] {
        let built = build(&scene(camera, 12, 9, 4, "camera", integrator, ROOM), "gbuffer.pbrt");
        let mut films = Vec::new();
        for threads in [1, 3] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            films.push(pool.install(|| render(&built)));
        }
        let (one, three) = (&films[0], &films[1]);
        let g = one.to_gbuffer_images().unwrap();
        assert_eq!(Some(&g), three.to_gbuffer_images().as_ref(), "{integrator}: the thread count changed the buffers");
        assert_eq!(one.to_aov_images(), three.to_aov_images(), "{integrator}");
        assert_eq!(one.to_rgb_image(), three.to_rgb_image(), "{integrator}");
        // Geometry comes from the camera samples, the same for every integrator (sppm weighs each iteration 1
        // rather than by its filter weight, which rounds differently).
        let reference = reference.get_or_insert_with(|| g.clone());
        for i in 0..g.p.len() {
            for c in 0..3 {
                assert!((g.p[i][c] - reference.p[i][c]).abs() < 1e-4, "{integrator} pixel {i}: P");
                assert!((g.n[i][c] - reference.n[i][c]).abs() < 1e-4, "{integrator} pixel {i}: N");
            }
            for c in 0..2 {
                assert!((g.uv[i][c] - reference.uv[i][c]).abs() < 1e-4, "{integrator} pixel {i}: uv");
                assert!((g.dz[i][c] - reference.dz[i][c]).abs() < 1e-4, "{integrator} pixel {i}: dz");
            }
        }
        // The room is closed towards the camera's view: every pixel sees a surface at a depth in the room.
        assert!(g.p.iter().all(|p| p[2] > 1.0 && p[2] < 12.0), "{integrator}: {:?}", g.p);
        // Photon mapping's pixels are not means of samples: no variance. The light tracer's camera samples carry
        // only emission seen directly (its light paths are splats, as in pbrt-v4): variance only where the light
        // is seen, here nowhere. The others' samples are noisy.
        let noisy = g.variance.iter().filter(|v| v[1] > 0.0).count();
        match integrator {
            "sppm" | "lightpath" => assert_eq!(noisy, 0, "{integrator}"),
            _ => assert!(noisy > g.p.len() / 2, "{integrator}: {noisy} pixels with variance"),
        }
    }
}

/// Runs `prismatic render` in `dir` with `args`.
fn prismatic(dir: &Path, args: &[&str]) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_prismatic"))
        .arg("render")
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

/// pbrt-v4's gbuffer channels in its order.
const GBUFFER_CHANNELS: [&str; 22] = [
    "Albedo.R",
    "Albedo.G",
    "Albedo.B",
    "P.X",
    "P.Y",
    "P.Z",
    "dzdx",
    "dzdy",
    "N.X",
    "N.Y",
    "N.Z",
    "Ns.X",
    "Ns.Y",
    "Ns.Z",
    "u",
    "v",
    "Variance.R",
    "Variance.G",
    "Variance.B",
    "RelativeVariance.R",
    "RelativeVariance.G",
    "RelativeVariance.B",
];

/// `--aovs` on an `rgb` and on a `spectral` film writes pbrt-v4's gbuffer channels, bit for bit those of the same
/// scene rendered with `Film "gbuffer"` (the same camera samples: geometry, albedo and the colour's variance), and
/// they are right: on the tilted plane z = 5 + b·y the depth and its change per row are the closed forms of
/// [`tilted_depth_and_change`], and both normals are the plane's, (0, b, −1)/√(1 + b²) in camera space (facing the
/// camera at the origin).
#[test]
fn aovs_on_any_film_write_the_gbuffer_channels() {
    let dir = std::env::temp_dir().join(format!("prismatic-gbuffer-aovs-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let (w, h) = (6, 6);
    let text = scene(PERSPECTIVE, w, h, 64, "camera", "volpath", &tilted_quad(TILT));
    std::fs::write(dir.join("gbuffer.pbrt"), &text).unwrap();
    prismatic(&dir, &["gbuffer.pbrt", "--quiet", "-o", "gbuffer.exr"]);
    let (_, _, reference) = film::read_exr_channels(&dir.join("gbuffer.exr")).unwrap();
    let channel = |channels: &film::NamedChannels, name: &str| -> Vec<f32> {
        channels.iter().find(|(n, _)| n == name).unwrap_or_else(|| panic!("no channel {name}")).1.clone()
    };
    let len = (1.0 + TILT * TILT).sqrt();
    let normal = [0.0, TILT / len, -1.0 / len];
    for kind in ["rgb", "spectral"] {
        let other = text
            .replace("Film \"gbuffer\"", &format!("Film \"{kind}\""))
            .replace("\"string coordinatesystem\" \"camera\"", "");
        std::fs::write(dir.join(format!("{kind}.pbrt")), other).unwrap();
        let out = format!("{kind}.exr");
        prismatic(&dir, &[&format!("{kind}.pbrt"), "--aovs", "--quiet", "-o", &out]);
        let (_, _, channels) = film::read_exr_channels(&dir.join(&out)).unwrap();
        let names: Vec<&str> = channels.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names.iter().filter(|n| n.starts_with("S0.")).count() > 0, kind == "spectral", "{names:?}");
        for name in GBUFFER_CHANNELS.iter().chain(["R", "G", "B"].iter()) {
            let (got, want) = (channel(&channels, name), channel(&reference, name));
            assert!(got.iter().zip(&want).all(|(a, b)| a.to_bits() == b.to_bits()), "{kind}: {name} differs");
        }
        let (pz, dzdx, dzdy) = (channel(&channels, "P.Z"), channel(&channels, "dzdx"), channel(&channels, "dzdy"));
        let n: Vec<Vec<f32>> = ["N.X", "N.Y", "N.Z", "Ns.X", "Ns.Y", "Ns.Z"].map(|c| channel(&channels, c)).into();
        for y in 0..h {
            let (depth, change) = tilted_depth_and_change(TILT, y, h);
            for x in 0..w {
                let i = (y * w + x) as usize;
                assert!((pz[i] as f64 - depth).abs() < 1e-3 * depth, "{kind} ({x}, {y}): z {} vs {depth}", pz[i]);
                let dz = dzdy[i] as f64;
                assert!((dz - change.abs()).abs() < 2e-3 * change.abs(), "{kind} ({x}, {y}): dz/dy {dz} vs {change}");
                assert!(dzdx[i].abs() < 1e-5, "{kind} ({x}, {y}): dz/dx {}", dzdx[i]);
                for c in 0..6 {
                    let want = normal[c % 3];
                    assert!(
                        (n[c][i] as f64 - want).abs() < 1e-5,
                        "{kind} ({x}, {y}): normal {c} {} vs {want}",
                        n[c][i]
                    );
                }
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

//! pbrt-v4's realistic camera with glass per element: a small off-axis source imaged through a BK7 singlet lands,
//! spectral bucket by bucket, where an independent real-ray trace of the same prescription puts it, spreads as that
//! trace's defocus says, and shows no colour at all through the same lens with a constant index.

mod support;

use std::path::Path;

use film::Film;
use glam::DVec2;
use optics::{LensPrescription, LensRay};
use render::BuiltScene;
use spectral::WavelengthStrategy;
use support::{build, build_error, temp_dir};

/// A plano-convex N-BK7 singlet (R = 51.5 mm, f ≈ 100 mm) with its stop 80 mm in front of it, so that off-axis
/// chief rays cross the glass away from its centre and lateral colour is large enough to measure.
const SINGLET: &str = "0 80 0 8\n51.5 3.6 N-BK7 25.4\n0 97.6 1 25.4\n";

/// The film: 35 mm diagonal (pbrt-v4's default), 3600 × 2400 pixels of 8.1 µm.
const RES: (u32, u32) = (3600, 2400);
const DIAGONAL_MM: f64 = 35.0;
/// The source: an emissive sphere 2 m in front of the film, 0.2 m off the axis (its image about 10 mm off axis).
const SOURCE: [f64; 3] = [0.16, 0.12, 2.0];
const SOURCE_RADIUS_M: f64 = 4e-4;
/// Buckets of 40 nm centred on 450, 490, …, 650 nm.
const BUCKETS: (f64, f64, usize) = (430.0, 670.0, 6);
const FOCUS_M: f64 = 2.0;

/// Half the film's width and height, mm (pbrt-v4's physical extent).
fn film_half_mm() -> [f64; 2] {
    let aspect = RES.1 as f64 / RES.0 as f64;
    let w = (DIAGONAL_MM * DIAGONAL_MM / (1.0 + aspect * aspect)).sqrt();
    [0.5 * w, 0.5 * aspect * w]
}

/// The independent prediction: rays from the source's centre through a 64 × 64 grid over the stop (the first
/// surface; a distant point source lights it evenly), traced with `optics` at `lambda_nm` through the lens focused
/// as the camera focuses it, to the film; their landing points in raster pixels.
fn landing_points(lens_text: &str, lambda_nm: f64, source: [f64; 3]) -> Vec<DVec2> {
    let lens = LensPrescription::parse(lens_text).unwrap();
    let lens = lens.focused(FOCUS_M * 1000.0, render::FOCUS_WAVELENGTH_NM).unwrap();
    let film_z = lens.length_mm();
    let stop_r = 0.5 * lens.surfaces[0].aperture_mm;
    // Camera space is world space here (LookAt from the origin along +z, up +y); lens space has its z from the
    // front vertex towards the film, in mm.
    let s = [source[0] * 1e3, source[1] * 1e3, film_z - source[2] * 1e3];
    let half = film_half_mm();
    let mut out = Vec::new();
    for i in 0..64 {
        for j in 0..64 {
            let p = [stop_r * (-1.0 + (i as f64 + 0.5) / 32.0), stop_r * (-1.0 + (j as f64 + 0.5) / 32.0)];
            if p[0].hypot(p[1]) > stop_r {
                continue;
            }
            let d = [p[0] - s[0], p[1] - s[1], -s[2]];
            let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let ray = LensRay { origin: s, direction: [d[0] / l, d[1] / l, d[2] / l] };
            let Some(r) = lens.trace_from_object(ray, lambda_nm) else { continue };
            let t = (film_z - r.origin[2]) / r.direction[2];
            let f = [r.origin[0] + t * r.direction[0], r.origin[1] + t * r.direction[1]];
            // pbrt-v4's film: raster x runs along −x on the film (the image is inverted), raster y along +y.
            let raster =
                DVec2::new((-f[0] / half[0] + 1.0) * 0.5 * RES.0 as f64, (f[1] / half[1] + 1.0) * 0.5 * RES.1 as f64);
            out.push(raster);
        }
    }
    out
}

/// Centroid and rms radius of the prediction over a bucket (its wavelengths weighted evenly: the source is flat and
/// the camera has no Fresnel losses).
fn predicted(lens_text: &str, centre: f64, width: f64, source: [f64; 3]) -> (DVec2, f64) {
    let pts: Vec<DVec2> = (0..8)
        .flat_map(|k| landing_points(lens_text, centre + width * ((k as f64 + 0.5) / 8.0 - 0.5), source))
        .collect();
    let c = pts.iter().sum::<DVec2>() / pts.len() as f64;
    let rms = (pts.iter().map(|p| (*p - c).length_squared()).sum::<f64>() / pts.len() as f64).sqrt();
    (c, rms)
}

fn scene(lens_file: &Path, crop: [u32; 4], spp: u32, source: [f64; 3], split: bool) -> BuiltScene {
    let (lo, hi, n) = BUCKETS;
    let text = format!(
        r#"LookAt 0 0 0  0 0 1  0 1 0
Camera "realistic" "string lensfile" "{}" "float aperturediameter" 8 "float focusdistance" {FOCUS_M}
Film "spectral" "integer xresolution" {} "integer yresolution" {} "float diagonal" {DIAGONAL_MM}
    "integer nbuckets" {n} "float lambdamin" {lo} "float lambdamax" {hi}
    "integer pixelbounds" [ {} {} {} {} ]
PixelFilter "box"
Sampler "zsobol" "integer pixelsamples" {spp}
Integrator "path" "integer maxdepth" 0 "bool splitdispersion" {split}
WorldBegin
AttributeBegin
  AreaLightSource "diffuse" "spectrum L" [ 360 1 830 1 ]
  Translate {} {} {}
  Shape "sphere" "float radius" {SOURCE_RADIUS_M}
AttributeEnd
"#,
        lens_file.display(),
        RES.0,
        RES.1,
        crop[0],
        crop[1],
        crop[2],
        crop[3],
        source[0],
        source[1],
        source[2],
    );
    build(&text, lens_file.with_extension("pbrt"))
}

/// A rendered spot in one bucket: its centroid and rms radius (raster pixels), and its total.
type Spot = (DVec2, f64, f64);

/// Per bucket, the rendered spot.
fn rendered_spots(built: &BuiltScene) -> Vec<Spot> {
    let mut spec = built.film.clone();
    spec.wavelengths = WavelengthStrategy::Hero;
    let mut film = Film::new(spec).unwrap();
    built.integrator.render(&built.scene, &mut film, 0..built.spp, 5, &|_| {}).unwrap();
    let b = film.bounds();
    (0..BUCKETS.2)
        .map(|k| {
            let (mut m, mut w) = (DVec2::ZERO, 0.0);
            let mut m2 = 0.0;
            for y in b.y0..b.y0 + b.height() {
                for x in b.x0..b.x0 + b.width() {
                    let v = film.pixel_spectrum(x, y)[k];
                    let p = DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
                    m += v * p;
                    m2 += v * p.length_squared();
                    w += v;
                }
            }
            let c = m / w;
            (c, (m2 / w - c.length_squared()).max(0.0).sqrt(), w)
        })
        .collect()
}

/// The crop of the film around the spot the prediction gives at 550 nm.
fn crop_around(lens_text: &str, source: [f64; 3]) -> [u32; 4] {
    let (c, _) = predicted(lens_text, 550.0, 1.0, source);
    let (x, y) = (c.x as u32, c.y as u32);
    [x - 60, x + 60, y - 60, y + 60]
}

fn bucket(k: usize) -> (f64, f64) {
    let (lo, hi, n) = BUCKETS;
    let w = (hi - lo) / n as f64;
    (lo + w * (k as f64 + 0.5), w)
}

/// The radius of the source's image, raster pixels: how far the image moves when the source moves by its radius.
fn source_image_radius(source: [f64; 3]) -> f64 {
    let centroid = |s: [f64; 3]| {
        let p = landing_points(SINGLET, 587.6, s);
        p.iter().sum::<DVec2>() / p.len() as f64
    };
    (centroid([source[0] + SOURCE_RADIUS_M, source[1], source[2]]) - centroid(source)).length()
}

/// Renders the spot through `lens_text` and checks each bucket's centroid against the ray trace (within a pixel)
/// and its rms radius against the trace's with the known blurs added (within 10%); returns the rendered and traced
/// spots.
fn spots_match_the_ray_trace(
    lens_text: &str,
    name: &str,
    source: [f64; 3],
    split: bool,
) -> (Vec<Spot>, Vec<(DVec2, f64)>) {
    let dir = temp_dir("realistic", name);
    let file = dir.join("lens.dat");
    std::fs::write(&file, lens_text).unwrap();
    // Without the split a sample carries one wavelength, not four, chosen at random: 16 times the samples bring
    // the centroids as close (at 512, 4 times, they were up to 1.2 px off; at 2048 within 0.3 px).
    let spp = if split { 128 } else { 2048 };
    let spots = rendered_spots(&scene(&file, crop_around(lens_text, source), spp, source, split));
    let disc = source_image_radius(source);
    let mut want = Vec::new();
    for (k, (got, rms, total)) in spots.iter().enumerate() {
        let (centre, width) = bucket(k);
        let (c, r) = predicted(lens_text, centre, width, source);
        eprintln!(
            "{name} {centre} nm: centroid {got} (ray trace {c}), rms {rms:.2} px (ray trace {r:.2}), total {total:.3e}"
        );
        assert!(*total > 0.0);
        assert!((*got - c).length() < 1.0, "{centre} nm: centroid {got}, ray trace {c}");
        // The rendered rms radius is the ray trace's with the source's disc (E r² = a²/2), the pixel and the box
        // filter (1/12 px² each, per axis) added in quadrature: the blur of each wavelength's defocus.
        let blur = (r * r + 0.5 * disc * disc + 2.0 * 2.0 / 12.0).sqrt();
        assert!((rms / blur - 1.0).abs() < 0.1, "{centre} nm: rms {rms} px, ray trace with blurs {blur} px");
        want.push((c, r));
    }
    (spots, want)
}

#[test]
fn an_off_axis_point_lands_per_bucket_where_real_rays_put_it() {
    let (spots, want) = spots_match_the_ray_trace(SINGLET, "bk7", SOURCE, true);
    // Lateral colour between the 450 and 650 nm buckets, measured against traced: within 5 per cent, and large.
    let measured = spots[5].0 - spots[0].0;
    let predicted = want[5].0 - want[0].0;
    eprintln!("lateral colour 650 − 450 nm: {measured} px rendered, {predicted} px traced");
    assert!(predicted.length() > 15.0, "{predicted}");
    assert!((measured - predicted).length() < 0.05 * predicted.length(), "{measured} vs {predicted}");
}

#[test]
fn keeping_one_wavelength_at_the_lens_lands_in_the_same_places() {
    // `"bool splitdispersion" false`: one wavelength per camera sample, chosen at random, its density over the
    // choice: unbiased, so the spots per bucket are where they were (the same checks, with more samples).
    let (spots, want) = spots_match_the_ray_trace(SINGLET, "onewl", SOURCE, false);
    let measured = spots[5].0 - spots[0].0;
    let predicted = want[5].0 - want[0].0;
    assert!((measured - predicted).length() < 0.05 * predicted.length(), "{measured} vs {predicted}");
}

#[test]
fn on_the_axis_each_bucket_is_as_sharp_as_its_focus_shift_allows() {
    // On the axis only defocus (longitudinal colour) and spherical aberration blur the spot: the camera focused at
    // the d line, so the 570 and 610 nm buckets are the sharpest and the blue end, focused in front of the film,
    // the most blurred; each bucket's radius matches the trace's within 10% (checked inside).
    let (spots, want) = spots_match_the_ray_trace(SINGLET, "axis", [0.0, 0.0, 2.0], true);
    let sharpest = (0..6).min_by(|&a, &b| spots[a].1.total_cmp(&spots[b].1)).unwrap();
    assert!(sharpest == 3 || sharpest == 4, "{sharpest}: {spots:?}");
    assert!(spots[0].1 > 2.0 * spots[sharpest].1, "{} vs {}", spots[0].1, spots[sharpest].1);
    assert_eq!(sharpest, (0..6).min_by(|&a, &b| want[a].1.total_cmp(&want[b].1)).unwrap());
}

#[test]
fn a_constant_index_lens_shows_no_colour() {
    // pbrt-v4's behaviour: every wavelength follows one ray, so every bucket sees the same spot.
    let (spots, _) = spots_match_the_ray_trace(&SINGLET.replace("N-BK7", "1.5168"), "constant", SOURCE, true);
    let shift = (spots[5].0 - spots[0].0).length();
    assert!(shift < 0.5, "{shift} px between the 450 and 650 nm buckets");
}

/// A scene with a realistic camera whose lens file holds `lens_text`, and `camera_more` after its parameters.
fn camera_scene(name: &str, lens_text: &str, camera_more: &str, integrator: &str) -> Result<BuiltScene, String> {
    let dir = temp_dir("realistic", name);
    std::fs::write(dir.join("lens.dat"), lens_text).unwrap();
    let text = format!(
        "LookAt 0 0 0  0 0 1  0 1 0\n\
         Camera \"realistic\" \"string lensfile\" \"lens.dat\" {camera_more}\n\
         Film \"rgb\" \"integer xresolution\" 32 \"integer yresolution\" 24\n\
         Integrator \"{integrator}\"\n\
         WorldBegin\n\
         LightSource \"infinite\"\n"
    );
    support::try_build(&text, dir.join("scene.pbrt"))
}

#[test]
fn bad_lenses_and_cameras_are_errors_that_say_where() {
    let err = |name: &str, lens: &str, more: &str, integrator: &str| {
        camera_scene(name, lens, more, integrator).err().unwrap_or_else(|| panic!("{name}: expected an error"))
    };
    // The lens file's own line and column, after the scene's.
    let e = err("columns", "50 5 N-BK7 20\n-50 45 0\n", "", "path");
    assert!(e.contains("scene.pbrt:2:") && e.contains("lens.dat:2:1") && e.contains("3 values"), "{e}");
    let e = err("glass", "0 5 0 20\n50 5 N-BK8 20\n-50 45 1 20\n", "", "path");
    assert!(e.contains("lens.dat:2:6") && e.contains("index"), "{e}");
    let e = err("aperture", "0 5 0 20\n50 5 1.5 -20\n-50 45 1 20\n", "", "path");
    assert!(e.contains("lens.dat:2:") && e.contains("aperture"), "{e}");
    // A lens that lets nothing through is an error, not a black image.
    let e = err("black", SINGLET, "\"float aperturediameter\" 1e-5", "path");
    assert!(e.contains("no ray from the film gets through"), "{e}");
    let e = err("close", SINGLET, "\"float focusdistance\" 0.2", "path");
    assert!(e.contains("too close"), "{e}");
    let e = err("nostop", "50 5 N-BK7 20\n-50 95 1 20\n", "", "path");
    assert!(e.contains("no aperture stop"), "{e}");
    let e = err("shape", SINGLET, "\"string aperture\" \"hexagon.png\"", "path");
    assert!(e.contains("'aperture' \"hexagon.png\"") && e.contains("scene.pbrt:2:"), "{e}");
    let e = err("missing", "", "", "path");
    assert!(e.contains("no surfaces"), "{e}");
    // Light paths cannot reach a realistic camera (as in pbrt-v4): bdpt and lightpath refuse it.
    for integrator in ["bdpt", "lightpath"] {
        let e = err(integrator, SINGLET, "", integrator);
        assert!(e.contains("realistic") && e.contains("scene.pbrt:2:"), "{integrator}: {e}");
    }
    let e = build_error("LookAt 0 0 0  0 0 1  0 1 0\nCamera \"realistic\"\nWorldBegin\n", "nolens.pbrt");
    assert!(e.contains("nolens.pbrt:2:") && e.contains("lensfile"), "{e}");
}

#[test]
fn a_larger_aperture_than_the_stop_is_clamped_with_a_warning() {
    let built = camera_scene("clamp", SINGLET, "\"float aperturediameter\" 50", "path").unwrap();
    assert!(built.warnings.iter().any(|w| w.contains("clamped") && w.contains("8 mm")), "{:?}", built.warnings);
}

/// pbrt-v4's `lenses/dgauss.50mm.dat` (mmp/pbrt-v4-scenes), unchanged: constant indices.
const DGAUSS_PBRT: &str = "# D-GAUSS F/2 22deg HFOV\n# Scaled to 50 mm from 100 mm\n29.475\t3.76\t1.67\t25.2\n\
    84.83\t0.12\t1\t25.2\n19.275\t4.025\t1.67\t23\n40.77\t3.275\t1.699\t23\n12.75\t5.705\t1\t18\n0\t4.5\t0\t17.1\n\
    -14.495\t1.18\t1.603\t17\n40.77\t6.065\t1.658\t20\n-20.385\t0.19\t1\t20\n437.065\t3.22\t1.717\t20\n-39.73\t0\t1\t20\n";

/// The mean of (R + G + B)/3 over 4 × 4 blocks of 24 × 16 pixels (rows from the top) of the scene in
/// [`renders_pbrt_v4s_double_gauss_as_pbrt_v4_does`], rendered by pbrt-v4 (`pbrt --nthreads 2`, 2048 samples per
/// pixel; the blocks' standard errors are below 0.1%).
const PBRT_BLOCKS: [f64; 16] = [
    0.04324, 0.0597, 0.06301, 0.04549, 0.05006, 0.07079, 0.07553, 0.05239, 0.05239, 0.07551, 0.0708, 0.05005, 0.0455,
    0.06302, 0.05968, 0.04326,
];

#[test]
fn renders_pbrt_v4s_double_gauss_as_pbrt_v4_does() {
    // A checkerboard 1 m away through pbrt-v4's f/2 double Gauss, wide open, focused on it, under a white sky: the
    // corners are vignetted to 57% of the centre by the lens's rims and cos⁴θ, which the blocks follow.
    let dir = temp_dir("realistic", "pbrt");
    std::fs::write(dir.join("dgauss.dat"), DGAUSS_PBRT).unwrap();
    // The camera-path integrators: path, volpath and photon mapping (its 256 iterations of one camera path per
    // pixel each); the chart is lit directly, so photon mapping's bias is below the tolerance.
    for integrator in [r#""path""#, r#""volpath""#, r#""sppm" "integer iterations" 256"#] {
        let text = format!(
            r#"LookAt 0 0 0  0 0 1  0 1 0
Camera "realistic" "string lensfile" "dgauss.dat" "float aperturediameter" 17.1 "float focusdistance" 1.0
Sampler "halton" "integer pixelsamples" 256
Integrator {integrator} "integer maxdepth" 2
Film "rgb" "integer xresolution" 96 "integer yresolution" 64 "float diagonal" 35
WorldBegin
LightSource "infinite" "rgb L" [1 1 1]
Texture "checks" "spectrum" "checkerboard" "float uscale" 16 "float vscale" 16 "rgb tex1" [0.9 0.9 0.9]
    "rgb tex2" [0.05 0.05 0.05]
Material "diffuse" "texture reflectance" "checks"
AttributeBegin
Translate 0 0 1.0
Shape "bilinearmesh" "point3 P" [-0.6 -0.4 0  0.6 -0.4 0  -0.6 0.4 0  0.6 0.4 0] "point2 uv" [0 0 1 0 0 1 1 1]
AttributeEnd
"#
        );
        let built = build(&text, dir.join("chart.pbrt"));
        let mut film = Film::new(built.film.clone()).unwrap();
        built.integrator.render(&built.scene, &mut film, 0..built.spp, 0, &|_| {}).unwrap();
        let rgb = film.to_rgb_image();
        let w = film.width() as usize;
        for (k, &want) in PBRT_BLOCKS.iter().enumerate() {
            let (bx, by) = (k % 4, k / 4);
            let mut sum = 0.0;
            for y in 16 * by..16 * (by + 1) {
                for x in 24 * bx..24 * (bx + 1) {
                    let p = rgb[y * w + x];
                    sum += (p[0] + p[1] + p[2]) as f64 / 3.0;
                }
            }
            let got = sum / (24.0 * 16.0);
            // 1.5%: about five standard errors of a block at 256 samples per pixel.
            assert!((got / want - 1.0).abs() < 0.015, "{integrator}: block {k}: {got} vs pbrt-v4's {want}");
        }
    }
}

#[test]
fn a_projective_cameras_parameters_are_unused_by_a_realistic_one() {
    // pbrt-v4's realistic camera reads no field of view, screen window or thin lens: given, they are reported.
    let built = camera_scene("unused", SINGLET, "\"float fov\" 40 \"float lensradius\" 0.1", "path").unwrap();
    for name in ["fov", "lensradius"] {
        assert!(built.warnings.iter().any(|w| w.contains("unused") && w.contains(name)), "{:?}", built.warnings);
    }
}

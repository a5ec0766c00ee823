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

/// A plano-convex N-BK7 singlet (R = 51.5 mm, f ≈ 100 mm) with its stop 40 mm in front of it, so that off-axis
/// chief rays cross the glass away from its centre and lateral colour is large enough to measure.
const SINGLET: &str = "0 40 0 8\n51.5 3.6 N-BK7 25.4\n0 97.6 1 25.4\n";

/// The film: 35 mm diagonal (pbrt-v4's default), 1800 × 1200 pixels of 16.2 µm.
const RES: (u32, u32) = (1800, 1200);
const DIAGONAL_MM: f64 = 35.0;
/// The source: an emissive sphere 2 m in front of the film, 0.2 m above the axis (its image about 10 mm off axis).
const SOURCE: [f64; 3] = [0.0, 0.2, 2.0];
const SOURCE_RADIUS_M: f64 = 3e-4;
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
fn landing_points(lens_text: &str, lambda_nm: f64) -> Vec<DVec2> {
    let lens = LensPrescription::parse(lens_text).unwrap();
    let lens = lens.focused(FOCUS_M * 1000.0, render::FOCUS_WAVELENGTH_NM).unwrap();
    let film_z = lens.length_mm();
    let stop_r = 0.5 * lens.surfaces[0].aperture_mm;
    // Camera space is world space here (LookAt from the origin along +z, up +y); lens space has its z from the
    // front vertex towards the film, in mm.
    let s = [SOURCE[0] * 1e3, SOURCE[1] * 1e3, film_z - SOURCE[2] * 1e3];
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
fn predicted(lens_text: &str, centre: f64, width: f64) -> (DVec2, f64) {
    let pts: Vec<DVec2> =
        (0..8).flat_map(|k| landing_points(lens_text, centre + width * ((k as f64 + 0.5) / 8.0 - 0.5))).collect();
    let c = pts.iter().sum::<DVec2>() / pts.len() as f64;
    let rms = (pts.iter().map(|p| (*p - c).length_squared()).sum::<f64>() / pts.len() as f64).sqrt();
    (c, rms)
}

fn scene(lens_file: &Path, crop: [u32; 4]) -> BuiltScene {
    let (lo, hi, n) = BUCKETS;
    let text = format!(
        r#"LookAt 0 0 0  0 0 1  0 1 0
Camera "realistic" "string lensfile" "{}" "float aperturediameter" 8 "float focusdistance" {FOCUS_M}
Film "spectral" "integer xresolution" {} "integer yresolution" {} "float diagonal" {DIAGONAL_MM}
    "integer nbuckets" {n} "float lambdamin" {lo} "float lambdamax" {hi}
    "integer pixelbounds" [ {} {} {} {} ]
PixelFilter "box"
Sampler "zsobol" "integer pixelsamples" 64
Integrator "path" "integer maxdepth" 0
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
        SOURCE[0],
        SOURCE[1],
        SOURCE[2],
    );
    build(&text, lens_file.with_extension("pbrt"))
}

/// Per bucket: the rendered spot's centroid and rms radius (raster pixels), and its total.
fn rendered_spots(built: &BuiltScene) -> Vec<(DVec2, f64, f64)> {
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
fn crop_around(lens_text: &str) -> [u32; 4] {
    let (c, _) = predicted(lens_text, 550.0, 1.0);
    let (x, y) = (c.x as u32, c.y as u32);
    [x - 40, x + 40, y - 40, y + 40]
}

fn bucket(k: usize) -> (f64, f64) {
    let (lo, hi, n) = BUCKETS;
    let w = (hi - lo) / n as f64;
    (lo + w * (k as f64 + 0.5), w)
}

#[test]
fn an_off_axis_point_lands_per_bucket_where_real_rays_put_it() {
    let dir = temp_dir("realistic", "lateral");
    let file = dir.join("singlet.dat");
    std::fs::write(&file, SINGLET).unwrap();
    let spots = rendered_spots(&scene(&file, crop_around(SINGLET)));
    let mut want = Vec::new();
    for (k, (got, rms, total)) in spots.iter().enumerate() {
        let (centre, width) = bucket(k);
        let (c, r) = predicted(SINGLET, centre, width);
        eprintln!("{centre} nm: centroid {got} (ray trace {c}), rms {rms:.2} px (ray trace {r:.2}), total {total:.3e}");
        assert!(*total > 0.0);
        // Within a pixel (the source's disc, the pixel and the box filter add about 0.6 px rms of blur, evenly).
        assert!((*got - c).length() < 1.0, "{centre} nm: centroid {got}, ray trace {c}");
        // The blur follows each wavelength's defocus (longitudinal colour): the rendered rms radius is the ray
        // trace's with the source disc (radius 0.93 px), pixel and box filter added in quadrature.
        let blur = (r * r + 0.5 * 0.93f64.powi(2) + 2.0 * 2.0 / 12.0).sqrt();
        assert!((rms / blur - 1.0).abs() < 0.1, "{centre} nm: rms {rms} px, ray trace with blur {blur} px");
        want.push((c, r));
    }
    // Lateral colour between the 450 and 650 nm buckets, measured against predicted: within 5 per cent, and large.
    let measured = spots[5].0 - spots[0].0;
    let predicted = want[5].0 - want[0].0;
    eprintln!("lateral colour 650 − 450 nm: {measured} px rendered, {predicted} px traced");
    assert!(predicted.length() > 5.0, "{predicted}");
    assert!((measured - predicted).length() < 0.05 * predicted.length(), "{measured} vs {predicted}");
    // The best focus is near the d line the camera focused at: the 570 and 610 nm buckets are the sharpest, and the
    // blue end (focused far in front of the film) is the most blurred.
    let sharpest = (0..6).min_by(|&a, &b| want[a].1.total_cmp(&want[b].1)).unwrap();
    assert!(sharpest == 3 || sharpest == 4, "{sharpest}");
    assert!(spots[0].1 > 2.0 * spots[sharpest].1, "{} vs {}", spots[0].1, spots[sharpest].1);
}

#[test]
fn a_constant_index_lens_shows_no_colour() {
    let text = SINGLET.replace("N-BK7", "1.5168");
    let dir = temp_dir("realistic", "constant");
    let file = dir.join("singlet.dat");
    std::fs::write(&file, &text).unwrap();
    let spots = rendered_spots(&scene(&file, crop_around(&text)));
    // pbrt-v4's behaviour: every wavelength follows one ray, so every bucket sees the same spot (the same samples,
    // reweighted: identical to rounding).
    for s in &spots[1..] {
        assert!((s.0 - spots[0].0).length() < 1e-3, "{:?} vs {:?}", s.0, spots[0].0);
    }
}

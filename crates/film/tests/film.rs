//! The film: accumulation, spectral buckets for every wavelength strategy, rows in parallel, merging, validation.

use film::{Film, FilmError, FilmKind, FilmSpec, Filter, FilterSampler};
use rand_core::{RngCore, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;
use spectral::{Observer, SampledSpectrum, WavelengthStrategy, Xyz};

fn uniform(rng: &mut Pcg64) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

fn spectral_spec(w: u32, h: u32, nbuckets: usize, lambda_min: f64, lambda_max: f64) -> FilmSpec {
    let mut spec = FilmSpec::new(w, h, "test.exr");
    spec.kind = FilmKind::Spectral { nbuckets, lambda_min, lambda_max };
    spec
}

#[test]
fn constant_xyz_samples_give_that_xyz_back() {
    let spec = FilmSpec::new(8, 5, "x.exr");
    let sampler = FilterSampler::new(&spec.filter).unwrap();
    let mut film = Film::new(spec).unwrap();
    let xyz = Xyz::new(0.3, 0.7, 1.1);
    let mut rng = Pcg64::seed_from_u64(5);
    for y in 0..5 {
        for x in 0..8 {
            for _ in 0..17 {
                let s = sampler.sample([uniform(&mut rng), uniform(&mut rng)]);
                assert!(film.add_xyz_sample(x, y, xyz, s.weight, &[]));
            }
        }
    }
    for y in 0..5 {
        for x in 0..8 {
            let p = film.pixel_xyz(x, y);
            assert!((p.x - 0.3).abs() < 1e-12 && (p.y - 0.7).abs() < 1e-12 && (p.z - 1.1).abs() < 1e-12, "{p:?}");
        }
    }
    // And the RGB image is that XYZ in sRGB.
    let rgb = film.to_rgb_image();
    let want = spectral::RgbColorSpace::srgb().to_rgb(xyz);
    for p in rgb {
        for c in 0..3 {
            assert!((p[c] as f64 - want[c]).abs() < 1e-6);
        }
    }
    // Pixels without samples, and outside the film, are black, never a panic.
    let empty = Film::new(FilmSpec::new(2, 2, "e.exr")).unwrap();
    assert_eq!(empty.pixel_xyz(0, 0), Xyz::default());
    assert_eq!(film.pixel_xyz(100, 100), Xyz::default());
    assert_eq!(film.pixel_spectrum(0, 0), Vec::<f64>::new());
}

#[test]
fn spectral_bucket_assignment() {
    // 47 buckets of 10 nm over 360–830: 405 nm is in bucket 4 ([400, 410)), value / 10 nm.
    let mut film = Film::new(spectral_spec(3, 2, 47, 360.0, 830.0)).unwrap();
    assert!(film.add_xyz_sample(1, 1, Xyz::new(1.0, 1.0, 1.0), 1.0, &[(405.0, 3.0)]));
    let s = film.pixel_spectrum(1, 1);
    assert_eq!(s.len(), 47);
    for (b, v) in s.iter().enumerate() {
        let want = if b == 4 { 0.3 } else { 0.0 };
        assert!((v - want).abs() < 1e-12, "bucket {b}: {v}");
    }
    let kind = &film.spec().kind;
    assert_eq!(kind.bucket_of(405.0), Some(4));
    assert_eq!(kind.bucket_of(360.0), Some(0));
    assert_eq!(kind.bucket_of(829.999), Some(46));
    assert_eq!(kind.bucket_of(830.0), None);
    assert_eq!(kind.bucket_of(359.9), None);
    assert_eq!(kind.bucket_of(f64::NAN), None);
    assert!((kind.bucket_centres()[4] - 405.0).abs() < 1e-12);

    // Weights scale the buckets like the colour; wavelengths outside [min, max) are ignored.
    let mut film = Film::new(spectral_spec(1, 1, 4, 400.0, 800.0)).unwrap();
    film.add_xyz_sample(0, 0, Xyz::default(), 2.0, &[(450.0, 10.0), (799.0, 100.0), (380.0, 1e6), (800.0, 1e6)]);
    film.add_xyz_sample(0, 0, Xyz::default(), 2.0, &[]);
    // bucket width 100 nm; weight sum 4.
    assert_eq!(film.pixel_spectrum(0, 0), vec![2.0 * 10.0 / 100.0 / 4.0, 0.0, 0.0, 2.0 * 100.0 / 100.0 / 4.0]);
}

#[test]
fn non_finite_samples_are_dropped_and_counted() {
    let mut film = Film::new(spectral_spec(2, 1, 4, 400.0, 800.0)).unwrap();
    assert!(!film.add_xyz_sample(0, 0, Xyz::new(f64::NAN, 0.0, 0.0), 1.0, &[]));
    assert!(!film.add_xyz_sample(0, 0, Xyz::new(1.0, 1.0, 1.0), f64::INFINITY, &[]));
    assert!(!film.add_xyz_sample(0, 0, Xyz::new(1.0, 1.0, 1.0), 1.0, &[(500.0, f32::NAN)]));
    assert!(!film.add_xyz_sample(5, 0, Xyz::new(1.0, 1.0, 1.0), 1.0, &[]));
    {
        let mut row = film.row_mut(0).unwrap();
        assert!(!row.add_xyz_sample(2, Xyz::new(1.0, 1.0, 1.0), 1.0, &[]));
    }
    assert!(film.row_mut(1).is_none());
    assert_eq!(film.pixel_weight(0, 0), 0.0);
    assert_eq!(film.rejected_samples(), 4);
}

/// A smooth test spectrum (W m⁻² sr⁻¹ nm⁻¹).
fn test_spectrum(lambda: f64) -> f64 {
    1.0 + 0.5 * ((lambda - 360.0) / 470.0) + 0.3 * (lambda / 40.0).sin()
}

fn bucket_mean(a: f64, b: f64) -> f64 {
    let n = 10_000;
    let h = (b - a) / n as f64;
    (0..n).map(|i| test_spectrum(a + (i as f64 + 0.5) * h)).sum::<f64>() * h / (b - a)
}

#[test]
fn every_wavelength_strategy_fills_the_buckets_correctly() {
    // Each (λ, L/pdf) goes whole into its own bucket, divided by the bucket width: the buckets converge to the mean
    // spectral radiance over each bucket whatever the density the wavelengths were drawn from.
    let (lo, hi, nb) = (400.0, 700.0, 10);
    for strategy in WavelengthStrategy::ALL {
        let mut spec = spectral_spec(1, 1, nb, lo, hi);
        spec.wavelengths = strategy;
        let mut film = Film::new(spec).unwrap();
        let n = 400_000;
        for k in 0..n {
            let u = (k as f64 + 0.5) / n as f64; // stratified, so the test is quick and deterministic
            let wl = film.sample_wavelengths(u);
            let l = SampledSpectrum(std::array::from_fn(|i| test_spectrum(wl.lambda(i) as f64) as f32));
            film.add_sample(0, 0, &l, &wl, 1.0);
        }
        let got = film.pixel_spectrum(0, 0);
        let width = (hi - lo) / nb as f64;
        for (b, v) in got.iter().enumerate() {
            let want = bucket_mean(lo + b as f64 * width, lo + (b + 1) as f64 * width);
            assert!((v - want).abs() < 0.01 * want, "{strategy}: bucket {b}: {v} vs {want}");
        }
    }
}

#[test]
fn parallel_rows_are_deterministic_and_match_serial() {
    let render = |film: &mut Film, sampler: &FilterSampler, parallel: bool| {
        let work = |mut row: film::FilmRow<'_>| {
            let y = row.y();
            for x in 0..row.width() {
                let mut rng = Pcg64::seed_from_u64(((y as u64) << 32) | x as u64);
                for _ in 0..8 {
                    let s = sampler.sample([uniform(&mut rng), uniform(&mut rng)]);
                    let v = uniform(&mut rng);
                    let lambda = 360.0 + 470.0 * uniform(&mut rng) as f32;
                    row.add_xyz_sample(x, Xyz::new(v, 2.0 * v, 0.5), s.weight, &[(lambda, v as f32)]);
                }
                row.add_aov(x, [0.5, 0.25, 0.125], [0.0, 0.0, 2.0]);
            }
        };
        if parallel {
            film.par_rows_mut().for_each(work);
        } else {
            film.rows_mut().for_each(work);
        }
    };
    let mut spec = spectral_spec(37, 23, 16, 360.0, 830.0);
    spec.aovs = true;
    let sampler = FilterSampler::new(&spec.filter).unwrap();
    let mut serial = Film::new(spec.clone()).unwrap();
    render(&mut serial, &sampler, false);
    for threads in [1, 2, 3] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        let mut par = Film::new(spec.clone()).unwrap();
        pool.install(|| render(&mut par, &sampler, true));
        assert_eq!(par.to_rgb_image(), serial.to_rgb_image());
        assert_eq!(par.to_spectral_image(), serial.to_spectral_image());
    }
    let aov = serial.to_aov_images().unwrap();
    assert_eq!(aov.albedo[5], [0.5, 0.25, 0.125]);
    assert_eq!(aov.normal[5], [0.0, 0.0, 1.0]);
}

#[test]
fn merge_of_two_half_films_equals_one_film() {
    let spec = {
        let mut s = spectral_spec(6, 4, 8, 400.0, 656.0); // 32 nm buckets: exact sums
        s.aovs = true;
        s
    };
    let sampler = FilterSampler::new(&spec.filter).unwrap();
    let mut whole = Film::new(spec.clone()).unwrap();
    let mut first = Film::new(spec.clone()).unwrap();
    let mut second = Film::new(spec.clone()).unwrap();
    let mut rng = Pcg64::seed_from_u64(9);
    for k in 0..2000 {
        let (x, y) = ((rng.next_u32() % 6), (rng.next_u32() % 4));
        let s = sampler.sample([uniform(&mut rng), uniform(&mut rng)]);
        // Values with few significant bits, so sums are exact in any order.
        let v = (rng.next_u32() % 64) as f64 / 8.0;
        let w = (s.weight * 64.0).round() / 64.0;
        let lambda = 400.0 + (rng.next_u32() % 256) as f32;
        let half = if k % 2 == 0 { &mut first } else { &mut second };
        for film in [&mut whole, half] {
            film.add_xyz_sample(x, y, Xyz::new(v, v / 2.0, 1.0), w, &[(lambda, v as f32)]);
            film.add_aov(x, y, [v, 0.5, 0.25], [0.0, 1.0, 0.0]);
        }
    }
    first.merge(&second).unwrap();
    for y in 0..4 {
        for x in 0..6 {
            assert_eq!(first.pixel_xyz(x, y), whole.pixel_xyz(x, y));
            assert_eq!(first.pixel_weight(x, y), whole.pixel_weight(x, y));
            assert_eq!(first.pixel_spectrum(x, y), whole.pixel_spectrum(x, y));
        }
    }
    assert_eq!(first.to_aov_images(), whole.to_aov_images());

    // Films that differ cannot be merged.
    let other = Film::new(spectral_spec(6, 4, 9, 400.0, 656.0)).unwrap();
    assert!(matches!(first.merge(&other), Err(FilmError::Mismatch(_))));
    let other = Film::new(FilmSpec::new(5, 4, "a.exr")).unwrap();
    assert!(matches!(first.merge(&other), Err(FilmError::Mismatch(_))));
}

#[test]
fn spec_validation_names_the_parameter() {
    let name = |spec: FilmSpec| match Film::new(spec).unwrap_err() {
        FilmError::InvalidParameter { name, .. } => name,
        e @ (FilmError::TooLarge { .. }
        | FilmError::Mismatch(_)
        | FilmError::OutOfBounds { .. }
        | FilmError::Table(_)) => {
            panic!("unexpected {e:?}")
        }
    };
    assert_eq!(name(FilmSpec::new(0, 10, "a.exr")), "xresolution");
    assert_eq!(name(FilmSpec::new(10, 0, "a.exr")), "yresolution");
    assert_eq!(name(spectral_spec(4, 4, 0, 360.0, 830.0)), "nbuckets");
    assert_eq!(name(spectral_spec(4, 4, 16, 300.0, 830.0)), "lambdamin");
    assert_eq!(name(spectral_spec(4, 4, 16, f64::NAN, 830.0)), "lambdamin");
    assert_eq!(name(spectral_spec(4, 4, 16, 500.0, 500.0)), "lambdamax");
    assert_eq!(name(spectral_spec(4, 4, 16, 500.0, 900.0)), "lambdamax");
    let mut spec = FilmSpec::new(4, 4, "a.exr");
    spec.filter = Filter::Gaussian { radius: [-1.0, 1.0], sigma: 0.5 };
    assert_eq!(name(spec), "xradius");
    // pbrt-v4's defaults.
    assert_eq!(FilmKind::spectral_default(), FilmKind::Spectral { nbuckets: 16, lambda_min: 360.0, lambda_max: 830.0 });
    let d = FilmSpec::default();
    assert_eq!((d.width, d.height, d.kind, d.filter, d.aovs), (1280, 720, FilmKind::Rgb, Filter::default(), false));
    // An absurd size is an error, not an abort.
    let e = Film::new(spectral_spec(u32::MAX, u32::MAX, 4700, 360.0, 830.0)).unwrap_err();
    assert!(matches!(e, FilmError::TooLarge { .. }), "{e:?}");
}

/// Splats: a pixel's value is camera mean + splat sum × pixels / light paths; the filter (normalised to unit
/// integral) spreads a splat over the pixels within its radius; spectral buckets get the same treatment; merging
/// adds splats and light-path counts.
#[test]
fn splats_are_scaled_by_pixels_per_light_path_and_spread_by_the_filter() {
    let mut spec = spectral_spec(4, 3, 2, 400.0, 600.0);
    spec.filter = Filter::new_box([0.5, 0.5]).unwrap();
    let mut film = Film::new(spec.clone()).unwrap();
    assert!(film.add_xyz_sample(1, 1, Xyz::new(1.0, 1.0, 1.0), 1.0, &[(450.0, 100.0)]));
    // Two splats in pixel (1, 1) and one in (3, 2); 24 light paths over 12 pixels: scale ½.
    assert!(film.add_xyz_splat([1.5, 1.5], Xyz::new(2.0, 4.0, 6.0), &[(450.0, 200.0)]));
    assert!(film.add_xyz_splat([1.2, 1.9], Xyz::new(2.0, 0.0, 0.0), &[(550.0, 100.0)]));
    assert!(film.add_xyz_splat([3.7, 2.1], Xyz::new(0.0, 8.0, 0.0), &[]));
    assert!(!film.add_xyz_splat([0.5, 0.5], Xyz::new(f64::NAN, 0.0, 0.0), &[]));
    film.add_light_paths(24);
    let p = film.pixel_xyz(1, 1);
    assert_eq!((p.x, p.y, p.z), (1.0 + 0.5 * 4.0, 1.0 + 0.5 * 4.0, 1.0 + 0.5 * 6.0));
    assert_eq!(film.pixel_xyz(3, 2).y, 4.0);
    assert_eq!(film.pixel_xyz(0, 0).y, 0.0);
    // Buckets of 100 nm: 100/100 from the camera sample, ½·200/100 and ½·100/100 from the splats.
    assert_eq!(film.pixel_spectrum(1, 1), vec![1.0 + 1.0, 0.5]);
    assert_eq!(film.rejected_samples(), 1);
    // A wider triangle filter spreads one splat over 2×2 pixels with weights summing to 1.
    let mut tri = spectral_spec(4, 4, 1, 400.0, 600.0);
    tri.filter = Filter::triangle([1.0, 1.0]).unwrap();
    let mut f2 = Film::new(tri).unwrap();
    f2.add_xyz_splat([2.0, 2.0], Xyz::new(0.0, 16.0, 0.0), &[]);
    f2.add_light_paths(16);
    let total: f64 = (0..4).flat_map(|y| (0..4).map(move |x| (x, y))).map(|(x, y)| f2.pixel_xyz(x, y).y).sum();
    assert!((total - 16.0).abs() < 1e-12, "{total}");
    assert!((f2.pixel_xyz(1, 1).y - 4.0).abs() < 1e-12);
    // Merging two films: splat sums and light paths add, so the scale stays right.
    let mut a = Film::new(spec.clone()).unwrap();
    let mut b = Film::new(spec).unwrap();
    a.add_xyz_splat([0.5, 0.5], Xyz::new(0.0, 6.0, 0.0), &[]);
    a.add_light_paths(12);
    b.add_xyz_splat([0.5, 0.5], Xyz::new(0.0, 2.0, 0.0), &[]);
    b.add_light_paths(12);
    a.merge(&b).unwrap();
    assert_eq!(a.pixel_xyz(0, 0).y, 4.0);
    // The sensor's imaging ratio (ISO 200: ×2) scales splats as it scales camera samples.
    let mut iso = spectral_spec(4, 3, 2, 400.0, 600.0);
    iso.filter = Filter::new_box([0.5, 0.5]).unwrap();
    iso.sensor = film::PixelSensor { imaging_ratio: 2.0, ..Default::default() };
    let mut c = Film::new(iso).unwrap();
    c.add_xyz_splat([0.5, 0.5], Xyz::new(0.0, 6.0, 0.0), &[]);
    c.add_light_paths(12);
    assert_eq!(c.pixel_xyz(0, 0).y, 12.0);
}

#[test]
fn imaging_ratio_scales_colour_exactly_but_not_buckets() {
    // ISO 200 at exposure 1 s: imaging ratio 1 · 200 / 100 = 2, so every pixel's XYZ doubles exactly (a power of two
    // scales floating-point sums without rounding); the spectral buckets are radiance and stay as they are.
    assert_eq!(film::PixelSensor::imaging_ratio(1.0, 200.0), 2.0);
    assert_eq!(film::PixelSensor::imaging_ratio(0.5, 100.0), 0.5);
    let base = spectral_spec(4, 3, 8, 400.0, 720.0);
    let mut doubled = base.clone();
    doubled.sensor.imaging_ratio = film::PixelSensor::imaging_ratio(1.0, 200.0);
    let (mut a, mut b) = (Film::new(base).unwrap(), Film::new(doubled).unwrap());
    let mut rng = Pcg64::seed_from_u64(11);
    for y in 0..3 {
        for x in 0..4 {
            for _ in 0..5 {
                let xyz = Xyz::new(uniform(&mut rng), uniform(&mut rng), uniform(&mut rng));
                let w = uniform(&mut rng);
                let pairs = [(450.0 + 200.0 * uniform(&mut rng) as f32, uniform(&mut rng) as f32)];
                a.add_xyz_sample(x, y, xyz, w, &pairs);
                b.add_xyz_sample(x, y, xyz, w, &pairs);
            }
            let (pa, pb) = (a.pixel_xyz(x, y), b.pixel_xyz(x, y));
            assert_eq!((2.0 * pa.x, 2.0 * pa.y, 2.0 * pa.z), (pb.x, pb.y, pb.z));
            assert_eq!(a.pixel_spectrum(x, y), b.pixel_spectrum(x, y));
        }
    }
    let (ia, ib) = (a.to_rgb_image(), b.to_rgb_image());
    for (p, q) in ia.iter().zip(&ib) {
        for c in 0..3 {
            assert_eq!(2.0 * p[c], q[c]);
        }
    }
}

#[test]
fn max_component_value_clamps_each_sample() {
    // Clamp at 1: a sample (0.5, 4, 2) has largest component 4, so it is scaled by 1/4 → (0.125, 1, 0.5), and its
    // bucket value with it; a sample under the limit is untouched. The clamp applies after the imaging ratio.
    let mut spec = spectral_spec(2, 1, 1, 400.0, 500.0);
    spec.max_component_value = 1.0;
    let mut film = Film::new(spec.clone()).unwrap();
    film.add_xyz_sample(0, 0, Xyz::new(0.5, 4.0, 2.0), 1.0, &[(450.0, 8.0)]);
    film.add_xyz_sample(1, 0, Xyz::new(0.2, 0.9, 0.4), 1.0, &[(450.0, 8.0)]);
    assert_eq!(film.pixel_xyz(0, 0), Xyz::new(0.125, 1.0, 0.5));
    assert_eq!(film.pixel_spectrum(0, 0), vec![8.0 / 4.0 / 100.0]);
    assert_eq!(film.pixel_xyz(1, 0), Xyz::new(0.2, 0.9, 0.4));
    spec.sensor.imaging_ratio = 2.0;
    let mut film = Film::new(spec.clone()).unwrap();
    film.add_xyz_sample(0, 0, Xyz::new(0.2, 0.9, 0.4), 1.0, &[]);
    let p = film.pixel_xyz(0, 0); // (0.4, 1.8, 0.8) scaled by 1/1.8
    assert!((p.x - 0.4 / 1.8).abs() < 1e-15 && p.y == 1.0 && (p.z - 0.8 / 1.8).abs() < 1e-15, "{p:?}");
    // Bad values name the parameter.
    for bad in [0.0, -1.0, f64::NAN] {
        spec.max_component_value = bad;
        let e = Film::new(spec.clone()).unwrap_err().to_string();
        assert!(e.contains("maxcomponentvalue"), "{e}");
    }
}

#[test]
fn white_balance_maps_the_illuminant_to_the_output_white() {
    // A white surface under CIE D50, XYZ normalised to Y = 1 (colour-science 0.4.7: sd_to_XYZ of SDS_ILLUMINANTS
    // ['D50'] linearly interpolated to 1 nm, 360–830 nm: (0.96424065, 1, 0.82512776)). `whitebalance 5000` is
    // (pbrt-v4) daylight at 5000 · 1.4388/1.4380 K, whose chromaticity we compute as (0.345669019, 0.358489925).
    // colour-science's chromatic_adaptation_VonKries(XYZ, xyY_to_XYZ([0.345669019, 0.358489925, 1]),
    // xyY_to_XYZ([0.3127, 0.3290, 1]), transform='Bradford') gives XYZ (0.95045272, 0.99999747, 1.08890548), which
    // is sRGB (0.99991271, 1.00009119, 0.99991383): white to within 1e-3.
    let d50 = Observer::Cie1931.spectrum_to_xyz(&spectral::named::illuminant("stdillum-D50").unwrap());
    for (got, want) in d50.to_array().iter().zip([0.964_240_65, 1.0, 0.825_127_76]) {
        assert!((got - want).abs() < 1e-6, "{d50:?}");
    }
    let mut spec = FilmSpec::new(1, 1, "wb.exr");
    spec.sensor.white_balance_from = Some(spectral::daylight::white_balance_chromaticity(5000.0).unwrap());
    let mut film = Film::new(spec).unwrap();
    film.add_xyz_sample(0, 0, d50, 1.0, &[]);
    let out = film.pixel_xyz(0, 0).to_array();
    let wb = spectral::daylight::white_balance_chromaticity(5000.0).unwrap();
    assert!((wb[0] - 0.345_669_019).abs() < 1e-9 && (wb[1] - 0.358_489_925).abs() < 1e-9, "{wb:?}");
    for (got, want) in out.iter().zip([0.950_452_72, 0.999_997_47, 1.088_905_48]) {
        assert!((got - want).abs() < 1e-7, "{out:?}");
    }
    let rgb = film.to_rgb_image()[0];
    for (got, want) in rgb.iter().zip([0.999_912_71, 1.000_091_19, 0.999_913_83]) {
        // colour-science's sRGB matrix and ours (derived from the primaries) differ in the 4th decimal.
        assert!((*got as f64 - want).abs() < 3e-4, "{rgb:?}");
        assert!((*got as f64 - 1.0).abs() < 1e-3, "{rgb:?}");
    }
    // Without white balance the same surface is visibly warm in sRGB (red above blue by more than 0.2).
    let mut plain = Film::new(FilmSpec::new(1, 1, "p.exr")).unwrap();
    plain.add_xyz_sample(0, 0, d50, 1.0, &[]);
    let rgb = plain.to_rgb_image()[0];
    assert!(rgb[0] - rgb[2] > 0.2, "{rgb:?}");
}

#[test]
fn max_component_value_clamps_a_path_sample_in_sensor_space() {
    // One wavelength, 450 nm, with effective density 0.01/nm and radiance 10: the sample's sensor value (for the
    // cie1931 sensor, XYZ with Y = 1 for a white light of luminance 1) is 10/0.01 · (x̄, ȳ, z̄)(450)/∫ȳ =
    // 1000 · (0.33620, 0.03800, 1.77211)/106.857 = (3.146, 0.3556, 16.584). Its largest component, Z, exceeds
    // maxcomponentvalue 2, so all three are scaled by 2/16.584: (0.3794, 0.04289, 2).
    let wl = spectral::SampledWavelengths::new([450.0; 4], [0.01, 0.0, 0.0, 0.0]);
    let l = SampledSpectrum([10.0, 0.0, 0.0, 0.0]);
    let y_int = Observer::Cie1931.y_integral();
    assert!((y_int - 106.857).abs() < 1e-3, "{y_int}");
    let raw = [0.33620, 0.03800, 1.77211].map(|c| 1000.0 * c / y_int);
    for kind in [FilmKind::Rgb, FilmKind::spectral_default()] {
        let mut spec = FilmSpec::new(1, 1, "clamp.exr");
        (spec.kind, spec.max_component_value) = (kind, 2.0);
        let mut film = Film::new(spec).unwrap();
        assert!(film.add_sample(0, 0, &l, &wl, 1.0));
        let got = film.pixel_xyz(0, 0).to_array();
        for c in 0..3 {
            let want = raw[c] * 2.0 / raw[2];
            assert!((got[c] - want).abs() < 2e-5 * want.max(0.05), "{got:?} vs {want}");
        }
        assert!((got[2] - 2.0).abs() < 1e-6 && (got[0] - 0.3794).abs() < 2e-4 && (got[1] - 0.04289).abs() < 2e-5);
    }
}

#[test]
fn max_component_value_clamps_as_pbrt_v4_with_its_wavelength_pdf() {
    // A clamp is nonlinear, so its bias depends on how each sample's value is distributed, i.e. on the pdf the
    // film draws wavelengths from. Single-wavelength paths of constant radiance 3 (a dispersive surface kept one
    // wavelength) with maxcomponentvalue 10: pbrt-v4 draws λ from 0.0039398042/cosh²(0.0072(λ − 538)) and a sample
    // is 3·(x̄, ȳ, z̄)(λ)/(p(λ)·∫ȳ); the clamped mean is ∫ min(1, 10/max component) · 3·(x̄, ȳ, z̄)/∫ȳ dλ. Blue
    // wavelengths have a small pdf there, so their large Z gets clamped: the image is (2.836, 2.981, 2.139), much
    // less blue than the unclamped (3, 3, 3). A film drawing from x̄ + ȳ + z̄ (Prismatic's pdf before) clamps almost
    // nothing and comes out 40% bluer.
    let obs = Observer::Cie1931;
    let y_int = obs.y_integral();
    let pbrt_pdf = |l: f64| 0.003_939_804_2 / (0.0072 * (l - 538.0)).cosh().powi(2);
    let mut want = [0.0; 3];
    let n = 470_000;
    for i in 0..n {
        let l = 360.0 + 470.0 * (i as f64 + 0.5) / n as f64;
        let cmf = obs.xyz_bar(l);
        let sample = cmf.map(|c| 3.0 * c / (pbrt_pdf(l) * y_int));
        let k = (10.0 / sample[0].max(sample[1]).max(sample[2])).min(1.0);
        for c in 0..3 {
            want[c] += k * 3.0 * cmf[c] / y_int * (470.0 / n as f64);
        }
    }
    for (w, hand) in want.iter().zip([2.836, 2.981, 2.139]) {
        assert!((w - hand).abs() < 2e-3, "{want:?}");
    }
    let mut spec = FilmSpec::new(1, 1, "clamp.exr");
    spec.max_component_value = 10.0;
    let mut film = Film::new(spec).unwrap();
    let m = 100_000;
    for i in 0..m {
        for slot in 0..4 {
            let mut wl = film.sample_wavelengths((i as f64 + 0.5) / m as f64);
            wl.terminate_secondary((slot as f32 + 0.5) / 4.0);
            film.add_sample(0, 0, &SampledSpectrum::splat(3.0), &wl, 1.0);
        }
    }
    let got = film.pixel_xyz(0, 0).to_array();
    for c in 0..3 {
        assert!((got[c] - want[c]).abs() < 2e-3 * want[c], "{got:?} vs pbrt-v4 {want:?}");
    }
}

#[test]
fn a_cropped_film_keeps_full_image_coordinates_and_splat_scale() {
    // A 4×2 crop of an 8×6 image: samples and splats use full-image pixel coordinates; pixels outside the crop are
    // not stored. Each light path estimates the whole 8×6 image, so splat sums are scaled by 48 pixels per light
    // path even though only 8 are stored. Box filter of radius 0.5: a splat at a pixel centre lands in that pixel
    // alone with weight 1.
    let mut spec = FilmSpec::new(8, 6, "crop.exr");
    spec.filter = Filter::new_box([0.5, 0.5]).unwrap();
    spec.pixel_bounds = Some(film::PixelBounds { x0: 3, x1: 7, y0: 2, y1: 4 });
    let mut film = Film::new(spec).unwrap();
    assert_eq!((film.width(), film.height(), film.bounds().width(), film.bounds().height()), (8, 6, 4, 2));
    assert!(film.add_xyz_sample(3, 2, Xyz::new(1.0, 2.0, 3.0), 1.0, &[]));
    assert!(!film.add_xyz_sample(2, 2, Xyz::new(1.0, 2.0, 3.0), 1.0, &[]), "outside the crop");
    let rows: Vec<(u32, std::ops::Range<u32>)> = film.rows_mut().map(|r| (r.y(), r.xs())).collect();
    assert_eq!(rows, vec![(2, 3..7), (3, 3..7)]);
    let mut row = film.row_mut(3).unwrap();
    assert!(row.add_xyz_sample(6, Xyz::new(0.0, 4.0, 0.0), 2.0, &[]));
    assert!(!row.add_xyz_sample(7, Xyz::new(0.0, 4.0, 0.0), 2.0, &[]));
    assert!(film.add_xyz_splat([4.5, 3.5], Xyz::new(0.0, 6.0, 0.0), &[]));
    assert!(film.add_xyz_splat([0.5, 0.5], Xyz::new(0.0, 6.0, 0.0), &[])); // lands outside: nothing stored
    film.add_light_paths(96);
    assert_eq!(film.pixel_xyz(3, 2), Xyz::new(1.0, 2.0, 3.0));
    assert_eq!(film.pixel_xyz(6, 3), Xyz::new(0.0, 4.0, 0.0));
    assert_eq!(film.pixel_xyz(4, 3), Xyz::new(0.0, 6.0 * 48.0 / 96.0, 0.0));
    let image = film.to_rgb_image();
    assert_eq!(image.len(), 8);
    assert_eq!(image[0], film.spec().color_space.to_rgb(Xyz::new(1.0, 2.0, 3.0)).map(|c| c as f32));
}

#[test]
fn a_pixel_under_mitchells_filter_stays_bounded_at_few_samples() {
    // 4 samples per pixel of values uniform in [0, 1]: where their signed filter weights nearly cancel, the weighted
    // average would divide by the remainder. With weights of one magnitude the sum is a whole multiple of it (0, ±2
    // or ±4 of them here), so a pixel is black (sum 0) or within 4/2 = 2 times the samples' largest value.
    let (w, h, n) = (128u32, 128u32, 4);
    let mut spec = FilmSpec::new(w, h, "mitchell.exr");
    spec.filter = Filter::default_for("mitchell").unwrap();
    let sampler = FilterSampler::new(&spec.filter).unwrap();
    let mut film = Film::new(spec).unwrap();
    let mut rng = Pcg64::seed_from_u64(17);
    let (mut negative, mut balanced) = (0, 0);
    for y in 0..h {
        for x in 0..w {
            let mut signs = 0i32;
            for _ in 0..n {
                let s = sampler.sample([uniform(&mut rng), uniform(&mut rng)]);
                let v = uniform(&mut rng);
                negative += usize::from(s.weight < 0.0);
                signs += if s.weight < 0.0 { -1 } else { 1 };
                assert!(film.add_xyz_sample(x, y, Xyz::new(v, v, v), s.weight, &[]));
            }
            balanced += usize::from(signs == 0);
        }
    }
    // The test needs cancellations to mean anything: Mitchell's lobes take about 3% of the samples, so about 0.5%
    // of the pixels get two negative weights of four.
    assert!(negative > 1000 && balanced > 20, "{negative} negative weights, {balanced} balanced pixels");
    let (mut sum, mut count, mut black) = (0.0, 0, 0);
    for y in 0..h {
        for x in 0..w {
            let p = film.pixel_xyz(x, y);
            assert!(p.y.abs() <= 2.0 + 1e-9, "pixel ({x}, {y}) is {}", p.y);
            if film.pixel_weight(x, y) == 0.0 {
                black += 1;
                assert_eq!(p.y, 0.0);
            } else {
                sum += p.y;
                count += 1;
            }
        }
    }
    assert_eq!(black, balanced, "a pixel's weights sum to zero exactly when their signs balance");
    // The samples' values do not depend on the weights, so every pixel with weight estimates their mean, 1/2.
    let mean = sum / count as f64;
    assert!((mean - 0.5).abs() < 0.01, "mean {mean}");
}

//! Filters: closed-form integrals, importance-sampled estimates, the distribution of offsets, validation.

use film::{FilmError, Filter, FilterSampler};
use rand_core::{RngCore, SeedableRng};
use rand_pcg::Pcg64;

fn uniform(rng: &mut Pcg64) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

fn all_filters() -> Vec<Filter> {
    vec![
        Filter::default_for("box").unwrap(),
        Filter::new_box([1.0, 0.75]).unwrap(),
        Filter::default(),
        Filter::gaussian([2.0, 1.0], 0.7).unwrap(),
        Filter::default_for("triangle").unwrap(),
        Filter::default_for("mitchell").unwrap(),
        Filter::mitchell([1.5, 2.5], 0.5, 0.25).unwrap(),
    ]
}

/// Midpoint quadrature of f·g over the filter's support.
fn quadrature(f: &Filter, g: impl Fn([f64; 2]) -> f64) -> f64 {
    let r = f.radius();
    let n = 800;
    let (hx, hy) = (2.0 * r[0] / n as f64, 2.0 * r[1] / n as f64);
    let mut s = 0.0;
    for j in 0..n {
        for i in 0..n {
            let p = [-r[0] + (i as f64 + 0.5) * hx, -r[1] + (j as f64 + 0.5) * hy];
            s += f.evaluate(p) * g(p);
        }
    }
    s * hx * hy
}

#[test]
fn closed_form_integrals_match_quadrature() {
    for f in all_filters() {
        let q = quadrature(&f, |_| 1.0);
        assert!((f.integral() - q).abs() < 1e-4 * q.abs().max(1.0), "{f:?}: {} vs {q}", f.integral());
    }
    // pbrt-v4's gaussian is g(x) − g(r) per axis: zero at the radius, positive inside.
    let g = Filter::default();
    assert_eq!(g.evaluate([1.5, 0.0]), 0.0);
    assert!(g.evaluate([1.49, 0.0]) > 0.0);
    assert_eq!(g.evaluate([1.6, 0.0]), 0.0);
}

#[test]
fn box_weight_is_one_and_offsets_uniform() {
    let s = FilterSampler::new(&Filter::default_for("box").unwrap()).unwrap();
    let mut rng = Pcg64::seed_from_u64(1);
    let mut sum = [0.0; 2];
    let n = 100_000;
    for _ in 0..n {
        let d = s.sample([uniform(&mut rng), uniform(&mut rng)]);
        assert_eq!(d.weight, 1.0);
        assert!(d.offset[0].abs() <= 0.5 && d.offset[1].abs() <= 0.5);
        sum[0] += d.offset[0];
        sum[1] += d.offset[1];
    }
    assert!(sum[0].abs() / (n as f64) < 0.005 && sum[1].abs() / (n as f64) < 0.005);
}

#[test]
fn importance_sampled_estimates_equal_the_integrals() {
    // E[w] = ∫f, and E[w·g(p)] = ∫f·g for a smooth test function g.
    let g = |p: [f64; 2]| 1.0 + 0.3 * p[0] + 0.2 * p[1] * p[1] + 0.1 * (p[0] * p[1]).sin();
    for f in all_filters() {
        let s = FilterSampler::new(&f).unwrap();
        let mut rng = Pcg64::seed_from_u64(7);
        let n = 200_000;
        let (mut sw, mut swg) = (0.0, 0.0);
        for _ in 0..n {
            let d = s.sample([uniform(&mut rng), uniform(&mut rng)]);
            sw += d.weight;
            swg += d.weight * g(d.offset);
        }
        let (ew, ewg) = (sw / n as f64, swg / n as f64);
        let (iw, iwg) = (f.integral(), quadrature(&f, g));
        assert!((ew - iw).abs() < 0.01 * iw, "{f:?}: E[w] = {ew}, ∫f = {iw}");
        assert!((ewg - iwg).abs() < 0.01 * iwg, "{f:?}: E[w g] = {ewg}, ∫f g = {iwg}");
    }
}

#[test]
fn positive_filters_have_nearly_constant_weights() {
    for f in [Filter::default(), Filter::default_for("triangle").unwrap()] {
        let s = FilterSampler::new(&f).unwrap();
        let mut rng = Pcg64::seed_from_u64(3);
        let weights: Vec<f64> = (0..20_000).map(|_| s.sample([uniform(&mut rng), uniform(&mut rng)]).weight).collect();
        // The table is piecewise constant and the filter is not, so the ratio varies a little inside each cell
        // (most in the last cells before the radius, where both go to zero): positive, bounded, small spread.
        let i = f.integral();
        assert!(weights.iter().all(|&w| w > 0.0 && w < 2.0 * i), "{f:?}");
        let mean = weights.iter().sum::<f64>() / weights.len() as f64;
        let var = weights.iter().map(|w| (w - mean).powi(2)).sum::<f64>() / weights.len() as f64;
        assert!(var.sqrt() < 0.05 * i, "{f:?}: spread {} of {i}", var.sqrt());
    }
    // Mitchell's negative lobes give negative weights.
    let s = FilterSampler::new(&Filter::default_for("mitchell").unwrap()).unwrap();
    let mut rng = Pcg64::seed_from_u64(4);
    let negative = (0..10_000).filter(|_| s.sample([uniform(&mut rng), uniform(&mut rng)]).weight < 0.0).count();
    assert!(negative > 100, "{negative}");
}

/// ∫ from a to b of pbrt-v4's 1D gaussian g(x) − g(r), by fine midpoint quadrature.
fn gaussian_1d_mass(a: f64, b: f64, r: f64, sigma: f64) -> f64 {
    let g = |x: f64| (-x * x / (2.0 * sigma * sigma)).exp() / ((2.0 * std::f64::consts::PI).sqrt() * sigma);
    let n = 20_000;
    let h = (b - a) / n as f64;
    (0..n).map(|i| (g(a + (i as f64 + 0.5) * h) - g(r)).max(0.0) * h).sum()
}

#[test]
fn gaussian_offsets_are_chi_square_consistent() {
    let (r, sigma) = (1.5, 0.5);
    let s = FilterSampler::new(&Filter::default()).unwrap();
    let bins = 10;
    let edges: Vec<f64> = (0..=bins).map(|i| -r + 2.0 * r * i as f64 / bins as f64).collect();
    let mass: Vec<f64> = edges.windows(2).map(|e| gaussian_1d_mass(e[0], e[1], r, sigma)).collect();
    let total: f64 = mass.iter().sum();
    let n = 400_000usize;
    let mut counts = vec![0usize; bins * bins];
    let mut rng = Pcg64::seed_from_u64(11);
    let cell = |v: f64| (((v + r) / (2.0 * r) * bins as f64) as usize).min(bins - 1);
    for _ in 0..n {
        let d = s.sample([uniform(&mut rng), uniform(&mut rng)]);
        counts[cell(d.offset[1]) * bins + cell(d.offset[0])] += 1;
    }
    // Pool the bins expecting fewer than 20 samples into one.
    let (mut chi2, mut dof) = (0.0, 0usize);
    let (mut pooled_obs, mut pooled_exp) = (0.0, 0.0);
    for j in 0..bins {
        for i in 0..bins {
            let expected = n as f64 * mass[i] * mass[j] / (total * total);
            let observed = counts[j * bins + i] as f64;
            if expected < 20.0 {
                pooled_obs += observed;
                pooled_exp += expected;
            } else {
                chi2 += (observed - expected).powi(2) / expected;
                dof += 1;
            }
        }
    }
    if pooled_exp > 0.0 {
        chi2 += (pooled_obs - pooled_exp).powi(2) / pooled_exp;
        dof += 1;
    }
    dof -= 1;
    // The 99.9th percentile of χ² is below dof + 3.1·√(2·dof) + 10 for these degrees of freedom.
    let limit = dof as f64 + 3.1 * (2.0 * dof as f64).sqrt() + 10.0;
    assert!(chi2 < limit, "χ² = {chi2} with {dof} degrees of freedom (limit {limit})");
}

#[test]
fn sampling_is_deterministic_and_pdf_matches() {
    let s = FilterSampler::new(&Filter::default()).unwrap();
    let a = s.sample([0.25, 0.75]);
    let b = s.sample([0.25, 0.75]);
    assert_eq!(a, b);
    let f = Filter::default();
    assert!((a.weight - f.evaluate(a.offset) / s.pdf(a.offset)).abs() < 1e-12);
    assert_eq!(s.pdf([2.0, 0.0]), 0.0);
    // Out-of-range and NaN-free edge inputs do not panic.
    let _ = s.sample([1.0, 1.0]);
    let _ = s.sample([-0.5, 2.0]);
    let _ = s.sample([f64::NAN, 0.5]);
}

#[test]
fn bad_parameters_are_named() {
    let name = |e: FilmError| match e {
        FilmError::InvalidParameter { name, .. } => name,
        e @ (FilmError::TooLarge { .. }
        | FilmError::Mismatch(_)
        | FilmError::OutOfBounds { .. }
        | FilmError::Table(_)) => {
            panic!("unexpected {e:?}")
        }
    };
    assert_eq!(name(Filter::new_box([-0.5, 0.5]).unwrap_err()), "xradius");
    assert_eq!(name(Filter::gaussian([1.5, 0.0], 0.5).unwrap_err()), "yradius");
    assert_eq!(name(Filter::gaussian([1.5, 1.5], -1.0).unwrap_err()), "sigma");
    assert_eq!(name(Filter::gaussian([1.5, f64::NAN], 0.5).unwrap_err()), "yradius");
    assert_eq!(name(Filter::triangle([f64::INFINITY, 1.0]).unwrap_err()), "xradius");
    assert_eq!(name(Filter::mitchell([2.0, 2.0], f64::NAN, 0.3).unwrap_err()), "B");
    let e = Filter::new_box([-1.0, 1.0]).unwrap_err().to_string();
    assert!(e.contains("radius") && e.contains("-1"), "{e}");
    assert!(FilterSampler::new(&Filter::Box { radius: [-1.0, 1.0] }).is_err());
    assert!(Filter::default_for("lanczos").is_none());
    // A huge radius is capped in the table, not an allocation failure.
    let big = FilterSampler::new(&Filter::gaussian([1000.0, 1000.0], 300.0).unwrap()).unwrap();
    assert!(big.sample([0.5, 0.5]).weight.is_finite());
}

#[test]
fn mitchell_weights_are_one_magnitude_of_either_sign() {
    for f in [Filter::default_for("mitchell").unwrap(), Filter::mitchell([1.5, 2.5], 0.5, 0.25).unwrap()] {
        let s = FilterSampler::new(&f).unwrap();
        let mut rng = Pcg64::seed_from_u64(5);
        let weights: Vec<f64> = (0..20_000).map(|_| s.sample([uniform(&mut rng), uniform(&mut rng)]).weight).collect();
        let m = weights[0].abs();
        assert!(weights.iter().all(|w| w.abs() == m), "{f:?}");
        assert!(weights.iter().any(|&w| w < 0.0) && weights.iter().any(|&w| w > 0.0), "{f:?}");
        // 16 significant bits: exact in f32 (camera samples carry their weight so), and every sum of a pixel's
        // weights a whole multiple of m, exact in f64.
        assert_eq!(m as f32 as f64, m);
        assert_eq!((m * 2f64.powi(15 - m.log2().floor() as i32)).fract(), 0.0, "{m}");
        // The sign is the filter's wherever it is not near a zero crossing.
        for _ in 0..1000 {
            let d = s.sample([uniform(&mut rng), uniform(&mut rng)]);
            let v = f.evaluate(d.offset);
            if v.abs() > 0.01 {
                assert_eq!(d.weight.signum(), v.signum(), "{f:?} at {:?}", d.offset);
            }
        }
    }
}

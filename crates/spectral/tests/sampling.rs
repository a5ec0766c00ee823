//! Statistical tests: every sampler draws from the density it reports, every density integrates to 1, and the
//! wavelength estimators converge to direct integration. All tests use fixed seeds, so they are deterministic; the
//! thresholds are chosen so a correct sampler fails with probability about 1e-3 or less and a wrong one cannot pass.

use rand_core::{RngCore, SeedableRng};
use rand_pcg::Pcg64;
use spectral::distribution::{Distribution1D, Distribution2D};
use spectral::wavelengths::stiles_burch_pdf;
use spectral::{named, Observer, SampledSpectrum, Spectrum, WavelengthSampler, WavelengthStrategy};

fn uniform(rng: &mut Pcg64) -> f64 {
    (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64
}

/// Upper critical value of χ² with `k` degrees of freedom at significance 0.001 (Wilson–Hilferty approximation).
fn chi2_critical_0001(k: usize) -> f64 {
    let k = k as f64;
    let z = 3.090_232; // standard normal quantile at 0.999
    k * (1.0 - 2.0 / (9.0 * k) + z * (2.0 / (9.0 * k)).sqrt()).powi(3)
}

/// χ² statistic over cells with expected counts, merging cells whose expectation is below 5 into a neighbour.
fn chi2(observed: &[f64], expected: &[f64]) -> (f64, usize) {
    let (mut stat, mut cells) = (0.0, 0usize);
    let (mut o_acc, mut e_acc) = (0.0, 0.0);
    for (o, e) in observed.iter().zip(expected) {
        o_acc += o;
        e_acc += e;
        if e_acc >= 5.0 {
            stat += (o_acc - e_acc).powi(2) / e_acc;
            cells += 1;
            o_acc = 0.0;
            e_acc = 0.0;
        }
    }
    assert!(o_acc == 0.0 || e_acc > 0.0, "observed samples where the density is zero");
    if e_acc > 0.0 {
        stat += (o_acc - e_acc).powi(2) / e_acc;
        cells += 1;
    }
    (stat, cells.saturating_sub(1))
}

/// Kolmogorov–Smirnov statistic of `samples` against the continuous `cdf`.
fn ks(mut samples: Vec<f64>, cdf: impl Fn(f64) -> f64) -> f64 {
    samples.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let n = samples.len() as f64;
    samples.iter().enumerate().fold(0.0f64, |d, (i, &x)| {
        let f = cdf(x);
        d.max((f - i as f64 / n).abs()).max(((i + 1) as f64 / n - f).abs())
    })
}

/// KS critical value at significance 0.001 for `n` samples.
fn ks_critical_0001(n: usize) -> f64 {
    1.949 / (n as f64).sqrt()
}

fn check_1d(d: &Distribution1D, rng: &mut Pcg64, n: usize) {
    // The density integrates to 1 (midpoint rule, exact for a piecewise-constant density on bin midpoints).
    let (a, b) = d.domain();
    let m = d.len() * 8;
    let integral: f64 =
        (0..m).map(|i| d.pdf(a + (b - a) * (i as f64 + 0.5) / m as f64)).sum::<f64>() * (b - a) / m as f64;
    assert!((integral - 1.0).abs() < 1e-9, "pdf integrates to {integral}");
    // Samples fall in bins with the reported probabilities (χ²), and within bins as the continuous cdf says (KS).
    let mut counts = vec![0.0; d.len()];
    let mut xs = Vec::with_capacity(n);
    for _ in 0..n {
        let s = d.sample(uniform(rng));
        assert!(s.x >= a && s.x < b);
        assert!(
            (s.pdf - d.pdf(s.x)).abs() <= 1e-12 * s.pdf.max(1.0),
            "reported pdf {} vs pdf(x) {}",
            s.pdf,
            d.pdf(s.x)
        );
        assert!(s.pdf > 0.0, "sampled a zero-density point");
        counts[s.bin] += 1.0;
        xs.push(s.x);
    }
    let expected: Vec<f64> = (0..d.len()).map(|j| d.bin_probability(j) * n as f64).collect();
    let (stat, dof) = chi2(&counts, &expected);
    if dof > 0 {
        assert!(stat < chi2_critical_0001(dof), "χ² = {stat} with {dof} dof");
    }
    let dks = ks(xs, |x| d.cdf(x));
    assert!(dks < ks_critical_0001(n), "KS D = {dks}");
}

#[test]
fn distribution_1d_draws_from_its_pdf() {
    let mut rng = Pcg64::seed_from_u64(1);
    for (len, zeros) in [(1, false), (7, true), (64, false), (300, true)] {
        let f: Vec<f64> = (0..len)
            .map(|i| if zeros && i % 3 == 1 { 0.0 } else { uniform(&mut rng) * 10.0 + (i % 5) as f64 })
            .collect();
        let d = Distribution1D::new(&f, -2.0, 5.0).unwrap();
        check_1d(&d, &mut rng, 50_000);
    }
}

#[test]
fn wavelength_tables_draw_from_their_pdfs() {
    let mut rng = Pcg64::seed_from_u64(2);
    check_1d(&stiles_burch_pdf(), &mut rng, 100_000);
    for observer in Observer::ALL {
        check_1d(WavelengthSampler::new(WavelengthStrategy::Hero, observer).visible_distribution(), &mut rng, 100_000);
    }
}

#[test]
fn distribution_2d_draws_from_its_pdf() {
    let mut rng = Pcg64::seed_from_u64(3);
    let (w, h) = (12, 9);
    let values: Vec<f64> =
        (0..w * h).map(|i| if i % 7 == 0 { 0.0 } else { 1.0 + uniform(&mut rng) * 4.0 + (i / w) as f64 }).collect();
    let d = Distribution2D::new(&values, w, h, (0.0, 2.0), (1.0, 4.0)).unwrap();
    // ∫∫ pdf = 1.
    let m = 8;
    let mut integral = 0.0;
    for j in 0..h * m {
        for i in 0..w * m {
            integral += d.pdf([2.0 * (i as f64 + 0.5) / (w * m) as f64, 1.0 + 3.0 * (j as f64 + 0.5) / (h * m) as f64]);
        }
    }
    integral *= 6.0 / (w * h * m * m) as f64;
    assert!((integral - 1.0).abs() < 1e-9, "{integral}");
    // χ² over the cells: expected probability of a cell is value / Σ values.
    let total: f64 = values.iter().sum();
    let n = 200_000;
    let mut counts = vec![0.0; w * h];
    for _ in 0..n {
        let s = d.sample([uniform(&mut rng), uniform(&mut rng)]);
        assert!((s.pdf - d.pdf(s.point)).abs() < 1e-9 * s.pdf);
        let (i, j) = (((s.point[0] / 2.0) * w as f64) as usize, (((s.point[1] - 1.0) / 3.0) * h as f64) as usize);
        counts[j.min(h - 1) * w + i.min(w - 1)] += 1.0;
    }
    let expected: Vec<f64> = values.iter().map(|v| v / total * n as f64).collect();
    let (stat, dof) = chi2(&counts, &expected);
    assert!(stat < chi2_critical_0001(dof), "χ² = {stat} with {dof} dof");
}

/// For every strategy, Σᵢ 1[λᵢ ∈ B]/pdfᵢ must estimate the width of every 10 nm bin B of its support: this holds
/// exactly when each slot's λ is distributed as its reported (effective) density says.
#[test]
fn wavelength_strategies_report_the_density_they_sample() {
    let mut rng = Pcg64::seed_from_u64(4);
    let n = 400_000;
    for strategy in WavelengthStrategy::ALL {
        let sampler = WavelengthSampler::new(strategy, Observer::Cie1931);
        let (lo, hi) = if strategy == WavelengthStrategy::Cmf { (390.0, 830.0) } else { (360.0, 830.0) };
        let nb = ((hi - lo) / 10.0) as usize;
        let mut sum = vec![0.0f64; nb];
        let mut sum2 = vec![0.0f64; nb];
        let mut hits = vec![0usize; nb];
        for _ in 0..n {
            let wl = sampler.sample(uniform(&mut rng));
            let mut contrib = vec![0.0f64; nb];
            for i in 0..4 {
                if wl.is_active(i) {
                    let l = wl.lambda(i) as f64;
                    assert!((lo..=hi).contains(&l), "{strategy}: λ = {l}");
                    let b = (((l - lo) / 10.0) as usize).min(nb - 1);
                    contrib[b] += 1.0 / wl.pdf()[i] as f64;
                    hits[b] += 1;
                }
            }
            for b in 0..nb {
                sum[b] += contrib[b];
                sum2[b] += contrib[b] * contrib[b];
            }
        }
        for b in 0..nb {
            // Far tails (above ~780 nm) are so rarely drawn that a bin may see no sample: the standard error is
            // meaningless there, so only bins with at least 30 hits are compared.
            if hits[b] < 30 {
                continue;
            }
            let mean = sum[b] / n as f64;
            let se = ((sum2[b] / n as f64 - mean * mean) / n as f64).sqrt();
            assert!((mean - 10.0).abs() < 4.5 * se + 1e-3, "{strategy}: bin {b} estimates width {mean} ± {se}");
            // The tails (where the observer barely sees) are sampled rarely by design; in 430–650 nm the estimate
            // must be tight enough that a density off by 8% would fail
            // (the densities themselves are tested exactly by χ² and KS above; this checks the slot bookkeeping).
            let centre = lo + 10.0 * b as f64 + 5.0;
            if (430.0..650.0).contains(&centre) {
                assert!(se < 0.15, "{strategy}: bin {b} too noisy to test ({se})");
            }
        }
    }
}

fn narrow_band_600() -> Spectrum {
    // A Gaussian of σ = 3 nm at 600 nm, tabulated at 0.25 nm.
    let l: Vec<f64> = (0..=240).map(|i| 570.0 + i as f64 * 0.25).collect();
    let v = l.iter().map(|x| (-0.5 * ((x - 600.0) / 3.0f64).powi(2)).exp()).collect();
    Spectrum::piecewise_linear(l, v).unwrap()
}

/// Mean and standard error of the XYZ estimate over `n` paths; with `dispersive`, every path meets a dispersive
/// event and keeps one wavelength.
fn estimate(sampler: &WavelengthSampler, s: &Spectrum, n: usize, dispersive: bool, seed: u64) -> ([f64; 3], [f64; 3]) {
    let mut rng = Pcg64::seed_from_u64(seed);
    let (mut sum, mut sum2) = ([0.0; 3], [0.0; 3]);
    for _ in 0..n {
        let mut wl = sampler.sample(uniform(&mut rng));
        if dispersive {
            wl.terminate_secondary(uniform(&mut rng) as f32);
        }
        let radiance: SampledSpectrum = s.sample(&wl);
        let xyz = sampler.to_xyz(&radiance, &wl).to_array();
        for c in 0..3 {
            sum[c] += xyz[c];
            sum2[c] += xyz[c] * xyz[c];
        }
    }
    let mean = sum.map(|v| v / n as f64);
    let se = std::array::from_fn(|c| ((sum2[c] / n as f64 - mean[c] * mean[c]) / n as f64).sqrt());
    (mean, se)
}

#[test]
fn estimators_converge_to_direct_integration() {
    let spectra = [
        ("flat", Spectrum::Constant(0.7)),
        ("D65", named::illuminant("stdillum-D65").unwrap()),
        ("narrow band at 600 nm", narrow_band_600()),
    ];
    for strategy in WavelengthStrategy::ALL {
        for observer in Observer::ALL {
            let sampler = WavelengthSampler::new(strategy, observer);
            for (name, s) in &spectra {
                let reference = sampler.reference_xyz(s).to_array();
                for dispersive in [false, true] {
                    let (mean, se) = estimate(&sampler, s, 100_000, dispersive, 5);
                    for c in 0..3 {
                        // Tolerance: 4.5 standard errors (a correct estimator fails with p < 1e-5 per component),
                        // plus 1e-5 absolute for f32 rounding of λ and pdf; the standard error itself must be small
                        // (under 2% of the reference's largest component) so the test has power.
                        let scale = reference.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                        assert!(se[c] < 0.02 * scale, "{strategy}/{name}: SE {se:?} too large");
                        assert!(
                            (mean[c] - reference[c]).abs() < 4.5 * se[c] + 1e-5 * scale,
                            "{strategy}/{observer:?}/{name}/dispersive={dispersive}: component {c}: {mean:?} ± {se:?} vs {reference:?}"
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn cmf_strategy_agrees_with_the_1964_observer_it_approximates() {
    // The Stiles & Burch route to XYZ₁₀ differs from the CIE 1964 table only by the fit residual (pilot vs final
    // data): D65's chromaticity must agree to 0.002.
    let sampler = WavelengthSampler::new(WavelengthStrategy::Cmf, Observer::Cie1964);
    let d65 = named::illuminant("stdillum-D65").unwrap();
    let via_sb = sampler.reference_xyz(&d65).chromaticity();
    let direct = Observer::Cie1964.spectrum_to_xyz(&d65).chromaticity();
    assert!((via_sb[0] - direct[0]).abs() < 2e-3 && (via_sb[1] - direct[1]).abs() < 2e-3, "{via_sb:?} vs {direct:?}");
}

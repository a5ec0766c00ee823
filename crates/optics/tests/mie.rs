//! Lorenz–Mie scattering against independent values, the phase tables' exactness and sampling, rainbow geometry.
//!
//! Reference numbers come from two independent implementations, run once and pasted here (the tests need neither):
//! scattnlay 2.4 (Peña & Pal 2009, Comput. Phys. Commun. 180, 2348; PyPI `scattnlay`), called with the index
//! n + ik in Bohren & Huffman's convention, whose S1 and S2 are B&H's; and miepython 3.3.0 (PyPI `miepython`,
//! after Wiscombe 1979), which agrees with scattnlay to ≤ 3e-10 relative in Q_ext, Q_sca and g for every case here,
//! to ≤ 2.3e-6 in Q_back, and to ≤ 1.3e-6 in S1, S2 (miepython's S with `norm='bohren'` is 2·conj of B&H's).

use optics::mie::{
    descartes_rainbow_angle, log_normal_node_count, log_normal_nodes, mie_amplitudes, mie_efficiencies, particle_index,
    MieCoefficients, MiePhaseTable, MieSpectralTable, MAX_SIZE_PARAMETER,
};
use optics::{catalogue, Complex, OpticsError};

/// (n, k, x, Q_ext, Q_sca, Q_back, g) from scattnlay 2.4.
const EFFICIENCIES: [(f64, f64, f64, f64, f64, f64, f64); 14] = [
    // Bohren & Huffman 1983, appendix A (BHMIE's example: r = 0.525 µm, λ = 0.6328 µm), whose printout gives
    // Q_sca = Q_ext = 3.10543 and Q_back = 2.92534.
    (1.55, 0.0, 5.212819668567135, 3.105425531466e+00, 3.105425531466e+00, 2.9253406497e+00, 6.331367580409e-01),
    (1.5, 0.0, 10.0, 2.881998952076e+00, 2.881998952076e+00, 1.6950635834e+00, 7.429128985687e-01),
    (1.5, 0.0, 100.0, 2.094387814677e+00, 2.094387814677e+00, 1.7361930101e+00, 8.182464399387e-01),
    (1.5, 0.0, 1000.0, 2.013944647149e+00, 2.013944647149e+00, 1.0303087153e+01, 8.278819606002e-01),
    (1.33, 1e-5, 1000.0, 2.016875432686e+00, 1.983333340295e+00, 5.4425742266e-01, 8.857723684569e-01),
    (1.5, 0.1, 1000.0, 2.019702521069e+00, 1.106932388926e+00, 4.1533559830e-02, 9.508799127403e-01),
    (1.33, 1e-2, 2000.0, 2.012508872054e+00, 1.074620278177e+00, 2.0077363797e-02, 9.719100712715e-01),
    (1.5, 0.1, 5000.0, 2.006775107548e+00, 1.099192953608e+00, 4.1533546863e-02, 9.506501430628e-01),
    (1.33, 1e-5, 5000.0, 2.005718928077e+00, 1.852025847931e+00, 6.8897063810e-01, 8.970528372710e-01),
    (1.342, 1e-3, 4000.0, 2.007897272256e+00, 1.073719952478e+00, 2.1325122398e-02, 9.705449277809e-01),
    (1.5, 1.0, 10.0, 2.417294528491e+00, 1.346957826094e+00, 1.7292620188e-01, 8.346946423125e-01),
    (0.75, 0.0, 10.0, 2.232264842502e+00, 2.232264842502e+00, 4.6584410116e-02, 8.964725543469e-01),
    (1.5, 0.1, 0.1, 2.006001462551e-02, 2.403819039554e-05, 3.5887611239e-05, 1.978246521909e-03),
    (3.0, 4.0, 2.0, 2.970350954710e+00, 2.116087265144e+00, 1.0069271916e+00, 4.289852262779e-01),
];

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn efficiencies_match_independent_values() {
    for &(n, k, x, ext, sca, back, g) in &EFFICIENCIES {
        let q = mie_efficiencies(Complex::new(n, k), x).unwrap();
        let what = format!("m = {n} + {k}i, x = {x}: {q:?}");
        // The references carry 13 digits; both implementations agree to ≤ 3e-10.
        assert!(rel(q.q_ext, ext) < 1e-9, "Q_ext {what}");
        assert!(rel(q.q_sca, sca) < 1e-9, "Q_sca {what}");
        assert!(rel(q.g, g) < 1e-9, "g {what}");
        assert!((q.q_abs - (ext - sca)).abs() < 1e-9 * ext, "Q_abs {what}");
        // Q_back sums terms of alternating sign and is the touchiest: the two references differ by up to 2.3e-6.
        assert!(rel(q.q_back, back) < 1e-5, "Q_back {what}");
    }
    // Bohren & Huffman's printed values.
    let q = mie_efficiencies(Complex::new(1.55, 0.0), 2.0 * std::f64::consts::PI * 0.525 / 0.6328).unwrap();
    assert!((q.q_sca - 3.10543).abs() < 5e-6 && (q.q_ext - 3.10543).abs() < 5e-6 && (q.q_back - 2.92534).abs() < 5e-6);
}

/// (θ in degrees, S1, S2) from scattnlay 2.4, B&H normalisation and sign convention.
type AmplitudeRow = (f64, [f64; 2], [f64; 2]);

const AMPLITUDES: [(f64, f64, f64, [AmplitudeRow; 5]); 4] = [
    (
        1.55,
        0.0,
        5.212819668567135,
        [
            (0.0, [2.109631154994e+01, 8.577001086030e+00], [2.109631154994e+01, 8.577001086030e+00]),
            (30.0, [1.159098036470e+00, 2.465328288237e+00], [1.933939658104e-01, 6.003095640327e+00]),
            (90.0, [2.381869247400e+00, 1.509302632509e+00], [1.494931423688e+00, 1.654678571503e+00]),
            (137.5, [7.526080776204e-01, 6.873947308418e-01], [2.582409621723e+00, -9.896606261797e-01]),
            (180.0, [-1.356813992222e+00, -4.246408330188e+00], [1.356813992222e+00, 4.246408330188e+00]),
        ],
    ),
    (
        1.5,
        0.1,
        100.0,
        [
            (0.0, [5.224554608161e+03, 2.616937684321e+02], [5.224554608161e+03, 2.616937684321e+02]),
            (30.0, [3.367899475613e+01, 1.054907876948e+01], [1.775293524091e+01, 6.528443109418e+00]),
            (90.0, [1.192235704949e+00, -1.537316103259e+01], [-8.508541799531e-01, 4.663318344932e+00]),
            (137.5, [-8.753753555409e+00, -6.933722943118e+00], [7.146513166257e+00, 5.801829167794e+00]),
            (180.0, [-9.549519050435e+00, 3.555808251207e+00], [9.549519050435e+00, -3.555808251207e+00]),
        ],
    ),
    (
        1.33,
        1e-5,
        1000.0,
        [
            (0.0, [5.042188581715e+05, 8.910429310143e+03], [5.042188581715e+05, 8.910429310143e+03]),
            (30.0, [-7.421661569492e+02, 1.569512477045e+02], [-8.599443994587e+02, 2.556097438773e+02]),
            (90.0, [4.905117894678e+01, 7.743740379828e+01], [-2.733851621025e+01, -2.504205574155e+01]),
            (137.5, [-5.053616171938e+02, -3.477402810245e+02], [-8.389141766397e+01, 4.388217921759e+01]),
            (180.0, [-2.675935116865e+02, 2.538859353487e+02], [2.675935116865e+02, -2.538859353487e+02]),
        ],
    ),
    (
        1.342,
        1e-3,
        4000.0,
        [
            (0.0, [8.031589089023e+06, 4.858928622003e+04], [8.031589089023e+06, 4.858928622003e+04]),
            (30.0, [-2.690840300547e+02, -1.100249698533e+03], [-1.610342574597e+02, -6.487595973143e+02]),
            (90.0, [4.294281591225e+02, -1.890312479776e+02], [-1.009055086156e+02, 4.416414051194e+01]),
            (137.5, [-2.827004962392e+02, -1.579498865991e+02], [2.270751695126e+02, 1.269123578207e+02]),
            (180.0, [2.913863248515e+02, 1.986200602726e+01], [-2.913863248515e+02, -1.986200602726e+01]),
        ],
    ),
];

#[test]
fn amplitudes_match_independent_values() {
    for (n, k, x, rows) in AMPLITUDES {
        let mus: Vec<f64> = rows.iter().map(|r| r.0.to_radians().cos()).collect();
        let got = mie_amplitudes(Complex::new(n, k), x, &mus).unwrap();
        for ((deg, s1, s2), (g1, g2)) in rows.iter().zip(&got) {
            let (w1, w2) = (Complex::new(s1[0], s1[1]), Complex::new(s2[0], s2[1]));
            let scale = w1.abs().max(w2.abs());
            // ≤ 1e-5 of the amplitude's size at that angle (the references agree to ≤ 1.3e-6).
            assert!((*g1 - w1).abs() < 1e-5 * scale, "S1 at {deg}° for m = {n} + {k}i, x = {x}: {g1:?} vs {w1:?}");
            assert!((*g2 - w2).abs() < 1e-5 * scale, "S2 at {deg}° for m = {n} + {k}i, x = {x}: {g2:?} vs {w2:?}");
        }
    }
}

#[test]
fn forward_and_backward_amplitudes_obey_the_optical_theorem_and_the_backscatter_formula() {
    for &(n, k, x, ..) in &EFFICIENCIES {
        let c = MieCoefficients::new(Complex::new(n, k), x).unwrap();
        let q = c.efficiencies();
        let (s0, _) = c.amplitudes(1.0);
        let (s180, _) = c.amplitudes(-1.0);
        // B&H eq. 4.76: Q_ext = (4/x²)·Re S(0°); eq. 4.82 and the text after it: Q_back = 4|S1(180°)|²/x².
        assert!(rel(4.0 * s0.re / (x * x), q.q_ext) < 1e-12, "optical theorem at x = {x}");
        assert!(rel(4.0 * s180.norm_sqr() / (x * x), q.q_back) < 1e-9, "Q_back at x = {x}");
    }
}

#[test]
fn rayleigh_limit() {
    // B&H eq. 5.8: Q_sca = (8/3)·x⁴·|(m²−1)/(m²+2)|², Q_abs = 4x·Im((m²−1)/(m²+2)), to relative O(x²).
    for (m, x) in [(Complex::new(1.5, 0.1), 1e-2), (Complex::new(1.33, 0.0), 1e-3), (Complex::new(0.2, 3.0), 1e-2)] {
        let one = Complex::from_real(1.0);
        let m2 = m * m;
        let alpha = (m2 - one) / (m2 + Complex::from_real(2.0));
        let q = mie_efficiencies(m, x).unwrap();
        let tol = 10.0 * x * x * m.norm_sqr().max(1.0);
        assert!(rel(q.q_sca, 8.0 / 3.0 * x.powi(4) * alpha.norm_sqr()) < tol, "{m:?}, {x}: {q:?}");
        if m.im > 0.0 {
            assert!(rel(q.q_abs, 4.0 * x * alpha.im) < tol, "{m:?}, {x}: {q:?}");
        }
        assert!((q.g).abs() < 10.0 * x * x, "{q:?}");
    }
}

#[test]
fn extinction_paradox() {
    // Q_ext → 2 as x → ∞; the approach goes as x^{−2/3} (van de Hulst 1957, §17.2: 2 + 1.99·x^{−2/3} for the
    // edge term), so |Q_ext − 2| < 3·x^{−2/3} bounds it with room for the ripple.
    let mut last = f64::INFINITY;
    for x in [100.0, 1000.0, 10_000.0, 50_000.0] {
        let q = mie_efficiencies(Complex::new(1.33, 0.0), x).unwrap();
        let dev = (q.q_ext - 2.0).abs();
        assert!(dev < 3.0 * x.powf(-2.0 / 3.0), "x = {x}: Q_ext = {}", q.q_ext);
        assert!(dev < last, "x = {x}: |Q_ext − 2| = {dev} did not shrink");
        assert!(q.q_abs < 1e-10, "non-absorbing: {q:?}");
        last = dev;
    }
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let m = Complex::new(1.33, 0.0);
    for (m, x) in [
        (m, 0.0),
        (m, -1.0),
        (m, f64::NAN),
        (m, f64::INFINITY),
        (m, MAX_SIZE_PARAMETER * 1.01),
        (Complex::new(0.0, 0.0), 1.0),
        (Complex::new(-1.33, 0.0), 1.0),
        (Complex::new(1.33, -1e-3), 1.0),
        (Complex::new(f64::NAN, 0.0), 1.0),
        (Complex::new(1.33, f64::INFINITY), 1.0),
    ] {
        assert!(mie_efficiencies(m, x).is_err(), "{m:?}, {x}");
        assert!(mie_amplitudes(m, x, &[0.5]).is_err(), "{m:?}, {x}");
        assert!(MiePhaseTable::new(m, x).is_err(), "{m:?}, {x}");
    }
    assert!(mie_amplitudes(m, 10.0, &[1.5]).is_err());
    assert!(mie_amplitudes(m, 10.0, &[f64::NAN]).is_err());
    assert!(mie_amplitudes(m, 10.0, &[]).unwrap().is_empty());
    // m = 1: nothing scatters, so there is no phase function.
    assert!(matches!(MiePhaseTable::new(Complex::new(1.0, 0.0), 10.0), Err(OpticsError::OutOfRange { .. })));
    assert!(MiePhaseTable::from_distribution(m, &[]).is_err());
    assert!(MiePhaseTable::from_distribution(m, &[(10.0, -1.0)]).is_err());
    assert!(MiePhaseTable::from_distribution(m, &[(10.0, 0.0)]).is_err());
    assert!(MiePhaseTable::log_normal(m, 10.0, -0.1).is_err());
    assert!(MiePhaseTable::log_normal(m, 10.0, f64::NAN).is_err());
    assert!(MieSpectralTable::from_particle("unobtainium", 10.0, 0.0).is_err());
    assert!(MieSpectralTable::from_particle("water", 0.0, 0.0).is_err());
    assert!(MieSpectralTable::from_particle("water", f64::NAN, 0.0).is_err());
    assert!(MieSpectralTable::from_particle("water", 10.0, 3.0).is_err());
    assert!(MieSpectralTable::from_particle("water", 1e6, 0.0).is_err()); // x ≈ 1.7e7 at 360 nm
    assert!(MieSpectralTable::from_index(|_| Complex::new(f64::NAN, 0.0), 1.0, 0.0).is_err());
    // An index that goes bad somewhere inside 360–830 nm is found before any table is computed.
    assert!(
        MieSpectralTable::from_index(|l| Complex::new(if l == 612.0 { -1.0 } else { 1.33 }, 0.0), 1.0, 0.0).is_err()
    );
    // So is one that stops scattering (m = 1) somewhere.
    assert!(MieSpectralTable::from_index(|l| Complex::new(if l == 700.0 { 1.0 } else { 1.33 }, 0.0), 1.0, 0.0).is_err());
    // Wavelengths outside 360–830 nm, and NaN, get an end's table, never a panic.
    let t = MieSpectralTable::from_particle("water", 2.0, 0.0).unwrap();
    assert_eq!(t.eval_phase(200.0, 0.3), t.eval_phase(360.0, 0.3));
    assert_eq!(t.eval_phase(2000.0, 0.3), t.eval_phase(830.0, 0.3));
    assert!(t.eval_phase(f64::NAN, 0.3).is_finite() && t.cross_sections(f64::NAN).0 > 0.0);
    // Evaluation and sampling never panic, whatever they are given.
    let t = MiePhaseTable::new(m, 5.0).unwrap();
    for v in [f64::NAN, f64::INFINITY, -f64::INFINITY, 2.0, -2.0, 0.5] {
        assert!(t.eval(v).is_finite());
        assert!((-1.0..=1.0).contains(&t.sample(v)));
    }
}

/// Simpson's rule for ∫_{θa}^{θb} (|S1|² + |S2|²)·sin θ dθ with `panels` panels.
fn intensity_integral(m: Complex, x: f64, a: f64, b: f64, panels: usize) -> f64 {
    let h = (b - a) / panels as f64;
    let thetas: Vec<f64> = (0..=panels).map(|i| a + h * i as f64).collect();
    let mus: Vec<f64> = thetas.iter().map(|t| t.cos()).collect();
    let s = mie_amplitudes(m, x, &mus).unwrap();
    let f: Vec<f64> = s.iter().zip(&thetas).map(|((s1, s2), t)| (s1.norm_sqr() + s2.norm_sqr()) * t.sin()).collect();
    let mut acc = f[0] + f[panels];
    for (i, v) in f.iter().enumerate().take(panels).skip(1) {
        acc += v * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    acc * h / 3.0
}

#[test]
fn bin_probabilities_are_the_exact_integrals_of_the_series() {
    // Each bin's probability against an independent quadrature of |S1|² + |S2|² (Simpson, 2000 panels per bin:
    // ≥ 500 per period of the fastest ripple, so converged to ~1e-10), normalised by ∫(|S1|²+|S2|²)dμ = x²·Q_sca (from B&H eqs. 4.61, 4.74).
    for (m, x) in
        [(Complex::new(1.33, 1e-5), 1000.0), (Complex::new(1.5, 0.1), 30.0), (Complex::new(1.342, 1e-3), 4000.0)]
    {
        let t = MiePhaseTable::new(m, x).unwrap();
        let q = mie_efficiencies(m, x).unwrap();
        let (e, c) = (t.theta_edges(), t.cdf());
        let bins = t.bins();
        for b in [0, 1, 50, 150, 400, bins / 3, bins / 2, 3 * bins / 4, bins - 2, bins - 1] {
            let want = intensity_integral(m, x, e[b], e[b + 1], 2000) / (x * x * q.q_sca);
            let got = c[b + 1] - c[b];
            // Measured ≤ 1e-9 relative; the last bins (P ~ 1e-9 for x = 4000) are limited by the cumulative
            // table's own rounding near 1, ~2e-16 absolute.
            assert!((got - want).abs() < 1e-9 * want + 5e-16, "m = {m:?}, x = {x}, bin {b}: {got:e} vs {want:e}");
        }
        assert!((t.normalisation_check() - 1.0).abs() < 1e-8, "∫p dω − 1 = {}", t.normalisation_check() - 1.0);
    }
}

#[test]
fn table_is_normalised_and_its_mean_cosine_matches_g() {
    for (m, x, spread) in [
        (Complex::new(1.5, 0.0), 10.0, 0.0),
        (Complex::new(1.33, 1e-5), 1000.0, 0.0),
        (Complex::new(1.342, 1e-3), 4000.0, 0.0),
        (Complex::new(1.334, 2e-9), 300.0, 0.1),
        (Complex::new(1.55, 0.0), 5.2, 0.3),
    ] {
        let t = MiePhaseTable::log_normal(m, x, spread).unwrap();
        // ∫ p dω over the bins, from eval: Σ density·2π·Δμ.
        let cos = t.cos_edges();
        let total: f64 = (0..t.bins())
            .map(|b| t.eval(0.5 * (cos[b] + cos[b + 1])) * 2.0 * std::f64::consts::PI * (cos[b] - cos[b + 1]))
            .sum();
        assert!((total - 1.0).abs() < 1e-12, "x = {x}: ∫p dω = {total}");
        assert!((t.normalisation_check() - 1.0).abs() < 1e-8, "x = {x}: {}", t.normalisation_check());
        // Constant density within each bin moves the mean cosine by at most Σ P_b·Δμ_b/2; measured ≤ 2e-7 here.
        let g = t.efficiencies().g;
        assert!((t.mean_cosine() - g).abs() < 1e-6, "x = {x}, spread {spread}: {} vs g = {g}", t.mean_cosine());
    }
}

/// SplitMix64 (Steele, Lea & Flood 2014): a small deterministic generator for the sampling tests.
struct SplitMix(u64);

impl SplitMix {
    fn next_f64(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// Pearson's χ² of `n` draws of cos θ against the density `eval` (per steradian, piecewise constant between the
/// sorted cosines `breaks`), over test bins in θ spaced quadratically (fine near the forward peak) so that their
/// edges cut the table's bins. Expected counts integrate `eval` exactly piece by piece; bins expecting fewer than 20
/// draws are merged into their neighbour. Returns (χ², degrees of freedom).
fn chi_square(eval: impl Fn(f64) -> f64, breaks: &[f64], mut draw: impl FnMut() -> f64, n: usize) -> (f64, usize) {
    const TEST_BINS: usize = 400;
    let theta: Vec<f64> =
        (0..=TEST_BINS).map(|j| std::f64::consts::PI * (j as f64 / TEST_BINS as f64).powi(2)).collect();
    let mu_edges: Vec<f64> = theta.iter().map(|t| t.cos()).collect(); // descending
    let mut expected = vec![0.0; TEST_BINS];
    for (j, e) in expected.iter_mut().enumerate() {
        let (hi, lo) = (mu_edges[j], mu_edges[j + 1]);
        let mut cuts: Vec<f64> = breaks.iter().copied().filter(|&b| b > lo && b < hi).collect();
        cuts.push(lo);
        cuts.push(hi);
        cuts.sort_by(f64::total_cmp);
        let prob: f64 =
            cuts.windows(2).map(|w| eval(0.5 * (w[0] + w[1])) * 2.0 * std::f64::consts::PI * (w[1] - w[0])).sum();
        *e = prob * n as f64;
    }
    let mut observed = vec![0.0; TEST_BINS];
    for _ in 0..n {
        let mu = draw();
        let j = mu_edges.partition_point(|&e| e > mu).saturating_sub(1).min(TEST_BINS - 1);
        observed[j] += 1.0;
    }
    let (mut chi2, mut dof) = (0.0, 0usize);
    let (mut o_acc, mut e_acc) = (0.0, 0.0);
    for j in 0..TEST_BINS {
        o_acc += observed[j];
        e_acc += expected[j];
        if e_acc >= 20.0 || j == TEST_BINS - 1 {
            if e_acc > 0.0 {
                chi2 += (o_acc - e_acc) * (o_acc - e_acc) / e_acc;
                dof += 1;
            } else {
                assert_eq!(o_acc, 0.0, "draws where the density is zero");
            }
            (o_acc, e_acc) = (0.0, 0.0);
        }
    }
    (chi2, dof.saturating_sub(1))
}

/// χ² threshold: the mean plus 6 standard deviations of the χ² distribution (fails by chance with p ≈ 1e-8).
fn threshold(dof: usize) -> f64 {
    dof as f64 + 6.0 * (2.0 * dof as f64).sqrt()
}

const DRAWS: usize = 2_000_000;

#[test]
fn sampling_draws_from_eval() {
    for (m, x, spread) in [(Complex::new(1.33, 1e-5), 500.0, 0.0), (Complex::new(1.5, 0.01), 3.0, 0.2)] {
        let t = MiePhaseTable::log_normal(m, x, spread).unwrap();
        let mut rng = SplitMix(7);
        let (chi2, dof) = chi_square(|mu| t.eval(mu), t.cos_edges(), || t.sample(rng.next_f64()), DRAWS);
        eprintln!(
            "x = {x}, spread {spread}: χ² = {chi2:.1}, {dof} degrees of freedom, threshold {:.1}",
            threshold(dof)
        );
        assert!(chi2 < threshold(dof), "x = {x}: χ² = {chi2:.1} with {dof} degrees of freedom");
        assert!(dof > 100, "{dof}");
    }
}

#[test]
fn chi_square_rejects_wrong_samplers() {
    // The same test must fail for samplers that are wrong in ways a renderer could be: (1) Henyey–Greenstein with the
    // right g; (2) the right bin but always its midpoint (wrong within bins only); (3) another table.
    let t = MiePhaseTable::new(Complex::new(1.33, 1e-5), 500.0).unwrap();
    let g = t.mean_cosine();
    let mut rng = SplitMix(11);
    let hg = |u: f64| {
        let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u);
        ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
    };
    let (chi2, dof) = chi_square(|mu| t.eval(mu), t.cos_edges(), || hg(rng.next_f64()), DRAWS);
    eprintln!("Henyey–Greenstein: χ² = {chi2:.1}, {dof} degrees of freedom, threshold {:.1}", threshold(dof));
    assert!(chi2 > 100.0 * threshold(dof), "Henyey–Greenstein: χ² = {chi2:.1}");
    let (cos, cdf) = (t.cos_edges(), t.cdf());
    let midpoint = |u: f64| {
        let b = cdf.partition_point(|&c| c <= u).saturating_sub(1).min(t.bins() - 1);
        0.5 * (cos[b] + cos[b + 1])
    };
    let (chi2, dof) = chi_square(|mu| t.eval(mu), t.cos_edges(), || midpoint(rng.next_f64()), DRAWS);
    eprintln!("bin midpoints: χ² = {chi2:.1}, {dof} degrees of freedom, threshold {:.1}", threshold(dof));
    assert!(chi2 > threshold(dof), "bin midpoints: χ² = {chi2:.1}, threshold {:.1}", threshold(dof));
    let other = MiePhaseTable::new(Complex::new(1.33, 1e-5), 505.0).unwrap();
    let (chi2, dof) = chi_square(|mu| t.eval(mu), t.cos_edges(), || other.sample(rng.next_f64()), DRAWS);
    eprintln!("x = 505 for x = 500: χ² = {chi2:.1}, {dof} degrees of freedom, threshold {:.1}", threshold(dof));
    assert!(chi2 > threshold(dof), "x = 505 for x = 500: χ² = {chi2:.1}");
}

/// The unpolarised phase function's probability in each 0.1° bin of θ from the series itself: Simpson's rule over
/// each bin in μ on `panels` panels of [`mie_amplitudes`] (the direct sums, checked above against two independent
/// codes), normalised by the series' own x²·Q_sca.
fn series_bins_per_tenth_degree(m: Complex, x: f64, panels: usize) -> Vec<f64> {
    let bins = 1800;
    let mut mu = Vec::with_capacity(bins * panels + 1);
    for b in 0..bins {
        let (t0, t1) = ((b as f64 * 0.1).to_radians(), ((b + 1) as f64 * 0.1).to_radians());
        for j in 0..panels {
            mu.push((t0 + (t1 - t0) * j as f64 / panels as f64).cos());
        }
    }
    mu.push(-1.0);
    let i: Vec<f64> = mie_amplitudes(m, x, &mu).unwrap().iter().map(|(s1, s2)| s1.norm_sqr() + s2.norm_sqr()).collect();
    let norm = x * x * mie_efficiencies(m, x).unwrap().q_sca;
    (0..bins)
        .map(|b| {
            // Simpson in θ over the bin (the integrand i(μ)·sin θ), panels even.
            let (t0, t1) = ((b as f64 * 0.1).to_radians(), ((b + 1) as f64 * 0.1).to_radians());
            let h = (t1 - t0) / panels as f64;
            let f = |j: usize| i[b * panels + j] * (t0 + h * j as f64).sin();
            let mut acc = f(0) + f(panels);
            for j in 1..panels {
                acc += f(j) * if j % 2 == 1 { 4.0 } else { 2.0 };
            }
            acc * h / 3.0 / norm
        })
        .collect()
}

#[test]
fn spectral_table_is_the_series_at_wavelengths_off_any_grid() {
    // Wavelengths no grid of round numbers holds; single drops, whose ripple and resonances change within a
    // fraction of a nanometre (linear interpolation between tables 10 nm apart is off by about 100 % rms for 40 µm drops).
    let water = particle_index("water").unwrap();
    for (radius, lambda) in [(1.0, 455.37), (10.0, 612.913), (40.0, 455.37), (100.0, 731.1131)] {
        let t = MieSpectralTable::from_particle("water", radius, 0.0).unwrap();
        let m = water(lambda);
        let x = 2.0 * std::f64::consts::PI * radius * 1e3 / lambda;
        let want = series_bins_per_tenth_degree(m, x, 64);
        let (got, (c_sca, c_abs)) = t.with_wavelengths([lambda], |[w]| {
            let cdf = |deg: f64| w.table.cdf_at_cos(deg.to_radians().cos());
            let got: Vec<f64> = (0..1800).map(|b| cdf((b + 1) as f64 * 0.1) - cdf(b as f64 * 0.1)).collect();
            (got, (w.c_sca, w.c_abs))
        });
        let rms = (got.iter().zip(&want).map(|(g, w)| ((g - w) / w).powi(2)).sum::<f64>() / 1800.0).sqrt();
        eprintln!("{radius} µm at {lambda} nm: rms relative error of 0.1° bins {rms:.2e}");
        assert!(rms < 0.02, "{radius} µm at {lambda} nm: rms {rms}");
        // Cross sections: π r² Q at this very wavelength.
        let q = mie_efficiencies(m, x).unwrap();
        let geo = std::f64::consts::PI * (radius * 1e-6f64).powi(2);
        assert!(rel(c_sca, geo * q.q_sca) < 1e-4 && rel(c_abs, geo * q.q_abs) < 1e-4, "{radius} µm at {lambda} nm");
        // Evaluation and sampling are the same density: the χ² test of the renderer's lookups.
        let edges = t.with_wavelengths([lambda], |[w]| w.table.cos_edges().to_vec());
        let mut rng = SplitMix(radius as u64);
        let (chi2, dof) =
            chi_square(|mu| t.eval_phase(lambda, mu), &edges, || t.sample_phase(lambda, rng.next_f64()), DRAWS / 4);
        assert!(chi2 < threshold(dof), "{radius} µm at {lambda} nm: χ² = {chi2:.1} with {dof} degrees of freedom");
    }
}

#[test]
fn spectral_table_caches_prepares_and_releases() {
    let t = MieSpectralTable::from_particle("water", 5.0, 0.0).unwrap();
    let pass = [421.3, 511.7, 574.9, 643.2];
    t.prepare(&pass);
    assert_eq!(t.cached_wavelengths(), 4);
    // Preparing the next pass keeps what it shares with this one and lets the rest go (renders come in many calls).
    t.prepare(&[pass[2], pass[3], 700.5]);
    assert_eq!(t.cached_wavelengths(), 3);
    t.prepare(&pass);
    // What is prepared, computed on demand, and computed after a release are the same numbers.
    let first: Vec<(f64, f64)> = pass.iter().map(|&l| t.cross_sections(l)).collect();
    let on_demand = MieSpectralTable::from_particle("water", 5.0, 0.0).unwrap();
    t.release();
    assert_eq!(t.cached_wavelengths(), 0);
    for (i, &l) in pass.iter().enumerate() {
        assert_eq!(on_demand.cross_sections(l), first[i]);
        assert_eq!(t.cross_sections(l), first[i]);
        assert_eq!(t.compute(l).c_sca, first[i].0);
    }
    // Two tables of different drops never see each other's entries, even at the same wavelength.
    let other = MieSpectralTable::from_particle("water", 6.0, 0.0).unwrap();
    assert_ne!(other.cross_sections(pass[0]), first[0]);
    // More wavelengths than the per-thread cache holds come back right.
    let many: Vec<f64> = (0..100).map(|i| 400.0 + 3.1 * i as f64).collect();
    let once: Vec<f64> = many.iter().map(|&l| t.cross_sections(l).0).collect();
    let again: Vec<f64> = many.iter().rev().map(|&l| t.cross_sections(l).0).collect();
    assert!(once.iter().zip(again.iter().rev()).all(|(a, b)| a == b));
    t.with_wavelengths([many[0], many[50], many[0], many[99]], |w| {
        assert_eq!(
            (w[0].lambda_nm, w[1].lambda_nm, w[2].lambda_nm, w[3].lambda_nm),
            (many[0], many[50], many[0], many[99])
        );
    });
}

#[test]
fn forward_cutoff_conditions_the_phase_function_beyond_the_cutoff() {
    // 20 µm drops between two grid tables, with everything within 2° of forward counted as unscattered.
    let exact = MieSpectralTable::from_particle("water", 20.0, 0.0).unwrap();
    let cut = MieSpectralTable::from_particle("water", 20.0, 0.0).unwrap().with_forward_cutoff(2.0).unwrap();
    let lambda = 530.0;
    let cos_c = 2f64.to_radians().cos();
    let mut breaks: Vec<f64> = exact.with_wavelengths([lambda], |[w]| w.table.cos_edges().to_vec());
    breaks.push(cos_c);
    breaks.sort_by(f64::total_cmp);
    // The removed fraction is the exact phase function's probability within 2°, integrated piece by piece.
    let inside: Vec<f64> = breaks.iter().copied().filter(|&b| b > cos_c).chain([cos_c, 1.0]).collect();
    let mut inside = inside;
    inside.sort_by(f64::total_cmp);
    inside.dedup();
    let removed: f64 = inside
        .windows(2)
        .map(|w| exact.eval_phase(lambda, 0.5 * (w[0] + w[1])) * 2.0 * std::f64::consts::PI * (w[1] - w[0]))
        .sum();
    let f = cut.forward_cut_fraction(lambda);
    assert!(rel(f, removed) < 1e-9, "removed {f}, expected {removed}");
    assert!(f > 0.3 && f < 0.9, "20 µm drops scatter much of their light within 2°: {f}");
    // Zero inside the cut-off, the exact function renormalised outside.
    assert_eq!(cut.eval_phase(lambda, 0.9999), 0.0);
    assert!(rel(cut.eval_phase(lambda, 0.3), exact.eval_phase(lambda, 0.3) / (1.0 - f)) < 1e-12);
    // Sampling draws from that density (χ² as above) and never inside the cut-off.
    let mut rng = SplitMix(5);
    let (chi2, dof) = chi_square(
        |mu| cut.eval_phase(lambda, mu),
        &breaks,
        || {
            let mu = cut.sample_phase(lambda, rng.next_f64());
            assert!(mu <= cos_c, "drawn inside the cut-off: {mu}");
            mu
        },
        DRAWS,
    );
    eprintln!("2° cut-off at {lambda} nm: χ² = {chi2:.1}, {dof} degrees of freedom, threshold {:.1}", threshold(dof));
    assert!(chi2 < threshold(dof), "χ² = {chi2:.1} with {dof} degrees of freedom");
    // A cut-off of 0 is the exact table, bit for bit; out-of-range cut-offs are errors.
    let fresh = || MieSpectralTable::from_particle("water", 20.0, 0.0).unwrap();
    let zero = fresh().with_forward_cutoff(0.0).unwrap();
    assert_eq!(zero.eval_phase(lambda, 0.99999), exact.eval_phase(lambda, 0.99999));
    assert_eq!(zero.sample_phase(lambda, 0.77), exact.sample_phase(lambda, 0.77));
    assert!(fresh().with_forward_cutoff(-1.0).is_err());
    assert!(fresh().with_forward_cutoff(f64::NAN).is_err());
    assert!(fresh().with_forward_cutoff(11.0).is_err());
}

#[test]
fn spectral_cross_sections() {
    let l = [400.0, 500.0, 600.0, 700.0];
    let t = MieSpectralTable::from_particle("water", 250.0, 0.0).unwrap();
    let geo = std::f64::consts::PI * (250e-6f64).powi(2);
    for &lambda in &l {
        let (sca, abs) = t.cross_sections(lambda);
        let m = particle_index("water").unwrap()(lambda);
        let q = mie_efficiencies(m, 2.0 * std::f64::consts::PI * 250e3 / lambda).unwrap();
        assert!(rel(sca, geo * q.q_sca) < 1e-12 && rel(abs, geo * q.q_abs) < 1e-9, "{lambda} nm");
        // Large, nearly transparent drops: Q_sca ≈ 2 (extinction paradox), Q_abs tiny but positive.
        assert!((q.q_sca - 2.0).abs() < 0.03, "{q:?}");
        assert!(abs > 0.0 && abs < 1e-3 * sca, "{lambda} nm: {abs}");
    }
    // Weak absorption: C_abs ∝ α·volume, with water's α = 0.60544 m⁻¹ at 700 nm and 0.023203 m⁻¹ at 500 nm
    // (data/water_absorption.csv, Segelstein 1981); n differs a little, so only to a few per cent.
    let ratio = t.cross_sections(700.0).1 / t.cross_sections(500.0).1;
    assert!(rel(ratio, 0.60544 / 0.023203) < 0.05, "C_abs(700)/C_abs(500) = {ratio}");
}

#[test]
fn water_k_comes_from_the_absorption_data_with_consistent_units() {
    let idx = particle_index("water").unwrap();
    // data/water_absorption.csv at 550 nm, Segelstein (1981): k = 2.4619e-9, α = 0.056248 m⁻¹; α = 4πk/λ.
    let m = idx(550.0);
    let alpha = catalogue::water_absorption_segelstein().eval(550.0);
    assert!(rel(4.0 * std::f64::consts::PI * m.im / 550e-9, alpha) < 1e-3, "k = {}, α = {alpha}", m.im);
    assert_eq!(m.im, 2.4619e-9);
    assert!(rel(m.re, catalogue::lookup("water").unwrap().ior.n(550.0)) < 1e-15);
    // Held at the table's end values outside 300–900 nm.
    assert_eq!(idx(250.0).im, idx(300.0).im);
    assert_eq!(idx(1000.0).im, idx(900.0).im);
    // Glass: k = 0; metals: the catalogue's k.
    assert_eq!(particle_index("N-BK7").unwrap()(550.0).im, 0.0);
    let au = catalogue::lookup("Au").unwrap().ior;
    assert_eq!(particle_index("gold").unwrap()(550.0), Complex::new(au.n(550.0), au.k(550.0)));
}

#[test]
fn log_normal_nodes_reproduce_the_distribution() {
    for (spread, count) in [(0.1, 5), (0.1, 50), (0.3, 200), (0.5, 31)] {
        let nodes = log_normal_nodes(250.0, spread, count).unwrap();
        assert_eq!(nodes.len(), count);
        let w: f64 = nodes.iter().map(|n| n.1).sum();
        let mean: f64 = nodes.iter().map(|n| n.0 * n.1).sum();
        let r2: f64 = nodes.iter().map(|n| n.0 * n.0 * n.1).sum();
        assert!((w - 1.0).abs() < 1e-14);
        // Log-normal: ⟨r⟩ = 250, ⟨r²⟩ = 250²·(1 + spread²); the unit-variance nodes get both to O(σ⁴).
        let sigma4 = (1.0f64 + spread * spread).ln().powi(2);
        assert!(rel(mean, 250.0) < 0.1 * sigma4, "spread {spread}, {count}: ⟨r⟩ = {mean}");
        assert!(rel(r2, 250.0f64.powi(2) * (1.0 + spread * spread)) < sigma4, "spread {spread}, {count}: ⟨r²⟩ = {r2}");
    }
    assert_eq!(log_normal_nodes(3.0, 0.0, 9).unwrap(), vec![(3.0, 1.0)]);
    assert_eq!(log_normal_node_count(4000.0, 0.0), 1);
    // Rain: the cost cap (5–7 radii); fog: spacing ≈ 0.25 in x (10·x·σ nodes).
    assert_eq!(log_normal_node_count(4000.0, 0.1), 5);
    assert_eq!(log_normal_node_count(100.0, 0.1), (10.0 * 100.0 * 1.01f64.ln().sqrt()).ceil() as usize);
}

/// Mean density per steradian over scattering angles [a°, b°], from the table's cumulative distribution.
fn band_density(t: &MiePhaseTable, a: f64, b: f64) -> f64 {
    let (e, c) = (t.theta_edges(), t.cdf());
    let cdf_at = |th: f64| {
        let i = e.partition_point(|&x| x <= th).clamp(1, e.len() - 1);
        let (m0, m1) = (e[i - 1].cos(), e[i].cos());
        c[i - 1] + (m0 - th.cos()) / (m0 - m1) * (c[i] - c[i - 1])
    };
    let (ra, rb) = (a.to_radians(), b.to_radians());
    (cdf_at(rb) - cdf_at(ra)) / (2.0 * std::f64::consts::PI * (ra.cos() - rb.cos()))
}

/// Scattering angles (degrees, window centres) of the local maxima of the density averaged over `w`° windows in
/// [a°, b°], with their densities.
fn maxima(t: &MiePhaseTable, a: f64, b: f64, w: f64) -> Vec<(f64, f64)> {
    let n = ((b - a) / w).round() as usize;
    let d: Vec<(f64, f64)> =
        (0..n).map(|i| (a + (i as f64 + 0.5) * w, band_density(t, a + i as f64 * w, a + (i + 1) as f64 * w))).collect();
    d.windows(3).filter(|v| v[1].1 > v[0].1 && v[1].1 >= v[2].1).map(|v| v[1]).collect()
}

#[test]
fn rain_shows_the_primary_and_secondary_bows_and_alexanders_dark_band() {
    // 262.6 µm drops at 550 nm: x ≈ 3000; a 2 % spread.
    let m = particle_index("water").unwrap()(550.0);
    let t = MiePhaseTable::log_normal(m, 3000.0, 0.02).unwrap();
    let primary = 180.0 - descartes_rainbow_angle(m.re, 1).unwrap(); // 138.17° scattering
    let secondary = 180.0 - descartes_rainbow_angle(m.re, 2).unwrap(); // 128.67°
    let peak =
        |a: f64, b: f64| maxima(&t, a, b, 0.05).into_iter().fold((0.0, 0.0), |m, p| if p.1 > m.1 { p } else { m });
    let (p1, d1) = peak(120.0, 145.0);
    // The Airy maximum lies slightly on the bright side of the geometric bow (van de Hulst 1957, §13.24).
    assert!(p1 > primary && p1 - primary < 0.6, "primary maximum at {p1}°, Descartes {primary}°");
    let (p2, d2) = peak(124.0, 131.0);
    assert!(p2 < secondary && secondary - p2 < 1.2, "secondary maximum at {p2}°, Descartes {secondary}°");
    // Alexander's dark band between them: darker than just outside either bow.
    let dark = band_density(&t, 130.0, 136.5);
    assert!(dark < 0.05 * d1 && dark < 0.5 * d2, "dark band {dark:e}, bows {d1:e}, {d2:e}");
    assert!(dark < 0.5 * band_density(&t, 138.5, 140.0) && dark < 0.5 * band_density(&t, 126.0, 128.0));
}

#[test]
fn small_drops_show_supernumeraries_and_fog_a_white_bow() {
    let idx = particle_index("water").unwrap();
    // 20 µm drops, 5 % spread: the primary maximum moves inside the geometric bow and supernumerary maxima follow it.
    let m = idx(550.0);
    let x = 2.0 * std::f64::consts::PI * 20e3 / 550.0;
    let t = MiePhaseTable::log_normal(m, x, 0.05).unwrap();
    let primary = 180.0 - descartes_rainbow_angle(m.re, 1).unwrap();
    let max = maxima(&t, 136.0, 160.0, 0.25);
    let top = max.iter().fold(0.0f64, |a, p| a.max(p.1));
    let strong: Vec<_> = max.iter().filter(|p| p.1 > 0.25 * top).collect();
    assert!(strong.len() >= 4, "{max:?}");
    assert!(strong[0].0 > primary + 1.0, "primary at {:?}, Descartes {primary}", strong[0]);
    // 10 µm drops, 20 % spread: blue and red bows nearly coincide (fogbow), where Descartes puts them 1.1° apart.
    let bow = |lambda: f64| {
        let m = idx(lambda);
        let t = MiePhaseTable::log_normal(m, 2.0 * std::f64::consts::PI * 10e3 / lambda, 0.2).unwrap();
        let p = maxima(&t, 130.0, 150.0, 0.25).into_iter().fold((0.0, 0.0), |a, p| if p.1 > a.1 { p } else { a });
        (p.0, 180.0 - descartes_rainbow_angle(m.re, 1).unwrap())
    };
    let ((blue, blue_d), (red, red_d)) = (bow(450.0), bow(650.0));
    assert!(blue_d - red_d > 1.0);
    assert!((blue - red).abs() < 0.6, "fogbow maxima at {blue}° (450 nm) and {red}° (650 nm)");
}

/// Deviation of the k-th order ray at incidence i, radians (geometric optics).
fn deviation(n: f64, k: f64, i: f64) -> f64 {
    k * std::f64::consts::PI + 2.0 * i - 2.0 * (k + 1.0) * (i.sin() / n).asin()
}

#[test]
fn descartes_angles_match_a_numerical_minimum_deviation() {
    // Minimise D(i) numerically (golden section), independently of the closed-form cos² i = (n² − 1)/(k(k+2)).
    for n in [1.31, 1.333, 1.3435, 1.5, 1.7] {
        for k in 1..=4u32 {
            let kf = f64::from(k);
            let (mut a, mut b) = (0.0, std::f64::consts::FRAC_PI_2);
            let r = (5f64.sqrt() - 1.0) / 2.0;
            for _ in 0..200 {
                let (c, d) = (b - r * (b - a), a + r * (b - a));
                if deviation(n, kf, c) < deviation(n, kf, d) {
                    b = d;
                } else {
                    a = c;
                }
            }
            let dmin = deviation(n, kf, 0.5 * (a + b));
            let mut s = dmin.rem_euclid(2.0 * std::f64::consts::PI);
            if s > std::f64::consts::PI {
                s = 2.0 * std::f64::consts::PI - s;
            }
            let want = 180.0 - s.to_degrees();
            let got = descartes_rainbow_angle(n, k).unwrap();
            assert!((got - want).abs() < 1e-6, "n = {n}, order {k}: {got} vs {want}");
        }
    }
    // The familiar values for water (n = 1.333): primary 42.08°, secondary 50.89°; orders 3 and 4 at 41.7° and 43.7°
    // from the sun.
    assert!((descartes_rainbow_angle(1.333, 1).unwrap() - 42.078).abs() < 1e-3);
    assert!((descartes_rainbow_angle(1.333, 2).unwrap() - 50.891).abs() < 1e-3);
    assert!((180.0 - descartes_rainbow_angle(1.333, 3).unwrap() - 41.737).abs() < 1e-3);
    assert!((180.0 - descartes_rainbow_angle(1.333, 4).unwrap() - 43.703).abs() < 1e-3);
    for (n, k) in [(1.0, 1), (0.9, 1), (2.0, 1), (3.5, 2), (f64::NAN, 1), (1.33, 0)] {
        assert_eq!(descartes_rainbow_angle(n, k), None, "n = {n}, k = {k}");
    }
}

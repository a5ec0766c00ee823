//! Lorenz–Mie scattering by homogeneous spheres, wavelength by wavelength: efficiencies, amplitude functions,
//! exactly sampleable tabulated phase functions (one radius or a log-normal size distribution), the optics of a cloud
//! of droplets at any wavelength for the renderer (computed per wavelength and cached), and the closed-form
//! (Descartes) rainbow angles.
//!
//! # Conventions
//!
//! Bohren & Huffman, *Absorption and Scattering of Light by Small Particles* (1983), "B&H" below: time dependence
//! e^{−iωt}, relative index `m = n + i·k` with `k ≥ 0` absorbing, size parameter `x = 2π·r·n_medium/λ` with the
//! medium air (`n_medium = 1`), scattering angle θ measured from the forward direction, `μ = cos θ`.
//!
//! # The series
//!
//! Wiscombe (1980, "Improved Mie scattering algorithms", Appl. Opt. 19, 1505): `N_stop = x + 4.05·x^{1/3} + 2`
//! terms; the logarithmic derivative `D_n(mx)` by downward recurrence, here started from the exact D_{N_stop} of
//! Lentz's continued fraction (Wiscombe's start, 0 at `max(N_stop, |mx|) + 16`, is not far enough above |mx| for
//! weakly absorbing spheres with |mx| ≳ 1000: Q_ext off by 3e-4 at m = 1.5, x = 1000); the Riccati–Bessel
//! functions ψ_n(x), ξ_n(x) by upward recurrence; a_n, b_n from B&H eq. 4.88; the angular functions π_n, τ_n by
//! the recurrences of B&H eq. 4.47. Checked against two independent implementations (`tests/mie.rs`) to ≤ 1e-9
//! relative in Q_ext, Q_sca and g and ≤ 1e-5 in S1, S2 (the limit of the printed references) for 0.1 ≤ x ≤ 5000,
//! 0 ≤ k ≤ 4, and against the Rayleigh limit; Q_ext → 2 is checked up to x = 5·10⁴. For x ≲ 0.01 the a_n lose
//! about x⁻² ulps to cancellation: Q_sca is good to ~1e-15/x² relative (5e-8 at x = 1e-4).
//!
//! # Phase tables
//!
//! The unpolarised intensity `i(μ) = |S1|² + |S2|²` is a polynomial of degree ≤ 2N in μ (π_n has degree n−1, τ_n
//! degree n), and S1 ± S2 are of degree ≤ N. [`MiePhaseTable`] evaluates S1 ± S2 at N+1 Chebyshev nodes (uniform
//! in θ), which determines them; FFTs carry them to 2N+1 nodes, where i is then known exactly, and give i's
//! Chebyshev coefficients, which integrate term by term. So the probability of every angular bin is the exact
//! integral of the truncated series, up to rounding: no quadrature error and no aliasing of the fast ripple
//! (period ~1/x rad), however narrow or wide the bins. Bins (angles in radians, x_max the largest size parameter
//! in the table):
//!
//! - forward: width 0.1/x_max up to θ = 10/x_max (the diffraction peak has width ~1/x), then widths growing by 5 %
//!   per bin;
//! - everywhere else: the uniform grid of 0.05° (π/3600);
//! - when 0.1/x_max ≥ 0.05° (x_max ≤ 115) the whole table is the uniform 0.05° grid.
//!
//! That is 3600–3760 bins. Within a bin the density is constant in solid angle (uniform in μ), so
//! [`MiePhaseTable::eval`] and [`MiePhaseTable::sample`] describe exactly the same piecewise-constant density.
//! Measured (`tests/mie.rs`): bin probabilities agree with an independent Simpson quadrature of
//! [`mie_amplitudes`] (2000 panels per bin) to ≤ 1e-9 relative, or ~2e-16 absolute for the last bins near 180°
//! (P ~ 1e-9 there, limited by the cumulative table's rounding near 1); ∫p dω = 1 to 1e-12 and the series'
//! normalisation ∫(|S1|²+|S2|²)dμ = x²·Q_sca to ≤ 4e-10; what the constant density loses is the structure inside
//! each bin, which moves the table's mean cosine from the series g by ≤ 1e-6 (6e-7 for one 250 µm drop at 360 nm,
//! ≤ 1e-7 otherwise).
//!
//! Cost: about N²/2 × 20 flops per radius (N ≈ x), so a rain drop (x ≈ 4000–4400 in the blue) costs far more than
//! a fog droplet; radii and wavelengths run in parallel (rayon). Timings: BENCHMARKS.md, "Build and setup times".

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

use rayon::prelude::*;

use crate::catalogue;
use crate::complex::Complex;
use crate::error::{check, finite, OpticsError};
use crate::fft;

/// The largest size parameter the functions here accept (a 3 mm drop at 100 nm). Beyond it N_stop and the cost of
/// the tables grow without bound; geometric optics is the better model there.
pub const MAX_SIZE_PARAMETER: f64 = 2.0e5;

/// Number of terms of the series for size parameter `x`: ⌈x + 4.05·x^{1/3} + 2⌉ (Wiscombe 1980, eq. 1 and table 1;
/// the criterion he gives for x > 8, used here for all x since extra terms are harmless).
pub fn n_stop(x: f64) -> usize {
    (x + 4.05 * x.cbrt() + 2.0).ceil() as usize
}

/// Extinction, scattering, absorption and backscattering efficiencies (cross sections divided by the geometric
/// cross section πr²) and the asymmetry parameter g = ⟨cos θ⟩.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MieEfficiencies {
    /// Q_ext = (2/x²)·Σ(2n+1)·Re(a_n + b_n) (B&H eq. 4.62).
    pub q_ext: f64,
    /// Q_sca = (2/x²)·Σ(2n+1)·(|a_n|² + |b_n|²) (B&H eq. 4.61).
    pub q_sca: f64,
    /// Q_abs = Q_ext − Q_sca, clamped at 0 (rounding can make it −1e-16 for k = 0).
    pub q_abs: f64,
    /// Q_back = (1/x²)·|Σ(2n+1)(−1)ⁿ(a_n − b_n)|² (B&H eq. 4.82), radar backscattering efficiency.
    pub q_back: f64,
    /// Asymmetry parameter g (B&H eq. 4.74, ⟨cos θ⟩·Q_sca written in a_n, b_n).
    pub g: f64,
}

fn check_m_x(m: Complex, x: f64) -> Result<(), OpticsError> {
    check("n (real part of the relative index m)", m.re, m.re > 0.0, "must be positive")?;
    check("k (imaginary part of the relative index m)", m.im, m.im >= 0.0, "must be ≥ 0 (m = n + ik, k > 0 absorbs)")?;
    check(
        "size parameter x",
        x,
        x > 0.0 && x <= MAX_SIZE_PARAMETER,
        &format!("must be positive and at most {MAX_SIZE_PARAMETER:e}"),
    )?;
    Ok(())
}

/// The Mie coefficients a_n, b_n (n = 1..=N_stop) of a homogeneous sphere, from which everything else follows.
#[derive(Clone, Debug, PartialEq)]
pub struct MieCoefficients {
    m: Complex,
    x: f64,
    a: Vec<Complex>,
    b: Vec<Complex>,
}

impl MieCoefficients {
    /// Computes a_n and b_n for relative index `m` (n > 0, k ≥ 0) and size parameter `x` (0 < x ≤
    /// [`MAX_SIZE_PARAMETER`]). Errors, never panics, for any other input.
    pub fn new(m: Complex, x: f64) -> Result<Self, OpticsError> {
        check_m_x(m, x)?;
        let nstop = n_stop(x);
        let mx = m * x;
        // D_n(mx) by downward recurrence D_{n−1} = n/(mx) − 1/(D_n + n/(mx)) (B&H eq. 4.89), started from the exact
        // D_{N_stop} of Lentz's continued fraction. (Wiscombe's start, D = 0 at max(N_stop, |mx|) + 16, lands in the
        // transition zone n ≈ |mx| where start errors are not damped: for m = 1.5, x = 1000 it gives Q_ext off by
        // 3e-4.)
        let inv_mx = mx.inv();
        let mut d = vec![Complex::default(); nstop + 1];
        let mut dn = log_derivative_lentz(nstop, mx);
        for n in (1..=nstop).rev() {
            d[n] = dn;
            let r = inv_mx * n as f64;
            dn = r - (dn + r).inv();
        }
        // ψ_n(x) and χ_n(x) upward, ψ_{n} = (2n−1)/x·ψ_{n−1} − ψ_{n−2}, from ψ_{−1} = cos x, ψ_0 = sin x,
        // χ_{−1} = −sin x, χ_0 = cos x; ξ_n = ψ_n − iχ_n (B&H eq. 4.89 and the text after it).
        let (s, c) = x.sin_cos();
        let (mut psi_prev, mut psi) = (c, s);
        let (mut chi_prev, mut chi) = (-s, c);
        let mut a = Vec::with_capacity(nstop);
        let mut b = Vec::with_capacity(nstop);
        for (n, &dn) in d.iter().enumerate().skip(1) {
            let nf = n as f64;
            let f = (2.0 * nf - 1.0) / x;
            let psi_n = f * psi - psi_prev;
            let chi_n = f * chi - chi_prev;
            let xi_n = Complex::new(psi_n, -chi_n);
            let xi_nm1 = Complex::new(psi, -chi);
            let n_over_x = Complex::from_real(nf / x);
            // B&H eq. 4.88.
            let da = dn / m + n_over_x;
            let db = m * dn + n_over_x;
            a.push((da * psi_n - Complex::from_real(psi)) / (da * xi_n - xi_nm1));
            b.push((db * psi_n - Complex::from_real(psi)) / (db * xi_n - xi_nm1));
            (psi_prev, psi) = (psi, psi_n);
            (chi_prev, chi) = (chi, chi_n);
        }
        Ok(Self { m, x, a, b })
    }

    /// The relative index m.
    pub fn m(&self) -> Complex {
        self.m
    }

    /// The size parameter x.
    pub fn x(&self) -> f64 {
        self.x
    }

    /// a_1 … a_N (index 0 holds a_1).
    pub fn a(&self) -> &[Complex] {
        &self.a
    }

    /// b_1 … b_N (index 0 holds b_1).
    pub fn b(&self) -> &[Complex] {
        &self.b
    }

    /// Number of terms N = [`n_stop`]`(x)`.
    pub fn terms(&self) -> usize {
        self.a.len()
    }

    /// The efficiencies and g of the sphere.
    pub fn efficiencies(&self) -> MieEfficiencies {
        let (mut ext, mut sca, mut g1, mut g2) = (0.0, 0.0, 0.0, 0.0);
        let mut back = Complex::default();
        let n_terms = self.a.len();
        for i in 0..n_terms {
            let n = (i + 1) as f64;
            let (an, bn) = (self.a[i], self.b[i]);
            let w = 2.0 * n + 1.0;
            ext += w * (an.re + bn.re);
            sca += w * (an.norm_sqr() + bn.norm_sqr());
            // B&H eq. 4.74: g·Q_sca = (4/x²)·[Σ n(n+2)/(n+1)·Re(a_n a*_{n+1} + b_n b*_{n+1}) + Σ (2n+1)/(n(n+1))·Re(a_n b*_n)].
            if i + 1 < n_terms {
                g1 += n * (n + 2.0) / (n + 1.0) * ((an * self.a[i + 1].conj()).re + (bn * self.b[i + 1].conj()).re);
            }
            g2 += w / (n * (n + 1.0)) * (an * bn.conj()).re;
            let sign = if i % 2 == 0 { -1.0 } else { 1.0 };
            back += (an - bn) * (w * sign);
        }
        let x2 = self.x * self.x;
        let q_ext = 2.0 * ext / x2;
        let q_sca = 2.0 * sca / x2;
        let g = if q_sca > 0.0 { 4.0 * (g1 + g2) / (x2 * q_sca) } else { 0.0 };
        MieEfficiencies { q_ext, q_sca, q_abs: (q_ext - q_sca).max(0.0), q_back: back.norm_sqr() / x2, g }
    }

    /// The amplitude functions (S1, S2) at μ = cos θ (B&H eq. 4.74: S1 = Σ (2n+1)/(n(n+1))·(a_n π_n + b_n τ_n),
    /// S2 = Σ (2n+1)/(n(n+1))·(a_n τ_n + b_n π_n)), normalised as in B&H so that S1(0) = S2(0) and
    /// Q_ext = (4/x²)·Re S(0). `cos_theta` is clamped to [−1, 1]; NaN gives NaN.
    pub fn amplitudes(&self, cos_theta: f64) -> (Complex, Complex) {
        let mu = cos_theta.clamp(-1.0, 1.0);
        let (mut s1, mut s2) = (Complex::default(), Complex::default());
        // π_0 = 0, π_1 = 1; π_{n+1} = (2n+1)/n·μ·π_n − (n+1)/n·π_{n−1}; τ_n = n·μ·π_n − (n+1)·π_{n−1} (B&H eq. 4.47).
        let (mut pi_prev, mut pi) = (0.0, 1.0);
        for (i, (&an, &bn)) in self.a.iter().zip(&self.b).enumerate() {
            let n = (i + 1) as f64;
            let t = mu * pi;
            let tau = n * t - (n + 1.0) * pi_prev;
            let c = (2.0 * n + 1.0) / (n * (n + 1.0));
            s1 += (an * pi + bn * tau) * c;
            s2 += (an * tau + bn * pi) * c;
            (pi_prev, pi) = (pi, ((2.0 * n + 1.0) * t - (n + 1.0) * pi_prev) / n);
        }
        (s1, s2)
    }

    /// S1 + S2 and S1 − S2 at the `g` Chebyshev nodes μ_k = cos θ_k, θ_k = (k+½)π/g (k = 0..g, θ ascending).
    ///
    /// With A_n = c_n(a_n + b_n), B_n = c_n(a_n − b_n), c_n = (2n+1)/(n(n+1)) (B&H eq. 4.74),
    /// S1 + S2 = Σ A_n(π_n + τ_n) and S1 − S2 = Σ B_n(π_n − τ_n). Eliminating τ_n = nμπ_n − (n+1)π_{n−1} (B&H
    /// eq. 4.47) leaves sums over π_n alone: S1 + S2 = Σ P_n π_n + μ·Σ Q_n π_n with P_n = A_n − (n+2)A_{n+1},
    /// Q_n = n·A_n, and S1 − S2 = Σ R_n π_n + μ·Σ T_n π_n with R_n = B_n + (n+2)B_{n+1}, T_n = −n·B_n. The nodes
    /// come in pairs ±μ and π_n(−μ) = (−1)^{n−1}·π_n(μ) (B&H p. 95), so the sums over odd and over even n, kept
    /// apart, give both: Σ X π(±μ) = O_X ± E_X. One run of π_{n+1} = ((2n+1)μπ_n − (n+1)π_{n−1})/n serves two
    /// nodes; eight node pairs at a time, for the vectoriser.
    fn sum_difference_at_chebyshev_nodes(&self, g: usize) -> (Vec<Complex>, Vec<Complex>) {
        const LANES: usize = 8;
        let n_terms = self.a.len();
        let coef = |i: usize| -> (Complex, Complex) {
            if i >= n_terms {
                return (Complex::default(), Complex::default());
            }
            let n = (i + 1) as f64;
            let c = (2.0 * n + 1.0) / (n * (n + 1.0));
            ((self.a[i] + self.b[i]) * c, (self.a[i] - self.b[i]) * c)
        };
        // Per term: [P, Q, R, T] as 8 reals, then α_n = (2n+1)/n, β_n = (n+1)/n.
        let terms: Vec<([f64; 8], f64, f64)> = (0..n_terms)
            .map(|i| {
                let n = (i + 1) as f64;
                let ((a, b), (a1, b1)) = (coef(i), coef(i + 1));
                let p = a - a1 * (n + 2.0);
                let q = a * n;
                let r = b + b1 * (n + 2.0);
                let t = -(b * n);
                ([p.re, p.im, q.re, q.im, r.re, r.im, t.re, t.im], (2.0 * n + 1.0) / n, (n + 1.0) / n)
            })
            .collect();
        let half = g.div_ceil(2); // nodes with μ ≥ 0 (the middle one, μ = 0, when g is odd)
        let mut sum = vec![Complex::default(); g];
        let mut diff = vec![Complex::default(); g];
        for start in (0..half).step_by(LANES) {
            let mut mu = [0.0; LANES];
            for (l, m) in mu.iter_mut().enumerate() {
                *m = fft::chebyshev_node((start + l).min(half - 1), g).cos();
            }
            let mut p_prev = [0.0; LANES]; // π_0
            let mut p_cur = [1.0; LANES]; // π_1
                                          // [odd n, even n][P.re, P.im, Q.re, Q.im, R.re, R.im, T.re, T.im][lane]
            let mut acc = [[[0.0; LANES]; 8]; 2];
            for (i, (c, alpha, beta)) in terms.iter().enumerate() {
                let a = &mut acc[i & 1];
                for l in 0..LANES {
                    let p = p_cur[l];
                    for (j, aj) in a.iter_mut().enumerate() {
                        aj[l] += c[j] * p;
                    }
                    let next = alpha * (mu[l] * p) - beta * p_prev[l];
                    p_prev[l] = p;
                    p_cur[l] = next;
                }
            }
            for (l, k) in (start..half.min(start + LANES)).enumerate() {
                let (o, e) = (&acc[0], &acc[1]);
                let pair = |j: usize| (Complex::new(o[j][l], o[j + 1][l]), Complex::new(e[j][l], e[j + 1][l]));
                let ((op, ep), (oq, eq), (or, er), (ot, et)) = (pair(0), pair(2), pair(4), pair(6));
                let m = mu[l];
                sum[k] = op + ep + (oq + eq) * m;
                diff[k] = or + er + (ot + et) * m;
                sum[g - 1 - k] = op - ep - (oq - eq) * m;
                diff[g - 1 - k] = or - er - (ot - et) * m;
            }
        }
        (sum, diff)
    }
}

/// The logarithmic derivative D_n(z) = ψ_n'(z)/ψ_n(z) by Lentz's continued fraction (Lentz 1976, Appl. Opt. 15,
/// 668) evaluated forwards with the modified Lentz algorithm (Thompson & Barnett 1986, J. Comput. Phys. 64, 490).
///
/// From j_{n−1} + j_{n+1} = (2n+1)/z·j_n, the ratio r_n = ψ_{n−1}/ψ_n = j_{n−1}/j_n satisfies
/// r_n = (2n+1)/z − 1/r_{n+1}, i.e. r_n = b_0 − 1/(b_1 − 1/(b_2 − …)) with b_j = (2(n+j)+1)/z, and
/// D_n = r_n − n/z (from ψ_n' = ψ_{n−1} − (n/z)·ψ_n).
fn log_derivative_lentz(n: usize, z: Complex) -> Complex {
    const TINY: f64 = 1e-300;
    let nonzero = |c: Complex| if c.norm_sqr() == 0.0 { Complex::from_real(TINY) } else { c };
    let inv_z = z.inv();
    let b = |j: usize| inv_z * (2 * (n + j) + 1) as f64;
    let mut f = nonzero(b(0));
    let (mut c, mut d) = (f, Complex::default());
    // The terms stop changing f a few z^{1/3} past n + j ≈ |z|; the cap is far beyond that.
    let cap = 2 * (z.abs() as usize) + 10_000;
    for j in 1..cap {
        let bj = b(j);
        d = nonzero(bj - d).inv();
        c = nonzero(bj - c.inv());
        let delta = c * d;
        f = f * delta;
        if (delta - Complex::from_real(1.0)).abs() < 1e-15 && (n + j) as f64 > z.abs() {
            break;
        }
    }
    f - inv_z * n as f64
}

/// Efficiencies and asymmetry parameter of a sphere of relative index `m` and size parameter `x`. Errors for
/// non-finite input, n ≤ 0, k < 0, x ≤ 0 or x > [`MAX_SIZE_PARAMETER`].
///
/// ```
/// use optics::{mie::mie_efficiencies, Complex};
/// // Bohren & Huffman 1983, appendix A: m = 1.55, r = 0.525 µm, λ = 0.6328 µm.
/// let x = 2.0 * std::f64::consts::PI * 0.525 / 0.6328;
/// let q = mie_efficiencies(Complex::new(1.55, 0.0), x).unwrap();
/// assert!((q.q_sca - 3.10543).abs() < 1e-5 && (q.q_back - 2.92534).abs() < 1e-5);
/// ```
pub fn mie_efficiencies(m: Complex, x: f64) -> Result<MieEfficiencies, OpticsError> {
    Ok(MieCoefficients::new(m, x)?.efficiencies())
}

/// The amplitude functions (S1, S2) at each `cos_theta` (B&H normalisation, see [`MieCoefficients::amplitudes`]).
/// Errors as [`mie_efficiencies`], and for a cosine that is not finite or outside [−1, 1].
pub fn mie_amplitudes(m: Complex, x: f64, cos_theta: &[f64]) -> Result<Vec<(Complex, Complex)>, OpticsError> {
    for &mu in cos_theta {
        check("cos θ", mu, (-1.0..=1.0).contains(&mu), "must lie in [−1, 1]")?;
    }
    let c = MieCoefficients::new(m, x)?;
    Ok(cos_theta.iter().map(|&mu| c.amplitudes(mu)).collect())
}

/// The bins of a phase table: edges in θ (radians, ascending from 0 to π). The first `n_direct` edges (the forward
/// ones) are off the uniform grid; the rest are the uniform grid points m·π/M for m = m0..=M.
struct AngularGrid {
    theta: Vec<f64>,
    n_direct: usize,
    m0: usize,
}

/// Divisions of [0, π] of the uniform part of the grid: 3600, i.e. 0.05°.
const UNIFORM_DIVISIONS: usize = 3600;
/// Forward bins are `FORWARD_STEP / x_max` radians wide…
const FORWARD_STEP: f64 = 0.1;
/// … up to `FORWARD_SPAN / x_max` radians, …
const FORWARD_SPAN: f64 = 10.0;
/// … then grow by this factor per bin until they reach the uniform width.
const FORWARD_GROWTH: f64 = 1.05;

impl AngularGrid {
    fn new(x_max: f64) -> Self {
        let h_u = std::f64::consts::PI / UNIFORM_DIVISIONS as f64;
        let h_f = FORWARD_STEP / x_max;
        if h_f >= h_u {
            let theta = (0..=UNIFORM_DIVISIONS).map(|m| m as f64 * h_u).collect();
            return Self { theta, n_direct: 0, m0: 0 };
        }
        let n_fine = (FORWARD_SPAN / FORWARD_STEP).round() as usize;
        let mut theta: Vec<f64> = (0..=n_fine).map(|j| j as f64 * h_f).collect();
        let mut t = n_fine as f64 * h_f;
        let mut w = h_f;
        loop {
            w *= FORWARD_GROWTH;
            if w >= h_u {
                break;
            }
            t += w;
            theta.push(t);
        }
        // Join the uniform grid at the first point at least 0.5·h_u beyond the last forward edge.
        let m0 = ((t + 0.5 * h_u) / h_u).ceil() as usize;
        let n_direct = theta.len();
        theta.extend((m0..=UNIFORM_DIVISIONS).map(|m| m as f64 * h_u));
        Self { theta, n_direct, m0 }
    }
}

/// The coefficients D_l (l = 0..=G, D_0 = 0) of `P(θ) = ∫_{cos θ}^{1} i(μ) dμ = Σ_{l≥1} D_l·(1 − cos lθ)`, exact for
/// the truncated series (see the module docs).
///
/// S1 ± S2 are polynomials of degree ≤ N in μ: their values at N' ≥ N+1 Chebyshev nodes give their Chebyshev
/// coefficients, which give their values at G ≥ 2N+1 nodes, where i = (|S1 + S2|² + |S1 − S2|²)/2 is known exactly
/// as a polynomial of degree ≤ 2N; its coefficients, i(μ) = c_0/2 + Σ c_j T_j(μ), integrate term by term with
/// ∫T_j = T_{j+1}/(2(j+1)) − T_{j−1}/(2(j−1)), giving D_l = (c_{l−1} − c_{l+1})/(2l).
fn cumulative_coefficients(coef: &MieCoefficients) -> Vec<f64> {
    let n = coef.terms();
    let n_amp = fft::next_smooth(n + 1);
    let g = fft::next_smooth(2 * n + 1);
    let (sum, diff) = coef.sum_difference_at_chebyshev_nodes(n_amp);
    let sum = fft::chebyshev_values(&fft::chebyshev_coefficients(&sum)[..n + 1], g);
    let diff = fft::chebyshev_values(&fft::chebyshev_coefficients(&diff)[..n + 1], g);
    let i: Vec<Complex> =
        sum.iter().zip(&diff).map(|(s, d)| Complex::from_real(0.5 * (s.norm_sqr() + d.norm_sqr()))).collect();
    let c: Vec<f64> = fft::chebyshev_coefficients(&i).iter().map(|z| z.re).collect();
    let cj = |j: usize| if j < g { c[j] } else { 0.0 };
    (0..=g).map(|l| if l == 0 { 0.0 } else { (cj(l - 1) - cj(l + 1)) / (2.0 * l as f64) }).collect()
}

/// P(θ) = Σ_l D_l·(1 − cos lθ) at every edge of `grid`: forward edges with 1 − cos lθ = 2 sin²(lθ/2) term by term
/// (no cancellation near θ = 0), the uniform edges with one folded cosine transform.
fn cumulative_at_edges(d: &[f64], grid: &AngularGrid) -> Vec<f64> {
    let mut p = forward_cumulative(d, &grid.theta[..grid.n_direct]);
    let cos_sums = fft::cosine_sum_on_grid(d, UNIFORM_DIVISIONS);
    let total: f64 = d.iter().sum();
    p.extend(cos_sums[grid.m0..].iter().map(|cm| total - cm));
    p
}

/// Σ_l D_l·2·sin²(lθ/2) at each θ, eight angles at a time; sin(lθ/2) by rotation (error ~l·ε: 1e-12 at l = 10⁴).
fn forward_cumulative(d: &[f64], theta: &[f64]) -> Vec<f64> {
    const LANES: usize = 8;
    let mut out = Vec::with_capacity(theta.len());
    for chunk in theta.chunks(LANES) {
        let (mut rc, mut rs) = ([1.0; LANES], [0.0; LANES]);
        for (l, &t) in chunk.iter().enumerate() {
            (rs[l], rc[l]) = (0.5 * t).sin_cos();
        }
        let (mut wc, mut ws) = ([1.0; LANES], [0.0; LANES]);
        let mut acc = [0.0; LANES];
        for &dl in &d[1..] {
            for l in 0..LANES {
                let c = wc[l] * rc[l] - ws[l] * rs[l];
                let s = ws[l] * rc[l] + wc[l] * rs[l];
                wc[l] = c;
                ws[l] = s;
                acc[l] += dl * s * s;
            }
        }
        out.extend(acc[..chunk.len()].iter().map(|a| 2.0 * a));
    }
    out
}

/// A tabulated phase function p(θ) per steradian (∫p dω = 1) for one sphere or a size distribution, sampled exactly.
///
/// Bins and accuracy are described in the module documentation. The density is constant in μ = cos θ within each
/// bin: [`eval`](Self::eval) returns exactly the density [`sample`](Self::sample) draws from. Bins run from θ = 0
/// (forward) to θ = π.
#[derive(Clone, Debug, PartialEq)]
pub struct MiePhaseTable {
    theta_edges: Vec<f64>,
    cos_edges: Vec<f64>,
    cdf: Vec<f64>,
    density: Vec<f64>,
    mean_cosine: f64,
    efficiencies: MieEfficiencies,
    mean_x2: f64,
    raw_total: f64,
}

impl MiePhaseTable {
    /// The table of one sphere (monodisperse): relative index `m`, size parameter `x`. Errors as
    /// [`mie_efficiencies`], and when the sphere does not scatter (m = 1).
    pub fn new(m: Complex, x: f64) -> Result<Self, OpticsError> {
        Self::from_distribution(m, &[(x, 1.0)])
    }

    /// The table of a log-normal distribution of sizes with number-mean size parameter `x_mean` and relative standard
    /// deviation `spread` (0 = monodisperse), on [`log_normal_node_count`] nodes of [`log_normal_nodes`].
    pub fn log_normal(m: Complex, x_mean: f64, spread: f64) -> Result<Self, OpticsError> {
        let nodes = log_normal_nodes(x_mean, spread, log_normal_node_count(x_mean, spread))?;
        Self::from_distribution(m, &nodes)
    }

    /// The table of a discrete size distribution: `nodes` are (size parameter, number weight) pairs, weights ≥ 0 and
    /// not all 0 (normalised here). Following the definition of the ensemble phase function,
    /// p = Σ w_i·C_sca,i·p_i / Σ w_i·C_sca,i (B&H §3.5 and eq. 4.74 summed over particles); cross sections are the
    /// w-weighted means. Radii are computed in parallel.
    pub fn from_distribution(m: Complex, nodes: &[(f64, f64)]) -> Result<Self, OpticsError> {
        Self::from_nodes(m, nodes, true)
    }

    /// [`from_distribution`](Self::from_distribution), the radii computed in parallel or, from inside a
    /// computation that must not let this thread take other work meanwhile (a lazily filled cache), on this thread.
    fn from_nodes(m: Complex, nodes: &[(f64, f64)], parallel: bool) -> Result<Self, OpticsError> {
        if nodes.is_empty() {
            return Err(OpticsError::OutOfRange {
                name: "size distribution".into(),
                value: 0.0,
                expected: "at least one (x, weight) node".into(),
            });
        }
        let mut wsum = 0.0;
        for &(x, w) in nodes {
            check_m_x(m, x)?;
            check("size distribution weight", w, w >= 0.0, "must be ≥ 0")?;
            wsum += w;
        }
        check("sum of the size distribution weights", wsum, wsum > 0.0, "must be positive")?;
        if m == Complex::from_real(1.0) {
            return Err(OpticsError::OutOfRange {
                name: "relative index m".into(),
                value: 1.0,
                expected: "m = 1 does not scatter, so there is no phase function".into(),
            });
        }
        let x_max = nodes.iter().filter(|n| n.1 > 0.0).map(|n| n.0).fold(0.0, f64::max);
        let grid = AngularGrid::new(x_max);
        type PerRadius = (f64, MieEfficiencies, f64, Vec<f64>);
        let one = |&(x, w): &(f64, f64)| -> PerRadius {
            let coef = MieCoefficients::new(m, x).expect("checked above");
            (w / wsum, coef.efficiencies(), x * x, cumulative_coefficients(&coef))
        };
        let per_radius: Vec<PerRadius> = if parallel {
            nodes.par_iter().filter(|n| n.1 > 0.0).map(one).collect()
        } else {
            nodes.iter().filter(|n| n.1 > 0.0).map(one).collect()
        };
        // Ensemble: P = Σ w_i·P_i, linear in the coefficients D (P_i(π) = x_i²·Q_sca,i, so the number weights
        // already carry C_sca,i·k²/π).
        let len = per_radius.iter().map(|r| r.3.len()).max().unwrap_or(0);
        let mut d = vec![0.0; len];
        let (mut ext, mut sca, mut abs, mut back, mut gsca, mut mean_x2) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        for (w, q, x2, di) in &per_radius {
            for (acc, v) in d.iter_mut().zip(di) {
                *acc += w * v;
            }
            ext += w * x2 * q.q_ext;
            sca += w * x2 * q.q_sca;
            abs += w * x2 * q.q_abs;
            back += w * x2 * q.q_back;
            gsca += w * x2 * q.q_sca * q.g;
            mean_x2 += w * x2;
        }
        let p = cumulative_at_edges(&d, &grid);
        let raw_total = *p.last().expect("grid has edges");
        if !(raw_total > 0.0 && raw_total.is_finite() && sca > 0.0) {
            return Err(OpticsError::OutOfRange {
                name: "scattering efficiency".into(),
                value: sca,
                expected: "the particles must scatter (m ≠ 1) for a phase function to exist".into(),
            });
        }
        let efficiencies = MieEfficiencies {
            q_ext: ext / mean_x2,
            q_sca: sca / mean_x2,
            q_abs: abs / mean_x2,
            q_back: back / mean_x2,
            g: gsca / sca,
        };
        Ok(Self::from_cumulative(grid.theta, &p, efficiencies, mean_x2, raw_total / sca))
    }

    /// Builds the table from the cumulative (unnormalised) P at the θ edges.
    fn from_cumulative(
        theta_edges: Vec<f64>,
        p: &[f64],
        efficiencies: MieEfficiencies,
        mean_x2: f64,
        raw_total: f64,
    ) -> Self {
        let total = *p.last().expect("edges");
        let mut cdf = Vec::with_capacity(p.len());
        let mut run = 0.0f64;
        for &v in p {
            // Rounding can make P dip by ~1e-13 of its total; keep the CDF monotone.
            run = run.max(v / total);
            cdf.push(run.min(1.0));
        }
        cdf[0] = 0.0;
        *cdf.last_mut().expect("edges") = 1.0;
        let cos_edges: Vec<f64> = theta_edges.iter().map(|t| t.cos()).collect();
        let mut density = Vec::with_capacity(p.len() - 1);
        let mut mean_cosine = 0.0;
        for b in 0..p.len() - 1 {
            let prob = cdf[b + 1] - cdf[b];
            let dmu = cos_edges[b] - cos_edges[b + 1];
            density.push(if dmu > 0.0 { prob / (2.0 * std::f64::consts::PI * dmu) } else { 0.0 });
            mean_cosine += prob * 0.5 * (cos_edges[b] + cos_edges[b + 1]);
        }
        Self { theta_edges, cos_edges, cdf, density, mean_cosine, efficiencies, mean_x2, raw_total }
    }

    /// The table's density per steradian at `cos_theta` (clamped to [−1, 1]; 0 for NaN): the probability of the bin
    /// holding θ divided by its solid angle. Binary search, O(log bins).
    pub fn eval(&self, cos_theta: f64) -> f64 {
        if cos_theta.is_nan() {
            return 0.0;
        }
        self.density[self.bin_of_cos(cos_theta.clamp(-1.0, 1.0))]
    }

    /// The probability that θ ≤ acos(`cos_theta`): the cumulative distribution of [`eval`](Self::eval)'s density,
    /// linear in μ within a bin (so `sample(cdf_at_cos(μ)) = μ` up to rounding).
    pub fn cdf_at_cos(&self, cos_theta: f64) -> f64 {
        if cos_theta.is_nan() {
            return 0.0;
        }
        let mu = cos_theta.clamp(-1.0, 1.0);
        let b = self.bin_of_cos(mu);
        let dmu = self.cos_edges[b] - self.cos_edges[b + 1];
        let f = if dmu > 0.0 { ((self.cos_edges[b] - mu) / dmu).clamp(0.0, 1.0) } else { 0.0 };
        self.cdf[b] + f * (self.cdf[b + 1] - self.cdf[b])
    }

    fn bin_of_cos(&self, mu: f64) -> usize {
        // cos_edges descend from 1 to −1: count the edges above μ.
        let idx = self.cos_edges.partition_point(|&e| e > mu);
        idx.saturating_sub(1).min(self.density.len() - 1)
    }

    /// Draws cos θ from the table with one uniform number `u` in [0, 1) (clamped into it; NaN counts as 0): the bin
    /// by inverting the cumulative distribution, then μ uniformly within the bin. The azimuth is the caller's.
    ///
    /// For rain the forward bins are 1 − cos θ ≈ 3e-10 wide, below f32's resolution near 1 (6e-8, θ ≈ 0.02°): build
    /// the direction in f64, with sin θ = √((1 − μ)(1 + μ)), before rounding it.
    pub fn sample(&self, u: f64) -> f64 {
        let u = if u.is_nan() { 0.0 } else { u.clamp(0.0, 1.0) };
        let idx = self.cdf.partition_point(|&c| c <= u);
        let b = idx.saturating_sub(1).min(self.density.len() - 1);
        let prob = self.cdf[b + 1] - self.cdf[b];
        let f = if prob > 0.0 { ((u - self.cdf[b]) / prob).clamp(0.0, 1.0) } else { 0.5 };
        let mu = self.cos_edges[b] + f * (self.cos_edges[b + 1] - self.cos_edges[b]);
        mu.clamp(-1.0, 1.0)
    }

    /// The mean cosine of the table's own density, Σ_bins P_b·(μ_b + μ_{b+1})/2 (what sampling averages to).
    pub fn mean_cosine(&self) -> f64 {
        self.mean_cosine
    }

    /// The efficiencies of the ensemble: w-weighted cross sections divided by the w-weighted geometric cross
    /// section (Q = ⟨C⟩/(π⟨r²⟩)); `g` is the series' asymmetry parameter, C_sca-weighted.
    pub fn efficiencies(&self) -> MieEfficiencies {
        self.efficiencies
    }

    /// ⟨x²⟩ over the size distribution, so that ⟨C⟩ = π·⟨x²⟩·Q/k² with k = 2π/λ.
    pub fn mean_x2(&self) -> f64 {
        self.mean_x2
    }

    /// ∫_{−1}^{1} (|S1|² + |S2|²) dμ as integrated by the table, divided by x²·Q_sca from the series (w-weighted for a
    /// distribution): 1 up to rounding. A check of the normalisation p = (|S1|²+|S2|²)/(2k²C_sca).
    pub fn normalisation_check(&self) -> f64 {
        self.raw_total
    }

    /// Bin edges in θ, radians, ascending from 0 to π (bins + 1 values).
    pub fn theta_edges(&self) -> &[f64] {
        &self.theta_edges
    }

    /// Bin edges in cos θ, descending from 1 to −1 (the cosines of [`theta_edges`](Self::theta_edges)).
    pub fn cos_edges(&self) -> &[f64] {
        &self.cos_edges
    }

    /// Cumulative probability at each edge, from 0 at θ = 0 to 1 at θ = π.
    pub fn cdf(&self) -> &[f64] {
        &self.cdf
    }

    /// Number of bins.
    pub fn bins(&self) -> usize {
        self.density.len()
    }
}

/// Fewest radii [`log_normal_node_count`] uses for a spread > 0.
pub const MIN_RADIUS_NODES: usize = 5;
/// Cost budget of [`log_normal_node_count`]: the nodes' Σ N_stop² stays below this (a fixed amount of work per
/// wavelength; its time is in BENCHMARKS.md, "Build and setup times"), unless [`MIN_RADIUS_NODES`] needs more.
const RADIUS_NODE_BUDGET: f64 = 3.0e7;

/// The number of radii [`MiePhaseTable::log_normal`] and [`MieSpectralTable`] use for number-mean size parameter
/// `x_mean` and relative spread `spread` (1 for spread 0).
///
/// The phase function of one sphere ripples as x changes by ~1 (interference between ray paths); a size
/// distribution averages that out only if neighbouring nodes are ≲ 0.25 apart in x, i.e. K ≈ 10·x̄·σ nodes
/// (σ² = ln(1 + spread²)). That is affordable for fog (x ~ 100: hundreds of cheap nodes) but not for rain
/// (x ~ 4000: 10⁴ nodes, each costing about 1,600 times a fog node, as the cost grows with x²), so K is capped
/// where Σ N_stop² would pass a fixed budget, and is at least [`MIN_RADIUS_NODES`]. Measured against 3000–6000-node
/// references at 550 nm, as the largest difference of the density averaged over 0.25°, relative to the largest such
/// density in the same range: water drops of 250 µm, spread 0.1, get 5 nodes (5–7 over the visible) and differ by
/// 2.3 % in 120°–150° (the ripple left over; 7 % in single 0.05° bins) and by 6e-4 in C_sca; 10 µm drops get 114
/// nodes at spread 0.1 and 336 at 0.3 and differ by 2.0 % and 1.3 % in 120°–150°, 3.2 % and 1.9 % in 150°–180°.
pub fn log_normal_node_count(x_mean: f64, spread: f64) -> usize {
    if !(spread > 0.0 && x_mean > 0.0 && x_mean.is_finite()) {
        return 1;
    }
    let sigma2 = (1.0 + spread * spread).ln();
    let wanted = (10.0 * x_mean * sigma2.sqrt()).ceil();
    let n = n_stop(x_mean) as f64;
    let cap = RADIUS_NODE_BUDGET / (n * n * (2.0 * sigma2).exp());
    (wanted.min(cap).min(1e5) as usize).max(MIN_RADIUS_NODES)
}

/// Log-normal size distribution nodes: `count` equally weighted `(size, 1/count)` pairs for number-mean size `mean`
/// (a radius or a size parameter: the distribution scales) and relative standard deviation `spread` (σ_r/⟨r⟩;
/// spread 0 or count 1 give the single node `(mean, 1)`).
///
/// ln r is normal with σ² = ln(1 + spread²) and mean ln⟨r⟩ − σ²/2. The nodes sit at the standard normal quantiles
/// z_i = κ·Φ⁻¹((i + ½)/count), κ scaling them to unit variance so that ⟨r²⟩, hence the cross sections for large
/// drops, come out right to O(σ⁴); all weights equal, so the fast ripple of the single-radius phase functions is
/// averaged with the full `count`, where Gauss–Hermite or trapezoidal nodes put most weight on a few radii (at equal
/// count they are about twice as far from a converged reference in the bow region).
pub fn log_normal_nodes(mean: f64, spread: f64, count: usize) -> Result<Vec<(f64, f64)>, OpticsError> {
    check("mean size", mean, mean > 0.0, "must be positive")?;
    check("spread", spread, (0.0..=2.0).contains(&spread), "the relative standard deviation must lie in [0, 2]")?;
    if spread == 0.0 || count <= 1 {
        return Ok(vec![(mean, 1.0)]);
    }
    let sigma2 = (1.0 + spread * spread).ln();
    let sigma = sigma2.sqrt();
    let z: Vec<f64> = (0..count).map(|i| normal_quantile((i as f64 + 0.5) / count as f64)).collect();
    let kappa = (count as f64 / z.iter().map(|v| v * v).sum::<f64>()).sqrt();
    let w = 1.0 / count as f64;
    Ok(z.iter().map(|&zi| (mean * (sigma * kappa * zi - 0.5 * sigma2).exp(), w)).collect())
}

/// Standard normal distribution function Φ(z) = ½·(1 + erf(z/√2)), with erf from the all-positive series
/// erf(t) = (2/√π)·e^{−t²}·Σ_n 2ⁿ·t^{2n+1}/(1·3·…·(2n+1)) (Abramowitz & Stegun 1964, eq. 7.1.6): no cancellation,
/// so Φ is accurate to a few ulps of 1 for |z| ≤ 10.
fn normal_cdf(z: f64) -> f64 {
    let t = (z.abs() / std::f64::consts::SQRT_2).min(8.0);
    let (mut term, mut sum, mut k) = (t, t, 0.0);
    while term > 1e-17 * sum {
        k += 1.0;
        term *= 2.0 * t * t / (2.0 * k + 1.0);
        sum += term;
    }
    let erf = (2.0 / std::f64::consts::PI.sqrt() * (-t * t).exp() * sum).min(1.0);
    0.5 * (1.0 + erf.copysign(z))
}

/// Φ⁻¹(p) for 0 < p < 1 by bisection on [`normal_cdf`] (60 halvings of [−10, 10]: to 2e-17).
fn normal_quantile(p: f64) -> f64 {
    let (mut lo, mut hi) = (-10.0, 10.0);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if normal_cdf(mid) < p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The complex index n(λ) + i·k(λ) of a catalogue material as a particle (λ in nm).
///
/// n is the catalogue's (for water, Daimon & Masumura 2007 at 20 °C). k is the catalogue's for metals; for water it
/// is Segelstein's (1981, 25 °C) k column of `data/water_absorption.csv` ([`catalogue::water_k_segelstein`]), held
/// at its end values outside 300–900 nm; for glasses and crystals (Sellmeier only) k = 0.
pub fn particle_index(name: &str) -> Result<impl Fn(f64) -> Complex + Send + Sync + Clone, OpticsError> {
    let entry = catalogue::lookup(name)?;
    let water = entry.name == "water 20C";
    let k_table = catalogue::water_k_segelstein();
    let (lo, hi) = catalogue::WATER_ABSORPTION_RANGE_NM;
    Ok(move |lambda_nm: f64| {
        let n = entry.ior.n(lambda_nm);
        let k = if water { k_table.eval(lambda_nm.clamp(lo, hi)) } else { entry.ior.k(lambda_nm) };
        Complex::new(n, k)
    })
}

/// Per-wavelength Mie optics of a cloud of droplets for the renderer: cross sections per particle and an exactly
/// sampleable phase function at any wavelength asked for, each computed from the series at that very wavelength
/// (a [`MiePhaseTable`] of its own) and cached.
///
/// Why not a wavelength grid: a drop's phase function and cross sections change within a small fraction of a
/// nanometre. The interference ripple of a 40 µm drop goes through a period every 1–2 nm, and its resonances
/// (Chýlek 1976; Bohren & Huffman §11.4) are far narrower. Measured against the table at λ
/// (`cargo run --release -p optics --example mie_lambda_interp`, rms of the relative error of 0.1° bins over
/// 0–180°, 16 wavelengths), linear interpolation between tables 10 nm apart is off by 104 % (median; up to 211 %)
/// for 40 µm drops, and still by 6 % (up to 40 %) with tables every 0.05 in size parameter (4000 tables), with
/// C_sca off by up to 2e-3. A renderer
/// carries only a few wavelengths at a time: [`prepare`](Self::prepare) computes them ahead (in parallel) and lets
/// the others go, lookups find them in a per-thread front cache without locking, and [`release`](Self::release)
/// forgets them all. The renderer shares each pass's wavelengths between all pixels, so a pass
/// needs four tables.
///
/// Wavelengths outside 360–830 nm get the table at the nearer end. Cost of one wavelength: BENCHMARKS.md, "Build
/// and setup times" (`cargo run --release -p optics --example mie_build_time`).
pub struct MieSpectralTable {
    index: Box<dyn Fn(f64) -> Complex + Send + Sync>,
    radius_um: f64,
    spread: f64,
    /// Forward cut-off in degrees (0 = none) and cos θc (1 = none).
    cutoff_deg: f64,
    cos_cut: f64,
    /// Tells this table's entries apart in the per-thread front caches.
    id: u64,
    /// Wavelength (f64 bits) → its optics, computed once.
    cache: Mutex<HashMap<u64, Arc<OnceLock<Arc<MieWavelength>>>>>,
}

impl std::fmt::Debug for MieSpectralTable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MieSpectralTable")
            .field("radius_um", &self.radius_um)
            .field("spread", &self.spread)
            .field("cutoff_deg", &self.cutoff_deg)
            .finish_non_exhaustive()
    }
}

/// The Mie optics of a [`MieSpectralTable`] at one wavelength.
#[derive(Clone, Debug)]
pub struct MieWavelength {
    /// The wavelength, nm (clamped to 360–830).
    pub lambda_nm: f64,
    /// The particle's complex index there.
    pub index: Complex,
    /// The phase function, one radius or the size distribution.
    pub table: MiePhaseTable,
    /// Mean scattering cross section per particle, m².
    pub c_sca: f64,
    /// Mean absorption cross section per particle, m².
    pub c_abs: f64,
    /// Probability of scattering by less than the forward cut-off (0 without one).
    pub cut_fraction: f64,
}

/// The wavelengths a thread looked up last, per table: found again without the shared lock. Entries of released
/// wavelengths may linger here; they are still exact for their wavelength.
const FRONT_CACHE_SIZE: usize = 32;

thread_local! {
    static FRONT_CACHE: std::cell::RefCell<Vec<(u64, u64, Arc<MieWavelength>)>> =
        const { std::cell::RefCell::new(Vec::new()) };
    static FRONT_NEXT: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

static NEXT_TABLE_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);

/// The wavelength range the renderer carries, nm; tables outside it are those of the nearer end.
const MIE_LAMBDA_RANGE: (f64, f64) = (360.0, 830.0);

impl MieSpectralTable {
    /// The optics of droplets of a catalogue material (see [`particle_index`]) with number-mean radius `radius_um`
    /// (µm) and log-normal relative spread `spread` (0 = all alike).
    pub fn from_particle(name: &str, radius_um: f64, spread: f64) -> Result<Self, OpticsError> {
        Self::from_index(particle_index(name)?, radius_um, spread)
    }

    /// As [`from_particle`](Self::from_particle) with the complex index given as a function of λ (nm). Checks the
    /// index every nanometre of 360–830 nm and the largest size parameter, so that every wavelength's table can
    /// be computed; computes none.
    pub fn from_index(
        index: impl Fn(f64) -> Complex + Send + Sync + 'static,
        radius_um: f64,
        spread: f64,
    ) -> Result<Self, OpticsError> {
        check("radius (µm)", radius_um, radius_um > 0.0, "must be positive")?;
        log_normal_nodes(radius_um, spread, 1)?; // checks the spread
        let (lo, hi) = MIE_LAMBDA_RANGE;
        for l in (lo as u32)..=(hi as u32) {
            let m = index(f64::from(l));
            finite("n of the particle", m.re)?;
            finite("k of the particle", m.im)?;
            check_m_x(m, 1.0)?;
            if m == Complex::from_real(1.0) {
                return Err(OpticsError::OutOfRange {
                    name: "relative index m".into(),
                    value: 1.0,
                    expected: format!("m = 1 at {l} nm does not scatter, so there is no phase function"),
                });
            }
        }
        // The largest size parameter: the largest radius node at the shortest wavelength.
        let x_mean = 2.0 * std::f64::consts::PI * 1e3 / lo * radius_um;
        let nodes = log_normal_nodes(x_mean, spread, log_normal_node_count(x_mean, spread))?;
        let x_max = nodes.iter().map(|n| n.0).fold(0.0, f64::max);
        check_m_x(index(lo), x_max)?;
        Ok(Self {
            index: Box::new(index),
            radius_um,
            spread,
            cutoff_deg: 0.0,
            cos_cut: 1.0,
            id: NEXT_TABLE_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
            cache: Mutex::new(HashMap::new()),
        })
    }

    /// The same optics with scattering by less than `theta_deg` degrees counted as no scattering at all (the
    /// δ-approximation of radiative transfer, e.g. Joseph, Wiscombe & Weinman 1976, "The delta-Eddington
    /// approximation", J. Atmos. Sci. 33, 2452): [`eval_phase`](Self::eval_phase) and
    /// [`sample_phase`](Self::sample_phase) become the phase function conditioned on θ ≥ θc, and a medium's σs is
    /// to be multiplied by 1 − [`forward_cut_fraction`](Self::forward_cut_fraction). Energy is conserved; light is
    /// misplaced by less than θc. Large drops put about half of what they scatter into a diffraction peak ~λ/(2r)
    /// wide (0.06° for 250 µm rain), far below the sun's 0.53° disc: a cut-off of that order removes the peak, whose
    /// spikes are otherwise the fireflies of multiple scattering under a point-like sun. `theta_deg` must lie in
    /// [0, 10]; 0 is the exact phase function. Checked at 360, 595 and 830 nm: an error if the cut-off takes all
    /// of the scattering there (a wavelength where it does scatters nothing).
    pub fn with_forward_cutoff(mut self, theta_deg: f64) -> Result<Self, OpticsError> {
        check("forward cut-off (degrees)", theta_deg, (0.0..=10.0).contains(&theta_deg), "must lie in [0, 10]")?;
        self.cutoff_deg = theta_deg;
        self.cos_cut = theta_deg.to_radians().cos();
        self.cache.lock().unwrap_or_else(|e| e.into_inner()).clear();
        if theta_deg > 0.0 {
            let ends = [MIE_LAMBDA_RANGE.0, 0.5 * (MIE_LAMBDA_RANGE.0 + MIE_LAMBDA_RANGE.1), MIE_LAMBDA_RANGE.1];
            let fractions: Vec<f64> = ends.par_iter().map(|&l| self.compute(l).cut_fraction).collect();
            if fractions.iter().any(|&f| f >= 1.0 - 1e-9) {
                return Err(OpticsError::BadTable(format!(
                    "a forward cut-off of {theta_deg}° removes all of the scattering at some wavelength"
                )));
            }
        }
        Ok(self)
    }

    /// The optics at `lambda_nm`, computed here without caching (one thread; the series and the table of every
    /// radius of the size distribution).
    pub fn compute(&self, lambda_nm: f64) -> MieWavelength {
        let l = if lambda_nm.is_nan() {
            MIE_LAMBDA_RANGE.0
        } else {
            lambda_nm.clamp(MIE_LAMBDA_RANGE.0, MIE_LAMBDA_RANGE.1)
        };
        let m = (self.index)(l);
        let k_um = 2.0 * std::f64::consts::PI * 1e3 / l;
        let nodes = log_normal_nodes(
            k_um * self.radius_um,
            self.spread,
            log_normal_node_count(k_um * self.radius_um, self.spread),
        )
        .expect("spread checked when the table was made");
        let table = MiePhaseTable::from_nodes(m, &nodes, false)
            .expect("index and largest size parameter checked when the table was made");
        // ⟨C⟩ = π⟨x²⟩Q/k², k in m⁻¹.
        let k = 2.0 * std::f64::consts::PI / (l * 1e-9);
        let geo = std::f64::consts::PI * table.mean_x2() / (k * k);
        let cut_fraction = if self.cutoff_deg > 0.0 { table.cdf_at_cos(self.cos_cut) } else { 0.0 };
        MieWavelength {
            lambda_nm: l,
            index: m,
            c_sca: geo * table.efficiencies().q_sca,
            c_abs: geo * table.efficiencies().q_abs,
            cut_fraction,
            table,
        }
    }

    /// The cell of `lambda_nm` in the shared cache (created empty if new).
    fn cell(&self, lambda_nm: f64) -> Arc<OnceLock<Arc<MieWavelength>>> {
        let mut cache = self.cache.lock().unwrap_or_else(|e| e.into_inner());
        cache.entry(lambda_nm.to_bits()).or_default().clone()
    }

    /// The optics at `lambda_nm` from the shared cache, computed on this thread if no thread has yet.
    fn shared(&self, lambda_nm: f64) -> Arc<MieWavelength> {
        self.cell(lambda_nm).get_or_init(|| Arc::new(self.compute(lambda_nm))).clone()
    }

    /// Computes the optics at each of `lambdas_nm` not yet cached, in parallel, so that the lookups that follow
    /// find them; lets go of every other wavelength cached.
    pub fn prepare(&self, lambdas_nm: &[f64]) {
        {
            let keep: std::collections::HashSet<u64> = lambdas_nm.iter().map(|l| l.to_bits()).collect();
            self.cache.lock().unwrap_or_else(|e| e.into_inner()).retain(|bits, _| keep.contains(bits));
        }
        let mut todo: Vec<(f64, Arc<OnceLock<Arc<MieWavelength>>>)> = Vec::new();
        for &l in lambdas_nm {
            let cell = self.cell(l);
            if cell.get().is_none() && !todo.iter().any(|(t, _)| t.to_bits() == l.to_bits()) {
                todo.push((l, cell));
            }
        }
        todo.par_iter().for_each(|(l, cell)| {
            cell.get_or_init(|| Arc::new(self.compute(*l)));
        });
    }

    /// How many wavelengths the shared cache holds (computed or being computed).
    pub fn cached_wavelengths(&self) -> usize {
        self.cache.lock().unwrap_or_else(|e| e.into_inner()).len()
    }

    /// Forgets the cached wavelengths (those still in a thread's front cache stay there until pushed out).
    pub fn release(&self) {
        self.cache.lock().unwrap_or_else(|e| e.into_inner()).clear();
    }

    /// Calls `f` with the optics at each of `lambdas_nm`, from the calling thread's front cache, else the shared
    /// cache, else computed here.
    pub fn with_wavelengths<const N: usize, R>(
        &self,
        lambdas_nm: [f64; N],
        f: impl FnOnce([&MieWavelength; N]) -> R,
    ) -> R {
        FRONT_CACHE.with(|front| {
            // Find or fetch each wavelength's slot first (fetching may compute, outside any borrow of the cache),
            // then hand out references.
            let mut slots = [usize::MAX; N];
            for (i, &l) in lambdas_nm.iter().enumerate() {
                let bits = l.to_bits();
                let found = front.borrow().iter().position(|e| e.0 == self.id && e.1 == bits);
                slots[i] = match found {
                    Some(s) => s,
                    None => {
                        let entry = self.shared(l);
                        let mut front = front.borrow_mut();
                        if front.len() < FRONT_CACHE_SIZE {
                            front.push((self.id, bits, entry));
                            front.len() - 1
                        } else {
                            // Round-robin replacement, never a slot this call still needs.
                            let mut s = FRONT_NEXT.get();
                            while slots[..i].contains(&s) {
                                s = (s + 1) % FRONT_CACHE_SIZE;
                            }
                            FRONT_NEXT.set((s + 1) % FRONT_CACHE_SIZE);
                            front[s] = (self.id, bits, entry);
                            s
                        }
                    }
                };
            }
            let front = front.borrow();
            f(slots.map(|s| &*front[s].2))
        })
    }

    /// The fraction of the scattered light [`with_forward_cutoff`](Self::with_forward_cutoff) counts as
    /// unscattered at `lambda_nm` (0 without a cut-off).
    pub fn forward_cut_fraction(&self, lambda_nm: f64) -> f64 {
        self.with_wavelengths([lambda_nm], |[w]| w.cut_fraction)
    }

    /// Mean scattering and absorption cross sections per particle at `lambda_nm`, m². σ_s = N·C_sca and
    /// σ_a = N·C_abs for N particles per m³.
    pub fn cross_sections(&self, lambda_nm: f64) -> (f64, f64) {
        self.with_wavelengths([lambda_nm], |[w]| (w.c_sca, w.c_abs))
    }

    /// Phase function per steradian at `lambda_nm` and `cos_theta` (0 inside a forward cut-off, and renormalised
    /// outside it): exactly the density [`sample_phase`](Self::sample_phase) draws from.
    pub fn eval_phase(&self, lambda_nm: f64, cos_theta: f64) -> f64 {
        self.with_wavelengths([lambda_nm], |[w]| self.phase_of(w, cos_theta))
    }

    /// [`eval_phase`](Self::eval_phase) with the optics of one wavelength at hand.
    pub fn phase_of(&self, w: &MieWavelength, cos_theta: f64) -> f64 {
        if cos_theta > self.cos_cut || w.cut_fraction >= 1.0 {
            return 0.0;
        }
        w.table.eval(cos_theta) / (1.0 - w.cut_fraction)
    }

    /// Samples cos θ at `lambda_nm` from `u`.
    pub fn sample_phase(&self, lambda_nm: f64, u: f64) -> f64 {
        self.with_wavelengths([lambda_nm], |[w]| self.sample_of(w, u))
    }

    /// [`sample_phase`](Self::sample_phase) with the optics of one wavelength at hand: with a forward cut-off, the
    /// table sampled beyond θc.
    pub fn sample_of(&self, w: &MieWavelength, u: f64) -> f64 {
        if w.cut_fraction == 0.0 {
            return w.table.sample(u);
        }
        let u = if u.is_nan() { 0.0 } else { u.clamp(0.0, 1.0) };
        w.table.sample(w.cut_fraction + u * (1.0 - w.cut_fraction)).min(self.cos_cut)
    }

    /// Mean cosine of the phase function at `lambda_nm` without a forward cut-off.
    pub fn mean_cosine(&self, lambda_nm: f64) -> f64 {
        self.with_wavelengths([lambda_nm], |[w]| w.table.mean_cosine())
    }

    /// Number-mean radius, µm.
    pub fn radius_um(&self) -> f64 {
        self.radius_um
    }

    /// Relative standard deviation of the radius.
    pub fn spread(&self) -> f64 {
        self.spread
    }

    /// The forward cut-off, degrees (0 = none).
    pub fn forward_cutoff_deg(&self) -> f64 {
        self.cutoff_deg
    }

    /// The work of one wavelength's optics in arbitrary units, from the size parameters the series sees at 550 nm:
    /// per radius N_stop² (the amplitudes at the Chebyshev nodes) plus 700·N_stop (the transforms), plus 10⁶ (the
    /// angular table). Follows the measured time within a factor of about 2 from 5 µm fog to 250 µm rain
    /// (`cargo run --release -p optics --example mie_build_time`), and is the same on every machine, so choices
    /// made from it do not change images.
    pub fn work_per_wavelength(&self) -> f64 {
        let x = 2.0 * std::f64::consts::PI * 1e3 / 550.0 * self.radius_um;
        let count = log_normal_node_count(x, self.spread);
        let n = n_stop(x) as f64;
        count as f64 * (n * n + 700.0 * n) + 1e6
    }
}

/// Angle of the rainbow of `order` k ≥ 1 (k internal reflections) from the antisolar point, degrees, for a sphere of
/// relative index `n`, by geometric optics (Descartes 1637; Newton): the ray of minimum deviation has
/// cos² i = (n² − 1)/(k(k+2)), sin r = sin i / n, and deviation D = k·180° + 2i − 2(k+1)·r; the scattering angle
/// is D folded into [0°, 180°] and the result is 180° minus it. Primary 42.08° and secondary 50.89° at n = 1.333;
/// orders 3 and 4 lie 138.26° and 136.30° from the antisolar point, i.e. 41.7° and 43.7° from the sun. `None` when there
/// is no such bow (k = 0, n ≤ 1, n ≥ k + 1, or n not finite).
pub fn descartes_rainbow_angle(n: f64, order: u32) -> Option<f64> {
    if order == 0 || !n.is_finite() || n <= 1.0 {
        return None;
    }
    let k = f64::from(order);
    let cos2 = (n * n - 1.0) / (k * (k + 2.0));
    if cos2 >= 1.0 {
        return None;
    }
    let i = cos2.sqrt().acos();
    let r = (i.sin() / n).asin();
    let pi = std::f64::consts::PI;
    let d = k * pi + 2.0 * i - 2.0 * (k + 1.0) * r;
    let mut scattering = d.rem_euclid(2.0 * pi);
    if scattering > pi {
        scattering = 2.0 * pi - scattering;
    }
    Some((pi - scattering).to_degrees())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lentz_matches_a_long_downward_recurrence() {
        // The downward recurrence from D = 0 at n + 5000 converges to the same D_n (its start error dies out once
        // past |z| + a few |z|^{1/3}).
        for (n, z) in [
            (10, Complex::new(5.0, 0.0)),
            (1043, Complex::new(1500.0, 0.0)),
            (5072, Complex::new(6650.0, 0.05)),
            (40, Complex::new(6.0, 8.0)),
            (300, Complex::new(200.0, 20.0)),
        ] {
            let mut d = Complex::default();
            for k in (n + 1..=n + 5000).rev() {
                let r = z.inv() * k as f64;
                d = r - (d + r).inv();
            }
            let l = log_derivative_lentz(n, z);
            assert!((l - d).abs() < 1e-12 * d.abs().max(1.0), "n = {n}, z = {z:?}: {l:?} vs {d:?}");
        }
    }

    #[test]
    fn normal_distribution_function_and_quantiles() {
        assert_eq!(normal_cdf(0.0), 0.5);
        // Φ(−1) and Φ(1.959963984540054) = 0.975 to 16 digits (Abramowitz & Stegun table 26.1 and 26.5).
        assert!((normal_cdf(-1.0) - 0.158_655_253_931_457_05).abs() < 1e-15);
        assert!((normal_cdf(1.959_963_984_540_054) - 0.975).abs() < 1e-15);
        assert!((normal_quantile(0.975) - 1.959_963_984_540_054).abs() < 1e-12);
        assert!((normal_quantile(0.5)).abs() < 1e-15);
        assert!((normal_quantile(1e-4) + 3.719_016_485_455_709).abs() < 1e-10);
    }

    #[test]
    fn angular_grid_is_fine_forward_then_uniform() {
        let g = AngularGrid::new(4000.0);
        let t = &g.theta;
        assert_eq!(t[0], 0.0);
        assert_eq!(*t.last().unwrap(), std::f64::consts::PI);
        assert!(t.windows(2).all(|w| w[1] > w[0]));
        assert!((t[1] - 0.1 / 4000.0).abs() < 1e-18);
        let h_u = std::f64::consts::PI / 3600.0;
        assert!(t.windows(2).all(|w| w[1] - w[0] <= 1.5 * h_u + 1e-15));
        assert!(t[g.n_direct..].windows(2).all(|w| (w[1] - w[0] - h_u).abs() < 1e-12));
        assert!((3700..3800).contains(&(t.len() - 1)), "{} bins", t.len() - 1);
        let small = AngularGrid::new(10.0);
        assert_eq!((small.theta.len(), small.n_direct, small.m0), (3601, 0, 0));
    }

    #[test]
    fn amplitudes_at_chebyshev_nodes_match_the_direct_sums() {
        let c = MieCoefficients::new(Complex::new(1.33, 1e-3), 60.0).unwrap();
        let g = 131;
        let (sum, diff) = c.sum_difference_at_chebyshev_nodes(g);
        for k in [0, 1, 40, 65, 90, 130] {
            let (s1, s2) = c.amplitudes(fft::chebyshev_node(k, g).cos());
            let scale = s1.abs().max(s2.abs());
            assert!((sum[k] - (s1 + s2)).abs() < 1e-11 * scale, "node {k}");
            assert!((diff[k] - (s1 - s2)).abs() < 1e-11 * scale, "node {k}");
        }
    }
}

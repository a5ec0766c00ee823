//! A small mixed-radix fast Fourier transform and the two cosine transforms the Mie phase tables need.
//!
//! Cooley–Tukey decimation in time (Cooley & Tukey 1965, Math. Comp. 19, 297) over the prime factors of the length,
//! each stage a direct DFT of the factor's size: O(n·Σpᵢ), efficient for the 5-smooth lengths (2^a·3^b·5^c) the
//! callers choose with [`next_smooth`]; correct, only slower, for any other length.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

use crate::complex::Complex;

/// `e^{−2πi·k/den}` for k = 0..count, cached for short tables: a spectral table of small droplets transforms the
/// same few short lengths thousands of times, where computing the roots would take half the time. At most 512
/// tables of at most 4096 entries are kept (≤ 32 MiB); longer ones belong to large drops, whose series cost far
/// more than their roots.
fn roots(den: usize, count: usize) -> Arc<Vec<Complex>> {
    type Cache = Mutex<HashMap<(usize, usize), Arc<Vec<Complex>>>>;
    static CACHE: OnceLock<Cache> = OnceLock::new();
    // Two-level table: e^{−2πi(64b + r)/den} = e^{−2πi·64b/den}·e^{−2πi·r/den}, so count/64 + 64 sines and
    // cosines instead of count, at one extra rounding.
    let make = || {
        const STEP: usize = 64;
        let root = |k: usize| Complex::cis(-2.0 * std::f64::consts::PI * k as f64 / den as f64);
        let fine: Vec<Complex> = (0..STEP.min(count)).map(root).collect();
        let table: Vec<Complex> = (0..count.div_ceil(STEP))
            .flat_map(|b| {
                let coarse = root(b * STEP);
                fine.iter().map(move |&f| coarse * f)
            })
            .take(count)
            .collect();
        Arc::new(table)
    };
    if count > 4096 {
        return make();
    }
    let cache = CACHE.get_or_init(|| Mutex::new(HashMap::new()));
    if let Some(t) = cache.lock().unwrap_or_else(|e| e.into_inner()).get(&(den, count)) {
        return Arc::clone(t);
    }
    let t = make();
    let mut c = cache.lock().unwrap_or_else(|e| e.into_inner());
    if c.len() < 512 {
        c.insert((den, count), Arc::clone(&t));
    }
    t
}

/// The smallest 5-smooth number (only prime factors 2, 3 and 5) that is ≥ `n` (and ≥ 1).
pub(crate) fn next_smooth(n: usize) -> usize {
    let mut m = n.max(1);
    loop {
        let mut r = m;
        for p in [2, 3, 5] {
            while r.is_multiple_of(p) {
                r /= p;
            }
        }
        if r == 1 {
            return m;
        }
        m += 1;
    }
}

/// Prime factors of `n`, smallest first (empty for n = 1).
fn factors(mut n: usize) -> Vec<usize> {
    let mut f = Vec::new();
    let mut p = 2;
    while p * p <= n {
        while n.is_multiple_of(p) {
            f.push(p);
            n /= p;
        }
        p += 1;
    }
    if n > 1 {
        f.push(n);
    }
    f
}

/// Forward DFT `X_j = Σ_k x_k·e^{−2πi·jk/n}` of `x` (any length ≥ 1), returned as a new vector.
pub(crate) fn fft(x: &[Complex]) -> Vec<Complex> {
    let n = x.len();
    let mut out = vec![Complex::default(); n];
    if n == 0 {
        return out;
    }
    let twiddles = roots(n, n);
    let f = factors(n);
    stage(x, 1, &mut out, &twiddles, 1, &f);
    out
}

/// One decimation-in-time stage: the DFT of the `out.len()` elements `x[0], x[stride], x[2·stride], …` into `out`.
/// `twiddles[k] = e^{−2πik/N}` for the top-level length N, and `tw_stride = N/out.len()`.
fn stage(x: &[Complex], stride: usize, out: &mut [Complex], twiddles: &[Complex], tw_stride: usize, f: &[usize]) {
    let n = out.len();
    if n == 1 {
        out[0] = x[0];
        return;
    }
    let p = f[0];
    let q = n / p;
    let big_n = twiddles.len();
    if q == 1 {
        // The last factor: a direct DFT of p elements (W_p^{rs} with r·s reduced mod p incrementally).
        let step = big_n / p;
        for (s, o) in out.iter_mut().enumerate() {
            let mut acc = Complex::default();
            let mut e = 0;
            for r in 0..p {
                acc += x[r * stride] * twiddles[e * step];
                e += s;
                if e >= p {
                    e -= p;
                }
            }
            *o = acc;
        }
        return;
    }
    // p interleaved sub-sequences x[r·stride + i·p·stride], each transformed into out[r·q .. (r+1)·q].
    for r in 0..p {
        stage(&x[r * stride..], stride * p, &mut out[r * q..(r + 1) * q], twiddles, tw_stride * p, &f[1..]);
    }
    // X[k + q·s] = Σ_r W_n^{r·k}·Y_r[k]·W_p^{r·s} with W_n = e^{−2πi/n} = twiddles[tw_stride]; r·k·tw_stride < N.
    if p == 2 {
        let (lo, hi) = out.split_at_mut(q);
        for (k, (a, b)) in lo.iter_mut().zip(hi.iter_mut()).enumerate() {
            let t = *b * twiddles[k * tw_stride];
            (*a, *b) = (*a + t, *a - t);
        }
        return;
    }
    // W_p^j = twiddles[j·q·tw_stride]; small factors use stack buffers (this runs once per sub-transform).
    const SMALL: usize = 8;
    let (mut wp_small, mut y_small) = ([Complex::default(); SMALL], [Complex::default(); SMALL]);
    let (mut wp_big, mut y_big) = (Vec::new(), Vec::new());
    let (wp, y): (&mut [Complex], &mut [Complex]) = if p <= SMALL {
        (&mut wp_small[..p], &mut y_small[..p])
    } else {
        wp_big.resize(p, Complex::default());
        y_big.resize(p, Complex::default());
        (&mut wp_big, &mut y_big)
    };
    for (j, w) in wp.iter_mut().enumerate() {
        *w = twiddles[j * q * tw_stride];
    }
    for k in 0..q {
        for (r, yr) in y.iter_mut().enumerate() {
            *yr = out[r * q + k] * twiddles[r * k * tw_stride];
        }
        for s in 0..p {
            let mut acc = Complex::default();
            let mut e = 0;
            for &yr in y.iter() {
                acc += yr * wp[e];
                e += s;
                if e >= p {
                    e -= p;
                }
            }
            out[k + q * s] = acc;
        }
    }
}

/// Inverse DFT without the 1/n factor, `x_k = Σ_j X_j·e^{+2πi·jk/n}`, as conj(FFT(conj(X))).
pub(crate) fn ifft_unscaled(x: &[Complex]) -> Vec<Complex> {
    let c: Vec<Complex> = x.iter().map(|z| z.conj()).collect();
    fft(&c).into_iter().map(|z| z.conj()).collect()
}

/// The Chebyshev nodes of the first kind in θ: θ_k = (k+½)π/n, k = 0..n (ascending θ, descending μ = cos θ).
pub(crate) fn chebyshev_node(k: usize, n: usize) -> f64 {
    (k as f64 + 0.5) * std::f64::consts::PI / n as f64
}

/// DCT-II, scaled as Chebyshev interpolation coefficients: for samples `v_k = f(cos θ_k)` at the n Chebyshev nodes
/// of the first kind θ_k = (k+½)π/n, returns `c_j = (2/n)·Σ_k v_k·cos(j·θ_k)`, j = 0..n, so that the interpolating
/// polynomial is `c_0/2 + Σ_{j≥1} c_j·T_j(μ)` (Trefethen, *Approximation Theory and Approximation Practice*, 2013,
/// ch. 3). Complex samples give complex coefficients (the kernel is real). One FFT of the even extension of
/// length 2n: Y_j = 2·e^{iπj/(2n)}·Σ_k v_k·cos(πj(k+½)/n).
pub(crate) fn chebyshev_coefficients(v: &[Complex]) -> Vec<Complex> {
    let n = v.len();
    let y: Vec<Complex> = v.iter().chain(v.iter().rev()).copied().collect();
    let yf = fft(&y);
    let phase = roots(4 * n, n); // e^{−iπj/(2n)}
    (0..n).map(|j| phase[j] * yf[j] / n as f64).collect()
}

/// The inverse of [`chebyshev_coefficients`] onto another node count: the values `c_0/2 + Σ_j c_j·cos(j·θ_k)` at the
/// `n` first-kind nodes θ_k = (k+½)π/n, for coefficients `c` (complex, fewer than n; the rest taken as 0): one
/// inverse FFT of length 2n.
pub(crate) fn chebyshev_values(c: &[Complex], n: usize) -> Vec<Complex> {
    assert!(c.len() < n, "chebyshev_values: {} coefficients onto {n} nodes", c.len());
    // v_k = c_0/2 + Σ_{j≥1} c_j·cos(jθ_k) = ½·Σ_{j=−(n−1)}^{n−1} c'_{|j|}·e^{ijθ_k} with c'_0 = c_0, c'_j = c_j, and
    // e^{ijθ_k} = e^{iπj/(2n)}·e^{2πi·jk/(2n)}; negative j sit at index j + 2n.
    let two_n = 2 * n;
    let phase = roots(4 * n, c.len()); // e^{−iπj/(2n)}
    let mut y = vec![Complex::default(); two_n];
    for (j, &cj) in c.iter().enumerate() {
        y[j] += cj * phase[j].conj();
        if j > 0 {
            y[two_n - j] += cj * phase[j];
        }
    }
    let t = ifft_unscaled(&y);
    t[..n].iter().map(|&z| z * 0.5).collect()
}

/// Cosine sum on a uniform grid: `C_m = Σ_l d_l·cos(l·m·π/M)` for m = 0..=M, for coefficients of any length. Terms
/// with l > M are first folded onto 0..=M (cos(l·mπ/M) is 2M-periodic and even in l, so the fold is exact), then
/// the DCT-I is the FFT of the even extension of length 2M.
pub(crate) fn cosine_sum_on_grid(d: &[f64], m_div: usize) -> Vec<f64> {
    let two_m = 2 * m_div;
    let mut e = vec![0.0; m_div + 1];
    for (l, &dl) in d.iter().enumerate() {
        let q = l % two_m;
        e[if q <= m_div { q } else { two_m - q }] += dl;
    }
    let mut z = vec![Complex::default(); two_m];
    for (r, &er) in e.iter().enumerate() {
        z[r] = Complex::from_real(er);
        if r > 0 && r < m_div {
            z[two_m - r] = Complex::from_real(er);
        }
    }
    let zf = fft(&z);
    // Z_m = E_0 + (−1)^m·E_M + 2·Σ_{r=1}^{M−1} E_r·cos(πrm/M).
    (0..=m_div)
        .map(|m| {
            let sign = if m % 2 == 0 { 1.0 } else { -1.0 };
            (zf[m].re + e[0] + sign * e[m_div]) / 2.0
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn naive_dft(x: &[Complex]) -> Vec<Complex> {
        let n = x.len();
        (0..n)
            .map(|j| {
                let mut acc = Complex::default();
                for (k, &xk) in x.iter().enumerate() {
                    acc += xk * Complex::cis(-2.0 * std::f64::consts::PI * ((j * k) % n) as f64 / n as f64);
                }
                acc
            })
            .collect()
    }

    #[test]
    fn fft_matches_the_naive_dft() {
        for n in [1, 2, 3, 5, 7, 12, 30, 45, 64, 98, 120] {
            let x: Vec<Complex> =
                (0..n).map(|k| Complex::new((k as f64 * 0.7).sin() + 0.1, (k as f64 * 1.3).cos())).collect();
            let a = fft(&x);
            let b = naive_dft(&x);
            for (p, q) in a.iter().zip(&b) {
                assert!((*p - *q).abs() < 1e-12 * (n as f64), "n = {n}: {p:?} vs {q:?}");
            }
        }
    }

    #[test]
    fn next_smooth_numbers() {
        assert_eq!(next_smooth(0), 1);
        assert_eq!(next_smooth(7), 8);
        assert_eq!(next_smooth(11), 12);
        assert_eq!(next_smooth(8341), 8640);
        assert_eq!(factors(7200), vec![2, 2, 2, 2, 2, 3, 3, 5, 5]);
    }

    #[test]
    fn chebyshev_coefficients_reproduce_a_polynomial() {
        // f = 3 − 2·T_1 + 0.5·T_4 (+ i·T_2) sampled at 9 Chebyshev nodes: c = [6, −2, i, 0, 0.5, 0, …].
        let n = 9;
        let f = |t: f64| Complex::new(3.0 - 2.0 * t.cos() + 0.5 * (4.0 * t).cos(), (2.0 * t).cos());
        let v: Vec<Complex> = (0..n).map(|k| f(chebyshev_node(k, n))).collect();
        let c = chebyshev_coefficients(&v);
        let want = [6.0, -2.0, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.0];
        for (j, (a, b)) in c.iter().zip(want).enumerate() {
            let im = if j == 2 { 1.0 } else { 0.0 };
            assert!((a.re - b).abs() < 1e-13 && (a.im - im).abs() < 1e-13, "{c:?}");
        }
        // … and evaluates back on a finer node set exactly.
        let m = 20;
        let back = chebyshev_values(&c, m);
        for (k, z) in back.iter().enumerate() {
            let want = f(chebyshev_node(k, m));
            assert!((*z - want).abs() < 1e-13, "node {k}: {z:?} vs {want:?}");
        }
    }

    #[test]
    fn cosine_sum_folds_high_orders_exactly() {
        let d: Vec<f64> = (0..50).map(|l| 1.0 / (1.0 + l as f64)).collect();
        let m_div = 12;
        let got = cosine_sum_on_grid(&d, m_div);
        for (m, g) in got.iter().enumerate() {
            let th = m as f64 * std::f64::consts::PI / m_div as f64;
            let want: f64 = d.iter().enumerate().map(|(l, dl)| dl * (l as f64 * th).cos()).sum();
            assert!((g - want).abs() < 1e-12, "m = {m}: {g} vs {want}");
        }
    }
}

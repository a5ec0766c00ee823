//! Wavelength strategies: how a path chooses the wavelengths it carries, and how its radiance becomes colour.
//!
//! Every strategy gives the integrator a [`SampledWavelengths`] whose effective densities make
//! `Σᵢ L(λᵢ)·w(λᵢ)/pdfᵢ` an unbiased estimate of `∫ L(λ)·w(λ) dλ` for the film's colour matching functions `w`,
//! and keeps it unbiased when a dispersive surface forces a single wavelength
//! ([`SampledWavelengths::terminate_secondary`]).

use std::fmt;
use std::str::FromStr;

use crate::cmf::{stiles_burch, stiles_burch_to_xyz, CmfTable, Observer};
use crate::color::{mul_mat_vec, Mat3, Xyz};
use crate::distribution::Distribution1D;
use crate::sampled::{SampledSpectrum, SampledWavelengths, N_WAVELENGTHS};
use crate::{LAMBDA_MAX, LAMBDA_MIN};

/// The three ways a path can carry wavelengths.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum WavelengthStrategy {
    /// Seed 000's simple solution: three bands (blue 360–490, green 490–590, red 590–830 nm), one wavelength drawn
    /// in each; at a dispersive event one band survives with probability 1/3 and is weighted by 3.
    Rgb,
    /// Seed 000's better solution: one wavelength per path from the discrete pdf made of the element-wise mean of
    /// the normalised Stiles & Burch r̄, ḡ, b̄; radiance weighted by (r̄, ḡ, b̄)(λ)/pdf(λ), then converted to XYZ.
    Cmf,
    /// Hero wavelength sampling (Wilkie et al. 2014): four wavelengths from a visible-importance pdf, rotated in
    /// primary sample space, carried together until a dispersive event keeps one (seed 001's proposal). The pdf
    /// is ∝ x̄ + ȳ + z̄, or pbrt-v4's own visible-wavelength pdf ([`visible_pdf`]) when the film clamps
    /// ([`WavelengthSampler::with_pbrt_hero_pdf`]): a clamp's bias depends on how single samples are distributed.
    #[default]
    Hero,
}

impl WavelengthStrategy {
    /// All strategies.
    pub const ALL: [WavelengthStrategy; 3] =
        [WavelengthStrategy::Rgb, WavelengthStrategy::Cmf, WavelengthStrategy::Hero];

    /// Name used on the command line.
    pub fn name(self) -> &'static str {
        match self {
            WavelengthStrategy::Rgb => "rgb",
            WavelengthStrategy::Cmf => "cmf",
            WavelengthStrategy::Hero => "hero",
        }
    }
}

impl fmt::Display for WavelengthStrategy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for WavelengthStrategy {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|w| w.name().eq_ignore_ascii_case(s))
            .ok_or_else(|| format!("unknown wavelength strategy '{s}': expected one of rgb, cmf, hero"))
    }
}

/// Edges of the `rgb` strategy's bands, nm: blue, green, red (near where b̄/ḡ and ḡ/r̄ of Stiles & Burch cross).
pub const RGB_BAND_EDGES: [f64; 4] = [LAMBDA_MIN, 490.0, 590.0, LAMBDA_MAX];

/// Draws wavelengths for one strategy and turns sampled radiance into XYZ for one observer.
#[derive(Clone, Debug)]
pub struct WavelengthSampler {
    strategy: WavelengthStrategy,
    observer: Observer,
    /// Density ∝ x̄ + ȳ + z̄ over 360–830 nm in 1 nm bins: positive everywhere the observer sees, so XYZ weights
    /// divided by it stay bounded (`hero`, and `rgb` band by band).
    visible: Distribution1D,
    /// The visible cdf at [`RGB_BAND_EDGES`].
    band_cdf: [f64; 4],
    /// Seed 000's Stiles & Burch pdf over 390–830 nm in 5 nm bins (`cmf`).
    cmf: Distribution1D,
    /// Stiles & Burch RGB → normalised XYZ of `observer`.
    sb_to_xyz: Mat3,
    /// The observer's x̄ȳz̄ table (`Observer::table` would pass a lazy initialisation on every lookup).
    xyz_table: &'static CmfTable,
    /// 1 / ∫ȳ dλ.
    inv_y_integral: f64,
    /// `hero` draws from pbrt-v4's visible pdf instead of x̄ + ȳ + z̄.
    pbrt_hero: bool,
}

impl WavelengthSampler {
    /// Builds the tables for `strategy` with colours measured by `observer`.
    pub fn new(strategy: WavelengthStrategy, observer: Observer) -> Self {
        let t = observer.table();
        let g: Vec<f64> = t.values.iter().map(|v| v[0] + v[1] + v[2]).collect();
        // One bin between consecutive 1 nm table points, valued at their mean.
        let bins: Vec<f64> = g.windows(2).map(|w| 0.5 * (w[0] + w[1])).collect();
        let visible = Distribution1D::new(&bins, t.lambda_min, t.lambda_max())
            .expect("observer tables are finite and non-negative");
        let band_cdf = RGB_BAND_EDGES.map(|l| visible.cdf(l));
        Self {
            strategy,
            observer,
            visible,
            band_cdf,
            cmf: stiles_burch_pdf(),
            sb_to_xyz: stiles_burch_to_xyz(observer),
            xyz_table: observer.table(),
            inv_y_integral: 1.0 / observer.y_integral(),
            pbrt_hero: false,
        }
    }

    /// With `on`, `hero` draws its wavelengths from pbrt-v4's visible-wavelength pdf ([`visible_pdf`]) instead of
    /// x̄ + ȳ + z̄. Both give unbiased images, and x̄ + ȳ + z̄ less colour noise (it keeps more samples at the ends of
    /// the spectrum: relative MSE 1.09 against 1.43 on the dispersive benchmark room); but where a nonlinear step
    /// sees single samples, as the film's `maxcomponentvalue` clamp does, the image depends on the pdf, and with
    /// pbrt-v4's it is pbrt-v4's. The film turns this on when it clamps.
    pub fn with_pbrt_hero_pdf(mut self, on: bool) -> Self {
        self.pbrt_hero = on;
        self
    }

    /// The strategy.
    pub fn strategy(&self) -> WavelengthStrategy {
        self.strategy
    }

    /// The observer colours are measured with.
    pub fn observer(&self) -> Observer {
        self.observer
    }

    /// The visible-importance density (∝ x̄ + ȳ + z̄) that `hero` (unless [`Self::with_pbrt_hero_pdf`]) and, band
    /// by band, `rgb` draw from.
    pub fn visible_distribution(&self) -> &Distribution1D {
        &self.visible
    }

    /// Draws the wavelengths of one path from a single uniform number `u ∈ [0, 1)`.
    pub fn sample(&self, u: f64) -> SampledWavelengths {
        let mut lambda = [0.0f32; N_WAVELENGTHS];
        let mut pdf = [0.0f32; N_WAVELENGTHS];
        match self.strategy {
            WavelengthStrategy::Hero => {
                // Rotation by i/N in primary sample space keeps every λᵢ's marginal density equal to p(λ);
                // the estimate averages the N of them, hence the effective density N·p(λᵢ).
                for i in 0..N_WAVELENGTHS {
                    let ui = (u + i as f64 / N_WAVELENGTHS as f64).fract();
                    let (l, p) = if self.pbrt_hero {
                        sample_visible_with_pdf(ui)
                    } else {
                        let s = self.visible.sample(ui);
                        (s.x, s.pdf)
                    };
                    lambda[i] = l as f32;
                    pdf[i] = (N_WAVELENGTHS as f64 * p) as f32;
                }
            }
            WavelengthStrategy::Rgb => {
                // One stratum per band: λ_k ~ p restricted to band k, density p(λ)/P(band k); the strata sum.
                for k in 0..3 {
                    let (c0, c1) = (self.band_cdf[k], self.band_cdf[k + 1]);
                    let s = self.visible.sample(c0 + u * (c1 - c0));
                    lambda[k] = s.x as f32;
                    pdf[k] = (s.pdf / (c1 - c0)) as f32;
                }
                lambda[3] = lambda[0];
            }
            WavelengthStrategy::Cmf => {
                let s = self.cmf.sample(u);
                lambda = [s.x as f32; N_WAVELENGTHS];
                pdf[0] = s.pdf as f32;
            }
        }
        SampledWavelengths::new(lambda, pdf)
    }

    /// The path's contribution to the image in XYZ (Y = 1 for a constant-1 spectrum seen by the observer).
    pub fn to_xyz(&self, radiance: &SampledSpectrum, wl: &SampledWavelengths) -> Xyz {
        let w = radiance.safe_div(wl.pdf());
        let mut acc = [0.0f64; 3];
        match self.strategy {
            WavelengthStrategy::Cmf => {
                // Seed 000: (Φr, Φg, Φb) = Φλ·(r̄, ḡ, b̄)(λ)/pdf(λ), then to XYZ by the fitted matrix.
                for i in 0..N_WAVELENGTHS {
                    if wl.is_active(i) {
                        let rgb = stiles_burch().eval(wl.lambda(i) as f64);
                        for c in 0..3 {
                            acc[c] += w[i] as f64 * rgb[c];
                        }
                    }
                }
                Xyz::from_array(mul_mat_vec(&self.sb_to_xyz, acc))
            }
            _ => {
                for i in 0..N_WAVELENGTHS {
                    if wl.is_active(i) {
                        let cmf = self.xyz_table.eval(wl.lambda(i) as f64);
                        for c in 0..3 {
                            acc[c] += w[i] as f64 * cmf[c];
                        }
                    }
                }
                Xyz::from_array(acc.map(|v| v * self.inv_y_integral))
            }
        }
    }

    /// The value `to_xyz` converges to for a spectrum: direct integration of the strategy's colour matching
    /// functions (the observer's x̄ȳz̄; for `cmf`, Stiles & Burch r̄ḡb̄ through the fitted matrix).
    pub fn reference_xyz(&self, s: &crate::Spectrum) -> Xyz {
        match self.strategy {
            WavelengthStrategy::Cmf => {
                let sb = stiles_burch();
                let mut acc = [0.0; 3];
                // Trapezoid rule on a 0.25 nm grid over the S&B range (the product is piecewise smooth).
                let (a, b) = (sb.lambda_min, sb.lambda_max());
                let n = ((b - a) / 0.25) as usize;
                for i in 0..=n {
                    let l = a + (b - a) * i as f64 / n as f64;
                    let wgt = if i == 0 || i == n { 0.5 } else { 1.0 } * (b - a) / n as f64;
                    let v = s.eval(l);
                    let rgb = sb.eval(l);
                    for c in 0..3 {
                        acc[c] += wgt * v * rgb[c];
                    }
                }
                Xyz::from_array(mul_mat_vec(&self.sb_to_xyz, acc))
            }
            _ => self.observer.spectrum_to_xyz(s),
        }
    }
}

/// pbrt-v4's visible-wavelength importance function p(λ) ∝ 1/cosh²(A(λ − B)), A = 0.0072 nm⁻¹, B = 538 nm
/// (Pharr, Jakob & Humphreys, *PBR* 4th ed., eq. 5.9).
const VISIBLE_A: f64 = 0.0072;
const VISIBLE_B: f64 = 538.0;

/// tanh(A(λ − B)) at the ends of [`LAMBDA_MIN`, `LAMBDA_MAX`]: the antiderivative of cosh⁻² is tanh / A.
/// Computed once: the hero strategy draws four wavelengths per camera sample, and two `tanh` per draw were a few
/// per cent of a render of a simple scene.
fn visible_tanh_range() -> (f64, f64) {
    static RANGE: std::sync::LazyLock<(f64, f64)> = std::sync::LazyLock::new(|| {
        ((VISIBLE_A * (LAMBDA_MIN - VISIBLE_B)).tanh(), (VISIBLE_A * (LAMBDA_MAX - VISIBLE_B)).tanh())
    });
    *RANGE
}

/// pbrt-v4's visible-wavelength density on 360–830 nm (per nm; 0 outside), which `hero` draws from:
/// p(λ) = A / (cosh²(A(λ − B)) · (tanh(A(830 − B)) − tanh(A(360 − B)))).
pub fn visible_pdf(lambda: f64) -> f64 {
    if !(LAMBDA_MIN..=LAMBDA_MAX).contains(&lambda) {
        return 0.0;
    }
    let (t0, t1) = visible_tanh_range();
    let c = (VISIBLE_A * (lambda - VISIBLE_B)).cosh();
    VISIBLE_A / (c * c * (t1 - t0))
}

/// Draws a wavelength (nm) from [`visible_pdf`] by inverting its cdf: λ = B + atanh(t₀ + u·(t₁ − t₀)) / A.
pub fn sample_visible(u: f64) -> f64 {
    sample_visible_with_pdf(u).0
}

/// [`sample_visible`] and the density there, [`visible_pdf`], from the same t = tanh(A(λ − B)): since
/// cosh⁻²(x) = 1 − tanh²(x), p(λ) = A(1 − t²)/(t₁ − t₀) needs no further transcendental function.
pub fn sample_visible_with_pdf(u: f64) -> (f64, f64) {
    let (t0, t1) = visible_tanh_range();
    let t = (t0 + u.clamp(0.0, 1.0) * (t1 - t0)).clamp(t0, t1);
    // atanh t = ½ ln((1 + t)/(1 − t)), with |t| ≤ 0.87 here; single precision keeps λ to 1e-4 nm and is cheaper.
    let atanh = 0.5 * (((1.0 + t) / (1.0 - t)) as f32).ln() as f64;
    let lambda = (VISIBLE_B + atanh / VISIBLE_A).clamp(LAMBDA_MIN, LAMBDA_MAX);
    (lambda, VISIBLE_A * (1.0 - t * t) / (t1 - t0))
}

/// Seed 000's discrete pdf for `cmf`: the element-wise mean of r̄, ḡ, b̄, each normalised to unit area.
///
/// Negative lobes: a pdf cannot be negative, so each function enters by its absolute value, |c̄|/∫|c̄|. The pdf is
/// then positive wherever any of r̄, ḡ, b̄ is non-zero, and weighting by the signed (r̄, ḡ, b̄)(λ)/pdf(λ) keeps the
/// estimate of ∫ L·c̄ unbiased, negative lobes included. Bins are the 5 nm intervals of the table, valued at the
/// mean of their end points.
pub fn stiles_burch_pdf() -> Distribution1D {
    let sb = stiles_burch();
    let area: [f64; 3] = std::array::from_fn(|c| sb.values.iter().map(|v| v[c].abs()).sum::<f64>() * sb.step);
    let g: Vec<f64> = sb.values.iter().map(|v| (0..3).map(|c| v[c].abs() / area[c]).sum::<f64>() / 3.0).collect();
    let bins: Vec<f64> = g.windows(2).map(|w| 0.5 * (w[0] + w[1])).collect();
    Distribution1D::new(&bins, sb.lambda_min, sb.lambda_max()).expect("Stiles & Burch table is finite")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strategies_parse_by_name() {
        assert_eq!("HERO".parse::<WavelengthStrategy>().unwrap(), WavelengthStrategy::Hero);
        assert_eq!("rgb".parse::<WavelengthStrategy>().unwrap(), WavelengthStrategy::Rgb);
        assert!("spectral".parse::<WavelengthStrategy>().unwrap_err().contains("rgb, cmf, hero"));
    }

    #[test]
    fn cmf_pdf_handles_negative_lobes_by_absolute_value() {
        // Where r̄ is negative (its lobe near 495 nm) the pdf must still be the mean of |r̄|, |ḡ|, |b̄| over their
        // areas — positive wherever any function is non-zero — so signed weights keep the estimate unbiased.
        let d = stiles_burch_pdf();
        let sb = stiles_burch();
        let area: [f64; 3] = std::array::from_fn(|c| sb.values.iter().map(|v| v[c].abs()).sum::<f64>() * sb.step);
        let g = |l: f64| (0..3).map(|c| sb.eval(l)[c].abs() / area[c]).sum::<f64>() / 3.0;
        assert!(sb.eval(495.0)[0] < -0.4);
        let expected = 0.5 * (g(495.0) + g(500.0));
        // (1e-3: the distribution renormalises the trapezoid bins, the areas here are 5 nm Riemann sums.)
        assert!((d.pdf(497.5) - expected).abs() < 1e-3 * expected, "{} vs {expected}", d.pdf(497.5));
        for i in 0..88 {
            let l = 390.0 + 5.0 * i as f64 + 2.5;
            assert!(d.pdf(l) > 0.0, "pdf vanishes at {l} nm");
        }
        // Clamping the lobe to zero instead would lose the r̄ < 0 part: the signed estimate of ∫ r̄ needs it.
        assert!(sb.values.iter().any(|v| v[0] < 0.0 && v[1].abs() + v[2].abs() > 0.0));
    }

    #[test]
    fn hero_draws_from_pbrt_v4_visible_pdf() {
        // pbrt-v4 writes its normalised density as 0.0039398042 / cosh²(0.0072 (λ − 538)) and its inverse cdf as
        // 538 − 138.888889 · atanh(0.85691062 − 1.82750197 u) (sampling.h); ours must be the same function.
        assert!((visible_pdf(538.0) - 0.003_939_804_2).abs() < 1e-9);
        assert!((visible_pdf(450.0) - 0.003_939_804_2 / (0.0072f64 * -88.0).cosh().powi(2)).abs() < 1e-9);
        assert_eq!((visible_pdf(359.0), visible_pdf(831.0)), (0.0, 0.0));
        for u in [0.0f64, 0.1, 0.37, 0.5, 0.9, 0.999] {
            let pbrt = 538.0 - 138.888_889 * (0.856_910_62 - 1.827_501_97 * u).atanh();
            assert!((sample_visible(u) - pbrt).abs() < 1e-3, "u {u}: {} vs {pbrt}", sample_visible(u));
        }
        // ∫ p = 1 over 360–830 nm (midpoint rule, 0.01 nm).
        let integral: f64 = (0..47_000).map(|i| visible_pdf(360.0 + 0.01 * (i as f64 + 0.5)) * 0.01).sum();
        assert!((integral - 1.0).abs() < 1e-9, "{integral}");
        // The four hero slots are rotated by 1/4 in primary sample space, each with effective density 4·p(λ).
        let wl =
            WavelengthSampler::new(WavelengthStrategy::Hero, Observer::Cie1931).with_pbrt_hero_pdf(true).sample(0.3);
        for (i, u) in [0.3, 0.55, 0.8, 0.05].into_iter().enumerate() {
            assert!((wl.lambda(i) as f64 - sample_visible(u)).abs() < 1e-3);
            let p = 4.0 * visible_pdf(wl.lambda(i) as f64);
            let (l, q) = sample_visible_with_pdf(u);
            assert!((l - sample_visible(u)).abs() < 1e-12 && (q - visible_pdf(l)).abs() < 1e-5 * q);
            assert!((wl.pdf().0[i] as f64 - p).abs() < 1e-6 * p);
        }
    }

    #[test]
    fn slot_layout_per_strategy() {
        let hero = WavelengthSampler::new(WavelengthStrategy::Hero, Observer::Cie1931).sample(0.3);
        assert_eq!(hero.active_count(), 4);
        let rgb = WavelengthSampler::new(WavelengthStrategy::Rgb, Observer::Cie1931).sample(0.3);
        assert_eq!(rgb.active_count(), 3);
        assert!(rgb.lambda(0) < 490.0 && (490.0..590.0).contains(&rgb.lambda(1)) && rgb.lambda(2) >= 590.0);
        let cmf = WavelengthSampler::new(WavelengthStrategy::Cmf, Observer::Cie1931).sample(0.3);
        assert_eq!(cmf.active_count(), 1);
        assert!((390.0..=830.0).contains(&cmf.lambda(0)));
    }
}

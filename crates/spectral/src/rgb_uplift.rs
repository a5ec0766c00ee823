//! RGB → spectrum uplifting after Jakob & Hanika 2019, "A Low-Dimensional Function Space for Efficient Spectral
//! Upsampling" (Computer Graphics Forum 38(2), Eurographics 2019).
//!
//! A reflectance is represented by three coefficients as f(λ) = S(c₀λ² + c₁λ + c₂) with the sigmoid
//! S(x) = ½ + x / (2√(1 + x²)), which maps the real line smoothly onto (0, 1), so every such spectrum is a valid,
//! smooth reflectance. The coefficients for a linear sRGB colour come from a precomputed table over the RGB cube,
//! interpolated trilinearly.
//!
//! # The table
//!
//! The table is computed by this crate's build script (`build.rs`) with its own Gauss–Newton optimiser: for each
//! target colour it finds the coefficients whose spectrum, as a reflectance lit by CIE D65 and seen by the
//! CIE 1931 2° observer (1 nm sums over 360–830 nm, normalised so that a perfect white reflector has Y = 1), has
//! the target's CIELAB coordinates (residual below 0.01 ΔE76 everywhere on the grid). The layout follows the paper:
//! for each choice of the largest component l, a grid of R = 64 nodes over its value z (spaced as
//! smoothstep(smoothstep(t)), dense near 0 and 1) and R × R nodes over the ratios of the other two components to it
//! (spaced quadratically, (i/63)², dense near 0 where saturated colours' spectra change fastest).
//! It is embedded in the binary (about 9 MB of `f32`) and decoded once on first use.
//!
//! # Spectrum kinds
//!
//! The three kinds mirror pbrt-v4's: [`RgbAlbedoSpectrum`] for reflectances (components in [0, 1]),
//! [`RgbUnboundedSpectrum`] for any non-negative colour (a scale times a sigmoid spectrum) and
//! [`RgbIlluminantSpectrum`] for emission (an unbounded spectrum times the colour space's illuminant, D65 for sRGB).
//! All are cheap to clone.

use std::fmt;
use std::sync::{Arc, OnceLock};

use crate::spectrum::{PiecewiseLinear, Spectrum};
use crate::{SpectrumError, LAMBDA_MAX, LAMBDA_MIN};

/// The build script's output: see `write_blob` in `build.rs` for the layout.
static SRGB_TABLE_BLOB: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/srgb_sigmoid_table.bin"));

/// Wavelength at which the table's normalised wavelength u is 0, nm.
const TABLE_LAMBDA_MIN: f64 = 360.0;
/// Width of the table's wavelength range, nm: u = (λ − 360) / 470.
const TABLE_LAMBDA_RANGE: f64 = 470.0;

/// The sigmoid S(x) = ½ + x / (2√(1 + x²)) (Jakob & Hanika 2019's S), with S(±∞) = 1 and 0.
pub fn sigmoid(x: f64) -> f64 {
    if x.is_nan() {
        return f64::NAN;
    }
    if x.abs() > 1e150 {
        // 1 + x² would overflow; S(x) is 0 or 1 to machine precision long before this.
        return if x > 0.0 { 1.0 } else { 0.0 };
    }
    0.5 + x / (2.0 * (1.0 + x * x).sqrt())
}

/// The inverse of [`sigmoid`]: x = (v − ½) / √(v(1 − v)), giving −∞ at v = 0 and +∞ at v = 1.
/// Values outside [0, 1] are clamped (NaN stays NaN).
pub fn inverse_sigmoid(v: f64) -> f64 {
    if v <= 0.0 {
        f64::NEG_INFINITY
    } else if v >= 1.0 {
        f64::INFINITY
    } else {
        (v - 0.5) / (v * (1.0 - v)).sqrt()
    }
}

/// A sigmoid-polynomial spectrum f(λ) = S(c₀λ² + c₁λ + c₂), λ in nm (Jakob & Hanika 2019's function space).
///
/// Values lie in [0, 1]. The coefficients may be infinite only for flat spectra (c₀ = c₁ = 0, c₂ = ±∞ meaning
/// the constants 1 and 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RgbSigmoid {
    /// Coefficient of λ², nm⁻².
    pub c0: f64,
    /// Coefficient of λ, nm⁻¹.
    pub c1: f64,
    /// Constant term.
    pub c2: f64,
}

impl RgbSigmoid {
    /// The flat spectrum of value `v` (clamped to [0, 1]): c₀ = c₁ = 0, c₂ = S⁻¹(v).
    pub fn constant(v: f64) -> Self {
        Self { c0: 0.0, c1: 0.0, c2: inverse_sigmoid(v) }
    }

    /// The polynomial c₀λ² + c₁λ + c₂ at `lambda_nm`.
    fn polynomial(&self, lambda_nm: f64) -> f64 {
        if self.c0 == 0.0 && self.c1 == 0.0 {
            // Keeps infinite c₂ (flat 0 or 1) away from 0·λ arithmetic.
            return self.c2;
        }
        (self.c0 * lambda_nm + self.c1) * lambda_nm + self.c2
    }

    /// The spectrum's value at `lambda_nm`: S(c₀λ² + c₁λ + c₂), in [0, 1].
    pub fn eval(&self, lambda_nm: f64) -> f64 {
        sigmoid(self.polynomial(lambda_nm))
    }

    /// Largest value over the transport range 360–830 nm. S is increasing, so this is S at the polynomial's
    /// maximum, found among the range's ends and the parabola's vertex.
    pub fn max_value(&self) -> f64 {
        let mut m = self.polynomial(LAMBDA_MIN).max(self.polynomial(LAMBDA_MAX));
        if self.c0 < 0.0 {
            let vertex = -self.c1 / (2.0 * self.c0);
            if (LAMBDA_MIN..=LAMBDA_MAX).contains(&vertex) {
                m = m.max(self.polynomial(vertex));
            }
        }
        sigmoid(m)
    }

    /// Converts coefficients of the polynomial in u = (λ − λ₀) / w into coefficients in λ (nm):
    /// a·u² + b·u + c = (a/w²)·λ² + (b/w − 2aλ₀/w²)·λ + (aλ₀²/w² − bλ₀/w + c).
    fn from_normalized(a: f64, b: f64, c: f64) -> Self {
        let (l0, w) = (TABLE_LAMBDA_MIN, TABLE_LAMBDA_RANGE);
        let (w2, l02) = (w * w, l0 * l0);
        Self { c0: a / w2, c1: b / w - 2.0 * a * l0 / w2, c2: a * l02 / w2 - b * l0 / w + c }
    }
}

/// Coefficients of the sigmoid-polynomial spectra of an RGB colour space (only linear sRGB is built in), with
/// trilinear interpolation between the precomputed colours.
#[derive(Clone)]
pub struct RgbToSpectrumTable {
    /// Resolution R of each axis.
    res: usize,
    /// The R values of the largest component at which coefficients are tabulated, increasing from 0 to 1.
    z_nodes: Arc<[f64]>,
    /// Coefficients in u = (λ − 360 nm)/470 nm as little-endian f32 bytes, indexed [largest component][z][ratio 2]
    /// [ratio 1][coefficient]; ratio node i is at ratio (i/(R−1))². Read in place from the program's embedded blob
    /// rather than decoded into a copy: the copy was 9.4 MB of every render's peak memory, and only the pages of
    /// colours a scene uses are ever touched.
    coeffs: &'static [u8],
    /// The colour space's illuminant, normalised to luminance Y = 1.
    illuminant: Arc<PiecewiseLinear>,
}

impl fmt::Debug for RgbToSpectrumTable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("RgbToSpectrumTable").field("resolution", &self.res).finish_non_exhaustive()
    }
}

impl PartialEq for RgbToSpectrumTable {
    fn eq(&self, other: &Self) -> bool {
        (std::ptr::eq(self.coeffs, other.coeffs) || self.coeffs == other.coeffs)
            && self.z_nodes == other.z_nodes
            && self.illuminant == other.illuminant
    }
}

impl RgbToSpectrumTable {
    /// The table for linear sRGB (ITU-R BT.709 primaries, D65 white), computed at build time and decoded on
    /// first use.
    pub fn srgb() -> &'static RgbToSpectrumTable {
        static TABLE: OnceLock<RgbToSpectrumTable> = OnceLock::new();
        TABLE.get_or_init(|| Self::decode(SRGB_TABLE_BLOB, normalized_d65()))
    }

    /// Decodes the build script's blob. The blob is part of the program, so a malformed one is a build defect.
    fn decode(blob: &'static [u8], illuminant: Arc<PiecewiseLinear>) -> Self {
        assert!(blob.len() >= 12 && &blob[..8] == b"RGBSIG01", "corrupt RGB-to-spectrum table");
        let res = u32::from_le_bytes(blob[8..12].try_into().expect("4 bytes")) as usize;
        let z_end = 12 + 8 * res;
        let n_coeffs = 3 * res * res * res * 3;
        assert_eq!(blob.len(), z_end + 4 * n_coeffs, "RGB-to-spectrum table has the wrong size");
        let z_nodes =
            blob[12..z_end].chunks_exact(8).map(|b| f64::from_le_bytes(b.try_into().expect("8 bytes"))).collect();
        Self { res, z_nodes, coeffs: &blob[z_end..], illuminant }
    }

    /// Resolution R of the table (3 × R³ tabulated colours).
    pub fn resolution(&self) -> usize {
        self.res
    }

    /// The colour space's illuminant (D65 for sRGB) as a spectrum normalised to luminance Y = 1, i.e.
    /// ∫ S(λ) ȳ(λ) dλ / ∫ ȳ(λ) dλ = 1 with 1 nm sums over 360–830 nm and the CIE 1931 observer.
    pub fn illuminant(&self) -> &Arc<PiecewiseLinear> {
        &self.illuminant
    }

    /// Coefficients of the sigmoid-polynomial reflectance whose colour is the linear RGB `rgb`.
    ///
    /// Components are clamped to [0, 1] (NaN counts as 0; the spectrum constructors reject NaN before it gets
    /// here). Greys (all components equal) get the exact flat spectrum c₀ = c₁ = 0, c₂ = S⁻¹(v), with v = 0 and 1
    /// giving c₂ = −∞ and +∞; other colours interpolate the table trilinearly.
    pub fn sigmoid_coefficients(&self, rgb: [f64; 3]) -> RgbSigmoid {
        let rgb = rgb.map(|v| if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) });
        if rgb[0] == rgb[1] && rgb[1] == rgb[2] {
            return RgbSigmoid::constant(rgb[0]);
        }
        // The largest component (ties resolve to the lowest index; the tied cells hold the same colour).
        let l = if rgb[0] >= rgb[1] {
            if rgb[0] >= rgb[2] {
                0
            } else {
                2
            }
        } else if rgb[1] >= rgb[2] {
            1
        } else {
            2
        };
        let z = rgb[l];
        // z > 0 here: not all components are equal, so the largest is positive. Ratio nodes sit at (i/(R−1))².
        let r = (self.res - 1) as f64;
        let x = (rgb[(l + 1) % 3] / z).sqrt() * r;
        let y = (rgb[(l + 2) % 3] / z).sqrt() * r;
        let xi = (x as usize).min(self.res - 2);
        let yi = (y as usize).min(self.res - 2);
        let zi = (self.z_nodes.partition_point(|&n| n <= z).max(1) - 1).min(self.res - 2);
        let (dx, dy) = (x - xi as f64, y - yi as f64);
        let dz = (z - self.z_nodes[zi]) / (self.z_nodes[zi + 1] - self.z_nodes[zi]);

        let mut c = [0.0f64; 3];
        for (k, ck) in c.iter_mut().enumerate() {
            let at = |zo: usize, yo: usize, xo: usize| {
                let cell = ((l * self.res + zi + zo) * self.res + yi + yo) * self.res + xi + xo;
                let i = 4 * (3 * cell + k);
                let b = [self.coeffs[i], self.coeffs[i + 1], self.coeffs[i + 2], self.coeffs[i + 3]];
                f64::from(f32::from_le_bytes(b))
            };
            let lerp = |t: f64, a: f64, b: f64| a + t * (b - a);
            let plane =
                |zo: usize| lerp(dy, lerp(dx, at(zo, 0, 0), at(zo, 0, 1)), lerp(dx, at(zo, 1, 0), at(zo, 1, 1)));
            *ck = lerp(dz, plane(0), plane(1));
        }
        RgbSigmoid::from_normalized(c[0], c[1], c[2])
    }
}

/// CIE D65 normalised to luminance 1 (Σ D65(λ)·ȳ(λ) / Σ ȳ(λ) = 1 over 1 nm steps from 360 to 830 nm, CIE 1931
/// observer), the normalisation pbrt-v4 gives its named illuminants: the crate's `stdillum-D65`, built from the
/// embedded 5 nm table of `data/cie_illuminants.csv` and cached, so every caller shares one allocation.
fn normalized_d65() -> Arc<PiecewiseLinear> {
    match crate::named::illuminant("stdillum-D65") {
        Ok(Spectrum::PiecewiseLinear(table)) => table,
        other => unreachable!("stdillum-D65 is a tabulated spectrum, got {other:?}"),
    }
}

/// Checks that every component of `rgb` is finite and non-negative (and at most `max`), naming the parameter
/// "rgb" otherwise.
fn validate_rgb(rgb: [f64; 3], max: f64, expected: &'static str) -> Result<(), SpectrumError> {
    for v in rgb {
        crate::check_finite("rgb", v)?;
        if !(0.0..=max).contains(&v) {
            return Err(SpectrumError::OutOfRange { name: "rgb", value: v, expected });
        }
    }
    Ok(())
}

/// Splits a non-negative colour into a scale 2·max(rgb) and the sigmoid spectrum of rgb / scale (whose largest
/// component is ½, leaving headroom on both sides of the sigmoid), as pbrt-v4 does for unbounded colours.
fn scale_and_sigmoid(table: &RgbToSpectrumTable, rgb: [f64; 3]) -> (f64, RgbSigmoid) {
    let m = rgb[0].max(rgb[1]).max(rgb[2]);
    let scale = 2.0 * m;
    let normalized = if scale > 0.0 { rgb.map(|v| v / scale) } else { [0.0; 3] };
    (scale, table.sigmoid_coefficients(normalized))
}

/// A reflectance (albedo) given as a linear sRGB colour with every component in [0, 1]: the sigmoid-polynomial
/// spectrum S(c₀λ² + c₁λ + c₂) of that colour, bounded by [0, 1] at every wavelength.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RgbAlbedoSpectrum {
    rsp: RgbSigmoid,
}

impl RgbAlbedoSpectrum {
    /// The albedo of linear sRGB colour `rgb`. Components must be finite and in [0, 1] (error naming "rgb").
    pub fn new(rgb: [f64; 3]) -> Result<Self, SpectrumError> {
        Self::with_table(RgbToSpectrumTable::srgb(), rgb)
    }

    /// The albedo of colour `rgb` in the colour space of `table`. Components must be finite and in [0, 1].
    pub fn with_table(table: &RgbToSpectrumTable, rgb: [f64; 3]) -> Result<Self, SpectrumError> {
        validate_rgb(rgb, 1.0, "a reflectance component in [0, 1]")?;
        Ok(Self { rsp: table.sigmoid_coefficients(rgb) })
    }

    /// The sigmoid polynomial.
    pub fn sigmoid(&self) -> &RgbSigmoid {
        &self.rsp
    }

    /// Value at `lambda_nm`, in [0, 1].
    pub fn eval(&self, lambda_nm: f64) -> f64 {
        self.rsp.eval(lambda_nm)
    }

    /// Largest value over 360–830 nm.
    pub fn max_value(&self) -> f64 {
        self.rsp.max_value()
    }

    /// The spectrum multiplied by `s`, which may leave [0, 1] and so is an unbounded spectrum.
    pub fn scaled(&self, s: f64) -> RgbUnboundedSpectrum {
        RgbUnboundedSpectrum { scale: s, rsp: self.rsp }
    }
}

/// Any non-negative linear sRGB colour as a spectrum: scale · S(c₀λ² + c₁λ + c₂) with scale = 2·max(rgb) and the
/// sigmoid fitted to rgb / scale (largest component ½), as pbrt-v4's `RGBUnboundedSpectrum`.
///
/// Fitting the half-height colour keeps the sigmoid away from its flat 0 and 1 limits, so the shape stays smooth
/// for bright colours; the colour is reproduced because the spectrum is linear in the scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RgbUnboundedSpectrum {
    scale: f64,
    rsp: RgbSigmoid,
}

impl RgbUnboundedSpectrum {
    /// The spectrum of linear sRGB colour `rgb`. Components must be finite and non-negative (error naming "rgb").
    pub fn new(rgb: [f64; 3]) -> Result<Self, SpectrumError> {
        Self::with_table(RgbToSpectrumTable::srgb(), rgb)
    }

    /// The spectrum of colour `rgb` in the colour space of `table`. Components must be finite and non-negative.
    pub fn with_table(table: &RgbToSpectrumTable, rgb: [f64; 3]) -> Result<Self, SpectrumError> {
        validate_rgb(rgb, f64::INFINITY, "a non-negative component")?;
        let (scale, rsp) = scale_and_sigmoid(table, rgb);
        Ok(Self { scale, rsp })
    }

    /// The scale, 2·max(rgb) for a freshly built spectrum.
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// The sigmoid polynomial.
    pub fn sigmoid(&self) -> &RgbSigmoid {
        &self.rsp
    }

    /// Value at `lambda_nm`.
    pub fn eval(&self, lambda_nm: f64) -> f64 {
        self.scale * self.rsp.eval(lambda_nm)
    }

    /// Largest value over 360–830 nm.
    pub fn max_value(&self) -> f64 {
        self.scale * self.rsp.max_value()
    }

    /// The spectrum multiplied by `s`.
    pub fn scaled(&self, s: f64) -> Self {
        Self { scale: self.scale * s, rsp: self.rsp }
    }
}

/// Emission given as a non-negative linear sRGB colour: scale · S(c₀λ² + c₁λ + c₂) · I(λ), where the scale and
/// sigmoid are those of [`RgbUnboundedSpectrum`] and I is the colour space's illuminant (D65 for sRGB) normalised
/// to luminance 1, as pbrt-v4's `RGBIlluminantSpectrum`. Colour (1, 1, 1) is thus exactly the normalised D65.
#[derive(Clone, Debug, PartialEq)]
pub struct RgbIlluminantSpectrum {
    scale: f64,
    rsp: RgbSigmoid,
    illuminant: Arc<PiecewiseLinear>,
}

impl RgbIlluminantSpectrum {
    /// The emission spectrum of linear sRGB colour `rgb`. Components must be finite and non-negative (error
    /// naming "rgb").
    pub fn new(rgb: [f64; 3]) -> Result<Self, SpectrumError> {
        Self::with_table(RgbToSpectrumTable::srgb(), rgb)
    }

    /// The emission spectrum of colour `rgb` in the colour space of `table`, over the table's illuminant.
    pub fn with_table(table: &RgbToSpectrumTable, rgb: [f64; 3]) -> Result<Self, SpectrumError> {
        validate_rgb(rgb, f64::INFINITY, "a non-negative component")?;
        let (scale, rsp) = scale_and_sigmoid(table, rgb);
        Ok(Self { scale, rsp, illuminant: table.illuminant().clone() })
    }

    /// The scale, 2·max(rgb) for a freshly built spectrum.
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// The sigmoid polynomial.
    pub fn sigmoid(&self) -> &RgbSigmoid {
        &self.rsp
    }

    /// The illuminant, normalised to luminance 1.
    pub fn illuminant(&self) -> &Arc<PiecewiseLinear> {
        &self.illuminant
    }

    /// Value at `lambda_nm`.
    pub fn eval(&self, lambda_nm: f64) -> f64 {
        self.scale * self.rsp.eval(lambda_nm) * self.illuminant.eval(lambda_nm)
    }

    /// Largest value over 360–830 nm, sampled at 1 nm and at the illuminant's own sample wavelengths.
    pub fn max_value(&self) -> f64 {
        let table_lambdas = self.illuminant.lambdas().iter().copied().filter(|l| (LAMBDA_MIN..=LAMBDA_MAX).contains(l));
        (360..=830).map(f64::from).chain(table_lambdas).map(|l| self.eval(l)).fold(0.0, f64::max)
    }

    /// The spectrum multiplied by `s`.
    pub fn scaled(&self, s: f64) -> Self {
        Self { scale: self.scale * s, rsp: self.rsp, illuminant: self.illuminant.clone() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sigmoid_and_inverse_agree() {
        for v in [1e-9, 0.01, 0.25, 0.5, 0.75, 0.99, 1.0 - 1e-9] {
            assert!((sigmoid(inverse_sigmoid(v)) - v).abs() < 1e-12, "{v}");
        }
        assert_eq!(sigmoid(f64::INFINITY), 1.0);
        assert_eq!(sigmoid(f64::NEG_INFINITY), 0.0);
        assert_eq!(sigmoid(1e200), 1.0);
        assert_eq!(RgbSigmoid::constant(0.0).eval(500.0), 0.0);
        assert_eq!(RgbSigmoid::constant(1.0).eval(500.0), 1.0);
        assert_eq!(RgbSigmoid::constant(1.0).max_value(), 1.0);
    }

    #[test]
    fn normalized_coefficients_convert_to_nanometres() {
        let (a, b, c) = (-3.0, 2.5, 0.4);
        let s = RgbSigmoid::from_normalized(a, b, c);
        for l in [360.0, 455.5, 600.0, 830.0] {
            let u = (l - 360.0) / 470.0;
            let direct = sigmoid((a * u + b) * u + c);
            assert!((s.eval(l) - direct).abs() < 1e-12);
        }
    }

    #[test]
    fn max_value_finds_interior_peaks() {
        // A parabola peaking at 550 nm.
        let s = RgbSigmoid { c0: -1e-4, c1: 0.11, c2: -30.0 };
        let brute = (360..=830).map(|l| s.eval(f64::from(l))).fold(0.0, f64::max);
        assert!((s.max_value() - brute).abs() < 1e-12);
        assert!((s.max_value() - s.eval(550.0)).abs() < 1e-15);
    }
}

//! The spectrum kinds a scene can describe.

use std::sync::Arc;

use crate::blackbody::Blackbody;
use crate::rgb_uplift::{RgbAlbedoSpectrum, RgbIlluminantSpectrum, RgbUnboundedSpectrum};
use crate::sampled::{SampledSpectrum, SampledWavelengths, N_WAVELENGTHS};
use crate::{check_finite, SpectrumError};

/// A tabulated spectrum, linearly interpolated between its samples and zero outside them.
#[derive(Clone, Debug, PartialEq)]
pub struct PiecewiseLinear {
    lambdas: Vec<f64>,
    values: Vec<f64>,
    /// The spacing, when the wavelengths form a regular grid (most tables): lookups then index directly.
    step: Option<f64>,
}

impl PiecewiseLinear {
    /// Builds a table from wavelengths (nm, strictly increasing) and values (finite).
    pub fn new(lambdas: Vec<f64>, values: Vec<f64>) -> Result<Self, SpectrumError> {
        if lambdas.len() != values.len() {
            return Err(SpectrumError::BadTable(format!("{} wavelengths but {} values", lambdas.len(), values.len())));
        }
        if lambdas.is_empty() {
            return Err(SpectrumError::BadTable("no samples".into()));
        }
        for (&l, &v) in lambdas.iter().zip(&values) {
            check_finite("wavelength", l)?;
            check_finite("spectrum value", v)?;
        }
        if let Some(w) = lambdas.windows(2).find(|w| w[1] <= w[0]) {
            return Err(SpectrumError::BadTable(format!(
                "wavelengths must increase strictly, but {} is followed by {}",
                w[0], w[1]
            )));
        }
        let step = regular_step(&lambdas);
        Ok(Self { lambdas, values, step })
    }

    /// Builds a table from interleaved `λ₀, v₀, λ₁, v₁, …` pairs, as pbrt-v4 writes inline spectra.
    pub fn from_interleaved(pairs: &[f64]) -> Result<Self, SpectrumError> {
        if !pairs.len().is_multiple_of(2) {
            return Err(SpectrumError::BadTable(format!(
                "interleaved wavelength/value list has odd length {}",
                pairs.len()
            )));
        }
        let (l, v) = pairs.chunks(2).map(|c| (c[0], c[1])).unzip();
        Self::new(l, v)
    }

    /// Wavelengths of the samples, nm.
    pub fn lambdas(&self) -> &[f64] {
        &self.lambdas
    }

    /// Values of the samples.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// Value at `lambda_nm`: linear interpolation inside the table, 0 outside it.
    pub fn eval(&self, lambda_nm: f64) -> f64 {
        let n = self.lambdas.len();
        if !(lambda_nm >= self.lambdas[0] && lambda_nm <= self.lambdas[n - 1]) {
            return 0.0;
        }
        if n == 1 {
            return self.values[0];
        }
        // The segment [λᵢ, λᵢ₊₁] holding λ: direct on a regular grid, else by binary search.
        let i = match self.step {
            Some(step) => (((lambda_nm - self.lambdas[0]) / step) as usize).min(n - 2),
            None => self.lambdas.partition_point(|&l| l <= lambda_nm).clamp(1, n - 1) - 1,
        };
        let t = (lambda_nm - self.lambdas[i]) / (self.lambdas[i + 1] - self.lambdas[i]);
        self.values[i] + t * (self.values[i + 1] - self.values[i])
    }

    /// The same table with every value multiplied by `s`.
    pub fn scaled(&self, s: f64) -> Self {
        Self { lambdas: self.lambdas.clone(), values: self.values.iter().map(|v| v * s).collect(), step: self.step }
    }

    /// Largest value.
    pub fn max_value(&self) -> f64 {
        self.values.iter().copied().fold(f64::NEG_INFINITY, f64::max)
    }
}

/// The common spacing of `lambdas` if they are a regular grid (to 1e-9 relative), else `None`.
fn regular_step(lambdas: &[f64]) -> Option<f64> {
    if lambdas.len() < 3 {
        return None;
    }
    let step = (lambdas[lambdas.len() - 1] - lambdas[0]) / (lambdas.len() - 1) as f64;
    let regular = lambdas
        .iter()
        .enumerate()
        .all(|(i, &l)| (l - (lambdas[0] + step * i as f64)).abs() <= 1e-9 * step.max(l.abs()));
    regular.then_some(step)
}

/// A spectral distribution: reflectance, index of refraction, emission, … as a function of wavelength in nm.
#[derive(Clone, Debug, PartialEq)]
pub enum Spectrum {
    /// The same value at every wavelength.
    Constant(f64),
    /// A table, linearly interpolated.
    PiecewiseLinear(Arc<PiecewiseLinear>),
    /// Planck's law, scaled.
    Blackbody(Blackbody),
    /// A reflectance given as a linear sRGB colour in [0, 1]³ (Jakob & Hanika 2019 sigmoid polynomial).
    RgbAlbedo(RgbAlbedoSpectrum),
    /// Any non-negative linear sRGB colour: a scale times a sigmoid polynomial.
    RgbUnbounded(RgbUnboundedSpectrum),
    /// Emission given as a non-negative linear sRGB colour: an unbounded RGB spectrum times normalised D65.
    RgbIlluminant(RgbIlluminantSpectrum),
}

impl Spectrum {
    /// A tabulated spectrum from wavelengths (nm) and values.
    pub fn piecewise_linear(lambdas: Vec<f64>, values: Vec<f64>) -> Result<Self, SpectrumError> {
        Ok(Self::PiecewiseLinear(Arc::new(PiecewiseLinear::new(lambdas, values)?)))
    }

    /// A blackbody at `kelvin`, normalised to peak 1 as pbrt-v4 does. Rejects non-finite or non-positive temperatures.
    pub fn blackbody(kelvin: f64) -> Result<Self, SpectrumError> {
        check_finite("temperature", kelvin)?;
        if kelvin <= 0.0 {
            return Err(SpectrumError::OutOfRange {
                name: "temperature",
                value: kelvin,
                expected: "a temperature in kelvin above 0",
            });
        }
        Ok(Self::Blackbody(Blackbody::normalized(kelvin)))
    }

    /// Value at `lambda_nm`.
    pub fn eval(&self, lambda_nm: f64) -> f64 {
        match self {
            Spectrum::Constant(c) => *c,
            Spectrum::PiecewiseLinear(t) => t.eval(lambda_nm),
            Spectrum::Blackbody(b) => b.eval(lambda_nm),
            Spectrum::RgbAlbedo(r) => r.eval(lambda_nm),
            Spectrum::RgbUnbounded(r) => r.eval(lambda_nm),
            Spectrum::RgbIlluminant(r) => r.eval(lambda_nm),
        }
    }

    /// Values at the wavelengths of `wl`.
    pub fn sample(&self, wl: &SampledWavelengths) -> SampledSpectrum {
        let mut s = SampledSpectrum::zero();
        for i in 0..N_WAVELENGTHS {
            s[i] = self.eval(wl.lambda(i) as f64) as f32;
        }
        s
    }

    /// The spectrum multiplied by `s`.
    pub fn scaled(&self, s: f64) -> Spectrum {
        match self {
            Spectrum::Constant(c) => Spectrum::Constant(c * s),
            Spectrum::PiecewiseLinear(t) => Spectrum::PiecewiseLinear(Arc::new(t.scaled(s))),
            Spectrum::Blackbody(b) => Spectrum::Blackbody(Blackbody { scale: b.scale * s, ..*b }),
            // A scaled albedo may leave [0, 1], so it becomes an unbounded RGB spectrum.
            Spectrum::RgbAlbedo(r) => Spectrum::RgbUnbounded(r.scaled(s)),
            Spectrum::RgbUnbounded(r) => Spectrum::RgbUnbounded(r.scaled(s)),
            Spectrum::RgbIlluminant(r) => Spectrum::RgbIlluminant(r.scaled(s)),
        }
    }

    /// Largest value over the transport range 360–830 nm (sampled at 1 nm for analytic kinds).
    pub fn max_value(&self) -> f64 {
        match self {
            Spectrum::Constant(c) => *c,
            Spectrum::PiecewiseLinear(t) => t.max_value(),
            Spectrum::RgbAlbedo(r) => r.max_value(),
            Spectrum::RgbUnbounded(r) => r.max_value(),
            Spectrum::RgbIlluminant(r) => r.max_value(),
            _ => (360..=830).map(|l| self.eval(l as f64)).fold(f64::NEG_INFINITY, f64::max),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn piecewise_linear_interpolates_and_is_zero_outside() {
        let s = PiecewiseLinear::new(vec![400.0, 500.0, 600.0], vec![1.0, 3.0, 2.0]).unwrap();
        assert_eq!(s.eval(400.0), 1.0);
        assert_eq!(s.eval(450.0), 2.0);
        assert_eq!(s.eval(500.0), 3.0);
        assert_eq!(s.eval(575.0), 2.25);
        assert_eq!(s.eval(600.0), 2.0);
        assert_eq!(s.eval(399.9), 0.0);
        assert_eq!(s.eval(600.1), 0.0);
        assert_eq!(s.eval(f64::NAN), 0.0);
    }

    #[test]
    fn regular_grids_index_directly_and_agree_with_binary_search() {
        let l: Vec<f64> = (0..=94).map(|i| 360.0 + 5.0 * i as f64).collect();
        let v: Vec<f64> = l.iter().map(|x| (x / 37.0).sin()).collect();
        let regular = PiecewiseLinear::new(l.clone(), v.clone()).unwrap();
        assert!(regular.step.is_some());
        let irregular = PiecewiseLinear { step: None, ..regular.clone() };
        for k in 0..=4700 {
            let x = 360.0 + k as f64 * 0.1;
            assert!((regular.eval(x) - irregular.eval(x)).abs() < 1e-12, "{x}");
        }
        assert!(PiecewiseLinear::new(vec![400.0, 410.0, 430.0], vec![1.0; 3]).unwrap().step.is_none());
    }

    #[test]
    fn bad_tables_are_rejected_with_reasons() {
        assert!(matches!(PiecewiseLinear::new(vec![400.0], vec![]), Err(SpectrumError::BadTable(_))));
        assert!(matches!(PiecewiseLinear::new(vec![500.0, 400.0], vec![1.0, 1.0]), Err(SpectrumError::BadTable(_))));
        assert!(matches!(
            PiecewiseLinear::new(vec![400.0, 500.0], vec![1.0, f64::NAN]),
            Err(SpectrumError::NotFinite { name: "spectrum value", .. })
        ));
        assert!(PiecewiseLinear::from_interleaved(&[400.0, 1.0, 500.0]).is_err());
        assert!(matches!(Spectrum::blackbody(-5.0), Err(SpectrumError::OutOfRange { name: "temperature", .. })));
        assert!(matches!(Spectrum::blackbody(f64::NAN), Err(SpectrumError::NotFinite { .. })));
    }

    #[test]
    fn scaling_scales_every_kind() {
        let t = Spectrum::piecewise_linear(vec![400.0, 700.0], vec![1.0, 2.0]).unwrap();
        assert_eq!(t.scaled(3.0).eval(550.0), 4.5);
        let b = Spectrum::blackbody(5000.0).unwrap();
        assert!((b.scaled(2.0).eval(600.0) - 2.0 * b.eval(600.0)).abs() < 1e-12);
        assert_eq!(Spectrum::Constant(0.5).scaled(4.0).eval(123.0), 2.0);
    }
}

//! Planck's law for a blackbody emitter.

/// Planck's constant, J·s (exact, SI 2019).
pub const PLANCK_H: f64 = 6.626_070_15e-34;
/// Speed of light in vacuum, m/s (exact).
pub const SPEED_OF_LIGHT: f64 = 299_792_458.0;
/// Boltzmann's constant, J/K (exact, SI 2019).
pub const BOLTZMANN_K: f64 = 1.380_649e-23;
/// Wien's displacement constant b, m·K (CODATA 2018): λ_max = b / T.
pub const WIEN_B: f64 = 2.897_771_955e-3;

/// Spectral radiance of a blackbody at temperature `kelvin`, at wavelength `lambda_nm`, in W·sr⁻¹·m⁻²·m⁻¹.
///
/// Planck's law, B(λ, T) = 2hc² / λ⁵ / (exp(hc / (λ k T)) − 1). Returns 0 for non-positive temperatures.
pub fn planck(lambda_nm: f64, kelvin: f64) -> f64 {
    if kelvin <= 0.0 || lambda_nm <= 0.0 {
        return 0.0;
    }
    let l = lambda_nm * 1e-9;
    let c1 = 2.0 * PLANCK_H * SPEED_OF_LIGHT * SPEED_OF_LIGHT;
    let x = PLANCK_H * SPEED_OF_LIGHT / (l * BOLTZMANN_K * kelvin);
    c1 / (l.powi(5) * x.exp_m1())
}

/// Wavelength of peak emission of a blackbody, in nm (Wien's displacement law).
pub fn peak_wavelength_nm(kelvin: f64) -> f64 {
    WIEN_B / kelvin * 1e9
}

/// A blackbody emitter as a spectrum: `scale · B(λ, T)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Blackbody {
    /// Temperature in kelvin.
    pub temperature: f64,
    /// Factor applied to Planck's law.
    pub scale: f64,
}

impl Blackbody {
    /// Blackbody in absolute units (W·sr⁻¹·m⁻²·m⁻¹).
    pub fn absolute(temperature: f64) -> Self {
        Self { temperature, scale: 1.0 }
    }

    /// Blackbody normalised so that its peak (at Wien's λ_max) is 1, as pbrt-v4's `BlackbodySpectrum` is.
    pub fn normalized(temperature: f64) -> Self {
        let peak = planck(peak_wavelength_nm(temperature), temperature);
        Self { temperature, scale: if peak > 0.0 { 1.0 / peak } else { 0.0 } }
    }

    /// Value at `lambda_nm`.
    pub fn eval(&self, lambda_nm: f64) -> f64 {
        self.scale * planck(lambda_nm, self.temperature)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normalized_blackbody_peaks_at_one_at_wien_wavelength() {
        for t in [2856.0, 5000.0, 6500.0, 10000.0] {
            let b = Blackbody::normalized(t);
            let peak = peak_wavelength_nm(t);
            assert!((b.eval(peak) - 1.0).abs() < 1e-12);
            assert!(b.eval(peak * 0.99) < 1.0 && b.eval(peak * 1.01) < 1.0);
        }
    }

    #[test]
    fn planck_matches_stefan_boltzmann_law() {
        // ∫ B dλ · π = σ T⁴ (σ = 5.670374419e-8 W m⁻² K⁻⁴); integrate 10 nm..100 µm in log space.
        let t = 3000.0;
        let n = 200_000;
        let (a, b) = (10.0f64.ln(), 100_000.0f64.ln());
        let mut sum = 0.0;
        for i in 0..n {
            let s = a + (b - a) * (i as f64 + 0.5) / n as f64;
            let l = s.exp();
            sum += planck(l, t) * l * 1e-9 * (b - a) / n as f64;
        }
        let sigma = 5.670_374_419e-8;
        let rel = (sum * std::f64::consts::PI / (sigma * t.powi(4)) - 1.0).abs();
        assert!(rel < 1e-4, "relative error {rel}");
    }
}

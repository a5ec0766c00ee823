//! CIE daylight (the D series) for any correlated colour temperature, and the white-balance illuminant of
//! pbrt-v4's `whitebalance` film parameter.

use crate::cmf::Observer;
use crate::spectrum::Spectrum;
use crate::{check_finite, tables, SpectrumError};

/// Lowest correlated colour temperature (K) for which the CIE defines a daylight illuminant (CIE 15:2004, 3.1).
pub const DAYLIGHT_CCT_MIN: f64 = 4000.0;
/// Highest correlated colour temperature (K) for which the CIE defines a daylight illuminant (CIE 15:2004, 3.1).
pub const DAYLIGHT_CCT_MAX: f64 = 25000.0;

/// Chromaticity (x_D, y_D) of CIE daylight at correlated colour temperature `cct` (K), by the daylight-locus
/// polynomials of CIE 15:2004, eqs. 3.3–3.4; meaningful for 4000–25000 K.
pub fn daylight_chromaticity(cct: f64) -> [f64; 2] {
    let t = cct;
    // CIE 15:2004 eq. 3.3: x_D as a cubic in 10³/T, with one set of coefficients up to 7000 K and another above.
    let x = if t <= 7000.0 {
        -4.6070e9 / t.powi(3) + 2.9678e6 / (t * t) + 0.09911e3 / t + 0.244063
    } else {
        -2.0064e9 / t.powi(3) + 1.9018e6 / (t * t) + 0.24748e3 / t + 0.237040
    };
    // CIE 15:2004 eq. 3.4: the daylight locus y_D = −3.000 x_D² + 2.870 x_D − 0.275.
    let y = -3.0 * x * x + 2.870 * x - 0.275;
    [x, y]
}

/// The relative spectral power distribution of CIE daylight at correlated colour temperature `cct` (K):
/// S(λ) = S₀(λ) + M₁ S₁(λ) + M₂ S₂(λ), tabulated at 5 nm from 300 to 830 nm and linearly interpolated.
///
/// The CIE defines it for 4000–25000 K; outside that range (or for a non-finite temperature) the parameter
/// `temperature` is reported out of range.
pub fn daylight(cct: f64) -> Result<Spectrum, SpectrumError> {
    check_finite("temperature", cct)?;
    if !(DAYLIGHT_CCT_MIN..=DAYLIGHT_CCT_MAX).contains(&cct) {
        return Err(SpectrumError::OutOfRange {
            name: "temperature",
            value: cct,
            expected: "a correlated colour temperature in [4000, 25000] K (CIE daylight)",
        });
    }
    let [x, y] = daylight_chromaticity(cct);
    // CIE 15:2004 eq. 3.6: the weights of the basis functions S₁ and S₂.
    let m = 0.0241 + 0.2562 * x - 0.7341 * y;
    let m1 = (-1.3515 - 1.7703 * x + 5.9114 * y) / m;
    let m2 = (0.0300 - 31.4424 * x + 30.0717 * y) / m;
    let t = tables::daylight_basis();
    let (s0, s1, s2) = (t.column("S0"), t.column("S1"), t.column("S2"));
    let values = (0..s0.len()).map(|i| s0[i] + m1 * s1[i] + m2 * s2[i]).collect();
    Spectrum::piecewise_linear(t.column("wavelength_nm"), values)
}

/// Ratio by which pbrt-v4 converts a nominal temperature into a correlated colour temperature: the ratio of the
/// second radiation constant c₂ as revised in 1968 (1.4388·10⁻² m·K) to its older value (1.4380·10⁻² m·K), the
/// change that moved D65's nominal 6500 K to 6504 K (CIE 15:2004, note to 3.1).
pub const C2_REVISION: f64 = 1.4388 / 1.4380;

/// The illuminant pbrt-v4 white-balances from for a `whitebalance` temperature `kelvin`: the temperature is scaled
/// by [`C2_REVISION`]; at or above 4000 K the result is CIE daylight at that CCT, below it (where CIE daylight is
/// undefined) a blackbody at that temperature. Errors name `whitebalance` for a non-finite or non-positive value
/// or one above the daylight range.
pub fn white_balance_illuminant(kelvin: f64) -> Result<Spectrum, SpectrumError> {
    let bad = |expected| SpectrumError::OutOfRange { name: "whitebalance", value: kelvin, expected };
    if !kelvin.is_finite() || kelvin <= 0.0 {
        return Err(bad("a colour temperature in kelvin above 0"));
    }
    let cct = kelvin * C2_REVISION;
    if cct > DAYLIGHT_CCT_MAX {
        return Err(bad("a colour temperature of at most 25000 K (the end of CIE daylight)"));
    }
    if cct < DAYLIGHT_CCT_MIN {
        Spectrum::blackbody(cct)
    } else {
        daylight(cct)
    }
}

/// Chromaticity (x, y) under the CIE 1931 observer of [`white_balance_illuminant`]`(kelvin)`.
pub fn white_balance_chromaticity(kelvin: f64) -> Result<[f64; 2], SpectrumError> {
    Ok(Observer::Cie1931.spectrum_to_xyz(&white_balance_illuminant(kelvin)?).chromaticity())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn daylight_locus_matches_colour_science() {
        // colour-science 0.4.7, colour.temperature.CCT_to_xy_CIE_D(5000·1.4388/1.4380) and (6500·1.4388/1.4380).
        for (t, xy) in [(5000.0, [0.345_659_45, 0.358_601_25]), (6500.0, [0.312_720_27, 0.329_125_28])] {
            let got = daylight_chromaticity(t * C2_REVISION);
            assert!((got[0] - xy[0]).abs() < 1e-7 && (got[1] - xy[1]).abs() < 1e-7, "{t} K: {got:?}");
        }
    }

    #[test]
    fn white_balance_illuminants_have_colour_science_chromaticities() {
        // colour-science 0.4.7: sd_to_XYZ (CIE 1931 2°, 'Integration', 360–830 nm at 1 nm) of
        // sd_CIE_illuminant_D_series at the scaled CCT for 5000 K and 6500 K, and of sd_blackbody(3201.78 K) for
        // 3200 K (below 4000 K pbrt-v4 uses a blackbody). colour-science interpolates the 5 nm basis with Sprague
        // polynomials and we linearly, hence the 2e-4 tolerance on the daylight cases; its Planck constants differ in
        // the last digits, hence 1e-5 on the blackbody.
        for (t, xy, tol) in [
            (5000.0, [0.345_684_22, 0.358_504_03], 2e-4),
            (6500.0, [0.312_726_88, 0.329_023_45], 2e-4),
            (3200.0, [0.423_247_86, 0.398_905_63], 1e-5),
        ] {
            let got = white_balance_chromaticity(t).unwrap();
            assert!((got[0] - xy[0]).abs() < tol && (got[1] - xy[1]).abs() < tol, "{t} K: {got:?}");
        }
        // Nominal 6500 K lands within 1e-3 of D65's tabulated chromaticity (0.3127, 0.3290).
        let d65 = white_balance_chromaticity(6500.0).unwrap();
        assert!((d65[0] - 0.3127).abs() < 1e-3 && (d65[1] - 0.3290).abs() < 1e-3);
    }

    #[test]
    fn bad_temperatures_are_errors_naming_the_parameter() {
        for t in [0.0, -5.0, f64::NAN, f64::INFINITY, 30000.0] {
            match white_balance_illuminant(t) {
                Err(SpectrumError::OutOfRange { name, .. }) => assert_eq!(name, "whitebalance"),
                other => panic!("{t}: {other:?}"),
            }
        }
        assert!(daylight(3000.0).is_err());
    }
}

//! Spectra and colour science for Prismatic.
//!
//! Everything here works in nanometres. The crate knows nothing of geometry or scenes: it holds the CIE observers,
//! the Stiles & Burch 1959 RGB colour matching functions and the CIE illuminants (embedded from CSV files copied
//! from the project's data set, see `data/SOURCES.md`), the spectrum kinds a scene can name, sampled spectra as the
//! integrator carries them, tabulated 1D and 2D distributions (the recipe of seed 000), the three wavelength
//! strategies (`rgb`, `cmf`, `hero`) and the conversions from spectra through CIE XYZ to output colour spaces.
//!
//! ```
//! use spectral::{named, Observer, RgbColorSpace};
//!
//! // The chromaticity of CIE illuminant D65 under the 1931 observer, and its colour in linear sRGB.
//! let d65 = named::illuminant("stdillum-D65").unwrap();
//! let xyz = Observer::Cie1931.spectrum_to_xyz(&d65);
//! let xy = xyz.chromaticity();
//! assert_eq!(format!("{:.4} {:.4}", xy[0], xy[1]), "0.3127 0.3290");
//! let rgb = RgbColorSpace::srgb().to_rgb(xyz);
//! assert!(rgb.iter().all(|c| (c - 1.0).abs() < 1e-3));
//! ```

#![forbid(unsafe_code)]

pub mod blackbody;
pub mod cmf;
pub mod color;
pub mod daylight;
pub mod distribution;
pub mod lab;
pub mod named;
pub mod oklab;
pub mod rgb_uplift;
pub mod sampled;
pub mod sensor;
pub mod spectrum;
mod tables;
pub mod wavelengths;

pub use cmf::Observer;
pub use color::{RgbColorSpace, Xyz};
pub use distribution::{Distribution1D, Distribution2D};
pub use sampled::{SampledSpectrum, SampledWavelengths, N_WAVELENGTHS};
pub use spectrum::{PiecewiseLinear, Spectrum};
pub use wavelengths::{WavelengthSampler, WavelengthStrategy};

/// Shortest wavelength light transport considers, in nm (the CIE observers' tables start here).
pub const LAMBDA_MIN: f64 = 360.0;
/// Longest wavelength light transport considers, in nm (the CIE observers' tables end here).
pub const LAMBDA_MAX: f64 = 830.0;

/// Errors from building spectra and distributions out of user-supplied numbers.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SpectrumError {
    /// A value that must be finite was NaN or infinite.
    #[error("{name} must be finite, got {value}")]
    NotFinite {
        /// The parameter's name.
        name: &'static str,
        /// The offending value.
        value: f64,
    },
    /// A value lies outside the range the parameter allows.
    #[error("{name} = {value} is out of range: {expected}")]
    OutOfRange {
        /// The parameter's name.
        name: &'static str,
        /// The offending value.
        value: f64,
        /// What the parameter allows, in words.
        expected: &'static str,
    },
    /// A tabulated spectrum was malformed (too short, unsorted wavelengths, length mismatch).
    #[error("invalid tabulated spectrum: {0}")]
    BadTable(String),
    /// No spectrum has that name.
    #[error("unknown spectrum name '{0}'")]
    UnknownName(String),
}

/// Checks that `value` is finite, naming the parameter otherwise.
pub fn check_finite(name: &'static str, value: f64) -> Result<f64, SpectrumError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(SpectrumError::NotFinite { name, value })
    }
}

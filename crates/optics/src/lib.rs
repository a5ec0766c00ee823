//! Optics for Prismatic: how light meets matter at a smooth interface, wavelength by wavelength.
//!
//! - [`ior`]: index-of-refraction models, all functions of the wavelength in nm — constant, Sellmeier, Cauchy, the
//!   two-term Cauchy fit to an Abbe number, tabulated real and complex (metal) indices, and the complex index of a
//!   material given by ε, μ and σ (seed 000, Frisvad "Dispersion and Spectral Rendering").
//! - [`catalogue`]: the built-in glasses, liquids, crystals and metals (embedded CSV data, `data/SOURCES.md`),
//!   looked up by name, plus pbrt-v4's named `glass-*` and `metal-*` spectra and the water absorption table.
//! - [`fresnel`]: exact Fresnel reflectance for dielectrics and conductors, Snell refraction of direction vectors and
//!   the critical and Brewster angles.
//! - [`mie`]: Lorenz–Mie scattering by spheres (efficiencies, amplitudes, exactly sampleable tabulated phase
//!   functions for one radius or a log-normal distribution, a spectral table for participating media) and the
//!   Descartes rainbow angles.
//! - [`lens`]: lens prescriptions (pbrt-v4's lens files, with glass by catalogue name or Abbe pair and coatings per
//!   surface).
//! - [`thinfilm`]: reflectance and transmittance of stacks of thin layers (interference) by the characteristic-matrix
//!   method, per wavelength, angle and polarisation.
//! - [`complex`]: the small complex-number type the above need.
//!
//! Everything is `f64` except [`reflect`] and [`refract`], which are generic over the float type so the renderer's
//! f32 directions use the same code; wavelengths are in nanometres in vacuo throughout the public API.
//!
//! ```
//! use optics::{catalogue, fresnel_dielectric, LAMBDA_D_NM};
//!
//! // Dense flint N-SF11 at the helium d line, and its reflectance at normal incidence from air.
//! let sf11 = catalogue::lookup("N-SF11").unwrap();
//! let n = sf11.ior.n(LAMBDA_D_NM);
//! assert!((n - 1.78472).abs() < 1e-5);
//! let r = fresnel_dielectric(1.0, n);
//! assert!((r - ((n - 1.0) / (n + 1.0)).powi(2)).abs() < 1e-12);
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod catalogue;
pub mod complex;
mod error;
mod fft;
pub mod fresnel;
pub mod ior;
pub mod lens;
pub mod mie;
pub mod thinfilm;

pub use catalogue::{lookup, named_spectrum, CatalogueEntry, Category, DispersionData};
pub use complex::Complex;
pub use error::OpticsError;
pub use fresnel::{
    brewster_angle, critical_angle, fresnel_complex, fresnel_complex_sp, fresnel_conductor, fresnel_dielectric,
    fresnel_dielectric_p, fresnel_dielectric_s, fresnel_dielectric_transmittance, prism_minimum_deviation, reflect,
    refract, refract_with_eta, snell_sin_t, Float,
};
pub use ior::{
    Cauchy, ConstantIor, Ior, MaterialConstants, Sellmeier, TabulatedComplexIor, TabulatedIor, LAMBDA_C_NM,
    LAMBDA_D_NM, LAMBDA_F_NM,
};
pub use lens::{CoatingLayerSpec, LensFileError, LensMedium, LensPrescription, LensRay, LensSurface, StopMask};
pub use mie::{
    descartes_rainbow_angle, mie_amplitudes, mie_efficiencies, MieCoefficients, MieEfficiencies, MiePhaseTable,
    MieSpectralTable,
};
pub use thinfilm::{film_stack, film_stack_reversed, FilmLayer, FilmResponse};

//! Rendering for Prismatic: from a scene description to radiance in a film.
//!
//! Knows nothing of file formats: it takes the plain scene description of the `scene` crate (which the `pbrt`
//! crate reads from pbrt-v4 files) and writes into a `film::Film`. What a caller does with it:
//!
//! - **Build a scene**: [`build_scene`] turns a description into a [`BuiltScene`]: the render-ready
//!   [`RenderScene`], the film to render into, the samples per pixel, the [`Integrator`] the scene asks for, and
//!   warnings (unused parameters, ignored features) with their file, line and column. [`BuildOptions`] overrides the
//!   scene's resolution, samples, output and crop, as the command line does.
//! - **Choose and configure an integrator**: [`Integrator`] is one of [`PathIntegrator`], [`VolPathIntegrator`],
//!   [`LightPathIntegrator`], [`BdptIntegrator`] and [`SppmIntegrator`], whose public fields are their pbrt-v4
//!   parameters; replace or edit the one the scene chose. [`Integrator::needs`] says what it requires of the scene
//!   and what a pass is ([`PassUnit`]: a sample per pixel, or a photon-mapping iteration).
//! - **Run passes into a film**: [`Integrator::begin`] starts a [`RenderJob`]; [`RenderJob::run`] renders any
//!   range of passes (their indices seed the random numbers, so running `0..4` then `4..8` is exactly `0..8`, on
//!   any number of threads), [`RenderJob::finish`] completes the film. [`RenderJob::save_state`] and
//!   [`RenderJob::restore_state`] with the film's own state make checkpoints.
//! - **Read statistics**: every run returns [`RenderStats`] (samples and rays), and `progress` hears the pixel
//!   samples done as rows complete.
//! - **Cancel**: a render stops between passes: run one pass (or a few) at a time and stop calling
//!   [`RenderJob::run`] when asked to; the film then holds every finished pass, ready to [`RenderJob::finish`] and
//!   write (the command line stops this way on a signal).
//! - **Errors**: every fallible public function returns a [`RenderError`]; scene errors keep their
//!   `file:line:column`.
//!
//! ```
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let text = r#"LookAt 0 0 -4  0 0 0  0 1 0
//!     Camera "perspective" "float fov" 40
//!     Film "rgb" "integer xresolution" 16 "integer yresolution" 12
//!     WorldBegin
//!     LightSource "infinite" "rgb L" [ 1 1 1 ]
//!     Material "diffuse" "rgb reflectance" [ 0.5 0.5 0.5 ]
//!     Shape "sphere" "float radius" 1"#;
//! let desc = pbrt::parse_str(text, std::path::Path::new("example.pbrt"))?;
//! let built = render::build_scene(&desc, &render::BuildOptions::default())?;
//! let mut film = film::Film::new(built.film.clone())?;
//! let mut job = built.integrator.begin(&built.scene, &film, 0)?;
//! let cancelled = || false; // e.g. a flag a signal handler or a user interface sets
//! let mut stats = render::RenderStats::default();
//! for pass in 0..4 {
//!     if cancelled() {
//!         break;
//!     }
//!     stats.samples += job.run(&mut film, pass..pass + 1, &|_| {}).samples;
//! }
//! job.finish(&mut film);
//! assert_eq!(stats.samples, 4 * 16 * 12);
//! // The sky seen directly (Y = 1, up to the noise of 16 wavelengths), and a diffuse sphere of albedo 0.5 under
//! // it, which sees only the sky (Y = 0.5, up to the noise of 4 samples).
//! assert!((film.pixel_xyz(0, 0).y - 1.0).abs() < 0.03);
//! assert!((film.pixel_xyz(8, 6).y - 0.5).abs() < 0.1);
//! # Ok(())
//! # }
//! ```
//!
//! Inside, one file or folder per layer, none of them public: `builder` (description → scene, one file per
//! directive family), `scene` (the scene and its geometry), `integrator` (one file per algorithm and the files they
//! share), the scattering models (`bxdf`, `layered`, `microfacet`, `measured`), what builds them at a hit
//! (`material`, `texture`, `bump`, `footprint`), `light`, `medium`, `camera`, `sampler` and `sampling`.
//! ARCHITECTURE.md draws them.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod builder;
mod bump;
mod bxdf;
mod camera;
mod coating;
mod error;
mod footprint;
mod integrator;
mod layered;
mod light;
mod material;
mod measured;
mod medium;
mod metallic_roughness;
mod microfacet;
mod sampler;
mod sampling;
mod scene;
#[cfg(test)]
mod tests;
mod texture;

pub use builder::{build_scene, build_scene_reusing, BuildOptions, BuiltScene};
pub use camera::{Camera, FOCUS_WAVELENGTH_NM};
pub use error::RenderError;
pub use integrator::{
    BdptIntegrator, Integrator, LightPathIntegrator, Needs, PassSizes, PassUnit, PathIntegrator, RenderJob,
    RenderStats, SppmIntegrator, VolPathIntegrator,
};
pub use scene::RenderScene;

/// The scattering models and the tables behind them, and MIP maps, for the crate's own benchmarks (`benches/bsdf.rs`
/// and `benches/texture.rs`, which turn the `internals` feature on through a dev-dependency on the crate itself),
/// the command's tests that write RGL tensor files, and the fuzz campaign's measured-BRDF target. Not part of the API: nothing here is kept stable.
#[cfg(feature = "internals")]
#[doc(hidden)]
pub mod internals {
    pub use crate::bxdf::{Bxdf, TransportMode};
    pub use crate::coating::CoatingAt;
    pub use crate::layered::Layered;
    pub use crate::measured::tensor::TensorFile;
    pub use crate::measured::warp::Warp2D;
    pub use crate::measured::MeasuredBrdf;
    pub use crate::microfacet::TrowbridgeReitz;
    pub use crate::texture::{MipMap, RgbImage, WrapMode};
}

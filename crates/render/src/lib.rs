//! Rendering for Prismatic: from a scene description to radiance in a film.
//!
//! Knows nothing of file formats: it consumes the plain scene description of the `scene` crate and writes into a
//! `film::Film`. The road through it, top to bottom:
//!
//! - [`build_scene`] ([`builder`], one file per directive family) turns a description into a [`RenderScene`]
//!   (geometry behind the [`Geometry`] trait, materials, lights with a power-based light sampler, media, camera)
//!   and reads the [`Integrator`].
//! - [`Integrator`] ([`integrator`], one file per algorithm: `path`, `lightpath`, `bdpt`, `sppm`) starts a
//!   [`RenderJob`] that renders ranges of passes into the film and finishes into it.
//! - Underneath: [`bxdf`], [`layered`], [`microfacet`] and [`measured`] (scattering models; RGL tensor files), [`material`], [`texture`] and
//!   [`bump`] (what builds them at a hit), [`light`], [`camera`], [`sampler`] (the per-sample random numbers) and
//!   [`sampling`] (warps and MIS heuristics).
//! - Every fallible public function returns a [`RenderError`].
//!
//! ```no_run
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! # let desc: scene::SceneDescription = unimplemented!();
//! let built = render::build_scene(&desc, &render::BuildOptions::default())?;
//! let mut film = film::Film::new(built.film.clone())?;
//! built.integrator.render(&built.scene, &mut film, 0..built.spp, 0, &|_| {})?;
//! film::write_image(&film, &built.film.filename)?;
//! # Ok(())
//! # }
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod builder;
pub mod bump;
pub mod bxdf;
pub mod camera;
mod error;
pub mod footprint;
pub mod integrator;
pub mod layered;
pub mod light;
pub mod material;
pub mod measured;
pub mod medium;
pub mod microfacet;
pub mod sampler;
pub mod sampling;
pub mod scene;
pub mod texture;

pub use builder::{build_scene, BuildOptions, BuiltScene};
pub use error::RenderError;
pub use integrator::{Integrate, Integrator, Needs, PassUnit, RenderJob, RenderStats};
pub use scene::{Geometry, RenderScene, SceneGeometry, SurfaceHit};

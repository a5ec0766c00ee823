//! Rendering for Prismatic: samplers, BSDFs, lights, cameras and integrators over a render-ready scene.
//!
//! Knows nothing of file formats: it consumes the plain scene description and writes into a film.

pub mod builder;
pub mod bxdf;
pub mod camera;
pub mod integrator;
pub mod layered;
pub mod light;
pub mod material;
pub mod microfacet;
pub mod sampler;
pub mod sampling;
pub mod scene;
pub mod texture;

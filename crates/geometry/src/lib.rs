//! Geometry for Prismatic: vectors (glam), transforms, rays, shapes, intersection and acceleration structures.
//!
//! Knows nothing of materials, spectra or scene files.

pub mod transform;

pub use glam::{DMat4, DVec3, Vec2, Vec3, Vec3A};
pub use transform::Transform;

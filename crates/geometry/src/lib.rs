//! Geometry for Prismatic: vectors (glam), transforms, rays, shapes, intersection and acceleration structures.
//!
//! Knows nothing of materials, spectra or scene files. Render-time geometry is f32; transforms are f64.
//!
//! - [`ray`]: [`Ray`], floating-point error bounds and robust ray spawning ([`spawn_ray`], [`spawn_ray_to`]).
//! - [`mesh`]: [`TriangleMesh`] and [`BilinearMesh`] in render space from object-space [`MeshData`] and
//!   [`BilinearMeshData`] (one [`IndexedMesh`] type with one validation for both); PLY loading ([`ply`]), Loop
//!   subdivision ([`subdiv`]); gzip-compressed input files ([`gzip`]).
//! - [`bilinear`]: [`BilinearMesh`], bilinear patches intersected exactly (Reshetov 2019), and their sampling.
//! - [`shapes`]: [`Shape`], which answers intersection, surface-geometry and sampling queries ([`ShapeSample`]) for
//!   every kind of shape ([`Sphere`], [`Disk`], triangles, bilinear patches), one file per kind.
//! - [`accel`]: the [`Accel`] trait and [`GeometryScene`], a two-level BVH (8-wide BVHs collapsed from `obvhs`'s
//!   binary ones) with instancing.
//! - [`animated`]: [`AnimatedTransform`], transforms that move during the shutter (pbrt-v4's decomposition into
//!   translation, rotation and stretch), and the bounds of what they move.

#![deny(unsafe_code)]
#![warn(missing_docs)]

pub mod accel;
pub mod animated;
pub mod bilinear;
pub mod bounds;
mod collapse;
mod error;
pub mod gzip;
mod huge_pages;
pub mod mesh;
pub mod ply;
pub mod ray;
pub mod shapes;
mod simd;
pub mod subdiv;
pub mod transform;
mod wide;

/// Uniform floats in [0, 1) from a 32-bit linear congruential generator (Numerical Recipes' constants) seeded with
/// `seed`: reproducible random inputs for the crate's tests.
#[cfg(test)]
pub(crate) fn test_floats(seed: u32) -> impl FnMut() -> f32 {
    let mut state = seed;
    move || {
        state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (state >> 8) as f32 / (1u32 << 24) as f32
    }
}

pub use accel::{Accel, GeometryScene, Hit, Instance, MovingInstance, Object, Shape};
pub use animated::AnimatedTransform;
pub use bilinear::BilinearMesh;
pub use bounds::Bounds3;
pub use error::GeometryError;
pub use glam::{DMat4, DVec3, Vec2, Vec3, Vec3A};
pub use huge_pages::LargeArray;
pub use mesh::{BilinearMeshData, IndexedMesh, IndexedMeshData, MeshData, TriangleMesh};
pub use ray::{offset_ray_origin, spawn_ray, spawn_ray_to, spawn_ray_to_point, Ray, SurfacePoint};
pub use shapes::{Disk, PointSample, ShapeSample, Sphere, SurfaceDerivatives};
pub use transform::Transform;

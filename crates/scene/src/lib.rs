//! The plain scene description of Prismatic: what a scene file says, as data, before anything is built to render.
//!
//! A parser (the `pbrt` crate for pbrt-v4 files) fills a [`SceneDescription`]: the camera, film, sampler,
//! integrator and filter as [`Entity`]s (a type name such as `"perspective"` plus a [`ParamSet`]), and lists of
//! materials, textures, lights, media, shapes, object definitions and instances, each with its transform and the
//! [`Loc`] (file, line, column) where it was written. Nothing here knows how to render: the renderer reads the
//! parameters it understands through the typed getters of [`ParamSet`], which mark them used, and reports the rest
//! with [`ParamSet::unused`] (or [`SceneDescription::unused_parameters`]).
//!
//! Space conventions: "render space" is world space. Every `render_from_*` transform maps the entity's own space to
//! world space; [`CameraEntity::camera_from_world`] maps world space to pbrt's left-handed camera space (camera at
//! the origin looking down +z, +y up).
//!
//! ```
//! use scene::{Loc, Param, ParamSet, ParamType};
//! use std::path::Path;
//! use std::sync::Arc;
//!
//! let loc = Loc::new(Arc::from(Path::new("scene.pbrt")), 3, 7);
//! let mut radius = Param::new(ParamType::Float, "radius", loc);
//! radius.floats.push(2.5);
//! let params = ParamSet::from_params(vec![radius]);
//! assert_eq!(params.get_float("radius", 1.0).unwrap(), 2.5);
//! assert!(params.unused().is_empty());
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod entities;
mod loc;
mod params;

pub use entities::{
    CameraEntity, EmbeddedImage, Entity, InstanceUse, LightEntity, MaterialRef, MediumEntity, ObjectDefinition,
    OptionEntry, SceneDescription, ShapeEntity, TextureEntity, TextureValueType, TransformMotion,
};
pub use loc::{Diagnostic, Loc, SceneError};
pub use params::{FloatParam, Param, ParamSet, ParamType, SpectrumKind, SpectrumParam};
pub use spectral::Spectrum;

#[cfg(test)]
mod tests {
    #[test]
    fn the_description_can_be_shared_across_render_threads() {
        fn send_sync<T: Send + Sync>() {}
        send_sync::<crate::SceneDescription>();
    }
}

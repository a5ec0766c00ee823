//! The integrators, behind one interface.
//!
//! Every integrator is a file of this folder with a parameter struct that implements [`Integrate`]: it reads its
//! pbrt-v4 parameters, says what it needs ([`Needs`]), and starts a render ([`Integrate::begin`]) that is driven
//! the same way whatever the algorithm: [`RenderJob::run`] over ranges of samples (or photon-mapping iterations),
//! then [`RenderJob::finish`] into the film. The [`Integrator`] enum lists them, one line each.
//!
//! An integrator's file depends only on what they all share, never on another integrator's file: `transport` (the
//! tracer, rays and the media they travel through, the bounce's random numbers, the start of a bounce, BSDF
//! sampling, next-event estimation), `volume` (spectral MIS, tracking and shadow rays through media that scatter,
//! next-event estimation through them), `volume_paths` (the volumetric camera-path estimator), `light_walk` (the
//! walk of a light path), `manifold` (manifold next-event estimation) and `drive` (camera samples, first-hit
//! records, the camera-path driver, and the loops that write camera samples and splats into the film).

use std::ops::Range;

use film::Film;
use scene::{Entity, Loc, SceneError};

use crate::scene::RenderScene;
use crate::RenderError;

// The integrators, one file each (listed again in `integrators!` below).
pub mod bdpt;
pub mod lightpath;
pub mod path;
pub mod sppm;
pub mod volpath;

// What they share.
mod drive;
mod light_walk;
mod manifold;
mod transport;
mod volume;
mod volume_paths;

pub use drive::{PassSizes, RenderStats};

/// What an integrator needs of the scene and how its passes count.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Needs {
    /// Light paths must reach the camera (`Camera::sample_wi`): a perspective camera, not an orthographic one.
    pub camera_reachable_by_light: bool,
    /// What a pass of [`RenderJob::run`] is.
    pub unit: PassUnit,
}

/// What one pass of a render is.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PassUnit {
    /// One sample per pixel (the sampler's `pixelsamples`).
    #[default]
    Samples,
    /// One photon-mapping iteration over all pixels (the integrator's `iterations`).
    Iterations,
}

impl PassUnit {
    /// How the command line names a count of passes.
    pub fn name(self) -> &'static str {
        match self {
            PassUnit::Samples => "spp",
            PassUnit::Iterations => "iterations",
        }
    }
}

/// A render in progress: passes can be added until it is finished into the film.
pub trait RenderJob: Send {
    /// Renders passes `passes` (sample indices, or iterations; their indices seed the random numbers, so running
    /// `0..4` then `4..8` gives exactly the image of `0..8`) into `film`. `progress` hears the number of pixel
    /// samples done as work completes.
    fn run(&mut self, film: &mut Film, passes: Range<u32>, progress: &(dyn Fn(u64) + Sync)) -> RenderStats;

    /// Writes what the job keeps outside the film (photon mapping's progressive estimate) into `film`.
    fn finish(self: Box<Self>, film: &mut Film);

    /// What the job keeps between passes outside the film, as little-endian bytes (photon mapping's per-pixel
    /// statistics; empty for the integrators that keep nothing: their passes leave everything in the film, splats
    /// included). With the film's accumulators, it is what a checkpoint stores.
    fn save_state(&self) -> Vec<u8> {
        Vec::new()
    }

    /// Puts back a state saved by [`RenderJob::save_state`] of a job of the same integrator, scene and film, so that
    /// the next passes continue that render exactly. A state of another shape is an error, never a panic.
    fn restore_state(&mut self, state: &[u8]) -> Result<(), RenderError> {
        if state.is_empty() {
            Ok(())
        } else {
            let n = state.len();
            Err(RenderError::StateMismatch(format!(
                "this integrator keeps no state outside the film, but {n} bytes were given"
            )))
        }
    }
}

/// The parameters of an `Integrator` directive, with pbrt-v4's shared ones read the same way for all.
pub(crate) struct IntegratorParams<'a> {
    /// The directive.
    pub entity: &'a Entity,
    /// Whether some medium of the scene scatters or glows (`volpath` renders such media; `path`, like pbrt-v4's,
    /// ignores them).
    pub media_scatter: bool,
    /// Whether some medium of the scene glows (emits light).
    pub media_glow: bool,
    /// Where warnings go.
    pub warnings: &'a mut Vec<String>,
}

impl IntegratorParams<'_> {
    /// Warns, for integrator `name`, that the light of media that glow is not rendered (if the scene has any).
    pub fn warn_unrendered_media_glow(&mut self, name: &str) {
        if self.media_glow {
            self.warnings.push(format!(
                "{}: warning: integrator \"{name}\" does not render the light of media that glow (their scattering \
                 and absorption are rendered); use \"volpath\"",
                self.entity.loc
            ));
        }
    }

    /// Where parameter `name` was written, or the directive's location if it was not.
    pub fn loc_of(&self, name: &str) -> Loc {
        self.entity.params.loc_of(name, &self.entity.loc)
    }

    /// pbrt-v4's `maxdepth` (default 5; negative values are an error; capped at 1000).
    pub fn max_depth(&self) -> Result<u32, RenderError> {
        let md = self.entity.params.get_int("maxdepth", 5)?;
        if md < 0 {
            let message = format!("'maxdepth' must be non-negative, got {md}");
            return Err(SceneError::at(self.loc_of("maxdepth"), message).into());
        }
        Ok(md.min(1_000) as u32)
    }

    /// pbrt-v4's `"bool regularize"` of `path`, `volpath` and `bdpt` (default false).
    pub fn regularize(&self) -> Result<bool, RenderError> {
        Ok(self.entity.params.get_bool("regularize", false)?)
    }

    /// An error about this integrator's parameters, at its directive.
    pub fn error(&self, message: &str) -> RenderError {
        SceneError::at(self.entity.loc.clone(), message.to_owned()).into()
    }

    /// A float parameter in [0, `max`], or `default`.
    pub fn fraction(&self, name: &str, default: f64, max: f64) -> Result<f32, RenderError> {
        let v = self.entity.params.get_float(name, default)?;
        if !(0.0..=max).contains(&v) {
            let message = format!("'{name}' must lie in [0, {max}], got {v}");
            return Err(SceneError::at(self.loc_of(name), message).into());
        }
        Ok(v as f32)
    }

    /// A positive integer parameter (at most 2²⁰), or `default`.
    pub fn count(&self, name: &str, default: i64) -> Result<u32, RenderError> {
        Ok(self.entity.params.get_count(name, default, &self.entity.loc)? as u32)
    }
}

/// What every integrator implements.
pub(crate) trait Integrate: Sync + std::fmt::Debug {
    /// Reads the integrator's parameters, naming the bad one with its file, line and column.
    fn read(params: &mut IntegratorParams) -> Result<Self, RenderError>
    where
        Self: Sized;

    /// What it needs of the scene and how its passes count.
    fn needs(&self) -> Needs {
        Needs::default()
    }

    /// The number of passes the scene asks for when the integrator sets it itself (photon mapping's
    /// `iterations`); `None` to use the sampler's `pixelsamples`.
    fn passes(&self) -> Option<u32> {
        None
    }

    /// Starts a render of `scene` into films like `film`, with the render seed `seed`.
    fn begin<'a>(
        &'a self,
        scene: &'a RenderScene,
        film: &Film,
        seed: u32,
    ) -> Result<Box<dyn RenderJob + 'a>, RenderError>;
}

/// Declares, per integrator, the re-export of its type from its module, a variant of [`Integrator`], its pbrt-v4
/// name (and aliases), and the dispatch to [`Integrate`]. (The `mod` lines stay outside the macro so that
/// `cargo fmt` sees the files.)
macro_rules! integrators {
    ($($(#[$doc:meta])* $variant:ident($module:ident::$ty:ident) = $name:literal $(| $alias:literal)*;)*) => {
        $(pub use $module::$ty;)*

        /// The integrators the renderer can run, chosen by the scene's `Integrator` directive.
        #[derive(Clone, Copy, Debug)]
        pub enum Integrator {
            $($(#[$doc])* $variant($ty),)*
        }

        impl Integrator {
            /// The names a scene file can give (aliases included).
            pub const NAMES: &'static [&'static str] = &[$($name, $($alias,)*)*];

            /// The integrator's name in a scene file.
            pub fn name(&self) -> &'static str {
                match self {
                    $(Integrator::$variant(_) => $name,)*
                }
            }

            /// The integrator as its interface.
            pub(crate) fn get(&self) -> &dyn Integrate {
                match self {
                    $(Integrator::$variant(i) => i,)*
                }
            }

            fn read_named(params: &mut IntegratorParams) -> Option<Result<Self, RenderError>> {
                match params.entity.name.as_str() {
                    $($name $(| $alias)* => Some(<$ty>::read(params).map(Integrator::$variant)),)*
                    _ => None,
                }
            }
        }
    };
}

integrators! {
    /// Unidirectional path tracing from the camera; media only absorb (pbrt-v4's `path` ignores them).
    Path(path::PathIntegrator) = "path";
    /// Volumetric path tracing: media absorb, scatter and glow.
    VolPath(volpath::VolPathIntegrator) = "volpath";
    /// Particle tracing from the lights, splatted onto the film.
    LightPath(lightpath::LightPathIntegrator) = "lightpath";
    /// Bidirectional path tracing with MIS over all connection strategies.
    Bdpt(bdpt::BdptIntegrator) = "bdpt";
    /// Stochastic progressive photon mapping; a pass is one iteration.
    Sppm(sppm::SppmIntegrator) = "sppm";
}

impl Integrator {
    /// Reads an `Integrator` directive. An unknown name is an error that lists the supported ones.
    pub(crate) fn read(params: &mut IntegratorParams) -> Result<Self, RenderError> {
        Self::read_named(params).unwrap_or_else(|| {
            let e = params.entity;
            Err(SceneError::at(
                e.loc.clone(),
                format!("integrator '{}' is not supported; supported: {}", e.name, Self::NAMES.join(", ")),
            )
            .into())
        })
    }

    /// What the integrator needs of the scene (a camera light paths can reach) and how its passes count.
    pub fn needs(&self) -> Needs {
        self.get().needs()
    }

    /// The number of passes the scene asks for when the integrator sets it itself (photon mapping's
    /// `iterations`); `None` to use the sampler's `pixelsamples` ([`crate::BuiltScene::spp`] has either).
    pub fn passes(&self) -> Option<u32> {
        self.get().passes()
    }

    /// Starts a render of `scene` into films like `film` (its size, crop and wavelength strategy), with the render
    /// seed `seed`: a [`RenderJob`] to run passes with. An error if the film's filter cannot be sampled.
    pub fn begin<'a>(
        &'a self,
        scene: &'a RenderScene,
        film: &Film,
        seed: u32,
    ) -> Result<Box<dyn RenderJob + 'a>, RenderError> {
        self.get().begin(scene, film, seed)
    }

    /// Renders passes `passes` into `film` from start to finish: [`Integrator::begin`], one
    /// [`RenderJob::run`], [`RenderJob::finish`].
    pub fn render(
        &self,
        scene: &RenderScene,
        film: &mut Film,
        passes: Range<u32>,
        seed: u32,
        progress: &(dyn Fn(u64) + Sync),
    ) -> Result<RenderStats, RenderError> {
        let mut job = self.begin(scene, film, seed)?;
        let stats = job.run(film, passes, progress);
        job.finish(film);
        Ok(stats)
    }
}

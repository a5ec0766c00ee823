//! Volumetric path tracing (pbrt-v4's `volpath`): the null-scattering path integral of Miller, Georgiev & Jarosz
//! 2019 with delta tracking against a majorant for collisions, ratio tracking for the transmittance of shadow rays,
//! and one-sample MIS over the carried wavelengths (spectral MIS), so that a medium whose σ depends on wavelength
//! does not turn into colour noise. Next-event estimation is combined with BSDF and phase-function sampling by the
//! balance heuristic through the same rescaled path probabilities r_u and r_l (pbrt-v4 §14.2.3).
//!
//! `maxdepth` counts scattering events, in media and at surfaces; crossing a material-less boundary is not one.
//! Absorbing-only media attenuate in closed form (Beer–Lambert) instead of by tracking. The estimator is
//! `volume_paths::VolumePaths`, which the light tracer shares.

use film::Film;

use super::drive::CameraPaths;
use super::volume_paths::VolumePaths;
use super::{Integrate, IntegratorParams, RenderError, RenderJob};
use crate::scene::RenderScene;

/// The `volpath` integrator.
#[derive(Clone, Copy, Debug)]
pub struct VolPathIntegrator {
    /// Maximum number of scattering events, in media and at surfaces (pbrt's `maxdepth`, default 5).
    pub max_depth: u32,
    /// Whether a refraction through a smooth dispersive surface splits the path into one branch per carried
    /// wavelength (Prismatic's `"bool splitdispersion"`, default true, as `path`'s).
    pub split_dispersion: bool,
    /// pbrt-v4's `"bool regularize"` (default false), as `path`'s.
    pub regularize: bool,
    /// The share of scattering directions in Mie media drawn towards the scene's sun, by the phase function centred
    /// on it (Prismatic's `"float sunguide"`, in [0, 0.9], default 0.25; 0 draws by the phase function only).
    pub sun_guide: f32,
    /// Whether next-event estimation in homogeneous media is done at a forced collision on every segment
    /// (Prismatic's `"bool forcedcollisions"`; unset: in Mie media only, where it pays, BENCHMARKS.md "Rainbow
    /// efficiency").
    pub forced_collisions: Option<bool>,
}

impl Integrate for VolPathIntegrator {
    fn read(params: &mut IntegratorParams) -> Result<Self, RenderError> {
        Ok(VolPathIntegrator {
            max_depth: params.max_depth()?,
            split_dispersion: params.entity.params.get_bool("splitdispersion", true)?,
            regularize: params.regularize()?,
            sun_guide: params.fraction("sunguide", 0.25, 0.9)?,
            forced_collisions: match params.entity.params.contains("forcedcollisions") {
                true => Some(params.entity.params.get_bool("forcedcollisions", false)?),
                false => None,
            },
        })
    }

    fn begin<'a>(
        &'a self,
        scene: &'a RenderScene,
        film: &Film,
        seed: u32,
    ) -> Result<Box<dyn RenderJob + 'a>, RenderError> {
        let paths = VolumePaths {
            max_depth: self.max_depth,
            split_dispersion: self.split_dispersion,
            regularize: self.regularize,
            sun_guide: self.sun_guide,
            forced_collisions: self.forced_collisions,
        };
        Ok(Box::new(CameraPaths::new(paths, scene, film, seed)?))
    }
}

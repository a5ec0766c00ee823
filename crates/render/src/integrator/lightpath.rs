//! The `lightpath` integrator: particle tracing from the lights, each scattering vertex connected to the camera
//! and splatted onto the film (Arvo & Kirk 1990; Veach 1997 §4.A and §10.2; pbrt-v4's `LightPathIntegrator`).
//!
//! A light path starts at a light chosen by power, carries the flux weight `L·|cos θ| / (p_sel·pdf_pos·pdf_dir)`
//! through BSDF samples in importance mode, and at every non-specular vertex sends one shadow ray to a point on the
//! lens: the contribution `β·f·|cos|·We/pdf` lands at the raster position the connection hits. Light that reaches
//! the camera without scattering (emitters seen directly) is left to camera rays, which see it without noise; paths
//! whose last vertex before the camera is specular (a light seen in a mirror or through glass) cannot be connected
//! and are missing, as in every light tracer. Dispersion works as in the path tracer: a refraction through a
//! dispersive surface keeps only the wavelength it followed.

use std::ops::Range;

use film::Film;
use glam::Vec2;
use spectral::{SampledSpectrum, SampledWavelengths};

use super::drive::{render_splatting, CameraPaths, RenderStats, SampleRecords, LIGHT_PATH_SEED_SALT};
use super::light_walk::{walk_light_path, LightVertexAt, LightWalk};
use super::transport::{adjoint_cos, next_medium, ShadowRay, ShadowTarget, Tracer};
use super::volume::{shadow_transmittance, TrackingSeed};
use super::volume_paths::VolumePaths;
use super::{Integrate, IntegratorParams, Needs, RenderError, RenderJob};
use crate::bxdf::TransportMode;
use crate::sampler::{hash_words, Sampler};
use crate::scene::RenderScene;

/// The `lightpath` integrator.
#[derive(Clone, Copy, Debug)]
pub struct LightPathIntegrator {
    /// Maximum number of scattering events (pbrt's `maxdepth`, default 5), counting the vertex connected to the
    /// camera.
    pub max_depth: u32,
}

impl LightPathIntegrator {
    /// Traces one light path with `sampler` at the wavelengths `wl` (which a dispersive refraction reduces to one)
    /// and at `time`, and calls `splat(raster, contribution, wavelengths)` for every connection to the camera (where
    /// the camera is at that time). The contributions are per light path: the film divides their sum by the number
    /// of light paths per pixel.
    fn trace(
        &self,
        tracer: &mut Tracer,
        time: f32,
        wl: &mut SampledWavelengths,
        sampler: &mut Sampler,
        mut splat: impl FnMut(Vec2, SampledSpectrum, &SampledWavelengths),
    ) {
        let camera = tracer.scene.camera.at_time(time);
        let walk = LightWalk { max_depth: self.max_depth, media: true, time };
        walk_light_path(tracer, walk, wl, sampler, |v, wl, tracer| {
            let Some(cs) = camera.sample_wi(v.p(), v.u) else { return };
            // The scattering function towards the lens (with the adjoint shading-normal correction at surfaces),
            // and where the connection starts.
            let (f, origin, medium) = match v.at {
                LightVertexAt::Surface { hit, frame, bxdf } => {
                    let f = bxdf.f(frame.to_local(v.w_from), frame.to_local(cs.wi), TransportMode::Importance)
                        * adjoint_cos(v.w_from, cs.wi, hit.ns, hit.n);
                    (f, hit.spawn_origin(cs.wi), next_medium(hit, cs.wi, v.medium))
                }
                LightVertexAt::Medium { p, phase } => (phase.p(-v.w_from, cs.wi, wl), p, v.medium),
            };
            if f.is_black() {
                return;
            }
            let seed = TrackingSeed { salt: LIGHT_PATH_SEED_SALT ^ v.depth, u: v.u.x };
            let ray = ShadowRay { origin, target: ShadowTarget::Point(cs.p_lens), medium, time };
            let Some(tr) = shadow_transmittance(tracer, ray, wl, &v.mis, seed) else { return };
            // One strategy: the tracking decisions of the path and of the connection, averaged over the
            // wavelengths that could have led (spectral MIS).
            let c = v.beta * f * tr.t * (cs.we / cs.pdf) / v.mis.average(v.r * tr.r_l);
            splat(cs.raster, c, wl);
        });
    }
}

impl Integrate for LightPathIntegrator {
    fn read(params: &mut IntegratorParams) -> Result<Self, RenderError> {
        params.warn_unrendered_media_glow("lightpath");
        Ok(LightPathIntegrator { max_depth: params.max_depth()? })
    }

    fn needs(&self) -> Needs {
        Needs { camera_reachable_by_light: true, ..Needs::default() }
    }

    fn begin<'a>(
        &'a self,
        scene: &'a RenderScene,
        film: &Film,
        seed: u32,
    ) -> Result<Box<dyn RenderJob + 'a>, RenderError> {
        // Emitters seen directly (through media, and media that glow): a volumetric path tracer that stops before
        // the first scattering event.
        let direct = VolumePaths {
            max_depth: 0,
            split_dispersion: true,
            regularize: false,
            sun_guide: 0.0,
            forced_collisions: Some(false),
        };
        let camera = CameraPaths::new(direct, scene, film, seed)?;
        Ok(Box::new(LightPaths { integrator: self, camera }))
    }
}

/// A light-tracing render: camera rays for directly visible light, and one light path per pixel sample, splatted.
struct LightPaths<'a> {
    integrator: &'a LightPathIntegrator,
    camera: CameraPaths<'a, VolumePaths>,
}

impl RenderJob for LightPaths<'_> {
    fn run(&mut self, film: &mut Film, passes: Range<u32>, progress: &(dyn Fn(u64) + Sync)) -> RenderStats {
        let (scene, seed) = (self.camera.scene, self.camera.seed);
        let camera = &self.camera;
        let wavelengths = &camera.camera;
        let light_seed = hash_words(&[seed, LIGHT_PATH_SEED_SALT]);
        let per_sample = |x: u32, y: u32, s: u32, tracer: &mut Tracer, records: &mut SampleRecords| {
            let mut sampler = Sampler::new(x, y, s, light_seed);
            // The pass's wavelengths, as the camera paths of the same pass carry them where a pass shares them.
            let mut wl = wavelengths.wavelengths_of(s, sampler.next_1d());
            // A light path's time, uniform over the shutter as a camera ray's is (a dimension of its own sampler,
            // drawn only when something moves); the whole path and its connections to the lens use it.
            let time = scene.sample_time(&mut sampler);
            let splat = |raster, l, wl: &SampledWavelengths| records.splat(raster, l, *wl);
            self.integrator.trace(tracer, time, &mut wl, &mut sampler, splat);
        };
        camera.camera.in_wavelength_chunks(scene, passes, |chunk| {
            let mut stats = camera.render_in_one(film, chunk.clone(), &|_| {});
            let light = render_splatting(film, scene, chunk, progress, &per_sample);
            stats.rays += light.rays;
            stats.samples = light.samples;
            stats
        })
    }

    fn finish(self: Box<Self>, _film: &mut Film) {}
}

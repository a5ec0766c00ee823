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

use film::{Film, FilmError};
use glam::{Vec2, Vec3};
use scene::SceneError;
use spectral::{SampledSpectrum, SampledWavelengths};

use super::drive::{render_splatting, RenderStats, SampleRecords, LIGHT_PATH_SEED_SALT};
use super::path::{CameraPaths, PathIntegrator};
use super::transport::{
    adjoint_cos, begin_bounce, next_medium, russian_roulette, sample_light_path, scatter, Bounce, PathRay, RayCounts,
};
use super::{Integrate, IntegratorParams, Needs, RenderJob};
use crate::bxdf::TransportMode;
use crate::sampler::{hash_words, Sampler};
use crate::sampling::Frame;
use crate::scene::RenderScene;

/// The `lightpath` integrator.
#[derive(Clone, Copy, Debug)]
pub struct LightPathIntegrator {
    /// Maximum number of scattering events (pbrt's `maxdepth`, default 5), counting the vertex connected to the
    /// camera.
    pub max_depth: u32,
}

/// A scattering vertex of a light path, as [`walk_light_path`] shows it to its caller.
pub(crate) struct LightVertex<'a> {
    /// The surface hit.
    pub hit: &'a crate::scene::SurfaceHit,
    /// Shading frame at the hit.
    pub frame: &'a Frame,
    /// The BxDF there (at the path's current wavelengths).
    pub bxdf: &'a crate::bxdf::Bxdf,
    /// Unit world direction towards where the light came from.
    pub w_from: Vec3,
    /// Flux weight of the path arriving at the vertex.
    pub beta: SampledSpectrum,
    /// The medium on each side is resolved by the caller with this (the medium the light arrived through).
    pub medium: Option<u32>,
    /// Scattering vertex number, 1 for the first surface the light meets.
    pub depth: u32,
    /// Two uniform numbers reserved for the caller at this vertex.
    pub u: Vec2,
}

/// Traces one light path (light chosen by power, `sample_le`, BSDF sampling in importance mode, Russian roulette)
/// through up to `max_depth` scattering vertices, calling `visit` at each one whose BxDF is not specular. The
/// path's wavelengths `wl` are reduced to one by a dispersive refraction.
pub(crate) fn walk_light_path(
    scene: &RenderScene,
    max_depth: u32,
    wl: &mut SampledWavelengths,
    sampler: &mut Sampler,
    counts: &mut RayCounts,
    mut visit: impl FnMut(&LightVertex, &SampledWavelengths, &mut RayCounts),
) {
    let Some(start) = sample_light_path(scene, wl, sampler) else { return };
    let mut beta = start.le.flux_weight() * (1.0 / start.p_select);
    if beta.is_black() || !beta.0.iter().all(|v| v.is_finite()) {
        return;
    }
    // Russian roulette compares the throughput with what the path started with (it carries flux, not 1).
    let beta_start = beta.max_value();
    // Lights sit where the camera does (pbrt's lights carry no medium interface here).
    let mut ray = PathRay::new(start.origin(), start.le.d, scene.camera_medium);
    let mut depth = 0u32;
    while depth < max_depth {
        let Some(hit) = ray.intersect(scene, counts) else { break };
        ray.attenuate(scene, &hit, wl, &mut beta);
        let (bxdf, u) = match begin_bounce(scene, &hit, &mut ray, wl, sampler) {
            Bounce::PassedThrough => continue,
            Bounce::Stop | Bounce::Absorb => break,
            Bounce::Scatter(bxdf, u) => (bxdf, u),
        };
        depth += 1;
        let frame = Frame::from_z_and_tangent(hit.ns, hit.dpdu);
        let w_from = -ray.d;
        let wo = frame.to_local(w_from);
        if !bxdf.is_specular() {
            let v = LightVertex {
                hit: &hit,
                frame: &frame,
                bxdf: &bxdf,
                w_from,
                beta,
                medium: ray.medium,
                depth,
                u: Vec2::new(u.connect[0], u.connect[1]),
            };
            visit(&v, wl, counts);
        }
        if depth == max_depth {
            break;
        }
        let mode = TransportMode::Importance;
        let Some(s) = scatter(&bxdf, &frame, &hit, wo, w_from, &u, mode, wl, &mut beta) else { break };
        ray.leave(&hit, s.wi, s.bs.transmission);
        // Russian roulette after the first bounce.
        if !russian_roulette(beta.max_value() / beta_start, depth, &u, &mut beta) {
            break;
        }
        if !beta.0.iter().all(|v| v.is_finite()) {
            break;
        }
    }
}

impl LightPathIntegrator {
    /// Traces one light path with `sampler` at the wavelengths `wl` (which a dispersive refraction reduces to one)
    /// and calls `splat(raster, contribution, wavelengths)` for every connection to the camera. The contributions
    /// are per light path: the film divides their sum by the number of light paths per pixel.
    pub fn trace(
        &self,
        scene: &RenderScene,
        wl: &mut SampledWavelengths,
        sampler: &mut Sampler,
        counts: &mut RayCounts,
        mut splat: impl FnMut(Vec2, SampledSpectrum, &SampledWavelengths),
    ) {
        walk_light_path(scene, self.max_depth, wl, sampler, counts, |v, wl, counts| {
            let hit = v.hit;
            let Some(cs) = scene.camera.sample_wi(hit.p, v.u) else { return };
            let f = v.bxdf.f(v.frame.to_local(v.w_from), v.frame.to_local(cs.wi), TransportMode::Importance);
            if f.is_black() {
                return;
            }
            let origin = hit.spawn_origin(cs.wi);
            let t_max = (cs.p_lens - origin).length() * (1.0 - 1e-4);
            counts.shadow += 1;
            if scene.geometry.occluded(origin, cs.wi, t_max) {
                return;
            }
            let mut c = v.beta * f * (adjoint_cos(v.w_from, cs.wi, hit.ns, hit.n) * cs.we / cs.pdf);
            if let Some(m) = next_medium(hit, cs.wi, v.medium) {
                c *= scene.media[m as usize].absorption_transmittance(cs.dist, wl);
            }
            splat(cs.raster, c, wl);
        });
    }
}

impl Integrate for LightPathIntegrator {
    fn read(params: &mut IntegratorParams) -> Result<Self, SceneError> {
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
    ) -> Result<Box<dyn RenderJob + 'a>, FilmError> {
        // Emitters seen directly: a path tracer that stops at the first surface.
        let direct = PathIntegrator { max_depth: 0 };
        let camera = CameraPaths::new(direct, scene, film, seed)?;
        Ok(Box::new(LightPaths { integrator: self, camera }))
    }
}

/// A light-tracing render: camera rays for directly visible light, and one light path per pixel sample, splatted.
struct LightPaths<'a> {
    integrator: &'a LightPathIntegrator,
    camera: CameraPaths<'a, PathIntegrator>,
}

impl RenderJob for LightPaths<'_> {
    fn run(&mut self, film: &mut Film, passes: Range<u32>, progress: &(dyn Fn(u64) + Sync)) -> RenderStats {
        let mut stats = self.camera.render(film, passes.clone(), &|_| {});
        let (scene, seed) = (self.camera.scene, self.camera.seed);
        let wavelengths = self.camera.camera.wavelengths();
        let light_seed = hash_words(&[seed, LIGHT_PATH_SEED_SALT]);
        let per_sample = |x: u32, y: u32, s: u32, counts: &mut RayCounts, records: &mut SampleRecords| {
            let mut sampler = Sampler::new(x, y, s, light_seed);
            let mut wl = wavelengths.sample(sampler.next_1d() as f64);
            self.integrator.trace(scene, &mut wl, &mut sampler, counts, |raster, l, wl| records.splat(raster, l, *wl));
        };
        let light = render_splatting(film, passes, progress, &per_sample);
        stats.rays += light.rays;
        stats.samples = light.samples;
        stats
    }

    fn finish(self: Box<Self>, _film: &mut Film) {}
}

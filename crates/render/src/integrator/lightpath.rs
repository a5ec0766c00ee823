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
use glam::{Vec2, Vec3};
use spectral::{SampledSpectrum, SampledWavelengths};

use super::drive::{render_splatting, RenderStats, SampleRecords, LIGHT_PATH_SEED_SALT};
use super::path::CameraPaths;
use super::transport::{
    adjoint_cos, begin_bounce, next_medium, russian_roulette, sample_light_path, scatter, shadow_transmittance,
    weigh_tracking, Bounce, BounceSamples, PathRay, RayCounts, ShadowTarget, SpectralMis,
};
use super::volpath::VolPathIntegrator;
use super::{Integrate, IntegratorParams, Needs, RenderError, RenderJob};
use crate::bxdf::TransportMode;
use crate::medium::{sample_t_maj, Collision, PhaseFunction, TrackingRng};
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

/// Where a light path scattered.
#[derive(Clone, Copy)]
pub(crate) enum LightVertexAt<'a> {
    /// At a surface, with its shading frame and BxDF (at the path's current wavelengths).
    Surface { hit: &'a crate::scene::SurfaceHit, frame: &'a Frame, bxdf: &'a crate::bxdf::Bxdf },
    /// At a point in a medium, with its phase function.
    Medium { p: Vec3, phase: &'a PhaseFunction },
}

/// A scattering vertex of a light path, as [`walk_light_path`] shows it to its caller.
pub(crate) struct LightVertex<'a> {
    /// Where it is.
    pub at: LightVertexAt<'a>,
    /// Unit world direction towards where the light came from.
    pub w_from: Vec3,
    /// Flux weight of the path arriving at the vertex.
    pub beta: SampledSpectrum,
    /// Rescaled probabilities of the path's tracking decisions in media at each wavelength (spectral MIS: the
    /// estimate at wavelength i is `beta[i] / mis.average(r)` times what the caller adds; all ones without media).
    pub r: SampledSpectrum,
    /// The spectral MIS state of the path.
    pub mis: SpectralMis,
    /// The medium the light arrived through (the caller resolves the side a connection leaves by).
    pub medium: Option<u32>,
    /// Scattering vertex number, 1 for the first surface the light meets.
    pub depth: u32,
    /// Two uniform numbers reserved for the caller at this vertex.
    pub u: Vec2,
}

impl LightVertex<'_> {
    /// The vertex's position.
    pub fn p(&self) -> Vec3 {
        match self.at {
            LightVertexAt::Surface { hit, .. } => hit.p,
            LightVertexAt::Medium { p, .. } => p,
        }
    }
}

/// Traces one light path (light chosen by power, `sample_le`, BSDF and phase-function sampling in importance mode,
/// Russian roulette) through up to `max_depth` scattering vertices, calling `visit` at each one that is not
/// specular. The path's wavelengths `wl` are reduced to one by a dispersive refraction. With `media`, media that
/// scatter are tracked (delta tracking against the majorant with spectral MIS, as in `volpath`) and their
/// scattering points are vertices too; without, they are treated as vacuum (integrators that do not render them).
#[allow(clippy::too_many_arguments)]
pub(crate) fn walk_light_path(
    scene: &RenderScene,
    max_depth: u32,
    media: bool,
    time: f32,
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
    let mut r = SampledSpectrum::splat(1.0);
    let mut mis = SpectralMis::new(wl);
    // A random hero from the start when there are media: a shadow ray may track through a chromatic medium
    // before the path enters one, and spectral MIS is unbiased only for a uniformly chosen hero.
    if media && scene.has_scattering_media() {
        mis.choose(sampler.next_1d());
    }
    let medium = scene.light_medium(start.light, start.le.d, start.le.surface.map(|s| s.n));
    let mut ray = PathRay::new(start.origin(), start.le.d, medium, time);
    let mut depth = 0u32;
    while depth < max_depth {
        let hit = ray.intersect(scene, counts);
        match ray.medium {
            Some(m) if media && !scene.media[m as usize].is_absorbing_only() => {
                let medium = &scene.media[m as usize];
                mis.choose(sampler.next_1d());
                let h = mis.hero;
                let mut rng = TrackingRng::new(sampler.next_1d(), depth);
                let (ro, rd) = (ray.o, ray.d);
                let t_end = hit.map_or(f32::INFINITY, |h| h.t);
                let mut scattered: Option<(Vec3, Vec3)> = None;
                let mut terminated = false;
                let t_maj = sample_t_maj(medium, ro, rd, t_end, &mut rng, wl, h, |p, mp, sigma_maj, t_maj, rng| {
                    let event = mp.collision(sigma_maj, h, rng.uniform());
                    if event == Collision::Absorb {
                        terminated = true;
                        return false;
                    }
                    if event == Collision::Scatter {
                        depth += 1;
                        if !weigh_tracking(&mut beta, &mut r, &mis, t_maj, mp.sigma_s) {
                            terminated = true;
                            return false;
                        }
                        let u = BounceSamples::draw(sampler);
                        let v = LightVertex {
                            at: LightVertexAt::Medium { p, phase: mp.phase },
                            w_from: -rd,
                            beta,
                            r,
                            mis,
                            medium: Some(m),
                            depth,
                            u: Vec2::new(u.connect[0], u.connect[1]),
                        };
                        visit(&v, wl, counts);
                        if depth == max_depth {
                            terminated = true;
                            return false;
                        }
                        let Some(ps) = mp.phase.sample(rd, u.dir, u.lobe, wl) else {
                            terminated = true;
                            return false;
                        };
                        beta *= ps.p / ps.pdf;
                        if !russian_roulette((beta / mis.average(r)).max_value() / beta_start, depth, &u, &mut beta) {
                            terminated = true;
                            return false;
                        }
                        scattered = Some((p, ps.wi));
                        return false;
                    }
                    if !weigh_tracking(&mut beta, &mut r, &mis, t_maj, mp.sigma_n(sigma_maj)) {
                        terminated = true;
                        return false;
                    }
                    !beta.is_black()
                });
                if terminated || beta.is_black() {
                    break;
                }
                if let Some((p, wi)) = scattered {
                    ray = PathRay::new(p, wi, Some(m), time);
                    continue;
                }
                // No collision before the surface: probability T_maj at the hero.
                if !weigh_tracking(&mut beta, &mut r, &mis, t_maj, SampledSpectrum::splat(1.0)) {
                    break;
                }
            }
            _ => {
                if let Some(hit) = &hit {
                    ray.attenuate(scene, hit, wl, &mut beta);
                }
            }
        }
        let Some(mut hit) = hit else { break };
        let (bxdf, u) = match begin_bounce(scene, &mut hit, &mut ray, wl, sampler) {
            Bounce::PassedThrough => continue,
            Bounce::Stop | Bounce::Absorb => break,
            Bounce::Scatter(bxdf, u) => (bxdf, u),
        };
        mis.update(wl);
        depth += 1;
        let frame = Frame::from_z_and_tangent(hit.ns, hit.dpdu);
        let w_from = -ray.d;
        let wo = frame.to_local(w_from);
        if !bxdf.is_specular() {
            let v = LightVertex {
                at: LightVertexAt::Surface { hit: &hit, frame: &frame, bxdf: &bxdf },
                w_from,
                beta,
                r,
                mis,
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
        mis.update(wl);
        ray.leave(&hit, s.wi, s.bs.transmission);
        // Russian roulette after the first bounce.
        if !russian_roulette((beta / mis.average(r)).max_value() / beta_start, depth, &u, &mut beta) {
            break;
        }
        if !beta.0.iter().all(|v| v.is_finite()) {
            break;
        }
    }
}

impl LightPathIntegrator {
    /// Traces one light path with `sampler` at the wavelengths `wl` (which a dispersive refraction reduces to one)
    /// and at `time`, and calls `splat(raster, contribution, wavelengths)` for every connection to the camera (where
    /// the camera is at that time). The contributions are per light path: the film divides their sum by the number
    /// of light paths per pixel.
    #[allow(clippy::too_many_arguments)]
    pub fn trace(
        &self,
        scene: &RenderScene,
        time: f32,
        wl: &mut SampledWavelengths,
        sampler: &mut Sampler,
        counts: &mut RayCounts,
        mut splat: impl FnMut(Vec2, SampledSpectrum, &SampledWavelengths),
    ) {
        let camera = scene.camera.at_time(time);
        walk_light_path(scene, self.max_depth, true, time, wl, sampler, counts, |v, wl, counts| {
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
            let salt = LIGHT_PATH_SEED_SALT ^ v.depth;
            let target = ShadowTarget::Point(cs.p_lens);
            let Some(tr) = shadow_transmittance(scene, origin, target, medium, time, wl, &v.mis, salt, v.u.x, counts)
            else {
                return;
            };
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
        let direct = VolPathIntegrator { max_depth: 0, split_dispersion: true };
        let camera = CameraPaths::new(direct, scene, film, seed)?;
        Ok(Box::new(LightPaths { integrator: self, camera }))
    }
}

/// A light-tracing render: camera rays for directly visible light, and one light path per pixel sample, splatted.
struct LightPaths<'a> {
    integrator: &'a LightPathIntegrator,
    camera: CameraPaths<'a, VolPathIntegrator>,
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
            // A light path's time, uniform over the shutter as a camera ray's is (a dimension of its own sampler,
            // drawn only when something moves); the whole path and its connections to the lens use it.
            let time = scene.sample_time(&mut sampler);
            let splat = |raster, l, wl: &SampledWavelengths| records.splat(raster, l, *wl);
            self.integrator.trace(scene, time, &mut wl, &mut sampler, counts, splat);
        };
        let light = render_splatting(film, passes, progress, &per_sample);
        stats.rays += light.rays;
        stats.samples = light.samples;
        stats
    }

    fn finish(self: Box<Self>, _film: &mut Film) {}
}

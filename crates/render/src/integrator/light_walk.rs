//! The light-path walk shared by the integrators that trace light from the lights (`lightpath`, `sppm`'s photons,
//! `bdpt`'s light subpaths start the same way): a light chosen by power and a ray leaving it, then BSDF and
//! phase-function sampling in importance mode with the adjoint shading-normal correction, Russian roulette, and
//! delta tracking with spectral MIS in media that scatter (as camera paths do in `volpath`).

use glam::{Vec2, Vec3};
use spectral::{SampledSpectrum, SampledWavelengths};

use super::transport::{
    begin_bounce, russian_roulette, scatter, Bounce, BounceSamples, PathRay, SurfaceVertex, Tracer,
};
use super::volume::{weigh_tracking, SpectralMis};
use crate::bxdf::{Bxdf, TransportMode};
use crate::light::LightLeSample;
use crate::medium::{sample_t_maj, Collision, PhaseFunction, TrackingRng};
use crate::sampler::Sampler;
use crate::sampling::Frame;
use crate::scene::{RenderScene, SurfaceHit};

/// The start of a light path: a light chosen by power, and a ray of light leaving it.
pub(crate) struct LightPathStart {
    /// The light's index.
    pub light: u32,
    /// The probability of having chosen it.
    pub p_select: f32,
    /// The emitted ray with its radiance and densities.
    pub le: LightLeSample,
}

impl LightPathStart {
    /// The ray's origin, offset off the light's surface for area lights.
    pub fn origin(&self) -> Vec3 {
        match self.le.surface {
            Some(sp) => geometry::offset_ray_origin(sp.p, sp.p_error, sp.n, self.le.d),
            None => self.le.o,
        }
    }
}

/// Starts a light path (light tracing, photon mapping and bidirectional path tracing alike), drawing five
/// dimensions of `sampler`: the light (1), the point on it (2), the direction (2).
pub(crate) fn sample_light_path(
    scene: &RenderScene,
    wl: &SampledWavelengths,
    sampler: &mut Sampler,
) -> Option<LightPathStart> {
    let u_light = sampler.next_1d();
    let u_pos = Vec2::from(sampler.next_2d());
    let u_dir = Vec2::from(sampler.next_2d());
    let (light, p_select) = scene.sample_light(u_light)?;
    let le = scene.lights[light as usize].sample_le(u_pos, u_dir, wl, scene.bounding_sphere)?;
    Some(LightPathStart { light, p_select, le })
}

/// What a light-path walk does: how many scattering vertices it may make, whether media that scatter are tracked
/// (delta tracking against the majorant with spectral MIS, their scattering points being vertices too) or treated
/// as vacuum (integrators that do not render them), and the path's time.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LightWalk {
    /// Most scattering vertices.
    pub max_depth: u32,
    /// Whether media that scatter are tracked.
    pub media: bool,
    /// The time the whole path is traced at.
    pub time: f32,
}

/// Where a light path scattered.
#[derive(Clone, Copy)]
pub(crate) enum LightVertexAt<'a> {
    /// At a surface, with its shading frame and BxDF (at the path's current wavelengths).
    Surface { hit: &'a SurfaceHit, frame: &'a Frame, bxdf: &'a Bxdf },
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
/// Russian roulette) as `walk` says, calling `visit` at each scattering vertex that is not specular. The path's
/// wavelengths `wl` are reduced to one by a dispersive refraction.
pub(crate) fn walk_light_path(
    tracer: &mut Tracer,
    walk: LightWalk,
    wl: &mut SampledWavelengths,
    sampler: &mut Sampler,
    mut visit: impl FnMut(&LightVertex, &SampledWavelengths, &mut Tracer),
) {
    let LightWalk { max_depth, media, time } = walk;
    let scene = tracer.scene;
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
        let hit = ray.intersect(tracer);
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
                        visit(&v, wl, tracer);
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
                    ray.scatter_in_medium(p, wi);
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
            visit(&v, wl, tracer);
        }
        if depth == max_depth {
            break;
        }
        let mode = TransportMode::Importance;
        let v = SurfaceVertex { hit: &hit, frame: &frame, bxdf: &bxdf, wo, medium: ray.medium };
        let Some(s) = scatter(&v, w_from, &u, mode, wl, &mut beta) else { break };
        mis.update(wl);
        ray.leave(&hit, s.wi, s.bs.specular);
        // Russian roulette after the first bounce.
        if !russian_roulette((beta / mis.average(r)).max_value() / beta_start, depth, &u, &mut beta) {
            break;
        }
        if !beta.0.iter().all(|v| v.is_finite()) {
            break;
        }
    }
}

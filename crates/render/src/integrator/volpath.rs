//! Volumetric path tracing (pbrt-v4's `volpath`): the null-scattering path integral of Miller, Georgiev & Jarosz
//! 2019 with delta tracking against a majorant for collisions, ratio tracking for the transmittance of shadow rays,
//! and one-sample MIS over the carried wavelengths (spectral MIS), so that a medium whose σ depends on wavelength
//! does not turn into colour noise. Next-event estimation is combined with BSDF and phase-function sampling by the
//! balance heuristic through the same rescaled path probabilities r_u and r_l (pbrt-v4 §14.2.3).
//!
//! `maxdepth` counts scattering events, in media and at surfaces; crossing a material-less boundary is not one.
//! Absorbing-only media attenuate in closed form (Beer–Lambert) instead of by tracking.

use glam::Vec3;
use spectral::{SampledSpectrum, SampledWavelengths};

use super::path::{CameraPaths, FirstHit, Radiance};
use super::transport::{
    begin_bounce, next_medium, russian_roulette, scatter, shadow_transmittance, weigh_tracking, Bounce, BounceSamples,
    PathRay, RayCounts, Scattered, ShadowTarget, SpectralMis,
};
use super::{Integrate, IntegratorParams, RenderError, RenderJob};
use crate::bxdf::{Bxdf, DispersiveSplit, TransportMode};
use crate::light::LightSampleContext;
use crate::medium::{sample_t_maj, Collision, PhaseFunction, TrackingRng};
use crate::sampler::Sampler;
use crate::sampling::Frame;
use crate::scene::{RenderScene, SurfaceHit};
use film::Film;

/// The `volpath` integrator.
#[derive(Clone, Copy, Debug)]
pub struct VolPathIntegrator {
    /// Maximum number of scattering events, in media and at surfaces (pbrt's `maxdepth`, default 5).
    pub max_depth: u32,
    /// Whether a refraction through a smooth dispersive surface splits the path into one branch per carried
    /// wavelength (Prismatic's `"bool splitdispersion"`, default true; see [`super::path::PathIntegrator`]).
    pub split_dispersion: bool,
}

/// Where the path scattered last, for the light-selection and MIS densities of the emitter it finds next.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Vertex<'a> {
    /// A surface with its BxDF in its shading frame, reached through `medium`.
    Surface { hit: &'a crate::scene::SurfaceHit, frame: &'a Frame, bxdf: &'a Bxdf, wo: Vec3, medium: Option<u32> },
    /// A point in a medium, reached travelling along `d_in` at `time`.
    Medium { p: Vec3, d_in: Vec3, phase: &'a PhaseFunction, medium: Option<u32>, time: f32 },
}

impl VolPathIntegrator {
    /// [`sample_ld`] weighted against BSDF or phase sampling.
    #[allow(clippy::too_many_arguments)]
    fn sample_ld(
        &self,
        scene: &RenderScene,
        v: Vertex,
        wl: &SampledWavelengths,
        u: &BounceSamples,
        mis: &SpectralMis,
        r_p: SampledSpectrum,
        counts: &mut RayCounts,
    ) -> SampledSpectrum {
        sample_ld(scene, v, wl, u, mis, r_p, false, counts)
    }
}

/// Next-event estimation at `v`: a light and a point on it, transmittance through media (closed form in
/// homogeneous ones, ratio tracking in grids) and material-less boundaries, weighted against BSDF or phase sampling
/// by the balance heuristic over all wavelengths (`r_p` is the path's r_u), or by spectral MIS alone when
/// `light_only` (for integrators that find the rest of the light otherwise, as photon mapping does). Draws the
/// light sample from `u`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn sample_ld(
    scene: &RenderScene,
    v: Vertex,
    wl: &SampledWavelengths,
    u: &BounceSamples,
    mis: &SpectralMis,
    r_p: SampledSpectrum,
    light_only: bool,
    counts: &mut RayCounts,
) -> SampledSpectrum {
    let [u_light, u0, u1] = u.connect;
    let Some((li, p_sel)) = scene.sample_light(u_light) else { return SampledSpectrum::zero() };
    let light = &scene.lights[li as usize];
    let ctx = match v {
        Vertex::Surface { hit, .. } => LightSampleContext { p: hit.p, n: hit.n },
        Vertex::Medium { p, .. } => LightSampleContext { p, n: Vec3::ZERO },
    };
    let Some(ls) = light.sample_li(&ctx, glam::Vec2::new(u0, u1), wl) else { return SampledSpectrum::zero() };
    if ls.pdf <= 0.0 || ls.l.is_black() {
        return SampledSpectrum::zero();
    }
    let p_l = p_sel * ls.pdf;
    let time = match v {
        Vertex::Surface { hit, .. } => hit.time,
        Vertex::Medium { time, .. } => time,
    };
    let (f_hat, scatter_pdf, origin, medium) = match v {
        Vertex::Surface { hit, frame, bxdf, wo, medium } => {
            let wi = frame.to_local(ls.wi);
            let (f, pdf) = bxdf.f_pdf(wo, wi, TransportMode::Radiance);
            let f = f * wi.z.abs();
            // The shadow ray leaves into the medium on the light's side (the arrival medium without an
            // interface).
            (f, pdf, hit.spawn_origin(ls.wi), next_medium(hit, ls.wi, medium))
        }
        Vertex::Medium { p, d_in, phase, medium, .. } => {
            (phase.p(d_in, ls.wi, wl), phase.pdf(d_in, ls.wi, wl), p, medium)
        }
    };
    if f_hat.is_black() {
        return SampledSpectrum::zero();
    }
    let target = if ls.dist.is_finite() { ShadowTarget::Point(ls.p) } else { ShadowTarget::Direction(ls.wi) };
    let Some(tr) = shadow_transmittance(scene, origin, target, medium, time, wl, mis, li ^ 0x5eed, u0, counts) else {
        return SampledSpectrum::zero();
    };
    let (t_ray, r_l, r_u) = (tr.t, tr.r_l, tr.r_u);
    let r_l = r_l * r_p * p_l;
    let r_u = r_u * r_p * scatter_pdf;
    if ls.delta || light_only {
        f_hat * t_ray * ls.l / mis.average(r_l)
    } else {
        f_hat * t_ray * ls.l / mis.average(r_l + r_u)
    }
}

/// A volumetric path between two events: what a split at a dispersive refraction copies into each branch.
#[derive(Clone, Copy, Debug)]
struct VolPathState {
    ray: PathRay,
    beta: SampledSpectrum,
    /// Rescaled unidirectional and light-sampling path probabilities (pbrt-v4 §14.2.3).
    r_u: SampledSpectrum,
    r_l: SampledSpectrum,
    mis: SpectralMis,
    specular_bounce: bool,
    eta_scale: f32,
    depth: u32,
    prev_p: Vec3,
}

impl VolPathState {
    /// Follows a sampled scattering `s` out of `hit` (the throughput already includes f·|cos|/pdf): the MIS
    /// probabilities, the ray leaving the surface, then Russian roulette. False if the path ends.
    fn follow(
        &mut self,
        bxdf: &Bxdf,
        hit: &SurfaceHit,
        s: Scattered,
        wo: Vec3,
        u: &BounceSamples,
        wl: &SampledWavelengths,
    ) -> bool {
        let mode = TransportMode::Radiance;
        self.mis.update(wl);
        let p_b = if s.bs.pdf_is_proportional { bxdf.pdf(wo, s.bs.wi, mode) } else { s.bs.pdf };
        self.r_l = self.r_u / p_b;
        self.specular_bounce = s.bs.specular;
        if s.bs.transmission {
            self.eta_scale *= s.bs.eta * s.bs.eta;
        }
        self.prev_p = hit.p;
        self.ray.leave(hit, s.wi, s.bs.transmission);
        let ratio = (self.beta * self.eta_scale / self.mis.average(self.r_u)).max_value();
        if !russian_roulette(ratio, self.depth, u, &mut self.beta) {
            return false;
        }
        self.beta.0.iter().all(|v| v.is_finite())
    }
}

impl VolPathIntegrator {
    /// Radiance along `st.ray` at the wavelengths of `wl`, continuing the path in `st` event by event.
    #[allow(clippy::too_many_arguments)]
    fn trace(
        &self,
        scene: &RenderScene,
        st: &mut VolPathState,
        wl: &mut SampledWavelengths,
        sampler: &mut Sampler,
        counts: &mut RayCounts,
        mut first_hit: Option<&mut Option<FirstHit>>,
    ) -> SampledSpectrum {
        let mut l = SampledSpectrum::zero();
        loop {
            let mut hit = st.ray.intersect(scene, counts);
            // Through the medium along the ray, up to the surface.
            if let Some(m) = st.ray.medium {
                let medium = &scene.media[m as usize];
                let t_end = hit.as_ref().map_or(f32::INFINITY, |h| h.t);
                if medium.is_absorbing_only() {
                    st.beta *= medium.absorption_transmittance(t_end, wl);
                } else {
                    st.mis.choose(sampler.next_1d());
                    let h = st.mis.hero;
                    let mut rng = TrackingRng::new(sampler.next_1d(), st.depth);
                    let (ro, rd) = (st.ray.o, st.ray.d);
                    let mut scattered: Option<(Vec3, Vec3)> = None;
                    let mut terminated = false;
                    let t_maj = sample_t_maj(medium, ro, rd, t_end, &mut rng, wl, h, |p, mp, sigma_maj, t_maj, rng| {
                        // Emission, σa·Le, estimated at every tentative collision.
                        if st.depth < self.max_depth && !mp.le.is_black() {
                            let pdf = sigma_maj[h] * t_maj[h];
                            let betap = st.beta * t_maj / pdf;
                            let r_e = st.r_u * st.mis.ratio(sigma_maj * t_maj / pdf);
                            let avg = st.mis.average(r_e);
                            if avg > 0.0 {
                                l += betap * mp.sigma_a * mp.le / avg;
                            }
                        }
                        let event = mp.collision(sigma_maj, h, rng.uniform());
                        if event == Collision::Absorb {
                            terminated = true;
                            return false;
                        }
                        if event == Collision::Scatter {
                            // A real scattering event.
                            if st.depth >= self.max_depth {
                                terminated = true;
                                return false;
                            }
                            st.depth += 1;
                            if !weigh_tracking(&mut st.beta, &mut st.r_u, &st.mis, t_maj, mp.sigma_s)
                                || st.beta.is_black()
                                || st.r_u.is_black()
                            {
                                terminated = true;
                                return false;
                            }
                            let u = BounceSamples::draw(sampler);
                            let v = Vertex::Medium { p, d_in: rd, phase: mp.phase, medium: Some(m), time: st.ray.time };
                            l += st.beta * self.sample_ld(scene, v, wl, &u, &st.mis, st.r_u, counts);
                            let Some(ps) = mp.phase.sample(rd, u.dir, u.lobe, wl) else {
                                terminated = true;
                                return false;
                            };
                            st.beta *= ps.p / ps.pdf;
                            st.r_l = st.r_u / ps.pdf;
                            if !russian_roulette(
                                (st.beta / st.mis.average(st.r_u)).max_value(),
                                st.depth,
                                &u,
                                &mut st.beta,
                            ) {
                                terminated = true;
                                return false;
                            }
                            scattered = Some((p, ps.wi));
                            return false;
                        }
                        // A null collision.
                        let sigma_n = mp.sigma_n(sigma_maj);
                        let pdf = t_maj[h] * sigma_n[h];
                        if weigh_tracking(&mut st.beta, &mut st.r_u, &st.mis, t_maj, sigma_n) {
                            st.r_l *= st.mis.ratio(t_maj * sigma_maj / pdf);
                        } else {
                            st.beta = SampledSpectrum::zero();
                        }
                        !st.beta.is_black() && !st.r_u.is_black()
                    });
                    if terminated || st.beta.is_black() || st.r_u.is_black() {
                        break;
                    }
                    if let Some((p, wi)) = scattered {
                        st.specular_bounce = false;
                        st.prev_p = p;
                        st.ray = PathRay::new(p, wi, st.ray.medium, st.ray.time);
                        continue;
                    }
                    // No collision before the surface: probability T_maj at the hero.
                    if !weigh_tracking(&mut st.beta, &mut st.r_u, &st.mis, t_maj, SampledSpectrum::splat(1.0)) {
                        break;
                    }
                    if medium.has_closed_form_transmittance() {
                        // Shadow rays take this medium's transmittance in closed form, so light sampling has no
                        // tracking probability here: its density relative to this path's loses T_maj[h] only.
                        st.r_l *= 1.0 / t_maj[h];
                    } else {
                        st.r_l *= st.mis.ratio(t_maj / t_maj[h]);
                    }
                }
            }
            let d = st.ray.d;
            let Some(hit) = hit.as_mut() else {
                // Escaped: infinite lights.
                for &li in &scene.infinite_lights {
                    let light = &scene.lights[li as usize];
                    let le = light.le(d, wl);
                    if le.is_black() {
                        continue;
                    }
                    if st.depth == 0 || st.specular_bounce {
                        l += st.beta * le / st.mis.average(st.r_u);
                    } else {
                        let p_l = scene.light_probability(li) * light.pdf_li_infinite(d);
                        l += st.beta * le / st.mis.average(st.r_u + st.r_l * p_l);
                    }
                }
                break;
            };
            // Emission from an area light that was hit.
            if let Some(li) = hit.area_light {
                let light = &scene.lights[li as usize];
                let le = light.l_area(hit.p, hit.uv, hit.n, -d, wl);
                if !le.is_black() {
                    if st.depth == 0 || st.specular_bounce {
                        l += st.beta * le / st.mis.average(st.r_u);
                    } else {
                        let p_l = scene.light_probability(li) * light.pdf_li_area(st.prev_p, d);
                        l += st.beta * le / st.mis.average(st.r_u + st.r_l * p_l);
                    }
                }
            }
            let arrived_in = st.ray.medium;
            let (bxdf, u) = match begin_bounce(scene, hit, &mut st.ray, wl, sampler) {
                Bounce::PassedThrough => continue,
                Bounce::Stop | Bounce::Absorb => break,
                Bounce::Scatter(bxdf, u) => (bxdf, u),
            };
            st.mis.update(wl);
            if st.depth == 0 {
                if let Some(fh) = first_hit.take() {
                    *fh = Some(FirstHit::at(hit, &bxdf));
                }
            }
            if st.depth == self.max_depth {
                break;
            }
            st.depth += 1;
            let frame = Frame::from_z_and_tangent(hit.ns, hit.dpdu);
            let wo = frame.to_local(-d);
            if !bxdf.is_specular() {
                let v = Vertex::Surface { hit, frame: &frame, bxdf: &bxdf, wo, medium: arrived_in };
                l += st.beta * self.sample_ld(scene, v, wl, &u, &st.mis, st.r_u, counts);
            }
            let mode = TransportMode::Radiance;
            // A dispersive refraction splits the path into one branch per carried wavelength (each at its full
            // density) instead of keeping one of them (as `path` does).
            let split = if self.split_dispersion { bxdf.sample_dispersive_split(wo, u.lobe, mode) } else { None };
            let s = match split {
                Some(DispersiveSplit::Refraction(branches)) => {
                    for (slot, bs) in branches.into_iter().enumerate() {
                        let Some(bs) = bs else { continue };
                        let mut branch = *st;
                        let mut wl_branch = wl.branch(slot);
                        branch.beta *= bs.f * (bs.wi.z.abs() / bs.pdf);
                        let wi = frame.from_local(bs.wi);
                        if branch.follow(&bxdf, hit, Scattered { bs, wi }, wo, &u, &wl_branch) {
                            let lb = self.trace(scene, &mut branch, &mut wl_branch, sampler, counts, None);
                            l[slot] += lb[slot];
                        }
                    }
                    break;
                }
                Some(DispersiveSplit::Reflection(bs)) => {
                    st.beta *= bs.f * (bs.wi.z.abs() / bs.pdf);
                    Scattered { wi: frame.from_local(bs.wi), bs }
                }
                None => {
                    let Some(s) = scatter(&bxdf, &frame, hit, wo, -d, &u, mode, wl, &mut st.beta) else { break };
                    s
                }
            };
            if !st.follow(&bxdf, hit, s, wo, &u, wl) {
                break;
            }
        }
        l
    }
}

impl Radiance for VolPathIntegrator {
    fn li(
        &self,
        scene: &RenderScene,
        o: Vec3,
        d: Vec3,
        time: f32,
        wl: &mut SampledWavelengths,
        sampler: &mut Sampler,
        counts: &mut RayCounts,
        first_hit: Option<&mut Option<FirstHit>>,
    ) -> SampledSpectrum {
        let mut mis = SpectralMis::new(wl);
        // A random hero from the start when there are media: a shadow ray may track through a chromatic medium
        // before the path enters one, and spectral MIS is unbiased only for a uniformly chosen hero.
        if scene.has_scattering_media() {
            mis.choose(sampler.next_1d());
        }
        let mut st = VolPathState {
            ray: PathRay::camera(o, d, scene.camera_medium, time),
            beta: SampledSpectrum::splat(1.0),
            r_u: SampledSpectrum::splat(1.0),
            r_l: SampledSpectrum::splat(1.0),
            mis,
            specular_bounce: false,
            eta_scale: 1.0,
            depth: 0,
            prev_p: o,
        };
        self.trace(scene, &mut st, wl, sampler, counts, first_hit)
    }
}

impl Integrate for VolPathIntegrator {
    fn read(params: &mut IntegratorParams) -> Result<Self, RenderError> {
        Ok(VolPathIntegrator {
            max_depth: params.max_depth()?,
            split_dispersion: params.entity.params.get_bool("splitdispersion", true)?,
        })
    }

    fn begin<'a>(
        &'a self,
        scene: &'a RenderScene,
        film: &Film,
        seed: u32,
    ) -> Result<Box<dyn RenderJob + 'a>, RenderError> {
        Ok(Box::new(CameraPaths::new(*self, scene, film, seed)?))
    }
}

//! The volumetric camera-path estimator, shared by `volpath` (whose render it is) and `lightpath` (which sees the
//! emitters visible from the camera through it, at depth 0): the null-scattering path integral of Miller, Georgiev
//! & Jarosz 2019 with delta tracking against a majorant for collisions, ratio tracking for the transmittance of
//! shadow rays, and one-sample MIS over the carried wavelengths (spectral MIS), so that a medium whose σ depends on
//! wavelength does not turn into colour noise. Next-event estimation is combined with BSDF and phase-function
//! sampling by the balance heuristic through the same rescaled path probabilities r_u and r_l (pbrt-v4 §14.2.3).
//!
//! The depth counts scattering events, in media and at surfaces; crossing a material-less boundary is not one.
//! Absorbing-only media attenuate in closed form (Beer–Lambert) instead of by tracking. In Mie media (or wherever
//! asked), light is sampled at a forced collision on each segment of a homogeneous medium rather than at the
//! path's own collisions ([`ForcedCollision`]).

use glam::Vec3;
use spectral::{SampledSpectrum, SampledWavelengths};

use super::drive::{begin_camera_bounce, CameraBounce, Depth, FirstHit, Radiance};
use super::transport::{
    russian_roulette, scatter, BounceSamples, DirectLight, PathRay, Scattered, SurfaceVertex, Tracer,
};
use super::volume::{
    sample_ld, sample_medium_direction, weigh_tracking, ForcedCollision, PrefixRatios, ScatterVertex, SpectralMis,
};
use crate::bxdf::{DispersiveSplit, TransportMode};
use crate::camera::CameraRay;
use crate::medium::{sample_t_maj, Collision, TrackingRng};
use crate::sampler::Sampler;

/// Volumetric camera paths of at most `max_depth` scattering events.
#[derive(Clone, Copy, Debug)]
pub(crate) struct VolumePaths {
    /// Maximum number of scattering events, in media and at surfaces.
    pub max_depth: u32,
    /// Whether a refraction through a smooth dispersive surface splits the path into one branch per carried
    /// wavelength.
    pub split_dispersion: bool,
    /// Whether near-specular BSDFs are widened after the first non-specular scattering (`"bool regularize"`).
    pub regularize: bool,
    /// The share of scattering directions in Mie media drawn towards the sun (`"float sunguide"`).
    pub sun_guide: f32,
    /// Whether light is sampled at a forced collision on each segment through a homogeneous medium
    /// ([`ForcedCollision`]) rather than at the path's own collisions; `None`: in Mie media.
    pub forced_collisions: Option<bool>,
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
    /// What Russian roulette multiplies the throughput by before it judges a path: the squared relative index of
    /// refraction crossed (radiance scales with it, pbrt-v4 §13.4.2), and for each guided scattering direction the
    /// ratio of its density to the phase function's. A direction guided towards the sun has a small weight because
    /// it is drawn often, not because little light follows it: its next event sees the sun through the drops'
    /// forward lobe, and judging it by its weight would end most such paths and make the survivors grains.
    rr_scale: f32,
    depth: Depth,
    prev_p: Vec3,
}

impl VolPathState {
    /// Follows a sampled scattering `s` out of vertex `v` (the throughput already includes f·|cos|/pdf): the MIS
    /// probabilities, the ray leaving the surface, then Russian roulette. False if the path ends.
    fn follow(&mut self, v: &SurfaceVertex, s: Scattered, u: &BounceSamples, wl: &SampledWavelengths) -> bool {
        let SurfaceVertex { hit, bxdf, wo, .. } = *v;
        let mode = TransportMode::Radiance;
        self.mis.update(wl);
        let p_b = if s.bs.pdf_is_proportional { bxdf.pdf(wo, s.bs.wi, mode) } else { s.bs.pdf };
        self.r_l = self.r_u / p_b;
        self.specular_bounce = s.bs.specular;
        if s.bs.transmission {
            self.rr_scale *= s.bs.eta * s.bs.eta;
        }
        self.prev_p = hit.p;
        self.ray.leave(hit, s.wi, s.bs.specular);
        let ratio = (self.beta * self.rr_scale / self.mis.average(self.r_u)).max_value();
        if !russian_roulette(ratio, self.depth.events, u, &mut self.beta) {
            return false;
        }
        self.beta.0.iter().all(|v| v.is_finite())
    }
}

impl VolumePaths {
    /// Radiance along `st.ray` at the wavelengths of `wl`, continuing the path in `st` event by event.
    fn trace(
        &self,
        tracer: &mut Tracer,
        st: &mut VolPathState,
        wl: &mut SampledWavelengths,
        sampler: &mut Sampler,
        mut first_hit: Option<&mut Option<FirstHit>>,
    ) -> SampledSpectrum {
        let scene = tracer.scene;
        let mut l = SampledSpectrum::zero();
        loop {
            let mut hit = st.ray.intersect(tracer);
            // Through the medium along the ray, up to the surface.
            if let Some(m) = st.ray.medium {
                let medium = &scene.media[m as usize];
                let t_end = hit.as_ref().map_or(f32::INFINITY, |h| h.t);
                if medium.is_absorbing_only() {
                    st.beta *= medium.absorption_transmittance(t_end, wl);
                } else {
                    st.mis.choose(sampler.next_1d());
                    let h = st.mis.hero;
                    let mut rng = TrackingRng::new(sampler.next_1d(), st.depth.events);
                    let (ro, rd) = (st.ray.o, st.ray.d);
                    let time = st.ray.time;
                    let vertex = |p| ScatterVertex::Medium {
                        p,
                        d_in: rd,
                        phase: medium.phase(),
                        medium: Some(m),
                        time,
                        sun_guide: self.sun_guide,
                    };
                    // Next-event estimation on this segment at a forced collision, where transmittance has a closed
                    // form and the path may still scatter once more.
                    let forcing = self.forced_collisions.unwrap_or(medium.mie_optics().is_some())
                        && medium.has_closed_form_transmittance()
                        && st.depth.events < st.depth.max;
                    // The numbers of this segment's scattering vertex (light sampling, then direction and roulette
                    // at the path's collision) are drawn here when light is sampled at a forced collision, else
                    // at the collision.
                    let (u_forced, forced) = if forcing {
                        let u = BounceSamples::draw(sampler);
                        let mp = medium.point(ro, wl);
                        let fc =
                            ForcedCollision::sample(ro, rd, t_end, mp.sigma_a, mp.sigma_s, &st.mis, sampler.next_1d());
                        (Some(u), fc)
                    } else {
                        (None, None)
                    };
                    if let (Some(fc), Some(u)) = (&forced, &u_forced) {
                        let r_p = PrefixRatios { r_u: st.r_u * fc.ratios.r_u, r_l: st.r_u * fc.ratios.r_l };
                        l += st.beta * fc.beta * sample_ld(tracer, vertex(fc.p), wl, u, &st.mis, r_p, DirectLight::Mis);
                    }
                    let mut scattered: Option<(Vec3, Vec3)> = None;
                    let mut terminated = false;
                    let t_maj = sample_t_maj(medium, ro, rd, t_end, &mut rng, wl, h, |p, mp, sigma_maj, t_maj, rng| {
                        // Emission, σa·Le, estimated at every tentative collision.
                        if st.depth.events < st.depth.max && !mp.le.is_black() {
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
                            if !st.depth.count() {
                                terminated = true;
                                return false;
                            }
                            let r_prefix = st.r_u;
                            if !weigh_tracking(&mut st.beta, &mut st.r_u, &st.mis, t_maj, mp.sigma_s)
                                || st.beta.is_black()
                                || st.r_u.is_black()
                            {
                                terminated = true;
                                return false;
                            }
                            let u = u_forced.unwrap_or_else(|| BounceSamples::draw(sampler));
                            // Light sampling from here: done at the forced collision, or now.
                            let r_l = match &forced {
                                Some(fc) => r_prefix * fc.light_ratio_at_collision(t_maj, mp.sigma_s, &st.mis),
                                None => {
                                    let r_p = PrefixRatios::shared(st.r_u);
                                    l += st.beta * sample_ld(tracer, vertex(p), wl, &u, &st.mis, r_p, DirectLight::Mis);
                                    st.r_u
                                }
                            };
                            let Some(ps) =
                                sample_medium_direction(tracer.scene, mp.phase, rd, u.dir, u.lobe, wl, self.sun_guide)
                            else {
                                terminated = true;
                                return false;
                            };
                            st.beta *= ps.p / ps.pdf;
                            st.r_l = r_l / ps.pdf;
                            // (A direction the phase function cannot take has no throughput left to judge.)
                            let phase_pdf = mp.phase.pdf_of_values(&ps.p, wl);
                            if phase_pdf > 0.0 {
                                st.rr_scale *= ps.pdf / phase_pdf;
                            }
                            if !russian_roulette(
                                (st.beta * st.rr_scale / st.mis.average(st.r_u)).max_value(),
                                st.depth.events,
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
                        st.ray.scatter_in_medium(p, wi);
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
                    if st.depth.events == 0 || st.specular_bounce {
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
                    if st.depth.events == 0 || st.specular_bounce {
                        l += st.beta * le / st.mis.average(st.r_u);
                    } else {
                        let p_l = scene.light_probability(li) * light.pdf_li_area(st.prev_p, d);
                        l += st.beta * le / st.mis.average(st.r_u + st.r_l * p_l);
                    }
                }
            }
            let arrived_in = st.ray.medium;
            let (bxdf, u, frame) =
                match begin_camera_bounce(scene, hit, &mut st.ray, wl, sampler, &mut st.depth, &mut first_hit) {
                    CameraBounce::PassedThrough => continue,
                    CameraBounce::End => break,
                    CameraBounce::Scatter(bxdf, u, frame) => (bxdf, u, frame),
                };
            st.mis.update(wl);
            let hit = &*hit;
            let wo = frame.to_local(-d);
            let v = SurfaceVertex { hit, frame: &frame, bxdf: &bxdf, wo, medium: arrived_in };
            if !bxdf.is_specular() {
                let r_p = PrefixRatios::shared(st.r_u);
                l += st.beta * sample_ld(tracer, ScatterVertex::Surface(v), wl, &u, &st.mis, r_p, DirectLight::Mis);
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
                        if branch.follow(&v, Scattered { bs, wi }, &u, &wl_branch) {
                            let lb = self.trace(tracer, &mut branch, &mut wl_branch, sampler, None);
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
                    let Some(s) = scatter(&v, -d, &u, mode, wl, &mut st.beta) else { break };
                    s
                }
            };
            if !st.follow(&v, s, &u, wl) {
                break;
            }
        }
        l
    }
}

impl Radiance for VolumePaths {
    fn splits_dispersion(&self) -> bool {
        self.split_dispersion
    }

    fn li(
        &self,
        tracer: &mut Tracer,
        ray: &CameraRay,
        wl: &mut SampledWavelengths,
        sampler: &mut Sampler,
        first_hit: Option<&mut Option<FirstHit>>,
    ) -> SampledSpectrum {
        let scene = tracer.scene;
        let o = ray.origin;
        let mut mis = SpectralMis::new(wl);
        // A random hero from the start when there are media: a shadow ray may track through a chromatic medium
        // before the path enters one, and spectral MIS is unbiased only for a uniformly chosen hero.
        if scene.has_scattering_media() {
            mis.choose(sampler.next_1d());
        }
        let mut st = VolPathState {
            ray: PathRay::camera(o, ray.direction, scene.camera_medium, ray.time).regularizing(self.regularize),
            beta: SampledSpectrum::splat(1.0),
            r_u: SampledSpectrum::splat(1.0),
            r_l: SampledSpectrum::splat(1.0),
            mis,
            specular_bounce: false,
            rr_scale: 1.0,
            depth: Depth::new(self.max_depth),
            prev_p: o,
        };
        self.trace(tracer, &mut st, wl, sampler, first_hit)
    }
}

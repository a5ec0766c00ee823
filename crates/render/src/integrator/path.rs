//! The unidirectional spectral path tracer: next-event estimation with multiple importance sampling (power
//! heuristic) between light and BSDF sampling, light selection by power, Russian roulette and `maxdepth`
//! (Veach 1997 ch. 9; pbrt-v4 §13.4).

use film::Film;
use glam::Vec3;
use spectral::{SampledSpectrum, SampledWavelengths};

use super::drive::{begin_camera_bounce, CameraBounce, CameraPaths, Depth, FirstHit, Radiance};
use super::manifold::{self, ChainTrack};
use super::transport::{
    russian_roulette, sample_direct_light, scatter, BounceSamples, DirectLight, PathRay, SurfaceVertex, Tracer,
};
use super::{Integrate, IntegratorParams, RenderError, RenderJob};
use crate::bxdf::{BsdfSample, DispersiveSplit, TransportMode};
use crate::camera::CameraRay;
use crate::sampler::Sampler;
use crate::sampling::power_heuristic;
use crate::scene::RenderScene;

/// The `path` integrator.
#[derive(Clone, Copy, Debug)]
pub struct PathIntegrator {
    /// Maximum number of scattering events (pbrt's `maxdepth`, default 5).
    pub max_depth: u32,
    /// Whether a refraction through a smooth dispersive surface splits the path into one branch per carried
    /// wavelength (Prismatic's `"bool splitdispersion"`, default true) instead of keeping one wavelength chosen at
    /// random. Both are unbiased; splitting has no colour noise from the choice, at the cost of tracing the
    /// branches.
    pub split_dispersion: bool,
    /// Manifold next-event estimation through chains of smooth dielectric refractions, per wavelength
    /// (Prismatic's `"bool manifoldnee"`, default false; see the `integrator::manifold` module). Unbiased: the BSDF-sampled
    /// paths it accounts for are left out of the path tracer's sum.
    pub manifold_nee: bool,
    /// pbrt-v4's `"bool regularize"` (default false): after the first non-specular scattering, near-specular
    /// BSDFs are widened ([`crate::microfacet::TrowbridgeReitz::regularized`]), trading bias for less noise from
    /// caustics.
    pub regularize: bool,
}

/// A camera path between two bounces: what a split at a dispersive refraction copies into each branch.
#[derive(Clone, Copy, Debug)]
struct PathState {
    ray: PathRay,
    beta: SampledSpectrum,
    specular_bounce: bool,
    eta_scale: f32,
    depth: Depth,
    prev_p: Vec3,
    /// Density of the BSDF sample that chose `ray` (for MIS against light sampling where it lands).
    p_b: f32,
    /// The refractions since the last non-specular vertex (manifold NEE only).
    chain: ChainTrack,
}

impl PathState {
    /// Follows a sampled scattering `bs` (`wi` in world space) out of vertex `v`: throughput, MIS density, the ray
    /// leaving the surface, then Russian roulette. False if the path ends.
    fn follow(&mut self, v: &SurfaceVertex, bs: &BsdfSample, wi: Vec3, u: &BounceSamples) -> bool {
        let SurfaceVertex { hit, bxdf, wo, .. } = *v;
        let mode = TransportMode::Radiance;
        self.p_b = if bs.pdf_is_proportional { bxdf.pdf(wo, bs.wi, mode) } else { bs.pdf };
        if bs.specular {
            self.chain.specular(hit, bs.transmission);
        }
        self.specular_bounce = bs.specular;
        if bs.transmission {
            self.eta_scale *= bs.eta * bs.eta;
        }
        self.prev_p = hit.p;
        self.ray.leave(hit, wi, bs.specular);
        // Russian roulette on the throughput with refraction's radiance scaling undone.
        if !russian_roulette((self.beta * self.eta_scale).max_value(), self.depth.events, u, &mut self.beta) {
            return false;
        }
        self.beta.0.iter().all(|v| v.is_finite())
    }
}

impl PathIntegrator {
    /// Radiance along `st.ray` at the wavelengths of `wl`, continuing the path in `st` bounce by bounce.
    fn trace(
        &self,
        tracer: &mut Tracer,
        st: &mut PathState,
        wl: &mut SampledWavelengths,
        sampler: &mut Sampler,
        mut first_hit: Option<&mut Option<FirstHit>>,
    ) -> SampledSpectrum {
        let scene = tracer.scene;
        let mut l = SampledSpectrum::zero();
        let mnee = self.manifold_nee && scene.media.is_empty();
        loop {
            let d = st.ray.d;
            // Used in place (a move out of the Option copied the ~150-byte record at every hit).
            let mut found = st.ray.intersect(tracer);
            let Some(hit) = found.as_mut() else {
                // Escaped: infinite lights, weighted against the BSDF sample that found them.
                for &li in &scene.infinite_lights {
                    let light = &scene.lights[li as usize];
                    let le = light.le(d, wl);
                    if le.is_black() {
                        continue;
                    }
                    if st.depth.events == 0 || st.specular_bounce {
                        l += st.beta * le;
                    } else {
                        let p_l = scene.light_probability(li) * light.pdf_li_infinite(d);
                        l += st.beta * le * power_heuristic(st.p_b, p_l);
                    }
                }
                break;
            };
            st.ray.attenuate(scene, hit, wl, &mut st.beta);
            // Emission from an area light that was hit.
            if let Some(li) = hit.area_light {
                let light = &scene.lights[li as usize];
                let mut le = light.l_area(hit.p, hit.uv, hit.n, -d, wl);
                if !le.is_black() {
                    if st.depth.events == 0 || st.specular_bounce {
                        if mnee {
                            // Leave out the wavelengths whose path manifold NEE counted at the chain's start.
                            let covered = manifold::covers(tracer, &st.chain, li, (hit.p, hit.n), wl);
                            for (j, c) in covered.into_iter().enumerate() {
                                if c {
                                    le[j] = 0.0;
                                }
                            }
                        }
                        l += st.beta * le;
                    } else {
                        let p_l = scene.light_probability(li) * light.pdf_li_area(st.prev_p, d);
                        l += st.beta * le * power_heuristic(st.p_b, p_l);
                    }
                }
            }
            let (bxdf, u, frame) =
                match begin_camera_bounce(scene, hit, &mut st.ray, wl, sampler, &mut st.depth, &mut first_hit) {
                    // A boundary between media does not count as a bounce.
                    CameraBounce::PassedThrough => {
                        st.chain.end();
                        continue;
                    }
                    CameraBounce::End => break,
                    CameraBounce::Scatter(bxdf, u, frame) => (bxdf, u, frame),
                };
            let hit = &*hit;
            let wo = frame.to_local(-d);
            let v = SurfaceVertex { hit, frame: &frame, bxdf: &bxdf, wo, medium: st.ray.medium };
            // Next-event estimation.
            if !bxdf.is_specular() {
                l += st.beta * sample_direct_light(tracer, &v, wl, &u, DirectLight::Mis);
                if mnee {
                    // Through refracting chains, at most as long as the path could still be.
                    let max_len = (st.depth.max - st.depth.events) as usize;
                    l += st.beta * manifold::estimate(tracer, &v, wl, &u, max_len);
                    st.chain = ChainTrack::start(hit, max_len);
                }
            }
            let mode = TransportMode::Radiance;
            // A dispersive refraction splits the path into one branch per carried wavelength (each at its full
            // density) instead of keeping one of them.
            if self.split_dispersion {
                if let Some(split) = bxdf.sample_dispersive_split(wo, u.lobe, mode) {
                    match split {
                        DispersiveSplit::Reflection(bs) => {
                            let wi = frame.from_local(bs.wi);
                            st.beta *= bs.f * (bs.wi.z.abs() / bs.pdf);
                            if !st.follow(&v, &bs, wi, &u) {
                                break;
                            }
                            continue;
                        }
                        DispersiveSplit::Refraction(branches) => {
                            for (slot, bs) in branches.iter().enumerate() {
                                let Some(bs) = bs else { continue };
                                let mut branch = *st;
                                let mut wl_branch = wl.branch(slot);
                                branch.beta *= bs.f * (bs.wi.z.abs() / bs.pdf);
                                if branch.follow(&v, bs, frame.from_local(bs.wi), &u) {
                                    let lb = self.trace(tracer, &mut branch, &mut wl_branch, sampler, None);
                                    l[slot] += lb[slot];
                                }
                            }
                            break;
                        }
                    }
                }
            }
            // BSDF sampling for the next direction.
            let Some(s) = scatter(&v, -d, &u, mode, wl, &mut st.beta) else { break };
            if !st.follow(&v, &s.bs, s.wi, &u) {
                break;
            }
        }
        l
    }
}

impl Radiance for PathIntegrator {
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
        let o = ray.origin;
        let mut st = PathState {
            ray: PathRay::camera(o, ray.direction, tracer.scene.camera_medium, ray.time).regularizing(self.regularize),
            beta: SampledSpectrum::splat(1.0),
            specular_bounce: false,
            eta_scale: 1.0,
            depth: Depth::new(self.max_depth),
            prev_p: o,
            p_b: 1.0,
            chain: ChainTrack::NONE,
        };
        self.trace(tracer, &mut st, wl, sampler, first_hit)
    }
}

impl Integrate for PathIntegrator {
    fn read(params: &mut IntegratorParams) -> Result<Self, RenderError> {
        let max_depth = params.max_depth()?;
        let split_dispersion = params.entity.params.get_bool("splitdispersion", true)?;
        let manifold_nee = params.entity.params.get_bool("manifoldnee", false)?;
        let regularize = params.regularize()?;
        if manifold_nee && regularize {
            return Err(params.error(
                "'manifoldnee' and 'regularize' cannot be combined: manifold next-event \
                                     estimation finds paths through smooth glass that regularization makes rough",
            ));
        }
        if params.media_scatter {
            params.warnings.push(format!(
                "{}: warning: integrator \"path\" ignores media that scatter or glow (as pbrt-v4's does); \
                 use \"volpath\" to render them",
                params.entity.loc
            ));
        }
        Ok(PathIntegrator { max_depth, split_dispersion, manifold_nee, regularize })
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

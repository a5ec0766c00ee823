//! The unidirectional spectral path tracer: next-event estimation with multiple importance sampling (power
//! heuristic) between light and BSDF sampling, light selection by power, Russian roulette and `maxdepth`
//! (Veach 1997 ch. 9; pbrt-v4 §13.4).

use std::ops::Range;

use film::{Film, FilmError};
use glam::{Vec2, Vec3};
use spectral::{SampledSpectrum, SampledWavelengths};

use super::drive::{finite_or_zero, render_rows, CameraSampler, RenderStats, SurfaceRecords};
use super::manifold::{self, ChainTrack};
use super::transport::{
    begin_bounce, russian_roulette, sample_direct_light, scatter, Bounce, BounceSamples, DirectLight, PathRay,
    RayCounts,
};
use super::{Integrate, IntegratorParams, RenderError, RenderJob};
use crate::bxdf::{BsdfSample, Bxdf, DispersiveSplit, TransportMode};
use crate::sampler::Sampler;
use crate::sampling::{power_heuristic, Frame};
use crate::scene::{RenderScene, SurfaceHit};

/// What the camera ray hit first, for AOVs and the geometry buffer (pbrt-v4's `VisibleSurface`, in world space).
#[derive(Clone, Copy, Debug)]
pub struct FirstHit {
    /// Albedo hint of the surface's BxDF at the path's wavelengths.
    pub albedo: SampledSpectrum,
    /// World-space shading normal.
    pub normal: Vec3,
    /// World-space point.
    pub p: Vec3,
    /// World-space geometric normal.
    pub ng: Vec3,
    /// Surface (u, v).
    pub uv: Vec2,
}

impl FirstHit {
    /// The first hit `hit`, scattering with `bxdf`.
    pub(crate) fn at(hit: &SurfaceHit, bxdf: &Bxdf) -> Self {
        FirstHit { albedo: bxdf.albedo_hint(), normal: hit.ns, p: hit.p, ng: hit.n, uv: hit.uv }
    }
}

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
}

/// A camera-side estimator of radiance: what `CameraPaths` traces into each pixel.
pub trait Radiance: Copy + Send + Sync {
    /// Radiance arriving at the camera along `o + t·d` at `time`, at the wavelengths of `wl` (which a dispersive
    /// surface may reduce to one); `first_hit` hears the first surface the path scatters at, for AOVs.
    #[allow(clippy::too_many_arguments)]
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
    ) -> SampledSpectrum;
}

/// A camera path between two bounces: what a split at a dispersive refraction copies into each branch.
#[derive(Clone, Copy, Debug)]
struct PathState {
    ray: PathRay,
    beta: SampledSpectrum,
    specular_bounce: bool,
    eta_scale: f32,
    depth: u32,
    prev_p: Vec3,
    /// Density of the BSDF sample that chose `ray` (for MIS against light sampling where it lands).
    p_b: f32,
    /// The refractions since the last non-specular vertex (manifold NEE only).
    chain: ChainTrack,
}

impl PathState {
    /// Follows a sampled scattering `bs` (local to `frame`) out of `hit`: throughput, MIS density, the ray leaving
    /// the surface, then Russian roulette. False if the path ends.
    fn follow(
        &mut self,
        bxdf: &Bxdf,
        hit: &SurfaceHit,
        bs: &BsdfSample,
        wi: Vec3,
        wo: Vec3,
        u: &BounceSamples,
    ) -> bool {
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
        self.ray.leave(hit, wi, bs.transmission);
        // Russian roulette on the throughput with refraction's radiance scaling undone.
        if !russian_roulette((self.beta * self.eta_scale).max_value(), self.depth, u, &mut self.beta) {
            return false;
        }
        self.beta.0.iter().all(|v| v.is_finite())
    }
}

impl PathIntegrator {
    /// Radiance along `st.ray` at the wavelengths of `wl`, continuing the path in `st` bounce by bounce.
    #[allow(clippy::too_many_arguments)]
    fn trace(
        &self,
        scene: &RenderScene,
        st: &mut PathState,
        wl: &mut SampledWavelengths,
        sampler: &mut Sampler,
        counts: &mut RayCounts,
        mut first_hit: Option<&mut Option<FirstHit>>,
    ) -> SampledSpectrum {
        let mut l = SampledSpectrum::zero();
        let mnee = self.manifold_nee && scene.media.is_empty();
        loop {
            let d = st.ray.d;
            // Used in place (a move out of the Option copied the ~150-byte record at every hit).
            let mut found = st.ray.intersect(scene, counts);
            let Some(hit) = found.as_mut() else {
                // Escaped: infinite lights, weighted against the BSDF sample that found them.
                for &li in &scene.infinite_lights {
                    let light = &scene.lights[li as usize];
                    let le = light.le(d, wl);
                    if le.is_black() {
                        continue;
                    }
                    if st.depth == 0 || st.specular_bounce {
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
                    if st.depth == 0 || st.specular_bounce {
                        if mnee {
                            // Leave out the wavelengths whose path manifold NEE counted at the chain's start.
                            let covered = manifold::covers(scene, &st.chain, li, hit.p, hit.n, wl, counts);
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
            let (bxdf, u) = match begin_bounce(scene, hit, &mut st.ray, wl, sampler) {
                // A boundary between media does not count as a bounce.
                Bounce::PassedThrough => {
                    st.chain.end();
                    continue;
                }
                Bounce::Stop | Bounce::Absorb => break,
                Bounce::Scatter(bxdf, u) => (bxdf, u),
            };
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
            // Next-event estimation.
            if !bxdf.is_specular() {
                let (mis, medium) = (DirectLight::Mis, st.ray.medium);
                l += st.beta * sample_direct_light(scene, hit, medium, &frame, &bxdf, wo, wl, &u, mis, counts);
                if mnee {
                    // Through refracting chains, at most as long as the path could still be.
                    let max_len = (self.max_depth - st.depth) as usize;
                    l += st.beta * manifold::estimate(scene, hit, &frame, &bxdf, wo, wl, &u, max_len, counts);
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
                            if !st.follow(&bxdf, hit, &bs, wi, wo, &u) {
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
                                if branch.follow(&bxdf, hit, bs, frame.from_local(bs.wi), wo, &u) {
                                    let lb = self.trace(scene, &mut branch, &mut wl_branch, sampler, counts, None);
                                    l[slot] += lb[slot];
                                }
                            }
                            break;
                        }
                    }
                }
            }
            // BSDF sampling for the next direction.
            let Some(s) = scatter(&bxdf, &frame, hit, wo, -d, &u, mode, wl, &mut st.beta) else { break };
            if !st.follow(&bxdf, hit, &s.bs, s.wi, wo, &u) {
                break;
            }
        }
        l
    }
}

impl Radiance for PathIntegrator {
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
        let mut st = PathState {
            ray: PathRay::camera(o, d, scene.camera_medium, time),
            beta: SampledSpectrum::splat(1.0),
            specular_bounce: false,
            eta_scale: 1.0,
            depth: 0,
            prev_p: o,
            p_b: 1.0,
            chain: ChainTrack::NONE,
        };
        self.trace(scene, &mut st, wl, sampler, counts, first_hit)
    }
}

impl Integrate for PathIntegrator {
    fn read(params: &mut IntegratorParams) -> Result<Self, RenderError> {
        let max_depth = params.max_depth()?;
        let split_dispersion = params.entity.params.get_bool("splitdispersion", true)?;
        let manifold_nee = params.entity.params.get_bool("manifoldnee", false)?;
        if params.media_scatter {
            params.warnings.push(format!(
                "{}: warning: integrator \"path\" ignores media that scatter or glow (as pbrt-v4's does); \
                 use \"volpath\" to render them",
                params.entity.loc
            ));
        }
        Ok(PathIntegrator { max_depth, split_dispersion, manifold_nee })
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

/// Camera paths traced into the pixels they start from: the `path` integrator's render, and the directly visible
/// emitters of the light tracer (with `max_depth` 0).
pub(crate) struct CameraPaths<'a, R: Radiance> {
    integrator: R,
    pub(crate) scene: &'a RenderScene,
    pub(crate) camera: CameraSampler,
    pub(crate) seed: u32,
}

impl<'a, R: Radiance> CameraPaths<'a, R> {
    /// Camera paths of `integrator` through `scene` into films like `film`.
    pub fn new(integrator: R, scene: &'a RenderScene, film: &Film, seed: u32) -> Result<Self, FilmError> {
        Ok(Self { integrator, scene, camera: CameraSampler::new(film)?, seed })
    }

    /// Renders samples `samples` of every pixel into `film`, with albedo and normal AOVs and the geometry buffer if
    /// the film keeps them.
    pub fn render(&self, film: &mut Film, samples: Range<u32>, progress: &(dyn Fn(u64) + Sync)) -> RenderStats {
        let surfaces = SurfaceRecords::of(film);
        render_rows(film, samples, progress, &|row, x, samples, counts| {
            let y = row.y();
            for s in samples {
                let mut sampler = Sampler::new(x, y, s, self.seed);
                let cs = self.camera.sample(self.scene, x, y, &mut sampler);
                let mut wl = cs.wl;
                let mut first_hit = None;
                let fh = surfaces.wanted().then_some(&mut first_hit);
                let (o, d, t) = (cs.ray.origin, cs.ray.direction, cs.ray.time);
                let l = finite_or_zero(self.integrator.li(self.scene, o, d, t, &mut wl, &mut sampler, counts, fh));
                let weight = cs.weight as f64;
                row.add_sample(x, &l, &wl, weight);
                if let Some(h) = first_hit {
                    surfaces.record(self.scene, &cs, &h).add_to_row(row, x, weight, Some((&l, &wl)));
                }
            }
        })
    }
}

impl<R: Radiance> RenderJob for CameraPaths<'_, R> {
    fn run(&mut self, film: &mut Film, passes: Range<u32>, progress: &(dyn Fn(u64) + Sync)) -> RenderStats {
        self.render(film, passes, progress)
    }

    fn finish(self: Box<Self>, _film: &mut Film) {}
}

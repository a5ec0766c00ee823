//! The unidirectional spectral path tracer: next-event estimation with multiple importance sampling (power
//! heuristic) between light and BSDF sampling, light selection by power, Russian roulette and `maxdepth`
//! (Veach 1997 ch. 9; pbrt-v4 §13.4).

use std::ops::Range;

use film::{Film, FilmError};
use glam::Vec3;
use scene::SceneError;
use spectral::{SampledSpectrum, SampledWavelengths};

use super::drive::{finite_or_zero, render_rows, CameraSampler, RenderStats};
use super::transport::{
    begin_bounce, russian_roulette, sample_direct_light, scatter, Bounce, DirectLight, PathRay, RayCounts,
};
use super::{Integrate, IntegratorParams, RenderJob};
use crate::bxdf::TransportMode;
use crate::sampler::Sampler;
use crate::sampling::{power_heuristic, Frame};
use crate::scene::RenderScene;

/// What the camera ray hit first, for AOVs.
#[derive(Clone, Copy, Debug)]
pub struct FirstHit {
    /// Albedo hint of the surface's BxDF at the path's wavelengths.
    pub albedo: SampledSpectrum,
    /// World-space shading normal.
    pub normal: Vec3,
}

/// The `path` integrator.
#[derive(Clone, Copy, Debug)]
pub struct PathIntegrator {
    /// Maximum number of scattering events (pbrt's `maxdepth`, default 5).
    pub max_depth: u32,
}

/// A camera-side estimator of radiance: what [`CameraPaths`] traces into each pixel.
pub trait Radiance: Copy + Send + Sync {
    /// Radiance arriving at the camera along `o + t·d`, at the wavelengths of `wl` (which a dispersive surface may
    /// reduce to one); `first_hit` hears the first surface the path scatters at, for AOVs.
    #[allow(clippy::too_many_arguments)]
    fn li(
        &self,
        scene: &RenderScene,
        o: Vec3,
        d: Vec3,
        wl: &mut SampledWavelengths,
        sampler: &mut Sampler,
        counts: &mut RayCounts,
        first_hit: Option<&mut Option<FirstHit>>,
    ) -> SampledSpectrum;
}

impl Radiance for PathIntegrator {
    fn li(
        &self,
        scene: &RenderScene,
        o: Vec3,
        d: Vec3,
        wl: &mut SampledWavelengths,
        sampler: &mut Sampler,
        counts: &mut RayCounts,
        mut first_hit: Option<&mut Option<FirstHit>>,
    ) -> SampledSpectrum {
        let mut l = SampledSpectrum::zero();
        let mut beta = SampledSpectrum::splat(1.0);
        let mut specular_bounce = false;
        let mut eta_scale = 1.0f32;
        let mut depth = 0u32;
        let mut prev_p = o;
        let mut p_b = 1.0f32;
        let mut ray = PathRay::new(o, d, scene.camera_medium);
        loop {
            let d = ray.d;
            let Some(mut hit) = ray.intersect(scene, counts) else {
                // Escaped: infinite lights, weighted against the BSDF sample that found them.
                for &li in &scene.infinite_lights {
                    let light = &scene.lights[li as usize];
                    let le = light.le(d, wl);
                    if le.is_black() {
                        continue;
                    }
                    if depth == 0 || specular_bounce {
                        l += beta * le;
                    } else {
                        let p_l = scene.light_probability(li) * light.pdf_li_infinite(d);
                        l += beta * le * power_heuristic(p_b, p_l);
                    }
                }
                break;
            };
            ray.attenuate(scene, &hit, wl, &mut beta);
            // Emission from an area light that was hit.
            if let Some(li) = hit.area_light {
                let light = &scene.lights[li as usize];
                let le = light.l_area(hit.n, -d, wl);
                if !le.is_black() {
                    if depth == 0 || specular_bounce {
                        l += beta * le;
                    } else {
                        let p_l = scene.light_probability(li) * light.pdf_li_area(prev_p, d);
                        l += beta * le * power_heuristic(p_b, p_l);
                    }
                }
            }
            let (bxdf, u) = match begin_bounce(scene, &mut hit, &mut ray, wl, sampler) {
                // A boundary between media does not count as a bounce.
                Bounce::PassedThrough => continue,
                Bounce::Stop | Bounce::Absorb => break,
                Bounce::Scatter(bxdf, u) => (bxdf, u),
            };
            if depth == 0 {
                if let Some(fh) = first_hit.take() {
                    *fh = Some(FirstHit { albedo: bxdf.albedo_hint(), normal: hit.ns });
                }
            }
            if depth == self.max_depth {
                break;
            }
            depth += 1;
            let frame = Frame::from_z_and_tangent(hit.ns, hit.dpdu);
            let wo = frame.to_local(-d);
            // Next-event estimation.
            if !bxdf.is_specular() {
                l += beta * sample_direct_light(scene, &hit, &frame, &bxdf, wo, wl, &u, DirectLight::Mis, counts);
            }
            // BSDF sampling for the next direction.
            let mode = TransportMode::Radiance;
            let Some(s) = scatter(&bxdf, &frame, &hit, wo, -d, &u, mode, wl, &mut beta) else { break };
            p_b = if s.bs.pdf_is_proportional { bxdf.pdf(wo, s.bs.wi, mode) } else { s.bs.pdf };
            specular_bounce = s.bs.specular;
            if s.bs.transmission {
                eta_scale *= s.bs.eta * s.bs.eta;
            }
            prev_p = hit.p;
            ray.leave(&hit, s.wi, s.bs.transmission);
            // Russian roulette on the throughput with refraction's radiance scaling undone.
            if !russian_roulette((beta * eta_scale).max_value(), depth, &u, &mut beta) {
                break;
            }
            if !beta.0.iter().all(|v| v.is_finite()) {
                break;
            }
        }
        l
    }
}

impl Integrate for PathIntegrator {
    fn read(params: &mut IntegratorParams) -> Result<Self, SceneError> {
        let max_depth = params.max_depth()?;
        if params.media_scatter {
            params.warnings.push(format!(
                "{}: warning: integrator \"path\" ignores media that scatter or glow (as pbrt-v4's does); \
                 use \"volpath\" to render them",
                params.entity.loc
            ));
        }
        Ok(PathIntegrator { max_depth })
    }

    fn begin<'a>(
        &'a self,
        scene: &'a RenderScene,
        film: &Film,
        seed: u32,
    ) -> Result<Box<dyn RenderJob + 'a>, FilmError> {
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

    /// Renders samples `samples` of every pixel into `film`, with albedo and normal AOVs if the film keeps them.
    pub fn render(&self, film: &mut Film, samples: Range<u32>, progress: &(dyn Fn(u64) + Sync)) -> RenderStats {
        let aovs = film.has_aovs();
        render_rows(film, samples, progress, &|row, x, samples, counts| {
            let y = row.y();
            for s in samples {
                let mut sampler = Sampler::new(x, y, s, self.seed);
                let cs = self.camera.sample(self.scene, x, y, &mut sampler);
                let mut wl = cs.wl;
                let mut first_hit = None;
                let fh = aovs.then_some(&mut first_hit);
                let (o, d) = (cs.ray.origin, cs.ray.direction);
                let l = finite_or_zero(self.integrator.li(self.scene, o, d, &mut wl, &mut sampler, counts, fh));
                row.add_sample(x, &l, &wl, cs.weight as f64);
                // The albedo is seen at the wavelengths the camera ray started with.
                if let Some(h) = first_hit {
                    let n = [h.normal.x as f64, h.normal.y as f64, h.normal.z as f64];
                    row.add_albedo(x, &h.albedo, &cs.wl, n);
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

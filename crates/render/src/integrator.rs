//! The unidirectional spectral path tracer: next-event estimation with multiple importance sampling (power
//! heuristic) between light and BSDF sampling, light selection by power, Russian roulette and `maxdepth`
//! (Veach 1997 ch. 9; pbrt-v4 §13.4).

use glam::{Vec2, Vec3};
use spectral::{SampledSpectrum, SampledWavelengths};

use crate::bxdf::{Bxdf, TransportMode};
use crate::light::LightSampleContext;
use crate::material::Material;
use crate::sampler::Sampler;
use crate::sampling::{power_heuristic, Frame};
use crate::scene::{RenderScene, SurfaceHit, NO_MATERIAL};
use crate::texture::TextureEvalContext;

/// Dimensions each bounce draws, so that a given bounce always uses the same Sobol dimensions.
const DIMS_PER_BOUNCE: u32 = 9;

/// Counters for statistics.
#[derive(Clone, Copy, Debug, Default)]
pub struct RayCounts {
    /// Closest-hit rays.
    pub intersect: u64,
    /// Shadow rays.
    pub shadow: u64,
}

/// What the camera ray hit first, for AOVs.
#[derive(Clone, Copy, Debug)]
pub struct FirstHit {
    /// Albedo hint of the surface's BxDF at the path's wavelengths.
    pub albedo: SampledSpectrum,
    /// World-space shading normal.
    pub normal: Vec3,
}

/// The integrators the renderer can run, chosen by the scene's `Integrator` directive.
#[derive(Clone, Copy, Debug)]
pub enum Integrator {
    /// Unidirectional path tracing from the camera.
    Path(PathIntegrator),
    /// Particle tracing from the lights, splatted onto the film.
    LightPath(crate::lightpath::LightPathIntegrator),
    /// Stochastic progressive photon mapping; the render's sample count is its number of iterations.
    Sppm(crate::sppm::SppmIntegrator),
    /// Bidirectional path tracing with MIS over all connection strategies.
    Bdpt(crate::bdpt::BdptIntegrator),
}

impl Integrator {
    /// The integrator's name in a scene file.
    pub fn name(&self) -> &'static str {
        match self {
            Integrator::Path(_) => "path",
            Integrator::LightPath(_) => "lightpath",
            Integrator::Sppm(_) => "sppm",
            Integrator::Bdpt(_) => "bdpt",
        }
    }
}

/// The `path` integrator.
#[derive(Clone, Copy, Debug)]
pub struct PathIntegrator {
    /// Maximum number of scattering events (pbrt's `maxdepth`, default 5).
    pub max_depth: u32,
}

impl PathIntegrator {
    /// Radiance arriving at the camera along `o + t·d`, at the wavelengths of `wl` (which a dispersive surface may
    /// reduce to one).
    #[allow(clippy::too_many_arguments)]
    pub fn li(
        &self,
        scene: &RenderScene,
        mut o: Vec3,
        mut d: Vec3,
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
        let mut medium = scene.camera_medium;
        let mut crossings = 0u32;
        loop {
            counts.intersect += 1;
            let hit = scene.geometry.intersect(o, d, f32::INFINITY);
            let Some(hit) = hit else {
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
            if let Some(m) = medium {
                beta *= scene.media[m as usize].transmittance(hit.t, wl);
            }
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
            // Resolve the material (mixes choose one stochastically); interfaces are skipped.
            let mut u = [0.0f32; DIMS_PER_BOUNCE as usize];
            for v in u.iter_mut() {
                *v = sampler.next_1d();
            }
            let bxdf = match resolve_surface(scene, &hit, wl, u[7], u[8]) {
                Surface::PassThrough => {
                    // Pass straight through, switching media; does not count as a bounce.
                    if !cross_boundary(&hit, d, &mut medium, &mut o, &mut crossings) {
                        break;
                    }
                    continue;
                }
                Surface::Absorb => break,
                Surface::Scatter(b) => b,
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
                l += beta * self.sample_ld(scene, &hit, &frame, &bxdf, wo, wl, u[0], Vec2::new(u[1], u[2]), counts);
            }
            // BSDF sampling for the next direction.
            let Some(bs) = bxdf.sample_f(wo, u[3], Vec2::new(u[4], u[5]), TransportMode::Radiance) else { break };
            if bs.pdf <= 0.0 || bs.f.is_black() {
                break;
            }
            if let Some(slot) = bs.keep_slot {
                wl.keep_only(slot);
            }
            let wi = frame.from_local(bs.wi);
            beta *= bs.f * (bs.wi.z.abs() / bs.pdf);
            p_b = if bs.pdf_is_proportional { bxdf.pdf(wo, bs.wi, TransportMode::Radiance) } else { bs.pdf };
            specular_bounce = bs.specular;
            if bs.transmission {
                eta_scale *= bs.eta * bs.eta;
                medium = next_medium(&hit, wi, medium);
            }
            prev_p = hit.p;
            o = hit.spawn_origin(wi);
            d = wi;
            // Russian roulette on the throughput with refraction's radiance scaling undone.
            let rr_beta = (beta * eta_scale).max_value();
            if rr_beta < 1.0 && depth > 1 {
                let q = (1.0 - rr_beta).max(0.0);
                if u[6] < q {
                    break;
                }
                beta *= 1.0 / (1.0 - q);
            }
            if !beta.0.iter().all(|v| v.is_finite()) {
                break;
            }
        }
        l
    }

    #[allow(clippy::too_many_arguments)]
    pub(crate) fn sample_ld(
        &self,
        scene: &RenderScene,
        hit: &SurfaceHit,
        frame: &Frame,
        bxdf: &Bxdf,
        wo: Vec3,
        wl: &SampledWavelengths,
        u_light: f32,
        u: Vec2,
        counts: &mut RayCounts,
    ) -> SampledSpectrum {
        let Some((li, p_sel)) = scene.sample_light(u_light) else { return SampledSpectrum::zero() };
        let light = &scene.lights[li as usize];
        let ctx = LightSampleContext { p: hit.p, n: hit.n };
        let Some(ls) = light.sample_li(&ctx, u, wl) else { return SampledSpectrum::zero() };
        if ls.pdf <= 0.0 || ls.l.is_black() {
            return SampledSpectrum::zero();
        }
        let wi_local = frame.to_local(ls.wi);
        let f = bxdf.f(wo, wi_local, TransportMode::Radiance) * wi_local.z.abs();
        if f.is_black() {
            return SampledSpectrum::zero();
        }
        let origin = hit.spawn_origin(ls.wi);
        counts.shadow += 1;
        // Stop just short of the light's surface (pbrt's ShadowEpsilon, relative).
        let t_max = if ls.dist.is_finite() { (ls.p - origin).length() * (1.0 - 1e-4) } else { f32::INFINITY };
        if scene.geometry.occluded(origin, ls.wi, t_max) {
            return SampledSpectrum::zero();
        }
        let p_l = p_sel * ls.pdf;
        if ls.delta {
            f * ls.l * (1.0 / p_l)
        } else {
            let p_b = bxdf.pdf(wo, wi_local, TransportMode::Radiance);
            f * ls.l * (power_heuristic(p_l, p_b) / p_l)
        }
    }
}

/// Longest run of material-less boundary crossings a path follows before it is dropped.
const MAX_CROSSINGS: u32 = 256;

/// Carries a path straight through a material-less boundary at `hit` (a change of medium only): updates the
/// medium and the ray origin and counts the crossing. Returns false once the path has crossed too many boundaries
/// and should be dropped.
pub(crate) fn cross_boundary(
    hit: &SurfaceHit,
    d: Vec3,
    medium: &mut Option<u32>,
    o: &mut Vec3,
    crossings: &mut u32,
) -> bool {
    *medium = next_medium(hit, d, *medium);
    *o = hit.spawn_origin(d);
    *crossings += 1;
    *crossings <= MAX_CROSSINGS
}

/// What a ray meets at a surface once mixes are resolved.
pub(crate) enum Surface {
    /// A boundary between media without a material: the ray goes on unchanged.
    PassThrough,
    /// A material that scatters nothing at these wavelengths.
    Absorb,
    /// The BxDF to scatter with.
    Scatter(Bxdf),
}

/// Resolves the material at `hit` (a mix picks one of its materials with `u_mix`, repeatedly) and builds its BxDF
/// at the path's wavelengths (`u_bxdf` for materials that reduce the wavelengths up front).
pub(crate) fn resolve_surface(
    scene: &RenderScene,
    hit: &SurfaceHit,
    wl: &mut SampledWavelengths,
    mut u_mix: f32,
    u_bxdf: f32,
) -> Surface {
    let mut material_index = hit.material;
    while material_index != NO_MATERIAL {
        if let Material::Mix { materials, amount } = &scene.materials[material_index as usize] {
            let a = amount.eval(&TextureEvalContext { uv: hit.uv, p: hit.p }).clamp(0.0, 1.0);
            let pick = if u_mix < a { 1 } else { 0 };
            u_mix = if pick == 1 { u_mix / a.max(1e-6) } else { (u_mix - a) / (1.0 - a).max(1e-6) };
            material_index = materials[pick];
        } else {
            break;
        }
    }
    if material_index == NO_MATERIAL {
        return Surface::PassThrough;
    }
    let ctx = TextureEvalContext { uv: hit.uv, p: hit.p };
    match scene.materials[material_index as usize].bxdf(&ctx, wl, u_bxdf) {
        Some(b) => Surface::Scatter(b),
        None => Surface::Absorb,
    }
}

/// The medium a ray enters when it leaves `hit` in direction `d` (unchanged if the surface has no interface).
pub(crate) fn next_medium(hit: &SurfaceHit, d: Vec3, current: Option<u32>) -> Option<u32> {
    match hit.media {
        Some(mi) => {
            if d.dot(hit.n) < 0.0 {
                mi.inside
            } else {
                mi.outside
            }
        }
        None => current,
    }
}

//! What every integrator does along a path, written once: ray counters, resolving the material at a hit (mixes,
//! material-less boundaries, absorption), crossing boundaries between media, and next-event estimation.

use glam::{Vec2, Vec3};
use spectral::{SampledSpectrum, SampledWavelengths};

use crate::bxdf::{Bxdf, TransportMode};
use crate::light::LightSampleContext;
use crate::material::Material;
use crate::sampling::{power_heuristic, Frame};
use crate::scene::{RenderScene, SurfaceHit, NO_MATERIAL};
use crate::texture::TextureEvalContext;

/// Counters for statistics.
#[derive(Clone, Copy, Debug, Default)]
pub struct RayCounts {
    /// Closest-hit rays.
    pub intersect: u64,
    /// Shadow rays.
    pub shadow: u64,
}

/// Next-event estimation at a surface: picks a light with `u_light`, samples a point on it with `u`, and returns
/// its contribution `f·|cos|·L / p` weighted by the power heuristic against BSDF sampling (Veach 1997 §9.2; delta
/// lights unweighted), or zero if occluded.
#[allow(clippy::too_many_arguments)]
pub(crate) fn sample_direct_light(
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

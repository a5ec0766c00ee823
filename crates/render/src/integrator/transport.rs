//! What every integrator does along a path, written once: the tracer (the scene and the counts of the rays traced
//! in it), the ray and the medium it travels through, the agreed layout of random numbers per bounce, the start of
//! a bounce (resolving the material at a hit: mixes, material-less boundaries, absorption), one scattering step
//! (BSDF sample, wavelength reduction, throughput), shadow rays, and next-event estimation where media only absorb.

use glam::{Vec2, Vec3};
use spectral::{SampledSpectrum, SampledWavelengths};

use crate::bxdf::{BsdfSample, Bxdf, TransportMode};
use crate::light::LightSampleContext;
use crate::material::Material;
use crate::sampler::Sampler;
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

/// The scene paths are traced through and the counters of the rays traced in it: the context every step of every
/// integrator takes first. One per unit of parallel work (a row, a batch of photons); its counts go into the
/// render's statistics.
pub(crate) struct Tracer<'a> {
    /// The scene.
    pub scene: &'a RenderScene,
    /// Rays traced so far.
    pub counts: RayCounts,
}

impl<'a> Tracer<'a> {
    /// A tracer through `scene` that has traced nothing yet.
    pub fn new(scene: &'a RenderScene) -> Self {
        Self { scene, counts: RayCounts::default() }
    }

    /// The rays traced, closest hit and shadow.
    pub fn rays(&self) -> u64 {
        self.counts.intersect + self.counts.shadow
    }

    /// Whether a shadow ray from `o` along `d` meets a surface before `t_max` at `time`, counted.
    #[inline]
    pub fn occluded(&mut self, o: Vec3, d: Vec3, t_max: f32, time: f32) -> bool {
        self.counts.shadow += 1;
        self.scene.geometry.occluded(o, d, t_max, time)
    }

    /// The closest surface a shadow ray from `o` along `d` meets before `t_max` at `time`, counted as a shadow ray
    /// (for shadow rays that cross media and material-less boundaries segment by segment).
    #[inline]
    pub fn shadow_hit(&mut self, o: Vec3, d: Vec3, t_max: f32, time: f32) -> Option<SurfaceHit> {
        self.counts.shadow += 1;
        self.scene.geometry.intersect(o, d, t_max, time)
    }
}

/// A surface where a path scatters, as next-event estimation and BSDF sampling read it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SurfaceVertex<'a> {
    /// The hit (its shading frame already tilted by a bump or normal map).
    pub hit: &'a SurfaceHit,
    /// The shading frame.
    pub frame: &'a Frame,
    /// The BxDF at the path's wavelengths.
    pub bxdf: &'a Bxdf,
    /// Unit direction back along the path, in the shading frame.
    pub wo: Vec3,
    /// The medium the path arrived through (a shadow ray leaves into the medium on its own side of an interface).
    pub medium: Option<u32>,
}

/// How next-event estimation shares direct light with BSDF (or phase-function) sampling.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum DirectLight {
    /// The caller also finds emitters by BSDF sampling: weight by the power heuristic (Veach 1997 §9.2) in
    /// [`sample_direct_light`], by the balance heuristic over the carried wavelengths in `volume::sample_ld`.
    Mis,
    /// Light sampling is the only estimate of direct light at this vertex (photon mapping's visible points, whose
    /// photons count from their second bounce): unweighted.
    LightSamplingOnly,
}

/// Next-event estimation at a surface reached through `medium`: picks a light and a point on it with the bounce's
/// connection numbers, and returns its contribution `f·|cos|·L·Tr / p` (weighted as `weighting` says; delta lights
/// always unweighted), or zero if occluded. Tr is the Beer–Lambert transmittance of the media that only absorb
/// along the shadow ray, which starts in the medium on the light's side of the surface (see
/// [`absorbing_transmittance`]).
pub(crate) fn sample_direct_light(
    tracer: &mut Tracer,
    v: &SurfaceVertex,
    wl: &SampledWavelengths,
    u: &BounceSamples,
    weighting: DirectLight,
) -> SampledSpectrum {
    let scene = tracer.scene;
    let SurfaceVertex { hit, frame, bxdf, wo, medium } = *v;
    let [u_light, u0, u1] = u.connect;
    let u = Vec2::new(u0, u1);
    let Some((li, p_sel)) = scene.sample_light(u_light) else { return SampledSpectrum::zero() };
    let light = &scene.lights[li as usize];
    let ctx = LightSampleContext { p: hit.p };
    let Some(ls) = light.sample_li(&ctx, u, wl) else { return SampledSpectrum::zero() };
    if ls.pdf <= 0.0 || ls.l.is_black() {
        return SampledSpectrum::zero();
    }
    let wi_local = frame.to_local(ls.wi);
    // The density is needed only if the shadow ray is clear (and for MIS): computed now only where it comes with
    // the value at little cost.
    let (f, joint_pdf) = if bxdf.joint_f_pdf() {
        let (f, pdf) = bxdf.f_pdf(wo, wi_local, TransportMode::Radiance);
        (f, Some(pdf))
    } else {
        (bxdf.f(wo, wi_local, TransportMode::Radiance), None)
    };
    let f = f * wi_local.z.abs();
    if f.is_black() {
        return SampledSpectrum::zero();
    }
    let origin = hit.spawn_origin(ls.wi);
    let f = if scene.media.is_empty() {
        // Stop just short of the light's surface (pbrt's ShadowEpsilon, relative).
        let t_max = if ls.dist.is_finite() { (ls.p - origin).length() * (1.0 - 1e-4) } else { f32::INFINITY };
        if tracer.occluded(origin, ls.wi, t_max, hit.time) {
            return SampledSpectrum::zero();
        }
        f
    } else {
        let target = if ls.dist.is_finite() { ShadowTarget::Point(ls.p) } else { ShadowTarget::Direction(ls.wi) };
        let medium = next_medium(hit, ls.wi, medium);
        let ray = ShadowRay { origin, target, medium, time: hit.time };
        let Some(tr) = absorbing_transmittance(tracer, ray, wl) else {
            return SampledSpectrum::zero();
        };
        f * tr
    };
    let p_l = p_sel * ls.pdf;
    if ls.delta || weighting == DirectLight::LightSamplingOnly {
        f * ls.l * (1.0 / p_l)
    } else {
        let p_b = joint_pdf.unwrap_or_else(|| bxdf.pdf(wo, wi_local, TransportMode::Radiance));
        f * ls.l * (power_heuristic(p_l, p_b) / p_l)
    }
}

/// The transmittance of shadow ray `ray` for the integrators that render only media that absorb (`path`, and photon
/// mapping's camera paths where no medium scatters): `None` if a surface with a material blocks it, otherwise the
/// product of exp(−σa·d) over the absorbing media it crosses, through material-less boundaries. Media that scatter
/// count as vacuum, as they do along these integrators' paths ([`PathRay::attenuate`]).
fn absorbing_transmittance(tracer: &mut Tracer, ray: ShadowRay, wl: &SampledWavelengths) -> Option<SampledSpectrum> {
    let scene = tracer.scene;
    let ShadowRay { mut origin, target, mut medium, time } = ray;
    let mut tr = SampledSpectrum::splat(1.0);
    for _ in 0..=MAX_SHADOW_CROSSINGS {
        let (d, t_max) = target.segment_from(origin);
        if t_max.is_nan() || t_max <= 0.0 {
            return Some(tr);
        }
        let hit = tracer.shadow_hit(origin, d, t_max, time);
        if hit.is_some_and(|h| h.material != NO_MATERIAL) {
            return None;
        }
        if let Some(m) = medium {
            tr *= scene.media[m as usize].absorption_transmittance(hit.map_or(t_max, |h| h.t), wl);
        }
        let Some(h) = hit else { return Some(tr) };
        medium = next_medium(&h, d, medium);
        origin = h.spawn_origin(d);
    }
    None
}

/// Longest run of material-less boundary crossings a path follows before it is dropped.
const MAX_CROSSINGS: u32 = 256;

/// The random numbers of one bounce, drawn together and always in this order (the agreed layout of every
/// integrator), so that bounce k of a path uses the same sampler dimensions whatever happened before and whatever
/// the integrator: Sobol dimensions stay stratified bounce by bounce.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BounceSamples {
    /// The connection made at this vertex: a light and a point on it for next-event estimation (path, sppm's
    /// camera paths), or a point on the lens (light tracing; the first two).
    pub connect: [f32; 3],
    /// The BSDF's lobe choice.
    pub lobe: f32,
    /// The BSDF's direction.
    pub dir: Vec2,
    /// Russian roulette.
    pub rr: f32,
    /// The choice of a mix's material (and of a nested mix's, rescaled).
    pub mix: f32,
    /// The wavelength kept by a material that must reduce the wavelengths up front (rough dispersive dielectrics).
    pub wavelength: f32,
}

impl BounceSamples {
    /// Dimensions drawn per bounce.
    pub const DIMENSIONS: usize = 9;

    /// Draws the next bounce's numbers from `sampler`.
    #[inline]
    pub fn draw(sampler: &mut Sampler) -> Self {
        let u: [f32; Self::DIMENSIONS] = std::array::from_fn(|_| sampler.next_1d());
        Self {
            connect: [u[0], u[1], u[2]],
            lobe: u[3],
            dir: Vec2::new(u[4], u[5]),
            rr: u[6],
            mix: u[7],
            wavelength: u[8],
        }
    }
}

/// A ray of a path with the medium it travels through: every integrator follows one from surface to surface.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PathRay {
    /// Origin (offset off the surface it leaves).
    pub o: Vec3,
    /// Unit direction.
    pub d: Vec3,
    /// The medium along the ray (`None` for vacuum).
    pub medium: Option<u32>,
    /// The path's time (within the shutter interval): every ray of a path is traced at the time of its first.
    pub time: f32,
    /// Material-less boundaries crossed in a row.
    crossings: u32,
    /// For a camera ray (also after crossing material-less boundaries), the lens point it left from: its hits take
    /// their texture footprints from the camera ray's differentials.
    camera_origin: Option<Vec3>,
    /// Whether the path regularizes the BSDFs it meets after its first non-specular scattering (pbrt-v4's
    /// `"bool regularize"` of `path`, `volpath` and `bdpt`).
    regularize: bool,
    /// Whether the path has scattered non-specularly (at a surface or in a medium) before this ray.
    after_non_specular: bool,
}

impl PathRay {
    /// A ray from `o` along `d` in `medium`, at `time`.
    #[inline]
    pub fn new(o: Vec3, d: Vec3, medium: Option<u32>, time: f32) -> Self {
        Self { o, d, medium, time, crossings: 0, camera_origin: None, regularize: false, after_non_specular: false }
    }

    /// The ray of a path that regularizes near-specular BSDFs once it has scattered non-specularly (`on`).
    #[inline]
    pub fn regularizing(self, on: bool) -> Self {
        Self { regularize: on, ..self }
    }

    /// Whether the BSDF at this ray's next hit is regularized.
    #[inline]
    fn regularizes(&self) -> bool {
        self.regularize && self.after_non_specular
    }

    /// Continues the path from a scattering in a medium at `p` in direction `wi` (same medium and time).
    #[inline]
    pub fn scatter_in_medium(&mut self, p: Vec3, wi: Vec3) {
        *self =
            Self { after_non_specular: true, ..Self::new(p, wi, self.medium, self.time) }.regularizing(self.regularize);
    }

    /// The camera ray from lens point `o` along `d` in `medium`, at `time`.
    #[inline]
    pub fn camera(o: Vec3, d: Vec3, medium: Option<u32>, time: f32) -> Self {
        Self { camera_origin: Some(o), ..Self::new(o, d, medium, time) }
    }

    /// The camera ray this ray continues (lens point and direction), if it is one.
    #[inline]
    fn camera_ray(&self) -> Option<(Vec3, Vec3)> {
        self.camera_origin.map(|o| (o, self.d))
    }

    /// The closest surface along the ray, counted in `counts`.
    #[inline]
    pub fn intersect(&self, tracer: &mut Tracer) -> Option<SurfaceHit> {
        tracer.counts.intersect += 1;
        tracer.scene.geometry.intersect(self.o, self.d, f32::INFINITY, self.time)
    }

    /// Multiplies `beta` by the medium's transmittance over the segment to `hit` (Beer–Lambert).
    #[inline]
    pub fn attenuate(
        &self,
        scene: &RenderScene,
        hit: &SurfaceHit,
        wl: &SampledWavelengths,
        beta: &mut SampledSpectrum,
    ) {
        if let Some(m) = self.medium {
            *beta *= scene.media[m as usize].absorption_transmittance(hit.t, wl);
        }
    }

    /// Carries the ray straight through a material-less boundary at `hit` (a change of medium only). Returns
    /// false once the path has crossed too many boundaries in a row and should be dropped.
    #[inline]
    fn cross(&mut self, hit: &SurfaceHit) -> bool {
        self.medium = next_medium(hit, self.d, self.medium);
        self.o = hit.spawn_origin(self.d);
        self.crossings += 1;
        self.crossings <= MAX_CROSSINGS
    }

    /// Continues the path from `hit` in direction `wi`, reflected or transmitted (by a `specular` lobe or not), in
    /// the medium on the side `wi` leaves into ([`next_medium`]).
    #[inline]
    pub fn leave(&mut self, hit: &SurfaceHit, wi: Vec3, specular: bool) {
        self.after_non_specular |= !specular;
        self.medium = next_medium(hit, wi, self.medium);
        self.o = hit.spawn_origin(wi);
        self.d = wi;
        self.camera_origin = None;
    }
}

/// What the start of a bounce found at a surface.
pub(crate) enum Bounce {
    /// A material-less boundary: the ray was carried through it; trace on (this is not a scattering event).
    PassedThrough,
    /// The path ends here: too many boundaries crossed in a row.
    Stop,
    /// The path ends here: the material scatters nothing at these wavelengths (the surface is still a vertex, which
    /// may emit).
    Absorb,
    /// A scattering surface with its BxDF at the path's wavelengths, and the bounce's random numbers.
    Scatter(Bxdf, BounceSamples),
}

/// The start of every bounce at a surface, for every integrator: draws the bounce's random numbers (always all of
/// them, see [`BounceSamples`]), resolves the material at `hit` (mixes, wavelength reduction up front; its bump or
/// normal map tilts `hit`'s shading frame), and carries the ray through material-less boundaries. Always inlined
/// into the integrators' bounce loops, which then take fewer instructions per bounce (BENCHMARKS.md, "The
/// integrators on shared ground").
#[inline(always)]
pub(crate) fn begin_bounce(
    scene: &RenderScene,
    hit: &mut SurfaceHit,
    ray: &mut PathRay,
    wl: &mut SampledWavelengths,
    sampler: &mut Sampler,
) -> Bounce {
    let u = BounceSamples::draw(sampler);
    match resolve_surface(scene, hit, ray.camera_ray(), wl, u.mix, u.wavelength, ray.regularizes()) {
        Surface::PassThrough => {
            if ray.cross(hit) {
                Bounce::PassedThrough
            } else {
                Bounce::Stop
            }
        }
        Surface::Absorb => Bounce::Absorb,
        Surface::Scatter(bxdf) => Bounce::Scatter(bxdf, u),
    }
}

/// Russian roulette (pbrt-v4 §13.4.2): from the second bounce on, a path whose throughput has fallen to
/// `ratio` < 1 of its start survives with probability `ratio` and is reweighted by its inverse. Returns false if the
/// path ends.
#[inline]
pub(crate) fn russian_roulette(ratio: f32, depth: u32, u: &BounceSamples, beta: &mut SampledSpectrum) -> bool {
    if ratio < 1.0 && depth > 1 {
        let q = (1.0 - ratio).max(0.0);
        if u.rr < q {
            return false;
        }
        *beta *= 1.0 / (1.0 - q);
    }
    true
}

/// A direction sampled from a BSDF at a path vertex.
pub(crate) struct Scattered {
    /// The BSDF sample (local frame).
    pub bs: BsdfSample,
    /// The new direction in world space.
    pub wi: Vec3,
}

/// One scattering step, the same for camera and light paths: samples the BxDF at vertex `v` (`w_from` the
/// direction back along the path in world space) with the bounce's numbers, keeps only the
/// followed wavelength after a dispersive refraction, and multiplies the throughput `beta` by f·|cos|/pdf — for
/// light paths with the adjoint BSDF's shading-normal correction |wo·ns||wi·ng|/|wo·ng| in place of |cos|
/// (Veach 1997 eq. 5.19). `None` if the sample carries no energy.
#[inline]
pub(crate) fn scatter(
    v: &SurfaceVertex,
    w_from: Vec3,
    u: &BounceSamples,
    mode: TransportMode,
    wl: &mut SampledWavelengths,
    beta: &mut SampledSpectrum,
) -> Option<Scattered> {
    let SurfaceVertex { hit, frame, bxdf, wo, .. } = *v;
    let bs = bxdf.sample_f(wo, u.lobe, u.dir, mode)?;
    if bs.pdf <= 0.0 || bs.f.is_black() {
        return None;
    }
    if let Some(slot) = bs.keep_slot {
        wl.keep_only(slot);
    }
    let wi = frame.from_local(bs.wi);
    let cos = match mode {
        TransportMode::Radiance => bs.wi.z.abs(),
        TransportMode::Importance => adjoint_cos(w_from, wi, hit.ns, hit.n),
    };
    *beta *= bs.f * (cos / bs.pdf);
    Some(Scattered { bs, wi })
}

/// The adjoint BSDF's shading-normal correction times the cosine at the outgoing direction: for particle tracing
/// with shading normals, `|wo·ns|·|wi·ng| / |wo·ng|` replaces `|wi·ns|` (Veach 1997 eq. 5.19), so that light and
/// importance transport agree on meshes with interpolated normals.
#[inline]
pub(crate) fn adjoint_cos(wo: Vec3, wi: Vec3, ns: Vec3, ng: Vec3) -> f32 {
    let den = wo.dot(ng).abs();
    if den == 0.0 {
        return 0.0;
    }
    wo.dot(ns).abs() * wi.dot(ng).abs() / den
}

/// What a ray meets at a surface once mixes are resolved.
enum Surface {
    /// A boundary between media without a material: the ray goes on unchanged.
    PassThrough,
    /// A material that scatters nothing at these wavelengths.
    Absorb,
    /// The BxDF to scatter with.
    Scatter(Bxdf),
}

/// Resolves the material at `hit` (a mix picks one of its materials with `u_mix`, repeatedly), applies the chosen
/// material's bump or normal map to `hit`'s shading frame (pbrt-v4 does it for the material a mix chose), and builds
/// its BxDF at the path's wavelengths (`u_bxdf` for materials that reduce the wavelengths up front), regularized if
/// `regularize`. Textures see the hit's footprint if the material reads it (`camera_ray`: the camera ray that found
/// the hit, if it was one).
#[inline]
fn resolve_surface(
    scene: &RenderScene,
    hit: &mut SurfaceHit,
    camera_ray: Option<(Vec3, Vec3)>,
    wl: &mut SampledWavelengths,
    mut u_mix: f32,
    u_bxdf: f32,
    regularize: bool,
) -> Surface {
    // Bump and normal maps below change the shading frame only, not the point, normal and (u, v) textures see.
    let ctx = match &scene.footprints {
        Some(f) if scene.reads_footprint(hit.material) => f.context(&scene.camera, hit, camera_ray),
        _ => TextureEvalContext { vertex_color: hit.vertex_color, ..TextureEvalContext::new(hit.p, hit.n, hit.uv) },
    };
    let mut material_index = hit.material;
    while material_index != NO_MATERIAL {
        if let Material::Mix { materials, amount } = &scene.materials[material_index as usize] {
            let a = amount.eval(&ctx).clamp(0.0, 1.0);
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
    let material = &scene.materials[material_index as usize];
    let perturbation = scene.normal_perturbations.get(material_index as usize).and_then(Option::as_ref);
    // A glTF clear coat keeps the shading frame the base's normal map tilts away from, or has its own map: either way
    // its normal is found from the hit as it is before the base's map (nothing to do when neither map is there).
    let coat_hit =
        material.clearcoat().filter(|coat| coat.normal_map.is_some() || perturbation.is_some()).map(|c| (c, *hit));
    if let Some(perturbation) = perturbation {
        perturbation.apply(hit, &ctx);
    }
    if let Some(anisotropy) = material.anisotropy() {
        anisotropy.orient(hit, &ctx);
    }
    match material.bxdf(&ctx, wl, u_bxdf, regularize) {
        Some(mut b) => {
            if let (Some((coat, mut coat_hit)), Bxdf::MetallicRoughness(m)) = (coat_hit, &mut b) {
                if let Some(map) = &coat.normal_map {
                    map.apply(&mut coat_hit, &ctx);
                }
                if let Some(c) = m.clearcoat_mut() {
                    if coat_hit.ns != hit.ns {
                        let local = Frame::from_z_and_tangent(hit.ns, hit.dpdu).to_local(coat_hit.ns);
                        c.normal = local.try_normalize().unwrap_or(Vec3::Z);
                    }
                }
            }
            Surface::Scatter(b)
        }
        None => Surface::Absorb,
    }
}

/// The medium a ray enters when it leaves `hit` in direction `d`, whether reflected, transmitted, a shadow ray or a
/// connection: the medium on the side `d` points into if the surface has an interface, the ray's own `current`
/// otherwise (pbrt-v4's `SurfaceInteraction::GetMedium`). Every ray spawned at a surface takes its medium from here.
#[inline]
pub(crate) fn next_medium(hit: &SurfaceHit, d: Vec3, current: Option<u32>) -> Option<u32> {
    hit.media.map_or(current, |mi| mi.towards(d, hit.n))
}

/// Where a shadow ray goes.
#[derive(Clone, Copy, Debug)]
pub(crate) enum ShadowTarget {
    /// A point (on a light or on the lens), stopped just short of it.
    Point(Vec3),
    /// Infinitely far along a direction.
    Direction(Vec3),
}

impl ShadowTarget {
    /// The unit direction from `origin` towards the target and the distance to trace.
    #[inline]
    pub fn segment_from(self, origin: Vec3) -> (Vec3, f32) {
        match self {
            ShadowTarget::Point(p) => {
                let to = p - origin;
                let len = to.length();
                // Stop just short of the target (pbrt's ShadowEpsilon, relative).
                (to / len, len * (1.0 - 1e-4))
            }
            ShadowTarget::Direction(d) => (d, f32::INFINITY),
        }
    }
}

/// A shadow ray: from `origin`, starting in `medium`, to `target`, traced at `time`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ShadowRay {
    /// Where it starts (offset off the surface it leaves).
    pub origin: Vec3,
    /// Where it goes.
    pub target: ShadowTarget,
    /// The medium it starts in.
    pub medium: Option<u32>,
    /// The path's time.
    pub time: f32,
}

/// Longest run of material-less boundaries a shadow ray crosses before it counts as blocked.
pub(crate) const MAX_SHADOW_CROSSINGS: u32 = 256;

//! The `bdpt` integrator: bidirectional path tracing with multiple importance sampling over every connection
//! strategy (Veach & Guibas 1995; Veach 1997 ch. 10; pbrt-v4 §16.3 describes the same algorithm).
//!
//! Each pixel sample traces a camera subpath and a light subpath and joins every prefix pair (s light vertices,
//! t camera vertices): s = 0 is a camera path that hits an emitter, t = 1 connects a light subpath vertex to the
//! lens (splatted, like the light tracer), s = 1 samples a point on a light (next-event estimation), and the rest
//! join two surface vertices with a shadow ray. Every strategy is weighted by the balance heuristic over all the
//! strategies that could have produced the same path, computed from the area densities of each vertex sampled
//! forwards and backwards. Delta lights (point, spot, distant) and specular BSDFs take part as in Veach: a
//! strategy that would need to hit a delta distribution has density zero and is left out of the weights.
//!
//! Spectral: both subpaths carry the pixel sample's wavelengths; the camera subpath is traced first, and a
//! dispersive refraction on either side reduces them to one (the reduction is an unbiased random choice, so
//! strategies evaluated afterwards at the reduced wavelengths stay unbiased).
//!
//! Media: absorbing-only media attenuate every segment by Beer–Lambert. In media that scatter, both subpaths
//! delta-track against the majorant at a hero wavelength (as `volpath` and `lightpath` do): null collisions go on,
//! absorption ends the subpath and real scattering makes a medium vertex with the phase function (pbrt-v4 §16.3's
//! `RandomWalk`). Connections carry the shadow ray's transmittance (closed form in homogeneous media, ratio tracking
//! in grids) through material-less boundaries. The MIS densities leave out the distance-sampling factors σs·T, as
//! pbrt-v4 does: the weights are then not exactly the balance heuristic's but still sum to one over the strategies
//! of each path, which is all unbiasedness needs. One hero slot serves the whole pixel sample (both subpaths and
//! every shadow ray), so each vertex carries the rescaled probabilities `r` of its subpath's tracking decisions and a
//! strategy divides by the mean over the carried wavelengths of the product of its two vertices' `r` and its shadow
//! ray's `r_l`: the one-sample spectral MIS estimator of the whole path (Wilkie et al. 2014; pbrt-v4 §14.2.3).
//! Media that glow are not rendered as emitters (with a warning).

use std::borrow::Cow;
use std::f32::consts::PI;
use std::ops::Range;

use film::Film;
use glam::{Vec2, Vec3};
use spectral::{SampledSpectrum, SampledWavelengths};

use super::drive::{
    finite_or_zero, render_splatting, CameraSampler, FirstHit, RenderStats, SampleRecords, SurfaceRecords,
    LIGHT_PATH_SEED_SALT,
};
use super::light_walk::sample_light_path;
use super::transport::{
    begin_bounce, scatter, Bounce, BounceSamples, PathRay, ShadowRay, ShadowTarget, SurfaceVertex, Tracer,
};
use super::volume::{shadow_transmittance, weigh_tracking, ShadowTransmittance, SpectralMis, TrackingSeed};
use super::{Integrate, IntegratorParams, Needs, RenderError, RenderJob};
use crate::bxdf::{Bxdf, TransportMode};
use crate::camera::{Camera, CameraRay};
use crate::medium::{sample_t_maj, Collision, PhaseFunction, TrackingRng};
use crate::sampler::{hash_words, Sampler};
use crate::sampling::Frame;
use crate::scene::{MediumInterface, RenderScene};

/// pbrt-v4's `bdpt` parameters.
#[derive(Clone, Copy, Debug)]
pub struct BdptIntegrator {
    /// Maximum number of scattering events of a full path (default 5).
    pub max_depth: u32,
    /// pbrt-v4's `"bool regularize"` (default false): both subpaths widen near-specular BSDFs after their first
    /// non-specular scattering, as `path`'s.
    pub regularize: bool,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// The camera (lens point).
    Camera,
    /// A point on a light, or the start of a light subpath (index into the scene's lights).
    Light(u32),
    /// A camera subpath that escaped to the infinite lights.
    Escape,
    /// A scattering surface.
    Surface,
    /// A real scattering event in a medium.
    Medium,
}

/// A subpath vertex (Veach 1997 §10.2; the fields pbrt-v4's `Vertex` keeps).
#[derive(Clone, Debug)]
struct Vertex {
    kind: Kind,
    p: Vec3,
    p_error: Vec3,
    /// Surface coordinates (for an emitter's alpha test).
    uv: Vec2,
    /// Geometric normal (zero where there is no surface: point lights, pinhole camera, lights at infinity).
    ng: Vec3,
    /// Shading normal.
    ns: Vec3,
    frame: Frame,
    bxdf: Option<Bxdf>,
    /// The phase function at a medium vertex.
    phase: Option<PhaseFunction>,
    /// Unit direction towards the previous vertex of the subpath (surfaces and medium vertices).
    wo: Vec3,
    /// Throughput of the subpath up to and including this vertex.
    beta: SampledSpectrum,
    /// Rescaled probabilities of the subpath's tracking decisions in media up to this vertex, per wavelength
    /// (spectral MIS, relative to the pixel sample's hero; all ones without media).
    r: SampledSpectrum,
    /// Scattering here was a delta event.
    delta: bool,
    /// Area density of sampling this vertex from the previous one (solid angle for a vertex at infinity).
    pdf_fwd: f32,
    /// Area density of sampling this vertex from the next one (the path traced the other way).
    pdf_rev: f32,
    /// The area light on this surface.
    area_light: Option<u32>,
    media: Option<MediumInterface>,
    /// The medium the subpath arrived through.
    medium: Option<u32>,
    /// For an escaped camera ray, its direction (towards infinity).
    w_escape: Vec3,
    mode: TransportMode,
}

impl Vertex {
    fn endpoint(kind: Kind, p: Vec3, ng: Vec3, beta: SampledSpectrum, pdf_fwd: f32, medium: Option<u32>) -> Self {
        Vertex {
            kind,
            p,
            p_error: Vec3::ZERO,
            uv: Vec2::ZERO,
            ng,
            ns: ng,
            frame: Frame::from_z(if ng == Vec3::ZERO { Vec3::Z } else { ng }),
            bxdf: None,
            phase: None,
            wo: Vec3::ZERO,
            beta,
            r: SampledSpectrum::splat(1.0),
            delta: false,
            pdf_fwd,
            pdf_rev: 0.0,
            area_light: None,
            media: None,
            medium,
            w_escape: Vec3::ZERO,
            mode: TransportMode::Radiance,
        }
    }

    fn on_surface(&self) -> bool {
        self.ng != Vec3::ZERO
    }

    fn light_index(&self) -> Option<u32> {
        match self.kind {
            Kind::Light(l) => Some(l),
            Kind::Surface => self.area_light,
            Kind::Camera | Kind::Escape | Kind::Medium => None,
        }
    }

    fn is_light(&self) -> bool {
        self.kind == Kind::Escape || self.light_index().is_some()
    }

    fn is_infinite_light(&self, scene: &RenderScene) -> bool {
        match self.kind {
            Kind::Escape => true,
            Kind::Light(l) => {
                let light = &scene.lights[l as usize];
                light.is_infinite() || light.is_delta_direction()
            }
            Kind::Camera | Kind::Surface | Kind::Medium => false,
        }
    }

    fn is_delta_light(&self, scene: &RenderScene) -> bool {
        match self.kind {
            Kind::Light(l) => {
                let light = &scene.lights[l as usize];
                light.is_delta_position() || light.is_delta_direction()
            }
            Kind::Camera | Kind::Escape | Kind::Surface | Kind::Medium => false,
        }
    }

    fn is_connectible(&self, scene: &RenderScene) -> bool {
        match self.kind {
            Kind::Camera => true,
            Kind::Light(l) => !scene.lights[l as usize].is_delta_direction(),
            Kind::Escape => false,
            Kind::Surface => self.bxdf.as_ref().is_some_and(|b| !b.is_specular()),
            Kind::Medium => true,
        }
    }

    /// The medium on the side of this vertex that direction `w` leaves through.
    fn medium_towards(&self, w: Vec3) -> Option<u32> {
        self.media.map_or(self.medium, |mi| mi.towards(w, self.ng))
    }

    /// A solid-angle density at this vertex turned into an area density at `next`: dω = |cos θ_next| dA / d²
    /// (Veach 1997 eq. 8.10).
    fn convert_density(&self, pdf: f32, next: &Vertex, scene: &RenderScene) -> f32 {
        if next.is_infinite_light(scene) {
            return pdf;
        }
        let w = next.p - self.p;
        let d2 = w.length_squared();
        if d2 == 0.0 {
            return 0.0;
        }
        let mut pdf = pdf / d2;
        if next.on_surface() {
            pdf *= next.ng.dot(w / d2.sqrt()).abs();
        }
        pdf
    }

    /// BSDF (or phase function) value for light arriving from `next` and leaving towards the previous vertex (or
    /// the reverse, in importance mode), with the adjoint shading-normal correction (Veach 1997 eq. 5.19) in
    /// importance mode. Phase functions depend only on the angle between the two directions, so they need no adjoint.
    fn f(&self, next: &Vertex, wl: &SampledWavelengths) -> SampledSpectrum {
        let Some(wi) = (next.p - self.p).try_normalize() else { return SampledSpectrum::zero() };
        if let Some(phase) = &self.phase {
            // Light travelling along −wo (arriving from the previous vertex) and leaving along wi.
            return phase.p(-self.wo, wi, wl);
        }
        let Some(bxdf) = &self.bxdf else { return SampledSpectrum::zero() };
        let f = bxdf.f(self.frame.to_local(self.wo), self.frame.to_local(wi), self.mode);
        if self.mode == TransportMode::Importance {
            f * correct_shading_normal(self.wo, wi, self.ns, self.ng)
        } else {
            f
        }
    }

    /// Area density at `next` of sampling it from this vertex, having come from `prev` (leaving out the
    /// distance-sampling factors σs·T of media, see the module's documentation).
    /// `camera` is the camera where it is at the path's time.
    fn pdf(
        &self,
        scene: &RenderScene,
        camera: &Camera,
        prev: Option<&Vertex>,
        next: &Vertex,
        wl: &SampledWavelengths,
    ) -> f32 {
        if matches!(self.kind, Kind::Light(_) | Kind::Escape) {
            return self.pdf_light(scene, next);
        }
        let wn = if next.kind == Kind::Escape { next.w_escape } else { next.p - self.p };
        let Some(wn) = wn.try_normalize() else { return 0.0 };
        let pdf = match self.kind {
            Kind::Camera => camera.pdf_we(self.p, wn).1,
            Kind::Medium => {
                let (Some(phase), Some(prev)) = (&self.phase, prev) else { return 0.0 };
                let Some(wp) = (prev.p - self.p).try_normalize() else { return 0.0 };
                // Arriving along −wp, leaving along wn.
                phase.pdf(-wp, wn, wl)
            }
            // Lights and escaped rays returned above; they have no BxDF either.
            Kind::Surface | Kind::Light(_) | Kind::Escape => {
                let (Some(bxdf), Some(prev)) = (&self.bxdf, prev) else { return 0.0 };
                let Some(wp) = (prev.p - self.p).try_normalize() else { return 0.0 };
                bxdf.pdf(self.frame.to_local(wp), self.frame.to_local(wn), self.mode)
            }
        };
        self.convert_density(pdf, next, scene)
    }

    /// Area density at `v` of a light path leaving this light vertex towards it (`sample_le`'s direction).
    fn pdf_light(&self, scene: &RenderScene, v: &Vertex) -> f32 {
        let w = v.p - self.p;
        let d2 = w.length_squared();
        if d2 == 0.0 {
            return 0.0;
        }
        let w = w / d2.sqrt();
        let mut pdf = if self.is_infinite_light(scene) {
            // Lights at infinity emit from a disk of the scene's radius: planar density.
            let r = scene.bounding_sphere.1;
            1.0 / (PI * r * r)
        } else {
            let Some(l) = self.light_index() else { return 0.0 };
            scene.lights[l as usize].pdf_le(self.ng, w, scene.bounding_sphere.1).1 / d2
        };
        if v.on_surface() {
            pdf *= v.ng.dot(w).abs();
        }
        pdf
    }

    /// Density of choosing this light vertex as the start of a light subpath (light selection times position;
    /// for lights at infinity, the direction towards `v`).
    fn pdf_light_origin(&self, scene: &RenderScene, v: &Vertex) -> f32 {
        let Some(w) = (v.p - self.p).try_normalize() else { return 0.0 };
        if self.is_infinite_light(scene) {
            return scene
                .infinite_lights
                .iter()
                .map(|&l| scene.light_probability(l) * scene.lights[l as usize].pdf_li_infinite(-w))
                .sum();
        }
        let Some(l) = self.light_index() else { return 0.0 };
        scene.light_probability(l) * scene.lights[l as usize].pdf_le(self.ng, w, scene.bounding_sphere.1).0
    }

    /// Radiance emitted from this vertex towards `v`.
    fn le(&self, scene: &RenderScene, v: &Vertex, wl: &SampledWavelengths) -> SampledSpectrum {
        match self.kind {
            Kind::Escape => {
                let mut l = SampledSpectrum::zero();
                for &i in &scene.infinite_lights {
                    l += scene.lights[i as usize].le(self.w_escape, wl);
                }
                l
            }
            Kind::Surface => match (self.area_light, (v.p - self.p).try_normalize()) {
                (Some(li), Some(w)) => scene.lights[li as usize].l_area(self.p, self.uv, self.ng, w, wl),
                _ => SampledSpectrum::zero(),
            },
            Kind::Camera | Kind::Light(_) | Kind::Medium => SampledSpectrum::zero(),
        }
    }

    fn surface_point(&self) -> geometry::SurfacePoint {
        geometry::SurfacePoint { p: self.p, p_error: self.p_error, n: self.ng }
    }
}

/// |wo·ns|·|wi·ng| / (|wo·ng|·|wi·ns|): the factor that makes shading normals symmetric for importance transport.
fn correct_shading_normal(wo: Vec3, wi: Vec3, ns: Vec3, ng: Vec3) -> f32 {
    let den = wo.dot(ng).abs() * wi.dot(ns).abs();
    if den == 0.0 {
        0.0
    } else {
        wo.dot(ns).abs() * wi.dot(ng).abs() / den
    }
}

/// The transmittance of shadow ray `ray`, `None` if a surface blocks it. In a scene without media this is exactly
/// the visibility test of the `vacuum` ray (origin, unit direction, t_max), as before media were rendered, so that
/// such images do not change; otherwise [`shadow_transmittance`] through material-less boundaries.
fn connection_transmittance(
    cx: &mut SampleContext,
    vacuum: (Vec3, Vec3, f32),
    ray: ShadowRay,
    wl: &SampledWavelengths,
    seed: TrackingSeed,
) -> Option<ShadowTransmittance> {
    if cx.tracer.scene.media.is_empty() {
        let (o, d, t_max) = vacuum;
        let ones = SampledSpectrum::splat(1.0);
        return (!cx.tracer.occluded(o, d, t_max, ray.time)).then_some(ShadowTransmittance {
            t: ones,
            r_l: ones,
            r_u: ones,
        });
    }
    shadow_transmittance(cx.tracer, ray, wl, &cx.mis, seed)
}

/// The transmittance between two vertices (both ends offset off their surfaces, pbrt-v4's `SpawnRayTo`).
fn transmittance(
    cx: &mut SampleContext,
    a: &Vertex,
    b: &Vertex,
    wl: &SampledWavelengths,
    seed: TrackingSeed,
) -> Option<ShadowTransmittance> {
    let (ray, t_max) = geometry::spawn_ray_to(&a.surface_point(), &b.surface_point());
    let target = geometry::offset_ray_origin(b.p, b.p_error, b.ng, ray.o - b.p);
    let medium = a.medium_towards(b.p - a.p);
    let vacuum = (ray.o, ray.d, t_max);
    let shadow = ShadowRay { origin: ray.o, target: ShadowTarget::Point(target), medium, time: cx.time };
    connection_transmittance(cx, vacuum, shadow, wl, seed)
}

/// The geometry term without visibility: |cos|·|cos|/d² with shading normals, no cosine at a vertex that is not on
/// a surface (a medium vertex, a point light, a pinhole).
fn geometry_term(a: &Vertex, b: &Vertex) -> f32 {
    let d = a.p - b.p;
    let d2 = d.length_squared();
    if d2 == 0.0 {
        return 0.0;
    }
    let dn = d / d2.sqrt();
    let mut g = 1.0 / d2;
    if a.on_surface() {
        g *= a.ns.dot(dn).abs();
    }
    if b.on_surface() {
        g *= b.ns.dot(dn).abs();
    }
    g
}

/// What every step of one pixel sample shares: the tracer, the camera where it is at the sample's time, that time,
/// and the spectral MIS state of the whole sample (one hero for both subpaths and every connection).
struct SampleContext<'t, 's> {
    tracer: &'t mut Tracer<'s>,
    cam: Cow<'s, Camera>,
    time: f32,
    mis: SpectralMis,
}

/// The start of a subpath's random walk: the ray, the throughput and solid-angle density it was sampled with, how
/// many vertices it may add, whether it carries radiance or importance, and the medium it starts in.
#[derive(Clone, Copy, Debug)]
struct Walk {
    o: Vec3,
    d: Vec3,
    beta: SampledSpectrum,
    pdf_dir: f32,
    max_vertices: usize,
    mode: TransportMode,
    medium: Option<u32>,
}

/// A connection strategy: `s` vertices of the light subpath and `t` of the camera subpath.
#[derive(Clone, Copy)]
struct Strategy<'p> {
    light: &'p [Vertex],
    camera: &'p [Vertex],
    s: usize,
    t: usize,
}

impl BdptIntegrator {
    /// One pixel sample: the camera ray `ray` (with its time), subpaths drawn from the three samplers (camera
    /// subpath, light subpath, connections), at wavelengths `wl`. Returns the radiance for the pixel; connections to
    /// the lens (t = 1) go to `splat(raster, contribution, wavelengths)` instead. Both subpaths and every connection
    /// are traced at the camera ray's time (pbrt-v4's light subpath takes the camera vertex's time), with the camera
    /// where it is then.
    fn li(
        &self,
        tracer: &mut Tracer,
        ray: &CameraRay,
        wl: &mut SampledWavelengths,
        samplers: [&mut Sampler; 3],
        first_hit: Option<&mut Option<FirstHit>>,
        mut splat: impl FnMut(Vec2, SampledSpectrum, &SampledWavelengths),
    ) -> SampledSpectrum {
        let [camera_sampler, light_sampler, connect_sampler] = samplers;
        let scene = tracer.scene;
        // One hero for the whole pixel sample, so that the tracking probabilities of the two subpaths and of a
        // connection multiply into those of the full path (drawn only where there are media, which leaves the
        // random numbers of scenes without media as they were).
        let mut mis = SpectralMis::new(wl);
        if !scene.media.is_empty() {
            mis.choose(connect_sampler.next_1d());
        }
        let time = ray.time;
        let mut cx = SampleContext { tracer, cam: scene.camera.at_time(time), time, mis };
        let camera = self.camera_subpath(&mut cx, ray, wl, camera_sampler);
        if let Some(fh) = first_hit {
            // The camera ray's first vertex, if it is a surface that scatters (pbrt-v4's visible surface).
            *fh = camera.get(1).filter(|v| v.kind == Kind::Surface).and_then(|v| {
                let b = v.bxdf.as_ref()?;
                Some(FirstHit { albedo: b.albedo_hint(), normal: v.ns, p: v.p, ng: v.ng, uv: v.uv })
            });
        }
        let light = self.light_subpath(&mut cx, wl, light_sampler);
        let mut l = SampledSpectrum::zero();
        for t in 1..=camera.len() {
            // s = 1 samples its own light point, so it runs even when the light subpath is empty (a light path
            // that started on a point an alpha cut-out masks): the MIS weights count on it.
            for s in 0..=light.len().max(1) {
                let depth = s as i64 + t as i64 - 2;
                if (s == 1 && t == 1) || depth < 0 || depth > self.max_depth as i64 {
                    continue;
                }
                let u = [connect_sampler.next_1d(), connect_sampler.next_1d(), connect_sampler.next_1d()];
                let strategy = Strategy { light: &light, camera: &camera, s, t };
                let (c, raster) = self.connect(&mut cx, strategy, wl, u);
                if c.is_black() || !c.0.iter().all(|v| v.is_finite()) {
                    continue;
                }
                match raster {
                    Some(r) => splat(r, c, wl),
                    None => l += c,
                }
            }
        }
        l
    }

    fn camera_subpath(
        &self,
        cx: &mut SampleContext,
        ray: &CameraRay,
        wl: &mut SampledWavelengths,
        sampler: &mut Sampler,
    ) -> Vec<Vertex> {
        let scene = cx.tracer.scene;
        let (o, d) = (ray.origin, ray.direction);
        let mut path = Vec::with_capacity(self.max_depth as usize + 2);
        let (pdf_pos, pdf_dir) = cx.cam.pdf_we(o, d);
        let cam =
            Vertex::endpoint(Kind::Camera, o, Vec3::ZERO, SampledSpectrum::splat(1.0), pdf_pos, scene.camera_medium);
        path.push(cam);
        if pdf_dir <= 0.0 {
            return path;
        }
        let walk = Walk {
            o,
            d,
            beta: SampledSpectrum::splat(1.0),
            pdf_dir,
            max_vertices: self.max_depth as usize + 1,
            mode: TransportMode::Radiance,
            medium: scene.camera_medium,
        };
        self.random_walk(cx, walk, wl, sampler, &mut path);
        path
    }

    fn light_subpath(&self, cx: &mut SampleContext, wl: &mut SampledWavelengths, sampler: &mut Sampler) -> Vec<Vertex> {
        let scene = cx.tracer.scene;
        let mut path = Vec::with_capacity(self.max_depth as usize + 1);
        let Some(start) = sample_light_path(scene, wl, sampler) else { return path };
        let (li, p_sel, le) = (start.light, start.p_select, start.le);
        let light = &scene.lights[li as usize];
        if le.l.is_black() {
            return path;
        }
        let ng = le.surface.map_or(Vec3::ZERO, |s| s.n);
        // The light emits into its own medium (pbrt-v4's exterior medium, or its shape's side).
        let light_medium = scene.light_medium(li, le.d, le.surface.map(|s| s.n));
        let mut v0 = Vertex::endpoint(Kind::Light(li), le.o, ng, le.l, p_sel * le.pdf_pos, light_medium);
        v0.p_error = le.surface.map_or(Vec3::ZERO, |s| s.p_error);
        v0.mode = TransportMode::Importance;
        let infinite = light.is_infinite() || light.is_delta_direction();
        if infinite {
            // pbrt-v4's convention for lights at infinity: the start vertex carries the directional density.
            v0.ng = Vec3::ZERO;
        }
        path.push(v0);
        let walk = Walk {
            o: start.origin(),
            d: le.d,
            beta: le.flux_weight() * (1.0 / p_sel),
            pdf_dir: le.pdf_dir,
            max_vertices: self.max_depth as usize,
            mode: TransportMode::Importance,
            medium: light_medium,
        };
        self.random_walk(cx, walk, wl, sampler, &mut path);
        if infinite {
            // The first surface vertex was sampled by position on the disk (planar density, cosine at the
            // vertex), and the start vertex's own density is that of the direction.
            if path.len() > 1 {
                let cos = if path[1].on_surface() { path[1].ng.dot(le.d).abs() } else { 1.0 };
                path[1].pdf_fwd = le.pdf_pos * cos;
            }
            path[0].pdf_fwd = if light.is_delta_direction() {
                p_sel
            } else {
                scene
                    .infinite_lights
                    .iter()
                    .map(|&l| scene.light_probability(l) * scene.lights[l as usize].pdf_li_infinite(-le.d))
                    .sum()
            };
        }
        path
    }

    /// Extends `path` by up to `walk.max_vertices` scattering vertices from the ray `walk.o + t·walk.d` sampled with
    /// solid-angle density `walk.pdf_dir` (pbrt-v4's `RandomWalk`, without Russian roulette so that densities stay
    /// exact). In media that scatter, distances are delta-tracked at the hero wavelength of the sample's spectral
    /// MIS and real scattering events are vertices.
    fn random_walk(
        &self,
        cx: &mut SampleContext,
        walk: Walk,
        wl: &mut SampledWavelengths,
        sampler: &mut Sampler,
        path: &mut Vec<Vertex>,
    ) {
        let Walk { o, d, mut beta, pdf_dir, max_vertices, mode, medium } = walk;
        let (scene, time) = (cx.tracer.scene, cx.time);
        if max_vertices == 0 {
            return;
        }
        let mut pdf_fwd = pdf_dir;
        let mut added = 0usize;
        let mut r = SampledSpectrum::splat(1.0);
        // The camera subpath starts with the camera ray (its first hit takes the ray's footprint).
        let mut ray = match mode {
            TransportMode::Radiance => PathRay::camera(o, d, medium, time),
            TransportMode::Importance => PathRay::new(o, d, medium, time),
        }
        .regularizing(self.regularize);
        loop {
            let d = ray.d;
            let hit = ray.intersect(cx.tracer);
            if let Some(m) = ray.medium.filter(|&m| !scene.media[m as usize].is_absorbing_only()) {
                let h = cx.mis.hero;
                let mut rng = TrackingRng::new(sampler.next_1d(), path.len() as u32);
                let t_end = hit.map_or(f32::INFINITY, |h| h.t);
                let (mut scattered, mut terminated) = (None, false);
                let wl_now: &SampledWavelengths = wl;
                let mis_now: &SpectralMis = &cx.mis;
                let t_maj = sample_t_maj(
                    &scene.media[m as usize],
                    ray.o,
                    d,
                    t_end,
                    &mut rng,
                    wl_now,
                    h,
                    |p, mp, sigma_maj, t_maj, rng| {
                        match mp.collision(sigma_maj, h, rng.uniform()) {
                            Collision::Absorb => terminated = true,
                            Collision::Scatter => {
                                // Distance and event sampled with density T_maj·σs at the hero (pbrt-v4 §14.1.3).
                                if !weigh_tracking(&mut beta, &mut r, mis_now, t_maj, mp.sigma_s) {
                                    terminated = true;
                                    return false;
                                }
                                let mut v = Vertex::endpoint(Kind::Medium, p, Vec3::ZERO, beta, 0.0, Some(m));
                                v.phase = Some(mp.phase.clone());
                                v.wo = -d;
                                v.r = r;
                                v.mode = mode;
                                v.pdf_fwd = path
                                    .last()
                                    .expect("the subpath has its endpoint")
                                    .convert_density(pdf_fwd, &v, scene);
                                path.push(v);
                                added += 1;
                                if added >= max_vertices {
                                    terminated = true;
                                    return false;
                                }
                                let u = BounceSamples::draw(sampler);
                                match mp.phase.sample(d, u.dir, u.lobe, wl_now) {
                                    Some(ps) if ps.pdf > 0.0 => {
                                        beta *= ps.p / ps.pdf;
                                        pdf_fwd = ps.pdf;
                                        // The previous vertex's reverse density: arriving along −wi, leaving along −d.
                                        let rev = mp.phase.pdf(-ps.wi, -d, wl_now);
                                        let n = path.len();
                                        path[n - 2].pdf_rev = path[n - 1].convert_density(rev, &path[n - 2], scene);
                                        scattered = Some((p, ps.wi));
                                    }
                                    _ => terminated = true,
                                }
                            }
                            Collision::Null => {
                                if !weigh_tracking(&mut beta, &mut r, mis_now, t_maj, mp.sigma_n(sigma_maj)) {
                                    terminated = true;
                                    return false;
                                }
                                return !beta.is_black();
                            }
                        }
                        false
                    },
                );
                if terminated || beta.is_black() || !beta.0.iter().all(|v| v.is_finite()) {
                    break;
                }
                if let Some((p, wi)) = scattered {
                    ray.scatter_in_medium(p, wi);
                    continue;
                }
                // No collision before the surface: probability T_maj at the hero.
                if !weigh_tracking(&mut beta, &mut r, &cx.mis, t_maj, SampledSpectrum::splat(1.0)) {
                    break;
                }
            }
            let Some(mut hit) = hit else {
                if mode == TransportMode::Radiance && !scene.infinite_lights.is_empty() {
                    let prev = path.last().expect("the subpath has its endpoint");
                    let mut v = Vertex::endpoint(Kind::Escape, prev.p + d, Vec3::ZERO, beta, pdf_fwd, ray.medium);
                    v.w_escape = d;
                    v.r = r;
                    path.push(v);
                }
                break;
            };
            ray.attenuate(scene, &hit, wl, &mut beta);
            let (bxdf, u) = match begin_bounce(scene, &mut hit, &mut ray, wl, sampler) {
                Bounce::PassedThrough => continue,
                Bounce::Stop => break,
                Bounce::Absorb => (None, None),
                Bounce::Scatter(bxdf, u) => (Some(bxdf), Some(u)),
            };
            cx.mis.update(wl);
            let frame = Frame::from_z_and_tangent(hit.ns, hit.dpdu);
            let mut v = Vertex {
                kind: Kind::Surface,
                p: hit.p,
                p_error: hit.p_error,
                uv: hit.uv,
                ng: hit.n,
                ns: hit.ns,
                frame,
                bxdf,
                phase: None,
                wo: -d,
                beta,
                r,
                delta: false,
                pdf_fwd: 0.0,
                pdf_rev: 0.0,
                area_light: hit.area_light,
                media: hit.media,
                medium: ray.medium,
                w_escape: Vec3::ZERO,
                mode,
            };
            v.pdf_fwd = path.last().expect("the subpath has its endpoint").convert_density(pdf_fwd, &v, scene);
            path.push(v);
            added += 1;
            let v = path.last().expect("just pushed");
            let (Some(bxdf), Some(u)) = (&v.bxdf, u) else { break };
            if added >= max_vertices {
                break;
            }
            let wo = frame.to_local(-d);
            let sv = SurfaceVertex { hit: &hit, frame: &frame, bxdf, wo, medium: ray.medium };
            let Some(s) = scatter(&sv, -d, &u, mode, wl, &mut beta) else { break };
            cx.mis.update(wl);
            let (mut fwd, mut rev) = if s.bs.pdf_is_proportional {
                (bxdf.pdf(wo, s.bs.wi, mode), bxdf.pdf(s.bs.wi, wo, mode))
            } else {
                (s.bs.pdf, bxdf.pdf(s.bs.wi, wo, mode))
            };
            let n = path.len();
            if s.bs.specular {
                path[n - 1].delta = true;
                fwd = 0.0;
                rev = 0.0;
            }
            pdf_fwd = fwd;
            // The previous vertex's reverse density: sampled from this one, towards it.
            let rev_area = path[n - 1].convert_density(rev, &path[n - 2], scene);
            path[n - 2].pdf_rev = rev_area;
            ray.leave(&hit, s.wi, s.bs.specular);
            if !beta.0.iter().all(|v| v.is_finite()) || beta.is_black() {
                break;
            }
        }
    }

    /// The contribution of strategy (s, t), MIS-weighted, and the raster position for t = 1. Every strategy divides
    /// by the mean over the wavelengths of the product of its vertices' and its shadow ray's rescaled tracking
    /// probabilities (spectral MIS of the whole path; exactly 1 without media).
    fn connect(
        &self,
        cx: &mut SampleContext,
        strategy: Strategy,
        wl: &SampledWavelengths,
        u: [f32; 3],
    ) -> (SampledSpectrum, Option<Vec2>) {
        let Strategy { light, camera, s, t } = strategy;
        let scene = cx.tracer.scene;
        let zero = (SampledSpectrum::zero(), None);
        // An escaped camera ray can only be an emitter seen directly (s = 0).
        if t > 1 && s != 0 && camera[t - 1].kind == Kind::Escape {
            return zero;
        }
        // The shadow ray's tracking decisions, seeded per strategy.
        let seed = TrackingSeed { salt: BDPT_CONNECT_SEED_SALT ^ ((s as u32) << 16 | t as u32), u: u[2] };
        let mut sampled: Option<Vertex> = None;
        let mut raster = None;
        let l = if s == 0 {
            let pt = &camera[t - 1];
            if !pt.is_light() {
                return zero;
            }
            pt.le(scene, &camera[t - 2], wl) * pt.beta / cx.mis.average(pt.r)
        } else if t == 1 {
            let qs = &light[s - 1];
            if !qs.is_connectible(scene) {
                return zero;
            }
            let Some(cs) = cx.cam.sample_wi(qs.p, Vec2::new(u[0], u[1])) else { return zero };
            let cam_n = if cx.cam.lens_area_is_finite() { cx.cam.forward() } else { Vec3::ZERO };
            let mut v = Vertex::endpoint(
                Kind::Camera,
                cs.p_lens,
                cam_n,
                SampledSpectrum::splat(cs.we / cs.pdf),
                0.0,
                scene.camera_medium,
            );
            v.ns = cam_n;
            let mut c = qs.beta * qs.f(&v, wl) * v.beta;
            if qs.on_surface() {
                c *= qs.ns.dot(cs.wi).abs();
            }
            if c.is_black() {
                return zero;
            }
            let Some(tr) = transmittance(cx, qs, &v, wl, seed) else { return zero };
            raster = Some(cs.raster);
            sampled = Some(v);
            c * tr.t / cx.mis.average(qs.r * tr.r_l)
        } else if s == 1 {
            let pt = &camera[t - 1];
            if !pt.is_connectible(scene) {
                return zero;
            }
            let Some((li, p_sel)) = scene.sample_light(u[0]) else { return zero };
            let light_ref = &scene.lights[li as usize];
            let ctx = crate::light::LightSampleContext { p: pt.p };
            let Some(ls) = light_ref.sample_li(&ctx, Vec2::new(u[1], u[2]), wl) else { return zero };
            if ls.pdf <= 0.0 || ls.l.is_black() {
                return zero;
            }
            let far = ls.dist.is_infinite();
            let p = if far { pt.p + ls.wi * (2.0 * scene.bounding_sphere.1) } else { ls.p };
            let mut v = Vertex::endpoint(
                Kind::Light(li),
                p,
                if far { Vec3::ZERO } else { ls.n },
                ls.l * (1.0 / (p_sel * ls.pdf)),
                0.0,
                scene.light_medium(li, -ls.wi, (!far).then_some(ls.n)),
            );
            v.mode = TransportMode::Importance;
            v.pdf_fwd = v.pdf_light_origin(scene, pt);
            let mut c = pt.beta * pt.f(&v, wl) * v.beta;
            if pt.on_surface() {
                c *= pt.ns.dot(ls.wi).abs();
            }
            if c.is_black() {
                return zero;
            }
            // Shadow ray to the light point (or to infinity).
            let origin = geometry::offset_ray_origin(pt.p, pt.p_error, pt.ng, ls.wi);
            let t_max = if far { f32::INFINITY } else { (ls.p - origin).length() * (1.0 - 1e-4) };
            let target = if far { ShadowTarget::Direction(ls.wi) } else { ShadowTarget::Point(ls.p) };
            let medium = pt.medium_towards(ls.wi);
            let vacuum = (origin, ls.wi, t_max);
            let shadow = ShadowRay { origin, target, medium, time: cx.time };
            let Some(tr) = connection_transmittance(cx, vacuum, shadow, wl, seed) else { return zero };
            sampled = Some(v);
            c * tr.t / cx.mis.average(pt.r * tr.r_l)
        } else {
            let (qs, pt) = (&light[s - 1], &camera[t - 1]);
            if !qs.is_connectible(scene) || !pt.is_connectible(scene) {
                return zero;
            }
            let c = qs.beta * qs.f(pt, wl) * pt.f(qs, wl) * pt.beta;
            if c.is_black() {
                return zero;
            }
            let g = geometry_term(qs, pt);
            if g == 0.0 {
                return zero;
            }
            let Some(tr) = transmittance(cx, qs, pt, wl, seed) else { return zero };
            c * g * tr.t / cx.mis.average(qs.r * pt.r * tr.r_l)
        };
        if l.is_black() {
            return zero;
        }
        let w = self.mis_weight(scene, &cx.cam, strategy, sampled.as_ref(), wl);
        (l * w, raster)
    }

    /// The balance-heuristic weight of strategy (s, t) against every other strategy that could have produced the
    /// same path (Veach 1997 §10.2.1, computed with density ratios as pbrt-v4 does). `sampled` replaces the
    /// camera endpoint when t = 1 and the light endpoint when s = 1.
    fn mis_weight(
        &self,
        scene: &RenderScene,
        view: &Camera,
        strategy: Strategy,
        sampled: Option<&Vertex>,
        wl: &SampledWavelengths,
    ) -> f32 {
        let Strategy { light, camera, s, t } = strategy;
        if s + t == 2 {
            return 1.0;
        }
        let remap = |f: f32| if f != 0.0 { f } else { 1.0 };
        // The path's vertices for this strategy, with the endpoints of the connection replaced where sampled.
        let qs: Option<&Vertex> = if s == 0 {
            None
        } else if s == 1 {
            sampled.or(light.first())
        } else {
            Some(&light[s - 1])
        };
        let pt: &Vertex = if t == 1 { sampled.unwrap_or(&camera[0]) } else { &camera[t - 1] };
        let qs_minus = if s >= 2 { Some(&light[s - 2]) } else { None };
        let pt_minus = if t >= 2 { Some(&camera[t - 2]) } else { None };

        // Densities of the camera subpath (index i < t) and light subpath (i < s) with the four vertices around
        // the connection updated for this strategy.
        let mut cam: Vec<(f32, f32, bool)> = camera[..t].iter().map(|v| (v.pdf_fwd, v.pdf_rev, v.delta)).collect();
        let mut lig: Vec<(f32, f32, bool)> = if s == 1 {
            vec![(0.0, 0.0, false)]
        } else {
            light[..s].iter().map(|v| (v.pdf_fwd, v.pdf_rev, v.delta)).collect()
        };
        if t == 1 {
            cam[0] = (pt.pdf_fwd, pt.pdf_rev, pt.delta);
        }
        if s == 1 {
            let q = qs.expect("s = 1 has a light vertex");
            lig[0] = (q.pdf_fwd, q.pdf_rev, q.delta);
        }
        // pt's reverse density: sampled from qs (or as the origin of a light subpath when s = 0).
        cam[t - 1].1 = match qs {
            Some(q) => q.pdf(scene, view, qs_minus, pt, wl),
            None => pt.pdf_light_origin(scene, pt_minus.expect("s = 0 needs t ≥ 2")),
        };
        if let Some(pm) = pt_minus {
            cam[t - 2].1 = match qs {
                Some(q) => pt.pdf(scene, view, Some(q), pm, wl),
                None => pt.pdf_light(scene, pm),
            };
        }
        if let Some(q) = qs {
            lig[s - 1].1 = pt.pdf(scene, view, pt_minus, q, wl);
            if let Some(qm) = qs_minus {
                lig[s - 2].1 = q.pdf(scene, view, Some(pt), qm, wl);
            }
        }
        // The connection's endpoints are not delta events for this strategy.
        cam[t - 1].2 = false;
        if s > 0 {
            lig[s - 1].2 = false;
        }
        let mut sum = 0.0f32;
        let mut ri = 1.0f32;
        for i in (1..t).rev() {
            ri *= remap(cam[i].1) / remap(cam[i].0);
            if !cam[i].2 && !cam[i - 1].2 {
                sum += ri;
            }
        }
        let light_start_delta = match s {
            0 => false,
            1 => qs.is_some_and(|q| q.is_delta_light(scene)),
            _ => light[0].is_delta_light(scene),
        };
        ri = 1.0;
        for i in (0..s).rev() {
            ri *= remap(lig[i].1) / remap(lig[i].0);
            let delta_before = if i > 0 { lig[i - 1].2 } else { light_start_delta };
            if !lig[i].2 && !delta_before {
                sum += ri;
            }
        }
        let w = 1.0 / (1.0 + sum);
        if w.is_finite() {
            w
        } else {
            0.0
        }
    }
}

/// Salt of the bidirectional path tracer's connection sampler (the light subpath uses the light tracer's salt).
const BDPT_CONNECT_SEED_SALT: u32 = 0x636f_6e6e;

impl Integrate for BdptIntegrator {
    fn read(params: &mut IntegratorParams) -> Result<Self, RenderError> {
        params.warn_unrendered_media_glow("bdpt");
        Ok(BdptIntegrator { max_depth: params.max_depth()?, regularize: params.regularize()? })
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
        Ok(Box::new(BdptRender {
            integrator: self,
            scene,
            camera: CameraSampler::new(film)?.sharing_pass_wavelengths(scene, film, seed),
            seed,
        }))
    }
}

/// A bidirectional render: per pixel sample, a camera sample for the pixel and splats for t = 1 connections.
struct BdptRender<'a> {
    integrator: &'a BdptIntegrator,
    scene: &'a RenderScene,
    camera: CameraSampler,
    seed: u32,
}

impl RenderJob for BdptRender<'_> {
    fn run(&mut self, film: &mut Film, passes: Range<u32>, progress: &(dyn Fn(u64) + Sync)) -> RenderStats {
        let (scene, seed) = (self.scene, self.seed);
        let light_seed = hash_words(&[seed, LIGHT_PATH_SEED_SALT]);
        let connect_seed = hash_words(&[seed, BDPT_CONNECT_SEED_SALT]);
        let surfaces = SurfaceRecords::of(film);
        let per_sample = |x: u32, y: u32, s: u32, tracer: &mut Tracer, records: &mut SampleRecords| {
            let mut sampler = Sampler::new(x, y, s, seed);
            let cs = self.camera.sample(scene, x, y, &mut sampler);
            // The builder refuses cameras whose rays light paths cannot reach, so the ray is shared; a vignetted
            // one brings nothing.
            let Some(ray) = cs.shared_ray().copied() else {
                records.camera(x, SampledSpectrum::zero(), cs.wl, cs.weight, None);
                return;
            };
            let mut first_hit = None;
            let mut wl = cs.wl;
            let mut light_sampler = Sampler::new(x, y, s, light_seed);
            let mut connect_sampler = Sampler::new(x, y, s, connect_seed);
            let l = self.integrator.li(
                tracer,
                &ray,
                &mut wl,
                [&mut sampler, &mut light_sampler, &mut connect_sampler],
                surfaces.wanted().then_some(&mut first_hit),
                // Splats keep the wavelengths they were made at (a later dispersive event on the other subpath may
                // have reduced the set since).
                |raster, c, swl| records.splat(raster, c, *swl),
            );
            let surface = first_hit.map(|h| surfaces.record(scene, &cs, &h));
            records.camera(x, finite_or_zero(l), wl, cs.weight, surface);
        };
        self.camera
            .in_wavelength_chunks(scene, passes, |chunk| render_splatting(film, scene, chunk, progress, &per_sample))
    }

    fn finish(self: Box<Self>, _film: &mut Film) {}
}

//! The render-ready scene: geometry behind a small trait (with [`SceneGeometry`], the BVH-backed implementation
//! every ray goes through), materials, lights with a power-based light sampler, media and the camera.

use std::sync::Arc;

use geometry::{GeometryScene, SurfaceDerivatives};
use glam::{Vec2, Vec3};
use optics::mie::MieSpectralTable;
use spectral::Distribution1D;

use crate::bump::NormalPerturbation;
use crate::camera::Camera;
use crate::light::Light;
use crate::material::Material;
use crate::medium::Medium;
use crate::texture::{FloatTexture, TextureEvalContext};

/// Material index meaning "no surface" (a boundary between media only).
pub const NO_MATERIAL: u32 = u32::MAX;

/// Which media lie on each side of a surface (indices into [`RenderScene::media`]; `None` is vacuum).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MediumInterface {
    /// Medium on the side the geometric normal points away from.
    pub inside: Option<u32>,
    /// Medium on the side the geometric normal points to.
    pub outside: Option<u32>,
}

impl MediumInterface {
    /// The medium on the side of a surface with geometric normal `n` that direction `d` points into: inside if
    /// `d` goes against the normal, outside otherwise.
    #[inline]
    pub fn towards(&self, d: Vec3, n: Vec3) -> Option<u32> {
        if d.dot(n) < 0.0 {
            self.inside
        } else {
            self.outside
        }
    }
}

/// The medium a light emits into.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightMedium {
    /// One medium whatever the direction (`LightSource` lights: pbrt-v4's exterior medium in effect).
    Fixed(Option<u32>),
    /// An area light on a shape with a `MediumInterface`: the outside medium on the side its geometric normal
    /// points to, the inside one on the other.
    Surface(MediumInterface),
}

/// What a ray hit.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceHit {
    /// Ray parameter.
    pub t: f32,
    /// Point.
    pub p: Vec3,
    /// Geometric normal (unit; for emitters, the emitting side).
    pub n: Vec3,
    /// Shading normal (unit, on the same side as `n`).
    pub ns: Vec3,
    /// Surface (u, v).
    pub uv: Vec2,
    /// Tangent the shading frame starts from (any length; the frame makes it perpendicular to `ns` and normalises
    /// it, see `Frame::from_z_and_tangent`): ∂p/∂u, or after bump mapping the perturbed shading ∂p/∂u.
    pub dpdu: Vec3,
    /// The surface's own ∂p/∂u and ∂p/∂v with respect to its texture (u, v) (pbrt-v4's `SurfaceInteraction::dpdu`,
    /// `dpdv`): how far (u, v) moves when the point does, for image textures' filter footprints.
    pub surface_dpdu: Vec3,
    /// See `surface_dpdu`.
    pub surface_dpdv: Vec3,
    /// pbrt-v4's shading ∂p/∂u (not normalised; see [`geometry::Hit::shading_dpdu`]), for bump and normal maps.
    pub shading_dpdu: Vec3,
    /// pbrt-v4's shading ∂p/∂v (not normalised).
    pub shading_dpdv: Vec3,
    /// Conservative absolute error bound of each coordinate of `p` (for spawning rays that cannot re-hit).
    pub p_error: Vec3,
    /// Material index, or [`NO_MATERIAL`].
    pub material: u32,
    /// Index of the area light on this surface, if it emits.
    pub area_light: Option<u32>,
    /// Media on either side, if the surface separates media.
    pub media: Option<MediumInterface>,
    /// The time of the ray that found the hit: rays leaving the surface are traced at the same time.
    pub time: f32,
    /// The interpolated per-vertex colour (linear RGB) of a mesh that has vertex colours.
    pub vertex_color: Option<Vec3>,
}

impl SurfaceHit {
    /// Origin for a ray leaving the surface in direction `d`: offset along ±n by the error bound (pbrt-v4 §6.8.6).
    pub fn spawn_origin(&self, d: Vec3) -> Vec3 {
        geometry::offset_ray_origin(self.p, self.p_error, self.n, d)
    }
}

/// A hit with what a specular-chain solver needs besides: which surface it lies on and the surface's derivatives.
#[derive(Clone, Copy, Debug)]
pub struct DifferentialHit {
    /// The hit.
    pub hit: SurfaceHit,
    /// The surface hit: (instance, shape) of the geometry (a mesh is one surface).
    pub surface: [u32; 2],
    /// First derivatives of the point and of the shading normal there, if the shape provides them.
    pub derivatives: Option<SurfaceDerivatives>,
}

/// Ray queries against the scene's geometry. Every query is made at a `time` within the camera's shutter interval,
/// where moving geometry is found (static geometry ignores it).
pub trait Geometry: Send + Sync {
    /// Closest hit along `o + t·d` with `0 < t < t_max`, at `time`.
    fn intersect(&self, o: Vec3, d: Vec3, t_max: f32, time: f32) -> Option<SurfaceHit>;
    /// The closest hit as [`Geometry::intersect`] finds it, with its surface and derivatives (a geometry that
    /// cannot tell surfaces apart or give derivatives answers with the hit alone).
    fn intersect_differential(&self, o: Vec3, d: Vec3, t_max: f32, time: f32) -> Option<DifferentialHit> {
        let hit = self.intersect(o, d, t_max, time)?;
        Some(DifferentialHit { hit, surface: [u32::MAX; 2], derivatives: None })
    }
    /// True if anything lies along `o + t·d` with `0 < t < t_max`, at `time`.
    fn occluded(&self, o: Vec3, d: Vec3, t_max: f32, time: f32) -> bool;
    /// A sphere (centre, radius) enclosing all geometry.
    fn bounding_sphere(&self) -> (Vec3, f32);
}

/// Per-shape data the geometry hit needs to find material, light and media.
#[derive(Clone, Copy, Debug)]
pub struct ShapeInfo {
    /// Material index, or [`NO_MATERIAL`].
    pub material: u32,
    /// Index of the area light of the shape's first primitive (primitive `i` has light `base + i`), if it emits.
    pub area_light_base: Option<u32>,
    /// Media on either side, if the shape separates media.
    pub media: Option<MediumInterface>,
    /// Index of the shape's per-vertex colours in the scene geometry's tables, if it has them.
    pub vertex_colors: Option<u32>,
}

/// A triangle mesh's per-vertex colours, with the mesh's vertex indices that pick them per triangle.
#[derive(Clone, Debug)]
pub struct VertexColors {
    /// The mesh (shared with the description): three vertex indices per triangle, in the order of the BVH's
    /// element indices.
    pub mesh: Arc<geometry::MeshData>,
    /// Linear RGB per vertex.
    pub colors: Arc<[[f32; 3]]>,
}

impl VertexColors {
    /// The colour at barycentric coordinates `b` of triangle `element` (white outside the tables).
    fn at(&self, element: u32, b: [f32; 3]) -> Vec3 {
        let i = element as usize * 3;
        let Some(tri) = self.mesh.indices.get(i..i + 3) else { return Vec3::ONE };
        let c = |k: usize| self.colors.get(tri[k] as usize).map_or(Vec3::ONE, |c| Vec3::from_array(*c));
        b[0] * c(0) + b[1] * c(1) + b[2] * c(2)
    }
}

/// The scene's [`Geometry`]: the two-level BVH of the shapes, and per shape what a hit on it means for rendering.
pub struct SceneGeometry {
    accel: GeometryScene,
    /// `[object][shape]`.
    info: Vec<Vec<ShapeInfo>>,
    /// The alpha textures of cut-out shapes (empty when no shape has one: then rays never look at alpha).
    alphas: Vec<FloatTexture>,
    /// `[object][shape]`: index into `alphas` (empty when `alphas` is).
    alpha_of: Vec<Vec<Option<u32>>>,
    /// The per-vertex colours [`ShapeInfo::vertex_colors`] index.
    vertex_colors: Vec<VertexColors>,
}

/// Longest run of cut-out surfaces a ray passes through before it counts as escaped.
const MAX_ALPHA_SKIPS: u32 = 1024;

impl SceneGeometry {
    /// Wraps `accel`; `info[object][shape]` describes shape `shape` of the accel's object `object`.
    pub fn new(accel: GeometryScene, info: Vec<Vec<ShapeInfo>>) -> Self {
        Self { accel, info, alphas: vec![], alpha_of: vec![], vertex_colors: vec![] }
    }

    /// [`SceneGeometry::new`] with cut-outs: `alpha_of[object][shape]` names the alpha texture (in `alphas`) of
    /// shape `shape` of object `object`, if it has one (pbrt-v4's `"float alpha"` / `"texture alpha"`).
    pub fn with_alpha(
        accel: GeometryScene,
        info: Vec<Vec<ShapeInfo>>,
        alphas: Vec<FloatTexture>,
        alpha_of: Vec<Vec<Option<u32>>>,
    ) -> Self {
        if alphas.is_empty() {
            return Self::new(accel, info);
        }
        Self { accel, info, alphas, alpha_of, vertex_colors: vec![] }
    }

    /// The tables of per-vertex colours that shapes' [`ShapeInfo::vertex_colors`] name.
    pub fn with_vertex_colors(mut self, vertex_colors: Vec<VertexColors>) -> Self {
        self.vertex_colors = vertex_colors;
        self
    }

    /// What a hit of the BVH means for rendering.
    #[inline]
    fn surface_hit(&self, hit: &geometry::Hit, time: f32) -> SurfaceHit {
        let info = self.info[hit.object as usize][hit.shape as usize];
        SurfaceHit {
            t: hit.t,
            p: hit.p,
            n: hit.n,
            ns: hit.ns,
            uv: hit.uv,
            dpdu: hit.dpdu,
            surface_dpdu: hit.dpdu,
            surface_dpdv: hit.dpdv,
            shading_dpdu: hit.shading_dpdu,
            shading_dpdv: hit.shading_dpdv,
            p_error: hit.p_error,
            material: info.material,
            area_light: info.area_light_base.map(|b| b + hit.element),
            media: info.media,
            time,
            vertex_color: info.vertex_colors.map(|i| self.vertex_colors[i as usize].at(hit.element, hit.bary)),
        }
    }

    /// pbrt-v4's stochastic alpha test of a hit found by the ray (`o`, `d`): true if the ray passes through. Alpha
    /// 0 always passes and 1 never does; in between the ray passes if a hash of the ray exceeds alpha, so the
    /// decision is the same for the same ray whatever thread traces it.
    fn cut_out(&self, hit: &geometry::Hit, o: Vec3, d: Vec3) -> bool {
        let Some(Some(i)) = self.alpha_of.get(hit.object as usize).and_then(|v| v.get(hit.shape as usize)) else {
            return false;
        };
        let a = self.alphas[*i as usize].eval(&TextureEvalContext::new(hit.p, hit.n, hit.uv));
        if a >= 1.0 {
            false
        } else if a <= 0.0 || a.is_nan() {
            true
        } else {
            hash_ray(o, d) > a
        }
    }
}

/// A number in [0, 1) from the bits of a ray's origin and direction (splitmix64's finaliser over each component).
fn hash_ray(o: Vec3, d: Vec3) -> f32 {
    let mut h: u64 = 0x9e37_79b9_7f4a_7c15;
    for v in [o.x, o.y, o.z, d.x, d.y, d.z] {
        h ^= u64::from(v.to_bits());
        h = h.wrapping_add(0x9e37_79b9_7f4a_7c15);
        h = (h ^ (h >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        h = (h ^ (h >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        h ^= h >> 31;
    }
    (h >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
}

impl Geometry for SceneGeometry {
    fn intersect(&self, o: Vec3, d: Vec3, t_max: f32, time: f32) -> Option<SurfaceHit> {
        use geometry::Accel;
        if self.alphas.is_empty() {
            let hit = self.accel.intersect(&geometry::Ray::at_time(o, d, time), t_max)?;
            return Some(self.surface_hit(&hit, time));
        }
        // Past each cut-out hit the ray goes on from just beyond it (pbrt-v4's GeometricPrimitive::Intersect).
        let (mut origin, mut remaining) = (o, t_max);
        let d2 = d.length_squared();
        for _ in 0..MAX_ALPHA_SKIPS {
            let hit = self.accel.intersect(&geometry::Ray::at_time(origin, d, time), remaining)?;
            if !self.cut_out(&hit, origin, d) {
                let mut sh = self.surface_hit(&hit, time);
                if origin != o {
                    sh.t = (hit.p - o).dot(d) / d2;
                }
                return Some(sh);
            }
            origin = geometry::offset_ray_origin(hit.p, hit.p_error, hit.n, d);
            remaining = t_max - (origin - o).dot(d) / d2;
            if remaining.is_nan() || remaining <= 0.0 {
                return None;
            }
        }
        None
    }

    fn intersect_differential(&self, o: Vec3, d: Vec3, t_max: f32, time: f32) -> Option<DifferentialHit> {
        let ray = geometry::Ray::at_time(o, d, time);
        let (hit, derivatives) = self.accel.intersect_with_derivatives(&ray, t_max)?;
        Some(DifferentialHit { hit: self.surface_hit(&hit, time), surface: [hit.instance, hit.shape], derivatives })
    }

    fn occluded(&self, o: Vec3, d: Vec3, t_max: f32, time: f32) -> bool {
        use geometry::Accel;
        if self.alphas.is_empty() {
            return self.accel.occluded(&geometry::Ray::at_time(o, d, time), t_max);
        }
        // Shadow rays take the same alpha tests as other rays (pbrt-v4's IntersectP runs Intersect on cut-outs).
        self.intersect(o, d, t_max, time).is_some()
    }

    fn bounding_sphere(&self) -> (Vec3, f32) {
        use geometry::Accel;
        self.accel.bounds().bounding_sphere()
    }
}

/// Everything the integrators need.
pub struct RenderScene {
    /// Ray queries (shared with later builds of the same shapes, see [`crate::build_scene_reusing`]).
    pub(crate) geometry: Arc<dyn Geometry>,
    /// Materials, indexed by [`SurfaceHit::material`].
    pub(crate) materials: Vec<Material>,
    /// Each material's bump or normal map, indexed like `materials` (empty, or `None`, for none).
    pub(crate) normal_perturbations: Vec<Option<NormalPerturbation>>,
    /// Lights.
    pub(crate) lights: Vec<Light>,
    /// Light selection by power (None when there are no lights).
    pub(crate) light_distribution: Option<Distribution1D>,
    /// Indices of the infinite lights.
    pub(crate) infinite_lights: Vec<u32>,
    /// Media.
    pub(crate) media: Vec<Medium>,
    /// The medium the camera sits in.
    pub(crate) camera_medium: Option<u32>,
    /// The medium each light emits into, indexed like `lights`; empty for scenes assembled without the builder,
    /// whose lights then sit in the camera's medium.
    pub(crate) light_media: Vec<LightMedium>,
    /// Whether some medium of `media` scatters or glows (asked once per path).
    scattering_media: bool,
    /// The optics of the scene's Mie particles, computed at the wavelengths carried (each once).
    mie_optics: Vec<Arc<MieSpectralTable>>,
    /// Towards the most powerful light at infinity of one direction or a small disc (the sun), in a scene with Mie
    /// particles: `volpath` guides some scattering directions towards it.
    sun: Option<Vec3>,
    /// The camera.
    pub(crate) camera: Camera,
    /// A sphere (centre, radius > 0) enclosing the geometry: where lights at infinity emit light paths from.
    pub(crate) bounding_sphere: (Vec3, f32),
    /// The shutter interval `[open, close]` when something moves (the camera or some geometry), `None` when
    /// nothing does: then no time is drawn and every ray is traced at time 0.
    pub(crate) motion: Option<[f32; 2]>,
    /// Ray footprints for image maps, which read their MIP maps by them; `None` when no material reads an image
    /// map: then textures are evaluated at points and hits compute no footprint.
    pub(crate) footprints: Option<crate::footprint::Footprints>,
    /// Per material, whether its textures read the footprint (see [`RenderScene::reads_footprint`]); materials
    /// beyond the end of the list are taken to read it.
    pub(crate) material_reads_footprint: Vec<bool>,
}

impl RenderScene {
    /// The number of lights (an area light counts once per primitive of its shape).
    pub fn light_count(&self) -> usize {
        self.lights.len()
    }

    /// The camera (where it is at time 0; see [`Camera::at_time`] for a moving one).
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// Builds the light sampler and the list of infinite lights from `lights` (selection ∝ power; a scene whose
    /// lights all report zero power falls back to uniform selection).
    pub(crate) fn new(
        geometry: Arc<dyn Geometry>,
        materials: Vec<Material>,
        lights: Vec<Light>,
        media: Vec<Medium>,
        camera_medium: Option<u32>,
        camera: Camera,
    ) -> Self {
        // Non-finite powers cannot occur for lights the builder validated; treat them as unusable rather than panic.
        let power: Vec<f64> =
            lights.iter().map(|l| l.power()).map(|p| if p.is_finite() { p.max(0.0) } else { 0.0 }).collect();
        let light_distribution = (!lights.is_empty())
            .then(|| Distribution1D::new(&power, 0.0, 1.0).expect("light powers are finite and non-negative"));
        let infinite_lights =
            lights.iter().enumerate().filter(|(_, l)| l.is_infinite()).map(|(i, _)| i as u32).collect();
        let (c, r) = geometry.bounding_sphere();
        let bounding_sphere = if r > 0.0 && r.is_finite() && c.is_finite() { (c, r) } else { (Vec3::ZERO, 1.0) };
        let scattering_media = media.iter().any(|m| !m.is_absorbing_only());
        let mut mie_optics: Vec<Arc<MieSpectralTable>> = Vec::new();
        for t in media.iter().filter_map(|m| m.mie_optics()) {
            if !mie_optics.iter().any(|u| Arc::ptr_eq(u, t)) {
                mie_optics.push(t.clone());
            }
        }
        let sun = if mie_optics.is_empty() {
            None
        } else {
            lights
                .iter()
                .zip(&power)
                .filter_map(|(l, &p)| l.sun_direction().map(|w| (w, p)))
                .filter(|(w, p)| *p > 0.0 && w.is_finite())
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .map(|(w, _)| w.normalize())
        };
        Self {
            scattering_media,
            mie_optics,
            sun,
            geometry,
            materials,
            normal_perturbations: vec![],
            lights,
            light_distribution,
            infinite_lights,
            media,
            camera_medium,
            light_media: vec![],
            camera,
            bounding_sphere,
            motion: None,
            footprints: None,
            material_reads_footprint: vec![],
        }
    }

    /// Whether a hit on material `material` needs its footprint: the scene has footprints and the material reads
    /// them (an image map among its textures; for a mix, in its amount or a material it may pick).
    #[inline]
    pub(crate) fn reads_footprint(&self, material: u32) -> bool {
        self.footprints.is_some()
            && material != NO_MATERIAL
            && self.material_reads_footprint.get(material as usize).copied().unwrap_or(true)
    }

    /// The time of a camera ray or a light path: uniform over the shutter interval (pbrt-v4's
    /// `CameraBase::SampleTime`), drawing one dimension of `sampler` — only when something moves, so that scenes
    /// without motion draw the random numbers they always did.
    #[inline]
    pub(crate) fn sample_time(&self, sampler: &mut crate::sampler::Sampler) -> f32 {
        match self.motion {
            None => 0.0,
            Some([open, close]) => {
                let u = sampler.next_1d();
                (1.0 - u) * open + u * close
            }
        }
    }

    /// True if some medium scatters or glows (paths then pick their spectral-MIS hero slot at random from the
    /// start, since a shadow ray may track through a chromatic medium before the path enters one).
    pub(crate) fn has_scattering_media(&self) -> bool {
        self.scattering_media
    }

    /// Whether the pixels of a pass share its wavelengths: in a scene with Mie particles, whose optics are
    /// computed at every wavelength carried, so that a pass needs them at four wavelengths, not at four per pixel.
    pub(crate) fn shares_pass_wavelengths(&self) -> bool {
        !self.mie_optics.is_empty()
    }

    /// The direction `volpath` guides scattering in Mie media towards (see [`RenderScene`]'s `sun`).
    pub(crate) fn sun(&self) -> Option<Vec3> {
        self.sun
    }

    /// The work of computing the scene's wavelength-dependent optics at one wavelength, in the units of
    /// [`MieSpectralTable::work_per_wavelength`].
    pub(crate) fn work_per_wavelength(&self) -> f64 {
        self.mie_optics.iter().map(|t| t.work_per_wavelength()).sum()
    }

    /// Computes what depends on the wavelength at `lambdas_nm` ahead of the passes that carry them (in parallel),
    /// and lets go of what was computed for other wavelengths.
    pub(crate) fn prepare_wavelengths(&self, lambdas_nm: &[f64]) {
        for t in &self.mie_optics {
            t.prepare(lambdas_nm);
        }
    }

    /// The medium a light path leaving light `light` along `d` starts in (from a point whose geometric normal is
    /// `n`, for area lights).
    pub(crate) fn light_medium(&self, light: u32, d: Vec3, n: Option<Vec3>) -> Option<u32> {
        match self.light_media.get(light as usize) {
            None => self.camera_medium,
            Some(LightMedium::Fixed(m)) => *m,
            Some(LightMedium::Surface(mi)) => n.map_or(mi.outside, |n| mi.towards(d, n)),
        }
    }

    /// Probability that the light sampler picks light `i`.
    pub(crate) fn light_probability(&self, i: u32) -> f32 {
        self.light_distribution.as_ref().map_or(0.0, |d| d.bin_probability(i as usize) as f32)
    }

    /// Picks a light with `u`: (index, probability).
    pub(crate) fn sample_light(&self, u: f32) -> Option<(u32, f32)> {
        let d = self.light_distribution.as_ref()?;
        let (i, p, _) = d.sample_discrete(u as f64);
        (p > 0.0).then_some((i as u32, p as f32))
    }
}

//! Acceleration structures: the [`Accel`] trait and [`GeometryScene`], a two-level BVH with instancing.
//!
//! A scene is a list of [`Object`]s (each a list of [`Shape`]s) and a list of [`Instance`]s (an object placed by a
//! render-from-instance transform). Every object gets a bottom-level compressed wide BVH (BVH8, `obvhs`) over its
//! primitives in its own space; a top-level BVH8 is built over the instances' render-space bounds. Objects are
//! built in parallel (rayon), and each BVH build is itself parallel (`obvhs`'s PLOC builder).
//!
//! Traversal uses `obvhs`'s `traverse!` loop with our own node test (an SSE-width slab test through glam's `Vec4`
//! with no minimum-`t` epsilon, and pbrt's `1 + 2γ(3)` widening of the far distance). Leaves ask the shapes: plain
//! triangles (`Shape::element_triangle`) are copied into the BVH and tested there with the watertight triangle
//! test, every other primitive through its [`Shape`]'s element queries (f64 sphere, disk and bilinear-patch tests),
//! so this file never looks at shape kinds. Hits are found down to `t → 0⁺` and rays spawned with
//! [`crate::spawn_ray`] never re-hit their surface.
//!
//! ## IDs in a [`Hit`]
//! - `instance`: index into the `instances` given to [`GeometryScene::build`].
//! - `object`: the instance's object, an index into the `objects` given to [`GeometryScene::build`].
//! - `shape`: index into that object's `shapes`.
//! - `element`: the primitive within the shape (triangle or patch index for a mesh; 0 for a sphere or disk).
//! - `primitive`: index into the object's flattened primitive list, in which the shapes' primitives follow each
//!   other in order: `primitive = primitive_range(object, shape).start + element`.

use std::ops::Range;
use std::sync::Arc;
use std::time::Duration;

use glam::{DMat3, DMat4, Mat3, UVec2, Vec2, Vec3, Vec3A, Vec4};
use obvhs::aabb::Aabb;
use obvhs::cwbvh::node::CwBvhNode;
use obvhs::cwbvh::CwBvh;
use obvhs::BvhBuildParams;
use rayon::prelude::*;

use crate::animated::{transform_bounds, AnimatedTransform};
use crate::bounds::Bounds3;
use crate::mesh::TriangleMesh;
use crate::ray::{gamma, spawn_ray, spawn_ray_to, spawn_ray_to_point, Ray, SurfacePoint};
pub use crate::shapes::Shape;
use crate::shapes::{
    coordinate_system, d_normalize, intersect_inline_triangle, ElementHit, ShapeRay, SurfaceDerivatives, SurfaceGeom,
};
use crate::transform::Transform;
use crate::GeometryError;

/// A ray–scene intersection: anything that answers closest-hit and occlusion queries.
pub trait Accel: Send + Sync {
    /// The closest hit with `0 < t < t_max` (`t` in units of `|ray.d|`), if any.
    fn intersect(&self, ray: &Ray, t_max: f32) -> Option<Hit>;
    /// True if anything is hit with `0 < t < t_max`.
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool;
    /// Render-space bounds of everything.
    fn bounds(&self) -> Bounds3;
}

/// A ray hit with the surface geometry the renderer needs, all in render space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit (in units of `|ray.d|`).
    pub t: f32,
    /// The hit point.
    pub p: Vec3,
    /// Conservative absolute error bound of each coordinate of `p` (used by [`Hit::spawn_ray`]).
    pub p_error: Vec3,
    /// Unit geometric normal, oriented as pbrt-v4 orients it (independent of the ray; the side an area light emits
    /// to): see [`TriangleMesh`] for triangles and [`crate::BilinearMesh`] for bilinear patches; outward for spheres
    /// and +z (object space) for disks, negated under `ReverseOrientation`.
    pub n: Vec3,
    /// Unit shading normal: the interpolated vertex normal for meshes that have normals, else `n`. Always on the
    /// same side as `n`.
    pub ns: Vec3,
    /// Surface coordinates.
    pub uv: Vec2,
    /// ∂p/∂u (not normalized; a tangent of the surface).
    pub dpdu: Vec3,
    /// Unit tangent perpendicular to `ns` (∂p/∂u made orthogonal to `ns`), for shading frames.
    pub tangent: Vec3,
    /// pbrt-v4's shading ∂p/∂u (not normalized): ∂p/∂u, or for meshes with vertex normals ∂p/∂u turned to `ns`
    /// (triangles: made perpendicular to `ns`; bilinear patches: rotated with the normal), as pbrt-v4's shapes set
    /// it. Bump and normal mapping perturb these.
    pub shading_dpdu: Vec3,
    /// pbrt-v4's shading ∂p/∂v (not normalized): ∂p/∂v, or for triangles with vertex normals `ns × ∂p/∂u`, for
    /// bilinear patches with vertex normals ∂p/∂v rotated with the normal.
    pub shading_dpdv: Vec3,
    /// The instance hit (index into the `instances` given to [`GeometryScene::build`]).
    pub instance: u32,
    /// The object of that instance (index into the `objects`).
    pub object: u32,
    /// Index into the object's flattened primitive list (see the module docs).
    pub primitive: u32,
    /// Index of the shape within the object.
    pub shape: u32,
    /// Primitive within the shape (triangle or patch index for meshes, 0 otherwise).
    pub element: u32,
}

impl Hit {
    /// The hit as a point to spawn rays from.
    pub fn surface_point(&self) -> SurfacePoint {
        SurfacePoint { p: self.p, p_error: self.p_error, n: self.n }
    }

    /// A ray leaving the surface in direction `w` (to either side) that cannot re-hit it.
    pub fn spawn_ray(&self, w: Vec3) -> Ray {
        spawn_ray(&self.surface_point(), w)
    }

    /// A shadow ray to another surface point and its `t_max` (see [`crate::spawn_ray_to`]).
    pub fn spawn_ray_to(&self, to: &SurfacePoint) -> (Ray, f32) {
        spawn_ray_to(&self.surface_point(), to)
    }

    /// A shadow ray to a point not on a surface and its `t_max`.
    pub fn spawn_ray_to_point(&self, p: Vec3) -> (Ray, f32) {
        spawn_ray_to_point(&self.surface_point(), p)
    }
}

/// A list of shapes intersected as a unit and placed in the scene by instances.
#[derive(Clone, Debug, Default)]
pub struct Object {
    /// The shapes, in the object's (instance) space.
    pub shapes: Vec<Shape>,
}

impl Object {
    /// An object of these shapes.
    pub fn new(shapes: Vec<Shape>) -> Self {
        Self { shapes }
    }
}

/// An object placed in the scene. Non-instanced geometry is one object with one instance with the identity
/// transform (its shapes already in render space).
#[derive(Clone, Debug)]
pub struct Instance {
    /// Index into the objects.
    pub object: u32,
    /// Render-from-instance transform.
    pub render_from_instance: Transform,
}

/// An object that moves while the shutter is open: at time t it is placed by `outer(t) · inner(t)` (an instance's
/// motion, and the motion of a moving shape inside its object; either may be fixed). Moving instances are kept out
/// of the static instances' top-level BVH: they have their own, over bounds that cover their motion, so scenes
/// without motion are traversed as before.
#[derive(Clone, Debug)]
pub struct MovingInstance {
    /// Index into the objects.
    pub object: u32,
    /// Render from instance space (the `ObjectInstance`'s transform), applied last.
    pub outer: AnimatedTransform,
    /// Instance space from the object's own space (a moving shape's transform inside an object), applied first.
    pub inner: AnimatedTransform,
}

impl MovingInstance {
    /// The render-from-object transform at `time`.
    pub fn render_from_instance(&self, time: f32) -> Transform {
        let outer = self.outer.at(time as f64);
        if !self.inner.is_animated() && self.inner.start().is_identity() {
            return outer;
        }
        outer * self.inner.at(time as f64)
    }

    /// Render-space bounds of everything the object (with bounds `b` in its own space) covers during the motion.
    fn motion_bounds(&self, b: &Bounds3) -> Bounds3 {
        if !self.inner.is_animated() && self.inner.start().is_identity() {
            return self.outer.motion_bounds(b);
        }
        self.outer.motion_bounds(&self.inner.motion_bounds(b))
    }
}

/// Bit marking a BVH slot whose primitive is intersected through its shape rather than as an inline triangle (see
/// [`Shape::element_triangle`]).
const INDIRECT: u32 = 1 << 31;

/// Bottom-level structure of one object.
struct Blas {
    shapes: Vec<Shape>,
    /// Flattened primitive index where each shape starts; one more entry at the end (the total).
    shape_starts: Vec<u32>,
    bvh: CwBvh,
    /// One record per BVH slot, the leaf's primitive with its triangle inline (see [`Slot`]).
    slots: Vec<Slot>,
    bounds: Bounds3,
}

/// A BVH leaf slot: the triangle's vertices (zeros for indirect slots), so triangles are tested without a lookup,
/// and the flattened primitive index, `| INDIRECT` for primitives that are not plain triangles. Kept together so
/// that a leaf visit touches one stream of memory, not two (the loads of a leaf's data are the traversal's main
/// cache misses on big meshes).
struct Slot {
    tri: [Vec3; 3],
    prim: u32,
}

#[derive(Clone)]
struct InstanceData {
    object: u32,
    identity: bool,
    render_from_instance: DMat4,
    instance_from_render: DMat4,
    linear: Mat3,
    abs_linear: Mat3,
    abs_translation: Vec3,
    normal_matrix: Mat3,
    transform: Transform,
    bounds: Bounds3,
}

/// The two-level BVH over a scene's objects and instances; see the module documentation.
pub struct GeometryScene {
    objects: Vec<Blas>,
    instances: Vec<InstanceData>,
    tlas: CwBvh,
    /// Instance index per top-level BVH slot.
    tlas_slot_instance: Vec<u32>,
    /// Moving instances; in a [`Hit`] they follow the static ones (`instance = instances.len() + k`).
    moving: Vec<MovingInstance>,
    /// Top-level BVH over the moving instances' motion bounds.
    moving_tlas: CwBvh,
    /// Moving-instance index per slot of `moving_tlas`.
    moving_slot: Vec<u32>,
    bounds: Bounds3,
    build_time: Duration,
}

/// The BVH box of a primitive: its bounds grown by a few ulps of their magnitude, so the rounding in the
/// compressed child boxes can never leave part of the primitive outside.
fn to_aabb(b: &Bounds3) -> Aabb {
    let grow = (b.min.abs().max(b.max.abs())) * (4.0 * f32::EPSILON) + Vec3::splat(f32::MIN_POSITIVE);
    Aabb::new(Vec3A::from(b.min - grow), Vec3A::from(b.max + grow))
}

fn build_params(count: usize) -> BvhBuildParams {
    // Cheaper builds for big inputs would go here; the medium preset (PLOC + reinsertion) measures best overall.
    let _ = count;
    BvhBuildParams::medium_build()
}

fn build_bvh(aabbs: &[Aabb]) -> CwBvh {
    if aabbs.is_empty() {
        return CwBvh::default();
    }
    // obvhs's `build_cwbvh` without its debug-build validation (whose fixed 1e-5 tolerance trips on far-away
    // geometry): PLOC, reinsertion, then collapse to the 8-wide compressed layout with up to 3 primitives per leaf.
    let p = build_params(aabbs.len());
    let mut bvh2 = obvhs::ploc::PlocBuilder::with_capacity(aabbs.len()).build(
        p.ploc_search_distance,
        aabbs,
        (0..aabbs.len() as u32).collect(),
        p.sort_precision,
        p.search_depth_threshold,
    );
    obvhs::bvh2::reinsertion::ReinsertionOptimizer::default().run(&mut bvh2, p.reinsertion_batch_ratio, None);
    obvhs::cwbvh::bvh2_to_cwbvh::bvh2_to_cwbvh(&bvh2, p.max_prims_per_leaf.clamp(1, 3), true, false)
}

impl Blas {
    fn build(object: Object) -> Result<Self, GeometryError> {
        let shapes = object.shapes;
        let mut shape_starts = Vec::with_capacity(shapes.len() + 1);
        let mut total: u64 = 0;
        for s in &shapes {
            shape_starts.push(total as u32);
            total += s.primitive_count() as u64;
            if total >= u64::from(INDIRECT) {
                return Err(GeometryError::InvalidMesh(format!("an object has too many primitives ({total})")));
            }
        }
        shape_starts.push(total as u32);
        // Per-primitive (shape, element) and bounds.
        let prims: Vec<(u32, u32)> = shapes
            .iter()
            .enumerate()
            .flat_map(|(s, shape)| (0..shape.primitive_count() as u32).map(move |e| (s as u32, e)))
            .collect();
        let aabbs: Vec<Aabb> =
            prims.par_iter().map(|&(s, e)| to_aabb(&shapes[s as usize].element_bounds(e as usize))).collect();
        let bounds = shapes.iter().fold(Bounds3::EMPTY, |b, s| b.union(&s.bounds()));
        let mut bvh = build_bvh(&aabbs);
        let slots: Vec<Slot> = bvh
            .primitive_indices
            .par_iter()
            .map(|&i| {
                let (s, e) = prims[i as usize];
                match shapes[s as usize].element_triangle(e as usize) {
                    Some(tri) => Slot { tri, prim: i },
                    None => Slot { tri: [Vec3::ZERO; 3], prim: i | INDIRECT },
                }
            })
            .collect();
        bvh.primitive_indices = Vec::new();
        Ok(Self { shapes, shape_starts, bvh, slots, bounds })
    }

    fn locate(&self, prim: u32) -> (u32, u32) {
        let s = self.shape_starts.partition_point(|&x| x <= prim) - 1;
        (s as u32, prim - self.shape_starts[s])
    }
}

/// Ray data for the node test.
struct NodeRay {
    o: Vec3A,
    inv_d: Vec3A,
    neg: [bool; 3],
}

impl NodeRay {
    fn new(o: Vec3, d: Vec3) -> Self {
        // Clamp tiny components so no inf or NaN enters the slab test; 1e20 bounds keep every product finite.
        let inv = |x: f32| if x.abs() < 1e-20 { 1e20f32.copysign(x) } else { 1.0 / x };
        let inv_d = Vec3A::new(inv(d.x), inv(d.y), inv(d.z));
        // The slab order follows the sign of the inverse (so −0.0 components are handled consistently).
        Self { o: o.into(), inv_d, neg: [inv_d.x < 0.0, inv_d.y < 0.0, inv_d.z < 0.0] }
    }
}

/// Far-distance widening so float error never culls a box the ray touches (pbrt-v4's `1 + 2γ(3)`).
const FAR_SCALE: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// Slab test of the ray against the eight quantized child boxes of `node`; returns `obvhs`'s hit mask.
///
/// Each box plane is first decoded to a float (`p + q·e`, with `q·e` exact), then `(plane − o) · (1/d)` is
/// evaluated, so every slab distance carries only a relative error of a few ulps and pbrt's `1 + 2γ(3)` widening of
/// the far distance makes the test conservative (no ray that touches a box is culled, even one grazing a box face
/// from an origin on that face). Primitive boxes are grown by a few ulps before the build (see [`to_aabb`]) to
/// cover the rounding of the quantized child boxes.
#[inline(always)]
fn node_hits(node: &CwBvhNode, r: &NodeRay, t_max: f32, oct_inv4: u32) -> u32 {
    let e = node.compute_extent();
    let (ex, ey, ez) = (Vec4::splat(e.x), Vec4::splat(e.y), Vec4::splat(e.z));
    let (px, py, pz) = (Vec4::splat(node.p.x), Vec4::splat(node.p.y), Vec4::splat(node.p.z));
    let (ox, oy, oz) = (Vec4::splat(r.o.x), Vec4::splat(r.o.y), Vec4::splat(r.o.z));
    let (ix, iy, iz) = (Vec4::splat(r.inv_d.x), Vec4::splat(r.inv_d.y), Vec4::splat(r.inv_d.z));
    let (child_bits8, bit_index8) = node.get_child_and_index_bits(oct_inv4);
    let t_max4 = Vec4::splat(t_max);
    let mut hit_mask = 0u32;
    for i in 0..2 {
        let q = |a: &[u8; 8]| Vec4::new(a[4 * i] as f32, a[4 * i + 1] as f32, a[4 * i + 2] as f32, a[4 * i + 3] as f32);
        let pick = |lo: Vec4, hi: Vec4, neg: bool| if neg { (hi, lo) } else { (lo, hi) };
        let (x0, x1) = pick(q(&node.child_min_x), q(&node.child_max_x), r.neg[0]);
        let (y0, y1) = pick(q(&node.child_min_y), q(&node.child_max_y), r.neg[1]);
        let (z0, z1) = pick(q(&node.child_min_z), q(&node.child_max_z), r.neg[2]);
        let tx0 = ((x0 * ex + px) - ox) * ix;
        let tx1 = ((x1 * ex + px) - ox) * ix;
        let ty0 = ((y0 * ey + py) - oy) * iy;
        let ty1 = ((y1 * ey + py) - oy) * iy;
        let tz0 = ((z0 * ez + pz) - oz) * iz;
        let tz1 = ((z1 * ez + pz) - oz) * iz;
        let t0 = tx0.max(ty0).max(tz0).max(Vec4::ZERO);
        let t1 = (tx1.min(ty1).min(tz1) * FAR_SCALE).min(t_max4);
        let mask = t0.cmple(t1).bitmask();
        if mask == 0 {
            continue;
        }
        for j in 0..4 {
            if mask & (1 << j) != 0 {
                let child = 4 * i + j;
                let child_bits = ((child_bits8 >> (child * 8)) as u32) & 0xff;
                let bit_index = ((bit_index8 >> (child * 8)) as u32) & 0xff;
                hit_mask |= child_bits << bit_index;
            }
        }
    }
    hit_mask
}

/// Closest hit so far.
#[derive(Clone, Copy)]
struct Closest {
    hit: ElementHit,
    instance: u32,
    prim: u32,
}

impl Closest {
    /// No hit yet: anything nearer than `t_max` is closer.
    fn none(t_max: f32) -> Self {
        Self { hit: ElementHit::at_coords(t_max, [0.0; 3]), instance: u32::MAX, prim: 0 }
    }
}

impl Blas {
    /// Closest hit in this object's space; updates `best` (and its `t`) when closer.
    #[inline]
    fn closest(&self, o: Vec3, d: Vec3, instance: u32, best: &mut Closest) {
        if self.bvh.nodes.is_empty() {
            return;
        }
        let ray = ShapeRay::new(o, d);
        let node_ray = NodeRay::new(o, d);
        let bvh = &self.bvh;
        let mut state = bvh.new_traversal(Vec3A::from(d));
        let mut node;
        obvhs::traverse!(bvh, node, state, node_hits(node, &node_ray, best.hit.t, state.oct_inv4), {
            let slot = &self.slots[state.primitive_id as usize];
            let prim = slot.prim;
            if prim & INDIRECT == 0 {
                if let Some(hit) = intersect_inline_triangle(&ray, &slot.tri, best.hit.t) {
                    *best = Closest { hit, instance, prim };
                }
            } else {
                let prim = prim & !INDIRECT;
                let (s, e) = self.locate(prim);
                if let Some(hit) = self.shapes[s as usize].intersect_element(e as usize, &ray, best.hit.t) {
                    *best = Closest { hit, instance, prim };
                }
            }
        });
    }

    /// True if anything in this object is hit with `0 < t < t_max`.
    #[inline]
    fn any(&self, o: Vec3, d: Vec3, t_max: f32) -> bool {
        if self.bvh.nodes.is_empty() {
            return false;
        }
        let ray = ShapeRay::new(o, d);
        let node_ray = NodeRay::new(o, d);
        let bvh = &self.bvh;
        let mut state = bvh.new_traversal(Vec3A::from(d));
        let mut node;
        let mut hit = false;
        'search: {
            obvhs::traverse!(bvh, node, state, node_hits(node, &node_ray, t_max, state.oct_inv4), {
                let slot = &self.slots[state.primitive_id as usize];
                let prim = slot.prim;
                let found = if prim & INDIRECT == 0 {
                    intersect_inline_triangle(&ray, &slot.tri, t_max).is_some()
                } else {
                    let (s, e) = self.locate(prim & !INDIRECT);
                    self.shapes[s as usize].occludes_element(e as usize, &ray, t_max)
                };
                if found {
                    hit = true;
                    break 'search;
                }
            });
        }
        hit
    }
}

impl InstanceData {
    /// The instance of `object` placed by `t`, whose render-space bounds are `bounds`.
    fn new(object: u32, t: Transform, bounds: Bounds3) -> Self {
        let m = t.matrix();
        let lin = DMat3::from_mat4(m);
        InstanceData {
            object,
            identity: t.is_identity(),
            render_from_instance: m,
            instance_from_render: t.inverse_matrix(),
            linear: lin.as_mat3(),
            abs_linear: Mat3::from_cols(
                lin.x_axis.abs().as_vec3(),
                lin.y_axis.abs().as_vec3(),
                lin.z_axis.abs().as_vec3(),
            ),
            abs_translation: m.w_axis.truncate().abs().as_vec3(),
            normal_matrix: DMat3::from_mat4(t.inverse_matrix()).transpose().as_mat3(),
            transform: t,
            bounds,
        }
    }

    /// The ray in instance space (origin transformed in f64), same `t` parametrization.
    #[inline]
    fn to_instance(&self, o: Vec3, d: Vec3) -> (Vec3, Vec3) {
        if self.identity {
            return (o, d);
        }
        let m = &self.instance_from_render;
        let oi = m.transform_point3(o.as_dvec3()).as_vec3();
        let di = m.transform_vector3(d.as_dvec3()).as_vec3();
        (oi, di)
    }

    /// Render-space derivatives at an instance-space surface point `g`: tangents by the linear part; the shading
    /// normal's by the normal matrix followed by normalization (and the flip [`InstanceData::geom_to_render`]
    /// applies to keep the shading normal on the geometric normal's side).
    fn derivatives_to_render(&self, g: &SurfaceGeom, d: SurfaceDerivatives) -> SurfaceDerivatives {
        if self.identity {
            return d;
        }
        let m = self.normal_matrix;
        let nm = m * g.ns;
        let mut sign = 1.0;
        if (m * g.n).dot(nm) < 0.0 {
            sign = -1.0;
        }
        SurfaceDerivatives {
            dpdu: self.linear * d.dpdu,
            dpdv: self.linear * d.dpdv,
            dndu: sign * d_normalize(nm, m * d.dndu),
            dndv: sign * d_normalize(nm, m * d.dndv),
        }
    }

    #[inline]
    fn geom_to_render(&self, g: SurfaceGeom) -> SurfaceGeom {
        if self.identity {
            return g;
        }
        let p = self.render_from_instance.transform_point3(g.p.as_dvec3()).as_vec3();
        let p_error = (1.0 + gamma(3)) * (self.abs_linear * g.p_error)
            + gamma(3) * (self.abs_linear * g.p.abs() + self.abs_translation);
        let n = (self.normal_matrix * g.n).normalize_or_zero();
        let mut ns = (self.normal_matrix * g.ns).normalize_or_zero();
        if ns.dot(n) < 0.0 {
            ns = -ns;
        }
        SurfaceGeom {
            p,
            p_error,
            n,
            ns,
            uv: g.uv,
            dpdu: self.linear * g.dpdu,
            shading_dpdu: self.linear * g.shading_dpdu,
            shading_dpdv: self.linear * g.shading_dpdv,
        }
    }
}

impl GeometryScene {
    /// Builds the BVHs (in parallel). Errors if an instance names a missing object or an object has more than
    /// 2³¹ primitives.
    pub fn build(objects: Vec<Object>, instances: Vec<Instance>) -> Result<Self, GeometryError> {
        Self::build_with_motion(objects, instances, Vec::new())
    }

    /// [`GeometryScene::build`] with instances that move during the shutter; rays find them where they are at the
    /// ray's time ([`Ray::time`]).
    pub fn build_with_motion(
        objects: Vec<Object>,
        instances: Vec<Instance>,
        moving: Vec<MovingInstance>,
    ) -> Result<Self, GeometryError> {
        let start = std::time::Instant::now();
        let n_objects = objects.len();
        for (i, m) in moving.iter().enumerate() {
            if m.object as usize >= n_objects {
                return Err(GeometryError::InvalidInstance(format!(
                    "moving instance {i} refers to object {} but there are {n_objects} objects",
                    m.object
                )));
            }
        }
        for (i, inst) in instances.iter().enumerate() {
            if inst.object as usize >= n_objects {
                return Err(GeometryError::InvalidInstance(format!(
                    "instance {i} refers to object {} but there are {n_objects} objects",
                    inst.object
                )));
            }
            if !inst.render_from_instance.matrix().is_finite()
                || !inst.render_from_instance.inverse_matrix().is_finite()
            {
                return Err(GeometryError::InvalidInstance(format!("instance {i} has a non-finite transform")));
            }
        }
        let objects: Vec<Blas> = objects.into_par_iter().map(Blas::build).collect::<Result<_, _>>()?;
        let instances: Vec<InstanceData> = instances
            .into_iter()
            .map(|inst| {
                let t = inst.render_from_instance;
                let ob = objects[inst.object as usize].bounds;
                let bounds = if ob.is_empty() {
                    Bounds3::EMPTY
                } else if t.is_identity() {
                    ob
                } else {
                    transform_bounds(&t, &ob)
                };
                InstanceData::new(inst.object, t, bounds)
            })
            .collect();
        let live: Vec<u32> =
            (0..instances.len() as u32).filter(|&i| !instances[i as usize].bounds.is_empty()).collect();
        let aabbs: Vec<Aabb> = live.iter().map(|&i| to_aabb(&instances[i as usize].bounds)).collect();
        let mut tlas = build_bvh(&aabbs);
        let tlas_slot_instance = tlas.primitive_indices.iter().map(|&k| live[k as usize]).collect();
        tlas.primitive_indices = Vec::new();
        let mut bounds = instances.iter().fold(Bounds3::EMPTY, |b, i| b.union(&i.bounds));
        // Moving instances: a top-level BVH of their own over the bounds of their whole motion.
        let moving_bounds: Vec<Bounds3> =
            moving.iter().map(|m| m.motion_bounds(&objects[m.object as usize].bounds)).collect();
        let live: Vec<u32> = (0..moving.len() as u32).filter(|&k| !moving_bounds[k as usize].is_empty()).collect();
        let aabbs: Vec<Aabb> = live.iter().map(|&k| to_aabb(&moving_bounds[k as usize])).collect();
        let mut moving_tlas = build_bvh(&aabbs);
        let moving_slot = moving_tlas.primitive_indices.iter().map(|&k| live[k as usize]).collect();
        moving_tlas.primitive_indices = Vec::new();
        bounds = moving_bounds.iter().fold(bounds, |b, m| b.union(m));
        Ok(Self {
            objects,
            instances,
            tlas,
            tlas_slot_instance,
            moving,
            moving_tlas,
            moving_slot,
            bounds,
            build_time: start.elapsed(),
        })
    }

    /// Wall-clock time [`GeometryScene::build`] took.
    pub fn build_time(&self) -> Duration {
        self.build_time
    }

    /// Number of objects.
    pub fn object_count(&self) -> usize {
        self.objects.len()
    }

    /// Number of (static) instances.
    pub fn instance_count(&self) -> usize {
        self.instances.len()
    }

    /// Number of moving instances (numbered after the static ones in a [`Hit`]).
    pub fn moving_instance_count(&self) -> usize {
        self.moving.len()
    }

    /// The instance data of `instance` (static, or moving and placed at `time`).
    fn instance_at(&self, instance: u32, time: f32) -> std::borrow::Cow<'_, InstanceData> {
        match self.instances.get(instance as usize) {
            Some(i) => std::borrow::Cow::Borrowed(i),
            None => std::borrow::Cow::Owned(self.moving_at(instance, time)),
        }
    }

    /// Moving instance `instance` (numbered after the static ones) placed where it is at `time`.
    #[inline(never)]
    fn moving_at(&self, instance: u32, time: f32) -> InstanceData {
        let m = &self.moving[instance as usize - self.instances.len()];
        InstanceData::new(m.object, m.render_from_instance(time), Bounds3::EMPTY)
    }

    /// The object and render-from-instance transform of static instance `instance`; `None` if out of range or
    /// moving.
    pub fn instance(&self, instance: u32) -> Option<(u32, &Transform)> {
        self.instances.get(instance as usize).map(|i| (i.object, &i.transform))
    }

    /// The shapes of object `object` (empty if out of range).
    pub fn shapes(&self, object: u32) -> &[Shape] {
        self.objects.get(object as usize).map_or(&[], |o| &o.shapes)
    }

    /// Total number of primitives of object `object`.
    pub fn primitive_count(&self, object: u32) -> u32 {
        self.objects.get(object as usize).map_or(0, |o| *o.shape_starts.last().unwrap_or(&0))
    }

    /// The flattened primitive indices of shape `shape` of object `object` (empty if out of range).
    pub fn primitive_range(&self, object: u32, shape: u32) -> Range<u32> {
        match self.objects.get(object as usize) {
            Some(o) if (shape as usize) < o.shapes.len() => {
                o.shape_starts[shape as usize]..o.shape_starts[shape as usize + 1]
            }
            _ => 0..0,
        }
    }

    /// The `(shape, element)` of flattened primitive `primitive` of object `object`; `None` if out of range.
    pub fn locate(&self, object: u32, primitive: u32) -> Option<(u32, u32)> {
        let o = self.objects.get(object as usize)?;
        (primitive < *o.shape_starts.last()?).then(|| o.locate(primitive))
    }

    #[inline]
    fn finish(&self, ray: &Ray, c: &Closest) -> Hit {
        let moved;
        let inst = match self.instances.get(c.instance as usize) {
            Some(inst) => inst,
            None => {
                moved = self.moving_at(c.instance, ray.time);
                &moved
            }
        };
        let blas = &self.objects[inst.object as usize];
        let (shape, element) = blas.locate(c.prim);
        let g = inst.geom_to_render(blas.shapes[shape as usize].surface_geom(element as usize, &c.hit));
        let mut tangent = g.dpdu - g.ns * g.ns.dot(g.dpdu);
        tangent = tangent.try_normalize().unwrap_or_else(|| coordinate_system(g.ns).0);
        Hit {
            t: c.hit.t,
            p: g.p,
            p_error: g.p_error,
            n: g.n,
            ns: g.ns,
            uv: g.uv,
            dpdu: g.dpdu,
            tangent,
            shading_dpdu: g.shading_dpdu,
            shading_dpdv: g.shading_dpdv,
            instance: c.instance,
            object: inst.object,
            primitive: c.prim,
            shape,
            element,
        }
    }

    fn valid_ray(ray: &Ray, t_max: f32) -> bool {
        ray.o.is_finite() && ray.d.is_finite() && ray.d != Vec3::ZERO && t_max > 0.0 && !t_max.is_nan()
    }
}

impl GeometryScene {
    /// The closest primitive hit, before its surface geometry is computed (shared by [`Accel::intersect`] and
    /// [`GeometryScene::intersect_with_derivatives`]).
    #[inline]
    fn closest_hit(&self, ray: &Ray, t_max: f32) -> Option<Closest> {
        if !Self::valid_ray(ray, t_max) {
            return None;
        }
        let mut best = Closest::none(t_max);
        if self.tlas_slot_instance.len() == 1 {
            let i = self.tlas_slot_instance[0];
            let inst = &self.instances[i as usize];
            let (o, d) = inst.to_instance(ray.o, ray.d);
            self.objects[inst.object as usize].closest(o, d, i, &mut best);
        } else if !self.tlas.nodes.is_empty() {
            let node_ray = NodeRay::new(ray.o, ray.d);
            let tlas = &self.tlas;
            let mut state = tlas.new_traversal(Vec3A::from(ray.d));
            let mut node;
            obvhs::traverse!(tlas, node, state, node_hits(node, &node_ray, best.hit.t, state.oct_inv4), {
                let i = self.tlas_slot_instance[state.primitive_id as usize];
                let inst = &self.instances[i as usize];
                let (o, d) = inst.to_instance(ray.o, ray.d);
                self.objects[inst.object as usize].closest(o, d, i, &mut best);
            });
        }
        if !self.moving.is_empty() {
            self.closest_moving(ray, &mut best);
        }
        (best.instance != u32::MAX).then_some(best)
    }

    /// The moving instances' part of [`GeometryScene::closest_hit`]: each is placed where it is at the ray's time.
    /// Out of line, so that the static path's code stays as it was.
    #[cold]
    #[inline(never)]
    fn closest_moving(&self, ray: &Ray, best: &mut Closest) {
        if self.moving_tlas.nodes.is_empty() {
            return;
        }
        let n_static = self.instances.len() as u32;
        let node_ray = NodeRay::new(ray.o, ray.d);
        let tlas = &self.moving_tlas;
        let mut state = tlas.new_traversal(Vec3A::from(ray.d));
        let mut node;
        obvhs::traverse!(tlas, node, state, node_hits(node, &node_ray, best.hit.t, state.oct_inv4), {
            let k = self.moving_slot[state.primitive_id as usize];
            let inst = self.moving_at(n_static + k, ray.time);
            let (o, d) = inst.to_instance(ray.o, ray.d);
            self.objects[inst.object as usize].closest(o, d, n_static + k, best);
        });
    }

    /// True if a moving instance, placed where it is at the ray's time, is hit with `0 < t < t_max`.
    #[cold]
    #[inline(never)]
    fn occluded_moving(&self, ray: &Ray, t_max: f32) -> bool {
        if self.moving_tlas.nodes.is_empty() {
            return false;
        }
        let n_static = self.instances.len() as u32;
        let node_ray = NodeRay::new(ray.o, ray.d);
        let tlas = &self.moving_tlas;
        let mut state = tlas.new_traversal(Vec3A::from(ray.d));
        let mut node;
        let mut hit = false;
        'search: {
            obvhs::traverse!(tlas, node, state, node_hits(node, &node_ray, t_max, state.oct_inv4), {
                let k = self.moving_slot[state.primitive_id as usize];
                let inst = self.moving_at(n_static + k, ray.time);
                let (o, d) = inst.to_instance(ray.o, ray.d);
                if self.objects[inst.object as usize].any(o, d, t_max) {
                    hit = true;
                    break 'search;
                }
            });
        }
        hit
    }

    /// The closest hit with `0 < t < t_max`, as [`Accel::intersect`] finds it, with the surface's first derivatives
    /// there in render space (`None` for hits on shapes that do not provide them). For specular-chain solvers;
    /// [`Accel::intersect`] itself never computes derivatives.
    pub fn intersect_with_derivatives(&self, ray: &Ray, t_max: f32) -> Option<(Hit, Option<SurfaceDerivatives>)> {
        let c = self.closest_hit(ray, t_max)?;
        let inst = self.instance_at(c.instance, ray.time);
        let blas = &self.objects[inst.object as usize];
        let (shape, element) = blas.locate(c.prim);
        let shape = &blas.shapes[shape as usize];
        let d = shape.derivatives(element as usize, &c.hit).map(|d| {
            let g = shape.surface_geom(element as usize, &c.hit);
            inst.derivatives_to_render(&g, d)
        });
        Some((self.finish(ray, &c), d))
    }
}

impl Accel for GeometryScene {
    fn intersect(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        let c = self.closest_hit(ray, t_max)?;
        Some(self.finish(ray, &c))
    }

    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        if !Self::valid_ray(ray, t_max) {
            return false;
        }
        if !self.moving.is_empty() && self.occluded_moving(ray, t_max) {
            return true;
        }
        if self.tlas_slot_instance.len() == 1 {
            let inst = &self.instances[self.tlas_slot_instance[0] as usize];
            let (o, d) = inst.to_instance(ray.o, ray.d);
            return self.objects[inst.object as usize].any(o, d, t_max);
        }
        if self.tlas.nodes.is_empty() {
            return false;
        }
        let node_ray = NodeRay::new(ray.o, ray.d);
        let tlas = &self.tlas;
        let mut state = tlas.new_traversal(Vec3A::from(ray.d));
        let mut node;
        let mut hit = false;
        'search: {
            obvhs::traverse!(tlas, node, state, node_hits(node, &node_ray, t_max, state.oct_inv4), {
                let inst = &self.instances[self.tlas_slot_instance[state.primitive_id as usize] as usize];
                let (o, d) = inst.to_instance(ray.o, ray.d);
                if self.objects[inst.object as usize].any(o, d, t_max) {
                    hit = true;
                    break 'search;
                }
            });
        }
        hit
    }

    fn bounds(&self) -> Bounds3 {
        self.bounds
    }
}

impl GeometryScene {
    /// Convenience: one object of `shapes` (already in render space) with one identity instance.
    pub fn from_shapes(shapes: Vec<Shape>) -> Result<Self, GeometryError> {
        Self::build(vec![Object::new(shapes)], vec![Instance { object: 0, render_from_instance: Transform::IDENTITY }])
    }

    /// Convenience: a shape holding a mesh.
    pub fn mesh_shape(mesh: TriangleMesh) -> Shape {
        Shape::Mesh(Arc::new(mesh))
    }

    /// Brute-force closest hit over every primitive of every instance (for tests and debugging).
    pub fn intersect_brute_force(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        if !Self::valid_ray(ray, t_max) {
            return None;
        }
        let mut best = Closest::none(t_max);
        for i in 0..self.instances.len() + self.moving.len() {
            let inst = self.instance_at(i as u32, ray.time);
            let (o, d) = inst.to_instance(ray.o, ray.d);
            let blas = &self.objects[inst.object as usize];
            let ray = ShapeRay::new(o, d);
            for (s, shape) in blas.shapes.iter().enumerate() {
                for e in 0..shape.primitive_count() {
                    if let Some(hit) = shape.intersect_element(e, &ray, best.hit.t) {
                        best = Closest { hit, instance: i as u32, prim: blas.shape_starts[s] + e as u32 };
                    }
                }
            }
        }
        (best.instance != u32::MAX).then(|| self.finish(ray, &best))
    }
}

//! Acceleration structures: the [`Accel`] trait and [`GeometryScene`], a two-level BVH with instancing.
//!
//! A scene is a list of [`Object`]s (each a list of [`Shape`]s) and a list of [`Instance`]s (an object placed by a
//! render-from-instance transform). Every object gets a bottom-level wide BVH over its primitives in its own space,
//! and a top-level one is built over the instances' render-space bounds: binary BVHs built by `obvhs` (PLOC,
//! reinsertion) and collapsed to eight children with float child boxes (the `collapse` and `wide` modules). Objects
//! are built in parallel (rayon), and each BVH build is itself parallel (`obvhs`'s PLOC builder).
//!
//! Both levels are traversed by the `wide` module's two loops: closest-hit queries visit a node's children nearest
//! first, occlusion queries in the reverse of the ray's octant order (which measured faster); the node test is an
//! SSE-width slab test through glam's `Vec4` with no minimum-`t` epsilon and pbrt's `1 + 2γ(3)` widening of the far
//! distance. Leaves ask the shapes: plain triangles (`Shape::element_triangle`) are copied into the BVH in blocks of
//! four and tested four at a time with the watertight triangle test, every other primitive through its [`Shape`]'s
//! element queries (f64 sphere, disk and bilinear-patch tests), so this file never looks at shape kinds. Hits are
//! found down to `t → 0⁺` and rays spawned with [`crate::spawn_ray`] never re-hit their surface.
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

use glam::{DMat3, DMat4, Mat3, Vec2, Vec3, Vec3A, Vec4};
use obvhs::aabb::Aabb;
use rayon::prelude::*;

use crate::animated::{transform_bounds, AnimatedTransform};
use crate::bounds::Bounds3;
use crate::collapse::{WideBvh, BIG_BVH, EMPTY_SLOT};
use crate::huge_pages::LargeArray;

use crate::error::GeometryError;
use crate::mesh::TriangleMesh;
use crate::ray::{gamma, spawn_ray, spawn_ray_to, spawn_ray_to_point, Ray, SurfacePoint};
pub use crate::shapes::Shape;
use crate::shapes::{
    coordinate_system, d_normalize, intersect_tri4, ElementHit, ShapeRay, SurfaceDerivatives, SurfaceGeom, Tri4,
};
use crate::simd::{with_best_simd, Portable};
use crate::transform::Transform;
use crate::wide::{any_hit, closest_first, octant, prefetch_leaf_blocks, NodeRay, NodeTest, WideNode};

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
    /// ∂p/∂v (not normalized): with `dpdu` the surface's own partials with respect to its (u, v), which turn a
    /// change of the point into a change of (u, v) (pbrt-v4's `SurfaceInteraction::dpdv`, for texture footprints).
    pub dpdv: Vec3,
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
    /// Barycentric coordinates of a triangle hit: the weights of the triangle's vertices in index order, as its uv
    /// is interpolated (the patch coordinates (u, v, 0) of a bilinear patch; zero for other shapes). Per-vertex
    /// data a mesh carries beside the geometry (glTF's vertex colours) is interpolated with them.
    pub bary: [f32; 3],
}

impl Hit {
    /// Unit tangent perpendicular to `ns` (∂p/∂u made orthogonal to `ns`), for shading frames. Computed on
    /// demand: the renderer's frames project and normalise ∂p/∂u themselves, and a square root and a division per
    /// hit in every record showed in the time of small glass scenes (BENCHMARKS.md, "Why the traversal is as it
    /// is").
    pub fn tangent(&self) -> Vec3 {
        (self.dpdu - self.ns * self.ns.dot(self.dpdu)).try_normalize().unwrap_or_else(|| coordinate_system(self.ns).0)
    }

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
    /// `shape_guide[k]`: the shape holding primitive `min(64·k, last)`, so that [`Blas::locate`] searches only
    /// the shapes between two entries (most often none: a binary search over all shapes mispredicted its
    /// branches on every hit of scenes with many shapes).
    shape_guide: Vec<u32>,
    /// The BVH's nodes (see [`WideNode`]); the root is node 0. Leaves hold up to eight primitives, in one or two
    /// blocks.
    nodes: LargeArray<WideNode>,
    /// Levels of `nodes` (for [`GeometryScene::bvh_stats`]).
    depth: u32,
    /// The BVH's leaf slots in blocks of four (slot `i` is lane `i % 4` of block `i / 4`; a leaf's slots start a
    /// block): each slot's triangle inline (zeros for indirect and empty slots), so triangles are tested without a
    /// lookup and four at a time, and its flattened primitive index, `| INDIRECT` for primitives that are not plain
    /// triangles (and for empty slots). One record holds both, so that a leaf visit touches one stream of memory
    /// (the loads of a leaf's data are the traversal's main cache misses on big meshes).
    slots: LargeArray<Tri4>,
    bounds: Bounds3,
    /// A BVH of [`BIG_BVH`] primitives or more, whose nodes and leaves mostly miss the caches: its traversal also
    /// prefetches a leaf's second block.
    big: bool,
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
    /// Top-level BVH over the static instances; its slots hold instance indices.
    tlas: TopLevel,
    /// Moving instances; in a [`Hit`] they follow the static ones (`instance = instances.len() + k`).
    moving: Vec<MovingInstance>,
    /// Top-level BVH over the moving instances' motion bounds; its slots hold indices into `moving`.
    moving_tlas: TopLevel,
    bounds: Bounds3,
    build_time: Duration,
}

/// A top-level BVH: 8-wide nodes (as the objects' own, see the `wide` module) whose leaves hold one instance each.
struct TopLevel {
    nodes: Vec<WideNode>,
    /// The instance (an index into the list the BVH was built over) in each leaf slot.
    slot: Vec<u32>,
}

impl TopLevel {
    /// The BVH over boxes `aabbs` of the instances `ids` (one box per instance, in the same order).
    fn build(aabbs: &[Aabb], ids: &[u32]) -> Self {
        let bvh = WideBvh::build(aabbs, 1, 1, &[]);
        let slot = bvh.slots.iter().map(|&k| ids[k as usize]).collect();
        Self { nodes: bvh.nodes, slot }
    }

    /// The instances in the leaves among the children `mask` of `node`.
    #[inline(always)]
    fn instances<'a>(&'a self, node: &'a WideNode, mask: u32) -> impl Iterator<Item = u32> + 'a {
        node.leaves(mask)
            .flat_map(move |(first, count)| self.slot[first as usize..(first + count) as usize].iter().copied())
    }
}

/// The BVH box of a primitive: its bounds grown by a few ulps of their magnitude, so that no rounding in the
/// bounds computation can leave part of the primitive outside.
pub(crate) fn to_aabb(b: &Bounds3) -> Aabb {
    let grow = (b.min.abs().max(b.max.abs())) * (4.0 * f32::EPSILON) + Vec3::splat(f32::MIN_POSITIVE);
    Aabb::new(Vec3A::from(b.min - grow), Vec3A::from(b.max + grow))
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
        // Leaves of up to two blocks of four: on the 1M-triangle benchmark, 8 beat 4 on every query (BENCHMARKS.md,
        // "Why the traversal is as it is").
        // Primitives that are not triangles are tested one at a time, through their shapes.
        let alone: Vec<bool> =
            prims.par_iter().map(|&(s, e)| shapes[s as usize].element_triangle(e as usize).is_none()).collect();
        let bvh = WideBvh::build(&aabbs, 8, 4, &alone);
        let mut slots: Vec<Tri4> = Vec::with_capacity(bvh.slots.len().div_ceil(4));
        slots.par_extend(bvh.slots.par_chunks(4).map(|chunk| {
            let mut block = Tri4::empty(INDIRECT);
            for (lane, &i) in chunk.iter().enumerate() {
                if i == EMPTY_SLOT {
                    continue;
                }
                let (s, e) = prims[i as usize];
                match shapes[s as usize].element_triangle(e as usize) {
                    Some(tri) => {
                        block.set(lane, &tri);
                        block.prim[lane] = i;
                    }
                    None => block.prim[lane] = i | INDIRECT,
                }
            }
            block
        }));
        let (slots, nodes, depth) = (LargeArray::new(slots), LargeArray::new(bvh.nodes), bvh.depth);
        let shape_guide = shape_guide(&shape_starts);
        let big = prims.len() >= BIG_BVH;
        Ok(Self { shapes, shape_starts, shape_guide, nodes, depth, slots, bounds, big })
    }

    /// The (shape, element) of flattened primitive `prim` (which must be below the total).
    #[inline]
    fn locate(&self, prim: u32) -> (u32, u32) {
        if self.shapes.len() == 1 {
            return (0, prim); // an object of one shape (most are): no search
        }
        locate_in(&self.shape_starts, &self.shape_guide, prim)
    }
}

/// Primitives per entry of [`Blas::shape_guide`], as a power of two.
const SHAPE_GUIDE_SHIFT: u32 = 6;

/// [`Blas::shape_guide`] for the flattened shape starts `starts` (one entry per shape and the total at the end).
fn shape_guide(starts: &[u32]) -> Vec<u32> {
    let total = *starts.last().unwrap_or(&0);
    let last = total.saturating_sub(1);
    let blocks = (total >> SHAPE_GUIDE_SHIFT) + 1;
    (0..=blocks)
        .map(|k| {
            let prim = (k << SHAPE_GUIDE_SHIFT).min(last);
            (starts[..starts.len() - 1].partition_point(|&x| x <= prim).max(1) - 1) as u32
        })
        .collect()
}

/// The (shape, element) of primitive `prim` given the shape starts and their [`shape_guide`]: the last shape
/// starting at or before `prim` (empty shapes are skipped), searched only between the two guide entries around it.
#[inline]
fn locate_in(starts: &[u32], guide: &[u32], prim: u32) -> (u32, u32) {
    let k = (prim >> SHAPE_GUIDE_SHIFT) as usize;
    let (lo, hi) = (guide[k] as usize, guide[k + 1] as usize);
    let s = lo + starts[lo + 1..=hi].iter().filter(|&&x| x <= prim).count();
    (s as u32, prim - starts[s])
}

/// Closest hit so far.
#[derive(Clone, Copy)]
struct Closest {
    hit: ElementHit,
    instance: u32,
    prim: u32,
    /// The leaf slot (`4 · block + lane`) whose inline triangle was hit, or `NO_SLOT` for primitives intersected
    /// through their shape: [`GeometryScene::finish`] takes the vertices from there, already in cache.
    slot: u32,
}

/// [`Closest::slot`] of a hit that has no inline triangle.
const NO_SLOT: u32 = u32::MAX;

impl Closest {
    /// No hit yet: anything nearer than `t_max` is closer.
    fn none(t_max: f32) -> Self {
        Self { hit: ElementHit::at_coords(t_max, [0.0; 3]), instance: u32::MAX, prim: 0, slot: NO_SLOT }
    }
}

impl Blas {
    /// Closest hit in this object's space; updates `best` (and its `t`) when closer. Nearest first
    /// ([`closest_first`]).
    #[inline]
    fn closest(&self, o: Vec3, d: Vec3, instance: u32, best: &mut Closest) {
        with_best_simd!(test => {
            let (ray, node_ray) = (ShapeRay::new(o, d), NodeRay::new(o, d));
            let prefetch =
                |node: &WideNode, mask| prefetch_leaf_blocks(&self.slots, node, mask, LEAF_PREFETCH_LINES, self.big);
            closest_first(test, &self.nodes, &node_ray, best.hit.t, prefetch, |node, mask| {
                // Out of line (the loop calls it from three places) but compiled for the loop's instruction set, not
                // the baseline's: faster closest hits, fewer instructions (BENCHMARKS.md, "Why the traversal is as
                // it is").
                test.leaf_test(|| {
                    for (first, count) in node.leaves(mask) {
                        self.closest_in_leaf(&ray, first, count, instance, best);
                    }
                    best.hit.t
                })
            })
        })
    }

    /// Tests the leaf of the `count` primitives from slot `first` (a multiple of four) and updates `best`.
    #[inline(always)]
    fn closest_in_leaf(&self, ray: &ShapeRay, first: u32, count: u32, instance: u32, best: &mut Closest) {
        for (block, lanes) in leaf_blocks(first, count) {
            let b = &self.slots[block];
            let indirect = indirect_lanes(b);
            let tris = lanes & !indirect;
            if tris != 0 {
                let hits = intersect_tri4(&ray.tri, b, tris, best.hit.t);
                if let Some(lane) = hits.nearest() {
                    let (t, bary) = hits.hit(lane);
                    *best = Closest {
                        hit: ElementHit::at_coords(t, bary),
                        instance,
                        prim: b.prim[lane],
                        slot: (4 * block + lane) as u32,
                    };
                }
            }
            if lanes & indirect != 0 {
                self.closest_indirect(ray, b, lanes & indirect, instance, best);
            }
        }
    }

    /// [`Blas::closest_in_leaf`] for the lanes `lanes` of block `b` whose primitives are intersected through their
    /// shapes. Out of line, so that the triangles' loop does not carry this code's registers and setup (its f64
    /// copies of the ray were computed for every query).
    #[inline(never)]
    fn closest_indirect(&self, ray: &ShapeRay, b: &Tri4, lanes: u32, instance: u32, best: &mut Closest) {
        let mut rest = lanes;
        while rest != 0 {
            let lane = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            let prim = b.prim[lane] & !INDIRECT;
            let (s, e) = self.locate(prim);
            if let Some(hit) = self.shapes[s as usize].intersect_element(e as usize, ray, best.hit.t) {
                *best = Closest { hit, instance, prim, slot: NO_SLOT };
            }
        }
    }

    /// True if anything in this object is hit with `0 < t < t_max` ([`any_hit`]).
    #[inline]
    fn any(&self, o: Vec3, d: Vec3, t_max: f32) -> bool {
        with_best_simd!(test => {
            let (ray, node_ray) = (ShapeRay::new(o, d), NodeRay::new(o, d));
            let prefetch =
                |node: &WideNode, mask| prefetch_leaf_blocks(&self.slots, node, mask, LEAF_PREFETCH_LINES, self.big);
            any_hit(test, &self.nodes, &node_ray, octant(d), t_max, prefetch, |node, mask| {
                node.leaves(mask).any(|(first, count)| self.any_in_leaf(&ray, first, count, t_max))
            })
        })
    }

    /// True if any primitive of the leaf of `count` slots from `first` is hit with `0 < t < t_max`.
    #[inline(always)]
    fn any_in_leaf(&self, ray: &ShapeRay, first: u32, count: u32, t_max: f32) -> bool {
        for (block, lanes) in leaf_blocks(first, count) {
            let b = &self.slots[block];
            let indirect = indirect_lanes(b);
            let tris = lanes & !indirect;
            if tris != 0 && intersect_tri4(&ray.tri, b, tris, t_max).mask != 0 {
                return true;
            }
            if lanes & indirect != 0 && self.any_indirect(ray, b, lanes & indirect, t_max) {
                return true;
            }
        }
        false
    }

    /// [`Blas::any_in_leaf`] for the lanes `lanes` of block `b` whose primitives are intersected through their
    /// shapes; out of line as [`Blas::closest_indirect`].
    #[inline(never)]
    fn any_indirect(&self, ray: &ShapeRay, b: &Tri4, lanes: u32, t_max: f32) -> bool {
        let mut rest = lanes;
        while rest != 0 {
            let lane = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            let (s, e) = self.locate(b.prim[lane] & !INDIRECT);
            if self.shapes[s as usize].occludes_element(e as usize, ray, t_max) {
                return true;
            }
        }
        false
    }
}

/// Lines of a hit leaf's first block of four triangles asked for ahead of its test: a block is 160 bytes, three
/// lines (its alignment keeps it from straddling a fourth; see [`Tri4`]).
const LEAF_PREFETCH_LINES: usize = 3;

/// The lanes of a slot block whose primitives are intersected through their shapes.
#[inline(always)]
fn indirect_lanes(b: &Tri4) -> u32 {
    // The records' top bits (`INDIRECT`) as the sign bits of four floats, read in one instruction.
    Vec4::from_array(b.prim.map(f32::from_bits)).is_negative_bitmask()
}

/// The slot blocks of the leaf of `count` primitives (1 to 8) from slot `first` (a multiple of four), as (block
/// index, lane mask) pairs.
#[inline(always)]
fn leaf_blocks(first: u32, count: u32) -> impl Iterator<Item = (usize, u32)> {
    debug_assert!(first.is_multiple_of(4) && (1..=8).contains(&count));
    let block = (first >> 2) as usize;
    let lanes = [(1u32 << count.min(4)) - 1, (1u32 << count.saturating_sub(4)) - 1];
    (0..1 + usize::from(count > 4)).map(move |k| (block + k, lanes[k]))
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
            dpdv: self.linear * g.dpdv,
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
        let tlas = TopLevel::build(&aabbs, &live);
        let mut bounds = instances.iter().fold(Bounds3::EMPTY, |b, i| b.union(&i.bounds));
        // Moving instances: a top-level BVH of their own over the bounds of their whole motion.
        let moving_bounds: Vec<Bounds3> =
            moving.iter().map(|m| m.motion_bounds(&objects[m.object as usize].bounds)).collect();
        let live: Vec<u32> = (0..moving.len() as u32).filter(|&k| !moving_bounds[k as usize].is_empty()).collect();
        let aabbs: Vec<Aabb> = live.iter().map(|&k| to_aabb(&moving_bounds[k as usize])).collect();
        let moving_tlas = TopLevel::build(&aabbs, &live);
        bounds = moving_bounds.iter().fold(bounds, |b, m| b.union(m));
        Ok(Self { objects, instances, tlas, moving, moving_tlas, bounds, build_time: start.elapsed() })
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
        let s = &blas.shapes[shape as usize];
        let g = inst.geom_to_render(if c.slot == NO_SLOT {
            s.surface_geom(element as usize, &c.hit)
        } else {
            let block = &blas.slots[c.slot as usize / 4];
            s.surface_geom_of_triangle(element as usize, &c.hit, block.triangle(c.slot as usize % 4))
        });
        Hit {
            t: c.hit.t,
            p: g.p,
            p_error: g.p_error,
            n: g.n,
            ns: g.ns,
            uv: g.uv,
            dpdu: g.dpdu,
            dpdv: g.dpdv,
            shading_dpdu: g.shading_dpdu,
            shading_dpdv: g.shading_dpdv,
            instance: c.instance,
            object: inst.object,
            primitive: c.prim,
            shape,
            element,
            bary: c.hit.b,
        }
    }

    /// A finite origin and direction, a direction not zero, and `t_max > 0` (false for NaN). Tested three
    /// coordinates at a time: this runs before every query, where testing one coordinate at a time took measurably
    /// more instructions (BENCHMARKS.md, "Why the traversal is as it is").
    #[inline(always)]
    fn valid_ray(ray: &Ray, t_max: f32) -> bool {
        let (o, d) = (Vec3A::from(ray.o), Vec3A::from(ray.d));
        o.is_finite() && d.is_finite() && d != Vec3A::ZERO && t_max > 0.0
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
        if self.tlas.slot.len() == 1 {
            let i = self.tlas.slot[0];
            let inst = &self.instances[i as usize];
            let (o, d) = inst.to_instance(ray.o, ray.d);
            self.objects[inst.object as usize].closest(o, d, i, &mut best);
        } else {
            closest_first(
                Portable,
                &self.tlas.nodes,
                &NodeRay::new(ray.o, ray.d),
                best.hit.t,
                |_, _| {},
                |node, mask| {
                    for i in self.tlas.instances(node, mask) {
                        let inst = &self.instances[i as usize];
                        let (o, d) = inst.to_instance(ray.o, ray.d);
                        self.objects[inst.object as usize].closest(o, d, i, &mut best);
                    }
                    best.hit.t
                },
            );
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
        let n_static = self.instances.len() as u32;
        closest_first(
            Portable,
            &self.moving_tlas.nodes,
            &NodeRay::new(ray.o, ray.d),
            best.hit.t,
            |_, _| {},
            |node, mask| {
                for k in self.moving_tlas.instances(node, mask) {
                    let inst = self.moving_at(n_static + k, ray.time);
                    let (o, d) = inst.to_instance(ray.o, ray.d);
                    self.objects[inst.object as usize].closest(o, d, n_static + k, best);
                }
                best.hit.t
            },
        );
    }

    /// True if a moving instance, placed where it is at the ray's time, is hit with `0 < t < t_max`.
    #[cold]
    #[inline(never)]
    fn occluded_moving(&self, ray: &Ray, t_max: f32) -> bool {
        let n_static = self.instances.len() as u32;
        any_hit(
            Portable,
            &self.moving_tlas.nodes,
            &NodeRay::new(ray.o, ray.d),
            octant(ray.d),
            t_max,
            |_, _| {},
            |node, mask| {
                self.moving_tlas.instances(node, mask).any(|k| {
                    let inst = self.moving_at(n_static + k, ray.time);
                    let (o, d) = inst.to_instance(ray.o, ray.d);
                    self.objects[inst.object as usize].any(o, d, t_max)
                })
            },
        )
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
        if self.tlas.slot.len() == 1 {
            let inst = &self.instances[self.tlas.slot[0] as usize];
            let (o, d) = inst.to_instance(ray.o, ray.d);
            return self.objects[inst.object as usize].any(o, d, t_max);
        }
        any_hit(
            Portable,
            &self.tlas.nodes,
            &NodeRay::new(ray.o, ray.d),
            octant(ray.d),
            t_max,
            |_, _| {},
            |node, mask| {
                self.tlas.instances(node, mask).any(|i| {
                    let inst = &self.instances[i as usize];
                    let (o, d) = inst.to_instance(ray.o, ray.d);
                    self.objects[inst.object as usize].any(o, d, t_max)
                })
            },
        )
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
                        best =
                            Closest { hit, instance: i as u32, prim: blas.shape_starts[s] + e as u32, slot: NO_SLOT };
                    }
                }
            }
        }
        (best.instance != u32::MAX).then(|| self.finish(ray, &best))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn guided_shape_lookup_equals_the_binary_search() {
        // Shapes of 1 to 300 primitives, some empty, around and across the guide's 64-primitive blocks.
        let mut state = 12345u32;
        for case in 0..200 {
            let n_shapes = 1 + case % 40;
            let mut starts = vec![0u32];
            for _ in 0..n_shapes {
                state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                let size = match state >> 29 {
                    0 => 0,
                    1 | 2 => 1 + (state >> 8) % 3,
                    _ => (state >> 8) % 300,
                };
                starts.push(starts.last().unwrap() + size);
            }
            let total = *starts.last().unwrap();
            let guide = shape_guide(&starts);
            for prim in 0..total {
                let s = starts.partition_point(|&x| x <= prim) - 1;
                assert_eq!(locate_in(&starts, &guide, prim), (s as u32, prim - starts[s]), "case {case}, prim {prim}");
            }
        }
    }
}

/// The shape of a scene's object BVHs, summed over its objects: for benchmarks and their reports.
#[derive(Clone, Copy, Debug, Default)]
pub struct BvhStats {
    /// Inner nodes (8-wide).
    pub nodes: usize,
    /// Leaves.
    pub leaves: usize,
    /// Primitives in the leaves.
    pub primitives: usize,
    /// Blocks of four leaf slots (a leaf takes whole blocks).
    pub blocks: usize,
    /// Bytes of the nodes.
    pub node_bytes: usize,
    /// Bytes of the leaf blocks.
    pub leaf_bytes: usize,
    /// Levels of nodes of the deepest object BVH.
    pub depth: u32,
    /// Surface-area cost of the nodes in Embree's convention (as its `verbose=2` statistics print it): each
    /// node's surface area over its object's, summed (the roots count 1 each).
    pub sah_nodes: f64,
    /// The same for the leaves: each leaf's surface area over its object's, times its blocks, summed.
    pub sah_leaves: f64,
}

impl GeometryScene {
    /// Statistics of the objects' BVHs ([`BvhStats`]).
    pub fn bvh_stats(&self) -> BvhStats {
        let mut st = BvhStats::default();
        for b in &self.objects {
            let area = |b: &Bounds3| {
                let d = (b.max - b.min).max(Vec3::ZERO).as_dvec3();
                d.x * d.y + d.y * d.z + d.z * d.x
            };
            let root = area(&b.bounds);
            st.nodes += b.nodes.len();
            st.depth = st.depth.max(b.depth);
            st.blocks += b.slots.len();
            st.node_bytes += std::mem::size_of_val(&b.nodes[..]);
            st.leaf_bytes += std::mem::size_of_val(&b.slots[..]);
            if root <= 0.0 {
                continue;
            }
            st.sah_nodes += b.nodes.len().min(1) as f64;
            for n in b.nodes.iter() {
                for c in 0..8 {
                    let Some(cb) = n.child_box(c) else { continue };
                    let a = area(&cb) / root;
                    if n.inner & (1 << c) != 0 {
                        st.sah_nodes += a;
                    } else if let Some((_, count)) = n.leaves(1 << c).next() {
                        st.leaves += 1;
                        st.primitives += count as usize;
                        st.sah_leaves += a * count.div_ceil(4) as f64;
                    }
                }
            }
        }
        st
    }
}

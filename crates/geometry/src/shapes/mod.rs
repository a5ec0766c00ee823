//! Shapes: triangles of meshes, analytic spheres (full or partial) and disks, and bilinear patches; their
//! intersection, surface geometry, error bounds and sampling (pbrt-v4 book ch. 6).
//!
//! Each kind of shape answers the same queries through the crate-internal `ShapeKind` trait, one file per kind
//! (`shapes/triangle.rs`, `shapes/sphere.rs`, `shapes/disk.rs`, and `bilinear.rs` for bilinear patches); [`Shape`]
//! holds one of them and dispatches, so the acceleration structures never look at what kind a shape is. A new shape
//! is its own file implementing `ShapeKind`, plus a variant of [`Shape`] and its arm in `dispatch!` in this file.
//!
//! Spheres and disks are intersected in object space in f64 (so the `t > 0` decision for a ray leaving the surface
//! is exact enough), triangles in render space with the watertight algorithm of Woop, Benthin and Wald (2013) and
//! pbrt-v4's conservative `t > 0` test.

use std::f32::consts::PI;
use std::sync::Arc;

use glam::{DVec3, Vec2, Vec3};

use crate::bilinear::BilinearMesh;
use crate::bounds::Bounds3;
use crate::mesh::TriangleMesh;
use crate::ray::Ray;

mod disk;
mod placement;
mod sphere;
mod triangle;

pub use disk::Disk;
pub use sphere::Sphere;
pub use triangle::sample_triangle_area;
pub(crate) use triangle::{intersect_tri4, Tri4, TriRay};

/// A point sampled on a shape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShapeSample {
    /// The point (render space).
    pub p: Vec3,
    /// Conservative absolute error bound of `p` (for [`crate::spawn_ray_to`]).
    pub p_error: Vec3,
    /// Unit geometric normal at `p`, oriented as at a ray hit (the side an area light emits to).
    pub n: Vec3,
    /// Surface (u, v) at `p`.
    pub uv: Vec2,
    /// Density: per unit area from `sample_area`, per steradian from `sample_solid_angle`.
    pub pdf: f32,
}

/// A point sampled on a shape by solid angle, with only what an area light without an alpha texture needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointSample {
    /// The point (render space).
    pub p: Vec3,
    /// Unit geometric normal at `p`, oriented as at a ray hit.
    pub n: Vec3,
    /// Density per steradian.
    pub pdf: f32,
}

impl From<ShapeSample> for PointSample {
    fn from(s: ShapeSample) -> Self {
        Self { p: s.p, n: s.n, pdf: s.pdf }
    }
}

/// Geometry of a surface point, in the space of the shape (render space, or instance space before the instance
/// transform).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct SurfaceGeom {
    pub p: Vec3,
    pub p_error: Vec3,
    pub n: Vec3,
    pub ns: Vec3,
    pub uv: Vec2,
    pub dpdu: Vec3,
    /// ∂p/∂v of the texture (u, v) (`dpdu` is its ∂p/∂u).
    pub dpdv: Vec3,
    /// pbrt-v4's shading ∂p/∂u and ∂p/∂v: the surface's own partials, or where vertex normals tilt the shading
    /// normal, partials turned to it as pbrt-v4's shape does (bump and normal maps start from these).
    pub shading_dpdu: Vec3,
    pub shading_dpdv: Vec3,
}

/// First derivatives of a surface at a point with respect to a local parametrization (u, v): of the point and of
/// the unit shading normal. What specular-chain solvers (manifold next-event estimation) need to move a vertex
/// along its surface; computed only when asked ([`crate::GeometryScene::intersect_with_derivatives`]), never on
/// the closest-hit path.
///
/// (u, v) is the shape's own parametrization where it has one: pbrt-v4's (φ/φmax, θ) for spheres, the texture
/// (u, v) for triangles (the barycentrics (b0, b1) when the texture coordinates are degenerate). Disks and
/// bilinear patches do not provide them yet.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceDerivatives {
    /// ∂p/∂u.
    pub dpdu: Vec3,
    /// ∂p/∂v.
    pub dpdv: Vec3,
    /// ∂ns/∂u of the unit shading normal (interpolated vertex normals of meshes; the geometric normal otherwise).
    pub dndu: Vec3,
    /// ∂ns/∂v.
    pub dndv: Vec3,
}

/// Derivative of `x / |x|` along `dx`: (I − x̂x̂ᵀ)·dx / |x| (how a normalized normal moves).
pub(crate) fn d_normalize(x: Vec3, dx: Vec3) -> Vec3 {
    let len = x.length();
    if len == 0.0 {
        return Vec3::ZERO;
    }
    let xh = x / len;
    (dx - xh * xh.dot(dx)) / len
}

/// Two unit vectors completing `n` (unit) to an orthonormal basis (Duff et al. 2017).
pub fn coordinate_system(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x), Vec3::new(b, sign + n.y * n.y * a, -n.y))
}

fn safe_sqrt(x: f32) -> f32 {
    x.max(0.0).sqrt()
}

/// Uniform barycentrics on a triangle (pbrt-v4's `SampleUniformTriangle`, area-preserving).
pub fn sample_uniform_triangle(u: Vec2) -> [f32; 3] {
    let (b0, b1) = if u.x < u.y {
        let b0 = u.x / 2.0;
        (b0, u.y - b0)
    } else {
        let b1 = u.y / 2.0;
        (u.x - b1, b1)
    };
    [b0, b1, 1.0 - b0 - b1]
}

/// Uniform direction on the unit sphere.
pub fn sample_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = safe_sqrt(1.0 - z * z);
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}
/// Where a ray hit one element of a shape: the ray parameter and the coordinates the shape needs to rebuild the
/// surface geometry there ([`ShapeKind::surface_geom`]); each kind uses the fields it needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ElementHit {
    /// Ray parameter (in units of `|ray.d|`).
    pub t: f32,
    /// Barycentrics of a triangle hit; `(u, v, 0)` patch parameters of a bilinear-patch hit.
    pub b: [f32; 3],
    /// Object-space point of a sphere or disk hit.
    pub p_obj: DVec3,
}

impl ElementHit {
    /// A hit at `t` with barycentric or patch coordinates `b`.
    #[inline]
    pub fn at_coords(t: f32, b: [f32; 3]) -> Self {
        Self { t, b, p_obj: DVec3::ZERO }
    }

    /// A hit at `t` at object-space point `p_obj`.
    #[inline]
    pub fn at_point(t: f32, p_obj: DVec3) -> Self {
        Self { t, b: [0.0; 3], p_obj }
    }
}

/// A ray prepared once for the element tests of a traversal: the ray and the watertight triangle test's
/// per-ray permutation and shear.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ShapeRay {
    /// The ray.
    pub ray: Ray,
    /// Its triangle-test form.
    pub tri: TriRay,
}

impl ShapeRay {
    /// Prepares the ray `o + t·d`.
    #[inline]
    pub fn new(o: Vec3, d: Vec3) -> Self {
        Self { ray: Ray::new(o, d), tri: TriRay::new(o, d) }
    }
}

/// The queries every kind of shape answers, in the space its geometry is stored in (render space, or instance space
/// for instanced objects). A shape is a list of elements (primitives): the triangles or patches of a mesh, or the
/// single surface of a sphere or disk. [`Shape`] dispatches to these; the acceleration structures only call
/// [`Shape`]'s methods.
pub(crate) trait ShapeKind {
    /// Number of elements.
    fn primitive_count(&self) -> usize {
        1
    }

    /// Bounds of the whole shape.
    fn bounds(&self) -> Bounds3;

    /// Bounds of element `e`.
    fn element_bounds(&self, e: usize) -> Bounds3 {
        let _ = e;
        self.bounds()
    }

    /// Area of element `e`.
    fn area(&self, e: usize) -> f32;

    /// The vertices of element `e` if it is a plain triangle. The BVH stores these inline and intersects them with
    /// [`triangle::intersect_inline_triangle`], which must give the same hit as [`ShapeKind::intersect_element`].
    fn element_triangle(&self, e: usize) -> Option<[Vec3; 3]> {
        let _ = e;
        None
    }

    /// Nearest hit of element `e` with `0 < t < t_max`.
    fn intersect_element(&self, e: usize, ray: &ShapeRay, t_max: f32) -> Option<ElementHit>;

    /// True if element `e` is hit with `0 < t < t_max` (a shape with a cheaper any-hit test overrides this).
    fn occludes_element(&self, e: usize, ray: &ShapeRay, t_max: f32) -> bool {
        self.intersect_element(e, ray, t_max).is_some()
    }

    /// Surface geometry of element `e` at a hit it returned.
    fn surface_geom(&self, e: usize, hit: &ElementHit) -> SurfaceGeom;

    /// [`ShapeKind::surface_geom`] of an element whose [`ShapeKind::element_triangle`] is `positions` (the BVH's
    /// inline copy), for shapes that can use them instead of reading their own.
    fn surface_geom_of_triangle(&self, e: usize, hit: &ElementHit, positions: [Vec3; 3]) -> SurfaceGeom {
        let _ = positions;
        self.surface_geom(e, hit)
    }

    /// First derivatives of the surface of element `e` at a hit it returned (in the same space as
    /// [`ShapeKind::surface_geom`]); `None` for shapes that do not provide them.
    fn derivatives(&self, e: usize, hit: &ElementHit) -> Option<SurfaceDerivatives> {
        let _ = (e, hit);
        None
    }

    /// A point on element `e` with its density per unit area; `None` at a degenerate point.
    fn sample_area(&self, e: usize, u: Vec2) -> Option<ShapeSample>;

    /// The density per unit area of [`ShapeKind::sample_area`] at a hit of element `e` (uniform unless overridden).
    fn pdf_area(&self, e: usize, hit: &ElementHit) -> f32 {
        let _ = hit;
        1.0 / self.area(e)
    }

    /// A point on element `e` sampled by solid angle from `ref_p`: area sampling converted to solid angle
    /// (pdf·dist²/|cos θ|) unless the shape does better.
    fn sample_solid_angle(&self, e: usize, ref_p: Vec3, u: Vec2) -> Option<ShapeSample> {
        area_to_solid_angle(ref_p, self.sample_area(e, u)?)
    }

    /// [`ShapeKind::sample_solid_angle`]'s point, normal and density alone (bit for bit the same), for callers that
    /// need neither `uv` nor `p_error`; shapes whose full sample costs more (a sphere's uv takes two inverse
    /// trigonometric functions) skip the rest.
    fn sample_solid_angle_point(&self, e: usize, ref_p: Vec3, u: Vec2) -> Option<PointSample> {
        self.sample_solid_angle(e, ref_p, u).map(PointSample::from)
    }

    /// The density per steradian of [`ShapeKind::sample_solid_angle`] for direction `wi` (unit) from `ref_p`; 0 if
    /// the ray misses element `e`.
    fn pdf_solid_angle(&self, e: usize, ref_p: Vec3, wi: Vec3) -> f32 {
        match self.intersect_element(e, &ShapeRay::new(ref_p, wi), f32::INFINITY) {
            Some(hit) => area_pdf_to_solid_angle(ref_p, &self.surface_geom(e, &hit), self.pdf_area(e, &hit)),
            None => 0.0,
        }
    }
}

/// Converts an area sample to a solid-angle one as seen from `ref_p`: pdf·dist²/|cos θ|.
fn area_to_solid_angle(ref_p: Vec3, mut ss: ShapeSample) -> Option<ShapeSample> {
    let wi = ss.p - ref_p;
    let d2 = wi.length_squared();
    if d2 == 0.0 {
        return None;
    }
    let cos = ss.n.dot(-wi / d2.sqrt()).abs();
    ss.pdf *= d2 / cos;
    (ss.pdf.is_finite() && ss.pdf > 0.0).then_some(ss)
}

fn area_pdf_to_solid_angle(ref_p: Vec3, g: &SurfaceGeom, pdf_area: f32) -> f32 {
    let wi = g.p - ref_p;
    let d2 = wi.length_squared();
    if d2 == 0.0 {
        return 0.0;
    }
    let cos = g.n.dot(-wi / d2.sqrt()).abs();
    let pdf = pdf_area * d2 / cos;
    if pdf.is_finite() {
        pdf
    } else {
        0.0
    }
}

// ---------------------------------------------------------------------------------------------------------------
// Shape: what an object is made of

/// A shape, the unit a scene is built from. A mesh holds many primitives (its triangles or patches); spheres and
/// disks one.
#[derive(Clone, Debug)]
pub enum Shape {
    /// A triangle mesh; primitive `k` of the shape is triangle `k`.
    Mesh(Arc<TriangleMesh>),
    /// A bilinear patch mesh; primitive `k` of the shape is patch `k`.
    Bilinear(Arc<BilinearMesh>),
    /// A sphere.
    Sphere(Sphere),
    /// A disk.
    Disk(Disk),
}

/// Calls a [`ShapeKind`] method on whatever kind `$shape` holds: the one place in this crate that lists the kinds
/// (the render crate matches on `Shape` in `builder/shapes.rs` and `integrator/manifold.rs` too).
macro_rules! dispatch {
    ($shape:expr, $kind:ident => $call:expr) => {
        match $shape {
            Shape::Mesh(m) => {
                let $kind: &TriangleMesh = m;
                $call
            }
            Shape::Bilinear(m) => {
                let $kind: &BilinearMesh = m;
                $call
            }
            Shape::Sphere($kind) => $call,
            Shape::Disk($kind) => $call,
        }
    };
}

impl Shape {
    /// Number of primitives (triangles or patches for a mesh, 1 otherwise).
    pub fn primitive_count(&self) -> usize {
        dispatch!(self, k => ShapeKind::primitive_count(k))
    }

    /// Bounds of the whole shape.
    pub fn bounds(&self) -> Bounds3 {
        dispatch!(self, k => ShapeKind::bounds(k))
    }

    /// Bounds of primitive `element`.
    pub fn element_bounds(&self, element: usize) -> Bounds3 {
        dispatch!(self, k => ShapeKind::element_bounds(k, element))
    }

    /// Area of primitive `element` (a triangle, a patch, or the whole sphere or disk).
    pub fn area(&self, element: usize) -> f32 {
        dispatch!(self, k => ShapeKind::area(k, element))
    }

    /// A point on primitive `element` with its pdf per unit area: uniform (1/area) except on a non-planar
    /// bilinear patch (see [`BilinearMesh::sample_area`]). `None` for a degenerate triangle or patch point.
    pub fn sample_area(&self, element: usize, u: Vec2) -> Option<ShapeSample> {
        dispatch!(self, k => ShapeKind::sample_area(k, element, u))
    }

    /// A point on primitive `element` sampled with a density per steradian as seen from `ref_p`: cone sampling
    /// for full spheres seen from outside, area sampling converted to solid angle (pdf·dist²/|cos θ|) otherwise.
    pub fn sample_solid_angle(&self, element: usize, ref_p: Vec3, u: Vec2) -> Option<ShapeSample> {
        dispatch!(self, k => ShapeKind::sample_solid_angle(k, element, ref_p, u))
    }

    /// [`Shape::sample_solid_angle`]'s point, normal and density alone, bit for bit the same, computed without the
    /// sample's `uv` and `p_error` where that is cheaper (spheres).
    pub fn sample_solid_angle_point(&self, element: usize, ref_p: Vec3, u: Vec2) -> Option<PointSample> {
        dispatch!(self, k => ShapeKind::sample_solid_angle_point(k, element, ref_p, u))
    }

    /// The density per steradian with which [`Shape::sample_solid_angle`] picks direction `wi` (unit) from
    /// `ref_p`; 0 if the ray misses the primitive.
    pub fn pdf_solid_angle(&self, element: usize, ref_p: Vec3, wi: Vec3) -> f32 {
        dispatch!(self, k => ShapeKind::pdf_solid_angle(k, element, ref_p, wi))
    }

    /// Intersects primitive `element` alone: nearest `t` in `(0, t_max)`.
    pub fn intersect_t(&self, element: usize, ray: &Ray, t_max: f32) -> Option<f32> {
        self.intersect_element(element, &ShapeRay::new(ray.o, ray.d), t_max).map(|h| h.t)
    }

    /// The vertices of primitive `element` if it is a plain triangle (see [`ShapeKind::element_triangle`]).
    #[inline]
    pub(crate) fn element_triangle(&self, element: usize) -> Option<[Vec3; 3]> {
        dispatch!(self, k => ShapeKind::element_triangle(k, element))
    }

    /// Nearest hit of primitive `element` with `0 < t < t_max`.
    #[inline]
    pub(crate) fn intersect_element(&self, element: usize, ray: &ShapeRay, t_max: f32) -> Option<ElementHit> {
        dispatch!(self, k => ShapeKind::intersect_element(k, element, ray, t_max))
    }

    /// True if primitive `element` is hit with `0 < t < t_max`.
    #[inline]
    pub(crate) fn occludes_element(&self, element: usize, ray: &ShapeRay, t_max: f32) -> bool {
        dispatch!(self, k => ShapeKind::occludes_element(k, element, ray, t_max))
    }

    /// Surface geometry of primitive `element` at a hit [`Shape::intersect_element`] returned.
    pub(crate) fn surface_geom(&self, element: usize, hit: &ElementHit) -> SurfaceGeom {
        dispatch!(self, k => ShapeKind::surface_geom(k, element, hit))
    }

    /// [`Shape::surface_geom`] of a primitive whose [`Shape::element_triangle`] is `positions`.
    #[inline]
    pub(crate) fn surface_geom_of_triangle(
        &self,
        element: usize,
        hit: &ElementHit,
        positions: [Vec3; 3],
    ) -> SurfaceGeom {
        dispatch!(self, k => ShapeKind::surface_geom_of_triangle(k, element, hit, positions))
    }

    /// Surface derivatives of primitive `element` at a hit [`Shape::intersect_element`] returned.
    pub(crate) fn derivatives(&self, element: usize, hit: &ElementHit) -> Option<SurfaceDerivatives> {
        dispatch!(self, k => ShapeKind::derivatives(k, element, hit))
    }
}

#[cfg(test)]
mod tests {
    use super::placement::phi_of;
    use super::triangle::triangle_geom;
    use super::*;
    use crate::mesh::MeshData;
    use crate::transform::Transform;

    fn tri_mesh() -> TriangleMesh {
        let data = MeshData {
            positions: vec![Vec3::new(0.0, 0.0, 1.0), Vec3::new(2.0, 0.0, 1.0), Vec3::new(0.0, 2.0, 1.0)],
            indices: vec![0, 1, 2],
            ..Default::default()
        };
        TriangleMesh::new(&Transform::IDENTITY, data, false).unwrap()
    }

    #[test]
    fn triangle_hit_at_closed_form_t() {
        let m = tri_mesh();
        let shape = Shape::Mesh(Arc::new(m));
        let ray = Ray::new(Vec3::new(0.5, 0.25, 5.0), Vec3::new(0.0, 0.0, -2.0));
        assert_eq!(shape.intersect_t(0, &ray, f32::INFINITY), Some(2.0));
        assert_eq!(shape.intersect_t(0, &ray, 1.9), None);
        let miss = Ray::new(Vec3::new(1.5, 1.5, 5.0), Vec3::new(0.0, 0.0, -1.0));
        assert_eq!(shape.intersect_t(0, &miss, f32::INFINITY), None);
        // Oblique: plane z = 1 from (0.2, 0.2, 0) along (0.1, 0.2, 0.5): t = 2.
        let ray = Ray::new(Vec3::new(0.2, 0.2, 0.0), Vec3::new(0.1, 0.2, 0.5));
        let t = shape.intersect_t(0, &ray, f32::INFINITY).unwrap();
        assert!((t - 2.0).abs() < 1e-6, "{t}");
    }

    #[test]
    fn triangle_normal_follows_pbrt() {
        let m = tri_mesh();
        // cross(p0 − p2, p1 − p2) = cross((0,−2,0), (2,−2,0)) = (0, 0, 4): +z.
        let g = triangle_geom(&m, 0, [1.0 / 3.0; 3]);
        assert!((g.n - Vec3::Z).length() < 1e-6);
        assert!((g.p - Vec3::new(2.0 / 3.0, 2.0 / 3.0, 1.0)).length() < 1e-6);
        let data = MeshData { normals: Some(vec![-Vec3::Z; 3]), ..Default::default() };
        let data = MeshData { positions: m.positions().to_vec(), indices: m.indices().to_vec(), ..data };
        let m2 = TriangleMesh::new(&Transform::IDENTITY, data, false).unwrap();
        let g = triangle_geom(&m2, 0, [1.0 / 3.0; 3]);
        assert!((g.n + Vec3::Z).length() < 1e-6 && (g.ns + Vec3::Z).length() < 1e-6);
    }

    #[test]
    fn sphere_hits_at_closed_form_t() {
        let t = Transform::translate(DVec3::new(1.0, 2.0, 3.0)) * Transform::scale(DVec3::splat(2.0)).unwrap();
        let s = Sphere::new(1.5, t, false).unwrap();
        assert!((s.render_radius() - 3.0).abs() < 1e-6);
        let ray = Ray::new(Vec3::new(1.0, 2.0, -10.0), Vec3::Z);
        let (th, p) = s.intersect_t(&ray, f32::INFINITY).unwrap();
        assert!((th - 10.0).abs() < 1e-5, "{th}");
        let g = s.geom(p);
        assert!((g.n + Vec3::Z).length() < 1e-6 && (g.p - Vec3::new(1.0, 2.0, 0.0)).length() < 1e-5);
        // From inside: the far side.
        let ray = Ray::new(Vec3::new(1.0, 2.0, 3.0), Vec3::X);
        assert!((s.intersect_t(&ray, f32::INFINITY).unwrap().0 - 3.0).abs() < 1e-6);
        // Off-centre: x offset 2 from the centre of a radius-3 sphere: t = 10 + 3 − √5.
        let ray = Ray::new(Vec3::new(3.0, 2.0, -10.0), Vec3::Z);
        let expect = 13.0 - 5f32.sqrt();
        assert!((s.intersect_t(&ray, f32::INFINITY).unwrap().0 - expect).abs() < 1e-5);
        assert!(s.intersect_t(&Ray::new(Vec3::new(4.1, 2.0, -10.0), Vec3::Z), f32::INFINITY).is_none());
        let rev = Sphere::new(1.5, t, true).unwrap();
        assert!((rev.geom(p).n - Vec3::Z).length() < 1e-6);
        assert!(Sphere::new(-1.0, Transform::IDENTITY, false).is_err());
    }

    #[test]
    fn disk_hits_at_closed_form_t() {
        let d = Disk::new(1.0, 2.0, 0.5, 360.0, Transform::IDENTITY, false).unwrap();
        let ray = Ray::new(Vec3::new(1.0, 0.0, 4.0), Vec3::new(0.0, 0.0, -0.5));
        let (t, p) = d.intersect_t(&ray, f32::INFINITY).unwrap();
        assert!((t - 6.0).abs() < 1e-6);
        let g = d.geom(p);
        assert!((g.n - Vec3::Z).length() < 1e-6);
        assert!((g.uv - Vec2::new(0.0, 1.0 / 1.5)).length() < 1e-6, "{:?}", g.uv);
        assert!(d.intersect_t(&Ray::new(Vec3::new(0.2, 0.0, 4.0), -Vec3::Z), f32::INFINITY).is_none());
        assert!(d.intersect_t(&Ray::new(Vec3::new(2.1, 0.0, 4.0), -Vec3::Z), f32::INFINITY).is_none());
        let half = Disk::new(1.0, 2.0, 0.0, 180.0, Transform::IDENTITY, false).unwrap();
        assert!(half.intersect_t(&Ray::new(Vec3::new(0.0, -1.0, 4.0), -Vec3::Z), f32::INFINITY).is_none());
        assert!(half.intersect_t(&Ray::new(Vec3::new(0.0, 1.0, 4.0), -Vec3::Z), f32::INFINITY).is_some());
        assert!((d.area() - PI * (4.0 - 0.25)).abs() < 1e-5);
        assert!(Disk::new(0.0, 1.0, 2.0, 360.0, Transform::IDENTITY, false).is_err());
    }

    #[test]
    fn shading_partials_are_the_derivatives_of_the_parametrisation() {
        // Sphere of radius 2 scaled by 1.5, clipped to z in [−1, 1.5] (object space), φmax 270°: p(u, v) with
        // φ = u·φmax and θ = θ(zmin) + v·(θ(zmax) − θ(zmin)); central differences of p match ∂p/∂u and ∂p/∂v.
        let t = Transform::scale(DVec3::splat(1.5)).unwrap();
        let s = Sphere::partial(2.0, -1.0, 1.5, 270.0, t, false).unwrap();
        let (tmin, tmax, phimax) = ((-0.5f64).acos(), 0.75f64.acos(), 1.5 * std::f64::consts::PI);
        let p_of = |u: f64, v: f64| {
            let (phi, th) = (u * phimax, tmin + v * (tmax - tmin));
            3.0 * DVec3::new(th.sin() * phi.cos(), th.sin() * phi.sin(), th.cos())
        };
        let h = 1e-5;
        for (u, v) in [(0.3, 0.4), (0.8, 0.1), (0.55, 0.9)] {
            let g = s.geom(p_of(u, v) / 1.5);
            assert!((g.uv - Vec2::new(u as f32, v as f32)).length() < 1e-5, "{:?}", g.uv);
            let du = ((p_of(u + h, v) - p_of(u - h, v)) / (2.0 * h)).as_vec3();
            let dv = ((p_of(u, v + h) - p_of(u, v - h)) / (2.0 * h)).as_vec3();
            assert!((g.shading_dpdu - du).length() < 1e-4 * du.length(), "{:?} {du:?}", g.shading_dpdu);
            assert!((g.shading_dpdv - dv).length() < 1e-4 * dv.length(), "{:?} {dv:?}", g.shading_dpdv);
        }
        // Disk of radius 2, inner radius 0.5: v = (r − ρ)/(r − ri), so ∂p/∂v = −1.5·(x, y)/ρ.
        let d = Disk::new(0.0, 2.0, 0.5, 360.0, Transform::IDENTITY, false).unwrap();
        let g = d.geom(DVec3::new(0.6, 0.8, 0.0));
        assert!((g.shading_dpdv - Vec3::new(-0.9, -1.2, 0.0)).length() < 1e-6, "{:?}", g.shading_dpdv);
        assert!((g.shading_dpdu - 2.0 * std::f32::consts::PI * Vec3::new(-0.8, 0.6, 0.0)).length() < 1e-5);
        // Triangle without normals, default uvs (0,0), (1,0), (1,1): ∂p/∂u = p1 − p0, ∂p/∂v = p2 − p1.
        let m = tri_mesh();
        let g = triangle_geom(&m, 0, [0.2, 0.3, 0.5]);
        let [p0, p1, p2] = m.triangle_positions(0);
        let [t0, t1, t2] = m.triangle_uvs(0);
        assert_eq!((t0, t1, t2), (Vec2::ZERO, Vec2::X, Vec2::ONE));
        assert!((g.shading_dpdu - (p1 - p0)).length() < 1e-6 && (g.shading_dpdv - (p2 - p1)).length() < 1e-6);
        // With vertex normals (pbrt-v4's Triangle): ns × ∂p/∂u, and ∂p/∂u made perpendicular to ns.
        let tilted = Vec3::new(0.3, 0.0, 1.0).normalize();
        let data = MeshData {
            positions: m.positions().to_vec(),
            indices: m.indices().to_vec(),
            normals: Some(vec![tilted; 3]),
            ..Default::default()
        };
        let m2 = TriangleMesh::new(&Transform::IDENTITY, data, false).unwrap();
        let g = triangle_geom(&m2, 0, [0.2, 0.3, 0.5]);
        let dpdu = p1 - p0;
        assert!((g.shading_dpdv - tilted.cross(dpdu)).length() < 1e-6);
        assert!((g.shading_dpdu - (dpdu - tilted * tilted.dot(dpdu))).length() < 1e-6);
        assert!(g.shading_dpdu.cross(g.shading_dpdv).normalize().dot(tilted) > 1.0 - 1e-6);
    }

    /// A simple deterministic low-discrepancy point set for Monte Carlo checks.
    fn points(n: usize) -> impl Iterator<Item = Vec2> {
        (0..n).map(move |i| {
            let a = (i as f64 + 0.5) / n as f64;
            let b = (i as f64 * 0.618_033_988_749_894_9).fract();
            Vec2::new(a as f32, b as f32)
        })
    }

    #[test]
    fn area_pdfs_integrate_to_one_and_match_area() {
        let sphere = Shape::Sphere(Sphere::new(0.7, Transform::translate(DVec3::X), false).unwrap());
        let disk = Shape::Disk(Disk::new(0.0, 1.0, 0.3, 270.0, Transform::IDENTITY, false).unwrap());
        let tri = Shape::Mesh(Arc::new(tri_mesh()));
        for (shape, area) in [(sphere, 4.0 * PI * 0.49), (disk, 0.75 * PI * (1.0 - 0.09)), (tri, 2.0)] {
            assert!((shape.area(0) - area).abs() < 1e-4 * area);
            let n = 4096;
            let sum: f64 = points(n).map(|u| 1.0 / shape.sample_area(0, u).unwrap().pdf as f64).sum();
            // E[1/pdf] = area; with a constant pdf the estimate is exact.
            assert!((sum / n as f64 - area as f64).abs() < 1e-3 * area as f64);
        }
    }

    #[test]
    fn disk_and_triangle_samples_are_uniform() {
        // Fraction of disk samples inside radius 0.5 of a unit disk = 0.25.
        let d = Disk::new(0.0, 1.0, 0.0, 360.0, Transform::IDENTITY, false).unwrap();
        let n = 10_000;
        let inside = points(n).filter(|&u| d.sample_area(u).p.truncate().length() < 0.5).count();
        assert!((inside as f64 / n as f64 - 0.25).abs() < 0.01);
        // Mean of triangle samples = centroid.
        let m = tri_mesh();
        let mean: Vec3 = points(n).map(|u| sample_triangle_area(&m, 0, u).unwrap().p).sum::<Vec3>() / n as f32;
        assert!((mean - Vec3::new(2.0 / 3.0, 2.0 / 3.0, 1.0)).length() < 5e-3, "{mean}");
    }

    #[test]
    fn point_samples_equal_full_samples_bit_for_bit() {
        let placed = Transform::translate(DVec3::new(0.3, -0.2, 4.0))
            * Transform::rotate(30.0, DVec3::new(1.0, 1.0, 0.0)).unwrap()
            * Transform::scale(DVec3::new(1.5, 1.5, 1.5)).unwrap();
        let shapes = [
            Shape::Sphere(Sphere::new(0.7, placed, false).unwrap()),
            Shape::Sphere(Sphere::new(0.7, placed, true).unwrap()),
            Shape::Sphere(Sphere::partial(1.0, -0.5, 0.8, 300.0, placed, false).unwrap()),
            Shape::Disk(Disk::new(0.0, 1.0, 0.3, 270.0, placed, false).unwrap()),
            Shape::Mesh(Arc::new(tri_mesh())),
        ];
        // From outside (cone sampling for the full spheres) and from inside the spheres (area sampling).
        for (k, shape) in shapes.iter().enumerate() {
            for ref_p in [Vec3::new(0.1, 0.2, -3.0), Vec3::new(0.3, -0.2, 4.1)] {
                for u in points(256) {
                    let full = shape.sample_solid_angle(0, ref_p, u).map(PointSample::from);
                    assert_eq!(shape.sample_solid_angle_point(0, ref_p, u), full, "shape {k} from {ref_p} at {u}");
                }
            }
        }
    }

    #[test]
    fn sphere_cone_sampling() {
        let s = Sphere::new(1.0, Transform::translate(DVec3::new(0.0, 0.0, 5.0)), false).unwrap();
        let shape = Shape::Sphere(s.clone());
        let ref_p = Vec3::ZERO;
        let cos_max = (1.0f32 - 1.0 / 25.0).sqrt();
        let expect = 1.0 / (2.0 * PI * (1.0 - cos_max));
        for u in points(2000) {
            let ss = shape.sample_solid_angle(0, ref_p, u).unwrap();
            assert!((ss.pdf - expect).abs() < 1e-3 * expect);
            assert!(((ss.p - s.center()).length() - 1.0).abs() < 1e-5);
            // The sampled point faces the reference point and a ray towards it hits the sphere there.
            let wi = (ss.p - ref_p).normalize();
            assert!(ss.n.dot(-wi) >= -1e-3);
            let t = shape.intersect_t(0, &Ray::new(ref_p, wi), f32::INFINITY).expect("sample direction hits");
            assert!((t - (ss.p - ref_p).length()).abs() < 2e-2, "{t}");
            assert!((shape.pdf_solid_angle(0, ref_p, wi) - expect).abs() < 1e-3 * expect);
        }
        // Tiny, distant sphere: Taylor branch keeps the pdf right.
        let far = Sphere::new(1e-3, Transform::translate(DVec3::new(0.0, 0.0, 100.0)), false).unwrap();
        let ss = far.sample_solid_angle(Vec3::ZERO, Vec2::new(0.3, 0.6)).unwrap();
        let omega = PI * 1e-10; // ≈ π (r/d)²
        assert!((ss.pdf * omega - 1.0).abs() < 1e-3, "{}", ss.pdf * omega);
        // From inside: area sampling converted to solid angle; its pdf integrates to 1 over the sphere of
        // directions (E[1/pdf] = 4π).
        let n = 20_000;
        let c = Vec3::new(0.0, 0.3, 5.0);
        let mean: f64 =
            points(n).map(|u| 1.0 / shape.sample_solid_angle(0, c, u).unwrap().pdf as f64).sum::<f64>() / n as f64;
        assert!((mean - 4.0 * std::f64::consts::PI).abs() < 0.05, "{mean}");
    }

    #[test]
    fn partial_sphere_clips_hits_against_closed_form() {
        // r = 2, zmin = −1, zmax = 1.5, φmax = 250°.
        let s = Sphere::partial(2.0, -1.0, 1.5, 250.0, Transform::IDENTITY, false).unwrap();
        let hit = |o: Vec3, d: Vec3| s.intersect_t(&Ray::new(o, d), f32::INFINITY);
        // Down the z axis: the pole z = 2 is above zmax and z = −2 below zmin: a miss.
        assert!(hit(Vec3::new(0.0, 0.0, 10.0), -Vec3::Z).is_none());
        // At x = 1: z = ±√3 are both clipped (√3 > 1.5, −√3 < −1).
        assert!(hit(Vec3::new(1.0, 0.0, 10.0), -Vec3::Z).is_none());
        // At x = 1.8: z = ±√(4 − 3.24) = ±0.8718, the near root kept: t = 10 − 0.8718.
        let (t, p) = hit(Vec3::new(1.8, 0.0, 10.0), -Vec3::Z).unwrap();
        assert!((t as f64 - (10.0 - 0.76f64.sqrt())).abs() < 1e-5, "{t}");
        assert!((p.z - 0.76f64.sqrt()).abs() < 1e-6, "{p}");
        // Along +x at z = 0.5: near root x = −√3.75 has φ = 180° ≤ 250°: kept, t = 10 − √3.75.
        let (t, p) = hit(Vec3::new(-10.0, 0.0, 0.5), Vec3::X).unwrap();
        assert!((t as f64 - (10.0 - 3.75f64.sqrt())).abs() < 1e-5, "{t}");
        // uv: u = φ/φmax, v = (θ − θ(zmin))/(θ(zmax) − θ(zmin)) with θ = acos(z/r).
        let g = s.geom(p);
        let (th, th0, th1) = (0.25f64.acos(), (-0.5f64).acos(), 0.75f64.acos());
        assert!((g.uv.x as f64 - 180.0 / 250.0).abs() < 1e-6, "{:?}", g.uv);
        assert!((g.uv.y as f64 - (th - th0) / (th1 - th0)).abs() < 1e-6, "{:?}", g.uv);
        assert!((g.n - (p / 2.0).as_vec3()).length() < 1e-6);
        // Along +y at z = 0: the near root (0, −2, 0) has φ = 270° > 250° and is clipped; the far root (0, 2, 0)
        // (φ = 90°) is hit from inside at t = 12, its outward normal +y facing away from the ray origin.
        let (t, p) = hit(Vec3::new(0.0, -10.0, 0.0), Vec3::Y).unwrap();
        assert!((t - 12.0).abs() < 1e-5 && (p - DVec3::new(0.0, 2.0, 0.0)).length() < 1e-9, "{t} {p}");
        assert!((s.geom(p).n - Vec3::Y).length() < 1e-6);
        // Along −x at y = −1, z = 0: the near root (√3, −1, 0) has φ = 330° (clipped); the far root (−√3, −1, 0)
        // has φ = 210° and is hit at t = 10 + √3.
        let (t, _) = hit(Vec3::new(10.0, -1.0, 0.0), -Vec3::X).unwrap();
        assert!((t as f64 - (10.0 + 3f64.sqrt())).abs() < 1e-5, "{t}");
        // t_max below the far root: a miss.
        assert!(s.intersect_t(&Ray::new(Vec3::new(10.0, -1.0, 0.0), -Vec3::X), 11.0).is_none());
    }

    #[test]
    fn partial_sphere_parameters_are_validated() {
        let e = |r, z0, z1, phi| Sphere::partial(r, z0, z1, phi, Transform::IDENTITY, false).unwrap_err().to_string();
        assert!(e(1.0, 0.5, 0.5, 360.0).contains("'zmin'"));
        // Clamped to [−1, 1] both become 1: empty.
        assert!(e(1.0, 2.0, 3.0, 360.0).contains("'zmin'"));
        assert!(e(1.0, f32::NAN, 1.0, 360.0).contains("'zmin'"));
        assert!(e(1.0, -1.0, 1.0, 0.0).contains("'phimax'"));
        assert!(e(1.0, -1.0, 1.0, 361.0).contains("'phimax'"));
        assert!(e(0.0, -1.0, 1.0, 360.0).contains("'radius'"));
        // Out-of-range z limits are clamped: the same as the full sphere.
        let s = Sphere::partial(1.0, -5.0, 5.0, 360.0, Transform::IDENTITY, false).unwrap();
        assert!(s.is_full() && (s.area() - 4.0 * PI).abs() < 1e-5);
    }

    #[test]
    fn partial_sphere_area_and_uniform_sampling() {
        // Object radius 1.5 scaled by 2 (render radius 3), zmin = −0.5, zmax = 1 (object), φmax = 120°:
        // area = φmax·r·(zmax − zmin)·s² = (2π/3)·1.5·1.5·4.
        let t = Transform::translate(DVec3::new(1.0, -2.0, 0.5)) * Transform::scale(DVec3::splat(2.0)).unwrap();
        let s = Sphere::partial(1.5, -0.5, 1.0, 120.0, t, false).unwrap();
        let area = 2.0 * std::f64::consts::PI / 3.0 * 1.5 * 1.5 * 4.0;
        assert!((s.area() as f64 - area).abs() < 1e-5 * area, "{}", s.area());
        let inv = t.inverse();
        let n = 20_000;
        let (mut above, mut low_phi, mut sum_inv_pdf) = (0usize, 0usize, 0.0f64);
        for u in points(n) {
            let ss = s.sample_area(u);
            sum_inv_pdf += 1.0 / ss.pdf as f64;
            let p = inv.point(ss.p.as_dvec3());
            assert!((p.length() - 1.5).abs() < 1e-5, "{p}");
            assert!(p.z >= -0.5 - 1e-6 && p.z <= 1.0 + 1e-6, "{p}");
            let phi = phi_of(p).to_degrees();
            assert!(phi <= 120.0 + 1e-3, "{phi}");
            above += (p.z > 0.25) as usize;
            low_phi += (phi < 60.0) as usize;
            // The sample's uv is the surface parametrization of its point.
            assert!((ss.uv - s.geom(p).uv).length() < 1e-4);
        }
        // E[1/pdf] = area (normalisation); uniform by area: P(z > 0.25) = 0.75/1.5, P(φ < 60°) = 1/2.
        assert!((sum_inv_pdf / n as f64 - area).abs() < 1e-4 * area);
        assert!((above as f64 / n as f64 - 0.5).abs() < 0.01, "{above}");
        assert!((low_phi as f64 / n as f64 - 0.5).abs() < 0.01, "{low_phi}");
    }

    #[test]
    fn hemisphere_seen_from_below_through_its_open_side() {
        // Upper hemisphere r = 1 (zmin = 0). From (0, 0, −5) looking up, rays through the opening hit its inside.
        let s = Sphere::partial(1.0, 0.0, 1.0, 360.0, Transform::IDENTITY, false).unwrap();
        assert!(!s.is_full());
        let o = Vec3::new(0.0, 0.0, -5.0);
        let (t, p) = s.intersect_t(&Ray::new(o, Vec3::Z), f32::INFINITY).unwrap();
        assert!((t - 6.0).abs() < 1e-5, "{t}");
        // The outward normal +z faces away from the viewer: the inside is seen.
        assert!((s.geom(p).n - Vec3::Z).length() < 1e-6);
        // Off axis: x = 0.6 hits at z = 0.8, t = 5.8.
        let (t, _) = s.intersect_t(&Ray::new(Vec3::new(0.6, 0.0, -5.0), Vec3::Z), f32::INFINITY).unwrap();
        assert!((t - 5.8).abs() < 1e-5, "{t}");
        // Area sampling converted to solid angle: every direction in the cone through the rim (half-angle
        // atan(1/5)) hits the hemisphere exactly once, so E[1/pdf_ω] = 2π(1 − 5/√26).
        let shape = Shape::Sphere(s.clone());
        let n = 40_000;
        let mut omega = 0.0f64;
        for u in points(n) {
            let ss = shape.sample_solid_angle(0, o, u).unwrap();
            omega += 1.0 / ss.pdf as f64;
            let wi = (ss.p - o).normalize();
            let back = shape.pdf_solid_angle(0, o, wi);
            assert!((back - ss.pdf).abs() < 2e-3 * ss.pdf, "{back} vs {}", ss.pdf);
        }
        let exact = 2.0 * std::f64::consts::PI * (1.0 - 5.0 / 26f64.sqrt());
        assert!((omega / n as f64 - exact).abs() < 5e-3 * exact, "{} vs {exact}", omega / n as f64);
        // A full sphere keeps cone sampling: the pdf is the constant 1/(2π(1 − cos θmax)).
        let full = Sphere::new(1.0, Transform::IDENTITY, false).unwrap();
        let cos_max = (1.0f32 - 1.0 / 25.0).sqrt();
        let pdf = full.sample_solid_angle(o, Vec2::new(0.3, 0.7)).unwrap().pdf;
        assert!((pdf - 1.0 / (2.0 * PI * (1.0 - cos_max))).abs() < 1e-3 * pdf);
    }

    #[test]
    fn area_sampling_as_solid_angle_integrates_to_the_subtended_angle() {
        // A unit square of two triangles at distance 1, seen from the origin: ∫ dω = E[1/pdf_ω].
        let data = MeshData {
            positions: vec![
                Vec3::new(-0.5, -0.5, 1.0),
                Vec3::new(0.5, -0.5, 1.0),
                Vec3::new(0.5, 0.5, 1.0),
                Vec3::new(-0.5, 0.5, 1.0),
            ],
            indices: vec![0, 1, 2, 0, 2, 3],
            ..Default::default()
        };
        let m = Shape::Mesh(Arc::new(TriangleMesh::new(&Transform::IDENTITY, data, false).unwrap()));
        let n = 20_000;
        let mut omega = 0.0f64;
        for tri in 0..2 {
            omega += points(n).map(|u| 1.0 / m.sample_solid_angle(tri, Vec3::ZERO, u).unwrap().pdf as f64).sum::<f64>()
                / n as f64;
        }
        // Solid angle of a square of side a at distance d: 4·asin(a² / (a² + 4d²)).
        let exact = 4.0 * (1.0f64 / 5.0).asin();
        assert!((omega - exact).abs() < 2e-3, "{omega} vs {exact}");
        let wi = Vec3::new(0.1, 0.2, 1.0).normalize();
        let ss_pdf = m.pdf_solid_angle(0, Vec3::ZERO, wi) + m.pdf_solid_angle(1, Vec3::ZERO, wi);
        let cos = wi.z;
        let expect = (1.0 / cos).powi(2) / cos / 0.5; // dist²/(cos·area) with area 1/2 per triangle
        assert!((ss_pdf - expect).abs() < 1e-3 * expect, "{ss_pdf} vs {expect}");
    }
}

//! Triangles of a [`TriangleMesh`]: the watertight ray–triangle test of Woop, Benthin and Wald (2013) with pbrt-v4's
//! conservative `t > 0` bound, surface geometry from barycentrics, and uniform area sampling.

use glam::{Vec2, Vec3};

use super::{
    coordinate_system, d_normalize, sample_uniform_triangle, ElementHit, ShapeKind, ShapeRay, ShapeSample,
    SurfaceDerivatives, SurfaceGeom,
};
use crate::bounds::Bounds3;
use crate::mesh::TriangleMesh;
use crate::ray::gamma;

/// A ray prepared for the watertight triangle test: the permutation making `|d.z|` largest and the shear
/// constants.
#[derive(Clone, Copy, Debug)]
pub(crate) struct TriRay {
    o: Vec3,
    k: [usize; 3],
    s: Vec3,
}

impl TriRay {
    #[inline]
    pub fn new(o: Vec3, d: Vec3) -> Self {
        let a = d.abs();
        let kz = if a.x > a.y {
            if a.x > a.z {
                0
            } else {
                2
            }
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let kx = (kz + 1) % 3;
        let ky = (kx + 1) % 3;
        let dz = d[kz];
        Self { o, k: [kx, ky, kz], s: Vec3::new(-d[kx] / dz, -d[ky] / dz, 1.0 / dz) }
    }
}

/// Watertight ray–triangle intersection (Woop et al. 2013, with pbrt-v4's conservative `t > 0` bound). Returns
/// `(t, [b0, b1, b2])` for `0 < t < t_max`.
#[inline]
pub(crate) fn intersect_triangle(r: &TriRay, p0: Vec3, p1: Vec3, p2: Vec3, t_max: f32) -> Option<(f32, [f32; 3])> {
    let [kx, ky, kz] = r.k;
    let perm = |p: Vec3| {
        let q = p - r.o;
        Vec3::new(q[kx], q[ky], q[kz])
    };
    let (mut p0t, mut p1t, mut p2t) = (perm(p0), perm(p1), perm(p2));
    let s = r.s;
    p0t.x += s.x * p0t.z;
    p0t.y += s.y * p0t.z;
    p1t.x += s.x * p1t.z;
    p1t.y += s.y * p1t.z;
    p2t.x += s.x * p2t.z;
    p2t.y += s.y * p2t.z;
    let mut e0 = p1t.x * p2t.y - p1t.y * p2t.x;
    let mut e1 = p2t.x * p0t.y - p2t.y * p0t.x;
    let mut e2 = p0t.x * p1t.y - p0t.y * p1t.x;
    if e0 == 0.0 || e1 == 0.0 || e2 == 0.0 {
        // Fall back to f64 on exact zeros so edges shared by two triangles are never missed.
        let f = |a: f32, b: f32, c: f32, d: f32| (a as f64 * b as f64 - c as f64 * d as f64) as f32;
        e0 = f(p1t.x, p2t.y, p1t.y, p2t.x);
        e1 = f(p2t.x, p0t.y, p2t.y, p0t.x);
        e2 = f(p0t.x, p1t.y, p0t.y, p1t.x);
    }
    if (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0) {
        return None;
    }
    let det = e0 + e1 + e2;
    if det == 0.0 || det.is_nan() {
        return None;
    }
    p0t.z *= s.z;
    p1t.z *= s.z;
    p2t.z *= s.z;
    let t_scaled = e0 * p0t.z + e1 * p1t.z + e2 * p2t.z;
    if det < 0.0 && (t_scaled >= 0.0 || t_scaled < t_max * det) {
        return None;
    }
    if det > 0.0 && (t_scaled <= 0.0 || t_scaled > t_max * det) {
        return None;
    }
    let inv_det = 1.0 / det;
    let t = t_scaled * inv_det;
    // Conservative bound on the error of t (pbrt-v4 §6.8.7): reject hits that may be at t <= 0.
    let max_zt = p0t.z.abs().max(p1t.z.abs()).max(p2t.z.abs());
    let delta_z = gamma(3) * max_zt;
    let max_xt = p0t.x.abs().max(p1t.x.abs()).max(p2t.x.abs());
    let max_yt = p0t.y.abs().max(p1t.y.abs()).max(p2t.y.abs());
    let delta_x = gamma(5) * (max_xt + max_zt);
    let delta_y = gamma(5) * (max_yt + max_zt);
    let delta_e = 2.0 * (gamma(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    let max_e = e0.abs().max(e1.abs()).max(e2.abs());
    let delta_t = 3.0 * (gamma(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) * inv_det.abs();
    if t <= delta_t {
        return None;
    }
    Some((t, [e0 * inv_det, e1 * inv_det, e2 * inv_det]))
}

/// Surface geometry of triangle `tri` of `mesh` at barycentrics `b` (pbrt-v4's `InteractionFromIntersection`).
pub(crate) fn triangle_geom(mesh: &TriangleMesh, tri: usize, b: [f32; 3]) -> SurfaceGeom {
    let [p0, p1, p2] = mesh.triangle_positions(tri);
    let [uv0, uv1, uv2] = mesh.triangle_uvs(tri);
    let p = b[0] * p0 + b[1] * p1 + b[2] * p2;
    let p_abs = (b[0] * p0).abs() + (b[1] * p1).abs() + (b[2] * p2).abs();
    let p_error = gamma(7) * p_abs;
    let uv = b[0] * uv0 + b[1] * uv1 + b[2] * uv2;
    let (dp02, dp12) = (p0 - p2, p1 - p2);
    let mut n = dp02.cross(dp12).normalize_or_zero();
    if mesh.flip_normal() {
        n = -n;
    }
    let (duv02, duv12) = (uv0 - uv2, uv1 - uv2);
    let det = duv02.x * duv12.y - duv02.y * duv12.x;
    let (mut dpdu, mut dpdv) = (Vec3::ZERO, Vec3::ZERO);
    if det.abs() >= 1e-9 {
        let inv = 1.0 / det;
        dpdu = (duv12.y * dp02 - duv02.y * dp12) * inv;
        dpdv = (duv02.x * dp12 - duv12.x * dp02) * inv;
        if dpdu.cross(dpdv).length_squared() == 0.0 || !dpdu.is_finite() || !dpdv.is_finite() {
            dpdu = Vec3::ZERO;
        }
    }
    if dpdu == Vec3::ZERO {
        (dpdu, dpdv) = coordinate_system(if n == Vec3::ZERO { Vec3::Z } else { n });
    }
    let mut ns = n;
    let (mut shading_dpdu, mut shading_dpdv) = (dpdu, dpdv);
    if let Some([n0, n1, n2]) = mesh.triangle_normals(tri) {
        if let Some(v) = (b[0] * n0 + b[1] * n1 + b[2] * n2).try_normalize() {
            ns = v;
            if n.dot(ns) < 0.0 {
                n = -n;
            }
        }
        // pbrt-v4's Triangle: the shading tangents are ns × ∂p/∂u and ∂p/∂u made perpendicular to ns.
        let ts = ns.cross(dpdu);
        (shading_dpdu, shading_dpdv) =
            if ts.length_squared() > 0.0 { (ts.cross(ns), ts) } else { coordinate_system(ns) };
    }
    SurfaceGeom { p, p_error, n, ns, uv, dpdu, shading_dpdu, shading_dpdv }
}

/// Derivatives of triangle `tri` of `mesh` at barycentrics `b`, with respect to the texture (u, v) as pbrt-v4 takes
/// them (§6.5.3), or to the barycentrics (b0, b1) when the texture coordinates are degenerate. The shading normal
/// is the normalized interpolation of the vertex normals, so its derivative is that of the interpolation projected
/// off the normal and divided by its length; without vertex normals the triangle is flat (zero).
pub(crate) fn triangle_derivatives(mesh: &TriangleMesh, tri: usize, b: [f32; 3]) -> SurfaceDerivatives {
    let [p0, p1, p2] = mesh.triangle_positions(tri);
    let [uv0, uv1, uv2] = mesh.triangle_uvs(tri);
    let (dp02, dp12) = (p0 - p2, p1 - p2);
    let (duv02, duv12) = (uv0 - uv2, uv1 - uv2);
    let det = duv02.x * duv12.y - duv02.y * duv12.x;
    // d/du X = a_u·(X0 − X2) + c_u·(X1 − X2) for anything X that varies linearly over the triangle (pbrt-v4's
    // inversion of the uv differences), likewise d/dv; the barycentric parametrization if the uvs are degenerate.
    let mut coef = [1.0, 0.0, 0.0, 1.0];
    if det.abs() >= 1e-9 {
        let inv = 1.0 / det;
        let c = [duv12.y * inv, -duv02.y * inv, -duv12.x * inv, duv02.x * inv];
        let du = c[0] * dp02 + c[1] * dp12;
        let dv = c[2] * dp02 + c[3] * dp12;
        if du.is_finite() && dv.is_finite() && du.cross(dv).length_squared() > 0.0 {
            coef = c;
        }
    }
    let to_u = |x02: Vec3, x12: Vec3| coef[0] * x02 + coef[1] * x12;
    let to_v = |x02: Vec3, x12: Vec3| coef[2] * x02 + coef[3] * x12;
    let (dpdu, dpdv) = (to_u(dp02, dp12), to_v(dp02, dp12));
    let (mut dndu, mut dndv) = (Vec3::ZERO, Vec3::ZERO);
    if let Some([n0, n1, n2]) = mesh.triangle_normals(tri) {
        let nsum = b[0] * n0 + b[1] * n1 + b[2] * n2;
        if nsum.length_squared() > 0.0 {
            let (dn02, dn12) = (n0 - n2, n1 - n2);
            dndu = d_normalize(nsum, to_u(dn02, dn12));
            dndv = d_normalize(nsum, to_v(dn02, dn12));
        }
    }
    SurfaceDerivatives { dpdu, dpdv, dndu, dndv }
}

/// Uniform area sample of triangle `tri` (pdf = 1/area).
pub fn sample_triangle_area(mesh: &TriangleMesh, tri: usize, u: Vec2) -> Option<ShapeSample> {
    let area = mesh.triangle_area(tri);
    if area <= 0.0 || !area.is_finite() {
        return None;
    }
    let b = sample_uniform_triangle(u);
    let g = triangle_geom(mesh, tri, b);
    Some(ShapeSample { p: g.p, p_error: g.p_error, n: g.n, uv: g.uv, pdf: 1.0 / area })
}

/// Intersects a triangle given by its vertices: the BVH's inline copy of a mesh element (see
/// [`ShapeKind::element_triangle`]), giving the same hit as [`TriangleMesh`]'s own `intersect_element`.
#[inline]
pub(crate) fn intersect_inline_triangle(ray: &ShapeRay, tri: &[Vec3; 3], t_max: f32) -> Option<ElementHit> {
    let [p0, p1, p2] = *tri;
    intersect_triangle(&ray.tri, p0, p1, p2, t_max).map(|(t, b)| ElementHit::at_coords(t, b))
}

impl ShapeKind for TriangleMesh {
    fn primitive_count(&self) -> usize {
        self.triangle_count()
    }

    fn bounds(&self) -> Bounds3 {
        TriangleMesh::bounds(self)
    }

    fn element_bounds(&self, e: usize) -> Bounds3 {
        Bounds3::from_points(self.triangle_positions(e))
    }

    fn area(&self, e: usize) -> f32 {
        self.triangle_area(e)
    }

    #[inline]
    fn element_triangle(&self, e: usize) -> Option<[Vec3; 3]> {
        Some(self.triangle_positions(e))
    }

    #[inline]
    fn intersect_element(&self, e: usize, ray: &ShapeRay, t_max: f32) -> Option<ElementHit> {
        intersect_inline_triangle(ray, &self.triangle_positions(e), t_max)
    }

    fn surface_geom(&self, e: usize, hit: &ElementHit) -> SurfaceGeom {
        triangle_geom(self, e, hit.b)
    }

    fn derivatives(&self, e: usize, hit: &ElementHit) -> Option<SurfaceDerivatives> {
        Some(triangle_derivatives(self, e, hit.b))
    }

    fn sample_area(&self, e: usize, u: Vec2) -> Option<ShapeSample> {
        sample_triangle_area(self, e, u)
    }
}

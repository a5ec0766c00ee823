//! Bilinear patch meshes (pbrt-v4's `bilinearmesh`), intersected exactly.
//!
//! Patch `k` has corners `p00 p10 p01 p11` and is the surface
//! `p(u, v) = (1−u)(1−v)·p00 + u(1−v)·p10 + (1−u)v·p01 + uv·p11` over `(u, v) ∈ [0, 1]²`: a parallelogram when
//! planar with `p11 − p10 = p01 − p00`, a hyperbolic paraboloid in general. Rays are intersected with the geometric
//! method of Reshetov (2019, "Cool Patches", Ray Tracing Gems ch. 8) in f64: a quadratic in `u` says where the ray
//! meets the segment `v ↦ p(u, v)`, and the closest-approach of ray and segment gives `t` and `v`.
//!
//! The mesh is an [`IndexedMesh`] like [`crate::TriangleMesh`]: shared render-space vertices, four `u32` indices per
//! patch, optional per-vertex normals and uvs. Its [`crate::shapes::Shape`] queries are at the end of this file.

use glam::{DVec3, Vec2, Vec3};

use crate::bounds::Bounds3;
use crate::mesh::IndexedMesh;
use crate::ray::gamma;
use crate::shapes::{coordinate_system, ElementHit, ShapeKind, ShapeRay, ShapeSample, SurfaceGeom};

/// A bilinear patch mesh with its vertices in render space (pbrt-v4's `BilinearPatchMesh`).
///
/// The geometric normal at `(u, v)` is `normalize(∂p/∂u × ∂p/∂v)`, negated when
/// `reverse_orientation() != transform_swaps_handedness()`; with per-vertex normals it is instead turned to the side
/// of the interpolated shading normal (as for triangles).
pub type BilinearMesh = IndexedMesh<4>;

/// Tolerance (in the patch parameters) by which a root may fall outside `[0, 1]` and still count as a hit, clamped
/// to the edge: it covers the f64 rounding of the solve, so that a ray through an edge shared by two patches hits at
/// least one of them.
const PARAM_EPS: f64 = 1e-9;

/// Hits nearer than this fraction of the distance from the ray origin to the farthest corner are rejected. A ray
/// spawned from a point lying exactly on the patch (zero error bound across it, as on an axis-aligned plane) would
/// otherwise re-hit it at a `t` of pure f64 rounding (~1e-16 relative); 1e-9 is far above that rounding and far
/// below the f32 resolution of the scene (2⁻²⁴ ≈ 6e-8 relative), so no distinguishable hit is lost.
const T_EPS: f64 = 1e-9;

/// Bilinear interpolation of four corner values at `(u, v)`.
#[inline]
fn bilerp<T>(c: [T; 4], u: f64, v: f64) -> T
where
    T: std::ops::Mul<f64, Output = T> + std::ops::Add<Output = T> + Copy,
{
    c[0] * ((1.0 - u) * (1.0 - v)) + c[1] * (u * (1.0 - v)) + c[2] * ((1.0 - u) * v) + c[3] * (u * v)
}

/// The partial derivatives `(∂p/∂u, ∂p/∂v)` of the patch with corners `c` at `(u, v)`.
#[inline]
fn partials(c: [DVec3; 4], u: f64, v: f64) -> (DVec3, DVec3) {
    let dpdu = (c[1] - c[0]).lerp(c[3] - c[2], v);
    let dpdv = (c[2] - c[0]).lerp(c[3] - c[1], u);
    (dpdu, dpdv)
}

/// Area element `|∂p/∂u × ∂p/∂v|` of the patch at `(u, v)`.
#[inline]
fn jacobian(c: [DVec3; 4], u: f64, v: f64) -> f64 {
    let (dpdu, dpdv) = partials(c, u, v);
    dpdu.cross(dpdv).length()
}

/// Ray–bilinear-patch intersection (Reshetov 2019): the nearest `(t, u, v)` with `0 < t < t_max` on the patch with
/// corners `c = [p00, p10, p01, p11]`, for the ray `o + t·d`. All in f64.
pub fn intersect_patch(o: DVec3, d: DVec3, c: [DVec3; 4], t_max: f64) -> Option<(f64, f64, f64)> {
    // Corners relative to the ray origin.
    let [q00, q10, q01, q11] = c.map(|p| p - o);
    // The ray meets the segment s(u) = a(u) + v·e(u), a(u) = lerp(q00, q10, u), e(u) = lerp(q01, q11, u) − a(u),
    // where it is coplanar with it: f(u) = d · (a(u) × e(u)) = 0 (Reshetov 2019, eq. 8.4), a quadratic in u.
    let e10 = q10 - q00;
    let e00 = q01 - q00;
    let e11 = q11 - q10;
    let c0 = d.dot(q00.cross(e00)); // f(0)
    let c1 = d.dot(q10.cross(e11)); // f(1)
    let a2 = d.dot(e10.cross(e11 - e00)); // u² coefficient: d · (e10 × (e11 − e00))
    let b1 = c1 - c0 - a2; // f(1) = a2 + b1 + c0
    let mut roots = [f64::NAN; 2];
    if a2 == 0.0 {
        if b1 != 0.0 {
            roots[0] = -c0 / b1;
        }
    } else {
        let disc = b1 * b1 - 4.0 * a2 * c0;
        if disc < 0.0 {
            return None;
        }
        // Numerically stable roots: q = −(b + sign(b)·√disc)/2, u = q/a and c/q.
        let q = -0.5 * (b1 + b1.signum() * disc.sqrt());
        if q != 0.0 {
            roots = [c0 / q, q / a2];
        } else {
            // b = 0 and disc = 0: the double root u = 0 (c = 0).
            roots[0] = 0.0;
        }
    }
    let mut best: Option<(f64, f64, f64)> = None;
    let mut t_lim = t_max;
    let reach = [q00, q10, q01, q11].iter().fold(0.0f64, |m, q| m.max(q.length()));
    let t_min = T_EPS * reach / d.length();
    for u in roots {
        if !(-PARAM_EPS..=1.0 + PARAM_EPS).contains(&u) {
            continue;
        }
        let u = u.clamp(0.0, 1.0);
        let a = q00.lerp(q10, u);
        let e = q01.lerp(q11, u) - a;
        // Closest approach of the ray t·d and the line a + v·e: with n = e × d,
        // v = (d × a)·n / |n|² and t = (e × a)·n / |n|² (Reshetov 2019, eq. 8.6).
        let n = e.cross(d);
        let nn = n.length_squared();
        if nn == 0.0 {
            continue;
        }
        let v = d.cross(a).dot(n) / nn;
        if !(-PARAM_EPS..=1.0 + PARAM_EPS).contains(&v) {
            continue;
        }
        let t = e.cross(a).dot(n) / nn;
        if t > t_min && t < t_lim {
            t_lim = t;
            best = Some((t, u, v.clamp(0.0, 1.0)));
        }
    }
    best
}

/// Samples `x ∈ [0, 1]` with density proportional to `(1 − x)·a + x·b` (`a, b ≥ 0`, not both 0), by inverting its
/// CDF `(a·x + (b − a)·x²/2) / ((a + b)/2) = ξ`, written in the cancellation-free form `ξ(a + b) / (a + √((1−ξ)a² +
/// ξb²))`.
fn sample_linear(xi: f64, a: f64, b: f64) -> f64 {
    if a == b {
        return xi;
    }
    let den = a + ((1.0 - xi) * a * a + xi * b * b).sqrt();
    if den == 0.0 {
        return 0.0;
    }
    (xi * (a + b) / den).clamp(0.0, 1.0)
}

impl IndexedMesh<4> {
    /// Number of patches.
    pub fn patch_count(&self) -> usize {
        self.face_count()
    }

    /// The vertex indices `p00 p10 p01 p11` of patch `k`. Panics if `k >= patch_count()` (an internal index, never
    /// user data).
    #[inline]
    pub fn patch(&self, k: usize) -> [u32; 4] {
        self.face(k)
    }

    /// The four render-space corners `p00 p10 p01 p11` of patch `k`.
    #[inline]
    pub fn patch_positions(&self, k: usize) -> [Vec3; 4] {
        self.face_positions(k)
    }

    fn corners(&self, k: usize) -> [DVec3; 4] {
        self.patch_positions(k).map(|p| p.as_dvec3())
    }

    /// Bounds of patch `k`.
    pub fn patch_bounds(&self, k: usize) -> Bounds3 {
        Bounds3::from_points(self.patch_positions(k))
    }

    /// Area of patch `k`: ∫∫ |∂p/∂u × ∂p/∂v| du dv by 5×5-point Gauss–Legendre quadrature (exact for
    /// parallelograms, where the integrand is constant; relative error below 1e-6 for smooth non-planar patches).
    pub fn patch_area(&self, k: usize) -> f32 {
        // 5-point Gauss–Legendre nodes and weights on [−1, 1] (Abramowitz & Stegun 25.4.30), mapped to [0, 1].
        const X: [f64; 5] =
            [-0.906_179_845_938_664, -0.538_469_310_105_683_1, 0.0, 0.538_469_310_105_683_1, 0.906_179_845_938_664];
        const W: [f64; 5] = [
            0.236_926_885_056_189_1,
            0.478_628_670_499_366_5,
            0.568_888_888_888_888_9,
            0.478_628_670_499_366_5,
            0.236_926_885_056_189_1,
        ];
        let c = self.corners(k);
        let mut sum = 0.0;
        for (xi, wi) in X.iter().zip(W) {
            for (xj, wj) in X.iter().zip(W) {
                sum += wi * wj * jacobian(c, 0.5 * (xi + 1.0), 0.5 * (xj + 1.0));
            }
        }
        (0.25 * sum) as f32
    }

    /// Total surface area.
    pub fn area(&self) -> f64 {
        (0..self.patch_count()).map(|k| self.patch_area(k) as f64).sum()
    }

    /// Nearest hit of patch `k` with the ray `o + t·d`, `0 < t < t_max`: `(t, (u, v))`.
    #[inline]
    pub fn intersect(&self, k: usize, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, Vec2)> {
        let (t, u, v) = intersect_patch(o.as_dvec3(), d.as_dvec3(), self.corners(k), t_max as f64)?;
        let t = t as f32;
        // Rounding t to f32 must not reach t_max or 0.
        (t > 0.0 && t < t_max).then(|| (t, Vec2::new(u as f32, v as f32)))
    }

    /// Surface geometry of patch `k` at patch parameters `uv` (pbrt-v4's `BilinearPatch::InteractionFromIntersection`
    /// in spirit: point, normal, texture uv and ∂p/∂u in texture space).
    pub(crate) fn geom(&self, k: usize, uv: Vec2) -> SurfaceGeom {
        let c = self.corners(k);
        let (u, v) = (uv.x as f64, uv.y as f64);
        let p = bilerp(c, u, v);
        // The point is on the surface for these (u, v) up to the rounding of the interpolation (a few ulps of the
        // weighted corner magnitudes, bounded as for triangles) and of the conversion to f32.
        let p_abs = bilerp(c.map(|q| q.abs()), u, v).as_vec3();
        let p_error = gamma(6) * p_abs;
        let (dpdu, dpdv) = partials(c, u, v);
        let mut n = dpdu.cross(dpdv);
        if n.length_squared() == 0.0 {
            // Degenerate point (a collapsed edge): the mean normal of the patch, from its diagonals.
            n = (c[3] - c[0]).cross(c[2] - c[1]);
        }
        let mut n = n.normalize_or_zero().as_vec3();
        if n == Vec3::ZERO {
            n = Vec3::Z;
        }
        if self.flip_normal() {
            n = -n;
        }
        // Texture coordinates and ∂p/∂s, ∂p/∂t in texture space: [∂p/∂u ∂p/∂v] = [∂p/∂s ∂p/∂t]·J,
        // J = ∂(s,t)/∂(u,v).
        let (tex_uv, mut dpds, mut dpdt) = match self.uvs() {
            Some(uvs) => {
                let t = self.patch(k).map(|i| uvs[i as usize].as_dvec2());
                let st = bilerp(t, u, v);
                let dstdu = (t[1] - t[0]).lerp(t[3] - t[2], v);
                let dstdv = (t[2] - t[0]).lerp(t[3] - t[1], u);
                let det = dstdu.x * dstdv.y - dstdv.x * dstdu.y;
                let dpds = (dpdu * dstdv.y - dpdv * dstdu.y) / det;
                let dpdt = (dpdv * dstdu.x - dpdu * dstdv.x) / det;
                if det.abs() > 1e-12 && dpds.is_finite() && dpdt.is_finite() {
                    (st.as_vec2(), dpds, dpdt)
                } else {
                    (st.as_vec2(), dpdu, dpdv)
                }
            }
            None => (uv, dpdu, dpdv),
        };
        if dpds.length_squared() == 0.0 {
            dpds = coordinate_system(n).0.as_dvec3();
        }
        if dpdt.length_squared() == 0.0 {
            dpdt = n.as_dvec3().cross(dpds);
        }
        let mut ns = n;
        let (mut shading_dpdu, mut shading_dpdv) = (dpds.as_vec3(), dpdt.as_vec3());
        if let Some(normals) = self.normals() {
            let nv = self.patch(k).map(|i| normals[i as usize]);
            if let Some(m) = bilerp(nv.map(|x| x.as_dvec3()), u, v).as_vec3().try_normalize() {
                ns = m;
                // pbrt-v4's BilinearPatch: ∂p/∂u and ∂p/∂v turn with the normal (a rotation about n × ns taking n
                // to ns), then ∂p/∂u is made perpendicular to ns.
                let (nd, nsd) = (n.as_dvec3(), ns.as_dvec3());
                let axis = nd.cross(nsd);
                if axis.length_squared() > 1e-14 {
                    let axis = axis.normalize();
                    let cos = nd.dot(nsd).clamp(-1.0, 1.0);
                    let sin = (1.0 - cos * cos).max(0.0).sqrt();
                    // Rodrigues' rotation formula.
                    let rot = |w: DVec3| w * cos + axis.cross(w) * sin + axis * axis.dot(w) * (1.0 - cos);
                    let (su, sv) = (rot(dpds), rot(dpdt));
                    shading_dpdu = (su - nsd * su.dot(nsd)).as_vec3();
                    shading_dpdv = sv.as_vec3();
                }
                if n.dot(ns) < 0.0 {
                    n = -n;
                }
            }
        }
        let (dpdu, dpdv) = (dpds.as_vec3(), dpdt.as_vec3());
        SurfaceGeom { p: p.as_vec3(), p_error, n, ns, uv: tex_uv, dpdu, dpdv, shading_dpdu, shading_dpdv }
    }

    /// Corner area elements of patch `k`, the weights of the bilinear density used to sample it.
    fn corner_weights(c: [DVec3; 4]) -> [f64; 4] {
        [jacobian(c, 0.0, 0.0), jacobian(c, 1.0, 0.0), jacobian(c, 0.0, 1.0), jacobian(c, 1.0, 1.0)]
    }

    /// Density in `(u, v)` of [`BilinearMesh::sample_area`]: the bilinear interpolation of the corner weights,
    /// normalised (uniform if the weights are all zero).
    fn pdf_uv(w: [f64; 4], u: f64, v: f64) -> f64 {
        let sum = w.iter().sum::<f64>();
        if !(sum > 0.0 && sum.is_finite()) {
            return 1.0;
        }
        // ∫∫ bilerp(w) du dv = (w00 + w10 + w01 + w11)/4.
        bilerp(w, u, v) * 4.0 / sum
    }

    /// Density per unit area of [`BilinearMesh::sample_area`] at patch parameters `uv` of patch `k`:
    /// `pdf_uv(u, v) / |∂p/∂u × ∂p/∂v|` (0 where the patch is degenerate).
    pub fn pdf_area(&self, k: usize, uv: Vec2) -> f32 {
        let c = self.corners(k);
        let (u, v) = (uv.x as f64, uv.y as f64);
        let j = jacobian(c, u, v);
        let pdf = Self::pdf_uv(Self::corner_weights(c), u, v) / j;
        if pdf.is_finite() {
            pdf as f32
        } else {
            0.0
        }
    }

    /// A point on patch `k` with its density per unit area. `(u, v)` is drawn from the bilinear density through the
    /// area elements at the four corners (marginal in `u`, then conditional in `v`, both linear), and the area
    /// density is `pdf_uv / |∂p/∂u × ∂p/∂v|`: exact for any patch, and exactly uniform (1/area) for a parallelogram,
    /// whose area element is constant. `None` at a degenerate point.
    pub fn sample_area(&self, k: usize, xi: Vec2) -> Option<ShapeSample> {
        let c = self.corners(k);
        let w = Self::corner_weights(c);
        let (u, v) = if w.iter().sum::<f64>() > 0.0 {
            let u = sample_linear(xi.x as f64, w[0] + w[2], w[1] + w[3]);
            let v = sample_linear(xi.y as f64, w[0] + (w[1] - w[0]) * u, w[2] + (w[3] - w[2]) * u);
            (u, v)
        } else {
            (xi.x as f64, xi.y as f64)
        };
        let j = jacobian(c, u, v);
        let pdf = Self::pdf_uv(w, u, v) / j;
        if !(pdf.is_finite() && pdf > 0.0) {
            return None;
        }
        let g = self.geom(k, Vec2::new(u as f32, v as f32));
        Some(ShapeSample { p: g.p, p_error: g.p_error, n: g.n, uv: g.uv, pdf: pdf as f32 })
    }
}

impl ShapeKind for BilinearMesh {
    fn primitive_count(&self) -> usize {
        self.patch_count()
    }

    fn bounds(&self) -> Bounds3 {
        BilinearMesh::bounds(self)
    }

    fn element_bounds(&self, e: usize) -> Bounds3 {
        self.patch_bounds(e)
    }

    fn area(&self, e: usize) -> f32 {
        self.patch_area(e)
    }

    #[inline]
    fn intersect_element(&self, e: usize, ray: &ShapeRay, t_max: f32) -> Option<ElementHit> {
        self.intersect(e, ray.ray.o, ray.ray.d, t_max).map(|(t, uv)| ElementHit::at_coords(t, [uv.x, uv.y, 0.0]))
    }

    fn surface_geom(&self, e: usize, hit: &ElementHit) -> SurfaceGeom {
        self.geom(e, Vec2::new(hit.b[0], hit.b[1]))
    }

    fn sample_area(&self, e: usize, u: Vec2) -> Option<ShapeSample> {
        BilinearMesh::sample_area(self, e, u)
    }

    fn pdf_area(&self, e: usize, hit: &ElementHit) -> f32 {
        BilinearMesh::pdf_area(self, e, Vec2::new(hit.b[0], hit.b[1]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::BilinearMeshData;
    use crate::transform::Transform;

    fn square(normals: Option<Vec<Vec3>>, uvs: Option<Vec<Vec2>>, reverse: bool) -> BilinearMesh {
        let data = BilinearMeshData {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)],
            normals,
            uvs,
            indices: vec![0, 1, 2, 3],
        };
        BilinearMesh::new(&Transform::IDENTITY, data, reverse).unwrap()
    }

    #[test]
    fn geometry_follows_pbrt_conventions() {
        // Unit square in z = 0: ∂p/∂u × ∂p/∂v = x × y = +z; ReverseOrientation negates it.
        let g = square(None, None, false).geom(0, Vec2::new(0.25, 0.5));
        assert!((g.p - Vec3::new(0.25, 0.5, 0.0)).length() < 1e-7 && g.n == Vec3::Z && g.ns == Vec3::Z);
        assert_eq!(g.uv, Vec2::new(0.25, 0.5));
        assert!((g.dpdu - Vec3::X).length() < 1e-7);
        assert_eq!(square(None, None, true).geom(0, Vec2::new(0.25, 0.5)).n, -Vec3::Z);
        // Per-vertex uvs (0,0), (2,0), (0,3), (2,3): uv = (2u, 3v), and ∂p/∂s = ∂p/∂u / 2.
        let uvs = vec![Vec2::ZERO, Vec2::new(2.0, 0.0), Vec2::new(0.0, 3.0), Vec2::new(2.0, 3.0)];
        let g = square(None, Some(uvs), false).geom(0, Vec2::new(0.25, 0.5));
        assert!((g.uv - Vec2::new(0.5, 1.5)).length() < 1e-6 && (g.dpdu - 0.5 * Vec3::X).length() < 1e-6);
        assert!((g.shading_dpdu - 0.5 * Vec3::X).length() < 1e-6 && (g.shading_dpdv - Vec3::Y / 3.0).length() < 1e-6);
        // Tilted vertex normals (pbrt-v4): ∂p/∂u and ∂p/∂v rotate with the normal, keeping their lengths.
        let tilted = Vec3::new(0.0, 0.6, 0.8);
        let g = square(Some(vec![tilted; 4]), None, false).geom(0, Vec2::new(0.25, 0.5));
        assert!(g.shading_dpdu.cross(g.shading_dpdv).dot(tilted) > 1.0 - 1e-6);
        assert!(
            (g.shading_dpdu - Vec3::X).length() < 1e-6 && (g.shading_dpdv - Vec3::new(0.0, 0.8, -0.6)).length() < 1e-6
        );
        // Per-vertex normals −z: the shading normal is −z and the geometric normal is turned to its side; under
        // ReverseOrientation the normals are negated (to +z) and so is the geometric one (−z, then turned to +z).
        let g = square(Some(vec![-Vec3::Z; 4]), None, false).geom(0, Vec2::new(0.5, 0.5));
        assert!(g.ns == -Vec3::Z && g.n == -Vec3::Z);
        let g = square(Some(vec![-Vec3::Z; 4]), None, true).geom(0, Vec2::new(0.5, 0.5));
        assert!(g.ns == Vec3::Z && g.n == Vec3::Z);
        // p_error bounds the rounding: a few ulps of the coordinates.
        assert!(g.p_error.max_element() < 1e-6);
    }

    #[test]
    fn linear_sampling_inverts_its_cdf() {
        // Density ∝ (1 − x)·a + x·b has CDF (a·x + (b − a)·x²/2)/((a + b)/2).
        for (a, b) in [(1.0, 3.0), (2.0, 0.0), (0.0, 1.0), (1.0, 1.0)] {
            for xi in [0.0, 0.1, 0.5, 0.9, 1.0] {
                let x = sample_linear(xi, a, b);
                let cdf = (a * x + (b - a) * x * x / 2.0) / ((a + b) / 2.0);
                assert!((cdf - xi).abs() < 1e-12, "{a} {b} {xi}: {x} {cdf}");
            }
        }
    }
}

//! Triangles of a [`TriangleMesh`]: the watertight ray–triangle test of Woop, Benthin and Wald (2013) with pbrt-v4's
//! conservative `t > 0` bound, surface geometry from barycentrics, and uniform area sampling.

use glam::{Vec2, Vec3, Vec3A, Vec4};

use super::{
    coordinate_system, d_normalize, sample_uniform_triangle, ElementHit, ShapeKind, ShapeRay, ShapeSample,
    SurfaceDerivatives, SurfaceGeom,
};
use crate::bounds::Bounds3;
use crate::mesh::TriangleMesh;
use crate::ray::gamma;

/// A ray prepared for the watertight triangle test: the permutation making `|d.z|` largest, the origin in that
/// order, and the shear constants.
#[derive(Clone, Copy, Debug)]
pub(crate) struct TriRay {
    k: [usize; 3],
    /// The origin's coordinates in the order `k`, so a vertex is translated with plain indexed loads.
    o: [f32; 3],
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
        // Indexed as arrays: `Vec3`'s indexing is a `match`, a chain of branches on the random axes of bounce rays.
        let (o, d) = (o.to_array(), d.to_array());
        let dz = d[kz];
        Self { k: [kx, ky, kz], o: [o[kx], o[ky], o[kz]], s: Vec3::new(-d[kx] / dz, -d[ky] / dz, 1.0 / dz) }
    }
}

/// Watertight ray–triangle intersection (Woop et al. 2013, with pbrt-v4's conservative `t > 0` bound). Returns
/// `(t, [b0, b1, b2])` for `0 < t < t_max`. Always inlined: it is the BVH's leaf test, and taking the vertices by
/// reference lets the permutation be indexed loads from the leaf record instead of a copy to the stack.
#[inline(always)]
pub(crate) fn intersect_triangle(r: &TriRay, tri: &[Vec3; 3], t_max: f32) -> Option<(f32, [f32; 3])> {
    let [kx, ky, kz] = r.k;
    let [ox, oy, oz] = r.o;
    // Translate to the ray origin and permute (pbrt-v4 §6.5.3); the same subtractions as `p - o` then permuting.
    let perm = |p: &Vec3| {
        let p: &[f32; 3] = p.as_ref();
        Vec3::new(p[kx] - ox, p[ky] - oy, p[kz] - oz)
    };
    let (mut p0t, mut p1t, mut p2t) = (perm(&tri[0]), perm(&tri[1]), perm(&tri[2]));
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

/// Four triangles in structure-of-arrays form (`v[vertex][axis]` holds that coordinate of the four triangles), so
/// that [`intersect_tri4`] tests them together with 4-lane arithmetic; with each lane's primitive record. The BVH
/// keeps its leaf slots in blocks of four of these (Embree's "triangle4" layout, with vertices instead of edges
/// because the watertight test needs them): 160 bytes per four slots, the same 40 bytes per slot as one triangle
/// and an index.
///
/// Aligned to 32 bytes, so that every block spans exactly three cache lines (160 is five 32-byte halves of a line).
/// With the 16-byte alignment of its vectors alone, an array of blocks in a large allocation started 16 bytes into
/// a line (the allocator's header), and every other block spanned four lines, the last of which the traversal's
/// three-line prefetch missed.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(crate) struct Tri4 {
    /// Vertex coordinates: `v[vertex][axis]`, one lane per triangle.
    pub v: [[Vec4; 3]; 3],
    /// Per lane: the record the BVH keeps with the triangle (its primitive index and flags).
    pub prim: [u32; 4],
}

// Five 32-byte halves of a line, no padding: three lines per block wherever it starts.
const _: () = assert!(std::mem::size_of::<Tri4>() == 160 && std::mem::align_of::<Tri4>() == 32);

impl Tri4 {
    /// Four empty lanes, each with record `prim`.
    pub const fn empty(prim: u32) -> Self {
        Self { v: [[Vec4::ZERO; 3]; 3], prim: [prim; 4] }
    }

    /// The triangle of lane `lane`.
    #[inline(always)]
    pub fn triangle(&self, lane: usize) -> [Vec3; 3] {
        // Indexed as arrays: a loaded address each, where `Vec4`'s indexing (a `match`) became a jump table.
        let at = |v: &Vec4| AsRef::<[f32; 4]>::as_ref(v)[lane];
        self.v.map(|v| Vec3::new(at(&v[0]), at(&v[1]), at(&v[2])))
    }

    /// Stores triangle `tri` in lane `lane`.
    pub fn set(&mut self, lane: usize, tri: &[Vec3; 3]) {
        for (v, p) in self.v.iter_mut().zip(tri) {
            for (lanes, c) in v.iter_mut().zip(p.to_array()) {
                lanes[lane] = c;
            }
        }
    }
}

/// The lanes of [`intersect_tri4`] that hit, with what a hit record needs.
pub(crate) struct Tri4Hits {
    /// Bit `i` set if lane `i` is hit with `0 < t < t_max`.
    pub mask: u32,
    /// Ray parameter per lane.
    pub t: Vec4,
    /// Scaled barycentrics (edge functions) per lane; divided by the determinant, `e · inv_det`.
    pub e: [Vec4; 3],
    /// Reciprocal determinant per lane.
    pub inv_det: Vec4,
}

impl Tri4Hits {
    /// The hit of lane `lane` (which must be in `mask`): `t` and the barycentrics.
    #[inline(always)]
    pub fn hit(&self, lane: usize) -> (f32, [f32; 3]) {
        let inv = self.inv_det[lane];
        (self.t[lane], [self.e[0][lane] * inv, self.e[1][lane] * inv, self.e[2][lane] * inv])
    }

    /// The lane in `mask` with the smallest `t` (the lowest such lane on ties), if any.
    #[inline(always)]
    pub fn nearest(&self) -> Option<usize> {
        let mut m = self.mask;
        let mut best: Option<usize> = None;
        while m != 0 {
            let lane = m.trailing_zeros() as usize;
            m &= m - 1;
            if best.is_none_or(|b| self.t[lane] < self.t[b]) {
                best = Some(lane);
            }
        }
        best
    }
}

/// [`intersect_triangle`] on the lanes `lanes` (a bit mask) of `tri` at once: the same operations in the same order
/// on each lane, so each lane's answer is bit-identical to the one-triangle test (including the f64 fallback for
/// edge functions that are exactly zero, taken only for the lanes that need it).
#[inline(always)]
pub(crate) fn intersect_tri4(r: &TriRay, tri: &Tri4, lanes: u32, t_max: f32) -> Tri4Hits {
    let [kx, ky, kz] = r.k;
    let (ox, oy, oz) = (Vec4::splat(r.o[0]), Vec4::splat(r.o[1]), Vec4::splat(r.o[2]));
    let (sx, sy, sz) = (Vec4::splat(r.s.x), Vec4::splat(r.s.y), Vec4::splat(r.s.z));
    let perm = |v: &[Vec4; 3]| {
        let z = v[kz] - oz;
        (v[kx] - ox + sx * z, v[ky] - oy + sy * z, z)
    };
    let (p0x, p0y, p0z) = perm(&tri.v[0]);
    let (p1x, p1y, p1z) = perm(&tri.v[1]);
    let (p2x, p2y, p2z) = perm(&tri.v[2]);
    let mut e0 = p1x * p2y - p1y * p2x;
    let mut e1 = p2x * p0y - p2y * p0x;
    let mut e2 = p0x * p1y - p0y * p1x;
    let zero = Vec4::ZERO;
    let exact_zero = (e0.cmpeq(zero) | e1.cmpeq(zero) | e2.cmpeq(zero)).bitmask() & lanes;
    if exact_zero != 0 {
        (e0, e1, e2) = edges_f64(exact_zero, [p0x, p0y, p1x, p1y, p2x, p2y], [e0, e1, e2]);
    }
    let neg = e0.cmplt(zero) | e1.cmplt(zero) | e2.cmplt(zero);
    let pos = e0.cmpgt(zero) | e1.cmpgt(zero) | e2.cmpgt(zero);
    let det = e0 + e1 + e2;
    let mut mask = lanes & !(neg & pos).bitmask() & !(det.cmpeq(zero) | det.cmpne(det)).bitmask();
    if mask == 0 {
        return Tri4Hits { mask, t: zero, e: [e0, e1, e2], inv_det: zero };
    }
    let (p0z, p1z, p2z) = (p0z * sz, p1z * sz, p2z * sz);
    let t_scaled = e0 * p0z + e1 * p1z + e2 * p2z;
    let t_max_det = Vec4::splat(t_max) * det;
    let det_neg = det.cmplt(zero);
    let det_pos = det.cmpgt(zero);
    let out_neg = det_neg & (t_scaled.cmpge(zero) | t_scaled.cmplt(t_max_det));
    let out_pos = det_pos & (t_scaled.cmple(zero) | t_scaled.cmpgt(t_max_det));
    mask &= !(out_neg | out_pos).bitmask();
    if mask == 0 {
        return Tri4Hits { mask, t: zero, e: [e0, e1, e2], inv_det: zero };
    }
    let inv_det = Vec4::ONE / det;
    let t = t_scaled * inv_det;
    // pbrt-v4 §6.8.7's bound on the error of t, as in `intersect_triangle`.
    let g = |n: i32| Vec4::splat(gamma(n));
    let max_zt = p0z.abs().max(p1z.abs()).max(p2z.abs());
    let delta_z = g(3) * max_zt;
    let max_xt = p0x.abs().max(p1x.abs()).max(p2x.abs());
    let max_yt = p0y.abs().max(p1y.abs()).max(p2y.abs());
    let delta_x = g(5) * (max_xt + max_zt);
    let delta_y = g(5) * (max_yt + max_zt);
    let delta_e = Vec4::splat(2.0) * (g(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    let max_e = e0.abs().max(e1.abs()).max(e2.abs());
    let delta_t = Vec4::splat(3.0) * (g(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) * inv_det.abs();
    mask &= t.cmpgt(delta_t).bitmask();
    Tri4Hits { mask, t, e: [e0, e1, e2], inv_det }
}

/// The edge functions of the lanes in `lanes` recomputed in f64 (as [`intersect_triangle`] does when one is exactly
/// zero); `p` is `[p0x, p0y, p1x, p1y, p2x, p2y]`. Out of line: it is rare.
#[cold]
#[inline(never)]
fn edges_f64(lanes: u32, p: [Vec4; 6], e: [Vec4; 3]) -> (Vec4, Vec4, Vec4) {
    let [p0x, p0y, p1x, p1y, p2x, p2y] = p.map(|v| v.to_array());
    let mut e = e.map(|v| v.to_array());
    let f = |a: f32, b: f32, c: f32, d: f32| (a as f64 * b as f64 - c as f64 * d as f64) as f32;
    for i in (0..4).filter(|i| lanes & (1 << i) != 0) {
        e[0][i] = f(p1x[i], p2y[i], p1y[i], p2x[i]);
        e[1][i] = f(p2x[i], p0y[i], p2y[i], p0x[i]);
        e[2][i] = f(p0x[i], p1y[i], p0y[i], p1x[i]);
    }
    (Vec4::from_array(e[0]), Vec4::from_array(e[1]), Vec4::from_array(e[2]))
}

/// Surface geometry of triangle `tri` of `mesh` at barycentrics `b` (pbrt-v4's `InteractionFromIntersection`).
pub(crate) fn triangle_geom(mesh: &TriangleMesh, tri: usize, b: [f32; 3]) -> SurfaceGeom {
    triangle_geom_at(mesh, tri, mesh.triangle_positions(tri), b)
}

/// [`triangle_geom`] given the triangle's vertex positions, which must equal `mesh.triangle_positions(tri)`: the
/// BVH passes its inline copy, which the hit test has just read, so that a mesh without uvs or normals needs no
/// further memory access: on a big mesh the index and vertex loads, two cache misses, were a large share of the
/// closest-hit time (BENCHMARKS.md, "Why the traversal is as it is").
///
/// Computed in `Vec3A` (three coordinates per instruction), whose operations are `Vec3`'s per coordinate and in the
/// same order (sums, dot and cross products alike), so the result is the same to the bit.
#[inline(always)]
pub(crate) fn triangle_geom_at(mesh: &TriangleMesh, tri: usize, positions: [Vec3; 3], b: [f32; 3]) -> SurfaceGeom {
    let [p0, p1, p2] = positions.map(Vec3A::from);
    let [uv0, uv1, uv2] = mesh.triangle_uvs(tri);
    let (w0, w1, w2) = (b[0] * p0, b[1] * p1, b[2] * p2);
    let p = w0 + w1 + w2;
    let p_error = gamma(7) * (w0.abs() + w1.abs() + w2.abs());
    let uv = b[0] * uv0 + b[1] * uv1 + b[2] * uv2;
    let (dp02, dp12) = (p0 - p2, p1 - p2);
    let mut n = dp02.cross(dp12).normalize_or_zero();
    if mesh.flip_normal() {
        n = -n;
    }
    let (duv02, duv12) = (uv0 - uv2, uv1 - uv2);
    let det = duv02.x * duv12.y - duv02.y * duv12.x;
    let (mut dpdu, mut dpdv) = (Vec3A::ZERO, Vec3A::ZERO);
    if det.abs() >= 1e-9 {
        let inv = 1.0 / det;
        dpdu = (duv12.y * dp02 - duv02.y * dp12) * inv;
        dpdv = (duv02.x * dp12 - duv12.x * dp02) * inv;
        if dpdu.cross(dpdv).length_squared() == 0.0 || !dpdu.is_finite() || !dpdv.is_finite() {
            dpdu = Vec3A::ZERO;
        }
    }
    if dpdu == Vec3A::ZERO {
        let (u, v) = coordinate_system(if n == Vec3A::ZERO { Vec3::Z } else { n.into() });
        (dpdu, dpdv) = (u.into(), v.into());
    }
    let mut ns = n;
    let (mut shading_dpdu, mut shading_dpdv) = (dpdu, dpdv);
    let normals = mesh.triangle_normals(tri);
    let tangents = mesh.triangle_tangents(tri);
    if normals.is_some() || tangents.is_some() {
        if let Some([n0, n1, n2]) = normals {
            let [n0, n1, n2] = [n0, n1, n2].map(Vec3A::from);
            if let Some(v) = (b[0] * n0 + b[1] * n1 + b[2] * n2).try_normalize() {
                ns = v;
                if n.dot(ns) < 0.0 {
                    n = -n;
                }
            }
        }
        // pbrt-v4's Triangle: the shading tangents are ns × s and s made perpendicular to ns, s the interpolated
        // tangent (its `S`) or else ∂p/∂u.
        let s = match tangents {
            Some([t0, t1, t2]) => b[0] * Vec3A::from(t0) + b[1] * Vec3A::from(t1) + b[2] * Vec3A::from(t2),
            None => dpdu,
        };
        let mut ts = ns.cross(s);
        if ts.length_squared() == 0.0 && tangents.is_some() {
            // A zero or normal-parallel tangent (a degenerate corner): ∂p/∂u instead.
            ts = ns.cross(dpdu);
        }
        (shading_dpdu, shading_dpdv) = if ts.length_squared() > 0.0 {
            (ts.cross(ns), ts)
        } else {
            let (u, v) = coordinate_system(ns.into());
            (u.into(), v.into())
        };
    }
    SurfaceGeom {
        p: p.into(),
        p_error: p_error.into(),
        n: n.into(),
        ns: ns.into(),
        uv,
        dpdu: dpdu.into(),
        dpdv: dpdv.into(),
        shading_dpdu: shading_dpdu.into(),
        shading_dpdv: shading_dpdv.into(),
    }
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
#[inline(always)]
pub(crate) fn intersect_inline_triangle(ray: &ShapeRay, tri: &[Vec3; 3], t_max: f32) -> Option<ElementHit> {
    intersect_triangle(&ray.tri, tri, t_max).map(|(t, b)| ElementHit::at_coords(t, b))
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

    #[inline(always)]
    fn surface_geom_of_triangle(&self, e: usize, hit: &ElementHit, positions: [Vec3; 3]) -> SurfaceGeom {
        triangle_geom_at(self, e, positions, hit.b)
    }

    fn derivatives(&self, e: usize, hit: &ElementHit) -> Option<SurfaceDerivatives> {
        Some(triangle_derivatives(self, e, hit.b))
    }

    fn sample_area(&self, e: usize, u: Vec2) -> Option<ShapeSample> {
        sample_triangle_area(self, e, u)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_core::{RngCore, SeedableRng};
    use rand_pcg::Pcg32;

    fn uniform(rng: &mut Pcg32) -> f32 {
        (rng.next_u32() >> 8) as f32 / (1u32 << 24) as f32
    }

    /// A vertex: on a small integer grid half the time (so rays through grid points pass exactly through vertices
    /// and edges, where edge functions are exactly zero and the f64 fallback runs), random otherwise.
    fn vertex(rng: &mut Pcg32) -> Vec3 {
        if rng.next_u32().is_multiple_of(2) {
            Vec3::new((rng.next_u32() % 5) as f32, (rng.next_u32() % 5) as f32, (rng.next_u32() % 5) as f32 - 8.0)
        } else {
            Vec3::new(4.0 * uniform(rng), 4.0 * uniform(rng), -8.0 + 4.0 * uniform(rng))
        }
    }

    #[test]
    fn four_lane_test_is_bit_identical_to_the_one_triangle_test() {
        let mut rng = Pcg32::seed_from_u64(11);
        let (mut hits, mut misses, mut edge_hits) = (0, 0, 0);
        for trial in 0..20_000 {
            let mut tris = [[Vec3::ZERO; 3]; 4];
            let mut block = Tri4::empty(0);
            for (lane, tri) in tris.iter_mut().enumerate() {
                *tri = [vertex(&mut rng), vertex(&mut rng), vertex(&mut rng)];
                if trial % 7 == 0 && lane == 1 {
                    tri[2] = tri[0]; // degenerate: never hit
                }
                block.set(lane, tri);
            }
            // Rays mostly down −z, through grid points or random points, from above or from inside the slab.
            let target = if rng.next_u32() % 2 == 0 {
                Vec3::new((rng.next_u32() % 5) as f32, (rng.next_u32() % 5) as f32, -6.0)
            } else {
                Vec3::new(4.0 * uniform(&mut rng), 4.0 * uniform(&mut rng), -6.0)
            };
            let o = if trial % 3 == 0 {
                target + Vec3::new(0.0, 0.0, 10.0)
            } else {
                Vec3::new(4.0 * uniform(&mut rng), 4.0 * uniform(&mut rng), -6.0 + 8.0 * uniform(&mut rng))
            };
            let d = target - o;
            if d == Vec3::ZERO {
                continue;
            }
            let r = TriRay::new(o, d);
            let t_max = if trial % 4 == 0 { 0.9 } else { f32::INFINITY };
            let lanes = rng.next_u32() % 16;
            let got = intersect_tri4(&r, &block, lanes, t_max);
            assert_eq!(got.mask & !lanes, 0, "trial {trial}: a lane outside the mask was reported");
            for (lane, tri) in tris.iter().enumerate() {
                let want = intersect_triangle(&r, tri, t_max);
                if lanes & (1 << lane) == 0 {
                    continue;
                }
                match want {
                    Some((t, b)) => {
                        assert!(got.mask & (1 << lane) != 0, "trial {trial} lane {lane}: missed {t}");
                        let (t4, b4) = got.hit(lane);
                        assert_eq!(t4.to_bits(), t.to_bits(), "trial {trial} lane {lane}");
                        assert_eq!(b4.map(f32::to_bits), b.map(f32::to_bits), "trial {trial} lane {lane}");
                        hits += 1;
                        edge_hits += usize::from(b.contains(&0.0));
                    }
                    None => {
                        assert!(got.mask & (1 << lane) == 0, "trial {trial} lane {lane}: false hit");
                        misses += 1;
                    }
                }
            }
            // The nearest lane is the smallest t of the hit lanes.
            if let Some(n) = got.nearest() {
                let m = (0..4).filter(|l| got.mask & (1 << l) != 0).map(|l| got.t[l]).fold(f32::INFINITY, f32::min);
                assert_eq!(got.t[n], m);
            } else {
                assert_eq!(got.mask, 0);
            }
        }
        // Enough of each case for the comparison to mean something.
        assert!(hits > 2500 && misses > 5000 && edge_hits > 200, "{hits} hits, {misses} misses, {edge_hits} on edges");
    }
}

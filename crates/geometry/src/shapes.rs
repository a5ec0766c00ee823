//! Shapes: analytic spheres (full or partial) and disks, triangles of meshes; their intersection, surface geometry,
//! error bounds and sampling (pbrt-v4 book ch. 6). Bilinear patches live in [`crate::bilinear`].
//!
//! Spheres and disks are intersected in object space in f64 (so the `t > 0` decision for a ray leaving the surface
//! is exact enough), triangles in render space with the watertight algorithm of Woop, Benthin and Wald (2013) and
//! pbrt-v4's conservative `t > 0` test.

use std::f32::consts::PI;
use std::sync::Arc;

use glam::{DMat3, DVec3, Vec2, Vec3};

use crate::bilinear::BilinearMesh;
use crate::bounds::Bounds3;
use crate::mesh::TriangleMesh;
use crate::ray::{gamma, Ray};
use crate::transform::Transform;
use crate::GeometryError;

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

// ---------------------------------------------------------------------------------------------------------------
// Triangles

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
    let mut dpdu = Vec3::ZERO;
    if det.abs() >= 1e-9 {
        let inv = 1.0 / det;
        dpdu = (duv12.y * dp02 - duv02.y * dp12) * inv;
        let dpdv = (duv02.x * dp12 - duv12.x * dp02) * inv;
        if dpdu.cross(dpdv).length_squared() == 0.0 || !dpdu.is_finite() {
            dpdu = Vec3::ZERO;
        }
    }
    if dpdu == Vec3::ZERO {
        dpdu = coordinate_system(if n == Vec3::ZERO { Vec3::Z } else { n }).0;
    }
    let mut ns = n;
    if let Some([n0, n1, n2]) = mesh.triangle_normals(tri) {
        if let Some(v) = (b[0] * n0 + b[1] * n1 + b[2] * n2).try_normalize() {
            ns = v;
            if n.dot(ns) < 0.0 {
                n = -n;
            }
        }
    }
    SurfaceGeom { p, p_error, n, ns, uv, dpdu }
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

// ---------------------------------------------------------------------------------------------------------------
// Analytic shapes: shared transform handling

/// Object-to-render transform of an analytic shape with cached pieces.
#[derive(Clone, Debug, PartialEq)]
struct Placement {
    render_from_object: Transform,
    linear: DMat3,
    normal_matrix: DMat3,
    abs_linear: glam::Mat3,
    abs_translation: Vec3,
    /// |det|^(1/3): the uniform scale of a similarity transform.
    scale: f64,
}

impl Placement {
    fn new(t: Transform, what: &str) -> Result<Self, GeometryError> {
        let m = t.matrix();
        let linear = DMat3::from_mat4(m);
        let det = linear.determinant();
        if !det.is_finite() || det == 0.0 || !m.is_finite() {
            return Err(GeometryError::InvalidShape(format!("{what}: singular or non-finite transform")));
        }
        let normal_matrix = DMat3::from_mat4(t.inverse_matrix()).transpose();
        let abs_linear = glam::Mat3::from_cols(
            linear.x_axis.abs().as_vec3(),
            linear.y_axis.abs().as_vec3(),
            linear.z_axis.abs().as_vec3(),
        );
        Ok(Self {
            render_from_object: t,
            linear,
            normal_matrix,
            abs_linear,
            abs_translation: m.w_axis.truncate().abs().as_vec3(),
            scale: det.abs().cbrt(),
        })
    }

    /// Object-space ray (f64), same `t` parametrization.
    fn ray_to_object(&self, ray: &Ray) -> (DVec3, DVec3) {
        let inv = self.render_from_object.inverse();
        (inv.point(ray.o.as_dvec3()), inv.vector(ray.d.as_dvec3()))
    }

    /// Render-space point, its error bound given an object-space error bound, unit normal, and dpdu.
    fn to_render(&self, p_obj: DVec3, p_err_obj: Vec3, n_obj: DVec3, dpdu_obj: DVec3) -> (Vec3, Vec3, Vec3, Vec3) {
        let p = self.render_from_object.point(p_obj).as_vec3();
        let pa = p_obj.abs().as_vec3();
        let p_error =
            (1.0 + gamma(3)) * (self.abs_linear * p_err_obj) + gamma(3) * (self.abs_linear * pa + self.abs_translation);
        let n = (self.normal_matrix * n_obj).normalize_or_zero().as_vec3();
        let dpdu = (self.linear * dpdu_obj).as_vec3();
        (p, p_error, n, dpdu)
    }

    fn bounds(&self, lo: DVec3, hi: DVec3) -> Bounds3 {
        let mut b = Bounds3::EMPTY;
        for i in 0..8 {
            let c = DVec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            );
            b = b.union_point(self.render_from_object.point(c).as_vec3());
        }
        // Grow by the rounding of the transform.
        let e = (b.max.abs().max(b.min.abs())) * gamma(4);
        Bounds3 { min: b.min - e, max: b.max + e }
    }
}

/// Azimuth of `p` in `[0, 2π)`.
fn phi_of(p: DVec3) -> f64 {
    let phi = p.y.atan2(p.x);
    if phi < 0.0 {
        phi + std::f64::consts::TAU
    } else {
        phi
    }
}

fn dpdu_or_frame(dpdu: DVec3, n_obj: DVec3) -> DVec3 {
    if dpdu.length_squared() > 0.0 {
        dpdu
    } else {
        coordinate_system(n_obj.as_vec3().normalize_or(Vec3::Z)).0.as_dvec3()
    }
}

// ---------------------------------------------------------------------------------------------------------------
// Sphere

/// A sphere of `radius` about the object-space origin (pbrt's `sphere`), optionally partial: only the part with
/// `z_min ≤ z ≤ z_max` and azimuth `0 ≤ φ ≤ φ_max` exists. Any transform is intersected exactly; sampling and area
/// assume a similarity transform (rotation, translation, uniform scale), as pbrt-v4 does.
#[derive(Clone, Debug, PartialEq)]
pub struct Sphere {
    radius: f64,
    z_min: f64,
    z_max: f64,
    /// Polar angles of `z_min` and `z_max` (θ = acos(z/r), so `theta_z_min ≥ theta_z_max`).
    theta_z_min: f64,
    theta_z_max: f64,
    phi_max: f64,
    place: Placement,
    reverse_orientation: bool,
    center: Vec3,
    render_radius: f32,
}

impl Sphere {
    /// A full sphere; errors unless `radius` is positive and finite and the transform invertible.
    pub fn new(radius: f32, render_from_object: Transform, reverse_orientation: bool) -> Result<Self, GeometryError> {
        Self::partial(radius, -radius, radius, 360.0, render_from_object, reverse_orientation)
    }

    /// A partial sphere (pbrt-v4's `zmin`, `zmax`, `phimax`): `z_min` and `z_max` are clamped to `[−radius,
    /// radius]` and must then satisfy `z_min < z_max`; `phi_max_deg` must be in `(0, 360]`. Errors name the
    /// offending parameter.
    pub fn partial(
        radius: f32,
        z_min: f32,
        z_max: f32,
        phi_max_deg: f32,
        render_from_object: Transform,
        reverse_orientation: bool,
    ) -> Result<Self, GeometryError> {
        if !(radius > 0.0 && radius.is_finite()) {
            return Err(GeometryError::InvalidShape(format!("sphere 'radius' must be positive, got {radius}")));
        }
        let r = radius as f64;
        let (zlo, zhi) = ((z_min as f64).clamp(-r, r), (z_max as f64).clamp(-r, r));
        if zlo.is_nan() || zhi.is_nan() || zlo >= zhi {
            return Err(GeometryError::InvalidShape(format!(
                "sphere 'zmin' ({z_min}) must be less than 'zmax' ({z_max}) after clamping both to [-radius, radius] \
                 (radius {radius})"
            )));
        }
        if !(phi_max_deg > 0.0 && phi_max_deg <= 360.0) {
            return Err(GeometryError::InvalidShape(format!("sphere 'phimax' must be in (0, 360], got {phi_max_deg}")));
        }
        let place = Placement::new(render_from_object, "sphere")?;
        let center = render_from_object.point(DVec3::ZERO).as_vec3();
        let render_radius = (r * place.scale) as f32;
        Ok(Self {
            radius: r,
            z_min: zlo,
            z_max: zhi,
            theta_z_min: (zlo / r).clamp(-1.0, 1.0).acos(),
            theta_z_max: (zhi / r).clamp(-1.0, 1.0).acos(),
            phi_max: (phi_max_deg as f64).clamp(0.0, 360.0).to_radians(),
            place,
            reverse_orientation,
            center,
            render_radius,
        })
    }

    /// Object-space radius.
    pub fn radius(&self) -> f32 {
        self.radius as f32
    }

    /// True for a whole sphere (no clipping by z range or φ).
    pub fn is_full(&self) -> bool {
        self.z_min <= -self.radius && self.z_max >= self.radius && self.phi_max >= std::f64::consts::TAU
    }

    /// Render-space centre.
    pub fn center(&self) -> Vec3 {
        self.center
    }

    /// Render-space radius (object radius times the transform's uniform scale).
    pub fn render_radius(&self) -> f32 {
        self.render_radius
    }

    /// The render-from-object transform.
    pub fn render_from_object(&self) -> &Transform {
        &self.place.render_from_object
    }

    /// Render-space bounds.
    pub fn bounds(&self) -> Bounds3 {
        let r = self.radius;
        self.place.bounds(DVec3::new(-r, -r, self.z_min), DVec3::new(r, r, self.z_max))
    }

    /// Surface area (render space): φmax·r·(zmax − zmin), the area of a spherical zone (Archimedes' hat-box
    /// theorem) cut to the wedge φ ≤ φmax; 4πr² for a full sphere.
    pub fn area(&self) -> f32 {
        let s2 = self.place.scale * self.place.scale;
        // Archimedes: a zone of height h on a sphere of radius r has area 2π·r·h; a wedge φmax/2π of it.
        (self.phi_max * self.radius * (self.z_max - self.z_min) * s2) as f32
    }

    /// True if the object-space point `p` on the sphere lies outside the partial sphere.
    fn clipped(&self, p: DVec3) -> bool {
        (self.z_min > -self.radius && p.z < self.z_min)
            || (self.z_max < self.radius && p.z > self.z_max)
            || (self.phi_max < std::f64::consts::TAU && phi_of(p) > self.phi_max)
    }

    /// Nearest hit `t` in `(0, t_max)` and the object-space hit point. For a partial sphere a root whose point is
    /// clipped away is skipped and the farther root tried.
    pub(crate) fn intersect_t(&self, ray: &Ray, t_max: f32) -> Option<(f32, DVec3)> {
        let (o, d) = self.place.ray_to_object(ray);
        let a = d.length_squared();
        if a == 0.0 {
            return None;
        }
        let hb = d.dot(o);
        let c = o.length_squared() - self.radius * self.radius;
        // Discriminant in the form of pbrt-v4 §6.8.5, accurate for distant spheres: a·(r² − |o − (hb/a)·d|²).
        let v = o - (hb / a) * d;
        let disc = a * (self.radius - v.length()) * (self.radius + v.length());
        if disc < 0.0 {
            return None;
        }
        let root = disc.sqrt();
        let q = if hb > 0.0 { -(hb + root) } else { -(hb - root) };
        if q == 0.0 {
            return None;
        }
        let (mut t0, mut t1) = (q / a, c / q);
        if t0 > t1 {
            std::mem::swap(&mut t0, &mut t1);
        }
        let t_max = t_max as f64;
        for t in [t0, t1] {
            if t <= 0.0 {
                continue;
            }
            if t >= t_max {
                return None;
            }
            let mut p = o + t * d;
            p *= self.radius / p.length();
            if self.clipped(p) {
                continue;
            }
            return Some((t as f32, p));
        }
        None
    }

    fn geom_at(&self, p: DVec3) -> SurfaceGeom {
        let phi = phi_of(p);
        let theta = (p.z / self.radius).clamp(-1.0, 1.0).acos();
        // pbrt-v4's sphere parametrization: u = φ/φmax, v = (θ − θ(zmin))/(θ(zmax) − θ(zmin)).
        let uv = Vec2::new(
            (phi / self.phi_max) as f32,
            ((theta - self.theta_z_min) / (self.theta_z_max - self.theta_z_min)) as f32,
        );
        let dpdu = dpdu_or_frame(self.phi_max * DVec3::new(-p.y, p.x, 0.0), p);
        let p_err_obj = gamma(5) * p.abs().as_vec3();
        let (pr, p_error, mut n, dpdu) = self.place.to_render(p, p_err_obj, p, dpdu);
        if self.reverse_orientation {
            n = -n;
        }
        SurfaceGeom { p: pr, p_error, n, ns: n, uv, dpdu }
    }

    pub(crate) fn geom(&self, p_obj: DVec3) -> SurfaceGeom {
        self.geom_at(p_obj)
    }

    /// A uniformly distributed point on the (partial) sphere (pdf per unit area = 1/area).
    pub fn sample_area(&self, u: Vec2) -> ShapeSample {
        let p = if self.is_full() {
            self.radius * sample_uniform_sphere(u).as_dvec3()
        } else {
            // Archimedes: z uniform in [zmin, zmax] and φ uniform in [0, φmax] is uniform by area on the zone.
            let z = self.z_min + u.x as f64 * (self.z_max - self.z_min);
            let phi = u.y as f64 * self.phi_max;
            let rho = (self.radius * self.radius - z * z).max(0.0).sqrt();
            DVec3::new(rho * phi.cos(), rho * phi.sin(), z)
        };
        let g = self.geom_at(p);
        ShapeSample { p: g.p, p_error: g.p_error, n: g.n, uv: g.uv, pdf: 1.0 / self.area() }
    }

    /// A point sampled by solid angle as seen from `ref_p`: for a full sphere seen from outside, uniform in the cone
    /// of directions it subtends (pdf = 1/(2π(1 − cos θmax)) per steradian); otherwise (inside, or a partial sphere)
    /// area sampling converted to solid angle. `None` if no valid sample.
    pub fn sample_solid_angle(&self, ref_p: Vec3, u: Vec2) -> Option<ShapeSample> {
        let pc = self.center;
        let r = self.render_radius;
        let dc2 = ref_p.distance_squared(pc);
        if !self.is_full() || dc2 <= r * r * (1.0 + 1e-4) {
            let ss = self.sample_area(u);
            return area_to_solid_angle(ref_p, ss);
        }
        let dc = dc2.sqrt();
        let sin2_max = r * r / dc2;
        let sin_max = sin2_max.sqrt();
        let cos_max = safe_sqrt(1.0 - sin2_max);
        let mut one_minus_cos_max = 1.0 - cos_max;
        let mut cos_t = (cos_max - 1.0) * u.x + 1.0;
        let mut sin2_t = 1.0 - cos_t * cos_t;
        if sin2_max < 0.000_685_23 {
            // Small cone: Taylor expansions keep precision (pbrt-v4).
            sin2_t = sin2_max * u.x;
            cos_t = (1.0 - sin2_t).sqrt();
            one_minus_cos_max = sin2_max / 2.0;
        }
        let cos_alpha = sin2_t / sin_max + cos_t * safe_sqrt(1.0 - sin2_t / sin2_max);
        let sin_alpha = safe_sqrt(1.0 - cos_alpha * cos_alpha);
        let phi = u.y * 2.0 * PI;
        let w = Vec3::new(sin_alpha * phi.cos(), sin_alpha * phi.sin(), cos_alpha);
        let z = (pc - ref_p) / dc;
        let (x, y) = coordinate_system(z);
        let n_out = -(w.x * x + w.y * y + w.z * z);
        let p = pc + r * n_out;
        // Geometry (uv, error) from the object-space point.
        let p_obj = self.place.render_from_object.inverse().point(p.as_dvec3());
        let p_obj = p_obj * (self.radius / p_obj.length());
        let g = self.geom_at(p_obj);
        Some(ShapeSample { p, p_error: g.p_error, n: g.n, uv: g.uv, pdf: 1.0 / (2.0 * PI * one_minus_cos_max) })
    }

    /// Solid-angle density of [`Sphere::sample_solid_angle`] for direction `wi` (unit) from `ref_p`; assumes `wi`
    /// hits the sphere when `ref_p` is outside a full sphere (a partial sphere is intersected: 0 on a miss).
    pub fn pdf_solid_angle(&self, ref_p: Vec3, wi: Vec3) -> f32 {
        let pc = self.center;
        let r = self.render_radius;
        let dc2 = ref_p.distance_squared(pc);
        if !self.is_full() || dc2 <= r * r * (1.0 + 1e-4) {
            let ray = Ray::new(ref_p, wi);
            return match self.intersect_t(&ray, f32::INFINITY) {
                Some((_, p)) => area_pdf_to_solid_angle(ref_p, &self.geom_at(p), 1.0 / self.area()),
                None => 0.0,
            };
        }
        let sin2_max = r * r / dc2;
        let cos_max = safe_sqrt(1.0 - sin2_max);
        let one_minus = if sin2_max < 0.000_685_23 { sin2_max / 2.0 } else { 1.0 - cos_max };
        1.0 / (2.0 * PI * one_minus)
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
// Disk

/// A disk (annulus) at object-space `z = height` between `inner_radius` and `radius`, facing +z, swept by `phi_max`
/// radians (pbrt's `disk`).
#[derive(Clone, Debug, PartialEq)]
pub struct Disk {
    height: f64,
    radius: f64,
    inner_radius: f64,
    phi_max: f64,
    place: Placement,
    reverse_orientation: bool,
}

impl Disk {
    /// A disk; errors unless `0 ≤ inner_radius < radius` are finite, `0 < phi_max_deg ≤ 360` and the transform is
    /// invertible.
    pub fn new(
        height: f32,
        radius: f32,
        inner_radius: f32,
        phi_max_deg: f32,
        render_from_object: Transform,
        reverse_orientation: bool,
    ) -> Result<Self, GeometryError> {
        if !(radius.is_finite() && inner_radius >= 0.0 && inner_radius < radius && height.is_finite()) {
            return Err(GeometryError::InvalidShape(format!(
                "disk needs 0 <= innerradius < radius, got innerradius {inner_radius}, radius {radius}"
            )));
        }
        if !(phi_max_deg > 0.0 && phi_max_deg <= 360.0) {
            return Err(GeometryError::InvalidShape(format!("disk phimax must be in (0, 360], got {phi_max_deg}")));
        }
        Ok(Self {
            height: height as f64,
            radius: radius as f64,
            inner_radius: inner_radius as f64,
            phi_max: (phi_max_deg as f64).to_radians(),
            place: Placement::new(render_from_object, "disk")?,
            reverse_orientation,
        })
    }

    /// Render-space bounds.
    pub fn bounds(&self) -> Bounds3 {
        let r = self.radius;
        self.place.bounds(DVec3::new(-r, -r, self.height), DVec3::new(r, r, self.height))
    }

    /// Surface area (render space; assumes a similarity transform).
    pub fn area(&self) -> f32 {
        let s2 = self.place.scale * self.place.scale;
        (0.5 * self.phi_max * (self.radius * self.radius - self.inner_radius * self.inner_radius) * s2) as f32
    }

    pub(crate) fn intersect_t(&self, ray: &Ray, t_max: f32) -> Option<(f32, DVec3)> {
        let (o, d) = self.place.ray_to_object(ray);
        if d.z == 0.0 {
            return None;
        }
        let t = (self.height - o.z) / d.z;
        if t <= 0.0 || t >= t_max as f64 {
            return None;
        }
        let p = o + t * d;
        let r2 = p.x * p.x + p.y * p.y;
        if r2 > self.radius * self.radius || r2 < self.inner_radius * self.inner_radius {
            return None;
        }
        if self.phi_max < std::f64::consts::TAU {
            let mut phi = p.y.atan2(p.x);
            if phi < 0.0 {
                phi += std::f64::consts::TAU;
            }
            if phi > self.phi_max {
                return None;
            }
        }
        Some((t as f32, DVec3::new(p.x, p.y, self.height)))
    }

    pub(crate) fn geom(&self, p: DVec3) -> SurfaceGeom {
        let mut phi = p.y.atan2(p.x);
        if phi < 0.0 {
            phi += std::f64::consts::TAU;
        }
        let r_hit = (p.x * p.x + p.y * p.y).sqrt();
        let uv =
            Vec2::new((phi / self.phi_max) as f32, ((self.radius - r_hit) / (self.radius - self.inner_radius)) as f32);
        let dpdu = dpdu_or_frame(self.phi_max * DVec3::new(-p.y, p.x, 0.0), DVec3::Z);
        let p_err_obj = Vec3::new(gamma(3) * p.x.abs() as f32, gamma(3) * p.y.abs() as f32, 0.0);
        let (pr, p_error, mut n, dpdu) = self.place.to_render(p, p_err_obj, DVec3::Z, dpdu);
        if self.reverse_orientation {
            n = -n;
        }
        SurfaceGeom { p: pr, p_error, n, ns: n, uv, dpdu }
    }

    /// A uniformly distributed point on the disk (pdf per unit area = 1/area).
    pub fn sample_area(&self, u: Vec2) -> ShapeSample {
        let ri2 = self.inner_radius * self.inner_radius;
        let r = (ri2 + u.x as f64 * (self.radius * self.radius - ri2)).sqrt();
        let phi = u.y as f64 * self.phi_max;
        let g = self.geom(DVec3::new(r * phi.cos(), r * phi.sin(), self.height));
        ShapeSample { p: g.p, p_error: g.p_error, n: g.n, uv: g.uv, pdf: 1.0 / self.area() }
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

impl Shape {
    /// Number of primitives (triangles or patches for a mesh, 1 otherwise).
    pub fn primitive_count(&self) -> usize {
        match self {
            Shape::Mesh(m) => m.triangle_count(),
            Shape::Bilinear(m) => m.patch_count(),
            Shape::Sphere(_) | Shape::Disk(_) => 1,
        }
    }

    /// Bounds of the whole shape.
    pub fn bounds(&self) -> Bounds3 {
        match self {
            Shape::Mesh(m) => m.bounds(),
            Shape::Bilinear(m) => m.bounds(),
            Shape::Sphere(s) => s.bounds(),
            Shape::Disk(d) => d.bounds(),
        }
    }

    /// Bounds of primitive `element`.
    pub fn element_bounds(&self, element: usize) -> Bounds3 {
        match self {
            Shape::Mesh(m) => Bounds3::from_points(m.triangle_positions(element)),
            Shape::Bilinear(m) => m.patch_bounds(element),
            _ => self.bounds(),
        }
    }

    /// Area of primitive `element` (a triangle, a patch, or the whole sphere or disk).
    pub fn area(&self, element: usize) -> f32 {
        match self {
            Shape::Mesh(m) => m.triangle_area(element),
            Shape::Bilinear(m) => m.patch_area(element),
            Shape::Sphere(s) => s.area(),
            Shape::Disk(d) => d.area(),
        }
    }

    /// A point on primitive `element` with its pdf per unit area: uniform (1/area) except on a non-planar
    /// bilinear patch (see [`BilinearMesh::sample_area`]). `None` for a degenerate triangle or patch point.
    pub fn sample_area(&self, element: usize, u: Vec2) -> Option<ShapeSample> {
        match self {
            Shape::Mesh(m) => sample_triangle_area(m, element, u),
            Shape::Bilinear(m) => m.sample_area(element, u),
            Shape::Sphere(s) => Some(s.sample_area(u)),
            Shape::Disk(d) => Some(d.sample_area(u)),
        }
    }

    /// A point on primitive `element` sampled with a density per steradian as seen from `ref_p`: cone sampling
    /// for full spheres seen from outside, area sampling converted to solid angle (pdf·dist²/|cos θ|) otherwise.
    pub fn sample_solid_angle(&self, element: usize, ref_p: Vec3, u: Vec2) -> Option<ShapeSample> {
        match self {
            Shape::Sphere(s) => s.sample_solid_angle(ref_p, u),
            _ => area_to_solid_angle(ref_p, self.sample_area(element, u)?),
        }
    }

    /// The density per steradian with which [`Shape::sample_solid_angle`] picks direction `wi` (unit) from
    /// `ref_p`; 0 if the ray misses the primitive.
    pub fn pdf_solid_angle(&self, element: usize, ref_p: Vec3, wi: Vec3) -> f32 {
        let ray = Ray::new(ref_p, wi);
        match self {
            Shape::Sphere(s) => s.pdf_solid_angle(ref_p, wi),
            Shape::Disk(d) => match d.intersect_t(&ray, f32::INFINITY) {
                Some((_, p)) => area_pdf_to_solid_angle(ref_p, &d.geom(p), 1.0 / d.area()),
                None => 0.0,
            },
            Shape::Bilinear(m) => match m.intersect(element, ref_p, wi, f32::INFINITY) {
                Some((_, uv)) => area_pdf_to_solid_angle(ref_p, &m.geom(element, uv), m.pdf_area(element, uv)),
                None => 0.0,
            },
            Shape::Mesh(m) => {
                let [p0, p1, p2] = m.triangle_positions(element);
                match intersect_triangle(&TriRay::new(ref_p, wi), p0, p1, p2, f32::INFINITY) {
                    Some((_, b)) => {
                        area_pdf_to_solid_angle(ref_p, &triangle_geom(m, element, b), 1.0 / m.triangle_area(element))
                    }
                    None => 0.0,
                }
            }
        }
    }

    /// Intersects primitive `element` alone: nearest `t` in `(0, t_max)`.
    pub fn intersect_t(&self, element: usize, ray: &Ray, t_max: f32) -> Option<f32> {
        match self {
            Shape::Mesh(m) => {
                let [p0, p1, p2] = m.triangle_positions(element);
                intersect_triangle(&TriRay::new(ray.o, ray.d), p0, p1, p2, t_max).map(|h| h.0)
            }
            Shape::Bilinear(m) => m.intersect(element, ray.o, ray.d, t_max).map(|h| h.0),
            Shape::Sphere(s) => s.intersect_t(ray, t_max).map(|h| h.0),
            Shape::Disk(d) => d.intersect_t(ray, t_max).map(|h| h.0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::MeshData;

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

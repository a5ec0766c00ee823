//! Spheres, full or partial (pbrt-v4's `sphere` with `zmin`, `zmax`, `phimax`), intersected in object space in f64,
//! sampled by area or by the cone of directions they subtend.

use std::f32::consts::PI;

use glam::{DVec3, Vec2, Vec3};

use super::placement::{dpdu_or_frame, phi_of, Placement};
use super::{
    area_pdf_to_solid_angle, area_to_solid_angle, coordinate_system, safe_sqrt, sample_uniform_sphere, ElementHit,
    PointSample, ShapeKind, ShapeRay, ShapeSample, SurfaceDerivatives, SurfaceGeom,
};
use crate::bounds::Bounds3;
use crate::error::GeometryError;
use crate::ray::{gamma, Ray};
use crate::transform::Transform;

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

    /// True if the normal points inwards (`ReverseOrientation`).
    pub fn reverse_orientation(&self) -> bool {
        self.reverse_orientation
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
        let (t0, t1, o, d) = self.roots(ray)?;
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

    /// True if the sphere is hit with `0 < t < t_max`: `intersect_t(ray, t_max).is_some()`, without computing the
    /// hit point when nothing is clipped away (a whole sphere), for shadow rays: a square root and a division fewer
    /// on the longest chain of dependent operations.
    pub(crate) fn occludes(&self, ray: &Ray, t_max: f32) -> bool {
        if !self.is_full() {
            return self.intersect_t(ray, t_max).is_some();
        }
        let Some((t0, t1, _, _)) = self.roots(ray) else {
            return false;
        };
        // The first root not ≤ 0 decides, as in `intersect_t` (no point is clipped), which also takes a NaN root
        // for a hit (it fails both of that loop's tests).
        let t = if t0 <= 0.0 { t1 } else { t0 };
        if t <= 0.0 {
            return false;
        }
        t < t_max as f64 || t.is_nan()
    }

    /// The two roots `t0 ≤ t1` of the ray's quadratic (object space) and the object-space ray, or `None` if there
    /// are none to test: the ray misses, its direction is zero, or the roots are degenerate (`q = 0`).
    #[inline]
    fn roots(&self, ray: &Ray) -> Option<(f64, f64, DVec3, DVec3)> {
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
        Some((t0, t1, o, d))
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
        let dpdv = self.dpdv_at(p);
        let p_err_obj = gamma(5) * p.abs().as_vec3();
        let (pr, p_error, mut n, dpdu) = self.place.to_render(p, p_err_obj, p, dpdu);
        let dpdv = self.place.vector(dpdv);
        if self.reverse_orientation {
            n = -n;
        }
        SurfaceGeom { p: pr, p_error, n, ns: n, uv, dpdu, dpdv, shading_dpdu: dpdu, shading_dpdv: dpdv }
    }

    /// pbrt-v4's ∂p/∂v = (θ(zmax) − θ(zmin))·(z cos φ, z sin φ, −r sin θ) at the object-space point `p` on the
    /// sphere, without trigonometry: cos φ = x/ρ, sin φ = y/ρ and r sin θ = ρ with ρ = √(x² + y²); at the poles
    /// (ρ = 0) φ is taken as 0, as `phi_of` does.
    fn dpdv_at(&self, p: DVec3) -> DVec3 {
        let rho = (p.x * p.x + p.y * p.y).sqrt();
        let (cos_phi, sin_phi) = if rho > 0.0 { (p.x / rho, p.y / rho) } else { (1.0, 0.0) };
        (self.theta_z_max - self.theta_z_min) * DVec3::new(p.z * cos_phi, p.z * sin_phi, -rho)
    }

    /// Derivatives in pbrt-v4's parametrization u = φ/φmax, v = (θ − θ(zmin))/(θ(zmax) − θ(zmin)) at the
    /// object-space point `p` (pbrt-v4 §6.2.2): ∂p/∂u = φmax·(−y, x, 0), ∂p/∂v = Δθ·(z cos φ, z sin φ, −r sin θ),
    /// and, the normal being p/r, ∂n/∂u = (∂p/∂u)/r, ∂n/∂v = (∂p/∂v)/r (negated with the normal when reversed).
    /// Degenerate (∂p/∂u = 0) at the poles.
    pub(crate) fn derivatives_at(&self, p: DVec3) -> SurfaceDerivatives {
        let r = self.radius;
        let dpdu = self.phi_max * DVec3::new(-p.y, p.x, 0.0);
        let dpdv = self.dpdv_at(p);
        let sign = if self.reverse_orientation { -1.0 } else { 1.0 };
        self.place.derivatives_to_render(p / r, dpdu, dpdv, sign * dpdu / r, sign * dpdv / r)
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
        match self.sample_cone(ref_p, u) {
            None => area_to_solid_angle(ref_p, self.sample_area(u)),
            Some((p, n_out, pdf)) => {
                // uv and the error bound from the same point in object space, projected onto the sphere.
                let p_obj = self.place.render_from_object.inverse().point(p.as_dvec3());
                let g = self.geom_at(p_obj * (self.radius / p_obj.length()));
                Some(ShapeSample { p, p_error: g.p_error, n: self.oriented(n_out), uv: g.uv, pdf })
            }
        }
    }

    /// [`Sphere::sample_solid_angle`]'s point, normal and density (bit for bit), without its uv and error bound.
    pub fn sample_solid_angle_point(&self, ref_p: Vec3, u: Vec2) -> Option<PointSample> {
        match self.sample_cone(ref_p, u) {
            None => area_to_solid_angle(ref_p, self.sample_area(u)).map(PointSample::from),
            Some((p, n_out, pdf)) => Some(PointSample { p, n: self.oriented(n_out), pdf }),
        }
    }

    /// The render-space outward normal `n_out` turned as the surface's normals are (`ReverseOrientation`).
    #[inline]
    fn oriented(&self, n_out: Vec3) -> Vec3 {
        if self.reverse_orientation {
            -n_out
        } else {
            n_out
        }
    }

    /// Cone sampling of a full sphere seen from outside (pbrt-v4 §6.2.4): the render-space point, the outward unit
    /// normal there, and the density per steradian; `None` for a partial sphere or a point inside, which sample by
    /// area. Under the similarity transform that sampling assumes, the normal is the direction from the centre that
    /// placed the point, so no transform back to object space is needed (it was a fifth of the sampling's time).
    #[inline]
    fn sample_cone(&self, ref_p: Vec3, u: Vec2) -> Option<(Vec3, Vec3, f32)> {
        let pc = self.center;
        let r = self.render_radius;
        let dc2 = ref_p.distance_squared(pc);
        if !self.is_full() || dc2 <= r * r * (1.0 + 1e-4) {
            return None;
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
        Some((p, n_out, 1.0 / (2.0 * PI * one_minus_cos_max)))
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

impl ShapeKind for Sphere {
    fn bounds(&self) -> Bounds3 {
        Sphere::bounds(self)
    }

    fn area(&self, _: usize) -> f32 {
        Sphere::area(self)
    }

    #[inline]
    fn intersect_element(&self, _: usize, ray: &ShapeRay, t_max: f32) -> Option<ElementHit> {
        self.intersect_t(&ray.ray, t_max).map(|(t, p)| ElementHit::at_point(t, p))
    }

    fn occludes_element(&self, _: usize, ray: &ShapeRay, t_max: f32) -> bool {
        self.occludes(&ray.ray, t_max)
    }

    fn surface_geom(&self, _: usize, hit: &ElementHit) -> SurfaceGeom {
        self.geom(hit.p_obj)
    }

    fn derivatives(&self, _: usize, hit: &ElementHit) -> Option<SurfaceDerivatives> {
        Some(self.derivatives_at(hit.p_obj))
    }

    fn sample_area(&self, _: usize, u: Vec2) -> Option<ShapeSample> {
        Some(Sphere::sample_area(self, u))
    }

    fn sample_solid_angle(&self, _: usize, ref_p: Vec3, u: Vec2) -> Option<ShapeSample> {
        Sphere::sample_solid_angle(self, ref_p, u)
    }

    fn sample_solid_angle_point(&self, _: usize, ref_p: Vec3, u: Vec2) -> Option<PointSample> {
        Sphere::sample_solid_angle_point(self, ref_p, u)
    }

    fn pdf_solid_angle(&self, _: usize, ref_p: Vec3, wi: Vec3) -> f32 {
        Sphere::pdf_solid_angle(self, ref_p, wi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transform::Transform;

    #[test]
    fn cone_samples_carry_the_normal_the_surface_has_there() {
        // A rotated, scaled, moved sphere, both orientations: the sampled normal is the one the surface's own
        // geometry gives at the sampled point (object-space point through the normal matrix), to rounding.
        let placed = Transform::translate(DVec3::new(0.3, -0.2, 4.0))
            * Transform::rotate(30.0, DVec3::new(1.0, 1.0, 0.0)).unwrap()
            * Transform::scale(DVec3::new(1.5, 1.5, 1.5)).unwrap();
        let mut next = crate::test_floats(4242);
        let mut checked = 0;
        for reverse in [false, true] {
            let s = Sphere::new(0.7, placed, reverse).unwrap();
            for ref_p in [Vec3::new(0.1, 0.2, -3.0), Vec3::new(5.0, 1.0, 4.0), Vec3::new(0.3, 30.0, 4.2)] {
                for _ in 0..500 {
                    let u = Vec2::new(next(), next());
                    let Some(ps) = s.sample_solid_angle_point(ref_p, u) else { panic!("no sample from {ref_p}") };
                    let p_obj = s.place.render_from_object.inverse().point(ps.p.as_dvec3());
                    let want = s.geom_at(p_obj * (s.radius / p_obj.length())).n;
                    assert!((ps.n - want).length() < 2e-6, "{} against {want} (reverse {reverse})", ps.n);
                    assert!((ps.n.length() - 1.0).abs() < 1e-6);
                    checked += 1;
                }
            }
        }
        assert_eq!(checked, 3000);
    }

    #[test]
    fn occlusion_answers_as_the_closest_hit_test_does() {
        // Shadow-ray-like segments (from outside and inside, ending before, on and past the surface) against a
        // whole sphere, which takes the short path, and a partial one, which does not.
        let placed = Transform::translate(DVec3::new(0.3, -0.2, 4.0)) * Transform::scale(DVec3::splat(1.5)).unwrap();
        let mut next = crate::test_floats(777);
        for s in
            [Sphere::new(0.7, placed, false).unwrap(), Sphere::partial(0.7, -0.3, 0.5, 270.0, placed, false).unwrap()]
        {
            let (mut hits, mut misses) = (0, 0);
            for _ in 0..4000 {
                let o = Vec3::new(0.3, -0.2, 4.0) + 3.0 * Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5);
                let target = Vec3::new(0.3, -0.2, 4.0) + 1.2 * Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5);
                let ray = Ray { o, d: target - o, time: 0.0 };
                for t_max in [0.5, 0.999, 1.0, 1.001, 2.0, f32::INFINITY] {
                    let want = s.intersect_t(&ray, t_max).is_some();
                    assert_eq!(s.occludes(&ray, t_max), want, "ray {ray:?}, t_max {t_max}");
                    if want {
                        hits += 1;
                    } else {
                        misses += 1;
                    }
                }
            }
            assert!(hits > 3000 && misses > 3000, "{hits} hits, {misses} misses");
        }
    }
}

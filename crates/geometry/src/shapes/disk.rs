//! Disks and annuli (pbrt-v4's `disk`), intersected in object space in f64 and sampled uniformly by area.

use glam::{DVec3, Vec2, Vec3};

use super::placement::{dpdu_or_frame, Placement};
use super::{ElementHit, ShapeKind, ShapeRay, ShapeSample, SurfaceGeom};
use crate::bounds::Bounds3;
use crate::error::GeometryError;
use crate::ray::{gamma, Ray};
use crate::transform::Transform;

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
        // pbrt-v4's disk: ∂p/∂v = (x, y, 0)·(r_inner − r)/r_hit, along the radius inwards (v grows inwards).
        let dpdv = if r_hit > 0.0 {
            DVec3::new(p.x, p.y, 0.0) * ((self.inner_radius - self.radius) / r_hit)
        } else {
            DVec3::Z.cross(dpdu)
        };
        let p_err_obj = Vec3::new(gamma(3) * p.x.abs() as f32, gamma(3) * p.y.abs() as f32, 0.0);
        let (pr, p_error, mut n, dpdu) = self.place.to_render(p, p_err_obj, DVec3::Z, dpdu);
        let dpdv = self.place.vector(dpdv);
        if self.reverse_orientation {
            n = -n;
        }
        SurfaceGeom { p: pr, p_error, n, ns: n, uv, dpdu, dpdv, shading_dpdu: dpdu, shading_dpdv: dpdv }
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

impl ShapeKind for Disk {
    fn bounds(&self) -> Bounds3 {
        Disk::bounds(self)
    }

    fn area(&self, _: usize) -> f32 {
        Disk::area(self)
    }

    #[inline]
    fn intersect_element(&self, _: usize, ray: &ShapeRay, t_max: f32) -> Option<ElementHit> {
        self.intersect_t(&ray.ray, t_max).map(|(t, p)| ElementHit::at_point(t, p))
    }

    fn surface_geom(&self, _: usize, hit: &ElementHit) -> SurfaceGeom {
        self.geom(hit.p_obj)
    }

    fn sample_area(&self, _: usize, u: Vec2) -> Option<ShapeSample> {
        Some(Disk::sample_area(self, u))
    }
}

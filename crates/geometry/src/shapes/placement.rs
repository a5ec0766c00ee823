//! What the analytic shapes (spheres, disks) share: their object-to-render placement and azimuth helpers.

use glam::{DMat3, DVec3, Vec3};

use super::coordinate_system;
use crate::bounds::Bounds3;
use crate::error::GeometryError;
use crate::ray::{gamma, Ray};
use crate::transform::Transform;

/// Object-to-render transform of an analytic shape with cached pieces.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Placement {
    pub(super) render_from_object: Transform,
    linear: DMat3,
    normal_matrix: DMat3,
    abs_linear: glam::Mat3,
    abs_translation: Vec3,
    /// |det|^(1/3): the uniform scale of a similarity transform.
    pub(super) scale: f64,
}

impl Placement {
    pub(super) fn new(t: Transform, what: &str) -> Result<Self, GeometryError> {
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
    #[inline]
    pub(super) fn ray_to_object(&self, ray: &Ray) -> (DVec3, DVec3) {
        let inv = self.render_from_object.inverse();
        (inv.point(ray.o.as_dvec3()), inv.vector(ray.d.as_dvec3()))
    }

    /// Render-space point, its error bound given an object-space error bound, unit normal, and dpdu.
    pub(super) fn to_render(
        &self,
        p_obj: DVec3,
        p_err_obj: Vec3,
        n_obj: DVec3,
        dpdu_obj: DVec3,
    ) -> (Vec3, Vec3, Vec3, Vec3) {
        let p = self.render_from_object.point(p_obj).as_vec3();
        let pa = p_obj.abs().as_vec3();
        let p_error =
            (1.0 + gamma(3)) * (self.abs_linear * p_err_obj) + gamma(3) * (self.abs_linear * pa + self.abs_translation);
        let n = self.normal(n_obj);
        let dpdu = (self.linear * dpdu_obj).as_vec3();
        (p, p_error, n, dpdu)
    }

    /// The unit render-space normal of object-space normal `n_obj` (as [`Placement::to_render`] gives it).
    #[inline]
    pub(super) fn normal(&self, n_obj: DVec3) -> Vec3 {
        (self.normal_matrix * n_obj).normalize_or_zero().as_vec3()
    }

    /// A vector (such as ∂p/∂v) from object to render space.
    pub(super) fn vector(&self, v_obj: DVec3) -> Vec3 {
        (self.linear * v_obj).as_vec3()
    }

    /// Render-space derivatives from object-space ones at a point whose object-space unit normal is `n_obj`:
    /// tangents by the linear part, the normal's by the normal matrix followed by normalization.
    pub(super) fn derivatives_to_render(
        &self,
        n_obj: DVec3,
        dpdu: DVec3,
        dpdv: DVec3,
        dndu: DVec3,
        dndv: DVec3,
    ) -> super::SurfaceDerivatives {
        let m = self.normal_matrix;
        let nm = m * n_obj;
        let len = nm.length();
        let nh = if len > 0.0 { nm / len } else { DVec3::ZERO };
        let dn = |d: DVec3| {
            let x = m * d;
            if len > 0.0 {
                ((x - nh * nh.dot(x)) / len).as_vec3()
            } else {
                Vec3::ZERO
            }
        };
        super::SurfaceDerivatives {
            dpdu: (self.linear * dpdu).as_vec3(),
            dpdv: (self.linear * dpdv).as_vec3(),
            dndu: dn(dndu),
            dndv: dn(dndv),
        }
    }

    pub(super) fn bounds(&self, lo: DVec3, hi: DVec3) -> Bounds3 {
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
pub(crate) fn phi_of(p: DVec3) -> f64 {
    let phi = p.y.atan2(p.x);
    if phi < 0.0 {
        phi + std::f64::consts::TAU
    } else {
        phi
    }
}

pub(super) fn dpdu_or_frame(dpdu: DVec3, n_obj: DVec3) -> DVec3 {
    if dpdu.length_squared() > 0.0 {
        dpdu
    } else {
        coordinate_system(n_obj.as_vec3().normalize_or(Vec3::Z)).0.as_dvec3()
    }
}

//! Affine and projective transforms with their inverses, in f64 (scene descriptions chain many of them).

use glam::{DMat3, DMat4, DVec3, DVec4};

/// A 4×4 transform and its inverse. Points are column vectors: `p' = M·p`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    m: DMat4,
    m_inv: DMat4,
}

impl Default for Transform {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Transform {
    /// The identity.
    pub const IDENTITY: Transform = Transform { m: DMat4::IDENTITY, m_inv: DMat4::IDENTITY };

    /// From a matrix; `None` if it is singular or not finite.
    pub fn from_matrix(m: DMat4) -> Option<Self> {
        let det = m.determinant();
        if !det.is_finite() || det.abs() < 1e-300 {
            return None;
        }
        let m_inv = m.inverse();
        m_inv.is_finite().then_some(Self { m, m_inv })
    }

    /// From a matrix that may be singular, as pbrt-v4 accepts (`Scale 1 1 0`, a `ConcatTransform` with an axis
    /// scaled to zero). A singular matrix gets an inverse of NaNs, as in pbrt-v4's `Transform`, so everything that
    /// needs the inverse (normals, rays into object space) is undefined and [`Transform::is_invertible`] is false;
    /// composing with it keeps the NaNs. `None` if the matrix is not finite.
    pub fn from_matrix_allow_singular(m: DMat4) -> Option<Self> {
        if !m.is_finite() {
            return None;
        }
        Some(Self::from_matrix(m).unwrap_or(Self { m, m_inv: DMat4::NAN }))
    }

    /// False for a transform made from a singular matrix ([`Transform::from_matrix_allow_singular`]) or composed
    /// with one: it maps points and vectors, but has no inverse.
    pub fn is_invertible(&self) -> bool {
        self.m_inv.is_finite()
    }

    /// From a matrix and its known inverse.
    pub fn from_matrix_and_inverse(m: DMat4, m_inv: DMat4) -> Self {
        Self { m, m_inv }
    }

    /// From 16 numbers in pbrt's order (`Transform` / `ConcatTransform`: column-major, i.e. the matrix is the
    /// transpose of the row-by-row reading); `None` if singular.
    pub fn from_pbrt_array(v: &[f64; 16]) -> Option<Self> {
        Self::from_matrix(DMat4::from_cols_array(v))
    }

    /// The matrix.
    pub fn matrix(&self) -> DMat4 {
        self.m
    }

    /// The inverse matrix.
    pub fn inverse_matrix(&self) -> DMat4 {
        self.m_inv
    }

    /// The inverse transform.
    pub fn inverse(&self) -> Self {
        Self { m: self.m_inv, m_inv: self.m }
    }

    /// Translation by `d`.
    pub fn translate(d: DVec3) -> Self {
        Self { m: DMat4::from_translation(d), m_inv: DMat4::from_translation(-d) }
    }

    /// Scale by `s` per axis; `None` if any factor is zero.
    pub fn scale(s: DVec3) -> Option<Self> {
        if s.x == 0.0 || s.y == 0.0 || s.z == 0.0 || !s.is_finite() {
            return None;
        }
        Some(Self { m: DMat4::from_scale(s), m_inv: DMat4::from_scale(1.0 / s) })
    }

    /// Rotation by `degrees` about `axis` (right-handed, as pbrt's `Rotate`); `None` for a zero axis.
    pub fn rotate(degrees: f64, axis: DVec3) -> Option<Self> {
        let a = axis.try_normalize()?;
        let r = DMat4::from_axis_angle(a, degrees.to_radians());
        Some(Self { m: r, m_inv: r.transpose() })
    }

    /// pbrt's `LookAt`: the camera-from-world transform of a camera at `eye` looking down +z towards `look`, with
    /// `up` projected to +y. `None` if `up` is parallel to the viewing direction or `eye == look`.
    pub fn look_at(eye: DVec3, look: DVec3, up: DVec3) -> Option<Self> {
        let dir = (look - eye).try_normalize()?;
        let right = up.try_normalize()?.cross(dir).try_normalize()?;
        let new_up = dir.cross(right);
        // Columns of world-from-camera: right, up, dir, eye (pbrt-v4 LookAt, left-handed camera space).
        let world_from_camera = DMat4::from_cols(
            right.extend(0.0),
            new_up.extend(0.0),
            dir.extend(0.0),
            DVec4::new(eye.x, eye.y, eye.z, 1.0),
        );
        let camera_from_world = world_from_camera.inverse();
        Some(Self { m: camera_from_world, m_inv: world_from_camera })
    }

    /// Perspective projection with field of view `fov_deg` and clipping planes `near`, `far` (pbrt's
    /// `Perspective`): maps camera space to \[-1,1\]² × \[0,1\] in x, y and depth before the screen-window scaling.
    pub fn perspective(fov_deg: f64, near: f64, far: f64) -> Option<Self> {
        let persp = DMat4::from_cols(
            DVec4::new(1.0, 0.0, 0.0, 0.0),
            DVec4::new(0.0, 1.0, 0.0, 0.0),
            DVec4::new(0.0, 0.0, far / (far - near), 1.0),
            DVec4::new(0.0, 0.0, -far * near / (far - near), 0.0),
        );
        let inv_tan = 1.0 / (fov_deg.to_radians() / 2.0).tan();
        let s = Self::scale(DVec3::new(inv_tan, inv_tan, 1.0))?;
        Self::from_matrix(s.m * persp)
    }

    /// `self ∘ other`: apply `other` first, then `self`.
    pub fn then_after(&self, other: &Transform) -> Transform {
        Transform { m: self.m * other.m, m_inv: other.m_inv * self.m_inv }
    }

    /// Applies to a point (with the homogeneous divide).
    pub fn point(&self, p: DVec3) -> DVec3 {
        let r = self.m * p.extend(1.0);
        if r.w == 1.0 || r.w == 0.0 {
            r.truncate()
        } else {
            r.truncate() / r.w
        }
    }

    /// Applies to a direction (ignores translation).
    pub fn vector(&self, v: DVec3) -> DVec3 {
        DMat3::from_mat4(self.m) * v
    }

    /// Applies to a surface normal (by the inverse transpose, so normals stay perpendicular to surfaces).
    pub fn normal(&self, n: DVec3) -> DVec3 {
        DMat3::from_mat4(self.m_inv).transpose() * n
    }

    /// True if the transform flips handedness (negative determinant of the linear part).
    pub fn swaps_handedness(&self) -> bool {
        DMat3::from_mat4(self.m).determinant() < 0.0
    }

    /// True for the identity.
    pub fn is_identity(&self) -> bool {
        self.m == DMat4::IDENTITY
    }
}

impl std::ops::Mul for Transform {
    type Output = Transform;
    /// `a * b` applies `b` first, then `a` (matrix product).
    fn mul(self, rhs: Transform) -> Transform {
        self.then_after(&rhs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: DVec3, b: DVec3) -> bool {
        (a - b).length() < 1e-9
    }

    #[test]
    fn composition_and_inverse() {
        let t = Transform::translate(DVec3::new(1.0, 2.0, 3.0));
        let r = Transform::rotate(90.0, DVec3::Z).unwrap();
        let s = Transform::scale(DVec3::new(2.0, 2.0, 2.0)).unwrap();
        let m = t * r * s; // scale, then rotate, then translate
        let p = DVec3::new(1.0, 0.0, 0.0);
        assert!(close(m.point(p), DVec3::new(1.0, 4.0, 3.0)));
        assert!(close(m.inverse().point(m.point(p)), p));
        assert!(!m.swaps_handedness());
        assert!(Transform::scale(DVec3::new(-1.0, 1.0, 1.0)).unwrap().swaps_handedness());
        assert!(Transform::scale(DVec3::new(0.0, 1.0, 1.0)).is_none());
        assert!(Transform::rotate(10.0, DVec3::ZERO).is_none());
    }

    #[test]
    fn normals_stay_perpendicular_under_non_uniform_scale() {
        let s = Transform::scale(DVec3::new(1.0, 4.0, 1.0)).unwrap();
        let (tangent, normal) = (DVec3::new(1.0, -1.0, 0.0), DVec3::new(1.0, 1.0, 0.0));
        assert!(s.vector(tangent).dot(s.normal(normal)).abs() < 1e-12);
    }

    #[test]
    fn look_at_puts_the_target_on_plus_z() {
        let eye = DVec3::new(0.0, 0.0, -5.0);
        let cam = Transform::look_at(eye, DVec3::ZERO, DVec3::Y).unwrap();
        assert!(close(cam.point(DVec3::ZERO), DVec3::new(0.0, 0.0, 5.0)));
        assert!(close(cam.point(DVec3::new(0.0, 1.0, 0.0)), DVec3::new(0.0, 1.0, 5.0)));
        // pbrt's camera space is left-handed: x = up × dir, so world +x (seen from −z) lands on camera +x.
        assert!(cam.point(DVec3::new(1.0, 0.0, 0.0)).x > 0.0);
        assert!(Transform::look_at(eye, eye, DVec3::Y).is_none());
        assert!(Transform::look_at(eye, DVec3::ZERO, DVec3::Z).is_none());
    }

    #[test]
    fn singular_matrices_map_points_but_have_no_inverse() {
        let flat = Transform::from_matrix_allow_singular(DMat4::from_scale(DVec3::new(2.0, 1.0, 0.0))).unwrap();
        assert!(!flat.is_invertible());
        assert!(close(flat.point(DVec3::new(1.0, 2.0, 3.0)), DVec3::new(2.0, 2.0, 0.0)));
        // Composition keeps it singular on either side, as pbrt-v4's NaN inverse does.
        let t = Transform::translate(DVec3::new(0.0, 0.0, 5.0));
        assert!(!(t * flat).is_invertible() && !(flat * t).is_invertible());
        assert!(close((t * flat).point(DVec3::new(1.0, 1.0, 1.0)), DVec3::new(2.0, 1.0, 5.0)));
        assert!(flat.normal(DVec3::Z).is_nan());
        // Invertible matrices are unchanged by the permissive constructor; non-finite ones are refused.
        let r = Transform::from_matrix_allow_singular(t.matrix()).unwrap();
        assert!(r.is_invertible() && r.inverse_matrix() == t.inverse_matrix());
        assert!(Transform::from_matrix_allow_singular(DMat4::from_scale(DVec3::new(f64::INFINITY, 1.0, 1.0))).is_none());
    }

    #[test]
    fn pbrt_array_order_is_column_major() {
        let v = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 5.0, 6.0, 7.0, 1.0];
        let t = Transform::from_pbrt_array(&v).unwrap();
        assert!(close(t.point(DVec3::ZERO), DVec3::new(5.0, 6.0, 7.0)));
    }
}

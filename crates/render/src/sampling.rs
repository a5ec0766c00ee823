//! Warping uniform samples to directions and points, and the MIS heuristics.

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_2, FRAC_PI_4, PI};

/// Concentric mapping of the unit square to the unit disk (Shirley & Chiu 1997).
pub fn sample_uniform_disk_concentric(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) =
        if o.x.abs() > o.y.abs() { (o.x, FRAC_PI_4 * (o.y / o.x)) } else { (o.y, FRAC_PI_2 - FRAC_PI_4 * (o.x / o.y)) };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// Cosine-weighted hemisphere around +z (Malley's method); pdf = cos θ / π.
pub fn sample_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = sample_uniform_disk_concentric(u);
    let z = (1.0 - d.x * d.x - d.y * d.y).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Density of [`sample_cosine_hemisphere`].
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) * FRAC_1_PI
}

/// Uniform direction on the unit sphere; pdf = 1/(4π).
pub fn sample_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Power heuristic with β = 2 (Veach 1997, §9.2.4) for one sample from each of two strategies.
pub fn power_heuristic(pdf_f: f32, pdf_g: f32) -> f32 {
    let (f, g) = (pdf_f * pdf_f, pdf_g * pdf_g);
    if f.is_infinite() {
        return 1.0;
    }
    if f + g == 0.0 {
        0.0
    } else {
        f / (f + g)
    }
}

/// An orthonormal frame whose z axis is a given unit vector (Duff et al. 2017, branchless ONB).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// First tangent.
    pub x: Vec3,
    /// Second tangent.
    pub y: Vec3,
    /// The normal.
    pub z: Vec3,
}

impl Frame {
    /// Frame around unit vector `n`.
    pub fn from_z(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let x = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let y = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Self { x, y, z: n }
    }

    /// Frame around unit `n` with the first tangent along `t` projected onto the plane (Gram–Schmidt).
    pub fn from_z_and_tangent(n: Vec3, t: Vec3) -> Self {
        let x = (t - n * n.dot(t)).try_normalize();
        match x {
            Some(x) => Self { x, y: n.cross(x), z: n },
            None => Self::from_z(n),
        }
    }

    /// World → local.
    // Named as pbrt-v4's Frame::ToLocal and FromLocal, which the integrators' comments follow.
    #[allow(clippy::wrong_self_convention)]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.x), v.dot(self.y), v.dot(self.z))
    }

    /// Local → world.
    #[allow(clippy::wrong_self_convention)]
    pub fn from_local(&self, v: Vec3) -> Vec3 {
        self.x * v.x + self.y * v.y + self.z * v.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_are_orthonormal() {
        for n in [Vec3::Z, -Vec3::Z, Vec3::X, Vec3::new(0.3, -0.5, 0.81).normalize(), Vec3::new(0.0, -1e-7, -1.0)] {
            let n = n.normalize();
            let f = Frame::from_z(n);
            assert!(f.x.dot(f.y).abs() < 1e-5 && f.x.dot(n).abs() < 1e-5 && f.y.dot(n).abs() < 1e-5);
            assert!((f.x.length() - 1.0).abs() < 1e-5 && (f.y.length() - 1.0).abs() < 1e-5);
            let v = Vec3::new(0.2, 0.3, 0.9);
            assert!((f.from_local(f.to_local(v)) - v).length() < 1e-5);
        }
    }

    #[test]
    fn cosine_hemisphere_is_normalised_and_above_the_plane() {
        let n = 64;
        let mut sum_cos = 0.0;
        for i in 0..n {
            for j in 0..n {
                let d = sample_cosine_hemisphere(Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32));
                assert!(d.z >= 0.0 && (d.length() - 1.0).abs() < 1e-5);
                sum_cos += d.z;
            }
        }
        // E[cos θ] under pdf cos θ/π is 2/3.
        assert!((sum_cos / (n * n) as f32 - 2.0 / 3.0).abs() < 2e-3);
    }

    #[test]
    fn power_heuristic_limits() {
        assert_eq!(power_heuristic(1.0, 0.0), 1.0);
        assert_eq!(power_heuristic(0.0, 0.0), 0.0);
        assert_eq!(power_heuristic(f32::INFINITY, 1.0), 1.0);
        assert!((power_heuristic(1.0, 1.0) - 0.5).abs() < 1e-7);
    }
}

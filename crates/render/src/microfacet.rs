//! The Trowbridge–Reitz (GGX) microfacet distribution with visible-normal sampling.
//!
//! Formulas from Walter et al. 2007 (D, Λ, G) and Heitz 2018, "Sampling the GGX Distribution of Visible Normals";
//! pbrt-v4 §9.6 is the reference for the anisotropic form used here. Directions are in the local shading frame
//! (z = normal).

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Anisotropic Trowbridge–Reitz distribution with roughness α along x and y.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrowbridgeReitz {
    alpha_x: f32,
    alpha_y: f32,
}

fn cos2_theta(w: Vec3) -> f32 {
    w.z * w.z
}
fn sin2_theta(w: Vec3) -> f32 {
    (1.0 - cos2_theta(w)).max(0.0)
}
fn tan2_theta(w: Vec3) -> f32 {
    sin2_theta(w) / cos2_theta(w)
}
fn cos_phi(w: Vec3) -> f32 {
    let s = sin2_theta(w).sqrt();
    if s == 0.0 {
        1.0
    } else {
        (w.x / s).clamp(-1.0, 1.0)
    }
}
fn sin_phi(w: Vec3) -> f32 {
    let s = sin2_theta(w).sqrt();
    if s == 0.0 {
        0.0
    } else {
        (w.y / s).clamp(-1.0, 1.0)
    }
}

impl TrowbridgeReitz {
    /// α along the shading frame's y axis.
    pub fn alpha_y(&self) -> f32 {
        self.alpha_y
    }

    /// A distribution with the given α values (clamped below at 1e-4 when not smooth, as pbrt-v4 does).
    pub fn new(alpha_x: f32, alpha_y: f32) -> Self {
        let mut d = Self { alpha_x, alpha_y };
        if !d.effectively_smooth() {
            d.alpha_x = d.alpha_x.max(1e-4);
            d.alpha_y = d.alpha_y.max(1e-4);
        }
        d
    }

    /// The distribution with near-specular roughness widened (pbrt-v4's `TrowbridgeReitzDistribution::Regularize`
    /// for `"bool regularize"`): each α below 0.3 becomes clamp(2α, 0.1, 0.3), so that paths after a diffuse
    /// bounce can find small lights through glass and mirrors, at the price of bias (Kaplanyan & Dachsbacher 2013).
    pub fn regularized(self) -> Self {
        let widen = |a: f32| if a < 0.3 { (2.0 * a).clamp(0.1, 0.3) } else { a };
        Self { alpha_x: widen(self.alpha_x), alpha_y: widen(self.alpha_y) }
    }

    /// pbrt's perceptual roughness remapping: α = √roughness.
    pub fn roughness_to_alpha(roughness: f32) -> f32 {
        roughness.max(0.0).sqrt()
    }

    /// True when the surface is so smooth it should be treated as a perfect specular interface.
    pub fn effectively_smooth(&self) -> bool {
        self.alpha_x.max(self.alpha_y) < 1e-3
    }

    /// The normal distribution D(ωm).
    pub fn d(&self, wm: Vec3) -> f32 {
        let t2 = tan2_theta(wm);
        if t2.is_infinite() {
            return 0.0;
        }
        let cos4 = cos2_theta(wm) * cos2_theta(wm);
        if cos4 < 1e-16 {
            return 0.0;
        }
        let (cp, sp) = (cos_phi(wm), sin_phi(wm));
        let e = t2 * (cp * cp / (self.alpha_x * self.alpha_x) + sp * sp / (self.alpha_y * self.alpha_y));
        1.0 / (PI * self.alpha_x * self.alpha_y * cos4 * (1.0 + e) * (1.0 + e))
    }

    /// Smith's auxiliary function Λ(ω).
    pub fn lambda(&self, w: Vec3) -> f32 {
        let t2 = tan2_theta(w);
        if t2.is_infinite() {
            return 0.0;
        }
        let (cp, sp) = (cos_phi(w), sin_phi(w));
        let alpha2 = cp * cp * self.alpha_x * self.alpha_x + sp * sp * self.alpha_y * self.alpha_y;
        ((1.0 + alpha2 * t2).sqrt() - 1.0) / 2.0
    }

    /// Masking G₁(ω) = 1/(1 + Λ(ω)).
    pub fn g1(&self, w: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// Height-correlated masking-shadowing G(ωo, ωi) = 1/(1 + Λ(ωo) + Λ(ωi)).
    pub fn g(&self, wo: Vec3, wi: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }

    /// Distribution of visible normals D_ω(ωm) = G₁(ω)/|cos θ| · D(ωm) · |ω·ωm|.
    pub fn d_visible(&self, w: Vec3, wm: Vec3) -> f32 {
        let c = w.z.abs();
        if c == 0.0 {
            return 0.0;
        }
        self.g1(w) / c * self.d(wm) * w.dot(wm).abs()
    }

    /// The density of [`TrowbridgeReitz::sample_wm`].
    pub fn pdf(&self, w: Vec3, wm: Vec3) -> f32 {
        self.d_visible(w, wm)
    }

    /// Samples a visible normal as seen from `w` (Heitz 2018).
    pub fn sample_wm(&self, w: Vec3, u: Vec2) -> Vec3 {
        // Transform to the hemispherical configuration.
        let mut wh = Vec3::new(self.alpha_x * w.x, self.alpha_y * w.y, w.z).normalize();
        if wh.z < 0.0 {
            wh = -wh;
        }
        let t1 = if wh.z < 0.99999 { Vec3::Z.cross(wh).normalize() } else { Vec3::X };
        let t2 = wh.cross(t1);
        // Uniform disk point, warped to the projected visible hemisphere.
        let r = u.x.sqrt();
        let phi = 2.0 * PI * u.y;
        let mut p = Vec2::new(r * phi.cos(), r * phi.sin());
        let h = (1.0 - p.x * p.x).max(0.0).sqrt();
        let s = (1.0 + wh.z) / 2.0;
        p.y = (1.0 - s) * h + s * p.y;
        let pz = (1.0 - p.length_squared()).max(0.0).sqrt();
        let nh = p.x * t1 + p.y * t2 + pz * wh;
        Vec3::new(self.alpha_x * nh.x, self.alpha_y * nh.y, nh.z.max(1e-6)).normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Midpoint quadrature of `f(ω)` over the upper hemisphere on an n×n grid in (cos θ, φ), where dω = d(cos θ) dφ.
    fn integrate_hemisphere(n: usize, f: impl Fn(Vec3, f64) -> f64) -> f64 {
        let mut sum = 0.0f64;
        for i in 0..n {
            for j in 0..n {
                let ct = (i as f64 + 0.5) / n as f64;
                let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / n as f64;
                let st = (1.0 - ct * ct).sqrt();
                let w = Vec3::new((st * phi.cos()) as f32, (st * phi.sin()) as f32, ct as f32);
                sum += f(w, ct);
            }
        }
        sum * 2.0 * std::f64::consts::PI / (n * n) as f64
    }

    #[test]
    fn d_is_normalised_over_projected_area() {
        // ∫ D(ωm) cos θm dωm = 1 over the hemisphere.
        for (ax, ay) in [(0.3, 0.3), (0.1, 0.5), (0.8, 0.8)] {
            let d = TrowbridgeReitz::new(ax, ay);
            let sum = integrate_hemisphere(800, |wm, ct| d.d(wm) as f64 * ct);
            assert!((sum - 1.0).abs() < 5e-3, "α = ({ax}, {ay}): {sum}");
        }
    }

    #[test]
    fn visible_normal_pdf_is_normalised() {
        // ∫ G₁(ω)/cos θ · D(ωm) · max(0, ω·ωm) dωm = 1 over the front-facing microfacets (midpoint quadrature).
        let d = TrowbridgeReitz::new(0.4, 0.2);
        let wo = Vec3::new(0.5, 0.1, 0.86).normalize();
        let sum = integrate_hemisphere(600, |wm, _| if wo.dot(wm) > 0.0 { d.d_visible(wo, wm) as f64 } else { 0.0 });
        assert!((sum - 1.0).abs() < 5e-3, "{sum}");
        // Samples are unit vectors in the upper hemisphere facing wo.
        for k in 0..100 {
            let wm = d.sample_wm(wo, Vec2::new((k as f32 + 0.5) / 100.0, 0.37));
            assert!(wm.z > 0.0 && (wm.length() - 1.0).abs() < 1e-4 && wm.dot(wo) > -1e-4);
        }
    }
}

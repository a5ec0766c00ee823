//! Fresnel equations for dielectrics and conductors, Snell refraction and the related angles.
//!
//! Conventions (as pbrt-v4, §9.3–9.4 of *Physically Based Rendering*, 4th ed.):
//! - `cos_theta_i` is the cosine between the incident direction and the surface normal. A positive value means the
//!   light arrives from the side the normal points into ("outside"); a negative value means it arrives from inside.
//! - `eta` is the **relative** index η = n_inside / n_outside, i.e. index of the side the normal points away from,
//!   divided by the index of the side it points into. Functions flip η to 1/η themselves when `cos_theta_i < 0`.
//! - Reflectances are for unpolarised light unless the name says `_s` / `_p`.
//! - Directions are `[T; 3]` unit vectors pointing **away** from the surface (both the incident `wi` and the
//!   returned transmitted `wt`), with `T` either float type ([`Float`]): f64 here, f32 in the renderer, one code.

use std::ops::{Add, Div, Mul, Neg, Sub};

use crate::complex::Complex;

/// The float types [`reflect`] and [`refract`] work in (`f32` and `f64`), so the renderer's f32 directions and the
/// f64 optics share one implementation.
pub trait Float:
    Copy
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// 0.
    const ZERO: Self;
    /// 1.
    const ONE: Self;
    /// 2.
    const TWO: Self;
    /// Square root.
    fn sqrt(self) -> Self;
    /// The larger of the two (the other if one is NaN).
    fn max(self, other: Self) -> Self;
    /// True unless infinite or NaN.
    fn is_finite(self) -> bool;
}

macro_rules! impl_float {
    ($t:ty) => {
        impl Float for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            const TWO: Self = 2.0;
            #[inline]
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }
            #[inline]
            fn max(self, other: Self) -> Self {
                <$t>::max(self, other)
            }
            #[inline]
            fn is_finite(self) -> bool {
                <$t>::is_finite(self)
            }
        }
    };
}
impl_float!(f32);
impl_float!(f64);

#[inline]
fn dot<T: Float>(a: [T; 3], b: [T; 3]) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Incident-side cosine, relative index and transmitted cosine after putting the incident ray outside;
/// `None` for total internal reflection.
fn dielectric_geometry(cos_theta_i: f64, eta: f64) -> Option<(f64, f64, f64)> {
    let mut cos_i = cos_theta_i.clamp(-1.0, 1.0);
    let mut eta = eta;
    if cos_i < 0.0 {
        // Ray inside: swap the roles of the two media.
        eta = 1.0 / eta;
        cos_i = -cos_i;
    }
    // Snell: sin²θt = sin²θi / η².
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    Some((cos_i, eta, (1.0 - sin2_t).sqrt()))
}

/// Reflectance for s-polarised light (E perpendicular to the plane of incidence):
/// R_s = ((cos θi − η cos θt)/(cos θi + η cos θt))² (Fresnel; Hecht, *Optics*, eq. 4.42). 1 under total internal
/// reflection.
pub fn fresnel_dielectric_s(cos_theta_i: f64, eta: f64) -> f64 {
    if eta == 1.0 {
        return 0.0;
    }
    match dielectric_geometry(cos_theta_i, eta) {
        None => 1.0,
        Some((ci, eta, ct)) => {
            let r = (ci - eta * ct) / (ci + eta * ct);
            r * r
        }
    }
}

/// Reflectance for p-polarised light (E in the plane of incidence):
/// R_p = ((η cos θi − cos θt)/(η cos θi + cos θt))² (Fresnel; Hecht, *Optics*, eq. 4.43). Zero at Brewster's angle,
/// 1 under total internal reflection.
pub fn fresnel_dielectric_p(cos_theta_i: f64, eta: f64) -> f64 {
    if eta == 1.0 {
        return 0.0;
    }
    match dielectric_geometry(cos_theta_i, eta) {
        None => 1.0,
        Some((ci, eta, ct)) => {
            let r = (eta * ci - ct) / (eta * ci + ct);
            r * r
        }
    }
}

/// Exact unpolarised Fresnel reflectance of a dielectric interface, R = (R_s + R_p)/2 (pbrt-v4 `FrDielectric`).
/// Works from either side (negative `cos_theta_i` = from inside) and returns 1 under total internal reflection.
pub fn fresnel_dielectric(cos_theta_i: f64, eta: f64) -> f64 {
    0.5 * (fresnel_dielectric_s(cos_theta_i, eta) + fresnel_dielectric_p(cos_theta_i, eta))
}

/// Unpolarised power transmittance of a dielectric interface, computed from the amplitude transmission
/// coefficients (not as 1 − R): T_{s,p} = (η cos θt / cos θi)·t_{s,p}² with t_s = 2cos θi/(cos θi + η cos θt) and
/// t_p = 2cos θi/(η cos θi + cos θt) (Hecht, *Optics*, eqs. 4.44–4.45, 4.60). It is the fraction of incident
/// **power** that crosses the interface, so R + T = 1; the transmitted **radiance** is further scaled by 1/η²
/// (the beam is compressed). 0 under total internal reflection.
pub fn fresnel_dielectric_transmittance(cos_theta_i: f64, eta: f64) -> f64 {
    if eta == 1.0 {
        return 1.0;
    }
    match dielectric_geometry(cos_theta_i, eta) {
        None => 0.0,
        Some((ci, eta, ct)) => {
            // (η cos θt/cos θi)·(2 cos θi)²/d² = 4 η cos θi cos θt / d².
            let num = 4.0 * eta * ci * ct;
            let ds = ci + eta * ct;
            let dp = eta * ci + ct;
            0.5 * (num / (ds * ds) + num / (dp * dp))
        }
    }
}

/// s- and p-polarised reflectances `(R_s, R_p)` of an interface to an absorbing medium with complex relative index
/// η = n + ik (pbrt-v4 `FrComplex`, with cos θt = √(1 − sin²θi/η²) on the principal branch). The light is taken to
/// arrive from the non-absorbing side, so the sign of `cos_theta_i` is ignored.
pub fn fresnel_complex_sp(cos_theta_i: f64, eta: Complex) -> (f64, f64) {
    if eta == Complex::from_real(1.0) {
        return (0.0, 0.0);
    }
    let ci = cos_theta_i.abs().min(1.0);
    let cos_i = Complex::from_real(ci);
    // Snell with a complex index: sin²θt = sin²θi/η², cos θt = √(1 − sin²θt).
    let sin2_t = Complex::from_real(1.0 - ci * ci) / (eta * eta);
    let cos_t = (Complex::from_real(1.0) - sin2_t).sqrt();
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    (r_perp.norm_sqr(), r_parl.norm_sqr())
}

/// Unpolarised reflectance of an interface to an absorbing medium with complex relative index η = n + ik:
/// R = (|r_s|² + |r_p|²)/2 (pbrt-v4 `FrComplex`). With k = 0 this equals [`fresnel_dielectric`] (from outside).
pub fn fresnel_complex(cos_theta_i: f64, eta: Complex) -> f64 {
    let (rs, rp) = fresnel_complex_sp(cos_theta_i, eta);
    0.5 * (rs + rp)
}

/// Unpolarised conductor reflectance for relative index `n + i·k`; see [`fresnel_complex`]. At normal incidence it is
/// ((n − 1)² + k²)/((n + 1)² + k²).
pub fn fresnel_conductor(cos_theta_i: f64, n: f64, k: f64) -> f64 {
    fresnel_complex(cos_theta_i, Complex::new(n, k))
}

/// Mirror reflection of `wo` about the normal `n`: 2(wo·n)n − wo (both unit; result points away from the surface).
#[inline]
pub fn reflect<T: Float>(wo: [T; 3], n: [T; 3]) -> [T; 3] {
    let d = T::TWO * dot(wo, n);
    [d * n[0] - wo[0], d * n[1] - wo[1], d * n[2] - wo[2]]
}

/// Refracts `wi` through a surface with unit normal `n` and relative index `eta` = n_inside/n_outside (the normal
/// points to the outside). `wi` is a unit vector pointing **away** from the surface on the side it arrives from; it
/// may be on either side of `n` (if `wi·n < 0` the ray is inside, and η and `n` are flipped). Returns the unit
/// transmitted direction `wt`, pointing away from the surface on the other side, with
/// wt = −wi/η + (cos θi/η − cos θt)·n (Snell's law in vector form, pbrt-v4 `Refract`), or `None` for total internal
/// reflection.
#[inline]
pub fn refract<T: Float>(wi: [T; 3], n: [T; 3], eta: T) -> Option<[T; 3]> {
    refract_with_eta(wi, n, eta).map(|(wt, _)| wt)
}

/// [`refract`], also returning the relative index actually crossed: `eta`, or `1/eta` when `wi` is inside.
#[inline]
pub fn refract_with_eta<T: Float>(wi: [T; 3], n: [T; 3], eta: T) -> Option<([T; 3], T)> {
    let mut cos_i = dot(n, wi);
    let (mut eta, mut n) = (eta, n);
    if cos_i < T::ZERO {
        eta = T::ONE / eta;
        cos_i = -cos_i;
        n = [-n[0], -n[1], -n[2]];
    }
    // sin²θt = sin²θi/η² (Snell, n₁ sin θ₁ = n₂ sin θ₂).
    let sin2_i = (T::ONE - cos_i * cos_i).max(T::ZERO);
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= T::ONE || !sin2_t.is_finite() {
        return None;
    }
    let cos_t = (T::ONE - sin2_t).sqrt();
    let a = cos_i / eta - cos_t;
    Some(([-wi[0] / eta + a * n[0], -wi[1] / eta + a * n[1], -wi[2] / eta + a * n[2]], eta))
}

/// Minimum deviation of a prism of apex angle `apex` (radians) and index `n` in air: D = 2·asin(n·sin(A/2)) − A
/// (the symmetric passage; Hecht, *Optics*, eq. 5.55). `None` when no ray gets through (n·sin(A/2) > 1).
pub fn prism_minimum_deviation(n: f64, apex: f64) -> Option<f64> {
    let s = n * (apex / 2.0).sin();
    (s <= 1.0).then(|| 2.0 * s.asin() - apex)
}

/// Snell's law for the sine: sin θ₂ = n₁ sin θ₁ / n₂; `None` when that exceeds 1 (total internal reflection).
pub fn snell_sin_t(sin_theta_i: f64, n1: f64, n2: f64) -> Option<f64> {
    let s = n1 * sin_theta_i / n2;
    (s.abs() <= 1.0).then_some(s)
}

/// Critical angle (radians) for light going from index `n1` into `n2`: θc = asin(n₂/n₁); `None` unless n₁ > n₂.
pub fn critical_angle(n1: f64, n2: f64) -> Option<f64> {
    (n1 > n2 && n2 > 0.0).then(|| (n2 / n1).asin())
}

/// Brewster's angle (radians) for light going from index `n1` into `n2`: θB = atan(n₂/n₁), where R_p = 0.
pub fn brewster_angle(n1: f64, n2: f64) -> f64 {
    (n2 / n1).atan()
}

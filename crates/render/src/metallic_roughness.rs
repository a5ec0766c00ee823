//! The glTF 2.0 metallic-roughness BRDF (glTF 2.0 specification, Appendix B), spectrally: a Lambertian base under
//! a GGX specular layer mixed by Schlick's Fresnel term (`fresnel_mix`), blended by `metallic` with a GGX metal
//! whose Schlick Fresnel starts at the base colour (`conductor_fresnel`):
//!
//! f = (1 − m)·[(1 − F_d)·c/π + F_d·D·V] + m·F_c·D·V,  F_d = f₀ + (1 − f₀)(1 − |V·H|)⁵,  F_c = c + (1 − c)(1 − |V·H|)⁵
//!
//! with c the base colour (a reflectance spectrum), f₀ = ((η − 1)/(η + 1))² (η = 1.5 unless `KHR_materials_ior`
//! says otherwise), D the Trowbridge–Reitz (GGX) distribution of α = roughness², and V = G₁(L)·G₁(V)/(4|N·L||N·V|)
//! the separable Smith visibility the specification uses.

use glam::{Vec2, Vec3};
use spectral::SampledSpectrum;
use std::f32::consts::FRAC_1_PI;

use crate::microfacet::TrowbridgeReitz;
use crate::sampling::{cosine_hemisphere_pdf, sample_cosine_hemisphere};

/// The least GGX α: roughness 0 (a mirror in the specification) is rendered as this, a highlight far narrower
/// than a pixel, so that one sampled lobe serves every roughness.
pub const MIN_ALPHA: f32 = 2e-3;

/// The BRDF at one hit (see the module documentation).
#[derive(Clone, Copy, Debug)]
pub struct MetallicRoughness {
    /// Base colour c per wavelength, in [0, 1].
    pub base: SampledSpectrum,
    /// Metalness m in [0, 1].
    pub metallic: f32,
    /// The GGX distribution of α = max(roughness², [`MIN_ALPHA`]).
    pub distrib: TrowbridgeReitz,
    /// The dielectric layer's normal-incidence reflectance f₀ = ((η − 1)/(η + 1))².
    pub f0: f32,
}

/// Schlick's weight (1 − cos θ)⁵.
fn schlick_weight(cos: f32) -> f32 {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

impl MetallicRoughness {
    /// The BRDF of base colour `base`, `metallic`, perceptual `roughness` (α = roughness²) and index `ior`.
    pub fn new(base: SampledSpectrum, metallic: f32, roughness: f32, ior: f32) -> Self {
        let alpha = (roughness * roughness).max(MIN_ALPHA);
        let f0 = ((ior - 1.0) / (ior + 1.0)).powi(2);
        MetallicRoughness {
            base: base.map(|v| v.clamp(0.0, 1.0)),
            metallic: metallic.clamp(0.0, 1.0),
            distrib: TrowbridgeReitz::new(alpha, alpha),
            f0,
        }
    }

    /// f(wo, wi) in the shading frame (reflection only: zero across the surface).
    pub fn f(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        let (cos_o, cos_i) = (wo.z, wi.z);
        if cos_o * cos_i <= 0.0 {
            return SampledSpectrum::zero();
        }
        let Some(wm) = (wo + wi).try_normalize() else { return SampledSpectrum::zero() };
        let w = schlick_weight(wo.dot(wm).abs());
        let (cos_o, cos_i) = (cos_o.abs(), cos_i.abs());
        let specular = self.distrib.d(wm) * self.distrib.g1(wo) * self.distrib.g1(wi) / (4.0 * cos_o * cos_i);
        let f_dielectric = self.f0 + (1.0 - self.f0) * w;
        let m = self.metallic;
        let dielectric =
            self.base * ((1.0 - f_dielectric) * FRAC_1_PI) + SampledSpectrum::splat(f_dielectric * specular);
        let metal = (self.base + (SampledSpectrum::splat(1.0) - self.base) * w) * specular;
        dielectric * (1.0 - m) + metal * m
    }

    /// The probability of sampling the specular lobe for `wo`: its share of the reflected energy, estimated from
    /// the Fresnel terms at normal-to-`wo` incidence and the mean base colour, kept within [0.1, 0.9] where the
    /// base reflects (both lobes then get samples).
    fn specular_probability(&self, wo: Vec3) -> f32 {
        let w = schlick_weight(wo.z.abs());
        let c = self.base.average();
        let f_dielectric = self.f0 + (1.0 - self.f0) * w;
        let specular = (1.0 - self.metallic) * f_dielectric + self.metallic * (c + (1.0 - c) * w);
        let diffuse = (1.0 - self.metallic) * (1.0 - f_dielectric) * c;
        if diffuse <= 0.0 {
            return 1.0;
        }
        (specular / (specular + diffuse)).clamp(0.1, 0.9)
    }

    /// Density of [`MetallicRoughness::sample`] choosing `wi` for `wo`.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z * wi.z <= 0.0 {
            return 0.0;
        }
        let Some(wm) = (wo + wi).try_normalize() else { return 0.0 };
        let wm = if wm.z < 0.0 { -wm } else { wm };
        let p = self.specular_probability(wo);
        let specular = self.distrib.pdf(wo, wm) / (4.0 * wo.dot(wm).abs());
        p * specular + (1.0 - p) * cosine_hemisphere_pdf(wi.z.abs())
    }

    /// Samples `wi` for `wo`: the specular lobe (GGX visible normals, reflected) with the probability of
    /// `specular_probability`, else the cosine-weighted diffuse one; returns (f, wi, pdf) of the mixture.
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<(SampledSpectrum, Vec3, f32)> {
        if wo.z == 0.0 {
            return None;
        }
        let wi = if uc < self.specular_probability(wo) {
            let wm = self.distrib.sample_wm(wo, u);
            crate::bxdf::reflect(wo, wm)
        } else {
            let mut wi = sample_cosine_hemisphere(u);
            if wo.z < 0.0 {
                wi.z = -wi.z;
            }
            wi
        };
        let pdf = self.pdf(wo, wi);
        (pdf > 0.0).then(|| (self.f(wo, wi), wi, pdf))
    }

    /// The albedo hint of AOVs: the base colour (a metal's reflectance at normal incidence is the base colour too).
    pub fn albedo_hint(&self) -> SampledSpectrum {
        self.base
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// The specification's BRDF written out again in f64 from its formulas (Appendix B), for one wavelength of base
    /// colour `c`: the reference the implementation is checked against.
    fn reference_f(c: f64, metallic: f64, roughness: f64, ior: f64, wo: [f64; 3], wi: [f64; 3]) -> f64 {
        if wo[2] <= 0.0 || wi[2] <= 0.0 {
            return 0.0;
        }
        let alpha = (roughness * roughness).max(MIN_ALPHA as f64);
        let a2 = alpha * alpha;
        let h = [wo[0] + wi[0], wo[1] + wi[1], wo[2] + wi[2]];
        let len = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
        let h = [h[0] / len, h[1] / len, h[2] / len];
        let (n_l, n_v, n_h) = (wi[2], wo[2], h[2]);
        let v_h = wo[0] * h[0] + wo[1] * h[1] + wo[2] * h[2];
        let d = a2 / (PI * (n_h * n_h * (a2 - 1.0) + 1.0).powi(2));
        let g1 = |n_x: f64| 2.0 * n_x / (n_x + (a2 + (1.0 - a2) * n_x * n_x).sqrt());
        let v = g1(n_l) * g1(n_v) / (4.0 * n_l * n_v);
        let specular = v * d;
        let f0 = ((1.0 - ior) / (1.0 + ior)).powi(2);
        let fresnel = |f0: f64| f0 + (1.0 - f0) * (1.0 - v_h.abs()).powi(5);
        let dielectric = (1.0 - fresnel(f0)) * c / PI + fresnel(f0) * specular;
        let metal = fresnel(c) * specular;
        (1.0 - metallic) * dielectric + metallic * metal
    }

    /// The directional albedo ∫ f cos θᵢ dωᵢ of the specification's BRDF for `wo`, by the midpoint rule on an
    /// (n_μ, n_φ) grid in (cos θᵢ, φᵢ): fine enough for α ≥ 0.09.
    fn reference_albedo(c: f64, m: f64, r: f64, ior: f64, wo: [f64; 3], (nt, np): (usize, usize)) -> f64 {
        let mut sum = 0.0;
        for i in 0..nt {
            let mu = (i as f64 + 0.5) / nt as f64;
            let s = (1.0 - mu * mu).sqrt();
            for j in 0..np {
                let phi = 2.0 * PI * (j as f64 + 0.5) / np as f64;
                sum += reference_f(c, m, r, ior, wo, [s * phi.cos(), s * phi.sin(), mu]) * mu;
            }
        }
        sum * 2.0 * PI / (nt * np) as f64
    }

    fn dir(theta: f64, phi: f64) -> [f64; 3] {
        [theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()]
    }

    fn v3(d: [f64; 3]) -> Vec3 {
        Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32)
    }

    /// Cases: (base colour, metallic, roughness, ior).
    const CASES: [(f64, f64, f64, f64); 6] = [
        (0.8, 0.0, 0.5, 1.5),
        (0.8, 1.0, 0.5, 1.5),
        (0.3, 0.5, 0.3, 1.5),
        (1.0, 0.0, 0.9, 1.5),
        (0.5, 0.0, 0.4, 2.4),
        (0.9, 1.0, 0.7, 1.5),
    ];

    #[test]
    fn the_brdf_is_the_specifications_and_reciprocal() {
        for (c, m, r, ior) in CASES {
            let brdf = MetallicRoughness::new(SampledSpectrum::splat(c as f32), m as f32, r as f32, ior as f32);
            for (to, po, ti, pi) in
                [(0.3, 0.0, 0.5, 2.0), (1.2, 1.0, 0.2, 4.0), (0.7, 0.5, 0.7, 3.64), (1.4, 0.0, 1.3, 3.0)]
            {
                let (wo, wi) = (dir(to, po), dir(ti, pi));
                let want = reference_f(c, m, r, ior, wo, wi);
                let got = brdf.f(v3(wo), v3(wi))[0] as f64;
                assert!((got - want).abs() <= 1e-4 * want.max(1.0), "{c} {m} {r} {ior}: f {got}, specification {want}");
                let back = brdf.f(v3(wi), v3(wo))[0] as f64;
                assert!((got - back).abs() <= 1e-5 * got.max(1.0), "not reciprocal: {got} {back}");
            }
            assert_eq!(brdf.f(v3(dir(0.3, 0.0)), v3([0.0, 0.3, -0.9]))[0], 0.0, "no transmission");
        }
    }

    /// The directional albedo ∫ f cos θᵢ dωᵢ by importance sampling (f cos / pdf with the BRDF's own sampler)
    /// equals a quadrature of the specification's formula within 4 standard errors (under 1.5 %): the sampler draws
    /// from the density `pdf` reports, and the energy is the specification's.
    #[test]
    fn sampled_albedo_matches_a_quadrature_of_the_specification() {
        let mut rng = rand_pcg::Pcg32::new(7, 11);
        use rand_core::RngCore;
        let mut uniform = move || (rng.next_u32() >> 8) as f32 / (1u32 << 24) as f32;
        for (c, m, r, ior) in CASES {
            let brdf = MetallicRoughness::new(SampledSpectrum::splat(c as f32), m as f32, r as f32, ior as f32);
            for theta_o in [0.2f64, 0.9, 1.35] {
                let wo = dir(theta_o, 0.4);
                let quad = reference_albedo(c, m, r, ior, wo, (600, 600));
                let n = 200_000;
                let (mut sum, mut sum2) = (0.0f64, 0.0f64);
                for _ in 0..n {
                    let u = Vec2::new(uniform(), uniform());
                    let x = match brdf.sample(v3(wo), uniform(), u) {
                        Some((f, wi, pdf)) => {
                            let p = brdf.pdf(v3(wo), wi);
                            assert!((p - pdf).abs() <= 1e-4 * pdf, "pdf {p} vs sampled {pdf}");
                            f[0] as f64 * wi.z.abs() as f64 / pdf as f64
                        }
                        None => 0.0,
                    };
                    sum += x;
                    sum2 += x * x;
                }
                let mean = sum / n as f64;
                let se = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
                // The estimate resolves the albedo to better than 1.5 %, and agrees within 4 standard errors (plus
                // the quadrature's own 0.2 %).
                assert!(4.0 * se < 0.015 * quad, "too noisy to tell: {mean} ± {se}");
                assert!(
                    (mean - quad).abs() < 4.0 * se + 0.002 * quad,
                    "{c} {m} {r} {ior} at θo {theta_o}: sampled {mean} ± {se}, quadrature {quad}"
                );
            }
        }
    }

    /// Through the renderer: a sphere of the material under a uniform white sky, seen head-on by an orthographic
    /// camera with one bounce, has the radiance of its directional albedo at normal incidence (the sky's radiance is
    /// 1): the quadrature of the specification's formula, within 1.5 %.
    #[test]
    fn a_white_furnace_returns_the_specifications_albedo() {
        for (c, m, r, ior) in [(0.8, 0.0, 0.5, 1.5), (0.6, 1.0, 0.3, 1.5), (0.9, 0.3, 0.8, 1.5)] {
            let scene = format!(
                "LookAt 0 0 -5  0 0 0  0 1 0\nCamera \"orthographic\" \"float screenwindow\" [ -0.05 0.05 -0.05 0.05 ]\n\
                 Film \"rgb\" \"integer xresolution\" 4 \"integer yresolution\" 4\n\
                 Sampler \"zsobol\" \"integer pixelsamples\" 256\nIntegrator \"path\" \"integer maxdepth\" 1\n\
                 WorldBegin\nLightSource \"infinite\" \"rgb L\" [ 1 1 1 ]\n\
                 Material \"metallicroughness\" \"rgb basecolor\" [ {c} {c} {c} ] \"float metallic\" {m} \
                 \"float roughness\" {r} \"float ior\" {ior}\nShape \"sphere\" \"float radius\" 1\n"
            );
            let desc = pbrt::parse_str(&scene, std::path::Path::new("furnace.pbrt")).unwrap();
            let built = crate::build_scene(&desc, &crate::BuildOptions::default()).unwrap();
            let y = crate::tests::support::mean_y(&built, 1, 0..4);
            let albedo = reference_albedo(c, m, r, ior, [0.0, 0.0, 1.0], (1000, 400));
            assert!((y / albedo - 1.0).abs() < 0.015, "{c} {m} {r}: rendered {y}, specification {albedo}");
        }
    }
}

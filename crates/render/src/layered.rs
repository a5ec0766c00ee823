//! pbrt-v4's `coateddiffuse`: a Lambertian base under a dielectric coating, with a thin absorbing layer between,
//! evaluated stochastically by random walks between the two interfaces (Guo et al. 2018, "Position-Free Monte
//! Carlo Simulation for Arbitrary Layered BSDFs"; pbrt-v4 §14.3). `f` and `pdf` are unbiased estimates; sampling
//! returns a proportional pdf, so integrators use `f/pdf` as the path weight and ask `pdf` for MIS.

use glam::{Vec2, Vec3};
use spectral::SampledSpectrum;

use crate::bxdf::{BsdfSample, Bxdf, Lobes, TransportMode};
use crate::microfacet::TrowbridgeReitz;
use crate::sampler::hash_words;
use crate::sampling::power_heuristic;
use std::f32::consts::PI;

/// A diffuse base with a dielectric coat; the medium between them has unit extinction and no scattering
/// (pbrt-v4's `albedo` 0 default), so light crossing it is attenuated by exp(−thickness/|cos θ|).
#[derive(Clone, Debug)]
pub struct CoatedDiffuse {
    top: Bxdf,
    bottom: Bxdf,
    thickness: f32,
    max_depth: u32,
    n_samples: u32,
}

/// A small deterministic generator for the walks, seeded from the directions (so `f` is a pure function).
struct WalkRng(u64);

impl WalkRng {
    fn new(a: Vec3, b: Vec3) -> Self {
        let s = hash_words(&[a.x.to_bits(), a.y.to_bits(), a.z.to_bits(), b.x.to_bits(), b.y.to_bits(), b.z.to_bits()]);
        Self(0x853c_49e6_748f_ea9b ^ (s as u64) << 1 | 1)
    }
    fn next(&mut self) -> f32 {
        // PCG32 (O'Neill 2014), XSH-RR output.
        let old = self.0;
        self.0 = old.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        (xorshifted.rotate_right(rot) >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }
    fn next2(&mut self) -> Vec2 {
        Vec2::new(self.next(), self.next())
    }
}

/// Transmittance through the layer of thickness `dz` along `w` (unit extinction coefficient).
fn tr(dz: f32, w: Vec3) -> f32 {
    if dz.abs() <= f32::MIN_POSITIVE {
        1.0
    } else {
        (-(dz / w.z).abs()).exp()
    }
}

impl CoatedDiffuse {
    /// A coated diffuse BxDF: base albedo `reflectance`, coat index `eta` and microfacet `distrib`.
    pub fn new(
        reflectance: SampledSpectrum,
        eta: f32,
        distrib: TrowbridgeReitz,
        thickness: f32,
        max_depth: u32,
        n_samples: u32,
    ) -> Self {
        Self {
            top: Bxdf::Dielectric { eta, distrib },
            bottom: Bxdf::Diffuse { r: reflectance },
            thickness: thickness.max(f32::MIN_POSITIVE),
            max_depth,
            n_samples: n_samples.max(1),
        }
    }

    /// The base's albedo (for albedo AOVs).
    pub fn base_albedo(&self) -> SampledSpectrum {
        match &self.bottom {
            Bxdf::Diffuse { r } => *r,
            _ => SampledSpectrum::zero(),
        }
    }

    /// Estimate of f(ωo, ωi). The base is opaque, so only reflection is non-zero.
    pub fn f(&self, mut wo: Vec3, mut wi: Vec3, mode: TransportMode) -> SampledSpectrum {
        // Two-sided: evaluate from the coated side.
        if wo.z < 0.0 {
            wo = -wo;
            wi = -wi;
        }
        if wi.z <= 0.0 {
            return SampledSpectrum::zero();
        }
        let other = match mode {
            TransportMode::Radiance => TransportMode::Importance,
            TransportMode::Importance => TransportMode::Radiance,
        };
        let mut f = self.top.f(wo, wi, mode) * self.n_samples as f32;
        let mut rng = WalkRng::new(wo, wi);
        let exit_specular = self.top.is_specular();
        for _ in 0..self.n_samples {
            // Enter through the coat, and pick the direction that will leave through it towards ωi.
            let Some(wos) = self.top.sample_f_lobes(wo, rng.next(), rng.next2(), mode, Lobes::Transmission) else {
                continue;
            };
            let Some(wis) = self.top.sample_f_lobes(wi, rng.next(), rng.next2(), other, Lobes::Transmission) else {
                continue;
            };
            if wos.pdf <= 0.0 || wos.wi.z == 0.0 || wis.pdf <= 0.0 || wis.wi.z == 0.0 {
                continue;
            }
            let mut beta = wos.f * (wos.wi.z.abs() / wos.pdf);
            let mut z = self.thickness;
            let mut w = wos.wi;
            for depth in 0..self.max_depth {
                if depth > 3 && beta.max_value() < 0.25 {
                    let q = (1.0 - beta.max_value()).max(0.0);
                    if rng.next() < q {
                        break;
                    }
                    beta *= 1.0 / (1.0 - q);
                }
                z = if z == self.thickness { 0.0 } else { self.thickness };
                beta *= tr(self.thickness, w);
                if z == 0.0 {
                    // At the diffuse base: connect to the exit direction (MIS against sampling the base).
                    let base_pdf = self.bottom.pdf(-w, -wis.wi, mode);
                    let wt = if exit_specular { 1.0 } else { power_heuristic(wis.pdf, base_pdf) };
                    f += beta
                        * self.bottom.f(-w, -wis.wi, mode)
                        * wis.f
                        * (wis.wi.z.abs() * wt * tr(self.thickness, wis.wi) / wis.pdf);
                    let Some(bs) = self.bottom.sample_f_lobes(-w, rng.next(), rng.next2(), mode, Lobes::Reflection)
                    else {
                        break;
                    };
                    if bs.pdf <= 0.0 || bs.wi.z == 0.0 {
                        break;
                    }
                    beta = beta * bs.f * (bs.wi.z.abs() / bs.pdf);
                    w = bs.wi;
                    if !exit_specular {
                        let f_exit = self.top.f(-w, wi, mode);
                        if !f_exit.is_black() {
                            let exit_pdf = self.top.pdf_lobes(-w, wi, mode, Lobes::Transmission);
                            let wt = power_heuristic(bs.pdf, exit_pdf);
                            f += beta * f_exit * (tr(self.thickness, bs.wi) * wt);
                        }
                    }
                } else {
                    // At the coat from inside: reflect back down.
                    let Some(bs) = self.top.sample_f_lobes(-w, rng.next(), rng.next2(), mode, Lobes::Reflection) else {
                        break;
                    };
                    if bs.pdf <= 0.0 || bs.wi.z == 0.0 {
                        break;
                    }
                    beta = beta * bs.f * (bs.wi.z.abs() / bs.pdf);
                    w = bs.wi;
                }
            }
        }
        f * (1.0 / self.n_samples as f32)
    }

    /// Estimate of the density of [`CoatedDiffuse::sample_f`], mixed with a uniform density for robustness.
    pub fn pdf(&self, mut wo: Vec3, mut wi: Vec3, mode: TransportMode) -> f32 {
        if wo.z < 0.0 {
            wo = -wo;
            wi = -wi;
        }
        if wi.z <= 0.0 {
            return 0.0;
        }
        let other = match mode {
            TransportMode::Radiance => TransportMode::Importance,
            TransportMode::Importance => TransportMode::Radiance,
        };
        let mut rng = WalkRng::new(wi, wo);
        let mut pdf_sum = self.n_samples as f32 * self.top.pdf_lobes(wo, wi, mode, Lobes::Reflection);
        for _ in 0..self.n_samples {
            // The transmit–reflect–transmit path.
            let wos = self.top.sample_f_lobes(wo, rng.next(), rng.next2(), mode, Lobes::Transmission);
            let wis = self.top.sample_f_lobes(wi, rng.next(), rng.next2(), other, Lobes::Transmission);
            let (Some(wos), Some(wis)) = (wos, wis) else { continue };
            if wos.pdf <= 0.0 || wis.pdf <= 0.0 {
                continue;
            }
            if self.top.is_specular() {
                pdf_sum += self.bottom.pdf(-wos.wi, -wis.wi, mode);
            } else if let Some(rs) = self.bottom.sample_f(-wos.wi, rng.next(), rng.next2(), mode) {
                if rs.pdf > 0.0 {
                    let r_pdf = self.bottom.pdf(-wos.wi, -wis.wi, mode);
                    pdf_sum += power_heuristic(wis.pdf, r_pdf) * r_pdf;
                    let t_pdf = self.top.pdf(-rs.wi, wi, mode);
                    pdf_sum += power_heuristic(rs.pdf, t_pdf) * t_pdf;
                }
            }
        }
        let estimate = pdf_sum / self.n_samples as f32;
        0.1 * (1.0 / (4.0 * PI)) + 0.9 * estimate
    }

    /// Samples a direction by a random walk through the layers.
    pub fn sample_f(&self, wo: Vec3, uc: f32, u: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        let flip = wo.z < 0.0;
        let wo = if flip { -wo } else { wo };
        let mut bs = self.top.sample_f(wo, uc, u, mode)?;
        if !bs.transmission {
            if flip {
                bs.wi = -bs.wi;
            }
            bs.pdf_is_proportional = true;
            return Some(bs);
        }
        let mut w = bs.wi;
        let mut specular = bs.specular;
        let mut f = bs.f * bs.wi.z.abs();
        let mut pdf = bs.pdf;
        let mut z = self.thickness;
        let mut rng = WalkRng::new(wo, Vec3::new(uc, u.x, u.y));
        for depth in 0..self.max_depth {
            let rr_beta = f.max_value() / pdf;
            if depth > 3 && rr_beta < 0.25 {
                let q = (1.0 - rr_beta).max(0.0);
                if rng.next() < q {
                    return None;
                }
                pdf *= 1.0 - q;
            }
            if w.z == 0.0 {
                return None;
            }
            z = if z == self.thickness { 0.0 } else { self.thickness };
            f *= tr(self.thickness, w);
            let interface = if z == 0.0 { &self.bottom } else { &self.top };
            let s = interface.sample_f(-w, rng.next(), rng.next2(), mode)?;
            if s.pdf <= 0.0 || s.wi.z == 0.0 {
                return None;
            }
            f *= s.f;
            pdf *= s.pdf;
            specular &= s.specular;
            w = s.wi;
            if s.transmission {
                // Left through the coat.
                let wi = if flip { -w } else { w };
                return Some(BsdfSample {
                    f,
                    wi,
                    pdf,
                    specular,
                    transmission: false,
                    eta: 1.0,
                    pdf_is_proportional: true,
                    keep_slot: None,
                });
            }
            f *= s.wi.z.abs();
        }
        None
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

    #[test]
    fn white_base_under_a_clear_coat_reflects_almost_everything() {
        // With a white base and a vanishing absorbing layer, energy is only lost to the walk's depth limit.
        let c = CoatedDiffuse::new(SampledSpectrum::splat(1.0), 1.5, TrowbridgeReitz::new(0.0, 0.0), 1e-6, 100, 1);
        let wo = Vec3::new(0.3, 0.0, 0.954).normalize();
        let mut rng = Pcg32::seed_from_u64(3);
        let n = 40_000;
        let mut sum_sampled = 0.0;
        let mut sum_uniform = 0.0;
        for _ in 0..n {
            if let Some(s) = c.sample_f(
                wo,
                uniform(&mut rng),
                Vec2::new(uniform(&mut rng), uniform(&mut rng)),
                TransportMode::Radiance,
            ) {
                sum_sampled += s.f[0] * s.wi.z.abs() / s.pdf;
            }
            // Independent check of f(): ∫ f cos dω by uniform hemisphere sampling (the specular coat's own
            // reflection is a delta and only appears in the sampled estimate; add it analytically).
            let (a, b) = (uniform(&mut rng), uniform(&mut rng));
            let zc = a;
            let r = (1.0 - zc * zc).sqrt();
            let wi = Vec3::new(r * (2.0 * PI * b).cos(), r * (2.0 * PI * b).sin(), zc);
            sum_uniform += c.f(wo, wi, TransportMode::Radiance)[0] * zc * 2.0 * PI;
        }
        let sampled = sum_sampled / n as f32;
        let coat = crate::bxdf::fresnel_dielectric(wo.z, 1.5);
        let uniform_est = sum_uniform / n as f32 + coat;
        assert!(sampled > 0.97 && sampled <= 1.01, "sampled albedo {sampled}");
        assert!((uniform_est - sampled).abs() < 0.03, "f() gives {uniform_est}, sampling gives {sampled}");
    }

    #[test]
    fn pdf_is_a_positive_finite_approximation() {
        let c = CoatedDiffuse::new(SampledSpectrum::splat(0.5), 1.5, TrowbridgeReitz::new(0.2, 0.2), 0.01, 10, 1);
        let wo = Vec3::new(0.2, 0.1, 0.97).normalize();
        let n = 200;
        let mut sum = 0.0f64;
        for i in 0..n {
            for j in 0..n {
                let zc = (i as f32 + 0.5) / n as f32;
                let phi = 2.0 * PI * (j as f32 + 0.5) / n as f32;
                let r = (1.0 - zc * zc).sqrt();
                let wi = Vec3::new(r * phi.cos(), r * phi.sin(), zc);
                let p = c.pdf(wo, wi, TransportMode::Radiance);
                assert!(p.is_finite() && p > 0.0);
                sum += p as f64 * 2.0 * std::f64::consts::PI / (n * n) as f64;
            }
        }
        // The estimate measures the base's density in the refracted directions inside the coat and, as pbrt-v4's
        // does, ignores the refraction Jacobian (η²·cos θ_in/cos θ_out): it is only approximately normalised
        // (here ≈ 0.05 + 0.9·η² ≈ 2.1–2.3). MIS stays unbiased because both strategies use this same function.
        assert!(sum > 1.5 && sum < 2.6, "{sum}");
    }
}

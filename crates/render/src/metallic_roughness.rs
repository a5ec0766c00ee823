//! The glTF 2.0 metallic-roughness BRDF (glTF 2.0 specification, Appendix B), spectrally, with the extensions that
//! change it: `KHR_materials_specular`, `_iridescence`, `_sheen` and `_clearcoat`.
//!
//! The core is a Lambertian base under a GGX specular layer mixed by Schlick's Fresnel term (`fresnel_mix`), blended
//! by `metallic` with a GGX metal whose Schlick Fresnel starts at the base colour (`conductor_fresnel`):
//!
//! f = (1 − m)·[(1 − max F_d)·c/π + F_d·D·V] + m·F_c·D·V,  F_d = f₀ + (f₉₀ − f₀)(1 − |V·H|)⁵,  F_c = c + (1 − c)(1 − |V·H|)⁵
//!
//! with c the base colour (a reflectance spectrum), D the Trowbridge–Reitz (GGX) distribution of α = roughness², and
//! V = G₁(L)·G₁(V)/(4|N·L||N·V|) the separable Smith visibility the specification uses. Without
//! `KHR_materials_specular`, f₀ = ((η − 1)/(η + 1))² (η = 1.5 unless `KHR_materials_ior` says otherwise; η = 0 means
//! infinite, f₀ = 1) and f₉₀ = 1; with it, f₀ = min(f₀·specularColor, 1)·specular and f₉₀ = specular, and the base
//! keeps 1 − max F_d, the largest of the RGB specular colour's channels (the extension's `max_value`).
//!
//! The layers on top, each optional:
//! - iridescence (`KHR_materials_iridescence`): F_d and F_c are mixed by the iridescence weight with the reflectance
//!   of a thin film of index n_f and thickness d on the substrate the Fresnel term stands for (n = (1 + √f₀)/(1 − √f₀),
//!   the extension's `Fresnel0ToIor`, from f₀ for the dielectric and from the base colour for the metal), at the angle
//!   to the microfacet normal. The extension approximates that reflectance for RGB rendering (Belcour & Barla 2017,
//!   with Schlick's Fresnel terms); here it is Airy's exact sum per carried wavelength ([`crate::coating`]). The base
//!   keeps 1 − the film's reflectance per wavelength: a film sends on what it does not reflect, and no RGB channel
//!   has to stand for the spectrum.
//! - sheen (`KHR_materials_sheen`): f ← sheenColor·D_s·V_s + f·min(1 − max(sheenColor)·E(|N·V|), 1 − max(sheenColor)·E(|N·L|)),
//!   with Conty & Kulla's "Charlie" distribution D_s (α = sheenRoughness²) and visibility V_s, and E the sheen
//!   lobe's directional albedo, tabulated once by quadrature.
//! - clearcoat (`KHR_materials_clearcoat`): f ← f·(1 − w·F_cc) + w·F_cc·D_cc·V_cc about the coat's own normal, with
//!   F_cc = 0.04 + 0.96·(1 − |V·N_c|)⁵ and α = clearcoatRoughness².
//!
//! The specification's BRDF is not reciprocal once a clearcoat is on it (its Fresnel term reads the view direction
//! only), so on light paths the camera-side direction is passed as V ([`MetallicRoughness::f`]'s `wo`).

use glam::{Vec2, Vec3};
use spectral::SampledSpectrum;
use std::f32::consts::{FRAC_1_PI, PI};
use std::sync::OnceLock;

use crate::bxdf::fresnel_conductor;
use crate::coating::CoatingAt;
use crate::microfacet::TrowbridgeReitz;
use crate::sampling::{cosine_hemisphere_pdf, sample_cosine_hemisphere, Frame};

/// The least GGX α: roughness 0 (a mirror in the specification) is rendered as this, a highlight far narrower
/// than a pixel, so that one sampled lobe serves every roughness.
pub const MIN_ALPHA: f32 = 2e-3;

/// The least sheen roughness: below it the Charlie distribution's peak at grazing half vectors is narrower than
/// the albedo table resolves (the extension leaves the lower end to implementations).
pub const MIN_SHEEN_ROUGHNESS: f32 = 0.07;

/// The clearcoat's normal-incidence reflectance: a coat of index 1.5 (`KHR_materials_clearcoat`).
const CLEARCOAT_F0: f32 = 0.04;

/// The BRDF at one hit (see the module documentation).
#[derive(Clone, Debug)]
pub struct MetallicRoughness {
    /// Base colour c per wavelength, in [0, 1].
    pub base: SampledSpectrum,
    /// Metalness m in [0, 1].
    pub metallic: f32,
    /// The GGX distribution of α = max(roughness², [`MIN_ALPHA`]).
    pub distrib: TrowbridgeReitz,
    /// The dielectric part's normal-incidence reflectance f₀ per wavelength.
    pub f0: SampledSpectrum,
    /// The dielectric part's grazing reflectance f₉₀ (the specular weight; 1 without `KHR_materials_specular`).
    pub f90: f32,
    /// The largest RGB channel of f₀, which sets the energy the diffuse base keeps.
    pub f0_max: f32,
    /// Iridescence, sheen and clearcoat, if the material has any of them.
    pub layers: Option<Box<Layers>>,
}

/// The optional layers of a [`MetallicRoughness`] at one hit.
#[derive(Clone, Debug, Default)]
pub struct Layers {
    /// A thin film on both parts (`KHR_materials_iridescence`).
    pub iridescence: Option<Iridescence>,
    /// Sheen on top of them (`KHR_materials_sheen`).
    pub sheen: Option<Sheen>,
    /// A clear coat on top of everything (`KHR_materials_clearcoat`).
    pub clearcoat: Option<Clearcoat>,
}

/// Iridescence at one hit.
#[derive(Clone, Debug)]
pub struct Iridescence {
    /// How much of the Fresnel terms the film's reflectance replaces, in [0, 1].
    pub weight: f32,
    /// The film at the path's wavelengths (`None`: zero thickness, the bare substrate).
    pub film: Option<Box<CoatingAt>>,
    /// The substrate's index under the dielectric part, per wavelength (from f₀).
    pub dielectric_eta: SampledSpectrum,
    /// The substrate's index under the metal part, per wavelength (from the base colour).
    pub metal_eta: SampledSpectrum,
}

/// Sheen at one hit.
#[derive(Clone, Copy, Debug)]
pub struct Sheen {
    /// The sheen colour per wavelength.
    pub color: SampledSpectrum,
    /// Its largest RGB channel (`max3(sheenColor)`), which scales the energy taken from the layers below.
    pub color_max: f32,
    /// The sheen roughness, at least [`MIN_SHEEN_ROUGHNESS`].
    pub roughness: f32,
}

/// A clear coat at one hit.
#[derive(Clone, Copy, Debug)]
pub struct Clearcoat {
    /// Its weight in [0, 1].
    pub weight: f32,
    /// The GGX distribution of α = max(clearcoatRoughness², [`MIN_ALPHA`]).
    pub distrib: TrowbridgeReitz,
    /// The coat's normal in the shading frame (z unless the base is normal-mapped and the coat is not, or the coat
    /// has its own normal map).
    pub normal: Vec3,
}

/// Schlick's weight (1 − cos θ)⁵.
fn schlick_weight(cos: f32) -> f32 {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

/// The index of a non-absorbing medium under vacuum with normal-incidence reflectance `f0` (the extensions'
/// `Fresnel0ToIor`), kept finite.
pub fn fresnel0_to_ior(f0: f32) -> f32 {
    let s = f0.clamp(0.0, 0.9999).sqrt();
    (1.0 + s) / (1.0 - s)
}

/// The normal-incidence reflectance of index `ior` under vacuum; index 0 stands for infinity (`KHR_materials_ior`'s
/// specular-glossiness mode), whose reflectance is 1.
pub fn ior_to_fresnel0(ior: f32) -> f32 {
    if ior == 0.0 {
        1.0
    } else {
        ((ior - 1.0) / (ior + 1.0)).powi(2)
    }
}

impl MetallicRoughness {
    /// The BRDF of base colour `base`, `metallic`, perceptual `roughness` (α = roughness²) and index `ior`, without
    /// extensions.
    pub fn new(base: SampledSpectrum, metallic: f32, roughness: f32, ior: f32) -> Self {
        let alpha = (roughness * roughness).max(MIN_ALPHA);
        let f0 = ior_to_fresnel0(ior);
        MetallicRoughness {
            base: base.map(|v| v.clamp(0.0, 1.0)),
            metallic: metallic.clamp(0.0, 1.0),
            distrib: TrowbridgeReitz::new(alpha, alpha),
            f0: SampledSpectrum::splat(f0),
            f90: 1.0,
            f0_max: f0,
            layers: None,
        }
    }

    /// `KHR_materials_anisotropy`: α along the shading frame's x axis (the anisotropy direction) becomes
    /// mix(α, 1, strength²), α across it stays (the extension's α_t and α_b).
    pub fn with_anisotropy(mut self, strength: f32) -> Self {
        let s = strength.clamp(0.0, 1.0);
        let alpha = self.distrib.alpha_y();
        self.distrib = TrowbridgeReitz::new(alpha + (1.0 - alpha) * s * s, alpha);
        self
    }

    /// `KHR_materials_specular`: f₀ becomes min(f₀·`color`, 1)·`weight` and f₉₀ `weight` (`color_max`: the colour's
    /// largest RGB channel).
    pub fn with_specular(mut self, weight: f32, color: SampledSpectrum, color_max: f32) -> Self {
        let weight = weight.clamp(0.0, 1.0);
        let f0 = self.f0_max;
        self.f0 = color.map(|c| (f0 * c.max(0.0)).min(1.0) * weight);
        self.f0_max = (f0 * color_max.max(0.0)).min(1.0) * weight;
        self.f90 = weight;
        self
    }

    /// The layers, added if there were none.
    pub fn layers_mut(&mut self) -> &mut Layers {
        self.layers.get_or_insert_with(Default::default)
    }

    /// `KHR_materials_iridescence`: a film (`film`, `None` for zero thickness) of weight `weight` on both parts.
    pub fn with_iridescence(mut self, weight: f32, film: Option<Box<CoatingAt>>) -> Self {
        let weight = weight.clamp(0.0, 1.0);
        if weight > 0.0 {
            let dielectric_eta = self.f0.map(fresnel0_to_ior);
            let metal_eta = self.base.map(fresnel0_to_ior);
            self.layers_mut().iridescence = Some(Iridescence { weight, film, dielectric_eta, metal_eta });
        }
        self
    }

    /// `KHR_materials_sheen`: sheen of colour `color` (largest RGB channel `color_max`) and `roughness`.
    pub fn with_sheen(mut self, color: SampledSpectrum, color_max: f32, roughness: f32) -> Self {
        let color = color.map(|c| c.clamp(0.0, 1.0));
        let color_max = color_max.clamp(0.0, 1.0);
        if color_max > 0.0 && !color.is_black() {
            let roughness = roughness.clamp(MIN_SHEEN_ROUGHNESS, 1.0);
            self.layers_mut().sheen = Some(Sheen { color, color_max, roughness });
        }
        self
    }

    /// `KHR_materials_clearcoat`: a coat of `weight` and perceptual `roughness` about the shading normal.
    pub fn with_clearcoat(mut self, weight: f32, roughness: f32) -> Self {
        let weight = weight.clamp(0.0, 1.0);
        if weight > 0.0 {
            let alpha = (roughness * roughness).max(MIN_ALPHA);
            let distrib = TrowbridgeReitz::new(alpha, alpha);
            self.layers_mut().clearcoat = Some(Clearcoat { weight, distrib, normal: Vec3::Z });
        }
        self
    }

    /// The clear coat, if there is one (to give it its normal).
    pub fn clearcoat_mut(&mut self) -> Option<&mut Clearcoat> {
        self.layers.as_mut().and_then(|l| l.clearcoat.as_mut())
    }

    fn iridescence(&self) -> Option<&Iridescence> {
        self.layers.as_ref().and_then(|l| l.iridescence.as_ref())
    }

    fn sheen(&self) -> Option<&Sheen> {
        self.layers.as_ref().and_then(|l| l.sheen.as_ref())
    }

    fn clearcoat(&self) -> Option<&Clearcoat> {
        self.layers.as_ref().and_then(|l| l.clearcoat.as_ref())
    }

    /// f(wo, wi) in the shading frame (reflection only: zero across the surface); `wo` is the view direction V.
    pub fn f(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        if wo.z * wi.z <= 0.0 {
            return SampledSpectrum::zero();
        }
        let mut f = self.core_f(wo, wi);
        if let Some(sheen) = self.sheen() {
            let (cos_o, cos_i) = (wo.z.abs(), wi.z.abs());
            let scaling = (1.0 - sheen.color_max * sheen_albedo(cos_o, sheen.roughness))
                .min(1.0 - sheen.color_max * sheen_albedo(cos_i, sheen.roughness));
            f = sheen.color * sheen_brdf(wo, wi, sheen.roughness) + f * scaling.max(0.0);
        }
        if let Some(coat) = self.clearcoat() {
            let fresnel = coat.weight * coat.fresnel(wo);
            f = f * (1.0 - fresnel) + SampledSpectrum::splat(fresnel * coat.specular(wo, wi));
        }
        f
    }

    /// The core BRDF with specular and iridescence (`wo`, `wi` on the same side).
    fn core_f(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        let Some(wm) = (wo + wi).try_normalize() else { return SampledSpectrum::zero() };
        let cos_h = wo.dot(wm).abs();
        let w = schlick_weight(cos_h);
        let (cos_o, cos_i) = (wo.z.abs(), wi.z.abs());
        let specular = self.distrib.d(wm) * self.distrib.g1(wo) * self.distrib.g1(wi) / (4.0 * cos_o * cos_i);
        let one = SampledSpectrum::splat(1.0);
        let mut f_dielectric = self.f0 + (SampledSpectrum::splat(self.f90) - self.f0) * w;
        // The base keeps what the largest channel of the Fresnel term leaves (the specular extension's max_value).
        let mut base_weight = SampledSpectrum::splat(1.0 - (self.f0_max + (self.f90 - self.f0_max) * w));
        let mut f_metal = self.base + (one - self.base) * w;
        let m = self.metallic;
        if let Some(irid) = self.iridescence() {
            // Each part's film is computed only where that part has weight (a pure metal or dielectric needs one).
            let t = irid.weight;
            if m < 1.0 {
                let film_dielectric = irid.reflectance(cos_h, &irid.dielectric_eta);
                f_dielectric = f_dielectric * (1.0 - t) + film_dielectric * t;
                base_weight = base_weight * (1.0 - t) + (one - film_dielectric) * t;
            }
            if m > 0.0 {
                f_metal = f_metal * (1.0 - t) + irid.reflectance(cos_h, &irid.metal_eta) * t;
            }
        }
        let dielectric = self.base * base_weight.map(|v| v.max(0.0)) * FRAC_1_PI + f_dielectric * specular;
        dielectric * (1.0 - m) + f_metal * (specular * m)
    }

    /// The probabilities of sampling the core's specular lobe, the cosine-weighted lobe (its diffuse base and the
    /// sheen) and the clear coat for `wo`: their shares of the reflected energy, estimated from the Fresnel terms at
    /// normal-to-`wo` incidence and the mean colours, each lobe that reflects kept at 0.1 or more.
    fn lobe_probabilities(&self, wo: Vec3) -> [f32; 3] {
        let cos_o = wo.z.abs();
        let w = schlick_weight(cos_o);
        let c = self.base.average();
        let f_dielectric = self.f0_max + (self.f90 - self.f0_max) * w;
        let mut specular = (1.0 - self.metallic) * f_dielectric + self.metallic * (c + (1.0 - c) * w);
        let mut diffuse = (1.0 - self.metallic) * (1.0 - f_dielectric) * c;
        if let Some(sheen) = self.sheen() {
            let e = sheen.color_max * sheen_albedo(cos_o, sheen.roughness);
            specular *= 1.0 - e;
            diffuse = diffuse * (1.0 - e) + e;
        }
        let mut coat = 0.0;
        if let Some(cc) = self.clearcoat() {
            coat = cc.weight * cc.fresnel(wo);
            specular *= 1.0 - coat;
            diffuse *= 1.0 - coat;
        }
        let mut p = [specular.max(0.0), diffuse.max(0.0), coat];
        let total: f32 = p.iter().sum();
        if total <= 0.0 {
            return [1.0, 0.0, 0.0];
        }
        let lit = p.iter().filter(|&&v| v > 0.0).count() as f32;
        for v in &mut p {
            if *v > 0.0 {
                // Each lobe that reflects gets at least 0.1, the rest shares what is left in proportion.
                *v = 0.1 + (1.0 - 0.1 * lit) * (*v / total);
            }
        }
        p
    }

    /// Density of [`MetallicRoughness::sample`] choosing `wi` for `wo`.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z * wi.z <= 0.0 {
            return 0.0;
        }
        let [p_specular, p_diffuse, p_coat] = self.lobe_probabilities(wo);
        let mut pdf = p_diffuse * cosine_hemisphere_pdf(wi.z.abs());
        if p_specular > 0.0 {
            pdf += p_specular * reflection_pdf(&self.distrib, wo, wi);
        }
        if let (Some(cc), true) = (self.clearcoat(), p_coat > 0.0) {
            pdf += p_coat * cc.pdf(wo, wi);
        }
        pdf
    }

    /// Samples `wi` for `wo`: the core's specular lobe (GGX visible normals, reflected), the cosine-weighted one or
    /// the clear coat's, with the probabilities of `lobe_probabilities`; returns (f, wi, pdf) of the mixture.
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<(SampledSpectrum, Vec3, f32)> {
        if wo.z == 0.0 {
            return None;
        }
        let [p_specular, p_diffuse, _] = self.lobe_probabilities(wo);
        let wi = if uc < p_specular {
            let wm = self.distrib.sample_wm(wo, u);
            crate::bxdf::reflect(wo, wm)
        } else if uc < p_specular + p_diffuse {
            let mut wi = sample_cosine_hemisphere(u);
            if wo.z < 0.0 {
                wi.z = -wi.z;
            }
            wi
        } else {
            self.clearcoat()?.sample(wo, u)?
        };
        let pdf = self.pdf(wo, wi);
        (pdf > 0.0).then(|| (self.f(wo, wi), wi, pdf))
    }

    /// The albedo hint of AOVs: the base colour (a metal's reflectance at normal incidence is the base colour too).
    pub fn albedo_hint(&self) -> SampledSpectrum {
        self.base
    }
}

/// The density of choosing `wi` by reflecting `wo` about a visible normal of `distrib` (both in its frame).
fn reflection_pdf(distrib: &TrowbridgeReitz, wo: Vec3, wi: Vec3) -> f32 {
    let Some(wm) = (wo + wi).try_normalize() else { return 0.0 };
    let wm = if wm.z < 0.0 { -wm } else { wm };
    distrib.pdf(wo, wm) / (4.0 * wo.dot(wm).abs())
}

impl Iridescence {
    /// The film's unpolarised reflectance per wavelength onto substrate `eta` at `cos` to the microfacet normal.
    fn reflectance(&self, cos: f32, eta: &SampledSpectrum) -> SampledSpectrum {
        let k = SampledSpectrum::zero();
        match &self.film {
            Some(film) => film.conductor_reflectance(cos, eta, &k),
            None => fresnel_conductor(cos, eta, &k),
        }
    }
}

impl Clearcoat {
    /// The coat's frame, if its normal is not the shading normal.
    fn frame(&self) -> Option<Frame> {
        (self.normal != Vec3::Z).then(|| Frame::from_z(self.normal))
    }

    /// F_cc = 0.04 + 0.96·(1 − |V·N_c|)⁵.
    fn fresnel(&self, wo: Vec3) -> f32 {
        CLEARCOAT_F0 + (1.0 - CLEARCOAT_F0) * schlick_weight(wo.dot(self.normal).abs())
    }

    /// D·V of the coat about its normal (zero unless both directions are on one side of it).
    fn specular(&self, wo: Vec3, wi: Vec3) -> f32 {
        let (wo, wi) = match self.frame() {
            Some(frame) => (frame.to_local(wo), frame.to_local(wi)),
            None => (wo, wi),
        };
        if wo.z * wi.z <= 0.0 {
            return 0.0;
        }
        let Some(wm) = (wo + wi).try_normalize() else { return 0.0 };
        self.distrib.d(wm) * self.distrib.g1(wo) * self.distrib.g1(wi) / (4.0 * wo.z.abs() * wi.z.abs())
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let (wo, wi) = match self.frame() {
            Some(frame) => (frame.to_local(wo), frame.to_local(wi)),
            None => (wo, wi),
        };
        if wo.z * wi.z <= 0.0 {
            return 0.0;
        }
        reflection_pdf(&self.distrib, wo, wi)
    }

    fn sample(&self, wo: Vec3, u: Vec2) -> Option<Vec3> {
        let frame = self.frame();
        let local = frame.map_or(wo, |f| f.to_local(wo));
        if local.z == 0.0 {
            return None;
        }
        let wi = crate::bxdf::reflect(local, self.distrib.sample_wm(local, u));
        Some(frame.map_or(wi, |f| f.from_local(wi)))
    }
}

/// The "Charlie" sheen distribution of Conty & Kulla (2017) for sheen roughness `r` (α = r²) at half vector `wm`:
/// (2 + 1/α)·sin^{1/α}θ_h / 2π (`KHR_materials_sheen`).
fn charlie_d(wm: Vec3, r: f32) -> f32 {
    let inv_alpha = 1.0 / (r * r);
    let sin2 = (1.0 - wm.z * wm.z).max(0.0);
    (2.0 + inv_alpha) * sin2.powf(0.5 * inv_alpha) / (2.0 * PI)
}

/// Conty & Kulla's fitted Λ of the Charlie distribution, as `KHR_materials_sheen` gives it.
fn charlie_lambda(cos: f32, r: f32) -> f32 {
    let alpha = r * r;
    let t = (1.0 - alpha) * (1.0 - alpha);
    let mix = |a: f32, b: f32| a + (b - a) * t;
    let (a, b, c, d, e) = (
        mix(21.5473, 25.3245),
        mix(3.82987, 3.32435),
        mix(0.19823, 0.16801),
        mix(-1.97760, -1.27393),
        mix(-4.32054, -4.85967),
    );
    let l = |x: f32| a / (1.0 + b * x.powf(c)) + d * x + e;
    let cos = cos.abs();
    if cos < 0.5 {
        l(cos).exp()
    } else {
        (2.0 * l(0.5) - l(1.0 - cos)).exp()
    }
}

/// The sheen BRDF D_s·V_s (without its colour), V_s = 1/((1 + Λ(N·V) + Λ(N·L))·4|N·V||N·L|).
fn sheen_brdf(wo: Vec3, wi: Vec3, r: f32) -> f32 {
    let Some(wm) = (wo + wi).try_normalize() else { return 0.0 };
    let (cos_o, cos_i) = (wo.z.abs(), wi.z.abs());
    let visibility = 1.0 / ((1.0 + charlie_lambda(cos_o, r) + charlie_lambda(cos_i, r)) * 4.0 * cos_o * cos_i);
    charlie_d(wm, r) * visibility
}

/// The albedo table's resolution in cos θ and in sheen roughness.
const SHEEN_TABLE: usize = 32;

/// E(cos θ, r) = ∫ D_s·V_s·cos θᵢ dωᵢ, the sheen lobe's directional albedo, bilinear in a table over √cos θ ∈ [0, 1]
/// (dense at grazing angles, where E changes fastest) and r ∈ [[`MIN_SHEEN_ROUGHNESS`], 1], computed once by the
/// midpoint rule.
pub fn sheen_albedo(cos: f32, r: f32) -> f32 {
    static TABLE: OnceLock<Vec<f32>> = OnceLock::new();
    let n = SHEEN_TABLE;
    let table = TABLE.get_or_init(|| {
        let mut t = Vec::with_capacity(n * n);
        for j in 0..n {
            let r = MIN_SHEEN_ROUGHNESS + (1.0 - MIN_SHEEN_ROUGHNESS) * j as f32 / (n - 1) as f32;
            for i in 0..n {
                let x = i as f32 / (n - 1) as f32;
                t.push(sheen_albedo_quadrature((x * x).max(1e-4), r, 64, 64) as f32);
            }
        }
        t
    });
    let x = cos.abs().clamp(0.0, 1.0).sqrt() * (n - 1) as f32;
    let y = ((r.clamp(MIN_SHEEN_ROUGHNESS, 1.0) - MIN_SHEEN_ROUGHNESS) / (1.0 - MIN_SHEEN_ROUGHNESS)) * (n - 1) as f32;
    let (i, j) = ((x as usize).min(n - 2), (y as usize).min(n - 2));
    let (fx, fy) = (x - i as f32, y - j as f32);
    let at = |i: usize, j: usize| table[j * n + i];
    (1.0 - fy) * ((1.0 - fx) * at(i, j) + fx * at(i + 1, j)) + fy * ((1.0 - fx) * at(i, j + 1) + fx * at(i + 1, j + 1))
}

/// ∫ D_s·V_s·cos θᵢ dωᵢ for view cosine `cos` by the midpoint rule on an (n_μ, n_φ) grid in (√cos θᵢ, φᵢ), in
/// double precision (the sum of small terms); φ over [0, π] twice, the lobe being symmetric about the plane of
/// incidence.
fn sheen_albedo_quadrature(cos: f32, r: f32, n_mu: usize, n_phi: usize) -> f64 {
    let wo = Vec3::new((1.0 - cos * cos).max(0.0).sqrt(), 0.0, cos);
    let mut sum = 0.0f64;
    for a in 0..n_mu {
        // cos θᵢ = t², dμ = 2t dt: samples gather at grazing incidence, where the sheen lobe peaks.
        let t = (a as f32 + 0.5) / n_mu as f32;
        let mu = t * t;
        let s = (1.0 - mu * mu).sqrt();
        for b in 0..n_phi {
            let phi = PI * (b as f32 + 0.5) / n_phi as f32;
            let wi = Vec3::new(s * phi.cos(), s * phi.sin(), mu);
            sum += f64::from(sheen_brdf(wo, wi, r) * mu * 2.0 * t);
        }
    }
    sum * 2.0 * std::f64::consts::PI / (n_mu * n_phi) as f64
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

    /// ∫ f(ωᵢ) cos θᵢ dωᵢ over the upper hemisphere by the midpoint rule on an (n_μ, n_φ) grid in (cos θᵢ, φᵢ).
    fn hemisphere_quadrature(f: &dyn Fn([f64; 3]) -> f64, (nt, np): (usize, usize)) -> f64 {
        let mut sum = 0.0;
        for i in 0..nt {
            let mu = (i as f64 + 0.5) / nt as f64;
            let s = (1.0 - mu * mu).sqrt();
            for j in 0..np {
                let phi = 2.0 * PI * (j as f64 + 0.5) / np as f64;
                sum += f([s * phi.cos(), s * phi.sin(), mu]) * mu;
            }
        }
        sum * 2.0 * PI / (nt * np) as f64
    }

    /// The directional albedo ∫ f cos θᵢ dωᵢ of the specification's BRDF for `wo`, by the midpoint rule on an
    /// (n_μ, n_φ) grid in (cos θᵢ, φᵢ): fine enough for α ≥ 0.09.
    fn reference_albedo(c: f64, m: f64, r: f64, ior: f64, wo: [f64; 3], grid: (usize, usize)) -> f64 {
        hemisphere_quadrature(&|wi| reference_f(c, m, r, ior, wo, wi), grid)
    }

    /// The directional albedo for `wo` estimated with `n` samples of the BRDF's own sampler (f cos / pdf), checking
    /// that each sample's density is the one `pdf` reports: (mean, standard error).
    fn sampled_albedo(
        brdf: &MetallicRoughness,
        wo: [f64; 3],
        n: usize,
        uniform: &mut dyn FnMut() -> f32,
    ) -> (f64, f64) {
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
        (mean, ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt())
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
                let (mean, se) = sampled_albedo(&brdf, wo, 200_000, &mut uniform);
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

    // The extensions: the specification's formulas again in f64, for grey colours (so that an RGB channel's maximum is
    // the value itself) and one wavelength.

    /// The extensions' parameters for [`reference_ext_f`].
    #[derive(Clone, Copy, Debug)]
    struct Ext {
        c: f64,
        metallic: f64,
        roughness: f64,
        ior: f64,
        /// (weight, colour) of KHR_materials_specular.
        specular: (f64, f64),
        /// (weight, film index, thickness nm, wavelength nm) of KHR_materials_iridescence.
        iridescence: Option<(f64, f64, f64, f64)>,
        /// (colour, roughness) of KHR_materials_sheen.
        sheen: Option<(f64, f64)>,
        /// (weight, roughness) of KHR_materials_clearcoat.
        clearcoat: Option<(f64, f64)>,
    }

    const PLAIN: Ext = Ext {
        c: 0.5,
        metallic: 0.0,
        roughness: 0.5,
        ior: 1.5,
        specular: (1.0, 1.0),
        iridescence: None,
        sheen: None,
        clearcoat: None,
    };

    fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    }

    fn half(wo: [f64; 3], wi: [f64; 3]) -> [f64; 3] {
        let h = [wo[0] + wi[0], wo[1] + wi[1], wo[2] + wi[2]];
        let l = dot(h, h).sqrt();
        [h[0] / l, h[1] / l, h[2] / l]
    }

    /// D·V of GGX α = roughness² (Appendix B's specular_brdf without F).
    fn ggx_dv(roughness: f64, wo: [f64; 3], wi: [f64; 3]) -> f64 {
        let alpha = (roughness * roughness).max(MIN_ALPHA as f64);
        let a2 = alpha * alpha;
        let h = half(wo, wi);
        let d = a2 / (PI * (h[2] * h[2] * (a2 - 1.0) + 1.0).powi(2));
        let g1 = |n_x: f64| 2.0 * n_x / (n_x + (a2 + (1.0 - a2) * n_x * n_x).sqrt());
        d * g1(wo[2]) * g1(wi[2]) / (4.0 * wo[2] * wi[2])
    }

    /// Airy's reflectance of a film of index `n1`, `d` nm thick, between vacuum and a substrate of real index `n2`,
    /// at `cos0` and wavelength `lambda` nm, s and p averaged (Born & Wolf §1.6.4), written out here from the
    /// amplitudes.
    fn airy(n1: f64, d: f64, n2: f64, cos0: f64, lambda: f64) -> f64 {
        let s2 = 1.0 - cos0 * cos0;
        let c1 = (1.0 - s2 / (n1 * n1)).sqrt();
        let c2 = (1.0 - s2 / (n2 * n2)).sqrt();
        let cos_2beta = (4.0 * PI * n1 * d * c1 / lambda).cos();
        let r = |r01: f64, r12: f64| {
            (r01 * r01 + r12 * r12 + 2.0 * r01 * r12 * cos_2beta)
                / (1.0 + r01 * r01 * r12 * r12 + 2.0 * r01 * r12 * cos_2beta)
        };
        let rs = r((cos0 - n1 * c1) / (cos0 + n1 * c1), (n1 * c1 - n2 * c2) / (n1 * c1 + n2 * c2));
        let rp = r((n1 * cos0 - c1) / (n1 * cos0 + c1), (n2 * c1 - n1 * c2) / (n2 * c1 + n1 * c2));
        0.5 * (rs + rp)
    }

    fn charlie_d64(h: [f64; 3], r: f64) -> f64 {
        let inv = 1.0 / (r * r);
        (2.0 + inv) * (1.0 - h[2] * h[2]).max(0.0).powf(0.5 * inv) / (2.0 * PI)
    }

    fn charlie_lambda64(cos: f64, r: f64) -> f64 {
        let t = (1.0 - r * r).powi(2);
        let mix = |a: f64, b: f64| a * (1.0 - t) + b * t;
        let (a, b, c, d, e) = (
            mix(21.5473, 25.3245),
            mix(3.82987, 3.32435),
            mix(0.19823, 0.16801),
            mix(-1.97760, -1.27393),
            mix(-4.32054, -4.85967),
        );
        let l = |x: f64| a / (1.0 + b * x.powf(c)) + d * x + e;
        if cos < 0.5 {
            l(cos).exp()
        } else {
            (2.0 * l(0.5) - l(1.0 - cos)).exp()
        }
    }

    fn sheen64(r: f64, wo: [f64; 3], wi: [f64; 3]) -> f64 {
        let v = 1.0 / ((1.0 + charlie_lambda64(wo[2], r) + charlie_lambda64(wi[2], r)) * 4.0 * wo[2] * wi[2]);
        charlie_d64(half(wo, wi), r) * v
    }

    /// E(μ) of the sheen lobe by a fine midpoint rule in f64.
    fn sheen_e64(mu: f64, r: f64) -> f64 {
        let wo = [(1.0 - mu * mu).sqrt(), 0.0, mu];
        let (n_mu, n_phi) = (400, 400);
        let mut sum = 0.0;
        for a in 0..n_mu {
            let m = (a as f64 + 0.5) / n_mu as f64;
            let s = (1.0 - m * m).sqrt();
            for b in 0..n_phi {
                let phi = 2.0 * PI * (b as f64 + 0.5) / n_phi as f64;
                sum += sheen64(r, wo, [s * phi.cos(), s * phi.sin(), m]) * m;
            }
        }
        sum * 2.0 * PI / (n_mu * n_phi) as f64
    }

    /// The specification's BRDF with the extensions (KHR_materials_specular, _iridescence, _sheen, _clearcoat), for
    /// one wavelength, the clear coat about the shading normal; `e` is the sheen albedo E(μ, r).
    fn reference_ext_f(x: &Ext, wo: [f64; 3], wi: [f64; 3], e: &dyn Fn(f64, f64) -> f64) -> f64 {
        if wo[2] <= 0.0 || wi[2] <= 0.0 {
            return 0.0;
        }
        let h = half(wo, wi);
        let v_h = dot(wo, h);
        let w = (1.0 - v_h).powi(5);
        let dv = ggx_dv(x.roughness, wo, wi);
        let (weight, color) = x.specular;
        let f0 = (((x.ior - 1.0) / (x.ior + 1.0)).powi(2) * color).min(1.0) * weight;
        let mut fd = f0 + (weight - f0) * w;
        let mut base_weight = 1.0 - fd;
        let mut fm = x.c + (1.0 - x.c) * w;
        if let Some((t, n_film, d, lambda)) = x.iridescence {
            let to_ior = |f0: f64| {
                let s = f0.min(0.9999).sqrt();
                (1.0 + s) / (1.0 - s)
            };
            let film_d = airy(n_film, d, to_ior(f0), v_h, lambda);
            let film_m = airy(n_film, d, to_ior(x.c), v_h, lambda);
            fd = (1.0 - t) * fd + t * film_d;
            base_weight = (1.0 - t) * base_weight + t * (1.0 - film_d);
            fm = (1.0 - t) * fm + t * film_m;
        }
        let dielectric = base_weight * x.c / PI + fd * dv;
        let mut f = (1.0 - x.metallic) * dielectric + x.metallic * fm * dv;
        if let Some((color, r)) = x.sheen {
            let r = r.max(MIN_SHEEN_ROUGHNESS as f64);
            let scaling = (1.0 - color * e(wo[2], r)).min(1.0 - color * e(wi[2], r));
            f = color * sheen64(r, wo, wi) + f * scaling;
        }
        if let Some((weight, r)) = x.clearcoat {
            let fc = weight * (0.04 + 0.96 * (1.0 - wo[2]).powi(5));
            f = f * (1.0 - fc) + fc * ggx_dv(r, wo, wi);
        }
        f
    }

    /// The BRDF of `x` as the renderer builds it, at wavelengths `lambda` (the film's, for iridescence).
    fn ext_brdf(x: &Ext, lambda: [f32; 4]) -> MetallicRoughness {
        let g = |v: f64| SampledSpectrum::splat(v as f32);
        let mut b = MetallicRoughness::new(g(x.c), x.metallic as f32, x.roughness as f32, x.ior as f32).with_specular(
            x.specular.0 as f32,
            g(x.specular.1),
            x.specular.1 as f32,
        );
        if let Some((t, n_film, d, _)) = x.iridescence {
            let layer = optics::FilmLayer::new(optics::Complex::new(n_film, 0.0), d);
            let film = (d > 0.0).then(|| Box::new(CoatingAt::uniform(lambda, &[layer])));
            b = b.with_iridescence(t as f32, film);
        }
        if let Some((color, r)) = x.sheen {
            b = b.with_sheen(g(color), color as f32, r as f32);
        }
        if let Some((weight, r)) = x.clearcoat {
            b = b.with_clearcoat(weight as f32, r as f32);
        }
        b
    }

    /// Cases of the extensions, alone and together.
    fn ext_cases() -> Vec<Ext> {
        vec![
            Ext { specular: (0.5, 1.0), ..PLAIN },
            Ext { specular: (1.0, 2.5), c: 0.3, roughness: 0.3, ..PLAIN },
            Ext { specular: (0.0, 1.0), c: 0.9, ..PLAIN },
            Ext { ior: 0.0, specular: (1.0, 0.6), c: 0.2, ..PLAIN },
            Ext { iridescence: Some((1.0, 1.3, 350.0, 550.0)), c: 0.0, roughness: 0.3, ..PLAIN },
            Ext { iridescence: Some((0.6, 1.8, 250.0, 450.0)), c: 0.4, ..PLAIN },
            Ext { iridescence: Some((1.0, 1.3, 400.0, 650.0)), c: 0.8, metallic: 1.0, roughness: 0.4, ..PLAIN },
            Ext { sheen: Some((1.0, 0.5)), c: 0.6, ..PLAIN },
            Ext { sheen: Some((0.7, 0.3)), c: 0.8, metallic: 1.0, ..PLAIN },
            Ext { clearcoat: Some((1.0, 0.3)), c: 0.7, roughness: 0.8, ..PLAIN },
            Ext { clearcoat: Some((0.5, 0.4)), c: 0.9, metallic: 1.0, roughness: 0.6, ..PLAIN },
            Ext {
                specular: (0.8, 1.2),
                iridescence: Some((0.5, 1.4, 300.0, 500.0)),
                sheen: Some((0.5, 0.7)),
                clearcoat: Some((0.7, 0.2)),
                c: 0.5,
                metallic: 0.3,
                roughness: 0.5,
                ior: 1.6,
            },
        ]
    }

    /// Each extension's BRDF (and all four together) is the specifications' formula within 2e-3 (the sheen albedo
    /// is interpolated in a table), the film's reflectance Airy's.
    #[test]
    fn the_extensions_brdf_is_the_specifications() {
        for x in ext_cases() {
            let lambda = x.iridescence.map_or(550.0, |i| i.3) as f32;
            let brdf = ext_brdf(&x, [lambda; 4]);
            for (to, po, ti, pi) in [
                (0.3, 0.0, 0.5, 2.0),
                (1.2, 1.0, 0.2, 4.0),
                (0.7, 0.5, 0.7, 3.64),
                (1.4, 0.0, 1.3, 3.0),
                (0.1, 0.0, 0.1, 3.1),
            ] {
                let (wo, wi) = (dir(to, po), dir(ti, pi));
                let want = reference_ext_f(&x, wo, wi, &sheen_e64);
                let got = brdf.f(v3(wo), v3(wi))[0] as f64;
                assert!(
                    (got - want).abs() <= 2e-3 * want.max(0.05),
                    "{x:?} at {to} {ti}: f {got}, specification {want}"
                );
            }
        }
    }

    /// The sheen albedo table holds E(μ, r) of a fine quadrature within 2e-3 + 1 %.
    #[test]
    fn the_sheen_albedo_table_is_the_lobes_albedo() {
        for r in [0.07, 0.1, 0.2, 0.5, 0.8, 1.0] {
            for mu in [0.02, 0.05, 0.1, 0.2, 0.5, 0.9, 1.0] {
                let (got, want) = (sheen_albedo(mu as f32, r as f32) as f64, sheen_e64(mu, r));
                assert!((got - want).abs() < 2e-3 + 0.01 * want, "E({mu}, {r}): table {got}, quadrature {want}");
            }
        }
        // A rough sheen scatters a sizeable fraction at grazing view, and far less head-on: the lobe is the fibres'.
        assert!(sheen_albedo(0.1, 1.0) > 2.0 * sheen_albedo(1.0, 1.0));
    }

    /// With the extensions the sampler still draws from the density `pdf` reports and the sampled albedo is the
    /// quadrature of the specification's formula (as `sampled_albedo_matches_a_quadrature_of_the_specification`).
    /// A white Lambertian base without a specular layer under white sheen keeps the albedo at most 1.
    #[test]
    fn sampled_albedo_with_the_extensions_matches_a_quadrature() {
        let mut rng = rand_pcg::Pcg32::new(5, 3);
        use rand_core::RngCore;
        let mut uniform = move || (rng.next_u32() >> 8) as f32 / (1u32 << 24) as f32;
        // The sheen albedo from the table (checked against a quadrature by its own test), for speed.
        let table = |mu: f64, r: f64| f64::from(sheen_albedo(mu as f32, r as f32));
        let mut cases = ext_cases();
        cases.push(Ext { specular: (0.0, 1.0), c: 1.0, sheen: Some((1.0, 0.6)), ..PLAIN });
        for x in cases {
            let lambda = x.iridescence.map_or(550.0, |i| i.3) as f32;
            let brdf = ext_brdf(&x, [lambda; 4]);
            for theta_o in [0.3f64, 1.2] {
                let wo = dir(theta_o, 0.4);
                let quad = hemisphere_quadrature(&|wi| reference_ext_f(&x, wo, wi, &table), (300, 300));
                let (mean, se) = sampled_albedo(&brdf, wo, 100_000, &mut uniform);
                assert!(4.0 * se < 0.03 * quad, "too noisy to tell: {mean} ± {se} ({x:?})");
                // Within 4 standard errors plus 1 % for the quadrature (the narrowest lobe, α = 0.04, on its grid).
                assert!(
                    (mean - quad).abs() < 4.0 * se + 0.01 * quad,
                    "{x:?} at θo {theta_o}: sampled {mean} ± {se}, quadrature {quad}"
                );
                assert!(quad <= 1.0 + 1e-3, "{x:?}: albedo {quad} > 1");
            }
        }
    }

    /// A clear coat whose normal is tilted (the base normal-mapped, the coat not) reflects about its own normal:
    /// the coat's term is the specification's in the coat's frame, while the base's stays in the shading frame.
    #[test]
    fn a_tilted_clear_coat_reflects_about_its_own_normal() {
        let tilt = 0.3f64;
        let nc = [tilt.sin(), 0.0, tilt.cos()];
        let x = Ext { c: 0.0, specular: (0.0, 1.0), clearcoat: Some((1.0, 0.2)), ..PLAIN };
        let mut brdf = ext_brdf(&x, [550.0; 4]);
        brdf.clearcoat_mut().unwrap().normal = v3(nc);
        // Directions in the coat's frame (x' = (cos t, 0, −sin t), y' = y, z' = nc) and in the shading frame.
        let to_shading = |d: [f64; 3]| {
            let (c, s) = (tilt.cos(), tilt.sin());
            [c * d[0] + s * d[2], d[1], -s * d[0] + c * d[2]]
        };
        for (to, po, ti, pi) in [(0.4, 0.3, 0.4, 3.44), (0.2, 1.0, 0.5, 4.0), (0.6, 0.0, 0.3, 3.0)] {
            let (wo_c, wi_c) = (dir(to, po), dir(ti, pi));
            let (wo, wi) = (to_shading(wo_c), to_shading(wi_c));
            assert!(wo[2] > 0.0 && wi[2] > 0.0);
            let want = reference_ext_f(&x, wo_c, wi_c, &sheen_e64);
            let got = brdf.f(v3(wo), v3(wi))[0] as f64;
            assert!((got - want).abs() <= 2e-3 * want.max(0.05), "tilted coat: f {got}, specification {want}");
        }
    }

    /// The core BRDF with `KHR_materials_anisotropy`'s roughness written out in f64: the extension's anisotropic GGX
    /// D with α_t = mix(α, 1, s²) along the frame's x axis and α_b = α across, and Smith's separable masking with
    /// the anisotropic Λ (Heitz 2014), as the core's isotropic term has it; one wavelength of base colour `c`.
    fn reference_anisotropic_f(c: f64, m: f64, r: f64, s: f64, wo: [f64; 3], wi: [f64; 3]) -> f64 {
        let alpha = (r * r).max(MIN_ALPHA as f64);
        let (at, ab) = (alpha + (1.0 - alpha) * s * s, alpha);
        let h = [wo[0] + wi[0], wo[1] + wi[1], wo[2] + wi[2]];
        let len = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
        let h = [h[0] / len, h[1] / len, h[2] / len];
        let a2 = at * ab;
        let f = [ab * h[0], at * h[1], a2 * h[2]];
        let w2 = a2 / (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
        let d = a2 * w2 * w2 / PI;
        let lambda = |w: [f64; 3]| {
            let tan2 = (w[0] * w[0] + w[1] * w[1]) / (w[2] * w[2]);
            let sin2 = w[0] * w[0] + w[1] * w[1];
            let a2 = if sin2 > 0.0 { (at * at * w[0] * w[0] + ab * ab * w[1] * w[1]) / sin2 } else { 0.0 };
            ((1.0 + a2 * tan2).sqrt() - 1.0) / 2.0
        };
        let specular = d / ((1.0 + lambda(wo)) * (1.0 + lambda(wi)) * 4.0 * wo[2] * wi[2]);
        let v_h = wo[0] * h[0] + wo[1] * h[1] + wo[2] * h[2];
        let fresnel = |f0: f64| f0 + (1.0 - f0) * (1.0 - v_h.abs()).powi(5);
        let dielectric = (1.0 - fresnel(0.04)) * c / PI + fresnel(0.04) * specular;
        (1.0 - m) * dielectric + m * fresnel(c) * specular
    }

    /// `KHR_materials_anisotropy`: the BRDF is the reference above, stretched along x, the same under ±y and
    /// reciprocal; its sampler draws from the density it reports and its albedo is a quadrature of the reference's.
    /// Strength 0 is the isotropic BRDF exactly.
    #[test]
    fn the_anisotropic_brdf_is_the_extensions() {
        let mut rng = rand_pcg::Pcg32::new(3, 5);
        use rand_core::RngCore;
        let mut uniform = move || (rng.next_u32() >> 8) as f32 / (1u32 << 24) as f32;
        for (c, m, r, strength) in [(0.8, 1.0, 0.3, 0.8), (0.5, 0.0, 0.5, 0.6), (0.9, 0.5, 0.2, 1.0)] {
            let iso = MetallicRoughness::new(SampledSpectrum::splat(c as f32), m as f32, r as f32, 1.5);
            let brdf = iso.clone().with_anisotropy(strength as f32);
            for (to, po, ti, pi) in [(0.3, 0.0, 0.5, 3.0), (0.9, 0.4, 0.7, 3.64), (0.6, 1.6, 0.6, 4.7)] {
                let (wo, wi) = (dir(to, po), dir(ti, pi));
                let want = reference_anisotropic_f(c, m, r, strength, wo, wi);
                let got = brdf.f(v3(wo), v3(wi))[0] as f64;
                assert!(
                    (got - want).abs() <= 2e-4 * want.max(1.0),
                    "{c} {m} {r} {strength}: f {got}, reference {want}"
                );
                let back = brdf.f(v3(wi), v3(wo))[0] as f64;
                assert!((got - back).abs() <= 1e-5 * got.max(1.0), "not reciprocal: {got} {back}");
                let flip = |w: [f64; 3]| v3([w[0], -w[1], w[2]]);
                let mirrored = brdf.f(flip(wo), flip(wi))[0] as f64;
                assert!((got - mirrored).abs() <= 1e-5 * got.max(1.0), "not symmetric about x: {got} {mirrored}");
                let none = iso.clone().with_anisotropy(0.0).f(v3(wo), v3(wi))[0];
                assert_eq!(none, iso.f(v3(wo), v3(wi))[0], "strength 0 changed the BRDF");
            }
            // Stretched along x: seen head-on, light tilted along x reflects more than light tilted along y (the
            // half vector leans the way the microfacets spread).
            let along = brdf.f(v3(dir(0.0, 0.0)), v3(dir(0.8, 0.0)))[0];
            let across = brdf.f(v3(dir(0.0, 0.0)), v3(dir(0.8, PI / 2.0)))[0];
            assert!(along > across, "{along} along x, {across} across");
            let wo = dir(0.7, 0.9);
            let quad = hemisphere_quadrature(&|wi| reference_anisotropic_f(c, m, r, strength, wo, wi), (600, 600));
            let (mean, se) = sampled_albedo(&brdf, wo, 200_000, &mut uniform);
            assert!(4.0 * se < 0.015 * quad, "too noisy to tell: {mean} ± {se}");
            assert!((mean - quad).abs() < 4.0 * se + 0.002 * quad, "sampled {mean} ± {se}, quadrature {quad}");
        }
    }
}

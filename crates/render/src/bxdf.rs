//! Scattering functions (BxDFs) in the local shading frame (z = shading normal).
//!
//! The models and their sampling follow pbrt-v4 chapter 9 (diffuse, conductor, dielectric, thin dielectric); the
//! Fresnel equations come from the `optics` crate. Values are spectral: one per carried wavelength.

use glam::{Vec2, Vec3};
use spectral::{SampledSpectrum, N_WAVELENGTHS};
use std::f32::consts::FRAC_1_PI;
use std::sync::Arc;

use crate::coating::CoatingAt;
use crate::layered::Layered;
use crate::measured::MeasuredBrdf;
use crate::metallic_roughness::MetallicRoughness;
use crate::microfacet::TrowbridgeReitz;
use crate::sampling::{cosine_hemisphere_pdf, sample_cosine_hemisphere};

/// Whether the path carries radiance (from the camera) or importance (from the lights): refraction scales
/// radiance by 1/η² but not importance (Veach 1997, §5.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransportMode {
    /// Camera paths.
    Radiance,
    /// Light paths.
    Importance,
}

/// The result of sampling a BxDF.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// BxDF value for the sampled pair.
    pub f: SampledSpectrum,
    /// The incident direction (local frame).
    pub wi: Vec3,
    /// Its density (a probability for specular events).
    pub pdf: f32,
    /// True for a perfectly specular (delta) event.
    pub specular: bool,
    /// True if `wi` is on the other side of the surface from `wo`.
    pub transmission: bool,
    /// Relative index of refraction across a transmission (1 for reflection), for Russian roulette.
    pub eta: f32,
    /// True when `pdf` is only proportional to the density (stochastic layered BxDFs): `f/pdf` is still the
    /// right path weight, but MIS must ask [`Bxdf::pdf`] for the density.
    pub pdf_is_proportional: bool,
    /// For a refraction through a dispersive interface: the wavelength slot whose direction was followed; the
    /// integrator must keep only that slot ([`spectral::SampledWavelengths::keep_only`]).
    pub keep_slot: Option<usize>,
}

impl BsdfSample {
    /// A reflection sample (no change of medium, exact pdf, all wavelengths kept).
    pub fn reflection(f: SampledSpectrum, wi: Vec3, pdf: f32, specular: bool) -> Self {
        Self { f, wi, pdf, specular, transmission: false, eta: 1.0, pdf_is_proportional: false, keep_slot: None }
    }
}

/// Which lobes a restricted sampling call may choose.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lobes {
    /// Reflection and transmission.
    All,
    /// Reflection only.
    Reflection,
    /// Transmission only.
    Transmission,
}

fn same_hemisphere(a: Vec3, b: Vec3) -> bool {
    a.z * b.z > 0.0
}

/// Reflection of `wo` about `n` (`optics::reflect` in f32).
#[inline]
pub fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
    Vec3::from_array(optics::reflect(wo.to_array(), n.to_array()))
}

/// Refraction of `wi` through a surface with normal `n` and relative index `eta` = n_inside/n_outside (n on the
/// outside). Returns the transmitted direction and the relative index actually crossed, or `None` for total
/// internal reflection (`optics::refract_with_eta` in f32: Snell's law in vector form, pbrt-v4 §9.3.2).
#[inline]
pub fn refract(wi: Vec3, n: Vec3, eta: f32) -> Option<(Vec3, f32)> {
    optics::refract_with_eta(wi.to_array(), n.to_array(), eta).map(|(wt, eta)| (Vec3::from_array(wt), eta))
}

/// A conductor's reflectance at `cos_i` to the (micro)surface normal: the bare Fresnel term, or its coating's.
fn conductor_reflectance(
    cos_i: f32,
    eta: &SampledSpectrum,
    k: &SampledSpectrum,
    coating: Option<&CoatingAt>,
) -> SampledSpectrum {
    match coating {
        None => fresnel_conductor(cos_i, eta, k),
        Some(c) => c.conductor_reflectance(cos_i, eta, k),
    }
}

/// Unpolarised dielectric Fresnel reflectance (f32 wrapper of `optics::fresnel_dielectric`).
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    optics::fresnel_dielectric(cos_i as f64, eta as f64) as f32
}

/// Unpolarised conductor Fresnel reflectance per wavelength.
pub fn fresnel_conductor(cos_i: f32, eta: &SampledSpectrum, k: &SampledSpectrum) -> SampledSpectrum {
    let mut r = SampledSpectrum::zero();
    for i in 0..N_WAVELENGTHS {
        r[i] = optics::fresnel_conductor(cos_i.abs() as f64, eta[i] as f64, k[i] as f64) as f32;
    }
    r
}

/// A BxDF with its parameters already evaluated at the path's wavelengths.
#[derive(Clone, Debug)]
pub enum Bxdf {
    /// Lambertian reflection with albedo `r`.
    Diffuse {
        /// Albedo per wavelength.
        r: SampledSpectrum,
    },
    /// Lambertian reflection with albedo `r` plus Lambertian transmission to the other side with transmittance `t`
    /// (pbrt-v4's `DiffuseTransmissionBxDF`): f = r/π on the side of `wo`, t/π on the other.
    DiffuseTransmission {
        /// Reflectance per wavelength, in [0, 1].
        r: SampledSpectrum,
        /// Transmittance per wavelength, in [0, 1].
        t: SampledSpectrum,
    },
    /// A metal: complex index η + ik relative to the outside medium, smooth or Trowbridge–Reitz rough, bare or
    /// under a thin-film coating.
    Conductor {
        /// Real part of the relative index.
        eta: SampledSpectrum,
        /// Imaginary part.
        k: SampledSpectrum,
        /// Microfacet roughness.
        distrib: TrowbridgeReitz,
        /// Thin films on the metal, whose reflectance replaces the bare Fresnel term (`None`: bare).
        coating: Option<Box<CoatingAt>>,
    },
    /// A dielectric interface with relative index `eta` (inside/outside) at the path's (single) wavelength, bare or
    /// under a thin-film coating (whose reflectance and transmittance still differ per carried wavelength).
    Dielectric {
        /// Relative index of refraction.
        eta: f32,
        /// Microfacet roughness.
        distrib: TrowbridgeReitz,
        /// Thin films on the outside, whose R and T replace the bare Fresnel terms (`None`: bare).
        coating: Option<Box<CoatingAt>>,
        /// What transmitted light is multiplied by at each crossing (glTF's base colour on a transmissive
        /// material; `None`: untinted).
        tint: Option<SampledSpectrum>,
    },
    /// A smooth dielectric whose index differs per carried wavelength. Reflection keeps every wavelength (its
    /// direction does not depend on λ); refraction follows one slot chosen uniformly, which the path then keeps.
    DispersiveDielectric {
        /// Relative index per wavelength slot.
        eta: SampledSpectrum,
        /// Which slots are active.
        active: [bool; N_WAVELENGTHS],
        /// Thin films on the outside (`None`: bare).
        coating: Option<Box<CoatingAt>>,
        /// What transmitted light is multiplied by (`None`: untinted).
        tint: Option<SampledSpectrum>,
    },
    /// A diffuse or conductor base under a dielectric coating with a medium between them, evaluated by a
    /// stochastic random walk between the layers (`coateddiffuse`, `coatedconductor`).
    Layered(Box<Layered>),
    /// A thin slab: reflection plus straight-through transmission with inter-reflection summed; the Fresnel
    /// term is evaluated per wavelength because directions do not depend on η.
    ThinDielectric {
        /// Relative index per wavelength.
        eta: SampledSpectrum,
    },
    /// A free-standing thin film (a soap film in air): mirror reflection and straight-through transmission with
    /// the film's interference R and T per carried wavelength (directions do not depend on λ, so none is dropped).
    ThinFilm {
        /// The film's layers at this hit (`None`: no thickness here, so no surface: everything passes).
        film: Option<Box<CoatingAt>>,
    },
    /// glTF 2.0's metallic-roughness BRDF (its Appendix B): a Lambertian base under a GGX layer, blended with a
    /// GGX metal, with the specular, iridescence, sheen and clearcoat extensions' layers.
    MetallicRoughness(MetallicRoughness),
    /// A measured BRDF (pbrt-v4's `MeasuredBxDF`): an RGL material's tables evaluated at the path's wavelengths.
    /// The camera-side direction is the table's incident direction in both transport modes.
    Measured {
        /// The tables.
        brdf: Arc<MeasuredBrdf>,
        /// The path's wavelengths (nm), at which the reflectance table is interpolated.
        lambda: [f32; N_WAVELENGTHS],
    },
}

impl Bxdf {
    /// True if every scattering event of this BxDF is a delta distribution.
    pub fn is_specular(&self) -> bool {
        match self {
            Bxdf::Diffuse { .. } | Bxdf::DiffuseTransmission { .. } => false,
            Bxdf::Conductor { distrib, .. } => distrib.effectively_smooth(),
            // An index-matched interface passes light straight through whatever its roughness.
            Bxdf::Dielectric { eta, distrib, .. } => *eta == 1.0 || distrib.effectively_smooth(),
            Bxdf::ThinDielectric { .. } | Bxdf::ThinFilm { .. } | Bxdf::DispersiveDielectric { .. } => true,
            Bxdf::Layered(_) | Bxdf::Measured { .. } | Bxdf::MetallicRoughness(_) => false,
        }
    }

    /// A colour for albedo AOVs (denoiser guides): the diffuse albedo, a coated base's hint, a conductor's
    /// normal-incidence reflectance, and 1 for transparent dielectrics.
    pub fn albedo_hint(&self) -> SampledSpectrum {
        match self {
            Bxdf::Diffuse { r } => *r,
            Bxdf::DiffuseTransmission { r, t } => (*r + *t).map(|v| v.min(1.0)),
            Bxdf::Conductor { eta, k, coating, .. } => conductor_reflectance(1.0, eta, k, coating.as_deref()),
            Bxdf::Layered(c) => c.base_albedo(),
            Bxdf::Measured { brdf, lambda } => brdf.albedo_hint(lambda),
            Bxdf::MetallicRoughness(m) => m.albedo_hint(),
            Bxdf::Dielectric { .. }
            | Bxdf::DispersiveDielectric { .. }
            | Bxdf::ThinDielectric { .. }
            | Bxdf::ThinFilm { .. } => SampledSpectrum::splat(1.0),
        }
    }

    /// Value for the pair (`wo`, `wi`) (zero for delta components).
    pub fn f(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> SampledSpectrum {
        match self {
            Bxdf::Diffuse { r } => {
                if same_hemisphere(wo, wi) {
                    *r * FRAC_1_PI
                } else {
                    SampledSpectrum::zero()
                }
            }
            Bxdf::DiffuseTransmission { r, t } => {
                if wo.z == 0.0 || wi.z == 0.0 {
                    SampledSpectrum::zero()
                } else if same_hemisphere(wo, wi) {
                    *r * FRAC_1_PI
                } else {
                    *t * FRAC_1_PI
                }
            }
            Bxdf::Conductor { eta, k, distrib, coating } => {
                if !same_hemisphere(wo, wi) || distrib.effectively_smooth() {
                    return SampledSpectrum::zero();
                }
                let (cos_o, cos_i) = (wo.z.abs(), wi.z.abs());
                if cos_i == 0.0 || cos_o == 0.0 {
                    return SampledSpectrum::zero();
                }
                let Some(wm) = (wi + wo).try_normalize() else { return SampledSpectrum::zero() };
                let fr = conductor_reflectance(wo.dot(wm).abs(), eta, k, coating.as_deref());
                fr * (distrib.d(wm) * distrib.g(wo, wi) / (4.0 * cos_i * cos_o))
            }
            Bxdf::Dielectric { eta, distrib, coating, tint } => {
                if *eta == 1.0 || distrib.effectively_smooth() {
                    return SampledSpectrum::zero();
                }
                let f = rough_dielectric_f(*eta, distrib, coating.as_deref(), wo, wi, mode);
                match tint {
                    Some(t) if !same_hemisphere(wo, wi) => f * *t,
                    Some(_) | None => f,
                }
            }
            Bxdf::ThinDielectric { .. } | Bxdf::ThinFilm { .. } | Bxdf::DispersiveDielectric { .. } => {
                SampledSpectrum::zero()
            }
            Bxdf::Layered(c) => c.f(wo, wi, mode),
            // The camera side is the view direction V in both modes (a clear coat's Fresnel term reads V only).
            Bxdf::MetallicRoughness(m) => match mode {
                TransportMode::Radiance => m.f(wo, wi),
                TransportMode::Importance => m.f(wi, wo),
            },
            Bxdf::Measured { brdf, lambda } => match mode {
                TransportMode::Radiance => brdf.f(wo, wi, lambda),
                // wo is the light side on a light path: the camera side, wi, is the table's incident direction.
                TransportMode::Importance => brdf.f(wi, wo, lambda),
            },
        }
    }

    /// [`Bxdf::f`] and [`Bxdf::pdf`] of the same pair, the same values, computed together where that saves work
    /// (a measured BRDF inverts its warp once instead of twice in radiance mode).
    pub fn f_pdf(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> (SampledSpectrum, f32) {
        match self {
            Bxdf::Measured { brdf, lambda } => match mode {
                TransportMode::Radiance => brdf.f_pdf(wo, wi, lambda),
                TransportMode::Importance => (self.f(wo, wi, mode), self.pdf(wo, wi, mode)),
            },
            Bxdf::Diffuse { .. }
            | Bxdf::DiffuseTransmission { .. }
            | Bxdf::Conductor { .. }
            | Bxdf::Dielectric { .. }
            | Bxdf::DispersiveDielectric { .. }
            | Bxdf::Layered(_)
            | Bxdf::ThinDielectric { .. }
            | Bxdf::ThinFilm { .. }
            | Bxdf::MetallicRoughness(_) => (self.f(wo, wi, mode), self.pdf(wo, wi, mode)),
        }
    }

    /// True if [`Bxdf::f_pdf`] is cheaper than [`Bxdf::f`] and [`Bxdf::pdf`] apart, so a caller that may not need
    /// the density should still ask for both.
    pub fn joint_f_pdf(&self) -> bool {
        matches!(self, Bxdf::Measured { .. })
    }

    /// Density of sampling `wi` given `wo` with [`Bxdf::sample_f`] (zero for delta components).
    pub fn pdf(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> f32 {
        self.pdf_lobes(wo, wi, mode, Lobes::All)
    }

    /// Density of [`Bxdf::sample_f_lobes`] restricted to `lobes`.
    pub fn pdf_lobes(&self, wo: Vec3, wi: Vec3, mode: TransportMode, lobes: Lobes) -> f32 {
        let reflection = same_hemisphere(wo, wi);
        if (reflection && lobes == Lobes::Transmission) || (!reflection && lobes == Lobes::Reflection) {
            return 0.0;
        }
        match self {
            Bxdf::Diffuse { .. } => {
                if same_hemisphere(wo, wi) {
                    cosine_hemisphere_pdf(wi.z.abs())
                } else {
                    0.0
                }
            }
            Bxdf::DiffuseTransmission { r, t } => {
                if wo.z == 0.0 || wi.z == 0.0 {
                    return 0.0;
                }
                let (pr, pt) = lobe_weights(r.max_value(), t.max_value(), lobes);
                if pr + pt <= 0.0 {
                    return 0.0;
                }
                let p_lobe = if reflection { pr } else { pt } / (pr + pt);
                p_lobe * cosine_hemisphere_pdf(wi.z.abs())
            }
            Bxdf::Conductor { distrib, .. } => {
                if !same_hemisphere(wo, wi) || distrib.effectively_smooth() {
                    return 0.0;
                }
                let Some(wm) = (wo + wi).try_normalize() else { return 0.0 };
                let wm = if wm.z < 0.0 { -wm } else { wm };
                distrib.pdf(wo, wm) / (4.0 * wo.dot(wm).abs())
            }
            Bxdf::Dielectric { eta, distrib, coating, .. } => {
                if *eta == 1.0 || distrib.effectively_smooth() {
                    return 0.0;
                }
                rough_dielectric_pdf(*eta, distrib, coating.as_deref(), wo, wi, lobes)
            }
            Bxdf::ThinDielectric { .. } | Bxdf::ThinFilm { .. } | Bxdf::DispersiveDielectric { .. } => 0.0,
            Bxdf::Layered(c) => c.pdf(wo, wi, mode),
            Bxdf::MetallicRoughness(m) => m.pdf(wo, wi),
            // Sampling always starts from wo, so its density is indexed by wo in both modes.
            Bxdf::Measured { brdf, .. } => brdf.pdf(wo, wi),
        }
    }

    /// Samples an incident direction for `wo` with the 1D sample `uc` (component choice) and 2D sample `u`.
    pub fn sample_f(&self, wo: Vec3, uc: f32, u: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        self.sample_f_lobes(wo, uc, u, mode, Lobes::All)
    }

    /// [`Bxdf::sample_f`] restricted to reflection or transmission (used inside layered BxDFs).
    pub fn sample_f_lobes(&self, wo: Vec3, uc: f32, u: Vec2, mode: TransportMode, lobes: Lobes) -> Option<BsdfSample> {
        match self {
            Bxdf::Diffuse { .. } | Bxdf::Conductor { .. } | Bxdf::Measured { .. } | Bxdf::MetallicRoughness(_)
                if lobes == Lobes::Transmission =>
            {
                None
            }
            Bxdf::MetallicRoughness(m) => {
                let (f, wi, pdf) = m.sample(wo, uc, u)?;
                let f = match mode {
                    TransportMode::Radiance => f,
                    TransportMode::Importance => m.f(wi, wo),
                };
                Some(BsdfSample::reflection(f, wi, pdf, false))
            }
            Bxdf::Measured { brdf, lambda } => {
                let (wi, f_cos, pdf) = brdf.sample(wo, u, lambda)?;
                let f = match mode {
                    TransportMode::Radiance => f_cos * (1.0 / wi.z.abs()),
                    TransportMode::Importance => brdf.f(wi, wo, lambda),
                };
                Some(BsdfSample::reflection(f, wi, pdf, false))
            }
            Bxdf::Diffuse { r } => {
                let mut wi = sample_cosine_hemisphere(u);
                if wo.z < 0.0 {
                    wi.z = -wi.z;
                }
                let pdf = cosine_hemisphere_pdf(wi.z.abs());
                (pdf > 0.0).then(|| BsdfSample::reflection(*r * FRAC_1_PI, wi, pdf, false))
            }
            Bxdf::DiffuseTransmission { r, t } => sample_diffuse_transmission(r, t, wo, uc, u, lobes),
            Bxdf::Conductor { eta, k, distrib, coating } => {
                if distrib.effectively_smooth() {
                    let wi = Vec3::new(-wo.x, -wo.y, wo.z);
                    let c = wi.z.abs();
                    if c == 0.0 {
                        return None;
                    }
                    let f = conductor_reflectance(c, eta, k, coating.as_deref()) * (1.0 / c);
                    return Some(BsdfSample::reflection(f, wi, 1.0, true));
                }
                if wo.z == 0.0 {
                    return None;
                }
                let wm = distrib.sample_wm(wo, u);
                let wi = reflect(wo, wm);
                if !same_hemisphere(wo, wi) {
                    return None;
                }
                let pdf = distrib.pdf(wo, wm) / (4.0 * wo.dot(wm).abs());
                let (cos_o, cos_i) = (wo.z.abs(), wi.z.abs());
                if cos_i == 0.0 || cos_o == 0.0 || pdf <= 0.0 {
                    return None;
                }
                let fr = conductor_reflectance(wo.dot(wm).abs(), eta, k, coating.as_deref());
                let f = fr * (distrib.d(wm) * distrib.g(wo, wi) / (4.0 * cos_i * cos_o));
                Some(BsdfSample::reflection(f, wi, pdf, false))
            }
            Bxdf::Dielectric { eta, distrib, coating, tint } => {
                sample_dielectric(*eta, distrib, coating.as_deref(), wo, uc, u, mode, lobes).map(|s| tinted(s, tint))
            }
            Bxdf::Layered(c) => c.sample_f(wo, uc, u, mode),
            Bxdf::DispersiveDielectric { eta, active, coating, tint } => {
                sample_dispersive(eta, active, coating.as_deref(), wo, uc, mode, lobes).map(|s| tinted(s, tint))
            }
            Bxdf::ThinFilm { film } => {
                let (r, t) = match film {
                    Some(film) => film.free_film_reflectance_transmittance(wo.z),
                    None => (SampledSpectrum::zero(), SampledSpectrum::splat(1.0)),
                };
                sample_thin(r, t, wo, uc, lobes, FILM_MIN_EVENT_PROBABILITY)
            }
            Bxdf::ThinDielectric { eta } => {
                let mut r = SampledSpectrum::zero();
                for i in 0..N_WAVELENGTHS {
                    let r0 = fresnel_dielectric(wo.z.abs(), eta[i]);
                    // Sum of the inter-reflections inside the slab: R' = R + T²R/(1 − R²).
                    r[i] = if r0 < 1.0 { r0 + (1.0 - r0) * (1.0 - r0) * r0 / (1.0 - r0 * r0) } else { 1.0 };
                }
                let t = SampledSpectrum::splat(1.0) - r;
                sample_thin(r, t, wo, uc, lobes, 0.0)
            }
        }
    }
}

/// The least probability with which a free-standing film or a coated dielectric picks reflection or transmission
/// (defensive sampling). A film or coating exists to change what a surface reflects, often a few per cent, and its
/// colour is the point: chosen by R alone, that reflection - of a bright sky, a softbox, the sheen of a bubble -
/// would come from few samples with large, per-wavelength weights (colour noise). Unbiased either way.
const FILM_MIN_EVENT_PROBABILITY: f32 = 0.25;

/// The probability of reflecting at a surface of reflectance `r` and transmittance `t` (means over the slots, or
/// one slot's): r/(r + t), kept between `floor` and 1 − `floor` where both events are possible (0 or 1 where one is
/// not). A floor of 0 is the proportional choice, pbrt-v4's.
fn reflect_probability(r: f32, t: f32, floor: f32) -> f32 {
    if r <= 0.0 || t <= 0.0 {
        return if r > 0.0 { 1.0 } else { 0.0 };
    }
    (r / (r + t)).clamp(floor, 1.0 - floor)
}

/// A thin sheet's mirror reflection or straight-through transmission, with reflectance `r` and transmittance `t`
/// per slot, chosen by their means over the slots, each event with probability at least `floor` where both are
/// possible (each slot then weighs Rᵢ/P or Tᵢ/(1 − P)).
fn sample_thin(
    r: SampledSpectrum,
    t: SampledSpectrum,
    wo: Vec3,
    uc: f32,
    lobes: Lobes,
    floor: f32,
) -> Option<BsdfSample> {
    let (pr, pt) = lobe_weights(r.average(), t.average(), lobes);
    if pr + pt <= 0.0 {
        return None;
    }
    let c = wo.z.abs();
    if c == 0.0 {
        return None;
    }
    let p_reflect = reflect_probability(pr, pt, floor);
    if uc < p_reflect {
        let wi = Vec3::new(-wo.x, -wo.y, wo.z);
        Some(BsdfSample::reflection(r * (1.0 / c), wi, p_reflect, true))
    } else {
        Some(BsdfSample {
            f: t * (1.0 / c),
            wi: -wo,
            pdf: 1.0 - p_reflect,
            specular: true,
            transmission: true,
            eta: 1.0,
            pdf_is_proportional: false,
            keep_slot: None,
        })
    }
}

/// Diffuse reflection or transmission, chosen in proportion to the largest value of each over the carried
/// wavelengths (as pbrt-v4 does), then a cosine-weighted direction on the chosen side of the surface.
fn sample_diffuse_transmission(
    r: &SampledSpectrum,
    t: &SampledSpectrum,
    wo: Vec3,
    uc: f32,
    u: Vec2,
    lobes: Lobes,
) -> Option<BsdfSample> {
    let (pr, pt) = lobe_weights(r.max_value(), t.max_value(), lobes);
    if pr + pt <= 0.0 || wo.z == 0.0 {
        return None;
    }
    let mut wi = sample_cosine_hemisphere(u);
    let reflect = uc < pr / (pr + pt);
    // Reflection stays on the side of wo; transmission goes to the other side.
    if (wo.z < 0.0) == reflect {
        wi.z = -wi.z;
    }
    let cos_pdf = cosine_hemisphere_pdf(wi.z.abs());
    if cos_pdf <= 0.0 {
        return None;
    }
    if reflect {
        Some(BsdfSample::reflection(*r * FRAC_1_PI, wi, cos_pdf * pr / (pr + pt), false))
    } else {
        Some(BsdfSample {
            f: *t * FRAC_1_PI,
            wi,
            pdf: cos_pdf * pt / (pr + pt),
            specular: false,
            transmission: true,
            eta: 1.0,
            pdf_is_proportional: false,
            keep_slot: None,
        })
    }
}

/// A smooth dielectric interface's reflectance and transmittance per slot at `cos_i` (negative from inside), and
/// the probability of reflecting that sampling gives each slot: R for a bare interface, [`reflect_probability`]'s
/// for a coated one.
fn dispersive_rt(
    eta: &SampledSpectrum,
    active: &[bool; N_WAVELENGTHS],
    coating: Option<&CoatingAt>,
    cos_i: f32,
) -> (SampledSpectrum, SampledSpectrum, SampledSpectrum) {
    let mut r = SampledSpectrum::zero();
    let mut t = SampledSpectrum::zero();
    let mut p = SampledSpectrum::zero();
    match coating {
        None => {
            for i in 0..N_WAVELENGTHS {
                if active[i] {
                    r[i] = fresnel_dielectric(cos_i, eta[i]);
                    (t[i], p[i]) = (1.0 - r[i], r[i]);
                }
            }
        }
        Some(c) => {
            let (cr, ct) = c.dielectric_reflectance_transmittance(cos_i, eta);
            for i in 0..N_WAVELENGTHS {
                if active[i] && cr[i] + ct[i] > 0.0 {
                    (r[i], t[i], p[i]) = (cr[i], ct[i], reflect_probability(cr[i], ct[i], FILM_MIN_EVENT_PROBABILITY));
                }
            }
        }
    }
    (r, t, p)
}

/// Smooth dispersive interface. A slot j is drawn uniformly from the k active ones (from `uc`), and reflection is
/// chosen with probability pⱼ (R(λj) for a bare interface; see [`dispersive_rt`]). Reflection is an event of
/// marginal probability P = (1/k)·Σj pⱼ whose direction is shared by all wavelengths, so every slot keeps its own
/// R(λi)/P. Refraction through slot j has probability (1/k)·(1 − pⱼ) and weight T(λj)/(1 − pⱼ); the returned pdf is
/// 1 − pⱼ and the integrator divides slot j's density by k when it keeps it.
fn sample_dispersive(
    eta: &SampledSpectrum,
    active: &[bool; N_WAVELENGTHS],
    coating: Option<&CoatingAt>,
    wo: Vec3,
    uc: f32,
    mode: TransportMode,
    lobes: Lobes,
) -> Option<BsdfSample> {
    let k = active.iter().filter(|&&a| a).count();
    if k == 0 || wo.z == 0.0 {
        return None;
    }
    let (r, t, p) = dispersive_rt(eta, active, coating, wo.z);
    // The probability of a reflection: each active slot is picked with probability 1/k and then reflects with
    // probability p, so the mean of p over the active slots.
    let mut mean_p = 0.0;
    for i in 0..N_WAVELENGTHS {
        if active[i] {
            mean_p += p[i] / k as f32;
        }
    }
    let x = uc * k as f32;
    let pick = (x as usize).min(k - 1);
    let u_event = x - pick as f32;
    let j = (0..N_WAVELENGTHS).filter(|&i| active[i]).nth(pick)?;
    // The slot's probability of reflecting (R for a bare interface, so 1 − p is its T).
    let (pr, pt) = lobe_weights(p[j], 1.0 - p[j], lobes);
    if pr + pt <= 0.0 {
        return None;
    }
    if u_event < pr / (pr + pt) {
        let wi = Vec3::new(-wo.x, -wo.y, wo.z);
        let p_reflect = match lobes {
            Lobes::Reflection => 1.0,
            Lobes::All | Lobes::Transmission => mean_p,
        };
        if p_reflect <= 0.0 {
            return None;
        }
        Some(BsdfSample::reflection(r * (1.0 / wi.z.abs()), wi, p_reflect, true))
    } else {
        smooth_transmission(wo, eta[j], SampledSpectrum::splat(t[j]), pt / (pr + pt), mode, Some(j))
    }
}

/// The outcome of sampling a smooth dispersive interface without dropping wavelengths
/// ([`Bxdf::sample_dispersive_split`]).
#[derive(Clone, Debug)]
pub enum DispersiveSplit {
    /// A mirror reflection, which keeps every wavelength.
    Reflection(BsdfSample),
    /// A refraction of every active slot along its own direction (`None` where that slot is totally reflected);
    /// each sample's `keep_slot` names its slot, and its `pdf` is the probability of refracting at all.
    Refraction([Option<BsdfSample>; N_WAVELENGTHS]),
}

impl Bxdf {
    /// Samples a smooth dispersive interface carrying several wavelengths by splitting instead of selecting: with
    /// probability P̄ (the mean over the active slots of their probability of reflecting, which for a bare interface
    /// is the Fresnel reflectance) a mirror reflection of all of them, slot i with weight Rᵢ/P̄, and otherwise a
    /// refraction of *every* active slot, slot i with weight Tᵢ/(1 − P̄) along its own direction, so
    /// that the path continues once per wavelength and none is dropped (the expectation per slot is Rᵢ·L_R + Tᵢ·L_Tᵢ,
    /// as for [`Bxdf::sample_f`], whose refraction keeps one slot chosen uniformly at k times the weight). `None`
    /// for other BxDFs and when at most one slot is active.
    pub fn sample_dispersive_split(&self, wo: Vec3, uc: f32, mode: TransportMode) -> Option<DispersiveSplit> {
        let Bxdf::DispersiveDielectric { eta, active, coating, tint } = self else { return None };
        let k = active.iter().filter(|&&a| a).count();
        if k < 2 || wo.z == 0.0 {
            return None;
        }
        let (r, t, p) = dispersive_rt(eta, active, coating.as_deref(), wo.z);
        let mut mean_p = 0.0;
        for i in 0..N_WAVELENGTHS {
            if active[i] {
                mean_p += p[i] / k as f32;
            }
        }
        if uc < mean_p {
            let wi = Vec3::new(-wo.x, -wo.y, wo.z);
            return Some(DispersiveSplit::Reflection(BsdfSample::reflection(r * (1.0 / wi.z.abs()), wi, mean_p, true)));
        }
        let p_refract = 1.0 - mean_p;
        if p_refract <= 0.0 {
            return None;
        }
        Some(DispersiveSplit::Refraction(std::array::from_fn(|i| {
            if active[i] && t[i] > 0.0 {
                let t = SampledSpectrum::splat(t[i]) * tint.unwrap_or(SampledSpectrum::splat(1.0));
                smooth_transmission(wo, eta[i], t, p_refract, mode, Some(i))
            } else {
                None
            }
        })))
    }
}

/// A dielectric's sample with its transmission multiplied by `tint`.
fn tinted(mut s: BsdfSample, tint: &Option<SampledSpectrum>) -> BsdfSample {
    if let (true, Some(t)) = (s.transmission, tint) {
        s.f *= *t;
    }
    s
}

/// Refraction through a smooth interface of relative index `eta` with transmittance `t` per slot, chosen with
/// probability `pdf`: f = T/|cos θi|, divided by η² for radiance (pbrt-v4 §9.3.5, non-symmetric scattering).
fn smooth_transmission(
    wo: Vec3,
    eta: f32,
    t: SampledSpectrum,
    pdf: f32,
    mode: TransportMode,
    keep_slot: Option<usize>,
) -> Option<BsdfSample> {
    let (wi, etap) = refract(wo, Vec3::Z, eta)?;
    if wi.z == 0.0 {
        return None;
    }
    let f = t.map(|t| {
        let ft = t / wi.z.abs();
        if mode == TransportMode::Radiance {
            ft / (etap * etap)
        } else {
            ft
        }
    });
    Some(BsdfSample {
        f,
        wi,
        pdf,
        specular: true,
        transmission: true,
        eta: etap,
        pdf_is_proportional: false,
        keep_slot,
    })
}

fn lobe_weights(r: f32, t: f32, lobes: Lobes) -> (f32, f32) {
    match lobes {
        Lobes::All => (r, t),
        Lobes::Reflection => (r, 0.0),
        Lobes::Transmission => (0.0, t),
    }
}

/// A dielectric interface's reflectance and transmittance per slot at `cos_i` to the (micro)normal (negative from
/// inside), bare or coated, with the scalars that choose between reflection and refraction: R and 1 − R for a bare
/// interface (as pbrt-v4), for a coated one [`reflect_probability`] of the means over the slots with the film's
/// floor (each slot then weighs Rᵢ/P or Tᵢ/(1 − P)).
struct InterfaceRt {
    r: SampledSpectrum,
    t: SampledSpectrum,
    pr: f32,
    pt: f32,
}

fn interface_rt(cos_i: f32, eta: f32, coating: Option<&CoatingAt>) -> InterfaceRt {
    match coating {
        None => {
            let f = fresnel_dielectric(cos_i, eta);
            InterfaceRt { r: SampledSpectrum::splat(f), t: SampledSpectrum::splat(1.0 - f), pr: f, pt: 1.0 - f }
        }
        Some(c) => {
            let (r, t) = c.dielectric_reflectance_transmittance(cos_i, &SampledSpectrum::splat(eta));
            let p = reflect_probability(r.average(), t.average(), FILM_MIN_EVENT_PROBABILITY);
            InterfaceRt { r, t, pr: p, pt: 1.0 - p }
        }
    }
}

#[allow(clippy::too_many_arguments)]
fn sample_dielectric(
    eta: f32,
    distrib: &TrowbridgeReitz,
    coating: Option<&CoatingAt>,
    wo: Vec3,
    uc: f32,
    u: Vec2,
    mode: TransportMode,
    lobes: Lobes,
) -> Option<BsdfSample> {
    if eta == 1.0 || distrib.effectively_smooth() {
        // Smooth interface: choose reflection or transmission by R and T (with the film's floor when coated).
        let rt = interface_rt(wo.z, eta, coating);
        let (r, t) = lobe_weights(rt.pr, rt.pt, lobes);
        if r + t <= 0.0 || wo.z == 0.0 {
            return None;
        }
        if uc < r / (r + t) {
            let wi = Vec3::new(-wo.x, -wo.y, wo.z);
            let f = rt.r.map(|v| v / wi.z.abs());
            Some(BsdfSample::reflection(f, wi, r / (r + t), true))
        } else {
            smooth_transmission(wo, eta, rt.t, t / (r + t), mode, None)
        }
    } else {
        // Rough interface (Walter et al. 2007): sample a visible microfacet normal, then reflect or refract.
        let wm = distrib.sample_wm(wo, u);
        let rt = interface_rt(wo.dot(wm), eta, coating);
        let (r, t) = lobe_weights(rt.pr, rt.pt, lobes);
        if r + t <= 0.0 {
            return None;
        }
        if uc < r / (r + t) {
            let wi = reflect(wo, wm);
            if !same_hemisphere(wo, wi) {
                return None;
            }
            let pdf = distrib.pdf(wo, wm) / (4.0 * wo.dot(wm).abs()) * r / (r + t);
            let dg = distrib.d(wm) * distrib.g(wo, wi);
            let denom = (4.0 * wi.z * wo.z).abs();
            let f = rt.r.map(|v| dg * v / denom);
            (pdf > 0.0).then(|| BsdfSample::reflection(f, wi, pdf, false))
        } else {
            let (wi, etap) = refract(wo, wm, eta)?;
            if same_hemisphere(wo, wi) || wi.z == 0.0 {
                return None;
            }
            let denom = (wi.dot(wm) + wo.dot(wm) / etap).powi(2);
            let dwm_dwi = wi.dot(wm).abs() / denom;
            let pdf = distrib.pdf(wo, wm) * dwm_dwi * t / (r + t);
            let (d, g) = (distrib.d(wm), distrib.g(wo, wi));
            let geometry = (wi.dot(wm) * wo.dot(wm) / (wi.z * wo.z * denom)).abs();
            let ft = rt.t.map(|v| {
                let ft = v * d * g * geometry;
                if mode == TransportMode::Radiance {
                    ft / (etap * etap)
                } else {
                    ft
                }
            });
            (pdf > 0.0 && ft.0.iter().all(|v| v.is_finite())).then_some(BsdfSample {
                f: ft,
                wi,
                pdf,
                specular: false,
                transmission: true,
                eta: etap,
                pdf_is_proportional: false,
                keep_slot: None,
            })
        }
    }
}

/// The generalised half vector of a rough dielectric pair, or `None` when the configuration has no valid
/// microfacet (Walter et al. 2007, eq. 16; back-facing microfacets discarded).
fn dielectric_half_vector(eta: f32, wo: Vec3, wi: Vec3) -> Option<(Vec3, f32, bool)> {
    let (cos_o, cos_i) = (wo.z, wi.z);
    if cos_o == 0.0 || cos_i == 0.0 {
        return None;
    }
    let reflect = cos_o * cos_i > 0.0;
    let etap = if reflect {
        1.0
    } else if cos_o > 0.0 {
        eta
    } else {
        1.0 / eta
    };
    let wm = (wi * etap + wo).try_normalize()?;
    let wm = if wm.z < 0.0 { -wm } else { wm };
    if wm.dot(wi) * cos_i < 0.0 || wm.dot(wo) * cos_o < 0.0 {
        return None;
    }
    Some((wm, etap, reflect))
}

fn rough_dielectric_f(
    eta: f32,
    distrib: &TrowbridgeReitz,
    coating: Option<&CoatingAt>,
    wo: Vec3,
    wi: Vec3,
    mode: TransportMode,
) -> SampledSpectrum {
    let Some((wm, etap, reflect)) = dielectric_half_vector(eta, wo, wi) else { return SampledSpectrum::zero() };
    let rt = interface_rt(wo.dot(wm), eta, coating);
    if reflect {
        let dg = distrib.d(wm) * distrib.g(wo, wi);
        let denom = (4.0 * wi.z * wo.z).abs();
        rt.r.map(|v| dg * v / denom)
    } else {
        let denom = (wi.dot(wm) + wo.dot(wm) / etap).powi(2) * wi.z * wo.z;
        let (d, g) = (distrib.d(wm), distrib.g(wo, wi));
        let geometry = (wi.dot(wm) * wo.dot(wm) / denom).abs();
        rt.t.map(|v| {
            let ft = d * v * g * geometry;
            if mode == TransportMode::Radiance {
                ft / (etap * etap)
            } else {
                ft
            }
        })
    }
}

fn rough_dielectric_pdf(
    eta: f32,
    distrib: &TrowbridgeReitz,
    coating: Option<&CoatingAt>,
    wo: Vec3,
    wi: Vec3,
    lobes: Lobes,
) -> f32 {
    let Some((wm, etap, reflect)) = dielectric_half_vector(eta, wo, wi) else { return 0.0 };
    let rt = interface_rt(wo.dot(wm), eta, coating);
    let (r, t) = lobe_weights(rt.pr, rt.pt, lobes);
    if r + t <= 0.0 {
        return 0.0;
    }
    if reflect {
        distrib.pdf(wo, wm) / (4.0 * wo.dot(wm).abs()) * r / (r + t)
    } else {
        let denom = (wi.dot(wm) + wo.dot(wm) / etap).powi(2);
        let dwm_dwi = wi.dot(wm).abs() / denom;
        distrib.pdf(wo, wm) * dwm_dwi * t / (r + t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::sample_uniform_sphere;
    use rand_core::{RngCore, SeedableRng};
    use rand_pcg::Pcg32;

    fn uniform(rng: &mut Pcg32) -> f32 {
        (rng.next_u32() >> 8) as f32 / (1u32 << 24) as f32
    }

    /// Monte Carlo albedo ∫ f |cos θi| dωi estimated by sampling the BxDF itself.
    fn albedo(b: &Bxdf, wo: Vec3, n: usize) -> f32 {
        let mut rng = Pcg32::seed_from_u64(7);
        let mut sum = 0.0;
        for _ in 0..n {
            if let Some(s) = b.sample_f(
                wo,
                uniform(&mut rng),
                Vec2::new(uniform(&mut rng), uniform(&mut rng)),
                TransportMode::Importance,
            ) {
                sum += s.f[0] * s.wi.z.abs() / s.pdf;
            }
        }
        sum / n as f32
    }

    /// Checks that sample_f's value and pdf agree with f() and pdf() for non-specular samples.
    fn consistent(b: &Bxdf, wo: Vec3) {
        let mut rng = Pcg32::seed_from_u64(11);
        for _ in 0..2000 {
            let Some(s) = b.sample_f(
                wo,
                uniform(&mut rng),
                Vec2::new(uniform(&mut rng), uniform(&mut rng)),
                TransportMode::Radiance,
            ) else {
                continue;
            };
            if s.specular {
                continue;
            }
            let f = b.f(wo, s.wi, TransportMode::Radiance)[0];
            let pdf = b.pdf(wo, s.wi, TransportMode::Radiance);
            assert!((f - s.f[0]).abs() <= 2e-3 * f.max(1e-3), "f {f} vs sampled {}", s.f[0]);
            assert!((pdf - s.pdf).abs() <= 2e-3 * pdf.max(1e-3), "pdf {pdf} vs sampled {}", s.pdf);
        }
    }

    #[test]
    fn diffuse_albedo_is_r() {
        let b = Bxdf::Diffuse { r: SampledSpectrum::splat(0.6) };
        assert!((albedo(&b, Vec3::new(0.3, 0.2, 0.93).normalize(), 20_000) - 0.6).abs() < 1e-4);
        consistent(&b, Vec3::new(0.3, 0.2, -0.93).normalize());
    }

    /// Mean and standard error of `n` values of `g`.
    fn mean_se(n: usize, mut g: impl FnMut() -> f64) -> (f64, f64) {
        let (mut s, mut s2) = (0.0, 0.0);
        for _ in 0..n {
            let v = g();
            s += v;
            s2 += v * v;
        }
        let m = s / n as f64;
        (m, ((s2 / n as f64 - m * m).max(0.0) / (n as f64 - 1.0)).sqrt())
    }

    fn chromatic_diffuse_transmission() -> Bxdf {
        Bxdf::DiffuseTransmission {
            r: SampledSpectrum([0.1, 0.5, 0.9, 0.3]),
            t: SampledSpectrum([0.6, 0.2, 0.05, 0.7]),
        }
    }

    /// ∫ f |cos θi| dωi over each side of the surface is the reflectance on the side of wo and the transmittance on
    /// the other, per wavelength: once with directions drawn uniformly over the sphere (which checks `f` alone) and
    /// once with the BxDF's own sampling (which checks `sample_f`'s weights). Tolerance: 5 standard errors, each
    /// asserted below 1% of the value.
    #[test]
    fn diffuse_transmission_integrates_to_its_reflectance_and_transmittance() {
        let b = chromatic_diffuse_transmission();
        let Bxdf::DiffuseTransmission { r, t } = b.clone() else { unreachable!() };
        for wo in [Vec3::new(0.3, 0.2, 0.93).normalize(), Vec3::new(-0.7, 0.1, -0.2).normalize()] {
            for slot in 0..N_WAVELENGTHS {
                for (reflect, expected) in [(true, r[slot]), (false, t[slot])] {
                    let side = |wi: Vec3| same_hemisphere(wo, wi) == reflect;
                    let mut rng = Pcg32::seed_from_u64(3 + slot as u64);
                    let (m, se) = mean_se(200_000, || {
                        let wi = sample_uniform_sphere(Vec2::new(uniform(&mut rng), uniform(&mut rng)));
                        if !side(wi) {
                            return 0.0;
                        }
                        (b.f(wo, wi, TransportMode::Radiance)[slot] * wi.z.abs() * 4.0 * std::f32::consts::PI) as f64
                    });
                    assert!(se < 0.01 * expected as f64, "uniform: {se}");
                    assert!((m - expected as f64).abs() < 5.0 * se, "uniform, {wo}, slot {slot}: {m} ± {se}");
                    let mut rng = Pcg32::seed_from_u64(5 + slot as u64);
                    let (m, se) = mean_se(200_000, || {
                        let u = Vec2::new(uniform(&mut rng), uniform(&mut rng));
                        match b.sample_f(wo, uniform(&mut rng), u, TransportMode::Radiance) {
                            Some(s) if side(s.wi) => {
                                assert_eq!(s.transmission, !reflect);
                                (s.f[slot] * s.wi.z.abs() / s.pdf) as f64
                            }
                            _ => 0.0,
                        }
                    });
                    assert!(se < 0.01 * expected as f64, "sampled: {se}");
                    assert!((m - expected as f64).abs() < 5.0 * se, "sampled, {wo}, slot {slot}: {m} ± {se}");
                }
            }
        }
    }

    /// Lambertian reflection and transmission are reciprocal, f(wo, wi) = f(wi, wo), and the same in both transport
    /// modes (no η² factor: the surface does not change the index); sampled values and densities match `f`, `pdf`.
    #[test]
    fn diffuse_transmission_is_reciprocal_and_consistent() {
        let b = chromatic_diffuse_transmission();
        let mut rng = Pcg32::seed_from_u64(9);
        for _ in 0..1000 {
            let wo = sample_uniform_sphere(Vec2::new(uniform(&mut rng), uniform(&mut rng)));
            let wi = sample_uniform_sphere(Vec2::new(uniform(&mut rng), uniform(&mut rng)));
            let f = b.f(wo, wi, TransportMode::Radiance);
            assert_eq!(f.0, b.f(wi, wo, TransportMode::Radiance).0);
            assert_eq!(f.0, b.f(wo, wi, TransportMode::Importance).0);
        }
        consistent(&b, Vec3::new(0.3, 0.2, 0.93).normalize());
        consistent(&b, Vec3::new(0.3, -0.6, -0.4).normalize());
    }

    /// Pearson's χ² of `n` directions drawn by `b.sample_f` for `wo` against `b.pdf` over 24 × 16 bins in (cos θ, φ)
    /// covering the whole sphere; each bin's expected count integrates the density on an 8 × 8 grid of midpoints
    /// (dω = d cos θ dφ). Bins expecting fewer than 20 draws are pooled. Returns (χ², degrees of freedom).
    fn chi_square(b: &Bxdf, pdf_of: &Bxdf, wo: Vec3, n: usize) -> (f64, usize) {
        const NZ: usize = 24;
        const NP: usize = 16;
        const SUB: usize = 8;
        let two_pi = 2.0 * std::f64::consts::PI;
        let cell = |w: Vec3| {
            let iz = (((w.z as f64 + 1.0) / 2.0 * NZ as f64) as usize).min(NZ - 1);
            let phi = (w.y as f64).atan2(w.x as f64).rem_euclid(two_pi);
            let ip = ((phi / two_pi * NP as f64) as usize).min(NP - 1);
            iz * NP + ip
        };
        let mut expected = vec![0.0; NZ * NP];
        for iz in 0..NZ {
            for ip in 0..NP {
                let (dz, dp) = (2.0 / (NZ * SUB) as f64, two_pi / (NP * SUB) as f64);
                let mut mass = 0.0;
                for a in 0..SUB {
                    for c in 0..SUB {
                        let z = -1.0 + (iz * SUB + a) as f64 * dz + 0.5 * dz;
                        let phi = (ip * SUB + c) as f64 * dp + 0.5 * dp;
                        let sin = (1.0 - z * z).max(0.0).sqrt();
                        let wi = Vec3::new((sin * phi.cos()) as f32, (sin * phi.sin()) as f32, z as f32);
                        mass += pdf_of.pdf(wo, wi, TransportMode::Radiance) as f64 * dz * dp;
                    }
                }
                expected[iz * NP + ip] = mass * n as f64;
            }
        }
        let mut observed = vec![0.0; NZ * NP];
        let mut rng = Pcg32::seed_from_u64(17);
        for _ in 0..n {
            let u = Vec2::new(uniform(&mut rng), uniform(&mut rng));
            if let Some(s) = b.sample_f(wo, uniform(&mut rng), u, TransportMode::Radiance) {
                observed[cell(s.wi)] += 1.0;
            }
        }
        let (mut chi2, mut dof) = (0.0, 0usize);
        let (mut o_acc, mut e_acc) = (0.0, 0.0);
        for (o, e) in observed.iter().zip(&expected) {
            if *e < 20.0 {
                (o_acc, e_acc) = (o_acc + o, e_acc + e);
            } else {
                chi2 += (o - e) * (o - e) / e;
                dof += 1;
            }
        }
        if e_acc > 0.0 {
            chi2 += (o_acc - e_acc) * (o_acc - e_acc) / e_acc;
            dof += 1;
        } else {
            assert_eq!(o_acc, 0.0, "draws where the density is zero");
        }
        (chi2, dof.saturating_sub(1))
    }

    /// The directions `sample_f` draws follow `pdf` (χ² below its mean plus 6 standard deviations: fails by chance
    /// with p ≈ 1e-8), from both sides; and the same test rejects a density whose lobe probabilities are swapped.
    #[test]
    fn diffuse_transmission_samples_its_pdf() {
        let b = chromatic_diffuse_transmission();
        let threshold = |dof: usize| dof as f64 + 6.0 * (2.0 * dof as f64).sqrt();
        for wo in [Vec3::new(0.3, 0.2, 0.93).normalize(), Vec3::new(0.5, -0.1, -0.3).normalize()] {
            let (chi2, dof) = chi_square(&b, &b, wo, 400_000);
            eprintln!("{wo}: χ² = {chi2:.1}, {dof} degrees of freedom, threshold {:.1}", threshold(dof));
            assert!(dof > 300, "{dof}");
            assert!(chi2 < threshold(dof), "{wo}: χ² = {chi2:.1} with {dof} degrees of freedom");
            let Bxdf::DiffuseTransmission { r, t } = b.clone() else { unreachable!() };
            let swapped = Bxdf::DiffuseTransmission { r: t, t: r };
            let (chi2, dof) = chi_square(&b, &swapped, wo, 400_000);
            eprintln!("{wo}, swapped lobes: χ² = {chi2:.1}");
            assert!(chi2 > 10.0 * threshold(dof), "swapped lobes: χ² = {chi2:.1} with {dof} degrees of freedom");
        }
    }

    #[test]
    fn smooth_dielectric_conserves_energy_from_both_sides() {
        // Importance mode: R + T = 1 exactly for a non-absorbing interface (white furnace of a single event).
        let b = Bxdf::Dielectric { eta: 1.5, distrib: TrowbridgeReitz::new(0.0, 0.0), coating: None, tint: None };
        for wo in
            [Vec3::new(0.5, 0.0, 0.866), Vec3::new(0.1, 0.3, -0.95).normalize(), Vec3::new(0.9, 0.0, -0.3).normalize()]
        {
            let a = albedo(&b, wo, 4000);
            assert!((a - 1.0).abs() < 1e-4, "{wo}: {a}");
        }
    }

    #[test]
    fn rough_dielectric_is_consistent_and_nearly_conserves_energy() {
        for alpha in [0.1, 0.3] {
            let b =
                Bxdf::Dielectric { eta: 1.5, distrib: TrowbridgeReitz::new(alpha, alpha), coating: None, tint: None };
            for wo in [Vec3::new(0.3, 0.1, 0.95).normalize(), Vec3::new(0.2, -0.3, -0.93).normalize()] {
                consistent(&b, wo);
                // Single-scattering microfacet models lose the energy of multiple bounces between microfacets
                // (Heitz et al. 2016): little from outside, more from the dense side where many microfacets
                // reflect totally. Nothing may ever be gained.
                let a = albedo(&b, wo, 40_000);
                let floor = if wo.z > 0.0 { 0.97 } else { 0.85 };
                assert!(a <= 1.005 && a > floor, "α {alpha}, {wo}: {a}");
            }
        }
    }

    /// A tinted rough dielectric transmits the untinted one's f times the tint and reflects as it does, whether
    /// evaluated or sampled, and with the same densities; the sampler stays consistent with its evaluation.
    #[test]
    fn a_tint_multiplies_transmission_only() {
        let tint = SampledSpectrum([0.9, 0.5, 0.25, 0.1]);
        let distrib = TrowbridgeReitz::new(0.3, 0.3);
        let bare = Bxdf::Dielectric { eta: 1.5, distrib, coating: None, tint: None };
        let tinted = Bxdf::Dielectric { eta: 1.5, distrib, coating: None, tint: Some(tint) };
        let wo = Vec3::new(0.3, 0.1, 0.95).normalize();
        consistent(&tinted, wo);
        let (mut reflections, mut transmissions) = (0, 0);
        for i in 0..64 {
            let (uc, u) =
                ((i as f32 + 0.5) / 64.0, Vec2::new(((i * 7) % 64) as f32 / 64.0, ((i * 13) % 64) as f32 / 64.0));
            let (Some(a), Some(b)) = (
                bare.sample_f(wo, uc, u, TransportMode::Radiance),
                tinted.sample_f(wo, uc, u, TransportMode::Radiance),
            ) else {
                continue;
            };
            assert_eq!((a.wi, a.pdf, a.transmission), (b.wi, b.pdf, b.transmission));
            let want = if a.transmission { a.f * tint } else { a.f };
            assert_eq!(b.f.0, want.0);
            let (fa, fb) = (bare.f(wo, a.wi, TransportMode::Radiance), tinted.f(wo, a.wi, TransportMode::Radiance));
            assert_eq!(fb.0, if a.transmission { fa * tint } else { fa }.0);
            if a.transmission {
                transmissions += 1;
            } else {
                reflections += 1;
            }
        }
        assert!(reflections > 0 && transmissions > 0, "{reflections} {transmissions}");
    }

    /// A lossless three-layer anti-reflection stack (MgF₂ / high-index / medium-index, quarter waves near 550 nm),
    /// the same at every slot.
    fn ar_stack() -> Option<Box<CoatingAt>> {
        let l = |n: f64, d: f64| optics::FilmLayer::new(optics::Complex::from_real(n), d);
        let layers = [l(1.38, 99.6), l(2.1, 130.0), l(1.65, 83.0)];
        Some(Box::new(CoatingAt::uniform([450.0, 550.0, 650.0, 750.0], &layers)))
    }

    /// A rough coated dielectric samples what it evaluates (values and densities match, and the drawn directions
    /// follow the density by χ²), and loses energy only as the bare rough interface does (single scattering).
    #[test]
    fn a_rough_coated_dielectric_is_consistent_and_samples_its_pdf() {
        let threshold = |dof: usize| dof as f64 + 6.0 * (2.0 * dof as f64).sqrt();
        let distrib = TrowbridgeReitz::new(0.3, 0.3);
        let coated = Bxdf::Dielectric { eta: 1.5, distrib, coating: ar_stack(), tint: None };
        let bare = Bxdf::Dielectric { eta: 1.5, distrib, coating: None, tint: None };
        for wo in [Vec3::new(0.3, 0.1, 0.95).normalize(), Vec3::new(0.5, -0.3, -0.6).normalize()] {
            consistent(&coated, wo);
            let (chi2, dof) = chi_square(&coated, &coated, wo, 400_000);
            assert!(chi2 < threshold(dof), "{wo}: χ² = {chi2:.1} with {dof} degrees of freedom");
            // The bare interface's density is a different one (it reflects more): the test sees it.
            let (chi2, dof) = chi_square(&coated, &bare, wo, 400_000);
            assert!(chi2 > 2.0 * threshold(dof), "{wo}: against the bare density χ² = {chi2:.1} ({dof})");
            let (a_coated, a_bare) = (albedo(&coated, wo, 40_000), albedo(&bare, wo, 40_000));
            assert!(a_coated <= 1.005 && (a_coated - a_bare).abs() < 0.03, "{wo}: {a_coated} vs bare {a_bare}");
        }
    }

    #[test]
    fn conductors_match_fresnel_and_sample_consistently() {
        let (eta, k) = (SampledSpectrum::splat(0.2), SampledSpectrum::splat(3.0));
        let smooth = Bxdf::Conductor { eta, k, distrib: TrowbridgeReitz::new(0.0, 0.0), coating: None };
        let wo = Vec3::new(0.0, 0.0, 1.0);
        let expected = ((0.2f32 - 1.0).powi(2) + 9.0) / ((1.2f32).powi(2) + 9.0);
        assert!((albedo(&smooth, wo, 10) - expected).abs() < 1e-5);
        let rough = Bxdf::Conductor { eta, k, distrib: TrowbridgeReitz::new(0.3, 0.3), coating: None };
        consistent(&rough, Vec3::new(0.4, 0.1, 0.9).normalize());
    }

    #[test]
    fn refraction_obeys_snell_and_reports_tir() {
        let wi = Vec3::new(0.6, 0.0, 0.8);
        let (wt, etap) = refract(wi, Vec3::Z, 1.5).unwrap();
        assert_eq!(etap, 1.5);
        let (sin_i, sin_t) = (0.6f32, (wt.x * wt.x + wt.y * wt.y).sqrt());
        assert!((sin_i - 1.5 * sin_t).abs() < 1e-6 && wt.z < 0.0);
        // From inside at 60°: sin θt = 1.5·0.866 > 1.
        assert!(refract(Vec3::new(0.866, 0.0, -0.5), Vec3::Z, 1.5).is_none());
    }

    #[test]
    fn dispersive_dielectric_conserves_energy_per_wavelength() {
        // Per slot, E[f·|cos|/pdf] over reflection and kept refractions (weighted by k for the kept slot, as the
        // integrator's density division does) must be 1: R(λ) + T(λ) = 1 for every wavelength.
        let eta = SampledSpectrum([1.80, 1.78, 1.77, 1.76]);
        let b = Bxdf::DispersiveDielectric { eta, active: [true; 4], coating: None, tint: None };
        let mut rng = Pcg32::seed_from_u64(5);
        for wo in [Vec3::new(0.6, 0.0, 0.8), Vec3::new(0.3, 0.2, -0.93).normalize()] {
            let n = 200_000;
            let mut sum = [0.0f64; 4];
            for _ in 0..n {
                let Some(s) = b.sample_f(wo, uniform(&mut rng), Vec2::ZERO, TransportMode::Importance) else {
                    continue;
                };
                let w = s.f * (s.wi.z.abs() / s.pdf);
                match s.keep_slot {
                    None => (0..4).for_each(|i| sum[i] += w[i] as f64),
                    Some(j) => sum[j] += 4.0 * w[j] as f64,
                }
            }
            for (i, v) in sum.iter().enumerate() {
                let a = v / n as f64;
                assert!((a - 1.0).abs() < 0.01, "{wo}: slot {i}: {a}");
            }
        }
    }

    #[test]
    fn thin_dielectric_sums_the_slab() {
        let b = Bxdf::ThinDielectric { eta: SampledSpectrum::splat(1.5) };
        let a = albedo(&b, Vec3::Z, 2000);
        assert!((a - 1.0).abs() < 1e-4, "{a}");
    }
}

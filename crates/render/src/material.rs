//! Materials: what a surface is made of, turned into a BxDF at the path's wavelengths.

use std::sync::Arc;

use optics::Ior;
use spectral::{SampledSpectrum, SampledWavelengths, Spectrum, N_WAVELENGTHS};

use crate::bump::NormalPerturbation;
use crate::bxdf::Bxdf;
use crate::coating::Coating;
use crate::layered::Layered;
use crate::measured::MeasuredBrdf;
use crate::metallic_roughness::MetallicRoughness;
use crate::microfacet::TrowbridgeReitz;
use crate::scene::SurfaceHit;
use crate::texture::{FloatTexture, ImageTexture, SpectrumTexture, TextureEvalContext};

/// The index of refraction of a dielectric.
#[derive(Clone, Debug)]
pub enum DielectricIor {
    /// A model from the optics crate (constant, Sellmeier, Cauchy, Abbe, tabulated, …).
    Model(Ior),
    /// A spectrum of n(λ) given in the scene (pbrt's `"spectrum eta"`).
    Spectrum(Spectrum),
}

impl DielectricIor {
    /// n at `lambda_nm`.
    pub fn n(&self, lambda_nm: f32) -> f32 {
        match self {
            DielectricIor::Model(m) => m.n(lambda_nm as f64) as f32,
            DielectricIor::Spectrum(s) => s.eval(lambda_nm as f64) as f32,
        }
    }

    /// True if n depends on the wavelength, so refraction must keep a single wavelength.
    pub fn is_dispersive(&self) -> bool {
        match self {
            DielectricIor::Model(m) => m.is_dispersive(),
            DielectricIor::Spectrum(s) => !matches!(s, Spectrum::Constant(_)),
        }
    }
}

/// Roughness parameters shared by the microfacet materials.
#[derive(Clone, Debug)]
pub struct Roughness {
    /// Roughness along u.
    pub u: FloatTexture,
    /// Roughness along v.
    pub v: FloatTexture,
    /// Map perceptual roughness to α = √roughness (pbrt's `remaproughness`, default true).
    pub remap: bool,
}

impl Roughness {
    /// A smooth surface.
    #[cfg(test)]
    pub fn smooth() -> Self {
        Self { u: FloatTexture::Constant(0.0), v: FloatTexture::Constant(0.0), remap: true }
    }

    fn distribution(&self, ctx: &TextureEvalContext) -> TrowbridgeReitz {
        let (mut u, mut v) = (self.u.eval(ctx).max(0.0), self.v.eval(ctx).max(0.0));
        if self.remap {
            u = TrowbridgeReitz::roughness_to_alpha(u);
            v = TrowbridgeReitz::roughness_to_alpha(v);
        }
        TrowbridgeReitz::new(u, v)
    }
}

/// How a conductor's optical constants are given.
#[derive(Clone, Debug)]
pub enum ConductorSpec {
    /// Complex index η + ik.
    EtaK {
        /// η.
        eta: SpectrumTexture,
        /// k.
        k: SpectrumTexture,
    },
    /// A reflectance at normal incidence, converted to η = 1 and k = 2√r/√(1 − r) (pbrt-v4).
    Reflectance(SpectrumTexture),
}

/// The medium between a layered material's coat and base, and how its random walks are run.
#[derive(Clone, Debug)]
pub struct LayerMedium {
    /// Optical depth of the layer (unit extinction, so thickness in mean free paths).
    pub thickness: f32,
    /// Single-scattering albedo of the medium (0: purely absorbing).
    pub albedo: SpectrumTexture,
    /// Henyey–Greenstein asymmetry, in (−1, 1).
    pub g: FloatTexture,
    /// Maximum random-walk depth.
    pub max_depth: u32,
    /// Walks per evaluation.
    pub n_samples: u32,
}

impl LayerMedium {
    fn apply(&self, layered: Layered, ctx: &TextureEvalContext, wl: &SampledWavelengths) -> Layered {
        let albedo = clamp01(self.albedo.eval(ctx, wl));
        if albedo.is_black() {
            layered
        } else {
            layered.with_medium(albedo, self.g.eval(ctx))
        }
    }
}

impl ConductorSpec {
    /// η and k at the path's wavelengths.
    pub fn eta_k(&self, ctx: &TextureEvalContext, wl: &SampledWavelengths) -> (SampledSpectrum, SampledSpectrum) {
        match self {
            ConductorSpec::EtaK { eta, k } => (eta.eval(ctx, wl), k.eval(ctx, wl)),
            ConductorSpec::Reflectance(r) => {
                let r = clamp01(r.eval(ctx, wl)).map(|v| v.min(0.9999));
                // Normal-incidence reflectance of η = 1, k: r = k²/(4 + k²), solved for k (pbrt-v4 §9.4).
                (SampledSpectrum::splat(1.0), r.map(|v| 2.0 * v.sqrt() / (1.0 - v).sqrt()))
            }
        }
    }
}

/// The layers glTF's extensions put on a `metallicroughness` material; `None`: not there.
#[derive(Clone, Debug, Default)]
pub struct MetallicRoughnessLayers {
    /// `KHR_materials_specular`.
    pub specular: Option<SpecularLayer>,
    /// `KHR_materials_iridescence`.
    pub iridescence: Option<IridescenceLayer>,
    /// `KHR_materials_sheen`.
    pub sheen: Option<SheenLayer>,
    /// `KHR_materials_clearcoat`.
    pub clearcoat: Option<ClearcoatLayer>,
    /// `KHR_materials_anisotropy`.
    pub anisotropy: Option<AnisotropyLayer>,
}

/// `KHR_materials_specular`'s parameters.
#[derive(Clone, Debug)]
pub struct SpecularLayer {
    /// The specular weight (f₉₀), in [0, 1].
    pub weight: FloatTexture,
    /// The colour f₀ is multiplied by (unbounded).
    pub color: SpectrumTexture,
    /// The colour's largest RGB channel.
    pub color_max: FloatTexture,
}

/// `KHR_materials_iridescence`'s parameters.
#[derive(Clone, Debug)]
pub struct IridescenceLayer {
    /// The weight, in [0, 1].
    pub weight: FloatTexture,
    /// The film: one layer of the film's index, its thickness in nm.
    pub film: Coating,
}

/// `KHR_materials_sheen`'s parameters.
#[derive(Clone, Debug)]
pub struct SheenLayer {
    /// The sheen colour.
    pub color: SpectrumTexture,
    /// The colour's largest RGB channel.
    pub color_max: FloatTexture,
    /// The sheen roughness.
    pub roughness: FloatTexture,
}

/// `KHR_materials_clearcoat`'s parameters.
#[derive(Clone, Debug)]
pub struct ClearcoatLayer {
    /// The weight, in [0, 1].
    pub weight: FloatTexture,
    /// The coat's perceptual roughness.
    pub roughness: FloatTexture,
    /// The coat's own normal map (without one the coat follows the unperturbed shading normal, whatever the base's
    /// normal map does).
    pub normal_map: Option<NormalPerturbation>,
}

/// `KHR_materials_anisotropy`'s parameters: the specular lobes stretched along a direction in the tangent plane.
#[derive(Clone, Debug)]
pub struct AnisotropyLayer {
    /// The strength, in [0, 1].
    pub strength: f32,
    /// The direction's angle from the tangent towards the bitangent, in radians.
    pub rotation: f32,
    /// A texture (linear) whose red and green hold the direction in the tangent frame as 2·rg − 1, turned further by
    /// `rotation`, and whose blue multiplies the strength.
    pub texture: Option<Box<ImageTexture>>,
}

impl AnisotropyLayer {
    /// The strength and the direction's angle from the tangent at `ctx`.
    pub fn at(&self, ctx: &TextureEvalContext) -> (f32, f32) {
        let Some(tex) = &self.texture else { return (self.strength, self.rotation) };
        let rgb = tex.rgb(ctx);
        let (x, y) = (2.0 * rgb[0] - 1.0, 2.0 * rgb[1] - 1.0);
        let angle = if x == 0.0 && y == 0.0 { 0.0 } else { y.atan2(x) };
        (self.strength * rgb[2], self.rotation + angle)
    }

    /// Turns the tangent `hit`'s BSDF frame starts from to the anisotropy direction at `ctx`: the angle from the
    /// tangent (∂p/∂u made perpendicular to the shading normal) towards the bitangent (ns × tangent on the side of
    /// the surface's ∂p/∂v, the frame of glTF's normal maps).
    pub fn orient(&self, hit: &mut SurfaceHit, ctx: &TextureEvalContext) {
        let angle = self.at(ctx).1;
        let ns = hit.ns;
        let Some(x) = (hit.dpdu - ns * ns.dot(hit.dpdu)).try_normalize() else { return };
        let y = ns.cross(x);
        let y = if y.dot(hit.surface_dpdv) < 0.0 { -y } else { y };
        let (sin, cos) = angle.sin_cos();
        hit.dpdu = (cos * x + sin * y) * hit.dpdu.length();
    }
}

impl MetallicRoughnessLayers {
    /// The BRDF of `core` with these layers at `ctx`.
    fn apply(
        &self,
        mut brdf: MetallicRoughness,
        ctx: &TextureEvalContext,
        wl: &SampledWavelengths,
    ) -> MetallicRoughness {
        if let Some(s) = &self.specular {
            brdf = brdf.with_specular(s.weight.eval(ctx), s.color.eval(ctx, wl), s.color_max.eval(ctx));
        }
        if let Some(i) = &self.iridescence {
            let weight = i.weight.eval(ctx);
            if weight > 0.0 {
                brdf = brdf.with_iridescence(weight, i.film.at(ctx, wl));
            }
        }
        if let Some(s) = &self.sheen {
            brdf = brdf.with_sheen(s.color.eval(ctx, wl), s.color_max.eval(ctx), s.roughness.eval(ctx));
        }
        if let Some(c) = &self.clearcoat {
            brdf = brdf.with_clearcoat(c.weight.eval(ctx), c.roughness.eval(ctx));
        }
        if let Some(a) = &self.anisotropy {
            brdf = brdf.with_anisotropy(a.at(ctx).0);
        }
        brdf
    }
}

/// A material.
#[derive(Clone, Debug)]
pub enum Material {
    /// Lambertian.
    Diffuse {
        /// Albedo.
        reflectance: SpectrumTexture,
    },
    /// Lambertian reflection and Lambertian transmission (pbrt-v4's `diffusetransmission`): leaves, paper,
    /// lamp shades.
    DiffuseTransmission {
        /// Reflectance (before `scale`).
        reflectance: SpectrumTexture,
        /// Transmittance (before `scale`).
        transmittance: SpectrumTexture,
        /// Multiplies both; the products are clamped to [0, 1].
        scale: f32,
    },
    /// Metal, bare or under thin films.
    Conductor {
        /// Optical constants.
        spec: ConductorSpec,
        /// Roughness.
        roughness: Roughness,
        /// Thin films on it (Prismatic's `film*` parameters; no layers: bare).
        coating: Coating,
    },
    /// Glass, water, gems: refracts with n(λ); bare or under thin films.
    Dielectric {
        /// n(λ).
        ior: DielectricIor,
        /// Roughness.
        roughness: Roughness,
        /// Thin films on the outside (Prismatic's `film*` parameters; no layers: bare).
        coating: Coating,
        /// What transmitted light is multiplied by at each crossing (Prismatic's `transmissiontint`, glTF's base
        /// colour on a transmissive material; `None`: untinted).
        tint: Option<SpectrumTexture>,
    },
    /// A thin sheet of glass (no refraction offset).
    ThinDielectric {
        /// n(λ).
        ior: DielectricIor,
    },
    /// A free-standing thin film in air (a soap film): interference in reflection and transmission.
    ThinFilm {
        /// The film: one layer, its index and thickness (nm, may be a texture).
        film: Coating,
    },
    /// Diffuse under a dielectric coat.
    CoatedDiffuse {
        /// Base albedo.
        reflectance: SpectrumTexture,
        /// Coat roughness.
        roughness: Roughness,
        /// Coat index.
        ior: DielectricIor,
        /// The layer between coat and base.
        medium: LayerMedium,
    },
    /// A conductor under a dielectric coat.
    CoatedConductor {
        /// The conductor's optical constants (relative to the coat).
        conductor: ConductorSpec,
        /// The conductor's roughness.
        conductor_roughness: Roughness,
        /// Coat roughness.
        interface_roughness: Roughness,
        /// Coat index.
        interface_ior: DielectricIor,
        /// The layer between coat and base.
        medium: LayerMedium,
    },
    /// Chooses one of two materials per shading point with probability `amount` for the second.
    Mix {
        /// The two materials (indices into the scene's material list).
        materials: [u32; 2],
        /// Probability of the second.
        amount: FloatTexture,
    },
    /// A measured BRDF from an RGL tensor file (pbrt-v4's `measured`); not dispersive, so every wavelength is kept.
    Measured {
        /// The tables, shared by every hit.
        brdf: Arc<MeasuredBrdf>,
    },
    /// glTF 2.0's metallic-roughness material (its Appendix B BRDF; Prismatic's `metallicroughness`).
    MetallicRoughness {
        /// Base colour (a reflectance).
        base_color: SpectrumTexture,
        /// Metalness in [0, 1].
        metallic: FloatTexture,
        /// Perceptual roughness in [0, 1] (α = roughness²).
        roughness: FloatTexture,
        /// The dielectric layer's index (1.5 in glTF unless `KHR_materials_ior` says otherwise; 0: infinite).
        ior: f32,
        /// The extensions' layers (specular, iridescence, sheen, clearcoat).
        layers: Box<MetallicRoughnessLayers>,
    },
    /// No surface: marks a boundary between media.
    Interface,
}

impl Material {
    /// The index of a smooth dielectric (`dielectric` with zero roughness at `ctx`), whose refraction is a delta
    /// distribution a specular-chain solver can follow; `None` for every other material.
    pub(crate) fn smooth_dielectric_ior(&self, ctx: &TextureEvalContext) -> Option<&DielectricIor> {
        match self {
            // A coated interface's transmittance is the film's, which a specular chain does not carry.
            Material::Dielectric { ior, roughness, coating, .. }
                if coating.layers.is_empty() && roughness.distribution(ctx).effectively_smooth() =>
            {
                Some(ior)
            }
            Material::Diffuse { .. }
            | Material::DiffuseTransmission { .. }
            | Material::Conductor { .. }
            | Material::Dielectric { .. }
            | Material::ThinDielectric { .. }
            | Material::ThinFilm { .. }
            | Material::CoatedDiffuse { .. }
            | Material::CoatedConductor { .. }
            | Material::Mix { .. }
            | Material::Measured { .. }
            | Material::MetallicRoughness { .. }
            | Material::Interface => None,
        }
    }

    /// The glTF extensions' layers of a `metallicroughness` material.
    fn metallic_roughness_layers(&self) -> Option<&MetallicRoughnessLayers> {
        match self {
            Material::MetallicRoughness { layers, .. } => Some(layers),
            Material::Diffuse { .. }
            | Material::DiffuseTransmission { .. }
            | Material::Conductor { .. }
            | Material::Dielectric { .. }
            | Material::ThinDielectric { .. }
            | Material::ThinFilm { .. }
            | Material::CoatedDiffuse { .. }
            | Material::CoatedConductor { .. }
            | Material::Mix { .. }
            | Material::Measured { .. }
            | Material::Interface => None,
        }
    }

    /// A glTF clear coat's parameters, if the material has one: its BxDF then needs the coat's normal, which
    /// ignores the base's normal map ([`crate::metallic_roughness::Clearcoat::normal`]).
    pub(crate) fn clearcoat(&self) -> Option<&ClearcoatLayer> {
        self.metallic_roughness_layers().and_then(|l| l.clearcoat.as_ref())
    }

    /// A glTF anisotropy's parameters, if the material has them: its BxDF's frame then starts from the anisotropy
    /// direction ([`AnisotropyLayer::orient`]).
    pub(crate) fn anisotropy(&self) -> Option<&AnisotropyLayer> {
        self.metallic_roughness_layers().and_then(|l| l.anisotropy.as_ref())
    }

    /// The BxDF at a shading point. Dispersive dielectrics first reduce the path to one wavelength with `u`
    /// (seed 001: a refractive surface forces a choice); `None` for interfaces.
    pub fn bxdf(
        &self,
        ctx: &TextureEvalContext,
        wl: &mut SampledWavelengths,
        u: f32,
        regularize: bool,
    ) -> Option<Bxdf> {
        // pbrt-v4 regularizes dielectrics, conductors and both layers of coated materials; diffuse, thin,
        // measured materials stay as they are. A regularized smooth dispersive dielectric is a rough one, which
        // picks its wavelength up front as every rough dispersive dielectric does.
        let distribution = |r: &Roughness| {
            let d = r.distribution(ctx);
            if regularize {
                d.regularized()
            } else {
                d
            }
        };
        match self {
            Material::Diffuse { reflectance } => Some(Bxdf::Diffuse { r: clamp01(reflectance.eval(ctx, wl)) }),
            Material::DiffuseTransmission { reflectance, transmittance, scale } => Some(Bxdf::DiffuseTransmission {
                r: clamp01(reflectance.eval(ctx, wl) * *scale),
                t: clamp01(transmittance.eval(ctx, wl) * *scale),
            }),
            Material::Conductor { spec, roughness, coating } => {
                let (eta, k) = spec.eta_k(ctx, wl);
                Some(Bxdf::Conductor { eta, k, distrib: distribution(roughness), coating: coating.at(ctx, wl) })
            }
            Material::Dielectric { ior, roughness, coating, tint } => {
                let distrib = distribution(roughness);
                let tint = tint.as_ref().map(|t| clamp01(t.eval(ctx, wl)));
                if ior.is_dispersive() && distrib.effectively_smooth() && !wl.is_single() {
                    // Keep all wavelengths until the sampled event is a refraction (see DispersiveDielectric).
                    let mut eta = SampledSpectrum::zero();
                    let mut active = [false; N_WAVELENGTHS];
                    for i in 0..N_WAVELENGTHS {
                        active[i] = wl.is_active(i);
                        eta[i] = ior.n(wl.lambda(i));
                    }
                    return Some(Bxdf::DispersiveDielectric { eta, active, coating: coating.at(ctx, wl), tint });
                }
                let eta = single_eta(ior, wl, u);
                Some(Bxdf::Dielectric { eta, distrib, coating: coating.at(ctx, wl), tint })
            }
            Material::ThinDielectric { ior } => {
                let mut eta = SampledSpectrum::zero();
                for i in 0..N_WAVELENGTHS {
                    eta[i] = ior.n(wl.lambda(i));
                }
                Some(Bxdf::ThinDielectric { eta })
            }
            Material::ThinFilm { film } => Some(Bxdf::ThinFilm { film: film.at(ctx, wl) }),
            Material::MetallicRoughness { base_color, metallic, roughness, ior, layers } => {
                let core =
                    MetallicRoughness::new(base_color.eval(ctx, wl), metallic.eval(ctx), roughness.eval(ctx), *ior);
                Some(Bxdf::MetallicRoughness(layers.apply(core, ctx, wl)))
            }
            Material::CoatedDiffuse { reflectance, roughness, ior, medium } => {
                let eta = single_eta(ior, wl, u);
                let layered = Layered::coated_diffuse(
                    clamp01(reflectance.eval(ctx, wl)),
                    eta,
                    distribution(roughness),
                    medium.thickness,
                    medium.max_depth,
                    medium.n_samples,
                );
                Some(Bxdf::Layered(Box::new(medium.apply(layered, ctx, wl))))
            }
            Material::CoatedConductor {
                conductor,
                conductor_roughness,
                interface_roughness,
                interface_ior,
                medium,
            } => {
                let eta = single_eta(interface_ior, wl, u);
                let (ce, ck) = conductor.eta_k(ctx, wl);
                // The base sits inside the coat: its index relative to the coat is (η + ik)/η_coat (pbrt-v4 §9.4).
                let layered = Layered::coated_conductor(
                    eta,
                    distribution(interface_roughness),
                    ce * (1.0 / eta),
                    ck * (1.0 / eta),
                    distribution(conductor_roughness),
                    medium.thickness,
                    medium.max_depth,
                    medium.n_samples,
                );
                Some(Bxdf::Layered(Box::new(medium.apply(layered, ctx, wl))))
            }
            Material::Measured { brdf } => Some(Bxdf::Measured { brdf: brdf.clone(), lambda: wl.lambdas() }),
            Material::Mix { .. } | Material::Interface => None,
        }
    }
}

/// The relative index for a dielectric at the path's wavelengths, terminating secondary wavelengths first if the
/// index is dispersive (the kept slot's λ decides the direction of refraction).
fn single_eta(ior: &DielectricIor, wl: &mut SampledWavelengths, u: f32) -> f32 {
    if ior.is_dispersive() {
        let keep = wl.terminate_secondary(u);
        ior.n(wl.lambda(keep))
    } else {
        ior.n(wl.lambda(0))
    }
}

fn clamp01(s: SampledSpectrum) -> SampledSpectrum {
    s.map(|v| v.clamp(0.0, 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::texture::FloatTexture;
    use glam::{Vec2, Vec3};

    #[test]
    fn diffuse_transmission_scales_then_clamps() {
        // pbrt-v4: R = clamp(scale·reflectance, 0, 1), T likewise.
        let constant = |v: f64| SpectrumTexture::Constant(Spectrum::Constant(v));
        let m = Material::DiffuseTransmission { reflectance: constant(0.5), transmittance: constant(0.25), scale: 3.0 };
        let mut wl = SampledWavelengths::new([450.0, 550.0, 650.0, 750.0], [4.0; 4]);
        let ctx = TextureEvalContext::new(Vec3::ZERO, Vec3::Z, Vec2::ZERO);
        let Some(Bxdf::DiffuseTransmission { r, t }) = m.bxdf(&ctx, &mut wl, 0.5, false) else { panic!() };
        assert_eq!(r.0, [1.0; 4]);
        assert_eq!(t.0, [0.75; 4]);
    }

    #[test]
    fn dispersive_glass_keeps_one_wavelength_and_uses_its_index() {
        let sf11 = optics::catalogue::lookup("N-SF11").unwrap().ior;
        let m = Material::Dielectric {
            ior: DielectricIor::Model(sf11.clone()),
            roughness: Roughness::smooth(),
            coating: Coating::default(),
            tint: None,
        };
        let mut wl = SampledWavelengths::new([450.0, 550.0, 650.0, 750.0], [4.0; 4]);
        let ctx = TextureEvalContext::new(Vec3::ZERO, Vec3::Z, Vec2::ZERO);
        let Some(Bxdf::DispersiveDielectric { eta, active, .. }) = m.bxdf(&ctx, &mut wl, 0.6, false) else { panic!() };
        assert_eq!(active, [true; 4], "a smooth dispersive interface keeps all wavelengths until it refracts");
        assert!((eta[2] as f64 - sf11.n(650.0)).abs() < 1e-6);
        // A rough dispersive interface reduces the path to one wavelength first (its microfacet sampling is shared).
        let rough = Roughness { u: FloatTexture::Constant(0.1), v: FloatTexture::Constant(0.1), remap: false };
        let m = Material::Dielectric {
            ior: DielectricIor::Model(sf11.clone()),
            roughness: rough,
            coating: Coating::default(),
            tint: None,
        };
        let Some(Bxdf::Dielectric { eta, .. }) = m.bxdf(&ctx, &mut wl, 0.6, false) else { panic!() };
        assert!(wl.is_single());
        assert!((eta as f64 - sf11.n(650.0)).abs() < 1e-6, "kept slot 2 (650 nm)");
        // A constant index keeps all four wavelengths.
        let m = Material::Dielectric {
            ior: DielectricIor::Model(optics::Ior::constant(1.5).unwrap()),
            roughness: Roughness::smooth(),
            coating: Coating::default(),
            tint: None,
        };
        let mut wl = SampledWavelengths::new([450.0, 550.0, 650.0, 750.0], [4.0; 4]);
        m.bxdf(&ctx, &mut wl, 0.6, false);
        assert_eq!(wl.active_count(), 4);
    }

    #[test]
    fn regularizing_widens_smooth_glass_and_metal_as_pbrt_v4_does() {
        let ctx = TextureEvalContext::new(Vec3::ZERO, Vec3::Z, Vec2::ZERO);
        let wl = || SampledWavelengths::new([450.0, 550.0, 650.0, 750.0], [4.0; 4]);
        let constant = |v: f64| SpectrumTexture::Constant(Spectrum::Constant(v));
        let metal = Material::Conductor {
            spec: ConductorSpec::EtaK { eta: constant(0.2), k: constant(3.0) },
            roughness: Roughness::smooth(),
            coating: Coating::default(),
        };
        // α = 0 becomes clamp(0, 0.1, 0.3) = 0.1: no longer a delta lobe.
        let Some(Bxdf::Conductor { distrib, .. }) = metal.bxdf(&ctx, &mut wl(), 0.5, true) else { panic!() };
        assert_eq!(distrib, TrowbridgeReitz::new(0.1, 0.1));
        let Some(smooth) = metal.bxdf(&ctx, &mut wl(), 0.5, false) else { panic!() };
        assert!(smooth.is_specular());
        // A smooth dispersive dielectric becomes a rough one, which keeps one wavelength up front.
        let sf11 = optics::catalogue::lookup("N-SF11").unwrap().ior;
        let glass = Material::Dielectric {
            ior: DielectricIor::Model(sf11),
            roughness: Roughness::smooth(),
            coating: Coating::default(),
            tint: None,
        };
        let mut w = wl();
        let Some(Bxdf::Dielectric { distrib, .. }) = glass.bxdf(&ctx, &mut w, 0.6, true) else { panic!() };
        assert!(w.is_single() && distrib == TrowbridgeReitz::new(0.1, 0.1));
        // Diffuse surfaces are what they were.
        let matte = Material::Diffuse { reflectance: constant(0.5) };
        let Some(Bxdf::Diffuse { r }) = matte.bxdf(&ctx, &mut wl(), 0.5, true) else { panic!() };
        assert_eq!(r.0, [0.5; 4]);
        // pbrt-v4's map of α: below 0.3, clamp(2α, 0.1, 0.3); from 0.3 on, unchanged; each axis on its own.
        for (alpha, widened) in [(0.0, 0.1), (0.04, 0.1), (0.1, 0.2), (0.2, 0.3), (0.29, 0.3), (0.3, 0.3), (0.7, 0.7)] {
            let d = TrowbridgeReitz::new(alpha, 0.5).regularized();
            assert_eq!(d, TrowbridgeReitz::new(widened, 0.5), "α {alpha}");
        }
    }
}

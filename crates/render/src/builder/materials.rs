//! Materials: pbrt-v4's `Material` and `MakeNamedMaterial` directives (`diffuse`, `diffusetransmission`,
//! `conductor`, `dielectric`, `thindielectric`, `coateddiffuse`, `coatedconductor`, `mix`, `interface`,
//! `subsurface`, `measured`) with their
//! roughness, conductor, index-of-refraction and layer parameters, into the scene's [`Materials`] (the index a
//! shape's material reference resolves to is looked up there).

use std::cell::RefCell;
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Arc;

use scene::{Entity, Loc, ParamSet, ParamType, SceneDescription, SceneError, SpectrumKind};
use spectral::Spectrum;

use super::context::{err, file_err, finite_positive, unsupported, ImageSource, Materials, Result, Textures};
use crate::bump::NormalPerturbation;
use crate::coating::{Coating, CoatingLayer, LayerIndex};
use crate::material::{
    AnisotropyLayer, ClearcoatLayer, ConductorSpec, DielectricIor, IridescenceLayer, LayerMedium, Material,
    MetallicRoughnessLayers, Roughness, SheenLayer, SpecularLayer,
};
use crate::measured::MeasuredBrdf;
use crate::medium::HomogeneousMedium;
use crate::texture::{FloatTexture, SpectrumTexture};
use film::{ChannelSelect, ColorEncoding};

/// How a `subsurface` material is made: its boundary material and interior medium, from the directive and the
/// roughness read here.
pub(super) type MakeSubsurface = fn(&Entity, Roughness) -> Result<(Material, HomogeneousMedium)>;

/// Reads every material; names are known before any is read, since a `mix` refers to others by name. A `subsurface`
/// material is made by `subsurface` (`subsurface.rs`'s, handed over by `mod.rs`) in its turn, so that the first
/// error in the file is the one reported.
pub(super) fn build(desc: &SceneDescription, textures: &Textures, subsurface: MakeSubsurface) -> Result<Materials> {
    let mut names: HashMap<String, u32> = HashMap::new();
    let n_anon = desc.materials.len();
    for (i, (name, _)) in desc.named_materials.iter().enumerate() {
        names.insert(name.clone(), (n_anon + i) as u32);
    }
    let mut materials = Vec::with_capacity(n_anon + desc.named_materials.len());
    let mut perturbations = Vec::with_capacity(materials.capacity());
    let mut interiors = Vec::with_capacity(materials.capacity());
    let measured = MeasuredFiles::default();
    let mut reads_footprint = Vec::with_capacity(materials.capacity());
    for e in desc.materials.iter().chain(desc.named_materials.iter().map(|(_, e)| e)) {
        textures.take_image_use();
        let (m, interior) = if e.name == "subsurface" {
            let (m, medium) = subsurface(e, roughness(textures, &e.params)?)?;
            (m, Some(medium))
        } else {
            (material(textures, e, &names, &measured)?, None)
        };
        interiors.push(interior);
        // A mix has none of its own (the material it picks brings its own), nor has an interface.
        let own = !matches!(m, Material::Mix { .. } | Material::Interface);
        let perturbation = if own { normal_perturbation(textures, e)? } else { None };
        // Bump mapping steps by half the footprint (pbrt-v4's `BumpMap`), whatever its displacement texture is.
        let bumps = matches!(perturbation, Some(NormalPerturbation::Bump(_)));
        reads_footprint.push(textures.take_image_use() || bumps);
        perturbations.push(perturbation);
        materials.push(m);
    }
    // A mix needs the footprint if a material it may pick does (mixes nest: one pass per level).
    for _ in 0..materials.len() {
        let mut changed = false;
        for (i, m) in materials.iter().enumerate() {
            if let Material::Mix { materials: picks, .. } = m {
                let any = picks.iter().any(|&k| reads_footprint.get(k as usize).copied().unwrap_or(false));
                if any && !reads_footprint[i] {
                    reads_footprint[i] = true;
                    changed = true;
                }
            }
        }
        if !changed {
            break;
        }
    }
    Ok(Materials::new(materials, perturbations, interiors, reads_footprint, names))
}

/// pbrt-v4's `"string normalmap"` (an image read linearly) or `"texture displacement"` (a float texture, or a
/// constant) on any material; the normal map wins when both are given, as in pbrt-v4.
fn normal_perturbation(t: &Textures, e: &Entity) -> Result<Option<NormalPerturbation>> {
    let p = &e.params;
    let displacement = if p.contains("displacement") { Some(t.float_param(p, "displacement", 0.0)?) } else { None };
    if p.param_type("normalmap") == Some(ParamType::Texture) {
        return normal_texture(t, p, &e.loc, "normalmap", "normalscale").map(Some);
    }
    if let Some(path) = p.get_filename("normalmap")? {
        let loc = p.loc_of("normalmap", &e.loc);
        let source = ImageSource::File(path);
        let image = t.image(&source, ColorEncoding::Linear, "linear", ChannelSelect::Rgb, &loc)?;
        return Ok(Some(NormalPerturbation::NormalMap(image)));
    }
    Ok(displacement.map(NormalPerturbation::Bump))
}

/// Prismatic's `"texture {map}"` (an imagemap spectrum texture, a tangent-space normal map as glTF stores them) with
/// its `"float {scale}"` (glTF's `normalTextureInfo.scale`, default 1).
fn normal_texture(t: &Textures, p: &ParamSet, loc: &Loc, map: &str, scale: &str) -> Result<NormalPerturbation> {
    let name = p.get_texture(map).unwrap_or_default();
    let Some(tex) = t.image_texture(&name) else {
        return err(
            &p.loc_of(map, loc),
            format!("'{map}' must name an imagemap spectrum texture; '{name}' is not one"),
        );
    };
    let s = p.get_float(scale, 1.0)?;
    if !s.is_finite() {
        return err(&p.loc_of(scale, loc), format!("'{scale}' must be finite, got {s}"));
    }
    Ok(NormalPerturbation::NormalTexture { tex: Box::new(tex), scale: s as f32 })
}

/// The layers glTF's extensions put on a `metallicroughness` material, each there if one of its parameters is
/// given (docs/scene-format.md): `specular` and `specularcolor`; `iridescence` with `iridescenceeta` (default 1.3)
/// and `iridescencethickness` (nm, default 400); `sheencolor` with `sheenroughness`; `clearcoat` with
/// `clearcoatroughness` and `clearcoatnormalmap`/`clearcoatnormalscale`; `anisotropy` with `anisotropyrotation`
/// (radians) and `anisotropytexture`.
fn metallic_roughness_layers(t: &Textures, p: &ParamSet, loc: &Loc) -> Result<MetallicRoughnessLayers> {
    let mut layers = MetallicRoughnessLayers::default();
    if p.contains("specular") || p.contains("specularcolor") {
        layers.specular = Some(SpecularLayer {
            weight: t.float_param(p, "specular", 1.0)?,
            color: t.spectrum_param(p, "specularcolor", SpectrumKind::Unbounded, 1.0)?,
            color_max: color_max(t, p, loc, "specularcolor", 1.0)?,
        });
    }
    if p.contains("iridescence") {
        let thickness = t.float_param(p, "iridescencethickness", 400.0)?;
        if let FloatTexture::Constant(v) = thickness {
            if !(v.is_finite() && v >= 0.0) {
                let at = p.loc_of("iridescencethickness", loc);
                return err(&at, thickness_message("iridescencethickness", v as f64));
            }
        }
        let index = layer_index(named_eta(p, loc, "iridescenceeta", 1.3)?);
        layers.iridescence = Some(IridescenceLayer {
            weight: t.float_param(p, "iridescence", 0.0)?,
            film: Coating { layers: vec![CoatingLayer { index, thickness }] },
        });
    }
    if p.contains("sheencolor") {
        layers.sheen = Some(SheenLayer {
            color: t.spectrum_param(p, "sheencolor", SpectrumKind::Albedo, 0.0)?,
            color_max: color_max(t, p, loc, "sheencolor", 0.0)?,
            roughness: t.float_param(p, "sheenroughness", 0.0)?,
        });
    }
    if p.contains("clearcoat") {
        let normal_map = if p.contains("clearcoatnormalmap") {
            Some(normal_texture(t, p, loc, "clearcoatnormalmap", "clearcoatnormalscale")?)
        } else {
            None
        };
        layers.clearcoat = Some(ClearcoatLayer {
            weight: t.float_param(p, "clearcoat", 0.0)?,
            roughness: t.float_param(p, "clearcoatroughness", 0.0)?,
            normal_map,
        });
    }
    if p.contains("anisotropy") || p.contains("anisotropytexture") {
        let strength = p.get_float("anisotropy", 0.0)?;
        if !(0.0..=1.0).contains(&strength) {
            return err(&p.loc_of("anisotropy", loc), format!("'anisotropy' must be in [0, 1], got {strength}"));
        }
        let rotation = p.get_float("anisotropyrotation", 0.0)?;
        if !(rotation as f32).is_finite() {
            return err(
                &p.loc_of("anisotropyrotation", loc),
                format!("'anisotropyrotation' must be finite, got {rotation}"),
            );
        }
        let texture = match p.get_texture("anisotropytexture") {
            None => None,
            Some(name) => match t.image_texture(&name) {
                Some(tex) => Some(Box::new(tex)),
                None => {
                    let at = p.loc_of("anisotropytexture", loc);
                    return err(
                        &at,
                        format!("'anisotropytexture' must name an imagemap spectrum texture; '{name}' is not one"),
                    );
                }
            },
        };
        layers.anisotropy = Some(AnisotropyLayer { strength: strength as f32, rotation: rotation as f32, texture });
    }
    Ok(layers)
}

/// The largest RGB channel of colour parameter `name` (glTF's `max_value`): of an `rgb` value, of an imagemap's
/// tinted texels, or the largest value of any other constant spectrum over 360–830 nm.
fn color_max(t: &Textures, p: &ParamSet, loc: &Loc, name: &str, default: f64) -> Result<FloatTexture> {
    if p.param_type(name) == Some(ParamType::Rgb) {
        if let Some(rgb) = p.get_rgb(name)? {
            return Ok(FloatTexture::Constant(rgb.iter().fold(0.0f64, |m, &v| m.max(v)) as f32));
        }
    }
    if p.param_type(name) == Some(ParamType::Texture) {
        let tex_name = p.get_texture(name).unwrap_or_default();
        return match t.image_texture(&tex_name) {
            Some(tex) => Ok(FloatTexture::ImageMaxChannel(Box::new(tex))),
            None => err(
                &p.loc_of(name, loc),
                format!("'{name}' must be a colour or an imagemap texture (its largest channel is needed); '{tex_name}' is not one"),
            ),
        };
    }
    // Not a texture here, so a constant.
    let SpectrumTexture::Constant(s) = t.spectrum_param(p, name, SpectrumKind::Unbounded, default)? else {
        return err(&p.loc_of(name, loc), format!("'{name}' must be a colour or an imagemap texture"));
    };
    Ok(FloatTexture::Constant((360..=830).map(|l| s.eval(l as f64)).fold(0.0f64, f64::max) as f32))
}

fn roughness(t: &Textures, p: &ParamSet) -> Result<Roughness> {
    prefixed_roughness(t, p, "")
}

/// `{prefix}roughness`, overridden per direction by `{prefix}uroughness`/`{prefix}vroughness`, and the shared
/// `remaproughness`.
fn prefixed_roughness(t: &Textures, p: &ParamSet, prefix: &str) -> Result<Roughness> {
    let name = |n: &str| format!("{prefix}{n}");
    let r = t.float_param(p, &name("roughness"), 0.0)?;
    let u = if p.contains(&name("uroughness")) { t.float_param(p, &name("uroughness"), 0.0)? } else { r.clone() };
    let v = if p.contains(&name("vroughness")) { t.float_param(p, &name("vroughness"), 0.0)? } else { r };
    Ok(Roughness { u, v, remap: p.get_bool("remaproughness", true)? })
}

/// A conductor's optical constants: `reflectance`, or the spectra `eta_name` and `k_name` (copper by default).
fn conductor_spec(t: &Textures, p: &ParamSet, loc: &Loc, eta_name: &str, k_name: &str) -> Result<ConductorSpec> {
    if p.contains("reflectance") {
        if p.contains(eta_name) || p.contains(k_name) {
            return err(loc, format!("give either 'reflectance' or '{eta_name}' and '{k_name}', not both"));
        }
        return Ok(ConductorSpec::Reflectance(t.spectrum_param(p, "reflectance", SpectrumKind::Albedo, 0.0)?));
    }
    let eta = match p.get_spectrum_texture(eta_name, SpectrumKind::Unbounded)? {
        Some(_) => t.spectrum_param(p, eta_name, SpectrumKind::Unbounded, 1.0)?,
        None => SpectrumTexture::Constant(named_metal("metal-Cu-eta", loc)?),
    };
    let k = match p.get_spectrum_texture(k_name, SpectrumKind::Unbounded)? {
        Some(_) => t.spectrum_param(p, k_name, SpectrumKind::Unbounded, 0.0)?,
        None => SpectrumTexture::Constant(named_metal("metal-Cu-k", loc)?),
    };
    Ok(ConductorSpec::EtaK { eta, k })
}

/// Prismatic's thin-film coating of a material (docs/scene-format.md): one layer of `filmthickness` nm (a float or
/// a float texture) whose index is `filmeta` (a float or a spectrum) or the catalogue's `filmmaterial`; or a stack
/// of `filmthicknesses` with as many `filmmaterials` (catalogue names or numbers), outermost first. No layers
/// without these parameters.
fn coating(t: &Textures, p: &ParamSet, loc: &Loc) -> Result<Coating> {
    let at = |name: &str| p.loc_of(name, loc);
    let single = ["filmthickness", "filmeta", "filmmaterial"].into_iter().find(|n| p.contains(n));
    let stack = ["filmthicknesses", "filmmaterials"].into_iter().find(|n| p.contains(n));
    let thickness_error = |name: &str, v: f64| err(&at(name), thickness_message(name, v));
    match (single, stack) {
        (None, None) => Ok(Coating::default()),
        (Some(a), Some(b)) => err(&at(b), format!("give one film ('{a}') or a stack ('{b}'), not both")),
        (Some(_), None) => {
            if !p.contains("filmthickness") {
                return err(loc, "a film needs its 'filmthickness' (nm)");
            }
            let thickness = film_thickness(t, p, loc, 0.0)?;
            let index = match (p.contains("filmeta"), p.contains("filmmaterial")) {
                (true, true) => return err(&at("filmmaterial"), "give 'filmeta' or 'filmmaterial', not both"),
                (false, false) => return err(loc, "a film needs its index: 'filmeta' or 'filmmaterial'"),
                (true, false) => layer_index(named_eta(p, loc, "filmeta", 1.5)?),
                (false, true) => {
                    film_material(&p.get_string("filmmaterial", "")?, &at("filmmaterial"), "filmmaterial")?
                }
            };
            Ok(Coating { layers: vec![CoatingLayer { index, thickness }] })
        }
        (None, Some(_)) => {
            let thicknesses = p.get_floats("filmthicknesses").unwrap_or(&[]);
            let materials = p.get_strings("filmmaterials").unwrap_or(&[]);
            if thicknesses.len() != materials.len() || thicknesses.is_empty() {
                return err(
                    &at(if p.contains("filmthicknesses") { "filmthicknesses" } else { "filmmaterials" }),
                    format!(
                        "'filmthicknesses' and 'filmmaterials' need one entry per layer ({} and {})",
                        thicknesses.len(),
                        materials.len()
                    ),
                );
            }
            let mut layers = Vec::with_capacity(thicknesses.len());
            for (&d, name) in thicknesses.iter().zip(materials) {
                if !(d.is_finite() && d >= 0.0) {
                    return thickness_error("filmthicknesses", d);
                }
                let index = film_material(name, &at("filmmaterials"), "filmmaterials")?;
                layers.push(CoatingLayer { index, thickness: FloatTexture::Constant(d as f32) });
            }
            Ok(Coating { layers })
        }
    }
}

/// Prismatic's free-standing film (`Material "thinfilm"`, docs/scene-format.md): one layer of `filmthickness` nm (a
/// float or a float texture, default 500) whose index is given as a dielectric's (`eta`, `glass`, Sellmeier or Abbe
/// forms; default 1.33, a soap film's water).
fn free_film(t: &Textures, p: &ParamSet, loc: &Loc) -> Result<Coating> {
    let thickness = film_thickness(t, p, loc, 500.0)?;
    let index = layer_index(dielectric_ior(p, loc, 1.33)?);
    Ok(Coating { layers: vec![CoatingLayer { index, thickness }] })
}

/// `filmthickness` (nm, a float or a float texture): a constant must be finite and ≥ 0 (a texture's values are
/// clamped at 0 where evaluated).
fn film_thickness(t: &Textures, p: &ParamSet, loc: &Loc, default: f64) -> Result<FloatTexture> {
    let thickness = t.float_param(p, "filmthickness", default)?;
    if let FloatTexture::Constant(v) = thickness {
        if !(v.is_finite() && v >= 0.0) {
            return err(&p.loc_of("filmthickness", loc), thickness_message("filmthickness", v as f64));
        }
    }
    Ok(thickness)
}

fn thickness_message(name: &str, v: f64) -> String {
    format!("'{name}' must be a finite thickness ≥ 0 nm, got {v}")
}

/// A dielectric's index as a film layer's.
fn layer_index(ior: DielectricIor) -> LayerIndex {
    match ior {
        DielectricIor::Model(m) => LayerIndex::Model(m),
        DielectricIor::Spectrum(s) => LayerIndex::Spectrum(s),
    }
}

/// A film layer's index by name: a catalogue entry (`prismatic ior --list`; metals bring their k) or a number.
fn film_material(name: &str, loc: &Loc, param: &str) -> Result<LayerIndex> {
    let ior = match name.trim().parse::<f64>() {
        Ok(n) => optics::Ior::constant(n),
        Err(_) => optics::catalogue::lookup(name).map(|entry| entry.ior),
    };
    match ior {
        Ok(ior) => Ok(LayerIndex::Model(ior)),
        Err(e) => err(loc, format!("'{param}': {e}")),
    }
}

/// The medium of a layered material: `thickness` (> 0, default 0.01), `albedo` (default 0), `g` (in (−1, 1),
/// default 0), `maxdepth` (default 10) and `nsamples` (default 1), pbrt-v4's names and defaults.
fn layer_medium(t: &Textures, p: &ParamSet, loc: &Loc) -> Result<LayerMedium> {
    let at = |name: &str| p.loc_of(name, loc);
    let thickness = finite_positive(&at("thickness"), "thickness", p.get_float("thickness", 0.01)?)?;
    let g = t.float_param(p, "g", 0.0)?;
    if let FloatTexture::Constant(v) = g {
        if !(v > -1.0 && v < 1.0) {
            return err(&at("g"), format!("'g' (Henyey–Greenstein asymmetry) must be in (−1, 1), got {v}"));
        }
    }
    Ok(LayerMedium {
        thickness: thickness as f32,
        albedo: t.spectrum_param(p, "albedo", SpectrumKind::Albedo, 0.0)?,
        g,
        max_depth: p.get_int("maxdepth", 10)?.clamp(1, 1000) as u32,
        n_samples: p.get_int("nsamples", 1)?.clamp(1, 1000) as u32,
    })
}

/// The index of refraction of a dielectric: pbrt's `eta` (float or spectrum), or Prismatic's extensions `glass`,
/// `sellmeierB`/`sellmeierC`, and `abbe` with `eta` as n_d (docs/scene-format.md).
fn dielectric_ior(p: &ParamSet, loc: &Loc, default: f64) -> Result<DielectricIor> {
    let bad = |name: &str, e: optics::OpticsError| {
        let l = p.loc_of(name, loc);
        SceneError::at(l, format!("'{name}': {e}"))
    };
    if p.contains("glass") {
        let name = p.get_string("glass", "")?;
        let entry = optics::catalogue::lookup(&name).map_err(|e| bad("glass", e))?;
        if entry.ior.is_complex() {
            return err(loc, format!("'glass' names '{name}', a metal; use the conductor material"));
        }
        return Ok(DielectricIor::Model(entry.ior));
    }
    if p.contains("sellmeierB") || p.contains("sellmeierC") {
        let b = p.get_floats("sellmeierB").unwrap_or(&[]).to_vec();
        let c = p.get_floats("sellmeierC").unwrap_or(&[]).to_vec();
        if b.is_empty() || b.len() != c.len() {
            return err(
                loc,
                format!("'sellmeierB' and 'sellmeierC' need the same number of terms ({} vs {})", b.len(), c.len()),
            );
        }
        let terms: Vec<(f64, f64)> = b.into_iter().zip(c).collect();
        return Ok(DielectricIor::Model(optics::Ior::sellmeier(0.0, &terms).map_err(|e| bad("sellmeierB", e))?));
    }
    if p.contains("abbe") {
        let vd = p.get_float("abbe", 0.0)?;
        let nd = p.get_float("eta", default)?;
        return Ok(DielectricIor::Model(optics::Ior::abbe(nd, vd).map_err(|e| bad("abbe", e))?));
    }
    named_eta(p, loc, "eta", default)
}

/// A dielectric index given as a float or a spectrum under `name`.
fn named_eta(p: &ParamSet, loc: &Loc, name: &str, default: f64) -> Result<DielectricIor> {
    match p.param_type(name) {
        Some(ParamType::Float) | None => {
            let n = p.get_float(name, default)?;
            let ior = optics::Ior::constant(n).map_err(|e| {
                let l = p.loc_of(name, loc);
                SceneError::at(l, format!("'{name}': {e}"))
            })?;
            Ok(DielectricIor::Model(ior))
        }
        // Any other type: read as a spectrum, whose reader refuses the types a spectrum cannot be given as.
        Some(
            ParamType::Integer
            | ParamType::Bool
            | ParamType::String
            | ParamType::Point2
            | ParamType::Vector2
            | ParamType::Point3
            | ParamType::Vector3
            | ParamType::Normal3
            | ParamType::Rgb
            | ParamType::Spectrum
            | ParamType::Blackbody
            | ParamType::Texture,
        ) => {
            let s = p.get_spectrum(name, SpectrumKind::Unbounded)?.unwrap_or(Spectrum::Constant(default));
            Ok(DielectricIor::Spectrum(s))
        }
    }
}

/// The measured BRDFs read so far, by path: each file is read once however many materials name it (as pbrt-v4
/// caches them).
#[derive(Default)]
struct MeasuredFiles(RefCell<HashMap<PathBuf, Arc<MeasuredBrdf>>>);

impl MeasuredFiles {
    /// pbrt-v4's `measured` material: `string filename`, an RGL tensor file (resolved like every file name).
    fn material(&self, e: &Entity) -> Result<Material> {
        let p = &e.params;
        let loc = p.loc_of("filename", &e.loc);
        let Some(path) = p.get_filename("filename")? else {
            return err(&e.loc, "the measured material needs 'string filename' (an RGL .bsdf tensor file)");
        };
        if let Some(brdf) = self.0.borrow().get(&path) {
            return Ok(Material::Measured { brdf: brdf.clone() });
        }
        // The error names the file.
        let brdf = MeasuredBrdf::read(&path).map_err(|e| file_err(&loc, &path, format!("'filename': {e}")))?;
        let brdf = Arc::new(brdf);
        self.0.borrow_mut().insert(path, brdf.clone());
        Ok(Material::Measured { brdf })
    }
}

fn material(t: &Textures, e: &Entity, names: &HashMap<String, u32>, measured: &MeasuredFiles) -> Result<Material> {
    let p = &e.params;
    Ok(match e.name.as_str() {
        "diffuse" => Material::Diffuse { reflectance: t.spectrum_param(p, "reflectance", SpectrumKind::Albedo, 0.5)? },
        "diffusetransmission" => {
            // pbrt-v4's defaults: 0.25 each, scale 1 (a float, not a texture).
            let scale = p.get_float("scale", 1.0)?;
            if !(scale.is_finite() && scale >= 0.0) {
                return err(&p.loc_of("scale", &e.loc), format!("'scale' must be a finite number ≥ 0, got {scale}"));
            }
            Material::DiffuseTransmission {
                reflectance: t.spectrum_param(p, "reflectance", SpectrumKind::Albedo, 0.25)?,
                transmittance: t.spectrum_param(p, "transmittance", SpectrumKind::Albedo, 0.25)?,
                scale: scale as f32,
            }
        }
        "conductor" => Material::Conductor {
            spec: conductor_spec(t, p, &e.loc, "eta", "k")?,
            roughness: roughness(t, p)?,
            coating: coating(t, p, &e.loc)?,
        },
        "dielectric" => Material::Dielectric {
            ior: dielectric_ior(p, &e.loc, 1.5)?,
            roughness: roughness(t, p)?,
            coating: coating(t, p, &e.loc)?,
            // Prismatic's `transmissiontint` (glTF's base colour on a transmissive material): an albedo.
            tint: if p.contains("transmissiontint") {
                Some(t.spectrum_param(p, "transmissiontint", SpectrumKind::Albedo, 1.0)?)
            } else {
                None
            },
        },
        "thindielectric" => Material::ThinDielectric { ior: dielectric_ior(p, &e.loc, 1.5)? },
        "metallicroughness" => {
            let ior = p.get_float("ior", 1.5)?;
            if !(ior.is_finite() && (ior >= 1.0 || ior == 0.0)) {
                return err(
                    &p.loc_of("ior", &e.loc),
                    format!("'ior' must be a number ≥ 1 (or 0, infinite), got {ior}"),
                );
            }
            Material::MetallicRoughness {
                base_color: t.spectrum_param(p, "basecolor", SpectrumKind::Albedo, 1.0)?,
                metallic: t.float_param(p, "metallic", 1.0)?,
                roughness: t.float_param(p, "roughness", 1.0)?,
                ior: ior as f32,
                layers: Box::new(metallic_roughness_layers(t, p, &e.loc)?),
            }
        }
        "thinfilm" => Material::ThinFilm { film: free_film(t, p, &e.loc)? },
        "coateddiffuse" => Material::CoatedDiffuse {
            reflectance: t.spectrum_param(p, "reflectance", SpectrumKind::Albedo, 0.5)?,
            roughness: roughness(t, p)?,
            ior: dielectric_ior(p, &e.loc, 1.5)?,
            medium: layer_medium(t, p, &e.loc)?,
        },
        "coatedconductor" => Material::CoatedConductor {
            conductor: conductor_spec(t, p, &e.loc, "conductor.eta", "conductor.k")?,
            conductor_roughness: prefixed_roughness(t, p, "conductor.")?,
            interface_roughness: prefixed_roughness(t, p, "interface.")?,
            interface_ior: named_eta(p, &e.loc, "interface.eta", 1.5)?,
            medium: layer_medium(t, p, &e.loc)?,
        },
        "mix" => {
            let Some(m) = p.get_strings("materials") else {
                return err(&e.loc, "mix needs 'string materials' [two names]");
            };
            if m.len() != 2 {
                return err(&e.loc, format!("mix needs exactly two materials, got {}", m.len()));
            }
            let idx = |n: &str| {
                names
                    .get(n)
                    .copied()
                    .ok_or_else(|| SceneError::at(e.loc.clone(), format!("mix: no material named '{n}'")))
            };
            Material::Mix { materials: [idx(&m[0])?, idx(&m[1])?], amount: t.float_param(p, "amount", 0.5)? }
        }
        "interface" => Material::Interface,
        "measured" => measured.material(e)?,
        other => {
            return err(
                &e.loc,
                unsupported(
                    "material",
                    other,
                    &[
                        "diffuse",
                        "diffusetransmission",
                        "conductor",
                        "dielectric",
                        "thindielectric",
                        "thinfilm",
                        "metallicroughness",
                        "coateddiffuse",
                        "coatedconductor",
                        "mix",
                        "interface",
                        "subsurface",
                        "measured",
                    ],
                ),
            )
        }
    })
}

fn named_metal(name: &str, loc: &Loc) -> Result<Spectrum> {
    Ok(optics::catalogue::named_spectrum_checked(name).map_err(|e| SceneError::at(loc.clone(), e.to_string()))?)
}

//! The material extensions that put layers on the metallic-roughness BRDF — `KHR_materials_specular`,
//! `_iridescence`, `_sheen`, `_clearcoat` and `_anisotropy` — read from the material's JSON (the gltf crate keeps them unparsed)
//! into the `metallicroughness` material's parameters (docs/scene-format.md), with their textures as image maps.

use scene::{Param, ParamSet, TextureEntity, TextureValueType};
use serde_json::{Map, Value};

use crate::textures::{TextureMaker, TextureRef};
use crate::{float, rgb, string, texture_param, GltfError};

/// A material extension's JSON object and its JSON path.
struct RawExtension<'m> {
    object: &'m Map<String, Value>,
    json: String,
}

impl<'m> RawExtension<'m> {
    /// Extension `name` of material `m` (JSON path `material_json`), if the material has it.
    fn of(m: &'m gltf::Material<'_>, name: &str, material_json: &str) -> Result<Option<Self>, (String, String)> {
        let Some(value) = m.extensions().and_then(|e| e.get(name)) else { return Ok(None) };
        let json = format!("{material_json}.extensions.{name}");
        match value.as_object() {
            Some(object) => Ok(Some(Self { object, json })),
            None => Err((json, "must be an object".into())),
        }
    }

    fn at(&self, key: &str) -> String {
        format!("{}.{key}", self.json)
    }

    /// Number `key` (finite, within `range`), or `default` without one.
    fn number(&self, key: &str, default: f64, range: (f64, f64)) -> Result<f64, (String, String)> {
        let Some(v) = self.object.get(key) else { return Ok(default) };
        match v.as_f64() {
            Some(x) if x.is_finite() && x >= range.0 && x <= range.1 => Ok(x),
            _ => Err((self.at(key), format!("must be a number in [{}, {}]", range.0, range.1))),
        }
    }

    /// Colour `key` (three finite numbers ≥ 0), or `default` without one.
    fn color(&self, key: &str, default: [f64; 3]) -> Result<[f64; 3], (String, String)> {
        let Some(v) = self.object.get(key) else { return Ok(default) };
        let values: Option<Vec<f64>> = v.as_array().and_then(|a| a.iter().map(Value::as_f64).collect());
        match values.as_deref() {
            Some(&[r, g, b]) if [r, g, b].iter().all(|c| c.is_finite() && *c >= 0.0) => Ok([r, g, b]),
            _ => Err((self.at(key), "must be three finite numbers ≥ 0".into())),
        }
    }

    /// Texture reference `key` (a `textureInfo`, or with `normal` a `normalTextureInfo` whose `scale` comes too).
    fn texture<'d>(
        &self,
        key: &str,
        doc: &'d gltf::Document,
    ) -> Result<Option<(TextureRef<'d>, f64)>, (String, String)> {
        let Some(info) = self.object.get(key) else { return Ok(None) };
        let at = self.at(key);
        let index = info.get("index").and_then(Value::as_u64);
        let Some(texture) = index.and_then(|i| doc.textures().nth(usize::try_from(i).ok()?)) else {
            return Err((format!("{at}.index"), format!("must name one of the {} textures", doc.textures().len())));
        };
        let scale = match info.get("scale") {
            None => 1.0,
            Some(s) => {
                s.as_f64().filter(|s| s.is_finite()).ok_or((format!("{at}.scale"), "must be a finite number".into()))?
            }
        };
        Ok(Some((TextureRef::raw(texture, info, at), scale)))
    }
}

/// Adds the layers of material `m` (JSON path `json`, textures named after `name`) to the opaque part's
/// parameters `opaque`, and the iridescence film to the transmitted part's parameters `glass`.
pub(crate) fn add_layers(
    t: &mut TextureMaker<'_>,
    name: &str,
    m: &gltf::Material<'_>,
    json: &str,
    opaque: &mut ParamSet,
    glass: &mut Vec<Param>,
) -> Result<(), GltfError> {
    let doc = t.document;
    let fail = |t: &TextureMaker<'_>, (path, message): (String, String)| GltfError {
        file: t.path.to_path_buf(),
        path,
        message,
    };
    let loc = t.loc.clone();
    let unit = (0.0, 1.0);

    // KHR_materials_specular: f₀ × specularColor (sRGB texture × factor), weight = specularFactor × texture alpha.
    if let Some(x) = RawExtension::of(m, "KHR_materials_specular", json).map_err(|e| fail(t, e))? {
        let weight = x.number("specularFactor", 1.0, unit).map_err(|e| fail(t, e))?;
        let color = x.color("specularColorFactor", [1.0; 3]).map_err(|e| fail(t, e))?;
        let tex = x.texture("specularTexture", doc).map_err(|e| fail(t, e))?;
        float_or_texture(t, opaque, "specular", weight, tex.map(|t| t.0), "a", &format!("{name}/specular"))?;
        let tex = x.texture("specularColorTexture", doc).map_err(|e| fail(t, e))?;
        color_or_texture(t, opaque, "specularcolor", color, tex.map(|t| t.0), &format!("{name}/specularcolor"))?;
    }

    // KHR_materials_iridescence: a film of iridescenceIor between the thickness bounds (the texture's green
    // channel mixes them; without it the film is the maximum thick).
    if let Some(x) = RawExtension::of(m, "KHR_materials_iridescence", json).map_err(|e| fail(t, e))? {
        let factor = x.number("iridescenceFactor", 0.0, unit).map_err(|e| fail(t, e))?;
        let weight_tex = x.texture("iridescenceTexture", doc).map_err(|e| fail(t, e))?;
        if factor > 0.0 {
            let ior = x.number("iridescenceIor", 1.3, (1.0, f64::MAX)).map_err(|e| fail(t, e))?;
            let thick = (0.0, 1e6);
            let min = x.number("iridescenceThicknessMinimum", 100.0, thick).map_err(|e| fail(t, e))?;
            let max = x.number("iridescenceThicknessMaximum", 400.0, thick).map_err(|e| fail(t, e))?;
            let weight_name = format!("{name}/iridescence");
            float_or_texture(t, opaque, "iridescence", factor, weight_tex.map(|t| t.0), "r", &weight_name)?;
            opaque.push(float("iridescenceeta", ior, &loc));
            glass.push(float("filmeta", ior, &loc));
            match x.texture("iridescenceThicknessTexture", doc).map_err(|e| fail(t, e))? {
                None => {
                    opaque.push(float("iridescencethickness", max, &loc));
                    glass.push(float("filmthickness", max, &loc));
                }
                Some((tex, _)) => {
                    let g = format!("{name}/iridescencethickness/g");
                    let extra = vec![
                        string("channel", "g", &loc),
                        float("scale", 1.0, &loc),
                        string("encoding", "linear", &loc),
                    ];
                    t.imagemap(&g, TextureValueType::Float, &tex, extra)?;
                    // thickness = mix(min, max, g), as the extension defines it.
                    let thickness = format!("{name}/iridescencethickness");
                    let mut p = ParamSet::new();
                    p.push(float("tex1", min, &loc));
                    p.push(float("tex2", max, &loc));
                    p.push(texture_param("amount", &g, &loc));
                    t.desc.textures.push(TextureEntity {
                        entity: scene::Entity::new("mix", p, loc.clone()),
                        texture_name: thickness.clone(),
                        value_type: TextureValueType::Float,
                        render_from_texture: geometry::Transform::IDENTITY,
                    });
                    opaque.push(texture_param("iridescencethickness", &thickness, &loc));
                    glass.push(texture_param("filmthickness", &thickness, &loc));
                }
            }
        }
    }

    // KHR_materials_sheen: colour (sRGB texture × factor) and roughness (texture alpha × factor); a black sheen
    // colour factor turns the layer off.
    if let Some(x) = RawExtension::of(m, "KHR_materials_sheen", json).map_err(|e| fail(t, e))? {
        let color = x.color("sheenColorFactor", [0.0; 3]).map_err(|e| fail(t, e))?.map(|c| c.min(1.0));
        if color.iter().any(|&c| c > 0.0) {
            let tex = x.texture("sheenColorTexture", doc).map_err(|e| fail(t, e))?;
            color_or_texture(t, opaque, "sheencolor", color, tex.map(|t| t.0), &format!("{name}/sheencolor"))?;
            let roughness = x.number("sheenRoughnessFactor", 0.0, unit).map_err(|e| fail(t, e))?;
            let tex = x.texture("sheenRoughnessTexture", doc).map_err(|e| fail(t, e))?;
            let tname = format!("{name}/sheenroughness");
            float_or_texture(t, opaque, "sheenroughness", roughness, tex.map(|t| t.0), "a", &tname)?;
        }
    }

    // KHR_materials_clearcoat: weight (texture red × factor), roughness (texture green × factor) and the coat's
    // own normal map; a zero factor turns the layer off.
    if let Some(x) = RawExtension::of(m, "KHR_materials_clearcoat", json).map_err(|e| fail(t, e))? {
        let weight = x.number("clearcoatFactor", 0.0, unit).map_err(|e| fail(t, e))?;
        if weight > 0.0 {
            let tex = x.texture("clearcoatTexture", doc).map_err(|e| fail(t, e))?;
            float_or_texture(t, opaque, "clearcoat", weight, tex.map(|t| t.0), "r", &format!("{name}/clearcoat"))?;
            let roughness = x.number("clearcoatRoughnessFactor", 0.0, unit).map_err(|e| fail(t, e))?;
            let tex = x.texture("clearcoatRoughnessTexture", doc).map_err(|e| fail(t, e))?;
            let tname = format!("{name}/clearcoatroughness");
            float_or_texture(t, opaque, "clearcoatroughness", roughness, tex.map(|t| t.0), "g", &tname)?;
            if let Some((tex, scale)) = x.texture("clearcoatNormalTexture", doc).map_err(|e| fail(t, e))? {
                let tname = format!("{name}/clearcoatnormal");
                t.imagemap(&tname, TextureValueType::Spectrum, &tex, vec![string("encoding", "linear", &loc)])?;
                opaque.push(texture_param("clearcoatnormalmap", &tname, &loc));
                opaque.push(float("clearcoatnormalscale", scale, &loc));
            }
        }
    }
    // KHR_materials_anisotropy: strength and rotation, and a texture (linear) of the direction (red, green) and the
    // strength's factor (blue); a zero strength without a texture turns it off.
    if let Some(x) = RawExtension::of(m, "KHR_materials_anisotropy", json).map_err(|e| fail(t, e))? {
        let strength = x.number("anisotropyStrength", 0.0, unit).map_err(|e| fail(t, e))?;
        let rotation = x.number("anisotropyRotation", 0.0, (f64::MIN, f64::MAX)).map_err(|e| fail(t, e))?;
        let tex = x.texture("anisotropyTexture", doc).map_err(|e| fail(t, e))?;
        if strength > 0.0 {
            opaque.push(float("anisotropy", strength, &loc));
            opaque.push(float("anisotropyrotation", rotation, &loc));
            if let Some((tex, _)) = tex {
                let tname = format!("{name}/anisotropy");
                t.imagemap(&tname, TextureValueType::Spectrum, &tex, vec![string("encoding", "linear", &loc)])?;
                opaque.push(texture_param("anisotropytexture", &tname, &loc));
            }
        }
    }
    Ok(())
}

/// Float parameter `param`: `factor`, or texture `tex`'s `channel` (linear) times it, added as `tname`.
fn float_or_texture(
    t: &mut TextureMaker<'_>,
    p: &mut ParamSet,
    param: &str,
    factor: f64,
    tex: Option<TextureRef<'_>>,
    channel: &str,
    tname: &str,
) -> Result<(), GltfError> {
    let loc = t.loc.clone();
    match tex {
        None => p.push(float(param, factor, &loc)),
        Some(tex) => {
            let extra = vec![
                string("channel", channel, &loc),
                float("scale", factor, &loc),
                string("encoding", "linear", &loc),
            ];
            t.imagemap(tname, TextureValueType::Float, &tex, extra)?;
            p.push(texture_param(param, tname, &loc));
        }
    }
    Ok(())
}

/// Colour parameter `param`: `factor`, or texture `tex` (sRGB) times it, added as `tname`.
fn color_or_texture(
    t: &mut TextureMaker<'_>,
    p: &mut ParamSet,
    param: &str,
    factor: [f64; 3],
    tex: Option<TextureRef<'_>>,
    tname: &str,
) -> Result<(), GltfError> {
    let loc = t.loc.clone();
    match tex {
        None => p.push(rgb(param, factor, &loc)),
        Some(tex) => {
            let extra = vec![rgb("tint", factor, &loc), string("encoding", "sRGB", &loc)];
            t.imagemap(tname, TextureValueType::Spectrum, &tex, extra)?;
            p.push(texture_param(param, tname, &loc));
        }
    }
    Ok(())
}

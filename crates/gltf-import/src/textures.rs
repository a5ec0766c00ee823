//! glTF textures as Prismatic `imagemap` textures: each glTF image once into [`SceneDescription::images`] (from the
//! GLB's binary chunk, a data URI or a file beside the glTF), each texture reference as an image map reading it
//! with the sampler's wrap modes and filter, `KHR_texture_transform` as a `uvtransform`, and the colour factor,
//! channel and encoding the material's role asks for.

use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

use scene::{
    Diagnostic, EmbeddedImage, Entity, Loc, Param, ParamSet, ParamType, SceneDescription, TextureEntity,
    TextureValueType,
};

use crate::{decode_data_uri, floats, ints, percent_decode, string, strings, GltfError};

/// The glTF images already added to the description, by their index in the file.
#[derive(Debug, Default)]
pub(crate) struct ImageTable {
    added: HashMap<usize, usize>,
}

/// A texture reference's `KHR_texture_transform`.
#[derive(Clone, Copy, Debug)]
struct TexTransform {
    offset: [f64; 2],
    rotation: f64,
    scale: [f64; 2],
    tex_coord: Option<u32>,
}

/// One texture reference of a material (`textureInfo`, `normalTextureInfo`): the texture, the texture coordinate
/// set, its `KHR_texture_transform` (or the JSON error in it), and the JSON path errors and warnings name.
pub(crate) struct TextureRef<'a> {
    texture: gltf::Texture<'a>,
    tex_coord: u32,
    transform: Result<Option<TexTransform>, (String, String)>,
    json: String,
}

impl<'a> TextureRef<'a> {
    /// A `textureInfo` at JSON path `json` (the gltf crate reads its transform).
    pub(crate) fn info(info: &gltf::texture::Info<'a>, json: String) -> Self {
        let transform = info.texture_transform().map(|t| TexTransform {
            offset: t.offset().map(f64::from),
            rotation: f64::from(t.rotation()),
            scale: t.scale().map(f64::from),
            tex_coord: t.tex_coord(),
        });
        Self { texture: info.texture(), tex_coord: info.tex_coord(), transform: Ok(transform), json }
    }

    /// A `textureInfo` or `normalTextureInfo` of an extension the gltf crate keeps unparsed, `info` its JSON at path
    /// `json` (its `texCoord` and `KHR_texture_transform` are read from there).
    pub(crate) fn raw(texture: gltf::Texture<'a>, info: &serde_json::Value, json: String) -> Self {
        let tex_coord =
            info.get("texCoord").and_then(serde_json::Value::as_u64).map_or(0, |v| v.min(u64::from(u32::MAX)) as u32);
        let at = format!("{json}.extensions.KHR_texture_transform");
        let raw = info.get("extensions").and_then(|e| e.get("KHR_texture_transform"));
        let transform = raw.map(|t| raw_transform(t, &at)).transpose();
        Self { texture, tex_coord, transform, json }
    }

    /// A `normalTextureInfo` at JSON path `json` (its transform is read from the raw extension object, which the
    /// gltf crate keeps unparsed there).
    pub(crate) fn normal(info: &gltf::material::NormalTexture<'a>, json: String) -> Self {
        let raw = info.extension_value("KHR_texture_transform");
        let at = format!("{json}.extensions.KHR_texture_transform");
        let transform = raw.map(|t| raw_transform(t, &at)).transpose();
        Self { texture: info.texture(), tex_coord: info.tex_coord(), transform, json }
    }
}

/// A `KHR_texture_transform` object read from JSON; errors as (JSON path, message).
fn raw_transform(t: &serde_json::Value, json: &str) -> Result<TexTransform, (String, String)> {
    let pair = |key: &str, default: [f64; 2]| -> Result<[f64; 2], (String, String)> {
        let Some(v) = t.get(key) else { return Ok(default) };
        match v.as_array().map(|a| a.iter().map(serde_json::Value::as_f64).collect::<Vec<_>>()).as_deref() {
            Some(&[Some(a), Some(b)]) => Ok([a, b]),
            _ => Err((format!("{json}.{key}"), "must be two numbers".into())),
        }
    };
    let rotation = match t.get("rotation") {
        None => 0.0,
        Some(v) => v.as_f64().ok_or_else(|| (format!("{json}.rotation"), "must be a number".to_string()))?,
    };
    let tex_coord = t.get("texCoord").and_then(serde_json::Value::as_u64).map(|v| v.min(u64::from(u32::MAX)) as u32);
    Ok(TexTransform { offset: pair("offset", [0.0, 0.0])?, rotation, scale: pair("scale", [1.0, 1.0])?, tex_coord })
}

/// What makes textures for one file's materials: the description they go into, the file's buffers, and the
/// images added so far.
pub(crate) struct TextureMaker<'a> {
    pub(crate) document: &'a gltf::Document,
    pub(crate) desc: &'a mut SceneDescription,
    pub(crate) buffers: &'a [Vec<u8>],
    pub(crate) path: &'a Path,
    pub(crate) images: &'a mut ImageTable,
    pub(crate) loc: &'a Loc,
}

/// KHR_texture_transform's matrix as Prismatic's `uvtransform` on the mesh's (u, v).
///
/// The extension maps glTF's coordinates (u, v_g) (v_g down the image) by T·R·S: u′ = sx·cos r·u + sy·sin r·v_g +
/// ox, v′ = −sx·sin r·u + sy·cos r·v_g + oy. The reader stores v = 1 − v_g and image lookups take t = 1 − v′ from
/// the bottom row, so s = u′ and t = 1 − v′ become, in (u, v): s = sx·cos r·u − sy·sin r·v + (sy·sin r + ox),
/// t = sx·sin r·u + sy·cos r·v + (1 − sy·cos r − oy).
pub fn uv_transform(offset: [f64; 2], rotation: f64, scale: [f64; 2]) -> [f64; 6] {
    let (sin, cos) = rotation.sin_cos();
    let ([ox, oy], [sx, sy]) = (offset, scale);
    [sx * cos, -sy * sin, sy * sin + ox, sx * sin, sy * cos, 1.0 - sy * cos - oy]
}

impl TextureMaker<'_> {
    fn err(&self, json: &str, message: String) -> GltfError {
        GltfError { file: self.path.to_path_buf(), path: json.to_string(), message }
    }

    /// Adds texture `name` of `value_type`: an `imagemap` reading `tex` with the parameters `extra` (encoding,
    /// channel, scale, tint) besides those of its image, sampler and transform.
    pub(crate) fn imagemap(
        &mut self,
        name: &str,
        value_type: TextureValueType,
        tex: &TextureRef<'_>,
        extra: Vec<Param>,
    ) -> Result<(), GltfError> {
        let loc = self.loc.clone();
        let image = self.image(tex.texture.source())?;
        let mut params = ParamSet::new();
        params.push(ints("image", &[image as i64], &loc));
        let sampler = tex.texture.sampler();
        let axis = |w: gltf::texture::WrappingMode| match w {
            gltf::texture::WrappingMode::Repeat => "repeat".to_string(),
            gltf::texture::WrappingMode::ClampToEdge => "clamp".to_string(),
            gltf::texture::WrappingMode::MirroredRepeat => "mirror".to_string(),
        };
        params.push(strings("wrap", &[axis(sampler.wrap_s()), axis(sampler.wrap_t())], &loc));
        // Nearest magnification reads texels (pixel art); otherwise the footprint picks and blends MIP levels.
        let filter = match sampler.mag_filter() {
            Some(gltf::texture::MagFilter::Nearest) => "point",
            Some(gltf::texture::MagFilter::Linear) | None => "trilinear",
        };
        params.push(string("filter", filter, &loc));
        let mut tex_coord = tex.tex_coord;
        let transform = tex.transform.clone().map_err(|(json, message)| self.err(&json, message))?;
        if let Some(t) = transform {
            let m = uv_transform(t.offset, t.rotation, t.scale);
            if !m.iter().all(|v| v.is_finite() && v.abs() <= f64::from(f32::MAX)) {
                let at = format!("{}.extensions.KHR_texture_transform", tex.json);
                return Err(self.err(&at, "offset, rotation and scale must be finite".into()));
            }
            tex_coord = t.tex_coord.unwrap_or(tex_coord);
            params.push(floats(ParamType::Float, "uvtransform", &m, &loc));
        }
        if tex_coord != 0 {
            self.desc.warnings.push(Diagnostic::new(
                loc.clone(),
                format!("{}: texture coordinate set {tex_coord} is read as set 0 (only TEXCOORD_0 is read)", tex.json),
            ));
        }
        for p in extra {
            params.push(p);
        }
        self.desc.textures.push(TextureEntity {
            entity: Entity::new("imagemap", params, loc),
            texture_name: name.to_string(),
            value_type,
            render_from_texture: geometry::Transform::IDENTITY,
        });
        Ok(())
    }

    /// The index in the description's images of glTF image `image`, adding its bytes the first time.
    fn image(&mut self, image: gltf::Image<'_>) -> Result<usize, GltfError> {
        if let Some(&i) = self.images.added.get(&image.index()) {
            return Ok(i);
        }
        let at = format!("images[{}]", image.index());
        let bytes: Vec<u8> = match image.source() {
            gltf::image::Source::View { view, .. } => {
                let buffer = self.buffers.get(view.buffer().index()).map(Vec::as_slice).unwrap_or_default();
                let range = view.offset()..view.offset().saturating_add(view.length());
                buffer.get(range).map(<[u8]>::to_vec).ok_or_else(|| {
                    self.err(
                        &format!("{at}.bufferView"),
                        format!("bufferViews[{}] reaches past the end of its buffer", view.index()),
                    )
                })?
            }
            gltf::image::Source::Uri { uri, .. } => {
                if let Some(rest) = uri.strip_prefix("data:") {
                    decode_data_uri(rest).map_err(|m| self.err(&format!("{at}.uri"), m))?
                } else {
                    let file = self.path.parent().unwrap_or(Path::new("")).join(percent_decode(uri));
                    let bytes = geometry::gzip::read_bounded(&file, geometry::gzip::MAX_DECOMPRESSED_BYTES)
                        .map_err(|e| self.err(&format!("{at}.uri"), format!("cannot read {}: {e}", file.display())))?;
                    self.desc.files.push(file);
                    bytes
                }
            }
        };
        let name = format!("{}#{at}", self.path.display());
        self.desc.images.push(EmbeddedImage { name, bytes: Arc::from(bytes) });
        let index = self.desc.images.len() - 1;
        self.images.added.insert(image.index(), index);
        Ok(index)
    }
}

//! Textures: pbrt-v4's `Texture "name" "float"|"spectrum" "constant"|"checkerboard"|"imagemap"` directives (with
//! the `uv` mapping's `uscale`/`vscale`/`udelta`/`vdelta`), and the lookups materials make when a parameter names a
//! texture instead of giving a value.

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Arc;

use scene::{FloatParam, Loc, ParamSet, SceneDescription, SceneError, SpectrumKind, SpectrumParam, TextureValueType};
use spectral::Spectrum;

use super::{err, unsupported, Result};
use crate::texture::{FloatTexture, RgbImage, RgbKind, SpectrumTexture, UvMapping};

/// The scene's named textures. A spectrum texture is kept twice, uplifted as an albedo and as an unbounded
/// spectrum, because which one a parameter needs is only known where it is used.
pub(super) struct Textures {
    float: HashMap<String, FloatTexture>,
    spectrum: HashMap<String, (SpectrumTexture, SpectrumTexture)>, // (albedo, unbounded) variants
}

fn uv_mapping(p: &ParamSet) -> Result<UvMapping> {
    let mapping = p.get_string("mapping", "uv")?;
    if mapping != "uv" {
        let loc = p.get("mapping").map(|q| q.loc.clone()).unwrap_or_else(|| Loc::builtin(Arc::from(PathBuf::new())));
        return err(&loc, format!("texture mapping '{mapping}' is not supported (only \"uv\")"));
    }
    Ok(UvMapping {
        su: p.get_float("uscale", 1.0)? as f32,
        sv: p.get_float("vscale", 1.0)? as f32,
        du: p.get_float("udelta", 0.0)? as f32,
        dv: p.get_float("vdelta", 0.0)? as f32,
    })
}

fn load_image(p: &ParamSet, loc: &Loc) -> Result<Arc<RgbImage>> {
    let Some(path) = p.get_filename("filename")? else { return err(loc, "imagemap needs a 'string filename'") };
    let (w, h, pixels) = film::read_rgb(&path)
        .map_err(|e| SceneError::at(loc.clone(), format!("cannot read image {}: {e}", path.display())))?;
    Ok(Arc::new(RgbImage { width: w as usize, height: h as usize, pixels }))
}

impl Textures {
    /// Reads every `Texture` directive in order, so a texture can use those defined before it.
    pub(super) fn build(desc: &SceneDescription) -> Result<Self> {
        let mut t = Textures { float: HashMap::new(), spectrum: HashMap::new() };
        for te in &desc.textures {
            let e = &te.entity;
            let p = &e.params;
            match te.value_type {
                TextureValueType::Float => {
                    let tex = match e.name.as_str() {
                        "constant" => FloatTexture::Constant(p.get_float("value", 1.0)? as f32),
                        "checkerboard" => {
                            check_2d(p, &e.loc)?;
                            FloatTexture::Checkerboard {
                                map: uv_mapping(p)?,
                                tex1: Box::new(t.float_param(p, "tex1", 1.0)?),
                                tex2: Box::new(t.float_param(p, "tex2", 0.0)?),
                            }
                        }
                        "imagemap" => FloatTexture::Image {
                            map: uv_mapping(p)?,
                            image: load_image(p, &e.loc)?,
                            scale: p.get_float("scale", 1.0)? as f32,
                            invert: p.get_bool("invert", false)?,
                        },
                        other => {
                            return err(
                                &e.loc,
                                unsupported("float texture", other, &["constant", "checkerboard", "imagemap"]),
                            )
                        }
                    };
                    t.float.insert(te.texture_name.clone(), tex);
                }
                TextureValueType::Spectrum => {
                    let pair = match e.name.as_str() {
                        "constant" => (
                            SpectrumTexture::Constant(spectrum_or(p, "value", SpectrumKind::Albedo, 1.0)?),
                            SpectrumTexture::Constant(spectrum_or(p, "value", SpectrumKind::Unbounded, 1.0)?),
                        ),
                        "checkerboard" => {
                            check_2d(p, &e.loc)?;
                            let map = uv_mapping(p)?;
                            let (a1, u1) = t.spectrum_pair(p, "tex1", 1.0)?;
                            let (a2, u2) = t.spectrum_pair(p, "tex2", 0.0)?;
                            (
                                SpectrumTexture::Checkerboard { map, tex1: Box::new(a1), tex2: Box::new(a2) },
                                SpectrumTexture::Checkerboard { map, tex1: Box::new(u1), tex2: Box::new(u2) },
                            )
                        }
                        "imagemap" => {
                            let map = uv_mapping(p)?;
                            let image = load_image(p, &e.loc)?;
                            let scale = p.get_float("scale", 1.0)? as f32;
                            let invert = p.get_bool("invert", false)?;
                            (
                                SpectrumTexture::Image {
                                    map,
                                    image: image.clone(),
                                    scale,
                                    invert,
                                    kind: RgbKind::Albedo,
                                },
                                SpectrumTexture::Image { map, image, scale, invert, kind: RgbKind::Unbounded },
                            )
                        }
                        other => {
                            return err(
                                &e.loc,
                                unsupported("spectrum texture", other, &["constant", "checkerboard", "imagemap"]),
                            )
                        }
                    };
                    t.spectrum.insert(te.texture_name.clone(), pair);
                }
            }
        }
        Ok(t)
    }

    /// A float parameter that may name a float texture.
    pub(super) fn float_param(&self, p: &ParamSet, name: &str, default: f64) -> Result<FloatTexture> {
        match p.get_float_texture(name, default)? {
            FloatParam::Value(v) => Ok(FloatTexture::Constant(v as f32)),
            FloatParam::Texture(t) => self.float.get(&t).cloned().ok_or_else(|| {
                SceneError::at(p.get(name).map(|q| q.loc.clone()).unwrap(), format!("no float texture named '{t}'"))
            }),
        }
    }

    fn spectrum_pair(&self, p: &ParamSet, name: &str, default: f64) -> Result<(SpectrumTexture, SpectrumTexture)> {
        match p.get_spectrum_texture(name, SpectrumKind::Unbounded)? {
            None => Ok((
                SpectrumTexture::Constant(Spectrum::Constant(default)),
                SpectrumTexture::Constant(Spectrum::Constant(default)),
            )),
            Some(SpectrumParam::Value(v)) => Ok((SpectrumTexture::Constant(v.clone()), SpectrumTexture::Constant(v))),
            Some(SpectrumParam::Texture(t)) => self.spectrum.get(&t).cloned().ok_or_else(|| {
                SceneError::at(p.get(name).map(|q| q.loc.clone()).unwrap(), format!("no spectrum texture named '{t}'"))
            }),
        }
    }

    /// A spectrum parameter that may be a texture; `kind` chooses the albedo or unbounded uplifting.
    pub(super) fn spectrum_param(
        &self,
        p: &ParamSet,
        name: &str,
        kind: SpectrumKind,
        default: f64,
    ) -> Result<SpectrumTexture> {
        match p.get_spectrum_texture(name, kind)? {
            None => Ok(SpectrumTexture::Constant(Spectrum::Constant(default))),
            Some(SpectrumParam::Value(v)) => Ok(SpectrumTexture::Constant(v)),
            Some(SpectrumParam::Texture(t)) => {
                let pair = self.spectrum.get(&t).ok_or_else(|| {
                    SceneError::at(
                        p.get(name).map(|q| q.loc.clone()).unwrap(),
                        format!("no spectrum texture named '{t}'"),
                    )
                })?;
                Ok(if kind == SpectrumKind::Albedo { pair.0.clone() } else { pair.1.clone() })
            }
        }
    }
}

fn check_2d(p: &ParamSet, loc: &Loc) -> Result<()> {
    let dim = p.get_int("dimension", 2)?;
    if dim != 2 {
        return err(loc, format!("checkerboard dimension {dim} is not supported (only 2)"));
    }
    Ok(())
}

fn spectrum_or(p: &ParamSet, name: &str, kind: SpectrumKind, default: f64) -> Result<Spectrum> {
    Ok(p.get_spectrum(name, kind)?.unwrap_or(Spectrum::Constant(default)))
}

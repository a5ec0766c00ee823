//! Textures: pbrt-v4's `Texture "name" "float"|"spectrum" "class"` directives — `constant`, `scale`, `mix`,
//! `directionmix`, `bilerp`, `checkerboard` (2-D and 3-D), `dots`, `fbm`, `wrinkled`, `windy`, `marble` and
//! `imagemap` — with the 2-D mappings (`uv`, `spherical`, `cylindrical`, `planar`) and the texture's own transform,
//! and the lookups materials make when a parameter names a texture instead of giving a value. Images are read once
//! per file and encoding.

use std::cell::{Cell, RefCell};
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use film::ColorEncoding;
use geometry::Transform;
use glam::{Affine3A, DVec3, Vec3};
use scene::{FloatParam, Loc, ParamSet, SceneDescription, SceneError, SpectrumKind, SpectrumParam};
use scene::{TextureEntity, TextureValueType};
use spectral::Spectrum;

use super::{err, file_err, unsupported, Result};
use crate::texture::{
    CheckerMapping, FloatTexture, ImageFilter, ImageTexture, MipMap, PointMapping, RgbImage, RgbKind, SpectrumTexture,
    TextureMapping2D, UvMapping, WrapMode,
};

/// Float texture classes Prismatic reads (pbrt-v4's, `ptex` aside).
const FLOAT_CLASSES: &[&str] = &[
    "constant",
    "scale",
    "mix",
    "directionmix",
    "bilerp",
    "checkerboard",
    "dots",
    "fbm",
    "wrinkled",
    "windy",
    "imagemap",
];
/// Spectrum texture classes Prismatic reads (pbrt-v4's, `ptex` aside).
const SPECTRUM_CLASSES: &[&str] =
    &["constant", "scale", "mix", "directionmix", "bilerp", "checkerboard", "dots", "marble", "imagemap"];

/// The scene's named textures. A spectrum texture is kept twice, uplifted as an albedo and as an unbounded
/// spectrum, because which one a parameter needs is only known where it is used.
pub(super) struct Textures {
    float: HashMap<String, FloatTexture>,
    spectrum: HashMap<String, (SpectrumTexture, SpectrumTexture)>, // (albedo, unbounded) variants
    /// Images read so far, by file and encoding (textures and normal maps share them).
    images: RefCell<HashMap<(PathBuf, String), Arc<RgbImage>>>,
    /// MIP maps built so far, by image (its address in `images`) and wrap mode.
    mipmaps: RefCell<HashMap<(usize, WrapMode), Arc<MipMap>>>,
    /// The named float and spectrum textures that contain an image map (directly or through textures they use).
    float_with_image: HashSet<String>,
    spectrum_with_image: HashSet<String>,
    /// Set whenever a texture containing an image map is built or handed out (see [`Textures::take_image_use`]).
    image_used: Cell<bool>,
}

/// A float parameter that must be finite.
fn finite(p: &ParamSet, loc: &Loc, name: &str, default: f64) -> Result<f32> {
    let v = p.get_float(name, default)?;
    if !v.is_finite() || v.abs() > f32::MAX as f64 {
        return err(&p.loc_of(name, loc), format!("'{name}' must be a finite number, got {v}"));
    }
    Ok(v as f32)
}

/// A `vector3` parameter that must be finite.
fn finite_vector(p: &ParamSet, loc: &Loc, name: &str, default: DVec3) -> Result<Vec3> {
    let v = p.get_vector3(name, default)?;
    if !v.is_finite() || v.abs().max_element() > f32::MAX as f64 {
        return err(&p.loc_of(name, loc), format!("'{name}' must be finite, got {v}"));
    }
    Ok(v.as_vec3())
}

/// The octave count of a noise texture (pbrt-v4's default 8); more than 32 octaves are finer than `f32` resolves.
fn octaves(p: &ParamSet, loc: &Loc) -> Result<u32> {
    let n = p.get_int("octaves", 8)?;
    if !(0..=32).contains(&n) {
        return err(&p.loc_of("octaves", loc), format!("'octaves' must be between 0 and 32, got {n}"));
    }
    Ok(n as u32)
}

/// Render space to the texture's space (the inverse of the texture's CTM), in single precision for lookups.
fn texture_from_render(render_from_texture: &Transform) -> Affine3A {
    Affine3A::from_mat4(render_from_texture.inverse().matrix().as_mat4())
}

/// pbrt-v4's `TextureMapping2D::Create`: `"string mapping"` with its parameters.
fn mapping_2d(p: &ParamSet, loc: &Loc, render_from_texture: &Transform) -> Result<TextureMapping2D> {
    let mapping = p.get_string("mapping", "uv")?;
    Ok(match mapping.as_str() {
        "uv" => TextureMapping2D::Uv(UvMapping {
            su: finite(p, loc, "uscale", 1.0)?,
            sv: finite(p, loc, "vscale", 1.0)?,
            du: finite(p, loc, "udelta", 0.0)?,
            dv: finite(p, loc, "vdelta", 0.0)?,
        }),
        "spherical" => TextureMapping2D::Spherical(texture_from_render(render_from_texture)),
        "cylindrical" => TextureMapping2D::Cylindrical(texture_from_render(render_from_texture)),
        "planar" => TextureMapping2D::Planar {
            texture_from_render: texture_from_render(render_from_texture),
            vs: finite_vector(p, loc, "v1", DVec3::X)?,
            vt: finite_vector(p, loc, "v2", DVec3::Y)?,
            ds: finite(p, loc, "udelta", 0.0)?,
            dt: finite(p, loc, "vdelta", 0.0)?,
        },
        other => {
            return err(
                &p.loc_of("mapping", loc),
                unsupported("texture mapping", other, &["uv", "spherical", "cylindrical", "planar"]),
            )
        }
    })
}

fn mapping_3d(render_from_texture: &Transform) -> PointMapping {
    PointMapping { texture_from_render: texture_from_render(render_from_texture) }
}

/// A checkerboard's `"integer dimension"` (2 or 3) and the mapping that goes with it.
fn checker_mapping(p: &ParamSet, loc: &Loc, render_from_texture: &Transform) -> Result<CheckerMapping> {
    match p.get_int("dimension", 2)? {
        2 => Ok(CheckerMapping::Planar(mapping_2d(p, loc, render_from_texture)?)),
        3 => Ok(CheckerMapping::Solid(mapping_3d(render_from_texture))),
        d => err(&p.loc_of("dimension", loc), format!("checkerboard 'dimension' must be 2 or 3, got {d}")),
    }
}

/// `directionmix`'s `"vector3 dir"` (default +y) in render space, normalised.
fn mix_direction(p: &ParamSet, loc: &Loc, render_from_texture: &Transform) -> Result<Vec3> {
    let d = finite_vector(p, loc, "dir", DVec3::Y)?;
    match render_from_texture.vector(d.as_dvec3()).as_vec3().try_normalize() {
        Some(d) => Ok(d),
        None => err(&p.loc_of("dir", loc), "'dir' must be a non-zero vector"),
    }
}

/// pbrt-v4's `ColorEncoding::Get`: `"linear"`, `"sRGB"` or `"gamma <γ>"`.
fn parse_encoding(s: &str) -> Option<ColorEncoding> {
    let lower = s.trim().to_ascii_lowercase();
    match lower.as_str() {
        "linear" => Some(ColorEncoding::Linear),
        "srgb" => Some(ColorEncoding::Srgb),
        _ => {
            let g: f32 = lower.strip_prefix("gamma")?.trim().parse().ok()?;
            (g.is_finite() && g > 0.0).then_some(ColorEncoding::Gamma(g))
        }
    }
}

/// The parameters of an `imagemap` (pbrt-v4's `ImageTextureBase`), its image read with its encoding.
fn image_texture(t: &Textures, e: &TextureEntity) -> Result<ImageTexture> {
    let (p, loc) = (&e.entity.params, &e.entity.loc);
    let map = mapping_2d(p, loc, &e.render_from_texture)?;
    let filter = match p.get_string("filter", "bilinear")?.as_str() {
        "point" => ImageFilter::Point,
        "bilinear" => ImageFilter::Bilinear,
        "trilinear" => ImageFilter::Trilinear,
        "ewa" | "EWA" => ImageFilter::Ewa,
        other => {
            return err(
                &p.loc_of("filter", loc),
                unsupported("image filter", other, &["point", "bilinear", "trilinear", "ewa"]),
            )
        }
    };
    let aniso = finite(p, loc, "maxanisotropy", 8.0)?;
    if aniso <= 0.0 {
        return err(&p.loc_of("maxanisotropy", loc), format!("'maxanisotropy' must be positive, got {aniso}"));
    }
    let wrap = match p.get_string("wrap", "repeat")?.as_str() {
        "repeat" => WrapMode::Repeat,
        "black" => WrapMode::Black,
        "clamp" => WrapMode::Clamp,
        "octahedralsphere" => WrapMode::OctahedralSphere,
        other => {
            return err(
                &p.loc_of("wrap", loc),
                unsupported("wrap mode", other, &["repeat", "black", "clamp", "octahedralsphere"]),
            )
        }
    };
    let scale = finite(p, loc, "scale", 1.0)?;
    let invert = p.get_bool("invert", false)?;
    let Some(path) = p.get_filename("filename")? else {
        return err(loc, format!("imagemap texture '{}' needs a 'string filename'", e.texture_name));
    };
    // pbrt-v4: PNGs are sRGB-encoded unless said otherwise, other files linear.
    let png = path.extension().is_some_and(|x| x.eq_ignore_ascii_case("png"));
    let enc_name = p.get_string("encoding", if png { "sRGB" } else { "linear" })?;
    let Some(encoding) = parse_encoding(&enc_name) else {
        return err(
            &p.loc_of("encoding", loc),
            format!("'encoding' must be \"linear\", \"sRGB\" or \"gamma <value>\", got \"{enc_name}\""),
        );
    };
    let image = t.image(&path, encoding, &enc_name, &p.loc_of("filename", loc))?;
    let mip = Some(t.mipmap(&image, wrap));
    Ok(ImageTexture { map, image, wrap, filter, mip, max_anisotropy: aniso, scale, invert })
}

/// The error for a texture class pbrt-v4 reads with its Ptex library.
fn ptex_error(e: &TextureEntity) -> SceneError {
    SceneError::at(
        e.entity.loc.clone(),
        format!(
            "texture '{}': ptex textures are not supported (there is no Ptex reader for Rust); convert it to an \
             imagemap",
            e.texture_name
        ),
    )
}

impl Textures {
    /// Reads every `Texture` directive in order, so a texture can use those defined before it.
    pub(super) fn build(desc: &SceneDescription) -> Result<Self> {
        let mut t = Textures {
            float: HashMap::new(),
            spectrum: HashMap::new(),
            images: RefCell::default(),
            mipmaps: RefCell::default(),
            float_with_image: HashSet::new(),
            spectrum_with_image: HashSet::new(),
            image_used: Cell::new(false),
        };
        for te in &desc.textures {
            t.take_image_use();
            match te.value_type {
                TextureValueType::Float => {
                    let tex = t.float_texture(te)?;
                    t.float.insert(te.texture_name.clone(), tex);
                    if t.take_image_use() {
                        t.float_with_image.insert(te.texture_name.clone());
                    }
                }
                TextureValueType::Spectrum => {
                    let pair = (
                        t.spectrum_texture(te, SpectrumKind::Albedo)?,
                        t.spectrum_texture(te, SpectrumKind::Unbounded)?,
                    );
                    t.spectrum.insert(te.texture_name.clone(), pair);
                    if t.take_image_use() {
                        t.spectrum_with_image.insert(te.texture_name.clone());
                    }
                }
            }
        }
        Ok(t)
    }

    /// Whether a texture containing an image map was built or handed out (by [`Textures::float_param`],
    /// [`Textures::spectrum_param`]) since the last call: what a material reads through footprints.
    pub(super) fn take_image_use(&self) -> bool {
        self.image_used.replace(false)
    }

    /// The image at `path` read with `encoding` (named `enc_name`), from the cache if it was read before.
    pub(super) fn image(
        &self,
        path: &Path,
        encoding: ColorEncoding,
        enc_name: &str,
        loc: &Loc,
    ) -> Result<Arc<RgbImage>> {
        let key = (path.to_path_buf(), enc_name.to_ascii_lowercase());
        if let Some(img) = self.images.borrow().get(&key) {
            return Ok(img.clone());
        }
        let (w, h, pixels) = film::read_rgb_encoded(path, encoding)
            .map_err(|e| file_err(loc, path, format!("cannot read image {}: {e}", path.display())))?;
        if w == 0 || h == 0 {
            return Err(file_err(loc, path, format!("image {} is empty", path.display())));
        }
        let img = Arc::new(RgbImage { width: w as usize, height: h as usize, pixels });
        self.images.borrow_mut().insert(key, img.clone());
        Ok(img)
    }

    /// The MIP map of `image` (one of `images`) under `wrap`, built once.
    fn mipmap(&self, image: &Arc<RgbImage>, wrap: WrapMode) -> Arc<MipMap> {
        self.image_used.set(true);
        let key = (Arc::as_ptr(image) as usize, wrap);
        self.mipmaps.borrow_mut().entry(key).or_insert_with(|| Arc::new(MipMap::new(image, wrap))).clone()
    }

    fn float_texture(&self, te: &TextureEntity) -> Result<FloatTexture> {
        let (e, rft) = (&te.entity, &te.render_from_texture);
        let (p, loc) = (&e.params, &e.loc);
        let b = |t: FloatTexture| Box::new(t);
        Ok(match e.name.as_str() {
            "constant" => FloatTexture::Constant(finite(p, loc, "value", 1.0)?),
            "scale" => FloatTexture::Scale {
                tex: b(self.float_param(p, "tex", 1.0)?),
                scale: b(self.float_param(p, "scale", 1.0)?),
            },
            "mix" => FloatTexture::Mix {
                tex1: b(self.float_param(p, "tex1", 0.0)?),
                tex2: b(self.float_param(p, "tex2", 1.0)?),
                amount: b(self.float_param(p, "amount", 0.5)?),
            },
            "directionmix" => FloatTexture::DirectionMix {
                tex1: b(self.float_param(p, "tex1", 0.0)?),
                tex2: b(self.float_param(p, "tex2", 1.0)?),
                dir: mix_direction(p, loc, rft)?,
            },
            "bilerp" => FloatTexture::Bilerp {
                map: Box::new(mapping_2d(p, loc, rft)?),
                v: [
                    finite(p, loc, "v00", 0.0)?,
                    finite(p, loc, "v01", 1.0)?,
                    finite(p, loc, "v10", 0.0)?,
                    finite(p, loc, "v11", 1.0)?,
                ],
            },
            "checkerboard" => FloatTexture::Checkerboard {
                map: Box::new(checker_mapping(p, loc, rft)?),
                tex1: b(self.float_param(p, "tex1", 1.0)?),
                tex2: b(self.float_param(p, "tex2", 0.0)?),
            },
            // pbrt-v4 hands `inside` and `outside` to its dots texture in swapped order, so its dots show
            // `outside` and the rest `inside`; Prismatic renders pbrt-v4 scenes as pbrt-v4 does.
            "dots" => FloatTexture::Dots {
                map: Box::new(mapping_2d(p, loc, rft)?),
                background: b(self.float_param(p, "inside", 1.0)?),
                dot: b(self.float_param(p, "outside", 0.0)?),
            },
            "fbm" => FloatTexture::Fbm {
                map: Box::new(mapping_3d(rft)),
                octaves: octaves(p, loc)?,
                omega: finite(p, loc, "roughness", 0.5)?,
            },
            "wrinkled" => FloatTexture::Wrinkled {
                map: Box::new(mapping_3d(rft)),
                octaves: octaves(p, loc)?,
                omega: finite(p, loc, "roughness", 0.5)?,
            },
            "windy" => FloatTexture::Windy { map: Box::new(mapping_3d(rft)) },
            "imagemap" => FloatTexture::Image(Box::new(image_texture(self, te)?)),
            "ptex" => return Err(ptex_error(te).into()),
            other => return err(loc, unsupported("float texture", other, FLOAT_CLASSES)),
        })
    }

    fn spectrum_texture(&self, te: &TextureEntity, kind: SpectrumKind) -> Result<SpectrumTexture> {
        let (e, rft) = (&te.entity, &te.render_from_texture);
        let (p, loc) = (&e.params, &e.loc);
        let b = |t: SpectrumTexture| Box::new(t);
        let f = |t: FloatTexture| Box::new(t);
        Ok(match e.name.as_str() {
            "constant" => SpectrumTexture::Constant(spectrum_or(p, "value", kind, 1.0)?),
            "scale" => SpectrumTexture::Scale {
                tex: b(self.spectrum_param(p, "tex", kind, 1.0)?),
                scale: f(self.float_param(p, "scale", 1.0)?),
            },
            "mix" => SpectrumTexture::Mix {
                tex1: b(self.spectrum_param(p, "tex1", kind, 0.0)?),
                tex2: b(self.spectrum_param(p, "tex2", kind, 1.0)?),
                amount: f(self.float_param(p, "amount", 0.5)?),
            },
            "directionmix" => SpectrumTexture::DirectionMix {
                tex1: b(self.spectrum_param(p, "tex1", kind, 0.0)?),
                tex2: b(self.spectrum_param(p, "tex2", kind, 1.0)?),
                dir: mix_direction(p, loc, rft)?,
            },
            "bilerp" => SpectrumTexture::Bilerp {
                map: Box::new(mapping_2d(p, loc, rft)?),
                v: Box::new([
                    spectrum_or(p, "v00", kind, 0.0)?,
                    spectrum_or(p, "v01", kind, 1.0)?,
                    spectrum_or(p, "v10", kind, 0.0)?,
                    spectrum_or(p, "v11", kind, 1.0)?,
                ]),
            },
            "checkerboard" => SpectrumTexture::Checkerboard {
                map: Box::new(checker_mapping(p, loc, rft)?),
                tex1: b(self.spectrum_param(p, "tex1", kind, 1.0)?),
                tex2: b(self.spectrum_param(p, "tex2", kind, 0.0)?),
            },
            // Swapped as in pbrt-v4 (see the float dots).
            "dots" => SpectrumTexture::Dots {
                map: Box::new(mapping_2d(p, loc, rft)?),
                background: b(self.spectrum_param(p, "inside", kind, 1.0)?),
                dot: b(self.spectrum_param(p, "outside", kind, 0.0)?),
            },
            "marble" => SpectrumTexture::Marble {
                map: Box::new(mapping_3d(rft)),
                octaves: octaves(p, loc)?,
                omega: finite(p, loc, "roughness", 0.5)?,
                scale: finite(p, loc, "scale", 1.0)?,
                variation: finite(p, loc, "variation", 0.2)?,
            },
            "imagemap" => SpectrumTexture::Image {
                tex: Box::new(image_texture(self, te)?),
                kind: if kind == SpectrumKind::Albedo { RgbKind::Albedo } else { RgbKind::Unbounded },
            },
            "ptex" => return Err(ptex_error(te).into()),
            other => return err(loc, unsupported("spectrum texture", other, SPECTRUM_CLASSES)),
        })
    }

    /// A float parameter that may name a float texture.
    pub(super) fn float_param(&self, p: &ParamSet, name: &str, default: f64) -> Result<FloatTexture> {
        match p.get_float_texture(name, default)? {
            FloatParam::Value(v) => {
                if !v.is_finite() {
                    let at =
                        p.get(name).map(|q| q.loc.clone()).unwrap_or_else(|| Loc::builtin(Arc::from(PathBuf::new())));
                    return err(&at, format!("'{name}' must be a finite number, got {v}"));
                }
                Ok(FloatTexture::Constant(v as f32))
            }
            FloatParam::Texture(t) => {
                if self.float_with_image.contains(&t) {
                    self.image_used.set(true);
                }
                self.float.get(&t).cloned().ok_or_else(|| {
                    SceneError::at(p.get(name).map(|q| q.loc.clone()).unwrap(), format!("no float texture named '{t}'"))
                        .into()
                })
            }
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
                if self.spectrum_with_image.contains(&t) {
                    self.image_used.set(true);
                }
                Ok(if kind == SpectrumKind::Albedo { pair.0.clone() } else { pair.1.clone() })
            }
        }
    }
}

fn spectrum_or(p: &ParamSet, name: &str, kind: SpectrumKind, default: f64) -> Result<Spectrum> {
    Ok(p.get_spectrum(name, kind)?.unwrap_or(Spectrum::Constant(default)))
}

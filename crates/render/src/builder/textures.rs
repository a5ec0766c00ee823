//! Textures: pbrt-v4's `Texture "name" "float"|"spectrum" "class"` directives — `constant`, `scale`, `mix`,
//! `directionmix`, `bilerp`, `checkerboard` (2-D and 3-D), `dots`, `fbm`, `wrinkled`, `windy`, `marble` and
//! `imagemap` — with the 2-D mappings (`uv`, `spherical`, `cylindrical`, `planar`) and the texture's own transform,
//! into the scene's [`Textures`] (in `context.rs`, with the lookups materials make when a parameter names a texture
//! instead of giving a value, and the images, read once per file and encoding).

use std::collections::HashMap;

use film::{ChannelSelect, ColorEncoding};
use geometry::Transform;
use glam::{Affine3A, DVec3, Vec3};
use scene::{Loc, ParamSet, SceneDescription, SceneError, SpectrumKind};
use scene::{TextureEntity, TextureValueType};
use spectral::Spectrum;

use super::context::{err, unsupported, ImageSource, Result, Textures};
use crate::texture::{
    AxisWrap, CheckerMapping, FloatTexture, ImageFilter, ImageTexture, PointMapping, RgbKind, SpectrumTexture,
    TextureMapping2D, UvMapping, WrapMode,
};

/// Float texture classes Prismatic reads (pbrt-v4's, `ptex` aside, and its own `threshold`).
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
    "threshold",
];
/// Spectrum texture classes Prismatic reads (pbrt-v4's, `ptex` aside).
const SPECTRUM_CLASSES: &[&str] = &[
    "constant",
    "scale",
    "mix",
    "directionmix",
    "bilerp",
    "checkerboard",
    "dots",
    "marble",
    "imagemap",
    "vertexcolor",
];

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
    if let Some(m) = p.get_floats("uvtransform") {
        let at = p.loc_of("uvtransform", loc);
        if mapping != "uv" {
            return err(&at, "'uvtransform' belongs to the \"uv\" mapping");
        }
        if ["uscale", "vscale", "udelta", "vdelta"].iter().any(|n| p.contains(n)) {
            return err(&at, "give 'uvtransform' or 'uscale'/'vscale'/'udelta'/'vdelta', not both");
        }
        let m: Vec<f32> = m.iter().map(|&v| v as f32).collect();
        if m.len() != 6 || !m.iter().all(|v| v.is_finite()) {
            return err(&at, "'uvtransform' must be six finite numbers: s = m0·u + m1·v + m2, t = m3·u + m4·v + m5");
        }
        return Ok(TextureMapping2D::UvMatrix([m[0], m[1], m[2], m[3], m[4], m[5]]));
    }
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
    let wrap = wrap_mode(p, loc)?;
    let scale = finite(p, loc, "scale", 1.0)?;
    let invert = p.get_bool("invert", false)?;
    let tint = match p.get_rgb("tint")? {
        None => [1.0; 3],
        Some(c) if c.iter().all(|c| c.is_finite() && c.abs() <= f32::MAX as f64) => c.map(|c| c as f32),
        Some(_) => return err(&p.loc_of("tint", loc), "'tint' must be three finite numbers"),
    };
    let channel = match p.get_string("channel", "rgb")?.as_str() {
        "rgb" => ChannelSelect::Rgb,
        "r" => ChannelSelect::One(0),
        "g" => ChannelSelect::One(1),
        "b" => ChannelSelect::One(2),
        "a" => ChannelSelect::One(3),
        other => {
            return err(&p.loc_of("channel", loc), unsupported("image channel", other, &["rgb", "r", "g", "b", "a"]))
        }
    };
    let embedded = if p.contains("image") { Some(p.get_int("image", 0)?) } else { None };
    let (source, source_loc, png) = match (p.get_filename("filename")?, embedded) {
        (Some(_), Some(_)) => return err(&p.loc_of("image", loc), "give 'filename' or 'image', not both"),
        (Some(path), None) => {
            let png = path.extension().is_some_and(|x| x.eq_ignore_ascii_case("png"));
            (ImageSource::File(path), p.loc_of("filename", loc), png)
        }
        (None, Some(i)) if i >= 0 => (ImageSource::Embedded(i as usize), p.loc_of("image", loc), true),
        (None, Some(i)) => return err(&p.loc_of("image", loc), format!("'image' must be an index ≥ 0, got {i}")),
        (None, None) => {
            return err(loc, format!("imagemap texture '{}' needs a 'string filename'", e.texture_name));
        }
    };
    // pbrt-v4: PNGs are sRGB-encoded unless said otherwise, other files linear. Embedded images are 8- or 16-bit
    // PNGs and JPEGs, sRGB by default like PNG files.
    let enc_name = p.get_string("encoding", if png { "sRGB" } else { "linear" })?;
    let Some(encoding) = parse_encoding(&enc_name) else {
        return err(
            &p.loc_of("encoding", loc),
            format!("'encoding' must be \"linear\", \"sRGB\" or \"gamma <value>\", got \"{enc_name}\""),
        );
    };
    let image = t.image(&source, encoding, &enc_name, channel, &source_loc)?;
    let mip = Some(t.mipmap(&image, wrap));
    Ok(ImageTexture { map, image, wrap, filter, mip, max_anisotropy: aniso, scale, tint, invert })
}

/// An image map's `"string wrap"`: one of pbrt-v4's modes for both axes, or (a Prismatic extension, for glTF's
/// samplers) two of `repeat`, `clamp` and `mirror`, along s then t.
fn wrap_mode(p: &ParamSet, loc: &Loc) -> Result<WrapMode> {
    let at = || p.loc_of("wrap", loc);
    let values = p.get_strings("wrap").unwrap_or_default();
    let axis = |v: &str| -> Result<AxisWrap> {
        Ok(match v {
            "repeat" => AxisWrap::Repeat,
            "clamp" => AxisWrap::Clamp,
            "mirror" => AxisWrap::Mirror,
            other => return err(&at(), unsupported("wrap mode of one axis", other, &["repeat", "clamp", "mirror"])),
        })
    };
    Ok(match values {
        [] => WrapMode::Repeat,
        [one] => match one.as_str() {
            "repeat" => WrapMode::Repeat,
            "black" => WrapMode::Black,
            "clamp" => WrapMode::Clamp,
            "octahedralsphere" => WrapMode::OctahedralSphere,
            "mirror" => WrapMode::Axes(AxisWrap::Mirror, AxisWrap::Mirror),
            other => {
                return err(
                    &at(),
                    unsupported("wrap mode", other, &["repeat", "black", "clamp", "octahedralsphere", "mirror"]),
                )
            }
        },
        [s, t] => WrapMode::Axes(axis(s)?, axis(t)?),
        more => return err(&at(), format!("'wrap' takes one mode, or one per axis (two), not {}", more.len())),
    })
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

/// Reads every `Texture` directive in order, so a texture can use those defined before it.
pub(super) fn build(desc: &SceneDescription) -> Result<Textures> {
    let mut t = Textures::new(desc.images.clone());
    // The embedded images each texture is the last to read: their decoded samples are let go after it (an image
    // read as several channels is decoded once, and held only while textures still to come read it).
    let mut last_reads: Vec<Vec<usize>> = vec![Vec::new(); desc.textures.len()];
    let mut last_reader: HashMap<usize, usize> = HashMap::new();
    for (n, te) in desc.textures.iter().enumerate() {
        // Read without marking it used: only an image map reads it (and says what is wrong with it).
        if let Some(&i @ 0..) = te.entity.params.get("image").and_then(|p| p.ints.first()) {
            last_reader.insert(i as usize, n);
        }
    }
    for (image, n) in last_reader {
        last_reads[n].push(image);
    }
    for (te, last_reads) in desc.textures.iter().zip(&last_reads) {
        t.take_image_use();
        match te.value_type {
            TextureValueType::Float => {
                let tex = float_texture(&t, te)?;
                let with_image = t.take_image_use();
                t.define_float(&te.texture_name, tex, with_image);
            }
            TextureValueType::Spectrum => {
                let pair = (
                    spectrum_texture(&t, te, SpectrumKind::Albedo)?,
                    spectrum_texture(&t, te, SpectrumKind::Unbounded)?,
                );
                let with_image = t.take_image_use();
                t.define_spectrum(&te.texture_name, pair, with_image);
            }
        }
        for &image in last_reads {
            t.forget_decoded(image);
        }
    }
    Ok(t)
}

fn float_texture(t: &Textures, te: &TextureEntity) -> Result<FloatTexture> {
    let (e, rft) = (&te.entity, &te.render_from_texture);
    let (p, loc) = (&e.params, &e.loc);
    let b = |t: FloatTexture| Box::new(t);
    Ok(match e.name.as_str() {
        "constant" => FloatTexture::Constant(finite(p, loc, "value", 1.0)?),
        "scale" => {
            FloatTexture::Scale { tex: b(t.float_param(p, "tex", 1.0)?), scale: b(t.float_param(p, "scale", 1.0)?) }
        }
        "mix" => FloatTexture::Mix {
            tex1: b(t.float_param(p, "tex1", 0.0)?),
            tex2: b(t.float_param(p, "tex2", 1.0)?),
            amount: b(t.float_param(p, "amount", 0.5)?),
        },
        "directionmix" => FloatTexture::DirectionMix {
            tex1: b(t.float_param(p, "tex1", 0.0)?),
            tex2: b(t.float_param(p, "tex2", 1.0)?),
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
            tex1: b(t.float_param(p, "tex1", 1.0)?),
            tex2: b(t.float_param(p, "tex2", 0.0)?),
        },
        // pbrt-v4 hands `inside` and `outside` to its dots texture in swapped order, so its dots show
        // `outside` and the rest `inside`; Prismatic renders pbrt-v4 scenes as pbrt-v4 does.
        "dots" => FloatTexture::Dots {
            map: Box::new(mapping_2d(p, loc, rft)?),
            background: b(t.float_param(p, "inside", 1.0)?),
            dot: b(t.float_param(p, "outside", 0.0)?),
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
        "imagemap" => FloatTexture::Image(Box::new(image_texture(t, te)?)),
        "threshold" => {
            FloatTexture::Threshold { tex: b(t.float_param(p, "tex", 1.0)?), cutoff: finite(p, loc, "cutoff", 0.5)? }
        }
        "ptex" => return Err(ptex_error(te).into()),
        other => return err(loc, unsupported("float texture", other, FLOAT_CLASSES)),
    })
}

fn spectrum_texture(t: &Textures, te: &TextureEntity, kind: SpectrumKind) -> Result<SpectrumTexture> {
    let (e, rft) = (&te.entity, &te.render_from_texture);
    let (p, loc) = (&e.params, &e.loc);
    let b = |t: SpectrumTexture| Box::new(t);
    let f = |t: FloatTexture| Box::new(t);
    Ok(match e.name.as_str() {
        "constant" => SpectrumTexture::Constant(spectrum_or(p, "value", kind, 1.0)?),
        "scale" => SpectrumTexture::Scale {
            tex: b(t.spectrum_param(p, "tex", kind, 1.0)?),
            scale: f(t.float_param(p, "scale", 1.0)?),
        },
        "mix" => SpectrumTexture::Mix {
            tex1: b(t.spectrum_param(p, "tex1", kind, 0.0)?),
            tex2: b(t.spectrum_param(p, "tex2", kind, 1.0)?),
            amount: f(t.float_param(p, "amount", 0.5)?),
        },
        "directionmix" => SpectrumTexture::DirectionMix {
            tex1: b(t.spectrum_param(p, "tex1", kind, 0.0)?),
            tex2: b(t.spectrum_param(p, "tex2", kind, 1.0)?),
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
            tex1: b(t.spectrum_param(p, "tex1", kind, 1.0)?),
            tex2: b(t.spectrum_param(p, "tex2", kind, 0.0)?),
        },
        // Swapped as in pbrt-v4 (see the float dots).
        "dots" => SpectrumTexture::Dots {
            map: Box::new(mapping_2d(p, loc, rft)?),
            background: b(t.spectrum_param(p, "inside", kind, 1.0)?),
            dot: b(t.spectrum_param(p, "outside", kind, 0.0)?),
        },
        "marble" => SpectrumTexture::Marble {
            map: Box::new(mapping_3d(rft)),
            octaves: octaves(p, loc)?,
            omega: finite(p, loc, "roughness", 0.5)?,
            scale: finite(p, loc, "scale", 1.0)?,
            variation: finite(p, loc, "variation", 0.2)?,
        },
        "imagemap" => SpectrumTexture::Image {
            tex: Box::new(image_texture(t, te)?),
            kind: if kind == SpectrumKind::Albedo { RgbKind::Albedo } else { RgbKind::Unbounded },
        },
        // Prismatic's `vertexcolor`: the mesh's interpolated vertex colour × `rgb tint` × the RGB of the imagemap
        // `tex` (if given), uplifted once (glTF's COLOR_0 × base colour factor × texture).
        "vertexcolor" => {
            let tint = match p.get_rgb("tint")? {
                Some(rgb) if rgb.iter().all(|v| v.is_finite() && *v >= 0.0 && *v <= f64::from(f32::MAX)) => {
                    rgb.map(|v| v as f32)
                }
                Some(_) => return err(&p.loc_of("tint", loc), "'tint' must be three finite numbers ≥ 0"),
                None => [1.0; 3],
            };
            let image = match p.get_texture("tex") {
                None => None,
                Some(name) => Some(Box::new(t.image_texture(&name).ok_or_else(|| {
                    SceneError::at(
                        p.loc_of("tex", loc),
                        format!("'tex' must name an imagemap spectrum texture; '{name}' is not one"),
                    )
                })?)),
            };
            SpectrumTexture::VertexColor {
                tint,
                image,
                kind: if kind == SpectrumKind::Albedo { RgbKind::Albedo } else { RgbKind::Unbounded },
            }
        }
        "ptex" => return Err(ptex_error(te).into()),
        other => return err(loc, unsupported("spectrum texture", other, SPECTRUM_CLASSES)),
    })
}

fn spectrum_or(p: &ParamSet, name: &str, kind: SpectrumKind, default: f64) -> Result<Spectrum> {
    Ok(p.get_spectrum(name, kind)?.unwrap_or(Spectrum::Constant(default)))
}

//! Lights: pbrt-v4's `LightSource` directive (`point`, `spot`, `distant`, and `infinite`, uniform or from an
//! environment map) and `AreaLightSource "diffuse"` on shapes, with pbrt-v4's photometric normalisation: `scale`,
//! `power` and `illuminance` fix the emitted luminance, so a spectrum's shape sets only the colour.

use geometry::{Shape, Transform};
use glam::DVec3;
use scene::{Entity, Loc, SceneDescription, SceneError, SpectrumKind};
use spectral::rgb_uplift::RgbIlluminantSpectrum;
use spectral::Spectrum;

use std::sync::Arc;

use film::{ChannelSelect, ColorEncoding};
use scene::ParamType;

use super::context::{err, file_err, normalise_emission, unsupported, ImageSource, Result, ShapeAlpha, Textures};
use crate::light::{EmissionImage, EnvironmentMap, Light};
use crate::sampling::Frame;
use crate::texture::{ImageFilter, ImageTexture, TextureMapping2D, WrapMode};

/// Appends one light per `LightSource` directive to `lights` (after the area lights, which the shapes made).
pub(super) fn make_lights(
    desc: &SceneDescription,
    scene_radius: f32,
    lights: &mut Vec<Light>,
    warnings: &mut Vec<String>,
) -> Result<()> {
    for le in &desc.lights {
        lights.push(light(le, scene_radius.max(1e-3), warnings)?);
    }
    Ok(())
}

/// Creates one area light per primitive of `shape` (whose alpha is `alpha`); returns the index of the first. Called
/// by `shapes.rs` for each shape it builds (`mod.rs` hands it over), so that area lights come in shape order.
pub(super) fn area_lights(
    al: &Entity,
    shape: &Shape,
    alpha: &ShapeAlpha,
    textures: &Textures,
    lights: &mut Vec<Light>,
) -> Result<u32> {
    let p = &al.params;
    if al.name != "diffuse" {
        return err(&al.loc, unsupported("area light", &al.name, &["diffuse"]));
    }
    let white = || Spectrum::RgbIlluminant(RgbIlluminantSpectrum::new([1.0, 1.0, 1.0]).expect("white is valid"));
    // An image of the emission: pbrt-v4's `"string filename"` (read bilinearly, clamped at the edges), or (a Prismatic
    // extension, glTF's emissive texture) `"texture L"` naming an `imagemap` spectrum texture. Either replaces `L`:
    // the image's RGB is uplifted as an illuminant, normalised as an RGB `L` is.
    let image = if p.param_type("L") == Some(ParamType::Texture) {
        let name = p.get_texture("L").unwrap_or_default();
        let Some(tex) = textures.image_texture(&name) else {
            return err(
                &p.loc_of("L", &al.loc),
                format!("'L' must name an imagemap spectrum texture; '{name}' is not one"),
            );
        };
        Some(tex)
    } else if let Some(path) = p.get_filename("filename")? {
        let at = p.loc_of("filename", &al.loc);
        if p.contains("L") {
            return err(&at, "give 'L' or 'filename', not both");
        }
        let png = path.extension().is_some_and(|x| x.eq_ignore_ascii_case("png"));
        let encoding = if png { ColorEncoding::Srgb } else { ColorEncoding::Linear };
        let image = textures.image(
            &ImageSource::File(path),
            encoding,
            if png { "srgb" } else { "linear" },
            ChannelSelect::Rgb,
            &at,
        )?;
        Some(ImageTexture {
            map: TextureMapping2D::default(),
            image,
            wrap: WrapMode::Clamp,
            filter: ImageFilter::Bilinear,
            mip: None,
            max_anisotropy: 8.0,
            scale: 1.0,
            tint: [1.0; 3],
            invert: false,
        })
    } else {
        None
    };
    let image = image.map(|tex| Arc::new(EmissionImage::new(tex)));
    let two_sided = p.get_bool("twosided", false)?;
    let mut scale = p.get_float("scale", 1.0)?;
    let power = p.get_float("power", -1.0)?;
    let n = shape.primitive_count();
    if power > 0.0 {
        // pbrt-v4: k_e = π · (2 if two-sided) · area, in luminance units (times an image's mean luminance).
        let area: f64 = (0..n).map(|i| shape.area(i) as f64).sum();
        let image_y = image.as_ref().map_or(1.0, |img| img.mean_luminance as f64);
        let k_e = std::f64::consts::PI * if two_sided { 2.0 } else { 1.0 } * area * image_y;
        if k_e > 0.0 {
            scale *= power / k_e;
        }
    }
    // An RGB illuminant has unit luminance per unit of its RGB's luminance, so an image's illuminant (uplifted at
    // each point) needs only the scale: the light's spectrum is the constant `scale`.
    let l = match image {
        Some(_) => {
            // The same checks of the scale as any emission's (the white illuminant has luminance 1).
            normalise_emission(&al.loc, white(), scale)?;
            Spectrum::Constant(scale)
        }
        None => {
            let l = p.get_spectrum("L", SpectrumKind::Illuminant)?.unwrap_or_else(white);
            normalise_emission(&al.loc, l, scale)?
        }
    };
    let base = lights.len() as u32;
    let (alpha, invisible) = match alpha {
        ShapeAlpha::Opaque => (None, false),
        ShapeAlpha::Invisible => (None, true),
        ShapeAlpha::CutOut(t) => (Some(Arc::new(t.clone())), false),
    };
    for element in 0..n {
        lights.push(Light::DiffuseArea {
            shape: Box::new(shape.clone()),
            element: element as u32,
            l: l.clone(),
            image: image.clone(),
            two_sided,
            alpha: alpha.clone(),
            invisible,
        });
    }
    Ok(base)
}

/// One `LightSource`; `scene_radius` places the lights at infinity.
fn light(le: &scene::LightEntity, scene_radius: f32, warnings: &mut Vec<String>) -> Result<Light> {
    let e = &le.entity;
    let p = &e.params;
    let t = &le.render_from_light;
    let white = || Spectrum::RgbIlluminant(RgbIlluminantSpectrum::new([1.0, 1.0, 1.0]).expect("white is valid"));
    let scale = p.get_float("scale", 1.0)?;
    let power = p.get_float("power", -1.0)?;
    Ok(match e.name.as_str() {
        "point" => {
            let i = p.get_spectrum("I", SpectrumKind::Illuminant)?.unwrap_or_else(white);
            let from = p.get_point3("from", DVec3::ZERO)?;
            let k = if power > 0.0 { power / (4.0 * std::f64::consts::PI) } else { 1.0 };
            Light::Point { p: t.point(from).as_vec3(), i: normalise_emission(&e.loc, i, scale * k)? }
        }
        "spot" => {
            let i = p.get_spectrum("I", SpectrumKind::Illuminant)?.unwrap_or_else(white);
            let from = p.get_point3("from", DVec3::ZERO)?;
            let to = p.get_point3("to", DVec3::new(0.0, 0.0, 1.0))?;
            let cone = p.get_float("coneangle", 30.0)?;
            let delta = p.get_float("conedeltaangle", 5.0)?;
            let (cos_end, cos_start) = (cone.to_radians().cos(), (cone - delta).to_radians().cos());
            let k = if power > 0.0 {
                power / (2.0 * std::f64::consts::PI * (1.0 - 0.5 * (cos_start + cos_end)))
            } else {
                1.0
            };
            let pf = t.point(from).as_vec3();
            let axis = (t.point(to).as_vec3() - pf)
                .try_normalize()
                .ok_or_else(|| SceneError::at(e.loc.clone(), "spot light 'from' equals 'to'"))?;
            Light::Spot {
                p: pf,
                frame: Frame::from_z(axis),
                i: normalise_emission(&e.loc, i, scale * k)?,
                cos_falloff_start: cos_start as f32,
                cos_falloff_end: cos_end as f32,
            }
        }
        "distant" => {
            let l = p.get_spectrum("L", SpectrumKind::Illuminant)?.unwrap_or_else(white);
            let from = p.get_point3("from", DVec3::ZERO)?;
            let to = p.get_point3("to", DVec3::new(0.0, 0.0, 1.0))?;
            let w = t
                .vector(from - to)
                .as_vec3()
                .try_normalize()
                .ok_or_else(|| SceneError::at(e.loc.clone(), "distant light 'from' equals 'to'"))?;
            let e_v = p.get_float("illuminance", -1.0)?;
            let k = if e_v > 0.0 { e_v } else { 1.0 };
            // Prismatic's extension: the light's angular diameter in degrees (the sun's is about 0.53); 0 is pbrt-v4's
            // single direction. The disc keeps the irradiance: its radiance is L / (π sin²θ_max).
            let angle = p.get_float("angle", 0.0)?;
            if !(angle.is_finite() && (0.0..180.0).contains(&angle)) {
                return err(
                    &p.loc_of("angle", &e.loc),
                    format!("'angle' (the light's angular diameter) must be in [0, 180) degrees, got {angle}"),
                );
            }
            let l = normalise_emission(&e.loc, l, scale * k)?;
            if angle == 0.0 {
                Light::Distant { w, l, scene_radius }
            } else {
                let half = (0.5 * angle).to_radians();
                let sin2_max = half.sin().powi(2);
                // 1 − cos θ = 2 sin²(θ/2), without cancellation.
                let one_minus_cos = 2.0 * (0.5 * half).sin().powi(2);
                let l = l.scaled(1.0 / (std::f64::consts::PI * sin2_max));
                Light::DistantDisc {
                    frame: Frame::from_z(w),
                    l,
                    one_minus_cos: one_minus_cos as f32,
                    sin2_max: sin2_max as f32,
                    scene_radius,
                }
            }
        }
        "infinite" => {
            let e_v = p.get_float("illuminance", -1.0)?;
            if let Some(path) = p.get_filename("filename")? {
                let map = environment_map(&path, &e.loc, t)?;
                let mut s = scale;
                if e_v > 0.0 {
                    // Scale so that an upward-facing point receives illuminance E_v (pbrt-v4 computes the same
                    // integral over the upper hemisphere; we use the mean luminance, exact for uniform maps).
                    let k_e = std::f64::consts::PI * map.mean_luminance as f64;
                    if k_e > 0.0 {
                        s *= e_v / k_e;
                    }
                    warnings.push(format!("{}: warning: 'illuminance' of an image light is matched on average", e.loc));
                }
                Light::ImageInfinite { map: Box::new(map), scale: s as f32, scene_radius }
            } else {
                let l = p.get_spectrum("L", SpectrumKind::Illuminant)?.unwrap_or_else(white);
                let k = if e_v > 0.0 { e_v / std::f64::consts::PI } else { 1.0 };
                Light::UniformInfinite { l: normalise_emission(&e.loc, l, scale * k)?, scene_radius }
            }
        }
        other => return err(&e.loc, unsupported("light", other, &["point", "spot", "distant", "infinite"])),
    })
}

/// An environment map (square: equal-area, 2:1: latitude-longitude) with its sampling distribution, oriented by `t`.
fn environment_map(path: &std::path::Path, loc: &Loc, t: &Transform) -> Result<EnvironmentMap> {
    let (w, h, pixels) =
        film::read_rgb(path).map_err(|e| file_err(loc, path, format!("cannot read {}: {e}", path.display())))?;
    let (w, h) = (w as usize, h as usize);
    let equal_area = w == h;
    if !equal_area && w != 2 * h {
        let message = format!("environment map {}×{} is neither square (equal-area) nor 2:1 (lat-long)", w, h);
        return Err(file_err(loc, path, message));
    }
    let x = t.vector(DVec3::X).as_vec3().normalize();
    let y = t.vector(DVec3::Y).as_vec3().normalize();
    let z = t.vector(DVec3::Z).as_vec3().normalize();
    EnvironmentMap::from_rgb(w, h, &pixels, Frame { x, y, z }).map_err(|e| file_err(loc, path, e.to_string()))
}

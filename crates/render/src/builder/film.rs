//! The film: pbrt-v4's `Film "rgb"|"spectral"` directive (resolution, `filename`, spectral buckets,
//! `maxcomponentvalue`, and Prismatic's `colorspace` and `view`), its pixel sensor (`sensor`, `iso`, `whitebalance`, with the camera's shutter interval as
//! the exposure time) and the `PixelFilter` directive.

use std::path::PathBuf;

use film::{CameraResponse, FilmKind, FilmSpec, Filter, GBuffer, GBufferCoordinates, PixelBounds, PixelSensor, View};
use scene::{Entity, SceneDescription, SceneError};
use spectral::sensor::CameraSensor;
use spectral::RgbColorSpace;

use super::context::{err, unsupported, BuildOptions, Result};

/// The film to render into; `options` override the resolution, the output file and the pixel bounds.
pub(super) fn make_film(
    desc: &SceneDescription,
    options: &BuildOptions,
    warnings: &mut Vec<String>,
) -> Result<FilmSpec> {
    let fp = &desc.film.params;
    let floc = &desc.film.loc;
    let kind = match desc.film.name.as_str() {
        "rgb" | "gbuffer" => FilmKind::Rgb,
        "spectral" => FilmKind::Spectral {
            nbuckets: fp.get_count("nbuckets", 16, &desc.film.loc)?,
            lambda_min: fp.get_float("lambdamin", 360.0)?,
            lambda_max: fp.get_float("lambdamax", 830.0)?,
        },
        other => return err(&desc.film.loc, unsupported("film", other, &["rgb", "spectral", "gbuffer"])),
    };
    let (mut w, mut h) = (
        fp.get_count("xresolution", 1280, &desc.film.loc)? as u32,
        fp.get_count("yresolution", 720, &desc.film.loc)? as u32,
    );
    if let Some((rw, rh)) = options.resolution {
        (w, h) = (rw, rh);
    }
    // Read the scene's values even when overridden, so they are not reported as unused.
    let scene_filename = PathBuf::from(fp.get_string("filename", "pbrt.exr")?);
    let filename = options.output.clone().unwrap_or(scene_filename);
    let filter = make_filter(&desc.filter)?;
    let mut film = FilmSpec::new(w, h, filename);
    (film.kind, film.filter) = (kind, filter);
    film.sensor = make_sensor(desc)?;
    film.max_component_value = fp.get_float("maxcomponentvalue", f64::INFINITY)?;
    // Prismatic extensions: the output colour space and the display view (read even when overridden, so they are
    // not reported as unused).
    let space_name = fp.get_string("colorspace", "srgb")?;
    film.color_space = match (&options.color_space, RgbColorSpace::by_name(&space_name)) {
        (Some(cs), _) => cs.clone(),
        (None, Some(cs)) => cs,
        (None, None) => {
            let names = RgbColorSpace::NAMES.map(|n| format!("\"{n}\"")).join(", ");
            return err(&fp.loc_of("colorspace", floc), format!("'colorspace' \"{space_name}\" is not one of {names}"));
        }
    };
    let view_name = fp.get_string("view", View::default().name())?;
    film.view = match (options.view, View::by_name(&view_name)) {
        (Some(v), _) => v,
        (None, Some(v)) => v,
        (None, None) => {
            let names = View::NAMES.map(|n| format!("\"{n}\"")).join(", ");
            return err(&fp.loc_of("view", floc), format!("'view' \"{view_name}\" is not one of {names}"));
        }
    };
    film.pixel_bounds = pixel_bounds(desc, options, (w, h), warnings)?;
    // pbrt-v4 writes half floats by default; Prismatic writes 32-bit floats unless asked (see the scene-format docs).
    film.write_fp16 = fp.get_bool("savefp16", false)?;
    // The sensor diagonal (mm) sizes the film only for pbrt-v4's realistic camera (read again by the camera).
    let diagonal = fp.get_float("diagonal", 35.0)?;
    if !(diagonal.is_finite() && diagonal > 0.0) {
        return err(
            &fp.loc_of("diagonal", floc),
            format!("'diagonal' must be a positive length in mm, got {diagonal}"),
        );
    }
    if desc.film.name == "gbuffer" {
        // pbrt-v4's GBufferFilm writes EXR only.
        if film::ImageFormat::from_path(&film.filename).ok() != Some(film::ImageFormat::Exr) {
            return err(floc, format!("film \"gbuffer\" writes EXR only, not {}", film.filename.display()));
        }
        let system = fp.get_string("coordinatesystem", "camera")?;
        film.aovs = true;
        film.gbuffer = Some(match system.as_str() {
            "camera" => GBuffer { coordinates: GBufferCoordinates::Camera },
            "world" => GBuffer { coordinates: GBufferCoordinates::World },
            other => {
                return err(
                    &fp.loc_of("coordinatesystem", floc),
                    format!("'coordinatesystem' \"{other}\" is not one of \"camera\", \"world\""),
                )
            }
        });
    }
    film.validate().map_err(|e| SceneError::at(desc.film.loc.clone(), e.to_string()))?;
    Ok(film)
}

/// The pixels to render, as pbrt-v4's `FilmBaseParameters` decides them: the film's `"integer pixelbounds"`
/// [x0 x1 y0 y1] (pixels, half-open, clamped to the image with a warning), or its `"float cropwindow"` [x0 x1 y0 y1]
/// (fractions of the image; pixels from ⌈W·x0⌉ to ⌈W·x1⌉, likewise in y), which wins over `pixelbounds`; the command
/// line's `--pixelbounds` and `--cropwindow` override both (a command-line crop window wins over everything).
/// `None` for the whole image.
fn pixel_bounds(
    desc: &SceneDescription,
    options: &BuildOptions,
    (w, h): (u32, u32),
    warnings: &mut Vec<String>,
) -> Result<Option<PixelBounds>> {
    let (fp, floc) = (&desc.film.params, &desc.film.loc);
    let film_pb = fp.get_ints("pixelbounds").map(|v| v.to_vec());
    let film_cw = fp.get_floats("cropwindow").map(|v| v.to_vec());
    let clamp_bounds = |pb: [i64; 4], what: &str, warnings: &mut Vec<String>| {
        let c = |v: i64, max: u32| v.clamp(0, max as i64) as u32;
        let b = PixelBounds { x0: c(pb[0], w), x1: c(pb[1], w), y0: c(pb[2], h), y1: c(pb[3], h) };
        if [b.x0 as i64, b.x1 as i64, b.y0 as i64, b.y1 as i64] != pb {
            warnings.push(format!("{floc}: warning: {what} {pb:?} extend beyond the {w}×{h} image: clamped"));
        }
        b
    };
    let from_crop = |c: [f64; 4]| {
        let (x0, x1) = (c[0].min(c[1]), c[0].max(c[1]));
        let (y0, y1) = (c[2].min(c[3]), c[2].max(c[3]));
        let px = |f: f64, n: u32| (n as f64 * f).ceil() as u32; // pbrt-v4: ⌈resolution · crop⌉
        PixelBounds { x0: px(x0, w), x1: px(x1, w), y0: px(y0, h), y1: px(y1, h) }
    };
    let mut bounds = None;
    if let Some(pb) = options.pixel_bounds {
        bounds = Some(clamp_bounds(pb.map(|v| v as i64), "--pixelbounds", warnings));
        if film_pb.is_some() {
            warnings.push(format!("{floc}: warning: --pixelbounds overrides the film's 'pixelbounds'"));
        }
    } else if let Some(pb) = &film_pb {
        let Ok(pb) = <[i64; 4]>::try_from(pb.as_slice()) else {
            return err(&fp.loc_of("pixelbounds", floc), format!("'pixelbounds' needs 4 values, got {}", pb.len()));
        };
        bounds = Some(clamp_bounds(pb, "'pixelbounds'", warnings));
    }
    if let Some(cw) = options.crop_window {
        bounds = Some(from_crop(cw));
        if film_cw.is_some() || film_pb.is_some() || options.pixel_bounds.is_some() {
            warnings.push(format!(
                "{floc}: warning: --cropwindow overrides the pixel bounds and crop window given elsewhere"
            ));
        }
    } else if let Some(cw) = &film_cw {
        let loc = fp.loc_of("cropwindow", floc);
        let Ok(cw) = <[f64; 4]>::try_from(cw.as_slice()) else {
            return err(&loc, format!("'cropwindow' needs 4 values, got {}", cw.len()));
        };
        if let Some(v) = cw.iter().find(|v| !(0.0..=1.0).contains(*v)) {
            return err(&loc, format!("'cropwindow' values are fractions of the image in [0, 1], got {v}"));
        }
        if options.pixel_bounds.is_some() {
            warnings.push(format!("{floc}: warning: 'cropwindow' is ignored: --pixelbounds was given"));
        } else {
            if film_pb.is_some() {
                warnings
                    .push(format!("{floc}: warning: both 'pixelbounds' and 'cropwindow' given: using the crop window"));
            }
            bounds = Some(from_crop(cw));
        }
    }
    if let Some(b) = bounds {
        if b.width() == 0 || b.height() == 0 {
            let name = if film_cw.is_some() || options.crop_window.is_some() { "cropwindow" } else { "pixelbounds" };
            return err(&fp.loc_of(name, floc), format!("the {name} selects no pixels of the {w}×{h} image: {b:?}"));
        }
    }
    Ok(bounds.filter(|b| *b != PixelBounds::full(w, h)))
}

/// pbrt-v4's pixel sensor from the film's `sensor`, `iso` and `whitebalance` and the camera's shutter interval.
///
/// pbrt-v4 takes the exposure time as the camera's `shutterclose` − `shutteropen` (defaults 1 and 0, so 1 s) and
/// `iso` defaults to 100, making the imaging ratio t · ISO / 100 exactly 1 by default. `whitebalance` (K) defaults
/// to 0, no white balance, for the `cie1931` sensor; a measured camera sensor ("canon_eos_5d_mkiv", …) is always
/// white-balanced, for daylight at 6500 K unless `whitebalance` says otherwise (pbrt-v4 `PixelSensor::Create`).
fn make_sensor(desc: &SceneDescription) -> Result<PixelSensor> {
    let (fp, floc) = (&desc.film.params, &desc.film.loc);
    let name = fp.get_string("sensor", "cie1931")?;
    let camera_sensor = if name == "cie1931" {
        None
    } else {
        let Some(s) = CameraSensor::by_name(&name) else {
            let known: Vec<&str> =
                std::iter::once("cie1931").chain(CameraSensor::names().iter().map(String::as_str)).collect();
            return err(
                &fp.loc_of("sensor", floc),
                format!("unknown 'sensor' \"{name}\"; known sensors: {}", known.join(", ")),
            );
        };
        Some(s)
    };
    let cp = &desc.camera.entity.params;
    let (open, close) = (cp.get_float("shutteropen", 0.0)?, cp.get_float("shutterclose", 1.0)?);
    let exposure = close - open;
    if !(exposure.is_finite() && exposure > 0.0) {
        return err(
            &cp.loc_of("shutterclose", &desc.camera.entity.loc),
            format!("'shutterclose' ({close}) must be later than 'shutteropen' ({open}): the shutter never opens"),
        );
    }
    let iso = fp.get_float("iso", 100.0)?;
    if !(iso.is_finite() && iso > 0.0) {
        return err(&fp.loc_of("iso", floc), format!("'iso' must be a positive number, got {iso}"));
    }
    let temperature = fp.get_float("whitebalance", 0.0)?;
    let wb_err = |e: spectral::SpectrumError| SceneError::at(fp.loc_of("whitebalance", floc), e.to_string());
    let imaging_ratio = PixelSensor::imaging_ratio(exposure, iso);
    if let Some(sensor) = camera_sensor {
        let kelvin = if temperature == 0.0 { 6500.0 } else { temperature };
        let illuminant = spectral::daylight::white_balance_illuminant(kelvin).map_err(wb_err)?;
        let output_white = spectral::named::illuminant("stdillum-D65").expect("D65 is built in");
        let Some(fit) = sensor.xyz_from_sensor_rgb(&illuminant, &output_white) else {
            return err(&fp.loc_of("sensor", floc), format!("sensor \"{name}\": its XYZ matrix cannot be fitted"));
        };
        let camera = CameraResponse { sensor, xyz_from_sensor_rgb: fit.matrix };
        return Ok(PixelSensor { imaging_ratio, white_balance_from: None, camera: Some(camera) });
    }
    let white_balance_from = if temperature == 0.0 {
        None
    } else {
        Some(spectral::daylight::white_balance_chromaticity(temperature).map_err(wb_err)?)
    };
    Ok(PixelSensor { imaging_ratio, white_balance_from, camera: None })
}

/// The `PixelFilter` directive: pbrt-v4's filters with their radii and shape parameters.
fn make_filter(e: &Entity) -> Result<Filter> {
    let p = &e.params;
    let Some(default) = Filter::default_for(&e.name) else {
        return err(&e.loc, unsupported("pixel filter", &e.name, &Filter::NAMES));
    };
    let r = default.radius();
    let radius = [p.get_float("xradius", r[0])?, p.get_float("yradius", r[1])?];
    let f = match default {
        Filter::Box { .. } => Filter::new_box(radius),
        Filter::Gaussian { sigma, .. } => Filter::gaussian(radius, p.get_float("sigma", sigma)?),
        Filter::Triangle { .. } => Filter::triangle(radius),
        Filter::Mitchell { b, c, .. } => Filter::mitchell(radius, p.get_float("B", b)?, p.get_float("C", c)?),
    };
    Ok(f.map_err(|x| SceneError::at(e.loc.clone(), x.to_string()))?)
}

//! The film: pbrt-v4's `Film "rgb"|"spectral"` directive (resolution, `filename`, spectral buckets,
//! `maxcomponentvalue`), its pixel sensor (`sensor`, `iso`, `whitebalance`, with the camera's shutter interval as
//! the exposure time) and the `PixelFilter` directive.

use std::path::PathBuf;

use film::{CameraResponse, FilmKind, FilmSpec, Filter, PixelSensor};
use scene::{Entity, SceneDescription, SceneError};
use spectral::sensor::CameraSensor;

use super::{err, unsupported, BuildOptions, Result};

/// The film to render into; `options` override the resolution and the output file.
pub(super) fn make_film(desc: &SceneDescription, options: &BuildOptions) -> Result<FilmSpec> {
    let fp = &desc.film.params;
    let kind = match desc.film.name.as_str() {
        "rgb" => FilmKind::Rgb,
        "spectral" => FilmKind::Spectral {
            nbuckets: fp.get_count("nbuckets", 16, &desc.film.loc)?,
            lambda_min: fp.get_float("lambdamin", 360.0)?,
            lambda_max: fp.get_float("lambdamax", 830.0)?,
        },
        other => return err(&desc.film.loc, unsupported("film", other, &["rgb", "spectral"])),
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
    film.validate().map_err(|e| SceneError::at(desc.film.loc.clone(), e.to_string()))?;
    Ok(film)
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
    f.map_err(|x| SceneError::at(e.loc.clone(), x.to_string()))
}

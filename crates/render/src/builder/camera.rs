//! The camera: pbrt-v4's `Camera "perspective"|"orthographic"` directive with `fov`, `frameaspectratio`,
//! `screenwindow`, `lensradius` and `focaldistance`, its `"realistic"` camera with `lensfile`, `aperturediameter`,
//! `focusdistance`, `aperture` and Prismatic's `lenstransmission`, and its motion (`ActiveTransform` before `Camera`). (Its
//! `shutteropen`/`shutterclose` set the exposure time, read with the film's sensor, and the interval rays' times
//! are drawn from when something moves.)

use std::sync::Arc;

use optics::{LensMedium, LensPrescription};
use scene::{Entity, SceneDescription};

use geometry::AnimatedTransform;

use super::context::{err, unsupported, Result};
use crate::camera::{ApertureMask, Camera, Projection, RealisticLens, RealisticParams, ScreenWindow};

/// pbrt-v4's realistic camera from its parameters, for a film of `res` pixels whose diagonal is `diagonal_mm`.
fn make_realistic(e: &Entity, res: (u32, u32), diagonal_mm: f64, warnings: &mut Vec<String>) -> Result<Projection> {
    let p = &e.params;
    let Some(path) = p.get_filename("lensfile")? else {
        return err(&e.loc, "camera \"realistic\" needs 'string lensfile' (a lens prescription)");
    };
    let at = p.loc_of("lensfile", &e.loc);
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(io) => return err(&at, format!("cannot read lens file {}: {io}", path.display())),
    };
    let lens = LensPrescription::parse(&text)
        .map_err(|le| scene::SceneError::at(at.clone(), format!("{}:{le}", path.display())))?;
    for (i, s) in lens.surfaces.iter().enumerate() {
        if s.radius_mm == 0.0 && !s.is_stop && s.medium != LensMedium::Air {
            warnings.push(format!(
                "{}:{}: warning: surface {} is flat with glass behind it: Prismatic refracts there, pbrt-v4 would \
                 take every flat row for the aperture stop",
                path.display(),
                s.line,
                i + 1
            ));
        }
    }
    let aperture_diameter_mm = p.get_float("aperturediameter", 1.0)?;
    let focus_distance_m = p.get_float("focusdistance", 10.0)?;
    let aperture = p.get_string("aperture", "")?;
    let mask = match aperture.as_str() {
        "" | "circular" => None,
        name => match ApertureMask::builtin(name) {
            Some(m) => Some(m),
            None => {
                let at = p.loc_of("aperture", &e.loc);
                let file = p.get_filename("aperture")?.unwrap_or_default();
                let (w, h, rgb) = film::read_rgb_encoded(&file, film::ColorEncoding::Srgb).map_err(|ie| {
                    scene::SceneError::at(
                        at.clone(),
                        format!(
                            "'aperture' \"{name}\" is not \"circular\", \"gaussian\", \"square\", \"pentagon\" \
                             or \"star\", and not an image that can be read: {ie}"
                        ),
                    )
                })?;
                let grey: Vec<f32> = rgb.iter().map(|c| (c[0] + c[1] + c[2]) / 3.0).collect();
                let Some(m) = ApertureMask::from_image(w as usize, h as usize, &grey) else {
                    return err(&at, format!("aperture image {} is black: it lets no light through", file.display()));
                };
                Some(m)
            }
        },
    };
    // Prismatic's extension: the light each surface reflects away (through its coating) is lost to the image. A
    // lens file that gives coatings asks for it; pbrt-v4's camera has none.
    let coated = lens.surfaces.iter().any(|s| !s.coating.is_empty());
    let fresnel = p.get_bool("lenstransmission", coated)?;
    let params = RealisticParams {
        lens,
        aperture_diameter_mm,
        focus_distance_m,
        film_diagonal_mm: diagonal_mm,
        resolution: res,
        mask,
        wavelength_range_nm: (spectral::LAMBDA_MIN, spectral::LAMBDA_MAX),
        fresnel,
    };
    let (lens, clamped) = RealisticLens::new(params)
        .map_err(|m| scene::SceneError::at(e.loc.clone(), format!("camera \"realistic\" ({}): {m}", path.display())))?;
    if let Some(stop_mm) = clamped {
        warnings.push(format!(
            "{}: warning: 'aperturediameter' {aperture_diameter_mm} mm is larger than the stop's {stop_mm} mm: clamped",
            p.loc_of("aperturediameter", &e.loc),
        ));
    }
    Ok(Projection::Realistic(Arc::new(lens)))
}

/// The camera for a film of `res` pixels (whose aspect ratio is the default `frameaspectratio`).
pub(super) fn make_camera(desc: &SceneDescription, res: (u32, u32), warnings: &mut Vec<String>) -> Result<Camera> {
    let e = &desc.camera.entity;
    let p = &e.params;
    // The screen window and thin lens belong to pbrt-v4's projective cameras; a realistic camera does not read them
    // (so, given, they are reported unused).
    let (window, lens_radius, focal) = if e.name == "realistic" {
        (ScreenWindow::for_aspect(res.0 as f32 / res.1 as f32), 0.0, 1.0)
    } else {
        let aspect = p.get_float("frameaspectratio", res.0 as f64 / res.1 as f64)? as f32;
        let window = match p.get_floats("screenwindow") {
            Some(s) if s.len() == 4 => {
                ScreenWindow { x_min: s[0] as f32, x_max: s[1] as f32, y_min: s[2] as f32, y_max: s[3] as f32 }
            }
            Some(s) => return err(&e.loc, format!("'screenwindow' needs 4 values, got {}", s.len())),
            None => ScreenWindow::for_aspect(aspect),
        };
        let lens_radius = p.get_float("lensradius", 0.0)?;
        let focal = p.get_float("focaldistance", 1e6)?;
        if lens_radius < 0.0 || focal.is_nan() || focal <= 0.0 {
            return err(&e.loc, "'lensradius' must be ≥ 0 and 'focaldistance' > 0");
        }
        (window, lens_radius, focal)
    };
    let projection = match e.name.as_str() {
        "perspective" => {
            let fov = p.get_float("fov", 90.0)?;
            if !(fov > 0.0 && fov < 180.0) {
                return err(&e.loc, format!("'fov' must be in (0, 180) degrees, got {fov}"));
            }
            Projection::Perspective { tan_half_fov: (fov.to_radians() / 2.0).tan() as f32 }
        }
        "orthographic" => Projection::Orthographic,
        "realistic" => {
            // The film's diagonal (checked with the film) sizes the sensor behind the lens.
            let diagonal = desc.film.params.get_float("diagonal", 35.0)?;
            make_realistic(e, res, diagonal, warnings)?
        }
        other => return err(&e.loc, unsupported("camera", other, &["perspective", "orthographic", "realistic"])),
    };
    let cfw = &desc.camera.camera_from_world;
    let camera = Camera::new(projection, cfw, res, window, lens_radius as f32, focal as f32);
    let Some(m) = &desc.camera.motion else { return Ok(camera) };
    // pbrt-v4 interpolates world-from-camera (not its inverse) between the two times.
    let Some(motion) = AnimatedTransform::new(cfw.inverse(), m.start_time, m.end.inverse(), m.end_time) else {
        return err(
            &e.loc,
            "the camera's moving transform cannot be interpolated: both ends must be affine to be split into \
             translation, rotation and scale",
        );
    };
    Ok(camera.with_motion(motion))
}

//! The camera: pbrt-v4's `Camera "perspective"|"orthographic"` directive with `fov`, `frameaspectratio`,
//! `screenwindow`, `lensradius` and `focaldistance`, and its motion (`ActiveTransform` before `Camera`). (Its
//! `shutteropen`/`shutterclose` set the exposure time, read with the film's sensor, and the interval rays' times
//! are drawn from when something moves.)

use scene::SceneDescription;

use geometry::AnimatedTransform;

use super::context::{err, unsupported, Result};
use crate::camera::{Camera, Projection, ScreenWindow};

/// The camera for a film of `res` pixels (whose aspect ratio is the default `frameaspectratio`).
pub(super) fn make_camera(desc: &SceneDescription, res: (u32, u32)) -> Result<Camera> {
    let e = &desc.camera.entity;
    let p = &e.params;
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
    let projection = match e.name.as_str() {
        "perspective" => {
            let fov = p.get_float("fov", 90.0)?;
            if !(fov > 0.0 && fov < 180.0) {
                return err(&e.loc, format!("'fov' must be in (0, 180) degrees, got {fov}"));
            }
            Projection::Perspective { tan_half_fov: (fov.to_radians() / 2.0).tan() as f32 }
        }
        "orthographic" => Projection::Orthographic,
        other => return err(&e.loc, unsupported("camera", other, &["perspective", "orthographic"])),
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

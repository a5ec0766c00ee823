//! pbrt-v4's rule for the medium of a ray that leaves a surface with a medium interface: reflected or transmitted,
//! it travels in the medium on the side it leaves into (pbrt-v4's `SurfaceInteraction::GetMedium`).
//!
//! The scene: a camera in absorbing fog (σa = 0.5, no scattering) looks along +z at a large diffuse quad of albedo
//! 0.5 at distance 2 whose interface says fog outside, vacuum inside, with its normal pointing away from the camera,
//! so the camera's side is the inside. A ray the quad reflects back towards the camera's side travels in vacuum and
//! sees the uniform sky of radiance 1 over the whole hemisphere; the camera ray crossed 2 units of fog. Every pixel
//! is exactly 0.5·e^(−0.5·2) = 0.5/e (an orthographic camera: every camera ray crosses the same fog). A reflected
//! ray that kept the fog would see the sky through infinite fog, black.

use std::path::Path;

use crate::{build_scene, BuildOptions, BuiltScene};

/// The scene with integrator line `integrator` and camera line `camera`.
fn fog_scene(integrator: &str, camera: &str) -> BuiltScene {
    let text = format!(
        "MakeNamedMedium \"fog\" \"string type\" \"homogeneous\" \"spectrum sigma_a\" [ 360 0.5 830 0.5 ] \
         \"spectrum sigma_s\" [ 360 0 830 0 ] \"float scale\" 1\n\
         MediumInterface \"\" \"fog\"\n\
         LookAt 0 0 0  0 0 1  0 1 0\n{camera}\n\
         Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\n\
         PixelFilter \"box\" \"float xradius\" 0.5 \"float yradius\" 0.5\n\
         Sampler \"zsobol\" \"integer pixelsamples\" 64\n{integrator}\n\
         WorldBegin\n\
         LightSource \"infinite\" \"spectrum L\" [ 360 1 830 1 ]\n\
         AttributeBegin\nMediumInterface \"\" \"fog\"\n\
         Material \"diffuse\" \"spectrum reflectance\" [ 360 0.5 830 0.5 ]\n\
         Shape \"trianglemesh\" \"point3 P\" [ -20 -20 2  20 -20 2  20 20 2  -20 20 2 ] \
         \"normal N\" [ 0 0 1  0 0 1  0 0 1  0 0 1 ] \"integer indices\" [ 0 1 2  0 2 3 ]\n\
         AttributeEnd\n"
    );
    let desc = pbrt::parse_str(&text, Path::new("fog.pbrt")).unwrap_or_else(|e| panic!("{e}"));
    build_scene(&desc, &BuildOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

/// Mean Y over the image at 64 spp.
fn mean_y(built: &BuiltScene) -> f64 {
    let mut film = film::Film::new(built.film.clone()).unwrap();
    built.integrator.render(&built.scene, &mut film, 0..built.spp, 7, &|_| {}).unwrap();
    let (w, h) = (film.width(), film.height());
    let mut sum = 0.0;
    for y in 0..h {
        for x in 0..w {
            sum += film.pixel_xyz(x, y).y;
        }
    }
    sum / (w * h) as f64
}

/// Camera paths (`path` attenuates through media that only absorb, `volpath` renders all media): the mean is 0.5/e
/// within 1% (the sky and the fog are constant over wavelength, so only the diffuse bounce's sampling is noisy; 4096
/// samples over the image put its error well under that).
#[test]
fn a_ray_reflected_at_an_interface_travels_in_the_medium_of_its_side() {
    let expected = 0.5 / std::f64::consts::E;
    let camera = "Camera \"orthographic\" \"float screenwindow\" [ -1 1 -1 1 ]";
    for integrator in ["Integrator \"path\"", "Integrator \"volpath\""] {
        let y = mean_y(&fog_scene(integrator, camera));
        assert!((y / expected - 1.0).abs() < 0.01, "{integrator}: mean Y {y}, expected 0.5/e = {expected}");
    }
}

/// The same scene for the integrators that connect vertices (`bdpt`) and gather photons (`sppm`), a cross-check
/// rather than a guard of the rule: here their estimates come mostly from shadow rays and connections leaving the
/// quad, which followed the rule before `PathRay::leave` did too, and they agree with or without it. They need a
/// perspective camera for light paths to reach; with it, pixel (sx, sy) of the screen window sees the quad at distance 2·√(1 + (sx² + sy²)·tan²20°)
/// through the fog, and the image mean is the mean of 0.5·e^(−0.5·d) over the screen (box filter), integrated here
/// on a 256² grid. `bdpt` within 1%, `sppm` (consistent, not unbiased: its gather radius blurs) within 2%.
/// (`lightpath` is left out: its light paths start in the light's medium, the fog, which this scene puts on the far
/// side of the quad from the camera while the camera sits in it too; the image depends on which side a light path
/// is said to start, not on the rule tested here.)
#[test]
fn connections_and_photons_follow_the_same_rule() {
    let t = 20f64.to_radians().tan();
    let n = 256;
    let mut sum = 0.0;
    for i in 0..n {
        for j in 0..n {
            let (sx, sy) = ((i as f64 + 0.5) / n as f64 * 2.0 - 1.0, (j as f64 + 0.5) / n as f64 * 2.0 - 1.0);
            let d = 2.0 * (1.0 + (sx * sx + sy * sy) * t * t).sqrt();
            sum += 0.5 * (-0.5 * d).exp();
        }
    }
    let expected = sum / (n * n) as f64;
    let camera = "Camera \"perspective\" \"float fov\" 40";
    for (integrator, tolerance) in
        [("Integrator \"bdpt\"", 0.01), ("Integrator \"sppm\" \"float radius\" 0.2 \"integer iterations\" 64", 0.02)]
    {
        let y = mean_y(&fog_scene(integrator, camera));
        assert!((y / expected - 1.0).abs() < tolerance, "{integrator}: mean Y {y}, expected {expected}");
    }
}

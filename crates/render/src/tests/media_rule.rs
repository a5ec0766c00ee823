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

/// The scene with integrator line `integrator` and camera line `camera`; the quad's normal points away from the
/// camera (interface: fog outside, vacuum inside).
fn fog_scene(integrator: &str, camera: &str) -> BuiltScene {
    quad_scene(integrator, camera, "MediumInterface \"\" \"fog\"", "0 0 1")
}

/// The fog scene with the quad's `interface` line and normal `normal` (the same at its four corners).
fn quad_scene(integrator: &str, camera: &str, interface: &str, normal: &str) -> BuiltScene {
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
         AttributeBegin\n{interface}\n\
         Material \"diffuse\" \"spectrum reflectance\" [ 360 0.5 830 0.5 ]\n\
         Shape \"trianglemesh\" \"point3 P\" [ -20 -20 2  20 -20 2  20 20 2  -20 20 2 ] \
         \"normal N\" [ {normal}  {normal}  {normal}  {normal} ] \"integer indices\" [ 0 1 2  0 2 3 ]\n\
         AttributeEnd\n"
    );
    let desc = pbrt::parse_str(&text, Path::new("fog.pbrt")).unwrap_or_else(|e| panic!("{e}"));
    build_scene(&desc, &BuildOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

/// Mean Y over the image at 64 spp.
fn mean_y(built: &BuiltScene) -> f64 {
    super::support::mean_y(built, 7, 0..built.film.height)
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
        // The quad turned to face the camera, its interface swapped to match: the camera's side is now the
        // outside, still vacuum, and the image is the same.
        let facing = quad_scene(integrator, camera, "MediumInterface \"fog\" \"\"", "0 0 -1");
        let y = mean_y(&facing);
        assert!((y / expected - 1.0).abs() < 0.01, "{integrator}, quad facing the camera: mean Y {y}");
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

/// Media nested along a ray: a camera inside a sphere of fog A (σa = 0.3, radius 6, vacuum and the sky of
/// radiance 1 outside) looks through a smaller sphere of fog B (σa = 1, radius 1.5, centre 3 units ahead) whose
/// interface says B inside, A outside; both spheres are index-matched boundaries (`interface`). An orthographic
/// ray at distance r from the axis crosses a chord c = 2√(1.5² − r²) of B and √(36 − r²) − c of A, so its pixel is
/// e^(−0.3(√(36 − r²) − c) − c) exactly; the image mean is that averaged over the screen window (a 512² grid here).
/// Each crossing hands the ray to the medium of the side it enters: a ray that kept A inside B, or kept B after
/// leaving it, or kept A beyond the outer sphere (never reaching the sky), gives another image.
#[test]
fn transmitted_rays_take_the_medium_of_each_side_they_enter() {
    let n = 512;
    let mut sum = 0.0;
    for i in 0..n {
        for j in 0..n {
            let (x, y) = ((i as f64 + 0.5) / n as f64 * 2.0 - 1.0, (j as f64 + 0.5) / n as f64 * 2.0 - 1.0);
            let r2 = x * x + y * y;
            let chord = 2.0 * (2.25 - r2).sqrt();
            sum += (-0.3 * ((36.0 - r2).sqrt() - chord) - chord).exp();
        }
    }
    let expected = sum / (n * n) as f64;
    for integrator in ["Integrator \"path\"", "Integrator \"volpath\""] {
        let text = format!(
            "MakeNamedMedium \"A\" \"string type\" \"homogeneous\" \"spectrum sigma_a\" [ 360 0.3 830 0.3 ] \
             \"spectrum sigma_s\" [ 360 0 830 0 ] \"float scale\" 1\n\
             MakeNamedMedium \"B\" \"string type\" \"homogeneous\" \"spectrum sigma_a\" [ 360 1 830 1 ] \
             \"spectrum sigma_s\" [ 360 0 830 0 ] \"float scale\" 1\n\
             MediumInterface \"\" \"A\"\n\
             LookAt 0 0 0  0 0 1  0 1 0\nCamera \"orthographic\" \"float screenwindow\" [ -1 1 -1 1 ]\n\
             Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\n\
             PixelFilter \"box\" \"float xradius\" 0.5 \"float yradius\" 0.5\n\
             Sampler \"zsobol\" \"integer pixelsamples\" 64\n{integrator}\n\
             WorldBegin\n\
             LightSource \"infinite\" \"spectrum L\" [ 360 1 830 1 ]\n\
             AttributeBegin\nMediumInterface \"A\" \"\"\nMaterial \"interface\"\nShape \"sphere\" \"float radius\" 6\n\
             AttributeEnd\n\
             AttributeBegin\nTranslate 0 0 3\nMediumInterface \"B\" \"A\"\nMaterial \"interface\"\n\
             Shape \"sphere\" \"float radius\" 1.5\nAttributeEnd\n"
        );
        let desc = pbrt::parse_str(&text, Path::new("nested.pbrt")).unwrap_or_else(|e| panic!("{e}"));
        let built = build_scene(&desc, &BuildOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        let y = mean_y(&built);
        assert!((y / expected - 1.0).abs() < 0.005, "{integrator}: mean Y {y}, expected {expected}");
    }
}

/// The white furnace through an index-matched boundary: a sphere of fog that scatters and never absorbs (σs = 2,
/// albedo 1, isotropic), bounded by an `interface` sphere, in vacuum under a sky of radiance 1. Every path
/// scatters in the fog until it leaves the sphere, and then, in vacuum, must reach the sky: every pixel's expected
/// value is exactly 1 (no path is lost with `maxdepth` high enough for the few dozen scatterings the fog takes).
/// Light sampling through the fog makes single pixels noisy (up to about 16% at 64 spp), so at 256 spp the image
/// mean must be within 1% of 1 (about three standard errors) and no pixel below 0.5. A ray leaving the sphere that kept the fog would scatter on in
/// unbounded fog, its shadow rays never reaching the sky: the sphere's pixels would go dark.
#[test]
fn the_furnace_through_an_index_matched_boundary_keeps_every_path() {
    for integrator in
        ["Integrator \"volpath\" \"integer maxdepth\" 100000", "Integrator \"bdpt\" \"integer maxdepth\" 100000"]
    {
        let text = format!(
            "MakeNamedMedium \"C\" \"string type\" \"homogeneous\" \"spectrum sigma_a\" [ 360 0 830 0 ] \
             \"spectrum sigma_s\" [ 360 2 830 2 ] \"float scale\" 1\n\
             LookAt 0 0 0  0 0 1  0 1 0\nCamera \"perspective\" \"float fov\" 40\n\
             Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\n\
             PixelFilter \"box\" \"float xradius\" 0.5 \"float yradius\" 0.5\n\
             Sampler \"zsobol\" \"integer pixelsamples\" 256\n{integrator}\n\
             WorldBegin\n\
             LightSource \"infinite\" \"spectrum L\" [ 360 1 830 1 ]\n\
             AttributeBegin\nTranslate 0 0 3\nMediumInterface \"C\" \"\"\nMaterial \"interface\"\n\
             Shape \"sphere\" \"float radius\" 1\nAttributeEnd\n"
        );
        let desc = pbrt::parse_str(&text, Path::new("furnace.pbrt")).unwrap_or_else(|e| panic!("{e}"));
        let built = build_scene(&desc, &BuildOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        let mut film = film::Film::new(built.film.clone()).unwrap();
        built.integrator.render(&built.scene, &mut film, 0..built.spp, 3, &|_| {}).unwrap();
        let mut sum = 0.0;
        for y in 0..film.height() {
            for x in 0..film.width() {
                let v = film.pixel_xyz(x, y).y;
                assert!(v > 0.5, "{integrator}: pixel ({x}, {y}) is {v}, not about 1");
                sum += v;
            }
        }
        let mean = sum / (film.width() * film.height()) as f64;
        assert!((mean - 1.0).abs() < 0.01, "{integrator}: image mean {mean}, not 1");
    }
}

/// Every integrator, light paths and photons included, on a scene whose media are consistent: the camera sits at
/// the centre of a sphere of absorbing fog (σa = 0.5, radius 1, an index-matched `interface` boundary with vacuum
/// outside), and everything else is in vacuum (the scene says so after `WorldBegin`: the camera's interface would
/// otherwise carry over to the shapes): a diffuse quad 3 units ahead and a quad light above it whose light
/// reaches the quad without crossing the sphere. Every path that reaches the camera, however it was built (a camera
/// path leaving the fog, a light path connected to the lens through the boundary, a photon gathered at the quad),
/// crosses exactly one radius of fog last, so the image with the fog is the image without it times e^(−0.5),
/// exactly. Both images use the same seed, so the paths are the same and only the fog's transmittance differs:
/// `bdpt`, `lightpath` and `sppm` multiply by it and are checked to 0.1% (they came out within 5e-5);
/// `volpath`'s paths survive the fog by chance (free-flight sampling), checked to 1% (it came out 0.08% off).
#[test]
fn every_integrator_sees_the_fog_around_the_camera_once() {
    let scene = |sigma_a: f64, integrator: &str| {
        let text = format!(
            "MakeNamedMedium \"F\" \"string type\" \"homogeneous\" \"spectrum sigma_a\" [ 360 {sigma_a} 830 {sigma_a} ] \
             \"spectrum sigma_s\" [ 360 0 830 0 ] \"float scale\" 1\n\
             MediumInterface \"\" \"F\"\n\
             LookAt 0 0 0  0 0 1  0 1 0\nCamera \"perspective\" \"float fov\" 40\n\
             Film \"rgb\" \"integer xresolution\" 16 \"integer yresolution\" 16\n\
             Sampler \"zsobol\" \"integer pixelsamples\" 64\n{integrator}\n\
             WorldBegin\nMediumInterface \"\" \"\"\n\
             AttributeBegin\nMediumInterface \"F\" \"\"\nMaterial \"interface\"\nShape \"sphere\" \"float radius\" 1\n\
             AttributeEnd\n\
             AttributeBegin\nMaterial \"diffuse\" \"spectrum reflectance\" [ 360 0.5 830 0.5 ]\n\
             Shape \"trianglemesh\" \"point3 P\" [ -3 -3 3  3 -3 3  3 3 3  -3 3 3 ] \
             \"normal N\" [ 0 0 -1  0 0 -1  0 0 -1  0 0 -1 ] \"integer indices\" [ 0 1 2  0 2 3 ]\n\
             AttributeEnd\n\
             AttributeBegin\nAreaLightSource \"diffuse\" \"spectrum L\" [ 360 5 830 5 ]\n\
             Shape \"trianglemesh\" \"point3 P\" [ -1 4 1  1 4 1  1 4 2.5  -1 4 2.5 ] \
             \"normal N\" [ 0 -1 0  0 -1 0  0 -1 0  0 -1 0 ] \"integer indices\" [ 0 1 2  0 2 3 ]\n\
             AttributeEnd\n"
        );
        let desc = pbrt::parse_str(&text, Path::new("fog-around-camera.pbrt")).unwrap_or_else(|e| panic!("{e}"));
        build_scene(&desc, &BuildOptions::default()).unwrap_or_else(|e| panic!("{integrator}: {e}"))
    };
    let expected = (-0.5f64).exp();
    for (integrator, tolerance) in [
        ("Integrator \"volpath\"", 0.01),
        ("Integrator \"bdpt\"", 1e-3),
        ("Integrator \"lightpath\"", 1e-3),
        ("Integrator \"sppm\" \"float radius\" 0.1 \"integer iterations\" 64", 1e-3),
    ] {
        let (fog, clear) = (mean_y(&scene(0.5, integrator)), mean_y(&scene(0.0, integrator)));
        assert!(clear > 1e-3, "{integrator}: the scene is dark ({clear})");
        let ratio = fog / clear;
        assert!(
            (ratio / expected - 1.0).abs() < tolerance,
            "{integrator}: ratio {ratio}, expected e^-0.5 = {expected}"
        );
    }
}

//! The four integrators against each other, on small scenes built in code (no parser).
//!
//! - **Agreement**: light tracing, bidirectional path tracing and photon mapping estimate the same image as the
//!   path tracer where all of them can render the scene (a diffuse room lit by an area light; for BDPT also delta
//!   lights, a rough metal and a thin lens). The comparison is statistical, per block of pixels, with the noise
//!   measured from two independent seeds (see [`block_y`]), never with numbers copied from an earlier run: another
//!   change to how the integrators draw random numbers changes every image but none of these expectations.
//! - **Determinism**: an image does not depend on the number of threads, and a render split into two runs of one
//!   job equals the render in one run (photon mapping's progressive state carries across runs).

use std::ops::Range;
use std::sync::Arc;

use crate::camera::{Camera, Projection, ScreenWindow};
use crate::integrator::{
    BdptIntegrator, Integrator, LightPathIntegrator, PathIntegrator, RenderJob, SppmIntegrator, VolPathIntegrator,
};
use crate::light::Light;
use crate::material::{ConductorSpec, DielectricIor, Material, Roughness};
use crate::medium::{HomogeneousMedium, Medium, PhaseFunction};
use crate::sampling::Frame;
use crate::scene::{LightMedium, MediumInterface, RenderScene, SceneGeometry, ShapeInfo, NO_MATERIAL};
use crate::texture::{FloatTexture, SpectrumTexture};
use film::{Film, FilmKind, FilmSpec, Filter};
use geometry::{
    AnimatedTransform, GeometryScene, Instance, MeshData, MovingInstance, Object, Shape, Sphere, Transform,
    TriangleMesh,
};
use glam::{DVec3, Vec3};
use spectral::rgb_uplift::{RgbAlbedoSpectrum, RgbIlluminantSpectrum};
use spectral::{Spectrum, WavelengthStrategy};

// ------------------------------------------------------------------------------------------------------------------
// Scenes
// ------------------------------------------------------------------------------------------------------------------

/// Image size: 4 × 3 blocks of 6 × 6 pixels.
const WIDTH: u32 = 24;
const HEIGHT: u32 = 18;
/// Side of a comparison block in pixels.
const BLOCK: u32 = 6;

/// What to put in the room besides its walls, the area light and the green diffuse sphere.
#[derive(Clone, Copy, Default)]
struct Extras {
    /// A point light and a spot light (delta lights: no strategy can hit them).
    delta_lights: bool,
    /// A rough gold sphere (glossy, not specular).
    rough_gold: bool,
    /// A thin-lens camera (lens radius 0.05, focused at 4.5) instead of a pinhole.
    thin_lens: bool,
    /// A smooth dispersive glass sphere (N-SF11): only for the determinism tests, where specular paths and
    /// wavelength-dependent refraction must be deterministic too.
    glass: bool,
    /// A ball of chromatic fog (radius 1.2, an index-matched boundary) in the middle of the room, away from the
    /// camera: light tracing connects fog vertices to the lens, and a vertex at distance d from the lens weighs
    /// 1/d², which only has finite variance if the fog keeps its distance.
    fog: bool,
    /// A small spherical lamp (radius 0.2, 2.4 above the floor, right above the glass sphere) in place of the
    /// ceiling quad: the glass focuses it into a caustic on the floor that the path tracer finds only by hitting
    /// the lamp through the glass.
    small_light: bool,
    /// The same fog, in a ball of radius 1 around the ceiling light instead (it reaches through the ceiling), so
    /// that the light emits into fog while the camera sits in clear air: light paths must start in the light's
    /// medium, not the camera's.
    fog_around_light: bool,
    /// Motion blur: the green sphere moves 1.2 to the right and 0.3 up while the shutter is open (a moving
    /// instance), and the camera moves 1 to the left and turns by 6° (pbrt-v4's `ActiveTransform`): every ray of a
    /// path, light paths included, must be traced at the path's time.
    motion: bool,
}

/// A quad as a two-triangle mesh (0 1 2, 0 2 3); its geometric normal is cross(p0 − p2, p1 − p2), which decides
/// the side an area light on it emits to.
fn quad(p: [[f32; 3]; 4]) -> Shape {
    let data = MeshData {
        positions: p.iter().map(|&v| Vec3::from(v)).collect(),
        normals: None,
        uvs: None,
        indices: vec![0, 1, 2, 0, 2, 3],
    };
    Shape::Mesh(Arc::new(TriangleMesh::new(&Transform::IDENTITY, data, false).unwrap()))
}

fn sphere(centre: [f64; 3], radius: f32) -> Shape {
    Shape::Sphere(Sphere::new(radius, Transform::translate(DVec3::from(centre)), false).unwrap())
}

fn diffuse(rgb: [f64; 3]) -> Material {
    Material::Diffuse {
        reflectance: SpectrumTexture::Constant(Spectrum::RgbAlbedo(RgbAlbedoSpectrum::new(rgb).unwrap())),
    }
}

/// A closed room of diffuse walls (grey, one red), a green diffuse sphere, and a 1.2 × 1.2 quad light (5000 K)
/// facing down from y = 3, seen from (0, 1.5, −4) through a 45° lens on a 24 × 18 film; `extras` adds to it. The
/// room is closed so that light bounces many times: every bounce up to the maximum depth matters (the fourth
/// bounce adds several per cent), so integrators that disagree on what the maximum depth counts disagree visibly.
fn room(extras: Extras) -> RenderScene {
    let mut materials = vec![diffuse([0.7, 0.7, 0.7]), diffuse([0.2, 0.6, 0.3]), diffuse([0.7, 0.25, 0.2])];
    let (mut shapes, mut info, mut lights) = (vec![], vec![], vec![]);
    let mut add = |shape: Shape, material: u32, emission: Option<Spectrum>, lights: &mut Vec<Light>| {
        let area_light_base = emission.map(|l| {
            let base = lights.len() as u32;
            for element in 0..shape.primitive_count() as u32 {
                lights.push(Light::DiffuseArea {
                    shape: Box::new(shape.clone()),
                    element,
                    l: l.clone(),
                    image: None,
                    two_sided: false,
                    alpha: None,
                    invisible: false,
                });
            }
            base
        });
        shapes.push(shape);
        info.push(ShapeInfo { material, area_light_base, media: None, vertex_colors: None });
    };
    if extras.small_light {
        add(sphere([0.6, 2.4, 0.0], 0.2), 0, Some(Spectrum::blackbody(5000.0).unwrap().scaled(60.0)), &mut lights);
    } else {
        let light = quad([[-0.6, 3.0, -0.6], [0.6, 3.0, -0.6], [0.6, 3.0, 0.6], [-0.6, 3.0, 0.6]]);
        add(light, 0, Some(Spectrum::blackbody(5000.0).unwrap().scaled(4.0)), &mut lights);
    }
    // The closed box x ∈ [−3, 3], y ∈ [0, 3.2], z ∈ [−4.5, 2]: floor, ceiling, back, front (behind the camera),
    // a red left wall and a grey right wall.
    let (x0, x1, y1, z0, z1) = (-3.0, 3.0, 3.2, -4.5, 2.0);
    add(quad([[x0, 0.0, z0], [x0, 0.0, z1], [x1, 0.0, z1], [x1, 0.0, z0]]), 0, None, &mut lights);
    add(quad([[x0, y1, z0], [x0, y1, z1], [x1, y1, z1], [x1, y1, z0]]), 0, None, &mut lights);
    add(quad([[x0, 0.0, z1], [x0, y1, z1], [x1, y1, z1], [x1, 0.0, z1]]), 0, None, &mut lights);
    add(quad([[x0, 0.0, z0], [x0, y1, z0], [x1, y1, z0], [x1, 0.0, z0]]), 0, None, &mut lights);
    add(quad([[x0, 0.0, z0], [x0, 0.0, z1], [x0, y1, z1], [x0, y1, z0]]), 2, None, &mut lights);
    add(quad([[x1, 0.0, z0], [x1, 0.0, z1], [x1, y1, z1], [x1, y1, z0]]), 0, None, &mut lights);
    // The green sphere: with motion, an object of its own placed by a moving instance (below).
    if !extras.motion {
        add(sphere([-0.8, 0.5, 0.5], 0.5), 1, None, &mut lights);
    }
    if extras.rough_gold {
        let named = |n: &str| SpectrumTexture::Constant(optics::catalogue::named_spectrum(n).unwrap());
        materials.push(Material::Conductor {
            spec: ConductorSpec::EtaK { eta: named("metal-Au-eta"), k: named("metal-Au-k") },
            roughness: Roughness { u: FloatTexture::Constant(0.3), v: FloatTexture::Constant(0.3), remap: true },
            coating: Default::default(),
        });
        add(sphere([0.9, 0.6, 0.2], 0.6), materials.len() as u32 - 1, None, &mut lights);
    }
    if extras.glass {
        let ior = DielectricIor::Model(optics::catalogue::lookup("N-SF11").unwrap().ior);
        materials.push(Material::Dielectric {
            ior,
            roughness: Roughness::smooth(),
            coating: Default::default(),
            tint: None,
        });
        add(sphere([0.6, 0.7, 0.0], 0.7), materials.len() as u32 - 1, None, &mut lights);
    }
    if extras.delta_lights {
        lights.push(Light::Point { p: Vec3::new(1.2, 2.2, -0.5), i: Spectrum::blackbody(3000.0).unwrap().scaled(3.0) });
        let (from, to) = (Vec3::new(-2.0, 3.0, -2.0), Vec3::new(0.0, 0.0, 1.0));
        lights.push(Light::Spot {
            p: from,
            frame: Frame::from_z((to - from).normalize()),
            i: Spectrum::RgbIlluminant(RgbIlluminantSpectrum::new([2.0, 3.0, 5.0]).unwrap()),
            cos_falloff_start: 20f32.to_radians().cos(),
            cos_falloff_end: 25f32.to_radians().cos(),
        });
    }
    if extras.fog || extras.fog_around_light {
        shapes.push(if extras.fog { sphere([0.3, 1.4, 0.0], 1.2) } else { sphere([0.0, 2.9, 0.0], 1.0) });
        let media = Some(MediumInterface { inside: Some(0), outside: None });
        info.push(ShapeInfo { material: NO_MATERIAL, area_light_base: None, media, vertex_colors: None });
    }
    let (accel, info) = if extras.motion {
        let start = Transform::translate(DVec3::new(-0.8, 0.5, 0.5));
        let end = Transform::translate(DVec3::new(0.4, 0.8, 0.5));
        let outer = AnimatedTransform::new(start, 0.0, end, 1.0).unwrap();
        let moving = MovingInstance { object: 1, outer, inner: AnimatedTransform::fixed(Transform::IDENTITY) };
        let objects = vec![Object::new(shapes), Object::new(vec![sphere([0.0; 3], 0.5)])];
        let still = vec![Instance { object: 0, render_from_instance: Transform::IDENTITY }];
        let green = ShapeInfo { material: 1, area_light_base: None, media: None, vertex_colors: None };
        (GeometryScene::build_with_motion(objects, still, vec![moving]).unwrap(), vec![info, vec![green]])
    } else {
        (GeometryScene::from_shapes(shapes).unwrap(), vec![info])
    };
    let cam = Transform::look_at(DVec3::new(0.0, 1.5, -4.0), DVec3::new(0.0, 1.0, 0.0), DVec3::Y).unwrap();
    let (lens_radius, focal_distance) = if extras.thin_lens { (0.05, 4.5) } else { (0.0, 1e6) };
    let mut camera = Camera::new(
        Projection::Perspective { tan_half_fov: 22.5f32.to_radians().tan() },
        &cam,
        (WIDTH, HEIGHT),
        ScreenWindow::for_aspect(WIDTH as f32 / HEIGHT as f32),
        lens_radius,
        focal_distance,
    );
    if extras.motion {
        let end = Transform::look_at(DVec3::new(-1.0, 1.5, -4.0), DVec3::new(-0.6, 1.0, 0.0), DVec3::Y).unwrap();
        camera = camera.with_motion(AnimatedTransform::new(cam.inverse(), 0.0, end.inverse(), 1.0).unwrap());
    }
    let media = if extras.fog || extras.fog_around_light {
        let fog = Medium::Homogeneous(HomogeneousMedium {
            sigma_a: Spectrum::Constant(0.02).into(),
            sigma_s: Spectrum::piecewise_linear(vec![400.0, 700.0], vec![1.2, 0.3]).unwrap().into(),
            le: None,
            phase: PhaseFunction::HenyeyGreenstein(0.3),
        });
        vec![fog]
    } else {
        vec![]
    };
    let light_count = lights.len();
    let mut scene =
        RenderScene::new(std::sync::Arc::new(SceneGeometry::new(accel, info)), materials, lights, media, None, camera);
    if extras.motion {
        scene.motion = Some([0.0, 1.0]);
    }
    if extras.fog_around_light {
        // Every light of this room is the ceiling quad's two triangles, inside the fog.
        scene.light_media = vec![LightMedium::Fixed(Some(0)); light_count];
    }
    scene
}

fn path(max_depth: u32) -> Integrator {
    Integrator::Path(PathIntegrator { max_depth, split_dispersion: true, manifold_nee: false, regularize: false })
}

fn volpath(max_depth: u32) -> Integrator {
    Integrator::VolPath(VolPathIntegrator {
        max_depth,
        split_dispersion: true,
        regularize: false,
        sun_guide: 0.25,
        forced_collisions: None,
    })
}

fn lightpath(max_depth: u32) -> Integrator {
    Integrator::LightPath(LightPathIntegrator { max_depth })
}

fn bdpt(max_depth: u32) -> Integrator {
    Integrator::Bdpt(BdptIntegrator { max_depth, regularize: false })
}

/// Photon mapping with one photon per pixel per iteration and an initial gather radius of 0.15 (a few per cent of
/// the room; the radius shrinks as the iterations progress).
fn sppm(max_depth: u32) -> Integrator {
    Integrator::Sppm(SppmIntegrator { max_depth, photons_per_iteration: None, initial_radius: 0.15, iterations: 64 })
}

/// A film of the scene's size with a box filter of radius ½ (each sample counts in its own pixel only, so pixels
/// are independent) and hero wavelengths.
fn film() -> Film {
    let mut spec = FilmSpec::new(WIDTH, HEIGHT, "integrators.exr");
    spec.filter = Filter::new_box([0.5, 0.5]).unwrap();
    spec.wavelengths = WavelengthStrategy::Hero;
    Film::new(spec).unwrap()
}

/// Renders passes `passes` (samples per pixel, or photon-mapping iterations) with `seed`.
fn render(scene: &RenderScene, integrator: &Integrator, passes: Range<u32>, seed: u32) -> Film {
    let mut film = film();
    integrator.render(scene, &mut film, passes, seed, &|_| {}).unwrap();
    film
}

// ------------------------------------------------------------------------------------------------------------------
// Agreement
// ------------------------------------------------------------------------------------------------------------------

/// Mean Y over a block of pixels and its standard error, from two renders with independent seeds: the pixel
/// differences aₚ − bₚ have zero mean and variance Var aₚ + Var bₚ whatever the image, so the standard error of the
/// mean of (a + b)/2 over n pixels is √(Σ (aₚ − bₚ)²)/(2n). That assumes independent pixels: true for camera
/// samples (each pixel has its own sampler and the box filter keeps samples in their pixel); a light path splats
/// into a few pixels and a photon is gathered by neighbouring pixels, a correlation this estimate ignores and
/// [`K_SIGMA`] (and, for photon mapping, its relative term) absorbs.
fn block_y(a: &Film, b: &Film, xs: Range<u32>, ys: Range<u32>) -> (f64, f64) {
    block_xyz(a, b, xs, ys, 1)
}

/// [`block_y`] for CIE XYZ component `c` (0 for X, 1 for Y, 2 for Z).
fn block_xyz(a: &Film, b: &Film, xs: Range<u32>, ys: Range<u32>, c: usize) -> (f64, f64) {
    let (mut sum, mut d2, mut n) = (0.0, 0.0, 0.0);
    for y in ys {
        for x in xs.clone() {
            let (va, vb) = (a.pixel_xyz(x, y).to_array()[c], b.pixel_xyz(x, y).to_array()[c]);
            sum += 0.5 * (va + vb);
            d2 += (va - vb).powi(2);
            n += 1.0;
        }
    }
    (sum / n, d2.sqrt() / (2.0 * n))
}

/// Number of standard errors allowed between two estimates of a block. Renders use fixed seeds, so the tests
/// never flake; 4.5σ keeps a correct integrator passing after any change of its random streams (about 1 in 150 000
/// per comparison for Gaussian noise, 13 comparisons per channel compared) while still resolving the few per cent that the
/// power checks in [`agrees_with_path`] guarantee.
const K_SIGMA: f64 = 4.5;

/// Renders `scene` with the path tracer (`path_spp` samples, seeds 1 and 2) and with `other` (`other_passes`,
/// seeds 3 and 4) and compares the mean Y of the whole image and of each of the 12 blocks of 6 × 6 pixels:
/// |Δ| ≤ K_SIGMA·σ_Δ + `relative`·Y_path, where σ_Δ combines both estimates' standard errors and `relative` allows
/// for a known bias (photon mapping's kernel).
///
/// Power, asserted: the whole image's tolerance is below `max_tolerance` of its value, so an integrator off by more
/// than that everywhere (a wrong normalisation, a missing cosine, a lost bounce) fails; and every block's relative
/// standard errors are below 4%, so the blocks resolve local errors of a few tens of per cent (a light missing from
/// one part of the image, a wrong weight for one kind of path). Prints the worst |Δ| in σ and in tolerances.
fn agrees_with_path(
    scene: &RenderScene,
    other: &Integrator,
    path_spp: u32,
    other_passes: u32,
    relative: f64,
    max_tolerance: f64,
) {
    agrees_with(scene, &path(4), other, path_spp, other_passes, relative, max_tolerance)
}

/// [`agrees_with_path`] with another reference than the path tracer (`volpath` where there are media).
fn agrees_with(
    scene: &RenderScene,
    reference: &Integrator,
    other: &Integrator,
    path_spp: u32,
    other_passes: u32,
    relative: f64,
    max_tolerance: f64,
) {
    agrees_with_in(&[1], scene, reference, other, path_spp, other_passes, relative, max_tolerance)
}

/// [`agrees_with`] for each CIE XYZ component in `channels` (0 X, 1 Y, 2 Z), from the same renders: in a chromatic
/// medium an error at some wavelengths (a spectral MIS that is biased per wavelength) shows most in X or Z, whose
/// matching functions weigh the ends of the spectrum where σ differs most from the mean.
// The comparison's scene, integrators, sample counts and tolerances, as each test states them.
#[allow(clippy::too_many_arguments)]
fn agrees_with_in(
    channels: &[usize],
    scene: &RenderScene,
    reference: &Integrator,
    other: &Integrator,
    path_spp: u32,
    other_passes: u32,
    relative: f64,
    max_tolerance: f64,
) {
    let (pa, pb) = (render(scene, reference, 0..path_spp, 1), render(scene, reference, 0..path_spp, 2));
    let (oa, ob) = (render(scene, other, 0..other_passes, 3), render(scene, other, 0..other_passes, 4));
    for &c in channels {
        compare_blocks(&pa, &pb, &oa, &ob, other.name(), c, relative, max_tolerance);
    }
}

/// The comparisons of [`agrees_with`] on XYZ component `c` of the reference's renders `pa`, `pb` and the other
/// integrator's `oa`, `ob`.
// Four renders, the integrator's name, the XYZ component and the two tolerances of `agrees_with_in`.
#[allow(clippy::too_many_arguments)]
fn compare_blocks(pa: &Film, pb: &Film, oa: &Film, ob: &Film, name: &str, c: usize, relative: f64, max_tolerance: f64) {
    let channel = ["X", "Y", "Z"][c];
    let (mut worst_sigmas, mut worst_of_tolerance) = (0.0f64, 0.0f64);
    let mut compare = |block: &str, xs: Range<u32>, ys: Range<u32>| {
        let what = format!("{block} {channel}");
        let (yp, sp) = block_xyz(pa, pb, xs.clone(), ys.clone(), c);
        let (yo, so) = block_xyz(oa, ob, xs, ys, c);
        let sigma = (sp * sp + so * so).sqrt();
        let tol = K_SIGMA * sigma + relative * yp;
        let d = (yp - yo).abs();
        eprintln!("{name}, {what}: path {yp:.5} ± {sp:.5}, {name} {yo:.5} ± {so:.5}: |Δ| = {:.2}σ", d / sigma);
        assert!(yp > 0.0 && sp / yp < 0.04 && so / yo < 0.04, "{what}: path {yp} ± {sp}, {name} {yo} ± {so}");
        assert!(d <= tol, "{what}: path {yp} ± {sp}, {name} {yo} ± {so}, |Δ| = {:.2}σ (tolerance {tol})", d / sigma);
        worst_sigmas = worst_sigmas.max(d / sigma);
        worst_of_tolerance = worst_of_tolerance.max(d / tol);
        tol / yp
    };
    for by in 0..HEIGHT / BLOCK {
        for bx in 0..WIDTH / BLOCK {
            compare(&format!("block ({bx},{by})"), bx * BLOCK..(bx + 1) * BLOCK, by * BLOCK..(by + 1) * BLOCK);
        }
    }
    let image_tolerance = compare("image", 0..WIDTH, 0..HEIGHT);
    assert!(image_tolerance < max_tolerance, "{name}: the image's tolerance is {image_tolerance}");
    eprintln!(
        "{name}, {channel}: worst |Δ| = {:.2}σ, {:.0}% of the tolerance; image tolerance {:.1}%",
        worst_sigmas,
        100.0 * worst_of_tolerance,
        100.0 * image_tolerance
    );
}

/// Light tracing estimates the path tracer's image of the diffuse room: the whole image and each block within
/// 4.5σ, with no allowance for bias (both are unbiased estimators of the same image). The whole image's tolerance
/// is asserted below 3%, so a light tracer off by π, a missing cosine, a wrong importance normalisation or a lost
/// bounce fails.
#[test]
fn lightpath_agrees_with_path_on_a_diffuse_room() {
    agrees_with_path(&room(Extras::default()), &lightpath(4), 128, 128, 0.0, 0.03);
}

/// Without media, volumetric path tracing is path tracing with the balance heuristic in place of the power
/// heuristic: it estimates the same image (same tolerances as light tracing), with delta lights, a rough metal and
/// a thin lens as well.
#[test]
fn volpath_agrees_with_path_without_media() {
    agrees_with_path(&room(Extras::default()), &volpath(4), 128, 128, 0.0, 0.03);
    let extras = Extras { delta_lights: true, rough_gold: true, thin_lens: true, ..Extras::default() };
    agrees_with_path(&room(extras), &volpath(4), 128, 128, 0.0, 0.03);
}

/// Splitting a path into its carried wavelengths at a dispersive refraction (the default, in `path` and `volpath`)
/// and keeping one of them at random estimate the same image: the room with an N-SF11 glass sphere, in X, Y and Z (the ends of the
/// spectrum, where the sphere's index differs most from its mean, show in X and Z), with no allowance for bias.
#[test]
fn path_splitting_at_dispersive_refraction_agrees_with_keeping_one_wavelength() {
    let scene = room(Extras { glass: true, ..Extras::default() });
    let keep_one = Integrator::Path(PathIntegrator {
        max_depth: 4,
        split_dispersion: false,
        manifold_nee: false,
        regularize: false,
    });
    agrees_with_in(&[0, 1, 2], &scene, &keep_one, &path(4), 512, 128, 0.0, 0.03);
    agrees_with_in(&[0, 1, 2], &scene, &keep_one, &volpath(4), 512, 128, 0.0, 0.03);
}

/// The path tracer with manifold next-event estimation.
fn path_mnee(max_depth: u32) -> Integrator {
    Integrator::Path(PathIntegrator { max_depth, split_dispersion: true, manifold_nee: true, regularize: false })
}

/// Manifold NEE through the dispersive glass sphere estimates the path tracer's image of a small lamp focused on
/// the floor, in X, Y and Z, with no allowance for bias: it counts the chains it solves (per wavelength) and the
/// path tracer drops exactly those, so the two are the same estimator in expectation. Power: at equal samples,
/// the block of the image with the caustic has a clearly smaller standard error (1.9x measured) with it (the chains the
/// path tracer found only by hitting the lamp through the glass come from light sampling now).
#[test]
fn manifold_nee_agrees_with_path_on_a_caustic_and_reduces_its_noise() {
    let scene = room(Extras { glass: true, small_light: true, ..Extras::default() });
    agrees_with_in(&[0, 1, 2], &scene, &path(4), &path_mnee(4), 1024, 256, 0.0, 0.03);
    let (pa, pb) = (render(&scene, &path(4), 0..256, 5), render(&scene, &path(4), 0..256, 6));
    let (ma, mb) = (render(&scene, &path_mnee(4), 0..256, 5), render(&scene, &path_mnee(4), 0..256, 6));
    let mut best = 0.0f64;
    for by in 0..HEIGHT / BLOCK {
        for bx in 0..WIDTH / BLOCK {
            let (xs, ys) = (bx * BLOCK..(bx + 1) * BLOCK, by * BLOCK..(by + 1) * BLOCK);
            let (_, sp) = block_y(&pa, &pb, xs.clone(), ys.clone());
            let (_, sm) = block_y(&ma, &mb, xs, ys);
            best = best.max(sp / sm);
        }
    }
    eprintln!("largest reduction of a block's standard error: {best:.1}x");
    assert!(best > 1.5, "manifold NEE reduces no block's noise by 1.5x (best {best:.2}x)");
}

/// The largest relative difference in mean Y between the same block of two images.
fn largest_block_change(a: &Film, b: &Film) -> f64 {
    let mut largest = 0.0f64;
    for by in 0..HEIGHT / BLOCK {
        for bx in 0..WIDTH / BLOCK {
            let (xs, ys) = (bx * BLOCK..(bx + 1) * BLOCK, by * BLOCK..(by + 1) * BLOCK);
            let (ya, _) = block_y(a, a, xs.clone(), ys.clone());
            let (yb, _) = block_y(b, b, xs, ys);
            largest = largest.max((ya - yb).abs() / yb);
        }
    }
    largest
}

/// In the room with a ball of chromatic fog, light tracing (particles scattered in the fog and connected to the
/// camera through it) estimates the volumetric path tracer's image (same tolerances as without fog). The fog is
/// asserted to change some block by more than 20%, so the comparison is not the one without media again.
#[test]
fn lightpath_agrees_with_volpath_in_fog() {
    let fog = room(Extras { fog: true, ..Extras::default() });
    agrees_with(&fog, &volpath(4), &lightpath(4), 256, 256, 0.0, 0.03);
    let (with, without) =
        (render(&fog, &volpath(4), 0..64, 1), render(&room(Extras::default()), &volpath(4), 0..64, 1));
    let largest_change = largest_block_change(&with, &without);
    eprintln!("the fog changes a block by up to {:.0}%", 100.0 * largest_change);
    assert!(largest_change > 0.2, "the fog changes no block by more than {largest_change}");
}

/// The light inside the fog, the camera outside: light tracing still estimates the volumetric path tracer's image
/// (light paths start in the light's medium; started in the camera's, they would miss the glow around the light).
#[test]
fn lightpath_agrees_with_volpath_with_the_light_in_fog() {
    let fog = room(Extras { fog_around_light: true, ..Extras::default() });
    agrees_with(&fog, &volpath(4), &lightpath(4), 512, 256, 0.0, 0.03);
}

/// Bidirectional path tracing estimates the path tracer's image of the diffuse room (same tolerances as light
/// tracing): its MIS weights over all connection strategies must sum to one.
#[test]
fn bdpt_agrees_with_path_on_a_diffuse_room() {
    agrees_with_path(&room(Extras::default()), &bdpt(4), 128, 32, 0.0, 0.03);
}

/// In the room with a ball of chromatic fog, bidirectional path tracing (both subpaths scattering in the fog, every
/// connection through it with its transmittance) estimates the volumetric path tracer's image (same tolerances as
/// without fog): its MIS weights over strategies that end or join at medium vertices must sum to one, and its
/// spectral MIS over the two subpaths and the shadow ray must stay unbiased at every wavelength. Not a vacuous pass:
/// the same bdpt on the room without the fog (what an integrator that ignores media renders) differs from its fog
/// image by more than 20% in some block.
#[test]
fn bdpt_agrees_with_volpath_in_fog() {
    let fog = room(Extras { fog: true, ..Extras::default() });
    agrees_with_in(&[0, 1, 2], &fog, &volpath(4), &bdpt(4), 256, 64, 0.0, 0.03);
    let (with, without) = (render(&fog, &bdpt(4), 0..16, 1), render(&room(Extras::default()), &bdpt(4), 0..16, 1));
    let largest_change = largest_block_change(&with, &without);
    eprintln!("the fog changes a bdpt block by up to {:.0}%", 100.0 * largest_change);
    assert!(largest_change > 0.2, "the fog changes no bdpt block by more than {largest_change}");
}

/// With motion blur (a moving sphere and a moving, turning camera), light tracing still estimates the path
/// tracer's image: each light path has one time, uniform over the shutter, at which it is traced and connected to
/// the lens where the camera is then. Not vacuous: the motion changes some block by more than 5%.
#[test]
fn lightpath_agrees_with_path_with_motion_blur() {
    let moving = room(Extras { motion: true, ..Extras::default() });
    agrees_with_path(&moving, &lightpath(4), 128, 128, 0.0, 0.03);
    let (with, without) = (render(&moving, &path(4), 0..16, 1), render(&room(Extras::default()), &path(4), 0..16, 1));
    let largest_change = largest_block_change(&with, &without);
    eprintln!("motion changes a block by up to {:.0}%", 100.0 * largest_change);
    assert!(largest_change > 0.05, "motion changes no block by more than {largest_change}");
}

/// With motion blur, bidirectional path tracing estimates the path tracer's image: both subpaths and every
/// connection are traced at the camera ray's time, with the camera where it is then.
#[test]
fn bdpt_agrees_with_path_with_motion_blur() {
    let moving = room(Extras { motion: true, delta_lights: true, ..Extras::default() });
    agrees_with_path(&moving, &bdpt(4), 128, 32, 0.0, 0.03);
}

/// The room with a point light and a spot light besides the area light, a rough gold sphere and a thin-lens
/// camera: BDPT's weights for the strategies that cannot hit a delta light or reach the lens must leave its image
/// equal to the path tracer's (same tolerances as light tracing; more samples, so that an error of 1–2% in how the
/// delta lights' paths are weighted is resolved). The delta lights are asserted to add more than 20% to the image.
#[test]
fn bdpt_agrees_with_path_with_delta_lights_a_rough_metal_and_a_thin_lens() {
    let extras = Extras { delta_lights: true, rough_gold: true, thin_lens: true, ..Extras::default() };
    agrees_with_path(&room(extras), &bdpt(4), 256, 128, 0.0, 0.03);
    // Not a vacuous pass: the delta lights light a good part of the image.
    let without = room(Extras { delta_lights: false, ..extras });
    let (with, without) = (render(&room(extras), &path(4), 0..16, 1), render(&without, &path(4), 0..16, 1));
    let (y_with, _) = block_y(&with, &with, 0..WIDTH, 0..HEIGHT);
    let (y_without, _) = block_y(&without, &without, 0..WIDTH, 0..HEIGHT);
    eprintln!("image Y with the delta lights {y_with:.5}, without {y_without:.5}");
    assert!(y_with > 1.2 * y_without, "the delta lights add only {y_with} − {y_without}");
}

/// Photon mapping converges to the path tracer's image of the diffuse room: the whole image and each block within
/// 4.5σ plus 2% for the density estimate's bias (the gather disc blurs the illumination and, in the room's
/// corners and around the sphere, gathers photons that landed on the other surface; the radius shrinks from 0.15
/// over 64 iterations) and for the photons shared by neighbouring pixels, which the noise estimate ignores. The
/// whole image's tolerance is asserted below 5%.
#[test]
fn sppm_agrees_with_path_on_a_diffuse_room() {
    agrees_with_path(&room(Extras::default()), &sppm(4), 128, 64, 0.02, 0.05);
}

/// In the room with a ball of chromatic fog, photon mapping (camera paths that stop at their first scattering event
/// in the fog as well as on surfaces, photons stored at scattering events in the fog and gathered in a sphere)
/// converges to the volumetric path tracer's image, with the same allowance for the density estimate's bias as on
/// surfaces (4.5σ + 2%). The bias is larger in fog: a gather sphere that reaches out of the ball finds no photons
/// in its outer part (a third of the ball lies within the initial radius 0.15 of its surface), which darkens the
/// image by about 1% at 512 iterations (1.8σ); a smaller radius shrinks it (0.08: within 1.5σ everywhere, but noisier).
/// The whole image's allowance is 5.3% (at most 5.5%): hero wavelengths drawn from pbrt-v4's visible pdf sample the
/// fog's blue end less often than x̄ + ȳ + z̄ did, and one wavelength set per iteration makes that sppm's noise.
#[test]
fn sppm_agrees_with_volpath_in_fog() {
    let fog = room(Extras { fog: true, ..Extras::default() });
    agrees_with(&fog, &volpath(4), &sppm(4), 512, 512, 0.02, 0.055);
}

// ------------------------------------------------------------------------------------------------------------------
// Determinism
// ------------------------------------------------------------------------------------------------------------------

/// The five integrators, each with maximum depth 5.
fn all_integrators() -> [Integrator; 5] {
    [path(5), volpath(5), lightpath(5), bdpt(5), sppm(5)]
}

/// The room with every extra (delta lights, rough gold, thin lens, and a dispersive glass sphere whose refraction
/// keeps one wavelength): every kind of path and splat the integrators have.
fn determinism_room() -> RenderScene {
    room(Extras {
        delta_lights: true,
        rough_gold: true,
        thin_lens: true,
        glass: true,
        fog: true,
        fog_around_light: false,
        small_light: false,
        motion: false,
    })
}

/// Asserts that two films hold the same colours, weights and spectral buckets: bit-identical when `rel` is 0,
/// otherwise within `rel` relative (for sums of the same terms added in another order). Also asserts that the
/// image is not vacuous (a black film is trivially deterministic): most pixels are lit.
fn assert_same(a: &Film, b: &Film, rel: f64, what: &str) {
    let same = |p: f64, q: f64| if rel == 0.0 { p.to_bits() == q.to_bits() } else { (p - q).abs() <= rel * p.abs() };
    let mut lit = 0;
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let (ca, cb) = (a.pixel_xyz(x, y).to_array(), b.pixel_xyz(x, y).to_array());
            assert!((0..3).all(|c| same(ca[c], cb[c])), "{what}: pixel ({x}, {y}): {ca:?} vs {cb:?}");
            assert_eq!(a.pixel_weight(x, y).to_bits(), b.pixel_weight(x, y).to_bits(), "{what}: weight ({x}, {y})");
            let (sa, sb) = (a.pixel_spectrum(x, y), b.pixel_spectrum(x, y));
            assert!(sa.iter().zip(&sb).all(|(p, q)| same(*p, *q)), "{what}: buckets of ({x}, {y})");
            if ca[1] > 0.0 {
                lit += 1;
            }
        }
    }
    assert!(lit > WIDTH * HEIGHT / 2, "{what}: only {lit} pixels are lit");
}

/// A spectral film (16 buckets) with pbrt-v4's default gaussian filter (radius 1.5, σ 0.5), whose splats spread
/// over several pixels: the most that can go wrong in the order of additions.
fn determinism_film() -> Film {
    let mut spec = FilmSpec::new(WIDTH, HEIGHT, "determinism.exr");
    spec.kind = FilmKind::spectral_default();
    spec.filter = Filter::gaussian([1.5, 1.5], 0.5).unwrap();
    Film::new(spec).unwrap()
}

/// Renders passes `0..passes` of `integrator` on a [`determinism_film`], in a rayon pool of `threads` threads.
fn render_with_threads(scene: &RenderScene, integrator: &Integrator, passes: u32, seed: u32, threads: usize) -> Film {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    pool.install(|| {
        let mut film = determinism_film();
        integrator.render(scene, &mut film, 0..passes, seed, &|_| {}).unwrap();
        film
    })
}

/// Every random number depends only on (pixel or light path, sample index, seed), and light-path splats and
/// photons are added in a fixed order: for each integrator, pools of one and two threads give bit-identical films
/// (colour, weights and spectral buckets). Another seed changes most pixels, so the images are not trivially
/// equal.
#[test]
fn images_do_not_depend_on_the_thread_count() {
    let scene = determinism_room();
    for integrator in all_integrators() {
        let name = integrator.name();
        let one = render_with_threads(&scene, &integrator, 8, 9, 1);
        let two = render_with_threads(&scene, &integrator, 8, 9, 2);
        assert_same(&one, &two, 0.0, name);
        let other_seed = render_with_threads(&scene, &integrator, 8, 10, 2);
        let changed = (0..HEIGHT)
            .flat_map(|y| (0..WIDTH).map(move |x| (x, y)))
            .filter(|&(x, y)| one.pixel_xyz(x, y).to_array() != other_seed.pixel_xyz(x, y).to_array())
            .count() as u32;
        assert!(changed > WIDTH * HEIGHT / 2, "{name}: only {changed} pixels change with the seed");
    }
}

/// With motion blur (each camera ray and light path drawing its time from its own sampler), pools of one and two
/// threads still give bit-identical films for every integrator.
#[test]
fn motion_blurred_images_do_not_depend_on_the_thread_count() {
    let scene = room(Extras { motion: true, thin_lens: true, delta_lights: true, fog: true, ..Extras::default() });
    for integrator in all_integrators() {
        let name = integrator.name();
        let one = render_with_threads(&scene, &integrator, 8, 9, 1);
        let two = render_with_threads(&scene, &integrator, 8, 9, 2);
        assert_same(&one, &two, 0.0, name);
    }
}

/// Manifold NEE's solves take their numbers from the sampler only: pools of one and two threads give bit-identical
/// films on the room with the dispersive glass sphere and point and spot lights (whose caustics only manifold NEE
/// renders), and the image is not the plain path tracer's.
#[test]
fn manifold_nee_images_do_not_depend_on_the_thread_count() {
    let scene = room(Extras { glass: true, delta_lights: true, ..Extras::default() });
    let one = render_with_threads(&scene, &path_mnee(5), 8, 9, 1);
    let two = render_with_threads(&scene, &path_mnee(5), 8, 9, 2);
    assert_same(&one, &two, 0.0, "path with manifold NEE");
    let plain = render_with_threads(&scene, &path(5), 8, 9, 2);
    let changed = (0..HEIGHT)
        .flat_map(|y| (0..WIDTH).map(move |x| (x, y)))
        .filter(|&(x, y)| one.pixel_xyz(x, y).to_array() != plain.pixel_xyz(x, y).to_array())
        .count();
    assert!(changed > 10, "manifold NEE changed only {changed} pixels");
}

/// A render job continues where it stopped: passes `0..4` then `4..8` in one job give bit-identical films to
/// `0..8` in one run (each pass's random numbers come from its index; photon mapping keeps its progressive
/// statistics and radii in the job and writes them into the film at the end). Two runs of 4 passes are not 8
/// passes by accident: the film after `0..4` alone differs.
#[test]
fn a_render_split_into_two_runs_equals_one_run() {
    let scene = determinism_room();
    for integrator in all_integrators() {
        let name = integrator.name();
        let mut whole = determinism_film();
        integrator.render(&scene, &mut whole, 0..8, 5, &|_| {}).unwrap();
        let mut split = determinism_film();
        let mut job: Box<dyn RenderJob + '_> = integrator.begin(&scene, &split, 5).unwrap();
        job.run(&mut split, 0..4, &|_| {});
        job.run(&mut split, 4..8, &|_| {});
        job.finish(&mut split);
        // Every integrator adds a pixel's samples and splats in the order (pass, row, column) whatever the runs, so
        // the split render is exactly the whole one.
        let rel = 0.0;
        assert_same(&whole, &split, rel, name);
        let mut half = determinism_film();
        integrator.render(&scene, &mut half, 0..4, 5, &|_| {}).unwrap();
        assert!(
            (0..WIDTH).any(|x| half.pixel_xyz(x, HEIGHT / 2).to_array() != whole.pixel_xyz(x, HEIGHT / 2).to_array()),
            "{name}: 4 passes give the image of 8"
        );
    }
}

/// A film like [`determinism_film`], RGB or spectral, holding only rows `rows` (all of them for `None`).
fn film_of(spectral: bool, rows: Option<Range<u32>>) -> Film {
    let mut spec = FilmSpec::new(WIDTH, HEIGHT, "determinism.exr");
    if spectral {
        spec.kind = FilmKind::spectral_default();
    }
    spec.filter = Filter::gaussian([1.5, 1.5], 0.5).unwrap();
    spec.pixel_bounds = rows.map(|r| film::PixelBounds { x0: 0, x1: WIDTH, y0: r.start, y1: r.end });
    Film::new(spec).unwrap()
}

/// A checkpoint holds the film's accumulators and the job's own state: a job stopped after passes `0..3`, whose
/// film and state are put into a fresh film and a fresh job (as a new process does when it resumes), then run on
/// `3..8`, gives bit for bit the film of `0..8` in one run, for every integrator (splats and photon mapping's
/// statistics included), RGB and spectral films. A state of the wrong shape is an error.
#[test]
fn a_render_resumed_from_its_saved_state_equals_one_run() {
    let scene = determinism_room();
    for spectral in [false, true] {
        for integrator in all_integrators() {
            let name = format!("{} ({})", integrator.name(), if spectral { "spectral" } else { "rgb" });
            let mut whole = film_of(spectral, None);
            integrator.render(&scene, &mut whole, 0..8, 5, &|_| {}).unwrap();
            let (film_state, job_state) = {
                let mut film = film_of(spectral, None);
                let mut job = integrator.begin(&scene, &film, 5).unwrap();
                job.run(&mut film, 0..3, &|_| {});
                (film.state(), job.save_state())
            };
            assert_eq!(job_state.is_empty(), !matches!(integrator, Integrator::Sppm(_)), "{name}");
            let mut resumed = film_of(spectral, None);
            resumed.paste(&film_state).unwrap();
            let mut job = integrator.begin(&scene, &resumed, 5).unwrap();
            if let Some((_, shorter)) = job_state.split_last() {
                assert!(job.restore_state(shorter).is_err(), "{name}");
            }
            assert!(job.restore_state(&[1, 2, 3]).is_err(), "{name}");
            job.restore_state(&job_state).unwrap();
            job.run(&mut resumed, 3..8, &|_| {});
            job.finish(&mut resumed);
            assert_same(&whole, &resumed, 0.0, &name);
        }
    }
}

/// Shards of a render: contiguous sample ranges rendered apart and their films' sums added in pass order equal
/// the film of all samples to the rounding of the additions (each sum regrouped: at most 2·n·2⁻⁵³ of the sum of
/// the terms' magnitudes, n = 8 passes, so 1e-14 relative for these sums of positive terms); photon mapping, whose
/// radii shrink with the iterations, renders tiles of rows with all iterations and the whole image's photon count
/// instead, and its tiles pasted together equal the whole image bit for bit.
#[test]
fn shards_add_up_to_the_whole_render() {
    let scene = determinism_room();
    let ranges = [0..3, 3..5, 5..8];
    for spectral in [false, true] {
        for integrator in all_integrators() {
            let name = format!("{} ({})", integrator.name(), if spectral { "spectral" } else { "rgb" });
            let mut whole = film_of(spectral, None);
            integrator.render(&scene, &mut whole, 0..8, 5, &|_| {}).unwrap();
            let mut merged = film_of(spectral, None);
            if let Integrator::Sppm(s) = integrator {
                let photons = Some(WIDTH as u64 * HEIGHT as u64);
                let tiled = Integrator::Sppm(SppmIntegrator { photons_per_iteration: photons, ..s });
                for rows in [0..5, 5..6, 6..HEIGHT] {
                    let mut tile = film_of(spectral, Some(rows));
                    tiled.render(&scene, &mut tile, 0..8, 5, &|_| {}).unwrap();
                    merged.paste(&tile.state()).unwrap();
                }
                assert_same(&whole, &merged, 0.0, &name);
                continue;
            }
            for (k, r) in ranges.iter().enumerate() {
                let mut part = film_of(spectral, None);
                integrator.render(&scene, &mut part, r.clone(), 5, &|_| {}).unwrap();
                if k == 0 {
                    merged.paste(&part.state()).unwrap();
                } else {
                    merged.add_state(&part.state()).unwrap();
                }
            }
            assert_same(&whole, &merged, 1e-14, &name);
        }
    }
}

//! Furnace tests: closed-form answers for objects inside a uniform environment.
//!
//! A convex object inside a uniform environment of radiance L: a diffuse sphere of albedo ρ looks exactly ρ·L
//! (every point sees only the environment), and a non-absorbing smooth glass sphere looks exactly L (it neither
//! absorbs nor emits; every path eventually leaves). A sphere that reflects R and transmits T diffusely looks
//! L·(R + T²/(1 − R)). Renders use a pinhole camera at a few hundred samples.

use crate::camera::{Camera, Projection, ScreenWindow};
use crate::integrator::{
    BdptIntegrator, Integrator, LightPathIntegrator, PathIntegrator, SppmIntegrator, VolPathIntegrator,
};
use crate::light::Light;
use crate::material::{DielectricIor, Material, Roughness};
use crate::scene::{Geometry, RenderScene, SurfaceHit};
use crate::texture::SpectrumTexture;
use film::{Film, FilmSpec, Filter};
use geometry::Transform;
use glam::{DVec3, Vec2, Vec3};
use spectral::{Spectrum, WavelengthStrategy};

/// One sphere at the origin.
struct OneSphere {
    radius: f32,
}

impl OneSphere {
    fn hit_t(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<f32> {
        let b = o.dot(d);
        let c = o.length_squared() - self.radius * self.radius;
        let disc = b * b - c;
        if disc < 0.0 {
            return None;
        }
        let s = disc.sqrt();
        [-b - s, -b + s].into_iter().find(|&t| t > 1e-4 && t < t_max)
    }
}

impl Geometry for OneSphere {
    fn intersect(&self, o: Vec3, d: Vec3, t_max: f32, time: f32) -> Option<SurfaceHit> {
        let t = self.hit_t(o, d, t_max)?;
        let p = o + d * t;
        let n = p.normalize();
        Some(SurfaceHit {
            t,
            p,
            n,
            ns: n,
            uv: Vec2::ZERO,
            dpdu: n.cross(Vec3::Z).try_normalize().unwrap_or(Vec3::X),
            surface_dpdu: n.cross(Vec3::Z).try_normalize().unwrap_or(Vec3::X),
            surface_dpdv: n.cross(n.cross(Vec3::Z)).try_normalize().unwrap_or(Vec3::Y),
            shading_dpdu: n.cross(Vec3::Z).try_normalize().unwrap_or(Vec3::X),
            shading_dpdv: n.cross(n.cross(Vec3::Z)).try_normalize().unwrap_or(Vec3::Y),
            p_error: Vec3::splat(1e-5),
            material: 0,
            area_light: None,
            media: None,
            time,
            vertex_color: None,
        })
    }
    fn occluded(&self, o: Vec3, d: Vec3, t_max: f32, _time: f32) -> bool {
        self.hit_t(o, d, t_max).is_some()
    }
    fn bounding_sphere(&self) -> (Vec3, f32) {
        (Vec3::ZERO, self.radius)
    }
}

fn scene(material: Material) -> RenderScene {
    let cam = Transform::look_at(DVec3::new(0.0, 0.0, -5.0), DVec3::ZERO, DVec3::Y).unwrap();
    let camera = Camera::new(
        Projection::Perspective { tan_half_fov: (10f32.to_radians()).tan() },
        &cam,
        (8, 8),
        ScreenWindow::for_aspect(1.0),
        0.0,
        1.0,
    );
    RenderScene::new(
        std::sync::Arc::new(OneSphere { radius: 1.0 }),
        vec![material],
        vec![Light::UniformInfinite { l: Spectrum::Constant(1.0), scene_radius: 1.0 }],
        vec![],
        None,
        camera,
    )
}

/// Mean Y over the central 4×4 pixels (all on the sphere) and its standard error across pixels.
fn mean_y(scene: &RenderScene, strategy: WavelengthStrategy, spp: u32, max_depth: u32) -> (f64, f64) {
    mean_y_with(
        scene,
        &Integrator::Path(PathIntegrator { max_depth, split_dispersion: true, manifold_nee: false, regularize: false }),
        strategy,
        spp,
    )
}

/// [`mean_y`] with any integrator (`passes` samples per pixel, or photon-mapping iterations).
fn mean_y_with(scene: &RenderScene, integrator: &Integrator, strategy: WavelengthStrategy, passes: u32) -> (f64, f64) {
    let mut spec = FilmSpec::new(8, 8, "furnace.exr");
    spec.filter = Filter::new_box([0.5, 0.5]).unwrap();
    spec.wavelengths = strategy;
    let mut film = Film::new(spec).unwrap();
    integrator.render(scene, &mut film, 0..passes, 1, &|_| {}).unwrap();
    let mut values = vec![];
    for y in 2..6 {
        for x in 2..6 {
            values.push(film.pixel_xyz(x, y).y);
        }
    }
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

#[test]
fn diffuse_sphere_in_a_furnace_reflects_albedo_times_l() {
    for rho in [0.25, 0.8] {
        let s = scene(Material::Diffuse { reflectance: SpectrumTexture::Constant(Spectrum::Constant(rho)) });
        for strategy in WavelengthStrategy::ALL {
            let (y, se) = mean_y(&s, strategy, 256, 5);
            // Exact answer ρ·L with L = 1; tolerance: 4 standard errors plus 0.5% for the cmf route's 1931 fit.
            let tol = 4.0 * se + 0.005;
            assert!((y - rho).abs() < tol, "{strategy}: ρ = {rho}: Y = {y} ± {se}");
        }
    }
}

#[test]
fn glass_spheres_in_a_furnace_are_invisible() {
    let glasses = [
        DielectricIor::Model(optics::Ior::constant(1.5).unwrap()),
        DielectricIor::Model(optics::catalogue::lookup("N-SF11").unwrap().ior),
    ];
    for ior in glasses {
        let s = scene(Material::Dielectric {
            ior,
            roughness: Roughness::smooth(),
            coating: Default::default(),
            tint: None,
        });
        for strategy in WavelengthStrategy::ALL {
            let (y, se) = mean_y(&s, strategy, 256, 64);
            assert!((y - 1.0).abs() < 4.0 * se + 0.01, "{strategy}: Y = {y} ± {se}");
        }
    }
}

/// Glass under a lossless anti-reflection stack (three layers) is still invisible in the furnace: the coating moves
/// light between reflection and refraction per wavelength but neither absorbs nor emits. Through the constant
/// index (all wavelengths carried through both events) and through N-SF11 (dispersive: refraction keeps one).
/// Fails if a coated interface's reflected or transmitted weight is not the stack's R or T over its probability.
#[test]
fn coated_glass_spheres_in_a_furnace_are_invisible() {
    use crate::coating::{Coating, CoatingLayer, LayerIndex};
    use crate::texture::FloatTexture;
    let layer = |n: f64, d: f32| CoatingLayer {
        index: LayerIndex::Spectrum(Spectrum::Constant(n)),
        thickness: FloatTexture::Constant(d),
    };
    let coating = Coating { layers: vec![layer(1.38, 99.6), layer(2.1, 130.0), layer(1.65, 283.0)] };
    let glasses = [
        DielectricIor::Model(optics::Ior::constant(1.5).unwrap()),
        DielectricIor::Model(optics::catalogue::lookup("N-SF11").unwrap().ior),
    ];
    for ior in glasses {
        let s =
            scene(Material::Dielectric { ior, roughness: Roughness::smooth(), coating: coating.clone(), tint: None });
        for strategy in WavelengthStrategy::ALL {
            let (y, se) = mean_y(&s, strategy, 256, 64);
            assert!((y - 1.0).abs() < 4.0 * se + 0.01, "{strategy}: Y = {y} ± {se}");
        }
    }
}

/// The diffuse sphere in the furnace through the integrators that start paths at the lights: the uniform
/// environment emits light paths from a disc on the scene's bounding sphere, so light tracing and BDPT must see the
/// same ρ·L as the path tracer. Light tracing reaches these pixels only through its splats and BDPT weighs all its
/// strategies; an error in the environment's emission pdf or area (π r² of the disc), in the splats'
/// normalisation or in a strategy's weight moves the answer by more than the tolerance: 4 standard errors across
/// the 16 pixels (asserted below 2% of ρ) plus 0.5% of ρ for the colour conversion.
#[test]
fn light_and_bidirectional_tracing_in_a_furnace_reflect_albedo_times_l() {
    for rho in [0.25, 0.8] {
        let s = scene(Material::Diffuse { reflectance: SpectrumTexture::Constant(Spectrum::Constant(rho)) });
        for (integrator, passes) in [
            (Integrator::LightPath(LightPathIntegrator { max_depth: 5 }), 4096),
            (Integrator::Bdpt(BdptIntegrator { max_depth: 5, regularize: false }), 64),
        ] {
            furnace_check(&s, &integrator, passes, rho, 0.0);
        }
    }
}

/// Photon mapping in the furnace: ρ·L within 4 standard errors plus 0.5% of ρ plus 2% of ρ for the gather disc's bias on
/// the curved surface.
///
/// This caught a bias (Y ≈ 0.18·ρ): photon mapping's visible points weighted their next-event estimation by the
/// power heuristic against BSDF sampling, but nothing added the BSDF-sampled share of direct light (photons are
/// gathered from their second bounce on). With a small area light the weight is close to 1 and the loss was
/// invisible; under an environment most of the direct light was lost.
#[test]
fn photon_mapping_in_a_furnace_reflects_albedo_times_l() {
    let sppm = SppmIntegrator { max_depth: 5, photons_per_iteration: Some(4096), initial_radius: 0.05, iterations: 64 };
    for rho in [0.25, 0.8] {
        let s = scene(Material::Diffuse { reflectance: SpectrumTexture::Constant(Spectrum::Constant(rho)) });
        furnace_check(&s, &Integrator::Sppm(sppm), 64, rho, 0.02);
    }
}

/// A sphere of `diffusetransmission` in the furnace, through every integrator. Inside, the radiance is uniform by
/// symmetry: L_in = T·L + R·L_in, so L_in = T·L/(1 − R), and outside the sphere looks L_out = R·L + T·L_in =
/// L·(R + T²/(1 − R)); 16 bounces leave out less than 1e-8 of it. A transmitted path that kept to the side it came
/// from, or an integrator that dropped transmission at some vertex (a light path's, a connection's, a photon's),
/// would see R·L = 0.3 instead of 0.657.
#[test]
fn diffuse_transmission_sphere_in_a_furnace_looks_r_plus_t_squared_over_one_minus_r() {
    let (r, t) = (0.3, 0.5);
    let m = Material::DiffuseTransmission {
        reflectance: SpectrumTexture::Constant(Spectrum::Constant(r)),
        transmittance: SpectrumTexture::Constant(Spectrum::Constant(t)),
        scale: 1.0,
    };
    let expected = r + t * t / (1.0 - r);
    let s = scene(m);
    let max_depth = 16;
    // Photons matter here (the light transmitted into the sphere reaches the visible points only through them), and
    // with few photons per gather disc SPPM's radius update leaves a bias of a few per cent after 256 iterations:
    // 16384 photons per iteration bring it within the 2% allowed for photon mapping above.
    let sppm = SppmIntegrator { max_depth, photons_per_iteration: Some(16384), initial_radius: 0.05, iterations: 64 };
    for (integrator, passes, bias) in [
        (
            Integrator::Path(PathIntegrator {
                max_depth,
                split_dispersion: true,
                manifold_nee: false,
                regularize: false,
            }),
            256,
            0.0,
        ),
        (
            Integrator::VolPath(VolPathIntegrator {
                max_depth,
                split_dispersion: true,
                regularize: false,
                sun_guide: 0.5,
                forced_collisions: None,
            }),
            256,
            0.0,
        ),
        (Integrator::LightPath(LightPathIntegrator { max_depth }), 4096, 0.0),
        (Integrator::Bdpt(BdptIntegrator { max_depth, regularize: false }), 256, 0.0),
        (Integrator::Sppm(sppm), 256, 0.02),
    ] {
        furnace_check(&s, &integrator, passes, expected, bias);
    }
}

/// Renders the furnace with `integrator` and checks Y = ρ within 4 standard errors (asserted below 2% of ρ, so the
/// check resolves a few per cent) plus 0.5% of ρ for the colour conversion plus `bias`·ρ.
fn furnace_check(s: &RenderScene, integrator: &Integrator, passes: u32, rho: f64, bias: f64) {
    let (y, se) = mean_y_with(s, integrator, WavelengthStrategy::Hero, passes);
    let name = integrator.name();
    eprintln!("{name}: ρ = {rho}: Y = {y:.5} ± {se:.5}, |Δ| = {:.2} SE", (y - rho).abs() / se);
    assert!(se < 0.02 * rho, "{name}: ρ = {rho}: standard error {se} too large to resolve a few per cent");
    assert!((y - rho).abs() < 4.0 * se + (0.005 + bias) * rho, "{name}: ρ = {rho}: Y = {y} ± {se}");
}

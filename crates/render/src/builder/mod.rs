//! From a scene description to a render-ready scene. [`build_scene`] reads the directives family by family, each
//! in its own file: the film (with its filter and sensor), the camera, textures, materials (`subsurface` in a file
//! of its own), media, shapes (into the two-level BVH, with their area lights) and lights (with pbrt-v4's
//! photometric normalisation). The sampler's `pixelsamples` is read here; the `Integrator` directive by
//! [`Integrator::read`], next to the integrators.
//!
//! The family files depend only on `context` (what they share: the named textures, materials and media with their
//! lookups, the error helpers, emission and the measured media), never on each other: this file calls them in
//! order and hands each what the earlier ones made, the functions of one family that another calls included.

use std::collections::HashMap;
use std::sync::Arc;

use ::film::FilmSpec;
use scene::SceneDescription;

use crate::integrator::{Integrator, IntegratorParams};
use crate::light::Light;
use crate::scene::{Geometry, LightMedium, RenderScene};

mod camera;
mod context;
mod film;
mod lights;
mod materials;
mod media;
mod shapes;
mod subsurface;
mod textures;

pub use context::BuildOptions;
use context::{err, unsupported, Result};

/// A scene ready to render, with the settings the scene file chose.
pub struct BuiltScene {
    /// The scene.
    pub scene: RenderScene,
    /// The film to render into.
    pub film: FilmSpec,
    /// Samples per pixel.
    pub spp: u32,
    /// The integrator.
    pub integrator: Integrator,
    /// Triangles in the scene (instances counted once).
    pub triangles: usize,
    /// Warnings (unused parameters, ignored features), each with file, line and column.
    pub warnings: Vec<String>,
    /// The shapes as built (BVH and area lights), which [`build_scene_reusing`] takes over.
    shapes: Arc<SceneShapes>,
    /// Whether this build made `shapes` (false: taken from an earlier build).
    shapes_made: bool,
}

impl BuiltScene {
    /// Whether this build made its shapes (BVH, area lights) rather than taking them from an earlier build.
    pub fn built_shapes(&self) -> bool {
        self.shapes_made
    }
}

/// The shapes of a built scene: the BVH, the area lights made with it, and what the shapes were bound to (each
/// material's index as a shape sees it, the media's indices), which a later build must match to reuse them.
struct SceneShapes {
    geometry: Arc<dyn Geometry>,
    area_lights: Vec<Light>,
    area_light_media: Vec<LightMedium>,
    triangles: usize,
    scene_radius: f32,
    moving: bool,
    bindings: ShapeBindings,
}

/// What the BVH's per-shape records hold besides geometry: per material, whether it is an `interface` (a shape
/// records no material) and the medium inside it (`subsurface`); the index of each named material and medium.
#[derive(Debug, PartialEq)]
struct ShapeBindings {
    materials: Vec<(bool, Option<u32>)>,
    material_names: HashMap<String, u32>,
    media_names: HashMap<String, u32>,
}

/// pbrt-v4's sampler names. Each one maps to Prismatic's own sampler (Owen-scrambled Sobol points per pixel);
/// only the sample count is taken from the directive.
pub const SAMPLER_NAMES: [&str; 7] =
    ["zsobol", "halton", "sobol", "paddedsobol", "pmj02bn", "independent", "stratified"];

/// Samples per pixel of the `Sampler` directive: `pixelsamples` (default 16), or for `stratified` `xsamples` ×
/// `ysamples` (default 4 × 4; its `jitter` is read, since Prismatic's samples are always stratified and jittered).
/// An unknown sampler name is an error listing pbrt-v4's.
fn sampler_spp(desc: &SceneDescription) -> Result<u32> {
    let (p, loc) = (&desc.sampler.params, &desc.sampler.loc);
    if !SAMPLER_NAMES.contains(&desc.sampler.name.as_str()) {
        return err(loc, unsupported("sampler", &desc.sampler.name, &SAMPLER_NAMES));
    }
    if desc.sampler.name == "stratified" {
        let (x, y) = (p.get_count("xsamples", 4, loc)?, p.get_count("ysamples", 4, loc)?);
        p.get_bool("jitter", true)?;
        return match u32::try_from(x * y) {
            Ok(n) if n <= 1 << 24 => Ok(n),
            _ => err(loc, format!("'xsamples' × 'ysamples' = {} samples per pixel is too many", x * y)),
        };
    }
    Ok(p.get_count("pixelsamples", 16, loc)? as u32)
}

/// Builds the render-ready scene from a parsed description.
pub fn build_scene(desc: &SceneDescription, options: &BuildOptions) -> Result<BuiltScene> {
    build(desc, options, None)
}

/// [`build_scene`] for a description that differs from the one `previous` was built from only in its materials'
/// and media's parameters (the same names), its `LightSource` lights, camera, film, sampler or integrator, or
/// `options`: the BVH and the area lights of `previous` are taken over instead of built again (a study that
/// changes a glass, a medium or a light pays only for what changed). If a change reaches what the BVH records (a
/// material becomes or stops being an `interface` or a `subsurface`, or the names change) the shapes are built
/// again; [`BuiltScene::built_shapes`] says which happened. The shapes, textures and area lights of `desc` must be
/// those `previous` was built from: they are not compared (nor read again: their parameters count as used).
pub fn build_scene_reusing(
    desc: &SceneDescription,
    options: &BuildOptions,
    previous: &BuiltScene,
) -> Result<BuiltScene> {
    build(desc, options, Some(&previous.shapes))
}

fn build(desc: &SceneDescription, options: &BuildOptions, previous: Option<&Arc<SceneShapes>>) -> Result<BuiltScene> {
    if desc.color_space != "srgb" {
        return err(&desc.film.loc, format!("colour space '{}' is not supported (only srgb)", desc.color_space));
    }
    let mut warnings = vec![];
    let film = film::make_film(desc, options, &mut warnings)?;

    // Sampler and integrator.
    let scene_spp = sampler_spp(desc)?;
    let textures = textures::build(desc)?;
    let mut materials = materials::build(desc, &textures, subsurface::subsurface)?;
    let mut media = media::build(desc)?;
    // A `subsurface` material's shapes are filled with its medium.
    materials.attach_interiors(&mut media.list);
    let integrator = Integrator::read(&mut IntegratorParams {
        entity: &desc.integrator,
        media_scatter: media.any_scattering(),
        media_glow: media.any_emissive(),
        warnings: &mut warnings,
    })?;
    // Photon mapping renders `iterations` passes (pbrt-v4 ignores the sampler's pixel samples there).
    let spp = options.spp.unwrap_or(integrator.passes().unwrap_or(scene_spp));

    let camera = camera::make_camera(desc, (film.width, film.height), &mut warnings)?;
    if integrator.needs().camera_reachable_by_light && !camera.supports_light_tracing() {
        return err(
            &desc.camera.entity.loc,
            format!(
                "integrator \"{}\" needs a perspective camera: light paths cannot reach an orthographic camera \
                 (its rays are parallel) or a realistic one (as in pbrt-v4, the lens is not traced from the scene \
                 side); use \"path\" or \"volpath\"",
                integrator.name()
            ),
        );
    }

    let camera_medium = media.of(&desc.camera.medium, &desc.camera.entity.loc)?;
    // Area lights are made with their shapes, so they come before the `LightSource` lights.
    let bindings = ShapeBindings {
        materials: (0..materials.list.len() as u32)
            .map(|i| {
                (matches!(materials.list[i as usize], crate::material::Material::Interface), materials.interior(i))
            })
            .collect(),
        material_names: materials.names().clone(),
        media_names: media.names().clone(),
    };
    let (shapes, shapes_made) = match previous.filter(|p| p.bindings == bindings) {
        Some(p) => {
            // The shapes' parameters were read by the build that made them; a description parsed anew must not
            // report them unused.
            let world = desc.shapes.iter().chain(desc.objects.iter().flat_map(|o| o.shapes.iter()));
            for se in world {
                let area = se.area_light.iter().flat_map(|a| a.params.iter());
                se.entity.params.iter().chain(area).for_each(|param| param.mark_used());
            }
            (p.clone(), false)
        }
        None => {
            let (mut area_lights, mut area_light_media) = (vec![], vec![]);
            let built = shapes::make_geometry(
                desc,
                &textures,
                &materials,
                &media,
                lights::area_lights,
                &mut area_lights,
                &mut area_light_media,
            )?;
            let shapes = SceneShapes {
                geometry: Arc::new(built.geometry),
                area_lights,
                area_light_media,
                triangles: built.triangles,
                scene_radius: built.scene_radius,
                moving: built.moving,
                bindings,
            };
            (Arc::new(shapes), true)
        }
    };
    let (mut lights, mut light_media) = (shapes.area_lights.clone(), shapes.area_light_media.clone());
    lights::make_lights(desc, shapes.scene_radius, &mut lights, &mut warnings)?;
    for le in &desc.lights {
        light_media.push(crate::scene::LightMedium::Fixed(media.of(&le.medium, &le.entity.loc)?));
    }

    // Rays get times within the shutter only when something moves (the film has checked that close > open).
    let motion = if camera.moves() || shapes.moving {
        let cp = &desc.camera.entity.params;
        Some([cp.get_float("shutteropen", 0.0)? as f32, cp.get_float("shutterclose", 1.0)? as f32])
    } else {
        None
    };
    let geometry = shapes.geometry.clone();
    let mut scene = RenderScene::new(geometry, materials.list, lights, media.list, camera_medium, camera);
    scene.motion = motion;
    scene.light_media = light_media;
    scene.normal_perturbations = materials.perturbations;
    // Footprints only where some material reads an image map or bump-maps (an image used only as an alpha map
    // needs none).
    if materials.reads_footprint.iter().any(|&r| r) {
        scene.footprints = Some(crate::footprint::Footprints::new(&scene.camera, spp));
        scene.material_reads_footprint = materials.reads_footprint;
    }
    warnings.extend(desc.warnings.iter().map(|d| d.to_string()));
    warnings.extend(desc.unused_parameters().iter().map(|d| d.to_string()));
    Ok(BuiltScene { scene, film, spp, integrator, triangles: shapes.triangles, warnings, shapes, shapes_made })
}

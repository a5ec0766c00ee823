//! Shapes: pbrt-v4's `Shape` directive (`trianglemesh`, `plymesh`, `loopsubdiv`, `bilinearmesh`, `sphere`,
//! `disk`), and the two-level BVH over the world's shapes and the `ObjectBegin`/`ObjectEnd` definitions placed by
//! `ObjectInstance`. Each shape's material, `MediumInterface`, `AreaLightSource` and alpha (cut-outs) are resolved
//! here, so the geometry a ray hits knows what it is made of.
//!
//! Motion (pbrt-v4's `ActiveTransform`): a moving shape is built in its own object space (a mesh is not moved to
//! render space) as an object of its own, placed by a moving instance whose transform is interpolated at each ray's
//! time; a moving `ObjectInstance` is a moving instance of its object; a moving shape inside an object definition
//! becomes, for every instance of the definition, a moving instance placed by the instance's transform times the
//! shape's. Static shapes and instances are built exactly as without motion.

use std::collections::HashMap;
use std::sync::Arc;

use geometry::mesh::BilinearMeshData;
use geometry::subdiv::loop_subdivide;
use geometry::{
    AnimatedTransform, BilinearMesh, GeometryScene, Instance, MeshData, MovingInstance, Object, Shape, Transform,
    TriangleMesh,
};
use glam::{DVec3, Vec2, Vec3};
use rayon::prelude::*;
use scene::{Entity, Loc, ParamSet, SceneDescription, SceneError, ShapeEntity, TransformMotion};

use super::context::{err, file_err, unsupported, Materials, Media, Result, ShapeAlpha, Textures};
use crate::light::Light;
use crate::scene::{LightMedium, MediumInterface, SceneGeometry, ShapeInfo, VertexColors, NO_MATERIAL};
use crate::texture::FloatTexture;

/// The scene's shapes, ready for ray queries.
pub(super) struct BuiltGeometry {
    /// The BVH with each shape's material, area light and media.
    pub(super) geometry: SceneGeometry,
    /// Triangles in the scene (instances counted once).
    pub(super) triangles: usize,
    /// Radius of a sphere enclosing the geometry (1 for an empty scene), which lights at infinity need.
    pub(super) scene_radius: f32,
    /// True if some shape or instance moves during the shutter.
    pub(super) moving: bool,
}

/// pbrt-v4's `AnimatedTransform` of an entity placed by `start` that moves as `motion` says: an error at `loc` if the
/// transform cannot be interpolated (projective, or singular at an end).
fn animated(start: Transform, motion: &Option<TransformMotion>, loc: &Loc, what: &str) -> Result<AnimatedTransform> {
    let Some(m) = motion else { return Ok(AnimatedTransform::fixed(start)) };
    AnimatedTransform::new(start, m.start_time, m.end, m.end_time).ok_or_else(|| {
        SceneError::at(
            loc.clone(),
            format!(
                "{what}'s moving transform cannot be interpolated: both ends must be affine and invertible to be split \
                 into translation, rotation and scale"
            ),
        )
        .into()
    })
}

/// An object's shapes, what a hit on each means, and each one's alpha texture (an index into the scene's list).
type ObjectShapes = (Vec<Shape>, Vec<ShapeInfo>, Vec<Option<u32>>);

/// The per-vertex colours of an `importedmesh` shape (`"integer vertexcolors"`, an index into the description's
/// vertex colours, one per vertex of the mesh), if it names them.
fn imported_vertex_colors(p: &ParamSet, loc: &Loc, desc: &SceneDescription) -> Result<Option<VertexColors>> {
    if !p.contains("vertexcolors") {
        return Ok(None);
    }
    let at = p.loc_of("vertexcolors", loc);
    let index = p.get_int("vertexcolors", -1)?;
    let mesh = p.get_int("mesh", -1)?;
    let colors = usize::try_from(index).ok().and_then(|i| desc.vertex_colors.get(i));
    let mesh = usize::try_from(mesh).ok().and_then(|i| desc.meshes.get(i));
    match (colors, mesh) {
        (Some(colors), Some(mesh)) if colors.len() == mesh.positions.len() => {
            Ok(Some(VertexColors { mesh: mesh.clone(), colors: colors.clone() }))
        }
        (Some(colors), Some(mesh)) => err(
            &at,
            format!(
                "'vertexcolors' {index} has {} colours for the mesh's {} vertices",
                colors.len(),
                mesh.positions.len()
            ),
        ),
        (None, _) => err(&at, format!("no vertex colours {index} (the scene has {})", desc.vertex_colors.len())),
        (Some(_), None) => err(&at, "'vertexcolors' is for an importedmesh shape"),
    }
}

/// Reads a shape's `alpha`: a constant must lie in [0, 1] (an error naming `alpha` otherwise); a texture is taken
/// as it is (values are clamped by the test).
fn shape_alpha(textures: &Textures, p: &ParamSet, loc: &Loc) -> Result<ShapeAlpha> {
    if !p.contains("alpha") {
        return Ok(ShapeAlpha::Opaque);
    }
    let alpha = textures.float_param(p, "alpha", 1.0)?;
    // Only a constant is decided here; any other texture, whatever its kind, is tested at each hit.
    if let FloatTexture::Constant(a) = alpha {
        if !(0.0..=1.0).contains(&a) {
            return err(&p.loc_of("alpha", loc), format!("'alpha' must be in [0, 1], got {a}"));
        }
        if a >= 1.0 {
            return Ok(ShapeAlpha::Opaque);
        }
        if a <= 0.0 {
            return Ok(ShapeAlpha::Invisible);
        }
    }
    Ok(ShapeAlpha::CutOut(alpha))
}

/// How the area lights of a shape are made (`lights.rs`'s `area_lights`, handed over by `mod.rs`): from the
/// `AreaLightSource` directive, the shape and its alpha, appended to the lights; returns the index of the first.
pub(super) type MakeAreaLights = fn(&Entity, &Shape, &ShapeAlpha, &Textures, &mut Vec<Light>) -> Result<u32>;

/// Builds every shape into the BVH; the world's area lights are made by `area_lights` as each shape is (so that the
/// first error in the file is the one reported) and appended to `lights`, one per primitive.
pub(super) fn make_geometry(
    desc: &SceneDescription,
    textures: &Textures,
    materials: &Materials,
    named_media: &Media,
    area_lights: MakeAreaLights,
    lights: &mut Vec<Light>,
    light_media: &mut Vec<LightMedium>,
) -> Result<BuiltGeometry> {
    // Shapes: object 0 holds the world's shapes; each ObjectBegin definition becomes another object. Area lights
    // are only created for world shapes (pbrt-v4 drops them inside instances, with a warning at parse time).
    let mut triangles = 0usize;
    let mut alphas: Vec<FloatTexture> = vec![];
    let mut vertex_colors: Vec<VertexColors> = vec![];
    let mut object_shapes =
        |shapes: &[&ShapeEntity], lights: Option<(&mut Vec<Light>, &mut Vec<LightMedium>)>| -> Result<ObjectShapes> {
            let mut lights = lights;
            let (mut out, mut out_info, mut out_alpha) = (vec![], vec![], vec![]);
            // The geometry of every shape (PLY files read and decoded, vertices transformed) is made on all
            // cores; the results are then taken in file order, so the first error in the file is the one reported.
            let built: Vec<Result<Option<Shape>>> = shapes.par_iter().map(|se| make_shape(se, desc)).collect();
            for (se, shape) in shapes.iter().zip(built) {
                let alpha = shape_alpha(textures, &se.entity.params, &se.entity.loc)?;
                let Some(shape) = shape? else { continue };
                let material = materials.index(&se.material, &se.entity.loc)?;
                // A `subsurface` material fills its shapes with its medium (in place of a named inside medium).
                let inside = match materials.interior(material) {
                    Some(m) => Some(m),
                    None => named_media.of(&se.inside_medium, &se.entity.loc)?,
                };
                let outside = named_media.of(&se.outside_medium, &se.entity.loc)?;
                let media = (inside.is_some() || outside.is_some() || material == NO_MATERIAL)
                    .then_some(MediumInterface { inside, outside });
                let area_light_base = match (&se.area_light, lights.as_mut()) {
                    (Some(al), Some((lights, light_media))) => {
                        let base = area_lights(al, &shape, &alpha, textures, lights)?;
                        // Emission leaves into the shape's media (none named: vacuum, as pbrt-v4's "").
                        let lm = media.map_or(LightMedium::Fixed(None), LightMedium::Surface);
                        light_media.resize(lights.len(), lm);
                        Some(base)
                    }
                    _ => None,
                };
                out_alpha.push(match alpha {
                    // Rays never meet a shape of alpha 0: it stays out of the BVH (its light, if any, is made above).
                    ShapeAlpha::Invisible => continue,
                    ShapeAlpha::Opaque => None,
                    ShapeAlpha::CutOut(t) => {
                        alphas.push(t);
                        Some(alphas.len() as u32 - 1)
                    }
                });
                triangles += shape_triangles(&shape);
                let colors = imported_vertex_colors(&se.entity.params, &se.entity.loc, desc)?.map(|c| {
                    vertex_colors.push(c);
                    vertex_colors.len() as u32 - 1
                });
                out_info.push(ShapeInfo { material, area_light_base, media, vertex_colors: colors });
                out.push(shape);
            }
            Ok((out, out_info, out_alpha))
        };
    // Moving shapes are left out of their object (world or definition) and get objects of their own below.
    for se in desc.shapes.iter().chain(desc.objects.iter().flat_map(|o| o.shapes.iter())) {
        if se.motion.is_some() && se.area_light.is_some() {
            return err(
                &se.entity.loc,
                "a moving shape cannot be an area light (pbrt-v4: animated area lights are not supported)",
            );
        }
    }
    let (world_still, world_moving) = split_moving(&desc.shapes);
    let (world_shapes, world_info, world_alpha) = object_shapes(&world_still, Some((lights, light_media)))?;
    let mut objects = vec![Object::new(world_shapes)];
    let mut info = vec![world_info];
    let mut alpha_of = vec![world_alpha];
    let mut object_index: HashMap<&str, u32> = HashMap::new();
    // Per object definition, its moving shapes: (object, instance-from-shape motion).
    let mut moving_parts: HashMap<&str, Vec<(u32, AnimatedTransform)>> = HashMap::new();
    let mut moving: Vec<MovingInstance> = vec![];
    for od in &desc.objects {
        let (od_still, od_moving) = split_moving(&od.shapes);
        let (shapes, oinfo, oalpha) = object_shapes(&od_still, None)?;
        object_index.insert(od.name.as_str(), objects.len() as u32);
        objects.push(Object::new(shapes));
        info.push(oinfo);
        alpha_of.push(oalpha);
        let mut parts = vec![];
        for se in od_moving {
            let motion = animated(se.render_from_object, &se.motion, &se.entity.loc, "the shape")?;
            let (shapes, oinfo, oalpha) = object_shapes(&[se], None)?;
            parts.push((objects.len() as u32, motion));
            objects.push(Object::new(shapes));
            info.push(oinfo);
            alpha_of.push(oalpha);
        }
        moving_parts.insert(od.name.as_str(), parts);
    }
    for se in world_moving {
        let motion = animated(se.render_from_object, &se.motion, &se.entity.loc, "the shape")?;
        let (shapes, oinfo, oalpha) = object_shapes(&[se], None)?;
        let inner = AnimatedTransform::fixed(Transform::IDENTITY);
        moving.push(MovingInstance { object: objects.len() as u32, outer: motion, inner });
        objects.push(Object::new(shapes));
        info.push(oinfo);
        alpha_of.push(oalpha);
    }
    let mut instances = vec![Instance { object: 0, render_from_instance: Transform::IDENTITY }];
    for iu in &desc.instances {
        let Some(&o) = object_index.get(iu.name.as_str()) else {
            return err(&iu.loc, format!("no object named '{}'", iu.name));
        };
        let outer = animated(iu.render_from_instance, &iu.motion, &iu.loc, "the instance")?;
        if iu.motion.is_none() {
            instances.push(Instance { object: o, render_from_instance: iu.render_from_instance });
        } else {
            moving.push(MovingInstance { object: o, outer, inner: AnimatedTransform::fixed(Transform::IDENTITY) });
        }
        for &(object, inner) in moving_parts.get(iu.name.as_str()).into_iter().flatten() {
            moving.push(MovingInstance { object, outer, inner });
        }
    }
    let any_moving = !moving.is_empty();
    let accel = GeometryScene::build_with_motion(objects, instances, moving)
        .map_err(|e| SceneError::at(desc.film.loc.clone(), e.to_string()))?;
    let bounds = {
        use geometry::Accel;
        accel.bounds()
    };
    let (_, scene_radius) = if bounds.is_empty() { (Vec3::ZERO, 1.0) } else { bounds.bounding_sphere() };
    let geometry = SceneGeometry::with_alpha(accel, info, alphas, alpha_of).with_vertex_colors(vertex_colors);
    Ok(BuiltGeometry { geometry, triangles, scene_radius, moving: any_moving })
}

/// The shapes that stay where they are, and those that move.
fn split_moving(shapes: &[ShapeEntity]) -> (Vec<&ShapeEntity>, Vec<&ShapeEntity>) {
    shapes.iter().partition(|s| s.motion.is_none())
}

fn shape_triangles(s: &Shape) -> usize {
    match s {
        Shape::Mesh(m) => m.triangle_count(),
        Shape::Bilinear(_) | Shape::Sphere(_) | Shape::Disk(_) => 0,
    }
}

fn geo_err(loc: &Loc, e: geometry::GeometryError) -> SceneError {
    SceneError::at(loc.clone(), e.to_string())
}

fn to_vec3s(v: Vec<DVec3>) -> Vec<Vec3> {
    v.into_iter().map(|p| p.as_vec3()).collect()
}

fn indices_u32(p: &ParamSet, loc: &Loc, name: &str) -> Result<Option<Vec<u32>>> {
    let Some(ints) = p.get_ints(name) else { return Ok(None) };
    ints.iter()
        .map(|&i| {
            u32::try_from(i).map_err(|_| {
                SceneError::at(loc.clone(), format!("'{name}': index {i} is negative or too large")).into()
            })
        })
        .collect::<Result<Vec<_>>>()
        .map(Some)
}

/// The geometry of one shape entity of `desc`.
fn make_shape(se: &ShapeEntity, desc: &SceneDescription) -> Result<Option<Shape>> {
    let meshes = &desc.meshes;
    let e = &se.entity;
    let p = &e.params;
    let loc = &e.loc;
    // A moving shape is built in its own space; its instance moves it.
    let rfo = if se.motion.is_some() { Transform::IDENTITY } else { se.render_from_object };
    let ro = se.reverse_orientation;
    // A mesh, with shading tangents per corner if it has them.
    let tangent_mesh = |data: MeshData, tangents: Option<&[[f32; 3]]>| -> Result<Option<Shape>> {
        if data.indices.is_empty() {
            return Ok(None);
        }
        let mut m = TriangleMesh::new(&rfo, data, ro).map_err(|e| geo_err(loc, e))?;
        if let Some(t) = tangents {
            m = m.with_corner_tangents(&rfo, t).map_err(|e| geo_err(loc, e))?;
        }
        Ok(Some(Shape::Mesh(Arc::new(m))))
    };
    let mesh = |data: MeshData| tangent_mesh(data, None);
    match e.name.as_str() {
        "trianglemesh" => {
            let Some(pos) = p.get_point3s("P")? else { return err(loc, "trianglemesh needs 'point3 P'") };
            let indices = match indices_u32(p, loc, "indices")? {
                Some(i) => i,
                None if pos.len() == 3 => vec![0, 1, 2],
                None => return err(loc, "trianglemesh needs 'integer indices' unless it has exactly 3 vertices"),
            };
            let normals = p.get_normals("N")?.map(to_vec3s);
            let uvs =
                p.get_point2s("uv")?.map(|v| v.into_iter().map(|a| Vec2::new(a[0] as f32, a[1] as f32)).collect());
            // pbrt-v4's per-vertex tangents `S`, given to the mesh per corner.
            let tangents = match p.get_vector3s("S")? {
                None => None,
                Some(s) if s.len() == pos.len() => {
                    let at = |i: u32| s.get(i as usize).map_or([0.0; 3], |v| v.as_vec3().to_array());
                    Some(indices.iter().map(|&i| at(i)).collect::<Vec<_>>())
                }
                Some(s) => {
                    let at = p.loc_of("S", loc);
                    return err(&at, format!("'S' has {} tangents for {} vertices", s.len(), pos.len()));
                }
            };
            tangent_mesh(MeshData { positions: to_vec3s(pos), normals, uvs, indices }, tangents.as_deref())
        }
        "importedmesh" => {
            // A mesh a reader decoded whole (glTF), named by its index in the description's meshes, with its
            // tangents per corner if it names them.
            let index = p.get_int("mesh", -1)?;
            let Some(data) = usize::try_from(index).ok().and_then(|i| meshes.get(i)) else {
                return err(loc, format!("importedmesh: no imported mesh {index} (the scene has {})", meshes.len()));
            };
            let tangents = if p.contains("tangents") {
                let t = p.get_int("tangents", -1)?;
                let Some(t) = usize::try_from(t).ok().and_then(|i| desc.corner_tangents.get(i)) else {
                    let at = p.loc_of("tangents", loc);
                    return err(&at, format!("no tangents {t} (the scene has {})", desc.corner_tangents.len()));
                };
                Some(&t[..])
            } else {
                None
            };
            tangent_mesh(MeshData::clone(data), tangents)
        }
        "plymesh" => {
            let Some(path) = p.get_filename("filename")? else { return err(loc, "plymesh needs 'string filename'") };
            let data = geometry::ply::read_ply_file(&path).map_err(|e| file_err(loc, &path, e.to_string()))?;
            if p.contains("displacement") {
                p.mark_used("displacement");
            }
            mesh(data)
        }
        "loopsubdiv" => {
            let Some(pos) = p.get_point3s("P")? else { return err(loc, "loopsubdiv needs 'point3 P'") };
            let Some(indices) = indices_u32(p, loc, "indices")? else {
                return err(loc, "loopsubdiv needs 'integer indices'");
            };
            let levels = p.get_int("levels", 3)?;
            if !(0..=10).contains(&levels) {
                return err(loc, format!("loopsubdiv 'levels' must be in 0..=10, got {levels}"));
            }
            let data = MeshData { positions: to_vec3s(pos), normals: None, uvs: None, indices };
            mesh(loop_subdivide(&data, levels as u32).map_err(|e| geo_err(loc, e))?)
        }
        "bilinearmesh" => {
            let Some(pos) = p.get_point3s("P")? else { return err(loc, "bilinearmesh needs 'point3 P'") };
            let indices = match indices_u32(p, loc, "indices")? {
                Some(i) => i,
                None if pos.len() == 4 => vec![0, 1, 2, 3],
                None => return err(loc, "bilinearmesh needs 'integer indices' unless it has exactly 4 vertices"),
            };
            let normals = p.get_normals("N")?.map(to_vec3s);
            let uvs =
                p.get_point2s("uv")?.map(|v| v.into_iter().map(|a| Vec2::new(a[0] as f32, a[1] as f32)).collect());
            let bl = BilinearMeshData { positions: to_vec3s(pos), normals, uvs, indices };
            if bl.indices.is_empty() {
                return Ok(None);
            }
            Ok(Some(Shape::Bilinear(Arc::new(BilinearMesh::new(&rfo, bl, ro).map_err(|e| geo_err(loc, e))?))))
        }
        "sphere" => {
            // Each error names its parameter at the parameter's own location when given.
            let at = |name: &str| p.loc_of(name, loc);
            let r = p.get_float("radius", 1.0)?;
            if !(r.is_finite() && r > 0.0) {
                return err(&at("radius"), format!("sphere 'radius' must be a positive number, got {r}"));
            }
            let zmin = p.get_float("zmin", -r)?;
            let zmax = p.get_float("zmax", r)?;
            let phimax = p.get_float("phimax", 360.0)?;
            for (name, v) in [("zmin", zmin), ("zmax", zmax)] {
                if v.is_nan() {
                    return err(&at(name), format!("sphere '{name}' must be a number, got {v}"));
                }
            }
            if zmin.clamp(-r, r) >= zmax.clamp(-r, r) {
                return err(
                    &at("zmin"),
                    format!(
                        "sphere 'zmin' ({zmin}) must be less than 'zmax' ({zmax}) after clamping both to \
                         [-radius, radius] = [{}, {r}]",
                        -r
                    ),
                );
            }
            if !(phimax > 0.0 && phimax <= 360.0) {
                return err(&at("phimax"), format!("sphere 'phimax' must be in (0, 360] degrees, got {phimax}"));
            }
            let s = geometry::Sphere::partial(r as f32, zmin as f32, zmax as f32, phimax as f32, rfo, ro)
                .map_err(|e| geo_err(loc, e))?;
            Ok(Some(Shape::Sphere(s)))
        }
        "disk" => {
            let d = geometry::Disk::new(
                p.get_float("height", 0.0)? as f32,
                p.get_float("radius", 1.0)? as f32,
                p.get_float("innerradius", 0.0)? as f32,
                p.get_float("phimax", 360.0)? as f32,
                rfo,
                ro,
            )
            .map_err(|e| geo_err(loc, e))?;
            Ok(Some(Shape::Disk(d)))
        }
        other => err(
            loc,
            unsupported("shape", other, &["trianglemesh", "plymesh", "loopsubdiv", "bilinearmesh", "sphere", "disk"]),
        ),
    }
}

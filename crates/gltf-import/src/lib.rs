//! glTF 2.0 into a scene description: `.gltf` (with external or embedded buffers) and `.glb` files, as Blender and
//! other tools export them, read with the `gltf` crate and turned into the same [`SceneDescription`] the pbrt-v4
//! parser makes, so the renderer sees one kind of scene.
//!
//! What becomes what:
//! - **Meshes**: every triangle primitive of every node of the default scene, decoded on all cores into
//!   [`SceneDescription::meshes`] (once per primitive however many nodes use it) and placed by `importedmesh` shapes
//!   under the node's world transform, with their vertex colours (`COLOR_0`, in
//!   [`SceneDescription::vertex_colors`]). glTF lengths are metres, used as scene units.
//! - **Cameras**: the chosen one (by name or index; the first by default), perspective or orthographic, looking down
//!   its node's −Z with +Y up as glTF says. Without any, a camera framing the scene's bounds, with a warning.
//! - **Lights** (`KHR_lights_punctual`): point and spot lights in candela, directional ones in lux, become radiometric
//!   by dividing by 683 lm/W (the luminous efficacy at 555 nm, as Blender's exporter multiplies by when it writes
//!   a light of P watts as P·683/(4π) cd): a Blender point light of P watts has intensity P/(4π) W/sr.
//! - **Materials**: the metallic-roughness material as the specification's Appendix B defines it (Prismatic's
//!   `metallicroughness`), with `KHR_materials_ior`; `KHR_materials_transmission` as a dielectric of that index (with
//!   `KHR_materials_dispersion`: n(λ) from the Abbe model with n_d = ior and V_d = 20/dispersion), mixed with the
//!   opaque material by the transmission factor; `KHR_materials_volume`'s attenuation as the glass's absorption;
//!   emission (`emissiveFactor` × `KHR_materials_emissive_strength`) as a diffuse area light on the mesh; the layers
//!   of `KHR_materials_specular`, `_iridescence`, `_sheen` and `_clearcoat` ([`layers`]).
//! - **Textures** ([`textures`]): base colour, metallic-roughness, normal, transmission and emissive textures as image maps of
//!   the file's PNG and JPEG images (kept encoded in [`SceneDescription::images`]; the renderer decodes them), with
//!   their samplers and `KHR_texture_transform`; alpha from the base colour texture for `MASK` and `BLEND`.
//!
//! Errors name the file and the JSON path of what is wrong (`meshes[3].primitives[0].attributes.POSITION`).

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use base64::Engine;
use geometry::{MeshData, Transform};
use glam::{DMat4, DVec3, Vec2, Vec3};
use rayon::prelude::*;
use textures::{ImageTable, TextureMaker, TextureRef};

mod layers;
mod meshopt;
mod tangents;
mod textures;
use scene::{
    CameraEntity, Diagnostic, Entity, LightEntity, Loc, MaterialRef, MediumEntity, Param, ParamSet, ParamType,
    SceneDescription, ShapeEntity, TextureValueType,
};
pub use textures::uv_transform;

/// A glTF file that cannot be read: the file, the JSON path of the offending element (empty for the file as a
/// whole) and what is wrong.
#[derive(Debug, thiserror::Error)]
#[error("{}: {}{message}", file.display(), if path.is_empty() { String::new() } else { format!("{path}: ") })]
pub struct GltfError {
    /// The file.
    pub file: PathBuf,
    /// The JSON path, e.g. `meshes[3].primitives[0].attributes.POSITION`.
    pub path: String,
    /// What is wrong.
    pub message: String,
}

/// How to read a file as a whole scene.
#[derive(Clone, Debug, Default)]
pub struct ReadOptions {
    /// The camera: a name, or an index into the file's cameras; the first one by default.
    pub camera: Option<String>,
}

/// The extensions this reader understands; any other in `extensionsRequired` is an error, in `extensionsUsed` a
/// warning.
pub const SUPPORTED_EXTENSIONS: [&str; 16] = [
    "KHR_lights_punctual",
    "KHR_mesh_quantization",
    "KHR_texture_transform",
    "EXT_texture_webp",
    "EXT_meshopt_compression",
    "KHR_materials_ior",
    "KHR_materials_transmission",
    "KHR_materials_volume",
    "KHR_materials_emissive_strength",
    "KHR_materials_dispersion",
    "KHR_materials_specular",
    "KHR_materials_iridescence",
    "KHR_materials_sheen",
    "KHR_materials_clearcoat",
    "KHR_materials_anisotropy",
    "EXT_mesh_gpu_instancing",
];

/// Lumens per watt at 555 nm: glTF's photometric light units to the renderer's radiometric ones.
const LUMENS_PER_WATT: f64 = 683.0;

/// Reads `path` as a whole scene: its meshes, materials and lights, the chosen camera, and pbrt-v4's defaults for
/// everything glTF does not describe (film, sampler, integrator), which the command line's options then set.
pub fn read_scene(path: &Path, options: &ReadOptions) -> Result<SceneDescription, GltfError> {
    let file: Arc<Path> = Arc::from(path);
    let mut desc = SceneDescription::new(file.clone());
    let imported = import(&mut desc, path, &Transform::IDENTITY)?;
    let loc = Loc::new(file.clone(), 0, 0);
    let aspect = match choose_camera(&imported.cameras, options, path)? {
        Some(cam) => {
            let (entity, aspect) = camera_entity(&cam.camera, loc.clone());
            // pbrt's camera space looks down +z with +y up and +x to the image's right; glTF's looks down -z.
            let flip = Transform::scale(DVec3::new(1.0, 1.0, -1.0)).expect("a reflection is invertible");
            let camera_from_world = flip.then_after(&cam.world.inverse());
            desc.camera = CameraEntity { entity, camera_from_world, medium: None, motion: None };
            aspect
        }
        None => {
            let (camera, warning) = framing_camera(&desc, loc.clone());
            desc.camera = camera;
            desc.warnings.push(Diagnostic::new(loc.clone(), warning));
            None
        }
    };
    // The film's size follows the camera's aspect ratio (the command line's --resolution replaces it).
    let (w, h) = match aspect {
        Some(a) if a.is_finite() && a > 0.0 => (1280, ((1280.0 / a).round() as i64).clamp(1, 16384)),
        _ => (1280, 720),
    };
    let mut film = ParamSet::new();
    film.push(ints("xresolution", &[w], &loc));
    film.push(ints("yresolution", &[h], &loc));
    let stem = path.file_stem().map_or("render".into(), |s| s.to_string_lossy().into_owned());
    film.push(string("filename", &format!("{stem}.exr"), &loc));
    desc.film = Entity::new("rgb", film, loc);
    Ok(desc)
}

/// A camera of the file and where its node puts it.
#[derive(Clone, Debug)]
pub struct PlacedCamera {
    /// Its name, if it has one.
    pub name: Option<String>,
    /// Its index in the file's `cameras`.
    pub index: usize,
    /// What it is.
    pub camera: CameraModel,
    /// Its node's world transform (glTF camera space to world).
    pub world: Transform,
}

/// A glTF camera's projection.
#[derive(Clone, Copy, Debug)]
pub enum CameraModel {
    /// Vertical field of view (radians) and, if given, the aspect ratio.
    Perspective { yfov: f64, aspect: Option<f64> },
    /// Half-width and half-height of the view in metres.
    Orthographic { xmag: f64, ymag: f64 },
}

/// What [`import`] found besides what it added to the description.
#[derive(Clone, Debug, Default)]
pub struct Imported {
    /// The cameras placed by nodes of the scene, in node order.
    pub cameras: Vec<PlacedCamera>,
}

/// Adds the meshes, materials and lights of the glTF file at `path` to `desc`, placed by `render_from_file` (pbrt's
/// `Import "model.glb"` under the current transform); returns the cameras it found.
pub fn import(desc: &mut SceneDescription, path: &Path, render_from_file: &Transform) -> Result<Imported, GltfError> {
    let err = |json: &str, message: String| GltfError { file: path.to_path_buf(), path: json.to_string(), message };
    // Files are read to at most 2 GiB, as every other reader does (a name leading to `/dev/zero` is an error).
    let bytes = geometry::gzip::read_bounded(path, geometry::gzip::MAX_DECOMPRESSED_BYTES)
        .map_err(|e| err("", format!("cannot read the file: {e}")))?;
    let (gltf, zeros) = parse(&bytes).map_err(|(json, message)| err(&json, message))?;
    let file: Arc<Path> = Arc::from(path);
    let loc = Loc::new(file.clone(), 0, 0);
    for ext in gltf.extensions_used() {
        if !SUPPORTED_EXTENSIONS.contains(&ext) {
            desc.warnings.push(Diagnostic::new(loc.clone(), format!("extension '{ext}' is used but ignored")));
        }
    }
    // The files read, for checkpoints' scene hash: the glTF file and its external buffers.
    desc.files.push(path.to_path_buf());
    let buffers = load_buffers(&gltf, zeros, path, &mut desc.files)?;
    let Some(scene) = gltf.default_scene().or_else(|| gltf.scenes().next()) else {
        return Ok(Imported::default());
    };

    // The nodes in depth-first order with their world transforms (a node reached twice on one path is a cycle).
    let mut placed: Vec<(gltf::Node<'_>, DMat4)> = vec![];
    let mut stack: Vec<(gltf::Node<'_>, DMat4, Vec<usize>)> =
        scene.nodes().map(|n| (n, render_from_file.matrix(), vec![])).collect();
    stack.reverse();
    while let Some((node, parent, mut ancestors)) = stack.pop() {
        if ancestors.contains(&node.index()) {
            return Err(err(&format!("nodes[{}].children", node.index()), "the node graph has a cycle".into()));
        }
        if ancestors.len() > 1000 {
            return Err(err(&format!("nodes[{}]", node.index()), "nodes nested more than 1000 deep".into()));
        }
        let local = DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
        let world = parent * local;
        if !world.is_finite() {
            return Err(err(&format!("nodes[{}]", node.index()), "the transform is not finite".into()));
        }
        ancestors.push(node.index());
        for child in node.children().collect::<Vec<_>>().into_iter().rev() {
            stack.push((child, world, ancestors.clone()));
        }
        placed.push((node, world));
    }

    // Materials: one named material per glTF material used (with the medium inside it, for a volume), and glTF's
    // default for primitives without one.
    type Made = (String, Option<String>);
    let mut material_names: Vec<Option<Made>> = vec![None; gltf.materials().len()];
    let mut default_material: Option<Made> = None;
    let mut images = ImageTable::default();
    let mut material_ref = |desc: &mut SceneDescription, m: gltf::Material<'_>| -> Result<Made, GltfError> {
        let slot = match m.index() {
            Some(i) => &mut material_names[i],
            None => &mut default_material,
        };
        if let Some(made) = slot {
            return Ok(made.clone());
        }
        let name = format!("{}#{}", path.display(), m.index().map_or("default".into(), |i| format!("materials[{i}]")));
        let mut textures =
            TextureMaker { document: &gltf, desc, buffers: &buffers, path, images: &mut images, loc: &loc };
        let medium = add_material(&mut textures, &name, &m)?;
        *slot = Some((name.clone(), medium.clone()));
        Ok((name, medium))
    };

    // Meshes: every primitive used, at the morph target weights of each node that uses it (the node's, else the
    // mesh's), decoded on all cores.
    let morph_weights = |node: &gltf::Node<'_>, mesh: &gltf::Mesh<'_>| -> Result<Vec<f32>, GltfError> {
        let (weights, json) = match node.weights() {
            Some(w) => (w, format!("nodes[{}].weights", node.index())),
            None => (mesh.weights().unwrap_or(&[]), format!("meshes[{}].weights", mesh.index())),
        };
        if weights.iter().any(|w| !w.is_finite()) {
            return Err(err(&json, "morph target weights must be finite".into()));
        }
        Ok(weights.to_vec())
    };
    // A primitive at its weights (as bits, for hashing).
    type PrimitiveKey = (usize, usize, Vec<u32>);
    let key = |m: usize, p: usize, w: &[f32]| -> PrimitiveKey { (m, p, w.iter().map(|v| v.to_bits()).collect()) };
    let mut used: Vec<(usize, usize, Vec<f32>)> = vec![];
    let mut seen = HashSet::new();
    for (node, _) in &placed {
        if let Some(mesh) = node.mesh() {
            let weights = morph_weights(node, &mesh)?;
            for prim in mesh.primitives() {
                if seen.insert(key(mesh.index(), prim.index(), &weights)) {
                    used.push((mesh.index(), prim.index(), weights.clone()));
                }
            }
        }
    }
    let meshes: Vec<gltf::Mesh<'_>> = gltf.meshes().collect();
    let decoded: Vec<Result<Option<DecodedPrimitive>, GltfError>> = used
        .par_iter()
        .map(|(m, p, weights)| {
            let prim = meshes[*m].primitives().nth(*p).expect("the primitive was listed from this mesh");
            decode_primitive(&prim, weights, &buffers, &format!("meshes[{m}].primitives[{p}]"))
                .map_err(|(json, message)| err(&json, message))
        })
        .collect();
    let mut mesh_index = std::collections::HashMap::new();
    for ((m, p, weights), d) in used.iter().zip(decoded) {
        if let Some((data, colors, tangents)) = d? {
            let colors = colors.map(|c| {
                desc.vertex_colors.push(c);
                desc.vertex_colors.len() - 1
            });
            let tangents = tangents.map(|t| {
                desc.corner_tangents.push(t);
                desc.corner_tangents.len() - 1
            });
            mesh_index.insert(key(*m, *p, weights), (desc.meshes.len(), colors, tangents));
            desc.meshes.push(data);
        }
    }
    // Materials of primitives with vertex colours: the base colour times COLOR_0, made once per material.
    let mut colored_materials: std::collections::HashMap<String, String> = std::collections::HashMap::new();

    let mut cameras = vec![];
    for (node, world) in &placed {
        let world_t = Transform::from_matrix(*world)
            .ok_or_else(|| err(&format!("nodes[{}]", node.index()), "the transform is singular".into()))?;
        if let Some(mesh) = node.mesh() {
            let weights = morph_weights(node, &mesh)?;
            let instances = gpu_instances(&gltf, node, &buffers).map_err(|(json, message)| err(&json, message))?;
            // An instanced node's shapes go into an object placed once per instance; emitters stay shapes of the
            // world, one per instance (area lights are not made inside instances, as in pbrt-v4).
            let mut object_shapes = vec![];
            for prim in mesh.primitives() {
                let Some(&(index, colors, tangents)) = mesh_index.get(&key(mesh.index(), prim.index(), &weights))
                else {
                    continue;
                };
                let material = prim.material();
                let (mut name, medium) = material_ref(desc, material.clone())?;
                let mut params = ParamSet::new();
                params.push(ints("mesh", &[index as i64], &loc));
                if let Some(t) = tangents {
                    params.push(ints("tangents", &[t as i64], &loc));
                }
                if let Some(c) = colors {
                    params.push(ints("vertexcolors", &[c as i64], &loc));
                    name = match colored_materials.get(&name) {
                        Some(colored) => colored.clone(),
                        None => {
                            let colored = vertex_color_material(desc, &name, &loc);
                            colored_materials.insert(name.clone(), colored.clone());
                            colored
                        }
                    };
                }
                if let Some(alpha) = alpha_param(&material, &name, &loc) {
                    params.push(alpha);
                }
                let area_light = emission(&material, &name, &loc);
                let shape = ShapeEntity {
                    entity: Entity::new("importedmesh", params, loc.clone()),
                    render_from_object: world_t,
                    reverse_orientation: false,
                    material: MaterialRef::Named(name),
                    area_light,
                    inside_medium: medium,
                    outside_medium: None,
                    motion: None,
                };
                match &instances {
                    None => desc.shapes.push(shape),
                    Some(list) if shape.area_light.is_some() => {
                        for instance in list {
                            desc.shapes.push(ShapeEntity { render_from_object: world_t * *instance, ..shape.clone() });
                        }
                    }
                    Some(_) => object_shapes.push(ShapeEntity { render_from_object: Transform::IDENTITY, ..shape }),
                }
            }
            if let (Some(list), false) = (&instances, object_shapes.is_empty()) {
                let name = format!("{}#nodes[{}]", path.display(), node.index());
                desc.objects.push(scene::ObjectDefinition {
                    name: name.clone(),
                    shapes: object_shapes,
                    loc: loc.clone(),
                });
                for instance in list {
                    desc.instances.push(scene::InstanceUse {
                        name: name.clone(),
                        render_from_instance: world_t * *instance,
                        loc: loc.clone(),
                        motion: None,
                    });
                }
            }
        }
        if let Some(camera) = node.camera() {
            let camera_model = match camera.projection() {
                gltf::camera::Projection::Perspective(p) => {
                    CameraModel::Perspective { yfov: f64::from(p.yfov()), aspect: p.aspect_ratio().map(f64::from) }
                }
                gltf::camera::Projection::Orthographic(o) => {
                    CameraModel::Orthographic { xmag: f64::from(o.xmag()), ymag: f64::from(o.ymag()) }
                }
            };
            cameras.push(PlacedCamera {
                name: camera.name().map(str::to_string),
                index: camera.index(),
                camera: camera_model,
                world: world_t,
            });
        }
        if let Some(light) = node.light() {
            desc.lights.push(light_entity(&light, world_t, &loc));
        }
    }
    Ok(Imported { cameras })
}

/// The document and its binary chunk: parsed, checked where the gltf crate's validation would index out of bounds
/// (a primitive's attribute naming an accessor that does not exist), then validated by the crate.
/// The most bytes of zeros that accessors without data (neither a buffer view nor sparse values) may stand for.
const MAX_ZERO_BYTES: u64 = 1 << 28;

/// The file's document and binary chunk, with the index of the buffer of zeros that accessors without data read
/// (see below), if it has any.
fn parse(bytes: &[u8]) -> Result<(gltf::Gltf, Option<usize>), (String, String)> {
    // A GLB header whose length is shorter than the header itself (the gltf crate subtracts the header's size).
    if bytes.starts_with(b"glTF") {
        let length = bytes.get(8..12).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
        if length.is_none_or(|l| l < 12) {
            return Err((String::new(), "the GLB header is truncated or gives a length under 12 bytes".into()));
        }
    }
    let gltf::Gltf { document, blob } =
        gltf::Gltf::from_slice_without_validation(bytes).map_err(|e| (String::new(), gltf_message(&e)))?;
    let mut json = document.into_json();
    // EXT_texture_webp: the WebP image replaces the texture's fallback `source` (or stands where it has none), as
    // the extension asks of readers that decode WebP; the crate's validation then checks the index.
    for texture in &mut json.textures {
        let webp = texture.extensions.as_ref().and_then(|e| e.others.get("EXT_texture_webp"));
        if let Some(source) = webp.and_then(|w| w.get("source")).and_then(serde_json::Value::as_u64) {
            texture.source = gltf::json::Index::new(source.min(u64::from(u32::MAX - 1)) as u32);
        }
    }
    // Required extensions first: a file that needs one this reader lacks (compressed meshes or textures, say) is
    // that error, not whatever the crate's validation finds missing without it (a KTX2 texture has no `source`).
    for ext in &json.extensions_required {
        if !SUPPORTED_EXTENSIONS.contains(&ext.as_str()) {
            return Err(("extensionsRequired".into(), format!("extension '{ext}' is required but not supported")));
        }
    }
    // Checked here: the crate's validation would refuse the extensions it does not parse itself, which this
    // reader reads from their JSON (the material layers, dispersion, WebP, meshopt).
    json.extensions_required.clear();
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            for (semantic, index) in &prim.attributes {
                if index.value() >= json.accessors.len() {
                    let name = match semantic {
                        gltf::json::validation::Checked::Valid(s) => s.to_string(),
                        gltf::json::validation::Checked::Invalid => "(invalid)".into(),
                    };
                    return Err((
                        format!("meshes[{m}].primitives[{p}].attributes.{name}"),
                        format!("accessor {} does not exist (the file has {})", index.value(), json.accessors.len()),
                    ));
                }
            }
        }
    }
    // An image needs a URI, or a buffer view and a MIME type (the gltf crate unwraps them when asked for the
    // image's source; found by fuzzing).
    for (i, image) in json.images.iter().enumerate() {
        let missing = match (&image.buffer_view, &image.uri) {
            (Some(_), _) if image.mime_type.is_none() => Some("an image in a buffer view needs its mimeType"),
            (None, None) => Some("an image needs a uri or a bufferView"),
            _ => None,
        };
        if let Some(message) = missing {
            return Err((format!("images[{i}]"), message.into()));
        }
    }
    let zeros = read_zero_accessors_from_a_buffer(&mut json)?;
    let document = gltf::Document::from_json(json).map_err(|e| (String::new(), gltf_message(&e)))?;
    Ok((gltf::Gltf { document, blob }, zeros))
}

/// An accessor with neither a buffer view nor sparse values holds zeros (glTF 2.0 §3.6.2.3; Blender writes the normal
/// displacements of a shape key that leaves the normals as they are so), which the gltf crate's validation refuses:
/// such accessors are pointed at one buffer of zeros appended to the document (made by [`load_buffers`]), as long
/// as the largest needs at most [`MAX_ZERO_BYTES`]. Returns that buffer's index.
fn read_zero_accessors_from_a_buffer(json: &mut gltf::json::Root) -> Result<Option<usize>, (String, String)> {
    use gltf::json::validation::Checked;
    let mut needed = 0u64;
    let mut empty = vec![];
    for (i, a) in json.accessors.iter().enumerate() {
        if a.buffer_view.is_some() || a.sparse.is_some() {
            continue;
        }
        // An accessor of an invalid type is left to the crate's validation.
        if let (Checked::Valid(c), Checked::Valid(t)) = (&a.component_type, &a.type_) {
            let bytes = a.count.0.saturating_mul((c.0.size() * t.multiplicity()) as u64);
            if bytes > MAX_ZERO_BYTES {
                return Err((
                    format!("accessors[{i}]"),
                    format!("{bytes} bytes of zeros: at most {MAX_ZERO_BYTES} are read"),
                ));
            }
            needed = needed.max(bytes);
            empty.push(i);
        }
    }
    if empty.is_empty() {
        return Ok(None);
    }
    let length = gltf::json::validation::USize64(needed.max(1));
    let buffer = json.buffers.len();
    json.buffers.push(gltf::json::Buffer {
        byte_length: length,
        name: None,
        uri: None,
        extensions: None,
        extras: Default::default(),
    });
    let view = json.buffer_views.len();
    json.buffer_views.push(gltf::json::buffer::View {
        buffer: gltf::json::Index::new(buffer as u32),
        byte_length: length,
        byte_offset: None,
        byte_stride: None,
        name: None,
        target: None,
        extensions: None,
        extras: Default::default(),
    });
    for i in empty {
        json.accessors[i].buffer_view = Some(gltf::json::Index::new(view as u32));
        json.accessors[i].byte_offset = None;
    }
    Ok(Some(buffer))
}

/// The gltf crate's error, with the JSON paths of validation errors.
fn gltf_message(e: &gltf::Error) -> String {
    match e {
        gltf::Error::Validation(list) => {
            list.iter().map(|(path, what)| format!("{path}: {what}")).collect::<Vec<_>>().join("; ")
        }
        other => other.to_string(),
    }
}

/// The data of every buffer: the GLB's binary chunk, a data URI's bytes, or an external file next to the glTF.
fn load_buffers(
    gltf: &gltf::Gltf,
    zeros: Option<usize>,
    path: &Path,
    files: &mut Vec<PathBuf>,
) -> Result<Vec<Vec<u8>>, GltfError> {
    let err =
        |i: usize, message: String| GltfError { file: path.to_path_buf(), path: format!("buffers[{i}]"), message };
    let dir = path.parent().unwrap_or(Path::new(""));
    let mut out = vec![];
    let json = gltf.document.as_json();
    let placeholder: Vec<bool> =
        (0..json.buffers.len()).map(|i| meshopt::is_placeholder(json, i, gltf.blob.is_some())).collect();
    for buffer in gltf.buffers() {
        let i = buffer.index();
        if Some(i) == zeros {
            out.push(vec![0; buffer.length()]);
            continue;
        }
        if placeholder[i] {
            // Filled by EXT_meshopt_compression's views below, as far as they reach.
            out.push(vec![]);
            continue;
        }
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => {
                gltf.blob.clone().ok_or_else(|| err(i, "refers to the GLB's binary chunk, which is missing".into()))?
            }
            gltf::buffer::Source::Uri(uri) => {
                if let Some(rest) = uri.strip_prefix("data:") {
                    decode_data_uri(rest).map_err(|m| err(i, m))?
                } else {
                    let file = dir.join(percent_decode(uri));
                    // Only the buffer's declared length is read (at most 2 GiB): an endless file is no hazard,
                    // and a shorter one is refused below.
                    let limit = (buffer.length() as u64).min(geometry::gzip::MAX_DECOMPRESSED_BYTES);
                    let mut data = Vec::new();
                    std::fs::File::open(&file)
                        .and_then(|f| std::io::Read::read_to_end(&mut std::io::Read::take(f, limit), &mut data))
                        .map_err(|e| err(i, format!("cannot read {}: {e}", file.display())))?;
                    files.push(file);
                    data
                }
            }
        };
        if data.len() < buffer.length() {
            return Err(err(i, format!("holds {} bytes, fewer than its byteLength {}", data.len(), buffer.length())));
        }
        out.push(data);
    }
    meshopt::decode_views(json, &mut out, &placeholder).map_err(|(json_path, message)| GltfError {
        file: path.to_path_buf(),
        path: json_path,
        message,
    })?;
    Ok(out)
}

/// The bytes of a data URI (after `data:`), which must be base64-encoded.
fn decode_data_uri(rest: &str) -> Result<Vec<u8>, String> {
    let (_, payload) = rest.split_once(";base64,").ok_or("a data URI must be base64-encoded")?;
    base64::engine::general_purpose::STANDARD
        .decode(payload)
        .map_err(|e| format!("the data URI is not valid base64: {e}"))
}

/// A relative URI's path with its `%XX` escapes decoded (RFC 3986 §2.1: glTF URIs escape spaces and other
/// reserved characters); an escape that is not two hex digits stays as written.
fn percent_decode(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = bytes.get(i + 1..i + 3).and_then(|h| std::str::from_utf8(h).ok());
        match (bytes[i], hex.and_then(|h| u8::from_str_radix(h, 16).ok())) {
            (b'%', Some(v)) => {
                out.push(v);
                i += 3;
            }
            (b, _) => {
                out.push(b);
                i += 1;
            }
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Checks that accessor `a` lies inside its buffer view and the view inside its buffer, so that reading it cannot go
/// out of bounds; `json` names it in errors.
fn check_accessor(a: &gltf::Accessor<'_>, buffers: &[Vec<u8>], json: &str) -> Result<(), (String, String)> {
    let bad = |m: String| (json.to_string(), m);
    // The specification's minimum count is 1.
    if a.count() == 0 {
        return Err(bad("an accessor must have at least one element".into()));
    }
    match (a.view(), a.sparse()) {
        (Some(view), _) => check_elements(&view, buffers, a.offset(), a.count(), a.size()).map_err(bad)?,
        // A sparse accessor without a buffer view starts from zeros.
        (None, Some(_)) => {}
        (None, None) => return Err(bad("an accessor without a buffer view or sparse values has no data".into())),
    }
    if let Some(sparse) = a.sparse() {
        check_sparse(a, &sparse, buffers).map_err(|m| (format!("{json}.sparse"), m))?;
    }
    Ok(())
}

/// Checks that `count` elements of `size` bytes from `offset` in buffer view `view` lie inside the view, and the view
/// inside its buffer (a stride shorter than an element would overlap elements).
fn check_elements(
    view: &gltf::buffer::View<'_>,
    buffers: &[Vec<u8>],
    offset: usize,
    count: usize,
    size: usize,
) -> Result<(), String> {
    let buffer = &buffers[view.buffer().index()];
    let view_end = view.offset().checked_add(view.length());
    if view_end.is_none_or(|e| e > buffer.len()) {
        return Err(format!("bufferViews[{}] reaches past the end of its buffer", view.index()));
    }
    let stride = view.stride().unwrap_or(size);
    if stride < size {
        return Err(format!(
            "bufferViews[{}]'s byteStride {stride} is shorter than an element ({size} bytes)",
            view.index()
        ));
    }
    let end = count
        .checked_sub(1)
        .and_then(|c| c.checked_mul(stride))
        .and_then(|v| v.checked_add(offset))
        .and_then(|v| v.checked_add(size));
    if end.is_none_or(|e| e > view.length()) {
        return Err(format!("{count} elements reach past the end of bufferViews[{}]", view.index()));
    }
    Ok(())
}

/// Checks a sparse accessor's substitutions (glTF 2.0 §3.6.2.3): at least one and at most the accessor's count, their
/// indices and values inside their buffer views, and the indices strictly increasing and below the count (the gltf
/// crate's reader pairs them with the values in order, assuming as much).
fn check_sparse(
    a: &gltf::Accessor<'_>,
    sparse: &gltf::accessor::sparse::Sparse<'_>,
    buffers: &[Vec<u8>],
) -> Result<(), String> {
    let count = sparse.count();
    if count == 0 || count > a.count() {
        return Err(format!("count {count}: 1 to the accessor's {} substitutions are allowed", a.count()));
    }
    let indices = sparse.indices();
    let (view, size) = (indices.view(), indices.index_type().size());
    check_elements(&view, buffers, indices.offset(), count, size).map_err(|m| format!("indices: {m}"))?;
    let values = sparse.values();
    check_elements(&values.view(), buffers, values.offset(), count, a.size()).map_err(|m| format!("values: {m}"))?;
    let data = &buffers[view.buffer().index()][view.offset()..view.offset() + view.length()];
    let stride = view.stride().unwrap_or(size);
    let mut previous: Option<u64> = None;
    for k in 0..count {
        let at = indices.offset() + k * stride;
        let b = &data[at..at + size];
        let index = match size {
            1 => u64::from(b[0]),
            2 => u64::from(u16::from_le_bytes([b[0], b[1]])),
            _ => u64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        };
        if index >= a.count() as u64 || previous.is_some_and(|p| index <= p) {
            return Err(format!(
                "index {index} (entry {k}): the indices must increase strictly and stay below the accessor's count {}",
                a.count()
            ));
        }
        previous = Some(index);
    }
    Ok(())
}

/// A decoded primitive: its mesh, its vertex colours (`COLOR_0`, linear RGB) and its shading tangents per corner, if
/// it has them.
type DecodedPrimitive = (Arc<MeshData>, Option<Arc<[[f32; 3]]>>, Option<Arc<[[f32; 3]]>>);

/// The elements of accessor `a` (checked by [`check_accessor`], `N` components each) as floats: float components
/// as they are; integers normalised if the accessor says so (glTF 2.0 §3.11: c/255 and c/65535 unsigned,
/// max(c/127, −1) and max(c/32767, −1) signed), else their values (KHR_mesh_quantization's positions, texture
/// coordinates and displacements). Sparse substitutions applied. `None` for 32-bit integers, which no vertex
/// attribute holds.
fn read_floats<const N: usize>(a: &gltf::Accessor<'_>, buffers: &[Vec<u8>]) -> Option<Vec<[f32; N]>>
where
    [f32; N]: gltf::accessor::Item,
    [i8; N]: gltf::accessor::Item,
    [u8; N]: gltf::accessor::Item,
    [i16; N]: gltf::accessor::Item,
    [u16; N]: gltf::accessor::Item,
{
    use gltf::accessor::{DataType, Iter};
    let get = |b: gltf::Buffer<'_>| buffers.get(b.index()).map(|v| v.as_slice());
    let normalized = a.normalized();
    fn floats<T: Copy, const N: usize>(it: Iter<'_, [T; N]>, f: impl Fn(T) -> f32) -> Vec<[f32; N]>
    where
        [T; N]: gltf::accessor::Item,
    {
        it.map(|v| v.map(&f)).collect()
    }
    let scaled = |c: f32, max: f32| if normalized { (c / max).max(-1.0) } else { c };
    Some(match a.data_type() {
        DataType::F32 => Iter::<[f32; N]>::new(a.clone(), get)?.collect(),
        DataType::I8 => floats(Iter::<[i8; N]>::new(a.clone(), get)?, |c| scaled(f32::from(c), 127.0)),
        DataType::U8 => floats(Iter::<[u8; N]>::new(a.clone(), get)?, |c| scaled(f32::from(c), 255.0)),
        DataType::I16 => floats(Iter::<[i16; N]>::new(a.clone(), get)?, |c| scaled(f32::from(c), 32767.0)),
        DataType::U16 => floats(Iter::<[u16; N]>::new(a.clone(), get)?, |c| scaled(f32::from(c), 65535.0)),
        DataType::U32 => return None,
    })
}

/// One triangle primitive as mesh data at the morph target `weights` (None for one with no triangles: points and
/// lines are skipped); errors as (JSON path, message).
fn decode_primitive(
    prim: &gltf::Primitive<'_>,
    weights: &[f32],
    buffers: &[Vec<u8>],
    json: &str,
) -> Result<Option<DecodedPrimitive>, (String, String)> {
    if prim.mode() != gltf::mesh::Mode::Triangles {
        return Ok(None);
    }
    use gltf::accessor::{DataType, Dimensions};
    for (semantic, accessor) in prim.attributes() {
        let path = format!("{json}.attributes.{}", semantic.to_string());
        check_accessor(&accessor, buffers, &path)?;
        // The types glTF allows, with KHR_mesh_quantization's (another would be misread).
        let (t, d) = (accessor.data_type(), accessor.dimensions());
        let fits = match semantic {
            gltf::Semantic::Positions | gltf::Semantic::TexCoords(_) => {
                matches!(t, DataType::F32 | DataType::I8 | DataType::U8 | DataType::I16 | DataType::U16)
                    && d == if semantic == gltf::Semantic::Positions { Dimensions::Vec3 } else { Dimensions::Vec2 }
            }
            gltf::Semantic::Normals => {
                matches!(t, DataType::F32 | DataType::I8 | DataType::I16) && d == Dimensions::Vec3
            }
            gltf::Semantic::Tangents => {
                matches!(t, DataType::F32 | DataType::I8 | DataType::I16) && d == Dimensions::Vec4
            }
            gltf::Semantic::Colors(_) => {
                matches!(t, DataType::F32 | DataType::U8 | DataType::U16)
                    && matches!(d, Dimensions::Vec3 | Dimensions::Vec4)
            }
            _ => true,
        };
        if !fits {
            return Err((path, format!("an accessor of {t:?} {d:?} cannot hold this attribute")));
        }
    }
    // The morph targets' displacements of positions, normals and tangents (all checked, whatever their weights).
    let weight = |t: usize| weights.get(t).copied().unwrap_or(0.0);
    for (t, target) in prim.morph_targets().enumerate() {
        for (name, accessor) in
            [("POSITION", target.positions()), ("NORMAL", target.normals()), ("TANGENT", target.tangents())]
        {
            let Some(accessor) = accessor else { continue };
            let path = format!("{json}.targets[{t}].{name}");
            check_accessor(&accessor, buffers, &path)?;
            let t = accessor.data_type();
            if !matches!(t, DataType::F32 | DataType::I8 | DataType::I16) || accessor.dimensions() != Dimensions::Vec3 {
                return Err((path, "a morph target's displacements must be VEC3 of floats, bytes or shorts".into()));
            }
        }
    }
    if let Some(indices) = prim.indices() {
        let path = format!("{json}.indices");
        check_accessor(&indices, buffers, &path)?;
        let (t, d) = (indices.data_type(), indices.dimensions());
        if !matches!(t, DataType::U8 | DataType::U16 | DataType::U32) || d != Dimensions::Scalar {
            return Err((path, format!("indices must be unsigned integer scalars, not {t:?} {d:?}")));
        }
    }
    let reader = prim.reader(|b| buffers.get(b.index()).map(|v| v.as_slice()));
    let attribute = |semantic: gltf::Semantic| prim.get(&semantic);
    let vec3s = |a: Option<gltf::Accessor<'_>>| -> Option<Vec<Vec3>> {
        a.and_then(|a| read_floats::<3>(&a, buffers)).map(|v| v.into_iter().map(Vec3::from).collect())
    };
    let mut positions: Vec<Vec3> = vec3s(attribute(gltf::Semantic::Positions))
        .ok_or_else(|| (format!("{json}.attributes.POSITION"), "a triangle primitive needs positions".to_string()))?;
    let n = positions.len();
    let mut normals: Option<Vec<Vec3>> = vec3s(attribute(gltf::Semantic::Normals));
    if normals.as_ref().is_some_and(|v| v.len() != n) {
        return Err((format!("{json}.attributes.NORMAL"), "as many normals as positions are needed".into()));
    }
    // Morph targets at their weights (glTF 2.0 §3.7.2.2): the base plus the weighted displacements; normals are
    // normalised after.
    let mut morphed_normals = false;
    for (t, target) in prim.morph_targets().enumerate() {
        let w = weight(t);
        if w == 0.0 {
            continue;
        }
        if let Some(dp) = vec3s(target.positions()) {
            if dp.len() != n {
                return Err((
                    format!("{json}.targets[{t}].POSITION"),
                    format!("{} displacements for {n} positions", dp.len()),
                ));
            }
            positions.iter_mut().zip(dp).for_each(|(p, d)| *p += w * d);
        }
        if let (Some(normals), Some(dn)) = (normals.as_mut(), vec3s(target.normals())) {
            if dn.len() != n {
                return Err((
                    format!("{json}.targets[{t}].NORMAL"),
                    format!("{} displacements for {n} normals", dn.len()),
                ));
            }
            normals.iter_mut().zip(dn).for_each(|(v, d)| *v += w * d);
            morphed_normals = true;
        }
    }
    if morphed_normals {
        normals.iter_mut().flatten().for_each(|v| *v = v.normalize_or_zero());
    }
    if positions.iter().any(|p| !p.is_finite()) {
        return Err((format!("{json}.attributes.POSITION"), "positions must be finite".into()));
    }
    let uvs: Option<Vec<Vec2>> = attribute(gltf::Semantic::TexCoords(0))
        .and_then(|a| read_floats::<2>(&a, buffers))
        .map(|v| v.into_iter().map(Vec2::from).collect());
    if uvs.as_ref().is_some_and(|v| v.len() != n) {
        return Err((
            format!("{json}.attributes.TEXCOORD_0"),
            "as many texture coordinates as positions are needed".into(),
        ));
    }
    let indices: Vec<u32> = match reader.read_indices() {
        Some(i) => i.into_u32().collect(),
        None => (0..n as u32).collect(),
    };
    if let Some(bad) = indices.iter().find(|&&i| i as usize >= n) {
        return Err((format!("{json}.indices"), format!("index {bad} points past the {n} vertices")));
    }
    if !indices.len().is_multiple_of(3) {
        return Err((format!("{json}.indices"), format!("{} indices are not whole triangles", indices.len())));
    }
    if indices.is_empty() {
        return Ok(None);
    }
    // Vertex colours are linear RGB (alpha, if stored, is not read), normalised integers mapped to [0, 1].
    let colors: Option<Vec<[f32; 3]>> = reader.read_colors(0).map(|c| c.into_rgb_f32().collect());
    if let Some(c) = &colors {
        if c.len() != n || c.iter().flatten().any(|v| !v.is_finite() || *v < 0.0) {
            return Err((
                format!("{json}.attributes.COLOR_0"),
                "as many finite, non-negative colours as positions are needed".into(),
            ));
        }
    }
    // glTF's uv origin is the image's top-left corner, pbrt's the bottom-left: v flips.
    let uvs: Option<Vec<Vec2>> = uvs.map(|v| v.into_iter().map(|t| Vec2::new(t.x, 1.0 - t.y)).collect());
    // Tangents where the material reads a tangent frame: the file's, else MikkTSpace's from the normals and
    // texture coordinates (without those, the renderer's ∂p/∂u).
    let tangents = if !tangents::material_needs_tangents(&prim.material()) {
        None
    } else if let Some(a) = attribute(gltf::Semantic::Tangents) {
        let path = format!("{json}.attributes.TANGENT");
        let t = read_floats::<4>(&a, buffers).ok_or_else(|| (path.clone(), "cannot be read".to_string()))?;
        if t.len() != n || t.iter().flatten().any(|v| !v.is_finite()) {
            return Err((path, "as many finite tangents as positions are needed".into()));
        }
        Some(tangents::from_vertices(&t, &indices))
    } else {
        match (&normals, &uvs) {
            // Non-finite values are the mesh data's error, reported when it is built.
            (Some(normals), Some(uvs))
                if normals.iter().all(|v| v.is_finite()) && uvs.iter().all(|v| v.is_finite()) =>
            {
                tangents::mikktspace(&positions, normals, uvs, &indices)
            }
            _ => None,
        }
    };
    Ok(Some((Arc::new(MeshData { positions, normals, uvs, indices }), colors.map(Arc::from), tangents.map(Arc::from))))
}

/// The instance transforms of a node with `EXT_mesh_gpu_instancing` (translation, rotation and scale per instance,
/// each applied in the node's space before its transform), or `None` for a node without it; errors as (JSON path,
/// message).
fn gpu_instances(
    document: &gltf::Document,
    node: &gltf::Node<'_>,
    buffers: &[Vec<u8>],
) -> Result<Option<Vec<Transform>>, (String, String)> {
    use gltf::accessor::{DataType, Dimensions};
    let Some(ext) = node.extensions().and_then(|e| e.get("EXT_mesh_gpu_instancing")) else { return Ok(None) };
    let json = format!("nodes[{}].extensions.EXT_mesh_gpu_instancing", node.index());
    let Some(attributes) = ext.get("attributes").and_then(serde_json::Value::as_object) else {
        return Err((format!("{json}.attributes"), "must be an object".into()));
    };
    let mut count = None;
    let mut read = |name: &str, dims: Dimensions| -> Result<Option<Vec<[f32; 4]>>, (String, String)> {
        let Some(index) = attributes.get(name) else { return Ok(None) };
        let path = format!("{json}.attributes.{name}");
        let accessor = index
            .as_u64()
            .and_then(|i| document.accessors().nth(usize::try_from(i).ok()?))
            .ok_or_else(|| (path.clone(), format!("must name one of the {} accessors", document.accessors().len())))?;
        check_accessor(&accessor, buffers, &path)?;
        let t = accessor.data_type();
        // Translation and scale are floats; a rotation may also be normalised bytes or shorts (quantized).
        let types_fit = t == DataType::F32 || (dims == Dimensions::Vec4 && matches!(t, DataType::I8 | DataType::I16));
        if accessor.dimensions() != dims || !types_fit {
            return Err((
                path,
                format!("an accessor of {t:?} {:?} cannot hold instance {name}s", accessor.dimensions()),
            ));
        }
        if *count.get_or_insert(accessor.count()) != accessor.count() {
            return Err((path, "every instance attribute needs one value per instance".into()));
        }
        let values: Option<Vec<[f32; 4]>> = if dims == Dimensions::Vec4 {
            read_floats::<4>(&accessor, buffers)
        } else {
            read_floats::<3>(&accessor, buffers).map(|v| v.into_iter().map(|[x, y, z]| [x, y, z, 0.0]).collect())
        };
        let values = values.ok_or_else(|| (path.clone(), "cannot be read".to_string()))?;
        if values.iter().flatten().any(|v| !v.is_finite()) {
            return Err((path, "values must be finite".into()));
        }
        Ok(Some(values))
    };
    let translations = read("TRANSLATION", Dimensions::Vec3)?;
    let rotations = read("ROTATION", Dimensions::Vec4)?;
    let scales = read("SCALE", Dimensions::Vec3)?;
    let Some(n) = count else { return Err((format!("{json}.attributes"), "names no instance attribute".into())) };
    let mut out = Vec::with_capacity(n);
    let xyz = |v: &[f32; 4]| glam::DVec3::new(f64::from(v[0]), f64::from(v[1]), f64::from(v[2]));
    for i in 0..n {
        let t = translations.as_ref().map_or(glam::DVec3::ZERO, |v| xyz(&v[i]));
        let r = rotations.as_ref().map_or(glam::DQuat::IDENTITY, |v| {
            glam::DQuat::from_vec4(glam::DVec4::from_array(v[i].map(f64::from))).normalize()
        });
        let s = scales.as_ref().map_or(glam::DVec3::ONE, |v| xyz(&v[i]));
        // An instance scaled to nothing (a way of hiding one) has nothing to draw: it is left out.
        if let Some(m) = Transform::from_matrix(glam::DMat4::from_scale_rotation_translation(s, r, t)) {
            out.push(m);
        }
    }
    Ok(Some(out))
}

/// The variant of named material `name` whose base colour is multiplied by the mesh's vertex colours (a
/// `vertexcolor` texture over the factor or the base colour texture), added as `{name}+COLOR_0`; its opaque part
/// for a transmissive mix. A material without a base colour (all glass) is returned unchanged.
fn vertex_color_material(desc: &mut SceneDescription, name: &str, loc: &Loc) -> String {
    let Some(entity) = desc.named_materials.iter().find(|(n, _)| n == name).map(|(_, e)| e.clone()) else {
        return name.to_string();
    };
    let colored = format!("{name}+COLOR_0");
    match entity.name.as_str() {
        "metallicroughness" => {
            let mut tex = ParamSet::new();
            match entity.params.get_texture("basecolor") {
                Some(t) => tex.push(texture_param("tex", &t, loc)),
                None => {
                    let rgb_value = entity.params.get_rgb("basecolor").ok().flatten().unwrap_or([1.0; 3]);
                    tex.push(rgb("tint", rgb_value, loc));
                }
            }
            let tname = format!("{name}/vertexcolor");
            desc.textures.push(scene::TextureEntity {
                entity: Entity::new("vertexcolor", tex, loc.clone()),
                texture_name: tname.clone(),
                value_type: TextureValueType::Spectrum,
                render_from_texture: Transform::IDENTITY,
            });
            let params = entity.params.params().iter().filter(|p| p.name != "basecolor").cloned().collect();
            let mut params = ParamSet::from_params(params);
            params.push(texture_param("basecolor", &tname, loc));
            desc.named_materials.push((colored.clone(), Entity::new("metallicroughness", params, loc.clone())));
            colored
        }
        "mix" => {
            let Some([opaque, glass]) =
                entity.params.get_strings("materials").and_then(|m| <[String; 2]>::try_from(m.to_vec()).ok())
            else {
                return name.to_string();
            };
            let opaque = vertex_color_material(desc, &opaque, loc);
            let params = entity.params.params().iter().filter(|p| p.name != "materials").cloned().collect();
            let mut params = ParamSet::from_params(params);
            params.push(strings("materials", &[opaque, glass], loc));
            desc.named_materials.push((colored.clone(), Entity::new("mix", params, loc.clone())));
            colored
        }
        _ => name.to_string(),
    }
}

fn param(ty: ParamType, name: &str, loc: &Loc) -> Param {
    Param::new(ty, name, loc.clone())
}

fn floats(ty: ParamType, name: &str, values: &[f64], loc: &Loc) -> Param {
    let mut p = param(ty, name, loc);
    p.floats = values.to_vec();
    p
}

fn float(name: &str, v: f64, loc: &Loc) -> Param {
    floats(ParamType::Float, name, &[v], loc)
}

fn ints(name: &str, values: &[i64], loc: &Loc) -> Param {
    let mut p = param(ParamType::Integer, name, loc);
    p.ints = values.to_vec();
    p
}

fn string(name: &str, v: &str, loc: &Loc) -> Param {
    let mut p = param(ParamType::String, name, loc);
    p.strings = vec![v.to_string()];
    p
}

fn strings(name: &str, v: &[String], loc: &Loc) -> Param {
    let mut p = param(ParamType::String, name, loc);
    p.strings = v.to_vec();
    p
}

fn boolean(name: &str, v: bool, loc: &Loc) -> Param {
    let mut p = param(ParamType::Bool, name, loc);
    p.bools = vec![v];
    p
}

fn rgb(name: &str, c: [f64; 3], loc: &Loc) -> Param {
    floats(ParamType::Rgb, name, &c, loc)
}

fn texture_param(name: &str, texture: &str, loc: &Loc) -> Param {
    let mut p = param(ParamType::Texture, name, loc);
    p.strings = vec![texture.to_string()];
    p
}

/// A number from a material's raw extension object (`extensions.NAME.KEY`).
fn extension_number(m: &gltf::Material<'_>, name: &str, key: &str) -> Option<f64> {
    m.extensions()?.get(name)?.get(key)?.as_f64()
}

/// Adds material `m` as named material `name` (and the parts a transmissive one is mixed from, and its textures,
/// named after it); returns the name of the medium inside it, for a transmissive material with
/// `KHR_materials_volume`'s attenuation.
fn add_material(t: &mut TextureMaker<'_>, name: &str, m: &gltf::Material<'_>) -> Result<Option<String>, GltfError> {
    let loc = t.loc.clone();
    let json = m.index().map_or("materials (the default)".to_string(), |i| format!("materials[{i}]"));
    let pbr = m.pbr_metallic_roughness();
    let [r, g, b, a] = pbr.base_color_factor().map(f64::from);
    let metallic = f64::from(pbr.metallic_factor());
    let roughness = f64::from(pbr.roughness_factor());
    let ior = m.ior().map_or(1.5, f64::from);
    let values = [r, g, b, a, metallic, roughness, ior];
    if values.iter().any(|v| !v.is_finite()) {
        return Err(GltfError { file: t.path.to_path_buf(), path: json, message: "factors must be finite".into() });
    }
    let (metallic, roughness, a) = (metallic.clamp(0.0, 1.0), roughness.clamp(0.0, 1.0), a.clamp(0.0, 1.0));
    let texture_json = |what: &str| format!("{json}.{what}");
    let mut opaque = ParamSet::new();
    // Base colour: the texture (sRGB) times the factor, uplifted as one RGB (glTF multiplies before shading).
    match pbr.base_color_texture() {
        Some(info) => {
            let tex = TextureRef::info(&info, texture_json("pbrMetallicRoughness.baseColorTexture"));
            let tname = format!("{name}/basecolor");
            let extra = vec![rgb("tint", [r, g, b], &loc), string("encoding", "sRGB", &loc)];
            t.imagemap(&tname, TextureValueType::Spectrum, &tex, extra)?;
            opaque.push(texture_param("basecolor", &tname, &loc));
            if m.alpha_mode() != gltf::material::AlphaMode::Opaque {
                // The texture's alpha (linear) times the factor's; MASK compares it with the cutoff.
                let blend = format!("{name}/alpha");
                let coverage = match m.alpha_mode() {
                    gltf::material::AlphaMode::Mask => format!("{name}/alpha/coverage"),
                    gltf::material::AlphaMode::Blend | gltf::material::AlphaMode::Opaque => blend.clone(),
                };
                let extra =
                    vec![string("channel", "a", &loc), float("scale", a, &loc), string("encoding", "linear", &loc)];
                t.imagemap(&coverage, TextureValueType::Float, &tex, extra)?;
                if coverage != blend {
                    let mut p = ParamSet::new();
                    p.push(texture_param("tex", &coverage, &loc));
                    p.push(float("cutoff", f64::from(m.alpha_cutoff().unwrap_or(0.5)), &loc));
                    t.desc.textures.push(scene::TextureEntity {
                        entity: Entity::new("threshold", p, loc.clone()),
                        texture_name: blend,
                        value_type: TextureValueType::Float,
                        render_from_texture: Transform::IDENTITY,
                    });
                }
            }
        }
        None => opaque.push(rgb("basecolor", [r, g, b], &loc)),
    }
    // Metalness in the blue channel and roughness in the green one, linear, times the factors.
    match pbr.metallic_roughness_texture() {
        Some(info) => {
            let tex = TextureRef::info(&info, texture_json("pbrMetallicRoughness.metallicRoughnessTexture"));
            for (param_name, channel, factor) in [("metallic", "b", metallic), ("roughness", "g", roughness)] {
                let tname = format!("{name}/{param_name}");
                let extra = vec![
                    string("channel", channel, &loc),
                    float("scale", factor, &loc),
                    string("encoding", "linear", &loc),
                ];
                t.imagemap(&tname, TextureValueType::Float, &tex, extra)?;
                opaque.push(texture_param(param_name, &tname, &loc));
            }
        }
        None => {
            opaque.push(float("metallic", metallic, &loc));
            opaque.push(float("roughness", roughness, &loc));
        }
    }
    // KHR_materials_ior: 0 is infinite (the specular-glossiness mode, whose Fresnel term is 1); else at least 1.
    opaque.push(float("ior", if ior == 0.0 { 0.0 } else { ior.max(1.0) }, &loc));
    let mut glass_film = vec![];
    layers::add_layers(t, name, m, &json, &mut opaque, &mut glass_film)?;
    // The normal map tilts the shading normal of every part (the glass too).
    let mut normal_map = vec![];
    if let Some(info) = m.normal_texture() {
        let tex = TextureRef::normal(&info, texture_json("normalTexture"));
        let tname = format!("{name}/normal");
        t.imagemap(&tname, TextureValueType::Spectrum, &tex, vec![string("encoding", "linear", &loc)])?;
        normal_map.push(texture_param("normalmap", &tname, &loc));
        normal_map.push(float("normalscale", f64::from(info.scale()), &loc));
    }
    if m.occlusion_texture().is_some() {
        t.desc.warnings.push(Diagnostic::new(
            loc.clone(),
            format!("{json}.occlusionTexture is ignored: tracing light computes occlusion, which the texture bakes"),
        ));
    }
    // The emissive texture (sRGB) times the emission, which the area light reads (`emission`).
    if let (Some(info), Some(e)) = (m.emissive_texture(), emissive_rgb(m)) {
        let tex = TextureRef::info(&info, texture_json("emissiveTexture"));
        let extra = vec![rgb("tint", e, &loc), string("encoding", "sRGB", &loc)];
        t.imagemap(&format!("{name}/emission"), TextureValueType::Spectrum, &tex, extra)?;
    }
    for p in &normal_map {
        opaque.push(p.clone());
    }
    let opaque = Entity::new("metallicroughness", opaque, loc.clone());
    let transmission_ext = m.transmission();
    let transmission = transmission_ext.as_ref().map_or(0.0, |x| f64::from(x.transmission_factor())).clamp(0.0, 1.0);
    // Transmission applies to the dielectric part only: the metal never transmits.
    let amount = transmission * (1.0 - metallic);
    if amount <= 0.0 {
        t.desc.named_materials.push((name.to_string(), opaque));
        return Ok(None);
    }
    let mut glass = ParamSet::new();
    glass.push(float("eta", ior.max(1.0), &loc));
    if let Some(d) = extension_number(m, "KHR_materials_dispersion", "dispersion").filter(|d| *d > 0.0) {
        // KHR_materials_dispersion: V_d = 20 / dispersion, with n_d the material's ior.
        glass.push(float("abbe", 20.0 / d, &loc));
    }
    // GGX α = roughness², given directly.
    glass.push(float("roughness", roughness * roughness, &loc));
    glass.push(boolean("remaproughness", false, &loc));
    for p in normal_map.into_iter().chain(glass_film) {
        glass.push(p);
    }
    // The specification's transmission BTDF is multiplied by the base colour (KHR_materials_transmission,
    // "specular_btdf(α) * baseColor"): light is tinted at each crossing of the surface.
    if pbr.base_color_texture().is_some() {
        glass.push(texture_param("transmissiontint", &format!("{name}/basecolor"), &loc));
    } else if [r, g, b] != [1.0; 3] {
        glass.push(rgb("transmissiontint", [r, g, b], &loc));
    }
    let mut medium = None;
    if let Some(v) = m.volume() {
        let distance = f64::from(v.attenuation_distance());
        if distance.is_finite() && distance > 0.0 {
            // Beer–Lambert: the attenuation colour is what remains after `attenuationDistance` metres, so
            // σa = −ln(c)/d per channel (uplifted as an unbounded RGB); no scattering. (`thickness` is a hint for
            // rasterisers, which have no volume to trace.)
            let c = v.attenuation_color().map(|c| f64::from(c).clamp(1e-6, 1.0));
            let mut params = ParamSet::new();
            params.push(rgb("sigma_a", c.map(|c| -c.ln() / distance), &loc));
            params.push(rgb("sigma_s", [0.0; 3], &loc));
            let medium_name = format!("{name}/volume");
            t.desc.media.push(MediumEntity {
                entity: Entity::new("homogeneous", params, loc.clone()),
                medium_name: medium_name.clone(),
                render_from_medium: Transform::IDENTITY,
            });
            medium = Some(medium_name);
        }
    }
    let glass = Entity::new("dielectric", glass, loc.clone());
    // The transmission texture's red channel scales the factor.
    let amount_texture = transmission_ext.as_ref().and_then(|x| x.transmission_texture());
    if amount >= 1.0 && amount_texture.is_none() {
        t.desc.named_materials.push((name.to_string(), glass));
        return Ok(medium);
    }
    let (opaque_name, glass_name) = (format!("{name}/opaque"), format!("{name}/transmission"));
    t.desc.named_materials.push((opaque_name.clone(), opaque));
    t.desc.named_materials.push((glass_name.clone(), glass));
    let mut mix = ParamSet::new();
    mix.push(strings("materials", &[opaque_name, glass_name], &loc));
    match amount_texture {
        Some(info) => {
            let tex =
                TextureRef::info(&info, texture_json("extensions.KHR_materials_transmission.transmissionTexture"));
            let tname = format!("{name}/transmissionamount");
            let extra =
                vec![string("channel", "r", &loc), float("scale", amount, &loc), string("encoding", "linear", &loc)];
            t.imagemap(&tname, TextureValueType::Float, &tex, extra)?;
            mix.push(texture_param("amount", &tname, &loc));
        }
        None => mix.push(float("amount", amount, &loc)),
    }
    t.desc.named_materials.push((name.to_string(), Entity::new("mix", mix, loc.clone())));
    Ok(medium)
}

/// A primitive's `alpha` under its material's `alphaMode`, if it is not opaque: with a base colour texture, the
/// texture's alpha times the factor's, which the material made as `{material}/alpha` (MASK's cutoff applied by a
/// `threshold` texture); without one, the factor's alpha as a constant (MASK keeps or drops the whole primitive).
/// BLEND is stochastic transparency, pbrt's `alpha`.
fn alpha_param(m: &gltf::Material<'_>, material_name: &str, loc: &Loc) -> Option<Param> {
    if m.alpha_mode() == gltf::material::AlphaMode::Opaque {
        return None;
    }
    if m.pbr_metallic_roughness().base_color_texture().is_some() {
        return Some(texture_param("alpha", &format!("{material_name}/alpha"), loc));
    }
    let a = f64::from(m.pbr_metallic_roughness().base_color_factor()[3]).clamp(0.0, 1.0);
    let alpha = match m.alpha_mode() {
        gltf::material::AlphaMode::Opaque => 1.0,
        gltf::material::AlphaMode::Mask => {
            if a >= f64::from(m.alpha_cutoff().unwrap_or(0.5)) {
                1.0
            } else {
                0.0
            }
        }
        gltf::material::AlphaMode::Blend => a,
    };
    (alpha < 1.0).then(|| float("alpha", alpha, loc))
}

/// An emissive material's emission (emissive factor × `KHR_materials_emissive_strength`), if it has any.
fn emissive_rgb(m: &gltf::Material<'_>) -> Option<[f64; 3]> {
    let strength = f64::from(m.emissive_strength().unwrap_or(1.0));
    let e = m.emissive_factor().map(|c| f64::from(c) * strength);
    (e.iter().all(|c| c.is_finite()) && e.iter().any(|&c| c > 0.0)).then_some(e)
}

/// The area light of an emissive material named `material_name`, if any: its emission, times its emissive texture
/// (made with the material as `{material_name}/emission`) when it has one.
fn emission(m: &gltf::Material<'_>, material_name: &str, loc: &Loc) -> Option<Entity> {
    let e = emissive_rgb(m)?;
    let mut params = ParamSet::new();
    if m.emissive_texture().is_some() {
        params.push(texture_param("L", &format!("{material_name}/emission"), loc));
    } else {
        params.push(rgb("L", e, loc));
    }
    // glTF emission is one-sided, on the side of the normal, as pbrt's diffuse area light.
    Some(Entity::new("diffuse", params, loc.clone()))
}

/// A `KHR_lights_punctual` light as a `LightSource`: lights shine down their node's −Z.
fn light_entity(light: &gltf::khr_lights_punctual::Light<'_>, world: Transform, loc: &Loc) -> LightEntity {
    let color = light.color().map(f64::from);
    let intensity = f64::from(light.intensity());
    let mut params = ParamSet::new();
    let name = match light.kind() {
        gltf::khr_lights_punctual::Kind::Directional => {
            params.push(rgb("L", color, loc));
            params.push(floats(ParamType::Point3, "from", &[0.0, 0.0, 0.0], loc));
            params.push(floats(ParamType::Point3, "to", &[0.0, 0.0, -1.0], loc));
            "distant"
        }
        gltf::khr_lights_punctual::Kind::Point => {
            params.push(rgb("I", color, loc));
            "point"
        }
        gltf::khr_lights_punctual::Kind::Spot { inner_cone_angle, outer_cone_angle } => {
            params.push(rgb("I", color, loc));
            params.push(floats(ParamType::Point3, "from", &[0.0, 0.0, 0.0], loc));
            params.push(floats(ParamType::Point3, "to", &[0.0, 0.0, -1.0], loc));
            let (inner, outer) = (f64::from(inner_cone_angle).to_degrees(), f64::from(outer_cone_angle).to_degrees());
            params.push(float("coneangle", outer, loc));
            params.push(float("conedeltaangle", (outer - inner).max(0.0), loc));
            "spot"
        }
    };
    // Candela (or lux) over 683 lm/W: the light's luminance-weighted intensity in W/sr (or W/m²), which pbrt-v4's
    // `scale` sets for a spectrum normalised to unit luminance.
    params.push(float("scale", intensity / LUMENS_PER_WATT, loc));
    LightEntity { entity: Entity::new(name, params, loc.clone()), render_from_light: world, medium: None }
}

/// The camera `options` asks for among `cameras` (None when the file has none).
fn choose_camera(
    cameras: &[PlacedCamera],
    options: &ReadOptions,
    path: &Path,
) -> Result<Option<PlacedCamera>, GltfError> {
    let Some(want) = &options.camera else { return Ok(cameras.first().cloned()) };
    let found = cameras
        .iter()
        .find(|c| c.name.as_deref() == Some(want.as_str()))
        .or_else(|| want.parse::<usize>().ok().and_then(|i| cameras.iter().find(|c| c.index == i)));
    match found {
        Some(c) => Ok(Some(c.clone())),
        None => {
            let names: Vec<String> =
                cameras.iter().map(|c| format!("{} ({})", c.index, c.name.as_deref().unwrap_or("unnamed"))).collect();
            Err(GltfError {
                file: path.to_path_buf(),
                path: "cameras".into(),
                message: format!(
                    "no camera named or numbered '{want}'; the scene's cameras: {}",
                    if names.is_empty() { "none".into() } else { names.join(", ") }
                ),
            })
        }
    }
}

/// An environment light from the image at `path` (EXR, Radiance HDR or PFM; a 2:1 latitude–longitude map or a square equal-area
/// one), scaled by `strength`, for the command line's `--env`. With `y_up` (glTF scenes) the map's top is +y, else
/// +z (pbrt-v4's convention).
pub fn environment_light(path: &Path, strength: f64, y_up: bool) -> LightEntity {
    let loc = Loc::new(Arc::from(path), 0, 0);
    let mut params = ParamSet::new();
    params.push(string("filename", &path.display().to_string(), &loc));
    params.push(float("scale", strength, &loc));
    // The map's +z (its top row) turned to +y: a rotation of -90 degrees about x.
    let render_from_light = if y_up {
        Transform::rotate(-90.0, DVec3::X).expect("a rotation about a unit axis")
    } else {
        Transform::IDENTITY
    };
    LightEntity { entity: Entity::new("infinite", params, loc), render_from_light, medium: None }
}

/// The pbrt-v4 camera of a glTF one and its aspect ratio, if it gives one.
fn camera_entity(model: &CameraModel, loc: Loc) -> (Entity, Option<f64>) {
    let mut params = ParamSet::new();
    match *model {
        CameraModel::Perspective { yfov, aspect } => {
            // pbrt's fov spans the shorter side: the vertical one for a landscape image, else the horizontal one.
            let fov = match aspect {
                Some(a) if a < 1.0 => 2.0 * ((yfov / 2.0).tan() * a).atan(),
                _ => yfov,
            };
            params.push(float("fov", fov.to_degrees(), &loc));
            (Entity::new("perspective", params, loc), aspect)
        }
        CameraModel::Orthographic { xmag, ymag } => {
            params.push(floats(ParamType::Float, "screenwindow", &[-xmag, xmag, -ymag, ymag], &loc));
            (Entity::new("orthographic", params, loc), Some(xmag / ymag))
        }
    }
}

/// A camera looking at the scene's bounds from +z (glTF's front) with a 40° field of view, and the warning that says
/// so.
fn framing_camera(desc: &SceneDescription, loc: Loc) -> (CameraEntity, String) {
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for s in &desc.shapes {
        let Some(index) = s.entity.params.get_ints("mesh").and_then(|i| i.first()) else { continue };
        let Some(mesh) = desc.meshes.get(*index as usize) else { continue };
        for p in &mesh.positions {
            let w = s.render_from_object.point(p.as_dvec3());
            lo = lo.min(w);
            hi = hi.max(w);
        }
    }
    let (centre, radius) =
        if lo.x <= hi.x { ((lo + hi) / 2.0, ((hi - lo).length() / 2.0).max(1e-3)) } else { (DVec3::ZERO, 1.0) };
    let fov = 40f64;
    let distance = radius / (fov.to_radians() / 2.0).sin();
    let eye = centre + DVec3::new(0.0, 0.0, distance);
    let mut params = ParamSet::new();
    params.push(float("fov", fov, &loc));
    let camera_from_world = Transform::look_at(eye, centre, DVec3::Y)
        .map(|t| Transform::scale(DVec3::new(-1.0, 1.0, 1.0)).expect("a reflection is invertible").then_after(&t))
        .unwrap_or(Transform::IDENTITY);
    let camera =
        CameraEntity { entity: Entity::new("perspective", params, loc), camera_from_world, medium: None, motion: None };
    (
        camera,
        format!("the file has no camera: one looks at the scene's bounds from +z, {distance:.3} m from their centre"),
    )
}

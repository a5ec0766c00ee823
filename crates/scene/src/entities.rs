//! The entities of a scene and the description that holds them.

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use geometry::Transform;

use crate::loc::{Diagnostic, Loc};
use crate::params::ParamSet;

/// Something a directive creates: a type name (`"perspective"`, `"diffuse"`, `"trianglemesh"`, …), its parameters,
/// and where it was written.
#[derive(Clone, Debug, PartialEq)]
pub struct Entity {
    /// The type name, e.g. `"perspective"`, `"diffuse"`, `"sphere"`, `"imagemap"`.
    pub name: String,
    /// The parameters (including applicable `Attribute` defaults, marked `may_be_unused`).
    pub params: ParamSet,
    /// Where the directive was written (line 0 for a built-in default).
    pub loc: Loc,
}

impl Entity {
    /// An entity of type `name` with parameters `params`, written at `loc`.
    pub fn new(name: impl Into<String>, params: ParamSet, loc: Loc) -> Self {
        Self { name: name.into(), params, loc }
    }

    /// A built-in default entity with no parameters (the renderer applies per-parameter defaults).
    pub fn builtin(name: impl Into<String>, file: Arc<Path>) -> Self {
        Self { name: name.into(), params: ParamSet::new(), loc: Loc::builtin(file) }
    }
}

/// The far end of a transform that moves while the shutter is open (pbrt-v4's `ActiveTransform` and
/// `TransformTimes`): the entity's ordinary transform holds at `start_time`, `end` at `end_time`, and the renderer
/// interpolates in between. Recorded only when the two ends differ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TransformMotion {
    /// The transform at `end_time` (same meaning as the entity's transform at `start_time`).
    pub end: Transform,
    /// When the entity's ordinary transform holds (`TransformTimes`' first value, default 0).
    pub start_time: f64,
    /// When `end` holds (`TransformTimes`' second value, default 1).
    pub end_time: f64,
}

/// The camera: its entity, where it sits, and the medium it sees through.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraEntity {
    /// Type (`"perspective"`, `"orthographic"`, `"realistic"`, `"spherical"`) and parameters.
    pub entity: Entity,
    /// World space to pbrt's left-handed camera space (the current transform at the `Camera` directive).
    pub camera_from_world: Transform,
    /// The exterior medium in effect at the `Camera` directive.
    pub medium: Option<String>,
    /// The camera-from-world transform at the end time, if the camera moves.
    pub motion: Option<TransformMotion>,
}

/// Which material a shape uses.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum MaterialRef {
    /// An index into [`SceneDescription::materials`] (anonymous `Material` directives, and the default at index 0).
    Anonymous(usize),
    /// A name from [`SceneDescription::named_materials`] (`NamedMaterial`).
    Named(String),
}

/// A shape and the graphics state it was created under.
#[derive(Clone, Debug, PartialEq)]
pub struct ShapeEntity {
    /// Type (`"trianglemesh"`, `"plymesh"`, `"sphere"`, …) and parameters.
    pub entity: Entity,
    /// Object space to world space; inside an object definition, object space to the instance's space (the full
    /// current transform at the `Shape`, as pbrt-v4 records it).
    pub render_from_object: Transform,
    /// True if `ReverseOrientation` was in effect (an odd number of times).
    pub reverse_orientation: bool,
    /// The material in effect.
    pub material: MaterialRef,
    /// The `AreaLightSource` in effect, making the shape emissive.
    pub area_light: Option<Entity>,
    /// The interior medium (`MediumInterface` first name), if any.
    pub inside_medium: Option<String>,
    /// The exterior medium (`MediumInterface` second name), if any.
    pub outside_medium: Option<String>,
    /// `render_from_object` at the end time, if the shape moves.
    pub motion: Option<TransformMotion>,
}

/// What a texture evaluates to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TextureValueType {
    /// A scalar (`Texture "name" "float" …`).
    Float,
    /// A spectrum (`Texture "name" "spectrum" …`).
    Spectrum,
}

/// A named texture. Float and spectrum textures have separate name spaces, as in pbrt.
#[derive(Clone, Debug, PartialEq)]
pub struct TextureEntity {
    /// Class (`"imagemap"`, `"checkerboard"`, `"constant"`, `"scale"`, `"mix"`, …) and parameters.
    pub entity: Entity,
    /// The name materials refer to it by.
    pub texture_name: String,
    /// Float or spectrum.
    pub value_type: TextureValueType,
    /// Texture space to world space.
    pub render_from_texture: Transform,
}

/// A light source (`LightSource`; area lights are attached to shapes instead).
#[derive(Clone, Debug, PartialEq)]
pub struct LightEntity {
    /// Type (`"point"`, `"spot"`, `"distant"`, `"infinite"`, …) and parameters.
    pub entity: Entity,
    /// Light space to world space.
    pub render_from_light: Transform,
    /// The exterior medium in effect.
    pub medium: Option<String>,
}

/// A participating medium (`MakeNamedMedium`).
#[derive(Clone, Debug, PartialEq)]
pub struct MediumEntity {
    /// Type (the value of its `"string type"`, e.g. `"homogeneous"`) and parameters (`"string type"` kept,
    /// marked used).
    pub entity: Entity,
    /// The name shapes and the camera refer to it by.
    pub medium_name: String,
    /// Medium space to world space.
    pub render_from_medium: Transform,
}

/// An object definition (`ObjectBegin` … `ObjectEnd`).
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectDefinition {
    /// The name instances refer to.
    pub name: String,
    /// The shapes, with transforms as pbrt-v4 records them (see [`ShapeEntity::render_from_object`]).
    pub shapes: Vec<ShapeEntity>,
    /// Where `ObjectBegin` was written.
    pub loc: Loc,
}

/// A use of an object definition (`ObjectInstance`).
#[derive(Clone, Debug, PartialEq)]
pub struct InstanceUse {
    /// The object's name (checked to be defined).
    pub name: String,
    /// Instance space to world space (the current transform at `ObjectInstance`).
    pub render_from_instance: Transform,
    /// Where `ObjectInstance` was written.
    pub loc: Loc,
    /// `render_from_instance` at the end time, if the instance moves.
    pub motion: Option<TransformMotion>,
}

/// A global rendering option (`Option "name" value`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct OptionEntry {
    /// The option's name as written (a pbrt-v4 `"type name"` declaration is reduced to the name).
    pub name: String,
    /// The value, as written (quotes removed from a string).
    pub value: String,
    /// Where it was written.
    pub loc: Loc,
}

/// Everything a scene file describes. Directives that were absent are pbrt-v4's defaults as parameterless
/// entities: perspective camera, `rgb` film, `zsobol` sampler, `volpath` integrator, `gaussian` filter.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneDescription {
    /// The main scene file.
    pub file: Arc<Path>,
    /// The camera.
    pub camera: CameraEntity,
    /// The film (`"rgb"`, `"spectral"`, `"gbuffer"`).
    pub film: Entity,
    /// The sampler.
    pub sampler: Entity,
    /// The integrator.
    pub integrator: Entity,
    /// The pixel filter.
    pub filter: Entity,
    /// The accelerator, if one was named.
    pub accelerator: Option<Entity>,
    /// The colour space `rgb` values are in (only `"srgb"` is accepted).
    pub color_space: String,
    /// Anonymous materials; index 0 is pbrt's default, a `"diffuse"` with no parameters (reflectance 0.5).
    pub materials: Vec<Entity>,
    /// Named materials, in definition order; each entity's name is its `"string type"`.
    pub named_materials: Vec<(String, Entity)>,
    /// Textures, in definition order.
    pub textures: Vec<TextureEntity>,
    /// Light sources other than area lights.
    pub lights: Vec<LightEntity>,
    /// Named media.
    pub media: Vec<MediumEntity>,
    /// Shapes outside object definitions.
    pub shapes: Vec<ShapeEntity>,
    /// Object definitions.
    pub objects: Vec<ObjectDefinition>,
    /// Object instances.
    pub instances: Vec<InstanceUse>,
    /// Triangle meshes a reader decoded whole (glTF's primitives), which `importedmesh` shapes name by their index
    /// in `"integer mesh"`; shared by every shape that places the same mesh.
    pub meshes: Vec<Arc<geometry::MeshData>>,
    /// Images a reader found inside a file (glTF's textures in its binary chunk or data URIs, and the files it
    /// names), still encoded; `imagemap` textures name them by index in `"integer image"`.
    pub images: Vec<EmbeddedImage>,
    /// Per-vertex linear RGB colours of imported meshes (glTF's `COLOR_0`), which an `importedmesh` shape names by
    /// index in `"integer vertexcolors"`: one colour per vertex of its mesh.
    pub vertex_colors: Vec<Arc<[[f32; 3]]>>,
    /// Shading tangents of imported meshes per face corner (glTF's `TANGENT`, or MikkTSpace's where a normal map or
    /// anisotropy needs them), which an `importedmesh` shape names by index in `"integer tangents"`: three per
    /// triangle of its mesh, in the order of its indices.
    pub corner_tangents: Vec<Arc<[[f32; 3]]>>,
    /// `Option` directives.
    pub options: Vec<OptionEntry>,
    /// Warnings from parsing (deprecated or ignored directives, …). Unused parameters are reported later, by
    /// [`SceneDescription::unused_parameters`], once the renderer has read what it understands.
    pub warnings: Vec<Diagnostic>,
    /// Every file the parser read, in the order read: the main file, `Include`d and `Import`ed files, spectrum
    /// files (what a checkpoint's scene hash covers, with the files the builder reads).
    pub files: Vec<PathBuf>,
}

/// An encoded image (PNG or JPEG bytes) that a reader took out of a scene file, and what errors call it.
#[derive(Clone, Debug, PartialEq)]
pub struct EmbeddedImage {
    /// Where it came from, for messages: `model.glb#images[2]`.
    pub name: String,
    /// The encoded bytes, shared by the textures that read them.
    pub bytes: Arc<[u8]>,
}

impl SceneDescription {
    /// pbrt-v4's defaults for a scene read from `file`: no shapes, lights or materials besides the default one.
    pub fn new(file: Arc<Path>) -> Self {
        let b = |n: &str| Entity::builtin(n, file.clone());
        Self {
            camera: CameraEntity {
                entity: b("perspective"),
                camera_from_world: Transform::IDENTITY,
                medium: None,
                motion: None,
            },
            film: b("rgb"),
            sampler: b("zsobol"),
            integrator: b("volpath"),
            filter: b("gaussian"),
            accelerator: None,
            color_space: "srgb".to_owned(),
            materials: vec![b("diffuse")],
            named_materials: Vec::new(),
            textures: Vec::new(),
            lights: Vec::new(),
            media: Vec::new(),
            shapes: Vec::new(),
            objects: Vec::new(),
            instances: Vec::new(),
            meshes: Vec::new(),
            images: Vec::new(),
            vertex_colors: Vec::new(),
            corner_tangents: Vec::new(),
            options: Vec::new(),
            warnings: Vec::new(),
            files: Vec::new(),
            file,
        }
    }

    /// The named material called `name`.
    pub fn named_material(&self, name: &str) -> Option<&Entity> {
        self.named_materials.iter().find(|(n, _)| n == name).map(|(_, e)| e)
    }

    /// The material a shape refers to.
    pub fn material(&self, r: &MaterialRef) -> Option<&Entity> {
        match r {
            MaterialRef::Anonymous(i) => self.materials.get(*i),
            MaterialRef::Named(n) => self.named_material(n),
        }
    }

    /// The object definition called `name`.
    pub fn object(&self, name: &str) -> Option<&ObjectDefinition> {
        self.objects.iter().find(|o| o.name == name)
    }

    /// The medium called `name`.
    pub fn medium(&self, name: &str) -> Option<&MediumEntity> {
        self.media.iter().find(|m| m.medium_name == name)
    }

    /// Every entity's parameter list, each once (area lights shared by several shapes appear once per shape).
    pub fn param_sets(&self) -> Vec<&ParamSet> {
        let mut v = vec![&self.camera.entity.params, &self.film.params, &self.sampler.params];
        v.extend([&self.integrator.params, &self.filter.params]);
        v.extend(self.accelerator.iter().map(|e| &e.params));
        v.extend(self.materials.iter().map(|e| &e.params));
        v.extend(self.named_materials.iter().map(|(_, e)| &e.params));
        v.extend(self.textures.iter().map(|t| &t.entity.params));
        v.extend(self.lights.iter().map(|l| &l.entity.params));
        v.extend(self.media.iter().map(|m| &m.entity.params));
        let shapes = self.shapes.iter().chain(self.objects.iter().flat_map(|o| o.shapes.iter()));
        for s in shapes {
            v.push(&s.entity.params);
            v.extend(s.area_light.iter().map(|a| &a.params));
        }
        v
    }

    /// Every input file of the scene: the files the parser read ([`SceneDescription::files`]), then the files named
    /// by parameters the renderer read as file names (PLY meshes, image textures, environment maps, …), each once,
    /// in that order. Complete once the scene has been built.
    pub fn input_files(&self) -> Vec<PathBuf> {
        let mut seen = HashSet::new();
        let mut out = Vec::new();
        let named = self.param_sets().into_iter().flat_map(|set| set.files_read());
        for f in self.files.iter().cloned().chain(named) {
            if seen.insert(f.clone()) {
                out.push(f);
            }
        }
        out
    }

    /// "unused parameter" warnings over the whole scene, each parameter once, in file order. Call it after the
    /// renderer has read every parameter it understands.
    pub fn unused_parameters(&self) -> Vec<Diagnostic> {
        let mut seen = HashSet::new();
        let mut out: Vec<Diagnostic> = Vec::new();
        for set in self.param_sets() {
            for d in set.unused() {
                if seen.insert((d.loc.clone(), d.message.clone())) {
                    out.push(d);
                }
            }
        }
        out.sort_by(|a, b| {
            (a.loc.file.as_ref(), a.loc.line, a.loc.column).cmp(&(b.loc.file.as_ref(), b.loc.line, b.loc.column))
        });
        out
    }
}

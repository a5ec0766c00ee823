//! From a scene description to a render-ready scene: materials, textures, lights (with pbrt-v4's photometric
//! normalisation), shapes into the two-level BVH, media, camera, film, sampler and integrator settings.

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Arc;

use film::{FilmKind, FilmSpec, Filter, PixelSensor};
use geometry::mesh::BilinearMeshData;
use geometry::subdiv::loop_subdivide;
use geometry::{BilinearMesh, GeometryScene, Instance, MeshData, Object, Shape, Transform, TriangleMesh};
use glam::{DVec3, Vec2, Vec3};
use scene::{
    Entity, FloatParam, Loc, MaterialRef, ParamSet, ParamType, SceneDescription, SceneError, ShapeEntity, SpectrumKind,
    SpectrumParam, TextureValueType,
};
use spectral::rgb_uplift::RgbIlluminantSpectrum;
use spectral::{Distribution2D, Observer, RgbColorSpace, Spectrum};

use crate::camera::{Camera, Projection, ScreenWindow};
use crate::integrator::{Integrator, PathIntegrator};
use crate::light::{EnvironmentMap, Light};
use crate::lightpath::LightPathIntegrator;
use crate::material::{ConductorSpec, DielectricIor, LayerMedium, Material, Roughness};
use crate::sampling::Frame;
use crate::scene::{AbsorbingMedium, MediumInterface, RenderScene, SceneGeometry, ShapeInfo, NO_MATERIAL};
use crate::sppm::SppmIntegrator;
use crate::texture::{FloatTexture, RgbImage, RgbKind, SpectrumTexture, UvMapping};

/// Command-line overrides of the scene's settings.
#[derive(Clone, Debug, Default)]
pub struct BuildOptions {
    /// Film resolution instead of the scene's.
    pub resolution: Option<(u32, u32)>,
    /// Samples per pixel instead of the scene's.
    pub spp: Option<u32>,
    /// Output file instead of the film's `filename`.
    pub output: Option<PathBuf>,
}

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
}

type Result<T> = std::result::Result<T, SceneError>;

fn err<T>(loc: &Loc, message: impl Into<String>) -> Result<T> {
    Err(SceneError::at(loc.clone(), message))
}

fn finite_positive(loc: &Loc, name: &str, v: f64) -> Result<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        err(loc, format!("'{name}' must be a positive number, got {v}"))
    }
}

/// Luminance Y of a spectrum in our convention (Y = 1 for a constant 1); for an RGB illuminant only the
/// illuminant counts, as pbrt-v4's `SpectrumToPhotometric` does.
fn photometric(s: &Spectrum) -> f64 {
    match s {
        Spectrum::RgbIlluminant(_) => 1.0, // the colour space illuminant is normalised to Y = 1
        other => Observer::Cie1931.spectrum_to_xyz(other).y,
    }
}

/// Scales an emission spectrum so that `scale` is its luminance in nits (pbrt-v4: `scale /= SpectrumToPhotometric`).
fn normalise_emission(loc: &Loc, s: Spectrum, scale: f64) -> Result<Spectrum> {
    let y = photometric(&s);
    if y.is_nan() || y <= 0.0 {
        return err(loc, "emission spectrum has no luminance (it is zero across the visible range)");
    }
    if !scale.is_finite() || scale < 0.0 {
        return err(loc, format!("emission scale must be a finite non-negative number, got {scale}"));
    }
    let scaled = s.scaled(scale / y);
    // Radiance is carried in f32: anything near its range would overflow along a path.
    let peak = scaled.max_value();
    if peak.is_nan() || peak >= 1e30 {
        return err(loc, format!("emission is too large ('scale'/'power' give a peak of {:e})", scaled.max_value()));
    }
    Ok(scaled)
}

struct Textures {
    float: HashMap<String, FloatTexture>,
    spectrum: HashMap<String, (SpectrumTexture, SpectrumTexture)>, // (albedo, unbounded) variants
}

fn uv_mapping(p: &ParamSet) -> Result<UvMapping> {
    let mapping = p.get_string("mapping", "uv")?;
    if mapping != "uv" {
        let loc = p.get("mapping").map(|q| q.loc.clone()).unwrap_or_else(|| Loc::builtin(Arc::from(PathBuf::new())));
        return err(&loc, format!("texture mapping '{mapping}' is not supported (only \"uv\")"));
    }
    Ok(UvMapping {
        su: p.get_float("uscale", 1.0)? as f32,
        sv: p.get_float("vscale", 1.0)? as f32,
        du: p.get_float("udelta", 0.0)? as f32,
        dv: p.get_float("vdelta", 0.0)? as f32,
    })
}

fn load_image(p: &ParamSet, loc: &Loc) -> Result<Arc<RgbImage>> {
    let Some(path) = p.get_filename("filename")? else { return err(loc, "imagemap needs a 'string filename'") };
    let (w, h, pixels) = film::read_rgb(&path)
        .map_err(|e| SceneError::at(loc.clone(), format!("cannot read image {}: {e}", path.display())))?;
    Ok(Arc::new(RgbImage { width: w as usize, height: h as usize, pixels }))
}

impl Textures {
    fn build(desc: &SceneDescription) -> Result<Self> {
        let mut t = Textures { float: HashMap::new(), spectrum: HashMap::new() };
        for te in &desc.textures {
            let e = &te.entity;
            let p = &e.params;
            match te.value_type {
                TextureValueType::Float => {
                    let tex = match e.name.as_str() {
                        "constant" => FloatTexture::Constant(p.get_float("value", 1.0)? as f32),
                        "checkerboard" => {
                            check_2d(p, &e.loc)?;
                            FloatTexture::Checkerboard {
                                map: uv_mapping(p)?,
                                tex1: Box::new(t.float_param(p, "tex1", 1.0)?),
                                tex2: Box::new(t.float_param(p, "tex2", 0.0)?),
                            }
                        }
                        "imagemap" => FloatTexture::Image {
                            map: uv_mapping(p)?,
                            image: load_image(p, &e.loc)?,
                            scale: p.get_float("scale", 1.0)? as f32,
                            invert: p.get_bool("invert", false)?,
                        },
                        other => {
                            return err(
                                &e.loc,
                                unsupported("float texture", other, &["constant", "checkerboard", "imagemap"]),
                            )
                        }
                    };
                    t.float.insert(te.texture_name.clone(), tex);
                }
                TextureValueType::Spectrum => {
                    let pair = match e.name.as_str() {
                        "constant" => (
                            SpectrumTexture::Constant(spectrum_or(p, "value", SpectrumKind::Albedo, 1.0)?),
                            SpectrumTexture::Constant(spectrum_or(p, "value", SpectrumKind::Unbounded, 1.0)?),
                        ),
                        "checkerboard" => {
                            check_2d(p, &e.loc)?;
                            let map = uv_mapping(p)?;
                            let (a1, u1) = t.spectrum_pair(p, "tex1", 1.0)?;
                            let (a2, u2) = t.spectrum_pair(p, "tex2", 0.0)?;
                            (
                                SpectrumTexture::Checkerboard { map, tex1: Box::new(a1), tex2: Box::new(a2) },
                                SpectrumTexture::Checkerboard { map, tex1: Box::new(u1), tex2: Box::new(u2) },
                            )
                        }
                        "imagemap" => {
                            let map = uv_mapping(p)?;
                            let image = load_image(p, &e.loc)?;
                            let scale = p.get_float("scale", 1.0)? as f32;
                            let invert = p.get_bool("invert", false)?;
                            (
                                SpectrumTexture::Image {
                                    map,
                                    image: image.clone(),
                                    scale,
                                    invert,
                                    kind: RgbKind::Albedo,
                                },
                                SpectrumTexture::Image { map, image, scale, invert, kind: RgbKind::Unbounded },
                            )
                        }
                        other => {
                            return err(
                                &e.loc,
                                unsupported("spectrum texture", other, &["constant", "checkerboard", "imagemap"]),
                            )
                        }
                    };
                    t.spectrum.insert(te.texture_name.clone(), pair);
                }
            }
        }
        Ok(t)
    }

    fn float_param(&self, p: &ParamSet, name: &str, default: f64) -> Result<FloatTexture> {
        match p.get_float_texture(name, default)? {
            FloatParam::Value(v) => Ok(FloatTexture::Constant(v as f32)),
            FloatParam::Texture(t) => self.float.get(&t).cloned().ok_or_else(|| {
                SceneError::at(p.get(name).map(|q| q.loc.clone()).unwrap(), format!("no float texture named '{t}'"))
            }),
        }
    }

    fn spectrum_pair(&self, p: &ParamSet, name: &str, default: f64) -> Result<(SpectrumTexture, SpectrumTexture)> {
        match p.get_spectrum_texture(name, SpectrumKind::Unbounded)? {
            None => Ok((
                SpectrumTexture::Constant(Spectrum::Constant(default)),
                SpectrumTexture::Constant(Spectrum::Constant(default)),
            )),
            Some(SpectrumParam::Value(v)) => Ok((SpectrumTexture::Constant(v.clone()), SpectrumTexture::Constant(v))),
            Some(SpectrumParam::Texture(t)) => self.spectrum.get(&t).cloned().ok_or_else(|| {
                SceneError::at(p.get(name).map(|q| q.loc.clone()).unwrap(), format!("no spectrum texture named '{t}'"))
            }),
        }
    }

    /// A spectrum parameter that may be a texture; `kind` chooses the albedo or unbounded uplifting.
    fn spectrum_param(&self, p: &ParamSet, name: &str, kind: SpectrumKind, default: f64) -> Result<SpectrumTexture> {
        match p.get_spectrum_texture(name, kind)? {
            None => Ok(SpectrumTexture::Constant(Spectrum::Constant(default))),
            Some(SpectrumParam::Value(v)) => Ok(SpectrumTexture::Constant(v)),
            Some(SpectrumParam::Texture(t)) => {
                let pair = self.spectrum.get(&t).ok_or_else(|| {
                    SceneError::at(
                        p.get(name).map(|q| q.loc.clone()).unwrap(),
                        format!("no spectrum texture named '{t}'"),
                    )
                })?;
                Ok(if kind == SpectrumKind::Albedo { pair.0.clone() } else { pair.1.clone() })
            }
        }
    }
}

fn check_2d(p: &ParamSet, loc: &Loc) -> Result<()> {
    let dim = p.get_int("dimension", 2)?;
    if dim != 2 {
        return err(loc, format!("checkerboard dimension {dim} is not supported (only 2)"));
    }
    Ok(())
}

fn spectrum_or(p: &ParamSet, name: &str, kind: SpectrumKind, default: f64) -> Result<Spectrum> {
    Ok(p.get_spectrum(name, kind)?.unwrap_or(Spectrum::Constant(default)))
}

fn unsupported(what: &str, name: &str, supported: &[&str]) -> String {
    format!("{what} '{name}' is not supported; supported: {}", supported.join(", "))
}

fn roughness(t: &Textures, p: &ParamSet) -> Result<Roughness> {
    prefixed_roughness(t, p, "")
}

/// `{prefix}roughness`, overridden per direction by `{prefix}uroughness`/`{prefix}vroughness`, and the shared
/// `remaproughness`.
fn prefixed_roughness(t: &Textures, p: &ParamSet, prefix: &str) -> Result<Roughness> {
    let name = |n: &str| format!("{prefix}{n}");
    let r = t.float_param(p, &name("roughness"), 0.0)?;
    let u = if p.contains(&name("uroughness")) { t.float_param(p, &name("uroughness"), 0.0)? } else { r.clone() };
    let v = if p.contains(&name("vroughness")) { t.float_param(p, &name("vroughness"), 0.0)? } else { r };
    Ok(Roughness { u, v, remap: p.get_bool("remaproughness", true)? })
}

/// A conductor's optical constants: `reflectance`, or the spectra `eta_name` and `k_name` (copper by default).
fn conductor_spec(t: &Textures, p: &ParamSet, loc: &Loc, eta_name: &str, k_name: &str) -> Result<ConductorSpec> {
    if p.contains("reflectance") {
        if p.contains(eta_name) || p.contains(k_name) {
            return err(loc, format!("give either 'reflectance' or '{eta_name}' and '{k_name}', not both"));
        }
        return Ok(ConductorSpec::Reflectance(t.spectrum_param(p, "reflectance", SpectrumKind::Albedo, 0.0)?));
    }
    let eta = match p.get_spectrum_texture(eta_name, SpectrumKind::Unbounded)? {
        Some(_) => t.spectrum_param(p, eta_name, SpectrumKind::Unbounded, 1.0)?,
        None => SpectrumTexture::Constant(named_metal("metal-Cu-eta", loc)?),
    };
    let k = match p.get_spectrum_texture(k_name, SpectrumKind::Unbounded)? {
        Some(_) => t.spectrum_param(p, k_name, SpectrumKind::Unbounded, 0.0)?,
        None => SpectrumTexture::Constant(named_metal("metal-Cu-k", loc)?),
    };
    Ok(ConductorSpec::EtaK { eta, k })
}

/// The medium of a layered material: `thickness` (> 0, default 0.01), `albedo` (default 0), `g` (in (−1, 1),
/// default 0), `maxdepth` (default 10) and `nsamples` (default 1), pbrt-v4's names and defaults.
fn layer_medium(t: &Textures, p: &ParamSet, loc: &Loc) -> Result<LayerMedium> {
    let at = |name: &str| p.get(name).map(|q| q.loc.clone()).unwrap_or_else(|| loc.clone());
    let thickness = finite_positive(&at("thickness"), "thickness", p.get_float("thickness", 0.01)?)?;
    let g = t.float_param(p, "g", 0.0)?;
    if let FloatTexture::Constant(v) = g {
        if !(v > -1.0 && v < 1.0) {
            return err(&at("g"), format!("'g' (Henyey–Greenstein asymmetry) must be in (−1, 1), got {v}"));
        }
    }
    Ok(LayerMedium {
        thickness: thickness as f32,
        albedo: t.spectrum_param(p, "albedo", SpectrumKind::Albedo, 0.0)?,
        g,
        max_depth: p.get_int("maxdepth", 10)?.clamp(1, 1000) as u32,
        n_samples: p.get_int("nsamples", 1)?.clamp(1, 1000) as u32,
    })
}

/// The index of refraction of a dielectric: pbrt's `eta` (float or spectrum), or Prismatic's extensions `glass`,
/// `sellmeierB`/`sellmeierC`, and `abbe` with `eta` as n_d (docs/scene-format.md).
fn dielectric_ior(p: &ParamSet, loc: &Loc, default: f64) -> Result<DielectricIor> {
    let bad = |name: &str, e: optics::OpticsError| {
        let l = p.get(name).map(|q| q.loc.clone()).unwrap_or_else(|| loc.clone());
        SceneError::at(l, format!("'{name}': {e}"))
    };
    if p.contains("glass") {
        let name = p.get_string("glass", "")?;
        let entry = optics::catalogue::lookup(&name).map_err(|e| bad("glass", e))?;
        if entry.ior.is_complex() {
            return err(loc, format!("'glass' names '{name}', a metal; use the conductor material"));
        }
        return Ok(DielectricIor::Model(entry.ior));
    }
    if p.contains("sellmeierB") || p.contains("sellmeierC") {
        let b = p.get_floats("sellmeierB").unwrap_or(&[]).to_vec();
        let c = p.get_floats("sellmeierC").unwrap_or(&[]).to_vec();
        if b.is_empty() || b.len() != c.len() {
            return err(
                loc,
                format!("'sellmeierB' and 'sellmeierC' need the same number of terms ({} vs {})", b.len(), c.len()),
            );
        }
        let terms: Vec<(f64, f64)> = b.into_iter().zip(c).collect();
        return Ok(DielectricIor::Model(optics::Ior::sellmeier(0.0, &terms).map_err(|e| bad("sellmeierB", e))?));
    }
    if p.contains("abbe") {
        let vd = p.get_float("abbe", 0.0)?;
        let nd = p.get_float("eta", default)?;
        return Ok(DielectricIor::Model(optics::Ior::abbe(nd, vd).map_err(|e| bad("abbe", e))?));
    }
    named_eta(p, loc, "eta", default)
}

/// A dielectric index given as a float or a spectrum under `name`.
fn named_eta(p: &ParamSet, loc: &Loc, name: &str, default: f64) -> Result<DielectricIor> {
    match p.param_type(name) {
        Some(ParamType::Float) | None => {
            let n = p.get_float(name, default)?;
            let ior = optics::Ior::constant(n).map_err(|e| {
                let l = p.get(name).map(|q| q.loc.clone()).unwrap_or_else(|| loc.clone());
                SceneError::at(l, format!("'{name}': {e}"))
            })?;
            Ok(DielectricIor::Model(ior))
        }
        _ => {
            let s = p.get_spectrum(name, SpectrumKind::Unbounded)?.unwrap_or(Spectrum::Constant(default));
            Ok(DielectricIor::Spectrum(s))
        }
    }
}

fn material(t: &Textures, e: &Entity, names: &HashMap<String, u32>) -> Result<Material> {
    let p = &e.params;
    Ok(match e.name.as_str() {
        "diffuse" => Material::Diffuse { reflectance: t.spectrum_param(p, "reflectance", SpectrumKind::Albedo, 0.5)? },
        "conductor" => {
            Material::Conductor { spec: conductor_spec(t, p, &e.loc, "eta", "k")?, roughness: roughness(t, p)? }
        }
        "dielectric" => Material::Dielectric { ior: dielectric_ior(p, &e.loc, 1.5)?, roughness: roughness(t, p)? },
        "thindielectric" => Material::ThinDielectric { ior: dielectric_ior(p, &e.loc, 1.5)? },
        "coateddiffuse" => Material::CoatedDiffuse {
            reflectance: t.spectrum_param(p, "reflectance", SpectrumKind::Albedo, 0.5)?,
            roughness: roughness(t, p)?,
            ior: dielectric_ior(p, &e.loc, 1.5)?,
            medium: layer_medium(t, p, &e.loc)?,
        },
        "coatedconductor" => Material::CoatedConductor {
            conductor: conductor_spec(t, p, &e.loc, "conductor.eta", "conductor.k")?,
            conductor_roughness: prefixed_roughness(t, p, "conductor.")?,
            interface_roughness: prefixed_roughness(t, p, "interface.")?,
            interface_ior: named_eta(p, &e.loc, "interface.eta", 1.5)?,
            medium: layer_medium(t, p, &e.loc)?,
        },
        "mix" => {
            let Some(m) = p.get_strings("materials") else {
                return err(&e.loc, "mix needs 'string materials' [two names]");
            };
            if m.len() != 2 {
                return err(&e.loc, format!("mix needs exactly two materials, got {}", m.len()));
            }
            let idx = |n: &str| {
                names
                    .get(n)
                    .copied()
                    .ok_or_else(|| SceneError::at(e.loc.clone(), format!("mix: no material named '{n}'")))
            };
            Material::Mix { materials: [idx(&m[0])?, idx(&m[1])?], amount: t.float_param(p, "amount", 0.5)? }
        }
        "interface" => Material::Interface,
        other => {
            return err(
                &e.loc,
                unsupported(
                    "material",
                    other,
                    &[
                        "diffuse",
                        "conductor",
                        "dielectric",
                        "thindielectric",
                        "coateddiffuse",
                        "coatedconductor",
                        "mix",
                        "interface",
                    ],
                ),
            )
        }
    })
}

fn named_metal(name: &str, loc: &Loc) -> Result<Spectrum> {
    optics::catalogue::named_spectrum_checked(name).map_err(|e| SceneError::at(loc.clone(), e.to_string()))
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
            u32::try_from(i)
                .map_err(|_| SceneError::at(loc.clone(), format!("'{name}': index {i} is negative or too large")))
        })
        .collect::<Result<Vec<_>>>()
        .map(Some)
}

/// The geometry of one shape entity.
fn make_shape(se: &ShapeEntity) -> Result<Option<Shape>> {
    let e = &se.entity;
    let p = &e.params;
    let loc = &e.loc;
    let rfo = se.render_from_object;
    let ro = se.reverse_orientation;
    let mesh = |data: MeshData| -> Result<Option<Shape>> {
        if data.indices.is_empty() {
            return Ok(None);
        }
        Ok(Some(Shape::Mesh(Arc::new(TriangleMesh::new(&rfo, data, ro).map_err(|e| geo_err(loc, e))?))))
    };
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
            mesh(MeshData { positions: to_vec3s(pos), normals, uvs, indices })
        }
        "plymesh" => {
            let Some(path) = p.get_filename("filename")? else { return err(loc, "plymesh needs 'string filename'") };
            let data = geometry::ply::read_ply_file(&path).map_err(|e| geo_err(loc, e))?;
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
            let at = |name: &str| p.get(name).map(|q| q.loc.clone()).unwrap_or_else(|| loc.clone());
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

/// Builds the render-ready scene from a parsed description.
pub fn build_scene(desc: &SceneDescription, options: &BuildOptions) -> Result<BuiltScene> {
    if desc.color_space != "srgb" {
        return err(&desc.film.loc, format!("colour space '{}' is not supported (only srgb)", desc.color_space));
    }
    let mut warnings = vec![];
    // Film.
    let fp = &desc.film.params;
    let kind = match desc.film.name.as_str() {
        "rgb" => FilmKind::Rgb,
        "spectral" => FilmKind::Spectral {
            nbuckets: p_count(fp, "nbuckets", 16, &desc.film.loc)?,
            lambda_min: fp.get_float("lambdamin", 360.0)?,
            lambda_max: fp.get_float("lambdamax", 830.0)?,
        },
        other => return err(&desc.film.loc, unsupported("film", other, &["rgb", "spectral"])),
    };
    let (mut w, mut h) = (
        p_count(fp, "xresolution", 1280, &desc.film.loc)? as u32,
        p_count(fp, "yresolution", 720, &desc.film.loc)? as u32,
    );
    if let Some((rw, rh)) = options.resolution {
        (w, h) = (rw, rh);
    }
    // Read the scene's values even when overridden, so they are not reported as unused.
    let scene_filename = PathBuf::from(fp.get_string("filename", "pbrt.exr")?);
    let filename = options.output.clone().unwrap_or(scene_filename);
    let filter = make_filter(&desc.filter)?;
    let mut film = FilmSpec::new(w, h, filename);
    (film.kind, film.filter) = (kind, filter);
    film.sensor = make_sensor(desc)?;
    film.max_component_value = fp.get_float("maxcomponentvalue", f64::INFINITY)?;
    film.validate().map_err(|e| SceneError::at(desc.film.loc.clone(), e.to_string()))?;

    // Sampler and integrator.
    let scene_spp = p_count(&desc.sampler.params, "pixelsamples", 16, &desc.sampler.loc)? as u32;
    let spp = options.spp.unwrap_or(scene_spp);
    let integrator = read_integrator(desc, &mut warnings)?;
    // Photon mapping renders `iterations` passes (pbrt-v4 ignores the sampler's pixel samples there).
    let spp = if matches!(integrator, Integrator::Sppm(_)) {
        let it = p_count(&desc.integrator.params, "iterations", 64, &desc.integrator.loc)? as u32;
        options.spp.unwrap_or(it)
    } else {
        spp
    };

    // Textures and materials (anonymous first, then named; a name maps to its index).
    let textures = Textures::build(desc)?;
    let mut names: HashMap<String, u32> = HashMap::new();
    let n_anon = desc.materials.len();
    for (i, (name, _)) in desc.named_materials.iter().enumerate() {
        names.insert(name.clone(), (n_anon + i) as u32);
    }
    let mut materials = Vec::with_capacity(n_anon + desc.named_materials.len());
    for e in desc.materials.iter().chain(desc.named_materials.iter().map(|(_, e)| e)) {
        materials.push(material(&textures, e, &names)?);
    }
    let material_index = |r: &MaterialRef, loc: &Loc| -> Result<u32> {
        let i = match r {
            MaterialRef::Anonymous(i) => *i as u32,
            MaterialRef::Named(n) => {
                *names.get(n).ok_or_else(|| SceneError::at(loc.clone(), format!("no material named '{n}'")))?
            }
        };
        Ok(if matches!(materials[i as usize], Material::Interface) { NO_MATERIAL } else { i })
    };

    // Media (absorbing homogeneous only).
    let mut media = vec![];
    let mut medium_index: HashMap<String, u32> = HashMap::new();
    for m in &desc.media {
        let p = &m.entity.params;
        if m.entity.name != "homogeneous" {
            return err(&m.entity.loc, unsupported("medium", &m.entity.name, &["homogeneous (absorbing)"]));
        }
        let sigma_s = p.get_spectrum("sigma_s", SpectrumKind::Unbounded)?;
        if sigma_s.as_ref().is_some_and(|s| s.max_value() > 0.0) {
            return err(&m.entity.loc, "scattering media ('sigma_s' > 0) are not supported yet: only absorption");
        }
        let scale = p.get_float("scale", 1.0)?;
        let sigma_a =
            p.get_spectrum("sigma_a", SpectrumKind::Unbounded)?.unwrap_or(Spectrum::Constant(1.0)).scaled(scale);
        medium_index.insert(m.medium_name.clone(), media.len() as u32);
        media.push(AbsorbingMedium { sigma_a });
    }
    let medium_of = |name: &Option<String>, loc: &Loc| -> Result<Option<u32>> {
        match name {
            None => Ok(None),
            Some(n) if n.is_empty() => Ok(None),
            Some(n) => medium_index
                .get(n)
                .copied()
                .map(Some)
                .ok_or_else(|| SceneError::at(loc.clone(), format!("no medium named '{n}'"))),
        }
    };

    // Shapes: object 0 holds the world's shapes; each ObjectBegin definition becomes another object. Area lights
    // are only created for world shapes (pbrt-v4 drops them inside instances, with a warning at parse time).
    let mut lights: Vec<Light> = vec![];
    let mut triangles = 0usize;
    let mut object_shapes =
        |shapes: &[ShapeEntity], lights: Option<&mut Vec<Light>>| -> Result<(Vec<Shape>, Vec<ShapeInfo>)> {
            let mut lights = lights;
            let (mut out, mut out_info) = (vec![], vec![]);
            for se in shapes {
                let Some(shape) = make_shape(se)? else { continue };
                triangles += shape_triangles(&shape);
                let material = material_index(&se.material, &se.entity.loc)?;
                let inside = medium_of(&se.inside_medium, &se.entity.loc)?;
                let outside = medium_of(&se.outside_medium, &se.entity.loc)?;
                let media = (inside.is_some() || outside.is_some() || material == NO_MATERIAL)
                    .then_some(MediumInterface { inside, outside });
                let area_light_base = match (&se.area_light, lights.as_deref_mut()) {
                    (Some(al), Some(lights)) => Some(area_lights(al, &shape, lights)?),
                    _ => None,
                };
                out_info.push(ShapeInfo { material, area_light_base, media });
                out.push(shape);
            }
            Ok((out, out_info))
        };
    let (world_shapes, world_info) = object_shapes(&desc.shapes, Some(&mut lights))?;
    let mut objects = vec![Object::new(world_shapes)];
    let mut info = vec![world_info];
    let mut object_index: HashMap<&str, u32> = HashMap::new();
    for od in &desc.objects {
        let (shapes, oinfo) = object_shapes(&od.shapes, None)?;
        object_index.insert(od.name.as_str(), objects.len() as u32);
        objects.push(Object::new(shapes));
        info.push(oinfo);
    }
    let mut instances = vec![Instance { object: 0, render_from_instance: Transform::IDENTITY }];
    for iu in &desc.instances {
        let Some(&o) = object_index.get(iu.name.as_str()) else {
            return err(&iu.loc, format!("no object named '{}'", iu.name));
        };
        instances.push(Instance { object: o, render_from_instance: iu.render_from_instance });
    }
    let accel =
        GeometryScene::build(objects, instances).map_err(|e| SceneError::at(desc.film.loc.clone(), e.to_string()))?;
    let bounds = {
        use geometry::Accel;
        accel.bounds()
    };
    let (_, scene_radius) = if bounds.is_empty() { (Vec3::ZERO, 1.0) } else { bounds.bounding_sphere() };

    // Lights.
    for le in &desc.lights {
        lights.push(light(le, scene_radius.max(1e-3), &mut warnings)?);
    }

    // Camera.
    let camera = make_camera(desc, (w, h))?;
    if matches!(integrator, Integrator::LightPath(_) | Integrator::Bdpt(_)) && !camera.supports_light_tracing() {
        return err(
            &desc.camera.entity.loc,
            format!("integrator \"{}\" needs a perspective camera (an orthographic camera cannot be reached by light paths)", integrator.name()),
        );
    }
    let camera_medium = medium_of(&desc.camera.medium, &desc.camera.entity.loc)?;

    let scene =
        RenderScene::new(Box::new(SceneGeometry::new(accel, info)), materials, lights, media, camera_medium, camera);
    warnings.extend(desc.warnings.iter().map(|d| d.to_string()));
    warnings.extend(desc.unused_parameters().iter().map(|d| d.to_string()));
    Ok(BuiltScene { scene, film, spp, integrator, triangles, warnings })
}

/// The `Integrator` directive: pbrt-v4's `path` (and `volpath`, rendered as `path`), `lightpath`, `bdpt` and `sppm`
/// with `maxdepth`, and for `sppm` also `photonsperiteration` and `radius` (its `iterations` count as samples per
/// pixel and are read with the sampler's in [`build_scene`]).
fn read_integrator(desc: &SceneDescription, warnings: &mut Vec<String>) -> Result<Integrator> {
    let ip = &desc.integrator.params;
    let max_depth = || -> Result<u32> {
        let md = ip.get_int("maxdepth", 5)?;
        if md < 0 {
            let l = ip.get("maxdepth").map(|q| q.loc.clone()).unwrap_or_else(|| desc.integrator.loc.clone());
            return err(&l, format!("'maxdepth' must be non-negative, got {md}"));
        }
        Ok(md.min(1_000) as u32)
    };
    let integrator = match desc.integrator.name.as_str() {
        "path" | "volpath" => {
            let md = max_depth()?;
            if desc.integrator.name == "volpath" && !desc.media.is_empty() {
                warnings.push(format!(
                    "{}: warning: integrator \"volpath\" renders as \"path\" (absorbing media only)",
                    desc.integrator.loc
                ));
            }
            Integrator::Path(PathIntegrator { max_depth: md })
        }
        "lightpath" => Integrator::LightPath(LightPathIntegrator { max_depth: max_depth()? }),
        "bdpt" => Integrator::Bdpt(crate::bdpt::BdptIntegrator { max_depth: max_depth()? }),
        "sppm" => {
            let photons = ip.get_int("photonsperiteration", -1)?;
            let radius = ip.get_float("radius", 1.0)?;
            let at = |name: &str| ip.get(name).map(|q| q.loc.clone()).unwrap_or_else(|| desc.integrator.loc.clone());
            if !(radius.is_finite() && radius > 0.0) {
                return err(&at("radius"), format!("'radius' must be a positive number, got {radius}"));
            }
            if photons == 0 || !(-1..=1 << 32).contains(&photons) {
                return err(
                    &at("photonsperiteration"),
                    format!("'photonsperiteration' must be positive (or -1 for one per pixel), got {photons}"),
                );
            }
            Integrator::Sppm(SppmIntegrator {
                max_depth: max_depth()?,
                photons_per_iteration: (photons > 0).then_some(photons as u64),
                initial_radius: radius as f32,
            })
        }
        other => {
            return err(
                &desc.integrator.loc,
                unsupported("integrator", other, &["path", "volpath", "lightpath", "sppm", "bdpt"]),
            )
        }
    };
    Ok(integrator)
}

fn shape_triangles(s: &Shape) -> usize {
    match s {
        Shape::Mesh(m) => m.triangle_count(),
        _ => 0,
    }
}

fn p_count(p: &ParamSet, name: &str, default: i64, loc: &Loc) -> Result<usize> {
    let v = p.get_int(name, default)?;
    if v <= 0 || v > 1 << 20 {
        let l = p.get(name).map(|q| q.loc.clone()).unwrap_or_else(|| loc.clone());
        return err(&l, format!("'{name}' must be a positive integer, got {v}"));
    }
    Ok(v as usize)
}

/// Where parameter `name` was written, or the directive's location if it was not.
fn param_loc(p: &ParamSet, name: &str, directive: &Loc) -> Loc {
    p.get(name).map(|q| q.loc.clone()).unwrap_or_else(|| directive.clone())
}

/// pbrt-v4's pixel sensor from the film's `sensor`, `iso` and `whitebalance` and the camera's shutter interval.
///
/// pbrt-v4 takes the exposure time as the camera's `shutterclose` − `shutteropen` (defaults 1 and 0, so 1 s) and
/// `iso` defaults to 100, making the imaging ratio t · ISO / 100 exactly 1 by default; `whitebalance` (K) defaults
/// to 0, no white balance, for the `cie1931` sensor. The measured camera sensors pbrt-v4 ships ("canon_eos_100d",
/// …) need response curves we do not have, so any other `sensor` is an error.
fn make_sensor(desc: &SceneDescription) -> Result<PixelSensor> {
    let (fp, floc) = (&desc.film.params, &desc.film.loc);
    let sensor = fp.get_string("sensor", "cie1931")?;
    if sensor != "cie1931" {
        return err(
            &param_loc(fp, "sensor", floc),
            format!("'sensor' \"{sensor}\" is not supported: only \"cie1931\" (measured camera sensors need response data we do not have)"),
        );
    }
    let cp = &desc.camera.entity.params;
    let (open, close) = (cp.get_float("shutteropen", 0.0)?, cp.get_float("shutterclose", 1.0)?);
    let exposure = close - open;
    if !(exposure.is_finite() && exposure > 0.0) {
        return err(
            &param_loc(cp, "shutterclose", &desc.camera.entity.loc),
            format!("'shutterclose' ({close}) must be later than 'shutteropen' ({open}): the shutter never opens"),
        );
    }
    let iso = fp.get_float("iso", 100.0)?;
    if !(iso.is_finite() && iso > 0.0) {
        return err(&param_loc(fp, "iso", floc), format!("'iso' must be a positive number, got {iso}"));
    }
    let temperature = fp.get_float("whitebalance", 0.0)?;
    let white_balance_from = if temperature == 0.0 {
        None
    } else {
        let xy = spectral::daylight::white_balance_chromaticity(temperature)
            .map_err(|e| SceneError::at(param_loc(fp, "whitebalance", floc), e.to_string()))?;
        Some(xy)
    };
    Ok(PixelSensor { imaging_ratio: PixelSensor::imaging_ratio(exposure, iso), white_balance_from })
}

fn make_filter(e: &Entity) -> Result<Filter> {
    let p = &e.params;
    let Some(default) = Filter::default_for(&e.name) else {
        return err(&e.loc, unsupported("pixel filter", &e.name, &Filter::NAMES));
    };
    let r = default.radius();
    let radius = [p.get_float("xradius", r[0])?, p.get_float("yradius", r[1])?];
    let f = match default {
        Filter::Box { .. } => Filter::new_box(radius),
        Filter::Gaussian { sigma, .. } => Filter::gaussian(radius, p.get_float("sigma", sigma)?),
        Filter::Triangle { .. } => Filter::triangle(radius),
        Filter::Mitchell { b, c, .. } => Filter::mitchell(radius, p.get_float("B", b)?, p.get_float("C", c)?),
    };
    f.map_err(|x| SceneError::at(e.loc.clone(), x.to_string()))
}

fn make_camera(desc: &SceneDescription, res: (u32, u32)) -> Result<Camera> {
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
    Ok(Camera::new(projection, &desc.camera.camera_from_world, res, window, lens_radius as f32, focal as f32))
}

/// Creates one area light per primitive of `shape`; returns the index of the first.
fn area_lights(al: &Entity, shape: &Shape, lights: &mut Vec<Light>) -> Result<u32> {
    let p = &al.params;
    if al.name != "diffuse" {
        return err(&al.loc, unsupported("area light", &al.name, &["diffuse"]));
    }
    let l = p.get_spectrum("L", SpectrumKind::Illuminant)?.unwrap_or_else(|| {
        Spectrum::RgbIlluminant(RgbIlluminantSpectrum::new([1.0, 1.0, 1.0]).expect("white is valid"))
    });
    let two_sided = p.get_bool("twosided", false)?;
    let mut scale = p.get_float("scale", 1.0)?;
    let power = p.get_float("power", -1.0)?;
    if p.contains("filename") {
        return err(&al.loc, "image area lights ('filename') are not supported yet");
    }
    let n = shape.primitive_count();
    if power > 0.0 {
        // pbrt-v4: k_e = π · (2 if two-sided) · area, in luminance units.
        let area: f64 = (0..n).map(|i| shape.area(i) as f64).sum();
        let k_e = std::f64::consts::PI * if two_sided { 2.0 } else { 1.0 } * area;
        if k_e > 0.0 {
            scale *= power / k_e;
        }
    }
    let l = normalise_emission(&al.loc, l, scale)?;
    let base = lights.len() as u32;
    for element in 0..n {
        lights.push(Light::DiffuseArea {
            shape: Box::new(shape.clone()),
            element: element as u32,
            l: l.clone(),
            two_sided,
        });
    }
    Ok(base)
}

fn light(le: &scene::LightEntity, scene_radius: f32, warnings: &mut Vec<String>) -> Result<Light> {
    let e = &le.entity;
    let p = &e.params;
    let t = &le.render_from_light;
    let white = || Spectrum::RgbIlluminant(RgbIlluminantSpectrum::new([1.0, 1.0, 1.0]).expect("white is valid"));
    let scale = p.get_float("scale", 1.0)?;
    let power = p.get_float("power", -1.0)?;
    Ok(match e.name.as_str() {
        "point" => {
            let i = p.get_spectrum("I", SpectrumKind::Illuminant)?.unwrap_or_else(white);
            let from = p.get_point3("from", DVec3::ZERO)?;
            let k = if power > 0.0 { power / (4.0 * std::f64::consts::PI) } else { 1.0 };
            Light::Point { p: t.point(from).as_vec3(), i: normalise_emission(&e.loc, i, scale * k)? }
        }
        "spot" => {
            let i = p.get_spectrum("I", SpectrumKind::Illuminant)?.unwrap_or_else(white);
            let from = p.get_point3("from", DVec3::ZERO)?;
            let to = p.get_point3("to", DVec3::new(0.0, 0.0, 1.0))?;
            let cone = p.get_float("coneangle", 30.0)?;
            let delta = p.get_float("conedeltaangle", 5.0)?;
            let (cos_end, cos_start) = (cone.to_radians().cos(), (cone - delta).to_radians().cos());
            let k = if power > 0.0 {
                power / (2.0 * std::f64::consts::PI * (1.0 - 0.5 * (cos_start + cos_end)))
            } else {
                1.0
            };
            let pf = t.point(from).as_vec3();
            let axis = (t.point(to).as_vec3() - pf)
                .try_normalize()
                .ok_or_else(|| SceneError::at(e.loc.clone(), "spot light 'from' equals 'to'"))?;
            Light::Spot {
                p: pf,
                frame: Frame::from_z(axis),
                i: normalise_emission(&e.loc, i, scale * k)?,
                cos_falloff_start: cos_start as f32,
                cos_falloff_end: cos_end as f32,
            }
        }
        "distant" => {
            let l = p.get_spectrum("L", SpectrumKind::Illuminant)?.unwrap_or_else(white);
            let from = p.get_point3("from", DVec3::ZERO)?;
            let to = p.get_point3("to", DVec3::new(0.0, 0.0, 1.0))?;
            let w = t
                .vector(from - to)
                .as_vec3()
                .try_normalize()
                .ok_or_else(|| SceneError::at(e.loc.clone(), "distant light 'from' equals 'to'"))?;
            let e_v = p.get_float("illuminance", -1.0)?;
            let k = if e_v > 0.0 { e_v } else { 1.0 };
            Light::Distant { w, l: normalise_emission(&e.loc, l, scale * k)?, scene_radius }
        }
        "infinite" => {
            let e_v = p.get_float("illuminance", -1.0)?;
            if let Some(path) = p.get_filename("filename")? {
                let map = environment_map(&path, &e.loc, t)?;
                let mut s = scale;
                if e_v > 0.0 {
                    // Scale so that an upward-facing point receives illuminance E_v (pbrt-v4 computes the same
                    // integral over the upper hemisphere; we use the mean luminance, exact for uniform maps).
                    let k_e = std::f64::consts::PI * map.mean_luminance as f64;
                    if k_e > 0.0 {
                        s *= e_v / k_e;
                    }
                    warnings.push(format!("{}: warning: 'illuminance' of an image light is matched on average", e.loc));
                }
                Light::ImageInfinite { map: Box::new(map), scale: s as f32, scene_radius }
            } else {
                let l = p.get_spectrum("L", SpectrumKind::Illuminant)?.unwrap_or_else(white);
                let k = if e_v > 0.0 { e_v / std::f64::consts::PI } else { 1.0 };
                Light::UniformInfinite { l: normalise_emission(&e.loc, l, scale * k)?, scene_radius }
            }
        }
        other => return err(&e.loc, unsupported("light", other, &["point", "spot", "distant", "infinite"])),
    })
}

fn environment_map(path: &std::path::Path, loc: &Loc, t: &Transform) -> Result<EnvironmentMap> {
    let (w, h, pixels) = film::read_rgb(path)
        .map_err(|e| SceneError::at(loc.clone(), format!("cannot read {}: {e}", path.display())))?;
    let (w, h) = (w as usize, h as usize);
    let equal_area = w == h;
    if !equal_area && w != 2 * h {
        return err(loc, format!("environment map {}×{} is neither square (equal-area) nor 2:1 (lat-long)", w, h));
    }
    let cs = RgbColorSpace::srgb();
    let mut texels = Vec::with_capacity(w * h);
    let mut weights = Vec::with_capacity(w * h);
    let mut lum_sum = 0.0f64;
    for (i, px) in pixels.iter().enumerate() {
        let rgb = px.map(|c| (c.max(0.0)) as f64);
        texels.push(RgbIlluminantSpectrum::new(rgb).map_err(|e| SceneError::at(loc.clone(), e.to_string()))?);
        let y = cs.to_xyz(rgb).y.max(0.0);
        lum_sum += y;
        // Lat-long rows cover less solid angle near the poles: weight by sin θ.
        let row = i / w;
        let sin_theta = if equal_area { 1.0 } else { ((row as f64 + 0.5) / h as f64 * std::f64::consts::PI).sin() };
        weights.push(y * sin_theta + 1e-6);
    }
    let distribution = Distribution2D::new(&weights, w, h, (0.0, 1.0), (0.0, 1.0))
        .map_err(|e| SceneError::at(loc.clone(), e.to_string()))?;
    let x = t.vector(DVec3::X).as_vec3().normalize();
    let y = t.vector(DVec3::Y).as_vec3().normalize();
    let z = t.vector(DVec3::Z).as_vec3().normalize();
    Ok(EnvironmentMap {
        width: w,
        height: h,
        texels,
        equal_area,
        mean_luminance: (lum_sum / (w * h) as f64) as f32,
        distribution,
        frame: Frame { x, y, z },
    })
}

//! `prismatic.Scene`: a parsed pbrt-v4 scene, its builds, its edits (materials, media, lights) and its renders.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use pyo3::exceptions::{PyIndexError, PyKeyError, PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use scene::{Entity, SceneDescription, TextureValueType};

use crate::errors::build_error;
use crate::image::{Image, RenderStatistics};

/// The options a scene is built with (the film's size and crop, the sample count the footprints are made for, the
/// integrator).
#[derive(Clone, Debug, Default, PartialEq)]
struct BuildKey {
    resolution: Option<(u32, u32)>,
    spp: Option<u32>,
    crop: Option<[f64; 4]>,
    /// The integrator's directive arguments, replacing the scene's `Integrator`.
    integrator: Option<String>,
}

/// The last build, of the description after `edits` edits with the options `key`.
struct Kept {
    key: BuildKey,
    edits: u64,
    built: Arc<render::BuiltScene>,
}

/// A scene's description with its edits and its last build.
struct State {
    desc: SceneDescription,
    /// How many edits the description has had.
    edits: u64,
    kept: Option<Kept>,
}

/// A build error, or a lock poisoned by a panic during an earlier build.
enum BuildFailure {
    Scene(render::RenderError),
    Poisoned,
}

impl BuildFailure {
    fn into_py(self, py: Python<'_>) -> PyErr {
        match self {
            BuildFailure::Scene(e) => build_error(py, e),
            BuildFailure::Poisoned => PyRuntimeError::new_err("an earlier build of this scene panicked"),
        }
    }
}

/// A built scene and what building it cost.
struct Build {
    built: Arc<render::BuiltScene>,
    /// Seconds spent building (0 for a kept build).
    seconds: f64,
    /// Whether the shapes (the BVH) were built.
    shapes_built: bool,
}

impl State {
    /// The scene built with `key`'s options: the kept build if it has the same options and edits, else a build that
    /// takes over the kept build's shapes (BVH and area lights) where nothing they record changed.
    fn build(&mut self, key: &BuildKey, builds: &AtomicU32) -> Result<Build, render::RenderError> {
        if let Some(k) = self.kept.as_ref().filter(|k| k.key == *key && k.edits == self.edits) {
            return Ok(Build { built: k.built.clone(), seconds: 0.0, shapes_built: false });
        }
        let start = Instant::now();
        let options = render::BuildOptions {
            resolution: key.resolution,
            spp: key.spp,
            crop_window: key.crop,
            ..Default::default()
        };
        // The integrator asked for replaces the scene's for this build only.
        let replaced = match &key.integrator {
            Some(args) => {
                let entity = integrator_entity(args, &self.desc.file)
                    .map_err(|e| render::RenderError::Scene(scene::SceneError::at(e.loc, e.message)))?;
                Some(std::mem::replace(&mut self.desc.integrator, entity))
            }
            None => None,
        };
        let result = match &self.kept {
            Some(k) => render::build_scene_reusing(&self.desc, &options, &k.built),
            None => render::build_scene(&self.desc, &options),
        };
        if let Some(original) = replaced {
            self.desc.integrator = original;
        }
        let built = Arc::new(result?);
        let shapes_built = built.built_shapes();
        if shapes_built {
            builds.fetch_add(1, Ordering::Relaxed);
        }
        self.kept = Some(Kept { key: key.clone(), edits: self.edits, built: built.clone() });
        Ok(Build { built, seconds: start.elapsed().as_secs_f64(), shapes_built })
    }
}

/// The virtual file an edit's text is parsed as, in the scene's directory (so that file names resolve as in the
/// scene).
fn virtual_file(scene_file: &Path, what: &str) -> PathBuf {
    scene_file.parent().unwrap_or(Path::new("")).join(format!("<{what}>"))
}

/// The `Integrator` directive with arguments `args` (`"volpath" "integer maxdepth" 20`, or a bare name).
fn integrator_entity(args: &str, scene_file: &Path) -> Result<Entity, pbrt::ParseError> {
    pbrt::parse_integrator(args, &virtual_file(scene_file, "integrator"))
}

/// Checks that `name` can be a type name in a directive (letters, digits, `-`, `_`, `.`).
fn type_name(name: &str) -> PyResult<&str> {
    if !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c)) {
        Ok(name)
    } else {
        Err(PyValueError::new_err(format!("type: '{name}' is not a type name (e.g. \"dielectric\", \"homogeneous\")")))
    }
}

/// `Directive "type" params` parsed with the scene's textures declared (so that `"texture …"` parameters resolve):
/// the directive's entity, taken out of the description by `take`. A syntax error is a ValueError naming
/// `params`, with the column within `params`.
fn parse_directive(
    desc: &SceneDescription,
    what: &str,
    directive: &str,
    ty: &str,
    params: &str,
    take: impl FnOnce(SceneDescription) -> Option<Entity>,
) -> PyResult<Entity> {
    let ty = type_name(ty)?;
    // Line 1 declares the scene's textures (as constants: only their names and kinds matter to the parser); line 2
    // is the directive.
    let mut text = String::from("WorldBegin");
    for t in &desc.textures {
        let kind = match t.value_type {
            TextureValueType::Float => "float",
            TextureValueType::Spectrum => "spectrum",
        };
        let name = t.texture_name.replace('"', "");
        text.push_str(&format!(" Texture \"{name}\" \"{kind}\" \"constant\""));
    }
    let head = format!("{directive} \"{ty}\" ");
    text.push_str(&format!("\n{head}{params}\n"));
    let file = virtual_file(&desc.file, what);
    let parsed = pbrt::parse_str(&text, &file).map_err(|e| {
        let at = if e.loc.line == 2 && e.loc.column as usize > head.chars().count() {
            format!(" (column {})", e.loc.column as usize - head.chars().count())
        } else {
            String::new()
        };
        PyValueError::new_err(format!("params{at}: {}", e.message))
    })?;
    take(parsed).ok_or_else(|| PyRuntimeError::new_err(format!("{what}: the directive was not read")))
}

/// A parsed pbrt-v4 scene. `render` builds it (the BVH once; other materials, media, lights, integrators and film
/// sizes reuse it) and renders it; `set_material`, `set_medium` and `set_light` change it between renders.
#[pyclass(module = "prismatic._prismatic", frozen)]
pub struct Scene {
    state: Mutex<State>,
    /// What `load` was given (None for `loads`).
    path: Option<PathBuf>,
    /// How many times the shapes (the BVH) were built.
    builds: AtomicU32,
}

/// `n` as a count in [1, `max`], else ValueError naming `name`.
fn positive(name: &str, n: i64, max: i64) -> PyResult<u32> {
    if (1..=max).contains(&n) {
        Ok(n as u32)
    } else {
        Err(PyValueError::new_err(format!("{name} must be between 1 and {max}, got {n}")))
    }
}

/// What calls back between passes: a function `progress(done, total)`, or a tqdm bar.
enum Progress {
    None,
    Function(Py<PyAny>),
    Bar(Py<PyAny>),
}

impl Progress {
    /// From `progress=`: None or False (none), True (a tqdm bar if tqdm is installed, else none), or a function.
    fn new(py: Python<'_>, progress: Option<Bound<'_, PyAny>>, total: Option<u32>) -> PyResult<Self> {
        let Some(p) = progress else { return Ok(Progress::None) };
        if let Ok(on) = p.cast::<pyo3::types::PyBool>() {
            if !on.is_true() {
                return Ok(Progress::None);
            }
            return Ok(match py.import("tqdm.auto") {
                Ok(tqdm) => {
                    let kwargs = PyDict::new(py);
                    kwargs.set_item("total", total)?;
                    kwargs.set_item("unit", "spp")?;
                    kwargs.set_item("desc", "rendering")?;
                    Progress::Bar(tqdm.getattr("tqdm")?.call((), Some(&kwargs))?.unbind())
                }
                Err(_) => Progress::None,
            });
        }
        if p.is_callable() {
            Ok(Progress::Function(p.unbind()))
        } else {
            Err(PyTypeError::new_err("progress must be True, False, None or a function progress(done, total)"))
        }
    }

    /// After a pass: `done` of `total` passes.
    fn report(&self, py: Python<'_>, done: u32, total: Option<u32>, pass: u32) -> PyResult<()> {
        match self {
            Progress::None => Ok(()),
            Progress::Function(f) => f.call1(py, (done, total)).map(|_| ()),
            Progress::Bar(bar) => bar.call_method1(py, "update", (pass,)).map(|_| ()),
        }
    }

    fn close(&self, py: Python<'_>) {
        if let Progress::Bar(bar) = self {
            // A bar that cannot close leaves a line on the terminal: nothing to report.
            let _ = bar.call_method0(py, "close");
        }
    }
}

#[pymethods]
impl Scene {
    /// Renders the scene; returns an [`Image`].
    ///
    /// - `spp`: samples per pixel (the scene's by default); `time_limit`: seconds after which the render stops at
    ///   the end of a pass (with `spp`, whichever comes first; without, passes go on until the time is spent), as
    ///   the command line's `--time`.
    /// - `resolution`: (width, height) instead of the film's; `crop`: (x0, x1, y0, y1), fractions of the image
    ///   (pbrt-v4's crop window): the image then holds just those pixels, as a full render has them.
    /// - `integrator`: a name ("path", "volpath", "bdpt", "sppm", …) or a directive's arguments
    ///   (`'"volpath" "integer maxdepth" 20'`) replacing the scene's `Integrator`.
    /// - `wavelengths`: "hero" (the default), "cmf" or "rgb"; `seed`: the sampler's seed (the command line's
    ///   `--seed`); `threads`: worker threads (all cores by default); `aovs`: also record the geometry buffer
    ///   (`Image.aovs`), as `--aovs` does.
    /// - `progress`: True for a tqdm bar (if tqdm is installed), or a function called as `progress(done, total)`
    ///   after each pass (total None for a time limit without spp).
    ///
    /// The GIL is released while rendering. Ctrl-C stops the render at the end of the pass: the KeyboardInterrupt
    /// raised carries the partial image as `.image` (so does an exception raised by `progress`).
    #[pyo3(signature = (*, spp=None, resolution=None, crop=None, integrator=None, wavelengths=None, seed=0,
                        threads=None, time_limit=None, aovs=false, progress=None))]
    #[allow(clippy::too_many_arguments)]
    fn render(
        &self,
        py: Python<'_>,
        spp: Option<i64>,
        resolution: Option<Bound<'_, PyAny>>,
        crop: Option<Bound<'_, PyAny>>,
        integrator: Option<Bound<'_, PyAny>>,
        wavelengths: Option<&str>,
        seed: i64,
        threads: Option<i64>,
        time_limit: Option<f64>,
        aovs: bool,
        progress: Option<Bound<'_, PyAny>>,
    ) -> PyResult<Image> {
        let spp = spp.map(|n| positive("spp", n, 1 << 24)).transpose()?;
        let resolution = match resolution {
            None => None,
            Some(r) => {
                let (w, h) = r.extract::<(i64, i64)>().map_err(|e| {
                    PyTypeError::new_err(format!("resolution must be (width, height), two integers: {e}"))
                })?;
                Some((positive("resolution width", w, 1 << 16)?, positive("resolution height", h, 1 << 16)?))
            }
        };
        let crop = match crop {
            None => None,
            Some(c) => {
                let c = c
                    .extract::<(f64, f64, f64, f64)>()
                    .map_err(|e| PyTypeError::new_err(format!("crop must be (x0, x1, y0, y1), four numbers: {e}")))?;
                let c = [c.0, c.1, c.2, c.3];
                if c.iter().any(|v| !(0.0..=1.0).contains(v)) || c[0] >= c[1] || c[2] >= c[3] {
                    return Err(PyValueError::new_err(format!(
                        "crop: (x0, x1, y0, y1) are fractions of the image in [0, 1] with x0 < x1 and y0 < y1, got \
                         {c:?}"
                    )));
                }
                Some(c)
            }
        };
        let integrator = match integrator {
            None => None,
            Some(i) => {
                let args: String = i.extract().map_err(|_| PyTypeError::new_err("integrator must be a string"))?;
                let file = self.path.clone().unwrap_or_else(|| PathBuf::from("scene"));
                integrator_entity(&args, &file)
                    .map_err(|e| PyValueError::new_err(format!("integrator: {}", e.message)))?;
                Some(args)
            }
        };
        let seed = u32::try_from(seed)
            .map_err(|_| PyValueError::new_err(format!("seed must be between 0 and {}, got {seed}", u32::MAX)))?;
        let threads = threads.map(|n| positive("threads", n, 4096)).transpose()?;
        let strategy = match wavelengths {
            None => spectral::WavelengthStrategy::default(),
            Some(s) => s.parse().map_err(|e: String| PyValueError::new_err(format!("wavelengths: {e}")))?,
        };
        if let Some(t) = time_limit {
            if !(t.is_finite() && t > 0.0 && t <= 1e7) {
                return Err(PyValueError::new_err(format!(
                    "time_limit must be a positive number of seconds (at most 1e7), got {t}"
                )));
            }
        }
        let budget = time_limit.map(Duration::from_secs_f64);
        let key = BuildKey { resolution, spp, crop, integrator };
        let build = self.build(py, &key)?;
        let built = &build.built;
        let mut spec = built.film.clone();
        spec.wavelengths = strategy;
        if aovs {
            // The command line's --aovs: pbrt-v4's geometry buffer in camera space on any film (a gbuffer film
            // keeps its own coordinates).
            spec.aovs = true;
            spec.gbuffer.get_or_insert(film::GBuffer { coordinates: film::GBufferCoordinates::Camera });
        }
        let mut film = film::Film::new(spec).map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        // Passes to render: the spp asked for (or the scene's), or without spp under a time limit, until the time
        // is spent.
        let total = if budget.is_some() && spp.is_none() { None } else { Some(built.spp) };
        let progress = Progress::new(py, progress, total)?;
        // The passes run on this thread (which must be Python's main thread to see Ctrl-C), their samples on the
        // threads asked for.
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads.unwrap_or(0) as usize)
            .build()
            .map_err(|e| PyRuntimeError::new_err(format!("cannot start the worker threads: {e}")))?;
        let nthreads = pool.current_num_threads();
        let start = Instant::now();
        let mut stats = render::RenderStats::default();
        let mut render = |film: &mut film::Film| -> Result<(u32, Option<PyErr>), String> {
            let mut job = built.integrator.begin(&built.scene, film, seed).map_err(|e| e.to_string())?;
            // Passes of growing size, each well under a second, so that Ctrl-C (seen between passes) is answered
            // quickly; a pixel's samples are added in the same order whatever the passes, so the image is the same.
            let (mut done, mut sizes, mut stopped) = (0u32, render::PassSizes::default(), None);
            let end = total.unwrap_or(u32::MAX);
            while done < end && budget.is_none_or(|b| done == 0 || start.elapsed() < b) {
                let pass_start = Instant::now();
                let n = sizes.next(end - done);
                let s = pool.install(|| job.run(film, done..done + n, &|_| {}));
                stats.samples += s.samples;
                stats.rays += s.rays;
                done += n;
                let left = budget.map_or(Duration::MAX, |b| b.saturating_sub(start.elapsed()));
                sizes.took_leaving(pass_start.elapsed(), left);
                let checked = Python::attach(|py| -> PyResult<()> {
                    progress.report(py, done, total, n)?;
                    py.check_signals()
                });
                if let Err(e) = checked {
                    stopped = Some(e);
                    break;
                }
            }
            // Whatever the integrator keeps outside the film (photon mapping's estimate) goes in, also after a stop.
            job.finish(film);
            Ok((done, stopped))
        };
        let result = py.detach(|| render(&mut film));
        progress.close(py);
        let (done, stopped) = result.map_err(PyRuntimeError::new_err)?;
        let statistics = RenderStatistics {
            render_seconds: start.elapsed().as_secs_f64(),
            build_seconds: build.seconds,
            shapes_built: build.shapes_built,
            samples: stats.samples,
            rays: stats.rays,
            integrator: built.integrator.name(),
            wavelengths: strategy.name(),
            threads: nthreads,
            triangles: built.triangles,
            lights: built.scene.light_count(),
            spp_requested: total,
        };
        let image = Image::new(py, film, done, statistics)?;
        match stopped {
            None => Ok(image),
            Some(e) => {
                // Ctrl-C: the KeyboardInterrupt carries the partial image (`.image`), the image the command line
                // writes when interrupted; so does an exception raised by the progress callback.
                e.value(py).setattr("image", Py::new(py, image)?)?;
                Err(e)
            }
        }
    }

    /// Replaces material `key` (a name given by `MakeNamedMaterial`, or the index of an anonymous `Material` in
    /// `materials`) by one of type `type` with parameters `params`, written as in a scene file
    /// (`'"spectrum eta" "glass-F11" "float roughness" 0.01'`; the scene's textures can be named). The scene is
    /// built again at once with the options of the last render (the BVH is kept unless the material becomes or
    /// stops being an `interface` or a `subsurface`): an error leaves the scene as it was and raises ValueError
    /// (a bad type or parameter), KeyError or IndexError (no such material).
    #[pyo3(signature = (key, r#type, params=""))]
    fn set_material(&self, py: Python<'_>, key: Bound<'_, PyAny>, r#type: &str, params: &str) -> PyResult<()> {
        let slot = if let Ok(name) = key.extract::<String>() {
            Slot::NamedMaterial(name)
        } else if let Ok(i) = key.extract::<i64>() {
            Slot::AnonymousMaterial(i)
        } else {
            return Err(PyTypeError::new_err("key must be a material's name (str) or an anonymous material's index"));
        };
        self.edit(py, slot, r#type, params)
    }

    /// Replaces medium `name` (a `MakeNamedMedium`) by a medium of type `type` ("homogeneous", "mie", …) with
    /// parameters `params`, written as in a scene file; the medium keeps its placement. Built at once, as
    /// `set_material` is (the BVH is kept).
    #[pyo3(signature = (name, r#type, params=""))]
    fn set_medium(&self, py: Python<'_>, name: String, r#type: &str, params: &str) -> PyResult<()> {
        self.edit(py, Slot::Medium(name), r#type, params)
    }

    /// Replaces light `index` (in `lights`: the scene's `LightSource` directives in file order) by a light of type
    /// `type` with parameters `params`, written as in a scene file; the light keeps its transform and medium.
    /// Built at once, as `set_material` is (the BVH is kept).
    #[pyo3(signature = (index, r#type, params=""))]
    fn set_light(&self, py: Python<'_>, index: i64, r#type: &str, params: &str) -> PyResult<()> {
        self.edit(py, Slot::Light(index), r#type, params)
    }

    /// The scene's materials, `{key: type}`: anonymous `Material`s by index (0 is pbrt-v4's default diffuse),
    /// then named ones by name, in the order `set_material` takes them.
    #[getter]
    fn materials<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let (anonymous, named) = self.read(py, |d| {
            let anonymous: Vec<String> = d.materials.iter().map(|m| m.name.clone()).collect();
            let named: Vec<(String, String)> =
                d.named_materials.iter().map(|(n, m)| (n.clone(), m.name.clone())).collect();
            (anonymous, named)
        })?;
        let dict = PyDict::new(py);
        for (i, ty) in anonymous.into_iter().enumerate() {
            dict.set_item(i, ty)?;
        }
        for (name, ty) in named {
            dict.set_item(name, ty)?;
        }
        Ok(dict)
    }

    /// The scene's named media, `{name: type}`.
    #[getter]
    fn media<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let media = self
            .read(py, |d| d.media.iter().map(|m| (m.medium_name.clone(), m.entity.name.clone())).collect::<Vec<_>>())?;
        let dict = PyDict::new(py);
        for (name, ty) in media {
            dict.set_item(name, ty)?;
        }
        Ok(dict)
    }

    /// The types of the scene's `LightSource` lights, in file order (area lights belong to their shapes).
    #[getter]
    fn lights(&self, py: Python<'_>) -> PyResult<Vec<String>> {
        self.read(py, |d| d.lights.iter().map(|l| l.entity.name.clone()).collect())
    }

    /// How many times the shapes (meshes, BVH, area lights) have been built: once, unless an edit changed what
    /// the BVH records (a material becoming an `interface` or a `subsurface`). Other options, materials, media,
    /// lights and integrators build only the rest of the scene (textures, materials, media, lights, camera, film).
    #[getter]
    fn builds(&self) -> u32 {
        self.builds.load(Ordering::Relaxed)
    }

    /// The file the scene was loaded from (None for a scene given as text).
    #[getter]
    fn path(&self) -> Option<String> {
        self.path.as_ref().map(|p| p.display().to_string())
    }

    fn __repr__(&self) -> String {
        match &self.path {
            Some(p) => format!("<prismatic.Scene {}>", p.display()),
            None => "<prismatic.Scene (from text)>".into(),
        }
    }
}

/// What an edit replaces.
enum Slot {
    NamedMaterial(String),
    AnonymousMaterial(i64),
    Medium(String),
    Light(i64),
}

impl Slot {
    /// How the edit is named in messages.
    fn what(&self) -> String {
        match self {
            Slot::NamedMaterial(n) => format!("set_material {n}"),
            Slot::AnonymousMaterial(i) => format!("set_material {i}"),
            Slot::Medium(n) => format!("set_medium {n}"),
            Slot::Light(i) => format!("set_light {i}"),
        }
    }

    /// The directive whose arguments the edit's type and parameters are (a medium's too are read as a
    /// `Material`'s: a type and parameters), and its entity taken out of a parsed description.
    fn directive(&self) -> (&'static str, fn(SceneDescription) -> Option<Entity>) {
        match self {
            Slot::NamedMaterial(_) | Slot::AnonymousMaterial(_) | Slot::Medium(_) => {
                ("Material", |mut d| d.materials.pop())
            }
            Slot::Light(_) => ("LightSource", |mut d| d.lights.pop().map(|l| l.entity)),
        }
    }

    /// The entity the edit replaces in `desc`.
    fn get<'d>(&self, desc: &'d mut SceneDescription) -> PyResult<&'d mut Entity> {
        match self {
            Slot::NamedMaterial(name) => {
                let names: Vec<String> = desc.named_materials.iter().map(|(n, _)| n.clone()).collect();
                desc.named_materials.iter_mut().find(|(n, _)| n == name).map(|(_, e)| e).ok_or_else(|| {
                    PyKeyError::new_err(format!("no material named '{name}'; named materials: {}", names.join(", ")))
                })
            }
            Slot::AnonymousMaterial(i) => {
                let n = desc.materials.len();
                usize::try_from(*i).ok().and_then(|i| desc.materials.get_mut(i)).ok_or_else(|| {
                    PyIndexError::new_err(format!("no anonymous material {i}: the scene has {n} (from 0)"))
                })
            }
            Slot::Medium(name) => {
                let names: Vec<String> = desc.media.iter().map(|m| m.medium_name.clone()).collect();
                desc.media.iter_mut().find(|m| m.medium_name == *name).map(|m| &mut m.entity).ok_or_else(|| {
                    PyKeyError::new_err(format!("no medium named '{name}'; media: {}", names.join(", ")))
                })
            }
            Slot::Light(i) => {
                let n = desc.lights.len();
                usize::try_from(*i)
                    .ok()
                    .and_then(|i| desc.lights.get_mut(i))
                    .map(|l| &mut l.entity)
                    .ok_or_else(|| PyIndexError::new_err(format!("no light {i}: the scene has {n} LightSource lights")))
            }
        }
    }
}

impl Scene {
    /// A scene of description `desc` read from `path`.
    pub fn new(desc: SceneDescription, path: Option<PathBuf>) -> Self {
        Scene { state: Mutex::new(State { desc, edits: 0, kept: None }), path, builds: AtomicU32::new(0) }
    }

    /// What `f` reads from the description, the lock taken with the GIL released (a thread holding it while
    /// building must be able to take the GIL back from another thread waiting for the lock).
    fn read<T: Send>(&self, py: Python<'_>, f: impl FnOnce(&SceneDescription) -> T + Send) -> PyResult<T> {
        py.detach(|| self.state.lock().map(|s| f(&s.desc)).map_err(|_| ()))
            .map_err(|_| PyRuntimeError::new_err("an earlier build of this scene panicked"))
    }

    /// The scene built with `key`'s options.
    fn build(&self, py: Python<'_>, key: &BuildKey) -> PyResult<Build> {
        py.detach(|| -> Result<Build, BuildFailure> {
            let mut state = self.state.lock().map_err(|_| BuildFailure::Poisoned)?;
            state.build(key, &self.builds).map_err(BuildFailure::Scene)
        })
        .map_err(|e| match e {
            // An error in the integrator asked for is a bad value of the option.
            BuildFailure::Scene(render::RenderError::Scene(s)) if is_virtual(&s.loc().file, "integrator") => {
                PyValueError::new_err(format!("integrator: {}", s.message()))
            }
            e => e.into_py(py),
        })
    }

    /// An edit: `type` and `params` parsed as the slot's directive, put in its place, and the scene built again
    /// with the last build's options; on any error the description is left as it was. All of it with the GIL
    /// released, under the lock.
    fn edit(&self, py: Python<'_>, slot: Slot, ty: &str, params: &str) -> PyResult<()> {
        let what = slot.what();
        let edited = py.detach(|| -> Result<(), EditFailure> {
            let mut state = self.state.lock().map_err(|_| EditFailure::Python(poisoned()))?;
            let (directive, take) = slot.directive();
            let entity = parse_directive(&state.desc, &what, directive, ty, params, take)?;
            let original = std::mem::replace(slot.get(&mut state.desc)?, entity);
            state.edits += 1;
            let key = state.kept.as_ref().map(|k| k.key.clone()).unwrap_or_default();
            let Err(e) = state.build(&key, &self.builds) else { return Ok(()) };
            *slot.get(&mut state.desc)? = original;
            state.edits += 1;
            Err(EditFailure::Build(e))
        });
        match edited {
            Ok(()) => Ok(()),
            Err(EditFailure::Python(e)) => Err(e),
            // An error in the edit's own text (its virtual file) is a bad value; any other is the scene's.
            Err(EditFailure::Build(render::RenderError::Scene(s))) if is_virtual(&s.loc().file, &what) => {
                Err(PyValueError::new_err(format!("{what}: {}", s.message())))
            }
            Err(EditFailure::Build(e)) => Err(build_error(py, e)),
        }
    }
}

/// Why an edit failed: a Python error (made without the GIL: raised later), or the build.
enum EditFailure {
    Python(PyErr),
    Build(render::RenderError),
}

impl From<PyErr> for EditFailure {
    fn from(e: PyErr) -> Self {
        EditFailure::Python(e)
    }
}

fn poisoned() -> PyErr {
    PyRuntimeError::new_err("an earlier build of this scene panicked")
}

/// Whether `file` is the virtual file of an edit or option named `what` (see [`virtual_file`]).
fn is_virtual(file: &Path, what: &str) -> bool {
    file.file_name().and_then(|n| n.to_str()).is_some_and(|n| n == format!("<{what}>"))
}

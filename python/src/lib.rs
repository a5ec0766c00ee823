//! `import prismatic`: the renderer as a Python extension module (built with maturin; the Python side is in
//! `python/prismatic/`). A scene is parsed once and built once per set of build options; a render releases the
//! GIL and returns the image as a NumPy array, the same values the command line writes for the same scene,
//! options and seed.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use numpy::ndarray::Array3;
use numpy::{IntoPyArray, PyArray1, PyArray3};
use pyo3::exceptions::{PyException, PyOSError, PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyBytes;

pyo3::create_exception!(
    _prismatic,
    SceneError,
    PyException,
    "A scene that cannot be read or built: `file`, `line` and `column` say where (None where the error has no place \
     in a scene file), `message` what is wrong."
);

/// A SceneError with its place.
fn scene_error(py: Python<'_>, loc: Option<&scene::Loc>, full: String, message: String) -> PyErr {
    let err = SceneError::new_err(full);
    let value = err.value(py);
    let (file, line, column) = match loc {
        Some(l) => {
            (Some(l.file.display().to_string()), Some(l.line).filter(|&n| n > 0), Some(l.column).filter(|&n| n > 0))
        }
        None => (None, None, None),
    };
    // Setting attributes on a fresh exception object cannot fail short of memory exhaustion; a failure would
    // leave the attribute missing, which the message still covers.
    let _ = value.setattr("file", file);
    let _ = value.setattr("line", line);
    let _ = value.setattr("column", column);
    let _ = value.setattr("message", message);
    err
}

fn parse_error(py: Python<'_>, e: pbrt::ParseError) -> PyErr {
    scene_error(py, Some(&e.loc), e.to_string(), e.message.clone())
}

fn build_error(py: Python<'_>, e: render::RenderError) -> PyErr {
    match &e {
        render::RenderError::Scene(s) => scene_error(py, Some(s.loc()), e.to_string(), s.message()),
        render::RenderError::ReferencedFile { loc, message, .. } => {
            scene_error(py, Some(loc), e.to_string(), message.clone())
        }
        _ => scene_error(py, None, e.to_string(), e.to_string()),
    }
}

/// The options a scene is built with (a film size or a sample count changes the built scene).
#[derive(Clone, Debug, PartialEq)]
struct BuildKey {
    resolution: Option<(u32, u32)>,
    spp: Option<u32>,
}

/// A parsed pbrt-v4 scene. `render` builds it (once per resolution and sample count) and renders it.
#[pyclass(module = "prismatic._prismatic", frozen)]
struct Scene {
    desc: pbrt::SceneDescription,
    /// What `load` was given (None for `loads`).
    path: Option<PathBuf>,
    /// The last scene built, with the options it was built with: rendering again with the same ones (another seed,
    /// other threads) builds nothing.
    built: Mutex<Option<(BuildKey, Arc<render::BuiltScene>)>>,
    /// How many times the scene was built.
    builds: AtomicU32,
}

/// A spectral film's buckets (height × width × N) and their N + 1 edges in nm.
type SpectralArrays = (Py<PyArray3<f32>>, Py<PyArray1<f64>>);

/// A rendered image: `rgb`, linear in the film's colour space, `height × width × 3` float32; for a spectral film
/// also `spectral` (`height × width × N`) with `wavelengths`, the N + 1 bucket edges in nm.
#[pyclass(module = "prismatic._prismatic", frozen)]
struct Image {
    film: film::Film,
    rgb: Py<PyArray3<f32>>,
    spectral: Option<SpectralArrays>,
    #[pyo3(get)]
    width: u32,
    #[pyo3(get)]
    height: u32,
    /// Samples per pixel rendered (fewer than asked if the render was interrupted).
    #[pyo3(get)]
    spp: u32,
}

impl Image {
    /// The display encoding of the film's colour space through `view` (the film's view if None).
    fn encoding(&self, view: Option<&str>) -> PyResult<film::DisplayEncoding> {
        let view = match view {
            None => self.film.spec().view,
            Some(name) => film::View::by_name(name).ok_or_else(|| {
                PyValueError::new_err(format!(
                    "view: unknown view '{name}'; valid views: {}",
                    film::View::NAMES.join(", ")
                ))
            })?,
        };
        Ok(film::DisplayEncoding::new(&self.film.spec().color_space, view))
    }

    /// The image of `film` after `spp` samples per pixel: one copy of the film's values into each array.
    fn new(py: Python<'_>, film: film::Film, spp: u32) -> PyResult<Self> {
        let b = film.bounds();
        let (w, h) = (b.width(), b.height());
        let shape = |n: usize| (h as usize, w as usize, n);
        let flat: Vec<f32> = film.to_rgb_image().into_iter().flatten().collect();
        let rgb = Array3::from_shape_vec(shape(3), flat)
            .map_err(|e| PyRuntimeError::new_err(format!("image of {w}×{h}: {e}")))?;
        let spectral = match film.spec().kind {
            film::FilmKind::Rgb => None,
            film::FilmKind::Spectral { nbuckets, lambda_min, lambda_max } => {
                let values = Array3::from_shape_vec(shape(nbuckets), film.to_spectral_image())
                    .map_err(|e| PyRuntimeError::new_err(format!("spectral image of {w}×{h}: {e}")))?;
                let step = (lambda_max - lambda_min) / nbuckets as f64;
                let edges: Vec<f64> = (0..=nbuckets).map(|i| lambda_min + step * i as f64).collect();
                Some((values.into_pyarray(py).unbind(), PyArray1::from_vec(py, edges).unbind()))
            }
        };
        Ok(Image { film, rgb: rgb.into_pyarray(py).unbind(), spectral, width: w, height: h, spp })
    }
}

#[pymethods]
impl Image {
    /// The linear RGB image, `height × width × 3`, float32 (rows from the top).
    #[getter]
    fn rgb(&self, py: Python<'_>) -> Py<PyArray3<f32>> {
        self.rgb.clone_ref(py)
    }

    /// The spectral image of a spectral film, `height × width × N` (radiance per bucket), else None.
    #[getter]
    fn spectral(&self, py: Python<'_>) -> Option<Py<PyArray3<f32>>> {
        self.spectral.as_ref().map(|(s, _)| s.clone_ref(py))
    }

    /// The N + 1 edges of the spectral buckets in nm, else None.
    #[getter]
    fn wavelengths(&self, py: Python<'_>) -> Option<Py<PyArray1<f64>>> {
        self.spectral.as_ref().map(|(_, w)| w.clone_ref(py))
    }

    /// Writes the image as the command line does, by the path's extension: `.exr` (linear; spectral films add
    /// their buckets), `.png` (the film's display view, 8-bit) or `.pfm`; atomically.
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let attributes = [("samplesPerPixel".to_string(), self.spp.to_string())];
        py.detach(|| film::write_image_with(&self.film, &path, &attributes))
            .map_err(|e| PyOSError::new_err(e.to_string()))
    }

    /// The 8-bit display image the command line's PNG holds, `height × width × 3` uint8: through `view` ("oklab",
    /// the default, or "clip"; the film's own if None) into the film's colour space, sRGB-encoded and dithered.
    #[pyo3(signature = (view=None))]
    fn display(&self, py: Python<'_>, view: Option<&str>) -> PyResult<Py<PyArray3<u8>>> {
        let bytes = self.encoding(view)?.encode_8bit(&self.film.to_rgb_image(), self.width);
        let array = Array3::from_shape_vec((self.height as usize, self.width as usize, 3), bytes)
            .map_err(|e| PyRuntimeError::new_err(format!("display image: {e}")))?;
        Ok(array.into_pyarray(py).unbind())
    }

    /// The PNG the command line writes (Jupyter shows an Image inline through this).
    fn _repr_png_<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        let png = film::encode_display_png(
            "image.png",
            self.width,
            self.height,
            &self.film.to_rgb_image(),
            &self.encoding(None)?,
        )
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        Ok(PyBytes::new(py, &png))
    }

    fn __repr__(&self) -> String {
        format!("<prismatic.Image {}×{}, {} spp>", self.width, self.height, self.spp)
    }
}

/// `n` as a count in [1, `max`], else ValueError naming `name`.
fn positive(name: &str, n: i64, max: i64) -> PyResult<u32> {
    if (1..=max).contains(&n) {
        Ok(n as u32)
    } else {
        Err(PyValueError::new_err(format!("{name} must be between 1 and {max}, got {n}")))
    }
}

#[pymethods]
impl Scene {
    /// Renders the scene; returns an [`Image`]. `spp` and `resolution` (width, height) replace the scene's, `seed`
    /// is the render seed (the command line's `--seed`), `threads` the number of threads (all cores by default),
    /// `wavelengths` the strategy ("hero", "cmf" or "rgb"), `progress` a function called as `progress(done,
    /// total)` after each pass. The GIL is released while rendering. Ctrl-C stops the render at the end of the
    /// pass: the KeyboardInterrupt raised carries the partial image as `.image`.
    #[pyo3(signature = (*, spp=None, resolution=None, seed=0, threads=None, wavelengths=None, progress=None))]
    #[allow(clippy::too_many_arguments)]
    fn render(
        &self,
        py: Python<'_>,
        spp: Option<i64>,
        resolution: Option<Bound<'_, PyAny>>,
        seed: i64,
        threads: Option<i64>,
        wavelengths: Option<&str>,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<Image> {
        let spp = spp.map(|n| positive("spp", n, 1 << 24)).transpose()?;
        let resolution =
            match resolution {
                None => None,
                Some(r) => Some(r.extract::<(i64, i64)>().map_err(|e| {
                    PyTypeError::new_err(format!("resolution must be (width, height), two integers: {e}"))
                })?),
            };
        let resolution = match resolution {
            None => None,
            Some((w, h)) => {
                Some((positive("resolution width", w, 1 << 16)?, positive("resolution height", h, 1 << 16)?))
            }
        };
        let seed = u32::try_from(seed)
            .map_err(|_| PyValueError::new_err(format!("seed must be between 0 and {}, got {seed}", u32::MAX)))?;
        let threads = threads.map(|n| positive("threads", n, 4096)).transpose()?;
        let strategy = match wavelengths {
            None => spectral::WavelengthStrategy::default(),
            Some(s) => s.parse().map_err(|e: String| PyValueError::new_err(format!("wavelengths: {e}")))?,
        };
        if let Some(f) = &progress {
            if !f.bind(py).is_callable() {
                return Err(PyTypeError::new_err("progress must be a function progress(done, total)"));
            }
        }
        let built = self.built(py, BuildKey { resolution, spp })?;
        let mut spec = built.film.clone();
        spec.wavelengths = strategy;
        let mut film = film::Film::new(spec).map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        let total = built.spp;
        // The passes run on this thread (which must be Python's main thread to see Ctrl-C), their samples on the
        // threads asked for.
        let pool = match threads {
            None => None,
            Some(n) => Some(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(n as usize)
                    .build()
                    .map_err(|e| PyRuntimeError::new_err(format!("cannot start {n} threads: {e}")))?,
            ),
        };
        let render = |film: &mut film::Film| -> Result<(u32, Option<PyErr>), String> {
            let mut job = built.integrator.begin(&built.scene, film, seed).map_err(|e| e.to_string())?;
            // Passes of growing size, each well under a second, so that Ctrl-C (seen between passes) is answered
            // quickly; a pixel's samples are added in the same order whatever the passes, so the image is the same.
            let (mut done, mut sizes, mut stopped) = (0u32, render::PassSizes::default(), None);
            while done < total {
                let start = Instant::now();
                let n = sizes.next(total - done);
                match &pool {
                    Some(pool) => pool.install(|| job.run(film, done..done + n, &|_| {})),
                    None => job.run(film, done..done + n, &|_| {}),
                };
                done += n;
                sizes.took(start.elapsed());
                let checked = Python::attach(|py| -> PyResult<()> {
                    if let Some(f) = &progress {
                        f.call1(py, (done, total))?;
                    }
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
        let (done, stopped) = result.map_err(PyRuntimeError::new_err)?;
        let image = Image::new(py, film, done)?;
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

    /// How many times the scene has been built (shapes, BVH, lights, textures): once per change of `spp` or
    /// `resolution` between renders; another seed, thread count or wavelength strategy reuses the last build.
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

impl Scene {
    /// The scene built with `key`'s options: the one kept from the last render if it had the same.
    fn built(&self, py: Python<'_>, key: BuildKey) -> PyResult<Arc<render::BuiltScene>> {
        // The lock is taken with the GIL released: a thread holding it while building must be able to take the GIL
        // back from another thread waiting for the lock.
        let built = py.detach(|| -> Result<Arc<render::BuiltScene>, Option<render::RenderError>> {
            let mut kept = self.built.lock().map_err(|_| None)?;
            if let Some((k, b)) = kept.as_ref() {
                if *k == key {
                    return Ok(b.clone());
                }
            }
            let options = render::BuildOptions { resolution: key.resolution, spp: key.spp, ..Default::default() };
            let built = Arc::new(render::build_scene(&self.desc, &options).map_err(Some)?);
            self.builds.fetch_add(1, Ordering::Relaxed);
            *kept = Some((key, built.clone()));
            Ok(built)
        });
        built.map_err(|e| match e {
            Some(e) => build_error(py, e),
            None => PyRuntimeError::new_err("an earlier render of this scene panicked"),
        })
    }
}

/// Parses the pbrt-v4 scene file at `path` (and the files it includes). Raises SceneError for a scene that cannot
/// be read, with the file, line and column.
#[pyfunction]
fn load(py: Python<'_>, path: PathBuf) -> PyResult<Scene> {
    let desc = py.detach(|| pbrt::parse_file(&path)).map_err(|e| parse_error(py, e))?;
    Ok(Scene { desc, path: Some(path), built: Mutex::new(None), builds: AtomicU32::new(0) })
}

/// Parses a pbrt-v4 scene given as text; files it names are found relative to `base_dir` (the current directory by
/// default). Raises SceneError as `load` does, naming the file `<string>`.
#[pyfunction]
#[pyo3(signature = (text, base_dir=None))]
fn loads(py: Python<'_>, text: &str, base_dir: Option<PathBuf>) -> PyResult<Scene> {
    let virtual_path = base_dir.map_or_else(|| PathBuf::from("<string>"), |d| d.join("<string>"));
    let desc = pbrt::parse_str(text, Path::new(&virtual_path)).map_err(|e| parse_error(py, e))?;
    Ok(Scene { desc, path: None, built: Mutex::new(None), builds: AtomicU32::new(0) })
}

/// n at each wavelength, and k for a material that absorbs.
type IndexArrays = (Py<PyArray1<f64>>, Option<Py<PyArray1<f64>>>);

/// A catalogue material: name, category, n_d, V_d, valid range (nm), source.
type CatalogueRow = (String, String, Option<f64>, Option<f64>, (f64, f64), String);

/// n(λ) and, for a material that absorbs (a metal), k(λ) of catalogue material `name` at each of `nm` (nm):
/// what `prismatic ior NAME --nm …` prints. `prismatic.ior` wraps it for any array shape.
#[pyfunction]
fn _ior(py: Python<'_>, name: &str, nm: numpy::PyReadonlyArray1<'_, f64>) -> PyResult<IndexArrays> {
    let entry = optics::catalogue::lookup(name).map_err(|e| PyValueError::new_err(format!("name: {e}")))?;
    let nm = nm.as_slice()?;
    if let Some(bad) = nm.iter().find(|l| !(l.is_finite() && **l > 0.0)) {
        return Err(PyValueError::new_err(format!("nm: wavelengths are positive numbers of nanometres, got {bad}")));
    }
    let n: Vec<f64> = nm.iter().map(|&l| entry.ior.n(l)).collect();
    use optics::catalogue::Category;
    let k = match entry.category {
        Category::Metal => Some(nm.iter().map(|&l| entry.ior.k(l)).collect::<Vec<f64>>()),
        Category::SchottGlass
        | Category::HoyaGlass
        | Category::Glass
        | Category::Liquid
        | Category::Crystal
        | Category::UniaxialCrystal => None,
    };
    Ok((PyArray1::from_vec(py, n).unbind(), k.map(|k| PyArray1::from_vec(py, k).unbind())))
}

/// The catalogue `prismatic ior --list` prints: (name, category, n_d or None, V_d or None, valid range in nm,
/// source) per material.
#[pyfunction]
fn _catalogue() -> Vec<CatalogueRow> {
    optics::catalogue::entries()
        .iter()
        .map(|e| {
            (
                e.name.to_string(),
                e.category.to_string(),
                e.dispersion.as_ref().map(|d| d.nd),
                e.dispersion.as_ref().map(|d| d.vd),
                e.valid_range_nm,
                e.source.to_string(),
            )
        })
        .collect()
}

/// The extension module; `prismatic/__init__.py` re-exports it.
#[pymodule]
fn _prismatic(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add_function(wrap_pyfunction!(loads, m)?)?;
    m.add_function(wrap_pyfunction!(_ior, m)?)?;
    m.add_function(wrap_pyfunction!(_catalogue, m)?)?;
    m.add_class::<Scene>()?;
    m.add_class::<Image>()?;
    m.add("SceneError", m.py().get_type::<SceneError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}

//! `import prismatic`: the renderer as a Python extension module (built with maturin; the Python side is in
//! `python/prismatic/`). A scene is parsed once and its shapes built once; a render releases the GIL and returns
//! the image as NumPy arrays, the same values the command line writes for the same scene, options and seed.

use pyo3::prelude::*;

mod errors;
mod image;
mod scene;
mod tools;

use errors::{gltf_error, parse_error, SceneError};
use scene::Scene;

/// Reads the scene file at `path`: a pbrt-v4 file (and the files it includes), or a glTF 2.0 file (`.gltf`,
/// `.glb`; `camera` picks its camera by name or index, the first by default). Raises SceneError for a scene that
/// cannot be read: with the file, line and column, or for glTF the JSON path in the message.
#[pyfunction]
#[pyo3(signature = (path, camera=None))]
fn load(py: Python<'_>, path: std::path::PathBuf, camera: Option<String>) -> PyResult<Scene> {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    let desc = if matches!(ext.as_deref(), Some("gltf" | "glb")) {
        let options = gltf_import::ReadOptions { camera };
        py.detach(|| gltf_import::read_scene(&path, &options)).map_err(|e| gltf_error(py, e))?
    } else {
        if camera.is_some() {
            return Err(pyo3::exceptions::PyValueError::new_err(
                "camera: picks a glTF scene's camera; a pbrt-v4 file has its own Camera directive",
            ));
        }
        py.detach(|| pbrt::parse_file(&path)).map_err(|e| parse_error(py, e))?
    };
    Ok(Scene::new(desc, Some(path)))
}

/// Parses a pbrt-v4 scene given as text; files it names are found relative to `base_dir` (the current directory by
/// default). Raises SceneError as `load` does, naming the file `<string>`.
#[pyfunction]
#[pyo3(signature = (text, base_dir=None))]
fn loads(py: Python<'_>, text: &str, base_dir: Option<std::path::PathBuf>) -> PyResult<Scene> {
    let virtual_path = base_dir.map_or_else(|| "<string>".into(), |d| d.join("<string>"));
    let desc = pbrt::parse_str(text, &virtual_path).map_err(|e| parse_error(py, e))?;
    Ok(Scene::new(desc, None))
}

/// The extension module; `prismatic/__init__.py` re-exports it.
#[pymodule]
fn _prismatic(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add_function(wrap_pyfunction!(loads, m)?)?;
    m.add_function(wrap_pyfunction!(tools::_ior, m)?)?;
    m.add_function(wrap_pyfunction!(tools::_catalogue, m)?)?;
    m.add_function(wrap_pyfunction!(tools::_prism_deviation, m)?)?;
    m.add_function(wrap_pyfunction!(tools::_rainbow_angle, m)?)?;
    m.add_class::<Scene>()?;
    m.add_class::<image::Image>()?;
    m.add_class::<tools::Spectrum>()?;
    m.add("SceneError", m.py().get_type::<SceneError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}

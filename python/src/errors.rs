//! `prismatic.SceneError` and the conversion of the renderer's errors into it.

use pyo3::exceptions::PyException;
use pyo3::prelude::*;

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

/// A parse error as a SceneError.
pub fn parse_error(py: Python<'_>, e: pbrt::ParseError) -> PyErr {
    scene_error(py, Some(&e.loc), e.to_string(), e.message.clone())
}

/// A glTF reader's error as a SceneError: the file, no line or column, the JSON path in the message.
pub fn gltf_error(py: Python<'_>, e: gltf_import::GltfError) -> PyErr {
    let loc = scene::Loc::new(std::sync::Arc::from(e.file.as_path()), 0, 0);
    scene_error(py, Some(&loc), e.to_string(), e.to_string())
}

/// A build error as a SceneError.
pub fn build_error(py: Python<'_>, e: render::RenderError) -> PyErr {
    match &e {
        render::RenderError::Scene(s) => scene_error(py, Some(s.loc()), e.to_string(), s.message()),
        render::RenderError::ReferencedFile { loc, message, .. } => {
            scene_error(py, Some(loc), e.to_string(), message.clone())
        }
        _ => scene_error(py, None, e.to_string(), e.to_string()),
    }
}

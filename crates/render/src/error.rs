//! The error type of the render crate: what can go wrong building a scene, reading the files it references, making
//! a render's film and continuing a render from a saved state.

use std::path::{Path, PathBuf};

use film::FilmError;
use scene::{Loc, SceneError};

/// What can go wrong in the render crate; every fallible public function returns it.
///
/// Errors about the scene ([`RenderError::Scene`], [`RenderError::ReferencedFile`]) read
/// `file:line:column: error: …`, as the scene parser's do.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The scene description is wrong: a directive or a parameter (an unknown type name, a value out of range, a
    /// name never defined), at its file, line and column.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// A file the scene references (an image, an environment map, a PLY mesh, an RGL tensor file) cannot be read or
    /// holds data that cannot be used, at the place in the scene that names it.
    #[error("{loc}: error: {message}")]
    ReferencedFile {
        /// Where the scene names the file.
        loc: Loc,
        /// The file.
        path: PathBuf,
        /// What is wrong, naming the file.
        message: String,
    },
    /// A file cannot be read.
    #[error("{}: {source}", .path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        #[source]
        source: std::io::Error,
    },
    /// Data that cannot be used (an RGL tensor file's contents, a table or an image given in memory): what is
    /// wrong, after the file's path when the data came from a file.
    #[error("{}{message}", file_prefix(.path))]
    InvalidData {
        /// The file the data were read from, if any.
        path: Option<PathBuf>,
        /// What is wrong.
        message: String,
    },
    /// The film cannot be made or rendered into (its size, its filter's table).
    #[error(transparent)]
    Film(#[from] FilmError),
    /// A saved render state (a checkpoint's) does not fit the render job it was given to: another integrator,
    /// film or size, or damaged values.
    #[error("{0}")]
    StateMismatch(String),
}

/// Data that cannot be used, not read from a file (see [`RenderError::in_file`]).
pub(crate) fn invalid_data(message: impl Into<String>) -> RenderError {
    RenderError::InvalidData { path: None, message: message.into() }
}

impl RenderError {
    /// The error with `path` as the file its data came from, if it is [`RenderError::InvalidData`] without one.
    pub fn in_file(self, path: &Path) -> Self {
        match self {
            RenderError::InvalidData { path: None, message } => {
                RenderError::InvalidData { path: Some(path.to_path_buf()), message }
            }
            other @ (RenderError::Scene(_)
            | RenderError::ReferencedFile { .. }
            | RenderError::Io { .. }
            | RenderError::InvalidData { path: Some(_), .. }
            | RenderError::Film(_)
            | RenderError::StateMismatch(_)) => other,
        }
    }
}

/// "path: " for data read from a file, nothing otherwise.
fn file_prefix(path: &Option<PathBuf>) -> String {
    path.as_ref().map(|p| format!("{}: ", p.display())).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;

    #[test]
    fn messages_keep_the_wording_of_what_they_wrap() {
        let loc = Loc::new(Arc::from(Path::new("scene.pbrt")), 3, 7);
        let scene = SceneError::at(loc.clone(), "no material named 'x'");
        assert_eq!(RenderError::from(scene.clone()).to_string(), scene.to_string());
        let file = RenderError::ReferencedFile {
            loc,
            path: "a.bsdf".into(),
            message: "'filename': a.bsdf: not a tensor file".into(),
        };
        assert_eq!(file.to_string(), "scene.pbrt:3:7: error: 'filename': a.bsdf: not a tensor file");
        let data = invalid_data("truncated");
        assert_eq!(data.to_string(), "truncated");
        assert_eq!(data.in_file(Path::new("a.bsdf")).to_string(), "a.bsdf: truncated");
        let io = RenderError::Io { path: "b.bsdf".into(), source: std::io::Error::other("gone") };
        assert_eq!(io.to_string(), "b.bsdf: gone");
    }
}

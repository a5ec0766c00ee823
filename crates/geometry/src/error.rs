//! The error type of the geometry crate.

/// Errors from building geometry from user data. Each names the problem.
#[derive(Debug, thiserror::Error)]
pub enum GeometryError {
    /// A mesh's data is inconsistent (index out of range, wrong array length, non-finite value…).
    #[error("invalid mesh: {0}")]
    InvalidMesh(String),
    /// A shape's parameters are invalid (negative radius…).
    #[error("invalid shape: {0}")]
    InvalidShape(String),
    /// An instance refers to a missing object or has a bad transform.
    #[error("invalid instance: {0}")]
    InvalidInstance(String),
    /// A PLY file could not be read or understood.
    #[error("PLY file {path}: {message}")]
    Ply {
        /// The file.
        path: String,
        /// What went wrong.
        message: String,
    },
}

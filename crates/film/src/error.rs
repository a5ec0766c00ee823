//! Error types of the film crate.

use std::path::PathBuf;

/// Errors from building filters and films out of user-supplied parameters, and from combining films.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum FilmError {
    /// A parameter lies outside the range it allows (or is NaN or infinite).
    #[error("{name} = {value} is invalid: {expected}")]
    InvalidParameter {
        /// The parameter's name, as a scene file spells it (`xradius`, `sigma`, `nbuckets`, `lambdamin`, ...).
        name: &'static str,
        /// The offending value.
        value: f64,
        /// What the parameter allows, in words.
        expected: &'static str,
    },
    /// The film would need more memory than can be allocated.
    #[error("a {width}×{height} film with {channels} values per pixel is too large to allocate")]
    TooLarge {
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
        /// Accumulated values per pixel.
        channels: usize,
    },
    /// Two films that were to be merged differ in size, kind or AOVs.
    #[error("cannot merge films: {0}")]
    Mismatch(String),
    /// A pixel coordinate outside the film.
    #[error("pixel ({x}, {y}) is outside the {width}×{height} film")]
    OutOfBounds {
        /// Column.
        x: u32,
        /// Row.
        y: u32,
        /// Film width.
        width: u32,
        /// Film height.
        height: u32,
    },
    /// The filter's tabulated distribution could not be built.
    #[error("filter table: {0}")]
    Table(#[from] spectral::SpectrumError),
}

/// Errors from writing and reading images.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    /// The file name's extension names no format this crate writes or reads.
    #[error("{path}: unsupported image extension '{extension}' (supported: {supported})")]
    UnsupportedExtension {
        /// The file.
        path: PathBuf,
        /// The extension as given (empty if none).
        extension: String,
        /// The supported extensions, comma-separated.
        supported: &'static str,
    },
    /// An operating-system error while creating, writing, syncing, renaming or reading a file.
    #[error("{path}: {source}")]
    Io {
        /// The file concerned.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The OpenEXR encoder or decoder failed.
    #[error("{path}: OpenEXR: {message}")]
    Exr {
        /// The file concerned.
        path: PathBuf,
        /// What the `exr` crate said.
        message: String,
    },
    /// The PNG encoder or decoder failed.
    #[error("{path}: PNG: {message}")]
    Png {
        /// The file concerned.
        path: PathBuf,
        /// What the `png` crate said.
        message: String,
    },
    /// The file is not a well-formed image of the expected kind (bad PFM header, missing channels, wrong sizes).
    #[error("{path}: {message}")]
    Malformed {
        /// The file concerned.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The image to write is inconsistent (pixel count differs from width × height, zero size).
    #[error("invalid image: {0}")]
    InvalidImage(String),
}

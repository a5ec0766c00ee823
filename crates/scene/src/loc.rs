//! Source locations, warnings and the error type of scene descriptions.

use std::fmt;
use std::path::Path;
use std::sync::Arc;

use crate::params::ParamType;

/// A place in a scene file: the file, and the 1-based line and column (in characters) where something was written.
///
/// Line 0 marks something no file wrote (a built-in default).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Loc {
    /// The file, as it was opened (relative or absolute).
    pub file: Arc<Path>,
    /// The line, from 1 (0 for built-in defaults).
    pub line: u32,
    /// The column, from 1, counted in characters.
    pub column: u32,
}

impl Loc {
    /// A location in `file` at `line`, `column`.
    pub fn new(file: Arc<Path>, line: u32, column: u32) -> Self {
        Self { file, line, column }
    }

    /// The location of a built-in default that belongs to `file` but was not written in it (line and column 0).
    pub fn builtin(file: Arc<Path>) -> Self {
        Self { file, line: 0, column: 0 }
    }

    /// True for the location of a built-in default.
    pub fn is_builtin(&self) -> bool {
        self.line == 0
    }
}

impl fmt::Display for Loc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // Line 0: a built-in default, or a file without lines (glTF, whose messages give the JSON path instead).
        if self.line == 0 {
            return write!(f, "{}", self.file.display());
        }
        write!(f, "{}:{}:{}", self.file.display(), self.line, self.column)
    }
}

/// A warning about a scene file, at a location: something accepted but ignored, deprecated or never used.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Diagnostic {
    /// Where.
    pub loc: Loc,
    /// What, in words.
    pub message: String,
}

impl Diagnostic {
    /// A warning at `loc`.
    pub fn new(loc: Loc, message: impl Into<String>) -> Self {
        Self { loc, message: message.into() }
    }
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: warning: {}", self.loc, self.message)
    }
}

/// An error found in a scene description, always with the location of what caused it.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SceneError {
    /// A parameter has the wrong type or number of values, a value out of range, or cannot be turned into what
    /// was asked of it.
    #[error("{loc}: error: parameter '{ty} {name}': {message}")]
    Param {
        /// Where the parameter was written.
        loc: Loc,
        /// Its type as written (after pbrt-v3 synonyms were mapped).
        ty: ParamType,
        /// Its name.
        name: String,
        /// What is wrong with it.
        message: String,
    },
    /// Anything else wrong with an entity (an unknown type name, a missing required parameter, …).
    #[error("{loc}: error: {message}")]
    Invalid {
        /// Where the entity was written.
        loc: Loc,
        /// What is wrong.
        message: String,
    },
}

impl SceneError {
    /// An error at `loc` with `message`, for problems that are not about one parameter.
    pub fn at(loc: Loc, message: impl Into<String>) -> Self {
        SceneError::Invalid { loc, message: message.into() }
    }

    /// Where the error is.
    pub fn loc(&self) -> &Loc {
        match self {
            SceneError::Param { loc, .. } | SceneError::Invalid { loc, .. } => loc,
        }
    }

    /// The message without the location and the "error:" prefix.
    pub fn message(&self) -> String {
        match self {
            SceneError::Param { ty, name, message, .. } => format!("parameter '{ty} {name}': {message}"),
            SceneError::Invalid { message, .. } => message.clone(),
        }
    }
}

//! The parse error type.

use std::fmt::Write;

use scene::{Loc, SceneError};

/// A scene file that cannot be read: where, why, and (for errors inside included files) the chain of `Include`
/// and `Import` directives that led there, innermost first.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{loc}: error: {message}{}", chain(.included_from))]
pub struct ParseError {
    /// Where the error is.
    pub loc: Loc,
    /// What is wrong.
    pub message: String,
    /// The `Include`/`Import` directives that led to the file holding the error, innermost first.
    pub included_from: Vec<Loc>,
}

impl ParseError {
    /// An error at `loc`.
    pub fn new(loc: Loc, message: impl Into<String>) -> Self {
        Self { loc, message: message.into(), included_from: Vec::new() }
    }
}

/// One "included from here" note per line.
fn chain(locs: &[Loc]) -> String {
    locs.iter().fold(String::new(), |mut s, l| {
        let _ = write!(s, "\n{l}: note: included from here");
        s
    })
}

impl From<SceneError> for ParseError {
    fn from(e: SceneError) -> Self {
        ParseError::new(e.loc().clone(), e.message())
    }
}

//! The crate's error type.

/// Errors from building index-of-refraction models and from catalogue look-ups.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum OpticsError {
    /// A parameter that must be finite was NaN or infinite.
    #[error("{name} must be finite, got {value}")]
    NotFinite {
        /// The parameter's name.
        name: String,
        /// The offending value.
        value: f64,
    },
    /// A parameter lies outside the range the model allows.
    #[error("{name} = {value} is out of range: {expected}")]
    OutOfRange {
        /// The parameter's name.
        name: String,
        /// The offending value.
        value: f64,
        /// What the parameter allows, in words.
        expected: String,
    },
    /// A tabulated index was malformed (too short, lengths differ, wavelengths not increasing).
    #[error("invalid table: {0}")]
    BadTable(String),
    /// No catalogue material or named spectrum has that name.
    #[error("unknown material or spectrum '{name}'{}", did_you_mean(.suggestions))]
    UnknownName {
        /// The name as given.
        name: String,
        /// Catalogue names close to it (may be empty).
        suggestions: Vec<String>,
    },
    /// The name is known (pbrt-v4 defines it) but this crate has no data for it.
    #[error("no data for '{name}': {reason}")]
    NoData {
        /// The name as given.
        name: String,
        /// Why, in words.
        reason: String,
    },
    /// A spectrum could not be built.
    #[error(transparent)]
    Spectrum(#[from] spectral::SpectrumError),
}

fn did_you_mean(s: &[String]) -> String {
    if s.is_empty() {
        String::new()
    } else {
        format!("; did you mean {}?", s.iter().map(|n| format!("'{n}'")).collect::<Vec<_>>().join(", "))
    }
}

/// Checks that `value` is finite, naming the parameter otherwise.
pub(crate) fn finite(name: &str, value: f64) -> Result<f64, OpticsError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(OpticsError::NotFinite { name: name.to_owned(), value })
    }
}

/// Checks that `value` is finite and that `ok(value)` holds, naming the parameter and the rule otherwise.
pub(crate) fn check(name: &str, value: f64, ok: bool, expected: &str) -> Result<f64, OpticsError> {
    finite(name, value)?;
    if ok {
        Ok(value)
    } else {
        Err(OpticsError::OutOfRange { name: name.to_owned(), value, expected: expected.to_owned() })
    }
}

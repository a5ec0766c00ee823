//! Parameter declarations and values: `"type name" value` or `"type name" [ values ]`, and spectrum files.

use std::path::Path;

use scene::{Loc, ParamType};

use crate::error::ParseError;
use crate::lexer::{Lexer, TokKind, Token};

/// A parameter type from its declared name; the second value is the pbrt-v4 name if a pbrt-v3 synonym was used.
pub(crate) fn param_type(s: &str) -> Option<(ParamType, Option<&'static str>)> {
    Some(match s {
        "float" => (ParamType::Float, None),
        "integer" => (ParamType::Integer, None),
        "bool" => (ParamType::Bool, None),
        "string" => (ParamType::String, None),
        "point2" => (ParamType::Point2, None),
        "vector2" => (ParamType::Vector2, None),
        "point3" => (ParamType::Point3, None),
        "vector3" => (ParamType::Vector3, None),
        "normal" | "normal3" => (ParamType::Normal3, None),
        "rgb" => (ParamType::Rgb, None),
        "spectrum" => (ParamType::Spectrum, None),
        "blackbody" => (ParamType::Blackbody, None),
        "texture" => (ParamType::Texture, None),
        "point" => (ParamType::Point3, Some("point3")),
        "vector" => (ParamType::Vector3, Some("vector3")),
        "color" => (ParamType::Rgb, Some("rgb")),
        _ => return None,
    })
}

/// Parses a bare word as a finite number: digits, sign, '.', exponent. No `inf`, `nan` or hexadecimal.
pub(crate) fn parse_number(word: &str, loc: &Loc) -> Result<f64, ParseError> {
    let ok_chars = word.bytes().all(|b| b.is_ascii_digit() || matches!(b, b'+' | b'-' | b'.' | b'e' | b'E'));
    let has_digit = word.bytes().any(|b| b.is_ascii_digit());
    let bad = || ParseError::new(loc.clone(), format!("expected a number, found '{word}'"));
    if !ok_chars || !has_digit {
        return Err(bad());
    }
    let v: f64 = word.parse().map_err(|_| bad())?;
    if !v.is_finite() {
        return Err(ParseError::new(loc.clone(), format!("number '{word}' is out of range (not finite)")));
    }
    Ok(v)
}

/// Parses a bare word as an integer; a real number with an integral value (`2.0`) is accepted, as pbrt-v4 does.
pub(crate) fn parse_integer(word: &str, loc: &Loc) -> Result<i64, ParseError> {
    if let Ok(i) = word.parse::<i64>() {
        return Ok(i);
    }
    let v = parse_number(word, loc)?;
    if v.fract() == 0.0 && v.abs() < 9.0e15 {
        Ok(v as i64)
    } else {
        Err(ParseError::new(loc.clone(), format!("expected an integer, found '{word}'")))
    }
}

/// Reads a spectrum file: whitespace- (or comma-) separated numbers, `#` comments, interleaved as
/// `λ₀ v₀ λ₁ v₁ …`. Returns the numbers; syntax errors point into the file.
pub(crate) fn read_spectrum_file(path: &Path, file: std::sync::Arc<Path>) -> Result<Vec<f64>, String> {
    let text =
        std::fs::read_to_string(path).map_err(|e| format!("cannot read spectrum file '{}': {e}", path.display()))?;
    let mut lexer = Lexer::new(text.replace(',', " "), file);
    let mut values = Vec::new();
    loop {
        match lexer.next_token() {
            Err(e) => return Err(e.to_string()),
            Ok(None) => break,
            Ok(Some(Token { kind: TokKind::Word(w), loc })) => {
                values.push(parse_number(&w, &loc).map_err(|e| e.to_string())?);
            }
            Ok(Some(t)) => return Err(format!("{}: expected a number, found {}", t.loc, t.describe())),
        }
    }
    Ok(values)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    #[test]
    fn numbers() {
        let loc = Loc::new(Arc::from(Path::new("a")), 1, 1);
        for (s, v) in [("1", 1.0), ("-2.5", -2.5), ("+.5", 0.5), ("5.", 5.0), ("1e3", 1000.0), ("-1.5E-2", -0.015)] {
            assert_eq!(parse_number(s, &loc).unwrap(), v, "{s}");
        }
        for s in ["inf", "nan", "1.2.3", "abc", "-", "1e", "0x10", "1e999"] {
            assert!(parse_number(s, &loc).is_err(), "{s}");
        }
        assert_eq!(parse_integer("-7", &loc).unwrap(), -7);
        assert_eq!(parse_integer("3.0", &loc).unwrap(), 3);
        assert!(parse_integer("3.5", &loc).is_err());
    }
}

//! A reader for pbrt-v4 scene files, producing Prismatic's plain [`scene::SceneDescription`].
//!
//! The tokenizer keeps the line and column of every token; every error is a [`ParseError`] that names
//! `file:line:column` (with the chain of `Include`s that led there), and everything accepted but ignored is a
//! warning in [`scene::SceneDescription::warnings`]. `Include` and `Import` are resolved relative to the
//! directory of the including file (falling back to the main file's directory, where pbrt-v4 looks), with cycle
//! detection. Spectra given by name or file are resolved while parsing, so a bad spectrum file is reported with
//! the location of the parameter that named it. See `docs/scene-format.md` for the supported subset.
//!
//! ```
//! use std::path::Path;
//!
//! let text = r#"
//!     LookAt 0 0 -5  0 0 0  0 1 0
//!     Camera "perspective" "float fov" 45
//!     WorldBegin
//!     AttributeBegin
//!       AreaLightSource "diffuse" "blackbody L" 6500
//!       Shape "sphere" "float radius" 1
//!     AttributeEnd
//! "#;
//! let scene = pbrt::parse_str(text, Path::new("example.pbrt")).unwrap();
//! assert_eq!(scene.camera.entity.params.get_float("fov", 90.0).unwrap(), 45.0);
//! assert_eq!(scene.shapes.len(), 1);
//! assert!(scene.shapes[0].area_light.is_some());
//!
//! let err = pbrt::parse_str("WorldBegin\nShape \"sphere\" \"float radius\" [ 1 ", Path::new("bad.pbrt")).unwrap_err();
//! assert_eq!(err.to_string(), "bad.pbrt:2:31: error: unterminated '[': the value list of \"float radius\" has no closing ']'");
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod error;
mod lexer;
mod params;
mod parser;

use std::path::Path;

pub use error::ParseError;
pub use scene::SceneDescription;

/// Parses the scene file at `path` and everything it includes.
pub fn parse_file(path: &Path) -> Result<SceneDescription, ParseError> {
    let text = parser::read_text(path, None)?;
    let mut scene = parser::Parser::new(path, text).run()?;
    scene.files.insert(0, path.to_path_buf());
    Ok(scene)
}

/// Parses the bytes of a scene file (plain UTF-8 text or gzip-compressed, as [`parse_file`] reads them) as if
/// they were the file `virtual_path`: locations name that path, and `Include`, `Import` and file names resolve
/// relative to its directory.
pub fn parse_bytes(bytes: &[u8], virtual_path: &Path) -> Result<SceneDescription, ParseError> {
    let text = parser::decode_text(bytes.to_vec(), virtual_path, None)?;
    parser::Parser::new(virtual_path, text).run()
}

/// The `Integrator` directive whose arguments are `args`: a name (`volpath`) or a quoted name with parameters
/// (`"volpath" "integer maxdepth" 20`), as the command line's `--integrator` and Python's `integrator=` take them;
/// errors locate themselves in `virtual_path`.
pub fn parse_integrator(args: &str, virtual_path: &Path) -> Result<scene::Entity, ParseError> {
    let args = if args.trim_start().starts_with('"') { args.to_string() } else { format!("\"{}\"", args.trim()) };
    Ok(parse_str(&format!("Integrator {args}\nWorldBegin\n"), virtual_path)?.integrator)
}

/// Parses scene text as if it were the file `virtual_path`: locations name that path, and `Include`, `Import`
/// and file names resolve relative to its directory.
pub fn parse_str(text: &str, virtual_path: &Path) -> Result<SceneDescription, ParseError> {
    parser::Parser::new(virtual_path, text.to_owned()).run()
}

//! What several of the command's integration tests share.

// Each test file is a crate of its own that includes this module and uses only a part of it.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use film::Film;
use render::{build_scene, BuildOptions, BuiltScene};

/// Parses `text` as the pbrt-v4 file `path` (the name its errors give, and the folder that relative file names in
/// it start from) and builds the render scene with `options`; the first error of either step, as its message.
pub fn try_build_with(text: &str, path: impl AsRef<Path>, options: &BuildOptions) -> Result<BuiltScene, String> {
    let desc = pbrt::parse_str(text, path.as_ref()).map_err(|e| e.to_string())?;
    build_scene(&desc, options).map_err(|e| e.to_string())
}

/// [`try_build_with`] with the default options.
pub fn try_build(text: &str, path: impl AsRef<Path>) -> Result<BuiltScene, String> {
    try_build_with(text, path, &BuildOptions::default())
}

/// [`try_build`] of a scene that must build, and without warnings (so that a misspelt parameter cannot silently
/// change what a test renders); panics with the error or the warnings otherwise.
pub fn build(text: &str, path: impl AsRef<Path>) -> BuiltScene {
    let path = path.as_ref();
    let built = try_build(text, path).unwrap_or_else(|e| panic!("{e}"));
    assert!(built.warnings.is_empty(), "{}: {:#?}", path.display(), built.warnings);
    built
}

/// The error that parsing or building `text` as the file `path` gives (the parser checks some things, such as
/// texture names, the builder the rest); panics if the scene builds.
pub fn build_error(text: &str, path: impl AsRef<Path>) -> String {
    let path = path.as_ref();
    try_build(text, path).err().unwrap_or_else(|| panic!("{}: expected an error", path.display()))
}

/// Mean XYZ over all pixels of two renders with different seeds, and the standard error of each component
/// (pixels are independent with a box filter: SE = √Σ(aₚ − bₚ)² / 2n).
pub fn image_xyz(a: &Film, b: &Film) -> ([f64; 3], [f64; 3]) {
    let (w, h) = (a.width(), a.height());
    let n = (w * h) as f64;
    let (mut m, mut d2) = ([0.0; 3], [0.0; 3]);
    for y in 0..h {
        for x in 0..w {
            let (va, vb) = (a.pixel_xyz(x, y).to_array(), b.pixel_xyz(x, y).to_array());
            for c in 0..3 {
                m[c] += 0.5 * (va[c] + vb[c]) / n;
                d2[c] += (va[c] - vb[c]).powi(2);
            }
        }
    }
    (m, d2.map(|d| d.sqrt() / (2.0 * n)))
}

/// A fresh, empty temporary directory for one test: `prismatic-<group>-<process>-<name>`.
pub fn temp_dir(group: &str, name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("prismatic-{group}-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs `prismatic <args>` in `dir`.
pub fn prismatic(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_prismatic")).args(args).current_dir(dir).output().unwrap()
}

/// The output of a run that succeeded (else the test fails with its stderr).
#[track_caller]
pub fn ok(out: Output) -> Output {
    assert!(out.status.success(), "failed: {}", String::from_utf8_lossy(&out.stderr));
    out
}

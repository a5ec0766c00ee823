//! What the glTF reader's test files share: a directory per test, writing a document, rendering a description.

use std::path::{Path, PathBuf};

use serde_json::Value;

/// A directory of its own for a test's files.
pub fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("gltf-import-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Writes `doc` as `name` in `dir`.
pub fn write(dir: &Path, name: &str, doc: &Value) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, serde_json::to_vec_pretty(doc).unwrap()).unwrap();
    path
}

/// Renders `desc` at its film's size, `spp` samples, seed 1; the film.
pub fn render(desc: &scene::SceneDescription, spp: u32, resolution: (u32, u32)) -> film::Film {
    let options = render::BuildOptions { spp: Some(spp), resolution: Some(resolution), ..Default::default() };
    let built = render::build_scene(desc, &options).unwrap_or_else(|e| panic!("{e}"));
    let mut film = film::Film::new(built.film.clone()).unwrap();
    built.integrator.render(&built.scene, &mut film, 0..built.spp, 1, &|_| {}).unwrap();
    film
}

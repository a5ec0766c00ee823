//! The repository's own scenes (the gallery in `scenes/`, the benchmarks in `scenes/bench/`) parse and build
//! without a warning, so that a change to a directive or parameter cannot leave a README command broken.

mod support;

use std::path::Path;

#[test]
fn every_scene_in_the_repository_builds_without_warnings() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let mut built = 0;
    for dir in [root.clone(), root.join("bench")] {
        let mut files: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "pbrt"))
            // A scene's world kept apart for `Include` is not a scene of its own.
            .filter(|p| !p.file_stem().unwrap().to_string_lossy().ends_with("-world"))
            .collect();
        files.sort();
        for path in files {
            let text = std::fs::read_to_string(&path).unwrap();
            let scene = support::try_build(&text, &path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            assert!(scene.warnings.is_empty(), "{}: {:#?}", path.display(), scene.warnings);
            built += 1;
        }
    }
    assert!(built >= 20, "only {built} scenes found");
}

//! Parses pbrt-v4 scene files and prints what they hold, the warnings, and how long parsing took.
//!
//! `cargo run --release -p pbrt --example parse -- scene.pbrt [more.pbrt …]`

use std::path::Path;
use std::process::ExitCode;
use std::time::Instant;

fn main() -> ExitCode {
    let mut status = ExitCode::SUCCESS;
    for arg in std::env::args().skip(1) {
        let start = Instant::now();
        match pbrt::parse_file(Path::new(&arg)) {
            Ok(s) => {
                println!(
                    "{arg}: {:.3} s: camera {}, film {}, sampler {}, integrator {}, {} shapes, {} lights, {} materials, \
                     {} named materials, {} textures, {} media, {} objects, {} instances",
                    start.elapsed().as_secs_f64(),
                    s.camera.entity.name,
                    s.film.name,
                    s.sampler.name,
                    s.integrator.name,
                    s.shapes.len(),
                    s.lights.len(),
                    s.materials.len(),
                    s.named_materials.len(),
                    s.textures.len(),
                    s.media.len(),
                    s.objects.len(),
                    s.instances.len()
                );
                for w in &s.warnings {
                    println!("{w}");
                }
            }
            Err(e) => {
                eprintln!("{e}");
                status = ExitCode::FAILURE;
            }
        }
    }
    status
}

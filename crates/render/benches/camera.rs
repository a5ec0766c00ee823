//! Camera-ray generation throughput (`cargo bench -p render --bench camera`): a thin lens against pbrt-v4's
//! realistic camera through the f/2 double Gauss of `scenes/lenses/`, with constant indices (one ray per camera
//! sample, as pbrt-v4) and with its glasses' dispersion (one ray per wavelength, four per sample).

use std::hint::black_box;
use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use glam::Vec2;
use render::{build_scene, BuildOptions, BuiltScene};
use spectral::SampledWavelengths;

/// A 640 × 427 film behind `camera`, in front of an empty world.
fn scene(camera: &str) -> BuiltScene {
    let lenses = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/lenses");
    let text = format!(
        "LookAt 0 0 0  0 0 1  0 1 0\n{camera}\nFilm \"rgb\" \"integer xresolution\" 640 \"integer yresolution\" 427\n\
         WorldBegin\nLightSource \"infinite\"\n"
    );
    let desc = pbrt::parse_str(&text, &lenses.join("bench.pbrt")).unwrap();
    build_scene(&desc, &BuildOptions::default()).unwrap()
}

fn camera_rays(c: &mut Criterion) {
    let cameras = [
        ("thin lens", r#"Camera "perspective" "float fov" 46 "float lensradius" 0.006 "float focaldistance" 2"#),
        (
            "double Gauss, constant indices",
            r#"Camera "realistic" "string lensfile" "dgauss-50mm-pbrt.dat" "float aperturediameter" 12.5 "float focusdistance" 2"#,
        ),
        (
            "double Gauss, six glasses",
            r#"Camera "realistic" "string lensfile" "dgauss-50mm.dat" "float aperturediameter" 12.5 "float focusdistance" 2"#,
        ),
    ];
    let wl = SampledWavelengths::new([450.0, 520.0, 590.0, 660.0], [1.0; 4]);
    let mut group = c.benchmark_group("camera rays");
    group.throughput(Throughput::Elements(1024));
    for (name, camera) in cameras {
        let built = scene(camera);
        let cam = built.scene.camera();
        // A fixed, well-spread set of film and lens samples (R2 sequence).
        let samples: Vec<(Vec2, Vec2)> = (0..1024)
            .map(|i| {
                let f = i as f32;
                let u = Vec2::new((0.5 + f * 0.754_877_7).fract(), (0.5 + f * 0.569_840_3).fract());
                let v = Vec2::new((0.3 + f * 0.569_840_3).fract(), (0.7 + f * 0.754_877_7).fract());
                (Vec2::new(u.x * 640.0, u.y * 427.0), v)
            })
            .collect();
        group.bench_function(name, |b| {
            b.iter(|| {
                for &(film, lens) in &samples {
                    black_box(cam.generate_rays(black_box(film), lens, 0.0, &wl));
                }
            })
        });
    }
    group.finish();
}

criterion_group!(benches, camera_rays);
criterion_main!(benches);

//! BSDF sampling and evaluation throughput (`cargo bench -p render --bench bsdf`).

#[path = "../src/tests/support/rgl.rs"]
mod rgl;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use glam::{Vec2, Vec3};
use optics::{Complex, FilmLayer};
use render::internals::{Bxdf, CoatingAt, Layered, MeasuredBrdf, TensorFile, TransportMode, TrowbridgeReitz, Warp2D};
use spectral::SampledSpectrum;
use std::hint::black_box;
use std::sync::Arc;

fn bxdfs() -> Vec<(&'static str, Bxdf)> {
    let rough = TrowbridgeReitz::new(0.3, 0.3);
    vec![
        ("diffuse", Bxdf::Diffuse { r: SampledSpectrum::splat(0.5) }),
        (
            "rough conductor",
            Bxdf::Conductor {
                eta: SampledSpectrum::splat(0.2),
                k: SampledSpectrum::splat(3.0),
                distrib: rough,
                coating: None,
            },
        ),
        (
            "rough conductor, 80 nm film",
            Bxdf::Conductor {
                eta: SampledSpectrum::splat(0.2),
                k: SampledSpectrum::splat(3.0),
                distrib: rough,
                coating: Some(Box::new(CoatingAt::uniform(
                    [450.0, 520.0, 590.0, 660.0],
                    &[FilmLayer::new(Complex::from_real(2.4), 80.0)],
                ))),
            },
        ),
        (
            "smooth dielectric",
            Bxdf::Dielectric { eta: 1.5, distrib: TrowbridgeReitz::new(0.0, 0.0), coating: None, tint: None },
        ),
        ("rough dielectric", Bxdf::Dielectric { eta: 1.5, distrib: rough, coating: None, tint: None }),
        (
            "coated diffuse",
            Bxdf::Layered(Box::new(Layered::coated_diffuse(SampledSpectrum::splat(0.5), 1.5, rough, 0.01, 10, 1))),
        ),
        (
            "coated diffuse, scattering layer",
            Bxdf::Layered(Box::new(
                Layered::coated_diffuse(SampledSpectrum::splat(0.5), 1.5, rough, 0.1, 10, 1)
                    .with_medium(SampledSpectrum::splat(0.8), 0.3),
            )),
        ),
        ("measured (GGX file)", measured()),
    ]
}

/// A measured BRDF: a GGX conductor tabulated at the test's resolution (24 incident elevations, 64 × 96 VNDF,
/// 48 × 48 sample space, 6 wavelengths).
fn measured() -> Bxdf {
    let model = rgl::Ggx {
        alpha: 0.3,
        wavelengths: vec![380.0, 450.0, 520.0, 600.0, 700.0, 830.0],
        facet: rgl::Facet::Conductor {
            eta: vec![1.5, 1.2, 0.9, 0.5, 0.3, 0.25],
            k: vec![2.0, 2.3, 2.6, 3.0, 3.8, 5.0],
        },
    };
    let t = TensorFile::parse(model.file(rgl::Resolution::FINE)).unwrap();
    let brdf = Arc::new(MeasuredBrdf::from_tensor(&t).unwrap());
    Bxdf::Measured { brdf, lambda: [420.0, 500.0, 580.0, 660.0] }
}

fn bench(c: &mut Criterion) {
    const N: u64 = 1024;
    let wo = Vec3::new(0.3, 0.2, 0.93).normalize();
    let mut g = c.benchmark_group("bsdf");
    g.throughput(Throughput::Elements(N));
    for (name, b) in bxdfs() {
        g.bench_function(format!("{name}/sample_f"), |bench| {
            bench.iter(|| {
                let mut acc = 0.0f32;
                for i in 0..N {
                    let u = (i as f32 + 0.5) / N as f32;
                    if let Some(s) = b.sample_f(wo, u, Vec2::new(u, 1.0 - u), TransportMode::Radiance) {
                        acc += s.f[0] / s.pdf;
                    }
                }
                black_box(acc)
            })
        });
        // The same N directions for the value and density apart and together.
        let over_pairs = |eval: &dyn Fn(Vec3) -> f32| {
            (0..N).map(|i| eval(Vec3::new((i as f32 + 0.5) / N as f32 - 0.5, 0.3, 0.8).normalize())).sum::<f32>()
        };
        g.bench_function(format!("{name}/f+pdf"), |bench| {
            bench.iter(|| {
                black_box(over_pairs(&|wi| {
                    b.f(wo, wi, TransportMode::Radiance)[0] + b.pdf(wo, wi, TransportMode::Radiance)
                }))
            })
        });
        g.bench_function(format!("{name}/f_pdf (joint)"), |bench| {
            bench.iter(|| {
                black_box(over_pairs(&|wi| {
                    let (f, pdf) = b.f_pdf(wo, wi, TransportMode::Radiance);
                    f[0] + pdf
                }))
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

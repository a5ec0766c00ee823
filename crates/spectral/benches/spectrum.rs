//! Spectrum operations on the hot path (`cargo bench -p spectral --bench spectrum`): wavelength sampling, spectrum
//! evaluation at four wavelengths, RGB uplifting lookups and conversion of a path's radiance to XYZ.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use spectral::rgb_uplift::RgbAlbedoSpectrum;
use spectral::{named, Observer, SampledSpectrum, Spectrum, WavelengthSampler, WavelengthStrategy};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    const N: u64 = 1024;
    let mut g = c.benchmark_group("spectrum");
    g.throughput(Throughput::Elements(N));
    for strategy in WavelengthStrategy::ALL {
        let ws = WavelengthSampler::new(strategy, Observer::Cie1931);
        g.bench_function(format!("sample+to_xyz/{strategy}"), |b| {
            b.iter(|| {
                let mut acc = 0.0;
                for i in 0..N {
                    let wl = ws.sample((i as f64 + 0.5) / N as f64);
                    acc += ws.to_xyz(&SampledSpectrum::splat(1.0), &wl).y;
                }
                black_box(acc)
            })
        });
    }
    let ws = WavelengthSampler::new(WavelengthStrategy::Hero, Observer::Cie1931);
    // As a renderer draws them: uniform numbers in random order (the ordered ones above make the cdf search's
    // branches predictable).
    let random_u: Vec<f64> =
        (0..N).map(|i| (i.wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 11) as f64 / (1u64 << 53) as f64).collect();
    g.bench_function("sample/hero, random order", |b| {
        b.iter(|| black_box(random_u.iter().map(|&u| ws.sample(u).lambda(0)).sum::<f32>()))
    });
    let wls: Vec<_> = (0..N).map(|i| ws.sample((i as f64 + 0.5) / N as f64)).collect();
    let spectra = [
        ("piecewise-linear D65", named::illuminant("stdillum-D65").unwrap()),
        ("blackbody", Spectrum::blackbody(3000.0).unwrap()),
        ("rgb albedo", Spectrum::RgbAlbedo(RgbAlbedoSpectrum::new([0.2, 0.5, 0.8]).unwrap())),
    ];
    for (name, s) in &spectra {
        g.bench_function(format!("sample/{name}"), |b| {
            b.iter(|| black_box(wls.iter().map(|wl| s.sample(wl)[0]).sum::<f32>()))
        });
    }
    g.bench_function("rgb uplift lookup", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for i in 0..N {
                let v = (i as f64 + 0.5) / N as f64;
                acc += RgbAlbedoSpectrum::new([v, 1.0 - v, 0.5]).unwrap().eval(550.0);
            }
            black_box(acc)
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

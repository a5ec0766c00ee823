//! MIP map lookups (`cargo bench -p render --bench texture`): bilinear, trilinear and EWA lookups of a 1024² colour
//! image kept as 8-bit samples with their decode table (as 8-bit files are read) and as linear floats, at random
//! points with footprints from a texel to a sixteenth of the image.

use std::hint::black_box;
use std::sync::Arc;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use glam::Vec2;
use render::internals::{MipMap, RgbImage, WrapMode};

const SIDE: usize = 1024;
const LOOKUPS: usize = 4096;

/// A linear-congruential stream in [0, 1) (the same points for every variant).
fn uniforms(n: usize) -> Vec<f32> {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    (0..n)
        .map(|_| {
            state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        })
        .collect()
}

fn lookups(c: &mut Criterion) {
    let u = uniforms(SIDE * SIDE * 3 + LOOKUPS * 4);
    let bytes: Vec<[u8; 3]> = (0..SIDE * SIDE).map(|i| std::array::from_fn(|c| (u[3 * i + c] * 256.0) as u8)).collect();
    let table = film::sample_table(spectral::color::srgb_decode);
    let eight = film::Texels::from_rgb8(bytes.clone(), table.clone());
    let floats = film::Texels::Rgb(bytes.iter().map(|p| p.map(|s| table[usize::from(s)])).collect());
    let points: Vec<(Vec2, Vec2, Vec2)> = (0..LOOKUPS)
        .map(|i| {
            let r = &u[SIDE * SIDE * 3 + 4 * i..][..4];
            // Footprints from one texel to a sixteenth of the image, in both axes.
            let width = (2.0f32).powf(-10.0 + 6.0 * r[2]);
            (Vec2::new(r[0], r[1]), Vec2::new(width, 0.3 * width), Vec2::new(-0.2 * width, width * (0.25 + r[3])))
        })
        .collect();
    let mut group = c.benchmark_group("mipmap lookups");
    group.throughput(Throughput::Elements(LOOKUPS as u64));
    for (name, texels) in [("8-bit", eight), ("f32", floats)] {
        let image = Arc::new(RgbImage { width: SIDE, height: SIDE, texels });
        let mip = MipMap::new(&image, WrapMode::Repeat);
        group.bench_function(format!("bilinear, {name}"), |b| {
            b.iter(|| points.iter().map(|&(st, d0, d1)| mip.bilinear(st, d0, d1)[1]).sum::<f32>())
        });
        group.bench_function(format!("trilinear, {name}"), |b| {
            b.iter(|| points.iter().map(|&(st, d0, d1)| mip.trilinear(st, d0, d1)[1]).sum::<f32>())
        });
        group.bench_function(format!("ewa, {name}"), |b| {
            b.iter(|| points.iter().map(|&(st, d0, d1)| mip.ewa(st, d0, d1, 8.0)[1]).sum::<f32>())
        });
        // Level 0 alone: where the 8-bit samples are read (the other levels are floats either way).
        group.bench_function(format!("level 0 bilinear, {name}"), |b| {
            b.iter(|| points.iter().map(|&(st, _, _)| image.bilerp(black_box(st))[1]).sum::<f32>())
        });
    }
    group.finish();
}

criterion_group!(benches, lookups);
criterion_main!(benches);

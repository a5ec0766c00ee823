//! BVH build and traversal on a ~200k-triangle bumpy sphere with incoherent random rays.
//!
//! `cargo bench -p geometry --bench bvh`; throughput is reported in rays per second (build: triangles per second).

use std::f32::consts::PI;
use std::hint::black_box;
use std::sync::Arc;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use geometry::accel::{Accel, GeometryScene};
use geometry::mesh::{MeshData, TriangleMesh};
use geometry::shapes::Shape;
use geometry::{Ray, Transform, Vec3};

mod support;
use support::hash01;

/// A lat-long sphere of `2·n·n` triangles with radial bumps.
fn bumpy_sphere(n: usize) -> MeshData {
    let (n_theta, n_phi) = (n, n);
    let mut positions = Vec::new();
    for j in 0..=n_theta {
        let theta = PI * j as f32 / n_theta as f32;
        for i in 0..n_phi {
            let phi = 2.0 * PI * i as f32 / n_phi as f32;
            let r = 1.0 + 0.05 * (7.0 * theta).sin() * (5.0 * phi).cos();
            positions.push(r * Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()));
        }
    }
    let v = |i: usize, j: usize| (j * n_phi + i % n_phi) as u32;
    let mut indices = Vec::new();
    for j in 0..n_theta {
        for i in 0..n_phi {
            indices.extend([v(i, j), v(i + 1, j + 1), v(i + 1, j), v(i, j), v(i, j + 1), v(i + 1, j + 1)]);
        }
    }
    MeshData { positions, indices, ..Default::default() }
}

fn rays(count: usize) -> Vec<Ray> {
    (0..count as u64)
        .map(|k| {
            let o = Vec3::new(hash01(6 * k), hash01(6 * k + 1), hash01(6 * k + 2)) * 4.0 - Vec3::splat(2.0);
            let t = Vec3::new(hash01(6 * k + 3), hash01(6 * k + 4), hash01(6 * k + 5)) * 2.0 - Vec3::ONE;
            Ray::new(o, (t - o).normalize_or(Vec3::Z))
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let data = bumpy_sphere(320);
    let tris = data.triangle_count();
    let mesh = Arc::new(TriangleMesh::new(&Transform::IDENTITY, data, false).unwrap());
    let mut g = c.benchmark_group(format!("bvh_{}k_tris", tris / 1000));
    g.sample_size(10);
    g.throughput(Throughput::Elements(tris as u64));
    g.bench_function("build", |b| {
        b.iter(|| GeometryScene::from_shapes(vec![Shape::Mesh(mesh.clone())]).unwrap());
    });
    let scene = GeometryScene::from_shapes(vec![Shape::Mesh(mesh.clone())]).unwrap();
    eprintln!("build time for {tris} triangles: {:?}", scene.build_time());
    let rays = rays(100_000);
    g.throughput(Throughput::Elements(rays.len() as u64));
    g.bench_function("closest_hit_incoherent", |b| {
        b.iter(|| rays.iter().filter(|r| scene.intersect(black_box(r), f32::INFINITY).is_some()).count());
    });
    g.bench_function("occluded_incoherent", |b| {
        b.iter(|| rays.iter().filter(|r| scene.occluded(black_box(r), f32::INFINITY)).count());
    });
    {
        // Baseline: obvhs's own traversal and triangle test on the same triangles.
        use obvhs::ray::RayHit;
        let otris: Vec<obvhs::triangle::Triangle> = (0..mesh.triangle_count())
            .map(|t| {
                let [a, b, c] = mesh.triangle_positions(t);
                obvhs::triangle::Triangle { v0: a.into(), v1: b.into(), v2: c.into() }
            })
            .collect();
        let bvh = obvhs::cwbvh::builder::build_cwbvh_from_tris(
            &otris,
            obvhs::BvhBuildParams::medium_build(),
            &mut std::time::Duration::default(),
        );
        g.bench_function("obvhs_baseline_closest", |b| {
            b.iter(|| {
                rays.iter()
                    .filter(|r| {
                        let ray = obvhs::ray::Ray::new_inf(r.o.into(), r.d.into());
                        let mut hit = RayHit::none();
                        bvh.ray_traverse(ray, &mut hit, |ray, id| {
                            otris[bvh.primitive_indices[id] as usize].intersect(ray)
                        })
                    })
                    .count()
            });
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

//! Exact bilinear patches: intersection against an independent closed form, watertightness across a shared edge,
//! BVH against brute force, area sampling, and spawn offsets.

use std::f32::consts::PI;
use std::sync::Arc;

use geometry::accel::{Accel, GeometryScene, Instance, Object};
use geometry::shapes::Shape;
use geometry::{BilinearMesh, BilinearMeshData, DVec3, Ray, Transform, Vec2, Vec3};
use rand_core::{RngCore, SeedableRng};
use rand_pcg::Pcg32;

fn uniform(rng: &mut Pcg32) -> f32 {
    (rng.next_u32() >> 8) as f32 / (1u32 << 24) as f32
}

fn vec3(rng: &mut Pcg32, lo: f32, hi: f32) -> Vec3 {
    Vec3::new(uniform(rng), uniform(rng), uniform(rng)) * (hi - lo) + Vec3::splat(lo)
}

fn unit_vector(rng: &mut Pcg32) -> Vec3 {
    let z = 1.0 - 2.0 * uniform(rng);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * uniform(rng);
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

fn patches(positions: Vec<Vec3>, indices: Vec<u32>, t: &Transform, reverse: bool) -> Arc<BilinearMesh> {
    Arc::new(BilinearMesh::new(t, BilinearMeshData { positions, indices, ..Default::default() }, reverse).unwrap())
}

/// The patch with corners (0,0,0), (1,0,0), (0,1,0), (1,1,1): p(u, v) = (u, v, uv), the saddle z = x·y.
fn saddle(t: &Transform, reverse: bool) -> Arc<BilinearMesh> {
    patches(vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE], vec![0, 1, 2, 3], t, reverse)
}

/// Independent reference for the saddle z = x·y, x, y ∈ [0, 1]: along o + t·d the condition is the quadratic
/// −dx·dy·t² + (dz − ox·dy − oy·dx)·t + (oz − ox·oy) = 0, solved in f64; the nearest root with t > 0 inside the
/// square. Returns (t, x, y).
fn saddle_reference(o: DVec3, d: DVec3) -> Option<(f64, f64, f64)> {
    let a = -d.x * d.y;
    let b = d.z - o.x * d.y - o.y * d.x;
    let c = o.z - o.x * o.y;
    let mut roots = vec![];
    if a.abs() < 1e-300 {
        if b != 0.0 {
            roots.push(-c / b);
        }
    } else {
        let disc = b * b - 4.0 * a * c;
        if disc < 0.0 {
            return None;
        }
        roots.push((-b - disc.sqrt()) / (2.0 * a));
        roots.push((-b + disc.sqrt()) / (2.0 * a));
    }
    // One Newton step on g(t) = z − x·y polishes the textbook formula's cancellation.
    let g = |t: f64| (o.z + t * d.z) - (o.x + t * d.x) * (o.y + t * d.y);
    let dg = |t: f64| d.z - d.x * (o.y + t * d.y) - d.y * (o.x + t * d.x);
    roots
        .into_iter()
        .map(|t| if dg(t) != 0.0 { t - g(t) / dg(t) } else { t })
        .filter(|&t| t > 0.0)
        .map(|t| (t, o.x + t * d.x, o.y + t * d.y))
        .filter(|&(_, x, y)| (0.0..=1.0).contains(&x) && (0.0..=1.0).contains(&y))
        .min_by(|p, q| p.0.total_cmp(&q.0))
}

#[test]
fn saddle_hits_match_the_closed_form() {
    let mut rng = Pcg32::seed_from_u64(11);
    for reverse in [false, true] {
        let scene = GeometryScene::from_shapes(vec![Shape::Bilinear(saddle(&Transform::IDENTITY, reverse))]).unwrap();
        let (mut hits, mut checked) = (0, 0);
        for i in 0..20_000 {
            let o = vec3(&mut rng, -2.0, 3.0);
            // Aim at the surface z = xy over a slightly larger square, so some rays miss past the edges.
            let (x, y) = (uniform(&mut rng) * 1.4 - 0.2, uniform(&mut rng) * 1.4 - 0.2);
            let d = Vec3::new(x, y, x * y) - o;
            let reference = saddle_reference(o.as_dvec3(), d.as_dvec3());
            let hit = scene.intersect(&Ray::new(o, d), f32::INFINITY);
            // Skip rays whose reference hit is within 1e-5 of the boundary, where the f32 rounding of o and d can
            // legitimately move the hit across the edge.
            if let Some((_, x, y)) = reference {
                if x.min(y) < 1e-5 || x.max(y) > 1.0 - 1e-5 {
                    continue;
                }
            }
            checked += 1;
            match (hit, reference) {
                (None, None) => {}
                (Some(h), Some((t, x, y))) => {
                    hits += 1;
                    // t is in units of |d| (|d| ≤ ~6): 1e-5 relative is ~100 f32 ulps, far below a wrong root.
                    assert!((h.t as f64 - t).abs() < 1e-5 * t.max(1.0), "ray {i}: t {} vs {t}", h.t);
                    assert!(
                        (h.uv.x as f64 - x).abs() < 1e-5 && (h.uv.y as f64 - y).abs() < 1e-5,
                        "ray {i}: {:?}",
                        h.uv
                    );
                    assert!((h.p.as_dvec3() - DVec3::new(x, y, x * y)).length() < 1e-5, "ray {i}: {}", h.p);
                    // n = normalize(∂p/∂u × ∂p/∂v) = normalize(−v, −u, 1), negated under ReverseOrientation.
                    let n = Vec3::new(-(y as f32), -(x as f32), 1.0).normalize();
                    let n = if reverse { -n } else { n };
                    assert!((h.n - n).length() < 1e-5 && h.ns == h.n, "ray {i}: {} vs {n}", h.n);
                }
                (h, r) => panic!("ray {i}: hit {h:?} vs reference {r:?}"),
            }
        }
        assert!(hits > 10_000 && checked > 19_000, "{hits} of {checked}");
    }
}

#[test]
fn planar_patch_and_transform() {
    // A unit square patch scaled by 2 and moved to z = 3 (the quad pbrt scenes use for floors and lights).
    let t = Transform::translate(DVec3::new(0.0, 0.0, 3.0)) * Transform::scale(DVec3::splat(2.0)).unwrap();
    let m = patches(vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)], vec![0, 1, 2, 3], &t, false);
    assert!((m.patch_area(0) - 4.0).abs() < 1e-6);
    let (th, uv) = m.intersect(0, Vec3::new(0.5, 1.5, 10.0), Vec3::new(0.0, 0.0, -2.0), f32::INFINITY).unwrap();
    assert!((th - 3.5).abs() < 1e-6 && (uv - Vec2::new(0.25, 0.75)).length() < 1e-6, "{th} {uv}");
    assert!(m.intersect(0, Vec3::new(0.5, 1.5, 10.0), Vec3::new(0.0, 0.0, -2.0), 3.4).is_none());
    assert!(m.intersect(0, Vec3::new(2.1, 1.0, 10.0), -Vec3::Z, f32::INFINITY).is_none());
    // A ray lying in the plane of the patch misses.
    assert!(m.intersect(0, Vec3::new(-1.0, 1.0, 3.0), Vec3::X, f32::INFINITY).is_none());
    // A mirror transform swaps handedness: the cross product ∂p/∂u × ∂p/∂v reverses and the handedness flip undoes
    // it, so the normal is the mirrored +z, i.e. +z (as for triangles).
    let mirror = Transform::scale(DVec3::new(-1.0, 1.0, 1.0)).unwrap();
    let m = patches(vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)], vec![0, 1, 2, 3], &mirror, false);
    assert!(m.flip_normal());
    let scene = GeometryScene::from_shapes(vec![Shape::Bilinear(m)]).unwrap();
    let h = scene.intersect(&Ray::new(Vec3::new(-0.5, 0.5, 1.0), -Vec3::Z), f32::INFINITY).unwrap();
    assert!((h.n - Vec3::Z).length() < 1e-6, "{}", h.n);
}

#[test]
fn shared_edges_are_watertight() {
    // Pairs of non-planar patches (the saddle and a twisted neighbour) sharing the edge from (1,0,0) to (1,1,1)
    // (u = 1 of the first, u = 0 of the second) or from (0,1,0) to (1,1,1) (v = 1 of the first, v = 0 of the
    // second); `edge(s)` is the point of the shared edge at parameter s.
    type Edge = fn(f32) -> Vec3;
    let u_edge: (Vec<Vec3>, Vec<u32>, Edge) = (
        vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE, Vec3::new(2.0, 0.0, 0.3), Vec3::new(2.0, 1.0, -0.5)],
        vec![0, 1, 2, 3, 1, 4, 3, 5],
        |s| Vec3::new(1.0, s, s),
    );
    let v_edge: (Vec<Vec3>, Vec<u32>, Edge) = (
        vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE, Vec3::new(0.0, 2.0, 0.4), Vec3::new(1.0, 2.0, -0.3)],
        vec![0, 1, 2, 3, 2, 3, 4, 5],
        |s| Vec3::new(s, 1.0, s),
    );
    let mut rng = Pcg32::seed_from_u64(5);
    // The patches meet at a crease, so a ray passing a rounding error beside the edge on the convex side may
    // rightly miss both: every coordinate here is a multiple of 2⁻¹⁰ of modest size, so `o`, `d = target − o` and
    // `o + d = target` are exact in f32 and each ray passes exactly through its point of the edge.
    let grid = |rng: &mut Pcg32, lo: i32, hi: i32| (lo + (rng.next_u32() % (hi - lo) as u32) as i32) as f32 / 1024.0;
    for (positions, indices, edge) in [u_edge, v_edge] {
        let m = patches(positions, indices, &Transform::IDENTITY, false);
        let scene = GeometryScene::from_shapes(vec![Shape::Bilinear(m)]).unwrap();
        for i in 0..20_000 {
            let target = edge(grid(&mut rng, 10, 1014));
            let o = target
                + Vec3::new(grid(&mut rng, -4096, 4096), grid(&mut rng, -4096, 4096), grid(&mut rng, -4096, 4096));
            let d = target - o;
            if d.length() < 0.1 {
                continue;
            }
            assert_eq!(o + d, target);
            // The ray reaches the edge at t = 1; nothing may let it through.
            let h = scene.intersect(&Ray::new(o, d), f32::INFINITY);
            let h = h.unwrap_or_else(|| panic!("ray {i} through the shared edge at {target} hits neither patch"));
            assert!(h.t <= 1.0 + 1e-4, "ray {i}: t = {}", h.t);
            assert!(scene.occluded(&Ray::new(o, d), 1.0 + 1e-4), "ray {i}");
        }
    }
}

/// A 12×12 heightfield of non-planar patches with shared vertices, plus scattered single twisted patches.
fn patch_field(rng: &mut Pcg32) -> Vec<Shape> {
    let n = 12;
    let mut positions = vec![];
    for j in 0..=n {
        for i in 0..=n {
            positions.push(Vec3::new(i as f32, j as f32, 2.0 * uniform(rng) - 1.0));
        }
    }
    let mut indices = vec![];
    let at = |i: u32, j: u32| j * (n + 1) + i;
    for j in 0..n {
        for i in 0..n {
            indices.extend([at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1)]);
        }
    }
    let field = patches(positions, indices, &Transform::translate(DVec3::new(-6.0, -6.0, 0.0)), false);
    let mut positions = vec![];
    for _ in 0..200 {
        let c = vec3(rng, -8.0, 8.0);
        for _ in 0..4 {
            positions.push(c + vec3(rng, -1.0, 1.0));
        }
    }
    let scattered = patches(positions, (0..800).collect(), &Transform::IDENTITY, true);
    vec![Shape::Bilinear(field), Shape::Bilinear(scattered)]
}

#[test]
fn bvh_matches_brute_force_over_patches() {
    let mut rng = Pcg32::seed_from_u64(3);
    let objects = vec![Object::new(patch_field(&mut rng))];
    let instances = vec![
        Instance { object: 0, render_from_instance: Transform::IDENTITY },
        Instance {
            object: 0,
            render_from_instance: Transform::translate(DVec3::new(25.0, 0.0, 0.0))
                * Transform::rotate(40.0, DVec3::new(1.0, 1.0, 0.0)).unwrap(),
        },
    ];
    let scene = GeometryScene::build(objects, instances).unwrap();
    let mut hits = 0;
    for i in 0..5000 {
        let o = vec3(&mut rng, -12.0, 35.0);
        let target = vec3(&mut rng, -8.0, 30.0);
        let ray = Ray::new(o, (target - o).normalize());
        let t_max = if i % 4 == 0 { 15.0 } else { f32::INFINITY };
        let a = scene.intersect(&ray, t_max);
        let b = scene.intersect_brute_force(&ray, t_max);
        match (a, b) {
            (Some(a), Some(b)) => {
                assert_eq!((a.t, a.instance, a.shape, a.element), (b.t, b.instance, b.shape, b.element), "ray {i}");
                assert_eq!((a.p, a.n, a.uv), (b.p, b.n, b.uv), "ray {i}");
                hits += 1;
            }
            (None, None) => {}
            (a, b) => panic!("ray {i}: bvh {a:?} vs brute force {b:?}"),
        }
        assert_eq!(scene.occluded(&ray, t_max), b.is_some(), "ray {i}");
    }
    assert!(hits > 300, "{hits}");
}

/// Midpoint-rule integral over [0, 1]² of `f` on an `n`×`n` grid.
fn grid_integral(n: usize, f: impl Fn(f64, f64) -> f64) -> f64 {
    let h = 1.0 / n as f64;
    let mut sum = 0.0;
    for j in 0..n {
        for i in 0..n {
            sum += f((i as f64 + 0.5) * h, (j as f64 + 0.5) * h);
        }
    }
    sum * h * h
}

/// Stratified points in [0, 1)² (an `n`×`n` grid jittered by a Pcg32).
fn stratified(n: usize, rng: &mut Pcg32) -> Vec<Vec2> {
    let mut out = vec![];
    for j in 0..n {
        for i in 0..n {
            let (a, b) = (uniform(rng), uniform(rng));
            out.push(Vec2::new((i as f32 + a) / n as f32, (j as f32 + b) / n as f32));
        }
    }
    out
}

#[test]
fn saddle_area_sampling_is_normalised() {
    let m = saddle(&Transform::IDENTITY, false);
    // Area element of p(u, v) = (u, v, uv): |(1, 0, v) × (0, 1, u)| = √(1 + u² + v²).
    let jac = |u: f64, v: f64| (1.0 + u * u + v * v).sqrt();
    let area = grid_integral(2000, jac); // midpoint rule: error ~1e-7
    assert!((area - 1.280_789).abs() < 1e-5, "{area}");
    assert!((m.patch_area(0) as f64 - area).abs() < 1e-6 * area, "{} vs {area}", m.patch_area(0));
    // ∫ pdf dA = ∫∫ pdf(u, v)·|∂p/∂u × ∂p/∂v| du dv = 1 (grid quadrature of the density the sampler reports).
    let total = grid_integral(400, |u, v| m.pdf_area(0, Vec2::new(u as f32, v as f32)) as f64 * jac(u, v));
    assert!((total - 1.0).abs() < 1e-4, "{total}");
    // Monte Carlo over samples: E[1/pdf] = area, and E[p/pdf] / E[1/pdf] is the area centroid ∫ p dA / area.
    let mut rng = Pcg32::seed_from_u64(9);
    let samples = stratified(150, &mut rng);
    let n = samples.len() as f64;
    let (mut inv_pdf, mut mean) = (0.0f64, DVec3::ZERO);
    for &xi in &samples {
        let s = m.sample_area(0, xi).unwrap();
        // The sample is on the saddle, and its pdf is the one pdf_area reports there.
        assert!((s.p.z - s.p.x * s.p.y).abs() < 1e-6, "{}", s.p);
        let back = m.pdf_area(0, Vec2::new(s.p.x, s.p.y));
        assert!((back - s.pdf).abs() < 1e-4 * s.pdf, "{back} vs {}", s.pdf);
        inv_pdf += 1.0 / s.pdf as f64;
        mean += s.p.as_dvec3() / s.pdf as f64;
    }
    assert!((inv_pdf / n - area).abs() < 1e-3 * area, "{} vs {area}", inv_pdf / n);
    let centroid = DVec3::new(
        grid_integral(500, |u, v| u * jac(u, v)),
        grid_integral(500, |u, v| v * jac(u, v)),
        grid_integral(500, |u, v| u * v * jac(u, v)),
    ) / area;
    assert!((mean / inv_pdf - centroid).length() < 1e-3, "{} vs {centroid}", mean / inv_pdf);
}

#[test]
fn parallelogram_sampling_is_exactly_uniform() {
    // A tilted parallelogram: edges (2, 0, 1) and (0.5, 1, 0), area |(2,0,1) × (0.5,1,0)| = |(−1, 0.5, 2)| = √5.25.
    let (e1, e2) = (Vec3::new(2.0, 0.0, 1.0), Vec3::new(0.5, 1.0, 0.0));
    let o = Vec3::new(1.0, -2.0, 0.5);
    let m = patches(vec![o, o + e1, o + e2, o + e1 + e2], vec![0, 1, 2, 3], &Transform::IDENTITY, false);
    let area = 5.25f32.sqrt();
    assert!((m.patch_area(0) - area).abs() < 1e-5, "{}", m.patch_area(0));
    let mut rng = Pcg32::seed_from_u64(1);
    let mut mean = Vec3::ZERO;
    let samples = stratified(100, &mut rng);
    for &xi in &samples {
        let s = m.sample_area(0, xi).unwrap();
        assert!((s.pdf * area - 1.0).abs() < 1e-5, "{}", s.pdf * area);
        mean += s.p;
    }
    let centroid = o + 0.5 * (e1 + e2);
    assert!((mean / samples.len() as f32 - centroid).length() < 1e-3);
    // As a light seen from a point: E[1/pdf_ω] is the solid angle, here checked against the sum over the two
    // triangles of the parallelogram (the same area-to-solid-angle conversion, independently sampled).
    let shape = Shape::Bilinear(m);
    let p = Vec3::new(1.5, -1.0, 4.0);
    let omega: f64 =
        samples.iter().map(|&xi| 1.0 / shape.sample_solid_angle(0, p, xi).unwrap().pdf as f64).sum::<f64>()
            / samples.len() as f64;
    // Exact solid angle of a planar polygon (Van Oosterom & Strackee 1983), summed over two triangles.
    let tri = |a: Vec3, b: Vec3, c: Vec3| {
        let (a, b, c) = ((a - p).as_dvec3(), (b - p).as_dvec3(), (c - p).as_dvec3());
        let (la, lb, lc) = (a.length(), b.length(), c.length());
        let num = a.dot(b.cross(c)).abs();
        let den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
        2.0 * num.atan2(den)
    };
    let exact = tri(o, o + e1, o + e1 + e2) + tri(o, o + e1 + e2, o + e2);
    assert!((omega - exact).abs() < 2e-3 * exact, "{omega} vs {exact}");
}

#[test]
fn spawned_rays_do_not_rehit_the_patch() {
    let mut rng = Pcg32::seed_from_u64(21);
    // Also far from the origin, where the f32 error bounds are large.
    for offset in [DVec3::ZERO, DVec3::new(1000.0, -500.0, 250.0)] {
        let t = Transform::translate(offset) * Transform::scale(DVec3::splat(3.0)).unwrap();
        let scene = GeometryScene::from_shapes(vec![Shape::Bilinear(saddle(&t, false))]).unwrap();
        let center = t.point(DVec3::new(0.5, 0.5, 0.25)).as_vec3();
        let mut spawned = 0;
        for i in 0..5000 {
            let o = center + unit_vector(&mut rng) * 6.0;
            let target = t.point(DVec3::new(uniform(&mut rng) as f64, uniform(&mut rng) as f64, 0.0)).as_vec3();
            let Some(h) = scene.intersect(&Ray::new(o, target - o), f32::INFINITY) else { continue };
            for _ in 0..4 {
                let w = unit_vector(&mut rng);
                if w.dot(h.n).abs() < 0.05 {
                    continue;
                }
                spawned += 1;
                // Any hit of the spawned ray is a genuine second crossing of the saddle, far from its origin.
                if let Some(h2) = scene.intersect(&h.spawn_ray(w), f32::INFINITY) {
                    assert!(h2.t > 1e-2, "ray {i}: re-hit at t = {} (offset {offset})", h2.t);
                }
            }
        }
        assert!(spawned > 5000, "{spawned}");
    }
}

#[test]
fn spawned_rays_leave_a_large_flat_patch() {
    // A 100 × 100 floor in z = 0: its points have exactly z = 0, so their error bound across the surface is zero and
    // spawned rays start exactly on it; neither shadow rays nor scattered rays may re-hit it.
    let corners = [(-50.0, -50.0), (50.0, -50.0), (-50.0, 50.0), (50.0, 50.0)].map(|(x, y)| Vec3::new(x, y, 0.0));
    let m = patches(corners.to_vec(), vec![0, 1, 2, 3], &Transform::IDENTITY, false);
    let scene = GeometryScene::from_shapes(vec![Shape::Bilinear(m)]).unwrap();
    let mut rng = Pcg32::seed_from_u64(2);
    for i in 0..10_000 {
        let o = Vec3::new(uniform(&mut rng) * 20.0 - 10.0, uniform(&mut rng) * 20.0 - 10.0, 0.5);
        let h = scene.intersect(&Ray::new(o, -Vec3::Z), f32::INFINITY).unwrap();
        assert!((h.t - 0.5).abs() < 1e-6 && h.p.z == 0.0, "ray {i}: {} {}", h.t, h.p);
        let target = vec3(&mut rng, -5.0, 5.0) * Vec3::new(1.0, 1.0, 0.0) + Vec3::Z * (uniform(&mut rng) - 0.5);
        let (r, t_max) = h.spawn_ray_to_point(target);
        assert!(scene.intersect(&r, t_max).is_none(), "ray {i}: shadow ray to {target} re-hits");
        let w = unit_vector(&mut rng);
        assert!(scene.intersect(&h.spawn_ray(w), f32::INFINITY).is_none(), "ray {i}: {w} re-hits");
    }
}

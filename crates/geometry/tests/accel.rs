//! BVH correctness against brute force, instancing, watertightness and spawn-offset robustness.

use std::f32::consts::PI;
use std::sync::Arc;

use geometry::accel::{Accel, GeometryScene, Instance, Object};
use geometry::mesh::{MeshData, TriangleMesh};
use geometry::shapes::{Disk, Shape, Sphere};
use geometry::{DVec3, Ray, Transform, Vec2, Vec3};
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

fn mesh(data: MeshData) -> Shape {
    Shape::Mesh(Arc::new(TriangleMesh::new(&Transform::IDENTITY, data, false).unwrap()))
}

fn soup(rng: &mut Pcg32, n: usize) -> MeshData {
    let mut positions = Vec::new();
    for _ in 0..n {
        let c = vec3(rng, -10.0, 10.0);
        for _ in 0..3 {
            positions.push(c + vec3(rng, -1.0, 1.0));
        }
    }
    MeshData { indices: (0..positions.len() as u32).collect(), positions, ..Default::default() }
}

fn identity(object: u32) -> Instance {
    Instance { object, render_from_instance: Transform::IDENTITY }
}

#[test]
fn bvh_matches_brute_force() {
    let mut rng = Pcg32::seed_from_u64(7);
    let mut shapes = vec![mesh(soup(&mut rng, 3000))];
    for _ in 0..30 {
        let c = vec3(&mut rng, -10.0, 10.0).as_dvec3();
        shapes.push(Shape::Sphere(Sphere::new(0.2 + uniform(&mut rng), Transform::translate(c), false).unwrap()));
    }
    shapes.push(mesh(soup(&mut rng, 500)));
    // A soup with per-vertex normals and uvs, whose hit records read them through the mesh's indices.
    let mut shaded = soup(&mut rng, 500);
    shaded.normals = Some(shaded.positions.iter().map(|_| unit_vector(&mut rng)).collect());
    shaded.uvs = Some(shaded.positions.iter().map(|p| glam::Vec2::new(p.x * 0.1, p.y * 0.3 + p.z)).collect());
    shapes.push(mesh(shaded));
    for _ in 0..5 {
        let t = Transform::translate(vec3(&mut rng, -8.0, 8.0).as_dvec3())
            * Transform::rotate(360.0 * uniform(&mut rng) as f64, unit_vector(&mut rng).as_dvec3()).unwrap();
        shapes.push(Shape::Disk(Disk::new(0.0, 1.5, 0.2, 360.0, t, false).unwrap()));
    }
    // The same object also instanced twice elsewhere, to exercise the top level.
    let objects = vec![Object::new(shapes)];
    let instances = vec![
        identity(0),
        Instance {
            object: 0,
            render_from_instance: Transform::translate(DVec3::new(30.0, 0.0, 0.0))
                * Transform::rotate(30.0, DVec3::Y).unwrap(),
        },
        Instance {
            object: 0,
            render_from_instance: Transform::translate(DVec3::new(0.0, 25.0, 5.0))
                * Transform::scale(DVec3::new(0.5, 0.5, 0.5)).unwrap(),
        },
    ];
    for scene in [
        GeometryScene::build(objects.clone(), vec![identity(0)]).unwrap(),
        GeometryScene::build(objects, instances).unwrap(),
    ] {
        let mut hits = 0;
        for i in 0..4000 {
            let o = vec3(&mut rng, -15.0, 35.0);
            let target = vec3(&mut rng, -10.0, 30.0);
            let ray = Ray::new(o, (target - o).normalize());
            let t_max = if i % 4 == 0 { 20.0 } else { f32::INFINITY };
            let a = scene.intersect(&ray, t_max);
            let b = scene.intersect_brute_force(&ray, t_max);
            match (a, b) {
                (Some(a), Some(b)) => {
                    assert_eq!((a.t, a.instance, a.primitive), (b.t, b.instance, b.primitive), "ray {i}");
                    // The whole record, bit for bit: the BVH builds it from its inline copy of the triangle, the
                    // brute force from the mesh.
                    assert_eq!((a.p, a.p_error, a.n, a.ns, a.uv), (b.p, b.p_error, b.n, b.ns, b.uv), "ray {i}");
                    assert_eq!(
                        (a.dpdu, a.tangent(), a.shading_dpdu, a.shading_dpdv),
                        (b.dpdu, b.tangent(), b.shading_dpdu, b.shading_dpdv),
                        "ray {i}"
                    );
                    hits += 1;
                }
                (None, None) => {}
                (a, b) => panic!("ray {i}: bvh {a:?} vs brute force {b:?}"),
            }
            assert_eq!(scene.occluded(&ray, t_max), b.is_some(), "ray {i}");
        }
        assert!(hits > 500, "{hits}");
    }
}

#[test]
fn instances_hit_at_their_transformed_positions() {
    // Object 0: a unit sphere at the origin and a unit square (two triangles) at z = -2 facing +z.
    let square = MeshData {
        positions: vec![
            Vec3::new(-1.0, -1.0, -2.0),
            Vec3::new(1.0, -1.0, -2.0),
            Vec3::new(1.0, 1.0, -2.0),
            Vec3::new(-1.0, 1.0, -2.0),
        ],
        indices: vec![0, 1, 2, 0, 2, 3],
        ..Default::default()
    };
    let shapes = vec![Shape::Sphere(Sphere::new(1.0, Transform::IDENTITY, false).unwrap()), mesh(square)];
    let a = Transform::translate(DVec3::new(10.0, 0.0, 0.0));
    let b = Transform::translate(DVec3::new(-10.0, 5.0, 0.0)) * Transform::scale(DVec3::splat(2.0)).unwrap();
    let scene = GeometryScene::build(
        vec![Object::new(shapes), Object::default()],
        vec![
            Instance { object: 0, render_from_instance: a },
            Instance { object: 1, render_from_instance: Transform::IDENTITY },
            Instance { object: 0, render_from_instance: b },
        ],
    )
    .unwrap();
    // Down the z axis onto instance A's sphere: hit at z = 1 → t = 9.
    let h = scene.intersect(&Ray::new(Vec3::new(10.0, 0.0, 10.0), -Vec3::Z), f32::INFINITY).unwrap();
    assert!((h.t - 9.0).abs() < 1e-5 && h.instance == 0 && h.object == 0 && h.primitive == 0 && h.shape == 0);
    assert!((h.n - Vec3::Z).length() < 1e-5 && (h.p - Vec3::new(10.0, 0.0, 1.0)).length() < 1e-5);
    // Instance B is scaled by 2: sphere radius 2 about (−10, 5, 0), square at z = −4.
    let h = scene.intersect(&Ray::new(Vec3::new(-10.0, 5.0, 10.0), -Vec3::Z), f32::INFINITY).unwrap();
    assert!((h.t - 8.0).abs() < 1e-5 && h.instance == 2, "{h:?}");
    let h = scene.intersect(&Ray::new(Vec3::new(-11.5, 3.5, 10.0), -Vec3::Z), f32::INFINITY).unwrap();
    assert!((h.t - 14.0).abs() < 1e-5 && h.instance == 2 && h.shape == 1 && h.primitive >= 1, "{h:?}");
    assert_eq!(scene.locate(0, h.primitive), Some((1, h.element)));
    assert_eq!(scene.primitive_range(0, 1), 1..3);
    assert!((h.n - Vec3::Z).length() < 1e-5, "{:?}", h.n);
    // Between the instances: nothing.
    assert!(scene.intersect(&Ray::new(Vec3::new(0.0, 0.0, 10.0), -Vec3::Z), f32::INFINITY).is_none());
    assert!(scene.occluded(&Ray::new(Vec3::new(10.0, 0.0, 10.0), -Vec3::Z), 9.5));
    assert!(!scene.occluded(&Ray::new(Vec3::new(10.0, 0.0, 10.0), -Vec3::Z), 8.5));
    let b = scene.bounds();
    assert!(b.contains(Vec3::new(-12.0, 3.0, -4.0)) && b.contains(Vec3::new(11.0, 1.0, 1.0)));
    // A bad object index is an error, not a panic.
    assert!(GeometryScene::build(vec![], vec![identity(3)]).is_err());
}

/// A grid of `n × n` quads (two triangles each) over [0,1]² at height `z(x, y)`.
fn grid(n: usize, z: impl Fn(f32, f32) -> f32) -> MeshData {
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (i as f32 / n as f32, j as f32 / n as f32);
            positions.push(Vec3::new(x, y, z(x, y)));
        }
    }
    let mut indices = Vec::new();
    let v = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    for j in 0..n {
        for i in 0..n {
            indices.extend([v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j), v(i + 1, j + 1), v(i, j + 1)]);
        }
    }
    MeshData { positions, indices, ..Default::default() }
}

/// Points on the interior edges of a mesh (and its vertices), with their edge's endpoints.
fn edge_points(data: &MeshData, rng: &mut Pcg32, per_edge: usize, skip: impl Fn(Vec3, Vec3) -> bool) -> Vec<Vec3> {
    let mut out = Vec::new();
    for tri in data.indices.chunks_exact(3) {
        for k in 0..3 {
            let (a, b) = (data.positions[tri[k] as usize], data.positions[tri[(k + 1) % 3] as usize]);
            if skip(a, b) {
                continue;
            }
            for s in 0..per_edge {
                let f = if s == 0 { 0.0 } else { uniform(rng) };
                out.push(a + f * (b - a));
            }
        }
    }
    out
}

#[test]
fn rays_through_shared_edges_and_vertices_never_miss() {
    let mut rng = Pcg32::seed_from_u64(3);
    // A subdivided planar quad (tilted so no coordinate is trivially zero): rays from any direction through points
    // on its shared edges and vertices.
    let tilt = |x: f32, y: f32| 0.3 * x - 0.2 * y + 0.1;
    let data = grid(8, tilt);
    let border = |p: Vec3| p.x == 0.0 || p.x == 1.0 || p.y == 0.0 || p.y == 1.0;
    let targets = edge_points(&data, &mut rng, 40, |a, b| border(a) && border(b) || border(a) && a == b);
    let scene = GeometryScene::from_shapes(vec![mesh(data)]).unwrap();
    let plane_n = Vec3::new(-0.3, 0.2, 1.0).normalize();
    let mut misses = 0;
    for target in &targets {
        if border(*target) {
            continue;
        }
        let mut d = unit_vector(&mut rng);
        while d.dot(plane_n).abs() < 0.01 {
            d = unit_vector(&mut rng);
        }
        if d.dot(plane_n) > 0.0 {
            d = -d;
        }
        let o = *target - 3.0 * d;
        if scene.intersect(&Ray::new(o, d), f32::INFINITY).is_none() {
            misses += 1;
        }
    }
    assert!(targets.len() > 10_000, "{}", targets.len());
    assert_eq!(misses, 0, "{misses} of {} rays through shared edges of a quad missed", targets.len());

    // A closed mesh: rays from an inside point towards its edges and vertices must all hit.
    let sphere = uv_sphere(Vec3::new(0.1, 0.2, 0.3), 2.0, 16, 32);
    let targets = edge_points(&sphere, &mut rng, 20, |_, _| false);
    let scene = GeometryScene::from_shapes(vec![mesh(sphere)]).unwrap();
    for o in [Vec3::new(0.1, 0.2, 0.3), Vec3::new(0.5, -0.7, 1.0)] {
        let misses = targets
            .iter()
            .filter(|&&t| {
                let r = Ray::new(o, (t - o).normalize());
                let m = scene.intersect(&r, f32::INFINITY).is_none();
                if m {
                    eprintln!("escape {t} brute {:?}", scene.intersect_brute_force(&r, f32::INFINITY).map(|h| h.t));
                }
                m
            })
            .count();
        assert_eq!(misses, 0, "{misses} of {} rays from inside a closed mesh escaped", targets.len());
    }
}

/// A lat-long tessellated sphere (a convex polyhedron: every vertex on the sphere, planar quads).
fn uv_sphere(center: Vec3, r: f32, n_theta: usize, n_phi: usize) -> MeshData {
    let mut positions = Vec::new();
    for j in 0..=n_theta {
        let theta = PI * j as f32 / n_theta as f32;
        for i in 0..n_phi {
            let phi = 2.0 * PI * i as f32 / n_phi as f32;
            let d = Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
            positions.push(center + r * d);
        }
    }
    let v = |i: usize, j: usize| (j * n_phi + i % n_phi) as u32;
    let mut indices = Vec::new();
    for j in 0..n_theta {
        for i in 0..n_phi {
            let (a, b, c, d) = (v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1));
            if j != 0 {
                indices.extend([a, c, b]);
            }
            if j != n_theta - 1 {
                indices.extend([a, d, c]);
            }
        }
    }
    MeshData { positions, indices, ..Default::default() }
}

/// Hits a convex closed shape from outside, then spawns rays to both sides: outward ones must hit nothing,
/// inward ones must not hit the primitive they leave (meshes) or must cross the whole chord (spheres). Also checks
/// that shadow rays between two hits on the inside are never occluded. Returns (self-intersections, inward misses).
fn spawn_trial(scene: &GeometryScene, center: Vec3, r: f32, is_mesh: bool, rays: usize, seed: u64) -> (usize, usize) {
    let mut rng = Pcg32::seed_from_u64(seed);
    let mut bad = 0;
    let mut inward_misses = 0;
    let mut done = 0;
    let mut prev = None;
    while done < rays {
        let o = center + 3.0 * r * unit_vector(&mut rng);
        let target = center + 0.9 * r * unit_vector(&mut rng);
        let Some(h) = scene.intersect(&Ray::new(o, (target - o).normalize()), f32::INFINITY) else {
            continue;
        };
        done += 1;
        let mut w = unit_vector(&mut rng);
        if w.dot(h.n) < 0.0 {
            w = -w;
        }
        // Reflection side: convex shape, nothing to hit.
        if let Some(h2) = scene.intersect(&h.spawn_ray(w), f32::INFINITY) {
            eprintln!("outward hit {h:?} -> {h2:?}");
            bad += 1;
        }
        // Transmission side.
        match scene.intersect(&h.spawn_ray(-w), f32::INFINITY) {
            Some(h2) => {
                let chord = 2.0 * r * w.dot(h.n.normalize()).abs();
                let self_hit =
                    if is_mesh { h2.primitive == h.primitive } else { h2.t < 0.5 * chord || h2.t < 1e-6 * r };
                if self_hit {
                    eprintln!("inward self-hit {h:?} -> {h2:?}");
                    bad += 1;
                }
            }
            None => inward_misses += 1,
        }
        // Shadow ray between two points on the shape: inside a convex shape they see each other.
        if let Some(p) = prev {
            let (ray, t_max) = h.spawn_ray_to(&p);
            // Only segments that really cross the inside (not along one facet, where cos θ = 0 anyway).
            let inside = ray.d.dot(h.n) < -1e-2 && ray.d.dot(p.n) > 1e-2;
            if inside && t_max > 0.0 && scene.occluded(&ray, t_max) {
                eprintln!("shadow occluded {h:?} -> {p:?}: {ray:?} {t_max} {:?}", scene.intersect(&ray, t_max));
                bad += 1;
            }
        }
        prev = Some(h.surface_point());
    }
    (bad, inward_misses)
}

#[test]
fn spawned_rays_never_self_intersect() {
    let cases: [(Vec3, f32); 3] =
        [(Vec3::new(1e4, 0.0, 0.0), 1e3), (Vec3::new(0.3, -0.2, 0.1), 1e-3), (Vec3::new(-3e3, 2e3, 7e3), 1.0)];
    for (k, (c, r)) in cases.into_iter().enumerate() {
        let sphere = Shape::Sphere(Sphere::new(r, Transform::translate(c.as_dvec3()), false).unwrap());
        let scene = GeometryScene::from_shapes(vec![sphere]).unwrap();
        let (bad, misses) = spawn_trial(&scene, c, r, false, 10_000, k as u64);
        assert_eq!(bad, 0, "sphere r={r} at {c}: {bad} self-intersections");
        assert!(misses <= 10, "sphere r={r}: {misses} inward rays missed");

        let m = mesh(uv_sphere(c, r, 24, 48));
        let scene = GeometryScene::from_shapes(vec![m]).unwrap();
        let (bad, _) = spawn_trial(&scene, c, r, true, 10_000, 100 + k as u64);
        assert_eq!(bad, 0, "mesh sphere r={r} at {c}: {bad} self-intersections");

        // The same through an instance with rotation and non-uniform scale.
        let inst = Transform::translate(c.as_dvec3())
            * Transform::rotate(33.0, DVec3::new(1.0, 2.0, 3.0)).unwrap()
            * Transform::scale(DVec3::new(1.0, 0.7, 1.3)).unwrap();
        let objects = vec![Object::new(vec![mesh(uv_sphere(Vec3::ZERO, r, 24, 48))])];
        let scene = GeometryScene::build(objects, vec![Instance { object: 0, render_from_instance: inst }]).unwrap();
        let (bad, _) = spawn_trial(&scene, c, r, true, 5_000, 200 + k as u64);
        assert_eq!(bad, 0, "instanced mesh sphere r={r} at {c}: {bad} self-intersections");
    }
}

#[test]
fn hit_geometry_of_a_mesh_with_normals_and_uvs() {
    let data = MeshData {
        positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
        normals: Some(vec![Vec3::new(0.0, 0.0, -1.0); 3]),
        uvs: Some(vec![Vec2::new(0.0, 0.0), Vec2::new(2.0, 0.0), Vec2::new(0.0, 2.0)]),
        indices: vec![0, 1, 2],
    };
    let scene = GeometryScene::from_shapes(vec![mesh(data)]).unwrap();
    let h = scene.intersect(&Ray::new(Vec3::new(0.25, 0.25, 1.0), -Vec3::Z), f32::INFINITY).unwrap();
    // Vertex normals point to −z, so the geometric normal is flipped there too (pbrt-v4).
    assert!((h.n + Vec3::Z).length() < 1e-6 && (h.ns + Vec3::Z).length() < 1e-6);
    assert!((h.uv - Vec2::new(0.5, 0.5)).length() < 1e-6);
    assert!((h.dpdu - Vec3::new(0.5, 0.0, 0.0)).length() < 1e-6, "{:?}", h.dpdu);
    assert!(h.tangent().dot(h.ns).abs() < 1e-6 && (h.tangent().length() - 1.0).abs() < 1e-6);
}

/// A cube [-1, 1]³ with outward per-vertex normals (4 vertices per face).
fn cube_with_normals() -> MeshData {
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut indices = Vec::new();
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let unit = |i: usize| Vec3::from_array(std::array::from_fn(|k| if k == i { 1.0 } else { 0.0 }));
            let n = sign * unit(axis);
            let (u, v) = (unit((axis + 1) % 3), n.cross(unit((axis + 1) % 3)));
            let base = positions.len() as u32;
            for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                positions.push(n + a * u + b * v);
                normals.push(n);
            }
            indices.extend([base, base + 1, base + 2, base, base + 2, base + 3]);
        }
    }
    MeshData { positions, normals: Some(normals), uvs: None, indices }
}

#[test]
fn a_mesh_under_a_singular_transform_is_flattened_and_uses_geometric_normals() {
    // The pattern of pbrt-v4 scenes exported from a modeller: a ConcatTransform whose first column is zero (x scaled
    // to zero), here with a half-turn about y and a translation to x = 3.
    let m = [0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, -1.2246469e-16, 0.0, -1.0, 0.0, 3.0, 0.5, 0.0, 1.0];
    let t = Transform::from_matrix_allow_singular(geometry::DMat4::from_cols_array(&m)).unwrap();
    assert!(!t.is_invertible());
    let mesh = TriangleMesh::new(&t, cube_with_normals(), false).unwrap();
    assert!(mesh.normals().is_none() && !mesh.flip_normal());
    let b = mesh.bounds();
    assert!((b.min.x - 3.0).abs() < 1e-6 && (b.max.x - 3.0).abs() < 1e-6, "{b:?}");
    assert!((b.min.y + 0.5).abs() < 1e-6 && (b.max.y - 1.5).abs() < 1e-6, "{b:?}");
    let scene = GeometryScene::from_shapes(vec![Shape::Mesh(Arc::new(mesh))]).unwrap();
    // Seen edge-on from the side it is a plane at x = 3: hit at t = 7 with the plane's normal as shading normal.
    let h = scene.intersect(&Ray::new(Vec3::new(10.0, 0.5, 0.2), Vec3::NEG_X), f32::INFINITY).unwrap();
    assert!((h.t - 7.0).abs() < 1e-5 && (h.p.x - 3.0).abs() < 1e-5, "{h:?}");
    assert!((h.n.x.abs() - 1.0).abs() < 1e-6 && h.ns == h.n, "{h:?}");
    // Where the cube would have been hit, off the plane, nothing is.
    assert!(scene.intersect(&Ray::new(Vec3::new(3.5, 10.0, 0.2), Vec3::NEG_Y), f32::INFINITY).is_none());
    assert!(scene.intersect(&Ray::new(Vec3::new(2.5, 0.5, 10.0), Vec3::NEG_Z), f32::INFINITY).is_none());
}

/// Checks the surface derivatives at the hit of `o + t·d` against finite differences: a second ray aimed a small
/// step away hits at (u + Δu, v + Δv), and its point and shading normal must differ from the first by
/// ∂p/∂u·Δu + ∂p/∂v·Δv and ∂n/∂u·Δu + ∂n/∂v·Δv up to second-order terms (relative 2%, where the first-order
/// change is ~1e-3 and an error in a derivative would show at its own size).
fn check_derivatives_fd(scene: &GeometryScene, o: Vec3, target: Vec3, curved: bool) {
    let d = (target - o).normalize();
    let (h0, der) = scene.intersect_with_derivatives(&Ray::new(o, d), f32::INFINITY).expect("the ray hits");
    let der = der.expect("the shape provides derivatives");
    let (tx, ty) = geometry::shapes::coordinate_system(d);
    for step in [tx, ty, tx + ty] {
        let d2 = (target + 2e-3 * step - o).normalize();
        let h1 = scene.intersect(&Ray::new(o, d2), f32::INFINITY).expect("the nearby ray hits");
        assert_eq!((h1.instance, h1.shape), (h0.instance, h0.shape));
        let (du, dv) = (h1.uv.x - h0.uv.x, h1.uv.y - h0.uv.y);
        let dp_pred = der.dpdu * du + der.dpdv * dv;
        let dp = h1.p - h0.p;
        assert!(dp.length() > 1e-4, "the step moved the hit ({dp})");
        assert!((dp - dp_pred).length() < 0.01 * dp.length(), "dp {dp} predicted {dp_pred}");
        let dn_pred = der.dndu * du + der.dndv * dv;
        let dn = h1.ns - h0.ns;
        if curved {
            assert!(dn.length() > 1e-4, "the normal turned ({dn})");
            assert!((dn - dn_pred).length() < 0.01 * dn.length(), "dn {dn} predicted {dn_pred}");
        } else {
            assert!(dn.length() < 1e-6 && dn_pred.length() < 1e-6, "flat: {dn} {dn_pred}");
        }
        // The normal's derivative is tangent to the unit sphere of normals.
        assert!(der.dndu.dot(h0.ns).abs() < 1e-5 && der.dndv.dot(h0.ns).abs() < 1e-5);
    }
}

#[test]
fn surface_derivatives_match_finite_differences() {
    // A sphere (also reversed and under a non-trivial instance transform) and a triangle with vertex normals and
    // uvs, placed by a rotation and a uniform scale.
    let sphere = |rev| Shape::Sphere(Sphere::new(1.3, Transform::translate(DVec3::new(0.2, -0.1, 0.3)), rev).unwrap());
    let tri = mesh(MeshData {
        positions: vec![Vec3::new(-1.0, -1.0, 0.0), Vec3::new(2.0, -1.0, 0.2), Vec3::new(0.0, 1.5, -0.1)],
        normals: Some(vec![Vec3::new(0.3, 0.0, 1.0), Vec3::new(-0.2, 0.1, 1.0), Vec3::new(0.0, -0.4, 1.0)]),
        uvs: Some(vec![Vec2::new(0.0, 0.0), Vec2::new(0.7, 0.1), Vec2::new(0.2, 0.9)]),
        indices: vec![0, 1, 2],
    });
    let flat = mesh(MeshData {
        positions: vec![Vec3::new(-1.0, -1.0, 0.0), Vec3::new(2.0, -1.0, 0.0), Vec3::new(0.0, 1.5, 0.0)],
        indices: vec![0, 1, 2],
        ..Default::default()
    });
    let placed = Transform::translate(DVec3::new(0.5, 0.0, -0.5))
        * Transform::rotate(30.0, DVec3::new(1.0, 1.0, 0.0)).unwrap()
        * Transform::scale(DVec3::splat(1.5)).unwrap();
    for (shape, curved) in [(sphere(false), true), (sphere(true), true), (tri, true), (flat, false)] {
        for t in [Transform::IDENTITY, placed] {
            let scene = GeometryScene::build(
                vec![Object::new(vec![shape.clone()])],
                vec![Instance { object: 0, render_from_instance: t }],
            )
            .unwrap();
            let target = t.point(DVec3::new(0.25, 0.1, 0.0)).as_vec3();
            let o = target + Vec3::new(0.3, 0.4, 6.0);
            check_derivatives_fd(&scene, o, target, curved);
        }
    }
}

#[test]
fn moving_instances_are_hit_where_they_are_at_the_ray_time() {
    use geometry::{AnimatedTransform, MovingInstance};
    let mut rng = Pcg32::seed_from_u64(11);
    let object = || {
        let mut rng = Pcg32::seed_from_u64(5);
        Object::new(vec![
            mesh(soup(&mut rng, 200)),
            Shape::Sphere(Sphere::new(2.0, Transform::translate(DVec3::new(3.0, 0.0, 0.0)), false).unwrap()),
        ])
    };
    let outer = AnimatedTransform::new(
        Transform::translate(DVec3::new(-5.0, 0.0, 0.0)),
        0.0,
        Transform::translate(DVec3::new(5.0, 2.0, 0.0))
            * Transform::rotate(120.0, DVec3::new(0.0, 1.0, 1.0)).unwrap()
            * Transform::scale(DVec3::new(1.0, 0.5, 1.5)).unwrap(),
        1.0,
    )
    .unwrap();
    let inner =
        AnimatedTransform::new(Transform::IDENTITY, 0.0, Transform::rotate(-45.0, DVec3::Z).unwrap(), 1.0).unwrap();
    let moving = MovingInstance { object: 1, outer, inner };
    // A static object next to it, so both top-level structures are searched.
    let scene = GeometryScene::build_with_motion(
        vec![Object::new(vec![mesh(soup(&mut rng, 100))]), object()],
        vec![identity(0)],
        vec![moving.clone()],
    )
    .unwrap();
    assert_eq!(scene.moving_instance_count(), 1);
    let mut hits = 0;
    for i in 0..400 {
        let time = i as f32 / 399.0;
        let o = vec3(&mut rng, -25.0, 25.0);
        let d = (vec3(&mut rng, -8.0, 8.0) - o).normalize();
        let ray = Ray::at_time(o, d, time);
        // The same object, fixed where the moving one is at this time.
        let frozen = GeometryScene::build(
            vec![Object::new(vec![mesh(soup(&mut Pcg32::seed_from_u64(11), 100))]), object()],
            vec![identity(0), Instance { object: 1, render_from_instance: moving.render_from_instance(time) }],
        );
        let frozen = frozen.unwrap();
        let (a, b) = (scene.intersect(&ray, f32::INFINITY), frozen.intersect(&ray, f32::INFINITY));
        assert_eq!(a.map(|h| (h.t, h.p, h.n, h.object)), b.map(|h| (h.t, h.p, h.n, h.object)), "ray {i}");
        assert_eq!(a.map(|h| h.t), scene.intersect_brute_force(&ray, f32::INFINITY).map(|h| h.t), "ray {i}");
        assert_eq!(scene.occluded(&ray, f32::INFINITY), a.is_some());
        hits += a.is_some_and(|h| h.object == 1) as u32;
    }
    assert!(hits > 20, "{hits}");
}

#[test]
fn an_instance_turning_a_quarter_turn_is_halfway_round_at_half_time() {
    use geometry::{AnimatedTransform, MovingInstance};
    // A thin bar along +x from 1 to 3, turning 90° about z between t = 0 and t = 1.
    let bar = MeshData {
        positions: vec![
            Vec3::new(1.0, -0.05, 0.0),
            Vec3::new(3.0, -0.05, 0.0),
            Vec3::new(3.0, 0.05, 0.0),
            Vec3::new(1.0, 0.05, 0.0),
        ],
        indices: vec![0, 1, 2, 0, 2, 3],
        ..Default::default()
    };
    let turn = AnimatedTransform::new(Transform::IDENTITY, 0.0, Transform::rotate(90.0, DVec3::Z).unwrap(), 1.0);
    let scene = GeometryScene::build_with_motion(
        vec![Object::new(vec![mesh(bar)])],
        vec![],
        vec![MovingInstance { object: 0, outer: turn.unwrap(), inner: AnimatedTransform::fixed(Transform::IDENTITY) }],
    )
    .unwrap();
    let down = |x: f32, y: f32, time: f32| scene.intersect(&Ray::at_time(Vec3::new(x, y, 1.0), -Vec3::Z, time), 10.0);
    let at = |deg: f32| {
        let a = deg.to_radians();
        (2.0 * a.cos(), 2.0 * a.sin())
    };
    for (time, deg) in [(0.0, 0.0), (0.25, 22.5), (0.5, 45.0), (1.0, 90.0)] {
        let (x, y) = at(deg);
        let hit = down(x, y, time).unwrap_or_else(|| panic!("bar at {deg}° at t = {time}"));
        assert!((hit.t - 1.0).abs() < 1e-6 && (hit.p - Vec3::new(x, y, 0.0)).length() < 1e-5);
        // 10° away from where it is, the bar is not there.
        let (x, y) = at(deg + 10.0);
        assert!(down(x, y, time).is_none(), "{deg}");
    }
    // Outside the interval the motion is clamped to its ends.
    let (x, y) = at(90.0);
    assert!(down(x, y, 7.0).is_some() && down(2.0, 0.0, -1.0).is_some());
}

#[test]
fn a_bvh_hundreds_of_levels_deep_matches_brute_force() {
    // Triangles shrinking around one point, each 0.5% smaller than the last, give a BVH hundreds of levels deep
    // (the traversal stack's fixed array holds nine levels' worth when every child is hit; its spill into a vector
    // is tested in the `wide` module).
    let mut positions = Vec::new();
    for k in 0..1500 {
        let s = 0.995f32.powi(k);
        positions.extend([Vec3::new(-s, -s, 0.1 * s), Vec3::new(s, -0.5 * s, -0.1 * s), Vec3::new(0.2 * s, s, 0.0)]);
    }
    let data = MeshData { indices: (0..positions.len() as u32).collect(), positions, ..Default::default() };
    let scene = GeometryScene::build(vec![Object::new(vec![mesh(data)])], vec![identity(0)]).unwrap();
    let depth = scene.bvh_stats().depth;
    assert!(depth > 40, "depth {depth}");
    let mut rng = Pcg32::seed_from_u64(11);
    let mut hits = 0;
    for i in 0..2000 {
        let o = vec3(&mut rng, -2.0, 2.0);
        let target = vec3(&mut rng, -0.3, 0.3) * if i % 2 == 0 { 1.0 } else { 0.01 };
        let ray = Ray::new(o, (target - o).normalize());
        let t_max = if i % 3 == 0 { (target - o).length() } else { f32::INFINITY };
        let (a, b) = (scene.intersect(&ray, t_max), scene.intersect_brute_force(&ray, t_max));
        // The distance to an ulp: the tiny triangles near the centre are often hit at the same float distance or
        // an ulp apart, and of two such the one found first is kept (the triangle test compares in scaled form,
        // `t·det` against `t_max·det`; see `closest_first`), so the traversal and brute force, which meet them in
        // different orders, can report either (12 of these 2,000 rays, in both directions).
        match (a, b) {
            (Some(a), Some(b)) => assert!(a.t.to_bits().abs_diff(b.t.to_bits()) <= 1, "ray {i}: {} vs {}", a.t, b.t),
            (a, b) => assert_eq!(a.is_some(), b.is_some(), "ray {i}"),
        }
        assert_eq!(scene.occluded(&ray, t_max), b.is_some(), "ray {i}");
        hits += usize::from(b.is_some());
    }
    assert!(hits > 1000, "{hits}");
}

//! Loop subdivision (Loop 1987; pbrt's `loopsubdiv` shape): refine a triangle mesh `levels` times, then move every
//! vertex to its limit position and give it the limit-surface normal.
//!
//! Rules (with Warren's weights as pbrt uses them): an interior vertex of valence `n` becomes
//! `(1 − nβ)·v + β·Σ neighbours`, `β = 3/16` for `n = 3` and `3/(8n)` otherwise; a boundary vertex becomes
//! `¾·v + ⅛·(its two boundary neighbours)`; a new interior edge vertex is `⅜·(a + b) + ⅛·(c + d)` (the two
//! opposite vertices), a new boundary edge vertex the edge midpoint. Limit positions: interior
//! `(1 − nγ)·v + γ·Σ neighbours`, `γ = 1/(n + 3/(8β))`; boundary `⅗·v + ⅕·(boundary neighbours)`. Limit
//! normals are the cross product of the two limit tangents (cos/sin-weighted ring sums for interior vertices, the
//! boundary tangent masks for boundary vertices), oriented to agree with the triangles' winding. Corners (a
//! boundary vertex with other than two boundary edges) and non-manifold edges (shared by more than two triangles)
//! are kept as creases.

use std::collections::HashMap;
use std::f32::consts::PI;

use glam::Vec3;

use crate::error::GeometryError;
use crate::mesh::MeshData;

/// Loop-subdivides the triangles of `data` (positions and indices; normals and uvs are ignored, as in pbrt)
/// `levels` times and returns the mesh with limit positions and limit normals. Degenerate triangles (a repeated
/// vertex) are dropped. Errors on invalid data or if the result would exceed 2³¹ triangles.
pub fn loop_subdivide(data: &MeshData, levels: u32) -> Result<MeshData, GeometryError> {
    let check = MeshData { positions: data.positions.clone(), normals: None, uvs: None, indices: data.indices.clone() };
    check.validate()?;
    let tri_count = data.indices.len() / 3;
    let final_count = (tri_count as u128) << (2 * levels.min(40));
    if levels > 15 || final_count > (1u128 << 31) {
        return Err(GeometryError::InvalidMesh(format!(
            "loop subdivision of {tri_count} triangles to {levels} levels would make too many triangles"
        )));
    }
    let mut positions = data.positions.clone();
    let mut tris: Vec<[u32; 3]> = data
        .indices
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]])
        .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
        .collect();
    for _ in 0..levels {
        (positions, tris) = subdivide_once(&positions, &tris);
    }
    let topo = Topology::new(positions.len(), &tris);
    let limit: Vec<Vec3> = (0..positions.len()).map(|v| topo.limit_position(&positions, v)).collect();
    let face_normals = area_weighted_normals(&limit, &tris);
    let normals = (0..positions.len()).map(|v| topo.limit_normal(&limit, v, face_normals[v], &tris)).collect();
    Ok(MeshData { positions: limit, normals: Some(normals), uvs: None, indices: tris.into_iter().flatten().collect() })
}

fn edge_key(a: u32, b: u32) -> u64 {
    let (lo, hi) = if a < b { (a, b) } else { (b, a) };
    (u64::from(lo) << 32) | u64::from(hi)
}

struct EdgeInfo {
    /// Index of the edge (its new vertex is `n_vertices + id`).
    id: u32,
    /// Opposite vertices of the (up to two) faces sharing the edge.
    opposite: [u32; 2],
    /// Number of faces sharing the edge.
    faces: u32,
}

/// Vertex adjacency of a triangle mesh.
struct Topology {
    edges: HashMap<u64, EdgeInfo>,
    /// All neighbours of each vertex.
    neighbours: Vec<Vec<u32>>,
    /// Neighbours across boundary (or non-manifold) edges.
    boundary: Vec<Vec<u32>>,
    /// Per vertex, the (from, to) neighbour pairs of its incident faces in counter-clockwise order.
    wedges: Vec<Vec<(u32, u32)>>,
}

impl Topology {
    fn new(n_vertices: usize, tris: &[[u32; 3]]) -> Self {
        let mut edges: HashMap<u64, EdgeInfo> = HashMap::with_capacity(tris.len() * 3 / 2 + 1);
        let mut wedges = vec![Vec::new(); n_vertices];
        for t in tris {
            for k in 0..3 {
                let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
                let next_id = edges.len() as u32;
                let e = edges.entry(edge_key(a, b)).or_insert(EdgeInfo { id: next_id, opposite: [c, c], faces: 0 });
                if e.faces < 2 {
                    e.opposite[e.faces as usize] = c;
                }
                e.faces += 1;
                wedges[a as usize].push((b, c));
            }
        }
        let mut neighbours = vec![Vec::new(); n_vertices];
        let mut boundary = vec![Vec::new(); n_vertices];
        for (&key, e) in &edges {
            let (a, b) = ((key >> 32) as u32, key as u32);
            neighbours[a as usize].push(b);
            neighbours[b as usize].push(a);
            if e.faces != 2 {
                boundary[a as usize].push(b);
                boundary[b as usize].push(a);
            }
        }
        // Sorted so that sums (and so the output) do not depend on hash order.
        neighbours.iter_mut().chain(boundary.iter_mut()).for_each(|l| l.sort_unstable());
        Self { edges, neighbours, boundary, wedges }
    }

    fn beta(valence: usize) -> f32 {
        if valence == 3 {
            3.0 / 16.0
        } else {
            3.0 / (8.0 * valence as f32)
        }
    }

    fn even_position(&self, p: &[Vec3], v: usize) -> Vec3 {
        let nb = &self.neighbours[v];
        if nb.is_empty() {
            return p[v];
        }
        let b = &self.boundary[v];
        if !b.is_empty() {
            if b.len() == 2 {
                return 0.75 * p[v] + 0.125 * (p[b[0] as usize] + p[b[1] as usize]);
            }
            return p[v];
        }
        let n = nb.len();
        let beta = Self::beta(n);
        let sum: Vec3 = nb.iter().map(|&u| p[u as usize]).sum();
        (1.0 - n as f32 * beta) * p[v] + beta * sum
    }

    fn limit_position(&self, p: &[Vec3], v: usize) -> Vec3 {
        let nb = &self.neighbours[v];
        if nb.is_empty() {
            return p[v];
        }
        let b = &self.boundary[v];
        if !b.is_empty() {
            if b.len() == 2 {
                return 0.6 * p[v] + 0.2 * (p[b[0] as usize] + p[b[1] as usize]);
            }
            return p[v];
        }
        let n = nb.len();
        let gamma = 1.0 / (n as f32 + 3.0 / (8.0 * Self::beta(n)));
        let sum: Vec3 = nb.iter().map(|&u| p[u as usize]).sum();
        (1.0 - n as f32 * gamma) * p[v] + gamma * sum
    }

    /// The one-ring of `v` in counter-clockwise order (for boundary vertices from one boundary neighbour to the
    /// other), or `None` if the neighbourhood is not a simple fan.
    fn ring(&self, v: usize) -> Option<Vec<u32>> {
        let w = &self.wedges[v];
        if w.is_empty() {
            return None;
        }
        let next = |from: u32| w.iter().find(|(a, _)| *a == from).map(|&(_, b)| b);
        let interior = self.boundary[v].is_empty();
        let start =
            if interior { w[0].0 } else { w.iter().map(|&(a, _)| a).find(|&a| w.iter().all(|&(_, b)| b != a))? };
        let mut ring = vec![start];
        let mut cur = start;
        for _ in 0..w.len() {
            let n = next(cur)?;
            if n == start {
                break;
            }
            ring.push(n);
            cur = n;
        }
        let expected = if interior { w.len() } else { w.len() + 1 };
        (ring.len() == expected && ring.len() == self.neighbours[v].len()).then_some(ring)
    }

    fn limit_normal(&self, p: &[Vec3], v: usize, fallback: Vec3, _tris: &[[u32; 3]]) -> Vec3 {
        let n = self.ring(v).and_then(|ring| {
            let q: Vec<Vec3> = ring.iter().map(|&u| p[u as usize]).collect();
            let k = q.len();
            let (s, t) = if self.boundary[v].is_empty() {
                let mut s = Vec3::ZERO;
                let mut t = Vec3::ZERO;
                for (i, qi) in q.iter().enumerate() {
                    let a = 2.0 * PI * i as f32 / k as f32;
                    s += a.cos() * *qi;
                    t += a.sin() * *qi;
                }
                (s, t)
            } else {
                if self.boundary[v].len() != 2 {
                    return None;
                }
                let s = q[k - 1] - q[0];
                let t = match k {
                    2 => q[0] + q[1] - 2.0 * p[v],
                    3 => q[1] - p[v],
                    // The regular boundary vertex; like every tangent mask its weights sum to zero.
                    4 => -q[0] + 2.0 * q[1] + 2.0 * q[2] - q[3] - 2.0 * p[v],
                    _ => {
                        let theta = PI / (k - 1) as f32;
                        let mut t = theta.sin() * (q[0] + q[k - 1]);
                        for (i, qi) in q.iter().enumerate().take(k - 1).skip(1) {
                            t += (2.0 * theta.cos() - 2.0) * (i as f32 * theta).sin() * *qi;
                        }
                        -t
                    }
                };
                (s, t)
            };
            s.cross(t).try_normalize()
        });
        match n {
            Some(n) if fallback != Vec3::ZERO => {
                if n.dot(fallback) < 0.0 {
                    -n
                } else {
                    n
                }
            }
            Some(n) => n,
            None => fallback,
        }
    }
}

/// Unit area-weighted vertex normals (zero for isolated vertices).
fn area_weighted_normals(p: &[Vec3], tris: &[[u32; 3]]) -> Vec<Vec3> {
    let mut n = vec![Vec3::ZERO; p.len()];
    for t in tris {
        let [a, b, c] = t.map(|i| p[i as usize]);
        let fnorm = (b - a).cross(c - a);
        for &i in t {
            n[i as usize] += fnorm;
        }
    }
    n.into_iter().map(|v| v.normalize_or_zero()).collect()
}

fn subdivide_once(p: &[Vec3], tris: &[[u32; 3]]) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let topo = Topology::new(p.len(), tris);
    let nv = p.len() as u32;
    let mut out = vec![Vec3::ZERO; p.len() + topo.edges.len()];
    for (v, slot) in out.iter_mut().enumerate().take(p.len()) {
        *slot = topo.even_position(p, v);
    }
    for (&key, e) in &topo.edges {
        let (a, b) = (p[(key >> 32) as usize], p[(key as u32) as usize]);
        out[(nv + e.id) as usize] = if e.faces == 2 {
            0.375 * (a + b) + 0.125 * (p[e.opposite[0] as usize] + p[e.opposite[1] as usize])
        } else {
            0.5 * (a + b)
        };
    }
    let mid = |a: u32, b: u32| nv + topo.edges[&edge_key(a, b)].id;
    let mut new_tris = Vec::with_capacity(tris.len() * 4);
    for &[a, b, c] in tris {
        let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
        new_tris.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
    }
    (out, new_tris)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetrahedron() -> MeshData {
        MeshData {
            positions: vec![
                Vec3::new(1.0, 1.0, 1.0),
                Vec3::new(1.0, -1.0, -1.0),
                Vec3::new(-1.0, 1.0, -1.0),
                Vec3::new(-1.0, -1.0, 1.0),
            ],
            indices: vec![0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2],
            ..Default::default()
        }
    }

    fn octahedron() -> MeshData {
        let positions = vec![Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
        let indices = vec![0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5];
        MeshData { positions, indices, ..Default::default() }
    }

    fn outward(m: &MeshData) -> bool {
        m.indices.chunks_exact(3).all(|t| {
            let [a, b, c] = [0, 1, 2].map(|k| m.positions[t[k] as usize]);
            (b - a).cross(c - a).dot(a + b + c) > 0.0
        })
    }

    #[test]
    fn vertex_counts_follow_euler() {
        // Closed mesh: V' = V + E, F' = 4F, E' = 2E + 3F.
        let (mut v, mut e, mut f) = (4usize, 6usize, 4usize);
        for levels in 0..4 {
            let m = loop_subdivide(&tetrahedron(), levels).unwrap();
            assert_eq!(m.positions.len(), v, "level {levels}");
            assert_eq!(m.triangle_count(), f);
            (v, e, f) = (v + e, 2 * e + 3 * f, 4 * f);
        }
    }

    #[test]
    fn limit_points_lie_in_the_convex_hull() {
        let t = tetrahedron();
        let m = loop_subdivide(&t, 3).unwrap();
        // The tetrahedron's hull: |x|+… planes; every face plane has the opposite vertex on its inner side.
        for tri in t.indices.chunks_exact(3) {
            let [a, b, c] = [0, 1, 2].map(|k| t.positions[tri[k] as usize]);
            let n = (b - a).cross(c - a);
            for p in &m.positions {
                assert!(n.dot(*p - a) <= 1e-5, "{p} outside face");
            }
        }
        assert!(outward(&m));
        // Limit normals point outward and are unit.
        for (p, n) in m.positions.iter().zip(m.normals.as_ref().unwrap()) {
            assert!((n.length() - 1.0).abs() < 1e-4 && n.dot(*p) > 0.0);
        }
    }

    #[test]
    fn octahedron_becomes_round() {
        // Loop's limit surface of an octahedron is a smooth, nearly round blob: every level's limit points lie on
        // it, so the spread of their radii stays small, and the limit normals are nearly radial.
        let mut sds = Vec::new();
        for levels in 0..5 {
            let m = loop_subdivide(&octahedron(), levels).unwrap();
            let r: Vec<f32> = m.positions.iter().map(|p| p.length()).collect();
            let mean = r.iter().sum::<f32>() / r.len() as f32;
            let rel_sd = (r.iter().map(|x| (x - mean).powi(2)).sum::<f32>() / r.len() as f32).sqrt() / mean;
            sds.push(rel_sd);
            for (p, n) in m.positions.iter().zip(m.normals.as_ref().unwrap()) {
                assert!(n.dot(p.normalize()) > 0.95, "level {levels}: {n} at {p}");
            }
        }
        // The control mesh (radius 1 at vertices, 1/√3 at face centres) is far less round than the limit surface.
        let control_sd = {
            let r = [1.0f32, 1.0 / 3f32.sqrt()];
            let mean = (r[0] + r[1]) / 2.0;
            (r[1] - mean).abs() / mean
        };
        // Level 0 has only the six symmetric vertices (spread 0); from level 1 on the spread shrinks with levels as
        // the samples cover the surface more evenly, far below the control mesh's.
        for w in sds[1..].windows(2) {
            assert!(w[1] < w[0], "{sds:?}");
        }
        assert!(sds.iter().all(|&sd| sd < 0.08 && sd < control_sd / 3.0), "{sds:?} vs {control_sd}");
    }

    #[test]
    fn open_mesh_keeps_its_boundary_and_corners() {
        // A square of two triangles: all vertices are corners of valence 2/3 on the boundary.
        let quad = MeshData {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
            indices: vec![0, 1, 2, 0, 2, 3],
            ..Default::default()
        };
        let m = loop_subdivide(&quad, 2).unwrap();
        assert_eq!(m.triangle_count(), 32);
        for (p, n) in m.positions.iter().zip(m.normals.as_ref().unwrap()) {
            assert!(p.z.abs() < 1e-6 && p.x >= -1e-6 && p.x <= 1.0 + 1e-6);
            assert!((n.z - 1.0).abs() < 1e-4, "{n}");
        }
        let bad = MeshData { indices: vec![0, 1, 9], ..quad };
        assert!(loop_subdivide(&bad, 1).is_err());
    }

    #[test]
    fn a_flat_open_mesh_anywhere_has_the_plane_normal_everywhere() {
        // A 4×3 grid of squares in the plane z = 7, away from the origin: every tangent mask (interior, and boundary
        // of every valence) gives vectors in the plane, so every limit normal is +z. A mask whose weights do not sum
        // to zero adds a multiple of the vertex's position, which leaves the plane unless the plane holds the origin.
        let offset = Vec3::new(40.0, -25.0, 7.0);
        let (nx, ny) = (4u32, 3u32);
        let positions =
            (0..=ny).flat_map(|j| (0..=nx).map(move |i| offset + Vec3::new(i as f32, j as f32, 0.0))).collect();
        let at = |i: u32, j: u32| j * (nx + 1) + i;
        let indices = (0..ny)
            .flat_map(|j| {
                (0..nx).flat_map(move |i| {
                    [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j), at(i + 1, j + 1), at(i, j + 1)]
                })
            })
            .collect();
        let grid = MeshData { positions, indices, ..Default::default() };
        for levels in 1..4 {
            let m = loop_subdivide(&grid, levels).unwrap();
            for (p, n) in m.positions.iter().zip(m.normals.as_ref().unwrap()) {
                assert!((p.z - 7.0).abs() < 1e-4, "level {levels}: {p}");
                assert!((n.z - 1.0).abs() < 1e-5, "level {levels}: normal {n} at {p}");
            }
        }
    }
}

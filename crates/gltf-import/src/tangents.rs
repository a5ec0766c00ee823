//! Shading tangents for normal maps and anisotropy, per face corner: glTF's `TANGENT`s where a primitive has them,
//! else MikkTSpace's (glTF 2.0 §3.7.2.1: the default when tangents are not given), computed by the
//! `bevy_mikktspace` crate (Bevy's port of Mikkelsen's reference implementation).

use glam::{Vec2, Vec3};

/// Whether material `m` reads a tangent frame: a normal texture, a clear coat's normal texture or anisotropy.
pub(crate) fn material_needs_tangents(m: &gltf::Material<'_>) -> bool {
    let ext = m.extensions();
    let has = |name: &str| ext.is_some_and(|e| e.contains_key(name));
    let coat_normal =
        ext.and_then(|e| e.get("KHR_materials_clearcoat")).is_some_and(|c| c.get("clearcoatNormalTexture").is_some());
    m.normal_texture().is_some() || has("KHR_materials_anisotropy") || coat_normal
}

/// Per-vertex tangents (the xyz of glTF's `TANGENT`) given to the corners of triangles `indices`.
pub(crate) fn from_vertices(tangents: &[[f32; 4]], indices: &[u32]) -> Vec<[f32; 3]> {
    indices.iter().map(|&i| tangents.get(i as usize).map_or([0.0; 3], |t| [t[0], t[1], t[2]])).collect()
}

/// MikkTSpace tangents of triangles `indices` over `positions`, unit `normals` and `uvs` (indices checked to be in
/// range), per corner; a corner MikkTSpace gives none (a degenerate triangle) gets zero, for which the renderer
/// falls back to ∂p/∂u. `None` if the algorithm fails.
pub(crate) fn mikktspace(positions: &[Vec3], normals: &[Vec3], uvs: &[Vec2], indices: &[u32]) -> Option<Vec<[f32; 3]>> {
    struct Triangles<'a> {
        positions: &'a [Vec3],
        normals: &'a [Vec3],
        uvs: &'a [Vec2],
        indices: &'a [u32],
        out: Vec<[f32; 3]>,
    }
    impl Triangles<'_> {
        fn vertex(&self, face: usize, vert: usize) -> usize {
            self.indices[3 * face + vert] as usize
        }
    }
    impl bevy_mikktspace::Geometry for Triangles<'_> {
        fn num_faces(&self) -> usize {
            self.indices.len() / 3
        }
        fn num_vertices_of_face(&self, _face: usize) -> usize {
            3
        }
        fn position(&self, face: usize, vert: usize) -> [f32; 3] {
            self.positions[self.vertex(face, vert)].to_array()
        }
        fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
            self.normals[self.vertex(face, vert)].to_array()
        }
        fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
            self.uvs[self.vertex(face, vert)].to_array()
        }
        fn set_tangent(&mut self, tangent: Option<bevy_mikktspace::TangentSpace>, face: usize, vert: usize) {
            if let Some(t) = tangent {
                self.out[3 * face + vert] = t.tangent();
            }
        }
    }
    let mut triangles = Triangles { positions, normals, uvs, indices, out: vec![[0.0; 3]; indices.len()] };
    bevy_mikktspace::generate_tangents(&mut triangles).ok()?;
    Some(triangles.out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A flat quad whose texture coordinates are affine: every corner's tangent is ∂p/∂u's direction, +x.
    #[test]
    fn an_affine_quad_has_its_du_direction_as_tangent() {
        let positions =
            [Vec3::new(0.0, 0.0, 0.0), Vec3::new(2.0, 0.0, 0.0), Vec3::new(2.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
        let normals = [Vec3::Z; 4];
        let uvs = [Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)];
        let t = mikktspace(&positions, &normals, &uvs, &[0, 1, 2, 0, 2, 3]).unwrap();
        for c in &t {
            assert!((Vec3::from_array(*c) - Vec3::X).length() < 1e-5, "{c:?}");
        }
    }

    /// A quad whose two triangles map v differently (the texture sheared in one of them): each triangle's ∂p/∂u
    /// points elsewhere, but MikkTSpace gives the two corners of each diagonal vertex one tangent, their average
    /// direction, so that the shading frame is continuous across the diagonal.
    #[test]
    fn tangents_are_shared_across_an_edge() {
        let positions =
            [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
        let normals = [Vec3::Z; 4];
        let uvs = [Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.5), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)];
        let indices = [0, 1, 2, 0, 2, 3];
        let t = mikktspace(&positions, &normals, &uvs, &indices).unwrap();
        // Per-triangle ∂p/∂u (the derivative of p with u at fixed v).
        let dpdu = |tri: [usize; 3]| {
            let (p, uv) = (tri.map(|i| positions[i]), tri.map(|i| uvs[i]));
            let (d1, d2, e1, e2) = (p[1] - p[0], p[2] - p[0], uv[1] - uv[0], uv[2] - uv[0]);
            let det = e1.x * e2.y - e1.y * e2.x;
            ((d1 * e2.y - d2 * e1.y) / det).normalize()
        };
        let (a, b) = (dpdu([0, 1, 2]), dpdu([0, 2, 3]));
        assert!(a.dot(b) < 0.99, "the triangles' ∂p/∂u differ: {a} {b}");
        // Vertex 0 is corner 0 of both triangles, vertex 2 corner 2 of the first and 1 of the second.
        for (i, j) in [(0, 3), (2, 4)] {
            let (ti, tj) = (Vec3::from_array(t[i]), Vec3::from_array(t[j]));
            assert!((ti - tj).length() < 1e-5, "corners {i} and {j} of one vertex: {ti} {tj}");
            assert!(ti.dot(a) > 0.0 && ti.dot(b) > 0.0 && (ti - a).length() > 1e-3, "{ti} between {a} and {b}");
        }
    }
}

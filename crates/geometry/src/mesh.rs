//! Indexed meshes: object-space [`IndexedMeshData`] as a scene file gives it, and [`IndexedMesh`], its vertices in
//! render space.
//! Both are generic over the vertices per face, `N`: triangle meshes ([`TriangleMesh`], `N = 3`) and bilinear
//! patch meshes ([`crate::BilinearMesh`], `N = 4`) share the validation and the transform to render space.

use glam::{Vec2, Vec3};

use crate::bounds::Bounds3;
use crate::error::GeometryError;
use crate::transform::Transform;

/// Object-space mesh data, as a scene file gives it: positions, optional per-vertex normals and uvs, and `N` `u32`
/// vertex indices per face. Used as [`MeshData`] (triangles) and [`BilinearMeshData`] (bilinear patches).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct IndexedMeshData<const N: usize> {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Per-vertex shading normals (same length as `positions`), if any.
    pub normals: Option<Vec<Vec3>>,
    /// Per-vertex texture coordinates (same length as `positions`), if any.
    pub uvs: Option<Vec<Vec2>>,
    /// Vertex indices, `N` per face.
    pub indices: Vec<u32>,
}

/// Object-space triangle mesh data: three indices per triangle, counter-clockwise seen from the side the normal
/// points to (as pbrt).
pub type MeshData = IndexedMeshData<3>;

/// Object-space bilinear patch mesh data (pbrt-v4's `bilinearmesh`): four indices per patch in the order
/// `p00 p10 p01 p11`, optional per-vertex uvs and normals.
pub type BilinearMeshData = IndexedMeshData<4>;

/// How error messages name a mesh with `N` vertices per face: bilinear meshes are named, triangle meshes (the
/// common case, whose messages predate bilinear meshes) are not.
fn label<const N: usize>() -> &'static str {
    if N == 4 {
        "bilinear mesh: "
    } else {
        ""
    }
}

impl<const N: usize> IndexedMeshData<N> {
    /// Checks the data: indices a multiple of `N` and in range, optional arrays of the right length, every value
    /// finite. The error names the first problem found.
    pub fn validate(&self) -> Result<(), GeometryError> {
        let err = |m: String| Err(GeometryError::InvalidMesh(format!("{}{m}", label::<N>())));
        if !self.indices.len().is_multiple_of(N) {
            return err(format!("{} vertex indices is not a multiple of {N}", self.indices.len()));
        }
        let n = self.positions.len();
        if let Some((i, &v)) = self.indices.iter().enumerate().find(|(_, &v)| v as usize >= n) {
            return err(format!("vertex index {v} (entry {i}) is out of range: the mesh has {n} vertices"));
        }
        if let Some(i) = self.positions.iter().position(|p| !p.is_finite()) {
            return err(format!("position {i} is not finite: {:?}", self.positions[i]));
        }
        if let Some(normals) = &self.normals {
            if normals.len() != n {
                return err(format!("{} normals for {n} vertices", normals.len()));
            }
            if let Some(i) = normals.iter().position(|p| !p.is_finite()) {
                return err(format!("normal {i} is not finite: {:?}", normals[i]));
            }
        }
        if let Some(uvs) = &self.uvs {
            if uvs.len() != n {
                return err(format!("{} uvs for {n} vertices", uvs.len()));
            }
            if let Some(i) = uvs.iter().position(|p| !p.is_finite()) {
                return err(format!("uv {i} is not finite: {:?}", uvs[i]));
            }
        }
        Ok(())
    }

    /// Number of faces.
    pub fn face_count(&self) -> usize {
        self.indices.len() / N
    }
}

impl IndexedMeshData<3> {
    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.face_count()
    }
}

impl IndexedMeshData<4> {
    /// Number of patches.
    pub fn patch_count(&self) -> usize {
        self.face_count()
    }
}

/// A mesh with its vertices in render space and `N` vertex indices per face: used as [`TriangleMesh`] and
/// [`crate::BilinearMesh`] (pbrt-v4's `TriangleMesh` and `BilinearPatchMesh`).
#[derive(Clone, Debug, PartialEq)]
pub struct IndexedMesh<const N: usize> {
    positions: Vec<Vec3>,
    normals: Option<Vec<Vec3>>,
    uvs: Option<Vec<Vec2>>,
    indices: Vec<u32>,
    reverse_orientation: bool,
    transform_swaps_handedness: bool,
    bounds: Bounds3,
    /// Render-space shading tangents per face corner (`N` per face, in the order of `indices`), if any.
    corner_tangents: Option<Vec<Vec3>>,
}

/// A triangle mesh with its vertices in render space (pbrt-v4's `TriangleMesh`).
///
/// The geometric normal of triangle `(p0, p1, p2)` is `normalize(cross(p0 − p2, p1 − p2))`, negated when
/// `reverse_orientation() != transform_swaps_handedness()`; if the mesh has per-vertex normals, the geometric normal
/// is instead flipped to the side of the interpolated shading normal (pbrt-v4's convention, which decides the side
/// an area light emits to).
pub type TriangleMesh = IndexedMesh<3>;

impl<const N: usize> IndexedMesh<N> {
    /// Transforms object-space `data` to render space with `render_from_object`. `reverse_orientation` is pbrt's
    /// `ReverseOrientation` state; per-vertex normals are negated when it is set (as pbrt-v4 does), and dropped when
    /// the transform is singular (see [`Transform::is_invertible`]: the geometric normals are used). Errors if the
    /// data is invalid (see [`IndexedMeshData::validate`]) or the transform produces non-finite positions.
    pub fn new(
        render_from_object: &Transform,
        data: IndexedMeshData<N>,
        reverse_orientation: bool,
    ) -> Result<Self, GeometryError> {
        data.validate()?;
        let IndexedMeshData { mut positions, mut normals, uvs, indices } = data;
        if !render_from_object.is_identity() {
            for p in &mut positions {
                *p = render_from_object.point(p.as_dvec3()).as_vec3();
            }
            if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
                return Err(GeometryError::InvalidMesh(format!(
                    "{}position {i} is not finite after the transform: {:?}",
                    label::<N>(),
                    positions[i]
                )));
            }
        }
        if !render_from_object.is_invertible() {
            // A singular transform (an axis scaled to zero) flattens the mesh and has no inverse transpose for
            // normals: pbrt-v4's normals become NaN there and every hit falls back to the geometric normal of the
            // flattened face, which dropping them reproduces.
            normals = None;
        }
        if let Some(ns) = &mut normals {
            for n in ns.iter_mut() {
                let mut m = if render_from_object.is_identity() {
                    *n
                } else {
                    render_from_object.normal(n.as_dvec3()).as_vec3()
                };
                if reverse_orientation {
                    m = -m;
                }
                *n = m.normalize_or_zero();
            }
        }
        let bounds = Bounds3::from_points(indices.iter().map(|&i| positions[i as usize]));
        Ok(Self {
            positions,
            normals,
            uvs,
            indices,
            reverse_orientation,
            transform_swaps_handedness: render_from_object.swaps_handedness(),
            bounds,
            corner_tangents: None,
        })
    }

    /// The mesh with shading tangents per face corner (object space, in the order of the indices; pbrt-v4's `S`
    /// expanded to corners, or glTF's `TANGENT` and MikkTSpace's, which may differ between the faces of a vertex),
    /// taken to render space by `render_from_object` (the transform the mesh was made with). The shading frame's
    /// ∂p/∂u then follows their interpolation instead of the texture coordinates' ∂p/∂u. Errors if there is not one
    /// finite tangent per corner.
    pub fn with_corner_tangents(
        mut self,
        render_from_object: &Transform,
        tangents: &[[f32; 3]],
    ) -> Result<Self, GeometryError> {
        if tangents.len() != self.indices.len() {
            return Err(GeometryError::InvalidMesh(format!(
                "{}{} tangents for {} face corners",
                label::<N>(),
                tangents.len(),
                self.indices.len()
            )));
        }
        let mut out = Vec::with_capacity(tangents.len());
        for (i, t) in tangents.iter().enumerate() {
            let t = Vec3::from_array(*t);
            let t =
                if render_from_object.is_identity() { t } else { render_from_object.vector(t.as_dvec3()).as_vec3() };
            if !t.is_finite() {
                return Err(GeometryError::InvalidMesh(format!("{}tangent {i} is not finite: {t:?}", label::<N>())));
            }
            out.push(t);
        }
        self.corner_tangents = Some(out);
        Ok(self)
    }

    /// Render-space vertex positions.
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    /// Render-space unit shading normals (already negated under `ReverseOrientation`), if any.
    pub fn normals(&self) -> Option<&[Vec3]> {
        self.normals.as_deref()
    }

    /// Per-vertex uvs, if any.
    pub fn uvs(&self) -> Option<&[Vec2]> {
        self.uvs.as_deref()
    }

    /// Vertex indices, `N` per face.
    pub fn indices(&self) -> &[u32] {
        &self.indices
    }

    /// Number of faces.
    pub fn face_count(&self) -> usize {
        self.indices.len() / N
    }

    /// True if pbrt's `ReverseOrientation` was in effect.
    pub fn reverse_orientation(&self) -> bool {
        self.reverse_orientation
    }

    /// True if the render-from-object transform swapped handedness.
    pub fn transform_swaps_handedness(&self) -> bool {
        self.transform_swaps_handedness
    }

    /// True if the geometric normal from the vertex order must be negated (pbrt's
    /// `reverseOrientation ^ transformSwapsHandedness`).
    pub fn flip_normal(&self) -> bool {
        self.reverse_orientation ^ self.transform_swaps_handedness
    }

    /// Bounds of all referenced vertices (a triangle or a bilinear patch lies in the convex hull of its corners).
    pub fn bounds(&self) -> Bounds3 {
        self.bounds
    }

    /// The vertex indices of face `k`. Panics if `k >= face_count()` (an internal index, never user data).
    #[inline]
    pub fn face(&self, k: usize) -> [u32; N] {
        let i = N * k;
        std::array::from_fn(|j| self.indices[i + j])
    }

    /// The `N` render-space vertices of face `k`.
    #[inline]
    pub fn face_positions(&self, k: usize) -> [Vec3; N] {
        self.face(k).map(|i| self.positions[i as usize])
    }
}

impl IndexedMesh<3> {
    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.face_count()
    }

    /// The vertex indices of triangle `tri`. Panics if `tri >= triangle_count()` (an internal index, never user
    /// data).
    #[inline]
    pub fn triangle(&self, tri: usize) -> [u32; 3] {
        self.face(tri)
    }

    /// The three render-space vertices of triangle `tri`.
    #[inline]
    pub fn triangle_positions(&self, tri: usize) -> [Vec3; 3] {
        self.face_positions(tri)
    }

    /// The uvs of triangle `tri`: the mesh's, or pbrt's default (0,0), (1,0), (1,1).
    #[inline]
    pub fn triangle_uvs(&self, tri: usize) -> [Vec2; 3] {
        match &self.uvs {
            Some(uv) => {
                let [a, b, c] = self.triangle(tri);
                [uv[a as usize], uv[b as usize], uv[c as usize]]
            }
            None => [Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0)],
        }
    }

    /// The shading tangents at the corners of triangle `tri`, if the mesh has them.
    pub fn triangle_tangents(&self, tri: usize) -> Option<[Vec3; 3]> {
        let t = self.corner_tangents.as_ref()?;
        let i = 3 * tri;
        Some([t[i], t[i + 1], t[i + 2]])
    }

    /// The shading normals at the vertices of triangle `tri`, if the mesh has normals.
    #[inline]
    pub fn triangle_normals(&self, tri: usize) -> Option<[Vec3; 3]> {
        let n = self.normals.as_ref()?;
        let [a, b, c] = self.triangle(tri);
        Some([n[a as usize], n[b as usize], n[c as usize]])
    }

    /// Area of triangle `tri`.
    pub fn triangle_area(&self, tri: usize) -> f32 {
        let [p0, p1, p2] = self.triangle_positions(tri);
        0.5 * (p1 - p0).cross(p2 - p0).length()
    }

    /// Total surface area.
    pub fn area(&self) -> f64 {
        (0..self.triangle_count()).map(|t| self.triangle_area(t) as f64).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn quad() -> MeshData {
        MeshData {
            positions: vec![
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::new(0.0, 1.0, 0.0),
            ],
            normals: None,
            uvs: None,
            indices: vec![0, 1, 2, 0, 2, 3],
        }
    }

    #[test]
    fn validation_names_the_problem() {
        let mut m = quad();
        m.indices.push(1);
        let e = m.validate().unwrap_err().to_string();
        assert!(e.ends_with(": 7 vertex indices is not a multiple of 3"), "{e}");
        let mut m = quad();
        m.indices[4] = 9;
        let e = m.validate().unwrap_err().to_string();
        assert!(e.contains("out of range"), "{e}");
        let mut m = quad();
        m.positions[2].x = f32::NAN;
        assert!(m.validate().unwrap_err().to_string().contains("not finite"));
        let mut m = quad();
        m.uvs = Some(vec![Vec2::ZERO; 3]);
        assert!(m.validate().unwrap_err().to_string().contains("3 uvs for 4 vertices"));
    }

    #[test]
    fn transform_and_handedness() {
        let t = Transform::scale(DVec3::new(-2.0, 1.0, 1.0)).unwrap();
        let m = TriangleMesh::new(&t, quad(), false).unwrap();
        assert_eq!(m.positions()[1], Vec3::new(-2.0, 0.0, 0.0));
        assert!(m.transform_swaps_handedness() && m.flip_normal());
        assert!((m.area() - 2.0).abs() < 1e-6);
        let m = TriangleMesh::new(&t, quad(), true).unwrap();
        assert!(!m.flip_normal());
    }

    #[test]
    fn bilinear_validation_names_the_problem() {
        let b = BilinearMeshData {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)],
            indices: vec![0, 1, 2, 3],
            ..Default::default()
        };
        assert!(b.validate().is_ok() && b.patch_count() == 1);
        let e = BilinearMeshData { indices: vec![0, 1, 2], ..b.clone() }.validate().unwrap_err().to_string();
        assert!(e.contains("bilinear mesh: 3 vertex indices is not a multiple of 4"), "{e}");
        let e = BilinearMeshData { indices: vec![0, 1, 2, 4], ..b.clone() }.validate().unwrap_err().to_string();
        assert!(e.contains("out of range"), "{e}");
        let e = BilinearMeshData { uvs: Some(vec![Vec2::ZERO; 3]), ..b.clone() }.validate().unwrap_err().to_string();
        assert!(e.contains("3 uvs for 4 vertices"), "{e}");
        let e = BilinearMeshData { normals: Some(vec![Vec3::Z; 5]), ..b }.validate().unwrap_err().to_string();
        assert!(e.contains("5 normals for 4 vertices"), "{e}");
    }
}

//! PLY loading (ASCII, binary little and big endian) into object-space [`MeshData`].
//!
//! Reads the `vertex` element's `x y z`, optional `nx ny nz` and optional texture coordinates (`u v`, `s t`,
//! `texture_u texture_v` or `texture_s texture_t`), and the `face` element's `vertex_indices` (or `vertex_index`)
//! lists of any integer type. Triangles are kept; quads are split into two triangles `(0 1 2)` and `(0 2 3)`;
//! larger polygons are fan-triangulated. Other elements and properties are skipped.

use std::io::{BufReader, Read};
use std::path::Path;

use glam::{Vec2, Vec3};
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{
    ElementDef, Encoding, Header, Property, PropertyAccess, PropertyAccessResult, PropertyType, ScalarType,
};

use crate::error::GeometryError;
use crate::mesh::MeshData;

#[derive(Default)]
struct PlyVertex {
    p: [f32; 3],
    n: [f32; 3],
    uv: [f32; 2],
    /// Bits: 1..4 position x y z, 8..64 normal x y z, 128/256 u v.
    seen: u16,
}

impl PropertyAccess for PlyVertex {
    fn new() -> Self {
        Self::default()
    }

    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        let Some(v) = property.to_f32_lossy() else {
            return PropertyAccessResult::Ignored;
        };
        let (slot, bit): (&mut f32, u16) = match name {
            "x" => (&mut self.p[0], 1),
            "y" => (&mut self.p[1], 2),
            "z" => (&mut self.p[2], 4),
            "nx" => (&mut self.n[0], 8),
            "ny" => (&mut self.n[1], 16),
            "nz" => (&mut self.n[2], 32),
            "u" | "s" | "texture_u" | "texture_s" => (&mut self.uv[0], 128),
            "v" | "t" | "texture_v" | "texture_t" => (&mut self.uv[1], 256),
            _ => return PropertyAccessResult::Ignored,
        };
        *slot = v;
        self.seen |= bit;
        PropertyAccessResult::Set
    }
}

#[derive(Default)]
struct PlyFace {
    indices: Vec<i64>,
    bad: bool,
}

impl PropertyAccess for PlyFace {
    fn new() -> Self {
        Self::default()
    }

    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        if name != "vertex_indices" && name != "vertex_index" {
            return PropertyAccessResult::Ignored;
        }
        self.indices = match property {
            Property::ListChar(v) => v.into_iter().map(i64::from).collect(),
            Property::ListUChar(v) => v.into_iter().map(i64::from).collect(),
            Property::ListShort(v) => v.into_iter().map(i64::from).collect(),
            Property::ListUShort(v) => v.into_iter().map(i64::from).collect(),
            Property::ListInt(v) => v.into_iter().map(i64::from).collect(),
            Property::ListUInt(v) => v.into_iter().map(i64::from).collect(),
            // Scalars and float lists are not vertex indices.
            Property::Char(_)
            | Property::UChar(_)
            | Property::Short(_)
            | Property::UShort(_)
            | Property::Int(_)
            | Property::UInt(_)
            | Property::Float(_)
            | Property::Double(_)
            | Property::ListFloat(_)
            | Property::ListDouble(_) => {
                self.bad = true;
                Vec::new()
            }
        };
        PropertyAccessResult::Set
    }
}

/// An element we do not use; its payload is read and dropped.
struct Skip;

impl PropertyAccess for Skip {
    fn new() -> Self {
        Skip
    }
}

/// Loads a PLY file into object-space mesh data. Errors name the file and the problem (unreadable file, missing
/// `vertex` or `face` element, missing `x`/`y`/`z`, non-integer face lists, faces with fewer than 3 vertices,
/// indices out of range).
/// A gzip-compressed file (`.ply.gz`, which pbrt-v4 reads) is recognised by its magic bytes and decompressed
/// first ([`crate::gzip`]).
pub fn read_ply_file(path: &Path) -> Result<MeshData, GeometryError> {
    let bytes = crate::gzip::read_maybe_gzip(path)
        .map_err(|message| GeometryError::Ply { path: path.display().to_string(), message })?;
    read_ply(&mut bytes.as_slice(), &path.display().to_string())
}

/// Loads PLY data from a reader; `name` is used in error messages.
///
/// The element counts of the header are checked against the bytes present before any element is read: every item
/// takes at least one byte per property in ASCII (a digit or a separator, two in fact) and its properties' sizes in
/// binary, so a short file cannot claim billions of items (and elements without properties, which would take no
/// bytes at all, are refused).
pub fn read_ply<R: Read>(source: &mut R, name: &str) -> Result<MeshData, GeometryError> {
    let err = |message: String| GeometryError::Ply { path: name.to_string(), message };
    let mut bytes = Vec::new();
    source.read_to_end(&mut bytes).map_err(|e| err(format!("cannot read: {e}")))?;
    let mut reader = Reader::new(BufReader::new(bytes.as_slice()));
    let header = Parser::<Skip>::new().read_header(&mut reader).map_err(|e| err(format!("bad header: {e}")))?;
    check_counts(&header, bytes.len()).map_err(err)?;
    let mut verts: Option<Vec<PlyVertex>> = None;
    let mut faces: Option<Vec<PlyFace>> = None;
    for (ename, element) in &header.elements {
        match ename.as_str() {
            "vertex" => {
                let v = Parser::<PlyVertex>::new()
                    .read_payload_for_element(&mut reader, element, &header)
                    .map_err(|e| err(format!("reading vertices: {e}")))?;
                verts = Some(v);
            }
            "face" => {
                let f = Parser::<PlyFace>::new()
                    .read_payload_for_element(&mut reader, element, &header)
                    .map_err(|e| err(format!("reading faces: {e}")))?;
                faces = Some(f);
            }
            _ => {
                Parser::<Skip>::new()
                    .read_payload_for_element(&mut reader, element, &header)
                    .map_err(|e| err(format!("reading element '{ename}': {e}")))?;
            }
        }
    }
    let verts = verts.ok_or_else(|| err("no 'vertex' element".into()))?;
    let faces = faces.ok_or_else(|| err("no 'face' element".into()))?;
    let all = verts.iter().fold(u16::MAX, |a, v| a & v.seen);
    if all & 7 != 7 {
        return Err(err("vertices lack x, y or z".into()));
    }
    let positions: Vec<Vec3> = verts.iter().map(|v| Vec3::from(v.p)).collect();
    let normals = (all & 56 == 56).then(|| verts.iter().map(|v| Vec3::from(v.n)).collect());
    let uvs = (all & 384 == 384).then(|| verts.iter().map(|v| Vec2::from(v.uv)).collect());
    let n = positions.len() as i64;
    let mut indices = Vec::with_capacity(faces.len() * 3);
    for (fi, f) in faces.iter().enumerate() {
        if f.bad {
            return Err(err(format!("face {fi}: vertex_indices is not a list of integers")));
        }
        if f.indices.len() < 3 {
            return Err(err(format!("face {fi} has {} vertices (at least 3 needed)", f.indices.len())));
        }
        if let Some(&bad) = f.indices.iter().find(|&&i| i < 0 || i >= n) {
            return Err(err(format!("face {fi}: vertex index {bad} is out of range (the file has {n} vertices)")));
        }
        for k in 1..f.indices.len() - 1 {
            indices.extend([f.indices[0] as u32, f.indices[k] as u32, f.indices[k + 1] as u32]);
        }
    }
    let data = MeshData { positions, normals, uvs, indices };
    data.validate().map_err(|e| err(e.to_string()))?;
    Ok(data)
}

/// The least number of bytes one item of `element` takes in a file of `encoding`.
fn min_item_bytes(element: &ElementDef, encoding: Encoding) -> usize {
    let size = |t: &ScalarType| match t {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    };
    element
        .properties
        .values()
        .map(|p| match (encoding, &p.data_type) {
            // A value and the space or newline after it (a list: its count, possibly 0).
            (Encoding::Ascii, _) => 2,
            (_, PropertyType::Scalar(t)) => size(t),
            // The count; an empty list has no items.
            (_, PropertyType::List(count, _)) => size(count),
        })
        .sum()
}

/// Refuses element counts the file cannot hold (`len` bytes in all), before anything is allocated for them.
fn check_counts(header: &Header, len: usize) -> Result<(), String> {
    for (ename, element) in &header.elements {
        if element.count == 0 {
            continue;
        }
        let each = min_item_bytes(element, header.encoding);
        if each == 0 {
            return Err(format!("element '{ename}' has {} items but no properties", element.count));
        }
        if element.count.saturating_mul(each) > len {
            return Err(format!(
                "element '{ename}' claims {} items (at least {each} bytes each) but the file has {len} bytes",
                element.count
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp_path(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("prismatic-geometry-ply-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir.join(name)
    }

    const POS: [[f32; 3]; 5] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.5, 0.5, 1.0]];

    fn expected_indices() -> Vec<u32> {
        // A quad (0 1 2 3) split into (0 1 2) (0 2 3), then a triangle (1 2 4).
        vec![0, 1, 2, 0, 2, 3, 1, 2, 4]
    }

    #[test]
    fn ascii_with_quads_normals_and_uvs() {
        let mut s = String::from(
            "ply\nformat ascii 1.0\ncomment test\nelement vertex 5\nproperty float x\nproperty float y\n\
             property float z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty float u\n\
             property float v\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n",
        );
        for (i, p) in POS.iter().enumerate() {
            s += &format!("{} {} {} 0 0 1 {} {}\n", p[0], p[1], p[2], i as f32 * 0.25, 1.0 - i as f32 * 0.25);
        }
        s += "4 0 1 2 3\n3 1 2 4\n";
        let path = temp_path("ascii.ply");
        std::fs::write(&path, s).unwrap();
        let m = read_ply_file(&path).unwrap();
        assert_eq!(m.positions, POS.map(Vec3::from).to_vec());
        assert_eq!(m.indices, expected_indices());
        assert_eq!(m.normals.as_ref().unwrap()[3], Vec3::Z);
        assert_eq!(m.uvs.as_ref().unwrap()[2], Vec2::new(0.5, 0.5));
    }

    fn binary(big_endian: bool, index_name: &str, st: bool) -> Vec<u8> {
        let fmt = if big_endian { "binary_big_endian" } else { "binary_little_endian" };
        let (u, v) = if st { ("s", "t") } else { ("texture_u", "texture_v") };
        let mut out = format!(
            "ply\nformat {fmt} 1.0\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\n\
             property float {u}\nproperty float {v}\nelement face 2\nproperty list uint8 uint32 {index_name}\n\
             element extra 1\nproperty int junk\nend_header\n"
        )
        .into_bytes();
        let f = |x: f32| if big_endian { x.to_be_bytes() } else { x.to_le_bytes() };
        let i = |x: u32| if big_endian { x.to_be_bytes() } else { x.to_le_bytes() };
        for (k, p) in POS.iter().enumerate() {
            for c in p {
                out.extend(f(*c));
            }
            out.extend(f(k as f32));
            out.extend(f(-(k as f32)));
        }
        out.push(4);
        for x in [0, 1, 2, 3] {
            out.extend(i(x));
        }
        out.push(3);
        for x in [1, 2, 4] {
            out.extend(i(x));
        }
        out.extend(i(77));
        out
    }

    #[test]
    fn binary_both_endians() {
        for (be, name, st) in [(false, "vertex_indices", false), (true, "vertex_index", true)] {
            let path = temp_path(&format!("bin-{be}.ply"));
            std::fs::write(&path, binary(be, name, st)).unwrap();
            let m = read_ply_file(&path).unwrap();
            assert_eq!(m.positions, POS.map(Vec3::from).to_vec(), "big endian: {be}");
            assert_eq!(m.indices, expected_indices());
            assert!(m.normals.is_none());
            assert_eq!(m.uvs.as_ref().unwrap()[3], Vec2::new(3.0, -3.0));
        }
    }

    #[test]
    fn gzip_compressed_files_by_magic_bytes() {
        use std::io::Write;
        let plain = binary(false, "vertex_indices", false);
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        e.write_all(&plain).unwrap();
        let z = e.finish().unwrap();
        // Detected by content: the same result under a .gz name and under a misleading .ply name.
        for name in ["mesh.ply.gz", "misnamed.ply"] {
            let path = temp_path(name);
            std::fs::write(&path, &z).unwrap();
            let m = read_ply_file(&path).unwrap();
            assert_eq!(m.positions, POS.map(Vec3::from).to_vec(), "{name}");
            assert_eq!(m.indices, expected_indices(), "{name}");
            assert_eq!(m.uvs.as_ref().unwrap()[3], Vec2::new(3.0, -3.0), "{name}");
        }
        // Truncated: an error naming the file, not a panic.
        let path = temp_path("cut.ply.gz");
        std::fs::write(&path, &z[..z.len() / 2]).unwrap();
        let e = read_ply_file(&path).unwrap_err().to_string();
        assert!(e.contains("cut.ply.gz") && e.contains("corrupt or truncated gzip"), "{e}");
    }

    /// Headers that claim more items than the file holds: found by review while fuzzing (docs/robustness.md);
    /// before the check, the first ran out of memory and the second looped for ever.
    #[test]
    fn counts_beyond_the_bytes_present_are_refused_before_reading() {
        let cases: [(&[u8], &str); 4] = [
            // 4·10⁹ vertices without properties: each took no bytes, so they were created until memory ran out.
            (
                b"ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nelement face 0\nend_header\n",
                "no properties",
            ),
            // An element of 2⁶⁴ − 1 property-less items: read (and dropped) for ever.
            (
                b"ply\nformat binary_little_endian 1.0\nelement junk 18446744073709551615\nelement vertex 0\n\
                  property float x\nelement face 0\nend_header\n",
                "no properties",
            ),
            // 10⁹ binary vertices of 12 bytes in a file of about 120 bytes.
            (
                b"ply\nformat binary_big_endian 1.0\nelement vertex 1000000000\nproperty float x\nproperty float y\n\
                  property float z\nelement face 0\nend_header\n\0\0\0\0",
                "claims 1000000000 items (at least 12 bytes each)",
            ),
            // ASCII: two bytes per value at least.
            (
                b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
                  element face 100\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
                "element 'face' claims 100 items",
            ),
        ];
        for (bytes, expected) in cases {
            let e = read_ply(&mut &bytes[..], "mem").unwrap_err().to_string();
            assert!(e.contains(expected), "{e}");
        }
        // The smallest ASCII file the bound allows is read: 3 vertices of 3 one-digit values and one triangle.
        let s = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
                  element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2";
        let m = read_ply(&mut &s[..], "mem").unwrap();
        assert_eq!(m.indices, [0, 1, 2]);
        assert_eq!(m.positions[1], Vec3::X);
    }

    #[test]
    fn errors_name_the_problem() {
        let e = read_ply_file(Path::new("/nonexistent/x.ply")).unwrap_err().to_string();
        assert!(e.contains("/nonexistent/x.ply"), "{e}");
        let s = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
                 element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n";
        let e = read_ply(&mut s.as_bytes(), "mem").unwrap_err().to_string();
        assert!(e.contains("out of range"), "{e}");
        let e = read_ply(&mut "not a ply".as_bytes(), "mem").unwrap_err().to_string();
        assert!(e.contains("header"), "{e}");
    }
}

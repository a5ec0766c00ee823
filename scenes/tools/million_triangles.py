"""Writes the same mesh of about a million triangles (a 708×708 grid of quads, two triangles each, bent into a
wave) as a glTF binary (.glb) and as a binary PLY, each with a pbrt-v4 scene that renders it, for BENCHMARKS.md's
load-time comparison; and the mesh with normals, texture coordinates and a normal texture (million-normal-mapped.glb),
whose tangents the reader computes with MikkTSpace. Nothing is committed: the files are 25–35 MB.

    python3 scenes/tools/million_triangles.py OUTDIR
    /usr/bin/time -v prismatic render OUTDIR/million-gltf.pbrt --spp 1 --resolution 64x64 -o /tmp/m.exr
    /usr/bin/time -v prismatic render OUTDIR/million-ply.pbrt  --spp 1 --resolution 64x64 -o /tmp/m.exr
    /usr/bin/time -v prismatic render OUTDIR/million-normal-mapped.glb --spp 1 --resolution 64x64 -o /tmp/m.exr
"""

import base64
import json
import os
import struct
import sys
import zlib

import numpy as np

N = 708  # quads per side: 2·708² = 1,002,528 triangles


def mesh():
    u = np.linspace(-1.0, 1.0, N + 1, dtype=np.float32)
    x, z = np.meshgrid(u, u)
    y = 0.1 * np.sin(6.0 * x) * np.cos(6.0 * z)
    positions = np.stack([x, y, z], axis=-1).reshape(-1, 3).astype(np.float32)
    i = np.arange(N, dtype=np.uint32)
    a = (i[:, None] * (N + 1) + i[None, :]).reshape(-1)
    b, c, d = a + 1, a + (N + 1), a + (N + 2)
    indices = np.stack([a, c, b, b, c, d], axis=-1).reshape(-1).astype(np.uint32)
    return positions, indices


def one_texel_png(rgb):
    """A 1×1 RGB PNG of the 8-bit colour `rgb`."""
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    header = struct.pack(">IIBBBBB", 1, 1, 8, 2, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(b"\0" + bytes(rgb)))
            + chunk(b"IEND", b""))


def write_glb(path, positions, indices, normal_mapped=False):
    """The mesh as a GLB; `normal_mapped` adds normals (+y), texture coordinates (x, z over [0, 1]) and a material
    with a one-texel normal texture."""
    arrays = [positions, indices]
    if normal_mapped:
        normals = np.zeros_like(positions)
        normals[:, 1] = 1.0
        uvs = ((positions[:, [0, 2]] + 1.0) / 2.0).astype(np.float32)
        arrays += [normals, uvs]
    blobs = [a.tobytes() for a in arrays]
    offsets = np.cumsum([0] + [len(b) for b in blobs]).tolist()
    doc = {
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": offsets[-1]}],
        "bufferViews": [{"buffer": 0, "byteOffset": offsets[i], "byteLength": len(b)} for i, b in enumerate(blobs)],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": len(positions), "type": "VEC3",
             "min": positions.min(axis=0).tolist(), "max": positions.max(axis=0).tolist()},
            {"bufferView": 1, "componentType": 5125, "count": len(indices), "type": "SCALAR"},
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}], "scene": 0,
    }
    if normal_mapped:
        doc["accessors"] += [{"bufferView": 2, "componentType": 5126, "count": len(positions), "type": "VEC3"},
                             {"bufferView": 3, "componentType": 5126, "count": len(positions), "type": "VEC2"}]
        primitive = doc["meshes"][0]["primitives"][0]
        primitive["attributes"].update({"NORMAL": 2, "TEXCOORD_0": 3})
        primitive["material"] = 0
        png = base64.b64encode(one_texel_png((150, 128, 230))).decode()
        doc.update({"materials": [{"normalTexture": {"index": 0}}], "textures": [{"source": 0}],
                    "images": [{"uri": "data:image/png;base64," + png}]})
    js = json.dumps(doc).encode()
    js += b" " * (-len(js) % 4)
    binary = b"".join(blobs)
    binary += b"\0" * (-len(binary) % 4)
    total = 12 + 8 + len(js) + 8 + len(binary)
    with open(path, "wb") as f:
        f.write(struct.pack("<4sII", b"glTF", 2, total))
        f.write(struct.pack("<I4s", len(js), b"JSON") + js)
        f.write(struct.pack("<I4s", len(binary), b"BIN\0") + binary)


def write_ply(path, positions, indices):
    faces = indices.reshape(-1, 3)
    header = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(positions)}\n"
              "property float x\nproperty float y\nproperty float z\n"
              f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n").encode()
    records = np.zeros(len(faces), dtype=[("n", "u1"), ("v", "<i4", 3)])
    records["n"], records["v"] = 3, faces
    with open(path, "wb") as f:
        f.write(header + positions.astype("<f4").tobytes() + records.tobytes())


def scene(shape):
    return ("LookAt 0 2.5 -2.5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 40\n"
            "Film \"rgb\" \"integer xresolution\" 64 \"integer yresolution\" 64\nWorldBegin\n"
            "LightSource \"distant\" \"point3 from\" [ 0 1 0 ] \"point3 to\" [ 0 0 0 ]\n" + shape + "\n")


if __name__ == "__main__":
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    positions, indices = mesh()
    write_glb(os.path.join(out, "million.glb"), positions, indices)
    write_glb(os.path.join(out, "million-normal-mapped.glb"), positions, indices, normal_mapped=True)
    write_ply(os.path.join(out, "million.ply"), positions, indices)
    with open(os.path.join(out, "million-gltf.pbrt"), "w") as f:
        f.write(scene('Import "million.glb"'))
    with open(os.path.join(out, "million-ply.pbrt"), "w") as f:
        f.write(scene('Shape "plymesh" "string filename" "million.ply"'))
    print(f"{len(indices) // 3} triangles in {out}")

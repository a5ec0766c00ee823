"""Writes a glTF binary (.glb) of one quad under a sun with two 4096² JPEG textures, a base colour and a
metallic-roughness map (read as two one-channel textures), for BENCHMARKS.md's texture-memory measurement. Nothing
is committed: the file is about 20 MB. Needs NumPy and Pillow.

    python3 scenes/tools/texture_memory.py OUTDIR
    /usr/bin/time -v prismatic render OUTDIR/textures-4k.glb --spp 1 --resolution 64x64 -o /tmp/t.exr
"""

import io
import json
import os
import struct
import sys

import numpy as np
from PIL import Image

SIDE = 4096


def jpeg(rgb):
    out = io.BytesIO()
    Image.fromarray(rgb, "RGB").save(out, "JPEG", quality=90)
    return out.getvalue()


def main(outdir):
    rng = np.random.default_rng(7)
    # Smooth colour noise (blocks of 4 texels), so that the JPEG is large but not random.
    small = rng.integers(0, 256, size=(SIDE // 4, SIDE // 4, 3), dtype=np.uint8)
    base = jpeg(np.repeat(np.repeat(small, 4, axis=0), 4, axis=1))
    mr = np.zeros((SIDE, SIDE, 3), dtype=np.uint8)
    ramp = np.linspace(0, 255, SIDE, dtype=np.float32)
    mr[:, :, 1] = ramp[None, :].astype(np.uint8)  # roughness in green
    mr[:, :, 2] = ramp[:, None].astype(np.uint8)  # metalness in blue
    metal_rough = jpeg(mr)

    positions = np.array([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], dtype=np.float32)
    uvs = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.float32)
    indices = np.array([0, 2, 1, 0, 3, 2], dtype=np.uint16)
    chunks = [positions.tobytes(), uvs.tobytes(), indices.tobytes(), base, metal_rough]
    views, offset, blob = [], 0, b""
    for c in chunks:
        views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(c)})
        pad = (-len(c)) % 4
        blob += c + b"\0" * pad
        offset += len(c) + pad
    doc = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2]}],
        "nodes": [
            {"mesh": 0},
            {"camera": 0, "translation": [0, 2.5, 0], "rotation": [-0.7071068, 0, 0, 0.7071068]},
            {"extensions": {"KHR_lights_punctual": {"light": 0}}, "rotation": [-0.7071068, 0, 0, 0.7071068]},
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.01}}],
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "directional", "intensity": 1500}]}},
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0},
                                                "metallicRoughnessTexture": {"index": 1}}}],
        "textures": [{"source": 0}, {"source": 1}],
        "images": [{"bufferView": 3, "mimeType": "image/jpeg"}, {"bufferView": 4, "mimeType": "image/jpeg"}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, 0, -1], "max": [1, 0, 1]},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"},
        ],
        "bufferViews": views,
        "buffers": [{"byteLength": len(blob)}],
    }
    js = json.dumps(doc).encode()
    js += b" " * ((-len(js)) % 4)
    glb = struct.pack("<III", 0x46546C67, 2, 12 + 8 + len(js) + 8 + len(blob))
    glb += struct.pack("<II", len(js), 0x4E4F534A) + js + struct.pack("<II", len(blob), 0x004E4942) + blob
    os.makedirs(outdir, exist_ok=True)
    path = os.path.join(outdir, "textures-4k.glb")
    with open(path, "wb") as f:
        f.write(glb)
    print(path, len(glb), "bytes")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else ".")

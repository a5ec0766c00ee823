#!/usr/bin/env python3
"""Writes scenes/meshes/trefoil.ply, the glass object of scenes/purple-glass.pbrt.

A closed, smooth tube around a trefoil knot: the centre line is
    c(t) = s * (sin t + 2 sin 2t,  cos t - 2 cos 2t,  -h sin 3t),   t in [0, 2 pi),
(the knot lies roughly in the xy plane, about 6 s across; h = 1.5 opens the crossings so the tube can be fat)
and the tube has circular cross-sections of radius r,
swept with rotation-minimising (parallel-transport) frames whose residual twist is spread evenly along the loop
so that the last ring meets the first exactly. The surface is a closed, watertight, consistently outward-wound
triangle mesh (quads split into two triangles) with per-vertex normals (the exact tube normals), written as a
binary little-endian PLY with `x y z nx ny nz` and `vertex_indices`.

Usage:  python3 scenes/tools/make_blob.py [output.ply]   (default: scenes/meshes/trefoil.ply next to this script)
Needs Python 3 and numpy.
"""

import os
import sys

import numpy as np

SCALE = 0.36  # s above: the centre line spans about 2.2 units
Z_AMP = 1.5  # h above
RADIUS = 0.23  # tube radius
N_ALONG = 360  # rings along the knot
N_AROUND = 32  # vertices around each ring


def centre(t):
    x = np.sin(t) + 2 * np.sin(2 * t)
    y = np.cos(t) - 2 * np.cos(2 * t)
    z = -Z_AMP * np.sin(3 * t)
    return SCALE * np.stack([x, y, z], axis=-1)


def tangent(t):
    dx = np.cos(t) + 4 * np.cos(2 * t)
    dy = -np.sin(t) + 4 * np.sin(2 * t)
    dz = -3 * Z_AMP * np.cos(3 * t)
    d = np.stack([dx, dy, dz], axis=-1)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def frames(t):
    """Parallel-transport normals along the closed curve, with the closing twist distributed evenly."""
    tan = tangent(t)
    n = len(t)
    normals = np.zeros((n, 3))
    a = np.cross(tan[0], [0.0, 0.0, 1.0])
    normals[0] = a / np.linalg.norm(a)
    for i in range(1, n + 1):
        prev = normals[i - 1]
        ti = tan[i % n]
        v = prev - ti * np.dot(prev, ti)  # project onto the next normal plane (small steps: a good transport)
        v /= np.linalg.norm(v)
        if i < n:
            normals[i] = v
        else:
            closing = v  # where transport brings the first normal after a full loop
    # Angle from normals[0] to the transported one, about tan[0].
    b0 = np.cross(tan[0], normals[0])
    twist = np.arctan2(np.dot(closing, b0), np.dot(closing, normals[0]))
    binormals = np.cross(tan, normals)
    # Undo the twist progressively: rotate frame i by -twist * i / n about its tangent.
    ang = -twist * np.arange(n) / n
    c, s = np.cos(ang)[:, None], np.sin(ang)[:, None]
    nrm = c * normals + s * binormals
    bin_ = np.cross(tan, nrm)
    return nrm, bin_


def min_strand_distance(t, pts):
    """Smallest distance between centre-line points that are far apart along the curve (tube must not touch)."""
    n = len(t)
    d = np.linalg.norm(pts[:, None, :] - pts[None, :, :], axis=-1)
    idx = np.arange(n)
    sep = np.abs(idx[:, None] - idx[None, :])
    sep = np.minimum(sep, n - sep)
    return d[sep > n // 8].min()


def make_mesh():
    t = 2 * np.pi * np.arange(N_ALONG) / N_ALONG
    c = centre(t)
    gap = min_strand_distance(t, c)
    if gap <= 2 * RADIUS * 1.05:
        raise SystemExit(f"tube radius {RADIUS} too large: strands come within {gap:.3f} of each other")
    nrm, bin_ = frames(t)
    phi = 2 * np.pi * np.arange(N_AROUND) / N_AROUND
    # Ring vertex (i, j): c_i + r (cos phi_j N_i + sin phi_j B_i); its outward normal is the unit radial vector.
    radial = np.cos(phi)[None, :, None] * nrm[:, None, :] + np.sin(phi)[None, :, None] * bin_[:, None, :]
    verts = (c[:, None, :] + RADIUS * radial).reshape(-1, 3)
    normals = radial.reshape(-1, 3)
    faces = []
    for i in range(N_ALONG):
        i2 = (i + 1) % N_ALONG
        for j in range(N_AROUND):
            j2 = (j + 1) % N_AROUND
            a, b, cc, d = i * N_AROUND + j, i2 * N_AROUND + j, i2 * N_AROUND + j2, i * N_AROUND + j2
            # (T, N, B) is right-handed and phi runs from N towards B, so T x B = -N: the (around, along) order
            # winds counter-clockwise seen from outside.
            faces.append((a, d, cc))
            faces.append((a, cc, b))
    faces = np.array(faces, dtype=np.int32)
    check_outward(verts, normals, faces)
    check_closed(faces)
    return verts.astype(np.float32), normals.astype(np.float32), faces, gap


def check_outward(verts, normals, faces):
    p = verts[faces]
    fn = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    agree = np.einsum("ij,ij->i", fn, normals[faces].mean(axis=1))
    if not (agree > 0).all():
        raise SystemExit(f"{(agree <= 0).sum()} faces wound inward")


def check_closed(faces):
    """Watertight and consistently wound: every directed edge occurs once and its reverse occurs once."""
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    directed = {tuple(e) for e in edges.tolist()}
    if len(directed) != len(edges) or any((b, a) not in directed for a, b in directed):
        raise SystemExit("mesh is not closed and consistently wound")


def write_ply(path, verts, normals, faces):
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        "comment trefoil-knot glass tube for scenes/purple-glass.pbrt (scenes/tools/make_blob.py)\n"
        f"element vertex {len(verts)}\n"
        "property float x\nproperty float y\nproperty float z\n"
        "property float nx\nproperty float ny\nproperty float nz\n"
        f"element face {len(faces)}\n"
        "property list uchar int vertex_indices\nend_header\n"
    )
    vdata = np.concatenate([verts, normals], axis=1).astype("<f4").tobytes()
    frec = np.zeros(len(faces), dtype=[("n", "u1"), ("i", "<i4", 3)])
    frec["n"] = 3
    frec["i"] = faces
    with open(path, "wb") as f:
        f.write(header.encode("ascii"))
        f.write(vdata)
        f.write(frec.tobytes())


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(here, "..", "meshes", "trefoil.ply")
    out = os.path.normpath(out)
    os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
    verts, normals, faces, gap = make_mesh()
    write_ply(out, verts, normals, faces)
    lo, hi = verts.min(axis=0), verts.max(axis=0)
    print(f"wrote {out}: {len(verts)} vertices, {len(faces)} triangles, bounds {lo.round(3)} .. {hi.round(3)}, "
          f"closest strands {gap:.3f} (tube diameter {2 * RADIUS})")


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Writes scenes/meshes/diamond.ply, a round brilliant-cut diamond for scenes/diamond.pbrt.

The stone is a convex polyhedron with 57 facets plus a thin girdle, built facet by facet from the classic
round-brilliant construction (girdle radius R = 1, table up along +z, girdle centred on z = 0):

  crown    table (an octagon), 8 bezels (main crown facets, kites), 8 stars (triangles on the table edges),
           16 upper girdle facets (triangles down to the girdle);
  girdle   16 narrow vertical facets (a 16-gon in plan whose corners are where the bezels and the upper-girdle
           pairs touch it), GIRDLE thick;
  pavilion 8 pavilion mains (kites down to a pointed culet) and 16 lower girdle facets.

Proportions (Tolkowsky-like, all adjustable below): crown angle 34.5 deg, pavilion angle 40.75 deg, table 55 %
of the diameter (across the flats), star facets 50 % of the way from table to girdle, lower girdle facets 77 % of
the way from girdle to culet. That gives a crown height of about 14 %, a pavilion depth of about 43 % and a total
depth of about 58 % of the diameter.

Construction (azimuths phi_k = 45 k deg for the mains, psi_k = phi_k + 22.5 deg between them):
  T_k  table corners at phi_k on the table plane;
  G_k  girdle points at phi_k (top of the girdle, z = +GIRDLE/2), H_k girdle points at psi_k;
  S_k  star tips at psi_k, on the bezel planes (so two bezels, a star and two upper girdles meet there);
  bezel k = (T_k, S_{k-1}, G_k, S_k) on the plane through G_k tilted by the crown angle (a symmetric kite,
  so its four corners are coplanar by construction); star k = (T_k, T_{k+1}, S_k); upper girdle facets
  (S_k, G_k, H_k) and (S_k, H_k, G_{k+1});
  pavilion: G'_k, H'_k the girdle points at z = -GIRDLE/2, the culet C on the axis, Q_k on the line where
  pavilion mains k and k+1 meet (at psi_k); main k = (C, Q_{k-1}, G'_k, Q_k) (again a symmetric kite), lower
  girdle facets (Q_k, G'_k, H'_k) and (Q_k, H'_k, G'_{k+1}).
Every facet is then checked to be flat, the solid to be convex and closed with every edge shared by exactly two
faces in opposite directions, and each triangle is wound counter-clockwise seen from outside (outward normals).
Polygons are split into triangles (fans); no vertex normals are written, so facets render flat.

Output: binary little-endian PLY (`x y z`, `vertex_indices`) with the 57 shared corners, so the triangle mesh is
closed (every edge between two triangles); with no normals in the file the renderer shades each facet flat.

Usage:  python3 scenes/tools/make_diamond.py [output.ply]   (default: scenes/meshes/diamond.ply)
Needs Python 3 and numpy.
"""

import os
import sys

import numpy as np

R = 1.0  # girdle radius
CROWN_ANGLE = 34.5  # degrees
PAVILION_ANGLE = 40.75  # degrees
TABLE = 0.55  # table width (across the flats of the octagon) / diameter
STAR = 0.50  # star tips: fraction of the way from the table edge out to the girdle
LOWER_GIRDLE = 0.77  # lower girdle facets: fraction of the way from the girdle down to the culet
GIRDLE = 0.02  # girdle thickness (1 % of the diameter: thin)


def polar(r, az_deg, z):
    a = np.radians(az_deg)
    return np.array([r * np.cos(a), r * np.sin(a), z])


def build_facets():
    """List of (name, [vertices...]) with each facet's corners in order around it."""
    tc, tp = np.tan(np.radians(CROWN_ANGLE)), np.tan(np.radians(PAVILION_ANGLE))
    c22 = np.cos(np.radians(22.5))
    zg = GIRDLE / 2
    t_edge = TABLE * R  # table edge midpoint radius (at psi_k)
    t_corner = t_edge / c22  # table corner radius (at phi_k)
    z_table = zg + (R - t_corner) * tc  # the bezel rises tan(crown angle) per unit of radius along phi_k
    r_star = t_edge + STAR * (R * c22 - t_edge)  # radius of the star tip, measured at psi_k

    def on_bezel_z(r, off_deg):
        # Height of the bezel plane through G_0 (tilted by the crown angle about phi_0) at radius r, azimuth off.
        return zg + tc * (R - r * np.cos(np.radians(off_deg)))

    z_culet = -zg - R * tp
    # Q_k: on the pavilion-main intersection line at psi_k; LOWER_GIRDLE of the way down from the girdle.
    r_q = R * c22 * (1 - LOWER_GIRDLE)  # radius along psi_k (the mains meet the girdle chord at R cos 22.5)

    def on_main_z(r, off_deg):
        return -zg - tp * (R - r * np.cos(np.radians(off_deg)))

    T = [polar(t_corner, 45 * k, z_table) for k in range(8)]
    G = [polar(R, 45 * k, zg) for k in range(8)]
    H = [polar(R, 45 * k + 22.5, zg) for k in range(8)]
    S = [polar(r_star, 45 * k + 22.5, on_bezel_z(r_star, 22.5)) for k in range(8)]
    Gp = [polar(R, 45 * k, -zg) for k in range(8)]
    Hp = [polar(R, 45 * k + 22.5, -zg) for k in range(8)]
    C = np.array([0.0, 0.0, z_culet])
    Q = [polar(r_q, 45 * k + 22.5, on_main_z(r_q, 22.5)) for k in range(8)]

    f = [("table", T)]
    for k in range(8):
        k1, km = (k + 1) % 8, (k - 1) % 8
        f.append((f"bezel {k}", [T[k], S[km], G[k], S[k]]))
        f.append((f"star {k}", [T[k], S[k], T[k1]]))
        f.append((f"upper girdle {2 * k}", [S[k], G[k], H[k]]))
        f.append((f"upper girdle {2 * k + 1}", [S[k], H[k], G[k1]]))
        f.append((f"girdle {2 * k}", [G[k], Gp[k], Hp[k], H[k]]))
        f.append((f"girdle {2 * k + 1}", [H[k], Hp[k], Gp[k1], G[k1]]))
        f.append((f"pavilion main {k}", [C, Q[k], Gp[k], Q[km]]))
        f.append((f"lower girdle {2 * k}", [Q[k], Hp[k], Gp[k]]))
        f.append((f"lower girdle {2 * k + 1}", [Q[k], Gp[k1], Hp[k]]))
    info = {
        "crown height": z_table - zg,
        "pavilion depth": -zg - z_culet,
        "total depth": z_table - z_culet,
        "table (across flats)": 2 * t_edge,
    }
    return f, info


def plane_of(pts):
    p = np.array(pts)
    c = p.mean(axis=0)
    # Newell's method: robust normal of a planar polygon.
    n = np.zeros(3)
    for i in range(len(p)):
        a, b = p[i], p[(i + 1) % len(p)]
        n += np.array([(a[1] - b[1]) * (a[2] + b[2]), (a[2] - b[2]) * (a[0] + b[0]), (a[0] - b[0]) * (a[1] + b[1])])
    return c, n / np.linalg.norm(n)


def check_and_orient(facets):
    """Flatness, convexity and outward orientation; returns facets with corners counter-clockwise from outside."""
    all_pts = np.concatenate([np.array(p) for _, p in facets])
    centre = all_pts.mean(axis=0)
    out = []
    for name, pts in facets:
        c, n = plane_of(pts)
        if np.dot(n, c - centre) < 0:  # wound inward: reverse
            pts = pts[::-1]
            c, n = plane_of(pts)
        dev = np.abs((np.array(pts) - c) @ n).max()
        if dev > 1e-9:
            raise SystemExit(f"facet '{name}' is not flat (off by {dev:.2e})")
        side = (all_pts - c) @ n
        if side.max() > 1e-9:
            raise SystemExit(f"not convex: a vertex lies {side.max():.2e} outside facet '{name}'")
        # Corners must be in convex order within the facet: every edge turns the same way.
        p = np.array(pts)
        for i in range(len(p)):
            e1, e2 = p[(i + 1) % len(p)] - p[i], p[(i + 2) % len(p)] - p[(i + 1) % len(p)]
            if np.dot(np.cross(e1, e2), n) <= 0:
                raise SystemExit(f"facet '{name}' is not a convex polygon in order")
        out.append((name, pts, n))
    return out


def check_closed(facets):
    """Every directed edge (between shared corner positions) appears once, its reverse once."""
    key = lambda p: tuple(np.round(p, 9))
    edges = {}
    for name, pts, _ in facets:
        for i in range(len(pts)):
            e = (key(pts[i]), key(pts[(i + 1) % len(pts)]))
            if e in edges:
                raise SystemExit(f"edge used twice in the same direction ({edges[e]} and {name})")
            edges[e] = name
    for (a, b), name in edges.items():
        if (b, a) not in edges:
            raise SystemExit(f"open edge on facet '{name}'")
    # Euler's formula for a closed genus-0 polyhedron: V - E + F = 2.
    v = len({a for a, _ in edges})
    e = len(edges) // 2
    if v - e + len(facets) != 2:
        raise SystemExit(f"Euler characteristic {v - e + len(facets)} != 2")
    return v, e


def write_ply(path, facets):
    verts, tris, index = [], [], {}

    def vid(p):
        k = tuple(np.round(p, 9))
        if k not in index:
            index[k] = len(verts)
            verts.append(p)
        return index[k]

    for _, pts, _ in facets:
        ids = [vid(p) for p in pts]
        for i in range(1, len(ids) - 1):  # fan: convex facets, counter-clockwise from outside
            tris.append((ids[0], ids[i], ids[i + 1]))
    verts = np.array(verts, dtype="<f4")
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        "comment round brilliant-cut diamond for scenes/diamond.pbrt (scenes/tools/make_diamond.py)\n"
        f"element vertex {len(verts)}\nproperty float x\nproperty float y\nproperty float z\n"
        f"element face {len(tris)}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    rec = np.zeros(len(tris), dtype=[("n", "u1"), ("i", "<i4", 3)])
    rec["n"] = 3
    rec["i"] = tris
    with open(path, "wb") as f:
        f.write(header.encode("ascii"))
        f.write(verts.tobytes())
        f.write(rec.tobytes())
    return len(verts), len(tris)


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    out = os.path.normpath(sys.argv[1] if len(sys.argv) > 1 else os.path.join(here, "..", "meshes", "diamond.ply"))
    os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
    facets, info = build_facets()
    facets = check_and_orient(facets)
    v, e = check_closed(facets)
    nv, nt = write_ply(out, facets)
    counts = {}
    for name, _, _ in facets:
        kind = name.rsplit(" ", 1)[0] if name[-1].isdigit() else name
        counts[kind] = counts.get(kind, 0) + 1
    d = 2 * R
    print(f"wrote {out}: {len(facets)} facets ({', '.join(f'{n} {k}' for k, n in counts.items())}), "
          f"{v} corners, {e} edges; {nv} vertices, {nt} triangles")
    print("  " + ", ".join(f"{k} {100 * x / d:.1f} %" for k, x in info.items()) + " of the diameter")
    angles = {}
    for name, _, n in facets:
        kind = name.rsplit(" ", 1)[0] if name[-1].isdigit() else name
        angles.setdefault(kind, np.degrees(np.arccos(abs(n[2]))))
    print("  facet angles from the girdle plane: " + ", ".join(f"{k} {a:.2f}" for k, a in angles.items()))


if __name__ == "__main__":
    main()

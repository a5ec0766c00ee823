#!/usr/bin/env python3
"""Writes scenes/textures/bubble-thickness.pfm, the film thickness of a soap bubble, in nanometres.

A single-channel float texture for `Shape "sphere"` whose material takes the thickness of its thin film from
`Texture "bubble" "float" "imagemap" "string filename" "textures/bubble-thickness.pfm"` (in Prismatic,
`"texture filmthickness" "bubble"`, docs/scene-format.md, "Thin-film coatings"; values are nm, unscaled). The film
is thin at the top of the bubble and thickens downwards, with swirls over the middle latitudes:

  - Mean profile: gravity drains a vertical soap film into a wedge, thin above and thick below (Mysels, Shinoda &
    Frankel, "Soap Films: Studies of Their Thinning", 1959). Here the simple empirical wedge
        h(z) = H_TOP + (H_BOTTOM - H_TOP) * ((1 - z) / 2) ** P        (z = cos theta, +1 at the top),
    not a solution of the drainage equations.
  - H_TOP is a black film: below ~30 nm a film reflects almost nothing (common black films are ~30 nm, Newton
    black films 5-10 nm: Isenberg, "The Science of Soap Films and Soap Bubbles", 1978).
  - Going down, a water film (n ~ 1.33) shows Newton's series in reflection: black, grey-silver (~100 nm), straw
    (~150 nm), magenta (~200 nm), blue (~250 nm), green (~300 nm), then third and fourth order pinks and greens
    (~400-800 nm) that wash out towards white (~1 um, H_BOTTOM).
  - Swirls: marginal regeneration at the film's edges and thermal convection stir the film into eddies and
    isolated vortices (Couder, Chomaz & Rabaud, Physica D 37, 1989; Seychelles et al., PRL 100, 144501, 2008).
    Modelled as VORTICES twists of the sphere about random axes, domain-warped gradient noise that displaces the
    bands in latitude, and a gentle multiplicative ripple, all faded out towards the poles as (1 - z^2); each row
    is then rescaled so that its mean is the profile's value h(z) exactly. Fixed seed: the output is repeatable.
The noise is evaluated at the 3-D point of each texel on the unit sphere, so the texture is periodic in u (the
seam at phi = 0/2pi is continuous) and has no pinch at the poles.

Layout (the pbrt-v4 conventions Prismatic follows):
  - sphere (crates/geometry/src/shapes/sphere.rs, Sphere::geom_at): u = phi / phimax with phi = atan2(y, x) in
    [0, 2pi) in object space, and v = (theta - theta(zmin)) / (theta(zmax) - theta(zmin)), so on a full sphere
    v = 1 - theta/pi: v = 0 at the -z pole, v = 1 at the +z pole;
  - imagemap, "uv" mapping by default (crates/render/src/texture.rs, UvMapping::map and RgbImage::bilerp_wrapped):
    (s, t) = (u, v), column x = s*W - 0.5 and row y = (1 - t)*H - 0.5 with row 0 the TOP row of the image
    (crates/film/src/image_io.rs, read_pfm, returns rows from the top: PFM stores them bottom-to-top);
  - so the image is W x H = 2H x H, column x <-> phi = 2pi (x + 0.5)/W from the sphere's +x axis towards +y, and
    row y <-> theta = pi (y + 0.5)/H from the sphere's +z axis: row 0 (top of the image) is the TOP of the bubble
    (thin), the last row its BOTTOM (thick). The writer below flips the array, so `h[0]` is the +z row.
  - The default wrap, "repeat", joins the seam. It also wraps rows, so within half a texel of a pole (of the MIP
    level a lookup picks) the lookup blends the top and bottom rows; that cap is far too small to notice. (With
    "string wrap" "clamp" instead, the seam is a step of one texel, as small as any step between neighbours.)

Orientation: the bubble's "up" is its object-space +z. In a z-up scene the unrotated sphere is right. In a y-up
scene put `Rotate -90 1 0 0` before the `Shape "sphere"` (it maps the sphere's +z onto world +y; the thin black cap
then faces +y and phi = 0 faces +x).

Usage:  python3 scenes/tools/make_bubble.py [output.pfm]   (default: scenes/textures/bubble-thickness.pfm next to
        this script). Needs Python 3 and numpy.
"""

import os
import sys

import numpy as np

W, H = 1024, 512  # u x v; powers of two, so the MIP map uses the image itself as level 0 (no resampling)
H_TOP = 20.0  # nm: black film at the top
H_BOTTOM = 1000.0  # nm: at the bottom pole, pale high-order colours
P = 1.7  # exponent of the wedge
H_MIN = 8.0  # nm: floor of the perturbed film (a Newton black film is no thinner)
SEED = 20240611
VORTICES = 9  # twists of the sphere (eddies)
BAND_SHIFT = 0.07  # standard deviation of the latitude displacement (in z = cos theta) at the equator
RIPPLE = 0.08  # relative amplitude (standard deviation) of the multiplicative ripple at the equator
WARP = 0.35  # strength of the domain warp (unit-sphere lengths per standard deviation of the warping noise)


def sphere_points():
    """Unit-sphere point of each texel centre, shape (H, W, 3), and z = cos theta per row, shape (H,)."""
    phi = 2.0 * np.pi * (np.arange(W) + 0.5) / W
    theta = np.pi * (np.arange(H) + 0.5) / H
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    p = np.stack(np.broadcast_arrays(st * np.cos(phi)[None, :], st * np.sin(phi)[None, :], ct), axis=-1)
    return p, np.cos(theta)


def profile(z):
    """The mean thickness (nm) at height z = cos theta in [-1, 1] (+1 the top)."""
    s = np.clip((1.0 - z) / 2.0, 0.0, 1.0)
    return H_TOP + (H_BOTTOM - H_TOP) * s**P


class Perlin3:
    """Perlin's gradient noise in 3-D (improved noise, quintic fade) from a seeded permutation; values ~[-1, 1]."""

    def __init__(self, rng):
        self.perm = np.tile(rng.permutation(256), 2)
        g = rng.normal(size=(256, 3))
        self.grad = g / np.linalg.norm(g, axis=1, keepdims=True)

    def __call__(self, p):
        i0 = np.floor(p).astype(np.int64)
        f = p - i0
        i0 &= 255
        fade = f * f * f * (f * (f * 6.0 - 15.0) + 10.0)
        out = 0.0
        for dx in (0, 1):
            for dy in (0, 1):
                for dz in (0, 1):
                    h = self.perm[self.perm[self.perm[i0[..., 0] + dx] + i0[..., 1] + dy] + i0[..., 2] + dz]
                    d = f - np.array([dx, dy, dz], dtype=float)
                    w = np.where(dx, fade[..., 0], 1 - fade[..., 0])
                    w = w * np.where(dy, fade[..., 1], 1 - fade[..., 1])
                    w = w * np.where(dz, fade[..., 2], 1 - fade[..., 2])
                    out = out + w * np.einsum("...k,...k->...", self.grad[h], d)
        return out * 1.4


def fbm(noise, p, octaves=4, freq=1.0):
    total, amp, norm = 0.0, 1.0, 0.0
    for o in range(octaves):
        total = total + amp * noise(p * freq * 2.0**o + 17.3 * o)
        norm += amp
        amp *= 0.5
    return total / norm


def unit(n):
    """The field n shifted and scaled to mean 0 and standard deviation 1."""
    return (n - n.mean()) / n.std()


def rotate(p, axis, angle):
    """Rodrigues' rotation of the points p (..., 3) about the unit axis by angle (...) radians."""
    c, s = np.cos(angle)[..., None], np.sin(angle)[..., None]
    k = np.broadcast_to(axis, p.shape)
    kp = np.sum(k * p, axis=-1, keepdims=True)
    return p * c + np.cross(k, p) * s + k * kp * (1 - c)


def make_thickness():
    rng = np.random.default_rng(SEED)
    p, zrow = sphere_points()
    env = 1.0 - p[..., 2] ** 2  # strongest at the equator, zero at the poles

    # Eddies: twist the sphere about axes through mid-latitude points, by an angle falling off with the angular
    # distance from the axis (a Gaussian vortex), so the bands that pass through are wound into spirals.
    q = p.copy()
    for _ in range(VORTICES):
        cz = rng.uniform(-0.55, 0.6)
        cphi = rng.uniform(0, 2 * np.pi)
        axis = np.array([np.sqrt(1 - cz * cz) * np.cos(cphi), np.sqrt(1 - cz * cz) * np.sin(cphi), cz])
        radius = rng.uniform(0.18, 0.38)  # radians
        twist = rng.choice([-1.0, 1.0]) * rng.uniform(1.5, 3.5) * (1.0 - cz * cz)
        d = np.arccos(np.clip(q @ axis, -1.0, 1.0))
        q = rotate(q, axis, twist * np.exp(-((d / radius) ** 2)))

    # Convection: domain-warped gradient noise displaces the bands in latitude.
    noise = Perlin3(rng)
    warp = np.stack([unit(fbm(noise, q + o, 3, 1.3)) for o in (0.0, 5.2, 9.7)], axis=-1)
    n_band = unit(fbm(noise, q + WARP * warp + 31.0, 3, 1.6))
    n_ripple = unit(fbm(noise, q + 0.7 * WARP * warp + 57.0, 3, 2.2))
    z = np.clip(q[..., 2] + BAND_SHIFT * env * n_band, -1.0, 1.0)
    h = profile(z) * np.maximum(1.0 + RIPPLE * env * n_ripple, 0.5)

    # Keep the mean profile: scale each row to the profile's mean there, then floor the film.
    h = h * (profile(zrow) / h.mean(axis=1))[:, None]
    h = np.maximum(h, H_MIN)
    return h.astype(np.float32), zrow


def write_pfm(path, img):
    """Little-endian greyscale PFM ("Pf"): header, then float32 rows from the bottom of the image to the top."""
    h, w = img.shape
    with open(path, "wb") as f:
        f.write(f"Pf\n{w} {h}\n-1.0\n".encode("ascii"))
        f.write(np.ascontiguousarray(img[::-1], dtype="<f4").tobytes())


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(here, "..", "textures", "bubble-thickness.pfm")
    os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
    h, zrow = make_thickness()
    assert np.all(np.isfinite(h)) and h.min() >= 0.0
    write_pfm(out, h)
    out = os.path.normpath(out)
    print(f"wrote {out}: {W}x{H} nm, min {h.min():.1f}, mean {h.mean():.1f}, max {h.max():.1f}")
    for lat in (75, 45, 20, 0, -20, -45, -75):
        y = int(np.argmin(np.abs(zrow - np.sin(np.radians(lat)))))
        row = h[y]
        print(f"  latitude {lat:+3d} (row {y:3d}): mean {row.mean():6.1f} nm, min {row.min():6.1f}, "
              f"max {row.max():6.1f}, relative std {row.std() / row.mean():.2f}")


if __name__ == "__main__":
    main()

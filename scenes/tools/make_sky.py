#!/usr/bin/env python3
"""Writes scenes/textures/sky.pfm, the environment map of scenes/metals.pbrt.

A procedural daylight sky in latitude-longitude layout: a blue gradient from zenith to a pale horizon, a bright
sun-like disc with a soft glow, a few soft clouds, a band of distant grey-green hills at the horizon and a dark
brown ground below it. Linear sRGB radiance, written as a little-endian float PFM (no clamping: the sun disc is
more than ten times as bright as the sky around it). The sun is deliberately large (16 degrees in radius) and hazy:
the same sun power in a small, very bright disc makes the caustics that the mirror spheres of metals.pbrt throw
onto the floor -- found by a unidirectional path tracer only by chance -- much noisier.

Layout (Prismatic's EnvironmentMap::direction in crates/render/src/light.rs; pbrt-v3's lat-long convention):
  - the image is W x H = 2H x H;
  - column u = (x + 0.5) / W  ->  azimuth  phi   = 2 pi u, measured from the light's +x axis towards +y;
  - row    v = (y + 0.5) / H  ->  polar    theta = pi v from the light's +z axis, row 0 (the TOP row of the
    image) looking straight up along +z;
  - so the direction of a texel is (sin theta cos phi, sin theta sin phi, cos theta) in light space.
PFM stores rows bottom-to-top; the writer below flips the array accordingly, so `img[0]` is the zenith row.

With a z-up scene `LightSource "infinite" "string filename" "textures/sky.pfm"` needs no rotation: +z is up and
the sun sits at azimuth SUN_PHI_DEG from +x. (For a y-up scene put `Rotate -90 1 0 0` before the light: it maps
the light's +z onto world +y.)

Usage:  python3 scenes/tools/make_sky.py [output.pfm]     (default: scenes/textures/sky.pfm next to this script)
Needs Python 3 and numpy.
"""

import os
import sys

import numpy as np

W, H = 512, 256
SUN_PHI_DEG = 235.0  # azimuth of the sun from +x towards +y
SUN_ELEV_DEG = 40.0  # elevation above the horizon
SUN_RADIUS_DEG = 16.0  # angular radius of the disc (the real sun's is 0.27 deg; see above)
SUN_RADIANCE = np.array([1.0, 0.93, 0.82]) * 12.5
SKY_ZENITH = np.array([0.10, 0.22, 0.62])
SKY_HORIZON = np.array([0.70, 0.80, 0.95])
GROUND = np.array([0.10, 0.085, 0.07])
HILLS = np.array([0.16, 0.19, 0.15])


def directions():
    """Unit direction of each texel centre, shape (H, W, 3), and its elevation above the horizon (radians)."""
    u = (np.arange(W) + 0.5) / W
    v = (np.arange(H) + 0.5) / H
    phi = 2.0 * np.pi * u[None, :]
    theta = np.pi * v[:, None]
    d = np.stack(
        np.broadcast_arrays(np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)), axis=-1
    )
    return d, np.pi / 2 - np.broadcast_to(theta, (H, W)), np.broadcast_to(phi, (H, W))


def smoothstep(e0, e1, x):
    t = np.clip((x - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3 - 2 * t)


def make_sky():
    d, elev, phi = directions()
    sp, se = np.radians(SUN_PHI_DEG), np.radians(SUN_ELEV_DEG)
    sun_dir = np.array([np.cos(se) * np.cos(sp), np.cos(se) * np.sin(sp), np.sin(se)])
    cos_sun = np.clip(d @ sun_dir, -1.0, 1.0)
    ang = np.arccos(cos_sun)  # angle from the sun centre

    # Sky: zenith-to-horizon gradient, brighter towards the sun (a crude Mie glow).
    t = np.clip(elev / (np.pi / 2), 0.0, 1.0) ** 0.45
    sky = SKY_HORIZON[None, None, :] * (1 - t[..., None]) + SKY_ZENITH[None, None, :] * t[..., None]
    glow = 0.9 * np.exp(-ang / 0.25) + 0.25 * np.exp(-ang / 0.9)
    sky = sky * (1.0 + glow[..., None] * np.array([1.0, 0.85, 0.6]))

    # Soft clouds: a few anisotropic Gaussian puffs at low and middle elevations.
    rng = np.random.default_rng(7)
    cloud = np.zeros((H, W))
    for _ in range(14):
        c_phi = rng.uniform(0, 2 * np.pi)
        c_el = rng.uniform(np.radians(8), np.radians(45))
        w_phi, w_el = rng.uniform(0.12, 0.35), rng.uniform(0.03, 0.07)
        dphi = np.angle(np.exp(1j * (phi - c_phi)))
        cloud += rng.uniform(0.5, 1.0) * np.exp(-0.5 * ((dphi / w_phi) ** 2 + ((elev - c_el) / w_el) ** 2))
    cloud = np.clip(cloud, 0.0, 1.0)[..., None]
    cloud_col = np.array([1.05, 1.05, 1.08]) * (1.0 + 0.6 * glow[..., None])
    sky = sky * (1 - 0.8 * cloud) + cloud_col * 0.8 * cloud

    # Distant hills: a band whose top follows a sum of sines (2-7 degrees above the horizon).
    ridge = np.radians(3.5 + 1.8 * np.sin(3 * phi + 0.4) + 1.2 * np.sin(7 * phi + 2.0) + 0.5 * np.sin(17 * phi))
    hill_shade = 0.85 + 0.15 * np.cos(5 * phi)
    img = sky.copy()
    in_hills = (elev < ridge) & (elev >= 0)
    shade = hill_shade[in_hills] * (0.8 + 0.4 * (elev[in_hills] / ridge[in_hills]))
    img[in_hills] = HILLS[None, :] * shade[:, None]
    # Ground below the horizon, slightly lighter near it (haze).
    below = elev < 0
    haze = np.exp(elev / 0.08)[..., None]
    ground = GROUND[None, None, :] * (1 - haze) + HILLS[None, None, :] * haze
    img[below] = ground[below]

    # The sun disc with a slightly soft limb; added last so it is always on top.
    r = np.radians(SUN_RADIUS_DEG)
    disc = smoothstep(r, 0.8 * r, ang)
    img = img + disc[..., None] * SUN_RADIANCE[None, None, :]
    return img.astype(np.float32)


def write_pfm(path, img):
    """Little-endian colour PFM: header, then float32 RGB rows from the bottom of the image to the top."""
    h, w, _ = img.shape
    with open(path, "wb") as f:
        f.write(f"PF\n{w} {h}\n-1.0\n".encode("ascii"))
        f.write(np.ascontiguousarray(img[::-1], dtype="<f4").tobytes())


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(here, "..", "textures", "sky.pfm")
    os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
    img = make_sky()
    write_pfm(out, img)
    out = os.path.normpath(out)
    print(f"wrote {out}: {W}x{H}, max {img.max():.1f}, mean {img.mean():.3f}")


if __name__ == "__main__":
    main()

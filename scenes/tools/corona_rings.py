#!/usr/bin/env python3
"""Measures the rings of scenes/corona.pbrt per wavelength, for the README, against Airy's diffraction by a disc.

It renders the scene once more on a spectral film of 20 nm buckets from 420 to 680 nm (the scene is single
scattering already), then averages each bucket's image over rings of 0.05 degrees around the moon (the image's
centre: the camera looks straight at it; a pixel at distance d from the centre is atan(d / (w/2) * tan(fov/2)) from
the moon). For each bucket it finds the first local minimum outwards from 2 degrees (the first dark ring, refined by
a parabola through its neighbours) and the first local maximum beyond it (the first bright ring), and prints
them beside Airy's first minimum, sin(theta) = 1.22 lambda / (2a), and first bright ring, 1.635 lambda / (2a),
for the scene's droplet radius a (the maxima of (2 J1(x) / x)^2 are at x = 5.136, i.e. 1.635 pi).

Usage:  python3 scenes/tools/corona_rings.py [scene.pbrt] [--spp N] [--prismatic PATH]
        (default: scenes/corona.pbrt, 32 spp, target/release/prismatic)
Needs Python 3 with numpy and the OpenEXR package.
"""

import argparse
import math
import os
import re
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from spectral_render import PRISMATIC, ROOT, render_buckets  # noqa: E402


def ring_profiles(scene_path, spp, prismatic):
    """Renders `scene_path` on a spectral film of 20 nm buckets from 420 to 680 nm and returns the scene's text, the
    ring centres (degrees from the image's centre, 0.05 degrees apart) and, per bucket, (λ, mean over each ring,
    smoothed over five rings, 0.25 degrees, against the noise, so that the first local extremum is a ring)."""
    text = open(scene_path).read()
    fov = float(re.search(r'"float fov"\s+([0-9.]+)', text).group(1))
    images = render_buckets(scene_path, text, spp, prismatic, (13, 420, 680))
    h, w = images[0][1].shape
    yy, xx = np.mgrid[0:h, 0:w]
    dist = np.hypot(xx + 0.5 - w / 2.0, yy + 0.5 - h / 2.0) / (w / 2.0)
    angle = np.degrees(np.arctan(dist * math.tan(math.radians(fov / 2.0))))
    step = 0.05
    ring = np.floor(angle / step).astype(int)
    n = ring.max() + 1
    centres = (np.arange(n) + 0.5) * step
    counts = np.bincount(ring.ravel(), minlength=n)
    profiles = []
    for lam, img in images:
        profile = np.bincount(ring.ravel(), weights=img.ravel(), minlength=n) / np.maximum(counts, 1)
        profiles.append((lam, np.convolve(profile, np.ones(5) / 5.0, mode="same")))
    return text, centres, profiles


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene", nargs="?", default=os.path.join(ROOT, "scenes", "corona.pbrt"))
    ap.add_argument("--spp", type=int, default=32)
    ap.add_argument("--prismatic", default=PRISMATIC)
    args = ap.parse_args()
    text, centres, profiles = ring_profiles(args.scene, args.spp, args.prismatic)
    radius_um = float(re.search(r'"float radius"\s+([0-9.]+)', text).group(1))
    print(f"rings of {os.path.relpath(args.scene, ROOT)} ({args.spp} spp), degrees from the moon, per 20 nm bucket;")
    print(f"Airy's for droplets of {radius_um:g} um: first minimum sin = 1.22 l/(2a), first bright ring 1.635 l/(2a)")
    print(f"{'λ (nm)':>8} {'minimum':>9} {'Airy':>7} {'ring':>7} {'Airy':>7}")
    for lam, smooth in profiles:
        minimum = extremum(smooth, centres, 2.0, 6.0, np.argmin)
        bright = extremum(smooth, centres, minimum + 0.2, 8.0, np.argmax)
        airy_min = math.degrees(math.asin(1.22 * lam * 1e-3 / (2.0 * radius_um)))
        airy_ring = math.degrees(math.asin(1.635 * lam * 1e-3 / (2.0 * radius_um)))
        print(f"{lam:8.1f} {minimum:9.2f} {airy_min:7.2f} {bright:7.2f} {airy_ring:7.2f}")


def extremum(profile, centres, lo, hi, pick):
    """The angle of the first local extremum of `profile` (`pick`: np.argmin for a minimum, np.argmax for a
    maximum) going outwards from `lo` (up to `hi`), refined by a parabola through its neighbours: the first dark
    ring, not a deeper one further out."""
    sign = 1.0 if pick is np.argmin else -1.0
    idx = np.where((centres >= lo) & (centres <= hi))[0]
    i = idx[-1]
    for k in idx[1:-1]:
        if sign * profile[k] <= sign * profile[k - 1] and sign * profile[k] < sign * profile[k + 1]:
            i = k
            break
    if 0 < i < len(profile) - 1:
        a, b, c = profile[i - 1], profile[i], profile[i + 1]
        denom = a - 2 * b + c
        off = 0.5 * (a - c) / denom if denom != 0 else 0.0
        return centres[i] + off * (centres[1] - centres[0])
    return centres[i]


if __name__ == "__main__":
    sys.exit(main())

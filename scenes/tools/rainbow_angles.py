#!/usr/bin/env python3
"""Measures the angles of the rendered bows of scenes/rainbow.pbrt (or another scene with its camera and sun), per
wavelength, for the README's table beside `prismatic ior water --rainbow`.

It renders the scene once more with single scattering only (maxdepth 1, so that the bows are not washed by multiply
scattered light) on a spectral film of 20 nm buckets from 400 to 700 nm, then reads the middle 21 columns of the
image, where the bows cross the vertical through the antisolar point. Row y sees the elevation
    e(y) = pitch + atan((h/2 - y - 0.5) / (h/2) * tan(fov/2))   (pitch = atan(0.25) = 14.04 degrees),
and its angle from the antisolar point (8 degrees below the horizon, straight ahead) is e(y) + 8 degrees. For each
bucket the script finds the brightest row between 36 and 46 degrees (primary) and between 48 and 58 degrees
(secondary), refines it with a parabola through the neighbouring rows, and prints both angles.

Usage:  python3 scenes/tools/rainbow_angles.py [scene.pbrt] [--spp N] [--prismatic PATH]
        (default: scenes/rainbow.pbrt, 32 spp, target/release/prismatic)
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

# The geometry of scenes/rainbow.pbrt: camera pitched atan(0.25) = 14.04 degrees up (LookAt 0 1.7 0 to 0 1.95 1),
# sun 8 degrees high (distant light from (0, sin 8°, -cos 8°)); the field of view is read from the scene.
PITCH_DEG = math.degrees(math.atan(0.25))
SUN_ELEVATION_DEG = 8.0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene", nargs="?", default=os.path.join(ROOT, "scenes", "rainbow.pbrt"))
    ap.add_argument("--spp", type=int, default=32)
    ap.add_argument("--prismatic", default=PRISMATIC)
    args = ap.parse_args()

    text = open(args.scene).read()
    fov = float(re.search(r'"float fov"\s+([0-9.]+)', text).group(1))
    text = re.sub(r'"integer maxdepth"\s+\d+', '"integer maxdepth" 1', text)
    images = render_buckets(args.scene, text, args.spp, args.prismatic, (15, 400, 700))
    h, w = images[0][1].shape
    rows = np.arange(h)
    half = math.tan(math.radians(fov / 2.0))
    angle = PITCH_DEG + np.degrees(np.arctan((h / 2.0 - rows - 0.5) / (h / 2.0) * half)) + SUN_ELEVATION_DEG
    print(f"rendered bows of {os.path.relpath(args.scene, ROOT)} (single scattering, {args.spp} spp), degrees")
    print("from the antisolar point, brightest row per 20 nm bucket:")
    print(f"{'λ (nm)':>10} {'primary':>10} {'secondary':>10}")
    for lam, img in images:
        profile = img[:, w // 2 - 10 : w // 2 + 11].mean(axis=1)
        print(f"{lam:10.1f} {peak(profile, angle, 36, 46):10.2f} {peak(profile, angle, 48, 58):10.2f}")


def peak(profile, angle, lo, hi):
    """Angle of the largest value of `profile` over rows whose angle is in [lo, hi], refined by a parabola."""
    idx = np.where((angle >= lo) & (angle <= hi))[0]
    i = idx[np.argmax(profile[idx])]
    if 0 < i < len(profile) - 1:
        a, b, c = profile[i - 1], profile[i], profile[i + 1]
        denom = a - 2 * b + c
        off = 0.5 * (a - c) / denom if denom != 0 else 0.0
        # Rows are nearly evenly spaced in angle here: interpolate the angle linearly.
        return angle[i] + off * (angle[i + 1] - angle[i - 1]) / 2.0
    return angle[i]


if __name__ == "__main__":
    sys.exit(main())

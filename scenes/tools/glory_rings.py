#!/usr/bin/env python3
"""Measures the bright rings of scenes/glory.pbrt per wavelength, for the README: the first two local maxima,
outwards from 1 degree, of each 20 nm band's mean over 0.05-degree rings around the image's centre (the camera
looks at the antisolar point), as scenes/tools/corona_rings.py measures a corona. If the independent Mie code
`miepython` is installed, it also prints the first two maxima of the Mie series' unpolarised intensity near 180
degrees for the scene's drop sizes over each band (an independent check of the renderer's Mie tables).

Usage:  python3 scenes/tools/glory_rings.py [scene.pbrt] [--spp N] [--prismatic PATH]
        (default: scenes/glory.pbrt, 32 spp, target/release/prismatic)
Needs Python 3 with numpy and the OpenEXR package (and, for the comparison, miepython).
"""

import argparse
import os
import re
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from corona_rings import extremum, ring_profiles  # noqa: E402
from spectral_render import PRISMATIC, ROOT  # noqa: E402


def mie_rings(radius_um, spread, lam_nm, width_nm=20.0):
    """The first two maxima (degrees from backscatter, beyond 0.8) of the Mie series' unpolarised intensity for water
    drops of log-normal radii (mean `radius_um`, relative spread `spread`) over the band `lam_nm` ± `width_nm`/2,
    or None without miepython."""
    try:
        import miepython
    except ImportError:
        return None
    # Water near the middle of the visible (n varies by 1% over it; the rings by far less than the bands' width).
    m = complex(1.333, 0.0)
    dev = np.linspace(0.0, 8.0, 1601)
    mu = np.cos(np.radians(180.0 - dev))
    total = np.zeros_like(dev)
    for z in np.linspace(-2.0, 2.0, 9):
        weight = np.exp(-0.5 * z * z)
        r = radius_um * np.exp(spread * z)
        for lam in lam_nm + width_nm * (np.arange(5) + 0.5 - 2.5) / 5.0:
            x = 2.0 * np.pi * r / (lam * 1e-3)
            # Cross-section-weighted: a drop scatters in proportion to its area.
            total += weight * r * r * miepython.i_unpolarized(m, x, mu)
    peaks = [dev[k] for k in range(1, len(dev) - 1) if total[k] > total[k - 1] and total[k] >= total[k + 1] and dev[k] > 0.8]
    return peaks[:2]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene", nargs="?", default=os.path.join(ROOT, "scenes", "glory.pbrt"))
    ap.add_argument("--spp", type=int, default=32)
    ap.add_argument("--prismatic", default=PRISMATIC)
    args = ap.parse_args()
    text, centres, profiles = ring_profiles(args.scene, args.spp, args.prismatic)
    radius_um = float(re.search(r'"float radius"\s+([0-9.]+)', text).group(1))
    spread = float(re.search(r'"float radiusspread"\s+([0-9.]+)', text).group(1))
    print(f"bright rings of {os.path.relpath(args.scene, ROOT)} ({args.spp} spp), degrees from the antisolar point;")
    print(f"the Mie series for {radius_um:g} um water drops ({spread:g} spread) over each band, if miepython is installed")
    print(f"{'λ (nm)':>8} {'ring 1':>8} {'Mie':>6} {'ring 2':>8} {'Mie':>6}")
    for lam, smooth in profiles:
        first = extremum(smooth, centres, 1.0, 6.0, np.argmax)
        second = extremum(smooth, centres, first + 0.5, 8.0, np.argmax)
        mie = mie_rings(radius_um, spread, lam)
        m1, m2 = (f"{mie[0]:6.2f}", f"{mie[1]:6.2f}") if mie and len(mie) == 2 else ("-", "-")
        print(f"{lam:8.1f} {first:8.2f} {m1:>6} {second:8.2f} {m2:>6}")


if __name__ == "__main__":
    sys.exit(main())

"""What the measuring scripts of scenes/tools share: rendering a scene again on a spectral film and reading its
buckets back (rainbow_angles.py, corona_rings.py, glory_rings.py). Needs numpy and the OpenEXR package."""

import os
import re
import subprocess
import tempfile

import numpy as np
import OpenEXR

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PRISMATIC = os.path.join(ROOT, "target", "release", "prismatic")


def render_buckets(scene_path, text, spp, prismatic, buckets):
    """Renders `text` (a scene, written beside `scene_path` so that its relative file names resolve) with its `Film
    "rgb"` made spectral, `buckets` = (count, λ min, λ max) in nm, at `spp` samples, and returns [(λ, image)] per
    bucket, shortest first, each image an h × w array of float64."""
    count, lo, hi = buckets
    spectral = re.sub(
        r'Film "rgb"', f'Film "spectral" "integer nbuckets" {count} "float lambdamin" {lo} "float lambdamax" {hi}', text
    )
    with tempfile.TemporaryDirectory() as tmp:
        scene = os.path.join(os.path.dirname(os.path.abspath(scene_path)), ".spectral_render.pbrt")
        out = os.path.join(tmp, "buckets.exr")
        try:
            open(scene, "w").write(spectral)
            subprocess.run([prismatic, "render", scene, "-o", out, "--spp", str(spp), "--quiet"], check=True)
        finally:
            if os.path.exists(scene):
                os.remove(scene)
        channels = OpenEXR.File(out).channels()
        names = sorted(
            # Channel names are S0.<λ>nm with a decimal comma (the spectral EXR convention, Fichet et al. 2021).
            (float(re.match(r"S0\.([0-9]+)", name).group(1)), name)
            for name in channels
            if name.startswith("S0.")
        )
        return [(lam, np.asarray(channels[name].pixels, dtype=np.float64)) for lam, name in names]

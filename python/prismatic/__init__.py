"""Prismatic, a physically based spectral renderer, from Python.

    import prismatic
    scene = prismatic.load("scenes/prism-exercise.pbrt")
    image = scene.render(spp=16, resolution=(400, 300), seed=1)
    image.rgb          # NumPy float32, height x width x 3, linear RGB
    prismatic.ior("N-BK7", [486.1, 587.6, 656.3])

A scene that cannot be read raises prismatic.SceneError with .file, .line, .column and .message.
"""

import numpy as _np

from ._prismatic import Image, Scene, SceneError, __version__, load, loads
from . import _prismatic

__all__ = ["Image", "Scene", "SceneError", "__version__", "catalogue", "ior", "load", "loads"]


def ior(name, nm):
    """The index of refraction of catalogue material `name` (anything `prismatic ior --list` prints, e.g. "N-BK7",
    "water", "Au") at wavelength(s) `nm` in nanometres: a float, or for a metal a complex n + ik; for an array of
    wavelengths, an array of the same shape. The values are those `prismatic ior NAME --nm ...` prints.
    ValueError for an unknown name (with close matches) or a wavelength that is not a positive number."""
    if not isinstance(name, str):
        raise TypeError(f"name must be a string, got {type(name).__name__}")
    try:
        lam = _np.asarray(nm, dtype=_np.float64)
    except (TypeError, ValueError) as e:
        raise TypeError(f"nm must be a number or an array of numbers: {e}") from None
    n, k = _prismatic._ior(name, _np.ascontiguousarray(lam.ravel()))
    out = (n if k is None else n + 1j * k).reshape(lam.shape)
    return out[()] if lam.ndim == 0 else out


def catalogue():
    """The materials `ior` knows, as dicts: name, category, nd and vd (None for metals), valid_nm (the data's
    range) and source."""
    keys = ("name", "category", "nd", "vd", "valid_nm", "source")
    return [dict(zip(keys, row)) for row in _prismatic._catalogue()]

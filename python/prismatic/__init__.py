"""Prismatic, a physically based spectral renderer, from Python.

    import prismatic
    scene = prismatic.load("scenes/prism-exercise.pbrt")
    image = scene.render(spp=16, resolution=(400, 300), seed=1)
    image.rgb          # NumPy float32, height x width x 3, linear RGB
    scene.set_material("prism", "dielectric", '"spectrum eta" "glass-F11"')
    image = scene.render(spp=16, resolution=(400, 300))   # the BVH is kept
    prismatic.ior("N-BK7", [486.1, 587.6, 656.3])

A scene that cannot be read raises prismatic.SceneError with .file, .line, .column and .message.
"""

import numpy as _np

from ._prismatic import Image, Scene, SceneError, Spectrum, __version__, load, loads
from . import _prismatic

__all__ = [
    "Image",
    "Scene",
    "SceneError",
    "Spectrum",
    "__version__",
    "catalogue",
    "ior",
    "load",
    "loads",
    "prism_deviation",
    "rainbow_angle",
    "spectrum",
]


def _wavelengths(nm):
    try:
        return _np.asarray(nm, dtype=_np.float64)
    except (TypeError, ValueError) as e:
        raise TypeError(f"nm must be a number or an array of numbers: {e}") from None


def _shaped(values, shape):
    out = values.reshape(shape)
    return out[()] if out.ndim == 0 else out


def ior(name, nm):
    """The index of refraction of catalogue material `name` (anything `prismatic ior --list` prints, e.g. "N-BK7",
    "water", "Au") at wavelength(s) `nm` in nanometres: a float, or for a metal a complex n + ik; for an array of
    wavelengths, an array of the same shape. The values are those `prismatic ior NAME --nm ...` prints.
    ValueError for an unknown name (with close matches) or a wavelength that is not a positive number."""
    if not isinstance(name, str):
        raise TypeError(f"name must be a string, got {type(name).__name__}")
    lam = _wavelengths(nm)
    n, k = _prismatic._ior(name, _np.ascontiguousarray(lam.ravel()))
    return _shaped(n if k is None else n + 1j * k, lam.shape)


def catalogue():
    """The materials `ior` knows, as dicts: name, category, nd and vd (None for metals), valid_nm (the data's
    range) and source."""
    keys = ("name", "category", "nd", "vd", "valid_nm", "source")
    return [dict(zip(keys, row)) for row in _prismatic._catalogue()]


def _indices(material, nm):
    """n of `material` (a catalogue name at `nm`, or the index itself: a number or an array) as a float64 array."""
    if isinstance(material, str):
        if nm is None:
            raise TypeError("nm: a catalogue material needs wavelengths in nm")
        n = _np.asarray(ior(material, nm))
        if _np.iscomplexobj(n):
            raise ValueError(f"material: '{material}' is a metal; light does not pass through it")
        return n.astype(_np.float64)
    try:
        return _np.asarray(material, dtype=_np.float64)
    except (TypeError, ValueError) as e:
        raise TypeError(f"material must be a catalogue name or an index of refraction: {e}") from None


def prism_deviation(material, nm=None, apex=60.0):
    """The minimum deviation in degrees of a prism of apex angle `apex` (degrees) in air, made of `material`: a
    catalogue name (with wavelengths `nm`) or an index n (a number or an array). D = 2 asin(n sin(A/2)) - A, the
    symmetric passage (Hecht, Optics, eq. 5.55); NaN where no ray gets through. What `prismatic ior NAME --prism
    APEX --nm ...` prints. The result has the shape of `nm` (or of n)."""
    n = _indices(material, nm)
    return _shaped(_prismatic._prism_deviation(_np.ascontiguousarray(n.ravel()), float(apex)), n.shape)


def rainbow_angle(material="water", nm=None, order=1):
    """The angle in degrees from the antisolar point of the rainbow of `order` (internal reflections: 1 primary,
    2 secondary, ...) of spherical drops of `material` (a catalogue name with wavelengths `nm`, or the relative
    index n itself), by geometric optics (Descartes): the ray of minimum deviation. Primary 42.08 and secondary
    50.89 degrees at n = 1.333; NaN where there is no such bow. What `prismatic ior NAME --rainbow` prints (which
    gives orders 3 and 4 from the sun: 180 minus these). Drops smaller than about 0.1 mm shift the bows (Airy;
    the Mie media render it)."""
    n = _indices(material, nm)
    return _shaped(_prismatic._rainbow_angle(_np.ascontiguousarray(n.ravel()), int(order)), n.shape)


def spectrum(spec, values=None):
    """A Spectrum: `spectrum("stdillum-D65")`, `spectrum("blackbody:5500")`, `spectrum("rgb:0.8,0.2,0.1")`, a
    catalogue glass's or metal's pbrt-v4 name, or `spectrum(nm, values)` from samples. Its `xyz()`, `xy()` and
    `rgb()` are what `prismatic spectrum SPEC` prints; calling it with wavelengths gives its values."""
    if isinstance(spec, str):
        return Spectrum(spec, values)
    nm = _np.asarray(spec, dtype=_np.float64).ravel()
    if values is None:
        raise TypeError("values: wavelengths need their values")
    v = _np.asarray(values, dtype=_np.float64).ravel()
    return Spectrum(nm.tolist(), v.tolist())

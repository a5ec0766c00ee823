"""Type stubs of the extension module (the renderer in Rust); `prismatic` re-exports its public names."""

from os import PathLike
from typing import Callable, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

class SceneError(Exception):
    """A scene that cannot be read or built: where (`file`, `line`, `column`; None where the error has no place in
    a scene file) and what (`message`)."""

    file: Optional[str]
    line: Optional[int]
    column: Optional[int]
    message: str

class Image:
    """A rendered image: NumPy arrays of the film, its statistics, and the command line's outputs."""

    @property
    def rgb(self) -> npt.NDArray[np.float32]:
        """Linear RGB in the film's colour space, height x width x 3, rows from the top."""
    @property
    def spectral(self) -> Optional[npt.NDArray[np.float32]]:
        """A spectral film's buckets, height x width x N (radiance per bucket); None for an RGB film."""
    @property
    def wavelengths(self) -> Optional[npt.NDArray[np.float64]]:
        """The N + 1 edges of the spectral buckets in nm; None for an RGB film."""
    @property
    def aovs(self) -> dict[str, npt.NDArray[np.float32]]:
        """The geometry buffer (with `aovs=True`): albedo, normal, position, geometric_normal, dzdxy, uv, variance,
        relative_variance; empty otherwise."""
    @property
    def stats(self) -> dict[str, Union[int, float, bool, str, None]]:
        """render_seconds, build_seconds, shapes_built, samples, rays, samples_per_second, rays_per_second, spp,
        spp_requested, integrator, wavelengths, threads, triangles, lights."""
    @property
    def bounds(self) -> Tuple[int, int, int, int]:
        """The pixels held within the full image, (x0, x1, y0, y1), half-open."""
    @property
    def width(self) -> int: ...
    @property
    def height(self) -> int: ...
    @property
    def spp(self) -> int:
        """Samples per pixel rendered (fewer than asked after Ctrl-C or a time limit)."""
    def save(self, path: Union[str, PathLike[str]]) -> None:
        """Writes .exr (linear, with spectral buckets and AOVs), .png (display view) or .pfm, atomically."""
    def display(self, view: Optional[str] = None) -> npt.NDArray[np.uint8]:
        """The 8-bit display image of the command line's PNG ("oklab" or "clip" view)."""
    def _repr_png_(self) -> bytes: ...

class Scene:
    """A parsed pbrt-v4 scene: render it, edit its materials, media and lights between renders (the BVH is
    kept)."""

    def render(
        self,
        *,
        spp: Optional[int] = None,
        resolution: Optional[Tuple[int, int]] = None,
        crop: Optional[Tuple[float, float, float, float]] = None,
        integrator: Optional[str] = None,
        wavelengths: Optional[str] = None,
        seed: int = 0,
        threads: Optional[int] = None,
        time_limit: Optional[float] = None,
        aovs: bool = False,
        progress: Union[None, bool, Callable[[int, Optional[int]], object]] = None,
    ) -> Image:
        """Renders the scene (the GIL released); Ctrl-C raises KeyboardInterrupt with the partial `.image`."""
    def set_material(self, key: Union[str, int], type: str, params: str = "") -> None:
        """Replaces a named (str) or anonymous (int) material by `type` with pbrt-v4 parameters `params`."""
    def set_medium(self, name: str, type: str, params: str = "") -> None:
        """Replaces named medium `name` by `type` with pbrt-v4 parameters `params`, keeping its placement."""
    def set_light(self, index: int, type: str, params: str = "") -> None:
        """Replaces `LightSource` number `index` by `type` with pbrt-v4 parameters `params`, keeping its place."""
    @property
    def materials(self) -> dict[Union[int, str], str]:
        """{key: type}: anonymous materials by index, named ones by name."""
    @property
    def media(self) -> dict[str, str]:
        """{name: type} of the named media."""
    @property
    def lights(self) -> list[str]:
        """The types of the `LightSource` lights, in file order."""
    @property
    def builds(self) -> int:
        """How many times the shapes (the BVH) were built."""
    @property
    def path(self) -> Optional[str]:
        """The file loaded (None for `loads`)."""

class Spectrum:
    """A spectrum from a SPEC string ("stdillum-D65", "blackbody:5500", "rgb:R,G,B", a catalogue spectrum) or from
    samples (wavelengths in nm and values); its colour as `prismatic spectrum` prints it."""

    def __init__(self, spec: Union[str, Sequence[float]], values: Optional[Sequence[float]] = None) -> None: ...
    def __call__(self, nm: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """The values at wavelengths `nm` (1-D, nm)."""
    def xyz(self, observer: str = "cie1931", under: Union[None, str, "Spectrum"] = None) -> Tuple[float, float, float]:
        """CIE XYZ (constant 1 has Y = 1), or as a reflectance under an illuminant (white has Y = 1)."""
    def xy(self, observer: str = "cie1931", under: Union[None, str, "Spectrum"] = None) -> Tuple[float, float]:
        """The chromaticity of `xyz`."""
    def rgb(
        self, colorspace: str = "srgb", observer: str = "cie1931", under: Union[None, str, "Spectrum"] = None
    ) -> Tuple[float, float, float]:
        """Linear RGB of `xyz` in srgb, dci-p3, rec2020 or aces2065-1."""

def load(path: Union[str, PathLike[str]], camera: Optional[str] = None) -> Scene:
    """Reads a pbrt-v4 scene file, or a glTF 2.0 file (camera: by name or index); SceneError if it cannot be read."""

def loads(text: str, base_dir: Union[None, str, PathLike[str]] = None) -> Scene:
    """Parses pbrt-v4 scene text; file names resolve from `base_dir`."""

def _ior(name: str, nm: npt.NDArray[np.float64]) -> Tuple[npt.NDArray[np.float64], Optional[npt.NDArray[np.float64]]]: ...
def _catalogue() -> list[tuple[str, str, Optional[float], Optional[float], Tuple[float, float], str]]: ...
def _prism_deviation(n: npt.NDArray[np.float64], apex: float) -> npt.NDArray[np.float64]: ...
def _rainbow_angle(n: npt.NDArray[np.float64], order: int) -> npt.NDArray[np.float64]: ...

//! `prismatic.Image`: a rendered film as NumPy arrays (one copy of the film's values each), with its statistics.

use numpy::ndarray::Array3;
use numpy::{IntoPyArray, PyArray1, PyArray3};
use pyo3::exceptions::{PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};

/// A spectral film's buckets (height × width × N) and their N + 1 edges in nm.
type SpectralArrays = (Py<PyArray3<f32>>, Py<PyArray1<f64>>);

/// What a render did: its time, samples and rays, and the build it used.
#[derive(Clone, Debug, Default)]
pub struct RenderStatistics {
    /// Wall-clock seconds spent rendering (after the build).
    pub render_seconds: f64,
    /// Wall-clock seconds spent building the scene for this render (0 when an earlier build was reused).
    pub build_seconds: f64,
    /// Whether this render's build made the shapes (the BVH) rather than reusing an earlier build's.
    pub shapes_built: bool,
    /// Pixel samples taken (for photon mapping: pixels × iterations).
    pub samples: u64,
    /// Rays traced (closest hit and shadow).
    pub rays: u64,
    /// The integrator's name.
    pub integrator: &'static str,
    /// The wavelength strategy's name.
    pub wavelengths: &'static str,
    /// Worker threads.
    pub threads: usize,
    /// Triangles in the scene (instances counted once).
    pub triangles: usize,
    /// Lights (an area light counts once per primitive).
    pub lights: usize,
    /// Samples per pixel asked for (the spp the render would have reached without a stop or a time limit).
    pub spp_requested: Option<u32>,
}

/// A rendered image: `rgb`, linear in the film's colour space, `height × width × 3` float32; for a spectral film
/// also `spectral` (`height × width × N`) with `wavelengths`, the N + 1 bucket edges in nm; with `aovs=True` the
/// geometry buffer in `aovs`; `stats` says what the render did.
#[pyclass(module = "prismatic._prismatic", frozen)]
pub struct Image {
    film: film::Film,
    rgb: Py<PyArray3<f32>>,
    spectral: Option<SpectralArrays>,
    aovs: Vec<(&'static str, Py<PyArray3<f32>>)>,
    statistics: RenderStatistics,
    /// Image width in pixels (of the crop, for a cropped render).
    #[pyo3(get)]
    width: u32,
    /// Image height in pixels.
    #[pyo3(get)]
    height: u32,
    /// Samples per pixel rendered (fewer than asked if the render was interrupted or ran out of time).
    #[pyo3(get)]
    spp: u32,
}

/// `values` (`n` per pixel, row-major from the top) as a `height × width × n` array, without a copy: the vector's
/// buffer becomes the array's.
fn array<const N: usize>(py: Python<'_>, (w, h): (u32, u32), values: Vec<[f32; N]>) -> PyResult<Py<PyArray3<f32>>> {
    let flat: Vec<f32> = values.into_flattened();
    let a = Array3::from_shape_vec((h as usize, w as usize, N), flat)
        .map_err(|e| PyRuntimeError::new_err(format!("image of {w}×{h}: {e}")))?;
    Ok(a.into_pyarray(py).unbind())
}

impl Image {
    /// The image of `film` after `spp` samples per pixel: the film's values converted once into each array, whose
    /// buffer NumPy then owns (no further copy; the getters hand out the same arrays).
    pub fn new(py: Python<'_>, film: film::Film, spp: u32, statistics: RenderStatistics) -> PyResult<Self> {
        let b = film.bounds();
        let size = (b.width(), b.height());
        let rgb = array(py, size, film.to_rgb_image())?;
        let spectral = match film.spec().kind {
            film::FilmKind::Rgb => None,
            film::FilmKind::Spectral { nbuckets, lambda_min, lambda_max } => {
                let values =
                    Array3::from_shape_vec((size.1 as usize, size.0 as usize, nbuckets), film.to_spectral_image())
                        .map_err(|e| PyRuntimeError::new_err(format!("spectral image: {e}")))?;
                let step = (lambda_max - lambda_min) / nbuckets as f64;
                let edges: Vec<f64> = (0..=nbuckets).map(|i| lambda_min + step * i as f64).collect();
                Some((values.into_pyarray(py).unbind(), PyArray1::from_vec(py, edges).unbind()))
            }
        };
        let mut aovs = vec![];
        if let Some(film::AovImages { albedo, normal }) = film.to_aov_images() {
            aovs.push(("albedo", array(py, size, albedo)?));
            aovs.push(("normal", array(py, size, normal)?));
            if let Some(g) = film.to_gbuffer_images() {
                aovs.push(("position", array(py, size, g.p)?));
                aovs.push(("geometric_normal", array(py, size, g.n)?));
                aovs.push(("dzdxy", array(py, size, g.dz)?));
                aovs.push(("uv", array(py, size, g.uv)?));
                aovs.push(("variance", array(py, size, g.variance)?));
                aovs.push(("relative_variance", array(py, size, g.relative_variance)?));
            }
        }
        Ok(Image { film, rgb, spectral, aovs, statistics, width: size.0, height: size.1, spp })
    }

    /// The display encoding of the film's colour space through `view` (the film's view if None).
    fn encoding(&self, view: Option<&str>) -> PyResult<film::DisplayEncoding> {
        let view = match view {
            None => self.film.spec().view,
            Some(name) => film::View::by_name(name).ok_or_else(|| {
                PyValueError::new_err(format!(
                    "view: unknown view '{name}'; valid views: {}",
                    film::View::NAMES.join(", ")
                ))
            })?,
        };
        Ok(film::DisplayEncoding::new(&self.film.spec().color_space, view))
    }
}

#[pymethods]
impl Image {
    /// The linear RGB image, `height × width × 3`, float32 (rows from the top), in the film's colour space.
    #[getter]
    fn rgb(&self, py: Python<'_>) -> Py<PyArray3<f32>> {
        self.rgb.clone_ref(py)
    }

    /// The spectral image of a spectral film, `height × width × N` (radiance per bucket), else None.
    #[getter]
    fn spectral(&self, py: Python<'_>) -> Option<Py<PyArray3<f32>>> {
        self.spectral.as_ref().map(|(s, _)| s.clone_ref(py))
    }

    /// The N + 1 edges of the spectral buckets in nm, else None.
    #[getter]
    fn wavelengths(&self, py: Python<'_>) -> Option<Py<PyArray1<f64>>> {
        self.spectral.as_ref().map(|(_, w)| w.clone_ref(py))
    }

    /// The geometry buffer of the first visible surface, `height × width × n` float32 arrays by name (empty
    /// unless rendered with `aovs=True` or on a `"gbuffer"` film): `albedo` (3), `normal` (shading normal, 3),
    /// `position` (3), `geometric_normal` (3), `dzdxy` (|dz/dx|, |dz/dy|: 2), `uv` (2), `variance` and
    /// `relative_variance` (of the pixel's colour, 3); camera space unless the film says otherwise: the EXR's
    /// `Albedo`, `Ns`, `P`, `N`, `dzdx`/`dzdy`, `u`/`v`, `Variance` and `RelativeVariance` channels.
    #[getter]
    fn aovs<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (name, a) in &self.aovs {
            d.set_item(*name, a.clone_ref(py))?;
        }
        Ok(d)
    }

    /// What the render did: `render_seconds`, `build_seconds` (0 if an earlier build was reused),
    /// `shapes_built` (whether the BVH was built for it), `samples`, `rays`, `samples_per_second`,
    /// `rays_per_second`, `spp`, `spp_requested` (None for a time-limited render without spp), `integrator`,
    /// `wavelengths`, `threads`, `triangles`, `lights`.
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = &self.statistics;
        let d = PyDict::new(py);
        let secs = s.render_seconds.max(1e-9);
        d.set_item("render_seconds", s.render_seconds)?;
        d.set_item("build_seconds", s.build_seconds)?;
        d.set_item("shapes_built", s.shapes_built)?;
        d.set_item("samples", s.samples)?;
        d.set_item("rays", s.rays)?;
        d.set_item("samples_per_second", s.samples as f64 / secs)?;
        d.set_item("rays_per_second", s.rays as f64 / secs)?;
        d.set_item("spp", self.spp)?;
        d.set_item("spp_requested", s.spp_requested)?;
        d.set_item("integrator", s.integrator)?;
        d.set_item("wavelengths", s.wavelengths)?;
        d.set_item("threads", s.threads)?;
        d.set_item("triangles", s.triangles)?;
        d.set_item("lights", s.lights)?;
        Ok(d)
    }

    /// The pixels this image holds within the full image, `(x0, x1, y0, y1)` (half-open; a crop's, or the whole
    /// image's).
    #[getter]
    fn bounds(&self) -> (u32, u32, u32, u32) {
        let b = self.film.bounds();
        (b.x0, b.x1, b.y0, b.y1)
    }

    /// Writes the image as the command line does, by the path's extension: `.exr` (linear; spectral films add
    /// their buckets, AOVs their channels), `.png` (the film's display view, 8-bit) or `.pfm`; atomically.
    fn save(&self, py: Python<'_>, path: std::path::PathBuf) -> PyResult<()> {
        let attributes = [("samplesPerPixel".to_string(), self.spp.to_string())];
        py.detach(|| film::write_image_with(&self.film, &path, &attributes))
            .map_err(|e| PyOSError::new_err(e.to_string()))
    }

    /// The 8-bit display image the command line's PNG holds, `height × width × 3` uint8: through `view` ("oklab",
    /// the default, or "clip"; the film's own if None) into the film's colour space, sRGB-encoded and dithered.
    #[pyo3(signature = (view=None))]
    fn display(&self, py: Python<'_>, view: Option<&str>) -> PyResult<Py<PyArray3<u8>>> {
        let bytes = self.encoding(view)?.encode_8bit(&self.film.to_rgb_image(), self.width);
        let array = Array3::from_shape_vec((self.height as usize, self.width as usize, 3), bytes)
            .map_err(|e| PyRuntimeError::new_err(format!("display image: {e}")))?;
        Ok(array.into_pyarray(py).unbind())
    }

    /// The PNG the command line writes (Jupyter shows an Image inline through this).
    fn _repr_png_<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        let png = film::encode_display_png(
            "image.png",
            self.width,
            self.height,
            &self.film.to_rgb_image(),
            &self.encoding(None)?,
        )
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        Ok(PyBytes::new(py, &png))
    }

    fn __repr__(&self) -> String {
        format!("<prismatic.Image {}×{}, {} spp>", self.width, self.height, self.spp)
    }
}

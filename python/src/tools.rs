//! The optics and colour tools of the command line (`prismatic ior`, `prismatic spectrum`) for Python: indices of
//! refraction, the catalogue, prism deviation, rainbow angles, and spectra with their colours.

use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;

/// n at each wavelength, and k for a material that absorbs.
type IndexArrays = (Py<PyArray1<f64>>, Option<Py<PyArray1<f64>>>);

/// A catalogue material: name, category, n_d, V_d, valid range (nm), source.
type CatalogueRow = (String, String, Option<f64>, Option<f64>, (f64, f64), String);

/// The values of `a`, each checked by `valid` (else ValueError naming `name` and saying `what` they must be).
fn checked<'a>(
    a: &'a PyReadonlyArray1<'_, f64>,
    name: &str,
    what: &str,
    valid: impl Fn(f64) -> bool,
) -> PyResult<&'a [f64]> {
    let values = a.as_slice()?;
    match values.iter().find(|v| !valid(**v)) {
        Some(bad) => Err(PyValueError::new_err(format!("{name}: {what}, got {bad}"))),
        None => Ok(values),
    }
}

/// n(λ) and, for a material that absorbs (a metal), k(λ) of catalogue material `name` at each of `nm` (nm):
/// what `prismatic ior NAME --nm …` prints. `prismatic.ior` wraps it for any array shape.
#[pyfunction]
pub fn _ior(py: Python<'_>, name: &str, nm: PyReadonlyArray1<'_, f64>) -> PyResult<IndexArrays> {
    let entry = optics::catalogue::lookup(name).map_err(|e| PyValueError::new_err(format!("name: {e}")))?;
    let nm = checked(&nm, "nm", "wavelengths are positive numbers of nanometres", |l| l.is_finite() && l > 0.0)?;
    let n: Vec<f64> = nm.iter().map(|&l| entry.ior.n(l)).collect();
    use optics::catalogue::Category;
    let k = match entry.category {
        Category::Metal => Some(nm.iter().map(|&l| entry.ior.k(l)).collect::<Vec<f64>>()),
        Category::SchottGlass
        | Category::HoyaGlass
        | Category::Glass
        | Category::Liquid
        | Category::Crystal
        | Category::UniaxialCrystal => None,
    };
    Ok((PyArray1::from_vec(py, n).unbind(), k.map(|k| PyArray1::from_vec(py, k).unbind())))
}

/// The catalogue `prismatic ior --list` prints: (name, category, n_d or None, V_d or None, valid range in nm,
/// source) per material.
#[pyfunction]
pub fn _catalogue() -> Vec<CatalogueRow> {
    optics::catalogue::entries()
        .iter()
        .map(|e| {
            (
                e.name.to_string(),
                e.category.to_string(),
                e.dispersion.as_ref().map(|d| d.nd),
                e.dispersion.as_ref().map(|d| d.vd),
                e.valid_range_nm,
                e.source.to_string(),
            )
        })
        .collect()
}

/// The minimum deviation (degrees) of a prism of apex angle `apex` (degrees) in air for each index in `n`
/// (`prismatic ior --prism`); NaN where no ray gets through.
#[pyfunction]
pub fn _prism_deviation(py: Python<'_>, n: PyReadonlyArray1<'_, f64>, apex: f64) -> PyResult<Py<PyArray1<f64>>> {
    if !(apex > 0.0 && apex < 180.0) {
        return Err(PyValueError::new_err(format!(
            "apex: the apex angle must be between 0 and 180 degrees, got {apex}"
        )));
    }
    let n = checked(&n, "n", "indices are finite and positive", |v| v.is_finite() && v > 0.0)?;
    let d = n.iter().map(|&n| optics::prism_minimum_deviation(n, apex.to_radians()).map_or(f64::NAN, f64::to_degrees));
    Ok(PyArray1::from_iter(py, d).unbind())
}

/// The angle (degrees) of the rainbow of `order` from the antisolar point for drops of each relative index in `n`,
/// by geometric optics (`prismatic ior --rainbow`); NaN where there is no such bow.
#[pyfunction]
pub fn _rainbow_angle(py: Python<'_>, n: PyReadonlyArray1<'_, f64>, order: u32) -> PyResult<Py<PyArray1<f64>>> {
    if order == 0 {
        return Err(PyValueError::new_err("order: the number of internal reflections must be at least 1"));
    }
    let n = checked(&n, "n", "indices are finite and positive", |v| v.is_finite() && v > 0.0)?;
    let a = n.iter().map(|&n| optics::descartes_rainbow_angle(n, order).unwrap_or(f64::NAN));
    Ok(PyArray1::from_iter(py, a).unbind())
}

/// A spectrum: `Spectrum("stdillum-D65")` (any SPEC `prismatic spectrum` takes: a named illuminant, a pbrt-v4
/// glass or metal spectrum, `blackbody:K`, `constant:V`, `rgb:R,G,B`, `rgb-illum:R,G,B`) or
/// `Spectrum(nm, values)` (linear between samples, zero outside). Call it with wavelengths in nm for its values;
/// `xyz`, `xy` and `rgb` give its colour as `prismatic spectrum` prints it.
#[pyclass(module = "prismatic._prismatic", frozen)]
pub struct Spectrum {
    spectrum: spectral::Spectrum,
    label: String,
}

fn observer(name: &str) -> PyResult<spectral::Observer> {
    spectral::Observer::ALL
        .into_iter()
        .find(|o| o.name() == name)
        .ok_or_else(|| PyValueError::new_err(format!("observer: '{name}' is not one of cie1931, cie1964")))
}

impl Spectrum {
    /// XYZ (a constant spectrum of 1 has Y = 1), or under `under` as a reflectance (a perfect white has Y = 1).
    fn xyz_of(&self, observer_name: &str, under: Option<&Bound<'_, PyAny>>) -> PyResult<spectral::Xyz> {
        let o = observer(observer_name)?;
        match under {
            None => Ok(o.spectrum_to_xyz(&self.spectrum)),
            Some(u) => {
                let light = match u.cast::<Spectrum>() {
                    Ok(s) => s.get().spectrum.clone(),
                    Err(_) => {
                        let spec: String = u.extract().map_err(|_| {
                            PyTypeError::new_err("under must be a Spectrum or a SPEC string (e.g. \"stdillum-D65\")")
                        })?;
                        optics::catalogue::spectrum_from_spec(&spec)
                            .map_err(|e| PyValueError::new_err(format!("under: {e}")))?
                    }
                };
                o.reflectance_to_xyz(&self.spectrum, &light)
                    .ok_or_else(|| PyValueError::new_err("under: the illuminant has no luminance"))
            }
        }
    }
}

#[pymethods]
impl Spectrum {
    #[new]
    #[pyo3(signature = (spec, values=None))]
    fn new(spec: Bound<'_, PyAny>, values: Option<Vec<f64>>) -> PyResult<Self> {
        if let Ok(s) = spec.extract::<String>() {
            if values.is_some() {
                return Err(PyTypeError::new_err("values are given with wavelengths, not with a SPEC string"));
            }
            let spectrum =
                optics::catalogue::spectrum_from_spec(&s).map_err(|e| PyValueError::new_err(format!("spec: {e}")))?;
            return Ok(Spectrum { spectrum, label: s });
        }
        let nm: Vec<f64> = spec
            .extract()
            .map_err(|_| PyTypeError::new_err("spec must be a SPEC string or a sequence of wavelengths in nm"))?;
        let values = values.ok_or_else(|| PyTypeError::new_err("values: wavelengths need their values"))?;
        if nm.len() != values.len() || nm.len() < 2 {
            return Err(PyValueError::new_err(format!(
                "values: {} wavelengths and {} values; at least two of each, as many of one as of the other",
                nm.len(),
                values.len()
            )));
        }
        if nm.iter().chain(&values).any(|v| !v.is_finite()) || nm.windows(2).any(|w| w[1] <= w[0]) {
            return Err(PyValueError::new_err("spec: wavelengths must increase and all values be finite"));
        }
        let label = format!("{} samples, {}–{} nm", nm.len(), nm[0], nm[nm.len() - 1]);
        let spectrum = spectral::Spectrum::piecewise_linear(nm, values)
            .map_err(|e| PyValueError::new_err(format!("spec: {e}")))?;
        Ok(Spectrum { spectrum, label })
    }

    /// The spectrum's values at wavelengths `nm` (a 1-D array of nm).
    fn __call__(&self, py: Python<'_>, nm: PyReadonlyArray1<'_, f64>) -> PyResult<Py<PyArray1<f64>>> {
        let nm = checked(&nm, "nm", "wavelengths are finite numbers of nanometres", f64::is_finite)?;
        Ok(PyArray1::from_iter(py, nm.iter().map(|&l| self.spectrum.eval(l))).unbind())
    }

    /// CIE XYZ (`observer` "cie1931" or "cie1964"), normalised so that a constant spectrum of 1 has Y = 1; with
    /// `under` (a Spectrum or SPEC), of the spectrum as a reflectance under that illuminant, normalised so that a
    /// perfect white reflector has Y = 1.
    #[pyo3(signature = (observer="cie1931", under=None))]
    fn xyz(&self, observer: &str, under: Option<Bound<'_, PyAny>>) -> PyResult<(f64, f64, f64)> {
        let x = self.xyz_of(observer, under.as_ref())?;
        Ok((x.x, x.y, x.z))
    }

    /// The chromaticity (x, y) of `xyz`.
    #[pyo3(signature = (observer="cie1931", under=None))]
    fn xy(&self, observer: &str, under: Option<Bound<'_, PyAny>>) -> PyResult<(f64, f64)> {
        let c = self.xyz_of(observer, under.as_ref())?.chromaticity();
        Ok((c[0], c[1]))
    }

    /// Linear RGB of `xyz` in `colorspace` ("srgb", "dci-p3", "rec2020" or "aces2065-1"; no chromatic adaptation).
    #[pyo3(signature = (colorspace="srgb", observer="cie1931", under=None))]
    fn rgb(&self, colorspace: &str, observer: &str, under: Option<Bound<'_, PyAny>>) -> PyResult<(f64, f64, f64)> {
        let cs = spectral::RgbColorSpace::by_name(colorspace).ok_or_else(|| {
            PyValueError::new_err(format!(
                "colorspace: '{colorspace}' is not one of {}",
                spectral::RgbColorSpace::NAMES.join(", ")
            ))
        })?;
        let rgb = cs.to_rgb(self.xyz_of(observer, under.as_ref())?);
        Ok((rgb[0], rgb[1], rgb[2]))
    }

    fn __repr__(&self) -> String {
        format!("<prismatic.Spectrum {}>", self.label)
    }
}

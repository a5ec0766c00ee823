//! Typed parameter lists, as pbrt writes them: `"float radius" [ 2 ]`, `"rgb reflectance" [ 0.5 0.5 0.5 ]`, …

use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use glam::DVec3;
use spectral::rgb_uplift::{RgbAlbedoSpectrum, RgbIlluminantSpectrum, RgbUnboundedSpectrum};
use spectral::spectrum::PiecewiseLinear;
use spectral::Spectrum;

use crate::loc::{Diagnostic, Loc, SceneError};

/// The type of a parameter, as declared before its name (`"float radius"`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ParamType {
    /// `float`: real numbers.
    Float,
    /// `integer`: whole numbers.
    Integer,
    /// `bool`: `true` or `false`.
    Bool,
    /// `string`: quoted strings.
    String,
    /// `point2`: pairs of numbers.
    Point2,
    /// `vector2`: pairs of numbers.
    Vector2,
    /// `point3` (pbrt-v3: `point`): triples of numbers.
    Point3,
    /// `vector3` (pbrt-v3: `vector`): triples of numbers.
    Vector3,
    /// `normal` or `normal3`: triples of numbers.
    Normal3,
    /// `rgb` (pbrt-v3: `color`): a linear colour in the scene's colour space, uplifted to a spectrum on use.
    Rgb,
    /// `spectrum`: a named spectrum, a file of wavelength/value pairs, or inline pairs.
    Spectrum,
    /// `blackbody`: a temperature in kelvin, giving a blackbody spectrum normalised to peak 1.
    Blackbody,
    /// `texture`: the name of a texture.
    Texture,
}

impl ParamType {
    /// The type's name as pbrt-v4 writes it.
    pub fn pbrt_name(self) -> &'static str {
        match self {
            ParamType::Float => "float",
            ParamType::Integer => "integer",
            ParamType::Bool => "bool",
            ParamType::String => "string",
            ParamType::Point2 => "point2",
            ParamType::Vector2 => "vector2",
            ParamType::Point3 => "point3",
            ParamType::Vector3 => "vector3",
            ParamType::Normal3 => "normal",
            ParamType::Rgb => "rgb",
            ParamType::Spectrum => "spectrum",
            ParamType::Blackbody => "blackbody",
            ParamType::Texture => "texture",
        }
    }

    /// How many numbers make one value of this type (1 for scalars and non-numeric types).
    pub fn numbers_per_value(self) -> usize {
        match self {
            ParamType::Point2 | ParamType::Vector2 => 2,
            ParamType::Point3 | ParamType::Vector3 | ParamType::Normal3 | ParamType::Rgb => 3,
            _ => 1,
        }
    }
}

impl fmt::Display for ParamType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.pbrt_name())
    }
}

/// How an `rgb` value becomes a spectrum, which depends on what the parameter means (as pbrt-v4's `SpectrumType`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpectrumKind {
    /// A reflectance or transmittance: every component must lie in [0, 1]; the spectrum stays in [0, 1].
    Albedo,
    /// Any non-negative quantity that is not emission (an index of refraction, a scattering coefficient, …).
    Unbounded,
    /// Emission: the colour times the colour space's illuminant (D65 for sRGB).
    Illuminant,
}

/// A float parameter that may instead name a float texture.
#[derive(Clone, Debug, PartialEq)]
pub enum FloatParam {
    /// A constant.
    Value(f64),
    /// The name of a float texture.
    Texture(String),
}

/// A spectrum parameter that may instead name a spectrum texture.
#[derive(Clone, Debug, PartialEq)]
pub enum SpectrumParam {
    /// A constant spectrum.
    Value(Spectrum),
    /// The name of a spectrum texture.
    Texture(String),
}

/// One parameter: its type, name, values and where it was written.
///
/// Only the value list that fits the type is filled: `floats` for `float`, `point*`, `vector*`, `normal`, `rgb`,
/// `blackbody` and inline `spectrum`; `ints` for `integer`; `bools` for `bool`; `strings` for `string`, `texture`
/// and named or file `spectrum` (whose spectra the parser resolves into `spectra`, one per string).
///
/// Clones share the "used" flag, so a parameter copied into several entities (an area light repeated on every shape
/// under it, an `Attribute` default) counts as used once any copy was read.
#[derive(Clone, Debug)]
pub struct Param {
    /// The declared type.
    pub ty: ParamType,
    /// The name.
    pub name: String,
    /// Where the parameter's declaration (`"type name"`) was written.
    pub loc: Loc,
    /// Numeric values of real-valued types.
    pub floats: Vec<f64>,
    /// Values of `integer` parameters.
    pub ints: Vec<i64>,
    /// Values of `bool` parameters.
    pub bools: Vec<bool>,
    /// Values of `string` and `texture` parameters, and the names or file names of a string-valued `spectrum`.
    pub strings: Vec<String>,
    /// For a string-valued `spectrum`: the spectrum each string resolved to (named spectrum or file contents).
    pub spectra: Vec<Spectrum>,
    /// Directories a relative file name is looked up in, in order (first: the directory of the file the parameter
    /// was written in).
    pub search_dirs: Vec<Arc<Path>>,
    /// True for defaults set by `Attribute`, which are not reported when unused.
    pub may_be_unused: bool,
    used: Arc<AtomicBool>,
    /// Set once the parameter was read as the name of an input file ([`ParamSet::get_filename`]).
    names_file: Arc<AtomicBool>,
}

impl PartialEq for Param {
    fn eq(&self, other: &Self) -> bool {
        self.ty == other.ty
            && self.name == other.name
            && self.loc == other.loc
            && self.floats == other.floats
            && self.ints == other.ints
            && self.bools == other.bools
            && self.strings == other.strings
            && self.spectra == other.spectra
    }
}

impl Param {
    /// An empty parameter of type `ty` called `name`, written at `loc`.
    pub fn new(ty: ParamType, name: impl Into<String>, loc: Loc) -> Self {
        Self {
            ty,
            name: name.into(),
            loc,
            floats: Vec::new(),
            ints: Vec::new(),
            bools: Vec::new(),
            strings: Vec::new(),
            spectra: Vec::new(),
            search_dirs: Vec::new(),
            may_be_unused: false,
            used: Arc::new(AtomicBool::new(false)),
            names_file: Arc::new(AtomicBool::new(false)),
        }
    }

    /// True once a getter has read the parameter (or any clone of it).
    pub fn is_used(&self) -> bool {
        self.used.load(Ordering::Relaxed)
    }

    /// Marks the parameter (and its clones) as read.
    pub fn mark_used(&self) {
        self.used.store(true, Ordering::Relaxed);
    }

    /// A copy that does not share the "used" flag with `self`.
    pub fn detached(&self) -> Self {
        let mut p = self.clone();
        p.used = Arc::new(AtomicBool::new(self.is_used()));
        p
    }

    /// How many values the parameter holds (points count once, not per coordinate).
    pub fn len(&self) -> usize {
        match self.ty {
            ParamType::Integer => self.ints.len(),
            ParamType::Bool => self.bools.len(),
            ParamType::String | ParamType::Texture => self.strings.len(),
            ParamType::Spectrum if !self.strings.is_empty() => self.strings.len(),
            ParamType::Spectrum => usize::from(!self.floats.is_empty()),
            t => self.floats.len() / t.numbers_per_value(),
        }
    }

    /// True if the parameter holds no value.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// An error about this parameter.
    pub fn error(&self, message: impl Into<String>) -> SceneError {
        SceneError::Param { loc: self.loc.clone(), ty: self.ty, name: self.name.clone(), message: message.into() }
    }

    fn check_type(&self, expected: &[ParamType]) -> Result<(), SceneError> {
        if expected.contains(&self.ty) {
            return Ok(());
        }
        let names: Vec<String> = expected.iter().map(|t| format!("'{t}'")).collect();
        let mut msg = format!("expected a parameter of type {}", names.join(" or "));
        if self.ty == ParamType::Float && expected.contains(&ParamType::Spectrum) {
            msg.push_str(" (a float is not accepted where a spectrum is expected, as in pbrt-v4)");
        }
        Err(self.error(msg))
    }

    fn check_finite(&self) -> Result<(), SceneError> {
        match self.floats.iter().find(|v| !v.is_finite()) {
            Some(v) => Err(self.error(format!("value {v} is not finite"))),
            None => Ok(()),
        }
    }

    fn one_count(&self, have: usize) -> Result<(), SceneError> {
        match have {
            1 => Ok(()),
            0 => Err(self.error("no value given")),
            n => Err(self.error(format!("expected one value, got {n}"))),
        }
    }

    fn one_float(&self) -> Result<f64, SceneError> {
        self.one_count(self.floats.len())?;
        self.check_finite()?;
        Ok(self.floats[0])
    }

    fn tuples<const N: usize>(&self) -> Result<Vec<[f64; N]>, SceneError> {
        if !self.floats.len().is_multiple_of(N) {
            return Err(self.error(format!("{} numbers is not a multiple of {N}", self.floats.len())));
        }
        self.check_finite()?;
        Ok(self.floats.chunks_exact(N).map(|c| std::array::from_fn(|i| c[i])).collect())
    }

    fn one_tuple<const N: usize>(&self) -> Result<[f64; N], SceneError> {
        let v = self.tuples::<N>()?;
        self.one_count(v.len())?;
        Ok(v[0])
    }

    fn one_string(&self) -> Result<&str, SceneError> {
        self.one_count(self.strings.len())?;
        Ok(&self.strings[0])
    }

    /// The parameter's spectrum, for a parameter of type `rgb`, `spectrum` or `blackbody`.
    fn spectrum(&self, kind: SpectrumKind) -> Result<Spectrum, SceneError> {
        let se = |e: spectral::SpectrumError| self.error(e.to_string());
        match self.ty {
            ParamType::Rgb => {
                let [r, g, b] = self.one_tuple::<3>()?;
                let rgb = [r, g, b];
                if let Some(c) = rgb.iter().find(|c| **c < 0.0) {
                    return Err(self.error(format!("component {c} is negative")));
                }
                match kind {
                    SpectrumKind::Albedo => {
                        if let Some(c) = rgb.iter().find(|c| **c > 1.0) {
                            return Err(self.error(format!(
                                "component {c} is greater than 1, but a reflectance must lie in [0, 1]"
                            )));
                        }
                        Ok(Spectrum::RgbAlbedo(RgbAlbedoSpectrum::new(rgb).map_err(se)?))
                    }
                    SpectrumKind::Unbounded => Ok(Spectrum::RgbUnbounded(RgbUnboundedSpectrum::new(rgb).map_err(se)?)),
                    SpectrumKind::Illuminant => {
                        Ok(Spectrum::RgbIlluminant(RgbIlluminantSpectrum::new(rgb).map_err(se)?))
                    }
                }
            }
            ParamType::Blackbody => {
                self.check_finite()?;
                match self.floats.as_slice() {
                    [t] => Spectrum::blackbody(*t).map_err(se),
                    // pbrt-v3's legacy form: temperature and scale.
                    [t, s] => Ok(Spectrum::blackbody(*t).map_err(se)?.scaled(*s)),
                    v => Err(self.error(format!("expected one temperature in kelvin, got {} values", v.len()))),
                }
            }
            ParamType::Spectrum if !self.strings.is_empty() => {
                let name = self.one_string()?;
                if let Some(s) = self.spectra.first() {
                    return Ok(s.clone());
                }
                spectral::named::illuminant(name).map_err(se)
            }
            ParamType::Spectrum => {
                self.check_finite()?;
                if self.floats.is_empty() {
                    return Err(self.error("no value given"));
                }
                let table = PiecewiseLinear::from_interleaved(&self.floats).map_err(se)?;
                Ok(Spectrum::PiecewiseLinear(Arc::new(table)))
            }
            _ => Err(self.error("expected a parameter of type 'rgb', 'spectrum' or 'blackbody'")),
        }
    }
}

/// A parameter list. Lookups find the parameter written last under a name (so a directive's own parameters
/// shadow `Attribute` defaults, and a repeated name takes its last value, as in pbrt-v4).
///
/// Typed getters mark what they read as used; they fail with a [`SceneError`] naming the parameter and its
/// location when it has another type, the wrong number of values, or a value that is not finite. The array getters
/// that return a bare `Option` (`get_floats`, `get_ints`, …) return `None` for a parameter of another type, which
/// then shows up in [`ParamSet::unused`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ParamSet {
    params: Vec<Param>,
}

impl ParamSet {
    /// An empty list.
    pub fn new() -> Self {
        Self::default()
    }

    /// A list of `params`, in the order written (later ones shadow earlier ones of the same name).
    pub fn from_params(params: Vec<Param>) -> Self {
        Self { params }
    }

    /// Appends a parameter, which shadows any earlier one of the same name.
    pub fn push(&mut self, p: Param) {
        self.params.push(p);
    }

    /// All parameters, in the order written.
    pub fn params(&self) -> &[Param] {
        &self.params
    }

    /// Iterates over all parameters, in the order written.
    pub fn iter(&self) -> std::slice::Iter<'_, Param> {
        self.params.iter()
    }

    /// Number of parameters.
    pub fn len(&self) -> usize {
        self.params.len()
    }

    /// True if there are no parameters.
    pub fn is_empty(&self) -> bool {
        self.params.is_empty()
    }

    /// The parameter called `name` (the last written), without marking it used.
    pub fn get(&self, name: &str) -> Option<&Param> {
        self.params.iter().rev().find(|p| p.name == name)
    }

    /// The type of the parameter called `name`, if any (to choose between, say, a `float` and a `spectrum` "eta").
    pub fn param_type(&self, name: &str) -> Option<ParamType> {
        self.get(name).map(|p| p.ty)
    }

    /// True if a parameter called `name` exists.
    pub fn contains(&self, name: &str) -> bool {
        self.get(name).is_some()
    }

    /// Marks the parameter called `name` as used (for parameters deliberately ignored without a warning).
    pub fn mark_used(&self, name: &str) {
        if let Some(p) = self.get(name) {
            p.mark_used();
        }
    }

    fn typed(&self, name: &str, ty: &[ParamType]) -> Result<Option<&Param>, SceneError> {
        match self.get(name) {
            None => Ok(None),
            Some(p) => {
                p.check_type(ty)?;
                p.mark_used();
                Ok(Some(p))
            }
        }
    }

    fn typed_opt(&self, name: &str, ty: ParamType) -> Option<&Param> {
        let p = self.get(name).filter(|p| p.ty == ty)?;
        p.mark_used();
        Some(p)
    }

    /// A single `float`, or `default` when absent.
    pub fn get_float(&self, name: &str, default: f64) -> Result<f64, SceneError> {
        self.typed(name, &[ParamType::Float])?.map_or(Ok(default), Param::one_float)
    }

    /// A single `integer`, or `default` when absent.
    pub fn get_int(&self, name: &str, default: i64) -> Result<i64, SceneError> {
        match self.typed(name, &[ParamType::Integer])? {
            None => Ok(default),
            Some(p) => {
                p.one_count(p.ints.len())?;
                Ok(p.ints[0])
            }
        }
    }

    /// A positive `integer` count (1 to 2²⁰), or `default` when absent; an out-of-range value is an error at the
    /// parameter (or at `directive` for a bad default).
    pub fn get_count(&self, name: &str, default: i64, directive: &Loc) -> Result<usize, SceneError> {
        let v = self.get_int(name, default)?;
        if v <= 0 || v > 1 << 20 {
            let message = format!("'{name}' must be a positive integer, got {v}");
            return Err(SceneError::at(self.loc_of(name, directive), message));
        }
        Ok(v as usize)
    }

    /// Where parameter `name` was written, or the directive's location `directive` if it was not.
    pub fn loc_of(&self, name: &str, directive: &Loc) -> Loc {
        self.get(name).map(|q| q.loc.clone()).unwrap_or_else(|| directive.clone())
    }

    /// A single `bool`, or `default` when absent.
    pub fn get_bool(&self, name: &str, default: bool) -> Result<bool, SceneError> {
        match self.typed(name, &[ParamType::Bool])? {
            None => Ok(default),
            Some(p) => {
                p.one_count(p.bools.len())?;
                Ok(p.bools[0])
            }
        }
    }

    /// A single `string`, or `default` when absent.
    pub fn get_string(&self, name: &str, default: &str) -> Result<String, SceneError> {
        match self.typed(name, &[ParamType::String])? {
            None => Ok(default.to_owned()),
            Some(p) => p.one_string().map(str::to_owned),
        }
    }

    /// All values of a `float` parameter (`None` if absent or of another type).
    pub fn get_floats(&self, name: &str) -> Option<&[f64]> {
        self.typed_opt(name, ParamType::Float).map(|p| p.floats.as_slice())
    }

    /// An `rgb` parameter's three values as written (no uplift), `None` when absent; another type or count is an
    /// error naming the parameter.
    pub fn get_rgb(&self, name: &str) -> Result<Option<[f64; 3]>, SceneError> {
        let Some(p) = self.typed(name, &[ParamType::Rgb])? else { return Ok(None) };
        match p.floats.as_slice() {
            &[r, g, b] => Ok(Some([r, g, b])),
            other => Err(SceneError::at(p.loc.clone(), format!("'{name}' needs 3 values, got {}", other.len()))),
        }
    }

    /// All values of an `integer` parameter (`None` if absent or of another type).
    pub fn get_ints(&self, name: &str) -> Option<&[i64]> {
        self.typed_opt(name, ParamType::Integer).map(|p| p.ints.as_slice())
    }

    /// All values of a `bool` parameter (`None` if absent or of another type).
    pub fn get_bools(&self, name: &str) -> Option<&[bool]> {
        self.typed_opt(name, ParamType::Bool).map(|p| p.bools.as_slice())
    }

    /// All values of a `string` parameter (`None` if absent or of another type).
    pub fn get_strings(&self, name: &str) -> Option<&[String]> {
        self.typed_opt(name, ParamType::String).map(|p| p.strings.as_slice())
    }

    /// All values of a `point2` parameter.
    pub fn get_point2s(&self, name: &str) -> Result<Option<Vec<[f64; 2]>>, SceneError> {
        self.typed(name, &[ParamType::Point2])?.map(Param::tuples::<2>).transpose()
    }

    /// All values of a `vector2` parameter.
    pub fn get_vector2s(&self, name: &str) -> Result<Option<Vec<[f64; 2]>>, SceneError> {
        self.typed(name, &[ParamType::Vector2])?.map(Param::tuples::<2>).transpose()
    }

    /// All values of a `point3` parameter.
    pub fn get_point3s(&self, name: &str) -> Result<Option<Vec<DVec3>>, SceneError> {
        self.vec3s(name, ParamType::Point3)
    }

    /// All values of a `vector3` parameter.
    pub fn get_vector3s(&self, name: &str) -> Result<Option<Vec<DVec3>>, SceneError> {
        self.vec3s(name, ParamType::Vector3)
    }

    /// All values of a `normal` parameter.
    pub fn get_normals(&self, name: &str) -> Result<Option<Vec<DVec3>>, SceneError> {
        self.vec3s(name, ParamType::Normal3)
    }

    fn vec3s(&self, name: &str, ty: ParamType) -> Result<Option<Vec<DVec3>>, SceneError> {
        let v = self.typed(name, &[ty])?.map(Param::tuples::<3>).transpose()?;
        Ok(v.map(|v| v.into_iter().map(DVec3::from_array).collect()))
    }

    /// A single `point2`, or `default` when absent.
    pub fn get_point2(&self, name: &str, default: [f64; 2]) -> Result<[f64; 2], SceneError> {
        self.typed(name, &[ParamType::Point2])?.map_or(Ok(default), Param::one_tuple::<2>)
    }

    /// A single `point3`, or `default` when absent.
    pub fn get_point3(&self, name: &str, default: DVec3) -> Result<DVec3, SceneError> {
        self.typed(name, &[ParamType::Point3])?.map_or(Ok(default), |p| p.one_tuple::<3>().map(DVec3::from_array))
    }

    /// A single `vector3`, or `default` when absent.
    pub fn get_vector3(&self, name: &str, default: DVec3) -> Result<DVec3, SceneError> {
        self.typed(name, &[ParamType::Vector3])?.map_or(Ok(default), |p| p.one_tuple::<3>().map(DVec3::from_array))
    }

    /// A single `normal`, or `default` when absent.
    pub fn get_normal(&self, name: &str, default: DVec3) -> Result<DVec3, SceneError> {
        self.typed(name, &[ParamType::Normal3])?.map_or(Ok(default), |p| p.one_tuple::<3>().map(DVec3::from_array))
    }

    /// A `string` parameter naming an input file, resolved against the directory of the file the parameter was
    /// written in (then, if it is not there, against the main scene file's directory, where pbrt-v4 looks).
    /// Absolute paths are returned as they are; `None` if the parameter is absent or the empty string.
    pub fn get_filename(&self, name: &str) -> Result<Option<PathBuf>, SceneError> {
        let Some(p) = self.typed(name, &[ParamType::String])? else { return Ok(None) };
        let s = p.one_string()?;
        p.names_file.store(true, Ordering::Relaxed);
        Ok(resolve_file(p, s))
    }

    /// The files named by parameters read with [`ParamSet::get_filename`] so far, resolved as it resolves them.
    pub fn files_read(&self) -> Vec<PathBuf> {
        self.params
            .iter()
            .filter(|p| p.names_file.load(Ordering::Relaxed))
            .filter_map(|p| p.strings.first().and_then(|s| resolve_file(p, s)))
            .collect()
    }

    /// The texture name of a `texture` parameter (`None` if absent, of another type, or empty).
    pub fn get_texture(&self, name: &str) -> Option<String> {
        self.typed_opt(name, ParamType::Texture).and_then(|p| p.strings.first().cloned())
    }

    /// A spectrum given as `rgb` (uplifted according to `kind`), `blackbody`, or `spectrum` (named, from a file, or
    /// inline λ/value pairs); `None` when absent. Any other type, a `float` included, is an error.
    pub fn get_spectrum(&self, name: &str, kind: SpectrumKind) -> Result<Option<Spectrum>, SceneError> {
        self.typed(name, &[ParamType::Rgb, ParamType::Spectrum, ParamType::Blackbody])?
            .map(|p| p.spectrum(kind))
            .transpose()
    }

    /// A `float` or the name of a float `texture`; `FloatParam::Value(default)` when absent.
    pub fn get_float_texture(&self, name: &str, default: f64) -> Result<FloatParam, SceneError> {
        match self.typed(name, &[ParamType::Float, ParamType::Texture])? {
            None => Ok(FloatParam::Value(default)),
            Some(p) if p.ty == ParamType::Texture => p.one_string().map(|s| FloatParam::Texture(s.to_owned())),
            Some(p) => p.one_float().map(FloatParam::Value),
        }
    }

    /// A spectrum (as [`ParamSet::get_spectrum`]) or the name of a spectrum `texture`; `None` when absent.
    pub fn get_spectrum_texture(&self, name: &str, kind: SpectrumKind) -> Result<Option<SpectrumParam>, SceneError> {
        let ty = [ParamType::Rgb, ParamType::Spectrum, ParamType::Blackbody, ParamType::Texture];
        match self.typed(name, &ty)? {
            None => Ok(None),
            Some(p) if p.ty == ParamType::Texture => p.one_string().map(|s| Some(SpectrumParam::Texture(s.to_owned()))),
            Some(p) => p.spectrum(kind).map(|s| Some(SpectrumParam::Value(s))),
        }
    }

    /// A warning for every parameter no getter read (except `Attribute` defaults, and parameters shadowed by a
    /// used one of the same name), in the order written: "unused parameter 'float foo'".
    pub fn unused(&self) -> Vec<Diagnostic> {
        self.params
            .iter()
            .filter(|p| !p.is_used() && !p.may_be_unused)
            .filter(|p| !self.params.iter().any(|q| q.name == p.name && q.is_used()))
            .map(|p| Diagnostic::new(p.loc.clone(), format!("unused parameter '{} {}'", p.ty, p.name)))
            .collect()
    }
}

/// File name `s` of parameter `p` resolved against its search directories (see [`ParamSet::get_filename`]).
fn resolve_file(p: &Param, s: &str) -> Option<PathBuf> {
    if s.is_empty() {
        return None;
    }
    let path = Path::new(s);
    if path.is_absolute() {
        return Some(path.to_path_buf());
    }
    let candidates: Vec<PathBuf> = p.search_dirs.iter().map(|d| d.join(path)).collect();
    Some(candidates.iter().find(|c| c.exists()).or(candidates.first()).cloned().unwrap_or_else(|| path.to_path_buf()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn loc(line: u32) -> Loc {
        Loc::new(Arc::from(Path::new("t.pbrt")), line, 5)
    }

    fn float(name: &str, v: &[f64], line: u32) -> Param {
        let mut p = Param::new(ParamType::Float, name, loc(line));
        p.floats = v.to_vec();
        p
    }

    #[test]
    fn getters_check_type_count_and_finiteness() {
        let mut rgb = Param::new(ParamType::Rgb, "Kd", loc(4));
        rgb.floats = vec![0.2, 1.5, 0.1];
        let set = ParamSet::from_params(vec![
            float("a", &[1.0], 1),
            float("b", &[1.0, 2.0], 2),
            float("c", &[f64::NAN], 3),
            rgb,
        ]);
        assert_eq!(set.get_float("a", 0.0).unwrap(), 1.0);
        assert_eq!(set.get_float("zz", 7.0).unwrap(), 7.0);
        let e = set.get_float("b", 0.0).unwrap_err().to_string();
        assert!(e.starts_with("t.pbrt:2:5: error: parameter 'float b'") && e.contains("one value"), "{e}");
        assert!(set.get_float("c", 0.0).unwrap_err().to_string().contains("not finite"));
        let e = set.get_int("a", 0).unwrap_err().to_string();
        assert!(e.contains("'integer'"), "{e}");
        let e = set.get_spectrum("Kd", SpectrumKind::Albedo).unwrap_err().to_string();
        assert!(e.contains("t.pbrt:4:5") && e.contains("'rgb Kd'") && e.contains("greater than 1"), "{e}");
        assert!(set.get_spectrum("Kd", SpectrumKind::Unbounded).unwrap().is_some());
        let e = set.get_spectrum("a", SpectrumKind::Unbounded).unwrap_err().to_string();
        assert!(e.contains("float is not accepted"), "{e}");
    }

    #[test]
    fn last_written_wins_and_unused_reports_the_rest() {
        let mut attr = float("r", &[9.0], 1);
        attr.may_be_unused = true;
        let set =
            ParamSet::from_params(vec![attr, float("r", &[1.0], 2), float("r", &[2.0], 3), float("x", &[0.0], 4)]);
        assert_eq!(set.get_float("r", 0.0).unwrap(), 2.0);
        let u = set.unused();
        assert_eq!(u.len(), 1);
        assert_eq!(u[0].to_string(), "t.pbrt:4:5: warning: unused parameter 'float x'");
    }

    #[test]
    fn textures_or_values() {
        let mut t = Param::new(ParamType::Texture, "roughness", loc(1));
        t.strings.push("rough".into());
        let set = ParamSet::from_params(vec![t, float("eta", &[1.5], 2)]);
        assert_eq!(set.get_float_texture("roughness", 0.0).unwrap(), FloatParam::Texture("rough".into()));
        assert_eq!(set.get_float_texture("eta", 1.0).unwrap(), FloatParam::Value(1.5));
        assert_eq!(set.get_float_texture("none", 0.25).unwrap(), FloatParam::Value(0.25));
        assert_eq!(set.get_spectrum_texture("none", SpectrumKind::Albedo).unwrap(), None);
        assert_eq!(set.param_type("eta"), Some(ParamType::Float));
    }
}

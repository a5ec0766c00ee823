//! The film: per-pixel accumulators of filtered camera samples.
//!
//! Every pixel keeps, in `f64`, the weighted sum of the CIE XYZ of its samples and the sum of their filter weights
//! (the pixel's colour is the ratio), and, for a spectral film, `nbuckets` weighted sums of spectral radiance over
//! equal wavelength buckets between `lambda_min` and `lambda_max`. A path sample carries a handful of wavelengths
//! λᵢ with estimates Lᵢ/pdfᵢ (the renderer divides by the *effective* density of each wavelength, whatever the
//! strategy: `rgb`, `cmf` or `hero`); each goes whole into the bucket containing λᵢ, divided by the bucket's width.
//! The expectation of a bucket is then the mean spectral radiance over the bucket (per nm), for any wavelength
//! strategy — unlike pbrt-v4's spectral film, which averages Lᵢ without the pdf and so is right only for uniform
//! wavelength sampling.
//!
//! Light-tracing integrators (`lightpath`, `bdpt`) also *splat*: a contribution found by connecting a light path to
//! the camera lands at a raster position of its own, spread over the pixels around it by the pixel filter
//! (normalised to unit integral). Splats are kept apart from the camera samples, and a pixel's value is
//! `camera sum / weight sum + splat sum · (pixels / light paths)`: each light path estimates the whole image, so the
//! splat sums divided by the number of light paths per pixel are in the same units (radiance) as camera samples, for
//! the RGB and the spectral film alike.
//!
//! Rendering threads write disjoint rows ([`Film::par_rows_mut`]) without locks; since the filter is importance
//! sampled ([`crate::FilterSampler`]) each camera sample lands in its own pixel, so the result does not depend on the
//! thread count. Films rendered separately (other processes, other sample ranges) add up with [`Film::merge`].

use crate::{FilmError, Filter, View};
use rayon::prelude::*;
use spectral::color::{mul_mat_vec, white_balance_matrix, Mat3};
use spectral::sensor::CameraSensor;
use spectral::{
    Observer, RgbColorSpace, SampledSpectrum, SampledWavelengths, Spectrum, WavelengthSampler, WavelengthStrategy, Xyz,
    N_WAVELENGTHS,
};
use std::path::PathBuf;

mod gbuffer;
mod state;
pub use gbuffer::{GBufferImages, GBufferPixel, VisibleSurface};
pub use state::{FilmState, Plane};

/// What a film records besides colour.
#[derive(Clone, Debug, PartialEq)]
pub enum FilmKind {
    /// pbrt-v4's `rgb` film: colour only.
    Rgb,
    /// pbrt-v4's `spectral` film: colour plus `nbuckets` equal buckets of spectral radiance over
    /// `[lambda_min, lambda_max)` nm, written in the spectral EXR layout of Fichet et al. 2021.
    Spectral {
        /// Number of buckets (pbrt-v4 default 16).
        nbuckets: usize,
        /// Lower end of the first bucket in nm (pbrt-v4 default 360).
        lambda_min: f64,
        /// Upper end of the last bucket in nm (pbrt-v4 default 830).
        lambda_max: f64,
    },
}

impl FilmKind {
    /// pbrt-v4's default bucket count for the spectral film.
    pub const DEFAULT_NBUCKETS: usize = 16;
    /// pbrt-v4's default `lambdamin` (nm).
    pub const DEFAULT_LAMBDA_MIN: f64 = 360.0;
    /// pbrt-v4's default `lambdamax` (nm).
    pub const DEFAULT_LAMBDA_MAX: f64 = 830.0;

    /// The spectral film with pbrt-v4's defaults: 16 buckets over 360–830 nm.
    pub fn spectral_default() -> Self {
        FilmKind::Spectral {
            nbuckets: Self::DEFAULT_NBUCKETS,
            lambda_min: Self::DEFAULT_LAMBDA_MIN,
            lambda_max: Self::DEFAULT_LAMBDA_MAX,
        }
    }

    /// Checks the spectral parameters, naming the first bad one (`nbuckets`, `lambdamin`, `lambdamax`).
    pub fn validate(&self) -> Result<(), FilmError> {
        if let FilmKind::Spectral { nbuckets, lambda_min, lambda_max } = *self {
            if nbuckets < 1 {
                return Err(FilmError::InvalidParameter {
                    name: "nbuckets",
                    value: nbuckets as f64,
                    expected: "at least 1",
                });
            }
            if !(spectral::LAMBDA_MIN..spectral::LAMBDA_MAX).contains(&lambda_min) {
                return Err(FilmError::InvalidParameter {
                    name: "lambdamin",
                    value: lambda_min,
                    expected: "a wavelength in [360, 830) nm",
                });
            }
            if !(lambda_max > lambda_min && lambda_max <= spectral::LAMBDA_MAX) {
                return Err(FilmError::InvalidParameter {
                    name: "lambdamax",
                    value: lambda_max,
                    expected: "a wavelength greater than lambdamin and at most 830 nm",
                });
            }
        }
        Ok(())
    }

    /// Number of spectral buckets (0 for an RGB film).
    pub fn nbuckets(&self) -> usize {
        match *self {
            FilmKind::Rgb => 0,
            FilmKind::Spectral { nbuckets, .. } => nbuckets,
        }
    }

    /// Width of one bucket in nm (0 for an RGB film).
    pub fn bucket_width(&self) -> f64 {
        match *self {
            FilmKind::Rgb => 0.0,
            FilmKind::Spectral { nbuckets, lambda_min, lambda_max } => (lambda_max - lambda_min) / nbuckets as f64,
        }
    }

    /// The buckets' central wavelengths in nm, ascending (empty for an RGB film).
    pub fn bucket_centres(&self) -> Vec<f64> {
        match *self {
            FilmKind::Rgb => Vec::new(),
            FilmKind::Spectral { nbuckets, lambda_min, .. } => {
                let w = self.bucket_width();
                (0..nbuckets).map(|b| lambda_min + (b as f64 + 0.5) * w).collect()
            }
        }
    }

    /// The bucket holding wavelength `lambda` (nm): `None` outside `[lambda_min, lambda_max)`, for NaN, and for an
    /// RGB film.
    pub fn bucket_of(&self, lambda: f64) -> Option<usize> {
        match *self {
            FilmKind::Rgb => None,
            FilmKind::Spectral { nbuckets, lambda_min, lambda_max } => {
                if !(lambda >= lambda_min && lambda < lambda_max) {
                    return None;
                }
                let b = ((lambda - lambda_min) / (lambda_max - lambda_min) * nbuckets as f64) as usize;
                Some(b.min(nbuckets - 1))
            }
        }
    }
}

/// pbrt-v4's pixel sensor: what a sample's radiance is recorded as, its imaging ratio, and how the recorded values
/// become XYZ.
///
/// The default `cie1931` sensor records CIE 1931 XYZ and optionally white-balances the image from the chromaticity
/// of a scene illuminant to the output colour space's white. A measured camera sensor ([`CameraResponse`]) records
/// the camera's raw r, g, b and maps them to XYZ with a fitted matrix, which white-balances too.
///
/// pbrt-v4 (`PixelSensor::Create`) sets the imaging ratio to exposure time × ISO / 100, the exposure time being
/// the camera's `shutterclose` − `shutteropen` (defaults 1 and 0) and `iso` defaulting to 100, so that by default
/// the ratio is exactly 1. The ratio scales the colour of every sample (before the `maxcomponentvalue` clamp) but
/// not the spectral buckets, as in pbrt-v4's spectral film.
#[derive(Clone, Debug, PartialEq)]
pub struct PixelSensor {
    /// Factor applied to every sample's sensor value (pbrt-v4's `imagingRatio`; 1 by default).
    pub imaging_ratio: f64,
    /// Chromaticity of the illuminant to white-balance from (pbrt-v4's `whitebalance` temperature, converted by
    /// [`spectral::daylight::white_balance_chromaticity`]); `None` for no white balance, the `cie1931` default.
    /// Only for the cie1931 sensor: a camera's matrix white-balances by itself.
    pub white_balance_from: Option<[f64; 2]>,
    /// A measured camera sensor instead of cie1931 (pbrt-v4's `"string sensor"`), or `None`.
    pub camera: Option<CameraResponse>,
}

/// A measured camera sensor as a film uses it: its r̄, ḡ, b̄, and the matrix from its raw RGB to XYZ, fitted for
/// the white-balance illuminant ([`spectral::sensor::CameraSensor::xyz_from_sensor_rgb`]).
#[derive(Clone, Debug, PartialEq)]
pub struct CameraResponse {
    /// The camera.
    pub sensor: &'static CameraSensor,
    /// XYZ = M · (camera r, g, b) (pbrt-v4's `XYZFromSensorRGB`).
    pub xyz_from_sensor_rgb: Mat3,
}

impl Default for PixelSensor {
    /// Imaging ratio 1, no white balance, cie1931: pbrt-v4's default sensor.
    fn default() -> Self {
        Self { imaging_ratio: 1.0, white_balance_from: None, camera: None }
    }
}

impl PixelSensor {
    /// pbrt-v4's imaging ratio for an exposure time (s) and an ISO speed: t · ISO / 100.
    pub fn imaging_ratio(exposure_time: f64, iso: f64) -> f64 {
        exposure_time * iso / 100.0 // pbrt-v4 PixelSensor::Create: imagingRatio = exposureTime · ISO / 100
    }

    /// The sensor-value → XYZ matrix applied to the accumulated pixels on output: a camera's fitted matrix, or for
    /// cie1931 the Bradford von Kries adaptation from the white-balance illuminant to `color_space`'s white, or the
    /// identity without white balance.
    pub fn output_matrix(&self, color_space: &RgbColorSpace) -> Mat3 {
        if let Some(camera) = &self.camera {
            return camera.xyz_from_sensor_rgb;
        }
        match self.white_balance_from {
            Some(from) => white_balance_matrix(from, color_space.white),
            None => [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        }
    }
}

/// A rectangle of pixels of the full image, half-open: `x0 ≤ x < x1`, `y0 ≤ y < y1` (pbrt-v4's pixel bounds; rows
/// from the top).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PixelBounds {
    /// First column.
    pub x0: u32,
    /// One past the last column.
    pub x1: u32,
    /// First row.
    pub y0: u32,
    /// One past the last row.
    pub y1: u32,
}

impl PixelBounds {
    /// The whole `width`×`height` image.
    pub fn full(width: u32, height: u32) -> Self {
        Self { x0: 0, x1: width, y0: 0, y1: height }
    }

    /// Width in pixels (0 if empty).
    pub fn width(&self) -> u32 {
        self.x1.saturating_sub(self.x0)
    }

    /// Height in pixels (0 if empty).
    pub fn height(&self) -> u32 {
        self.y1.saturating_sub(self.y0)
    }

    /// Whether (x, y) lies inside.
    pub fn contains(&self, x: u32, y: u32) -> bool {
        (self.x0..self.x1).contains(&x) && (self.y0..self.y1).contains(&y)
    }
}

/// Everything that defines a film: pbrt-v4's `Film` directive plus the pixel filter.
#[derive(Clone, Debug, PartialEq)]
pub struct FilmSpec {
    /// Width in pixels (`xresolution`, pbrt-v4 default 1280).
    pub width: u32,
    /// Height in pixels (`yresolution`, pbrt-v4 default 720).
    pub height: u32,
    /// Where the image goes; the extension chooses the format (see [`crate::write_image`]).
    pub filename: PathBuf,
    /// RGB or spectral.
    pub kind: FilmKind,
    /// The colour space of the RGB output (pbrt-v4 default sRGB): the EXR's `R`, `G`, `B` and `chromaticities`, and
    /// the PNG's display space when it is one ([`crate::display_space_for`]).
    pub color_space: RgbColorSpace,
    /// How the PNG shows colours outside the display's gamut or brighter than its white (default
    /// [`View::Oklab`]); linear outputs ignore it.
    pub view: View,
    /// The pixel reconstruction filter (pbrt-v4 default: gaussian, radius 1.5, σ 0.5).
    pub filter: Filter,
    /// Whether to accumulate the albedo and normal AOVs (written as EXR layers `albedo` and `N`). Off by default.
    pub aovs: bool,
    /// The pixel sensor: imaging ratio and white balance (pbrt-v4 default: ratio 1, no white balance).
    pub sensor: PixelSensor,
    /// `maxcomponentvalue`: a sample whose largest sensor component (XYZ for the cie1931 sensor, after the imaging
    /// ratio, before white balance) exceeds it is scaled down to it, colour and spectral buckets alike (pbrt-v4
    /// `RGBFilm::AddSample`; default infinity, no clamp).
    pub max_component_value: f64,
    /// How paths draw their wavelengths and how their radiance becomes colour (`rgb`, `cmf` or `hero`, the
    /// default): the film samples the wavelengths ([`Film::sample_wavelengths`]) and converts with the same
    /// strategy, as pbrt-v4's film does with its sensor.
    pub wavelengths: WavelengthStrategy,
    /// The observer colours are measured with (CIE 1931 2°, as pbrt-v4's `cie1931` sensor).
    pub observer: Observer,
    /// The pixels rendered and written (pbrt-v4's `pixelbounds`, or its `cropwindow` turned into pixels); `None`
    /// for the whole image. The camera still frames the whole `width`×`height` image, and every pixel keeps its
    /// coordinates (and so its random numbers), so a crop holds exactly the full render's pixels.
    pub pixel_bounds: Option<PixelBounds>,
    /// Write EXR channels as 16-bit half floats (pbrt-v4's `savefp16`; values above 65504 are clamped to it).
    pub write_fp16: bool,
    /// pbrt-v4's `gbuffer` film: the AOVs are written under its channel names (`Albedo.R`, `Ns.X`, …) with its
    /// geometry channels (`P.X`, `dzdx`, `N.X`, `u`, `Variance.R`, …; see [`VisibleSurface`]). `None` for the `rgb`
    /// and `spectral` films.
    pub gbuffer: Option<GBuffer>,
}

/// What pbrt-v4's `gbuffer` film changes in the output.
#[derive(Clone, Debug, PartialEq)]
pub struct GBuffer {
    /// The coordinate system of positions, normals (shading normals included) and depth derivatives. The
    /// renderer transforms each sample's values before it adds them (so a moving camera's space is the one at
    /// the sample's time, as in pbrt-v4).
    pub coordinates: GBufferCoordinates,
}

/// pbrt-v4's `"string coordinatesystem"` of the gbuffer film.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GBufferCoordinates {
    /// pbrt-v4's camera space (the default): the camera at the origin looking down +z.
    Camera,
    /// World space.
    World,
}

impl Default for FilmSpec {
    /// pbrt-v4's defaults: 1280×720, `pbrt.exr`, RGB in sRGB, gaussian filter, no AOVs.
    fn default() -> Self {
        Self::new(1280, 720, "pbrt.exr")
    }
}

impl FilmSpec {
    /// An RGB film of the given size and file name, in sRGB, with the default gaussian filter and no AOVs.
    pub fn new(width: u32, height: u32, filename: impl Into<PathBuf>) -> Self {
        Self {
            width,
            height,
            filename: filename.into(),
            kind: FilmKind::Rgb,
            color_space: RgbColorSpace::srgb(),
            view: View::default(),
            filter: Filter::default(),
            aovs: false,
            sensor: PixelSensor::default(),
            max_component_value: f64::INFINITY,
            wavelengths: WavelengthStrategy::default(),
            observer: Observer::Cie1931,
            pixel_bounds: None,
            write_fp16: false,
            gbuffer: None,
        }
    }

    /// The pixels rendered: [`FilmSpec::pixel_bounds`] or the whole image.
    pub fn bounds(&self) -> PixelBounds {
        self.pixel_bounds.unwrap_or(PixelBounds::full(self.width, self.height))
    }

    /// Checks the resolution (`xresolution`, `yresolution` ≥ 1), `maxcomponentvalue` (> 0), the imaging ratio
    /// (finite, > 0), the spectral parameters and the filter.
    pub fn validate(&self) -> Result<(), FilmError> {
        for (name, value) in [("xresolution", self.width), ("yresolution", self.height)] {
            if value < 1 {
                return Err(FilmError::InvalidParameter { name, value: value as f64, expected: "at least 1" });
            }
        }
        if self.max_component_value.is_nan() || self.max_component_value <= 0.0 {
            return Err(FilmError::InvalidParameter {
                name: "maxcomponentvalue",
                value: self.max_component_value,
                expected: "a number above 0 (or infinity for no clamp)",
            });
        }
        let ratio = self.sensor.imaging_ratio;
        if !(ratio.is_finite() && ratio > 0.0) {
            return Err(FilmError::InvalidParameter {
                name: "imaging ratio (exposure time × iso / 100)",
                value: ratio,
                expected: "a finite number above 0",
            });
        }
        let b = self.bounds();
        if b.width() == 0 || b.height() == 0 || b.x1 > self.width || b.y1 > self.height {
            return Err(FilmError::InvalidParameter {
                name: "pixelbounds",
                value: f64::NAN,
                expected: "a non-empty rectangle of pixels inside the image",
            });
        }
        self.kind.validate()?;
        self.filter.validate()
    }
}

/// The film: per-pixel `f64` accumulators. See the module documentation.
#[derive(Clone, Debug)]
pub struct Film {
    spec: FilmSpec,
    /// The pixels stored (the spec's pixel bounds or the whole image).
    bounds: PixelBounds,
    nbuckets: usize,
    /// Wavelength sampling, colour conversion, sensor response and bucket assignment.
    conversion: SampleConversion,
    /// XYZ → output XYZ (the sensor's white balance, or the identity).
    output_matrix: Mat3,
    /// Weighted XYZ sums, one per pixel, row-major from the top row.
    xyz: Vec<[f64; 3]>,
    /// Filter-weight sums, one per pixel.
    weight: Vec<f64>,
    /// Weighted bucket sums, `nbuckets` per pixel, pixel-major.
    buckets: Vec<f64>,
    /// Albedo sums (empty without AOVs).
    albedo: Vec<[f64; 3]>,
    /// Normal sums (empty without AOVs).
    normal: Vec<[f64; 3]>,
    /// Number of AOV records per pixel (empty without AOVs).
    aov_count: Vec<f64>,
    /// The gbuffer's sums per pixel (empty without a gbuffer; see the `gbuffer` module).
    surfaces: Vec<[f64; gbuffer::NSUMS]>,
    /// Samples dropped for non-finite values or out-of-range coordinates, per row.
    rejected: Vec<u64>,
    /// Splatted XYZ sums (empty until the first splat).
    splat_xyz: Vec<[f64; 3]>,
    /// Splatted bucket sums (empty until the first splat on a spectral film).
    splat_buckets: Vec<f64>,
    /// Number of light paths whose splats were added (see the module documentation).
    light_paths: f64,
    /// Splats dropped for non-finite values.
    rejected_splats: u64,
}

fn zeroed<T: Clone>(n: usize, value: T) -> Option<Vec<T>> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).ok()?;
    v.resize(n, value);
    Some(v)
}

impl Film {
    /// Validates the spec and allocates zeroed accumulators; an allocation too large for memory is an error, not
    /// an abort.
    pub fn new(spec: FilmSpec) -> Result<Self, FilmError> {
        spec.validate()?;
        let nbuckets = spec.kind.nbuckets();
        let bounds = spec.bounds();
        let too_large = || FilmError::TooLarge {
            width: bounds.width(),
            height: bounds.height(),
            channels: 4
                + nbuckets
                + if spec.aovs { 7 } else { 0 }
                + if spec.gbuffer.is_some() { gbuffer::NSUMS } else { 0 },
        };
        let npix = (bounds.width() as usize).checked_mul(bounds.height() as usize).ok_or_else(too_large)?;
        let nb = npix.checked_mul(nbuckets).ok_or_else(too_large)?;
        let naov = if spec.aovs { npix } else { 0 };
        let nsurf = if spec.gbuffer.is_some() { npix } else { 0 };
        Ok(Self {
            nbuckets,
            conversion: SampleConversion::new(&spec),
            output_matrix: spec.sensor.output_matrix(&spec.color_space),
            xyz: zeroed(npix, [0.0; 3]).ok_or_else(too_large)?,
            weight: zeroed(npix, 0.0).ok_or_else(too_large)?,
            buckets: zeroed(nb, 0.0).ok_or_else(too_large)?,
            albedo: zeroed(naov, [0.0; 3]).ok_or_else(too_large)?,
            normal: zeroed(naov, [0.0; 3]).ok_or_else(too_large)?,
            aov_count: zeroed(naov, 0.0).ok_or_else(too_large)?,
            surfaces: zeroed(nsurf, [0.0; gbuffer::NSUMS]).ok_or_else(too_large)?,
            rejected: zeroed(bounds.height() as usize, 0).ok_or_else(too_large)?,
            splat_xyz: Vec::new(),
            splat_buckets: Vec::new(),
            light_paths: 0.0,
            rejected_splats: 0,
            bounds,
            spec,
        })
    }

    /// The film's definition.
    pub fn spec(&self) -> &FilmSpec {
        &self.spec
    }

    /// How the film converts path samples (colour, sensor, buckets).
    pub fn conversion(&self) -> &SampleConversion {
        &self.conversion
    }

    /// The wavelength strategy paths rendered into this film draw from.
    pub fn wavelengths(&self) -> &WavelengthSampler {
        &self.conversion.wavelengths
    }

    /// Draws the wavelengths of one path from one uniform number (pbrt-v4's `Film::SampleWavelengths`).
    pub fn sample_wavelengths(&self, u: f64) -> SampledWavelengths {
        self.conversion.wavelengths.sample(u)
    }

    /// Width of the full image in pixels (the camera's; see [`Film::bounds`] for the pixels stored).
    pub fn width(&self) -> u32 {
        self.spec.width
    }

    /// Height of the full image in pixels.
    pub fn height(&self) -> u32 {
        self.spec.height
    }

    /// The pixels the film stores and writes, in full-image coordinates; every method taking pixel coordinates
    /// takes them in full-image coordinates too.
    pub fn bounds(&self) -> PixelBounds {
        self.bounds
    }

    /// Number of spectral buckets per pixel (0 for an RGB film).
    pub fn nbuckets(&self) -> usize {
        self.nbuckets
    }

    /// Whether the film accumulates the albedo and normal AOVs.
    pub fn has_aovs(&self) -> bool {
        self.spec.aovs
    }

    /// Number of samples (and splats) dropped so far because a value was NaN or infinite or `x` was outside the
    /// film.
    pub fn rejected_samples(&self) -> u64 {
        self.rejected.iter().sum::<u64>() + self.rejected_splats
    }

    /// Splats a light-path contribution at raster position `raster` (pixels, y down, continuous): every pixel whose
    /// centre lies within the filter's radius receives the contribution times `f(centre offset) / ∫f`. `l` is the
    /// contribution at the wavelengths `wl` (converted as camera samples are). The splat sums count once
    /// [`Film::add_light_paths`] says how many light paths were traced. Returns whether the splat was accumulated
    /// (non-finite values are dropped and counted).
    pub fn add_splat(&mut self, raster: [f64; 2], l: &SampledSpectrum, wl: &SampledWavelengths) -> bool {
        self.add_splats(&[Splat { raster, l: *l, wl: *wl }]) == 1
    }

    /// Adds many splats (see [`Film::add_splat`]), rows of the film in parallel. Each pixel receives its splats in
    /// the order given, so the sums do not depend on the number of threads. Returns how many were accumulated.
    pub fn add_splats(&mut self, splats: &[Splat]) -> usize {
        let conv = &self.conversion;
        let converted: Vec<XyzSplat> = splats
            .par_iter()
            .map(|sp| {
                let (xyz, spectral) = conv.reduce(&sp.l, &sp.wl);
                XyzSplat { raster: sp.raster, xyz, spectral }
            })
            .collect();
        self.add_xyz_splats(&converted)
    }

    /// Splats a contribution already reduced to XYZ and `(λ nm, L/pdf)` pairs (see [`Film::add_splat`]); for tests
    /// and tools that form these themselves.
    pub fn add_xyz_splat(&mut self, raster: [f64; 2], xyz: Xyz, spectral: &[(f32, f32)]) -> bool {
        let mut estimates = SpectralEstimates::default();
        for &(l, v) in spectral.iter().take(N_WAVELENGTHS) {
            estimates.pairs[estimates.len] = (l, v);
            estimates.len += 1;
        }
        self.add_xyz_splats(&[XyzSplat { raster, xyz, spectral: estimates }]) == 1
    }

    fn add_xyz_splats(&mut self, splats: &[XyzSplat]) -> usize {
        let npix = self.weight.len();
        if self.splat_xyz.is_empty() {
            self.splat_xyz = vec![[0.0; 3]; npix];
            self.splat_buckets = vec![0.0; npix * self.nbuckets];
        }
        let conv = &self.conversion;
        let filter = &self.spec.filter;
        let [rx, ry] = filter.radius();
        let norm = 1.0 / filter.integral();
        let b = self.bounds;
        let (bx0, bx1, by0, by1) = (b.x0 as i64, b.x1 as i64, b.y0 as i64, b.y1 as i64);
        let w = (bx1 - bx0) as usize;
        // Validate and scale (the sensor's imaging ratio and the maxcomponentvalue clamp apply to splats as to
        // camera samples), and list each splat under the rows its filter footprint covers.
        let mut prepared = Vec::with_capacity(splats.len());
        let mut rows: Vec<Vec<u32>> = vec![Vec::new(); (by1 - by0) as usize];
        for sp in splats {
            let finite = sp.xyz.x.is_finite()
                && sp.xyz.y.is_finite()
                && sp.xyz.z.is_finite()
                && sp.raster.iter().all(|v| v.is_finite())
                && sp.spectral.as_slice().iter().all(|(l, v)| v.is_finite() && !l.is_nan());
            if !finite {
                self.rejected_splats += 1;
                continue;
            }
            let (xyz, clamp) = conv.respond(sp.xyz);
            let y0 = ((sp.raster[1] - 0.5 - ry).ceil() as i64).max(by0);
            let y1 = ((sp.raster[1] - 0.5 + ry).floor() as i64).min(by1 - 1);
            let k = prepared.len() as u32;
            prepared.push((sp, xyz.scaled(clamp), clamp));
            for y in y0..=y1 {
                rows[(y - by0) as usize].push(k);
            }
        }
        let nb = self.nbuckets;
        let xyz_rows: Vec<&mut [[f64; 3]]> = self.splat_xyz.chunks_mut(w).collect();
        let bucket_rows: Vec<&mut [f64]> = if nb > 0 {
            self.splat_buckets.chunks_mut(w * nb).collect()
        } else {
            (by0..by1).map(|_| <&mut [f64]>::default()).collect()
        };
        xyz_rows.into_par_iter().zip(bucket_rows).zip(rows.par_iter()).enumerate().for_each(
            |(row, ((xyz_row, bucket_row), list))| {
                let y = by0 + row as i64;
                for &k in list {
                    let (sp, xyz, clamp) = &prepared[k as usize];
                    let x0 = ((sp.raster[0] - 0.5 - rx).ceil() as i64).max(bx0);
                    let x1 = ((sp.raster[0] - 0.5 + rx).floor() as i64).min(bx1 - 1);
                    for x in x0..=x1 {
                        let f = filter.evaluate([x as f64 + 0.5 - sp.raster[0], y as f64 + 0.5 - sp.raster[1]]) * norm;
                        if f == 0.0 {
                            continue;
                        }
                        let i = (x - bx0) as usize;
                        let s = &mut xyz_row[i];
                        s[0] += f * xyz.x;
                        s[1] += f * xyz.y;
                        s[2] += f * xyz.z;
                        if nb > 0 {
                            let b = &mut bucket_row[i * nb..(i + 1) * nb];
                            conv.add_estimates_to_buckets(b, sp.spectral.as_slice(), f * clamp);
                        }
                    }
                }
            },
        );
        prepared.len()
    }

    /// Adds a finished estimate to pixel (x, y) as one sample of weight `weight`: `xyz` and, for a spectral film,
    /// `buckets` (spectral radiance per nm, one value per bucket; ignored for an RGB film, must have `nbuckets`
    /// values otherwise). For integrators such as photon mapping that form a pixel's value themselves. Returns
    /// whether it was accumulated (non-finite values, a wrong bucket count or a pixel outside are dropped).
    pub fn add_pixel_estimate(&mut self, x: u32, y: u32, xyz: Xyz, buckets: &[f64], weight: f64) -> bool {
        let Some(i) = self.index(x, y) else { return false };
        let nb = self.nbuckets;
        let ok = xyz.x.is_finite()
            && xyz.y.is_finite()
            && xyz.z.is_finite()
            && weight.is_finite()
            && (nb == 0 || buckets.len() == nb)
            && buckets.iter().all(|v| v.is_finite());
        if !ok {
            self.rejected[(y - self.bounds.y0) as usize] += 1;
            return false;
        }
        // The sensor's imaging ratio applies as to camera samples (the estimate is final: no clamp).
        let (xyz, _) = self.conversion.respond(xyz);
        let s = &mut self.xyz[i];
        s[0] += weight * xyz.x;
        s[1] += weight * xyz.y;
        s[2] += weight * xyz.z;
        self.weight[i] += weight;
        for (b, v) in self.buckets[i * nb..(i + 1) * nb].iter_mut().zip(buckets) {
            *b += weight * v;
        }
        true
    }

    /// Records that `n` more light paths were traced (their splats, if any, have been or will be added).
    pub fn add_light_paths(&mut self, n: u64) {
        self.light_paths += n as f64;
    }

    /// The number of light paths recorded with [`Film::add_light_paths`].
    pub fn light_paths(&self) -> f64 {
        self.light_paths
    }

    /// The factor that turns splat sums into radiance: pixels of the full image per light path (each light path
    /// estimates the whole image, even when only a crop is stored; 0 before any light path).
    fn splat_scale(&self) -> f64 {
        if self.light_paths > 0.0 && !self.splat_xyz.is_empty() {
            self.spec.width as f64 * self.spec.height as f64 / self.light_paths
        } else {
            0.0
        }
    }

    fn index(&self, x: u32, y: u32) -> Option<usize> {
        let b = &self.bounds;
        b.contains(x, y).then(|| (y - b.y0) as usize * b.width() as usize + (x - b.x0) as usize)
    }

    fn rows(&mut self) -> Vec<FilmRow<'_>> {
        let w = self.bounds.width() as usize;
        let (x0, y0) = (self.bounds.x0, self.bounds.y0);
        let nb = self.nbuckets;
        let aov = self.spec.aovs;
        let gb = if self.spec.gbuffer.is_some() { w } else { 0 };
        let (conv, color_space, output_matrix) = (&self.conversion, &self.spec.color_space, &self.output_matrix);
        let (mut xyz, mut weight, mut buckets) = (&mut self.xyz[..], &mut self.weight[..], &mut self.buckets[..]);
        let (mut albedo, mut normal, mut count) = (&mut self.albedo[..], &mut self.normal[..], &mut self.aov_count[..]);
        let mut surfaces = &mut self.surfaces[..];
        let mut rows = Vec::with_capacity(self.bounds.height() as usize);
        for (row, rejected) in self.rejected.iter_mut().enumerate() {
            let (x_row, x_rest) = std::mem::take(&mut xyz).split_at_mut(w);
            let (w_row, w_rest) = std::mem::take(&mut weight).split_at_mut(w);
            let (b_row, b_rest) = std::mem::take(&mut buckets).split_at_mut(w * nb);
            let a = if aov { w } else { 0 };
            let (a_row, a_rest) = std::mem::take(&mut albedo).split_at_mut(a);
            let (n_row, n_rest) = std::mem::take(&mut normal).split_at_mut(a);
            let (c_row, c_rest) = std::mem::take(&mut count).split_at_mut(a);
            let (s_row, s_rest) = std::mem::take(&mut surfaces).split_at_mut(gb);
            (xyz, weight, buckets, albedo, normal, count) = (x_rest, w_rest, b_rest, a_rest, n_rest, c_rest);
            surfaces = s_rest;
            rows.push(FilmRow {
                y: y0 + row as u32,
                x0,
                conv,
                color_space,
                output_matrix,
                xyz: x_row,
                weight: w_row,
                buckets: b_row,
                albedo: a_row,
                normal: n_row,
                aov_count: c_row,
                surfaces: s_row,
                rejected,
            });
        }
        rows
    }

    /// The rows, top to bottom, each with exclusive access to its pixels' accumulators.
    pub fn rows_mut(&mut self) -> impl Iterator<Item = FilmRow<'_>> {
        self.rows().into_iter()
    }

    /// The rows as a rayon parallel iterator: threads write disjoint rows without locks.
    pub fn par_rows_mut(&mut self) -> impl IndexedParallelIterator<Item = FilmRow<'_>> {
        self.rows().into_par_iter()
    }

    /// Row `y` alone (`None` outside the film's bounds).
    pub fn row_mut(&mut self, y: u32) -> Option<FilmRow<'_>> {
        if !(self.bounds.y0..self.bounds.y1).contains(&y) {
            return None;
        }
        let k = (y - self.bounds.y0) as usize;
        self.rows().into_iter().nth(k)
    }

    /// Adds one camera sample to pixel (x, y): see [`FilmRow::add_sample`]. Returns whether it was accumulated.
    pub fn add_sample(&mut self, x: u32, y: u32, l: &SampledSpectrum, wl: &SampledWavelengths, weight: f64) -> bool {
        let (xyz, spectral) = self.conversion.reduce(l, wl);
        self.add_xyz_sample(x, y, xyz, weight, spectral.as_slice())
    }

    /// Adds one sample already reduced to XYZ and `(λ nm, L/pdf)` pairs to pixel (x, y): see
    /// [`FilmRow::add_xyz_sample`]. Returns whether it was accumulated.
    pub fn add_xyz_sample(&mut self, x: u32, y: u32, xyz: Xyz, weight: f64, spectral: &[(f32, f32)]) -> bool {
        let Some(i) = self.index(x, y) else { return false };
        let nb = self.nbuckets;
        accumulate(
            &self.conversion,
            &mut self.xyz[i],
            &mut self.weight[i],
            &mut self.buckets[i * nb..(i + 1) * nb],
            &mut self.rejected[(y - self.bounds.y0) as usize],
            xyz,
            weight,
            spectral,
        )
    }

    /// Adds one albedo (linear RGB) and shading-normal record to pixel (x, y); ignored (returns `false`) without
    /// AOVs, outside the film, or for non-finite values.
    pub fn add_aov(&mut self, x: u32, y: u32, albedo: [f64; 3], normal: [f64; 3]) -> bool {
        let Some(i) = self.index(x, y) else { return false };
        if !self.spec.aovs {
            return false;
        }
        accumulate_aov(&mut self.albedo[i], &mut self.normal[i], &mut self.aov_count[i], albedo, normal)
    }

    /// Adds one albedo and shading-normal record to pixel (x, y): see [`FilmRow::add_albedo`].
    pub fn add_albedo(
        &mut self,
        x: u32,
        y: u32,
        albedo: &SampledSpectrum,
        wl: &SampledWavelengths,
        normal: [f64; 3],
    ) -> bool {
        match self.conversion.albedo_rgb(albedo, wl, &self.spec.color_space) {
            Some(rgb) => self.add_aov(x, y, rgb, normal),
            None => false,
        }
    }

    /// Adds `other`'s accumulators to this film's (for renders split across processes or sample ranges). The films
    /// must have the same size, kind and AOV setting.
    pub fn merge(&mut self, other: &Film) -> Result<(), FilmError> {
        if (self.spec.width, self.spec.height, self.bounds) != (other.spec.width, other.spec.height, other.bounds) {
            return Err(FilmError::Mismatch(format!(
                "sizes or pixel bounds differ: {}×{} {:?} and {}×{} {:?}",
                self.spec.width, self.spec.height, self.bounds, other.spec.width, other.spec.height, other.bounds
            )));
        }
        if self.spec.kind != other.spec.kind {
            return Err(FilmError::Mismatch(format!("kinds differ: {:?} and {:?}", self.spec.kind, other.spec.kind)));
        }
        if self.spec.aovs != other.spec.aovs || self.spec.gbuffer != other.spec.gbuffer {
            return Err(FilmError::Mismatch("the films' AOVs or geometry buffers differ".into()));
        }
        if (&self.spec.sensor, self.spec.max_component_value) != (&other.spec.sensor, other.spec.max_component_value) {
            return Err(FilmError::Mismatch("the films' sensors or 'maxcomponentvalue' differ".into()));
        }
        let add3 = |a: &mut [f64; 3], b: &[f64; 3]| {
            for c in 0..3 {
                a[c] += b[c];
            }
        };
        self.xyz.iter_mut().zip(&other.xyz).for_each(|(a, b)| add3(a, b));
        self.weight.iter_mut().zip(&other.weight).for_each(|(a, b)| *a += b);
        self.buckets.iter_mut().zip(&other.buckets).for_each(|(a, b)| *a += b);
        self.albedo.iter_mut().zip(&other.albedo).for_each(|(a, b)| add3(a, b));
        self.normal.iter_mut().zip(&other.normal).for_each(|(a, b)| add3(a, b));
        self.aov_count.iter_mut().zip(&other.aov_count).for_each(|(a, b)| *a += b);
        for (a, b) in self.surfaces.iter_mut().zip(&other.surfaces) {
            a.iter_mut().zip(b).for_each(|(a, b)| *a += b);
        }
        self.rejected.iter_mut().zip(&other.rejected).for_each(|(a, b)| *a += b);
        if !other.splat_xyz.is_empty() {
            if self.splat_xyz.is_empty() {
                self.splat_xyz = vec![[0.0; 3]; self.weight.len()];
                self.splat_buckets = vec![0.0; self.weight.len() * self.nbuckets];
            }
            self.splat_xyz.iter_mut().zip(&other.splat_xyz).for_each(|(a, b)| add3(a, b));
            self.splat_buckets.iter_mut().zip(&other.splat_buckets).for_each(|(a, b)| *a += b);
        }
        self.light_paths += other.light_paths;
        self.rejected_splats += other.rejected_splats;
        Ok(())
    }

    /// The sum of filter weights at (x, y) (0 outside the film).
    pub fn pixel_weight(&self, x: u32, y: u32) -> f64 {
        self.index(x, y).map_or(0.0, |i| self.weight[i])
    }

    /// The pixel's output XYZ: weighted sum over weight sum, white-balanced by the sensor (zero for a pixel without
    /// weight, or outside the film).
    pub fn pixel_xyz(&self, x: u32, y: u32) -> Xyz {
        self.index(x, y).map_or(Xyz::default(), |i| self.xyz_at(i))
    }

    fn xyz_at(&self, i: usize) -> Xyz {
        let w = self.weight[i];
        let s = self.xyz[i];
        let camera = if w == 0.0 { [0.0; 3] } else { [s[0] / w, s[1] / w, s[2] / w] };
        let k = self.splat_scale();
        let sum = if k == 0.0 {
            camera
        } else {
            let p = self.splat_xyz[i];
            [camera[0] + k * p[0], camera[1] + k * p[1], camera[2] + k * p[2]]
        };
        Xyz::from_array(mul_mat_vec(&self.output_matrix, sum))
    }

    /// Bucket `b` of pixel `i`: camera part plus splat part.
    fn bucket_at(&self, i: usize, b: usize, k: f64) -> f64 {
        let nb = self.nbuckets;
        let w = self.weight[i];
        let camera = if w == 0.0 { 0.0 } else { self.buckets[i * nb + b] / w };
        if k == 0.0 {
            camera
        } else {
            camera + k * self.splat_buckets[i * nb + b]
        }
    }

    /// The pixel's spectrum: per bucket, the mean spectral radiance over the bucket (per nm). Empty for an RGB film;
    /// zeros without weight or outside the film.
    pub fn pixel_spectrum(&self, x: u32, y: u32) -> Vec<f64> {
        let nb = self.nbuckets;
        let k = self.splat_scale();
        match self.index(x, y) {
            Some(i) => (0..nb).map(|b| self.bucket_at(i, b, k)).collect(),
            None => vec![0.0; nb],
        }
    }

    /// The image in the film's colour space, linear, row-major from the top row: the pixels of [`Film::bounds`].
    pub fn to_rgb_image(&self) -> Vec<[f32; 3]> {
        (0..self.weight.len())
            .into_par_iter()
            .map(|i| self.spec.color_space.to_rgb(self.xyz_at(i)).map(|c| c as f32))
            .collect()
    }

    /// The spectral image: `nbuckets` values per pixel (see [`Film::pixel_spectrum`]), pixel-major, rows from the
    /// top. Empty for an RGB film.
    pub fn to_spectral_image(&self) -> Vec<f32> {
        let nb = self.nbuckets;
        if nb == 0 {
            return Vec::new();
        }
        let k = self.splat_scale();
        (0..self.weight.len())
            .into_par_iter()
            .flat_map_iter(|i| (0..nb).map(move |b| self.bucket_at(i, b, k) as f32))
            .collect()
    }

    /// The AOV images (mean albedo, and the mean shading normal renormalised to unit length), or `None` without
    /// AOVs. Pixels without records are zero.
    pub fn to_aov_images(&self) -> Option<AovImages> {
        if !self.spec.aovs {
            return None;
        }
        let albedo = self
            .albedo
            .iter()
            .zip(&self.aov_count)
            .map(|(a, &n)| if n > 0.0 { a.map(|c| (c / n) as f32) } else { [0.0; 3] })
            .collect();
        let normal = self
            .normal
            .iter()
            .map(|v| {
                let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                if len > 0.0 {
                    v.map(|c| (c / len) as f32)
                } else {
                    [0.0; 3]
                }
            })
            .collect();
        Some(AovImages { albedo, normal })
    }
}

/// The albedo and normal AOV images, row-major from the top.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AovImages {
    /// Mean albedo per pixel, linear RGB (`albedo.R/G/B` in an EXR).
    pub albedo: Vec<[f32; 3]>,
    /// Mean shading normal per pixel, unit length or zero (`N.X/Y/Z` in an EXR).
    pub normal: Vec<[f32; 3]>,
}

/// How the film turns what a path carries into what a pixel stores, each rule written once: the wavelength
/// strategy's conversion of `L(λᵢ)` to XYZ, the sensor's response (imaging ratio, then pbrt-v4's
/// `maxcomponentvalue` clamp), and the assignment of each wavelength to its spectral bucket.
#[derive(Clone, Debug)]
pub struct SampleConversion {
    wavelengths: WavelengthSampler,
    kind: FilmKind,
    nbuckets: usize,
    /// Buckets per nm (1 / the bucket width).
    inv_width: f64,
    imaging_ratio: f64,
    max_component: f64,
    /// The colour space's white as a spectrum (D65), under which AOV albedos are seen; `None` without AOVs.
    white: Option<Spectrum>,
    /// A measured camera sensor (its raw r, g, b are recorded instead of XYZ), and 1/∫ȳ for its scale.
    camera: Option<(&'static CameraSensor, f64)>,
}

impl SampleConversion {
    fn new(spec: &FilmSpec) -> Self {
        let (imaging_ratio, max_component) = (spec.sensor.imaging_ratio, spec.max_component_value);
        let inv_width = match spec.kind {
            FilmKind::Rgb => 0.0,
            FilmKind::Spectral { nbuckets, lambda_min, lambda_max } => nbuckets as f64 / (lambda_max - lambda_min),
        };
        let white = spec.aovs.then(|| spectral::named::illuminant("stdillum-D65").expect("D65 is built in"));
        let camera = spec.sensor.camera.as_ref().map(|c| (c.sensor, 1.0 / spec.observer.y_integral()));
        Self {
            camera,
            // A clamp is biased by an amount that depends on the wavelength pdf: clamp as pbrt-v4 does with its pdf.
            wavelengths: WavelengthSampler::new(spec.wavelengths, spec.observer)
                .with_pbrt_hero_pdf(max_component.is_finite()),
            kind: spec.kind.clone(),
            nbuckets: spec.kind.nbuckets(),
            inv_width,
            imaging_ratio,
            max_component,
            white,
        }
    }

    /// The wavelength strategy with its tables.
    pub fn wavelengths(&self) -> &WavelengthSampler {
        &self.wavelengths
    }

    /// The sensor value of a path sample, before the imaging ratio: for the cie1931 sensor its XYZ, `L(λᵢ)/pdfᵢ`
    /// weighted by the strategy's colour matching functions; for a camera sensor its raw r, g, b,
    /// `Σᵢ (r̄, ḡ, b̄)(λᵢ)·L(λᵢ)/pdfᵢ / ∫ȳ` (pbrt-v4 `PixelSensor::ToSensorRGB`, on the scale where a light of
    /// luminance 1 has ∫ȳL = 1), carried in an [`Xyz`] whose x, y, z are r, g, b.
    #[inline]
    pub fn xyz(&self, l: &SampledSpectrum, wl: &SampledWavelengths) -> Xyz {
        let Some((camera, inv_y)) = self.camera else { return self.wavelengths.to_xyz(l, wl) };
        let pdf = wl.pdf();
        let mut rgb = [0.0f64; 3];
        for i in 0..N_WAVELENGTHS {
            if wl.is_active(i) && pdf.0[i] > 0.0 {
                let w = (l.0[i] / pdf.0[i]) as f64;
                let s = camera.response(wl.lambda(i) as f64);
                for c in 0..3 {
                    rgb[c] += w * s[c];
                }
            }
        }
        Xyz::from_array(rgb.map(|v| v * inv_y))
    }

    /// A path sample reduced to what the film accumulates: its colour ([`SampleConversion::xyz`]) and its
    /// `(λ, L/pdf)` pairs for the spectral buckets.
    #[inline]
    pub fn reduce(&self, l: &SampledSpectrum, wl: &SampledWavelengths) -> (Xyz, SpectralEstimates) {
        (self.xyz(l, wl), SpectralEstimates::new(l, wl))
    }

    /// The sensor's response to a sample's colour: times the imaging ratio (pbrt-v4 `PixelSensor::ToSensorRGB` for
    /// the cie1931 sensor), then, if its largest component `m` exceeds `maxcomponentvalue`, scaled by max/m
    /// (pbrt-v4 `RGBFilm::AddSample`). Returns the colour times the imaging ratio and the clamp factor, which the
    /// caller applies to the colour and the sample's spectral buckets alike.
    #[inline]
    fn respond(&self, xyz: Xyz) -> (Xyz, f64) {
        let xyz = xyz.scaled(self.imaging_ratio);
        let m = xyz.x.max(xyz.y).max(xyz.z);
        let clamp = if m > self.max_component { self.max_component / m } else { 1.0 };
        (xyz, clamp)
    }

    /// Adds `weight·(L/pdf)/Δλ` of each `(λ, L/pdf)` pair to the bucket holding λ (pairs outside
    /// `[lambda_min, lambda_max)` are ignored): the expectation of a bucket is then the mean spectral radiance over
    /// it, per nm, whatever the wavelength strategy.
    pub fn add_estimates_to_buckets(&self, buckets: &mut [f64], spectral: &[(f32, f32)], weight: f64) {
        for &(lambda, value) in spectral {
            if let Some(b) = self.kind.bucket_of(lambda as f64) {
                buckets[b] += value as f64 * self.inv_width * weight;
            }
        }
    }

    /// [`SampleConversion::add_estimates_to_buckets`] for a path sample (nothing for an RGB film).
    pub fn add_to_buckets(&self, buckets: &mut [f64], l: &SampledSpectrum, wl: &SampledWavelengths, weight: f64) {
        if self.nbuckets > 0 {
            self.add_estimates_to_buckets(buckets, SpectralEstimates::new(l, wl).as_slice(), weight);
        }
    }

    /// Linear RGB of an albedo (a reflectance at the path's wavelengths) seen under the colour space's white, with
    /// Y = 1 for a white reflector; `None` when the film keeps no AOVs.
    fn albedo_rgb(&self, albedo: &SampledSpectrum, wl: &SampledWavelengths, cs: &RgbColorSpace) -> Option<[f64; 3]> {
        let white = self.white.as_ref()?;
        Some(cs.to_rgb(self.wavelengths.to_xyz(&(*albedo * white.sample(wl)), wl)))
    }
}

/// Adds one sample already reduced to XYZ and `(λ, L/pdf)` pairs to a pixel's accumulators.
// The accumulators are disjoint borrows of one pixel's slots in a row's arrays, which rows split between threads.
#[allow(clippy::too_many_arguments)]
fn accumulate(
    conv: &SampleConversion,
    xyz_sum: &mut [f64; 3],
    weight_sum: &mut f64,
    buckets: &mut [f64],
    rejected: &mut u64,
    xyz: Xyz,
    weight: f64,
    spectral: &[(f32, f32)],
) -> bool {
    let finite = xyz.x.is_finite()
        && xyz.y.is_finite()
        && xyz.z.is_finite()
        && weight.is_finite()
        && spectral.iter().all(|(l, v)| v.is_finite() && !l.is_nan());
    if !finite {
        *rejected += 1;
        return false;
    }
    let (xyz, clamp) = conv.respond(xyz);
    xyz_sum[0] += weight * clamp * xyz.x;
    xyz_sum[1] += weight * clamp * xyz.y;
    xyz_sum[2] += weight * clamp * xyz.z;
    *weight_sum += weight;
    if conv.nbuckets > 0 {
        conv.add_estimates_to_buckets(buckets, spectral, weight * clamp);
    }
    true
}

fn accumulate_aov(
    albedo_sum: &mut [f64; 3],
    normal_sum: &mut [f64; 3],
    count: &mut f64,
    albedo: [f64; 3],
    normal: [f64; 3],
) -> bool {
    if !albedo.iter().chain(&normal).all(|v| v.is_finite()) {
        return false;
    }
    for c in 0..3 {
        albedo_sum[c] += albedo[c];
        normal_sum[c] += normal[c];
    }
    *count += 1.0;
    true
}

/// Exclusive access to one row of a [`Film`], for one rendering thread.
#[derive(Debug)]
pub struct FilmRow<'a> {
    y: u32,
    /// Full-image column of the row's first pixel.
    x0: u32,
    conv: &'a SampleConversion,
    color_space: &'a RgbColorSpace,
    /// The film's sensor-to-output XYZ matrix (for the colour of variance samples).
    output_matrix: &'a Mat3,
    xyz: &'a mut [[f64; 3]],
    weight: &'a mut [f64],
    buckets: &'a mut [f64],
    albedo: &'a mut [[f64; 3]],
    normal: &'a mut [[f64; 3]],
    aov_count: &'a mut [f64],
    surfaces: &'a mut [[f64; gbuffer::NSUMS]],
    rejected: &'a mut u64,
}

impl FilmRow<'_> {
    /// The row's index in the full image, from the top.
    pub fn y(&self) -> u32 {
        self.y
    }

    /// The number of pixels in the row (the film's bounds' width).
    pub fn width(&self) -> u32 {
        self.weight.len() as u32
    }

    /// The full-image columns of the row's pixels: what `x` of [`FilmRow::add_sample`] ranges over.
    pub fn xs(&self) -> std::ops::Range<u32> {
        self.x0..self.x0 + self.width()
    }

    /// Draws the wavelengths of one path from one uniform number (see [`Film::sample_wavelengths`]).
    pub fn sample_wavelengths(&self, u: f64) -> SampledWavelengths {
        self.conv.wavelengths.sample(u)
    }

    /// Adds one camera sample to pixel `x` of this row: radiance `l` at the path's wavelengths `wl` (the slots
    /// still active, with their effective densities), and its filter weight `weight`
    /// ([`crate::FilterSample::weight`]). The film converts it to XYZ with its wavelength strategy, applies the
    /// sensor's response, and for a spectral film puts each `L(λᵢ)/pdfᵢ` in the bucket holding λᵢ (see
    /// [`FilmRow::add_xyz_sample`]).
    ///
    /// A sample with any NaN or infinite value, or with `x` outside the row, is dropped and counted
    /// ([`Film::rejected_samples`]); the return value says whether the sample was accumulated.
    pub fn add_sample(&mut self, x: u32, l: &SampledSpectrum, wl: &SampledWavelengths, weight: f64) -> bool {
        let (xyz, spectral) = self.conv.reduce(l, wl);
        self.add_xyz_sample(x, xyz, weight, spectral.as_slice())
    }

    /// Adds one camera sample already reduced to colour and per-wavelength estimates to pixel `x` of this row.
    ///
    /// `xyz` is the sample's tristimulus estimate and `weight` its filter weight ([`crate::FilterSample::weight`]);
    /// the pixel accumulates `weight·xyz` and `weight`. For a spectral film each `(λ nm, L/pdf)` pair with λ in
    /// `[lambda_min, lambda_max)` adds `weight·(L/pdf)/Δλ` to the bucket holding λ (Δλ the bucket width); pairs
    /// outside are ignored, and so is `spectral` for an RGB film. Pass only the active wavelengths.
    ///
    /// A sample with any NaN or infinite value, or with `x` outside the row, is dropped and counted
    /// ([`Film::rejected_samples`]); the return value says whether the sample was accumulated.
    pub fn add_xyz_sample(&mut self, x: u32, xyz: Xyz, weight: f64, spectral: &[(f32, f32)]) -> bool {
        let x = x.wrapping_sub(self.x0) as usize;
        if x >= self.weight.len() {
            *self.rejected += 1;
            return false;
        }
        let nb = self.conv.nbuckets;
        accumulate(
            self.conv,
            &mut self.xyz[x],
            &mut self.weight[x],
            &mut self.buckets[x * nb..(x + 1) * nb],
            self.rejected,
            xyz,
            weight,
            spectral,
        )
    }

    /// Adds one albedo and shading-normal record to pixel `x`: `albedo` is the first surface's reflectance at the
    /// wavelengths `wl`, which the film sees under its colour space's white (Y = 1 for a white reflector).
    /// Ignored (returns `false`) when the film has no AOVs, outside the row, or for non-finite values.
    pub fn add_albedo(&mut self, x: u32, albedo: &SampledSpectrum, wl: &SampledWavelengths, normal: [f64; 3]) -> bool {
        match self.conv.albedo_rgb(albedo, wl, self.color_space) {
            Some(rgb) => self.add_aov(x, rgb, normal),
            None => false,
        }
    }

    /// Adds one albedo (linear RGB) and shading-normal record to pixel `x`; ignored (returns `false`) when the
    /// film has no AOVs, outside the row, or for non-finite values.
    pub fn add_aov(&mut self, x: u32, albedo: [f64; 3], normal: [f64; 3]) -> bool {
        let x = x.wrapping_sub(self.x0) as usize;
        if x >= self.aov_count.len() {
            return false;
        }
        accumulate_aov(&mut self.albedo[x], &mut self.normal[x], &mut self.aov_count[x], albedo, normal)
    }
}

/// A light-path contribution to splat: where it lands and its radiance at the wavelengths it was made at.
#[derive(Clone, Copy, Debug)]
pub struct Splat {
    /// Where it lands on the film (pixels, y down).
    pub raster: [f64; 2],
    /// Its radiance estimate per wavelength slot.
    pub l: SampledSpectrum,
    /// The wavelengths (and effective densities) `l` is at.
    pub wl: SampledWavelengths,
}

/// A splat reduced to colour and per-wavelength estimates.
#[derive(Clone, Copy, Debug)]
struct XyzSplat {
    raster: [f64; 2],
    xyz: Xyz,
    spectral: SpectralEstimates,
}

/// The `(λ nm, L/pdf)` pairs of a path's active wavelengths, as [`FilmRow::add_sample`] takes them; built without
/// allocating.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SpectralEstimates {
    pairs: [(f32, f32); N_WAVELENGTHS],
    len: usize,
}

impl SpectralEstimates {
    /// One pair per active slot of `wl` (pdf > 0): the wavelength and `radiance[i] / pdf[i]`.
    pub fn new(radiance: &SampledSpectrum, wl: &SampledWavelengths) -> Self {
        let pdf = wl.pdf();
        let mut out = Self::default();
        for i in 0..N_WAVELENGTHS {
            if wl.is_active(i) && pdf.0[i] > 0.0 {
                out.pairs[out.len] = (wl.lambda(i), radiance.0[i] / pdf.0[i]);
                out.len += 1;
            }
        }
        out
    }

    /// The pairs.
    pub fn as_slice(&self) -> &[(f32, f32)] {
        &self.pairs[..self.len]
    }
}

//! pbrt-v4's geometry buffer (`Film "gbuffer"`): per pixel, filter-weighted sums of the first visible surface's
//! position, geometric normal, (u, v) and depth derivatives, and the sums that give the variance of the samples'
//! colour.
//!
//! As pbrt-v4's `GBufferFilm::AddSample`, a camera sample that found a visible surface adds `w·p`, `w·n`, `w·uv`,
//! `w·dz/dx`, `w·dz/dy` and its filter weight `w` to the pixel's geometry sums, and its colour to the pixel's
//! variance estimate. pbrt-v4 keeps that estimate with Welford's algorithm (`VarianceEstimator`, unweighted:
//! sample variance S/(n−1), relative variance variance/mean); Prismatic keeps the count n, Σx and Σx² of each
//! channel instead, so that renders of other sample ranges (checkpoints, shards) add up plane by plane, and forms
//! the same sample variance (Σx² − (Σx)²/n)/(n−1) on output.

use super::{Film, FilmRow, SampleConversion};
use spectral::color::{mul_mat_vec, Mat3};
use spectral::{RgbColorSpace, SampledSpectrum, SampledWavelengths, Xyz};

/// Number of sums a gbuffer pixel keeps.
pub(super) const NSUMS: usize = 18;

/// The sums' plane names in a film state, in storage order.
pub(super) const PLANE_NAMES: [&str; NSUMS] = [
    "gbuffer.W",
    "P.X",
    "P.Y",
    "P.Z",
    "Ng.X",
    "Ng.Y",
    "Ng.Z",
    "u",
    "v",
    "dzdx",
    "dzdy",
    "variance.n",
    "variance.R",
    "variance.G",
    "variance.B",
    "variance.R2",
    "variance.G2",
    "variance.B2",
];

// Offsets of the sums.
const W: usize = 0;
const P: usize = 1;
const N: usize = 4;
const UV: usize = 7;
const DZ: usize = 9;
const COUNT: usize = 11;
const RGB: usize = 12;
const RGB2: usize = 15;

/// A camera sample's first visible surface as a gbuffer film records it, already in the film's output
/// coordinate system ([`super::GBufferCoordinates`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VisibleSurface {
    /// The point.
    pub p: [f64; 3],
    /// The geometric normal, unit length, on the side the camera ray came from (pbrt-v4 face-forwards it).
    pub n: [f64; 3],
    /// The surface parameterisation (u, v) at the point.
    pub uv: [f64; 2],
    /// The change of the output z coordinate from this pixel to the next one to the right.
    pub dzdx: f64,
    /// The change of the output z coordinate from this pixel to the next one down.
    pub dzdy: f64,
}

/// One pixel of a gbuffer film's output (see [`Film::pixel_gbuffer`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GBufferPixel {
    /// Filter-weighted mean position (zero without a visible surface).
    pub p: [f64; 3],
    /// |mean dz/dx| and |mean dz/dy| (pbrt-v4 writes their absolute values).
    pub dz: [f64; 2],
    /// The weighted sum of geometric normals, normalised (zero without a visible surface).
    pub n: [f64; 3],
    /// Filter-weighted mean (u, v).
    pub uv: [f64; 2],
    /// Number of samples in the variance estimate.
    pub count: f64,
    /// Mean colour of those samples (the film's RGB).
    pub mean: [f64; 3],
    /// Sample variance of their colour, per channel (0 for fewer than 2 samples).
    pub variance: [f64; 3],
    /// Variance over mean, per channel (0 where the mean is 0), as pbrt-v4's `RelativeVariance`.
    pub relative_variance: [f64; 3],
}

/// A gbuffer film's images, row-major from the top (see [`Film::to_gbuffer_images`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GBufferImages {
    /// `P.X`, `P.Y`, `P.Z`.
    pub p: Vec<[f32; 3]>,
    /// `dzdx`, `dzdy`.
    pub dz: Vec<[f32; 2]>,
    /// `N.X`, `N.Y`, `N.Z`.
    pub n: Vec<[f32; 3]>,
    /// `u`, `v`.
    pub uv: Vec<[f32; 2]>,
    /// `Variance.R`, `Variance.G`, `Variance.B`.
    pub variance: Vec<[f32; 3]>,
    /// `RelativeVariance.R`, `RelativeVariance.G`, `RelativeVariance.B`.
    pub relative_variance: Vec<[f32; 3]>,
}

/// The colour of a path sample as the film writes it: the sensor's response (imaging ratio and clamp), its output
/// matrix, then the colour space's RGB.
fn sample_rgb(
    conv: &SampleConversion,
    output_matrix: &Mat3,
    color_space: &RgbColorSpace,
    l: &SampledSpectrum,
    wl: &SampledWavelengths,
) -> [f64; 3] {
    let (xyz, clamp) = conv.respond(conv.xyz(l, wl));
    color_space.to_rgb(Xyz::from_array(mul_mat_vec(output_matrix, xyz.scaled(clamp).to_array())))
}

/// Adds one visible surface of filter weight `weight` to a pixel's sums, and `rgb` (the sample's colour) to its
/// variance estimate. Non-finite values are dropped.
fn accumulate(sums: &mut [f64; NSUMS], s: &VisibleSurface, weight: f64, rgb: Option<[f64; 3]>) -> bool {
    let values = s.p.iter().chain(&s.n).chain(&s.uv).chain([&s.dzdx, &s.dzdy]);
    if !(weight.is_finite()
        && values.copied().all(f64::is_finite)
        && rgb.is_none_or(|c| c.iter().all(|v| v.is_finite())))
    {
        return false;
    }
    sums[W] += weight;
    for c in 0..3 {
        sums[P + c] += weight * s.p[c];
        sums[N + c] += weight * s.n[c];
    }
    sums[UV] += weight * s.uv[0];
    sums[UV + 1] += weight * s.uv[1];
    sums[DZ] += weight * s.dzdx;
    sums[DZ + 1] += weight * s.dzdy;
    if let Some(rgb) = rgb {
        sums[COUNT] += 1.0;
        for c in 0..3 {
            sums[RGB + c] += rgb[c];
            sums[RGB2 + c] += rgb[c] * rgb[c];
        }
    }
    true
}

/// The sample variance of `n` values with sum `sum` and sum of squares `sq`, and their mean.
///
/// (Σx² − (Σx)²/n)/(n−1) is pbrt-v4's S/(n−1) (Welford's S is Σ(x − mean)²). The difference is never negative in
/// exact arithmetic; where it is within the rounding of the two sums (at most about 3n·ε·Σx² for sums of n terms)
/// the samples are equal to working precision and the variance is 0.
fn variance(n: f64, sum: f64, sq: f64) -> (f64, f64) {
    if n < 1.0 {
        return (0.0, 0.0);
    }
    let mean = sum / n;
    if n < 2.0 {
        return (mean, 0.0);
    }
    let d = sq - sum * sum / n;
    let var = if d <= 3.0 * n * f64::EPSILON * sq { 0.0 } else { d / (n - 1.0) };
    (mean, var)
}

fn pixel(sums: &[f64; NSUMS]) -> GBufferPixel {
    let w = sums[W];
    // pbrt-v4 divides the geometry by the weight of the samples that saw a surface (when not 0).
    let k = if w != 0.0 { 1.0 / w } else { 1.0 };
    let n = [sums[N], sums[N + 1], sums[N + 2]];
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    let mut out = GBufferPixel {
        p: [sums[P] * k, sums[P + 1] * k, sums[P + 2] * k],
        dz: [(sums[DZ] * k).abs(), (sums[DZ + 1] * k).abs()],
        n: if len > 0.0 { n.map(|c| c / len) } else { [0.0; 3] },
        uv: [sums[UV] * k, sums[UV + 1] * k],
        count: sums[COUNT],
        ..GBufferPixel::default()
    };
    for c in 0..3 {
        let (mean, var) = variance(sums[COUNT], sums[RGB + c], sums[RGB2 + c]);
        out.mean[c] = mean;
        out.variance[c] = var;
        // pbrt-v4's VarianceEstimator::RelativeVariance: 0 without samples or with a zero mean.
        out.relative_variance[c] = if sums[COUNT] < 1.0 || mean == 0.0 { 0.0 } else { var / mean };
    }
    out
}

impl FilmRow<'_> {
    /// Adds the first visible surface of a camera sample of pixel `x` with filter weight `weight` (the one given
    /// to [`FilmRow::add_sample`]) to a gbuffer film's geometry, and `sample`, the radiance `l` the camera sample
    /// brought at wavelengths `wl`, to the pixel's variance estimate (`None` for an integrator whose pixel values
    /// are not means of samples). Ignored (returns `false`) without a gbuffer, outside the row, or for non-finite
    /// values.
    pub fn add_visible_surface(
        &mut self,
        x: u32,
        surface: &VisibleSurface,
        weight: f64,
        sample: Option<(&SampledSpectrum, &SampledWavelengths)>,
    ) -> bool {
        let x = x.wrapping_sub(self.x0) as usize;
        if x >= self.surfaces.len() {
            return false;
        }
        let rgb = sample.map(|(l, wl)| sample_rgb(self.conv, self.output_matrix, self.color_space, l, wl));
        accumulate(&mut self.surfaces[x], surface, weight, rgb)
    }
}

impl Film {
    /// Whether the film keeps pbrt-v4's geometry buffer (`Film "gbuffer"`).
    pub fn has_gbuffer(&self) -> bool {
        self.spec.gbuffer.is_some()
    }

    /// [`FilmRow::add_visible_surface`] for pixel (x, y).
    pub fn add_visible_surface(
        &mut self,
        x: u32,
        y: u32,
        surface: &VisibleSurface,
        weight: f64,
        sample: Option<(&SampledSpectrum, &SampledWavelengths)>,
    ) -> bool {
        let Some(i) = self.index(x, y).filter(|&i| i < self.surfaces.len()) else { return false };
        let rgb =
            sample.map(|(l, wl)| sample_rgb(&self.conversion, &self.output_matrix, &self.spec.color_space, l, wl));
        accumulate(&mut self.surfaces[i], surface, weight, rgb)
    }

    /// The gbuffer's values at pixel (x, y) in full precision; `None` without a gbuffer or outside the film.
    pub fn pixel_gbuffer(&self, x: u32, y: u32) -> Option<GBufferPixel> {
        let i = self.index(x, y)?;
        self.surfaces.get(i).map(pixel)
    }

    /// The gbuffer's images (pixels of [`Film::bounds`]), or `None` without a gbuffer.
    pub fn to_gbuffer_images(&self) -> Option<GBufferImages> {
        if !self.has_gbuffer() {
            return None;
        }
        let mut out = GBufferImages::default();
        let f = |v: f64| v as f32;
        for sums in &self.surfaces {
            let px = pixel(sums);
            out.p.push(px.p.map(f));
            out.dz.push(px.dz.map(f));
            out.n.push(px.n.map(f));
            out.uv.push(px.uv.map(f));
            out.variance.push(px.variance.map(f));
            out.relative_variance.push(px.relative_variance.map(f));
        }
        Some(out)
    }
}

#[cfg(test)]
mod tests {
    use super::variance;

    #[test]
    fn equal_samples_have_no_variance_and_others_the_sample_variance() {
        // 0.1 is not exact in binary: the sums round, yet equal samples give exactly 0.
        for (n, x) in [(7.0, 0.1), (1000.0, 3.7), (2.0, 1e-30), (4096.0, 123456.789)] {
            let (sum, sq) = (0..n as usize).fold((0.0, 0.0), |(s, q), _| (s + x, q + x * x));
            assert_eq!(variance(n, sum, sq), (sum / n, 0.0), "{n} × {x}");
        }
        // 1, 2, 3, 4: mean 2.5, S = 5, S/(n−1) = 5/3.
        let (mean, var) = variance(4.0, 10.0, 30.0);
        assert_eq!(mean, 2.5);
        assert!((var - 5.0 / 3.0).abs() < 1e-15);
        assert_eq!(variance(1.0, 2.0, 4.0), (2.0, 0.0));
        assert_eq!(variance(0.0, 0.0, 0.0), (0.0, 0.0));
    }
}

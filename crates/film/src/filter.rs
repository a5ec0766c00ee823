//! Pixel reconstruction filters and their importance sampling.
//!
//! The filters are pbrt-v4's, with its parameters and defaults: box (radius 0.5), gaussian (radius 1.5, σ 0.5, the
//! gaussian minus its value at the radius so that it reaches zero there), triangle (radius 2) and Mitchell–Netravali
//! (radius 2, B = C = 1/3). Radii are per axis, in pixels.
//!
//! Like pbrt-v4, the film does not splat a camera sample into every pixel its filter covers. Instead the camera
//! sample's offset from the pixel centre is *drawn from the filter* ([`FilterSampler::sample`]: exactly for the box,
//! otherwise from tabulated 1D distributions of |f| along each axis), and the sample is weighted by f(p)/pdf(p). Each sample then
//! touches only its own pixel, so pixels are independent: rendering is lock-free and deterministic for any thread
//! count. For a positive filter the weight is (close to) the constant ∫f; a filter with negative lobes (Mitchell)
//! gives weights of either sign, all of one magnitude (see `SignedWeights` for why).

use crate::FilmError;
use spectral::Distribution1D;

/// A pixel reconstruction filter, centred on the pixel centre, with per-axis radii in pixels.
#[derive(Clone, Debug, PartialEq)]
pub enum Filter {
    /// f = 1 inside the radius.
    Box {
        /// Half-widths in x and y (pbrt-v4 default 0.5).
        radius: [f64; 2],
    },
    /// pbrt-v4's gaussian: per axis, g(x) − g(radius) clamped at zero, with g the normal density of σ.
    Gaussian {
        /// Half-widths in x and y (pbrt-v4 default 1.5).
        radius: [f64; 2],
        /// Standard deviation in pixels (pbrt-v4 default 0.5).
        sigma: f64,
    },
    /// Per axis, max(0, radius − |x|).
    Triangle {
        /// Half-widths in x and y (pbrt-v4 default 2).
        radius: [f64; 2],
    },
    /// The Mitchell–Netravali cubic, per axis, scaled to the radius (negative lobes).
    Mitchell {
        /// Half-widths in x and y (pbrt-v4 default 2).
        radius: [f64; 2],
        /// The B parameter (pbrt-v4 default 1/3).
        b: f64,
        /// The C parameter (pbrt-v4 default 1/3).
        c: f64,
    },
}

impl Default for Filter {
    /// pbrt-v4's default filter: the gaussian with radius 1.5 and σ = 0.5.
    fn default() -> Self {
        Filter::Gaussian { radius: [1.5; 2], sigma: 0.5 }
    }
}

fn check_radius(radius: [f64; 2]) -> Result<(), FilmError> {
    for (name, value) in [("xradius", radius[0]), ("yradius", radius[1])] {
        if !(value.is_finite() && value > 0.0) {
            return Err(FilmError::InvalidParameter { name, value, expected: "a finite radius greater than 0" });
        }
    }
    Ok(())
}

impl Filter {
    /// The filter names [`Filter::name`] gives, as pbrt-v4 scene files spell them.
    pub const NAMES: [&'static str; 4] = ["box", "gaussian", "triangle", "mitchell"];

    /// A box filter with the given radii, validated.
    pub fn new_box(radius: [f64; 2]) -> Result<Self, FilmError> {
        let f = Filter::Box { radius };
        f.validate()?;
        Ok(f)
    }

    /// A gaussian filter with the given radii and σ, validated.
    pub fn gaussian(radius: [f64; 2], sigma: f64) -> Result<Self, FilmError> {
        let f = Filter::Gaussian { radius, sigma };
        f.validate()?;
        Ok(f)
    }

    /// A triangle filter with the given radii, validated.
    pub fn triangle(radius: [f64; 2]) -> Result<Self, FilmError> {
        let f = Filter::Triangle { radius };
        f.validate()?;
        Ok(f)
    }

    /// A Mitchell–Netravali filter with the given radii and B, C, validated.
    pub fn mitchell(radius: [f64; 2], b: f64, c: f64) -> Result<Self, FilmError> {
        let f = Filter::Mitchell { radius, b, c };
        f.validate()?;
        Ok(f)
    }

    /// pbrt-v4's default for the named filter (`box`, `gaussian`, `triangle`, `mitchell`), or `None`.
    pub fn default_for(name: &str) -> Option<Self> {
        match name {
            "box" => Some(Filter::Box { radius: [0.5; 2] }),
            "gaussian" => Some(Filter::default()),
            "triangle" => Some(Filter::Triangle { radius: [2.0; 2] }),
            "mitchell" => Some(Filter::Mitchell { radius: [2.0; 2], b: 1.0 / 3.0, c: 1.0 / 3.0 }),
            _ => None,
        }
    }

    /// Checks every parameter, naming the first bad one (`xradius`, `yradius`, `sigma`, `B`, `C`).
    pub fn validate(&self) -> Result<(), FilmError> {
        check_radius(self.radius())?;
        match *self {
            Filter::Gaussian { sigma, .. } if !(sigma.is_finite() && sigma > 0.0) => Err(FilmError::InvalidParameter {
                name: "sigma",
                value: sigma,
                expected: "a finite standard deviation greater than 0",
            }),
            Filter::Mitchell { b, c, .. } => {
                for (name, value) in [("B", b), ("C", c)] {
                    if !value.is_finite() {
                        return Err(FilmError::InvalidParameter { name, value, expected: "a finite number" });
                    }
                }
                Ok(())
            }
            Filter::Box { .. } | Filter::Gaussian { .. } | Filter::Triangle { .. } => Ok(()),
        }
    }

    /// The filter's name as pbrt-v4 scene files spell it.
    pub fn name(&self) -> &'static str {
        match self {
            Filter::Box { .. } => "box",
            Filter::Gaussian { .. } => "gaussian",
            Filter::Triangle { .. } => "triangle",
            Filter::Mitchell { .. } => "mitchell",
        }
    }

    /// The per-axis radii in pixels; the filter is zero outside `[-rx, rx] × [-ry, ry]`.
    pub fn radius(&self) -> [f64; 2] {
        match *self {
            Filter::Box { radius }
            | Filter::Gaussian { radius, .. }
            | Filter::Triangle { radius }
            | Filter::Mitchell { radius, .. } => radius,
        }
    }

    /// The filter's value at offset `p` (pixels) from the pixel centre.
    pub fn evaluate(&self, p: [f64; 2]) -> f64 {
        let r = self.radius();
        if !(p[0].abs() <= r[0] && p[1].abs() <= r[1]) {
            return 0.0;
        }
        match *self {
            Filter::Box { .. } => 1.0,
            Filter::Gaussian { sigma, .. } => {
                let g = |x: f64, r: f64| (gaussian(x, sigma) - gaussian(r, sigma)).max(0.0);
                g(p[0], r[0]) * g(p[1], r[1])
            }
            Filter::Triangle { .. } => (r[0] - p[0].abs()).max(0.0) * (r[1] - p[1].abs()).max(0.0),
            Filter::Mitchell { b, c, .. } => {
                mitchell_1d(2.0 * p[0] / r[0], b, c) * mitchell_1d(2.0 * p[1] / r[1], b, c)
            }
        }
    }

    /// ∫∫ f over the plane, in closed form.
    pub fn integral(&self) -> f64 {
        let r = self.radius();
        match *self {
            Filter::Box { .. } => 4.0 * r[0] * r[1],
            Filter::Gaussian { sigma, .. } => {
                let axis = |r: f64| gaussian_integral(-r, r, sigma) - 2.0 * r * gaussian(r, sigma);
                axis(r[0]) * axis(r[1])
            }
            Filter::Triangle { .. } => r[0] * r[0] * r[1] * r[1],
            // ∫ Mitchell1D over [-2, 2] is 1 for any B, C; the scaling x → 2x/r makes each axis integrate to r/2.
            Filter::Mitchell { .. } => r[0] * r[1] / 4.0,
        }
    }
}

/// The normal density with mean 0 and standard deviation `sigma`, at `x`.
fn gaussian(x: f64, sigma: f64) -> f64 {
    (-x * x / (2.0 * sigma * sigma)).exp() / ((2.0 * std::f64::consts::PI).sqrt() * sigma)
}

/// ∫ from `x0` to `x1` of the normal density with mean 0 and standard deviation `sigma`.
fn gaussian_integral(x0: f64, x1: f64, sigma: f64) -> f64 {
    let s = sigma * std::f64::consts::SQRT_2;
    0.5 * (erf(x1 / s) - erf(x0 / s))
}

/// The error function, to about 1e-13: the Taylor series below |x| = 2.5, the continued fraction of erfc above.
pub(crate) fn erf(x: f64) -> f64 {
    if x.is_nan() {
        return x;
    }
    let a = x.abs();
    let v = if a < 2.5 {
        let (mut term, mut sum, x2) = (a, a, a * a);
        for n in 1..200 {
            term *= -x2 / n as f64;
            let t = term / (2 * n + 1) as f64;
            sum += t;
            if t.abs() < 1e-17 * sum.abs() {
                break;
            }
        }
        sum * 2.0 / std::f64::consts::PI.sqrt()
    } else if a > 6.0 {
        1.0
    } else {
        let mut t = a;
        for k in (1..=80).rev() {
            t = a + (k as f64 / 2.0) / t;
        }
        1.0 - (-a * a).exp() / std::f64::consts::PI.sqrt() / t
    };
    v.copysign(x)
}

/// The Mitchell–Netravali cubic on [-2, 2] (zero outside).
fn mitchell_1d(x: f64, b: f64, c: f64) -> f64 {
    let x = x.abs();
    if x <= 1.0 {
        ((12.0 - 9.0 * b - 6.0 * c) * x * x * x + (-18.0 + 12.0 * b + 6.0 * c) * x * x + (6.0 - 2.0 * b)) / 6.0
    } else if x <= 2.0 {
        ((-b - 6.0 * c) * x * x * x + (6.0 * b + 30.0 * c) * x * x + (-12.0 * b - 48.0 * c) * x + (8.0 * b + 24.0 * c))
            / 6.0
    } else {
        0.0
    }
}

/// A draw from a filter: where the camera sample goes relative to the pixel centre, and its weight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilterSample {
    /// Offset from the pixel centre in pixels, inside the filter's radius.
    pub offset: [f64; 2],
    /// f(offset) / pdf(offset): the sample's weight in the pixel's weighted average (1 for the default box; for
    /// Mitchell's filter ± one magnitude, the sign of the tabulated filter).
    pub weight: f64,
}

/// Tabulated cells per pixel of radius (pbrt-v4 uses 32; 64 halves the spread of the weights f/pdf, to ~2.5%).
const CELLS_PER_PIXEL: f64 = 64.0;
/// Upper bound on the tabulated cells per axis, so that a huge radius cannot exhaust memory.
const MAX_CELLS: f64 = 512.0;

/// Draws camera-sample offsets from a [`Filter`] (pbrt-v4's `FilterSampler`). Immutable and `Sync`: share one
/// between render threads.
#[derive(Clone, Debug)]
pub struct FilterSampler {
    filter: Filter,
    /// `None` for the box, which is sampled exactly; otherwise one tabulated distribution per axis (every filter
    /// here is separable, f(x, y) = fx(x)·fy(y), so sampling x and y independently from |fx| and |fy| is exact
    /// importance sampling of |f| up to the tabulation, and much cheaper than a 2D table).
    distribution: Option<(Distribution1D, Distribution1D)>,
    /// For a filter with negative lobes (Mitchell), the weights it gives: see [`SignedWeights`].
    signed: Option<SignedWeights>,
}

/// The weights of a filter with negative lobes: ±`magnitude`, the sign of the sampled cell of each axis's table.
///
/// A pixel divides its weighted sum by the sum of its samples' weights, and with weights of both signs a few of them
/// can cancel. Weights f/pdf that vary from cell to cell leave a remainder near zero when they nearly cancel, and the
/// pixel explodes (pbrt-v4's RGBFilm does this: at 4 samples per pixel one to three pixels in a hundred of its
/// Mitchell-filtered `veach-ajar` reach ±65504). With one magnitude, rounded to 16 significant bits so that every sum of a pixel's
/// weights is exact in f32 and f64, the sum is a whole multiple of it: zero exactly when the signs balance (the
/// film then leaves the camera part black), and otherwise at least the magnitude, so a pixel of n samples stays
/// within n times its samples' largest value. The effective filter is the table, sign times |f| at the cell
/// centres, as pbrt-v4's is; the magnitude ∫f / (S_x·S_y), with S the table's signed probability per axis, keeps
/// the weights' expectation ∫f.
#[derive(Clone, Debug)]
struct SignedWeights {
    /// Per axis, the sign (±1) of f at the centre of each cell of the table.
    sign: [Vec<f64>; 2],
    magnitude: f64,
}

/// `x` rounded to 16 significant bits (a multiple of a power of two that f32 holds exactly).
fn round_to_16_bits(x: f64) -> f64 {
    let scale = 2f64.powi(15 - x.abs().log2().floor() as i32);
    (x * scale).round() / scale
}

impl FilterSampler {
    /// Validates the filter and tabulates |f| at 64 cells per pixel of radius (at most 512 per axis).
    pub fn new(filter: &Filter) -> Result<Self, FilmError> {
        filter.validate()?;
        let (distribution, signed) = match filter {
            Filter::Box { .. } => (None, None),
            Filter::Gaussian { .. } | Filter::Triangle { .. } | Filter::Mitchell { .. } => {
                let r = filter.radius();
                // One axis of |f| through the centre (f(x, 0) ∝ fx(x) for these separable filters, all non-zero
                // at the origin), tabulated at 64 cells per pixel of radius.
                // Returns the table and the sign of f in each cell.
                let axis = |radius: f64, eval: &dyn Fn(f64) -> f64| -> Result<(Distribution1D, Vec<f64>), FilmError> {
                    let n = (CELLS_PER_PIXEL * radius).ceil().clamp(2.0, MAX_CELLS) as usize;
                    let dx = 2.0 * radius / n as f64;
                    let (values, signs): (Vec<f64>, Vec<f64>) = (0..n)
                        .map(|i| {
                            let x0 = -radius + i as f64 * dx;
                            let centre = eval(x0 + 0.5 * dx);
                            let (left, right) = (eval(x0), eval(x0 + dx));
                            // A cell centred on a zero crossing still needs some probability, or the estimator
                            // would miss the filter's mass there: fall back to the edges' mean (and the sign of
                            // the larger edge).
                            if centre != 0.0 {
                                (centre.abs(), centre.signum())
                            } else {
                                let larger = if left.abs() >= right.abs() { left } else { right };
                                (0.5 * (left.abs() + right.abs()), larger.signum())
                            }
                        })
                        .unzip();
                    Ok((Distribution1D::new(&values, -radius, radius)?, signs))
                };
                let (dx, sx) = axis(r[0], &|x| filter.evaluate([x, 0.0]))?;
                let (dy, sy) = axis(r[1], &|y| filter.evaluate([0.0, y]))?;
                let signed_probability = |d: &Distribution1D, sign: &[f64]| -> f64 {
                    sign.iter().enumerate().map(|(j, s)| s * d.bin_probability(j)).sum()
                };
                let signed = match filter {
                    Filter::Box { .. } | Filter::Gaussian { .. } | Filter::Triangle { .. } => None,
                    Filter::Mitchell { .. } => Some(SignedWeights {
                        magnitude: round_to_16_bits(
                            filter.integral() / (signed_probability(&dx, &sx) * signed_probability(&dy, &sy)),
                        ),
                        sign: [sx, sy],
                    }),
                };
                (Some((dx, dy)), signed)
            }
        };
        Ok(Self { filter: filter.clone(), distribution, signed })
    }

    /// The filter this samples.
    pub fn filter(&self) -> &Filter {
        &self.filter
    }

    /// Draws an offset with `u ∈ [0, 1)²` and returns it with its weight f/pdf.
    ///
    /// The box is sampled uniformly (weight 4·rx·ry, which is 1 for the default radius 0.5); the other filters
    /// from their table, so that the weight is nearly constant (f/pdf), and for Mitchell's filter exactly ± one
    /// magnitude.
    pub fn sample(&self, u: [f64; 2]) -> FilterSample {
        let r = self.filter.radius();
        let u = [u[0].clamp(0.0, 1.0), u[1].clamp(0.0, 1.0)];
        match &self.distribution {
            None => FilterSample {
                offset: [(2.0 * u[0] - 1.0) * r[0], (2.0 * u[1] - 1.0) * r[1]],
                weight: 4.0 * r[0] * r[1],
            },
            Some((dx, dy)) => {
                let (sx, sy) = (dx.sample(u[0]), dy.sample(u[1]));
                let pdf = sx.pdf * sy.pdf;
                let point = [sx.x, sy.x];
                let weight = match &self.signed {
                    Some(w) => w.magnitude * w.sign[0][sx.bin] * w.sign[1][sy.bin],
                    None if pdf > 0.0 => self.filter.evaluate(point) / pdf,
                    None => 0.0,
                };
                FilterSample { offset: point, weight }
            }
        }
    }

    /// The density with which [`FilterSampler::sample`] draws `offset`.
    pub fn pdf(&self, offset: [f64; 2]) -> f64 {
        let r = self.filter.radius();
        if !(offset[0].abs() <= r[0] && offset[1].abs() <= r[1]) {
            return 0.0;
        }
        match &self.distribution {
            None => 1.0 / (4.0 * r[0] * r[1]),
            Some((dx, dy)) => dx.pdf(offset[0]) * dy.pdf(offset[1]),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn erf_matches_reference_values() {
        for (x, e) in [
            (0.0, 0.0),
            (0.5, 0.520_499_877_813_046_5),
            (1.0, 0.842_700_792_949_714_9),
            (2.0, 0.995_322_265_018_952_7),
            (2.6, 0.999_763_965_583_347_3),
            (3.0, 0.999_977_909_503_001_4),
            (-1.0, -0.842_700_792_949_714_9),
        ] {
            assert!((erf(x) - e).abs() < 1e-12, "erf({x}) = {} vs {e}", erf(x));
        }
    }

    #[test]
    fn mitchell_1d_integrates_to_one() {
        let n = 100_000;
        let h = 4.0 / n as f64;
        let s: f64 = (0..n).map(|i| mitchell_1d(-2.0 + (i as f64 + 0.5) * h, 1.0 / 3.0, 1.0 / 3.0) * h).sum();
        assert!((s - 1.0).abs() < 1e-8, "{s}");
    }
}

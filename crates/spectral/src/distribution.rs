//! Tabulated 1D and 2D distributions for importance sampling.
//!
//! [`Distribution1D`] follows the recipe of seed 000 ("Sampling of a discrete pdf (tabulation)"): the cdf is the
//! running sum cdf(xᵢ) = pdf(xᵢ)·Δx + cdf(xᵢ₋₁) with cdf(x₀) = 0, a uniform ξ ∈ [0, 1) is located in its bin
//! (cdf(x_{j−1}) ≤ ξ < cdf(x_j); the seed's binary search, here a guide table and a count of the few edges it
//! leaves, which finds the same bin), the sample is linearly interpolated inside that bin,
//! x = x_min + Δx·(j − (cdf(x_j) − ξ)/(cdf(x_j) − cdf(x_{j−1}))), and its pdf is returned with it. The seed's pdf
//! value cdf(x_j) − cdf(x_{j−1}) is the probability of the bin; divided by Δx it is the density, which is what
//! [`Distribution1D::sample`] returns, so Monte Carlo estimators can divide by it directly.

use crate::{check_finite, SpectrumError};

/// A piecewise-constant density over `[min, max]` with `n` equal bins.
#[derive(Clone, Debug, PartialEq)]
pub struct Distribution1D {
    /// Per bin, everything a draw reads (see [`Bin`]), so that a draw touches one record instead of three arrays.
    bins: Vec<Bin>,
    /// Guide table: `guide[g]` is the bin holding u = g/G, so a search only scans the bins between two entries
    /// (same result as a full binary search, fewer steps).
    guide: Vec<u32>,
    integral: f64,
    min: f64,
    max: f64,
    /// The bin width, `(max − min) / n`.
    dx: f64,
}

/// One bin of a [`Distribution1D`]: its cdf at both edges, its density and the reciprocal of its probability, in
/// one 32-byte record. Renderers draw from these tables at random several times per camera sample, and the
/// tables' lines are mostly not in L1 by then: one record is one miss where three arrays were three.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
struct Bin {
    /// cdf at the bin's lower edge.
    cdf: f64,
    /// cdf at its upper edge (the next bin's `cdf`; 1 for the last).
    next: f64,
    /// The density in the bin, `func / integral` (stored, as are `dx` and `inv_width`, so a draw needs no
    /// division).
    density: f64,
    /// 1 / (next − cdf) (0 for empty bins).
    inv_width: f64,
}

/// One draw from a [`Distribution1D`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample1D {
    /// The sampled value in `[min, max)`.
    pub x: f64,
    /// Its probability density.
    pub pdf: f64,
    /// The bin it fell in.
    pub bin: usize,
}

impl Distribution1D {
    /// Builds the distribution of bin values `func` (finite, non-negative) over `[min, max]`.
    ///
    /// If every value is zero the distribution is uniform (so sampling never fails), as pbrt-v4 does.
    pub fn new(func: &[f64], min: f64, max: f64) -> Result<Self, SpectrumError> {
        check_finite("distribution minimum", min)?;
        check_finite("distribution maximum", max)?;
        if func.is_empty() {
            return Err(SpectrumError::BadTable("distribution needs at least one bin".into()));
        }
        if max <= min {
            return Err(SpectrumError::OutOfRange {
                name: "distribution maximum",
                value: max,
                expected: "greater than the minimum",
            });
        }
        for &v in func {
            check_finite("distribution value", v)?;
            if v < 0.0 {
                return Err(SpectrumError::OutOfRange {
                    name: "distribution value",
                    value: v,
                    expected: "non-negative",
                });
            }
        }
        let n = func.len();
        let dx = (max - min) / n as f64;
        let mut cdf = Vec::with_capacity(n + 1);
        cdf.push(0.0);
        for (i, &f) in func.iter().enumerate() {
            cdf.push(cdf[i] + f * dx); // the seed's running sum
        }
        let integral = cdf[n];
        // An all-zero table becomes the uniform density.
        let (density, integral) = if integral > 0.0 {
            for c in cdf.iter_mut() {
                *c /= integral;
            }
            (func.iter().map(|&f| f / integral).collect::<Vec<_>>(), integral)
        } else {
            for (i, c) in cdf.iter_mut().enumerate() {
                *c = i as f64 / n as f64;
            }
            (vec![1.0 / (max - min); n], max - min)
        };
        cdf[n] = 1.0;
        let g = n.max(1);
        let guide = (0..=g)
            .map(|i| {
                let u = i as f64 / g as f64;
                (cdf.partition_point(|&c| c <= u).saturating_sub(1)).min(n - 1) as u32
            })
            .collect();
        let bins = (0..n)
            .map(|j| {
                let (c0, c1) = (cdf[j], cdf[j + 1]);
                Bin { cdf: c0, next: c1, density: density[j], inv_width: if c1 > c0 { 1.0 / (c1 - c0) } else { 0.0 } }
            })
            .collect();
        Ok(Self { bins, guide, integral, min, max, dx })
    }

    /// Number of bins.
    pub fn len(&self) -> usize {
        self.bins.len()
    }

    /// True if there are no bins (never, by construction).
    pub fn is_empty(&self) -> bool {
        self.bins.is_empty()
    }

    /// ∫ f(x) dx of the (unnormalised) bin values.
    pub fn integral(&self) -> f64 {
        self.integral
    }

    /// The domain `[min, max]`.
    pub fn domain(&self) -> (f64, f64) {
        (self.min, self.max)
    }

    /// The normalised cdf at the bin edges (`len() + 1` values from 0 to 1).
    pub fn cdf_table(&self) -> Vec<f64> {
        self.bins.iter().map(|b| b.cdf).chain([1.0]).collect()
    }

    /// Draws x from the density with `u ∈ [0, 1)`; see the module docs for the recipe.
    pub fn sample(&self, u: f64) -> Sample1D {
        let n = self.len();
        let u = u.clamp(0.0, 1.0);
        // The bin j with cdf[j] ≤ u < cdf[j + 1] (the last such edge when empty bins repeat a cdf value), between
        // the bins the guide table gives for the ends of u's guide cell: the count of bins from `lo` whose upper
        // edge is ≤ u. Most cells span at most three bins, counted without branches (a loop of one to three
        // steps mispredicted its exit on most draws); wider ones (a narrow peak) take the loop.
        let g = self.guide.len() - 1;
        let gi = ((u * g as f64) as usize).min(g - 1);
        let (lo, hi) = (self.guide[gi] as usize, self.guide[gi + 1] as usize);
        let j = if hi <= lo + 2 {
            let step = |k: usize| usize::from(self.bins[k.min(n - 1)].next <= u);
            lo + step(lo) + step(lo + 1)
        } else {
            lo + self.bins[lo..=hi].iter().map(|b| usize::from(b.next <= u)).sum::<usize>()
        }
        .min(n - 1);
        let b = &self.bins[j];
        let t = ((u - b.cdf) * b.inv_width).clamp(0.0, 1.0);
        let x = (self.min + (j as f64 + t) * self.dx).min(self.max);
        Sample1D { x, pdf: b.density, bin: j }
    }

    /// Density at `x` (0 outside the domain).
    pub fn pdf(&self, x: f64) -> f64 {
        if !(x >= self.min && x <= self.max) {
            return 0.0;
        }
        let j = (((x - self.min) / self.dx) as usize).min(self.len() - 1);
        self.bins[j].density
    }

    /// Probability of bin `j` (the seed's cdf(x_j) − cdf(x_{j−1})).
    pub fn bin_probability(&self, j: usize) -> f64 {
        self.bins[j].next - self.bins[j].cdf
    }

    /// The cdf at `x`: the inverse of [`Distribution1D::sample`], so that `sample(cdf(x)).x == x`.
    pub fn cdf(&self, x: f64) -> f64 {
        if x <= self.min {
            return 0.0;
        }
        if x >= self.max {
            return 1.0;
        }
        let s = (x - self.min) / self.dx;
        let j = (s as usize).min(self.len() - 1);
        let t = s - j as f64;
        let b = &self.bins[j];
        b.cdf + t * (b.next - b.cdf)
    }

    /// Draws a bin index with probability proportional to its value; returns the index, its probability and `u`
    /// remapped to [0, 1) within the bin (for reuse as a fresh uniform number).
    pub fn sample_discrete(&self, u: f64) -> (usize, f64, f64) {
        if self.len() == 1 {
            // One bin (a scene with one light): what the general path returns, without the search.
            return (0, 1.0, u.clamp(0.0, 1.0 - f64::EPSILON));
        }
        let s = self.sample(u);
        let p = self.bin_probability(s.bin);
        let remapped = if p > 0.0 { ((u - self.bins[s.bin].cdf) / p).clamp(0.0, 1.0 - f64::EPSILON) } else { 0.0 };
        (s.bin, p, remapped)
    }
}

/// A piecewise-constant density over a rectangle, sampled as a marginal over rows and a conditional within the row.
#[derive(Clone, Debug, PartialEq)]
pub struct Distribution2D {
    conditional: Vec<Distribution1D>,
    marginal: Distribution1D,
}

/// One draw from a [`Distribution2D`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample2D {
    /// The sampled point (x along a row, y across rows).
    pub point: [f64; 2],
    /// Its probability density with respect to area in the domain.
    pub pdf: f64,
}

impl Distribution2D {
    /// Builds the distribution of `values` (row-major, `height` rows of `width` columns; finite, non-negative) over
    /// `[x0, x1] × [y0, y1]`.
    pub fn new(
        values: &[f64],
        width: usize,
        height: usize,
        x: (f64, f64),
        y: (f64, f64),
    ) -> Result<Self, SpectrumError> {
        if width == 0 || height == 0 || values.len() != width * height {
            return Err(SpectrumError::BadTable(format!(
                "2D distribution of {width}×{height} needs {} values, got {}",
                width * height,
                values.len()
            )));
        }
        let conditional =
            values.chunks(width).map(|row| Distribution1D::new(row, x.0, x.1)).collect::<Result<Vec<_>, _>>()?;
        let row_integrals: Vec<f64> =
            values.chunks(width).map(|r| r.iter().sum::<f64>() * (x.1 - x.0) / width as f64).collect();
        let marginal = Distribution1D::new(&row_integrals, y.0, y.1)?;
        Ok(Self { conditional, marginal })
    }

    /// Draws a point with `u ∈ [0, 1)²`: the row from the marginal with `u[1]`, the column within it with `u[0]`.
    pub fn sample(&self, u: [f64; 2]) -> Sample2D {
        let row = self.marginal.sample(u[1]);
        let col = self.conditional[row.bin].sample(u[0]);
        Sample2D { point: [col.x, row.x], pdf: row.pdf * col.pdf }
    }

    /// Density at `point`.
    pub fn pdf(&self, point: [f64; 2]) -> f64 {
        let (y0, y1) = self.marginal.domain();
        if !(point[1] >= y0 && point[1] <= y1) {
            return 0.0;
        }
        let n = self.marginal.len();
        let row = (((point[1] - y0) / (y1 - y0) * n as f64) as usize).min(n - 1);
        self.marginal.pdf(point[1]) * self.conditional[row].pdf(point[0])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seed_recipe_on_a_small_table() {
        // Bins [0,1), [1,2), [2,3), [3,4) with weights 1, 0, 3, 4: cdf = 0, 1/8, 1/8, 4/8, 1.
        let d = Distribution1D::new(&[1.0, 0.0, 3.0, 4.0], 0.0, 4.0).unwrap();
        assert_eq!(d.cdf_table(), [0.0, 0.125, 0.125, 0.5, 1.0]);
        let s = d.sample(0.3125); // halfway through bin 2
        assert_eq!(s.bin, 2);
        assert!((s.x - 2.5).abs() < 1e-12);
        assert!((s.pdf - 3.0 / 8.0).abs() < 1e-12);
        // The empty bin is never chosen, even at its cdf value.
        assert_eq!(d.sample(0.125).bin, 2);
        assert!((d.cdf(2.5) - 0.3125).abs() < 1e-12);
        assert_eq!(d.sample(0.0).x, 0.0);
        assert!(d.sample(0.999_999_9).x < 4.0);
    }

    #[test]
    fn guided_search_finds_the_same_bin_as_a_full_binary_search() {
        let mut x = 12345u64;
        let mut next = || {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (x >> 11) as f64 / (1u64 << 53) as f64
        };
        let peaked = |i: usize| (-((i as f64 - 100.0) / 8.0).powi(2)).exp();
        for (n, is_peaked) in
            [(1usize, false), (2, false), (3, false), (7, false), (100, false), (471, false), (200, true)]
        {
            // Random values with every fourth bin empty; or a narrow peak, whose tails put many bins in one guide
            // cell (the search's loop rather than its fixed steps).
            let f: Vec<f64> = (0..n)
                .map(|i| {
                    if is_peaked {
                        peaked(i)
                    } else if i % 4 == 2 {
                        0.0
                    } else {
                        next() * next() * 10.0
                    }
                })
                .collect();
            let d = Distribution1D::new(&f, 0.0, 1.0).unwrap();
            let cdf = d.cdf_table();
            for k in 0..5000 {
                let u = if k < 3 { [0.0, 1.0, 0.5][k] } else { next() };
                let full = (cdf.partition_point(|&c| c <= u).saturating_sub(1)).min(n - 1);
                assert_eq!(d.sample(u).bin, full, "n {n}, u {u}");
            }
        }
    }

    #[test]
    fn all_zero_is_uniform_and_bad_values_are_rejected() {
        let d = Distribution1D::new(&[0.0, 0.0], 10.0, 20.0).unwrap();
        assert!((d.pdf(12.0) - 0.1).abs() < 1e-12);
        assert!(Distribution1D::new(&[1.0, -1.0], 0.0, 1.0).is_err());
        assert!(Distribution1D::new(&[1.0, f64::NAN], 0.0, 1.0).is_err());
        assert!(Distribution1D::new(&[], 0.0, 1.0).is_err());
        assert!(Distribution1D::new(&[1.0], 1.0, 1.0).is_err());
        assert!(Distribution2D::new(&[1.0; 5], 2, 3, (0.0, 1.0), (0.0, 1.0)).is_err());
    }
}

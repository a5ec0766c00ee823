//! Bilinearly interpolated 2-D tables on the unit square that can depend on up to three parameters, with
//! marginal-conditional sampling of the density they describe and its exact inverse: the `PiecewiseLinear2D` of
//! pbrt-v4 (`util/sampling.h`) and Mitsuba (`Marginal2D`), after Dupuy & Jakob 2018, §5.
//!
//! The table holds `nx × ny` values per slice (x contiguous); a slice exists for every combination of the
//! parameters' tabulated values, and between them every query interpolates the slices linearly in each parameter
//! (clamped at the ends). Positions are in [0, 1]², the nodes at i/(nx − 1) and j/(ny − 1).
//!
//! A table built for sampling is a density: each slice is normalised so that its bilinear interpolant integrates
//! to 1, and the cumulative sums of rows (conditional) and of row totals (marginal) are stored. Interpolating
//! these between slices gives exactly the cumulative sums of the interpolated density, so [`Warp2D::sample`] and
//! [`Warp2D::invert`] stay inverse to each other and their densities are [`Warp2D::eval`] at every parameter value.

use crate::error::invalid_data as bad;
use crate::RenderError;

/// The most parameters a table may depend on.
pub const MAX_PARAMS: usize = 3;

/// A 2-D table over [0, 1]² with optional parameters.
#[derive(Clone)]
pub struct Warp2D {
    nx: usize,
    ny: usize,
    params: Vec<Vec<f32>>,
    /// Stride between consecutive values of each parameter, in slices (0 for a parameter with one value).
    strides: Vec<usize>,
    data: Vec<f32>,
    marginal_cdf: Vec<f32>,
    conditional_cdf: Vec<f32>,
}

impl std::fmt::Debug for Warp2D {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let res: Vec<usize> = self.params.iter().map(|p| p.len()).collect();
        write!(f, "Warp2D {{ {}×{}, parameters {res:?}, sampling {} }}", self.nx, self.ny, self.can_sample())
    }
}

/// A sampled position and the density there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WarpSample {
    /// The position in [0, 1]².
    pub p: [f32; 2],
    /// The density at `p` (or, from [`Warp2D::invert`], the density at the position inverted).
    pub pdf: f32,
}

/// Interpolation of the parameters: the first slice's index and, for each corner of the parameter cell, its slice
/// offset and weight.
struct Corners {
    n: usize,
    offset: [usize; 1 << MAX_PARAMS],
    weight: [f32; 1 << MAX_PARAMS],
}

/// The largest i in [0, n − 2] with `pred(i)` true, for a predicate that is true up to some index and false after
/// (0 if it is false everywhere): the interval of a sorted sequence that holds a value.
fn find_interval(n: usize, pred: impl Fn(usize) -> bool) -> usize {
    let (mut lo, mut hi) = (1usize, n.saturating_sub(1).max(1));
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        if pred(mid) {
            lo = mid + 1;
        } else {
            hi = mid;
        }
    }
    lo - 1
}

impl Warp2D {
    /// A table of `nx × ny` values per slice with `params[k]` the tabulated values of parameter k (increasing), the
    /// data laid out as `[params[0].len(), …, ny, nx]` with x contiguous. With `sampling`, each slice is normalised
    /// to a density and the cumulative sums for sampling are built (a slice whose values are all zero becomes
    /// uniform); otherwise the values are kept as they are and only interpolated. `what` names the table in errors.
    pub fn new(
        what: &str,
        data: &[f32],
        nx: usize,
        ny: usize,
        params: &[&[f32]],
        sampling: bool,
    ) -> Result<Self, RenderError> {
        if nx < 2 || ny < 2 {
            return Err(bad(format!("'{what}': a {nx}×{ny} table is too small (at least 2×2)")));
        }
        if params.len() > MAX_PARAMS {
            return Err(bad(format!("'{what}': {} parameters, at most {MAX_PARAMS}", params.len())));
        }
        let mut slices = 1usize;
        let mut strides = vec![0; params.len()];
        for k in (0..params.len()).rev() {
            let values = params[k];
            if values.is_empty() {
                return Err(bad(format!("'{what}': parameter {k} has no values")));
            }
            if values.iter().any(|v| !v.is_finite()) || values.windows(2).any(|w| w[1] <= w[0]) {
                return Err(bad(format!("'{what}': parameter {k}'s values must be finite and increasing")));
            }
            strides[k] = if values.len() > 1 { slices } else { 0 };
            slices = slices.checked_mul(values.len()).ok_or_else(|| bad(format!("'{what}': too many slices")))?;
        }
        let per_slice = nx.checked_mul(ny).ok_or_else(|| bad(format!("'{what}': too many values")))?;
        if slices.checked_mul(per_slice) != Some(data.len()) {
            return Err(bad(format!("'{what}': {} values, expected {slices} slices of {nx}×{ny}", data.len())));
        }
        if let Some(i) = data.iter().position(|v| !v.is_finite()) {
            return Err(bad(format!("'{what}': value {i} is {}, not a finite number", data[i])));
        }
        let mut w = Warp2D {
            nx,
            ny,
            params: params.iter().map(|p| p.to_vec()).collect(),
            strides,
            data: Vec::with_capacity(data.len()),
            marginal_cdf: vec![],
            conditional_cdf: vec![],
        };
        if !sampling {
            w.data.extend_from_slice(data);
            return Ok(w);
        }
        if let Some(i) = data.iter().position(|&v| v < 0.0) {
            return Err(bad(format!("'{what}': value {i} is {}, a density must not be negative", data[i])));
        }
        w.marginal_cdf = Vec::with_capacity(slices * ny);
        w.conditional_cdf = Vec::with_capacity(slices * per_slice);
        let uniform = vec![1.0f32; per_slice];
        for slice in data.chunks_exact(per_slice) {
            let total: f64 = slice.iter().map(|&v| v as f64).sum();
            let slice = if total > 0.0 { slice } else { &uniform[..] };
            // Trapezoid sums in units of one patch: conditional along each row, then marginal over rows.
            let cond_start = w.conditional_cdf.len();
            for row in slice.chunks_exact(nx) {
                let mut sum = 0.0f64;
                w.conditional_cdf.push(0.0);
                for x in 0..nx - 1 {
                    sum += 0.5 * (row[x] as f64 + row[x + 1] as f64);
                    w.conditional_cdf.push(sum as f32);
                }
            }
            let cond = &w.conditional_cdf[cond_start..];
            let marg_start = w.marginal_cdf.len();
            let mut sum = 0.0f64;
            w.marginal_cdf.push(0.0);
            for y in 0..ny - 1 {
                sum += 0.5 * (cond[(y + 1) * nx - 1] as f64 + cond[(y + 2) * nx - 1] as f64);
                w.marginal_cdf.push(sum as f32);
            }
            // The integral of the bilinear interpolant is sum/((nx − 1)(ny − 1)); dividing by sum here and
            // multiplying by (nx − 1)(ny − 1) on every lookup makes it 1.
            let norm = (1.0 / sum) as f32;
            w.conditional_cdf[cond_start..].iter_mut().for_each(|v| *v *= norm);
            w.marginal_cdf[marg_start..].iter_mut().for_each(|v| *v *= norm);
            w.data.extend(slice.iter().map(|&v| v * norm));
        }
        Ok(w)
    }

    /// True if the table was built for sampling.
    pub fn can_sample(&self) -> bool {
        !self.marginal_cdf.is_empty()
    }

    /// The slice offsets and weights of the parameter cell holding `param`.
    fn corners(&self, param: &[f32]) -> Corners {
        let mut c = Corners { n: 1, offset: [0; 1 << MAX_PARAMS], weight: [0.0; 1 << MAX_PARAMS] };
        c.weight[0] = 1.0;
        for (k, values) in self.params.iter().enumerate() {
            if values.len() == 1 {
                continue;
            }
            let p = param[k];
            let i = find_interval(values.len(), |j| values[j] <= p);
            let (p0, p1) = (values[i], values[i + 1]);
            let t = ((p - p0) / (p1 - p0)).clamp(0.0, 1.0);
            // NaN parameters (never from the BxDF, which passes angles and wavelengths) count as the first value.
            let t = if t.is_nan() { 0.0 } else { t };
            let base = i * self.strides[k];
            for j in 0..c.n {
                c.offset[j + c.n] = c.offset[j] + base + self.strides[k];
                c.weight[j + c.n] = c.weight[j] * t;
                c.offset[j] += base;
                c.weight[j] *= 1.0 - t;
            }
            c.n *= 2;
        }
        c
    }

    /// Value `i` of a slice of `table` (`stride` values per slice), interpolated between the parameter corners.
    #[inline]
    fn lookup(c: &Corners, table: &[f32], stride: usize, i: usize) -> f32 {
        let mut v = 0.0;
        for j in 0..c.n {
            v += c.weight[j] * table[c.offset[j] * stride + i];
        }
        v
    }

    /// Interpolated value (or density) at `pos` for parameters `param`.
    pub fn eval(&self, pos: [f32; 2], param: &[f32]) -> f32 {
        let c = self.corners(param);
        let (fx, fy) = ((self.nx - 1) as f32, (self.ny - 1) as f32);
        let (x, y) = (pos[0].clamp(0.0, 1.0) * fx, pos[1].clamp(0.0, 1.0) * fy);
        let (ix, iy) = ((x as usize).min(self.nx - 2), (y as usize).min(self.ny - 2));
        let (wx, wy) = (x - ix as f32, y - iy as f32);
        let size = self.nx * self.ny;
        let i = ix + iy * self.nx;
        let at = |d: usize| Self::lookup(&c, &self.data, size, i + d);
        let (v00, v10, v01, v11) = (at(0), at(1), at(self.nx), at(self.nx + 1));
        let v = (1.0 - wy) * ((1.0 - wx) * v00 + wx * v10) + wy * ((1.0 - wx) * v01 + wx * v11);
        if self.can_sample() {
            v * fx * fy
        } else {
            v
        }
    }

    /// Maps a uniform point `u` of [0, 1]² to a point distributed by the density (marginal in y, then conditional
    /// in x, each inverting a piecewise-linear density in closed form), with the density there. `None` only for a
    /// table not built for sampling or if rounding leaves no valid interval.
    pub fn sample(&self, u: [f32; 2], param: &[f32]) -> Option<WarpSample> {
        if !self.can_sample() {
            return None;
        }
        let c = self.corners(param);
        let (nx, ny) = (self.nx, self.ny);
        let one_minus = 1.0 - f32::EPSILON / 2.0;
        let (mut sx, mut sy) = (u[0].clamp(1.0 - one_minus, one_minus), u[1].clamp(1.0 - one_minus, one_minus));

        // The row, from the marginal cumulative sums.
        let marginal = |j: usize| Self::lookup(&c, &self.marginal_cdf, ny, j);
        let row = find_interval(ny, |j| marginal(j) < sy);
        sy -= marginal(row);
        let size = nx * ny;
        let cond = |i: usize| Self::lookup(&c, &self.conditional_cdf, size, i);
        let row_start = row * nx;
        let (r0, r1) = (cond(row_start + nx - 1), cond(row_start + 2 * nx - 1));
        // Invert the linear density between the row totals r0 and r1 (a quadratic), or a constant one.
        sy = invert_linear(sy, r0, r1)?;

        // The column, from the conditional cumulative sums interpolated between the two rows.
        sx *= (1.0 - sy) * r0 + sy * r1;
        let conditional = |i: usize| (1.0 - sy) * cond(row_start + i) + sy * cond(row_start + nx + i);
        let col = find_interval(nx, |i| conditional(i) < sx);
        sx -= conditional(col);
        let i = row_start + col;
        let at = |d: usize| Self::lookup(&c, &self.data, size, i + d);
        let (v00, v10, v01, v11) = (at(0), at(1), at(nx), at(nx + 1));
        let c0 = (1.0 - sy) * v00 + sy * v01;
        let c1 = (1.0 - sy) * v10 + sy * v11;
        sx = invert_linear(sx, c0, c1)?;
        let pdf = ((1.0 - sx) * c0 + sx * c1) * ((nx - 1) * (ny - 1)) as f32;
        let p = [(col as f32 + sx) / (nx - 1) as f32, (row as f32 + sy) / (ny - 1) as f32];
        (pdf.is_finite() && p.iter().all(|v| v.is_finite())).then_some(WarpSample { p, pdf })
    }

    /// The inverse of [`Warp2D::sample`]: the uniform point that maps to `pos`, with the density at `pos`. `None`
    /// for a table not built for sampling, or where the density's row total is zero.
    pub fn invert(&self, pos: [f32; 2], param: &[f32]) -> Option<WarpSample> {
        if !self.can_sample() {
            return None;
        }
        let c = self.corners(param);
        let (nx, ny) = (self.nx, self.ny);
        let (x, y) = (pos[0].clamp(0.0, 1.0) * (nx - 1) as f32, pos[1].clamp(0.0, 1.0) * (ny - 1) as f32);
        let (ix, iy) = ((x as usize).min(nx - 2), (y as usize).min(ny - 2));
        let (mut sx, mut sy) = (x - ix as f32, y - iy as f32);
        let size = nx * ny;
        let i = ix + iy * nx;
        let at = |d: usize| Self::lookup(&c, &self.data, size, i + d);
        let (v00, v10, v01, v11) = (at(0), at(1), at(nx), at(nx + 1));
        let c0 = (1.0 - sy) * v00 + sy * v01;
        let c1 = (1.0 - sy) * v10 + sy * v11;
        let pdf = (1.0 - sx) * c0 + sx * c1;

        // x: the mass of this patch's row segment up to sx, plus the rows' cumulative sums before the patch, over
        // the row total.
        sx *= c0 + 0.5 * sx * (c1 - c0);
        let cond = |k: usize| Self::lookup(&c, &self.conditional_cdf, size, k);
        sx += (1.0 - sy) * cond(i) + sy * cond(i + nx);
        let row_start = iy * nx;
        let (r0, r1) = (cond(row_start + nx - 1), cond(row_start + 2 * nx - 1));
        let total = (1.0 - sy) * r0 + sy * r1;
        if total <= 0.0 {
            return None;
        }
        sx /= total;

        // y: the same along the marginal.
        sy *= r0 + 0.5 * sy * (r1 - r0);
        sy += Self::lookup(&c, &self.marginal_cdf, ny, iy);
        Some(WarpSample { p: [sx, sy], pdf: pdf * ((nx - 1) * (ny - 1)) as f32 })
    }
}

/// The t in [0, 1] where the integral of the linear density a + (b − a)·t from 0 reaches `s` (a quadratic; nearly
/// constant densities are treated as constant, as pbrt-v4 and Mitsuba do, to avoid cancellation).
fn invert_linear(s: f32, a: f32, b: f32) -> Option<f32> {
    let t = if (a - b).abs() < 1e-4 * (a + b) {
        2.0 * s / (a + b)
    } else {
        (a - (a * a - 2.0 * s * (a - b)).max(0.0).sqrt()) / (a - b)
    };
    t.is_finite().then(|| t.clamp(0.0, 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn find_interval_brackets() {
        let v = [0.0f32, 1.0, 2.0, 3.0];
        let f = |x: f32| find_interval(v.len(), |i| v[i] <= x);
        assert_eq!([f(-1.0), f(0.0), f(0.5), f(1.0), f(2.9), f(3.0), f(9.0)], [0, 0, 0, 1, 2, 2, 2]);
        assert_eq!(find_interval(2, |_| true), 0);
    }

    /// A 3×2 table's density is its bilinear interpolant over the interpolant's integral, by hand: the rows 1, 2, 3
    /// and 3, 4, 5 make two patches averaging 2.5 and 3.5, so the integral over [0, 1]² is 3.
    #[test]
    fn density_is_the_normalised_bilinear_interpolant() {
        let data = [1.0, 2.0, 3.0, 3.0, 4.0, 5.0];
        let w = Warp2D::new("t", &data, 3, 2, &[], true).unwrap();
        let raw = Warp2D::new("t", &data, 3, 2, &[], false).unwrap();
        for (x, y) in [(0.0, 0.0), (0.25, 0.5), (0.8, 0.1), (1.0, 1.0)] {
            assert!((w.eval([x, y], &[]) - raw.eval([x, y], &[]) / 3.0).abs() < 1e-6);
        }
        assert_eq!(raw.eval([0.5, 1.0], &[]), 4.0);
        assert!((raw.eval([0.25, 0.5], &[]) - (0.5 * 1.5 + 0.5 * 3.5)).abs() < 1e-6);
    }

    #[test]
    fn sample_and_invert_are_inverse_and_agree_with_eval() {
        // Two parameters, one of them with a single value.
        let (nx, ny) = (5, 4);
        let p0 = [0.0f32];
        let p1 = [0.0f32, 0.5, 2.0];
        let data: Vec<f32> =
            (0..3 * nx * ny).map(|i| 0.2 + ((i * 7919) % 13) as f32 / 5.0 + (i / (nx * ny)) as f32).collect();
        let w = Warp2D::new("t", &data, nx, ny, &[&p0, &p1], true).unwrap();
        for k in 0..200 {
            let u = [((k * 37) % 101) as f32 / 101.0 + 0.004, ((k * 53) % 97) as f32 / 97.0 + 0.005];
            let param = [0.0, (k % 11) as f32 * 0.21];
            let s = w.sample(u, &param).unwrap();
            let back = w.invert(s.p, &param).unwrap();
            assert!((back.p[0] - u[0]).abs() < 2e-4 && (back.p[1] - u[1]).abs() < 2e-4, "{u:?} → {s:?} → {back:?}");
            let e = w.eval(s.p, &param);
            assert!((e - s.pdf).abs() < 1e-4 * e && (back.pdf - e).abs() < 1e-4 * e, "{e} {s:?} {back:?}");
        }
    }

    #[test]
    fn bad_tables_are_errors() {
        assert!(Warp2D::new("t", &[1.0; 4], 1, 4, &[], true).unwrap_err().to_string().contains("too small"));
        assert!(Warp2D::new("t", &[1.0; 5], 2, 2, &[], true).unwrap_err().to_string().contains("expected 1 slices"));
        assert!(Warp2D::new("t", &[1.0, f32::NAN, 1.0, 1.0], 2, 2, &[], false)
            .unwrap_err()
            .to_string()
            .contains("finite"));
        assert!(Warp2D::new("t", &[1.0, -1.0, 1.0, 1.0], 2, 2, &[], true)
            .unwrap_err()
            .to_string()
            .contains("negative"));
        let p = [1.0f32, 1.0];
        assert!(Warp2D::new("t", &[1.0; 8], 2, 2, &[&p], true).unwrap_err().to_string().contains("increasing"));
        // A slice of zeros samples uniformly.
        let w = Warp2D::new("t", &[0.0; 4], 2, 2, &[], true).unwrap();
        assert!((w.eval([0.3, 0.7], &[]) - 1.0).abs() < 1e-6);
    }
}

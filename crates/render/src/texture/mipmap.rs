//! MIP maps of image textures (pbrt-v4 §10.4.3, `MIPMap`): `point` and `bilinear` lookups in the level the ray's
//! footprint picks, `trilinear` and `ewa` filtering over it.
//!
//! As pbrt-v4's `Image::GeneratePyramid`: an image whose sides are not powers of two is first resampled up to the
//! next powers of two with a two-lobe windowed sinc (Lanczos, 4 taps per axis, weights normalised, negative results
//! clamped to 0; texels beyond the edges under the texture's wrap mode); each further level averages 2×2 texels of
//! the one below (a side of one texel is reused), down to a single texel. A power-of-two image is its own first level,
//! in the texels it was read into (8-bit samples stay 8-bit, `film::Texels`); the other levels keep 32-bit floats, one
//! per texel where the image is grey (pbrt-v4 stores every level in the image's own pixel format, re-quantising 8-bit
//! images at every level).
//!
//! Lookups take pbrt-v4's texture coordinates (t = 0 at the bottom row) and their change per pixel.

use std::sync::{Arc, OnceLock};

use glam::Vec2;

use super::{RgbImage, WrapMode};

/// The pyramid of an image: level 0 the (power-of-two) image, each next level half the size, the last 1×1.
#[derive(Clone, Debug, PartialEq)]
pub struct MipMap {
    levels: Vec<Arc<RgbImage>>,
    wrap: WrapMode,
}

/// Texels the EWA filter visits at most in one level before it settles for a bilinear lookup (only absurd
/// `maxanisotropy` values come near it: the footprint's minor axis spans one or two texels of the level chosen).
const MAX_EWA_TEXELS: i64 = 1 << 20;

/// pbrt-v4's EWA weights: a Gaussian exp(−2r²) − exp(−2) tabulated at 128 values of r² in [0, 1].
fn ewa_weights() -> &'static [f32; 128] {
    static TABLE: OnceLock<[f32; 128]> = OnceLock::new();
    TABLE.get_or_init(|| std::array::from_fn(|i| (-2.0 * i as f32 / 127.0).exp() - (-2.0f32).exp()))
}

/// The two-lobe windowed sinc sinc(x)·sinc(x/2) for |x| < 2 (pbrt-v4's `WindowedSinc(x, 2, 2)`).
fn lanczos2(x: f32) -> f32 {
    let sinc = |x: f32| {
        let px = std::f32::consts::PI * x;
        if px.abs() < 1e-5 {
            1.0
        } else {
            px.sin() / px
        }
    };
    if x.abs() > 2.0 {
        0.0
    } else {
        sinc(x) * sinc(x / 2.0)
    }
}

/// For each of `new` texels resampled from `old` (`new` ≥ `old`): its first source texel and the normalised weights
/// of it and the next three (pbrt-v4's `resampleWeights`).
fn resample_weights(old: usize, new: usize) -> Vec<(i64, [f32; 4])> {
    (0..new)
        .map(|i| {
            let centre = (i as f32 + 0.5) * old as f32 / new as f32;
            let first = (centre - 2.0 + 0.5).floor();
            let mut w: [f32; 4] = std::array::from_fn(|j| lanczos2(first + j as f32 + 0.5 - centre));
            let sum: f32 = w.iter().sum();
            w.iter_mut().for_each(|v| *v /= sum);
            (first as i64, w)
        })
        .collect()
}

/// `image` resampled up to `w`×`h` texels, texels beyond its edges read under `wrap`.
fn resample_up(image: &RgbImage, w: usize, h: usize, wrap: WrapMode) -> RgbImage {
    let (wx, wy) = (resample_weights(image.width, w), resample_weights(image.height, h));
    let mut pixels = Vec::with_capacity(w * h);
    for &(y0, ky) in &wy {
        for &(x0, kx) in &wx {
            let mut sum = [0.0f32; 3];
            for (j, ky) in ky.iter().enumerate() {
                for (i, kx) in kx.iter().enumerate() {
                    let t = image.texel(x0 + i as i64, y0 + j as i64, wrap);
                    (0..3).for_each(|c| sum[c] += ky * kx * t[c]);
                }
            }
            pixels.push(sum.map(|v| v.max(0.0)));
        }
    }
    RgbImage::new(w, h, pixels)
}

/// The next MIP level: each texel the mean of a 2×2 block (a side of one texel is used twice).
fn downsample(image: &RgbImage) -> RgbImage {
    let (w, h) = ((image.width / 2).max(1), (image.height / 2).max(1));
    let at = |x: usize, y: usize| image.texels.get(y.min(image.height - 1) * image.width + x.min(image.width - 1));
    let mut pixels = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            let (a, b, c, d) = (at(2 * x, 2 * y), at(2 * x + 1, 2 * y), at(2 * x, 2 * y + 1), at(2 * x + 1, 2 * y + 1));
            pixels.push(std::array::from_fn(|i| 0.25 * (a[i] + b[i] + c[i] + d[i])));
        }
    }
    RgbImage::new(w, h, pixels)
}

impl MipMap {
    /// The pyramid of `image` (not empty) under `wrap`. A power-of-two image is its own level 0.
    pub fn new(image: &Arc<RgbImage>, wrap: WrapMode) -> Self {
        let (w, h) = (image.width.next_power_of_two(), image.height.next_power_of_two());
        let base = if (w, h) == (image.width, image.height) {
            image.clone()
        } else {
            Arc::new(resample_up(image, w, h, wrap))
        };
        let mut levels = vec![base];
        while let Some(last) = levels.last().filter(|l| l.width > 1 || l.height > 1) {
            let next = downsample(last);
            levels.push(Arc::new(next));
        }
        Self { levels, wrap }
    }

    /// Number of levels: 1 + log₂ of the longer side of level 0.
    #[cfg(test)]
    pub fn levels(&self) -> usize {
        self.levels.len()
    }

    /// Level `i` (0 the finest).
    pub fn level(&self, i: usize) -> &RgbImage {
        &self.levels[i.min(self.levels.len() - 1)]
    }

    /// The single texel of the coarsest level (the image's mean, for a power-of-two image).
    fn top(&self) -> [f32; 3] {
        self.levels[self.levels.len() - 1].texels.get(0)
    }

    fn bilerp(&self, level: usize, st: Vec2) -> [f32; 3] {
        self.level(level).bilerp_wrapped(st, self.wrap)
    }

    /// pbrt-v4's level for the `point` and `bilinear` filters, from the footprint (∂s/∂x, ∂t/∂x) = `dst0`,
    /// (∂s/∂y, ∂t/∂y) = `dst1`: ⌊n − 1 + log₂ w⌋ for the filter width w = 2·max|∂|, at least 0 (a footprint of
    /// zero is level 0); `None` at or beyond the last level, where pbrt-v4 reads the last level's single texel.
    fn discrete_level(&self, dst0: Vec2, dst1: Vec2) -> Option<usize> {
        let width = 2.0 * dst0.abs().max(dst1.abs()).max_element();
        let n = self.levels.len();
        let level = (n - 1) as f32 + width.max(1e-8).log2();
        if level >= (n - 1) as f32 {
            return None;
        }
        // `f32::max` returns 0 for a NaN level (a NaN footprint), as for no footprint.
        Some(level.floor().max(0.0) as usize)
    }

    /// pbrt-v4's `point` lookup: the texel nearest to `st` in the level the footprint picks
    /// (`MipMap::discrete_level`).
    pub fn nearest(&self, st: Vec2, dst0: Vec2, dst1: Vec2) -> [f32; 3] {
        match self.discrete_level(dst0, dst1) {
            Some(level) => self.level(level).nearest(st, self.wrap),
            None => self.top(),
        }
    }

    /// pbrt-v4's `bilinear` lookup: bilinear interpolation at `st` in the level the footprint picks
    /// (`MipMap::discrete_level`).
    pub fn bilinear(&self, st: Vec2, dst0: Vec2, dst1: Vec2) -> [f32; 3] {
        match self.discrete_level(dst0, dst1) {
            Some(level) => self.bilerp(level, st),
            None => self.top(),
        }
    }

    /// pbrt-v4's trilinear lookup at `st` with footprint (∂s/∂x, ∂t/∂x) = `dst0`, (∂s/∂y, ∂t/∂y) = `dst1`: the
    /// filter width 2·max|∂| picks the continuous level n − 1 + log₂ width, looked up bilinearly in the two levels
    /// around it and blended linearly; below level 0 it is a bilinear lookup of level 0, beyond the last level
    /// its single texel. (pbrt-v4 does not blend between levels 0 and 1, which makes its lookups jump where the
    /// level reaches 1; here the blend is continuous.)
    pub fn trilinear(&self, st: Vec2, dst0: Vec2, dst1: Vec2) -> [f32; 3] {
        let width = 2.0 * dst0.abs().max(dst1.abs()).max_element();
        let n = self.levels.len();
        let level = (n - 1) as f32 + width.max(1e-8).log2();
        if level >= (n - 1) as f32 {
            return self.top();
        }
        if level.is_nan() || level <= 0.0 {
            return self.bilerp(0, st);
        }
        let i = level.floor();
        let f = level - i;
        let (a, b) = (self.bilerp(i as usize, st), self.bilerp(i as usize + 1, st));
        std::array::from_fn(|c| (1.0 - f) * a[c] + f * b[c])
    }

    /// pbrt-v4's EWA lookup (Heckbert 1989) at `st` with footprint axes `dst0`, `dst1` (as for
    /// [`MipMap::trilinear`]): the minor axis is lengthened so that the major one is at most `max_anisotropy`
    /// times as long, the minor axis's length picks the continuous level, and the two levels around it are each
    /// filtered with a Gaussian over the ellipse the axes span (widened by one texel), then blended. A footprint
    /// without area is a bilinear lookup of level 0.
    pub fn ewa(&self, st: Vec2, dst0: Vec2, dst1: Vec2, max_anisotropy: f32) -> [f32; 3] {
        // pbrt-v4 flips t to image rows (t = 0 at the top) for the whole lookup; the footprint flips with it.
        let (mut major, mut minor) = (Vec2::new(dst0.x, -dst0.y), Vec2::new(dst1.x, -dst1.y));
        if major.length_squared() < minor.length_squared() {
            std::mem::swap(&mut major, &mut minor);
        }
        let (longer, mut shorter) = (major.length(), minor.length());
        if shorter * max_anisotropy < longer && shorter > 0.0 {
            let scale = longer / (shorter * max_anisotropy);
            minor *= scale;
            shorter *= scale;
        }
        if !(shorter > 0.0 && shorter.is_finite() && longer.is_finite()) {
            return self.bilerp(0, st);
        }
        let n = self.levels.len();
        let lod = ((n - 1) as f32 + shorter.log2()).max(0.0);
        let i = lod.floor();
        let f = lod - i;
        let image_st = Vec2::new(st.x, 1.0 - st.y);
        let (a, b) = (
            self.ewa_level(i as usize, image_st, major, minor),
            self.ewa_level(i as usize + 1, image_st, major, minor),
        );
        std::array::from_fn(|c| (1.0 - f) * a[c] + f * b[c])
    }

    /// The EWA filter over level `level` at image coordinates `st` (t down) with axes `d0`, `d1` (image
    /// coordinates).
    fn ewa_level(&self, level: usize, st: Vec2, d0: Vec2, d1: Vec2) -> [f32; 3] {
        if level >= self.levels.len() {
            return self.top();
        }
        let image = &self.levels[level];
        let res = Vec2::new(image.width as f32, image.height as f32);
        let (s, t) = (st.x * res.x - 0.5, st.y * res.y - 0.5);
        let (d0, d1) = (d0 * res, d1 * res);
        // The ellipse A·s² + B·s·t + C·t² < 1 of the two axes, widened by a texel (pbrt-v4 §10.4.5).
        let mut a = d0.y * d0.y + d1.y * d1.y + 1.0;
        let mut b = -2.0 * (d0.x * d0.y + d1.x * d1.y);
        let mut c = d0.x * d0.x + d1.x * d1.x + 1.0;
        let inv_f = 1.0 / (a * c - b * b * 0.25);
        (a, b, c) = (a * inv_f, b * inv_f, c * inv_f);
        // Its bounding box.
        let det = 4.0 * a * c - b * b;
        let inv_det = 1.0 / det;
        let (u_sqrt, v_sqrt) = ((det * c).max(0.0).sqrt(), (a * det).max(0.0).sqrt());
        let (s0, s1) = ((s - 2.0 * inv_det * u_sqrt).ceil(), (s + 2.0 * inv_det * u_sqrt).floor());
        let (t0, t1) = ((t - 2.0 * inv_det * v_sqrt).ceil(), (t + 2.0 * inv_det * v_sqrt).floor());
        let box_ok = [s0, s1, t0, t1].iter().all(|v| v.is_finite() && v.abs() < 1e9);
        let (s0, s1, t0, t1) = (s0 as i64, s1 as i64, t0 as i64, t1 as i64);
        if !box_ok || (s1 - s0 + 1).max(0) * (t1 - t0 + 1).max(0) > MAX_EWA_TEXELS {
            return image.bilerp_texels(s, t, self.wrap);
        }
        let weights = ewa_weights();
        let (mut sum, mut sum_w) = ([0.0f32; 3], 0.0f32);
        for it in t0..=t1 {
            let tt = it as f32 - t;
            for is in s0..=s1 {
                let ss = is as f32 - s;
                let r2 = a * ss * ss + b * ss * tt + c * tt * tt;
                if r2 < 1.0 {
                    let w = weights[((r2 * 128.0) as usize).min(127)];
                    let texel = image.texel(is, it, self.wrap);
                    (0..3).for_each(|k| sum[k] += w * texel[k]);
                    sum_w += w;
                }
            }
        }
        if sum_w > 0.0 {
            sum.map(|v| v / sum_w)
        } else {
            image.bilerp_texels(s, t, self.wrap)
        }
    }
}

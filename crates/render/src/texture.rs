//! Textures: constant, checkerboard and image textures over (u, v), for scalars and spectra.

use glam::{Vec2, Vec3};
use spectral::rgb_uplift::{RgbAlbedoSpectrum, RgbUnboundedSpectrum};
use spectral::{SampledSpectrum, SampledWavelengths, Spectrum, N_WAVELENGTHS};
use std::sync::Arc;

/// Where a texture is evaluated.
#[derive(Clone, Copy, Debug, Default)]
pub struct TextureEvalContext {
    /// Surface (u, v).
    pub uv: Vec2,
    /// World-space point.
    pub p: Vec3,
}

/// pbrt's `uv` mapping: s = su·u + du, t = sv·v + dv.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvMapping {
    /// Scale of u.
    pub su: f32,
    /// Scale of v.
    pub sv: f32,
    /// Offset of u.
    pub du: f32,
    /// Offset of v.
    pub dv: f32,
}

impl Default for UvMapping {
    fn default() -> Self {
        Self { su: 1.0, sv: 1.0, du: 0.0, dv: 0.0 }
    }
}

impl UvMapping {
    /// Texture coordinates for a context.
    pub fn map(&self, ctx: &TextureEvalContext) -> Vec2 {
        Vec2::new(self.su * ctx.uv.x + self.du, self.sv * ctx.uv.y + self.dv)
    }
}

/// A linear RGB image (rows top to bottom), with bilinear lookup and repeat wrapping.
#[derive(Clone, Debug, PartialEq)]
pub struct RgbImage {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Linear RGB pixels.
    pub pixels: Vec<[f32; 3]>,
}

impl RgbImage {
    /// Bilinear lookup at texture coordinates `st` (t = 0 at the top row, as pbrt flips images on load).
    pub fn bilerp(&self, st: Vec2) -> [f32; 3] {
        let x = st.x * self.width as f32 - 0.5;
        let y = (1.0 - st.y) * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let texel = |xi: i64, yi: i64| {
            let xi = xi.rem_euclid(self.width as i64) as usize;
            let yi = yi.rem_euclid(self.height as i64) as usize;
            self.pixels[yi * self.width + xi]
        };
        let (x0, y0) = (x0 as i64, y0 as i64);
        let (a, b, c, d) = (texel(x0, y0), texel(x0 + 1, y0), texel(x0, y0 + 1), texel(x0 + 1, y0 + 1));
        std::array::from_fn(|i| (1.0 - fy) * ((1.0 - fx) * a[i] + fx * b[i]) + fy * ((1.0 - fx) * c[i] + fx * d[i]))
    }
}

/// A scalar texture.
#[derive(Clone, Debug)]
pub enum FloatTexture {
    /// The same value everywhere.
    Constant(f32),
    /// Alternating squares of two textures in (s, t).
    Checkerboard {
        /// Mapping.
        map: UvMapping,
        /// Texture of the even squares.
        tex1: Box<FloatTexture>,
        /// Texture of the odd squares.
        tex2: Box<FloatTexture>,
    },
    /// The mean of an image's channels.
    Image {
        /// Mapping.
        map: UvMapping,
        /// The image.
        image: Arc<RgbImage>,
        /// Multiplier.
        scale: f32,
        /// Invert (1 − value).
        invert: bool,
    },
}

impl FloatTexture {
    /// Value at `ctx`.
    pub fn eval(&self, ctx: &TextureEvalContext) -> f32 {
        match self {
            FloatTexture::Constant(v) => *v,
            FloatTexture::Checkerboard { map, tex1, tex2 } => {
                if checker_even(map.map(ctx)) {
                    tex1.eval(ctx)
                } else {
                    tex2.eval(ctx)
                }
            }
            FloatTexture::Image { map, image, scale, invert } => {
                let rgb = image.bilerp(map.map(ctx));
                let v = scale * (rgb[0] + rgb[1] + rgb[2]) / 3.0;
                if *invert {
                    (1.0 - v).max(0.0)
                } else {
                    v
                }
            }
        }
    }
}

fn checker_even(st: Vec2) -> bool {
    (st.x.floor() as i64 + st.y.floor() as i64) % 2 == 0
}

/// How an image texture's RGB becomes a spectrum.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RgbKind {
    /// Reflectances in [0, 1] (clamped).
    Albedo,
    /// Any non-negative values.
    Unbounded,
}

/// A spectral texture.
#[derive(Clone, Debug)]
pub enum SpectrumTexture {
    /// The same spectrum everywhere.
    Constant(Spectrum),
    /// Alternating squares of two textures.
    Checkerboard {
        /// Mapping.
        map: UvMapping,
        /// Texture of the even squares.
        tex1: Box<SpectrumTexture>,
        /// Texture of the odd squares.
        tex2: Box<SpectrumTexture>,
    },
    /// An RGB image uplifted per lookup (Jakob & Hanika 2019).
    Image {
        /// Mapping.
        map: UvMapping,
        /// The image.
        image: Arc<RgbImage>,
        /// Multiplier.
        scale: f32,
        /// Invert (1 − value).
        invert: bool,
        /// Albedo or unbounded uplifting.
        kind: RgbKind,
    },
}

impl SpectrumTexture {
    /// Values at the path's wavelengths.
    pub fn eval(&self, ctx: &TextureEvalContext, wl: &SampledWavelengths) -> SampledSpectrum {
        match self {
            SpectrumTexture::Constant(s) => s.sample(wl),
            SpectrumTexture::Checkerboard { map, tex1, tex2 } => {
                if checker_even(map.map(ctx)) {
                    tex1.eval(ctx, wl)
                } else {
                    tex2.eval(ctx, wl)
                }
            }
            SpectrumTexture::Image { map, image, scale, invert, kind } => {
                let rgb = image.bilerp(map.map(ctx)).map(|c| {
                    let v = (c * scale).max(0.0);
                    (if *invert { (1.0 - v).max(0.0) } else { v }) as f64
                });
                let mut s = SampledSpectrum::zero();
                match kind {
                    RgbKind::Albedo => {
                        let Ok(sp) = RgbAlbedoSpectrum::new(rgb.map(|c| c.min(1.0))) else { return s };
                        for i in 0..N_WAVELENGTHS {
                            s[i] = sp.eval(wl.lambda(i) as f64) as f32;
                        }
                    }
                    RgbKind::Unbounded => {
                        let Ok(sp) = RgbUnboundedSpectrum::new(rgb) else { return s };
                        for i in 0..N_WAVELENGTHS {
                            s[i] = sp.eval(wl.lambda(i) as f64) as f32;
                        }
                    }
                }
                s
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checkerboard_alternates() {
        let t = FloatTexture::Checkerboard {
            map: UvMapping { su: 4.0, sv: 4.0, du: 0.0, dv: 0.0 },
            tex1: Box::new(FloatTexture::Constant(1.0)),
            tex2: Box::new(FloatTexture::Constant(0.0)),
        };
        let at = |u: f32, v: f32| t.eval(&TextureEvalContext { uv: Vec2::new(u, v), p: Vec3::ZERO });
        assert_eq!(at(0.1, 0.1), 1.0);
        assert_eq!(at(0.3, 0.1), 0.0);
        assert_eq!(at(0.3, 0.3), 1.0);
    }

    #[test]
    fn image_bilinear_lookup_interpolates_and_wraps() {
        let img = RgbImage { width: 2, height: 1, pixels: vec![[0.0; 3], [1.0; 3]] };
        assert!((img.bilerp(Vec2::new(0.25, 0.5))[0] - 0.0).abs() < 1e-6);
        assert!((img.bilerp(Vec2::new(0.5, 0.5))[0] - 0.5).abs() < 1e-6);
        assert!((img.bilerp(Vec2::new(0.0, 0.5))[0] - 0.5).abs() < 1e-6, "wraps");
    }
}

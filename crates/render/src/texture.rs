//! Textures: pbrt-v4's float and spectrum textures (pbrt-v4 §10.3–10.6) — constant, scale, mix, directionmix,
//! bilerp, checkerboard (2-D and 3-D), dots, fbm, wrinkled, windy, marble and image maps — with their 2-D mappings
//! (`uv`, `spherical`, `cylindrical`, `planar`) and the 3-D mapping to texture space.
//!
//! Image maps read a MIP map ([`mipmap`]) as pbrt-v4 does: `point` and `bilinear` in the level the ray's footprint
//! in (s, t) picks, `trilinear` and `ewa` filtering over it; the footprint comes from the context's screen-space
//! derivatives (filled in only at hits on materials that read an image map: [`crate::footprint`]). The other textures are
//! evaluated at a point (pbrt-v4's lookups with a vanishing filter footprint): checkerboards are sharp and noise
//! sums all its octaves, and the pixel filter's supersampling does the antialiasing.

use std::sync::Arc;

use film::Texels;
use glam::{Affine3A, Vec2, Vec3};
use spectral::rgb_uplift::{RgbAlbedoSpectrum, RgbIlluminantSpectrum, RgbUnboundedSpectrum};
use spectral::{SampledSpectrum, SampledWavelengths, Spectrum, N_WAVELENGTHS};

pub mod mipmap;
pub mod noise;

pub use mipmap::MipMap;

/// Where a texture is evaluated (pbrt-v4's `TextureEvalContext`): the point, and how it and its (u, v) change from
/// one pixel to the next (zero where no footprint is known: then filtered lookups are point lookups).
#[derive(Clone, Copy, Debug, Default)]
pub struct TextureEvalContext {
    /// Render-space point.
    pub p: Vec3,
    /// Geometric normal (pbrt-v4 gives textures the surface's geometric normal, not the shading one).
    pub n: Vec3,
    /// Surface (u, v).
    pub uv: Vec2,
    /// Change of `p` per pixel along the film's x.
    pub dpdx: Vec3,
    /// Change of `p` per pixel along the film's y.
    pub dpdy: Vec3,
    /// ∂u/∂x, ∂u/∂y, ∂v/∂x, ∂v/∂y per pixel.
    pub duv: [f32; 4],
    /// The surface's interpolated vertex colour (linear RGB), if its mesh has vertex colours.
    pub vertex_color: Option<Vec3>,
}

impl TextureEvalContext {
    /// A context at point `p` with geometric normal `n` and surface coordinates `uv`, without a footprint.
    pub fn new(p: Vec3, n: Vec3, uv: Vec2) -> Self {
        Self { p, n, uv, ..Self::default() }
    }
}

/// Texture coordinates and their change per pixel along x and y (pbrt-v4's `TexCoord2D`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TexCoord2D {
    /// (s, t).
    pub st: Vec2,
    /// (∂s/∂x, ∂t/∂x).
    pub dst_dx: Vec2,
    /// (∂s/∂y, ∂t/∂y).
    pub dst_dy: Vec2,
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

/// How a 2-D texture finds its (s, t) coordinates (pbrt-v4's `TextureMapping2D`). The matrices are the inverse of
/// the texture's CTM: they take render space to the texture's own space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TextureMapping2D {
    /// (s, t) from the surface's (u, v), scaled and offset.
    Uv(UvMapping),
    /// (s, t) = M·(u, v, 1) for a 2×3 matrix M, rows first: s = m₀u + m₁v + m₂, t = m₃u + m₄v + m₅ (Prismatic's
    /// `"float uvtransform"`, which glTF's `KHR_texture_transform` becomes: rotations and shears besides scales).
    UvMatrix([f32; 6]),
    /// s = θ/π and t = φ/2π of the direction from the texture space's origin (pbrt-v4's `SphericalMapping`: s runs
    /// from the +z pole to the −z pole).
    Spherical(Affine3A),
    /// s = (π + atan2(y, x))/2π around the texture space's z axis, t = z.
    Cylindrical(Affine3A),
    /// s = ds + p·vs, t = dt + p·vt for the texture-space point p.
    Planar {
        /// Render to texture space.
        texture_from_render: Affine3A,
        /// The s axis (`v1`).
        vs: Vec3,
        /// The t axis (`v2`).
        vt: Vec3,
        /// Offset of s (`udelta`).
        ds: f32,
        /// Offset of t (`vdelta`).
        dt: f32,
    },
}

impl TextureMapping2D {
    /// Texture coordinates (s, t) for a context.
    pub fn map(&self, ctx: &TextureEvalContext) -> Vec2 {
        use std::f32::consts::PI;
        match self {
            TextureMapping2D::Uv(m) => m.map(ctx),
            TextureMapping2D::UvMatrix(m) => {
                let (u, v) = (ctx.uv.x, ctx.uv.y);
                Vec2::new(m[0] * u + m[1] * v + m[2], m[3] * u + m[4] * v + m[5])
            }
            TextureMapping2D::Spherical(m) => {
                let d = m.transform_point3(ctx.p).normalize_or_zero();
                let theta = d.z.clamp(-1.0, 1.0).acos();
                let mut phi = d.y.atan2(d.x);
                if phi < 0.0 {
                    phi += 2.0 * PI;
                }
                Vec2::new(theta / PI, phi / (2.0 * PI))
            }
            TextureMapping2D::Cylindrical(m) => {
                let p = m.transform_point3(ctx.p);
                Vec2::new((PI + p.y.atan2(p.x)) / (2.0 * PI), p.z)
            }
            TextureMapping2D::Planar { texture_from_render, vs, vt, ds, dt } => {
                let p = texture_from_render.transform_point3(ctx.p);
                Vec2::new(ds + p.dot(*vs), dt + p.dot(*vt))
            }
        }
    }
}

impl TextureMapping2D {
    /// Texture coordinates with their change per pixel (pbrt-v4's `TextureMapping2D::Map`), from the context's
    /// derivatives; non-finite derivatives (at a pole of a spherical mapping) are zero.
    pub fn map_footprint(&self, ctx: &TextureEvalContext) -> TexCoord2D {
        use std::f32::consts::PI;
        let st = self.map(ctx);
        // (∂s/∂p, ∂t/∂p) in texture space, and the context's dp/dx, dp/dy taken there.
        let gradients = |m: &Affine3A, ds: Vec3, dt: Vec3| {
            let (dx, dy) = (m.transform_vector3(ctx.dpdx), m.transform_vector3(ctx.dpdy));
            (Vec2::new(ds.dot(dx), dt.dot(dx)), Vec2::new(ds.dot(dy), dt.dot(dy)))
        };
        let (dst_dx, dst_dy) = match self {
            TextureMapping2D::Uv(m) => {
                let [dudx, dudy, dvdx, dvdy] = ctx.duv;
                (Vec2::new(m.su * dudx, m.sv * dvdx), Vec2::new(m.su * dudy, m.sv * dvdy))
            }
            TextureMapping2D::UvMatrix(m) => {
                let [dudx, dudy, dvdx, dvdy] = ctx.duv;
                (
                    Vec2::new(m[0] * dudx + m[1] * dvdx, m[3] * dudx + m[4] * dvdx),
                    Vec2::new(m[0] * dudy + m[1] * dvdy, m[3] * dudy + m[4] * dvdy),
                )
            }
            TextureMapping2D::Spherical(m) => {
                // s = θ/π, t = φ/2π: ∂θ/∂p = (xz/ρ, yz/ρ, −ρ)/r², ∂φ/∂p = (−y, x, 0)/ρ² (ρ² = x² + y²).
                let p = m.transform_point3(ctx.p);
                let rho2 = p.x * p.x + p.y * p.y;
                let (rho, r2) = (rho2.sqrt(), rho2 + p.z * p.z);
                let dtheta = Vec3::new(p.x * p.z / rho, p.y * p.z / rho, -rho) / r2;
                let dphi = Vec3::new(-p.y, p.x, 0.0) / rho2;
                gradients(m, dtheta / PI, dphi / (2.0 * PI))
            }
            TextureMapping2D::Cylindrical(m) => {
                let p = m.transform_point3(ctx.p);
                let rho2 = p.x * p.x + p.y * p.y;
                gradients(m, Vec3::new(-p.y, p.x, 0.0) / (2.0 * PI * rho2), Vec3::Z)
            }
            TextureMapping2D::Planar { texture_from_render, vs, vt, .. } => gradients(texture_from_render, *vs, *vt),
        };
        let finite = |v: Vec2| if v.is_finite() { v } else { Vec2::ZERO };
        TexCoord2D { st, dst_dx: finite(dst_dx), dst_dy: finite(dst_dy) }
    }
}

impl Default for TextureMapping2D {
    fn default() -> Self {
        TextureMapping2D::Uv(UvMapping::default())
    }
}

/// The 3-D textures' mapping: the point in the texture's own space (pbrt-v4's `PointTransformMapping`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointMapping {
    /// Render to texture space (the inverse of the texture's CTM).
    pub texture_from_render: Affine3A,
}

impl PointMapping {
    /// The texture-space point for a context.
    pub fn map(&self, ctx: &TextureEvalContext) -> Vec3 {
        self.texture_from_render.transform_point3(ctx.p)
    }
}

/// A checkerboard's squares: in (s, t) of a 2-D mapping, or cubes in texture space (`"integer dimension" 3`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CheckerMapping {
    /// Squares in (s, t).
    Planar(TextureMapping2D),
    /// Cubes of the texture-space point.
    Solid(PointMapping),
}

impl CheckerMapping {
    /// True on the checks of the first texture: those whose integer coordinates sum to an even number.
    fn even(&self, ctx: &TextureEvalContext) -> bool {
        let sum = match self {
            CheckerMapping::Planar(m) => {
                let st = m.map(ctx);
                st.x.floor() as i64 + st.y.floor() as i64
            }
            CheckerMapping::Solid(m) => {
                let p = m.map(ctx);
                p.x.floor() as i64 + p.y.floor() as i64 + p.z.floor() as i64
            }
        };
        sum.rem_euclid(2) == 0
    }
}

/// What an image lookup does outside [0, 1]² (pbrt-v4's `WrapMode`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum WrapMode {
    /// The image tiles the plane.
    Repeat,
    /// Zero outside the image.
    Black,
    /// The nearest edge texel.
    Clamp,
    /// Each edge folded at its midpoint, continuing an equal-area octahedral sphere map across its seams.
    OctahedralSphere,
    /// One rule along s (the image's columns) and another along t (its rows), as glTF's samplers give them
    /// (`"string wrap" [s t]`, a Prismatic extension).
    Axes(AxisWrap, AxisWrap),
}

/// What an image lookup does beyond the image along one axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum AxisWrap {
    /// The image repeats.
    Repeat,
    /// The edge texel continues.
    Clamp,
    /// The image repeats, every other copy mirrored (glTF's `MIRRORED_REPEAT`): texel −1 is texel 0.
    Mirror,
}

impl AxisWrap {
    /// The texel index inside 0..n that index `i` reads.
    pub fn wrap(self, i: i64, n: i64) -> i64 {
        match self {
            AxisWrap::Repeat => i.rem_euclid(n),
            AxisWrap::Clamp => i.clamp(0, n - 1),
            AxisWrap::Mirror => {
                let m = i.rem_euclid(2 * n);
                if m >= n {
                    2 * n - 1 - m
                } else {
                    m
                }
            }
        }
    }
}

/// The texel of a `w`×`h` equal-area octahedral image that continues texel (x, y) when that lies one texel beyond
/// the square's edge.
///
/// Each edge of the octahedral square is folded at its midpoint: the square's point (0, v) is the same direction
/// as (0, 1 − v), and likewise along the other three edges (Clarberg 2008, the octahedral layout; pbrt-v4 wraps its
/// environment maps the same way). So the texel just beyond an edge is the one just inside it, mirrored about the
/// edge's midpoint: (−1, y) → (0, h−1−y), (w, y) → (w−1, h−1−y), (x, −1) → (w−1−x, 0), (x, h) → (w−1−x, h−1).
/// Beyond a corner both reflections apply (all four corners are one direction). Anything still outside (only
/// possible for coordinates more than one texel out, or a 1-texel side) is clamped.
pub fn octahedral_wrap(x: i64, y: i64, w: i64, h: i64) -> (i64, i64) {
    let (mut x, mut y) = (x, y);
    if x < 0 {
        (x, y) = (-1 - x, h - 1 - y);
    } else if x >= w {
        (x, y) = (2 * w - 1 - x, h - 1 - y);
    }
    if y < 0 {
        (x, y) = (w - 1 - x, -1 - y);
    } else if y >= h {
        (x, y) = (w - 1 - x, 2 * h - 1 - y);
    }
    (x.clamp(0, w - 1), y.clamp(0, h - 1))
}

/// How an image texture is sampled between texels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFilter {
    /// The nearest texel of the MIP level the footprint picks (pbrt-v4's `point`).
    Point,
    /// Bilinear interpolation between the four nearest texel centres of the MIP level the footprint picks
    /// (pbrt-v4's `bilinear`).
    Bilinear,
    /// Bilinear lookups in the two MIP levels whose texels match the footprint, blended (pbrt-v4's `trilinear`).
    Trilinear,
    /// A Gaussian-weighted elliptical average over the footprint (pbrt-v4's `ewa`, Heckbert 1989).
    Ewa,
}

/// A linear RGB image (rows top to bottom), with bilinear and nearest lookups under a wrap mode.
#[derive(Clone, Debug, PartialEq)]
pub struct RgbImage {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// The texels, rows from the top, read as linear RGB (8-bit images stay 8-bit: `film::Texels`).
    pub texels: Texels,
}

impl RgbImage {
    /// A `width`×`height` image of linear RGB `pixels` (rows from the top), kept as one value per texel where
    /// the three are equal everywhere.
    pub fn new(width: usize, height: usize, pixels: Vec<[f32; 3]>) -> Self {
        Self { width, height, texels: Texels::from_rgb(pixels) }
    }

    /// Texel (x, y) (row 0 at the top) under `wrap`.
    pub fn texel(&self, x: i64, y: i64, wrap: WrapMode) -> [f32; 3] {
        let (w, h) = (self.width as i64, self.height as i64);
        if w == 0 || h == 0 {
            return [0.0; 3];
        }
        let (x, y) = match wrap {
            WrapMode::Repeat => (x.rem_euclid(w), y.rem_euclid(h)),
            WrapMode::Clamp => (x.clamp(0, w - 1), y.clamp(0, h - 1)),
            WrapMode::Black => {
                if x < 0 || y < 0 || x >= w || y >= h {
                    return [0.0; 3];
                }
                (x, y)
            }
            WrapMode::OctahedralSphere => octahedral_wrap(x, y, w, h),
            WrapMode::Axes(s, t) => (s.wrap(x, w), t.wrap(y, h)),
        };
        self.texels.get((y * w + x) as usize)
    }

    /// Bilinear lookup at texture coordinates `st` with repeat wrapping (t = 0 at the bottom row: pbrt flips
    /// images, whose first row is the top, on lookup).
    pub fn bilerp(&self, st: Vec2) -> [f32; 3] {
        self.bilerp_wrapped(st, WrapMode::Repeat)
    }

    /// Bilinear lookup at `st` between texel centres, under `wrap`.
    pub fn bilerp_wrapped(&self, st: Vec2, wrap: WrapMode) -> [f32; 3] {
        let x = st.x * self.width as f32 - 0.5;
        let y = (1.0 - st.y) * self.height as f32 - 0.5;
        self.bilerp_texels(x, y, wrap)
    }

    /// Bilinear interpolation at continuous texel coordinates (x, y) (texel centres at integers, row 0 at the top),
    /// under `wrap`.
    pub fn bilerp_texels(&self, x: f32, y: f32, wrap: WrapMode) -> [f32; 3] {
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let a = self.texel(x0, y0, wrap);
        let b = self.texel(x0 + 1, y0, wrap);
        let c = self.texel(x0, y0 + 1, wrap);
        let d = self.texel(x0 + 1, y0 + 1, wrap);
        std::array::from_fn(|i| (1.0 - fy) * ((1.0 - fx) * a[i] + fx * b[i]) + fy * ((1.0 - fx) * c[i] + fx * d[i]))
    }

    /// The texel nearest to `st` under `wrap` (pbrt-v4's point lookup: texel centres at half-integers).
    pub fn nearest(&self, st: Vec2, wrap: WrapMode) -> [f32; 3] {
        let x = (st.x * self.width as f32 - 0.5).round() as i64;
        let y = ((1.0 - st.y) * self.height as f32 - 0.5).round() as i64;
        self.texel(x, y, wrap)
    }
}

/// An image map: an image looked up through a mapping, scaled and optionally inverted (pbrt-v4's `imagemap`).
#[derive(Clone, Debug, PartialEq)]
pub struct ImageTexture {
    /// Mapping.
    pub map: TextureMapping2D,
    /// The image (already linear: its encoding was applied when it was read).
    pub image: Arc<RgbImage>,
    /// Outside [0, 1]².
    pub wrap: WrapMode,
    /// Between texels.
    pub filter: ImageFilter,
    /// The image's MIP map, which every filter reads (pbrt-v4's `MIPMap`); without one (`None`), lookups read
    /// `image` itself, `trilinear` and `ewa` as `bilinear`.
    pub mip: Option<Arc<MipMap>>,
    /// The `ewa` filter's largest ratio of the footprint's axes (pbrt-v4's `maxanisotropy`, default 8).
    pub max_anisotropy: f32,
    /// Multiplier.
    pub scale: f32,
    /// Per-channel multiplier of the looked-up RGB (Prismatic's `"rgb tint"`, glTF's colour factors; 1, 1, 1 for
    /// pbrt-v4's image maps).
    pub tint: [f32; 3],
    /// 1 − value (clamped at zero).
    pub invert: bool,
}

impl ImageTexture {
    /// The filtered RGB at `ctx`, times the tint.
    pub fn rgb(&self, ctx: &TextureEvalContext) -> [f32; 3] {
        let rgb = self.lookup(ctx);
        [rgb[0] * self.tint[0], rgb[1] * self.tint[1], rgb[2] * self.tint[2]]
    }

    /// The filtered RGB at `ctx`.
    fn lookup(&self, ctx: &TextureEvalContext) -> [f32; 3] {
        match (self.filter, &self.mip) {
            (ImageFilter::Point, Some(mip)) => {
                let c = self.map.map_footprint(ctx);
                mip.nearest(c.st, c.dst_dx, c.dst_dy)
            }
            (ImageFilter::Point, None) => self.image.nearest(self.map.map(ctx), self.wrap),
            (ImageFilter::Bilinear, Some(mip)) => {
                let c = self.map.map_footprint(ctx);
                mip.bilinear(c.st, c.dst_dx, c.dst_dy)
            }
            (ImageFilter::Trilinear, Some(mip)) => {
                let c = self.map.map_footprint(ctx);
                mip.trilinear(c.st, c.dst_dx, c.dst_dy)
            }
            (ImageFilter::Ewa, Some(mip)) => {
                let c = self.map.map_footprint(ctx);
                mip.ewa(c.st, c.dst_dx, c.dst_dy, self.max_anisotropy)
            }
            (ImageFilter::Bilinear | ImageFilter::Trilinear | ImageFilter::Ewa, None) => {
                self.image.bilerp_wrapped(self.map.map(ctx), self.wrap)
            }
        }
    }

    /// The scalar value: the channels' mean for bilinear and trilinear lookups, the first channel for point and
    /// EWA lookups (pbrt-v4's MIP map reads a float from an RGB image so: `Bilerp` averages, `Texel` takes the
    /// first channel), times `scale`, then inverted.
    fn value(&self, ctx: &TextureEvalContext) -> f32 {
        let rgb = self.rgb(ctx);
        let v = match self.filter {
            ImageFilter::Point | ImageFilter::Ewa => rgb[0],
            ImageFilter::Bilinear | ImageFilter::Trilinear => (rgb[0] + rgb[1] + rgb[2]) / 3.0,
        };
        let v = self.scale * v;
        if self.invert {
            (1.0 - v).max(0.0)
        } else {
            v
        }
    }
}

/// A scalar texture.
#[derive(Clone, Debug)]
pub enum FloatTexture {
    /// The same value everywhere.
    Constant(f32),
    /// `tex` × `scale` (`tex` is not evaluated where the scale is zero).
    Scale {
        /// The texture.
        tex: Box<FloatTexture>,
        /// Its factor.
        scale: Box<FloatTexture>,
    },
    /// (1 − amount)·tex1 + amount·tex2.
    Mix {
        /// Where `amount` is 0.
        tex1: Box<FloatTexture>,
        /// Where `amount` is 1.
        tex2: Box<FloatTexture>,
        /// The blend.
        amount: Box<FloatTexture>,
    },
    /// a·tex1 + (1 − a)·tex2 with a = |n·dir| for the geometric normal n.
    DirectionMix {
        /// Facing `dir`.
        tex1: Box<FloatTexture>,
        /// Perpendicular to `dir`.
        tex2: Box<FloatTexture>,
        /// Unit render-space direction.
        dir: Vec3,
    },
    /// Bilinear interpolation of four values over (s, t): v00 at (0, 0), v01 at (0, 1), v10 at (1, 0), v11 at (1, 1).
    Bilerp {
        /// Mapping.
        map: Box<TextureMapping2D>,
        /// v00, v01, v10, v11.
        v: [f32; 4],
    },
    /// Alternating checks of two textures.
    Checkerboard {
        /// Squares or cubes.
        map: Box<CheckerMapping>,
        /// Texture of the even checks.
        tex1: Box<FloatTexture>,
        /// Texture of the odd checks.
        tex2: Box<FloatTexture>,
    },
    /// Randomly placed polka dots (one per cell at most, by noise).
    Dots {
        /// Mapping.
        map: Box<TextureMapping2D>,
        /// Inside the dots.
        dot: Box<FloatTexture>,
        /// Between the dots.
        background: Box<FloatTexture>,
    },
    /// Fractional Brownian motion of the texture-space point.
    Fbm {
        /// Mapping.
        map: Box<PointMapping>,
        /// Octaves summed.
        octaves: u32,
        /// Amplitude ratio between octaves (`roughness`).
        omega: f32,
    },
    /// Turbulence of the texture-space point.
    Wrinkled {
        /// Mapping.
        map: Box<PointMapping>,
        /// Octaves summed.
        octaves: u32,
        /// Amplitude ratio between octaves (`roughness`).
        omega: f32,
    },
    /// Waves under wind: |fBm(p/10, 3 octaves)|·fBm(p, 6 octaves), both with ω = 0.5.
    Windy {
        /// Mapping.
        map: Box<PointMapping>,
    },
    /// An image map.
    Image(Box<ImageTexture>),
    /// The largest channel of an image map's tinted RGB, times its scale: the `max_value` glTF's specular and sheen
    /// extensions take of an RGB colour, for a colour that is a texture.
    ImageMaxChannel(Box<ImageTexture>),
    /// 1 where `tex` ≥ `cutoff`, else 0 (Prismatic's `"threshold"`: glTF's `MASK` alpha mode on a texture's alpha).
    Threshold {
        /// The texture compared.
        tex: Box<FloatTexture>,
        /// The value at and above which the result is 1.
        cutoff: f32,
    },
}

impl FloatTexture {
    /// Value at `ctx`.
    #[inline]
    pub fn eval(&self, ctx: &TextureEvalContext) -> f32 {
        // Inline for constants (most roughness and bump parameters), which need no call into the recursive match;
        // every other kind is evaluated in `eval_varying`, whose match names them all.
        if let FloatTexture::Constant(v) = self {
            return *v;
        }
        self.eval_varying(ctx)
    }

    /// [`FloatTexture::eval`] of any texture, out of line.
    #[inline(never)]
    fn eval_varying(&self, ctx: &TextureEvalContext) -> f32 {
        match self {
            FloatTexture::Constant(v) => *v,
            FloatTexture::Scale { tex, scale } => {
                let s = scale.eval(ctx);
                if s == 0.0 {
                    0.0
                } else {
                    tex.eval(ctx) * s
                }
            }
            FloatTexture::Mix { tex1, tex2, amount } => {
                let a = amount.eval(ctx);
                let t1 = if a != 1.0 { tex1.eval(ctx) } else { 0.0 };
                let t2 = if a != 0.0 { tex2.eval(ctx) } else { 0.0 };
                (1.0 - a) * t1 + a * t2
            }
            FloatTexture::DirectionMix { tex1, tex2, dir } => {
                let a = ctx.n.dot(*dir).abs();
                let t1 = if a != 0.0 { tex1.eval(ctx) } else { 0.0 };
                let t2 = if a != 1.0 { tex2.eval(ctx) } else { 0.0 };
                a * t1 + (1.0 - a) * t2
            }
            FloatTexture::Bilerp { map, v } => {
                let st = map.map(ctx);
                let (s, t) = (st.x, st.y);
                (1.0 - s) * (1.0 - t) * v[0] + (1.0 - s) * t * v[1] + s * (1.0 - t) * v[2] + s * t * v[3]
            }
            FloatTexture::Checkerboard { map, tex1, tex2 } => {
                if map.even(ctx) {
                    tex1.eval(ctx)
                } else {
                    tex2.eval(ctx)
                }
            }
            FloatTexture::Dots { map, dot, background } => {
                if inside_polka_dot(map.map(ctx)) {
                    dot.eval(ctx)
                } else {
                    background.eval(ctx)
                }
            }
            FloatTexture::Fbm { map, octaves, omega } => noise::fbm(map.map(ctx), *omega, *octaves),
            FloatTexture::Wrinkled { map, octaves, omega } => noise::turbulence(map.map(ctx), *omega, *octaves),
            FloatTexture::Windy { map } => {
                let p = map.map(ctx);
                let wind_strength = noise::fbm(0.1 * p, 0.5, 3);
                let wave_height = noise::fbm(p, 0.5, 6);
                wind_strength.abs() * wave_height
            }
            FloatTexture::Image(img) => img.value(ctx),
            FloatTexture::ImageMaxChannel(img) => {
                let [r, g, b] = img.rgb(ctx);
                img.scale * r.max(g).max(b)
            }
            FloatTexture::Threshold { tex, cutoff } => {
                if tex.eval(ctx) >= *cutoff {
                    1.0
                } else {
                    0.0
                }
            }
        }
    }
}

/// True if `st` lies in a polka dot: cells of unit size centred on integer (s, t) hold a dot of radius 0.35 where
/// the noise at the cell is positive, shifted by up to 0.15 by two more noise values (pbrt-v4 §10.5.2).
fn inside_polka_dot(st: Vec2) -> bool {
    let (s_cell, t_cell) = ((st.x + 0.5).floor(), (st.y + 0.5).floor());
    if noise::noise_2d(s_cell + 0.5, t_cell + 0.5) > 0.0 {
        const RADIUS: f32 = 0.35;
        const MAX_SHIFT: f32 = 0.5 - RADIUS;
        let s_center = s_cell + MAX_SHIFT * noise::noise_2d(s_cell + 1.5, t_cell + 2.8);
        let t_center = t_cell + MAX_SHIFT * noise::noise_2d(s_cell + 4.5, t_cell + 9.8);
        return (st - Vec2::new(s_center, t_center)).length_squared() < RADIUS * RADIUS;
    }
    false
}

/// How an image texture's RGB becomes a spectrum.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RgbKind {
    /// Reflectances in [0, 1] (clamped).
    Albedo,
    /// Any non-negative values.
    Unbounded,
    /// Emitted radiance: an unbounded RGB times the colour space's illuminant (pbrt-v4's `RGBIlluminantSpectrum`).
    Illuminant,
}

/// A spectral texture.
#[derive(Clone, Debug)]
pub enum SpectrumTexture {
    /// The same spectrum everywhere.
    Constant(Spectrum),
    /// `tex` × `scale` (`tex` is not evaluated where the scale is zero).
    Scale {
        /// The texture.
        tex: Box<SpectrumTexture>,
        /// Its factor.
        scale: Box<FloatTexture>,
    },
    /// (1 − amount)·tex1 + amount·tex2.
    Mix {
        /// Where `amount` is 0.
        tex1: Box<SpectrumTexture>,
        /// Where `amount` is 1.
        tex2: Box<SpectrumTexture>,
        /// The blend.
        amount: Box<FloatTexture>,
    },
    /// a·tex1 + (1 − a)·tex2 with a = |n·dir| for the geometric normal n.
    DirectionMix {
        /// Facing `dir`.
        tex1: Box<SpectrumTexture>,
        /// Perpendicular to `dir`.
        tex2: Box<SpectrumTexture>,
        /// Unit render-space direction.
        dir: Vec3,
    },
    /// Bilinear interpolation of four spectra over (s, t).
    Bilerp {
        /// Mapping.
        map: Box<TextureMapping2D>,
        /// v00, v01, v10, v11.
        v: Box<[Spectrum; 4]>,
    },
    /// Alternating checks of two textures.
    Checkerboard {
        /// Squares or cubes.
        map: Box<CheckerMapping>,
        /// Texture of the even checks.
        tex1: Box<SpectrumTexture>,
        /// Texture of the odd checks.
        tex2: Box<SpectrumTexture>,
    },
    /// Randomly placed polka dots.
    Dots {
        /// Mapping.
        map: Box<TextureMapping2D>,
        /// Inside the dots.
        dot: Box<SpectrumTexture>,
        /// Between the dots.
        background: Box<SpectrumTexture>,
    },
    /// Veined marble: a cubic Bézier colour ramp over sin(y + variation·fBm) (pbrt-v4's `marble`).
    Marble {
        /// Mapping.
        map: Box<PointMapping>,
        /// Octaves of the fBm.
        octaves: u32,
        /// Amplitude ratio between octaves (`roughness`).
        omega: f32,
        /// Scale of the texture-space point.
        scale: f32,
        /// Strength of the fBm perturbation.
        variation: f32,
    },
    /// A mesh's interpolated vertex colour (white where it has none) × `tint` × an image map's RGB, uplifted per
    /// lookup (Prismatic's `vertexcolor`: glTF's `COLOR_0` times the base colour).
    VertexColor {
        /// Per-channel factor.
        tint: [f32; 3],
        /// The image map whose RGB multiplies the colour, if any.
        image: Option<Box<ImageTexture>>,
        /// Albedo or unbounded uplifting.
        kind: RgbKind,
    },
    /// An RGB image uplifted per lookup (Jakob & Hanika 2019).
    Image {
        /// The image map.
        tex: Box<ImageTexture>,
        /// Albedo or unbounded uplifting.
        kind: RgbKind,
    },
}

/// The marble's colour ramp: control points of three cubic Bézier segments sliding by one point (pbrt-v4's
/// `MarbleTexture` colours, linear sRGB; the ramp is scaled by 1.5).
const MARBLE_COLORS: [[f32; 3]; 9] = [
    [0.58, 0.58, 0.6],
    [0.58, 0.58, 0.6],
    [0.58, 0.58, 0.6],
    [0.5, 0.5, 0.5],
    [0.6, 0.59, 0.58],
    [0.58, 0.58, 0.6],
    [0.58, 0.58, 0.6],
    [0.2, 0.2, 0.33],
    [0.58, 0.58, 0.6],
];

/// The marble's linear sRGB colour at texture-space point `p` (before uplifting).
pub fn marble_rgb(p: Vec3, octaves: u32, omega: f32, scale: f32, variation: f32) -> [f32; 3] {
    let p = p * scale;
    let marble = p.y + variation * noise::fbm(p, omega, octaves);
    let t = 0.5 + 0.5 * marble.sin();
    let n_seg = MARBLE_COLORS.len() - 3;
    let first = ((t * n_seg as f32).floor() as usize).min(n_seg - 1);
    let t = t * n_seg as f32 - first as f32;
    let c = &MARBLE_COLORS[first..first + 4];
    // Cubic Bernstein basis.
    let s = 1.0 - t;
    let w = [s * s * s, 3.0 * s * s * t, 3.0 * s * t * t, t * t * t];
    std::array::from_fn(|i| 1.5 * (w[0] * c[0][i] + w[1] * c[1][i] + w[2] * c[2][i] + w[3] * c[3][i]))
}

/// An RGB colour as a spectrum at the path's wavelengths (albedo colours are clamped to [0, 1]).
pub fn uplift(rgb: [f32; 3], kind: RgbKind, wl: &SampledWavelengths) -> SampledSpectrum {
    let mut s = SampledSpectrum::zero();
    match kind {
        RgbKind::Albedo => {
            let Ok(sp) = RgbAlbedoSpectrum::new(rgb.map(|c| c.clamp(0.0, 1.0) as f64)) else { return s };
            for i in 0..N_WAVELENGTHS {
                s[i] = sp.eval(wl.lambda(i) as f64) as f32;
            }
        }
        RgbKind::Unbounded => {
            let Ok(sp) = RgbUnboundedSpectrum::new(rgb.map(|c| c.max(0.0) as f64)) else { return s };
            for i in 0..N_WAVELENGTHS {
                s[i] = sp.eval(wl.lambda(i) as f64) as f32;
            }
        }
        RgbKind::Illuminant => {
            let Ok(sp) = RgbIlluminantSpectrum::new(rgb.map(|c| c.max(0.0) as f64)) else { return s };
            for i in 0..N_WAVELENGTHS {
                s[i] = sp.eval(wl.lambda(i) as f64) as f32;
            }
        }
    }
    s
}

impl SpectrumTexture {
    /// Values at the path's wavelengths.
    pub fn eval(&self, ctx: &TextureEvalContext, wl: &SampledWavelengths) -> SampledSpectrum {
        match self {
            SpectrumTexture::Constant(s) => s.sample(wl),
            SpectrumTexture::Scale { tex, scale } => {
                let s = scale.eval(ctx);
                if s == 0.0 {
                    SampledSpectrum::zero()
                } else {
                    tex.eval(ctx, wl) * s
                }
            }
            SpectrumTexture::Mix { tex1, tex2, amount } => {
                let a = amount.eval(ctx);
                let t1 = if a != 1.0 { tex1.eval(ctx, wl) } else { SampledSpectrum::zero() };
                let t2 = if a != 0.0 { tex2.eval(ctx, wl) } else { SampledSpectrum::zero() };
                t1 * (1.0 - a) + t2 * a
            }
            SpectrumTexture::DirectionMix { tex1, tex2, dir } => {
                let a = ctx.n.dot(*dir).abs();
                let t1 = if a != 0.0 { tex1.eval(ctx, wl) } else { SampledSpectrum::zero() };
                let t2 = if a != 1.0 { tex2.eval(ctx, wl) } else { SampledSpectrum::zero() };
                t1 * a + t2 * (1.0 - a)
            }
            SpectrumTexture::Bilerp { map, v } => {
                let st = map.map(ctx);
                let (s, t) = (st.x, st.y);
                v[0].sample(wl) * ((1.0 - s) * (1.0 - t))
                    + v[1].sample(wl) * ((1.0 - s) * t)
                    + v[2].sample(wl) * (s * (1.0 - t))
                    + v[3].sample(wl) * (s * t)
            }
            SpectrumTexture::Checkerboard { map, tex1, tex2 } => {
                if map.even(ctx) {
                    tex1.eval(ctx, wl)
                } else {
                    tex2.eval(ctx, wl)
                }
            }
            SpectrumTexture::Dots { map, dot, background } => {
                if inside_polka_dot(map.map(ctx)) {
                    dot.eval(ctx, wl)
                } else {
                    background.eval(ctx, wl)
                }
            }
            SpectrumTexture::Marble { map, octaves, omega, scale, variation } => {
                uplift(marble_rgb(map.map(ctx), *octaves, *omega, *scale, *variation), RgbKind::Albedo, wl)
            }
            SpectrumTexture::Image { tex, kind } => {
                let rgb = tex.rgb(ctx).map(|c| {
                    let v = tex.scale * c;
                    (if tex.invert { 1.0 - v } else { v }).max(0.0)
                });
                uplift(rgb, *kind, wl)
            }
            SpectrumTexture::VertexColor { tint, image, kind } => {
                let vc = ctx.vertex_color.unwrap_or(Vec3::ONE);
                let mut rgb = [vc.x * tint[0], vc.y * tint[1], vc.z * tint[2]];
                if let Some(tex) = image {
                    let t = tex.rgb(ctx);
                    rgb = [rgb[0] * t[0], rgb[1] * t[1], rgb[2] * t[2]];
                }
                uplift(rgb.map(|c| c.max(0.0)), *kind, wl)
            }
        }
    }
}

#[cfg(test)]
mod tests;

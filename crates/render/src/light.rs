//! Light sources: point, spot, distant (a direction, or a disc of directions such as the sun's), uniform and image
//! infinite lights, and diffuse area lights.
//!
//! Emission spectra arrive already scaled to pbrt-v4's photometric convention (see `scene_build`): a light
//! spectrum is divided by its luminance before `scale` applies, so `"rgb L" [1 1 1]` is one nit.

use glam::{Vec2, Vec3};
use spectral::{Distribution2D, SampledSpectrum, SampledWavelengths, Spectrum};
use std::f32::consts::PI;

use crate::error::invalid_data;
use crate::sampling::{sample_uniform_sphere, Frame};
use crate::texture::{octahedral_wrap, uplift, FloatTexture, ImageTexture, RgbKind, TextureEvalContext};

use crate::RenderError;
use std::sync::Arc;

/// Where light arrives. (pbrt-v4's context also carries the receiver's normals, for light sampling that weighs by
/// the receiver's cosine; no light here does.)
#[derive(Clone, Copy, Debug)]
pub struct LightSampleContext {
    /// The receiving point.
    pub p: Vec3,
}

/// A sampled incident direction from a light.
#[derive(Clone, Copy, Debug)]
pub struct LightLiSample {
    /// Incident radiance (or intensity / d² for point lights).
    pub l: SampledSpectrum,
    /// Unit direction from the receiver towards the light.
    pub wi: Vec3,
    /// Density with respect to solid angle (1 for delta lights).
    pub pdf: f32,
    /// Distance to the sampled point (infinity for lights at infinity).
    pub dist: f32,
    /// The sampled point (for lights at infinity, meaningless).
    pub p: Vec3,
    /// True for delta distributions (point, spot, distant), which BSDF sampling can never hit.
    pub delta: bool,
    /// Unit surface normal at the sampled point for area lights (zero for other lights).
    pub n: Vec3,
}

impl LightLiSample {
    /// A sample of a light at infinity: radiance `l` from unit direction `wi` with density `pdf` (1 for a delta
    /// direction, `delta`).
    fn at_infinity(l: SampledSpectrum, wi: Vec3, pdf: f32, delta: bool) -> Self {
        Self { l, wi, pdf, dist: f32::INFINITY, p: Vec3::ZERO, delta, n: Vec3::ZERO }
    }
}

/// A ray of light leaving a light source, for light tracing and photon mapping.
#[derive(Clone, Copy, Debug)]
pub struct LightLeSample {
    /// Origin of the emitted ray.
    pub o: Vec3,
    /// Unit direction of the emitted ray.
    pub d: Vec3,
    /// Emitted radiance (or intensity for point and spot lights) along the ray.
    pub l: SampledSpectrum,
    /// For area lights, the surface point the ray leaves (to spawn rays from and to weight by |cos θ|).
    pub surface: Option<geometry::SurfacePoint>,
    /// Density of the origin: per unit area (area lights; the disk of a light at infinity), 1 for point lights.
    pub pdf_pos: f32,
    /// Density of the direction per steradian (1 for a distant light's single direction).
    pub pdf_dir: f32,
}

impl LightLeSample {
    /// The sample's contribution to the emitted flux: `L·|cos θ| / (pdf_pos·pdf_dir)` (the cosine only for area
    /// lights), the initial throughput of a light path before the light-selection probability.
    pub fn flux_weight(&self) -> SampledSpectrum {
        let cos = self.surface.map_or(1.0, |s| s.n.dot(self.d).abs());
        self.l * (cos / (self.pdf_pos * self.pdf_dir))
    }
}

/// An environment image in equal-area octahedral (pbrt-v4's native) or latitude–longitude layout.
#[derive(Clone, Debug)]
pub struct EnvironmentMap {
    /// Width in texels.
    pub width: usize,
    /// Height in texels.
    pub height: usize,
    /// Linear RGB texels (already uplifted to spectra per texel at lookup).
    pub texels: Vec<spectral::rgb_uplift::RgbIlluminantSpectrum>,
    /// True for the equal-area octahedral layout (square images), false for lat-long.
    pub equal_area: bool,
    /// Mean luminance of the texels (for the light's power).
    pub mean_luminance: f32,
    /// Importance distribution over the image, piecewise constant on the texels: the mean of each texel's R, G, B
    /// (pbrt-v4's `Image::GetSamplingDistribution`), times sin θ at the texel's centre for lat-long.
    pub distribution: Distribution2D,
    /// Light-from-world rotation frame: (x, y, z) axes of the light in world space.
    pub frame: Frame,
}

/// A light.
#[derive(Clone, Debug)]
pub enum Light {
    /// An isotropic point light: intensity `i·scale` (W/sr, relative).
    Point {
        /// Position.
        p: Vec3,
        /// Intensity spectrum (scaled).
        i: Spectrum,
    },
    /// A spot light with smooth falloff between the two cone angles (pbrt-v4 smoothstep).
    Spot {
        /// Position.
        p: Vec3,
        /// Frame whose z is the spot axis.
        frame: Frame,
        /// Intensity spectrum (scaled).
        i: Spectrum,
        /// cos of the angle where falloff starts.
        cos_falloff_start: f32,
        /// cos of the total cone angle.
        cos_falloff_end: f32,
    },
    /// A directional light arriving from direction `w` (unit, pointing towards the light).
    Distant {
        /// Direction towards the light.
        w: Vec3,
        /// Radiance spectrum (scaled).
        l: Spectrum,
        /// Radius of the scene's bounding sphere (for power).
        scene_radius: f32,
    },
    /// A light at infinity of finite angular size: uniform radiance `l` from a disc of directions (a cone of
    /// half-angle θ_max about `frame.z`, towards the light), such as the sun's 0.53°. Prismatic's `"float angle"` on
    /// a distant light, whose irradiance it keeps: `l` is the distant light's radiance over π sin²θ_max.
    DistantDisc {
        /// Frame whose z points towards the disc's centre.
        frame: Frame,
        /// Radiance of the disc (scaled).
        l: Spectrum,
        /// 1 − cos θ_max, kept apart from cos θ_max: for the sun it is 1.07e-5, which 1 − (cos θ_max as f32) would
        /// give only to a few per cent.
        one_minus_cos: f32,
        /// sin²θ_max, for the test of a direction against the disc's rim (by the cross product, exact near the
        /// centre where the dot product is 1 to within rounding).
        sin2_max: f32,
        /// Radius of the scene's bounding sphere (for power).
        scene_radius: f32,
    },
    /// Constant radiance from every direction.
    UniformInfinite {
        /// Radiance (scaled).
        l: Spectrum,
        /// Scene bounding sphere radius (for power).
        scene_radius: f32,
    },
    /// Radiance from an environment image, importance-sampled.
    ImageInfinite {
        /// The image.
        map: Box<EnvironmentMap>,
        /// Scale (photometric normalisation and `scale`).
        scale: f32,
        /// Scene bounding sphere radius (for power).
        scene_radius: f32,
    },
    /// Lambertian emission from one side (or both) of one primitive of a shape (one light per triangle, as
    /// pbrt-v4 does).
    DiffuseArea {
        /// The emitting shape (render space; shared with the geometry).
        shape: Box<geometry::Shape>,
        /// The primitive of the shape (triangle index for meshes).
        element: u32,
        /// Emitted radiance (scaled); with `image`, the factor of the image's.
        l: Spectrum,
        /// An image of the emitted RGB over the surface's (u, v), uplifted as an illuminant at each point (pbrt-v4's
        /// `"string filename"`, glTF's emissive texture).
        image: Option<Arc<EmissionImage>>,
        /// Emit from both sides.
        two_sided: bool,
        /// The shape's alpha texture, if it is a cut-out: points where pbrt-v4's alpha test fails emit nothing.
        alpha: Option<Arc<FloatTexture>>,
        /// The shape has constant alpha 0: no ray ever hits it, so the light is found only by light sampling and
        /// counts as a delta light for MIS (pbrt-v4's invisible area lights).
        invisible: bool,
    },
}

/// An area light's image of emitted RGB, and its mean luminance, which stands for the surface's in the light's
/// power (power only chooses among lights, so the mean serves).
#[derive(Clone, Debug)]
pub struct EmissionImage {
    /// The image map (its tint and scale included).
    pub tex: ImageTexture,
    /// The mean of its texels' luminance (Rec. 709 weights), tint and scale applied.
    pub mean_luminance: f32,
}

impl EmissionImage {
    /// The emission image of `tex`, its mean luminance computed once.
    pub fn new(tex: ImageTexture) -> Self {
        let n = tex.image.texels.len().max(1) as f64;
        let sum = tex
            .image
            .texels
            .iter()
            .fold([0.0f64; 3], |m, p| [m[0] + p[0] as f64, m[1] + p[1] as f64, m[2] + p[2] as f64]);
        let t = tex.tint.map(f64::from);
        let y = (0.2126 * sum[0] * t[0] + 0.7152 * sum[1] * t[1] + 0.0722 * sum[2] * t[2]) / n * tex.scale as f64;
        Self { tex, mean_luminance: y.max(0.0) as f32 }
    }
}

/// The radiance an area light emits at point `p` (normal `n`, surface coordinates `uv`): its spectrum, times its
/// image's RGB there uplifted as an illuminant when it has one (pbrt-v4's `DiffuseAreaLight::L`).
fn emitted(
    l: &Spectrum,
    image: &Option<Arc<EmissionImage>>,
    p: Vec3,
    n: Vec3,
    uv: Vec2,
    wl: &SampledWavelengths,
) -> SampledSpectrum {
    let base = l.sample(wl);
    match image {
        None => base,
        Some(img) => base * uplift(img.tex.rgb(&TextureEvalContext::new(p, n, uv)), RgbKind::Illuminant, wl),
    }
}

/// pbrt-v4's alpha test for a point of an emitter (`AlphaMasked`): true if the point at `p` (normal `n`), `uv` is cut away, where
/// a fractional alpha keeps a point when a hash of its position does not exceed it.
fn alpha_masked(alpha: &Option<Arc<FloatTexture>>, p: Vec3, n: Vec3, uv: Vec2) -> bool {
    let Some(t) = alpha else { return false };
    let a = t.eval(&TextureEvalContext::new(p, n, uv));
    if a >= 1.0 {
        false
    } else if a <= 0.0 || a.is_nan() {
        true
    } else {
        hash_point(p) > a
    }
}

/// A number in [0, 1) from the bits of a point (splitmix64's finaliser over each coordinate).
fn hash_point(p: Vec3) -> f32 {
    let mut h: u64 = 0x2545_f491_4f6c_dd1d;
    for v in [p.x, p.y, p.z] {
        h ^= u64::from(v.to_bits());
        h = h.wrapping_add(0x9e37_79b9_7f4a_7c15);
        h = (h ^ (h >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        h = (h ^ (h >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        h ^= h >> 31;
    }
    (h >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
}

impl Light {
    /// True for lights at infinity that a ray escaping the scene sees.
    pub fn is_infinite(&self) -> bool {
        // A full match (not `matches!`): a new light must say whether escaping rays see it.
        match self {
            Light::UniformInfinite { .. } | Light::ImageInfinite { .. } | Light::DistantDisc { .. } => true,
            Light::Point { .. } | Light::Spot { .. } | Light::Distant { .. } | Light::DiffuseArea { .. } => false,
        }
    }

    /// For a light at infinity of finite size, whether unit direction `w` (towards the light) falls on its disc.
    fn disc_contains(frame: &Frame, sin2_max: f32, w: Vec3) -> bool {
        w.dot(frame.z) > 0.0 && w.cross(frame.z).length_squared() <= sin2_max
    }

    /// A direction in the cone of `1 − cos θ_max` = `one_minus_cos` about `frame.z`, uniform in solid angle, and its
    /// density 1/(2π(1 − cos θ_max)).
    fn sample_disc(frame: &Frame, one_minus_cos: f32, u: Vec2) -> (Vec3, f32) {
        // cos θ = 1 − u(1 − cos θ_max); sin θ from 1 − cos θ directly, precise for small cones.
        let a = u.x * one_minus_cos;
        let sin_t = (a * (2.0 - a)).max(0.0).sqrt();
        let phi = 2.0 * PI * u.y;
        let w = frame.from_local(Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), 1.0 - a));
        (w, 1.0 / (2.0 * PI * one_minus_cos))
    }

    /// Samples incident light at `ctx` with `u`.
    pub fn sample_li(&self, ctx: &LightSampleContext, u: Vec2, wl: &SampledWavelengths) -> Option<LightLiSample> {
        match self {
            Light::Point { p, i } => {
                let d = *p - ctx.p;
                let d2 = d.length_squared();
                (d2 > 0.0).then(|| LightLiSample {
                    l: i.sample(wl) * (1.0 / d2),
                    wi: d / d2.sqrt(),
                    pdf: 1.0,
                    dist: d2.sqrt(),
                    p: *p,
                    delta: true,
                    n: Vec3::ZERO,
                })
            }
            Light::Spot { p, frame, i, cos_falloff_start, cos_falloff_end } => {
                let d = *p - ctx.p;
                let d2 = d.length_squared();
                if d2 == 0.0 {
                    return None;
                }
                let wi = d / d2.sqrt();
                let cos = frame.z.dot(-wi);
                let falloff = smoothstep(*cos_falloff_end, *cos_falloff_start, cos);
                (falloff > 0.0).then(|| LightLiSample {
                    l: i.sample(wl) * (falloff / d2),
                    wi,
                    pdf: 1.0,
                    dist: d2.sqrt(),
                    p: *p,
                    delta: true,
                    n: Vec3::ZERO,
                })
            }
            Light::Distant { w, l, .. } => Some(LightLiSample::at_infinity(l.sample(wl), *w, 1.0, true)),
            Light::DistantDisc { frame, l, one_minus_cos, .. } => {
                let (wi, pdf) = Self::sample_disc(frame, *one_minus_cos, u);
                Some(LightLiSample::at_infinity(l.sample(wl), wi, pdf, false))
            }
            Light::UniformInfinite { l, .. } => {
                Some(LightLiSample::at_infinity(l.sample(wl), sample_uniform_sphere(u), 1.0 / (4.0 * PI), false))
            }
            Light::ImageInfinite { map, scale, .. } => {
                let s = map.distribution.sample([u.x as f64, u.y as f64]);
                let uv = Vec2::new(s.point[0] as f32, s.point[1] as f32);
                let (w_local, jac) = map.direction(uv)?;
                let pdf = s.pdf as f32 / jac;
                let wi = map.frame.from_local(w_local);
                (pdf > 0.0).then(|| LightLiSample::at_infinity(map.lookup(uv, wl) * *scale, wi, pdf, false))
            }
            Light::DiffuseArea { shape, element, l, image, two_sided, alpha, invisible } => {
                // Only an alpha texture or an image needs the point's uv: without them, the sample skips it.
                let (p, n, pdf, uv) = if alpha.is_some() || image.is_some() {
                    let ss = shape.sample_solid_angle(*element as usize, ctx.p, u)?;
                    if alpha_masked(alpha, ss.p, ss.n, ss.uv) {
                        return None;
                    }
                    (ss.p, ss.n, ss.pdf, ss.uv)
                } else {
                    let ps = shape.sample_solid_angle_point(*element as usize, ctx.p, u)?;
                    (ps.p, ps.n, ps.pdf, Vec2::ZERO)
                };
                if !(pdf > 0.0 && pdf.is_finite()) {
                    return None;
                }
                let d = p - ctx.p;
                let dist = d.length();
                if dist == 0.0 {
                    return None;
                }
                let wi = d / dist;
                let facing = n.dot(-wi) > 0.0;
                if !facing && !two_sided {
                    return None;
                }
                Some(LightLiSample { l: emitted(l, image, p, n, uv, wl), wi, pdf, dist, p, delta: *invisible, n })
            }
        }
    }

    /// Samples a ray leaving the light with `u_pos` and `u_dir` (pbrt-v4's `SampleLe`, §12 and §16.1.2). `scene`
    /// is the scene's bounding sphere (centre, radius): lights at infinity emit from a disk of that radius
    /// facing the scene, so that every parallel ray that can hit the scene is sampled.
    pub fn sample_le(
        &self,
        u_pos: Vec2,
        u_dir: Vec2,
        wl: &SampledWavelengths,
        scene: (Vec3, f32),
    ) -> Option<LightLeSample> {
        let (center, radius) = (scene.0, scene.1.max(1e-6));
        // A ray arriving from direction `w_to_light`: origin on the disk of radius R perpendicular to it, R beyond
        // the centre, pdf 1/(πR²) (pbrt-v4 §12.5).
        let from_infinity = |w_to_light: Vec3| {
            let f = Frame::from_z(w_to_light);
            let disk = crate::sampling::sample_uniform_disk_concentric(u_pos);
            let o = center + radius * (w_to_light + disk.x * f.x + disk.y * f.y);
            (o, -w_to_light, 1.0 / (PI * radius * radius))
        };
        let s = match self {
            Light::Point { p, i } => LightLeSample {
                o: *p,
                d: sample_uniform_sphere(u_dir),
                l: i.sample(wl),
                surface: None,
                pdf_pos: 1.0,
                pdf_dir: 1.0 / (4.0 * PI),
            },
            Light::Spot { p, frame, i, cos_falloff_start, cos_falloff_end } => {
                // Uniform in the cone of half-angle acos(cos_falloff_end); pdf 1/(2π(1 − cos)).
                let cos_max = *cos_falloff_end;
                let cos_t = 1.0 - u_dir.x * (1.0 - cos_max);
                let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
                let phi = 2.0 * PI * u_dir.y;
                let d = frame.from_local(Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t));
                let falloff = smoothstep(*cos_falloff_end, *cos_falloff_start, cos_t);
                LightLeSample {
                    o: *p,
                    d,
                    l: i.sample(wl) * falloff,
                    surface: None,
                    pdf_pos: 1.0,
                    pdf_dir: 1.0 / (2.0 * PI * (1.0 - cos_max)),
                }
            }
            Light::Distant { w, l, .. } => {
                let (o, d, pdf_pos) = from_infinity(*w);
                LightLeSample { o, d, l: l.sample(wl), surface: None, pdf_pos, pdf_dir: 1.0 }
            }
            Light::DistantDisc { frame, l, one_minus_cos, .. } => {
                let (w, pdf_dir) = Self::sample_disc(frame, *one_minus_cos, u_dir);
                let (o, d, pdf_pos) = from_infinity(w);
                LightLeSample { o, d, l: l.sample(wl), surface: None, pdf_pos, pdf_dir }
            }
            Light::UniformInfinite { l, .. } => {
                let w = sample_uniform_sphere(u_dir);
                let (o, d, pdf_pos) = from_infinity(w);
                LightLeSample { o, d, l: l.sample(wl), surface: None, pdf_pos, pdf_dir: 1.0 / (4.0 * PI) }
            }
            Light::ImageInfinite { map, scale, .. } => {
                let s = map.distribution.sample([u_dir.x as f64, u_dir.y as f64]);
                let uv = Vec2::new(s.point[0] as f32, s.point[1] as f32);
                let (w_local, jac) = map.direction(uv)?;
                let pdf_dir = s.pdf as f32 / jac;
                let (o, d, pdf_pos) = from_infinity(map.frame.from_local(w_local));
                LightLeSample { o, d, l: map.lookup(uv, wl) * *scale, surface: None, pdf_pos, pdf_dir }
            }
            Light::DiffuseArea { shape, element, l, image, two_sided, alpha, .. } => {
                let ss = shape.sample_area(*element as usize, u_pos)?;
                if alpha_masked(alpha, ss.p, ss.n, ss.uv) {
                    return None;
                }
                // Cosine-weighted about the emitting side; a two-sided emitter picks a side with probability ½.
                let (mut u, mut n) = (u_dir, ss.n);
                let mut side_pdf = 1.0;
                if *two_sided {
                    side_pdf = 0.5;
                    if u.x < 0.5 {
                        u.x *= 2.0;
                    } else {
                        u.x = 2.0 * u.x - 1.0;
                        n = -n;
                    }
                    u.x = u.x.min(1.0 - f32::EPSILON / 2.0);
                }
                let local = crate::sampling::sample_cosine_hemisphere(u);
                let d = Frame::from_z(n).from_local(local);
                LightLeSample {
                    o: ss.p,
                    d,
                    l: emitted(l, image, ss.p, ss.n, ss.uv, wl),
                    surface: Some(geometry::SurfacePoint { p: ss.p, p_error: ss.p_error, n: ss.n }),
                    pdf_pos: ss.pdf,
                    pdf_dir: side_pdf * crate::sampling::cosine_hemisphere_pdf(local.z),
                }
            }
        };
        (s.pdf_pos > 0.0 && s.pdf_dir > 0.0 && s.pdf_pos.is_finite() && s.pdf_dir.is_finite()).then_some(s)
    }

    /// True for lights whose position is a delta (point and spot lights) and for area lights on shapes of alpha 0,
    /// as pbrt-v4 marks them: no ray can hit them.
    pub fn is_delta_position(&self) -> bool {
        // A full match (not `matches!`): bdpt's MIS weights depend on it.
        match self {
            Light::Point { .. } | Light::Spot { .. } | Light::DiffuseArea { invisible: true, .. } => true,
            Light::DiffuseArea { invisible: false, .. }
            | Light::Distant { .. }
            | Light::DistantDisc { .. }
            | Light::UniformInfinite { .. }
            | Light::ImageInfinite { .. } => false,
        }
    }

    /// True for lights whose direction is a delta (distant lights).
    pub fn is_delta_direction(&self) -> bool {
        // A full match (not `matches!`): bdpt's MIS weights depend on it.
        match self {
            Light::Distant { .. } => true,
            Light::Point { .. }
            | Light::Spot { .. }
            | Light::DiffuseArea { .. }
            | Light::DistantDisc { .. }
            | Light::UniformInfinite { .. }
            | Light::ImageInfinite { .. } => false,
        }
    }

    /// Densities with which [`Light::sample_le`] emits a ray leaving the light in unit direction `w`: per unit area
    /// of the origin (0 for a point light's delta position; the disk's 1/(πR²) for lights at infinity) and per
    /// steradian of the direction (0 for a distant light's delta direction). `n` is the emitting surface's normal
    /// at the origin for area lights (ignored otherwise); `scene_radius` the radius of the scene's bounding sphere.
    pub fn pdf_le(&self, n: Vec3, w: Vec3, scene_radius: f32) -> (f32, f32) {
        let disk = 1.0 / (PI * scene_radius.max(1e-6) * scene_radius.max(1e-6));
        match self {
            Light::Point { .. } => (0.0, 1.0 / (4.0 * PI)),
            Light::Spot { frame, cos_falloff_end, .. } => {
                let inside = frame.z.dot(w) >= *cos_falloff_end;
                (0.0, if inside { 1.0 / (2.0 * PI * (1.0 - cos_falloff_end)) } else { 0.0 })
            }
            Light::Distant { .. } => (disk, 0.0),
            Light::UniformInfinite { .. } | Light::ImageInfinite { .. } | Light::DistantDisc { .. } => {
                (disk, self.pdf_li_infinite(-w))
            }
            Light::DiffuseArea { shape, element, two_sided, .. } => {
                let area = shape.area(*element as usize);
                let pos = if area > 0.0 { 1.0 / area } else { 0.0 };
                let cos = n.dot(w);
                let dir = if *two_sided {
                    0.5 * crate::sampling::cosine_hemisphere_pdf(cos.abs())
                } else {
                    crate::sampling::cosine_hemisphere_pdf(cos)
                };
                (pos, dir)
            }
        }
    }

    /// Solid-angle density that [`Light::sample_li`] would give for direction `wi` from `from` (area lights).
    pub fn pdf_li_area(&self, from: Vec3, wi: Vec3) -> f32 {
        match self {
            Light::DiffuseArea { shape, element, .. } => shape.pdf_solid_angle(*element as usize, from, wi),
            Light::Point { .. }
            | Light::Spot { .. }
            | Light::Distant { .. }
            | Light::DistantDisc { .. }
            | Light::UniformInfinite { .. }
            | Light::ImageInfinite { .. } => 0.0,
        }
    }

    /// Solid-angle density of [`Light::sample_li`] for an escaping direction `w` (infinite lights).
    pub fn pdf_li_infinite(&self, w: Vec3) -> f32 {
        match self {
            Light::UniformInfinite { .. } => 1.0 / (4.0 * PI),
            Light::DistantDisc { frame, one_minus_cos, sin2_max, .. } => {
                if Self::disc_contains(frame, *sin2_max, w) {
                    1.0 / (2.0 * PI * one_minus_cos)
                } else {
                    0.0
                }
            }
            Light::ImageInfinite { map, .. } => {
                let local = map.frame.to_local(w);
                let (uv, jac) = map.uv(local);
                map.distribution.pdf([uv.x as f64, uv.y as f64]) as f32 / jac
            }
            Light::Point { .. } | Light::Spot { .. } | Light::Distant { .. } | Light::DiffuseArea { .. } => 0.0,
        }
    }

    /// Radiance emitted from an area light's surface point `p` (surface coordinates `uv`, normal `n`) towards `w`.
    pub fn l_area(&self, p: Vec3, uv: Vec2, n: Vec3, w: Vec3, wl: &SampledWavelengths) -> SampledSpectrum {
        match self {
            Light::DiffuseArea { l, image, two_sided, alpha, .. } => {
                if (*two_sided || n.dot(w) > 0.0) && !alpha_masked(alpha, p, n, uv) {
                    emitted(l, image, p, n, uv, wl)
                } else {
                    SampledSpectrum::zero()
                }
            }
            Light::Point { .. }
            | Light::Spot { .. }
            | Light::Distant { .. }
            | Light::DistantDisc { .. }
            | Light::UniformInfinite { .. }
            | Light::ImageInfinite { .. } => SampledSpectrum::zero(),
        }
    }

    /// Radiance arriving along an escaping ray with direction `w` (infinite lights).
    pub fn le(&self, w: Vec3, wl: &SampledWavelengths) -> SampledSpectrum {
        match self {
            Light::UniformInfinite { l, .. } => l.sample(wl),
            Light::DistantDisc { frame, l, sin2_max, .. } => {
                if Self::disc_contains(frame, *sin2_max, w) {
                    l.sample(wl)
                } else {
                    SampledSpectrum::zero()
                }
            }
            Light::ImageInfinite { map, scale, .. } => {
                let (uv, _) = map.uv(map.frame.to_local(w));
                map.lookup(uv, wl) * *scale
            }
            Light::Point { .. } | Light::Spot { .. } | Light::Distant { .. } | Light::DiffuseArea { .. } => {
                SampledSpectrum::zero()
            }
        }
    }

    /// The direction towards a light at infinity that arrives from one direction or a small disc of them (a sun),
    /// if this is one.
    pub fn sun_direction(&self) -> Option<Vec3> {
        match self {
            Light::Distant { w, .. } => Some(*w),
            Light::DistantDisc { frame, .. } => Some(frame.z),
            Light::Point { .. }
            | Light::Spot { .. }
            | Light::DiffuseArea { .. }
            | Light::UniformInfinite { .. }
            | Light::ImageInfinite { .. } => None,
        }
    }

    /// Emitted power, reduced to a luminance-weighted scalar for the power-based light sampler.
    pub fn power(&self) -> f64 {
        let y = |s: &Spectrum| spectral::Observer::Cie1931.spectrum_to_xyz(s).y;
        let pi = std::f64::consts::PI;
        match self {
            Light::Point { i, .. } => 4.0 * pi * y(i),
            Light::Spot { i, cos_falloff_start, cos_falloff_end, .. } => {
                2.0 * pi * y(i) * (1.0 - 0.5 * ((cos_falloff_start + cos_falloff_end) as f64))
            }
            Light::Distant { l, scene_radius, .. } => pi * (*scene_radius as f64).powi(2) * y(l),
            // The disc's irradiance π sin²θ_max · L through the scene's cross-section.
            Light::DistantDisc { l, sin2_max, scene_radius, .. } => {
                pi * (*scene_radius as f64).powi(2) * pi * *sin2_max as f64 * y(l)
            }
            Light::UniformInfinite { l, scene_radius } => 4.0 * pi * pi * (*scene_radius as f64).powi(2) * y(l),
            Light::ImageInfinite { map, scale, scene_radius } => {
                4.0 * pi * pi * (*scene_radius as f64).powi(2) * (*scale as f64) * map.average_luminance() as f64
            }
            Light::DiffuseArea { shape, element, l, image, two_sided, .. } => {
                let image_y = image.as_ref().map_or(1.0, |img| img.mean_luminance as f64);
                pi * shape.area(*element as usize) as f64 * y(l) * image_y * if *two_sided { 2.0 } else { 1.0 }
            }
        }
    }
}

fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    if a == b {
        return if x < a { 0.0 } else { 1.0 };
    }
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

impl EnvironmentMap {
    /// The map of a `width`×`height` linear sRGB image (row-major from the top; negative values count as 0):
    /// square for the equal-area octahedral layout, 2:1 for lat-long. Texels are uplifted to illuminant spectra,
    /// and the sampling distribution is built over the texel grid (see [`EnvironmentMap::distribution`]).
    pub fn from_rgb(width: usize, height: usize, pixels: &[[f32; 3]], frame: Frame) -> Result<Self, RenderError> {
        let equal_area = width == height;
        if !equal_area && width != 2 * height {
            return Err(invalid_data(format!(
                "environment map {width}×{height} is neither square (equal-area) nor 2:1 (lat-long)"
            )));
        }
        if pixels.len() != width * height {
            return Err(invalid_data(format!("environment map {width}×{height} given {} pixels", pixels.len())));
        }
        let cs = spectral::RgbColorSpace::srgb();
        let mut texels = Vec::with_capacity(pixels.len());
        let mut weights = Vec::with_capacity(pixels.len());
        let mut lum_sum = 0.0f64;
        for (i, px) in pixels.iter().enumerate() {
            let rgb = px.map(|c| (c.max(0.0)) as f64);
            texels
                .push(spectral::rgb_uplift::RgbIlluminantSpectrum::new(rgb).map_err(|e| invalid_data(e.to_string()))?);
            lum_sum += cs.to_xyz(rgb).y.max(0.0);
            // pbrt-v4 samples the mean of the texel's channels (Image::GetSamplingDistribution); lat-long rows
            // cover less solid angle near the poles, so they are weighted by sin θ at the row's centre. A black
            // texel is never sampled: its radiance is exactly zero, since lookups take the nearest texel.
            let row = i / width;
            let sin_theta =
                if equal_area { 1.0 } else { ((row as f64 + 0.5) / height as f64 * std::f64::consts::PI).sin() };
            weights.push((rgb[0] + rgb[1] + rgb[2]) / 3.0 * sin_theta);
        }
        let distribution = Distribution2D::new(&weights, width, height, (0.0, 1.0), (0.0, 1.0))
            .map_err(|e| invalid_data(e.to_string()))?;
        Ok(Self {
            width,
            height,
            texels,
            equal_area,
            mean_luminance: (lum_sum / pixels.len() as f64) as f32,
            distribution,
            frame,
        })
    }

    /// Unit direction (light space) for image coordinates `uv ∈ [0,1]²`, and the Jacobian |dω/d(uv)| (so a density
    /// over uv divided by it is a density over solid angle).
    pub fn direction(&self, uv: Vec2) -> Option<(Vec3, f32)> {
        if self.equal_area {
            Some((equal_area_square_to_sphere(uv), 4.0 * PI))
        } else {
            // Lat-long: u → φ ∈ [0, 2π), v → θ ∈ [0, π] from +z.
            let theta = uv.y * PI;
            let phi = uv.x * 2.0 * PI;
            let st = theta.sin();
            if st <= 0.0 {
                return None;
            }
            Some((Vec3::new(st * phi.cos(), st * phi.sin(), theta.cos()), 2.0 * PI * PI * st))
        }
    }

    /// Image coordinates of a light-space direction, and the Jacobian as in [`EnvironmentMap::direction`].
    pub fn uv(&self, w: Vec3) -> (Vec2, f32) {
        if self.equal_area {
            (equal_area_sphere_to_square(w), 4.0 * PI)
        } else {
            let theta = w.z.clamp(-1.0, 1.0).acos();
            let mut phi = w.y.atan2(w.x);
            if phi < 0.0 {
                phi += 2.0 * PI;
            }
            (Vec2::new(phi / (2.0 * PI), theta / PI), 2.0 * PI * PI * theta.sin().max(1e-8))
        }
    }

    /// The texel holding `uv` (pbrt-v4's `ImageInfiniteLight` looks up the nearest texel: radiance is constant
    /// over each texel, as is the sampling density, so eval and pdf agree texel by texel). `uv` exactly on the
    /// far edge maps back inside (octahedrally for equal-area maps; lat-long wraps in φ and clamps at the poles).
    pub fn texel_index(&self, uv: Vec2) -> usize {
        let (w, h) = (self.width as i64, self.height as i64);
        let (x, y) = ((uv.x * self.width as f32).floor() as i64, (uv.y * self.height as f32).floor() as i64);
        let (x, y) = if self.equal_area { octahedral_wrap(x, y, w, h) } else { (x.rem_euclid(w), y.clamp(0, h - 1)) };
        (y * w + x) as usize
    }

    /// Radiance at `uv`: the texel holding it (see [`EnvironmentMap::texel_index`]), uplifted at the path's
    /// wavelengths.
    pub fn lookup(&self, uv: Vec2, wl: &SampledWavelengths) -> SampledSpectrum {
        let t = &self.texels[self.texel_index(uv)];
        let mut s = SampledSpectrum::zero();
        for i in 0..spectral::N_WAVELENGTHS {
            s[i] = t.eval(wl.lambda(i) as f64) as f32;
        }
        s
    }

    /// Mean luminance over the image.
    pub fn average_luminance(&self) -> f32 {
        self.mean_luminance
    }
}

/// Clarberg's equal-area mapping from the square to the sphere (pbrt-v4's environment map layout).
pub fn equal_area_square_to_sphere(p: Vec2) -> Vec3 {
    let u = 2.0 * p.x - 1.0;
    let v = 2.0 * p.y - 1.0;
    let (up, vp) = (u.abs(), v.abs());
    let signed_distance = 1.0 - (up + vp);
    let d = signed_distance.abs();
    let r = 1.0 - d;
    let phi = if r == 0.0 { 1.0 } else { (vp - up) / r + 1.0 } * PI / 4.0;
    let z = (1.0 - r * r).copysign(signed_distance);
    let cos_phi = phi.cos().copysign(u);
    let sin_phi = phi.sin().copysign(v);
    let s = r * (2.0 - r * r).max(0.0).sqrt();
    Vec3::new(cos_phi * s, sin_phi * s, z)
}

/// Inverse of [`equal_area_square_to_sphere`].
pub fn equal_area_sphere_to_square(d: Vec3) -> Vec2 {
    let (x, y, z) = (d.x.abs(), d.y.abs(), d.z.abs());
    let r = (1.0 - z).max(0.0).sqrt();
    let a = x.max(y);
    let b = x.min(y);
    let b = if a == 0.0 { 0.0 } else { b / a };
    let mut phi = b.atan() * 2.0 / PI;
    if x < y {
        phi = 1.0 - phi;
    }
    let mut v = phi * r;
    let mut u = r - v;
    if d.z < 0.0 {
        std::mem::swap(&mut u, &mut v);
        u = 1.0 - u;
        v = 1.0 - v;
    }
    u = u.copysign(d.x);
    v = v.copysign(d.y);
    Vec2::new(0.5 * (u + 1.0), 0.5 * (v + 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn environment_lookup_takes_the_nearest_texel_and_wraps_in_phi() {
        let map = EnvironmentMap::from_rgb(2, 1, &[[0.0; 3], [1.0; 3]], Frame::from_z(Vec3::Z)).unwrap();
        let wl = SampledWavelengths::new([450.0, 500.0, 550.0, 600.0], [4.0; 4]);
        let one = grey_at_550(1.0);
        let at = |u: f32| map.lookup(Vec2::new(u, 0.5), &wl)[2] / one;
        assert_eq!((at(0.0), at(0.25), at(0.499)), (0.0, 0.0, 0.0));
        assert_eq!((at(0.5), at(0.75), at(0.999)), (1.0, 1.0, 1.0));
        assert_eq!(at(1.0), 0.0, "u = 1 wraps around φ to the first texel");
    }

    /// The flux that emitted light paths carry equals each light's power: the mean of `flux_weight` over
    /// stratified `sample_le` draws matches `power()` (closed forms: 4πI, 2πI(1 − (cos θ₀ + cos θ₁)/2), πR²L,
    /// 4π²R²L, πAL, twice for two-sided) within 0.5% for a constant spectrum (luminance 1 per unit value).
    #[test]
    fn emitted_flux_equals_power() {
        let wl = SampledWavelengths::new([450.0, 500.0, 550.0, 600.0], [4.0; 4]);
        let c = |v: f64| Spectrum::Constant(v);
        let sphere = geometry::Shape::Sphere(
            geometry::shapes::Sphere::new(0.7, geometry::Transform::translate(glam::DVec3::new(1.0, 2.0, 3.0)), false)
                .unwrap(),
        );
        let lights = [
            Light::Point { p: Vec3::new(1.0, 0.0, 0.0), i: c(2.0) },
            Light::Spot {
                p: Vec3::ZERO,
                frame: Frame::from_z(Vec3::new(0.0, 0.6, 0.8)),
                i: c(3.0),
                cos_falloff_start: 20f32.to_radians().cos(),
                cos_falloff_end: 35f32.to_radians().cos(),
            },
            Light::Distant { w: Vec3::new(0.0, 0.0, 1.0), l: c(1.5), scene_radius: 2.0 },
            Light::UniformInfinite { l: c(0.5), scene_radius: 2.0 },
            Light::DiffuseArea {
                shape: Box::new(sphere.clone()),
                element: 0,
                l: c(1.25),
                image: None,
                two_sided: false,
                alpha: None,
                invisible: false,
            },
            Light::DiffuseArea {
                shape: Box::new(sphere),
                element: 0,
                l: c(1.25),
                image: None,
                two_sided: true,
                alpha: None,
                invisible: false,
            },
        ];
        let n = 64;
        for light in &lights {
            let mut sum = 0.0f64;
            for i in 0..n * n {
                let (a, b) = (i / n, i % n);
                let u_pos = Vec2::new((a as f32 + 0.5) / n as f32, (b as f32 + 0.5) / n as f32);
                // A second, shuffled stratification for the direction.
                let j = (i * 2654435761usize) % (n * n);
                let u_dir = Vec2::new(((j / n) as f32 + 0.5) / n as f32, ((j % n) as f32 + 0.5) / n as f32);
                if let Some(s) = light.sample_le(u_pos, u_dir, &wl, (Vec3::ZERO, 2.0)) {
                    sum += s.flux_weight()[2] as f64;
                }
            }
            let flux = sum / (n * n) as f64;
            let power = light.power();
            assert!((flux / power - 1.0).abs() < 5e-3, "{light:?}: flux {flux} vs power {power}");
        }
    }

    /// An `n`×`n` equal-area map of greys `f(direction of the texel centre)`.
    fn equal_area_map(n: usize, f: impl Fn(Vec3) -> f64) -> EnvironmentMap {
        let mut texels = vec![];
        for y in 0..n {
            for x in 0..n {
                let w =
                    equal_area_square_to_sphere(Vec2::new((x as f32 + 0.5) / n as f32, (y as f32 + 0.5) / n as f32));
                let v = f(w);
                texels.push(spectral::rgb_uplift::RgbIlluminantSpectrum::new([v, v, v]).unwrap());
            }
        }
        EnvironmentMap {
            width: n,
            height: n,
            texels,
            equal_area: true,
            mean_luminance: 1.0,
            distribution: Distribution2D::new(&vec![1.0; n * n], n, n, (0.0, 1.0), (0.0, 1.0)).unwrap(),
            frame: Frame::from_z(Vec3::Z),
        }
    }

    /// Radiance of grey `v` at 550 nm, the reference for lookups of grey maps.
    fn grey_at_550(v: f64) -> f32 {
        spectral::rgb_uplift::RgbIlluminantSpectrum::new([v, v, v]).unwrap().eval(550.0) as f32
    }

    #[test]
    fn equal_area_lookup_returns_the_texel_holding_the_direction() {
        // Distinct texel values; any direction must get exactly the value of the texel its square point lies in.
        let n = 16;
        let map = equal_area_map(n, |w| 1.0 + 0.9 * (13.0 * w.x + 7.0 * w.y * w.y + 5.0 * w.z).sin() as f64);
        let wl = SampledWavelengths::new([450.0, 500.0, 550.0, 600.0], [4.0; 4]);
        let mut rng = rand_pcg::Pcg32::new(7, 11);
        let mut next = || (rand_core::RngCore::next_u32(&mut rng) >> 8) as f32 / (1u32 << 24) as f32;
        for _ in 0..2000 {
            let w = sample_uniform_sphere(Vec2::new(next(), next()));
            let uv = equal_area_sphere_to_square(w);
            let (x, y) = (((uv.x * n as f32) as usize).min(n - 1), ((uv.y * n as f32) as usize).min(n - 1));
            assert_eq!(map.lookup(uv, &wl)[2], map.texels[y * n + x].eval(550.0) as f32, "{w}");
        }
        // The far edges map back inside, mirrored about the edge's midpoint as pbrt-v4's octahedral wrap does.
        assert_eq!(map.texel_index(Vec2::new(1.0, 0.1)), (n - 1 - 1) * n + (n - 1));
        assert_eq!(map.texel_index(Vec2::new(0.3, 1.0)), (n - 1) * n + (n - 1 - 4));
    }

    /// ∫ Le dω by `n`² stratified light samples (Le/pdf), the density of every sample checked against
    /// `pdf_li_infinite`, and ∫ pdf dω over a grid of directions.
    fn integrate_environment(light: &Light, n: usize) -> (f64, f64, f64) {
        let wl = SampledWavelengths::new([450.0, 500.0, 550.0, 600.0], [4.0; 4]);
        let ctx = LightSampleContext { p: Vec3::ZERO };
        let (mut sum, mut worst) = (0.0f64, 0.0f64);
        for i in 0..n * n {
            let u = Vec2::new(((i % n) as f32 + 0.5) / n as f32, ((i / n) as f32 + 0.5) / n as f32);
            if let Some(s) = light.sample_li(&ctx, u, &wl) {
                sum += (s.l[2] / s.pdf) as f64;
                let p = light.pdf_li_infinite(s.wi);
                worst = worst.max(((p - s.pdf) / s.pdf).abs() as f64);
            }
        }
        // ∫ pdf dω on a (θ, φ) grid, dω = sin θ dθ dφ (midpoint rule).
        let (m, pi) = (400, std::f64::consts::PI);
        let mut integral = 0.0f64;
        for i in 0..m {
            let theta = (i as f64 + 0.5) / m as f64 * pi;
            for j in 0..2 * m {
                let phi = (j as f64 + 0.5) / (2 * m) as f64 * 2.0 * pi;
                let w =
                    Vec3::new((theta.sin() * phi.cos()) as f32, (theta.sin() * phi.sin()) as f32, theta.cos() as f32);
                integral += light.pdf_li_infinite(w) as f64 * theta.sin() * (pi / m as f64) * (pi / m as f64);
            }
        }
        (sum / (n * n) as f64, worst, integral)
    }

    #[test]
    fn small_environment_maps_emit_each_texel_in_its_solid_angle() {
        // Equal-area 2×2: each texel is one quarter of the sphere (π sr, the quadrant of the signs of x and y).
        // Sampling is proportional to the texel's value, so for a grey map Le/pdf is the same for every sample:
        // exactly ∫ Le dω = π Σ L.
        let v = [0.5f32, 2.0, 1.0, 4.0];
        let map = EnvironmentMap::from_rgb(2, 2, &v.map(|g| [g; 3]), Frame::from_z(Vec3::Z)).unwrap();
        let wl = SampledWavelengths::new([450.0, 500.0, 550.0, 600.0], [4.0; 4]);
        for (w, texel) in [
            (Vec3::new(-0.3, -0.2, 0.9), 0),
            (Vec3::new(0.3, -0.2, -0.9), 1),
            (Vec3::new(-0.5, 0.4, -0.1), 2),
            (Vec3::new(0.1, 0.7, 0.2), 3),
        ] {
            let light = Light::ImageInfinite { map: Box::new(map.clone()), scale: 1.0, scene_radius: 1.0 };
            assert_eq!(light.le(w.normalize(), &wl)[2], grey_at_550(v[texel] as f64), "{w}");
        }
        let light = Light::ImageInfinite { map: Box::new(map), scale: 1.0, scene_radius: 1.0 };
        let exact = std::f64::consts::PI * v.iter().map(|&g| grey_at_550(g as f64) as f64).sum::<f64>();
        let (mean, worst_pdf, pdf_integral) = integrate_environment(&light, 16);
        assert!((mean / exact - 1.0).abs() < 1e-5, "∫Le {mean} vs {exact}");
        assert!(worst_pdf < 1e-5, "sample pdf vs pdf_li_infinite: {worst_pdf}");
        assert!((pdf_integral - 1.0).abs() < 1e-4, "∫pdf = {pdf_integral}");

        // Lat-long 4×2: texel (x, y) spans φ ∈ [πx/2, π(x+1)/2] and θ ∈ [πy/2, π(y+1)/2]: π/2 sr each.
        let v = [0.5f32, 2.0, 1.0, 4.0, 3.0, 0.0, 1.5, 0.25];
        let map = EnvironmentMap::from_rgb(4, 2, &v.map(|g| [g; 3]), Frame::from_z(Vec3::Z)).unwrap();
        let light = Light::ImageInfinite { map: Box::new(map), scale: 1.0, scene_radius: 1.0 };
        let (theta, phi) = (1.1f32, 3.5f32); // upper row (θ < π/2), φ in the third quarter: texel 2; mirrored in z: 6
        let w = Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
        assert_eq!(light.le(Vec3::new(w.x, w.y, -w.z), &wl)[2], grey_at_550(v[6] as f64));
        assert_eq!(light.le(w, &wl)[2], grey_at_550(v[2] as f64));
        let exact = std::f64::consts::FRAC_PI_2 * v.iter().map(|&g| grey_at_550(g as f64) as f64).sum::<f64>();
        let (mean, worst_pdf, pdf_integral) = integrate_environment(&light, 256);
        assert!((mean / exact - 1.0).abs() < 2e-3, "∫Le {mean} vs {exact}");
        // (f32 acos near the poles: θ recovered from z loses a few 1e-4 of sin θ there.)
        assert!(worst_pdf < 2e-3, "sample pdf vs pdf_li_infinite: {worst_pdf}");
        assert!((pdf_integral - 1.0).abs() < 2e-3, "∫pdf = {pdf_integral}");
    }

    #[test]
    fn equal_area_mapping_round_trips() {
        for i in 0..20 {
            for j in 0..20 {
                let p = Vec2::new((i as f32 + 0.5) / 20.0, (j as f32 + 0.5) / 20.0);
                let w = equal_area_square_to_sphere(p);
                assert!((w.length() - 1.0).abs() < 1e-5);
                let q = equal_area_sphere_to_square(w);
                assert!((p - q).length() < 1e-4, "{p} → {w} → {q}");
            }
        }
    }
}

//! Participating media: what a point inside a medium does to light (absorption σa, scattering σs, emission Le and
//! the phase function), and distance sampling against a majorant σ_maj ≥ σt, the building block of delta tracking
//! and ratio tracking in the null-scattering formulation (Miller, Georgiev & Jarosz 2019; pbrt-v4 §11.2–11.4).
//!
//! Coefficients are per unit scene length and depend on wavelength: a chromatic medium is the normal case.

use std::sync::Arc;

use glam::{DVec3, Vec2, Vec3};
use optics::mie::MieSpectralTable;
use spectral::{SampledSpectrum, SampledWavelengths, Spectrum, N_WAVELENGTHS};

use crate::sampling::Frame;

/// 1/(4π).
const INV_4PI: f32 = 1.0 / (4.0 * std::f32::consts::PI);

/// A phase function: the angular distribution of light scattered at a point of a medium.
#[derive(Clone, Debug)]
pub enum PhaseFunction {
    /// Henyey & Greenstein (1941) with asymmetry `g` ∈ (−1, 1): the mean cosine of the scattering angle.
    HenyeyGreenstein(f32),
    /// The unpolarised Lorenz–Mie phase function of spherical particles, tabulated per wavelength (Bohren & Huffman
    /// 1983, eq. 4.74 and 3.16): a different function at every wavelength, sampled exactly from its table.
    Mie(Arc<MieSpectralTable>),
}

/// A direction sampled from a phase function.
#[derive(Clone, Copy, Debug)]
pub struct PhaseSample {
    /// The new direction of propagation (unit).
    pub wi: Vec3,
    /// The phase function's value at each carried wavelength.
    pub p: SampledSpectrum,
    /// The density `wi` was drawn with (per steradian).
    pub pdf: f32,
}

/// Henyey–Greenstein phase function of the scattering angle θ between the incoming and the outgoing propagation
/// directions: p(θ) = (1 − g²) / (4π (1 + g² − 2g cos θ)^{3/2}) (Henyey & Greenstein 1941, eq. 2).
#[inline]
pub fn henyey_greenstein(cos_theta: f32, g: f32) -> f32 {
    let denom = 1.0 + g * g - 2.0 * g * cos_theta;
    INV_4PI * (1.0 - g * g) / (denom * denom.max(0.0).sqrt())
}

/// The cosine of a scattering angle drawn from Henyey–Greenstein by inverting its CDF:
/// cos θ = (1 + g² − ((1 − g²)/(1 − g + 2gu))²) / (2g), and 1 − 2u for isotropic scattering.
#[inline]
pub fn sample_henyey_greenstein(g: f32, u: f32) -> f32 {
    if g.abs() < 1e-3 {
        return 1.0 - 2.0 * u;
    }
    let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u);
    ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
}

impl PhaseFunction {
    /// The phase function for light travelling along `d_in` and leaving along `wi` (both directions of
    /// propagation), at each carried wavelength.
    #[inline]
    pub fn p(&self, d_in: Vec3, wi: Vec3, wl: &SampledWavelengths) -> SampledSpectrum {
        match self {
            PhaseFunction::HenyeyGreenstein(g) => SampledSpectrum::splat(henyey_greenstein(d_in.dot(wi), *g)),
            PhaseFunction::Mie(table) => mie_p(table, scattering_cosine(d_in, wi), wl),
        }
    }

    /// The density [`PhaseFunction::sample`] draws `wi` with.
    #[inline]
    pub fn pdf(&self, d_in: Vec3, wi: Vec3, wl: &SampledWavelengths) -> f32 {
        match self {
            PhaseFunction::HenyeyGreenstein(g) => henyey_greenstein(d_in.dot(wi), *g),
            PhaseFunction::Mie(table) => mie_mixture_pdf(&mie_p(table, scattering_cosine(d_in, wi), wl), wl),
        }
    }

    /// [`PhaseFunction::pdf`] from the phase function's values `p` at the direction (what [`PhaseFunction::p`]
    /// returned there), without looking them up again.
    #[inline]
    pub fn pdf_of_values(&self, p: &SampledSpectrum, wl: &SampledWavelengths) -> f32 {
        match self {
            PhaseFunction::HenyeyGreenstein(_) => p[0],
            PhaseFunction::Mie(_) => mie_mixture_pdf(p, wl),
        }
    }

    /// Draws an outgoing direction for light travelling along `d_in`: `u` places the direction around the lobe and
    /// `u_pick` chooses among the carried wavelengths where the lobe depends on wavelength.
    #[inline]
    pub fn sample(&self, d_in: Vec3, u: Vec2, u_pick: f32, wl: &SampledWavelengths) -> Option<PhaseSample> {
        match self {
            PhaseFunction::HenyeyGreenstein(g) => {
                let cos = sample_henyey_greenstein(*g, u.x);
                let wi = direction_about(d_in, f64::from(cos), u.y);
                let p = henyey_greenstein(cos, *g);
                (p > 0.0).then(|| PhaseSample { wi, p: SampledSpectrum::splat(p), pdf: p })
            }
            PhaseFunction::Mie(table) => {
                // One-sample MIS over the carried wavelengths (Veach 1997, §9.2.4): pick an active slot uniformly,
                // draw from its lobe; the density is the mean of the active slots' lobes (the balance heuristic), so
                // a bow that only one wavelength puts at this angle is still sampled in proportion to its share.
                let k = wl.active_count().max(1);
                let pick = ((u_pick * k as f32) as usize).min(k - 1);
                let slot = (0..N_WAVELENGTHS).filter(|&i| wl.is_active(i)).nth(pick).unwrap_or(0);
                table.with_wavelengths(lambdas(wl), |w| {
                    let cos = table.sample_of(w[slot], f64::from(u.x));
                    let wi = direction_about(d_in, cos, u.y);
                    let p = SampledSpectrum(std::array::from_fn(|i| table.phase_of(w[i], cos) as f32));
                    let pdf = mie_mixture_pdf(&p, wl);
                    (pdf > 0.0 && pdf.is_finite()).then_some(PhaseSample { wi, p, pdf })
                })
            }
        }
    }
}

/// The cosine of the angle between two unit vectors, in f64 from atan2(|a×b|, a·b): accurate near 0 and π, where
/// the Mie tables of large drops resolve angles far below what an f32 cosine can (a 250 µm drop's forward peak
/// is ~3e-4 rad wide; f32's cosine steps are that size there).
#[inline]
fn scattering_cosine(a: Vec3, b: Vec3) -> f64 {
    let (a, b) = (DVec3::from(a), DVec3::from(b));
    a.cross(b).length().atan2(a.dot(b)).cos()
}

/// The unit direction at angle acos(`cos`) from `axis` and azimuth 2π·`u_phi`. The sine is taken in f64 so that
/// directions a few µrad from `axis` keep their angle.
#[inline]
fn direction_about(axis: Vec3, cos: f64, u_phi: f32) -> Vec3 {
    let cos = cos.clamp(-1.0, 1.0);
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    let phi = 2.0 * std::f64::consts::PI * f64::from(u_phi);
    let local = Vec3::new((sin * phi.cos()) as f32, (sin * phi.sin()) as f32, cos as f32);
    Frame::from_z(axis).from_local(local).normalize()
}

/// The carried wavelengths in f64, as the Mie optics are looked up by.
#[inline]
fn lambdas(wl: &SampledWavelengths) -> [f64; N_WAVELENGTHS] {
    std::array::from_fn(|i| f64::from(wl.lambda(i)))
}

/// The Mie phase function at scattering cosine `cos`, at each carried wavelength.
#[inline]
fn mie_p(table: &MieSpectralTable, cos: f64, wl: &SampledWavelengths) -> SampledSpectrum {
    table.with_wavelengths(lambdas(wl), |w| SampledSpectrum(std::array::from_fn(|i| table.phase_of(w[i], cos) as f32)))
}

/// A homogeneous medium's absorption or scattering coefficient: a spectrum, or the particle density times the
/// Mie cross section computed at each carried wavelength.
#[derive(Clone, Debug)]
pub enum Coefficient {
    /// A coefficient given as a spectrum, per unit length.
    Spectrum(Spectrum),
    /// σs = N·C_sca(λ)·(1 − F(λ)) of particles `density` N per m³ (F the fraction inside the forward cut-off, which
    /// counts as no scattering).
    MieScattering {
        /// The particles' optics.
        table: Arc<MieSpectralTable>,
        /// Particles per m³.
        density: f64,
    },
    /// σa = N·C_abs(λ) of particles `density` N per m³.
    MieAbsorption {
        /// The particles' optics.
        table: Arc<MieSpectralTable>,
        /// Particles per m³.
        density: f64,
    },
}

impl Coefficient {
    /// The coefficient at each carried wavelength.
    #[inline]
    pub fn sample(&self, wl: &SampledWavelengths) -> SampledSpectrum {
        match self {
            Coefficient::Spectrum(s) => s.sample(wl),
            Coefficient::MieScattering { table, density } => table.with_wavelengths(lambdas(wl), |w| {
                SampledSpectrum(std::array::from_fn(|i| (density * w[i].c_sca * (1.0 - w[i].cut_fraction)) as f32))
            }),
            Coefficient::MieAbsorption { table, density } => table.with_wavelengths(lambdas(wl), |w| {
                SampledSpectrum(std::array::from_fn(|i| (density * w[i].c_abs) as f32))
            }),
        }
    }

    /// The coefficient at one wavelength, nm (what tests compare with closed forms).
    #[cfg(test)]
    pub fn eval(&self, lambda_nm: f64) -> f64 {
        match self {
            Coefficient::Spectrum(s) => s.eval(lambda_nm),
            Coefficient::MieScattering { table, density } => {
                table.with_wavelengths([lambda_nm], |[w]| density * w.c_sca * (1.0 - w.cut_fraction))
            }
            Coefficient::MieAbsorption { table, density } => {
                table.with_wavelengths([lambda_nm], |[w]| density * w.c_abs)
            }
        }
    }

    /// Whether the coefficient is 0 at every wavelength (particles always scatter, and absorb unless k = 0, which
    /// is taken as "may absorb").
    pub fn is_zero(&self) -> bool {
        match self {
            Coefficient::Spectrum(s) => s.max_value() <= 0.0,
            Coefficient::MieScattering { .. } | Coefficient::MieAbsorption { .. } => false,
        }
    }
}

impl From<Spectrum> for Coefficient {
    fn from(s: Spectrum) -> Self {
        Coefficient::Spectrum(s)
    }
}

/// The density of the one-sample mixture [`PhaseFunction::sample`] draws Mie directions from: the mean of the
/// active wavelengths' phase functions.
#[inline]
fn mie_mixture_pdf(p: &SampledSpectrum, wl: &SampledWavelengths) -> f32 {
    let (sum, k) = (0..N_WAVELENGTHS).filter(|&i| wl.is_active(i)).fold((0.0, 0), |(s, k), i| (s + p[i], k + 1));
    if k == 0 {
        0.0
    } else {
        sum / k as f32
    }
}

/// What a medium is at one point, at the path's wavelengths.
#[derive(Clone, Copy, Debug)]
pub struct MediumPoint<'a> {
    /// Absorption coefficient σa.
    pub sigma_a: SampledSpectrum,
    /// Scattering coefficient σs.
    pub sigma_s: SampledSpectrum,
    /// Emitted radiance Le (the source term is σa·Le, pbrt-v4's convention).
    pub le: SampledSpectrum,
    /// The phase function there.
    pub phase: &'a PhaseFunction,
}

/// What a tentative collision of delta tracking turns out to be.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Collision {
    /// Absorption, with probability σa/σ_maj.
    Absorb,
    /// Real scattering, with probability σs/σ_maj.
    Scatter,
    /// A null collision: the rest.
    Null,
}

impl MediumPoint<'_> {
    /// The null-collision coefficient σn = σ_maj − σa − σs (clamped at zero) for majorant `sigma_maj`.
    #[inline]
    pub fn sigma_n(&self, sigma_maj: SampledSpectrum) -> SampledSpectrum {
        (sigma_maj - self.sigma_a - self.sigma_s).map(|x| x.max(0.0))
    }

    /// Chooses the collision type with `u`, by the hero slot's probabilities (pbrt-v4 §14.1.3).
    #[inline]
    pub fn collision(&self, sigma_maj: SampledSpectrum, hero: usize, u: f32) -> Collision {
        let p_absorb = self.sigma_a[hero] / sigma_maj[hero];
        let p_scatter = self.sigma_s[hero] / sigma_maj[hero];
        if u < p_absorb {
            Collision::Absorb
        } else if u < p_absorb + p_scatter {
            Collision::Scatter
        } else {
            Collision::Null
        }
    }
}

/// A homogeneous medium: the same coefficients everywhere.
#[derive(Clone, Debug)]
pub struct HomogeneousMedium {
    /// Absorption coefficient, per unit length.
    pub sigma_a: Coefficient,
    /// Scattering coefficient, per unit length.
    pub sigma_s: Coefficient,
    /// Emitted radiance (already scaled), if the medium glows.
    pub le: Option<Spectrum>,
    /// Phase function.
    pub phase: PhaseFunction,
}

/// A medium whose density is a grid of samples over a box, interpolated trilinearly (pbrt-v4's `uniformgrid`):
/// σa(p) = density(p)·σa, σs(p) = density(p)·σs, Le(p) = Le_scale(p)·Le.
#[derive(Clone, Debug)]
pub struct GridMedium {
    /// Maps a render-space point into medium space (the transform in effect at `MakeNamedMedium`, inverted).
    pub medium_from_render: glam::Affine3A,
    /// The box's corners in medium space (`p0`, `p1`).
    pub bounds: (Vec3, Vec3),
    /// The density samples.
    pub density: DensityGrid,
    /// Absorption coefficient at density 1.
    pub sigma_a: Spectrum,
    /// Scattering coefficient at density 1.
    pub sigma_s: Spectrum,
    /// Emission: the spectrum and the grid that scales it, if the medium glows.
    pub le: Option<(Spectrum, DensityGrid)>,
    /// Phase function.
    pub phase: PhaseFunction,
}

/// Samples on a regular grid over the unit cube, at voxel centres, trilinearly interpolated and zero outside
/// (pbrt-v4's `SampledGrid`).
#[derive(Clone, Debug)]
pub struct DensityGrid {
    res: [usize; 3],
    values: Vec<f32>,
    max: f32,
}

impl DensityGrid {
    /// A grid of `res[0]·res[1]·res[2]` values, x fastest. `None` if the sizes disagree or a value is negative or
    /// not finite.
    pub fn new(res: [usize; 3], values: Vec<f32>) -> Option<Self> {
        let n = res.iter().try_fold(1usize, |a, &r| a.checked_mul(r))?;
        if n == 0 || values.len() != n || values.iter().any(|v| !v.is_finite() || *v < 0.0) {
            return None;
        }
        let max = values.iter().copied().fold(0.0, f32::max);
        Some(Self { res, values, max })
    }

    /// The largest sample (a majorant of the interpolated values).
    pub fn max_value(&self) -> f32 {
        self.max
    }

    fn at(&self, x: i64, y: i64, z: i64) -> f32 {
        let [nx, ny, nz] = self.res.map(|r| r as i64);
        if x < 0 || y < 0 || z < 0 || x >= nx || y >= ny || z >= nz {
            return 0.0;
        }
        self.values[((z * ny + y) * nx + x) as usize]
    }

    /// The trilinear interpolation at `p` ∈ [0, 1]³.
    pub fn lookup(&self, p: Vec3) -> f32 {
        let s = [p.x * self.res[0] as f32 - 0.5, p.y * self.res[1] as f32 - 0.5, p.z * self.res[2] as f32 - 0.5];
        let i = s.map(|v| v.floor());
        let d = [s[0] - i[0], s[1] - i[1], s[2] - i[2]];
        let (x, y, z) = (i[0] as i64, i[1] as i64, i[2] as i64);
        let lerp = |t: f32, a: f32, b: f32| a + t * (b - a);
        let c00 = lerp(d[0], self.at(x, y, z), self.at(x + 1, y, z));
        let c10 = lerp(d[0], self.at(x, y + 1, z), self.at(x + 1, y + 1, z));
        let c01 = lerp(d[0], self.at(x, y, z + 1), self.at(x + 1, y, z + 1));
        let c11 = lerp(d[0], self.at(x, y + 1, z + 1), self.at(x + 1, y + 1, z + 1));
        lerp(d[2], lerp(d[1], c00, c10), lerp(d[1], c01, c11))
    }
}

/// A participating medium.
#[derive(Clone, Debug)]
pub enum Medium {
    /// The same everywhere.
    Homogeneous(HomogeneousMedium),
    /// A density grid over a box.
    Grid(Box<GridMedium>),
}

/// A stretch of a ray over which `sigma_maj` bounds σt.
#[derive(Clone, Copy, Debug)]
pub struct MajorantSegment {
    /// Where it starts (ray parameter).
    pub t_min: f32,
    /// Where it ends.
    pub t_max: f32,
    /// The majorant at each carried wavelength.
    pub sigma_maj: SampledSpectrum,
}

impl Medium {
    /// True if the medium only absorbs (no scattering, no emission): Beer–Lambert is exact along any ray.
    pub fn is_absorbing_only(&self) -> bool {
        match self {
            Medium::Homogeneous(h) => h.sigma_s.is_zero() && h.le.is_none(),
            Medium::Grid(_) => false,
        }
    }

    /// True if the medium glows.
    pub fn is_emissive(&self) -> bool {
        match self {
            Medium::Homogeneous(h) => h.le.is_some(),
            Medium::Grid(g) => g.le.is_some(),
        }
    }

    /// Transmittance exp(−σa(λ)·d) over distance `d` of a medium that only absorbs (see
    /// [`Medium::is_absorbing_only`]; other media are treated as vacuum by integrators that cannot render them).
    pub fn absorption_transmittance(&self, d: f32, wl: &SampledWavelengths) -> SampledSpectrum {
        match self {
            Medium::Homogeneous(h) if self.is_absorbing_only() => (h.sigma_a.sample(wl) * -d).exp(),
            Medium::Homogeneous(_) | Medium::Grid(_) => SampledSpectrum::splat(1.0),
        }
    }

    /// True if shadow rays take this medium's transmittance exp(−σt·d) in closed form (homogeneous media that
    /// scatter; [`Medium::is_absorbing_only`] media are closed-form everywhere).
    #[inline]
    pub fn has_closed_form_transmittance(&self) -> bool {
        // A full match (not `matches!`): a new medium must say whether shadow rays cross it in closed form.
        match self {
            Medium::Homogeneous(_) => true,
            Medium::Grid(_) => false,
        }
    }

    /// exp(−σt(λ)·d) of a homogeneous medium (1 for other media).
    #[inline]
    pub fn homogeneous_transmittance(&self, d: f32, wl: &SampledWavelengths) -> SampledSpectrum {
        match self {
            // σt·d with σt = 0 and d = ∞ counts as no extinction, not NaN.
            Medium::Homogeneous(h) => {
                (h.sigma_a.sample(wl) + h.sigma_s.sample(wl)).map(|s| if s > 0.0 { (-s * d).exp() } else { 1.0 })
            }
            Medium::Grid(_) => SampledSpectrum::splat(1.0),
        }
    }

    /// The Mie particles' optics, if the medium is a cloud of them.
    pub fn mie_optics(&self) -> Option<&Arc<MieSpectralTable>> {
        match self.phase() {
            PhaseFunction::Mie(table) => Some(table),
            PhaseFunction::HenyeyGreenstein(_) => None,
        }
    }

    /// The phase function (the same at every point of a medium here).
    pub fn phase(&self) -> &PhaseFunction {
        match self {
            Medium::Homogeneous(h) => &h.phase,
            Medium::Grid(g) => &g.phase,
        }
    }

    /// The medium at render-space point `p`.
    #[inline]
    pub fn point(&self, p: Vec3, wl: &SampledWavelengths) -> MediumPoint<'_> {
        match self {
            Medium::Homogeneous(h) => MediumPoint {
                sigma_a: h.sigma_a.sample(wl),
                sigma_s: h.sigma_s.sample(wl),
                le: h.le.as_ref().map_or(SampledSpectrum::zero(), |l| l.sample(wl)),
                phase: &h.phase,
            },
            Medium::Grid(g) => {
                let q = g.unit_point(p);
                let d = g.density.lookup(q);
                let le = match &g.le {
                    Some((spec, scale)) => {
                        let s = scale.lookup(q);
                        if s > 0.0 {
                            spec.sample(wl) * s
                        } else {
                            SampledSpectrum::zero()
                        }
                    }
                    None => SampledSpectrum::zero(),
                };
                MediumPoint {
                    sigma_a: g.sigma_a.sample(wl) * d,
                    sigma_s: g.sigma_s.sample(wl) * d,
                    le,
                    phase: &g.phase,
                }
            }
        }
    }

    /// The part of the ray `o + t·d`, `0 ≤ t < t_max`, that lies in the medium, with a majorant of σt over it
    /// (`None` if the ray misses the medium's extent).
    #[inline]
    pub fn majorant(&self, o: Vec3, d: Vec3, t_max: f32, wl: &SampledWavelengths) -> Option<MajorantSegment> {
        match self {
            Medium::Homogeneous(h) => {
                Some(MajorantSegment { t_min: 0.0, t_max, sigma_maj: h.sigma_a.sample(wl) + h.sigma_s.sample(wl) })
            }
            Medium::Grid(g) => {
                let (t0, t1) = g.clip(o, d, t_max)?;
                let sigma_t = g.sigma_a.sample(wl) + g.sigma_s.sample(wl);
                Some(MajorantSegment { t_min: t0, t_max: t1, sigma_maj: sigma_t * g.density.max_value() })
            }
        }
    }
}

impl GridMedium {
    /// `p` in the unit cube of the grid's box.
    #[inline]
    fn unit_point(&self, p: Vec3) -> Vec3 {
        let q = self.medium_from_render.transform_point3(p);
        (q - self.bounds.0) / (self.bounds.1 - self.bounds.0)
    }

    /// The ray parameters where `o + t·d` is inside the box, clipped to [0, t_max).
    fn clip(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, f32)> {
        let o = self.medium_from_render.transform_point3(o);
        let d = self.medium_from_render.transform_vector3(d);
        let (mut t0, mut t1) = (0.0f32, t_max);
        for a in 0..3 {
            let inv = 1.0 / d[a];
            let (mut near, mut far) = ((self.bounds.0[a] - o[a]) * inv, (self.bounds.1[a] - o[a]) * inv);
            if near > far {
                std::mem::swap(&mut near, &mut far);
            }
            // NaN (a ray parallel to and on a slab's plane) leaves the interval unchanged.
            if near > t0 {
                t0 = near;
            }
            if far < t1 {
                t1 = far;
            }
            if t0 > t1 {
                return None;
            }
        }
        Some((t0, t1))
    }
}

/// A small random number generator for the unbounded number of decisions delta and ratio tracking make along one
/// ray (seeded from the path's sampler, so images stay independent of the thread count): a hash of a counter.
#[derive(Clone, Copy, Debug)]
pub struct TrackingRng {
    seed: u32,
    n: u32,
}

impl TrackingRng {
    /// A generator seeded with `u` (a sampler value in [0, 1)) and a salt.
    pub fn new(u: f32, salt: u32) -> Self {
        Self { seed: crate::sampler::hash_words(&[u.to_bits(), salt]), n: 0 }
    }

    /// The next uniform number in [0, 1).
    #[inline]
    pub fn uniform(&mut self) -> f32 {
        self.n = self.n.wrapping_add(1);
        let h = crate::sampler::hash_words(&[self.seed, self.n]);
        (h >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }
}

/// Most collisions one call of [`sample_t_maj`] visits before it gives up on the ray (a guard against media that are
/// optically huge but finite: such a ray is treated as absorbed).
pub const MAX_COLLISIONS: u32 = 1 << 20;

/// Samples collision points along `o + t·d` (0 ≤ t < `t_max`) in `medium` against its majorant, choosing distances
/// with the majorant at wavelength slot `hero` (delta tracking; pbrt-v4's `SampleT_maj`). At every tentative
/// collision, `callback(p, medium point, σ_maj, T_maj)` is called with the majorant transmittance since the previous
/// collision and the generator for its own decisions; it returns false to stop. Returns the majorant transmittance from the last collision to `t_max` (all
/// ones if the callback stopped the walk).
// pbrt-v4's SampleT_maj: the ray and its extent, the generator, the wavelengths and hero, and the callback.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn sample_t_maj(
    medium: &Medium,
    o: Vec3,
    d: Vec3,
    t_max: f32,
    rng: &mut TrackingRng,
    wl: &SampledWavelengths,
    hero: usize,
    mut callback: impl FnMut(Vec3, &MediumPoint, SampledSpectrum, SampledSpectrum, &mut TrackingRng) -> bool,
) -> SampledSpectrum {
    let Some(seg) = medium.majorant(o, d, t_max, wl) else { return SampledSpectrum::splat(1.0) };
    let sigma_maj = seg.sigma_maj;
    let transmittance = |dt: f32| {
        let dt = dt.min(f32::MAX);
        SampledSpectrum(std::array::from_fn::<f32, N_WAVELENGTHS, _>(|i| {
            if sigma_maj[i] == 0.0 {
                1.0
            } else {
                (-sigma_maj[i] * dt).exp()
            }
        }))
    };
    if sigma_maj[hero] <= 0.0 {
        return transmittance(seg.t_max - seg.t_min);
    }
    // A homogeneous medium is the same at every collision: sample its spectra once.
    let uniform = matches!(medium, Medium::Homogeneous(_)).then(|| medium.point(o, wl));
    let mut t = seg.t_min;
    for _ in 0..MAX_COLLISIONS {
        // Exponential distance with rate σ_maj at the hero wavelength.
        let u = rng.uniform();
        let t_next = t - (1.0 - u).ln() / sigma_maj[hero];
        // (Also when t_next is NaN.)
        if t_next.partial_cmp(&seg.t_max) != Some(std::cmp::Ordering::Less) {
            return transmittance(seg.t_max - t);
        }
        let t_maj = transmittance(t_next - t);
        let p = o + d * t_next;
        let mp = uniform.unwrap_or_else(|| medium.point(p, wl));
        if !callback(p, &mp, sigma_maj, t_maj, rng) {
            return SampledSpectrum::splat(1.0);
        }
        if t_next <= t {
            // No progress in f32 (an optically enormous majorant): the ray cannot leave; treat it as absorbed.
            return SampledSpectrum::zero();
        }
        t = t_next;
    }
    SampledSpectrum::zero()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn henyey_greenstein_is_normalised_and_has_mean_cosine_g() {
        for g in [-0.9f32, -0.3, 0.0, 0.5, 0.95] {
            let n = 200_000;
            let (mut total, mut mean) = (0.0f64, 0.0f64);
            for i in 0..n {
                let cos = -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
                let p = henyey_greenstein(cos as f32, g) as f64 * 2.0 * std::f64::consts::PI * (2.0 / n as f64);
                total += p;
                mean += p * cos;
            }
            assert!((total - 1.0).abs() < 2e-3, "g {g}: integral {total}");
            assert!((mean - g as f64).abs() < 2e-3, "g {g}: mean cosine {mean}");
        }
    }

    /// Chi-square test of HG sampling against its density in 20 bins of cos θ (19 degrees of freedom; the 1e-6
    /// critical value is about 57).
    #[test]
    fn henyey_greenstein_sampling_matches_its_density() {
        for g in [-0.7f32, 0.0, 0.4, 0.9] {
            let bins = 20;
            let n = 200_000u32;
            let mut counts = vec![0u32; bins];
            let mut rng = TrackingRng::new(0.25, 7);
            for _ in 0..n {
                let cos = sample_henyey_greenstein(g, rng.uniform());
                counts[(((cos + 1.0) / 2.0 * bins as f32) as usize).min(bins - 1)] += 1;
            }
            let chi2 = chi_square(&counts, n, bins, |c| henyey_greenstein(c, g));
            assert!(chi2 < 57.0, "g {g}: chi-square {chi2}");
            // The same test rejects a wrong sampler (g off by 0.05).
            let wrong = chi_square(&counts, n, bins, |c| henyey_greenstein(c, g + 0.05));
            assert!(wrong > 200.0, "g {g}: wrong density not rejected ({wrong})");
        }
    }

    fn chi_square(counts: &[u32], n: u32, bins: usize, p: impl Fn(f32) -> f32) -> f64 {
        let mut chi2 = 0.0;
        for (b, &c) in counts.iter().enumerate() {
            // Expected probability of the bin by midpoint quadrature on 1000 sub-intervals.
            let (lo, hi) = (-1.0 + 2.0 * b as f64 / bins as f64, -1.0 + 2.0 * (b + 1) as f64 / bins as f64);
            let m = 1000;
            let prob: f64 = (0..m)
                .map(|k| {
                    let c = lo + (hi - lo) * (k as f64 + 0.5) / m as f64;
                    p(c as f32) as f64 * 2.0 * std::f64::consts::PI * (hi - lo) / m as f64
                })
                .sum();
            let e = prob * n as f64;
            chi2 += (c as f64 - e).powi(2) / e;
        }
        chi2
    }

    #[test]
    fn sampled_directions_have_the_sampled_angle() {
        let wl = SampledWavelengths::new([450.0, 500.0, 550.0, 600.0], [1.0; 4]);
        let phase = PhaseFunction::HenyeyGreenstein(0.6);
        let d = Vec3::new(0.3, -0.5, 0.8).normalize();
        let s = phase.sample(d, Vec2::new(0.3, 0.7), 0.5, &wl).unwrap();
        let cos = sample_henyey_greenstein(0.6, 0.3);
        assert!((s.wi.dot(d) - cos).abs() < 1e-5);
        assert!((s.pdf - phase.pdf(d, s.wi, &wl)).abs() < 1e-4 * s.pdf);
        assert!((s.wi.length() - 1.0).abs() < 1e-5);
    }

    /// The Mie phase function of 10 µm water drops as the renderer samples it: a histogram of scattering angles in
    /// 1° bins against the mixture density (the mean of the carried wavelengths' lobes), integrated over each bin.
    /// The same counts reject the lobe of one wavelength alone, which differs from the mixture only in the ripple
    /// and the bows' positions.
    #[test]
    fn mie_sampling_follows_the_mixture_of_the_carried_wavelengths() {
        let table = Arc::new(MieSpectralTable::from_particle("water", 10.0, 0.0).unwrap());
        let phase = PhaseFunction::Mie(table);
        let d = Vec3::new(0.2, 0.9, -0.3).normalize();
        let bins = 180usize;
        let n = 400_000u32;
        let mut rng = TrackingRng::new(0.37, 11);
        for wl in [
            SampledWavelengths::new([450.0, 530.0, 610.0, 650.0], [1.0; 4]),
            SampledWavelengths::new([450.0, 530.0, 610.0, 650.0], [0.0, 0.0, 1.0, 0.0]),
        ] {
            let mut counts = vec![0u32; bins];
            let mut mismatched = 0;
            for _ in 0..n {
                let u = Vec2::new(rng.uniform(), rng.uniform());
                let s = phase.sample(d, u, rng.uniform(), &wl).unwrap();
                // What sample reports is what pdf says of the same direction, except where rounding the direction to
                // f32 carries it over one of the tables' bin edges (the density is piecewise constant).
                let pdf = phase.pdf(d, s.wi, &wl);
                if (s.pdf - pdf).abs() > 1e-4 * pdf {
                    mismatched += 1;
                }
                let theta = s.wi.dot(d).clamp(-1.0, 1.0).acos().to_degrees();
                counts[(theta as usize).min(bins - 1)] += 1;
            }
            assert!(mismatched < n / 1000, "{mismatched} samples whose pdf disagrees with the density");
            let expected = |f: &dyn Fn(Vec3) -> f32| -> Vec<f64> {
                // Each 1° bin on 400 sub-intervals (0.0025°, finer than the tables' 0.05° bins).
                (0..bins)
                    .map(|b| {
                        let m = 400;
                        (0..m)
                            .map(|k| {
                                let (t0, t1) = (
                                    ((b * m + k) as f64 / m as f64).to_radians(),
                                    ((b * m + k + 1) as f64 / m as f64).to_radians(),
                                );
                                let w = direction_about(d, (0.5 * (t0 + t1)).cos(), 0.1);
                                f(w) as f64 * 2.0 * std::f64::consts::PI * (t0.cos() - t1.cos())
                            })
                            .sum()
                    })
                    .collect()
            };
            let chi2 = |probs: &[f64]| -> f64 {
                let total: f64 = probs.iter().sum();
                assert!((total - 1.0).abs() < 2e-3, "the density integrates to {total}");
                crate::tests::support::chi_square_of_counts(&counts, probs, n, 5.0)
            };
            let right = chi2(&expected(&|w| phase.pdf(d, w, &wl)));
            // 180 bins (fewer after dropping the empty ones): the 0.999 quantile of chi-square with 179 dof is 243.
            assert!(right < 243.0, "chi-square {right} against the mixture");
            if wl.active_count() > 1 {
                let one = SampledWavelengths::new([450.0, 530.0, 610.0, 650.0], [1.0, 0.0, 0.0, 0.0]);
                let wrong = chi2(&expected(&|w| phase.pdf(d, w, &one)));
                assert!(wrong > 1000.0, "one wavelength's lobe not rejected ({wrong})");
            }
        }
    }

    #[test]
    fn grid_interpolates_between_voxel_centres_and_fades_to_zero_outside() {
        let g = DensityGrid::new([2, 1, 1], vec![1.0, 3.0]).unwrap();
        assert!((g.lookup(Vec3::new(0.25, 0.5, 0.5)) - 1.0).abs() < 1e-6);
        assert!((g.lookup(Vec3::new(0.5, 0.5, 0.5)) - 2.0).abs() < 1e-6);
        assert!((g.lookup(Vec3::new(0.75, 0.5, 0.5)) - 3.0).abs() < 1e-6);
        assert!((g.lookup(Vec3::new(1.0, 0.5, 0.5)) - 1.5).abs() < 1e-6);
        assert!(DensityGrid::new([2, 2, 1], vec![1.0, 3.0]).is_none());
        assert!(DensityGrid::new([2, 1, 1], vec![1.0, -3.0]).is_none());
        assert!(DensityGrid::new([2, 1, 1], vec![1.0, f32::NAN]).is_none());
    }

    /// Delta tracking in a homogeneous medium: the fraction of rays that collide before distance L is
    /// 1 − exp(−σ L), with the number of collisions per unit length equal to σ.
    #[test]
    fn collisions_follow_the_exponential_distribution() {
        let wl = SampledWavelengths::new([450.0, 500.0, 550.0, 600.0], [1.0; 4]);
        let m = Medium::Homogeneous(HomogeneousMedium {
            sigma_a: Spectrum::Constant(0.5).into(),
            sigma_s: Spectrum::Constant(1.0).into(),
            le: None,
            phase: PhaseFunction::HenyeyGreenstein(0.0),
        });
        let n = 100_000;
        let mut hit = 0;
        for i in 0..n {
            let mut rng = TrackingRng::new(i as f32 / n as f32, i);
            let mut first = true;
            let tr = sample_t_maj(&m, Vec3::ZERO, Vec3::X, 0.8, &mut rng, &wl, 0, |_, _, _, _, _| {
                first = false;
                false
            });
            if !first {
                hit += 1;
            } else {
                assert!((tr[0] - (-1.5f32 * 0.8).exp()).abs() < 1e-5);
            }
        }
        let expected = 1.0 - (-1.5f64 * 0.8).exp();
        let p = hit as f64 / n as f64;
        let sigma = (expected * (1.0 - expected) / n as f64).sqrt();
        assert!((p - expected).abs() < 5.0 * sigma, "{p} vs {expected}");
    }
}

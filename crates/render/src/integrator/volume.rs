//! Light transport through media that scatter, shared by the integrators that render them (`volpath`, `lightpath`,
//! `bdpt`, `sppm`): one-sample MIS over the carried wavelengths (spectral MIS: the hero wavelength whose densities
//! sample distances, and the rescaled path probabilities every contribution is divided by the mean of), the
//! weighing of delta-tracking decisions, shadow rays through media (closed form in homogeneous media, ratio
//! tracking in grids) and next-event estimation through them (pbrt-v4 §14.2.3; Miller, Georgiev & Jarosz 2019;
//! Wilkie et al. 2014).

use glam::Vec3;
use spectral::{SampledSpectrum, SampledWavelengths, N_WAVELENGTHS};

use super::transport::{
    next_medium, BounceSamples, DirectLight, ShadowRay, ShadowTarget, SurfaceVertex, Tracer, MAX_SHADOW_CROSSINGS,
};
use crate::bxdf::TransportMode;
use crate::light::LightSampleContext;
use crate::medium::{sample_t_maj, PhaseFunction, TrackingRng};
use crate::scene::NO_MATERIAL;

/// What seeds a shadow ray's tracking decisions: a per-purpose salt and a uniform number of the path's sampler.
#[derive(Clone, Copy, Debug)]
pub(crate) struct TrackingSeed {
    /// Tells apart the shadow rays of one path (its light, its depth, its strategy).
    pub salt: u32,
    /// A uniform number drawn for the connection.
    pub u: f32,
}

/// The wavelengths that share one path in spectral MIS: which slots take part, and the hero slot whose densities
/// sample distances and collision types. Each path picks its hero uniformly among the active slots, which makes
/// the one-sample MIS estimator f(λᵢ) / mean_h p(λ_h) unbiased for every wavelength strategy (for `hero` any slot
/// would do; the bands of `rgb` are not interchangeable). After a dispersive event leaves one wavelength, the rest
/// of the path is sampled at that wavelength whichever slot would have been the hero, so its probability ratios
/// change by the same factor for every slot (`ratio` broadcasts).
#[derive(Clone, Copy, Debug)]
pub(crate) struct SpectralMis {
    /// Slots active when the path started.
    active: [bool; N_WAVELENGTHS],
    count: f32,
    /// The slot whose densities sample distances and collision types.
    pub hero: usize,
    chosen: bool,
    reduced: bool,
}

impl SpectralMis {
    pub fn new(wl: &SampledWavelengths) -> Self {
        let active = std::array::from_fn(|i| wl.is_active(i));
        let count = active.iter().filter(|&&a| a).count().max(1) as f32;
        let first = active.iter().position(|&a| a).unwrap_or(0);
        Self { active, count, hero: first, chosen: wl.is_single(), reduced: wl.is_single() }
    }

    /// Chooses the hero with `u` (once per path, at its first medium).
    pub fn choose(&mut self, u: f32) {
        if self.chosen {
            return;
        }
        let pick = ((u * self.count) as usize).min(self.count as usize - 1);
        self.hero = (0..N_WAVELENGTHS).filter(|&i| self.active[i]).nth(pick).unwrap_or(self.hero);
        self.chosen = true;
    }

    /// Notes a dispersive event that left one wavelength.
    pub fn update(&mut self, wl: &SampledWavelengths) {
        if !self.reduced && wl.is_single() {
            self.reduced = true;
            self.chosen = true;
            self.hero = (0..N_WAVELENGTHS).find(|&i| wl.is_active(i)).unwrap_or(self.hero);
        }
    }

    /// The factor a probability ratio changes by at each slot.
    #[inline]
    pub fn ratio(&self, v: SampledSpectrum) -> SampledSpectrum {
        if self.reduced {
            SampledSpectrum::splat(v[self.hero])
        } else {
            v
        }
    }

    /// The mean of `r` over the slots that take part: the balance heuristic's denominator.
    #[inline]
    pub fn average(&self, r: SampledSpectrum) -> f32 {
        let mut s = 0.0;
        for i in 0..N_WAVELENGTHS {
            if self.active[i] {
                s += r[i];
            }
        }
        s / self.count
    }
}

/// Weighs a delta-tracking decision sampled with density T_maj·σ at the hero wavelength (σ = σs for a real
/// scattering, σn for a null collision, 1 for crossing the rest of the segment; pbrt-v4 §14.1.3): the throughput
/// `beta` is multiplied by T_maj·σ/pdf and the rescaled probabilities `r` by the same factor per slot. Returns
/// false, changing nothing, if the decision had probability zero at the hero.
#[inline]
pub(crate) fn weigh_tracking(
    beta: &mut SampledSpectrum,
    r: &mut SampledSpectrum,
    mis: &SpectralMis,
    t_maj: SampledSpectrum,
    sigma: SampledSpectrum,
) -> bool {
    let pdf = t_maj[mis.hero] * sigma[mis.hero];
    if pdf.is_nan() || pdf <= 0.0 {
        return false;
    }
    let w = t_maj * sigma / pdf;
    *beta *= w;
    *r *= mis.ratio(w);
    true
}

/// What a shadow ray carries back: the transmittance estimate and the rescaled probabilities of its tracking
/// decisions, for the light-sampling (`r_l`) and the unidirectional (`r_u`) strategies of spectral MIS.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ShadowTransmittance {
    /// Transmittance estimate at each wavelength.
    pub t: SampledSpectrum,
    /// Rescaled probability of the ratio-tracking decisions (null collisions sampled with T_maj·σ_maj).
    pub r_l: SampledSpectrum,
    /// Rescaled probability of the same collisions as a path would sample them (T_maj·σ_n).
    pub r_u: SampledSpectrum,
}

/// Traces shadow ray `ray` through material-less boundaries: `None` if a surface with a material blocks it; otherwise the transmittance: Beer–Lambert in closed form for homogeneous media
/// and ratio tracking against the majorant for heterogeneous ones (pbrt-v4 §14.2.3, with its Russian roulette once the
/// estimate falls below 0.05). `seed` seeds the tracking decisions.
pub(crate) fn shadow_transmittance(
    tracer: &mut Tracer,
    ray: ShadowRay,
    wl: &SampledWavelengths,
    mis: &SpectralMis,
    seed: TrackingSeed,
) -> Option<ShadowTransmittance> {
    let scene = tracer.scene;
    let ShadowRay { mut origin, target, mut medium, time } = ray;
    let ones = SampledSpectrum::splat(1.0);
    let mut out = ShadowTransmittance { t: ones, r_l: ones, r_u: ones };
    if scene.media.is_empty() {
        let (d, t_max) = target.segment_from(origin);
        return (!tracer.occluded(origin, d, t_max, time)).then_some(out);
    }
    let mut rng = TrackingRng::new(seed.u, seed.salt);
    let mut crossings = 0;
    loop {
        let (d, t_max) = target.segment_from(origin);
        if t_max.is_nan() || t_max <= 0.0 {
            return Some(out);
        }
        let hit = tracer.shadow_hit(origin, d, t_max, time);
        if hit.is_some_and(|h| h.material != NO_MATERIAL) {
            return None;
        }
        if let Some(m) = medium {
            let seg_end = hit.map_or(t_max, |h| h.t);
            let med = &scene.media[m as usize];
            if med.is_absorbing_only() {
                out.t *= med.absorption_transmittance(seg_end, wl);
            } else if med.has_closed_form_transmittance() {
                // exp(−σt·d) exactly, where ratio tracking against σ_maj = σt would return 0 or 1 (a track-length
                // estimate). No tracking decisions: r_l keeps its value; the unidirectional strategy would have had
                // to cross without a collision, with probability T, at each hero wavelength.
                let tr = med.homogeneous_transmittance(seg_end, wl);
                out.t *= tr;
                out.r_u *= mis.ratio(tr);
            } else {
                let h = mis.hero;
                let (mut t_ray, mut r_l, mut r_u) = (out.t, out.r_l, out.r_u);
                let t_maj = sample_t_maj(med, origin, d, seg_end, &mut rng, wl, h, |_, mp, sigma_maj, t_maj, rng| {
                    // Ratio tracking: every tentative collision is a null one.
                    let sigma_n = mp.sigma_n(sigma_maj);
                    let pdf = t_maj[h] * sigma_maj[h];
                    t_ray *= t_maj * sigma_n / pdf;
                    r_l *= mis.ratio(t_maj * sigma_maj / pdf);
                    r_u *= mis.ratio(t_maj * sigma_n / pdf);
                    // Russian roulette once the estimate is small.
                    let tr = t_ray / mis.average(r_l + r_u);
                    if tr.max_value() < 0.05 {
                        if rng.uniform() < 0.75 {
                            t_ray = SampledSpectrum::zero();
                        } else {
                            t_ray *= 4.0;
                        }
                    }
                    !t_ray.is_black()
                });
                if t_maj[h] <= 0.0 {
                    return None;
                }
                out.t = t_ray * t_maj / t_maj[h];
                out.r_l = r_l * mis.ratio(t_maj / t_maj[h]);
                out.r_u = r_u * mis.ratio(t_maj / t_maj[h]);
            }
        }
        if out.t.is_black() || !out.t.0.iter().all(|x| x.is_finite()) {
            return None;
        }
        let Some(h) = hit else { return Some(out) };
        crossings += 1;
        if crossings > MAX_SHADOW_CROSSINGS {
            return None;
        }
        medium = next_medium(&h, d, medium);
        origin = h.spawn_origin(d);
    }
}

/// Where the path scattered last, for the light-selection and MIS densities of the emitter it finds next.
#[derive(Clone, Copy, Debug)]
pub(crate) enum ScatterVertex<'a> {
    /// A surface with its BxDF in its shading frame, reached through `medium`.
    Surface(SurfaceVertex<'a>),
    /// A point in a medium, reached travelling along `d_in` at `time`, whose scattering directions are drawn with
    /// the share `sun_guide` towards the sun ([`sample_medium_direction`]).
    Medium { p: Vec3, d_in: Vec3, phase: &'a PhaseFunction, medium: Option<u32>, time: f32, sun_guide: f32 },
}

/// Draws a scattering direction at a medium vertex of a path travelling along `d_in`: by the phase function, or in
/// a Mie medium of a scene with a sun and `alpha` > 0, by the one-sample mixture of the phase function (weight
/// 1 − `alpha`) and the same phase function centred on the sun (weight `alpha`; Veach 1997, §9.2.4: the density is
/// the mixture's, the value the phase function's).
///
/// Why: large drops scatter hundreds of times more within a few degrees of forward than sideways or back, so a
/// path that turns towards the sun (unlikely by the phase function) sees the sun at its next event through that
/// forward lobe; such rare paths are the bright grains of multiply scattered light. The phase function centred on
/// the sun has the shape of that next event's light.
pub(crate) fn sample_medium_direction(
    scene: &crate::scene::RenderScene,
    phase: &PhaseFunction,
    d_in: Vec3,
    u_dir: glam::Vec2,
    u_lobe: f32,
    wl: &SampledWavelengths,
    alpha: f32,
) -> Option<crate::medium::PhaseSample> {
    let Some(sun) = guide_axis(scene, phase, alpha) else {
        return phase.sample(d_in, u_dir, u_lobe, wl);
    };
    let (axis, u_pick) = if u_lobe < alpha {
        (sun, u_lobe / alpha)
    } else {
        (d_in, ((u_lobe - alpha) / (1.0 - alpha)).min(1.0 - f32::EPSILON))
    };
    let wi = phase.sample(axis, u_dir, u_pick, wl)?.wi;
    // Both densities at the direction as stored (f32), exactly as `medium_direction_pdf` will find them when light
    // sampling weighs this strategy; the phase function's own density comes from its values, not a second lookup.
    let p = phase.p(d_in, wi, wl);
    let pdf = (1.0 - alpha) * phase.pdf_of_values(&p, wl) + alpha * phase.pdf(sun, wi, wl);
    (pdf > 0.0 && pdf.is_finite()).then_some(crate::medium::PhaseSample { wi, p, pdf })
}

/// The sun to guide towards at a vertex with `phase` and guide share `alpha`: only Mie drops' lobes are guided.
fn guide_axis(scene: &crate::scene::RenderScene, phase: &PhaseFunction, alpha: f32) -> Option<Vec3> {
    let guided = match phase {
        PhaseFunction::Mie(_) => alpha > 0.0,
        PhaseFunction::HenyeyGreenstein(_) => false,
    };
    if guided {
        scene.sun()
    } else {
        None
    }
}

/// The density [`sample_medium_direction`] draws `wi` with.
pub(crate) fn medium_direction_pdf(
    scene: &crate::scene::RenderScene,
    phase: &PhaseFunction,
    d_in: Vec3,
    wi: Vec3,
    wl: &SampledWavelengths,
    alpha: f32,
) -> f32 {
    match guide_axis(scene, phase, alpha) {
        Some(sun) => (1.0 - alpha) * phase.pdf_of_values(&phase.p(d_in, wi, wl), wl) + alpha * phase.pdf(sun, wi, wl),
        None => phase.pdf(d_in, wi, wl),
    }
}

/// The rescaled probabilities of a path up to a scattering vertex by the two strategies that finish it at a light:
/// unidirectional sampling (`r_u`, the prefix as the path sampled it, then BSDF or phase sampling) and light
/// sampling (`r_l`, the prefix as next-event estimation takes it, then the light's density). They differ where
/// next-event estimation places its vertex by another density than the path's ([`ForcedCollision`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct PrefixRatios {
    pub r_u: SampledSpectrum,
    pub r_l: SampledSpectrum,
}

impl PrefixRatios {
    /// Both strategies share the prefix the path sampled.
    #[inline]
    pub fn shared(r_u: SampledSpectrum) -> Self {
        Self { r_u, r_l: r_u }
    }
}

/// A scattering vertex placed for next-event estimation on every segment of a path through a homogeneous medium,
/// whether or not the path collides there: the forced collision of neutron transport (Lux & Koblinger 1991,
/// "Monte Carlo Particle Transport Methods"), with density f(t) = σt·e^(−σt·t) / (1 − e^(−σt·L)) on [0, L) at
/// the hero.
///
/// Why: delta tracking collides on a segment of optical depth τ only with probability 1 − e^(−τ), and its
/// next-event estimate is all or nothing on that draw; on the rain of `scenes/rainbow.pbrt` (τ near 1) that
/// Bernoulli draw is most of the noise of each scattering order. The path itself still collides (or not) by
/// delta tracking; only its light-sampling vertex moves here, so at the path's own collision light sampling is
/// weighed with this density ([`ForcedCollision::light_ratio_at_collision`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct ForcedCollision {
    /// Where on the segment.
    pub p: Vec3,
    /// The throughput factor T(t)·σs / f_hero(t).
    pub beta: SampledSpectrum,
    /// The prefix ratios at the vertex: the path's collision density T·σs (unidirectional) and f (light sampling),
    /// each over f at the hero, to multiply the path's r_u with.
    pub ratios: PrefixRatios,
    /// σt / (1 − e^(−σt·L)): f(t) / T(t) at each wavelength.
    f_over_t: SampledSpectrum,
}

impl ForcedCollision {
    /// Draws the vertex on the segment `o + t·d`, 0 ≤ t < `t_end` (infinite for a ray that leaves the scene) of a
    /// homogeneous medium with coefficients `sigma_a`, `sigma_s`, with `u`. None where the medium does not scatter
    /// at the hero.
    pub fn sample(
        o: Vec3,
        d: Vec3,
        t_end: f32,
        sigma_a: SampledSpectrum,
        sigma_s: SampledSpectrum,
        mis: &SpectralMis,
        u: f32,
    ) -> Option<Self> {
        let h = mis.hero;
        let sigma_t = sigma_a + sigma_s;
        if !(sigma_t[h] > 0.0 && sigma_s[h] > 0.0) {
            return None;
        }
        // 1 − e^(−σt·L) without cancellation for thin segments; 1 for an infinite one.
        let collide = sigma_t.map(|s| if s > 0.0 { -(-s * t_end.min(f32::MAX)).exp_m1() } else { 0.0 });
        if collide[h].is_nan() || collide[h] <= 0.0 {
            return None;
        }
        // Inverse of the truncated exponential's distribution function.
        let t = -(-u * collide[h]).ln_1p() / sigma_t[h];
        if !(t.is_finite() && t < t_end) {
            return None;
        }
        let tr = sigma_t.map(|s| (-s * t).exp());
        let f_over_t =
            SampledSpectrum(std::array::from_fn(|i| if collide[i] > 0.0 { sigma_t[i] / collide[i] } else { 0.0 }));
        let f_h = f_over_t[h] * tr[h];
        let beta = tr * sigma_s / f_h;
        let ratios = PrefixRatios { r_u: mis.ratio(beta), r_l: mis.ratio(f_over_t * tr / f_h) };
        Some(Self { p: o + d * t, beta, ratios, f_over_t })
    }

    /// The factor that turns the path's r_u before its own collision on this segment (transmittance `t_maj` to
    /// it, scattering coefficient `sigma_s`, hero `h`) into the light-sampling strategy's r_l there: f / (T·σs at
    /// the hero).
    pub fn light_ratio_at_collision(
        &self,
        t_maj: SampledSpectrum,
        sigma_s: SampledSpectrum,
        mis: &SpectralMis,
    ) -> SampledSpectrum {
        let h = mis.hero;
        mis.ratio(self.f_over_t * t_maj / (t_maj[h] * sigma_s[h]))
    }
}

/// Next-event estimation at `v`: a light and a point on it, transmittance through media (closed form in
/// homogeneous ones, ratio tracking in grids) and material-less boundaries, weighted against BSDF or phase sampling
/// by the balance heuristic over all wavelengths (`r_p` the path's prefix ratios, `mis` its spectral MIS), or by spectral
/// MIS alone for [`DirectLight::LightSamplingOnly`] (integrators that find the rest of the light otherwise, as
/// photon mapping does). Draws the light sample from `u`.
pub(crate) fn sample_ld(
    tracer: &mut Tracer,
    v: ScatterVertex,
    wl: &SampledWavelengths,
    u: &BounceSamples,
    mis: &SpectralMis,
    r_p: PrefixRatios,
    weighting: DirectLight,
) -> SampledSpectrum {
    let scene = tracer.scene;
    let [u_light, u0, u1] = u.connect;
    let Some((li, p_sel)) = scene.sample_light(u_light) else { return SampledSpectrum::zero() };
    let light = &scene.lights[li as usize];
    let ctx = match v {
        ScatterVertex::Surface(SurfaceVertex { hit, .. }) => LightSampleContext { p: hit.p },
        ScatterVertex::Medium { p, .. } => LightSampleContext { p },
    };
    let Some(ls) = light.sample_li(&ctx, glam::Vec2::new(u0, u1), wl) else { return SampledSpectrum::zero() };
    if ls.pdf <= 0.0 || ls.l.is_black() {
        return SampledSpectrum::zero();
    }
    let p_l = p_sel * ls.pdf;
    let time = match v {
        ScatterVertex::Surface(SurfaceVertex { hit, .. }) => hit.time,
        ScatterVertex::Medium { time, .. } => time,
    };
    let (f_hat, scatter_pdf, origin, medium) = match v {
        ScatterVertex::Surface(SurfaceVertex { hit, frame, bxdf, wo, medium }) => {
            let wi = frame.to_local(ls.wi);
            let (f, pdf) = bxdf.f_pdf(wo, wi, TransportMode::Radiance);
            let f = f * wi.z.abs();
            // The shadow ray leaves into the medium on the light's side (the arrival medium without an
            // interface).
            (f, pdf, hit.spawn_origin(ls.wi), next_medium(hit, ls.wi, medium))
        }
        ScatterVertex::Medium { p, d_in, phase, medium, sun_guide, .. } => {
            (phase.p(d_in, ls.wi, wl), medium_direction_pdf(scene, phase, d_in, ls.wi, wl, sun_guide), p, medium)
        }
    };
    if f_hat.is_black() {
        return SampledSpectrum::zero();
    }
    let target = if ls.dist.is_finite() { ShadowTarget::Point(ls.p) } else { ShadowTarget::Direction(ls.wi) };
    let ray = ShadowRay { origin, target, medium, time };
    let Some(tr) = shadow_transmittance(tracer, ray, wl, mis, TrackingSeed { salt: li ^ 0x5eed, u: u0 }) else {
        return SampledSpectrum::zero();
    };
    let (t_ray, r_l, r_u) = (tr.t, tr.r_l, tr.r_u);
    let r_l = r_l * r_p.r_l * p_l;
    let r_u = r_u * r_p.r_u * scatter_pdf;
    if ls.delta || weighting == DirectLight::LightSamplingOnly {
        f_hat * t_ray * ls.l / mis.average(r_l)
    } else {
        f_hat * t_ray * ls.l / mis.average(r_l + r_u)
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use glam::{Vec2, Vec3};
    use spectral::SampledWavelengths;

    use super::{medium_direction_pdf, sample_medium_direction, ForcedCollision, SpectralMis};
    use crate::medium::TrackingRng;
    use crate::tests::support::chi_square_of_counts;
    use crate::{build_scene, BuildOptions};
    use spectral::SampledSpectrum;

    /// Directions drawn with the sun guide: the density reported is the mixture's at the direction drawn, the value
    /// the phase function's, and a histogram of their angle to the sun follows the mixture (χ² in 2° bins about the
    /// sun, from 120,000 draws), while the phase function's own density does not. The path travels away from the
    /// sun, so that both parts of the mixture are symmetric about the same axis and their ring integrals exact.
    #[test]
    fn sun_guided_directions_follow_the_mixture_they_report() {
        let text = r#"LookAt 0 0 0  0 0 1  0 1 0
Camera "perspective"
Film "rgb" "integer xresolution" 4 "integer yresolution" 4 "string filename" "x.exr"
WorldBegin
LightSource "distant" "point3 from" [ 0 1 -1 ] "point3 to" [ 0 0 0 ] "blackbody L" 5778
MakeNamedMedium "rain" "string type" "mie" "string particle" "water" "float radius" 20 "float density" 1e6
    "float forwardcutoff" 2
MediumInterface "rain" ""
Material "interface"
Shape "sphere" "float radius" 10
"#;
        let desc = pbrt::parse_str(text, Path::new("guide.pbrt")).unwrap();
        let built = build_scene(&desc, &BuildOptions::default()).unwrap();
        let scene = &built.scene;
        let sun = scene.sun().expect("a sun in a scene with Mie drops");
        assert!((sun - Vec3::new(0.0, 1.0, -1.0).normalize()).length() < 1e-6);
        let phase = scene.media[0].phase();
        let wl = SampledWavelengths::new([450.0, 530.0, 610.0, 690.0], [1.0; 4]);
        let d_in = -sun;
        let alpha = 0.4;
        let (bins, n) = (90usize, 120_000u32);
        let mut counts = vec![0u32; bins];
        let mut rng = TrackingRng::new(0.81, 3);
        for _ in 0..n {
            let u = Vec2::new(rng.uniform(), rng.uniform());
            let s = sample_medium_direction(scene, phase, d_in, u, rng.uniform(), &wl, alpha).unwrap();
            let pdf = medium_direction_pdf(scene, phase, d_in, s.wi, &wl, alpha);
            assert!((s.pdf - pdf).abs() <= 1e-3 * pdf, "reported {} against {pdf}", s.pdf);
            let p = phase.p(d_in, s.wi, &wl);
            assert!((0..4).all(|i| (s.p[i] - p[i]).abs() <= 1e-6 * p[i].max(1e-30)));
            let theta = s.wi.dot(sun).clamp(-1.0, 1.0).acos().to_degrees();
            counts[((theta / 2.0) as usize).min(bins - 1)] += 1;
        }
        // Expected counts: each density integrated over each 2° ring about the sun (200 rings of 0.01°, along one
        // azimuth: both densities are symmetric about the sun's axis).
        let expected = |f: &dyn Fn(Vec3) -> f32| -> Vec<f64> {
            let frame = crate::sampling::Frame::from_z(sun);
            (0..bins)
                .map(|b| {
                    (0..200)
                        .map(|k| {
                            let t0 = (2.0 * b as f64 + k as f64 * 0.01).to_radians();
                            let t1 = (2.0 * b as f64 + (k + 1) as f64 * 0.01).to_radians();
                            let t = 0.5 * (t0 + t1);
                            let w = frame.from_local(Vec3::new(t.sin() as f32, 0.0, t.cos() as f32)).normalize();
                            f(w) as f64 * 2.0 * std::f64::consts::PI * (t0.cos() - t1.cos())
                        })
                        .sum()
                })
                .collect()
        };
        let chi2 = |probs: &[f64]| chi_square_of_counts(&counts, probs, n, 20.0);
        let mixture = expected(&|w| medium_direction_pdf(scene, phase, d_in, w, &wl, alpha));
        let plain = expected(&|w| phase.pdf(d_in, w, &wl));
        let total: f64 = mixture.iter().sum();
        assert!((total - 1.0).abs() < 0.02, "the mixture integrates to {total}");
        let (right, wrong) = (chi2(&mixture), chi2(&plain));
        // 90 bins: χ² of a right density stays below ~150 (mean 89, sd 13, plus the quadrature's error).
        assert!(right < 150.0, "χ² against the mixture {right}");
        assert!(wrong > 1000.0, "χ² against the phase function alone {wrong}");
    }
    /// The forced collision's throughput factor T(t)·σs/f(t) averages to the probability of scattering on the
    /// segment, σs/σt·(1 − e^(−σt·L)), at every wavelength of a chromatic medium, on a short and an infinite
    /// segment (10⁵ stratified draws, 0.3 %); its density ratios are f and T·σs over the hero's f, and at a
    /// collision the light strategy's ratio is f/(T·σs) at the hero.
    #[test]
    fn forced_collisions_average_to_the_scattering_probability() {
        let sigma_a = SampledSpectrum([0.1, 0.0, 0.4, 0.2]);
        let sigma_s = SampledSpectrum([0.5, 1.2, 0.3, 2.0]);
        let wl = SampledWavelengths::new([450.0, 530.0, 610.0, 690.0], [1.0; 4]);
        let mut mis = SpectralMis::new(&wl);
        mis.choose(0.6);
        let h = mis.hero;
        let (o, d) = (Vec3::ZERO, Vec3::Z);
        for t_end in [0.7f32, f32::INFINITY] {
            let n = 100_000;
            let mut sum = [0.0f64; 4];
            for k in 0..n {
                let u = (k as f32 + 0.5) / n as f32;
                let fc = ForcedCollision::sample(o, d, t_end, sigma_a, sigma_s, &mis, u).unwrap();
                let t = fc.p.z;
                assert!((0.0..t_end).contains(&t), "{t} outside [0, {t_end})");
                let st = sigma_a + sigma_s;
                let tr = st.map(|s| (-s * t).exp());
                let f = st.map(|s| s * (-s * t).exp() / -(-s * t_end.min(f32::MAX)).exp_m1());
                for i in 0..4 {
                    sum[i] += f64::from(fc.beta[i]);
                    let close = |a: f32, b: f32| (a - b).abs() <= 1e-4 * b.abs().max(1e-12);
                    assert!(close(fc.ratios.r_l[i], f[i] / f[h]), "r_l[{i}] {} at t = {t}", fc.ratios.r_l[i]);
                    assert!(close(fc.ratios.r_u[i], tr[i] * sigma_s[i] / f[h]), "r_u[{i}] at t = {t}");
                }
                let at_collision = fc.light_ratio_at_collision(tr, sigma_s, &mis);
                for i in 0..4 {
                    let want = f[i] / (tr[h] * sigma_s[h]);
                    assert!((at_collision[i] - want).abs() <= 1e-4 * want, "collision ratio [{i}] at t = {t}");
                }
            }
            for i in 0..4 {
                let st = f64::from(sigma_a[i] + sigma_s[i]);
                let want = f64::from(sigma_s[i]) / st * -(-st * f64::from(t_end)).exp_m1();
                let got = sum[i] / n as f64;
                assert!((got - want).abs() <= 3e-3 * want, "L = {t_end}, slot {i}: {got} against {want}");
            }
        }
    }
}

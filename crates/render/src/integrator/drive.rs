//! The road from camera sample to film, shared by every integrator: building a camera sample, the parallel loop
//! over pixels that writes camera samples into the film's rows, and the batched loop of integrators that also
//! splat light-path contributions.
//!
//! Determinism: every random number comes from a [`Sampler`] seeded by (pixel, sample index, seed and a
//! per-purpose salt); camera samples of one pixel are written by one thread, and splats are added in a fixed order,
//! so an image does not depend on the number of threads.

use std::ops::Range;
use std::time::Duration;

use film::{Film, FilmError, FilmRow, FilterSampler, GBufferCoordinates, Splat, VisibleSurface};
use glam::{DVec3, Vec2, Vec3};
use rayon::prelude::*;
use spectral::{SampledSpectrum, SampledWavelengths, WavelengthSampler};

use super::transport::{begin_bounce, Bounce, BounceSamples, PathRay, Tracer};
use super::RenderJob;
use crate::bxdf::Bxdf;
use crate::camera::{CameraRay, CameraRays};
use crate::sampler::{hash_words, Sampler};
use crate::sampling::Frame;
use crate::scene::{RenderScene, SurfaceHit};

/// Totals of a render pass.
#[derive(Clone, Copy, Debug, Default)]
pub struct RenderStats {
    /// Pixel samples taken (for photon mapping: pixels × iterations).
    pub samples: u64,
    /// Rays traced (closest hit and shadow).
    pub rays: u64,
}

/// The sizes of the passes of an interactive render (one that answers a signal, a progress report or a live view
/// between passes): doubling from one while a pass takes under a quarter of a second, halved past a second; in a
/// render with a time budget, also kept well inside the time left. A pixel's samples are added in the same order
/// whatever the passes, so the sizes never change the image.
#[derive(Clone, Copy, Debug)]
pub struct PassSizes {
    next: u32,
}

impl Default for PassSizes {
    fn default() -> Self {
        Self { next: 1 }
    }
}

impl PassSizes {
    /// The size of the next pass, at most `remaining`.
    pub fn next(&self, remaining: u32) -> u32 {
        self.next.min(remaining)
    }

    /// Notes that the last pass took `took`.
    pub fn took(&mut self, took: Duration) {
        self.took_leaving(took, Duration::MAX);
    }

    /// Notes that the last pass took `took` and that `left` remains of the render's time budget: the next pass
    /// doubles only if this one took under a quarter of both a second and the time left, and halves if it took
    /// more than a second or than the time left.
    pub fn took_leaving(&mut self, took: Duration, left: Duration) {
        if took < Duration::from_millis(250) && took < left / 4 {
            self.next = self.next.saturating_mul(2);
        } else if (took > Duration::from_millis(1000) || took > left) && self.next > 1 {
            self.next /= 2;
        }
    }
}

/// Salt that makes a light path's random numbers independent of its pixel sample's camera ray.
pub(crate) const LIGHT_PATH_SEED_SALT: u32 = 0x6c69_6768;

/// What the camera ray hit first, for AOVs and the geometry buffer (pbrt-v4's `VisibleSurface`, in world space).
#[derive(Clone, Copy, Debug)]
pub(crate) struct FirstHit {
    /// Albedo hint of the surface's BxDF at the path's wavelengths.
    pub albedo: SampledSpectrum,
    /// World-space shading normal.
    pub normal: Vec3,
    /// World-space point.
    pub p: Vec3,
    /// World-space geometric normal.
    pub ng: Vec3,
    /// Surface (u, v).
    pub uv: Vec2,
}

impl FirstHit {
    /// The first hit `hit`, scattering with `bxdf`.
    pub(crate) fn at(hit: &SurfaceHit, bxdf: &Bxdf) -> Self {
        FirstHit { albedo: bxdf.albedo_hint(), normal: hit.ns, p: hit.p, ng: hit.n, uv: hit.uv }
    }
}

/// A camera-side estimator of radiance: what `CameraPaths` traces into each pixel.
pub(crate) trait Radiance: Copy + Send + Sync {
    /// Radiance arriving at the camera along `ray`, at the wavelengths of `wl` (which a dispersive surface may reduce
    /// to one); `first_hit` hears the first surface the path scatters at, for AOVs.
    fn li(
        &self,
        tracer: &mut Tracer,
        ray: &CameraRay,
        wl: &mut SampledWavelengths,
        sampler: &mut Sampler,
        first_hit: Option<&mut Option<FirstHit>>,
    ) -> SampledSpectrum;

    /// Whether a dispersive event splits the path into one branch per wavelength (else one wavelength is kept at
    /// random): Prismatic's `"bool splitdispersion"`, which a dispersive camera lens follows as glass does.
    fn splits_dispersion(&self) -> bool;
}

/// How far a camera path has come: its scattering events so far and the most it may make (pbrt-v4's `maxdepth`).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Depth {
    /// Scattering events so far.
    pub events: u32,
    /// The most the path may make.
    pub max: u32,
}

impl Depth {
    /// A path that has not scattered yet and may scatter `max` times.
    pub fn new(max: u32) -> Self {
        Self { events: 0, max }
    }

    /// Counts one more scattering event; false (and nothing counted) if the path has made all it may.
    #[inline]
    pub fn count(&mut self) -> bool {
        if self.events >= self.max {
            return false;
        }
        self.events += 1;
        true
    }
}

/// What the start of a bounce at a camera path's surface found.
pub(crate) enum CameraBounce {
    /// A material-less boundary: the ray was carried through it; trace on (this is not a scattering event).
    PassedThrough,
    /// The path ends here (it crossed too many boundaries in a row, the surface absorbs everything, or the path
    /// has made all its scattering events).
    End,
    /// A scattering event, counted: the BxDF at the path's wavelengths, the bounce's random numbers and the
    /// shading frame.
    Scatter(Bxdf, BounceSamples, Frame),
}

/// The start of a bounce at the surface `hit` of a camera path, the same for every integrator that traces camera
/// paths: [`begin_bounce`] (random numbers, material, boundaries), then the record of the first surface the path
/// scatters at for the film's AOVs (into `first_hit`, at depth 0), then the depth limit. Always inlined, as
/// [`begin_bounce`] is (BENCHMARKS.md, "The integrators on shared ground").
#[inline(always)]
pub(crate) fn begin_camera_bounce(
    scene: &RenderScene,
    hit: &mut SurfaceHit,
    ray: &mut PathRay,
    wl: &mut SampledWavelengths,
    sampler: &mut Sampler,
    depth: &mut Depth,
    first_hit: &mut Option<&mut Option<FirstHit>>,
) -> CameraBounce {
    let (bxdf, u) = match begin_bounce(scene, hit, ray, wl, sampler) {
        Bounce::PassedThrough => return CameraBounce::PassedThrough,
        Bounce::Stop | Bounce::Absorb => return CameraBounce::End,
        Bounce::Scatter(bxdf, u) => (bxdf, u),
    };
    if depth.events == 0 {
        if let Some(fh) = first_hit.take() {
            *fh = Some(FirstHit::at(hit, &bxdf));
        }
    }
    if !depth.count() {
        return CameraBounce::End;
    }
    CameraBounce::Scatter(bxdf, u, Frame::from_z_and_tangent(hit.ns, hit.dpdu))
}

/// One camera sample: the path's wavelengths, the film position and filter weight, and the camera rays.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CameraSample {
    /// Wavelengths the path starts with.
    pub wl: SampledWavelengths,
    /// Filter weight f/pdf of the sampled film offset.
    pub weight: f32,
    /// The rays leaving the lens: one for every wavelength, or one per wavelength through a dispersive lens.
    pub rays: CameraRays,
    /// The film position the rays were generated for (raster pixels, y down).
    pub film: Vec2,
    /// The lens sample the rays were generated with.
    pub lens: Vec2,
    /// The time the rays are traced at.
    pub time: f32,
}

impl CameraSample {
    /// The ray every wavelength follows; `None` if the lens stopped it or gives each wavelength its own (the
    /// integrators that connect to the camera refuse such lenses).
    pub fn shared_ray(&self) -> Option<&CameraRay> {
        match &self.rays {
            CameraRays::Shared(r) => r.as_ref(),
            CameraRays::Filtered(..) | CameraRays::PerWavelength(_) => None,
        }
    }

    /// The first of the sample's rays that left the lens: what the first-hit records describe.
    pub fn first_ray(&self) -> Option<&CameraRay> {
        match &self.rays {
            CameraRays::Shared(r) | CameraRays::Filtered(r, _) => r.as_ref(),
            CameraRays::PerWavelength(rays) => rays.iter().flatten().next(),
        }
    }
}

/// The radiance camera sample `cs` brings to the film through `integrator`, times each ray's camera weight, and the
/// wavelengths it is at. Through a dispersive lens the path splits at the lens, as at a dispersive refraction: each
/// wavelength follows its own ray as a branch of its own (at its full density: every wavelength has a branch, none
/// is selected), so no wavelength is dropped; `first_hit` hears the first branch's first surface. (For an
/// integrator that does not split, `"bool splitdispersion" false`, the camera sampler keeps one wavelength and its
/// ray instead: [`CameraSampler::keeping_one_wavelength_through_dispersion`].)
pub(crate) fn camera_sample_radiance<R: Radiance>(
    integrator: &R,
    tracer: &mut Tracer,
    cs: &CameraSample,
    sampler: &mut Sampler,
    mut first_hit: Option<&mut Option<FirstHit>>,
) -> (SampledSpectrum, SampledWavelengths) {
    let (ray, filter) = match &cs.rays {
        CameraRays::Shared(ray) => (ray, SampledSpectrum::splat(1.0)),
        CameraRays::Filtered(ray, filter) => (ray, *filter),
        CameraRays::PerWavelength(rays) => {
            let mut l = SampledSpectrum::zero();
            for (slot, ray) in rays.iter().enumerate() {
                let Some(ray) = ray.filter(|_| cs.wl.is_active(slot)) else { continue };
                let mut wl = cs.wl.branch(slot);
                let lb = finite_or_zero(integrator.li(tracer, &ray, &mut wl, sampler, first_hit.take()));
                l[slot] += lb[slot] * ray.weight;
            }
            return (l, cs.wl);
        }
    };
    let Some(ray) = ray else { return (SampledSpectrum::zero(), cs.wl) };
    let mut wl = cs.wl;
    let l = finite_or_zero(integrator.li(tracer, ray, &mut wl, sampler, first_hit));
    (l * filter * ray.weight, wl)
}

/// Salt of the random shift of each pass's shared wavelengths.
const PASS_WAVELENGTH_SEED_SALT: u32 = 0x7061_7373;

/// How many wavelengths a chunk of passes holds: their optics stay cached until the next chunk (for 250 µm rain, 64
/// tables of about 120 kB).
const WAVELENGTH_CHUNK_WAVELENGTHS: u32 = 64;

/// The work of one pixel sample in the units of [`RenderScene::work_per_wavelength`] (the ratio of the rainbow's
/// measured time per pixel sample to its drops' time per unit, BENCHMARKS.md "Lorenz–Mie optics per wavelength"),
/// and the share of a render the tables may take: a set's tables cost at most that share of its passes' samples.
const WORK_PER_PIXEL_SAMPLE: f64 = 2000.0;
const WAVELENGTH_WORK_SHARE: f64 = 0.1;

/// The most passes one wavelength set serves, and the most hero quadruples a set holds.
const MAX_PASSES_PER_WAVELENGTH_SET: u32 = 64;
const MAX_QUADRUPLES_PER_WAVELENGTH_SET: u32 = 16;

/// How a scene's passes share wavelengths (see [`CameraSampler::wavelengths_of`]).
#[derive(Clone, Copy, Debug)]
struct PassWavelengths {
    /// Seed of the sets' random shifts.
    seed: u32,
    /// Passes per wavelength set.
    passes_per_set: u32,
    /// Hero quadruples per set: each path takes one of them at random.
    quadruples: u32,
}

/// Makes camera samples for a film: its pixel filter, importance sampled, and its wavelength strategy.
pub(crate) struct CameraSampler {
    filter: FilterSampler,
    wavelengths: WavelengthSampler,
    /// Through a dispersive lens, keep one wavelength chosen at random (and trace its ray only) instead of giving
    /// every wavelength its ray.
    one_wavelength_through_dispersion: bool,
    /// In a scene whose optics are computed per wavelength, how passes share wavelengths.
    pass_wavelengths: Option<PassWavelengths>,
}

impl CameraSampler {
    /// The camera sampler of `film`.
    pub fn new(film: &Film) -> Result<Self, FilmError> {
        Ok(Self {
            filter: FilterSampler::new(&film.spec().filter)?,
            wavelengths: film.wavelengths().clone(),
            one_wavelength_through_dispersion: false,
            pass_wavelengths: None,
        })
    }

    /// This sampler sharing each pass's wavelengths between pixels if `scene` asks for it
    /// ([`RenderScene::shares_pass_wavelengths`]), for renders of `film` with `seed` (see
    /// [`CameraSampler::wavelengths_of`]). The optics of a set's wavelengths may cost a tenth of the work of the
    /// passes it serves, judged from the scene and the full image's pixel count (not the machine, the crop or the
    /// shard, so that images agree): where four wavelengths cost more, several passes share a set; where they cost
    /// less, a set holds several hero quadruples (more wavelengths over the render, so finer spectra).
    pub fn sharing_pass_wavelengths(mut self, scene: &RenderScene, film: &Film, seed: u32) -> Self {
        self.pass_wavelengths = scene.shares_pass_wavelengths().then(|| {
            let pixels = f64::from(film.width()) * f64::from(film.height());
            let quadruple_work = 4.0 * scene.work_per_wavelength();
            let affordable = WAVELENGTH_WORK_SHARE * WORK_PER_PIXEL_SAMPLE * pixels.max(1.0) / quadruple_work;
            let (passes_per_set, quadruples) = if affordable >= 1.0 {
                (1, affordable.floor().min(f64::from(MAX_QUADRUPLES_PER_WAVELENGTH_SET)) as u32)
            } else {
                ((1.0 / affordable).ceil().min(f64::from(MAX_PASSES_PER_WAVELENGTH_SET)) as u32, 1)
            };
            PassWavelengths { seed: hash_words(&[seed, PASS_WAVELENGTH_SEED_SALT]), passes_per_set, quadruples }
        });
        self
    }

    /// The wavelengths of a path of pass `pass` from its own uniform number `u`.
    ///
    /// Where the scene shares pass wavelengths, the paths of a set of passes carry one of the set's Q hero
    /// quadruples: the primary sample (q + (b + ξ)/Q)/4 of the strategy, with t = ⌊4Qu⌋, b = t mod Q, q = ⌊t/Q⌋
    /// and ξ the set's shift, uniform over [0, 1) for every set (Owen-scrambled van der Corput over the sets, as
    /// photon mapping's iterations); the hero's rotations by 1/4 stay in the set. Each pass is unbiased on its
    /// own and the sets together stratify the spectrum. Pixels then share wavelengths within a pass (less colour
    /// noise between neighbours, a tint that changes from set to set) and the Mie optics are computed at 4Q
    /// wavelengths per set instead of four per path.
    #[inline]
    pub fn wavelengths_of(&self, pass: u32, u: f32) -> SampledWavelengths {
        match self.pass_wavelengths {
            None => self.wavelengths.sample(f64::from(u)),
            Some(p) => self.wavelengths.sample(set_primary_sample(pass / p.passes_per_set, p.seed, p.quadruples, u)),
        }
    }

    /// Renders `samples` with `render` chunk by chunk, computing each chunk's wavelength-dependent optics before
    /// (and letting go of the previous chunk's), where the scene shares pass wavelengths; in one call otherwise. A
    /// pixel's samples are added in the same order either way. The last chunk's optics stay cached for the next
    /// call, which often continues the same chunk (renders with progress, checkpoints or a time limit come in many
    /// calls of a few passes).
    pub fn in_wavelength_chunks(
        &self,
        scene: &RenderScene,
        samples: Range<u32>,
        mut render: impl FnMut(Range<u32>) -> RenderStats,
    ) -> RenderStats {
        let Some(p) = self.pass_wavelengths else { return render(samples) };
        let chunk = p.passes_per_set * (WAVELENGTH_CHUNK_WAVELENGTHS / (4 * p.quadruples)).max(1);
        let mut total = RenderStats::default();
        let mut s0 = samples.start;
        while s0 < samples.end {
            // Chunks end on set boundaries, so that no set is computed twice.
            let s1 = ((s0 / chunk).saturating_add(1)).saturating_mul(chunk).min(samples.end);
            let mut lambdas: Vec<f64> = Vec::new();
            for set in s0 / p.passes_per_set..=(s1 - 1) / p.passes_per_set {
                for t in 0..4 * p.quadruples {
                    let u = (t as f32 + 0.5) / (4 * p.quadruples) as f32;
                    let wl = self.wavelengths.sample(set_primary_sample(set, p.seed, p.quadruples, u));
                    lambdas.extend((0..spectral::N_WAVELENGTHS).map(|i| f64::from(wl.lambda(i))));
                }
            }
            scene.prepare_wavelengths(&lambdas);
            let stats = render(s0..s1);
            total.samples += stats.samples;
            total.rays += stats.rays;
            s0 = s1;
        }
        total
    }

    /// This sampler keeping, through a dispersive lens, one wavelength chosen at random with its density over the
    /// choice (as at a dispersive refraction), and tracing that wavelength's ray only, when `one` (an integrator
    /// whose `"bool splitdispersion"` is false).
    pub fn keeping_one_wavelength_through_dispersion(mut self, one: bool) -> Self {
        self.one_wavelength_through_dispersion = one;
        self
    }

    /// The camera sample of pixel (`x`, `y`), drawing the first five dimensions of `sampler`: wavelengths (1),
    /// film offset from the filter (2), lens (2); in a scene where something moves, six: the ray's time (1, uniform
    /// over the shutter) comes between the film offset and the lens, as in pbrt-v4's `GetCameraSample`.
    #[inline]
    pub fn sample(&self, scene: &RenderScene, x: u32, y: u32, sampler: &mut Sampler) -> CameraSample {
        self.sample_at(scene, x, y, sampler, None)
    }

    /// [`CameraSampler::sample`] with the wavelengths `wl` in place of the sample's own (photon mapping's are the
    /// iteration's), drawing the same dimensions.
    #[inline]
    pub fn sample_at(
        &self,
        scene: &RenderScene,
        x: u32,
        y: u32,
        sampler: &mut Sampler,
        wl: Option<SampledWavelengths>,
    ) -> CameraSample {
        let u_wl = sampler.next_1d();
        let own = self.wavelengths_of(sampler.sample_index(), u_wl);
        let mut wl = wl.unwrap_or(own);
        let [u0, u1] = sampler.next_2d();
        let f = self.filter.sample([u0 as f64, u1 as f64]);
        let offset = Vec2::new(f.offset[0] as f32, f.offset[1] as f32);
        let time = scene.sample_time(sampler);
        let lens = Vec2::from(sampler.next_2d());
        let film = Vec2::new(x as f32 + 0.5, y as f32 + 0.5) + offset;
        let rays = if self.one_wavelength_through_dispersion && scene.camera.is_dispersive() {
            let slot = wl.terminate_secondary(sampler.next_1d());
            CameraRays::Shared(scene.camera.generate_ray_at(film, lens, time, wl.lambda(slot) as f64))
        } else {
            scene.camera.generate_rays(film, lens, time, &wl)
        };
        CameraSample { wl, weight: f.weight as f32, rays, film, lens, time }
    }
}

/// The primary sample of wavelength set `set` (of `quadruples` hero quadruples) picked by `u`: (q + (b + ξ)/Q)/4,
/// t = ⌊4Qu⌋, b = t mod Q, q = ⌊t/Q⌋, ξ the set's shift (see [`CameraSampler::wavelengths_of`]).
#[inline]
fn set_primary_sample(set: u32, seed: u32, quadruples: u32, u: f32) -> f64 {
    let xi = f64::from(sobol_burley::sample(set, 0, seed));
    let n = f64::from(4 * quadruples);
    let t = (f64::from(u) * n).floor().clamp(0.0, n - 1.0);
    let (b, q) = (t % f64::from(quadruples), (t / f64::from(quadruples)).floor());
    ((q + (b + xi) / f64::from(quadruples)) / 4.0).min(1.0 - f64::EPSILON)
}

/// What a film keeps of each camera sample's first visible surface: nothing, the AOVs (albedo and world-space
/// shading normal), or pbrt-v4's geometry buffer besides. Integrators look for the first hit only when it is kept,
/// so films without AOVs cost nothing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum SurfaceRecords {
    /// No AOVs.
    None,
    /// The albedo and the world-space shading normal (the command line's `--aovs`).
    Aovs,
    /// pbrt-v4's `Film "gbuffer"`: the AOVs and the geometry, in its coordinate system.
    GBuffer(GBufferCoordinates),
}

/// One camera sample's first visible surface as the film records it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SurfaceRecord {
    albedo: SampledSpectrum,
    /// The wavelengths the camera ray started with, at which the film sees the albedo.
    wl: SampledWavelengths,
    /// The shading normal in the film's coordinates.
    normal: [f64; 3],
    /// The gbuffer's geometry, if the film keeps it.
    geometry: Option<VisibleSurface>,
}

impl SurfaceRecords {
    /// What `film` keeps.
    pub fn of(film: &Film) -> Self {
        match (&film.spec().gbuffer, film.has_aovs()) {
            (Some(g), _) => SurfaceRecords::GBuffer(g.coordinates),
            (None, true) => SurfaceRecords::Aovs,
            (None, false) => SurfaceRecords::None,
        }
    }

    /// Whether the film keeps anything of the first hit.
    pub fn wanted(self) -> bool {
        self != SurfaceRecords::None
    }

    /// The record of the first surface `hit` camera sample `cs` found.
    ///
    /// For a gbuffer, as pbrt-v4's `VisibleSurface`: the geometric and shading normals face the camera ray's
    /// origin, and dp/dx, dp/dy are where the camera rays through the film one pixel to the right and one pixel
    /// down (same lens point and time) meet the surface's tangent plane at the hit, minus the hit (pbrt-v4's
    /// `SurfaceInteraction::ComputeDifferentials` with unscaled camera ray differentials): the change of the point
    /// per pixel. Positions, normals and dp/dx, dp/dy are then taken to the film's coordinate system at the
    /// sample's time (pbrt-v4's `CameraFromRender(time)`), dz/dx and dz/dy being the z of the last two.
    pub fn record(self, scene: &RenderScene, cs: &CameraSample, hit: &FirstHit) -> SurfaceRecord {
        // A first hit was found by one of the sample's rays; the stand-in only keeps this function total.
        let ray = cs.first_ray().copied().unwrap_or(CameraRay {
            origin: hit.p,
            direction: Vec3::Z,
            time: cs.time,
            weight: 0.0,
        });
        let v3 = |v: Vec3| [v.x as f64, v.y as f64, v.z as f64];
        let d3 = |v: DVec3| v.to_array();
        let coordinates = match self {
            SurfaceRecords::GBuffer(c) => c,
            SurfaceRecords::None | SurfaceRecords::Aovs => {
                return SurfaceRecord { albedo: hit.albedo, wl: cs.wl, normal: v3(hit.normal), geometry: None }
            }
        };
        let wo = -ray.direction;
        let face = |v: Vec3| if v.dot(wo) < 0.0 { -v } else { v };
        let (n, ns) = (face(hit.ng).as_dvec3(), face(hit.normal).as_dvec3());
        let p = hit.p.as_dvec3();
        let time = cs.time;
        let dp = |offset: Vec2| {
            // A neighbour the lens stops has no point on the plane: no finite change.
            let Some(r) = scene.camera.generate_ray(cs.film + offset, cs.lens, time) else { return DVec3::ZERO };
            let (o, d) = (r.origin.as_dvec3(), r.direction.as_dvec3());
            let t = n.dot(p - o) / n.dot(d);
            let q = o + d * t;
            // A ray parallel to the tangent plane never meets it: no finite change.
            if q.is_finite() {
                q - p
            } else {
                DVec3::ZERO
            }
        };
        let (dpdx, dpdy) = (dp(Vec2::X), dp(Vec2::Y));
        let camera = scene.camera.at_time(time);
        let (p, n, ns, dpdx, dpdy) = match coordinates {
            GBufferCoordinates::World => (p, n, ns, dpdx, dpdy),
            GBufferCoordinates::Camera => {
                let m = camera.camera_from_world();
                (m.point(p), m.normal(n).normalize(), m.normal(ns).normalize(), m.vector(dpdx), m.vector(dpdy))
            }
        };
        let uv = [hit.uv.x as f64, hit.uv.y as f64];
        let geometry = VisibleSurface { p: d3(p), n: d3(n), uv, dzdx: dpdx.z, dzdy: dpdy.z };
        SurfaceRecord { albedo: hit.albedo, wl: cs.wl, normal: d3(ns), geometry: Some(geometry) }
    }
}

impl SurfaceRecord {
    /// Adds the record to pixel `x` of `row` for a camera sample of filter weight `weight` that brought `sample`
    /// (radiance and its wavelengths) to the pixel; `None` for an integrator whose pixels are not means of samples.
    pub fn add_to_row(
        &self,
        row: &mut FilmRow,
        x: u32,
        weight: f64,
        sample: Option<(&SampledSpectrum, &SampledWavelengths)>,
    ) {
        row.add_albedo(x, &self.albedo, &self.wl, self.normal);
        if let Some(g) = &self.geometry {
            row.add_visible_surface(x, g, weight, sample);
        }
    }

    /// [`SurfaceRecord::add_to_row`] for pixel (x, y) of `film`.
    pub fn add_to_film(
        &self,
        film: &mut Film,
        (x, y): (u32, u32),
        weight: f64,
        sample: Option<(&SampledSpectrum, &SampledWavelengths)>,
    ) {
        film.add_albedo(x, y, &self.albedo, &self.wl, self.normal);
        if let Some(g) = &self.geometry {
            film.add_visible_surface(x, y, g, weight, sample);
        }
    }
}

/// A camera path's radiance, or zero if any value is NaN or infinite (pbrt-v4 drops such samples' radiance the
/// same way, keeping their filter weight, so one bad path does not blacken or brighten a pixel).
pub(crate) fn finite_or_zero(l: SampledSpectrum) -> SampledSpectrum {
    if l.0.iter().all(|v| v.is_finite()) {
        l
    } else {
        SampledSpectrum::zero()
    }
}

/// What [`render_rows`] calls for each pixel: `(row, x, samples, tracer)` adds samples `samples` of pixel `x` to
/// `row`.
pub(crate) type PixelSamples<'f, 's> = dyn Fn(&mut FilmRow, u32, Range<u32>, &mut Tracer<'s>) + Sync + 'f;

/// Renders samples `samples` of every pixel of a render of `scene`, rows in parallel, with `per_pixel`. `progress`
/// hears the number of pixel samples done after each row.
pub(crate) fn render_rows<'s>(
    film: &mut Film,
    scene: &'s RenderScene,
    samples: Range<u32>,
    progress: &(dyn Fn(u64) + Sync),
    per_pixel: &PixelSamples<'_, 's>,
) -> RenderStats {
    let per_pixel_samples = (samples.end - samples.start) as u64;
    film.par_rows_mut()
        .map(|mut row| {
            let mut tracer = Tracer::new(scene);
            for x in row.xs() {
                per_pixel(&mut row, x, samples.clone(), &mut tracer);
            }
            let taken = per_pixel_samples * row.width() as u64;
            progress(taken);
            RenderStats { samples: taken, rays: tracer.rays() }
        })
        .reduce(RenderStats::default, |a, b| RenderStats { samples: a.samples + b.samples, rays: a.rays + b.rays })
}

/// A camera sample's contribution to its own pixel, from a splatting integrator.
struct CameraRecord {
    x: u32,
    l: SampledSpectrum,
    wl: SampledWavelengths,
    weight: f32,
    /// Boxed: a batch holds many records, most films keep no AOVs.
    surface: Option<Box<SurfaceRecord>>,
}

/// What the pixel samples of a splatting integrator produced: camera samples for their own pixels and splats.
#[derive(Default)]
pub(crate) struct SampleRecords {
    camera: Vec<CameraRecord>,
    splats: Vec<Splat>,
}

impl SampleRecords {
    /// Records a camera sample of pixel `x` (of the row being rendered) with radiance `l` at wavelengths `wl`, and
    /// its first visible surface if the film keeps it.
    pub fn camera(
        &mut self,
        x: u32,
        l: SampledSpectrum,
        wl: SampledWavelengths,
        weight: f32,
        surface: Option<SurfaceRecord>,
    ) {
        self.camera.push(CameraRecord { x, l, wl, weight, surface: surface.map(Box::new) });
    }

    /// Records a light-path contribution `l` at wavelengths `wl` landing at raster position `raster`.
    pub fn splat(&mut self, raster: Vec2, l: SampledSpectrum, wl: SampledWavelengths) {
        self.splats.push(Splat { raster: [raster.x as f64, raster.y as f64], l, wl });
    }
}

/// What [`render_splatting`] calls for every pixel sample: `(x, y, s, tracer, records)`.
pub(crate) type PixelSample<'f, 's> = dyn Fn(u32, u32, u32, &mut Tracer<'s>, &mut SampleRecords) + Sync + 'f;

/// Runs `per_sample(x, y, s, tracer, records)` for every pixel sample of a render of `scene`, rows in parallel in batches small enough to
/// hold their records in memory, and adds the camera samples and splats to the film in the order (sample index,
/// row, column) whatever the batching: the same sums in the same order for any number of threads, and for a render
/// split into several runs of consecutive sample ranges. Counts `samples` light paths per pixel for the splats'
/// scale.
pub(crate) fn render_splatting<'s>(
    film: &mut Film,
    scene: &'s RenderScene,
    samples: Range<u32>,
    progress: &(dyn Fn(u64) + Sync),
    per_sample: &PixelSample<'_, 's>,
) -> RenderStats {
    // The film's pixel bounds (a crop renders only its own pixels' samples and light paths; coordinates stay
    // those of the full image, so each pixel draws the same random numbers as in a full render).
    let b = film.bounds();
    let (x0, y_start, w, h) = (b.x0, b.y0, b.width(), b.height());
    let spp = (samples.end - samples.start) as u64;
    // A batch holds at most ~32k pixel samples' records: a band of rows of one sample pass for large films, or
    // several whole passes for small ones (work for every thread either way). In dense fog a light path leaves ~8
    // splats of ~250 bytes each on their way into the film: 2^17 paths per batch peaked at 174 MB. Records are kept
    // per pass within a row, so the batch adds them pass by pass, and the global order of additions is (pass, row,
    // column).
    const BATCH_PATHS: u64 = 1 << 15;
    let rows_per_batch = (BATCH_PATHS / w as u64).clamp(1, h as u64) as u32;
    let passes_per_batch =
        if rows_per_batch < h { 1 } else { (BATCH_PATHS / (w as u64 * h as u64)).clamp(1, spp.max(1)) as u32 };
    let mut stats = RenderStats::default();
    let mut s0 = samples.start;
    while s0 < samples.end {
        let s1 = (s0 + passes_per_batch).min(samples.end);
        let mut y0 = y_start;
        while y0 < y_start + h {
            let y1 = (y0 + rows_per_batch).min(y_start + h);
            // Per row: one record set per pass s0..s1.
            let rows: Vec<(Vec<SampleRecords>, u64)> = (y0..y1)
                .into_par_iter()
                .map(|y| {
                    let mut tracer = Tracer::new(scene);
                    let records = (s0..s1)
                        .map(|s| {
                            let mut records = SampleRecords::default();
                            for x in x0..x0 + w {
                                per_sample(x, y, s, &mut tracer, &mut records);
                            }
                            records
                        })
                        .collect();
                    progress(w as u64 * (s1 - s0) as u64);
                    (records, tracer.rays())
                })
                .collect();
            let mut splats = Vec::new();
            for pass in 0..(s1 - s0) as usize {
                for (y, (records, _)) in (y0..y1).zip(&rows) {
                    for c in &records[pass].camera {
                        film.add_sample(c.x, y, &c.l, &c.wl, c.weight as f64);
                        if let Some(s) = &c.surface {
                            s.add_to_film(film, (c.x, y), c.weight as f64, Some((&c.l, &c.wl)));
                        }
                    }
                    splats.extend_from_slice(&records[pass].splats);
                }
            }
            stats.rays += rows.iter().map(|(_, rays)| rays).sum::<u64>();
            film.add_splats(&splats);
            y0 = y1;
        }
        s0 = s1;
    }
    film.add_light_paths(w as u64 * h as u64 * spp);
    stats.samples = w as u64 * h as u64 * spp;
    stats
}

/// Camera paths traced into the pixels they start from, by any camera-side estimator: the render of `path` and
/// `volpath`, and the directly visible emitters of the light tracer.
pub(crate) struct CameraPaths<'a, R: Radiance> {
    integrator: R,
    pub(crate) scene: &'a RenderScene,
    pub(crate) camera: CameraSampler,
    pub(crate) seed: u32,
}

impl<'a, R: Radiance> CameraPaths<'a, R> {
    /// Camera paths of `integrator` through `scene` into films like `film`.
    pub fn new(integrator: R, scene: &'a RenderScene, film: &Film, seed: u32) -> Result<Self, FilmError> {
        let camera = CameraSampler::new(film)?
            .keeping_one_wavelength_through_dispersion(!integrator.splits_dispersion())
            .sharing_pass_wavelengths(scene, film, seed);
        Ok(Self { integrator, scene, camera, seed })
    }

    /// Renders samples `samples` of every pixel into `film`, with albedo and normal AOVs and the geometry buffer if
    /// the film keeps them.
    pub fn render(&self, film: &mut Film, samples: Range<u32>, progress: &(dyn Fn(u64) + Sync)) -> RenderStats {
        self.camera.in_wavelength_chunks(self.scene, samples, |chunk| self.render_in_one(film, chunk, progress))
    }

    /// [`CameraPaths::render`] in one go, for a caller that prepares the wavelengths of `samples` itself
    /// ([`CameraSampler::in_wavelength_chunks`]).
    pub fn render_in_one(&self, film: &mut Film, samples: Range<u32>, progress: &(dyn Fn(u64) + Sync)) -> RenderStats {
        let surfaces = SurfaceRecords::of(film);
        render_rows(film, self.scene, samples, progress, &|row, x, samples, tracer| {
            let y = row.y();
            for s in samples {
                let mut sampler = Sampler::new(x, y, s, self.seed);
                let cs = self.camera.sample(self.scene, x, y, &mut sampler);
                let mut first_hit = None;
                let fh = surfaces.wanted().then_some(&mut first_hit);
                let (l, wl) = camera_sample_radiance(&self.integrator, tracer, &cs, &mut sampler, fh);
                let weight = cs.weight as f64;
                row.add_sample(x, &l, &wl, weight);
                if let Some(h) = first_hit {
                    surfaces.record(self.scene, &cs, &h).add_to_row(row, x, weight, Some((&l, &wl)));
                }
            }
        })
    }
}

impl<R: Radiance> RenderJob for CameraPaths<'_, R> {
    fn run(&mut self, film: &mut Film, passes: Range<u32>, progress: &(dyn Fn(u64) + Sync)) -> RenderStats {
        self.render(film, passes, progress)
    }

    fn finish(self: Box<Self>, _film: &mut Film) {}
}

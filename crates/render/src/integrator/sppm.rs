//! The `sppm` integrator: stochastic progressive photon mapping (Hachisuka & Jensen 2009), spectral.
//!
//! Every iteration
//! 1. samples one set of wavelengths for the whole iteration (stratified over iterations), so photons and camera
//!    paths carry the same wavelengths and a photon's flux can be gathered wavelength by wavelength;
//! 2. traces one camera path per pixel through specular surfaces to its first non-specular surface, adding the
//!    emission it sees and next-event estimation there (the direct light), and leaves a *visible point*;
//! 3. traces `photonsperiteration` photons from the lights (chosen by power) in importance mode; every photon that
//!    arrives at a non-specular surface after at least one bounce adds `β_photon · f(vp)` to each visible point
//!    within that point's radius (a dispersive refraction leaves a photon with one wavelength, which then adds to
//!    that wavelength only, with the selection probability divided out);
//! 4. updates each pixel with Hachisuka & Jensen's progressive rule (α = 2/3): N ← N + αM,
//!    R ← R·√(N_new/(N + M)), τ ← (τ + Φ)·R_new²/R².
//!
//! The pixel's radiance is `L_direct/iterations + τ/(N_emitted·π·R²)`, kept as XYZ and, for a spectral film, per
//! bucket, so the spectral film is right for photon-mapped light too. Photon contributions are gathered in batches
//! and added in photon order: the image does not depend on the number of threads.

use std::f64::consts::PI;
use std::ops::Range;

use film::{Film, SampleConversion};
use glam::Vec3;
use rayon::prelude::*;
use scene::SceneError;
use spectral::{SampledSpectrum, SampledWavelengths, Xyz};

use super::drive::{begin_camera_bounce, CameraBounce, Depth, FirstHit, RenderStats};
use super::drive::{CameraSample, CameraSampler, SurfaceRecord, SurfaceRecords};
use super::light_walk::{walk_light_path, LightVertexAt, LightWalk};
use super::transport::{sample_direct_light, scatter, BounceSamples, DirectLight, PathRay, SurfaceVertex, Tracer};
use super::volume::{sample_ld, weigh_tracking, PrefixRatios, ScatterVertex, SpectralMis};
use super::{Integrate, IntegratorParams, Needs, PassUnit, RenderError, RenderJob};
use crate::bxdf::{Bxdf, TransportMode};
use crate::camera::CameraRays;
use crate::medium::{sample_t_maj, Collision, PhaseFunction, TrackingRng};
use crate::sampler::{hash_words, Sampler};
use crate::sampling::Frame;
use crate::scene::RenderScene;

/// pbrt-v4's `sppm` parameters.
#[derive(Clone, Copy, Debug)]
pub struct SppmIntegrator {
    /// Maximum number of scattering events of camera and photon paths (default 5).
    pub max_depth: u32,
    /// Photons per iteration; `None` for one per pixel (pbrt-v4's default −1).
    pub photons_per_iteration: Option<u64>,
    /// Initial gather radius in scene units (default 1).
    pub initial_radius: f32,
    /// Iterations the scene asks for (default 64; pbrt-v4 ignores the sampler's pixel samples here).
    pub iterations: u32,
}

/// Salt for the photon samplers' seeds.
const PHOTON_SEED_SALT: u32 = 0x7068_6f74;
/// Salt for the per-iteration wavelength sample.
const WAVELENGTH_SEED_SALT: u32 = 0x7761_7665;
/// Photons traced per batch before their contributions are added (bounds memory).
const PHOTON_BATCH: u64 = 1 << 16;
/// The progressive radius reduction parameter α (Hachisuka & Jensen 2009 use 0.7; pbrt-v4 2/3).
const ALPHA: f64 = 2.0 / 3.0;

/// A camera path's first non-specular vertex in the current iteration.
#[derive(Clone, Debug)]
struct VisiblePoint<'a> {
    p: Vec3,
    at: VisibleAt<'a>,
    /// The camera path's weight: its throughput over the spectral-MIS mean of its densities, and for a point in a
    /// medium also over σs there (photons are deposited at scattering events, whose density carries σs).
    beta: SampledSpectrum,
    wl: SampledWavelengths,
}

/// Where a visible point is.
#[derive(Clone, Debug)]
enum VisibleAt<'a> {
    /// On a surface, with its BxDF in its shading frame and the direction to the camera.
    Surface { frame: Frame, wo: Vec3, bxdf: Bxdf },
    /// At a scattering event in a medium, reached along `d_in`.
    Medium { phase: &'a PhaseFunction, d_in: Vec3 },
}

/// Per-pixel progressive state.
#[derive(Clone, Debug)]
struct PixelState {
    radius: f64,
    n: f64,
    tau_xyz: [f64; 3],
    ld_xyz: [f64; 3],
    /// Sum of the camera samples' filter weights over the iterations.
    weight: f64,
}

/// The progressive state of an SPPM render: iterations can be added until the image is written.
pub(crate) struct SppmState {
    /// Full-image coordinates of the first pixel rendered (the film's pixel bounds).
    origin: (u32, u32),
    width: u32,
    height: u32,
    nbuckets: usize,
    /// The film's conversion of path samples to colour and buckets.
    conversion: SampleConversion,
    /// Camera samples for the film's filter.
    camera: CameraSampler,
    pixels: Vec<PixelState>,
    /// τ per bucket (pixel-major), for spectral films.
    tau_buckets: Vec<f64>,
    /// Direct light per bucket (pixel-major), for spectral films.
    ld_buckets: Vec<f64>,
    iterations: u32,
    photons: u64,
}

impl SppmState {
    /// A fresh state for `film` with the integrator's initial radius.
    pub fn new(film: &Film, integrator: &SppmIntegrator) -> Result<Self, RenderError> {
        // Only the film's pixel bounds are rendered (a crop), with full-image pixel coordinates.
        let b = film.bounds();
        let (w, h) = (b.width(), b.height());
        let npix = w as usize * h as usize;
        let nb = film.nbuckets();
        Ok(Self {
            origin: (b.x0, b.y0),
            width: w,
            height: h,
            nbuckets: nb,
            conversion: film.conversion().clone(),
            // A camera path has one visible point: through a dispersive lens it keeps one wavelength, chosen at
            // random (as at a dispersive refraction), and only that wavelength's ray is traced.
            camera: CameraSampler::new(film)?.keeping_one_wavelength_through_dispersion(true),
            pixels: vec![
                PixelState {
                    radius: integrator.initial_radius as f64,
                    n: 0.0,
                    tau_xyz: [0.0; 3],
                    ld_xyz: [0.0; 3],
                    weight: 0.0,
                };
                npix
            ],
            tau_buckets: vec![0.0; npix * nb],
            ld_buckets: vec![0.0; npix * nb],
            iterations: 0,
            photons: 0,
        })
    }

    /// Values per pixel in [`SppmState::to_bytes`]: radius, n, τ (XYZ), direct light (XYZ), weight sum.
    const PIXEL_VALUES: usize = 9;
    /// Bytes of [`SppmState::to_bytes`]'s header.
    const HEADER_BYTES: usize = 4 + 8 + 5 * 4;

    /// The state as little-endian bytes: iterations (u32), photons emitted (u64), origin x, origin y, width,
    /// height, buckets (u32 each), then per pixel radius, n, τ X Y Z, direct X Y Z, weight sum (f64 each), then τ
    /// and direct light per bucket (f64, pixel-major).
    pub fn to_bytes(&self) -> Vec<u8> {
        let npix = self.pixels.len();
        let mut out = Vec::with_capacity(
            Self::HEADER_BYTES + 8 * (npix * Self::PIXEL_VALUES + self.tau_buckets.len() + self.ld_buckets.len()),
        );
        out.extend_from_slice(&self.iterations.to_le_bytes());
        out.extend_from_slice(&self.photons.to_le_bytes());
        for v in [self.origin.0, self.origin.1, self.width, self.height, self.nbuckets as u32] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        for p in &self.pixels {
            let values = [p.radius, p.n, p.tau_xyz[0], p.tau_xyz[1], p.tau_xyz[2]];
            for v in values.into_iter().chain(p.ld_xyz).chain([p.weight]) {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
        for v in self.tau_buckets.iter().chain(&self.ld_buckets) {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out
    }

    /// Puts back a state written by [`SppmState::to_bytes`] for the same pixels and buckets; anything else (other
    /// sizes, a wrong length, radii that are not positive, counts that are not finite) is an error and leaves
    /// the state as it was.
    pub fn restore(&mut self, bytes: &[u8]) -> Result<(), RenderError> {
        let npix = self.pixels.len();
        let nb = self.nbuckets;
        let want = npix
            .checked_mul(Self::PIXEL_VALUES + 2 * nb)
            .and_then(|n| n.checked_mul(8))
            .and_then(|n| n.checked_add(Self::HEADER_BYTES));
        if Some(bytes.len()) != want {
            return Err(RenderError::StateMismatch(format!(
                "the photon-mapping state has {} bytes; {} pixels with {nb} buckets need {}",
                bytes.len(),
                npix,
                want.map_or("more than can be addressed".into(), |n| n.to_string())
            )));
        }
        let u32_at = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().unwrap_or_default());
        let f64_at = |i: usize| f64::from_le_bytes(bytes[i..i + 8].try_into().unwrap_or_default());
        let iterations = u32_at(0);
        let photons = u64::from_le_bytes(bytes[4..12].try_into().unwrap_or_default());
        let dims = [u32_at(12), u32_at(16), u32_at(20), u32_at(24), u32_at(28)];
        let own = [self.origin.0, self.origin.1, self.width, self.height, nb as u32];
        if dims != own {
            return Err(RenderError::StateMismatch(format!(
                "the photon-mapping state is for pixels at ({}, {}) of {}×{} with {} buckets, not ({}, {}) of {}×{} \
                 with {}",
                dims[0], dims[1], dims[2], dims[3], dims[4], own[0], own[1], own[2], own[3], own[4]
            )));
        }
        let mut at = Self::HEADER_BYTES;
        let mut pixels = Vec::with_capacity(npix);
        for _ in 0..npix {
            let v: Vec<f64> = (0..Self::PIXEL_VALUES).map(|k| f64_at(at + 8 * k)).collect();
            at += 8 * Self::PIXEL_VALUES;
            let valid = v.iter().all(|x| x.is_finite()) && v[0] > 0.0 && v[1] >= 0.0;
            if !valid {
                let (r, n) = (v[0], v[1]);
                return Err(RenderError::StateMismatch(format!(
                    "the photon-mapping state holds a pixel with radius {r} and count {n}"
                )));
            }
            pixels.push(PixelState {
                radius: v[0],
                n: v[1],
                tau_xyz: [v[2], v[3], v[4]],
                ld_xyz: [v[5], v[6], v[7]],
                weight: v[8],
            });
        }
        let read_buckets = |at: &mut usize| -> Vec<f64> {
            let out = (0..npix * nb).map(|k| f64_at(*at + 8 * k)).collect();
            *at += 8 * npix * nb;
            out
        };
        let tau = read_buckets(&mut at);
        let ld = read_buckets(&mut at);
        (self.iterations, self.photons, self.pixels, self.tau_buckets, self.ld_buckets) =
            (iterations, photons, pixels, tau, ld);
        Ok(())
    }

    /// Writes the current estimate into `film` (one sample of weight 1 per pixel).
    ///
    /// Every iteration's camera sample carries its filter weight w into the direct light and the visible point's
    /// throughput, so the pixel is the weighted mean over iterations (as the film forms it for the other
    /// integrators): `Σ w·L_direct / Σ w + τ/(N_emitted·π·R²) · iterations / Σ w`.
    pub fn write_to(&self, film: &mut Film) {
        let nb = self.nbuckets;
        let iters = self.iterations as f64;
        let photons = self.photons.max(1) as f64;
        let mut buckets = vec![0.0; nb];
        for y in 0..self.height {
            for x in 0..self.width {
                let i = (y * self.width + x) as usize;
                let px = &self.pixels[i];
                let per_weight = if px.weight != 0.0 { 1.0 / px.weight } else { 0.0 };
                let k = iters * per_weight / (photons * PI * px.radius * px.radius);
                let c = |j: usize| px.ld_xyz[j] * per_weight + px.tau_xyz[j] * k;
                for (b, v) in buckets.iter_mut().enumerate() {
                    *v = self.ld_buckets[i * nb + b] * per_weight + self.tau_buckets[i * nb + b] * k;
                }
                let (x0, y0) = self.origin;
                film.add_pixel_estimate(x0 + x, y0 + y, Xyz::new(c(0), c(1), c(2)), &buckets, 1.0);
            }
        }
    }
}

/// A uniform grid over the visible points, hashed into a table of cell lists (compressed rows).
struct VisibleGrid {
    origin: Vec3,
    inv_cell: f32,
    table: usize,
    starts: Vec<u32>,
    entries: Vec<u32>,
}

fn cell_hash(c: [i32; 3], table: usize) -> usize {
    (hash_words(&[c[0] as u32, c[1] as u32, c[2] as u32]) as usize) % table
}

impl VisibleGrid {
    /// Inserts every visible point into each cell its gather sphere overlaps; cell size is the largest radius.
    ///
    /// A point goes into every cell its sphere's box overlaps, widened by a little more than the rounding of the
    /// f32 distance test and of the box corners (0.1% of the radius and 2⁻²⁰ of the coordinates): every photon the
    /// distance test accepts is then found whatever the grid's origin and cell size (rounded cell indices are
    /// monotonic in the position). So which photons a point gathers does not depend on the other points, and a render
    /// of a tile of the image gives its pixels exactly as the whole image's render does.
    fn build(points: &[Option<VisiblePoint<'_>>], radii: &[f64]) -> Option<Self> {
        let reach = |p: Vec3, r: f64| Vec3::splat(r as f32 * 1.001) + p.abs() * (1.0 / (1 << 20) as f32);
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut max_r = 0.0f32;
        let mut count = 0usize;
        for (vp, &r) in points.iter().zip(radii) {
            if let Some(vp) = vp {
                lo = lo.min(vp.p - reach(vp.p, r));
                max_r = max_r.max(r as f32);
                count += 1;
            }
        }
        if count == 0 || max_r.is_nan() || max_r <= 0.0 || !lo.is_finite() {
            return None;
        }
        let inv_cell = 1.0 / max_r;
        let table = (2 * count).next_power_of_two();
        let cell_of = |p: Vec3| {
            let c = ((p - lo) * inv_cell).floor();
            [c.x as i32, c.y as i32, c.z as i32]
        };
        let mut pairs: Vec<(u32, u32)> = Vec::with_capacity(count * 4);
        for (i, (vp, &r)) in points.iter().zip(radii).enumerate() {
            let Some(vp) = vp else { continue };
            let e = reach(vp.p, r);
            let (a, b) = (cell_of(vp.p - e), cell_of(vp.p + e));
            for z in a[2]..=b[2] {
                for y in a[1]..=b[1] {
                    for x in a[0]..=b[0] {
                        pairs.push((cell_hash([x, y, z], table) as u32, i as u32));
                    }
                }
            }
        }
        // Cells that hash alike share a list: sort by slot, drop duplicate points within a slot.
        pairs.par_sort_unstable();
        pairs.dedup();
        let mut starts = vec![0u32; table + 1];
        for &(slot, _) in &pairs {
            starts[slot as usize + 1] += 1;
        }
        for s in 1..=table {
            starts[s] += starts[s - 1];
        }
        let entries = pairs.into_iter().map(|(_, i)| i).collect();
        Some(Self { origin: lo, inv_cell, table, starts, entries })
    }

    /// Candidate visible points for a photon at `p`.
    fn candidates(&self, p: Vec3) -> &[u32] {
        let c = ((p - self.origin) * self.inv_cell).floor();
        let slot = cell_hash([c.x as i32, c.y as i32, c.z as i32], self.table);
        &self.entries[self.starts[slot] as usize..self.starts[slot + 1] as usize]
    }
}

/// What a pixel's camera path gave in one iteration: its visible point, the direct light (times the filter
/// weight), the wavelengths after it, ray counts, the camera sample's filter weight, and the first surface it
/// saw if the film keeps AOVs.
type CameraPass<'a> = (Option<VisiblePoint<'a>>, SampledSpectrum, SampledWavelengths, u64, f32, Option<SurfaceRecord>);

/// A photon's contribution to one visible point.
/// What the photons of one iteration are gathered into: the visible points, their grid and radii, and what seeds
/// the photons.
#[derive(Clone, Copy)]
struct PhotonPass<'p> {
    /// Whether photons are tracked through media that scatter (and visible points may lie in them).
    media: bool,
    grid: &'p VisibleGrid,
    points: &'p [Option<VisiblePoint<'p>>],
    radii: &'p [f64],
    /// The iteration's wavelengths.
    wl: SampledWavelengths,
    iteration: u32,
    /// The photon samplers' seed.
    seed: u32,
}

struct Gathered {
    vp: u32,
    phi: SampledSpectrum,
}

impl SppmIntegrator {
    /// Runs iterations `iterations` (their indices seed the random numbers) on `state`; see the module docs. The
    /// camera paths' first surfaces go into `film`'s AOVs and geometry buffer, if it keeps them, as records of
    /// filter weight 1 per iteration (the pixel's colour is written by [`SppmState::write_to`]; the gbuffer's
    /// variance is left out: a pixel is a progressive estimate, not a mean of samples).
    pub(crate) fn run(
        &self,
        scene: &RenderScene,
        state: &mut SppmState,
        film: &mut Film,
        iterations: std::ops::Range<u32>,
        seed: u32,
        progress: &(dyn Fn(u64) + Sync),
    ) -> RenderStats {
        let (w, h) = (state.width, state.height);
        let npix = w as u64 * h as u64;
        let media = scene.has_scattering_media();
        let photons = self.photons_per_iteration.unwrap_or(npix).max(1);
        let mut stats = RenderStats::default();
        let surfaces = SurfaceRecords::of(film);
        for it in iterations {
            // One wavelength set per iteration, stratified over iterations (van der Corput, Owen-scrambled).
            let u_wl = sobol_burley::sample(it, 0, hash_words(&[seed, WAVELENGTH_SEED_SALT]));
            let wl_iter = state.conversion.wavelengths().sample(u_wl as f64);
            // The iteration's wavelengths are all its paths carry: Mie optics are computed for them up front (and
            // the previous iteration's let go).
            if scene.shares_pass_wavelengths() {
                scene.prepare_wavelengths(
                    &(0..spectral::N_WAVELENGTHS).map(|i| f64::from(wl_iter.lambda(i))).collect::<Vec<_>>(),
                );
            }

            // 1. Camera pass: visible points and direct light.
            let camera_sampler = &state.camera;
            let camera: Vec<CameraPass> = (0..npix)
                .into_par_iter()
                .map(|i| {
                    let (x, y) = (state.origin.0 + (i % w as u64) as u32, state.origin.1 + (i / w as u64) as u32);
                    let mut tracer = Tracer::new(scene);
                    let mut sampler = Sampler::new(x, y, it, seed);
                    // The camera sample's own wavelengths are replaced by the iteration's (and reduced to one
                    // through a dispersive lens).
                    let cs = camera_sampler.sample_at(scene, x, y, &mut sampler, Some(wl_iter));
                    let mut wl = cs.wl;
                    let mut first_hit = None;
                    let fh = surfaces.wanted().then_some(&mut first_hit);
                    let (vp, ld) = self.camera_path(&mut tracer, &cs, media, &mut wl, &mut sampler, fh);
                    let surface = first_hit.map(|h| surfaces.record(scene, &cs, &h));
                    (vp, ld, wl, tracer.rays(), cs.weight, surface)
                })
                .collect();
            let mut points = Vec::with_capacity(camera.len());
            for (i, (vp, ld, wl, rays, weight, surface)) in camera.into_iter().enumerate() {
                if let Some(s) = surface {
                    let (x, y) = (state.origin.0 + i as u32 % w, state.origin.1 + i as u32 / w);
                    s.add_to_film(film, (x, y), 1.0, None);
                }
                stats.rays += rays;
                state.pixels[i].weight += weight as f64;
                if !ld.is_black() {
                    let xyz = state.conversion.xyz(&ld, &wl);
                    let px = &mut state.pixels[i];
                    px.ld_xyz[0] += xyz.x;
                    px.ld_xyz[1] += xyz.y;
                    px.ld_xyz[2] += xyz.z;
                    let nb = state.nbuckets;
                    state.conversion.add_to_buckets(&mut state.ld_buckets[i * nb..(i + 1) * nb], &ld, &wl, 1.0);
                }
                points.push(vp);
            }
            progress(npix / 2);

            // 2. Photon pass, gathered into per-point flux Φ and counts M.
            let radii: Vec<f64> = state.pixels.iter().map(|p| p.radius).collect();
            let mut phi = vec![SampledSpectrum::zero(); points.len()];
            let mut m = vec![0u32; points.len()];
            if let Some(grid) = VisibleGrid::build(&points, &radii) {
                let pass = PhotonPass {
                    media,
                    grid: &grid,
                    points: &points,
                    radii: &radii,
                    wl: wl_iter,
                    iteration: it,
                    seed: hash_words(&[seed, PHOTON_SEED_SALT]),
                };
                let mut start = 0u64;
                while start < photons {
                    let end = (start + PHOTON_BATCH).min(photons);
                    let chunk_starts: Vec<u64> = (start..end).step_by(1024).collect();
                    let chunks: Vec<(Vec<Gathered>, u64)> = chunk_starts
                        .into_par_iter()
                        .map(|k0| {
                            let mut out = Vec::new();
                            let mut tracer = Tracer::new(scene);
                            for k in k0..(k0 + 1024).min(end) {
                                self.photon(&mut tracer, &pass, k, &mut out);
                            }
                            (out, tracer.rays())
                        })
                        .collect();
                    for (gathered, rays) in chunks {
                        stats.rays += rays;
                        for g in gathered {
                            phi[g.vp as usize] += g.phi;
                            m[g.vp as usize] += 1;
                        }
                    }
                    start = end;
                }
            }

            // 3. Progressive update (Hachisuka & Jensen 2009, eqs. 6–8 with α = 2/3).
            let nb = state.nbuckets;
            for (i, vp) in points.iter().enumerate() {
                let Some(vp) = vp else { continue };
                if m[i] == 0 {
                    continue;
                }
                let l = vp.beta * phi[i];
                let xyz = state.conversion.xyz(&l, &vp.wl);
                let px = &state.pixels[i];
                let n_new = px.n + ALPHA * m[i] as f64;
                let r_new = px.radius * (n_new / (px.n + m[i] as f64)).sqrt();
                let shrink = (r_new / px.radius).powi(2);
                if nb > 0 {
                    let mut add = vec![0.0; nb];
                    state.conversion.add_to_buckets(&mut add, &l, &vp.wl, 1.0);
                    for (t, a) in state.tau_buckets[i * nb..(i + 1) * nb].iter_mut().zip(&add) {
                        *t = (*t + a) * shrink;
                    }
                }
                let px = &mut state.pixels[i];
                px.tau_xyz = [
                    (px.tau_xyz[0] + xyz.x) * shrink,
                    (px.tau_xyz[1] + xyz.y) * shrink,
                    (px.tau_xyz[2] + xyz.z) * shrink,
                ];
                px.n = n_new;
                px.radius = r_new;
            }
            state.iterations += 1;
            state.photons += photons;
            stats.samples += npix;
            progress(npix - npix / 2);
        }
        stats
    }

    /// Traces the camera path of the camera sample `cs` (at the iteration's wavelengths `wl`): emission seen
    /// through specular bounces and direct light at its first non-specular vertex (both in `ld`), and the visible
    /// point there. With `media` (the scene has media that scatter), the path delta-tracks through them with
    /// spectral MIS (as `volpath` does) and its visible point is its first non-specular surface or its first
    /// scattering event in a medium, whichever comes first; direct light there is next-event estimation through the
    /// media. Without, media only absorb along the path and its shadow rays. Direct light is light sampling only:
    /// photons count from their second vertex.
    fn camera_path<'s>(
        &self,
        tracer: &mut Tracer<'s>,
        cs: &CameraSample,
        media: bool,
        wl: &mut SampledWavelengths,
        sampler: &mut Sampler,
        mut first_hit: Option<&mut Option<FirstHit>>,
    ) -> (Option<VisiblePoint<'s>>, SampledSpectrum) {
        let scene = tracer.scene;
        // A camera path of photon mapping has one visible point: the camera sampler keeps one wavelength through a
        // dispersive lens, and a sample with a ray per wavelength would keep one here the same way.
        let (camera_ray, filter) = match cs.rays {
            CameraRays::Shared(r) => (r, SampledSpectrum::splat(1.0)),
            CameraRays::Filtered(r, filter) => (r, filter),
            CameraRays::PerWavelength(rays) => {
                (rays[wl.terminate_secondary(sampler.next_1d())], SampledSpectrum::splat(1.0))
            }
        };
        let Some(camera_ray) = camera_ray else { return (None, SampledSpectrum::zero()) };
        let mut ray = PathRay::camera(camera_ray.origin, camera_ray.direction, scene.camera_medium, camera_ray.time);
        // The camera sample's filter weight, as a camera sample of the other integrators carries it into the film,
        // times the camera's weight of the ray.
        let mut beta = filter * (cs.weight * camera_ray.weight);
        // The rescaled probabilities of the path's tracking decisions: ones without media, where every division by
        // their mean is a division by exactly 1.
        let mut r_u = SampledSpectrum::splat(1.0);
        let mut mis = SpectralMis::new(wl);
        if media {
            // A random hero from the start: a shadow ray may track through a chromatic medium before the path enters
            // one.
            mis.choose(sampler.next_1d());
        }
        let mut ld = SampledSpectrum::zero();
        let mut depth = Depth::new(self.max_depth);
        loop {
            let d = ray.d;
            let hit = ray.intersect(tracer);
            if let Some(m) = ray.medium.filter(|&m| media && !scene.media[m as usize].is_absorbing_only()) {
                let medium = &scene.media[m as usize];
                mis.choose(sampler.next_1d());
                let h = mis.hero;
                let mut rng = TrackingRng::new(sampler.next_1d(), depth.events);
                let t_end = hit.map_or(f32::INFINITY, |h| h.t);
                let (mut scattered, mut terminated) = (None, false);
                let t_maj = sample_t_maj(medium, ray.o, d, t_end, &mut rng, wl, h, |p, mp, sigma_maj, t_maj, rng| {
                    match mp.collision(sigma_maj, h, rng.uniform()) {
                        Collision::Absorb => {
                            terminated = true;
                            false
                        }
                        Collision::Scatter => {
                            if depth.events == depth.max {
                                terminated = true;
                                return false;
                            }
                            if weigh_tracking(&mut beta, &mut r_u, &mis, t_maj, mp.sigma_s) {
                                scattered = Some((p, mp.sigma_s));
                            } else {
                                terminated = true;
                            }
                            false
                        }
                        Collision::Null => {
                            if !weigh_tracking(&mut beta, &mut r_u, &mis, t_maj, mp.sigma_n(sigma_maj)) {
                                terminated = true;
                                return false;
                            }
                            !beta.is_black()
                        }
                    }
                });
                if terminated || beta.is_black() || r_u.is_black() {
                    return (None, ld);
                }
                if let Some((p, sigma_s)) = scattered {
                    let phase = medium.phase();
                    let u = BounceSamples::draw(sampler);
                    let v =
                        ScatterVertex::Medium { p, d_in: d, phase, medium: Some(m), time: ray.time, sun_guide: 0.0 };
                    ld += beta
                        * sample_ld(tracer, v, wl, &u, &mis, PrefixRatios::shared(r_u), DirectLight::LightSamplingOnly);
                    let weight = (beta / mis.average(r_u)).safe_div(sigma_s);
                    let vp = VisiblePoint { p, at: VisibleAt::Medium { phase, d_in: d }, beta: weight, wl: *wl };
                    return (Some(vp), ld);
                }
                // No collision before the surface: probability T_maj at the hero.
                if !weigh_tracking(&mut beta, &mut r_u, &mis, t_maj, SampledSpectrum::splat(1.0)) {
                    return (None, ld);
                }
            } else if let Some(hit) = &hit {
                ray.attenuate(scene, hit, wl, &mut beta);
            }
            let Some(mut hit) = hit else {
                // Only specular bounces led here: the environment is seen directly.
                for &li in &scene.infinite_lights {
                    ld += beta * scene.lights[li as usize].le(d, wl) / mis.average(r_u);
                }
                return (None, ld);
            };
            if let Some(li) = hit.area_light {
                ld += beta * scene.lights[li as usize].l_area(hit.p, hit.uv, hit.n, -d, wl) / mis.average(r_u);
            }
            let arrived_in = ray.medium;
            let (bxdf, u, frame) =
                match begin_camera_bounce(scene, &mut hit, &mut ray, wl, sampler, &mut depth, &mut first_hit) {
                    CameraBounce::PassedThrough => continue,
                    CameraBounce::End => return (None, ld),
                    CameraBounce::Scatter(bxdf, u, frame) => (bxdf, u, frame),
                };
            mis.update(wl);
            let wo = frame.to_local(-d);
            let v = SurfaceVertex { hit: &hit, frame: &frame, bxdf: &bxdf, wo, medium: arrived_in };
            if !bxdf.is_specular() {
                let weighting = DirectLight::LightSamplingOnly;
                ld += beta
                    * if media {
                        sample_ld(tracer, ScatterVertex::Surface(v), wl, &u, &mis, PrefixRatios::shared(r_u), weighting)
                    } else {
                        sample_direct_light(tracer, &v, wl, &u, weighting)
                    };
                let weight = beta / mis.average(r_u);
                let vp = VisiblePoint { p: hit.p, at: VisibleAt::Surface { frame, wo, bxdf }, beta: weight, wl: *wl };
                return (Some(vp), ld);
            }
            let mode = TransportMode::Radiance;
            let Some(s) = scatter(&v, -d, &u, mode, wl, &mut beta) else { return (None, ld) };
            mis.update(wl);
            ray.leave(&hit, s.wi, s.bs.specular);
        }
    }

    /// Traces photon `k` of the iteration of `pass` and records what it gives to visible points within their radii.
    fn photon(&self, tracer: &mut Tracer, pass: &PhotonPass, k: u64, out: &mut Vec<Gathered>) {
        let PhotonPass { media, grid, points, radii, wl: wl_iter, iteration: it, seed } = *pass;
        let mut sampler = Sampler::new(k as u32, (k >> 32) as u32, it, seed);
        let mut wl = wl_iter;
        // Each photon has its own time, uniform over the shutter (pbrt-v4's photons too): the photon map is the
        // shutter's average, gathered by visible points at their camera rays' times.
        let time = tracer.scene.sample_time(&mut sampler);
        let walk = LightWalk { max_depth: self.max_depth, media, time };
        walk_light_path(tracer, walk, &mut wl, &mut sampler, |v, wl, _| {
            // Direct light is the visible points' next-event estimation: photons count from their second vertex.
            if v.depth == 1 {
                return;
            }
            // A photon reduced to one wavelength by dispersion stands for all of them: undo the selection
            // probability so that its flux is an estimate at the iteration's density of that wavelength. In media
            // its throughput is also over the spectral-MIS mean of its densities (1 without media).
            let mut beta = v.beta / v.mis.average(v.r);
            for i in 0..spectral::N_WAVELENGTHS {
                let (p_iter, p_now) = (wl_iter.pdf()[i], wl.pdf()[i]);
                beta[i] = if p_now > 0.0 { beta[i] * p_iter / p_now } else { 0.0 };
            }
            let p = v.p();
            for &j in grid.candidates(p) {
                let Some(vp) = &points[j as usize] else { continue };
                let r = radii[j as usize] as f32;
                if (vp.p - p).length_squared() > r * r {
                    continue;
                }
                // Surface photons meet surface points and medium photons medium points. A medium point's density
                // is per volume, (4/3)πr³, where the progressive update divides by πr²: its photons carry the ratio
                // 3/(4r) (Jensen & Christensen 1998's volume radiance estimate in Hachisuka & Jensen's update).
                let f = match (&vp.at, &v.at) {
                    (VisibleAt::Surface { frame, wo, bxdf }, LightVertexAt::Surface { .. }) => {
                        bxdf.f(*wo, frame.to_local(v.w_from), TransportMode::Radiance)
                    }
                    (VisibleAt::Medium { phase, d_in }, LightVertexAt::Medium { .. }) => {
                        phase.p(-v.w_from, -*d_in, wl) * (3.0 / (4.0 * r))
                    }
                    _ => continue,
                };
                let phi = beta * f;
                if !phi.is_black() {
                    out.push(Gathered { vp: j, phi });
                }
            }
        });
    }
}

impl Integrate for SppmIntegrator {
    fn read(params: &mut IntegratorParams) -> Result<Self, RenderError> {
        params.warn_unrendered_media_glow("sppm");
        let p = &params.entity.params;
        let photons = p.get_int("photonsperiteration", -1)?;
        let radius = p.get_float("radius", 1.0)?;
        if !(radius.is_finite() && radius > 0.0) {
            let msg = format!("'radius' must be a positive number, got {radius}");
            return Err(SceneError::at(params.loc_of("radius"), msg).into());
        }
        if photons == 0 || !(-1..=1 << 32).contains(&photons) {
            let msg = format!("'photonsperiteration' must be positive (or -1 for one per pixel), got {photons}");
            return Err(SceneError::at(params.loc_of("photonsperiteration"), msg).into());
        }
        Ok(SppmIntegrator {
            max_depth: params.max_depth()?,
            photons_per_iteration: (photons > 0).then_some(photons as u64),
            initial_radius: radius as f32,
            iterations: params.count("iterations", 64)?,
        })
    }

    fn needs(&self) -> Needs {
        Needs { unit: PassUnit::Iterations, ..Needs::default() }
    }

    fn passes(&self) -> Option<u32> {
        Some(self.iterations)
    }

    fn begin<'a>(
        &'a self,
        scene: &'a RenderScene,
        film: &Film,
        seed: u32,
    ) -> Result<Box<dyn RenderJob + 'a>, RenderError> {
        Ok(Box::new(SppmRender { integrator: self, scene, state: SppmState::new(film, self)?, seed }))
    }
}

/// A photon-mapping render: iterations extend the progressive state, which is written into the film once.
struct SppmRender<'a> {
    integrator: &'a SppmIntegrator,
    scene: &'a RenderScene,
    state: SppmState,
    seed: u32,
}

impl RenderJob for SppmRender<'_> {
    fn run(&mut self, film: &mut Film, passes: Range<u32>, progress: &(dyn Fn(u64) + Sync)) -> RenderStats {
        self.integrator.run(self.scene, &mut self.state, film, passes, self.seed, progress)
    }

    fn finish(self: Box<Self>, film: &mut Film) {
        self.state.write_to(film);
    }

    fn save_state(&self) -> Vec<u8> {
        self.state.to_bytes()
    }

    fn restore_state(&mut self, state: &[u8]) -> Result<(), RenderError> {
        self.state.restore(state)
    }
}

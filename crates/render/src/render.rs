//! The per-pixel driver: camera samples through the integrator into colour and spectral contributions.

use film::{SpectralEstimates, Splat};
use glam::Vec2;
use glam::Vec3;
use spectral::{Spectrum, WavelengthSampler, Xyz};
use std::ops::Range;

use film::{Film, FilmError, FilterSampler};
use rayon::prelude::*;

use crate::bdpt::BdptIntegrator;
use crate::integrator::{Integrator, PathIntegrator, RayCounts};
use crate::lightpath::LightPathIntegrator;
use crate::sampler::Sampler;
use crate::scene::RenderScene;

/// One camera sample's contribution to its pixel.
#[derive(Clone, Copy, Debug)]
pub struct PixelContribution {
    /// Colour (XYZ of the film's observer).
    pub xyz: Xyz,
    /// Filter weight f/pdf of the sampled film offset.
    pub weight: f32,
    /// Per-wavelength estimates L(λ)/pdf(λ) of the active slots, for spectral films.
    pub spectral: SpectralEstimates,
    /// Albedo (XYZ under the colour space's white, Y = 1 for white) and shading normal at the first hit, when
    /// AOVs were asked for and the camera ray hit a surface.
    pub aov: Option<(Xyz, Vec3)>,
}

/// Renders samples `samples` of pixel (`x`, `y`), calling `add` once per camera sample.
///
/// `filter` maps a uniform 2D sample to a film offset (pixels, relative to the pixel centre) and its weight.
#[allow(clippy::too_many_arguments)]
pub fn render_pixel(
    scene: &RenderScene,
    integrator: &PathIntegrator,
    wavelengths: &WavelengthSampler,
    filter: &(dyn Fn([f32; 2]) -> (Vec2, f32) + Sync),
    x: u32,
    y: u32,
    samples: Range<u32>,
    seed: u32,
    counts: &mut RayCounts,
    aovs: Option<&Spectrum>,
    mut add: impl FnMut(PixelContribution),
) {
    for s in samples {
        let mut sampler = Sampler::new(x, y, s, seed);
        let mut wl = wavelengths.sample(sampler.next_1d() as f64);
        let (offset, weight) = filter(sampler.next_2d());
        let lens = Vec2::from(sampler.next_2d());
        let film = Vec2::new(x as f32 + 0.5, y as f32 + 0.5) + offset;
        let ray = scene.camera.generate_ray(film, lens);
        let mut first_hit = None;
        let fh = aovs.is_some().then_some(&mut first_hit);
        let wl_camera = wl;
        let l = integrator.li(scene, ray.origin, ray.direction, &mut wl, &mut sampler, counts, fh);
        let l = if l.0.iter().all(|v| v.is_finite()) { l } else { spectral::SampledSpectrum::zero() };
        let xyz = wavelengths.to_xyz(&l, &wl);
        // The albedo is seen under the white illuminant at the wavelengths the camera ray started with.
        let aov = match (aovs, first_hit) {
            (Some(white), Some(h)) => {
                Some((wavelengths.to_xyz(&(h.albedo * white.sample(&wl_camera)), &wl_camera), h.normal))
            }
            _ => None,
        };
        add(PixelContribution { xyz, weight, spectral: SpectralEstimates::new(&l, &wl), aov });
    }
}

/// Totals of a render pass.
#[derive(Clone, Copy, Debug, Default)]
pub struct RenderStats {
    /// Camera samples taken.
    pub samples: u64,
    /// Rays traced (closest hit and shadow).
    pub rays: u64,
}

/// Renders samples `samples` of every pixel into `film` with `integrator`, in parallel (rayon). `progress` is called
/// as work completes with the number of pixel samples done. The result does not depend on the number of threads:
/// every sample's random numbers depend only on (pixel, sample index, seed), each pixel's camera samples are written
/// by one thread, and light-path splats are added in a fixed order.
///
/// For `sppm`, `samples` are the photon-mapping iterations (see [`crate::sppm`]).
///
/// For `lightpath`, every pixel sample is one camera ray that records only the light it sees directly, plus one
/// light path whose connections to the camera are splatted.
pub fn render_film(
    scene: &RenderScene,
    integrator: &Integrator,
    wavelengths: &WavelengthSampler,
    film: &mut Film,
    samples: Range<u32>,
    seed: u32,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<RenderStats, FilmError> {
    match integrator {
        Integrator::Path(p) => render_camera_paths(scene, p, wavelengths, film, samples, seed, progress),
        Integrator::LightPath(lp) => render_light_paths(scene, lp, wavelengths, film, samples, seed, progress),
        Integrator::Bdpt(b) => render_bdpt(scene, b, wavelengths, film, samples, seed, progress),
        Integrator::Sppm(sppm) => {
            // A fresh progressive state for these iterations; callers that add iterations over time keep an
            // `SppmState` themselves.
            let mut state = crate::sppm::SppmState::new(film, sppm);
            let stats = sppm.run(scene, wavelengths, &mut state, samples, seed, progress);
            state.write_to(film);
            Ok(stats)
        }
    }
}

/// Salt that makes a light path's random numbers independent of its pixel sample's camera ray.
const LIGHT_PATH_SEED_SALT: u32 = 0x6c69_6768;

/// A camera sample's contribution to its own pixel, from a splatting integrator.
struct CameraRecord {
    x: u32,
    xyz: Xyz,
    weight: f32,
    spectral: SpectralEstimates,
}

/// What one pixel sample of a splatting integrator produced.
#[derive(Default)]
struct SampleRecords {
    camera: Vec<CameraRecord>,
    splats: Vec<Splat>,
}

/// Runs `per_sample(x, y, s, counts, records)` for every pixel sample, rows in parallel in batches small enough to
/// hold their records in memory, then adds the camera samples and splats in row order: the same sums in the same
/// order for any number of threads. Counts `samples` light paths per pixel for the splats' scale.
fn render_splatting(
    film: &mut Film,
    samples: Range<u32>,
    progress: &(dyn Fn(u64) + Sync),
    per_sample: &(dyn Fn(u32, u32, u32, &mut RayCounts, &mut SampleRecords) + Sync),
) -> RenderStats {
    let (w, h) = (film.width(), film.height());
    let spp = (samples.end - samples.start) as u64;
    // Batches of at least 32 rows (work for every thread) and at most ~128k pixel samples (memory for their
    // records): the sample range is split into chunks when the rows are wide or the sample count high. Batching
    // depends only on the film size and the sample range, never on the thread count.
    const BATCH_PATHS: u64 = 1 << 17;
    let batch_rows = 32u32.min(h).max(1);
    let chunk = (BATCH_PATHS / (w as u64 * batch_rows as u64).max(1)).clamp(1, spp.max(1)) as u32;
    let mut stats = RenderStats::default();
    let mut s0 = samples.start;
    while s0 < samples.end {
        let s1 = (s0 + chunk).min(samples.end);
        let mut y0 = 0;
        while y0 < h {
            let y1 = (y0 + batch_rows).min(h);
            let rows: Vec<(SampleRecords, RayCounts)> = (y0..y1)
                .into_par_iter()
                .map(|y| {
                    let mut records = SampleRecords::default();
                    let mut counts = RayCounts::default();
                    for x in 0..w {
                        for s in s0..s1 {
                            per_sample(x, y, s, &mut counts, &mut records);
                        }
                    }
                    progress(w as u64 * (s1 - s0) as u64);
                    (records, counts)
                })
                .collect();
            let mut splats = Vec::new();
            for (y, (records, counts)) in (y0..y1).zip(rows) {
                for c in &records.camera {
                    film.add_sample(c.x, y, c.xyz, c.weight as f64, c.spectral.as_slice());
                }
                splats.extend(records.splats);
                stats.rays += counts.intersect + counts.shadow;
            }
            film.add_splats(&splats);
            y0 = y1;
        }
        s0 = s1;
    }
    film.add_light_paths(w as u64 * h as u64 * spp);
    stats.samples = w as u64 * h as u64 * spp;
    stats
}

/// Camera rays for directly visible light, and one light path per pixel sample, splatted.
fn render_light_paths(
    scene: &RenderScene,
    integrator: &LightPathIntegrator,
    wavelengths: &WavelengthSampler,
    film: &mut Film,
    samples: Range<u32>,
    seed: u32,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<RenderStats, FilmError> {
    // Emitters seen directly: a path tracer that stops at the first surface.
    let direct = PathIntegrator { max_depth: 0 };
    let mut stats = render_camera_paths(scene, &direct, wavelengths, film, samples.clone(), seed, &|_| {})?;
    let light_seed = crate::sampler::hash_words(&[seed, LIGHT_PATH_SEED_SALT]);
    let per_sample = |x: u32, y: u32, s: u32, counts: &mut RayCounts, records: &mut SampleRecords| {
        let mut sampler = Sampler::new(x, y, s, light_seed);
        let mut wl = wavelengths.sample(sampler.next_1d() as f64);
        integrator.trace(scene, &mut wl, &mut sampler, counts, |raster, l, wl| {
            records.splats.push(Splat {
                raster: [raster.x as f64, raster.y as f64],
                xyz: wavelengths.to_xyz(&l, wl),
                spectral: SpectralEstimates::new(&l, wl),
            });
        });
    };
    let light = render_splatting(film, samples, progress, &per_sample);
    stats.rays += light.rays;
    stats.samples = light.samples;
    Ok(stats)
}

/// Salts of the bidirectional path tracer's second and third samplers.
const BDPT_CONNECT_SEED_SALT: u32 = 0x636f_6e6e;

/// Bidirectional path tracing: per pixel sample a camera sample for the pixel and splats for t = 1 connections.
fn render_bdpt(
    scene: &RenderScene,
    integrator: &BdptIntegrator,
    wavelengths: &WavelengthSampler,
    film: &mut Film,
    samples: Range<u32>,
    seed: u32,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<RenderStats, FilmError> {
    let filter_sampler = FilterSampler::new(&film.spec().filter)?;
    let light_seed = crate::sampler::hash_words(&[seed, LIGHT_PATH_SEED_SALT]);
    let connect_seed = crate::sampler::hash_words(&[seed, BDPT_CONNECT_SEED_SALT]);
    let per_sample = |x: u32, y: u32, s: u32, counts: &mut RayCounts, records: &mut SampleRecords| {
        let mut sampler = Sampler::new(x, y, s, seed);
        let mut wl = wavelengths.sample(sampler.next_1d() as f64);
        let f = filter_sampler.sample({
            let [a, b] = sampler.next_2d();
            [a as f64, b as f64]
        });
        let lens = Vec2::from(sampler.next_2d());
        let film_p = Vec2::new(x as f32 + 0.5 + f.offset[0] as f32, y as f32 + 0.5 + f.offset[1] as f32);
        let ray = scene.camera.generate_ray(film_p, lens);
        let mut light_sampler = Sampler::new(x, y, s, light_seed);
        let mut connect_sampler = Sampler::new(x, y, s, connect_seed);
        let mut splats = Vec::new();
        let l = integrator.li(
            scene,
            ray.origin,
            ray.direction,
            &mut wl,
            [&mut sampler, &mut light_sampler, &mut connect_sampler],
            counts,
            |raster, c, wl| splats.push((raster, c, *wl)),
        );
        // Splats are converted with the wavelengths they were made at (a later dispersive event on the other
        // subpath may have reduced the set since).
        for (raster, c, swl) in splats {
            records.splats.push(Splat {
                raster: [raster.x as f64, raster.y as f64],
                xyz: wavelengths.to_xyz(&c, &swl),
                spectral: SpectralEstimates::new(&c, &swl),
            });
        }
        let l = if l.0.iter().all(|v| v.is_finite()) { l } else { spectral::SampledSpectrum::zero() };
        records.camera.push(CameraRecord {
            x,
            xyz: wavelengths.to_xyz(&l, &wl),
            weight: f.weight as f32,
            spectral: SpectralEstimates::new(&l, &wl),
        });
    };
    Ok(render_splatting(film, samples, progress, &per_sample))
}

/// Path tracing from the camera: see [`render_film`].
fn render_camera_paths(
    scene: &RenderScene,
    integrator: &PathIntegrator,
    wavelengths: &WavelengthSampler,
    film: &mut Film,
    samples: Range<u32>,
    seed: u32,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<RenderStats, FilmError> {
    let filter_sampler = FilterSampler::new(&film.spec().filter)?;
    let filter = |u: [f32; 2]| {
        let s = filter_sampler.sample([u[0] as f64, u[1] as f64]);
        (Vec2::new(s.offset[0] as f32, s.offset[1] as f32), s.weight as f32)
    };
    let per_pixel = (samples.end - samples.start) as u64;
    let white = film.has_aovs().then(|| spectral::named::illuminant("stdillum-D65").expect("D65 is built in"));
    let color_space = film.spec().color_space.clone();
    let stats = film
        .par_rows_mut()
        .map(|mut row| {
            let mut counts = RayCounts::default();
            let y = row.y();
            for x in 0..row.width() {
                let aovs = white.as_ref();
                render_pixel(
                    scene,
                    integrator,
                    wavelengths,
                    &filter,
                    x,
                    y,
                    samples.clone(),
                    seed,
                    &mut counts,
                    aovs,
                    |c| {
                        row.add_sample(x, c.xyz, c.weight as f64, c.spectral.as_slice());
                        if let Some((albedo, n)) = c.aov {
                            let n = [n.x as f64, n.y as f64, n.z as f64];
                            row.add_aov(x, color_space.to_rgb(albedo), n);
                        }
                    },
                );
            }
            let taken = per_pixel * row.width() as u64;
            progress(taken);
            RenderStats { samples: taken, rays: counts.intersect + counts.shadow }
        })
        .reduce(RenderStats::default, |a, b| RenderStats { samples: a.samples + b.samples, rays: a.rays + b.rays });
    Ok(stats)
}

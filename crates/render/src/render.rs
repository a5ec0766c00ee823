//! The per-pixel driver: camera samples through the integrator into colour and spectral contributions.

use glam::Vec2;
use spectral::{WavelengthSampler, Xyz, N_WAVELENGTHS};
use std::ops::Range;

use film::{Film, FilmError, FilterSampler};
use rayon::prelude::*;

use crate::integrator::{PathIntegrator, RayCounts};
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
    pub spectral: [(f32, f32); N_WAVELENGTHS],
    /// How many entries of `spectral` are used.
    pub n_spectral: usize,
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
    mut add: impl FnMut(PixelContribution),
) {
    for s in samples {
        let mut sampler = Sampler::new(x, y, s, seed);
        let mut wl = wavelengths.sample(sampler.next_1d() as f64);
        let (offset, weight) = filter(sampler.next_2d());
        let lens = Vec2::from(sampler.next_2d());
        let film = Vec2::new(x as f32 + 0.5, y as f32 + 0.5) + offset;
        let ray = scene.camera.generate_ray(film, lens);
        let l = integrator.li(scene, ray.origin, ray.direction, &mut wl, &mut sampler, counts);
        let l = if l.0.iter().all(|v| v.is_finite()) { l } else { spectral::SampledSpectrum::zero() };
        let xyz = wavelengths.to_xyz(&l, &wl);
        let mut spectral = [(0.0f32, 0.0f32); N_WAVELENGTHS];
        let mut n = 0;
        let pdf = wl.pdf();
        for i in 0..N_WAVELENGTHS {
            if wl.is_active(i) {
                spectral[n] = (wl.lambda(i), l[i] / pdf[i]);
                n += 1;
            }
        }
        add(PixelContribution { xyz, weight, spectral, n_spectral: n });
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

/// Renders samples `samples` of every pixel into `film`, rows in parallel (rayon). `progress` is called after each
/// row with the number of camera samples it took. The result does not depend on the number of threads: every
/// sample's random numbers depend only on (pixel, sample index, seed), and each pixel is written by one thread.
pub fn render_film(
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
    let stats = film
        .par_rows_mut()
        .map(|mut row| {
            let mut counts = RayCounts::default();
            let y = row.y();
            for x in 0..row.width() {
                render_pixel(scene, integrator, wavelengths, &filter, x, y, samples.clone(), seed, &mut counts, |c| {
                    row.add_sample(x, c.xyz, c.weight as f64, &c.spectral[..c.n_spectral]);
                });
            }
            let taken = per_pixel * row.width() as u64;
            progress(taken);
            RenderStats { samples: taken, rays: counts.intersect + counts.shadow }
        })
        .reduce(RenderStats::default, |a, b| RenderStats { samples: a.samples + b.samples, rays: a.rays + b.rays });
    Ok(stats)
}

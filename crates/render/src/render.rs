//! The per-pixel driver: camera samples through the integrator into colour and spectral contributions.

use film::SpectralEstimates;
use glam::Vec2;
use glam::Vec3;
use spectral::{Spectrum, WavelengthSampler, Xyz};
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

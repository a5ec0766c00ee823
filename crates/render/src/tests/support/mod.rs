//! Helpers shared by the render crate's tests (and, for `rgl`, its BSDF benchmark).
pub mod rgl;

pub(crate) use crate::measured::warp::Warp2D;

/// The mean of Y over pixel rows `rows` of `built`'s image, rendered at its sample count with `seed`.
pub(crate) fn mean_y(built: &crate::BuiltScene, seed: u32, rows: std::ops::Range<u32>) -> f64 {
    let mut film = film::Film::new(built.film.clone()).unwrap();
    built.integrator.render(&built.scene, &mut film, 0..built.spp, seed, &|_| {}).unwrap();
    let w = film.width();
    let n = (rows.end - rows.start) * w;
    let sum: f64 = rows.flat_map(|y| (0..w).map(move |x| (x, y))).map(|(x, y)| film.pixel_xyz(x, y).y).sum();
    sum / n as f64
}

/// Pearson's χ² of histogram `counts` of `n` draws against bin probabilities `probs`, over the bins expecting more
/// than `min_expected` draws.
pub(crate) fn chi_square_of_counts(counts: &[u32], probs: &[f64], n: u32, min_expected: f64) -> f64 {
    counts
        .iter()
        .zip(probs)
        .filter(|(_, &p)| p * n as f64 > min_expected)
        .map(|(&c, &p)| (c as f64 - p * n as f64).powi(2) / (p * n as f64))
        .sum()
}

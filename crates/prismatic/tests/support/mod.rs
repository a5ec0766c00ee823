//! What several of the command's integration tests share.

use film::Film;

/// Mean XYZ over all pixels of two renders with different seeds, and the standard error of each component
/// (pixels are independent with a box filter: SE = √Σ(aₚ − bₚ)² / 2n).
pub fn image_xyz(a: &Film, b: &Film) -> ([f64; 3], [f64; 3]) {
    let (w, h) = (a.width(), a.height());
    let n = (w * h) as f64;
    let (mut m, mut d2) = ([0.0; 3], [0.0; 3]);
    for y in 0..h {
        for x in 0..w {
            let (va, vb) = (a.pixel_xyz(x, y).to_array(), b.pixel_xyz(x, y).to_array());
            for c in 0..3 {
                m[c] += 0.5 * (va[c] + vb[c]) / n;
                d2[c] += (va[c] - vb[c]).powi(2);
            }
        }
    }
    (m, d2.map(|d| d.sqrt() / (2.0 * n)))
}

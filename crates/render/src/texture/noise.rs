//! Perlin's improved gradient noise (Perlin 2002, "Improving Noise") and the sums of its octaves that pbrt-v4's
//! procedural textures use: fractional Brownian motion and turbulence (pbrt-v4 §10.6).
//!
//! Everything is in `f32` with the lattice of Perlin's reference permutation, so a point gives the same value as in
//! pbrt-v4 and on every thread: noise is a pure function of the point.

use glam::Vec3;

/// Ken Perlin's reference permutation of 0..=255 (Perlin 2002), which pbrt-v4 uses too.
const PERM: [u8; 256] = [
    151, 160, 137, 91, 90, 15, 131, 13, 201, 95, 96, 53, 194, 233, 7, 225, 140, 36, 103, 30, 69, 142, 8, 99, 37, 240,
    21, 10, 23, 190, 6, 148, 247, 120, 234, 75, 0, 26, 197, 62, 94, 252, 219, 203, 117, 35, 11, 32, 57, 177, 33, 88,
    237, 149, 56, 87, 174, 20, 125, 136, 171, 168, 68, 175, 74, 165, 71, 134, 139, 48, 27, 166, 77, 146, 158, 231, 83,
    111, 229, 122, 60, 211, 133, 230, 220, 105, 92, 41, 55, 46, 245, 40, 244, 102, 143, 54, 65, 25, 63, 161, 1, 216,
    80, 73, 209, 76, 132, 187, 208, 89, 18, 169, 200, 196, 135, 130, 116, 188, 159, 86, 164, 100, 109, 198, 173, 186,
    3, 64, 52, 217, 226, 250, 124, 123, 5, 202, 38, 147, 118, 126, 255, 82, 85, 212, 207, 206, 59, 227, 47, 16, 58, 17,
    182, 189, 28, 42, 223, 183, 170, 213, 119, 248, 152, 2, 44, 154, 163, 70, 221, 153, 101, 155, 167, 43, 172, 9, 129,
    22, 39, 253, 19, 98, 108, 110, 79, 113, 224, 232, 178, 185, 112, 104, 218, 246, 97, 228, 251, 34, 242, 193, 238,
    210, 144, 12, 191, 179, 162, 241, 81, 51, 145, 235, 249, 14, 239, 107, 49, 192, 214, 31, 181, 199, 106, 157, 184,
    84, 204, 176, 115, 121, 50, 45, 127, 4, 150, 254, 138, 236, 205, 93, 222, 114, 67, 29, 24, 72, 243, 141, 128, 195,
    78, 66, 215, 61, 156, 180,
];

/// The permutation as a function on all integers (indices wrap modulo 256, as a doubled table does).
#[inline]
fn perm(i: i32) -> i32 {
    PERM[(i & 255) as usize] as i32
}

/// The gradient of lattice point (x, y, z) dotted with the offset (dx, dy, dz): one of the 12 edge directions of a
/// cube, chosen by hashing the point (Perlin 2002's 16-entry table, four directions repeated).
#[inline]
fn gradient(x: i32, y: i32, z: i32, dx: f32, dy: f32, dz: f32) -> f32 {
    let h = perm(perm(perm(x) + y) + z) & 15;
    let u = if h < 8 || h == 12 || h == 13 { dx } else { dy };
    let v = if h < 4 || h == 12 || h == 13 { dy } else { dz };
    (if h & 1 == 0 { u } else { -u }) + (if h & 2 == 0 { v } else { -v })
}

/// Perlin's quintic fade 6t⁵ − 15t⁴ + 10t³ (zero first and second derivatives at 0 and 1).
#[inline]
fn fade(t: f32) -> f32 {
    let t3 = t * t * t;
    6.0 * t3 * t * t - 15.0 * t3 * t + 10.0 * t3
}

#[inline]
fn lerp(t: f32, a: f32, b: f32) -> f32 {
    (1.0 - t) * a + t * b
}

/// Gradient noise at `p`: zero at every lattice point, smooth, of mean zero and within about ±1.
pub fn noise(p: Vec3) -> f32 {
    // Reduce the coordinates first so that the cell offsets stay accurate far from the origin (the lattice repeats
    // every 256 cells, so this changes nothing below 2³⁰).
    let reduce = |v: f32| v % (1u32 << 30) as f32;
    let (x, y, z) = (reduce(p.x), reduce(p.y), reduce(p.z));
    let (fx, fy, fz) = (x.floor(), y.floor(), z.floor());
    let (dx, dy, dz) = (x - fx, y - fy, z - fz);
    let (ix, iy, iz) = ((fx as i32) & 255, (fy as i32) & 255, (fz as i32) & 255);
    let w000 = gradient(ix, iy, iz, dx, dy, dz);
    let w100 = gradient(ix + 1, iy, iz, dx - 1.0, dy, dz);
    let w010 = gradient(ix, iy + 1, iz, dx, dy - 1.0, dz);
    let w110 = gradient(ix + 1, iy + 1, iz, dx - 1.0, dy - 1.0, dz);
    let w001 = gradient(ix, iy, iz + 1, dx, dy, dz - 1.0);
    let w101 = gradient(ix + 1, iy, iz + 1, dx - 1.0, dy, dz - 1.0);
    let w011 = gradient(ix, iy + 1, iz + 1, dx, dy - 1.0, dz - 1.0);
    let w111 = gradient(ix + 1, iy + 1, iz + 1, dx - 1.0, dy - 1.0, dz - 1.0);
    let (wx, wy, wz) = (fade(dx), fade(dy), fade(dz));
    let y0 = lerp(wy, lerp(wx, w000, w100), lerp(wx, w010, w110));
    let y1 = lerp(wy, lerp(wx, w001, w101), lerp(wx, w011, w111));
    lerp(wz, y0, y1)
}

/// Noise in the plane z = 0.5 (pbrt-v4's two-argument `Noise`, used by the polka dots).
pub fn noise_2d(x: f32, y: f32) -> f32 {
    noise(Vec3::new(x, y, 0.5))
}

/// Octave frequencies grow by 1.99 rather than 2 so that the octaves' lattices do not line up (pbrt-v4 §10.6.2).
const LACUNARITY: f32 = 1.99;

/// Fractional Brownian motion: Σᵢ ωⁱ·noise(1.99ⁱ·p) over `octaves` octaves (pbrt-v4's `FBm`). pbrt-v4 drops the
/// octaves finer than a ray differential's footprint; without differentials every octave is summed (the limit of a
/// vanishing footprint), and supersampling the pixel averages the finest ones away.
pub fn fbm(p: Vec3, omega: f32, octaves: u32) -> f32 {
    let (mut sum, mut lambda, mut o) = (0.0, 1.0, 1.0);
    for _ in 0..octaves {
        sum += o * noise(lambda * p);
        lambda *= LACUNARITY;
        o *= omega;
    }
    sum
}

/// Turbulence: Σᵢ ωⁱ·|noise(1.99ⁱ·p)| over `octaves` octaves, plus 0.2·ω^octaves for the octaves beyond (pbrt-v4's
/// `Turbulence` at a vanishing footprint, where the last, partial octave is replaced by 0.2, close to the mean of
/// |noise|).
pub fn turbulence(p: Vec3, omega: f32, octaves: u32) -> f32 {
    let (mut sum, mut lambda, mut o) = (0.0, 1.0, 1.0);
    for _ in 0..octaves {
        sum += o * noise(lambda * p).abs();
        lambda *= LACUNARITY;
        o *= omega;
    }
    sum + o * 0.2
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points from a fixed low-discrepancy sequence (R3, Roberts 2018) in the box [−50, 50)³.
    fn points(n: usize) -> impl Iterator<Item = Vec3> {
        let a = [0.819_172_5_f64, 0.671_043_5, 0.549_700_5];
        (0..n).map(move |i| {
            let f = |k: usize| ((0.5 + a[k] * i as f64).fract() * 100.0 - 50.0) as f32;
            Vec3::new(f(0), f(1), f(2))
        })
    }

    #[test]
    fn noise_vanishes_on_the_lattice_and_matches_its_gradient_between() {
        for p in [Vec3::ZERO, Vec3::new(3.0, -7.0, 12.0), Vec3::new(-200.0, 5.0, 1000.0)] {
            assert_eq!(noise(p), 0.0, "{p}");
        }
        // Near a lattice point the fade weights are 1 at that corner to first order, so noise ≈ g·δ with g the
        // corner's gradient. Corner (0,0,0) hashes to h = perm[perm[perm[0]]] & 15 = perm[perm[151]] & 15 =
        // perm[17] & 15 = 36 & 15 = 4: gradient (1, 0, 1), so noise(δ, 0, 0) = noise(0, 0, δ) = δ, noise(0, δ, 0) = 0.
        assert_eq!((PERM[0], PERM[151], PERM[17]), (151, 17, 36));
        let d = 1e-3;
        assert!((noise(Vec3::new(d, 0.0, 0.0)) - d).abs() < 5e-8, "{}", noise(Vec3::new(d, 0.0, 0.0)));
        assert!((noise(Vec3::new(0.0, 0.0, d)) - d).abs() < 5e-8);
        assert!(noise(Vec3::new(0.0, d, 0.0)).abs() < 5e-8);
    }

    #[test]
    fn noise_is_deterministic_bounded_and_of_mean_zero() {
        let n = 200_000;
        let (mut sum, mut sum_abs, mut max) = (0.0f64, 0.0f64, 0.0f32);
        for p in points(n) {
            let v = noise(p);
            assert_eq!(v.to_bits(), noise(p).to_bits(), "a pure function of the point");
            sum += v as f64;
            sum_abs += v.abs() as f64;
            max = max.max(v.abs());
        }
        // Improved noise with these gradients stays within about ±1.04 (analyses put the bound near 1.036).
        assert!(max <= 1.04 && max > 0.8, "max |noise| {max}");
        let mean = sum / n as f64;
        // Standard deviation of noise is about 0.2, so the mean of 2·10⁵ values has a standard error below 5e-4.
        assert!(mean.abs() < 3e-3, "mean {mean}");
        let mean_abs = sum_abs / n as f64;
        assert!(mean_abs > 0.1 && mean_abs < 0.3, "mean |noise| {mean_abs}");
        // The lattice repeats every 256 cells.
        let p = Vec3::new(1.3, 2.7, -0.4);
        assert!((noise(p) - noise(p + Vec3::new(256.0, -512.0, 256.0))).abs() < 1e-4);
    }

    #[test]
    fn octave_sums_follow_their_definitions() {
        let p = Vec3::new(0.37, -1.21, 2.9);
        let expect_fbm: f32 = (0..5).map(|i| 0.6f32.powi(i) * noise(1.99f32.powi(i) * p)).sum();
        assert!((fbm(p, 0.6, 5) - expect_fbm).abs() < 1e-6);
        let expect_turb: f32 =
            (0..5).map(|i| 0.6f32.powi(i) * noise(1.99f32.powi(i) * p).abs()).sum::<f32>() + 0.2 * 0.6f32.powi(5);
        assert!((turbulence(p, 0.6, 5) - expect_turb).abs() < 1e-6);
        // One octave is the noise itself; zero octaves leave only turbulence's 0.2.
        assert_eq!(fbm(p, 0.5, 1), noise(p));
        assert_eq!(turbulence(p, 0.5, 0), 0.2);
        // fBm's mean is zero and its values are bounded by Σ ωⁱ·1.04.
        let (mut sum, n) = (0.0f64, 50_000);
        for q in points(n) {
            let v = fbm(q, 0.5, 8);
            assert!(v.abs() <= 1.04 * 2.0);
            sum += v as f64;
        }
        assert!((sum / n as f64).abs() < 5e-3, "fbm mean {}", sum / n as f64);
    }
}

//! The per-sample random number source: Owen-scrambled Sobol points seeded by (pixel, sample index, seed).
//!
//! Every random decision of a camera sample draws the next dimension of one sampler, so the image does not depend
//! on the number of threads or the order in which pixels are rendered, and a render can be split across processes.

/// Dimensions available from the Sobol tables before falling back to hashing.
const SOBOL_DIMENSIONS: u32 = 256;
/// Samples per Sobol sequence; later indices start a fresh, independently scrambled sequence.
const SOBOL_SAMPLES: u32 = 1 << 16;

/// 32-bit integer hash (Wellons' lowbias32, public domain): well-mixed seeds from structured inputs.
pub fn hash_u32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// Combines several words into one hash.
pub fn hash_words(words: &[u32]) -> u32 {
    words.iter().fold(0x9e37_79b9u32, |h, &w| hash_u32(h ^ w.wrapping_add(0x9e37_79b9).wrapping_add(h << 6)))
}

/// Random numbers for one camera sample of one pixel.
#[derive(Clone, Debug)]
pub struct Sampler {
    seed: u32,
    index: u32,
    dimension: u32,
    /// Dimensions `4·k … 4·k + 3` computed together (`sobol_burley::sample_4d` gives the same values as four
    /// `sample` calls, with SIMD).
    block: [f32; 4],
    block_set: u32,
}

impl Sampler {
    /// The sampler of sample `sample_index` of pixel (`x`, `y`) for the render seed `seed`.
    pub fn new(x: u32, y: u32, sample_index: u32, seed: u32) -> Self {
        let block = sample_index / SOBOL_SAMPLES;
        Self {
            seed: hash_words(&[x, y, seed, block]),
            index: sample_index % SOBOL_SAMPLES,
            dimension: 0,
            block: [0.0; 4],
            block_set: u32::MAX,
        }
    }

    /// The next uniform number in [0, 1).
    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        let d = self.dimension;
        self.dimension += 1;
        // Inline: three of four draws are a lookup in the current block of four dimensions.
        if d / 4 == self.block_set {
            return self.block[(d % 4) as usize];
        }
        self.next_block(d)
    }

    /// [`Sampler::next_1d`] for dimension `d` outside the current block: computes its block (or, beyond the
    /// tables, a hash of (seed, index, dimension), uniform but not stratified).
    #[inline(never)]
    fn next_block(&mut self, d: u32) -> f32 {
        if d < SOBOL_DIMENSIONS {
            let set = d / 4;
            self.block = sobol_burley::sample_4d(self.index, set, self.seed);
            self.block_set = set;
            self.block[(d % 4) as usize]
        } else {
            let h = hash_words(&[self.seed, self.index, d]);
            (h >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
        }
    }

    /// The next two uniform numbers.
    pub fn next_2d(&mut self) -> [f32; 2] {
        [self.next_1d(), self.next_1d()]
    }

    /// How many dimensions have been drawn so far.
    pub fn dimension(&self) -> u32 {
        self.dimension
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deterministic_and_in_range() {
        let mut a = Sampler::new(3, 4, 5, 6);
        let mut b = Sampler::new(3, 4, 5, 6);
        for _ in 0..300 {
            let (x, y) = (a.next_1d(), b.next_1d());
            assert_eq!(x, y);
            assert!((0.0..1.0).contains(&x));
        }
        assert_ne!(Sampler::new(3, 4, 5, 6).next_1d(), Sampler::new(4, 3, 5, 6).next_1d());
    }

    #[test]
    fn blocks_of_four_equal_single_dimensions() {
        let mut s = Sampler::new(7, 9, 33, 2);
        let seed = hash_words(&[7, 9, 2, 0]);
        for d in 0..40 {
            assert_eq!(s.next_1d(), sobol_burley::sample(33, d, seed), "dimension {d}");
        }
    }

    #[test]
    fn samples_of_a_pixel_are_stratified() {
        // 64 Sobol samples in the first dimension: exactly one in each interval [k/64, (k+1)/64).
        let mut seen = [0u32; 64];
        for i in 0..64 {
            let u = Sampler::new(10, 20, i, 1).next_1d();
            seen[(u * 64.0) as usize] += 1;
        }
        assert!(seen.iter().all(|&c| c == 1), "{seen:?}");
        // The 2D projection of dimensions (2, 3) is stratified on a 8×8 grid.
        let mut grid = [0u32; 64];
        for i in 0..64 {
            let mut s = Sampler::new(10, 20, i, 1);
            s.next_2d();
            let [u, v] = s.next_2d();
            grid[(u * 8.0) as usize * 8 + (v * 8.0) as usize] += 1;
        }
        assert!(grid.iter().all(|&c| c == 1), "{grid:?}");
    }
}

//! The per-sample random number source: Owen-scrambled Sobol points seeded by (pixel, sample index, seed).
//!
//! Every random decision of a camera sample draws the next dimension of one sampler, so the image does not depend
//! on the number of threads or the order in which pixels are rendered, and a render can be split across processes.

/// Dimensions available from the Sobol tables before falling back to hashing.
const SOBOL_DIMENSIONS: u32 = 256;
const _: () = assert!(SOBOL_DIMENSIONS == sobol_burley::NUM_DIMENSIONS);
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

/// `sobol_burley::sample_4d` with the Sobol matrix product read from tables: the same values, bit for bit (a test
/// compares them), without the crate's loop over the set bits of the shuffled index, whose trip count is random
/// and whose exit the processor mispredicts (a large share of the sampler's time in a profile of killeroo-simple;
/// BENCHMARKS.md, "Why the sampling code is as it is"). The index shuffle, which depends only on the seed and the
/// index, is done once per sample ([`Sampler::new`]); here only the per-dimension Owen scramble (Burley 2020,
/// "Practical hash-based Owen scrambling", with `sobol_burley`'s hash and constants).
mod sobol {
    use std::sync::LazyLock;

    use sobol_burley::parts::{hash, hash_int4, owen_scramble_int4_rev, owen_scramble_rev, sobol_int4_rev, Int4};
    use sobol_burley::NUM_DIMENSION_SETS_4D;

    /// Per set of four dimensions, per nibble of the shuffled index's 16 used bits (most significant first), the
    /// XOR of the direction vectors of that nibble's set bits: the Sobol product is linear over GF(2), so the
    /// four looked-up entries XORed give `sobol_int4_rev` of the whole index. 64 KB for the 256 dimensions; a
    /// render touches the first few sets.
    type SetTable = [[[u32; 4]; 16]; 4];

    static TABLES: LazyLock<Vec<SetTable>> = LazyLock::new(|| {
        (0..NUM_DIMENSION_SETS_4D)
            .map(|set| {
                std::array::from_fn(|nibble| {
                    std::array::from_fn(|v| <[u32; 4]>::from(sobol_int4_rev((v as u32) << (28 - 4 * nibble), set)))
                })
            })
            .collect()
    });

    /// The shuffled, bit-reversed sample index of `sobol_burley::sample_4d(index, _, seed)`: the same for every
    /// set of dimensions.
    #[inline]
    pub(super) fn shuffled_index(index: u32, seed: u32) -> u32 {
        owen_scramble_rev(index.reverse_bits(), hash(seed ^ 0x79c6_8e4a))
    }

    /// `sobol_burley::sample_4d(index, set, seed)` for `shuffled = shuffled_index(index, seed)`.
    #[inline]
    pub(super) fn sample_4d(shuffled: u32, set: u32, seed: u32) -> [f32; 4] {
        let t = &TABLES[set as usize];
        let entry = |k: usize| Int4::from(t[k][((shuffled >> (28 - 4 * k)) & 15) as usize]);
        let sobol = entry(0) ^ entry(1) ^ entry(2) ^ entry(3);
        let scramble = Int4::from([seed.wrapping_mul(0x9c8f_2d3b); 4])
            ^ Int4::from([set; 4])
            ^ Int4::from([0x912f_69ba, 0x174f_18ab, 0x691e_72ca, 0xb40c_c1b8]);
        owen_scramble_int4_rev(sobol, hash_int4(scramble)).reverse_bits().to_f32_norm()
    }
}

/// Random numbers for one camera sample of one pixel.
#[derive(Clone, Debug)]
pub struct Sampler {
    seed: u32,
    /// The sample index this sampler was made for (the pass).
    pass: u32,
    index: u32,
    /// The index as the Sobol sequence of this seed shuffles it (see the `sobol` module).
    shuffled: u32,
    dimension: u32,
    /// Dimensions `4·k … 4·k + 3` computed together (as `sobol_burley::sample_4d` gives them: the same values as
    /// four `sample` calls).
    block: [f32; 4],
    block_set: u32,
}

impl Sampler {
    /// The sampler of sample `sample_index` of pixel (`x`, `y`) for the render seed `seed`.
    pub fn new(x: u32, y: u32, sample_index: u32, seed: u32) -> Self {
        let block = sample_index / SOBOL_SAMPLES;
        let (seed, index) = (hash_words(&[x, y, seed, block]), sample_index % SOBOL_SAMPLES);
        Self {
            seed,
            pass: sample_index,
            index,
            shuffled: sobol::shuffled_index(index, seed),
            dimension: 0,
            block: [0.0; 4],
            block_set: u32::MAX,
        }
    }

    /// The sample index (the pass) this sampler draws for.
    #[inline]
    pub fn sample_index(&self) -> u32 {
        self.pass
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
            self.block = sobol::sample_4d(self.shuffled, set, self.seed);
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
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_tabulated_sobol_points_equal_sobol_burleys() {
        // Every set of dimensions, indices across the 2^16 range (the low ones densely) and varied seeds.
        let mut checked = 0;
        for seed in [0u32, 1, 0x9e37_79b9, 0xffff_ffff, 12345] {
            for set in 0..SOBOL_DIMENSIONS / 4 {
                for index in (0..300).chain((300..SOBOL_SAMPLES).step_by(977)).chain([SOBOL_SAMPLES - 1]) {
                    let got = sobol::sample_4d(sobol::shuffled_index(index, seed), set, seed);
                    let want = sobol_burley::sample_4d(index, set, seed);
                    assert_eq!(got.map(f32::to_bits), want.map(f32::to_bits), "index {index}, set {set}, seed {seed}");
                    checked += 1;
                }
            }
        }
        assert!(checked > 100_000);
    }

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

//! What the geometry benchmarks share.

/// A deterministic hash to [0, 1) (a 64-bit finaliser, MurmurHash3's fmix64), for reproducible scenes and rays.
pub fn hash01(mut x: u64) -> f32 {
    x ^= x >> 33;
    x = x.wrapping_mul(0xff51_afd7_ed55_8ccd);
    x ^= x >> 33;
    x = x.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
    x ^= x >> 33;
    (x >> 40) as f32 / (1u64 << 24) as f32
}

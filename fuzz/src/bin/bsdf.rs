//! AFL++ entry point for the `bsdf` target ([`prismatic_fuzz::bsdf`]): RGL tensor files of the `measured` material.
fn main() {
    afl::fuzz!(|data: &[u8]| prismatic_fuzz::bsdf(data));
}

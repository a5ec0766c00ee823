//! AFL++ entry point for the `hdr` target ([`prismatic_fuzz::hdr`]): Radiance RGBE images.
fn main() {
    afl::fuzz!(|data: &[u8]| prismatic_fuzz::hdr(data));
}

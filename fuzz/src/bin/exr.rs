//! AFL++ entry point for the `exr` target ([`prismatic_fuzz::exr`]).
fn main() {
    afl::fuzz!(|data: &[u8]| prismatic_fuzz::exr(data));
}

//! AFL++ entry point for the `tga` target ([`prismatic_fuzz::tga`]).
fn main() {
    afl::fuzz!(|data: &[u8]| prismatic_fuzz::tga(data));
}

//! AFL++ entry point for the `pbrt` target ([`prismatic_fuzz::pbrt`]).
fn main() {
    afl::fuzz!(|data: &[u8]| prismatic_fuzz::pbrt(data));
}

//! AFL++ entry point for the `pfm` target ([`prismatic_fuzz::pfm`]).
fn main() {
    afl::fuzz!(|data: &[u8]| prismatic_fuzz::pfm(data));
}

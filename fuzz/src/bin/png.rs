//! AFL++ entry point for the `png` target ([`prismatic_fuzz::png`]).
fn main() {
    afl::fuzz!(|data: &[u8]| prismatic_fuzz::png(data));
}

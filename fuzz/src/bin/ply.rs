//! AFL++ entry point for the `ply` target ([`prismatic_fuzz::ply`]).
fn main() {
    afl::fuzz!(|data: &[u8]| prismatic_fuzz::ply(data));
}

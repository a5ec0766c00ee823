//! AFL++ entry point for the `lens` target ([`prismatic_fuzz::lens`]): lens prescription files.
fn main() {
    afl::fuzz!(|data: &[u8]| prismatic_fuzz::lens(data));
}

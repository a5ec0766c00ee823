//! AFL++ entry point for the `jpeg` target ([`prismatic_fuzz::jpeg`]): PNG and JPEG images decoded from memory.
fn main() {
    afl::fuzz!(|data: &[u8]| prismatic_fuzz::jpeg(data));
}

//! AFL++ entry point for the `gltf` target ([`prismatic_fuzz::gltf`]): glTF 2.0 files.
fn main() {
    afl::fuzz!(|data: &[u8]| prismatic_fuzz::gltf(data));
}

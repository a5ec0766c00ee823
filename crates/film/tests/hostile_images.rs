//! Hostile image files (docs/robustness.md): sizes claimed in a header are checked against the bytes present before
//! anything is allocated for them, so each of these is an error, not an abort; files that compress as well as the
//! formats allow are still read.

use film::{read_exr_rgb, read_png_linear, write_rgb, ImageError};
use std::fs;
use std::path::PathBuf;

fn scratch(name: &str, bytes: &[u8]) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("prismatic-film-hostile-{}", std::process::id()));
    fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    fs::write(&path, bytes).unwrap();
    path
}

fn malformed(r: Result<(u32, u32, Vec<[f32; 3]>), ImageError>) -> String {
    match r {
        Err(ImageError::Malformed { message, .. }) => message,
        Err(e) => panic!("expected a Malformed error, got {e}"),
        Ok((w, h, _)) => panic!("expected an error, read a {w}×{h} image"),
    }
}

/// 68 bytes whose header claims 100000×100000 RGBA pixels of 16 bits: the reader allocated the 80 GB output buffer
/// first and the process aborted.
#[test]
fn png_larger_than_its_bytes_can_hold() {
    let path = scratch("big.png", include_bytes!("hostile/png-100000x100000-in-68-bytes.png"));
    let m = malformed(read_png_linear(&path));
    assert!(m.contains("100000×100000") && m.contains("more than its 68 bytes can hold"), "{m}");
}

/// A constant 2000×2000 grey PNG deflates to about a thousandth of its raw size, near deflate's limit: still read.
#[test]
fn png_compressed_near_the_deflate_limit_is_read() {
    let (w, h) = (2000u32, 2000u32);
    let mut bytes = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut bytes, w, h);
        enc.set_color(png::ColorType::Grayscale);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_compression(png::Compression::Best);
        enc.write_header().unwrap().write_image_data(&vec![255u8; (w * h) as usize]).unwrap();
    }
    // Close to the bound: at least 500 raw bytes per file byte.
    assert!(bytes.len() * 500 < (w * (h + 1)) as usize, "{} bytes", bytes.len());
    let (rw, rh, px) = read_png_linear(&scratch("flat.png", &bytes)).unwrap();
    assert_eq!((rw, rh, px.len()), (w, h, (w * h) as usize));
    assert!(px.iter().all(|p| *p == [1.0; 3]));
}

/// 333-byte EXRs claiming 10⁹×1 and 10⁹×1000 pixels of three float channels: the decoder allocated each channel
/// (4 GB, then 4 TB) before finding the data missing, and the process aborted.
#[test]
fn exr_larger_than_its_bytes_can_hold() {
    for (name, bytes, size) in [
        ("wide.exr", &include_bytes!("hostile/exr-1e9x1-in-333-bytes.exr")[..], "1000000000×1 "),
        ("huge.exr", &include_bytes!("hostile/exr-1e9x1000-in-333-bytes.exr")[..], "1000000000×1000 "),
    ] {
        let m = malformed(read_exr_rgb(&scratch(name, bytes)));
        assert!(m.contains(size) && m.contains("more than the file's 333 bytes can hold"), "{m}");
    }
}

/// A constant 1024×1024 EXR as Prismatic writes it (lossless compression) is far below the bound and read back.
#[test]
fn exr_of_a_constant_image_is_read() {
    let (w, h) = (1024u32, 1024u32);
    let path = scratch("flat.exr", b"");
    write_rgb(&path, w, h, &vec![[0.25, 0.5, 2.0]; (w * h) as usize]).unwrap();
    let (rw, rh, px) = read_exr_rgb(&path).unwrap();
    assert_eq!((rw, rh), (w, h));
    assert!(px.iter().all(|p| *p == [0.25, 0.5, 2.0]));
}

/// Found by the fuzzer: an indexed PNG whose `PLTE` chunk holds 26 bytes (8⅔ entries); the png crate panicked
/// expanding it (CRCs recomputed so that a normal build, which checks them, reaches the palette).
#[test]
fn png_palette_of_a_fractional_number_of_entries() {
    let path = scratch("palette.png", include_bytes!("hostile/png-palette-of-26-bytes.png"));
    assert_png_error(&path, "PLTE chunk of 26 bytes");
}

/// Reading the PNG at `path` is a PNG error whose message contains `fragment`.
fn assert_png_error(path: &std::path::Path, fragment: &str) {
    match read_png_linear(path) {
        Err(ImageError::Png { message, .. }) => assert!(message.contains(fragment), "{message}"),
        r => panic!("expected a PNG error, got {:?}", r.map(|(w, h, _)| (w, h))),
    }
}

/// Found by the fuzzer: a 5×3 RGB PNG with a suggested palette (`PLTE`) of 474 entries, more than the 256 a palette
/// may have (PNG spec. §11.2.3): the png crate (0.17) copied it into a 256-entry table and panicked past its end.
#[test]
fn png_palette_of_more_than_256_entries() {
    let path = scratch("palette-474.png", include_bytes!("hostile/png-palette-of-474-entries.png"));
    assert_png_error(&path, "PLTE chunk of 1422 bytes");
}

/// Found by the fuzzer, all mutations of a tiled 5×3 B44 file: B44 blocks whose deltas wrap below zero (the decoder
/// relies on wrapping arithmetic, as OpenEXR's C++ does, and panicked where overflow checks were on) and a tile
/// whose level index the decoder asserted on. Each is read as a release build reads it, in every profile: an
/// error, or an image of the header's size.
#[test]
fn exr_b44_and_tile_level_mutations() {
    let cases: [(&str, &[u8], Option<&str>); 3] = [
        ("b44-error.exr", include_bytes!("hostile/exr-b44-wrapping-error.exr"), Some("B44")),
        ("b44-ok.exr", include_bytes!("hostile/exr-b44-wrapping-ok.exr"), None),
        ("tile-level.exr", include_bytes!("hostile/exr-tile-level-assertion.exr"), None),
    ];
    for (name, bytes, error) in cases {
        match (read_exr_rgb(&scratch(name, bytes)), error) {
            (Err(ImageError::Exr { message, .. }), Some(e)) => assert!(message.contains(e), "{name}: {message}"),
            (Ok((w, h, px)), None) => assert_eq!((w, h, px.len()), (5, 3, 15), "{name}"),
            (r, _) => panic!("{name}: unexpected {:?}", r.map(|(w, h, _)| (w, h))),
        }
    }
}

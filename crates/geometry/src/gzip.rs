//! Gzip-compressed input files. pbrt-v4 reads scene files (`.pbrt.gz`) and PLY meshes (`.ply.gz`) compressed
//! with gzip; so does Prismatic. A file is recognised by gzip's magic bytes (RFC 1952 §2.3.1), not by its name,
//! so a misnamed file works too.
//!
//! Decompression is bounded: output beyond [`MAX_DECOMPRESSED_BYTES`] is refused, so a small hostile file cannot
//! make the reader allocate without limit (a deflate stream can expand about a thousandfold).

use std::io::Read;
use std::path::Path;

use flate2::read::MultiGzDecoder;

/// The first two bytes of every gzip member (RFC 1952 §2.3.1: ID1 = 31, ID2 = 139).
pub const GZIP_MAGIC: [u8; 2] = [0x1f, 0x8b];

/// The most bytes a compressed file may expand to, and the largest file read: 2 GiB. Larger scenes or meshes should be split into several
/// files (pbrt-v4's own collection stays far below this).
pub const MAX_DECOMPRESSED_BYTES: u64 = 2 << 30;

/// True if `bytes` start with gzip's magic number.
pub fn is_gzip(bytes: &[u8]) -> bool {
    bytes.starts_with(&GZIP_MAGIC)
}

/// Decompresses gzip data (one or more concatenated members) into at most `limit` bytes. The error says what is
/// wrong: corrupt or truncated data, or output beyond the limit.
pub fn gunzip(bytes: &[u8], limit: u64) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    // Read one byte past the limit to tell "exactly the limit" from "more than the limit".
    MultiGzDecoder::new(bytes)
        .take(limit.saturating_add(1))
        .read_to_end(&mut out)
        .map_err(|e| format!("corrupt or truncated gzip data ({e})"))?;
    if out.len() as u64 > limit {
        return Err(format!("gzip data expands to more than {limit} bytes, the limit; refusing it"));
    }
    Ok(out)
}

/// Reads at most `limit` bytes of a file: a longer one is an error, so that a name such as `/dev/zero` or an endless
/// pipe cannot make the reader allocate without end. The error message does not repeat the path.
pub fn read_bounded(path: &Path, limit: u64) -> Result<Vec<u8>, String> {
    let mut bytes = Vec::new();
    // Read one byte past the limit to tell "exactly the limit" from "more than the limit".
    std::fs::File::open(path)
        .and_then(|f| f.take(limit.saturating_add(1)).read_to_end(&mut bytes))
        .map_err(|e| e.to_string())?;
    if bytes.len() as u64 > limit {
        return Err(format!("the file is larger than {limit} bytes, the limit; refusing it"));
    }
    Ok(bytes)
}

/// Reads a file of at most [`MAX_DECOMPRESSED_BYTES`] ([`read_bounded`]), decompressing it if it is gzip data (to
/// at most as many bytes). The error message does not repeat the path.
pub fn read_maybe_gzip(path: &Path) -> Result<Vec<u8>, String> {
    let bytes = read_bounded(path, MAX_DECOMPRESSED_BYTES)?;
    if is_gzip(&bytes) {
        gunzip(&bytes, MAX_DECOMPRESSED_BYTES)
    } else {
        Ok(bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use flate2::write::GzEncoder;
    use flate2::Compression;
    use std::io::Write;

    fn gz(data: &[u8]) -> Vec<u8> {
        let mut e = GzEncoder::new(Vec::new(), Compression::default());
        e.write_all(data).unwrap();
        e.finish().unwrap()
    }

    #[test]
    fn round_trip_and_concatenated_members() {
        let text = b"WorldBegin\nShape \"sphere\"\n".repeat(100);
        let z = gz(&text);
        assert!(is_gzip(&z) && !is_gzip(&text));
        assert!(z.len() < text.len() / 5);
        assert_eq!(gunzip(&z, MAX_DECOMPRESSED_BYTES).unwrap(), text);
        // Two members one after the other decompress to the two texts one after the other (RFC 1952 §2.2).
        let mut two = gz(b"abc");
        two.extend(gz(b"def"));
        assert_eq!(gunzip(&two, 100).unwrap(), b"abcdef");
    }

    /// `Include "/dev/zero"` in a scene was read without end until memory ran out (found by review while fuzzing
    /// the scene reader, docs/robustness.md); files are now read up to a limit.
    #[test]
    fn reads_stop_at_the_limit() {
        let e = read_bounded(Path::new("/dev/zero"), 1 << 20).unwrap_err();
        assert!(e.contains("larger than 1048576 bytes"), "{e}");
        let path = std::env::temp_dir().join(format!("prismatic-gzip-bounded-{}", std::process::id()));
        std::fs::write(&path, [7u8; 100]).unwrap();
        assert_eq!(read_bounded(&path, 100).unwrap(), [7u8; 100]);
        assert!(read_bounded(&path, 99).unwrap_err().contains("larger than 99 bytes"));
        let _ = std::fs::remove_file(&path);
        assert!(read_bounded(Path::new("/nonexistent/x"), 10).is_err());
    }

    #[test]
    fn corrupt_truncated_and_oversized_data_are_errors() {
        let text = vec![b'x'; 10_000];
        let z = gz(&text);
        for cut in [3, 10, z.len() / 2, z.len() - 4] {
            let e = gunzip(&z[..cut], u64::MAX).unwrap_err();
            assert!(e.contains("corrupt or truncated"), "cut at {cut}: {e}");
        }
        let mut bad = z.clone();
        let mid = bad.len() / 2;
        bad[mid] ^= 0xff;
        bad[mid + 1] ^= 0x55;
        assert!(gunzip(&bad, u64::MAX).is_err());
        // The limit: exactly 10 000 bytes pass, one fewer is refused.
        assert_eq!(gunzip(&z, 10_000).unwrap().len(), 10_000);
        let e = gunzip(&z, 9_999).unwrap_err();
        assert!(e.contains("more than 9999 bytes"), "{e}");
    }
}

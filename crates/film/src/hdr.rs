//! Reading Radiance RGBE images (`.hdr`, `.pic`): the format most environment maps are shared in.
//!
//! The format (Greg Ward, *Real Pixels*, Graphics Gems II, 1991; Radiance's `color.c` and `header.c`): a text
//! header starting `#?RADIANCE` (or `#?RGBE`), lines of `NAME=value` up to an empty line, then a resolution line,
//! then the scanlines. Each pixel is four bytes, a shared exponent after three mantissas: a value is
//! (m + ½)·2^(e − 136), and 0 where e is 0. Scanlines are stored flat, in the old run-length form (a pixel 1, 1, 1, n
//! repeats the previous pixel n·256^k times for the k-th such pixel in a row), or in the adaptive run-length form
//! (2, 2, width / 256, width % 256, then each of the four components run-length coded on its own: a count above
//! 128 repeats the next byte count − 128 times, a count up to 128 is followed by that many literal bytes).
//!
//! `FORMAT=32-bit_rle_xyze` images are converted from CIE XYZ to linear sRGB; `EXPOSURE=` values (their product is
//! what the pixels were multiplied by) are divided out, so the values read are the radiances written. The standard
//! orientation `-Y h +X w` (rows from the top) and the bottom-up `+Y h +X w` are read; any other is an error. Every
//! size is checked against the bytes present before the image is allocated.

use std::path::Path;

use crate::image_io::open_read;
use crate::ImageError;

/// The most pixels one byte of scanline data can describe: the adaptive run-length form codes a run of up to 127
/// bytes of one component in two bytes, so four components of 127 pixels take at least 8 bytes.
const MAX_PIXELS_PER_BYTE: usize = 16;

/// Reads a Radiance `.hdr` file: (width, height, linear RGB pixels row-major from the top).
pub fn read_hdr(path: &Path) -> Result<(u32, u32, Vec<[f32; 3]>), ImageError> {
    decode_hdr(&open_read(path)?, path)
}

/// Decodes Radiance RGBE bytes (`name` is what errors call them).
pub fn decode_hdr(bytes: &[u8], name: &Path) -> Result<(u32, u32, Vec<[f32; 3]>), ImageError> {
    let bad = |m: String| ImageError::Malformed { path: name.to_path_buf(), message: format!("Radiance HDR: {m}") };
    let mut pos = 0;
    let mut line = || -> Option<&[u8]> {
        let rest = bytes.get(pos..)?;
        let end = rest.iter().position(|&b| b == b'\n')?;
        pos += end + 1;
        Some(&rest[..end])
    };
    let magic = line().ok_or_else(|| bad("no header".into()))?;
    if !(magic.starts_with(b"#?RADIANCE") || magic.starts_with(b"#?RGBE")) {
        return Err(bad("the file does not start with #?RADIANCE or #?RGBE".into()));
    }
    let (mut xyz, mut exposure) = (false, 1.0f64);
    loop {
        let l = line().ok_or_else(|| bad("the header does not end (no empty line)".into()))?;
        if l.is_empty() {
            break;
        }
        let text = String::from_utf8_lossy(l);
        if let Some(format) = text.strip_prefix("FORMAT=") {
            match format.trim() {
                "32-bit_rle_rgbe" => xyz = false,
                "32-bit_rle_xyze" => xyz = true,
                other => return Err(bad(format!("unknown FORMAT '{other}'"))),
            }
        } else if let Some(e) = text.strip_prefix("EXPOSURE=") {
            let e: f64 = e.trim().parse().map_err(|_| bad(format!("EXPOSURE '{}' is not a number", e.trim())))?;
            if !(e.is_finite() && e > 0.0) {
                return Err(bad(format!("EXPOSURE must be positive, got {e}")));
            }
            exposure *= e;
        }
    }
    let resolution = line().ok_or_else(|| bad("no resolution line".into()))?;
    let words: Vec<String> = String::from_utf8_lossy(resolution).split_whitespace().map(str::to_string).collect();
    let (bottom_up, h, w) = match words.as_slice() {
        [y, h, x, w] if (y == "-Y" || y == "+Y") && x == "+X" => (y == "+Y", h, w),
        _ => {
            return Err(bad(format!(
                "resolution line '{}': only '-Y height +X width' and '+Y height +X width' are read",
                String::from_utf8_lossy(resolution)
            )))
        }
    };
    let size = |s: &str| s.parse::<usize>().ok().filter(|&v| (1..=1 << 20).contains(&v));
    let (Some(w), Some(h)) = (size(w), size(h)) else {
        return Err(bad(format!("width {w} and height {h} must be whole numbers from 1 to 2^20")));
    };
    let data = &bytes[pos..];
    let pixels = w.checked_mul(h).ok_or_else(|| bad("the size overflows".into()))?;
    if pixels > MAX_PIXELS_PER_BYTE.saturating_mul(data.len()).saturating_add(w) {
        return Err(bad(format!("a {w}×{h} image needs more data than the file's {} bytes can hold", data.len())));
    }
    let mut rgbe = vec![[0u8; 4]; pixels];
    let mut at = 0;
    for row in rgbe.chunks_exact_mut(w) {
        at = read_scanline(data, at, row).map_err(|m| bad(m.to_string()))?;
    }
    let to_float = |p: [u8; 4]| -> [f32; 3] {
        if p[3] == 0 {
            return [0.0; 3];
        }
        let f = 2f64.powi(i32::from(p[3]) - 136) / exposure;
        [(f64::from(p[0]) + 0.5) * f, (f64::from(p[1]) + 0.5) * f, (f64::from(p[2]) + 0.5) * f].map(|v| v as f32)
    };
    let mut out: Vec<[f32; 3]> = rgbe.into_iter().map(to_float).collect();
    if xyz {
        // CIE XYZ to linear sRGB (IEC 61966-2-1, D65).
        for p in &mut out {
            let [x, y, z] = *p;
            *p = [
                3.240_97 * x - 1.537_383 * y - 0.498_611 * z,
                -0.969_244 * x + 1.875_968 * y + 0.041_555 * z,
                0.055_63 * x - 0.203_977 * y + 1.056_972 * z,
            ];
        }
    }
    if bottom_up {
        let rows: Vec<&[[f32; 3]]> = out.chunks_exact(w).rev().collect();
        out = rows.concat();
    }
    Ok((w as u32, h as u32, out))
}

/// Reads one scanline of `row.len()` pixels from `data` at `at`, in whichever of the three forms it is stored;
/// returns where the next one starts.
fn read_scanline(data: &[u8], mut at: usize, row: &mut [[u8; 4]]) -> Result<usize, &'static str> {
    let w = row.len();
    let head = data.get(at..at + 4).ok_or("the scanlines are truncated")?;
    if (8..0x8000).contains(&w) && head[0] == 2 && head[1] == 2 && head[2] & 0x80 == 0 {
        if (usize::from(head[2]) << 8 | usize::from(head[3])) != w {
            return Err("a run-length scanline's width differs from the image's");
        }
        at += 4;
        for c in 0..4 {
            let mut x = 0;
            while x < w {
                let count = *data.get(at).ok_or("the scanlines are truncated")? as usize;
                at += 1;
                if count > 128 {
                    let n = count - 128;
                    let v = *data.get(at).ok_or("the scanlines are truncated")?;
                    at += 1;
                    if x + n > w {
                        return Err("a run reaches past the end of its scanline");
                    }
                    row[x..x + n].iter_mut().for_each(|p| p[c] = v);
                    x += n;
                } else {
                    if count == 0 || x + count > w {
                        return Err("a literal run is empty or reaches past the end of its scanline");
                    }
                    let src = data.get(at..at + count).ok_or("the scanlines are truncated")?;
                    row[x..x + count].iter_mut().zip(src).for_each(|(p, &v)| p[c] = v);
                    at += count;
                    x += count;
                }
            }
        }
        return Ok(at);
    }
    // Flat pixels, with the old run-length form's repeats.
    let (mut x, mut shift) = (0, 0u32);
    while x < w {
        let p = data.get(at..at + 4).ok_or("the scanlines are truncated")?;
        at += 4;
        if p[0] == 1 && p[1] == 1 && p[2] == 1 {
            if x == 0 {
                return Err("a repeat at the start of a scanline has no pixel to repeat");
            }
            let n = usize::from(p[3]).checked_shl(shift).filter(|&n| x + n <= w);
            let n = n.ok_or("a repeat reaches past the end of its scanline")?;
            let previous = row[x - 1];
            row[x..x + n].iter_mut().for_each(|q| *q = previous);
            x += n;
            shift += 8;
        } else {
            row[x] = [p[0], p[1], p[2], p[3]];
            x += 1;
            shift = 0;
        }
    }
    Ok(at)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(extra: &str, resolution: &str) -> Vec<u8> {
        let extra = if extra.is_empty() { String::new() } else { format!("{extra}\n") };
        format!("#?RADIANCE\n# made by a test\nFORMAT=32-bit_rle_rgbe\n{extra}\n{resolution}\n").into_bytes()
    }

    /// One component of a scanline in the adaptive run-length form: runs of equal bytes, else literals.
    fn rle_component(values: &[u8]) -> Vec<u8> {
        let mut out = vec![];
        let mut i = 0;
        while i < values.len() {
            let run = values[i..].iter().take(127).take_while(|&&v| v == values[i]).count();
            if run >= 3 {
                out.extend([128 + run as u8, values[i]]);
                i += run;
            } else {
                let n = (values.len() - i).min(128).min(2.max(run));
                out.push(n as u8);
                out.extend(&values[i..i + n]);
                i += n;
            }
        }
        out
    }

    #[test]
    fn rgbe_values_are_mantissa_plus_a_half_times_two_to_the_exponent() {
        // A 2×1 flat image: (128, 64, 0, 129) = (128.5, 64.5, 0.5)·2^(129−136); (9, 9, 9, 0) is black.
        let mut bytes = header("EXPOSURE=2", "-Y 1 +X 2");
        bytes.extend([128, 64, 0, 129, 9, 9, 9, 0]);
        let (w, h, px) = decode_hdr(&bytes, Path::new("t.hdr")).unwrap();
        assert_eq!((w, h), (2, 1));
        let f = 2f32.powi(-7) / 2.0;
        assert_eq!(px[0], [128.5 * f, 64.5 * f, 0.5 * f], "EXPOSURE=2 is divided out");
        assert_eq!(px[1], [0.0; 3]);
    }

    #[test]
    fn run_length_scanlines_decode_as_the_flat_ones_and_bottom_up_flips() {
        // 40×3 pixels, varying along the row with long runs, in the adaptive form; the same image flat.
        let (w, h) = (40usize, 3usize);
        let pixel = |x: usize, y: usize| [(x / 10 * 50) as u8, (y * 80) as u8, (x % 7 * 30) as u8, 130 + y as u8];
        let mut rle = header("", "-Y 3 +X 40");
        let mut flat = header("", "-Y 3 +X 40");
        let mut up = header("", "+Y 3 +X 40");
        for y in 0..h {
            rle.extend([2, 2, 0, w as u8]);
            for c in 0..4 {
                let values: Vec<u8> = (0..w).map(|x| pixel(x, y)[c]).collect();
                rle.extend(rle_component(&values));
            }
            flat.extend((0..w).flat_map(|x| pixel(x, y)));
            up.extend((0..w).flat_map(|x| pixel(x, h - 1 - y)));
        }
        let a = decode_hdr(&rle, Path::new("rle.hdr")).unwrap();
        let b = decode_hdr(&flat, Path::new("flat.hdr")).unwrap();
        let c = decode_hdr(&up, Path::new("up.hdr")).unwrap();
        assert_eq!(a, b);
        assert_eq!(a, c, "+Y stores the bottom row first");
        let v = a.2[2 * w + 35];
        let want = pixel(35, 2);
        let f = 2f32.powi(i32::from(want[3]) - 136);
        assert_eq!(v, [(f32::from(want[0]) + 0.5) * f, (f32::from(want[1]) + 0.5) * f, (f32::from(want[2]) + 0.5) * f]);
    }

    #[test]
    fn old_style_repeats_multiply_by_256_for_each_one_in_a_row() {
        // 300 pixels: one, then repeat 43 (1, 1, 1, 43) and 1·256 (1, 1, 1, 1): 1 + 43 + 256 = 300.
        let mut bytes = header("", "-Y 1 +X 300");
        bytes.extend([10, 20, 30, 128, 1, 1, 1, 43, 1, 1, 1, 1]);
        let (_, _, px) = decode_hdr(&bytes, Path::new("old.hdr")).unwrap();
        assert_eq!(px.len(), 300);
        assert!(px.iter().all(|p| *p == px[0]));
    }

    #[test]
    fn xyze_is_converted_to_srgb() {
        // D65 white (0.9505, 1, 1.089) becomes sRGB (1, 1, 1): encode it with exponent 129 (values/128·256...).
        let mut bytes = b"#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 1 +X 1\n".to_vec();
        // Mantissas for 0.9505, 1.0, 1.089 with exponent 129 (scale 2^-7): m + 0.5 = v·128.
        bytes.extend([(0.9505f32 * 128.0 - 0.5).round() as u8, 127, (1.089f32 * 128.0 - 0.5).round() as u8, 129]);
        let (_, _, px) = decode_hdr(&bytes, Path::new("xyz.hdr")).unwrap();
        for c in px[0] {
            assert!((c - 1.0).abs() < 0.01, "{:?}", px[0]);
        }
    }

    #[test]
    fn malformed_files_are_errors() {
        let cases: Vec<(Vec<u8>, &str)> = vec![
            (b"P6\n1 1\n255\n".to_vec(), "does not start"),
            (header("FORMAT=16-bit", "-Y 1 +X 1"), "unknown FORMAT"),
            (header("", "+X 1 -Y 1"), "resolution line"),
            (header("", "-Y 0 +X 1"), "whole numbers"),
            ([header("", "-Y 100000 +X 100000"), vec![0; 16]].concat(), "more data"),
            ([header("", "-Y 1 +X 2"), vec![1, 2, 3, 4]].concat(), "truncated"),
            ([header("", "-Y 1 +X 8"), vec![2, 2, 0, 9]].concat(), "width differs"),
            ([header("", "-Y 1 +X 8"), vec![2, 2, 0, 8, 137, 1]].concat(), "past the end"),
            ([header("", "-Y 1 +X 2"), vec![1, 1, 1, 5, 0, 0, 0, 0]].concat(), "no pixel to repeat"),
            ([header("", "-Y 1 +X 2"), vec![9, 9, 9, 9, 1, 1, 1, 5]].concat(), "past the end"),
        ];
        for (bytes, want) in cases {
            let e = decode_hdr(&bytes, Path::new("bad.hdr")).unwrap_err().to_string();
            assert!(e.contains(want) && e.contains("bad.hdr"), "{e} (wanted '{want}')");
        }
    }
}

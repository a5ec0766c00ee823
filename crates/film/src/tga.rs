//! Reading Truevision TGA images (image textures of pbrt-v4 scenes are often `.tga`).
//!
//! Decoded: uncompressed and run-length-encoded (RLE) true-colour (24-bit BGR, 32-bit BGRA) and 8-bit grey images,
//! with the origin at the bottom left (the default) or top left, and right-to-left rows (Truevision TGA File Format
//! Specification 2.0, 1989: header fields, image types 2, 3, 10 and 11, image descriptor bits 4 and 5).
//! Colour-mapped and 15/16-bit images are errors naming what they are.
//!
//! Every size is checked against the bytes present before anything is allocated, so a hostile header cannot make
//! the reader allocate more than a bounded multiple of the file's own size.
//!
//! [`decode_tga`] yields the raw 8-bit values; [`read_tga_linear`] decodes them with the sRGB curve, as 8-bit PNGs
//! are decoded.

use std::path::Path;

use crate::ImageError;

/// An image of 8-bit samples as stored in the file: `channels` (1 grey, 3 RGB or 4 RGBA) per pixel, rows from the
/// top, each left to right.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Image8 {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Samples per pixel: 1 (grey), 3 (RGB) or 4 (RGBA).
    pub channels: usize,
    /// `width · height · channels` samples, in R, G, B, A order.
    pub data: Vec<u8>,
}

/// The length of a TGA header (spec 2.0, fields 1–5).
const HEADER_LEN: usize = 18;
/// Pixels one RLE packet can describe (7-bit count + 1).
const MAX_RUN: usize = 128;

/// Decodes a TGA file's bytes into raw 8-bit samples. The error says what is wrong with the data.
pub fn decode_tga(bytes: &[u8]) -> Result<Image8, String> {
    let h = bytes.get(..HEADER_LEN).ok_or("truncated TGA header (18 bytes expected)")?;
    let u16_at = |i: usize| u16::from_le_bytes([h[i], h[i + 1]]) as usize;
    let id_len = h[0] as usize;
    let colour_map_type = h[1];
    let image_type = h[2];
    let (map_len, map_entry_bits) = (u16_at(5), h[7] as usize);
    let (width, height) = (u16_at(12), u16_at(14));
    let depth = h[16];
    let descriptor = h[17];

    let rle = match image_type {
        2 | 3 => false,
        10 | 11 => true,
        1 | 9 => return Err("colour-mapped TGA images are not supported (save it as true-colour or grey)".into()),
        0 => return Err("the TGA file holds no image data (image type 0)".into()),
        t => return Err(format!("unknown TGA image type {t}")),
    };
    let grey = image_type == 3 || image_type == 11;
    let channels = match (grey, depth) {
        (true, 8) => 1,
        (false, 24) => 3,
        (false, 32) => 4,
        (true, d) => return Err(format!("{d}-bit grey TGA images are not supported (8-bit only)")),
        (false, d) => return Err(format!("{d}-bit true-colour TGA images are not supported (24 or 32 bits only)")),
    };
    if width == 0 || height == 0 {
        return Err(format!("TGA image of zero size ({width}×{height})"));
    }
    // A colour map may be present even in a true-colour image (spec 2.0, field 2); it is skipped.
    let map_bytes = if colour_map_type == 1 { map_len * map_entry_bits.div_ceil(8) } else { 0 };
    let start = HEADER_LEN + id_len + map_bytes;
    let pixels = bytes.get(start..).ok_or("TGA file ends inside its image ID or colour map")?;

    let n = width.checked_mul(height).ok_or("TGA image size overflows")?;
    let bpp = channels;
    let total = n.checked_mul(bpp).ok_or("TGA image size overflows")?;
    let mut stored = if rle {
        // Each packet takes at least 1 + bpp bytes and yields at most 128 pixels: refuse a header that claims
        // more pixels than the data can hold, before allocating for them.
        let most = pixels.len() / (1 + bpp) * MAX_RUN;
        if n > most {
            return Err(format!(
                "truncated TGA data: {width}×{height} pixels cannot come from {} bytes of RLE data",
                pixels.len()
            ));
        }
        decode_rle(pixels, n, bpp)?
    } else {
        let raw = pixels.get(..total).ok_or_else(|| {
            format!("truncated TGA data: {width}×{height}×{bpp} bytes expected, {} present", pixels.len())
        })?;
        raw.to_vec()
    };

    // Stored order: B, G, R, (A) for true colour; rows from the bottom unless descriptor bit 5 is set.
    if channels >= 3 {
        for px in stored.chunks_exact_mut(bpp) {
            px.swap(0, 2);
        }
    }
    let row = width * bpp;
    let mut data = Vec::with_capacity(total);
    let top_first = descriptor & 0x20 != 0;
    let right_to_left = descriptor & 0x10 != 0;
    for y in 0..height {
        let src_y = if top_first { y } else { height - 1 - y };
        let line = &stored[src_y * row..(src_y + 1) * row];
        if right_to_left {
            for px in line.chunks_exact(bpp).rev() {
                data.extend_from_slice(px);
            }
        } else {
            data.extend_from_slice(line);
        }
    }
    stored.clear();
    Ok(Image8 { width: width as u32, height: height as u32, channels, data })
}

/// Expands RLE packets (spec 2.0, image types 9–11) into `n` pixels of `bpp` bytes. Packets may cross rows, as
/// many writers emit them.
fn decode_rle(mut src: &[u8], n: usize, bpp: usize) -> Result<Vec<u8>, String> {
    let mut out = Vec::with_capacity(n * bpp);
    let truncated = || "truncated TGA RLE data".to_string();
    while out.len() < n * bpp {
        let (&head, rest) = src.split_first().ok_or_else(truncated)?;
        let count = (head & 0x7f) as usize + 1;
        let remaining = n - out.len() / bpp;
        if count > remaining {
            return Err(format!("TGA RLE packet of {count} pixels runs past the image's end ({remaining} left)"));
        }
        if head & 0x80 != 0 {
            let px = rest.get(..bpp).ok_or_else(truncated)?;
            for _ in 0..count {
                out.extend_from_slice(px);
            }
            src = &rest[bpp..];
        } else {
            let run = rest.get(..count * bpp).ok_or_else(truncated)?;
            out.extend_from_slice(run);
            src = &rest[count * bpp..];
        }
    }
    Ok(out)
}

/// Reads a TGA file's raw 8-bit samples ([`decode_tga`]), up to [`crate::image_io::MAX_IMAGE_FILE_BYTES`].
pub fn read_tga(path: &Path) -> Result<Image8, ImageError> {
    let bytes = crate::image_io::open_read(path)?;
    decode_tga(&bytes).map_err(|message| ImageError::Malformed { path: path.to_path_buf(), message })
}

/// The linear values of 8-bit samples decoded with the sRGB curve (IEC 61966-2-1), as 8-bit PNGs are read: grey is
/// repeated in R, G and B and alpha is ignored. Pixels row-major from the top.
pub fn srgb8_to_linear(image: &Image8) -> Vec<[f32; 3]> {
    let lut: Vec<f32> = (0..256).map(|v| spectral::color::srgb_decode(v as f64 / 255.0) as f32).collect();
    samples_to_rgb(image, &lut)
}

/// RGB pixels from 8-bit samples through a 256-entry table (a colour encoding's decode): grey is repeated in R, G
/// and B and alpha is ignored. Pixels row-major from the top.
pub fn samples_to_rgb(image: &Image8, lut: &[f32]) -> Vec<[f32; 3]> {
    image
        .data
        .chunks_exact(image.channels)
        .map(|px| {
            if image.channels < 3 {
                [lut[px[0] as usize]; 3]
            } else {
                [lut[px[0] as usize], lut[px[1] as usize], lut[px[2] as usize]]
            }
        })
        .collect()
}

/// Reads a TGA image as linear RGB (sRGB-decoded 8-bit samples): (width, height, pixels row-major from the top).
pub fn read_tga_linear(path: &Path) -> Result<(u32, u32, Vec<[f32; 3]>), ImageError> {
    let image = read_tga(path)?;
    Ok((image.width, image.height, srgb8_to_linear(&image)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A header for a `w`×`h` image of `image_type` and `depth` bits with `descriptor`, and an image ID of `id`.
    fn header(image_type: u8, w: u16, h: u16, depth: u8, descriptor: u8, id: &[u8]) -> Vec<u8> {
        let mut v = vec![id.len() as u8, 0, image_type, 0, 0, 0, 0, 0, 0, 0, 0, 0];
        v.extend(w.to_le_bytes());
        v.extend(h.to_le_bytes());
        v.extend([depth, descriptor]);
        v.extend(id);
        v
    }

    #[test]
    fn uncompressed_rgb_bottom_left_origin() {
        // 2×2, rows stored bottom first, pixels as B G R.
        let mut f = header(2, 2, 2, 24, 0, b"hi");
        f.extend([3, 2, 1, 6, 5, 4]); // bottom row: (1,2,3) (4,5,6)
        f.extend([9, 8, 7, 12, 11, 10]); // top row: (7,8,9) (10,11,12)
        let im = decode_tga(&f).unwrap();
        assert_eq!((im.width, im.height, im.channels), (2, 2, 3));
        assert_eq!(im.data, [7, 8, 9, 10, 11, 12, 1, 2, 3, 4, 5, 6]);
    }

    #[test]
    fn uncompressed_rgba_top_left_and_right_to_left() {
        let mut f = header(2, 2, 1, 32, 0x20 | 8, b"");
        f.extend([3, 2, 1, 255, 6, 5, 4, 128]);
        let im = decode_tga(&f).unwrap();
        assert_eq!((im.channels, im.data.as_slice()), (4, &[1, 2, 3, 255, 4, 5, 6, 128][..]));
        // Descriptor bit 4: the stored row runs right to left.
        f[17] = 0x20 | 0x10 | 8;
        assert_eq!(decode_tga(&f).unwrap().data, [4, 5, 6, 128, 1, 2, 3, 255]);
    }

    #[test]
    fn rle_grey_and_rgb_with_packets_across_rows() {
        // 3×2 grey, top-left origin: a run of 4 × 50 (crossing into the second row), then a raw packet 7 8.
        let mut f = header(11, 3, 2, 8, 0x20, b"");
        f.extend([0x80 | 3, 50, 0x01, 7, 8]);
        let im = decode_tga(&f).unwrap();
        assert_eq!((im.channels, im.data.as_slice()), (1, &[50, 50, 50, 50, 7, 8][..]));
        // 2×2 RGB, bottom-left origin: raw packet of 1 pixel, then a run of 3.
        let mut f = header(10, 2, 2, 24, 0, b"");
        f.extend([0x00, 30, 20, 10, 0x80 | 2, 3, 2, 1]);
        let im = decode_tga(&f).unwrap();
        assert_eq!(im.data, [1, 2, 3, 1, 2, 3, 10, 20, 30, 1, 2, 3]);
    }

    #[test]
    fn linear_values_use_the_srgb_curve() {
        let mut f = header(3, 3, 1, 8, 0x20, b"");
        f.extend([0, 188, 255]);
        let px = srgb8_to_linear(&decode_tga(&f).unwrap());
        // sRGB 188/255 = 0.7373 decodes to ((0.7373 + 0.055)/1.055)^2.4 = 0.5029.
        assert_eq!(px[0], [0.0; 3]);
        assert!((px[1][0] - 0.5029).abs() < 2e-4 && px[1][0] == px[1][2], "{:?}", px[1]);
        assert_eq!(px[2], [1.0; 3]);
    }

    #[test]
    fn hostile_or_truncated_headers_are_errors_before_allocating() {
        // 65535×65535 RGBA claimed by a 20-byte file: refused from the sizes alone.
        let mut f = header(2, 65535, 65535, 32, 0, b"");
        f.extend([0, 0]);
        assert!(decode_tga(&f).unwrap_err().contains("truncated"));
        let mut f = header(10, 65535, 65535, 32, 0, b"");
        f.extend([0xff, 1, 2, 3, 4]);
        assert!(decode_tga(&f).unwrap_err().contains("cannot come from 5 bytes"));
        // An RLE packet running past the image, a raw packet cut short, a short header, an ID past the end.
        let mut f = header(11, 2, 1, 8, 0, b"");
        f.extend([0x80 | 2, 9]);
        assert!(decode_tga(&f).unwrap_err().contains("past the image"));
        let mut f = header(11, 2, 1, 8, 0, b"");
        f.extend([0x01, 9]);
        assert!(decode_tga(&f).unwrap_err().contains("truncated"));
        assert!(decode_tga(&[0; 10]).unwrap_err().contains("header"));
        let mut f = header(2, 1, 1, 24, 0, b"");
        f[0] = 200;
        assert!(decode_tga(&f).is_err());
        // Unsupported kinds say what they are.
        assert!(decode_tga(&header(1, 1, 1, 8, 0, b"")).unwrap_err().contains("colour-mapped"));
        assert!(decode_tga(&header(2, 1, 1, 16, 0, b"")).unwrap_err().contains("16-bit"));
        assert!(decode_tga(&header(2, 0, 1, 24, 0, b"")).unwrap_err().contains("zero size"));
    }

    #[test]
    fn endless_files_are_read_only_to_the_limit() {
        use crate::image_io::open_read_bounded;
        // /dev/zero never ends: reading stops one byte past the limit and says so.
        if Path::new("/dev/zero").exists() {
            let e = open_read_bounded(Path::new("/dev/zero"), 1 << 20).unwrap_err().to_string();
            assert!(e.contains("larger than 1048576 bytes"), "{e}");
        }
        // A file of exactly the limit is read whole (and decodes: here a 1×1 grey image); one byte less is refused.
        let dir = std::env::temp_dir().join(format!("prismatic-tga-limit-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut f = header(3, 1, 1, 8, 0, b"");
        f.push(77);
        let path = dir.join("one.tga");
        std::fs::write(&path, &f).unwrap();
        let bytes = open_read_bounded(&path, f.len() as u64).unwrap();
        assert_eq!(decode_tga(&bytes).unwrap().data, vec![77]);
        assert_eq!(read_tga(&path).unwrap().data, vec![77]);
        assert!(open_read_bounded(&path, f.len() as u64 - 1).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

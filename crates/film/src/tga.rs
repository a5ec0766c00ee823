//! Reading Truevision TGA images (image textures of pbrt-v4 scenes are often `.tga`).
//!
//! Decoded: uncompressed and run-length-encoded (RLE) true-colour (15/16-bit 5-5-5, 24-bit BGR, 32-bit BGRA),
//! grey (8-bit, and 16-bit grey and alpha) and colour-mapped images (8- or 16-bit indices into a map of 8-bit grey
//! or 15-, 16-, 24- or 32-bit colours, starting at its first-entry index), with the origin at the bottom left (the
//! default) or top left, and right-to-left rows (Truevision TGA File Format Specification 2.0, 1989: header
//! fields, image types 1, 2, 3, 9, 10 and 11, image descriptor bits 4 and 5). The pixel formats and 5-bit scaling
//! are those of stb_image, pbrt-v4's reader; an index outside the colour map is an error (stb_image reads entry 0).
//!
//! Every size is checked against the bytes present before anything is allocated, so a hostile header cannot make
//! the reader allocate more than a bounded multiple of the file's own size.
//!
//! [`decode_tga`] yields the raw 8-bit values; [`srgb8_texels`] reads them through the sRGB curve, as 8-bit PNGs
//! are read.

use std::path::Path;

use crate::texels::{sample_table, Texels};
use crate::ImageError;

/// An image of 8-bit samples as stored in the file: `channels` (1 grey, 2 grey and alpha, 3 RGB or 4 RGBA) per
/// pixel, rows from the top, each left to right.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Image8 {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Samples per pixel: 1 (grey), 2 (grey, alpha), 3 (RGB) or 4 (RGBA).
    pub channels: usize,
    /// `width · height · channels` samples, in R, G, B, A order.
    pub data: Vec<u8>,
}

/// The length of a TGA header (spec 2.0, fields 1–5).
const HEADER_LEN: usize = 18;
/// Pixels one RLE packet can describe (7-bit count + 1).
const MAX_RUN: usize = 128;

/// How a stored pixel (or colour-map entry) becomes samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stored {
    /// One byte of grey.
    Grey,
    /// Grey then alpha (16-bit grey images, as stb_image reads them).
    GreyAlpha,
    /// A little-endian 16-bit A-R-G-B 1-5-5-5 value (15- and 16-bit images and map entries).
    Rgb555,
    /// B, G, R.
    Bgr,
    /// B, G, R, A.
    Bgra,
}

impl Stored {
    /// The layout of a true-colour (`grey` false) or grey value of `bits` bits, as pbrt-v4's reader (stb_image)
    /// accepts it.
    fn of(bits: usize, grey: bool) -> Option<Self> {
        Some(match (bits, grey) {
            (8, _) => Stored::Grey,
            (16, true) => Stored::GreyAlpha,
            (15 | 16, false) => Stored::Rgb555,
            (24, false) => Stored::Bgr,
            (32, false) => Stored::Bgra,
            _ => return None,
        })
    }

    /// Bytes a value takes in the file.
    fn bytes(self) -> usize {
        match self {
            Stored::Grey => 1,
            Stored::GreyAlpha | Stored::Rgb555 => 2,
            Stored::Bgr => 3,
            Stored::Bgra => 4,
        }
    }

    /// Samples a value decodes to.
    fn channels(self) -> usize {
        match self {
            Stored::Grey => 1,
            Stored::GreyAlpha => 2,
            Stored::Rgb555 | Stored::Bgr => 3,
            Stored::Bgra => 4,
        }
    }

    /// Appends the samples of stored value `v` (of [`Stored::bytes`] bytes) to `out` in R, G, B, A order.
    fn decode(self, v: &[u8], out: &mut Vec<u8>) {
        match self {
            Stored::Grey | Stored::GreyAlpha => out.extend_from_slice(v),
            Stored::Rgb555 => {
                // stb_image's stbi__tga_read_rgb16: R in bits 10–14, G in 5–9, B in 0–4, each scaled by 255/31
                // (rounded down); the top bit (alpha or unused) is ignored, the image is RGB.
                let px = u16::from_le_bytes([v[0], v[1]]);
                let five = |shift: u16| (((px >> shift) & 31) as u32 * 255 / 31) as u8;
                out.extend([five(10), five(5), five(0)]);
            }
            Stored::Bgr => out.extend([v[2], v[1], v[0]]),
            Stored::Bgra => out.extend([v[2], v[1], v[0], v[3]]),
        }
    }
}

/// What a stored pixel is: a value of a layout, or an index into a colour map.
enum Pixel {
    Value(Stored),
    Index(ColourMap),
}

/// A colour map: its decoded entries and the index of the first (spec 2.0, field 4.1).
struct ColourMap {
    first: usize,
    len: usize,
    channels: usize,
    entries: Vec<u8>,
}

impl ColourMap {
    /// Appends the samples of entry `index` to `out`; an index outside the map is an error.
    fn lookup(&self, index: usize, out: &mut Vec<u8>) -> Result<(), String> {
        let k = index.checked_sub(self.first).filter(|&k| k < self.len).ok_or_else(|| {
            format!(
                "TGA colour index {index} is outside the colour map (entries {} to {})",
                self.first,
                self.first + self.len - 1
            )
        })?;
        out.extend_from_slice(&self.entries[k * self.channels..(k + 1) * self.channels]);
        Ok(())
    }
}

/// Decodes a TGA file's bytes into raw 8-bit samples. The error says what is wrong with the data.
pub fn decode_tga(bytes: &[u8]) -> Result<Image8, String> {
    let h = bytes.get(..HEADER_LEN).ok_or("truncated TGA header (18 bytes expected)")?;
    let u16_at = |i: usize| u16::from_le_bytes([h[i], h[i + 1]]) as usize;
    let id_len = h[0] as usize;
    let colour_map_type = h[1];
    let image_type = h[2];
    let (map_first, map_len, map_entry_bits) = (u16_at(3), u16_at(5), h[7] as usize);
    let (width, height) = (u16_at(12), u16_at(14));
    let depth = h[16] as usize;
    let descriptor = h[17];

    let rle = match image_type {
        1..=3 => false,
        9..=11 => true,
        0 => return Err("the TGA file holds no image data (image type 0)".into()),
        t => return Err(format!("unknown TGA image type {t}")),
    };
    let mapped = image_type & 7 == 1;
    let grey = image_type & 7 == 3;
    if width == 0 || height == 0 {
        return Err(format!("TGA image of zero size ({width}×{height})"));
    }
    // A colour map may be present even in a true-colour image (spec 2.0, field 2); it is skipped there.
    let map_bytes = if colour_map_type == 1 { map_len * map_entry_bits.div_ceil(8) } else { 0 };
    let map_start = HEADER_LEN + id_len;
    let start = map_start + map_bytes;
    let pixels = bytes.get(start..).ok_or("TGA file ends inside its image ID or colour map")?;

    // What each stored pixel is: a colour index of `depth` bits, or a value.
    let pixel = if mapped {
        if colour_map_type != 1 {
            return Err("colour-mapped TGA image without a colour map".into());
        }
        if map_len == 0 {
            return Err("colour-mapped TGA image with an empty colour map".into());
        }
        let entry = Stored::of(map_entry_bits, false).ok_or_else(|| {
            format!("TGA colour-map entries of {map_entry_bits} bits are not supported (8, 15, 16, 24 or 32)")
        })?;
        if depth != 8 && depth != 16 {
            return Err(format!("TGA colour indices of {depth} bits are not supported (8 or 16)"));
        }
        let raw = &bytes[map_start..start];
        let mut entries = Vec::with_capacity(map_len * entry.channels());
        for v in raw.chunks_exact(entry.bytes()) {
            entry.decode(v, &mut entries);
        }
        Pixel::Index(ColourMap { first: map_first, len: map_len, channels: entry.channels(), entries })
    } else {
        let what = if grey { "grey (8 or 16 bits)" } else { "true-colour (15, 16, 24 or 32 bits)" };
        let stored = Stored::of(depth, grey)
            .ok_or_else(|| format!("{depth}-bit TGA images of this type are not supported: {what}"))?;
        Pixel::Value(stored)
    };
    let (bpp, channels) = match &pixel {
        Pixel::Value(s) => (s.bytes(), s.channels()),
        Pixel::Index(map) => (depth / 8, map.channels),
    };

    let n = width.checked_mul(height).ok_or("TGA image size overflows")?;
    let total = n.checked_mul(bpp).ok_or("TGA image size overflows")?;
    let raw = if rle {
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
        pixels
            .get(..total)
            .ok_or_else(|| {
                format!("truncated TGA data: {width}×{height}×{bpp} bytes expected, {} present", pixels.len())
            })?
            .to_vec()
    };
    // Samples in R, G, B, A order, in the stored pixel order.
    let mut samples = Vec::with_capacity(n * channels);
    for v in raw.chunks_exact(bpp) {
        match &pixel {
            Pixel::Index(map) => {
                let index = if bpp == 1 { v[0] as usize } else { u16::from_le_bytes([v[0], v[1]]) as usize };
                map.lookup(index, &mut samples)?;
            }
            Pixel::Value(s) => s.decode(v, &mut samples),
        }
    }
    drop(raw);

    // Rows from the bottom unless descriptor bit 5 is set; right to left if bit 4 is.
    let row = width * channels;
    let mut data = Vec::with_capacity(n * channels);
    let top_first = descriptor & 0x20 != 0;
    let right_to_left = descriptor & 0x10 != 0;
    for y in 0..height {
        let src_y = if top_first { y } else { height - 1 - y };
        let line = &samples[src_y * row..(src_y + 1) * row];
        if right_to_left {
            for px in line.chunks_exact(channels).rev() {
                data.extend_from_slice(px);
            }
        } else {
            data.extend_from_slice(line);
        }
    }
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

/// The texels of 8-bit samples read through the sRGB curve (IEC 61966-2-1), as 8-bit PNGs are read: kept as the
/// samples with their table ([`Texels`]), grey standing for R, G and B, alpha ignored; rows from the top.
pub fn srgb8_texels(image: &Image8) -> Texels {
    let table = sample_table(spectral::color::srgb_decode);
    let px = image.data.chunks_exact(image.channels.max(1));
    if image.channels < 3 {
        Texels::Grey8 { samples: px.map(|p| p[0]).collect(), table }
    } else {
        Texels::from_rgb8(px.map(|p| [p[0], p[1], p[2]]).collect(), table)
    }
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

    /// A header for a colour-mapped `w`×`h` image of `image_type` with `index_bits`-bit indices and a map of `len`
    /// entries of `entry_bits` bits starting at index `first` (the map's bytes follow).
    fn mapped_header(
        image_type: u8,
        (first, len, entry_bits): (u16, u16, u8),
        w: u16,
        h: u16,
        index_bits: u8,
    ) -> Vec<u8> {
        let mut v = vec![0, 1, image_type];
        v.extend(first.to_le_bytes());
        v.extend(len.to_le_bytes());
        v.extend([entry_bits, 0, 0, 0, 0]);
        v.extend(w.to_le_bytes());
        v.extend(h.to_le_bytes());
        v.extend([index_bits, 0x20]);
        v
    }

    /// A 5-5-5 value's 8-bit samples as stb_image scales them: ⌊c·255/31⌋.
    fn five(c: u16) -> u8 {
        (c as u32 * 255 / 31) as u8
    }

    #[test]
    fn sixteen_and_fifteen_bit_true_colour_is_5_5_5_rgb_without_alpha() {
        // 3×1 top-left: pure red with the top (attribute) bit set, green 16 of 31, and (1, 2, 30).
        let px = [0x8000 | (31 << 10), 16 << 5, (1 << 10) | (2 << 5) | 30];
        for depth in [15, 16] {
            let mut f = header(2, 3, 1, depth, 0x20 | 1, b"");
            px.iter().for_each(|p: &u16| f.extend(p.to_le_bytes()));
            let im = decode_tga(&f).unwrap();
            assert_eq!(im.channels, 3, "{depth}-bit");
            assert_eq!(im.data, [255, 0, 0, 0, 131, 0, five(1), five(2), five(30)], "{depth}-bit");
            assert_eq!((five(1), five(2), five(30)), (8, 16, 246));
        }
        // RLE, bottom-left origin, 2×2: a run of 3 whites then one raw (0, 0, 31) blue.
        let mut f = header(10, 2, 2, 16, 0, b"");
        f.extend([0x80 | 2, 0xff, 0x7f, 0x00, 31, 0]);
        let im = decode_tga(&f).unwrap();
        assert_eq!(im.data, [255, 255, 255, 0, 0, 255, 255, 255, 255, 255, 255, 255]);
        // 16-bit grey is grey and alpha (stb_image's grey_alpha); its RGB is the grey.
        let mut f = header(3, 2, 1, 16, 0x20, b"");
        f.extend([10, 200, 250, 0]);
        let im = decode_tga(&f).unwrap();
        assert_eq!((im.channels, im.data.as_slice()), (2, &[10, 200, 250, 0][..]));
        let srgb = |v: u8| spectral::color::srgb_decode(f64::from(v) / 255.0) as f32;
        assert_eq!(srgb8_texels(&im).iter().collect::<Vec<_>>(), [[srgb(10); 3], [srgb(250); 3]]);
    }

    #[test]
    fn colour_mapped_images_look_their_indices_up_from_the_first_entry() {
        // A map of three BGR entries for indices 2, 3, 4 (first entry 2); a 2×2 image of 8-bit indices, top row
        // first: 2 3 / 4 2.
        let mut f = mapped_header(1, (2, 3, 24), 2, 2, 8);
        f.extend([30, 20, 10, 60, 50, 40, 90, 80, 70]);
        f.extend([2, 3, 4, 2]);
        let im = decode_tga(&f).unwrap();
        assert_eq!((im.width, im.height, im.channels), (2, 2, 3));
        assert_eq!(im.data, [10, 20, 30, 40, 50, 60, 70, 80, 90, 10, 20, 30]);
        // 16-bit indices into 32-bit BGRA entries 0 and 1; the image is RGBA.
        let mut f = mapped_header(1, (0, 2, 32), 3, 1, 16);
        f.extend([3, 2, 1, 4, 7, 6, 5, 8]);
        f.extend([1, 0, 0, 0, 1, 0]);
        let im = decode_tga(&f).unwrap();
        assert_eq!((im.channels, im.data.as_slice()), (4, &[5, 6, 7, 8, 1, 2, 3, 4, 5, 6, 7, 8][..]));
        // 8-bit grey entries: a grey image.
        let mut f = mapped_header(1, (0, 2, 8), 2, 1, 8);
        f.extend([17, 230, 1, 0]);
        let im = decode_tga(&f).unwrap();
        assert_eq!((im.channels, im.data.as_slice()), (1, &[230, 17][..]));
        // RLE (type 9) of 8-bit indices into 15- and 16-bit entries (first entry 1): a run of 3 × index 2, then a
        // raw packet of index 1.
        for bits in [15, 16] {
            let mut f = mapped_header(9, (1, 2, bits), 4, 1, 8);
            f.extend((31u16 << 10).to_le_bytes());
            f.extend(((3u16 << 5) | 0x8000).to_le_bytes());
            f.extend([0x80 | 2, 2, 0x00, 1]);
            let im = decode_tga(&f).unwrap();
            let g = [0, five(3), 0];
            assert_eq!(im.data, [g, g, g, [255, 0, 0]].concat(), "{bits}-bit entries");
        }
    }

    #[test]
    fn malformed_colour_maps_are_errors() {
        let good = |first: u16| {
            let mut f = mapped_header(1, (first, 2, 24), 2, 1, 8);
            f.extend([1, 2, 3, 4, 5, 6]);
            f
        };
        // Indices below the first entry or past the last.
        for (first, idx) in [(0, 2), (5, 4), (5, 7), (0, 255)] {
            let mut f = good(first);
            f.extend([first as u8, idx]);
            let e = decode_tga(&f).unwrap_err();
            assert!(e.contains(&format!("index {idx} is outside the colour map")), "{e}");
        }
        let mut f = good(0);
        f.extend([1, 0]);
        assert!(decode_tga(&f).is_ok());
        // A map cut short, or the image data.
        let f = good(0);
        assert!(decode_tga(&f[..f.len() - 1]).unwrap_err().contains("colour map"));
        assert!(decode_tga(&[&f[..], &[0]].concat()).unwrap_err().contains("truncated"));
        // Entry sizes and index sizes not supported, an empty map, a 65535-entry map claimed by a short file.
        for bits in [0, 7, 12, 48] {
            let mut f = mapped_header(1, (0, 1, bits), 1, 1, 8);
            f.extend([0; 8]);
            assert!(decode_tga(&f).unwrap_err().contains(&format!("entries of {bits} bits")), "{bits}");
        }
        let mut f = mapped_header(9, (0, 1, 24), 1, 1, 24);
        f.extend([0; 8]);
        assert!(decode_tga(&f).unwrap_err().contains("indices of 24 bits"));
        let mut f = mapped_header(1, (0, 0, 24), 1, 1, 8);
        f.extend([0; 8]);
        assert!(decode_tga(&f).unwrap_err().contains("empty colour map"));
        let mut f = mapped_header(1, (0, 65535, 32), 1, 1, 8);
        f.extend([0; 8]);
        assert!(decode_tga(&f).unwrap_err().contains("ends inside"));
    }

    #[test]
    fn linear_values_use_the_srgb_curve() {
        let mut f = header(3, 3, 1, 8, 0x20, b"");
        f.extend([0, 188, 255]);
        let px: Vec<[f32; 3]> = srgb8_texels(&decode_tga(&f).unwrap()).iter().collect();
        // sRGB 188/255 = 0.7373 decodes to ((0.7373 + 0.055)/1.055)^2.4 = 0.5029.
        assert_eq!(px[0], [0.0; 3]);
        assert!((px[1][0] - 0.5029).abs() < 2e-4 && px[1][0] == px[1][2], "{:?}", px[1]);
        assert_eq!(px[2], [1.0; 3]);
    }

    #[test]
    fn compact_texels_read_as_the_linear_values() {
        let data: Vec<u8> = (0..48u32).map(|k| (k * 37 % 256) as u8).collect();
        let srgb = |v: u8| spectral::color::srgb_decode(f64::from(v) / 255.0) as f32;
        for channels in 1..=4 {
            let image = Image8 { width: 12 / channels as u32, height: 1, channels, data: data[..12].to_vec() };
            let texels = srgb8_texels(&image);
            // Grey stands for R, G and B; alpha is ignored.
            let want: Vec<[f32; 3]> = image
                .data
                .chunks_exact(channels)
                .map(|p| if channels < 3 { [srgb(p[0]); 3] } else { [srgb(p[0]), srgb(p[1]), srgb(p[2])] })
                .collect();
            let bits = |v: Vec<[f32; 3]>| v.iter().flatten().map(|c| c.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(texels.iter().collect()), bits(want), "{channels} channels");
            assert_eq!(texels.bytes(), if channels < 3 { 12 / channels } else { 3 * 12 / channels });
        }
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
        assert!(decode_tga(&header(1, 1, 1, 8, 0, b"")).unwrap_err().contains("without a colour map"));
        assert!(decode_tga(&header(2, 1, 1, 12, 0, b"")).unwrap_err().contains("12-bit"));
        assert!(decode_tga(&header(3, 1, 1, 24, 0, b"")).unwrap_err().contains("24-bit"));
        assert!(decode_tga(&header(2, 0, 1, 24, 0, b"")).unwrap_err().contains("zero size"));
        assert!(decode_tga(&header(2, 1, 1, 16, 0, b"")).unwrap_err().contains("truncated"));
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

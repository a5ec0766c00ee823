//! Decoding PNG, JPEG and WebP images held in memory: the textures a glTF file embeds (in its binary chunk or as data
//! URIs) or names (WebP through `EXT_texture_webp`), and JPEG and WebP textures of pbrt-v4 scenes. The format is
//! recognised by its signature, not a name.
//!
//! [`decode_image_bytes`] keeps the samples as stored (8 or 16 bits, 1 to 4 channels, alpha included);
//! [`DecodedImage::to_rgb`] turns them into the linear RGB a texture reads, through a colour encoding and a choice
//! of channels (glTF's metallic-roughness texture keeps metalness in blue and roughness in green; its alpha lives
//! in the base colour texture's fourth channel).

use std::path::Path;

use crate::image_io::{check_png_palette, ColorEncoding, DEFLATE_MAX_RATIO};
use crate::texels::{sample_table, SampleTable, Texels};
use crate::ImageError;

/// The most pixels a decoded JPEG may have: 2^28, an image of 16384 × 16384 (the JPEG decoder's own default limit
/// on each side). JPEG's entropy coding can describe a large flat image in very few bytes, so, unlike PNG's, its
/// size cannot be bounded by the file's.
pub const MAX_JPEG_PIXELS: u64 = 1 << 28;

/// The most pixels one byte of a JPEG can describe: 64 pixels per block, 8 blocks per byte at one bit each.
const JPEG_PIXELS_PER_BYTE: u64 = 64 * 8;

/// The most pixels a decoded WebP may have: 2^26, an image of 8192 × 8192. Lossless WebP codes a flat image in a
/// few bytes (a one-symbol Huffman code takes no bits per pixel), so its size cannot be bounded by the file's; the
/// format's own limit, 16384 on each side, would allow a gigabyte from a hundred bytes.
pub const MAX_WEBP_PIXELS: u64 = 1 << 26;

/// An image's samples as stored: `channels` per pixel (1 grey, 2 grey and alpha, 3 RGB, 4 RGBA), rows from the top,
/// each left to right.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DecodedImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Samples per pixel: 1 to 4.
    pub channels: usize,
    /// `width · height · channels` samples.
    pub samples: Samples,
}

/// Samples of 8 or 16 bits, each kept in its own size (a decoded image lives as long as a scene's textures are
/// being built).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Samples {
    /// 8-bit samples.
    Eight(Vec<u8>),
    /// 16-bit samples.
    Sixteen(Vec<u16>),
}

impl Samples {
    /// Sample `k`. Panics if `k` is out of range.
    #[inline]
    pub fn value(&self, k: usize) -> u16 {
        match self {
            Samples::Eight(v) => u16::from(v[k]),
            Samples::Sixteen(v) => v[k],
        }
    }

    /// The number of samples.
    pub fn len(&self) -> usize {
        match self {
            Samples::Eight(v) => v.len(),
            Samples::Sixteen(v) => v.len(),
        }
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Which of an image's channels a texture reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ChannelSelect {
    /// Red, green and blue (grey replicated).
    Rgb,
    /// One channel (0 red, 1 green, 2 blue, 3 alpha), replicated to all three: a grey image's one value stands for
    /// red, green and blue, and an image without alpha is opaque (alpha 1).
    One(usize),
}

impl DecodedImage {
    /// Whether the samples have 16 bits (else 8).
    pub fn sixteen(&self) -> bool {
        matches!(self.samples, Samples::Sixteen(_))
    }

    /// Whether the image stores an alpha channel.
    pub fn has_alpha(&self) -> bool {
        self.channels == 2 || self.channels == 4
    }

    /// Where sample `c` (0 R, 1 G, 2 B, 3 A) of a pixel is stored among its channels: grey stands for R, G and B;
    /// `None` for the alpha of an image without one.
    fn slot(&self, c: usize) -> Option<usize> {
        match (self.channels, c) {
            (1 | 2, 0..=2) => Some(0),
            (2, _) => Some(1),
            (4, _) | (3, 0..=2) => Some(c),
            _ => None,
        }
    }

    /// Stored sample `c` of pixel `i` in [0, 1]; a missing alpha is 1.
    fn sample(&self, i: usize, c: usize) -> f64 {
        let Some(slot) = self.slot(c) else { return 1.0 };
        let max = if self.sixteen() { 65535.0 } else { 255.0 };
        f64::from(self.samples.value(i * self.channels + slot)) / max
    }

    /// Linear RGB pixels (rows from the top): colour channels through `encoding`, alpha as stored (alpha is linear
    /// in PNG and glTF alike).
    pub fn to_rgb(&self, encoding: ColorEncoding, select: ChannelSelect) -> Vec<[f32; 3]> {
        // 8-bit values go through the compact texels' table: 256 evaluations of the transfer function instead of
        // one per sample.
        if !self.sixteen() {
            return self.to_texels(encoding, select).iter().collect();
        }
        let n = self.width as usize * self.height as usize;
        let colour = |i: usize, c: usize| encoding.to_linear(self.sample(i, c)) as f32;
        (0..n)
            .map(|i| match select {
                ChannelSelect::Rgb => [colour(i, 0), colour(i, 1), colour(i, 2)],
                ChannelSelect::One(3) => [self.sample(i, 3) as f32; 3],
                ChannelSelect::One(c) => [colour(i, c.min(2)); 3],
            })
            .collect()
    }
}

impl DecodedImage {
    /// The texels [`DecodedImage::to_rgb`] gives, kept compact: 8-bit samples stay 8-bit, read through a table of
    /// the linear values `to_rgb` would compute, and one channel (a grey image, alpha, or one colour picked out)
    /// keeps one sample per texel. Images of 16 bits keep linear floats.
    pub fn to_texels(&self, encoding: ColorEncoding, select: ChannelSelect) -> Texels {
        let Samples::Eight(bytes) = &self.samples else {
            return Texels::from_rgb(self.to_rgb(encoding, select));
        };
        let n = self.width as usize * self.height as usize;
        let byte = |i: usize, slot: usize| bytes[i * self.channels + slot];
        // The values `to_rgb` computes: colours through the encoding, alpha as stored.
        let colour = || sample_table(|v| encoding.to_linear(v));
        let one = |c: usize, table: SampleTable| match self.slot(c) {
            Some(slot) => Texels::Grey8 { samples: (0..n).map(|i| byte(i, slot)).collect(), table },
            None => Texels::Grey8 { samples: vec![255; n], table },
        };
        match select {
            ChannelSelect::Rgb if self.channels <= 2 => one(0, colour()),
            ChannelSelect::Rgb => {
                Texels::from_rgb8((0..n).map(|i| [byte(i, 0), byte(i, 1), byte(i, 2)]).collect(), colour())
            }
            ChannelSelect::One(3) => one(3, sample_table(|v| v)),
            ChannelSelect::One(c) => one(c.min(2), colour()),
        }
    }
}

/// What format `bytes` hold, by signature: `"png"`, `"jpeg"`, `"webp"` (a RIFF container of type `WEBP`), or `None`.
pub fn sniff_format(bytes: &[u8]) -> Option<&'static str> {
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        Some("png")
    } else if bytes.starts_with(&[0xff, 0xd8, 0xff]) {
        Some("jpeg")
    } else if bytes.starts_with(b"RIFF") && bytes.get(8..12) == Some(b"WEBP") {
        Some("webp")
    } else {
        None
    }
}

/// Decodes a PNG, JPEG or WebP held in `bytes` (`name` is what errors call it: a file, or a glTF image's JSON path).
pub fn decode_image_bytes(bytes: &[u8], name: &Path) -> Result<DecodedImage, ImageError> {
    match sniff_format(bytes) {
        Some("png") => decode_png(bytes, name),
        Some("jpeg") => decode_jpeg(bytes, name),
        Some("webp") => decode_webp(bytes, name),
        _ => Err(ImageError::Malformed {
            path: name.to_path_buf(),
            message: "not a PNG, JPEG or WebP image (no signature of one is present)".into(),
        }),
    }
}

/// Decodes a WebP, lossy or lossless, with or without alpha (the first frame of an animation), with the
/// `image-webp` crate; at most [`MAX_WEBP_PIXELS`] pixels.
pub(crate) fn decode_webp(bytes: &[u8], name: &Path) -> Result<DecodedImage, ImageError> {
    let malformed = |message: String| ImageError::Malformed { path: name.to_path_buf(), message };
    let webp_err = |e: image_webp::DecodingError| malformed(format!("WebP: {e}"));
    let mut decoder = image_webp::WebPDecoder::new(std::io::Cursor::new(bytes)).map_err(webp_err)?;
    let (w, h) = decoder.dimensions();
    let pixels = u64::from(w) * u64::from(h);
    if pixels == 0 || pixels > MAX_WEBP_PIXELS {
        return Err(malformed(format!("a {w}×{h} WebP: images of 1 to {MAX_WEBP_PIXELS} pixels are read")));
    }
    let channels = if decoder.has_alpha() { 4 } else { 3 };
    let size = pixels as usize * channels;
    if decoder.output_buffer_size() != Some(size) {
        return Err(malformed(format!("WebP: the decoder's buffer for a {w}×{h} image is not {size} bytes")));
    }
    let mut buf = vec![0u8; size];
    decoder.read_image(&mut buf).map_err(webp_err)?;
    Ok(DecodedImage { width: w, height: h, channels, samples: Samples::Eight(buf) })
}

/// Decodes a PNG (8- or 16-bit; grey, grey+alpha, RGB, RGBA or palette, expanded) without touching the samples'
/// values.
///
/// The size in the header is checked against the bytes before the image is allocated: its filtered rows come out
/// of a deflate stream held in them, so they cannot exceed [`DEFLATE_MAX_RATIO`] times their length.
pub(crate) fn decode_png(bytes: &[u8], name: &Path) -> Result<DecodedImage, ImageError> {
    let png_err = |e: png::DecodingError| ImageError::Png { path: name.to_path_buf(), message: e.to_string() };
    let malformed = |message: String| ImageError::Malformed { path: name.to_path_buf(), message };
    check_png_palette(bytes).map_err(|message| ImageError::Png { path: name.to_path_buf(), message })?;
    let mut decoder = png::Decoder::new(bytes);
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().map_err(png_err)?;
    let info = reader.info();
    let raw = info.height as u128 * info.raw_row_length() as u128;
    if raw > (DEFLATE_MAX_RATIO * bytes.len() as u64) as u128 {
        return Err(malformed(format!(
            "a {}×{} PNG needs {raw} bytes of image data, more than its {} bytes can hold",
            info.width,
            info.height,
            bytes.len()
        )));
    }
    let mut buf = vec![0u8; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).map_err(png_err)?;
    let (w, h) = (info.width, info.height);
    let channels = match info.color_type {
        png::ColorType::Grayscale => 1,
        png::ColorType::GrayscaleAlpha => 2,
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        png::ColorType::Indexed => return Err(malformed("unexpanded palette".into())),
    };
    let sixteen = match info.bit_depth {
        png::BitDepth::Eight => false,
        png::BitDepth::Sixteen => true,
        d @ (png::BitDepth::One | png::BitDepth::Two | png::BitDepth::Four) => {
            return Err(malformed(format!("unexpected bit depth {d:?} after expansion")))
        }
    };
    let bytes_per_sample = if sixteen { 2 } else { 1 };
    let row = w as usize * channels;
    let stride = info.line_size;
    let line = |y: usize| {
        buf.get(y * stride..y * stride + row * bytes_per_sample).ok_or_else(|| malformed("short image data".into()))
    };
    let samples = if sixteen {
        let mut samples = Vec::with_capacity(row * h as usize);
        for y in 0..h as usize {
            samples.extend(line(y)?.chunks_exact(2).map(|b| u16::from_be_bytes([b[0], b[1]])));
        }
        Samples::Sixteen(samples)
    } else {
        let mut samples = Vec::with_capacity(row * h as usize);
        for y in 0..h as usize {
            samples.extend_from_slice(line(y)?);
        }
        Samples::Eight(samples)
    };
    Ok(DecodedImage { width: w, height: h, channels, samples })
}

/// Decodes a baseline or progressive JPEG (grey, YCbCr, CMYK or YCCK) into 8-bit RGB with the `zune-jpeg` crate,
/// refusing images of more than [`MAX_JPEG_PIXELS`] before their pixels are allocated.
pub(crate) fn decode_jpeg(bytes: &[u8], name: &Path) -> Result<DecodedImage, ImageError> {
    use zune_jpeg::zune_core::bytestream::ZCursor;
    use zune_jpeg::zune_core::colorspace::ColorSpace;
    use zune_jpeg::zune_core::options::DecoderOptions;
    let jpeg_err = |e: zune_jpeg::errors::DecodeErrors| ImageError::Malformed {
        path: name.to_path_buf(),
        message: format!("JPEG: {e:?}"),
    };
    let options = DecoderOptions::default().jpeg_set_out_colorspace(ColorSpace::RGB);
    let mut decoder = zune_jpeg::JpegDecoder::new_with_options(ZCursor::new(bytes), options);
    decoder.decode_headers().map_err(jpeg_err)?;
    let (w, h) = decoder
        .dimensions()
        .ok_or_else(|| ImageError::Malformed { path: name.to_path_buf(), message: "JPEG: no frame header".into() })?;
    let pixels = w as u64 * h as u64;
    if pixels == 0 || pixels > MAX_JPEG_PIXELS {
        return Err(ImageError::Malformed {
            path: name.to_path_buf(),
            message: format!("a {w}×{h} JPEG: images of 1 to {MAX_JPEG_PIXELS} pixels are read"),
        });
    }
    // Every 8×8 block of the first component takes at least one bit of entropy-coded data (a DC code, in baseline
    // and progressive JPEG alike), so the file's bytes bound its pixels. The decoder itself fills missing data in:
    // without this check a 326-byte file claiming 16384×16384 pixels took a minute and 6 GB (found by fuzzing).
    if pixels > JPEG_PIXELS_PER_BYTE * bytes.len() as u64 {
        return Err(ImageError::Malformed {
            path: name.to_path_buf(),
            message: format!("a {w}×{h} JPEG needs more data than its {} bytes can hold", bytes.len()),
        });
    }
    // The decoder (zune-jpeg 0.5.15) writes outside its row buffers and panics when a component other than the first
    // is sampled more finely than it (found by fuzzing). Encoders put the finest sampling on the first component
    // (luma); a file that does not is refused.
    if let Some(factors) = jpeg_sampling_factors(bytes) {
        let (h1, v1) = factors[0];
        if let Some((i, (h, v))) = factors.iter().enumerate().find(|(_, (h, v))| *h > h1 || *v > v1) {
            return Err(ImageError::Malformed {
                path: name.to_path_buf(),
                message: format!(
                    "JPEG: component {} is sampled {h}×{v}, more finely than the first ({h1}×{v1}): not supported",
                    i + 1
                ),
            });
        }
    }
    // A backstop for other such bugs: a panic in the decoder is this file's error, not the end of the render (the
    // decoder is dropped with the failed image; nothing it touched is used again).
    let data = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| decoder.decode()))
        .map_err(|_| ImageError::Malformed {
            path: name.to_path_buf(),
            message: "JPEG: the decoder failed on this malformed file".into(),
        })?
        .map_err(jpeg_err)?;
    if data.len() != pixels as usize * 3 {
        return Err(ImageError::Malformed {
            path: name.to_path_buf(),
            message: format!("JPEG: {} bytes decoded for a {w}×{h} RGB image", data.len()),
        });
    }
    Ok(DecodedImage { width: w as u32, height: h as u32, channels: 3, samples: Samples::Eight(data) })
}

/// The (horizontal, vertical) sampling factors of each component in a JPEG's first frame header, found by walking
/// the marker segments from the start of the file as the decoder does (bytes between segments are skipped up to the
/// next marker); `None` if there is no frame header before the first scan.
fn jpeg_sampling_factors(bytes: &[u8]) -> Option<Vec<(u8, u8)>> {
    let mut at = 2;
    loop {
        // Up to the next marker: 0xff followed by neither 0x00 (a stuffed byte) nor 0xff (fill).
        while bytes.get(at) != Some(&0xff) || matches!(bytes.get(at + 1), Some(0x00 | 0xff) | None) {
            if at >= bytes.len() {
                return None;
            }
            at += 1;
        }
        let marker = *bytes.get(at + 1)?;
        let length = usize::from(u16::from_be_bytes([*bytes.get(at + 2)?, *bytes.get(at + 3)?]));
        // SOF0–SOF15 except DHT (c4), JPG (c8) and DAC (cc).
        if (0xc0..=0xcf).contains(&marker) && ![0xc4, 0xc8, 0xcc].contains(&marker) {
            let n = usize::from(*bytes.get(at + 9)?);
            let factors: Option<Vec<(u8, u8)>> =
                (0..n).map(|k| bytes.get(at + 11 + 3 * k).map(|&f| (f >> 4, f & 15))).collect();
            return factors.filter(|f| !f.is_empty());
        }
        if marker == 0xda || length < 2 {
            return None;
        }
        at += 2 + length;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A PNG of `w`×`h` pixels of colour type `color` holding `data`.
    fn png_bytes(w: u32, h: u32, color: png::ColorType, depth: png::BitDepth, data: &[u8]) -> Vec<u8> {
        let mut out = vec![];
        let mut enc = png::Encoder::new(&mut out, w, h);
        enc.set_color(color);
        enc.set_depth(depth);
        enc.write_header().unwrap().write_image_data(data).unwrap();
        out
    }

    #[test]
    fn png_alpha_and_channels_are_kept_and_selected() {
        // Two RGBA pixels: (255, 128, 0, 64) and (0, 0, 255, 255).
        let bytes = png_bytes(2, 1, png::ColorType::Rgba, png::BitDepth::Eight, &[255, 128, 0, 64, 0, 0, 255, 255]);
        let img = decode_image_bytes(&bytes, Path::new("t.png")).unwrap();
        assert_eq!((img.width, img.height, img.channels, img.has_alpha()), (2, 1, 4, true));
        let alpha = img.to_rgb(ColorEncoding::Srgb, ChannelSelect::One(3));
        // Alpha is linear whatever the colour encoding: 64/255.
        assert!((alpha[0][0] - 64.0 / 255.0).abs() < 1e-6, "{alpha:?}");
        assert_eq!(alpha[1], [1.0; 3]);
        let green = img.to_rgb(ColorEncoding::Linear, ChannelSelect::One(1));
        assert!((green[0][2] - 128.0 / 255.0).abs() < 1e-6);
        let rgb = img.to_rgb(ColorEncoding::Srgb, ChannelSelect::Rgb);
        // sRGB 128/255 decodes to 0.2158605 (IEC 61966-2-1).
        assert!((rgb[0][1] - 0.215_860_5).abs() < 1e-5, "{rgb:?}");
        assert_eq!(rgb[1], [0.0, 0.0, 1.0]);
    }

    #[test]
    fn grey_sixteen_bit_png_stands_for_all_three_channels_and_is_opaque() {
        let bytes = png_bytes(1, 1, png::ColorType::Grayscale, png::BitDepth::Sixteen, &[0x80, 0x00]);
        let img = decode_image_bytes(&bytes, Path::new("g.png")).unwrap();
        assert!(img.sixteen() && !img.has_alpha());
        let v = 32768.0 / 65535.0;
        assert!(img.to_rgb(ColorEncoding::Linear, ChannelSelect::Rgb)[0].iter().all(|c| (c - v).abs() < 1e-6));
        assert_eq!(img.to_rgb(ColorEncoding::Linear, ChannelSelect::One(3))[0], [1.0; 3]);
        assert!((img.to_rgb(ColorEncoding::Linear, ChannelSelect::One(2))[0][0] - v).abs() < 1e-6);
    }

    #[test]
    fn jpeg_of_flat_colours_decodes_to_them() {
        // A committed 16×8 baseline JPEG (quality 95, 4:4:4): the left half sRGB (200, 40, 40), the right half
        // (40, 40, 200), written by Pillow.
        let bytes = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/two-colours.jpg")).unwrap();
        assert_eq!(sniff_format(&bytes), Some("jpeg"));
        let img = decode_image_bytes(&bytes, Path::new("two-colours.jpg")).unwrap();
        assert_eq!((img.width, img.height, img.channels), (16, 8, 3));
        let at = |x: usize, y: usize| (0..3).map(|c| img.samples.value((y * 16 + x) * 3 + c)).collect::<Vec<u16>>();
        for (x, want) in [(2, [200, 40, 40]), (13, [40, 40, 200])] {
            for (got, want) in at(x, 4).iter().zip(want) {
                assert!(got.abs_diff(want) <= 3, "pixel ({x}, 4): {:?} against {want:?}", at(x, 4));
            }
        }
    }

    #[test]
    fn damaged_and_unknown_images_are_errors() {
        let bytes = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/two-colours.jpg")).unwrap();
        for cut in [3, 20, 200] {
            assert!(decode_image_bytes(&bytes[..cut], Path::new("cut.jpg")).is_err(), "cut at {cut}");
        }
        // A 326-byte file (found by fuzzing) whose frame header claims far more pixels than its data can code.
        let bomb = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/jpeg-size-bomb.jpg")).unwrap();
        let e = decode_image_bytes(&bomb, Path::new("bomb.jpg")).unwrap_err().to_string();
        assert!(e.contains("more data than its 326 bytes"), "{e}");
        // Files (found by fuzzing) whose chroma is sampled more finely than their luma, on which the decoder panics.
        for (file, component) in [
            ("jpeg-fine-chroma-1.jpg", "component 3 is sampled 2×4"),
            ("jpeg-fine-chroma-2.jpg", "component 3 is sampled 4×4"),
        ] {
            let bytes = std::fs::read(format!("{}/tests/fixtures/{file}", env!("CARGO_MANIFEST_DIR"))).unwrap();
            let e = decode_image_bytes(&bytes, Path::new(file)).unwrap_err().to_string();
            assert!(e.contains(component), "{e}");
        }
        let e = decode_image_bytes(b"GIF89a....", Path::new("images[3]")).unwrap_err().to_string();
        assert!(e.contains("images[3]") && e.contains("not a PNG, JPEG or WebP"), "{e}");
        let webp =
            std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/two-colours-lossy.webp")).unwrap();
        for cut in [11, 20, 40, 60] {
            assert!(decode_image_bytes(&webp[..cut], Path::new("cut.webp")).is_err(), "cut at {cut}");
        }
        // 38 bytes of lossless WebP (written by Pillow) that decode to a flat 16383 × 8200 image.
        let bomb = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/webp-size-bomb.webp")).unwrap();
        let e = decode_image_bytes(&bomb, Path::new("bomb.webp")).unwrap_err().to_string();
        assert!(e.contains("16383×8200"), "{e}");
    }

    /// The compact texels of every channel layout, encoding and channel choice read as exactly the values of the
    /// samples over 255 (or 65535) through the encoding (alpha as it is, 1 where missing), as `to_rgb` does too, and
    /// an 8-bit image keeps 8-bit samples (one per texel where one channel is read).
    #[test]
    fn compact_texels_equal_the_linear_values_bit_for_bit() {
        let n = 37;
        for channels in 1..=4 {
            for sixteen in [false, true] {
                let values = (0..n * channels).map(|k| ((k * 97 + 13) % 256) as u16);
                let samples = if sixteen {
                    Samples::Sixteen(values.map(|v| v * 257 - v / 2).collect())
                } else {
                    Samples::Eight(values.map(|v| v as u8).collect())
                };
                let img = DecodedImage { width: n as u32, height: 1, channels, samples };
                let max = if sixteen { 65535.0 } else { 255.0 };
                // Where sample c (0–2 colour, 3 alpha) of a pixel is stored: grey stands for every colour.
                let slot = |c: usize| match (channels, c) {
                    (1 | 2, 0..=2) => Some(0),
                    (2, _) => Some(1),
                    (1 | 3, 3) => None,
                    _ => Some(c),
                };
                let value = |i: usize, c: usize| slot(c).map(|s| f64::from(img.samples.value(i * channels + s)) / max);
                for encoding in [ColorEncoding::Linear, ColorEncoding::Srgb, ColorEncoding::Gamma(2.2)] {
                    let colour = |i: usize, c: usize| encoding.to_linear(value(i, c).unwrap()) as f32;
                    let alpha = |i: usize| value(i, 3).unwrap_or(1.0) as f32;
                    for select in [0, 1, 2, 3].map(ChannelSelect::One).into_iter().chain([ChannelSelect::Rgb]) {
                        let want: Vec<[f32; 3]> = (0..n)
                            .map(|i| match select {
                                ChannelSelect::Rgb => [colour(i, 0), colour(i, 1), colour(i, 2)],
                                ChannelSelect::One(3) => [alpha(i); 3],
                                ChannelSelect::One(c) => [colour(i, c); 3],
                            })
                            .collect();
                        let texels = img.to_texels(encoding, select);
                        let got: Vec<[f32; 3]> = texels.iter().collect();
                        let bits = |v: &[[f32; 3]]| v.iter().flatten().map(|c| c.to_bits()).collect::<Vec<_>>();
                        let case = format!("{channels} channels, 16-bit {sixteen}, {encoding:?}, {select:?}");
                        assert_eq!(bits(&got), bits(&want), "{case}");
                        assert_eq!(bits(&img.to_rgb(encoding, select)), bits(&want), "to_rgb: {case}");
                        let one = select != ChannelSelect::Rgb || channels <= 2;
                        let bytes = texels.bytes();
                        let expected = match (sixteen, one) {
                            (false, true) => n,
                            (false, false) => 3 * n,
                            (true, true) => 4 * n,
                            (true, false) => 12 * n,
                        };
                        assert_eq!(bytes, expected, "{case}");
                    }
                }
            }
        }
    }

    /// Committed 16×8 WebPs written by Pillow: the left half sRGB (200, 30, 30), the right half (30, 200, 30); the
    /// lossless one with alpha 255 and 128, exactly; the lossy one (quality 90) within 6 of each value.
    #[test]
    fn webp_of_flat_colours_decodes_to_them() {
        let read = |name: &str| {
            let bytes = std::fs::read(format!("{}/tests/fixtures/{name}", env!("CARGO_MANIFEST_DIR"))).unwrap();
            assert_eq!(sniff_format(&bytes), Some("webp"));
            decode_image_bytes(&bytes, Path::new(name)).unwrap()
        };
        let lossless = read("two-colours-lossless.webp");
        assert_eq!((lossless.width, lossless.height, lossless.channels), (16, 8, 4));
        let px =
            |img: &DecodedImage, k: usize, n: usize| (0..n).map(|c| img.samples.value(k * n + c)).collect::<Vec<_>>();
        assert_eq!(px(&lossless, 4 * 16 + 2, 4), [200, 30, 30, 255]);
        assert_eq!(px(&lossless, 4 * 16 + 13, 4), [30, 200, 30, 128]);
        // A `.webp` file read as a texture: the sRGB curve applied, alpha dropped.
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/two-colours-lossless.webp");
        let (w, h, rgb) = crate::read_rgb(&path).unwrap();
        assert_eq!((w, h), (16, 8));
        let srgb = |v: u8| spectral::color::srgb_decode(f64::from(v) / 255.0) as f32;
        assert_eq!(rgb[4 * 16 + 13], [srgb(30), srgb(200), srgb(30)]);
        let lossy = read("two-colours-lossy.webp");
        assert_eq!((lossy.width, lossy.height, lossy.channels), (16, 8, 3));
        for (x, want) in [(2usize, [200u16, 30, 30]), (13, [30, 200, 30])] {
            let got = px(&lossy, 4 * 16 + x, 3);
            assert!(got.iter().zip(want).all(|(g, w)| g.abs_diff(w) <= 6), "pixel ({x}, 4): {got:?} against {want:?}");
        }
    }
}

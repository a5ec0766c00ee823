//! Writing and reading images: OpenEXR (RGB, AOV layers, and the spectral layout of Fichet et al. 2021), PNG and
//! PFM. The format follows the file extension, case-insensitively.
//!
//! Every write is atomic: the image goes to a temporary file in the destination's directory, which is flushed and
//! synced, then renamed over the destination (and the directory synced). A reader sees either the previous complete
//! file or the new complete file, never a partial one; on any error the temporary file is removed and an existing
//! destination is left untouched.
//!
//! # The spectral EXR layout
//!
//! A spectral film's EXR follows *An OpenEXR Layout for Spectral Images* (A. Fichet, R. Pacanowski, A. Wilkie,
//! JCGT 10(3), 2021) as its reference implementation (`afichet/spectral-exr`, `EXRSpectralImage.cpp`) and pbrt-v4's
//! `SpectralFilm` write it: besides `R`, `G`, `B` (linear, the film's colour space), one `FLOAT` channel per bucket
//! named `S0.<λ>nm` (Stokes component 0, i.e. unpolarised emissive radiance), the bucket's central wavelength
//! printed as C's `%f` prints a `float` (six decimals) with a comma for the decimal separator, because the dot is
//! OpenEXR's layer separator: `S0.550,000000nm`. The header carries the string attributes
//! `spectralLayoutVersion = "1.0"` and `emissiveUnits = "W.m^-2.sr^-1"`. Channel values are the bucket means of
//! spectral radiance per nm.
//!
//! The reader accepts any channel name the layout's grammar allows,
//! `S0.<digits>[,<digits>][e±<digits>][SI prefix](m|Hz)`, converting to nm.

use crate::texels::Texels;
use crate::view::{DisplayEncoding, View};
use crate::{AovImages, Film, FilmState, ImageError, PixelBounds, Plane};
use exr::prelude::{
    self as ex, AnyChannel, AnyChannels, AttributeValue, Encoding, FlatSamples, Image, ImageAttributes, Layer,
    LayerAttributes, Text, Vec2,
};
use spectral::RgbColorSpace;
use std::collections::BTreeMap;
use std::fs::{self, File};
use std::io::{BufWriter, Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// The extensions [`write_image`] understands, for error messages.
pub const SUPPORTED_EXTENSIONS: &str = "exr, png, pfm";

/// The value of the `spectralLayoutVersion` attribute written (Fichet et al. 2021).
pub const SPECTRAL_LAYOUT_VERSION: &str = "1.0";
/// The value of the `emissiveUnits` attribute written (Fichet et al. 2021; pbrt-v4 writes the same).
pub const EMISSIVE_UNITS: &str = "W.m^-2.sr^-1";

/// An image file format, chosen by extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    /// OpenEXR, 32-bit float channels, linear.
    Exr,
    /// PNG, 8-bit sRGB-encoded with dither on writing; 8 or 16 bit on reading.
    Png,
    /// Portable float map, little-endian RGB float, rows bottom to top.
    Pfm,
}

impl ImageFormat {
    /// The format named by `path`'s extension (case-insensitive), or an error naming the extension and the
    /// supported ones.
    pub fn from_path(path: &Path) -> Result<Self, ImageError> {
        let ext = path.extension().map(|e| e.to_string_lossy().into_owned()).unwrap_or_default();
        match ext.to_ascii_lowercase().as_str() {
            "exr" => Ok(ImageFormat::Exr),
            "png" => Ok(ImageFormat::Png),
            "pfm" => Ok(ImageFormat::Pfm),
            _ => Err(ImageError::UnsupportedExtension {
                path: path.to_path_buf(),
                extension: ext,
                supported: SUPPORTED_EXTENSIONS,
            }),
        }
    }
}

/// A spectral image read from an EXR in the Fichet et al. layout.
#[derive(Clone, Debug, PartialEq)]
pub struct SpectralImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The `S0` channels' wavelengths in nm, ascending.
    pub wavelengths_nm: Vec<f64>,
    /// The `S0` channels' exact names, in the order of `wavelengths_nm`.
    pub channel_names: Vec<String>,
    /// The values: `wavelengths_nm.len()` per pixel, pixel-major, rows from the top.
    pub data: Vec<f32>,
    /// The header's string attributes (such as `spectralLayoutVersion` and `emissiveUnits`).
    pub attributes: BTreeMap<String, String>,
}

impl SpectralImage {
    /// The spectrum of pixel (x, y), one value per wavelength (`None` outside the image).
    pub fn pixel(&self, x: u32, y: u32) -> Option<&[f32]> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let n = self.wavelengths_nm.len();
        let i = (y as usize * self.width as usize + x as usize) * n;
        self.data.get(i..i + n)
    }
}

/// The Fichet et al. channel name of the unpolarised emissive channel at `lambda_nm`: `S0.550,000000nm`.
pub fn spectral_channel_name(lambda_nm: f64) -> String {
    // The reference implementation prints a float with std::to_string (C's "%f"): six decimals.
    format!("S0.{:.6}nm", lambda_nm as f32).replace('.', ",").replacen(',', ".", 1)
}

/// Parses a Fichet et al. channel name: `Some((stokes component, wavelength in nm))` for an emissive channel
/// `S<0-3>.<value>[prefix](m|Hz)`, `None` for any other name.
pub fn parse_spectral_channel_name(name: &str) -> Option<(u8, f64)> {
    let rest = name.strip_prefix('S')?;
    let mut chars = rest.chars();
    let stokes = chars.next()?.to_digit(10)?;
    if stokes > 3 {
        return None;
    }
    let rest = chars.as_str().strip_prefix('.')?;
    let (rest, hertz) =
        if let Some(r) = rest.strip_suffix("Hz") { (r, true) } else { (rest.strip_suffix('m')?, false) };
    const PREFIXES: [(&str, f64); 16] = [
        ("da", 1e1),
        ("Y", 1e24),
        ("Z", 1e21),
        ("E", 1e18),
        ("P", 1e15),
        ("T", 1e12),
        ("G", 1e9),
        ("M", 1e6),
        ("k", 1e3),
        ("h", 1e2),
        ("d", 1e-1),
        ("c", 1e-2),
        ("m", 1e-3),
        ("u", 1e-6),
        ("n", 1e-9),
        ("p", 1e-12),
    ];
    let (number, multiplier) =
        PREFIXES.iter().find_map(|&(p, m)| rest.strip_suffix(p).map(|r| (r, m))).unwrap_or((rest, 1.0));
    let value = parse_layout_number(number)? * multiplier;
    let nm = if hertz { 299_792_458.0 / value * 1e9 } else { value * 1e9 };
    (nm.is_finite() && nm > 0.0).then_some((stokes as u8, nm))
}

/// `\d*,?\d*([Ee][+-]?\d+)?` with at least one digit, comma as the decimal separator.
fn parse_layout_number(s: &str) -> Option<f64> {
    let (mantissa, exponent) = match s.find(['e', 'E']) {
        Some(i) => (&s[..i], Some(&s[i + 1..])),
        None => (s, None),
    };
    let (int, frac) = mantissa.split_once(',').unwrap_or((mantissa, ""));
    let digits = |t: &str| t.bytes().all(|b| b.is_ascii_digit());
    if !(digits(int) && digits(frac)) || int.len() + frac.len() == 0 {
        return None;
    }
    if let Some(e) = exponent {
        let e = e.strip_prefix(['+', '-']).unwrap_or(e);
        if e.is_empty() || !digits(e) {
            return None;
        }
    }
    s.replace(',', ".").parse().ok()
}

// ------------------------------------------------------------------------------------------------------------------
// Atomic writes
// ------------------------------------------------------------------------------------------------------------------

static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> ImageError + '_ {
    move |source| ImageError::Io { path: path.to_path_buf(), source }
}

/// The temporary file next to `path`: `.<name>.tmp-<pid>-<n>` in the same directory.
fn temp_path(path: &Path) -> PathBuf {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "image".into());
    let n = TEMP_COUNTER.fetch_add(1, Ordering::Relaxed);
    path.with_file_name(format!(".{name}.tmp-{}-{n}", std::process::id()))
}

/// Runs `write` on a buffered temporary file beside `path`, syncs it and renames it to `path`; on any error the
/// temporary file is removed and `path` is untouched.
fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> Result<(), ImageError>,
) -> Result<(), ImageError> {
    let tmp = temp_path(path);
    let result = (|| {
        let file = File::options().write(true).create_new(true).open(&tmp).map_err(io_err(&tmp))?;
        let mut out = BufWriter::with_capacity(1 << 20, file);
        write(&mut out)?;
        let file = out.into_inner().map_err(|e| ImageError::Io { path: tmp.clone(), source: e.into_error() })?;
        file.sync_all().map_err(io_err(&tmp))?;
        drop(file);
        fs::rename(&tmp, path).map_err(io_err(path))
    })();
    match result {
        Ok(()) => {
            // Make the rename itself durable; failing to open the directory (e.g. on some platforms) is harmless.
            let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
            if let Ok(d) = File::open(dir) {
                let _ = d.sync_all();
            }
            Ok(())
        }
        Err(e) => {
            let _ = fs::remove_file(&tmp);
            Err(e)
        }
    }
}

// ------------------------------------------------------------------------------------------------------------------
// Writers
// ------------------------------------------------------------------------------------------------------------------

fn check_size(width: u32, height: u32, len: usize) -> Result<(), ImageError> {
    if width == 0 || height == 0 {
        return Err(ImageError::InvalidImage(format!("{width}×{height} has no pixels")));
    }
    if (width as usize).checked_mul(height as usize) != Some(len) {
        return Err(ImageError::InvalidImage(format!("{width}×{height} image given {len} pixels")));
    }
    Ok(())
}

/// Writes the film to `path`, the format following the extension (`.exr`, `.png`, `.pfm`, any case).
///
/// EXR: `R`, `G`, `B` in the film's colour space (with its `chromaticities` attribute), plus the spectral channels
/// and attributes of the Fichet et al. layout for a spectral film, plus `albedo.R/G/B` and `N.X/Y/Z` with AOVs,
/// or for a gbuffer film pbrt-v4's channels (`Albedo.*`, `P.*`, `dzdx`, `dzdy`, `N.*`, `Ns.*`, `u`, `v`,
/// `Variance.*`, `RelativeVariance.*`). PNG and PFM hold the RGB image only.
pub fn write_image(film: &Film, path: &Path) -> Result<(), ImageError> {
    write_image_with(film, path, &[])
}

/// [`write_image`] with extra text attributes in an EXR's header (name, value), such as the samples per pixel a
/// render achieved; other formats have no header and ignore them.
pub fn write_image_with(film: &Film, path: &Path, extra_attributes: &[(String, String)]) -> Result<(), ImageError> {
    let format = ImageFormat::from_path(path)?;
    let bounds = film.bounds();
    let (w, h) = (bounds.width(), bounds.height());
    match format {
        ImageFormat::Png => {
            let display = DisplayEncoding::new(&film.spec().color_space, film.spec().view);
            write_atomic(path, |out| encode_png(out, path, w, h, &film.to_rgb_image(), &display))
        }
        ImageFormat::Pfm => write_atomic(path, |out| encode_pfm(out, path, w, h, &film.to_rgb_image())),
        ImageFormat::Exr => {
            let exr = film_exr(film, extra_attributes);
            write_atomic(path, |out| encode_exr(out, path, w, h, exr))
        }
    }
}

/// The channels, attributes and windows of a film's EXR (see [`write_image`]).
fn film_exr(film: &Film, extra_attributes: &[(String, String)]) -> ExrContent {
    let bounds = film.bounds();
    let rgb = film.to_rgb_image();
    let npix = rgb.len();
    let mut channels: Vec<(String, Vec<f32>)> = Vec::new();
    for (c, name) in ["R", "G", "B"].iter().enumerate() {
        channels.push((name.to_string(), rgb.iter().map(|p| p[c]).collect()));
    }
    // The interleaved copy is not needed once the channels exist: at 1080×1080 it is 14 MB of peak memory.
    drop(rgb);
    let mut attributes = extra_attributes.to_vec();
    let nb = film.nbuckets();
    if nb > 0 {
        let spectral = film.to_spectral_image();
        for (b, lambda) in film.spec().kind.bucket_centres().into_iter().enumerate() {
            let values = (0..npix).map(|i| spectral[i * nb + b]).collect();
            channels.push((spectral_channel_name(lambda), values));
        }
        attributes.push(("spectralLayoutVersion".to_string(), SPECTRAL_LAYOUT_VERSION.to_string()));
        attributes.push(("emissiveUnits".to_string(), EMISSIVE_UNITS.to_string()));
    }
    if let Some(AovImages { albedo, normal }) = film.to_aov_images() {
        let c = &mut channels;
        match film.to_gbuffer_images() {
            // pbrt-v4's GBufferFilm::GetImage: its channel names, in its order.
            Some(g) => {
                push_channels(c, ["Albedo.R", "Albedo.G", "Albedo.B"], &albedo);
                push_channels(c, ["P.X", "P.Y", "P.Z"], &g.p);
                push_channels(c, ["dzdx", "dzdy"], &g.dz);
                push_channels(c, ["N.X", "N.Y", "N.Z"], &g.n);
                push_channels(c, ["Ns.X", "Ns.Y", "Ns.Z"], &normal);
                push_channels(c, ["u", "v"], &g.uv);
                push_channels(c, ["Variance.R", "Variance.G", "Variance.B"], &g.variance);
                let relative = ["RelativeVariance.R", "RelativeVariance.G", "RelativeVariance.B"];
                push_channels(c, relative, &g.relative_variance);
            }
            None => {
                push_channels(c, ["albedo.R", "albedo.G", "albedo.B"], &albedo);
                push_channels(c, ["N.X", "N.Y", "N.Z"], &normal);
            }
        }
    }
    let cs = &film.spec().color_space;
    let chroma = ex::attribute::Chromaticities {
        red: Vec2(cs.primaries[0][0] as f32, cs.primaries[0][1] as f32),
        green: Vec2(cs.primaries[1][0] as f32, cs.primaries[1][1] as f32),
        blue: Vec2(cs.primaries[2][0] as f32, cs.primaries[2][1] as f32),
        white: Vec2(cs.white[0] as f32, cs.white[1] as f32),
    };
    // pbrt-v4 writes a crop as the data window inside a display window of the full image.
    let windows = ExrWindows {
        position: (bounds.x0, bounds.y0),
        display: (film.width(), film.height()),
        half: film.spec().write_fp16,
    };
    ExrContent { channels, bits: Vec::new(), attributes, chromaticities: Some(chroma), windows }
}

/// Appends one channel per component of `values`, named `names`.
fn push_channels<const N: usize>(channels: &mut Vec<(String, Vec<f32>)>, names: [&str; N], values: &[[f32; N]]) {
    for (c, name) in names.iter().enumerate() {
        channels.push((name.to_string(), values.iter().map(|p| p[c]).collect()));
    }
}

/// What an EXR file holds: float channels, 32-bit unsigned integer channels, text attributes, chromaticities and
/// windows.
struct ExrContent {
    channels: Vec<(String, Vec<f32>)>,
    bits: Vec<(String, Vec<u32>)>,
    attributes: Vec<(String, String)>,
    chromaticities: Option<ex::attribute::Chromaticities>,
    windows: ExrWindows,
}

/// The prefix of the channels of a render part that hold the film's accumulators.
const PART_PREFIX: &str = "sum.";
/// Attributes of a render part that hold the film's counts (light paths as the hexadecimal bits of an `f64`).
const PART_LIGHT_PATHS: &str = "sum.lightPaths";
const PART_REJECTED: &str = "sum.rejectedSamples";
const PART_REJECTED_SPLATS: &str = "sum.rejectedSplats";

/// Writes a *part* of a render: the EXR of [`write_image_with`] (the part's own image, to look at) plus the
/// film's unnormalised accumulators ([`Film::state`]), each `f64` plane exactly, as two `UINT` channels
/// `sum.<plane>.hi` and `sum.<plane>.lo` holding the high and low 32 bits of its IEEE 754 binary64 bits, and the
/// film's counts as text attributes `sum.lightPaths` (hexadecimal `f64` bits), `sum.rejectedSamples` and
/// `sum.rejectedSplats`. [`read_part`] reads them back bit for bit, so parts add up to the film one process would
/// have accumulated. The path must end in `.exr`.
pub fn write_part(film: &Film, path: &Path, extra_attributes: &[(String, String)]) -> Result<(), ImageError> {
    if ImageFormat::from_path(path)? != ImageFormat::Exr {
        return Err(ImageError::InvalidImage(format!("{}: a render part is an .exr file", path.display())));
    }
    let state = film.state();
    let mut exr = film_exr(film, extra_attributes);
    // Full precision: the sums are data, not a picture.
    exr.windows.half = false;
    for plane in &state.planes {
        let hi = plane.values.iter().map(|v| (v.to_bits() >> 32) as u32).collect();
        let lo = plane.values.iter().map(|v| v.to_bits() as u32).collect();
        exr.bits.push((format!("{PART_PREFIX}{}.hi", plane.name), hi));
        exr.bits.push((format!("{PART_PREFIX}{}.lo", plane.name), lo));
    }
    exr.attributes.push((PART_LIGHT_PATHS.into(), format!("{:016x}", state.light_paths.to_bits())));
    exr.attributes.push((PART_REJECTED.into(), state.rejected_samples.to_string()));
    exr.attributes.push((PART_REJECTED_SPLATS.into(), state.rejected_splats.to_string()));
    let b = film.bounds();
    write_atomic(path, |out| encode_exr(out, path, b.width(), b.height(), exr))
}

/// Reads a render part written by [`write_part`]: its text attributes and the film state it stores (the pixels
/// of its data window, in full-image coordinates). Anything else (a plain image, a truncated file, planes of
/// different sizes, missing halves, bad counts) is an error.
pub fn read_part(path: &Path) -> Result<(BTreeMap<String, String>, FilmState), ImageError> {
    let image = read_exr(path)?;
    let malformed = |message: String| ImageError::Malformed { path: path.to_path_buf(), message };
    let (w, h) = exr_size(path, &image)?;
    let origin = image.layer_data.attributes.layer_position;
    let (x0, y0) = match (u32::try_from(origin.0), u32::try_from(origin.1)) {
        (Ok(x), Ok(y)) if x.checked_add(w).is_some() && y.checked_add(h).is_some() => (x, y),
        _ => return Err(malformed(format!("data window at ({}, {}) is not a part of an image", origin.0, origin.1))),
    };
    let mut attributes = BTreeMap::new();
    for (name, value) in image.attributes.other.iter().chain(image.layer_data.attributes.other.iter()) {
        if let AttributeValue::Text(t) = value {
            attributes.insert(name.to_string(), t.to_string());
        }
    }
    let npix = w as usize * h as usize;
    let mut halves: BTreeMap<String, [Option<&[u32]>; 2]> = BTreeMap::new();
    for c in &image.layer_data.channel_data.list {
        let name = c.name.to_string();
        let Some(rest) = name.strip_prefix(PART_PREFIX) else { continue };
        let (plane, half) = match (rest.strip_suffix(".hi"), rest.strip_suffix(".lo")) {
            (Some(p), _) => (p, 0),
            (_, Some(p)) => (p, 1),
            _ => return Err(malformed(format!("channel {name} is not a half of a stored sum"))),
        };
        let FlatSamples::U32(values) = &c.sample_data else {
            return Err(malformed(format!("channel {name} is not a UINT channel")));
        };
        if values.len() != npix {
            return Err(malformed(format!("channel {name} has {} values for {w}×{h} pixels", values.len())));
        }
        halves.entry(plane.to_string()).or_default()[half] = Some(values.as_slice());
    }
    if halves.is_empty() {
        return Err(malformed("no sum.* channels: not a render part (write one with render --shard)".into()));
    }
    let mut planes = Vec::with_capacity(halves.len());
    for (name, pair) in halves {
        let [Some(hi), Some(lo)] = pair else { return Err(malformed(format!("sum.{name} lacks a half"))) };
        let values = hi.iter().zip(lo).map(|(&a, &b)| f64::from_bits((a as u64) << 32 | b as u64)).collect();
        planes.push(Plane { name, values });
    }
    let get = |key: &str| attributes.get(key).ok_or_else(|| malformed(format!("no '{key}' attribute")));
    let light_paths = u64::from_str_radix(get(PART_LIGHT_PATHS)?, 16)
        .map(f64::from_bits)
        .map_err(|_| malformed(format!("'{PART_LIGHT_PATHS}' is not hexadecimal f64 bits")))?;
    let count = |key: &str| -> Result<u64, ImageError> {
        get(key)?.parse().map_err(|_| malformed(format!("'{key}' is not a count")))
    };
    let state = FilmState {
        bounds: PixelBounds { x0, x1: x0 + w, y0, y1: y0 + h },
        planes,
        light_paths,
        rejected_samples: count(PART_REJECTED)?,
        rejected_splats: count(PART_REJECTED_SPLATS)?,
    };
    Ok((attributes, state))
}

/// Writes `bytes` to `path` atomically, as images are written (a synced temporary file renamed over `path`): a
/// reader, or a process killed at any moment, sees the old file or the new one, never a part.
pub fn write_file_atomic(path: &Path, bytes: &[u8]) -> Result<(), ImageError> {
    write_atomic(path, |out| out.write_all(bytes).map_err(io_err(path)))
}

/// Where an EXR's pixels lie and how they are stored: the data window's top-left corner in the display window,
/// the display window's size, and whether channels are 16-bit half floats.
#[derive(Clone, Copy, Debug)]
struct ExrWindows {
    position: (u32, u32),
    display: (u32, u32),
    half: bool,
}

impl ExrWindows {
    /// A whole image of `width`×`height` 32-bit float pixels.
    fn whole(width: u32, height: u32) -> Self {
        Self { position: (0, 0), display: (width, height), half: false }
    }
}

/// Writes a linear sRGB image (row-major from the top) to `path`, the format following the extension: EXR with
/// `R`, `G`, `B`; PNG sRGB-encoded and dithered, each channel clipped to [0, 1] ([`View::Clip`], so values in range
/// round-trip to within one 8-bit step; a render's display image goes through [`write_image`] or
/// [`write_display_png`] and its view); PFM.
pub fn write_rgb(path: &Path, width: u32, height: u32, pixels: &[[f32; 3]]) -> Result<(), ImageError> {
    let format = ImageFormat::from_path(path)?;
    check_size(width, height, pixels.len())?;
    match format {
        ImageFormat::Png => {
            let display = DisplayEncoding::new(&RgbColorSpace::srgb(), View::Clip);
            write_atomic(path, |out| encode_png(out, path, width, height, pixels, &display))
        }
        ImageFormat::Pfm => write_atomic(path, |out| encode_pfm(out, path, width, height, pixels)),
        ImageFormat::Exr => {
            let channels = ["R", "G", "B"]
                .iter()
                .enumerate()
                .map(|(c, n)| (n.to_string(), pixels.iter().map(|p| p[c]).collect()))
                .collect();
            let exr = ExrContent {
                channels,
                bits: Vec::new(),
                attributes: Vec::new(),
                chromaticities: None,
                windows: ExrWindows::whole(width, height),
            };
            write_atomic(path, |out| encode_exr(out, path, width, height, exr))
        }
    }
}

fn text(path: &Path, s: &str) -> Result<Text, ImageError> {
    Text::new_or_none(s).ok_or_else(|| ImageError::Exr {
        path: path.to_path_buf(),
        message: format!("'{s}' cannot be stored as OpenEXR text"),
    })
}

fn encode_exr(
    out: &mut BufWriter<File>,
    path: &Path,
    width: u32,
    height: u32,
    exr: ExrContent,
) -> Result<(), ImageError> {
    let ExrContent { channels, bits, attributes, chromaticities, windows } = exr;
    let samples = |values: Vec<f32>| {
        if windows.half {
            // Half floats top out at 65504; larger values are clamped to it, as pbrt-v4 does.
            FlatSamples::F16(values.into_iter().map(|v| ex::f16::from_f32(v.clamp(-65504.0, 65504.0))).collect())
        } else {
            FlatSamples::F32(values)
        }
    };
    let mut list = channels
        .into_iter()
        .map(|(name, values)| Ok(AnyChannel::new(text(path, &name)?, samples(values))))
        .collect::<Result<Vec<_>, ImageError>>()?;
    for (name, values) in bits {
        list.push(AnyChannel::new(text(path, &name)?, FlatSamples::U32(values)));
    }
    let mut layer_attributes = LayerAttributes::default();
    for (name, value) in &attributes {
        layer_attributes.other.insert(text(path, name)?, AttributeValue::Text(text(path, value)?));
    }
    layer_attributes.layer_position = Vec2(windows.position.0 as i32, windows.position.1 as i32);
    let size = (width as usize, height as usize);
    let layer = Layer::new(size, layer_attributes, Encoding::SMALL_LOSSLESS, AnyChannels::sort(list.into()));
    let display = (windows.display.0 as usize, windows.display.1 as usize);
    let mut image_attributes = ImageAttributes::new(ex::IntegerBounds::from_dimensions(display));
    image_attributes.chromaticities = chromaticities;
    let image = Image::new(image_attributes, layer);
    use exr::prelude::WritableImage;
    image.write().to_buffered(out).map_err(|e| ImageError::Exr { path: path.to_path_buf(), message: e.to_string() })
}

/// A uniform number in [0, 1) from a hash of (x, y, channel): the PNG dither, deterministic and uncorrelated
/// between neighbouring pixels.
pub(crate) fn dither_u(x: u32, y: u32, channel: u32) -> f64 {
    fn mix(mut z: u64) -> u64 {
        // splitmix64's finaliser.
        z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    let h = mix(mix(mix(x as u64) ^ y as u64) ^ channel as u64);
    (h >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

fn encode_png(
    out: &mut impl Write,
    path: &Path,
    width: u32,
    height: u32,
    pixels: &[[f32; 3]],
    display: &DisplayEncoding,
) -> Result<(), ImageError> {
    let png_err = |e: png::EncodingError| ImageError::Png { path: path.to_path_buf(), message: e.to_string() };
    let data = display.encode_8bit(pixels, width);
    let mut info = png::Info::with_size(width, height);
    info.color_type = png::ColorType::Rgb;
    info.bit_depth = png::BitDepth::Eight;
    let cicp = display.cicp();
    match cicp {
        None => info.srgb = Some(png::SrgbRenderingIntent::Perceptual),
        // Viewers that know cICP (browsers) read it first; the rest read the ICC profile.
        Some(_) => {
            let space = display.display_space();
            let description = format!("Prismatic {} (sRGB transfer curve)", space.name);
            info.icc_profile = Some(crate::icc::display_profile(space, &description).into());
        }
    }
    let mut encoder = png::Encoder::with_info(out, info).map_err(png_err)?;
    if display.fast_compression() {
        encoder.set_compression(png::Compression::Fast);
    }
    let mut writer = encoder.write_header().map_err(png_err)?;
    if let Some(code_points) = cicp {
        // cICP must precede IDAT (PNG third edition, 11.3.2.6): the header is written, the image data not yet.
        writer.write_chunk(png::chunk::ChunkType(*b"cICP"), &code_points).map_err(png_err)?;
    }
    writer.write_image_data(&data).map_err(png_err)?;
    writer.finish().map_err(png_err)
}

fn encode_pfm(
    out: &mut BufWriter<File>,
    path: &Path,
    width: u32,
    height: u32,
    pixels: &[[f32; 3]],
) -> Result<(), ImageError> {
    let mut bytes = Vec::with_capacity(32 + pixels.len() * 12);
    bytes.extend_from_slice(format!("PF\n{width} {height}\n-1.0\n").as_bytes());
    for row in pixels.chunks(width as usize).rev() {
        for p in row {
            for c in p {
                bytes.extend_from_slice(&c.to_le_bytes());
            }
        }
    }
    out.write_all(&bytes).map_err(io_err(path))
}

// ------------------------------------------------------------------------------------------------------------------
// Readers
// ------------------------------------------------------------------------------------------------------------------

type ExrImage = Image<Layer<AnyChannels<FlatSamples>>>;

fn read_exr(path: &Path) -> Result<ExrImage, ImageError> {
    use exr::prelude::*;
    let exr_err = |e: exr::error::Error| match e {
        exr::error::Error::Io(source) => ImageError::Io { path: path.to_path_buf(), source },
        e @ (exr::error::Error::Aborted | exr::error::Error::NotSupported(_) | exr::error::Error::Invalid(_)) => {
            ImageError::Exr { path: path.to_path_buf(), message: e.to_string() }
        }
    };
    let bytes = open_read(path)?;
    let meta = exr::meta::MetaData::read_from_buffered(bytes.as_slice(), false).map_err(exr_err)?;
    check_exr_sizes(path, &meta, bytes.len())?;
    read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(std::io::Cursor::new(bytes))
        .map_err(exr_err)
}

/// The most bytes one byte of an EXR chunk can decode to, by compression (a bound on what a file can hold, so that
/// sizes in a header can be checked before the decoder allocates for them): none 1; RLE 64 (a count byte and a
/// value byte for a run of up to 128); ZIP 1032 (deflate's limit, [`DEFLATE_MAX_RATIO`]); PXR24 4/3 of that (32-bit
/// floats are cut to 24 bits before deflate); PIZ 1032 (Huffman codes of at least one bit with run-length codes of
/// 8-bit counts stay below it); B44 11 (a 4×4 block of halves in 3 bytes at best); DWA 64 × 1032 (one deflated DC
/// value per 8×8 block); the rest, which the decoder refuses anyway, the DWA bound.
fn exr_max_ratio(compression: exr::compression::Compression) -> u128 {
    use exr::compression::Compression as C;
    let deflate = DEFLATE_MAX_RATIO as u128;
    match compression {
        C::Uncompressed => 1,
        C::RLE => 64,
        C::ZIP1 | C::ZIP16 | C::PIZ => deflate,
        C::PXR24 => deflate * 4 / 3,
        C::B44 | C::B44A => 11,
        C::DWAA(_) | C::DWAB(_) | C::HTJ2K32 | C::HTJ2K256 => 64 * deflate,
    }
}

/// Refuses an EXR whose headers claim more than its `len` bytes can hold, before its pixels are allocated: every
/// chunk has an 8-byte entry in the offset table, and the decoder allocates each channel at the layer's full size
/// (subsampled channels included), which the chunks must decode to within [`exr_max_ratio`].
fn check_exr_sizes(path: &Path, meta: &exr::meta::MetaData, len: usize) -> Result<(), ImageError> {
    let len = len as u128;
    for (i, header) in meta.headers.iter().enumerate() {
        let (w, h) = (header.layer_size.0 as u128, header.layer_size.1 as u128);
        let sample_bytes: u128 = header.channels.list.iter().map(|c| c.sample_type.bytes_per_sample() as u128).sum();
        let pixel_bytes = w * h * sample_bytes;
        let table_bytes = header.chunk_count as u128 * 8;
        if table_bytes > len || (!header.deep && pixel_bytes > exr_max_ratio(header.compression) * len) {
            return Err(ImageError::Malformed {
                path: path.to_path_buf(),
                message: format!(
                    "part {i} claims {w}×{h} pixels of {sample_bytes} bytes in {} chunks ({}), more than the file's \
                     {len} bytes can hold",
                    header.chunk_count, header.compression
                ),
            });
        }
    }
    Ok(())
}

/// The text attributes of an EXR file's header and first layer (name → value), such as those written by
/// [`write_image_with`].
pub fn read_exr_text_attributes(path: &Path) -> Result<BTreeMap<String, String>, ImageError> {
    let image = read_exr(path)?;
    let mut attributes = BTreeMap::new();
    for (name, value) in image.attributes.other.iter().chain(image.layer_data.attributes.other.iter()) {
        if let AttributeValue::Text(t) = value {
            attributes.insert(name.to_string(), t.to_string());
        }
    }
    Ok(attributes)
}

fn exr_size(path: &Path, image: &ExrImage) -> Result<(u32, u32), ImageError> {
    let s = image.layer_data.size;
    match (u32::try_from(s.0), u32::try_from(s.1)) {
        (Ok(w), Ok(h)) if w > 0 && h > 0 => Ok((w, h)),
        _ => Err(ImageError::Malformed { path: path.to_path_buf(), message: format!("bad size {}×{}", s.0, s.1) }),
    }
}

fn exr_channel(image: &ExrImage, name: &str) -> Option<Vec<f32>> {
    image
        .layer_data
        .channel_data
        .list
        .iter()
        .find(|c| c.name.to_string() == name)
        .map(|c| c.sample_data.values_as_f32().collect())
}

/// How an EXR's pixels are laid out: its data window (origin and size) inside its display window, and whether
/// its channels are half floats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ExrLayout {
    /// Top-left corner of the data window.
    pub data_origin: (i32, i32),
    /// Size of the data window (the pixels stored).
    pub data_size: (usize, usize),
    /// Top-left corner of the display window.
    pub display_origin: (i32, i32),
    /// Size of the display window.
    pub display_size: (usize, usize),
    /// Whether every channel is stored as 16-bit half floats.
    pub half: bool,
}

/// The layout of the EXR at `path` (see [`ExrLayout`]).
pub fn read_exr_layout(path: &Path) -> Result<ExrLayout, ImageError> {
    let image = read_exr(path)?;
    let layer = &image.layer_data;
    let d = image.attributes.display_window;
    Ok(ExrLayout {
        data_origin: (layer.attributes.layer_position.0, layer.attributes.layer_position.1),
        data_size: (layer.size.0, layer.size.1),
        display_origin: (d.position.0, d.position.1),
        display_size: (d.size.0, d.size.1),
        half: layer.channel_data.list.iter().all(|c| matches!(c.sample_data, FlatSamples::F16(_))),
    })
}

/// The colour space an EXR's `R`, `G`, `B` are in, from its `chromaticities` attribute: one of
/// [`RgbColorSpace::NAMES`] (primaries and white within 1e-4), sRGB when the attribute is absent (OpenEXR's
/// default is Rec. 709, sRGB's primaries), or an error naming the chromaticities when they are none of those.
pub fn read_exr_color_space(path: &Path) -> Result<RgbColorSpace, ImageError> {
    let bytes = open_read(path)?;
    let meta = exr::meta::MetaData::read_from_buffered(bytes.as_slice(), false)
        .map_err(|e| ImageError::Exr { path: path.to_path_buf(), message: e.to_string() })?;
    let Some(c) = meta.headers.first().and_then(|h| h.shared_attributes.chromaticities) else {
        return Ok(RgbColorSpace::srgb());
    };
    let found = [c.red, c.green, c.blue, c.white].map(|v| [v.0 as f64, v.1 as f64]);
    let close = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).abs() < 1e-4 && (a[1] - b[1]).abs() < 1e-4;
    RgbColorSpace::NAMES
        .iter()
        .filter_map(|n| RgbColorSpace::by_name(n))
        .find(|cs| (0..3).all(|i| close(cs.primaries[i], found[i])) && close(cs.white, found[3]))
        .ok_or_else(|| ImageError::Exr {
            path: path.to_path_buf(),
            message: format!(
                "chromaticities {found:?} (red, green, blue, white) are none of the colour spaces {}",
                RgbColorSpace::NAMES.join(", ")
            ),
        })
}

/// The bytes of the PNG [`write_display_png`] writes, in memory (for a live view): `name` only labels errors.
pub fn encode_display_png(
    name: &str,
    width: u32,
    height: u32,
    pixels: &[[f32; 3]],
    display: &DisplayEncoding,
) -> Result<Vec<u8>, ImageError> {
    check_size(width, height, pixels.len())?;
    let mut bytes = Vec::new();
    encode_png(&mut bytes, Path::new(name), width, height, pixels, display)?;
    Ok(bytes)
}

/// Writes a display image (PNG) of linear RGB `pixels` (row-major from the top) through `display`: its view, its
/// display space and the tags that name it.
pub fn write_display_png(
    path: &Path,
    width: u32,
    height: u32,
    pixels: &[[f32; 3]],
    display: &DisplayEncoding,
) -> Result<(), ImageError> {
    if ImageFormat::from_path(path)? != ImageFormat::Png {
        return Err(ImageError::InvalidImage(format!("{}: a display image is a .png file", path.display())));
    }
    check_size(width, height, pixels.len())?;
    write_atomic(path, |out| encode_png(out, path, width, height, pixels, display))
}

/// Reads the `R`, `G`, `B` channels of an EXR (a lone `Y` channel is read as grey): (width, height, linear pixels
/// row-major from the top).
pub fn read_exr_rgb(path: &Path) -> Result<(u32, u32, Vec<[f32; 3]>), ImageError> {
    let image = read_exr(path)?;
    let (w, h) = exr_size(path, &image)?;
    let channels = match (exr_channel(&image, "R"), exr_channel(&image, "G"), exr_channel(&image, "B")) {
        (Some(r), Some(g), Some(b)) => [r, g, b],
        _ => match exr_channel(&image, "Y") {
            Some(y) => [y.clone(), y.clone(), y],
            None => {
                return Err(ImageError::Malformed {
                    path: path.to_path_buf(),
                    message: "no R, G, B (or Y) channels".into(),
                })
            }
        },
    };
    let n = w as usize * h as usize;
    if channels.iter().any(|c| c.len() != n) {
        return Err(ImageError::Malformed { path: path.to_path_buf(), message: "channel sizes differ".into() });
    }
    Ok((w, h, (0..n).map(|i| [channels[0][i], channels[1][i], channels[2][i]]).collect()))
}

/// Channels of an image by name: (name, one value per pixel, row-major from the top).
pub type NamedChannels = Vec<(String, Vec<f32>)>;

/// Reads every channel of an EXR (converted to `f32`), in the file's order (EXR sorts channels by name): width,
/// height, and (name, values row-major from the top) per channel.
pub fn read_exr_channels(path: &Path) -> Result<(u32, u32, NamedChannels), ImageError> {
    let image = read_exr(path)?;
    let (w, h) = exr_size(path, &image)?;
    let channels = image
        .layer_data
        .channel_data
        .list
        .iter()
        .map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect()))
        .collect();
    Ok((w, h, channels))
}

/// Reads the `albedo.R/G/B` and `N.X/Y/Z` layers of an EXR written with AOVs (or a gbuffer film's `Albedo.R/G/B`
/// and `Ns.X/Y/Z`), row-major from the top.
pub fn read_exr_aovs(path: &Path) -> Result<AovImages, ImageError> {
    let image = read_exr(path)?;
    let get = |names: [&str; 3]| -> Result<Vec<[f32; 3]>, ImageError> {
        let mut c = Vec::new();
        for n in names {
            c.push(exr_channel(&image, n).ok_or_else(|| ImageError::Malformed {
                path: path.to_path_buf(),
                message: format!("no channel {n}"),
            })?);
        }
        Ok((0..c[0].len()).map(|i| [c[0][i], c[1][i], c[2][i]]).collect())
    };
    // `--aovs` names (albedo.*, N.*) or pbrt-v4's gbuffer names (Albedo.*, Ns.*).
    let gbuffer = exr_channel(&image, "albedo.R").is_none() && exr_channel(&image, "Albedo.R").is_some();
    Ok(if gbuffer {
        AovImages { albedo: get(["Albedo.R", "Albedo.G", "Albedo.B"])?, normal: get(["Ns.X", "Ns.Y", "Ns.Z"])? }
    } else {
        AovImages { albedo: get(["albedo.R", "albedo.G", "albedo.B"])?, normal: get(["N.X", "N.Y", "N.Z"])? }
    })
}

/// Reads an EXR in the Fichet et al. spectral layout: its `S0` channels sorted by wavelength, and its string
/// attributes. An EXR without `S0` channels is an error.
pub fn read_exr_spectral(path: &Path) -> Result<SpectralImage, ImageError> {
    let image = read_exr(path)?;
    let (w, h) = exr_size(path, &image)?;
    let mut found: Vec<(f64, String, Vec<f32>)> = image
        .layer_data
        .channel_data
        .list
        .iter()
        .filter_map(|c| {
            let name = c.name.to_string();
            match parse_spectral_channel_name(&name) {
                Some((0, nm)) => Some((nm, name, c.sample_data.values_as_f32().collect())),
                _ => None,
            }
        })
        .collect();
    if found.is_empty() {
        return Err(ImageError::Malformed {
            path: path.to_path_buf(),
            message: "no spectral S0.<wavelength> channels (not a spectral EXR)".into(),
        });
    }
    found.sort_by(|a, b| a.0.total_cmp(&b.0));
    let n = w as usize * h as usize;
    if found.iter().any(|c| c.2.len() != n) {
        return Err(ImageError::Malformed { path: path.to_path_buf(), message: "channel sizes differ".into() });
    }
    let nl = found.len();
    let mut data = vec![0.0f32; n * nl];
    for (l, (_, _, values)) in found.iter().enumerate() {
        for (i, v) in values.iter().enumerate() {
            data[i * nl + l] = *v;
        }
    }
    let mut attributes = BTreeMap::new();
    for (name, value) in image.attributes.other.iter().chain(image.layer_data.attributes.other.iter()) {
        if let AttributeValue::Text(t) = value {
            attributes.insert(name.to_string(), t.to_string());
        }
    }
    Ok(SpectralImage {
        width: w,
        height: h,
        wavelengths_nm: found.iter().map(|c| c.0).collect(),
        channel_names: found.iter().map(|c| c.1.clone()).collect(),
        data,
        attributes,
    })
}

/// The largest image file read (2 GiB, the bound of scene and mesh files): a name that leads to an endless stream
/// such as `/dev/zero` is an error once this much is read, not a read until memory runs out.
pub const MAX_IMAGE_FILE_BYTES: u64 = 2 << 30;

/// A whole image file (EXR, PNG, PFM, TGA), up to [`MAX_IMAGE_FILE_BYTES`].
pub(crate) fn open_read(path: &Path) -> Result<Vec<u8>, ImageError> {
    open_read_bounded(path, MAX_IMAGE_FILE_BYTES)
}

/// A whole file of at most `limit` bytes; a longer one is an error, found by reading one byte past the limit.
pub(crate) fn open_read_bounded(path: &Path, limit: u64) -> Result<Vec<u8>, ImageError> {
    let mut bytes = Vec::new();
    File::open(path).and_then(|f| f.take(limit + 1).read_to_end(&mut bytes)).map_err(io_err(path))?;
    if bytes.len() as u64 > limit {
        return Err(ImageError::Malformed {
            path: path.to_path_buf(),
            message: format!("larger than {limit} bytes, the most an image file is read to"),
        });
    }
    Ok(bytes)
}

/// Reads a PNG (8- or 16-bit; grey, grey+alpha, RGB, RGBA or palette; alpha ignored), decoding the sRGB transfer
/// function: (width, height, linear pixels row-major from the top).
pub fn read_png_linear(path: &Path) -> Result<(u32, u32, Vec<[f32; 3]>), ImageError> {
    let img = crate::decode::decode_png(&open_read(path)?, path)?;
    Ok((img.width, img.height, img.to_rgb(ColorEncoding::Srgb, crate::decode::ChannelSelect::Rgb)))
}

/// How the integer samples of an 8- or 16-bit image become linear values (pbrt-v4's `ColorEncoding`, the
/// `"string encoding"` of image textures).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ColorEncoding {
    /// v/max as is.
    Linear,
    /// The sRGB transfer function (IEC 61966-2-1) undone.
    Srgb,
    /// (v/max)^γ.
    Gamma(f32),
}

impl ColorEncoding {
    /// The linear value of a stored value `v` in [0, 1].
    pub fn to_linear(self, v: f64) -> f64 {
        match self {
            ColorEncoding::Linear => v,
            ColorEncoding::Srgb => spectral::color::srgb_decode(v),
            ColorEncoding::Gamma(g) => v.max(0.0).powf(g as f64),
        }
    }
}

/// Reads an RGB image for a texture, with `encoding` turning the samples of PNGs (8 or 16 bit) into linear values
/// as pbrt-v4 does; float formats (EXR, PFM, HDR) are linear and ignore it, and so do TGA and JPEG, which are always sRGB-decoded
/// (below). With [`ColorEncoding::Srgb`] this returns what [`read_rgb`] does.
pub fn read_rgb_encoded(path: &Path, encoding: ColorEncoding) -> Result<(u32, u32, Vec<[f32; 3]>), ImageError> {
    let (w, h, texels) = read_texels_encoded(path, encoding)?;
    Ok((w, h, texels.iter().collect()))
}

/// [`read_rgb_encoded`]'s texels kept compact ([`Texels`]): 8-bit images (PNG, JPEG, WebP, TGA) stay 8-bit, one
/// channel where red, green and blue are equal.
pub fn read_texels_encoded(path: &Path, encoding: ColorEncoding) -> Result<(u32, u32, Texels), ImageError> {
    if let Some(read) = read_not_written_format(path) {
        return read;
    }
    match ImageFormat::from_path(path)? {
        ImageFormat::Png => {
            let img = crate::decode::decode_png(&open_read(path)?, path)?;
            Ok((img.width, img.height, img.to_texels(encoding, crate::decode::ChannelSelect::Rgb)))
        }
        ImageFormat::Exr | ImageFormat::Pfm => {
            let (w, h, rgb) = read_rgb(path)?;
            Ok((w, h, Texels::from_rgb(rgb)))
        }
    }
}

/// (width, height, texels row-major from the top): what the texture readers return.
type ImageTexels = (u32, u32, Texels);

/// The formats read but never written, which are not `ImageFormat`s, by extension: TGA and JPEG (8-bit, always
/// sRGB-decoded: pbrt-v4 reads both through stb_image and tags the result sRGB whatever encoding the texture asked
/// for (pbrt-v4 src/pbrt/util/image.cpp, Image::Read); measured: its "linear" default for non-PNG textures does not
/// reach TGA, so the staircase scenes' wood is as dark in pbrt-v4 as sRGB decoding makes it), and Radiance HDR
/// (linear floats). `None` for any other extension.
fn read_not_written_format(path: &Path) -> Option<Result<ImageTexels, ImageError>> {
    let ext = path.extension()?.to_string_lossy().to_ascii_lowercase();
    let srgb8 = |img: crate::decode::DecodedImage| {
        (img.width, img.height, img.to_texels(ColorEncoding::Srgb, crate::decode::ChannelSelect::Rgb))
    };
    match ext.as_str() {
        "tga" => Some(crate::tga::read_tga(path).map(|img| (img.width, img.height, crate::tga::srgb8_texels(&img)))),
        "jpg" | "jpeg" => Some(open_read(path).and_then(|bytes| crate::decode::decode_jpeg(&bytes, path)).map(srgb8)),
        "webp" => Some(open_read(path).and_then(|bytes| crate::decode::decode_webp(&bytes, path)).map(srgb8)),
        "hdr" | "pic" => Some(crate::hdr::read_hdr(path).map(|(w, h, rgb)| (w, h, Texels::from_rgb(rgb)))),
        _ => None,
    }
}

/// The most bytes one byte of a deflate stream can expand to (RFC 1951: a 258-byte match coded in two bits); zlib's
/// technical notes give the same 1032:1.
pub(crate) const DEFLATE_MAX_RATIO: u64 = 1032;

/// Refuses a `PLTE` chunk that is not 1 to 256 whole RGB entries (PNG spec. §11.2.3), which the png crate (0.17)
/// lets through to a panic when it expands the palette into its 256-entry table: a fractional last entry
/// (image-rs/image-png issue 694) or more than 256 entries (found by fuzzing). Walks the chunks up to `IEND`;
/// anything else malformed is left to the decoder.
pub(crate) fn check_png_palette(bytes: &[u8]) -> Result<(), String> {
    let mut rest = bytes.get(8..).unwrap_or_default();
    while let Some(head) = rest.get(..8) {
        let len = u32::from_be_bytes([head[0], head[1], head[2], head[3]]) as usize;
        let kind = &head[4..8];
        if kind == b"PLTE" && !len.is_multiple_of(3) {
            return Err(format!("PLTE chunk of {len} bytes: not a whole number of 3-byte palette entries"));
        }
        if kind == b"PLTE" && !(3..=768).contains(&len) {
            return Err(format!("PLTE chunk of {len} bytes: a palette has 1 to 256 entries of 3 bytes"));
        }
        if kind == b"IEND" {
            break;
        }
        // Length, type, data and CRC.
        rest = rest.get(len.saturating_add(12)..).unwrap_or_default();
    }
    Ok(())
}

/// Reads a PFM (`PF` colour or `Pf` grey, either byte order; values multiplied by |scale| when it is not 1):
/// (width, height, pixels row-major from the top).
pub fn read_pfm(path: &Path) -> Result<(u32, u32, Vec<[f32; 3]>), ImageError> {
    let bytes = open_read(path)?;
    let bad = |m: &str| ImageError::Malformed { path: path.to_path_buf(), message: format!("PFM: {m}") };
    // Four whitespace-separated tokens, then exactly one whitespace byte before the raster.
    let mut pos = 0;
    let mut tokens = Vec::new();
    while tokens.len() < 4 {
        while pos < bytes.len() && bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        let start = pos;
        while pos < bytes.len() && !bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        if start == pos || pos - start > 64 {
            return Err(bad("truncated or malformed header"));
        }
        tokens.push(std::str::from_utf8(&bytes[start..pos]).map_err(|_| bad("non-text header"))?);
    }
    if pos >= bytes.len() {
        return Err(bad("no pixel data"));
    }
    pos += 1;
    let channels = match tokens[0] {
        "PF" => 3,
        "Pf" => 1,
        m => return Err(bad(&format!("bad magic '{m}' (expected PF or Pf)"))),
    };
    let w: u32 = tokens[1].parse().map_err(|_| bad("bad width"))?;
    let h: u32 = tokens[2].parse().map_err(|_| bad("bad height"))?;
    let scale: f32 = tokens[3].parse().map_err(|_| bad("bad scale"))?;
    if w == 0 || h == 0 || !scale.is_finite() || scale == 0.0 {
        return Err(bad("zero size or bad scale"));
    }
    let n = (w as usize).checked_mul(h as usize).ok_or_else(|| bad("size overflows"))?;
    let need = n.checked_mul(channels * 4).ok_or_else(|| bad("size overflows"))?;
    let raster = bytes.get(pos..).filter(|r| r.len() >= need).ok_or_else(|| bad("truncated pixel data"))?;
    let little = scale < 0.0;
    let mult = if scale.abs() != 1.0 { scale.abs() } else { 1.0 };
    let value = |i: usize| {
        let b = [raster[4 * i], raster[4 * i + 1], raster[4 * i + 2], raster[4 * i + 3]];
        (if little { f32::from_le_bytes(b) } else { f32::from_be_bytes(b) }) * mult
    };
    let mut out = Vec::with_capacity(n);
    for y in (0..h as usize).rev() {
        for x in 0..w as usize {
            let i = (y * w as usize + x) * channels;
            out.push(if channels == 3 { [value(i), value(i + 1), value(i + 2)] } else { [value(i); 3] });
        }
    }
    Ok((w, h, out))
}

/// Reads a linear RGB image by extension: EXR (`R`, `G`, `B`), PNG, JPEG or TGA (8-bit sRGB-decoded,
/// [`crate::tga`]), PFM or Radiance HDR ([`crate::hdr`]) — for textures and environment maps.
pub fn read_rgb(path: &Path) -> Result<(u32, u32, Vec<[f32; 3]>), ImageError> {
    if let Some(read) = read_not_written_format(path) {
        return read.map(|(w, h, texels)| (w, h, texels.iter().collect()));
    }
    match ImageFormat::from_path(path)? {
        ImageFormat::Exr => read_exr_rgb(path),
        ImageFormat::Png => read_png_linear(path),
        ImageFormat::Pfm => read_pfm(path),
    }
}

#[cfg(test)]
mod encoding_tests {
    use super::*;

    /// Writes a PNG of `width`×1 pixels with the given raw samples (8 or 16 bit, RGB or grey).
    fn write_png(path: &Path, width: u32, color: png::ColorType, depth: png::BitDepth, data: &[u8]) {
        let file = File::create(path).unwrap();
        let mut enc = png::Encoder::new(BufWriter::new(file), width, 1);
        enc.set_color(color);
        enc.set_depth(depth);
        enc.write_header().unwrap().write_image_data(data).unwrap();
    }

    #[test]
    fn encoding_decides_what_integer_samples_mean() {
        let dir = std::env::temp_dir().join(format!("prismatic-encoding-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let p8 = dir.join("rgb8.png");
        write_png(&p8, 2, png::ColorType::Rgb, png::BitDepth::Eight, &[128, 64, 255, 0, 10, 200]);
        let raw: [[f64; 3]; 2] = [[128.0, 64.0, 255.0], [0.0, 10.0, 200.0]];
        let read = |e| read_rgb_encoded(&p8, e).unwrap().2;
        let (lin, srgb, gamma) =
            (read(ColorEncoding::Linear), read(ColorEncoding::Srgb), read(ColorEncoding::Gamma(2.2)));
        for (i, px) in raw.iter().enumerate() {
            for c in 0..3 {
                let v = px[c] / 255.0;
                assert_eq!(lin[i][c], v as f32, "linear is v/255");
                assert!((gamma[i][c] as f64 - v.powf(2.2)).abs() < 1e-6);
                // sRGB by its definition (IEC 61966-2-1), independently of the decoder used above.
                let s = if v <= 0.04045 { v / 12.92 } else { ((v + 0.055) / 1.055).powf(2.4) };
                assert!((srgb[i][c] as f64 - s).abs() < 1e-6);
            }
        }
        // 128 in sRGB is 0.2158605, linearly 0.5019608: the two readings of the same byte differ by 2.3×.
        assert!((srgb[0][0] - 0.215_860_5).abs() < 1e-6 && (lin[0][0] - 0.501_960_8).abs() < 1e-6);
        // sRGB is what read_rgb (and read_png_linear) return, bit for bit.
        assert_eq!(read_rgb(&p8).unwrap().2, srgb);
        // 16-bit grey goes through the encoding too (pbrt-v4 decodes 16-bit PNG samples with it).
        let p16 = dir.join("grey16.png");
        write_png(&p16, 1, png::ColorType::Grayscale, png::BitDepth::Sixteen, &32768u16.to_be_bytes());
        let v: f64 = 32768.0 / 65535.0;
        assert_eq!(read_rgb_encoded(&p16, ColorEncoding::Linear).unwrap().2, vec![[v as f32; 3]]);
        let g = read_rgb_encoded(&p16, ColorEncoding::Gamma(2.2)).unwrap().2[0][1] as f64;
        assert!((g - v.powf(2.2)).abs() < 1e-6);
        fs::remove_dir_all(&dir).ok();
    }
}

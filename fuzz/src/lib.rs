//! The fuzz targets: each feeds arbitrary bytes to one of Prismatic's input readers the way a file would reach it,
//! and ignores the result. A panic, an abort (an allocation beyond the memory limit) or a run beyond the time
//! limit is a finding; an `Err` is the expected answer to bad input.

use std::fmt::Debug;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// With `PRISMATIC_FUZZ_VERBOSE` set, prints each reader's verdict to stderr (to triage or check seeds by hand).
fn report<T, E: Debug>(what: &str, r: Result<T, E>) {
    static VERBOSE: OnceLock<bool> = OnceLock::new();
    if *VERBOSE.get_or_init(|| std::env::var_os("PRISMATIC_FUZZ_VERBOSE").is_some()) {
        match r {
            Ok(_) => eprintln!("{what}: ok"),
            Err(e) => eprintln!("{what}: error: {e:?}"),
        }
    }
}

/// The pbrt-v4 scene reader on a file's bytes (plain or gzip-compressed). The virtual file lies in a directory
/// that does not exist, so relative `Include`s and spectrum files fail without touching the file system.
pub fn pbrt(data: &[u8]) {
    report("pbrt", pbrt::parse_bytes(data, Path::new("/nonexistent-fuzz-dir/scene.pbrt")));
}

/// The PLY reader as `read_ply_file` runs it: gzip data (by its magic bytes) decompressed first.
pub fn ply(data: &[u8]) {
    let plain;
    let bytes = if geometry::gzip::is_gzip(data) {
        match geometry::gzip::gunzip(data, geometry::gzip::MAX_DECOMPRESSED_BYTES) {
            Ok(b) => {
                plain = b;
                &plain[..]
            }
            Err(e) => return report("gunzip", Err::<(), _>(e)),
        }
    } else {
        data
    };
    report("ply", geometry::ply::read_ply(&mut &bytes[..], "fuzz.ply"));
}

/// The PNG reader (through a file as textures are read), with the linear encoding: the decoding is the same as
/// with sRGB, whose per-sample curve for 16-bit images only slowed the fuzzer down.
pub fn png(data: &[u8]) {
    // As image libraries' own fuzz harnesses do (libpng's sets png_set_user_limits), inputs whose header claims more
    // than 2^18 pixels are skipped: decoding a large image is slow in the instrumented build, and such inputs (a
    // large constant image compresses into a few hundred bytes) dominated the run (docs/robustness.md).
    // The size check before allocating is the same code for every size and is tested in the film crate.
    if let Some(pixels) = png_pixels(data) {
        if pixels > 1 << 18 {
            return;
        }
    }
    let file = Scratch::new("png", data);
    report("png", film::read_rgb_encoded(&file.0, film::ColorEncoding::Linear));
}

/// Width × height from a PNG's IHDR chunk (the first chunk, at byte 8), if the data is long enough to have one.
fn png_pixels(data: &[u8]) -> Option<u64> {
    let be = |i: usize| data.get(i..i + 4).map(|b| u32::from_be_bytes([b[0], b[1], b[2], b[3]]) as u64);
    (data.get(12..16) == Some(b"IHDR")).then(|| Some(be(16)? * be(20)?)).flatten()
}

/// The in-memory image decoder that glTF textures and JPEG files go through (it recognises PNG and JPEG by their
/// signatures), then the conversions a texture makes (linear values, compact texels), with every channel
/// selection. Inputs whose JPEG frame header claims more than 2^18 pixels are skipped, as for the `png` target.
pub fn jpeg(data: &[u8]) {
    let big = |p: Option<u64>| p.is_some_and(|p| p > 1 << 18);
    if big(jpeg_pixels(data)) || big(png_pixels(data)) || big(webp_pixels(data)) {
        return;
    }
    let decoded = film::decode_image_bytes(data, Path::new("fuzz.jpg"));
    if let Ok(img) = &decoded {
        for select in [film::ChannelSelect::Rgb, film::ChannelSelect::One(1), film::ChannelSelect::One(3)] {
            std::hint::black_box(img.to_rgb(film::ColorEncoding::Srgb, select));
            std::hint::black_box(img.to_texels(film::ColorEncoding::Srgb, select));
        }
    }
    report("jpeg", decoded);
}

/// Width × height from a WebP's headers (the decoder reads them without decoding the image).
fn webp_pixels(data: &[u8]) -> Option<u64> {
    if film::sniff_format(data) != Some("webp") {
        return None;
    }
    let (w, h) = image_webp::WebPDecoder::new(std::io::Cursor::new(data)).ok()?.dimensions();
    Some(u64::from(w) * u64::from(h))
}

/// Height × width from the first JPEG start-of-frame marker (SOF0–SOF15 but DHT, JPG and DAC) in the data.
fn jpeg_pixels(data: &[u8]) -> Option<u64> {
    let at = data.windows(2).position(|w| w[0] == 0xff && (0xc0..=0xcf).contains(&w[1]) && ![0xc4, 0xc8, 0xcc].contains(&w[1]))?;
    let be = |i: usize| data.get(i..i + 2).map(|b| u16::from_be_bytes([b[0], b[1]]) as u64);
    Some(be(at + 5)? * be(at + 7)?)
}

/// The OpenEXR readers: RGB (textures, `compare`, `convert`), the spectral layout and the colour space.
pub fn exr(data: &[u8]) {
    let file = Scratch::new("exr", data);
    report("exr rgb", film::read_exr_rgb(&file.0));
    report("exr spectral", film::read_exr_spectral(&file.0));
    report("exr colour space", film::read_exr_color_space(&file.0).map(|cs| cs.name));
}

/// The PFM reader.
pub fn pfm(data: &[u8]) {
    let file = Scratch::new("pfm", data);
    report("pfm", film::read_pfm(&file.0));
}

/// The Radiance HDR (RGBE) decoder, from memory.
pub fn hdr(data: &[u8]) {
    report("hdr", film::hdr::decode_hdr(data, Path::new("fuzz.hdr")));
}

/// The TGA decoder and its conversion to linear RGB.
pub fn tga(data: &[u8]) {
    let r = film::tga::decode_tga(data);
    if let Ok(image) = &r {
        let _ = film::tga::srgb8_texels(image);
    }
    report("tga", r);
}

/// The `measured` material's RGL tensor-file reader, then the BRDF built from what it read, evaluated, sampled and
/// inverted at a few fixed directions (the warps index their tables with values the file provides). The albedo
/// estimate of AOVs (1024 samples of the same functions per wavelength, computed on first use) is left out: it
/// would cost more than everything else together.
pub fn bsdf(data: &[u8]) {
    let tensor = match render::internals::TensorFile::parse(data.to_vec()) {
        Ok(t) => t,
        Err(e) => return report("tensor", Err::<(), _>(e)),
    };
    let brdf = match render::internals::MeasuredBrdf::from_tensor(&tensor) {
        Ok(b) => b,
        Err(e) => return report("measured", Err::<(), _>(e)),
    };
    let lambda = [450.0, 520.0, 600.0, 680.0];
    let dirs = [glam::Vec3::Z, glam::Vec3::new(0.6, 0.0, 0.8), glam::Vec3::new(-0.28, 0.96, 0.02).normalize()];
    for wi in dirs {
        for wo in dirs {
            let _ = brdf.f(wi, wo, &lambda);
            let _ = brdf.pdf(wi, wo);
        }
        for u in [[0.5, 0.5], [0.01, 0.99], [0.999, 0.0]] {
            let _ = brdf.sample(wi, glam::Vec2::from(u), &lambda);
        }
    }
    report("measured", Ok::<(), String>(()));
}

/// This process's scratch file holding one input (in memory-backed `/dev/shm` when there is one), removed when
/// dropped: the image readers take paths.
struct Scratch(PathBuf);

impl Scratch {
    fn new(ext: &str, data: &[u8]) -> Self {
        let dir = if Path::new("/dev/shm").is_dir() { PathBuf::from("/dev/shm") } else { std::env::temp_dir() };
        let path = dir.join(format!("prismatic-fuzz-{}.{ext}", std::process::id()));
        std::fs::write(&path, data).expect("the scratch file must be writable");
        Scratch(path)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

/// The lens-file reader (pbrt-v4's lens files with Prismatic's glass names, Abbe pairs and coatings), on the bytes as
/// text (invalid UTF-8 replaced, as a reader of a text file would see it).
pub fn lens(data: &[u8]) {
    let parsed = optics::LensPrescription::parse(&String::from_utf8_lossy(data));
    if let Ok(lens) = &parsed {
        // What `prismatic lens` and the realistic camera then do with it (with small grids: the limit is 1 s an
        // input): first-order figures, focusing, exit-pupil boxes, and rays out through the surfaces with their
        // coatings' transmittance, at the ends and middle of the spectrum.
        let lambdas = [360.0, 587.5618, 830.0];
        for &l in &lambdas {
            let _ = lens.paraxial(l);
            let _ = lens.cardinal_points(l);
            let _ = lens.lateral_colour(486.1327, 656.2725, l, 10.0);
        }
        let lens = lens.focused(2000.0, 587.5618).unwrap_or_else(|_| lens.clone());
        for ring in [(0.0, 0.5), (10.0, 10.5)] {
            if let Some(b) = lens.exit_pupil_bounds(ring, &lambdas, (2, 8)) {
                let z = lens.length_mm();
                let rear = z - lens.surfaces.last().map_or(0.0, |s| s.thickness_mm);
                let ray = optics::LensRay::towards([ring.0, 0.0, z], [0.5 * (b[0] + b[1]), 0.5 * (b[2] + b[3]), rear]);
                let _ = lens.trace_from_film_many(ray, lambdas, Some(&|x: f64, y: f64| 1.0 - x * x - y * y), true);
            }
        }
    }
    report("lens", parsed);
}

/// The glTF reader on the bytes as a file (JSON or binary: the reader tells them apart by content), read as a whole
/// scene: buffers, accessors, the node graph, cameras, lights and materials.
pub fn gltf(data: &[u8]) {
    let file = Scratch::new("glb", data);
    let scene = gltf_import::read_scene(&file.0, &gltf_import::ReadOptions::default());
    // The images the file embeds, decoded as the scene's build would (small ones: see `jpeg`).
    if let Ok(desc) = &scene {
        for image in &desc.images {
            jpeg(&image.bytes);
        }
    }
    report("gltf", scene);
}

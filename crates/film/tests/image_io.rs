//! Image output and input: EXR (RGB, AOVs, the Fichet et al. spectral layout), PNG, PFM, atomic writes.

use film::image_io::{EMISSIVE_UNITS, SPECTRAL_LAYOUT_VERSION};
use film::{
    parse_spectral_channel_name, read_exr_aovs, read_exr_rgb, read_exr_spectral, read_pfm, read_png_linear, read_rgb,
    spectral_channel_name, write_image, write_rgb, Film, FilmKind, FilmSpec, ImageError,
};
use rand_core::{RngCore, SeedableRng};
use rand_pcg::Pcg64;
use spectral::color::{srgb_decode, srgb_encode};
use spectral::Xyz;
use std::fs;
use std::path::{Path, PathBuf};

fn uniform(rng: &mut Pcg64) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// A fresh scratch directory for one test.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("prismatic-film-{}-{name}", std::process::id()));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

fn temp_leftovers(dir: &Path) -> Vec<String> {
    fs::read_dir(dir)
        .map(|rd| {
            rd.filter_map(|e| e.ok())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.contains(".tmp-"))
                .collect()
        })
        .unwrap_or_default()
}

/// A film with random colours and spectra (one sample per pixel).
fn random_film(w: u32, h: u32, kind: FilmKind, aovs: bool, seed: u64) -> Film {
    let mut spec = FilmSpec::new(w, h, "r.exr");
    spec.kind = kind;
    spec.aovs = aovs;
    let mut film = Film::new(spec).unwrap();
    let mut rng = Pcg64::seed_from_u64(seed);
    for y in 0..h {
        for x in 0..w {
            let xyz = Xyz::new(uniform(&mut rng), uniform(&mut rng), uniform(&mut rng));
            let spectral: Vec<(f32, f32)> =
                (0..4).map(|_| (360.0 + 470.0 * uniform(&mut rng) as f32, 10.0 * uniform(&mut rng) as f32)).collect();
            film.add_xyz_sample(x, y, xyz, 0.5 + uniform(&mut rng), &spectral);
            film.add_aov(x, y, [uniform(&mut rng), 0.5, 0.25], [uniform(&mut rng), 1.0, -0.5]);
        }
    }
    film
}

#[test]
fn exr_rgb_round_trip() {
    let dir = scratch("exr-rgb");
    let film = random_film(31, 17, FilmKind::Rgb, false, 1);
    let path = dir.join("rgb.exr");
    write_image(&film, &path).unwrap();
    let (w, h, pixels) = read_exr_rgb(&path).unwrap();
    assert_eq!((w, h), (31, 17));
    assert_eq!(pixels, film.to_rgb_image());
    // An RGB EXR is not spectral, and has no AOV layers.
    assert!(matches!(read_exr_spectral(&path), Err(ImageError::Malformed { .. })));
    assert!(read_exr_aovs(&path).is_err());
    // Upper-case extension, and the generic reader.
    let upper = dir.join("RGB.EXR");
    write_image(&film, &upper).unwrap();
    assert_eq!(read_rgb(&upper).unwrap().2, film.to_rgb_image());
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn exr_spectral_round_trip_in_the_fichet_layout() {
    let dir = scratch("exr-spectral");
    let film = random_film(13, 9, FilmKind::spectral_default(), true, 2);
    let path = dir.join("spectral.exr");
    write_image(&film, &path).unwrap();

    let img = read_exr_spectral(&path).unwrap();
    assert_eq!((img.width, img.height), (13, 9));
    // 16 buckets of 29.375 nm over 360–830: centres 374.6875, 404.0625, ...
    let centres = film.spec().kind.bucket_centres();
    assert_eq!(img.wavelengths_nm.len(), 16);
    for (a, b) in img.wavelengths_nm.iter().zip(&centres) {
        assert!((a - b).abs() < 1e-6, "{a} vs {b}");
    }
    assert_eq!(img.channel_names[0], "S0.374,687500nm");
    assert_eq!(img.channel_names[1], "S0.404,062500nm");
    assert_eq!(img.channel_names[15], "S0.815,312500nm");
    assert_eq!(img.data, film.to_spectral_image());
    for y in 0..9 {
        for x in 0..13 {
            let want: Vec<f32> = film.pixel_spectrum(x, y).iter().map(|&v| v as f32).collect();
            assert_eq!(img.pixel(x, y).unwrap(), &want[..]);
        }
    }
    assert!(img.pixel(13, 0).is_none());
    // The layout's attributes, spelled as Fichet et al. (and pbrt-v4) spell them.
    assert_eq!(img.attributes.get("spectralLayoutVersion").map(String::as_str), Some("1.0"));
    assert_eq!(img.attributes.get("emissiveUnits").map(String::as_str), Some("W.m^-2.sr^-1"));
    assert_eq!((SPECTRAL_LAYOUT_VERSION, EMISSIVE_UNITS), ("1.0", "W.m^-2.sr^-1"));
    // The same file holds the RGB image and the AOV layers.
    assert_eq!(read_exr_rgb(&path).unwrap().2, film.to_rgb_image());
    assert_eq!(Some(read_exr_aovs(&path).unwrap()), film.to_aov_images());
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn fichet_channel_names() {
    assert_eq!(spectral_channel_name(550.0), "S0.550,000000nm");
    assert_eq!(spectral_channel_name(405.0), "S0.405,000000nm");
    assert_eq!(spectral_channel_name(374.6875), "S0.374,687500nm");
    assert_eq!(parse_spectral_channel_name("S0.550,000000nm"), Some((0, 550.0)));
    assert_eq!(parse_spectral_channel_name("S0.550nm"), Some((0, 550.0)));
    assert_eq!(parse_spectral_channel_name("S2.550nm"), Some((2, 550.0)));
    let close = |name: &str, nm: f64| {
        let (_, v) = parse_spectral_channel_name(name).unwrap_or_else(|| panic!("{name}"));
        assert!((v - nm).abs() < 1e-6 * nm, "{name}: {v}");
    };
    close("S0.5,5e2nm", 550.0);
    close("S0.0,55um", 550.0);
    close("S0.5,5E-7m", 550.0);
    close("S0.545,077196THz", 550.0);
    close("S0.5500dam", 5.5e13);
    for bad in ["R", "S0.550", "S4.550nm", "S0.nm", "S0.,nm", "S0.550xm", "T.550nm", "S0550nm", "S0.5e+nm", ""] {
        assert_eq!(parse_spectral_channel_name(bad), None, "{bad}");
    }
}

#[test]
fn png_round_trip_within_one_step_and_dither_unbiased() {
    let dir = scratch("png");
    // A gradient in [0, 1] (linear), round trip within one 8-bit step of the encoded value.
    let (w, h) = (64u32, 32u32);
    let pixels: Vec<[f32; 3]> = (0..w * h)
        .map(|i| {
            let t = (i % w) as f32 / (w - 1) as f32;
            [t, t * t, 1.0 - t]
        })
        .collect();
    let path = dir.join("g.png");
    write_rgb(&path, w, h, &pixels).unwrap();
    let (rw, rh, back) = read_png_linear(&path).unwrap();
    assert_eq!((rw, rh), (w, h));
    for (a, b) in pixels.iter().zip(&back) {
        for c in 0..3 {
            let (ea, eb) = (srgb_encode(a[c] as f64), srgb_encode(b[c] as f64));
            assert!((ea - eb).abs() <= 1.0 / 255.0 + 1e-6, "{} vs {}", a[c], b[c]);
        }
    }
    // Deterministic: the same image twice gives the same bytes.
    let again = dir.join("g2.png");
    write_rgb(&again, w, h, &pixels).unwrap();
    assert_eq!(fs::read(&path).unwrap(), fs::read(&again).unwrap());

    // A flat region: the mean code is 255·v (v the encoded value).
    for v in [0.1234, 0.5, 0.77777, 0.0031] {
        let linear = srgb_decode(v) as f32;
        let (w, h) = (256u32, 256u32);
        let flat = vec![[linear; 3]; (w * h) as usize];
        let p = dir.join("flat.png");
        write_rgb(&p, w, h, &flat).unwrap();
        let decoder = png::Decoder::new(fs::File::open(&p).unwrap());
        let mut reader = decoder.read_info().unwrap();
        let mut buf = vec![0u8; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.color_type, info.bit_depth), (png::ColorType::Rgb, png::BitDepth::Eight));
        for c in 0..3 {
            let codes: Vec<f64> = buf.iter().skip(c).step_by(3).map(|&b| b as f64).collect();
            let mean = codes.iter().sum::<f64>() / codes.len() as f64;
            let target = 255.0 * srgb_encode(linear as f64);
            assert!((mean - target).abs() < 0.01, "v = {v}, channel {c}: mean {mean} vs {target}");
            // Random rounding only ever picks the two neighbouring codes.
            assert!(codes.iter().all(|&k| (k - target).abs() < 1.0));
        }
    }
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn png_reader_handles_16_bit_grey_and_rgba() {
    let dir = scratch("png-read");
    let write = |name: &str, color: png::ColorType, depth: png::BitDepth, data: &[u8]| {
        let p = dir.join(name);
        let mut e = png::Encoder::new(fs::File::create(&p).unwrap(), 2, 1);
        e.set_color(color);
        e.set_depth(depth);
        let mut wr = e.write_header().unwrap();
        wr.write_image_data(data).unwrap();
        wr.finish().unwrap();
        p
    };
    let p = write("g16.png", png::ColorType::Grayscale, png::BitDepth::Sixteen, &[0xff, 0xff, 0x80, 0x00]);
    let (_, _, px) = read_png_linear(&p).unwrap();
    assert_eq!(px[0], [1.0; 3]);
    let want = srgb_decode(0x8000 as f64 / 65535.0) as f32;
    assert!((px[1][0] - want).abs() < 1e-6 && px[1][0] == px[1][2]);
    let p = write("rgba.png", png::ColorType::Rgba, png::BitDepth::Eight, &[255, 0, 128, 7, 0, 255, 0, 255]);
    let (_, _, px) = read_png_linear(&p).unwrap();
    assert_eq!(px[0][0], 1.0);
    assert_eq!(px[0][1], 0.0);
    assert!((px[0][2] - srgb_decode(128.0 / 255.0) as f32).abs() < 1e-6);
    assert_eq!(px[1], [0.0, 1.0, 0.0]);
    let p = write("ga.png", png::ColorType::GrayscaleAlpha, png::BitDepth::Eight, &[255, 0, 0, 255]);
    assert_eq!(read_png_linear(&p).unwrap().2, vec![[1.0; 3], [0.0; 3]]);
    // Garbage is an error, not a panic.
    let bad = dir.join("bad.png");
    fs::write(&bad, b"\x89PNG\r\n\x1a\nnot really").unwrap();
    assert!(matches!(read_png_linear(&bad), Err(ImageError::Png { .. })));
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn pfm_round_trip_is_exact() {
    let dir = scratch("pfm");
    let film = random_film(7, 5, FilmKind::Rgb, false, 3);
    let path = dir.join("a.pfm");
    write_image(&film, &path).unwrap();
    let bytes = fs::read(&path).unwrap();
    assert!(bytes.starts_with(b"PF\n7 5\n-1.0\n"));
    assert_eq!(bytes.len(), 12 + 7 * 5 * 12);
    // Rows are stored bottom to top: the first stored pixel is the bottom-left one.
    let rgb = film.to_rgb_image();
    assert_eq!(&bytes[12..16], &rgb[4 * 7][0].to_le_bytes());
    let (w, h, back) = read_pfm(&path).unwrap();
    assert_eq!((w, h), (7, 5));
    assert_eq!(back, rgb);

    // Big-endian grey with a scale of 2.
    let mut be = b"Pf 2 1\n2.0\n".to_vec();
    be.extend_from_slice(&1.5f32.to_be_bytes());
    be.extend_from_slice(&(-0.25f32).to_be_bytes());
    let p = dir.join("be.pfm");
    fs::write(&p, &be).unwrap();
    assert_eq!(read_pfm(&p).unwrap(), (2, 1, vec![[3.0; 3], [-0.5; 3]]));
    // Truncated and malformed files are errors.
    for bad in [&b"PF\n2 2\n-1.0\n\0\0\0\0"[..], b"P6\n1 1\n255\n\0\0\0", b"PF\n-2 1\n-1\n", b"PF", b""] {
        fs::write(&p, bad).unwrap();
        assert!(matches!(read_pfm(&p), Err(ImageError::Malformed { .. })), "{bad:?}");
    }
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn unsupported_extensions_are_errors() {
    let dir = scratch("ext");
    let film = random_film(2, 2, FilmKind::Rgb, false, 4);
    for name in ["a.jpg", "a", "a.exr.bak", "a.tiff"] {
        let path = dir.join(name);
        let e = write_image(&film, &path).unwrap_err();
        let msg = e.to_string();
        assert!(matches!(e, ImageError::UnsupportedExtension { .. }), "{msg}");
        assert!(msg.contains("exr, png, pfm"), "{msg}");
        assert!(!path.exists());
    }
    let msg = write_image(&film, &dir.join("a.jpg")).unwrap_err().to_string();
    assert!(msg.contains("'jpg'"), "{msg}");
    assert!(read_rgb(&dir.join("a.bmp")).is_err());
    // Inconsistent pixel data is an error too.
    assert!(matches!(write_rgb(&dir.join("a.exr"), 3, 3, &[[0.0; 3]; 8]), Err(ImageError::InvalidImage(_))));
    assert!(matches!(write_rgb(&dir.join("a.exr"), 0, 3, &[]), Err(ImageError::InvalidImage(_))));
    assert!(temp_leftovers(&dir).is_empty());
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn failing_writes_leave_no_temporary_file_and_the_destination_untouched() {
    let dir = scratch("atomic-fail");
    let film = random_film(4, 4, FilmKind::spectral_default(), false, 5);
    // Into a directory that does not exist.
    for ext in ["exr", "png", "pfm"] {
        let path = dir.join("missing").join(format!("out.{ext}"));
        assert!(matches!(write_image(&film, &path), Err(ImageError::Io { .. })));
    }
    assert!(!dir.join("missing").exists());
    // Onto an existing directory: the rename fails, the directory stays, the temporary file is removed.
    for ext in ["exr", "png", "pfm"] {
        let path = dir.join(format!("taken.{ext}"));
        fs::create_dir(&path).unwrap();
        fs::write(path.join("keep"), b"x").unwrap();
        assert!(matches!(write_image(&film, &path), Err(ImageError::Io { .. })));
        assert_eq!(fs::read(path.join("keep")).unwrap(), b"x");
    }
    assert!(temp_leftovers(&dir).is_empty(), "{:?}", temp_leftovers(&dir));

    // In a read-only directory (meaningless as root, who may write anyway): an existing file is kept as it was.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let ro = dir.join("ro");
        fs::create_dir(&ro).unwrap();
        let dest = ro.join("old.pfm");
        fs::write(&dest, b"old contents").unwrap();
        fs::set_permissions(&ro, fs::Permissions::from_mode(0o555)).unwrap();
        let probe = ro.join("probe");
        let root = fs::write(&probe, b"").is_ok();
        if !root {
            assert!(matches!(write_image(&film, &dest), Err(ImageError::Io { .. })));
            assert_eq!(fs::read(&dest).unwrap(), b"old contents");
            assert!(temp_leftovers(&ro).is_empty());
        }
        let _ = fs::remove_file(&probe);
        fs::set_permissions(&ro, fs::Permissions::from_mode(0o755)).unwrap();
    }
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn replacing_a_file_is_atomic() {
    // A reader polling the destination while it is rewritten sees either image, complete, and never a part.
    let dir = scratch("atomic-replace");
    let (w, h) = (1024u32, 768u32);
    let a = vec![[1.0f32, 2.0, 3.0]; (w * h) as usize];
    let b = vec![[4.0f32, 5.0, 6.0]; (w * h) as usize];
    let path = dir.join("big.pfm");
    write_rgb(&path, w, h, &a).unwrap();
    let expected = w as usize * h as usize * 12 + format!("PF\n{w} {h}\n-1.0\n").len();
    let stop = std::sync::atomic::AtomicBool::new(false);
    std::thread::scope(|s| {
        let reader = s.spawn(|| {
            let mut reads = 0;
            while !stop.load(std::sync::atomic::Ordering::Relaxed) || reads < 5 {
                let bytes = fs::read(&path).expect("the destination always exists");
                assert_eq!(bytes.len(), expected, "partial file observed");
                let (_, _, px) = read_pfm(&path).expect("always a complete PFM");
                let first = px[0];
                assert!(first == a[0] || first == b[0]);
                assert!(px.iter().all(|p| *p == first), "mixed file observed");
                reads += 1;
            }
            reads
        });
        for i in 0..8 {
            write_rgb(&path, w, h, if i % 2 == 0 { &b } else { &a }).unwrap();
        }
        stop.store(true, std::sync::atomic::Ordering::Relaxed);
        assert!(reader.join().unwrap() >= 5);
    });
    assert_eq!(read_pfm(&path).unwrap().2[0], a[0]);
    assert!(temp_leftovers(&dir).is_empty());
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn tga_textures_are_read_through_read_rgb() {
    let dir = std::env::temp_dir().join(format!("prismatic-film-tga-{}", std::process::id()));
    fs::create_dir_all(&dir).unwrap();
    // 2×1 RLE true colour, top-left origin: one run of two pixels B=0 G=188 R=255.
    let mut f = vec![0u8, 0, 10, 0, 0, 0, 0, 0, 0, 0, 0, 0, 2, 0, 1, 0, 24, 0x20];
    f.extend([0x81, 0, 188, 255]);
    let path = dir.join("t.TGA");
    fs::write(&path, &f).unwrap();
    let (w, h, px) = read_rgb(&path).unwrap();
    assert_eq!((w, h), (2, 1));
    // sRGB-decoded as an 8-bit PNG would be: 255 → 1, 188 → 0.5029, 0 → 0.
    for p in &px {
        assert_eq!((p[0], p[2]), (1.0, 0.0));
        assert!((p[1] - 0.5029).abs() < 2e-4, "{p:?}");
    }
    fs::write(&path, &f[..20]).unwrap();
    let msg = read_rgb(&path).unwrap_err().to_string();
    assert!(msg.contains("t.TGA") && msg.contains("truncated"), "{msg}");
    fs::remove_dir_all(&dir).unwrap();
}

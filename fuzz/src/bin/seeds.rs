//! Writes the generated seed inputs (small PLY meshes, PNG, EXR, PFM and TGA images, gzip-compressed scene and
//! mesh files) into `<dir>/<target>/`: `seeds DIR [SCENE.pbrt ...]`. Each covers a case the readers must decode
//! (every PLY format and index type, every PNG colour type and bit depth, the EXR compressions and tiling, both
//! PFM byte orders, every TGA image type and origin, 15/16-bit and colour-mapped TGAs), kept tiny so that the
//! fuzzer runs fast.

use std::io::Write;
use std::path::{Path, PathBuf};

// The measured-material tests' writer of RGL tensor files (an analytic GGX BRDF tabulated as pbrt-v4 reads it).
#[allow(dead_code, clippy::all)]
#[path = "../../../crates/render/src/tests/support/rgl.rs"]
mod rgl;
// What the writer builds its tables with (it takes it from the module that includes it).
use render::internals::Warp2D;

fn main() {
    let mut args = std::env::args().skip(1);
    let dir = PathBuf::from(args.next().expect("usage: seeds DIR [SCENE.pbrt ...]"));
    let scenes: Vec<PathBuf> = args.map(PathBuf::from).collect();
    for t in ["pbrt", "ply", "png", "exr", "pfm", "tga", "bsdf", "lens"] {
        std::fs::create_dir_all(dir.join(t)).unwrap();
    }
    ply_seeds(&dir.join("ply"));
    png_seeds(&dir.join("png"));
    exr_seeds(&dir.join("exr"));
    pfm_seeds(&dir.join("pfm"));
    tga_seeds(&dir.join("tga"));
    bsdf_seeds(&dir.join("bsdf"));
    lens_seeds(&dir.join("lens"));
    // One scene compressed, so the gzip path of the scene reader has a seed.
    if let Some(first) = scenes.first() {
        let text = std::fs::read(first).unwrap();
        std::fs::write(dir.join("pbrt").join("scene.pbrt.gz"), gzip(&text)).unwrap();
    }
}

/// Tiny tensor files: a spectral conductor, a white anisotropic table (3 incident azimuths) and an `rgb` file.
fn bsdf_seeds(dir: &Path) {
    use rgl::{Facet, Ggx, Resolution};
    let nodes = vec![400.0f32, 550.0, 700.0];
    let conductor = Ggx {
        alpha: 0.3,
        wavelengths: nodes.clone(),
        facet: Facet::Conductor { eta: vec![0.2, 0.9, 1.1], k: vec![2.0, 2.5, 3.5] },
    };
    std::fs::write(dir.join("conductor.bsdf"), conductor.file(Resolution::TINY)).unwrap();
    let white = Ggx { alpha: 0.5, wavelengths: nodes, facet: Facet::White };
    std::fs::write(dir.join("aniso.bsdf"), white.file(Resolution { phi_i: 3, ..Resolution::TINY })).unwrap();
    let rgb = Ggx { alpha: 0.2, wavelengths: Vec::new(), facet: Facet::Rgb([0.9, 0.5, 0.1]) };
    std::fs::write(dir.join("rgb.bsdf"), rgb.file(Resolution::TINY)).unwrap();
}

fn gzip(data: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
    e.write_all(data).unwrap();
    e.finish().unwrap()
}

fn ply_seeds(dir: &Path) {
    let ascii = "ply\nformat ascii 1.0\ncomment seed\nelement vertex 4\nproperty float x\nproperty float y\n\
                 property float z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty float u\n\
                 property float v\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n\
                 0 0 0 0 0 1 0 0\n1 0 0 0 0 1 1 0\n1 1 0 0 0 1 1 1\n0 1 0 0 0 1 0 1\n4 0 1 2 3\n3 0 2 3\n";
    std::fs::write(dir.join("ascii.ply"), ascii).unwrap();
    for (name, big, list) in
        [("le.ply", false, "uchar uint"), ("be.ply", true, "uint8 int16"), ("le8.ply", false, "char uchar")]
    {
        let fmt = if big { "binary_big_endian" } else { "binary_little_endian" };
        let mut out = format!(
            "ply\nformat {fmt} 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
             property float s\nproperty float t\nelement face 1\nproperty list {list} vertex_index\n\
             element extra 1\nproperty double junk\nproperty list uchar float more\nend_header\n"
        )
        .into_bytes();
        for (k, p) in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]].iter().enumerate() {
            for c in p.iter().chain([k as f32, 0.5].iter()) {
                out.extend(if big { c.to_be_bytes() } else { c.to_le_bytes() });
            }
        }
        out.push(3);
        for i in 0..3u32 {
            match list {
                "uchar uint" => out.extend(i.to_le_bytes()),
                "uint8 int16" => out.extend((i as i16).to_be_bytes()),
                _ => out.push(i as u8),
            }
        }
        out.extend(if big { 7.0f64.to_be_bytes() } else { 7.0f64.to_le_bytes() });
        out.push(1);
        out.extend(if big { 1.0f32.to_be_bytes() } else { 1.0f32.to_le_bytes() });
        if name == "le.ply" {
            std::fs::write(dir.join("le.ply.gz"), gzip(&out)).unwrap();
        }
        std::fs::write(dir.join(name), out).unwrap();
    }
}

fn png_seeds(dir: &Path) {
    use png::{BitDepth as D, ColorType as C};
    let cases: [(&str, C, D, bool); 9] = [
        ("rgb8", C::Rgb, D::Eight, false),
        ("rgba8", C::Rgba, D::Eight, false),
        ("grey8", C::Grayscale, D::Eight, false),
        ("greya8", C::GrayscaleAlpha, D::Eight, false),
        ("rgb16", C::Rgb, D::Sixteen, false),
        ("grey16", C::Grayscale, D::Sixteen, false),
        ("grey1", C::Grayscale, D::One, false),
        ("grey4", C::Grayscale, D::Four, true),
        ("pal2", C::Indexed, D::Two, false),
    ];
    let (w, h) = (5u32, 3u32);
    for (name, color, depth, _) in cases {
        let samples = match color {
            C::Rgb => 3,
            C::Rgba => 4,
            C::GrayscaleAlpha => 2,
            _ => 1,
        };
        let bits = match depth {
            D::One => 1,
            D::Two => 2,
            D::Four => 4,
            D::Eight => 8,
            D::Sixteen => 16,
        };
        let row = (w as usize * samples * bits).div_ceil(8);
        let data: Vec<u8> = (0..row * h as usize).map(|i| (i * 37 % 251) as u8).collect();
        let mut out = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut out, w, h);
            enc.set_color(color);
            enc.set_depth(depth);
            if color == C::Indexed {
                enc.set_palette(vec![0, 0, 0, 255, 0, 0, 0, 255, 0, 0, 0, 255]);
                enc.set_trns(vec![255, 128]);
            }
            let mut wr = enc.write_header().unwrap();
            wr.write_image_data(&data).unwrap();
        }
        std::fs::write(dir.join(format!("{name}.png")), out).unwrap();
    }
}

fn exr_seeds(dir: &Path) {
    use exr::prelude::*;
    let (w, h) = (5usize, 3usize);
    let values = |k: usize| -> Vec<f32> { (0..w * h).map(|i| (i + k) as f32 * 0.25).collect() };
    /// (file name, compression, tile size, half floats, channels)
    type Case<'a> = (&'a str, Compression, Option<usize>, bool, &'a [&'a str]);
    let cases: [Case; 9] = [
        ("rgb-none", Compression::Uncompressed, None, false, &["R", "G", "B"]),
        ("rgb-zip-half", Compression::ZIP16, None, true, &["R", "G", "B"]),
        ("rgba-piz-tiled", Compression::PIZ, Some(4), true, &["A", "B", "G", "R"]),
        ("y-rle", Compression::RLE, None, false, &["Y"]),
        ("rgb-pxr24", Compression::PXR24, None, false, &["R", "G", "B"]),
        ("rgb-b44-half", Compression::B44, Some(4), true, &["R", "G", "B"]),
        ("rgb-zips", Compression::ZIP1, None, false, &["R", "G", "B"]),
        ("spectral", Compression::ZIP1, None, false, &["B", "G", "R", "S0.450,000000nm", "S0.550,000000nm"]),
        (
            "aovs",
            Compression::RLE,
            None,
            true,
            &["B", "G", "N.X", "N.Y", "N.Z", "R", "albedo.B", "albedo.G", "albedo.R"],
        ),
    ];
    for (name, compression, tiles, half, channels) in cases {
        let list: Vec<AnyChannel<FlatSamples>> = channels
            .iter()
            .enumerate()
            .map(|(k, c)| {
                let v = values(k);
                let samples = if half {
                    FlatSamples::F16(v.into_iter().map(f16::from_f32).collect())
                } else {
                    FlatSamples::F32(v)
                };
                AnyChannel::new(Text::from(*c), samples)
            })
            .collect();
        let blocks = match tiles {
            Some(t) => Blocks::Tiles(Vec2(t, t)),
            None => Blocks::ScanLines,
        };
        let encoding = Encoding { compression, blocks, line_order: LineOrder::Increasing };
        let mut attributes = LayerAttributes::default();
        if name == "spectral" {
            attributes.other.insert(Text::from("spectralLayoutVersion"), AttributeValue::Text(Text::from("1.0")));
        }
        let layer = Layer::new((w, h), attributes, encoding, AnyChannels::sort(list.into()));
        let image = Image::from_layer(layer);
        image.write().to_file(dir.join(format!("{name}.exr"))).unwrap();
    }
}

fn pfm_seeds(dir: &Path) {
    for (name, magic, scale, channels) in [("rgb-le", "PF", -1.0f32, 3), ("grey-be", "Pf", 2.0, 1)] {
        let (w, h) = (3, 2);
        let mut out = format!("{magic}\n{w} {h}\n{scale}\n").into_bytes();
        for i in 0..w * h * channels {
            let v = i as f32 * 0.5;
            out.extend(if scale < 0.0 { v.to_le_bytes() } else { v.to_be_bytes() });
        }
        std::fs::write(dir.join(format!("{name}.pfm")), out).unwrap();
    }
}

fn tga_seeds(dir: &Path) {
    // (name, image type, bits per pixel, descriptor, pixel data after the header)
    let header = |image_type: u8, w: u16, h: u16, depth: u8, descriptor: u8, id: &[u8]| {
        let mut v = vec![id.len() as u8, 0, image_type, 0, 0, 0, 0, 0, 0, 0, 0, 0];
        v.extend(w.to_le_bytes());
        v.extend(h.to_le_bytes());
        v.extend([depth, descriptor]);
        v.extend(id);
        v
    };
    let mut rgb = header(2, 2, 2, 24, 0, b"id");
    rgb.extend([3, 2, 1, 6, 5, 4, 9, 8, 7, 12, 11, 10]);
    let mut rgba = header(2, 2, 1, 32, 0x28 | 0x10, b"");
    rgba.extend([3, 2, 1, 255, 6, 5, 4, 128]);
    let mut grey = header(3, 3, 1, 8, 0x20, b"");
    grey.extend([0, 188, 255]);
    let mut rle_grey = header(11, 3, 2, 8, 0x20, b"");
    rle_grey.extend([0x80 | 3, 50, 0x01, 7, 8]);
    let mut rle_rgb = header(10, 2, 2, 24, 0, b"");
    rle_rgb.extend([0x00, 30, 20, 10, 0x80 | 2, 3, 2, 1]);
    // 16-bit 5-5-5 true colour (attribute bit set on the first pixel), raw and RLE; 16-bit grey and alpha.
    let mut rgb16 = header(2, 2, 1, 16, 0x21, b"");
    rgb16.extend([0x00, 0xfc, 0xe0, 0x03]);
    let mut rle_rgb16 = header(10, 3, 1, 15, 0, b"");
    rle_rgb16.extend([0x81, 0x1f, 0x00, 0x00, 0xff, 0x7f]);
    let mut grey16 = header(3, 2, 1, 16, 0x20, b"");
    grey16.extend([10, 200, 250, 0]);
    // Colour-mapped: 8-bit indices into three 24-bit entries starting at index 2, and RLE 16-bit indices into
    // two 16-bit entries.
    let mapped = |image_type: u8, first: u16, len: u16, entry_bits: u8, w: u16, index_bits: u8| {
        let mut v = vec![0, 1, image_type];
        v.extend(first.to_le_bytes());
        v.extend(len.to_le_bytes());
        v.extend([entry_bits, 0, 0, 0, 0]);
        v.extend(w.to_le_bytes());
        v.extend(1u16.to_le_bytes());
        v.extend([index_bits, 0x20]);
        v
    };
    let mut cmap = mapped(1, 2, 3, 24, 4, 8);
    cmap.extend([30, 20, 10, 60, 50, 40, 90, 80, 70, 2, 3, 4, 2]);
    let mut rle_cmap = mapped(9, 0, 2, 16, 4, 16);
    rle_cmap.extend([0x00, 0x7c, 0xe0, 0x83, 0x82, 1, 0, 0x00, 0, 0]);
    for (name, bytes) in [
        ("rgb", rgb),
        ("rgba", rgba),
        ("grey", grey),
        ("rle-grey", rle_grey),
        ("rle-rgb", rle_rgb),
        ("rgb16", rgb16),
        ("rle-rgb15", rle_rgb16),
        ("grey16", grey16),
        ("cmap", cmap),
        ("rle-cmap16", rle_cmap),
    ] {
        std::fs::write(dir.join(format!("{name}.tga")), bytes).unwrap();
    }
}

/// Lens files: pbrt-v4's numbers only, and Prismatic's rows with glass names, an Abbe pair, a stop and coatings.
fn lens_seeds(dir: &Path) {
    std::fs::write(dir.join("pbrt.dat"), "# singlet\n50 5 1.5 20\n-50 45 0 20\n").unwrap();
    std::fs::write(
        dir.join("rows.dat"),
        "61.07 6.0 N-BK7 25.4 MgF2@99.6\n-47.68 2.5 SF5 25.4\n0 10 0 15\n-178.6 90 1.6/40 25.4 MgF2@92.4+zirconia@117.7\n",
    )
    .unwrap();
}

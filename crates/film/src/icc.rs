//! A minimal ICC v4 display profile (matrix and tone curves) for a wide-gamut PNG, so that viewers that read
//! `iCCP` but not `cICP` (most desktop image viewers) show Display P3 and Rec. 2020 images with their colours.
//!
//! The layout follows ICC.1:2022 (profile version 4.4): a 128-byte header, a tag table, and the tags a matrix/TRC
//! monitor profile needs (§8.3 and §8.4 of the specification): `desc`, `cprt` (`multiLocalizedUnicodeType`),
//! `wtpt` (the PCS white D50, as v4 requires), `chad` (the Bradford adaptation from the space's white to D50),
//! `rXYZ`/`gXYZ`/`bXYZ` (the primaries adapted to D50) and `rTRC`/`gTRC`/`bTRC` (one shared
//! `parametricCurveType` of function type 3, which is the sRGB transfer curve exactly).

use spectral::color::{mul_mat, white_balance_matrix, Mat3};
use spectral::RgbColorSpace;

/// The ICC profile connection space's illuminant, D50, as the specification gives it (XYZ with Y = 1).
pub const PCS_D50: [f64; 3] = [0.9642, 1.0, 0.8249];

/// The sRGB transfer function as ICC parametric curve type 3: Y = (aX + b)^g for X ≥ d, else Y = cX
/// (IEC 61966-2-1), as `[g, a, b, c, d]`.
const SRGB_CURVE: [f64; 5] = [2.4, 1.0 / 1.055, 0.055 / 1.055, 1.0 / 12.92, 0.040_45];

/// An s15Fixed16Number (ICC.1 §4.6): the value times 65536, rounded, big-endian.
fn s15f16(v: f64) -> [u8; 4] {
    ((v * 65536.0).round() as i32).to_be_bytes()
}

/// A `multiLocalizedUnicodeType` tag holding `text` in US English (ICC.1 §10.15).
fn mluc(text: &str) -> Vec<u8> {
    let utf16: Vec<u8> = text.encode_utf16().flat_map(u16::to_be_bytes).collect();
    let mut t = Vec::new();
    t.extend_from_slice(b"mluc\0\0\0\0");
    t.extend_from_slice(&1u32.to_be_bytes()); // one record
    t.extend_from_slice(&12u32.to_be_bytes()); // of 12 bytes
    t.extend_from_slice(b"enUS");
    t.extend_from_slice(&(utf16.len() as u32).to_be_bytes());
    t.extend_from_slice(&28u32.to_be_bytes()); // the string starts after this 28-byte head
    t.extend_from_slice(&utf16);
    t
}

/// An `XYZType` tag (ICC.1 §10.31).
fn xyz_tag(xyz: [f64; 3]) -> Vec<u8> {
    let mut t = b"XYZ \0\0\0\0".to_vec();
    for v in xyz {
        t.extend_from_slice(&s15f16(v));
    }
    t
}

/// The ICC v4 profile of `space` with the sRGB transfer curve: the encoding Prismatic writes its display images in.
pub fn display_profile(space: &RgbColorSpace, description: &str) -> Vec<u8> {
    let d50_xy = [PCS_D50[0] / PCS_D50.iter().sum::<f64>(), PCS_D50[1] / PCS_D50.iter().sum::<f64>()];
    let chad: Mat3 = white_balance_matrix(space.white, d50_xy);
    let to_pcs = mul_mat(&chad, &space.rgb_to_xyz);
    let column = |c: usize| [to_pcs[0][c], to_pcs[1][c], to_pcs[2][c]];
    let mut chad_tag = b"sf32\0\0\0\0".to_vec();
    for row in chad {
        for v in row {
            chad_tag.extend_from_slice(&s15f16(v));
        }
    }
    let mut curve = b"para\0\0\0\0".to_vec();
    curve.extend_from_slice(&3u16.to_be_bytes());
    curve.extend_from_slice(&[0, 0]);
    for v in SRGB_CURVE {
        curve.extend_from_slice(&s15f16(v));
    }
    // (signature, data); the three curves share one copy of the data, which ICC.1 §7.3.5 allows.
    let tags: Vec<(&[u8; 4], Vec<u8>)> = vec![
        (b"desc", mluc(description)),
        (b"cprt", mluc("No copyright, use freely")),
        (b"wtpt", xyz_tag(PCS_D50)),
        (b"chad", chad_tag),
        (b"rXYZ", xyz_tag(column(0))),
        (b"gXYZ", xyz_tag(column(1))),
        (b"bXYZ", xyz_tag(column(2))),
        (b"rTRC", curve),
    ];
    let shared_curve = [b"gTRC", b"bTRC"];
    let count = tags.len() + shared_curve.len();
    let mut table = Vec::new();
    let mut data = Vec::new();
    let data_start = 128 + 4 + 12 * count;
    let mut curve_entry = (0u32, 0u32);
    for (sig, bytes) in &tags {
        let offset = (data_start + data.len()) as u32;
        table.extend_from_slice(*sig);
        table.extend_from_slice(&offset.to_be_bytes());
        table.extend_from_slice(&(bytes.len() as u32).to_be_bytes());
        if *sig == b"rTRC" {
            curve_entry = (offset, bytes.len() as u32);
        }
        data.extend_from_slice(bytes);
        // Every tag starts on a 4-byte boundary (§7.3.1).
        data.resize(data.len().next_multiple_of(4), 0);
    }
    for sig in shared_curve {
        table.extend_from_slice(sig);
        table.extend_from_slice(&curve_entry.0.to_be_bytes());
        table.extend_from_slice(&curve_entry.1.to_be_bytes());
    }
    let size = data_start + data.len();
    let mut p = Vec::with_capacity(size);
    p.extend_from_slice(&(size as u32).to_be_bytes());
    p.extend_from_slice(&[0; 4]); // preferred CMM: none
    p.extend_from_slice(&[4, 0x40, 0, 0]); // version 4.4
    p.extend_from_slice(b"mntrRGB XYZ ");
    // Creation date (fixed, so the same image gives the same bytes): 2026-11-28 00:00:00.
    for v in [2026u16, 11, 28, 0, 0, 0] {
        p.extend_from_slice(&v.to_be_bytes());
    }
    p.extend_from_slice(b"acsp");
    p.extend_from_slice(&[0; 4 * 4 + 8]); // platform, flags, manufacturer, model; attributes (8 bytes)
    p.extend_from_slice(&0u32.to_be_bytes()); // rendering intent: perceptual
    for v in PCS_D50 {
        p.extend_from_slice(&s15f16(v));
    }
    p.extend_from_slice(&[0; 4]); // creator
    p.extend_from_slice(&[0; 16]); // profile ID: not computed (allowed, §7.2.18)
    p.extend_from_slice(&[0; 28]); // reserved
    debug_assert_eq!(p.len(), 128);
    p.extend_from_slice(&(count as u32).to_be_bytes());
    p.extend_from_slice(&table);
    p.extend_from_slice(&data);
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    fn be32(p: &[u8], at: usize) -> u32 {
        u32::from_be_bytes(p[at..at + 4].try_into().unwrap())
    }
    fn fixed(p: &[u8], at: usize) -> f64 {
        i32::from_be_bytes(p[at..at + 4].try_into().unwrap()) as f64 / 65536.0
    }
    /// The data of tag `sig`, read through the tag table as a reader would.
    fn tag<'a>(p: &'a [u8], sig: &[u8; 4]) -> &'a [u8] {
        let n = be32(p, 128) as usize;
        for i in 0..n {
            let e = 132 + 12 * i;
            if &p[e..e + 4] == sig {
                let (off, len) = (be32(p, e + 4) as usize, be32(p, e + 8) as usize);
                assert_eq!(off % 4, 0, "tag {sig:?} not 4-byte aligned");
                return &p[off..off + len];
            }
        }
        panic!("no tag {:?}", std::str::from_utf8(sig));
    }

    /// Read back as a colour-managing viewer would: the header's size and signature, the primaries adding up to
    /// the PCS white (what makes RGB white display as white), P3 red's D50 XYZ against the value the space's
    /// matrix and Bradford give independently, and the curve reproducing the sRGB decode.
    #[test]
    fn profile_reads_back_as_its_colour_space() {
        let p3 = RgbColorSpace::dci_p3();
        let p = display_profile(&p3, "Display P3");
        assert_eq!(be32(&p, 0) as usize, p.len());
        assert_eq!(&p[36..40], b"acsp");
        assert_eq!(&p[12..24], b"mntrRGB XYZ ");
        let xyz = |sig: &[u8; 4]| {
            let t = tag(&p, sig);
            assert_eq!(&t[..4], b"XYZ ");
            [fixed(t, 8), fixed(t, 12), fixed(t, 16)]
        };
        let (r, g, b) = (xyz(b"rXYZ"), xyz(b"gXYZ"), xyz(b"bXYZ"));
        for c in 0..3 {
            assert!((r[c] + g[c] + b[c] - PCS_D50[c]).abs() < 3e-4, "white component {c}");
        }
        // Display P3 red in D50 as published with Apple's Display P3 profile: (0.5151, 0.2412, -0.0011).
        for (got, want) in r.iter().zip([0.5151, 0.2412, -0.0011]) {
            assert!((got - want).abs() < 6e-4, "{r:?}");
        }
        let curve = tag(&p, b"gTRC");
        assert_eq!(&curve[..4], b"para");
        let params: Vec<f64> = (0..5).map(|i| fixed(curve, 12 + 4 * i)).collect();
        for x in [0.02, 0.2, 0.5, 0.9] {
            let y = if x >= params[4] { (params[1] * x + params[2]).powf(params[0]) } else { params[3] * x };
            assert!((y - spectral::color::srgb_decode(x)).abs() < 2e-4, "x {x}: {y}");
        }
        let desc = tag(&p, b"desc");
        assert_eq!(&desc[..4], b"mluc");
        let text: Vec<u16> = desc[28..].chunks(2).map(|c| u16::from_be_bytes([c[0], c[1]])).collect();
        assert_eq!(String::from_utf16(&text).unwrap(), "Display P3");
    }
}

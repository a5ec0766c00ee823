//! The 24 ColorChecker patches (BabelColor average spectra) under D65, against colour-science.
//!
//! The fixture `fixtures/colorchecker_babelcolor_d65.csv` was made once by `fixtures/make_colorchecker.py` with
//! colour-science 0.4.7; its header states the exact procedure. Our pipeline: the reflectance as a piecewise-linear
//! spectrum (held constant outside 380–730 nm, as the fixture's procedure does), times our embedded D65, integrated
//! at 1 nm against the CIE 1931 observer and normalised by the white's Y, then to linear sRGB with the matrix derived
//! from the sRGB primaries. Criterion: CIEDE2000 < 0.5 for every patch (Lab relative to the sRGB white).

use spectral::color::srgb_encode;
use spectral::lab::{delta_e_2000, xyz_to_lab};
use spectral::{named, Observer, RgbColorSpace, Spectrum, Xyz};

const FIXTURE: &str = include_str!("fixtures/colorchecker_babelcolor_d65.csv");

struct Patch {
    name: String,
    reflectance: Vec<f64>, // 380..=730 nm at 10 nm
    srgb_linear: [f64; 3],
    srgb_encoded: [f64; 3],
}

fn patches() -> Vec<Patch> {
    let mut lines = FIXTURE.lines().filter(|l| !l.starts_with('#') && !l.trim().is_empty());
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap_or_else(|| panic!("no column {name}"));
    let (r380, slin, senc) = (col("r380"), col("sR_lin"), col("sR"));
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let num = |i: usize| f[i].parse::<f64>().unwrap();
            Patch {
                name: f[col("name")].to_string(),
                reflectance: (0..36).map(|i| num(r380 + i)).collect(),
                srgb_linear: [num(slin), num(slin + 1), num(slin + 2)],
                srgb_encoded: [num(senc), num(senc + 1), num(senc + 2)],
            }
        })
        .collect()
}

#[test]
fn colorchecker_under_d65_matches_colour_science() {
    let patches = patches();
    assert_eq!(patches.len(), 24);
    let d65 = named::illuminant("stdillum-D65").unwrap();
    let white_y = Observer::Cie1931.spectrum_to_xyz(&d65).y;
    let srgb = RgbColorSpace::srgb();
    let white_lab_ref = srgb.to_xyz([1.0, 1.0, 1.0]).to_array();
    let mut worst = (0.0f64, String::new());
    for p in &patches {
        // Reflectance × D65 tabulated at 1 nm over 360–830 nm (reflectance constant beyond its table's ends).
        let lambdas: Vec<f64> = (360..=830).map(f64::from).collect();
        let values = lambdas
            .iter()
            .map(|&l| {
                let x = ((l - 380.0) / 10.0).clamp(0.0, 35.0);
                let i = (x as usize).min(34);
                let t = x - i as f64;
                let r = p.reflectance[i] + t * (p.reflectance[i + 1] - p.reflectance[i]);
                r * d65.eval(l)
            })
            .collect();
        let lit = Spectrum::piecewise_linear(lambdas, values).unwrap();
        let xyz: Xyz = Observer::Cie1931.spectrum_to_xyz(&lit).scaled(1.0 / white_y);
        let rgb = srgb.to_rgb(xyz);
        // Compare in CIELAB: both linear sRGB triples back to XYZ with the same matrix, Lab relative to the white.
        let ours = xyz_to_lab(srgb.to_xyz(rgb).to_array(), white_lab_ref);
        let theirs = xyz_to_lab(srgb.to_xyz(p.srgb_linear).to_array(), white_lab_ref);
        let de = delta_e_2000(ours, theirs);
        assert!(de < 0.5, "{}: ΔE00 = {de:.3} (ours {rgb:?}, colour-science {:?})", p.name, p.srgb_linear);
        // Encoded values agree to well under one 8-bit step for in-gamut patches.
        if p.srgb_linear.iter().all(|&c| (0.0..=1.0).contains(&c)) {
            for (c, (ours, theirs)) in rgb.iter().zip(p.srgb_encoded).enumerate() {
                assert!((srgb_encode(*ours) - theirs).abs() < 2.0 / 255.0, "{} channel {c}", p.name);
            }
        }
        if de > worst.0 {
            worst = (de, p.name.clone());
        }
    }
    eprintln!("worst ΔE00 = {:.4} ({})", worst.0, worst.1);
    // Measured 0.014 (white 9.5): the remaining differences are D65 past 780 nm (colour-science holds it constant,
    // our table has the CIE values) and IEC's rounded matrix. Guard against regressions well below the 0.5 bound.
    assert!(worst.0 < 0.05, "worst ΔE00 {:.4} ({})", worst.0, worst.1);
}

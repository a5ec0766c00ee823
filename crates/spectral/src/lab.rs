//! CIE 1976 L\*a\*b\* and the colour differences ΔE\*ab (CIE 1976) and ΔE00 (CIEDE2000).
//!
//! Self-contained (std only). Lab triples are `[L*, a*, b*]` with L* on the usual 0–100 scale; XYZ and the
//! reference white may use any common scale (Y = 1 or Y = 100), as only the ratios X/Xn, Y/Yn, Z/Zn enter.

/// The CIE L\*a\*b\* threshold ε = 216/24389 ≈ 0.008856 on the relative tristimulus value t = Y/Yn.
// Citation: CIE 15:2004, Colorimetry, 3rd ed., §8.2.1 (CIELAB), ε = (6/29)³ written as an exact fraction.
pub const EPSILON: f64 = 216.0 / 24389.0;

/// The CIE L\*a\*b\* slope κ = 24389/27 ≈ 903.3: L\* = κ·Y/Yn below the threshold [`EPSILON`].
// Citation: CIE 15:2004, Colorimetry, 3rd ed., §8.2.1 (CIELAB), κ = (29/3)³ written as an exact fraction.
pub const KAPPA: f64 = 24389.0 / 27.0;

/// 25⁷, the constant of the CIEDE2000 chroma terms G and R_C (exact in f64).
const POW25_7: f64 = 6_103_515_625.0;

/// The CIE L\*a\*b\* companding function f(t): ∛t above ε, (κ·t + 16)/116 at or below it.
///
/// The two branches meet at t = ε (both give 6/29), so f is continuous.
fn lab_f(t: f64) -> f64 {
    if t > EPSILON {
        t.cbrt()
    } else {
        (KAPPA * t + 16.0) / 116.0
    }
}

/// Converts CIE XYZ to CIE 1976 L\*a\*b\* relative to the reference white `white` = [Xn, Yn, Zn].
///
/// `xyz` and `white` must be on the same scale (both Y = 1 or both Y = 100) and under the same observer. The
/// white itself maps to exactly `[100.0, 0.0, 0.0]`. Values below the threshold (including zero and negative
/// tristimulus values) use the linear segment, so the result is finite for any finite input with a positive
/// white.
// Citation: CIE 15:2004, Colorimetry, 3rd ed., §8.2.1 (CIELAB: L*, a*, b* via f(t), with exact ε and κ).
pub fn xyz_to_lab(xyz: [f64; 3], white: [f64; 3]) -> [f64; 3] {
    let fx = lab_f(xyz[0] / white[0]);
    let fy = lab_f(xyz[1] / white[1]);
    let fz = lab_f(xyz[2] / white[2]);
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

/// The CIE 1976 colour difference ΔE\*ab: the Euclidean distance between two L\*a\*b\* triples.
// Citation: CIE 15:2004, Colorimetry, 3rd ed., §8.2.1 (ΔE*ab = [(ΔL*)² + (Δa*)² + (Δb*)²]^½).
pub fn delta_e_76(a: [f64; 3], b: [f64; 3]) -> f64 {
    let (dl, da, db) = (a[0] - b[0], a[1] - b[1], a[2] - b[2]);
    (dl * dl + da * da + db * db).sqrt()
}

/// A hue angle in degrees in [0, 360), with the convention h = 0 when a = b = 0 (Sharma et al. 2005).
fn hue_degrees(b: f64, a: f64) -> f64 {
    if a == 0.0 && b == 0.0 {
        return 0.0;
    }
    let h = b.atan2(a).to_degrees();
    if h < 0.0 {
        h + 360.0
    } else {
        h
    }
}

/// The CIEDE2000 colour difference ΔE00 between two L\*a\*b\* triples, with parametric factors kL = kC = kH = 1.
///
/// Follows the implementation notes of Sharma, Wu & Dalal (2005) step by step, including their hue conventions:
/// h′ = 0 for a neutral colour (a′ = b = 0); Δh′ = 0 and h̄′ = h′₁ + h′₂ when either chroma C′ is 0; Δh′ and the mean
/// hue h̄′ are taken the short way round the hue circle (the ±360° wrap when |h′₁ − h′₂| > 180°, with |Δh′| = 180°
/// counted as the direct branch). The result is symmetric in `a` and `b` except, possibly, at a hue difference of
/// exactly 180°, where the formula itself is discontinuous.
// Citation: G. Sharma, W. Wu, E. N. Dalal, Color Res. Appl. 30(1), 21–30 (2005), implementation notes; CIE 142:2001.
pub fn delta_e_2000(a: [f64; 3], b: [f64; 3]) -> f64 {
    let [l1, a1, b1] = a;
    let [l2, a2, b2] = b;

    // Step 1: C′, h′.
    let c1 = a1.hypot(b1);
    let c2 = a2.hypot(b2);
    let c_bar = 0.5 * (c1 + c2);
    let c_bar7 = c_bar.powi(7);
    let g = 0.5 * (1.0 - (c_bar7 / (c_bar7 + POW25_7)).sqrt());
    let a1p = (1.0 + g) * a1;
    let a2p = (1.0 + g) * a2;
    let c1p = a1p.hypot(b1);
    let c2p = a2p.hypot(b2);
    let h1p = hue_degrees(b1, a1p);
    let h2p = hue_degrees(b2, a2p);

    // Step 2: ΔL′, ΔC′, Δh′, ΔH′.
    let dlp = l2 - l1;
    let dcp = c2p - c1p;
    let c_prod = c1p * c2p;
    let dh_raw = h2p - h1p;
    let dhp = if c_prod == 0.0 {
        0.0
    } else if dh_raw.abs() <= 180.0 {
        dh_raw
    } else if dh_raw > 180.0 {
        dh_raw - 360.0
    } else {
        dh_raw + 360.0
    };
    let dhp_big = 2.0 * c_prod.sqrt() * (0.5 * dhp).to_radians().sin();

    // Step 3: L̄′, C̄′, h̄′, T, Δθ, R_C, S_L, S_C, S_H, R_T, ΔE00.
    let l_bar = 0.5 * (l1 + l2);
    let cp_bar = 0.5 * (c1p + c2p);
    let h_sum = h1p + h2p;
    let hp_bar = if c_prod == 0.0 {
        h_sum
    } else if (h1p - h2p).abs() <= 180.0 {
        0.5 * h_sum
    } else if h_sum < 360.0 {
        0.5 * (h_sum + 360.0)
    } else {
        0.5 * (h_sum - 360.0)
    };
    let t = 1.0 - 0.17 * (hp_bar - 30.0).to_radians().cos()
        + 0.24 * (2.0 * hp_bar).to_radians().cos()
        + 0.32 * (3.0 * hp_bar + 6.0).to_radians().cos()
        - 0.20 * (4.0 * hp_bar - 63.0).to_radians().cos();
    let d_theta = 30.0 * (-((hp_bar - 275.0) / 25.0).powi(2)).exp();
    let cp_bar7 = cp_bar.powi(7);
    let r_c = 2.0 * (cp_bar7 / (cp_bar7 + POW25_7)).sqrt();
    let l50 = (l_bar - 50.0) * (l_bar - 50.0);
    let s_l = 1.0 + 0.015 * l50 / (20.0 + l50).sqrt();
    let s_c = 1.0 + 0.045 * cp_bar;
    let s_h = 1.0 + 0.015 * cp_bar * t;
    let r_t = -(2.0 * d_theta).to_radians().sin() * r_c;

    // kL = kC = kH = 1.
    let tl = dlp / s_l;
    let tc = dcp / s_c;
    let th = dhp_big / s_h;
    (tl * tl + tc * tc + th * th + r_t * tc * th).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    const PAIRS: &str = include_str!("../tests/fixtures/ciede2000_pairs.csv");
    const CHECKER: &str = include_str!("../tests/fixtures/colorchecker_babelcolor_d65.csv");

    /// Non-comment lines of a fixture: (header columns, data rows), split on commas.
    fn table(text: &str) -> (Vec<&str>, Vec<Vec<&str>>) {
        let mut lines = text.lines().filter(|l| !l.starts_with('#') && !l.trim().is_empty());
        let header = lines.next().expect("header row").split(',').collect();
        (header, lines.map(|l| l.split(',').collect()).collect())
    }

    fn col(header: &[&str], name: &str) -> usize {
        header.iter().position(|h| *h == name).unwrap_or_else(|| panic!("no column {name}"))
    }

    fn num(s: &str) -> f64 {
        s.parse().unwrap_or_else(|e| panic!("bad number {s:?}: {e}"))
    }

    #[test]
    fn ciede2000_matches_sharma_pairs() {
        let (h, rows) = table(PAIRS);
        assert_eq!(rows.len(), 33, "Sharma et al. pairs 1–34 less pair 14");
        let lab = |r: &[&str], names: [&str; 3]| names.map(|n| num(r[col(&h, n)]));
        let mut cases = std::collections::BTreeSet::new();
        for r in &rows {
            let lab1 = lab(r, ["L1", "a1", "b1"]);
            let lab2 = lab(r, ["L2", "a2", "b2"]);
            let colour = num(r[col(&h, "de00_colour")]);
            let published = num(r[col(&h, "de00_published")]);
            let de = delta_e_2000(lab1, lab2);
            let pair = r[col(&h, "pair")];
            assert!((de - colour).abs() < 1e-4, "pair {pair}: {de} vs colour-science {colour}");
            assert!((de - published).abs() < 1e-4, "pair {pair}: {de} vs published {published}");
            // Tighter: the same formula in f64 agrees with colour-science far below the paper's rounding.
            assert!((de - colour).abs() < 1e-9, "pair {pair}: {de} vs colour-science {colour}");
            let back = delta_e_2000(lab2, lab1);
            assert!((de - back).abs() < 1e-9, "pair {pair} not symmetric: {de} vs {back}");
            cases.insert(r[col(&h, "dh_case")]);
            cases.insert(r[col(&h, "hbar_case")]);
        }
        // The fixture exercises every branch of Δh′ and h̄′.
        for c in ["zero", "direct", "minus360", "plus360", "sum", "mean", "mean_plus180", "mean_minus180"] {
            assert!(cases.contains(c), "no pair exercises the {c} branch");
        }
    }

    #[test]
    fn ciede2000_basic_properties() {
        let x = [50.0, 2.5, -3.0];
        assert_eq!(delta_e_2000(x, x), 0.0);
        assert_eq!(delta_e_2000([0.0; 3], [0.0; 3]), 0.0);
        // Pure lightness difference at L̄ = 50: S_L = 1, so ΔE00 = |ΔL|.
        assert!((delta_e_2000([49.0, 0.0, 0.0], [51.0, 0.0, 0.0]) - 2.0).abs() < 1e-12);
    }

    #[test]
    fn white_is_100_0_0() {
        for white in [[0.9504707649452452, 0.9999999999999997, 1.0888284224364946], [95.047, 100.0, 108.883]] {
            assert_eq!(xyz_to_lab(white, white), [100.0, 0.0, 0.0]);
        }
    }

    #[test]
    fn lab_branches_meet_at_epsilon() {
        assert!((EPSILON.cbrt() - 6.0 / 29.0).abs() < 1e-15);
        assert!(((KAPPA * EPSILON + 16.0) / 116.0 - 6.0 / 29.0).abs() < 1e-15);
        let w = [1.0; 3];
        assert_eq!(xyz_to_lab([0.0; 3], w), [0.0, 0.0, 0.0]);
        // Below ε, L* = κ·Y/Yn.
        let y = 0.5 * EPSILON;
        assert!((xyz_to_lab([y, y, y], w)[0] - KAPPA * y).abs() < 1e-12);
    }

    #[test]
    fn lab_matches_colour_science_on_colorchecker() {
        // The fixture's L, a, b columns are colour.XYZ_to_Lab relative to its computed PRD white, given in the
        // comment line "White (PRD, ...): X,Y,Z = x,y,z".
        let white_line = CHECKER.lines().find(|l| l.starts_with("#   White (PRD")).expect("white comment line");
        let white: Vec<f64> = white_line.rsplit("= ").next().unwrap().split(',').map(|s| num(s.trim())).collect();
        let white = [white[0], white[1], white[2]];
        let (h, rows) = table(CHECKER);
        assert_eq!(rows.len(), 24);
        for r in &rows {
            let xyz = ["X", "Y", "Z"].map(|n| num(r[col(&h, n)]));
            let expect = ["L", "a", "b"].map(|n| num(r[col(&h, n)]));
            let got = xyz_to_lab(xyz, white);
            for i in 0..3 {
                assert!((got[i] - expect[i]).abs() < 1e-9, "{}: {got:?} vs {expect:?}", r[1]);
            }
        }
    }

    #[test]
    fn delta_e_76_is_euclidean() {
        assert_eq!(delta_e_76([50.0, 3.0, 4.0], [50.0, 0.0, 0.0]), 5.0);
        assert_eq!(delta_e_76([10.0, -1.0, 2.0], [10.0, -1.0, 2.0]), 0.0);
    }
}

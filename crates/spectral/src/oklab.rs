//! Oklab, the perceptual colour space of Ottosson (2020), and its polar form LCh.
//!
//! Oklab predicts lightness `L` (0 black, 1 the D65 white of luminance Y = 1), and two opponent axes `a`, `b`,
//! such that hue (the angle of (a, b)) stays perceptually constant when chroma (the length of (a, b)) changes;
//! the display transform keeps hue and lightness there while it compresses chroma (CIELAB bends blues towards
//! purple when it does the same). Source: B. Ottosson, "A perceptual color space for image processing" (2020),
//! whose XYZ (D65, Y = 1) → LMS matrix M1 and LMS′ → Lab matrix M2 are used as published; the inverses are
//! computed from them to 12 digits.
//!
//! ```
//! use spectral::oklab::{xyz_to_oklab, oklab_to_xyz};
//! // The D65 white of luminance 1 is L = 1 with no chroma.
//! let lab = xyz_to_oklab([0.950, 1.000, 1.089]);
//! assert!((lab[0] - 1.0).abs() < 1e-3 && lab[1].abs() < 1e-3 && lab[2].abs() < 1e-3);
//! let back = oklab_to_xyz(lab);
//! assert!((back[2] - 1.089).abs() < 1e-9);
//! ```

use crate::color::{mul_mat_vec, Mat3};

/// XYZ (D65, Y = 1) → cone-like LMS (Ottosson 2020, M1).
const M1: Mat3 = [
    [0.818_933_010_1, 0.361_866_742_4, -0.128_859_713_7],
    [0.032_984_543_6, 0.929_311_871_5, 0.036_145_638_7],
    [0.048_200_301_8, 0.264_366_269_1, 0.633_851_707_0],
];
/// Cube-rooted LMS → Lab (Ottosson 2020, M2).
const M2: Mat3 = [
    [0.210_454_255_3, 0.793_617_785_0, -0.004_072_046_8],
    [1.977_998_495_1, -2.428_592_205_0, 0.450_593_709_9],
    [0.025_904_037_1, 0.782_771_766_2, -0.808_675_766_0],
];
/// M1⁻¹.
const M1_INV: Mat3 = [
    [1.227_013_851_104, -0.557_799_980_652, 0.281_256_148_966],
    [-0.040_580_178_423, 1.112_256_869_617, -0.071_676_678_666],
    [-0.076_381_284_506, -0.421_481_978_418, 1.586_163_220_441],
];
/// M2⁻¹.
const M2_INV: Mat3 = [
    [0.999_999_998_451, 0.396_337_792_174, 0.215_803_758_061],
    [1.000_000_008_882, -0.105_561_342_324, -0.063_854_174_772],
    [1.000_000_054_672, -0.089_484_182_095, -1.291_485_537_864],
];

/// XYZ (D65, Y = 1) → Oklab's linear cone responses LMS (M1), for composing with a colour space's matrix.
pub const XYZ_TO_LMS: Mat3 = M1;
/// LMS → XYZ (M1⁻¹).
pub const LMS_TO_XYZ: Mat3 = M1_INV;

/// Oklab's linear cone responses LMS ([`XYZ_TO_LMS`]) → `[L, a, b]`: the cube root, then M2.
pub fn lms_to_oklab(lms: [f64; 3]) -> [f64; 3] {
    mul_mat_vec(&M2, lms.map(f64::cbrt))
}

/// `[L, a, b]` → linear cone responses LMS; the inverse of [`lms_to_oklab`].
pub fn oklab_to_lms(lab: [f64; 3]) -> [f64; 3] {
    mul_mat_vec(&M2_INV, lab).map(|v| v * v * v)
}

/// CIE XYZ (D65 white at Y = 1) → Oklab `[L, a, b]`. Negative cone responses keep their sign through the cube
/// root, so the map is defined (and invertible) for any XYZ.
pub fn xyz_to_oklab(xyz: [f64; 3]) -> [f64; 3] {
    lms_to_oklab(mul_mat_vec(&M1, xyz))
}

/// Oklab `[L, a, b]` → CIE XYZ (D65 white at Y = 1); the inverse of [`xyz_to_oklab`].
pub fn oklab_to_xyz(lab: [f64; 3]) -> [f64; 3] {
    mul_mat_vec(&M1_INV, oklab_to_lms(lab))
}

/// Oklab `[L, a, b]` → `[L, C, h]`: chroma C = |(a, b)| and hue h = atan2(b, a) in degrees, in [0, 360).
pub fn oklab_to_lch(lab: [f64; 3]) -> [f64; 3] {
    let h = lab[2].atan2(lab[1]).to_degrees();
    [lab[0], lab[1].hypot(lab[2]), if h < 0.0 { h + 360.0 } else { h }]
}

/// `[L, C, h]` (h in degrees) → Oklab `[L, a, b]`; the inverse of [`oklab_to_lch`].
pub fn lch_to_oklab(lch: [f64; 3]) -> [f64; 3] {
    let (s, c) = lch[2].to_radians().sin_cos();
    [lch[0], lch[1] * c, lch[1] * s]
}

/// The Oklab colour difference ΔE_ok: the Euclidean distance in Oklab. One unit of L spans black to white, so
/// ΔE_ok ≈ ΔE*ab / 100 for small differences; about 0.02 is just noticeable.
pub fn delta_e_ok(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Ottosson's table of test values (XYZ → Oklab), given there to three decimals.
    #[test]
    fn matches_the_published_test_values() {
        let cases = [
            ([0.950, 1.000, 1.089], [1.000, 0.000, 0.000]),
            ([1.000, 0.000, 0.000], [0.450, 1.236, -0.019]),
            ([0.000, 1.000, 0.000], [0.922, -0.671, 0.263]),
            ([0.000, 0.000, 1.000], [0.153, -1.415, -0.449]),
        ];
        for (xyz, want) in cases {
            let got = xyz_to_oklab(xyz);
            for c in 0..3 {
                assert!((got[c] - want[c]).abs() <= 6e-4, "{xyz:?}: {got:?} vs {want:?}");
            }
        }
    }

    #[test]
    fn round_trips_and_polar_form_round_trips() {
        for xyz in [[0.2, 0.3, 0.4], [0.05, 0.01, 0.9], [1.5, 2.0, 0.1], [-0.01, 0.02, 0.03]] {
            let lab = xyz_to_oklab(xyz);
            let back = oklab_to_xyz(lab);
            for c in 0..3 {
                assert!((back[c] - xyz[c]).abs() < 1e-9, "{xyz:?} → {back:?}");
            }
            let again = lch_to_oklab(oklab_to_lch(lab));
            assert!(delta_e_ok(lab, again) < 1e-12);
            let h = oklab_to_lch(lab)[2];
            assert!((0.0..360.0).contains(&h));
        }
    }

    /// Lightness is the cube root of luminance along the grey axis: L(Y·white) = Y^(1/3).
    #[test]
    fn grey_lightness_is_the_cube_root_of_luminance() {
        let white = oklab_to_xyz([1.0, 0.0, 0.0]);
        for y in [0.001, 0.18, 0.5, 2.0] {
            let lab = xyz_to_oklab(white.map(|v| v * y));
            assert!((lab[0] - f64::cbrt(y)).abs() < 1e-9, "Y {y}: L {}", lab[0]);
            assert!(lab[1].hypot(lab[2]) < 1e-9);
        }
    }
}

//! Colour: CIE XYZ, chromaticity, RGB colour spaces, the sRGB transfer function and dithered quantisation.

/// A 3×3 matrix in row-major order (f64: colour matrices need the precision).
pub type Mat3 = [[f64; 3]; 3];

/// `m · v`.
pub fn mul_mat_vec(m: &Mat3, v: [f64; 3]) -> [f64; 3] {
    [
        m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
        m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
        m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2],
    ]
}

/// `a · b`.
pub fn mul_mat(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut r = [[0.0; 3]; 3];
    for (i, row) in r.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    r
}

/// Inverse by the adjugate, or `None` for a singular matrix.
pub fn invert(m: &Mat3) -> Option<Mat3> {
    let c = |r0: usize, c0: usize, r1: usize, c1: usize| m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0];
    let cof = [
        [c(1, 1, 2, 2), -c(1, 0, 2, 2), c(1, 0, 2, 1)],
        [-c(0, 1, 2, 2), c(0, 0, 2, 2), -c(0, 0, 2, 1)],
        [c(0, 1, 1, 2), -c(0, 0, 1, 2), c(0, 0, 1, 1)],
    ];
    let det = m[0][0] * cof[0][0] + m[0][1] * cof[0][1] + m[0][2] * cof[0][2];
    if det.abs() < 1e-300 || !det.is_finite() {
        return None;
    }
    let mut inv = [[0.0; 3]; 3];
    for (i, row) in inv.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = cof[j][i] / det; // transpose of the cofactor matrix
        }
    }
    Some(inv)
}

/// CIE 1931 (or 1964) tristimulus values. Y = 1 is the luminance of the reference white.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Xyz {
    /// X.
    pub x: f64,
    /// Y (luminance).
    pub y: f64,
    /// Z.
    pub z: f64,
}

impl Xyz {
    /// From components.
    pub const fn new(x: f64, y: f64, z: f64) -> Self {
        Self { x, y, z }
    }

    /// From chromaticity (x, y) and luminance Y: X = xY/y, Z = (1 − x − y)Y/y.
    pub fn from_xy_y(xy: [f64; 2], luminance: f64) -> Self {
        if xy[1] == 0.0 {
            return Self::default();
        }
        Self::new(xy[0] * luminance / xy[1], luminance, (1.0 - xy[0] - xy[1]) * luminance / xy[1])
    }

    /// Chromaticity coordinates x = X/(X+Y+Z), y = Y/(X+Y+Z); (0, 0) for black.
    pub fn chromaticity(&self) -> [f64; 2] {
        let s = self.x + self.y + self.z;
        if s == 0.0 {
            [0.0, 0.0]
        } else {
            [self.x / s, self.y / s]
        }
    }

    /// As an array.
    pub fn to_array(self) -> [f64; 3] {
        [self.x, self.y, self.z]
    }

    /// From an array.
    pub fn from_array(a: [f64; 3]) -> Self {
        Self::new(a[0], a[1], a[2])
    }

    /// Scaled by `s`.
    pub fn scaled(self, s: f64) -> Self {
        Self::new(self.x * s, self.y * s, self.z * s)
    }
}

/// A linear RGB colour space defined by the chromaticities of its primaries and white point.
#[derive(Clone, Debug, PartialEq)]
pub struct RgbColorSpace {
    /// Name used on the command line and in scene files.
    pub name: &'static str,
    /// Chromaticities of the red, green and blue primaries.
    pub primaries: [[f64; 2]; 3],
    /// Chromaticity of the white point (RGB = (1, 1, 1) has this chromaticity and Y = 1).
    pub white: [f64; 2],
    /// Linear RGB → XYZ.
    pub rgb_to_xyz: Mat3,
    /// XYZ → linear RGB.
    pub xyz_to_rgb: Mat3,
}

impl RgbColorSpace {
    /// Builds the space; the matrix columns are the primaries' XYZ scaled so that RGB (1,1,1) maps to the white
    /// with Y = 1 (SMPTE RP 177-1993 derivation).
    pub fn new(name: &'static str, primaries: [[f64; 2]; 3], white: [f64; 2]) -> Self {
        let p = primaries.map(|xy| Xyz::from_xy_y(xy, 1.0).to_array());
        let m = [[p[0][0], p[1][0], p[2][0]], [p[0][1], p[1][1], p[2][1]], [p[0][2], p[1][2], p[2][2]]];
        let w = Xyz::from_xy_y(white, 1.0).to_array();
        let s = mul_mat_vec(&invert(&m).expect("colour space primaries are not collinear"), w);
        let rgb_to_xyz = m.map(|row| [row[0] * s[0], row[1] * s[1], row[2] * s[2]]);
        let xyz_to_rgb = invert(&rgb_to_xyz).expect("colour space matrix is invertible");
        Self { name, primaries, white, rgb_to_xyz, xyz_to_rgb }
    }

    /// sRGB / Rec. 709 primaries, D65 white (IEC 61966-2-1).
    pub fn srgb() -> Self {
        Self::new("srgb", [[0.64, 0.33], [0.30, 0.60], [0.15, 0.06]], D65_WHITE)
    }

    /// ITU-R BT.2020 primaries, D65 white.
    pub fn rec2020() -> Self {
        Self::new("rec2020", [[0.708, 0.292], [0.170, 0.797], [0.131, 0.046]], D65_WHITE)
    }

    /// Display P3: the DCI-P3 primaries with a D65 white (SMPTE EG 432-1), the wide gamut of current phones and
    /// laptops; pbrt-v4 calls it `dci-p3` (its `RGBColorSpace::DCI_P3` has the D65 white).
    pub fn dci_p3() -> Self {
        Self::new("dci-p3", [[0.680, 0.320], [0.265, 0.690], [0.150, 0.060]], D65_WHITE)
    }

    /// ACES2065-1 (AP0 primaries, ACES white ≈ D60), SMPTE ST 2065-1.
    pub fn aces2065_1() -> Self {
        Self::new("aces2065-1", [[0.7347, 0.2653], [0.0, 1.0], [0.0001, -0.0770]], [0.32168, 0.33767])
    }

    /// Looks a space up by name: `srgb`, `dci-p3` (also `display-p3`, `p3`), `rec2020`, `aces2065-1`
    /// (case-insensitive).
    pub fn by_name(name: &str) -> Option<Self> {
        match name.to_ascii_lowercase().as_str() {
            "srgb" => Some(Self::srgb()),
            "dci-p3" | "display-p3" | "p3" => Some(Self::dci_p3()),
            "rec2020" => Some(Self::rec2020()),
            "aces2065-1" | "aces" => Some(Self::aces2065_1()),
            _ => None,
        }
    }

    /// Names accepted by [`RgbColorSpace::by_name`].
    pub const NAMES: [&'static str; 4] = ["srgb", "dci-p3", "rec2020", "aces2065-1"];

    /// XYZ → linear RGB (colorimetric: no chromatic adaptation).
    pub fn to_rgb(&self, xyz: Xyz) -> [f64; 3] {
        mul_mat_vec(&self.xyz_to_rgb, xyz.to_array())
    }

    /// Linear RGB → XYZ.
    pub fn to_xyz(&self, rgb: [f64; 3]) -> Xyz {
        Xyz::from_array(mul_mat_vec(&self.rgb_to_xyz, rgb))
    }
}

/// CIE D65 chromaticity as the sRGB and Rec. 2020 standards state it.
pub const D65_WHITE: [f64; 2] = [0.3127, 0.3290];

/// Bradford cone response matrix (Lam 1985, as used in ICC v4).
const BRADFORD: Mat3 = [[0.8951, 0.2664, -0.1614], [-0.7502, 1.7135, 0.0367], [0.0389, -0.0685, 1.0296]];

/// The XYZ → XYZ matrix of a von Kries chromatic adaptation in Bradford cone space from white `from` to white `to`
/// (chromaticities, both taken at Y = 1): M⁻¹ · diag(ρ_d/ρ_s, γ_d/γ_s, β_d/β_s) · M with M the Bradford matrix
/// (von Kries 1902; Lam 1985 for M). It maps the XYZ of `from` at any luminance to that of `to` at the same Y.
pub fn white_balance_matrix(from: [f64; 2], to: [f64; 2]) -> Mat3 {
    let ws = mul_mat_vec(&BRADFORD, Xyz::from_xy_y(from, 1.0).to_array());
    let wd = mul_mat_vec(&BRADFORD, Xyz::from_xy_y(to, 1.0).to_array());
    let gain = [[wd[0] / ws[0], 0.0, 0.0], [0.0, wd[1] / ws[1], 0.0], [0.0, 0.0, wd[2] / ws[2]]];
    mul_mat(&invert(&BRADFORD).expect("Bradford is invertible"), &mul_mat(&gain, &BRADFORD))
}

/// Chromatic adaptation of `xyz` from white `from` to white `to` (chromaticities) by the Bradford transform.
pub fn bradford_adapt(xyz: Xyz, from: [f64; 2], to: [f64; 2]) -> Xyz {
    Xyz::from_array(mul_mat_vec(&white_balance_matrix(from, to), xyz.to_array()))
}

/// The sRGB transfer function (IEC 61966-2-1): linear → encoded, for values in [0, 1] (clamped).
pub fn srgb_encode(linear: f64) -> f64 {
    let v = linear.clamp(0.0, 1.0);
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// Inverse of [`srgb_encode`]: encoded → linear.
pub fn srgb_decode(encoded: f64) -> f64 {
    let v = encoded.clamp(0.0, 1.0);
    if v <= 0.040_45 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// Quantises an encoded value in [0, 1] to 8 bits with random-rounding dither.
///
/// `u ∈ [0, 1)` is a uniform random number: the result is ⌊255·v + u⌋, so its expectation is exactly 255·v and
/// smooth gradients show no banding (seed 001: "apply dithering and map each component to 8 bit integers").
pub fn quantize_8bit_dithered(encoded: f64, u: f64) -> u8 {
    if encoded.is_nan() {
        return 0;
    }
    (encoded.clamp(0.0, 1.0) * 255.0 + u.clamp(0.0, 0.999_999)).floor().clamp(0.0, 255.0) as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn srgb_matrix_matches_iec_61966() {
        // IEC 61966-2-1 publishes the XYZ → sRGB matrix to 4 decimals.
        let m = RgbColorSpace::srgb().xyz_to_rgb;
        let iec = [[3.2406, -1.5372, -0.4986], [-0.9689, 1.8758, 0.0415], [0.0557, -0.2040, 1.0570]];
        for i in 0..3 {
            for j in 0..3 {
                assert!(close(m[i][j], iec[i][j], 6e-4), "{i},{j}: {} vs {}", m[i][j], iec[i][j]);
            }
        }
    }

    #[test]
    fn aces_and_rec2020_matrices_match_published_values() {
        // SMPTE ST 2065-1 AP0 → XYZ matrix.
        let m = RgbColorSpace::aces2065_1().rgb_to_xyz;
        let ap0 = [[0.952_552_4, 0.0, 0.000_093_7], [0.343_966_4, 0.728_166_1, -0.072_132_5], [0.0, 0.0, 1.008_825_2]];
        // Rec. 2020 → XYZ (ITU-R BT.2087 / colour-science), 6 decimals.
        let r = RgbColorSpace::rec2020().rgb_to_xyz;
        let bt = [[0.636_958, 0.144_617, 0.168_881], [0.262_700, 0.677_998, 0.059_302], [0.0, 0.028_073, 1.060_985]];
        for i in 0..3 {
            for j in 0..3 {
                assert!(close(m[i][j], ap0[i][j], 1e-6), "AP0 {i},{j}: {}", m[i][j]);
                assert!(close(r[i][j], bt[i][j], 2e-6), "2020 {i},{j}: {}", r[i][j]);
            }
        }
    }

    #[test]
    fn white_maps_to_unit_rgb_and_back() {
        for cs in RgbColorSpace::NAMES.map(|n| RgbColorSpace::by_name(n).unwrap()) {
            let rgb = cs.to_rgb(Xyz::from_xy_y(cs.white, 1.0));
            for c in rgb {
                assert!(close(c, 1.0, 1e-12), "{}: {rgb:?}", cs.name);
            }
            let back = cs.to_xyz([0.2, 0.5, 0.9]);
            let again = cs.to_rgb(back);
            assert!(close(again[0], 0.2, 1e-12) && close(again[1], 0.5, 1e-12) && close(again[2], 0.9, 1e-12));
        }
        assert!(RgbColorSpace::by_name("adobe").is_none());
    }

    #[test]
    fn srgb_transfer_roundtrips_and_hits_known_points() {
        assert_eq!(srgb_encode(0.0), 0.0);
        assert!(close(srgb_encode(1.0), 1.0, 1e-12));
        assert!(close(srgb_encode(0.18), 0.461_356, 1e-6)); // 18% grey → 0.4614
        for i in 0..=100 {
            let v = i as f64 / 100.0;
            assert!(close(srgb_decode(srgb_encode(v)), v, 1e-12));
        }
    }

    #[test]
    fn dithered_quantisation_is_unbiased() {
        // With u uniform on a fine grid, the mean code equals 255·v.
        for v in [0.0, 0.1234, 0.5, 0.777, 1.0] {
            let n = 10_000;
            let mean: f64 =
                (0..n).map(|i| quantize_8bit_dithered(v, (i as f64 + 0.5) / n as f64) as f64).sum::<f64>() / n as f64;
            assert!(close(mean, 255.0 * v, 1e-3), "v = {v}: mean {mean}");
        }
        assert_eq!(quantize_8bit_dithered(f64::NAN, 0.5), 0);
        assert_eq!(quantize_8bit_dithered(2.0, 0.99), 255);
    }

    #[test]
    fn bradford_maps_white_to_white() {
        let d65 = Xyz::from_xy_y(D65_WHITE, 1.0);
        let d50 = [0.3457, 0.3585];
        let a = bradford_adapt(d65, D65_WHITE, d50);
        let xy = a.chromaticity();
        assert!(close(xy[0], d50[0], 1e-9) && close(xy[1], d50[1], 1e-9));
    }

    #[test]
    fn white_balance_matrix_matches_colour_science() {
        // colour-science 0.4.7: chromatic_adaptation_VonKries([0.2, 0.3, 0.4], xyY_to_XYZ([0.3457, 0.3585, 1]),
        // xyY_to_XYZ([0.3127, 0.3290, 1]), transform='Bradford').
        let m = white_balance_matrix([0.3457, 0.3585], D65_WHITE);
        let got = mul_mat_vec(&m, [0.2, 0.3, 0.4]);
        let want = [0.209_468_85, 0.305_741_25, 0.528_456_88];
        for c in 0..3 {
            assert!(close(got[c], want[c], 1e-6), "{got:?}");
        }
    }

    #[test]
    fn matrix_inverse_is_inverse() {
        let m = [[2.0, 1.0, 0.5], [0.1, 3.0, 0.2], [0.3, 0.4, 1.5]];
        let p = mul_mat(&m, &invert(&m).unwrap());
        for (i, row) in p.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                assert!(close(*v, if i == j { 1.0 } else { 0.0 }, 1e-12));
            }
        }
        assert!(invert(&[[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 1.0]]).is_none());
    }
}

//! The view transform: how display-referred output (the 8-bit PNG) shows the film's linear, scene-referred colour.
//!
//! Monochromatic light lies far outside any display's gamut: in linear sRGB, 520 nm has a red component of about
//! −1.5 times its green. Clipping each channel on its own ([`View::Clip`]) collapses whole ranges of wavelengths
//! onto one corner of the RGB cube, so a prism's smooth spectrum shows as flat bands with hard steps between them,
//! and hues flip where a channel crosses zero or one. The default view ([`View::Oklab`]) keeps what the eye
//! reads in a spectrum, hue and lightness order, and gives up chroma instead:
//!
//! 1. The colour goes to Oklab (Ottosson 2020, [`spectral::oklab`]), where hue stays perceptually constant as
//!    chroma changes.
//! 2. Lightness above [`L_KNEE`] rolls off smoothly towards 1 (the display's white), so a highlight brighter than
//!    white keeps a little gradation instead of a hard edge; below the knee lightness is untouched.
//! 3. Chroma is compressed into the target gamut along a line of constant hue towards a point on the grey axis
//!    whose lightness moves from the colour's own (for near-greys) to the gamut's cusp at that hue (for strongly
//!    saturated colours): the adaptive-L₀ projection of Ottosson's "sRGB gamut clipping" (2021). Distances
//!    inside [`C_KNEE`] of the boundary are untouched; beyond it they approach the boundary asymptotically (the
//!    same soft knee), so no two colours of different chroma land on the same point, as clipping makes them.
//!
//! In-gamut colours well inside the boundary come out as they went in (the ColorChecker patches inside sRGB move
//! by less than ΔE2000 1 from a plain clip), and the linear EXR is never touched: the view is display-only.

use spectral::color::{mul_mat, mul_mat_vec, white_balance_matrix, Mat3};
use spectral::oklab::{lms_to_oklab, oklab_to_lms, xyz_to_oklab, LMS_TO_XYZ, XYZ_TO_LMS};
use spectral::RgbColorSpace;

/// How display-referred output shows colours outside the display's gamut or brighter than its white.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum View {
    /// Each channel clipped to [0, 1] on its own: Prismatic's PNGs before the view existed, and pbrt-v4's. Kept
    /// for comparison; it turns a spectrum into bands.
    Clip,
    /// Hue-preserving lightness roll-off and gamut compression in Oklab (see the module documentation).
    #[default]
    Oklab,
}

impl View {
    /// The names [`View::by_name`] accepts, default first.
    pub const NAMES: [&'static str; 2] = ["oklab", "clip"];

    /// The view called `name` (`oklab` or `clip`, case-insensitive).
    pub fn by_name(name: &str) -> Option<Self> {
        match name.to_ascii_lowercase().as_str() {
            "oklab" => Some(Self::Oklab),
            "clip" => Some(Self::Clip),
            _ => None,
        }
    }

    /// The name [`View::by_name`] reads back.
    pub fn name(self) -> &'static str {
        match self {
            Self::Oklab => "oklab",
            Self::Clip => "clip",
        }
    }
}

/// Oklab lightness where the highlight roll-off starts: display white (L = 1) shows as L ≈ 0.99 (8-bit 252), and
/// the lightest ColorChecker patch (L ≈ 0.965) is untouched.
pub const L_KNEE: f64 = 0.98;
/// Fraction of the distance to the gamut boundary below which chroma is untouched.
pub const C_KNEE: f64 = 0.95;
/// Chroma at which the projection's target lightness is halfway between the colour's own and the cusp's.
const ADAPTIVE_CHROMA: f64 = 0.05;
/// Hue bins of the cusp table (0.5° each).
const CUSP_BINS: usize = 720;
/// Bisection steps to the gamut boundary: 2⁻³⁰ of the search range, far below one 16-bit code value.
const BOUNDARY_STEPS: u32 = 30;

/// `x` below `knee` unchanged; above it, knee + (1 − knee)·t/(1 + t) with t = (x − knee)/(1 − knee): continuous
/// with slope 1 at the knee, strictly increasing, and below 1 for every finite x.
fn soft_knee(x: f64, knee: f64) -> f64 {
    if x <= knee {
        return x;
    }
    let t = (x - knee) / (1.0 - knee);
    knee + (1.0 - knee) * t / (1.0 + t)
}

/// The display transform from a film's linear RGB to a display's linear RGB in [0, 1], through a [`View`].
#[derive(Clone, Debug)]
pub struct DisplayTransform {
    view: View,
    /// Source linear RGB → display linear RGB (through XYZ, chromatically adapted when the whites differ).
    source_to_display: Mat3,
    /// Source linear RGB → Oklab's linear cone responses.
    source_to_lms: Mat3,
    /// Oklab's linear cone responses → display linear RGB.
    lms_to_display: Mat3,
    /// The Oklab lightness of the display gamut's most chromatic colour per hue bin.
    cusp_lightness: Vec<f64>,
}

impl DisplayTransform {
    /// Shows linear RGB in `source` on a display with the primaries of `display` (its white should be D65, as
    /// sRGB's, Display P3's and Rec. 2020's are; Oklab is defined for D65), through `view`. Colours are adapted
    /// from the source's white to the display's (Bradford) when they differ, as for an ACES film.
    pub fn new(source: &RgbColorSpace, display: &RgbColorSpace, view: View) -> Self {
        let adapt = if source.white == display.white {
            [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
        } else {
            white_balance_matrix(source.white, display.white)
        };
        let source_to_xyz = mul_mat(&adapt, &source.rgb_to_xyz);
        let source_to_display = mul_mat(&display.xyz_to_rgb, &source_to_xyz);
        let source_to_lms = mul_mat(&XYZ_TO_LMS, &source_to_xyz);
        let lms_to_display = mul_mat(&display.xyz_to_rgb, &LMS_TO_XYZ);
        let cusp_lightness = match view {
            View::Clip => Vec::new(),
            View::Oklab => cusp_table(display),
        };
        Self { view, source_to_display, source_to_lms, lms_to_display, cusp_lightness }
    }

    /// A source pixel's display-linear RGB, each component in [0, 1] (0 for NaN input).
    pub fn apply(&self, rgb: [f32; 3]) -> [f64; 3] {
        let rgb = rgb.map(f64::from);
        let out = match self.view {
            View::Clip => mul_mat_vec(&self.source_to_display, rgb),
            View::Oklab => self.oklab(rgb),
        };
        out.map(|c| if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) })
    }

    /// The Oklab view of one colour given in source RGB (module documentation, steps 1–3).
    fn oklab(&self, rgb: [f64; 3]) -> [f64; 3] {
        let [l, a, b] = lms_to_oklab(mul_mat_vec(&self.source_to_lms, rgb));
        if !(l > 0.0 && a.is_finite() && b.is_finite()) {
            return [0.0; 3];
        }
        let c = a.hypot(b);
        let lightness = soft_knee(l, L_KNEE);
        let (ua, ub) = if c > 0.0 { (a / c, b / c) } else { (1.0, 0.0) };
        let cusp = self.cusp_at(ub.atan2(ua).to_degrees());
        let w = c / (c + ADAPTIVE_CHROMA);
        let l0 = lightness + (cusp - lightness) * w;
        // Points on the line from (l0, 0) through (lightness, c) at parameter t (t = 1 is the colour itself).
        let at = |t: f64| {
            let (lt, ct) = (l0 + t * (lightness - l0), t * c);
            mul_mat_vec(&self.lms_to_display, oklab_to_lms([lt, ct * ua, ct * ub]))
        };
        let inside = |rgb: [f64; 3]| rgb.iter().all(|v| (-1e-9..=1.0 + 1e-9).contains(v));
        let far = 1.0 / C_KNEE;
        if inside(at(far)) {
            // Untouched (most pixels): the colour itself, without the trip back through Oklab.
            return if lightness == l { mul_mat_vec(&self.source_to_display, rgb) } else { at(1.0) };
        }
        // The boundary lies between t = 0 (on the grey axis, inside) and t = 1/C_KNEE (outside).
        let (mut lo, mut hi) = (0.0, far);
        for _ in 0..BOUNDARY_STEPS {
            let mid = 0.5 * (lo + hi);
            if inside(at(mid)) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        if lo <= 0.0 {
            return at(0.0);
        }
        // The colour's distance as a fraction of the boundary's, compressed by the soft knee.
        let r = 1.0 / lo;
        at(soft_knee(r, C_KNEE) / r)
    }

    /// The cusp lightness at hue `h` (degrees), linearly interpolated between bins.
    fn cusp_at(&self, h: f64) -> f64 {
        let x = h.rem_euclid(360.0) / 360.0 * CUSP_BINS as f64;
        let i = (x as usize).min(CUSP_BINS - 1);
        let t = x - i as f64;
        self.cusp_lightness[i] * (1.0 - t) + self.cusp_lightness[(i + 1) % CUSP_BINS] * t
    }
}

/// The colour space display images of a film in `color_space` are encoded in: the film's own when it is a
/// display space (sRGB, Display P3 = `dci-p3`, Rec. 2020), else sRGB (an ACES film's PNG is an sRGB image).
pub fn display_space_for(color_space: &RgbColorSpace) -> RgbColorSpace {
    match color_space.name {
        "srgb" => RgbColorSpace::srgb(),
        "dci-p3" => RgbColorSpace::dci_p3(),
        "rec2020" => RgbColorSpace::rec2020(),
        _ => RgbColorSpace::srgb(),
    }
}

/// Everything that turns a film's linear RGB into an 8-bit display image: the [`DisplayTransform`] and the display
/// space's encoding (the sRGB transfer curve, which sRGB and Display P3 use, and which Prismatic also uses for
/// Rec. 2020 and says so in the PNG's `cICP` chunk and ICC profile).
#[derive(Clone, Debug)]
pub struct DisplayEncoding {
    transform: DisplayTransform,
    space: RgbColorSpace,
    /// For a live view ([`DisplayEncoding::for_live_view`]): rows on the calling thread only, fast compression.
    live: bool,
}

impl DisplayEncoding {
    /// The encoding of a film in `source` through `view`, into [`display_space_for`] the source.
    pub fn new(source: &RgbColorSpace, view: View) -> Self {
        Self::with_display(source, &display_space_for(source), view)
    }

    /// The encoding of linear RGB in `source` through `view` into the display space `display` (D65 white).
    pub fn with_display(source: &RgbColorSpace, display: &RgbColorSpace, view: View) -> Self {
        Self { transform: DisplayTransform::new(source, display, view), space: display.clone(), live: false }
    }

    /// The same pixels for a live view: encoded on the calling thread only (the render keeps rayon's pool busy,
    /// where parallel rows would wait for the render's work, and their time would measure that wait), and the PNG
    /// compressed fast rather than small.
    pub fn for_live_view(self) -> Self {
        Self { live: true, ..self }
    }

    /// Whether the PNG is compressed fast rather than small (a live view's).
    pub fn fast_compression(&self) -> bool {
        self.live
    }

    /// The display space the image is encoded in.
    pub fn display_space(&self) -> &RgbColorSpace {
        &self.space
    }

    /// The 8-bit, dithered, transfer-encoded RGB bytes of `pixels` (row-major, `width` per row), three per pixel.
    /// The dither depends on the pixel's position only, so the same image gives the same bytes.
    pub fn encode_8bit(&self, pixels: &[[f32; 3]], width: u32) -> Vec<u8> {
        use rayon::prelude::*;
        let width = width.max(1) as usize;
        let mut data = vec![0u8; pixels.len() * 3];
        let encode_row = |(y, (out, row)): (usize, (&mut [u8], &[[f32; 3]]))| {
            for (x, (p, o)) in row.iter().zip(out.chunks_exact_mut(3)).enumerate() {
                let linear = self.transform.apply(*p);
                for c in 0..3 {
                    let encoded = spectral::color::srgb_encode(linear[c]);
                    o[c] = spectral::color::quantize_8bit_dithered(
                        encoded,
                        crate::image_io::dither_u(x as u32, y as u32, c as u32),
                    );
                }
            }
        };
        if !self.live {
            data.par_chunks_mut(width * 3).zip(pixels.par_chunks(width)).enumerate().for_each(encode_row);
        } else {
            data.chunks_mut(width * 3).zip(pixels.chunks(width)).enumerate().for_each(encode_row);
        }
        data
    }

    /// The PNG `cICP` chunk's payload (ITU-T H.273 code points: primaries, transfer = 13 (the sRGB curve), matrix
    /// = 0 (RGB), full range), or `None` for sRGB, which the `sRGB` chunk says.
    pub fn cicp(&self) -> Option<[u8; 4]> {
        match self.space.name {
            "dci-p3" => Some([12, 13, 0, 1]),
            "rec2020" => Some([9, 13, 0, 1]),
            _ => None,
        }
    }
}

/// The Oklab lightness of the most chromatic colour of each hue in the gamut of `display`. The most chromatic
/// colour of a hue has one channel at 0 and another at 1 (Ottosson 2021): it lies on the six cube edges from each
/// primary to its neighbouring secondaries, which are walked finely and interpolated in hue.
fn cusp_table(display: &RgbColorSpace) -> Vec<f64> {
    const STEPS: usize = 512;
    // (hue in degrees, L, C) around the loop of the six edges, in order.
    let mut loop_points: Vec<[f64; 3]> = Vec::with_capacity(6 * STEPS);
    for edge in 0..6 {
        for s in 0..STEPS {
            // The varying channel in cubes of even steps: Oklab's cube root makes hue change fastest near 0.
            let rising = (s as f64 / STEPS as f64).powi(3);
            let falling = ((STEPS - s) as f64 / STEPS as f64).powi(3);
            let rgb = match edge {
                0 => [1.0, rising, 0.0],
                1 => [falling, 1.0, 0.0],
                2 => [0.0, 1.0, rising],
                3 => [0.0, falling, 1.0],
                4 => [rising, 0.0, 1.0],
                _ => [1.0, 0.0, falling],
            };
            let [l, c, h] = spectral::oklab::oklab_to_lch(xyz_to_oklab(display.to_xyz(rgb).to_array()));
            loop_points.push([h, l, c]);
        }
    }
    // Each segment of the loop fills the bins its hue range covers; where the loop's hue doubles back (it does
    // near some primaries), the most chromatic crossing wins, as the cusp is the most chromatic colour of a hue.
    let mut best = vec![(f64::NEG_INFINITY, 0.0); CUSP_BINS];
    let bin_width = 360.0 / CUSP_BINS as f64;
    for i in 0..loop_points.len() {
        let (p, q) = (loop_points[i], loop_points[(i + 1) % loop_points.len()]);
        let dh = (q[0] - p[0] + 540.0).rem_euclid(360.0) - 180.0;
        let (from, to) = if dh >= 0.0 { (p[0], p[0] + dh) } else { (p[0] + dh, p[0]) };
        let mut k = (from / bin_width).ceil() as i64;
        while (k as f64) * bin_width <= to {
            let h = k as f64 * bin_width;
            let t = if dh.abs() > 0.0 { ((h - p[0]) / dh).clamp(0.0, 1.0) } else { 0.0 };
            let t = if dh >= 0.0 { t } else { ((p[0] - h) / -dh).clamp(0.0, 1.0) };
            let (l, c) = (p[1] + t * (q[1] - p[1]), p[2] + t * (q[2] - p[2]));
            let bin = k.rem_euclid(CUSP_BINS as i64) as usize;
            if c > best[bin].0 {
                best[bin] = (c, l);
            }
            k += 1;
        }
    }
    best.into_iter().map(|(_, l)| l).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use spectral::oklab::oklab_to_xyz;

    #[test]
    fn soft_knee_is_continuous_increasing_and_bounded() {
        let k = 0.9;
        assert_eq!(soft_knee(0.5, k), 0.5);
        assert!((soft_knee(k + 1e-9, k) - k).abs() < 2e-9);
        let mut prev = soft_knee(k, k);
        for i in 1..1000 {
            let v = soft_knee(k + i as f64 * 0.05, k);
            assert!(v > prev && v < 1.0, "{v}");
            prev = v;
        }
    }

    /// The cusp table against a brute-force search (the lightness of the largest in-gamut chroma, over L in steps
    /// of 0.002) at 36 hues, for sRGB and Rec. 2020; and at sRGB's red and green, each primary's own lightness.
    #[test]
    fn cusp_table_finds_the_most_chromatic_colour_of_each_hue() {
        for space in [RgbColorSpace::srgb(), RgbColorSpace::rec2020()] {
            let t = DisplayTransform::new(&space, &space, View::Oklab);
            let inside = |l: f64, c: f64, h: f64| {
                let lab = spectral::oklab::lch_to_oklab([l, c, h]);
                let rgb = mul_mat_vec(&space.xyz_to_rgb, oklab_to_xyz(lab));
                rgb.iter().all(|v| (-1e-9..=1.0 + 1e-9).contains(v))
            };
            for k in 0..36 {
                let h = 3.0 + 10.0 * k as f64;
                let mut best = (0.0, 0.0);
                for i in 1..500 {
                    let l = i as f64 * 0.002;
                    let (mut lo, mut hi) = (0.0, 0.6);
                    for _ in 0..30 {
                        let mid = 0.5 * (lo + hi);
                        if inside(l, mid, h) {
                            lo = mid
                        } else {
                            hi = mid
                        }
                    }
                    if lo > best.0 {
                        best = (lo, l);
                    }
                }
                assert!((t.cusp_at(h) - best.1).abs() < 0.01, "{} hue {h}: {} vs {}", space.name, t.cusp_at(h), best.1);
            }
        }
        let srgb = RgbColorSpace::srgb();
        let t = DisplayTransform::new(&srgb, &srgb, View::Oklab);
        for (rgb, want) in [([1.0, 0.0, 0.0], 0.628), ([0.0, 1.0, 0.0], 0.866)] {
            let lch = spectral::oklab::oklab_to_lch(xyz_to_oklab(srgb.to_xyz(rgb).to_array()));
            assert!((t.cusp_at(lch[2]) - want).abs() < 2e-3, "{rgb:?}: {}", t.cusp_at(lch[2]));
        }
    }

    #[test]
    fn names_round_trip() {
        for n in View::NAMES {
            assert_eq!(View::by_name(n).unwrap().name(), n);
        }
        assert_eq!(View::by_name("CLIP"), Some(View::Clip));
        assert_eq!(View::by_name("agx"), None);
        assert_eq!(View::default(), View::Oklab);
    }
}

//! The view transform on the thing that matters: a spectrum.
//!
//! Monochromatic stimuli from 400 to 700 nm at equal energy (XYZ = the CIE 1931 colour-matching functions times a
//! peak luminance, so the brightest wavelength, 555 nm, has Y = peak) become the film's linear sRGB as the film's
//! own conversion makes it (f32), go through the display transform, and the displayed colours are measured in
//! Oklab before 8-bit quantisation. The default view must show a spectrum, not bands; `clip` must fail the same
//! checks; and colours inside the gamut must come out as `clip` shows them.

use film::{DisplayEncoding, DisplayTransform, View};
use spectral::lab::{delta_e_2000, xyz_to_lab};
use spectral::oklab::{delta_e_ok, oklab_to_lch, xyz_to_oklab};
use spectral::{Observer, RgbColorSpace};

/// Wavelengths 5 nm apart must differ by at least this ΔE_ok (about a third of a just-noticeable difference,
/// 0.02): no plateau. The default view's smallest such difference is 0.0071 (peak 2, at 522 nm), 0.0119 and
/// 0.0128 at peaks 0.5 and 1; a clipped spectrum has whole runs of identical colours (ΔE_ok 0).
const MIN_DE_5NM: f64 = 0.006;
/// No 1 nm step may jump by more than this ΔE_ok: no band edge. The largest steps are the spectrum's own fastest
/// hue change, 455–465 nm (0.057).
const MAX_DE_1NM: f64 = 0.065;
/// Hue must not increase with wavelength by more than this (degrees): CIE 1931's chromaticity is constant to the
/// table's rounding above 690 nm, where hue wobbles by hundredths of a degree.
const HUE_SLACK_DEG: f64 = 0.1;

/// The Oklab colours a view shows for the spectrum at `peak`, at 400, 401, … 700 nm.
fn displayed_spectrum(view: View, peak: f64) -> Vec<[f64; 3]> {
    let srgb = RgbColorSpace::srgb();
    let transform = DisplayTransform::new(&srgb, &srgb, view);
    (400..=700)
        .map(|lambda| {
            let xyz = Observer::Cie1931.xyz_bar(lambda as f64).map(|v| v * peak);
            let film_rgb = srgb.to_rgb(spectral::Xyz::from_array(xyz)).map(|c| c as f32);
            let shown = transform.apply(film_rgb);
            xyz_to_oklab(srgb.to_xyz(shown).to_array())
        })
        .collect()
}

/// (largest hue increase in degrees, smallest ΔE_ok 5 nm apart, largest ΔE_ok 1 nm apart) of a displayed spectrum.
fn spectrum_measures(colours: &[[f64; 3]]) -> (f64, f64, f64) {
    let hues: Vec<f64> = colours.iter().map(|&c| oklab_to_lch(c)[2]).collect();
    let mut worst_rise = f64::NEG_INFINITY;
    for w in hues.windows(2) {
        // The shortest signed angle from one hue to the next (hue decreases from violet to red).
        let d = (w[1] - w[0] + 540.0).rem_euclid(360.0) - 180.0;
        worst_rise = worst_rise.max(d);
    }
    let min5 = (0..colours.len() - 5).map(|i| delta_e_ok(colours[i], colours[i + 5])).fold(f64::INFINITY, f64::min);
    let max1 = colours.windows(2).map(|w| delta_e_ok(w[0], w[1])).fold(0.0, f64::max);
    (worst_rise, min5, max1)
}

#[test]
fn the_default_view_shows_a_spectrum_and_clip_shows_bands() {
    // The brightest wavelength at half, once and twice the display's white.
    for peak in [0.5, 1.0, 2.0] {
        let (rise, min5, max1) = spectrum_measures(&displayed_spectrum(View::Oklab, peak));
        assert!(rise <= HUE_SLACK_DEG, "peak {peak}: hue rises by {rise:.2}° somewhere");
        assert!(min5 >= MIN_DE_5NM, "peak {peak}: a plateau: ΔE_ok {min5:.4} between wavelengths 5 nm apart");
        assert!(max1 <= MAX_DE_1NM, "peak {peak}: a band edge: ΔE_ok {max1:.4} in one 1 nm step");

        // Clip fails the same check: whole runs of wavelengths show one colour.
        let (_, min5, _) = spectrum_measures(&displayed_spectrum(View::Clip, peak));
        assert!(min5 < 1e-3, "peak {peak}: clip should have plateaus (smallest ΔE_ok 5 nm apart {min5:.4})");
    }
}

/// The ColorChecker's 24 patches under D65 (the fixture of the spectral crate's ColorChecker test, as linear sRGB).
fn colorchecker() -> Vec<(String, [f64; 3])> {
    let text = include_str!("../../spectral/tests/fixtures/colorchecker_babelcolor_d65.csv");
    let mut lines = text.lines().filter(|l| !l.starts_with('#') && !l.trim().is_empty());
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let (name, lin) =
        (header.iter().position(|h| *h == "name").unwrap(), header.iter().position(|h| *h == "sR_lin").unwrap());
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let v = |i: usize| f[i].parse::<f64>().unwrap();
            (f[name].to_string(), [v(lin), v(lin + 1), v(lin + 2)])
        })
        .collect()
}

#[test]
fn colours_inside_the_gamut_come_out_as_clip_shows_them() {
    let srgb = RgbColorSpace::srgb();
    let white = srgb.to_xyz([1.0; 3]).to_array();
    let lab = |rgb: [f64; 3]| xyz_to_lab(srgb.to_xyz(rgb).to_array(), white);
    let (oklab, clip) =
        (DisplayTransform::new(&srgb, &srgb, View::Oklab), DisplayTransform::new(&srgb, &srgb, View::Clip));
    let patches = colorchecker();
    assert_eq!(patches.len(), 24);
    let mut inside = 0;
    for (name, rgb) in &patches {
        let f = rgb.map(|c| c as f32);
        let (ours, clipped) = (oklab.apply(f), clip.apply(f));
        if rgb.iter().all(|c| (0.0..=1.0).contains(c)) {
            inside += 1;
            let de = delta_e_2000(lab(ours), lab(clipped));
            assert!(de < 1.0, "{name}: ΔE2000 {de:.3} from clip");
        } else {
            // Cyan lies just outside sRGB (R < 0): the view keeps its hue; clip turns it.
            let hue = |rgb: [f64; 3]| oklab_to_lch(xyz_to_oklab(srgb.to_xyz(rgb).to_array()))[2];
            let (true_hue, our_hue, clip_hue) = (hue(*rgb), hue(ours), hue(clipped));
            assert!((our_hue - true_hue).abs() < 0.05, "{name}: hue {our_hue:.2}° for {true_hue:.2}°");
            assert!((clip_hue - true_hue).abs() > 1.0, "{name}: clip's hue {clip_hue:.2}° for {true_hue:.2}°");
        }
    }
    assert_eq!(inside, 23);
}

/// Wider gamuts show more of the spectrum: at every wavelength the displayed chroma in Display P3 and Rec. 2020 is
/// at least sRGB's, and at 520 nm (a green far outside sRGB) markedly more.
#[test]
fn wider_gamuts_show_more_saturated_spectra() {
    let srgb = RgbColorSpace::srgb();
    let chroma = |display: &RgbColorSpace, lambda: f64| {
        let t = DisplayTransform::new(&srgb, display, View::Oklab);
        let xyz = Observer::Cie1931.xyz_bar(lambda).map(|v| v * 0.5);
        let shown = t.apply(srgb.to_rgb(spectral::Xyz::from_array(xyz)).map(|c| c as f32));
        oklab_to_lch(xyz_to_oklab(display.to_xyz(shown).to_array()))[1]
    };
    let (p3, rec2020) = (RgbColorSpace::dci_p3(), RgbColorSpace::rec2020());
    for lambda in (400..=700).step_by(10).map(f64::from) {
        let s = chroma(&srgb, lambda);
        assert!(chroma(&p3, lambda) >= s - 1e-3 && chroma(&rec2020, lambda) >= s - 1e-3, "{lambda} nm");
    }
    let (s, p, r) = (chroma(&srgb, 520.0), chroma(&p3, 520.0), chroma(&rec2020, 520.0));
    assert!(p > 1.15 * s && r > 1.15 * p, "520 nm chroma: sRGB {s:.3}, P3 {p:.3}, Rec. 2020 {r:.3}");
}

/// The encoding's bytes for an in-gamut grey are today's sRGB encoding, and P3 and Rec. 2020 images say what they are.
#[test]
fn encodings_name_their_display_space() {
    let srgb = RgbColorSpace::srgb();
    let grey = [[0.18f32; 3]];
    let bytes = DisplayEncoding::new(&srgb, View::Oklab).encode_8bit(&grey, 1);
    let want = spectral::color::srgb_encode(0.18) * 255.0;
    for b in bytes {
        assert!((b as f64 - want).abs() < 1.0, "{b} vs {want}");
    }
    assert_eq!(DisplayEncoding::new(&srgb, View::Oklab).cicp(), None);
    assert_eq!(DisplayEncoding::new(&RgbColorSpace::dci_p3(), View::Oklab).cicp(), Some([12, 13, 0, 1]));
    assert_eq!(DisplayEncoding::new(&RgbColorSpace::rec2020(), View::Clip).cicp(), Some([9, 13, 0, 1]));
    // An ACES film's PNG is an sRGB image.
    let aces = DisplayEncoding::new(&RgbColorSpace::aces2065_1(), View::Oklab);
    assert_eq!(aces.display_space().name, "srgb");
}

/// Colours beyond the gamut keep their hue and their order: mixtures of 520 nm light with white of the same
/// luminance, from well outside sRGB to pure spectral light, show at their own Oklab hue in increasing chroma;
/// clipping turns their hue.
#[test]
fn colours_beyond_the_gamut_keep_their_hue_and_order() {
    let srgb = RgbColorSpace::srgb();
    let mono = Observer::Cie1931.xyz_bar(520.0);
    let white = srgb.to_xyz([1.0; 3]).to_array();
    let shown = |view: View| -> Vec<([f64; 3], [f64; 3])> {
        let transform = DisplayTransform::new(&srgb, &srgb, view);
        (10..=20)
            .map(|k| {
                let t = k as f64 * 0.05; // the share of spectral light: 0.5 (outside sRGB) to 1
                let xyz = [0, 1, 2].map(|i| 0.3 * (t * mono[i] / mono[1] + (1.0 - t) * white[i]));
                let rgb = srgb.to_rgb(spectral::Xyz::from_array(xyz)).map(|c| c as f32);
                assert!(rgb.iter().any(|&c| c < 0.0), "mixture {t} lies inside sRGB");
                let out = oklab_to_lch(xyz_to_oklab(srgb.to_xyz(transform.apply(rgb)).to_array()));
                (oklab_to_lch(xyz_to_oklab(xyz)), out)
            })
            .collect()
    };
    let ours = shown(View::Oklab);
    for (given, out) in &ours {
        assert!((out[2] - given[2]).abs() < 0.05, "hue {:.3}° for {:.3}°", out[2], given[2]);
    }
    for w in ours.windows(2) {
        assert!(w[1].1[1] - w[0].1[1] > 1e-3, "chroma {:.4} then {:.4}: a plateau", w[0].1[1], w[1].1[1]);
    }
    let turned = shown(View::Clip).iter().map(|(g, o)| (o[2] - g[2]).abs()).fold(0.0, f64::max);
    assert!(turned > 2.0, "clip turns hue by only {turned:.2}°");
}

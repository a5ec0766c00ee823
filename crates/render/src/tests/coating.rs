//! Thin-film coatings on conductors, rendered: an orthographic camera looks straight down at a smooth coated metal
//! under a uniform sky, so every pixel shows the sky's radiance times the film stack's reflectance at normal
//! incidence, wavelength by wavelength; the sky seen past the metal gives the radiance itself.

use std::path::Path;

use optics::{film_stack, Complex, FilmLayer};

use crate::{build_scene, BuildOptions, BuiltScene};

/// A 16×8 RGB film: the metal fills the right half of the image (world x < 0 is on the image's right, seen from +z
/// with y up, as in pbrt-v4), the sky the left.
fn scene(material: &str, spp: u32) -> BuiltScene {
    scene_with(material, "", spp)
}

/// [`scene`] with more of the world after the coated quad.
fn scene_with(material: &str, more: &str, spp: u32) -> BuiltScene {
    let text = format!(
        "LookAt 0 0 5  0 0 0  0 1 0\n\
         Camera \"orthographic\" \"float screenwindow\" [ -2 2 -1 1 ]\n\
         Film \"rgb\" \"integer xresolution\" 16 \"integer yresolution\" 8\n\
         PixelFilter \"box\" \"float xradius\" 0.5 \"float yradius\" 0.5\n\
         Sampler \"zsobol\" \"integer pixelsamples\" {spp}\n\
         Integrator \"path\" \"integer maxdepth\" 2\n\
         WorldBegin\n\
         LightSource \"infinite\" \"spectrum L\" [ 360 1 830 1 ]\n\
         {material}\n\
         Shape \"trianglemesh\" \"point3 P\" [ -3 -2 0  0 -2 0  0 2 0  -3 2 0 ] \"integer indices\" [ 0 1 2  0 2 3 ]\n\
         {more}"
    );
    let desc = pbrt::parse_str(&text, Path::new("coating.pbrt")).unwrap_or_else(|e| panic!("{e}"));
    build_scene(&desc, &BuildOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

/// X, Y, Z of the metal's pixels (x > 8) over those of the sky's (x < 7), each averaged.
fn metal_over_sky(built: &BuiltScene) -> [f64; 3] {
    metal_over_sky_with(built, spectral::WavelengthStrategy::Hero)
}

/// [`metal_over_sky`] with the film's wavelength strategy `strategy`.
fn metal_over_sky_with(built: &BuiltScene, strategy: spectral::WavelengthStrategy) -> [f64; 3] {
    let mut spec = built.film.clone();
    spec.wavelengths = strategy;
    let mut film = film::Film::new(spec).unwrap();
    built.integrator.render(&built.scene, &mut film, 0..built.spp, 3, &|_| {}).unwrap();
    let sum = |xs: std::ops::Range<u32>| {
        let mut s = [0.0; 3];
        for y in 0..film.height() {
            for x in xs.clone() {
                let p = film.pixel_xyz(x, y);
                s = [s[0] + p.x, s[1] + p.y, s[2] + p.z];
            }
        }
        s
    };
    let (metal, sky) = (sum(9..16), sum(0..7));
    [0, 1, 2].map(|c| metal[c] / sky[c])
}

/// Titanium-like metal (n 2.7, k 3.8) under an oxide film of index 2.4: a heat tint.
const METAL: &str = "\"spectrum eta\" [ 360 2.7 830 2.7 ] \"spectrum k\" [ 360 3.8 830 3.8 ]";

#[test]
fn a_coated_mirror_reflects_the_film_stacks_reflectance_at_every_wavelength() {
    let coated = |d: f64| format!("Material \"conductor\" {METAL} \"float filmthickness\" {d} \"float filmeta\" 2.4");
    for d in [80.0, 300.0] {
        let measured = metal_over_sky(&scene(&coated(d), 64));
        // Under a sky of constant spectral radiance, each tristimulus value of the mirror over the sky's is the
        // reflectance weighted by that colour matching function: ∫R(λ)·x̄(λ)dλ / ∫x̄(λ)dλ, and so on.
        let (mut num, mut den) = ([0.0; 3], [0.0; 3]);
        for j in 0..4700 {
            let lambda = 360.0 + 0.1 * (j as f64 + 0.5);
            let film = [FilmLayer::new(Complex::from_real(2.4), d)];
            let r = film_stack(1.0, &film, Complex::new(2.7, 3.8), 1.0, lambda).reflectance();
            let cmf = spectral::Observer::Cie1931.xyz_bar(lambda);
            for c in 0..3 {
                num[c] += r * cmf[c];
                den[c] += cmf[c];
            }
        }
        let exact = [0, 1, 2].map(|c| num[c] / den[c]);
        for c in 0..3 {
            // Hero wavelengths with 64 samples on each of 56 pixels: well under 1% of noise.
            assert!((measured[c] / exact[c] - 1.0).abs() < 0.01, "{d} nm, channel {c}: {measured:?} vs {exact:?}");
        }
    }
}

#[test]
fn a_film_of_no_thickness_is_the_bare_metal_and_a_thick_one_colours_it() {
    let bare = metal_over_sky(&scene(&format!("Material \"conductor\" {METAL}"), 64));
    let none = metal_over_sky(&scene(
        &format!("Material \"conductor\" {METAL} \"float filmthickness\" 0 \"float filmeta\" 2.4"),
        64,
    ));
    assert_eq!(bare, none, "a film of no thickness renders exactly the bare metal");
    let r = optics::fresnel_conductor(1.0, 2.7, 3.8);
    assert!(bare.iter().all(|v| (v - r).abs() < 0.01 * r), "{bare:?} vs {r}");
    // The bare metal is grey here; under 80 nm of oxide it is coloured: its X, Y and Z ratios spread apart.
    let coated = metal_over_sky(&scene(
        &format!("Material \"conductor\" {METAL} \"float filmthickness\" 80 \"float filmeta\" 2.4"),
        64,
    ));
    let spread = coated.iter().fold(0.0f64, |m, &v| m.max(v)) - coated.iter().fold(1.0f64, |m, &v| m.min(v));
    assert!(spread > 0.05, "{coated:?}");
}

/// A smooth coated dielectric reflects the film stack's R and transmits its T per wavelength, from outside and
/// from inside (the stack crossed in reverse): a specular event's f·|cos θi| is its R or T (importance transport,
/// no η² factor), and the event is chosen with probability R̄/(R̄ + T̄) of the means over the slots, kept within
/// [1/4, 3/4] where both events can happen.
#[test]
fn a_smooth_coated_dielectric_reflects_and_transmits_the_stacks_r_and_t_per_wavelength() {
    use crate::bxdf::{Bxdf, TransportMode};
    use crate::coating::CoatingAt;
    use crate::microfacet::TrowbridgeReitz;
    use glam::{Vec2, Vec3};
    let lambda = [450.0f32, 550.0, 650.0, 750.0];
    let layers = [FilmLayer::new(Complex::from_real(1.38), 99.6), FilmLayer::new(Complex::from_real(2.1), 130.0)];
    let reversed: Vec<FilmLayer> = layers.iter().rev().copied().collect();
    let eta = 1.52f32;
    let coated = |layers: &[FilmLayer]| Bxdf::Dielectric {
        eta,
        distrib: TrowbridgeReitz::new(0.0, 0.0),
        coating: Some(Box::new(CoatingAt::uniform(lambda, layers))),
        tint: None,
    };
    let b = coated(&layers);
    // From outside at three angles; from inside below and beyond the critical angle (41.1°).
    for (cos_o, inside) in [(1.0f32, false), (0.7, false), (0.2, false), (0.9, true), (0.6, true)] {
        let sin = (1.0 - cos_o * cos_o).sqrt();
        let wo = Vec3::new(sin, 0.0, if inside { -cos_o } else { cos_o });
        let want: Vec<_> = (0..4)
            .map(|i| {
                let lambda = lambda[i] as f64;
                if inside {
                    film_stack(eta as f64, &reversed, Complex::from_real(1.0), cos_o as f64, lambda)
                } else {
                    film_stack(1.0, &layers, Complex::from_real(eta as f64), cos_o as f64, lambda)
                }
            })
            .collect();
        let mean = |g: fn(&optics::FilmResponse) -> f64| want.iter().map(g).sum::<f64>() / 4.0;
        // Chosen by the means, but each event with probability at least 1/4 where both can happen.
        let (mean_r, mean_t) = (mean(|w| w.reflectance()), mean(|w| w.transmittance()));
        let p_reflect = if mean_t == 0.0 { 1.0 } else { (mean_r / (mean_r + mean_t)).clamp(0.25, 0.75) };
        let what = format!("cos {cos_o}, inside {inside}");
        let r = b.sample_f(wo, 0.0, Vec2::splat(0.5), TransportMode::Importance).unwrap();
        assert!(!r.transmission && r.specular, "{what}");
        assert!((r.pdf as f64 - p_reflect).abs() < 1e-5, "{what}: P(reflect) {} vs {p_reflect}", r.pdf);
        let t = b.sample_f(wo, 0.99999, Vec2::splat(0.5), TransportMode::Importance).unwrap();
        let total_internal = inside && cos_o < 0.75;
        assert_eq!(t.transmission, !total_internal, "{what}");
        for (i, want) in want.iter().enumerate() {
            let reflectance = (r.f[i] * r.wi.z.abs()) as f64;
            assert!((reflectance - want.reflectance()).abs() < 1e-5, "{what}, slot {i}: R {reflectance} vs {want:?}");
            if !total_internal {
                let transmittance = (t.f[i] * t.wi.z.abs()) as f64;
                assert!((transmittance - want.transmittance()).abs() < 1e-5, "{what}, slot {i}: T {transmittance}");
                assert!((reflectance + transmittance - 1.0).abs() < 1e-5, "{what}, slot {i}: lossless layers");
            }
        }
    }
    // The quarter-wave MgF₂ layer alone at its design wavelength (slot 1) and normal incidence:
    // R = ((n₀n_s − n₁²)/(n₀n_s + n₁²))², 1.26% in place of the bare glass's 4.26%.
    let quarter = coated(&[FilmLayer::new(Complex::from_real(1.38), 550.0 / (4.0 * 1.38))]);
    let s = quarter.sample_f(Vec3::Z, 0.0, Vec2::splat(0.5), TransportMode::Importance).unwrap();
    let want = ((1.52f64 - 1.38 * 1.38) / (1.52 + 1.38 * 1.38)).powi(2);
    assert!(!s.transmission && (s.f[1] as f64 - want).abs() < 1e-6, "{} vs {want}", s.f[1]);
}

/// A black quad under the film's quad, so the camera sees only what the film reflects of the sky.
const BLACK_BELOW: &str = "Material \"diffuse\" \"spectrum reflectance\" [ 360 0 830 0 ]\n\
     Shape \"trianglemesh\" \"point3 P\" [ -3 -2 -1  0 -2 -1  0 2 -1  -3 2 -1 ] \"integer indices\" [ 0 1 2  0 2 3 ]\n";

/// A water film's reflectance (n 1.33, `d` nm, in air at normal incidence) weighted by each CIE 1931 colour matching
/// function: what the film over black shows of a sky of constant spectral radiance.
fn water_film_xyz_ratio(d: f64) -> [f64; 3] {
    let (mut num, mut den) = ([0.0; 3], [0.0; 3]);
    for j in 0..4700 {
        let lambda = 360.0 + 0.1 * (j as f64 + 0.5);
        let r = film_stack(1.0, &[FilmLayer::new(Complex::from_real(1.33), d)], Complex::from_real(1.0), 1.0, lambda)
            .reflectance();
        let cmf = spectral::Observer::Cie1931.xyz_bar(lambda);
        for c in 0..3 {
            num[c] += r * cmf[c];
            den[c] += cmf[c];
        }
    }
    [0, 1, 2].map(|c| num[c] / den[c])
}

/// A free-standing soap film (`thinfilm`) reflects its interference colour and, with nothing behind it but the sky,
/// is invisible: what it does not reflect it transmits (R + T = 1, no offset), at every wavelength. A film of no
/// thickness is no surface at all.
#[test]
fn a_soap_film_reflects_its_interference_colour_and_transmits_the_rest() {
    let soap = |d: f64| format!("Material \"thinfilm\" \"float filmthickness\" {d} \"float eta\" 1.33");
    for d in [120.0, 300.0, 550.0] {
        // 1024 samples on each of 56 pixels: the ratios converge to 0.05% at 8192 and scatter by about 0.3% here.
        let measured = metal_over_sky(&scene_with(&soap(d), BLACK_BELOW, 1024));
        let exact = water_film_xyz_ratio(d);
        for c in 0..3 {
            assert!((measured[c] / exact[c] - 1.0).abs() < 0.01, "{d} nm, channel {c}: {measured:?} vs {exact:?}");
        }
        // Each sample weighs Rᵢ/P̄ or Tᵢ/(1 − P̄) per wavelength, 1 only on average: noise of about 0.2% here.
        let alone = metal_over_sky(&scene(&soap(d), 256));
        assert!(alone.iter().all(|v| (v - 1.0).abs() < 0.01), "{d} nm over the sky: {alone:?}");
    }
    let none = metal_over_sky(&scene_with(&soap(0.0), BLACK_BELOW, 4));
    assert!(none.iter().all(|&v| v == 0.0), "no film: the black quad, {none:?}");
}

/// Spectral honesty. A 2 µm water film's reflectance oscillates with a period of about 57 nm in λ (λ²/2nd at 550 nm),
/// so its colour is an average over many fringes, nearly neutral. All of Prismatic's wavelength strategies sample λ
/// continuously (`rgb` stratifies its three bands but draws a random wavelength in each), so each converges to its
/// own integral of the reflectance spectrum; a renderer that evaluates the film at three fixed wavelengths (one per
/// RGB primary, as an RGB renderer must) lands on three points of the fringes and shows a strong false colour.
#[test]
fn a_thick_film_converges_under_every_wavelength_strategy_where_three_fixed_wavelengths_cannot() {
    use spectral::{Observer, Spectrum, WavelengthSampler, WavelengthStrategy};
    let d = 2000.0;
    let r = |lambda: f64| {
        film_stack(1.0, &[FilmLayer::new(Complex::from_real(1.33), d)], Complex::from_real(1.0), 1.0, lambda)
            .reflectance()
    };
    let lambdas: Vec<f64> = (0..=47000).map(|j| 360.0 + 0.01 * j as f64).collect();
    let reflectance = Spectrum::piecewise_linear(lambdas.clone(), lambdas.iter().map(|&l| r(l)).collect()).unwrap();
    let built =
        scene_with(&format!("Material \"thinfilm\" \"float filmthickness\" {d} \"float eta\" 1.33"), BLACK_BELOW, 2048);
    for strategy in WavelengthStrategy::ALL {
        // What the strategy converges to: its own colour matching functions (`cmf`: Stiles & Burch through a fitted
        // matrix, which differs from CIE 1931 by up to 1.6% on this spectrum) applied to R(λ), over the sky's.
        let sampler = WavelengthSampler::new(strategy, Observer::Cie1931);
        let (film, sky) = (sampler.reference_xyz(&reflectance), sampler.reference_xyz(&Spectrum::Constant(1.0)));
        let exact = [film.x / sky.x, film.y / sky.y, film.z / sky.z];
        let measured = metal_over_sky_with(&built, strategy);
        for c in 0..3 {
            // 2048 samples on 56 pixels: within 0.5% of the reference for every strategy and channel.
            assert!((measured[c] / exact[c] - 1.0).abs() < 0.01, "{strategy}, channel {c}: {measured:?} vs {exact:?}");
        }
    }
    // Three fixed wavelengths near sRGB's primaries' dominant wavelengths, as an RGB renderer's three channels.
    let exact = water_film_xyz_ratio(d);
    let xyz = spectral::RgbColorSpace::srgb().to_xyz([r(612.0), r(549.0), r(465.0)]);
    let white = spectral::RgbColorSpace::srgb().to_xyz([1.0; 3]);
    let three = [xyz.x / white.x, xyz.y / white.y, xyz.z / white.z];
    let off = (0..3).map(|c| (three[c] / exact[c] - 1.0).abs()).fold(0.0, f64::max);
    assert!(off > 0.3, "three wavelengths {three:?} vs {exact:?}");
}

/// A free-standing film reflects R and transmits T per slot (f·|cos| of each event, in either direction), and
/// picks either event with probability at least 1/4 although it reflects only a few per cent.
#[test]
fn a_free_film_samples_each_event_with_probability_at_least_a_quarter() {
    use crate::bxdf::{Bxdf, TransportMode};
    use crate::coating::CoatingAt;
    use glam::{Vec2, Vec3};
    let lambda = [450.0f32, 520.0, 600.0, 680.0];
    let layer = [FilmLayer::new(Complex::from_real(1.33), 300.0)];
    let film = Bxdf::ThinFilm { film: Some(Box::new(CoatingAt::uniform(lambda, &layer))) };
    for wo in [Vec3::new(0.6, 0.0, 0.8), Vec3::new(0.0, 0.6, -0.8)] {
        let reflected = film.sample_f(wo, 0.24, Vec2::splat(0.5), TransportMode::Radiance).unwrap();
        let transmitted = film.sample_f(wo, 0.26, Vec2::splat(0.5), TransportMode::Radiance).unwrap();
        assert!(!reflected.transmission && reflected.pdf == 0.25, "{reflected:?}");
        assert!(transmitted.transmission && transmitted.pdf == 0.75 && transmitted.wi == -wo, "{transmitted:?}");
        for (i, &l) in lambda.iter().enumerate() {
            let want = film_stack(1.0, &layer, Complex::from_real(1.0), 0.8, l as f64);
            assert!(want.reflectance() < 0.15);
            assert!(((reflected.f[i] * 0.8) as f64 - want.reflectance()).abs() < 1e-5, "slot {i}");
            assert!(((transmitted.f[i] * 0.8) as f64 - want.transmittance()).abs() < 1e-5, "slot {i}");
        }
    }
    // No film here (thickness 0): everything passes straight through.
    let none = Bxdf::ThinFilm { film: None };
    let s = none.sample_f(Vec3::new(0.6, 0.0, 0.8), 0.0, Vec2::splat(0.5), TransportMode::Radiance).unwrap();
    assert!(s.transmission && s.pdf == 1.0 && (s.f[0] * 0.8 - 1.0).abs() < 1e-6, "{s:?}");
}

//! pbrt-v4's geometry buffer on the film: filter-weighted means of the visible surfaces' geometry, the sample
//! variance of the samples' colour (exactly 0 for equal samples, the closed form for two values), its merge
//! and state, and the EXR channels under pbrt-v4's names.

use film::{Film, FilmSpec, GBuffer, GBufferCoordinates, VisibleSurface};
use rand_core::{RngCore, SeedableRng};
use rand_pcg::Pcg64;
use spectral::{SampledSpectrum, SampledWavelengths};

fn uniform(rng: &mut Pcg64) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

fn gbuffer_spec(w: u32, h: u32) -> FilmSpec {
    let mut spec = FilmSpec::new(w, h, "g.exr");
    spec.aovs = true;
    spec.gbuffer = Some(GBuffer { coordinates: GBufferCoordinates::Camera });
    spec
}

/// The colour the film gives a sample (default sensor and white: XYZ to sRGB).
fn rgb_of(film: &Film, l: &SampledSpectrum, wl: &SampledWavelengths) -> [f64; 3] {
    film.spec().color_space.to_rgb(film.conversion().xyz(l, wl))
}

fn surface(rng: &mut Pcg64) -> VisibleSurface {
    let mut u = || uniform(rng) * 2.0 - 1.0;
    VisibleSurface { p: [u(), u(), 5.0 + u()], n: [u(), u(), -1.0], uv: [u(), u()], dzdx: u(), dzdy: u() }
}

#[test]
fn geometry_is_the_filter_weighted_mean_over_the_samples_that_saw_a_surface() {
    let mut film = Film::new(gbuffer_spec(3, 2)).unwrap();
    let mut rng = Pcg64::seed_from_u64(1);
    let wl = film.sample_wavelengths(0.3);
    let l = SampledSpectrum::splat(1.0);
    let (mut sw, mut sp, mut sn, mut suv, mut sdz) = (0.0, [0.0; 3], [0.0; 3], [0.0; 2], [0.0; 2]);
    for k in 0..20 {
        let s = surface(&mut rng);
        // Weights of both signs, as the Mitchell filter gives.
        let w = if k % 5 == 0 { -0.25 } else { 0.5 + uniform(&mut rng) };
        assert!(film.add_sample(1, 1, &l, &wl, w));
        assert!(film.add_visible_surface(1, 1, &s, w, Some((&l, &wl))));
        sw += w;
        for c in 0..3 {
            sp[c] += w * s.p[c];
            sn[c] += w * s.n[c];
        }
        suv[0] += w * s.uv[0];
        suv[1] += w * s.uv[1];
        sdz[0] += w * s.dzdx;
        sdz[1] += w * s.dzdy;
    }
    // Samples without a visible surface count for the colour only.
    film.add_sample(1, 1, &SampledSpectrum::splat(9.0), &wl, 3.0);
    let px = film.pixel_gbuffer(1, 1).unwrap();
    let len = (sn[0] * sn[0] + sn[1] * sn[1] + sn[2] * sn[2]).sqrt();
    for c in 0..3 {
        assert!((px.p[c] - sp[c] / sw).abs() < 1e-12, "{px:?}");
        assert!((px.n[c] - sn[c] / len).abs() < 1e-12, "{px:?}");
    }
    assert!((px.uv[0] - suv[0] / sw).abs() < 1e-12 && (px.uv[1] - suv[1] / sw).abs() < 1e-12);
    // pbrt-v4 writes |mean dz/dx|.
    assert!((px.dz[0] - (sdz[0] / sw).abs()).abs() < 1e-12 && (px.dz[1] - (sdz[1] / sw).abs()).abs() < 1e-12);
    assert_eq!(px.count, 20.0);
    // Pixels without surfaces are zero; non-finite values and pixels outside are dropped.
    assert_eq!(film.pixel_gbuffer(0, 0).unwrap().p, [0.0; 3]);
    let bad = VisibleSurface { dzdx: f64::NAN, ..surface(&mut rng) };
    assert!(!film.add_visible_surface(0, 0, &bad, 1.0, None));
    assert!(!film.add_visible_surface(3, 0, &surface(&mut rng), 1.0, None));
    assert!(!film.add_visible_surface(0, 0, &surface(&mut rng), f64::INFINITY, None));
    assert_eq!(film.pixel_gbuffer(0, 0).unwrap().count, 0.0);
    // A film without a gbuffer keeps none.
    let mut plain = Film::new(FilmSpec::new(3, 2, "p.exr")).unwrap();
    assert!(!plain.add_visible_surface(0, 0, &surface(&mut rng), 1.0, None));
    assert!(plain.pixel_gbuffer(0, 0).is_none() && plain.to_gbuffer_images().is_none());
}

#[test]
fn variance_is_pbrt_v4s_sample_variance_of_the_samples_colour() {
    let mut film = Film::new(gbuffer_spec(3, 1)).unwrap();
    let mut rng = Pcg64::seed_from_u64(2);
    let wl = film.sample_wavelengths(0.61);
    let l = SampledSpectrum::splat(0.37);
    let s = surface(&mut rng);
    // Pixel 0: 1000 equal samples (a constant radiance): variance exactly 0, although 0.37 rounds in the sums.
    for _ in 0..1000 {
        film.add_sample(0, 0, &l, &wl, 1.0);
        film.add_visible_surface(0, 0, &s, 1.0, Some((&l, &wl)));
    }
    let px = film.pixel_gbuffer(0, 0).unwrap();
    let rgb = rgb_of(&film, &l, &wl);
    assert_eq!(px.variance, [0.0; 3]);
    assert_eq!(px.relative_variance, [0.0; 3]);
    for c in 0..3 {
        assert!((px.mean[c] - rgb[c]).abs() <= 1e-12 * rgb[c].abs(), "{px:?} {rgb:?}");
    }
    // Pixel 1: a Bernoulli pixel, k of n samples see the radiance and the others black: the sample variance is
    // k(n−k)/(n(n−1))·v² exactly, and the relative variance that over the mean k·v/n.
    let (n, k) = (240u32, 90u32);
    for i in 0..n {
        let li = if i % 8 < 3 { l } else { SampledSpectrum::zero() };
        film.add_visible_surface(1, 0, &s, 0.7, Some((&li, &wl)));
    }
    let px = film.pixel_gbuffer(1, 0).unwrap();
    let (nf, kf) = (n as f64, k as f64);
    for (c, v) in rgb.iter().enumerate() {
        let want = kf * (nf - kf) / (nf * (nf - 1.0)) * v * v;
        assert!((px.variance[c] - want).abs() <= 1e-12 * want, "{c}: {} vs {want}", px.variance[c]);
        let rel = want / (kf * v / nf);
        assert!((px.relative_variance[c] - rel).abs() <= 1e-12 * rel.abs(), "{c}: {px:?}");
    }
    // Pixel 2: random colours against a two-pass variance; one sample alone has variance 0; a record without a
    // sample (photon mapping's) adds geometry only.
    let mut values = Vec::new();
    for _ in 0..50 {
        let wl = film.sample_wavelengths(uniform(&mut rng));
        let l = SampledSpectrum::splat(uniform(&mut rng) as f32 * 4.0);
        film.add_visible_surface(2, 0, &s, 1.0, Some((&l, &wl)));
        values.push(rgb_of(&film, &l, &wl));
    }
    film.add_visible_surface(2, 0, &s, 1.0, None);
    let px = film.pixel_gbuffer(2, 0).unwrap();
    assert_eq!(px.count, 50.0);
    for c in 0..3 {
        let mean = values.iter().map(|v| v[c]).sum::<f64>() / 50.0;
        let var = values.iter().map(|v| (v[c] - mean).powi(2)).sum::<f64>() / 49.0;
        assert!((px.variance[c] - var).abs() <= 1e-10 * var, "{c}: {} vs {var}", px.variance[c]);
        assert!(var > 1e-3 * mean * mean, "not a trivial case");
    }
}

/// Random gbuffer samples into `film` (every third without a surface).
fn fill(film: &mut Film, rng: &mut Pcg64, n: usize) {
    for y in 0..film.height() {
        for x in 0..film.width() {
            for k in 0..n {
                let wl = film.sample_wavelengths(uniform(rng));
                let l = SampledSpectrum::splat(uniform(rng) as f32 * 2.0);
                let w = 0.5 + uniform(rng);
                film.add_sample(x, y, &l, &wl, w);
                if k % 3 != 0 {
                    film.add_albedo(x, y, &SampledSpectrum::splat(0.5), &wl, [0.0, 0.0, -1.0]);
                    film.add_visible_surface(x, y, &surface(rng), w, Some((&l, &wl)));
                }
            }
        }
    }
}

#[test]
fn gbuffer_sums_are_state_planes_that_paste_add_and_merge() {
    let mut rng = Pcg64::seed_from_u64(3);
    let (mut a, mut b, mut whole) = (
        Film::new(gbuffer_spec(4, 3)).unwrap(),
        Film::new(gbuffer_spec(4, 3)).unwrap(),
        Film::new(gbuffer_spec(4, 3)).unwrap(),
    );
    let mut r = rng.clone();
    fill(&mut a, &mut rng, 5);
    fill(&mut whole, &mut r, 5);
    let mut r = rng.clone();
    fill(&mut b, &mut rng, 5);
    fill(&mut whole, &mut r, 5);
    let state = a.state();
    let names: Vec<&str> = state.planes.iter().map(|p| p.name.as_str()).collect();
    for want in ["gbuffer.W", "P.X", "Ng.Z", "u", "v", "dzdx", "dzdy", "variance.n", "variance.B2"] {
        assert!(names.contains(&want), "{want} missing from {names:?}");
    }
    assert_eq!(names.len(), 4 + 7 + 18);
    // Pasted: the same bits; added: the whole film up to the rounding of the sums.
    let mut restored = Film::new(gbuffer_spec(4, 3)).unwrap();
    restored.paste(&state).unwrap();
    assert_eq!(restored.state(), state);
    assert_eq!(restored.to_gbuffer_images(), a.to_gbuffer_images());
    restored.add_state(&b.state()).unwrap();
    let mut merged = a.clone();
    merged.merge(&b).unwrap();
    for film in [&restored, &merged] {
        for y in 0..3 {
            for x in 0..4 {
                let (p, q) = (film.pixel_gbuffer(x, y).unwrap(), whole.pixel_gbuffer(x, y).unwrap());
                assert_eq!(p.count, q.count);
                for c in 0..3 {
                    assert!((p.p[c] - q.p[c]).abs() <= 1e-13 && (p.n[c] - q.n[c]).abs() <= 1e-13, "{p:?} {q:?}");
                    assert!((p.variance[c] - q.variance[c]).abs() <= 1e-12 * q.variance[c], "{p:?} {q:?}");
                }
            }
        }
    }
    // A state of a film without a gbuffer is not this film's, nor is a gbuffer film mergeable with a plain one.
    let mut plain_spec = gbuffer_spec(4, 3);
    plain_spec.gbuffer = None;
    let plain = Film::new(plain_spec).unwrap();
    let e = restored.paste(&plain.state()).unwrap_err().to_string();
    assert!(e.contains("gbuffer"), "{e}");
    assert!(restored.merge(&plain).is_err());
}

#[test]
fn the_exr_holds_pbrt_v4s_gbuffer_channels() {
    let dir = std::env::temp_dir().join(format!("prismatic-film-gbuffer-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("g.exr");
    let mut film = Film::new(gbuffer_spec(4, 3)).unwrap();
    fill(&mut film, &mut Pcg64::seed_from_u64(4), 6);
    film::write_image(&film, &path).unwrap();
    let (w, h, channels) = film::read_exr_channels(&path).unwrap();
    assert_eq!((w, h), (4, 3));
    let mut names: Vec<&str> = channels.iter().map(|(n, _)| n.as_str()).collect();
    names.sort_unstable();
    let mut want = vec![
        "R",
        "G",
        "B",
        "Albedo.R",
        "Albedo.G",
        "Albedo.B",
        "P.X",
        "P.Y",
        "P.Z",
        "dzdx",
        "dzdy",
        "N.X",
        "N.Y",
        "N.Z",
        "Ns.X",
        "Ns.Y",
        "Ns.Z",
        "u",
        "v",
        "Variance.R",
        "Variance.G",
        "Variance.B",
        "RelativeVariance.R",
        "RelativeVariance.G",
        "RelativeVariance.B",
    ];
    want.sort_unstable();
    assert_eq!(names, want);
    let get = |name: &str| &channels.iter().find(|(n, _)| n == name).unwrap().1;
    let g = film.to_gbuffer_images().unwrap();
    for i in 0..12 {
        assert_eq!(get("P.Y")[i], g.p[i][1]);
        assert_eq!(get("dzdy")[i], g.dz[i][1]);
        assert_eq!(get("N.X")[i], g.n[i][0]);
        assert_eq!(get("v")[i], g.uv[i][1]);
        assert_eq!(get("Variance.G")[i], g.variance[i][1]);
        assert_eq!(get("RelativeVariance.B")[i], g.relative_variance[i][2]);
        assert!(g.variance[i][1] > 0.0);
    }
    // The albedo and shading-normal channels are read back as before.
    let aovs = film::read_exr_aovs(&path).unwrap();
    assert!(aovs.normal.iter().all(|n| *n == [0.0, 0.0, -1.0]));
    let _ = std::fs::remove_dir_all(&dir);
}

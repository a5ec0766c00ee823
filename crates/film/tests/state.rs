//! A film's accumulators stored and put back: the state, pasted into a fresh film, gives the same bits; parts of a
//! render written as EXR read back exactly; sums of two halves equal the film of all samples up to rounding;
//! anything that is not this film's state is an error.

use film::{Film, FilmKind, FilmSpec, PixelBounds};
use rand_core::{RngCore, SeedableRng};
use rand_pcg::Pcg64;
use spectral::{SampledSpectrum, Xyz};

fn uniform(rng: &mut Pcg64) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

fn spec(spectral: bool, aovs: bool) -> FilmSpec {
    let mut spec = FilmSpec::new(7, 5, "state.exr");
    if spectral {
        spec.kind = FilmKind::Spectral { nbuckets: 6, lambda_min: 380.0, lambda_max: 740.0 };
    }
    spec.aovs = aovs;
    spec
}

/// Adds `n` random camera samples per pixel, AOV records and (if `splats`) random splats to `film`.
fn fill(film: &mut Film, rng: &mut Pcg64, n: usize, splats: bool) {
    for y in 0..5 {
        for x in 0..7 {
            for _ in 0..n {
                let wl = film.sample_wavelengths(uniform(rng));
                let l = SampledSpectrum::splat(uniform(rng) as f32 * 3.0);
                film.add_sample(x, y, &l, &wl, 0.5 + uniform(rng));
                film.add_aov(x, y, [uniform(rng), 0.5, 0.25], [0.0, 1.0, uniform(rng)]);
            }
        }
    }
    if splats {
        for _ in 0..40 {
            let wl = film.sample_wavelengths(uniform(rng));
            let l = SampledSpectrum::splat(uniform(rng) as f32);
            film.add_splat([uniform(rng) * 7.0, uniform(rng) * 5.0], &l, &wl);
        }
        film.add_light_paths(35 * n as u64);
    }
    // One dropped sample, counted.
    film.add_xyz_sample(1, 1, Xyz::new(f64::NAN, 0.0, 0.0), 1.0, &[]);
}

fn bits(film: &Film) -> Vec<u64> {
    let mut out: Vec<u64> = film.to_rgb_image().iter().flat_map(|p| p.map(|c| c.to_bits() as u64)).collect();
    out.extend(film.to_spectral_image().iter().map(|v| v.to_bits() as u64));
    for p in film.state().planes {
        out.extend(p.values.iter().map(|v| v.to_bits()));
    }
    out
}

#[test]
fn a_pasted_state_restores_the_film_bit_for_bit_and_it_renders_on_identically() {
    for (spectral, aovs, splats) in
        [(false, false, false), (true, true, true), (true, false, true), (false, true, false)]
    {
        let mut rng = Pcg64::seed_from_u64(11);
        let mut film = Film::new(spec(spectral, aovs)).unwrap();
        fill(&mut film, &mut rng, 3, splats);
        let state = film.state();
        assert_eq!(state.has_splats(), splats);
        assert_eq!(state.rejected_samples, 1);
        let names: Vec<&str> = state.planes.iter().map(|p| p.name.as_str()).collect();
        assert_eq!(names, film.plane_names(splats));
        assert_eq!(
            names.len(),
            4 + if spectral { 6 } else { 0 }
                + if aovs { 7 } else { 0 }
                + if splats { 3 + if spectral { 6 } else { 0 } } else { 0 }
        );
        let mut restored = Film::new(spec(spectral, aovs)).unwrap();
        restored.paste(&state).unwrap();
        assert_eq!(restored.state(), state);
        assert_eq!(bits(&restored), bits(&film));
        assert_eq!(restored.rejected_samples(), film.rejected_samples());
        // Both go on with the same samples: still the same bits.
        let mut r2 = rng.clone();
        fill(&mut film, &mut rng, 2, splats);
        fill(&mut restored, &mut r2, 2, splats);
        assert_eq!(bits(&restored), bits(&film));
    }
}

#[test]
fn added_states_equal_the_film_of_all_samples_to_rounding() {
    let mut rng = Pcg64::seed_from_u64(3);
    let mut first = Film::new(spec(true, false)).unwrap();
    let mut second = Film::new(spec(true, false)).unwrap();
    let mut both = Film::new(spec(true, false)).unwrap();
    let mut r = rng.clone();
    fill(&mut first, &mut rng, 4, true);
    fill(&mut both, &mut r, 4, true);
    let mut r = rng.clone();
    fill(&mut second, &mut rng, 4, true);
    fill(&mut both, &mut r, 4, true);
    let mut merged = Film::new(spec(true, false)).unwrap();
    merged.paste(&first.state()).unwrap();
    merged.add_state(&second.state()).unwrap();
    assert_eq!(merged.light_paths(), both.light_paths());
    let (a, b) = (merged.state(), both.state());
    for (p, q) in a.planes.iter().zip(&b.planes) {
        for (u, v) in p.values.iter().zip(&q.values) {
            // Sums of 8 positive terms in a different grouping: within a few units of 2^-53.
            assert!((u - v).abs() <= 8.0 * f64::EPSILON * u.abs().max(v.abs()), "{}: {u} {v}", p.name);
        }
    }
    // Not trivially equal: each half alone is far from the whole.
    assert!((first.pixel_xyz(3, 2).y - both.pixel_xyz(3, 2).y).abs() > 1e-3);
}

#[test]
fn a_tile_pastes_into_its_pixels_only() {
    let mut rng = Pcg64::seed_from_u64(5);
    let mut whole = Film::new(spec(true, true)).unwrap();
    fill(&mut whole, &mut rng, 2, false);
    let mut tile_spec = spec(true, true);
    tile_spec.pixel_bounds = Some(PixelBounds { x0: 2, x1: 6, y0: 1, y1: 4 });
    let mut tile = Film::new(tile_spec).unwrap();
    let mut rng = Pcg64::seed_from_u64(6);
    for y in 1..4 {
        for x in 2..6 {
            let wl = tile.sample_wavelengths(uniform(&mut rng));
            tile.add_sample(x, y, &SampledSpectrum::splat(7.0), &wl, 1.0);
        }
    }
    let before = whole.clone();
    whole.paste(&tile.state()).unwrap();
    for y in 0..5 {
        for x in 0..7 {
            if (2..6).contains(&x) && (1..4).contains(&y) {
                assert_eq!(whole.pixel_xyz(x, y), tile.pixel_xyz(x, y));
                assert_eq!(whole.pixel_spectrum(x, y), tile.pixel_spectrum(x, y));
            } else {
                assert_eq!(whole.pixel_xyz(x, y), before.pixel_xyz(x, y));
            }
        }
    }
}

#[test]
fn foreign_states_are_errors() {
    let mut rng = Pcg64::seed_from_u64(8);
    let mut film = Film::new(spec(true, false)).unwrap();
    fill(&mut film, &mut rng, 1, true);
    let good = film.state();
    let mut rgb = Film::new(spec(false, false)).unwrap();
    assert!(rgb.paste(&good).unwrap_err().to_string().contains("not this film's"));
    let mut target = Film::new(spec(true, false)).unwrap();
    let mut short = good.clone();
    short.planes[2].values.pop();
    assert!(target.paste(&short).unwrap_err().to_string().contains("has 34 values"));
    let mut twice = good.clone();
    twice.planes[1].name = "X".into();
    assert!(target.paste(&twice).is_err());
    let mut outside = good.clone();
    outside.bounds = PixelBounds { x0: 1, x1: 8, y0: 0, y1: 5 };
    assert!(target.paste(&outside).unwrap_err().to_string().contains("not inside"));
    // A tile with splats: splats reach every pixel, so it cannot stand for its pixels alone.
    let mut tile = good.clone();
    tile.bounds = PixelBounds { x0: 0, x1: 7, y0: 0, y1: 1 };
    for p in &mut tile.planes {
        p.values.truncate(7);
    }
    assert!(target.paste(&tile).unwrap_err().to_string().contains("splats"));
    let mut nan = good.clone();
    nan.light_paths = f64::NAN;
    assert!(target.add_state(&nan).is_err());
    // Nothing above changed the target.
    assert_eq!(target.state(), Film::new(spec(true, false)).unwrap().state());
}

#[test]
fn a_part_exr_stores_the_sums_exactly() {
    let dir = std::env::temp_dir().join(format!("prismatic-film-state-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut rng = Pcg64::seed_from_u64(9);
    let mut s = spec(true, true);
    s.pixel_bounds = Some(PixelBounds { x0: 1, x1: 7, y0: 2, y1: 5 });
    s.write_fp16 = true;
    let mut film = Film::new(s).unwrap();
    for y in 2..5 {
        for x in 1..7 {
            let wl = film.sample_wavelengths(uniform(&mut rng));
            film.add_sample(x, y, &SampledSpectrum::splat(uniform(&mut rng) as f32), &wl, 0.9);
        }
    }
    let path = dir.join("part.exr");
    let attrs = vec![("prismatic.shard".to_string(), "2/3".to_string())];
    film::write_part(&film, &path, &attrs).unwrap();
    let (read_attrs, state) = film::read_part(&path).unwrap();
    assert_eq!(read_attrs["prismatic.shard"], "2/3");
    let mut want = film.state();
    want.planes.sort_by(|a, b| a.name.cmp(&b.name));
    let mut got = state.clone();
    got.planes.sort_by(|a, b| a.name.cmp(&b.name));
    assert_eq!(got, want);
    // The part is also an image: its R, G, B are the film's.
    let (w, h, rgb) = film::read_exr_rgb(&path).unwrap();
    assert_eq!((w, h), (6, 3));
    assert_eq!(rgb, film.to_rgb_image());
    // A plain image is not a part; a truncated part is an error, not a panic.
    let plain = dir.join("plain.exr");
    film::write_image(&film, &plain).unwrap();
    assert!(film::read_part(&plain).unwrap_err().to_string().contains("not a render part"));
    let bytes = std::fs::read(&path).unwrap();
    for cut in [10, bytes.len() / 2, bytes.len() - 3] {
        std::fs::write(dir.join("cut.exr"), &bytes[..cut]).unwrap();
        assert!(film::read_part(&dir.join("cut.exr")).is_err(), "cut at {cut}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

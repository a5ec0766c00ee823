use super::*;
use std::f32::consts::PI;

fn c(v: f32) -> Box<FloatTexture> {
    Box::new(FloatTexture::Constant(v))
}

fn at_uv(u: f32, v: f32) -> TextureEvalContext {
    TextureEvalContext::new(Vec3::ZERO, Vec3::Z, Vec2::new(u, v))
}

fn at_p(p: Vec3) -> TextureEvalContext {
    TextureEvalContext::new(p, Vec3::Z, Vec2::ZERO)
}

#[test]
fn checkerboard_alternates() {
    let t = FloatTexture::Checkerboard {
        map: Box::new(CheckerMapping::Planar(TextureMapping2D::Uv(UvMapping { su: 4.0, sv: 4.0, du: 0.0, dv: 0.0 }))),
        tex1: c(1.0),
        tex2: c(0.0),
    };
    assert_eq!(t.eval(&at_uv(0.1, 0.1)), 1.0);
    assert_eq!(t.eval(&at_uv(0.3, 0.1)), 0.0);
    assert_eq!(t.eval(&at_uv(0.3, 0.3)), 1.0);
    // Negative coordinates: floor(−0.4) = −1, so (−0.1, 0.1)·4 lies on an odd check.
    assert_eq!(t.eval(&at_uv(-0.1, 0.1)), 0.0);
}

#[test]
fn solid_checkerboard_uses_the_texture_space_point() {
    // Texture space = render space shifted by −(0.5, 0, 0) and halved: p_tex = (p − (0.5, 0, 0))/2.
    let m = PointMapping {
        texture_from_render: Affine3A::from_scale(Vec3::splat(0.5)) * Affine3A::from_translation(-0.5 * Vec3::X),
    };
    let t = FloatTexture::Checkerboard { map: Box::new(CheckerMapping::Solid(m)), tex1: c(1.0), tex2: c(7.0) };
    // p = (0.6, 0.1, 0.1) → (0.05, 0.05, 0.05): cube (0, 0, 0), even.
    assert_eq!(t.eval(&at_p(Vec3::new(0.6, 0.1, 0.1))), 1.0);
    // p = (0.4, 0.1, 0.1) → (−0.05, …): cube (−1, 0, 0), odd.
    assert_eq!(t.eval(&at_p(Vec3::new(0.4, 0.1, 0.1))), 7.0);
    // p = (2.6, 2.1, 0.1) → (1.05, 1.05, 0.05): cube (1, 1, 0), even.
    assert_eq!(t.eval(&at_p(Vec3::new(2.6, 2.1, 0.1))), 1.0);
    // p = (2.6, 2.1, -0.1) → z −0.05: cube (1, 1, −1), odd.
    assert_eq!(t.eval(&at_p(Vec3::new(2.6, 2.1, -0.1))), 7.0);
}

#[test]
fn scale_mix_and_direction_mix_follow_their_formulas() {
    let ctx = at_uv(0.5, 0.5);
    assert_eq!(FloatTexture::Scale { tex: c(2.0), scale: c(3.0) }.eval(&ctx), 6.0);
    // A zero scale never evaluates the texture (pbrt-v4), so even a NaN texture gives 0.
    assert_eq!(FloatTexture::Scale { tex: c(f32::NAN), scale: c(0.0) }.eval(&ctx), 0.0);
    let mix = |a: f32| FloatTexture::Mix { tex1: c(2.0), tex2: c(6.0), amount: c(a) }.eval(&ctx);
    assert_eq!(mix(0.25), 3.0);
    assert_eq!(mix(0.0), 2.0);
    assert_eq!(mix(1.0), 6.0);
    // Direction mix with dir = +y and geometric normal (0, −0.6, 0.8): a = |n·dir| = 0.6.
    let dm = FloatTexture::DirectionMix { tex1: c(10.0), tex2: c(20.0), dir: Vec3::Y };
    let ctx = TextureEvalContext::new(Vec3::ZERO, Vec3::new(0.0, -0.6, 0.8), Vec2::ZERO);
    assert!((dm.eval(&ctx) - (0.6 * 10.0 + 0.4 * 20.0)).abs() < 1e-5);
    // Facing dir exactly: tex1 alone (tex2 is not evaluated).
    let dm = FloatTexture::DirectionMix { tex1: c(10.0), tex2: c(f32::NAN), dir: Vec3::Y };
    assert_eq!(dm.eval(&TextureEvalContext::new(Vec3::ZERO, -Vec3::Y, Vec2::ZERO)), 10.0);
    // Spectra: the same formulas at every wavelength.
    let wl = SampledWavelengths::new([450.0, 550.0, 650.0, 700.0], [1.0; 4]);
    let sc = |v: f64| Box::new(SpectrumTexture::Constant(Spectrum::Constant(v)));
    let s = SpectrumTexture::Mix { tex1: sc(2.0), tex2: sc(6.0), amount: c(0.25) }.eval(&at_uv(0.0, 0.0), &wl);
    assert!((0..4).all(|i| (s[i] - 3.0).abs() < 1e-6));
    let s = SpectrumTexture::Scale { tex: sc(0.5), scale: c(3.0) }.eval(&at_uv(0.0, 0.0), &wl);
    assert!((0..4).all(|i| (s[i] - 1.5).abs() < 1e-6));
    let s = SpectrumTexture::DirectionMix { tex1: sc(10.0), tex2: sc(20.0), dir: Vec3::Y }.eval(&ctx, &wl);
    assert!((0..4).all(|i| (s[i] - 14.0).abs() < 1e-5));
}

#[test]
fn bilerp_interpolates_its_corners() {
    let map = Box::new(TextureMapping2D::Uv(UvMapping::default()));
    let t = FloatTexture::Bilerp { map: map.clone(), v: [1.0, 2.0, 3.0, 5.0] };
    // (1−s)(1−t)·1 + (1−s)t·2 + s(1−t)·3 + st·5 at (0.25, 0.5) = 0.375 + 0.75 + 0.375 + 0.625.
    assert!((t.eval(&at_uv(0.25, 0.5)) - 2.125).abs() < 1e-6);
    assert_eq!(t.eval(&at_uv(0.0, 0.0)), 1.0);
    assert_eq!(t.eval(&at_uv(0.0, 1.0)), 2.0);
    assert_eq!(t.eval(&at_uv(1.0, 0.0)), 3.0);
    assert_eq!(t.eval(&at_uv(1.0, 1.0)), 5.0);
    let wl = SampledWavelengths::new([450.0, 550.0, 650.0, 700.0], [1.0; 4]);
    let v = Box::new([1.0, 2.0, 3.0, 5.0].map(Spectrum::Constant));
    let s = SpectrumTexture::Bilerp { map, v }.eval(&at_uv(0.25, 0.5), &wl);
    assert!((0..4).all(|i| (s[i] - 2.125).abs() < 1e-6));
}

#[test]
fn mappings_round_trip_known_points() {
    // The texture's CTM: translate by c, then scale by 2; texture_from_render is its inverse.
    let centre = Vec3::new(1.0, -2.0, 0.5);
    let render_from_texture = Affine3A::from_translation(centre) * Affine3A::from_scale(Vec3::splat(2.0));
    let tfr = render_from_texture.inverse();
    let ctx = |p_tex: Vec3| at_p(render_from_texture.transform_point3(p_tex));
    // Spherical: s = θ/π from +z, t = φ/2π.
    let sph = TextureMapping2D::Spherical(tfr);
    for (theta, phi) in [(0.3f32, 0.4f32), (2.0, 5.5), (1.2, 3.5)] {
        let d = Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
        let st = sph.map(&ctx(3.0 * d));
        assert!((st - Vec2::new(theta / PI, phi / (2.0 * PI))).length() < 1e-5, "{st}");
    }
    // Cylindrical: s = (π + atan2(y, x))/2π, t = z.
    let cyl = TextureMapping2D::Cylindrical(tfr);
    for (a, z) in [(0.5f32, 0.25f32), (-2.0, 3.0), (3.0, -1.5)] {
        let st = cyl.map(&ctx(Vec3::new(1.7 * a.cos(), 1.7 * a.sin(), z)));
        assert!((st - Vec2::new((PI + a) / (2.0 * PI), z)).length() < 1e-5, "{st}");
    }
    // Planar: s = ds + p·v1, t = dt + p·v2.
    let (vs, vt) = (Vec3::new(1.0, 0.0, 1.0), Vec3::new(0.0, 2.0, 0.0));
    let pl = TextureMapping2D::Planar { texture_from_render: tfr, vs, vt, ds: 0.25, dt: -1.0 };
    let p = Vec3::new(0.3, -0.7, 1.1);
    let st = pl.map(&ctx(p));
    assert!((st - Vec2::new(0.25 + 0.3 + 1.1, -1.0 - 1.4)).length() < 1e-5, "{st}");
    // uv: scale and offset of (u, v).
    let uv = TextureMapping2D::Uv(UvMapping { su: 2.0, sv: 3.0, du: 0.5, dv: -1.0 });
    assert_eq!(uv.map(&at_uv(0.25, 0.5)), Vec2::new(1.0, 0.5));
    // 3-D: the point in texture space.
    let m = PointMapping { texture_from_render: tfr };
    assert!((m.map(&ctx(p)) - p).length() < 1e-5);
}

fn two_by_two() -> RgbImage {
    // Row 0 (top): 1, 2; row 1 (bottom): 3, 4 (all channels equal).
    RgbImage::new(2, 2, [1.0, 2.0, 3.0, 4.0].map(|v| [v; 3]).to_vec())
}

#[test]
fn wrap_modes_decide_the_texels_beyond_the_edges() {
    let img = two_by_two();
    // Texel centres: s = 0.25, 0.75 for columns 0, 1; t = 0.75 for row 0 (top), 0.25 for row 1.
    assert_eq!(img.bilerp_wrapped(Vec2::new(0.25, 0.75), WrapMode::Clamp)[0], 1.0);
    assert_eq!(img.bilerp_wrapped(Vec2::new(0.75, 0.25), WrapMode::Clamp)[0], 4.0);
    // At s = 0 (halfway between column 0 and the texel left of it), row 0:
    let at = |wrap| img.bilerp_wrapped(Vec2::new(0.0, 0.75), wrap)[0];
    assert_eq!(at(WrapMode::Repeat), 1.5, "repeat: column −1 is column 1 (2)");
    assert_eq!(at(WrapMode::Clamp), 1.0, "clamp: column −1 is column 0 (1)");
    assert_eq!(at(WrapMode::Black), 0.5, "black: column −1 is 0");
    assert_eq!(at(WrapMode::OctahedralSphere), 2.0, "octahedral: (−1, 0) continues at (0, 1) (3)");
    // Past the top edge at column 1: row −1.
    let at = |wrap| img.bilerp_wrapped(Vec2::new(0.75, 1.0), wrap)[0];
    assert_eq!(at(WrapMode::Repeat), 3.0, "repeat: row −1 is row 1 (4)");
    assert_eq!(at(WrapMode::Clamp), 2.0);
    assert_eq!(at(WrapMode::Black), 1.0);
    assert_eq!(at(WrapMode::OctahedralSphere), 1.5, "octahedral: (1, −1) continues at (0, 0) (1)");
    // Far outside: repeat tiles, clamp holds the corner, black is zero.
    assert_eq!(img.bilerp_wrapped(Vec2::new(3.25, -4.25), WrapMode::Repeat)[0], 1.0);
    assert_eq!(img.bilerp_wrapped(Vec2::new(3.25, -4.25), WrapMode::Clamp)[0], 4.0);
    assert_eq!(img.bilerp_wrapped(Vec2::new(3.25, -4.25), WrapMode::Black)[0], 0.0);
    // Point lookups take the nearest texel.
    assert_eq!(img.nearest(Vec2::new(0.49, 0.51), WrapMode::Clamp)[0], 1.0);
    assert_eq!(img.nearest(Vec2::new(0.51, 0.49), WrapMode::Clamp)[0], 4.0);
    assert_eq!(img.nearest(Vec2::new(1.1, 0.9), WrapMode::Black)[0], 0.0);
}

#[test]
fn octahedral_wrap_mirrors_about_each_edge_midpoint() {
    let (w, h) = (8, 6);
    assert_eq!(octahedral_wrap(3, 2, w, h), (3, 2)); // inside: unchanged
    assert_eq!(octahedral_wrap(-1, 1, w, h), (0, 4)); // (−1, y) → (0, h−1−y)
    assert_eq!(octahedral_wrap(8, 0, w, h), (7, 5)); // (w, y) → (w−1, h−1−y)
    assert_eq!(octahedral_wrap(2, -1, w, h), (5, 0)); // (x, −1) → (w−1−x, 0)
    assert_eq!(octahedral_wrap(6, 6, w, h), (1, 5)); // (x, h) → (w−1−x, h−1)
    assert_eq!(octahedral_wrap(-1, -1, w, h), (7, 5)); // beyond a corner: the opposite corner

    // The wrapped texel's centre is the mirror image's: the direction half a texel beyond the edge u = 0 at row
    // y is the direction half a texel inside it at row h−1−y.
    let n = 16;
    for y in 0..n {
        let out = crate::light::equal_area_square_to_sphere(Vec2::new(-1e-6, (y as f32 + 0.5) / n as f32));
        let (xw, yw) = octahedral_wrap(-1, y, n, n);
        let inside = crate::light::equal_area_square_to_sphere(Vec2::new(1e-6, (yw as f32 + 0.5) / n as f32));
        assert_eq!(xw, 0);
        assert!((out - inside).length() < 1e-4, "row {y}: {out} vs {inside}");
    }
}

#[test]
fn image_textures_scale_invert_and_read_channels_as_pbrt_does() {
    let img = Arc::new(RgbImage::new(1, 1, vec![[0.2, 0.4, 0.9]]));
    let tex = |filter, scale, invert| ImageTexture {
        map: TextureMapping2D::default(),
        image: img.clone(),
        wrap: WrapMode::Repeat,
        filter,
        mip: None,
        max_anisotropy: 8.0,
        scale,
        tint: [1.0; 3],
        invert,
    };
    let ctx = at_uv(0.3, 0.6);
    let f = |filter, scale, invert| FloatTexture::Image(Box::new(tex(filter, scale, invert))).eval(&ctx);
    assert!((f(ImageFilter::Bilinear, 1.0, false) - 0.5).abs() < 1e-6, "mean of the channels");
    assert!((f(ImageFilter::Point, 1.0, false) - 0.2).abs() < 1e-6, "first channel");
    assert!((f(ImageFilter::Bilinear, 2.0, false) - 1.0).abs() < 1e-6);
    assert!((f(ImageFilter::Bilinear, 1.0, true) - 0.5).abs() < 1e-6);
    assert_eq!(f(ImageFilter::Bilinear, 3.0, true), 0.0, "1 − 1.5 clamped at zero");
    // Spectrum: a grey image is a constant spectrum; scale then invert.
    let grey = Arc::new(RgbImage::new(1, 1, vec![[0.25; 3]]));
    let wl = SampledWavelengths::new([400.0, 500.0, 600.0, 700.0], [1.0; 4]);
    let s = |kind, invert| {
        let tex = ImageTexture { image: grey.clone(), ..tex(ImageFilter::Bilinear, 2.0, invert) };
        SpectrumTexture::Image { tex: Box::new(tex), kind }.eval(&ctx, &wl)
    };
    for (kind, invert, expect) in
        [(RgbKind::Albedo, false, 0.5), (RgbKind::Unbounded, false, 0.5), (RgbKind::Albedo, true, 0.5)]
    {
        let v = s(kind, invert);
        assert!((0..4).all(|i| (v[i] - expect).abs() < 2e-3), "{kind:?} {invert}: {v:?}");
    }
}

#[test]
fn noise_textures_are_their_sums_in_texture_space() {
    let render_from_texture = Affine3A::from_scale(Vec3::splat(4.0));
    let map = Box::new(PointMapping { texture_from_render: render_from_texture.inverse() });
    let p_tex = Vec3::new(0.37, -1.21, 2.9);
    let ctx = at_p(render_from_texture.transform_point3(p_tex));
    let fbm = FloatTexture::Fbm { map: map.clone(), octaves: 8, omega: 0.5 }.eval(&ctx);
    assert!((fbm - noise::fbm(p_tex, 0.5, 8)).abs() < 1e-6);
    let wr = FloatTexture::Wrinkled { map: map.clone(), octaves: 4, omega: 0.7 }.eval(&ctx);
    assert!((wr - noise::turbulence(p_tex, 0.7, 4)).abs() < 1e-6);
    let windy = FloatTexture::Windy { map }.eval(&ctx);
    let expect = noise::fbm(0.1 * p_tex, 0.5, 3).abs() * noise::fbm(p_tex, 0.5, 6);
    assert!((windy - expect).abs() < 1e-6);
    assert!(fbm != 0.0 && wr > 0.0, "a generic point gives non-zero noise");
}

#[test]
fn marble_ramp_has_its_closed_form_values() {
    // Without variation, t = ½ + ½·sin(scale·y). sin = 0 gives t = ½: segment 3 at its start, colour 3 (0.5 grey);
    // sin = ±1 gives t = 1 or 0: the ramp's ends, colours 8 and 0 ((0.58, 0.58, 0.6)); all times 1.5.
    let grey = marble_rgb(Vec3::new(0.3, 0.0, -2.0), 8, 0.5, 1.0, 0.0);
    assert!(grey.iter().all(|&v| (v - 0.75).abs() < 1e-6), "{grey:?}");
    for y in [PI / 2.0, -PI / 2.0] {
        let end = marble_rgb(Vec3::new(0.0, y / 2.0, 0.0), 8, 0.5, 2.0, 0.0);
        assert!((end[0] - 0.87).abs() < 1e-5 && (end[2] - 0.9).abs() < 1e-5, "{end:?}");
    }
    // Between: t = ½ + ½ sin(y) = 7/12 is segment 3 at t = 0.5: Bernstein weights 1/8, 3/8, 3/8, 1/8 of
    // colours 3–6.
    let y = (2.0f32 * 7.0 / 12.0 - 1.0).asin();
    let mid = marble_rgb(Vec3::new(0.0, y, 0.0), 8, 0.5, 1.0, 0.0);
    let expect_r = 1.5 * (0.5 / 8.0 + 3.0 * 0.6 / 8.0 + 3.0 * 0.58 / 8.0 + 0.58 / 8.0);
    assert!((mid[0] - expect_r).abs() < 1e-5, "{mid:?} vs {expect_r}");
    // With variation the fBm shifts the phase: y + variation·fBm.
    let p = Vec3::new(0.4, 0.2, 0.9);
    let with = marble_rgb(p, 8, 0.5, 1.0, 0.2);
    let y_eff = 0.2 + 0.2 * noise::fbm(p, 0.5, 8);
    let without = marble_rgb(Vec3::new(p.x, y_eff, p.z), 0, 0.5, 1.0, 0.0);
    assert!((0..3).all(|i| (with[i] - without[i]).abs() < 1e-5));
}

#[test]
fn polka_dots_sit_in_cells_with_positive_noise() {
    let t = FloatTexture::Dots { map: Box::default(), dot: c(1.0), background: c(0.0) };
    let (mut with_dot, mut cells) = (0, 0);
    for i in -10..10 {
        for j in -10..10 {
            let (s, tt) = (i as f32, j as f32);
            let has_dot = noise::noise_2d(s + 0.5, tt + 0.5) > 0.0;
            // The dot's centre is within 0.15·1.04 of the cell's centre and its radius is 0.35: the centre is
            // always inside, the cell's corners (0.49·√2 − 0.16 > 0.35 away) never.
            assert_eq!(t.eval(&at_uv(s, tt)), if has_dot { 1.0 } else { 0.0 }, "cell ({i}, {j})");
            assert_eq!(t.eval(&at_uv(s + 0.49, tt - 0.49)), 0.0);
            with_dot += has_dot as u32;
            cells += 1;
        }
    }
    assert!(with_dot > cells / 5 && with_dot < cells * 4 / 5, "{with_dot} of {cells} cells hold a dot");
}

/// A `w`×`h` image with texel values from `f(x, y)` (grey).
fn grey_image(w: usize, h: usize, f: impl Fn(usize, usize) -> f32) -> Arc<RgbImage> {
    let pixels = (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).map(|(x, y)| [f(x, y); 3]).collect();
    Arc::new(RgbImage::new(w, h, pixels))
}

/// A hash of (x, y) in [0, 1), for images without structure.
fn noise(x: usize, y: usize) -> f32 {
    let h = (x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ (y as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
    ((h ^ (h >> 29)).wrapping_mul(0xBF58_476D_1CE4_E5B9) >> 40) as f32 / (1u64 << 24) as f32
}

fn image_mean(img: &RgbImage) -> f64 {
    img.texels.iter().map(|p| p[0] as f64).sum::<f64>() / img.texels.len() as f64
}

#[test]
fn mip_levels_halve_down_to_one_texel_and_keep_the_mean() {
    // A power-of-two image of random texels: 1 + log₂ 32 levels, each half the last, each with the image's mean
    // (a 2×2 box average keeps it exactly, up to f32 rounding); a 1-texel side is reused (32×8 → … → 2×1 → 1×1).
    let img = grey_image(32, 8, noise);
    let mip = MipMap::new(&img, WrapMode::Repeat);
    assert_eq!(mip.levels(), 6);
    let sizes: Vec<(usize, usize)> = (0..6).map(|i| (mip.level(i).width, mip.level(i).height)).collect();
    assert_eq!(sizes, [(32, 8), (16, 4), (8, 2), (4, 1), (2, 1), (1, 1)]);
    assert_eq!(mip.level(0), &*img);
    let mean = image_mean(&img);
    assert!(mean > 0.3 && mean < 0.7, "{mean}");
    for i in 0..6 {
        let m = image_mean(mip.level(i));
        assert!((m - mean).abs() < 1e-6, "level {i}: mean {m} vs {mean}");
    }
    // Level 1's texel (0, 0) is the mean of the four texels it covers.
    let want = (noise(0, 0) + noise(1, 0) + noise(0, 1) + noise(1, 1)) / 4.0;
    assert!((mip.level(1).texels.get(0)[0] - want).abs() < 1e-7);
    // Any other size is resampled up to the next powers of two first (20×12 → 32×16), and the levels below keep
    // that level's mean; a constant image stays constant through the resampling (normalised weights) under every
    // wrap mode but black.
    let img = grey_image(20, 12, noise);
    let mip = MipMap::new(&img, WrapMode::Clamp);
    assert_eq!((mip.level(0).width, mip.level(0).height, mip.levels()), (32, 16, 6));
    let base = image_mean(mip.level(0));
    assert!((base - image_mean(&img)).abs() < 0.02, "{base} vs {}", image_mean(&img));
    for i in 1..6 {
        assert!((image_mean(mip.level(i)) - base).abs() < 1e-6, "level {i}");
    }
    for wrap in [WrapMode::Repeat, WrapMode::Clamp, WrapMode::OctahedralSphere] {
        let constant = grey_image(12, 12, |_, _| 0.37);
        let mip = MipMap::new(&constant, wrap);
        for i in 0..mip.levels() {
            assert!(mip.level(i).texels.iter().all(|p| (p[0] - 0.37).abs() < 1e-5), "{wrap:?} level {i}");
        }
    }
}

#[test]
fn filtered_lookups_of_a_constant_are_the_constant_and_without_footprint_are_bilinear() {
    let constant = grey_image(16, 16, |_, _| 0.61);
    let img = grey_image(16, 16, noise);
    let st = [Vec2::new(0.3, 0.7), Vec2::new(0.03, 0.99), Vec2::new(1.4, -0.2), Vec2::new(0.5, 0.5)];
    let footprints = [
        (Vec2::new(0.01, 0.0), Vec2::new(0.0, 0.01)),
        (Vec2::new(0.2, 0.05), Vec2::new(-0.01, 0.004)),
        (Vec2::new(3.0, 0.0), Vec2::new(0.0, 2.0)),
        (Vec2::new(0.0005, 0.0001), Vec2::new(0.0, 0.0)),
    ];
    for wrap in [WrapMode::Repeat, WrapMode::Clamp, WrapMode::Black] {
        let (mc, mi) = (MipMap::new(&constant, wrap), MipMap::new(&img, wrap));
        for &st in &st {
            // No footprint: exactly the full-resolution bilinear lookup.
            let bilinear = img.bilerp_wrapped(st, wrap);
            assert_eq!(mi.trilinear(st, Vec2::ZERO, Vec2::ZERO), bilinear, "{wrap:?} {st}");
            assert_eq!(mi.ewa(st, Vec2::ZERO, Vec2::ZERO, 8.0), bilinear, "{wrap:?} {st}");
            if wrap == WrapMode::Black {
                continue;
            }
            for &(d0, d1) in &footprints {
                let (t, e) = (mc.trilinear(st, d0, d1), mc.ewa(st, d0, d1, 8.0));
                assert!(
                    (t[0] - 0.61).abs() < 1e-5 && (e[0] - 0.61).abs() < 1e-5,
                    "{wrap:?} {st} {d0} {d1}: {t:?} {e:?}"
                );
            }
        }
    }
    // A footprint wider than the image is its mean (the last level's texel).
    let mi = MipMap::new(&img, WrapMode::Repeat);
    let mean = image_mean(&img) as f32;
    for f in [
        mi.trilinear(Vec2::splat(0.4), Vec2::new(2.0, 0.0), Vec2::new(0.0, 2.0)),
        mi.ewa(Vec2::splat(0.4), Vec2::new(4.0, 0.0), Vec2::new(0.0, 4.0), 8.0),
    ] {
        assert!((f[0] - mean).abs() < 1e-5, "{f:?} vs {mean}");
    }
}

#[test]
fn filtered_lookups_of_a_fine_checkerboard_are_its_mean_where_the_footprint_covers_many_checks() {
    // Checks of one texel, 0 and 1: a point lookup is 0 or 1, a footprint of a few texels or more is 1/2. EWA with
    // an anisotropic footprint (a grazing view: 16 texels along s, one along t) too.
    let img = grey_image(64, 64, |x, y| ((x + y) % 2) as f32);
    let mip = MipMap::new(&img, WrapMode::Repeat);
    let texel = 1.0 / 64.0;
    for i in 0..50 {
        let st = Vec2::new(noise(i, 1), noise(i, 2));
        for (d0, d1) in [
            (Vec2::new(4.0 * texel, 0.0), Vec2::new(0.0, 4.0 * texel)),
            (Vec2::new(16.0 * texel, 0.0), Vec2::new(0.0, texel)),
        ] {
            let t = mip.trilinear(st, d0, d1)[0];
            let e = mip.ewa(st, d0, d1, 8.0)[0];
            assert!((t - 0.5).abs() < 1e-6, "trilinear at {st}: {t}");
            assert!((e - 0.5).abs() < 0.05, "ewa at {st}: {e}");
        }
    }
}

#[test]
fn point_and_bilinear_lookups_read_the_level_the_footprint_picks() {
    // pbrt-v4: level ⌊n − 1 + log₂(2·max|∂|)⌋. A 64×64 checkerboard of one-texel checks (7 levels) is 0 or 1 in
    // level 0 and 1/2 in every level above it.
    let img = grey_image(64, 64, |x, y| ((x + y) % 2) as f32);
    let mip = MipMap::new(&img, WrapMode::Repeat);
    let texel = 1.0 / 64.0;
    let level_of =
        |d: f32| mip.bilinear(Vec2::new(0.25 + 0.3 * texel, 0.5 + 0.2 * texel), Vec2::new(d, 0.0), Vec2::ZERO)[0];
    for i in 0..50 {
        let st = Vec2::new(noise(i, 1), noise(i, 2));
        // No footprint, or one that keeps level 0 (width up to just under two texels): the full-resolution lookups.
        for d in [Vec2::ZERO, Vec2::new(0.45 * texel, 0.0), Vec2::new(0.0, 0.99 * texel)] {
            assert_eq!(mip.bilinear(st, d, Vec2::ZERO), img.bilerp_wrapped(st, WrapMode::Repeat), "{st} {d}");
            assert_eq!(mip.nearest(st, Vec2::ZERO, d), img.nearest(st, WrapMode::Repeat), "{st} {d}");
        }
        // Widths of two and eight texels: levels 1 and 3, all 1/2.
        for d in [texel, 4.0 * texel] {
            assert_eq!(mip.bilinear(st, Vec2::new(d, 0.0), Vec2::ZERO), [0.5; 3], "{st} {d}");
            assert_eq!(mip.nearest(st, Vec2::new(0.0, d), Vec2::new(-d, 0.0)), [0.5; 3], "{st} {d}");
        }
    }
    // Between levels there is no blend (unlike trilinear): just below width 2 texels it is level 0's value.
    let full = img.bilerp_wrapped(Vec2::new(0.25 + 0.3 * texel, 0.5 + 0.2 * texel), WrapMode::Repeat)[0];
    assert!((full - 0.5).abs() > 0.1, "{full}");
    assert_eq!(level_of(0.99 * texel), full);
    // A footprint as wide as the image reads the last level's single texel, the image's mean.
    let noisy = grey_image(16, 16, noise);
    let m = MipMap::new(&noisy, WrapMode::Repeat);
    let mean = image_mean(&noisy) as f32;
    for f in [
        m.bilinear(Vec2::splat(0.4), Vec2::new(0.5, 0.0), Vec2::ZERO),
        m.nearest(Vec2::splat(0.4), Vec2::ZERO, Vec2::new(0.0, 0.7)),
    ] {
        assert!((f[0] - mean).abs() < 1e-5, "{f:?} vs {mean}");
    }
}

#[test]
fn mappings_carry_the_footprint_into_texture_space() {
    let ctx = TextureEvalContext {
        p: Vec3::new(1.0, 2.0, 3.0),
        dpdx: Vec3::new(0.1, 0.0, 0.0),
        dpdy: Vec3::new(0.0, 0.2, 0.05),
        duv: [0.01, 0.02, 0.03, 0.04],
        ..TextureEvalContext::new(Vec3::new(1.0, 2.0, 3.0), Vec3::Z, Vec2::new(0.5, 0.25))
    };
    // uv: s = 2u + 1, t = 3v: (∂s/∂x, ∂t/∂x) = (2·0.01, 3·0.03).
    let c = TextureMapping2D::Uv(UvMapping { su: 2.0, sv: 3.0, du: 1.0, dv: 0.0 }).map_footprint(&ctx);
    assert_eq!(c.st, Vec2::new(2.0, 0.75));
    assert!((c.dst_dx - Vec2::new(0.02, 0.09)).length() < 1e-7 && (c.dst_dy - Vec2::new(0.04, 0.12)).length() < 1e-7);
    // Planar: s = p·v1, t = p·v2.
    let planar = TextureMapping2D::Planar {
        texture_from_render: Affine3A::IDENTITY,
        vs: Vec3::new(1.0, 1.0, 0.0),
        vt: Vec3::new(0.0, 0.0, 2.0),
        ds: 0.0,
        dt: 0.0,
    };
    let c = planar.map_footprint(&ctx);
    assert!((c.dst_dx - Vec2::new(0.1, 0.0)).length() < 1e-7 && (c.dst_dy - Vec2::new(0.2, 0.1)).length() < 1e-7);
    // Spherical and cylindrical: the derivatives are those of the mapping, by central differences.
    for map in [TextureMapping2D::Spherical(Affine3A::IDENTITY), TextureMapping2D::Cylindrical(Affine3A::IDENTITY)] {
        let c = map.map_footprint(&ctx);
        // f32 differences of step h: truncation O(h²), rounding ~1e-7/h; a swapped or wrong derivative is off by
        // far more than 1%.
        let h = 1e-2;
        let at = |p: Vec3| map.map(&TextureEvalContext::new(p, Vec3::Z, Vec2::ZERO));
        for (dp, got) in [(ctx.dpdx, c.dst_dx), (ctx.dpdy, c.dst_dy)] {
            let want = (at(ctx.p + dp * h) - at(ctx.p - dp * h)) / (2.0 * h);
            assert!((got - want).length() < 1e-2 * want.length(), "{map:?}: {got} vs {want}");
        }
    }
}

/// glTF's wrap modes per axis: mirrored repeat reflects about each edge (texel −1 is texel 0, texel n is n − 1),
/// clamp holds the edge texel, repeat tiles; s and t wrap independently.
#[test]
fn per_axis_wrap_modes_mirror_clamp_and_repeat() {
    let (m, c, r) = (AxisWrap::Mirror, AxisWrap::Clamp, AxisWrap::Repeat);
    let mirrored: Vec<i64> = (-5..9).map(|i| m.wrap(i, 3)).collect();
    assert_eq!(mirrored, vec![1, 2, 2, 1, 0, 0, 1, 2, 2, 1, 0, 0, 1, 2]);
    assert_eq!((-2..5).map(|i| c.wrap(i, 3)).collect::<Vec<_>>(), vec![0, 0, 0, 1, 2, 2, 2]);
    assert_eq!((-2..5).map(|i| r.wrap(i, 3)).collect::<Vec<_>>(), vec![1, 2, 0, 1, 2, 0, 1]);
    // A 2×2 image read at texel (3, −1): mirrored along s (→ 0), clamped along t (→ row 0).
    let img = RgbImage::new(2, 2, vec![[1.0; 3], [2.0; 3], [3.0; 3], [4.0; 3]]);
    assert_eq!(img.texel(3, -1, WrapMode::Axes(m, c)), [1.0; 3]);
    assert_eq!(img.texel(3, 2, WrapMode::Axes(r, m)), [4.0; 3]);
}

/// The `uvtransform` mapping is the affine map it names, and its footprint is the map's linear part applied to
/// the surface's (u, v) derivatives.
#[test]
fn the_uv_matrix_mapping_maps_points_and_footprints() {
    let m = TextureMapping2D::UvMatrix([0.0, -2.0, 0.5, 3.0, 0.0, -1.0]);
    let ctx = TextureEvalContext { duv: [0.1, 0.2, 0.3, 0.4], ..at_uv(0.25, 0.5) };
    assert_eq!(m.map(&ctx), Vec2::new(-0.5, -0.25));
    let f = m.map_footprint(&ctx);
    // ∂s/∂x = −2·∂v/∂x, ∂t/∂x = 3·∂u/∂x; likewise in y.
    assert!(
        (f.dst_dx - Vec2::new(-0.6, 0.3)).length() < 1e-6 && (f.dst_dy - Vec2::new(-0.8, 0.6)).length() < 1e-6,
        "{f:?}"
    );
}

/// `threshold` is 1 at and above the cutoff, 0 below (glTF's MASK).
#[test]
fn threshold_keeps_values_at_or_above_the_cutoff() {
    let t = |v: f32| {
        FloatTexture::Threshold { tex: Box::new(FloatTexture::Constant(v)), cutoff: 0.5 }.eval(&at_uv(0.0, 0.0))
    };
    assert_eq!([t(0.49), t(0.5), t(0.9)], [0.0, 1.0, 1.0]);
}

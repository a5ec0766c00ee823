//! pbrt-v4's textures, image-texture encodings and bump maps, end to end: pbrt text → `build_scene` → render.
//!
//! - every texture class and mapping builds from pbrt text without warnings, and bad parameters are errors naming
//!   the parameter with file:line:column (`ptex` names the texture);
//! - an 8-bit image read as sRGB (PNG's default), linear or gamma 3 gives a diffuse plane under a uniform sky the
//!   albedo that reading of the byte means;
//! - a bumped diffuse plane under a uniform sky keeps its albedo (a Lambertian surface reflects ρ·L whatever its
//!   shading normal), with every integrator that renders it, while under a low sun the bumps do show.

use std::path::PathBuf;

use film::Film;
use render::BuiltScene;

mod support;
use support::{build, build_error};

fn render(built: &BuiltScene, seed: u32) -> Film {
    let mut film = Film::new(built.film.clone()).unwrap();
    built.integrator.render(&built.scene, &mut film, 0..built.spp, seed, &|_| {}).unwrap();
    film
}

/// Luminance Y of every pixel.
fn pixel_y(film: &Film) -> Vec<f64> {
    let mut v = vec![];
    for y in 0..film.height() {
        for x in 0..film.width() {
            let l = film.pixel_xyz(x, y).to_array()[1];
            assert!(l.is_finite(), "pixel ({x}, {y}): {l}");
            v.push(l);
        }
    }
    v
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

fn std_dev(v: &[f64]) -> f64 {
    let m = mean(v);
    (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / v.len() as f64).sqrt()
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("prismatic-textures-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The square [−1, 1]² in z = 0 as one bilinear patch with u along +y and v along +x, so that its geometric normal
/// ∂p/∂u × ∂p/∂v is −z, towards the camera.
const PLANE: &str =
    "Shape \"bilinearmesh\" \"point3 P\" [ -1 -1 0  -1 1 0  1 -1 0  1 1 0 ] \"integer indices\" [ 0 1 2 3 ]\n";

/// The plane filling the view of a camera 5 units in front of it, under `light`, with `defs` (textures, from line 9
/// on) and `material`.
fn plane_scene(integrator: &str, light: &str, defs: &str, material: &str, res: u32, spp: u32) -> String {
    format!(
        "LookAt 0 0 -5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 22\n\
         Film \"rgb\" \"integer xresolution\" {res} \"integer yresolution\" {res}\nPixelFilter \"box\"\n\
         Sampler \"zsobol\" \"integer pixelsamples\" {spp}\nIntegrator \"{integrator}\" \"integer maxdepth\" 3\n\
         WorldBegin\n{light}\n{defs}\n{material}\n{PLANE}"
    )
}

const SKY: &str = "LightSource \"infinite\" \"rgb L\" [ 1 1 1 ]";

#[test]
fn every_texture_class_and_mapping_builds() {
    let defs = r#"
Texture "c" "float" "constant" "float value" 0.3
Texture "sc" "float" "scale" "texture tex" "c" "float scale" 2
Texture "dm" "float" "directionmix" "texture tex1" "c" "float tex2" 0.1 "vector3 dir" [ 0 0 1 ]
Texture "bl" "float" "bilerp" "float v00" 0.1 "float v01" 0.2 "float v10" 0.3 "float v11" 0.4 "string mapping" "spherical"
Texture "ch3" "float" "checkerboard" "integer dimension" 3 "texture tex1" "bl" "float tex2" 0.2
Texture "dots" "float" "dots" "string mapping" "planar" "vector3 v1" [ 4 0 0 ] "vector3 v2" [ 0 4 0 ] "float udelta" 0.5
Texture "fbm" "float" "fbm" "integer octaves" 4 "float roughness" 0.6
Texture "wr" "float" "wrinkled"
Texture "wi" "float" "windy"
Texture "mx" "float" "mix" "texture tex1" "fbm" "texture tex2" "wr" "texture amount" "wi"
Texture "rough" "float" "scale" "texture tex" "mx" "float scale" 0.1
Texture "marble" "spectrum" "marble" "float scale" 3 "float variation" 0.4
Texture "cyl" "spectrum" "checkerboard" "string mapping" "cylindrical" "texture tex1" "marble" "rgb tex2" [ 0.2 0.3 0.4 ]
Texture "sb" "spectrum" "bilerp" "rgb v00" [ 0.1 0.2 0.3 ] "rgb v11" [ 0.5 0.5 0.5 ] "string mapping" "uv" "float uscale" 2
Texture "sd" "spectrum" "dots" "texture inside" "cyl" "texture outside" "sb"
Texture "smix" "spectrum" "mix" "texture tex1" "sd" "rgb tex2" [ 0.4 0.4 0.4 ] "texture amount" "ch3"
Texture "sdm" "spectrum" "directionmix" "texture tex1" "smix" "texture tex2" "marble" "vector3 dir" [ 1 0 0 ]
Texture "albedo" "spectrum" "scale" "texture tex" "sdm" "texture scale" "dots"
"#;
    let material = r#"Material "coateddiffuse" "texture reflectance" "albedo" "texture roughness" "rough" "texture displacement" "sc""#;
    let built = build(&plane_scene("path", SKY, defs, material, 8, 4), "classes.pbrt");
    let y = pixel_y(&render(&built, 1));
    // A coat over an albedo of at most 1 under a sky of 1 reflects at most 1 (4 samples per pixel: some noise).
    assert!(y.iter().all(|&v| (0.0..1.5).contains(&v)) && mean(&y) < 1.0, "{y:?}");
    assert!(std_dev(&y) > 0.0, "textures vary over the plane");
}

#[test]
fn bad_texture_parameters_are_errors_naming_them() {
    let cases: &[(&str, &str)] = &[
        (r#"Texture "t" "float" "imagemap" "string filename" "x.png" "string wrap" "spiral""#, "'spiral'"),
        (r#"Texture "t" "float" "imagemap" "string filename" "x.png" "string wrap" [ "clamp" "black" ]"#, "'black'"),
        (r#"Texture "t" "float" "imagemap" "string filename" "x.png" "string wrap" [ "a" "b" "c" ]"#, "not 3"),
        (r#"Texture "t" "float" "imagemap" "string filename" "x.png" "string channel" "q""#, "'q'"),
        (r#"Texture "t" "float" "imagemap" "integer image" 0"#, "no embedded image 0"),
        (r#"Texture "t" "float" "imagemap" "integer image" -2"#, "'image'"),
        (r#"Texture "t" "float" "imagemap" "string filename" "x.png" "integer image" 0"#, "not both"),
        (r#"Texture "t" "float" "imagemap" "string filename" "x.png" "float uvtransform" [ 1 0 0 0 1 ]"#, "six"),
        (
            r#"Texture "t" "float" "imagemap" "string filename" "x.png" "float uvtransform" [ 1 0 0 0 1 0 ] "float uscale" 2"#,
            "not both",
        ),
        (r#"Texture "t" "spectrum" "imagemap" "string filename" "x.png" "rgb tint" [ 1 1 ]"#, "rgb tint"),
        (r#"Texture "t" "float" "threshold" "float cutoff" 1e40"#, "'cutoff'"),
        (r#"Texture "t" "float" "imagemap" "string filename" "x.png" "string filter" "gauss""#, "'gauss'"),
        (r#"Texture "t" "float" "imagemap" "string filename" "x.png" "string encoding" "gamma -1""#, "'encoding'"),
        (r#"Texture "t" "float" "imagemap" "string filename" "x.png" "float maxanisotropy" 0"#, "'maxanisotropy'"),
        (r#"Texture "t" "float" "imagemap""#, "'string filename'"),
        (r#"Texture "t" "float" "fbm" "integer octaves" 40"#, "'octaves'"),
        (r#"Texture "t" "float" "wrinkled" "float roughness" 1e40"#, "'roughness'"),
        (r#"Texture "t" "float" "checkerboard" "integer dimension" 4"#, "'dimension'"),
        (r#"Texture "t" "float" "bilerp" "string mapping" "toroidal""#, "'toroidal'"),
        (r#"Texture "t" "spectrum" "dots" "string mapping" "planar" "vector3 v1" [ 1e39 0 0 ]"#, "'v1'"),
        (r#"Texture "t" "float" "directionmix" "vector3 dir" [ 0 0 0 ]"#, "'dir'"),
        (r#"Texture "t" "float" "scale" "texture tex" "nothing""#, "no texture named 'nothing'"),
        (r#"Texture "t" "spectrum" "vertexcolor" "rgb tint" [ 1 -1 0 ]"#, "'tint'"),
        (r#"Texture "c" "spectrum" "checkerboard" Texture "t" "spectrum" "vertexcolor" "texture tex" "c""#, "'tex'"),
    ];
    for (i, (def, needle)) in cases.iter().enumerate() {
        let name = format!("bad{i}.pbrt");
        let e = build_error(&plane_scene("path", SKY, def, r#"Material "diffuse""#, 4, 1), &name);
        assert!(e.contains(needle) && e.contains(&format!("{name}:9:")), "{def}: {e}");
    }
    let e = build_error(&plane_scene("path", SKY, r#"Texture "skin" "spectrum" "ptex""#, "", 4, 1), "ptex.pbrt");
    assert!(e.contains("'skin'") && e.contains("ptex") && e.contains("ptex.pbrt:9:"), "{e}");
}

#[test]
fn image_encoding_decides_what_an_8_bit_value_means() {
    // A 4×4 PNG whose every byte is 128 (written sRGB-encoded: 128/255 + 1e-7, which the dither cannot move).
    let dir = temp_dir("encoding");
    let png = dir.join("grey.png");
    let linear = spectral::color::srgb_decode(128.0 / 255.0 + 1e-7) as f32;
    film::write_rgb(&png, 4, 4, &[[linear; 3]; 16]).unwrap();
    let bytes = film::read_rgb_encoded(&png, film::ColorEncoding::Linear).unwrap().2;
    assert!(bytes.iter().all(|p| p.iter().all(|&v| v == 128.0 / 255.0)), "every byte is 128");
    let v: f64 = 128.0 / 255.0;
    for (encoding, albedo) in [
        ("", spectral::color::srgb_decode(v)),
        (r#""string encoding" "sRGB""#, spectral::color::srgb_decode(v)),
        (r#""string encoding" "linear""#, v),
        (r#""string encoding" "gamma 3""#, v.powi(3)),
    ] {
        let defs = format!(r#"Texture "img" "spectrum" "imagemap" "string filename" "{}" {encoding}"#, png.display());
        let built = build(
            &plane_scene("path", SKY, &defs, r#"Material "diffuse" "texture reflectance" "img""#, 8, 64),
            "encoding.pbrt",
        );
        let y = mean(&pixel_y(&render(&built, 2)));
        // A grey diffuse plane under a uniform sky of luminance 1 has luminance ρ.
        assert!((y - albedo).abs() < 0.02 * albedo, "{encoding}: Y {y}, expected {albedo}");
    }
    // A TGA of the same bytes is sRGB-decoded whatever the encoding says, as pbrt-v4 reads it (through stb_image,
    // tagged sRGB): measured there on staircase's WoodFloor.tga under a white sky, where "linear" would be 1.5–3.4
    // times too bright. An uncompressed 24-bit TGA: 18-byte header (image type 2, 4×4, 24 bits), then BGR bytes.
    let tga = dir.join("grey.tga");
    let mut bytes = vec![0u8, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 4, 0, 4, 0, 24, 0];
    bytes.extend([128u8; 48]);
    std::fs::write(&tga, bytes).unwrap();
    for encoding in ["", r#""string encoding" "linear""#, r#""string encoding" "gamma 3""#] {
        let defs = format!(r#"Texture "img" "spectrum" "imagemap" "string filename" "{}" {encoding}"#, tga.display());
        let built = build(
            &plane_scene("path", SKY, &defs, r#"Material "diffuse" "texture reflectance" "img""#, 8, 64),
            "encoding.pbrt",
        );
        let y = mean(&pixel_y(&render(&built, 2)));
        let albedo = spectral::color::srgb_decode(v);
        assert!((y - albedo).abs() < 0.02 * albedo, "TGA {encoding}: Y {y}, expected {albedo}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bumped_diffuse_plane_keeps_its_albedo_under_a_uniform_sky() {
    // fBm ripples about 0.2 units across (texture space scaled by 5), displaced by up to ~0.05: slopes of tens of
    // degrees.
    let defs = "AttributeBegin\nScale 0.2 0.2 0.2\nTexture \"ripples\" \"float\" \"fbm\" \"integer octaves\" 4\n\
                AttributeEnd\nTexture \"bumps\" \"float\" \"scale\" \"texture tex\" \"ripples\" \"float scale\" 0.05";
    let bumped = r#"Material "diffuse" "rgb reflectance" [ 0.5 0.5 0.5 ] "texture displacement" "bumps""#;
    let flat = r#"Material "diffuse" "rgb reflectance" [ 0.5 0.5 0.5 ]"#;
    for integrator in ["path", "volpath", "bdpt"] {
        let y_bumped = pixel_y(&render(&build(&plane_scene(integrator, SKY, defs, bumped, 8, 64), "b.pbrt"), 3));
        let y_flat = pixel_y(&render(&build(&plane_scene(integrator, SKY, defs, flat, 8, 64), "f.pbrt"), 3));
        // The estimate is exactly ρ·L in expectation whatever the shading normal; 4096 samples per image.
        let (mb, mf) = (mean(&y_bumped), mean(&y_flat));
        assert!((mb - 0.5).abs() < 0.01 && (mf - 0.5).abs() < 0.01, "{integrator}: bumped {mb}, flat {mf}");
    }
    // Under a low sun the bumps show: the flat plane is uniform but for the colour noise of the sampled wavelengths,
    // the bumped one varies from pixel to pixel far more.
    let sun = "LightSource \"distant\" \"point3 from\" [ 3 0 -1 ] \"point3 to\" [ 0 0 0 ] \"rgb L\" [ 3 3 3 ]";
    let y_bumped = pixel_y(&render(&build(&plane_scene("path", sun, defs, bumped, 8, 16), "sb.pbrt"), 4));
    let y_flat = pixel_y(&render(&build(&plane_scene("path", sun, defs, flat, 8, 16), "sf.pbrt"), 4));
    let (rel_b, rel_f) = (std_dev(&y_bumped) / mean(&y_bumped), std_dev(&y_flat) / mean(&y_flat));
    assert!(rel_b > 0.1 && rel_b > 5.0 * rel_f, "relative spread: flat {rel_f}, bumped {rel_b}");
}

#[test]
fn normal_map_tilts_the_shading_normal() {
    // A uniform normal map (255, 128, 255), read linearly: local normal (1, 2·128/255 − 1, 1), leaning 45° along
    // ∂p/∂u. The plane's shading frame is x = ∂p/∂u = +y, y = ns × x = +x, z = ns = −z, so the mapped normal is
    // (g, 1, −1)/|…| with g = 2·128/255 − 1. Under a sun 60° off the plane's normal on the +y side, the cosine law
    // gives the ratio of the mapped plane's radiance to the flat one's exactly (direct light only).
    let dir = temp_dir("normalmap");
    let png = dir.join("tilt.png");
    let half = spectral::color::srgb_decode(128.0 / 255.0 + 1e-7) as f32;
    film::write_rgb(&png, 2, 2, &[[1.0, half, 1.0]; 4]).unwrap();
    let sun = "LightSource \"distant\" \"point3 from\" [ 0 1.7320508 -1 ] \"point3 to\" [ 0 0 0 ] \"rgb L\" [ 1 1 1 ]";
    let flat = r#"Material "diffuse" "rgb reflectance" [ 0.5 0.5 0.5 ]"#;
    let mapped =
        format!(r#"Material "diffuse" "rgb reflectance" [ 0.5 0.5 0.5 ] "string normalmap" "{}""#, png.display());
    let y_flat = mean(&pixel_y(&render(&build(&plane_scene("path", sun, "", flat, 4, 16), "nf.pbrt"), 5)));
    let y_map = mean(&pixel_y(&render(&build(&plane_scene("path", sun, "", &mapped, 4, 16), "nm.pbrt"), 5)));
    let g = 2.0 * 128.0 / 255.0 - 1.0;
    let n = glam::DVec3::new(g, 1.0, -1.0).normalize();
    let to_sun = glam::DVec3::new(0.0, 3f64.sqrt(), -1.0).normalize();
    let expect = n.dot(to_sun) / 0.5;
    assert!((y_map / y_flat - expect).abs() < 0.01 * expect, "ratio {} expected {expect}", y_map / y_flat);
    std::fs::remove_dir_all(&dir).ok();
}

/// A floor checkered with one-texel checks of 0 and 1 (a 64×64 image repeated 100 times over 400 units), seen at
/// grazing angles from a camera one unit above it: far away a pixel covers tens to thousands of checks. Filtered
/// over the rays' footprints (`trilinear`, `ewa`), or read in the MIP level the footprint picks (`bilinear`,
/// `point`), each far pixel's albedo is the checks' mean 1/2, as on a floor of constant reflectance 1/2 rendered
/// with the same samples (the albedo is the gbuffer's, the first hit's reflectance, which has the wavelength
/// sampling's noise but no lighting noise).
#[test]
fn filtered_image_textures_average_a_fine_checkerboard_at_grazing_angles() {
    let dir = temp_dir("grazing");
    let path = dir.join("checks.pfm");
    let checks: Vec<[f32; 3]> = (0..64 * 64).map(|i| [((i % 64 + i / 64) % 2) as f32; 3]).collect();
    film::write_rgb(&path, 64, 64, &checks).unwrap();
    // The far pixels' albedo (G) with the floor's material `material` after texture definitions `defs`.
    let far_albedos = |defs: &str, material: &str| {
        let text = format!(
            "LookAt 0 1 0  0 0 10  0 1 0\nCamera \"perspective\" \"float fov\" 30\n\
             Film \"gbuffer\" \"integer xresolution\" 32 \"integer yresolution\" 16 \"string filename\" \"g.exr\"\n\
             PixelFilter \"box\"\nSampler \"zsobol\" \"integer pixelsamples\" 16\n\
             Integrator \"path\" \"integer maxdepth\" 1\nWorldBegin\n{SKY}\n{defs}\n{material}\n\
             Shape \"bilinearmesh\" \"point3 P\" [ -200 0 0  200 0 0  -200 0 400  200 0 400 ]\n"
        );
        let film = render(&build(&text, "grazing.pbrt"), 1);
        let albedo = film.to_aov_images().unwrap().albedo;
        let mut far = vec![];
        for y in 0..film.height() {
            for x in 0..film.width() {
                let g = film.pixel_gbuffer(x, y).unwrap();
                // Depths of 8 to 200 units: every sample of the pixel sees the floor, many checks away.
                if g.count >= 16.0 && (8.0..200.0).contains(&g.p[2]) {
                    far.push(albedo[(y * film.width() + x) as usize][1] as f64);
                }
            }
        }
        far
    };
    let reference = far_albedos("", "Material \"diffuse\" \"rgb reflectance\" [ 0.5 0.5 0.5 ]");
    assert!(reference.len() >= 64, "{} far pixels", reference.len());
    let textured = |filter: &str| {
        let defs = format!(
            "Texture \"checks\" \"spectrum\" \"imagemap\" \"string filename\" \"{}\" \"string filter\" \"{filter}\"\n\
               \"float uscale\" 100 \"float vscale\" 100",
            path.display()
        );
        far_albedos(&defs, "Material \"diffuse\" \"texture reflectance\" \"checks\"")
    };
    // Each far pixel's difference from the constant floor's.
    let differences = |far: &[f64]| far.iter().zip(&reference).map(|(a, b)| a - b).collect::<Vec<f64>>();
    // Trilinear: these footprints span more than a texel, where the MIP levels of one-texel checks are exactly 1/2.
    let d = differences(&textured("trilinear"));
    assert!(d.iter().all(|v| v.abs() < 1e-4), "trilinear: {d:?}");
    // EWA: a Gaussian-weighted mean over an ellipse of a few texels across (the footprint's minor axis, from 1/4
    // of a pixel at 16 spp), close to 1/2.
    let d = differences(&textured("ewa"));
    assert!(d.iter().all(|v| v.abs() < 0.03) && mean(&d).abs() < 0.005, "ewa: {d:?}");
    // Bilinear and point: one lookup per sample in the level the footprint picks (pbrt-v4's ⌊level⌋), here level 1
    // or above, whose texels are all 1/2. (Read in the full-resolution image instead, a bilinear lookup would be
    // 1/2 + (1 − 2f)(1 − 2g)/2 between the nearest texel centres, of standard deviation 1/24 ≈ 0.042 over 16
    // samples: aliased.)
    for filter in ["bilinear", "point"] {
        let d = differences(&textured(filter));
        assert!(d.iter().all(|v| v.abs() < 1e-4), "{filter}: {d:?}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

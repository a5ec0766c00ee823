//! What the builder makes of pbrt-v4 text, looked at inside the render-ready scene: parameters the renders of the
//! command's tests see only through their images.

use std::path::Path;

use crate::medium::Medium;
use crate::scene::NO_MATERIAL;
use crate::{build_scene, BuildOptions, BuiltScene};

/// The scene `text` read as the file `name` (for its messages) and built with no warnings.
fn build(text: &str, name: &str) -> BuiltScene {
    let desc = pbrt::parse_str(text, Path::new(name)).unwrap_or_else(|e| panic!("{e}"));
    let built = build_scene(&desc, &BuildOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert!(built.warnings.is_empty(), "{name}: {:#?}", built.warnings);
    built
}

/// A sphere of `material` under a uniform sky.
fn subsurface_scene(material: &str) -> String {
    format!(
        "LookAt 0 0 -3.2  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 30\n\
         Film \"rgb\" \"integer xresolution\" 12 \"integer yresolution\" 12 \"string filename\" \"x.exr\"\n\
         Integrator \"volpath\"\nWorldBegin\nLightSource \"infinite\" \"spectrum L\" [ 360 1 830 1 ]\n\
         AttributeBegin\n{material}\nShape \"sphere\" \"float radius\" 1\nAttributeEnd\n"
    )
}

/// The subsurface material's coefficients, from each of the four ways pbrt-v4 lets a scene give them.
#[test]
fn the_four_ways_of_giving_coefficients() {
    let sigma = |material: &str| {
        let built = build(&subsurface_scene(material), "sss.pbrt");
        let m = built.scene.media.last().cloned().expect("the subsurface medium");
        let Medium::Homogeneous(h) = m else { panic!("homogeneous") };
        (h.sigma_a.eval(550.0), h.sigma_s.eval(550.0))
    };
    // A measured medium: pbrt-v4's Skin1 (σ's 0.74, 0.88, 1.01; σa 0.032, 0.17, 0.48 mm⁻¹), times scale.
    let (a, s) = sigma("Material \"subsurface\" \"string name\" \"Skin1\" \"float scale\" 10");
    assert!(a > 0.32 && a < 4.8 && s > 7.4 && s < 10.1, "{a} {s}");
    // Directly.
    let (a, s) = sigma(
        "Material \"subsurface\" \"spectrum sigma_a\" [ 360 0.25 830 0.25 ] \"spectrum sigma_s\" [ 360 3 830 3 ]",
    );
    assert!((a - 0.25).abs() < 1e-6 && (s - 3.0).abs() < 1e-6);
    // Reflectance and mean free path: σt = 1/mfp, and the albedo reflects the reflectance (dipole model).
    let (a, s) = sigma(
        "Material \"subsurface\" \"spectrum reflectance\" [ 360 0.5 830 0.5 ] \"spectrum mfp\" [ 360 0.25 830 0.25 ]",
    );
    assert!(((a + s) - 4.0).abs() < 1e-6 && s / (a + s) > 0.9 && s / (a + s) < 1.0, "{a} {s}");
    // pbrt-v4's defaults (σa 0.0011, 0.0024, 0.014; σs 2.55, 3.21, 3.77).
    let (a, s) = sigma("Material \"subsurface\"");
    assert!(a > 0.0011 && a < 0.014 && s > 2.55 && s < 3.77, "{a} {s}");
}

/// Only hits on materials that read an image map compute footprints: a material with an image map (directly, or
/// through a scale texture and a named texture), a mix that may pick one, or whose amount is one, and a bump-mapped
/// material; not a plain diffuse, a checkerboard or a mix of plain materials.
#[test]
fn footprints_are_computed_for_materials_that_read_image_maps_or_bump_only() {
    let dir = std::env::temp_dir().join(format!("render-builder-{}-reads-footprint", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("img.pfm");
    film::write_rgb(&path, 2, 2, &[[0.5; 3]; 4]).unwrap();
    let text = format!(
        "Camera \"perspective\"\nFilm \"rgb\" \"integer xresolution\" 4 \"integer yresolution\" 4\nWorldBegin\n\
         Texture \"img\" \"spectrum\" \"imagemap\" \"string filename\" \"{img}\"\n\
         Texture \"scaled\" \"spectrum\" \"scale\" \"texture tex\" \"img\" \"float scale\" 0.5\n\
         Texture \"amount\" \"float\" \"imagemap\" \"string filename\" \"{img}\"\n\
         Texture \"checks\" \"spectrum\" \"checkerboard\"\n\
         MakeNamedMaterial \"imaged\" \"string type\" \"diffuse\" \"texture reflectance\" \"scaled\"\n\
         MakeNamedMaterial \"plain\" \"string type\" \"diffuse\"\n\
         MakeNamedMaterial \"checked\" \"string type\" \"diffuse\" \"texture reflectance\" \"checks\"\n\
         MakeNamedMaterial \"mix-imaged\" \"string type\" \"mix\" \"string materials\" [ \"plain\" \"imaged\" ]\n\
         MakeNamedMaterial \"mix-plain\" \"string type\" \"mix\" \"string materials\" [ \"plain\" \"checked\" ]\n\
         MakeNamedMaterial \"mix-amount\" \"string type\" \"mix\" \"string materials\" [ \"plain\" \"checked\" ] \
         \"texture amount\" \"amount\"\n\
         MakeNamedMaterial \"mix-of-mix\" \"string type\" \"mix\" \"string materials\" [ \"mix-plain\" \"mix-imaged\" ]\n\
         Texture \"ripples\" \"float\" \"wrinkled\"\n\
         MakeNamedMaterial \"bumped\" \"string type\" \"diffuse\" \"texture displacement\" \"ripples\"\n\
         NamedMaterial \"plain\"\nShape \"sphere\"\n",
        img = path.display()
    );
    let built = build(&text, "reads-footprint.pbrt");
    let scene = &built.scene;
    assert!(scene.footprints.is_some());
    // Named materials follow the anonymous one (the default diffuse), in the order they were made.
    // A bump map steps by half the footprint whatever its texture (pbrt-v4's `BumpMap`), so it reads it too.
    let expected = [false, true, false, false, true, false, true, true, true];
    assert_eq!(scene.material_reads_footprint, expected);
    for (i, &e) in expected.iter().enumerate() {
        assert_eq!(scene.reads_footprint(i as u32), e, "material {i}");
    }
    assert!(!scene.reads_footprint(NO_MATERIAL));
    std::fs::remove_dir_all(&dir).ok();
}

/// A study's scene: a named material on a sphere over a floor, a light, `edit` at the end of the world block.
fn study_scene(material: &str, light: &str, integrator: &str) -> String {
    format!(
        "LookAt 0 1 -4  0 0.5 0  0 1 0\nCamera \"perspective\" \"float fov\" 40\n\
         Film \"rgb\" \"integer xresolution\" 16 \"integer yresolution\" 12 \"string filename\" \"x.exr\"\n\
         Sampler \"zsobol\" \"integer pixelsamples\" 4\nIntegrator {integrator}\nWorldBegin\n{light}\n\
         MakeNamedMaterial \"ball\" {material}\n\
         AttributeBegin\nNamedMaterial \"ball\"\nTranslate 0 0.5 0\nShape \"sphere\" \"float radius\" 0.5\nAttributeEnd\n\
         AttributeBegin\nAreaLightSource \"diffuse\" \"blackbody L\" 4000\nTranslate 0 3 0\nRotate 90 1 0 0\n\
         Shape \"disk\" \"float radius\" 0.3\nAttributeEnd\n\
         Shape \"trianglemesh\" \"point3 P\" [ -5 0 -5  5 0 -5  5 0 5  -5 0 5 ] \"integer indices\" [ 0 1 2  0 2 3 ]\n"
    )
}

/// A build reusing an earlier one's shapes (another material, light, integrator or resolution) shares its BVH and
/// renders exactly the image of a build from scratch; a change the BVH records (a material that becomes an
/// `interface`) builds the shapes again.
#[test]
fn a_build_reusing_shapes_renders_what_a_fresh_build_renders() {
    let parse = |text: &str| pbrt::parse_str(text, Path::new("study.pbrt")).unwrap_or_else(|e| panic!("{e}"));
    let glass = "\"string type\" \"dielectric\" \"spectrum eta\" \"glass-BK7\"";
    let sun = "LightSource \"distant\" \"point3 from\" [ 1 4 -2 ] \"blackbody L\" 5500";
    let first = build_scene(&parse(&study_scene(glass, sun, "\"path\"")), &BuildOptions::default()).unwrap();
    assert!(first.built_shapes());
    let variants = [
        (study_scene("\"string type\" \"dielectric\" \"spectrum eta\" \"glass-F11\"", sun, "\"path\""), None),
        (study_scene("\"string type\" \"diffuse\" \"rgb reflectance\" [ 0.8 0.2 0.1 ]", sun, "\"path\""), None),
        (study_scene(glass, "LightSource \"point\" \"point3 from\" [ 1 2 -1 ] \"blackbody I\" 3000", "\"path\""), None),
        (study_scene(glass, sun, "\"volpath\" \"integer maxdepth\" 3"), Some((24, 10))),
    ];
    for (text, resolution) in &variants {
        let desc = parse(text);
        let options = BuildOptions { resolution: *resolution, ..Default::default() };
        let reused = crate::build_scene_reusing(&desc, &options, &first).unwrap_or_else(|e| panic!("{e}"));
        assert!(!reused.built_shapes(), "{text}");
        assert!(std::sync::Arc::ptr_eq(&reused.scene.geometry, &first.scene.geometry));
        let fresh = build_scene(&desc, &options).unwrap();
        assert!(reused.warnings.is_empty() && fresh.warnings.is_empty(), "{:?} {:?}", reused.warnings, fresh.warnings);
        let rows = 0..reused.film.height;
        let (a, b) = (super::support::mean_y(&reused, 1, rows.clone()), super::support::mean_y(&fresh, 1, rows));
        assert!(a > 0.0 && a == b, "{text}: reused {a}, fresh {b}");
    }
    // The glass image differs from the F11 one (the edit reached the render).
    let glass_y = super::support::mean_y(&first, 1, 0..12);
    let f11 = parse(&variants[0].0);
    let f11_y =
        super::support::mean_y(&crate::build_scene_reusing(&f11, &BuildOptions::default(), &first).unwrap(), 1, 0..12);
    assert_ne!(glass_y, f11_y);
    // An interface material is recorded in the BVH as no material: the shapes are built again.
    let desc = parse(&study_scene("\"string type\" \"interface\"", sun, "\"path\""));
    let rebuilt = crate::build_scene_reusing(&desc, &BuildOptions::default(), &first).unwrap();
    assert!(rebuilt.built_shapes());
    let fresh = build_scene(&desc, &BuildOptions::default()).unwrap();
    assert_eq!(super::support::mean_y(&rebuilt, 1, 0..12), super::support::mean_y(&fresh, 1, 0..12));
}

/// pbrt-v4's per-vertex tangents `S` on a triangle mesh: one per vertex builds, another count is an error naming `S`
/// at its file, line and column.
#[test]
fn triangle_mesh_tangents_are_checked() {
    let scene = |s: &str| {
        format!(
            "Camera \"perspective\"\nFilm \"rgb\" \"integer xresolution\" 4 \"integer yresolution\" 4\nWorldBegin\n\
             Shape \"trianglemesh\" \"point3 P\" [ 0 0 0  1 0 0  0 1 0 ] \"normal N\" [ 0 0 1  0 0 1  0 0 1 ]\n\
             \"vector3 S\" [ {s} ]\n"
        )
    };
    build(&scene("1 0 0  1 0 0  0 1 0"), "tangents.pbrt");
    let desc = pbrt::parse_str(&scene("1 0 0"), Path::new("tangents.pbrt")).unwrap_or_else(|e| panic!("{e}"));
    let e = build_scene(&desc, &BuildOptions::default()).err().expect("an error").to_string();
    assert!(e.contains("'S' has 1 tangents for 3 vertices") && e.contains("tangents.pbrt:5:"), "{e}");
}

//! The real pbrt-v4 scenes in `tests/fixtures` parse unchanged and give what pbrt-v4 would build.

use std::path::{Path, PathBuf};

use geometry::Transform;
use glam::DVec3;
use scene::{MaterialRef, SpectrumKind, TextureValueType};

fn fixture(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures").join(p)
}

fn close(a: DVec3, b: DVec3) -> bool {
    (a - b).length() < 1e-6 * (1.0 + b.length())
}

#[test]
fn cornell_box() {
    let s = pbrt::parse_file(&fixture("cornell-box/cornell-box.pbrt")).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert_eq!(s.camera.entity.name, "perspective");
    assert_eq!(s.camera.entity.params.get_float("fov", 90.0).unwrap(), 37.5);
    // LookAt 278 273 -800  278 273 0  0 1 0: the target lies 800 units down camera +z.
    let c = s.camera.camera_from_world;
    assert!(close(c.point(DVec3::new(278.0, 273.0, 0.0)), DVec3::new(0.0, 0.0, 800.0)));
    assert!(close(c.point(DVec3::new(278.0, 274.0, -800.0)), DVec3::new(0.0, 1.0, 0.0)));
    assert_eq!(s.film.name, "rgb");
    assert_eq!(s.film.params.get_int("xresolution", 1280).unwrap(), 1080);
    assert_eq!(s.film.params.get_int("yresolution", 720).unwrap(), 1080);
    assert_eq!(s.film.params.get_string("filename", "pbrt.exr").unwrap(), "cornell-box.png");
    assert_eq!(s.integrator.name, "path");
    assert_eq!((s.sampler.name.as_str(), s.filter.name.as_str()), ("zsobol", "gaussian"));
    assert!(s.sampler.loc.is_builtin());

    assert_eq!(s.shapes.len(), 8);
    assert_eq!(s.materials.len(), 4, "default diffuse + grey + red + green");
    assert_eq!(s.materials[0].name, "diffuse");
    assert!(s.materials[0].params.is_empty());
    let lights: Vec<_> = s.shapes.iter().filter(|sh| sh.area_light.is_some()).collect();
    assert_eq!(lights.len(), 1);
    let al = lights[0].area_light.as_ref().unwrap();
    assert_eq!(al.name, "diffuse");
    assert_eq!(al.params.get_float("scale", 1.0).unwrap(), 20.0);
    assert!(al.params.get_spectrum("L", SpectrumKind::Illuminant).unwrap().is_some());
    // Material state: grey for the light and the "everything else" shapes, red and green walls in between.
    let mats: Vec<_> = s.shapes.iter().map(|sh| sh.material.clone()).collect();
    use MaterialRef::Anonymous as A;
    assert_eq!(mats, vec![A(1), A(2), A(3), A(1), A(1), A(1), A(1), A(1)]);
    let red = s.material(&s.shapes[1].material).unwrap();
    let refl = red.params.get_spectrum("reflectance", SpectrumKind::Albedo).unwrap().unwrap();
    assert!(refl.eval(650.0) > refl.eval(450.0));
    for m in &s.materials[1..] {
        assert!(m.params.get_spectrum("reflectance", SpectrumKind::Albedo).unwrap().is_some());
    }
    for sh in &s.shapes {
        assert_eq!(sh.entity.name, "trianglemesh");
        assert!(sh.render_from_object.is_identity());
        let p = sh.entity.params.get_point3s("P").unwrap().unwrap();
        let idx = sh.entity.params.get_ints("indices").unwrap();
        assert!(idx.iter().all(|&i| (i as usize) < p.len()));
    }
    assert_eq!(s.shapes[7].entity.params.get_point3s("P").unwrap().unwrap().len(), 20);
    // Everything the checks above did not read is reported, with its location.
    let unused = s.unused_parameters();
    assert!(unused.is_empty(), "{unused:?}");
}

#[test]
fn killeroo_simple() {
    let s = pbrt::parse_file(&fixture("killeroos/killeroo-simple.pbrt")).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert_eq!(s.camera.entity.params.get_float("fov", 90.0).unwrap(), 39.0);
    assert_eq!(s.film.params.get_int("xresolution", 1280).unwrap(), 700);
    assert_eq!(s.film.params.get_int("yresolution", 720).unwrap(), 700);
    assert_eq!(s.sampler.name, "halton");
    assert_eq!(s.sampler.params.get_int("pixelsamples", 16).unwrap(), 256);
    assert_eq!(s.integrator.name, "volpath", "pbrt-v4's default integrator");

    // LookAt then Rotate -5 about z: each directive post-multiplies, camera_from_world = LookAt · Rotate.
    let look = Transform::look_at(DVec3::new(400.0, 20.0, 30.0), DVec3::new(0.0, 63.0, -110.0), DVec3::Z).unwrap();
    let expected = look * Transform::rotate(-5.0, DVec3::Z).unwrap();
    let p = DVec3::new(10.0, -20.0, 30.0);
    assert!(close(s.camera.camera_from_world.point(p), expected.point(p)));

    let names: Vec<&str> = s.shapes.iter().map(|sh| sh.entity.name.as_str()).collect();
    assert_eq!(names, ["sphere", "trianglemesh", "trianglemesh", "loopsubdiv", "loopsubdiv"]);
    assert_eq!(s.materials.len(), 5);
    assert!(s.lights.is_empty());
    let sphere = &s.shapes[0];
    assert_eq!(sphere.entity.params.get_float("radius", 1.0).unwrap(), 3.0);
    assert!(close(sphere.render_from_object.point(DVec3::ZERO), DVec3::new(150.0, 120.0, 20.0)));
    let l = sphere.area_light.as_ref().unwrap();
    let spd = l.params.get_spectrum("L", SpectrumKind::Illuminant).unwrap().unwrap();
    assert!(spd.eval(550.0) > 100.0);
    assert!(s.shapes[1..].iter().all(|sh| sh.area_light.is_none()));
    assert_eq!(s.shapes[1].entity.params.get_point2s("uv").unwrap().unwrap().len(), 4);

    // The included killeroo: Scale .5, Rotate -60 z, Translate (100 200 -140), then Translate -200 for the second.
    let base = Transform::scale(DVec3::splat(0.5)).unwrap() * Transform::rotate(-60.0, DVec3::Z).unwrap();
    let first = base * Transform::translate(DVec3::new(100.0, 200.0, -140.0));
    let second = first * Transform::translate(DVec3::new(-200.0, 0.0, 0.0));
    let q = DVec3::new(1.0, 2.0, 3.0);
    assert!(close(s.shapes[3].render_from_object.point(q), first.point(q)));
    assert!(close(s.shapes[4].render_from_object.point(q), second.point(q)));
    assert_eq!(s.shapes[3].material, MaterialRef::Anonymous(3));
    assert_eq!(s.shapes[4].material, MaterialRef::Anonymous(4));
    let coated = s.material(&s.shapes[4].material).unwrap();
    assert_eq!(coated.name, "coateddiffuse");
    assert_eq!(coated.params.get_float("roughness", 0.0).unwrap(), 0.15);
    let k = &s.shapes[3].entity;
    assert!(k.loc.file.ends_with("geometry/killeroo.pbrt"));
    assert_eq!((k.loc.line, k.loc.column), (1, 1));
    assert_eq!(k.params.get_int("levels", 3).unwrap(), 1);
    let p = k.params.get_point3s("P").unwrap().unwrap();
    let idx = k.params.get_ints("indices").unwrap();
    assert_eq!(idx.len() % 3, 0);
    assert!(idx.iter().all(|&i| i >= 0 && (i as usize) < p.len()));
    assert!(p.len() > 3000, "{}", p.len());
}

#[test]
fn a_missing_include_is_named_at_its_line() {
    // killeroo-gold with its Include pointing at a file that is not there: the error points at the Include.
    let path = fixture("killeroos/killeroo-gold.pbrt");
    let text = std::fs::read_to_string(&path).unwrap().replace("killeroo3.pbrt", "killeroo-missing.pbrt");
    let line = 1 + text.lines().position(|l| l.contains("killeroo-missing.pbrt")).unwrap() as u32;
    let e = pbrt::parse_str(&text, &path).unwrap_err();
    assert!(e.loc.file.ends_with("killeroo-gold.pbrt"));
    assert_eq!((e.loc.line, e.loc.column), (line, 5));
    assert!(e.message.contains("killeroo-missing.pbrt"), "{e}");
}

#[test]
fn killeroo_gold_unchanged() {
    // killeroo-gold unchanged: textures, CoordSysTransform "camera", spectrum files, its own killeroo3.pbrt.
    let path = fixture("killeroos/killeroo-gold.pbrt");
    let s = pbrt::parse_file(&path).unwrap();
    let k = s.shapes.iter().find(|k| k.entity.loc.file.ends_with("geometry/killeroo3.pbrt")).unwrap();
    assert_eq!(k.entity.name, "loopsubdiv");
    assert_eq!(s.camera.entity.params.get_float("fov", 90.0).unwrap(), 38.0);
    assert_eq!(s.film.params.get_int("xresolution", 0).unwrap(), 1368);
    assert_eq!(s.sampler.params.get_int("pixelsamples", 0).unwrap(), 512);

    let disk = &s.shapes[0];
    assert_eq!(disk.entity.name, "disk");
    assert!(disk.reverse_orientation);
    assert!(close(disk.render_from_object.point(DVec3::ZERO), DVec3::new(0.0, 0.0, 800.0)));

    // CoordSysTransform "camera": the distant light sits in camera space.
    assert_eq!(s.lights.len(), 1);
    let light = &s.lights[0];
    assert_eq!(light.entity.name, "distant");
    let eye = DVec3::new(200.0, 250.0, 70.0);
    assert!(close(light.render_from_light.point(DVec3::ZERO), eye));
    let fwd = light.render_from_light.vector(DVec3::Z);
    assert!(close(fwd, (DVec3::new(0.0, 33.0, -50.0) - eye).normalize()));

    assert_eq!(s.textures.len(), 2);
    let grid = &s.textures[0];
    assert_eq!((grid.texture_name.as_str(), grid.entity.name.as_str()), ("grid", "imagemap"));
    assert_eq!(grid.value_type, TextureValueType::Spectrum);
    let f = grid.entity.params.get_filename("filename").unwrap().unwrap();
    assert!(f.ends_with("killeroos/textures/lines.png") && f.exists(), "{}", f.display());
    assert_eq!(s.textures[1].entity.params.get_texture("tex").as_deref(), Some("grid"));

    let gold = s.material(&s.shapes.last().unwrap().material).unwrap();
    assert_eq!(gold.name, "conductor");
    let k = gold.params.get_spectrum("k", SpectrumKind::Unbounded).unwrap().unwrap();
    let eta = gold.params.get_spectrum("eta", SpectrumKind::Unbounded).unwrap().unwrap();
    // Au.eta.spd starts "298.757050 1.795000".
    assert!((eta.eval(298.757050) - 1.795).abs() < 1e-9);
    assert!(k.eval(700.0) > 3.0, "gold's k is large in the red: {}", k.eval(700.0));
}

//! Transforms, graphics state, instancing, spectra and parameters.

use std::path::{Path, PathBuf};

use glam::DVec3;
use scene::{FloatParam, MaterialRef, ParamType, SceneDescription, Spectrum, SpectrumKind, SpectrumParam};

fn parse(text: &str) -> SceneDescription {
    pbrt::parse_str(text, Path::new("t.pbrt")).unwrap_or_else(|e| panic!("{e}"))
}

fn close(a: DVec3, b: DVec3) -> bool {
    (a - b).length() < 1e-9 * (1.0 + b.length())
}

/// A fresh directory under the system temp dir for one test.
fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("prismatic-pbrt-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn transforms_match_pbrt() {
    let s = parse(
        "WorldBegin
         AttributeBegin Translate 1 2 3 Shape \"sphere\" AttributeEnd
         AttributeBegin Rotate 90 0 0 1 Shape \"sphere\" AttributeEnd
         AttributeBegin Scale 2 3 4 Shape \"sphere\" AttributeEnd
         AttributeBegin Translate 1 0 0 Scale 2 2 2 Shape \"sphere\" AttributeEnd
         AttributeBegin ConcatTransform [1 0 0 0  0 1 0 0  0 0 1 0  5 6 7 1] Shape \"sphere\" AttributeEnd
         AttributeBegin Translate 9 9 9 Transform [2 0 0 0  0 2 0 0  0 0 2 0  0 0 1 1] Shape \"sphere\" AttributeEnd
         AttributeBegin Translate 9 9 9 Identity Shape \"sphere\" AttributeEnd
         Shape \"sphere\"",
    );
    let t: Vec<_> = s.shapes.iter().map(|sh| sh.render_from_object).collect();
    let p = DVec3::new(1.0, 1.0, 1.0);
    assert!(close(t[0].point(DVec3::ZERO), DVec3::new(1.0, 2.0, 3.0)));
    assert!(close(t[1].point(DVec3::X), DVec3::Y), "right-handed rotation about +z");
    assert!(close(t[2].point(p), DVec3::new(2.0, 3.0, 4.0)));
    assert!(close(t[3].point(DVec3::X), DVec3::new(3.0, 0.0, 0.0)), "the later transform applies first");
    assert!(close(t[4].point(DVec3::ZERO), DVec3::new(5.0, 6.0, 7.0)), "column-major 16 numbers");
    assert!(close(t[5].point(p), DVec3::new(2.0, 2.0, 3.0)), "Transform replaces the current transform");
    assert!(t[6].is_identity());
    assert!(t[7].is_identity(), "AttributeEnd restored the transform");
    assert!(close(t[4].normal(DVec3::Z), DVec3::Z));
}

#[test]
fn camera_and_named_coordinate_systems() {
    let s = parse(
        "LookAt 0 0 -5  0 0 0  0 1 0
         CoordinateSystem \"mine\"
         Camera \"orthographic\"
         WorldBegin
         AttributeBegin CoordSysTransform \"camera\" LightSource \"point\" AttributeEnd
         AttributeBegin Translate 1 1 1 CoordSysTransform \"world\" LightSource \"point\" AttributeEnd
         AttributeBegin CoordSysTransform \"mine\" LightSource \"point\" AttributeEnd",
    );
    assert_eq!(s.camera.entity.name, "orthographic");
    assert!(close(s.camera.camera_from_world.point(DVec3::ZERO), DVec3::new(0.0, 0.0, 5.0)));
    assert!(close(s.lights[0].render_from_light.point(DVec3::ZERO), DVec3::new(0.0, 0.0, -5.0)));
    assert!(close(s.lights[0].render_from_light.vector(DVec3::Z), DVec3::Z));
    assert!(s.lights[1].render_from_light.is_identity());
    assert_eq!(s.lights[2].render_from_light, s.camera.camera_from_world);
}

#[test]
fn attribute_blocks_restore_the_graphics_state() {
    let s = parse(
        "WorldBegin
         Material \"conductor\"
         AttributeBegin
           Material \"dielectric\" ReverseOrientation
           AreaLightSource \"diffuse\" \"rgb L\" [1 1 1]
           MakeNamedMedium \"fog\" \"string type\" \"homogeneous\"
           MediumInterface \"fog\" \"\"
           Attribute \"shape\" \"float radius\" 7
           Shape \"sphere\"
           AttributeBegin NamedMaterial \"gold\" Shape \"sphere\" \"float radius\" 2 AttributeEnd
           Shape \"disk\"
         AttributeEnd
         Shape \"sphere\"
         MakeNamedMaterial \"gold\" \"string type\" \"conductor\"",
    );
    let [a, b, c, d] = &s.shapes[..] else { panic!("{}", s.shapes.len()) };
    assert!(a.reverse_orientation && b.reverse_orientation && c.reverse_orientation && !d.reverse_orientation);
    assert!(a.area_light.is_some() && c.area_light.is_some() && d.area_light.is_none());
    assert_eq!(a.material, MaterialRef::Anonymous(2));
    assert_eq!(b.material, MaterialRef::Named("gold".into()));
    assert_eq!(c.material, MaterialRef::Anonymous(2));
    assert_eq!(d.material, MaterialRef::Anonymous(1));
    assert_eq!(s.material(&d.material).unwrap().name, "conductor");
    assert_eq!(s.named_material("gold").unwrap().name, "conductor");
    assert_eq!((a.inside_medium.as_deref(), a.outside_medium.as_deref()), (Some("fog"), None));
    assert_eq!(d.inside_medium, None);
    assert_eq!(s.media[0].entity.name, "homogeneous");
    assert_eq!(s.media[0].medium_name, "fog");
    // Attribute defaults: used where the shape gives none, shadowed where it does, never reported unused.
    assert_eq!(a.entity.params.get_float("radius", 1.0).unwrap(), 7.0);
    assert_eq!(b.entity.params.get_float("radius", 1.0).unwrap(), 2.0);
    assert_eq!(d.entity.params.get_float("radius", 1.0).unwrap(), 1.0);
    assert!(c.entity.params.unused().is_empty());
}

#[test]
fn objects_and_instances() {
    let s = parse(
        "WorldBegin
         AttributeBegin
           Translate 0 0 1
           ObjectBegin \"thing\"
             Shape \"sphere\"
             AreaLightSource \"diffuse\"
             Translate 1 0 0
             Shape \"disk\"
           ObjectEnd
           Shape \"cylinder\"
         AttributeEnd
         Translate 10 0 0
         ObjectInstance \"thing\"
         Translate 10 0 0
         ObjectInstance \"thing\"",
    );
    assert_eq!(s.objects.len(), 1);
    let o = &s.objects[0];
    assert_eq!(o.name, "thing");
    assert_eq!(o.shapes.len(), 2);
    // As pbrt-v4 records them: the full transform at the shape.
    assert!(close(o.shapes[0].render_from_object.point(DVec3::ZERO), DVec3::new(0.0, 0.0, 1.0)));
    assert!(close(o.shapes[1].render_from_object.point(DVec3::ZERO), DVec3::new(1.0, 0.0, 1.0)));
    assert!(o.shapes[1].area_light.is_none(), "no area lights in instances");
    assert!(s.warnings.iter().any(|w| w.message.contains("area lights")));
    // ObjectEnd restored the transform; the cylinder is outside the object.
    assert_eq!(s.shapes.len(), 1);
    assert!(close(s.shapes[0].render_from_object.point(DVec3::ZERO), DVec3::new(0.0, 0.0, 1.0)));
    assert_eq!(s.instances.len(), 2);
    assert!(close(s.instances[1].render_from_instance.point(DVec3::ZERO), DVec3::new(20.0, 0.0, 0.0)));
    assert!(s.object("thing").is_some());
}

#[test]
fn spectra_of_every_form() {
    let dir = temp_dir("spectra");
    std::fs::write(dir.join("ramp.spd"), "# a ramp\n400 0.25\n500, 0.5\n600 0.75 # end\n").unwrap();
    let text = "WorldBegin
        Material \"diffuse\"
          \"rgb reflectance\" [0.2 0.4 0.6]
          \"rgb toobright\" [0.2 1.4 0.6]
          \"blackbody temp\" 6000
          \"spectrum illum\" \"stdillum-D65\"
          \"spectrum glass\" \"glass-BK7\"
          \"spectrum gold\" \"metal-Au-eta\"
          \"spectrum inline\" [400 0.5 500 0.6]
          \"spectrum file\" \"ramp.spd\"
          \"float eta\" 1.5
          \"texture tex\" \"checks\"
        Texture \"checks\" \"spectrum\" \"checkerboard\"";
    let s = pbrt::parse_str(text, &dir.join("s.pbrt")).unwrap_or_else(|e| panic!("{e}"));
    let p = &s.materials[1].params;
    let get = |n: &str, k| p.get_spectrum(n, k).unwrap().unwrap();
    let refl = get("reflectance", SpectrumKind::Albedo);
    assert!(matches!(refl, Spectrum::RgbAlbedo(_)));
    assert!(refl.eval(450.0) > refl.eval(650.0));
    assert!(matches!(get("reflectance", SpectrumKind::Illuminant), Spectrum::RgbIlluminant(_)));
    let e = p.get_spectrum("toobright", SpectrumKind::Albedo).unwrap_err().to_string();
    assert!(e.starts_with(&format!("{}:4:11: error: parameter 'rgb toobright'", dir.join("s.pbrt").display())), "{e}");
    assert!(e.contains("1.4"), "{e}");
    assert!(matches!(get("toobright", SpectrumKind::Unbounded), Spectrum::RgbUnbounded(_)));
    let bb = get("temp", SpectrumKind::Illuminant);
    let peak = (360..=830).map(|l| bb.eval(f64::from(l))).fold(0.0, f64::max);
    assert!((peak - 1.0).abs() < 1e-3, "normalised blackbody peaks at 1 in the visible for 6000 K: {peak}");
    assert!(get("illum", SpectrumKind::Illuminant).eval(560.0) > 0.0);
    assert!((get("glass", SpectrumKind::Unbounded).eval(587.56) - 1.5168).abs() < 1e-3);
    assert!(get("gold", SpectrumKind::Unbounded).eval(600.0) > 0.1);
    assert!((get("inline", SpectrumKind::Unbounded).eval(450.0) - 0.55).abs() < 1e-12);
    assert!((get("file", SpectrumKind::Unbounded).eval(550.0) - 0.625).abs() < 1e-12);
    let e = p.get_spectrum("eta", SpectrumKind::Unbounded).unwrap_err().to_string();
    assert!(e.contains(":11:11:") && e.contains("float is not accepted"), "{e}");
    assert_eq!(p.param_type("eta"), Some(ParamType::Float));
    assert_eq!(p.get_float_texture("eta", 1.0).unwrap(), FloatParam::Value(1.5));
    assert_eq!(
        p.get_spectrum_texture("tex", SpectrumKind::Albedo).unwrap(),
        Some(SpectrumParam::Texture("checks".into()))
    );
    assert!(p.unused().is_empty(), "{:?}", p.unused());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn unused_parameters_name_their_location() {
    let s = parse("WorldBegin\nShape \"sphere\" \"float radius\" 1\n   \"float foo\" [ 2 ]\n");
    let params = &s.shapes[0].entity.params;
    assert_eq!(params.get_float("radius", 1.0).unwrap(), 1.0);
    let u = params.unused();
    assert_eq!(u.len(), 1);
    assert_eq!(u[0].to_string(), "t.pbrt:3:4: warning: unused parameter 'float foo'");
    let all = s.unused_parameters();
    assert_eq!(all.len(), 1, "{all:?}");
}

#[test]
fn parameter_syntax() {
    let s = parse(
        "WorldBegin
         Shape \"x\" \"bool a\" true \"bool b\" \"false\" \"bool c\" [ true false ]
           \"integer n\" [ -3 +4 5.0 ] \"string s\" \"q\\\"uote\" \"point2 uv\" [0 1 2 3]
           \"normal N\" [0 0 1] \"normal3 M\" [0 1 0] \"vector3 v\" [1 2 3] \"point P\" [1 2 3]
           \"color C\" [0.1 0.2 0.3] \"float f\" [ .5 -1e-2 +3 ]",
    );
    let p = &s.shapes[0].entity.params;
    assert!(p.get_bool("a", false).unwrap());
    assert!(!p.get_bool("b", true).unwrap());
    assert_eq!(p.get_bools("c").unwrap(), &[true, false]);
    assert_eq!(p.get_ints("n").unwrap(), &[-3, 4, 5]);
    assert_eq!(p.get_string("s", "").unwrap(), "q\"uote");
    assert_eq!(p.get_point2s("uv").unwrap().unwrap(), vec![[0.0, 1.0], [2.0, 3.0]]);
    assert_eq!(p.get_normals("N").unwrap().unwrap(), vec![DVec3::Z]);
    assert_eq!(p.get_normals("M").unwrap().unwrap(), vec![DVec3::Y]);
    assert_eq!(p.get_vector3("v", DVec3::ZERO).unwrap(), DVec3::new(1.0, 2.0, 3.0));
    assert_eq!(p.get_point3("P", DVec3::ZERO).unwrap(), DVec3::new(1.0, 2.0, 3.0));
    assert_eq!(p.param_type("C"), Some(ParamType::Rgb));
    assert_eq!(p.get_floats("f").unwrap(), &[0.5, -0.01, 3.0]);
    let v3: Vec<_> = s.warnings.iter().filter(|w| w.message.contains("pbrt-v3")).collect();
    assert_eq!(v3.len(), 2, "point and color are pbrt-v3 synonyms: {:?}", s.warnings);
}

#[test]
fn defaults_when_directives_are_absent() {
    let s = parse("WorldBegin");
    assert_eq!(s.camera.entity.name, "perspective");
    assert!(s.camera.camera_from_world.is_identity());
    assert_eq!(s.film.name, "rgb");
    assert_eq!(s.sampler.name, "zsobol");
    assert_eq!(s.integrator.name, "volpath");
    assert_eq!(s.filter.name, "gaussian");
    assert!(s.accelerator.is_none());
    assert_eq!(s.color_space, "srgb");
    assert_eq!(s.materials.len(), 1);
    assert_eq!(s.materials[0].name, "diffuse");
}

#[test]
fn includes_and_imports_resolve_relative_to_the_including_file() {
    let dir = temp_dir("include");
    std::fs::create_dir_all(dir.join("sub/deeper")).unwrap();
    std::fs::write(dir.join("sub/a.pbrt"), "Include \"deeper/b.pbrt\"\nShape \"sphere\"\n").unwrap();
    std::fs::write(dir.join("sub/deeper/b.pbrt"), "Material \"conductor\"\n").unwrap();
    std::fs::write(dir.join("sub/imp.pbrt"), "Material \"dielectric\" Translate 5 0 0 Shape \"disk\"\n").unwrap();
    std::fs::write(
        dir.join("main.pbrt"),
        "WorldBegin\nInclude \"sub/a.pbrt\"\nImport \"sub/imp.pbrt\"\nShape \"cylinder\"\n",
    )
    .unwrap();
    let s = pbrt::parse_file(&dir.join("main.pbrt")).unwrap_or_else(|e| panic!("{e}"));
    let names: Vec<_> = s.shapes.iter().map(|s| s.entity.name.as_str()).collect();
    assert_eq!(names, ["sphere", "disk", "cylinder"]);
    assert_eq!(s.material(&s.shapes[0].material).unwrap().name, "conductor");
    assert_eq!(s.material(&s.shapes[1].material).unwrap().name, "dielectric");
    assert!(close(s.shapes[1].render_from_object.point(DVec3::ZERO), DVec3::new(5.0, 0.0, 0.0)));
    // Import does not leak its graphics state; Include does.
    assert_eq!(s.material(&s.shapes[2].material).unwrap().name, "conductor");
    assert!(s.shapes[2].render_from_object.is_identity());
    assert!(s.shapes[0].entity.loc.file.ends_with("sub/a.pbrt"));
    assert_eq!(s.shapes[0].entity.loc.line, 2);
    // Every file read is listed once, in the order read (what a checkpoint's scene hash covers).
    let files: Vec<String> =
        s.files.iter().map(|f| f.strip_prefix(&dir).unwrap().to_string_lossy().into_owned()).collect();
    assert_eq!(files, ["main.pbrt", "sub/a.pbrt", "sub/deeper/b.pbrt", "sub/imp.pbrt"]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn spectrum_files_and_file_parameters_are_input_files() {
    let dir = temp_dir("input-files");
    std::fs::write(dir.join("glow.spd"), "400 1  500 2  600 1\n").unwrap();
    std::fs::write(
        dir.join("main.pbrt"),
        "WorldBegin\nAreaLightSource \"diffuse\" \"spectrum L\" \"glow.spd\"\n\
         Shape \"plymesh\" \"string filename\" \"mesh.ply\"\n\
         Shape \"plymesh\" \"string filename\" \"other.ply\"\n",
    )
    .unwrap();
    let s = pbrt::parse_file(&dir.join("main.pbrt")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.files, [dir.join("main.pbrt"), dir.join("glow.spd")]);
    // A file parameter counts once the renderer reads it as a file name (here: the first mesh only).
    assert_eq!(s.input_files(), s.files);
    assert_eq!(s.shapes[0].entity.params.get_filename("filename").unwrap(), Some(dir.join("mesh.ply")));
    assert_eq!(s.input_files(), [dir.join("main.pbrt"), dir.join("glow.spd"), dir.join("mesh.ply")]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn active_transforms_record_both_ends_as_killeroo_moving_does() {
    // The directive pattern of pbrt-v4's killeroos/killeroo-moving.pbrt (spheres in place of the killeroos).
    let s = parse(
        "TransformTimes 0 1
         WorldBegin
         AttributeBegin
           Translate 100 200 -140
           ActiveTransform StartTime
           Translate 35 35 35
           AttributeBegin Shape \"sphere\" AttributeEnd
           AttributeBegin
             ActiveTransform StartTime
             Translate 30 0 0
             ActiveTransform All
             Translate -200 0 0
             Shape \"sphere\"
           AttributeEnd
           Translate 1 0 0
           Shape \"sphere\"
         AttributeEnd
         Shape \"sphere\"",
    );
    let at = |i: usize| {
        let sh = &s.shapes[i];
        let m = sh.motion.expect("moving");
        assert_eq!((m.start_time, m.end_time), (0.0, 1.0));
        (sh.render_from_object.point(DVec3::ZERO), m.end.point(DVec3::ZERO))
    };
    let (a0, a1) = at(0);
    assert!(close(a0, DVec3::new(135.0, 235.0, -105.0)) && close(a1, DVec3::new(100.0, 200.0, -140.0)));
    let (b0, b1) = at(1);
    assert!(close(b0, DVec3::new(-35.0, 235.0, -105.0)) && close(b1, DVec3::new(-100.0, 200.0, -140.0)));
    // AttributeEnd restored StartTime as the active transform: the last Translate moved only the start.
    let (c0, c1) = at(2);
    assert!(close(c0, DVec3::new(136.0, 235.0, -105.0)) && close(c1, DVec3::new(100.0, 200.0, -140.0)));
    assert!(s.shapes[3].motion.is_none() && s.shapes[3].render_from_object.is_identity());
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}

#[test]
fn camera_instances_and_named_systems_move() {
    let s = parse(
        "TransformTimes 0.5 2
         ActiveTransform EndTime Translate -1 0 0 ActiveTransform All
         Camera \"orthographic\" \"float shutteropen\" 0.5 \"float shutterclose\" 2
         WorldBegin
         ObjectBegin \"o\" Shape \"sphere\" ObjectEnd
         AttributeBegin ActiveTransform EndTime Rotate 90 0 0 1 ObjectInstance \"o\" AttributeEnd
         ObjectInstance \"o\"
         AttributeBegin ActiveTransform EndTime Identity Translate 0 3 0 ActiveTransform StartTime
           Translate 0 0 1 ObjectInstance \"o\" LightSource \"point\" AttributeEnd
         AttributeBegin CoordSysTransform \"camera\" Shape \"sphere\" AttributeEnd",
    );
    let cam = s.camera.motion.expect("the camera moves");
    assert_eq!((cam.start_time, cam.end_time), (0.5, 2.0));
    assert!(s.camera.camera_from_world.is_identity());
    assert!(close(cam.end.point(DVec3::ZERO), DVec3::new(-1.0, 0.0, 0.0)));
    let i0 = s.instances[0].motion.expect("moving instance");
    assert!(close(i0.end.vector(DVec3::X), DVec3::Y));
    assert!(s.instances[1].motion.is_none());
    let i2 = s.instances[2].motion.expect("moving instance");
    assert!(close(s.instances[2].render_from_instance.point(DVec3::ZERO), DVec3::new(0.0, 0.0, 1.0)));
    assert!(close(i2.end.point(DVec3::ZERO), DVec3::new(0.0, 3.0, 0.0)));
    // Lights keep the start transform, with a warning, as in pbrt-v4.
    assert!(close(s.lights[0].render_from_light.point(DVec3::ZERO), DVec3::new(0.0, 0.0, 1.0)));
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(s.warnings[0].message.contains("LightSource under a moving transform"));
    // "camera" is world-from-camera at both times.
    let sh = &s.shapes[0];
    assert!(sh.render_from_object.is_identity());
    assert!(close(sh.motion.expect("moves with the camera").end.point(DVec3::ZERO), DVec3::new(1.0, 0.0, 0.0)));
}

#[test]
fn bad_transform_times_are_errors() {
    for (text, want) in [
        ("TransformTimes 1 0 WorldBegin", "t.pbrt:1:1: error: TransformTimes: the end time (0) is before"),
        ("WorldBegin TransformTimes 0 1", "t.pbrt:1:12: error: TransformTimes is not allowed after WorldBegin"),
        ("TransformTimes 0 WorldBegin", "t.pbrt:1:18"),
        (
            "ActiveTransform EndTime Scale 0 1 1 ActiveTransform All Camera \"perspective\" WorldBegin",
            "the camera transform is singular",
        ),
    ] {
        let e = pbrt::parse_str(text, Path::new("t.pbrt")).unwrap_err().to_string();
        assert!(e.contains(want), "{text}: {e}");
    }
}

#[test]
fn options_and_deprecated_directives() {
    let s = parse(
        "Option \"bool disablepixeljitter\" true Option \"seed\" 7 ColorSpace \"srgb\"
         Accelerator \"kdtree\"
         WorldBegin TransformBegin Translate 1 0 0 TransformEnd Shape \"sphere\" WorldEnd",
    );
    assert_eq!(s.options.len(), 2);
    assert_eq!((s.options[0].name.as_str(), s.options[0].value.as_str()), ("disablepixeljitter", "true"));
    assert_eq!(s.options[1].value, "7");
    assert_eq!(s.accelerator.as_ref().unwrap().name, "kdtree");
    assert!(s.shapes[0].render_from_object.is_identity());
    assert!(s.warnings.iter().any(|w| w.message.contains("TransformBegin")));
    assert!(s.warnings.iter().any(|w| w.message.contains("WorldEnd")));
}

fn gzip(data: &[u8]) -> Vec<u8> {
    use std::io::Write;
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    e.write_all(data).unwrap();
    e.finish().unwrap()
}

#[test]
fn gzip_compressed_scene_include_and_import_files() {
    let dir = temp_dir("gzip");
    std::fs::write(dir.join("mats.pbrt.gz"), gzip(b"Material \"conductor\"\n")).unwrap();
    // Recognised by content: this one is gzip data under a plain name.
    std::fs::write(dir.join("geo.pbrt"), gzip(b"Translate 5 0 0\n\n  Shape \"disk\"\n")).unwrap();
    std::fs::write(
        dir.join("main.pbrt.gz"),
        gzip(b"WorldBegin\nInclude \"mats.pbrt.gz\"\nImport \"geo.pbrt\"\nShape \"sphere\"\n"),
    )
    .unwrap();
    let s = pbrt::parse_file(&dir.join("main.pbrt.gz")).unwrap_or_else(|e| panic!("{e}"));
    let names: Vec<_> = s.shapes.iter().map(|s| s.entity.name.as_str()).collect();
    assert_eq!(names, ["disk", "sphere"]);
    assert_eq!(s.material(&s.shapes[1].material).unwrap().name, "conductor");
    assert!(close(s.shapes[0].render_from_object.point(DVec3::ZERO), DVec3::new(5.0, 0.0, 0.0)));
    // The Import's transform stays inside it.
    assert!(s.shapes[1].render_from_object.is_identity());
    // Locations are lines and columns of the decompressed text, in the compressed file.
    let l = &s.shapes[0].entity.loc;
    assert!(l.file.ends_with("geo.pbrt") && (l.line, l.column) == (3, 3), "{l}");
    let l = &s.shapes[1].entity.loc;
    assert!(l.file.ends_with("main.pbrt.gz") && (l.line, l.column) == (4, 1), "{l}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Exported scenes (transparent-machines) scale an axis of a nested object's transform to zero; pbrt-v4 accepts it.
#[test]
fn singular_transforms_are_accepted_as_pbrt_v4_does() {
    let s = parse(
        "WorldBegin
AttributeBegin
  ObjectBegin \"part\"
  AttributeBegin
    ConcatTransform [ -0 0 -0 0  0 1 0 0  0 0 -1 0  7 -2 3 1 ]
    AttributeBegin
      ConcatTransform [ 1 0 0 0  0 1 0 0  0 0 1 0  5 0 1 1 ]
      Shape \"trianglemesh\" \"point3 P\" [ 0 0 0  1 0 0  0 1 1 ] \"normal N\" [ 1 0 0  1 0 0  1 0 0 ]
      Shape \"sphere\"
    AttributeEnd
  AttributeEnd
  ObjectEnd
AttributeEnd
ObjectInstance \"part\"
AttributeBegin
  Scale 2 0 2
  ObjectInstance \"part\"
  LightSource \"spot\"
  LightSource \"point\" \"point3 from\" [ 1 5 1 ]
  Shape \"disk\"
  Shape \"bilinearmesh\" \"point3 P\" [ 0 0 0  1 0 0  0 1 0  1 1 0 ]
AttributeEnd
Shape \"sphere\"",
    );
    let warned_at = |line: u32, column: u32, needle: &str| {
        s.warnings.iter().any(|w| (w.loc.line, w.loc.column) == (line, column) && w.message.contains(needle))
    };
    assert!(warned_at(5, 5, "ConcatTransform: the matrix makes the transform singular"), "{:?}", s.warnings);
    assert!(warned_at(16, 3, "Scale 2 0 2: a zero factor"), "{:?}", s.warnings);
    // The mesh is kept and flattened onto the plane x = 7 (object x, then x + 5, scaled to zero and moved to 7).
    let part = &s.objects[0];
    assert_eq!(part.shapes.len(), 1);
    let t = part.shapes[0].render_from_object;
    assert!(!t.is_invertible());
    assert!(close(t.point(DVec3::new(1.0, 2.0, 3.0)), DVec3::new(7.0, 0.0, -1.0)));
    // What needs the inverse is left out, each with a warning at its own directive.
    assert!(warned_at(9, 7, "Shape \"sphere\" under a singular transform is left out"), "{:?}", s.warnings);
    assert!(warned_at(17, 3, "ObjectInstance \"part\""), "{:?}", s.warnings);
    assert!(warned_at(18, 3, "LightSource \"spot\""), "{:?}", s.warnings);
    assert!(warned_at(20, 3, "Shape \"disk\""), "{:?}", s.warnings);
    assert_eq!(s.instances.len(), 1);
    assert!(s.instances[0].render_from_instance.is_identity());
    // A point light keeps its flattened position; a bilinear mesh is kept like a triangle mesh.
    assert_eq!(s.lights.len(), 1);
    assert_eq!(s.lights[0].entity.name, "point");
    assert!(close(s.lights[0].render_from_light.point(DVec3::new(1.0, 5.0, 1.0)), DVec3::new(2.0, 0.0, 2.0)));
    let names: Vec<_> = s.shapes.iter().map(|s| s.entity.name.as_str()).collect();
    assert_eq!(names, ["bilinearmesh", "sphere"]);
    // AttributeEnd restores an invertible transform.
    assert!(s.shapes[1].render_from_object.is_invertible() && s.shapes[1].render_from_object.is_identity());
}

//! The syntax real pbrt-v4 scenes use, each pattern in a small snippet of our own, parsed and checked for what it
//! means. Where each pattern was seen (scenes of pbrt-v4's public collection):
//!
//! - multi-line `LookAt`, `Scale -1 1 1` before the camera: crown, pbrt-book, ganesha-coated-gold
//! - `Transform`/`ConcatTransform` before `Camera`, `-0`, exponents, `1  ]`: veach-ajar, transparent-machines,
//!   zero-day, bathroom2
//! - comments between a directive and its parameters, between parameters, and commented-out parameters:
//!   cornell-box-volume, cornell-box-instance, crown, zero-day, ganesha-coated-gold
//! - a directive's type on the next line (`AreaLightSource` / `"diffuse"`): cornell-box-volume
//! - values with and without brackets or spaces (`[37.5]`, `["a.png"]`, `"float iso" 150`): cornell-box-instance,
//!   crown, transparent-machines
//! - numbers `.5`, `343.0`, `2.4000000000000004`, `-1.3000000000000007`, `8.326673e-17`: crown,
//!   material-testball, transparent-machines (and pbrt-v4's number syntax: `1.e-3`, `-.5`, `+2`, `5.`)
//! - `bool` as `[ false ]`, bare `true`, quoted `"true"`: veach-ajar, bathroom2, ganesha-coated-gold
//! - named spectra in brackets (`[ "metal-Ag-eta" ]`), inline λ/value spectra, `blackbody`: bathroom2, crown
//! - `MakeNamedMedium` and `MediumInterface "" "fog"` before `Camera`: cornell-box-volume
//! - `MakeNamedMedium` in nested `AttributeBegin`s after `Transform`, parameters at column 1, `Material
//!   "interface"`: material-testball (volumes)
//! - `ObjectBegin` holding `AttributeBegin`/`Material`/`Translate`/`Shape`, instanced under `AttributeBegin`s:
//!   cornell-box-instance; `ObjectBegin` inside `AttributeBegin`: transparent-machines
//! - `Texture "scale"` with `"texture tex"`, `mix` materials' `"string materials"` lists, material names with dots:
//!   crown, pbrt-book
//! - file names with spaces (`"textures/Good Textures_005844.tga"`): veach-ajar
//! - `ReverseOrientation`, an infinite light under `Transform` with `"float scale" [0.1]`: ganesha-coated-gold

use std::path::Path;

use geometry::Transform;
use glam::DVec3;
use scene::{MaterialRef, ParamType, SceneDescription, SpectrumKind};

fn parse(text: &str) -> SceneDescription {
    pbrt::parse_str(text, Path::new("scenes/s.pbrt")).unwrap_or_else(|e| panic!("{e}\n{text}"))
}

fn close(a: DVec3, b: DVec3) -> bool {
    (a - b).length() < 1e-9 * (1.0 + b.length())
}

#[test]
fn camera_transforms_before_camera() {
    // LookAt over three lines after a handedness flip.
    let s = parse("Scale -1 1 1\nLookAt 0 2 10\n    0 2 9\n    0 1 0\nCamera \"perspective\"\nWorldBegin");
    let expected = Transform::scale(DVec3::new(-1.0, 1.0, 1.0)).unwrap()
        * Transform::look_at(DVec3::new(0.0, 2.0, 10.0), DVec3::new(0.0, 2.0, 9.0), DVec3::Y).unwrap();
    let p = DVec3::new(0.3, -0.7, 2.0);
    assert!(close(s.camera.camera_from_world.point(p), expected.point(p)));
    // Camera space: the look point is straight ahead (+z) at distance 1; the flip mirrors x.
    assert!(close(s.camera.camera_from_world.point(DVec3::new(0.0, 2.0, 9.0)), DVec3::new(0.0, 0.0, 1.0)));
    // Translate, then a column-major ConcatTransform written with -0, tiny exponents and a trailing "1  ]".
    let s = parse(
        "Translate 0 22 0\nConcatTransform [ 1 -0 8.326673e-17 0 -0 1 0 0 0 0 1 0 5 6 7 1  ]\nCamera \"perspective\"\n\
         WorldBegin",
    );
    assert!(close(s.camera.camera_from_world.point(DVec3::ZERO), DVec3::new(5.0, 28.0, 7.0)));
}

#[test]
fn comments_and_line_breaks_inside_directives() {
    let s = parse(
        "Camera \"perspective\"\n    #\"float lensradius\" [ 0.5 ]\n    \"float lensradius\" [ 0 ]\n    \
         \"float fov\" [37.5]\nWorldBegin\n# light source\nAttributeBegin\n   AreaLightSource\n   \"diffuse\"\n   \
         # \"rgb L\" [20 20 20] # old\n   \"rgb L\" [108 76 24]\n   Shape \"trianglemesh\"\n   \
         \"integer indices\" [ 0 1 2  2 3 0 ]\n   \"point3 P\" [\n      343.0 548.7 227.0\n      343.0 548.7 332.0\n      \
         213.0 548.7 332.0\n      213.0 548.7 227.0 ]\nAttributeEnd\nMaterial \"dielectric\"\n    \
         #\"bool remaproughness\" [ true ]\n    \"float roughness\" [ 0.1 ]\n",
    );
    let cam = &s.camera.entity.params;
    assert_eq!(cam.len(), 2);
    assert_eq!((cam.get_float("lensradius", 9.0).unwrap(), cam.get_float("fov", 90.0).unwrap()), (0.0, 37.5));
    let al = s.shapes[0].area_light.as_ref().unwrap();
    assert_eq!(al.name, "diffuse");
    assert_eq!(al.params.len(), 1);
    assert_eq!(al.params.get("L").unwrap().floats, [108.0, 76.0, 24.0]);
    let pts = s.shapes[0].entity.params.get_point3s("P").unwrap().unwrap();
    assert_eq!(pts.len(), 4);
    assert!(close(pts[1], DVec3::new(343.0, 548.7, 332.0)));
    let m = &s.materials[1];
    assert_eq!((m.name.as_str(), m.params.len()), ("dielectric", 1));
    assert!(!m.params.contains("remaproughness"));
}

#[test]
fn values_with_and_without_brackets_and_every_number_form() {
    let s = parse(
        "Film \"rgb\" \"string filename\" [\"out.png\"] \"float iso\" 150 \"string sensor\" \"cie1931\"\n\
         WorldBegin\nShape \"trianglemesh\" \"float a\" [.5 .2 .01] \"float b\" [ 2.4000000000000004 \
         -1.3000000000000007 8.326673e-17 ] \"float c\" [ 1.e-3 -.5 +2 5. -0 343.0 ] \"integer indices\" [0 1 2] \
         \"point3 P\" [0 0 0 1 0 0 0 1 0]",
    );
    let f = &s.film.params;
    assert_eq!(f.get_string("filename", "").unwrap(), "out.png");
    assert_eq!(f.get_float("iso", 0.0).unwrap(), 150.0);
    assert_eq!(f.get_string("sensor", "").unwrap(), "cie1931");
    let p = &s.shapes[0].entity.params;
    assert_eq!(p.get_floats("a").unwrap(), [0.5, 0.2, 0.01]);
    assert_eq!(p.get_floats("b").unwrap(), [2.4000000000000004, -1.3000000000000007, 8.326673e-17]);
    let c = p.get_floats("c").unwrap();
    assert_eq!(c, [1e-3, -0.5, 2.0, 5.0, 0.0, 343.0]);
    assert!(c[4].is_sign_negative(), "-0 keeps its sign");
    assert_eq!(p.get_ints("indices").unwrap(), [0, 1, 2]);
}

#[test]
fn bools_spectra_and_blackbody() {
    let s = parse(
        "WorldBegin\nMakeNamedMaterial \"Mirror\" \"string type\" [ \"conductor\" ] \"float roughness\" [ 0 ]\n    \
         \"spectrum eta\" [ \"metal-Ag-eta\" ]\n    \"spectrum k\" [ \"metal-Ag-k\" ] \"bool remaproughness\" [ false ]\n\
         MakeNamedMaterial \"diamond\" \"string type\" \"dielectric\" \"spectrum eta\" [ 200 3.5 900 3.3 ]\n\
         Material \"coateddiffuse\" \"bool remaproughness\" true \"bool a\" \"true\" \"bool b\" [ \"false\" true ]\n\
         AttributeBegin\n    AreaLightSource \"diffuse\"\n        \"float scale\" [10]\n        \"blackbody L\" [ 5500 ]\n\
             Shape \"sphere\"\nAttributeEnd\n",
    );
    let (name, mirror) = &s.named_materials[0];
    assert_eq!((name.as_str(), mirror.name.as_str()), ("Mirror", "conductor"));
    assert!(!mirror.params.get_bool("remaproughness", true).unwrap());
    let eta = mirror.params.get_spectrum("eta", SpectrumKind::Unbounded).unwrap().unwrap();
    // Silver's η is about 0.05 through the visible (Palik; pbrt-v4's metal-Ag-eta).
    assert!((0.02..0.2).contains(&eta.eval(550.0)), "{}", eta.eval(550.0));
    let k = mirror.params.get_spectrum("k", SpectrumKind::Unbounded).unwrap().unwrap();
    assert!((3.0..4.5).contains(&k.eval(550.0)), "{}", k.eval(550.0));
    let diamond = &s.named_materials[1].1;
    let n = diamond.params.get_spectrum("eta", SpectrumKind::Unbounded).unwrap().unwrap();
    // Linear between (200, 3.5) and (900, 3.3): 3.4 at 550 nm.
    assert!((n.eval(550.0) - 3.4).abs() < 1e-9);
    let m = &s.materials[1].params;
    assert!(m.get_bool("remaproughness", false).unwrap() && m.get_bool("a", false).unwrap());
    assert_eq!(m.get_bools("b").unwrap(), [false, true]);
    let al = s.shapes[0].area_light.as_ref().unwrap();
    assert_eq!(al.params.param_type("L"), Some(ParamType::Blackbody));
    assert_eq!(al.params.get("L").unwrap().floats, [5500.0]);
    assert_eq!(al.params.get_float("scale", 1.0).unwrap(), 10.0);
}

#[test]
fn media_before_the_camera_and_in_nested_blocks() {
    let s = parse(
        "MakeNamedMedium \"fog\"\n    \"string type\" [ \"homogeneous\" ]\n    \"float scale\" [ 0.0015 ]\n    \
         \"rgb sigma_s\" [ 1 1 1 ]\n\nMediumInterface \"\" \"fog\"\nCamera \"perspective\"\nWorldBegin\n\
         AttributeBegin\n    Transform [\n        0.5 0 0 0\n        0 0.5 0 0\n        0 0 0.5 0\n        1 2 3 1  ]\n\
         AttributeBegin\n    Translate -1.3000000000000007 0 -12.5\nMakeNamedMedium \"fog_0\"\n\
         \"string type\" [ \"homogeneous\" ]\n\"rgb sigma_s\" [ 3.0 3.0 3.0 ]\n    Material \"interface\"\n    \
         MediumInterface \"fog_0\" \"\"\n    Shape \"sphere\"\n        \"float radius\" [ 1.3 ]\nAttributeEnd\n\
         AttributeEnd\nShape \"sphere\"\n",
    );
    assert_eq!(s.camera.medium.as_deref(), Some("fog"));
    assert_eq!(s.media.len(), 2);
    assert_eq!((s.media[0].medium_name.as_str(), s.media[0].entity.name.as_str()), ("fog", "homogeneous"));
    assert_eq!(s.media[0].entity.params.get_float("scale", 1.0).unwrap(), 0.0015);
    // fog_0's medium-to-world: translate, then scale by 0.5, then move by (1, 2, 3).
    let m = s.media[1].render_from_medium;
    assert!(close(m.point(DVec3::ZERO), DVec3::new(1.0 + 0.5 * -1.3000000000000007, 2.0, 3.0 - 6.25)));
    let sphere = &s.shapes[0];
    assert_eq!((sphere.inside_medium.as_deref(), sphere.outside_medium.as_deref()), (Some("fog_0"), None));
    assert_eq!(s.material(&sphere.material).unwrap().name, "interface");
    // After the blocks: the camera's MediumInterface is in effect again (pbrt-v4 semantics).
    assert_eq!(s.shapes[1].outside_medium.as_deref(), Some("fog"));
    assert!(s.shapes[1].render_from_object.is_identity());
}

#[test]
fn objects_with_attribute_blocks_and_instances() {
    let s = parse(
        "WorldBegin\nAttributeBegin\nObjectBegin \"sphere\"\n    # sphere\n    AttributeBegin\n    \
         Material \"dielectric\"\n        \"bool remaproughness\" [ false ]\n        #\"float vroughness\" [ 0.01 ]\n\n        \
         Translate 186 90 168\n        Shape \"sphere\"\n            \"float radius\" [ 90 ]\n    AttributeEnd\n\
         ObjectEnd\nAttributeEnd\n\nAttributeBegin\n    ObjectInstance \"sphere\"\nAttributeEnd\n\nAttributeBegin\n    \
         Translate 180 0 180\n    ObjectInstance \"sphere\"\nAttributeEnd\nShape \"disk\"\n",
    );
    assert_eq!(s.objects.len(), 1);
    let o = &s.objects[0];
    assert_eq!(o.shapes.len(), 1);
    assert!(close(o.shapes[0].render_from_object.point(DVec3::ZERO), DVec3::new(186.0, 90.0, 168.0)));
    assert_eq!(s.material(&o.shapes[0].material).unwrap().name, "dielectric");
    assert_eq!(s.instances.len(), 2);
    assert!(s.instances[0].render_from_instance.is_identity());
    assert!(close(s.instances[1].render_from_instance.point(DVec3::ZERO), DVec3::new(180.0, 0.0, 180.0)));
    // The material set inside the object does not leak out.
    assert_eq!(s.shapes[0].material, MaterialRef::Anonymous(0));
}

#[test]
fn textures_mix_materials_and_odd_names() {
    let s = parse(
        "WorldBegin\nTexture \"arc-kd-img\" \"spectrum\" \"imagemap\"\n    \"string filename\" [ \"textures/Good \
         Textures_005844.tga\" ]\nTexture \"arc-kd\" \"spectrum\" \"scale\"\n    \"float scale\" [ 0.620968 ]\n    \
         \"texture tex\" [ \"arc-kd-img\" ]\nTexture \"bump_scale\" \"float\" \"constant\" \"float value\" [ 0.00019999999 ]\n\
         MakeNamedMaterial \"gold_base_mitra_border.png.002\" \"string type\" [ \"conductor\" ]\n\
         MakeNamedMaterial \"red\" \"string type\" \"coateddiffuse\" \"texture reflectance\" [ \"arc-kd\" ]\n\
         MakeNamedMaterial \"bl_clamp_a\"\n    \"string type\" [ \"mix\" ]\n    \
         \"string materials\" [ \"red\" \"gold_base_mitra_border.png.002\" ]\n    \"texture amount\" [ \"bump_scale\" ]\n\
         NamedMaterial \"bl_clamp_a\"\nShape \"sphere\"\n",
    );
    assert_eq!(s.textures.len(), 3);
    let img = &s.textures[0].entity.params;
    let file = img.get_filename("filename").unwrap().unwrap();
    assert!(file.ends_with("textures/Good Textures_005844.tga"), "{}", file.display());
    let scale = &s.textures[1];
    assert_eq!((scale.texture_name.as_str(), scale.entity.name.as_str()), ("arc-kd", "scale"));
    assert_eq!(scale.entity.params.get_texture("tex").as_deref(), Some("arc-kd-img"));
    assert_eq!(scale.entity.params.get_float("scale", 1.0).unwrap(), 0.620968);
    let mix = &s.named_materials[2].1;
    assert_eq!(mix.name, "mix");
    assert_eq!(mix.params.get_strings("materials").unwrap(), ["red", "gold_base_mitra_border.png.002"]);
    assert_eq!(s.material(&s.shapes[0].material).unwrap().name, "mix");
}

#[test]
fn reverse_orientation_and_an_infinite_light_under_a_transform() {
    let s = parse(
        "WorldBegin\nAttributeBegin\n    Transform [ 0 0 -1 0 1 0 0 0 0 1 0 0 0 0 0 1  ]\n    LightSource \"infinite\"\n\
                 \"float scale\" [0.1]\n        \"string filename\" \"textures/sky.exr\"\nAttributeEnd\nAttributeBegin\n    \
         AreaLightSource \"diffuse\"\n        \"rgb L\" [ 15.258819 12.083925 9.589462 ]\n    ReverseOrientation\n    \
         Shape \"trianglemesh\" \"point3 P\" [ 0 0 0 1 0 0 0 1 0 ]\nAttributeEnd\nShape \"sphere\"\n",
    );
    let l = &s.lights[0];
    assert_eq!(l.entity.params.get_float("scale", 1.0).unwrap(), 0.1);
    // Column-major: the columns are the images of x, y, z: x goes to −z, y to x, z to y.
    assert!(close(l.render_from_light.vector(DVec3::X), DVec3::NEG_Z));
    assert!(close(l.render_from_light.vector(DVec3::Z), DVec3::Y));
    assert!(s.shapes[0].reverse_orientation && s.shapes[0].area_light.is_some());
    assert!(!s.shapes[1].reverse_orientation && s.shapes[1].area_light.is_none());
}

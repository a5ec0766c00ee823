//! glTF files written here (JSON with the buffer as a data URI) against hand-written pbrt-v4 scenes, the
//! specification's units and its errors.

use std::path::{Path, PathBuf};

use base64::Engine;
use serde_json::{json, Value};

mod common;
use common::{dir, render, write};

/// Positions (f32 triples) and u32 indices as one little-endian buffer: (bytes, positions' length in bytes).
fn geometry(positions: &[[f32; 3]], indices: &[u32]) -> (Vec<u8>, usize) {
    let mut bytes = vec![];
    for p in positions {
        for c in p {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
    }
    let n = bytes.len();
    for i in indices {
        bytes.extend_from_slice(&i.to_le_bytes());
    }
    (bytes, n)
}

/// A glTF document with one mesh of `positions` and `indices` (material 0), with `extra` merged in at the top.
fn document(positions: &[[f32; 3]], indices: &[u32], extra: Value) -> Value {
    let (bytes, n) = geometry(positions, indices);
    let (lo, hi) = positions.iter().fold(([f32::MAX; 3], [f32::MIN; 3]), |(lo, hi), p| {
        ([lo[0].min(p[0]), lo[1].min(p[1]), lo[2].min(p[2])], [hi[0].max(p[0]), hi[1].max(p[1]), hi[2].max(p[2])])
    });
    let uri =
        format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&bytes));
    let mut doc = json!({
        "asset": { "version": "2.0" },
        "buffers": [ { "byteLength": bytes.len(), "uri": uri } ],
        "bufferViews": [
            { "buffer": 0, "byteOffset": 0, "byteLength": n },
            { "buffer": 0, "byteOffset": n, "byteLength": bytes.len() - n }
        ],
        "accessors": [
            { "bufferView": 0, "componentType": 5126, "count": positions.len(), "type": "VEC3", "min": lo, "max": hi },
            { "bufferView": 1, "componentType": 5125, "count": indices.len(), "type": "SCALAR" }
        ],
        "meshes": [ { "primitives": [ { "attributes": { "POSITION": 0 }, "indices": 1, "material": 0 } ] } ],
        "materials": [ { "pbrMetallicRoughness": { "baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0 } } ],
        "scene": 0,
        "scenes": [ { "nodes": [0] } ],
        "nodes": [ { "mesh": 0 } ]
    });
    merge(&mut doc, extra);
    doc
}

/// A glTF document with one mesh of two primitives over the same `positions`: indices `first` with material 0 and
/// `second` with material 1, with `extra` (the materials, cameras, nodes, …) merged in at the top.
fn two_primitives(positions: &[[f32; 3]], first: &[u32], second: &[u32], extra: Value) -> Value {
    let mut doc = document(positions, &[first, second].concat(), json!({}));
    let offset = first.len() * 4;
    doc["accessors"][1] =
        json!({ "bufferView": 1, "byteOffset": 0, "componentType": 5125, "count": first.len(), "type": "SCALAR" });
    doc["accessors"].as_array_mut().unwrap().push(
        json!({ "bufferView": 1, "byteOffset": offset, "componentType": 5125, "count": second.len(), "type": "SCALAR" }),
    );
    doc["meshes"] = json!([ { "primitives": [
        { "attributes": { "POSITION": 0 }, "indices": 1, "material": 0 },
        { "attributes": { "POSITION": 0 }, "indices": 2, "material": 1 }
    ] } ]);
    merge(&mut doc, extra);
    doc
}

/// Merges `extra` into `doc`: objects key by key, anything else replaced.
fn merge(doc: &mut Value, extra: Value) {
    match (doc, extra) {
        (Value::Object(a), Value::Object(b)) => {
            for (k, v) in b {
                merge(a.entry(k).or_insert(Value::Null), v);
            }
        }
        (a, b) => *a = b,
    }
}

/// Mean Y over blocks of `b`×`b` pixels.
fn blocks(film: &film::Film, b: u32) -> Vec<f64> {
    let (w, h) = (film.width(), film.height());
    let mut out = vec![];
    for by in 0..h / b {
        for bx in 0..w / b {
            let mut s = 0.0;
            for y in by * b..(by + 1) * b {
                for x in bx * b..(bx + 1) * b {
                    s += film.pixel_xyz(x, y).y;
                }
            }
            out.push(s / f64::from(b * b));
        }
    }
    out
}

/// An off-centre quad (to the right of and above the centre) lit by a sun shining along (0, -0.6, -0.8) (683 lx),
/// and a camera 5 m out on +z, in `d`.
fn quad_scene(d: &Path) -> PathBuf {
    let quad = [[0.2f32, 0.1, 0.0], [1.2, 0.1, 0.0], [1.2, 0.9, 0.0], [0.2, 0.9, 0.0]];
    let doc = document(
        &quad,
        &[0, 1, 2, 0, 2, 3],
        json!({
            "extensionsUsed": ["KHR_lights_punctual"],
            "extensions": { "KHR_lights_punctual": { "lights": [
                { "type": "directional", "intensity": 683.0, "color": [1.0, 1.0, 1.0] }
            ] } },
            "cameras": [ { "type": "perspective", "perspective": { "yfov": 0.6, "aspectRatio": 1.5, "znear": 0.1 } } ],
            "scenes": [ { "nodes": [0, 1, 2] } ],
            "nodes": [
                { "mesh": 0 },
                { "camera": 0, "translation": [0.0, 0.0, 5.0] },
                // The sun shines down its node's -Z: turned to point along (0, -0.6, -0.8) by a rotation about x.
                { "extensions": { "KHR_lights_punctual": { "light": 0 } }, "rotation": [-0.316_227_77, 0.0, 0.0, 0.948_683_3] }
            ]
        }),
    );
    write(d, "scene.gltf", &doc)
}

/// An off-centre quad (to the right of and above the centre), seen by a glTF camera 5 m out on +z
/// under a sun: the same image as the pbrt-v4 scene written with LookAt (no mirror, the same light, the same
/// material), block by block within the noise.
#[test]
fn a_gltf_scene_renders_as_the_same_pbrt_scene() {
    let d = dir("equivalent");
    let path = quad_scene(&d);
    let desc = gltf_import::read_scene(&path, &gltf_import::ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert!(desc.warnings.is_empty(), "{:?}", desc.warnings);
    let pbrt = format!(
        r#"Scale -1 1 1
LookAt 0 0 5  0 0 0  0 1 0
Camera "perspective" "float fov" {}
Film "rgb" "integer xresolution" 48 "integer yresolution" 32
WorldBegin
LightSource "distant" "point3 from" [ 0 0 0 ] "point3 to" [ 0 -0.6 -0.8 ] "rgb L" [ 1 1 1 ] "float scale" 1
Material "metallicroughness" "rgb basecolor" [ 0.8 0.8 0.8 ] "float metallic" 0 "float roughness" 1 "float ior" 1.5
Shape "trianglemesh" "point3 P" [ 0.2 0.1 0  1.2 0.1 0  1.2 0.9 0  0.2 0.9 0 ] "integer indices" [ 0 1 2 0 2 3 ]
"#,
        0.6f64.to_degrees()
    );
    let reference = pbrt::parse_str(&pbrt, &d.join("scene.pbrt")).unwrap_or_else(|e| panic!("{e}"));
    let (a, b) = (render(&desc, 16, (48, 32)), render(&reference, 16, (48, 32)));
    let (ba, bb) = (blocks(&a, 8), blocks(&b, 8));
    let lit = bb.iter().filter(|&&v| v > 0.01).count();
    assert!(lit >= 2 && lit < bb.len() / 2, "the quad covers a few blocks: {bb:?}");
    // Blocks of 8 pixels, 6 to a row, rows from the top: the quad is right of and above the centre (its mirror
    // image would light the second block of that row, not the fifth).
    assert!(bb[6 + 4] > 0.01 && bb[6 + 1] < 1e-6 && bb[0] < 1e-6, "{bb:?}");
    for (i, (x, y)) in ba.iter().zip(&bb).enumerate() {
        assert!((x - y).abs() <= 0.03 * y.max(0.01), "block {i}: glTF {x}, pbrt {y}");
    }
}

/// A Blender point light of P watts (exported as P·683/(4π) cd) lights a white diffuse plane at distance r with
/// irradiance P/(4π r²): the plane's radiance, seen head on, is that over π.
#[test]
fn a_point_light_of_p_watts_gives_the_irradiance_of_p_watts() {
    let d = dir("point");
    let (p_watts, r) = (100.0f64, 2.0f64);
    let plane = [[-0.05f32, -0.05, 0.0], [0.05, -0.05, 0.0], [0.05, 0.05, 0.0], [-0.05, 0.05, 0.0]];
    let doc = document(
        &plane,
        &[0, 1, 2, 0, 2, 3],
        json!({
            "extensionsUsed": ["KHR_lights_punctual"],
            "extensions": { "KHR_lights_punctual": { "lights": [
                { "type": "point", "intensity": p_watts * 683.0 / (4.0 * std::f64::consts::PI) }
            ] } },
            "materials": [ { "pbrMetallicRoughness": { "baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0 } } ],
            "cameras": [ { "type": "perspective", "perspective": { "yfov": 0.01, "aspectRatio": 1.0, "znear": 0.1 } } ],
            "scenes": [ { "nodes": [0, 1, 2] } ],
            "nodes": [ { "mesh": 0 }, { "camera": 0, "translation": [0.0, 0.0, 3.0] }, { "extensions": { "KHR_lights_punctual": { "light": 0 } }, "translation": [0.0, 0.0, r] } ]
        }),
    );
    let path = write(&d, "point.gltf", &doc);
    let mut desc = gltf_import::read_scene(&path, &gltf_import::ReadOptions::default()).unwrap();
    // The diffuse reference: a white Lambertian plane (the metallic-roughness base has a specular layer too).
    let loc = desc.named_materials[0].1.loc.clone();
    let mut white = scene::Param::new(scene::ParamType::Rgb, "reflectance", loc.clone());
    white.floats = vec![1.0, 1.0, 1.0];
    desc.named_materials[0].1 = scene::Entity::new("diffuse", scene::ParamSet::from_params(vec![white]), loc);
    let film = render(&desc, 64, (8, 8));
    let y: f64 =
        (0..8).flat_map(|y| (0..8).map(move |x| (x, y))).map(|(x, y)| film.pixel_xyz(x, y).y).sum::<f64>() / 64.0;
    let want = p_watts / (4.0 * std::f64::consts::PI * r * r) / std::f64::consts::PI;
    assert!((y / want - 1.0).abs() < 0.01, "radiance {y}, P/(4π² r²) = {want}");
}

/// Transmission with dispersion becomes a dielectric of index n_d = ior and Abbe number 20/dispersion; volume
/// attenuation an absorbing medium inside the shape with σa = −ln(colour)/distance.
#[test]
fn glass_dispersion_and_volume_map_to_the_abbe_model_and_beer_lambert() {
    let d = dir("glass");
    let doc = document(
        &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        &[0, 1, 2],
        json!({
            "extensionsUsed": ["KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_dispersion", "KHR_materials_volume"],
            "materials": [ {
                "pbrMetallicRoughness": { "metallicFactor": 0.0, "roughnessFactor": 0.0 },
                "extensions": {
                    "KHR_materials_transmission": { "transmissionFactor": 1.0 },
                    "KHR_materials_ior": { "ior": 1.7847 },
                    "KHR_materials_dispersion": { "dispersion": 20.0 / 25.68 },
                    "KHR_materials_volume": { "attenuationColor": [0.5, 0.25, 1.0], "attenuationDistance": 2.0 }
                }
            } ]
        }),
    );
    let path = write(&d, "glass.gltf", &doc);
    let desc = gltf_import::read_scene(&path, &gltf_import::ReadOptions::default()).unwrap();
    let (_, glass) = &desc.named_materials[0];
    assert_eq!(glass.name, "dielectric");
    assert_eq!(glass.params.get_float("eta", 0.0).unwrap() as f32, 1.7847f32);
    assert!((glass.params.get_float("abbe", 0.0).unwrap() - 25.68).abs() < 1e-5);
    let medium = &desc.media[0];
    let sigma = &medium.entity.params.get("sigma_a").expect("sigma_a").floats;
    for (s, c) in sigma.iter().zip([0.5f64, 0.25, 1.0]) {
        assert!((s - (-(c as f32 as f64).ln() / 2.0)).abs() < 1e-6, "{sigma:?}");
    }
    assert_eq!(desc.shapes[0].inside_medium.as_deref(), Some(medium.medium_name.as_str()));
    // Partial transmission on a half-metallic material: the dielectric part's share, transmission × (1 − metallic),
    // picks the glass in a mix with the opaque material.
    let mut partial = doc.clone();
    partial["materials"][0]["pbrMetallicRoughness"]["metallicFactor"] = json!(0.5);
    partial["materials"][0]["extensions"]["KHR_materials_transmission"]["transmissionFactor"] = json!(0.4);
    let p = gltf_import::read_scene(&write(&d, "partial.gltf", &partial), &Default::default()).unwrap();
    let (name, mix) = p.named_materials.last().unwrap();
    assert_eq!(mix.name, "mix");
    assert!((mix.params.get_float("amount", 0.0).unwrap() - 0.2).abs() < 1e-6);
    let parts = mix.params.get_strings("materials").unwrap();
    assert_eq!(parts, [format!("{name}/opaque"), format!("{name}/transmission")]);
    // n(λ) through the builder is the Abbe model `prismatic ior` prints for 1.7847/25.68.
    let built = render::build_scene(&desc, &render::BuildOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    // Only the warning that the file has no camera: every parameter written was read.
    assert!(built.warnings.len() == 1 && built.warnings[0].contains("no camera"), "{:?}", built.warnings);
}

#[test]
fn bad_files_are_errors_that_name_the_json_path() {
    let d = dir("bad");
    let tri = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let read = |name: &str, doc: &Value| {
        let path = write(&d, name, doc);
        gltf_import::read_scene(&path, &gltf_import::ReadOptions::default()).map(|_| ())
    };
    let e = read("required.gltf", &document(&tri, &[0, 1, 2], json!({ "extensionsRequired": ["KHR_draco_mesh_compression"], "extensionsUsed": ["KHR_draco_mesh_compression"] }))).unwrap_err();
    assert!(
        e.to_string().contains("extensionsRequired") && e.to_string().contains("KHR_draco_mesh_compression"),
        "{e}"
    );
    // A KTX2 texture has no `source` for the crate's validation to find: the missing extension is the error.
    let basisu = json!({
        "extensionsRequired": ["KHR_texture_basisu"], "extensionsUsed": ["KHR_texture_basisu"],
        "images": [ { "uri": "t.ktx2", "mimeType": "image/ktx2" } ],
        "textures": [ { "extensions": { "KHR_texture_basisu": { "source": 0 } } } ],
        "materials": [ { "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } } ]
    });
    let e = read("basisu.gltf", &document(&tri, &[0, 1, 2], basisu)).unwrap_err();
    assert!(
        e.path == "extensionsRequired" && e.message.contains("'KHR_texture_basisu' is required but not supported"),
        "{e}"
    );
    let e = read("index.gltf", &document(&tri, &[0, 1, 7], json!({}))).unwrap_err();
    assert_eq!(e.path, "meshes[0].primitives[0].indices", "{e}");
    assert!(e.message.contains("index 7"), "{e}");
    let mut short = document(&tri, &[0, 1, 2], json!({}));
    short["accessors"][0]["count"] = json!(30);
    let e = read("short.gltf", &short).unwrap_err();
    assert!(e.to_string().contains("accessors") || e.path.contains("POSITION"), "{e}");
    let cycle = document(&tri, &[0, 1, 2], json!({ "nodes": [ { "mesh": 0, "children": [1] }, { "children": [0] } ] }));
    assert!(read("cycle.gltf", &cycle).is_err());
    let nan = document(
        &tri,
        &[0, 1, 2],
        json!({ "nodes": [ { "mesh": 0, "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1] } ] }),
    );
    read("fine.gltf", &nan).unwrap();
    // Found by fuzzing: a POSITION naming an accessor that does not exist (the gltf crate's validation indexed
    // out of bounds), and float indices (its index reader assumed integers).
    let mut missing = document(&tri, &[0, 1, 2], json!({}));
    missing["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(9);
    let e = read("missing-accessor.gltf", &missing).unwrap_err();
    assert_eq!(e.path, "meshes[0].primitives[0].attributes.POSITION", "{e}");
    let mut float_indices = document(&tri, &[0, 1, 2], json!({}));
    float_indices["accessors"][1]["componentType"] = json!(5126);
    let e = read("float-indices.gltf", &float_indices).unwrap_err();
    assert_eq!(e.path, "meshes[0].primitives[0].indices", "{e}");
    // Also found by fuzzing: an accessor of no elements (the gltf crate computes count − 1).
    let mut empty = document(&tri, &[0, 1, 2], json!({}));
    empty["accessors"][1]["count"] = json!(0);
    let e = read("empty-accessor.gltf", &empty).unwrap_err();
    assert!(e.path == "meshes[0].primitives[0].indices" && e.message.contains("at least one"), "{e}");
    // And images without a source, or in a buffer view without a MIME type (the gltf crate unwraps both).
    for image in [json!({ "name": "nothing" }), json!({ "bufferView": 0 })] {
        let doc = document(&tri, &[0, 1, 2], json!({ "images": [image] }));
        let e = read("no-source.gltf", &doc).unwrap_err();
        assert_eq!(e.path, "images[0]", "{e}");
    }
    // And a GLB header whose length is shorter than the header.
    std::fs::write(d.join("short.glb"), b"glTF\x02\0\0\0\x04\0\0\0").unwrap();
    let e = gltf_import::read_scene(&d.join("short.glb"), &Default::default()).unwrap_err();
    assert!(e.message.contains("GLB header"), "{e}");
    // A buffer naming an endless file is read only to its declared length (not until memory runs out): here that
    // gives zeros, so the file reads (a triangle at the origin), and a length past 2 GiB is refused.
    let mut endless = document(&tri, &[0, 1, 2], json!({}));
    endless["buffers"][0]["uri"] = json!("/dev/zero");
    read("endless.gltf", &endless).unwrap();
    let mut short_file = document(&tri, &[0, 1, 2], json!({}));
    short_file["buffers"][0]["uri"] = json!("/dev/null");
    let e = read("short-file.gltf", &short_file).unwrap_err();
    assert!(e.path == "buffers[0]" && e.message.contains("fewer than its byteLength"), "{e}");
    std::fs::write(d.join("broken.gltf"), b"{ \"asset\": ").unwrap();
    assert!(gltf_import::read_scene(&d.join("broken.gltf"), &Default::default()).is_err());
    let e = gltf_import::read_scene(
        &write(&d, "cams.gltf", &document(&tri, &[0, 1, 2], json!({}))),
        &gltf_import::ReadOptions { camera: Some("front".into()) },
    )
    .unwrap_err();
    assert!(e.message.contains("no camera named or numbered 'front'"), "{e}");
}

/// `Import "scene.gltf"` in a pbrt-v4 file (Prismatic's extension) brings the glTF's meshes, materials and lights
/// in under the current transform: the same image as the quad written in pbrt-v4 syntax, moved the same way.
#[test]
fn a_pbrt_file_imports_a_gltf_file_under_its_transform() {
    let d = dir("import");
    quad_scene(&d);
    let scene = |content: &str| {
        format!(
            "Scale -1 1 1\nLookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 34.377\n\
             Film \"rgb\" \"integer xresolution\" 48 \"integer yresolution\" 32\nWorldBegin\n\
             AttributeBegin\nTranslate -1.2 -0.9 0\n{content}\nAttributeEnd\n"
        )
    };
    let imported =
        pbrt::parse_str(&scene("Import \"scene.gltf\""), &d.join("main.pbrt")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(imported.files.iter().filter(|f| f.ends_with("scene.gltf")).count(), 1, "{:?}", imported.files);
    let written = pbrt::parse_str(
        &scene(
            "LightSource \"distant\" \"point3 from\" [ 0 0 0 ] \"point3 to\" [ 0 -0.6 -0.8 ] \"rgb L\" [ 1 1 1 ]\n\
             Material \"metallicroughness\" \"rgb basecolor\" [ 0.8 0.8 0.8 ] \"float metallic\" 0\n\
             Shape \"trianglemesh\" \"point3 P\" [ 0.2 0.1 0  1.2 0.1 0  1.2 0.9 0  0.2 0.9 0 ] \"integer indices\" [ 0 1 2 0 2 3 ]",
        ),
        &d.join("written.pbrt"),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let (a, b) = (render(&imported, 16, (48, 32)), render(&written, 16, (48, 32)));
    let (ba, bb) = (blocks(&a, 8), blocks(&b, 8));
    // Moved left and down by the quad's own far corner: now left of and below the centre.
    assert!(bb[2 * 6 + 1] > 0.01 && bb[6 + 4] < 1e-6, "{bb:?}");
    for (i, (x, y)) in ba.iter().zip(&bb).enumerate() {
        assert!((x - y).abs() <= 0.03 * y.max(0.01), "block {i}: imported {x}, written {y}");
    }
    // A file that is not there is an error at the Import.
    let e = pbrt::parse_str(&scene("Import \"missing.glb\""), &d.join("main.pbrt")).unwrap_err();
    assert!(e.loc.line == 8 && e.to_string().contains("missing.glb"), "{e}");
}

/// alphaMode with the base colour's alpha: BLEND lets the light through in proportion (pbrt's stochastic alpha),
/// MASK keeps or drops the surface at the cutoff, OPAQUE ignores alpha.
#[test]
fn alpha_modes_cut_out_and_blend() {
    let d = dir("alpha");
    // A blocker between a sun and a white floor: how much light reaches the floor under it.
    let floor_and_blocker = |mode: &str, alpha: f64| {
        let positions = [
            [-2.0f32, 0.0, -2.0],
            [2.0, 0.0, -2.0],
            [2.0, 0.0, 2.0],
            [-2.0, 0.0, 2.0],
            [-3.0, 1.0, -3.0],
            [3.0, 1.0, -3.0],
            [3.0, 1.0, 3.0],
            [-3.0, 1.0, 3.0],
        ];
        let doc = two_primitives(
            &positions,
            &[0, 2, 1, 0, 3, 2],
            &[4, 6, 5, 4, 7, 6],
            json!({
                "materials": [
                    { "pbrMetallicRoughness": { "baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0 } },
                    { "pbrMetallicRoughness": { "baseColorFactor": [0, 0, 0, alpha], "metallicFactor": 0.0 }, "alphaMode": mode, "alphaCutoff": 0.5 }
                ],
                "extensionsUsed": ["KHR_lights_punctual"],
                "extensions": { "KHR_lights_punctual": { "lights": [ { "type": "directional", "intensity": 683.0 } ] } },
                "cameras": [ { "type": "perspective", "perspective": { "yfov": 0.2, "aspectRatio": 1.0, "znear": 0.01 } } ],
                "scene": 0,
                "scenes": [ { "nodes": [0, 1, 2] } ],
                "nodes": [
                    { "mesh": 0 },
                    // Below the blocker, looking straight down at the floor.
                    { "camera": 0, "translation": [0.0, 0.5, 0.0], "rotation": [-0.707_106_77, 0.0, 0.0, 0.707_106_77] },
                    { "extensions": { "KHR_lights_punctual": { "light": 0 } }, "rotation": [-0.707_106_77, 0.0, 0.0, 0.707_106_77] }
                ]
            }),
        );
        let path = write(&d, &format!("{mode}-{alpha}.gltf"), &doc);
        let desc =
            gltf_import::read_scene(&path, &gltf_import::ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        let film = render(&desc, 64, (4, 4));
        (0..4).flat_map(|y| (0..4).map(move |x| (x, y))).map(|(x, y)| film.pixel_xyz(x, y).y).sum::<f64>() / 16.0
    };
    let open = floor_and_blocker("MASK", 0.2);
    assert!(open > 0.1, "a masked-out blocker lets the sun through: {open}");
    assert!(floor_and_blocker("MASK", 0.7) < 1e-4 * open, "kept at the cutoff");
    assert!(floor_and_blocker("OPAQUE", 0.2) < 1e-4 * open, "opaque ignores alpha");
    let blend = floor_and_blocker("BLEND", 0.3);
    assert!((blend / open - 0.7).abs() < 0.05, "BLEND at alpha 0.3 lets 70% through: {}", blend / open);
}

/// The gallery's diamond as Blender built and exported it (`scenes/tools/gltf_scenes.py`): its camera, its
/// dispersive glass (n_d 2.4175, V_d 55.3) and emissive softboxes are read, and its fire comes from dispersion: the
/// image is several times more colourful than with the same glass without dispersion.
#[test]
fn the_blender_diamond_has_fire_from_dispersion() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/gltf/gem.glb");
    let mut desc =
        gltf_import::read_scene(&path, &gltf_import::ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert!(desc.warnings.is_empty(), "{:?}", desc.warnings);
    assert!((desc.camera.entity.params.get_float("fov", 0.0).unwrap() - 18.0).abs() < 1e-4);
    desc.integrator = pbrt::parse_integrator("\"path\" \"integer maxdepth\" 20", Path::new("test")).unwrap();
    let glass = desc.named_materials.iter().position(|(_, m)| m.name == "dielectric").expect("the diamond's glass");
    let m = &desc.named_materials[glass].1;
    assert!((m.params.get_float("eta", 0.0).unwrap() - 2.4175).abs() < 1e-6);
    assert!((m.params.get_float("abbe", 0.0).unwrap() - 55.3).abs() < 1e-3);
    // Colourfulness: the mean spread of each pixel's linear RGB channels.
    let colourfulness = |desc: &scene::SceneDescription| {
        let film = render(desc, 32, (112, 84));
        let rgb = film.to_rgb_image();
        rgb.iter().map(|p| (p[0].max(p[1]).max(p[2]) - p[0].min(p[1]).min(p[2])) as f64).sum::<f64>() / rgb.len() as f64
    };
    let fire = colourfulness(&desc);
    let params = desc.named_materials[glass].1.params.params().iter().filter(|p| p.name != "abbe").cloned().collect();
    desc.named_materials[glass].1.params = scene::ParamSet::from_params(params);
    let plain = colourfulness(&desc);
    assert!(fire > 3.0 * plain && fire > 0.01, "colourfulness with dispersion {fire}, without {plain}");
}

/// `--env`'s light: a latitude–longitude map whose upper half is white and lower half black lights a glTF scene
/// from above (+y), its top row turned from pbrt's +z to glTF's up.
#[test]
fn an_environment_map_has_its_top_towards_gltf_up() {
    let d = dir("env");
    // PFM, 8×4, rows written bottom to top: the two bottom rows black, the two top rows white.
    let mut pfm = b"PF\n8 4\n-1.0\n".to_vec();
    for row in 0..4 {
        for _ in 0..8 {
            let v: f32 = if row >= 2 { 1.0 } else { 0.0 };
            for _ in 0..3 {
                pfm.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    let env = d.join("sky.pfm");
    std::fs::write(&env, pfm).unwrap();
    // The same sky as a Radiance HDR (rows from the top, flat RGBE pixels): (127 + ½)·2^(129 − 136) ≈ 0.996.
    let mut rgbe = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 4 +X 8\n".to_vec();
    for row in 0..4 {
        for _ in 0..8 {
            rgbe.extend(if row < 2 { [127, 127, 127, 129] } else { [0, 0, 0, 0] });
        }
    }
    let hdr = d.join("sky.hdr");
    std::fs::write(&hdr, rgbe).unwrap();
    let look = |env: &Path, rotation: [f64; 4]| {
        let doc = document(
            &[[100.0f32, 100.0, 100.0], [100.1, 100.0, 100.0], [100.0, 100.1, 100.0]],
            &[0, 1, 2],
            json!({
                "cameras": [ { "type": "perspective", "perspective": { "yfov": 0.3, "aspectRatio": 1.0, "znear": 0.01 } } ],
                "scenes": [ { "nodes": [0, 1] } ],
                "nodes": [ { "mesh": 0 }, { "camera": 0, "rotation": rotation } ]
            }),
        );
        let path = write(&d, "env.gltf", &doc);
        let mut desc = gltf_import::read_scene(&path, &gltf_import::ReadOptions::default()).unwrap();
        desc.lights.push(gltf_import::environment_light(env, 1.0, true));
        let film = render(&desc, 4, (4, 4));
        (0..4).flat_map(|y| (0..4).map(move |x| (x, y))).map(|(x, y)| film.pixel_xyz(x, y).y).sum::<f64>() / 16.0
    };
    let h = std::f64::consts::FRAC_1_SQRT_2;
    for (sky, white) in [(&env, 1.0), (&hdr, 127.5 / 128.0)] {
        let (up, down) = (look(sky, [h, 0.0, 0.0, h]), look(sky, [-h, 0.0, 0.0, h]));
        assert!((up - white).abs() < 0.02 * white && down < 1e-6, "{}: looking up {up}, down {down}", sky.display());
    }
}

/// KHR_materials_transmission multiplies the transmitted light by the base colour at each crossing: a grey base
/// colour g seen through a glass slab (in and out: two crossings) against an emitter dims it by g². (Russian
/// roulette, which follows the path's throughput, makes the ratio statistical: 256 samples in each of 64 pixels
/// give it to about 0.7%, and 3% is allowed.)
#[test]
fn transmission_is_tinted_by_the_base_colour_at_each_crossing() {
    let d = dir("tint");
    let mut positions = vec![];
    for z in [-0.5f32, 0.5] {
        for (x, y) in [(-1.0f32, -1.0f32), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            positions.push([x, y, z]);
        }
    }
    positions.extend([[-3.0f32, -3.0, -2.0], [3.0, -3.0, -2.0], [3.0, 3.0, -2.0], [-3.0, 3.0, -2.0]]);
    // The slab's six faces wound outwards, then the emitter facing +z.
    let slab: [u32; 36] =
        [0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4, 1, 2, 6, 1, 6, 5, 2, 3, 7, 2, 7, 6, 3, 0, 4, 3, 4, 7];
    let render_grey = |g: f64| {
        let doc = two_primitives(
            &positions,
            &slab,
            &[8, 9, 10, 8, 10, 11],
            json!({
                "extensionsUsed": ["KHR_materials_transmission", "KHR_materials_ior"],
                "materials": [
                    { "pbrMetallicRoughness": { "baseColorFactor": [g, g, g, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.0 },
                      "extensions": { "KHR_materials_transmission": { "transmissionFactor": 1.0 }, "KHR_materials_ior": { "ior": 1.5 } } },
                    { "pbrMetallicRoughness": { "baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0 }, "emissiveFactor": [1.0, 1.0, 1.0] }
                ],
                "cameras": [ { "type": "perspective", "perspective": { "yfov": 0.2, "aspectRatio": 1.0, "znear": 0.01 } } ],
                "scene": 0,
                "scenes": [ { "nodes": [0, 1] } ],
                "nodes": [ { "mesh": 0 }, { "camera": 0, "translation": [0.0, 0.0, 5.0] } ]
            }),
        );
        let path = write(&d, &format!("tint-{g}.gltf"), &doc);
        let desc =
            gltf_import::read_scene(&path, &gltf_import::ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        let film = render(&desc, 256, (8, 8));
        (0..8).flat_map(|y| (0..8).map(move |x| (x, y))).map(|(x, y)| film.pixel_xyz(x, y).y).sum::<f64>() / 64.0
    };
    let (clear, grey) = (render_grey(1.0), render_grey(0.5));
    // Through two faces of n = 1.5 at normal incidence: (1 − 0.04)² of the emitter's 1, and more by internal
    // reflections; nothing else reaches the camera (the front face reflects black).
    assert!(clear > 0.9 && clear < 1.0, "the clear slab transmits {clear}");
    assert!(
        (grey / clear - 0.25).abs() < 0.03 * 0.25,
        "a base colour of 0.5 transmits 0.5² = 0.25 of it: {}",
        grey / clear
    );
}

/// Blender's exporter writes the Principled BSDF's Coat, Sheen, Thin Film and Specular Tint as the four layer
/// extensions, and the reader gives them to the `metallicroughness` material with the values set in Blender
/// (through the exporter's conversions: Specular IOR Level 0.3 is specularFactor 0.6, Sheen Weight × Sheen Tint the
/// sheen colour, Thin Film Thickness the film's maximum thickness), without a warning. Rendered, the thin film
/// colours the white metal: its plate is ten times as colourful as the same plate without the film.
#[test]
fn blenders_coat_sheen_thin_film_and_specular_tint_are_read() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/layered-plates.glb");
    let mut desc =
        gltf_import::read_scene(&path, &gltf_import::ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert!(desc.warnings.is_empty(), "{:?}", desc.warnings);
    let with = |param: &str| {
        let m = desc.named_materials.iter().find(|(_, m)| m.params.contains(param));
        m.map(|(_, m)| m.params.clone()).unwrap_or_else(|| panic!("no material with '{param}'"))
    };
    let near = |a: f64, b: f64| (a - b).abs() < 1e-6;
    let near3 = |a: [f64; 3], b: [f64; 3]| a.iter().zip(&b).all(|(x, y)| near(*x, *y));
    let coat = with("clearcoat");
    assert!(near(coat.get_float("clearcoat", 0.0).unwrap(), 1.0));
    assert!(near(coat.get_float("clearcoatroughness", 0.0).unwrap(), 0.1));
    let sheen = with("sheencolor");
    assert!(near3(sheen.get_rgb("sheencolor").unwrap().unwrap(), [0.9, 0.8, 0.7]));
    assert!(near(sheen.get_float("sheenroughness", 0.0).unwrap(), 0.4));
    let film = with("iridescence");
    assert!(near(film.get_float("iridescence", 0.0).unwrap(), 1.0));
    assert!(near(film.get_float("iridescenceeta", 0.0).unwrap(), 1.35));
    assert!(near(film.get_float("iridescencethickness", 0.0).unwrap(), 350.0));
    assert!(near(film.get_float("metallic", 0.0).unwrap(), 1.0));
    let specular = with("specular");
    assert!(near(specular.get_float("specular", 0.0).unwrap(), 0.6));
    assert!(near3(specular.get_rgb("specularcolor").unwrap().unwrap(), [1.0, 0.6, 0.3]));
    // The film's plate is the third of four across the 128-pixel-wide image; its colourfulness is the spread of
    // its mean linear RGB over the mean (the mean, so that the spectral sampling's colour noise averages out).
    let colourfulness = |desc: &scene::SceneDescription| {
        let film = render(desc, 16, (128, 32));
        let rgb = film.to_rgb_image();
        let mut mean = [0.0f64; 3];
        for y in 8..24 {
            for x in 70..90 {
                for (m, c) in mean.iter_mut().zip(rgb[y * 128 + x]) {
                    *m += f64::from(c);
                }
            }
        }
        let (hi, lo) = (mean.iter().fold(0.0f64, |a, &b| a.max(b)), mean.iter().fold(f64::MAX, |a, &b| a.min(b)));
        (hi - lo) / (mean.iter().sum::<f64>() / 3.0)
    };
    let coloured = colourfulness(&desc);
    let i = desc.named_materials.iter().position(|(_, m)| m.params.contains("iridescence")).unwrap();
    let params =
        desc.named_materials[i].1.params.params().iter().filter(|p| p.name != "iridescence").cloned().collect();
    desc.named_materials[i].1.params = scene::ParamSet::from_params(params);
    let plain = colourfulness(&desc);
    assert!(coloured > 10.0 * plain && coloured > 0.05, "colourfulness with the film {coloured}, without {plain}");
}

/// The layer extensions' values and texture references are checked: a wrong type or range, or a texture index
/// past the file's textures, is an error naming its JSON path.
#[test]
fn bad_layer_extensions_are_errors_that_name_the_json_path() {
    let d = dir("bad-layers");
    let tri = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    for (ext, value, path) in [
        ("KHR_materials_clearcoat", json!({ "clearcoatFactor": "x" }), "clearcoatFactor"),
        ("KHR_materials_anisotropy", json!({ "anisotropyStrength": 2 }), "anisotropyStrength"),
        ("KHR_materials_anisotropy", json!({ "anisotropyRotation": "x" }), "anisotropyRotation"),
        (
            "KHR_materials_anisotropy",
            json!({ "anisotropyStrength": 0.5, "anisotropyTexture": { "index": 9 } }),
            "anisotropyTexture.index",
        ),
        ("KHR_materials_clearcoat", json!({ "clearcoatFactor": 1.5 }), "clearcoatFactor"),
        ("KHR_materials_sheen", json!({ "sheenColorFactor": [1, 0] }), "sheenColorFactor"),
        ("KHR_materials_specular", json!({ "specularColorFactor": [1, -1, 0] }), "specularColorFactor"),
        ("KHR_materials_iridescence", json!({ "iridescenceFactor": 1, "iridescenceIor": 0.5 }), "iridescenceIor"),
        (
            "KHR_materials_iridescence",
            json!({ "iridescenceFactor": 1, "iridescenceThicknessMaximum": -1 }),
            "iridescenceThicknessMaximum",
        ),
        (
            "KHR_materials_clearcoat",
            json!({ "clearcoatFactor": 1, "clearcoatTexture": { "index": 3 } }),
            "clearcoatTexture.index",
        ),
        ("KHR_materials_specular", json!({ "specularTexture": { "index": 0 } }), "specularTexture.index"),
        ("KHR_materials_sheen", json!(7), ""),
    ] {
        let material = json!({ "materials": [ { "extensions": { ext: value } } ] });
        let p = write(&d, "bad.gltf", &document(&tri, &[0, 1, 2], material));
        let e = gltf_import::read_scene(&p, &gltf_import::ReadOptions::default()).unwrap_err();
        let want = if path.is_empty() {
            format!("materials[0].extensions.{ext}")
        } else {
            format!("materials[0].extensions.{ext}.{path}")
        };
        assert_eq!(e.path, want, "{e}");
    }
}

/// EXT_meshopt_compression: the quad scene with its positions (exponential filter) and indices (triangle codec)
/// compressed by meshoptimizer's own encoders into buffer 0, decoded into a placeholder buffer, renders bit for bit
/// as the uncompressed file. The same views with the file's uncompressed data still present are read from it.
/// Malformed extension objects are errors naming the JSON path.
#[test]
fn meshopt_compressed_views_render_as_the_uncompressed_file() {
    let d = dir("meshopt");
    let plain_path = quad_scene(&d);
    let plain: Value = serde_json::from_slice(&std::fs::read(&plain_path).unwrap()).unwrap();
    let quad = [[0.2f32, 0.1, 0.0], [1.2, 0.1, 0.0], [1.2, 0.9, 0.0], [0.2, 0.9, 0.0]];
    let indices = [0u32, 1, 2, 0, 2, 3];
    // Exponential filter with a 24-bit mantissa: these coordinates survive exactly.
    let filtered: Vec<[u32; 3]> = meshopt::encode_filter_exp(&quad, 24, meshopt::EncodeExpMode::Separate);
    let positions = meshopt::encode_vertex_buffer(&filtered).unwrap();
    let tris = meshopt::encode_index_buffer(&indices, 4).unwrap();
    let mut compressed = positions.clone();
    compressed.extend_from_slice(&tris);
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&compressed)
    );
    let mut doc = plain.clone();
    doc["extensionsUsed"] = json!(["KHR_lights_punctual", "EXT_meshopt_compression"]);
    doc["extensionsRequired"] = json!(["EXT_meshopt_compression"]);
    let placeholder = json!({ "byteLength": 72, "extensions": { "EXT_meshopt_compression": { "fallback": true } } });
    doc["buffers"] = json!([ { "byteLength": compressed.len(), "uri": uri }, placeholder ]);
    doc["bufferViews"] = json!([
        { "buffer": 1, "byteOffset": 0, "byteLength": 48, "extensions": { "EXT_meshopt_compression": {
            "buffer": 0, "byteOffset": 0, "byteLength": positions.len(), "byteStride": 12, "count": 4,
            "mode": "ATTRIBUTES", "filter": "EXPONENTIAL" } } },
        { "buffer": 1, "byteOffset": 48, "byteLength": 24, "extensions": { "EXT_meshopt_compression": {
            "buffer": 0, "byteOffset": positions.len(), "byteLength": tris.len(), "byteStride": 4, "count": 6,
            "mode": "TRIANGLES" } } }
    ]);
    let read = |name: &str, doc: &Value| gltf_import::read_scene(&write(&d, name, doc), &Default::default());
    let want = render(&gltf_import::read_scene(&plain_path, &Default::default()).unwrap(), 4, (48, 32));
    let desc = read("compressed.gltf", &doc).unwrap_or_else(|e| panic!("{e}"));
    assert!(desc.warnings.is_empty(), "{:?}", desc.warnings);
    let got = render(&desc, 4, (48, 32));
    assert!(blocks(&want, 8).iter().any(|&v| v > 0.01), "the quad is lit");
    for y in 0..32 {
        for x in 0..48 {
            assert_eq!(got.pixel_xyz(x, y), want.pixel_xyz(x, y), "pixel ({x}, {y})");
        }
    }
    // With the uncompressed data in a real buffer 1, the views read it (the compressed bytes are not decoded:
    // here they are garbage, which decoding would refuse).
    let mut with_fallback = doc.clone();
    with_fallback["buffers"][1] = plain["buffers"][0].clone();
    with_fallback["buffers"][0]["uri"] = json!(format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(vec![0xabu8; compressed.len()])
    ));
    let got = render(&read("fallback.gltf", &with_fallback).unwrap_or_else(|e| panic!("{e}")), 4, (48, 32));
    assert_eq!(got.pixel_xyz(30, 10), want.pixel_xyz(30, 10));
    let at = "bufferViews[0].extensions.EXT_meshopt_compression";
    for (key, value, path) in [
        ("count", json!(5), format!("{at}.count")),
        ("mode", json!("SPIRAL"), format!("{at}.mode")),
        ("filter", json!("OCTAHEDRAL"), format!("{at}.filter")),
        ("byteStride", json!(6), format!("{at}.byteStride")),
        ("byteLength", json!(1), at.to_string()),
        ("buffer", json!(9), format!("{at}.buffer")),
    ] {
        let mut bad = doc.clone();
        bad["bufferViews"][0]["extensions"]["EXT_meshopt_compression"][key] = value;
        if key == "byteStride" {
            bad["bufferViews"][0]["extensions"]["EXT_meshopt_compression"]["count"] = json!(8);
        }
        let e = read("bad.gltf", &bad).unwrap_err();
        assert_eq!(e.path, path, "{key}: {e}");
    }
    // A view claiming far more data than its compressed bytes can hold is refused before anything is allocated.
    let mut huge = doc.clone();
    huge["buffers"][1]["byteLength"] = json!(12_000_024u64);
    huge["bufferViews"][0]["byteLength"] = json!(12_000_000u64);
    huge["bufferViews"][0]["extensions"]["EXT_meshopt_compression"]["count"] = json!(1_000_000);
    let e = read("huge.gltf", &huge).unwrap_err();
    assert!(e.path == format!("{at}.byteLength") && e.message.contains("cannot come out of"), "{e}");
}

/// Blender's exporter writes the Principled BSDF's Anisotropic and Anisotropic Rotation (in turns) as
/// KHR_materials_anisotropy's strength and rotation (radians); the reader gives them to the material without a
/// warning, and they change the rendered plate under the tilted sun.
#[test]
fn blenders_anisotropy_is_read() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/brushed-plate.glb");
    let mut desc =
        gltf_import::read_scene(&path, &gltf_import::ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert!(desc.warnings.is_empty(), "{:?}", desc.warnings);
    let i = desc.named_materials.iter().position(|(_, m)| m.params.contains("anisotropy")).expect("anisotropy");
    let params = desc.named_materials[i].1.params.clone();
    assert!((params.get_float("anisotropy", 0.0).unwrap() - 0.8).abs() < 1e-6);
    assert!((params.get_float("anisotropyrotation", 0.0).unwrap() - 0.2 * std::f64::consts::PI).abs() < 1e-6);
    let mean_y = |desc: &scene::SceneDescription| {
        let film = render(desc, 16, (32, 32));
        (8..24).flat_map(|y| (8..24).map(move |x| (x, y))).map(|(x, y)| film.pixel_xyz(x, y).y).sum::<f64>() / 256.0
    };
    let brushed = mean_y(&desc);
    let kept = params.params().iter().filter(|p| !p.name.starts_with("anisotropy")).cloned().collect();
    desc.named_materials[i].1.params = scene::ParamSet::from_params(kept);
    let plain = mean_y(&desc);
    assert!((brushed - plain).abs() > 0.02 * plain, "brushed {brushed}, isotropic {plain}");
}

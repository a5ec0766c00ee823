//! glTF textures: a textured unit quad filling an orthographic camera's view, lit head on by a sun along the view,
//! so each pixel shows the material at one texel. Textures are checked against the same quad with the texel's
//! value given as a factor (the specification multiplies texture and factor before shading), transforms and wrap
//! modes against KHR_texture_transform's matrix worked out here, alpha against MASK's cutoff, and normal maps
//! against geometry tilted to the mapped normal.

use base64::Engine;
use serde_json::{json, Value};

mod common;
use common::{dir, render, write};

/// The side of the rendered image in pixels.
const SIDE: u32 = 32;

/// A PNG of `w`×`h` RGBA pixels (rows from the top) as bytes.
fn png_rgba(w: u32, h: u32, pixels: &[[u8; 4]]) -> Vec<u8> {
    let mut out = vec![];
    let mut enc = png::Encoder::new(&mut out, w, h);
    enc.set_color(png::ColorType::Rgba);
    enc.set_depth(png::BitDepth::Eight);
    enc.write_header().unwrap().write_image_data(&pixels.concat()).unwrap();
    out
}

fn data_uri(mime: &str, bytes: &[u8]) -> String {
    format!("data:{mime};base64,{}", base64::engine::general_purpose::STANDARD.encode(bytes))
}

/// The unit quad about the origin in z = 0 (normal +z) with glTF texture coordinates putting the image upright: its
/// top-left corner (uv 0, 0) at (−0.5, 0.5, 0). Positions, texture coordinates, then indices, in one buffer.
fn quad_buffer() -> Vec<u8> {
    let positions = [[-0.5f32, -0.5, 0.0], [0.5, -0.5, 0.0], [0.5, 0.5, 0.0], [-0.5, 0.5, 0.0]];
    let uvs = [[0f32, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]];
    let mut bytes: Vec<u8> =
        positions.iter().flatten().chain(uvs.iter().flatten()).flat_map(|c| c.to_le_bytes()).collect();
    bytes.extend([0u32, 1, 2, 0, 2, 3].iter().flat_map(|i| i.to_le_bytes()));
    bytes
}

/// A document with the quad (node 0, turned by `rotation`, a quaternion, about its centre at (0.5, 0.5, 0)), an
/// orthographic camera on +z seeing
/// exactly [0, 1]², a sun shining down −z (683 lx: 1 W/m²) and `material` (with `textures`, `samplers`, `images`).
fn quad_document(material: Value, rest: Value, rotation: [f64; 4]) -> Value {
    let bytes = quad_buffer();
    let mut doc = json!({
        "asset": { "version": "2.0" },
        "buffers": [ { "byteLength": bytes.len(), "uri": data_uri("application/octet-stream", &bytes) } ],
        "bufferViews": [
            { "buffer": 0, "byteOffset": 0, "byteLength": 48 },
            { "buffer": 0, "byteOffset": 48, "byteLength": 32 },
            { "buffer": 0, "byteOffset": 80, "byteLength": 24 }
        ],
        "accessors": [
            { "bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-0.5, -0.5, 0], "max": [0.5, 0.5, 0] },
            { "bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2" },
            { "bufferView": 2, "componentType": 5125, "count": 6, "type": "SCALAR" }
        ],
        "meshes": [ { "primitives": [ { "attributes": { "POSITION": 0, "TEXCOORD_0": 1 }, "indices": 2, "material": 0 } ] } ],
        "materials": [ material ],
        "extensionsUsed": ["KHR_lights_punctual", "KHR_texture_transform"],
        "extensions": { "KHR_lights_punctual": { "lights": [ { "type": "directional", "intensity": 683.0 } ] } },
        "cameras": [ { "type": "orthographic", "orthographic": { "xmag": 0.5, "ymag": 0.5, "znear": 0.01, "zfar": 100 } } ],
        "scene": 0,
        "scenes": [ { "nodes": [0, 1, 2] } ],
        "nodes": [
            { "mesh": 0, "rotation": rotation, "translation": [0.5, 0.5, 0.0] },
            { "camera": 0, "translation": [0.5, 0.5, 5.0] },
            { "extensions": { "KHR_lights_punctual": { "light": 0 } } }
        ]
    });
    for (k, v) in rest.as_object().cloned().unwrap_or_default() {
        doc[k] = v;
    }
    doc
}

/// The rendered film's linear XYZ at the centre of each of `SIDE`² pixels, rows from the top.
fn render_doc(name: &str, doc: &Value) -> (film::Film, scene::SceneDescription) {
    let d = dir("textures");
    let path = write(&d, name, doc);
    let desc = gltf_import::read_scene(&path, &gltf_import::ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    (render(&desc, 4, (SIDE, SIDE)), desc)
}

/// How far from a pixel's centre its samples reach: the default Gaussian pixel filter's radius, 1.5 pixels.
const FILTER_RADIUS: f64 = 1.5;

/// The mean XYZ over the pixels whose filter footprints lie in the quad region [x0, x1] × [y0, y1] (scene units,
/// y up).
fn region(film: &film::Film, x0: f64, x1: f64, y0: f64, y1: f64) -> [f64; 3] {
    let mut sum = [0.0; 3];
    let mut n = 0.0;
    for py in 0..SIDE {
        for px in 0..SIDE {
            let (x, y) = ((f64::from(px) + 0.5) / f64::from(SIDE), 1.0 - (f64::from(py) + 0.5) / f64::from(SIDE));
            let margin = FILTER_RADIUS / f64::from(SIDE);
            if x > x0 + margin && x < x1 - margin && y > y0 + margin && y < y1 - margin {
                let c = film.pixel_xyz(px, py);
                sum = [sum[0] + c.x, sum[1] + c.y, sum[2] + c.z];
                n += 1.0;
            }
        }
    }
    assert!(n > 0.0, "no pixel in the region");
    sum.map(|v| v / n)
}

fn close(a: [f64; 3], b: [f64; 3], tolerance: f64) -> bool {
    a.iter().zip(&b).all(|(x, y)| (x - y).abs() <= tolerance * y.abs().max(1e-3))
}

/// Four texels, sRGB: top-left, top-right, bottom-left, bottom-right (rows from the top).
const TEXELS: [[u8; 4]; 4] = [[200, 30, 30, 255], [30, 200, 30, 255], [30, 30, 200, 255], [230, 230, 230, 255]];

fn srgb_to_linear(v: u8) -> f64 {
    let c = f64::from(v) / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// A material with the 2×2 texture as base colour (nearest filtering, so each quadrant is one texel) and `factor`.
fn textured(factor: [f64; 4], sampler: Value, transform: Option<Value>) -> (Value, Value) {
    let png = png_rgba(2, 2, &TEXELS);
    let mut info = json!({ "index": 0 });
    if let Some(t) = transform {
        info["extensions"] = json!({ "KHR_texture_transform": t });
    }
    let material = json!({
        "pbrMetallicRoughness": { "baseColorTexture": info, "baseColorFactor": factor, "metallicFactor": 0.0, "roughnessFactor": 1.0 }
    });
    let rest = json!({
        "textures": [ { "source": 0, "sampler": 0 } ],
        "samplers": [ sampler ],
        "images": [ { "uri": data_uri("image/png", &png) } ]
    });
    (material, rest)
}

/// Each quadrant of the textured quad renders as the untextured quad whose base colour factor is the texel's
/// (linear) colour times the factor: texture × factor, uplifted once, as the specification's shading does.
#[test]
fn a_base_colour_texture_times_its_factor_renders_as_that_colour() {
    let factor = [0.5, 1.0, 0.8, 1.0];
    let (material, rest) = textured(factor, json!({ "magFilter": 9728, "minFilter": 9728 }), None);
    let (film, desc) = render_doc("base.gltf", &quad_document(material, rest, [0.0, 0.0, 0.0, 1.0]));
    assert!(desc.warnings.is_empty(), "{:?}", desc.warnings);
    let quadrants = [(0.0, 0.5, 0.5, 1.0), (0.5, 1.0, 0.5, 1.0), (0.0, 0.5, 0.0, 0.5), (0.5, 1.0, 0.0, 0.5)];
    for (texel, (x0, x1, y0, y1)) in TEXELS.iter().zip(quadrants) {
        let colour: Vec<f64> = (0..3).map(|c| srgb_to_linear(texel[c]) * factor[c]).collect();
        let plain = json!({ "pbrMetallicRoughness": { "baseColorFactor": [colour[0], colour[1], colour[2], 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0 } });
        let (reference, _) = render_doc("plain.gltf", &quad_document(plain, json!({}), [0.0, 0.0, 0.0, 1.0]));
        // The same pixels: the same samples and wavelengths, so only the material can differ.
        let (got, want) = (region(&film, x0, x1, y0, y1), region(&reference, x0, x1, y0, y1));
        assert!(want[1] > 0.01, "the reference is lit: {want:?}");
        assert!(close(got, want, 1e-4), "texel {texel:?}: textured {got:?}, factor {want:?}");
    }
}

/// The texel KHR_texture_transform and the sampler's wrap modes pick for quad point (x, y): glTF's uv there is
/// (x, 1 − y); the transform is T·R·S with R = [[cos, sin], [−sin, cos]]; s repeats mirrored, t clamps.
fn expected_texel(x: f64, y: f64, offset: [f64; 2], rotation: f64, scale: [f64; 2]) -> usize {
    let (u, v) = (x, 1.0 - y);
    let (sin, cos) = rotation.sin_cos();
    let (us, vs) = (scale[0] * u, scale[1] * v);
    let (ut, vt) = (cos * us + sin * vs + offset[0], -sin * us + cos * vs + offset[1]);
    // Texel columns and rows of the 2×2 image: mirrored repeat along s, clamp along t.
    let column = {
        let i = (ut * 2.0).floor() as i64;
        let m = i.rem_euclid(4);
        if m >= 2 {
            3 - m
        } else {
            m
        }
    };
    let row = ((vt * 2.0).floor() as i64).clamp(0, 1);
    (row * 2 + column) as usize
}

/// A rotated, scaled and offset texture with mirrored repeat along s and clamping along t shows, at points across
/// the quad, the texel the extension's matrix and the wrap modes pick.
#[test]
fn texture_transforms_and_wrap_modes_land_where_the_specification_says() {
    let (offset, rotation, scale) = ([0.3, -0.2], 0.6, [1.7, 1.3]);
    let sampler = json!({ "magFilter": 9728, "minFilter": 9728, "wrapS": 33648, "wrapT": 33071 });
    let transform = json!({ "offset": offset, "rotation": rotation, "scale": scale });
    let (material, rest) = textured([1.0; 4], sampler, Some(transform));
    let (film, _) = render_doc("transform.gltf", &quad_document(material, rest, [0.0, 0.0, 0.0, 1.0]));
    // Each texel's colour, seen as the renderer shows it: the dominant linear channel of X, Y, Z is not enough to
    // tell four colours apart, so the pixel is matched to the nearest of four untransformed renders.
    let (plain_material, plain_rest) = textured([1.0; 4], json!({ "magFilter": 9728, "minFilter": 9728 }), None);
    let (plain, _) = render_doc("untransformed.gltf", &quad_document(plain_material, plain_rest, [0.0, 0.0, 0.0, 1.0]));
    let looks: Vec<[f64; 3]> = [(0.0, 0.5, 0.5, 1.0), (0.5, 1.0, 0.5, 1.0), (0.0, 0.5, 0.0, 0.5), (0.5, 1.0, 0.0, 0.5)]
        .iter()
        .map(|&(x0, x1, y0, y1)| region(&plain, x0, x1, y0, y1))
        .collect();
    let (mut checked, mut wrong) = (0, vec![]);
    for py in 0..SIDE {
        for px in 0..SIDE {
            let (x, y) = ((f64::from(px) + 0.5) / f64::from(SIDE), 1.0 - (f64::from(py) + 0.5) / f64::from(SIDE));
            // Only pixels whose whole filter footprint lies on the quad and maps into one texel (texels are
            // parallelograms in (u, v), so the footprint's corners tell).
            let h = FILTER_RADIUS / f64::from(SIDE);
            if x - h < 0.0 || x + h > 1.0 || y - h < 0.0 || y + h > 1.0 {
                continue;
            }
            let corners = [(x - h, y - h), (x + h, y - h), (x - h, y + h), (x + h, y + h)];
            let want = expected_texel(x, y, offset, rotation, scale);
            if corners.iter().any(|&(cx, cy)| expected_texel(cx, cy, offset, rotation, scale) != want) {
                continue;
            }
            let c = film.pixel_xyz(px, py);
            let got = looks
                .iter()
                .enumerate()
                .min_by(|a, b| {
                    let d = |l: &[f64; 3]| (l[0] - c.x).powi(2) + (l[1] - c.y).powi(2) + (l[2] - c.z).powi(2);
                    d(a.1).total_cmp(&d(b.1))
                })
                .map(|(i, _)| i)
                .unwrap();
            checked += 1;
            if got != want {
                wrong.push((px, py, got, want));
            }
        }
    }
    assert!(checked > SIDE * SIDE / 4, "many pixels lie inside one texel: {checked}");
    assert!(wrong.is_empty(), "pixels showing another texel than the transform picks (x, y, got, want): {wrong:?}");
}

/// MASK with the base colour texture's alpha: texels under the cutoff are holes (the quad is black there: nothing
/// behind it is lit), texels at or above it are kept; BLEND lets the alpha's fraction of rays hit.
#[test]
fn alpha_from_the_base_colour_texture_cuts_out_and_blends() {
    // Left column alpha 0.2, right column 0.9 (alpha is linear: 51/255 and 230/255).
    let texels = [[200, 200, 200, 51], [200, 200, 200, 230], [200, 200, 200, 51], [200, 200, 200, 230]];
    let render_mode = |mode: &str| {
        let png = png_rgba(2, 2, &texels);
        let material = json!({
            "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 }, "metallicFactor": 0.0 },
            "alphaMode": mode, "alphaCutoff": 0.5
        });
        let rest = json!({
            "textures": [ { "source": 0, "sampler": 0 } ],
            "samplers": [ { "magFilter": 9728, "minFilter": 9728 } ],
            "images": [ { "uri": data_uri("image/png", &png) } ]
        });
        let (film, _) = render_doc(&format!("alpha-{mode}.gltf"), &quad_document(material, rest, [0.0, 0.0, 0.0, 1.0]));
        (region(&film, 0.0, 0.5, 0.0, 1.0)[1], region(&film, 0.5, 1.0, 0.0, 1.0)[1])
    };
    // Each half against the same half rendered opaque: the same pixels, samples and wavelengths.
    let (opaque_left, opaque_right) = render_mode("OPAQUE");
    assert!(opaque_left > 0.05 && opaque_right > 0.05, "lit: {opaque_left} {opaque_right}");
    let (left, right) = render_mode("MASK");
    assert!(left == 0.0, "alpha 0.2 is under the cutoff: a hole ({left})");
    assert!(
        (right - opaque_right).abs() < 1e-6 * opaque_right,
        "alpha 0.9 is kept whole: {right} against {opaque_right}"
    );
    let (left, right) = render_mode("BLEND");
    // Stochastic: 4 spp over about 200 pixels per half; the fractions 0.2 and 0.9 within 0.05.
    assert!((left / opaque_left - 51.0 / 255.0).abs() < 0.05, "BLEND at 0.2: {}", left / opaque_left);
    assert!((right / opaque_right - 230.0 / 255.0).abs() < 0.05, "BLEND at 0.9: {}", right / opaque_right);
}

/// The metallic-roughness texture's blue channel is metalness and its green roughness (linear), times the factors:
/// each half renders as the untextured material with those values.
#[test]
fn metalness_is_blue_and_roughness_green_in_the_metallic_roughness_texture() {
    // Left: metal (blue 255) with roughness 0.6 (green 153); right: dielectric (blue 0), roughness 0.2 (green 51).
    let texels = [[0, 153, 255, 255], [0, 51, 0, 255], [0, 153, 255, 255], [0, 51, 0, 255]];
    let png = png_rgba(2, 2, &texels);
    let base = [0.9, 0.6, 0.3, 1.0];
    let material = json!({ "pbrMetallicRoughness": {
        "baseColorFactor": base, "metallicFactor": 1.0, "roughnessFactor": 0.5,
        "metallicRoughnessTexture": { "index": 0 } } });
    let rest = json!({
        "textures": [ { "source": 0, "sampler": 0 } ],
        "samplers": [ { "magFilter": 9728, "minFilter": 9728 } ],
        "images": [ { "uri": data_uri("image/png", &png) } ]
    });
    // Seen slightly off the sun's direction, so that roughness changes what the camera sees.
    let tilt = [0.0, 0.087_155_74, 0.0, 0.996_194_7];
    let (film, _) = render_doc("mr.gltf", &quad_document(material, rest, tilt));
    for ((x0, x1), metallic, roughness) in
        [((0.1, 0.45), 1.0, 0.5 * 153.0 / 255.0), ((0.55, 0.9), 0.0, 0.5 * 51.0 / 255.0)]
    {
        let plain = json!({ "pbrMetallicRoughness": { "baseColorFactor": base, "metallicFactor": metallic, "roughnessFactor": roughness } });
        let (reference, _) = render_doc("mr-plain.gltf", &quad_document(plain, json!({}), tilt));
        let (got, want) = (region(&film, x0, x1, 0.1, 0.9), region(&reference, x0, x1, 0.1, 0.9));
        assert!(want[1] > 1e-3, "lit: {want:?}");
        assert!(
            close(got, want, 1e-3),
            "metallic {metallic}, roughness {roughness}: textured {got:?}, factors {want:?}"
        );
    }
}

/// A grey dielectric (roughness 0.4) with, if `map`, a 1×1 normal texture encoding the tangent-space normal `map`,
/// and the document's parts it needs (texture and image).
fn normal_mapped(map: Option<[f64; 3]>) -> (Value, Value) {
    let mut m = json!({ "pbrMetallicRoughness": { "baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.4 } });
    let mut rest = json!({});
    if let Some(n) = map {
        let [r, g, b] = n.map(|c| ((c * 0.5 + 0.5) * 255.0).round() as u8);
        m["normalTexture"] = json!({ "index": 0 });
        let png = png_rgba(1, 1, &[[r, g, b, 255]]);
        rest = json!({ "textures": [ { "source": 0 } ], "images": [ { "uri": data_uri("image/png", &png) } ] });
    }
    (m, rest)
}

/// A normal map whose texel encodes the tangent-space normal (0.6, 0, 0.8) — tilted towards +u — or (0, 0.6, 0.8)
/// — towards +v, up the image — shades the flat quad as the quad turned to that normal: the view is orthographic
/// and the sun distant, so only the normal's direction matters (the sun comes from one side, so the direction of
/// the tilt shows, not only its angle).
#[test]
fn a_normal_map_shades_as_geometry_turned_to_its_normal() {
    // The quaternions turning +z to (0.6, 0, 0.8) (about +y) and to (0, 0.6, 0.8) (about −x), by asin 0.6 / 2.
    let half = 0.6f64.asin() / 2.0;
    let cases =
        [([0.6, 0.0, 0.8], [0.0, half.sin(), 0.0, half.cos()]), ([0.0, 0.6, 0.8], [-half.sin(), 0.0, 0.0, half.cos()])];
    // The sun turned 30° about (1, 1, 0), so that it comes from one side: a normal tilted towards +u or +v is lit
    // differently from one tilted the other way.
    let render_lit = |map: Option<[f64; 3]>, rotation: [f64; 4]| {
        let (m, rest) = normal_mapped(map);
        let mut doc = quad_document(m, rest, rotation);
        let (s, c) = (15f64.to_radians().sin(), 15f64.to_radians().cos());
        doc["nodes"][2]["rotation"] = json!([s / 2f64.sqrt(), s / 2f64.sqrt(), 0.0, c]);
        region(&render_doc("normal.gltf", &doc).0, 0.3, 0.7, 0.3, 0.7)
    };
    for (normal, rotation) in cases {
        let got = render_lit(Some(normal), [0.0, 0.0, 0.0, 1.0]);
        let want = render_lit(None, rotation);
        // The tilt the other way round shades differently: the comparison sees the tilt's direction.
        let opposite = render_lit(Some([-normal[0], -normal[1], normal[2]]), [0.0, 0.0, 0.0, 1.0]);
        assert!((opposite[1] - want[1]).abs() > 0.05 * want[1], "{normal:?}: {opposite:?} against {want:?}");
        // The encoded normal is quantised to 8 bits: within 1%.
        assert!(close(got, want, 0.01), "normal {normal:?}: mapped {got:?}, turned geometry {want:?}");
    }
}

/// The quad of [`quad_document`] with its texture coordinates' u mirrored (u = 1 at x = −0.5) and, if `normals`,
/// a `NORMAL` of +z at every vertex: the data of `doc`'s buffer replaced.
fn with_mirrored_u(doc: &mut Value, normals: bool) {
    let positions = [[-0.5f32, -0.5, 0.0], [0.5, -0.5, 0.0], [0.5, 0.5, 0.0], [-0.5, 0.5, 0.0]];
    let uvs = [[1f32, 1.0], [0.0, 1.0], [0.0, 0.0], [1.0, 0.0]];
    let mut bytes: Vec<u8> =
        positions.iter().flatten().chain(uvs.iter().flatten()).flat_map(|c| c.to_le_bytes()).collect();
    // Mirrored: the triangles keep facing +z with the winding reversed in texture space.
    bytes.extend([0u32, 1, 2, 0, 2, 3].iter().flat_map(|i| i.to_le_bytes()));
    if normals {
        bytes.extend([[0f32, 0.0, 1.0]; 4].iter().flatten().flat_map(|c| c.to_le_bytes()));
        doc["bufferViews"].as_array_mut().unwrap().push(json!({ "buffer": 0, "byteOffset": 104, "byteLength": 48 }));
        doc["accessors"]
            .as_array_mut()
            .unwrap()
            .push(json!({ "bufferView": 3, "componentType": 5126, "count": 4, "type": "VEC3" }));
        doc["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = json!(3);
    }
    doc["buffers"][0] = json!({ "byteLength": bytes.len(), "uri": data_uri("application/octet-stream", &bytes) });
}

/// Normal maps on a quad whose u runs right to left (a mirrored half of a model), with and without vertex normals:
/// a texel tilted towards +u turns the normal towards −x, one tilted towards +v (up the image) still towards +y, as
/// glTF's tangent frame (MikkTSpace: the bitangent's sign follows the texture coordinates) has it.
#[test]
fn a_normal_map_on_mirrored_texture_coordinates_keeps_its_bumps() {
    let half = 0.6f64.asin() / 2.0;
    // Towards +u: the normal turned to (−0.6, 0, 0.8) (about −y); towards +v: to (0, 0.6, 0.8) (about −x).
    let cases = [
        ([0.6, 0.0, 0.8], [0.0, -half.sin(), 0.0, half.cos()]),
        ([0.0, 0.6, 0.8], [-half.sin(), 0.0, 0.0, half.cos()]),
    ];
    let render_lit = |map: Option<[f64; 3]>, rotation: [f64; 4], normals: bool| {
        let (m, rest) = normal_mapped(map);
        let mut doc = quad_document(m, rest, rotation);
        with_mirrored_u(&mut doc, normals);
        let (s, c) = (15f64.to_radians().sin(), 15f64.to_radians().cos());
        doc["nodes"][2]["rotation"] = json!([s / 2f64.sqrt(), s / 2f64.sqrt(), 0.0, c]);
        region(&render_doc("mirrored.gltf", &doc).0, 0.3, 0.7, 0.3, 0.7)
    };
    for normals in [false, true] {
        for (normal, rotation) in cases {
            let got = render_lit(Some(normal), [0.0, 0.0, 0.0, 1.0], normals);
            let want = render_lit(None, rotation, normals);
            let case = format!("normal {normal:?}, vertex normals {normals}");
            assert!(close(got, want, 0.01), "{case}: mapped {got:?}, turned geometry {want:?}");
        }
    }
}

/// Images in a GLB's binary chunk (as Blender writes them) are read as data URIs are, and a texture that is not an
/// image is an error naming the image.
#[test]
fn images_in_a_glb_buffer_view_and_bad_images() {
    let png = png_rgba(2, 2, &TEXELS);
    let (material, rest) = textured([1.0; 4], json!({ "magFilter": 9728, "minFilter": 9728 }), None);
    let doc = quad_document(material, rest, [0.0, 0.0, 0.0, 1.0]);
    let (by_uri, _) = render_doc("uri.gltf", &doc);
    // The same document as a GLB: the quad's buffer stays a data URI; the image moves into the binary chunk.
    let mut glb_doc = doc.clone();
    let mut bin = png.clone();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    // The binary chunk is the first buffer (the one without a URI); the quad's buffer becomes the second.
    glb_doc["buffers"] = json!([{ "byteLength": bin.len() }, glb_doc["buffers"][0].clone()]);
    for view in glb_doc["bufferViews"].as_array_mut().unwrap() {
        view["buffer"] = json!(1);
    }
    glb_doc["bufferViews"]
        .as_array_mut()
        .unwrap()
        .push(json!({ "buffer": 0, "byteOffset": 0, "byteLength": png.len() }));
    glb_doc["images"] = json!([ { "bufferView": 3, "mimeType": "image/png" } ]);
    let mut text = serde_json::to_vec(&glb_doc).unwrap();
    while !text.len().is_multiple_of(4) {
        text.push(b' ');
    }
    let mut glb = vec![];
    glb.extend(b"glTF");
    glb.extend(2u32.to_le_bytes());
    glb.extend(((12 + 8 + text.len() + 8 + bin.len()) as u32).to_le_bytes());
    glb.extend((text.len() as u32).to_le_bytes());
    glb.extend(b"JSON");
    glb.extend(&text);
    glb.extend((bin.len() as u32).to_le_bytes());
    glb.extend(b"BIN\0");
    glb.extend(&bin);
    let d = dir("textures");
    let path = d.join("binary.glb");
    std::fs::write(&path, &glb).unwrap();
    let desc = gltf_import::read_scene(&path, &gltf_import::ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let by_view = render(&desc, 4, (SIDE, SIDE));
    for (a, b) in [(4, 4), (28, 4), (4, 28), (28, 28)].map(|(x, y)| (by_uri.pixel_xyz(x, y), by_view.pixel_xyz(x, y))) {
        assert!((a.y - b.y).abs() < 1e-9 && (a.x - b.x).abs() < 1e-9, "{a:?} {b:?}");
    }
    // Not an image: the error names the glTF image.
    let mut bad = doc.clone();
    bad["images"] = json!([ { "uri": data_uri("image/png", b"GIF89a not really") } ]);
    let path = write(&d, "bad-image.gltf", &bad);
    let desc = gltf_import::read_scene(&path, &gltf_import::ReadOptions::default()).unwrap();
    let e = render::build_scene(&desc, &render::BuildOptions::default())
        .err()
        .expect("a bad image is an error")
        .to_string();
    assert!(e.contains("images[0]") && e.contains("not a PNG, JPEG or WebP"), "{e}");
}

/// KHR_texture_transform's matrix in the reader's (u, v) (v = 1 − glTF's v, t from the image's bottom) against
/// the extension's T·R·S worked through the same flips here.
#[test]
fn the_uv_transform_is_the_extensions_matrix_in_flipped_coordinates() {
    let (offset, rotation, scale) = ([0.25, -0.5], 1.1, [2.0, 0.5]);
    let m = gltf_import::uv_transform(offset, rotation, scale);
    for (u, v) in [(0.0, 0.0), (1.0, 0.0), (0.3, 0.7), (-2.0, 5.0)] {
        let (vg, (sin, cos)) = (1.0 - v, rotation.sin_cos());
        let ut = cos * scale[0] * u + sin * scale[1] * vg + offset[0];
        let vt = -sin * scale[0] * u + cos * scale[1] * vg + offset[1];
        let (s, t) = (m[0] * u + m[1] * v + m[2], m[3] * u + m[4] * v + m[5]);
        assert!(
            (s - ut).abs() < 1e-12 && (t - (1.0 - vt)).abs() < 1e-12,
            "({u}, {v}): ({s}, {t}) against ({ut}, {})",
            1.0 - vt
        );
    }
}

/// Linear sRGB of an XYZ value (IEC 61966-2-1).
fn srgb_of([x, y, z]: [f64; 3]) -> [f64; 3] {
    [
        3.240_97 * x - 1.537_383 * y - 0.498_611 * z,
        -0.969_244 * x + 1.875_968 * y + 0.041_555 * z,
        0.055_63 * x - 0.203_977 * y + 1.056_972 * z,
    ]
}

/// What Blender's own exporter writes for a textured plane (scenes/tools/gltf_scenes.py): an RGBA image in the
/// GLB, a Mapping node's scale as KHR_texture_transform and a clipped alpha as MASK. Each pixel shows the texel
/// Blender's shading picks there: its UVs run from (0, 0) at the plane's (−1, −1) corner to (1, 1), scaled by 2;
/// the image's rows count from the bottom; the transparent texels are holes.
#[test]
fn a_blender_textured_plane_shows_its_texels_where_blender_puts_them() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/textured-plane.glb");
    let desc = gltf_import::read_scene(&path, &gltf_import::ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert!(desc.warnings.is_empty(), "{:?}", desc.warnings);
    assert_eq!(desc.images.len(), 1, "one image, in the GLB");
    let n = 64;
    let film = render(&desc, 16, (n, n));
    // 0 red, 1 green, 2 blue, 3 white at Blender UV (u, v) after the Mapping node.
    let texel = |x: f64, y: f64| {
        let (u, v) = (2.0 * (x + 1.0) / 2.0, 2.0 * (y + 1.0) / 2.0);
        let (column, row_from_bottom) =
            (((u * 2.0).floor() as i64).rem_euclid(2), ((v * 2.0).floor() as i64).rem_euclid(2));
        match (row_from_bottom, column) {
            (1, 0) => 0,
            (1, _) => 1,
            (_, 0) => 2,
            _ => 3,
        }
    };
    // The plane shows 4 × 4 copies of texels; each copy's pixels (those whose filter footprint lies inside it) are
    // averaged, which leaves little of the per-pixel colour noise of sampling four wavelengths at a time.
    let mut copies: std::collections::HashMap<(i64, i64), (usize, [f64; 3], u32)> = Default::default();
    for py in 0..n {
        for px in 0..n {
            let at = |dx: f64, dy: f64| {
                let x = -1.0 + 2.0 * (f64::from(px) + 0.5 + dx) / f64::from(n);
                let y = 1.0 - 2.0 * (f64::from(py) + 0.5 + dy) / f64::from(n);
                (texel(x, y), (((x + 1.0) * 2.0).floor() as i64, ((y + 1.0) * 2.0).floor() as i64))
            };
            let (want, copy) = at(0.0, 0.0);
            let r = FILTER_RADIUS;
            let inside = |d: f64, p: u32| f64::from(p) + 0.5 + d >= 0.0 && f64::from(p) + 0.5 + d <= f64::from(n);
            if !(inside(-r, px) && inside(r, px) && inside(-r, py) && inside(r, py))
                || [(-r, -r), (r, -r), (-r, r), (r, r)].iter().any(|&(dx, dy)| at(dx, dy).1 != copy)
            {
                continue;
            }
            let c = film.pixel_xyz(px, py);
            let entry = copies.entry(copy).or_insert((want, [0.0; 3], 0));
            entry.1 = [entry.1[0] + c.x, entry.1[1] + c.y, entry.1[2] + c.z];
            entry.2 += 1;
        }
    }
    assert_eq!(copies.len(), 16, "every copy of a texel is seen");
    for (copy, (want, sum, count)) in copies {
        assert!(count >= 60, "copy {copy:?}: {count} pixels");
        let [r, g, b] = srgb_of(sum.map(|v| v / f64::from(count)));
        let ok = match want {
            // The red texel is sRGB (204, 13, 13): more saturated than a smooth reflectance spectrum can be, so its
            // uplift reflects some green and blue too (as in pbrt-v4); still plainly red.
            0 => r > 2.5 * g.abs().max(b.abs()) && r > 0.02,
            3 => r > 0.05 && (r - g).abs() < 0.03 * r && (r - b).abs() < 0.03 * r,
            _ => sum[1] == 0.0,
        };
        assert!(ok, "copy {copy:?} should show texel {want}: linear sRGB {:?}", [r, g, b]);
    }
}

/// An emissive texture times the emissive factor and strength: seen directly, each quadrant of an emitting quad
/// shows what the untextured emitter whose factor is the texel's linear colour times them shows (the same pixels,
/// so the same wavelengths).
#[test]
fn an_emissive_texture_times_its_factor_and_strength_is_the_emission() {
    let (factor, strength) = ([1.0, 0.5, 0.8], 2.0);
    let png = png_rgba(2, 2, &TEXELS);
    let emitter = |emissive: [f64; 3], textured: bool| {
        let mut m = json!({
            "pbrMetallicRoughness": { "baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0 },
            "emissiveFactor": emissive,
            "extensions": { "KHR_materials_emissive_strength": { "emissiveStrength": strength } }
        });
        let mut rest = json!({});
        if textured {
            m["emissiveTexture"] = json!({ "index": 0 });
            rest = json!({
                "textures": [ { "source": 0, "sampler": 0 } ],
                "samplers": [ { "magFilter": 9728, "minFilter": 9728 } ],
                "images": [ { "uri": data_uri("image/png", &png) } ]
            });
        }
        let mut doc = quad_document(m, rest, [0.0, 0.0, 0.0, 1.0]);
        doc["extensionsUsed"].as_array_mut().unwrap().push(json!("KHR_materials_emissive_strength"));
        doc
    };
    let (film, desc) = render_doc("emissive.gltf", &emitter(factor, true));
    assert!(desc.warnings.is_empty(), "{:?}", desc.warnings);
    let quadrants = [(0.0, 0.5, 0.5, 1.0), (0.5, 1.0, 0.5, 1.0), (0.0, 0.5, 0.0, 0.5), (0.5, 1.0, 0.0, 0.5)];
    for (texel, (x0, x1, y0, y1)) in TEXELS.iter().zip(quadrants) {
        let colour = [0, 1, 2].map(|c| srgb_to_linear(texel[c]) * factor[c]);
        let (reference, _) = render_doc("emissive-plain.gltf", &emitter(colour, false));
        let (got, want) = (region(&film, x0, x1, y0, y1), region(&reference, x0, x1, y0, y1));
        assert!(want[1] > 0.05, "bright: {want:?}");
        // The texture's colour is uplifted in single precision, the factor's in double: within 0.1%.
        assert!(close(got, want, 1e-3), "texel {texel:?}: textured {got:?}, factor {want:?}");
    }
}

/// An emissive texture lights the scene through light sampling as it shows: a floor under a downward-facing
/// emitter with a one-texel texture receives what it receives from the untextured emitter of that colour.
#[test]
fn an_emissive_texture_lights_the_scene_as_it_shows() {
    let texel = [180u8, 120, 60, 255];
    let png = png_rgba(1, 1, &[texel]);
    let scene = |textured: bool| {
        let colour = [0, 1, 2].map(|c| if textured { 1.0 } else { srgb_to_linear(texel[c]) });
        let floor = json!({ "pbrMetallicRoughness": { "baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0 } });
        let mut doc = quad_document(floor, json!({}), [0.0, 0.0, 0.0, 1.0]);
        let mut emitter = json!({ "pbrMetallicRoughness": { "baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0 }, "emissiveFactor": colour });
        if textured {
            emitter["emissiveTexture"] = json!({ "index": 0 });
            doc["textures"] = json!([ { "source": 0 } ]);
            doc["images"] = json!([ { "uri": data_uri("image/png", &png) } ]);
        }
        doc["materials"].as_array_mut().unwrap().push(emitter);
        let mut second = doc["meshes"][0].clone();
        second["primitives"][0]["material"] = json!(1);
        doc["meshes"].as_array_mut().unwrap().push(second);
        // Half the floor's size, 0.5 above it, turned over to face it; no sun.
        doc["nodes"].as_array_mut().unwrap().push(json!({ "mesh": 1, "translation": [0.5, 0.5, 0.5], "rotation": [1.0, 0.0, 0.0, 0.0], "scale": [0.5, 0.5, 0.5] }));
        doc["scenes"][0]["nodes"] = json!([0, 1, 3]);
        let d = dir("textures");
        let path = write(&d, &format!("lit-{textured}.gltf"), &doc);
        let desc =
            gltf_import::read_scene(&path, &gltf_import::ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        render(&desc, 64, (SIDE, SIDE))
    };
    let (textured, plain) = (scene(true), scene(false));
    // The floor's border, outside the emitter's silhouette.
    let (got, want) = (region(&textured, 0.0, 0.2, 0.0, 1.0), region(&plain, 0.0, 0.2, 0.0, 1.0));
    assert!(want[1] > 0.01, "the floor is lit: {want:?}");
    assert!(close(got, want, 0.02), "textured emitter {got:?}, untextured {want:?}");
}

/// pbrt-v4's image area light (`AreaLightSource "diffuse" "string filename"`): each quadrant of an emitting quad
/// shows the texel's colour as an RGB `L` of that colour does (t = 0 at the image's bottom row, as pbrt-v4 flips).
#[test]
fn a_pbrt_image_area_light_emits_its_texels() {
    let d = dir("pbrt-image-light");
    // 16×16 texels, each quadrant one of the four colours: bilinear lookups (as pbrt-v4's) blend only near the
    // middle lines.
    let big: Vec<[u8; 4]> = (0..256).map(|i| TEXELS[(i / 16 / 8) * 2 + (i % 16) / 8]).collect();
    std::fs::write(d.join("emit.png"), png_rgba(16, 16, &big)).unwrap();
    let scene = |light: &str| {
        let text = format!(
            r#"LookAt 0.5 0.5 5  0.5 0.5 0  0 1 0
Camera "orthographic" "float screenwindow" [ -0.5 0.5 -0.5 0.5 ]
Film "rgb" "integer xresolution" {SIDE} "integer yresolution" {SIDE}
WorldBegin
AreaLightSource "diffuse" "bool twosided" true {light}
Material "diffuse" "rgb reflectance" [ 0 0 0 ]
Shape "trianglemesh" "point3 P" [ 1 0 0  0 0 0  0 1 0  1 1 0 ] "point2 uv" [ 0 0  1 0  1 1  0 1 ]
    "integer indices" [ 0 1 2 0 2 3 ]
"#
        );
        let desc = pbrt::parse_str(&text, &d.join("scene.pbrt")).unwrap_or_else(|e| panic!("{e}"));
        render(&desc, 4, (SIDE, SIDE))
    };
    // pbrt-v4's camera space is left-handed, so this LookAt shows world +x to the left of the image: the quad's u,
    // which runs from x = 1 to x = 0, runs left to right in the render, and the image shows upright.
    let film = scene(r#""string filename" "emit.png""#);
    let quadrants = [(0.0, 0.4, 0.6, 1.0), (0.6, 1.0, 0.6, 1.0), (0.0, 0.4, 0.0, 0.4), (0.6, 1.0, 0.0, 0.4)];
    for (texel, (x0, x1, y0, y1)) in TEXELS.iter().zip(quadrants) {
        let c = [0, 1, 2].map(|c| srgb_to_linear(texel[c]));
        let reference = scene(&format!(r#""rgb L" [ {} {} {} ]"#, c[0], c[1], c[2]));
        let (got, want) = (region(&film, x0, x1, y0, y1), region(&reference, x0, x1, y0, y1));
        assert!(want[1] > 0.01, "bright: {want:?}");
        assert!(close(got, want, 1e-3), "texel {texel:?}: image {got:?}, rgb L {want:?}");
    }
}

/// The layer extensions' textures (KHR_materials_specular, _sheen, _clearcoat, _iridescence) read the channel each
/// extension names, linear or sRGB as it says, times the factor: each column of the textured quad renders as the
/// untextured quad whose factor is the column's texel value times the factor, within 1e-3 (the same pixels, hence
/// the same wavelengths), and the two columns differ by more than 2 %, so the texture matters.
#[test]
fn layer_extension_textures_read_their_channels_times_their_factors() {
    // (extension, its other members, texture key, factor key and value, the channel, the two columns' texel
    // values, whether the channel is a colour in sRGB).
    struct Case {
        ext: &'static str,
        base: Value,
        key: &'static str,
        factor: (&'static str, f64),
        channel: usize,
        texels: [u8; 2],
    }
    let cases = [
        Case {
            ext: "KHR_materials_specular",
            base: json!({}),
            key: "specularTexture",
            factor: ("specularFactor", 0.9),
            channel: 3,
            texels: [40, 230],
        },
        Case {
            ext: "KHR_materials_sheen",
            base: json!({ "sheenColorFactor": [1.0, 0.9, 0.8] }),
            key: "sheenRoughnessTexture",
            factor: ("sheenRoughnessFactor", 1.0),
            channel: 3,
            texels: [60, 250],
        },
        Case {
            ext: "KHR_materials_clearcoat",
            base: json!({ "clearcoatRoughnessFactor": 0.2 }),
            key: "clearcoatTexture",
            factor: ("clearcoatFactor", 1.0),
            channel: 0,
            texels: [30, 255],
        },
        Case {
            ext: "KHR_materials_clearcoat",
            base: json!({ "clearcoatFactor": 1.0 }),
            key: "clearcoatRoughnessTexture",
            factor: ("clearcoatRoughnessFactor", 0.8),
            channel: 1,
            texels: [30, 255],
        },
        Case {
            ext: "KHR_materials_iridescence",
            base: json!({ "iridescenceThicknessMaximum": 500.0 }),
            key: "iridescenceTexture",
            factor: ("iridescenceFactor", 1.0),
            channel: 0,
            texels: [40, 255],
        },
        Case {
            ext: "KHR_materials_iridescence",
            base: json!({ "iridescenceFactor": 1.0, "iridescenceThicknessMinimum": 150.0, "iridescenceThicknessMaximum": 650.0 }),
            key: "iridescenceThicknessTexture",
            factor: ("iridescenceFactor", 1.0),
            channel: 1,
            texels: [60, 200],
        },
    ];
    // Seen off the sun's direction (the quad turned 20° about y), so that roughness changes what the camera sees.
    let tilt = [0.0, 0.173_648_18, 0.0, 0.984_807_75];
    let dielectric = json!({ "baseColorFactor": [0.4, 0.3, 0.2, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.5 });
    // A film shows most on a metal, whose Fresnel term it replaces.
    let metal = json!({ "baseColorFactor": [0.9, 0.8, 0.6, 1.0], "metallicFactor": 1.0, "roughnessFactor": 0.4 });
    for case in cases {
        let pbr = if case.ext == "KHR_materials_iridescence" { &metal } else { &dielectric };
        let texel = |v: u8| {
            let mut t = [128u8, 128, 128, 255];
            t[case.channel] = v;
            t
        };
        let [a, b] = case.texels.map(texel);
        let png = png_rgba(2, 2, &[a, b, a, b]);
        let mut ext = case.base.clone();
        ext[case.key] = json!({ "index": 0 });
        ext[case.factor.0] = json!(case.factor.1);
        let material = json!({ "pbrMetallicRoughness": pbr, "extensions": { case.ext: ext } });
        let rest = json!({
            "textures": [ { "source": 0, "sampler": 0 } ],
            "samplers": [ { "magFilter": 9728, "minFilter": 9728 } ],
            "images": [ { "uri": data_uri("image/png", &png) } ]
        });
        let (film, _) = render_doc("layer.gltf", &quad_document(material, rest, tilt));
        let mut plain_regions = vec![];
        for ((x0, x1), v) in [((0.1, 0.45), case.texels[0]), ((0.55, 0.9), case.texels[1])] {
            // Linear channels: the texel value / 255 times the factor (the thickness texture mixes its bounds).
            let mut plain = case.base.clone();
            plain[case.factor.0] = json!(case.factor.1 * f64::from(v) / 255.0);
            if case.key == "iridescenceThicknessTexture" {
                let (lo, hi) = (150.0, 650.0);
                plain["iridescenceThicknessMaximum"] = json!(lo + (hi - lo) * f64::from(v) / 255.0);
                plain[case.factor.0] = json!(case.factor.1);
            }
            let plain = json!({ "pbrMetallicRoughness": pbr, "extensions": { case.ext: plain } });
            let (reference, _) = render_doc("layer-plain.gltf", &quad_document(plain, json!({}), tilt));
            let (got, want) = (region(&film, x0, x1, 0.1, 0.9), region(&reference, x0, x1, 0.1, 0.9));
            assert!(want[1] > 1e-3, "lit: {want:?}");
            assert!(close(got, want, 1e-3), "{} {}: texel {v}: textured {got:?}, factor {want:?}", case.ext, case.key);
            plain_regions.push(want);
        }
        let (l, r) = (plain_regions[0][1], plain_regions[1][1]);
        assert!((l / r - 1.0).abs() > 0.02, "{} {}: the texture makes no difference ({l} and {r})", case.ext, case.key);
    }
}

/// The colour textures of the layer extensions (specular colour, sheen colour) are sRGB, times the colour factor.
#[test]
fn layer_extension_colour_textures_are_srgb_times_the_factor() {
    let pbr = json!({ "baseColorFactor": [0.3, 0.3, 0.3, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.4 });
    let tilt = [0.0, 0.173_648_18, 0.0, 0.984_807_75];
    let (a, b) = ([200u8, 60, 30, 255], [40, 120, 220, 255]);
    let png = png_rgba(2, 2, &[a, b, a, b]);
    let factor = [0.9, 0.8, 1.0];
    // ior 0: the specular-glossiness mode, in which f₀ is the specular colour itself (so the colour shows).
    for (ext, key, factor_key, extra, ior) in [
        ("KHR_materials_specular", "specularColorTexture", "specularColorFactor", json!({}), json!({ "ior": 0.0 })),
        (
            "KHR_materials_sheen",
            "sheenColorTexture",
            "sheenColorFactor",
            json!({ "sheenRoughnessFactor": 0.6 }),
            json!({ "ior": 1.5 }),
        ),
    ] {
        let mut e = extra.clone();
        e[key] = json!({ "index": 0 });
        e[factor_key] = json!(factor);
        let material = json!({ "pbrMetallicRoughness": pbr, "extensions": { ext: e, "KHR_materials_ior": ior } });
        let rest = json!({
            "textures": [ { "source": 0, "sampler": 0 } ],
            "samplers": [ { "magFilter": 9728, "minFilter": 9728 } ],
            "images": [ { "uri": data_uri("image/png", &png) } ]
        });
        let (film, _) = render_doc("layer-colour.gltf", &quad_document(material, rest, tilt));
        for ((x0, x1), t) in [((0.1, 0.45), a), ((0.55, 0.9), b)] {
            let colour: Vec<f64> = (0..3).map(|c| srgb_to_linear(t[c]) * factor[c]).collect();
            let mut plain = extra.clone();
            plain[factor_key] = json!(colour);
            let plain = json!({ "pbrMetallicRoughness": pbr, "extensions": { ext: plain, "KHR_materials_ior": ior } });
            let (reference, _) = render_doc("layer-colour-plain.gltf", &quad_document(plain, json!({}), tilt));
            let (got, want) = (region(&film, x0, x1, 0.1, 0.9), region(&reference, x0, x1, 0.1, 0.9));
            assert!(want[1] > 1e-3, "lit: {want:?}");
            assert!(close(got, want, 2e-3), "{ext} {key}: texel {t:?}: textured {got:?}, factor {want:?}");
        }
    }
}

/// A lossless WebP of `w`×`h` RGBA pixels as bytes.
fn webp_rgba(w: u32, h: u32, pixels: &[[u8; 4]]) -> Vec<u8> {
    let mut out = vec![];
    image_webp::WebPEncoder::new(&mut out).encode(&pixels.concat(), w, h, image_webp::ColorType::Rgba8).unwrap();
    out
}

/// EXT_texture_webp: a texture whose extension names a (lossless) WebP image renders bit for bit as the same
/// texels in a PNG, whether the WebP stands alone or beside a PNG fallback in `source` (which it replaces: the
/// fallback here is a different image, so reading it would show).
#[test]
fn a_webp_texture_renders_as_the_same_png() {
    let (material, rest) = textured([1.0; 4], json!({ "magFilter": 9728, "minFilter": 9728 }), None);
    let (want, _) = render_doc("png.gltf", &quad_document(material.clone(), rest, [0.0, 0.0, 0.0, 1.0]));
    let webp = webp_rgba(2, 2, &TEXELS);
    let fallback = png_rgba(2, 2, &[[0, 0, 0, 255]; 4]);
    for (texture, images) in [
        (
            json!({ "sampler": 0, "extensions": { "EXT_texture_webp": { "source": 0 } } }),
            json!([ { "uri": data_uri("image/webp", &webp) } ]),
        ),
        (
            json!({ "source": 1, "sampler": 0, "extensions": { "EXT_texture_webp": { "source": 0 } } }),
            json!([ { "uri": data_uri("image/webp", &webp) }, { "uri": data_uri("image/png", &fallback) } ]),
        ),
    ] {
        let rest = json!({
            "textures": [ texture ],
            "samplers": [ { "magFilter": 9728, "minFilter": 9728 } ],
            "images": images,
            "extensionsUsed": ["KHR_lights_punctual", "EXT_texture_webp"]
        });
        let (got, desc) = render_doc("webp.gltf", &quad_document(material.clone(), rest, [0.0, 0.0, 0.0, 1.0]));
        assert!(desc.warnings.is_empty(), "{:?}", desc.warnings);
        for py in 0..SIDE {
            for px in 0..SIDE {
                assert_eq!(got.pixel_xyz(px, py), want.pixel_xyz(px, py), "pixel ({px}, {py})");
            }
        }
    }
}

/// `doc` (a quad document) with vertex colours `colors` (one per corner, in the quad's vertex order: bottom-left,
/// bottom-right, top-right, top-left) as COLOR_0: float RGB, or with `unorm8` normalised bytes RGBA.
fn with_vertex_colors(mut doc: Value, colors: [[f32; 3]; 4], unorm8: bool) -> Value {
    let (bytes, component, kind): (Vec<u8>, u32, &str) = if unorm8 {
        let b = colors.iter().flat_map(|c| [c[0], c[1], c[2], 1.0].map(|v| (v * 255.0).round() as u8)).collect();
        (b, 5121, "VEC4")
    } else {
        (colors.iter().flatten().flat_map(|v| v.to_le_bytes()).collect(), 5126, "VEC3")
    };
    let n = bytes.len();
    doc["buffers"]
        .as_array_mut()
        .unwrap()
        .push(json!({ "byteLength": n, "uri": data_uri("application/octet-stream", &bytes) }));
    doc["bufferViews"].as_array_mut().unwrap().push(json!({ "buffer": 1, "byteOffset": 0, "byteLength": n }));
    let mut accessor = json!({ "bufferView": 3, "componentType": component, "count": 4, "type": kind });
    if unorm8 {
        accessor["normalized"] = json!(true);
    }
    doc["accessors"].as_array_mut().unwrap().push(accessor);
    doc["meshes"][0]["primitives"][0]["attributes"]["COLOR_0"] = json!(3);
    doc
}

/// Vertex colours (COLOR_0) multiply the base colour: a quad whose four corners have one colour renders as the
/// quad whose base colour factor is that colour times the factor (within 1e-3: the product is uplifted in single
/// precision, the factor in double), as float RGB or normalised RGBA bytes, and times a base colour texture too.
/// Between corners of two colours the colour is interpolated: the middle column is their mean.
#[test]
fn vertex_colours_multiply_the_base_colour() {
    let factor = [0.9, 0.8, 0.7, 1.0];
    let c = [0.6f32, 0.2, 0.4];
    let straight = [0.0, 0.0, 0.0, 1.0];
    let lit = |m: [f64; 3]| json!({ "pbrMetallicRoughness": { "baseColorFactor": [m[0], m[1], m[2], 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0 } });
    let plain = [0, 1, 2].map(|i| f64::from(c[i]) * factor[i]);
    let (want, _) = render_doc("vc-plain.gltf", &quad_document(lit(plain), json!({}), straight));
    let material =
        json!({ "pbrMetallicRoughness": { "baseColorFactor": factor, "metallicFactor": 0.0, "roughnessFactor": 1.0 } });
    for unorm8 in [false, true] {
        let c = if unorm8 { c.map(|v| (v * 255.0).round() / 255.0) } else { c };
        let doc = with_vertex_colors(quad_document(material.clone(), json!({}), straight), [c; 4], unorm8);
        let (got, _) = render_doc("vc.gltf", &doc);
        let (g, w) = (region(&got, 0.1, 0.9, 0.1, 0.9), region(&want, 0.1, 0.9, 0.1, 0.9));
        assert!(close(g, w, 1e-3), "unorm8 {unorm8}: vertex colours {g:?}, factor {w:?}");
    }
    // Times the base colour texture: the quadrants as the texture test's, times the vertex colour.
    let (textured_material, rest) = textured([1.0; 4], json!({ "magFilter": 9728, "minFilter": 9728 }), None);
    let doc = with_vertex_colors(quad_document(textured_material, rest, straight), [c; 4], false);
    let (got, _) = render_doc("vc-tex.gltf", &doc);
    let texel = TEXELS[1];
    let m = [0, 1, 2].map(|i| srgb_to_linear(texel[i]) * f64::from(c[i]));
    let (want, _) = render_doc("vc-tex-plain.gltf", &quad_document(lit(m), json!({}), straight));
    let (g, w) = (region(&got, 0.55, 0.9, 0.55, 0.9), region(&want, 0.55, 0.9, 0.55, 0.9));
    assert!(close(g, w, 1e-3), "texture × vertex colour {g:?}, factor {w:?}");
    // Red on the left corners, blue on the right: the middle column is purple, the mean.
    let (red, blue) = ([0.8f32, 0.1, 0.1], [0.1f32, 0.1, 0.8]);
    let doc = with_vertex_colors(quad_document(material.clone(), json!({}), straight), [red, blue, blue, red], false);
    let (got, _) = render_doc("vc-gradient.gltf", &doc);
    let mean = [0, 1, 2].map(|i| 0.5 * f64::from(red[i] + blue[i]) * factor[i]);
    let (want, _) = render_doc("vc-mean.gltf", &quad_document(lit(mean), json!({}), straight));
    let (g, w) = (region(&got, 0.4, 0.6, 0.1, 0.9), region(&want, 0.4, 0.6, 0.1, 0.9));
    assert!(close(g, w, 0.03), "middle of the gradient {g:?}, mean colour {w:?}");
    let (l, r) = (region(&got, 0.05, 0.2, 0.1, 0.9), region(&got, 0.8, 0.95, 0.1, 0.9));
    assert!(l[0] > 1.5 * r[0] && r[2] > 1.5 * l[2], "left is red, right is blue: {l:?} {r:?}");
    // An accessor that cannot hold colours is an error naming the attribute.
    let mut bad = with_vertex_colors(quad_document(material, json!({}), straight), [red; 4], false);
    bad["accessors"][3]["type"] = json!("VEC2");
    let path = write(&dir("textures"), "vc-bad.gltf", &bad);
    let e = gltf_import::read_scene(&path, &gltf_import::ReadOptions::default()).unwrap_err();
    assert_eq!(e.path, "meshes[0].primitives[0].attributes.COLOR_0", "{e}");
}

/// The quad of [`quad_document`] (a white diffuse material) with one morph target that moves its right edge (vertices
/// 1 and 2) by −0.5 in x, its displacements a sparse accessor without a buffer view (zeros but for `indices`, whose
/// `values` are the displacements); `mesh_weights` and `node_weights` as given. With `sparse_base`, the base positions
/// are sparse too: their right edge moved to x = 0 over the buffer view's positions.
fn morph_document(mesh_weights: Option<f32>, node_weights: Option<f32>, indices: [u32; 2], sparse_base: bool) -> Value {
    let material =
        json!({ "pbrMetallicRoughness": { "baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0 } });
    let mut doc = quad_document(material, json!({}), [0.0, 0.0, 0.0, 1.0]);
    let mut bytes = quad_buffer();
    bytes.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
    bytes.extend([[-0.5f32, 0.0, 0.0]; 2].iter().flatten().flat_map(|c| c.to_le_bytes()));
    bytes.extend([[0.0f32, -0.5, 0.0], [0.0, 0.5, 0.0]].iter().flatten().flat_map(|c| c.to_le_bytes()));
    doc["buffers"][0] = json!({ "byteLength": bytes.len(), "uri": data_uri("application/octet-stream", &bytes) });
    let views = doc["bufferViews"].as_array_mut().unwrap();
    views.push(json!({ "buffer": 0, "byteOffset": 104, "byteLength": 8 }));
    views.push(json!({ "buffer": 0, "byteOffset": 112, "byteLength": 24 }));
    views.push(json!({ "buffer": 0, "byteOffset": 136, "byteLength": 24 }));
    let sparse = |values: usize| json!({ "count": 2, "indices": { "bufferView": 3, "componentType": 5125 }, "values": { "bufferView": values } });
    doc["accessors"]
        .as_array_mut()
        .unwrap()
        .push(json!({ "componentType": 5126, "count": 4, "type": "VEC3", "sparse": sparse(4) }));
    if sparse_base {
        doc["accessors"][0]["sparse"] = sparse(5);
    }
    doc["meshes"][0]["primitives"][0]["targets"] = json!([ { "POSITION": 3 } ]);
    if let Some(w) = mesh_weights {
        doc["meshes"][0]["weights"] = json!([w]);
    }
    if let Some(w) = node_weights {
        doc["nodes"][0]["weights"] = json!([w]);
    }
    doc
}

/// Morph targets at the file's weights (the node's over the mesh's), with displacements in a sparse accessor, and
/// base positions in a sparse accessor over a buffer view: the lit quad ends where the weighted displacement puts
/// its right edge (the view shows x from 0 to 1, the quad without morphing fills it).
#[test]
fn morph_targets_at_their_weights_and_sparse_accessors() {
    let lit = |doc: &Value| {
        let film = render_doc("morph.gltf", doc).0;
        (region(&film, 0.0, 0.45, 0.0, 1.0), region(&film, 0.55, 0.7, 0.0, 1.0), region(&film, 0.8, 1.0, 0.0, 1.0))
    };
    let (full, _, _) = lit(&morph_document(None, None, [1, 2], false));
    assert!(full[1] > 0.1, "the unmorphed quad is lit: {full:?}");
    let dark = |v: [f64; 3]| v[1] < 1e-3 * full[1];
    // Weight 0.5 from the mesh: the right edge at x = 0.75.
    let (left, middle, right) = lit(&morph_document(Some(0.5), None, [1, 2], false));
    assert!(close(left, full, 0.01) && close(middle, full, 0.01) && dark(right), "{left:?} {middle:?} {right:?}");
    // The node's weight 1 wins over the mesh's 0.5: the right edge at x = 0.5.
    let (left, middle, right) = lit(&morph_document(Some(0.5), Some(1.0), [1, 2], false));
    assert!(close(left, full, 0.01) && dark(middle) && dark(right), "{left:?} {middle:?} {right:?}");
    // Base positions with the right edge substituted at x = 0 (sparse over the view), no morphing: edge at 0.5.
    let (left, middle, right) = lit(&morph_document(None, None, [1, 2], true));
    assert!(close(left, full, 0.01) && dark(middle) && dark(right), "{left:?} {middle:?} {right:?}");
    // And the target on top at weight 0.5: the edge at 0.25 (the base's x = 0 moved by −0.25), left of 0.45.
    let film = render_doc("morph.gltf", &morph_document(Some(0.5), None, [1, 2], true)).0;
    assert!(close(region(&film, 0.0, 0.2, 0.0, 1.0), full, 0.01) && dark(region(&film, 0.3, 1.0, 0.0, 1.0)));
}

/// Sparse accessors whose indices do not increase, leave the accessor, or whose data leaves its buffer view, and
/// morph weights that are not finite, are errors naming the JSON path.
#[test]
fn bad_sparse_accessors_and_weights_are_errors() {
    let read = |doc: &Value| {
        let path = write(&dir("textures"), "bad-sparse.gltf", doc);
        gltf_import::read_scene(&path, &gltf_import::ReadOptions::default()).unwrap_err().to_string()
    };
    let target = "meshes[0].primitives[0].targets[0].POSITION.sparse";
    for indices in [[2, 1], [1, 1]] {
        let e = read(&morph_document(Some(1.0), None, indices, false));
        assert!(e.contains(target) && e.contains("increase strictly"), "{indices:?}: {e}");
    }
    let e = read(&morph_document(Some(1.0), None, [1, 4], false));
    assert!(e.contains(target) && e.contains("index 4"), "{e}");
    let mut doc = morph_document(Some(1.0), None, [1, 2], false);
    doc["accessors"][3]["sparse"]["count"] = json!(3);
    let e = read(&doc);
    assert!(e.contains(target) && e.contains("past the end"), "{e}");
    doc["accessors"][3]["sparse"]["count"] = json!(5);
    let e = read(&doc);
    assert!(e.contains(target) && e.contains("count 5"), "{e}");
    // An accessor without data is zeros, up to 256 MiB of them.
    let mut doc = morph_document(Some(1.0), None, [1, 2], false);
    doc["accessors"][3].as_object_mut().unwrap().remove("sparse");
    doc["accessors"][3]["count"] = json!(100_000_000);
    let e = read(&doc);
    assert!(e.contains("accessors[3]") && e.contains("1200000000 bytes of zeros"), "{e}");
    let mut doc = morph_document(None, None, [1, 2], false);
    doc["nodes"][0]["weights"] = json!([1e39]);
    let e = read(&doc);
    assert!(e.contains("nodes[0].weights"), "{e}");
}

/// What Blender's exporter writes for a shape key (scenes/tools/gltf_scenes.py): a morph target at the mesh's
/// default weight 0.5 that moves the 2 m plane's +x edge from x = 1 towards 0, and normal displacements of zeros
/// written as an accessor without data. The plane, filling an orthographic view 2 m wide, ends at x = 0.5: the
/// view's right quarter is empty.
#[test]
fn a_blender_shape_key_is_rendered_at_its_value() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/shape-key-plane.glb");
    let bytes = std::fs::read(&path).unwrap();
    let length = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let doc: Value = serde_json::from_slice(&bytes[20..20 + length]).unwrap();
    let zeros = doc["accessors"].as_array().unwrap().iter().any(|a| a.get("bufferView").is_none());
    assert!(zeros && doc["meshes"][0]["weights"] == json!([0.5]), "the fixture has what the test is about");
    let desc = gltf_import::read_scene(&path, &gltf_import::ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert!(desc.warnings.is_empty(), "{:?}", desc.warnings);
    let film = render(&desc, 4, (SIDE, SIDE));
    let (plane, beyond) = (region(&film, 0.0, 0.7, 0.0, 1.0), region(&film, 0.8, 1.0, 0.0, 1.0));
    assert!(plane[1] > 0.1 && beyond[1] < 1e-3 * plane[1], "plane {plane:?}, beyond its edge {beyond:?}");
    // Its column just inside the edge is as lit as the middle: the normals stayed up.
    assert!(close(region(&film, 0.6, 0.74, 0.0, 1.0), region(&film, 0.2, 0.4, 0.0, 1.0), 0.02));
}

/// The textured quad with KHR_mesh_quantization's types: positions as normalised shorts (±32767, the node scaling
/// them to ±0.5), texture coordinates as normalised unsigned shorts, normals as normalised bytes, indices as
/// unsigned shorts; and a morph target of normalised short displacements at weight 0.5 (−32767: the right edge
/// moved by −1 in the mesh's units, −0.5 after the node's scale). Quantized, the quad renders as the float quad,
/// quadrant by quadrant; morphed, its right edge is at x = 0.75.
#[test]
fn quantized_attributes_render_as_floats() {
    let (material, rest) = textured([1.0; 4], json!({ "magFilter": 9728, "minFilter": 9728 }), None);
    let float_quad = quad_document(material.clone(), rest.clone(), [0.0, 0.0, 0.0, 1.0]);
    let quantized = |morph: bool| {
        let mut doc = quad_document(material.clone(), rest.clone(), [0.0, 0.0, 0.0, 1.0]);
        let m = 32767i16;
        let positions: [[i16; 4]; 4] = [[-m, -m, 0, 0], [m, -m, 0, 0], [m, m, 0, 0], [-m, m, 0, 0]];
        let uvs: [[u16; 2]; 4] = [[0, 65535], [65535, 65535], [65535, 0], [0, 0]];
        let mut bytes: Vec<u8> = positions.iter().flatten().flat_map(|c| c.to_le_bytes()).collect(); // 32 bytes
        bytes.extend(uvs.iter().flatten().flat_map(|c| c.to_le_bytes())); // 16
        bytes.extend([0u16, 1, 2, 0, 2, 3].iter().flat_map(|i| i.to_le_bytes())); // 12
        bytes.extend([[0i8, 0, 127, 0]; 4].iter().flatten().map(|&c| c as u8)); // 16
        let displacements: [[i16; 4]; 4] = [[0; 4], [-m, 0, 0, 0], [-m, 0, 0, 0], [0; 4]];
        bytes.extend(displacements.iter().flatten().flat_map(|c| c.to_le_bytes())); // 32
        doc["buffers"][0] = json!({ "byteLength": bytes.len(), "uri": data_uri("application/octet-stream", &bytes) });
        doc["bufferViews"] = json!([
            { "buffer": 0, "byteOffset": 0, "byteLength": 32, "byteStride": 8 },
            { "buffer": 0, "byteOffset": 32, "byteLength": 16 },
            { "buffer": 0, "byteOffset": 48, "byteLength": 12 },
            { "buffer": 0, "byteOffset": 60, "byteLength": 16, "byteStride": 4 },
            { "buffer": 0, "byteOffset": 76, "byteLength": 32, "byteStride": 8 }
        ]);
        doc["accessors"] = json!([
            { "bufferView": 0, "componentType": 5122, "normalized": true, "count": 4, "type": "VEC3", "min": [-32767, -32767, 0], "max": [32767, 32767, 0] },
            { "bufferView": 1, "componentType": 5123, "normalized": true, "count": 4, "type": "VEC2" },
            { "bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR" },
            { "bufferView": 3, "componentType": 5120, "normalized": true, "count": 4, "type": "VEC3" },
            { "bufferView": 4, "componentType": 5122, "normalized": true, "count": 4, "type": "VEC3" }
        ]);
        doc["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = json!(3);
        if morph {
            doc["meshes"][0]["primitives"][0]["targets"] = json!([ { "POSITION": 4 } ]);
            doc["meshes"][0]["weights"] = json!([0.5]);
        }
        doc["nodes"][0]["scale"] = json!([0.5, 0.5, 1.0]);
        doc["extensionsUsed"].as_array_mut().unwrap().push(json!("KHR_mesh_quantization"));
        doc["extensionsRequired"] = json!(["KHR_mesh_quantization"]);
        doc
    };
    let (reference, _) = render_doc("float-quad.gltf", &float_quad);
    let (film, desc) = render_doc("quantized.gltf", &quantized(false));
    assert!(desc.warnings.is_empty(), "{:?}", desc.warnings);
    let quadrants = [(0.0, 0.5, 0.5, 1.0), (0.5, 1.0, 0.5, 1.0), (0.0, 0.5, 0.0, 0.5), (0.5, 1.0, 0.0, 0.5)];
    for (x0, x1, y0, y1) in quadrants {
        let (got, want) = (region(&film, x0, x1, y0, y1), region(&reference, x0, x1, y0, y1));
        assert!(want[1] > 0.01 && close(got, want, 1e-3), "quadrant {x0} {y0}: quantized {got:?}, float {want:?}");
    }
    let (film, _) = render_doc("quantized-morph.gltf", &quantized(true));
    let (lit, beyond) = (region(&film, 0.0, 0.7, 0.0, 1.0), region(&film, 0.8, 1.0, 0.0, 1.0));
    assert!(lit[1] > 0.01 && beyond[1] < 1e-3 * lit[1], "lit {lit:?}, beyond the edge {beyond:?}");
}

/// A white metal's BRDF with KHR_materials_anisotropy at strength `s` along the direction at `angle` from the
/// tangent +x towards the bitangent +y (α_t = mix(α, 1, s²) along it, α_b = α across; the extension's D, Smith's
/// separable masking with the anisotropic Λ), for the view straight down the normal and light from `wi`.
fn anisotropic_metal(r: f64, s: f64, angle: f64, wi: [f64; 3]) -> f64 {
    let alpha = r * r;
    let (at, ab) = (alpha + (1.0 - alpha) * s * s, alpha);
    let (c, sn) = (angle.cos(), angle.sin());
    // Into the frame (t, b, n).
    let local = |w: [f64; 3]| [c * w[0] + sn * w[1], -sn * w[0] + c * w[1], w[2]];
    let (wo, wi) = ([0.0, 0.0, 1.0], local(wi));
    let h = [wi[0], wi[1], wi[2] + 1.0];
    let len = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
    let h = h.map(|v| v / len);
    let a2 = at * ab;
    let f = [ab * h[0], at * h[1], a2 * h[2]];
    let w2 = a2 / (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
    let d = a2 * w2 * w2 / std::f64::consts::PI;
    let lambda = |w: [f64; 3]| {
        let sin2 = w[0] * w[0] + w[1] * w[1];
        if sin2 == 0.0 {
            return 0.0;
        }
        let a2 = (at * at * w[0] * w[0] + ab * ab * w[1] * w[1]) / sin2;
        ((1.0 + a2 * sin2 / (w[2] * w[2])).sqrt() - 1.0) / 2.0
    };
    d / ((1.0 + lambda(wo)) * (1.0 + lambda(wi)) * 4.0 * wo[2] * wi[2])
}

/// KHR_materials_anisotropy on a white metal quad lit by a sun 0.6 rad from the normal at 30° azimuth (towards
/// +y) and seen head-on: its radiance relative to the isotropic metal's is the BRDF's ratio for the anisotropy
/// direction along the tangent and turned ±45° towards the bitangent (which differ: the sun is off the axes), as
/// the extension orients it. Also through an anisotropy texture whose texel turns the direction by a further 90°.
#[test]
fn anisotropy_is_oriented_in_the_tangent_frame() {
    let (theta, phi) = (0.6f64, 30f64.to_radians());
    let wi = [theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()];
    let (r, s) = (0.35, 0.8);
    let render_with = |anisotropy: Option<Value>, rest: Value| {
        let mut m = json!({ "pbrMetallicRoughness": { "baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 1.0, "roughnessFactor": r } });
        if let Some(a) = anisotropy {
            m["extensions"] = json!({ "KHR_materials_anisotropy": a });
        }
        let mut doc = quad_document(m, rest, [0.0, 0.0, 0.0, 1.0]);
        doc["extensionsUsed"].as_array_mut().unwrap().push(json!("KHR_materials_anisotropy"));
        // The quaternion turning +z to wi: about (−sin φ, cos φ, 0) by θ.
        let (hs, hc) = ((theta / 2.0).sin(), (theta / 2.0).cos());
        doc["nodes"][2]["rotation"] = json!([-phi.sin() * hs, phi.cos() * hs, 0.0, hc]);
        region(&render_doc("anisotropy.gltf", &doc).0, 0.2, 0.8, 0.2, 0.8)[1]
    };
    let iso = render_with(None, json!({}));
    let want_iso = anisotropic_metal(r, 0.0, 0.0, wi);
    assert!(iso > 0.01, "lit: {iso}");
    for angle in [0.0, std::f64::consts::FRAC_PI_4, -std::f64::consts::FRAC_PI_4] {
        let got = render_with(Some(json!({ "anisotropyStrength": s, "anisotropyRotation": angle })), json!({})) / iso;
        let want = anisotropic_metal(r, s, angle, wi) / want_iso;
        assert!(
            (got - want).abs() < 0.01 * want,
            "rotation {angle}: {got} of the isotropic radiance, BRDF says {want}"
        );
    }
    // A texel (0.5, 1, 1): direction (0, 1) in the tangent frame (90°), strength × 1; with the rotation −45°, the
    // direction is +45°.
    let png = png_rgba(1, 1, &[[128, 255, 255, 255]]);
    let rest = json!({ "textures": [ { "source": 0 } ], "images": [ { "uri": data_uri("image/png", &png) } ] });
    let a = json!({ "anisotropyStrength": s, "anisotropyRotation": -std::f64::consts::FRAC_PI_4, "anisotropyTexture": { "index": 0 } });
    let got = render_with(Some(a), rest) / iso;
    // 128/255 is not quite 0.5: the direction is (2·128/255 − 1, 1).
    let angle = 1f64.atan2(2.0 * 128.0 / 255.0 - 1.0) - std::f64::consts::FRAC_PI_4;
    let want = anisotropic_metal(r, s, angle, wi) / want_iso;
    assert!((got - want).abs() < 0.01 * want, "textured: {got}, BRDF says {want}");
}

/// The quad of [`quad_document`] drawn by EXT_mesh_gpu_instancing twice: instance A scaled by 0.4 and moved by
/// −0.25 in x (x from 0.05 to 0.45, y from 0.3 to 0.7 in the view), instance B scaled to 1 × 0.2, turned 90° about
/// z (a quantized rotation: normalised shorts) and moved by +0.25 (x from 0.65 to 0.85, y from 0 to 1). With
/// `emissive`, the material emits.
fn instanced_document(emissive: bool) -> Value {
    let mut material =
        json!({ "pbrMetallicRoughness": { "baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0 } });
    if emissive {
        material["emissiveFactor"] = json!([1.0, 1.0, 1.0]);
    }
    let mut doc = quad_document(material, json!({}), [0.0, 0.0, 0.0, 1.0]);
    let mut bytes = quad_buffer();
    bytes.extend([[-0.25f32, 0.0, 0.0], [0.25, 0.0, 0.0]].iter().flatten().flat_map(|c| c.to_le_bytes()));
    let q = 23170i16; // 32767 · sin 45°
    bytes.extend([[0i16, 0, 0, 32767], [0, 0, q, q]].iter().flatten().flat_map(|c| c.to_le_bytes()));
    bytes.extend([[0.4f32, 0.4, 1.0], [1.0, 0.2, 1.0]].iter().flatten().flat_map(|c| c.to_le_bytes()));
    doc["buffers"][0] = json!({ "byteLength": bytes.len(), "uri": data_uri("application/octet-stream", &bytes) });
    let views = doc["bufferViews"].as_array_mut().unwrap();
    views.push(json!({ "buffer": 0, "byteOffset": 104, "byteLength": 24 }));
    views.push(json!({ "buffer": 0, "byteOffset": 128, "byteLength": 16 }));
    views.push(json!({ "buffer": 0, "byteOffset": 144, "byteLength": 24 }));
    let accessors = doc["accessors"].as_array_mut().unwrap();
    accessors.push(json!({ "bufferView": 3, "componentType": 5126, "count": 2, "type": "VEC3" }));
    accessors.push(json!({ "bufferView": 4, "componentType": 5122, "normalized": true, "count": 2, "type": "VEC4" }));
    accessors.push(json!({ "bufferView": 5, "componentType": 5126, "count": 2, "type": "VEC3" }));
    doc["nodes"][0]["extensions"] =
        json!({ "EXT_mesh_gpu_instancing": { "attributes": { "TRANSLATION": 3, "ROTATION": 4, "SCALE": 5 } } });
    doc["extensionsUsed"].as_array_mut().unwrap().push(json!("EXT_mesh_gpu_instancing"));
    doc["extensionsRequired"] = json!(["EXT_mesh_gpu_instancing"]);
    doc
}

/// EXT_mesh_gpu_instancing: each instance's translation, rotation and scale are applied in the node's space before
/// its transform, the instances sharing one object (or, for an emitter, each a shape of its own, since area lights
/// are not made inside instances); an instance scaled to nothing is left out; bad instance attributes are errors
/// naming their JSON path.
#[test]
fn gpu_instances_are_placed_by_their_transforms() {
    let (film, desc) = render_doc("instanced.gltf", &instanced_document(false));
    assert!(desc.warnings.is_empty(), "{:?}", desc.warnings);
    assert_eq!((desc.objects.len(), desc.instances.len(), desc.shapes.len()), (1, 2, 0));
    let lit = region(&film, 0.05, 0.45, 0.3, 0.7);
    assert!(lit[1] > 0.1, "instance A is lit: {lit:?}");
    for (x0, x1, y0, y1, on) in [
        (0.05, 0.45, 0.75, 1.0, false),
        (0.65, 0.85, 0.8, 1.0, true),
        (0.65, 0.85, 0.0, 0.2, true),
        (0.85, 1.0, 0.3, 0.7, false),
        (0.45, 0.65, 0.3, 0.7, false),
    ] {
        let y = region(&film, x0, x1, y0, y1)[1];
        let ok = if on { (y - lit[1]).abs() < 0.03 * lit[1] } else { y < 1e-3 * lit[1] };
        assert!(ok, "[{x0}, {x1}] × [{y0}, {y1}]: {y} (lit {})", lit[1]);
    }
    // An instance scaled to nothing is left out.
    let mut doc = instanced_document(false);
    let mut bytes = quad_buffer();
    bytes.extend([[-0.25f32, 0.0, 0.0], [0.25, 0.0, 0.0]].iter().flatten().flat_map(|c| c.to_le_bytes()));
    bytes.extend([[0i16, 0, 0, 32767], [0, 0, 0, 32767]].iter().flatten().flat_map(|c| c.to_le_bytes()));
    bytes.extend([[0.4f32, 0.4, 1.0], [0.0, 0.0, 0.0]].iter().flatten().flat_map(|c| c.to_le_bytes()));
    doc["buffers"][0] = json!({ "byteLength": bytes.len(), "uri": data_uri("application/octet-stream", &bytes) });
    let (film, desc) = render_doc("instanced-hidden.gltf", &doc);
    assert_eq!(desc.instances.len(), 1);
    assert!((region(&film, 0.05, 0.45, 0.3, 0.7)[1] - lit[1]).abs() < 0.03 * lit[1]);
    let (_, desc) = render_doc("instanced-emitter.gltf", &instanced_document(true));
    assert_eq!((desc.objects.len(), desc.instances.len(), desc.shapes.len()), (0, 0, 2));
    let read = |doc: &Value| {
        let path = write(&dir("textures"), "bad-instances.gltf", doc);
        gltf_import::read_scene(&path, &gltf_import::ReadOptions::default()).unwrap_err().to_string()
    };
    let at = "nodes[0].extensions.EXT_mesh_gpu_instancing.attributes";
    let mut doc = instanced_document(false);
    doc["accessors"][5]["count"] = json!(1);
    let e = read(&doc);
    assert!(e.contains(&format!("{at}.SCALE")) && e.contains("one value per instance"), "{e}");
    let mut doc = instanced_document(false);
    doc["nodes"][0]["extensions"]["EXT_mesh_gpu_instancing"]["attributes"]["TRANSLATION"] = json!(9);
    let e = read(&doc);
    assert!(e.contains(&format!("{at}.TRANSLATION")) && e.contains("accessors"), "{e}");
    let mut doc = instanced_document(false);
    doc["nodes"][0]["extensions"]["EXT_mesh_gpu_instancing"]["attributes"]["ROTATION"] = json!(3);
    let e = read(&doc);
    assert!(e.contains(&format!("{at}.ROTATION")) && e.contains("cannot hold"), "{e}");
}

/// A quad with vertex `NORMAL`s (+z) and `TANGENT`s turned 45° from ∂p/∂u (+x) towards +y: a normal map's texel
/// tilted towards +u, (0.6, 0, 0.8), tilts the normal towards the given tangent, not towards +x, so it shades as
/// the quad turned to (0.6·(1, 1)/√2, 0.8).
#[test]
fn a_normal_map_follows_the_files_tangents() {
    let render_lit = |map: bool, rotation: [f64; 4]| {
        let (m, rest) = normal_mapped(map.then_some([0.6, 0.0, 0.8]));
        let mut doc = quad_document(m, rest, rotation);
        let mut bytes = quad_buffer();
        bytes.extend([[0f32, 0.0, 1.0]; 4].iter().flatten().flat_map(|c| c.to_le_bytes()));
        let s = std::f32::consts::FRAC_1_SQRT_2;
        bytes.extend([[s, s, 0.0, 1.0]; 4].iter().flatten().flat_map(|c| c.to_le_bytes()));
        doc["buffers"][0] = json!({ "byteLength": bytes.len(), "uri": data_uri("application/octet-stream", &bytes) });
        let views = doc["bufferViews"].as_array_mut().unwrap();
        views.push(json!({ "buffer": 0, "byteOffset": 104, "byteLength": 48 }));
        views.push(json!({ "buffer": 0, "byteOffset": 152, "byteLength": 64 }));
        let accessors = doc["accessors"].as_array_mut().unwrap();
        accessors.push(json!({ "bufferView": 3, "componentType": 5126, "count": 4, "type": "VEC3" }));
        accessors.push(json!({ "bufferView": 4, "componentType": 5126, "count": 4, "type": "VEC4" }));
        doc["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = json!(3);
        doc["meshes"][0]["primitives"][0]["attributes"]["TANGENT"] = json!(4);
        let (sn, cs) = (15f64.to_radians().sin(), 15f64.to_radians().cos());
        doc["nodes"][2]["rotation"] = json!([sn / 2f64.sqrt(), sn / 2f64.sqrt(), 0.0, cs]);
        let (film, desc) = render_doc("tangents.gltf", &doc);
        assert_eq!(desc.corner_tangents.len(), usize::from(map), "tangents are kept for a normal-mapped material only");
        region(&film, 0.3, 0.7, 0.3, 0.7)
    };
    // The quaternion turning +z to (0.6/√2, 0.6/√2, 0.8): about (−1, 1, 0)/√2 by asin 0.6.
    let half = 0.6f64.asin() / 2.0;
    let k = half.sin() / 2f64.sqrt();
    let (got, want) = (render_lit(true, [0.0, 0.0, 0.0, 1.0]), render_lit(false, [-k, k, 0.0, half.cos()]));
    assert!(close(got, want, 0.01), "mapped {got:?}, turned geometry {want:?}");
}

//! End-to-end tests of the light-tracing integrators (issue 4) through the pbrt parser: they put each wavelength
//! of a beam refracted by a prism where Snell's law says, and light tracing refuses a camera light cannot reach.
//! Their agreement with the path tracer, their determinism and their furnace tests run on scenes built in code, in
//! `crates/render/src/tests/integrators.rs` and `furnace.rs`.

use std::path::Path;

use film::Film;
use render::{build_scene, BuildOptions, BuiltScene};
use spectral::WavelengthStrategy;

mod support;
use support::build;

fn render(built: &BuiltScene, spp: u32, seed: u32) -> Film {
    let mut spec = built.film.clone();
    spec.wavelengths = WavelengthStrategy::Hero;
    let mut film = Film::new(spec).unwrap();
    built.integrator.render(&built.scene, &mut film, 0..spp, seed, &|_| {}).unwrap();
    film
}

/// A diffuse room (a floor, a back wall, a coloured sphere and a quad light facing down) rendered by `integrator`.
fn diffuse_room(integrator: &str) -> String {
    format!(
        r#"LookAt 0 1.5 -4  0 1 0  0 1 0
Camera "perspective" "float fov" 45
Film "rgb" "integer xresolution" 24 "integer yresolution" 18
PixelFilter "box"
Integrator "{integrator}" "integer maxdepth" 4
WorldBegin
AttributeBegin
  AreaLightSource "diffuse" "blackbody L" 5000 "float scale" 4
  Shape "trianglemesh" "point3 P" [ -0.6 3 -0.6  0.6 3 -0.6  0.6 3 0.6  -0.6 3 0.6 ] "integer indices" [ 0 1 2 0 2 3 ]
AttributeEnd
Material "diffuse" "rgb reflectance" [ 0.7 0.7 0.7 ]
Shape "trianglemesh" "point3 P" [ -4 0 -4  4 0 -4  4 0 4  -4 0 4 ] "integer indices" [ 0 2 1 0 3 2 ]
Shape "trianglemesh" "point3 P" [ -4 0 2  -4 4 2  4 4 2  4 0 2 ] "integer indices" [ 0 1 2 0 2 3 ]
Material "diffuse" "rgb reflectance" [ 0.2 0.6 0.3 ]
Translate -0.8 0.5 0.5
Shape "sphere" "float radius" 0.5
"#
    )
}

/// 2D vector helpers in the x–z plane of the prism tests.
type V2 = [f64; 2];
fn sub(a: V2, b: V2) -> V2 {
    [a[0] - b[0], a[1] - b[1]]
}
fn dot(a: V2, b: V2) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}
fn norm(a: V2) -> V2 {
    let l = dot(a, a).sqrt();
    [a[0] / l, a[1] / l]
}
fn along(p: V2, d: V2, t: f64) -> V2 {
    [p[0] + t * d[0], p[1] + t * d[1]]
}

/// Refracts unit `d` through a surface with unit normal `n` (pointing against `d`) from index `n1` to `n2`
/// (Snell's law in vector form); `None` on total internal reflection.
fn refract(d: V2, n: V2, eta: f64) -> Option<V2> {
    let cos_i = -dot(d, n);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i);
    if sin2_t > 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some(norm([eta * d[0] + (eta * cos_i - cos_t) * n[0], eta * d[1] + (eta * cos_i - cos_t) * n[1]]))
}

/// Where a ray `p + t·d` meets the line through `a` with unit normal `n`.
fn hit_line(p: V2, d: V2, a: V2, n: V2) -> V2 {
    along(p, d, dot(sub(a, p), n) / dot(d, n))
}

/// The prism of the beam test: an equilateral triangle (side 2, centroid at the origin) in the x–z plane,
/// extruded along y, and a beam entering its left face at 60° incidence.
struct BeamPrism {
    verts: [V2; 3],
    source: V2,
    dir: V2,
    ior: optics::Ior,
}

impl BeamPrism {
    fn new() -> Self {
        let h = 3f64.sqrt();
        let verts = [[-1.0, -h / 3.0], [1.0, -h / 3.0], [0.0, 2.0 * h / 3.0]];
        // Outward normal of the left face is (−cos 30°, sin 30°); the beam direction makes 60° with its reverse.
        let dir = [30f64.to_radians().cos(), 30f64.to_radians().sin()];
        let mid = [(verts[0][0] + verts[2][0]) / 2.0, (verts[0][1] + verts[2][1]) / 2.0];
        let source = along(mid, dir, -4.0);
        Self { verts, source, dir, ior: optics::catalogue::lookup("N-SF11").unwrap().ior }
    }

    /// Outward unit normal of the face from vertex `i` to vertex `j`.
    fn normal(&self, i: usize, j: usize) -> V2 {
        let e = sub(self.verts[j], self.verts[i]);
        let n = norm([e[1], -e[0]]);
        let c = [0.0, 0.0];
        if dot(n, sub(self.verts[i], c)) > 0.0 {
            n
        } else {
            [-n[0], -n[1]]
        }
    }

    /// The beam's central ray after both refractions at wavelength `lambda` (exit point, direction) and the
    /// Fresnel transmittance of the two faces (unpolarised).
    fn exit(&self, lambda: f64) -> (V2, V2, f64) {
        let n = self.ior.n(lambda);
        let (n_left, n_right) = (self.normal(0, 2), self.normal(1, 2));
        let p1 = hit_line(self.source, self.dir, self.verts[0], n_left);
        let cos1 = -dot(self.dir, n_left);
        let d1 = refract(self.dir, n_left, 1.0 / n).unwrap();
        let p2 = hit_line(p1, d1, self.verts[1], n_right);
        let inside = [-n_right[0], -n_right[1]];
        let d2 = refract(d1, inside, n).expect("no total internal reflection at the exit face");
        let t = (1.0 - optics::fresnel_dielectric(cos1, n)) * (1.0 - optics::fresnel_dielectric(-dot(d1, n_right), n));
        (p2, d2, t)
    }

    /// The prism as a pbrt triangle mesh with outward normals (y from −1 to 1).
    fn mesh(&self) -> String {
        let v = |i: usize, y: f64| format!("{} {} {}", self.verts[i][0], y, self.verts[i][1]);
        let p: Vec<String> = (0..3).flat_map(|i| [v(i, -1.0), v(i, 1.0)]).collect();
        // Vertex 2i is (verts[i], y = −1), 2i + 1 is (verts[i], y = 1). Winding makes cross(p0 − p2, p1 − p2)
        // point outwards; checked against the face normals below.
        let quads = [(0usize, 1usize), (1, 2), (2, 0)];
        let mut idx = vec![];
        let pos = |k: usize| {
            let i = k / 2;
            [self.verts[i][0], if k.is_multiple_of(2) { -1.0 } else { 1.0 }, self.verts[i][1]]
        };
        let mut tri = |a: usize, b: usize, c: usize, out: [f64; 3]| {
            let (p0, p1, p2) = (pos(a), pos(b), pos(c));
            let e1 = [p0[0] - p2[0], p0[1] - p2[1], p0[2] - p2[2]];
            let e2 = [p1[0] - p2[0], p1[1] - p2[1], p1[2] - p2[2]];
            let n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
            if n[0] * out[0] + n[1] * out[1] + n[2] * out[2] > 0.0 {
                idx.extend([a, b, c]);
            } else {
                idx.extend([a, c, b]);
            }
        };
        for (i, j) in quads {
            let n = self.normal(i, j);
            let out = [n[0], 0.0, n[1]];
            tri(2 * i, 2 * j, 2 * j + 1, out);
            tri(2 * i, 2 * j + 1, 2 * i + 1, out);
        }
        tri(0, 2, 4, [0.0, -1.0, 0.0]);
        tri(1, 3, 5, [0.0, 1.0, 0.0]);
        let i: Vec<String> = idx.iter().map(|k| k.to_string()).collect();
        format!("Shape \"trianglemesh\" \"point3 P\" [ {} ] \"integer indices\" [ {} ]\n", p.join("  "), i.join(" "))
    }
}

/// A narrow beam (a 0.4° spot light) through a 60° N-SF11 prism onto a white screen, seen by a camera off the
/// beam's plane, on a spectral film. Each bucket's centroid on the film must sit where Snell's law with N-SF11's
/// n(λ) puts the beam for the bucket's wavelengths, within 0.3 pixels; changing n by 0.002 moves the prediction by
/// more than a pixel (asserted), so the test resolves the index to about 5e-4.
#[test]
fn lightpath_beam_through_a_prism_lands_where_snell_says() {
    beam_through_a_prism(r#"Integrator "lightpath" "integer maxdepth" 3"#, 8, 0.3);
}

/// The same beam with photon mapping: 64 iterations (each with its own four wavelengths, so every bucket is
/// sampled by about 30 of them) and a gather radius of about one pixel on the screen; 0.35 pixels allowed for the
/// finite set of wavelengths per bucket.
#[test]
fn sppm_beam_through_a_prism_lands_where_snell_says() {
    // 128 iterations: each draws one set of four hero wavelengths, and pbrt-v4's visible pdf puts half as many in
    // the 420–452 nm bucket as x̄ + ȳ + z̄ did (64 iterations left that bucket's centroid 0.61 px off).
    beam_through_a_prism(r#"Integrator "sppm" "integer maxdepth" 3 "float radius" 0.008"#, 128, 0.35);
}

/// The same beam with bidirectional path tracing (its light-tracing strategy carries the caustic).
#[test]
fn bdpt_beam_through_a_prism_lands_where_snell_says() {
    beam_through_a_prism(r#"Integrator "bdpt" "integer maxdepth" 3"#, 8, 0.3);
}

/// The same beam through the same prism built and exported by Blender (`scenes/tools/gltf_scenes.py`): a glTF file
/// with `KHR_materials_transmission`, `_ior` and `_dispersion` brought in by `Import`, whose glass is the Abbe model
/// of the file's n_d and V_d = 20/dispersion.
#[test]
fn lightpath_beam_through_a_blender_gltf_prism_lands_where_snell_says() {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/gltf/dispersive-prism.glb");
    // The numbers as Blender's exporter wrote them (f32): ior 1.78472, dispersion 20/25.68.
    let (nd, dispersion) = (1.784_719_944_000_244_1, 0.778_816_223_144_531_2);
    let abbe = optics::Ior::abbe(nd, 20.0 / dispersion).unwrap();
    let import = format!("Import \"{}\"\n", file.display());
    beam_through(r#"Integrator "lightpath" "integer maxdepth" 3"#, 8, 0.3, Some((import, abbe)));
}

fn beam_through_a_prism(integrator: &str, spp: u32, tolerance: f32) {
    beam_through(integrator, spp, tolerance, None);
}

/// The beam test with the prism written in pbrt-v4 syntax (N-SF11), or given as scene text with its glass's index.
fn beam_through(integrator: &str, spp: u32, tolerance: f32, prism_text: Option<(String, optics::Ior)>) {
    let mut prism = BeamPrism::new();
    let prism_shape = match prism_text {
        Some((text, ior)) => {
            prism.ior = ior;
            text
        }
        None => format!("Material \"dielectric\" \"string glass\" \"N-SF11\"\n  {}", prism.mesh()),
    };
    let (lambda_min, lambda_max, nbuckets) = (420.0, 680.0, 8usize);
    // The screen: perpendicular to the 550 nm exit ray, 3 units beyond the exit point.
    let (e550, d550, _) = prism.exit(550.0);
    let screen_c = along(e550, d550, 3.0);
    let screen_n = [-d550[0], -d550[1]];
    let tangent = [d550[1], -d550[0]];
    let corner = |s: f64, y: f64| {
        let p = along(screen_c, tangent, s);
        format!("{} {} {}", p[0], y, p[1])
    };
    let screen = format!(
        "Shape \"trianglemesh\" \"point3 P\" [ {} {} {} {} ] \"integer indices\" [ 0 1 2 0 2 3 ]\n",
        corner(-2.0, -1.5),
        corner(2.0, -1.5),
        corner(2.0, 1.5),
        corner(-2.0, 1.5)
    );
    let cam = along(screen_c, screen_n, 3.0);
    let (w, h) = (160u32, 120u32);
    let from = [prism.source[0], 0.0, prism.source[1]];
    let to = [prism.source[0] + prism.dir[0], 0.0, prism.source[1] + prism.dir[1]];
    let scene = format!(
        r#"LookAt {} -1.2 {}  {} 0 {}  0 0 1
Camera "perspective" "float fov" 20
Film "spectral" "integer xresolution" {w} "integer yresolution" {h}
    "integer nbuckets" {nbuckets} "float lambdamin" {lambda_min} "float lambdamax" {lambda_max}
PixelFilter "box"
{integrator}
WorldBegin
LightSource "spot" "point3 from" [ {} {} {} ] "point3 to" [ {} {} {} ] "float coneangle" 0.4
    "float conedeltaangle" 0 "spectrum I" [ 360 1  830 1 ]
AttributeBegin
  {prism_shape}AttributeEnd
AttributeBegin
  Material "diffuse" "rgb reflectance" [ 1 1 1 ]
  {screen}AttributeEnd
"#,
        cam[0], cam[1], screen_c[0], screen_c[1], from[0], from[1], from[2], to[0], to[1], to[2],
    );
    let built = build(&scene, "test.pbrt");
    let camera = built.scene.camera();
    let cam_pos = camera.position();
    // Raster position of the beam's screen point at wavelength λ, and its Fresnel weight.
    let predict = |lambda: f64, dn: f64| {
        let mut p = BeamPrism::new();
        p.ior = if dn != 0.0 { optics::Ior::constant(prism.ior.n(lambda) + dn).unwrap() } else { prism.ior.clone() };
        let (e, d, t) = p.exit(lambda);
        let s = hit_line(e, d, screen_c, screen_n);
        let world = glam::Vec3::new(s[0] as f32, 0.0, s[1] as f32);
        let (_, raster) = camera.we(cam_pos, (world - cam_pos).normalize()).expect("beam on the film");
        (raster, t)
    };
    let sensitivity = (predict(550.0, 0.002).0 - predict(550.0, 0.0).0).length();
    assert!(sensitivity > 1.0, "Δn = 0.002 moves the beam by only {sensitivity} px");

    let film = render(&built, spp, 11);
    let centres = built.film.kind.bucket_centres();
    let width = built.film.kind.bucket_width();
    let mut spread = 0.0f32;
    for (b, &centre) in centres.iter().enumerate() {
        let (mut sx, mut sy, mut sw) = (0.0, 0.0, 0.0);
        for y in 0..h {
            for x in 0..w {
                let v = film.pixel_spectrum(x, y)[b];
                sx += v * (x as f64 + 0.5);
                sy += v * (y as f64 + 0.5);
                sw += v;
            }
        }
        assert!(sw > 0.0, "bucket {centre} nm is empty");
        let got = glam::Vec2::new((sx / sw) as f32, (sy / sw) as f32);
        // Prediction: the bucket's wavelengths weighted by the light (flat) times the Fresnel transmittance.
        let (mut px, mut pw) = (glam::Vec2::ZERO, 0.0f32);
        for i in 0..100 {
            let lambda = centre + width * ((i as f64 + 0.5) / 100.0 - 0.5);
            let (r, t) = predict(lambda, 0.0);
            px += r * t as f32;
            pw += t as f32;
        }
        let want = px / pw;
        spread = spread.max((want - predict(centres[0], 0.0).0).length());
        eprintln!("{integrator}: bucket {centre} nm: centroid {got}, Snell {want}, error {}", (got - want).length());
        assert!((got - want).length() < tolerance, "bucket {centre} nm: centroid {got}, Snell {want}");
    }
    // The spectrum is spread over many pixels, so the check distinguishes the buckets.
    assert!(spread > 10.0, "spectrum spans only {spread} px");
}

/// Light tracing needs a camera that light paths can reach: an orthographic camera is an error naming the camera's
/// line, not a black image.
#[test]
fn lightpath_with_an_orthographic_camera_is_an_error() {
    let text = diffuse_room("lightpath").replace(r#"Camera "perspective" "float fov" 45"#, r#"Camera "orthographic""#);
    let desc = pbrt::parse_str(&text, Path::new("ortho.pbrt")).unwrap();
    let e = build_scene(&desc, &BuildOptions::default()).err().expect("an error").to_string();
    assert!(e.contains("ortho.pbrt:2:") && e.contains("perspective"), "{e}");
}

//! `coateddiffuse` against the geometry it stands for: a rough dielectric interface a hair above a Lambertian floor,
//! built from a `dielectric` quad and a `diffuse` quad and path traced. The layered BSDF (random walks between the
//! interfaces, Guo et al. 2018) must give the same image under a small sphere light, where the shape of the BSDF
//! matters, not only its albedo.
//!
//! pbrt-v4 renders the two geometric scenes alike (0.001530 against Prismatic's 0.001525, mean over the floor's
//! half of the image, 48×48 at 2048 spp) but its `coateddiffuse` 9.8% brighter (0.001675), while under a uniform sky
//! all four agree within 0.5%: this is the test behind the deviation docs/scene-format.md ("Layered materials")
//! records.

use std::path::Path;

use crate::{build_scene, BuildOptions, BuiltScene};

/// The scene: camera above a large floor, a sphere light of radius 0.3 at height 1.5, and `floor` (the lines that
/// make the floor) with paths of up to 100 events, at `spp` samples per pixel.
fn scene(floor: &str, spp: u32) -> BuiltScene {
    let text = format!(
        "LookAt 0 3 -3  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 70\n\
         Film \"rgb\" \"integer xresolution\" 24 \"integer yresolution\" 24\n\
         Sampler \"zsobol\" \"integer pixelsamples\" {spp}\nIntegrator \"path\" \"integer maxdepth\" 100\n\
         WorldBegin\n\
         AttributeBegin\nTranslate 0 1.5 1\nAreaLightSource \"diffuse\" \"spectrum L\" [ 360 1 830 1 ]\n\
         Shape \"sphere\" \"float radius\" 0.3\nAttributeEnd\n{floor}\n"
    );
    let desc = pbrt::parse_str(&text, Path::new("coat.pbrt")).unwrap_or_else(|e| panic!("{e}"));
    build_scene(&desc, &BuildOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

/// Mean Y over the bottom half of the image (the floor; the light is in the top half).
fn floor_y(built: &BuiltScene) -> f64 {
    let h = built.film.height;
    super::support::mean_y(built, 5, h / 2..h)
}

#[test]
fn coated_diffuse_equals_a_rough_interface_over_a_diffuse_floor() {
    const QUAD: &str = "\"integer indices\" [ 0 2 1  0 3 2 ]";
    // The coat's medium made negligible (optical depth 1e-4) and the walks long, so that the layered BSDF models
    // exactly the two surfaces below: an interface of index 1.5 and roughness 0.3 (α = √0.3) over albedo 0.64.
    let layered = scene(
        &format!(
            "Material \"coateddiffuse\" \"spectrum reflectance\" [ 360 0.64 830 0.64 ] \"float roughness\" 0.3 \
             \"float thickness\" 0.0001 \"integer maxdepth\" 100\n\
             Shape \"trianglemesh\" \"point3 P\" [ -50 0 -50  50 0 -50  50 0 50  -50 0 50 ] {QUAD}"
        ),
        64,
    );
    // The interface 0.001 above the floor, its normal up (glass below it).
    let geometric = scene(
        &format!(
            "Material \"diffuse\" \"spectrum reflectance\" [ 360 0.64 830 0.64 ]\n\
             Shape \"trianglemesh\" \"point3 P\" [ -50 0 -50  50 0 -50  50 0 50  -50 0 50 ] {QUAD}\n\
             Material \"dielectric\" \"float roughness\" 0.3 \"float eta\" 1.5\n\
             Shape \"trianglemesh\" \"point3 P\" [ -50 0.001 -50  50 0.001 -50  50 0.001 50  -50 0.001 50 ] {QUAD}"
        ),
        1024,
    );
    let (l, g) = (floor_y(&layered), floor_y(&geometric));
    // The geometric scene finds the light only by sampling through the rough interface: seeds spread by about 1%
    // at 1024 spp (2% at 256); the layered one by 0.1% at 256 spp. pbrt-v4's coateddiffuse is 9.8% above.
    assert!((l / g - 1.0).abs() < 0.04, "coateddiffuse {l}, the geometry it models {g}");
}

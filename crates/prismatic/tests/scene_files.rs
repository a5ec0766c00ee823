//! Scenes made of many files, as pbrt-v4's collection has them: thousands of `plymesh` shapes (some gzip-compressed)
//! and TGA image textures. The PLY files are read on all cores; the image and the first error reported must not
//! depend on that.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("prismatic-files-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn prismatic(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_prismatic")).arg("render").args(args).current_dir(dir).output().unwrap()
}

fn gzip(data: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    e.write_all(data).unwrap();
    e.finish().unwrap()
}

/// An ASCII PLY of the unit square [0,1]² at z = 0 (one quad, so two triangles).
const SQUARE: &str = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
                      element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n\
                      4 0 1 2 3\n";

const N: usize = 48;

/// Writes `N` PLY files (every third gzip-compressed) and a scene placing them on an 8×6 grid under a TGA-textured
/// material; returns the scene file's line of each `Shape`.
fn write_scene(dir: &Path) -> Vec<usize> {
    std::fs::create_dir_all(dir.join("geometry")).unwrap();
    // A 2×2 TGA, RLE true colour, all pixels (R, G, B) = (200, 120, 40).
    let mut tga = vec![0u8, 0, 10, 0, 0, 0, 0, 0, 0, 0, 0, 0, 2, 0, 2, 0, 24, 0x20];
    tga.extend([0x83, 40, 120, 200]);
    std::fs::write(dir.join("wood.tga"), tga).unwrap();
    let mut scene = String::from(
        "LookAt 4 3 4  4 3 0  0 1 0\nCamera \"perspective\" \"float fov\" 60\n\
         Film \"rgb\" \"integer xresolution\" 12 \"integer yresolution\" 9 \"string filename\" \"out.exr\"\n\
         Sampler \"zsobol\" \"integer pixelsamples\" 4\nIntegrator \"path\" \"integer maxdepth\" 2\nWorldBegin\n\
         LightSource \"distant\" \"point3 from\" [ 0 0 1 ] \"point3 to\" [ 0 0 0 ]\n\
         Texture \"wood\" \"spectrum\" \"imagemap\" \"string filename\" \"wood.tga\" \"string encoding\" \"sRGB\"\n\
         Material \"diffuse\" \"texture reflectance\" \"wood\"\n",
    );
    let mut lines = Vec::new();
    for k in 0..N {
        let name = if k % 3 == 0 { format!("geometry/m{k}.ply.gz") } else { format!("geometry/m{k}.ply") };
        let bytes = if k % 3 == 0 { gzip(SQUARE.as_bytes()) } else { SQUARE.as_bytes().to_vec() };
        std::fs::write(dir.join(&name), bytes).unwrap();
        scene += &format!("AttributeBegin\n  Translate {} {} 0\n", k % 8, k / 8);
        lines.push(scene.lines().count() + 1);
        scene += &format!("  Shape \"plymesh\" \"string filename\" \"{name}\"\nAttributeEnd\n");
    }
    std::fs::write(dir.join("scene.pbrt"), scene).unwrap();
    lines
}

#[test]
fn many_ply_files_load_in_parallel_with_the_same_image() {
    let dir = temp_dir("many");
    write_scene(&dir);
    let mut images = Vec::new();
    for threads in ["1", "2", "4"] {
        let out = format!("out{threads}.exr");
        let run = prismatic(&dir, &["scene.pbrt", "-o", &out, "--threads", threads]);
        let stdout = String::from_utf8_lossy(&run.stdout);
        assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
        // The statistics give the scene load time, split into parsing and building.
        assert!(stdout.contains("scene load ") && stdout.contains(" s (parse "), "{stdout}");
        assert!(stdout.contains(&format!("{} triangles", 2 * N)), "{stdout}");
        images.push(film::read_exr_rgb(&dir.join(out)).unwrap().2);
    }
    assert!(images.iter().all(|im| *im == images[0]));
    // The squares tile the view, and the TGA texture is the constant reflectance its sRGB (200, 120, 40) decodes
    // to: (0.57758, 0.18782, 0.021219). The same scene with that rgb reflectance renders the same image.
    let scene = std::fs::read_to_string(dir.join("scene.pbrt")).unwrap();
    let constant =
        scene.replace("\"texture reflectance\" \"wood\"", "\"rgb reflectance\" [ 0.57758 0.18782 0.021219 ]");
    assert_ne!(constant, scene);
    std::fs::write(dir.join("constant.pbrt"), constant).unwrap();
    let run = prismatic(&dir, &["constant.pbrt", "-o", "constant.exr", "--quiet"]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let reference = film::read_exr_rgb(&dir.join("constant.exr")).unwrap().2;
    for (p, q) in images[0].iter().zip(&reference) {
        assert!(p[0] > p[1] && p[1] > p[2] && p[0] > 0.0, "{p:?}");
        for c in 0..3 {
            assert!((p[c] - q[c]).abs() <= 1e-3 * q[c].abs().max(1e-3), "{p:?} vs {q:?}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_first_bad_ply_file_in_scene_order_is_the_error() {
    let dir = temp_dir("bad");
    let lines = write_scene(&dir);
    // Shape 30 is a truncated gzip file, shape 13 a PLY with an index out of range; 13 comes first in the file.
    let z = gzip(SQUARE.as_bytes());
    std::fs::write(dir.join("geometry/m30.ply.gz"), &z[..z.len() / 2]).unwrap();
    std::fs::write(dir.join("geometry/m13.ply"), SQUARE.replace("4 0 1 2 3", "4 0 1 2 9")).unwrap();
    let at = format!("scene.pbrt:{}:3: error", lines[13]);
    for _ in 0..3 {
        let run = prismatic(&dir, &["scene.pbrt", "-o", "out.exr", "--quiet"]);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success() && !stderr.contains("panicked"), "{stderr}");
        assert!(stderr.contains(&at) && stderr.contains("m13.ply") && stderr.contains("out of range"), "{stderr}");
    }
    // With shape 13 repaired, the truncated gzip file is reported, at its own line.
    std::fs::write(dir.join("geometry/m13.ply"), SQUARE).unwrap();
    let run = prismatic(&dir, &["scene.pbrt", "-o", "out.exr", "--quiet"]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    let at = format!("scene.pbrt:{}:3: error", lines[30]);
    assert!(stderr.contains(&at) && stderr.contains("corrupt or truncated gzip"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}

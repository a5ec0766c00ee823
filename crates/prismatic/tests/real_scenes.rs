//! The pbrt-v4 test-collection scenes kept in the pbrt crate's fixtures render unchanged through the command line,
//! at a small size (`--resolution`) and few samples, and show what the scenes are: killeroo-gold's gold
//! conductor is yellow (red > green > blue) against its grey tiled room, killeroo-simple's two coated killeroos are
//! green and red on a floor lit by a small sphere light.

use std::path::{Path, PathBuf};
use std::process::Command;

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../pbrt/tests/fixtures")
}

/// Renders `scene` (relative to the fixtures) at 64×48 with `spp` samples and returns its linear RGB pixels.
fn render(scene: &str, spp: u32) -> Vec<[f32; 3]> {
    let out =
        std::env::temp_dir().join(format!("prismatic-real-{}-{}.exr", std::process::id(), scene.replace('/', "-")));
    let scene = fixtures().join(scene);
    let run = Command::new(env!("CARGO_BIN_EXE_prismatic"))
        .args(["render", "--resolution", "64x48", "--spp", &spp.to_string(), "--quiet", "-o"])
        .arg(&out)
        .arg(&scene)
        .current_dir(scene.parent().unwrap())
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let (w, h, px) = film::read_rgb(&out).unwrap();
    std::fs::remove_file(&out).unwrap();
    assert_eq!((w, h), (64, 48));
    px
}

/// Mean linear RGB over pixels x0 ≤ x < x1, y0 ≤ y < y1 of a 64-wide image.
fn mean(px: &[[f32; 3]], [x0, y0, x1, y1]: [usize; 4]) -> [f64; 3] {
    let mut s = [0.0f64; 3];
    for y in y0..y1 {
        for x in x0..x1 {
            for c in 0..3 {
                s[c] += px[y * 64 + x][c] as f64;
            }
        }
    }
    let n = ((x1 - x0) * (y1 - y0)) as f64;
    s.map(|v| v / n)
}

/// Largest over smallest channel.
fn spread(c: [f64; 3]) -> f64 {
    c.iter().cloned().fold(0.0, f64::max) / c.iter().cloned().fold(f64::INFINITY, f64::min)
}

#[test]
fn killeroo_gold_renders_unchanged() {
    // Measured at 16 spp: body (1.35, 1.03, 0.46), wall (0.289, 0.296, 0.288), floor (0.40, 0.40, 0.38).
    let px = render("killeroos/killeroo-gold.pbrt", 16);
    let body = mean(&px, [29, 10, 38, 22]);
    let wall = mean(&px, [1, 1, 12, 10]);
    let floor = mean(&px, [0, 38, 64, 48]);
    // Gold (Au's η, k from the scene's .spd files) reflects red most and blue least.
    assert!(body[0] > 1.15 * body[1] && body[1] > 1.6 * body[2], "body {body:?}");
    // The room's tiles are grey: lines.png modulates a white diffuse, under a white light.
    assert!(spread(wall) < 1.08 && spread(floor) < 1.12, "wall {wall:?} floor {floor:?}");
    assert!((0.2..0.4).contains(&wall[1]) && (0.3..0.5).contains(&floor[1]), "wall {wall:?} floor {floor:?}");
}

#[test]
fn killeroo_simple_renders_unchanged() {
    // Measured at 16 spp: the top strip, dark but for the small sphere light, (6.1, 6.5, 6.1); the bluish-lit floor
    // (0.22, 0.22, 0.35); around the left (green) killeroo (0.104, 0.128, 0.117) and the right (red) one (0.033,
    // 0.024, 0.037, with the floor between its legs).
    let px = render("killeroos/killeroo-simple.pbrt", 16);
    let top = mean(&px, [0, 0, 64, 12]);
    let floor = mean(&px, [0, 38, 64, 48]);
    let green = mean(&px, [18, 20, 30, 28]);
    let red = mean(&px, [38, 24, 48, 34]);
    assert!(top.iter().all(|&v| v > 3.0) && spread(top) < 1.15, "top {top:?}");
    assert!(floor[2] > 1.4 * floor[0] && (0.15..0.3).contains(&floor[0]), "floor {floor:?}");
    assert!(green[1] > 1.12 * green[0], "green killeroo {green:?}");
    assert!(red[0] > 1.2 * red[1], "red killeroo {red:?}");
}

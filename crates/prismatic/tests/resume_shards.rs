//! Checkpoints, resume, shards and merge, as a user runs them: the binary on small scenes in a temporary directory.
//!
//! - a render killed with SIGKILL between checkpoints resumes from the last complete checkpoint and writes the
//!   image of an uninterrupted render bit for bit, for every integrator (RGB, spectral and gbuffer films in turn:
//!   every channel, the gbuffer's geometry and variance too);
//! - resuming refuses changed scene files (the main file, an included file, a PLY mesh), other options, and
//!   damaged, truncated or foreign checkpoint files, with a message and without a panic;
//! - the shards of a render merge into the single-process image: within one f32 unit in the last place of the
//!   pixel's largest value for sample shards (the gbuffer's channels within two units of the value), bit for bit
//!   for sppm's bands of rows; merge refuses parts of other scenes, seeds or options, missing and repeated shards.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

mod support;
use support::{ok, prismatic};

/// A fresh, empty temporary directory for one test.
fn temp_dir(name: &str) -> PathBuf {
    support::temp_dir("resume", name)
}

/// Asserts that the run failed with an error message (exit status 1: a refusal, not a scene or I/O error; no panic)
/// and returns the message.
#[track_caller]
fn failure(out: &Output) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    stderr
}

/// A 16×16 scene: a dispersive glass sphere on a diffuse PLY floor (from `floor.ply`) under a disk light in an
/// included file, and a dim environment; `INTEGRATOR` and `FILM` are replaced.
const SCENE: &str = r#"LookAt 0 0.8 -4  0 0.5 0  0 1 0
Camera "perspective" "float fov" 40
Film "FILM" "integer xresolution" 16 "integer yresolution" 16 "string filename" "scene.exr"
Sampler "zsobol" "integer pixelsamples" 4
Integrator "INTEGRATOR" "integer maxdepth" 5
WorldBegin
LightSource "infinite" "rgb L" [ 0.2 0.25 0.3 ]
Include "light.pbrt"
AttributeBegin
  Material "diffuse" "rgb reflectance" [ 0.6 0.5 0.3 ]
  Shape "plymesh" "string filename" "floor.ply"
AttributeEnd
AttributeBegin
  Material "dielectric" "string glass" "N-SF11"
  Translate 0 0.6 0
  Shape "sphere" "float radius" 0.6
AttributeEnd
"#;

const LIGHT: &str = r#"AttributeBegin
  AreaLightSource "diffuse" "blackbody L" 4500 "float scale" 5
  Translate 0 3 0
  Rotate 90 1 0 0
  Shape "disk" "float radius" 1
AttributeEnd
"#;

const FLOOR: &str = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
                     element face 2\nproperty list uchar int vertex_indices\nend_header\n\
                     -4 0 -4\n4 0 -4\n4 0 4\n-4 0 4\n3 0 2 1\n3 0 3 2\n";

/// Writes the scene (with `integrator` and an `rgb`, `spectral` or `gbuffer` film) and its files into `dir`.
fn write_scene(dir: &Path, integrator: &str, film: &str) {
    std::fs::write(dir.join("scene.pbrt"), SCENE.replace("INTEGRATOR", integrator).replace("FILM", film)).unwrap();
    std::fs::write(dir.join("light.pbrt"), LIGHT).unwrap();
    std::fs::write(dir.join("floor.ply"), FLOOR).unwrap();
}

/// Every value of an EXR: R, G, B, then the spectral channels (if any), pixel by pixel.
fn values(path: &Path) -> (Vec<[f32; 3]>, Vec<f32>, usize) {
    let (_, _, rgb) = film::read_exr_rgb(path).unwrap();
    match film::read_exr_spectral(path) {
        Ok(s) => (rgb, s.data, s.wavelengths_nm.len()),
        Err(_) => (rgb, Vec::new(), 0),
    }
}

/// The channels of an EXR other than R, G, B and the spectral ones: a gbuffer film's (albedo, geometry,
/// variance), by name.
fn other_channels(path: &Path) -> Vec<(String, Vec<f32>)> {
    let (_, _, channels) = film::read_exr_channels(path).unwrap();
    channels.into_iter().filter(|(n, _)| !["R", "G", "B"].contains(&n.as_str()) && !n.starts_with("S0.")).collect()
}

/// Asserts two EXRs hold the same bits in every channel.
#[track_caller]
fn assert_identical(a: &Path, b: &Path, what: &str) {
    let (oa, ob) = (other_channels(a), other_channels(b));
    assert_eq!(oa.len(), ob.len(), "{what}");
    for ((na, va), (nb, vb)) in oa.iter().zip(&ob) {
        assert_eq!(na, nb, "{what}");
        assert!(va.iter().zip(vb).all(|(p, q)| p.to_bits() == q.to_bits()), "{what}: {na} differs");
    }
    let (ra, sa, _) = values(a);
    let (rb, sb, _) = values(b);
    assert_eq!(ra.len(), rb.len(), "{what}");
    assert!(ra.iter().zip(&rb).all(|(p, q)| p.map(f32::to_bits) == q.map(f32::to_bits)), "{what}: RGB differs");
    assert_eq!(sa.len(), sb.len(), "{what}");
    assert!(sa.iter().zip(&sb).all(|(p, q)| p.to_bits() == q.to_bits()), "{what}: spectral channels differ");
    assert!(ra.iter().any(|p| p[1] > 0.0), "{what}: black image");
}

/// (start, end, done) of a checkpoint file: its pass range and the passes it holds (see the format's table).
fn checkpoint_passes(path: &Path) -> (u32, u32, u32) {
    let b = std::fs::read(path).unwrap();
    let u = |i: usize| u32::from_le_bytes(b[i..i + 4].try_into().unwrap());
    assert_eq!(&b[..8], b"PRISMCKP");
    (u(28), u(32), u(36))
}

/// Starts a render with a checkpoint after every pass, waits until the first checkpoint is on disk and a little
/// more, then kills the process with SIGKILL: no handler runs, so what is on disk is whatever the last atomic write
/// left.
#[cfg(unix)]
fn render_and_kill(dir: &Path, args: &[&str]) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_prismatic"))
        .arg("render")
        .args(args)
        .args(["--checkpoint", "c.ckpt", "--checkpoint-every", "0", "--quiet"])
        .current_dir(dir)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    while !dir.join("c.ckpt").exists() {
        assert!(child.try_wait().unwrap().is_none(), "the render ended before its first checkpoint");
        std::thread::yield_now();
    }
    std::thread::sleep(std::time::Duration::from_millis(100));
    child.kill().unwrap();
    let status = child.wait().unwrap();
    use std::os::unix::process::ExitStatusExt;
    assert_eq!(status.signal(), Some(9), "the render finished before it was killed: make it longer");
}

/// SIGKILL between checkpoints, then `render --resume`: the image is bit for bit the uninterrupted render's, for
/// every integrator (splats of lightpath and bdpt, sppm's progressive statistics), RGB, spectral and gbuffer
/// films in turn, and a spectral film with `--aovs` (the gbuffer's channels on it). The checkpoint was really taken mid-render (fewer passes done than asked). (A kill during a write
/// can leave a temporary file beside it; the checkpoint itself is always a complete one.)
#[cfg(unix)]
#[test]
fn a_killed_render_resumes_to_the_uninterrupted_image() {
    for (integrator, film, spp, aovs) in [
        ("path", "spectral", 2048, false),
        ("volpath", "gbuffer", 2048, false),
        ("bdpt", "spectral", 1536, true),
        ("lightpath", "rgb", 2048, false),
        ("sppm", "gbuffer", 4096, false),
    ] {
        let dir = temp_dir(&format!("kill-{integrator}"));
        write_scene(&dir, integrator, film);
        let spp = spp.to_string();
        let aovs: &[&str] = if aovs { &["--aovs"] } else { &[] };
        render_and_kill(&dir, &[&["scene.pbrt", "--spp", &spp, "--seed", "3", "-o", "out.exr"], aovs].concat());
        let (start, end, done) = checkpoint_passes(&dir.join("c.ckpt"));
        assert!(start == 0 && done < end && end.to_string() == spp, "{integrator}: {start}..{end}, done {done}");
        let resumed = ok(prismatic(&dir, &["render", "--resume", "c.ckpt"]));
        let summary = String::from_utf8_lossy(&resumed.stdout);
        assert!(summary.contains(&format!("resumed at {done}")), "{summary}");
        let whole = ["render", "scene.pbrt", "--spp", &spp, "--seed", "3", "-o", "whole.exr", "--quiet"];
        ok(prismatic(&dir, &[&whole[..], aovs].concat()));
        let names: Vec<String> = other_channels(&dir.join("out.exr")).into_iter().map(|(n, _)| n).collect();
        assert_eq!(names.iter().any(|n| n == "P.Z"), film == "gbuffer" || !aovs.is_empty(), "{integrator}");
        assert_identical(&dir.join("out.exr"), &dir.join("whole.exr"), integrator);
        let header = film::read_exr_text_attributes(&dir.join("out.exr")).unwrap();
        assert_eq!(header["samplesPerPixel"], spp);
        // The checkpoint now holds the finished render: resuming it again writes the same image.
        ok(prismatic(&dir, &["render", "--resume", "c.ckpt", "-o", "again.exr", "--quiet"]));
        assert_identical(&dir.join("again.exr"), &dir.join("whole.exr"), integrator);
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// The same command line with --resume added continues the render; any change to the scene's files (the main
/// file, an included file, the PLY mesh) or to the options that change the image is refused with a message that
/// says what differs; damaged, truncated and foreign checkpoints are errors, never panics.
#[test]
fn resume_refuses_other_scenes_options_and_damaged_checkpoints() {
    let dir = temp_dir("refuse");
    write_scene(&dir, "path", "rgb");
    // `render` with the options of the checkpointed render (8 spp unless `extra` says otherwise).
    let render = |extra: &[&str]| {
        let mut args = vec!["render", "scene.pbrt", "--quiet"];
        args.extend_from_slice(extra);
        if !extra.contains(&"--spp") {
            args.extend_from_slice(&["--spp", "8"]);
        }
        prismatic(&dir, &args)
    };
    ok(render(&["--checkpoint", "c.ckpt", "-o", "first.exr"]));
    // The same command with --resume: fine, the same image.
    ok(render(&["--resume", "c.ckpt", "-o", "second.exr"]));
    assert_identical(&dir.join("first.exr"), &dir.join("second.exr"), "same command");
    let e = failure(&render(&["--resume", "c.ckpt", "--spp", "9"]));
    assert!(e.contains("options differ") && e.contains("spp: 9 vs 8"), "{e}");
    let e = failure(&render(&["--resume", "c.ckpt", "--seed", "2"]));
    assert!(e.contains("seed: 2 vs 0"), "{e}");
    let e = failure(&render(&["--resume", "c.ckpt", "--wavelengths", "cmf"]));
    assert!(e.contains("wavelengths: cmf vs hero"), "{e}");
    // Any scene file changed, even by one byte, is another scene.
    for (file, text) in [("floor.ply", FLOOR.replace("-4 0 -4", "-4 0 -5")), ("light.pbrt", LIGHT.replace('5', "6"))] {
        std::fs::write(dir.join(file), text).unwrap();
        let e = failure(&prismatic(&dir, &["render", "--resume", "c.ckpt"]));
        assert!(e.contains("scene's files changed"), "{file}: {e}");
        write_scene(&dir, "path", "rgb");
    }
    let main = std::fs::read_to_string(dir.join("scene.pbrt")).unwrap();
    std::fs::write(dir.join("scene.pbrt"), main.clone() + "# a comment\n").unwrap();
    assert!(failure(&prismatic(&dir, &["render", "--resume", "c.ckpt"])).contains("scene's files changed"));
    std::fs::write(dir.join("scene.pbrt"), &main).unwrap();
    ok(prismatic(&dir, &["render", "--resume", "c.ckpt", "-o", "third.exr", "--quiet"]));
    // Damaged, truncated, empty and foreign files.
    let bytes = std::fs::read(dir.join("c.ckpt")).unwrap();
    let mut flipped = bytes.clone();
    flipped[bytes.len() / 2] ^= 1;
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("flipped", flipped, "damaged"),
        ("truncated", bytes[..bytes.len() - 100].to_vec(), "truncated"),
        ("empty", Vec::new(), "not a Prismatic checkpoint"),
        ("foreign", std::fs::read(dir.join("first.exr")).unwrap(), "not a Prismatic checkpoint"),
    ];
    for (name, content, want) in cases {
        std::fs::write(dir.join(name), content).unwrap();
        let e = failure(&prismatic(&dir, &["render", "--resume", name]));
        assert!(e.contains(want), "{name}: {e}");
    }
    // A checkpoint that cannot be read is an I/O error (exit status 4), not a refusal (1).
    let out = prismatic(&dir, &["render", "--resume", "nowhere.ckpt"]);
    let e = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(4), "{e}");
    assert!(e.contains("cannot read checkpoint"), "{e}");
    // Options that cannot be checkpointed or sharded.
    assert_eq!(render(&["--time", "1", "--checkpoint", "x.ckpt"]).status.code(), Some(2));
    let e = failure(&render(&["--shard", "5/4"]));
    assert!(e.contains("--shard"), "{e}");
    let e = failure(&render(&["--shard", "1/9"]));
    assert!(e.contains("8 spp cannot be split into 9"), "{e}");
    let e = failure(&render(&["--shard", "1/2", "-o", "part.png"]));
    assert!(e.contains(".exr"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Every value of a merged image is within 2⁻²³ (one f32 unit in the last place) of the pixel's largest value in
/// the single-process image (RGB and the spectral channels each); returns how many values are bit-identical.
#[track_caller]
fn assert_within_rounding(merged: &Path, single: &Path, what: &str) -> (usize, usize) {
    let (ra, sa, nb) = values(merged);
    let (rb, sb, _) = values(single);
    let mut same = 0;
    let mut count = 0;
    for (i, (p, q)) in ra.iter().zip(&rb).enumerate() {
        let m = q.iter().fold(0.0f32, |m, v| m.max(v.abs()));
        for c in 0..3 {
            assert!((p[c] - q[c]).abs() <= m * f32::EPSILON, "{what}: pixel {i} channel {c}: {} vs {}", p[c], q[c]);
            same += usize::from(p[c].to_bits() == q[c].to_bits());
            count += 1;
        }
    }
    for (p, q) in sa.chunks(nb.max(1)).zip(sb.chunks(nb.max(1))) {
        let m = q.iter().fold(0.0f32, |m, v| m.max(v.abs()));
        for (a, b) in p.iter().zip(q) {
            assert!((a - b).abs() <= m * f32::EPSILON, "{what}: bucket {a} vs {b}");
            same += usize::from(a.to_bits() == b.to_bits());
            count += 1;
        }
    }
    assert!(rb.iter().any(|p| p[1] > 0.0), "{what}: black image");
    // The gbuffer's channels are ratios (sums over weight sums, normalised sums, variances from sums of squares):
    // within two f32 units of the value, or of the channel's largest value times 10⁻⁹ where sums cancel to ~0.
    let (oa, ob) = (other_channels(merged), other_channels(single));
    assert_eq!(oa.len(), ob.len(), "{what}");
    for ((na, va), (nb, vb)) in oa.iter().zip(&ob) {
        assert_eq!(na, nb, "{what}");
        let scale = vb.iter().fold(0.0f32, |m, v| m.max(v.abs()));
        for (i, (a, b)) in va.iter().zip(vb).enumerate() {
            let tol = 2.0 * f32::EPSILON * a.abs().max(b.abs()) + 1e-9 * scale;
            assert!((a - b).abs() <= tol, "{what}: {na} pixel {i}: {a} vs {b}");
            same += usize::from(a.to_bits() == b.to_bits());
            count += 1;
        }
    }
    (same, count)
}

/// Three shards merged equal the single-process render: within one f32 unit of the pixel's largest value for the
/// sample shards of path, volpath, bdpt and lightpath (sums regrouped, see the merge's bound), bit for bit for
/// sppm's bands of rows, RGB, spectral and gbuffer films, and a spectral film with `--aovs`. A part alone is not
/// the image (each holds a third of the samples, or of the rows).
#[test]
fn shards_merge_into_the_single_process_image() {
    for (film, aovs) in [("rgb", false), ("spectral", false), ("gbuffer", false), ("spectral", true)] {
        let aovs: &[&str] = if aovs { &["--aovs"] } else { &[] };
        for integrator in ["path", "volpath", "bdpt", "lightpath", "sppm"] {
            let what = format!("{integrator} ({film}{})", aovs.concat());
            let dir = temp_dir(&format!("shards-{integrator}-{film}{}", aovs.concat()));
            write_scene(&dir, integrator, film);
            let spp = "6";
            let whole = ["render", "scene.pbrt", "--spp", spp, "--seed", "4", "-o", "whole.exr", "--quiet"];
            ok(prismatic(&dir, &[&whole[..], aovs].concat()));
            for k in 1..=3 {
                let (shard, out) = (format!("{k}/3"), format!("part-{k}.exr"));
                let args = ["render", "scene.pbrt", "--spp", spp, "--seed", "4", "--shard", &shard, "-o", &out];
                ok(prismatic(&dir, &[&args[..], aovs].concat()));
                let header = film::read_exr_text_attributes(&dir.join(&out)).unwrap();
                assert_eq!(header["prismatic.shard"], shard);
                let passes =
                    if integrator == "sppm" { "0..6".to_string() } else { format!("{}..{}", 2 * k - 2, 2 * k) };
                assert_eq!(header["prismatic.passes"], passes, "{what}");
                assert_eq!(header["prismatic.seed"], "4");
            }
            // Given in any order.
            ok(prismatic(&dir, &["merge", "part-3.exr", "part-1.exr", "part-2.exr", "-o", "merged.exr"]));
            let names: Vec<String> = other_channels(&dir.join("merged.exr")).into_iter().map(|(n, _)| n).collect();
            let gbuffer = ["P.Z", "dzdx", "N.X", "Ns.Y", "u", "Variance.G", "RelativeVariance.B"];
            let want = film == "gbuffer" || !aovs.is_empty();
            assert_eq!(gbuffer.iter().all(|g| names.iter().any(|n| n == g)), want, "{what}: {names:?}");
            if integrator == "sppm" {
                assert_identical(&dir.join("merged.exr"), &dir.join("whole.exr"), &what);
                let layout = film::read_exr_layout(&dir.join("part-2.exr")).unwrap();
                assert_eq!((layout.data_origin, layout.data_size), ((0, 5), (16, 5)), "{what}: the middle band");
            } else {
                let (same, count) = assert_within_rounding(&dir.join("merged.exr"), &dir.join("whole.exr"), &what);
                assert!(same * 2 > count, "{what}: only {same} of {count} values bit-identical");
                let (part, _, _) = values(&dir.join("part-1.exr"));
                let (whole, _, _) = values(&dir.join("whole.exr"));
                let far = part.iter().zip(&whole).filter(|(p, q)| (p[1] - q[1]).abs() > 1e-3 * q[1].abs()).count();
                assert!(far > part.len() / 4, "{what}: a part alone is the whole image");
            }
            let header = film::read_exr_text_attributes(&dir.join("merged.exr")).unwrap();
            assert_eq!(header["samplesPerPixel"], spp);
            let _ = std::fs::remove_dir_all(&dir);
        }
    }
}

/// Merge refuses what is not the N shards of one render: parts of another seed, options or scene, a shard given
/// twice, a missing shard, shards of different splits, a plain image.
#[test]
fn merge_refuses_parts_of_other_renders() {
    let dir = temp_dir("merge-refuse");
    write_scene(&dir, "bdpt", "rgb");
    let part = |out: &str, shard: &str, extra: &[&str]| {
        let mut args = vec!["render", "scene.pbrt", "--spp", "4", "--shard", shard, "-o", out, "--quiet"];
        args.extend_from_slice(extra);
        ok(prismatic(&dir, &args));
    };
    part("a1.exr", "1/2", &[]);
    part("a2.exr", "2/2", &[]);
    part("seed.exr", "2/2", &["--seed", "9"]);
    part("cmf.exr", "2/2", &["--wavelengths", "cmf"]);
    part("q1.exr", "1/4", &[]);
    ok(prismatic(&dir, &["render", "scene.pbrt", "--spp", "4", "-o", "plain.exr", "--quiet"]));
    let merge = |parts: &[&str]| {
        let mut args = vec!["merge"];
        args.extend_from_slice(parts);
        args.extend_from_slice(&["-o", "m.exr"]);
        prismatic(&dir, &args)
    };
    ok(merge(&["a1.exr", "a2.exr"]));
    for (parts, want) in [
        (vec!["a1.exr", "seed.exr"], "different seeds"),
        (vec!["a1.exr", "cmf.exr"], "different options"),
        (vec!["a1.exr", "a1.exr"], "given twice"),
        (vec!["a1.exr"], "shards 2/2 are missing"),
        (vec!["a1.exr", "a2.exr", "q1.exr"], "of 4"),
        (vec!["a1.exr", "plain.exr"], "not a render part"),
    ] {
        let e = failure(&merge(&parts));
        assert!(e.contains(want), "{parts:?}: {e}");
    }
    // Another scene: the same options on changed scene files.
    std::fs::write(dir.join("light.pbrt"), LIGHT.replace("4500", "5000")).unwrap();
    part("other.exr", "2/2", &[]);
    let e = failure(&merge(&["a1.exr", "other.exr"]));
    assert!(e.contains("different scenes"), "{e}");
    // And the scene as it is now is not the one a1 and a2 were rendered from.
    let e = failure(&merge(&["a1.exr", "a2.exr"]));
    assert!(e.contains("not those the parts were rendered from"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

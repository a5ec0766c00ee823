//! Checkpoints of a render in progress, and the hashes that tie checkpoints and shard parts to their scene.
//!
//! # The checkpoint file
//!
//! A checkpoint holds what a render has accumulated after its last complete sample pass (or photon-mapping
//! iteration): the film's accumulators ([`film::FilmState`]) and the integrator job's own state
//! ([`render::RenderJob::save_state`]), with what is needed to check that a resumed render is the
//! same render. It is written atomically (a synced temporary file renamed over the old one), so after a crash or a
//! `kill -9` the file on disk is the last complete checkpoint. Every number is little-endian:
//!
//! | bytes | field |
//! |---|---|
//! | 8 | magic `PRISMCKP` |
//! | 4 | format version, u32 (1) |
//! | 8 | scene hash, u64: [`Fnv64`] of every input file's length and bytes, in the order read |
//! | 8 | options hash, u64: [`Fnv64`] of the canonical text of the options that change the image |
//! | 4 + 4 | the render's pass range, first and one past the last, u32 |
//! | 4 | passes done: the passes `first..done` are in the state, u32 |
//! | 4 + P | the render's options ([`Plan`]) as UTF-8 `key=value` lines, P ≤ 64 KiB |
//! | 4 × 4 | the film state's pixel bounds x0, x1, y0, y1, u32 |
//! | 8 + 8 + 8 | light paths (f64), dropped samples (u64), dropped splats (u64) |
//! | 4 | number of planes K, u32, K ≤ 4096 |
//! | K × (2 + L + 8·n) | per plane: name length L (u16, ≤ 64), the name, n = pixels of the bounds f64 values |
//! | 8 + J | the job's state: its length J (u64), then its bytes |
//! | 8 | [`Fnv64`] of every byte before it |
//!
//! Reading checks the magic, the version and the trailing hash first (a truncated or damaged file fails there),
//! then every length against the bytes actually left before allocating anything.

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Context, Result};
use film::{FilmState, PixelBounds, Plane};
use spectral::WavelengthStrategy;

/// The first bytes of a checkpoint.
pub const MAGIC: &[u8; 8] = b"PRISMCKP";
/// The format version written and read.
pub const VERSION: u32 = 1;
const MAX_PLAN_BYTES: usize = 64 << 10;
const MAX_PLANES: usize = 4096;
const MAX_PLANE_NAME: usize = 64;

/// The 64-bit FNV-1a hash (Fowler, Noll, Vo): enough to notice a changed file or option, not a defence against
/// someone forging one.
#[derive(Clone, Copy, Debug)]
pub struct Fnv64(u64);

impl Default for Fnv64 {
    fn default() -> Self {
        Fnv64(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv64 {
    /// Adds `bytes`.
    pub fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ b as u64).wrapping_mul(0x0100_0000_01b3);
        }
    }

    /// The hash so far.
    pub fn finish(&self) -> u64 {
        self.0
    }

    /// The hash of `bytes`.
    pub fn of(bytes: &[u8]) -> u64 {
        let mut h = Fnv64::default();
        h.write(bytes);
        h.finish()
    }
}

/// The scene hash: every input file's length and bytes, in order (file names do not count, so a scene directory
/// can move).
pub fn scene_hash(files: &[PathBuf]) -> Result<u64> {
    let mut h = Fnv64::default();
    for f in files {
        let bytes = std::fs::read(f).with_context(|| format!("cannot read scene file {}", f.display()))?;
        h.write(&(bytes.len() as u64).to_le_bytes());
        h.write(&bytes);
    }
    Ok(h.finish())
}

/// The options of a render as given on the command line (paths absolute): what a checkpoint records to rebuild the
/// render, and what shard parts record to rebuild the film they merge into.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// The scene file.
    pub scene: PathBuf,
    /// The output file, if given with `-o`.
    pub output: Option<PathBuf>,
    /// `--spp`.
    pub spp: Option<u32>,
    /// `--seed`.
    pub seed: u32,
    /// `--wavelengths`.
    pub wavelengths: WavelengthStrategy,
    /// `--resolution`.
    pub resolution: Option<(u32, u32)>,
    /// `--cropwindow`.
    pub crop_window: Option<[f64; 4]>,
    /// `--pixelbounds`.
    pub pixel_bounds: Option<[u32; 4]>,
    /// `--aovs`.
    pub aovs: bool,
    /// `--shard K/N`.
    pub shard: Option<(u32, u32)>,
    /// `--view`: how the PNG shows the film (an output option like `output`: a resume may change it).
    pub view: Option<film::View>,
    /// `--colorspace`: the output colour space (an output option: the film accumulates XYZ whatever it is).
    pub colorspace: Option<String>,
    /// `--camera`: a glTF scene's camera, by name or index (recorded only when given, so that plans written
    /// before the option existed read back unchanged).
    pub camera: Option<String>,
    /// `--integrator`: the integrator's arguments instead of the scene's (recorded only when given).
    pub integrator: Option<String>,
    /// `--env`: an environment image (recorded only when given, with `--env-strength`).
    pub env: Option<PathBuf>,
    /// `--env-strength`.
    pub env_strength: f64,
}

fn join<T: ToString>(v: &[T]) -> String {
    v.iter().map(ToString::to_string).collect::<Vec<_>>().join(" ")
}

impl Plan {
    /// The options that change the image, as `key=value` lines (the output and the shard excluded).
    pub fn image_options(&self) -> Vec<(&'static str, String)> {
        let or_none = |v: Option<String>| v.unwrap_or_else(|| "none".into());
        vec![
            ("spp", or_none(self.spp.map(|s| s.to_string()))),
            ("seed", self.seed.to_string()),
            ("wavelengths", self.wavelengths.to_string()),
            ("resolution", or_none(self.resolution.map(|(w, h)| format!("{w}x{h}")))),
            // Rust prints f64 so that it parses back to the same bits.
            ("cropwindow", or_none(self.crop_window.map(|c| join(&c.map(|v| format!("{v:?}")))))),
            ("pixelbounds", or_none(self.pixel_bounds.map(|b| join(&b)))),
            ("aovs", self.aovs.to_string()),
        ]
    }

    /// All options as `key=value` pairs.
    pub fn to_pairs(&self) -> Vec<(String, String)> {
        let mut out = vec![("scene".to_string(), self.scene.display().to_string())];
        if let Some(o) = &self.output {
            out.push(("output".into(), o.display().to_string()));
        }
        out.extend(self.image_options().into_iter().map(|(k, v)| (k.to_string(), v)));
        if let Some((k, n)) = self.shard {
            out.push(("shard".into(), format!("{k}/{n}")));
        }
        if let Some(v) = self.view {
            out.push(("view".into(), v.name().to_string()));
        }
        if let Some(c) = &self.colorspace {
            out.push(("colorspace".into(), c.clone()));
        }
        if let Some(c) = &self.camera {
            out.push(("camera".into(), c.clone()));
        }
        if let Some(i) = &self.integrator {
            out.push(("integrator".into(), i.clone()));
        }
        if let Some(e) = &self.env {
            out.push(("env".into(), e.display().to_string()));
            out.push(("env-strength".into(), format!("{:?}", self.env_strength)));
        }
        out
    }

    /// All options as `key=value` lines.
    pub fn to_text(&self) -> String {
        self.to_pairs().into_iter().map(|(k, v)| format!("{k}={v}\n")).collect()
    }

    /// Reads options written by [`Plan::to_pairs`]; a missing or malformed value is an error naming it.
    pub fn from_pairs(pairs: &BTreeMap<String, String>) -> Result<Self> {
        let get = |k: &str| pairs.get(k).map(String::as_str).ok_or_else(|| anyhow!("no '{k}' option recorded"));
        let bad = |k: &str, v: &str| anyhow!("recorded option {k}={v} is malformed");
        fn opt<T>(v: &str, f: impl FnOnce(&str) -> Option<T>) -> Option<Option<T>> {
            if v == "none" {
                Some(None)
            } else {
                f(v).map(Some)
            }
        }
        fn nums<T: std::str::FromStr, const N: usize>(v: &str) -> Option<[T; N]> {
            let parsed: Option<Vec<T>> = v.split(' ').map(|s| s.parse().ok()).collect();
            parsed?.try_into().ok()
        }
        let spp = get("spp")?;
        let resolution = get("resolution")?;
        let crop = get("cropwindow")?;
        let bounds = get("pixelbounds")?;
        let wavelengths = get("wavelengths")?;
        let shard = pairs.get("shard").map(|s| parse_shard(s)).transpose()?;
        let view = pairs.get("view").map(|v| film::View::by_name(v).ok_or_else(|| bad("view", v))).transpose()?;
        let colorspace = pairs.get("colorspace").cloned();
        let camera = pairs.get("camera").cloned();
        let integrator = pairs.get("integrator").cloned();
        let env = pairs.get("env").map(PathBuf::from);
        let env_strength = match pairs.get("env-strength") {
            Some(v) => v.parse().map_err(|_| bad("env-strength", v))?,
            None => 1.0,
        };
        Ok(Plan {
            scene: PathBuf::from(get("scene")?),
            output: pairs.get("output").map(PathBuf::from),
            spp: opt(spp, |v| v.parse().ok()).ok_or_else(|| bad("spp", spp))?,
            seed: get("seed")?.parse().map_err(|_| anyhow!("recorded option seed is malformed"))?,
            wavelengths: wavelengths.parse().map_err(|_| bad("wavelengths", wavelengths))?,
            resolution: opt(resolution, |v| {
                let (w, h) = v.split_once('x')?;
                Some((w.parse().ok()?, h.parse().ok()?))
            })
            .ok_or_else(|| bad("resolution", resolution))?,
            crop_window: opt(crop, nums::<f64, 4>).ok_or_else(|| bad("cropwindow", crop))?,
            pixel_bounds: opt(bounds, nums::<u32, 4>).ok_or_else(|| bad("pixelbounds", bounds))?,
            aovs: get("aovs")?.parse().map_err(|_| anyhow!("recorded option aovs is malformed"))?,
            shard,
            view,
            colorspace,
            camera,
            integrator,
            env,
            env_strength,
        })
    }

    /// Reads options written by [`Plan::to_text`].
    pub fn from_text(text: &str) -> Result<Self> {
        let mut pairs = BTreeMap::new();
        for line in text.lines().filter(|l| !l.is_empty()) {
            let (k, v) = line.split_once('=').ok_or_else(|| anyhow!("recorded option line '{line}' has no '='"))?;
            pairs.insert(k.to_string(), v.to_string());
        }
        Self::from_pairs(&pairs)
    }

    /// The options that change the image and differ between `self` and `other`, as `key: self vs other`.
    pub fn differences(&self, other: &Plan) -> Vec<String> {
        let mut out = Vec::new();
        if self.scene != other.scene {
            out.push(format!("scene: {} vs {}", self.scene.display(), other.scene.display()));
        }
        for ((k, a), (_, b)) in self.image_options().into_iter().zip(other.image_options()) {
            if a != b {
                out.push(format!("{k}: {a} vs {b}"));
            }
        }
        if self.shard != other.shard {
            let s = |v: Option<(u32, u32)>| v.map_or("none".into(), |(k, n)| format!("{k}/{n}"));
            out.push(format!("shard: {} vs {}", s(self.shard), s(other.shard)));
        }
        let c = |v: &Option<String>| v.clone().unwrap_or_else(|| "none".into());
        if self.camera != other.camera {
            out.push(format!("camera: {} vs {}", c(&self.camera), c(&other.camera)));
        }
        if self.integrator != other.integrator {
            out.push(format!("integrator: {} vs {}", c(&self.integrator), c(&other.integrator)));
        }
        if self.env != other.env || self.env_strength != other.env_strength {
            let e =
                |p: &Plan| p.env.as_ref().map_or("none".into(), |e| format!("{} × {}", e.display(), p.env_strength));
            out.push(format!("env: {} vs {}", e(self), e(other)));
        }
        out
    }
}

/// Parses `K/N` with 1 ≤ K ≤ N ≤ 65536.
pub fn parse_shard(s: &str) -> Result<(u32, u32)> {
    let parsed =
        s.split_once('/').and_then(|(k, n)| Some((k.trim().parse::<u32>().ok()?, n.trim().parse::<u32>().ok()?)));
    match parsed {
        Some((k, n)) if (1..=n).contains(&k) && n <= 65536 => Ok((k, n)),
        _ => bail!("--shard takes K/N with 1 ≤ K ≤ N ≤ 65536 (the K-th of N parts), got '{s}'"),
    }
}

/// The options hash: the image options' text and what the scene resolved them to (integrator, passes, film size,
/// pixels rendered, buckets), so that parts and checkpoints of other settings never mix.
pub fn options_hash(plan: &Plan, resolved: &str) -> u64 {
    let mut h = Fnv64::default();
    for (k, v) in plan.image_options() {
        h.write(format!("{k}={v}\n").as_bytes());
    }
    if let Some(c) = &plan.camera {
        h.write(format!("camera={c}\n").as_bytes());
    }
    if let Some(i) = &plan.integrator {
        h.write(format!("integrator={i}\n").as_bytes());
    }
    if let Some(e) = &plan.env {
        h.write(format!("env={} {:?}\n", e.display(), plan.env_strength).as_bytes());
    }
    h.write(resolved.as_bytes());
    h.finish()
}

/// A checkpoint: see the module documentation.
#[derive(Clone, Debug, PartialEq)]
pub struct Checkpoint {
    /// Hash of the scene's input files.
    pub scene_hash: u64,
    /// Hash of the options that change the image.
    pub options_hash: u64,
    /// The passes the render covers.
    pub passes: Range<u32>,
    /// Passes `passes.start..done` are in the state.
    pub done: u32,
    /// The render's options.
    pub plan: String,
    /// The film's accumulators.
    pub film: FilmState,
    /// The job's state.
    pub job: Vec<u8>,
}

impl Checkpoint {
    /// The file's bytes.
    pub fn encode(&self) -> Vec<u8> {
        let npix = self.film.bounds.width() as usize * self.film.bounds.height() as usize;
        let mut out =
            Vec::with_capacity(128 + self.plan.len() + self.job.len() + self.film.planes.len() * (70 + 8 * npix));
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&VERSION.to_le_bytes());
        out.extend_from_slice(&self.scene_hash.to_le_bytes());
        out.extend_from_slice(&self.options_hash.to_le_bytes());
        for v in [self.passes.start, self.passes.end, self.done, self.plan.len() as u32] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(self.plan.as_bytes());
        let b = self.film.bounds;
        for v in [b.x0, b.x1, b.y0, b.y1] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(&self.film.light_paths.to_le_bytes());
        out.extend_from_slice(&self.film.rejected_samples.to_le_bytes());
        out.extend_from_slice(&self.film.rejected_splats.to_le_bytes());
        out.extend_from_slice(&(self.film.planes.len() as u32).to_le_bytes());
        for p in &self.film.planes {
            out.extend_from_slice(&(p.name.len() as u16).to_le_bytes());
            out.extend_from_slice(p.name.as_bytes());
            for v in &p.values {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
        out.extend_from_slice(&(self.job.len() as u64).to_le_bytes());
        out.extend_from_slice(&self.job);
        let h = Fnv64::of(&out);
        out.extend_from_slice(&h.to_le_bytes());
        out
    }

    /// Reads a checkpoint's bytes; anything that is not a complete checkpoint of this version is an error.
    pub fn decode(bytes: &[u8]) -> Result<Self> {
        if bytes.len() < MAGIC.len() + 4 || &bytes[..8] != MAGIC {
            bail!("not a Prismatic checkpoint (no PRISMCKP magic)");
        }
        let version = u32::from_le_bytes(bytes[8..12].try_into()?);
        if version != VERSION {
            bail!("checkpoint format version {version}; this Prismatic reads version {VERSION}");
        }
        if bytes.len() < 12 + 8 {
            bail!("the checkpoint is truncated");
        }
        let (body, tail) = bytes.split_at(bytes.len() - 8);
        if Fnv64::of(body) != u64::from_le_bytes(tail.try_into()?) {
            bail!("the checkpoint is truncated or damaged (its checksum does not match)");
        }
        let mut r = Reader { bytes: body, at: 12 };
        let scene_hash = r.u64()?;
        let options_hash = r.u64()?;
        let (start, end, done) = (r.u32()?, r.u32()?, r.u32()?);
        if !(start <= done && done <= end) {
            bail!("the checkpoint's passes done ({done}) are outside its range {start}..{end}");
        }
        let plan_len = r.u32()? as usize;
        if plan_len > MAX_PLAN_BYTES {
            bail!("the checkpoint's options take {plan_len} bytes (at most {MAX_PLAN_BYTES})");
        }
        let plan = String::from_utf8(r.take(plan_len)?.to_vec()).map_err(|_| anyhow!("the options are not UTF-8"))?;
        let bounds = PixelBounds { x0: r.u32()?, x1: r.u32()?, y0: r.u32()?, y1: r.u32()? };
        if bounds.width() == 0 || bounds.height() == 0 {
            bail!("the checkpoint's film covers no pixels ({bounds:?})");
        }
        let npix = bounds.width() as usize * bounds.height() as usize;
        let light_paths = f64::from_le_bytes(r.take(8)?.try_into()?);
        let (rejected_samples, rejected_splats) = (r.u64()?, r.u64()?);
        let nplanes = r.u32()? as usize;
        if nplanes > MAX_PLANES {
            bail!("the checkpoint lists {nplanes} planes (at most {MAX_PLANES})");
        }
        let mut planes = Vec::with_capacity(nplanes);
        for _ in 0..nplanes {
            let len = u16::from_le_bytes(r.take(2)?.try_into()?) as usize;
            if len > MAX_PLANE_NAME {
                bail!("a plane name of {len} bytes (at most {MAX_PLANE_NAME})");
            }
            let name = String::from_utf8(r.take(len)?.to_vec()).map_err(|_| anyhow!("a plane name is not UTF-8"))?;
            // `take` checks the length against the bytes left before anything is allocated.
            let raw = r.take(npix.checked_mul(8).ok_or_else(|| anyhow!("the film is too large"))?)?;
            let values = raw.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().unwrap_or_default())).collect();
            planes.push(Plane { name, values });
        }
        let job_len = usize::try_from(r.u64()?).map_err(|_| anyhow!("the job state is too large"))?;
        let job = r.take(job_len)?.to_vec();
        if r.at != body.len() {
            bail!("the checkpoint has {} bytes after its end", body.len() - r.at);
        }
        Ok(Checkpoint {
            scene_hash,
            options_hash,
            passes: start..end,
            done,
            plan,
            film: FilmState { bounds, planes, light_paths, rejected_samples, rejected_splats },
            job,
        })
    }

    /// Writes the checkpoint to `path` atomically.
    pub fn save(&self, path: &Path) -> Result<()> {
        film::write_file_atomic(path, &self.encode()).context("cannot write checkpoint")
    }

    /// Reads the checkpoint at `path`.
    pub fn load(path: &Path) -> Result<Self> {
        let bytes = std::fs::read(path).with_context(|| format!("cannot read checkpoint {}", path.display()))?;
        Self::decode(&bytes).with_context(|| format!("checkpoint {}", path.display()))
    }
}

/// Reads little-endian fields, each checked against the bytes left.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8]> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len());
        let Some(end) = end else {
            bail!("the checkpoint is truncated: a field of {n} bytes at offset {} runs past its end", self.at)
        };
        let s = &self.bytes[self.at..end];
        self.at = end;
        Ok(s)
    }

    fn u32(&mut self) -> Result<u32> {
        Ok(u32::from_le_bytes(self.take(4)?.try_into()?))
    }

    fn u64(&mut self) -> Result<u64> {
        Ok(u64::from_le_bytes(self.take(8)?.try_into()?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Checkpoint {
        let bounds = PixelBounds { x0: 1, x1: 4, y0: 0, y1: 2 };
        let plane =
            |name: &str, k: f64| Plane { name: name.into(), values: (0..6).map(|i| i as f64 * k + 0.1).collect() };
        Checkpoint {
            scene_hash: 0x1234_5678_9abc_def0,
            options_hash: 42,
            passes: 8..16,
            done: 11,
            plan: "scene=/x.pbrt\nseed=3\n".into(),
            film: FilmState {
                bounds,
                planes: vec![plane("X", 1.5), plane("W", -0.25)],
                light_paths: 96.0,
                rejected_samples: 2,
                rejected_splats: 1,
            },
            job: vec![9, 8, 7],
        }
    }

    #[test]
    fn a_checkpoint_reads_back_exactly() {
        let c = sample();
        assert_eq!(Checkpoint::decode(&c.encode()).unwrap(), c);
    }

    #[test]
    fn truncated_damaged_and_foreign_files_are_errors() {
        let bytes = sample().encode();
        for cut in [0, 5, 11, 12, 30, bytes.len() / 2, bytes.len() - 1] {
            assert!(Checkpoint::decode(&bytes[..cut]).is_err(), "cut at {cut}");
        }
        for i in [9, 20, 40, bytes.len() - 20] {
            let mut b = bytes.clone();
            b[i] ^= 0x10;
            let e = Checkpoint::decode(&b).unwrap_err().to_string();
            assert!(e.contains("checksum") || e.contains("version"), "byte {i}: {e}");
        }
        assert!(Checkpoint::decode(b"P3\n1 1\n255\n0 0 0\n").unwrap_err().to_string().contains("magic"));
    }

    #[test]
    fn huge_sizes_are_refused_before_allocating() {
        // A well-formed file (valid checksum) whose film claims 65536 × 65536 pixels and one plane, whose values
        // (32 GiB) are not there: refused from the bytes left, nothing allocated.
        let mut c = sample();
        c.film.bounds = PixelBounds { x0: 0, x1: 65536, y0: 0, y1: 65536 };
        c.film.planes.clear();
        c.job.clear();
        let mut bytes = c.encode();
        bytes.truncate(bytes.len() - 8);
        let nplanes_at = 12 + 8 + 8 + 16 + c.plan.len() + 16 + 24;
        bytes[nplanes_at..nplanes_at + 4].copy_from_slice(&1u32.to_le_bytes());
        // The plane: name "X", then the bytes left.
        bytes.splice(nplanes_at + 4..nplanes_at + 4, [1, 0, b'X']);
        let h = Fnv64::of(&bytes);
        bytes.extend_from_slice(&h.to_le_bytes());
        let e = Checkpoint::decode(&bytes).unwrap_err().to_string();
        assert!(e.contains("truncated"), "{e}");
    }

    #[test]
    fn plans_read_back_and_differences_are_named() {
        let plan = Plan {
            scene: "/s/scene.pbrt".into(),
            output: Some("/o/out.exr".into()),
            spp: Some(64),
            seed: 7,
            wavelengths: WavelengthStrategy::Cmf,
            resolution: Some((16, 8)),
            crop_window: Some([0.1, 0.7, 0.0, 1.0 / 3.0]),
            pixel_bounds: None,
            aovs: true,
            shard: Some((2, 5)),
            view: Some(film::View::Clip),
            colorspace: Some("dci-p3".into()),
            camera: Some("front".into()),
            integrator: Some("\"path\" \"integer maxdepth\" 20".into()),
            env: Some("/e/sky.exr".into()),
            env_strength: 0.5,
        };
        assert_eq!(Plan::from_text(&plan.to_text()).unwrap(), plan);
        let other = Plan { seed: 8, spp: None, ..plan.clone() };
        assert_eq!(plan.differences(&other), ["spp: 64 vs none", "seed: 7 vs 8"]);
        // The view and the colour space are output options: a resume may change them, and parts of either mix.
        let display = Plan { view: None, colorspace: Some("srgb".into()), ..plan.clone() };
        assert!(plan.differences(&display).is_empty());
        assert_eq!(options_hash(&plan, ""), options_hash(&display, ""));
        assert!(Plan::from_text(&plan.to_text().replace("view=clip", "view=agx")).is_err());
        assert_ne!(options_hash(&plan, ""), options_hash(&other, ""));
        assert_ne!(options_hash(&plan, "path"), options_hash(&plan, "bdpt"));
        assert!(Plan::from_text("scene=/x\nspp=ten\n").is_err());
        for bad in ["0/3", "4/3", "3", "a/b", "1/0"] {
            assert!(parse_shard(bad).is_err(), "{bad}");
        }
        assert_eq!(parse_shard("3/4").unwrap(), (3, 4));
    }

    #[test]
    fn the_scene_hash_follows_the_bytes_not_the_names() {
        let dir = std::env::temp_dir().join(format!("prismatic-ckpt-hash-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (a, b) = (dir.join("a.pbrt"), dir.join("b.pbrt"));
        std::fs::write(&a, "WorldBegin\n").unwrap();
        std::fs::write(&b, "WorldBegin\n").unwrap();
        assert_eq!(scene_hash(std::slice::from_ref(&a)).unwrap(), scene_hash(std::slice::from_ref(&b)).unwrap());
        std::fs::write(&b, "WorldBegin \n").unwrap();
        assert_ne!(scene_hash(std::slice::from_ref(&a)).unwrap(), scene_hash(std::slice::from_ref(&b)).unwrap());
        // Where one file ends counts: "ab" + "c" is not "a" + "bc".
        std::fs::write(&a, "ab").unwrap();
        std::fs::write(&b, "c").unwrap();
        let h1 = scene_hash(&[a.clone(), b.clone()]).unwrap();
        std::fs::write(&a, "a").unwrap();
        std::fs::write(&b, "bc").unwrap();
        assert_ne!(h1, scene_hash(&[a, b]).unwrap());
        assert_eq!(Fnv64::of(b"a"), 0xaf63_dc4c_8601_ec8c); // FNV-1a's published value for "a".
        let _ = std::fs::remove_dir_all(&dir);
    }
}

//! `prismatic render`: a pbrt-v4 scene in, an image out.

use std::io::IsTerminal;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use render::{build_scene, BuildOptions};
use render::{Integrator, PassUnit};

use crate::checkpoint::{self, Checkpoint, Plan};
use crate::exit;
use crate::preview;
use spectral::WavelengthStrategy;

/// Arguments of `prismatic render`.
#[derive(Args, Debug)]
#[command(after_help = "Examples:\n  prismatic render scenes/cornell-glass.pbrt -o cornell.png\n  \
                        prismatic render scene.pbrt --spp 64 --wavelengths cmf -o out.exr\n  \
                        prismatic render scene.pbrt --time 30 --resolution 640x480\n  \
                        prismatic render scene.pbrt --spp 4096 --checkpoint scene.ckpt -o out.exr\n  \
                        prismatic render --resume scene.ckpt\n  \
                        prismatic render scene.pbrt --spp 4096 --shard 2/8 -o part-2.exr\n  \
                        prismatic merge part-*.exr -o out.exr\n\n\
                        The output format follows the file extension: .exr (linear RGB; spectral films add S0.<λ>nm \
                        channels), .png (dithered 8-bit through --view, tagged with --colorspace), .pfm.\n\n\
                        Ctrl-C (SIGINT) or SIGTERM stops at the end of the current sample pass (passes last at most \
                        about a second), writes the image of the samples done (the EXR header's samplesPerPixel \
                        says how many) and exits with status 130 (SIGINT) or 143 (SIGTERM); a second signal exits \
                        at once, leaving any earlier output file as it was.\n\n\
                        Exit status: 0 done, 1 any other failure, 2 a command line that cannot be parsed, 3 an \
                        error in the scene (file:line:column), 4 a file that cannot be read or written, 130 or 143 \
                        stopped by a signal.\n\n\
                        Checkpoints: with --checkpoint FILE the render's accumulated state is written to FILE \
                        (atomically) at a pass boundary every --checkpoint-every seconds, when a signal stops it, \
                        and at the end. After a crash, a kill or a lost node, `prismatic render --resume FILE` \
                        continues from the last complete checkpoint and writes exactly the image of an \
                        uninterrupted render. It reads the scene again and refuses to go on if any of its files \
                        (the main file, Include/Import, PLY, image and spectrum files) or the options that change \
                        the image differ; the same command line with --resume added works too, and -o may name \
                        another output.\n\n\
                        Shards: --shard K/N renders the K-th of N parts of the render, on as many machines: \
                        contiguous ranges of sample indices (for sppm, whose radii shrink from iteration to \
                        iteration, bands of image rows with all iterations). Each part is an EXR (the part's image \
                        plus its exact unnormalised sums); `prismatic merge` adds them into the image one process \
                        would have rendered.")]
pub struct RenderArgs {
    /// The scene: a pbrt-v4 file, or a glTF 2.0 file (.gltf, .glb) (optional with --resume: the checkpoint names it).
    #[arg(required_unless_present = "resume")]
    pub scene: Option<PathBuf>,

    /// Output image (overrides the scene's Film "filename").
    #[arg(short, long, value_name = "FILE")]
    pub output: Option<PathBuf>,

    /// Samples per pixel (overrides the scene's Sampler "pixelsamples").
    #[arg(long, value_name = "N")]
    pub spp: Option<u32>,

    /// Worker threads (default: all cores). The image does not depend on it.
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,

    /// Seed of the sampler: different seeds give independent images that can be averaged.
    #[arg(long, default_value_t = 0)]
    pub seed: u32,

    /// Render progressively for this many seconds, then write (instead of a fixed --spp).
    #[arg(long, value_name = "SECONDS", conflicts_with_all = ["checkpoint", "resume", "shard"])]
    pub time: Option<f64>,

    /// Image size WxH (overrides the scene's film resolution).
    #[arg(long, value_name = "WxH", value_parser = parse_resolution)]
    pub resolution: Option<(u32, u32)>,

    /// Render only this part of the image, as fractions of its width and height: x0 x1 y0 y1 in [0, 1] (pbrt-v4's
    /// --cropwindow; overrides the film's "cropwindow" and "pixelbounds"). The output holds just those pixels,
    /// exactly as a full render has them.
    #[arg(long, num_args = 4, value_names = ["X0", "X1", "Y0", "Y1"], allow_negative_numbers = true)]
    pub cropwindow: Option<Vec<f64>>,

    /// Render only pixels x0 ≤ x < x1, y0 ≤ y < y1 (pbrt-v4's --pixelbounds; overrides the film's "pixelbounds").
    #[arg(long, num_args = 4, value_names = ["X0", "X1", "Y0", "Y1"])]
    pub pixelbounds: Option<Vec<u32>>,

    /// Wavelength strategy: rgb (three bands), cmf (one wavelength from the Stiles & Burch pdf) or hero (four).
    #[arg(long, default_value = "hero")]
    pub wavelengths: WavelengthStrategy,

    /// Also write pbrt-v4's geometry-buffer channels of the first visible surface (Albedo, P, dzdx, dzdy, N, Ns,
    /// u, v, Variance, RelativeVariance; camera space) on any film, as Film "gbuffer" does (EXR output only).
    #[arg(long)]
    pub aovs: bool,

    /// Keep the render's accumulated state in FILE (written atomically at pass boundaries), to --resume after a
    /// crash or a kill. With --resume, defaults to the checkpoint resumed.
    #[arg(long, value_name = "FILE")]
    pub checkpoint: Option<PathBuf>,

    /// Seconds between checkpoints (at the next pass boundary; 0 for every pass).
    #[arg(long, value_name = "SECONDS", default_value_t = 300.0)]
    pub checkpoint_every: f64,

    /// Continue the render saved in this checkpoint: same scene files and options (checked), exactly the image
    /// of an uninterrupted render. Options given with it must match the checkpoint's; -o may change.
    #[arg(long, value_name = "FILE")]
    pub resume: Option<PathBuf>,

    /// Render only the K-th of N parts (K from 1 to N) into an EXR part for `prismatic merge`: sample indices
    /// (K−1)·spp/N up to K·spp/N (for sppm: the K-th of N bands of image rows, all iterations).
    #[arg(long, value_name = "K/N")]
    pub shard: Option<String>,

    /// How the PNG shows colours outside the display's gamut or brighter than its white: oklab (hue-preserving
    /// compression, the default) or clip (each channel on its own). Overrides the film's "view"; EXR and PFM
    /// output is linear and never changes with it.
    #[arg(long, value_name = "VIEW", value_parser = parse_view)]
    pub view: Option<film::View>,

    /// The output colour space: srgb, dci-p3 (Display P3), rec2020 or aces2065-1. The EXR's RGB and chromaticities
    /// follow it; the PNG is encoded for it (aces2065-1: sRGB) and tagged (cICP chunk and ICC profile). Overrides
    /// the film's "colorspace".
    #[arg(long, value_name = "SPACE", value_parser = parse_colorspace)]
    pub colorspace: Option<String>,

    /// The integrator instead of the scene's: a name (`path`, `volpath`, `bdpt`, `sppm`, …) or a directive's
    /// arguments (`'"path" "integer maxdepth" 20'`); for glTF scenes, which have none, `volpath` by default.
    #[arg(long, value_name = "INTEGRATOR")]
    pub integrator: Option<String>,

    /// An environment around the scene: an EXR, Radiance HDR or PFM image, 2:1 latitude–longitude (or square
    /// equal-area), its top towards +y in a glTF scene (+z in a pbrt-v4 one).
    #[arg(long, value_name = "FILE")]
    pub env: Option<PathBuf>,

    /// Multiplies the environment's radiance.
    #[arg(long, value_name = "S", default_value_t = 1.0, requires = "env")]
    pub env_strength: f64,

    /// A glTF scene's camera, by name or index (the first one by default).
    #[arg(long, value_name = "NAME|INDEX")]
    pub camera: Option<String>,

    /// Serve a live view on 127.0.0.1 (the address is printed): the image as it converges, through the view, with
    /// samples, elapsed time and ETA, and buttons for the view and the exposure. Closing the page does not stop the
    /// render.
    #[arg(long)]
    pub preview: bool,

    /// The live view's port (0: any free port; implies --preview).
    #[arg(long, value_name = "PORT")]
    pub preview_port: Option<u16>,

    /// Send the image as it converges to tev at HOST:PORT (pbrt-v4's --display-server; tev listens on 14158).
    #[arg(long, value_name = "HOST:PORT")]
    pub display_server: Option<String>,

    /// No progress bar and no statistics.
    #[arg(long)]
    pub quiet: bool,
}

/// `--view`: a name [`film::View::by_name`] knows.
pub(crate) fn parse_view(s: &str) -> Result<film::View, String> {
    film::View::by_name(s).ok_or_else(|| format!("unknown view '{s}'; valid views: {}", film::View::NAMES.join(", ")))
}

/// `--colorspace`: a name [`spectral::RgbColorSpace::by_name`] knows, as given.
pub(crate) fn parse_colorspace(s: &str) -> Result<String, String> {
    match spectral::RgbColorSpace::by_name(s) {
        Some(cs) => Ok(cs.name.to_string()),
        None => Err(format!(
            "unknown colour space '{s}'; valid colour spaces: {}",
            spectral::RgbColorSpace::NAMES.join(", ")
        )),
    }
}

fn parse_resolution(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("'{s}' is not WxH (e.g. 640x480)"))?;
    let w: u32 = w.trim().parse().map_err(|_| format!("width '{w}' is not a positive integer"))?;
    let h: u32 = h.trim().parse().map_err(|_| format!("height '{h}' is not a positive integer"))?;
    if w == 0 || h == 0 || w > 65536 || h > 65536 {
        return Err(format!("resolution {w}x{h} is out of range (1..=65536 each)"));
    }
    Ok((w, h))
}

/// Peak resident set size of this process in bytes (Linux `VmHWM`), if known.
pub fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// A render stopped by a signal: its image was written (if any sample pass had finished) and the process should
/// exit with `exit_code` (128 + the signal's number, as shells report a death by that signal).
#[derive(Debug)]
pub struct Interrupted {
    /// What happened, for stderr.
    pub message: String,
    /// The exit status.
    pub exit_code: u8,
}

impl std::fmt::Display for Interrupted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Interrupted {}

/// SIGINT and SIGTERM: the first sets the returned number (the signal's), which the render loop checks between
/// sample passes; the second ends the process at once with status 128 + its number. Files are only ever replaced
/// by renaming a complete temporary file, so that cannot leave a corrupt image.
fn install_stop_signals() -> Result<Arc<AtomicUsize>> {
    use signal_hook::consts::{SIGINT, SIGTERM};
    let received = Arc::new(AtomicUsize::new(0));
    let once = Arc::new(AtomicBool::new(false));
    for sig in [SIGINT, SIGTERM] {
        // Registered first, so on the first signal `once` is still false and nothing exits.
        signal_hook::flag::register_conditional_shutdown(sig, 128 + sig, Arc::clone(&once))
            .context("cannot install signal handlers")?;
        signal_hook::flag::register(sig, Arc::clone(&once)).context("cannot install signal handlers")?;
        signal_hook::flag::register_usize(sig, Arc::clone(&received), sig as usize)
            .context("cannot install signal handlers")?;
    }
    Ok(received)
}

fn signal_name(sig: usize) -> &'static str {
    if sig == signal_hook::consts::SIGINT as usize {
        "SIGINT"
    } else if sig == signal_hook::consts::SIGTERM as usize {
        "SIGTERM"
    } else {
        "a signal"
    }
}

/// A render ready to go: the scene built from a [`Plan`], its film, the passes this process renders, and the hashes
/// that identify it.
pub struct Setup {
    /// The scene.
    pub built: render::BuiltScene,
    /// The film this process renders into (a band of rows for an sppm shard).
    pub spec: film::FilmSpec,
    /// The pixels of the whole render (the film's, or the crop's).
    pub whole: film::PixelBounds,
    /// The passes this process renders.
    pub passes: Range<u32>,
    /// The passes of the whole render.
    pub total: u32,
    /// See [`checkpoint::scene_hash`].
    pub scene_hash: u64,
    /// See [`checkpoint::options_hash`].
    pub options_hash: u64,
    /// Time spent parsing the scene files.
    pub parsed: Duration,
}

impl Setup {
    /// Parses and builds the scene of `plan` and works out the film and the passes (of its shard, if any).
    pub fn new(plan: &Plan) -> Result<Self> {
        let start = Instant::now();
        let mut desc = read_scene_file(&plan.scene, plan.camera.as_deref())?;
        if let Some(env) = &plan.env {
            let ext = env.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
            if !matches!(ext.as_deref(), Some("exr" | "pfm")) {
                bail!("--env {}: an EXR or PFM image is needed (Radiance .hdr files are not read yet)", env.display());
            }
            if !(plan.env_strength.is_finite() && plan.env_strength >= 0.0) {
                bail!("--env-strength must be a number ≥ 0, got {}", plan.env_strength);
            }
            let ext = plan.scene.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
            let y_up = matches!(ext.as_deref(), Some("gltf" | "glb"));
            desc.lights.push(gltf_import::environment_light(env, plan.env_strength, y_up));
        }
        if let Some(args) = &plan.integrator {
            desc.integrator = pbrt::parse_integrator(args, Path::new("<--integrator>"))
                .map_err(|e| anyhow!("--integrator: {}", e.message))?;
        }
        let parsed = start.elapsed();
        let options = BuildOptions {
            resolution: plan.resolution,
            spp: plan.spp,
            output: plan.output.clone(),
            crop_window: plan.crop_window,
            pixel_bounds: plan.pixel_bounds,
            view: plan.view,
            color_space: plan.colorspace.as_deref().and_then(spectral::RgbColorSpace::by_name),
        };
        let mut built = build_scene(&desc, &options)?;
        let scene_hash = checkpoint::scene_hash(&desc.input_files())?;
        let mut spec = built.film.clone();
        if plan.aovs {
            // pbrt-v4's geometry buffer on any film: its channels, names and camera space, as `Film "gbuffer"`
            // writes them (a gbuffer film keeps its own coordinate system).
            spec.aovs = true;
            spec.gbuffer.get_or_insert(film::GBuffer { coordinates: film::GBufferCoordinates::Camera });
        }
        spec.wavelengths = plan.wavelengths;
        let whole = spec.bounds();
        let unit = built.integrator.needs().unit;
        let total = built.spp;
        let resolved = format!(
            "integrator={}\npasses={total}\nfilm={}x{} {:?} {:?} aovs={}\n",
            built.integrator.name(),
            spec.width,
            spec.height,
            whole,
            spec.kind,
            spec.aovs
        );
        let options_hash = checkpoint::options_hash(plan, &resolved);
        let passes = match (plan.shard, unit) {
            (None, _) => 0..total,
            (Some((k, n)), PassUnit::Samples) => {
                if n > total {
                    bail!("--shard {k}/{n}: {total} spp cannot be split into {n} parts of at least one sample");
                }
                split(total, (k, n))
            }
            (Some((k, n)), PassUnit::Iterations) => {
                // Photon mapping's radii shrink with the iterations, so disjoint iterations are not independent
                // renders: a shard renders all iterations for a band of rows instead. Each pixel's statistics
                // depend only on the photons near its own visible points, and the photon count per iteration is
                // the whole render's, so the band's pixels are exactly those of the whole render.
                let h = whole.height();
                if n > h {
                    bail!("--shard {k}/{n}: sppm shards are bands of image rows, and the image has only {h} rows");
                }
                let rows = split(h, (k, n));
                spec.pixel_bounds =
                    Some(film::PixelBounds { y0: whole.y0 + rows.start, y1: whole.y0 + rows.end, ..whole });
                if let Integrator::Sppm(s) = &mut built.integrator {
                    s.photons_per_iteration.get_or_insert(whole.width() as u64 * whole.height() as u64);
                }
                0..total
            }
        };
        Ok(Setup { built, spec, whole, passes, total, scene_hash, options_hash, parsed })
    }

    /// The EXR header attributes of a part of a sharded render (see `prismatic merge`).
    pub fn part_attributes(&self, plan: &Plan, done: u32) -> Vec<(String, String)> {
        let (k, n) = plan.shard.unwrap_or((1, 1));
        let w = self.whole;
        let mut out = vec![
            ("prismatic.part".to_string(), "1".to_string()),
            ("prismatic.shard".into(), format!("{k}/{n}")),
            ("prismatic.unit".into(), self.built.integrator.needs().unit.name().into()),
            ("prismatic.passes".into(), format!("{}..{done}", self.passes.start)),
            ("prismatic.passesTotal".into(), self.total.to_string()),
            ("prismatic.bounds".into(), format!("{} {} {} {}", w.x0, w.x1, w.y0, w.y1)),
            ("prismatic.seed".into(), plan.seed.to_string()),
            ("prismatic.sceneHash".into(), format!("{:016x}", self.scene_hash)),
            ("prismatic.optionsHash".into(), format!("{:016x}", self.options_hash)),
        ];
        out.extend(plan.to_pairs().into_iter().map(|(key, v)| (format!("prismatic.plan.{key}"), v)));
        out
    }
}

/// The scene description of `path`: a glTF 2.0 file (`.gltf`, `.glb`; `camera` picks its camera) or a pbrt-v4 file.
pub fn read_scene_file(path: &Path, camera: Option<&str>) -> Result<scene::SceneDescription> {
    // A scene file that cannot be opened is an I/O error for the exit status (the operating system's error is the
    // cause), with the reader's message.
    let io = |e: anyhow::Error| match std::fs::File::open(path) {
        Err(io) => anyhow::Error::new(io).context(e.to_string()),
        Ok(_) => e,
    };
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    if matches!(ext.as_deref(), Some("gltf" | "glb")) {
        let options = gltf_import::ReadOptions { camera: camera.map(str::to_string) };
        return gltf_import::read_scene(path, &options).map_err(|e| io(anyhow::Error::new(e)));
    }
    if camera.is_some() {
        bail!(
            "--camera picks a glTF scene's camera; {} is a pbrt-v4 file, whose Camera directive is used",
            path.display()
        );
    }
    pbrt::parse_file(path).map_err(|e| io(anyhow::Error::new(e)))
}

/// The K-th of N contiguous parts of `0..len` (K from 1): `(K−1)·len/N .. K·len/N`, rounded down.
pub fn split(len: u32, (k, n): (u32, u32)) -> Range<u32> {
    let at = |i: u32| (i as u64 * len as u64 / n as u64) as u32;
    at(k - 1)..at(k)
}

/// The render's options from the command line, paths made absolute (a checkpoint may be resumed elsewhere).
fn plan_from_args(args: &RenderArgs, scene: &Path) -> Result<Plan> {
    let crop_window = match &args.cropwindow {
        Some(c) => {
            if let Some(v) = c.iter().find(|v| !(0.0..=1.0).contains(*v)) {
                bail!("--cropwindow values are fractions of the image in [0, 1], got {v}");
            }
            Some([c[0], c[1], c[2], c[3]])
        }
        None => None,
    };
    let absolute = |p: &Path| std::path::absolute(p).with_context(|| format!("cannot resolve {}", p.display()));
    Ok(Plan {
        scene: absolute(scene)?,
        output: args.output.as_deref().map(absolute).transpose()?,
        spp: args.spp,
        seed: args.seed,
        wavelengths: args.wavelengths,
        resolution: args.resolution,
        crop_window,
        pixel_bounds: args.pixelbounds.as_ref().map(|b| [b[0], b[1], b[2], b[3]]),
        aovs: args.aovs,
        shard: args.shard.as_deref().map(checkpoint::parse_shard).transpose()?,
        view: args.view,
        colorspace: args.colorspace.clone(),
        camera: args.camera.clone(),
        integrator: args.integrator.clone(),
        env: args.env.as_deref().map(absolute).transpose()?,
        env_strength: args.env_strength,
    })
}

/// Runs the subcommand; returns the summary to print.
pub fn run(args: &RenderArgs) -> Result<String> {
    if let Some(s) = args.spp {
        if s == 0 || s > 1 << 24 {
            bail!("--spp must be between 1 and {}, got {s}", 1 << 24);
        }
    }
    if let Some(t) = args.time {
        if !(t.is_finite() && t > 0.0 && t <= 1e7) {
            bail!("--time must be a positive number of seconds (at most 1e7), got {t}");
        }
    }
    let every = args.checkpoint_every;
    if !(every.is_finite() && (0.0..=1e9).contains(&every)) {
        bail!("--checkpoint-every must be a number of seconds between 0 and 1e9, got {every}");
    }
    if let Some(n) = args.threads {
        if n == 0 {
            bail!("--threads must be at least 1");
        }
        rayon::ThreadPoolBuilder::new().num_threads(n).build_global().context("cannot start the thread pool")?;
    }
    // The render's options: the command line's, or the checkpoint's (which a command line given with it must
    // match).
    let (mut plan, resume) = match &args.resume {
        Some(path) => {
            let ck = Checkpoint::load(path)?;
            let recorded = Plan::from_text(&ck.plan).with_context(|| format!("checkpoint {}", path.display()))?;
            if let Some(scene) = &args.scene {
                let given = plan_from_args(args, scene)?;
                let diff = given.differences(&recorded);
                if !diff.is_empty() {
                    bail!(
                        "the options differ from those of checkpoint {} (given vs recorded): {}",
                        path.display(),
                        diff.join("; ")
                    );
                }
            }
            let mut plan = recorded;
            // Output options: given with --resume, they replace the recorded ones.
            if args.view.is_some() {
                plan.view = args.view;
            }
            if args.colorspace.is_some() {
                plan.colorspace = args.colorspace.clone();
            }
            if let Some(o) = &args.output {
                plan.output = Some(std::path::absolute(o).with_context(|| format!("cannot resolve {}", o.display()))?);
            }
            (plan, Some(ck))
        }
        None => {
            let scene = args.scene.as_deref().ok_or_else(|| anyhow!("no scene file given"))?;
            (plan_from_args(args, scene)?, None)
        }
    };
    let checkpoint_path = args.checkpoint.clone().or_else(|| args.resume.clone());
    let stop = install_stop_signals()?;
    let start = Instant::now();
    let setup = Setup::new(&plan)?;
    let built = &setup.built;
    for w in &built.warnings {
        eprintln!("{w}");
    }
    // Check the output before spending time on the render.
    let out_path = built.film.filename.clone();
    let format = film::ImageFormat::from_path(&out_path)?;
    if let Some(dir) = out_path.parent().filter(|d| !d.as_os_str().is_empty()) {
        if !dir.is_dir() {
            let message = format!("cannot write {}: directory {} does not exist", out_path.display(), dir.display());
            return Err(exit::io_error(std::io::ErrorKind::NotFound, message));
        }
    }
    if plan.aovs && format != film::ImageFormat::Exr {
        bail!("--aovs needs an .exr output (got {})", out_path.display());
    }
    if plan.shard.is_some() && format != film::ImageFormat::Exr {
        bail!(
            "a shard's part is an EXR file that `prismatic merge` reads: -o must end in .exr (got {})",
            out_path.display()
        );
    }
    // The output is fixed from now on: a checkpoint resumed from another directory writes the same file.
    plan.output =
        Some(std::path::absolute(&out_path).with_context(|| format!("cannot resolve {}", out_path.display()))?);
    // Scene load: parsing the files, then building (shapes and their PLY files, textures, lights, the BVH).
    let setup_time = start.elapsed();
    let mut film = film::Film::new(setup.spec.clone())?;
    let unit = built.integrator.needs().unit.name();
    let mut job = built.integrator.begin(&built.scene, &film, plan.seed)?;
    let passes = setup.passes.clone();
    let mut done = passes.start;
    let preview_port = args.preview_port.or(args.preview.then_some(0));
    let mut live = match (preview_port, &args.display_server) {
        (None, None) => None,
        (port, server) => {
            let name = out_path.file_name().map_or("prismatic".into(), |n| n.to_string_lossy().into_owned());
            let space = setup.spec.color_space.clone();
            Some(preview::LiveView::start(port, server.as_deref(), space, &name)?)
        }
    };
    if let (Some(ck), Some(path)) = (&resume, &args.resume) {
        let at = path.display();
        if ck.scene_hash != setup.scene_hash {
            bail!("the scene's files changed since checkpoint {at} was written (its scene hash differs); resuming would not give the image of one render");
        }
        if ck.options_hash != setup.options_hash || ck.passes != passes {
            bail!("checkpoint {at} is of a render with other options or passes ({:?}, now {:?})", ck.passes, passes);
        }
        if ck.film.bounds != film.bounds() {
            bail!("checkpoint {at} holds pixels {:?}, the render {:?}", ck.film.bounds, film.bounds());
        }
        film.paste(&ck.film).with_context(|| format!("checkpoint {at}"))?;
        job.restore_state(&ck.job).with_context(|| format!("checkpoint {at}"))?;
        done = ck.done;
    }
    let save_checkpoint = |film: &film::Film, job: &dyn render::RenderJob, done: u32| -> Result<()> {
        let Some(path) = &checkpoint_path else { return Ok(()) };
        let ck = Checkpoint {
            scene_hash: setup.scene_hash,
            options_hash: setup.options_hash,
            passes: passes.clone(),
            done,
            plan: plan.to_text(),
            film: film.state(),
            job: job.save_state(),
        };
        ck.save(path).with_context(|| format!("checkpoint {}", path.display()))
    };
    // Pixels rendered: the film's pixel bounds (a crop), or the whole image.
    let (w, h) = (film.bounds().width() as u64, film.bounds().height() as u64);

    let show = !args.quiet && std::io::stderr().is_terminal();
    let bar =
        if show { ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr()) } else { ProgressBar::hidden() };
    let taken = AtomicU64::new(0);
    let render_start = Instant::now();
    let mut rays = 0u64;
    let first = done;
    match args.time {
        None => {
            let total = w * h * (passes.end - done) as u64;
            bar.set_length(total);
            bar.set_style(
                ProgressStyle::with_template("{bar:40} {percent:>3}%  {msg}  eta {eta}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            let progress = |n: u64| {
                let t = taken.fetch_add(n, Ordering::Relaxed) + n;
                bar.set_position(t);
                let secs = render_start.elapsed().as_secs_f64().max(1e-9);
                bar.set_message(format!("{:.2} Msamples/s", t as f64 / secs / 1e6));
            };
            // Passes of growing size, each well under a second, so that a signal is answered quickly; a pixel's
            // samples are added in the same order whatever the passes, so the image is the same.
            let mut sizes = render::PassSizes::default();
            let mut saved = (done, Instant::now());
            while done < passes.end && stop.load(Ordering::SeqCst) == 0 {
                let pass_start = Instant::now();
                let n = sizes.next(passes.end - done);
                let stats = job.run(&mut film, done..done + n, &progress);
                rays += stats.rays;
                done += n;
                sizes.took(pass_start.elapsed());
                if done < passes.end && saved.1.elapsed().as_secs_f64() >= every {
                    save_checkpoint(&film, job.as_ref(), done)?;
                    saved = (done, Instant::now());
                }
                if let Some(live) = live.as_mut().filter(|l| done < passes.end && l.due()) {
                    let elapsed = render_start.elapsed().as_secs_f64();
                    let rate = (done - first) as f64 / elapsed.max(1e-9);
                    let eta = Some((passes.end - done) as f64 / rate.max(1e-12));
                    let total = Some(passes.end);
                    live.publish(&film, preview::Progress { done, total, unit, elapsed, eta, finished: false });
                }
            }
            // The last state too (after a signal, or the end: resuming a finished render writes its image again).
            if saved.0 != done {
                save_checkpoint(&film, job.as_ref(), done)?;
            }
        }
        Some(seconds) => {
            // Progressive: passes of growing sample counts until the time is spent (each pass continues the
            // per-pixel sample sequence, so the result equals a single render with the same total spp).
            let budget = Duration::from_secs_f64(seconds);
            bar.set_style(
                ProgressStyle::with_template("{spinner} {elapsed} {msg}")
                    .unwrap_or_else(|_| ProgressStyle::default_spinner()),
            );
            let mut sizes = render::PassSizes::default();
            while (done == 0 || render_start.elapsed() < budget) && stop.load(Ordering::SeqCst) == 0 {
                let pass_start = Instant::now();
                let progress = |n: u64| {
                    taken.fetch_add(n, Ordering::Relaxed);
                };
                let range = done..done + sizes.next(u32::MAX - done);
                let stats = job.run(&mut film, range.clone(), &progress);
                rays += stats.rays;
                done = range.end;
                bar.set_message(format!("{done} {unit}"));
                bar.tick();
                if let Some(live) = live.as_mut().filter(|l| l.due()) {
                    let elapsed = render_start.elapsed().as_secs_f64();
                    let eta = Some(budget.saturating_sub(render_start.elapsed()).as_secs_f64());
                    live.publish(&film, preview::Progress { done, total: None, unit, elapsed, eta, finished: false });
                }
                // Passes stay well inside the remaining time and under about a second (so that a signal is answered
                // and the live view updated promptly); the passes do not change the image.
                sizes.took_leaving(pass_start.elapsed(), budget.saturating_sub(render_start.elapsed()));
            }
        }
    }
    let signal = stop.load(Ordering::SeqCst);
    bar.finish_and_clear();
    let path = out_path;
    // Messages name the output as the command line did.
    let shown = args.output.clone().unwrap_or_else(|| path.clone());
    let resume_hint = checkpoint_path
        .as_ref()
        .map(|c| format!("; resume with: prismatic render --resume {}", c.display()))
        .unwrap_or_default();
    if signal != 0 && done == passes.start {
        return Err(Interrupted {
            message: format!(
                "interrupted by {} before the first sample pass; nothing written{resume_hint}",
                signal_name(signal)
            ),
            exit_code: (128 + signal).min(255) as u8,
        }
        .into());
    }
    // Whatever the integrator keeps outside the film (photon mapping's progressive estimate) goes in once.
    job.finish(&mut film);
    let render_time = render_start.elapsed();
    // The live view's last frame: the image about to be written.
    if let Some(live) = live {
        let elapsed = render_time.as_secs_f64();
        let total = args.time.is_none().then_some(passes.end);
        let cost = live.finish(&film, preview::Progress { done, total, unit, elapsed, eta: Some(0.0), finished: true });
        if !args.quiet {
            eprintln!("{cost}");
        }
    }
    let spp_done = done - passes.start;
    let requested = if args.time.is_some() { done } else { passes.end - passes.start };
    let mut header = vec![
        ("samplesPerPixel".to_string(), spp_done.to_string()),
        ("samplesPerPixelRequested".to_string(), requested.to_string()),
    ];
    if signal != 0 {
        header.push(("interruptedBy".to_string(), signal_name(signal).to_string()));
    }
    if plan.shard.is_some() {
        header.extend(setup.part_attributes(&plan, done));
        film::write_part(&film, &path, &header).with_context(|| format!("cannot write {}", path.display()))?;
    } else {
        film::write_image_with(&film, &path, &header).with_context(|| format!("cannot write {}", path.display()))?;
    }
    if signal != 0 {
        return Err(Interrupted {
            message: format!(
                "interrupted by {} after {spp_done} of {requested} {unit}; wrote {}{resume_hint}",
                signal_name(signal),
                shown.display()
            ),
            exit_code: (128 + signal).min(255) as u8,
        }
        .into());
    }
    if args.quiet {
        return Ok(String::new());
    }
    let samples = w * h * (done - first) as u64;
    let secs = render_time.as_secs_f64().max(1e-9);
    let peak = peak_rss_bytes().map(|b| format!("{:.1} MB", b as f64 / 1e6)).unwrap_or_else(|| "unknown".into());
    let resumed = if first != passes.start { format!(", resumed at {first}") } else { String::new() };
    let shard = plan
        .shard
        .map(|(k, n)| format!(", shard {k}/{n}: passes {}..{}", passes.start, passes.end))
        .unwrap_or_default();
    Ok(format!(
        "wrote {} ({}x{}, {} {}, {} wavelengths, {}{resumed}{shard})\n\
         scene load {:.2} s (parse {:.2} s, build {:.2} s; {} triangles, {} lights), render {:.2} s\n\
         {:.3} Msamples/s, {:.3} Mrays/s, peak memory {}\n",
        shown.display(),
        w,
        h,
        spp_done,
        unit,
        plan.wavelengths,
        built.integrator.name(),
        setup_time.as_secs_f64(),
        setup.parsed.as_secs_f64(),
        (setup_time - setup.parsed).as_secs_f64(),
        built.triangles,
        built.scene.light_count(),
        secs,
        samples as f64 / secs / 1e6,
        rays as f64 / secs / 1e6,
        peak
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resolutions_parse_and_bad_ones_are_rejected() {
        assert_eq!(parse_resolution("640x480"), Ok((640, 480)));
        assert_eq!(parse_resolution("8X4"), Ok((8, 4)));
        for bad in ["640", "0x10", "ax4", "10x-1", "100000x1"] {
            assert!(parse_resolution(bad).is_err(), "{bad}");
        }
    }
}

//! `prismatic render`: a pbrt-v4 scene in, an image out.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use render::{build_scene, BuildOptions};
use spectral::WavelengthStrategy;

/// Arguments of `prismatic render`.
#[derive(Args, Debug)]
#[command(after_help = "Examples:\n  prismatic render scenes/cornell-glass.pbrt -o cornell.png\n  \
                        prismatic render scene.pbrt --spp 64 --wavelengths cmf -o out.exr\n  \
                        prismatic render scene.pbrt --time 30 --resolution 640x480\n\n\
                        The output format follows the file extension: .exr (linear RGB; spectral films add S0.<λ>nm \
                        channels), .png (sRGB, dithered 8-bit), .pfm.\n\n\
                        Ctrl-C (SIGINT) or SIGTERM stops at the end of the current sample pass (passes last at most \
                        about a second), writes the image of the samples done (the EXR header's samplesPerPixel \
                        says how many) and exits with status 130 (SIGINT) or 143 (SIGTERM); a second signal exits \
                        at once, leaving any earlier output file as it was.")]
pub struct RenderArgs {
    /// The pbrt-v4 scene file.
    pub scene: PathBuf,

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
    #[arg(long, value_name = "SECONDS")]
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

    /// Also write albedo and normal layers (albedo.R/G/B, N.X/Y/Z) of the first surface hit, for denoisers
    /// (EXR output only).
    #[arg(long)]
    pub aovs: bool,

    /// No progress bar and no statistics.
    #[arg(long)]
    pub quiet: bool,
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

/// Runs the subcommand; returns the summary to print.
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
    if let Some(n) = args.threads {
        if n == 0 {
            bail!("--threads must be at least 1");
        }
        rayon::ThreadPoolBuilder::new().num_threads(n).build_global().context("cannot start the thread pool")?;
    }
    let crop_window = match &args.cropwindow {
        Some(c) => {
            if let Some(v) = c.iter().find(|v| !(0.0..=1.0).contains(*v)) {
                bail!("--cropwindow values are fractions of the image in [0, 1], got {v}");
            }
            Some([c[0], c[1], c[2], c[3]])
        }
        None => None,
    };
    let pixel_bounds = args.pixelbounds.as_ref().map(|b| [b[0], b[1], b[2], b[3]]);
    let stop = install_stop_signals()?;
    let start = Instant::now();
    let desc = pbrt::parse_file(&args.scene).map_err(|e| anyhow!("{e}"))?;
    let parsed = start.elapsed();
    let options = BuildOptions {
        resolution: args.resolution,
        spp: args.spp,
        output: args.output.clone(),
        crop_window,
        pixel_bounds,
    };
    let built = build_scene(&desc, &options).map_err(|e| anyhow!("{e}"))?;
    for w in &built.warnings {
        eprintln!("{w}");
    }
    // Check the output before spending time on the render.
    let out_path = &built.film.filename;
    film::ImageFormat::from_path(out_path).map_err(|e| anyhow!("{e}"))?;
    if let Some(dir) = out_path.parent().filter(|d| !d.as_os_str().is_empty()) {
        if !dir.is_dir() {
            bail!("cannot write {}: directory {} does not exist", out_path.display(), dir.display());
        }
    }
    // Scene load: parsing the files, then building (shapes and their PLY files, textures, lights, the BVH).
    let setup = start.elapsed();
    let mut spec = built.film.clone();
    if args.aovs {
        if film::ImageFormat::from_path(out_path).ok() != Some(film::ImageFormat::Exr) {
            bail!("--aovs needs an .exr output (got {})", out_path.display());
        }
        spec.aovs = true;
    }
    spec.wavelengths = args.wavelengths;
    let mut film = film::Film::new(spec).map_err(|e| anyhow!("{e}"))?;
    let unit = built.integrator.needs().unit.name();
    let mut job = built.integrator.begin(&built.scene, &film, args.seed).map_err(|e| anyhow!("{e}"))?;
    // Pixels rendered: the film's pixel bounds (a crop), or the whole image.
    let (w, h) = (film.bounds().width() as u64, film.bounds().height() as u64);

    let show = !args.quiet && std::io::stderr().is_terminal();
    let bar =
        if show { ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr()) } else { ProgressBar::hidden() };
    let taken = AtomicU64::new(0);
    let render_start = Instant::now();
    let mut rays = 0u64;
    let mut spp_done = 0u32;
    match args.time {
        None => {
            let total = w * h * built.spp as u64;
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
            let mut pass = 1u32;
            while spp_done < built.spp && stop.load(Ordering::SeqCst) == 0 {
                let pass_start = Instant::now();
                let n = pass.min(built.spp - spp_done);
                let stats = job.run(&mut film, spp_done..spp_done + n, &progress);
                rays += stats.rays;
                spp_done += n;
                let took = pass_start.elapsed();
                if took < Duration::from_millis(250) {
                    pass = pass.saturating_mul(2);
                } else if took > Duration::from_millis(1000) && pass > 1 {
                    pass /= 2;
                }
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
            let mut pass = 1u32;
            while (spp_done == 0 || render_start.elapsed() < budget) && stop.load(Ordering::SeqCst) == 0 {
                let pass_start = Instant::now();
                let progress = |n: u64| {
                    taken.fetch_add(n, Ordering::Relaxed);
                };
                let range = spp_done..spp_done + pass;
                let stats = job.run(&mut film, range, &progress);
                rays += stats.rays;
                spp_done += pass;
                bar.set_message(format!("{spp_done} {unit}"));
                bar.tick();
                // Grow the pass while it stays well inside the remaining time.
                let left = budget.saturating_sub(render_start.elapsed());
                if pass_start.elapsed() * 4 < left {
                    pass *= 2;
                } else if pass_start.elapsed() > left && pass > 1 {
                    pass /= 2;
                }
            }
        }
    }
    let signal = stop.load(Ordering::SeqCst);
    bar.finish_and_clear();
    let path = built.film.filename.clone();
    if signal != 0 && spp_done == 0 {
        return Err(Interrupted {
            message: format!("interrupted by {} before the first sample pass; nothing written", signal_name(signal)),
            exit_code: (128 + signal).min(255) as u8,
        }
        .into());
    }
    // Whatever the integrator keeps outside the film (photon mapping's progressive estimate) goes in once.
    job.finish(&mut film);
    let render_time = render_start.elapsed();
    let requested = if args.time.is_some() { spp_done } else { built.spp };
    let mut header = vec![
        ("samplesPerPixel".to_string(), spp_done.to_string()),
        ("samplesPerPixelRequested".to_string(), requested.to_string()),
    ];
    if signal != 0 {
        header.push(("interruptedBy".to_string(), signal_name(signal).to_string()));
    }
    film::write_image_with(&film, &path, &header).map_err(|e| anyhow!("cannot write {}: {e}", path.display()))?;
    if signal != 0 {
        return Err(Interrupted {
            message: format!(
                "interrupted by {} after {spp_done} of {requested} {unit}; wrote {}",
                signal_name(signal),
                path.display()
            ),
            exit_code: (128 + signal).min(255) as u8,
        }
        .into());
    }
    if args.quiet {
        return Ok(String::new());
    }
    let samples = w * h * spp_done as u64;
    let secs = render_time.as_secs_f64().max(1e-9);
    let peak = peak_rss_bytes().map(|b| format!("{:.1} MB", b as f64 / 1e6)).unwrap_or_else(|| "unknown".into());
    Ok(format!(
        "wrote {} ({}x{}, {} {}, {} wavelengths, {})\n\
         scene load {:.2} s (parse {:.2} s, build {:.2} s; {} triangles, {} lights), render {:.2} s\n\
         {:.3} Msamples/s, {:.3} Mrays/s, peak memory {}\n",
        path.display(),
        w,
        h,
        spp_done,
        unit,
        args.wavelengths,
        built.integrator.name(),
        setup.as_secs_f64(),
        parsed.as_secs_f64(),
        (setup - parsed).as_secs_f64(),
        built.triangles,
        built.scene.lights.len(),
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

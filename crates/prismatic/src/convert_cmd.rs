//! `prismatic convert`: a display image (PNG) of a linear render (EXR or PFM), through a view and into a display
//! colour space, without rendering again.

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use clap::Args;

/// Arguments of `prismatic convert`.
#[derive(Args, Debug)]
#[command(after_help = "Examples:\n  prismatic convert prism.exr -o prism.png\n  \
                        prismatic convert prism.exr -o prism-clip.png --view clip\n  \
                        prismatic convert prism.exr -o prism-p3.png --colorspace dci-p3 --exposure -1\n\n\
                        The EXR's chromaticities say which colour space its R, G, B are in (sRGB without them; a \
                        PFM is read as linear sRGB). The PNG is what `prismatic render -o out.png` writes for the \
                        same film, view and colour space.")]
pub struct ConvertArgs {
    /// The linear image: .exr (its R, G, B) or .pfm.
    pub input: PathBuf,
    /// The display image to write (.png).
    #[arg(short, long, value_name = "FILE")]
    pub output: PathBuf,
    /// oklab (hue-preserving compression, the default) or clip (each channel on its own).
    #[arg(long, value_name = "VIEW", value_parser = crate::render_cmd::parse_view, default_value = "oklab")]
    pub view: film::View,
    /// The display colour space: srgb, dci-p3 (Display P3) or rec2020; by default the input's own when it is one
    /// of those, else srgb.
    #[arg(long, value_name = "SPACE", value_parser = crate::render_cmd::parse_colorspace)]
    pub colorspace: Option<String>,
    /// Exposure in stops: the pixels are scaled by 2^EV before the view.
    #[arg(long, value_name = "EV", default_value_t = 0.0, allow_negative_numbers = true)]
    pub exposure: f64,
}

/// Runs the subcommand; returns the summary to print.
pub fn run(args: &ConvertArgs) -> Result<String> {
    if !(args.exposure.is_finite() && args.exposure.abs() <= 64.0) {
        bail!("--exposure must be a number of stops between -64 and 64, got {}", args.exposure);
    }
    if film::ImageFormat::from_path(&args.output)? != film::ImageFormat::Png {
        bail!("-o must name a .png file (got {}): EXR and PFM output is linear, with no view", args.output.display());
    }
    let input = &args.input;
    let (source, (w, h, mut pixels)) = match film::ImageFormat::from_path(input)? {
        film::ImageFormat::Exr => (film::read_exr_color_space(input)?, film::read_exr_rgb(input)?),
        film::ImageFormat::Pfm => (spectral::RgbColorSpace::srgb(), film::read_pfm(input)?),
        film::ImageFormat::Png => bail!("{} is already a display image: convert reads .exr or .pfm", input.display()),
    };
    let scale = 2f64.powf(args.exposure) as f32;
    for p in &mut pixels {
        *p = p.map(|c| c * scale);
    }
    let display_space = match &args.colorspace {
        Some(name) => spectral::RgbColorSpace::by_name(name).context("colour space")?,
        None => film::display_space_for(&source),
    };
    if display_space.name == "aces2065-1" {
        bail!("--colorspace aces2065-1 is not a display space: choose srgb, dci-p3 or rec2020");
    }
    let display = film::DisplayEncoding::with_display(&source, &display_space, args.view);
    film::write_display_png(&args.output, w, h, &pixels, &display)?;
    Ok(format!(
        "wrote {} ({w}x{h}, view {}, {} from {})\n",
        args.output.display(),
        args.view.name(),
        display_space.name,
        source.name
    ))
}

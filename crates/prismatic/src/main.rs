//! `prismatic`: the command-line front end of the Prismatic spectral renderer.
//!
//! A thin layer: it parses arguments, calls the library crates and prints. Errors are reported as one message and a
//! non-zero exit status that says what failed ([`exit`]; README.md, "Exit status"), never a panic.

#![forbid(unsafe_code)]

mod checkpoint;
mod compare_cmd;
mod convert_cmd;
mod exit;
mod ior_cmd;
mod lens_cmd;
mod merge_cmd;
mod preview;
mod render_cmd;
mod spectrum_cmd;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Prismatic: a physically based spectral renderer for light that depends on wavelength.
#[derive(Parser, Debug)]
#[command(name = "prismatic", version, about, long_about = None, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

// One value per process, parsed once: the size of its largest variant costs nothing worth a box.
#[allow(clippy::large_enum_variant)]
#[derive(Subcommand, Debug)]
enum Command {
    /// Print the index of refraction n(λ) (and k for metals) of a catalogue material, then n_d and V_d.
    Ior(ior_cmd::IorArgs),
    /// Print a lens prescription's first-order optics per wavelength: focal lengths, pupils, f-number and colour.
    Lens(lens_cmd::LensArgs),
    /// Print the colour of a spectrum: CIE XYZ, chromaticity xy and linear RGB.
    Spectrum(spectrum_cmd::SpectrumArgs),
    /// Render a pbrt-v4 or glTF 2.0 scene to EXR, PNG or PFM (spectral path tracing with dispersion).
    Render(render_cmd::RenderArgs),
    /// Merge the parts of a sharded render (render --shard K/N) into the image one process would have rendered.
    Merge(merge_cmd::MergeArgs),
    /// Compare two renders: means and (relative) RMS difference, for noise and convergence measurements.
    Compare(compare_cmd::CompareArgs),
    /// Write the display image (PNG) of a linear render (EXR, PFM) through a view and into a display colour space.
    Convert(convert_cmd::ConvertArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Ior(args) => ior_cmd::run(&args),
        Command::Lens(args) => lens_cmd::run(&args),
        Command::Spectrum(args) => spectrum_cmd::run(&args),
        Command::Render(args) => render_cmd::run(&args),
        Command::Compare(args) => compare_cmd::run(&args),
        Command::Merge(args) => merge_cmd::run(&args),
        Command::Convert(args) => convert_cmd::run(&args),
    };
    match result {
        Ok(text) => {
            print!("{text}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            let code = exit::code(&e);
            let msg = exit::message(&e);
            // A stopped render says so without "error"; scene errors already read "file:line:column: error: …".
            if e.is::<render_cmd::Interrupted>() || msg.contains(": error: ") {
                eprintln!("prismatic: {msg}");
            } else {
                eprintln!("prismatic: error: {msg}");
            }
            ExitCode::from(code)
        }
    }
}

//! `prismatic spectrum`: the colour of a spectrum.

use std::fmt::Write;

use anyhow::{anyhow, Context, Result};
use clap::Args;
use spectral::{Observer, RgbColorSpace, Spectrum};

/// Arguments of `prismatic spectrum`.
#[derive(Args, Debug)]
#[command(after_help = "SPEC is one of:\n  a named illuminant: stdillum-D65, stdillum-D50, stdillum-A, stdillum-F1 … \
                        stdillum-F12\n  a pbrt-v4 glass or metal spectrum: glass-BK7, metal-Au-eta, …\n  \
                        blackbody:KELVIN   Planck's law, normalised to peak 1 (e.g. blackbody:6500)\n  \
                        constant:VALUE     the same value at every wavelength\n  \
                        rgb:R,G,B          a linear sRGB reflectance (each in [0, 1]) uplifted to a smooth spectrum\n  \
                        rgb-illum:R,G,B    a linear sRGB emitter (non-negative), uplifted and multiplied by D65\n\n\
                        XYZ is normalised so that a constant spectrum of 1 has Y = 1; named illuminants have Y = 1.")]
pub struct SpectrumArgs {
    /// The spectrum (see below).
    pub spec: String,

    /// Colour matching functions: cie1931 (2°) or cie1964 (10°).
    #[arg(long, default_value = "cie1931", value_parser = ["cie1931", "cie1964"])]
    pub observer: String,

    /// Treat SPEC as a reflectance seen under this illuminant (a SPEC of the same forms, e.g. stdillum-D65):
    /// XYZ is then normalised so that a perfect white reflector has Y = 1.
    #[arg(long, value_name = "ILLUMINANT")]
    pub under: Option<String>,

    /// Output RGB colour space: srgb, rec2020 or aces2065-1 (linear, no chromatic adaptation).
    #[arg(long, default_value = "srgb", value_parser = ["srgb", "rec2020", "aces2065-1"])]
    pub colorspace: String,
}

/// Parses a SPEC string.
pub fn parse_spec(spec: &str) -> Result<Spectrum> {
    optics::catalogue::spectrum_from_spec(spec).map_err(|e| anyhow!(e))
}

/// Runs the subcommand and returns what to print.
pub fn run(args: &SpectrumArgs) -> Result<String> {
    let spectrum = parse_spec(&args.spec)?;
    let observer = if args.observer == "cie1964" { Observer::Cie1964 } else { Observer::Cie1931 };
    let cs = RgbColorSpace::by_name(&args.colorspace).ok_or_else(|| anyhow!("unknown colour space"))?;
    let xyz = match &args.under {
        None => observer.spectrum_to_xyz(&spectrum),
        Some(name) => {
            let light = parse_spec(name).with_context(|| format!("--under {name}"))?;
            observer
                .reflectance_to_xyz(&spectrum, &light)
                .ok_or_else(|| anyhow!("--under {name}: the illuminant has no luminance"))?
        }
    };
    let xy = xyz.chromaticity();
    let rgb = cs.to_rgb(xyz);
    let mut out = String::new();
    match &args.under {
        Some(light) => _ = writeln!(out, "{} under {light} ({} observer)", args.spec, observer.name()),
        None => _ = writeln!(out, "{} ({} observer)", args.spec, observer.name()),
    }
    let _ = writeln!(out, "XYZ          {:.6} {:.6} {:.6}", xyz.x, xyz.y, xyz.z);
    let _ = writeln!(out, "xy           {:.4} {:.4}", xy[0], xy[1]);
    let _ = writeln!(out, "linear {:<6}{:.6} {:.6} {:.6}", cs.name, rgb[0], rgb[1], rgb[2]);
    if xyz.y > 0.0 && args.under.is_none() {
        let n = rgb.map(|c| c / xyz.y);
        let _ = writeln!(out, "  (Y = 1)    {:.6} {:.6} {:.6}", n[0], n[1], n[2]);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(spec: &str) -> SpectrumArgs {
        SpectrumArgs { spec: spec.into(), observer: "cie1931".into(), colorspace: "srgb".into(), under: None }
    }

    #[test]
    fn d65_prints_its_white_point() {
        let out = run(&args("stdillum-D65")).unwrap();
        assert!(out.contains("xy           0.3127 0.3290"), "{out}");
    }

    #[test]
    fn blackbody_and_constant_parse() {
        let out = run(&args("blackbody:6500")).unwrap();
        assert!(out.contains("xy           0.3135 0.3236"), "{out}");
        assert!(run(&args("constant:1")).unwrap().contains("xy           0.3333 0.3333"), "equal-energy white");
    }

    #[test]
    fn rgb_specs_round_trip_through_uplifting() {
        // An uplifted reflectance under D65 gives back its sRGB values (Jakob & Hanika's fit criterion).
        let out = run(&SpectrumArgs { under: Some("stdillum-D65".into()), ..args("rgb:0.2,0.5,0.8") }).unwrap();
        let line = out.lines().find(|l| l.starts_with("linear srgb")).unwrap();
        let rgb: Vec<f64> = line.split_whitespace().skip(2).map(|v| v.parse().unwrap()).collect();
        for (got, want) in rgb.iter().zip([0.2, 0.5, 0.8]) {
            assert!((got - want).abs() < 2e-3, "{out}");
        }
    }

    #[test]
    fn bad_specs_are_errors() {
        for bad in [
            "rgb:1,2",
            "rgb:0.5,0.5,1.5",
            "rgb:a,b,c",
            "rgb-illum:-1,0,0",
            "blackbody:hot",
            "blackbody:-3",
            "blackbody:NaN",
            "constant:inf",
            "stdillum-D75",
            "glass-XYZ",
        ] {
            assert!(parse_spec(bad).is_err(), "{bad}");
        }
    }
}

//! `prismatic lens`: the first-order optics of a lens prescription, per wavelength.

use std::fmt::Write;
use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use clap::Args;
use optics::{LensMedium, LensPrescription, LAMBDA_C_NM, LAMBDA_D_NM, LAMBDA_F_NM};

/// Arguments of `prismatic lens`.
#[derive(Args, Debug)]
#[command(after_help = "Examples:\n  prismatic lens lenses/achromat.dat\n  \
                        prismatic lens dgauss.50mm.dat --nm 450 550 650 --image-height 21.6")]
pub struct LensArgs {
    /// A lens file: pbrt-v4's (radius, thickness, index, aperture diameter in mm per surface, object side first),
    /// with Prismatic's glass names, Abbe pairs and coatings (docs/scene-format.md, "Lens files").
    pub file: PathBuf,

    /// Wavelengths in nanometres (default: the F, d and C lines, 486.13, 587.56 and 656.27 nm).
    #[arg(long, num_args = 1.., value_name = "NM", allow_negative_numbers = true)]
    pub nm: Vec<f64>,

    /// Image height (mm from the axis) at which to report lateral colour (default 21.6, the corner of a 36×24 mm
    /// frame).
    #[arg(long, value_name = "MM", default_value_t = 21.6)]
    pub image_height: f64,

    /// Also print where the film must sit to focus on a plane this far in front of it (mm), at the d line.
    #[arg(long, value_name = "MM")]
    pub focus: Option<f64>,
}

/// Runs the command and returns what it prints.
pub fn run(args: &LensArgs) -> Result<String> {
    let text = std::fs::read_to_string(&args.file).with_context(|| format!("reading {}", args.file.display()))?;
    let lens = LensPrescription::parse(&text).map_err(|e| anyhow::anyhow!("{}:{e}", args.file.display()))?;
    let wavelengths = if args.nm.is_empty() { vec![LAMBDA_F_NM, LAMBDA_D_NM, LAMBDA_C_NM] } else { args.nm.clone() };
    for &l in &wavelengths {
        if !l.is_finite() || l <= 0.0 {
            bail!("--nm: wavelengths must be positive numbers of nanometres, got {l}");
        }
    }
    if !(args.image_height.is_finite() && args.image_height > 0.0) {
        bail!("--image-height: must be a positive number of mm, got {}", args.image_height);
    }
    let mut out = String::new();
    writeln!(
        out,
        "{}: {} surfaces, {:.3} mm from the front surface to the film",
        args.file.display(),
        lens.surfaces.len(),
        lens.length_mm()
    )?;
    writeln!(out, "  #   radius  thickness  medium behind              aperture  coating")?;
    for (i, s) in lens.surfaces.iter().enumerate() {
        let medium = match (&s.medium, s.is_stop) {
            (_, true) => "(aperture stop)".to_owned(),
            (LensMedium::Air, false) => "air".to_owned(),
            (LensMedium::Glass(ior), false) => format!("n_d {:.5}, V_d {:.2}", ior.nd(), ior.vd()),
        };
        let coating: Vec<String> = s.coating.iter().map(|l| format!("{} {} nm", l.name, l.thickness_nm)).collect();
        writeln!(
            out,
            "{:>3} {:>8.3} {:>10.3}  {:<26} {:>8.3}  {}",
            i + 1,
            s.radius_mm,
            s.thickness_mm,
            medium,
            s.aperture_mm,
            if coating.is_empty() { "-".to_owned() } else { coating.join(" + ") }
        )?;
    }
    writeln!(out)?;
    writeln!(
        out,
        "      λ (nm)     EFL (mm)     BFL (mm)  focus − film   f-number   entrance pupil (at, ⌀)   exit pupil (at, ⌀)"
    )?;
    for &l in &wavelengths {
        let p = lens.paraxial(l).map_err(|e| anyhow::anyhow!("{}: {e}", args.file.display()))?;
        writeln!(
            out,
            "{l:>12.2} {:>12.4} {:>12.4} {:>13.4} {:>10.3}   {:>9.3} {:>9.3}    {:>9.3} {:>9.3}",
            p.efl_mm,
            p.bfl_mm,
            p.focus_behind_film_mm,
            p.f_number,
            p.entrance_pupil_mm.0,
            p.entrance_pupil_mm.1,
            p.exit_pupil_mm.0,
            p.exit_pupil_mm.1
        )?;
    }
    let (f, c) = (lens.paraxial(LAMBDA_F_NM), lens.paraxial(LAMBDA_C_NM));
    if let (Ok(f), Ok(c)) = (f, c) {
        writeln!(out)?;
        writeln!(out, "longitudinal colour (focus at F − focus at C): {:.4} mm", f.bfl_mm - c.bfl_mm)?;
        let lateral = lens
            .lateral_colour(LAMBDA_F_NM, LAMBDA_C_NM, LAMBDA_D_NM, args.image_height)
            .map_err(|e| anyhow::anyhow!("{}: {e}", args.file.display()))?;
        writeln!(
            out,
            "lateral colour at {} mm (image at F − image at C, in the d focus): {:.4} mm",
            args.image_height, lateral
        )?;
    }
    if let Some(distance) = args.focus {
        let focused = lens.focused(distance, LAMBDA_D_NM).map_err(|e| anyhow::anyhow!("--focus: {e}"))?;
        let last = lens.surfaces.len() - 1;
        let (from, to) = (lens.surfaces[last].thickness_mm, focused.surfaces[last].thickness_mm);
        writeln!(out)?;
        writeln!(
            out,
            "focused at {distance} mm (d line): last surface to film {to:.4} mm (the file's {from:.4}; moved {:+.4})",
            to - from
        )?;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(name: &str, text: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("prismatic-lens-cmd-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        path
    }

    #[test]
    fn prints_the_thick_lens_focal_length_and_colour() {
        // Plano-convex, n 1.5 constant: f = R/(n − 1) = 100 mm exactly, and no colour at all (pbrt-v4's numbers).
        let file = write("pc.dat", "0 2 0 10\n50 4 1.5 25\n0 96 1 25\n");
        let out = run(&LensArgs { file, nm: vec![550.0], image_height: 21.6, focus: None }).unwrap();
        assert!(out.contains("     550.00     100.0000"), "{out}");
        assert!(out.contains("longitudinal colour (focus at F − focus at C): 0.0000 mm"), "{out}");
        // N-BK7: the F line focuses shorter than the C line.
        let file = write("bk7.dat", "0 2 0 10\n51.5 3.6 N-BK7 25.4\n0 97.6 1 25.4\n");
        let out = run(&LensArgs { file, nm: vec![], image_height: 21.6, focus: None }).unwrap();
        assert!(out.contains("longitudinal colour (focus at F − focus at C): -1.53"), "{out}");
    }

    #[test]
    fn bad_files_and_arguments_are_errors_naming_them() {
        let file = write("bad.dat", "0 2 0 10\n51.5 3.6 N-BK8 25.4\n");
        let e = run(&LensArgs { file, nm: vec![], image_height: 21.6, focus: None }).unwrap_err().to_string();
        assert!(e.contains("bad.dat:2:10:") && e.contains("N-BK8"), "{e}");
        let file = write("ok.dat", "0 2 0 10\n50 4 1.5 25\n0 96 1 25\n");
        let e = run(&LensArgs { file: file.clone(), nm: vec![-3.0], image_height: 21.6, focus: None })
            .unwrap_err()
            .to_string();
        assert!(e.contains("--nm"), "{e}");
        let e =
            run(&LensArgs { file: file.clone(), nm: vec![], image_height: 0.0, focus: None }).unwrap_err().to_string();
        assert!(e.contains("--image-height"), "{e}");
        let e =
            run(&LensArgs { file: PathBuf::from("/nonexistent/x.dat"), nm: vec![], image_height: 1.0, focus: None })
                .unwrap_err();
        assert!(format!("{e:#}").contains("/nonexistent/x.dat"), "{e:#}");
        let e = run(&LensArgs { file, nm: vec![], image_height: 1.0, focus: Some(150.0) }).unwrap_err().to_string();
        assert!(e.contains("--focus") && e.contains("too close"), "{e}");
    }

    #[test]
    fn focuses_by_the_thin_lens_equation() {
        // A thin lens of f = 100 mm (n 1.5, R ±100, almost no thickness) focused at 1000 mm from the film: the
        // object is u from the lens, the film v behind it, u + v = 1000 and 1/u + 1/v = 1/100, so v = 112.7017 mm.
        let file = write("thin.dat", "0 0 0 10\n100 0.000001 1.5 25\n-100 100 1 25\n");
        let out = run(&LensArgs { file, nm: vec![], image_height: 1.0, focus: Some(1000.0) }).unwrap();
        assert!(out.contains("last surface to film 112.7017 mm"), "{out}");
    }

    /// The repository's lens files: each reads, and its first-order figures are its published ones.
    #[test]
    fn the_shipped_lens_files_have_their_published_focal_lengths() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/lenses");
        let read = |name: &str| LensPrescription::parse(&std::fs::read_to_string(dir.join(name)).unwrap()).unwrap();
        let d = |lens: &LensPrescription| lens.paraxial(LAMBDA_D_NM).unwrap();
        let colour = |lens: &LensPrescription| {
            lens.paraxial(LAMBDA_F_NM).unwrap().bfl_mm - lens.paraxial(LAMBDA_C_NM).unwrap().bfl_mm
        };
        let singlet = read("singlet-bk7.dat");
        let achromat = read("achromat-100mm.dat");
        let dgauss = read("dgauss-50mm.dat");
        // Thorlabs AC254-100-A: f = 100.1 mm; the achromat's F − C focus shift is a tenth of the singlet's or less.
        assert!((d(&achromat).efl_mm - 100.1).abs() < 0.5, "{:?}", d(&achromat));
        assert!(
            colour(&achromat).abs() < colour(&singlet).abs() / 10.0,
            "{} vs {}",
            colour(&achromat),
            colour(&singlet)
        );
        // Smith's double Gauss: f = 50 mm (50.36 with the table's three-decimal indices), f/2, focused near infinity.
        assert!((d(&dgauss).efl_mm - 50.0).abs() < 0.5 && (d(&dgauss).f_number - 2.0).abs() < 0.05, "{:?}", d(&dgauss));
        assert!(d(&dgauss).focus_behind_film_mm.abs() < 0.05);
        assert!((d(&singlet).efl_mm - 100.0).abs() < 0.5);
        // The fluorite-crown apochromat: F and C focus together, and g (435.83 nm) lands within f/5000 of them, less
        // than a fifth of the achromat's g − F shift scaled to the same focal length.
        let apo = read("apochromat-200mm.dat");
        let g_minus_f = |lens: &LensPrescription| {
            lens.paraxial(435.8343).unwrap().bfl_mm - lens.paraxial(LAMBDA_F_NM).unwrap().bfl_mm
        };
        let f = d(&apo).efl_mm;
        assert!((f - 206.4).abs() < 0.5 && colour(&apo).abs() < 1e-3, "{f} {}", colour(&apo));
        let scaled = g_minus_f(&achromat) * f / d(&achromat).efl_mm;
        assert!(
            g_minus_f(&apo).abs() < f / 5000.0 && g_minus_f(&apo).abs() < scaled.abs() / 5.0,
            "{} vs {scaled}",
            g_minus_f(&apo)
        );
    }
}

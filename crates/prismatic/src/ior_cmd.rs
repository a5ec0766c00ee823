//! `prismatic ior`: indices of refraction from the catalogue.

use std::fmt::Write;

use anyhow::{bail, Context, Result};
use clap::Args;
use optics::catalogue::{self, CatalogueEntry};
use optics::{descartes_rainbow_angle, prism_minimum_deviation, LAMBDA_C_NM, LAMBDA_D_NM, LAMBDA_F_NM};

/// Arguments of `prismatic ior`.
#[derive(Args, Debug)]
#[command(after_help = "Examples:\n  prismatic ior N-SF11 --nm 486.13 587.56 656.27\n  prismatic ior glass-BK7\n  \
                        prismatic ior N-SF11 --prism 60 --nm 400 550 700\n  \
                        prismatic ior water --rainbow\n  \
                        prismatic ior Au --nm 450 550 650\n  prismatic ior --list")]
pub struct IorArgs {
    /// Material: a catalogue name (N-BK7, SF11, diamond, water, sapphire e, Au, …) or a pbrt-v4 spectrum name
    /// (glass-BK7, metal-Au-eta, …). Case-insensitive; spaces may be written as '-' or '_'.
    #[arg(required_unless_present = "list")]
    pub material: Option<String>,

    /// Wavelengths in nanometres (default: the F, d and C lines, 486.13, 587.56 and 656.27 nm).
    #[arg(long, num_args = 1.., value_name = "NM", allow_negative_numbers = true)]
    pub nm: Vec<f64>,

    /// Also print, for a prism of this apex angle (degrees) in air, the minimum deviation at each wavelength and
    /// the angular spread between the first and last wavelength.
    #[arg(long, value_name = "DEGREES")]
    pub prism: Option<f64>,

    /// Also print the rainbows of spherical drops of the material by geometric optics (Descartes): per wavelength,
    /// n and the angles of the primary and secondary bows from the antisolar point, those of the third- and
    /// fourth-order bows from the sun, and each bow's width across the wavelengths (default 400, 450, …, 700 nm).
    #[arg(long)]
    pub rainbow: bool,

    /// List every catalogue material and pbrt-v4 name instead.
    #[arg(long, conflicts_with_all = ["material", "nm", "prism", "rainbow"])]
    pub list: bool,
}

/// Runs the subcommand and returns what to print.
pub fn run(args: &IorArgs) -> Result<String> {
    if args.list {
        return Ok(list());
    }
    let name = args.material.as_deref().unwrap_or_default();
    let entry = resolve(name)?;
    let wavelengths = match (args.nm.is_empty(), args.rainbow) {
        (false, _) => args.nm.clone(),
        (true, false) => vec![LAMBDA_F_NM, LAMBDA_D_NM, LAMBDA_C_NM],
        (true, true) => RAINBOW_NM.to_vec(),
    };
    for &l in &wavelengths {
        if !l.is_finite() || l <= 0.0 {
            bail!("--nm: wavelength {l} is not a positive number of nanometres");
        }
    }
    let mut out = String::new();
    let _ = writeln!(out, "{} ({})", entry.name, entry.category);
    let _ = writeln!(out, "  source: {}", entry.source);
    let (lo, hi) = entry.valid_range_nm;
    let metal = entry.ior.is_complex();
    let _ = writeln!(
        out,
        "  {:>10}  {:>10}{}",
        "λ (nm)",
        "n",
        if metal { format!("  {:>10}", "k") } else { String::new() }
    );
    for &l in &wavelengths {
        let (n, k) = entry.ior.complex(l);
        let mut line = format!("  {l:>10.2}  {n:>10.6}");
        if metal {
            let _ = write!(line, "  {k:>10.6}");
        }
        if l < lo || l > hi {
            let _ = write!(line, "   (outside the data's range {lo:.0}–{hi:.0} nm: extrapolated)");
        }
        let _ = writeln!(out, "{line}");
    }
    if let Some(apex_deg) = args.prism {
        if !(apex_deg.is_finite() && apex_deg > 0.0 && apex_deg < 180.0) {
            bail!("--prism: the apex angle must be between 0 and 180 degrees, got {apex_deg}");
        }
        let apex = apex_deg.to_radians();
        let _ = writeln!(out, "  {apex_deg}° prism in air, minimum deviation:");
        let mut first_last = vec![];
        for &l in &wavelengths {
            let n = entry.ior.n(l);
            match prism_minimum_deviation(n, apex) {
                Some(d) => {
                    let _ = writeln!(out, "  {l:>10.2}  D = {:>8.3}°", d.to_degrees());
                    first_last.push(d);
                }
                None => {
                    let _ = writeln!(out, "  {l:>10.2}  no ray passes (n·sin(A/2) > 1)");
                }
            }
        }
        if let (Some(a), Some(b)) = (first_last.first(), first_last.last()) {
            if first_last.len() > 1 {
                let _ =
                    writeln!(out, "  spread {:.3}° between the first and last wavelength", (a - b).abs().to_degrees());
            }
        }
    }
    if args.rainbow {
        if metal {
            bail!("--rainbow: {} absorbs (k > 0); rainbows need transparent drops", entry.name);
        }
        rainbow(&mut out, &entry, &wavelengths);
    }
    if let Some(d) = &entry.dispersion {
        let _ = write!(out, "  n_d = {:.6}  V_d = {:.2}", d.nd, d.vd);
        match (d.nd_catalog, d.vd_catalog) {
            (Some(nd), Some(vd)) => {
                let _ = writeln!(out, "   (catalogue: n_d = {nd}, V_d = {vd})");
            }
            _ => out.push('\n'),
        }
    }
    Ok(out)
}

/// Default wavelengths of `--rainbow`, nm.
const RAINBOW_NM: [f64; 7] = [400.0, 450.0, 500.0, 550.0, 600.0, 650.0, 700.0];

/// Appends the `--rainbow` table: per wavelength n, the primary and secondary bows' angles from the antisolar point
/// and the third and fourth orders' from the sun ([`descartes_rainbow_angle`]), then each bow's width.
fn rainbow(out: &mut String, entry: &CatalogueEntry, wavelengths: &[f64]) {
    const ORDERS: [u32; 4] = [1, 2, 3, 4];
    let _ = writeln!(out, "  rainbows by geometric optics (Descartes), degrees:");
    let _ = writeln!(
        out,
        "  {:>10}  {:>10}  {:>9}  {:>9}  {:>9}  {:>9}",
        "λ (nm)", "n", "primary", "secondary", "3rd", "4th"
    );
    // angles[order][wavelength]: from the antisolar point for orders 1–2, from the sun for 3–4.
    let mut angles: Vec<Vec<Option<f64>>> = vec![Vec::new(); ORDERS.len()];
    for &l in wavelengths {
        let n = entry.ior.n(l);
        let mut line = format!("  {l:>10.2}  {n:>10.6}");
        for (i, &k) in ORDERS.iter().enumerate() {
            let a = descartes_rainbow_angle(n, k).map(|a| if k >= 3 { 180.0 - a } else { a });
            let _ = write!(line, "  {:>9}", a.map_or("-".to_owned(), |a| format!("{a:.3}")));
            angles[i].push(a);
        }
        let _ = writeln!(out, "{line}");
    }
    let _ = writeln!(
        out,
        "  (primary and secondary: from the antisolar point; 3rd and 4th orders: from the sun, which they circle \
         and whose glare hides them)"
    );
    let names = ["primary", "secondary", "3rd-order", "4th-order"];
    let (first, last) = (wavelengths.first().copied(), wavelengths.last().copied());
    for (i, name) in names.iter().enumerate() {
        let Some((lo, hi)) = wavelengths.iter().zip(&angles[i]).filter_map(|(&l, a)| a.map(|a| (l, a))).fold(
            None,
            |acc: Option<((f64, f64), (f64, f64))>, p| match acc {
                None => Some((p, p)),
                Some((lo, hi)) => Some((if p.0 < lo.0 { p } else { lo }, if p.0 > hi.0 { p } else { hi })),
            },
        ) else {
            continue;
        };
        if lo.0 == hi.0 {
            continue;
        }
        let (min, max) = angles[i].iter().flatten().fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
        let red = if hi.1 > lo.1 { "red outside" } else { "red inside" };
        let _ = writeln!(
            out,
            "  {name} bow: {:.3}° at {:.0} nm, {:.3}° at {:.0} nm: {:.3}° wide, {red}",
            lo.1,
            lo.0,
            hi.1,
            hi.0,
            max - min
        );
    }
    if let (Some(a), Some(b)) = (first, last) {
        if a != b {
            let _ = writeln!(
                out,
                "  (widths between the shortest and longest wavelength given; the sun's 0.53° disc adds about half a \
                 degree, and drops smaller than ~0.1 mm widen and shift the bows further: see optics::mie)"
            );
        }
    }
}

/// A catalogue entry by catalogue name, or by pbrt-v4 spectrum name (`glass-BK7`, `metal-Au-eta`).
fn resolve(name: &str) -> Result<CatalogueEntry> {
    if let Ok(e) = catalogue::lookup(name) {
        return Ok(e);
    }
    if let Some((_, target)) = catalogue::PBRT_GLASSES.iter().find(|(p, _)| p.eq_ignore_ascii_case(name)) {
        return Ok(catalogue::lookup(target)?);
    }
    let lower = name.to_ascii_lowercase();
    if let Some(metal) = lower.strip_prefix("metal-").and_then(|m| m.strip_suffix("-eta").or(m.strip_suffix("-k"))) {
        return catalogue::lookup(metal).with_context(|| format!("'{name}' names metal '{metal}'"));
    }
    Ok(catalogue::lookup(name)?)
}

fn list() -> String {
    let mut out = String::new();
    let _ = writeln!(out, "{:<18} {:<22} {:>9} {:>7}  range (nm)", "name", "category", "n_d", "V_d");
    for e in catalogue::entries() {
        let (nd, vd) = match &e.dispersion {
            Some(d) => (format!("{:.5}", d.nd), format!("{:.2}", d.vd)),
            None => ("-".into(), "-".into()),
        };
        let (lo, hi) = e.valid_range_nm;
        let _ = writeln!(out, "{:<18} {:<22} {:>9} {:>7}  {lo:.0}–{hi:.0}", e.name, e.category.label(), nd, vd);
    }
    let _ = writeln!(out, "\npbrt-v4 spectrum names:");
    for (pbrt, ours) in catalogue::PBRT_GLASSES {
        let _ = writeln!(out, "  {pbrt:<16} = {ours}");
    }
    let _ = writeln!(
        out,
        "  {}",
        catalogue::named_spectrum_names().into_iter().filter(|n| n.starts_with("metal-")).collect::<Vec<_>>().join(" ")
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(material: &str, nm: &[f64]) -> IorArgs {
        IorArgs { material: Some(material.into()), nm: nm.to_vec(), prism: None, rainbow: false, list: false }
    }

    #[test]
    fn prism_deviation_follows_the_minimum_deviation_formula() {
        // 60° prism, n = 1.5: D = 2·asin(0.75) − 60° = 37.1808°; n = 2 (sin 30° · 2 = 1): grazing, D = 120°.
        assert!((prism_minimum_deviation(1.5, 60f64.to_radians()).unwrap().to_degrees() - 37.18075578).abs() < 1e-6);
        assert!((prism_minimum_deviation(2.0, 60f64.to_radians()).unwrap().to_degrees() - 120.0).abs() < 1e-5);
        assert!(prism_minimum_deviation(2.5, 60f64.to_radians()).is_none());
        let mut a = args("N-SF11", &[400.0, 700.0]);
        a.prism = Some(60.0);
        let out = run(&a).unwrap();
        assert!(out.contains("spread"), "{out}");
        a.prism = Some(f64::NAN);
        assert!(run(&a).is_err());
    }

    #[test]
    fn prints_n_then_nd_and_vd() {
        let out = run(&args("N-SF11", &[486.13, 587.56, 656.27])).unwrap();
        assert!(out.contains("587.56    1.784720"), "{out}"); // n at the d line
        assert!(out.contains("n_d = 1.784720  V_d = 25.68"), "{out}");
    }

    #[test]
    fn pbrt_names_and_metals_resolve() {
        assert!(run(&args("glass-BK7", &[587.56])).unwrap().starts_with("N-BK7"));
        let au = run(&args("metal-Au-eta", &[650.0])).unwrap();
        assert!(au.lines().nth(2).unwrap().contains('k'), "{au}");
    }

    #[test]
    fn rainbow_prints_descartes_angles_and_widths() {
        let mut a = args("water", &[]);
        a.rainbow = true;
        let out = run(&a).unwrap();
        // Water 20 °C at 400 nm, computed separately (a short script from the CSV's Sellmeier coefficients and the
        // textbook minimum-deviation condition): n = 1.343557, primary 40.567° and secondary 53.620° from the
        // antisolar point, 3rd and 4th orders 37.906° and 48.600° from the sun.
        let row = out.lines().rev().find(|l| l.trim_start().starts_with("400.00")).expect("a 400 nm row");
        assert_eq!(
            row.split_whitespace().collect::<Vec<_>>(),
            ["400.00", "1.343557", "40.567", "53.620", "37.906", "48.600"],
            "{out}"
        );
        // The n table and the rainbow table, 7 default wavelengths each.
        let rows = out.lines().filter(|l| l.split_whitespace().next().is_some_and(|w| w.parse::<f64>().is_ok()));
        assert_eq!(rows.count(), 14, "{out}");
        assert!(out.contains("primary bow: 40.567° at 400 nm, 42.440° at 700 nm: 1.873° wide"), "{out}");
        let primary = out.lines().find(|l| l.contains("primary bow:")).expect("primary width");
        assert!(primary.contains("red outside") && primary.contains("at 400 nm") && primary.contains("at 700 nm"));
        assert!(out.lines().any(|l| l.contains("secondary bow:") && l.contains("red inside")), "{out}");
        // Explicit wavelengths replace the default set; a single one has no width.
        a.nm = vec![550.0];
        let one = run(&a).unwrap();
        assert!(one.contains("550.00") && !one.contains("wide"), "{one}");
        // Metals have no rainbow.
        let mut au = args("Au", &[550.0]);
        au.rainbow = true;
        assert!(run(&au).is_err());
    }

    #[test]
    fn bad_input_is_an_error_not_a_panic() {
        assert!(run(&args("unobtainium", &[])).is_err());
        assert!(run(&args("N-BK7", &[f64::NAN])).is_err());
        assert!(run(&args("N-BK7", &[-5.0])).is_err());
        assert!(list().contains("N-SF11"));
    }
}

//! Why the renderer computes the Mie optics at each wavelength instead of interpolating between tables: the error
//! of linear interpolation between the tables of two neighbouring wavelengths, against the table at the wavelength
//! itself, for water drops.
//!
//! `cargo run --release -p optics --example mie_lambda_interp RADIUS_UM STEP DEGREES [GRID [SPREAD]]`
//!
//! GRID 0 (default) puts the tables on a grid uniform in size parameter with step STEP, GRID 1 on a grid uniform in
//! wavelength with step STEP nm. The phase functions are compared in bins of DEGREES over 0–180°: printed are the
//! median and largest rms of the relative bin error over 16 wavelengths spread over 362–808 nm (or those listed in
//! the environment variable LAMS, comma-separated, each printed), the worst single bin, and the largest relative
//! error of C_sca.

use optics::mie::{particle_index, MiePhaseTable};
use rayon::prelude::*;

/// The table's probability in each bin of `deg` degrees.
fn binned(t: &MiePhaseTable, deg: f64) -> Vec<f64> {
    let n = (180.0 / deg).round() as usize;
    let c: Vec<f64> = (0..=n).map(|i| t.cdf_at_cos((i as f64 * deg).to_radians().cos())).collect();
    c.windows(2).map(|w| w[1] - w[0]).collect()
}

fn main() {
    let args: Vec<f64> = std::env::args().skip(1).map(|a| a.parse().expect("numbers")).collect();
    if args.len() < 3 {
        eprintln!("usage: mie_lambda_interp RADIUS_UM STEP DEGREES [GRID [SPREAD]]");
        std::process::exit(2);
    }
    let (radius, step, deg) = (args[0], args[1], args[2]);
    let grid_in_nm = args.get(3).copied().unwrap_or(0.0) != 0.0;
    let spread = args.get(4).copied().unwrap_or(0.0);
    let index = particle_index("water").expect("water");
    let k = |l: f64| 2.0 * std::f64::consts::PI * 1e3 / l; // µm⁻¹
    let listed = std::env::var("LAMS").ok();
    let lambdas: Vec<f64> = match &listed {
        Some(v) => v.split(',').map(|s| s.parse().expect("LAMS: numbers")).collect(),
        None => (0..16).map(|i| 362.0 + 29.3 * i as f64 + 0.37 * ((i * 7) % 5) as f64).collect(),
    };
    let table = |l: f64| MiePhaseTable::log_normal(index(l), k(l) * radius, spread).expect("table");
    let results: Vec<(f64, f64, f64)> = lambdas
        .par_iter()
        .map(|&l| {
            let exact = table(l);
            // The neighbouring grid wavelengths and the weight of the upper one.
            let (l0, l1, w) = if grid_in_nm {
                let l0 = (l / step).floor() * step;
                (l0, l0 + step, (l - l0) / step)
            } else {
                let x = k(l) * radius;
                let x0 = (x / step).floor() * step;
                (k(1.0) * radius / x0, k(1.0) * radius / (x0 + step), (x - x0) / step)
            };
            let (t0, t1) = (table(l0), table(l1));
            let (pe, p0, p1) = (binned(&exact, deg), binned(&t0, deg), binned(&t1, deg));
            let (mut sum2, mut worst) = (0.0, 0.0f64);
            for i in 0..pe.len() {
                let e = ((1.0 - w) * p0[i] + w * p1[i] - pe[i]) / pe[i];
                sum2 += e * e;
                worst = worst.max(e.abs());
            }
            let q = |t: &MiePhaseTable| t.efficiencies().q_sca;
            let q_err = ((1.0 - w) * q(&t0) + w * q(&t1) - q(&exact)).abs() / q(&exact);
            ((sum2 / pe.len() as f64).sqrt(), worst, q_err)
        })
        .collect();
    if listed.is_some() {
        for (l, r) in lambdas.iter().zip(&results) {
            println!("  {l} nm: rms {:.4}, worst bin {:.3}, C_sca {:.2e}", r.0, r.1, r.2);
        }
    }
    let mut rms: Vec<f64> = results.iter().map(|r| r.0).collect();
    rms.sort_by(f64::total_cmp);
    println!(
        "r = {radius} µm, spread {spread}, tables every {step} {} at {deg}°: rms median {:.4}, largest {:.4}; worst bin \
         {:.3}; C_sca error up to {:.2e}",
        if grid_in_nm { "nm" } else { "in x" },
        rms[rms.len() / 2],
        rms[rms.len() - 1],
        results.iter().map(|r| r.1).fold(0.0, f64::max),
        results.iter().map(|r| r.2).fold(0.0, f64::max)
    );
}

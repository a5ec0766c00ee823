//! Build time of `MieSpectralTable` for water droplets over the default grid (360–830 nm every 10 nm).
//!
//! `cargo run --release -p optics --example mie_build_time [RADIUS_UM SPREAD]...`
//! (default: 10 and 250 µm, spreads 0 and 0.1). Prints the best and the median of five builds, with the number of
//! radii per wavelength and the threads rayon uses. Cached twiddle tables make the first build of a process a
//! little slower; it is the first figure printed.

use std::time::Instant;

use optics::mie::{default_mie_wavelengths, log_normal_node_count, MieSpectralTable};

fn main() {
    let args: Vec<f64> = std::env::args().skip(1).map(|a| a.parse().expect("numbers: RADIUS_UM SPREAD ...")).collect();
    let cases: Vec<(f64, f64)> = if args.len() >= 2 {
        args.chunks_exact(2).map(|c| (c[0], c[1])).collect()
    } else {
        vec![(10.0, 0.0), (10.0, 0.1), (250.0, 0.0), (250.0, 0.1)]
    };
    let lambdas = default_mie_wavelengths();
    println!("{} wavelengths, {} threads", lambdas.len(), rayon::current_num_threads());
    for (radius, spread) in cases {
        let mut times = Vec::new();
        let mut bins = 0;
        for _ in 0..5 {
            let t0 = Instant::now();
            let t = MieSpectralTable::from_particle("water", radius, spread, &lambdas).expect("water table");
            times.push(t0.elapsed().as_secs_f64());
            bins = t.tables().iter().map(|t| t.bins()).max().unwrap_or(0);
        }
        let first = times[0];
        times.sort_by(f64::total_cmp);
        let nodes: Vec<usize> = lambdas
            .iter()
            .map(|l| log_normal_node_count(2.0 * std::f64::consts::PI * radius * 1e3 / l, spread))
            .collect();
        println!(
            "r = {radius} µm, spread {spread}: best {:.3} s, median {:.3} s, first {:.3} s; radii per wavelength \
             {}–{}, up to {bins} bins",
            times[0],
            times[2],
            first,
            nodes.iter().min().unwrap_or(&0),
            nodes.iter().max().unwrap_or(&0)
        );
    }
}

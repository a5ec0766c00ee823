//! Time to compute the Lorenz–Mie optics of water droplets at the wavelengths of one render pass.
//!
//! `cargo run --release -p optics --example mie_build_time [RADIUS_UM SPREAD]...`
//! (default: 10 and 250 µm, spreads 0 and 0.1). For each case prints the best and the median of five runs of
//! `MieSpectralTable::prepare` for four wavelengths (one pass of hero wavelengths, computed in parallel), and of one
//! wavelength's table on one thread, with the number of radii per wavelength and the threads rayon uses. Cached
//! twiddle tables make the first computation of a process a little slower.

use std::time::Instant;

use optics::mie::{log_normal_node_count, MieSpectralTable};

/// Best and median of five timings of `f`, seconds.
fn time5(mut f: impl FnMut()) -> (f64, f64) {
    let mut times: Vec<f64> = (0..5)
        .map(|_| {
            let t0 = Instant::now();
            f();
            t0.elapsed().as_secs_f64()
        })
        .collect();
    times.sort_by(f64::total_cmp);
    (times[0], times[2])
}

fn main() {
    let args: Vec<f64> = std::env::args().skip(1).map(|a| a.parse().expect("numbers: RADIUS_UM SPREAD ...")).collect();
    let cases: Vec<(f64, f64)> = if args.len() >= 2 {
        args.chunks_exact(2).map(|c| (c[0], c[1])).collect()
    } else {
        vec![(10.0, 0.0), (10.0, 0.1), (250.0, 0.0), (250.0, 0.1)]
    };
    // A pass's four wavelengths: hero wavelengths a quarter of the visible pdf apart.
    let pass = [421.3, 511.7, 574.9, 643.2];
    println!("{} threads", rayon::current_num_threads());
    for (radius, spread) in cases {
        let t = MieSpectralTable::from_particle("water", radius, spread).expect("water table");
        t.prepare(&[550.0]); // warm the transform tables
        let (pass_best, pass_median) = time5(|| {
            t.release();
            t.prepare(&pass);
        });
        let (one_best, one_median) = time5(|| {
            std::hint::black_box(t.compute(450.0));
        });
        let nodes: Vec<usize> = [360.0, 830.0]
            .iter()
            .map(|l| log_normal_node_count(2.0 * std::f64::consts::PI * radius * 1e3 / l, spread))
            .collect();
        println!(
            "r = {radius} µm, spread {spread}: a pass (4 wavelengths) best {pass_best:.4} s, median {pass_median:.4} s; \
             one wavelength on one thread best {one_best:.4} s, median {one_median:.4} s; radii per wavelength {}–{}",
            nodes[1], nodes[0]
        );
    }
}

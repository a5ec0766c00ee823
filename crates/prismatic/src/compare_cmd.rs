//! `prismatic compare`: how far apart two renders of the same scene are (for noise and convergence measurements).

use std::fmt::Write;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;

/// Arguments of `prismatic compare`.
#[derive(Args, Debug)]
#[command(after_help = "Examples:\n  prismatic compare seed1.exr seed2.exr\n  \
                        prismatic compare render.exr reference.exr --region 100,50,300,200\n\n\
                        Two renders of one scene with different --seed values differ only by noise: their relative \
                        RMS difference divided by √2 is the relative noise of one of them. With a converged \
                        reference as B, relative_mse = MSE / mean(B)² is A's error, and 1 / (relative_mse × CPU \
                        seconds) its efficiency (scripts/efficiency.sh).")]
pub struct CompareArgs {
    /// First image (.exr, .pfm or .png; linear RGB is compared, PNGs are linearised).
    pub a: PathBuf,
    /// Second image, the same size.
    pub b: PathBuf,
    /// Only the pixels x0 ≤ x < x1, y0 ≤ y < y1.
    #[arg(long, value_name = "X0,Y0,X1,Y1", value_parser = parse_region)]
    pub region: Option<[u32; 4]>,
    /// Also compare the means of N×N blocks, each against both images' noise (see --a2, --b2).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub blocks: Option<u32>,
    /// A second render of A's scene with another seed: A becomes the average of both, and their difference
    /// measures A's noise per pixel for --blocks. Without it A counts as noiseless.
    #[arg(long, value_name = "FILE", requires = "blocks")]
    pub a2: Option<PathBuf>,
    /// A second render of B's scene with another seed, as --a2 for B.
    #[arg(long, value_name = "FILE", requires = "blocks")]
    pub b2: Option<PathBuf>,
    /// A block is off when its mean differs from B's by more than this fraction …
    #[arg(long, value_name = "FRACTION", default_value_t = 0.1, requires = "blocks")]
    pub block_tolerance: f64,
    /// … and by more than this many standard deviations of the difference.
    #[arg(long, value_name = "SIGMAS", default_value_t = 5.0, requires = "blocks")]
    pub block_sigmas: f64,
    /// Also print every off block (top-left pixel, relative difference, σ), one per line.
    #[arg(long, requires = "blocks")]
    pub list_blocks: bool,
}

fn parse_region(s: &str) -> Result<[u32; 4], String> {
    let v: Vec<u32> = s
        .split(',')
        .map(|p| p.trim().parse::<u32>().map_err(|_| format!("'{p}' is not a non-negative integer")))
        .collect::<Result<_, _>>()?;
    match *v.as_slice() {
        [x0, y0, x1, y1] if x0 < x1 && y0 < y1 => Ok([x0, y0, x1, y1]),
        [_, _, _, _] => Err(format!("region {s} is empty (need x0 < x1 and y0 < y1)")),
        _ => Err(format!("'{s}' is not X0,Y0,X1,Y1")),
    }
}

/// Statistics of two images over a region, on the luminance-like mean of the RGB channels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Comparison {
    /// Pixels compared: those of the region finite in both images.
    pub pixels: usize,
    /// Pixels of the region left out because a channel of a or of b is not finite (infinite or NaN).
    pub non_finite: usize,
    /// Mean of image a and of image b (average of R, G, B).
    pub mean: [f64; 2],
    /// Root mean square of the per-channel differences.
    pub rmse: f64,
    /// Mean over pixels and channels of (a − b)² / (b² + 0.01): the per-pixel relative MSE of a against the
    /// reference b (Rousselle et al. 2011's relMSE; the 0.01 keeps black pixels from dominating).
    pub pixel_relative_mse: f64,
    /// Channel values (of `3 × pixels`) equal bit for bit in both images.
    pub identical_values: usize,
    /// Largest over pixels of max |a − b| over the channels divided by the pixel's largest |b|: the distance of a
    /// merged or resumed render from the single-process one, in units of the pixel's scale (2⁻²³ is one f32 ulp).
    /// 0 for identical images; infinite where b's pixel is black and a's is not.
    pub max_difference_over_pixel_max: f64,
}

impl Comparison {
    /// MSE divided by the square of b's mean: the relative MSE of a against the reference b. Efficiency
    /// comparisons use 1 / (relative MSE × CPU time), which does not depend on the sample count of an unbiased
    /// render.
    pub fn relative_mse(&self) -> f64 {
        if self.mean[1] > 0.0 {
            (self.rmse / self.mean[1]).powi(2)
        } else {
            f64::INFINITY
        }
    }

    /// RMSE relative to the mean of both images.
    pub fn relative_rmse(&self) -> f64 {
        let m = 0.5 * (self.mean[0] + self.mean[1]);
        if m > 0.0 {
            self.rmse / m
        } else {
            f64::INFINITY
        }
    }
}

/// A pixel all of whose channels are finite numbers.
fn finite(p: &[f32; 3]) -> bool {
    p.iter().all(|v| v.is_finite())
}

/// Compares two RGB images of size `w`×`h` over `region` (the whole image if `None`). Pixels with a channel that
/// is not finite in either image are left out and counted: one infinite pixel would make every statistic infinite,
/// and a reference renderer may write some (pbrt-v4's half-float EXRs turn values beyond 65504 into infinities).
pub fn compare(w: u32, h: u32, a: &[[f32; 3]], b: &[[f32; 3]], region: Option<[u32; 4]>) -> Result<Comparison> {
    let [x0, y0, x1, y1] = region.unwrap_or([0, 0, w, h]);
    if x1 > w || y1 > h {
        bail!("--region {x0},{y0},{x1},{y1} is outside the {w}x{h} image");
    }
    let (mut sa, mut sb, mut d2, mut rel, mut n) = (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0usize);
    let (mut identical_values, mut max_scaled, mut non_finite) = (0usize, 0.0f64, 0usize);
    for y in y0..y1 {
        for x in x0..x1 {
            let i = (y * w + x) as usize;
            if !(finite(&a[i]) && finite(&b[i])) {
                non_finite += 1;
                continue;
            }
            let scale = b[i].iter().fold(0.0f64, |m, v| m.max((*v as f64).abs()));
            let mut largest_difference = 0.0f64;
            for c in 0..3 {
                let (va, vb) = (a[i][c] as f64, b[i][c] as f64);
                sa += va;
                sb += vb;
                d2 += (va - vb) * (va - vb);
                rel += (va - vb) * (va - vb) / (vb * vb + 0.01);
                identical_values += usize::from(a[i][c].to_bits() == b[i][c].to_bits());
                largest_difference = largest_difference.max((va - vb).abs());
            }
            if largest_difference > 0.0 {
                max_scaled = max_scaled.max(if scale > 0.0 { largest_difference / scale } else { f64::INFINITY });
            }
            n += 1;
        }
    }
    if n == 0 {
        bail!("no pixel of the region is finite in both images");
    }
    let k = (3 * n) as f64;
    Ok(Comparison {
        pixels: n,
        non_finite,
        mean: [sa / k, sb / k],
        rmse: (d2 / k).sqrt(),
        pixel_relative_mse: rel / k,
        identical_values,
        max_difference_over_pixel_max: max_scaled,
    })
}

/// A render averaged over one or two seeds, with the variance of each pixel's average where two were given.
struct Estimate {
    mean: Vec<[f32; 3]>,
    /// Per pixel and channel, (x₁ − x₂)²/4: an unbiased estimate of the variance of (x₁ + x₂)/2 for independent
    /// renders. `None` for a single render.
    variance: Option<Vec<[f32; 3]>>,
}

impl Estimate {
    /// Whether pixel `i`'s mean and variance are finite numbers.
    fn finite_at(&self, i: usize) -> bool {
        finite(&self.mean[i]) && self.variance.as_ref().is_none_or(|v| finite(&v[i]))
    }
}

/// The per-channel means over a region and the test of every `n`×`n` block of two estimates.
#[derive(Clone, Debug, PartialEq)]
pub struct BlockComparison {
    /// Mean of R, G and B of a and of b over the region.
    pub channel_mean: [[f64; 3]; 2],
    /// Standard deviation of the difference of those means (both estimates' variances over the region's pixels;
    /// 0 for renders given without a second seed).
    pub channel_sigma: [f64; 3],
    /// Blocks compared (partial blocks at the right and bottom edges count; a block none of whose pixels is finite
    /// in both estimates does not).
    pub blocks: usize,
    /// Blocks whose mean (of R, G and B) differs from b's by more than the tolerance and the sigmas.
    pub off: usize,
    /// Among the off blocks (or, if none is, all blocks) the one farthest in sigmas: its top-left pixel, relative
    /// difference (a − b)/b and distance in standard deviations (infinite where neither image has noise).
    pub worst: Option<([u32; 2], f64, f64)>,
    /// Every off block as the worst one is given, in raster order.
    pub off_blocks: Vec<([u32; 2], f64, f64)>,
}

/// When a block of two renders counts as off.
#[derive(Clone, Copy, Debug)]
struct BlockTest {
    /// Blocks are `size`×`size` pixels.
    size: u32,
    /// Off only when the means differ by more than this fraction of b's …
    tolerance: f64,
    /// … and by more than this many standard deviations of the difference.
    sigmas: f64,
}

/// Tests every block of `region`, leaving out pixels that are not finite in a or b: it is off when |ā − b̄| > tolerance·b̄ and > sigmas·σ, with σ² the sum of both
/// estimates' block variances (each pixel's variance summed over the block's pixels and channels, divided by their
/// count squared, as for a mean of independent values).
fn compare_blocks(
    (w, h): (u32, u32),
    a: &Estimate,
    b: &Estimate,
    region: Option<[u32; 4]>,
    test: BlockTest,
) -> Result<BlockComparison> {
    let BlockTest { size: n, tolerance, sigmas } = test;
    let [x0, y0, x1, y1] = region.unwrap_or([0, 0, w, h]);
    if x1 > w || y1 > h {
        bail!("--region {x0},{y0},{x1},{y1} is outside the {w}x{h} image");
    }
    let mut channel_sum = [[0.0f64; 3]; 2];
    let mut channel_var = [0.0f64; 3];
    let (mut blocks, mut off, mut worst_off, mut worst_any) = (0, 0, None, None::<([u32; 2], f64, f64)>);
    let mut off_blocks = Vec::new();
    let mut compared_pixels = 0usize;
    let farther = |w: &Option<([u32; 2], f64, f64)>, z: f64| w.is_none_or(|(_, _, wz)| z > wz);
    for by in (y0..y1).step_by(n as usize) {
        for bx in (x0..x1).step_by(n as usize) {
            let (mut sum, mut var, mut count) = ([0.0f64; 2], 0.0f64, 0usize);
            for y in by..(by + n).min(y1) {
                for x in bx..(bx + n).min(x1) {
                    let i = (y * w + x) as usize;
                    if !(a.finite_at(i) && b.finite_at(i)) {
                        continue;
                    }
                    for (k, e) in [a, b].into_iter().enumerate() {
                        for c in 0..3 {
                            let v = e.mean[i][c] as f64;
                            channel_sum[k][c] += v;
                            sum[k] += v;
                            let pixel_var = e.variance.as_ref().map_or(0.0, |s| s[i][c] as f64);
                            var += pixel_var;
                            channel_var[c] += pixel_var;
                        }
                    }
                    count += 3;
                }
            }
            if count == 0 {
                continue;
            }
            compared_pixels += count / 3;
            let (ma, mb) = (sum[0] / count as f64, sum[1] / count as f64);
            let sigma = var.sqrt() / count as f64;
            let difference = (ma - mb).abs();
            let z = if sigma > 0.0 {
                difference / sigma
            } else if difference > 0.0 {
                f64::INFINITY
            } else {
                0.0
            };
            let relative = if mb != 0.0 { (ma - mb) / mb } else { f64::INFINITY.copysign(ma - mb) };
            let entry = ([bx, by], relative, z);
            blocks += 1;
            if difference > tolerance * mb.abs() && z > sigmas {
                off += 1;
                off_blocks.push(entry);
                if farther(&worst_off, z) {
                    worst_off = Some(entry);
                }
            }
            if farther(&worst_any, z) {
                worst_any = Some(entry);
            }
        }
    }
    // Every pixel used was counted once per channel in each block's `count`; the channel means are over those.
    let pixels = compared_pixels as f64;
    if compared_pixels == 0 {
        bail!("no pixel of the region is finite in both images");
    }
    Ok(BlockComparison {
        channel_mean: channel_sum.map(|s| s.map(|v| v / pixels)),
        channel_sigma: channel_var.map(|v| v.sqrt() / pixels),
        blocks,
        off,
        worst: worst_off.or(worst_any),
        off_blocks,
    })
}

/// Reads a render and, if given, a second one of another seed into an [`Estimate`].
fn read_estimate(first: &Path, second: Option<&Path>) -> Result<(u32, u32, Estimate)> {
    let read = |p: &Path| film::read_rgb(p).with_context(|| format!("cannot read {}", p.display()));
    let (w, h, x1) = read(first)?;
    let Some(second) = second else {
        return Ok((w, h, Estimate { mean: x1, variance: None }));
    };
    let (w2, h2, x2) = read(second)?;
    if (w2, h2) != (w, h) {
        bail!("{} is {w2}x{h2}, {} is {w}x{h}", second.display(), first.display());
    }
    let mean = x1.iter().zip(&x2).map(|(p, q)| [0, 1, 2].map(|c| 0.5 * (p[c] + q[c]))).collect();
    let variance = x1.iter().zip(&x2).map(|(p, q)| [0, 1, 2].map(|c| 0.25 * (p[c] - q[c]).powi(2))).collect();
    Ok((w, h, Estimate { mean, variance: Some(variance) }))
}

/// Runs the subcommand and returns what to print.
pub fn run(args: &CompareArgs) -> Result<String> {
    let (wa, ha, ea) = read_estimate(&args.a, args.a2.as_deref())?;
    let (wb, hb, eb) = read_estimate(&args.b, args.b2.as_deref())?;
    if (wa, ha) != (wb, hb) {
        bail!("the images differ in size: {wa}x{ha} and {wb}x{hb}");
    }
    let c = compare(wa, ha, &ea.mean, &eb.mean, args.region)?;
    let mut out = String::new();
    let _ = writeln!(out, "pixels {}", c.pixels);
    // Which image holds them matters: in a render under test they are a bug, in a reference a limitation.
    let [x0, y0, x1, y1] = args.region.unwrap_or([0, 0, wa, ha]);
    let non_finite = |e: &Estimate| {
        (y0..y1).flat_map(|y| (x0..x1).map(move |x| (y * wa + x) as usize)).filter(|&i| !e.finite_at(i)).count()
    };
    let (nfa, nfb) = (non_finite(&ea), non_finite(&eb));
    if nfa + nfb > 0 {
        let _ = writeln!(out, "non_finite_pixels {nfa} {nfb} (left out)");
    }
    let _ = writeln!(out, "mean {:.6e} {:.6e}", c.mean[0], c.mean[1]);
    let _ = writeln!(out, "rmse {:.6e}", c.rmse);
    let _ = writeln!(out, "relative_rmse {:.6}", c.relative_rmse());
    let _ = writeln!(out, "relative_mse {:.6e}", c.relative_mse());
    let _ = writeln!(out, "pixel_relative_mse {:.6e}", c.pixel_relative_mse);
    let _ = writeln!(out, "identical_values {} of {}", c.identical_values, 3 * c.pixels);
    let _ = writeln!(out, "max_difference_over_pixel_max {:.6e}", c.max_difference_over_pixel_max);
    if let Some(n) = args.blocks {
        if !(args.block_tolerance >= 0.0 && args.block_sigmas >= 0.0) {
            bail!("--block-tolerance and --block-sigmas must not be negative");
        }
        let test = BlockTest { size: n, tolerance: args.block_tolerance, sigmas: args.block_sigmas };
        let bc = compare_blocks((wa, ha), &ea, &eb, args.region, test)?;
        let [ma, mb] = bc.channel_mean;
        let _ = writeln!(out, "channel_mean_a {:.6e} {:.6e} {:.6e}", ma[0], ma[1], ma[2]);
        let _ = writeln!(out, "channel_mean_b {:.6e} {:.6e} {:.6e}", mb[0], mb[1], mb[2]);
        let rel = [0, 1, 2].map(|c| if mb[c] != 0.0 { ma[c] / mb[c] - 1.0 } else { f64::NAN });
        let _ = writeln!(out, "channel_relative_difference {:+.4} {:+.4} {:+.4}", rel[0], rel[1], rel[2]);
        // The same differences in standard deviations: a mean dominated by a few bright pixels (a small light seen
        // directly at a few samples per pixel) can differ by per cents from noise alone.
        let z = [0, 1, 2].map(|c| {
            let d = (ma[c] - mb[c]).abs();
            if bc.channel_sigma[c] > 0.0 {
                d / bc.channel_sigma[c]
            } else if d > 0.0 {
                f64::INFINITY
            } else {
                0.0
            }
        });
        let _ = writeln!(out, "channel_difference_sigmas {:.1} {:.1} {:.1}", z[0], z[1], z[2]);
        let _ = writeln!(
            out,
            "blocks_off {} of {} ({n}x{n}, beyond {} and {} sigma)",
            bc.off, bc.blocks, args.block_tolerance, args.block_sigmas
        );
        if let Some(([x, y], relative, z)) = bc.worst {
            let _ = writeln!(out, "worst_block {x},{y} {relative:+.4} {z:.1}");
        }
        if args.list_blocks {
            for ([x, y], relative, z) in &bc.off_blocks {
                let _ = writeln!(out, "off_block {x},{y} {relative:+.4} {z:.1}");
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rmse_and_means_of_known_images() {
        let a = vec![[1.0, 1.0, 1.0], [3.0, 3.0, 3.0]];
        let b = vec![[1.0, 1.0, 1.0], [1.0, 1.0, 1.0]];
        let c = compare(2, 1, &a, &b, None).unwrap();
        assert_eq!(c.pixels, 2);
        assert_eq!(c.mean, [2.0, 1.0]);
        // Differences 0 (×3) and 2 (×3): RMSE √(12/6) = √2; relative to the mean 1.5.
        assert!((c.rmse - 2f64.sqrt()).abs() < 1e-12);
        assert!((c.relative_rmse() - 2f64.sqrt() / 1.5).abs() < 1e-12);
        // Against b (mean 1): MSE 2 / 1² = 2; per pixel, 0 for the first and 4 / 1.01 for the second.
        assert!((c.relative_mse() - 2.0).abs() < 1e-12);
        assert!((c.pixel_relative_mse - 0.5 * 4.0 / 1.01).abs() < 1e-12);
        // The first pixel is equal bit for bit; the second differs by 2 on a scale of 1.
        assert_eq!(c.identical_values, 3);
        assert_eq!(c.max_difference_over_pixel_max, 2.0);
        let same = compare(2, 1, &a, &a, None).unwrap();
        assert_eq!((same.identical_values, same.max_difference_over_pixel_max), (6, 0.0));
        let black = compare(1, 1, &[[0.0, 1e-9, 0.0]], &[[0.0; 3]], None).unwrap();
        assert_eq!(black.max_difference_over_pixel_max, f64::INFINITY);
        let right = compare(2, 1, &a, &b, Some([1, 0, 2, 1])).unwrap();
        assert_eq!(right.mean, [3.0, 1.0]);
        assert!(compare(2, 1, &a, &b, Some([0, 0, 3, 1])).is_err());
        assert!(parse_region("1,2,3").is_err() && parse_region("5,0,5,1").is_err());
        assert_eq!(parse_region("0, 1, 2, 3"), Ok([0, 1, 2, 3]));
    }

    #[test]
    fn a_block_is_off_only_beyond_both_the_tolerance_and_the_noise() {
        // 8×4 pixels of value 1 in b; in a, the left 4×4 block is 1.2 (20% off) and the right one 1.05 (5% off).
        let b = vec![[1.0f32; 3]; 32];
        let a: Vec<[f32; 3]> = (0..32).map(|i| if i % 8 < 4 { [1.2; 3] } else { [1.05; 3] }).collect();
        let estimate = |mean: &Vec<[f32; 3]>, var: Option<f32>| Estimate {
            mean: mean.clone(),
            variance: var.map(|v| vec![[v; 3]; mean.len()]),
        };
        // Per-value variance v over 48 values of a block: σ of a block mean is √(48 v)/48 = √(v/48), both images'.
        let blocks = |size| BlockTest { size, tolerance: 0.1, sigmas: 5.0 };
        let test = |va, vb| compare_blocks((8, 4), &estimate(&a, va), &estimate(&b, vb), None, blocks(4)).unwrap();
        // Noiseless: only the 20% block is beyond 10%; it is infinitely many σ away.
        let c = test(None, None);
        assert_eq!((c.blocks, c.off), (2, 1));
        assert_eq!(c.off_blocks.len(), 1);
        assert_eq!(c.off_blocks[0].0, [0, 0]);
        let ([x, y], rel, z) = c.worst.unwrap();
        assert_eq!([x, y], [0, 0]);
        assert!((rel - 0.2).abs() < 1e-6 && z.is_infinite());
        assert!((c.channel_mean[0][0] - 1.125).abs() < 1e-6 && c.channel_mean[1] == [1.0; 3]);
        assert_eq!(c.channel_sigma, [0.0; 3]);
        // σ = √(2·0.048/48) ≈ 0.045 in total: 0.2 is 4.5σ, not beyond 5σ; with a quarter the variance it is 8.9σ.
        let c = test(Some(0.048), Some(0.048));
        assert_eq!(c.off, 0);
        // Each channel's mean over 32 pixels, both with variance 0.048 per pixel: σ = √(2·32·0.048)/32.
        assert!(c.channel_sigma.iter().all(|s| (s - (2.0f64 * 32.0 * 0.048).sqrt() / 32.0).abs() < 1e-6));
        assert!((c.worst.unwrap().2 - 0.2 / (0.096f64 / 48.0).sqrt()).abs() < 1e-3);
        assert_eq!(test(Some(0.012), Some(0.012)).off, 1);
        // A region holding the right block only: 5% is within the tolerance however small the noise.
        let right = compare_blocks((8, 4), &estimate(&a, None), &estimate(&b, None), Some([4, 0, 8, 4]), blocks(4));
        assert_eq!(right.unwrap().off, 0);
        // Partial blocks at the edges count: 3×3 blocks tile 8×4 as 3 columns by 2 rows.
        let c = compare_blocks((8, 4), &estimate(&a, None), &estimate(&b, None), None, blocks(3)).unwrap();
        assert_eq!(c.blocks, 6);
    }

    #[test]
    fn pixels_that_are_not_finite_are_left_out_and_counted() {
        // b has an infinite pixel at x = 1 and a NaN at x = 2; a is 2 everywhere, b 1 elsewhere.
        let a = vec![[2.0f32; 3]; 4];
        let b = vec![[1.0; 3], [f32::INFINITY, 1.0, 1.0], [1.0, f32::NAN, 1.0], [1.0; 3]];
        let c = compare(4, 1, &a, &b, None).unwrap();
        assert_eq!((c.pixels, c.non_finite), (2, 2));
        assert_eq!(c.mean, [2.0, 1.0]);
        assert!((c.rmse - 1.0).abs() < 1e-12);
        // Either image's: the same pixels go, whichever holds them.
        let c = compare(4, 1, &b, &a, None).unwrap();
        assert_eq!((c.pixels, c.non_finite, c.mean), (2, 2, [1.0, 2.0]));
        assert!(compare(4, 1, &a, &b, Some([1, 0, 3, 1])).is_err(), "nothing finite is left to compare");
        // Blocks of 2×1: the block at x = 0 keeps its finite pixel, the one at x = 2 is only the pixel at x = 3.
        // A second seed with an infinite value makes the pixel's variance infinite, so it goes too.
        let one = |mean: Vec<[f32; 3]>| Estimate { variance: Some(vec![[0.01; 3]; mean.len()]), mean };
        let mut noisy_a = one(a.clone());
        noisy_a.variance.as_mut().unwrap()[3] = [f32::INFINITY; 3];
        let test = BlockTest { size: 2, tolerance: 0.1, sigmas: 5.0 };
        let c = compare_blocks((4, 1), &noisy_a, &one(b.clone()), None, test).unwrap();
        assert_eq!((c.blocks, c.off), (1, 1));
        assert_eq!(c.channel_mean, [[2.0; 3], [1.0; 3]]);
        let c = compare_blocks((4, 1), &one(a.clone()), &one(b), None, test).unwrap();
        assert_eq!((c.blocks, c.off), (2, 2));
        assert!(c.worst.unwrap().2.is_finite());
    }
}

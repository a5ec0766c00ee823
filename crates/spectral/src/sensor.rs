//! pbrt-v4's measured camera sensors: the r̄, ḡ, b̄ spectral sensitivities of 17 digital cameras, and the 3×3
//! matrix that takes a camera's raw RGB to CIE XYZ, fitted by least squares over the 24 ColorChecker patches.
//!
//! A film with a camera sensor records, per sample, the camera's raw responses `∫ r̄(λ) L(λ) dλ` (and ḡ, b̄). As in
//! pbrt-v4 (`PixelSensor`), the curves are used as measured (not normalised), on the scale where a light of
//! luminance 1 has `∫ ȳ L dλ = 1`: with Prismatic's radiance (Y = ∫ ȳ L / ∫ ȳ), the raw response is
//! `∫ r̄ L dλ / ∫ ȳ`. [`CameraSensor::xyz_from_sensor_rgb`] is pbrt-v4's fit: each patch's camera RGB under the
//! sensor illuminant, divided by the illuminant's ḡ response, is mapped to the patch's XYZ under the output colour
//! space's illuminant, divided by that illuminant's Y and multiplied by the sensor illuminant's Y over its ḡ
//! response. A grey card under the sensor illuminant then comes out with the output white's chromaticity
//! (white balance) and its true luminance.

use std::sync::{Arc, OnceLock};

use crate::cmf::Observer;
use crate::color::{invert, Mat3};
use crate::spectrum::{PiecewiseLinear, Spectrum};
use crate::{tables, LAMBDA_MAX, LAMBDA_MIN};

/// A measured camera: its name (pbrt-v4's, e.g. `canon_eos_5d_mkiv`) and r̄, ḡ, b̄ (zero outside 380–720 nm).
#[derive(Clone, Debug, PartialEq)]
pub struct CameraSensor {
    /// pbrt-v4's sensor name.
    pub name: String,
    /// The red, green and blue spectral sensitivities (relative, as measured).
    pub curves: [Arc<PiecewiseLinear>; 3],
}

/// The least-squares fit of [`CameraSensor::xyz_from_sensor_rgb`] and how well it reproduces the 24 patches.
#[derive(Clone, Debug, PartialEq)]
pub struct SensorFit {
    /// XYZ = M · (camera r, g, b).
    pub matrix: Mat3,
    /// Each patch's camera RGB (normalised by the sensor illuminant's ḡ response), in patch order.
    pub camera_rgb: Vec<[f64; 3]>,
    /// Each patch's target XYZ, in patch order.
    pub target_xyz: Vec<[f64; 3]>,
    /// Root mean square over the patches of |M·rgb − xyz| (Euclidean in XYZ, white patch Y ≈ 0.9).
    pub rms_residual: f64,
}

fn camera_table() -> &'static (Vec<String>, Vec<CameraSensor>) {
    static CELL: OnceLock<(Vec<String>, Vec<CameraSensor>)> = OnceLock::new();
    CELL.get_or_init(|| {
        let t = tables::camera_sensors();
        let lambdas = t.column(&t.columns[0]);
        let mut names = Vec::new();
        let mut sensors = Vec::new();
        for col in &t.columns[1..] {
            let Some(name) = col.strip_suffix("_r") else { continue };
            let curve = |c: &str| {
                let values = t.column(&format!("{name}_{c}"));
                Arc::new(PiecewiseLinear::new(lambdas.clone(), values).expect("embedded sensor table is well formed"))
            };
            names.push(name.to_string());
            sensors.push(CameraSensor { name: name.to_string(), curves: [curve("r"), curve("g"), curve("b")] });
        }
        (names, sensors)
    })
}

/// The 24 ColorChecker reflectances (BabelColor average, 380–730 nm at 10 nm; zero outside), in chart order.
pub fn colorchecker_patches() -> &'static [(String, Arc<PiecewiseLinear>)] {
    static CELL: OnceLock<Vec<(String, Arc<PiecewiseLinear>)>> = OnceLock::new();
    CELL.get_or_init(|| {
        let t = tables::colorchecker();
        let lambdas = t.column(&t.columns[0]);
        t.columns[1..]
            .iter()
            .map(|c| {
                let r = PiecewiseLinear::new(lambdas.clone(), t.column(c)).expect("embedded chart is well formed");
                (c.clone(), Arc::new(r))
            })
            .collect()
    })
}

/// Σ f(λ) over 360–830 nm at 1 nm (pbrt-v4's `InnerProduct` and `ProjectReflectance` sum the same way).
fn sum_1nm(f: impl Fn(f64) -> f64) -> f64 {
    let n = (LAMBDA_MAX - LAMBDA_MIN) as usize;
    (0..=n).map(|i| f(LAMBDA_MIN + i as f64)).sum()
}

impl CameraSensor {
    /// The names of every measured sensor, in the data's order.
    pub fn names() -> &'static [String] {
        &camera_table().0
    }

    /// The sensor called `name` (pbrt-v4's spelling), or `None`.
    pub fn by_name(name: &str) -> Option<&'static CameraSensor> {
        camera_table().1.iter().find(|s| s.name == name)
    }

    /// The three sensitivities at `lambda_nm`.
    #[inline]
    pub fn response(&self, lambda_nm: f64) -> [f64; 3] {
        [self.curves[0].eval(lambda_nm), self.curves[1].eval(lambda_nm), self.curves[2].eval(lambda_nm)]
    }

    /// pbrt-v4's `XYZFromSensorRGB` for this camera white-balanced for `sensor_illuminant`, with `output_white` the
    /// output colour space's illuminant (D65 for sRGB): the least-squares 3×3 matrix over the 24 ColorChecker
    /// patches (`PixelSensor`'s constructor). `None` if the normal equations are singular.
    pub fn xyz_from_sensor_rgb(&self, sensor_illuminant: &Spectrum, output_white: &Spectrum) -> Option<SensorFit> {
        let obs = Observer::Cie1931;
        let g_white = sum_1nm(|l| self.curves[1].eval(l) * sensor_illuminant.eval(l));
        let y_white = sum_1nm(|l| obs.xyz_bar(l)[1] * sensor_illuminant.eval(l));
        let y_out = sum_1nm(|l| obs.xyz_bar(l)[1] * output_white.eval(l));
        if !(g_white > 0.0 && y_white > 0.0 && y_out > 0.0) {
            return None;
        }
        let mut camera_rgb = Vec::with_capacity(24);
        let mut target_xyz = Vec::with_capacity(24);
        for (_, r) in colorchecker_patches() {
            let rgb: [f64; 3] = std::array::from_fn(|c| {
                sum_1nm(|l| self.curves[c].eval(l) * r.eval(l) * sensor_illuminant.eval(l)) / g_white
            });
            let xyz: [f64; 3] = std::array::from_fn(|c| {
                sum_1nm(|l| obs.xyz_bar(l)[c] * r.eval(l) * output_white.eval(l)) / y_out * (y_white / g_white)
            });
            camera_rgb.push(rgb);
            target_xyz.push(xyz);
        }
        // Normal equations of min Σᵢ |M·aᵢ − bᵢ|²: M = (Σ bᵢ aᵢᵀ)(Σ aᵢ aᵢᵀ)⁻¹.
        let mut ata = [[0.0; 3]; 3];
        let mut bta = [[0.0; 3]; 3];
        for (a, b) in camera_rgb.iter().zip(&target_xyz) {
            for i in 0..3 {
                for j in 0..3 {
                    ata[i][j] += a[i] * a[j];
                    bta[i][j] += b[i] * a[j];
                }
            }
        }
        let inv = invert(&ata)?;
        let matrix: Mat3 = crate::color::mul_mat(&bta, &inv);
        let sq: f64 = camera_rgb
            .iter()
            .zip(&target_xyz)
            .map(|(a, b)| {
                let m = crate::color::mul_mat_vec(&matrix, *a);
                (0..3).map(|c| (m[c] - b[c]).powi(2)).sum::<f64>()
            })
            .sum();
        Some(SensorFit { matrix, camera_rgb, target_xyz, rms_residual: (sq / 24.0).sqrt() })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_hold_pbrt_v4_sensors_and_the_babelcolor_chart() {
        assert_eq!(CameraSensor::names().len(), 17);
        let s = CameraSensor::by_name("canon_eos_5d_mkiv").expect("known sensor");
        assert!(CameraSensor::by_name("canon_eos_5d_mkv").is_none());
        // Zero outside the measured 380–720 nm, positive inside.
        assert_eq!(s.response(370.0), [0.0; 3]);
        assert_eq!(s.response(730.0), [0.0; 3]);
        assert!(s.response(550.0)[1] > s.response(550.0)[0] && s.response(450.0)[2] > s.response(450.0)[0]);
        let chart = colorchecker_patches();
        assert_eq!(chart.len(), 24);
        // Pascale's BabelColor average as pbrt-v4 ships it: dark skin starts 0.055, 0.058, 0.061; white 0.189 at 380.
        assert_eq!((chart[0].1.eval(380.0), chart[0].1.eval(390.0), chart[0].1.eval(400.0)), (0.055, 0.058, 0.061));
        assert_eq!((chart[18].0.as_str(), chart[18].1.eval(380.0)), ("white_9_5", 0.189));
    }

    #[test]
    fn fits_reproduce_the_colorchecker_within_their_residual() {
        // Three sensitivities cannot match the observer exactly, so 24 patches leave a residual: at 6500 K the RMS
        // over the patches of |M·rgb − xyz| is 0.012–0.019 for the 17 cameras (canon_eos_5d_mkiv 0.0129, worst
        // component 0.020; the white patch has Y ≈ 0.9), and 0.024–0.034 white-balanced for 3000 K.
        let d65 = crate::named::illuminant("stdillum-D65").unwrap();
        let d65_xy = Observer::Cie1931.spectrum_to_xyz(&d65).chromaticity();
        for (kelvin, bound) in [(6500.0, 0.02), (3000.0, 0.035)] {
            let illuminant = crate::daylight::white_balance_illuminant(kelvin).unwrap();
            for name in CameraSensor::names() {
                let fit = CameraSensor::by_name(name).unwrap().xyz_from_sensor_rgb(&illuminant, &d65).unwrap();
                assert!(fit.rms_residual < bound && fit.rms_residual > 0.005, "{name} {kelvin}: {}", fit.rms_residual);
                // Least squares: the residuals are orthogonal to the camera RGB (the normal equations hold).
                let mut normal = [[0.0f64; 3]; 3];
                for (a, b) in fit.camera_rgb.iter().zip(&fit.target_xyz) {
                    let m = crate::color::mul_mat_vec(&fit.matrix, *a);
                    for i in 0..3 {
                        for j in 0..3 {
                            normal[i][j] += (m[i] - b[i]) * a[j];
                        }
                    }
                }
                assert!(normal.iter().flatten().all(|v| v.abs() < 1e-12), "{name}: {normal:?}");
                // Every patch within 2.5 residuals per component; the neutral patches (19–24), whose targets lie
                // within 0.006 of D65's chromaticity in x and y (the chart's white is not flat: measured 0.0055),
                // come out within 0.006 of their targets' (measured worst 0.0049): white balance.
                for (i, (a, b)) in fit.camera_rgb.iter().zip(&fit.target_xyz).enumerate() {
                    let m = crate::color::mul_mat_vec(&fit.matrix, *a);
                    for c in 0..3 {
                        assert!((m[c] - b[c]).abs() < 2.5 * bound, "{name} {kelvin} patch {i}: {m:?} vs {b:?}");
                    }
                    if i >= 18 {
                        let xy = crate::Xyz::from_array(m).chromaticity();
                        let t = crate::Xyz::from_array(*b).chromaticity();
                        assert!((xy[0] - t[0]).abs() < 6e-3 && (xy[1] - t[1]).abs() < 6e-3, "{name} {kelvin} {i}");
                        assert!((t[0] - d65_xy[0]).abs() < 6e-3 && (t[1] - d65_xy[1]).abs() < 6e-3, "{i}");
                    }
                }
            }
        }
        let mkiv = CameraSensor::by_name("canon_eos_5d_mkiv").unwrap();
        let fit = mkiv.xyz_from_sensor_rgb(&crate::daylight::white_balance_illuminant(6500.0).unwrap(), &d65);
        assert!((fit.unwrap().rms_residual - 0.0129).abs() < 5e-4);
    }
}

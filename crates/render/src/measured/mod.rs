//! Measured BRDFs of the RGL material database: pbrt-v4's `MeasuredBxDF` (`Material "measured"`), after Dupuy &
//! Jakob 2018, "An Adaptive Parameterization for Efficient Material Acquisition and Rendering".
//!
//! A file ([`tensor`]) holds, for the isotropic or anisotropic material it describes:
//!
//! - `ndf`: the microfacet distribution D(ωm) on a grid over (u_θ, u_φ), with θ = u_θ²·π/2 and φ = (2u_φ − 1)π;
//! - `sigma`: the projected microfacet area σ(ωi) = ∫ D(ωm)⟨ωi, ωm⟩⁺ dωm on the same kind of grid;
//! - `vndf`: per tabulated incident direction (`phi_i` × `theta_i`), the density of visible normals over (u_θ, u_φ)
//!   of ωm (φm relative to φi when the material is isotropic), from which a [`warp::Warp2D`] maps a "sample
//!   space" square onto the normals;
//! - `spectra` (with `wavelengths` in nm) or `rgb`: per incident direction and wavelength (or channel), the
//!   reflectance ρ tabulated on a regular grid of that sample space, so that f(ωi, ωo) = ρ(s)·D(ωm) /
//!   (4 σ(ωi) cos θo) where s is the sample-space point of ωm = (ωi + ωo)/‖ωi + ωo‖ (if the `jacobian` flag is 0,
//!   ρ already is f·cos θo);
//! - `luminance`: per incident direction, a density over the sample space proportional to ρ's luminance, sampled
//!   before the VNDF warp.
//!
//! Sampling draws a sample-space point from `luminance`, warps it to a normal with `vndf` and reflects; the density
//! is the product of both warps' densities over the Jacobians from (u_θ, u_φ) to solid angle (2π²u_θ sin θm) and
//! from normals to reflected directions (4⟨ωi, ωm⟩).
//!
//! As in pbrt-v4 (after its fix of f and PDF, pull request 215), the table's incident direction is the path's `wo`
//! for camera paths, in [`MeasuredBrdf::f`], [`MeasuredBrdf::pdf`] and [`MeasuredBrdf::sample`] alike; a light path
//! evaluates the same function with the roles swapped, so light tracing and path tracing estimate the same image
//! even for a table that is not exactly reciprocal. The BRDF is two-sided (directions below the surface are
//! mirrored), as pbrt-v4's.

pub mod tensor;
pub mod warp;

use std::f32::consts::PI;
use std::path::Path;

use std::sync::OnceLock;

use glam::{Vec2, Vec3};
use spectral::rgb_uplift::RgbUnboundedSpectrum;
use spectral::{SampledSpectrum, N_WAVELENGTHS};

use crate::error::invalid_data as bad;
use crate::RenderError;
use tensor::{DType, TensorFile};
use warp::{Warp2D, WarpSample};

/// u_θ of an elevation: θ = u²·π/2.
fn theta2u(theta: f32) -> f32 {
    (theta * (2.0 / PI)).max(0.0).sqrt()
}

/// u_φ of an azimuth in [−π, π]: φ = (2u − 1)π.
fn phi2u(phi: f32) -> f32 {
    (phi + PI) * (0.5 / PI)
}

fn u2theta(u: f32) -> f32 {
    u * u * (PI / 2.0)
}

fn u2phi(u: f32) -> f32 {
    (2.0 * u - 1.0) * PI
}

/// The elevation of a unit vector, from its distance to the pole (accurate near the pole, where acos is not).
fn elevation(d: Vec3) -> f32 {
    let dist = (d.x * d.x + d.y * d.y + (d.z - 1.0) * (d.z - 1.0)).sqrt();
    2.0 * (0.5 * dist).clamp(-1.0, 1.0).asin()
}

/// What the reflectance table is tabulated over.
#[derive(Clone, Debug)]
enum Channels {
    /// Wavelengths in nm (the `spectra` field).
    Spectral(Vec<f32>),
    /// Linear sRGB red, green and blue (the `rgb` field), uplifted to a spectrum per evaluation.
    Rgb,
}

/// A measured BRDF read from a tensor file, shared by every hit on surfaces of its material.
#[derive(Clone)]
pub struct MeasuredBrdf {
    description: String,
    ndf: Warp2D,
    sigma: Warp2D,
    vndf: Warp2D,
    luminance: Warp2D,
    reflectance: Warp2D,
    channels: Channels,
    isotropic: bool,
    jacobian: bool,
    /// The tabulated wavelengths (nm) or RGB channel indices, the reflectance table's third parameter.
    channel_values: Vec<f32>,
    /// Directional albedo at normal incidence per tabulated wavelength or channel (for albedo AOVs), estimated on
    /// first use: only renders that write an albedo pay for it (real files tabulate about 200 wavelengths).
    albedo: OnceLock<Vec<f32>>,
}

impl std::fmt::Debug for MeasuredBrdf {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let channels = match &self.channels {
            Channels::Spectral(w) => format!("{} wavelengths", w.len()),
            Channels::Rgb => "rgb".to_owned(),
        };
        write!(
            f,
            "MeasuredBrdf {{ {:?}, {}, vndf {:?}, {channels} }}",
            self.description,
            if self.isotropic { "isotropic" } else { "anisotropic" },
            self.vndf
        )
    }
}

/// The table coordinates of one incident direction and one normal.
struct Coords {
    params: [f32; 2],
    u_wi: [f32; 2],
    u_m: [f32; 2],
}

impl MeasuredBrdf {
    /// Reads and checks a tensor file; the error names the file.
    pub fn read(path: &Path) -> Result<MeasuredBrdf, RenderError> {
        MeasuredBrdf::from_tensor(&TensorFile::read(path)?).map_err(|e| e.in_file(path))
    }

    /// Builds the BRDF from a tensor file's fields, checking their types and shapes against each other as pbrt-v4
    /// and Mitsuba do (pbrt-v4 reads only `spectra`; Mitsuba also reads `rgb` files, which have no `wavelengths`).
    pub fn from_tensor(t: &TensorFile) -> Result<MeasuredBrdf, RenderError> {
        let field = |name: &str| t.field(name).ok_or_else(|| bad(format!("the field '{name}' is missing")));
        let floats = |name: &str, rank: usize| -> Result<(Vec<f32>, Vec<usize>), RenderError> {
            let f = field(name)?;
            if f.shape.len() != rank {
                return Err(bad(format!("field '{name}' has rank {}, expected {rank}", f.shape.len())));
            }
            Ok((t.f32s(f)?, f.shape.clone()))
        };
        let description = field("description")?;
        if description.dtype != DType::UInt8 || description.shape.len() != 1 {
            return Err(bad("field 'description' must be a 1-D uint8 array"));
        }
        let description = String::from_utf8_lossy(t.bytes_of(description)).trim_end_matches('\0').to_owned();
        let jacobian = field("jacobian")?;
        if jacobian.dtype != DType::UInt8 || jacobian.shape != [1] {
            return Err(bad("field 'jacobian' must be a single uint8"));
        }
        let jacobian = t.bytes_of(jacobian)[0] != 0;
        let (theta_i, _) = floats("theta_i", 1)?;
        let (phi_i, _) = floats("phi_i", 1)?;
        let (ndf, ndf_shape) = floats("ndf", 2)?;
        let (sigma, sigma_shape) = floats("sigma", 2)?;
        let (vndf, vndf_shape) = floats("vndf", 4)?;
        let (luminance, lum_shape) = floats("luminance", 4)?;
        let (refl_name, channels) = match t.field("wavelengths") {
            Some(_) => ("spectra", Channels::Spectral(floats("wavelengths", 1)?.0)),
            None if t.field("rgb").is_some() => ("rgb", Channels::Rgb),
            None => return Err(bad("the fields 'spectra' and 'wavelengths' (or 'rgb') are missing")),
        };
        let (refl, refl_shape) = floats(refl_name, 5)?;
        let (n_phi, n_theta) = (phi_i.len(), theta_i.len());
        let shape_err = |name: &str, shape: &[usize], expected: String| {
            Err(bad(format!("field '{name}' has shape {shape:?}, expected {expected}")))
        };
        if vndf_shape[..2] != [n_phi, n_theta] {
            return shape_err("vndf", &vndf_shape, format!("[{n_phi}, {n_theta}, …] (phi_i × theta_i × …)"));
        }
        if lum_shape[..2] != [n_phi, n_theta] || lum_shape[2] != lum_shape[3] {
            return shape_err("luminance", &lum_shape, format!("[{n_phi}, {n_theta}, n, n]"));
        }
        let n_channels = match &channels {
            Channels::Spectral(w) => w.len(),
            Channels::Rgb => 3,
        };
        if refl_shape[..3] != [n_phi, n_theta, n_channels] || refl_shape[3..] != lum_shape[2..] {
            let n = lum_shape[2];
            return shape_err(refl_name, &refl_shape, format!("[{n_phi}, {n_theta}, {n_channels}, {n}, {n}]"));
        }
        let isotropic = n_phi <= 2;
        if !isotropic {
            // pbrt-v4 refuses anisotropic tables that cover a half or a quarter of the azimuths (Mitsuba mirrors them).
            let span = phi_i[n_phi - 1] - phi_i[0];
            let reduction = (2.0 * PI / span).round();
            if reduction != 1.0 {
                return Err(bad(format!(
                    "'phi_i' covers 1/{reduction} of the azimuths; only full tables are supported"
                )));
            }
        }
        let params: [&[f32]; 2] = [&phi_i, &theta_i];
        let channel_values: Vec<f32> = match &channels {
            Channels::Spectral(w) => w.clone(),
            Channels::Rgb => vec![0.0, 1.0, 2.0],
        };
        let brdf = MeasuredBrdf {
            description,
            ndf: Warp2D::new("ndf", &ndf, ndf_shape[1], ndf_shape[0], &[], false)?,
            sigma: Warp2D::new("sigma", &sigma, sigma_shape[1], sigma_shape[0], &[], false)?,
            vndf: Warp2D::new("vndf", &vndf, vndf_shape[3], vndf_shape[2], &params, true)?,
            luminance: Warp2D::new("luminance", &luminance, lum_shape[3], lum_shape[2], &params, true)?,
            reflectance: Warp2D::new(
                refl_name,
                &refl,
                refl_shape[4],
                refl_shape[3],
                &[&phi_i, &theta_i, &channel_values],
                false,
            )?,
            channels,
            isotropic,
            jacobian,
            channel_values,
            albedo: OnceLock::new(),
        };
        if sigma.iter().any(|&v| v <= 0.0) || ndf.iter().any(|&v| v < 0.0) {
            return Err(bad("'sigma' must be positive and 'ndf' not negative"));
        }
        Ok(brdf)
    }

    /// True if the material is isotropic (at most two tabulated incident azimuths).
    #[cfg(test)]
    pub fn is_isotropic(&self) -> bool {
        self.isotropic
    }

    /// True if the reflectance is tabulated in RGB rather than per wavelength.
    #[cfg(test)]
    pub fn is_rgb(&self) -> bool {
        matches!(self.channels, Channels::Rgb)
    }

    fn coords(&self, wi: Vec3, wm: Vec3) -> Coords {
        let (theta_i, phi_i) = (elevation(wi), wi.y.atan2(wi.x));
        let (theta_m, phi_m) = (elevation(wm), wm.y.atan2(wm.x));
        let mut u_phi = phi2u(if self.isotropic { phi_m - phi_i } else { phi_m });
        u_phi -= u_phi.floor();
        Coords { params: [phi_i, theta_i], u_wi: [theta2u(theta_i), phi2u(phi_i)], u_m: [theta2u(theta_m), u_phi] }
    }

    /// The reflectance at sample-space point `s` for each of `lambda` (nm), clamped at 0 as pbrt-v4 does.
    fn rho(&self, s: [f32; 2], params: [f32; 2], lambda: &[f32; N_WAVELENGTHS]) -> SampledSpectrum {
        let at = |c: f32| self.reflectance.eval(s, &[params[0], params[1], c]).max(0.0);
        match &self.channels {
            Channels::Spectral(_) => SampledSpectrum(lambda.map(at)),
            Channels::Rgb => {
                let rgb = [0.0, 1.0, 2.0].map(|c| at(c) as f64);
                match RgbUnboundedSpectrum::new(rgb) {
                    Ok(s) => SampledSpectrum(lambda.map(|l| s.eval(l as f64) as f32)),
                    Err(_) => SampledSpectrum::zero(),
                }
            }
        }
    }

    /// f·cos θo for the table's incident direction `wi` and the other direction `wo`, both above the surface,
    /// from the sample-space point `s` of their half vector.
    fn f_cos(&self, c: &Coords, s: [f32; 2], lambda: &[f32; N_WAVELENGTHS]) -> SampledSpectrum {
        let rho = self.rho(s, c.params, lambda);
        if !self.jacobian {
            return rho;
        }
        let sigma = self.sigma.eval(c.u_wi, &[]);
        let d = self.ndf.eval(c.u_m, &[]);
        let k = d / (4.0 * sigma);
        if k.is_finite() && k > 0.0 {
            rho * k
        } else {
            SampledSpectrum::zero()
        }
    }

    /// The BRDF for table incident direction `wi` and outgoing `wo` at wavelengths `lambda` (nm). Both directions
    /// must be on the same side; below the surface both are mirrored.
    pub fn f(&self, wi: Vec3, wo: Vec3, lambda: &[f32; N_WAVELENGTHS]) -> SampledSpectrum {
        if wi.z * wo.z <= 0.0 {
            return SampledSpectrum::zero();
        }
        let (wi, wo) = if wi.z < 0.0 { (-wi, -wo) } else { (wi, wo) };
        let Some(wm) = (wi + wo).try_normalize() else { return SampledSpectrum::zero() };
        let c = self.coords(wi, wm);
        let Some(s) = self.vndf.invert(c.u_m, &c.params) else { return SampledSpectrum::zero() };
        self.f_cos(&c, s.p, lambda) * (1.0 / wo.z)
    }

    /// [`MeasuredBrdf::f`] and [`MeasuredBrdf::pdf`] of the same pair at once, with one inversion of the VNDF warp
    /// (the costly part of each): the same values bit for bit.
    pub fn f_pdf(&self, wi: Vec3, wo: Vec3, lambda: &[f32; N_WAVELENGTHS]) -> (SampledSpectrum, f32) {
        if wi.z * wo.z <= 0.0 {
            return (SampledSpectrum::zero(), 0.0);
        }
        let (wi, wo) = if wi.z < 0.0 { (-wi, -wo) } else { (wi, wo) };
        let Some(wm) = (wi + wo).try_normalize() else { return (SampledSpectrum::zero(), 0.0) };
        let c = self.coords(wi, wm);
        let Some(s) = self.vndf.invert(c.u_m, &c.params) else { return (SampledSpectrum::zero(), 0.0) };
        let f = self.f_cos(&c, s.p, lambda) * (1.0 / wo.z);
        (f, self.pdf_at(&c, &s, wi, wm))
    }

    /// The density of [`MeasuredBrdf::sample`] drawing `wo` for table incident direction `wi` (solid angle).
    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z * wo.z <= 0.0 {
            return 0.0;
        }
        let (wi, wo) = if wi.z < 0.0 { (-wi, -wo) } else { (wi, wo) };
        let Some(wm) = (wi + wo).try_normalize() else { return 0.0 };
        let c = self.coords(wi, wm);
        let Some(s) = self.vndf.invert(c.u_m, &c.params) else { return 0.0 };
        self.pdf_at(&c, &s, wi, wm)
    }

    /// The density for the half vector `wm` of `wi` at coordinates `c`, whose VNDF inversion is `s`.
    fn pdf_at(&self, c: &Coords, s: &WarpSample, wi: Vec3, wm: Vec3) -> f32 {
        let lum = self.luminance.eval(s.p, &c.params);
        let sin_m = (wm.x * wm.x + wm.y * wm.y).sqrt();
        let jac = (2.0 * PI * PI * c.u_m[0] * sin_m).max(1e-6) * 4.0 * wi.dot(wm);
        let pdf = s.pdf * lum / jac;
        if pdf.is_finite() && pdf > 0.0 {
            pdf
        } else {
            0.0
        }
    }

    /// Draws an outgoing direction for table incident direction `wi` from the uniform point `u`: returns it with
    /// f·cos θo (for `wi` as the table's incident direction, at `lambda`) and its density.
    pub fn sample(&self, wi: Vec3, u: Vec2, lambda: &[f32; N_WAVELENGTHS]) -> Option<(Vec3, SampledSpectrum, f32)> {
        if wi.z == 0.0 {
            return None;
        }
        let flip = wi.z < 0.0;
        let wi = if flip { -wi } else { wi };
        let (theta_i, phi_i) = (elevation(wi), wi.y.atan2(wi.x));
        let params = [phi_i, theta_i];
        // The luminance first (the second uniform number along its x), then the VNDF warp (Mitsuba's order).
        let lum = self.luminance.sample([u.y, u.x], &params)?;
        let m = self.vndf.sample(lum.p, &params)?;
        let u_m = m.p;
        let theta_m = u2theta(u_m[0]);
        let phi_m = u2phi(u_m[1]) + if self.isotropic { phi_i } else { 0.0 };
        let (sin_t, cos_t) = theta_m.sin_cos();
        let wm = Vec3::new(sin_t * phi_m.cos(), sin_t * phi_m.sin(), cos_t);
        let cos_im = wi.dot(wm);
        if cos_im <= 0.0 {
            return None;
        }
        let wo = wm * (2.0 * cos_im) - wi;
        if wo.z <= 0.0 {
            return None;
        }
        let c = Coords { params, u_wi: [theta2u(theta_i), phi2u(phi_i)], u_m };
        let f_cos = self.f_cos(&c, lum.p, lambda);
        let jac = (2.0 * PI * PI * u_m[0] * sin_t).max(1e-6) * 4.0 * cos_im;
        let pdf = m.pdf * lum.pdf / jac;
        if !(pdf.is_finite() && pdf > 0.0) {
            return None;
        }
        Some((if flip { -wo } else { wo }, f_cos, pdf))
    }

    /// The directional albedo at normal incidence per tabulated channel, estimated with 32 × 32 stratified samples
    /// of the BRDF's own sampling.
    fn normal_albedo(&self, channels: &[f32]) -> Vec<f32> {
        const N: usize = 32;
        let mut sum = vec![0.0f64; channels.len()];
        for j in 0..N {
            for i in 0..N {
                let u = Vec2::new((i as f32 + 0.5) / N as f32, (j as f32 + 0.5) / N as f32);
                let params = [0.0, 0.0];
                let Some(lum) = self.luminance.sample([u.y, u.x], &params) else { continue };
                let Some(m) = self.vndf.sample(lum.p, &params) else { continue };
                let theta_m = u2theta(m.p[0]);
                let sin_t = theta_m.sin();
                // wi = z: the Jacobian's ⟨wi, wm⟩ is cos θm.
                let jac = (2.0 * PI * PI * m.p[0] * sin_t).max(1e-6) * 4.0 * theta_m.cos();
                let pdf = m.pdf * lum.pdf / jac;
                if !(pdf > 0.0 && pdf.is_finite()) || (2.0 * theta_m).cos() <= 0.0 {
                    continue;
                }
                let c = Coords { params, u_wi: [0.0, 0.5], u_m: m.p };
                for (k, &ch) in channels.iter().enumerate() {
                    let mut rho = self.reflectance.eval(lum.p, &[0.0, 0.0, ch]).max(0.0);
                    if self.jacobian {
                        rho *= self.ndf.eval(c.u_m, &[]) / (4.0 * self.sigma.eval(c.u_wi, &[]));
                    }
                    sum[k] += (rho / pdf) as f64;
                }
            }
        }
        sum.iter().map(|s| (s / (N * N) as f64) as f32).collect()
    }

    /// The directional albedo at normal incidence at `lambda` (nm), for albedo AOVs.
    pub fn albedo_hint(&self, lambda: &[f32; N_WAVELENGTHS]) -> SampledSpectrum {
        let albedo = self.albedo.get_or_init(|| self.normal_albedo(&self.channel_values));
        match &self.channels {
            Channels::Spectral(w) => SampledSpectrum(lambda.map(|l| {
                let i = w.partition_point(|&x| x <= l).clamp(1, w.len().max(2) - 1);
                if w.len() == 1 {
                    return albedo[0];
                }
                let t = ((l - w[i - 1]) / (w[i] - w[i - 1])).clamp(0.0, 1.0);
                albedo[i - 1] + t * (albedo[i] - albedo[i - 1])
            })),
            Channels::Rgb => {
                let rgb = [0, 1, 2].map(|k| albedo[k].max(0.0) as f64);
                match RgbUnboundedSpectrum::new(rgb) {
                    Ok(s) => SampledSpectrum(lambda.map(|l| s.eval(l as f64) as f32)),
                    Err(_) => SampledSpectrum::zero(),
                }
            }
        }
    }
}

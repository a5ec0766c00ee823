//! Test support: a writer of RGL tensor files (the format of pbrt-v4's `measured` material) and an analytic
//! isotropic GGX (Trowbridge–Reitz) microfacet BRDF tabulated into one, so that the measured BRDF can be checked
//! against the model it was built from without the RGL database's files.
//!
//! The model is f(ωi, ωo) = F(⟨ωi, ωm⟩)·D(ωm)·G2(ωi, ωo)/(4 cos θi cos θo) with Smith's height-correlated G2 =
//! 1/(1 + Λ(ωi) + Λ(ωo)) (pbrt-v4's `ConductorBxDF`), F a conductor's Fresnel reflectance, 1 (a white, lossless
//! facet) or 1 times an RGB colour. A tensor file writes f as ρ(ωi, s)·D(ωm)/(4 σ(ωi) cos θo), where s is the
//! sample-space point the VNDF warp maps to ωm and σ(ωi) = cos θi·(1 + Λ(ωi)) is the projected area (Smith), so the
//! table holds ρ = F·G2·(1 + Λ(ωi)), exactly representable up to interpolation.

#![allow(dead_code)]

use std::f64::consts::PI;

use glam::DVec3;

// The includer provides it: the crate's tests from `crate::measured`, the BSDF benchmark from `render::internals`.
use super::Warp2D;

/// One field to write.
#[derive(Clone, Debug)]
pub struct OutField {
    /// Its name.
    pub name: String,
    /// Its type code (1 uint8, 10 float32, 11 float64).
    pub dtype: u8,
    /// Its extents.
    pub shape: Vec<u64>,
    /// Its values' bytes.
    pub data: Vec<u8>,
}

/// A float32 field of `shape`.
pub fn f32_field(name: &str, shape: &[usize], values: &[f32]) -> OutField {
    assert_eq!(shape.iter().product::<usize>(), values.len(), "{name}");
    OutField {
        name: name.into(),
        dtype: 10,
        shape: shape.iter().map(|&s| s as u64).collect(),
        data: values.iter().flat_map(|v| v.to_le_bytes()).collect(),
    }
}

/// A float64 field of `shape`.
pub fn f64_field(name: &str, shape: &[usize], values: &[f64]) -> OutField {
    OutField {
        name: name.into(),
        dtype: 11,
        shape: shape.iter().map(|&s| s as u64).collect(),
        data: values.iter().flat_map(|v| v.to_le_bytes()).collect(),
    }
}

/// A uint8 field of `shape`.
pub fn u8_field(name: &str, shape: &[usize], values: &[u8]) -> OutField {
    OutField { name: name.into(), dtype: 1, shape: shape.iter().map(|&s| s as u64).collect(), data: values.to_vec() }
}

/// The bytes of a tensor file holding `fields`: the header, then each field's data in order.
pub fn write_tensor(fields: &[OutField]) -> Vec<u8> {
    let header: usize = 18 + fields.iter().map(|f| 2 + f.name.len() + 2 + 1 + 8 + 8 * f.shape.len()).sum::<usize>();
    let mut out = b"tensor_file\0".to_vec();
    out.extend([1u8, 0]);
    out.extend((fields.len() as u32).to_le_bytes());
    let mut offset = header as u64;
    for f in fields {
        out.extend((f.name.len() as u16).to_le_bytes());
        out.extend(f.name.as_bytes());
        out.extend((f.shape.len() as u16).to_le_bytes());
        out.push(f.dtype);
        out.extend(offset.to_le_bytes());
        for s in &f.shape {
            out.extend(s.to_le_bytes());
        }
        offset += f.data.len() as u64;
    }
    assert_eq!(out.len(), header);
    for f in fields {
        out.extend(&f.data);
    }
    out
}

pub fn theta2u(theta: f64) -> f64 {
    (theta * 2.0 / PI).sqrt()
}
pub fn u2theta(u: f64) -> f64 {
    u * u * PI / 2.0
}
pub fn u2phi(u: f64) -> f64 {
    (2.0 * u - 1.0) * PI
}

/// The unit vector of elevation θ and azimuth φ.
pub fn dir(theta: f64, phi: f64) -> DVec3 {
    DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
}

/// What multiplies the microfacet terms.
#[derive(Clone, Debug)]
pub enum Facet {
    /// A conductor: η and k at each of the file's wavelengths.
    Conductor { eta: Vec<f64>, k: Vec<f64> },
    /// F = 1 at every wavelength (the table still has its wavelengths).
    White,
    /// F = 1 times a linear sRGB colour, written as an `rgb` file (no wavelengths).
    Rgb([f64; 3]),
}

/// Table resolutions.
#[derive(Clone, Copy, Debug)]
pub struct Resolution {
    /// Tabulated incident elevations, evenly spaced from 0 to `theta_max`.
    pub theta_i: usize,
    /// The largest tabulated incident elevation (radians).
    pub theta_max: f64,
    /// `ndf` and `sigma`: rows (φ) and columns (θ).
    pub ndf: (usize, usize),
    /// `vndf`: rows (φm) and columns (θm).
    pub vndf: (usize, usize),
    /// The sample space's grid (`luminance`, `spectra`), n × n.
    pub sample: usize,
    /// Tabulated incident azimuths: 0 for an isotropic file (`phi_i` = [0], normals' azimuths relative to it),
    /// otherwise that many evenly spaced from −π to π (an anisotropic file: absolute azimuths).
    pub phi_i: usize,
}

impl Resolution {
    /// The resolutions of the accuracy tests.
    pub const FINE: Resolution =
        Resolution { theta_i: 24, theta_max: 89.0 * PI / 180.0, ndf: (8, 128), vndf: (64, 96), sample: 48, phi_i: 0 };
    /// A small file for the error tests.
    pub const TINY: Resolution =
        Resolution { theta_i: 3, theta_max: 80.0 * PI / 180.0, ndf: (2, 4), vndf: (3, 4), sample: 3, phi_i: 0 };
}

/// An isotropic GGX BRDF.
#[derive(Clone, Debug)]
pub struct Ggx {
    /// Trowbridge–Reitz α.
    pub alpha: f64,
    /// The file's wavelengths (nm); ignored for an RGB file.
    pub wavelengths: Vec<f32>,
    /// The facets' reflectance.
    pub facet: Facet,
}

impl Ggx {
    /// D(ωm) = 1/(π α² cos⁴θm (1 + tan²θm/α²)²).
    pub fn d(&self, m: DVec3) -> f64 {
        if m.z <= 0.0 {
            return 0.0;
        }
        let c2 = m.z * m.z;
        let t2 = (1.0 - c2).max(0.0) / c2;
        let a2 = self.alpha * self.alpha;
        1.0 / (PI * a2 * c2 * c2 * (1.0 + t2 / a2).powi(2))
    }

    /// Smith's Λ(ω) = (√(1 + α² tan²θ) − 1)/2.
    pub fn lambda(&self, w: DVec3) -> f64 {
        let c2 = w.z * w.z;
        let t2 = (1.0 - c2).max(0.0) / c2;
        ((1.0 + self.alpha * self.alpha * t2).sqrt() - 1.0) / 2.0
    }

    /// The projected microfacet area σ(ω) = cos θ (1 + Λ(ω)).
    pub fn sigma(&self, w: DVec3) -> f64 {
        w.z * (1.0 + self.lambda(w))
    }

    /// F at wavelength slot `c` (a wavelength of the file, or an RGB channel).
    pub fn fresnel(&self, cos: f64, c: usize) -> f64 {
        match &self.facet {
            Facet::Conductor { eta, k } => optics::fresnel_conductor(cos.abs(), eta[c], k[c]),
            Facet::White => 1.0,
            Facet::Rgb(rgb) => rgb[c],
        }
    }

    /// Number of wavelengths or channels.
    pub fn channels(&self) -> usize {
        match self.facet {
            Facet::Rgb(_) => 3,
            Facet::Conductor { .. } | Facet::White => self.wavelengths.len(),
        }
    }

    /// The BRDF at slot `c`.
    pub fn f(&self, wi: DVec3, wo: DVec3, c: usize) -> f64 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let m = (wi + wo).normalize();
        let g2 = 1.0 / (1.0 + self.lambda(wi) + self.lambda(wo));
        self.fresnel(wi.dot(m), c) * self.d(m) * g2 / (4.0 * wi.z * wo.z)
    }

    /// The directional albedo ∫ f cos θo dωo at slot `c` for incidence `wi`, by the midpoint rule on `n` × 4n
    /// cells of (θo, φo) (converged to better than 1e-4 for n = 400 and α ≥ 0.2).
    pub fn albedo(&self, wi: DVec3, c: usize, n: usize) -> f64 {
        let (dt, dp) = (PI / 2.0 / n as f64, 2.0 * PI / (4 * n) as f64);
        let mut sum = 0.0;
        for i in 0..n {
            let t = (i as f64 + 0.5) * dt;
            for j in 0..4 * n {
                let wo = dir(t, (j as f64 + 0.5) * dp);
                sum += self.f(wi, wo, c) * wo.z * t.sin();
            }
        }
        sum * dt * dp
    }

    /// The fields of the tensor file tabulating this BRDF at resolution `r`.
    pub fn fields(&self, r: Resolution) -> Vec<OutField> {
        let theta_i: Vec<f64> = (0..r.theta_i).map(|k| r.theta_max * k as f64 / (r.theta_i - 1) as f64).collect();
        let phi_i: Vec<f64> = match r.phi_i {
            0 => vec![0.0],
            n => (0..n).map(|k| -PI + 2.0 * PI * k as f64 / (n - 1) as f64).collect(),
        };
        let grid = |rows: usize, cols: usize, g: &dyn Fn(f64, f64) -> f64| -> Vec<f32> {
            let mut v = Vec::with_capacity(rows * cols);
            for y in 0..rows {
                for x in 0..cols {
                    v.push(g(x as f64 / (cols - 1) as f64, y as f64 / (rows - 1) as f64) as f32);
                }
            }
            v
        };
        let ndf = grid(r.ndf.0, r.ndf.1, &|ut, up| self.d(dir(u2theta(ut), u2phi(up))));
        let sigma = grid(r.ndf.0, r.ndf.1, &|ut, up| self.sigma(dir(u2theta(ut), u2phi(up))));
        let (n, nc) = (r.sample, self.channels());
        let slices = phi_i.len() * r.theta_i;
        let (mut vndf, mut refl, mut lum) = (vec![], vec![0.0f32; slices * nc * n * n], vec![]);
        for k in 0..slices {
            let (pi, ti) = (phi_i[k / r.theta_i], theta_i[k % r.theta_i]);
            let wi = dir(ti, pi);
            // Isotropic files tabulate the normals' azimuths relative to the incident one.
            let phi_m = |up: f64| u2phi(up) + if r.phi_i == 0 { pi } else { 0.0 };
            // The density of visible normals over (u_θ, u_φ): ⟨ωi, ωm⟩⁺ D(ωm) times dωm/du ∝ u_θ sin θm.
            let slice = grid(r.vndf.0, r.vndf.1, &|ut, up| {
                let m = dir(u2theta(ut), phi_m(up));
                wi.dot(m).max(0.0) * self.d(m) * ut * u2theta(ut).sin()
            });
            let warp = Warp2D::new("vndf", &slice, r.vndf.1, r.vndf.0, &[], true).unwrap();
            vndf.extend(&slice);
            // Each node of the sample space's grid is one normal, found by warping it.
            let mut lum_slice = vec![0.0f32; n * n];
            for y in 0..n {
                for x in 0..n {
                    let s = [x as f32 / (n - 1) as f32, y as f32 / (n - 1) as f32];
                    let um = warp.sample(s, &[]).unwrap().p;
                    let m = dir(u2theta(um[0] as f64), phi_m(um[1] as f64));
                    let wo = 2.0 * wi.dot(m) * m - wi;
                    let g = if wo.z > 0.0 && wi.dot(m) > 0.0 {
                        (1.0 + self.lambda(wi)) / (1.0 + self.lambda(wi) + self.lambda(wo))
                    } else {
                        0.0
                    };
                    let mut y_sum = 0.0;
                    for c in 0..nc {
                        let rho = self.fresnel(wi.dot(m), c) * g;
                        refl[((k * nc + c) * n + y) * n + x] = rho as f32;
                        y_sum += rho / nc as f64;
                    }
                    lum_slice[y * n + x] = y_sum as f32;
                }
            }
            lum.extend(lum_slice);
        }
        let theta_f: Vec<f32> = theta_i.iter().map(|&t| t as f32).collect();
        let phi_f: Vec<f32> = phi_i.iter().map(|&t| t as f32).collect();
        let np = phi_i.len();
        let description = b"GGX conductor written by the measured-material tests";
        let mut fields = vec![
            u8_field("description", &[description.len()], description),
            u8_field("jacobian", &[1], &[1]),
            f32_field("theta_i", &[r.theta_i], &theta_f),
            f32_field("phi_i", &[np], &phi_f),
            f32_field("ndf", &[r.ndf.0, r.ndf.1], &ndf),
            f32_field("sigma", &[r.ndf.0, r.ndf.1], &sigma),
            f32_field("vndf", &[np, r.theta_i, r.vndf.0, r.vndf.1], &vndf),
            f32_field("luminance", &[np, r.theta_i, n, n], &lum),
        ];
        match self.facet {
            Facet::Rgb(_) => fields.push(f32_field("rgb", &[np, r.theta_i, 3, n, n], &refl)),
            Facet::Conductor { .. } | Facet::White => {
                fields.push(f32_field("wavelengths", &[nc], &self.wavelengths));
                fields.push(f32_field("spectra", &[np, r.theta_i, nc, n, n], &refl));
            }
        }
        fields
    }

    /// The tensor file at resolution `r`.
    pub fn file(&self, r: Resolution) -> Vec<u8> {
        write_tensor(&self.fields(r))
    }
}

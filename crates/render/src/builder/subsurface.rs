//! pbrt-v4's `Material "subsurface"`, rendered as what it describes: a dielectric boundary (`eta`, roughness)
//! around a homogeneous scattering medium (σa, σs, Henyey–Greenstein `g`) that light enters, random-walks through
//! and leaves. pbrt-v4 approximates the same transport with a tabulated BSSRDF (photon beam diffusion); the random
//! walk is the exact transport of that medium inside the actual shape (thin parts and edges included), and every
//! integrator that renders scattering media (`volpath`; `path` ignores such media as pbrt-v4's `path` ignores
//! BSSRDFs) renders it.
//!
//! The coefficients come from one of pbrt-v4's four mutually exclusive ways: a measured medium by `name` (g = 0, as
//! the data are reduced coefficients), `sigma_a` and `sigma_s`, `reflectance` with `mfp`, or pbrt-v4's defaults;
//! all times `scale`.

use scene::{Entity, Loc, SceneError, SpectrumKind};
use spectral::rgb_uplift::RgbUnboundedSpectrum;
use spectral::Spectrum;

use super::context::{err, measured_medium, Result};
use crate::material::{DielectricIor, Material, Roughness};
use crate::medium::{HomogeneousMedium, PhaseFunction};

/// The boundary material and the interior medium of a `subsurface` material.
pub(super) fn subsurface(e: &Entity, roughness: Roughness) -> Result<(Material, HomogeneousMedium)> {
    let p = &e.params;
    let loc = |name: &str| p.loc_of(name, &e.loc);
    let scale = p.get_float("scale", 1.0)?;
    if !(scale.is_finite() && scale >= 0.0) {
        return err(&loc("scale"), format!("'scale' must be a finite number ≥ 0, got {scale}"));
    }
    let eta = p.get_float("eta", 1.33)?;
    if !(eta.is_finite() && eta > 0.0) {
        return err(&loc("eta"), format!("'eta' must be a positive number, got {eta}"));
    }
    let mut g = p.get_float("g", 0.0)?;
    if !(g > -1.0 && g < 1.0) {
        return err(&loc("g"), format!("'g' must lie strictly between -1 and 1, got {g}"));
    }
    let name = p.get_string("name", "")?;
    let (sigma_a, sigma_s) = if !name.is_empty() {
        // The measured data are reduced scattering coefficients: pbrt-v4 forces g = 0 (with a warning if given).
        g = 0.0;
        measured_medium(&name, &loc("name"))?
    } else if p.contains("sigma_a") || p.contains("sigma_s") {
        let get = |n: &str| -> Result<Spectrum> {
            p.get_spectrum(n, SpectrumKind::Unbounded)?.ok_or_else(|| {
                SceneError::at(
                    e.loc.clone(),
                    format!("'sigma_a' and 'sigma_s' must be given together ('{n}' is missing)"),
                )
                .into()
            })
        };
        (get("sigma_a")?, get("sigma_s")?)
    } else if p.contains("reflectance") {
        let r = p.get_spectrum("reflectance", SpectrumKind::Albedo)?.unwrap_or(Spectrum::Constant(0.5));
        let mfp = p.get_spectrum("mfp", SpectrumKind::Unbounded)?.unwrap_or(Spectrum::Constant(1.0));
        from_reflectance(&r, &mfp, eta, g, &loc("mfp"))?
    } else {
        // pbrt-v4's defaults (in mm⁻¹): a skin-like medium.
        let rgb = |v: [f64; 3]| {
            RgbUnboundedSpectrum::new(v)
                .map(Spectrum::RgbUnbounded)
                .map_err(|x| SceneError::at(e.loc.clone(), x.to_string()))
        };
        (rgb([0.0011, 0.0024, 0.014])?, rgb([2.55, 3.21, 3.77])?)
    };
    for (n, s) in [("sigma_a", &sigma_a), ("sigma_s", &sigma_s)] {
        let lo = (360..=830).map(|l| s.eval(l as f64)).fold(f64::INFINITY, f64::min);
        let hi = (360..=830).map(|l| s.eval(l as f64)).fold(f64::NEG_INFINITY, f64::max);
        if lo.is_nan() || lo < 0.0 || !hi.is_finite() || hi > 1e30 {
            return err(&loc(n), format!("'{n}' must be finite and non-negative at every wavelength ({lo} to {hi})"));
        }
    }
    let boundary = Material::Dielectric {
        ior: DielectricIor::Model(
            optics::Ior::constant(eta).map_err(|x| SceneError::at(loc("eta"), format!("'eta': {x}")))?,
        ),
        roughness,
        coating: Default::default(),
        tint: None,
    };
    let medium = HomogeneousMedium {
        sigma_a: sigma_a.scaled(scale).into(),
        sigma_s: sigma_s.scaled(scale).into(),
        le: None,
        phase: PhaseFunction::HenyeyGreenstein(g as f32),
    };
    Ok((boundary, medium))
}

/// Total diffuse reflectance of a semi-infinite medium of reduced albedo `alpha_p` under a boundary of relative
/// index `eta`, by the dipole diffusion approximation (Jensen, Marschner, Levoy & Hanrahan 2001; in the closed form
/// of Jensen & Buhler 2002, eq. 5): Rd = α'/2 · (1 + e^(−4/3·A·√(3(1−α')))) · e^(−√(3(1−α'))), with A = (1 + Fdr) /
/// (1 − Fdr) and Fdr the diffuse Fresnel reflectance (Egan & Hilgeman's fit).
pub(super) fn dipole_reflectance(alpha_p: f64, eta: f64) -> f64 {
    let fdr = -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta;
    let a = (1.0 + fdr) / (1.0 - fdr);
    let s = (3.0 * (1.0 - alpha_p)).max(0.0).sqrt();
    0.5 * alpha_p * (1.0 + (-4.0 / 3.0 * a * s).exp()) * (-s).exp()
}

/// The reduced albedo α' whose [`dipole_reflectance`] is `rd` (bisection: Rd rises monotonically from 0 at α' = 0
/// to 1 at α' = 1).
pub(super) fn invert_dipole_reflectance(rd: f64, eta: f64) -> f64 {
    let rd = rd.clamp(0.0, 1.0);
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if dipole_reflectance(mid, eta) < rd {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// σa and σs from a diffuse `reflectance` and mean free path `mfp` (1/σt), per wavelength every 5 nm: the reduced
/// albedo that reflects `reflectance` ([`invert_dipole_reflectance`]), turned into the single-scattering albedo of
/// phase asymmetry g (α' = α(1−g)/(1−αg)). pbrt-v4 inverts its photon-beam-diffusion table instead; both invert
/// a diffusion model of a flat semi-infinite medium.
fn from_reflectance(r: &Spectrum, mfp: &Spectrum, eta: f64, g: f64, loc: &Loc) -> Result<(Spectrum, Spectrum)> {
    let lambdas: Vec<f64> = (0..=94).map(|i| 360.0 + 5.0 * i as f64).collect();
    let (mut sa, mut ss) = (Vec::with_capacity(lambdas.len()), Vec::with_capacity(lambdas.len()));
    for &l in &lambdas {
        let m = mfp.eval(l);
        if !(m.is_finite() && m > 0.0) {
            return err(loc, format!("'mfp' must be positive and finite at every wavelength (it is {m} at {l} nm)"));
        }
        let ap = invert_dipole_reflectance(r.eval(l), eta);
        let alpha = ap / (1.0 - g + ap * g);
        let sigma_t = 1.0 / m;
        ss.push(alpha * sigma_t);
        sa.push((1.0 - alpha) * sigma_t);
    }
    let pl = |v: Vec<f64>| {
        Spectrum::piecewise_linear(lambdas.clone(), v).map_err(|e| SceneError::at(loc.clone(), e.to_string()))
    };
    Ok((pl(sa)?, pl(ss)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn here() -> Loc {
        Loc::builtin(std::sync::Arc::from(std::path::Path::new("test.pbrt")))
    }

    #[test]
    fn dipole_reflectance_ends_and_inversion() {
        for eta in [1.0, 1.33, 1.5] {
            assert!(dipole_reflectance(0.0, eta).abs() < 1e-12);
            assert!((dipole_reflectance(1.0, eta) - 1.0).abs() < 1e-12);
            // Monotone, and the inverse reproduces the reflectance.
            let mut prev = 0.0;
            for i in 1..=100 {
                let a = i as f64 / 100.0;
                let rd = dipole_reflectance(a, eta);
                assert!(rd > prev, "eta {eta}, α' {a}");
                prev = rd;
                assert!((invert_dipole_reflectance(rd, eta) - a).abs() < 1e-9, "eta {eta}, α' {a}");
            }
        }
        // Jensen et al.'s Figure: a matched boundary reflects more than η = 1.3 at the same albedo.
        assert!(dipole_reflectance(0.9, 1.0) > dipole_reflectance(0.9, 1.3));
    }

    #[test]
    fn reflectance_and_mfp_give_coefficients_that_reflect_it() {
        let (sa, ss) =
            from_reflectance(&Spectrum::Constant(0.6), &Spectrum::Constant(0.5), 1.33, 0.0, &here()).unwrap();
        for l in [400.0, 550.0, 700.0] {
            let (a, s) = (sa.eval(l), ss.eval(l));
            assert!(((a + s) - 2.0).abs() < 1e-9, "σt = 1/mfp");
            assert!((dipole_reflectance(s / (a + s), 1.33) - 0.6).abs() < 1e-6);
        }
        // With g the reduced albedo is what reflects.
        let g = 0.7;
        let (sa, ss) = from_reflectance(&Spectrum::Constant(0.6), &Spectrum::Constant(1.0), 1.33, g, &here()).unwrap();
        let alpha = ss.eval(550.0) / (sa.eval(550.0) + ss.eval(550.0));
        let ap = alpha * (1.0 - g) / (1.0 - alpha * g);
        assert!((dipole_reflectance(ap, 1.33) - 0.6).abs() < 1e-6);
        assert!(from_reflectance(&Spectrum::Constant(0.6), &Spectrum::Constant(0.0), 1.33, 0.0, &here()).is_err());
    }
}

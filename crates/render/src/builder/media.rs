//! Media: pbrt-v4's `MakeNamedMedium` directive (`homogeneous`, with pbrt-v4's named measured `preset`s, and
//! `uniformgrid`), and Prismatic's `mie`, into the scene's [`Media`] (which the names that `MediumInterface` and
//! the camera's medium give are looked up in).

use std::collections::HashMap;
use std::sync::Arc;

use glam::{Affine3A, Mat4};
use optics::mie::MieSpectralTable;
use scene::{Loc, MediumEntity, SceneDescription, SceneError, SpectrumKind};
use spectral::rgb_uplift::RgbUnboundedSpectrum;
use spectral::Spectrum;

use super::context::{err, normalise_emission, unsupported, Media, Result, MEASURED_MEDIA};
use crate::medium::{Coefficient, DensityGrid, GridMedium, HomogeneousMedium, Medium, PhaseFunction};

/// Reads every named medium.
pub(super) fn build(desc: &SceneDescription) -> Result<Media> {
    let mut list = vec![];
    let mut index: HashMap<String, u32> = HashMap::new();
    let mut mie_tables = MieTables::default();
    for m in &desc.media {
        let medium = match m.entity.name.as_str() {
            "homogeneous" => Medium::Homogeneous(homogeneous(m)?),
            "uniformgrid" => Medium::Grid(Box::new(uniform_grid(m)?)),
            "mie" => Medium::Homogeneous(mie(m, &mut mie_tables)?),
            other => return err(&m.entity.loc, unsupported("medium", other, &["homogeneous", "uniformgrid", "mie"])),
        };
        index.insert(m.medium_name.clone(), list.len() as u32);
        list.push(medium);
    }
    Ok(Media::new(list, index))
}

/// Where parameter `name` of medium `m` was written.
fn loc(m: &MediumEntity, name: &str) -> Loc {
    m.entity.params.loc_of(name, &m.entity.loc)
}

/// A coefficient spectrum (`sigma_a`, `sigma_s`): finite and non-negative across 360–830 nm.
fn coefficient(m: &MediumEntity, name: &str, default: f64) -> Result<Spectrum> {
    let s = m.entity.params.get_spectrum(name, SpectrumKind::Unbounded)?.unwrap_or(Spectrum::Constant(default));
    check_coefficient(m, name, &s)?;
    Ok(s)
}

fn check_coefficient(m: &MediumEntity, name: &str, s: &Spectrum) -> Result<()> {
    let (lo, hi) = (360..=830)
        .map(|l| s.eval(l as f64))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
    if lo.is_nan() || hi.is_nan() || lo < 0.0 {
        return err(&loc(m, name), format!("'{name}' must be non-negative at every wavelength (its minimum is {lo})"));
    }
    // f32 optical depths: σt·distance must stay representable over scene-sized distances.
    if !hi.is_finite() || hi > 1e30 {
        return err(&loc(m, name), format!("'{name}' must be finite (its maximum is {hi})"));
    }
    Ok(())
}

/// A non-negative finite scale factor.
fn scale(m: &MediumEntity, name: &str) -> Result<f64> {
    let v = m.entity.params.get_float(name, 1.0)?;
    if !v.is_finite() || v < 0.0 {
        return err(&loc(m, name), format!("'{name}' must be a finite non-negative number, got {v}"));
    }
    Ok(v)
}

/// Henyey–Greenstein's `g`, strictly between −1 and 1.
fn phase(m: &MediumEntity) -> Result<PhaseFunction> {
    let g = m.entity.params.get_float("g", 0.0)?;
    if !(g > -1.0 && g < 1.0) {
        return err(&loc(m, "g"), format!("'g' must lie strictly between -1 and 1, got {g}"));
    }
    Ok(PhaseFunction::HenyeyGreenstein(g as f32))
}

/// `Le` times `Lescale` with pbrt-v4's photometric normalisation, or `None` if the medium does not glow.
fn emission(m: &MediumEntity, scale_value: f64) -> Result<Option<Spectrum>> {
    let Some(le) = m.entity.params.get_spectrum("Le", SpectrumKind::Illuminant)? else { return Ok(None) };
    if le.max_value() <= 0.0 || scale_value == 0.0 {
        return Ok(None);
    }
    normalise_emission(&loc(m, "Le"), le, scale_value).map(Some)
}

/// pbrt-v4's `homogeneous` medium.
fn homogeneous(m: &MediumEntity) -> Result<HomogeneousMedium> {
    let p = &m.entity.params;
    let s = scale(m, "scale")?;
    let preset = p.get_string("preset", "")?;
    let (sigma_a, sigma_s) = if preset.is_empty() {
        (coefficient(m, "sigma_a", 1.0)?, coefficient(m, "sigma_s", 1.0)?)
    } else {
        let Some(preset) = MEASURED_MEDIA.iter().find(|mm| mm.name == preset) else {
            let names: Vec<&str> = MEASURED_MEDIA.iter().map(|mm| mm.name).collect();
            return err(
                &loc(m, "preset"),
                format!("unknown medium preset '{preset}'; known presets: {}", names.join(", ")),
            );
        };
        let rgb = |v: [f64; 3]| RgbUnboundedSpectrum::new(v).map(Spectrum::RgbUnbounded);
        let bad = |e| SceneError::at(loc(m, "preset"), format!("{e}"));
        (rgb(preset.sigma_a).map_err(bad)?, rgb(preset.sigma_prime_s).map_err(bad)?)
    };
    let le = emission(m, scale(m, "Lescale")?)?;
    Ok(HomogeneousMedium { sigma_a: sigma_a.scaled(s).into(), sigma_s: sigma_s.scaled(s).into(), le, phase: phase(m)? })
}

/// Mie optics already made for this scene, by (particle, radius, spread, forward cut-off): media that differ only in
/// density share one cache of per-wavelength tables.
type MieTables = HashMap<(String, u64, u64, u64), Arc<MieSpectralTable>>;

/// Prismatic's `mie` medium: a cloud of spheres of a catalogue material (`particle`) with number-mean radius
/// `radius` (µm), log-normal relative spread `radiusspread`, and `density` particles per cubic scene unit (a scene
/// unit is a metre): σs(λ) = N·C_sca(λ), σa(λ) = N·C_abs(λ) and the Mie phase function p(θ, λ). An optional
/// `forwardcutoff` (degrees, default 0 = exact) counts scattering by less than that angle as none.
fn mie(m: &MediumEntity, tables: &mut MieTables) -> Result<HomogeneousMedium> {
    let p = &m.entity.params;
    for unused in ["sigma_a", "sigma_s", "g", "preset"] {
        if p.contains(unused) {
            return err(
                &loc(m, unused),
                format!("a \"mie\" medium computes its coefficients and phase function; '{unused}' does not apply"),
            );
        }
    }
    let particle = p.get_string("particle", "water")?;
    let positive = |name: &str| -> Result<f64> {
        if !p.contains(name) {
            return err(&m.entity.loc, format!("a \"mie\" medium needs '{name}'"));
        }
        let v = p.get_float(name, 0.0)?;
        if !(v.is_finite() && v > 0.0) {
            return err(&loc(m, name), format!("'{name}' must be a finite number above 0, got {v}"));
        }
        Ok(v)
    };
    let radius = positive("radius")?;
    let density = positive("density")?;
    let spread = p.get_float("radiusspread", 0.0)?;
    if !(spread.is_finite() && (0.0..=1.0).contains(&spread)) {
        return err(&loc(m, "radiusspread"), format!("'radiusspread' must lie in [0, 1], got {spread}"));
    }
    let cutoff = p.get_float("forwardcutoff", 0.0)?;
    if !(cutoff.is_finite() && (0.0..=10.0).contains(&cutoff)) {
        return err(&loc(m, "forwardcutoff"), format!("'forwardcutoff' must lie in [0, 10] degrees, got {cutoff}"));
    }
    let key = (particle.clone(), radius.to_bits(), spread.to_bits(), cutoff.to_bits());
    let table = match tables.get(&key) {
        Some(t) => t.clone(),
        None => {
            let table = MieSpectralTable::from_particle(&particle, radius, spread).map_err(|e| {
                // An unknown name is the particle's fault; a size parameter out of range is the radius's.
                let name = if optics::catalogue::lookup(&particle).is_err() { "particle" } else { "radius" };
                SceneError::at(loc(m, name), format!("\"mie\" medium, '{name}': {e}"))
            })?;
            let table = table.with_forward_cutoff(cutoff).map_err(|e| {
                SceneError::at(loc(m, "forwardcutoff"), format!("\"mie\" medium, 'forwardcutoff': {e}"))
            })?;
            let t = Arc::new(table);
            tables.insert(key, t.clone());
            t
        }
    };
    // f32 optical depths: σt·distance must stay representable. Q_ext stays below ~4.5 (it tends to 2 for large
    // drops), so 5π·r² with the largest radius bounds the cross section.
    let r_max = radius * (1.0 + 4.0 * spread) * 1e-6;
    let bound = density * 5.0 * std::f64::consts::PI * r_max * r_max;
    if !(bound.is_finite() && bound <= 1e30) {
        return err(&loc(m, "density"), format!("'density' {density} makes σt far too large to represent"));
    }
    Ok(HomogeneousMedium {
        sigma_a: Coefficient::MieAbsorption { table: table.clone(), density },
        sigma_s: Coefficient::MieScattering { table: table.clone(), density },
        le: None,
        phase: PhaseFunction::Mie(table),
    })
}

/// pbrt-v4's `uniformgrid` medium.
fn uniform_grid(m: &MediumEntity) -> Result<GridMedium> {
    let p = &m.entity.params;
    if p.contains("temperature") {
        return err(&loc(m, "temperature"), "'temperature' grids (blackbody emission) are not supported; use 'Le'");
    }
    let res = [
        p.get_count("nx", 1, &m.entity.loc)?,
        p.get_count("ny", 1, &m.entity.loc)?,
        p.get_count("nz", 1, &m.entity.loc)?,
    ];
    let n = res[0] * res[1] * res[2];
    let Some(density) = p.get_floats("density") else {
        return err(&m.entity.loc, "a \"uniformgrid\" medium needs 'density' (nx·ny·nz values)");
    };
    if density.len() != n {
        return err(
            &loc(m, "density"),
            format!("'density' has {} values; nx·ny·nz = {}·{}·{} = {n}", density.len(), res[0], res[1], res[2]),
        );
    }
    let grid = |name: &str, v: &[f64]| {
        DensityGrid::new(res, v.iter().map(|&x| x as f32).collect())
            .ok_or_else(|| SceneError::at(loc(m, name), format!("'{name}' values must be finite and non-negative")))
    };
    let density = grid("density", density)?;
    let p0 = p.get_point3("p0", glam::DVec3::ZERO)?.as_vec3();
    let p1 = p.get_point3("p1", glam::DVec3::ONE)?.as_vec3();
    if !(p0.cmplt(p1).all() && p0.is_finite() && p1.is_finite()) {
        return err(&loc(m, "p1"), format!("the grid's box must have p0 < p1 on every axis, got p0 {p0}, p1 {p1}"));
    }
    let s = scale(m, "scale")?;
    let sigma_a = coefficient(m, "sigma_a", 1.0)?.scaled(s);
    let sigma_s = coefficient(m, "sigma_s", 1.0)?.scaled(s);
    // `Lescale` is a grid of nx·ny·nz factors (pbrt-v4), or one factor for the whole box.
    let le = match p.get_spectrum("Le", SpectrumKind::Illuminant)? {
        Some(le) if le.max_value() > 0.0 => {
            let factors = p.get_floats("Lescale").unwrap_or(&[1.0]);
            let scale_grid = if factors.len() == 1 {
                grid("Lescale", &vec![factors[0]; n])?
            } else if factors.len() == n {
                grid("Lescale", factors)?
            } else {
                return err(
                    &loc(m, "Lescale"),
                    format!("'Lescale' has {} values; expected 1 or nx·ny·nz = {n}", factors.len()),
                );
            };
            Some((normalise_emission(&loc(m, "Le"), le, 1.0)?, scale_grid))
        }
        _ => None,
    };
    let render_from_medium = Mat4::from_cols_array(&m.render_from_medium.matrix().as_mat4().to_cols_array());
    let medium_from_render = Affine3A::from_mat4(render_from_medium).inverse();
    if !medium_from_render.is_finite() {
        return err(&m.entity.loc, "the transform in effect at this medium cannot be inverted");
    }
    Ok(GridMedium { medium_from_render, bounds: (p0, p1), density, sigma_a, sigma_s, le, phase: phase(m)? })
}

//! The built-in material catalogue: the Sellmeier glasses, liquids and crystals of `data/glass_sellmeier.csv`, the
//! tabulated metals of `data/metals_nk.csv`, pbrt-v4's named spectra for the same materials, and the water
//! absorption table of `data/water_absorption.csv`. Sources and caveats are in `data/SOURCES.md` §5–7.
//!
//! The CSV files are embedded with `include_str!` and parsed once, on first use.
//!
//! # Names
//!
//! Look-ups ignore case and treat spaces, `_` and `-` alike, so `N-BK7`, `n_bk7` and `n bk7` all name SCHOTT N-BK7
//! and `water_20c` names `water 20C`. Besides the CSV names the catalogue accepts:
//!
//! - pbrt-v4's named glass spectra (see [`PBRT_GLASSES`]): `glass-BK7` → N-BK7, `glass-BAF10` → N-BAF10,
//!   `glass-FK51A` → N-FK51A, `glass-LASF9` → N-LASF9, and `glass-F5` / `glass-F10` / `glass-F11` → SCHOTT **SF5 /
//!   SF10 / SF11** (pbrt-v4 `spectrum.cpp` registers these names for its `GlassSF5_eta`, `GlassSF10_eta` and
//!   `GlassSF11_eta` tables, which hold the refractiveindex.info SCHOTT SF5/SF10/SF11 data). Note that plain `F5`
//!   is the different SCHOTT flint F5 (n_d 1.6034), while `glass-F5` is SF5 (n_d 1.6727).
//! - `metal-<M>`, `metal-<M>-eta` and `metal-<M>-k` for the metals M = Au, Ag, Cu, Al, Cr, Ti, and the English names
//!   gold, silver, copper, aluminium/aluminum, chromium, titanium.
//! - the short forms `BK7` (→ N-BK7), `water` (→ water 20C), `sapphire` (→ sapphire o, the ordinary ray),
//!   `spinel` (→ MgAl2O4 spinel), and for coatings `MgF2` (→ MgF2 o), `rutile` (→ TiO2 rutile o), `zirconia` (→
//!   ZrO2 cubic) and `Ta2O5` (→ Ta2O5 film Gao fit). Plain `TiO2` stays pbrt-v4's metal name without data: rutile's
//!   index is well above a deposited TiO₂ film's (2.65 against 2.2–2.5 at 550 nm), so the name says which it is.
//!
//! `glass-BAF10` maps to SCHOTT N-BAF10 rather than the HOYA BAF10 row: both carry glass code 670472 and the same
//! n_d = 1.67003, but N-BAF10 is SCHOTT's own published Sellmeier (valid 350–2500 nm, covering the whole 360–830 nm
//! grid the named spectrum is tabulated on), whereas the BAF10 row is a least-squares fit to HOYA's polynomial valid
//! only from 365 nm, which SOURCES.md says not to extrapolate.

use std::collections::BTreeMap;
use std::fmt;
use std::sync::{Arc, OnceLock};

use spectral::{PiecewiseLinear, Spectrum};

use crate::error::OpticsError;
use crate::ior::Ior;

const GLASS_CSV: &str = include_str!("../data/glass_sellmeier.csv");
const METALS_CSV: &str = include_str!("../data/metals_nk.csv");
const WATER_CSV: &str = include_str!("../data/water_absorption.csv");

/// pbrt-v4's named glass spectra and the catalogue rows they resolve to (see the module documentation).
pub const PBRT_GLASSES: [(&str, &str); 7] = [
    ("glass-BK7", "N-BK7"),
    ("glass-BAF10", "N-BAF10"),
    ("glass-FK51A", "N-FK51A"),
    ("glass-LASF9", "N-LASF9"),
    ("glass-F5", "SF5"),
    ("glass-F10", "SF10"),
    ("glass-F11", "SF11"),
];

/// Metals with tabulated n, k (`data/metals_nk.csv`), with their English names and data sources.
const METALS: [(&str, &str, &str); 6] = [
    ("Au", "gold", "database/data/main/Au/nk/Johnson.yml (P. B. Johnson, R. W. Christy, Phys. Rev. B 6, 4370, 1972)"),
    ("Ag", "silver", "database/data/main/Ag/nk/Johnson.yml (Johnson & Christy 1972)"),
    ("Cu", "copper", "database/data/main/Cu/nk/Johnson.yml (Johnson & Christy 1972)"),
    ("Al", "aluminium", "database/data/main/Al/nk/Rakic.yml (A. D. Rakić, Appl. Opt. 34, 4755, 1995)"),
    (
        "Cr",
        "chromium",
        "database/data/main/Cr/nk/Johnson.yml (P. B. Johnson, R. W. Christy, Phys. Rev. B 9, 5056, 1974)",
    ),
    ("Ti", "titanium", "database/data/main/Ti/nk/Johnson.yml (Johnson & Christy 1974)"),
];

/// pbrt-v4 named metal spectra we have no data for, with what they are.
const PBRT_METALS_WITHOUT_DATA: [(&str, &str); 3] =
    [("CuZn", "brass"), ("MgO", "magnesium oxide"), ("TiO2", "titanium dioxide")];

/// Extra short names: (alias, catalogue name).
const ALIASES: [(&str, &str); 10] = [
    ("BK7", "N-BK7"),
    ("water", "water 20C"),
    ("sapphire", "sapphire o"),
    ("spinel", "MgAl2O4 spinel"),
    ("aluminum", "Al"),
    ("fused quartz", "fused silica"),
    ("MgF2", "MgF2 o"),
    ("rutile", "TiO2 rutile o"),
    ("zirconia", "ZrO2 cubic"),
    ("Ta2O5", "Ta2O5 film Gao fit"),
];

/// What kind of material a catalogue entry is (the CSV `category` column, plus `Metal`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Category {
    /// SCHOTT optical glass (Zemax catalogue 2017-01-20b).
    SchottGlass,
    /// HOYA optical glass (Zemax catalogue 2017-04-01).
    HoyaGlass,
    /// Other glass (fused silica).
    Glass,
    /// Liquid (water).
    Liquid,
    /// Isotropic crystal (diamond, CaF2, spinel).
    Crystal,
    /// Uniaxial crystal, one row per ray (sapphire o / e).
    UniaxialCrystal,
    /// Metal with tabulated complex index.
    Metal,
}

impl Category {
    /// The label, as in the CSV `category` column (`metal` for metals).
    pub fn label(self) -> &'static str {
        match self {
            Self::SchottGlass => "SCHOTT optical glass",
            Self::HoyaGlass => "HOYA optical glass",
            Self::Glass => "glass",
            Self::Liquid => "liquid",
            Self::Crystal => "crystal",
            Self::UniaxialCrystal => "crystal (uniaxial)",
            Self::Metal => "metal",
        }
    }

    fn from_label(s: &str) -> Self {
        match s {
            "SCHOTT optical glass" => Self::SchottGlass,
            "HOYA optical glass" => Self::HoyaGlass,
            "glass" => Self::Glass,
            "liquid" => Self::Liquid,
            "crystal" => Self::Crystal,
            "crystal (uniaxial)" => Self::UniaxialCrystal,
            other => panic!("glass_sellmeier.csv: unknown category '{other}'"),
        }
    }
}

impl fmt::Display for Category {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.label())
    }
}

/// n_d and V_d of a Sellmeier row, three ways: computed here from our [`Ior`], the CSV's own computed columns (from
/// the database formula; for HOYA BAF10 that is the polynomial our Sellmeier is fitted to), and the manufacturer's
/// catalogue values where the CSV gives them (glasses only).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DispersionData {
    /// n at the d line (587.5618 nm), computed by this crate.
    pub nd: f64,
    /// V_d = (n_d − 1)/(n_F − n_C), computed by this crate.
    pub vd: f64,
    /// CSV column `n_d_computed`.
    pub nd_data: f64,
    /// CSV column `V_d_computed`.
    pub vd_data: f64,
    /// CSV column `n_F_computed`.
    pub nf_data: f64,
    /// CSV column `n_C_computed`.
    pub nc_data: f64,
    /// CSV column `nd_catalog` (manufacturer's catalogue), when present.
    pub nd_catalog: Option<f64>,
    /// CSV column `Vd_catalog` (manufacturer's catalogue), when present.
    pub vd_catalog: Option<f64>,
}

/// One catalogue material.
#[derive(Clone, Debug, PartialEq)]
pub struct CatalogueEntry {
    /// The canonical name (the CSV `name`, or the element symbol for metals).
    pub name: &'static str,
    /// What kind of material it is.
    pub category: Category,
    /// Its index of refraction: `Ior::Sellmeier` for CSV rows, `Ior::TabulatedComplex` for metals.
    pub ior: Ior,
    /// Where the data come from (refractiveindex.info database path; for metals also the publication).
    pub source: &'static str,
    /// Validity range of the data, nm (Sellmeier: the database's stated range; metals: the table's span).
    pub valid_range_nm: (f64, f64),
    /// Temperature of the data, K, when the database gives it.
    pub temperature_k: Option<f64>,
    /// Free-text notes from the CSV (for metals, the English name).
    pub notes: &'static str,
    /// n_d / V_d data for the Sellmeier rows; `None` for metals.
    pub dispersion: Option<DispersionData>,
}

/// A parsed row of `glass_sellmeier.csv` (all columns, for tests of the data).
#[derive(Clone, Debug)]
pub(crate) struct GlassRow {
    pub name: &'static str,
    pub category: &'static str,
    pub source_file: &'static str,
    // Read only by the data checks in the tests below.
    #[cfg_attr(not(test), allow(dead_code))]
    pub formula: &'static str,
    #[cfg_attr(not(test), allow(dead_code))]
    pub coefficients_raw: &'static str,
    pub a0: f64,
    pub b: [f64; 4],
    pub c_um2: [f64; 4],
    pub valid_um: (f64, f64),
    pub temperature_k: Option<f64>,
    pub nd: f64,
    pub vd: f64,
    pub nf: f64,
    pub nc: f64,
    pub nd_catalog: Option<f64>,
    pub vd_catalog: Option<f64>,
    pub notes: &'static str,
}

fn num(s: &str, what: &str) -> f64 {
    s.trim().parse().unwrap_or_else(|e| panic!("embedded CSV: cannot parse {what} '{s}': {e}"))
}

fn opt_num(s: &str, what: &str) -> Option<f64> {
    if s.trim().is_empty() {
        None
    } else {
        Some(num(s, what))
    }
}

/// Splits a CSV (no quoting; SOURCES.md) into its header and data rows.
fn csv_rows(text: &'static str) -> (Vec<&'static str>, Vec<Vec<&'static str>>) {
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let header: Vec<&str> = lines.next().expect("embedded CSV has a header").split(',').collect();
    let rows = lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            assert_eq!(f.len(), header.len(), "embedded CSV row has {} fields, header {}: {l}", f.len(), header.len());
            f
        })
        .collect();
    (header, rows)
}

fn column(header: &[&str], name: &str) -> usize {
    header.iter().position(|h| h.trim() == name).unwrap_or_else(|| panic!("embedded CSV lacks column '{name}'"))
}

pub(crate) fn glass_rows() -> &'static [GlassRow] {
    static ROWS: OnceLock<Vec<GlassRow>> = OnceLock::new();
    ROWS.get_or_init(|| {
        let (h, rows) = csv_rows(GLASS_CSV);
        let c = |n: &str| column(&h, n);
        let (name, cat, src, formula, raw) =
            (c("name"), c("category"), c("source_file"), c("formula"), c("coefficients_raw"));
        let a0 = c("A0");
        let b = [c("B1"), c("B2"), c("B3"), c("B4")];
        let cc = [c("C1_um2"), c("C2_um2"), c("C3_um2"), c("C4_um2")];
        let (vmin, vmax, temp) = (c("valid_min_um"), c("valid_max_um"), c("temperature_K"));
        let (nd, vd, nf, nc) = (c("n_d_computed"), c("V_d_computed"), c("n_F_computed"), c("n_C_computed"));
        let (ndc, vdc, notes) = (c("nd_catalog"), c("Vd_catalog"), c("notes"));
        rows.iter()
            .map(|r| GlassRow {
                name: r[name].trim(),
                category: r[cat].trim(),
                source_file: r[src].trim(),
                formula: r[formula].trim(),
                coefficients_raw: r[raw].trim(),
                a0: num(r[a0], "A0"),
                b: b.map(|i| num(r[i], "B")),
                c_um2: cc.map(|i| num(r[i], "C")),
                valid_um: (num(r[vmin], "valid_min_um"), num(r[vmax], "valid_max_um")),
                temperature_k: opt_num(r[temp], "temperature_K"),
                nd: num(r[nd], "n_d_computed"),
                vd: num(r[vd], "V_d_computed"),
                nf: num(r[nf], "n_F_computed"),
                nc: num(r[nc], "n_C_computed"),
                nd_catalog: opt_num(r[ndc], "nd_catalog"),
                vd_catalog: opt_num(r[vdc], "Vd_catalog"),
                notes: r[notes].trim(),
            })
            .collect()
    })
}

/// Per-metal columns of `metals_nk.csv`: (symbol, λ nm, n, k), in file order.
type MetalTable = (&'static str, Vec<f64>, Vec<f64>, Vec<f64>);

fn metal_tables() -> Vec<MetalTable> {
    let (h, rows) = csv_rows(METALS_CSV);
    let (m, l, n, k) = (column(&h, "metal"), column(&h, "wavelength_nm"), column(&h, "n"), column(&h, "k"));
    let mut out: Vec<MetalTable> = Vec::new();
    for r in &rows {
        let sym = r[m].trim();
        if out.last().map(|t| t.0) != Some(sym) {
            assert!(out.iter().all(|t| t.0 != sym), "metals_nk.csv: rows of {sym} are not contiguous");
            out.push((sym, Vec::new(), Vec::new(), Vec::new()));
        }
        let t = out.last_mut().expect("just pushed");
        t.1.push(num(r[l], "wavelength_nm"));
        t.2.push(num(r[n], "n"));
        t.3.push(num(r[k], "k"));
    }
    out
}

fn build_entries() -> Vec<CatalogueEntry> {
    let mut v: Vec<CatalogueEntry> = glass_rows()
        .iter()
        .map(|r| {
            let terms: Vec<(f64, f64)> =
                r.b.iter().zip(&r.c_um2).filter(|(b, _)| **b != 0.0).map(|(&b, &c)| (b, c)).collect();
            let ior =
                Ior::sellmeier(r.a0, &terms).unwrap_or_else(|e| panic!("glass_sellmeier.csv row {}: {e}", r.name));
            let dispersion = DispersionData {
                nd: ior.nd(),
                vd: ior.vd(),
                nd_data: r.nd,
                vd_data: r.vd,
                nf_data: r.nf,
                nc_data: r.nc,
                nd_catalog: r.nd_catalog,
                vd_catalog: r.vd_catalog,
            };
            CatalogueEntry {
                name: r.name,
                category: Category::from_label(r.category),
                ior,
                source: r.source_file,
                valid_range_nm: (r.valid_um.0 * 1e3, r.valid_um.1 * 1e3),
                temperature_k: r.temperature_k,
                notes: r.notes,
                dispersion: Some(dispersion),
            }
        })
        .collect();
    for (sym, l, n, k) in metal_tables() {
        let &(_, english, source) =
            METALS.iter().find(|m| m.0 == sym).unwrap_or_else(|| panic!("metals_nk.csv: unexpected metal {sym}"));
        let range = (l[0], l[l.len() - 1]);
        let ior = Ior::tabulated_complex(l, n, k).unwrap_or_else(|e| panic!("metals_nk.csv {sym}: {e}"));
        v.push(CatalogueEntry {
            name: sym,
            category: Category::Metal,
            ior,
            source,
            valid_range_nm: range,
            temperature_k: None,
            notes: english,
            dispersion: None,
        });
    }
    v
}

/// Every catalogue entry: the CSV rows in file order, then the metals (Au, Ag, Cu, Al, Cr, Ti).
pub fn entries() -> &'static [CatalogueEntry] {
    static ENTRIES: OnceLock<Vec<CatalogueEntry>> = OnceLock::new();
    ENTRIES.get_or_init(build_entries)
}

/// Lower-cases and maps spaces and `_` to `-`, so names compare loosely.
fn normalize(name: &str) -> String {
    name.trim().chars().map(|c| if c == ' ' || c == '_' { '-' } else { c.to_ascii_lowercase() }).collect()
}

/// Every accepted (normalised) name and the index of its entry.
fn name_index() -> &'static BTreeMap<String, usize> {
    static INDEX: OnceLock<BTreeMap<String, usize>> = OnceLock::new();
    INDEX.get_or_init(|| {
        let es = entries();
        let pos = |n: &str| es.iter().position(|e| e.name == n).unwrap_or_else(|| panic!("no catalogue entry {n}"));
        let mut m = BTreeMap::new();
        for (i, e) in es.iter().enumerate() {
            m.insert(normalize(e.name), i);
        }
        for (alias, target) in PBRT_GLASSES.iter().chain(ALIASES.iter()) {
            m.insert(normalize(alias), pos(target));
        }
        for (sym, english, _) in METALS {
            let i = pos(sym);
            m.insert(normalize(english), i);
            for suffix in ["", "-eta", "-k"] {
                m.insert(normalize(&format!("metal-{sym}{suffix}")), i);
            }
        }
        m
    })
}

/// Why a name known elsewhere has no data here, if it is one of those.
fn known_without_data(norm: &str) -> Option<String> {
    for (sym, what) in PBRT_METALS_WITHOUT_DATA {
        let s = normalize(sym);
        let forms = [s.clone(), format!("metal-{s}"), format!("metal-{s}-eta"), format!("metal-{s}-k")];
        if forms.iter().any(|f| f == norm) {
            return Some(format!(
                "pbrt-v4 defines metal-{sym}-eta and metal-{sym}-k ({what}), but data/metals_nk.csv has no n, k table \
                 for {sym}; only Au, Ag, Cu, Al, Cr and Ti are available"
            ));
        }
    }
    if norm == "f10" || norm == "schott-f10" {
        return Some(
            "SCHOTT F10 is not in the refractiveindex.info database (data/SOURCES.md); pbrt-v4's glass-F10 is SF10, \
             which is available as 'SF10' or 'glass-F10'"
                .into(),
        );
    }
    None
}

/// Levenshtein edit distance between two short strings.
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, &cb) in b.iter().enumerate() {
            cur[j + 1] = (prev[j] + usize::from(ca != cb)).min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}

/// Up to five catalogue names close to `norm` (small edit distance, or one name containing the other).
fn suggestions(norm: &str) -> Vec<String> {
    let es = entries();
    let mut scored: Vec<(usize, &'static str)> = Vec::new();
    for (alias, &i) in name_index() {
        let d = edit_distance(norm, alias);
        let close = d <= (norm.chars().count() / 3).max(2)
            || (norm.len() >= 2 && (alias.contains(norm) || norm.contains(alias.as_str())));
        if close {
            scored.push((d, es[i].name));
        }
    }
    scored.sort();
    let mut out: Vec<String> = Vec::new();
    for (_, n) in scored {
        if !out.iter().any(|o| o == n) {
            out.push(n.to_owned());
        }
    }
    out.truncate(5);
    out
}

fn unknown(name: &str) -> OpticsError {
    let norm = normalize(name);
    match known_without_data(&norm) {
        Some(reason) => OpticsError::NoData { name: name.to_owned(), reason },
        None => OpticsError::UnknownName { name: name.to_owned(), suggestions: suggestions(&norm) },
    }
}

/// Finds a material by name (see the module documentation for the accepted spellings). Unknown names give
/// [`OpticsError::UnknownName`] with close matches; names pbrt-v4 knows but we have no data for (CuZn, MgO, TiO2,
/// SCHOTT F10) give [`OpticsError::NoData`].
pub fn lookup(name: &str) -> Result<CatalogueEntry, OpticsError> {
    name_index().get(&normalize(name)).map(|&i| entries()[i].clone()).ok_or_else(|| unknown(name))
}

/// The spectrum names [`named_spectrum`] resolves: pbrt-v4's seven `glass-*` names and `metal-<M>-eta` /
/// `metal-<M>-k` for Au, Ag, Cu, Al (pbrt-v4's) and Cr, Ti (ours).
pub fn named_spectrum_names() -> Vec<String> {
    let mut v: Vec<String> = PBRT_GLASSES.iter().map(|(p, _)| (*p).to_owned()).collect();
    for (sym, _, _) in METALS {
        v.push(format!("metal-{sym}-eta"));
        v.push(format!("metal-{sym}-k"));
    }
    v
}

/// A spectrum written as `prismatic spectrum` takes it: a named illuminant (`stdillum-D65`, …), a pbrt-v4 glass or
/// metal spectrum (`glass-BK7`, `metal-Au-eta`, …), `blackbody:KELVIN` (Planck's law normalised to peak 1),
/// `constant:VALUE`, `rgb:R,G,B` (a linear sRGB reflectance uplifted to a smooth spectrum) or `rgb-illum:R,G,B` (a
/// linear sRGB emitter, uplifted and multiplied by D65). The error says what is wrong.
pub fn spectrum_from_spec(spec: &str) -> Result<Spectrum, String> {
    use spectral::rgb_uplift::{RgbAlbedoSpectrum, RgbIlluminantSpectrum};
    if let Some(t) = spec.strip_prefix("blackbody:") {
        let kelvin: f64 = t.trim().parse().map_err(|_| format!("blackbody temperature '{t}' is not a number"))?;
        return Spectrum::blackbody(kelvin).map_err(|e| e.to_string());
    }
    if let Some(v) = spec.strip_prefix("constant:") {
        let value: f64 = v.trim().parse().map_err(|_| format!("constant value '{v}' is not a number"))?;
        if !value.is_finite() {
            return Err(format!("constant value must be finite, got {value}"));
        }
        return Ok(Spectrum::Constant(value));
    }
    for (prefix, illuminant) in [("rgb:", false), ("rgb-illum:", true)] {
        if let Some(list) = spec.strip_prefix(prefix) {
            let v: Vec<f64> = list
                .split(',')
                .map(|c| c.trim().parse::<f64>().map_err(|_| format!("rgb component '{c}' is not a number")))
                .collect::<Result<_, _>>()?;
            let rgb: [f64; 3] = v.try_into().map_err(|_| format!("{prefix} needs exactly three components R,G,B"))?;
            let s = if illuminant {
                RgbIlluminantSpectrum::new(rgb).map(Spectrum::RgbIlluminant)
            } else {
                RgbAlbedoSpectrum::new(rgb).map(Spectrum::RgbAlbedo)
            };
            return s.map_err(|e| e.to_string());
        }
    }
    if let Ok(s) = spectral::named::illuminant(spec) {
        return Ok(s);
    }
    named_spectrum_checked(spec).map_err(|e| {
        format!(
            "{e}\n(named illuminants: {}; or blackbody:KELVIN, constant:VALUE, rgb:R,G,B, rgb-illum:R,G,B)",
            spectral::named::ILLUMINANT_NAMES.join(", ")
        )
    })
}

/// Resolves a pbrt-v4 style named spectrum, as [`named_spectrum`] does, but says why a name fails.
pub fn named_spectrum_checked(name: &str) -> Result<Spectrum, OpticsError> {
    let norm = normalize(name);
    if let Some((_, target)) = PBRT_GLASSES.iter().find(|(p, _)| normalize(p) == norm) {
        return Ok(lookup(target)?.ior.to_spectrum());
    }
    for (sym, _, _) in METALS {
        let s = normalize(sym);
        let part = if norm == format!("metal-{s}-eta") {
            Some(true)
        } else if norm == format!("metal-{s}-k") {
            Some(false)
        } else {
            None
        };
        if let Some(eta) = part {
            let e = lookup(sym)?;
            if let Ior::TabulatedComplex(t) = &e.ior {
                let table = if eta { t.n_arc() } else { t.k_arc() };
                return Ok(Spectrum::PiecewiseLinear(table));
            }
        }
    }
    Err(match known_without_data(&norm) {
        Some(reason) => OpticsError::NoData { name: name.to_owned(), reason },
        None => {
            let mut s: Vec<String> =
                named_spectrum_names().into_iter().filter(|n| edit_distance(&norm, &normalize(n)) <= 3).collect();
            s.truncate(5);
            OpticsError::UnknownName { name: name.to_owned(), suggestions: s }
        }
    })
}

/// A pbrt-v4 named spectrum: `glass-BK7`, `glass-BAF10`, `glass-FK51A`, `glass-LASF9`, `glass-F5`, `glass-F10`,
/// `glass-F11` (n tabulated every 1 nm over 360–830 nm from the Sellmeier of the mapped catalogue glass), and
/// `metal-<M>-eta` / `metal-<M>-k` for M = Au, Ag, Cu, Al, Cr, Ti (the 300–900 nm, 5 nm table of
/// `data/metals_nk.csv`). Case-insensitive. `None` for anything else, including pbrt's `metal-CuZn-*`,
/// `metal-MgO-*` and `metal-TiO2-*`, for which there is no data ([`named_spectrum_checked`] says so).
pub fn named_spectrum(name: &str) -> Option<Spectrum> {
    named_spectrum_checked(name).ok()
}

fn water_table(column_name: &str) -> Spectrum {
    let (h, rows) = csv_rows(WATER_CSV);
    let (l, a) = (column(&h, "wavelength_nm"), column(&h, column_name));
    let lambdas = rows.iter().map(|r| num(r[l], "wavelength_nm")).collect();
    let alpha = rows.iter().map(|r| num(r[a], column_name)).collect();
    let t = PiecewiseLinear::new(lambdas, alpha).unwrap_or_else(|e| panic!("water_absorption.csv: {e}"));
    Spectrum::PiecewiseLinear(Arc::new(t))
}

/// Absorption coefficient α(λ) of pure liquid water, m⁻¹ (Beer–Lambert I = I₀·exp(−α·d)), from Segelstein (1981)
/// at 25 °C: α = 4πk/λ, 300–900 nm every 5 nm (`data/water_absorption.csv`, SOURCES.md §7). A helper for a later
/// coloured-medium feature. Like every older table it overestimates absorption in the blue and violet (minimum
/// ≈ 0.02 m⁻¹ near 480 nm, against ≈ 0.0044 m⁻¹ near 418 nm in Pope & Fry 1997, which is not available here).
pub fn water_absorption_segelstein() -> Spectrum {
    static S: OnceLock<Spectrum> = OnceLock::new();
    S.get_or_init(|| water_table("alpha_per_m_segelstein_1981")).clone()
}

/// Wavelength range of `data/water_absorption.csv`, nm: the water absorption and k tables are 0 outside it.
pub const WATER_ABSORPTION_RANGE_NM: (f64, f64) = (300.0, 900.0);

/// Imaginary part k(λ) of the refractive index of pure water (dimensionless), Segelstein (1981) at 25 °C: the k
/// column behind [`water_absorption_segelstein`] (α = 4πk/λ), 300–900 nm every 5 nm.
pub fn water_k_segelstein() -> Spectrum {
    static S: OnceLock<Spectrum> = OnceLock::new();
    S.get_or_init(|| water_table("k_segelstein_1981")).clone()
}

/// Absorption coefficient α(λ) of pure water, m⁻¹, from Hale & Querry (1973) at 25 °C (same table, 25 nm native
/// sampling). Higher still than Segelstein below 400 nm; prefer [`water_absorption_segelstein`].
pub fn water_absorption_hale_querry() -> Spectrum {
    static S: OnceLock<Spectrum> = OnceLock::new();
    S.get_or_init(|| water_table("alpha_per_m_hale_querry_1973")).clone()
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn parses_every_row() {
        assert_eq!(glass_rows().len(), 31);
        assert_eq!(entries().len(), 31 + 6);
        for (sym, l, n, k) in metal_tables() {
            assert_eq!((l.len(), n.len(), k.len()), (121, 121, 121), "{sym}");
            assert_eq!((l[0], l[120]), (300.0, 900.0));
        }
    }

    #[test]
    fn a0_is_zero_except_in_converted_and_fitted_rows() {
        // SOURCES.md §5: A0 is 0 in every row but the two converted from formula 4 and the Ta2O5 fit.
        let nonzero: Vec<&str> = glass_rows().iter().filter(|r| r.a0 != 0.0).map(|r| r.name).collect();
        assert_eq!(nonzero, ["TiO2 rutile o", "TiO2 rutile e", "Ta2O5 film Gao fit"]);
    }

    #[test]
    fn formula_4_rows_are_the_database_formula_exactly() {
        // formula 4: n² = C1 + C2·λ^C3/(λ² − C4^C5) + C6·λ^C7/(λ² − C8^C9), λ in µm (Devore's rutile: C3 = C7 = 0,
        // C5 = C9 = 1, C6 = 0), rewritten as 1 + A0 + B1λ²/(λ² − C1) with B1 = C2/C4, A0 = C1 − 1 − B1.
        let mut count = 0;
        for r in glass_rows().iter().filter(|r| r.formula == "formula 4") {
            let c: Vec<f64> = r.coefficients_raw.split_whitespace().map(|s| num(s, "raw")).collect();
            let ior = lookup(r.name).unwrap().ior;
            for l_nm in [430.0f64, 500.0, 587.5618, 700.0, 1500.0] {
                let l = l_nm / 1e3;
                let n2 = c[0]
                    + c[1] * l.powf(c[2]) / (l * l - c[3].powf(c[4]))
                    + c[5] * l.powf(c[6]) / (l * l - c[7].powf(c[8]));
                assert_relative_eq!(ior.n(l_nm), n2.sqrt(), max_relative = 1e-14);
            }
            count += 1;
        }
        assert_eq!(count, 2); // TiO2 rutile o, e
    }

    #[test]
    fn the_ta2o5_fit_matches_gaos_film_table() {
        // database/data/main/Ta2O5/nk/Gao.yml (Gao, Lemarchand & Lequime, Opt. Express 20, 15734, 2012): n of a
        // 400 nm ion-assisted e-beam film, read from the table; SOURCES.md quotes a largest fit error of 5.9e-5.
        let gao = [
            (400.0, 2.246896),
            (450.0, 2.204562),
            (500.0, 2.176708),
            (550.0, 2.157262),
            (600.0, 2.143086),
            (700.0, 2.124149),
            (800.0, 2.112356),
        ];
        let fit = lookup("Ta2O5").unwrap().ior;
        for (l, n) in gao {
            assert!((fit.n(l) - n).abs() < 6e-5, "{l} nm: {} vs {n}", fit.n(l));
        }
    }

    #[test]
    fn formula_2_rows_copy_the_database_coefficients() {
        // formula 2 raw order: C0 B1 C1 B2 C2 …, C in µm².
        for r in glass_rows().iter().filter(|r| r.formula == "formula 2") {
            let raw: Vec<f64> = r.coefficients_raw.split_whitespace().map(|s| num(s, "raw")).collect();
            assert_eq!(raw[0], r.a0, "{}", r.name);
            for (i, pair) in raw[1..].chunks(2).enumerate() {
                assert_eq!(pair[0], r.b[i], "{} B{}", r.name, i + 1);
                assert_eq!(pair[1], r.c_um2[i], "{} C{}", r.name, i + 1);
            }
        }
    }

    #[test]
    fn formula_1_rows_store_the_squared_resonance() {
        // formula 1: n² − 1 = C0 + Σ Bᵢλ²/(λ² − cᵢ²), cᵢ in µm; the CSV stores Cᵢ = cᵢ².
        let mut count = 0;
        for r in glass_rows().iter().filter(|r| r.formula == "formula 1") {
            let raw: Vec<f64> = r.coefficients_raw.split_whitespace().map(|s| num(s, "raw")).collect();
            for (i, pair) in raw[1..].chunks(2).enumerate() {
                assert_eq!(pair[0], r.b[i], "{} B{}", r.name, i + 1);
                assert_relative_eq!(pair[1] * pair[1], r.c_um2[i], max_relative = 1e-14);
            }
            count += 1;
        }
        // fused silica, diamond, sapphire o/e, CaF2 (Malitson), spinel, MgF2 o/e, cubic zirconia, cyclohexane
        assert_eq!(count, 10);
    }

    #[test]
    fn baf10_fit_matches_hoya_polynomial_over_its_range() {
        // formula 3: n² = c0 + Σ c₂ᵢ₋₁ λ^c₂ᵢ, λ in µm. SOURCES.md §5 quotes a largest fit error of 6.4e-6.
        let r = glass_rows().iter().find(|r| r.name == "BAF10").unwrap();
        assert_eq!(r.formula, "formula 3");
        let raw: Vec<f64> = r.coefficients_raw.split_whitespace().map(|s| num(s, "raw")).collect();
        let poly = |l_um: f64| {
            let n2 = raw[0] + raw[1..].chunks(2).map(|p| p[0] * l_um.powf(p[1])).sum::<f64>();
            n2.sqrt()
        };
        let fit = lookup("BAF10").unwrap().ior;
        let mut worst = 0.0_f64;
        let (lo, hi) = r.valid_um;
        for i in 0..=1000 {
            let l = lo + (hi - lo) * f64::from(i) / 1000.0;
            worst = worst.max((fit.n(l * 1e3) - poly(l)).abs());
        }
        assert!(worst < 7e-6, "worst |Δn| = {worst}");
        assert_relative_eq!(poly(0.5875618), r.nd, epsilon = 1e-6);
    }

    #[test]
    fn water_k_and_alpha_columns_agree() {
        // α = 4πk/λ with λ in metres; the CSV rounds both columns to 5 significant digits.
        let (k, a) = (water_k_segelstein(), water_absorption_segelstein());
        let (lo, hi) = WATER_ABSORPTION_RANGE_NM;
        let mut l = lo;
        while l <= hi {
            let from_k = 4.0 * std::f64::consts::PI * k.eval(l) / (l * 1e-9);
            assert_relative_eq!(from_k, a.eval(l), max_relative = 1e-3);
            l += 5.0;
        }
        assert_eq!(k.eval(lo - 1.0), 0.0);
    }

    #[test]
    fn normalize_and_edit_distance() {
        assert_eq!(normalize(" N_BK7 "), "n-bk7");
        assert_eq!(normalize("water 20C"), "water-20c");
        assert_eq!(edit_distance("kitten", "sitting"), 3);
        assert_eq!(edit_distance("", "abc"), 3);
        assert_eq!(edit_distance("sf11", "sf11"), 0);
    }
}

//! Named spectra: the CIE illuminants under the names pbrt-v4 scenes use.
//!
//! Glass and metal names (`glass-BK7`, `metal-Au-eta`, …) live with the optical catalogue in the `optics` crate,
//! which knows the materials.

use std::sync::{Arc, OnceLock};

use crate::cmf::Observer;
use crate::spectrum::{PiecewiseLinear, Spectrum};
use crate::tables;
use crate::SpectrumError;

/// Every illuminant name this module knows, in listing order.
pub const ILLUMINANT_NAMES: [&str; 15] = [
    "stdillum-D65",
    "stdillum-D50",
    "stdillum-A",
    "stdillum-F1",
    "stdillum-F2",
    "stdillum-F3",
    "stdillum-F4",
    "stdillum-F5",
    "stdillum-F6",
    "stdillum-F7",
    "stdillum-F8",
    "stdillum-F9",
    "stdillum-F10",
    "stdillum-F11",
    "stdillum-F12",
];

fn build(name: &str) -> Spectrum {
    let (table, column) = match name.strip_prefix("stdillum-").unwrap_or(name) {
        d @ ("D65" | "D50" | "A") => (tables::illuminants(), d.to_string()),
        f => (tables::fluorescent(), format!("FL{}", &f[1..])),
    };
    let lambdas = table.column(&table.columns[0]);
    let values = table.column(&column);
    let raw = PiecewiseLinear::new(lambdas, values).expect("embedded illuminant tables are well formed");
    // Normalised to luminance Y = 1 under the CIE 1931 observer, as pbrt-v4 normalises its named illuminants.
    let y = Observer::Cie1931.spectrum_to_xyz(&Spectrum::PiecewiseLinear(Arc::new(raw.clone()))).y;
    Spectrum::PiecewiseLinear(Arc::new(raw.scaled(1.0 / y)))
}

/// The illuminant called `name` (pbrt-v4 spelling, e.g. `stdillum-D65`, `stdillum-F11`; case-sensitive like pbrt),
/// normalised to luminance 1.
pub fn illuminant(name: &str) -> Result<Spectrum, SpectrumError> {
    static CACHE: OnceLock<Vec<Spectrum>> = OnceLock::new();
    let all = CACHE.get_or_init(|| ILLUMINANT_NAMES.iter().map(|n| build(n)).collect());
    ILLUMINANT_NAMES
        .iter()
        .position(|n| *n == name)
        .map(|i| all[i].clone())
        .ok_or_else(|| SpectrumError::UnknownName(name.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_illuminant_has_unit_luminance() {
        for n in ILLUMINANT_NAMES {
            let xyz = Observer::Cie1931.spectrum_to_xyz(&illuminant(n).unwrap());
            assert!((xyz.y - 1.0).abs() < 1e-12, "{n}: {xyz:?}");
        }
        assert!(matches!(illuminant("stdillum-D75"), Err(SpectrumError::UnknownName(_))));
    }

    #[test]
    fn white_points_match_the_data_readme() {
        // Chromaticities computed from these tables at 1 nm (data/SOURCES.md, section 4).
        for (n, x, y) in
            [("stdillum-D65", 0.31273, 0.32902), ("stdillum-D50", 0.34568, 0.35850), ("stdillum-A", 0.44756, 0.40743)]
        {
            let xy = Observer::Cie1931.spectrum_to_xyz(&illuminant(n).unwrap()).chromaticity();
            assert!((xy[0] - x).abs() < 1e-5 && (xy[1] - y).abs() < 1e-5, "{n}: {xy:?}");
        }
    }

    #[test]
    fn fluorescent_f2_chromaticity_matches_cie_15() {
        // CIE 15:2004 Table T.8.2: F2 (cool white) x = 0.37208, y = 0.37529; F11 x = 0.38052, y = 0.37713.
        for (n, x, y) in [("stdillum-F2", 0.37208, 0.37529), ("stdillum-F11", 0.38052, 0.37713)] {
            let xy = Observer::Cie1931.spectrum_to_xyz(&illuminant(n).unwrap()).chromaticity();
            assert!((xy[0] - x).abs() < 5e-4 && (xy[1] - y).abs() < 5e-4, "{n}: {xy:?}");
        }
    }
}

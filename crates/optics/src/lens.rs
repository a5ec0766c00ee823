//! Lens prescriptions: the surfaces of a photographic or test lens, read from pbrt-v4's lens files with Prismatic's
//! extensions (glass by catalogue name or Abbe pair, coatings per surface).
//!
//! A prescription lists the lens's surfaces from the object (scene) side to the film, one row each, as pbrt-v4's
//! `realistic` camera and most optical-design tables do:
//!
//! ```text
//! # radius (mm)   thickness (mm)   index    aperture diameter (mm)
//!   58.950          7.520           1.670    50.4
//!  169.660          0.240           0        50.4
//!    0              9.0             0        30.0      # the aperture stop: radius 0 and index 0
//! ```
//!
//! - **radius**: the surface's radius of curvature in mm, positive when its centre of curvature lies on the film side
//!   of the surface (a convex front surface), negative when on the object side; 0 for a flat surface (and for the
//!   stop).
//! - **thickness**: the distance along the axis to the next surface, mm (for the last surface, to the film plane as
//!   designed; the camera refocuses by moving the film).
//! - **index**: the medium *behind* the surface (towards the film): 0 or 1 for air, a number for pbrt-v4's constant
//!   index, and, as Prismatic extensions, a catalogue name (`N-BK7`, `N-SF11`, `CaF2`, … anything `prismatic ior
//!   --list` prints; spaces written as `_`) or an Abbe pair `nd/Vd` (`1.5168/64.17`, the two-term Cauchy of
//!   [`Ior::abbe`]). A row whose radius and index are both 0 is the aperture stop (pbrt-v4's rule).
//! - **aperture**: the surface's clear aperture diameter, mm (for the stop, its largest opening).
//! - **coating** (Prismatic extension, optional fifth column): thin films on the surface, outermost (the object side)
//!   first, as `MATERIAL@THICKNESS_NM` joined by `+`, e.g. `MgF2@99.6` (a quarter-wave magnesium fluoride layer for
//!   550 nm) or `MgF2@92.4+zirconia@117.7+sapphire@72`; materials as for the index column.
//!
//! A file whose tokens are all numbers is read as pbrt-v4 reads it: a stream of numbers, four per surface, line
//! breaks not significant. A file with any other token is read row by row, four or five tokens a row. `#` starts a
//! comment to the end of the line. Every error names the line and column.

use std::fmt;

use crate::catalogue;
use crate::error::OpticsError;
use crate::ior::Ior;

/// What fills the space behind a surface (towards the film).
#[derive(Clone, Debug, PartialEq)]
pub enum LensMedium {
    /// Air, index 1 (pbrt-v4's 0 or 1).
    Air,
    /// A glass (or crystal, or liquid) with its n(λ): a constant for pbrt-v4's numbers, a catalogue model, or an
    /// Abbe pair's Cauchy.
    Glass(Ior),
}

impl LensMedium {
    /// The index at `lambda_nm`.
    pub fn n(&self, lambda_nm: f64) -> f64 {
        match self {
            LensMedium::Air => 1.0,
            LensMedium::Glass(ior) => ior.n(lambda_nm),
        }
    }

    /// True if the index depends on the wavelength.
    pub fn is_dispersive(&self) -> bool {
        match self {
            LensMedium::Air => false,
            LensMedium::Glass(ior) => ior.is_dispersive(),
        }
    }
}

/// One layer of a surface's coating: its material's index model and its thickness in nm.
#[derive(Clone, Debug, PartialEq)]
pub struct CoatingLayerSpec {
    /// The layer's material as written (for messages and listings).
    pub name: String,
    /// Its index (complex where the catalogue has k).
    pub ior: Ior,
    /// Thickness, nm.
    pub thickness_nm: f64,
}

/// One surface of a lens prescription.
#[derive(Clone, Debug, PartialEq)]
pub struct LensSurface {
    /// Radius of curvature, mm: positive with the centre of curvature on the film side, 0 for flat (and the stop).
    pub radius_mm: f64,
    /// Axial distance to the next surface (or to the film for the last), mm.
    pub thickness_mm: f64,
    /// The medium behind the surface, towards the film.
    pub medium: LensMedium,
    /// Clear aperture diameter, mm.
    pub aperture_mm: f64,
    /// True for the aperture stop (radius 0 and index 0).
    pub is_stop: bool,
    /// Thin films on the surface, outermost first (empty: bare).
    pub coating: Vec<CoatingLayerSpec>,
    /// The 1-based line of the file the surface was read from.
    pub line: usize,
}

/// A lens: its surfaces from the object side to the film.
#[derive(Clone, Debug, PartialEq)]
pub struct LensPrescription {
    /// The surfaces, front (object side) first.
    pub surfaces: Vec<LensSurface>,
}

/// Where in a lens file an error is, and what it is.
#[derive(Clone, Debug, PartialEq)]
pub struct LensFileError {
    /// 1-based line.
    pub line: usize,
    /// 1-based column (in characters).
    pub column: usize,
    /// What is wrong, in words.
    pub message: String,
}

impl fmt::Display for LensFileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}: {}", self.line, self.column, self.message)
    }
}

impl std::error::Error for LensFileError {}

/// A token of the file and where it starts.
struct Token<'a> {
    text: &'a str,
    line: usize,
    column: usize,
}

fn tokens(text: &str) -> Vec<Token<'_>> {
    let mut out = Vec::new();
    for (l, raw) in text.lines().enumerate() {
        let content = raw.split('#').next().unwrap_or("");
        let mut rest = content;
        let mut offset = 0;
        while let Some(start) = rest.find(|c: char| !c.is_whitespace()) {
            let after = &rest[start..];
            let len = after.find(char::is_whitespace).unwrap_or(after.len());
            let column = content[..offset + start].chars().count() + 1;
            out.push(Token { text: &after[..len], line: l + 1, column });
            offset += start + len;
            rest = &after[len..];
        }
    }
    out
}

fn error(t: &Token<'_>, message: impl Into<String>) -> LensFileError {
    LensFileError { line: t.line, column: t.column, message: message.into() }
}

fn number(t: &Token<'_>, what: &str) -> Result<f64, LensFileError> {
    match t.text.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(error(t, format!("{what}: expected a number, got '{}'", t.text))),
    }
}

/// A material by name: a catalogue entry (underscores for spaces), an Abbe pair `nd/Vd`, or a number.
fn material(text: &str) -> Result<Ior, OpticsError> {
    if let Ok(n) = text.parse::<f64>() {
        return Ior::constant(n);
    }
    if let Some((nd, vd)) = text.split_once('/') {
        if let (Ok(nd), Ok(vd)) = (nd.parse::<f64>(), vd.parse::<f64>()) {
            return Ior::abbe(nd, vd);
        }
    }
    Ok(catalogue::lookup(&text.replace('_', " "))?.ior)
}

fn medium(t: &Token<'_>) -> Result<LensMedium, LensFileError> {
    if let Ok(n) = t.text.parse::<f64>() {
        if !n.is_finite() || n < 0.0 || (n > 0.0 && n < 1.0) {
            return Err(error(t, format!("index: must be 0 (air) or at least 1, got {n}")));
        }
        return Ok(if n == 0.0 || n == 1.0 {
            LensMedium::Air
        } else {
            LensMedium::Glass(Ior::constant(n).map_err(|e| error(t, format!("index: {e}")))?)
        });
    }
    let ior = material(t.text).map_err(|e| error(t, format!("index: {e}")))?;
    if ior.is_complex() {
        return Err(error(t, format!("index: '{}' is a metal, not a glass", t.text)));
    }
    Ok(LensMedium::Glass(ior))
}

fn coating(t: &Token<'_>) -> Result<Vec<CoatingLayerSpec>, LensFileError> {
    let mut layers = Vec::new();
    for part in t.text.split('+') {
        let Some((name, d)) = part.split_once('@') else {
            return Err(error(t, format!("coating: expected MATERIAL@THICKNESS_NM, got '{part}'")));
        };
        let thickness_nm = match d.parse::<f64>() {
            Ok(v) if v.is_finite() && v >= 0.0 => v,
            _ => return Err(error(t, format!("coating: '{d}' is not a thickness ≥ 0 nm (in '{part}')"))),
        };
        let ior = material(name).map_err(|e| error(t, format!("coating: {e}")))?;
        layers.push(CoatingLayerSpec { name: name.to_owned(), ior, thickness_nm });
    }
    Ok(layers)
}

fn surface(row: &[Token<'_>]) -> Result<LensSurface, LensFileError> {
    let radius_mm = number(&row[0], "radius")?;
    let thickness_mm = number(&row[1], "thickness")?;
    if thickness_mm < 0.0 {
        return Err(error(&row[1], format!("thickness: must be ≥ 0 mm, got {thickness_mm}")));
    }
    let index_is_zero = row[2].text.parse::<f64>() == Ok(0.0);
    let medium = medium(&row[2])?;
    let aperture_mm = number(&row[3], "aperture diameter")?;
    if aperture_mm <= 0.0 {
        return Err(error(&row[3], format!("aperture diameter: must be > 0 mm, got {aperture_mm}")));
    }
    if radius_mm != 0.0 && aperture_mm > 2.0 * radius_mm.abs() {
        return Err(error(
            &row[3],
            format!("aperture diameter {aperture_mm} mm exceeds the surface's sphere (radius {radius_mm} mm)"),
        ));
    }
    let coating = match row.get(4) {
        Some(t) => coating(t)?,
        None => Vec::new(),
    };
    let is_stop = radius_mm == 0.0 && index_is_zero;
    if is_stop && !coating.is_empty() {
        return Err(error(&row[4], "coating: the aperture stop is not a surface"));
    }
    Ok(LensSurface { radius_mm, thickness_mm, medium, aperture_mm, is_stop, coating, line: row[0].line })
}

impl LensPrescription {
    /// Reads a lens file's text (see the module documentation).
    pub fn parse(text: &str) -> Result<Self, LensFileError> {
        let all = tokens(text);
        if all.is_empty() {
            return Err(LensFileError { line: 1, column: 1, message: "no surfaces in the lens file".into() });
        }
        let numeric = all.iter().all(|t| t.text.parse::<f64>().is_ok());
        let mut surfaces = Vec::new();
        if numeric {
            // pbrt-v4: a stream of numbers, four per surface.
            if !all.len().is_multiple_of(4) {
                let t = &all[all.len() - all.len() % 4];
                return Err(error(
                    t,
                    format!(
                        "{} numbers: a lens file needs four per surface (radius, thickness, index, aperture)",
                        all.len()
                    ),
                ));
            }
            for row in all.chunks(4) {
                surfaces.push(surface(row)?);
            }
        } else {
            let mut line_start = 0;
            while line_start < all.len() {
                let line = all[line_start].line;
                let end = all[line_start..].iter().position(|t| t.line != line).map_or(all.len(), |k| line_start + k);
                let row = &all[line_start..end];
                if row.len() != 4 && row.len() != 5 {
                    return Err(error(
                        &row[0],
                        format!(
                            "{} values on this line: a surface is radius, thickness, index, aperture diameter and an \
                             optional coating",
                            row.len()
                        ),
                    ));
                }
                surfaces.push(surface(row)?);
                line_start = end;
            }
        }
        let stops = surfaces.iter().filter(|s| s.is_stop).count();
        if stops > 1 {
            let s = surfaces.iter().filter(|s| s.is_stop).nth(1).expect("two stops");
            return Err(LensFileError { line: s.line, column: 1, message: "a second aperture stop".into() });
        }
        Ok(Self { surfaces })
    }

    /// The index of the medium in front of surface `i` (towards the object) at `lambda_nm`.
    pub fn index_before(&self, i: usize, lambda_nm: f64) -> f64 {
        if i == 0 {
            1.0
        } else {
            self.surfaces[i - 1].medium.n(lambda_nm)
        }
    }

    /// The total axial length from the front surface to the film plane, mm.
    pub fn length_mm(&self) -> f64 {
        self.surfaces.iter().map(|s| s.thickness_mm).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_pbrt_numbers_and_prismatic_rows() {
        // pbrt-v4's form: numbers only, line breaks not significant.
        let pbrt = "# a singlet\n 50 5 1.5 20\n -50\n 45 0 20\n";
        let lens = LensPrescription::parse(pbrt).unwrap();
        assert_eq!(lens.surfaces.len(), 2);
        assert_eq!(lens.surfaces[0].medium, LensMedium::Glass(Ior::constant(1.5).unwrap()));
        assert_eq!(lens.surfaces[1].medium, LensMedium::Air);
        assert_eq!(lens.length_mm(), 50.0);
        // Prismatic's rows: catalogue glass, Abbe pair, a stop, coatings.
        let rows =
            "61.07 6.0 N-BK7 25.4 MgF2@99.6\n-47.68 2.5 SF5 25.4\n-178.6 3.0 1.6/40 25.4 MgF2@92.4+zirconia@117.7\n\
                    0 10 0 15\n 0 90 1 25\n";
        let lens = LensPrescription::parse(rows).unwrap();
        assert_eq!(lens.surfaces.len(), 5);
        assert!(lens.surfaces[0].medium.is_dispersive());
        assert_eq!(lens.surfaces[0].coating.len(), 1);
        assert_eq!(lens.surfaces[2].coating[1].name, "zirconia");
        assert!((lens.surfaces[2].medium.n(587.5618) - 1.6).abs() < 1e-12);
        assert!(lens.surfaces[3].is_stop && !lens.surfaces[4].is_stop);
        assert_eq!(lens.index_before(1, 587.5618), lens.surfaces[0].medium.n(587.5618));
    }

    #[test]
    fn bad_lens_files_name_line_and_column() {
        for (text, at, says) in [
            ("", (1, 1), "no surfaces"),
            ("50 5 1.5 20\n-50 45 0", (2, 1), "four per surface"),
            ("50 5 N-BK7 20\n-50 45 0", (2, 1), "3 values"),
            ("50 5 N-BK8 20\n", (1, 6), "index"),
            ("50 5 gold 20\n", (1, 6), "metal"),
            ("50 -5 1.5 20\n", (1, 4), "thickness"),
            ("50 5 1.5 0\n", (1, 10), "aperture"),
            ("5 5 1.5 20\n", (1, 9), "exceeds"),
            ("50 5 0.5 20\n", (1, 6), "index"),
            ("50 5 N-BK7 20 MgF2\n", (1, 15), "MATERIAL@THICKNESS_NM"),
            ("50 5 N-BK7 20 MgF2@-3\n", (1, 15), "thickness"),
            ("50 5 N-BK7 20 unobtainium@90\n", (1, 15), "coating"),
            ("0 5 0 20 MgF2@99\n", (1, 10), "stop"),
            ("0 5 0 20\n0 5 0 20\n", (2, 1), "second aperture stop"),
            ("50 x 1.5 20\n", (1, 4), "thickness"),
        ] {
            let e = LensPrescription::parse(text).unwrap_err();
            assert_eq!((e.line, e.column), at, "{text:?}: {e}");
            assert!(e.message.contains(says), "{text:?}: {e}");
        }
    }
}

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
use crate::complex::Complex;
use crate::error::OpticsError;
use crate::ior::Ior;
use crate::thinfilm::{film_stack, film_stack_reversed, FilmLayer};

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

/// First-order (paraxial) properties of a lens at one wavelength: what a lens designer checks first.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Paraxial {
    /// Effective focal length, mm (positive: converging).
    pub efl_mm: f64,
    /// Back focal length: from the last surface to the focus of rays parallel to the axis, mm.
    pub bfl_mm: f64,
    /// Where that focus lies relative to the film plane of the prescription, mm (positive: behind the film).
    pub focus_behind_film_mm: f64,
    /// Entrance pupil: its position from the first surface (positive: towards the film), mm, and diameter, mm.
    pub entrance_pupil_mm: (f64, f64),
    /// Exit pupil: its position from the last surface (negative: in front of it), mm, and diameter, mm.
    pub exit_pupil_mm: (f64, f64),
    /// Focal ratio EFL / entrance pupil diameter.
    pub f_number: f64,
}

/// A paraxial ray: height y (mm) and slope u (the reduced angle n·u is conserved across a refraction's tangent).
#[derive(Clone, Copy, Debug)]
struct ParaxialRay {
    y: f64,
    u: f64,
}

impl LensPrescription {
    /// The index of the stop surface, if the prescription has one.
    pub fn stop(&self) -> Option<usize> {
        self.surfaces.iter().position(|s| s.is_stop)
    }

    /// Traces a paraxial ray from just before the front surface to just after surface `to` (inclusive), then along
    /// the following thickness when `transfer_last`: n′u′ = nu − y(n′ − n)/R at each surface, y ← y + u′t between them
    /// (the y-nu trace of first-order optics; e.g. Smith, *Modern Optical Engineering*, 4th ed., §2.6).
    fn trace_paraxial(&self, mut ray: ParaxialRay, to: usize, lambda_nm: f64, transfer_last: bool) -> ParaxialRay {
        for i in 0..=to {
            let s = &self.surfaces[i];
            let (n, n_after) = (self.index_before(i, lambda_nm), s.medium.n(lambda_nm));
            if !s.is_stop {
                let curvature = if s.radius_mm == 0.0 { 0.0 } else { 1.0 / s.radius_mm };
                ray.u = (n * ray.u - ray.y * (n_after - n) * curvature) / n_after;
            }
            if i < to || transfer_last {
                ray.y += ray.u * s.thickness_mm;
            }
        }
        ray
    }

    /// The linear map of rays at the front surface onto the stop, y_stop = a·y₀ + b·u₀, as (a, b): the chief ray,
    /// through the stop's centre, starts at y₀ = −(b/a)·u₀.
    fn onto_stop(&self, stop: usize, lambda_nm: f64) -> (f64, f64) {
        let at_stop = |y: f64, u: f64| self.trace_paraxial(ParaxialRay { y, u }, stop, lambda_nm, false).y;
        (at_stop(1.0, 0.0), at_stop(0.0, 1.0))
    }

    /// The paraxial properties at `lambda_nm`, or why there are none: no surfaces, an afocal lens, no stop (the
    /// pupils and f-number need one), or a last medium that is not air.
    pub fn paraxial(&self, lambda_nm: f64) -> Result<Paraxial, String> {
        let last = self.surfaces.len().checked_sub(1).ok_or("no surfaces")?;
        if self.surfaces[last].medium != LensMedium::Air {
            return Err("the last surface must be followed by air (the film side)".into());
        }
        // A ray parallel to the axis at height 1: its slope after the lens gives the focal length.
        let marginal = self.trace_paraxial(ParaxialRay { y: 1.0, u: 0.0 }, last, lambda_nm, false);
        if marginal.u.abs() < 1e-15 {
            return Err("the lens is afocal (parallel rays leave it parallel)".into());
        }
        let efl_mm = -1.0 / marginal.u;
        let bfl_mm = -marginal.y / marginal.u;
        let focus_behind_film_mm = bfl_mm - self.surfaces[last].thickness_mm;
        let stop = self.stop().ok_or("no aperture stop (a row with radius 0 and index 0)")?;
        let (a, b) = self.onto_stop(stop, lambda_nm);
        if a.abs() < 1e-15 {
            return Err("the stop is at a focus of the elements in front of it".into());
        }
        let stop_radius = 0.5 * self.surfaces[stop].aperture_mm;
        // The chief ray crosses the stop's centre: y₀ = −(b/a)·u₀; in object space it crosses the axis at z = b/a.
        let entrance_pupil = (b / a, 2.0 * stop_radius / a.abs());
        let chief = self.trace_paraxial(ParaxialRay { y: -b / a, u: 1.0 }, last, lambda_nm, false);
        if chief.u.abs() < 1e-15 {
            return Err("the exit pupil is at infinity (telecentric in image space)".into());
        }
        // In image space the chief ray crosses the axis at the exit pupil; the pupils' magnification is u₀/u′.
        let exit_pupil = (-chief.y / chief.u, entrance_pupil.1 * (1.0 / chief.u).abs());
        Ok(Paraxial {
            efl_mm,
            bfl_mm,
            focus_behind_film_mm,
            entrance_pupil_mm: entrance_pupil,
            exit_pupil_mm: exit_pupil,
            f_number: efl_mm.abs() / entrance_pupil.1,
        })
    }

    /// Lateral colour, mm: the height difference, in the paraxial focal plane at `reference_nm`, between the images
    /// at `lambda_a_nm` and `lambda_b_nm` of a distant point whose image at the reference wavelength lies
    /// `image_height_mm` from the axis (each wavelength's chief ray through the stop's centre).
    pub fn lateral_colour(
        &self,
        lambda_a_nm: f64,
        lambda_b_nm: f64,
        reference_nm: f64,
        image_height_mm: f64,
    ) -> Result<f64, String> {
        let reference = self.paraxial(reference_nm)?;
        let last = self.surfaces.len() - 1;
        let stop = self.stop().ok_or("no aperture stop")?;
        // The field angle's slope whose chief ray at the reference wavelength lands at the image height.
        let height = |lambda: f64, u0: f64| -> f64 {
            let (a, b) = self.onto_stop(stop, lambda);
            let chief = self.trace_paraxial(ParaxialRay { y: -b / a * u0, u: u0 }, last, lambda, false);
            chief.y + chief.u * reference.bfl_mm
        };
        let per_unit_slope = height(reference_nm, 1.0);
        if per_unit_slope.abs() < 1e-15 {
            return Err("no image height for any field angle".into());
        }
        let u0 = image_height_mm / per_unit_slope;
        Ok(height(lambda_a_nm, u0) - height(lambda_b_nm, u0))
    }
}

/// The cardinal points of a lens at one wavelength (Gaussian optics), as axial positions in mm from the front
/// vertex (positive towards the film), with its focal length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CardinalPoints {
    /// Front focal point F.
    pub front_focus: f64,
    /// Front principal plane H.
    pub front_principal: f64,
    /// Rear principal plane H′.
    pub rear_principal: f64,
    /// Rear focal point F′.
    pub rear_focus: f64,
    /// Effective focal length f (H′ to F′).
    pub focal_length: f64,
}

impl LensPrescription {
    /// The cardinal points at `lambda_nm`, from the paraxial system matrix between the front and last vertices:
    /// [y′, u′] = [[A, B], [C, D]]·[y, u] in air on both sides gives f = −1/C, F′ = z_last − A/C, F = D/C, and the
    /// principal planes one focal length from the foci (Hecht, *Optics*, §6.2).
    pub fn cardinal_points(&self, lambda_nm: f64) -> Result<CardinalPoints, String> {
        let last = self.surfaces.len().checked_sub(1).ok_or("no surfaces")?;
        let (a, c) = {
            let r = self.trace_paraxial(ParaxialRay { y: 1.0, u: 0.0 }, last, lambda_nm, false);
            (r.y, r.u)
        };
        let d = self.trace_paraxial(ParaxialRay { y: 0.0, u: 1.0 }, last, lambda_nm, false).u;
        if c.abs() < 1e-15 {
            return Err("the lens is afocal (parallel rays leave it parallel)".into());
        }
        let z_last = self.vertices_mm()[last];
        let focal_length = -1.0 / c;
        let (front_focus, rear_focus) = (d / c, z_last - a / c);
        Ok(CardinalPoints {
            front_focus,
            front_principal: front_focus + focal_length,
            rear_principal: rear_focus - focal_length,
            rear_focus,
            focal_length,
        })
    }

    /// The same lens with its film moved (the last thickness changed) so that a plane `focus_distance_mm` in front
    /// of the film is in focus at `lambda_nm`: with x the film's distance from H′ and K the object's distance from H
    /// plus x, the thick-lens equation 1/(K − x) + 1/x = 1/f gives x² − Kx + Kf = 0, whose root near f is the film
    /// (K = focus distance − HH′). pbrt-v4's realistic camera focuses the same way, from its thick-lens approximation.
    pub fn focused(&self, focus_distance_mm: f64, lambda_nm: f64) -> Result<LensPrescription, String> {
        let cp = self.cardinal_points(lambda_nm)?;
        let f = cp.focal_length;
        if f <= 0.0 {
            return Err(format!("a lens of negative focal length ({f:.3} mm) forms no real image to focus"));
        }
        let k = focus_distance_mm - (cp.rear_principal - cp.front_principal);
        if !(focus_distance_mm.is_finite() && k > 4.0 * f) {
            return Err(format!(
                "focus distance {focus_distance_mm} mm is too close: this lens (f = {f:.3} mm) focuses no nearer \
                 than {:.3} mm from its film",
                4.0 * f + cp.rear_principal - cp.front_principal
            ));
        }
        let x = 0.5 * (k - (k * k - 4.0 * k * f).sqrt());
        let last = self.surfaces.len() - 1;
        let back = cp.rear_principal + x - self.vertices_mm()[last];
        if back <= 0.0 {
            return Err(format!("focused at {focus_distance_mm} mm the film would lie inside the lens"));
        }
        let mut lens = self.clone();
        lens.surfaces[last].thickness_mm = back;
        Ok(lens)
    }
}

impl LensPrescription {
    /// The box on the rear element's vertex plane, (x₀, x₁, y₀, y₁) in mm, through which rays from film points
    /// between `film_radius_mm.0` and `.1` from the axis (on the +x axis) reach the scene at any of `lambdas_nm`:
    /// found as pbrt-v4's realistic camera finds it, by tracing rays from
    /// `film_points` film points in the ring aimed at a grid of `aims`² points over 1.5 times the rear aperture, then
    /// (where pbrt-v4 takes a million aims) again over that box widened by one grid cell, with `aims`² aims, and
    /// widened by twice the finer cell's diagonal so that rays between grid points are not cut off. Aims inside the
    /// box found so far are not traced.
    /// `None` if no ray gets through (the lens vignettes that whole ring). A camera samples the rear element only
    /// inside the box of each film ring, and rotates it for film points off the +x axis (the lens is round).
    pub fn exit_pupil_bounds(
        &self,
        film_radius_mm: (f64, f64),
        lambdas_nm: &[f64],
        (film_points, aims): (usize, usize),
    ) -> Option<[f64; 4]> {
        let last = self.surfaces.len().checked_sub(1)?;
        let z_last = self.vertices_mm()[last];
        let z_film = self.length_mm();
        // The box of the aims over `area` that get through, and the grid's cell size.
        let search = |area: [f64; 4]| -> (Option<[f64; 4]>, [f64; 2]) {
            let step = [(area[1] - area[0]) / aims as f64, (area[3] - area[2]) / aims as f64];
            let mut bounds: Option<[f64; 4]> = None;
            for k in 0..film_points {
                let r =
                    film_radius_mm.0 + (film_radius_mm.1 - film_radius_mm.0) * (k as f64 + 0.5) / film_points as f64;
                for i in 0..aims {
                    for j in 0..aims {
                        let (x, y) = (area[0] + (i as f64 + 0.5) * step[0], area[2] + (j as f64 + 0.5) * step[1]);
                        if bounds.is_some_and(|b| x >= b[0] && x <= b[1] && y >= b[2] && y <= b[3]) {
                            continue;
                        }
                        let ray = LensRay::towards([r, 0.0, z_film], [x, y, z_last]);
                        if lambdas_nm.iter().any(|&l| self.trace(ray, l, false, None, false).is_some()) {
                            let b = bounds.get_or_insert([x, x, y, y]);
                            *b = [b[0].min(x), b[1].max(x), b[2].min(y), b[3].max(y)];
                        }
                    }
                }
            }
            (bounds, step)
        };
        // The aims first cover 1.5 times the rear aperture's radius, as pbrt-v4's do: a rear surface that bulges
        // towards the film is crossed within its aperture by rays aimed beyond it on the vertex plane.
        let rear = 1.5 * 0.5 * self.surfaces[last].aperture_mm;
        let (coarse, step) = search([-rear, rear, -rear, rear]);
        let c = coarse?;
        let (fine, step) = search([c[0] - step[0], c[1] + step[0], c[2] - step[1], c[3] + step[1]]);
        // pbrt-v4 widens by twice the grid cell's diagonal.
        let widen = 2.0 * step[0].hypot(step[1]);
        fine.map(|b| [b[0] - widen, b[1] + widen, b[2] - widen, b[3] + widen])
    }
}

/// A ray in lens space: z along the optical axis towards the film, 0 at the front surface's vertex; mm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LensRay {
    /// A point on the ray, mm.
    pub origin: [f64; 3],
    /// Its unit direction.
    pub direction: [f64; 3],
}

impl LensRay {
    /// The ray from `origin` towards the point `target` (which must differ from it).
    pub fn towards(origin: [f64; 3], target: [f64; 3]) -> Self {
        let d = [target[0] - origin[0], target[1] - origin[1], target[2] - origin[2]];
        let len = dot(d, d).sqrt();
        Self { origin, direction: [d[0] / len, d[1] / len, d[2] / len] }
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn along(o: [f64; 3], d: [f64; 3], t: f64) -> [f64; 3] {
    [o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]]
}

impl LensPrescription {
    /// The axial position of each surface's vertex, mm from the front surface.
    pub fn vertices_mm(&self) -> Vec<f64> {
        let mut z = 0.0;
        self.surfaces
            .iter()
            .map(|s| {
                let at = z;
                z += s.thickness_mm;
                at
            })
            .collect()
    }

    /// Where `ray` meets surface `i` (vertex at `z`), and the surface's unit normal there facing against the ray;
    /// `None` if it misses the surface. The aperture is checked by the caller.
    fn hit(&self, i: usize, z: f64, ray: &LensRay) -> Option<([f64; 3], [f64; 3])> {
        let s = &self.surfaces[i];
        let (o, d) = (ray.origin, ray.direction);
        let (p, mut normal) = if s.radius_mm == 0.0 {
            if d[2] == 0.0 {
                return None;
            }
            (along(o, d, (z - o[2]) / d[2]), [0.0, 0.0, -1.0])
        } else {
            // The sphere of radius R centred at z + R; of its two crossings, the one on the vertex's side of the
            // centre: (z_hit − z_centre)·(−R) > 0.
            let c = z + s.radius_mm;
            let oc = [o[0], o[1], o[2] - c];
            let b = dot(oc, d);
            let disc = b * b - (dot(oc, oc) - s.radius_mm * s.radius_mm);
            if disc < 0.0 {
                return None;
            }
            let root = disc.sqrt();
            let p =
                [-b - root, -b + root].into_iter().map(|t| along(o, d, t)).find(|p| (p[2] - c) * -s.radius_mm > 0.0)?;
            let n = [p[0] / s.radius_mm, p[1] / s.radius_mm, (p[2] - c) / s.radius_mm];
            // Outward from the centre for R > 0 is towards the object; flipped below to face the ray either way.
            (p, [-n[0], -n[1], -n[2]])
        };
        if dot(normal, d) > 0.0 {
            normal = [-normal[0], -normal[1], -normal[2]];
        }
        Some((p, normal))
    }

    /// Traces `ray` through every surface, front to film when `forward`, film to front otherwise, refracting with
    /// each medium's n(`lambda_nm`) by Snell's law in vector form (as pbrt-v4's `Refract`): the ray leaving the last
    /// surface crossed, the stop's transmission there (1 for a clear circular stop, else `stop`'s), and, with
    /// `fresnel`, the product of the surfaces' transmittances (else 1). `None` where it misses a surface or its
    /// clear aperture, is totally reflected, or the stop's mask is 0 there.
    fn trace(
        &self,
        ray: LensRay,
        lambda_nm: f64,
        forward: bool,
        stop: Option<StopMask<'_>>,
        fresnel: bool,
    ) -> Option<(LensRay, f64, f64)> {
        let [out] = self.trace_many(ray, [lambda_nm], forward, stop, fresnel);
        out
    }

    /// [`LensPrescription::trace`] of one ray at each of `lambdas_nm`, surface by surface for all of them at once:
    /// a ray's way through a lens is one long chain of square roots and divisions, and tracing the wavelengths side
    /// by side lets the processor overlap their chains.
    #[inline(always)]
    fn trace_many<const N: usize>(
        &self,
        ray: LensRay,
        lambdas_nm: [f64; N],
        forward: bool,
        stop: Option<StopMask<'_>>,
        fresnel: bool,
    ) -> [Option<(LensRay, f64, f64)>; N] {
        let count = self.surfaces.len();
        let mut state: [Option<(LensRay, f64, f64)>; N] = [Some((ray, 1.0, 1.0)); N];
        // Each surface's vertex, followed along the way rather than collected: no allocation per ray.
        let mut z =
            if forward { 0.0 } else { self.surfaces[..count.saturating_sub(1)].iter().map(|s| s.thickness_mm).sum() };
        for step in 0..count {
            let i = if forward { step } else { count - 1 - step };
            if !forward && step > 0 {
                z -= self.surfaces[i].thickness_mm;
            }
            for (slot, &lambda_nm) in state.iter_mut().zip(&lambdas_nm) {
                if let Some(s) = slot {
                    if !self.cross(i, z, forward, stop, fresnel, lambda_nm, s) {
                        *slot = None;
                    }
                }
            }
            if forward {
                z += self.surfaces[i].thickness_mm;
            }
        }
        state
    }

    /// One ray (with its stop weight and transmittance so far) across surface `i`, whose vertex is at `z`; false
    /// if the surface stops it (see [`LensPrescription::trace`]).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn cross(
        &self,
        i: usize,
        z: f64,
        forward: bool,
        stop: Option<StopMask<'_>>,
        fresnel: bool,
        lambda_nm: f64,
        (ray, weight, transmittance): &mut (LensRay, f64, f64),
    ) -> bool {
        let Some((p, m)) = self.hit(i, z, ray) else { return false };
        let surface = &self.surfaces[i];
        let radius = 0.5 * surface.aperture_mm;
        match stop {
            // pbrt-v4's aperture image replaces the stop's circle: its value over the square [−r, r]².
            Some(mask) if surface.is_stop => {
                *weight = mask(p[0] / radius, p[1] / radius);
                if *weight <= 0.0 {
                    return false;
                }
            }
            _ => {
                if p[0] * p[0] + p[1] * p[1] > radius * radius {
                    return false;
                }
            }
        }
        ray.origin = p;
        if surface.is_stop {
            return true;
        }
        let (before, after) = (self.index_before(i, lambda_nm), surface.medium.n(lambda_nm));
        let (n_i, n_t) = if forward { (before, after) } else { (after, before) };
        let mu = n_i / n_t;
        // t = μd + (μ cos θi − cos θt) m, with m facing against d (Snell's law in vector form).
        let d = ray.direction;
        let cos_i = -dot(m, d);
        let sin2_t = mu * mu * (1.0 - cos_i * cos_i);
        if sin2_t > 1.0 {
            return false;
        }
        if fresnel {
            *transmittance *= self.surface_transmittance(i, forward, (n_i, n_t), cos_i, lambda_nm);
        }
        let k = mu * cos_i - (1.0 - sin2_t).sqrt();
        ray.direction = [mu * d[0] + k * m[0], mu * d[1] + k * m[1], mu * d[2] + k * m[2]];
        true
    }

    /// The transmittance of surface `i` and its coating, crossed towards the film when `forward`, from index
    /// `n.0` into `n.1` at incidence cosine `cos_i`: the transfer-matrix method of [`crate::film_stack`] (Fresnel's
    /// for a bare surface), s and p averaged, as if the light were unpolarised at every surface (the usual estimate
    /// of a lens's transmission; the exact one would carry the polarisation from surface to surface).
    fn surface_transmittance(&self, i: usize, forward: bool, n: (f64, f64), cos_i: f64, lambda_nm: f64) -> f64 {
        let coating = &self.surfaces[i].coating;
        // Coatings are short: their layers at this wavelength are kept on the stack.
        const MAX_ON_STACK: usize = 16;
        let mut on_stack = [FilmLayer::new(Complex::from_real(1.0), 0.0); MAX_ON_STACK];
        let on_heap: Vec<FilmLayer>;
        let layers: &[FilmLayer] = if coating.len() <= MAX_ON_STACK {
            for (slot, c) in on_stack.iter_mut().zip(coating) {
                *slot = FilmLayer::new(c.ior.complex_value(lambda_nm), c.thickness_nm);
            }
            &on_stack[..coating.len()]
        } else {
            on_heap = coating.iter().map(|c| FilmLayer::new(c.ior.complex_value(lambda_nm), c.thickness_nm)).collect();
            &on_heap
        };
        let r = if forward {
            film_stack(n.0, layers, Complex::from_real(n.1), cos_i, lambda_nm)
        } else {
            // Layers are listed from the object side; from the film they are met last first.
            film_stack_reversed(n.0, layers, Complex::from_real(n.1), cos_i, lambda_nm)
        };
        r.transmittance()
    }

    /// Traces a ray from the object side through every surface towards the film: the ray leaving the last surface.
    pub fn trace_from_object(&self, ray: LensRay, lambda_nm: f64) -> Option<LensRay> {
        self.trace(ray, lambda_nm, true, None, false).map(|(r, _, _)| r)
    }

    /// Traces a ray from the film side back through every surface: the ray leaving the front surface towards the
    /// scene (what a camera does with a ray from a point on its film).
    pub fn trace_from_film(&self, ray: LensRay, lambda_nm: f64) -> Option<LensRay> {
        self.trace(ray, lambda_nm, false, None, false).map(|(r, _, _)| r)
    }

    /// [`LensPrescription::trace_from_film`] with what the lens lets through: the ray leaving the front surface,
    /// and the fraction of light it carries, the product of the stop's transmission (1 inside its circle, or
    /// `stop`'s mask for a shaped diaphragm, as pbrt-v4's aperture images) and, with `fresnel`, every surface's
    /// transmittance with its coating at `lambda_nm` (light is lost to reflection at each surface; pbrt-v4's
    /// realistic camera leaves this out).
    pub fn trace_from_film_through(
        &self,
        ray: LensRay,
        lambda_nm: f64,
        stop: Option<StopMask<'_>>,
        fresnel: bool,
    ) -> Option<(LensRay, f64)> {
        self.trace(ray, lambda_nm, false, stop, fresnel).map(|(r, w, t)| (r, w * t))
    }

    /// [`LensPrescription::trace_from_film_through`] at each of `lambdas_nm` (one ray from the film, refracted by
    /// each wavelength's indices), traced side by side: cheaper than one trace after another.
    pub fn trace_from_film_many<const N: usize>(
        &self,
        ray: LensRay,
        lambdas_nm: [f64; N],
        stop: Option<StopMask<'_>>,
        fresnel: bool,
    ) -> [Option<(LensRay, f64)>; N] {
        self.trace_many(ray, lambdas_nm, false, stop, fresnel).map(|o| o.map(|(r, w, t)| (r, w * t)))
    }
}

/// A shaped aperture stop: its transmission at (x/r, y/r) for a point (x, y) on the stop's plane and r the stop's
/// radius; it may be non-zero anywhere in the square [−1, 1]², and its circle no longer applies.
pub type StopMask<'a> = &'a (dyn Fn(f64, f64) -> f64 + Sync);

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

    /// A singlet of index n, radii R1 and R2 and thickness d, stop at its front surface, film at `back` mm.
    fn singlet(glass: &str, r1: f64, r2: f64, d: f64, back: f64) -> LensPrescription {
        LensPrescription::parse(&format!("0 0 0 20\n{r1} {d} {glass} 25\n{r2} {back} 1 25\n")).unwrap()
    }

    #[test]
    fn a_singlets_paraxial_figures_are_the_thick_lens_equations() {
        // 1/f = (n − 1)[1/R1 − 1/R2 + (n − 1)d/(n R1 R2)], BFL = f(1 − (n − 1)d/(n R1)) (Hecht, Optics, §6.1).
        for (r1, r2, d) in [(50.0, -50.0, 5.0), (60.0, 0.0, 4.0), (40.0, 120.0, 6.0), (-80.0, 30.0, 3.0)] {
            let lens = singlet("1.5168", r1, r2, d, 90.0);
            let p = lens.paraxial(587.5618).unwrap();
            let n = 1.5168;
            let inv_r = |r: f64| if r == 0.0 { 0.0 } else { 1.0 / r };
            let f = 1.0 / ((n - 1.0) * (inv_r(r1) - inv_r(r2) + (n - 1.0) * d * inv_r(r1) * inv_r(r2) / n));
            let bfl = f * (1.0 - (n - 1.0) * d * inv_r(r1) / n);
            assert!((p.efl_mm - f).abs() < 1e-9 * f.abs(), "{r1} {r2} {d}: {} vs {f}", p.efl_mm);
            assert!((p.bfl_mm - bfl).abs() < 1e-9 * f.abs(), "{r1} {r2} {d}: {} vs {bfl}", p.bfl_mm);
            assert!((p.focus_behind_film_mm - (bfl - 90.0)).abs() < 1e-9 * f.abs());
            // The stop sits on the first surface: the entrance pupil is the stop itself, f-number f/20.
            assert!(p.entrance_pupil_mm.0.abs() < 1e-12 && (p.entrance_pupil_mm.1 - 20.0).abs() < 1e-12);
            assert!((p.f_number - f.abs() / 20.0).abs() < 1e-9);
        }
    }

    #[test]
    fn a_singlets_colour_focus_shift_is_about_f_over_abbe_and_an_achromat_cancels_it() {
        // A thin singlet's focal length varies as 1/(n − 1): f_F − f_C ≈ −f/V_d (Smith §10.2). N-BK7, V_d 64.17.
        let lens = singlet("N-BK7", 103.36, -103.36, 2.0, 100.0);
        let (f, c, d) = (
            lens.paraxial(crate::LAMBDA_F_NM).unwrap(),
            lens.paraxial(crate::LAMBDA_C_NM).unwrap(),
            lens.paraxial(crate::LAMBDA_D_NM).unwrap(),
        );
        let shift = f.bfl_mm - c.bfl_mm;
        let vd = crate::catalogue::lookup("N-BK7").unwrap().ior.vd();
        assert!((shift - (-d.efl_mm / vd)).abs() < 0.03 * d.efl_mm / vd, "{shift} vs {}", -d.efl_mm / vd);
        // A cemented achromat from the thin-lens conditions φ₁ + φ₂ = φ, φ₁/V₁ + φ₂/V₂ = 0 (N-BK7 crown, F2 flint,
        // f = 100 mm, equiconvex crown): F and C focus within a twentieth of the singlet's shift.
        let cat = |n: &str| crate::catalogue::lookup(n).unwrap().ior;
        let (crown, flint) = (cat("N-BK7"), cat("F2"));
        let (v1, v2) = (crown.vd(), flint.vd());
        let phi = 0.01;
        let (phi1, phi2) = (phi * v1 / (v1 - v2), -phi * v2 / (v1 - v2));
        let (n1, n2) = (crown.nd() - 1.0, flint.nd() - 1.0);
        let r1 = 2.0 * n1 / phi1; // equiconvex crown: φ₁ = (n₁ − 1)·2/R
        let r2 = -r1;
        // Flint: φ₂ = (n₂ − 1)(1/R2 − 1/R3).
        let r3 = 1.0 / (1.0 / r2 - phi2 / n2);
        let achromat =
            LensPrescription::parse(&format!("0 0 0 20\n{r1} 4 N-BK7 25\n{r2} 2 F2 25\n{r3} 97 1 25\n")).unwrap();
        let residual = achromat.paraxial(crate::LAMBDA_F_NM).unwrap().bfl_mm
            - achromat.paraxial(crate::LAMBDA_C_NM).unwrap().bfl_mm;
        assert!(residual.abs() < shift.abs() / 20.0, "achromat F − C {residual} vs singlet {shift}");
        // With the stop at the lens the chief ray crosses it undeviated: no lateral colour to first order; with the
        // stop 30 mm in front, the singlet has some.
        assert!(
            lens.lateral_colour(crate::LAMBDA_F_NM, crate::LAMBDA_C_NM, crate::LAMBDA_D_NM, 20.0).unwrap().abs() < 0.05
        );
        let ahead = LensPrescription::parse("0 30 0 10\n103.36 2 N-BK7 25\n-103.36 100 1 25\n").unwrap();
        let lateral = ahead.lateral_colour(crate::LAMBDA_F_NM, crate::LAMBDA_C_NM, crate::LAMBDA_D_NM, 20.0).unwrap();
        assert!(lateral.abs() > 0.05, "{lateral}");
    }

    /// Where a traced ray crosses the axis (its height's zero), mm from the front surface.
    fn axis_crossing(r: &LensRay) -> f64 {
        r.origin[2] - r.origin[1] * r.direction[2] / r.direction[1]
    }

    #[test]
    fn real_rays_agree_with_the_paraxial_focus_near_the_axis_and_show_spherical_aberration() {
        let lens = singlet("N-BK7", 51.5, 0.0, 3.6, 97.6);
        let vertex_last = lens.vertices_mm()[2];
        for lambda in [crate::LAMBDA_F_NM, crate::LAMBDA_D_NM, crate::LAMBDA_C_NM] {
            let bfl = lens.paraxial(lambda).unwrap().bfl_mm;
            let ray = |h: f64| LensRay { origin: [0.0, h, -10.0], direction: [0.0, 0.0, 1.0] };
            let near = lens.trace_from_object(ray(0.01), lambda).unwrap();
            let focus = axis_crossing(&near) - vertex_last;
            assert!((focus - bfl).abs() < 1e-4, "{lambda} nm: real {focus} vs paraxial {bfl}");
            // A convex singlet is undercorrected: the marginal rays focus shorter than the paraxial focus, by
            // roughly the square of the height (third-order spherical aberration).
            let (f5, f9) = [5.0, 9.0]
                .map(|h| axis_crossing(&lens.trace_from_object(ray(h), lambda).unwrap()) - vertex_last)
                .into();
            assert!(f5 < bfl && f9 < f5, "{lambda}: {f9} < {f5} < {bfl}");
            let ratio = (bfl - f9) / (bfl - f5);
            assert!((ratio - 81.0 / 25.0).abs() < 0.3, "{ratio}");
            // Beyond the clear aperture the ray is stopped.
            assert!(lens.trace_from_object(ray(10.5), lambda).is_none());
        }
    }

    #[test]
    fn a_ray_traced_back_from_the_film_retraces_its_path() {
        let lens =
            LensPrescription::parse("0 4 0 18\n61.07 6.0 N-BK7 25.4\n-47.68 2.5 F2 25.4\n-178.6 95 1 25.4\n").unwrap();
        let norm = |d: [f64; 3]| {
            let l = dot(d, d).sqrt();
            [d[0] / l, d[1] / l, d[2] / l]
        };
        for (h, tilt) in [(0.0, 0.02), (3.0, -0.05), (6.0, 0.1), (-7.0, 0.0)] {
            for lambda in [420.0, 550.0, 700.0] {
                let start = LensRay { origin: [0.5, h, -20.0], direction: norm([0.01, tilt, 1.0]) };
                let out = lens.trace_from_object(start, lambda).unwrap();
                let back = lens
                    .trace_from_film(LensRay { origin: out.origin, direction: out.direction.map(|v| -v) }, lambda)
                    .unwrap();
                // Back at the front surface, going the other way along the same line.
                for k in 0..3 {
                    assert!((back.direction[k] + start.direction[k]).abs() < 1e-12, "{h} {tilt} {lambda}");
                }
                let t = (back.origin[2] - start.origin[2]) / start.direction[2];
                let on_line = along(start.origin, start.direction, t);
                assert!((0..3).all(|k| (on_line[k] - back.origin[k]).abs() < 1e-9), "{h} {tilt} {lambda}");
            }
        }
    }

    #[test]
    fn cardinal_points_and_focusing_put_the_object_plane_on_the_film() {
        let lens =
            LensPrescription::parse("0 4 0 18\n61.07 6.0 N-BK7 25.4\n-47.68 2.5 F2 25.4\n-178.6 95 1 25.4\n").unwrap();
        let lambda = crate::LAMBDA_D_NM;
        let cp = lens.cardinal_points(lambda).unwrap();
        let p = lens.paraxial(lambda).unwrap();
        assert!((cp.focal_length - p.efl_mm).abs() < 1e-9);
        assert!((cp.rear_focus - lens.vertices_mm()[3] - p.bfl_mm).abs() < 1e-9);
        // Thin-lens check of the principal planes of a thin singlet: both at its centre.
        let thin = singlet("1.5", 100.0, -100.0, 1e-6, 100.0);
        let t = thin.cardinal_points(lambda).unwrap();
        assert!((t.front_principal - 5e-7).abs() < 1e-5 && (t.rear_principal - 5e-7).abs() < 1e-5, "{t:?}");
        for distance in [500.0, 1000.0, 1e7] {
            let focused = lens.focused(distance, lambda).unwrap();
            let z = focused.vertices_mm();
            let film = z[3] + focused.surfaces[3].thickness_mm;
            // A ray from the axial object point reaching the lens 0.02 mm from the axis (where spherical aberration,
            // about 0.01 mm per mm² of height here, is negligible) crosses the axis at the film.
            let object = film - distance;
            let u: f64 = 0.02 / distance;
            let ray = LensRay { origin: [0.0, 0.0, object], direction: [0.0, u.sin(), u.cos()] };
            let out = focused.trace_from_object(ray, lambda).unwrap();
            let crossing = axis_crossing(&out);
            assert!((crossing - film).abs() < 1e-4, "{distance} mm: crossing {crossing} vs film {film}");
        }
        // Too close: an error saying how close it can focus.
        let e = lens.focused(200.0, lambda).unwrap_err();
        assert!(e.contains("too close"), "{e}");
    }

    #[test]
    fn an_axial_ray_loses_each_surfaces_fresnel_reflection_and_a_quarter_wave_coating_cuts_it() {
        // On the axis every surface is met at normal incidence: the bare flat rear loses ((n − 1)/(n + 1))², and the
        // front, under a layer of index 1.38 whose optical thickness is a quarter of 549.78 nm, loses
        // ((n₀n_s − n₁²)/(n₀n_s + n₁²))² at that wavelength.
        let lens = LensPrescription::parse("0 5 0 20\n51.5 3.6 N-BK7 25.4 1.38@99.6\n0 97.6 1 25.4\n").unwrap();
        let lambda = 4.0 * 1.38 * 99.6;
        let n = lens.surfaces[1].medium.n(lambda);
        let axial = LensRay { origin: [0.0, 0.0, lens.length_mm()], direction: [0.0, 0.0, -1.0] };
        let (_, t) = lens.trace_from_film_through(axial, lambda, None, true).unwrap();
        let r_rear = ((n - 1.0) / (n + 1.0)).powi(2);
        let r_front = ((n - 1.38 * 1.38) / (n + 1.38 * 1.38)).powi(2);
        assert!((t - (1.0 - r_rear) * (1.0 - r_front)).abs() < 1e-9, "{t}");
        // Without the coating the front loses as much as the rear; without Fresnel nothing is lost.
        let bare = LensPrescription::parse("0 5 0 20\n51.5 3.6 N-BK7 25.4\n0 97.6 1 25.4\n").unwrap();
        let (_, t_bare) = bare.trace_from_film_through(axial, lambda, None, true).unwrap();
        assert!((t_bare - (1.0 - r_rear).powi(2)).abs() < 1e-9 && t_bare < t, "{t_bare}");
        assert_eq!(lens.trace_from_film_through(axial, lambda, None, false).unwrap().1, 1.0);
    }

    #[test]
    fn no_ray_aimed_outside_the_exit_pupil_bounds_gets_through() {
        let lens = LensPrescription::parse(
            "29.475 3.76 1.670/47.1 25.2\n84.83 0.12 1 25.2\n19.275 4.025 1.670/47.1 23.0\n40.77 3.275 1.699/30.1 23.0\n\
             12.75 5.705 1 18.0\n0 4.5 0 17.1\n-14.495 1.18 1.603/38.0 17.0\n40.77 6.065 1.658/57.3 20.0\n\
             -20.385 0.19 1 20.0\n437.065 3.22 1.717/48.0 20.0\n-39.73 36.114 1 20.0\n",
        )
        .unwrap();
        let lambdas = [450.0, 550.0, 650.0];
        let (z_last, z_film) = (lens.vertices_mm()[10], lens.length_mm());
        let mut areas = Vec::new();
        for ring in [(0.0, 0.5), (10.0, 10.5), (20.0, 20.5)] {
            let b = lens.exit_pupil_bounds(ring, &lambdas, (8, 48)).unwrap();
            areas.push((b[1] - b[0]) * (b[3] - b[2]));
            // A finer grid of aims over 1.6 times the rear element from film points in the ring: every ray that gets
            // through was aimed inside the box, and some aimed inside do get through.
            let (mut inside, mut through) = (0, 0);
            for k in 0..4 {
                let r = ring.0 + (ring.1 - ring.0) * k as f64 / 3.0;
                for i in 0..100 {
                    for j in 0..100 {
                        let (x, y) =
                            (-16.0 + 32.0 * (i as f64 + 0.37) / 100.0, -16.0 + 32.0 * (j as f64 + 0.61) / 100.0);
                        let d = [x - r, y, z_last - z_film];
                        let l = dot(d, d).sqrt();
                        let ray = LensRay { origin: [r, 0.0, z_film], direction: [d[0] / l, d[1] / l, d[2] / l] };
                        let ok = lambdas.iter().any(|&lambda| lens.trace_from_film(ray, lambda).is_some());
                        let in_box = x >= b[0] && x <= b[1] && y >= b[2] && y <= b[3];
                        assert!(!ok || in_box, "ring {ring:?}: ({x}, {y}) gets through outside {b:?}");
                        inside += in_box as usize;
                        through += ok as usize;
                    }
                }
            }
            assert!(through > inside / 3, "ring {ring:?}: {through} of {inside} aims in the box get through");
            // The lens is round: on the axis the box is symmetric.
            if ring.0 == 0.0 {
                assert!((b[0] + b[1]).abs() < 0.5 && (b[2] + b[3]).abs() < 0.5, "{b:?}");
            }
        }
        // Towards the edge of the field the double Gauss vignettes: the box shrinks.
        assert!(areas[2] < areas[0], "{areas:?}");
    }
}

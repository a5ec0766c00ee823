//! pbrt-v4's realistic camera: rays traced from the film through a lens prescription's surfaces (Kolb, Mitchell and
//! Hanrahan 1995; pbrt-v4 §5.3), with Prismatic's glasses per element, so that each wavelength is refracted with its
//! own n(λ) and the lens's chromatic aberration appears in the image.
//!
//! Lens space is [`optics::LensPrescription`]'s: millimetres, z along the axis from the front vertex towards the
//! film. Camera space is pbrt-v4's: the film's centre at the origin, the scene towards +z, in scene units taken as
//! metres (pbrt-v4 divides the lens file's millimetres by 1000).

use glam::{DVec3, Vec2};
use optics::{LensPrescription, LensRay};
use rayon::prelude::*;

/// The wavelength a dispersive lens is focused at, and at which its footprints are traced: the helium d line,
/// where catalogues quote n_d.
pub const FOCUS_WAVELENGTH_NM: f64 = 587.5618;

/// Film rings over which the exit pupil's box is precomputed, from the centre to the corner (pbrt-v4's 64).
const PUPIL_RINGS: usize = 64;

/// Film points per ring and aims per axis of each of the two grids over the rear element for each ring's box (see
/// `LensPrescription::exit_pupil_bounds`): at most two million lens traces per wavelength for the whole film, fewer
/// since aims inside the box found so far are skipped; the double Gauss's take 0.1–0.2 s of scene setup.
const PUPIL_SEARCH: (usize, usize) = (4, 64);

/// A shaped diaphragm (pbrt-v4's `aperture` image): a transmission over the square circumscribing the stop,
/// scaled so that its mean over the square is π/4 (a clear circle's), so a shaped stop passes as much light as the
/// round one. Row 0 is the stop's −y edge.
#[derive(Clone, Debug, PartialEq)]
pub struct ApertureMask {
    width: usize,
    height: usize,
    values: Vec<f32>,
}

impl ApertureMask {
    /// The mask of an image of `width` × `height` values, top row first (as an image file is stored), as pbrt-v4
    /// reads it: flipped so the top row is the stop's +y edge, then scaled to mean π/4. `None` if it lets no light
    /// through (or has no pixels).
    pub fn from_image(width: usize, height: usize, top_down: &[f32]) -> Option<Self> {
        if width == 0 || height == 0 || top_down.len() != width * height {
            return None;
        }
        let mut values: Vec<f32> =
            (0..height).rev().flat_map(|y| top_down[y * width..(y + 1) * width].iter().map(|v| v.max(0.0))).collect();
        let mean = values.iter().map(|&v| v as f64).sum::<f64>() / values.len() as f64;
        if !(mean > 0.0 && mean.is_finite()) {
            return None;
        }
        let scale = (std::f64::consts::FRAC_PI_4 / mean) as f32;
        values.iter_mut().for_each(|v| *v *= scale);
        Some(Self { width, height, values })
    }

    /// pbrt-v4's built-in diaphragms, rasterised at 256² as it does: `"gaussian"` (e^(−r²) − e^(−1)), `"square"`
    /// (half the stop's width), `"pentagon"` (a regular pentagon at 0.8 of the radius) and `"star"` (five points,
    /// inner radius cos 72°/cos 36°). `None` for any other name.
    pub fn builtin(name: &str) -> Option<Self> {
        const RES: usize = 256;
        let centre = |i: usize| -1.0 + 2.0 * (i as f64 + 0.5) / RES as f64;
        let image: Vec<f32> = match name {
            "gaussian" => (0..RES * RES)
                .map(|k| {
                    let (x, y) = (centre(k % RES), centre(k / RES));
                    ((-(x * x + y * y)).exp() - (-1f64).exp()).max(0.0) as f32
                })
                .collect(),
            "square" => (0..RES * RES)
                .map(|k| {
                    let inside = |i: usize| (RES / 4..3 * RES / 4).contains(&i);
                    if inside(k % RES) && inside(k / RES) {
                        4.0
                    } else {
                        0.0
                    }
                })
                .collect(),
            "pentagon" | "star" => {
                let vertices: Vec<[f64; 2]> = if name == "pentagon" {
                    let s5 = 5f64.sqrt();
                    let (c1, c2) = ((s5 - 1.0) / 4.0, (s5 + 1.0) / 4.0);
                    let (s1, s2) = ((10.0 + 2.0 * s5).sqrt() / 4.0, (10.0 - 2.0 * s5).sqrt() / 4.0);
                    [[0.0, 1.0], [s1, c1], [s2, -c2], [-s2, -c2], [-s1, c1]].map(|[x, y]| [0.8 * x, 0.8 * y]).to_vec()
                } else {
                    let inner = 72f64.to_radians().cos() / 36f64.to_radians().cos();
                    (0..10)
                        .map(|i| {
                            let r = if i % 2 == 1 { 1.0 } else { inner };
                            let a = std::f64::consts::PI * i as f64 / 5.0;
                            [r * a.cos(), r * a.sin()]
                        })
                        .collect()
                };
                (0..RES * RES)
                    .map(|k| if winding_number([centre(k % RES), centre(k / RES)], &vertices) != 0 { 1.0 } else { 0.0 })
                    .collect()
            }
            _ => return None,
        };
        Self::from_image(RES, RES, &image)
    }

    /// The radius, in units of the stop's, of the smallest circle about the centre outside which the mask lets
    /// nothing through (bilinear filtering reaches one pixel beyond a lit pixel's centre).
    pub fn support_radius(&self) -> f64 {
        let (w, h) = (self.width as f64, self.height as f64);
        let mut r2: f64 = 0.0;
        for (k, &v) in self.values.iter().enumerate() {
            if v > 0.0 {
                let (i, j) = ((k % self.width) as f64, (k / self.width) as f64);
                // The pixel's farthest reach: its centre plus one pixel, on each axis.
                let x = ((i + 0.5) / w * 2.0 - 1.0).abs() + 2.0 / w;
                let y = ((j + 0.5) / h * 2.0 - 1.0).abs() + 2.0 / h;
                r2 = r2.max(x * x + y * y);
            }
        }
        r2.sqrt().min(std::f64::consts::SQRT_2)
    }

    /// The transmission at (x/r, y/r) on the stop: bilinear between pixel centres, 0 outside the square (pbrt-v4's
    /// `Bilerp` with black wrapping).
    pub fn at(&self, x: f64, y: f64) -> f64 {
        let (u, v) = (0.5 * (x + 1.0), 0.5 * (y + 1.0));
        let (fx, fy) = (u * self.width as f64 - 0.5, v * self.height as f64 - 0.5);
        let (x0, y0) = (fx.floor(), fy.floor());
        let (dx, dy) = (fx - x0, fy - y0);
        let texel = |i: f64, j: f64| -> f64 {
            if i < 0.0 || j < 0.0 || i >= self.width as f64 || j >= self.height as f64 {
                0.0
            } else {
                self.values[j as usize * self.width + i as usize] as f64
            }
        };
        (1.0 - dx) * (1.0 - dy) * texel(x0, y0)
            + dx * (1.0 - dy) * texel(x0 + 1.0, y0)
            + (1.0 - dx) * dy * texel(x0, y0 + 1.0)
            + dx * dy * texel(x0 + 1.0, y0 + 1.0)
    }
}

/// The winding number of the closed polygon `vertices` around `p` (0 outside).
fn winding_number(p: [f64; 2], vertices: &[[f64; 2]]) -> i32 {
    let mut winding = 0;
    for (i, a) in vertices.iter().enumerate() {
        let b = vertices[(i + 1) % vertices.len()];
        // Which side of the edge a→b the point lies on.
        let side = (b[0] - a[0]) * (p[1] - a[1]) - (p[0] - a[0]) * (b[1] - a[1]);
        if a[1] <= p[1] {
            if b[1] > p[1] && side > 0.0 {
                winding += 1;
            }
        } else if b[1] <= p[1] && side < 0.0 {
            winding -= 1;
        }
    }
    winding
}

/// A lens in front of a film, ready to generate camera rays: the prescription focused and stopped down, the film's
/// physical size, and the exit pupil's box per film ring.
#[derive(Clone, Debug)]
pub struct RealisticLens {
    lens: LensPrescription,
    /// Half the film's width and height, mm.
    film_half_mm: [f64; 2],
    /// Half the film's diagonal, mm: the rings span it.
    half_diagonal_mm: f64,
    /// The full film resolution the raster positions refer to.
    resolution: (u32, u32),
    /// Per film ring from the centre outwards: the exit pupil's box on the rear vertex plane (x₀, x₁, y₀, y₁), mm.
    pupils: Vec<Option<[f64; 4]>>,
    /// Lens-space z of the rear vertex and of the film, mm.
    rear_vertex_mm: f64,
    film_mm: f64,
    /// A shaped diaphragm, if any.
    mask: Option<ApertureMask>,
    dispersive: bool,
    /// Whether the rays' weights depend on the wavelength though their paths do not (coatings counted, no glass
    /// that disperses).
    filters: bool,
    /// Whether each surface's Fresnel (and coating) transmittance weighs the rays.
    fresnel: bool,
}

/// A ray leaving the lens, in camera space (metres), with its weight: pbrt-v4's cos⁴θ · A_box / z_rear² times the
/// diaphragm's transmission, the measurement of irradiance on the film that a unit radiance gives.
#[derive(Clone, Copy, Debug)]
pub struct LensExit {
    /// A point on the front surface, camera space.
    pub origin: DVec3,
    /// Unit direction into the scene, camera space.
    pub direction: DVec3,
    /// The sample's weight.
    pub weight: f32,
}

/// What a realistic camera is made of, as the scene gives it.
#[derive(Clone, Debug)]
pub struct RealisticParams {
    /// The prescription as read.
    pub lens: LensPrescription,
    /// pbrt-v4's `aperturediameter`, mm: the stop's opening, at most its diameter in the file.
    pub aperture_diameter_mm: f64,
    /// pbrt-v4's `focusdistance`, in scene units (metres) from the film.
    pub focus_distance_m: f64,
    /// The film's diagonal, mm (pbrt-v4's film `diagonal`).
    pub film_diagonal_mm: f64,
    /// The full film resolution.
    pub resolution: (u32, u32),
    /// A shaped diaphragm (None: the stop's circle).
    pub mask: Option<ApertureMask>,
    /// The wavelengths the exit pupil must let through, nm.
    pub wavelength_range_nm: (f64, f64),
    /// Whether the light lost to reflection at each surface (per wavelength and angle, through its coating) is
    /// taken out of the rays (Prismatic's `"bool lenstransmission"`; pbrt-v4's camera loses none).
    pub fresnel: bool,
}

impl RealisticLens {
    /// Stops the lens down to `aperture_diameter_mm` (pbrt-v4 clamps a larger one to the stop's diameter, which is
    /// then returned beside the lens), moves its film so that the plane `focus_distance_m` in front of the film is
    /// sharp (at [`FOCUS_WAVELENGTH_NM`]), and finds the exit pupil's box over each film ring. Errors say why no
    /// image can form: no stop, a focus too close, or a lens through which no ray from the film gets out.
    pub fn new(p: RealisticParams) -> Result<(Self, Option<f64>), String> {
        let mut lens = p.lens;
        let stop = lens.stop().ok_or("the lens file has no aperture stop (a row with radius 0 and index 0)")?;
        let stop_mm = lens.surfaces[stop].aperture_mm;
        if !(p.aperture_diameter_mm.is_finite() && p.aperture_diameter_mm > 0.0) {
            return Err(format!("'aperturediameter' must be a positive length in mm, got {}", p.aperture_diameter_mm));
        }
        let clamped = (p.aperture_diameter_mm > stop_mm).then_some(stop_mm);
        lens.surfaces[stop].aperture_mm = p.aperture_diameter_mm.min(stop_mm);
        if !(p.focus_distance_m.is_finite() && p.focus_distance_m > 0.0) {
            return Err(format!("'focusdistance' must be a positive distance, got {}", p.focus_distance_m));
        }
        let lens = lens.focused(p.focus_distance_m * 1000.0, FOCUS_WAVELENGTH_NM)?;
        let dispersive = lens.surfaces.iter().any(|s| s.medium.is_dispersive());
        // With the surfaces' transmittance, coatings (interference) make even a lens of constant indices a filter
        // that depends on the wavelength: one ray, a weight per wavelength.
        let filters = p.fresnel && !dispersive && lens.surfaces.iter().any(|s| !s.coating.is_empty());
        // pbrt-v4's physical extent: the diagonal split by the full resolution's aspect ratio.
        let aspect = p.resolution.1 as f64 / p.resolution.0 as f64;
        let width = (p.film_diagonal_mm * p.film_diagonal_mm / (1.0 + aspect * aspect)).sqrt();
        let film_half_mm = [0.5 * width, 0.5 * aspect * width];
        let half_diagonal_mm = 0.5 * p.film_diagonal_mm;
        let (lo, hi) = p.wavelength_range_nm;
        let lambdas: Vec<f64> = if dispersive { vec![lo, 0.5 * (lo + hi), hi] } else { vec![FOCUS_WAVELENGTH_NM] };
        let mask = p.mask;
        // The boxes are found for film points on the +x axis and turned to each film point's azimuth, which holds
        // for a round lens only: a shaped diaphragm's pupil does not turn with the film point. So they are found
        // through the round stop that just holds the diaphragm's shape (pbrt-v4 finds them through the shape itself
        // and turns them, which cuts off part of a square or pentagonal pupil away from the film's axes).
        let mut pupil_lens = lens.clone();
        if let Some(m) = &mask {
            pupil_lens.surfaces[stop].aperture_mm *= m.support_radius();
        }
        let pupils: Vec<Option<[f64; 4]>> = (0..PUPIL_RINGS)
            .into_par_iter()
            .map(|i| {
                let ring = (
                    i as f64 / PUPIL_RINGS as f64 * half_diagonal_mm,
                    (i + 1) as f64 / PUPIL_RINGS as f64 * half_diagonal_mm,
                );
                pupil_lens.exit_pupil_bounds(ring, &lambdas, PUPIL_SEARCH)
            })
            .collect();
        if pupils.iter().all(Option::is_none) {
            return Err(format!(
                "no ray from the film gets through the lens (stopped down to {:.3} mm, focused at {} m): it would \
                 render black",
                p.aperture_diameter_mm.min(stop_mm),
                p.focus_distance_m
            ));
        }
        let last = lens.surfaces.len() - 1;
        let film_mm = lens.length_mm();
        let rear_vertex_mm = film_mm - lens.surfaces[last].thickness_mm;
        Ok((
            Self {
                lens,
                film_half_mm,
                half_diagonal_mm,
                resolution: p.resolution,
                pupils,
                rear_vertex_mm,
                film_mm,
                mask,
                dispersive,
                filters,
                fresnel: p.fresnel,
            },
            clamped,
        ))
    }

    /// True if some element's index depends on the wavelength: each wavelength then has its own camera ray.
    pub fn is_dispersive(&self) -> bool {
        self.dispersive
    }

    /// True if the rays' weights depend on the wavelength (coatings counted through `"bool lenstransmission"`)
    /// though their paths do not (no glass disperses).
    pub fn filters_wavelengths(&self) -> bool {
        self.filters
    }

    /// The lens as focused and stopped down.
    pub fn prescription(&self) -> &LensPrescription {
        &self.lens
    }

    /// The film point (lens space, mm) of raster position `film` (pixels, y down): the film is behind the lens, so
    /// the image is upside down and mirrored, and pbrt-v4 negates x (raster y already grows downwards).
    fn film_point(&self, film: Vec2) -> [f64; 3] {
        let s = [film.x as f64 / self.resolution.0 as f64, film.y as f64 / self.resolution.1 as f64];
        let p = [(2.0 * s[0] - 1.0) * self.film_half_mm[0], (2.0 * s[1] - 1.0) * self.film_half_mm[1]];
        [-p[0], p[1], self.film_mm]
    }

    /// The film ray of raster position `film` and lens sample `u`: from the film point to a point of its ring's exit
    /// pupil box (rotated to the film point's azimuth), and that ray's weight before the lens (cos⁴θ · A / z²);
    /// `None` if the ring lets nothing through.
    fn film_ray(&self, film: Vec2, u: Vec2) -> Option<(LensRay, f64)> {
        let p = self.film_point(film);
        let r = p[0].hypot(p[1]);
        let ring = ((r / self.half_diagonal_mm * PUPIL_RINGS as f64) as usize).min(PUPIL_RINGS - 1);
        let b = self.pupils[ring]?;
        let (lx, ly) = (b[0] + (b[1] - b[0]) * u.x as f64, b[2] + (b[3] - b[2]) * u.y as f64);
        let (sin, cos) = if r > 0.0 { (p[1] / r, p[0] / r) } else { (0.0, 1.0) };
        let ray = LensRay::towards(p, [cos * lx - sin * ly, sin * lx + cos * ly, self.rear_vertex_mm]);
        let cos_theta = ray.direction[2].abs();
        let z_rear = self.film_mm - self.rear_vertex_mm;
        let area = (b[1] - b[0]) * (b[3] - b[2]);
        Some((ray, cos_theta.powi(4) * area / (z_rear * z_rear)))
    }

    /// The film ray traced out through the lens at each of `lambdas_nm` (side by side), in camera space.
    fn exits<const N: usize>(&self, ray: LensRay, weight: f64, lambdas_nm: [f64; N]) -> [Option<LensExit>; N] {
        let mask = self.mask.as_ref().map(|m| move |x: f64, y: f64| m.at(x, y));
        let stop = mask.as_ref().map(|f| f as optics::StopMask<'_>);
        self.lens.trace_from_film_many(ray, lambdas_nm, stop, self.fresnel).map(|out| {
            out.map(|(out, transmission)| LensExit {
                origin: self.to_camera_point(out.origin),
                direction: self.to_camera_vector(out.direction).normalize(),
                weight: (weight * transmission) as f32,
            })
        })
    }

    /// The camera ray of raster position `film` and lens sample `u` at `lambda_nm` (pbrt-v4's
    /// `RealisticCamera::GenerateRay`); `None` if the lens stops it.
    pub fn ray(&self, film: Vec2, u: Vec2, lambda_nm: f64) -> Option<LensExit> {
        let (ray, weight) = self.film_ray(film, u)?;
        let [exit] = self.exits(ray, weight, [lambda_nm]);
        exit
    }

    /// The camera rays of raster position `film` and lens sample `u` at each of `lambdas_nm`: one film ray (the
    /// same film and pupil points for every wavelength), refracted by each wavelength's indices.
    pub fn rays<const N: usize>(&self, film: Vec2, u: Vec2, lambdas_nm: [f64; N]) -> [Option<LensExit>; N] {
        match self.film_ray(film, u) {
            None => [None; N],
            Some((ray, weight)) => self.exits(ray, weight, lambdas_nm),
        }
    }

    /// The rays through the film points one pixel to the right and one pixel down of the camera-space ray
    /// (`origin`, `dir`) that left the lens, aimed at the same point of the rear vertex plane, at
    /// [`FOCUS_WAVELENGTH_NM`] (pbrt-v4's differentials shift the film point and keep the lens sample). `None` if
    /// the ray cannot be traced back to the film or a neighbour is stopped by the lens.
    pub fn differential(&self, origin: DVec3, dir: DVec3) -> Option<[(DVec3, DVec3); 2]> {
        // Back from the scene, starting a little in front of the front surface.
        let o = self.to_lens_point(origin - dir * 1e-3);
        let d = self.to_lens_vector(-dir);
        let back = self.lens.trace_from_object(LensRay { origin: o, direction: d }, FOCUS_WAVELENGTH_NM)?;
        let at_z = |z: f64| {
            let t = (z - back.origin[2]) / back.direction[2];
            [back.origin[0] + t * back.direction[0], back.origin[1] + t * back.direction[1], z]
        };
        let (film, rear) = (at_z(self.film_mm), at_z(self.rear_vertex_mm));
        if !(film.iter().chain(&rear).all(|v| v.is_finite())) {
            return None;
        }
        // One pixel in raster x moves the film point by −width/res in lens x; one down, by +height/res in lens y.
        let px = 2.0 * self.film_half_mm[0] / self.resolution.0 as f64;
        let py = 2.0 * self.film_half_mm[1] / self.resolution.1 as f64;
        let neighbour = |shift: [f64; 2]| -> Option<(DVec3, DVec3)> {
            let ray = LensRay::towards([film[0] + shift[0], film[1] + shift[1], film[2]], rear);
            let out = self.lens.trace_from_film(ray, FOCUS_WAVELENGTH_NM)?;
            Some((self.to_camera_point(out.origin), self.to_camera_vector(out.direction).normalize()))
        };
        Some([neighbour([-px, 0.0])?, neighbour([0.0, py])?])
    }

    fn to_camera_point(&self, p: [f64; 3]) -> DVec3 {
        DVec3::new(p[0], p[1], self.film_mm - p[2]) * 1e-3
    }

    fn to_camera_vector(&self, d: [f64; 3]) -> DVec3 {
        DVec3::new(d[0], d[1], -d[2])
    }

    fn to_lens_point(&self, p: DVec3) -> [f64; 3] {
        let q = p * 1e3;
        [q.x, q.y, self.film_mm - q.z]
    }

    fn to_lens_vector(&self, d: DVec3) -> [f64; 3] {
        [d.x, d.y, -d.z]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// pbrt-v4's `lenses/dgauss.50mm.dat` (mmp/pbrt-v4-scenes): constant indices, last thickness 0.
    const DGAUSS_PBRT: &str = "29.475 3.76 1.67 25.2\n84.83 0.12 1 25.2\n19.275 4.025 1.67 23\n40.77 3.275 1.699 23\n\
        12.75 5.705 1 18\n0 4.5 0 17.1\n-14.495 1.18 1.603 17\n40.77 6.065 1.658 20\n-20.385 0.19 1 20\n\
        437.065 3.22 1.717 20\n-39.73 0 1 20\n";

    /// The same lens with the Abbe pairs of Kolb et al. 1995 (as scenes/lenses/dgauss-50mm.dat).
    const DGAUSS_GLASS: &str = "29.475 3.76 1.670/47.1 25.2\n84.83 0.12 1 25.2\n19.275 4.025 1.670/47.1 23.0\n\
        40.77 3.275 1.699/30.1 23.0\n12.75 5.705 1 18.0\n0 4.5 0 17.1\n-14.495 1.18 1.603/38.0 17.0\n\
        40.77 6.065 1.658/57.3 20.0\n-20.385 0.19 1 20.0\n437.065 3.22 1.717/48.0 20.0\n-39.73 36.114 1 20.0\n";

    fn camera(text: &str, aperture_mm: f64, focus_m: f64, mask: Option<ApertureMask>) -> Result<RealisticLens, String> {
        RealisticLens::new(RealisticParams {
            lens: LensPrescription::parse(text).unwrap(),
            aperture_diameter_mm: aperture_mm,
            focus_distance_m: focus_m,
            film_diagonal_mm: 35.0,
            resolution: (300, 200),
            mask,
            wavelength_range_nm: (360.0, 830.0),
            fresnel: false,
        })
        .map(|(lens, _)| lens)
    }

    fn lens_samples() -> impl Iterator<Item = Vec2> {
        (0..64).map(|i| Vec2::new((i % 8) as f32 / 8.0 + 0.0625, (i / 8) as f32 / 8.0 + 0.0625))
    }

    #[test]
    fn constant_indices_send_every_wavelength_one_way_and_glass_does_not() {
        let pbrt = camera(DGAUSS_PBRT, 17.1, 2.0, None).unwrap();
        let glass = camera(DGAUSS_GLASS, 17.1, 2.0, None).unwrap();
        assert!(!pbrt.is_dispersive() && glass.is_dispersive());
        let film = Vec2::new(280.0, 20.0);
        let mut spread = (0.0f64, 0.0f64);
        for u in lens_samples() {
            for (lens, s) in [(&pbrt, &mut spread.0), (&glass, &mut spread.1)] {
                let [a, b] = lens.rays(film, u, [450.0, 650.0]);
                if let (Some(a), Some(b)) = (a, b) {
                    *s = s.max((a.direction - b.direction).length());
                    // The film ray is shared: only the lens's indices differ, never the weight's geometry.
                    assert_eq!(a.weight, b.weight);
                }
            }
        }
        assert_eq!(spread.0, 0.0);
        // The flint and crown of a double Gauss still bend 450 and 650 nm apart by a few arc-minutes at f/2.
        assert!(spread.1 > 1e-4, "{}", spread.1);
    }

    #[test]
    fn coatings_filter_the_light_per_wavelength_without_bending_it() {
        // pbrt-v4's double Gauss with a quarter-wave layer for 550 nm on its first surface, surfaces' Fresnel counted.
        let coated = DGAUSS_PBRT.replacen("25.2\n", "25.2 1.38@99.64\n", 1);
        let lens = RealisticLens::new(RealisticParams {
            lens: LensPrescription::parse(&coated).unwrap(),
            aperture_diameter_mm: 8.0,
            focus_distance_m: 2.0,
            film_diagonal_mm: 35.0,
            resolution: (300, 200),
            mask: None,
            wavelength_range_nm: (360.0, 830.0),
            fresnel: true,
        })
        .unwrap()
        .0;
        assert!(lens.filters_wavelengths() && !lens.is_dispersive());
        let plain = camera(DGAUSS_PBRT, 8.0, 2.0, None).unwrap();
        let [a, b] = lens.rays(Vec2::new(150.0, 100.0), Vec2::splat(0.5), [550.0, 400.0]);
        let (a, b) = (a.unwrap(), b.unwrap());
        assert_eq!((a.origin, a.direction), (b.origin, b.direction));
        // The axial ray meets every surface head on: each bare one passes 1 − ((n − n′)/(n + n′))², the coated
        // first one 1 − ((n_s − n₁²)/(n_s + n₁²))² at the coating's design wavelength 4·1.38·99.64 = 550.0 nm;
        // away from it (400 nm) the coating helps less.
        let index = [1.0, 1.67, 1.0, 1.67, 1.699, 1.0, 1.0, 1.603, 1.658, 1.0, 1.717, 1.0];
        let refracting = [0, 1, 2, 3, 4, 6, 7, 8, 9, 10];
        let mut expected = 1.0;
        for &i in &refracting {
            let (n, m) = (index[i], index[i + 1]);
            expected *= if i == 0 {
                1.0 - ((m - 1.38f64.powi(2)) / (m + 1.38f64.powi(2))).powi(2)
            } else {
                1.0 - ((n - m) / (n + m)).powi(2)
            };
        }
        let bare = plain.ray(Vec2::new(150.0, 100.0), Vec2::splat(0.5), 550.0).unwrap().weight;
        let (ta, tb) = ((a.weight / bare) as f64, (b.weight / bare) as f64);
        assert!((ta - expected).abs() < 1e-5, "{ta} vs {expected}");
        assert!(tb < ta - 5e-3, "{tb} vs {ta}");
    }

    #[test]
    fn rays_from_one_film_point_meet_on_the_plane_of_focus() {
        // Stopped down to 4 mm (f/12.5), spherical aberration is small: the rays of one film point cross the plane
        // 2 m from the film within a fraction of a millimetre, and an on-axis point images onto the axis.
        let lens = camera(DGAUSS_PBRT, 4.0, 2.0, None).unwrap();
        for film in [Vec2::new(150.0, 100.0), Vec2::new(60.0, 170.0)] {
            let hits: Vec<DVec3> = lens_samples()
                .filter_map(|u| lens.ray(film, u, FOCUS_WAVELENGTH_NM))
                .map(|r| r.origin + r.direction * ((2.0 - r.origin.z) / r.direction.z))
                .collect();
            assert!(hits.len() > 32, "{} of 64 rays get through", hits.len());
            let mean = hits.iter().sum::<DVec3>() / hits.len() as f64;
            let spread = hits.iter().map(|h| (*h - mean).length()).fold(0.0, f64::max);
            assert!(spread < 3e-4, "film {film}: rays spread over {spread} m on the plane of focus");
            if film == Vec2::new(150.0, 100.0) {
                assert!(mean.truncate().length() < 1e-5, "{mean}");
            } else {
                // Raster left and down is scene left (−x) and down (−y): the lens inverts, the film undoes it.
                assert!(mean.x < 0.0 && mean.y < 0.0, "{mean}");
            }
        }
    }

    #[test]
    fn weight_is_cos4_times_the_pupil_box_over_the_rear_distance_squared() {
        let lens = camera(DGAUSS_PBRT, 17.1, 2.0, None).unwrap();
        // From the film's centre towards the centre of its box (symmetric about the axis): cos θ = 1.
        let b = lens.pupils[0].unwrap();
        let z = lens.film_mm - lens.rear_vertex_mm;
        let r = lens.ray(Vec2::new(150.0, 100.0), Vec2::splat(0.5), 550.0).unwrap();
        let expected = (b[1] - b[0]) * (b[3] - b[2]) / (z * z);
        assert!((r.weight as f64 - expected).abs() < 1e-3 * expected, "{} vs {expected}", r.weight);
    }

    #[test]
    fn neighbouring_pixels_differ_by_a_pixel_over_the_focal_length() {
        let lens = camera(DGAUSS_PBRT, 8.0, 1e3, None).unwrap();
        let r = lens.ray(Vec2::new(150.0, 100.0), Vec2::new(0.3, 0.6), FOCUS_WAVELENGTH_NM).unwrap();
        let [dx, dy] = lens.differential(r.origin, r.direction).unwrap();
        // 300 pixels over the film's 29.12 mm width, at f = 50.36 mm (Smith's table's EFL at n_d).
        let pixel = 35.0 / (1.0f64 + (2.0f64 / 3.0).powi(2)).sqrt() / 300.0;
        for (n, along) in [(dx, DVec3::X), (dy, DVec3::NEG_Y)] {
            let turn = n.1 - r.direction;
            assert!((turn.length() - pixel / 50.36).abs() < 0.03 * pixel / 50.36, "{turn}");
            // One pixel right is scene +x, one pixel down is scene −y (pbrt-v4's camera space).
            assert!(turn.normalize().dot(along) > 0.99, "{turn}");
        }
    }

    #[test]
    fn a_lens_that_lets_nothing_through_is_an_error() {
        let e = camera(DGAUSS_PBRT, 1e-5, 2.0, None).unwrap_err();
        assert!(e.contains("no ray from the film gets through"), "{e}");
        assert!(camera(DGAUSS_PBRT, 17.1, 0.05, None).unwrap_err().contains("too close"));
    }

    #[test]
    fn builtin_diaphragms_pass_as_much_light_as_the_circle_in_pbrt_v4s_orientation() {
        for name in ["gaussian", "square", "pentagon", "star"] {
            let m = ApertureMask::builtin(name).unwrap();
            // Mean over the square [−1, 1]² is π/4, a clear circle's.
            let n = 400;
            let mean = (0..n * n)
                .map(|k| {
                    m.at(-1.0 + 2.0 * ((k % n) as f64 + 0.5) / n as f64, -1.0 + 2.0 * ((k / n) as f64 + 0.5) / n as f64)
                })
                .sum::<f64>()
                / (n * n) as f64;
            assert!((mean - std::f64::consts::FRAC_PI_4).abs() < 5e-3, "{name}: {mean}");
        }
        assert!(ApertureMask::builtin("hexagon").is_none());
        let square = ApertureMask::builtin("square").unwrap();
        assert!((square.at(0.1, -0.3) - std::f64::consts::PI).abs() < 1e-5);
        assert_eq!(square.at(0.75, 0.0), 0.0);
        assert!((square.support_radius() - 0.5f64.hypot(0.5)).abs() < 0.02, "{}", square.support_radius());
        // pbrt-v4 draws the pentagon with a vertex at +y and then flips the image: on the stop it points to −y.
        let pentagon = ApertureMask::builtin("pentagon").unwrap();
        assert!(pentagon.at(0.0, -0.75) > 0.0 && pentagon.at(0.0, 0.72) == 0.0);
        // A shaped stop lets as much light through as the round one (pbrt-v4's normalisation): stopped down to 4 mm
        // (no element vignettes), the mean weight over a 128² grid of lens samples agrees within 1%, at the film's
        // centre and at a point off both axes, where a box found on the x axis and turned would cut a square's
        // pupil (pbrt-v4's way: 7.5% too little light there).
        for film in [Vec2::new(150.0, 100.0), Vec2::new(280.0, 180.0)] {
            let mean_weight = |lens: &RealisticLens| {
                let n = 128;
                (0..n * n)
                    .filter_map(|i| {
                        let u = Vec2::new(((i % n) as f32 + 0.5) / n as f32, ((i / n) as f32 + 0.5) / n as f32);
                        lens.ray(film, u, 550.0)
                    })
                    .map(|r| r.weight as f64)
                    .sum::<f64>()
                    / (n * n) as f64
            };
            let round = mean_weight(&camera(DGAUSS_PBRT, 4.0, 2.0, None).unwrap());
            for name in ["square", "pentagon", "star", "gaussian"] {
                let shaped = mean_weight(&camera(DGAUSS_PBRT, 4.0, 2.0, ApertureMask::builtin(name)).unwrap());
                assert!((shaped / round - 1.0).abs() < 0.01, "{name} at {film}: {shaped} vs {round}");
            }
        }
    }
}

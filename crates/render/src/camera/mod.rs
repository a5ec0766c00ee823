//! Cameras: pbrt-v4's perspective (with a thin lens), orthographic and realistic (a lens prescription traced per
//! wavelength, [`realistic`]) projections.

mod realistic;

use std::borrow::Cow;
use std::sync::Arc;

use geometry::{AnimatedTransform, Transform};
use glam::{DVec3, Vec2, Vec3};
use spectral::{SampledSpectrum, SampledWavelengths, N_WAVELENGTHS};

use crate::sampling::sample_uniform_disk_concentric;

pub use realistic::{ApertureMask, RealisticLens, RealisticParams, FOCUS_WAVELENGTH_NM};

/// The screen-space window the film maps to (pbrt's `screenwindow`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScreenWindow {
    /// Minimum x.
    pub x_min: f32,
    /// Maximum x.
    pub x_max: f32,
    /// Minimum y.
    pub y_min: f32,
    /// Maximum y.
    pub y_max: f32,
}

impl ScreenWindow {
    /// pbrt's default: the shorter image axis spans [−1, 1], the longer one keeps the aspect ratio.
    pub fn for_aspect(aspect: f32) -> Self {
        if aspect > 1.0 {
            Self { x_min: -aspect, x_max: aspect, y_min: -1.0, y_max: 1.0 }
        } else {
            Self { x_min: -1.0, x_max: 1.0, y_min: -1.0 / aspect, y_max: 1.0 / aspect }
        }
    }
}

/// How the camera projects.
#[derive(Clone, Debug)]
pub enum Projection {
    /// Perspective with tan(fov/2) for the unit screen extent.
    Perspective {
        /// tan of half the field of view.
        tan_half_fov: f32,
    },
    /// Orthographic: screen coordinates are camera-space lengths.
    Orthographic,
    /// pbrt-v4's realistic camera: a film behind a lens prescription, rays traced through its surfaces.
    Realistic(Arc<RealisticLens>),
}

/// A camera in world (render) space.
#[derive(Clone, Debug)]
pub struct Camera {
    projection: Projection,
    world_from_camera: Transform,
    camera_from_world: Transform,
    resolution: (u32, u32),
    window: ScreenWindow,
    lens_radius: f32,
    focal_distance: f32,
    /// World-from-camera over the shutter, if the camera moves (pbrt-v4 interpolates this one, not its inverse).
    motion: Option<AnimatedTransform>,
}

/// A generated camera ray in world space.
#[derive(Clone, Copy, Debug)]
pub struct CameraRay {
    /// Origin.
    pub origin: Vec3,
    /// Unit direction.
    pub direction: Vec3,
    /// The time it is traced at.
    pub time: f32,
    /// The camera's weight of the ray, multiplying the radiance it brings: 1 for a pinhole, thin lens or
    /// orthographic camera, pbrt-v4's cos⁴θ · A / z² for a realistic one.
    pub weight: f32,
}

/// The rays of one camera sample: one for all its wavelengths, or, through a lens whose glass disperses, one per
/// wavelength. A missing ray is one the lens stopped (vignetting), which brings no light.
#[derive(Clone, Copy, Debug)]
pub enum CameraRays {
    /// One ray for every wavelength.
    Shared(Option<CameraRay>),
    /// One ray for every wavelength (of weight 1) and the camera's weight per wavelength (a lens whose coatings
    /// filter the light but whose glass does not disperse).
    Filtered(Option<CameraRay>, SampledSpectrum),
    /// A ray per wavelength slot.
    PerWavelength([Option<CameraRay>; N_WAVELENGTHS]),
}

impl Camera {
    /// A camera with `camera_from_world` (pbrt's camera transform), the film `resolution`, projection, screen
    /// window, and thin-lens parameters (`lens_radius` 0 is a pinhole).
    pub fn new(
        projection: Projection,
        camera_from_world: &Transform,
        resolution: (u32, u32),
        window: ScreenWindow,
        lens_radius: f32,
        focal_distance: f32,
    ) -> Self {
        Self {
            projection,
            world_from_camera: camera_from_world.inverse(),
            camera_from_world: *camera_from_world,
            resolution,
            window,
            lens_radius,
            focal_distance,
            motion: None,
        }
    }

    /// This camera moving with `world_from_camera` over the shutter (pbrt-v4's animated `CameraTransform`); its
    /// start must be the inverse of the transform it was made with.
    pub fn with_motion(mut self, world_from_camera: AnimatedTransform) -> Self {
        self.motion = world_from_camera.is_animated().then_some(world_from_camera);
        self
    }

    /// True if the camera moves while the shutter is open.
    pub fn moves(&self) -> bool {
        self.motion.is_some()
    }

    /// The camera as it is at `time` (itself when it does not move): for light paths, which connect to the lens
    /// where it is at their time.
    pub fn at_time(&self, time: f32) -> Cow<'_, Camera> {
        match &self.motion {
            None => Cow::Borrowed(self),
            Some(m) => {
                let world_from_camera = m.at(time as f64);
                Cow::Owned(Camera {
                    world_from_camera,
                    camera_from_world: world_from_camera.inverse(),
                    motion: None,
                    ..self.clone()
                })
            }
        }
    }

    /// pbrt-v4's camera space from world space, where the camera is at the start of the shutter (see
    /// [`Camera::at_time`] for a moving camera).
    pub fn camera_from_world(&self) -> &Transform {
        &self.camera_from_world
    }

    /// World space from pbrt-v4's camera space (where the camera is at the start of the shutter).
    pub fn world_from_camera(&self) -> &Transform {
        &self.world_from_camera
    }

    /// The rays through the film position one pixel to the right and one pixel down of the camera ray
    /// (`origin`, `dir`) traced at `time`, from the same lens point (pbrt-v4's `GenerateRayDifferential`): a pinhole's
    /// ray through the neighbouring pixel, a thin lens's ray to the neighbour's point on the plane of focus, an
    /// orthographic ray shifted by a pixel, a realistic camera's rays from the neighbouring film points through the
    /// same point of its rear element. `None` for a ray the camera cannot have generated (pointing backwards, or
    /// stopped by the lens).
    pub fn ray_differential(&self, origin: Vec3, dir: Vec3, time: f32) -> Option<[(Vec3, Vec3); 2]> {
        let camera = self.at_time(time);
        let (m, w) = (camera.camera_from_world(), camera.world_from_camera());
        let o = m.point(origin.as_dvec3());
        let d = m.vector(dir.as_dvec3());
        let win = &self.window;
        let (rx, ry) = (self.resolution.0 as f64, self.resolution.1 as f64);
        // Screen-space extent of one pixel along x and along y (y grows downwards on the film).
        let (px, py) = ((win.x_max - win.x_min) as f64 / rx, -(win.y_max - win.y_min) as f64 / ry);
        let rays = match &self.projection {
            &Projection::Perspective { tan_half_fov } => {
                if d.z <= 0.0 {
                    return None;
                }
                // The ray's point at depth f (the plane of focus, or z = 1 for a pinhole) moves by f·tan·(pixel).
                let f = if self.lens_radius > 0.0 { self.focal_distance as f64 } else { 1.0 };
                let p_focus = o + d * ((f - o.z) / d.z);
                let k = f * tan_half_fov as f64;
                let dx = (p_focus + DVec3::new(k * px, 0.0, 0.0) - o).normalize();
                let dy = (p_focus + DVec3::new(0.0, k * py, 0.0) - o).normalize();
                [(o, dx), (o, dy)]
            }
            Projection::Orthographic => [(o + DVec3::new(px, 0.0, 0.0), d), (o + DVec3::new(0.0, py, 0.0), d)],
            Projection::Realistic(lens) => lens.differential(o, d.normalize())?,
        };
        let world = |(o, d): (DVec3, DVec3)| (w.point(o).as_vec3(), w.vector(d).normalize().as_vec3());
        Some(rays.map(world))
    }

    /// Film resolution in pixels.
    pub fn resolution(&self) -> (u32, u32) {
        self.resolution
    }

    /// The camera position in world space.
    pub fn position(&self) -> Vec3 {
        self.world_from_camera.point(DVec3::ZERO).as_vec3()
    }

    /// World-from-camera at `time` (where a moving camera is then).
    fn world_from_camera_at(&self, time: f32) -> Cow<'_, Transform> {
        match &self.motion {
            None => Cow::Borrowed(&self.world_from_camera),
            Some(m) => Cow::Owned(m.at(time as f64)),
        }
    }

    /// The world-space camera ray of the camera-space ray (`origin`, `dir`) at `time`, with the camera's `weight`.
    fn to_world(w: &Transform, origin: DVec3, dir: DVec3, time: f32, weight: f32) -> CameraRay {
        let o = w.point(origin).as_vec3();
        let d = w.vector(dir).normalize().as_vec3();
        CameraRay { origin: o, direction: d, time, weight }
    }

    /// True if the camera's rays depend on the wavelength (a realistic camera whose glass disperses): use
    /// [`Camera::generate_rays`] for them.
    pub fn is_dispersive(&self) -> bool {
        match &self.projection {
            Projection::Perspective { .. } | Projection::Orthographic => false,
            Projection::Realistic(lens) => lens.is_dispersive(),
        }
    }

    /// The ray through raster position `film` (pixels, y down) and lens sample `lens ∈ [0,1)²`, at `time` (where
    /// a moving camera is then). A realistic camera traces it at [`FOCUS_WAVELENGTH_NM`] (its glass may disperse:
    /// [`Camera::generate_rays`] gives each wavelength its own) and returns `None` where the lens stops it.
    pub fn generate_ray(&self, film: Vec2, lens: Vec2, time: f32) -> Option<CameraRay> {
        self.generate_ray_at(film, lens, time, FOCUS_WAVELENGTH_NM)
    }

    /// [`Camera::generate_ray`] for light of wavelength `lambda_nm` (which only a realistic camera's glass sees).
    pub fn generate_ray_at(&self, film: Vec2, lens: Vec2, time: f32, lambda_nm: f64) -> Option<CameraRay> {
        let w = &self.window;
        let sx = w.x_min + film.x / self.resolution.0 as f32 * (w.x_max - w.x_min);
        let sy = w.y_max - film.y / self.resolution.1 as f32 * (w.y_max - w.y_min);
        let (mut origin, mut dir) = match &self.projection {
            &Projection::Perspective { tan_half_fov } => {
                (Vec3::ZERO, Vec3::new(sx * tan_half_fov, sy * tan_half_fov, 1.0).normalize())
            }
            Projection::Orthographic => (Vec3::new(sx, sy, 0.0), Vec3::Z),
            Projection::Realistic(l) => {
                let exit = l.ray(film, lens, lambda_nm)?;
                let w = self.world_from_camera_at(time);
                return Some(Self::to_world(&w, exit.origin, exit.direction, time, exit.weight));
            }
        };
        if self.lens_radius > 0.0 {
            // Thin lens: rays through the lens point converge on the plane of focus (pbrt-v4 §5.2.3).
            let p_lens = self.lens_radius * sample_uniform_disk_concentric(lens);
            let ft = self.focal_distance / dir.z;
            let p_focus = origin + dir * ft;
            origin += Vec3::new(p_lens.x, p_lens.y, 0.0);
            dir = (p_focus - origin).normalize();
        }
        let w = self.world_from_camera_at(time);
        Some(Self::to_world(&w, origin.as_dvec3(), dir.as_dvec3(), time, 1.0))
    }

    /// The rays of a camera sample at the wavelengths `wl`: [`Camera::generate_ray`]'s, shared by every wavelength,
    /// unless the camera disperses; then one ray per wavelength, each refracted with its own indices through the
    /// same film point and the same point of the rear element.
    pub fn generate_rays(&self, film: Vec2, lens: Vec2, time: f32, wl: &SampledWavelengths) -> CameraRays {
        match &self.projection {
            Projection::Realistic(l) if l.is_dispersive() || l.filters_wavelengths() => {
                let exits = l.rays(film, lens, std::array::from_fn::<f64, N_WAVELENGTHS, _>(|i| wl.lambda(i) as f64));
                let w = self.world_from_camera_at(time);
                let rays = exits.map(|e| e.map(|e| Self::to_world(&w, e.origin, e.direction, time, e.weight)));
                if l.is_dispersive() {
                    return CameraRays::PerWavelength(rays);
                }
                // One path for all along the first ray that got through, the weights kept per wavelength.
                let weights = SampledSpectrum(rays.map(|r| r.map_or(0.0, |r| r.weight)));
                let first = rays.iter().flatten().next().map(|r| CameraRay { weight: 1.0, ..*r });
                CameraRays::Filtered(first, weights)
            }
            Projection::Perspective { .. } | Projection::Orthographic | Projection::Realistic(_) => {
                CameraRays::Shared(self.generate_ray(film, lens, time))
            }
        }
    }
}

/// A sampled connection from a point in the scene to the camera's lens (for light tracing).
#[derive(Clone, Copy, Debug)]
pub struct CameraWiSample {
    /// Unit direction from the reference point towards the lens point.
    pub wi: Vec3,
    /// Importance `We` of the ray from the lens point towards the reference point.
    pub we: f32,
    /// Density of the lens point with respect to solid angle at the reference point.
    pub pdf: f32,
    /// Where the ray lands on the film (pixels, y down).
    pub raster: Vec2,
    /// The lens point (world space).
    pub p_lens: Vec3,
    /// Distance from the reference point to the lens point.
    pub dist: f32,
}

impl Camera {
    /// Whether the camera has a finite-aperture importance function that light paths can connect to: perspective
    /// cameras (pinhole or thin lens). An orthographic camera's importance is a delta in direction.
    pub fn supports_light_tracing(&self) -> bool {
        // A full match (not `matches!`): a new projection must say whether light paths can reach it. A realistic
        // camera's importance would need the lens traced from the scene side (pbrt-v4 leaves it unimplemented).
        match self.projection {
            Projection::Perspective { .. } => true,
            Projection::Orthographic | Projection::Realistic(_) => false,
        }
    }

    /// True for a thin lens (finite aperture), false for a pinhole.
    pub fn lens_area_is_finite(&self) -> bool {
        self.lens_radius > 0.0
    }

    /// Unit viewing axis (camera +z) in world space.
    pub fn forward(&self) -> Vec3 {
        self.world_from_camera.vector(DVec3::Z).normalize().as_vec3()
    }

    /// Area of the film's window on the plane z = 1 in camera space (pbrt-v4's `A` in §16.1.1).
    fn image_plane_area(&self) -> f32 {
        match self.projection {
            Projection::Perspective { tan_half_fov } => {
                let w = &self.window;
                (w.x_max - w.x_min) * (w.y_max - w.y_min) * tan_half_fov * tan_half_fov
            }
            Projection::Orthographic | Projection::Realistic(_) => 0.0,
        }
    }

    /// Area of the lens (1 for a pinhole, whose position density is a delta).
    fn lens_area(&self) -> f32 {
        if self.lens_radius > 0.0 {
            std::f32::consts::PI * self.lens_radius * self.lens_radius
        } else {
            1.0
        }
    }

    /// Raster position of the camera-space ray from lens point `o` (z = 0) in direction `d`, if it is in front of
    /// the camera and lands on the film.
    fn raster_of(&self, o: Vec3, d: Vec3) -> Option<Vec2> {
        let Projection::Perspective { tan_half_fov } = &self.projection else { return None };
        let tan_half_fov = *tan_half_fov;
        if d.z <= 0.0 {
            return None;
        }
        // A thin lens sends every ray through the point where the chief ray of its film position meets the plane
        // of focus; a pinhole ray is its own chief ray (pbrt-v4 §5.2.3).
        let q = if self.lens_radius > 0.0 {
            let p_focus = o + d * (self.focal_distance / d.z);
            Vec2::new(p_focus.x, p_focus.y) / self.focal_distance
        } else {
            Vec2::new(d.x, d.y) / d.z
        };
        let (sx, sy) = (q.x / tan_half_fov, q.y / tan_half_fov);
        let w = &self.window;
        let x = (sx - w.x_min) / (w.x_max - w.x_min) * self.resolution.0 as f32;
        let y = (w.y_max - sy) / (w.y_max - w.y_min) * self.resolution.1 as f32;
        let inside = x >= 0.0 && y >= 0.0 && x < self.resolution.0 as f32 && y < self.resolution.1 as f32;
        inside.then_some(Vec2::new(x, y))
    }

    /// Importance `We` of the world-space ray leaving lens point `origin` in unit direction `dir`, and its raster
    /// position; `None` outside the film. `We = 1 / (A · A_lens · cos⁴θ)` (pbrt-v4 eq. 16.3 with the lens), so that
    /// ∫ We cosθ dω over the film is `1/A_lens` and a pixel's measurement is the radiance averaged over it.
    pub fn we(&self, origin: Vec3, dir: Vec3) -> Option<(f32, Vec2)> {
        let o = self.camera_from_world.point(origin.as_dvec3()).as_vec3();
        let d = self.camera_from_world.vector(dir.as_dvec3()).as_vec3().normalize_or_zero();
        let raster = self.raster_of(Vec3::new(o.x, o.y, 0.0), d)?;
        let cos = d.z;
        let cos2 = cos * cos;
        Some((1.0 / (self.image_plane_area() * self.lens_area() * cos2 * cos2), raster))
    }

    /// Densities with which [`Camera::generate_ray`] produces a ray in world direction `dir` with uniform film and
    /// lens samples: (per unit lens area, per steradian). `(0, 0)` outside the film.
    pub fn pdf_we(&self, origin: Vec3, dir: Vec3) -> (f32, f32) {
        if self.we(origin, dir).is_none() {
            return (0.0, 0.0);
        }
        let cos = self.camera_from_world.vector(dir.as_dvec3()).as_vec3().normalize_or_zero().z;
        (1.0 / self.lens_area(), 1.0 / (self.image_plane_area() * cos * cos * cos))
    }

    /// Samples a point on the lens with `u` and connects the world-space point `p_ref` to it: the importance
    /// arriving at `p_ref` from the camera, the density per solid angle at `p_ref`, and the raster position. `None`
    /// if the connection misses the film or the camera cannot be connected to (orthographic).
    pub fn sample_wi(&self, p_ref: Vec3, u: Vec2) -> Option<CameraWiSample> {
        if !self.supports_light_tracing() {
            return None;
        }
        let lens = self.lens_radius * sample_uniform_disk_concentric(u);
        let p_lens = self.world_from_camera.point(DVec3::new(lens.x as f64, lens.y as f64, 0.0)).as_vec3();
        let v = p_lens - p_ref;
        let dist = v.length();
        if dist.is_nan() || dist <= 0.0 {
            return None;
        }
        let wi = v / dist;
        let (we, raster) = self.we(p_lens, -wi)?;
        let cos = self.forward().dot(-wi).abs();
        // Area density 1/A_lens turned into solid angle at p_ref: dist² / (cos θ_lens · A_lens).
        let pdf = dist * dist / (cos * self.lens_area());
        Some(CameraWiSample { wi, we, pdf, raster, p_lens, dist })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn perspective_field_of_view_spans_the_shorter_axis() {
        let cam_from_world = Transform::look_at(DVec3::ZERO, DVec3::Z, DVec3::Y).unwrap();
        let fov = 60.0f32;
        let cam = Camera::new(
            Projection::Perspective { tan_half_fov: (fov.to_radians() / 2.0).tan() },
            &cam_from_world,
            (200, 100),
            ScreenWindow::for_aspect(2.0),
            0.0,
            1.0,
        );
        // Top edge centre of a 2:1 image: the shorter (vertical) axis spans the fov.
        let top = cam.generate_ray(Vec2::new(100.0, 0.0), Vec2::ZERO, 0.0).unwrap().direction;
        assert!((top.y.atan2(top.z).to_degrees() - 30.0).abs() < 1e-4);
        let centre = cam.generate_ray(Vec2::new(100.0, 50.0), Vec2::ZERO, 0.0).unwrap().direction;
        assert!((centre - Vec3::Z).length() < 1e-6);
        // Raster x to the right is world +x for this LookAt (pbrt's left-handed camera space).
        assert!(cam.generate_ray(Vec2::new(150.0, 50.0), Vec2::ZERO, 0.0).unwrap().direction.x > 0.0);
    }

    #[test]
    fn thin_lens_focuses_on_the_focal_plane() {
        let cam_from_world = Transform::look_at(DVec3::ZERO, DVec3::Z, DVec3::Y).unwrap();
        let cam = Camera::new(
            Projection::Perspective { tan_half_fov: 0.5 },
            &cam_from_world,
            (64, 64),
            ScreenWindow::for_aspect(1.0),
            0.2,
            5.0,
        );
        let film = Vec2::new(40.0, 20.0);
        let pinhole = cam.generate_ray(film, Vec2::splat(0.5), 0.0).unwrap();
        let target = pinhole.origin + pinhole.direction * (5.0 / pinhole.direction.z);
        for lens in [Vec2::new(0.1, 0.9), Vec2::new(0.8, 0.2), Vec2::new(0.0, 0.0)] {
            let r = cam.generate_ray(film, lens, 0.0).unwrap();
            let hit = r.origin + r.direction * ((5.0 - r.origin.z) / r.direction.z);
            assert!((hit - target).length() < 1e-4, "{hit} vs {target}");
        }
    }

    fn test_camera(lens_radius: f32) -> Camera {
        let cam_from_world =
            Transform::look_at(DVec3::new(0.3, -0.2, 0.1), DVec3::new(1.0, 0.5, 4.0), DVec3::Y).unwrap();
        Camera::new(
            Projection::Perspective { tan_half_fov: (25f32.to_radians()).tan() },
            &cam_from_world,
            (48, 32),
            ScreenWindow::for_aspect(1.5),
            lens_radius,
            3.0,
        )
    }

    #[test]
    fn importance_raster_inverts_generate_ray() {
        for lens_radius in [0.0, 0.05] {
            let cam = test_camera(lens_radius);
            for (film, lens) in [
                (Vec2::new(3.3, 7.9), Vec2::new(0.2, 0.7)),
                (Vec2::new(40.1, 30.5), Vec2::new(0.9, 0.1)),
                (Vec2::new(24.0, 16.0), Vec2::new(0.5, 0.5)),
            ] {
                let r = cam.generate_ray(film, lens, 0.0).unwrap();
                let (we, raster) = cam.we(r.origin, r.direction).expect("on the film");
                assert!((raster - film).length() < 2e-3, "{raster} vs {film}");
                assert!(we > 0.0);
            }
            // Behind the camera: no importance.
            assert!(cam.we(cam.position(), -cam.forward()).is_none());
        }
    }

    #[test]
    fn importance_integrates_to_one_over_the_film() {
        // ∫ We(ω) cosθ dω over the film's directions = 1 / A_lens (pbrt-v4 eq. 16.2); Monte Carlo with uniform
        // sphere directions from the lens centre (pinhole) — 200k samples, expected error ≈ 1%.
        let cam = test_camera(0.0);
        let n = 200_000;
        let mut sum = 0.0f64;
        for i in 0..n {
            let u = Vec2::new(((i as f32) + 0.5) / n as f32, ((i as u64 * 7919 % n as u64) as f32 + 0.5) / n as f32);
            let w = crate::sampling::sample_uniform_sphere(u);
            if let Some((we, _)) = cam.we(cam.position(), w) {
                sum += (we * w.dot(cam.forward())) as f64 * 4.0 * std::f64::consts::PI;
            }
        }
        let integral = sum / n as f64;
        assert!((integral - 1.0).abs() < 0.02, "∫ We cos dω = {integral}");
    }

    #[test]
    fn sample_wi_agrees_with_we_and_pdf_we() {
        for lens_radius in [0.0, 0.05] {
            let cam = test_camera(lens_radius);
            let r = cam.generate_ray(Vec2::new(10.5, 20.25), Vec2::new(0.3, 0.6), 0.0).unwrap();
            let p_ref = r.origin + 5.0 * r.direction;
            let s = cam.sample_wi(p_ref, Vec2::new(0.3, 0.6)).expect("visible");
            assert!((s.raster - Vec2::new(10.5, 20.25)).length() < 5e-3, "{}", s.raster);
            assert!((s.dist - 5.0).abs() < 1e-4);
            let (we, _) = cam.we(s.p_lens, -s.wi).unwrap();
            assert_eq!(we, s.we);
            let (pdf_pos, pdf_dir) = cam.pdf_we(s.p_lens, -s.wi);
            assert!(pdf_pos > 0.0 && pdf_dir > 0.0);
            let cos = cam.forward().dot(-s.wi);
            assert!(
                (s.pdf - s.dist * s.dist / (cos * if lens_radius > 0.0 { pdf_pos.recip() } else { 1.0 })).abs()
                    < 1e-3 * s.pdf
            );
        }
    }

    #[test]
    fn orthographic_rays_are_parallel() {
        let cam_from_world = Transform::look_at(DVec3::new(0.0, 0.0, -10.0), DVec3::ZERO, DVec3::Y).unwrap();
        let cam =
            Camera::new(Projection::Orthographic, &cam_from_world, (10, 10), ScreenWindow::for_aspect(1.0), 0.0, 1.0);
        let a = cam.generate_ray(Vec2::new(0.0, 0.0), Vec2::ZERO, 0.0).unwrap();
        let b = cam.generate_ray(Vec2::new(10.0, 10.0), Vec2::ZERO, 0.0).unwrap();
        assert!((a.direction - b.direction).length() < 1e-6);
        assert!(((a.origin - b.origin).length() - 8f32.sqrt()).abs() < 1e-5);
    }
}

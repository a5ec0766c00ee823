//! Cameras: pbrt-v4's perspective (with a thin lens) and orthographic projections.

use geometry::Transform;
use glam::{DVec3, Vec2, Vec3};

use crate::sampling::sample_uniform_disk_concentric;

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
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Perspective with tan(fov/2) for the unit screen extent.
    Perspective {
        /// tan of half the field of view.
        tan_half_fov: f32,
    },
    /// Orthographic: screen coordinates are camera-space lengths.
    Orthographic,
}

/// A camera in world (render) space.
#[derive(Clone, Debug)]
pub struct Camera {
    projection: Projection,
    world_from_camera: Transform,
    resolution: (u32, u32),
    window: ScreenWindow,
    lens_radius: f32,
    focal_distance: f32,
}

/// A generated camera ray in world space.
#[derive(Clone, Copy, Debug)]
pub struct CameraRay {
    /// Origin.
    pub origin: Vec3,
    /// Unit direction.
    pub direction: Vec3,
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
            resolution,
            window,
            lens_radius,
            focal_distance,
        }
    }

    /// Film resolution in pixels.
    pub fn resolution(&self) -> (u32, u32) {
        self.resolution
    }

    /// The camera position in world space.
    pub fn position(&self) -> Vec3 {
        self.world_from_camera.point(DVec3::ZERO).as_vec3()
    }

    /// The ray through raster position `film` (pixels, y down) and lens sample `lens ∈ [0,1)²`.
    pub fn generate_ray(&self, film: Vec2, lens: Vec2) -> CameraRay {
        let w = &self.window;
        let sx = w.x_min + film.x / self.resolution.0 as f32 * (w.x_max - w.x_min);
        let sy = w.y_max - film.y / self.resolution.1 as f32 * (w.y_max - w.y_min);
        let (mut origin, mut dir) = match self.projection {
            Projection::Perspective { tan_half_fov } => {
                (Vec3::ZERO, Vec3::new(sx * tan_half_fov, sy * tan_half_fov, 1.0).normalize())
            }
            Projection::Orthographic => (Vec3::new(sx, sy, 0.0), Vec3::Z),
        };
        if self.lens_radius > 0.0 {
            // Thin lens: rays through the lens point converge on the plane of focus (pbrt-v4 §5.2.3).
            let p_lens = self.lens_radius * sample_uniform_disk_concentric(lens);
            let ft = self.focal_distance / dir.z;
            let p_focus = origin + dir * ft;
            origin += Vec3::new(p_lens.x, p_lens.y, 0.0);
            dir = (p_focus - origin).normalize();
        }
        let o = self.world_from_camera.point(origin.as_dvec3()).as_vec3();
        let d = self.world_from_camera.vector(dir.as_dvec3()).normalize().as_vec3();
        CameraRay { origin: o, direction: d }
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
        let top = cam.generate_ray(Vec2::new(100.0, 0.0), Vec2::ZERO).direction;
        assert!((top.y.atan2(top.z).to_degrees() - 30.0).abs() < 1e-4);
        let centre = cam.generate_ray(Vec2::new(100.0, 50.0), Vec2::ZERO).direction;
        assert!((centre - Vec3::Z).length() < 1e-6);
        // Raster x to the right is world +x for this LookAt (pbrt's left-handed camera space).
        assert!(cam.generate_ray(Vec2::new(150.0, 50.0), Vec2::ZERO).direction.x > 0.0);
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
        let pinhole = cam.generate_ray(film, Vec2::splat(0.5));
        let target = pinhole.origin + pinhole.direction * (5.0 / pinhole.direction.z);
        for lens in [Vec2::new(0.1, 0.9), Vec2::new(0.8, 0.2), Vec2::new(0.0, 0.0)] {
            let r = cam.generate_ray(film, lens);
            let hit = r.origin + r.direction * ((5.0 - r.origin.z) / r.direction.z);
            assert!((hit - target).length() < 1e-4, "{hit} vs {target}");
        }
    }

    #[test]
    fn orthographic_rays_are_parallel() {
        let cam_from_world = Transform::look_at(DVec3::new(0.0, 0.0, -10.0), DVec3::ZERO, DVec3::Y).unwrap();
        let cam =
            Camera::new(Projection::Orthographic, &cam_from_world, (10, 10), ScreenWindow::for_aspect(1.0), 0.0, 1.0);
        let a = cam.generate_ray(Vec2::new(0.0, 0.0), Vec2::ZERO);
        let b = cam.generate_ray(Vec2::new(10.0, 10.0), Vec2::ZERO);
        assert!((a.direction - b.direction).length() < 1e-6);
        assert!(((a.origin - b.origin).length() - 8f32.sqrt()).abs() < 1e-5);
    }
}

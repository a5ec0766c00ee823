//! Ray footprints on surfaces: how a hit point and its (u, v) change from one pixel to the next, which picks the MIP
//! level or sizes the filter of image textures (pbrt-v4's `SurfaceInteraction::ComputeDifferentials` and
//! `CameraBase::Approximate_dp_dxy`).
//!
//! A camera ray's hit uses the camera ray's own differentials: the rays one pixel to the right and one pixel down
//! ([`Camera::ray_differential`]) meet the hit's tangent plane. Every other hit (after a bounce, on a light path)
//! uses pbrt-v4's approximation: the camera's smallest differentials over the film, turned to look at the point,
//! meet the tangent plane there. Both are scaled by pbrt-v4's max(1/8, 1/√spp), since a pixel's samples together
//! cover the pixel. dp/dx and dp/dy then give (du/dx, dv/dx) and (du/dy, dv/dy) by least squares against the
//! surface's ∂p/∂u and ∂p/∂v.
//!
//! Only hits on materials that read an image map compute footprints ([`crate::RenderScene::reads_footprint`]);
//! the others evaluate every texture at a point.

use glam::{Quat, Vec2, Vec3};

use crate::camera::Camera;
use crate::scene::SurfaceHit;
use crate::texture::TextureEvalContext;

/// What a scene needs to find footprints: the camera's smallest differentials and the scale for the sample count.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Footprints {
    /// max(1/8, 1/√spp).
    scale: f32,
    /// The shortest change of a camera ray's origin per pixel along x and along y (camera space).
    min_pos: [Vec3; 2],
    /// The shortest change of a camera ray's unit direction per pixel along x and along y, in the frame whose z is
    /// the ray.
    min_dir: [Vec3; 2],
}

/// A unit vector's frame (x, y, z = v), for pbrt-v4's `Frame::FromZ`.
fn frame_from_z(v: Vec3) -> [Vec3; 3] {
    let (x, y) = v.any_orthonormal_pair();
    [x, y, v]
}

impl Footprints {
    /// The footprints of `camera` for renders of `spp` samples per pixel. As pbrt-v4's `FindMinimumDifferentials`,
    /// the smallest differentials are searched among the rays through 512 points along the film's diagonal, from
    /// the lens centre.
    pub fn new(camera: &Camera, spp: u32) -> Self {
        let scale = (1.0 / (spp.max(1) as f32).sqrt()).max(0.125);
        // A moving camera's differentials are the same in its own space at any time.
        let camera = camera.at_time(0.0);
        let (w, h) = camera.resolution();
        let m = camera.camera_from_world();
        let to_camera = |v: Vec3| m.vector(v.as_dvec3()).as_vec3();
        let mut min_pos = [Vec3::INFINITY; 2];
        let mut min_dir = [Vec3::INFINITY; 2];
        let n = 512;
        for i in 0..n {
            let f = i as f32 / (n - 1) as f32;
            let Some(ray) = camera.generate_ray(Vec2::new(f * w as f32, f * h as f32), Vec2::splat(0.5), 0.0) else {
                continue;
            };
            let Some(neighbours) = camera.ray_differential(ray.origin, ray.direction, 0.0) else { continue };
            let d = to_camera(ray.direction).normalize_or_zero();
            let frame = frame_from_z(d);
            for (k, (o, dir)) in neighbours.into_iter().enumerate() {
                let dpos = to_camera(o - ray.origin);
                if dpos.length() < min_pos[k].length() {
                    min_pos[k] = dpos;
                }
                let local = {
                    let v = to_camera(dir);
                    Vec3::new(v.dot(frame[0]), v.dot(frame[1]), v.dot(frame[2])).normalize_or_zero()
                };
                let ddir = local - Vec3::Z;
                if ddir.length() < min_dir[k].length() {
                    min_dir[k] = ddir;
                }
            }
        }
        let finite = |v: Vec3| if v.is_finite() { v } else { Vec3::ZERO };
        Self { scale, min_pos: min_pos.map(finite), min_dir: min_dir.map(finite) }
    }

    /// dp/dx and dp/dy at `hit`: from the camera ray that found it, if it is one (`camera_ray`: its lens point and
    /// direction), else from the camera's approximation. Zero where neither meets the tangent plane.
    pub fn dp_dxy(&self, camera: &Camera, hit: &SurfaceHit, camera_ray: Option<(Vec3, Vec3)>) -> (Vec3, Vec3) {
        let (p, n) = (hit.p, hit.n);
        if let Some(rays) = camera_ray.and_then(|(o, d)| camera.ray_differential(o, d, hit.time).map(|r| (o, d, r))) {
            let (o, d, [(xo, xd), (yo, yd)]) = rays;
            // pbrt-v4's ScaleDifferentials, then the tangent plane n·x = n·p met by each shifted ray.
            let meet = |ro: Vec3, rd: Vec3| {
                let (ro, rd) = (o + (ro - o) * self.scale, d + (rd - d) * self.scale);
                let t = n.dot(p - ro) / n.dot(rd);
                let q = ro + rd * t;
                q.is_finite().then(|| q - p)
            };
            if let (Some(dx), Some(dy)) = (meet(xo, xd), meet(yo, yd)) {
                return (dx, dy);
            }
        }
        self.approximate(camera, p, n, hit.time)
    }

    /// pbrt-v4's `Approximate_dp_dxy`: the smallest camera differentials, in a frame looking straight at `p`, meet
    /// the tangent plane of normal `n` there.
    fn approximate(&self, camera: &Camera, p: Vec3, n: Vec3, time: f32) -> (Vec3, Vec3) {
        let camera = camera.at_time(time);
        let p_cam = camera.camera_from_world().point(p.as_dvec3()).as_vec3();
        let n_cam = camera.camera_from_world().normal(n.as_dvec3()).as_vec3().normalize_or_zero();
        let Some(towards) = p_cam.try_normalize() else { return (Vec3::ZERO, Vec3::ZERO) };
        let down_z = Quat::from_rotation_arc(towards, Vec3::Z);
        let (p_z, n_z) = (down_z * p_cam, down_z * n_cam);
        let d = n_z.dot(p_z);
        let w = camera.world_from_camera();
        let step = |k: usize| {
            let (o, dir) = (self.min_pos[k], Vec3::Z + self.min_dir[k]);
            let t = (d - n_z.dot(o)) / n_z.dot(dir);
            let q = o + dir * t;
            let v = self.scale * (down_z.inverse() * (q - p_z));
            let v = w.vector(v.as_dvec3()).as_vec3();
            if v.is_finite() {
                v
            } else {
                Vec3::ZERO
            }
        };
        (step(0), step(1))
    }

    /// The texture context at `hit` with its footprint (see [`Footprints::dp_dxy`]).
    pub fn context(&self, camera: &Camera, hit: &SurfaceHit, camera_ray: Option<(Vec3, Vec3)>) -> TextureEvalContext {
        let (dpdx, dpdy) = self.dp_dxy(camera, hit, camera_ray);
        let duv = uv_derivatives(hit.surface_dpdu, hit.surface_dpdv, dpdx, dpdy);
        TextureEvalContext { p: hit.p, n: hit.n, uv: hit.uv, dpdx, dpdy, duv, vertex_color: hit.vertex_color }
    }
}

/// (du/dx, du/dy, dv/dx, dv/dy) from dp/dx and dp/dy by least squares against ∂p/∂u and ∂p/∂v (pbrt-v4's
/// `ComputeDifferentials`: the normal equations of dp = ∂p/∂u·du + ∂p/∂v·dv), clamped to ±10⁸, non-finite values
/// zero.
pub fn uv_derivatives(dpdu: Vec3, dpdv: Vec3, dpdx: Vec3, dpdy: Vec3) -> [f32; 4] {
    let (a00, a01, a11) = (dpdu.dot(dpdu), dpdu.dot(dpdv), dpdv.dot(dpdv));
    let inv_det = 1.0 / (a00 * a11 - a01 * a01);
    let inv_det = if inv_det.is_finite() { inv_det } else { 0.0 };
    let solve = |dp: Vec3| {
        let (b0, b1) = (dpdu.dot(dp), dpdv.dot(dp));
        ((a11 * b0 - a01 * b1) * inv_det, (a00 * b1 - a01 * b0) * inv_det)
    };
    let ((dudx, dvdx), (dudy, dvdy)) = (solve(dpdx), solve(dpdy));
    [dudx, dudy, dvdx, dvdy].map(|v| if v.is_finite() { v.clamp(-1e8, 1e8) } else { 0.0 })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Projection, ScreenWindow};
    use geometry::Transform;

    /// A 100×100 camera at the origin looking down +z, screen window [−1, 1]².
    fn camera(projection: Projection) -> Camera {
        let window = ScreenWindow { x_min: -1.0, x_max: 1.0, y_min: -1.0, y_max: 1.0 };
        Camera::new(projection, &Transform::IDENTITY, (100, 100), window, 0.0, 1.0)
    }

    /// A hit at `p` on the plane z = 5 (normal towards the camera), with ∂p/∂u = (2, 0, 0), ∂p/∂v = (0, 1, 0).
    fn hit(p: Vec3) -> SurfaceHit {
        SurfaceHit {
            t: p.length(),
            p,
            n: -Vec3::Z,
            ns: -Vec3::Z,
            uv: Vec2::ZERO,
            dpdu: Vec3::X,
            surface_dpdu: Vec3::new(2.0, 0.0, 0.0),
            surface_dpdv: Vec3::Y,
            shading_dpdu: Vec3::X,
            shading_dpdv: Vec3::Y,
            p_error: Vec3::ZERO,
            material: 0,
            area_light: None,
            media: None,
            time: 0.0,
            vertex_color: None,
        }
    }

    #[test]
    fn uv_derivatives_solve_the_normal_equations() {
        // dp = 2·∂p/∂u + 0.5·∂p/∂v plus a part along the normal, which least squares ignores.
        let (dpdu, dpdv) = (Vec3::new(2.0, 0.0, 0.0), Vec3::new(1.0, 3.0, 0.0));
        let dx = 2.0 * dpdu + 0.5 * dpdv + Vec3::new(0.0, 0.0, 7.0);
        let dy = -1.0 * dpdu + 0.25 * dpdv;
        let [dudx, dudy, dvdx, dvdy] = uv_derivatives(dpdu, dpdv, dx, dy);
        for (got, want) in [(dudx, 2.0), (dudy, -1.0), (dvdx, 0.5), (dvdy, 0.25)] {
            assert!((got - want).abs() < 1e-6, "{got} vs {want}");
        }
        // A degenerate parameterisation gives no footprint rather than infinities.
        assert_eq!(uv_derivatives(Vec3::X, Vec3::X, dx, dy), [0.0; 4]);
    }

    #[test]
    fn a_plane_facing_the_camera_has_the_pixel_footprint_scaled_for_the_sample_count() {
        // Pinhole, fov 90° (tan = 1): at depth 5 a pixel is 5·2/100 = 0.1 wide; 16 spp scale it by 1/4.
        let cam = camera(Projection::Perspective { tan_half_fov: 1.0 });
        let f = Footprints::new(&cam, 16);
        let h = hit(Vec3::new(0.0, 0.0, 5.0));
        let (dx, dy) = f.dp_dxy(&cam, &h, Some((Vec3::ZERO, Vec3::Z)));
        assert!((dx - Vec3::new(0.025, 0.0, 0.0)).length() < 1e-5, "{dx}");
        // Film y grows downwards.
        assert!((dy - Vec3::new(0.0, -0.025, 0.0)).length() < 1e-5, "{dy}");
        // The context's (u, v) derivatives: u moves half as fast as x (∂p/∂u = 2).
        let ctx = f.context(&cam, &h, Some((Vec3::ZERO, Vec3::Z)));
        let want = [0.0125, 0.0, 0.0, -0.025];
        assert!(ctx.duv.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-5), "{:?}", ctx.duv);
        // Without the camera ray, pbrt-v4's approximation: the smallest change of a camera ray's direction per pixel
        // (at the film's bottom-right corner, screen (1, −1), where a pixel subtends the least angle), turned to
        // look at the point, meets its tangent plane at depth 5.
        let (a, b) = (Vec3::new(1.0, -1.0, 1.0).normalize(), Vec3::new(1.02, -1.0, 1.0).normalize());
        let want = 0.25 * 5.0 * (b - a).length();
        let (ax, ay) = f.dp_dxy(&cam, &h, None);
        for v in [ax, ay] {
            assert!((v.length() - want).abs() < 1e-3 * want && v.z.abs() < 1e-6, "{v} vs {want}");
        }
        // One sample per pixel is the whole pixel; very many never less than 1/8 of it.
        let (d1, _) = Footprints::new(&cam, 1).dp_dxy(&cam, &h, Some((Vec3::ZERO, Vec3::Z)));
        let (d4096, _) = Footprints::new(&cam, 4096).dp_dxy(&cam, &h, Some((Vec3::ZERO, Vec3::Z)));
        assert!((d1.x - 0.1).abs() < 1e-5 && (d4096.x - 0.1 / 8.0).abs() < 1e-5, "{d1} {d4096}");
        // Orthographic: a pixel is 2/100 wide at any depth, by the camera ray and by the approximation.
        let cam = camera(Projection::Orthographic);
        let f = Footprints::new(&cam, 1);
        let o = Vec3::new(0.3, -0.2, 0.0);
        let (dx, dy) = f.dp_dxy(&cam, &hit(o + 5.0 * Vec3::Z), Some((o, Vec3::Z)));
        assert!((dx - Vec3::new(0.02, 0.0, 0.0)).length() < 1e-6 && (dy - Vec3::new(0.0, -0.02, 0.0)).length() < 1e-6);
        let (ax, _) = f.dp_dxy(&cam, &hit(Vec3::new(0.0, 0.0, 5.0)), None);
        assert!((ax.length() - 0.02).abs() < 1e-5, "{ax}");
    }
}

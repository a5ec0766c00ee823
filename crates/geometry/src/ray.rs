//! Rays, floating-point error bounds and robust spawning of rays from surfaces (pbrt-v4 book §6.8).
//!
//! Every intersection routine in this crate returns, with the hit point, a conservative bound on the absolute error
//! of each of its coordinates (`p_error`). A ray leaving the surface starts from the hit point pushed along the
//! geometric normal just far enough to leave that error box, to the side the ray goes (reflection or
//! transmission), and then rounded away from the surface. Such a ray can never re-intersect the surface it leaves.

use glam::Vec3;

/// A ray `o + t·d`, `t ≥ 0`. `d` need not be normalized: every `t` (hits, `t_max`) is in units of `|d|`. Rays made by
/// this crate ([`spawn_ray`], [`spawn_ray_to`]) have a unit `d`, so there `t` is a distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Origin.
    pub o: Vec3,
    /// Direction.
    pub d: Vec3,
    /// The time the ray is traced at (within the camera's shutter interval): moving geometry is intersected where
    /// it is at that time. Static geometry ignores it.
    pub time: f32,
}

impl Ray {
    /// A ray from `o` along `d` at time 0.
    pub fn new(o: Vec3, d: Vec3) -> Self {
        Self { o, d, time: 0.0 }
    }

    /// A ray from `o` along `d` at time `time`.
    pub fn at_time(o: Vec3, d: Vec3, time: f32) -> Self {
        Self { o, d, time }
    }

    /// The point at parameter `t`.
    pub fn at(&self, t: f32) -> Vec3 {
        self.o + self.d * t
    }
}

/// pbrt's γ(n) = n·ε / (1 − n·ε) with ε = f32::EPSILON / 2, the bound on the relative error of `n` successive
/// rounded f32 operations.
#[inline]
pub fn gamma(n: i32) -> f32 {
    let e = f32::EPSILON * 0.5 * n as f32;
    e / (1.0 - e)
}

/// The next f32 above `v` (towards +∞); +∞ and NaN unchanged.
#[inline]
pub fn next_float_up(v: f32) -> f32 {
    if v.is_infinite() && v > 0.0 || v.is_nan() {
        return v;
    }
    let v = if v == -0.0 { 0.0 } else { v };
    let bits = v.to_bits();
    let bits = if v >= 0.0 { bits + 1 } else { bits - 1 };
    f32::from_bits(bits)
}

/// The next f32 below `v` (towards −∞); −∞ and NaN unchanged.
#[inline]
pub fn next_float_down(v: f32) -> f32 {
    if v.is_infinite() && v < 0.0 || v.is_nan() {
        return v;
    }
    let v = if v == 0.0 { -0.0 } else { v };
    let bits = v.to_bits();
    let bits = if v > 0.0 { bits - 1 } else { bits + 1 };
    f32::from_bits(bits)
}

/// A point on a surface as needed to spawn rays from it: position, per-coordinate absolute error bound of the
/// position, and geometric normal (either orientation; unit length not required).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    /// Position.
    pub p: Vec3,
    /// Conservative absolute error bound of each coordinate of `p`.
    pub p_error: Vec3,
    /// Geometric normal.
    pub n: Vec3,
}

/// Shadow rays stop this fraction of their length short of the target (pbrt's `ShadowEpsilon`).
pub const SHADOW_EPSILON: f32 = 1e-4;

/// pbrt-v4's `OffsetRayOrigin`: moves `p` along the normal `n` by the projection of its error box onto `n`, to the
/// side of the surface that `w` points to, and rounds each coordinate away from `p`, so that a ray from the result
/// along `w` cannot hit the surface that `p` lies on. `w` may point to either side (reflection or transmission).
#[inline]
pub fn offset_ray_origin(p: Vec3, p_error: Vec3, n: Vec3, w: Vec3) -> Vec3 {
    let d = n.abs().dot(p_error);
    let mut offset = n * d;
    if w.dot(n) < 0.0 {
        offset = -offset;
    }
    let po = p + offset;
    // Both neighbours computed and one selected, so the compiler can use selects instead of branches on the
    // offset's signs (which a path tracer's random directions make unpredictable).
    let round = |x: f32, o: f32| {
        let (up, down) = (next_float_up(x), next_float_down(x));
        if o > 0.0 {
            up
        } else if o < 0.0 {
            down
        } else {
            x
        }
    };
    Vec3::new(round(po.x, offset.x), round(po.y, offset.y), round(po.z, offset.z))
}

/// A ray leaving the surface point `sp` in direction `w` (normalized here), whose origin is offset so it never
/// re-hits the surface it leaves, to whichever side `w` points.
#[inline]
pub fn spawn_ray(sp: &SurfacePoint, w: Vec3) -> Ray {
    Ray { o: offset_ray_origin(sp.p, sp.p_error, sp.n, w), d: w.normalize_or_zero(), time: 0.0 }
}

/// A ray from the surface point `sp` towards the point `p_to` (not on a surface, e.g. a point light): returns the
/// ray (unit direction) and the `t_max` to use, which stops `SHADOW_EPSILON` of the length short of `p_to`.
#[inline]
pub fn spawn_ray_to_point(sp: &SurfacePoint, p_to: Vec3) -> (Ray, f32) {
    let o = offset_ray_origin(sp.p, sp.p_error, sp.n, p_to - sp.p);
    let d = p_to - o;
    let len = d.length();
    if len == 0.0 || !len.is_finite() {
        return (Ray { o, d: Vec3::Z, time: 0.0 }, 0.0);
    }
    (Ray { o, d: d / len, time: 0.0 }, len * (1.0 - SHADOW_EPSILON))
}

/// A shadow ray between two surface points (pbrt-v4's `SpawnRayTo`): both ends are offset off their surfaces towards
/// each other, and the returned `t_max` stops `SHADOW_EPSILON` of the length short of the target, so neither
/// surface is hit. Returns the ray (unit direction) and `t_max`; `t_max` is 0 if the points coincide.
#[inline]
pub fn spawn_ray_to(from: &SurfacePoint, to: &SurfacePoint) -> (Ray, f32) {
    let mut pf = offset_ray_origin(from.p, from.p_error, from.n, to.p - from.p);
    let mut pt = offset_ray_origin(to.p, to.p_error, to.n, pf - to.p);
    let mut d = pt - pf;
    // Near-tangent segments: the final direction may leave a surface on the other side than the one each end was
    // offset to; then redo the offsets with the final direction.
    let side = |a: Vec3, b: Vec3, n: Vec3| (a.dot(n) > 0.0) == (b.dot(n) > 0.0);
    if !side(d, to.p - from.p, from.n) || !side(-d, pf - to.p, to.n) {
        pf = offset_ray_origin(from.p, from.p_error, from.n, d);
        pt = offset_ray_origin(to.p, to.p_error, to.n, -d);
        d = pt - pf;
    }
    let len = d.length();
    if len == 0.0 || !len.is_finite() {
        return (Ray { o: pf, d: Vec3::Z, time: 0.0 }, 0.0);
    }
    (Ray { o: pf, d: d / len, time: 0.0 }, len * (1.0 - SHADOW_EPSILON))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn next_float_steps_by_one_ulp() {
        assert!(next_float_up(1.0) > 1.0 && next_float_up(1.0) - 1.0 == f32::EPSILON);
        assert!(next_float_down(1.0) < 1.0);
        assert!(next_float_up(0.0) > 0.0 && next_float_up(-0.0) > 0.0);
        assert!(next_float_down(0.0) < 0.0);
        assert!(next_float_up(-1.0) > -1.0);
        assert_eq!(next_float_up(f32::INFINITY), f32::INFINITY);
    }

    #[test]
    fn offset_goes_to_the_side_of_w() {
        let p = Vec3::new(1.0, 2.0, 3.0);
        let e = Vec3::splat(1e-6);
        let n = Vec3::Z;
        assert!(offset_ray_origin(p, e, n, Vec3::Z).z > p.z);
        assert!(offset_ray_origin(p, e, n, -Vec3::Z).z < p.z);
        // Even with a zero error bound the origin moves by one ulp off the plane.
        assert!(offset_ray_origin(p, Vec3::ZERO, n, Vec3::Z).z >= p.z);
    }
}

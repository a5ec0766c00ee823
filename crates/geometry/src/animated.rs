//! Transforms that move during the shutter interval: pbrt-v4's `AnimatedTransform` (pbrt-v4 book §3.10, after
//! Shoemake & Duff 1992). Each end transform is split into a translation T, a rotation R and a symmetric stretch S
//! (M = T·R·S, R·S the polar decomposition of M's linear part); in between, T and S are interpolated linearly and R
//! by spherical linear interpolation of its unit quaternion (Shoemake 1985), so a rotating object turns at a
//! constant angular speed instead of shrinking as a matrix blend would.

use glam::{DMat3, DMat4, DQuat, DVec3, Vec3};

use crate::bounds::Bounds3;
use crate::ray::gamma;
use crate::transform::Transform;

/// An affine transform split into translation, rotation and stretch: `M = T·R·S`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Decomposed {
    /// The translation (the matrix's last column).
    pub t: DVec3,
    /// The rotation, a unit quaternion.
    pub r: DQuat,
    /// The symmetric stretch that remains once the rotation is taken out (R·S is the polar decomposition of the
    /// linear part; for a reflection both R and S are negated, so that R stays a rotation).
    pub s: DMat3,
}

impl Decomposed {
    /// Splits `m` into T·R·S; `None` for a projective matrix (bottom row not 0 0 0 1), a singular linear part or
    /// non-finite entries.
    pub fn new(m: &DMat4) -> Option<Self> {
        if !m.is_finite() || m.row(3) != glam::DVec4::new(0.0, 0.0, 0.0, 1.0) {
            return None;
        }
        let linear = DMat3::from_mat4(*m);
        let det = linear.determinant();
        if det.abs() < 1e-300 {
            return None;
        }
        // Polar decomposition by Newton's iteration R ← (R + R⁻ᵀ)/2, which converges to the orthogonal factor
        // (Higham 1986); pbrt-v4 stops after 100 steps or when the change is small.
        let mut r = linear;
        for _ in 0..100 {
            let next = (r + r.transpose().inverse()) * 0.5;
            let change = (0..3).map(|c| (next.col(c) - r.col(c)).abs().max_element()).fold(0.0, f64::max);
            r = next;
            if change < 1e-14 {
                break;
            }
        }
        if !r.is_finite() {
            return None;
        }
        if det < 0.0 {
            // A reflection: −R is a rotation and (−R)(−S) = R·S.
            r = -r;
        }
        let s = r.transpose() * linear;
        Some(Self { t: m.w_axis.truncate(), r: DQuat::from_mat3(&r).normalize(), s })
    }

    /// The matrix T·R·S.
    pub fn matrix(&self) -> DMat4 {
        let rs = DMat3::from_quat(self.r) * self.s;
        DMat4::from_cols(rs.x_axis.extend(0.0), rs.y_axis.extend(0.0), rs.z_axis.extend(0.0), self.t.extend(1.0))
    }

    /// The transform T·R·S with its inverse S⁻¹·Rᵀ·T⁻¹ (a NaN inverse if S is singular).
    pub fn transform(&self) -> Transform {
        let m = self.matrix();
        let s_inv = self.s.inverse();
        if !s_inv.is_finite() {
            return Transform::from_matrix_allow_singular(m).unwrap_or(Transform::IDENTITY);
        }
        let lin_inv = s_inv * DMat3::from_quat(self.r.conjugate());
        let t_inv = -(lin_inv * self.t);
        let inv = DMat4::from_cols(
            lin_inv.x_axis.extend(0.0),
            lin_inv.y_axis.extend(0.0),
            lin_inv.z_axis.extend(0.0),
            t_inv.extend(1.0),
        );
        Transform::from_matrix_and_inverse(m, inv)
    }
}

/// Spherical linear interpolation between unit quaternions `a` and `b` (which the caller has put in the same
/// hemisphere): constant angular speed along the great arc (Shoemake 1985); a normalised linear blend when the arc
/// is too short for the sine ratio to be accurate.
pub fn slerp(a: DQuat, b: DQuat, t: f64) -> DQuat {
    let cos = a.dot(b).clamp(-1.0, 1.0);
    if cos > 0.9995 {
        return (a * (1.0 - t) + b * t).normalize();
    }
    let theta = cos.acos();
    // The unit quaternion perpendicular to a in the plane of a and b, then a turned by t·θ towards it.
    let perp = (b - a * cos).normalize();
    a * (theta * t).cos() + perp * (theta * t).sin()
}

/// A transform that moves from `start` at `start_time` to `end` at `end_time` (pbrt-v4's `AnimatedTransform`):
/// before `start_time` it is `start`, after `end_time` it is `end`, and in between the decompositions of the two
/// are interpolated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnimatedTransform {
    start: Transform,
    end: Transform,
    start_time: f64,
    end_time: f64,
    /// False when both ends are the same matrix: then it is `start` at every time.
    animated: bool,
    d0: Decomposed,
    d1: Decomposed,
}

impl AnimatedTransform {
    /// A transform that does not move.
    pub fn fixed(t: Transform) -> Self {
        let d = Decomposed::new(&t.matrix()).unwrap_or(Decomposed {
            t: DVec3::ZERO,
            r: DQuat::IDENTITY,
            s: DMat3::IDENTITY,
        });
        Self { start: t, end: t, start_time: 0.0, end_time: 1.0, animated: false, d0: d, d1: d }
    }

    /// `start` at `start_time` moving to `end` at `end_time`. `None` if the times are not finite or
    /// `end_time < start_time`, or if a moving transform cannot be split into translation, rotation and stretch
    /// (a projective or singular matrix).
    pub fn new(start: Transform, start_time: f64, end: Transform, end_time: f64) -> Option<Self> {
        if !(start_time.is_finite() && end_time.is_finite() && end_time >= start_time) {
            return None;
        }
        if start.matrix() == end.matrix() {
            return Some(Self { start_time, end_time, ..Self::fixed(start) });
        }
        let d0 = Decomposed::new(&start.matrix())?;
        let mut d1 = Decomposed::new(&end.matrix())?;
        // q and −q are the same rotation: take the one that makes the shorter arc.
        if d0.r.dot(d1.r) < 0.0 {
            d1.r = -d1.r;
        }
        Some(Self { start, end, start_time, end_time, animated: true, d0, d1 })
    }

    /// True if the two ends differ.
    pub fn is_animated(&self) -> bool {
        self.animated
    }

    /// The transform at the start time.
    pub fn start(&self) -> &Transform {
        &self.start
    }

    /// The transform at the end time.
    pub fn end(&self) -> &Transform {
        &self.end
    }

    /// The fraction of the way from start to end at `time`, in [0, 1].
    fn fraction(&self, time: f64) -> f64 {
        if time <= self.start_time || self.end_time <= self.start_time {
            return if time <= self.start_time { 0.0 } else { 1.0 };
        }
        ((time - self.start_time) / (self.end_time - self.start_time)).min(1.0)
    }

    /// The transform at `time`: exactly `start` or `end` at and beyond the two times.
    pub fn at(&self, time: f64) -> Transform {
        if !self.animated {
            return self.start;
        }
        let f = self.fraction(time);
        if f <= 0.0 {
            return self.start;
        }
        if f >= 1.0 {
            return self.end;
        }
        self.interpolated(f).transform()
    }

    /// The decomposition at fraction `f` of the way.
    fn interpolated(&self, f: f64) -> Decomposed {
        Decomposed {
            t: self.d0.t.lerp(self.d1.t, f),
            r: slerp(self.d0.r, self.d1.r, f),
            s: self.d0.s * (1.0 - f) + self.d1.s * f,
        }
    }

    /// A box holding every point of `b` under the transform at every time (pbrt-v4's `MotionBounds`, computed
    /// differently: conservative by construction rather than exact).
    ///
    /// Without a change of rotation every point moves along a straight segment (T and S are linear in time), so the
    /// union of the two ends' boxes holds the motion. With one, the box of 33 evenly spaced times is grown by how far
    /// a point can move between neighbours: its speed is at most |ΔT| + ω·|S p| + |ΔS p| (ω the rotation's angle), and
    /// the result is also clipped to the sphere swept by the translation with radius max |S p|, which holds every
    /// rotated point.
    pub fn motion_bounds(&self, b: &Bounds3) -> Bounds3 {
        if b.is_empty() {
            return Bounds3::EMPTY;
        }
        let ends = transform_bounds(&self.start, b).union(&transform_bounds(&self.end, b));
        if !self.animated || self.d0.r == self.d1.r {
            return ends;
        }
        let corners: Vec<DVec3> = (0..8)
            .map(|c| {
                DVec3::new(
                    if c & 1 == 0 { b.min.x } else { b.max.x } as f64,
                    if c & 2 == 0 { b.min.y } else { b.max.y } as f64,
                    if c & 4 == 0 { b.min.z } else { b.max.z } as f64,
                )
            })
            .collect();
        // |S(f) p| is convex in p and in f, so its largest value is at a corner at one end; likewise |ΔS p|.
        let reach = corners.iter().map(|&c| (self.d0.s * c).length().max((self.d1.s * c).length())).fold(0.0, f64::max);
        let ds = self.d1.s - self.d0.s;
        let stretch_speed = corners.iter().map(|&c| (ds * c).length()).fold(0.0, f64::max);
        let angle = 2.0 * self.d0.r.dot(self.d1.r).clamp(-1.0, 1.0).acos();
        let speed = (self.d1.t - self.d0.t).length() + angle * reach + stretch_speed;
        const STEPS: usize = 32;
        let mut sampled = ends;
        for k in 1..STEPS {
            let t = self.interpolated(k as f64 / STEPS as f64).transform();
            sampled = sampled.union(&transform_bounds(&t, b));
        }
        let pad = (speed / (2.0 * STEPS as f64)) as f32;
        let sampled = Bounds3 { min: sampled.min - Vec3::splat(pad), max: sampled.max + Vec3::splat(pad) };
        let (t0, t1) = (self.d0.t.min(self.d1.t), self.d0.t.max(self.d1.t));
        let swept = Bounds3 { min: (t0 - DVec3::splat(reach)).as_vec3(), max: (t1 + DVec3::splat(reach)).as_vec3() };
        let clipped = Bounds3 { min: sampled.min.max(swept.min), max: sampled.max.min(swept.max) };
        grow(&clipped)
    }
}

/// The box of `b`'s eight corners under `t`, grown by the rounding of the transform.
pub fn transform_bounds(t: &Transform, b: &Bounds3) -> Bounds3 {
    if b.is_empty() {
        return Bounds3::EMPTY;
    }
    let mut out = Bounds3::EMPTY;
    for c in 0..8 {
        let corner = Vec3::new(
            if c & 1 == 0 { b.min.x } else { b.max.x },
            if c & 2 == 0 { b.min.y } else { b.max.y },
            if c & 4 == 0 { b.min.z } else { b.max.z },
        );
        out = out.union_point(t.point(corner.as_dvec3()).as_vec3());
    }
    grow(&out)
}

/// `b` grown by a few ulps of its magnitude (f32 rounding of the transformed coordinates).
fn grow(b: &Bounds3) -> Bounds3 {
    let e = b.max.abs().max(b.min.abs()) * gamma(4);
    Bounds3 { min: b.min - e, max: b.max + e }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mat_close(a: DMat4, b: DMat4, tol: f64) -> bool {
        (0..4).all(|c| (a.col(c) - b.col(c)).abs().max_element() < tol)
    }

    #[test]
    fn a_product_of_translation_rotation_and_scale_decomposes_back_into_them() {
        let t = DVec3::new(1.5, -2.0, 7.0);
        let axis = DVec3::new(1.0, 2.0, -0.5).normalize();
        let r = DQuat::from_axis_angle(axis, 1.1);
        let s = DVec3::new(2.0, 0.5, 3.0);
        let m = Transform::translate(t)
            * Transform::rotate(1.1f64.to_degrees(), axis).unwrap()
            * Transform::scale(s).unwrap();
        let d = Decomposed::new(&m.matrix()).unwrap();
        assert!((d.t - t).length() < 1e-12);
        // q and −q are the same rotation.
        assert!((d.r.dot(r).abs() - 1.0).abs() < 1e-12, "{:?} vs {r:?}", d.r);
        assert!((0..3).all(|c| (d.s.col(c) - DMat3::from_diagonal(s).col(c)).abs().max_element() < 1e-12));
        assert!(mat_close(d.matrix(), m.matrix(), 1e-12));
        let back = d.transform();
        assert!(mat_close(back.inverse_matrix() * m.matrix(), DMat4::IDENTITY, 1e-12));
    }

    #[test]
    fn a_reflection_keeps_a_proper_rotation() {
        let m = Transform::rotate(30.0, DVec3::Z).unwrap() * Transform::scale(DVec3::new(-1.0, 2.0, 1.0)).unwrap();
        let d = Decomposed::new(&m.matrix()).unwrap();
        assert!(mat_close(d.matrix(), m.matrix(), 1e-12));
        assert!((DMat3::from_quat(d.r).determinant() - 1.0).abs() < 1e-12);
        assert!(Decomposed::new(&Transform::perspective(60.0, 0.1, 10.0).unwrap().matrix()).is_none());
    }

    #[test]
    fn a_quarter_turn_is_an_eighth_turn_halfway() {
        // An instance turning 90° about z between t = 0 and t = 1, moving 2 along x and growing from 1 to 3.
        let start = Transform::IDENTITY;
        let end = Transform::translate(DVec3::new(2.0, 0.0, 0.0))
            * Transform::rotate(90.0, DVec3::Z).unwrap()
            * Transform::scale(DVec3::splat(3.0)).unwrap();
        let a = AnimatedTransform::new(start, 0.0, end, 1.0).unwrap();
        let half = a.at(0.5);
        let want = Transform::translate(DVec3::new(1.0, 0.0, 0.0))
            * Transform::rotate(45.0, DVec3::Z).unwrap()
            * Transform::scale(DVec3::splat(2.0)).unwrap();
        assert!(mat_close(half.matrix(), want.matrix(), 1e-12), "{:?}", half.matrix());
        assert!(mat_close(half.inverse_matrix() * half.matrix(), DMat4::IDENTITY, 1e-12));
        // At a quarter of the way: 22.5°, the rotation's angle grows linearly in time (constant angular speed).
        let q = a.at(0.25).vector(DVec3::X).normalize();
        assert!((q.y.atan2(q.x).to_degrees() - 22.5).abs() < 1e-10);
        // Clamped outside the interval, exact at the ends.
        assert_eq!(a.at(-1.0), start);
        assert_eq!(a.at(0.0), start);
        assert_eq!(a.at(1.0), end);
        assert_eq!(a.at(5.0), end);
        // Other times scale the fraction.
        let b = AnimatedTransform::new(start, 2.0, end, 4.0).unwrap();
        assert!(mat_close(b.at(3.0).matrix(), want.matrix(), 1e-12));
    }

    #[test]
    fn slerp_takes_the_short_way_at_constant_speed() {
        let a = DQuat::from_axis_angle(DVec3::Y, 0.2);
        let b = DQuat::from_axis_angle(DVec3::Y, 2.6);
        for k in 0..=10 {
            let t = k as f64 / 10.0;
            let q = slerp(a, b, t);
            let want = DQuat::from_axis_angle(DVec3::Y, 0.2 + 2.4 * t);
            assert!((q.dot(want) - 1.0).abs() < 1e-12, "t = {t}");
        }
        // Nearly equal rotations use the normalised blend, still on the arc to 1e-9.
        let c = DQuat::from_axis_angle(DVec3::Y, 0.2001);
        let q = slerp(a, c, 0.5);
        assert!((q.dot(DQuat::from_axis_angle(DVec3::Y, 0.20005)) - 1.0).abs() < 1e-9);
    }

    #[test]
    fn bad_times_and_projective_motion_are_rejected() {
        let t = Transform::translate(DVec3::X);
        assert!(AnimatedTransform::new(Transform::IDENTITY, 1.0, t, 0.0).is_none());
        assert!(AnimatedTransform::new(Transform::IDENTITY, f64::NAN, t, 1.0).is_none());
        let p = Transform::perspective(60.0, 0.1, 10.0).unwrap();
        assert!(AnimatedTransform::new(Transform::IDENTITY, 0.0, p, 1.0).is_none());
        // Equal ends never need a decomposition.
        let still = AnimatedTransform::new(p, 0.0, p, 1.0).unwrap();
        assert!(!still.is_animated());
        assert_eq!(still.at(0.5), p);
    }

    #[test]
    fn motion_bounds_hold_every_point_at_every_time() {
        let b = Bounds3 { min: Vec3::new(-1.0, -0.5, -0.2), max: Vec3::new(2.0, 0.5, 0.3) };
        let cases = [
            (Transform::IDENTITY, Transform::translate(DVec3::new(5.0, 1.0, 0.0))),
            (
                Transform::translate(DVec3::new(1.0, 2.0, 3.0)),
                Transform::translate(DVec3::new(-1.0, 0.0, 3.0))
                    * Transform::rotate(170.0, DVec3::new(1.0, 1.0, 0.0)).unwrap()
                    * Transform::scale(DVec3::new(1.0, 2.0, 0.5)).unwrap(),
            ),
            (Transform::IDENTITY, Transform::rotate(90.0, DVec3::Z).unwrap()),
        ];
        for (s, e) in cases {
            let a = AnimatedTransform::new(s, 0.0, e, 1.0).unwrap();
            let mb = a.motion_bounds(&b);
            let mut hull = Bounds3::EMPTY;
            for k in 0..=400 {
                let t = a.at(k as f64 / 400.0);
                for c in 0..8 {
                    let p = Vec3::new(
                        if c & 1 == 0 { b.min.x } else { b.max.x },
                        if c & 2 == 0 { b.min.y } else { b.max.y },
                        if c & 4 == 0 { b.min.z } else { b.max.z },
                    );
                    let q = t.point(p.as_dvec3()).as_vec3();
                    hull = hull.union_point(q);
                    assert!(mb.contains(q), "{q:?} at {k} outside {mb:?}");
                }
            }
            // Conservative but not wasteful: no side further out than 5% of the swept hull's largest extent.
            let excess = (hull.min - mb.min).max(mb.max - hull.max) / hull.diagonal().max_element();
            assert!(excess.max_element() < 0.05, "{excess:?}: {mb:?} vs {hull:?}");
        }
    }
}

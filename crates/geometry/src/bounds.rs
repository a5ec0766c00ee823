//! Axis-aligned bounding boxes.

use glam::Vec3;

/// An axis-aligned box `[min, max]`; empty when any `min > max` (the default is empty).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds3 {
    /// Lower corner.
    pub min: Vec3,
    /// Upper corner.
    pub max: Vec3,
}

impl Default for Bounds3 {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl Bounds3 {
    /// The empty box (union identity).
    pub const EMPTY: Bounds3 = Bounds3 { min: Vec3::splat(f32::INFINITY), max: Vec3::splat(f32::NEG_INFINITY) };

    /// The box of one point.
    pub fn from_point(p: Vec3) -> Self {
        Self { min: p, max: p }
    }

    /// The smallest box holding all `points`.
    pub fn from_points(points: impl IntoIterator<Item = Vec3>) -> Self {
        points.into_iter().fold(Self::EMPTY, |b, p| b.union_point(p))
    }

    /// True if the box holds no point.
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    /// This box grown to hold `p`.
    pub fn union_point(&self, p: Vec3) -> Self {
        Self { min: self.min.min(p), max: self.max.max(p) }
    }

    /// The smallest box holding both.
    pub fn union(&self, o: &Bounds3) -> Self {
        Self { min: self.min.min(o.min), max: self.max.max(o.max) }
    }

    /// `max − min`.
    pub fn diagonal(&self) -> Vec3 {
        self.max - self.min
    }

    /// The centre.
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// True if `p` is inside or on the boundary.
    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// The centre and radius of a sphere holding the box.
    pub fn bounding_sphere(&self) -> (Vec3, f32) {
        if self.is_empty() {
            return (Vec3::ZERO, 0.0);
        }
        let c = self.center();
        (c, (self.max - c).length())
    }
}

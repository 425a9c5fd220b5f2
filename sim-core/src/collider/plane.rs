//! Half-space collider: the solid is everything behind a plane through `point` with outward
//! normal `normal`.

use glam::Vec3A;

/// A plane collider (solid on the side opposite to `normal`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    /// A point on the plane (m).
    pub point_m: Vec3A,
    /// Unit outward normal (pointing into the free space).
    pub normal: Vec3A,
}

impl Plane {
    /// A plane through `point_m` with normal `normal` (normalised here; `None` if zero or NaN).
    pub fn new(point_m: Vec3A, normal: Vec3A) -> Option<Self> {
        let n = normal.try_normalize()?;
        point_m.is_finite().then_some(Self { point_m, normal: n })
    }

    /// Signed distance of `x` from the plane (m), positive on the free side.
    #[inline]
    pub fn signed_distance(&self, x: Vec3A) -> f32 {
        (x - self.point_m).dot(self.normal)
    }

    /// The outward normal if `x` is on or behind the plane.
    #[inline]
    pub fn contact_normal(&self, x: Vec3A) -> Option<Vec3A> {
        (self.signed_distance(x) <= 0.0).then_some(self.normal)
    }
}

//! Axis-aligned box colliders: a solid box (nodes inside are boundary nodes, normal of the
//! nearest face) or a domain bound (nodes outside are boundary nodes, normal pointing back in).

use glam::Vec3A;

/// An axis-aligned box `[min_m, max_m]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoxShape {
    /// Lower corner (m).
    pub min_m: Vec3A,
    /// Upper corner (m).
    pub max_m: Vec3A,
}

impl BoxShape {
    /// A box from its corners; `None` unless finite with min < max on every axis.
    pub fn new(min_m: Vec3A, max_m: Vec3A) -> Option<Self> {
        (min_m.is_finite() && max_m.is_finite() && min_m.cmplt(max_m).all())
            .then_some(Self { min_m, max_m })
    }

    /// Outward normal of the nearest face if `x` is inside the solid box.
    #[inline]
    pub fn contact_normal(&self, x: Vec3A) -> Option<Vec3A> {
        if !(x.cmpge(self.min_m).all() && x.cmple(self.max_m).all()) {
            return None;
        }
        let below = x - self.min_m;
        let above = self.max_m - x;
        let mut best = f32::INFINITY;
        let mut n = Vec3A::Z;
        for axis in 0..3 {
            if below[axis] < best {
                best = below[axis];
                n = -Vec3A::AXES[axis];
            }
            if above[axis] < best {
                best = above[axis];
                n = Vec3A::AXES[axis];
            }
        }
        Some(n)
    }

    /// Signed distance (m, negative inside) of `x` from the box surface and the outward normal
    /// of the nearest face, edge or corner.
    pub fn signed_distance(&self, x: Vec3A) -> (f32, Vec3A) {
        let c = (self.min_m + self.max_m) * 0.5;
        let d = x - c;
        let q = d.abs() - (self.max_m - self.min_m) * 0.5;
        let outside = q.max(Vec3A::ZERO);
        let len = outside.length();
        if len > 0.0 {
            return (len, outside * d.signum() / len);
        }
        let axis = if q.x >= q.y && q.x >= q.z {
            0
        } else if q.y >= q.z {
            1
        } else {
            2
        };
        let mut n = Vec3A::ZERO;
        n[axis] = if d[axis] >= 0.0 { 1.0 } else { -1.0 };
        (q[axis], n)
    }

    /// Inward normal (pointing back into the box) if `x` is outside the box: the domain bound.
    #[inline]
    pub fn outside_normal(&self, x: Vec3A) -> Option<Vec3A> {
        let mut n = Vec3A::ZERO;
        for axis in 0..3 {
            if x[axis] < self.min_m[axis] {
                n[axis] = 1.0;
            } else if x[axis] > self.max_m[axis] {
                n[axis] = -1.0;
            }
        }
        n.try_normalize()
    }
}

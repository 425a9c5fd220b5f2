//! Automatic framing: an axis-aligned box around the Gaussians and a camera that sees all of it.
//!
//! The camera looks at the box centre from a given direction, at the distance where the box's
//! bounding sphere (radius r) just fits the narrower half field of view θ: d = r / sin θ
//! (the tangent-cone condition of a sphere seen by a pinhole camera).

use glam::Vec3;

use crate::camera::{Camera, CameraError};

/// Axis-aligned bounds, world metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    /// Minimum corner, m.
    pub min: Vec3,
    /// Maximum corner, m.
    pub max: Vec3,
}

impl Bounds {
    /// Tight bounds of the finite points in `positions` (`[N][3]`, m); `None` when there are none.
    pub fn of_points(positions: &[[f32; 3]]) -> Option<Self> {
        let mut it = positions
            .iter()
            .map(|p| Vec3::from(*p))
            .filter(|p| p.is_finite());
        let first = it.next()?;
        let (min, max) = it.fold((first, first), |(lo, hi), p| (lo.min(p), hi.max(p)));
        Some(Self { min, max })
    }

    /// Bounds that ignore the `trim` fraction (0..0.5) of points at each end of each axis, so a
    /// few far-away floaters of a captured scene do not shrink the object to a dot. `None` when
    /// there are no finite points.
    pub fn of_points_trimmed(positions: &[[f32; 3]], trim: f32) -> Option<Self> {
        let finite: Vec<Vec3> = positions
            .iter()
            .map(|p| Vec3::from(*p))
            .filter(|p| p.is_finite())
            .collect();
        if finite.is_empty() {
            return None;
        }
        let n = finite.len();
        let trim = if trim.is_finite() {
            trim.clamp(0.0, 0.49)
        } else {
            0.0
        };
        let lo_i = ((n as f32 * trim) as usize).min(n - 1);
        let hi_i = (n - 1).saturating_sub(lo_i).max(lo_i);
        let mut min = Vec3::ZERO;
        let mut max = Vec3::ZERO;
        let mut axis: Vec<f32> = Vec::with_capacity(n);
        for a in 0..3 {
            axis.clear();
            axis.extend(finite.iter().map(|p| p[a]));
            let (_, lo, _) = axis.select_nth_unstable_by(lo_i, f32::total_cmp);
            min[a] = *lo;
            let (_, hi, _) = axis.select_nth_unstable_by(hi_i, f32::total_cmp);
            max[a] = *hi;
        }
        Some(Self { min, max })
    }

    /// Box centre, m.
    pub fn centre(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// Radius of the bounding sphere (half the diagonal), m; at least 1 mm.
    pub fn radius(&self) -> f32 {
        ((self.max - self.min).length() * 0.5).max(1e-3)
    }

    /// Distance from the centre at which a camera with `fov_y_deg` and aspect `width_px /
    /// height_px` sees the whole bounding sphere, times `margin` (1.0 = touching the edges).
    pub fn framing_distance(
        &self,
        fov_y_deg: f32,
        width_px: u32,
        height_px: u32,
        margin: f32,
    ) -> f32 {
        let tan_y = (fov_y_deg.to_radians() * 0.5).tan();
        let tan_x = tan_y * width_px.max(1) as f32 / height_px.max(1) as f32;
        let half = tan_y.min(tan_x).atan();
        self.radius() / half.sin() * margin
    }

    /// A camera looking at the centre from direction `view_dir` (from the centre towards the
    /// camera; need not be unit) at [`Bounds::framing_distance`] with a 5 % margin.
    ///
    /// # Errors
    /// [`CameraError`] for a zero-size image, a bad field of view, or `view_dir` zero or
    /// parallel to `up`.
    pub fn frame(
        &self,
        view_dir: Vec3,
        up: Vec3,
        fov_y_deg: f32,
        width_px: u32,
        height_px: u32,
    ) -> Result<Camera, CameraError> {
        let centre = self.centre();
        let distance = self.framing_distance(fov_y_deg, width_px, height_px, 1.05);
        let position = centre + view_dir.normalize_or_zero() * distance;
        Camera::new(position, centre, up, fov_y_deg, width_px, height_px)
    }

    /// A near-plane distance for `camera` that does not cut into the bounding sphere: half the
    /// gap between the camera and the sphere, at most 0.2 m (the 3DGS default) and at least 1 mm.
    pub fn suggested_near_m(&self, camera: &Camera) -> f32 {
        let gap = (camera.position - self.centre()).length() - self.radius();
        (0.5 * gap).clamp(1e-3, 0.2)
    }
}

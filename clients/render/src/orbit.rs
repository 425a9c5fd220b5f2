//! Orbit paths: `N` cameras evenly spaced in azimuth on a circle around a centre, all looking at
//! it, at a fixed elevation above the plane normal to `up`.

use glam::{Mat3, Vec3};

use crate::camera::{Camera, CameraError};
use crate::framing::Bounds;

/// A circular camera path around a centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrbitPath {
    /// Point every camera looks at, world metres.
    pub centre: Vec3,
    /// Distance from the centre to each camera, m.
    pub distance_m: f32,
    /// Elevation of the cameras above the plane normal to `up`, degrees (default 20).
    pub elevation_deg: f32,
    /// Azimuth of the first camera, degrees, measured about `up` from a reference direction
    /// perpendicular to `up` (+x, or +y when `up` is along x).
    pub start_azimuth_deg: f32,
    /// Up axis of the orbit and of each camera; default +z.
    pub up: Vec3,
    /// Vertical field of view, degrees.
    pub fov_y_deg: f32,
    /// Image width, pixels.
    pub width_px: u32,
    /// Image height, pixels.
    pub height_px: u32,
}

impl OrbitPath {
    /// An orbit around `bounds` at the distance where the whole box stays in view
    /// ([`Bounds::framing_distance`] with a 5 % margin), 20° elevation, first camera at azimuth 0.
    pub fn around(
        bounds: &Bounds,
        up: Vec3,
        fov_y_deg: f32,
        width_px: u32,
        height_px: u32,
    ) -> Self {
        Self {
            centre: bounds.centre(),
            distance_m: bounds.framing_distance(fov_y_deg, width_px, height_px, 1.05),
            elevation_deg: 20.0,
            start_azimuth_deg: 0.0,
            up,
            fov_y_deg,
            width_px,
            height_px,
        }
    }

    /// The `n` cameras of one full turn, counter-clockwise about `up`, the first at
    /// `start_azimuth_deg`.
    ///
    /// # Errors
    /// [`CameraError`] for a zero-size image, a bad field of view, a zero `up`, a non-positive
    /// distance, or an elevation of ±90° (the view direction is parallel to `up`).
    pub fn cameras(&self, n: usize) -> Result<Vec<Camera>, CameraError> {
        let up = self.up.normalize_or_zero();
        let reference = if up.x.abs() < 0.9 { Vec3::X } else { Vec3::Y };
        let e1 = (reference - up * up.dot(reference)).normalize_or_zero();
        let elevation = self.elevation_deg.to_radians();
        (0..n)
            .map(|i| {
                let azimuth = self.start_azimuth_deg.to_radians()
                    + std::f32::consts::TAU * i as f32 / n as f32;
                let horizontal = Mat3::from_axis_angle(up, azimuth) * e1;
                let dir = horizontal * elevation.cos() + up * elevation.sin();
                let position = self.centre + dir * self.distance_m;
                Camera::new(
                    position,
                    self.centre,
                    self.up,
                    self.fov_y_deg,
                    self.width_px,
                    self.height_px,
                )
            })
            .collect()
    }
}

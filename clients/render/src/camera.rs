//! Pinhole camera: world -> view transform and intrinsics in the convention of the 3DGS reference
//! rasterizer (Kerbl et al. 2023; COLMAP/OpenCV view frame: x right, y down, z forward).
//!
//! A view-space point t projects to pixel `u = fx · tx/tz + cx`, `v = fy · ty/tz + cy` with
//! `fy = H / (2 tan(fov_y/2))`, square pixels (`fx = fy`) and `cx = (W - 1)/2`, `cy = (H - 1)/2`:
//! the reference's `ndc2Pix(v, S) = ((v + 1) S - 1) / 2`, so pixel `(i, j)` has its centre at
//! integer coordinates `(i, j)`.

use glam::{Mat3, Vec3};

/// A camera that cannot be used: degenerate direction, bad field of view or zero-size image.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CameraError {
    /// Width or height is zero.
    #[error("image size {width_px}x{height_px} px is empty")]
    ZeroSizeImage {
        /// Width in pixels.
        width_px: u32,
        /// Height in pixels.
        height_px: u32,
    },
    /// Field of view outside (0, 180) degrees or not finite.
    #[error("vertical field of view {fov_y_deg} deg is outside (0, 180)")]
    FieldOfView {
        /// The value given, degrees.
        fov_y_deg: f32,
    },
    /// Position, look-at point or up vector not finite, look-at equal to the position, or up
    /// parallel to the viewing direction.
    #[error(
        "camera at {position:?} looking at {look_at:?} with up {up:?} has no defined orientation"
    )]
    Degenerate {
        /// Camera position, m.
        position: [f32; 3],
        /// Look-at point, m.
        look_at: [f32; 3],
        /// Up vector.
        up: [f32; 3],
    },
}

/// Pinhole camera (position, look-at point, up vector, vertical field of view, image size).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Centre of projection, world metres.
    pub position: Vec3,
    /// Point the optical axis passes through, world metres.
    pub look_at: Vec3,
    /// Up direction (need not be unit or orthogonal to the viewing direction); default +z.
    pub up: Vec3,
    /// Vertical field of view, degrees, in (0, 180).
    pub fov_y_deg: f32,
    /// Image width, pixels (> 0).
    pub width_px: u32,
    /// Image height, pixels (> 0).
    pub height_px: u32,
}

/// Everything the rasterizer needs from a camera, precomputed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewParams {
    /// World -> view rotation W (rows: right, down, forward).
    pub rotation: Mat3,
    /// Camera position, world metres.
    pub position: Vec3,
    /// Focal lengths `fx, fy`, pixels.
    pub focal_px: [f32; 2],
    /// Principal point `cx, cy`, pixels (pixel centres at integers).
    pub principal_px: [f32; 2],
    /// `tan(fov_x / 2)`, `tan(fov_y / 2)`.
    pub tan_half_fov: [f32; 2],
    /// Image width and height, pixels.
    pub size_px: [u32; 2],
}

impl Camera {
    /// Builds and checks a camera.
    ///
    /// # Errors
    /// [`CameraError`] for a zero-size image, a field of view outside (0, 180) degrees, or a
    /// degenerate orientation.
    pub fn new(
        position: Vec3,
        look_at: Vec3,
        up: Vec3,
        fov_y_deg: f32,
        width_px: u32,
        height_px: u32,
    ) -> Result<Self, CameraError> {
        let camera = Self {
            position,
            look_at,
            up,
            fov_y_deg,
            width_px,
            height_px,
        };
        camera.view_params()?;
        Ok(camera)
    }

    /// Unit viewing direction (from the position towards the look-at point).
    pub fn forward(&self) -> Vec3 {
        (self.look_at - self.position).normalize_or_zero()
    }

    /// The same camera with every point and direction rotated by `rotation` about `pivot`.
    pub fn rotated_about(&self, pivot: Vec3, rotation: Mat3) -> Self {
        Self {
            position: pivot + rotation * (self.position - pivot),
            look_at: pivot + rotation * (self.look_at - pivot),
            up: rotation * self.up,
            ..*self
        }
    }

    /// Precomputes the view rotation and intrinsics.
    ///
    /// # Errors
    /// See [`Camera::new`].
    pub fn view_params(&self) -> Result<ViewParams, CameraError> {
        if self.width_px == 0 || self.height_px == 0 {
            return Err(CameraError::ZeroSizeImage {
                width_px: self.width_px,
                height_px: self.height_px,
            });
        }
        if !(self.fov_y_deg > 0.0 && self.fov_y_deg < 180.0) {
            return Err(CameraError::FieldOfView {
                fov_y_deg: self.fov_y_deg,
            });
        }
        let degenerate = || CameraError::Degenerate {
            position: self.position.to_array(),
            look_at: self.look_at.to_array(),
            up: self.up.to_array(),
        };
        if !(self.position.is_finite() && self.look_at.is_finite() && self.up.is_finite()) {
            return Err(degenerate());
        }
        let forward = (self.look_at - self.position).normalize_or_zero();
        let right = forward.cross(self.up).normalize_or_zero();
        if forward == Vec3::ZERO || right == Vec3::ZERO {
            return Err(degenerate());
        }
        let down = forward.cross(right);
        let rotation = Mat3::from_cols(right, down, forward).transpose();
        let (w, h) = (self.width_px as f32, self.height_px as f32);
        let tan_y = (self.fov_y_deg.to_radians() * 0.5).tan();
        let fy = h / (2.0 * tan_y);
        let fx = fy;
        let tan_x = w / (2.0 * fx);
        Ok(ViewParams {
            rotation,
            position: self.position,
            focal_px: [fx, fy],
            principal_px: [(w - 1.0) * 0.5, (h - 1.0) * 0.5],
            tan_half_fov: [tan_x, tan_y],
            size_px: [self.width_px, self.height_px],
        })
    }
}

impl ViewParams {
    /// World point -> view space (x right, y down, z forward), metres.
    pub fn to_view(&self, p: Vec3) -> Vec3 {
        self.rotation * (p - self.position)
    }

    /// View-space point -> pixel coordinates (pixel centres at integers). `t.z` must be > 0.
    pub fn to_pixel(&self, t: Vec3) -> [f32; 2] {
        [
            self.focal_px[0] * t.x / t.z + self.principal_px[0],
            self.focal_px[1] * t.y / t.z + self.principal_px[1],
        ]
    }
}

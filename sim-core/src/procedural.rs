//! Procedural shapes (sphere, box, cylinder) filled with particles on a jittered cubic lattice,
//! each particle an isotropic Gaussian of one colour. Used by validation scenes and the
//! built-in default scene (the way PhysGaussian and MPM papers seed solid test bodies).
//!
//! Lattice: cell centres of a cubic grid of spacing `h` covering the shape's bounding box, each
//! moved by a uniform offset in `[-j h, j h]³` (`j` = [`JITTER`]) from a ChaCha8 stream seeded by
//! `seed`, kept when inside the shape. Gaussian: log scale `ln(h / 2)` on every axis, identity
//! rotation, opacity logit [`OPACITY_LOGIT`], `f_dc = (c - 0.5) / C0` (degree-0 SH).

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::formats::splat::SH_C0;
use crate::gaussians::GaussianCloud;

/// Jitter amplitude as a fraction of the spacing (each axis, uniform in ±JITTER·h).
pub const JITTER: f32 = 0.25;
/// Opacity logit of procedural Gaussians (sigmoid = 0.99).
pub const OPACITY_LOGIT: f32 = 4.595_12;
/// Most particles one shape may produce; more is an error, not an allocation.
pub const MAX_PARTICLES: usize = 4_000_000;

/// A solid shape in world metres.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Shape {
    /// A ball.
    Sphere {
        /// Centre, m.
        center_m: [f32; 3],
        /// Radius, m.
        radius_m: f32,
    },
    /// An axis-aligned box.
    Box {
        /// Lower corner, m.
        min_m: [f32; 3],
        /// Upper corner, m.
        max_m: [f32; 3],
    },
    /// A solid circular cylinder.
    Cylinder {
        /// Centre of the base disc, m.
        base_m: [f32; 3],
        /// Axis direction from the base (normalised here; need not be unit).
        axis: [f32; 3],
        /// Radius, m.
        radius_m: f32,
        /// Height along the axis, m.
        height_m: f32,
    },
}

/// Why a shape cannot be filled.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ProceduralError {
    /// A size, spacing or direction is zero, negative or not finite.
    #[error("{what} must be positive and finite, got {value}")]
    BadParameter {
        /// The parameter (`spacing_m`, `radius_m`, `height_m`, `axis`, `box`).
        what: &'static str,
        /// Its value (for vectors, the length or the smallest extent).
        value: f32,
    },
    /// The lattice would exceed [`MAX_PARTICLES`].
    #[error(
        "shape at spacing {spacing_m} m needs about {estimate} particles (limit {MAX_PARTICLES})"
    )]
    TooManyParticles {
        /// The spacing asked for, m.
        spacing_m: f32,
        /// Lattice cells in the bounding box.
        estimate: u64,
    },
}

fn positive(what: &'static str, value: f32) -> Result<(), ProceduralError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(ProceduralError::BadParameter { what, value })
    }
}

impl Shape {
    /// Checks sizes are positive and finite.
    ///
    /// # Errors
    /// [`ProceduralError::BadParameter`].
    pub fn validate(&self) -> Result<(), ProceduralError> {
        match *self {
            Shape::Sphere { center_m, radius_m } => {
                positive("radius_m", radius_m)?;
                if !Vec3::from(center_m).is_finite() {
                    return Err(ProceduralError::BadParameter {
                        what: "center_m",
                        value: f32::NAN,
                    });
                }
            }
            Shape::Box { min_m, max_m } => {
                let d = Vec3::from(max_m) - Vec3::from(min_m);
                positive("box", d.min_element())?;
            }
            Shape::Cylinder {
                base_m,
                axis,
                radius_m,
                height_m,
            } => {
                positive("radius_m", radius_m)?;
                positive("height_m", height_m)?;
                positive("axis", Vec3::from(axis).length())?;
                if !Vec3::from(base_m).is_finite() {
                    return Err(ProceduralError::BadParameter {
                        what: "base_m",
                        value: f32::NAN,
                    });
                }
            }
        }
        Ok(())
    }

    /// Its thickness, m: the smallest extent across it (a box's shortest side, a sphere's
    /// diameter, a cylinder's diameter or height, whichever is less).
    pub fn thickness_m(&self) -> f32 {
        match *self {
            Shape::Sphere { radius_m, .. } => 2.0 * radius_m,
            Shape::Box { min_m, max_m } => (Vec3::from(max_m) - Vec3::from(min_m)).min_element(),
            Shape::Cylinder {
                radius_m, height_m, ..
            } => (2.0 * radius_m).min(height_m),
        }
    }

    /// The centre of its bounding box, m: what `rotation_deg` turns it about.
    pub fn center(&self) -> Vec3 {
        let (lo, hi) = self.aabb();
        (lo + hi) * 0.5
    }

    /// Axis-aligned bounding box `(min, max)`, m.
    pub fn aabb(&self) -> (Vec3, Vec3) {
        match *self {
            Shape::Sphere { center_m, radius_m } => {
                let c = Vec3::from(center_m);
                (c - radius_m, c + radius_m)
            }
            Shape::Box { min_m, max_m } => (Vec3::from(min_m), Vec3::from(max_m)),
            Shape::Cylinder {
                base_m,
                axis,
                radius_m,
                height_m,
            } => {
                let a = Vec3::from(axis).normalize_or_zero();
                let b = Vec3::from(base_m);
                let t = b + a * height_m;
                // Disc extent along each world axis: r * sqrt(1 - a_k²).
                let e = (Vec3::ONE - a * a).max(Vec3::ZERO).powf(0.5) * radius_m;
                (b.min(t) - e, b.max(t) + e)
            }
        }
    }

    /// Whether `p` (m) is inside or on the shape.
    pub fn contains(&self, p: Vec3) -> bool {
        match *self {
            Shape::Sphere { center_m, radius_m } => {
                p.distance_squared(Vec3::from(center_m)) <= radius_m * radius_m
            }
            Shape::Box { min_m, max_m } => {
                p.cmpge(Vec3::from(min_m)).all() && p.cmple(Vec3::from(max_m)).all()
            }
            Shape::Cylinder {
                base_m,
                axis,
                radius_m,
                height_m,
            } => {
                let a = Vec3::from(axis).normalize_or_zero();
                let d = p - Vec3::from(base_m);
                let h = d.dot(a);
                (0.0..=height_m).contains(&h) && (d - a * h).length_squared() <= radius_m * radius_m
            }
        }
    }

    /// Volume, m³.
    pub fn volume_m3(&self) -> f32 {
        match *self {
            Shape::Sphere { radius_m, .. } => 4.0 / 3.0 * std::f32::consts::PI * radius_m.powi(3),
            Shape::Box { min_m, max_m } => {
                (Vec3::from(max_m) - Vec3::from(min_m)).element_product()
            }
            Shape::Cylinder {
                radius_m, height_m, ..
            } => std::f32::consts::PI * radius_m * radius_m * height_m,
        }
    }
}

/// Particle positions filling `shape` on a jittered lattice of spacing `spacing_m`, `[N][3]` m.
/// Deterministic for a given `seed`; roughly `volume / spacing³` points.
///
/// # Errors
/// [`ProceduralError`] for bad sizes or more than [`MAX_PARTICLES`] lattice cells.
pub fn fill_points(
    shape: &Shape,
    spacing_m: f32,
    seed: u64,
) -> Result<Vec<[f32; 3]>, ProceduralError> {
    positive("spacing_m", spacing_m)?;
    shape.validate()?;
    let (lo, hi) = shape.aabb();
    let cells = ((hi - lo) / spacing_m).ceil().max(Vec3::ONE);
    let estimate = (cells.x as f64 * cells.y as f64 * cells.z as f64) as u64;
    if estimate > MAX_PARTICLES as u64 {
        return Err(ProceduralError::TooManyParticles {
            spacing_m,
            estimate,
        });
    }
    let [nx, ny, nz] = [cells.x as usize, cells.y as usize, cells.z as usize];
    // Centre the lattice in the box so symmetric shapes fill symmetrically.
    let start = (lo + hi) * 0.5 - (cells - Vec3::ONE) * 0.5 * spacing_m;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let j = JITTER * spacing_m;
    let mut out = Vec::new();
    for k in 0..nz {
        for jy in 0..ny {
            for i in 0..nx {
                let jitter = Vec3::new(
                    rng.random_range(-j..=j),
                    rng.random_range(-j..=j),
                    rng.random_range(-j..=j),
                );
                let p = start + Vec3::new(i as f32, jy as f32, k as f32) * spacing_m + jitter;
                if shape.contains(p) {
                    out.push(p.to_array());
                }
            }
        }
    }
    Ok(out)
}

/// Isotropic Gaussians of linear RGB `color` (each in [0, 1]) at `positions` (m), standard
/// deviation `sigma_m` on every axis.
pub fn isotropic_gaussians(
    positions: Vec<[f32; 3]>,
    sigma_m: f32,
    color: [f32; 3],
) -> GaussianCloud {
    let n = positions.len();
    let dc = color.map(|c| ((f64::from(c) - 0.5) / SH_C0) as f32);
    let ls = sigma_m.ln();
    GaussianCloud {
        positions,
        normals: None,
        sh_degree: 0,
        sh_dc: vec![dc; n],
        sh_rest: Vec::new(),
        sh_rest_len: 0,
        opacity_logit: vec![OPACITY_LOGIT; n],
        log_scales: vec![[ls; 3]; n],
        rotations_wxyz: vec![[1.0, 0.0, 0.0, 0.0]; n],
        extra: Vec::new(),
    }
}

/// `shape` filled at `spacing_m` (see [`fill_points`]) as Gaussians of `color` with standard
/// deviation `spacing_m / 2`.
///
/// # Errors
/// As [`fill_points`].
pub fn shape_gaussians(
    shape: &Shape,
    spacing_m: f32,
    color: [f32; 3],
    seed: u64,
) -> Result<GaussianCloud, ProceduralError> {
    let pts = fill_points(shape, spacing_m, seed)?;
    Ok(isotropic_gaussians(pts, 0.5 * spacing_m, color))
}

//! The captured background as a static collision surface: the Gaussians no object selects (the
//! table, the floor, the ground) become a [`LevelSet`] that objects rest on.
//!
//! Which Gaussians count: opacity at least `background_min_opacity`; not a floater (a cell of
//! size dx holding opaque Gaussians with no other such cell within [`FLOATER_REACH_CELLS`]);
//! not in a cell an object occupies at t = 0, dilated by one cell, so an object standing on or
//! sunk into the captured ground is not shot out of it. The solid is thickened by
//! [`THICKEN_CELLS`] along gravity: a capture holds only the skin of the ground.

use std::collections::HashSet;
use std::sync::Arc;

use glam::{IVec3, Mat3A, Vec3A};

use super::body::{Body, MAX_SURFACE_CELLS};
use crate::contact::geometry::Placed;
use crate::contact::{Collision, Geometry, LevelSet};
use crate::gaussians::GaussianCloud;
use crate::kinematics::{GaussianState, pack_symmetric};

/// Coulomb friction coefficient μ of the captured background.
pub const BACKGROUND_FRICTION: f32 = 0.5;

/// The captured background: the Gaussians no object claimed, drawn as captured, and the static
/// surface they make.
#[derive(Debug, Clone)]
pub(crate) struct Background {
    /// `[G]` the Gaussians (static, published).
    pub(crate) cloud: Arc<GaussianCloud>,
    /// `[G]` their published state, which never changes.
    pub(crate) state: Arc<Vec<GaussianState>>,
    /// The collision surface (`None`: it does not collide).
    pub(crate) collision: Option<Arc<Collision>>,
    /// What it became.
    pub(crate) report: BackgroundReport,
    /// Coulomb friction coefficient μ.
    pub(crate) friction: f32,
}

impl Background {
    /// The background of `cloud` around `bodies` (for the cells they occupy at t = 0); with
    /// `collide`, its surface on cells of `dx_m` (m) from the Gaussians of opacity at least
    /// `min_opacity`, thickened along `gravity_m_s2` ([`collision`]).
    pub(crate) fn new(
        cloud: &GaussianCloud,
        bodies: &[Body],
        collide: bool,
        dx_m: f32,
        min_opacity: f32,
        gravity_m_s2: Vec3A,
    ) -> Self {
        let (collision, report) = if collide {
            collision(cloud, bodies, dx_m, min_opacity, gravity_m_s2)
        } else {
            (None, BackgroundReport::default())
        };
        Self {
            cloud: Arc::new(cloud.clone()),
            state: Arc::new(published_state(cloud)),
            collision: collision.map(Arc::new),
            report,
            friction: BACKGROUND_FRICTION,
        }
    }

    /// Its surface where it lies, when it collides.
    pub(crate) fn placed(&self) -> Option<Placed<'_>> {
        let c = self.collision.as_ref()?;
        Some(c.placed(c.rest_com_m.as_dvec3(), glam::Quat::IDENTITY))
    }
}

/// A cell of opaque Gaussians with no other within this many cells is a floater.
pub const FLOATER_REACH_CELLS: i32 = 2;
/// Cells the background's solid is thickened by along gravity.
pub const THICKEN_CELLS: usize = 3;

/// What the background became.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct BackgroundReport {
    /// Background Gaussians.
    pub gaussians: usize,
    /// Of them, opaque enough.
    pub opaque: usize,
    /// Opaque ones dropped as floaters.
    pub floaters: usize,
    /// Opaque ones dropped because an object occupies their cell at t = 0.
    pub under_objects: usize,
    /// Gaussians in the collision surface.
    pub solid: usize,
}

fn cell(x: Vec3A, dx: f32) -> IVec3 {
    (x / dx).floor().as_ivec3()
}

/// The background's collision surface (cells of `dx_m`, thickened along `gravity_m_s2`) and the
/// counts behind it; `None` when no Gaussian qualifies.
pub fn collision(
    background: &GaussianCloud,
    bodies: &[Body],
    dx_m: f32,
    min_opacity: f32,
    gravity_m_s2: Vec3A,
) -> (Option<Collision>, BackgroundReport) {
    let mut report = BackgroundReport {
        gaussians: background.len(),
        ..Default::default()
    };
    let opaque: Vec<Vec3A> = (0..background.len())
        .filter(|&g| background.opacity(g) >= min_opacity)
        .map(|g| Vec3A::from(background.positions[g]))
        .filter(|x| x.is_finite())
        .collect();
    report.opaque = opaque.len();
    let cells: HashSet<IVec3> = opaque.iter().map(|x| cell(*x, dx_m)).collect();
    let r = FLOATER_REACH_CELLS;
    let isolated = |c: IVec3| {
        !(-r..=r).any(|z| {
            (-r..=r).any(|y| {
                (-r..=r).any(|x| {
                    let d = IVec3::new(x, y, z);
                    d != IVec3::ZERO && cells.contains(&(c + d))
                })
            })
        })
    };
    let mut occupied: HashSet<IVec3> = HashSet::new();
    for b in bodies {
        for x in b.particle_positions() {
            let c = cell(x, dx_m);
            for z in -1..=1 {
                for y in -1..=1 {
                    for xx in -1..=1 {
                        occupied.insert(c + IVec3::new(xx, y, z));
                    }
                }
            }
        }
    }
    let mut solid = Vec::with_capacity(opaque.len() * (1 + THICKEN_CELLS));
    for x in opaque {
        let c = cell(x, dx_m);
        if isolated(c) {
            report.floaters += 1;
        } else if occupied.contains(&c) {
            report.under_objects += 1;
        } else {
            solid.push(x);
        }
    }
    report.solid = solid.len();
    // A captured surface is a skin one or two cells thick; thicken it downwards (along gravity)
    // so material pressed onto it meets interior nodes whose normal points out of the top, not
    // a skin it can squeeze through.
    if let Some(down) = gravity_m_s2.try_normalize() {
        let skin = solid.len();
        for k in 1..=THICKEN_CELLS {
            for i in 0..skin {
                let x = solid[i] + down * (k as f32 * dx_m);
                solid.push(x);
            }
        }
    }
    let surface = LevelSet::from_points(&solid, dx_m, MAX_SURFACE_CELLS)
        .map(|ls| Collision::new(Geometry::Sampled(ls), dx_m, Vec3A::ZERO));
    (surface, report)
}

/// The published state of the background's Gaussians: where they were captured, unrotated.
fn published_state(background: &GaussianCloud) -> Vec<GaussianState> {
    (0..background.len())
        .map(|i| GaussianState {
            position_m: background.positions[i],
            covariance_m2: pack_symmetric(Mat3A::from(background.covariance(i))),
            rotation_wxyz: [1.0, 0.0, 0.0, 0.0],
        })
        .collect()
}

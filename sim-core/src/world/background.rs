//! The captured background as a static collision surface: the Gaussians no object selects (the
//! table, the floor, the ground) become a [`LevelSet`] that objects rest on.
//!
//! Which Gaussians count: opacity at least `background_min_opacity`; not a floater (a cell of
//! size dx holding opaque Gaussians with no other such cell within [`FLOATER_REACH_CELLS`]);
//! not in a cell an object occupies at t = 0, dilated by one cell, so an object standing on or
//! sunk into the captured ground is not shot out of it, unless the cell lies below the object
//! and joins the ground beyond it (`carve`). The solid is thickened by [`THICKEN_CELLS`]
//! along gravity: a capture holds only the skin of the ground.

use std::collections::{HashMap, HashSet};
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
    /// Opaque ones dropped because an object lies within a cell of theirs at t = 0 and they are
    /// not ground under it.
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
    let skin: Vec<Vec3A> = opaque
        .into_iter()
        .filter(|x| {
            let floater = isolated(cell(*x, dx_m));
            report.floaters += usize::from(floater);
            !floater
        })
        .collect();
    // A captured surface is a skin one or two cells thick; thicken it downwards (along gravity)
    // so material pressed onto it meets interior nodes whose normal points out of the top, not
    // a skin it can squeeze through. Each copy remembers the skin point it came from.
    let down = gravity_m_s2.try_normalize();
    let mut points: Vec<(Vec3A, usize)> = skin.iter().copied().zip(0..).collect();
    if let Some(down) = down {
        for k in 1..=THICKEN_CELLS {
            for (i, x) in skin.iter().enumerate() {
                points.push((*x + down * (k as f32 * dx_m), i));
            }
        }
    }
    let kept = carve(&points, skin.len(), bodies, dx_m, down.map(|d| -d));
    report.under_objects = (0..skin.len()).filter(|&i| !kept[i]).count();
    report.solid = skin.len() - report.under_objects;
    let solid: Vec<Vec3A> = points
        .iter()
        .zip(&kept)
        .filter_map(|((x, _), k)| k.then_some(*x))
        .collect();
    let surface = LevelSet::from_points(&solid, dx_m, MAX_SURFACE_CELLS)
        .map(|ls| Collision::new(Geometry::Sampled(ls), dx_m, Vec3A::ZERO));
    (surface, report)
}

/// Which of the background's solid `points` (`(position m, skin point it came from)`: the
/// first `skin` are the captured Gaussians, the rest their copies along gravity) stay solid
/// around `bodies` at t = 0 (cells of `dx_m`, `up` against gravity). A point whose cell is
/// within one cell of an object's particle goes, so that an object standing on or sunk into
/// the captured ground is not shot out of it, unless its cell lies wholly below the object's
/// lowest particle in that column of cells and joins, through such cells, the solid beyond the
/// objects (a captured Gaussian there, or a copy of one): the ground under an object stays, and
/// a sunk object rests in a dimple of the thickened ground, not in a hole through the skin,
/// while Gaussians a segmentation left around an object in the air go with it.
fn carve(
    points: &[(Vec3A, usize)],
    skin: usize,
    bodies: &[Body],
    dx_m: f32,
    up: Option<Vec3A>,
) -> Vec<bool> {
    let mut occupied: HashSet<IVec3> = HashSet::new();
    // Per column of cells across up: the lowest particle's height along up (m).
    let mut lowest: HashMap<IVec3, f32> = HashMap::new();
    let column = |x: Vec3A, up: Vec3A| cell(x - up * x.dot(up), dx_m);
    for b in bodies {
        for x in b.particle_positions() {
            let c = cell(x, dx_m);
            for d in neighbourhood() {
                occupied.insert(c + d);
            }
            if let Some(up) = up {
                let h = lowest.entry(column(x, up)).or_insert(f32::INFINITY);
                *h = h.min(x.dot(up));
            }
        }
    }
    // A cell's highest point along up lies below the lowest particle of its column and of the
    // columns beside it.
    let below = |c: IVec3| {
        up.is_some_and(|up| {
            let centre = (c.as_vec3a() + 0.5) * dx_m;
            let top = centre.dot(up) + 0.5 * dx_m * up.abs().element_sum();
            let floor = neighbourhood()
                .filter_map(|d| lowest.get(&(column(centre, up) + d)))
                .fold(f32::INFINITY, |a, &b| a.min(b));
            top <= floor
        })
    };
    // Seeds: free cells of captured Gaussians and of their copies; candidates: cells under the
    // objects, and cells a copy of a removed Gaussian reaches.
    let free_skin: Vec<bool> = points[..skin]
        .iter()
        .map(|(x, _)| !occupied.contains(&cell(*x, dx_m)))
        .collect();
    let mut seeds: Vec<IVec3> = Vec::new();
    let mut candidates: HashSet<IVec3> = HashSet::new();
    for (x, from) in points {
        let c = cell(*x, dx_m);
        if !occupied.contains(&c) && free_skin[*from] {
            seeds.push(c);
        } else if !occupied.contains(&c) || below(c) {
            candidates.insert(c);
        }
    }
    let mut joined: HashSet<IVec3> = seeds.iter().copied().collect();
    while let Some(c) = seeds.pop() {
        for d in neighbourhood() {
            let n = c + d;
            if candidates.remove(&n) {
                joined.insert(n);
                seeds.push(n);
            }
        }
    }
    points
        .iter()
        .map(|(x, _)| joined.contains(&cell(*x, dx_m)))
        .collect()
}

/// The 27 cell offsets of a cell's neighbourhood, itself included.
fn neighbourhood() -> impl Iterator<Item = IVec3> {
    (-1..=1).flat_map(|z| (-1..=1).flat_map(move |y| (-1..=1).map(move |x| IVec3::new(x, y, z))))
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

//! The node gaps ([`NodeGaps`]) a deformable object's grid reads against the solids it meets
//! as boundaries ([`super::boundary`]): which solids wait for material to reach them (gated),
//! and which thin ones the grid reads the material's side of (held).

use super::barrier::Wall;
use super::boundary::Obstacle;
use crate::collider::Surface;
use crate::mpm::Particles;
use crate::mpm::grid::SparseGrid;
use crate::mpm::reach::{BARRIER_REACH, BEHIND, NODE_REACH, NodeGaps};

/// The node gaps ([`NodeGaps`]) of `particles` on `grid` (cell `dx_m`) against those of
/// `obstacles` whose nodes take the rule only where material reaches them (immovable,
/// not sticky); `None` when there is none. With `barrier`, the particles met the obstacles that
/// take it through the particle barrier first ([`super::barrier`]), and those obstacles' nodes
/// wait until particle centres pass a quarter of their size inside them.
pub fn gaps(
    grid: &SparseGrid,
    dx_m: f32,
    particles: &Particles,
    obstacles: &[Obstacle],
    barrier: bool,
) -> Option<NodeGaps> {
    node_gaps(grid, dx_m, particles, obstacles, barrier, gated)
}

/// The node gaps of `particles` on `grid` (cell `dx_m`) against those of `obstacles` that hold
/// every node inside them (sticky, clamp, awake rigid) and are thin enough to have nodes
/// behind them: only which side of such a solid the material lies on is read from them, for the
/// nodes behind it ([`NodeGaps::behind_normal`]); `None` when there is none.
pub fn sides(
    grid: &SparseGrid,
    dx_m: f32,
    particles: &Particles,
    obstacles: &[Obstacle],
) -> Option<NodeGaps> {
    node_gaps(grid, dx_m, particles, obstacles, false, |o| held(o, dx_m))
}

/// The node gaps of `particles` against the `obstacles` that `which` picks ([`gaps`]).
fn node_gaps(
    grid: &SparseGrid,
    dx_m: f32,
    particles: &Particles,
    obstacles: &[Obstacle],
    barrier: bool,
    which: impl Fn(&Obstacle) -> bool + Sync,
) -> Option<NodeGaps> {
    if !obstacles.iter().any(&which) {
        return None;
    }
    Some(
        NodeGaps::new(grid, dx_m, particles, |x| {
            obstacles
                .iter()
                .filter(|o| which(o))
                .filter_map(|o| {
                    let (lo, hi) = o.placed.bounds_m;
                    let margin = 2.0 * dx_m;
                    if !(x.cmpge(lo - margin).all() && x.cmple(hi + margin).all()) {
                        return None;
                    }
                    let (phi, n) = o.placed.surface_at(x);
                    let reach = if barrier && Wall::takes_obstacle(o) {
                        BARRIER_REACH
                    } else {
                        NODE_REACH
                    };
                    Some((phi, n, reach))
                })
                .min_by(|a, b| a.0.total_cmp(&b.0))
        })
        .with_barrier(barrier),
    )
}

/// Whether a node inside `o` takes its rule only where material reaches it (`apply`'s
/// `reach`): an immovable solid, exact or sampled (captured ground), whose rule lets material
/// leave and does not grip. Taken at every node inside it, captured ground held a jelly ball
/// thrown along it over a band of nodes, which stopped it within 0.15 s and rocked it, where on
/// a procedural slab it rolls. A clamp holds every node inside it (it holds the material it
/// encloses: gated, a clamped bar's period and damping were off), so does a sticky one (as a
/// sticky collider, [`crate::collider::Collider::is_gated`]), and a movable solid meets the grid
/// two-way over its whole band (gated, a 1.6 kg block sank 7.4 mm into a jelly that carries it
/// 0.8 mm down).
pub(super) fn gated(o: &Obstacle) -> bool {
    !o.is_movable() && !matches!(o.surface, Surface::Clamp | Surface::Sticky)
}

/// Whether `o` holds every node inside it (sticky, clamp, or movable: an awake rigid solid) and
/// is exact and thin enough on a grid of cell `dx_m` (m) for a node behind it to lie in the
/// stencil of a particle on its near side (thinner than twice [`crate::mpm::reach::BEHIND`]
/// cells): the obstacles of [`sides`]. In an awake rigid plate whose middle lies on a node
/// layer, those nodes took the far face's normal, held a jelly ball's rebound against the plate
/// and so threw the plate up with it.
pub(super) fn held(o: &Obstacle, dx_m: f32) -> bool {
    !gated(o) && o.placed.geometry.is_thinner_than(2.0 * BEHIND * dx_m)
}

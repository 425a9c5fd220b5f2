//! Where material actually reaches a solid's surface, node by node: the gap check of
//! multi-material MPM contact (Bardenhagen et al. 2001, "An improved contact algorithm for the
//! material point method"; Lemiale et al. 2010; Nairn 2013's displacement check), applied to
//! solid boundaries.
//!
//! A grid node inside a solid carries the velocity the particles around it extrapolate to it
//! (APIC), up to 1.5 cells from where they are. Taking the surface rule at every such node acts on
//! a band of material up to 1.5 cells deep: ahead of a rolling ball's contact the band sees the
//! ball's surface turning down towards the solid, still a few millimetres above it, and stops
//! it, which brakes the spin and springs the ball back (a jelly ball thrown along a slab whose top
//! lies on a node layer rocked to and fro within 0.2 s), and a body lands on a cushion of nodes
//! above the surface (a jelly cube thrown at a slab turned back with its particles 5 mm clear of
//! it). So each node gets the smallest gap φ(x_p) − (½ + ¼) V₀^⅓ of the particles whose column
//! along the solid's normal holds the node (½ V₀^⅓ is the particle's half size and ¼ V₀^⅓ a
//! tolerance, `REACH_TOLERANCE`; the column's radius is half a cell, or ¾ of the particle's size
//! where that is more, so a lattice of particles leaves no node between columns), and takes the
//! rule only when that gap closes within the substep: gap ≤ max(−v_n, 0) dt, v_n the node's
//! normal velocity relative to the solid. A node that no particle's column reaches is left free:
//! the particles it carries are above the surface.

use glam::{IVec3, Vec3A};
use rayon::prelude::*;

use super::Particles;
use super::binning::{BLOCK, BLOCK_NODES, pack};
use super::grid::SparseGrid;

/// Particles per parallel chunk of [`NodeGaps::new`] (fixed, so the result does not depend on the
/// thread count; a minimum does not depend on order anyway).
const CHUNK: usize = 4096;

/// A node counts as reached when the gap is within this fraction of the particle's size, so
/// material resting on a solid is held across the lattice's unevenness. Measured: with 0, a
/// 1.6 kg block on a jelly slab on a plane (5 mm grid) sank 1.40 mm (uniaxial 0.80 mm) and the
/// middle cube of a column of three jelly cubes on a plane (1 cm grid) drifted 6.4 mm; with
/// 0.25, 1.27 mm and 4.1 mm; with 0.5, a jelly ball thrown along a plane (1 cm grid) slowed to
/// 0.18 m/s by 0.2 s (0.22 with 0.25), as the band of nodes ahead of its contact grew back.
const REACH_TOLERANCE: f32 = 0.25;

/// How far a particle reaches towards a surface for the grid rule, in particle sizes V₀^⅓: its
/// half size and `REACH_TOLERANCE` (module docs). A surface with a particle barrier
/// (`contact::barrier`) gives its own, smaller reach.
pub const NODE_REACH: f32 = 0.5 + REACH_TOLERANCE;

/// The reach at a surface with the particle barrier (`contact::barrier`), in particle sizes: the
/// grid rule waits until a particle's centre is a quarter of its size inside the surface, as far
/// below it as the barrier's rest lies above.
pub const BARRIER_REACH: f32 = -0.25;

/// How far outside a solid's surface a grid node still takes its rule where the rule waits for
/// material to reach the surface, in cells: with only the nodes inside, the first node layer
/// inside held the material, anywhere from on the surface to a cell below it, so a jelly cube
/// on a static box (1 cm cells) rested up to 1.05 mm lower when the box's top lay just below a
/// node layer than when it lay on one; with the nodes up to half a cell outside, within
/// 0.05 mm wherever the top lies in the cell.
pub const OUTSIDE: f32 = 0.5;

/// How far beyond a solid's far face a grid node still holds the material on its near side, in
/// cells ([`NodeGaps::rule_normal`]): the reach of a particle's stencil. A plate thinner than a
/// cell may hold no node; then only the particles' sweeps stopped the material (it stored no
/// strain for the stop, and a 4 cm jelly ball thrown at 5 m/s onto a 1 mm plate lay flat on it,
/// its COM 12–17 mm above it), while the nodes beyond the plate kept the material's fall and
/// stretched it.
pub const BEHIND: f32 = 1.5;

/// A node closer to the surface than this (in cells) lies on it but for round-off, and its
/// normal is any feature's: it is not taken as outside (at a support's edge, a node at
/// φ = 1.1e-8 m took a side face's normal, and a block landing on two supports at e = 0
/// bounced off at 0.06 m/s).
pub const ON_SURFACE: f32 = 1e-3;

/// Per grid node, the smallest gap (m) between a particle whose column holds the node and the
/// solid (+∞ where none does): module docs.
#[derive(Debug, Clone, Default)]
pub struct NodeGaps {
    /// `[blocks × 64]`, in the grid's node order.
    pub gap_m: Vec<f32>,
    /// `[blocks × 64]`: the outward normal of the solid at the particle that gave the gap.
    pub normal: Vec<Vec3A>,
    /// Whether the gaps were taken with the particle barrier on: a node deeper than
    /// [`super::deep_nodes::HELD_DEPTH`] inside a surface that takes it is then tied to the node
    /// above it instead of taking the rule ([`Self::tied`]).
    pub barrier: bool,
}

impl NodeGaps {
    /// The gaps of `particles` on `grid` (cell `dx_m`), for solids whose signed distance,
    /// outward normal and particle reach (in particle sizes: [`NODE_REACH`], or a barrier's)
    /// at a point `surface(x)` returns (`None` where the point is far from every solid of
    /// interest: more than two cells out).
    pub fn new(
        grid: &SparseGrid,
        dx_m: f32,
        particles: &Particles,
        surface: impl Fn(Vec3A) -> Option<(f32, Vec3A, f32)> + Sync,
    ) -> Self {
        let inv_dx = 1.0 / dx_m;
        // (node, gap) for every node in a near particle's column, found in parallel; the
        // minimum per node is then taken in one pass (a minimum does not depend on order).
        let touches: Vec<(usize, f32, Vec3A)> = particles
            .x
            .par_chunks(CHUNK)
            .zip(particles.volume0_m3.par_chunks(CHUNK))
            .flat_map_iter(|(x, v0)| {
                let mut out = Vec::new();
                for (&x, &v0) in x.iter().zip(v0) {
                    let Some((phi, n, reach)) = surface(x).filter(|(phi, ..)| *phi < 3.0 * dx_m)
                    else {
                        continue;
                    };
                    let size = v0.cbrt();
                    let gap = phi - reach * size;
                    if !(gap.is_finite() && gap < 2.0 * dx_m && n.is_finite()) {
                        continue;
                    }
                    // The column's radius: half a cell, and wide enough that the columns of a
                    // lattice of particles `size` apart leave no node between them. A particle
                    // already inside the solid holds every node of its stencil there: alone (a
                    // stray, or sparse material), its column may hold no node (it can lie
                    // dx/√2 from the nearest one), and then nothing stopped it from sinking
                    // through the surface (measured: four particles of a donut on a sticky
                    // plane, 5 mm grid, fell through it at 12 mm/s).
                    let radius2 = if phi < 0.0 {
                        f32::INFINITY
                    } else {
                        (0.5 * dx_m).max(0.75 * size).powi(2)
                    };
                    let base = (x * inv_dx - Vec3A::splat(0.5)).floor().as_ivec3();
                    for dz in 0..3 {
                        for dy in 0..3 {
                            for dx in 0..3 {
                                let node = base + IVec3::new(dx, dy, dz);
                                let d = node.as_vec3a() * dx_m - x;
                                // Only the nodes of the particle's column that lie about inside
                                // the solid (φ there ≈ φ + d·n; half a cell of slack for a
                                // curved surface) need a gap.
                                if phi + d.dot(n) > 0.5 * dx_m
                                    || (d - n * d.dot(n)).length_squared() > radius2
                                {
                                    continue;
                                }
                                if let Some(i) = node_index(grid, node) {
                                    out.push((i, gap, n));
                                }
                            }
                        }
                    }
                }
                out
            })
            .collect();
        let mut gap_m = vec![f32::INFINITY; grid.mass_kg.len()];
        let mut normal = vec![Vec3A::ZERO; grid.mass_kg.len()];
        for (i, gap, n) in touches {
            if gap < gap_m[i] {
                gap_m[i] = gap;
                normal[i] = n;
            }
        }
        Self {
            gap_m,
            normal,
            barrier: false,
        }
    }

    /// The same gaps, marked as taken with the particle barrier on (`on`) or off.
    pub fn with_barrier(self, on: bool) -> Self {
        Self {
            barrier: on,
            ..self
        }
    }

    /// Whether a node at signed distance `phi_m` (m) inside a surface that takes the particle
    /// barrier (`takes_barrier`), on a grid of cell `dx_m`, is left to
    /// [`super::deep_nodes::tie`] rather than the rule.
    #[inline]
    pub fn tied(&self, takes_barrier: bool, phi_m: f32, dx_m: f32) -> bool {
        self.barrier && takes_barrier && phi_m < -super::deep_nodes::HELD_DEPTH * dx_m
    }

    /// The outward normal along which node `i` takes a gated solid's rule, given the solid's
    /// signed distance `phi_m` (m) and outward normal `normal` at the node (cell `dx_m`);
    /// `None` where it does not take it: [`Self::behind_normal`] where the node lies behind a
    /// thin solid, `normal` inside it otherwise, and `normal` outside by more than round-off and
    /// at most [`OUTSIDE`] cells where it faces the material that reaches it (within 60° of the
    /// gap's normal: not a node beside a solid's edge reached from its top).
    #[inline]
    pub fn rule_normal(&self, i: usize, phi_m: f32, normal: Vec3A, dx_m: f32) -> Option<Vec3A> {
        if let Some(behind) = self.behind_normal(i, phi_m, normal, dx_m) {
            Some(behind)
        } else if phi_m <= 0.0 {
            Some(normal)
        } else {
            (phi_m >= ON_SURFACE * dx_m && phi_m <= OUTSIDE * dx_m && self.facing(i, normal) > 0.5)
                .then_some(normal)
        }
    }

    /// −`normal` where node `i` (signed distance `phi_m`, outward normal `normal` of the solid
    /// there) lies behind a solid thinner than a particle's stencil, as seen from the material
    /// that reaches it: it faces away from that material (its normal more than 120° from the
    /// normal at the particle that gave its gap), inside the solid or at most [`BEHIND`] cells
    /// (`dx_m`) outside. Such a node, past a plate's middle or beyond its far face, holds the
    /// material on the near side along the near face's normal, so the grid sees a thin plate
    /// as it sees a thick one (the shadow of a thin boundary in Hu et al. 2018's CPIC).
    #[inline]
    pub fn behind_normal(&self, i: usize, phi_m: f32, normal: Vec3A, dx_m: f32) -> Option<Vec3A> {
        (self.facing(i, normal) < -0.5 && phi_m <= BEHIND * dx_m).then_some(-normal)
    }

    /// The cosine between `normal` and the normal at the particle that gave node `i` its gap
    /// (0 where no particle did).
    #[inline]
    fn facing(&self, i: usize, normal: Vec3A) -> f32 {
        self.normal
            .get(i)
            .filter(|_| self.gap_m.get(i).is_some_and(|g| g.is_finite()))
            .map_or(0.0, |m| m.dot(normal))
    }

    /// Whether node `i`, moving at normal velocity `v_n_m_s` relative to the solid (negative
    /// towards it), meets the surface within `dt_s`.
    #[inline]
    pub fn reaches(&self, i: usize, v_n_m_s: f32, dt_s: f32) -> bool {
        self.gap_m
            .get(i)
            .is_some_and(|&g| g <= (-v_n_m_s).max(0.0) * dt_s)
    }
}

/// The index of grid node `node` (integer coordinates) in `grid`'s node order, if its block
/// exists.
fn node_index(grid: &SparseGrid, node: IVec3) -> Option<usize> {
    let key = IVec3::new(
        node.x.div_euclid(BLOCK),
        node.y.div_euclid(BLOCK),
        node.z.div_euclid(BLOCK),
    );
    let b = grid
        .keys
        .binary_search_by_key(&pack(key), |k| pack(*k))
        .ok()?;
    let l = node - key * BLOCK;
    Some(b * BLOCK_NODES + (l.x + 4 * l.y + 16 * l.z) as usize)
}

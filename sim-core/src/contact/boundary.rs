//! Solid objects as boundaries on a deformable object's MPM grid: static objects, rigid objects
//! (moving with v + ω × r) and the captured background, rasterised node by node after the grid
//! update, the way grid colliders are (Hu et al. 2018, section 4; rigid bodies as moving
//! boundaries as in Jiang et al. 2016, "The material point method for simulating continuum
//! materials", SIGGRAPH course, section 12).
//!
//! A node of the deformable's grid whose signed distance in a solid is ≤ 0 takes the solid's
//! surface rule (sticky, clamp, slip, or by default "separate" with Coulomb friction, the rule
//! whose grid friction matches the analytic law) relative to the solid's velocity there. Inside an
//! immovable procedural solid that lets material leave, only where the material reaches the
//! surface within the substep ([`crate::mpm::reach`]): a ball rolling on it is not braked by the
//! nodes ahead of its contact, and a body lands on the surface, not on the nodes above it.
//! The momentum this takes out of the grid, m (v' − v) summed over the solid's nodes, is the
//! impulse the material gave the solid, reversed; it is returned with its moment about the
//! solid's COM so a rigid object receives the reaction and the pair conserves momentum. Sums run per grid block in parallel and are added in block order, so
//! the result does not depend on the thread count.
//!
//! Such a solid's rule also acts at nodes up to half a cell outside it, once the material
//! reaches the surface ([`crate::mpm::reach::OUTSIDE`]), so where an object rests does not
//! depend on where the surface lies in a cell; and nodes past the middle of a solid thinner
//! than a particle's stencil, or up to [`crate::mpm::reach::BEHIND`] cells beyond its far face,
//! hold the material on the near side along the near face's normal, so the grid stops material
//! at a plate that holds no node (the particles' sweeps, [`super::crossing`], keep each
//! particle on its side).
//!
//! An awake rigid object is movable and meets the grid two-way: each node's impulse is shared by
//! the node's mass and the node's share of the solid's mass and inertia, over a few Jacobi
//! sweeps in which the solid's velocity follows ([`super::coupling`]; over the grids of every
//! deformable object touching it at once, [`super::grid_coupling`]), so a solid lighter than
//! the material it meets is not treated as a wall (which handed it 1 − m/M + (m/M)² of its
//! kinetic energy, more than it had once the node mass m passed M). Within the sweeps the
//! solid is held where it leaned on immovable solids in the last contact pass
//! ([`super::coupling::Support`]): a light box on a floor under a heavy jelly gives way to the
//! jelly only as far as the floor lets it. Static, kinematic and sleeping objects and the
//! background are immovable: the one-way rule.
//!
//! Grid nodes sample a solid's surface only every cell, so on a rough solid (captured ground,
//! whose surface varies within a cell) particles can sink between nodes well inside it. After
//! G2P, [`project_particles`] therefore gives every particle that lies inside a solid, at depth
//! d, a normal velocity relative to the solid of at least the push-out speed
//! min(d / [`PUSH_OUT_TIME_S`], [`MAX_PUSH_OUT_M_S`]): a particle-level collision (Jiang et al.
//! 2016, course notes, section 12) with a Baumgarte-style bias (Baumgarte 1972; Catto 2005,
//! "Iterative dynamics with temporal coherence") that relaxes the depth over the push-out time.
//! The velocity reaches the grid at the next P2G, so the material around the particle moves out
//! with it and its deformation gradient follows; its momentum change is part of the solid's
//! reaction. Positions are never moved directly: moving a particle out without its deformation
//! gradient feeds energy back every substep (a jelly robot on captured grass, pushed out that
//! way, never came to rest).

use glam::{DMat3, DVec3, IVec3, Vec3A};
use rayon::prelude::*;

use super::coupling::{COUPLING_SWEEPS, Hold, SolidShare, Support, node_impulse};
use super::geometry::Placed;
use super::grid_coupling::Solids;
pub use super::grid_coupling::{CoupledGrid, couple};
pub use super::obstacle_gaps::{gaps, sides};
use super::obstacle_gaps::{gated, held};
use crate::collider::{Surface, apply_surface};
use crate::mpm::Particles;
use crate::mpm::binning::{BLOCK, BLOCK_NODES};
use crate::mpm::grid::SparseGrid;
use crate::mpm::reach::{NodeGaps, ON_SURFACE};

/// A solid as a grid boundary.
#[derive(Debug, Clone, Copy)]
pub struct Obstacle<'a> {
    /// Its surface, pose and bounds.
    pub placed: Placed<'a>,
    /// COM velocity (m/s).
    pub velocity_m_s: Vec3A,
    /// Angular velocity (rad/s).
    pub omega_rad_s: Vec3A,
    /// Coulomb friction μ of the pair.
    pub friction: f32,
    /// The solid's boundary rule.
    pub surface: Surface,
    /// 1/M (1/kg): zero for an immovable solid (static, kinematic or asleep; the background).
    pub inverse_mass: f64,
    /// World-frame inverse inertia about the COM (1/(kg m²)); zero for an immovable solid.
    pub inverse_inertia: DMat3,
    /// Where a movable solid leans on immovable ones ([`super::coupling::Support`]); the
    /// two-way solve holds its motion there.
    pub supports: &'a [Support],
}

impl Obstacle<'_> {
    /// Whether the grid moves it: a movable solid meets the grid two-way
    /// ([`super::coupling`]), an immovable one one-way.
    pub fn is_movable(&self) -> bool {
        self.inverse_mass > 0.0 || self.inverse_inertia != DMat3::ZERO
    }

    /// The part of it a node or particle of mass share `w` (of the mass touching it) meets:
    /// inverse mass and inertia divided by w (mass splitting, [`super::coupling`]).
    pub(super) fn share(&self, w: f64) -> SolidShare {
        SolidShare {
            inverse_mass: self.inverse_mass / w,
            inverse_inertia: self.inverse_inertia * (1.0 / w),
        }
    }

    /// Its velocities after receiving `reaction` (a movable solid's change within the substep).
    pub fn receive(&mut self, reaction: &Reaction) {
        self.velocity_m_s += (reaction.impulse_n_s * self.inverse_mass).as_vec3a();
        self.omega_rad_s += (self.inverse_inertia * reaction.angular_impulse_n_m_s).as_vec3a();
    }

    /// Holds a movable solid's velocities `v` and `w` on its supports ([`Hold`]).
    pub(super) fn hold_motion(&self, hold: &mut Hold, v: &mut DVec3, w: &mut DVec3) {
        if self.is_movable() && !self.supports.is_empty() {
            hold.apply(v, w, self.inverse_mass, self.inverse_inertia, self.supports);
        }
    }
}

/// Impulse a solid received from the grid in one substep.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Reaction {
    /// Linear impulse on the solid (N s).
    pub impulse_n_s: DVec3,
    /// Angular impulse on the solid about its COM (N m s).
    pub angular_impulse_n_m_s: DVec3,
    /// The normal part of `impulse_n_s`: Σ n (n·Δp) over the nodes, each with the solid's
    /// surface normal there (N s; what the restitution law takes its normal from).
    pub normal_impulse_n_s: DVec3,
    /// The moment of `normal_impulse_n_s` about the solid's COM, Σ r × n (n·Δp) reversed
    /// (N m s; where the restitution law finds the contact's lever arm).
    pub normal_moment_n_m_s: DVec3,
    /// Grid nodes with mass inside the solid (whether or not they took its rule).
    pub nodes: u64,
}

impl Reaction {
    /// Adds the reaction to a node or particle at offset `r_m` from the solid's COM gaining
    /// momentum `dp_n_s` (N s) there, at the solid's outward normal `normal`.
    pub(super) fn receive(&mut self, dp_n_s: DVec3, r_m: Vec3A, normal: Vec3A) {
        self.impulse_n_s -= dp_n_s;
        self.angular_impulse_n_m_s -= r_m.as_dvec3().cross(dp_n_s);
        let n = normal.as_dvec3();
        let normal_dp = n * n.dot(dp_n_s);
        self.normal_impulse_n_s -= normal_dp;
        self.normal_moment_n_m_s -= r_m.as_dvec3().cross(normal_dp);
    }

    pub(super) fn add(&mut self, o: &Reaction) {
        self.impulse_n_s += o.impulse_n_s;
        self.angular_impulse_n_m_s += o.angular_impulse_n_m_s;
        self.normal_impulse_n_s += o.normal_impulse_n_s;
        self.normal_moment_n_m_s += o.normal_moment_n_m_s;
        self.nodes += o.nodes;
    }
}

/// Applies `obstacles` to the nodes of `grid` (cell `dx_m`, velocities relative to `v_ref`);
/// returns each obstacle's reaction, in order. Immovable obstacles are applied first, in order
/// at each node; then the movable ones, two-way, over Jacobi sweeps
/// ([`super::coupling`]). With `reach` (the node gaps of the grid's particles, [`gaps`], and the
/// substep dt in s), a node inside an immovable obstacle (procedural or sampled) that lets
/// material leave takes the rule only where material meets the surface within the substep
/// ([`crate::mpm::reach`]); inside any other obstacle (awake rigid, sticky, clamp) every node
/// takes it, and with `sides` (the node gaps against the thin solids that hold every
/// node, [`sides`]) so does a node behind one ([`NodeGaps::behind_normal`]).
pub fn apply(
    grid: &mut SparseGrid,
    dx_m: f32,
    v_ref: Vec3A,
    obstacles: &[Obstacle],
    reach: Option<(&NodeGaps, f32)>,
    sides: Option<&NodeGaps>,
) -> Vec<Reaction> {
    let (mut total, touches) = apply_one_way(grid, dx_m, v_ref, obstacles, reach, sides);
    if touches.iter().any(|t| !t.is_empty()) {
        let SparseGrid {
            mass_kg,
            velocity_m_s,
            ..
        } = grid;
        let solid_of: Vec<Option<usize>> = (0..obstacles.len()).map(Some).collect();
        let mut one = [CoupledGrid {
            mass_kg,
            velocity_m_s,
            v_ref,
            obstacles,
            solid_of: &solid_of,
            touches: &touches,
            total: &mut total,
        }];
        couple(&mut one, obstacles);
    }
    total
}

/// [`apply`] but for the movable obstacles' two-way solve: each obstacle's reaction from the
/// immovable ones' rule, in order, and the nodes that touch movable ones, for a solve
/// ([`couple`]) that may take in the grids of other deformable objects touching the same solids.
pub fn apply_one_way(
    grid: &mut SparseGrid,
    dx_m: f32,
    v_ref: Vec3A,
    obstacles: &[Obstacle],
    reach: Option<(&NodeGaps, f32)>,
    sides: Option<&NodeGaps>,
) -> (Vec<Reaction>, GridTouches) {
    let n = obstacles.len();
    if n == 0 {
        return (Vec::new(), Vec::new());
    }
    let SparseGrid {
        keys,
        mass_kg,
        velocity_m_s,
        ..
    } = grid;
    let per_block: Vec<(Vec<Reaction>, Vec<Touch>)> = mass_kg
        .par_chunks(BLOCK_NODES)
        .zip(velocity_m_s.par_chunks_mut(BLOCK_NODES))
        .zip(keys.par_iter())
        .enumerate()
        .map(|(block, ((mass, vel), key))| {
            let mut out = vec![Reaction::default(); n];
            let mut touches = Vec::new();
            let origin = *key * BLOCK;
            let lo = origin.as_vec3a() * dx_m;
            let hi = (origin + IVec3::splat(BLOCK - 1)).as_vec3a() * dx_m;
            let near: Vec<usize> = (0..n)
                .filter(|&k| {
                    let (blo, bhi) = obstacles[k].placed.bounds_m;
                    lo.cmple(bhi + dx_m).all() && hi.cmpge(blo - dx_m).all()
                })
                .collect();
            if near.is_empty() {
                return (out, touches);
            }
            for l in 0..BLOCK_NODES {
                let m = mass[l];
                if m <= 0.0 {
                    continue;
                }
                let local = IVec3::new((l % 4) as i32, ((l / 4) % 4) as i32, (l / 16) as i32);
                let x = (origin + local).as_vec3a() * dx_m;
                for &k in &near {
                    let o = &obstacles[k];
                    let (blo, bhi) = o.placed.bounds_m;
                    if !(x.cmpge(blo - dx_m).all() && x.cmple(bhi + dx_m).all()) {
                        continue;
                    }
                    let pose = o.placed.pose;
                    let (phi, n0) = o.placed.geometry.distance(pose.to_rest(x));
                    // A sampled surface's faces lie on the grid's node layers (both are anchored
                    // at the world's origin), and its φ at a node on a face is round-off either
                    // side of 0: such a node lies inside (counted outside, the layer below held
                    // the material, and a jelly ball rested 3.3 mm deeper in captured ground
                    // than on a box, 1 cm cells).
                    let phi = if o.placed.geometry.is_exact() || phi.abs() >= ON_SURFACE * dx_m {
                        phi
                    } else {
                        0.0
                    };
                    // Where the rule acts only where material reaches the surface, a node up to
                    // half a cell outside it takes the rule too, and one past a thin solid's
                    // middle or beyond its far face holds the material on the near side
                    // (module docs; `NodeGaps::rule_normal`).
                    let gate = reach.filter(|_| gated(o));
                    let node = block * BLOCK_NODES + l;
                    if !phi.is_finite() {
                        continue;
                    }
                    let n0 = pose.rotation * n0;
                    let behind = || {
                        sides
                            .filter(|_| held(o, dx_m))
                            .and_then(|s| s.behind_normal(node, phi, n0, dx_m))
                    };
                    let Some(normal) = (match gate {
                        Some((g, _)) => g.rule_normal(node, phi, n0, dx_m),
                        None if phi <= 0.0 => behind().or(Some(n0)),
                        None => behind(),
                    }) else {
                        continue;
                    };
                    let r = x - pose.com_m;
                    // Material inside the solid touches it (the restitution law's contact
                    // lasts while any node does), even where it does not reach the surface yet.
                    if phi <= 0.0 {
                        out[k].nodes += 1;
                    }
                    if let Some((gaps, dt_s)) = gate {
                        let solid_v = o.velocity_m_s + o.omega_rad_s.cross(r);
                        let v_n = (vel[l] + v_ref - solid_v).dot(normal);
                        // Deep inside a barrier's surface (gated and "separate": the barrier's
                        // `Wall::takes_obstacle`): tied after the update (`deep_nodes`).
                        let separate = matches!(o.surface, Surface::Separate);
                        if gaps.tied(separate, phi, dx_m) || !gaps.reaches(node, v_n, dt_s) {
                            continue;
                        }
                    }
                    if phi > 0.0 {
                        // It holds material at the surface: a contact, as a node inside is.
                        out[k].nodes += 1;
                    }
                    if o.is_movable() {
                        touches.push(Touch {
                            node: l as u16,
                            obstacle: k as u16,
                            normal,
                            r_m: r,
                        });
                        continue;
                    }
                    let solid_v = o.velocity_m_s + o.omega_rad_s.cross(r);
                    let v = vel[l] + v_ref;
                    let v_new = apply_surface(v - solid_v, normal, o.surface, o.friction) + solid_v;
                    let dp = (v_new - v).as_dvec3() * m as f64;
                    vel[l] = v_new - v_ref;
                    out[k].receive(dp, r, normal);
                }
            }
            (out, touches)
        })
        .collect();
    let (parts, touches): (Vec<Vec<Reaction>>, GridTouches) = per_block.into_iter().unzip();
    (sum_in_order(&parts, n), touches)
}

/// A node of a block touching a movable obstacle.
#[derive(Debug, Clone, Copy)]
pub struct Touch {
    /// The node, within its block.
    pub(super) node: u16,
    /// The obstacle.
    pub(super) obstacle: u16,
    /// The obstacle's outward normal there.
    pub(super) normal: Vec3A,
    /// The node's offset from the obstacle's COM (m).
    pub(super) r_m: Vec3A,
}

/// Per grid block, the nodes that touch movable obstacles, for the two-way solve
/// ([`super::grid_coupling`]).
pub type GridTouches = Vec<Vec<Touch>>;

/// The `n` obstacles' reactions summed over `parts` in their order (so the sums do not depend
/// on how the parts were scheduled).
pub(super) fn sum_in_order(parts: &[Vec<Reaction>], n: usize) -> Vec<Reaction> {
    let mut total = vec![Reaction::default(); n];
    for part in parts {
        for (t, r) in total.iter_mut().zip(part) {
            t.add(r);
        }
    }
    total
}

/// Particles per parallel chunk of [`project_particles`] (fixed, so sums do not depend on the
/// thread count).
const PROJECTION_CHUNK: usize = 4096;

/// Time over which [`project_particles`] relaxes a particle's depth in a solid (s): the push-out
/// speed is depth / this. Long against a substep (the push acts through the grid over many
/// substeps, so it does not ring), short against settling: a particle 1 cm deep leaves at
/// 0.2 m/s. A jelly robot on captured grass (4 cm grid) comes to rest with it at 0.05 s; at
/// 0.01 s it kept bouncing.
pub const PUSH_OUT_TIME_S: f32 = 0.05;
/// Largest push-out speed of [`project_particles`] (m/s): bounds the kinetic energy the
/// push-out can give a particle, ½ m (0.3 m/s)², whatever its depth.
pub const MAX_PUSH_OUT_M_S: f32 = 0.3;

/// Gives every particle of `particles` that lies inside one of `obstacles` a normal velocity
/// relative to the solid of at least its push-out speed, so it stops sinking and leaves over
/// [`PUSH_OUT_TIME_S`] (module docs); returns each obstacle's reaction, in order. Against a
/// movable obstacle the push is shared two-way, each particle with its mass share of the solid,
/// over sweeps in which the solid's velocity follows, held on its supports, as the grid's
/// nodes are ([`super::coupling`]).
pub fn project_particles(particles: &mut Particles, obstacles: &[Obstacle]) -> Vec<Reaction> {
    let n = obstacles.len();
    if n == 0 {
        return Vec::new();
    }
    let Particles { x, v, mass_kg, .. } = particles;
    let per_chunk: Vec<(Vec<Reaction>, Vec<Inside>)> = x
        .par_chunks(PROJECTION_CHUNK)
        .zip(v.par_chunks_mut(PROJECTION_CHUNK))
        .zip(mass_kg.par_chunks(PROJECTION_CHUNK))
        .map(|((x, v), m)| {
            let mut out = vec![Reaction::default(); n];
            let mut inside = Vec::new();
            for i in 0..x.len() {
                for (k, o) in obstacles.iter().enumerate() {
                    let (lo, hi) = o.placed.bounds_m;
                    if !(x[i].cmpge(lo).all() && x[i].cmple(hi).all()) {
                        continue;
                    }
                    let (phi, normal) = o.placed.surface_at(x[i]);
                    if !(phi < 0.0 && phi.is_finite() && normal.is_finite()) {
                        continue;
                    }
                    let r = x[i] - o.placed.pose.com_m;
                    let push = (-phi / PUSH_OUT_TIME_S).min(MAX_PUSH_OUT_M_S);
                    if o.is_movable() {
                        inside.push(Inside {
                            particle: i as u32,
                            obstacle: k as u16,
                            normal,
                            r_m: r,
                            push_m_s: push,
                        });
                        continue;
                    }
                    let solid_v = o.velocity_m_s + o.omega_rad_s.cross(r);
                    let into = (v[i] - solid_v).dot(normal) - push;
                    if into < 0.0 {
                        v[i] -= normal * into;
                        out[k].receive((normal * -into * m[i]).as_dvec3(), r, normal);
                    }
                }
            }
            (out, inside)
        })
        .collect();
    let (parts, inside): (Vec<Vec<Reaction>>, Vec<Vec<Inside>>) = per_chunk.into_iter().unzip();
    let mut total = sum_in_order(&parts, n);
    if inside.iter().all(|c| c.is_empty()) {
        return total;
    }
    let mut inside_mass = vec![0.0f64; n];
    for (c, chunk) in inside.iter().enumerate() {
        for p in chunk {
            inside_mass[p.obstacle as usize] +=
                mass_kg[c * PROJECTION_CHUNK + p.particle as usize] as f64;
        }
    }
    let mut solids = Solids::new(obstacles);
    for _ in 0..COUPLING_SWEEPS {
        let (parts, changes): (Vec<Vec<Reaction>>, Vec<f32>) = v
            .par_chunks_mut(PROJECTION_CHUNK)
            .zip(mass_kg.par_chunks(PROJECTION_CHUNK))
            .zip(inside.par_iter())
            .map(|((v, m), chunk)| {
                if chunk.is_empty() {
                    return (Vec::new(), 0.0);
                }
                let mut out = vec![Reaction::default(); n];
                let mut change = 0.0f32;
                for p in chunk {
                    let (k, i) = (p.obstacle as usize, p.particle as usize);
                    let o = &obstacles[k];
                    let solid = o.share(m[i] as f64 / inside_mass[k]);
                    let (v_solid, w_solid) = solids.motion[k];
                    let solid_v = (v_solid + w_solid.cross(p.r_m.as_dvec3())).as_vec3a();
                    // The push is a separating target: shift it out of the relative velocity
                    // and let the separate rule stop the approach to it.
                    let target = p.normal * p.push_m_s;
                    let j = node_impulse(
                        v[i] - solid_v - target,
                        p.normal,
                        m[i],
                        p.r_m,
                        &solid,
                        Surface::Separate,
                        0.0,
                    );
                    v[i] += j / m[i];
                    change = change.max((j / m[i]).length());
                    out[k].receive(j.as_dvec3(), p.r_m, p.normal);
                }
                (out, change)
            })
            .unzip();
        if solids.follow(obstacles, &parts, &changes, &mut total) {
            break;
        }
    }
    total
}

/// A particle inside a movable obstacle, for the two-way push-out.
#[derive(Debug, Clone, Copy)]
struct Inside {
    /// The particle, within its chunk.
    particle: u32,
    /// The obstacle.
    obstacle: u16,
    /// The obstacle's outward normal there.
    normal: Vec3A,
    /// The particle's offset from the obstacle's COM (m).
    r_m: Vec3A,
    /// Its push-out speed (m/s).
    push_m_s: f32,
}

#[cfg(test)]
pub(crate) mod tests {
    use glam::Quat;

    use super::*;
    use crate::contact::Geometry;
    use crate::procedural::Shape;

    /// A static slab with its top face at z = 0 (m).
    fn slab() -> Geometry {
        Geometry::Analytic(Shape::Box {
            min_m: [-1.0, -1.0, -0.5],
            max_m: [1.0, 1.0, 0.0],
        })
    }

    /// A still, immovable solid of surface `g` with its COM at `com_m` and world bounds
    /// `bounds_m` (m), μ = 0.5, the separate rule.
    pub(crate) fn still_obstacle(
        g: &Geometry,
        com_m: Vec3A,
        bounds_m: (Vec3A, Vec3A),
    ) -> Obstacle<'_> {
        Obstacle {
            placed: Placed {
                geometry: g,
                points: &[],
                groups: None,
                pose: crate::contact::Pose {
                    rest_com_m: com_m,
                    com_m,
                    rotation: Quat::IDENTITY,
                },
                bounds_m,
            },
            velocity_m_s: Vec3A::ZERO,
            omega_rad_s: Vec3A::ZERO,
            friction: 0.5,
            surface: Surface::Separate,
            inverse_mass: 0.0,
            inverse_inertia: DMat3::ZERO,
            supports: &[],
        }
    }

    fn obstacle(g: &Geometry) -> Obstacle<'_> {
        let bounds = (Vec3A::new(-1.0, -1.0, -0.5), Vec3A::new(1.0, 1.0, 0.0));
        still_obstacle(g, Vec3A::ZERO, bounds)
    }

    #[test]
    fn a_particle_inside_a_solid_leaves_at_its_push_out_speed_and_the_solid_takes_the_momentum() {
        let g = slab();
        let obstacles = [obstacle(&g)];
        let mut p = Particles::default();
        // Sinking 1 mm deep (push-out 0.02 m/s), sinking 5 cm deep (capped at 0.3 m/s), leaving
        // faster than its push-out (kept), sliding above the surface (kept).
        let cases = [
            (-0.001, Vec3A::new(0.1, 0.0, -0.5), 0.001 / PUSH_OUT_TIME_S),
            (-0.05, Vec3A::new(0.0, 0.0, -0.5), MAX_PUSH_OUT_M_S),
            (-0.001, Vec3A::new(0.0, 0.0, 1.0), 1.0),
            (0.001, Vec3A::new(0.0, 0.0, -0.5), -0.5),
        ];
        for (z, v, _) in cases {
            p.push(Vec3A::new(0.0, 0.0, z), v, 2.0, 1e-3, 0, 0, 0.0);
        }
        let r = project_particles(&mut p, &obstacles);
        let mut gained = DVec3::ZERO;
        for (i, (_, v0, vz)) in cases.iter().enumerate() {
            assert!(
                (p.v[i].z - vz).abs() < 1e-6,
                "particle {i}: v_z {}",
                p.v[i].z
            );
            // The tangential velocity is the grid's business, not the push-out's.
            assert_eq!((p.v[i].x, p.v[i].y), (v0.x, v0.y));
            gained += ((p.v[i] - *v0) * 2.0).as_dvec3();
        }
        // Momentum conservation: what the particles gained, the solid received reversed.
        assert!((r[0].impulse_n_s + gained).length() < 1e-9);
        assert!((r[0].normal_impulse_n_s - r[0].impulse_n_s).length() < 1e-12);
    }

    /// A grid of one block whose nodes at z = 0 (on the slab's top face) carry `nodes`
    /// (local index, mass kg, velocity m/s).
    fn grid_with(nodes: &[(usize, f32, Vec3A)]) -> SparseGrid {
        let mut grid = SparseGrid {
            keys: vec![IVec3::ZERO],
            mass_kg: vec![0.0; BLOCK_NODES],
            velocity_m_s: vec![Vec3A::ZERO; BLOCK_NODES],
            ..Default::default()
        };
        for &(l, m, v) in nodes {
            grid.mass_kg[l] = m;
            grid.velocity_m_s[l] = v;
        }
        grid
    }

    /// The slab as a free body of mass `mass_kg` with its COM `com_m` and a box's inertia.
    fn free_slab(g: &Geometry, mass_kg: f64, com_m: Vec3A) -> Obstacle<'_> {
        let mut o = obstacle(g);
        o.placed.pose.com_m = com_m;
        o.placed.pose.rest_com_m = com_m;
        o.inverse_mass = 1.0 / mass_kg;
        // A 2 × 2 × 0.5 m box: I = m (b² + c²) / 12 about each axis.
        let i = |b: f64, c: f64| mass_kg * (b * b + c * c) / 12.0;
        o.inverse_inertia = DMat3::from_diagonal(DVec3::new(
            1.0 / i(2.0, 0.5),
            1.0 / i(2.0, 0.5),
            1.0 / i(2.0, 2.0),
        ));
        o
    }

    #[test]
    fn a_node_and_a_free_solid_leave_together_at_the_momentum_weighted_velocity() {
        // One node of mass m at 1 m/s into a solid of mass M at rest, straight at its COM:
        // perfectly inelastic, both at m / (m + M) after; a wall would have kept the node at 0.
        let g = slab();
        for ratio in [0.5f32, 1.0, 2.0, 3.0] {
            let obstacles = [free_slab(&g, 1.0, Vec3A::new(0.0, 0.0, -0.25))];
            let mut grid = grid_with(&[(0, ratio, Vec3A::new(0.0, 0.0, -1.0))]);
            let r = apply(&mut grid, 0.01, Vec3A::ZERO, &obstacles, None, None);
            let common = -(ratio as f64) / (ratio as f64 + 1.0);
            let v_solid = r[0].impulse_n_s.z;
            assert!(
                (grid.velocity_m_s[0].z as f64 - common).abs() < 1e-6,
                "{ratio}"
            );
            assert!((v_solid - common).abs() < 1e-6, "{ratio}: solid {v_solid}");
            assert!(r[0].angular_impulse_n_m_s.length() < 1e-9);
        }
    }

    #[test]
    fn many_nodes_and_a_free_solid_keep_momentum_and_lose_energy() {
        // Nodes of unequal masses and velocities on the top face of a light free slab, off its
        // COM: linear and angular momentum are conserved, kinetic energy does not grow, and after
        // the sweeps no node still approaches the solid's surface faster than a fifth of the
        // fastest approach before.
        let g = slab();
        let com = Vec3A::new(0.05, -0.03, -0.25);
        let mass = 0.02;
        let obstacles = [free_slab(&g, mass, com)];
        let nodes: Vec<(usize, f32, Vec3A)> = (0..16)
            .map(|l| {
                let s = l as f32;
                let m = 0.001 * (1.0 + (s * 0.37).sin().abs() * 3.0);
                let v = Vec3A::new(
                    0.3 * (s * 0.7).cos(),
                    0.2 * (s * 1.3).sin(),
                    -0.5 - 0.05 * s,
                );
                (l, m, v)
            })
            .collect();
        let mut grid = grid_with(&nodes);
        let dx = 0.01;
        let x = |l: usize| Vec3A::new((l % 4) as f32, ((l / 4) % 4) as f32, 0.0) * dx;
        let r = apply(&mut grid, dx, Vec3A::ZERO, &obstacles, None, None);
        let (mut p0, mut p1, mut l0, mut l1, mut e0, mut e1) =
            (DVec3::ZERO, DVec3::ZERO, DVec3::ZERO, DVec3::ZERO, 0.0, 0.0);
        for &(l, m, v) in &nodes {
            let (m, v0, v1) = (m as f64, v.as_dvec3(), grid.velocity_m_s[l].as_dvec3());
            let xl = x(l).as_dvec3();
            p0 += v0 * m;
            p1 += v1 * m;
            l0 += xl.cross(v0) * m;
            l1 += xl.cross(v1) * m;
            e0 += 0.5 * m * v0.length_squared();
            e1 += 0.5 * m * v1.length_squared();
        }
        // The solid starts at rest and takes the reaction.
        let (j, h) = (r[0].impulse_n_s, r[0].angular_impulse_n_m_s);
        let v_solid = j / mass;
        let w_solid = obstacles[0].inverse_inertia * h;
        p1 += j;
        l1 += com.as_dvec3().cross(j) + h;
        e1 += 0.5 * mass * v_solid.length_squared() + 0.5 * w_solid.dot(h);
        assert!(
            (p1 - p0).length() < 1e-7 * p0.length(),
            "momentum {p0} -> {p1}"
        );
        assert!(
            (l1 - l0).length() < 1e-7 * l0.length().max(1e-6),
            "L {l0} -> {l1}"
        );
        assert!(e1 <= e0, "energy {e0} -> {e1}");
        let approach = |v: Vec3A, l: usize| {
            let at = v_solid + w_solid.cross((x(l) - com).as_dvec3());
            (at.z - v.as_dvec3().z).max(0.0)
        };
        let before = nodes
            .iter()
            .map(|&(_, _, v)| -v.z as f64)
            .fold(0.0, f64::max);
        let after = nodes
            .iter()
            .map(|&(l, _, _)| approach(grid.velocity_m_s[l], l))
            .fold(0.0, f64::max);
        assert!(
            after < 0.2 * before,
            "still approaching at {after} m/s (from {before})"
        );
    }
}

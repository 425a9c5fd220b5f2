//! Solid objects as boundaries on a deformable object's MPM grid: static objects, rigid objects
//! (moving with v + ω × r) and the captured background, rasterised node by node after the grid
//! update, the way grid colliders are (Hu et al. 2018, section 4; rigid bodies as moving
//! boundaries as in Jiang et al. 2016, "The material point method for simulating continuum
//! materials", SIGGRAPH course, section 12).
//!
//! A node of the deformable's grid whose signed distance in a solid is ≤ 0 takes the solid's
//! surface rule (sticky, slip, or by default "separate" with Coulomb friction, the rule whose grid
//! friction matches the analytic law) relative to the solid's velocity there. The momentum this takes out of the grid, m (v' − v)
//! summed over the solid's nodes, is the impulse the material gave the solid, reversed; it is
//! returned with its moment about the solid's COM so a rigid object receives the reaction and the
//! pair conserves momentum. Sums run per grid block in parallel and are added in block order, so
//! the result does not depend on the thread count.
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

use glam::{DVec3, IVec3, Vec3A};
use rayon::prelude::*;

use super::geometry::Placed;
use crate::collider::{Surface, apply_surface};
use crate::mpm::Particles;
use crate::mpm::binning::{BLOCK, BLOCK_NODES};
use crate::mpm::grid::SparseGrid;

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
    /// Grid nodes the solid touched.
    pub nodes: u64,
}

impl Reaction {
    fn add(&mut self, o: &Reaction) {
        self.impulse_n_s += o.impulse_n_s;
        self.angular_impulse_n_m_s += o.angular_impulse_n_m_s;
        self.normal_impulse_n_s += o.normal_impulse_n_s;
        self.nodes += o.nodes;
    }
}

/// Applies `obstacles` to the nodes of `grid` (cell `dx_m`, velocities relative to `v_ref`);
/// returns each obstacle's reaction, in order. Obstacles are applied in order at each node.
pub fn apply(
    grid: &mut SparseGrid,
    dx_m: f32,
    v_ref: Vec3A,
    obstacles: &[Obstacle],
) -> Vec<Reaction> {
    let n = obstacles.len();
    if n == 0 {
        return Vec::new();
    }
    let SparseGrid {
        keys,
        mass_kg,
        velocity_m_s,
        ..
    } = grid;
    let per_block: Vec<Vec<Reaction>> = mass_kg
        .par_chunks(BLOCK_NODES)
        .zip(velocity_m_s.par_chunks_mut(BLOCK_NODES))
        .zip(keys.par_iter())
        .map(|((mass, vel), key)| {
            let mut out = vec![Reaction::default(); n];
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
                return out;
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
                    if phi > 0.0 || !phi.is_finite() {
                        continue;
                    }
                    let normal = pose.rotation * n0;
                    let r = x - pose.com_m;
                    let solid_v = o.velocity_m_s + o.omega_rad_s.cross(r);
                    let v = vel[l] + v_ref;
                    let v_new = apply_surface(v - solid_v, normal, o.surface, o.friction) + solid_v;
                    let dp = (v_new - v).as_dvec3() * m as f64;
                    vel[l] = v_new - v_ref;
                    let reaction = &mut out[k];
                    reaction.impulse_n_s -= dp;
                    reaction.angular_impulse_n_m_s -= r.as_dvec3().cross(dp);
                    let n = normal.as_dvec3();
                    reaction.normal_impulse_n_s -= n * n.dot(dp);
                    reaction.nodes += 1;
                }
            }
            out
        })
        .collect();
    sum_in_order(&per_block, n)
}

/// The `n` obstacles' reactions summed over `parts` in their order (so the sums do not depend
/// on how the parts were scheduled).
fn sum_in_order(parts: &[Vec<Reaction>], n: usize) -> Vec<Reaction> {
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
/// [`PUSH_OUT_TIME_S`] (module docs); returns each obstacle's reaction, in order.
pub fn project_particles(particles: &mut Particles, obstacles: &[Obstacle]) -> Vec<Reaction> {
    let n = obstacles.len();
    if n == 0 {
        return Vec::new();
    }
    let Particles { x, v, mass_kg, .. } = particles;
    let per_chunk: Vec<Vec<Reaction>> = x
        .par_chunks(PROJECTION_CHUNK)
        .zip(v.par_chunks_mut(PROJECTION_CHUNK))
        .zip(mass_kg.par_chunks(PROJECTION_CHUNK))
        .map(|((x, v), m)| {
            let mut out = vec![Reaction::default(); n];
            for i in 0..x.len() {
                for (k, o) in obstacles.iter().enumerate() {
                    let (lo, hi) = o.placed.bounds_m;
                    if !(x[i].cmpge(lo).all() && x[i].cmple(hi).all()) {
                        continue;
                    }
                    let pose = o.placed.pose;
                    let (phi, n0) = o.placed.geometry.distance(pose.to_rest(x[i]));
                    let normal = pose.rotation * n0;
                    if !(phi < 0.0 && phi.is_finite() && normal.is_finite()) {
                        continue;
                    }
                    let r = x[i] - pose.com_m;
                    let solid_v = o.velocity_m_s + o.omega_rad_s.cross(r);
                    let push = (-phi / PUSH_OUT_TIME_S).min(MAX_PUSH_OUT_M_S);
                    let into = (v[i] - solid_v).dot(normal) - push;
                    if into < 0.0 {
                        v[i] -= normal * into;
                        let dp = (normal * -into * m[i]).as_dvec3();
                        let reaction = &mut out[k];
                        reaction.impulse_n_s -= dp;
                        reaction.angular_impulse_n_m_s -= r.as_dvec3().cross(dp);
                        reaction.normal_impulse_n_s -= dp;
                    }
                }
            }
            out
        })
        .collect();
    sum_in_order(&per_chunk, n)
}

#[cfg(test)]
mod tests {
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

    fn obstacle(g: &Geometry) -> Obstacle<'_> {
        Obstacle {
            placed: Placed {
                geometry: g,
                points: &[],
                groups: None,
                pose: crate::contact::Pose {
                    rest_com_m: Vec3A::ZERO,
                    com_m: Vec3A::ZERO,
                    rotation: Quat::IDENTITY,
                },
                bounds_m: (Vec3A::new(-1.0, -1.0, -0.5), Vec3A::new(1.0, 1.0, 0.0)),
            },
            velocity_m_s: Vec3A::ZERO,
            omega_rad_s: Vec3A::ZERO,
            friction: 0.5,
            surface: Surface::Separate,
        }
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
}

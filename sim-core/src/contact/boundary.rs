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
//! G2P, [`project_particles`] therefore removes the velocity into the solid (relative to the
//! solid's, along its normal) of every particle that lies inside one, a particle-level collision
//! (Jiang et al. 2016, course notes, section 12); its momentum change is part of the solid's
//! reaction. Positions are left alone: moving a particle out without its deformation gradient
//! feeds energy back every substep (a jelly robot on captured grass, pushed out, never came to
//! rest).

use glam::{DVec3, IVec3, Vec3A};
use rayon::prelude::*;

use super::manifold::Placed;
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

/// Removes the velocity into the solid of every particle of `particles` that lies inside one of
/// `obstacles` (module docs); returns each obstacle's reaction, in order.
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
                    let into = (v[i] - solid_v).dot(normal);
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

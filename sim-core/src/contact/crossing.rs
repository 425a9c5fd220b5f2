//! Particle-level continuous collision against solids thinner than a grid cell.
//!
//! Grid boundary nodes hold material only where a node lies inside a solid; a plate thinner than
//! a cell may hold none, and the particle push-out ([`super::boundary::project_particles`])
//! then sees a particle that has moved past the plate's mid-plane as lying inside the far
//! side, and pushes it on through. So after G2P every particle's path over the substep,
//! x₀ = x − (v − v_solid) dt to x (relative to the solid, in its current pose), is followed by
//! conservative advancement on the solid's signed distance φ (steps of φ, at least
//! 1/[`MAX_MARCH_STEPS`] of the path: Mirtich 1996's conservative advancement, the particle
//! collision of Hu et al. 2018's CPIC for thin boundaries). A particle whose path entered the
//! solid and whose end lies on the far side of it (its nearest surface faces away from the one
//! it entered by: n(x)·n_entry < [`FAR_SIDE_COSINE`]) is put back just outside its entry
//! point, and its velocity into the surface there is removed (the separate rule, no friction;
//! the grid's friction acts on the next substep). In a thick solid, paths that end inside on
//! the near side are the grid's and the push-out's. A solid much thinner than a cell, which may
//! hold no grid node, has no room for that: a particle left inside it crept to its middle,
//! where round-off put it on the far side, and the push-out then drove it through (a jelly ball
//! thrown at 5 m/s onto an awake 2 mm rigid plate ended under it). So in a solid thinner than
//! [`THIN_CELLS`] of a cell every path that enters it and ends inside is put back too, and a
//! particle whose substep starts inside (the solid moved onto it) leaves by the face nearest
//! its start. Not in thicker ones: moving positions at every substep of a resting contact
//! stores no strain for the moves.
//!
//! Only exact surfaces take part: procedural shapes and grid colliders. A sampled level set
//! (captured ground, a solid built from particles) resolves nothing thinner than its cells, and
//! its normal turns over within a cell on a rough surface, which the far-side test would read as
//! a crossing (a robot resting on captured grass sank 9 cm with it).
//!
//! The position is moved, which MPM otherwise never does here (moving a particle without its
//! deformation gradient stores no strain for the move), but only for a particle that has
//! crossed a solid, where the alternative is tunnelling. The grid stops the material at such a
//! plate too, at the nodes behind it ([`crate::mpm::reach::NodeGaps::behind_normal`]), so the
//! material stores the strain of the stop and a soft ball keeps its shape on it.

use glam::{DVec3, Vec3A};
use rayon::prelude::*;

use super::boundary::{Obstacle, Reaction, sum_in_order};
use crate::collider::{Collider, Shape};
use crate::mpm::Particles;

/// The most steps of a conservative-advancement march along one particle's path.
pub const MAX_MARCH_STEPS: usize = 32;

/// A path's end lies on the far side of a solid when the cosine between its nearest surface's
/// normal and the normal where the path entered is below this (opposite faces of a plate: −1;
/// adjacent faces of a box: 0).
pub const FAR_SIDE_COSINE: f32 = -0.5;

/// A solid thinner than this many grid cells has every path into it put back, and a particle
/// it moved onto put out (module docs). Where a solid is a cell thick or more, a node layer
/// lies inside it and holds the material before it creeps to the middle; between half a cell
/// and a cell it may, and moving positions there stores no strain: a 1 cm rigid block on a
/// jelly cube, 1 cm cells (its thickness a hair under a cell in f32), sank 2.6 times the
/// uniaxial strain with the rules at a cell.
pub const THIN_CELLS: f32 = 0.5;

/// Particles per parallel chunk (fixed, so sums do not depend on the thread count).
const CHUNK: usize = 4096;

/// The signed distance (m) and outward world normal of obstacle `o` at `x` (m); `None` where it
/// is not finite.
fn distance(o: &Obstacle<'_>, x: Vec3A) -> Option<(f32, Vec3A)> {
    let (phi, n) = o.placed.surface_at(x);
    (phi.is_finite() && n.is_finite()).then_some((phi, n))
}

/// Where the path from `x0` to `x1` (m) first reaches the solid of signed distance and outward
/// normal `distance` (φ ≤ 0), and the normal there; `None` if it does not within
/// [`MAX_MARCH_STEPS`] steps.
fn entry(
    distance: &impl Fn(Vec3A) -> Option<(f32, Vec3A)>,
    x0: Vec3A,
    x1: Vec3A,
) -> Option<(Vec3A, Vec3A)> {
    let length = (x1 - x0).length();
    if length.is_nan() || length <= 0.0 {
        return None;
    }
    let dir = (x1 - x0) / length;
    let min_step = length / MAX_MARCH_STEPS as f32;
    let (mut outside, mut s) = (0.0f32, 0.0f32);
    loop {
        let p = x0 + dir * s;
        let (phi, n) = distance(p)?;
        if phi <= 0.0 {
            if s == 0.0 {
                return Some((p, n));
            }
            break;
        }
        if s >= length {
            return None;
        }
        outside = s;
        // The distance bounds how far the surface can be (a distance with a Lipschitz
        // constant of 1), so no step passes it; the floor ends the march in bounded steps
        // (and may step past the surface, which the bisection below finds again).
        s = (s + phi.max(min_step)).min(length);
    }
    // Between the last point outside and the first inside, to 2^-16 of a step; the
    // point returned is the last outside, so a particle put back there lies outside and its
    // next path into the solid is an entry again (a particle left just inside a thin plate
    // crept to its middle, where round-off put it on the far side).
    let mut inside = s;
    for _ in 0..16 {
        let mid = 0.5 * (outside + inside);
        match distance(x0 + dir * mid) {
            Some((phi, _)) if phi <= 0.0 => inside = mid,
            _ => outside = mid,
        }
    }
    let p = x0 + dir * outside;
    distance(x0 + dir * inside).map(|(_, n)| (p, n))
}

/// Where the path from `x0` to `x1` (m) entered the solid of `distance` if it crossed it (ends
/// on its far side; module docs), or, for a `thin` solid, if it entered it from outside and
/// ends anywhere inside; and the outward normal there.
fn crossing(
    distance: &impl Fn(Vec3A) -> Option<(f32, Vec3A)>,
    x0: Vec3A,
    x1: Vec3A,
    thin: bool,
) -> Option<(Vec3A, Vec3A)> {
    let (phi1, n1) = distance(x1)?;
    // A path that ends outside, coming towards the surface or along it, has not passed
    // through it.
    if phi1 > 0.0 && n1.dot(x1 - x0) <= 0.0 {
        return None;
    }
    let (phi0, n0) = distance(x0)?;
    if thin && phi0 <= 0.0 && (phi1 <= 0.0 || n1.dot(n0) < FAR_SIDE_COSINE) {
        // It started inside the thin solid (the solid moved onto it, by less than a substep's
        // travel), and ends inside or beyond it: out by the face nearest its start, just
        // outside it (a particle left inside crept to the middle, where round-off put it on
        // the far side).
        let margin = 1e-6 * (1.0 + x0.abs().max_element());
        return Some((x0 + n0 * (margin - phi0), n0));
    }
    let entered = thin && phi1 <= 0.0 && phi0 > 0.0;
    let (point, normal) = entry(distance, x0, x1)?;
    (entered || n1.dot(normal) < FAR_SIDE_COSINE).then_some((point, normal))
}

/// [`stop_crossings`] for grid colliders at time `time_s` (s), on a grid of cell `dx_m` (m);
/// returns the normal impulse each collider gave the particles (N s), in order. Only box
/// colliders can be crossed: a plane's half-space and the domain bound's outside have no far
/// side, and are skipped.
pub fn stop_collider_crossings(
    particles: &mut Particles,
    colliders: &[Collider],
    time_s: f64,
    dt_s: f32,
    dx_m: f32,
) -> Vec<DVec3> {
    let n_colliders = colliders.len();
    let boxes = |c: &Collider| matches!(c.shape, Shape::Box(_));
    if !colliders.iter().any(boxes) || dt_s.is_nan() || dt_s <= 0.0 {
        return vec![DVec3::ZERO; n_colliders];
    }
    let Particles { x, v, mass_kg, .. } = particles;
    let parts: Vec<Vec<DVec3>> = x
        .par_chunks_mut(CHUNK)
        .zip(v.par_chunks_mut(CHUNK))
        .zip(mass_kg.par_chunks(CHUNK))
        .map(|((x, v), m)| {
            let mut out = vec![DVec3::ZERO; n_colliders];
            for i in 0..x.len() {
                for (k, c) in colliders.iter().enumerate().filter(|(_, c)| boxes(c)) {
                    let solid_v = c.velocity_at(time_s);
                    let x0 = x[i] - (v[i] - solid_v) * dt_s;
                    let distance = |p| c.signed_distance(p, time_s);
                    let thin = c.is_thinner_than(THIN_CELLS * dx_m);
                    let Some((point, normal)) = crossing(&distance, x0, x[i], thin) else {
                        continue;
                    };
                    x[i] = point;
                    let into = (v[i] - solid_v).dot(normal);
                    if into < 0.0 {
                        v[i] -= normal * into;
                        out[k] += (normal * (-into * m[i])).as_dvec3();
                    }
                }
            }
            out
        })
        .collect();
    let mut total = vec![DVec3::ZERO; n_colliders];
    for part in &parts {
        for (t, j) in total.iter_mut().zip(part) {
            *t += *j;
        }
    }
    total
}

/// Puts back every particle of `particles` whose path over the substep `dt_s` (s) crossed one
/// of `obstacles`, or entered one thinner than [`THIN_CELLS`] of the grid's cell `dx_m` (m)
/// (module docs), and
/// returns each obstacle's reaction, in order: the momentum the removed velocities took,
/// reversed.
pub fn stop_crossings(
    particles: &mut Particles,
    obstacles: &[Obstacle<'_>],
    dt_s: f32,
    dx_m: f32,
) -> Vec<Reaction> {
    let n_obstacles = obstacles.len();
    if !obstacles.iter().any(|o| o.placed.geometry.is_exact()) || dt_s.is_nan() || dt_s <= 0.0 {
        return vec![Reaction::default(); n_obstacles];
    }
    let Particles { x, v, mass_kg, .. } = particles;
    let parts: Vec<Vec<Reaction>> = x
        .par_chunks_mut(CHUNK)
        .zip(v.par_chunks_mut(CHUNK))
        .zip(mass_kg.par_chunks(CHUNK))
        .map(|((x, v), m)| {
            let mut out = vec![Reaction::default(); n_obstacles];
            for i in 0..x.len() {
                for (k, o) in obstacles
                    .iter()
                    .enumerate()
                    .filter(|(_, o)| o.placed.geometry.is_exact())
                {
                    let pose = o.placed.pose;
                    let solid_v = o.velocity_m_s + o.omega_rad_s.cross(x[i] - pose.com_m);
                    let x0 = x[i] - (v[i] - solid_v) * dt_s;
                    let (lo, hi) = o.placed.bounds_m;
                    if !(x0.min(x[i]).cmple(hi).all() && x0.max(x[i]).cmpge(lo).all()) {
                        continue;
                    }
                    let thin = o.placed.geometry.is_thinner_than(THIN_CELLS * dx_m);
                    let Some((point, normal)) = crossing(&|p| distance(o, p), x0, x[i], thin)
                    else {
                        continue;
                    };
                    x[i] = point;
                    let into = (v[i] - solid_v).dot(normal);
                    if into < 0.0 {
                        v[i] -= normal * into;
                        let dp = (normal * (-into * m[i])).as_dvec3();
                        out[k].receive(dp, point - pose.com_m, normal);
                    }
                }
            }
            out
        })
        .collect();
    sum_in_order(&parts, n_obstacles)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::Geometry;
    use crate::contact::boundary::tests::still_obstacle;
    use crate::procedural::Shape as Procedural;

    /// A static plate 1 mm thick with its top face at z = 0.
    fn plate() -> Geometry {
        Geometry::Analytic(Procedural::Box {
            min_m: [-1.0, -1.0, -0.001],
            max_m: [1.0, 1.0, 0.0],
        })
    }

    #[test]
    fn a_particle_that_crossed_a_thin_plate_is_put_back_on_the_side_it_came_from() {
        let g = plate();
        let bounds = (Vec3A::new(-1.0, -1.0, -0.001), Vec3A::new(1.0, 1.0, 0.0));
        let obstacles = [still_obstacle(&g, Vec3A::new(0.0, 0.0, -0.0005), bounds)];
        let dt = 1e-3;
        let mut p = Particles::default();
        // At 5 m/s down over a 1 ms substep (5 mm): from 2 mm above the plate to 3 mm below
        // it, clean through (its end is outside, below); from 0.2 mm above to 0.8 mm into a
        // 1 mm plate (past its mid-plane); one that ends inside on the near side (0.3 mm deep:
        // in a plate this thin, put back too); one that moves along above it, one that leaves
        // upwards.
        let cases = [
            (
                Vec3A::new(0.0, 0.0, -0.003),
                Vec3A::new(0.0, 0.0, -5.0),
                true,
            ),
            (
                Vec3A::new(0.1, 0.0, -0.0008),
                Vec3A::new(1.0, 0.0, -1.0),
                true,
            ),
            (
                Vec3A::new(0.2, 0.0, -0.0003),
                Vec3A::new(0.0, 0.0, -1.0),
                true,
            ),
            (
                Vec3A::new(0.3, 0.0, 0.001),
                Vec3A::new(2.0, 0.0, 0.0),
                false,
            ),
            (
                Vec3A::new(0.4, 0.0, 0.002),
                Vec3A::new(0.0, 0.0, 1.0),
                false,
            ),
        ];
        for (x, v, _) in cases {
            p.push(x, v, 2.0, 1e-6, 0, 0, 0.0);
        }
        let r = stop_crossings(&mut p, &obstacles, dt, 0.01);
        let mut gained = 0.0;
        for (i, (x, v, crossed)) in cases.iter().enumerate() {
            if *crossed {
                // Back on the top face where its path entered, no longer moving into it, its
                // motion along the face kept.
                let x0 = *x - *v * dt;
                let t = x0.z / (x0.z - x.z);
                let entry = x0 + (*x - x0) * t;
                assert!((p.x[i] - entry).length() < 1e-6, "{i}: {}", p.x[i]);
                assert!(p.x[i].z > 0.0, "{i} was left inside the plate: {}", p.x[i]);
                assert_eq!(p.v[i].z, 0.0);
                assert_eq!(p.v[i].x, v.x);
                gained += 2.0 * (p.v[i].z - v.z) as f64;
            } else {
                assert_eq!((p.x[i], p.v[i]), (*x, *v), "{i} was touched");
            }
        }
        // The plate took the momentum the particles lost.
        assert!((r[0].impulse_n_s.z + gained).abs() < 1e-9);
    }

    #[test]
    fn a_particle_a_thin_plate_moved_onto_leaves_by_the_face_nearest_its_start() {
        let g = plate();
        let bounds = (Vec3A::new(-1.0, -1.0, -0.001), Vec3A::new(1.0, 1.0, 0.0));
        let obstacles = [still_obstacle(&g, Vec3A::new(0.0, 0.0, -0.0005), bounds)];
        let mut p = Particles::default();
        // Its substep started 0.1 mm inside the top face and ends 0.2 mm inside: out by the
        // top face, just above it; in a plate 4 cm thick (thick on a 1 cm grid) it is left
        // to the push-out.
        p.push(
            Vec3A::new(0.0, 0.0, -0.0002),
            Vec3A::new(0.0, 0.0, -0.1),
            2.0,
            1e-6,
            0,
            0,
            0.0,
        );
        let mut thick = p.clone();
        stop_crossings(&mut p, &obstacles, 1e-3, 0.01);
        assert!(p.x[0].z > 0.0 && p.x[0].z < 1e-5, "{}", p.x[0]);
        assert_eq!(p.v[0].z, 0.0);
        let slab = Geometry::Analytic(Procedural::Box {
            min_m: [-1.0, -1.0, -0.04],
            max_m: [1.0, 1.0, 0.0],
        });
        let bounds = (Vec3A::new(-1.0, -1.0, -0.04), Vec3A::new(1.0, 1.0, 0.0));
        let obstacles = [still_obstacle(&slab, Vec3A::new(0.0, 0.0, -0.02), bounds)];
        stop_crossings(&mut thick, &obstacles, 1e-3, 0.01);
        assert_eq!(thick.x[0].z, -0.0002);
    }
}

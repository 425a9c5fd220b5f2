//! Method `com`'s MPM part: every awake deformable object on its own grid, the solids as
//! boundaries on each, and the movable solids' two-way solve over every grid that touches them
//! at once ([`crate::contact::grid_coupling`]).
//!
//! A substep runs in phases: each object's particle barrier, P2G and grid update with the
//! immovable boundaries; then one two-way solve of the movable solids with the touching nodes
//! of all the grids; then each object's G2P and the particles' sweeps and push-out against the
//! solids as that solve left them.

use std::time::Instant;

use super::mpm_step::{
    GridContacts, ObstacleOf, Step, Touch, collider_touches, device_substep, obstacles_near,
    project_out_of_solids, push_at_surfaces, simulated,
};
use super::{Body, Env, WorldError, WorldStats};
use crate::contact::boundary::{self, CoupledGrid, GridTouches, Obstacle, Reaction};
use crate::mpm::grid::SparseGrid;
use crate::mpm::{MpmError, MpmSolver, Particles};

/// A deformable object's solver and particles, out of its body for the substep.
struct Taken {
    /// The object.
    k: usize,
    solver: MpmSolver,
    particles: Particles,
    /// Wall time spent on it (s).
    wall_s: f64,
    /// P2G's and the grid update's result.
    scattered: Result<(), MpmError>,
    /// What its grid left for the two-way solve: per obstacle the reactions so far, and the
    /// nodes touching movable ones.
    boundary: (Vec<Reaction>, GridTouches),
    /// Its touches for the restitution law and rolling resistance (together, in order: rolling
    /// resistance takes each object's touches as one run).
    touches: Vec<Touch>,
}

/// Method `com`: every awake deformable object of `bodies` runs a whole substep of `dt_s` on its
/// own grid, with the solids as boundaries; on the device where `env` has one and the object's
/// situation allows ([`super::mpm_step::device_may_step`]).
pub(super) fn per_object(
    env: &Env,
    bodies: &mut [Body],
    stats: &mut WorldStats,
    dt_s: f32,
) -> Result<GridContacts, WorldError> {
    let mut reactions = vec![Reaction::default(); bodies.len()];
    let mut touches = Vec::new();
    let mut taken = Vec::new();
    for k in 0..bodies.len() {
        if !env.stepping(k) {
            continue;
        }
        if !simulated(&bodies[k]) {
            bodies[k].stats.substeps_skipped += 1;
            continue;
        }
        match device_substep(env, bodies, stats, k, dt_s) {
            Ok(Some(t)) => {
                touches.extend(t);
                continue;
            }
            Ok(None) => {}
            Err(e) => {
                // The objects taken out so far go back as they were.
                for t in taken {
                    put_back(bodies, t);
                }
                return Err(e);
            }
        }
        let b = &mut bodies[k];
        let dx = b.solver.dx_m;
        taken.push(Taken {
            k,
            solver: std::mem::replace(&mut b.solver, MpmSolver::new(dx)),
            particles: std::mem::take(&mut b.particles),
            wall_s: 0.0,
            scattered: Ok(()),
            boundary: (Vec::new(), Vec::new()),
            touches: Vec::new(),
        });
    }
    let step = Step::new(env, dt_s);
    let gathered = {
        let bodies: &[Body] = bodies;
        let mut solids = Vec::with_capacity(taken.len());
        for t in &mut taken {
            let started = Instant::now();
            let (b, dx) = (&bodies[t.k], t.solver.dx_m);
            let near = obstacles_near(env, bodies, &reactions, &t.particles, b.friction, dx);
            t.touches.extend(push_at_surfaces(
                step,
                t.k,
                &mut t.particles,
                &b.materials,
                dx,
                &near,
                &mut reactions,
            ));
            t.scattered = t
                .solver
                .scatter_and_update(&t.particles, &step.input(&b.materials));
            if t.scattered.is_ok() {
                let j = (
                    t.solver.collider_impulses_n_s(),
                    t.solver.collider_friction_n_s(),
                );
                t.touches
                    .extend(collider_touches(t.k, j, t.solver.collider_nodes()));
                t.boundary = one_way(&mut t.solver, &t.particles, dt_s, step.barrier, &near.0);
            }
            solids.push(near);
            t.wall_s += started.elapsed().as_secs_f64();
        }
        two_way(bodies, &mut taken, &solids, &mut reactions);
        let mut gathered = Vec::with_capacity(taken.len());
        for (t, near) in taken.iter_mut().zip(&mut solids) {
            let started = Instant::now();
            for (r, &o) in t.boundary.0.iter().zip(&near.1) {
                if r.nodes > 0 {
                    t.touches.push(Touch::of(t.k, o, r));
                }
            }
            let b = &bodies[t.k];
            let r = std::mem::replace(&mut t.scattered, Ok(()))
                .and_then(|()| t.solver.gather(&mut t.particles, &step.input(&b.materials)));
            if r.is_ok() {
                // The solids as every grid's two-way solve (and the push-outs of the grids
                // before) left them; their margin covers how far G2P moved the particles.
                for (o, &which) in near.0.iter_mut().zip(&near.1) {
                    if let ObstacleOf::Object(k) = which
                        && o.is_movable()
                    {
                        *o = received(o, &bodies[k], &reactions[k]);
                    }
                }
                let at = (step, t.k, t.solver.dx_m);
                let c = project_out_of_solids(at, &mut t.particles, near, &mut reactions);
                t.touches.extend(c);
            }
            t.wall_s += started.elapsed().as_secs_f64();
            gathered.push(r);
        }
        gathered
    };
    // Every object goes back before the first error is reported.
    let mut result = Ok(());
    for (mut t, r) in taken.into_iter().zip(gathered) {
        touches.append(&mut t.touches);
        let k = t.k;
        put_back(bodies, t);
        if result.is_ok() {
            result = step.finish(stats, &mut bodies[k], r);
        }
    }
    result.map(|()| GridContacts { reactions, touches })
}

/// Puts `t`'s solver and particles back into its body, with the wall time spent on it.
fn put_back(bodies: &mut [Body], t: Taken) {
    let b = &mut bodies[t.k];
    b.solver = t.solver;
    b.particles = t.particles;
    b.stats.mpm_wall_s += t.wall_s;
}

/// The immovable `obstacles`' rule on `solver`'s grid of `particles` in a substep of `dt_s`
/// (with `barrier`: after the particle barrier), and the nodes touching movable ones
/// ([`boundary::apply_one_way`]).
fn one_way(
    solver: &mut MpmSolver,
    particles: &Particles,
    dt_s: f32,
    barrier: bool,
    obstacles: &[Obstacle],
) -> (Vec<Reaction>, GridTouches) {
    if obstacles.is_empty() {
        return (Vec::new(), Vec::new());
    }
    let (v_ref, dx) = (solver.reference_velocity_m_s(), solver.dx_m);
    let gaps = boundary::gaps(solver.grid(), dx, particles, obstacles, barrier);
    let sides = boundary::sides(solver.grid(), dx, particles, obstacles);
    let reach = gaps.as_ref().map(|g| (g, dt_s));
    boundary::apply_one_way(
        solver.grid_mut(),
        dx,
        v_ref,
        obstacles,
        reach,
        sides.as_ref(),
    )
}

/// The two-way solve of the movable solids with the touching nodes of every grid in `taken`
/// (each with its `solids`, in order), each solid as it starts the solve: its velocity plus
/// what it received so far (`reactions`). Then adds every grid's reactions to `reactions`.
fn two_way(
    bodies: &[Body],
    taken: &mut [Taken],
    solids: &[(Vec<Obstacle>, Vec<ObstacleOf>)],
    reactions: &mut [Reaction],
) {
    // The movable solids of every grid, each once, as they start the solve.
    let mut index = vec![usize::MAX; bodies.len()];
    let mut movable: Vec<Obstacle> = Vec::new();
    let mut solid_of: Vec<Vec<Option<usize>>> = Vec::with_capacity(taken.len());
    for (obstacles, of) in solids {
        let mut map = vec![None; obstacles.len()];
        for ((o, &which), slot) in obstacles.iter().zip(of).zip(&mut map) {
            let ObstacleOf::Object(k) = which else {
                continue;
            };
            if !o.is_movable() {
                continue;
            }
            if index[k] == usize::MAX {
                index[k] = movable.len();
                movable.push(received(o, &bodies[k], &reactions[k]));
            }
            *slot = Some(index[k]);
        }
        solid_of.push(map);
    }
    let mut grids: Vec<CoupledGrid> = Vec::new();
    for ((t, (obstacles, _)), map) in taken.iter_mut().zip(solids).zip(&solid_of) {
        let Taken {
            solver,
            boundary: (total, touches),
            ..
        } = t;
        if touches.iter().all(|ts| ts.is_empty()) {
            continue;
        }
        let v_ref = solver.reference_velocity_m_s();
        let SparseGrid {
            mass_kg,
            velocity_m_s,
            ..
        } = solver.grid_mut();
        grids.push(CoupledGrid {
            mass_kg,
            velocity_m_s,
            v_ref,
            obstacles,
            solid_of: map,
            touches,
            total,
        });
    }
    if !grids.is_empty() {
        boundary::couple(&mut grids, &movable);
    }
    drop(grids);
    for (t, (_, of)) in taken.iter().zip(solids) {
        for (r, &which) in t.boundary.0.iter().zip(of) {
            if let ObstacleOf::Object(k) = which {
                reactions[k].impulse_n_s += r.impulse_n_s;
                reactions[k].angular_impulse_n_m_s += r.angular_impulse_n_m_s;
                reactions[k].nodes += r.nodes;
            }
        }
    }
}

/// Movable obstacle `o` (solid `b`) as it moves once it has received `reaction` this substep.
fn received<'a>(o: &Obstacle<'a>, b: &Body, reaction: &Reaction) -> Obstacle<'a> {
    let mut o = *o;
    o.velocity_m_s = b.rigid.velocity_m_s.as_vec3a();
    o.omega_rad_s = b.rigid.omega_rad_s.as_vec3a();
    o.receive(reaction);
    o
}

//! The MPM part of a world substep, one function per method: `com` (every awake deformable
//! object on its own grid, [`super::per_object`], with the helpers here), `multi-field`
//! (per-object fields coupled at shared nodes, Bardenhagen et al. 2000,
//! [`crate::mpm::multi_field`]) and `mpm` (every awake deformable object on one shared grid,
//! contact through the grid). Rigid and static objects and the captured background are
//! boundaries on these grids ([`crate::contact::boundary`]); each function returns the reaction
//! every object received, for the rigid step.

use glam::{DMat3, DVec3, Vec3A};

use super::device;
use super::measure::inverse_or_zero;
use super::{Body, Env, WorldError, WorldStats};
use crate::collider::Collider;
use crate::contact::SurfaceContact;
use crate::contact::barrier::{self, Wall};
use crate::contact::boundary::{self, Obstacle, Reaction};
use crate::contact::crossing;
use crate::contact::mix_friction;
use crate::material::Material;
use crate::mpm::{
    MpmError, MpmSolver, Particles, SubstepInput, SubstepReport, deep_nodes, multi_field,
};
use crate::scene::ObjectKind;

/// Whether `b` runs MPM this substep.
pub(super) fn simulated(b: &Body) -> bool {
    b.is_active() && b.kind == ObjectKind::Deformable
}

/// What every solver call of one substep shares: colliders, gravity (m/s²), dt (s) and the time
/// at the start of the substep (s).
#[derive(Clone, Copy)]
pub(super) struct Step<'a> {
    colliders: &'a [Collider],
    gravity_m_s2: Vec3A,
    dt_s: f32,
    time_s: f64,
    /// Whether "separate" surfaces meet the material through the particle barrier
    /// ([`barrier`], `[simulation] surface_contact`).
    pub(super) barrier: bool,
}

impl<'a> Step<'a> {
    pub(super) fn new(env: &Env<'a>, dt_s: f32) -> Self {
        Self {
            colliders: env.colliders,
            gravity_m_s2: env.gravity_m_s2,
            dt_s,
            time_s: env.time_s,
            barrier: env.settings.surface_contact == SurfaceContact::Barrier,
        }
    }

    /// The solver input for `materials`.
    pub(super) fn input(self, materials: &'a [Material]) -> SubstepInput<'a> {
        SubstepInput {
            materials,
            colliders: self.colliders,
            gravity_m_s2: self.gravity_m_s2,
            dt_s: self.dt_s,
            time_s: self.time_s,
            barrier: self.barrier,
        }
    }

    /// A solver error as the world reports it: object, substep and time.
    fn error(self, stats: &WorldStats, object: &str, source: MpmError) -> WorldError {
        WorldError::Solver {
            object: object.to_string(),
            substep: stats.substeps,
            time_s: self.time_s,
            source,
        }
    }

    /// Records body `b`'s result in it and in `stats`, or names it in the error.
    pub(super) fn finish(
        self,
        stats: &mut WorldStats,
        b: &mut Body,
        r: Result<SubstepReport, MpmError>,
    ) -> Result<(), WorldError> {
        let r = r.map_err(|e| self.error(stats, &b.name, e))?;
        b.max_speed_m_s = r.max_speed_m_s;
        stats.mpm_particle_substeps += b.particles.len() as u64;
        Ok(())
    }
}

/// Deformable `k`'s touches of grid colliders in its last grid update, from each collider's
/// normal and friction impulse on it (N s; no friction where `friction_n_s` is empty) and its
/// grid nodes with mass inside the collider: one where either impulse or node count is not
/// zero, for the restitution law (`impact.rs`).
pub(super) fn collider_touches<'a>(
    k: usize,
    (impulses_n_s, friction_n_s): (&'a [DVec3], &'a [DVec3]),
    nodes: &'a [u64],
) -> impl Iterator<Item = Touch> + 'a {
    impulses_n_s
        .iter()
        .zip(nodes)
        .enumerate()
        .filter(|(_, (j, n))| **j != DVec3::ZERO || **n > 0)
        .map(move |(c, (j, _))| {
            let friction = friction_n_s.get(c).copied().unwrap_or(DVec3::ZERO);
            Touch::collider(k, c, *j, friction)
        })
}

/// The box around `particles`' positions (m).
fn bounds(particles: &Particles) -> (Vec3A, Vec3A) {
    particles.x.iter().fold(
        (Vec3A::splat(f32::INFINITY), Vec3A::splat(f32::NEG_INFINITY)),
        |(lo, hi), x| (lo.min(*x), hi.max(*x)),
    )
}

/// Applies `solids` (obstacles and which solid each is) as boundaries on `solver`'s grid of
/// `particles` in a substep of `dt_s` (with `barrier`: after the particle barrier, [`barrier`]),
/// adds their reactions to `reactions`, moves the movable
/// ones by theirs (for the particle push-out after G2P) and returns the solids touched with the
/// reaction each received.
fn apply_obstacles(
    (solver, particles, dt_s, barrier): (&mut MpmSolver, &Particles, f32, bool),
    (obstacles, of): &mut (Vec<Obstacle<'_>>, Vec<ObstacleOf>),
    reactions: &mut [Reaction],
) -> Vec<(ObstacleOf, Reaction)> {
    if obstacles.is_empty() {
        return Vec::new();
    }
    let v_ref = solver.reference_velocity_m_s();
    let dx = solver.dx_m;
    let gaps = boundary::gaps(solver.grid(), dx, particles, obstacles, barrier);
    let sides = boundary::sides(solver.grid(), dx, particles, obstacles);
    let reach = gaps.as_ref().map(|g| (g, dt_s));
    let r = boundary::apply(
        solver.grid_mut(),
        dx,
        v_ref,
        obstacles,
        reach,
        sides.as_ref(),
    );
    if barrier && obstacles.iter().any(Wall::takes_obstacle) {
        deep_nodes::tie(solver.grid_mut(), dx, |x| {
            obstacles
                .iter()
                .filter(|o| Wall::takes_obstacle(o))
                .filter(|o| {
                    let (lo, hi) = o.placed.bounds_m;
                    x.cmpge(lo - dx).all() && x.cmple(hi + dx).all()
                })
                .map(|o| o.placed.surface_at(x))
                .min_by(|a, b| a.0.total_cmp(&b.0))
        });
    }
    let mut touched = Vec::new();
    for ((r, &k), o) in r.iter().zip(of.iter()).zip(obstacles.iter_mut()) {
        o.receive(r);
        if r.nodes > 0 {
            touched.push((k, *r));
        }
        if let ObstacleOf::Object(k) = k {
            reactions[k].impulse_n_s += r.impulse_n_s;
            reactions[k].angular_impulse_n_m_s += r.angular_impulse_n_m_s;
            reactions[k].nodes += r.nodes;
        }
    }
    touched
}

/// The walls of the particle barrier ([`barrier`]) at time `time_s` among `colliders` and
/// `obstacles`, with which solid each is.
fn walls<'a>(
    colliders: &'a [Collider],
    time_s: f64,
    (obstacles, of): &'a (Vec<Obstacle<'a>>, Vec<ObstacleOf>),
) -> (Vec<Wall<'a>>, Vec<ObstacleOf>) {
    let mut walls = Vec::new();
    let mut which = Vec::new();
    for (c, collider) in colliders.iter().enumerate() {
        if collider.takes_barrier() && collider.is_active(time_s) {
            walls.push(Wall::Collider(collider, time_s));
            which.push(ObstacleOf::Collider(c));
        }
    }
    for (o, &solid) in obstacles.iter().zip(of) {
        if Wall::takes_obstacle(o) {
            walls.push(Wall::Obstacle(o));
            which.push(solid);
        }
    }
    (walls, which)
}

/// The energy the particle barrier holds in deformable `k` of `bodies` now, before a substep of
/// `dt_s` (J; [`barrier::energy_j`]).
pub(super) fn barrier_energy_j(env: &Env, bodies: &[Body], k: usize, dt_s: f32) -> f64 {
    let b = &bodies[k];
    let on = env.settings.surface_contact == SurfaceContact::Barrier;
    if !on || b.kind != ObjectKind::Deformable || b.particles.is_empty() {
        return 0.0;
    }
    let dx = b.dx_m();
    let solids = obstacles_near(env, bodies, &[], &b.particles, b.friction, dx);
    let (walls, _) = walls(env.colliders, env.time_s, &solids);
    barrier::energy_j(&b.particles, &b.materials, &walls, dx, dt_s)
}

/// Before P2G of `step`: pushes deformable `k`'s `particles` (cell `dx_m`) out of the
/// colliders and `solids` that meet it at its surface ([`barrier`]), adds the momentum this
/// takes to the solids' `reactions`, and returns the touches for the restitution law and
/// rolling resistance (deformable, solid, normal impulse the deformable received in N s).
pub(super) fn push_at_surfaces(
    step: Step<'_>,
    k: usize,
    particles: &mut Particles,
    materials: &[Material],
    dx_m: f32,
    solids: &(Vec<Obstacle<'_>>, Vec<ObstacleOf>),
    reactions: &mut [Reaction],
) -> Vec<Touch> {
    if !step.barrier {
        return Vec::new();
    }
    let (walls, which) = walls(step.colliders, step.time_s, solids);
    if walls.is_empty() {
        return Vec::new();
    }
    let motion = |p: &Particles| {
        let s = super::measure::measure(p, dx_m);
        let inverse_inertia = inverse_or_zero(s.inertia);
        barrier::Motion {
            mass_kg: s.mass_kg,
            com_m: s.com_m,
            velocity_m_s: s.velocity_m_s,
            omega_rad_s: inverse_inertia * s.angular_momentum,
            inverse_inertia,
        }
    };
    let r = barrier::push(particles, materials, &walls, dx_m, step.dt_s, motion);
    let mut touched = Vec::new();
    for (r, &solid) in r.iter().zip(&which) {
        if r.normal_impulse_n_s != DVec3::ZERO {
            touched.push(Touch::of(k, solid, r));
        }
        if let ObstacleOf::Object(s) = solid {
            reactions[s].impulse_n_s += r.impulse_n_s;
            reactions[s].angular_impulse_n_m_s += r.angular_impulse_n_m_s;
        }
    }
    touched
}

/// After G2P of `step`: puts back `particles` whose path crossed a thin collider or one of
/// `solids` ([`crossing`]), removes the velocity into the solids of those that lie inside them
/// ([`boundary::project_particles`]), and adds the momentum this takes to the solids'
/// `reactions`. Returns deformable `k`'s touches of the solids the crossings met, for the
/// restitution law: a plate thinner than a cell may hold no grid node, and these are then its
/// only touches. `dx_m` is the deformable's grid cell (m).
pub(super) fn project_out_of_solids(
    (step, k, dx_m): (Step<'_>, usize, f32),
    particles: &mut Particles,
    (obstacles, of): &(Vec<Obstacle<'_>>, Vec<ObstacleOf>),
    reactions: &mut [Reaction],
) -> Vec<Touch> {
    let end_s = step.time_s + step.dt_s as f64;
    let mut touched = Vec::new();
    let by_colliders =
        crossing::stop_collider_crossings(particles, step.colliders, end_s, step.dt_s, dx_m);
    for (c, j) in by_colliders.into_iter().enumerate() {
        if j != DVec3::ZERO {
            touched.push(Touch::collider(k, c, j, DVec3::ZERO));
        }
    }
    let crossed = crossing::stop_crossings(particles, obstacles, step.dt_s, dx_m);
    let projected = boundary::project_particles(particles, obstacles);
    for ((c, p), &solid) in crossed.iter().zip(&projected).zip(of) {
        if c.normal_impulse_n_s != DVec3::ZERO {
            touched.push(Touch::of(k, solid, c));
        }
        if let ObstacleOf::Object(s) = solid {
            reactions[s].impulse_n_s += c.impulse_n_s + p.impulse_n_s;
            reactions[s].angular_impulse_n_m_s += c.angular_impulse_n_m_s + p.angular_impulse_n_m_s;
        }
    }
    touched
}

/// Which solid an obstacle is.
pub(super) type ObstacleOf = super::impact::SolidOf;

/// A deformable object's contact with a solid in one substep, for the restitution law and
/// rolling resistance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Touch {
    /// The deformable object.
    pub(super) object: usize,
    /// The solid.
    pub(super) solid: ObstacleOf,
    /// The normal impulse the deformable received there (N s).
    pub(super) impulse_n_s: DVec3,
    /// Its moment about the solid's COM (N m s; zero at a grid collider, which has none).
    pub(super) moment_n_m_s: DVec3,
    /// The friction impulse the deformable received there (N s): the rest of its impulse, each
    /// node's or particle's less its part along the solid's normal there.
    pub(super) friction_n_s: DVec3,
}

impl Touch {
    /// Deformable `object`'s touch of `solid`, from the `reaction` the solid received: the
    /// deformable's normal impulse and its moment are the solid's reversed.
    pub(super) fn of(object: usize, solid: ObstacleOf, reaction: &Reaction) -> Self {
        Self {
            object,
            solid,
            impulse_n_s: -reaction.normal_impulse_n_s,
            moment_n_m_s: -reaction.normal_moment_n_m_s,
            friction_n_s: reaction.normal_impulse_n_s - reaction.impulse_n_s,
        }
    }

    /// Deformable `object`'s touch of grid collider `c` with normal impulse `impulse_n_s` and
    /// friction impulse `friction_n_s`.
    fn collider(object: usize, c: usize, impulse_n_s: DVec3, friction_n_s: DVec3) -> Self {
        Self {
            object,
            solid: ObstacleOf::Collider(c),
            impulse_n_s,
            moment_n_m_s: DVec3::ZERO,
            friction_n_s,
        }
    }
}

/// What the deformable objects' grids did to the solids in one substep: `reactions[k]` the
/// impulse and angular impulse solid k received, `touches` each contact of a deformable object
/// with a solid, for the restitution law and rolling resistance.
pub(super) struct GridContacts {
    pub(super) reactions: Vec<Reaction>,
    pub(super) touches: Vec<Touch>,
}

/// The solids of `bodies` and the background near `bounds` (m) as boundaries for a deformable
/// of friction `friction` on a grid of cell `dx_m` (m). An awake rigid solid is movable, at its
/// velocity plus what `received` (the reactions of deformable objects solved before this one in
/// the substep, by object) gave it: Gauss–Seidel over objects, so two objects pressing on one
/// light solid do not both push it as if alone.
fn obstacles<'a>(
    env: &Env<'a>,
    bodies: &'a [Body],
    received: &[Reaction],
    bounds: (Vec3A, Vec3A),
    friction: f32,
    dx_m: f32,
) -> (Vec<Obstacle<'a>>, Vec<ObstacleOf>) {
    let margin = 2.0 * env.dx_m().max(dx_m);
    let near = |b: (Vec3A, Vec3A)| {
        (bounds.0 - margin).cmple(b.1).all() && (b.0 - margin).cmple(bounds.1).all()
    };
    let mut out = Vec::new();
    let mut of = Vec::new();
    for (k, b) in bodies.iter().enumerate() {
        // `None` for objects of another island, too.
        let Some(placed) = env.placed(bodies, k) else {
            continue;
        };
        if !near(placed.bounds_m) {
            continue;
        }
        let moving = b.moves_rigidly();
        let mut obstacle = Obstacle {
            placed,
            velocity_m_s: if moving {
                b.rigid.velocity_m_s.as_vec3a()
            } else {
                Vec3A::ZERO
            },
            omega_rad_s: if moving {
                b.rigid.omega_rad_s.as_vec3a()
            } else {
                Vec3A::ZERO
            },
            friction: mix_friction(friction, b.friction),
            surface: b.surface,
            inverse_mass: 0.0,
            inverse_inertia: DMat3::ZERO,
            supports: &[],
        };
        if b.kind == ObjectKind::Rigid && !b.sleeping && b.rigid.mass_kg > 0.0 {
            obstacle.inverse_mass = 1.0 / b.rigid.mass_kg;
            obstacle.inverse_inertia = inverse_or_zero(b.rigid_world_inertia());
            obstacle.supports = &b.supports;
            if let Some(r) = received.get(k) {
                obstacle.receive(r);
            }
        }
        out.push(obstacle);
        of.push(ObstacleOf::Object(k));
    }
    if let Some(placed) = env.background.placed()
        && near(placed.bounds_m)
    {
        out.push(Obstacle {
            placed,
            velocity_m_s: Vec3A::ZERO,
            omega_rad_s: Vec3A::ZERO,
            friction: mix_friction(friction, env.background.friction),
            surface: crate::collider::Surface::Separate,
            inverse_mass: 0.0,
            inverse_inertia: DMat3::ZERO,
            supports: &[],
        });
        of.push(ObstacleOf::Background);
    }
    (out, of)
}

/// The solids near `particles` as boundaries for a deformable of friction `friction` on a grid
/// of cell `dx_m` (m), with which solid each is; none for no particles. Found once per substep:
/// the obstacles' margin (two cells) covers how far G2P then moves the particles.
pub(super) fn obstacles_near<'a>(
    env: &Env<'a>,
    bodies: &'a [Body],
    received: &[Reaction],
    particles: &Particles,
    friction: f32,
    dx_m: f32,
) -> (Vec<Obstacle<'a>>, Vec<ObstacleOf>) {
    if particles.is_empty() {
        return (Vec::new(), Vec::new());
    }
    obstacles(env, bodies, received, bounds(particles), friction, dx_m)
}

/// Whether deformable `k` of `bodies` may step on the device this substep (`device.rs`), and
/// over the next `travel_m` (m) of its motion: no box collider thinner than two of its cells,
/// no solid, background or other deformable object within reach of its particles.
pub(super) fn device_may_step(env: &Env, bodies: &[Body], k: usize, travel_m: f32) -> bool {
    let b = &bodies[k];
    let dx = b.dx_m();
    let barrier = env.settings.surface_contact == SurfaceContact::Barrier;
    if b.device_refused().is_some() || !device::colliders_allow(env.colliders, dx, barrier) {
        return false;
    }
    let s = b.measured_bounds();
    let travel = Vec3A::splat(travel_m);
    let (lo, hi) = (
        s.aabb_m.0.as_vec3a() - travel,
        s.aabb_m.1.as_vec3a() + travel,
    );
    if !obstacles(env, bodies, &[], (lo, hi), b.friction, dx)
        .0
        .is_empty()
    {
        return false;
    }
    // The pair law's broad phase reaches one cell; four leave room for a substep's motion.
    let alone = |(j, o): (usize, &Body)| {
        if j == k || o.kind != ObjectKind::Deformable || o.particles.is_empty() {
            return true;
        }
        let margin = 4.0 * f64::from(dx.max(o.dx_m())) + f64::from(travel_m);
        let t = o.measured_bounds();
        let m = glam::DVec3::splat(margin);
        !((s.aabb_m.0 - m).cmple(t.aabb_m.1).all() && (t.aabb_m.0 - m).cmple(s.aabb_m.1).all())
    };
    bodies.iter().enumerate().all(alone)
}

/// Deformable `k`'s substep on the device (`device.rs`) when `env` has one and its situation
/// allows: its collider touches, or `None` to step on the CPU (the device's copy, if any, is
/// then brought back).
pub(super) fn device_substep(
    env: &Env,
    bodies: &mut [Body],
    stats: &mut WorldStats,
    k: usize,
    dt_s: f32,
) -> Result<Option<Vec<Touch>>, WorldError> {
    // A substep the device already ran in a run (`device_run.rs`) is taken as it ran.
    if let Some(backend) = env.device
        && (bodies[k].replaying() || device_may_step(env, bodies, k, 0.0))
    {
        let started = std::time::Instant::now();
        let b = &mut bodies[k];
        let r = device::substep(
            backend,
            b,
            (env.colliders, env.gravity_m_s2),
            dt_s,
            env.time_s,
        );
        let report = r.map_err(|e| WorldError::Device {
            object: b.name.clone(),
            message: e.to_string(),
        })?;
        if let Some(report) = report {
            b.stats.mpm_wall_s += started.elapsed().as_secs_f64();
            stats.mpm_particle_substeps += b.particles.len() as u64;
            let j = (&report.impulses_n_s[..], &report.friction_n_s[..]);
            return Ok(Some(collider_touches(k, j, &report.nodes).collect()));
        }
    }
    bodies[k].leave_device();
    Ok(None)
}

/// Method `multi-field`: per-object P2G and grid update, multi-field contact at shared nodes,
/// the solids as boundaries, per-object G2P.
pub(super) fn multi_field(
    env: &Env,
    bodies: &mut [Body],
    stats: &mut WorldStats,
    dt_s: f32,
) -> Result<GridContacts, WorldError> {
    let dx_m = env.dx_m();
    let mut reactions = vec![Reaction::default(); bodies.len()];
    let mut touches = Vec::new();
    let step = Step::new(env, dt_s);
    for k in 0..bodies.len() {
        if !simulated(&bodies[k]) {
            bodies[k].stats.substeps_skipped += 1;
            continue;
        }
        if step.barrier {
            let mut particles = std::mem::take(&mut bodies[k].particles);
            let b = &bodies[k];
            let solids = obstacles_near(env, bodies, &reactions, &particles, b.friction, dx_m);
            let (materials, r) = (&b.materials, &mut reactions);
            let t = push_at_surfaces(step, k, &mut particles, materials, dx_m, &solids, r);
            touches.extend(t);
            drop(solids);
            bodies[k].particles = particles;
        }
        let b = &mut bodies[k];
        let input = step.input(&b.materials);
        if let Err(e) = b.solver.scatter_and_update(&b.particles, &input) {
            return Err(step.error(stats, &b.name, e));
        }
    }
    let mut fields: Vec<multi_field::Field<'_>> = bodies
        .iter_mut()
        .filter(|b| simulated(b))
        .map(|b| {
            let v_ref_m_s = b.solver.reference_velocity_m_s();
            multi_field::Field {
                grid: b.solver.grid_mut(),
                v_ref_m_s,
                friction: b.friction,
            }
        })
        .collect();
    let r = multi_field::couple(&mut fields, dx_m, step.colliders, step.time_s);
    drop(fields);
    stats.contact_nodes += r.corrected as u64;
    for k in 0..bodies.len() {
        if !simulated(&bodies[k]) {
            continue;
        }
        let b = &mut bodies[k];
        let mut solver = std::mem::replace(&mut b.solver, MpmSolver::new(dx_m));
        let friction = b.friction;
        let particles = std::mem::take(&mut b.particles);
        let mut solids = obstacles_near(env, bodies, &reactions, &particles, friction, dx_m);
        let t = apply_obstacles(
            (&mut solver, &particles, dt_s, step.barrier),
            &mut solids,
            &mut reactions,
        );
        touches.extend(t.iter().map(|(o, r)| Touch::of(k, *o, r)));
        let b = &mut bodies[k];
        b.solver = solver;
        b.particles = particles;
    }
    for k in 0..bodies.len() {
        if !simulated(&bodies[k]) {
            continue;
        }
        let b = &mut bodies[k];
        let r = b.solver.gather(&mut b.particles, &step.input(&b.materials));
        if r.is_ok() {
            let (friction, mut particles) = (b.friction, std::mem::take(&mut b.particles));
            let solids = obstacles_near(env, bodies, &reactions, &particles, friction, dx_m);
            let at = (step, k, bodies[k].solver.dx_m);
            let t = project_out_of_solids(at, &mut particles, &solids, &mut reactions);
            touches.extend(t);
            bodies[k].particles = particles;
        }
        step.finish(stats, &mut bodies[k], r)?;
    }
    // Each object's touches together (rolling resistance takes them object by object): the
    // passes above list all objects' barrier touches, then their grid's, then their crossings'.
    touches.sort_by_key(|t| t.object);
    Ok(GridContacts { reactions, touches })
}

/// Method `mpm`: every awake deformable object on one `shared` grid; each object's particles are
/// copied in, stepped together and copied back.
pub(super) fn shared_grid(
    env: &Env,
    bodies: &mut [Body],
    shared: &mut MpmSolver,
    stats: &mut WorldStats,
    dt_s: f32,
) -> Result<GridContacts, WorldError> {
    let mut reactions = vec![Reaction::default(); bodies.len()];
    let ids: Vec<usize> = (0..bodies.len())
        .filter(|&k| simulated(&bodies[k]))
        .collect();
    let mut all = Particles::default();
    let mut materials = Vec::new();
    let mut friction = 0.0f32;
    for &k in &ids {
        let b = &bodies[k];
        let start = all.len();
        all.extend_from(&b.particles);
        all.material[start..].fill(materials.len() as u16);
        materials.push(b.materials[0].clone());
        friction = friction.max(b.friction);
    }
    // The paper's shared grid keeps the grid rule at every surface.
    let step = Step {
        barrier: false,
        ..Step::new(env, dt_s)
    };
    let dx = env.dx_m();
    let r = shared.scatter_and_update(&all, &step.input(&materials));
    if r.is_ok() {
        // One grid for every object: no per-object impacts to follow.
        let mut solids = obstacles_near(env, bodies, &reactions, &all, friction, dx);
        let _ = apply_obstacles((shared, &all, dt_s, false), &mut solids, &mut reactions);
    }
    let r = r.and_then(|()| shared.gather(&mut all, &step.input(&materials)));
    let r = r.map_err(|e| step.error(stats, "shared grid", e))?;
    stats.mpm_particle_substeps += all.len() as u64;
    let mut start = 0;
    for &k in &ids {
        let b = &mut bodies[k];
        let end = start + b.particles.len();
        b.particles.x.copy_from_slice(&all.x[start..end]);
        b.particles.v.copy_from_slice(&all.v[start..end]);
        b.particles.c.copy_from_slice(&all.c[start..end]);
        b.particles.f.copy_from_slice(&all.f[start..end]);
        b.particles
            .f_plastic
            .copy_from_slice(&all.f_plastic[start..end]);
        b.particles
            .plastic
            .copy_from_slice(&all.plastic[start..end]);
        b.max_speed_m_s = r.max_speed_m_s;
        start = end;
    }
    Ok(GridContacts {
        reactions,
        touches: Vec::new(),
    })
}

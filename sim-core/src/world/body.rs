//! One object of the world: its particles (one per Gaussian, fill particles included, or a
//! voxel subset that carries the Gaussians along, [`super::carry`]), its material, its own MPM
//! grid, its rest state for the Gaussian kinematics, and its object-level state
//! ([`super::measure`]).
//!
//! A solid (rigid, static or kinematic object) is a rigid body: a pose (x, q), v, ω, mass and
//! body-frame inertia, with its Gaussians stored in the body frame and placed only when a frame
//! is published (μ = x + R μ_b, Σ = R Σ_b Rᵀ). It holds no live particles: they wait as a
//! body-frame template ([`Body::template`]) that becoming deformable places by the pose.

use glam::{DMat3, DVec3, Mat3A, Quat, Vec3A};

use super::WorldError;
use super::measure::{BodyState, inverse_or_zero, measure};
use crate::contact::{Collision, Geometry, LevelSet};
use crate::material::{ConstitutiveModel, Material};
use crate::mpm::{MpmSolver, Particles};
use crate::procedural::Shape;
use crate::scene::{ObjectKind, SceneObject};

/// Rigid-body state of a rigid object (its particles follow x = com + R r0, F = R).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidState {
    /// Orientation R relative to the rest pose.
    pub orientation: Quat,
    /// COM position (m).
    pub com_m: DVec3,
    /// COM velocity (m/s).
    pub velocity_m_s: DVec3,
    /// Angular velocity (rad/s).
    pub omega_rad_s: DVec3,
    /// Inertia about the COM in the rest pose (kg m²).
    pub inertia_rest: DMat3,
    /// Mass (kg).
    pub mass_kg: f64,
}

/// What one object did: counters of the run so far and accumulators of the current frame. Not
/// simulation state: nothing in a step reads them back.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyStats {
    /// Substeps skipped while asleep or static.
    pub substeps_skipped: u64,
    /// Substeps of its island it took part in (every substep of the world unless islands step
    /// separately, `islands.rs`), skipped ones included.
    pub substeps_taken: u64,
    /// Smallest and largest of those substeps (s); `[inf, 0]` before the first.
    pub dt_range_s: [f64; 2],
    /// Wall time its own MPM substeps took so far (s): a timing of this machine, not simulation
    /// state (method `com` only; zero for objects without MPM and under the shared-grid
    /// baselines).
    pub mpm_wall_s: f64,
    /// Contact impulses received, summed over the run (N s).
    pub impulse_total_n_s: f64,
    /// Contacts with other objects in the current frame (the last published one between frames).
    pub contacts: u32,
    /// Contact impulses a solid object received this frame, from the contact solver, deformable
    /// objects' grids and the restitution law (N s); over the frame time, its contact force.
    pub frame_impulse_n_s: DVec3,
    /// Their moment about the object's COM (N m s); over the frame time, its contact torque.
    pub frame_angular_impulse_n_m_s: DVec3,
}

impl Default for BodyStats {
    fn default() -> Self {
        Self {
            substeps_skipped: 0,
            substeps_taken: 0,
            dt_range_s: [f64::INFINITY, 0.0],
            mpm_wall_s: 0.0,
            impulse_total_n_s: 0.0,
            contacts: 0,
            frame_impulse_n_s: DVec3::ZERO,
            frame_angular_impulse_n_m_s: DVec3::ZERO,
        }
    }
}

impl BodyStats {
    /// Clears the accumulators of the current frame.
    pub(crate) fn begin_frame(&mut self) {
        self.contacts = 0;
        self.frame_impulse_n_s = DVec3::ZERO;
        self.frame_angular_impulse_n_m_s = DVec3::ZERO;
    }
}

/// A simulated or static object.
#[derive(Debug)]
pub struct Body {
    /// Name from the scene.
    pub(crate) name: String,
    /// Deformable, rigid, static or kinematic.
    pub(crate) kind: ObjectKind,
    /// Coefficient of restitution e in [0, 1].
    pub(crate) restitution: f32,
    /// Coulomb friction coefficient.
    pub(crate) friction: f32,
    /// Rolling resistance b (m): the couple against rolling is at most b times the normal force.
    pub(crate) rolling_resistance_m: f32,
    /// A deformable object's particles (world frame); `material` indexes `materials`. Empty for
    /// a solid, whose particles wait in [`Self::template`].
    pub(crate) particles: Particles,
    /// `[N]` a solid's particles in its body frame: x the offset from the COM in the rest pose
    /// (m), v = 0, F = I, C = 0, masses, volumes and plastic state as they were. Becoming
    /// deformable places them by the pose (filling an object is expensive, so they are kept).
    /// Empty for a deformable object.
    pub(crate) template: Particles,
    /// `[G]` a solid's Gaussian centres in its body frame: offsets from the COM in the rest pose
    /// (m). Empty for a deformable object.
    pub(crate) gaussian_offsets: Vec<Vec3A>,
    /// The object's material table (one entry).
    pub(crate) materials: Vec<Material>,
    /// Its own MPM grid.
    pub(crate) solver: MpmSolver,
    /// `[G]` the object's Gaussians (world frame at t = 0): SH, opacity, scales for publishing.
    pub(crate) gaussians: crate::gaussians::GaussianCloud,
    /// `[G]` rest covariance Σ0 of each Gaussian (m², world frame at t = 0).
    pub(crate) sigma0: Vec<Mat3A>,
    /// `[N]` a deformable object's particle offsets from the COM in its rest pose (m), for its
    /// best-fit orientation; empty for a solid (its [`Self::template`] holds them).
    pub(crate) rest_offsets: Vec<Vec3A>,
    /// The largest particle distance from the COM in the rest pose (m), computed with the rest
    /// offsets.
    rest_arm_m: f64,
    /// `[G]` whether each Gaussian is published (false for fill particles).
    pub(crate) visible: Vec<bool>,
    /// How the `[G]` Gaussians follow the `[N]` particles; `None`: G = N and each Gaussian is a
    /// particle, [`Self::gaussian_particle`] (no `physics_spacing_m`).
    pub(crate) carry: Option<super::carry::Carry>,
    /// `[G]` the particle that is Gaussian g when there is no carry (particles are stored in
    /// block order, Gaussians in the scene's, [`super::block_order`]); empty with a carry.
    pub(crate) gaussian_particle: Vec<u32>,
    /// Rigid state (kept for every body; used when `kind` is rigid).
    pub(crate) rigid: RigidState,
    /// Asleep: skips all work until woken.
    pub(crate) sleeping: bool,
    /// Object-level state of a static or sleeping object (it does not change until woken or
    /// edited); `None` while the object moves.
    pub(crate) state_cache: Option<BodyState>,
    /// Its copy on the device its MPM may run on (`world/device.rs`).
    pub(crate) device: super::device::DeviceSlot,
    /// Simulated time the body has been still (s).
    pub(crate) still_s: f64,
    /// Largest particle speed after the last substep (m/s).
    pub(crate) max_speed_m_s: f32,
    /// The boundary rule it imposes, as a static or rigid object, on deformable objects' grids.
    pub(crate) surface: crate::collider::Surface,
    /// Collision surface of a rigid or static object (`None` for a deformable one).
    pub(crate) collision: Option<Collision>,
    /// Cell of the collision surface when it is sampled from particles, m
    /// ([`crate::scene::SimulationSettings::collision_cell_m`]).
    pub(crate) collision_cell_m: f32,
    /// The contact solver's push-out pseudo-velocities (m/s, rad/s) for this substep.
    pub(crate) push: (DVec3, DVec3),
    /// Where a rigid object leaned on immovable solids in the last contact pass (`contact.rs`),
    /// for the deformable grids it meets two-way.
    pub(crate) supports: Vec<crate::contact::coupling::Support>,
    /// What moves a kinematic object (unused for other kinds).
    pub(crate) drive: super::kinematic::Drive,
    /// Counters of its run so far and of the current frame.
    pub(crate) stats: BodyStats,
}

crate::clone_reusing::clone_reusing!(Body {
    name,
    kind,
    restitution,
    friction,
    rolling_resistance_m,
    particles,
    template,
    gaussian_offsets,
    materials,
    solver,
    gaussians,
    sigma0,
    rest_offsets,
    rest_arm_m,
    visible,
    carry,
    gaussian_particle,
    rigid,
    sleeping,
    state_cache,
    device,
    still_s,
    max_speed_m_s,
    surface,
    collision,
    collision_cell_m,
    push,
    supports,
    drive,
    stats,
});

/// Most cells of an object's sampled surface before its cell size grows.
pub const MAX_SURFACE_CELLS: usize = 8_000_000;

impl Body {
    /// Builds the body of scene object `object`, number `index` in the scene (the particles'
    /// object id), on a grid of cell size `dx_m` (m): its particles (one per Gaussian, or the
    /// voxel subset of [`super::carry::physics_particles`]) at the object's initial velocity,
    /// with masses from its material's density; its rest covariances; its rigid pose. A static
    /// object starts, and stays, at rest.
    ///
    /// # Errors
    /// [`WorldError::Material`] when the object's material is refused.
    pub(crate) fn from_object(
        object: &SceneObject,
        index: u32,
        dx_m: f32,
        collision_cell_m: f32,
    ) -> Result<Body, WorldError> {
        let o = object;
        let material = Material::from_spec(&o.material).map_err(|source| WorldError::Material {
            object: o.name.clone(),
            source,
        })?;
        let g = &o.gaussians;
        let x: Vec<Vec3A> = g.positions.iter().map(|p| Vec3A::from(*p)).collect();
        let (phys, gaussian_particle) =
            super::carry::physics_particles(&x, dx_m, o.physics_spacing_m).into_block_order(dx_m);
        let rho = material.density_kg_m3();
        let mut particles = Particles::default();
        let v0 = Vec3A::from(o.velocity_m_s);
        for (xi, vol) in phys.x.iter().zip(&phys.volume_m3) {
            particles.push(
                *xi,
                v0,
                rho * vol,
                *vol,
                0,
                index,
                material.initial_plastic_state(),
            );
        }
        let sigma0 = (0..g.len()).map(|i| Mat3A::from(g.covariance(i))).collect();
        let mut body = Body {
            name: o.name.clone(),
            kind: o.kind,
            restitution: o.restitution.clamp(0.0, 1.0),
            friction: o.friction.max(0.0),
            rolling_resistance_m: o.rolling_resistance_m.max(0.0),
            particles,
            template: Particles::default(),
            gaussian_offsets: Vec::new(),
            materials: vec![material],
            solver: MpmSolver::new(dx_m),
            gaussians: g.clone(),
            sigma0,
            rest_offsets: Vec::new(),
            rest_arm_m: 0.0,
            visible: if o.visible.len() == g.len() {
                o.visible.clone()
            } else {
                vec![true; g.len()]
            },
            carry: phys.carry,
            gaussian_particle,
            rigid: RigidState {
                orientation: Quat::IDENTITY,
                com_m: DVec3::ZERO,
                velocity_m_s: DVec3::ZERO,
                omega_rad_s: DVec3::ZERO,
                inertia_rest: DMat3::ZERO,
                mass_kg: 0.0,
            },
            sleeping: false,
            state_cache: None,
            device: super::device::DeviceSlot::default(),
            still_s: 0.0,
            max_speed_m_s: v0.length(),
            stats: BodyStats::default(),
            surface: o.surface,
            collision: None,
            collision_cell_m,
            push: (DVec3::ZERO, DVec3::ZERO),
            supports: Vec::new(),
            drive: Default::default(),
        };
        body.capture_rigid_pose();
        if o.kind != ObjectKind::Deformable {
            body.build_collision(o.shape, o.shape_rotation);
            body.freeze();
        }
        if o.kind == ObjectKind::Static {
            body.rigid.velocity_m_s = DVec3::ZERO;
            body.rigid.omega_rad_s = DVec3::ZERO;
            body.max_speed_m_s = 0.0;
        }
        Ok(body)
    }

    /// The cell of its own MPM grid (m).
    pub fn dx_m(&self) -> f32 {
        self.solver.dx_m
    }

    /// Name from the scene.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Deformable, rigid, static or kinematic.
    pub fn kind(&self) -> ObjectKind {
        self.kind
    }

    /// Coefficient of restitution e in [0, 1].
    pub fn restitution(&self) -> f32 {
        self.restitution
    }

    /// Coulomb friction coefficient μ.
    pub fn friction(&self) -> f32 {
        self.friction
    }

    /// Rolling resistance b (m): the couple against rolling is at most b times the normal force.
    pub fn rolling_resistance_m(&self) -> f32 {
        self.rolling_resistance_m
    }

    /// The boundary rule it imposes, as a solid, on deformable objects' grids.
    pub fn surface(&self) -> crate::collider::Surface {
        self.surface
    }

    /// Its material.
    pub fn material(&self) -> &Material {
        &self.materials[0]
    }

    /// `[N]` a deformable object's particles (world frame); empty for a solid, whose particles
    /// wait in [`Self::template`] (see [`Self::particle_positions`] for either).
    pub fn particles(&self) -> &Particles {
        &self.particles
    }

    /// `[N]` a deformable object's particles, to edit (positions, velocities, F, C). What is
    /// written here is what the next substep starts from: keep it finite (NaN is refused only
    /// at the command boundary, not here) and call nothing but tests and tools with it.
    pub fn particles_mut(&mut self) -> &mut Particles {
        self.leave_device();
        &mut self.particles
    }

    /// `[G]` the rest covariance Σ0 of each Gaussian (m², world frame at t = 0).
    pub fn sigma0(&self) -> &[Mat3A] {
        &self.sigma0
    }

    /// `[G]` a solid's Gaussian centres in its body frame: offsets from the COM in the rest pose
    /// (m); empty for a deformable object.
    pub fn gaussian_offsets(&self) -> &[Vec3A] {
        &self.gaussian_offsets
    }

    /// `[N]` a solid's particles in its body frame: x the offset from the COM in the rest pose
    /// (m), v = 0, F = I, C = 0; empty for a deformable object.
    pub fn template(&self) -> &Particles {
        &self.template
    }

    /// `[G]` the object's Gaussians as loaded (world frame at t = 0): SH, opacity, scales.
    pub fn gaussians(&self) -> &crate::gaussians::GaussianCloud {
        &self.gaussians
    }

    /// `[G]` whether each Gaussian is published (false for fill particles).
    pub fn visible(&self) -> &[bool] {
        &self.visible
    }

    /// How the `[G]` Gaussians follow the `[N]` particles; `None`: each Gaussian is a particle,
    /// [`Self::gaussian_particle`].
    pub fn carry(&self) -> Option<&super::carry::Carry> {
        self.carry.as_ref()
    }

    /// `[G]` the particle that is Gaussian g when there is no carry (particles are stored in
    /// block order, Gaussians in the scene's); empty with a carry.
    pub fn gaussian_particle(&self) -> &[u32] {
        &self.gaussian_particle
    }

    /// The rigid pose and velocities (kept for every body; current for a solid).
    pub fn rigid(&self) -> &RigidState {
        &self.rigid
    }

    /// Asleep: it skips all work until woken.
    pub fn is_sleeping(&self) -> bool {
        self.sleeping
    }

    /// Largest particle speed after the last substep (m/s).
    pub fn max_speed_m_s(&self) -> f32 {
        self.max_speed_m_s
    }

    /// Collision surface of a solid (`None` for a deformable object).
    pub fn collision(&self) -> Option<&Collision> {
        self.collision.as_ref()
    }

    /// Counters of its run so far and of the current frame.
    pub fn stats(&self) -> &BodyStats {
        &self.stats
    }

    /// Counts a substep of `dt_s` (s) it took part in.
    pub(crate) fn count_substep(&mut self, dt_s: f64) {
        self.stats.substeps_taken += 1;
        self.stats.dt_range_s = [
            self.stats.dt_range_s[0].min(dt_s),
            self.stats.dt_range_s[1].max(dt_s),
        ];
    }

    /// Whether the body moves at all this substep.
    pub fn is_active(&self) -> bool {
        !self.sleeping && self.kind != ObjectKind::Static
    }

    /// Whether contacts cannot move it: a static or kinematic object.
    pub fn is_immovable(&self) -> bool {
        matches!(self.kind, ObjectKind::Static | ObjectKind::Kinematic)
    }

    /// Whether it moves as a rigid body this substep: an awake rigid or a kinematic object.
    pub fn moves_rigidly(&self) -> bool {
        (self.kind == ObjectKind::Rigid && !self.sleeping) || self.kind == ObjectKind::Kinematic
    }

    /// Inverse mass (1/kg): zero for static and kinematic objects.
    pub(crate) fn inverse_mass(&self, state: &BodyState) -> f64 {
        if self.is_immovable() || state.mass_kg <= 0.0 {
            0.0
        } else {
            1.0 / state.mass_kg
        }
    }

    /// Inverse inertia about the COM (1/(kg m²)): zero for static and kinematic objects.
    pub(crate) fn inverse_inertia(&self, state: &BodyState) -> DMat3 {
        if self.is_immovable() {
            DMat3::ZERO
        } else {
            inverse_or_zero(state.inertia)
        }
    }

    /// Re-derives the rigid state from the particles (on creation or when the kind changes).
    pub(crate) fn capture_rigid_pose(&mut self) {
        let s = measure(&self.particles, self.solver.dx_m);
        let com = s.com_m.as_vec3a();
        self.rest_offsets = self.particles.x.iter().map(|x| *x - com).collect();
        self.rest_arm_m = self
            .rest_offsets
            .iter()
            .map(|r| r.length())
            .fold(0.0f32, f32::max) as f64;
        self.rigid = RigidState {
            orientation: Quat::IDENTITY,
            com_m: s.com_m,
            velocity_m_s: s.velocity_m_s,
            omega_rad_s: s.angular_velocity(),
            inertia_rest: s.inertia,
            mass_kg: s.mass_kg,
        };
        // The rigid pose restarts from the current shape: its deformation becomes the rest shape.
        match &mut self.carry {
            Some(carry) => {
                carry.rebase(&self.particles, &mut self.sigma0);
            }
            None => {
                for (s0, &j) in self.sigma0.iter_mut().zip(&self.gaussian_particle) {
                    let j = j as usize;
                    let f = self.particles.f[j] * self.particles.f_plastic[j];
                    *s0 = f * *s0 * f.transpose();
                }
            }
        }
        let p = &mut self.particles;
        p.f.iter_mut().for_each(|f| *f = Mat3A::IDENTITY);
        p.f_plastic.iter_mut().for_each(|f| *f = Mat3A::IDENTITY);
        self.particles.c.iter_mut().for_each(|c| *c = Mat3A::ZERO);
    }

    /// Whether it is a solid whose particles wait in its template ([`Body::freeze`]).
    #[inline]
    pub(crate) fn is_frozen(&self) -> bool {
        !self.template.is_empty()
    }

    /// Makes a solid of it (call after [`Self::capture_rigid_pose`]): its Gaussians' centres go
    /// into the body frame ([`Self::gaussian_offsets`]), its particles into the
    /// [`Self::template`], and it keeps no live particles.
    pub(crate) fn freeze(&mut self) {
        if self.is_frozen() || self.particles.is_empty() {
            return; // frozen already, or nothing to freeze
        }
        let com = self.rigid.com_m.as_vec3a();
        self.gaussian_offsets = (0..self.gaussian_count())
            .map(|g| self.gaussian_pose(g).0 - com)
            .collect();
        let mut t = std::mem::take(&mut self.particles);
        t.x = std::mem::take(&mut self.rest_offsets);
        t.v.iter_mut().for_each(|v| *v = Vec3A::ZERO);
        t.c.iter_mut().for_each(|c| *c = Mat3A::ZERO);
        t.f.iter_mut().for_each(|f| *f = Mat3A::IDENTITY);
        t.f_plastic.iter_mut().for_each(|f| *f = Mat3A::IDENTITY);
        self.template = t;
    }

    /// Makes a deformable object of a solid: places its [`Self::template`] by the pose,
    /// x = com + R r0, v = v + ω × R r0, F = R, C = `[ω]×` (a rigid motion as an APIC velocity
    /// field), and drops the body-frame Gaussians (the particles carry them again).
    pub(crate) fn thaw(&mut self) {
        if !self.is_frozen() {
            return;
        }
        let r = Mat3A::from_quat(self.rigid.orientation);
        let com = self.rigid.com_m.as_vec3a();
        let v = self.rigid.velocity_m_s.as_vec3a();
        let w = self.rigid.omega_rad_s.as_vec3a();
        let skew = Mat3A::from_cols(
            Vec3A::new(0.0, w.z, -w.y),
            Vec3A::new(-w.z, 0.0, w.x),
            Vec3A::new(w.y, -w.x, 0.0),
        );
        let mut p = std::mem::take(&mut self.template);
        self.rest_offsets.clone_from(&p.x);
        for i in 0..p.len() {
            let off = r * p.x[i];
            p.x[i] = com + off;
            p.v[i] = v + w.cross(off);
            p.f[i] = r;
            p.c[i] = skew;
        }
        self.max_speed_m_s = p.v.iter().map(|v| v.length()).fold(0.0, f32::max);
        self.particles = p;
        self.gaussian_offsets = Vec::new();
    }

    /// The object-level state: measured from the particles of a deformable object, read from
    /// the pose of a solid (its aabb the collision surface's box in place, or the sphere of its
    /// arm without one).
    pub fn state(&self) -> BodyState {
        if self.kind == ObjectKind::Deformable {
            return measure(&self.particles, self.dx_m());
        }
        let rs = &self.rigid;
        let inertia = self.rigid_world_inertia();
        let radius_m = self.rest_arm_m + self.dx_m() as f64 / 2.0;
        let aabb_m = match &self.collision {
            Some(c) => {
                let (lo, hi) = c.placed(rs.com_m, rs.orientation).bounds_m;
                (lo.as_dvec3(), hi.as_dvec3())
            }
            None => (rs.com_m - radius_m, rs.com_m + radius_m),
        };
        BodyState {
            mass_kg: rs.mass_kg,
            com_m: rs.com_m,
            velocity_m_s: rs.velocity_m_s,
            angular_momentum: inertia * rs.omega_rad_s,
            inertia,
            radius_m,
            aabb_m,
        }
    }

    /// Every particle's position now (m), world frame: a deformable object's particles, or a
    /// solid's template placed by its pose.
    pub fn particle_positions(&self) -> Vec<Vec3A> {
        if !self.is_frozen() {
            return self.particles.x.clone();
        }
        let r = Mat3A::from_quat(self.rigid.orientation);
        let com = self.rigid.com_m.as_vec3a();
        self.template.x.iter().map(|x| com + r * *x).collect()
    }

    /// Builds the collision surface in the current rest frame (call after
    /// [`Self::capture_rigid_pose`] and before [`Self::freeze`]): `shape`'s exact surface turned
    /// by `rotation` about its centre, or a level set of the particles with cells of
    /// `collision_cell_m`.
    pub(crate) fn build_collision(&mut self, shape: Option<Shape>, rotation: Quat) {
        let dx = self.collision_cell_m;
        let geometry = match shape {
            Some(shape) if rotation == Quat::IDENTITY => Geometry::Analytic(shape),
            Some(shape) => Geometry::Turned { shape, rotation },
            None => match LevelSet::from_points(&self.particles.x, dx, MAX_SURFACE_CELLS) {
                Some(ls) => Geometry::Sampled(ls),
                None => {
                    self.collision = None;
                    return;
                }
            },
        };
        self.collision = Some(Collision::new(geometry, dx, self.rigid.com_m.as_vec3a()));
    }

    /// The largest distance of a particle from the COM in the rest pose (m): the lever arm that
    /// turns ω into the fastest particle speed.
    pub fn arm_m(&self) -> f64 {
        self.rest_arm_m
    }

    /// Gives rigid body impulse `j` (N s) at `point` (m).
    pub(crate) fn apply_rigid_impulse(&mut self, j: DVec3, point: DVec3) {
        let inv_i = inverse_or_zero(self.rigid_world_inertia());
        let rs = &mut self.rigid;
        rs.velocity_m_s += j / rs.mass_kg.max(f64::MIN_POSITIVE);
        rs.omega_rad_s += inv_i * (point - rs.com_m).cross(j);
        self.stats.impulse_total_n_s += j.length();
    }

    /// The fastest speed of a point of the rigid state (m/s): |v| + |ω| times [`Self::arm_m`].
    pub fn rigid_speed_m_s(&self) -> f32 {
        (self.rigid.velocity_m_s.length() + self.rigid.omega_rad_s.length() * self.rest_arm_m)
            as f32
    }

    /// World inertia of the rigid state, R I0 Rᵀ.
    pub fn rigid_world_inertia(&self) -> DMat3 {
        let r = DMat3::from_quat(self.rigid.orientation.as_dquat());
        r * self.rigid.inertia_rest * r.transpose()
    }
}

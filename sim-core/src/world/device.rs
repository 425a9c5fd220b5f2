//! A deformable object's MPM on a device (a GPU) under method `com`: the interface a backend
//! implements ([`DeviceBackend`], [`DeviceMpm`]; `splatphys-gpu` is the one there is, given to
//! the world with [`World::set_device`]), and where an object's particles live from substep to
//! substep.
//!
//! An object steps on the device while nothing but grid colliders can reach it: no solid object
//! and no captured background within two cells of its particles (they are level-set boundaries
//! on its grid, `contact/boundary.rs`), no other deformable object within reach (the impulse law
//! of deformable pairs needs its particles' surface every substep) and no box collider thinner
//! than two cells (the particles' crossing check, `contact/crossing.rs`, runs on the CPU). Its
//! particles then stay on the device; what the COM layer needs crosses back each substep in one
//! small read-back ([`DeviceReport`]): the object's moments ([`BodyState`] and its largest
//! speed) and each collider's normal impulse and nodes (the restitution law's touches). While
//! it is all that moves, a run of substeps shares one read-back (`device_run.rs`). The
//! restitution law and rolling resistance change the object by a rigid field (v += δv + δω × r,
//! C += \[δω\]×), applied on the device. Everything else (publishing, commands and events, sleep, another object coming
//! near) first brings the particles back (`Body::leave_device`): at the end of every frame
//! they are copied back, and the next substep on the device reuses its copy unless the host's
//! changed.
//!
//! The CFL bound reads the object's plastic state (snow's hardening raises its wave speed) from
//! the report too: its smallest plastic scalar.

use std::fmt;

use glam::{DVec3, Vec3A};

use super::body::Body;
use super::measure::{BodyState, measure, measure_bounds};
use super::{World, WorldError};
use crate::collider::{Collider, Shape};
use crate::material::Material;
use crate::mpm::{MpmSystem, Particles};

/// What a device backend reported, in words.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DeviceError {
    /// The backend does not run this object (a model, layout or size it lacks); it stays on
    /// the CPU.
    #[error("not on the device: {0}")]
    Unsupported(String),
    /// The device failed (a substep, a read-back).
    #[error("{0}")]
    Failed(String),
}

/// A device that runs deformable objects' MPM (a GPU through `splatphys-gpu`).
pub trait DeviceBackend: Send + Sync + fmt::Debug {
    /// The device's name, e.g. `"NVIDIA H100 (Vulkan)"`.
    fn name(&self) -> String;

    /// Uploads `system` (particles, materials, grid colliders, gravity, the cell of its solver
    /// and its clock) onto a grid over `extent_m` (min, max corners in m; a domain bound among
    /// the colliders bounds it instead).
    ///
    /// # Errors
    /// [`DeviceError::Unsupported`] for what the device does not run,
    /// [`DeviceError::Failed`].
    fn upload(
        &self,
        system: &MpmSystem,
        extent_m: (Vec3A, Vec3A),
    ) -> Result<Box<dyn DeviceMpm>, DeviceError>;
}

/// One object's particles on a device.
pub trait DeviceMpm: Send + Sync + fmt::Debug {
    /// Replaces the particles' state with `particles` (the same count and order as uploaded).
    ///
    /// # Errors
    /// [`DeviceError::Failed`] for another count.
    fn write_particles(&mut self, particles: &Particles) -> Result<(), DeviceError>;

    /// One substep of `dt_s` (s) starting at simulated time `time_s` (s): P2G, the grid update
    /// with the colliders, G2P with the return mappings; then what the COM layer takes back,
    /// summed about `reference_m` (a point near the COM). Waits for the device once.
    ///
    /// # Errors
    /// [`DeviceError::Failed`] when a particle left the grid or a value was not finite.
    fn substep(
        &mut self,
        dt_s: f32,
        time_s: f64,
        reference_m: Vec3A,
    ) -> Result<DeviceReport, DeviceError>;

    /// The object's state (mass, COM, velocity, angular momentum, inertia, bounds) and its
    /// largest particle speed (m/s), summed about `reference_m` (a point near the COM).
    ///
    /// # Errors
    /// [`DeviceError::Failed`].
    fn moments(&mut self, reference_m: Vec3A) -> Result<(BodyState, f32), DeviceError>;

    /// Moves its grid to cover `extent_m` (min, max corners in m) without a new upload; `false`
    /// when the extent does not fit in the grid uploaded.
    fn recentre(&mut self, extent_m: (Vec3A, Vec3A)) -> bool;

    /// Lays its grid out anew over `extent_m` (min, max corners in m), keeping the particles
    /// on the device; `false` when it cannot (the object is then uploaded again whole).
    fn regrid(&mut self, _extent_m: (Vec3A, Vec3A)) -> bool {
        false
    }

    /// v += `dv` + `dw` × (x − `about`), C += \[`dw`\]× on every particle (m/s, rad/s, m).
    fn rigid_field(&mut self, dv: Vec3A, dw: Vec3A, about: Vec3A);

    /// Copies positions, velocities, C, F, F_p and the plastic state back into `into` (the
    /// uploaded count and order).
    ///
    /// # Errors
    /// [`DeviceError::Failed`].
    fn read_particles(&mut self, into: &mut Particles) -> Result<(), DeviceError>;

    /// Up to `plan.substeps` substeps of `plan.dt_s` in one submission and one wait, the device
    /// halting after the first one whose end the host must see ([`RunPlan`]); `None` when it
    /// does not run them (the caller then takes one substep at a time).
    ///
    /// # Errors
    /// [`DeviceError::Failed`] when a particle left the grid or a value was not finite.
    fn run(&mut self, _plan: &RunPlan) -> Result<Option<DeviceRun>, DeviceError> {
        Ok(None)
    }
}

/// A run of substeps of one object on the device (`world/device_run.rs`): what the host decided
/// before it, and when the device halts it. A substep whose end the host must see (a collider
/// contact opening or closing, a speed or plastic state past what the substep's CFL bound
/// assumed) ends the run: the substeps after it do nothing.
#[derive(Debug, Clone, PartialEq)]
pub struct RunPlan {
    /// Substeps at most.
    pub substeps: u32,
    /// Every substep's length (s).
    pub dt_s: f32,
    /// Simulated time at the run's start (s).
    pub time_s: f64,
    /// The point the run's report is summed about (m), near the COM.
    pub reference_m: Vec3A,
    /// Halt after a substep in which a particle ends faster than this (m/s): dt is within the
    /// CFL bound up to this speed.
    pub speed_limit_m_s: f32,
    /// Halt after a substep in which snow's Jp falls below this (the CFL wave speed grows as
    /// Jp falls).
    pub plastic_floor: f32,
    /// Per grid collider: whether the object's impact there is open (halt after the first
    /// substep that does not touch it), else halt after the first substep whose normal
    /// impulse there exceeds [`RunPlan::opens_at_n_s`] (an impact opens).
    pub open: Vec<bool>,
    /// See [`RunPlan::open`] (N s).
    pub opens_at_n_s: f64,
    /// Halt after any substep touching a collider (rolling resistance acts at every touch).
    pub halt_on_touch: bool,
}

/// One substep of a run as the device logged it.
#[derive(Debug, Clone, PartialEq)]
pub struct RunStep {
    /// The largest particle speed at its end (m/s).
    pub max_speed_m_s: f32,
    /// Each grid collider's normal impulse on the object in it (N s).
    pub impulses_n_s: Vec<DVec3>,
    /// Each grid collider's friction impulse on the object in it (N s; empty: none reported).
    pub friction_n_s: Vec<DVec3>,
    /// Each grid collider's nodes with mass inside it.
    pub nodes: Vec<u64>,
}

/// What a run reports: each substep that ran, and the full report of the last.
#[derive(Debug, Clone, PartialEq)]
pub struct DeviceRun {
    /// The substeps that ran, in order (at least one).
    pub steps: Vec<RunStep>,
    /// After the last of them.
    pub report: DeviceReport,
}

/// What the COM layer takes back after an object's substep on the device.
#[derive(Debug, Clone, PartialEq)]
pub struct DeviceReport {
    /// The object's state (mass, COM, velocity, angular momentum, inertia, bounds).
    pub state: BodyState,
    /// Its largest particle speed (m/s).
    pub max_speed_m_s: f32,
    /// The smallest plastic scalar of its particles (snow's Jp, which sets its CFL wave speed:
    /// `ConstitutiveModel::wave_speed_for_m_s`).
    pub min_plastic: f32,
    /// Each grid collider's normal impulse on it in the substep (N s), in order
    /// (`MpmSolver::collider_impulses_n_s` on the CPU).
    pub impulses_n_s: Vec<DVec3>,
    /// Each grid collider's friction impulse on it in the substep (N s), in order
    /// (`MpmSolver::collider_friction_n_s` on the CPU; empty: none reported, and the
    /// restitution law then leaves the impact's friction as the grid gave it).
    pub friction_n_s: Vec<DVec3>,
    /// Each grid collider's nodes with mass inside it (`MpmSolver::collider_nodes`).
    pub nodes: Vec<u64>,
}

/// Where an object's current particles are.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
enum Residence {
    /// Only on the host (the device's copy, if any, is stale).
    #[default]
    Host,
    /// Only on the device (the host's copy is stale).
    Device,
    /// The same on both.
    Both,
}

/// What an upload depends on besides the particles' state: another value needs a new upload.
#[derive(Debug, Clone, PartialEq)]
struct Uploaded {
    particles: usize,
    dx_m: f32,
    materials: Vec<Material>,
    gravity_m_s2: Vec3A,
    colliders: usize,
}

impl Uploaded {
    /// Whether body `b` under `gravity_m_s2` among `colliders` is what was uploaded (compared
    /// in place: this runs every substep).
    fn matches(&self, b: &Body, gravity_m_s2: Vec3A, colliders: &[Collider]) -> bool {
        self.particles == b.particles.len()
            && self.dx_m == b.dx_m()
            && self.materials == b.materials
            && self.gravity_m_s2 == gravity_m_s2
            && self.colliders == colliders.len()
    }
}

/// An object's copy on the device, if it has one. A clone (a checkpoint, a reset) has none: its
/// particles are the host's.
#[derive(Default)]
pub(crate) struct DeviceSlot {
    mpm: Option<Box<dyn DeviceMpm>>,
    at: Residence,
    /// The object's state from the device's last moments, while its particles are there.
    state: Option<BodyState>,
    /// The smallest plastic scalar from the device's last report.
    min_plastic: f32,
    /// The device grid's extent (m).
    extent_m: (Vec3A, Vec3A),
    uploaded: Option<Uploaded>,
    /// Why the backend does not run this object (it stays on the CPU).
    refused: Option<String>,
    /// A device failure outside a substep (a read-back), reported at the substep's end.
    failed: Option<String>,
    /// Substeps it ran on the device.
    pub(crate) substeps: u64,
    /// Uploads to the device (the first, and each for a changed material, particle count,
    /// gravity or colliders, or a grid the device could not lay out anew).
    uploads: u64,
    /// Grids laid out anew around particles that outgrew theirs, the particles staying on the
    /// device.
    regrids: u64,
    /// A substep the device already ran in a run, which the next substep takes instead of
    /// running one (`world/device_run.rs`).
    replay: Option<DeviceReport>,
    /// Runs of substeps in one submission, and the substeps they took.
    runs: u64,
    run_substeps: u64,
}

impl Clone for DeviceSlot {
    fn clone(&self) -> Self {
        Self {
            refused: self.refused.clone(),
            ..Self::default()
        }
    }
}

impl fmt::Debug for DeviceSlot {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("DeviceSlot")
            .field("uploaded", &self.mpm.is_some())
            .field("at", &self.at)
            .field("refused", &self.refused)
            .finish_non_exhaustive()
    }
}

impl Body {
    /// Whether its current particles are on the device only.
    pub(crate) fn on_device(&self) -> bool {
        self.device.at == Residence::Device
    }

    /// Its state with bounds as its particles are now: the device's last moments while they are
    /// there, else measured from the host's particles.
    pub(crate) fn measured_bounds(&self) -> BodyState {
        match self.device.state {
            Some(s) if self.on_device() => s,
            _ => measure_bounds(&self.particles, self.dx_m()),
        }
    }

    /// Its whole state (angular momentum and inertia too, [`measure`]) as its particles are now:
    /// the device's last moments (which have bounds as well) while they are there.
    pub(crate) fn measured(&self) -> BodyState {
        match self.device.state {
            Some(s) if self.on_device() => s,
            _ => measure(&self.particles, self.dx_m()),
        }
    }

    /// The plastic state its CFL wave speed reads (`ConstitutiveModel::wave_speed_for_m_s`):
    /// the device's smallest value while the particles are there, else the host's.
    pub(crate) fn plastic_for_cfl(&self) -> &[f32] {
        if self.on_device() && self.device.state.is_some() {
            std::slice::from_ref(&self.device.min_plastic)
        } else {
            &self.particles.plastic
        }
    }

    /// Copies its particles back from the device if only the device has them; the device's copy
    /// stays current. A failure is kept for [`World::substep`] to report.
    pub(crate) fn sync_host(&mut self) {
        if !self.on_device() {
            return;
        }
        let Some(mpm) = self.device.mpm.as_mut() else {
            return;
        };
        match mpm.read_particles(&mut self.particles) {
            Ok(()) => self.device.at = Residence::Both,
            Err(e) => self.device.failed = Some(e.to_string()),
        }
    }

    /// Its host particles are about to change: brings them back ([`Body::sync_host`]), and the
    /// device's copy is stale from here.
    pub(crate) fn leave_device(&mut self) {
        self.sync_host();
        if self.device.failed.is_none() {
            self.device.at = Residence::Host;
            self.device.state = None;
        }
    }

    /// v += `dv` + `dw` × (x − `about`), C += \[`dw`\]× on its particles on the device (m/s,
    /// rad/s, m), and the state and largest speed measured again. Only while the particles are
    /// on the device ([`Body::on_device`]).
    pub(crate) fn device_rigid_field(&mut self, dv: DVec3, dw: DVec3, about: DVec3) {
        let Some(mpm) = self.device.mpm.as_mut() else {
            return;
        };
        mpm.rigid_field(dv.as_vec3a(), dw.as_vec3a(), about.as_vec3a());
        let reference = self.device.state.map_or(about, |s| s.com_m).as_vec3a();
        match mpm.moments(reference) {
            Ok((state, speed)) => {
                self.device.state = Some(state);
                self.max_speed_m_s = speed;
            }
            Err(e) => self.device.failed = Some(e.to_string()),
        }
    }

    /// Why the device backend does not run it, once it refused.
    pub fn device_refused(&self) -> Option<&str> {
        self.device.refused.as_deref()
    }

    /// Substeps its MPM ran on the device.
    pub fn device_substeps(&self) -> u64 {
        self.device.substeps
    }

    /// Times its particles were uploaded to the device whole (a changed material, particle
    /// count or gravity, or a new grid the device could not lay out in place; not the copies
    /// written back after a command).
    pub fn device_uploads(&self) -> u64 {
        self.device.uploads
    }

    /// Times its grid on the device was laid out anew around particles that outgrew it, the
    /// particles staying there ([`DeviceMpm::regrid`]).
    pub fn device_regrids(&self) -> u64 {
        self.device.regrids
    }
}

/// Whether `colliders` allow an object of cell `dx_m` to step on the device: every box is at
/// least two cells thick (a thinner one needs the particles' crossing check) and, with `barrier`
/// (`[simulation] surface_contact = "barrier"`), none meets the material through the particle
/// barrier (`contact::barrier`, host only).
pub(super) fn colliders_allow(colliders: &[Collider], dx_m: f32, barrier: bool) -> bool {
    colliders.iter().all(|c| {
        let thick = match c.shape {
            Shape::Box(b) => (b.max_m - b.min_m).min_element() >= 2.0 * dx_m,
            _ => true,
        };
        // The particle barrier at "separate" surfaces runs on the host only.
        thick && !(barrier && c.takes_barrier())
    })
}

/// Cells of margin the device grid keeps around an object's particles when it is laid out; it
/// moves ([`DeviceMpm::recentre`]) when they come within [`EDGE_CELLS`] of its edge (a particle
/// moves less than a cell per substep), and a new one is uploaded only when they no longer fit.
const MARGIN_CELLS: f32 = 8.0;
/// See [`MARGIN_CELLS`].
const EDGE_CELLS: f32 = 4.0;

/// Body `b`'s particles on `backend` for a substep at `time_s` among `colliders` under
/// `gravity_m_s2`: uploaded, or its copy there reused. `Ok(false)` when the backend refuses it.
fn prepare(
    backend: &dyn DeviceBackend,
    b: &mut Body,
    colliders: &[Collider],
    gravity_m_s2: Vec3A,
    time_s: f64,
) -> Result<bool, DeviceError> {
    let dx = b.dx_m();
    let s = b.measured_bounds();
    let (lo, hi) = (s.aabb_m.0.as_vec3a(), s.aabb_m.1.as_vec3a());
    let edge = EDGE_CELLS * dx;
    let inside = (lo - edge).cmpge(b.device.extent_m.0).all()
        && (hi + edge).cmple(b.device.extent_m.1).all();
    let margin = MARGIN_CELLS * dx;
    let extent = (lo - margin, hi + margin);
    // Outgrown, a grid is laid out with two cells more than a move asks for, so it still takes
    // the same box wherever it lies against the nodes, and the object may swell a little.
    let grown = (extent.0 - 2.0 * dx, extent.1 + 2.0 * dx);
    let same = (b.device.uploaded.as_ref()).is_some_and(|u| u.matches(b, gravity_m_s2, colliders));
    if same && let Some(mpm) = b.device.mpm.as_mut() {
        let laid_out = if inside {
            Some(b.device.extent_m)
        } else if mpm.recentre(extent) {
            Some(extent)
        } else if mpm.regrid(grown) {
            b.device.regrids += 1;
            Some(grown)
        } else {
            None
        };
        if let Some(extent) = laid_out {
            b.device.extent_m = extent;
            if b.device.at == Residence::Host {
                mpm.write_particles(&b.particles)?;
                b.device.at = Residence::Both;
            }
            return Ok(true);
        }
    }
    // A new upload over the particles' box, with room to move.
    b.leave_device();
    if let Some(e) = b.device.failed.take() {
        return Err(DeviceError::Failed(e));
    }
    let extent = grown;
    let mut system = MpmSystem::new(b.particles.clone(), b.materials.clone(), dx);
    system.colliders = colliders.to_vec();
    system.gravity_m_s2 = gravity_m_s2;
    system.time_s = time_s;
    b.device.mpm = None;
    b.device.uploads += 1;
    match backend.upload(&system, extent) {
        Ok(mpm) => {
            b.device.mpm = Some(mpm);
            b.device.extent_m = extent;
            b.device.uploaded = Some(Uploaded {
                particles: b.particles.len(),
                dx_m: dx,
                materials: b.materials.clone(),
                gravity_m_s2,
                colliders: colliders.len(),
            });
            b.device.at = Residence::Both;
            Ok(true)
        }
        Err(DeviceError::Unsupported(why)) => {
            b.device.refused = Some(why);
            Ok(false)
        }
        Err(e) => Err(e),
    }
}

/// Runs body `b`'s MPM substep of `dt_s` at `time_s` on `backend`; returns what the device
/// reported, or `None` when the backend refuses the object (it steps on the CPU from now on).
///
/// # Errors
/// [`DeviceError::Failed`] when the device failed.
pub(super) fn substep(
    backend: &dyn DeviceBackend,
    b: &mut Body,
    (colliders, gravity_m_s2): (&[Collider], Vec3A),
    dt_s: f32,
    time_s: f64,
) -> Result<Option<DeviceReport>, DeviceError> {
    if let Some(report) = replayed(b) {
        return Ok(Some(report));
    }
    if !prepare(backend, b, colliders, gravity_m_s2, time_s)? {
        return Ok(None);
    }
    let reference = b.measured_bounds().com_m.as_vec3a();
    let Some(mpm) = b.device.mpm.as_mut() else {
        return Ok(None);
    };
    let report = mpm.substep(dt_s, time_s, reference)?;
    Ok(Some(b.took_device_substep(report)))
}

impl Body {
    /// Takes `report` of a substep its particles made on the device.
    fn took_device_substep(&mut self, report: DeviceReport) -> DeviceReport {
        self.device.at = Residence::Device;
        self.device.state = Some(report.state);
        self.device.min_plastic = report.min_plastic;
        self.device.substeps += 1;
        self.max_speed_m_s = report.max_speed_m_s;
        report
    }

    /// Whether its next substep takes a substep the device already ran ([`replay`]).
    pub(crate) fn replaying(&self) -> bool {
        self.device.replay.is_some()
    }

    /// Runs of substeps its MPM took on the device in one submission each.
    pub fn device_runs(&self) -> u64 {
        self.device.runs
    }

    /// Substeps its MPM took on the device in runs ([`Body::device_runs`]).
    pub fn device_run_substeps(&self) -> u64 {
        self.device.run_substeps
    }
}

/// Body `b`'s next substep takes `report`, of a substep the device already ran in a run.
pub(super) fn replay(b: &mut Body, report: DeviceReport) {
    b.device.replay = Some(report);
}

/// Runs `plan` on `backend` for body `b` (`world/device_run.rs`), its particles uploaded or
/// its grid moved first as a substep would, and the grid then covering `travel_m` (m) more:
/// `None` when it cannot, or the device does not run runs (one substep, as ever, then).
///
/// # Errors
/// [`DeviceError::Failed`] when the device failed.
pub(super) fn run(
    backend: &dyn DeviceBackend,
    b: &mut Body,
    (colliders, gravity_m_s2): (&[Collider], Vec3A),
    plan: &RunPlan,
    travel_m: f32,
) -> Result<Option<DeviceRun>, DeviceError> {
    if !prepare(backend, b, colliders, gravity_m_s2, plan.time_s)? {
        return Ok(None);
    }
    let s = b.measured_bounds();
    let dx = b.dx_m();
    let reach = Vec3A::splat(EDGE_CELLS * dx + travel_m);
    let (lo, hi) = (s.aabb_m.0.as_vec3a() - reach, s.aabb_m.1.as_vec3a() + reach);
    let Some(mpm) = b.device.mpm.as_mut() else {
        return Ok(None);
    };
    let extent = b.device.extent_m;
    if !(lo.cmpge(extent.0).all() && hi.cmple(extent.1).all()) {
        // Moved ahead of the travel, as a substep moves it when the particles near its edge.
        let margin = Vec3A::splat(MARGIN_CELLS * dx);
        let (from, to) = (
            s.aabb_m.0.as_vec3a() - margin,
            s.aabb_m.1.as_vec3a() + margin,
        );
        let covers = from.cmple(lo).all() && to.cmpge(hi).all();
        if !(covers && mpm.recentre((from, to))) {
            return Ok(None);
        }
        b.device.extent_m = (from, to);
    }
    let run = mpm.run(plan)?;
    if let Some(r) = &run {
        b.device.runs += 1;
        b.device.at = Residence::Device;
        b.device.run_substeps += r.steps.len() as u64;
    }
    Ok(run)
}

/// Body `b`'s substep on the device taken from a run ([`replay`]), if one is waiting.
fn replayed(b: &mut Body) -> Option<DeviceReport> {
    let report = b.device.replay.take()?;
    Some(b.took_device_substep(report))
}

impl World {
    /// Runs deformable objects' MPM on `backend` where their situation allows (module docs of
    /// `world/device.rs`) when the scene's `[simulation] device` is `gpu`; `None`: on the CPU.
    pub fn set_device(&mut self, backend: Option<std::sync::Arc<dyn DeviceBackend>>) {
        for b in &mut self.bodies {
            b.leave_device();
            b.device = DeviceSlot::default();
        }
        self.device = backend;
    }

    /// The device deformable objects may run on, if any.
    pub fn device(&self) -> Option<&dyn DeviceBackend> {
        self.device.as_deref()
    }

    /// Brings every object's particles back from the device (the frame's end, a command).
    ///
    /// # Errors
    /// [`WorldError::Device`] when a read-back failed.
    pub(super) fn sync_devices(&mut self, leave: bool) -> Result<(), WorldError> {
        let started = std::time::Instant::now();
        for b in &mut self.bodies {
            if leave {
                b.leave_device();
            } else {
                b.sync_host();
            }
        }
        self.stats.device_read_wall_s += started.elapsed().as_secs_f64();
        self.device_failure()
    }

    /// The first device failure an object recorded outside a substep, as an error.
    pub(super) fn device_failure(&mut self) -> Result<(), WorldError> {
        for b in &mut self.bodies {
            if let Some(message) = b.device.failed.take() {
                return Err(WorldError::Device {
                    object: b.name.clone(),
                    message,
                });
            }
        }
        Ok(())
    }
}

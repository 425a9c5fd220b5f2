//! Runs of substeps on the device: while one deformable object is all that moves and only grid
//! colliders can reach it, the device takes several of its substeps in one submission and the
//! host waits once, not after every substep.
//!
//! A substep on the device ends with a read-back of what the COM layer needs (`device.rs`),
//! and that wait, not the kernels, set the pace of small objects (a captured donut's 11,733
//! particles). Most of those substeps the host only records: free flight, or resting on a
//! collider, it takes the impulses and the speed and changes nothing. So the host plans a run
//! ([`RunPlan`]): one dt for all of it, chosen by the CFL bound for a speed above the object's
//! present one, and the substeps up to the frame's last (which lands on the frame's end), the
//! next scene event, the moment the object could fall asleep, or two cells of travel. The
//! device halts the run after the first substep whose end the host must see: a collider
//! contact that opens or closes (the restitution law acts when an impact ends), any touch when
//! the object has rolling resistance (which acts at every touch), a particle faster than the
//! speed the dt was chosen for, snow whose Jp fell below what its wave speed was chosen for, a
//! failure. The host then takes every substep that ran, in order, through the world's own
//! substep ([`World::substep_of`]) with the device's log in place of a device substep: the
//! laws, contact memory, sleep and counters see each substep as they would have.
//!
//! What differs from one substep at a time: a run's dt is the bound for a speed a little above
//! the present one, held over the run (the CFL bound of a falling object shrinks as it speeds
//! up), and the object's state between the run's substeps is the one after its last (the host
//! reads it only there: a substep that would read it halts the run).

use std::time::Instant;

use super::body::Body;
use super::device::{self, DeviceReport, DeviceRun, RunPlan};
use super::sleep::SLEEP_AFTER_S;
use super::step::Parts;
use super::{World, WorldError, kinematic, mpm_step};
use crate::material::ConstitutiveModel;
use crate::scene::{Method, ObjectKind};

/// Substeps a run takes at most, unless `SPLATPHYS_DEVICE_RUN` says otherwise (0 or 1: one
/// substep at a time).
const RUN_SUBSTEPS: u32 = 32;

/// Cells an object may travel in a run at its speed limit: the device's grid keeps four cells
/// of margin before it moves (`device.rs`), and the checks for solids and other objects nearby
/// are made over this travel at the run's start.
const RUN_TRAVEL_CELLS: f32 = 2.0;

/// Above the object's present largest speed, the speed (m/s) a run's dt is chosen for: this
/// fraction of it, and what gravity adds over the run, and [`SPEED_MARGIN_M_S`].
const SPEED_MARGIN: f32 = 0.05;
/// See [`SPEED_MARGIN`].
const SPEED_MARGIN_M_S: f32 = 1e-3;

/// Snow's Jp a run's wave speed is chosen for: this much below the object's smallest.
const PLASTIC_MARGIN: f32 = 0.01;

/// [`RUN_SUBSTEPS`], or `SPLATPHYS_DEVICE_RUN`.
pub(super) fn default_substeps() -> u32 {
    std::env::var("SPLATPHYS_DEVICE_RUN")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(RUN_SUBSTEPS)
}

/// A planned run: its object and what the device is told.
struct Planned {
    object: usize,
    plan: RunPlan,
    travel_m: f32,
}

impl World {
    /// At most `substeps` substeps in a run on the device (module docs); 0 or 1: one substep at
    /// a time. By default 32, or `SPLATPHYS_DEVICE_RUN`.
    pub fn set_device_run(&mut self, substeps: u32) {
        self.device_run = substeps;
    }

    /// A run of substeps on the device towards the frame's end `end_s` (s) (module docs), when
    /// the world allows one: the substeps taken, or `None` (then one substep, as ever).
    ///
    /// # Errors
    /// As [`World::substep`].
    pub(super) fn device_run(&mut self, end_s: f64) -> Result<Option<u64>, WorldError> {
        let Some(Planned {
            object: k,
            plan,
            travel_m,
        }) = self.plan_run(end_s)
        else {
            return Ok(None);
        };
        let Some(backend) = self.device.clone() else {
            return Ok(None);
        };
        let started = Instant::now();
        let b = &mut self.bodies[k];
        let on = (self.colliders.as_slice(), self.gravity_m_s2);
        let r = device::run(&*backend, b, on, &plan, travel_m);
        let run = r.map_err(|e| WorldError::Device {
            object: self.bodies[k].name.clone(),
            message: e.to_string(),
        })?;
        let Some(run) = run else {
            return Ok(None);
        };
        let wall_s = started.elapsed().as_secs_f64();
        self.stats.mpm_wall_s += wall_s;
        self.bodies[k].stats.mpm_wall_s += wall_s;
        let DeviceRun { mut steps, report } = run;
        // The last substep is the report's; the others take its state (module docs).
        steps.pop();
        let n = steps.len() + 1;
        let (state, min_plastic) = (report.state, report.min_plastic);
        let before_last = steps.into_iter().map(|step| DeviceReport {
            state,
            max_speed_m_s: step.max_speed_m_s,
            min_plastic,
            impulses_n_s: step.impulses_n_s,
            friction_n_s: step.friction_n_s,
            nodes: step.nodes,
        });
        for report in before_last.chain(std::iter::once(report)) {
            device::replay(&mut self.bodies[k], report);
            let Parts { env, bodies, .. } = self.parts();
            kinematic::drive(&env, bodies);
            self.substep_of(plan.dt_s)?;
            self.check_stable()?;
        }
        Ok(Some(n as u64))
    }

    /// The run the world allows now towards `end_s` (s), if any (module docs).
    fn plan_run(&self, end_s: f64) -> Option<Planned> {
        let most = self.device_run;
        if most < 2
            || self.device.is_none()
            || self.settings.method != Method::Com
            || self.island.is_some()
            || !self.contacts.resting_patches.is_empty()
            || self.colliders.len() > 32
        {
            return None;
        }
        // One object moves, and it is deformable.
        let mut awake = self
            .bodies
            .iter()
            .enumerate()
            .filter(|(_, b)| b.is_active());
        let (k, b) = awake.next()?;
        if awake.next().is_some() || b.kind != ObjectKind::Deformable || b.replaying() {
            return None;
        }
        let (dt, speed_limit, plastic_floor) = self.run_dt(b, end_s, most)?;
        let dx = b.dx_m();
        let remaining = end_s - self.time_s;
        // The frame's last substep is taken alone, landing on its end.
        let to_end = (remaining / f64::from(dt)).round() as u64;
        let mut substeps = u64::from(most).min(to_end.saturating_sub(1));
        if let Some(at) = self.next_event_s().filter(|&t| t < end_s) {
            substeps = substeps.min(((at - self.time_s - 1e-12) / f64::from(dt)).ceil() as u64);
        }
        if self.settings.sleep {
            let left = ((SLEEP_AFTER_S - b.still_s) / f64::from(dt)).ceil() as u64;
            substeps = substeps.min(left.saturating_sub(1).max(1));
        }
        let travel = RUN_TRAVEL_CELLS * dx;
        let by_travel = (travel / (speed_limit * dt)).floor();
        substeps = substeps.min(by_travel.min(u32::MAX as f32) as u64);
        if substeps < 2 {
            return None;
        }
        let env = self.env();
        if !mpm_step::device_may_step(&env, &self.bodies, k, travel) {
            return None;
        }
        let open = (0..self.colliders.len())
            .map(|c| {
                let key = (k, super::impact::SolidOf::Collider(c));
                self.contacts.impacts.contains_key(&key)
            })
            .collect();
        let state = b.measured_bounds();
        Some(Planned {
            object: k,
            plan: RunPlan {
                substeps: substeps as u32,
                dt_s: dt,
                time_s: self.time_s,
                reference_m: state.com_m.as_vec3a(),
                speed_limit_m_s: speed_limit,
                plastic_floor,
                open,
                opens_at_n_s: super::impact::NEGLIGIBLE_TOUCH_M_S * b.rigid.mass_kg,
                halt_on_touch: b.rolling_resistance_m > 0.0,
            },
            travel_m: travel,
        })
    }

    /// A run's dt (s) towards `end_s` for object `b` of at most `most` substeps, the speed (m/s)
    /// and the smallest snow Jp it holds for: [`World::time_step`]'s bound with `b` the only
    /// object stepping, for a speed above its present one.
    fn run_dt(&self, b: &Body, end_s: f64, most: u32) -> Option<(f32, f32, f32)> {
        let m = b.materials.first()?;
        let plastic = b.plastic_for_cfl();
        let lowest = plastic.iter().copied().fold(f32::INFINITY, f32::min);
        let plastic_floor = if lowest.is_finite() {
            lowest - PLASTIC_MARGIN * lowest.abs().max(1.0)
        } else {
            f32::NEG_INFINITY
        };
        let dx_b = b.solver.dx_m;
        let wave = m.wave_speed_for_m_s(&[plastic_floor]) + m.elastic().damping_speed_m_s(dx_b);
        let limit = |vmax: f32| {
            let dx = self.dx_m();
            let (dx, wave) = if dx_b / (wave + vmax) < dx / vmax {
                (dx_b, wave)
            } else {
                (dx, 0.0)
            };
            self.policy
                .next_dt_s(dx, wave, vmax, end_s - self.time_s)
                .ok()
        };
        // The colliders active at any time the run could reach, at the present speed's dt.
        let dt0 = limit(b.max_speed_m_s.max(f32::MIN_POSITIVE))?;
        let horizon = f64::from(dt0) * f64::from(most);
        let mut vmax = b.max_speed_m_s;
        for c in &self.colliders {
            if c.is_active(self.time_s) || c.is_active(self.time_s + horizon) {
                vmax = vmax.max(c.velocity_m_s.length());
            }
        }
        let gravity = self.gravity_m_s2.length() * horizon as f32;
        let speed_limit = vmax * (1.0 + SPEED_MARGIN) + gravity + SPEED_MARGIN_M_S;
        let dt = limit(speed_limit)?;
        (dt > 0.0 && dt.is_finite()).then_some((dt, speed_limit, plastic_floor))
    }
}

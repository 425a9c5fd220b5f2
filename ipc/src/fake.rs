//! A stand-in simulation for tests and `splatphys serve --fake`: particles in free fall.
//!
//! Each object is a small cube of Gaussians that falls under gravity g = 9.81 m/s² with the
//! closed form z(t) = z0 + v0 t - g t² / 2 (explicit Euler would drift; this is exact, so tests
//! can check positions to float precision). Impulses change an object's velocity by J / m.

use crate::command::Command;
use crate::simulation::{Advance, Simulation, SimulationError};
use crate::wire::{FrameGaussian, ObjectState, SceneGaussian};

/// Gravity used by the fake, m/s².
pub const GRAVITY_M_S2: f64 = 9.81;

/// Particles in free fall, grouped into objects; every object has mass 1 kg.
#[derive(Debug, Clone)]
pub struct FreeFall {
    name: String,
    per_object: usize,
    objects: usize,
    frame_dt_s: f64,
    substeps_per_frame: u64,
    max_steps: Option<u64>,
    step: u64,
    substeps: u64,
    generation: u32,
    /// Per object: COM position (m) and velocity (m/s) at `time_s`.
    com_m: Vec<[f64; 3]>,
    vel_m_s: Vec<[f64; 3]>,
    time_s: f64,
    names: Vec<String>,
    /// The state of the last [`Simulation::checkpoint`]: step, substeps, time, COMs, velocities.
    saved: Option<Saved>,
    /// Fail (as a blow-up would) the first time it is asked to compute this step: tests of the
    /// server's failure handling.
    pub fail_at_step: Option<u64>,
}

/// What [`FreeFall`] restores after a failure.
#[derive(Debug, Clone)]
struct Saved {
    step: u64,
    substeps: u64,
    time_s: f64,
    com_m: Vec<[f64; 3]>,
    vel_m_s: Vec<[f64; 3]>,
}

impl FreeFall {
    /// `objects` cubes of `per_object` Gaussians each, published every `frame_dt_s` seconds;
    /// finishes after `max_steps` frames if given.
    pub fn new(
        name: &str,
        objects: usize,
        per_object: usize,
        frame_dt_s: f64,
        max_steps: Option<u64>,
    ) -> Self {
        let mut s = Self {
            name: name.to_owned(),
            per_object,
            objects,
            frame_dt_s,
            substeps_per_frame: 10,
            max_steps,
            step: 0,
            substeps: 0,
            generation: 0,
            com_m: Vec::new(),
            vel_m_s: Vec::new(),
            time_s: 0.0,
            names: (0..objects).map(|i| format!("cube{i}")).collect(),
            saved: None,
            fail_at_step: None,
        };
        s.reset_state();
        s
    }

    fn reset_state(&mut self) {
        self.com_m = (0..self.objects).map(|i| [i as f64, 0.0, 10.0]).collect();
        self.vel_m_s = vec![[0.0; 3]; self.objects];
        self.time_s = 0.0;
        self.step = 0;
        self.substeps = 0;
    }

    /// Offset of Gaussian `k` of an object from its COM, metres (a cube of 1 cm spacing).
    fn offset_m(&self, k: usize) -> [f64; 3] {
        let side = (self.per_object as f64).cbrt().ceil().max(1.0) as usize;
        let (x, y, z) = (k % side, (k / side) % side, k / (side * side));
        [x as f64 * 0.01, y as f64 * 0.01, z as f64 * 0.01]
    }
}

impl Simulation for FreeFall {
    fn scene_name(&self) -> &str {
        &self.name
    }
    fn scene_generation(&self) -> u32 {
        self.generation
    }
    fn gaussian_count(&self) -> usize {
        self.objects * self.per_object
    }
    fn object_count(&self) -> usize {
        self.objects
    }
    fn object_name(&self, id: u32) -> Option<&str> {
        self.names.get(id as usize).map(String::as_str)
    }
    fn sh_degree(&self) -> u32 {
        0
    }
    fn frame_dt_s(&self) -> f64 {
        self.frame_dt_s
    }
    fn step(&self) -> u64 {
        self.step
    }
    fn time_s(&self) -> f64 {
        self.time_s
    }
    fn substeps(&self) -> u64 {
        self.substeps
    }

    fn write_scene(&self, out: &mut [SceneGaussian]) {
        for (i, g) in out.iter_mut().enumerate() {
            let object = (i / self.per_object.max(1)) as u32;
            *g = SceneGaussian::default();
            // DC colour: a different grey level per object (SH DC = (c - 0.5) / 0.2821).
            let c = 0.3 + 0.5 * (object as f32 / self.objects.max(1) as f32);
            g.sh[..3].copy_from_slice(&[(c - 0.5) / 0.282_095; 3]);
            g.object_id = object;
        }
    }

    fn advance(
        &mut self,
        keep_going: &mut dyn FnMut() -> bool,
    ) -> Result<Advance, SimulationError> {
        if !keep_going() {
            return Err(SimulationError::Interrupted { step: self.step });
        }
        if self.fail_at_step == Some(self.step + 1) {
            self.fail_at_step = None;
            self.com_m.iter_mut().for_each(|p| *p = [f64::NAN; 3]);
            return Err(SimulationError::Failed {
                step: self.step + 1,
                reason: "injected failure (fail_at_step)".into(),
            });
        }
        let dt = self.frame_dt_s;
        for (p, v) in self.com_m.iter_mut().zip(&mut self.vel_m_s) {
            for a in 0..3 {
                let g = if a == 2 { GRAVITY_M_S2 } else { 0.0 };
                p[a] += v[a] * dt - 0.5 * g * dt * dt;
                v[a] -= g * dt;
            }
        }
        self.time_s += dt;
        self.step += 1;
        self.substeps += self.substeps_per_frame;
        Ok(Advance {
            steps: 1,
            substeps: self.substeps_per_frame,
            time_s: self.time_s,
        })
    }

    fn checkpoint(&mut self) {
        self.saved = Some(Saved {
            step: self.step,
            substeps: self.substeps,
            time_s: self.time_s,
            com_m: self.com_m.clone(),
            vel_m_s: self.vel_m_s.clone(),
        });
    }

    fn restore_checkpoint(&mut self) -> bool {
        let Some(s) = &self.saved else { return false };
        self.step = s.step;
        self.substeps = s.substeps;
        self.time_s = s.time_s;
        self.com_m.clone_from(&s.com_m);
        self.vel_m_s.clone_from(&s.vel_m_s);
        true
    }

    fn write_frame(&self, out: &mut [FrameGaussian]) {
        let per = self.per_object.max(1);
        for (i, g) in out.iter_mut().enumerate() {
            let com = self.com_m[(i / per).min(self.objects.saturating_sub(1))];
            let o = self.offset_m(i % per);
            g.position_m = [
                (com[0] + o[0]) as f32,
                (com[1] + o[1]) as f32,
                (com[2] + o[2]) as f32,
            ];
            g.covariance_m2 = [1e-4, 0.0, 0.0, 1e-4, 0.0, 1e-4];
            g.rotation_wxyz = [1.0, 0.0, 0.0, 0.0];
        }
    }

    fn write_objects(&self, out: &mut [ObjectState]) {
        for (i, o) in out.iter_mut().enumerate() {
            let (p, v) = (self.com_m[i], self.vel_m_s[i]);
            *o = ObjectState {
                id: i as u32,
                contact_count: 0,
                position_m: p.map(|x| x as f32),
                velocity_m_s: v.map(|x| x as f32),
                orientation_wxyz: [1.0, 0.0, 0.0, 0.0],
                angular_velocity_rad_s: [0.0; 3],
                mass_kg: 1.0,
                contact_force_n: [0.0; 3],
                contact_torque_n_m: [0.0; 3],
            };
        }
    }

    fn apply(&mut self, command: &Command) -> Result<u64, String> {
        let at = self.step + 1;
        match *command {
            Command::Impulse {
                object,
                impulse_n_s,
                ..
            } => {
                let v = &mut self.vel_m_s[object as usize];
                for a in 0..3 {
                    v[a] += impulse_n_s[a]; // mass 1 kg
                }
            }
            Command::SetVelocity {
                object,
                velocity_m_s,
                ..
            } => self.vel_m_s[object as usize] = velocity_m_s,
            Command::SetPose {
                object, position_m, ..
            } => self.com_m[object as usize] = position_m,
            Command::Reset => {
                self.reset_state();
                self.generation += 1;
                return Ok(0);
            }
            Command::EditMaterial { .. } | Command::SetKind { .. } => {}
            Command::Pause | Command::Resume | Command::Step { .. } | Command::Shutdown => {
                return Err("handled by the server".into());
            }
        }
        Ok(at)
    }

    fn is_finished(&self) -> bool {
        self.max_steps.is_some_and(|m| self.step >= m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn free_fall_matches_closed_form() {
        let mut s = FreeFall::new("t", 1, 1, 0.01, None);
        for _ in 0..100 {
            s.advance(&mut || true).unwrap();
        }
        let mut o = [ObjectState::default()];
        s.write_objects(&mut o);
        // z = 10 - g t^2 / 2 at t = 1 s; f32 output, so 1e-4 m is float rounding, not physics.
        assert!((o[0].position_m[2] as f64 - (10.0 - 0.5 * GRAVITY_M_S2)).abs() < 1e-4);
        assert!((o[0].velocity_m_s[2] as f64 + GRAVITY_M_S2).abs() < 1e-4);
    }

    #[test]
    fn reset_bumps_generation_and_restores_time() {
        let mut s = FreeFall::new("t", 2, 8, 0.01, None);
        s.advance(&mut || true).unwrap();
        s.apply(&Command::Reset).unwrap();
        assert_eq!(s.scene_generation(), 1);
        assert_eq!(s.step(), 0);
        assert_eq!(s.time_s(), 0.0);
    }
}

//! Command validation: the checks every command passes before it reaches the simulation.
//!
//! Rejected, never applied: NaN or infinite values, unknown objects, nu outside (-1, 0.5),
//! E <= 0, density <= 0, restitution outside [0, 1], friction < 0, an impulse whose magnitude
//! exceeds [`Limits::max_impulse_n_s`], `Step` with a count of 0 or above
//! [`Limits::max_step_count`].

use splatphys_types::limits::{DEFAULT_MAX_IMPULSE_N_S, MAX_COMMAND_SPEED_M_S, MAX_STEP_COUNT};

use crate::command::{Command, RejectCode, Reply};

/// Server-side limits on command values (defaults from [`splatphys_types::limits`], the bounds
/// the simulation and the scene loader use too).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// Largest accepted impulse magnitude, N·s. Default [`DEFAULT_MAX_IMPULSE_N_S`] (1e3).
    pub max_impulse_n_s: f64,
    /// Largest accepted speed for `SetVelocity`, m/s. Default [`MAX_COMMAND_SPEED_M_S`] (100):
    /// the simulation refuses any command that would move a particle faster.
    pub max_speed_m_s: f64,
    /// Largest `Step { count }`. Default [`MAX_STEP_COUNT`] (1e6).
    pub max_step_count: u64,
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            max_impulse_n_s: DEFAULT_MAX_IMPULSE_N_S,
            max_speed_m_s: MAX_COMMAND_SPEED_M_S,
            max_step_count: MAX_STEP_COUNT,
        }
    }
}

fn reject(code: RejectCode, reason: String) -> Result<(), Reply> {
    Err(Reply::Rejected { code, reason })
}

fn finite3(name: &str, v: &[f64; 3]) -> Result<(), Reply> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        reject(RejectCode::NotFinite, format!("{name} {v:?} is not finite"))
    }
}

fn finite(name: &str, v: Option<f64>) -> Result<(), Reply> {
    match v {
        Some(x) if !x.is_finite() => {
            reject(RejectCode::NotFinite, format!("{name} {x} is not finite"))
        }
        _ => Ok(()),
    }
}

fn norm(v: &[f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Checks `cmd` against `limits` and a scene with `object_count` objects.
///
/// # Errors
/// The rejection [`Reply`] to send back.
pub fn validate(cmd: &Command, object_count: u32, limits: &Limits) -> Result<(), Reply> {
    if let Some(&object) = cmd.object()
        && object >= object_count
    {
        return reject(
            RejectCode::UnknownObject,
            format!("object {object} does not exist (scene has {object_count})"),
        );
    }
    match cmd {
        Command::Impulse {
            impulse_n_s,
            point_m,
            ..
        } => {
            finite3("impulse", impulse_n_s)?;
            if let Some(p) = point_m {
                finite3("point", p)?;
            }
            let m = norm(impulse_n_s);
            if m > limits.max_impulse_n_s {
                return reject(
                    RejectCode::ImpulseTooLarge,
                    format!(
                        "impulse {m:.3e} N·s above limit {:.3e}",
                        limits.max_impulse_n_s
                    ),
                );
            }
        }
        Command::SetPose {
            position_m,
            orientation_wxyz,
            ..
        } => {
            finite3("position", position_m)?;
            if !orientation_wxyz.iter().all(|x| x.is_finite()) {
                return reject(
                    RejectCode::NotFinite,
                    format!("orientation {orientation_wxyz:?} is not finite"),
                );
            }
            if orientation_wxyz.iter().map(|x| x * x).sum::<f64>() < 1e-12 {
                return reject(
                    RejectCode::OutOfRange,
                    "orientation (0, 0, 0, 0) is not a rotation".into(),
                );
            }
        }
        Command::SetVelocity {
            velocity_m_s,
            angular_velocity_rad_s,
            ..
        } => {
            if let Some(w) = angular_velocity_rad_s {
                finite3("angular velocity", w)?;
            }
            finite3("velocity", velocity_m_s)?;
            let s = norm(velocity_m_s);
            if s > limits.max_speed_m_s {
                return reject(
                    RejectCode::OutOfRange,
                    format!("speed {s:.3e} m/s above limit {:.3e}", limits.max_speed_m_s),
                );
            }
        }
        Command::EditMaterial { edit, .. } => {
            finite("E", edit.youngs_modulus_pa)?;
            finite("nu", edit.poisson_ratio)?;
            finite("density", edit.density_kg_m3)?;
            finite("restitution", edit.restitution)?;
            finite("friction", edit.friction)?;
            if let Some(e) = edit.youngs_modulus_pa
                && e <= 0.0
            {
                return reject(RejectCode::OutOfRange, format!("E = {e} Pa must be > 0"));
            }
            if let Some(nu) = edit.poisson_ratio
                && !(nu > -1.0 && nu < 0.5)
            {
                return reject(
                    RejectCode::OutOfRange,
                    format!("nu = {nu} outside (-1, 0.5)"),
                );
            }
            if let Some(d) = edit.density_kg_m3
                && d <= 0.0
            {
                return reject(
                    RejectCode::OutOfRange,
                    format!("density = {d} kg/m3 must be > 0"),
                );
            }
            if let Some(e) = edit.restitution
                && !(0.0..=1.0).contains(&e)
            {
                return reject(
                    RejectCode::OutOfRange,
                    format!("restitution e = {e} outside [0, 1]"),
                );
            }
            if let Some(mu) = edit.friction
                && mu < 0.0
            {
                return reject(
                    RejectCode::OutOfRange,
                    format!("friction = {mu} must be >= 0"),
                );
            }
        }
        Command::Step { count } => {
            if *count == 0 || *count > limits.max_step_count {
                return reject(
                    RejectCode::OutOfRange,
                    format!("step count {count} outside 1..={}", limits.max_step_count),
                );
            }
        }
        Command::SetKind { .. }
        | Command::Pause
        | Command::Resume
        | Command::Reset
        | Command::Shutdown => {}
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::command::MaterialEdit;

    fn code(r: Result<(), Reply>) -> RejectCode {
        match r {
            Err(Reply::Rejected { code, .. }) => code,
            other => panic!("expected a rejection, got {other:?}"),
        }
    }

    fn edit(e: MaterialEdit) -> Command {
        Command::EditMaterial { object: 0, edit: e }
    }

    #[test]
    fn nan_and_infinite_values_are_rejected() {
        let l = Limits::default();
        let c = Command::Impulse {
            object: 0,
            impulse_n_s: [f64::NAN, 0.0, 0.0],
            point_m: None,
        };
        assert_eq!(code(validate(&c, 1, &l)), RejectCode::NotFinite);
        let c = Command::Impulse {
            object: 0,
            impulse_n_s: [0.0, 0.0, 1.0],
            point_m: Some([0.0, f64::INFINITY, 0.0]),
        };
        assert_eq!(code(validate(&c, 1, &l)), RejectCode::NotFinite);
        let c = edit(MaterialEdit {
            youngs_modulus_pa: Some(f64::NEG_INFINITY),
            ..Default::default()
        });
        assert_eq!(code(validate(&c, 1, &l)), RejectCode::NotFinite);
    }

    #[test]
    fn unknown_object_is_rejected() {
        let c = Command::SetVelocity {
            object: 2,
            velocity_m_s: [0.0; 3],
            angular_velocity_rad_s: None,
        };
        assert_eq!(
            code(validate(&c, 2, &Limits::default())),
            RejectCode::UnknownObject
        );
        assert!(validate(&c, 3, &Limits::default()).is_ok());
    }

    #[test]
    fn poisson_ratio_must_lie_in_open_interval() {
        let l = Limits::default();
        for nu in [-1.0, 0.5, 0.6, -2.0] {
            let c = edit(MaterialEdit {
                poisson_ratio: Some(nu),
                ..Default::default()
            });
            assert_eq!(code(validate(&c, 1, &l)), RejectCode::OutOfRange, "nu={nu}");
        }
        for nu in [-0.99, 0.0, 0.3, 0.499] {
            let c = edit(MaterialEdit {
                poisson_ratio: Some(nu),
                ..Default::default()
            });
            assert!(validate(&c, 1, &l).is_ok(), "nu={nu}");
        }
    }

    #[test]
    fn nonpositive_modulus_and_density_are_rejected() {
        let l = Limits::default();
        for e in [0.0, -1e5] {
            let c = edit(MaterialEdit {
                youngs_modulus_pa: Some(e),
                ..Default::default()
            });
            assert_eq!(code(validate(&c, 1, &l)), RejectCode::OutOfRange);
            let c = edit(MaterialEdit {
                density_kg_m3: Some(e),
                ..Default::default()
            });
            assert_eq!(code(validate(&c, 1, &l)), RejectCode::OutOfRange);
        }
    }

    #[test]
    fn impulse_above_limit_is_rejected_and_at_limit_accepted() {
        let l = Limits {
            max_impulse_n_s: 10.0,
            ..Default::default()
        };
        let at = Command::Impulse {
            object: 0,
            impulse_n_s: [6.0, 8.0, 0.0], // |J| = 10 exactly
            point_m: None,
        };
        assert!(validate(&at, 1, &l).is_ok());
        let above = Command::Impulse {
            object: 0,
            impulse_n_s: [6.0, 8.0, 0.1],
            point_m: None,
        };
        assert_eq!(code(validate(&above, 1, &l)), RejectCode::ImpulseTooLarge);
    }

    #[test]
    fn step_count_zero_is_rejected() {
        assert_eq!(
            code(validate(&Command::Step { count: 0 }, 1, &Limits::default())),
            RejectCode::OutOfRange
        );
    }
}

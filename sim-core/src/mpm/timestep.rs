//! Substep size: the CFL bound dt <= C dx / (c_p + |v|max) with c_p the dilational wave speed of
//! the stiffest material present (explicit MPM is stable only while information crosses less than
//! a cell per substep; Fang et al. 2018 discuss the constant). C defaults to 0.5. The rest of a
//! frame is cut into equal substeps within the bound, so a frame never ends on a sliver.

/// Largest substep ever taken (s), whatever the bound says (a motionless, soft scene).
pub const MAX_DT_S: f32 = 1e-2;

/// How substeps are sized.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TimeStepPolicy {
    /// dt = number · dx / (c_p + |v|max), recomputed every substep; the rest of the frame is
    /// cut into equal substeps no longer than that.
    Cfl {
        /// The CFL number C, in (0, 1] for stability (default 0.5).
        number: f32,
    },
    /// A fixed dt; refused when above the CFL bound with C = 1 unless `force` (stability studies).
    Fixed {
        /// Substep in s.
        dt_s: f32,
        /// Take it even when above the bound.
        force: bool,
    },
}

impl Default for TimeStepPolicy {
    fn default() -> Self {
        Self::Cfl { number: 0.5 }
    }
}

/// Why a substep size was refused.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum TimeStepError {
    /// A fixed dt above the CFL bound without `force`.
    #[error(
        "fixed dt_s = {dt_s:.3e} s is above the CFL bound {bound_s:.3e} s = dx / (c_p + |v|max) \
         with dx = {dx_m} m, c_p = {wave_speed_m_s:.3} m/s, |v|max = {max_speed_m_s:.3} m/s; \
         lower dt_s, use `cfl`, or force it for a stability study"
    )]
    FixedAboveBound {
        /// The dt asked for (s).
        dt_s: f32,
        /// The bound (s).
        bound_s: f32,
        /// Cell size (m).
        dx_m: f32,
        /// c_p (m/s).
        wave_speed_m_s: f32,
        /// Largest particle speed (m/s).
        max_speed_m_s: f32,
    },
    /// A CFL number or dt that is not a positive finite number.
    #[error("invalid time step setting: {what} = {value} (must be positive and finite)")]
    Invalid {
        /// "cfl" or "dt_s".
        what: &'static str,
        /// The value given.
        value: f32,
    },
}

/// The CFL bound C dx / (c_p + |v|max) in s, capped at [`MAX_DT_S`].
pub fn cfl_dt_s(cfl: f32, dx_m: f32, wave_speed_m_s: f32, max_speed_m_s: f32) -> f32 {
    let speed = wave_speed_m_s + max_speed_m_s;
    if speed > 0.0 {
        (cfl * dx_m / speed).min(MAX_DT_S)
    } else {
        MAX_DT_S
    }
}

impl TimeStepPolicy {
    /// Checks the setting itself.
    ///
    /// # Errors
    /// [`TimeStepError::Invalid`] for a non-positive or non-finite number.
    pub fn validate(&self) -> Result<(), TimeStepError> {
        match *self {
            Self::Cfl { number } if !(number.is_finite() && number > 0.0) => {
                Err(TimeStepError::Invalid {
                    what: "cfl",
                    value: number,
                })
            }
            Self::Fixed { dt_s, .. } if !(dt_s.is_finite() && dt_s > 0.0) => {
                Err(TimeStepError::Invalid {
                    what: "dt_s",
                    value: dt_s,
                })
            }
            _ => Ok(()),
        }
    }

    /// The next substep (s), never past `remaining_s` (the end of the current frame).
    ///
    /// # Errors
    /// [`TimeStepError::FixedAboveBound`] when a fixed, unforced dt exceeds the C = 1 bound.
    pub fn next_dt_s(
        &self,
        dx_m: f32,
        wave_speed_m_s: f32,
        max_speed_m_s: f32,
        remaining_s: f64,
    ) -> Result<f32, TimeStepError> {
        self.validate()?;
        let dt = match *self {
            Self::Cfl { number } => cfl_dt_s(number, dx_m, wave_speed_m_s, max_speed_m_s),
            Self::Fixed { dt_s, force } => {
                let bound_s = cfl_dt_s(1.0, dx_m, wave_speed_m_s, max_speed_m_s);
                if dt_s > bound_s && !force {
                    return Err(TimeStepError::FixedAboveBound {
                        dt_s,
                        bound_s,
                        dx_m,
                        wave_speed_m_s,
                        max_speed_m_s,
                    });
                }
                dt_s
            }
        };
        // Land exactly on the frame boundary. Under the CFL policy the rest of the frame is cut
        // into equal substeps no longer than the bound (as many as whole bounds would take), not
        // whole bounds and a sliver: a 10-box stack on 10 ms substeps with a 3.3 ms sliver per
        // frame at 30 frames/s rocked at 6 cm/s for 10 s (and fell with 0.3 ms slivers at 33);
        // on 4 × 8.3 ms it stands still.
        let remaining = remaining_s as f32;
        let slack = 1.0001;
        Ok(if remaining <= dt * slack {
            remaining.max(f32::MIN_POSITIVE)
        } else if matches!(self, Self::Cfl { .. }) && remaining.is_finite() {
            remaining / (remaining / (dt * slack)).ceil()
        } else {
            dt
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Steps `policy` through a frame of `frame_s` with a bound of 10 ms (dx 0.01 m, speed
    /// 0.5 m/s at C = 0.5); returns the substeps taken (s).
    fn frame(policy: TimeStepPolicy, frame_s: f64) -> Vec<f32> {
        let mut left = frame_s;
        let mut steps = Vec::new();
        while left > 1e-9 {
            let dt = policy.next_dt_s(0.01, 0.5, 0.0, left).expect("dt");
            steps.push(dt);
            left -= f64::from(dt);
        }
        steps
    }

    #[test]
    fn a_frame_is_cut_into_equal_substeps_within_the_bound() {
        // 33.3 ms at a 10 ms bound: four substeps of 8.33 ms, not 10, 10, 10 and 3.3.
        let steps = frame(TimeStepPolicy::default(), 1.0 / 30.0);
        assert_eq!(steps.len(), 4, "{steps:?}");
        for dt in &steps {
            assert!((dt - 1.0 / 120.0).abs() < 1e-6, "{steps:?}");
        }
        // A frame of whole bounds keeps them.
        let steps = frame(TimeStepPolicy::default(), 0.04);
        assert_eq!(steps.len(), 4, "{steps:?}");
        assert!(steps.iter().all(|dt| (dt - 0.01).abs() < 1e-6), "{steps:?}");
        // A fixed dt is what was asked, with the rest of the frame last.
        let fixed = TimeStepPolicy::Fixed {
            dt_s: 0.01,
            force: false,
        };
        let steps = frame(fixed, 1.0 / 30.0);
        assert_eq!(steps.len(), 4, "{steps:?}");
        assert!((steps[3] - (1.0 / 30.0 - 0.03)).abs() < 1e-6, "{steps:?}");
    }

    #[test]
    fn a_substep_with_no_frame_end_is_the_bound() {
        // A substep asked for outside a frame (no end to land on) is the bound itself, not
        // ∞ / ⌈∞⌉ = NaN.
        let cfl = TimeStepPolicy::Cfl { number: 0.5 };
        for remaining_s in [f64::INFINITY, f64::NAN] {
            let dt = cfl.next_dt_s(0.01, 0.0, 0.5, remaining_s).expect("dt");
            assert!((dt - 0.01).abs() < 1e-9, "{remaining_s}: {dt}");
        }
    }
}

//! What a scene needed and what was modelled, per object (`splatphys run --explain`): how each
//! object moves, how many MPM particles it simulated and how many Gaussians it carried, the
//! sparse-grid blocks it touched, how many substeps it slept through, and its own CFL limit
//! dt = C·dx / (c_p + |v|max) (Courant-Friedrichs-Lewy; c_p = sqrt((λ + 2μ)/ρ) of its material),
//! so a user sees which object and material set the substep. Objects that step in separate
//! islands (`world/islands.rs`) show their own substep counts and ranges, and each object's own
//! MPM wall time says where a frame's time goes.

use serde::{Deserialize, Serialize};

use super::World;
use crate::material::ConstitutiveModel;
use crate::mpm::TimeStepPolicy;
use crate::mpm::timestep::cfl_dt_s;
use crate::scene::ObjectKind;

/// One object's line of the report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ObjectExplanation {
    /// Object name.
    pub name: String,
    /// "deformable", "rigid" or "static".
    pub kind: String,
    /// Material model name.
    pub material: String,
    /// How it was modelled, in words.
    pub modelled_as: String,
    /// MPM particles simulated (0 for rigid and static objects).
    pub particles_simulated: usize,
    /// Gaussians carried along by the simulated state.
    pub gaussians_carried: usize,
    /// Sparse-grid blocks of its own grid in the last substep it computed (0 when it has none).
    pub grid_blocks: usize,
    /// Its grid cell dx, m.
    #[serde(default)]
    pub dx_m: f32,
    /// Substeps of its island it took part in (computed or slept).
    #[serde(default)]
    pub substeps: u64,
    /// Smallest and largest of those substeps, s (`[0, 0]` before the first).
    #[serde(default)]
    pub dt_range_s: [f64; 2],
    /// Substeps it was computed in.
    pub substeps_computed: u64,
    /// Substeps it skipped (asleep, static, or rigid: no MPM).
    pub substeps_slept: u64,
    /// The speed its CFL bound divides by, m/s (deformable only): its material's dilational
    /// wave speed c_p, plus 6 η_d / (ρ dx) when the material is damped.
    pub wave_speed_m_s: Option<f32>,
    /// Its largest particle speed in the last substep, m/s.
    pub max_speed_m_s: f32,
    /// Its own CFL limit with the scene's C, s (deformable only).
    pub dt_limit_s: Option<f32>,
    /// Wall time its own MPM substeps took so far, s (method `com`; a timing of this machine).
    #[serde(default)]
    pub mpm_wall_s: f64,
}

/// The whole report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Explanation {
    /// Method: "com", "mpm" or "multi-field".
    pub method: String,
    /// Grid spacing dx, m.
    pub dx_m: f32,
    /// "cfl C" or "fixed dt_s".
    pub time_step: String,
    /// Substeps taken so far, by all islands together.
    pub substeps: u64,
    /// Smallest and largest substep taken, s.
    pub dt_range_s: [f64; 2],
    /// The object whose limit is the smallest now (sets the substep under CFL stepping).
    pub limited_by: Option<String>,
    /// Per object.
    pub objects: Vec<ObjectExplanation>,
    /// What the captured background became, in words.
    #[serde(default)]
    pub background: String,
}

impl World {
    /// The report at the current state (see the module docs).
    pub fn explain(&self) -> Explanation {
        let dx = self.dx_m();
        let cfl = match self.policy {
            TimeStepPolicy::Cfl { number } => number,
            TimeStepPolicy::Fixed { .. } => 1.0,
        };
        let substeps = self.stats.substeps;
        let objects: Vec<ObjectExplanation> = self
            .bodies
            .iter()
            .map(|b| {
                let deformable = b.kind == ObjectKind::Deformable;
                // The CFL bound of the current state (snow: its moduli at its hardest particle;
                // with its damping's own limit as a speed).
                let wave = b.materials.first().map(|m| {
                    m.wave_speed_for_m_s(&b.particles.plastic)
                        + m.elastic().damping_speed_m_s(b.solver.dx_m)
                });
                let kind = b.kind.name().to_string();
                let fill = b.visible.iter().filter(|v| !**v).count();
                let mut modelled_as = match b.kind {
                    ObjectKind::Deformable if b.particles.len() < b.gaussians.len() => format!(
                        "MPM on {} particles carrying {} Gaussians",
                        b.particles.len(),
                        b.gaussians.len()
                    ),
                    ObjectKind::Deformable => "MPM, one particle per Gaussian".to_string(),
                    ObjectKind::Rigid => "rigid body (no MPM)".to_string(),
                    ObjectKind::Static => "static (never stepped)".to_string(),
                    ObjectKind::Kinematic => "kinematic (moves as commanded, no MPM)".to_string(),
                };
                if b.device_substeps() > 0 {
                    modelled_as.push_str(&format!(
                        "; {} substeps on the device, {} of them in {} runs of one wait each \
                         ({} upload(s))",
                        b.device_substeps(),
                        b.device_run_substeps(),
                        b.device_runs(),
                        b.device_uploads()
                    ));
                }
                if let Some(why) = b.device_refused() {
                    modelled_as.push_str(&format!("; on the CPU: {why}"));
                }
                if fill > 0 {
                    modelled_as.push_str(&format!(
                        "; {fill} of its Gaussians are interior fill (never published)"
                    ));
                }
                ObjectExplanation {
                    name: b.name.clone(),
                    kind,
                    material: b
                        .materials
                        .first()
                        .map_or_else(String::new, |m| m.name().to_string()),
                    modelled_as,
                    particles_simulated: if deformable { b.particles.len() } else { 0 },
                    gaussians_carried: b.gaussians.len(),
                    grid_blocks: if deformable {
                        b.solver.grid().block_count()
                    } else {
                        0
                    },
                    dx_m: b.solver.dx_m,
                    substeps: b.stats.substeps_taken,
                    dt_range_s: if b.stats.substeps_taken > 0 {
                        b.stats.dt_range_s
                    } else {
                        [0.0, 0.0]
                    },
                    substeps_computed: b
                        .stats
                        .substeps_taken
                        .saturating_sub(b.stats.substeps_skipped),
                    substeps_slept: b.stats.substeps_skipped.min(b.stats.substeps_taken),
                    wave_speed_m_s: wave.filter(|_| deformable),
                    max_speed_m_s: b.max_speed_m_s,
                    dt_limit_s: wave
                        .filter(|_| deformable)
                        .map(|c| cfl_dt_s(cfl, b.solver.dx_m, c, b.max_speed_m_s)),
                    mpm_wall_s: b.stats.mpm_wall_s,
                }
            })
            .collect();
        let limited_by = objects
            .iter()
            .filter_map(|o| o.dt_limit_s.map(|dt| (dt, o)))
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .map(|(_, o)| format!("{} ({})", o.name, o.material));
        Explanation {
            method: self.settings.method.name().to_string(),
            dx_m: dx,
            time_step: match self.policy {
                TimeStepPolicy::Cfl { number } => format!("cfl {number}"),
                TimeStepPolicy::Fixed { dt_s, force } => {
                    format!("fixed {dt_s} s{}", if force { " (forced)" } else { "" })
                }
            },
            substeps,
            dt_range_s: if substeps > 0 {
                [self.stats.dt_min_s, self.stats.dt_max_s]
            } else {
                [0.0, 0.0]
            },
            limited_by,
            objects,
            background: self.background_in_words(),
        }
    }

    fn background_in_words(&self) -> String {
        let r = &self.background.report;
        if r.gaussians == 0 {
            return "no background".into();
        }
        if !self.settings.background_collision {
            return format!(
                "{} Gaussians, drawn only (background_collision = false)",
                r.gaussians
            );
        }
        match &self.background.collision {
            Some(_) => format!(
                "{} Gaussians: {} opaque (>= {}), {} floaters and {} under objects dropped, {} \
                 form a static collision surface (cells of {} m)",
                r.gaussians,
                r.opaque,
                self.settings.background_min_opacity,
                r.floaters,
                r.under_objects,
                r.solid,
                self.dx_m()
            ),
            None => format!(
                "{} Gaussians, none solid (opacity >= {}): drawn only",
                r.gaussians, self.settings.background_min_opacity
            ),
        }
    }
}

impl Explanation {
    /// The report as a plain-text table.
    pub fn to_table(&self) -> String {
        let mut s = format!(
            "method {}, dx {} m, time step {}, {} substeps, dt {:.3e}..{:.3e} s{}\n",
            self.method,
            self.dx_m,
            self.time_step,
            self.substeps,
            self.dt_range_s[0],
            self.dt_range_s[1],
            self.limited_by
                .as_ref()
                .map_or_else(String::new, |o| format!(", dt set by {o}"))
        );
        s.push_str(&format!("background: {}\n", self.background));
        s.push_str(&format!(
            "{:<16} {:<10} {:<11} {:>9} {:>9} {:>7} {:>7} {:>19} {:>9} {:>7} {:>9} {:>10} {:>10}  modelled as\n",
            "object",
            "kind",
            "material",
            "particles",
            "gaussians",
            "blocks",
            "dx m",
            "dt s taken",
            "computed",
            "slept",
            "speed m/s",
            "dt limit s",
            "MPM wall s"
        ));
        for o in &self.objects {
            s.push_str(&format!(
                "{:<16} {:<10} {:<11} {:>9} {:>9} {:>7} {:>7} {:>19} {:>9} {:>7} {:>9} {:>10} {:>10}  {}\n",
                o.name,
                o.kind,
                o.material,
                o.particles_simulated,
                o.gaussians_carried,
                o.grid_blocks,
                o.dx_m,
                format!("{:.2e}..{:.2e}", o.dt_range_s[0], o.dt_range_s[1]),
                o.substeps_computed,
                o.substeps_slept,
                o.wave_speed_m_s.map_or("-".into(), |c| format!("{c:.1}")),
                o.dt_limit_s.map_or("-".into(), |d| format!("{d:.2e}")),
                if o.particles_simulated > 0 {
                    format!("{:.3}", o.mpm_wall_s)
                } else {
                    "-".into()
                },
                o.modelled_as
            ));
        }
        s
    }
}

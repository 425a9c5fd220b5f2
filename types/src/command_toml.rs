//! [`CommandToml`]: a command as scene files (`[[event]]`) and control timelines write it.

use serde::{Deserialize, Serialize};

use crate::{Command, MaterialEdit, MaterialModel, ObjectKind};

/// A command as a TOML table: `command` names it, the other keys are its fields. Scene files'
/// `[[event]]`s and control timelines use exactly these keys (plus their own `at_s`):
///
/// ```toml
/// command = "impulse"            # object, impulse_n_s, optional point_m
/// object = "ball"
/// impulse_n_s = [0.0, 0.0, 2.0]
/// ```
///
/// | `command` | keys |
/// |---|---|
/// | `impulse` | `object`, `impulse_n_s` [x, y, z] N·s, optional `point_m` [x, y, z] m (default: the COM) |
/// | `set-velocity` | `object`, `velocity_m_s` [x, y, z] m/s, optional `angular_velocity_rad_s` [x, y, z] rad/s |
/// | `set-pose` | `object` (kinematic), `position_m` [x, y, z] m (COM), `orientation_wxyz` [w, x, y, z] (relative to the rest pose), optional `at_step` |
/// | `edit-material` | `object`, any of `model`, `youngs_modulus_pa`, `poisson_ratio`, `density_kg_m3`, `restitution`, `friction` |
/// | `set-kind` | `object`, `kind` (`deformable`, `rigid`, `static`, `kinematic`) |
/// | `step` | `count` |
/// | `pause`, `resume`, `reset`, `shutdown` | none |
///
/// Unknown keys, and keys that do not belong to the command, are errors
/// ([`CommandToml::into_command`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(
    deny_unknown_fields,
    bound(serialize = "O: Serialize", deserialize = "O: Deserialize<'de>")
)]
pub struct CommandToml<O> {
    /// The command's name ([`Command::name`]).
    pub command: String,
    /// Target object.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub object: Option<O>,
    /// `impulse`: impulse, N·s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub impulse_n_s: Option<[f64; 3]>,
    /// `impulse`: point of application, m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub point_m: Option<[f64; 3]>,
    /// `set-velocity`: velocity, m/s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub velocity_m_s: Option<[f64; 3]>,
    /// `set-velocity`: angular velocity, rad/s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub angular_velocity_rad_s: Option<[f64; 3]>,
    /// `set-pose`: COM position, m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position_m: Option<[f64; 3]>,
    /// `set-pose`: orientation (w, x, y, z) relative to the rest pose.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub orientation_wxyz: Option<[f64; 4]>,
    /// `set-pose`: the step at whose end the pose is reached.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub at_step: Option<u64>,
    /// `edit-material`: model.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model: Option<MaterialModel>,
    /// `edit-material`: Young's modulus E, Pa.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub youngs_modulus_pa: Option<f64>,
    /// `edit-material`: Poisson's ratio nu.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub poisson_ratio: Option<f64>,
    /// `edit-material`: density, kg/m³.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub density_kg_m3: Option<f64>,
    /// `edit-material`: restitution e.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub restitution: Option<f64>,
    /// `edit-material`: Coulomb friction mu.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<f64>,
    /// `set-kind`: the new kind.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kind: Option<ObjectKind>,
    /// `step`: frames.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub count: Option<u64>,
}

impl<O> From<Command<O>> for CommandToml<O> {
    /// The table that [`CommandToml::into_command`] turns back into `command`.
    fn from(command: Command<O>) -> Self {
        let mut t = Self {
            command: command.name().to_string(),
            object: None,
            impulse_n_s: None,
            point_m: None,
            velocity_m_s: None,
            angular_velocity_rad_s: None,
            position_m: None,
            orientation_wxyz: None,
            at_step: None,
            model: None,
            youngs_modulus_pa: None,
            poisson_ratio: None,
            density_kg_m3: None,
            restitution: None,
            friction: None,
            kind: None,
            count: None,
        };
        match command {
            Command::Impulse {
                object,
                impulse_n_s,
                point_m,
            } => {
                t.object = Some(object);
                t.impulse_n_s = Some(impulse_n_s);
                t.point_m = point_m;
            }
            Command::SetVelocity {
                object,
                velocity_m_s,
                angular_velocity_rad_s,
            } => {
                t.object = Some(object);
                t.velocity_m_s = Some(velocity_m_s);
                t.angular_velocity_rad_s = angular_velocity_rad_s;
            }
            Command::SetPose {
                object,
                position_m,
                orientation_wxyz,
                at_step,
            } => {
                t.object = Some(object);
                t.position_m = Some(position_m);
                t.orientation_wxyz = Some(orientation_wxyz);
                t.at_step = at_step;
            }
            Command::EditMaterial { object, edit } => {
                t.object = Some(object);
                t.model = edit.model;
                t.youngs_modulus_pa = edit.youngs_modulus_pa;
                t.poisson_ratio = edit.poisson_ratio;
                t.density_kg_m3 = edit.density_kg_m3;
                t.restitution = edit.restitution;
                t.friction = edit.friction;
            }
            Command::SetKind { object, kind } => {
                t.object = Some(object);
                t.kind = Some(kind);
            }
            Command::Step { count } => t.count = Some(count),
            Command::Pause | Command::Resume | Command::Reset | Command::Shutdown => {}
        }
        t
    }
}

impl<O> CommandToml<O> {
    /// The keys set besides `command`.
    fn present(&self) -> Vec<&'static str> {
        [
            (self.object.is_some(), "object"),
            (self.impulse_n_s.is_some(), "impulse_n_s"),
            (self.point_m.is_some(), "point_m"),
            (self.velocity_m_s.is_some(), "velocity_m_s"),
            (
                self.angular_velocity_rad_s.is_some(),
                "angular_velocity_rad_s",
            ),
            (self.position_m.is_some(), "position_m"),
            (self.orientation_wxyz.is_some(), "orientation_wxyz"),
            (self.at_step.is_some(), "at_step"),
            (self.model.is_some(), "model"),
            (self.youngs_modulus_pa.is_some(), "youngs_modulus_pa"),
            (self.poisson_ratio.is_some(), "poisson_ratio"),
            (self.density_kg_m3.is_some(), "density_kg_m3"),
            (self.restitution.is_some(), "restitution"),
            (self.friction.is_some(), "friction"),
            (self.kind.is_some(), "kind"),
            (self.count.is_some(), "count"),
        ]
        .into_iter()
        .filter_map(|(set, key)| set.then_some(key))
        .collect()
    }

    /// The command, checked: every key it needs is there and no other key is.
    ///
    /// # Errors
    /// A message naming the command and the key: an unknown command, a missing key, a key that
    /// does not apply, or an `edit-material` that changes nothing.
    pub fn into_command(self) -> Result<Command<O>, String> {
        let allowed: &[&str] = match self.command.as_str() {
            "impulse" => &["object", "impulse_n_s", "point_m"],
            "set-velocity" => &["object", "velocity_m_s", "angular_velocity_rad_s"],
            "set-pose" => &["object", "position_m", "orientation_wxyz", "at_step"],
            "edit-material" => &[
                "object",
                "model",
                "youngs_modulus_pa",
                "poisson_ratio",
                "density_kg_m3",
                "restitution",
                "friction",
            ],
            "set-kind" => &["object", "kind"],
            "step" => &["count"],
            "pause" | "resume" | "reset" | "shutdown" => &[],
            other => {
                return Err(format!(
                    "unknown command `{other}` (impulse, set-velocity, set-pose, edit-material, set-kind, pause, resume, step, reset, shutdown)"
                ));
            }
        };
        if let Some(k) = self.present().into_iter().find(|k| !allowed.contains(k)) {
            return Err(format!("`{k}` does not apply to `{}`", self.command));
        }
        let name = self.command.clone();
        let need = |k: &str| format!("`{name}` needs `{k}`");
        let object = self.object.ok_or_else(|| need("object"));
        Ok(match self.command.as_str() {
            "impulse" => Command::Impulse {
                object: object?,
                impulse_n_s: self.impulse_n_s.ok_or_else(|| need("impulse_n_s"))?,
                point_m: self.point_m,
            },
            "set-velocity" => Command::SetVelocity {
                object: object?,
                velocity_m_s: self.velocity_m_s.ok_or_else(|| need("velocity_m_s"))?,
                angular_velocity_rad_s: self.angular_velocity_rad_s,
            },
            "set-pose" => Command::SetPose {
                object: object?,
                position_m: self.position_m.ok_or_else(|| need("position_m"))?,
                orientation_wxyz: self
                    .orientation_wxyz
                    .ok_or_else(|| need("orientation_wxyz"))?,
                at_step: self.at_step,
            },
            "edit-material" => {
                let edit = MaterialEdit {
                    model: self.model,
                    youngs_modulus_pa: self.youngs_modulus_pa,
                    poisson_ratio: self.poisson_ratio,
                    density_kg_m3: self.density_kg_m3,
                    restitution: self.restitution,
                    friction: self.friction,
                };
                if edit == MaterialEdit::default() {
                    return Err("`edit-material` changes nothing".into());
                }
                Command::EditMaterial {
                    object: object?,
                    edit,
                }
            }
            "set-kind" => Command::SetKind {
                object: object?,
                kind: self.kind.ok_or_else(|| need("kind"))?,
            },
            "step" => Command::Step {
                count: self.count.ok_or_else(|| need("count"))?,
            },
            "pause" => Command::Pause,
            "resume" => Command::Resume,
            "reset" => Command::Reset,
            _ => Command::Shutdown,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Command<String>, String> {
        toml::from_str::<CommandToml<String>>(text)
            .map_err(|e| e.to_string())?
            .into_command()
    }

    #[test]
    fn every_command_parses_from_its_keys_and_maps_to_ids() {
        let c = parse("command = \"impulse\"\nobject = \"ball\"\nimpulse_n_s = [0.0, 0.0, 2.0]")
            .unwrap();
        assert_eq!(c.name(), "impulse");
        let id = c
            .map_object(|n| if n == "ball" { Ok(7) } else { Err(n) })
            .unwrap();
        assert_eq!(
            id,
            Command::Impulse {
                object: 7,
                impulse_n_s: [0.0, 0.0, 2.0],
                point_m: None
            }
        );
        let c = parse("command = \"edit-material\"\nobject = \"b\"\nmodel = \"snow\"\nyoungs_modulus_pa = 1e5").unwrap();
        let Command::EditMaterial { edit, .. } = c else {
            panic!("{c:?}")
        };
        assert_eq!(edit.model, Some(MaterialModel::Snow));
        assert_eq!(edit.youngs_modulus_pa, Some(1e5));
        assert_eq!(edit.poisson_ratio, None);
        let c = parse("command = \"set-kind\"\nobject = \"b\"\nkind = \"rigid\"").unwrap();
        assert_eq!(c.name(), "set-kind");
        assert_eq!(
            parse("command = \"step\"\ncount = 3").unwrap(),
            Command::Step { count: 3 }
        );
        for name in ["pause", "resume", "reset", "shutdown"] {
            assert_eq!(
                parse(&format!("command = \"{name}\"")).unwrap().name(),
                name
            );
        }
    }

    #[test]
    fn every_command_round_trips_through_its_table() {
        let edit = MaterialEdit {
            model: Some(MaterialModel::Sand),
            friction: Some(0.4),
            ..MaterialEdit::default()
        };
        let all: [Command<String>; 11] = [
            Command::Impulse {
                object: "a".into(),
                impulse_n_s: [1.0, 2.0, 3.0],
                point_m: Some([0.0, 0.0, 0.1]),
            },
            Command::SetVelocity {
                object: "a".into(),
                velocity_m_s: [0.0, 1.0, 0.0],
                angular_velocity_rad_s: None,
            },
            Command::SetVelocity {
                object: "a".into(),
                velocity_m_s: [0.0, 1.0, 0.0],
                angular_velocity_rad_s: Some([0.0, 0.0, 2.0]),
            },
            Command::SetPose {
                object: "a".into(),
                position_m: [0.1, 0.2, 0.3],
                orientation_wxyz: [0.0, 1.0, 0.0, 0.0],
                at_step: Some(12),
            },
            Command::EditMaterial {
                object: "a".into(),
                edit,
            },
            Command::SetKind {
                object: "a".into(),
                kind: ObjectKind::Static,
            },
            Command::Pause,
            Command::Resume,
            Command::Step { count: 4 },
            Command::Reset,
            Command::Shutdown,
        ];
        for c in all {
            let text = toml::to_string(&CommandToml::from(c.clone())).unwrap();
            assert_eq!(parse(&text).unwrap(), c, "{text}");
        }
    }

    #[test]
    fn bad_commands_name_the_key_and_the_problem() {
        let cases = [
            (
                "command = \"impulse\"\nobject = \"a\"",
                "needs `impulse_n_s`",
            ),
            ("command = \"pause\"\nobject = \"a\"", "does not apply"),
            ("command = \"explode\"", "unknown command"),
            (
                "command = \"set-kind\"\nobject = \"a\"\nkind = \"gas\"",
                "unknown variant",
            ),
            (
                "command = \"edit-material\"\nobject = \"a\"",
                "changes nothing",
            ),
            ("command = \"pause\"\nbogus = 1", "bogus"),
            (
                "command = \"set-pose\"\nobject = \"a\"\nposition_m = [0.0, 0.0, 0.0]",
                "needs `orientation_wxyz`",
            ),
        ];
        for (text, want) in cases {
            let e = parse(text).unwrap_err();
            assert!(e.contains(want), "{text:?}: {e} lacks {want}");
        }
    }
}

//! The command vocabulary: what a scene `[[event]]`, a control timeline entry and a wire command
//! all are once parsed.

use serde::{Deserialize, Serialize};

use crate::{MaterialEdit, ObjectKind};

/// A command to a running simulation.
///
/// `O` names the target object: `u32` ids on the wire and inside the simulation, `String` names
/// in scene files and timelines ([`Command::map_object`] resolves one into the other). In TOML a
/// command is a table with `action` set to the variant's snake-case name and the variant's
/// fields as keys, the same in scene files and timelines:
///
/// ```toml
/// action = "impulse"
/// object = "ball"
/// impulse_n_s = [0.0, 0.0, 2.0]
/// point_m = [0.0, 0.0, 0.1]    # optional; the centre of mass when absent
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "action", rename_all = "snake_case", deny_unknown_fields)]
pub enum Command<O = u32> {
    /// Apply an impulse (N·s, world frame) to an object, at a point (m, world) or at its COM.
    Impulse {
        /// Target object.
        object: O,
        /// Impulse, N·s.
        impulse_n_s: [f64; 3],
        /// Point of application, metres; `None` = centre of mass.
        #[serde(default)]
        point_m: Option<[f64; 3]>,
    },
    /// Set an object's COM velocity, m/s (angular velocity unchanged).
    SetVelocity {
        /// Target object.
        object: O,
        /// Velocity, m/s.
        velocity_m_s: [f64; 3],
    },
    /// Edit an object's material; only the fields named change.
    EditMaterial {
        /// Target object.
        object: O,
        /// The fields to change.
        #[serde(flatten)]
        edit: MaterialEdit,
    },
    /// Change how an object moves.
    SetKind {
        /// Target object.
        object: O,
        /// New kind.
        kind: ObjectKind,
    },
    /// Stop stepping (frames and status keep flowing).
    Pause,
    /// Resume stepping.
    Resume,
    /// While paused, advance this many published frames (>= 1).
    Step {
        /// Frames to advance.
        count: u64,
    },
    /// Reset the scene to its initial state (bumps the scene generation).
    Reset,
    /// Ask the server to shut down cleanly.
    Shutdown,
}

impl<O> Command<O> {
    /// The object this command targets, if any.
    pub fn object(&self) -> Option<&O> {
        match self {
            Self::Impulse { object, .. }
            | Self::SetVelocity { object, .. }
            | Self::EditMaterial { object, .. }
            | Self::SetKind { object, .. } => Some(object),
            _ => None,
        }
    }

    /// The variant's snake-case name (`impulse`, `set_velocity`, ...), as written in TOML.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Impulse { .. } => "impulse",
            Self::SetVelocity { .. } => "set_velocity",
            Self::EditMaterial { .. } => "edit_material",
            Self::SetKind { .. } => "set_kind",
            Self::Pause => "pause",
            Self::Resume => "resume",
            Self::Step { .. } => "step",
            Self::Reset => "reset",
            Self::Shutdown => "shutdown",
        }
    }

    /// The same command with its target mapped by `f` (e.g. a name resolved to an id).
    ///
    /// # Errors
    /// Whatever `f` returns for the target.
    pub fn map_object<P, E>(self, f: impl FnOnce(O) -> Result<P, E>) -> Result<Command<P>, E> {
        Ok(match self {
            Self::Impulse {
                object,
                impulse_n_s,
                point_m,
            } => Command::Impulse {
                object: f(object)?,
                impulse_n_s,
                point_m,
            },
            Self::SetVelocity {
                object,
                velocity_m_s,
            } => Command::SetVelocity {
                object: f(object)?,
                velocity_m_s,
            },
            Self::EditMaterial { object, edit } => Command::EditMaterial {
                object: f(object)?,
                edit,
            },
            Self::SetKind { object, kind } => Command::SetKind {
                object: f(object)?,
                kind,
            },
            Self::Pause => Command::Pause,
            Self::Resume => Command::Resume,
            Self::Step { count } => Command::Step { count },
            Self::Reset => Command::Reset,
            Self::Shutdown => Command::Shutdown,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::MaterialModel;

    #[test]
    fn toml_commands_parse_with_names_and_map_to_ids() {
        let text = r#"
            [[e]]
            action = "impulse"
            object = "ball"
            impulse_n_s = [0.0, 0.0, 2.0]
            [[e]]
            action = "edit_material"
            object = "ball"
            model = "snow"
            youngs_modulus_pa = 1e5
            [[e]]
            action = "step"
            count = 3
        "#;
        #[derive(Deserialize)]
        struct Doc {
            e: Vec<Command<String>>,
        }
        let doc: Doc = toml::from_str(text).unwrap();
        let ids: Vec<Command> = doc
            .e
            .into_iter()
            .map(|c| c.map_object(|n| if n == "ball" { Ok(7) } else { Err(n) }).unwrap())
            .collect();
        assert_eq!(
            ids[0],
            Command::Impulse {
                object: 7,
                impulse_n_s: [0.0, 0.0, 2.0],
                point_m: None
            }
        );
        let Command::EditMaterial { object: 7, edit } = ids[1] else {
            panic!("{:?}", ids[1]);
        };
        assert_eq!(edit.model, Some(MaterialModel::Snow));
        assert_eq!(edit.youngs_modulus_pa, Some(1e5));
        assert_eq!(edit.poisson_ratio, None);
        assert_eq!(ids[2], Command::Step { count: 3 });
        assert_eq!(ids[2].name(), "step");
    }

    #[test]
    fn unknown_keys_are_refused() {
        let r: Result<Command<String>, _> =
            toml::from_str("action = \"impulse\"\nobject = \"a\"\nimpulse_n_s = [0.0,0.0,1.0]\nforce = 1");
        assert!(r.is_err());
    }
}

//! Typed commands and replies, and their conversion to and from the wire PODs
//! ([`CommandMsg`], [`ReplyMsg`]).
//!
//! Decoding never panics: an unknown kind or code decodes to a [`DecodeError`] that the server
//! answers with a rejection.

use crate::wire::{
    CommandMsg, LAYOUT_VERSION, REPLY_MESSAGE_BYTES, ReplyMsg, read_fixed_str, write_fixed_str,
};

/// Wire codes of [`CommandMsg::kind`].
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CommandKind {
    /// [`Command::Impulse`].
    Impulse = 1,
    /// [`Command::SetVelocity`].
    SetVelocity = 2,
    /// [`Command::EditMaterial`].
    EditMaterial = 3,
    /// [`Command::SetKind`].
    SetKind = 4,
    /// [`Command::Pause`].
    Pause = 5,
    /// [`Command::Resume`].
    Resume = 6,
    /// [`Command::Step`].
    Step = 7,
    /// [`Command::Reset`].
    Reset = 8,
    /// [`Command::Shutdown`].
    Shutdown = 9,
    /// [`Command::SetPose`].
    SetPose = 10,
}

/// [`CommandMsg::fields`]: `point_m` is present.
pub const FIELD_POINT: u32 = 1;
/// [`CommandMsg::fields`]: `code` (material model) is present.
pub const FIELD_MODEL: u32 = 2;
/// [`CommandMsg::fields`]: `youngs_modulus_pa` is present.
pub const FIELD_E: u32 = 4;
/// [`CommandMsg::fields`]: `poisson_ratio` is present.
pub const FIELD_NU: u32 = 8;
/// [`CommandMsg::fields`]: `density_kg_m3` is present.
pub const FIELD_DENSITY: u32 = 16;
/// [`CommandMsg::fields`]: `restitution` is present.
pub const FIELD_RESTITUTION: u32 = 32;
/// [`CommandMsg::fields`]: `friction` is present.
pub const FIELD_FRICTION: u32 = 64;
/// [`CommandMsg::fields`]: `angular_velocity_rad_s` is present.
pub const FIELD_ANGULAR: u32 = 128;
/// [`CommandMsg::fields`]: `count` is a pose's `at_step`.
pub const FIELD_AT_STEP: u32 = 256;

pub use splatphys_types::{
    Command, CommandToml, MaterialEdit, MaterialModel, ObjectKind, UnknownName,
};

/// Why a command message could not be decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum DecodeError {
    /// `kind` is not a known [`CommandKind`].
    #[error("unknown command kind {kind}")]
    UnknownKind {
        /// The code received.
        kind: u32,
    },
    /// The sender speaks another [`LAYOUT_VERSION`].
    #[error("layout version {sent}, this server speaks {LAYOUT_VERSION}")]
    LayoutVersion {
        /// The version the command carried.
        sent: u32,
    },
    /// `code` is not a known material model.
    #[error("unknown material model code {code}")]
    UnknownModel {
        /// The code received.
        code: u32,
    },
    /// `code` is not a known object kind.
    #[error("unknown object kind code {code}")]
    UnknownObjectKind {
        /// The code received.
        code: u32,
    },
}

/// Encodes `command` to the wire form with the given sequence number.
pub fn encode(command: &Command, sequence: u64) -> CommandMsg {
    let mut m = CommandMsg {
        sequence,
        layout_version: LAYOUT_VERSION,
        ..Default::default()
    };
    match *command {
        Command::Impulse {
            object,
            impulse_n_s,
            point_m,
        } => {
            m.kind = CommandKind::Impulse as u32;
            m.object_id = object;
            m.vector = impulse_n_s;
            if let Some(p) = point_m {
                m.point_m = p;
                m.fields |= FIELD_POINT;
            }
        }
        Command::SetVelocity {
            object,
            velocity_m_s,
            angular_velocity_rad_s,
        } => {
            m.kind = CommandKind::SetVelocity as u32;
            m.object_id = object;
            m.vector = velocity_m_s;
            if let Some(w) = angular_velocity_rad_s {
                m.angular_velocity_rad_s = w;
                m.fields |= FIELD_ANGULAR;
            }
        }
        Command::SetPose {
            object,
            position_m,
            orientation_wxyz,
            at_step,
        } => {
            m.kind = CommandKind::SetPose as u32;
            m.object_id = object;
            m.vector = position_m;
            m.orientation_wxyz = orientation_wxyz;
            if let Some(step) = at_step {
                m.count = step;
                m.fields |= FIELD_AT_STEP;
            }
        }
        Command::EditMaterial { object, edit } => {
            m.kind = CommandKind::EditMaterial as u32;
            m.object_id = object;
            let mut set = |flag: u32, v: Option<f64>, dst: &mut f64| {
                if let Some(v) = v {
                    *dst = v;
                    m.fields |= flag;
                }
            };
            set(FIELD_E, edit.youngs_modulus_pa, &mut m.youngs_modulus_pa);
            set(FIELD_NU, edit.poisson_ratio, &mut m.poisson_ratio);
            set(FIELD_DENSITY, edit.density_kg_m3, &mut m.density_kg_m3);
            set(FIELD_RESTITUTION, edit.restitution, &mut m.restitution);
            set(FIELD_FRICTION, edit.friction, &mut m.friction);
            if let Some(model) = edit.model {
                m.code = model.code();
                m.fields |= FIELD_MODEL;
            }
        }
        Command::SetKind { object, kind } => {
            m.kind = CommandKind::SetKind as u32;
            m.object_id = object;
            m.code = kind.code();
        }
        Command::Pause => m.kind = CommandKind::Pause as u32,
        Command::Resume => m.kind = CommandKind::Resume as u32,
        Command::Step { count } => {
            m.kind = CommandKind::Step as u32;
            m.count = count;
        }
        Command::Reset => m.kind = CommandKind::Reset as u32,
        Command::Shutdown => m.kind = CommandKind::Shutdown as u32,
    }
    m
}

/// Decodes the wire form. Values are not checked here; see [`crate::validate`].
///
/// # Errors
/// [`DecodeError`] for an unknown command kind, material model or object kind code.
pub fn decode(m: &CommandMsg) -> Result<Command, DecodeError> {
    if m.layout_version != LAYOUT_VERSION {
        return Err(DecodeError::LayoutVersion {
            sent: m.layout_version,
        });
    }
    let opt = |flag: u32, v: f64| (m.fields & flag != 0).then_some(v);
    Ok(match m.kind {
        1 => Command::Impulse {
            object: m.object_id,
            impulse_n_s: m.vector,
            point_m: (m.fields & FIELD_POINT != 0).then_some(m.point_m),
        },
        2 => Command::SetVelocity {
            object: m.object_id,
            velocity_m_s: m.vector,
            angular_velocity_rad_s: (m.fields & FIELD_ANGULAR != 0)
                .then_some(m.angular_velocity_rad_s),
        },
        3 => Command::EditMaterial {
            object: m.object_id,
            edit: MaterialEdit {
                model: if m.fields & FIELD_MODEL != 0 {
                    Some(
                        MaterialModel::from_code(m.code)
                            .ok_or(DecodeError::UnknownModel { code: m.code })?,
                    )
                } else {
                    None
                },
                youngs_modulus_pa: opt(FIELD_E, m.youngs_modulus_pa),
                poisson_ratio: opt(FIELD_NU, m.poisson_ratio),
                density_kg_m3: opt(FIELD_DENSITY, m.density_kg_m3),
                restitution: opt(FIELD_RESTITUTION, m.restitution),
                friction: opt(FIELD_FRICTION, m.friction),
            },
        },
        4 => Command::SetKind {
            object: m.object_id,
            kind: ObjectKind::from_code(m.code)
                .ok_or(DecodeError::UnknownObjectKind { code: m.code })?,
        },
        5 => Command::Pause,
        6 => Command::Resume,
        7 => Command::Step { count: m.count },
        8 => Command::Reset,
        9 => Command::Shutdown,
        10 => Command::SetPose {
            object: m.object_id,
            position_m: m.vector,
            orientation_wxyz: m.orientation_wxyz,
            at_step: (m.fields & FIELD_AT_STEP != 0).then_some(m.count),
        },
        kind => return Err(DecodeError::UnknownKind { kind }),
    })
}

/// Wire codes of [`ReplyMsg::reject_code`].
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RejectCode {
    /// Not rejected.
    None = 0,
    /// The message could not be decoded.
    Malformed = 1,
    /// A NaN or infinite value.
    NotFinite = 2,
    /// The object id does not exist.
    UnknownObject = 3,
    /// A value outside its physical range.
    OutOfRange = 4,
    /// The impulse exceeds the server's limit.
    ImpulseTooLarge = 5,
    /// The simulation refused it.
    Refused = 6,
}

impl RejectCode {
    /// Decodes a wire code (unknown codes map to `Refused`).
    pub fn from_code(code: u32) -> Self {
        use RejectCode::*;
        [
            None,
            Malformed,
            NotFinite,
            UnknownObject,
            OutOfRange,
            ImpulseTooLarge,
        ]
        .into_iter()
        .find(|c| *c as u32 == code)
        .unwrap_or(Refused)
    }
}

/// The server's answer to one command.
#[derive(Debug, Clone, PartialEq)]
pub enum Reply {
    /// Accepted; it takes effect at this step.
    Accepted {
        /// Step index at which the command takes effect.
        effective_step: u64,
        /// Scene generation after the command (a reset's reply names the new generation).
        generation: u32,
    },
    /// Rejected and not applied.
    Rejected {
        /// Category.
        code: RejectCode,
        /// Human-readable reason.
        reason: String,
    },
}

impl Reply {
    /// Encodes to the wire form; `generation` is the scene generation a rejected command left
    /// in place (an accepted one carries its own).
    pub fn to_msg(&self, sequence: u64, generation: u32) -> ReplyMsg {
        let mut m = ReplyMsg {
            sequence,
            scene_generation: generation,
            layout_version: LAYOUT_VERSION,
            ..Default::default()
        };
        match self {
            Reply::Accepted {
                effective_step,
                generation,
            } => {
                m.accepted = 1;
                m.effective_step = *effective_step;
                m.scene_generation = *generation;
            }
            Reply::Rejected { code, reason } => {
                m.reject_code = *code as u32;
                write_fixed_str(&mut m.message[..REPLY_MESSAGE_BYTES], reason);
            }
        }
        m
    }

    /// Decodes the wire form.
    pub fn from_msg(m: &ReplyMsg) -> Self {
        if m.accepted == 1 {
            Reply::Accepted {
                effective_step: m.effective_step,
                generation: m.scene_generation,
            }
        } else {
            Reply::Rejected {
                code: RejectCode::from_code(m.reject_code),
                reason: read_fixed_str(&m.message),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_command_round_trips_through_the_wire() {
        let cmds = [
            Command::Impulse {
                object: 3,
                impulse_n_s: [0.0, 0.0, 2.0],
                point_m: Some([1.0, 2.0, 3.0]),
            },
            Command::Impulse {
                object: 0,
                impulse_n_s: [1.0, 0.0, 0.0],
                point_m: None,
            },
            Command::SetVelocity {
                object: 1,
                velocity_m_s: [0.5, 0.0, 0.0],
                angular_velocity_rad_s: None,
            },
            Command::SetVelocity {
                object: 1,
                velocity_m_s: [0.5, 0.0, 0.0],
                angular_velocity_rad_s: Some([0.0, -1.0, 3.0]),
            },
            Command::SetPose {
                object: 4,
                position_m: [0.1, 0.2, 0.3],
                orientation_wxyz: [0.5, 0.5, 0.5, 0.5],
                at_step: Some(40),
            },
            Command::SetPose {
                object: 4,
                position_m: [0.1, 0.2, 0.3],
                orientation_wxyz: [1.0, 0.0, 0.0, 0.0],
                at_step: None,
            },
            Command::EditMaterial {
                object: 2,
                edit: MaterialEdit {
                    model: Some(MaterialModel::Snow),
                    youngs_modulus_pa: Some(1e5),
                    poisson_ratio: None,
                    density_kg_m3: Some(1000.0),
                    restitution: None,
                    friction: Some(0.3),
                },
            },
            Command::SetKind {
                object: 1,
                kind: ObjectKind::Rigid,
            },
            Command::Pause,
            Command::Resume,
            Command::Step { count: 7 },
            Command::Reset,
            Command::Shutdown,
        ];
        for (i, c) in cmds.iter().enumerate() {
            let m = encode(c, i as u64);
            assert_eq!(m.sequence, i as u64);
            assert_eq!(decode(&m).unwrap(), *c);
        }
    }

    #[test]
    fn unknown_codes_decode_to_errors_not_panics() {
        let m = CommandMsg {
            kind: 99,
            layout_version: LAYOUT_VERSION,
            ..Default::default()
        };
        assert_eq!(decode(&m), Err(DecodeError::UnknownKind { kind: 99 }));
        let m = CommandMsg {
            kind: 4,
            code: 17,
            layout_version: LAYOUT_VERSION,
            ..Default::default()
        };
        assert!(matches!(
            decode(&m),
            Err(DecodeError::UnknownObjectKind { code: 17 })
        ));
    }

    #[test]
    fn reply_round_trips_with_reason() {
        let r = Reply::Rejected {
            code: RejectCode::OutOfRange,
            reason: "nu = 0.6 outside (-1, 0.5)".into(),
        };
        let m = r.to_msg(5, 3);
        assert_eq!((m.scene_generation, m.layout_version), (3, LAYOUT_VERSION));
        assert_eq!(*m.message.last().unwrap(), 0);
        assert_eq!(Reply::from_msg(&m), r);
        let a = Reply::Accepted {
            effective_step: 12,
            generation: 4,
        };
        assert_eq!(Reply::from_msg(&a.to_msg(5, 3)), a);
    }

    #[test]
    fn another_layout_version_is_malformed() {
        let mut m = encode(&Command::Pause, 1);
        m.layout_version = 1;
        assert_eq!(decode(&m), Err(DecodeError::LayoutVersion { sent: 1 }));
    }
}

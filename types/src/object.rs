//! How an object moves.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::UnknownName;

/// How an object moves. The discriminant is the wire code.
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ObjectKind {
    /// Simulated with MPM on its own grid.
    #[default]
    Deformable = 0,
    /// A rigid body (skips MPM; angular momentum integrated).
    Rigid = 1,
    /// Does not move; a boundary for the others.
    Static = 2,
    /// Moves only as commanded (a pose to reach, or a velocity), with infinite mass in contacts:
    /// a hand or a tool driven by a client.
    Kinematic = 3,
}

impl ObjectKind {
    /// Every kind, in wire-code order.
    pub const ALL: [Self; 4] = [Self::Deformable, Self::Rigid, Self::Static, Self::Kinematic];

    /// The scene-file name (`deformable`, `rigid`, `static`, `kinematic`).
    pub const fn name(self) -> &'static str {
        match self {
            Self::Deformable => "deformable",
            Self::Rigid => "rigid",
            Self::Static => "static",
            Self::Kinematic => "kinematic",
        }
    }

    /// The wire code.
    pub const fn code(self) -> u32 {
        self as u32
    }

    /// Decodes a wire code (`None` for an unknown one).
    pub fn from_code(code: u32) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.code() == code)
    }
}

impl fmt::Display for ObjectKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for ObjectKind {
    type Err = UnknownName;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let key = s.trim().to_ascii_lowercase();
        Self::ALL
            .into_iter()
            .find(|k| k.name() == key)
            .ok_or_else(|| UnknownName {
                what: "object kind",
                name: s.to_string(),
                expected: Self::ALL.map(Self::name).join(", "),
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_round_trips_through_name_and_code() {
        for k in ObjectKind::ALL {
            assert_eq!(k.name().parse::<ObjectKind>(), Ok(k));
            assert_eq!(ObjectKind::from_code(k.code()), Some(k));
        }
        assert_eq!(ObjectKind::from_code(4), None);
        assert!("liquid".parse::<ObjectKind>().is_err());
    }
}

//! What a user asks the server to do, before object names are resolved to ids.
//!
//! Objects are named (`donut`, as in the scene header) or numbered (`3` or `#3`, the object
//! id). Vectors are written `x,y,z` in world coordinates (metres, seconds, newton-seconds).
//! Parsing never panics; bad text becomes a [`ControlError`].

use std::fmt;
use std::str::FromStr;

use serde::Deserialize;
use splatphys_ipc::command::{Command, MaterialModel, ObjectKind};

use crate::error::ControlError;

/// An object, by name or by id.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize)]
#[serde(untagged)]
pub enum ObjectRef {
    /// The object id (index into the scene's objects).
    Id(u32),
    /// A name from the scene header, or a number written as text (`"3"`, `"#3"`).
    Name(String),
}

impl ObjectRef {
    /// The id when the reference is a number (`3`, `"3"`, `"#3"`), without needing the scene.
    pub fn as_id(&self) -> Option<u32> {
        match self {
            ObjectRef::Id(id) => Some(*id),
            ObjectRef::Name(s) => s.strip_prefix('#').unwrap_or(s).parse().ok(),
        }
    }
}

impl FromStr for ObjectRef {
    type Err = ControlError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let s = s.trim();
        if s.is_empty() {
            return Err(ControlError::UnknownObject {
                name: String::new(),
                known: "an empty name matches none".into(),
            });
        }
        Ok(ObjectRef::Name(s.to_owned()))
    }
}

impl fmt::Display for ObjectRef {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ObjectRef::Id(id) => write!(f, "#{id}"),
            ObjectRef::Name(n) => f.write_str(n),
        }
    }
}

/// Parses `x,y,z` (spaces allowed, optional surrounding brackets) into three floats.
/// Non-finite values parse (`nan`, `inf`): the server rejects them, which is its job.
///
/// # Errors
/// [`ControlError::BadVector`] when there are not exactly three numbers.
pub fn parse_vec3(input: &str) -> Result<[f64; 3], ControlError> {
    parse_floats(input)
}

/// Parses `N` comma-separated floats, as [`parse_vec3`] (a quaternion `w,x,y,z` is `N` = 4).
///
/// # Errors
/// [`ControlError::BadVector`] when there are not exactly `N` numbers.
pub fn parse_floats<const N: usize>(input: &str) -> Result<[f64; N], ControlError> {
    let bad = |reason: String| ControlError::BadVector {
        input: input.to_owned(),
        reason,
    };
    let inner = input.trim().trim_start_matches('[').trim_end_matches(']');
    let parts: Vec<&str> = inner.split(',').map(str::trim).collect();
    if parts.len() != N {
        return Err(bad(format!("{} components, expected {N}", parts.len())));
    }
    let mut out = [0.0; N];
    for (o, p) in out.iter_mut().zip(&parts) {
        *o = p
            .parse()
            .map_err(|e| bad(format!("component `{p}`: {e}")))?;
    }
    Ok(out)
}

/// Parses a material model name (`jelly`, `fixed-corotated`, `neo-hookean`, `snow`, `sand`,
/// `metal`, `plasticine`, `foam`).
///
/// # Errors
/// [`ControlError::UnknownName`].
pub fn parse_model(input: &str) -> Result<MaterialModel, ControlError> {
    input.parse().map_err(
        |e: splatphys_ipc::command::UnknownName| ControlError::UnknownName {
            what: e.what,
            input: e.name,
            expected: e.expected,
        },
    )
}

/// Parses an object kind (`deformable`, `rigid`, `static`).
///
/// # Errors
/// [`ControlError::UnknownName`].
pub fn parse_kind(input: &str) -> Result<ObjectKind, ControlError> {
    match input.trim().to_ascii_lowercase().as_str() {
        "mpm" => Ok(ObjectKind::Deformable),
        "fixed" => Ok(ObjectKind::Static),
        _ => input
            .parse()
            .map_err(
                |e: splatphys_ipc::command::UnknownName| ControlError::UnknownName {
                    what: e.what,
                    input: e.name,
                    expected: e.expected,
                },
            ),
    }
}

/// A command with its object not yet resolved to an id: the one command vocabulary
/// ([`Command`]) with objects named or numbered.
pub type Action = Command<ObjectRef>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vectors_parse_with_spaces_brackets_and_signs() {
        assert_eq!(parse_vec3("0,0,2").unwrap(), [0.0, 0.0, 2.0]);
        assert_eq!(parse_vec3(" [-1.5, 2e-3 ,3] ").unwrap(), [-1.5, 0.002, 3.0]);
        assert!(parse_vec3("nan,0,0").unwrap()[0].is_nan());
    }

    #[test]
    fn malformed_vectors_are_errors_not_panics() {
        for bad in ["", "1,2", "1,2,3,4", "a,b,c", "1,,2", "1;2;3"] {
            assert!(
                matches!(parse_vec3(bad), Err(ControlError::BadVector { .. })),
                "{bad:?}"
            );
        }
    }

    #[test]
    fn numbered_objects_resolve_without_a_scene() {
        assert_eq!(ObjectRef::Id(4).as_id(), Some(4));
        assert_eq!("#3".parse::<ObjectRef>().unwrap().as_id(), Some(3));
        assert_eq!("12".parse::<ObjectRef>().unwrap().as_id(), Some(12));
        assert_eq!("donut".parse::<ObjectRef>().unwrap().as_id(), None);
        assert!("  ".parse::<ObjectRef>().is_err());
    }

    #[test]
    fn kinds_and_models_parse_by_name() {
        assert_eq!(parse_kind("Rigid").unwrap(), ObjectKind::Rigid);
        assert!(parse_kind("gas").is_err());
        assert_eq!(
            parse_model("neo_hookean").unwrap(),
            MaterialModel::NeoHookean
        );
        assert!(matches!(
            parse_model("rubber"),
            Err(ControlError::UnknownName { .. })
        ));
    }
}

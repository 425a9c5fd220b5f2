//! splatphys-types: the one vocabulary the simulation core (`splatphys-core`) and the protocol
//! (`splatphys-ipc`) share, as plain types with no solver and no IPC in them:
//!
//! - [`MaterialModel`]: the constitutive models, with their scene-file names and wire codes;
//! - [`ObjectKind`]: how an object moves;
//! - [`MaterialEdit`]: a change of an object's material that names only what it changes;
//! - [`Command`]: what scene `[[event]]`s, control timelines and wire commands all become, and
//!   [`CommandToml`], the one way scene files and timelines write one;
//! - [`limits`]: the bounds on commands and scene values, one set for the protocol's validation,
//!   the scene loader and the world.
//!
//! Every table of names in the workspace derives from these enums (`ALL`, `name()`), so a new
//! variant cannot be forgotten in one spelling.

mod command;
mod command_toml;
pub mod limits;
mod material;
mod object;

pub use command::Command;
pub use command_toml::CommandToml;
pub use material::{MaterialEdit, MaterialModel, UnknownName};
pub use object::ObjectKind;

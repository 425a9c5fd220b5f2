//! splatphys-control: drive a running splatphys server from another process.
//!
//! - [`action`]: what a user asks for ([`action::Action`]), with objects named or numbered
//!   ([`action::ObjectRef`]), and the text parsers the CLI and timelines share;
//! - [`session`]: a connection to one server that resolves object names from the scene header
//!   and sends commands, waiting for their replies;
//! - [`timeline`]: commands scheduled at simulated times, from a TOML file;
//! - [`follow`]: a closed-loop PD controller that pushes an object's centre of mass (COM)
//!   towards a target with impulses and measures the loop latency;
//! - [`latency`]: percentiles of latency samples.
//!
//! Every command gets a reply from the server: accepted with the step at which it takes
//! effect, or rejected with a reason (see docs/reference/protocol.md).

pub mod action;
pub mod cli;
pub mod error;
pub mod follow;
pub mod latency;
pub mod session;
pub mod timeline;

pub use action::{Action, ObjectRef};
pub use error::ControlError;
pub use session::{SceneInfo, Session, SessionOptions};

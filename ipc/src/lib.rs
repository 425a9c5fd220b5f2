//! splatphys_ipc: the wire contract over iceoryx2, the co-simulation server and client helpers.
//! The protocol alone: it does not depend on the simulation core.
//!
//! - [`wire`]: every type that crosses a process boundary (`#[repr(C)]` POD);
//! - [`services`]: every service's name and settings, defined once for servers and clients;
//! - [`simulation`]: the [`Simulation`] trait the server drives ([`fake::FreeFall`] for tests);
//! - [`server`]: the server loop; [`client`]: subscribe, detect a dead server, send commands;
//! - [`command`] and [`validate`]: typed commands and their validation.

pub mod backpressure;
pub mod client;
pub mod command;
pub mod error;
pub mod fake;
pub mod heartbeat;
pub mod server;
pub mod services;
pub mod simulation;
pub mod validate;
pub mod wire;

pub use error::IpcError;
pub use simulation::{Advance, Simulation, SimulationError};

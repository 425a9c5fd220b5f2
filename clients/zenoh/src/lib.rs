//! splatphys-zenoh: a bridge from a splatphys server's shared-memory services to Zenoh, so
//! clients on other machines (and in any language Zenoh speaks) hear frames, objects, status,
//! the scene and object names with the shared-memory contract's byte layouts, and send
//! commands as queries.
//!
//! - [`keys`]: the key expressions, in one place;
//! - [`bridge`]: the loop, the Zenoh configuration (loopback by default; TLS and access control
//!   from a Zenoh configuration file);
//! - [`ros2`]: with `--ros2`, the same server as ROS 2 topics in rmw_zenoh's conventions;
//! - [`cli`]: the command line.

pub mod bridge;
pub mod cli;
pub mod keys;
pub mod ros2;

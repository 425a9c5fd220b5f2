//! `splatphys-web`: watch a running splatphys server live in a browser and push it.
//!
//! A bridge process follows the server's services as a best-effort client ([`feed`]), serves a
//! WebGL2 page compiled into the binary and one WebSocket per page ([`server`]), and forwards
//! the page's commands to the server ([`commands`]). Frames go to the page as binary messages
//! ([`messages`]): the static part once per scene generation, then only what changed, and never
//! more frames than the page draws.

pub mod cli;
pub mod commands;
pub mod feed;
pub mod messages;
pub mod server;

pub use server::{CameraJson, Stats, WebConfig, serve};

//! splatphys: the application around the simulation core. The `splatphys` command (run, serve,
//! select, align, inspect, uplift, bench) is [`cli`], each subcommand a module ([`run`],
//! [`serve`], [`select`], [`align`], [`inspect`], [`uplift`]); `src/main.rs` only dispatches. What the subcommands share:
//!
//! - [`world_sim`]: the adapter that makes a sim-core [`World`](splatphys_core::world::World) a
//!   server-ready [`Simulation`](splatphys_ipc::Simulation);
//! - [`device`]: `--device` (deformable objects' MPM on a GPU where their situation allows);
//! - [`level_of_detail`]: `--budget-fps` and `--spacing-from` (calibrated or recorded level of
//!   detail);
//! - [`plan`]: what the parent of `splatphys run` reads from the scene, once;
//! - [`report`]: `server.json` and `summary.json` as typed reports;
//! - [`view`]: the browser viewer as a child process (`--view`);
//! - [`child_args`]: the arguments of every child process, built in one place;
//! - [`calibration`] and [`trace`]: the timed in-process runs behind `--budget-fps` (the
//!   benchmarks of `splatphys-bench` use them too).

pub mod align;
pub mod calibration;
pub mod child_args;
pub mod cli;
pub mod device;
pub mod inspect;
pub mod level_of_detail;
pub mod plan;
pub mod report;
pub mod run;
pub mod select;
pub mod serve;
pub mod trace;
pub mod uplift;
pub mod view;
pub mod world_sim;

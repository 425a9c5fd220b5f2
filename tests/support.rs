//! Support for the end-to-end tests across processes: the workspace's binaries, refused when
//! stale ([`bin`]); child processes killed on drop ([`Proc`]) and bounded waits on them; a
//! per-test iceoryx2 file prefix, service prefix and loopback port ([`iox_prefix`],
//! [`service_prefix`], [`free_port`]) and the check that nothing of it is left behind
//! ([`leftovers`]); `splatphys serve --fake` and
//! `splatphys-probe` ([`fake_server`], [`probe`]); and reading what the processes wrote: JSON
//! lines, CSV tables, PNG frames.
//!
//! Deadlines here only catch hangs; no test asserts wall-clock speed (CI runs on a loaded
//! 2-core machine).
//!
//! Cargo builds a package's binaries for `cargo test` only when that package has an integration
//! test of its own, so every package with a binary keeps one (else [`bin`] finds it stale).

#[path = "support/bins.rs"]
mod bins;
#[path = "support/iox.rs"]
mod iox;
#[path = "support/output.rs"]
mod output;
#[path = "support/process.rs"]
mod process;
#[path = "support/servers.rs"]
mod servers;

pub use bins::{bin, workspace};
pub use iox::{IOX_PREFIX_ENV, free_port, iox_prefix, leftovers, service_prefix};
pub use output::{
    Row, json_field, json_objects, lit_pixels, num, pngs, read_csv, run_bench, summary,
};
pub use process::{Exit, Proc, last_line, wait_for, wait_until};
pub use servers::{fake_server, lost_by_recorders, probe, stepping_server, stop_server};

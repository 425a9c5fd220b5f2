//! Feature unification for the splatphys workspace (no code).
//!
//! Cargo resolves a crate's features once per build, over the packages that build needs. The
//! tests' dependencies (proptest, criterion) turn on more features of `regex-automata`,
//! `regex-syntax` and `getrandom` than the libraries do; without this crate every crate above
//! them (tracing-subscriber, Zenoh, kiddo, zip) is compiled twice in release (`cargo build`,
//! then `cargo test`) and checked twice (`cargo clippy --all-targets`, then `cargo doc`). As a
//! workspace member that depends on them with the test graph's features, this crate makes both
//! graphs the same for every `--workspace` build.

use getrandom as _;
use regex_automata as _;
use regex_syntax as _;

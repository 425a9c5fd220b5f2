//! Feature unification for the splatphys workspace (no code).
//!
//! Cargo resolves a crate's features once per build, over the packages that build needs. The
//! tests' dependencies (proptest, criterion) turn on more features of `regex-automata`,
//! `regex-syntax` and `getrandom` than the libraries do; without this crate every crate above
//! them (tracing-subscriber, Zenoh, kiddo, zip) is compiled twice: once for `cargo build` and
//! `cargo doc`, once for `cargo test`. As a workspace member that depends on them with the test
//! graph's features, this crate makes both graphs the same.

use getrandom as _;
use regex_automata as _;
use regex_syntax as _;

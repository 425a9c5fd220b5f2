//! Support for the end-to-end tests: the workspace's binaries, child processes killed on drop,
//! bounded waits, per-test service prefixes and PNG checks.

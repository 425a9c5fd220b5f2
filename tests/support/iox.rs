//! Per-test iceoryx2 names, and what a test left of them in /dev/shm or /tmp/iceoryx2.
//!
//! Every test gives its processes an iceoryx2 file prefix of its own through
//! [`IOX_PREFIX_ENV`] (so tests running side by side never see each other's services or shared
//! memory) and a service prefix of its own, and ends by checking that nothing of that file prefix
//! is left.

/// The environment variable the splatphys processes read their iceoryx2 file prefix from.
pub const IOX_PREFIX_ENV: &str = "SPLATPHYS_IOX2_PREFIX";

/// The iceoryx2 file prefix of test `test` in this test process: `spxt_<test>_<pid>_`.
pub fn iox_prefix(test: &str) -> String {
    format!("spxt_{test}_{}_", std::process::id())
}

/// The service prefix of test `test` in this test process: `t/<test>-<pid>`.
pub fn service_prefix(test: &str) -> String {
    format!("t/{test}-{}", std::process::id())
}

/// Files of iceoryx2 prefix `iox` left in /dev/shm, /tmp/iceoryx2/services or /tmp/iceoryx2/nodes
/// (node folders included), except iceoryx2's persistent 16-byte `*.global_mgmt` node counter,
/// which it keeps per prefix on purpose.
pub fn leftovers(iox: &str) -> Vec<String> {
    let mut found = Vec::new();
    for dir in ["/dev/shm", "/tmp/iceoryx2/services", "/tmp/iceoryx2/nodes"] {
        for e in std::fs::read_dir(dir).into_iter().flatten().flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            if name.starts_with(iox) && !name.ends_with(".global_mgmt") {
                found.push(format!("{dir}/{name}"));
            }
        }
    }
    // Node folders are named by node id; look inside them for the prefix.
    for node in std::fs::read_dir("/tmp/iceoryx2/nodes")
        .into_iter()
        .flatten()
        .flatten()
        .filter(|e| e.path().is_dir())
    {
        for f in std::fs::read_dir(node.path())
            .into_iter()
            .flatten()
            .flatten()
        {
            if f.file_name().to_string_lossy().starts_with(iox) {
                found.push(f.path().display().to_string());
            }
        }
    }
    found
}

/// A TCP port on 127.0.0.1 free at the time of the call (for a test's Zenoh endpoint).
pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .expect("a free loopback port")
        .port()
}

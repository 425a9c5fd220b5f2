//! Support shared by the in-process server tests: an iceoryx2 file prefix per test binary and
//! a look at what of it is left in /dev/shm. Each test binary uses what it needs.
#![allow(dead_code)]

/// The iceoryx2 file prefix of this test binary (`<tag>_<pid>_`), set once for the process
/// before any iceoryx2 node exists.
pub fn init(tag: &str) -> String {
    static ONCE: std::sync::Once = std::sync::Once::new();
    let iox = format!("{tag}_{}_", std::process::id());
    ONCE.call_once(|| {
        // SAFETY: every test calls this first, so the variable is set before any thread reads
        // the environment (iceoryx2 nodes read it when created).
        unsafe { std::env::set_var("SPLATPHYS_IOX2_PREFIX", &iox) };
    });
    iox
}

/// Files of iceoryx2 prefix `iox` left in /dev/shm (iceoryx2 keeps one 16-byte
/// `*.global_mgmt` node counter per prefix on purpose).
pub fn leftovers(iox: &str) -> Vec<String> {
    std::fs::read_dir("/dev/shm")
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(iox) && !n.ends_with(".global_mgmt"))
        .collect()
}

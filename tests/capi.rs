//! The C library against a live server: a frame it lends lies in the server's shared memory (not
//! a copy); the C example (`clients/c/examples/frames_and_push.c`)
//! and the C++ one (`frames.cpp`, through the RAII wrapper) are compiled with the system
//! compiler against `libsplatphys_client.a` and run against `splatphys serve --fake`: they print
//! each frame's step and Gaussian count, push an object and get the server's acceptance. Skipped,
//! with a message, where there is no C compiler or the library is not built.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use splatphys_tests::{
    IOX_PREFIX_ENV, Proc, iox_prefix, leftovers, service_prefix, stepping_server, stop_server,
    workspace,
};

/// `libsplatphys_client.a` of the running test's profile, when built at least as recently as
/// its source.
fn static_library() -> Result<PathBuf, String> {
    let exe = std::env::current_exe().map_err(|e| e.to_string())?;
    let profile = exe
        .parent()
        .and_then(Path::parent)
        .ok_or("no profile folder")?;
    let lib = profile.join("libsplatphys_client.a");
    let built = std::fs::metadata(&lib)
        .and_then(|m| m.modified())
        .map_err(|e| {
            format!(
                "{}: {e} (cargo build --release -p splatphys-capi)",
                lib.display()
            )
        })?;
    let source = std::fs::metadata(workspace().join("clients/capi/src/lib.rs"))
        .and_then(|m| m.modified())
        .map_err(|e| e.to_string())?;
    if built < source {
        return Err(format!(
            "{} is older than its source (cargo build --release -p splatphys-capi)",
            lib.display()
        ));
    }
    Ok(lib)
}

fn compile(
    compiler: &str,
    source: &str,
    lib: &Path,
    out: &Path,
    extra: &[&str],
) -> Result<(), String> {
    let c = workspace().join("clients/c");
    let status = Command::new(compiler)
        .args(extra)
        .arg("-Wall")
        .arg("-Werror")
        .arg(format!("-I{}", c.display()))
        .arg(c.join("examples").join(source))
        .arg(lib)
        .args(["-lpthread", "-ldl", "-lm", "-o"])
        .arg(out)
        .output()
        .map_err(|e| format!("{compiler}: {e}"))?;
    if !status.status.success() {
        panic!(
            "{compiler} {source}:\n{}",
            String::from_utf8_lossy(&status.stderr)
        );
    }
    Ok(())
}

/// The tests of this binary run one at a time: one sets the process environment, which another
/// thread spawning children must not read meanwhile.
static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

#[test]
fn c_and_cpp_examples_read_frames_and_push_an_object() {
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let lib = match static_library() {
        Ok(lib) => lib,
        Err(why) => {
            eprintln!("skipped: {why}");
            return;
        }
    };
    let dir = tempfile::tempdir().unwrap();
    let c_exe = dir.path().join("frames_and_push");
    let cpp_exe = dir.path().join("frames_cpp");
    if let Err(why) = compile("cc", "frames_and_push.c", &lib, &c_exe, &["-std=c11"]) {
        eprintln!("skipped: no C compiler ({why})");
        return;
    }
    compile("c++", "frames.cpp", &lib, &cpp_exe, &["-std=c++17"])
        .expect("a C++ compiler beside the C one");

    let iox = iox_prefix("capi");
    let prefix = service_prefix("capi");
    let server = stepping_server(&iox, &prefix, 200, &[]);
    for (exe, step_line, push_line) in [
        (&c_exe, "frame ", "push accepted for object 1"),
        (&cpp_exe, "c++ frame ", "c++ push accepted"),
    ] {
        let run = Proc::spawn(
            Command::new(exe)
                .args([prefix.as_str(), "cube1", "5"])
                .env(IOX_PREFIX_ENV, &iox)
                .stdout(Stdio::piped())
                .stderr(Stdio::piped()),
        )
        .wait_exit(Duration::from_secs(60));
        assert_eq!(
            run.code,
            Some(0),
            "{}: {}{}",
            exe.display(),
            run.out,
            run.err
        );
        let frames: Vec<&str> = run
            .out
            .lines()
            .filter(|l| l.starts_with(step_line))
            .collect();
        assert_eq!(frames.len(), 5, "{}", run.out);
        // The fake scene: two objects of 200 Gaussians each.
        assert!(
            frames.iter().all(|l| l.contains("gaussians 400")),
            "{}",
            run.out
        );
        assert!(run.out.contains(push_line), "{}", run.out);
        assert!(run.out.contains("objects 2"), "{}", run.out);
        let statuses = if exe == &c_exe { 3 } else { 1 };
        assert_eq!(
            run.out.matches("status step").count(),
            statuses,
            "{}",
            run.out
        );
    }
    let stopped = stop_server(server);
    assert!(stopped.contains("stopped"), "{stopped}");
    assert!(leftovers(&iox).is_empty(), "{:?}", leftovers(&iox));
}

#[test]
fn a_borrowed_frame_is_not_a_copy() {
    use splatphys_client::{
        splatphys_Result, splatphys_connect, splatphys_disconnect, splatphys_release_frame,
        splatphys_wait_frame,
    };
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let iox = iox_prefix("capi_zero_copy");
    let prefix = service_prefix("capi_zero_copy");
    let server = stepping_server(&iox, &prefix, 100, &[]);
    // SAFETY: iceoryx2 reads the prefix when a node is created; this is the only test of this
    // binary that creates one in-process, and no other test runs meanwhile (ONE_AT_A_TIME).
    unsafe { std::env::set_var(IOX_PREFIX_ENV, &iox) };
    let c_prefix = std::ffi::CString::new(prefix).unwrap();
    let mut client = std::ptr::null_mut();
    // SAFETY: a valid string and out pointer.
    let r = unsafe { splatphys_connect(c_prefix.as_ptr(), 10.0, &mut client) };
    assert_eq!(r, splatphys_Result::SPLATPHYS_OK);
    let (mut header, mut gaussians, mut count) = (std::ptr::null(), std::ptr::null(), 0usize);
    let t0 = std::time::Instant::now();
    loop {
        // SAFETY: a live client and writable out pointers.
        let r =
            unsafe { splatphys_wait_frame(client, 1.0, &mut header, &mut gaussians, &mut count) };
        if r == splatphys_Result::SPLATPHYS_OK {
            break;
        }
        assert!(t0.elapsed() < Duration::from_secs(20), "no frame: {r:?}");
    }
    assert_eq!(count, 200);
    // The payload's address lies in a mapping of a POSIX shared-memory file (/dev/shm/...):
    // the server's segment, not a copy on our heap.
    let address = gaussians as usize;
    let maps = std::fs::read_to_string("/proc/self/maps").unwrap();
    let mapping = maps
        .lines()
        .find(|l| {
            let range = l.split_whitespace().next().unwrap_or("");
            let mut ends = range
                .split('-')
                .map(|h| usize::from_str_radix(h, 16).unwrap_or(0));
            let (lo, hi) = (ends.next().unwrap_or(0), ends.next().unwrap_or(0));
            (lo..hi).contains(&address)
        })
        .expect("the frame's address is mapped");
    assert!(mapping.contains("/dev/shm/"), "{mapping}");
    // SAFETY: the client is live until disconnected here, once.
    unsafe {
        splatphys_release_frame(client);
        splatphys_disconnect(client);
    }
    stop_server(server);
}

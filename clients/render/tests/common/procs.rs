//! Helpers of the process tests: child processes killed on drop, bounded waits, PNG checks.
#![allow(dead_code)]

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::Child;
use std::time::{Duration, Instant};

/// The renderer binary of this package.
pub const RENDER: &str = env!("CARGO_BIN_EXE_splatphys-render");

/// A child process killed (and reaped) on drop, so a failing test leaves nothing running.
pub struct Proc(pub Child);

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Exit code, stdout, stderr.
pub struct Exit {
    pub code: Option<i32>,
    pub stdout: String,
    pub stderr: String,
}

/// Waits for `p` to exit within `timeout`, reading its pipes in the background; kills it and
/// panics after the timeout.
pub fn wait_exit(mut p: Proc, timeout: Duration) -> Exit {
    let reader = |pipe: Option<Box<dyn Read + Send>>| {
        std::thread::spawn(move || {
            let mut s = String::new();
            if let Some(mut r) = pipe {
                let _ = r.read_to_string(&mut s);
            }
            s
        })
    };
    let out = reader(
        p.0.stdout
            .take()
            .map(|o| Box::new(o) as Box<dyn Read + Send>),
    );
    let err = reader(
        p.0.stderr
            .take()
            .map(|e| Box::new(e) as Box<dyn Read + Send>),
    );
    let start = Instant::now();
    let status = loop {
        if let Some(st) = p.0.try_wait().expect("try_wait") {
            break st;
        }
        if start.elapsed() > timeout {
            let _ = p.0.kill();
            let _ = p.0.wait();
            let stderr = err.join().unwrap_or_default();
            panic!("process did not exit within {timeout:?}; stderr:\n{stderr}");
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    Exit {
        code: status.code(),
        stdout: out.join().unwrap_or_default(),
        stderr: err.join().unwrap_or_default(),
    }
}

/// The PNGs in `dir`, sorted by name.
pub fn pngs(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|rd| {
            rd.flatten()
                .map(|e| e.path())
                .filter(|p| p.extension().is_some_and(|x| x == "png"))
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// Pixels of `png` that differ from the black background.
pub fn lit_pixels(png: &Path) -> usize {
    let img = image::open(png).expect("readable PNG").into_rgb8();
    img.pixels().filter(|p| p.0 != [0, 0, 0]).count()
}

/// The last line of `stdout` as JSON.
pub fn summary(stdout: &str) -> serde_json::Value {
    let line = stdout.lines().last().unwrap_or("");
    serde_json::from_str(line).unwrap_or_else(|e| panic!("summary `{line}` is not JSON: {e}"))
}

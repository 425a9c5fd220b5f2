//! Child processes killed on drop, and bounded waits on them and their output.

use std::io::{BufRead, BufReader, Read};
use std::path::Path;
use std::process::{Child, Command};
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

/// How long a pipe may stay open after its process exited (a grandchild holding it).
const PIPE_GRACE: Duration = Duration::from_secs(10);

/// A child process, killed (SIGKILL, which also ends a SIGSTOPped one) and reaped when dropped,
/// so a failing test leaves nothing running.
pub struct Proc {
    child: Child,
    /// The program's file name and first argument, for messages.
    what: String,
}

impl Drop for Proc {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
        }
        let _ = self.child.wait();
    }
}

/// How a process ended and what it wrote.
#[derive(Debug)]
pub struct Exit {
    /// Exit code; `None` when a signal ended it.
    pub code: Option<i32>,
    /// Its stdout, unless taken before ([`Proc::stdout_lines`], [`Proc::wait_line`]) or not piped.
    pub out: String,
    /// Its stderr, unless not piped.
    pub err: String,
}

impl Proc {
    /// Spawns `cmd` with the stdio it was given.
    ///
    /// # Panics
    /// When the program cannot be started.
    pub fn spawn(cmd: &mut Command) -> Self {
        let program = Path::new(cmd.get_program());
        let mut what = program
            .file_name()
            .unwrap_or(program.as_os_str())
            .to_string_lossy()
            .into_owned();
        if let Some(first) = cmd.get_args().next() {
            what = format!("{what} {}", first.to_string_lossy());
        }
        let child = cmd.spawn().unwrap_or_else(|e| panic!("spawn {what}: {e}"));
        Self { child, what }
    }

    /// The process id.
    pub fn id(&self) -> u32 {
        self.child.id()
    }

    /// Sends `signal` ("TERM", "STOP", "CONT", "KILL", ...) with kill(1).
    ///
    /// # Panics
    /// When kill(1) fails.
    pub fn signal(&self, signal: &str) {
        let st = Command::new("kill")
            .args([&format!("-{signal}"), &self.id().to_string()])
            .status()
            .expect("run kill");
        assert!(st.success(), "kill -{signal} {} failed", self.what);
    }

    /// SIGKILL and reap.
    ///
    /// # Panics
    /// When the process cannot be signalled.
    pub fn kill9(&mut self) {
        self.child
            .kill()
            .unwrap_or_else(|e| panic!("kill -9 {}: {e}", self.what));
        let _ = self.child.wait();
    }

    /// Forwards every stdout line to the returned channel (from a reader thread); the channel
    /// disconnects when the process closes its stdout.
    ///
    /// # Panics
    /// When stdout was not piped or was taken already.
    pub fn stdout_lines(&mut self) -> Receiver<String> {
        let out = self
            .child
            .stdout
            .take()
            .expect("stdout piped and not taken yet");
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(out).lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        rx
    }

    /// Takes stdout and waits for a line containing `needle`, within `timeout`; the rest of
    /// stdout is read and dropped.
    ///
    /// # Panics
    /// When no such line comes in time.
    pub fn wait_line(&mut self, needle: &str, timeout: Duration) -> String {
        let lines = self.stdout_lines();
        let line = wait_for(&lines, needle, timeout);
        // Keep draining so the process never blocks on a full pipe.
        std::thread::spawn(move || lines.iter().for_each(drop));
        line
    }

    /// Waits for the process to exit within `timeout`, reading its pipes meanwhile.
    ///
    /// # Panics
    /// When it is still running after `timeout` (it is killed first; the panic shows its
    /// stderr), or a pipe stays open long after it exited.
    pub fn wait_exit(mut self, timeout: Duration) -> Exit {
        let stdout = read_all(self.child.stdout.take());
        let stderr = read_all(self.child.stderr.take());
        let t0 = Instant::now();
        let status = loop {
            if let Some(st) = self.child.try_wait().expect("try_wait") {
                break st;
            }
            if t0.elapsed() > timeout {
                let _ = self.child.kill();
                let _ = self.child.wait();
                let err = stderr.recv_timeout(PIPE_GRACE).unwrap_or_default();
                panic!(
                    "{} did not exit within {timeout:?}; stderr:\n{err}",
                    self.what
                );
            }
            std::thread::sleep(Duration::from_millis(5));
        };
        let collect = |pipe: Receiver<String>, name: &str| {
            pipe.recv_timeout(PIPE_GRACE).unwrap_or_else(|_| {
                panic!(
                    "{}: {name} still open {PIPE_GRACE:?} after it exited",
                    self.what
                )
            })
        };
        Exit {
            code: status.code(),
            out: collect(stdout, "stdout"),
            err: collect(stderr, "stderr"),
        }
    }

    /// [`Proc::wait_exit`], then checks the exit code is 0.
    ///
    /// # Panics
    /// As [`Proc::wait_exit`], and on any other exit (showing stderr).
    pub fn wait_success(self, timeout: Duration) -> Exit {
        let what = self.what.clone();
        let e = self.wait_exit(timeout);
        assert_eq!(e.code, Some(0), "{what} failed; stderr:\n{}", e.err);
        e
    }

    /// SIGTERM (a clean shutdown: a server removes its services), then [`Proc::wait_exit`].
    ///
    /// # Panics
    /// As [`Proc::signal`] and [`Proc::wait_exit`].
    pub fn terminate(self, timeout: Duration) -> Exit {
        self.signal("TERM");
        self.wait_exit(timeout)
    }
}

/// Reads `pipe` to its end on a thread; the text arrives on the returned channel ("" for none).
fn read_all(pipe: Option<impl Read + Send + 'static>) -> Receiver<String> {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut text = String::new();
        if let Some(mut pipe) = pipe {
            let _ = pipe.read_to_string(&mut text);
        }
        let _ = tx.send(text);
    });
    rx
}

/// Waits on `lines` (from [`Proc::stdout_lines`]) for one containing `needle`.
///
/// # Panics
/// When none comes within `timeout`, or stdout closes first.
pub fn wait_for(lines: &Receiver<String>, needle: &str, timeout: Duration) -> String {
    let t0 = Instant::now();
    loop {
        match lines.recv_timeout(timeout.saturating_sub(t0.elapsed())) {
            Ok(line) if line.contains(needle) => return line,
            Ok(_) => {}
            Err(RecvTimeoutError::Timeout) => panic!("no line with {needle:?} within {timeout:?}"),
            Err(RecvTimeoutError::Disconnected) => panic!("stdout closed before {needle:?}"),
        }
    }
}

/// The last line of `lines` once the writer closed its stdout.
///
/// # Panics
/// When stdout is still open after `timeout`.
pub fn last_line(lines: &Receiver<String>, timeout: Duration) -> String {
    let t0 = Instant::now();
    let mut last = String::new();
    loop {
        match lines.recv_timeout(timeout.saturating_sub(t0.elapsed())) {
            Ok(line) => last = line,
            Err(RecvTimeoutError::Disconnected) => return last,
            Err(RecvTimeoutError::Timeout) => panic!("stdout still open after {timeout:?}"),
        }
    }
}

/// Polls `done` every 10 ms until it holds.
///
/// # Panics
/// When it does not hold within `timeout`; the message says `what` was awaited.
pub fn wait_until(what: &str, timeout: Duration, mut done: impl FnMut() -> bool) {
    let t0 = Instant::now();
    while !done() {
        assert!(t0.elapsed() < timeout, "{what}: not within {timeout:?}");
        std::thread::sleep(Duration::from_millis(10));
    }
}

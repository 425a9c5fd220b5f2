//! `--view`: the browser viewer (`splatphys-web`) as a child process of `run` or `serve`.

use std::ffi::OsString;
use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use anyhow::{Context, Result, bail};
use clap::Args;

use crate::child_args::opt;

/// Flags of the browser viewer, shared by `run` and `serve`.
#[derive(Args, Debug, Clone)]
pub struct ViewArgs {
    /// Start the browser viewer (`splatphys-web`) and print its URL.
    #[arg(long)]
    pub view: bool,
    /// Port of the viewer.
    #[arg(long, default_value_t = 8765)]
    pub view_port: u16,
    /// Address the viewer listens on; anything but loopback exposes it (read-only unless
    /// --view-token is given).
    #[arg(long, default_value = "127.0.0.1")]
    pub view_host: String,
    /// Token the viewer's URL must carry (needed to push the simulation from another machine).
    #[arg(long)]
    pub view_token: Option<String>,
}

/// A running viewer; SIGTERM when dropped.
pub struct Viewer {
    child: Child,
    /// The URL to open.
    pub url: String,
}

impl Viewer {
    /// Prints "`who`: watch it live at URL" on stderr in one write, so that the viewer's own
    /// lines on the same stream cannot land inside it (a reader takes the URL from its end).
    pub fn announce(&self, who: &str) {
        use std::io::Write;
        let line = format!("{who}: watch it live at {}\n", self.url);
        let _ = std::io::stderr().lock().write_all(line.as_bytes());
    }

    /// Starts `splatphys-web` (next to this executable) for `prefix` with the scene's camera
    /// flags, and waits for its URL.
    ///
    /// # Errors
    /// When the viewer is missing, cannot start, or exits before it listens (a port in use).
    pub fn start(args: &ViewArgs, prefix: &str, camera_args: &[OsString]) -> Result<Self> {
        let me = std::env::current_exe().context("locating the splatphys executable")?;
        let bin: PathBuf = me.with_file_name("splatphys-web");
        if !bin.exists() {
            bail!(
                "{} not found: build every client with `cargo build --release --workspace`",
                bin.display()
            );
        }
        let mut cmd = Command::new(&bin);
        cmd.arg(opt("--prefix", prefix))
            .arg(opt("--host", &args.view_host))
            .arg(opt("--port", args.view_port))
            .args(camera_args)
            // The viewer ends when this process does (Linux's parent-death signal, which follows
            // the spawning thread: start it from the thread that lives as long as the command).
            .arg(opt("--exit-with-parent", std::process::id()))
            .stdin(Stdio::null())
            .stdout(Stdio::piped());
        if let Some(t) = &args.view_token {
            cmd.arg(opt("--token", t));
        }
        let mut child = cmd.spawn().context("starting splatphys-web")?;
        let mut line = String::new();
        let out = child.stdout.take().context("viewer stdout")?;
        BufReader::new(out).read_line(&mut line)?;
        let url = line.trim().to_owned();
        if !url.starts_with("http") {
            let _ = child.wait();
            bail!("splatphys-web did not start (see its message above)");
        }
        Ok(Self { child, url })
    }

    /// Waits until the viewer exits, or this process gets SIGINT/SIGTERM (then the viewer is
    /// stopped too).
    pub fn wait(mut self) {
        // A node of our own to see signals (iceoryx2 takes SIGINT/SIGTERM once one exists).
        let node = splatphys_ipc::services::create_node("splatphys-view").ok();
        loop {
            if !matches!(self.child.try_wait(), Ok(None)) {
                return;
            }
            match &node {
                Some(n) if n.wait(Duration::from_millis(100)).is_err() => return,
                Some(_) => {}
                None => std::thread::sleep(Duration::from_millis(100)),
            }
        }
    }
}

impl Drop for Viewer {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            if let Some(pid) = i32::try_from(self.child.id())
                .ok()
                .and_then(rustix::process::Pid::from_raw)
            {
                let _ = rustix::process::kill_process(pid, rustix::process::Signal::TERM);
            }
            for _ in 0..100 {
                if let Ok(Some(_)) = self.child.try_wait() {
                    return;
                }
                std::thread::sleep(Duration::from_millis(20));
            }
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

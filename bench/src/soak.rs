//! `splatphys bench soak`: a server, a lossless recorder and a controller run together for
//! minutes; the resident memory (RSS) of the server and the recorder is sampled over the run and
//! its growth reported, with the frames the recording lost and what was left in /dev/shm.
//!
//! The processes are the real ones: `splatphys serve` (paced to simulated time unless `--fast`),
//! `splatphys-record record` and a `bench ipc-peer --role flood` controller sending impulses at
//! `--commands-hz`. They run under their own iceoryx2 file prefix, so the leftover check sees
//! only them. The server waits for the recorder before its first step. Growth is measured from the first sample after the warm-up (a tenth of the run, at
//! least one sample) to the last one, so allocations made once at start do not count.
//!
//! Output: one JSON line per sample, a final JSON line (`"bench": "soak"`), `soak.csv`, the
//! chart `soak.svg`/`.png`, the server's report and both processes' logs in `--out-dir`.

use std::path::{Path, PathBuf};
use std::process::{Command as Process, Stdio};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail, ensure};
use serde_json::{Value, json};

use crate::chart::{Series, line_chart, write_columns_csv};
use crate::child::KillOnDrop;
use crate::peer::Peer;

/// Arguments of `splatphys bench soak`.
#[derive(clap::Args, Debug)]
pub struct SoakBenchArgs {
    /// Scene file to serve (default: the built-in default scene).
    pub scene: Option<PathBuf>,
    /// Length of the run, minutes.
    #[arg(long, default_value_t = 30.0)]
    pub minutes: f64,
    /// Time between RSS samples, seconds.
    #[arg(long, default_value_t = 10.0)]
    pub sample_s: f64,
    /// Impulse commands per second from the controller.
    #[arg(long, default_value_t = 100.0)]
    pub commands_hz: f64,
    /// Step as fast as possible instead of pacing to simulated time (a much larger recording).
    #[arg(long)]
    pub fast: bool,
    /// Keep the recording (by default only its size is reported and the file is deleted).
    #[arg(long)]
    pub keep_recording: bool,
    /// The recorder's MCAP chunk size, MiB (`splatphys-record record --chunk-mb`): its memory
    /// grows by one index entry per chunk.
    #[arg(long, default_value_t = 4)]
    pub chunk_mb: u64,
    /// Output folder (CSV, chart, server report, recording).
    #[arg(long, default_value = "out/soak")]
    pub out_dir: PathBuf,
}

/// A child process killed (and reaped) when dropped; its stderr goes to a log file (a pipe
/// nobody reads for 30 minutes could fill and block it).
struct Proc(KillOnDrop, PathBuf);

impl Proc {
    /// Waits up to `timeout` for the exit; returns (success, stderr).
    fn finish(mut self, what: &str, timeout: Duration) -> Result<(bool, String)> {
        let status = self.0.wait_for(what, timeout, Duration::from_millis(20))?;
        let err = std::fs::read_to_string(&self.1).unwrap_or_default();
        Ok((status.success(), err))
    }
}

/// Resident set size of process `pid`, MB (`VmRSS` of /proc/PID/status).
fn rss_mb(pid: u32) -> Result<f64> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status"))
        .with_context(|| format!("reading /proc/{pid}/status (did the process exit?)"))?;
    let kb = status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.split_whitespace().next())
        .and_then(|v| v.parse::<f64>().ok())
        .context("no VmRSS in /proc/PID/status")?;
    Ok(kb / 1e3)
}

/// Files of iceoryx2 prefix `iox` in /dev/shm, without iceoryx2's persistent node counter.
fn shm_leftovers(iox: &str) -> Vec<String> {
    std::fs::read_dir("/dev/shm")
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(iox) && !n.ends_with(".global_mgmt"))
        .collect()
}

/// The frame count of the recorder's last line (`splatphys-record: N frames, ...`).
fn recorded_frames(stderr: &str) -> Option<u64> {
    let line = stderr
        .lines()
        .rfind(|l| l.starts_with("splatphys-record:") && l.contains(" frames"))?;
    let before = &line[..line.find(" frames")?];
    before.rsplit(' ').next()?.parse().ok()
}

/// Growth from the first sample at or after `warmup_s` to the last, percent.
fn growth_percent(samples: &[(f64, f64)], warmup_s: f64) -> f64 {
    let Some(first) = samples
        .iter()
        .find(|(t, _)| *t >= warmup_s)
        .or(samples.first())
    else {
        return 0.0;
    };
    let last = samples.last().map_or(first.1, |s| s.1);
    100.0 * (last - first.1) / first.1.max(1e-9)
}

/// Runs the soak.
///
/// # Errors
/// A process that fails to start or dies during the run, or an unwritable output folder.
pub fn run(a: &SoakBenchArgs) -> Result<()> {
    ensure!(
        a.minutes > 0.0 && a.sample_s > 0.0,
        "--minutes and --sample-s must be positive"
    );
    std::fs::create_dir_all(&a.out_dir)
        .with_context(|| format!("creating {}", a.out_dir.display()))?;
    let me = std::env::current_exe().context("locating the splatphys-bench binary")?;
    let (exe, recorder_exe) = (
        me.with_file_name("splatphys"),
        me.with_file_name("splatphys-record"),
    );
    for bin in [&exe, &recorder_exe] {
        ensure!(
            bin.exists(),
            "{} not found next to splatphys-bench (build the workspace: cargo build --release --workspace)",
            bin.display()
        );
    }
    let (_, scene) = splatphys_core::scene::load_named(a.scene.as_deref(), Some(1.0))?;
    let object = scene
        .objects
        .iter()
        .position(|o| o.kind != splatphys_core::scene::ObjectKind::Static)
        .context("the scene has no movable object for the controller to push")?;
    let iox = format!("soak{}_", std::process::id());
    let prefix = format!("splatphys/soak-{}", std::process::id());
    let report = a.out_dir.join("server.json");
    let recording = a.out_dir.join("soak.mcap");

    let mut serve = Process::new(&exe);
    serve.arg("serve");
    if let Some(scene) = &a.scene {
        serve.arg(scene);
    }
    serve
        .args(["--prefix", &prefix, "--duration-s", "1e9"])
        .args(["--wait-for-recorders=1", "--exit-at-end", "--report"])
        .arg(&report)
        .args(if a.fast { &[][..] } else { &["--realtime"][..] });
    let server = spawn(
        &mut serve,
        &iox,
        &a.out_dir.join("server.log"),
        "splatphys serve",
    )?;
    let recorder = spawn(
        Process::new(&recorder_exe)
            .args([
                "record",
                "--prefix",
                &prefix,
                "--connect-timeout-s",
                "60",
                "--out",
            ])
            .arg(&recording)
            .arg(format!("--chunk-mb={}", a.chunk_mb)),
        &iox,
        &a.out_dir.join("recorder.log"),
        "splatphys-record",
    )?;
    // SAFETY: the bench is single-threaded here and creates no iceoryx2 node itself; the peer
    // inherits the variable.
    unsafe { std::env::set_var(splatphys_ipc::services::IOX2_PREFIX_ENV, &iox) };
    let controller = Peer::spawn(&[
        "--role".into(),
        "flood".into(),
        "--prefix".into(),
        prefix.clone(),
        "--hz".into(),
        a.commands_hz.to_string(),
        "--object".into(),
        object.to_string(),
    ])?;

    let total = Duration::from_secs_f64(a.minutes * 60.0);
    let pb = indicatif::ProgressBar::new(total.as_secs());
    pb.set_style(
        indicatif::ProgressStyle::with_template("soak [{bar:40}] {pos}/{len} s {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let started = Instant::now();
    let mut rows: Vec<Value> = Vec::new();
    let (mut server_rss, mut recorder_rss) = (Vec::new(), Vec::new());
    loop {
        let t = started.elapsed().as_secs_f64();
        let (s, r) = (rss_mb(server.0.id())?, rss_mb(recorder.0.id())?);
        server_rss.push((t, s));
        recorder_rss.push((t, r));
        let row =
            json!({"bench": "soak_sample", "t_s": t, "server_rss_mb": s, "recorder_rss_mb": r});
        pb.suspend(|| println!("{row}"));
        rows.push(row);
        pb.set_position(t as u64);
        pb.set_message(format!("server {s:.0} MB, recorder {r:.0} MB"));
        if started.elapsed() >= total {
            break;
        }
        std::thread::sleep(Duration::from_secs_f64(a.sample_s).min(total - started.elapsed()));
    }
    pb.finish_and_clear();

    let status = Process::new("kill")
        .args(["-TERM", &server.0.id().to_string()])
        .status()
        .context("running kill")?;
    ensure!(status.success(), "could not SIGTERM the server");
    let (server_ok, server_err) = server.finish("splatphys serve", Duration::from_secs(60))?;
    let (recorder_ok, recorder_err) =
        recorder.finish("splatphys-record", Duration::from_secs(120))?;
    let flood = controller
        .finish(Duration::from_secs(30))
        .unwrap_or(Value::Null);
    if !server_ok {
        bail!("the server failed: {server_err}");
    }
    let server_json: Value = serde_json::from_str(
        &std::fs::read_to_string(&report)
            .with_context(|| format!("reading {}", report.display()))?,
    )
    .context("parsing the server report")?;
    let published = server_json["frames_published"].as_u64().unwrap_or(0);
    let recorded = recorded_frames(&recorder_err);
    // The server publishes its first frame once the recorder is ready (`--wait-for-recorders`)
    // and waits for it to take the last: every published frame is in the recording.
    let not_recorded = recorded.map(|r| published.saturating_sub(r));
    let recording_mb = std::fs::metadata(&recording).map_or(0.0, |m| m.len() as f64 / 1e6);
    if !a.keep_recording {
        let _ = std::fs::remove_file(&recording);
    }
    let warmup_s = (total.as_secs_f64() / 10.0).max(a.sample_s);
    let leftovers = shm_leftovers(&iox);
    let summary = json!({
        "bench": "soak",
        "minutes": started.elapsed().as_secs_f64() / 60.0,
        "recorder_chunk_mb": a.chunk_mb,
        "samples": rows.len(),
        "warmup_s": warmup_s,
        "server_rss_mb_first": server_rss.iter().find(|(t, _)| *t >= warmup_s).map(|s| s.1),
        "server_rss_mb_last": server_rss.last().map(|s| s.1),
        "server_rss_growth_percent": growth_percent(&server_rss, warmup_s),
        "recorder_rss_mb_first": recorder_rss.iter().find(|(t, _)| *t >= warmup_s).map(|s| s.1),
        "recorder_rss_mb_last": recorder_rss.last().map(|s| s.1),
        "recorder_rss_growth_percent": growth_percent(&recorder_rss, warmup_s),
        "frames_published": published,
        "frames_recorded": recorded,
        "frames_not_recorded": not_recorded,
        "frames_lost_by_recorder": server_json["frames_lost_by_recorder"],
        "recorder_ok": recorder_ok,
        "recording_mb": recording_mb,
        "commands_received": server_json["commands_received"],
        "controller": flood,
        "shm_leftovers": leftovers,
    });
    write_columns_csv(
        &a.out_dir.join("soak.csv"),
        &["t_s", "server_rss_mb", "recorder_rss_mb"],
        &rows,
    )?;
    let minutes = |v: &[(f64, f64)]| v.iter().map(|&(t, m)| (t / 60.0, m)).collect();
    line_chart(
        &a.out_dir.join("soak"),
        "Resident memory over a soak run",
        "minutes",
        "RSS (MB)",
        &[
            Series {
                name: "server".into(),
                points: minutes(&server_rss),
            },
            Series {
                name: "recorder".into(),
                points: minutes(&recorder_rss),
            },
        ],
        false,
        false,
    )?;
    println!("{summary}");
    if !recorder_ok {
        eprintln!("soak: the recorder failed: {recorder_err}");
    }
    Ok(())
}

/// Starts `cmd` under iceoryx2 file prefix `iox`, stderr to `log`.
fn spawn(cmd: &mut Process, iox: &str, log: &Path, what: &str) -> Result<Proc> {
    let file = std::fs::File::create(log).with_context(|| format!("creating {}", log.display()))?;
    cmd.env(splatphys_ipc::services::IOX2_PREFIX_ENV, iox)
        .stdout(Stdio::null())
        .stderr(file)
        .spawn()
        .map(|c| Proc(KillOnDrop(c), log.to_path_buf()))
        .with_context(|| format!("starting {what}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn growth_counts_from_the_first_sample_after_warm_up() {
        let s = [(0.0, 50.0), (10.0, 100.0), (20.0, 102.0), (30.0, 105.0)];
        assert!((growth_percent(&s, 10.0) - 5.0).abs() < 1e-12);
        assert!((growth_percent(&s, 0.0) - 110.0).abs() < 1e-12);
    }

    #[test]
    fn the_recorders_frame_count_is_read_from_its_last_line() {
        let err = "warning\nsplatphys-record: 1234 frames, 1234 objects, 1 scenes -> x (ServerShutDown)\n";
        assert_eq!(recorded_frames(err), Some(1234));
        assert_eq!(recorded_frames("nothing"), None);
    }
}

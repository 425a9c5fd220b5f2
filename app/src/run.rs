//! `splatphys run`: the main job. Starts the server, the recorder and the renderer as separate
//! processes, shows a progress bar of simulated time, waits for the end, and leaves frames, an
//! animation, a recording, `objects.csv` and `summary.json` in the output folder.
//! `--in-process` runs the simulation alone (no IPC, no rendering) and writes the same CSV and
//! summary: what validation and benchmarks use.

use std::fs::File;
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::{Value, json};
use splatphys_core::world::World;
use splatphys_core::world::explain::Explanation;

/// Arguments of `splatphys run`.
#[derive(Args, Debug)]
#[command(after_help = "Examples:
  splatphys run --out out/default                        # the built-in scene
  splatphys run scenes/donut_drop.toml --out out/donut   # a captured donut dropped on a table
  splatphys run scenes/guitar_topple.toml --out out/g --duration-s 0.5 --threads 2
  splatphys run scenes/donut_drop.toml --out out/d --in-process   # simulation only
  splatphys run scenes/guitar_topple.toml --out out/g --explain   # what each object needed")]
pub struct RunArgs {
    /// Scene file (TOML); the built-in default scene when absent.
    pub scene: Option<PathBuf>,
    /// Output folder (created; existing files in it are overwritten).
    #[arg(long, short)]
    pub out: PathBuf,
    /// Run the simulation alone in this process: objects.csv and summary.json only.
    #[arg(long)]
    pub in_process: bool,
    /// Worker threads for the simulation (and the renderer).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Override the scene's duration, seconds.
    #[arg(long)]
    pub duration_s: Option<f64>,
    /// Service prefix (default `splatphys/run-<pid>`, so runs never cross-talk).
    #[arg(long)]
    pub prefix: Option<String>,
    /// Print per object what was modelled (particles simulated and carried, grid blocks, substeps
    /// slept, the dt limit and which material set it); also written to explain.txt.
    #[arg(long)]
    pub explain: bool,
    /// Seconds to wait for the clients to exit after the server has stopped.
    #[arg(long, default_value_t = 120.0)]
    pub client_timeout_s: f64,
}

/// Runs the main job.
pub fn run(args: &RunArgs) -> Result<()> {
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    if args.in_process {
        in_process(args)
    } else {
        multi_process(args)
    }
}

fn progress_bar(total_frames: u64) -> ProgressBar {
    let pb = ProgressBar::new(total_frames);
    pb.set_style(
        ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} frames {msg}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    pb
}

fn in_process(args: &RunArgs) -> Result<()> {
    if let Some(n) = args.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .context("setting --threads")?;
    }
    let (name, scene) = splatphys_core::scene::load_named(args.scene.as_deref(), args.duration_s)?;
    let mut world =
        World::from_scene(&scene).with_context(|| format!("building scene {name:?}"))?;
    let csv_path = args.out.join("objects.csv");
    let mut csv = std::io::BufWriter::new(
        File::create(&csv_path).with_context(|| format!("creating {}", csv_path.display()))?,
    );
    writeln!(
        csv,
        "step,time_s,object,x_m,y_m,z_m,vx_m_s,vy_m_s,vz_m_s,mass_kg"
    )?;
    let write_rows = |csv: &mut std::io::BufWriter<File>, w: &World| -> Result<()> {
        for o in w.objects() {
            let (p, v) = (o.com_m, o.velocity_m_s);
            writeln!(
                csv,
                "{},{},{},{},{},{},{},{},{},{}",
                w.frame, w.time_s, o.id, p[0], p[1], p[2], v[0], v[1], v[2], o.mass_kg
            )?;
        }
        Ok(())
    };
    write_rows(&mut csv, &world)?;
    let diag0 = world.diagnostics();
    let pb = progress_bar(world.total_frames());
    let started = Instant::now();
    let mut error = None;
    while !world.is_finished() {
        if let Err(e) = world.advance_frame() {
            error = Some(e);
            break;
        }
        write_rows(&mut csv, &world)?;
        pb.set_position(world.frame);
        pb.set_message(format!("t = {:.3} s", world.time_s));
    }
    pb.finish_and_clear();
    csv.flush()?;
    let wall_s = started.elapsed().as_secs_f64();
    let summary = json!({
        "mode": "in-process",
        "scene": name,
        "method": format!("{:?}", world.settings.method).to_lowercase(),
        "particles": world.particle_count(),
        "gaussians": world.published_count(),
        "objects": world.bodies.len(),
        "substeps": world.stats.substeps,
        "frames": world.frame,
        "simulated_s": world.time_s,
        "wall_s": wall_s,
        "particle_substeps_per_s": world.stats.mpm_particle_substeps as f64 / wall_s.max(1e-9),
        "com_layer_fraction": world.stats.com_layer_wall_s / (world.stats.com_layer_wall_s + world.stats.mpm_wall_s).max(1e-12),
        "frames_dropped_by_renderer": 0,
        "frames_lost_by_recorder": 0,
        "stats": world.stats,
        "diagnostics_start": diag0,
        "diagnostics_end": world.diagnostics(),
        "explain": world.explain(),
        "error": error.as_ref().map(|e| e.to_string()),
    });
    write_json(&args.out.join("summary.json"), &summary)?;
    if args.explain {
        explain(&args.out, &world.explain())?;
    }
    eprintln!(
        "splatphys run: {} frames in {wall_s:.2} s; wrote {}",
        world.frame,
        args.out.display()
    );
    if let Some(e) = error {
        bail!("simulation stopped: {e} (objects.csv and summary.json keep what was done)");
    }
    Ok(())
}

/// Prints the `--explain` table and writes it to explain.txt.
fn explain(out: &Path, report: &Explanation) -> Result<()> {
    let table = report.to_table();
    eprint!("{table}");
    std::fs::write(out.join("explain.txt"), &table)
        .with_context(|| format!("writing {}", out.join("explain.txt").display()))
}

fn write_json(path: &Path, v: &Value) -> Result<()> {
    std::fs::write(path, serde_json::to_string_pretty(v)?)
        .with_context(|| format!("writing {}", path.display()))
}

/// A sibling executable of this one (cargo puts every workspace binary in one folder).
pub(crate) fn sibling(name: &str) -> Result<PathBuf> {
    let me = std::env::current_exe().context("locating the splatphys executable")?;
    let path = me.with_file_name(name);
    if !path.exists() {
        bail!(
            "{} not found next to {}: build every client with `cargo build --release --workspace`",
            name,
            me.display()
        );
    }
    Ok(path)
}

struct Proc {
    name: &'static str,
    child: Child,
}

impl Proc {
    fn spawn(
        name: &'static str,
        mut cmd: Command,
        log: &Path,
        threads: Option<usize>,
    ) -> Result<Self> {
        let err = File::create(log).with_context(|| format!("creating {}", log.display()))?;
        cmd.stderr(err).stdin(Stdio::null());
        if let Some(n) = threads {
            cmd.env("RAYON_NUM_THREADS", n.to_string());
        }
        let child = cmd.spawn().with_context(|| format!("starting {name}"))?;
        Ok(Self { name, child })
    }

    /// Waits up to `timeout`; kills the process past it. Returns its exit success.
    fn wait(&mut self, timeout: Duration) -> Result<bool> {
        let until = Instant::now() + timeout;
        loop {
            if let Some(status) = self.child.try_wait()? {
                return Ok(status.success());
            }
            if Instant::now() >= until {
                eprintln!(
                    "splatphys run: {} did not exit within {:.0} s; killing it",
                    self.name,
                    timeout.as_secs_f64()
                );
                let _ = self.child.kill();
                let _ = self.child.wait();
                return Ok(false);
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

fn multi_process(args: &RunArgs) -> Result<()> {
    // Validate the scene here first, for a clear error before any process starts.
    let (name, scene) = splatphys_core::scene::load_named(args.scene.as_deref(), args.duration_s)?;
    let world = World::from_scene(&scene).with_context(|| format!("building scene {name:?}"))?;
    let total_frames = world.total_frames();
    drop(world);
    let prefix = args
        .prefix
        .clone()
        .unwrap_or_else(|| format!("splatphys/run-{}", std::process::id()));
    let logs = args.out.join("logs");
    let frames = args.out.join("frames");
    std::fs::create_dir_all(&logs)?;
    std::fs::create_dir_all(&frames)?;
    let me = std::env::current_exe()?;
    let record_bin = sibling("splatphys-record")?;
    let render_bin = sibling("splatphys-render")?;

    let mut server_cmd = Command::new(&me);
    server_cmd.arg("serve");
    if let Some(s) = &args.scene {
        server_cmd.arg(s);
    }
    server_cmd
        .args([
            "--prefix",
            &prefix,
            "--wait-for-subscribers",
            "2",
            "--progress",
            "--report",
        ])
        .arg(args.out.join("server.json"))
        .stdout(Stdio::piped());
    if let Some(d) = args.duration_s {
        server_cmd.args(["--duration-s", &d.to_string()]);
    }
    let mut server = Proc::spawn("server", server_cmd, &logs.join("server.log"), args.threads)?;
    let server_out = server.child.stdout.take().context("server stdout")?;

    let mut rec_cmd = Command::new(&record_bin);
    rec_cmd
        .args([
            "record",
            "--prefix",
            &prefix,
            "--connect-timeout-s",
            "30",
            "--out",
        ])
        .arg(args.out.join("run.mcap"));
    rec_cmd.stdout(Stdio::null());
    let mut recorder = Proc::spawn("recorder", rec_cmd, &logs.join("recorder.log"), None)?;

    let mut ren_cmd = Command::new(&render_bin);
    ren_cmd
        .args([
            "live",
            "--prefix",
            &prefix,
            "--timeout-s",
            "30",
            "--out-dir",
        ])
        .arg(&frames)
        .arg("--gif")
        .arg(args.out.join("animation.gif"))
        .stdout(Stdio::piped());
    let camera_args: Vec<String> = match scene.cameras.first() {
        Some(cam) => {
            let v = |a: [f32; 3]| format!("{},{},{}", a[0], a[1], a[2]);
            vec![
                "--camera-pos".into(),
                v(cam.position_m),
                "--look-at".into(),
                v(cam.look_at_m),
                "--up".into(),
                v(cam.up),
                "--fov-deg".into(),
                cam.fov_y_deg.to_string(),
                "--width".into(),
                cam.width_px.to_string(),
                "--height".into(),
                cam.height_px.to_string(),
            ]
        }
        None => Vec::new(),
    };
    ren_cmd.args(&camera_args);
    let mut renderer = Proc::spawn(
        "renderer",
        ren_cmd,
        &logs.join("renderer.log"),
        args.threads,
    )?;
    let render_out = renderer.child.stdout.take().context("renderer stdout")?;
    let render_json = std::thread::spawn(move || -> Option<Value> {
        BufReader::new(render_out)
            .lines()
            .map_while(Result::ok)
            .filter_map(|l| serde_json::from_str::<Value>(&l).ok())
            .last()
    });

    let pb = progress_bar(total_frames);
    let started = Instant::now();
    for line in BufReader::new(server_out).lines().map_while(Result::ok) {
        let mut it = line.split_whitespace();
        if it.next() == Some("progress") {
            let frame: u64 = it.next().and_then(|v| v.parse().ok()).unwrap_or(0);
            let t: f64 = it.nth(1).and_then(|v| v.parse().ok()).unwrap_or(0.0);
            pb.set_position(frame);
            pb.set_message(format!("t = {t:.3} s"));
        }
        // A client that died early ends the run with a clear message.
        for p in [&mut recorder, &mut renderer] {
            if let Ok(Some(status)) = p.child.try_wait()
                && !status.success()
            {
                pb.abandon();
                let _ = server.child.kill();
                bail!(
                    "the {} exited with {status} before the end; see {}/{}.log (files written so far are kept)",
                    p.name,
                    logs.display(),
                    p.name
                );
            }
        }
    }
    pb.finish_and_clear();
    let server_ok = server.wait(Duration::from_secs(30))?;
    let timeout = Duration::from_secs_f64(args.client_timeout_s.max(1.0));
    let recorder_ok = recorder.wait(timeout)?;
    let renderer_ok = renderer.wait(timeout)?;
    let wall_s = started.elapsed().as_secs_f64();
    if !server_ok {
        bail!("the server failed; see {}/server.log", logs.display());
    }

    // objects.csv from the lossless recording.
    let csv = args.out.join("objects.csv");
    let export = Command::new(&record_bin)
        .args(["export-objects"])
        .arg(args.out.join("run.mcap"))
        .arg("--out")
        .arg(&csv)
        .status()
        .context("running splatphys-record export-objects")?;
    let server_json: Value = std::fs::read_to_string(args.out.join("server.json"))
        .ok()
        .and_then(|s| serde_json::from_str(&s).ok())
        .unwrap_or(Value::Null);
    let render_json = render_json.join().ok().flatten().unwrap_or(Value::Null);
    // The live renderer shows the newest frame and skips when it is slower than the simulation;
    // the animation left behind should hold every step, so re-render any skipped ones from the
    // lossless recording (the live figure stays in the summary).
    let mut rerendered = false;
    if recorder_ok && render_json["frames_dropped"].as_u64().unwrap_or(0) > 0 {
        let status = Command::new(&render_bin)
            .arg("mcap")
            .arg(args.out.join("run.mcap"))
            .arg("--out-dir")
            .arg(&frames)
            .arg("--gif")
            .arg(args.out.join("animation.gif"))
            .args(&camera_args)
            .stdout(Stdio::null())
            .stderr(File::create(logs.join("render-mcap.log"))?)
            .status()
            .context("running splatphys-render mcap")?;
        rerendered = status.success();
    }
    let frames_png = std::fs::read_dir(&frames)
        .map(|d| d.filter_map(Result::ok).count())
        .unwrap_or(0);
    let summary = json!({
        "mode": "multi-process",
        "scene": name,
        "prefix": prefix,
        "method": server_json["method"],
        "particles": server_json["particles"],
        "gaussians": server_json["gaussians"],
        "objects": server_json["objects"],
        "substeps": server_json["substeps"],
        "frames": server_json["frames_published"],
        "frames_rendered": render_json["frames_rendered"],
        "frame_pngs": frames_png,
        "wall_s": wall_s,
        "simulation_wall_s": server_json["step_wall_s"],
        "particle_substeps_per_s": server_json["particle_substeps_per_s"],
        "frames_dropped_by_renderer": render_json["frames_dropped"],
        "frames_rerendered_from_recording": rerendered,
        "frames_lost_by_recorder": server_json["frames_lost_by_recorder"],
        "recorder_ok": recorder_ok,
        "renderer_ok": renderer_ok,
        "objects_csv_ok": export.success(),
        "stats": server_json["stats"],
        "diagnostics_end": server_json["diagnostics"],
        "explain": server_json["explain"],
    });
    write_json(&args.out.join("summary.json"), &summary)?;
    if args.explain {
        let report: Explanation = serde_json::from_value(server_json["explain"].clone())
            .context("the server's report has no explanation (see logs/server.log)")?;
        explain(&args.out, &report)?;
    }
    eprintln!(
        "splatphys run: {} frames simulated, {} rendered, in {wall_s:.1} s; wrote {}",
        server_json["frames_published"],
        render_json["frames_rendered"],
        args.out.display()
    );
    if !(recorder_ok && renderer_ok && export.success()) {
        bail!(
            "a client failed (recorder ok: {recorder_ok}, renderer ok: {renderer_ok}, csv export ok: {}); see {}",
            export.success(),
            logs.display()
        );
    }
    Ok(())
}

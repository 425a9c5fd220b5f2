//! `splatphys run`: the main job. Starts the server, the recorder and the renderer as separate
//! processes, shows a progress bar of simulated time, waits for the end, and leaves frames, an
//! animation, a recording, `objects.csv` and `summary.json` in the output folder. The progress
//! bar follows the server's `status` service. `--in-process` runs the simulation alone (no IPC,
//! no rendering) and writes the same CSV and summary keys: what validation and benchmarks use.

use std::fs::File;
use std::io::{BufWriter, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::child_args::{opt, opt_path};
use crate::device::DeviceArgs;
use crate::level_of_detail::{self, LodArgs};
use crate::plan::RunPlan;
use crate::report::{RunSummary, ServerJson, read_json, write_json};
use crate::view::{ViewArgs, Viewer};
use crate::world_sim::WorldSim;
use anyhow::{Context, Result, bail};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use splatphys_core::world::explain::Explanation;
use splatphys_ipc::Simulation;
use splatphys_ipc::client::{ClientOptions, Connection};
use splatphys_ipc::wire::ObjectState;
use splatphys_record::channels::FRAME;
use splatphys_record::export::{ExportFormat, ExportOptions, export_frames};
use splatphys_record::objects_csv::ObjectsCsv;
use splatphys_record::read::{Recording, frame_header, objects_csv};
use splatphys_render::report::RenderReport;

/// Arguments of `splatphys run`.
#[derive(Args, Debug)]
#[command(after_help = "Examples:
  splatphys run --out out/default                        # the built-in scene
  splatphys run scenes/donut_drop.toml --out out/donut   # a captured donut dropped on a table
  splatphys run scenes/guitar_topple.toml --out out/g --duration-s 0.5 --threads 2
  splatphys run scenes/donut_drop.toml --out out/d --in-process   # simulation only
  splatphys run scenes/guitar_topple.toml --out out/g --explain   # what each object needed
  splatphys run scenes/donut_snow_push.toml --out out/s --budget-fps 30   # coarsen to real time
  splatphys run scenes/donut_snow_push.toml --out out/s2 --spacing-from out/s/summary.json
  splatphys run scenes/donut_drop.toml --out out/d --export-ply --every 10   # PLY files of the frames")]
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
    /// The browser viewer (not with --in-process); it keeps showing the last frame after the
    /// run until Ctrl-C.
    #[command(flatten)]
    pub view: ViewArgs,
    /// Level of detail by budget.
    #[command(flatten)]
    pub lod: LodArgs,
    /// Where deformable objects' MPM runs.
    #[command(flatten)]
    pub device: DeviceArgs,
    /// After the run, write frames as INRIA PLY files (`OUT/export/frame_<index>.ply`, world
    /// metres, z up, with each Gaussian's `object_id`) from the recording.
    #[arg(long)]
    pub export_ply: bool,
    /// After the run, write frames as SPZ files (`OUT/export/frame_<index>.spz`, y up).
    #[arg(long)]
    pub export_spz: bool,
    /// With --export-ply/--export-spz: one frame in N.
    #[arg(long, visible_alias = "every", default_value_t = 1, value_parser = clap::value_parser!(u64).range(1..))]
    pub export_every: u64,
}

impl RunArgs {
    /// The export formats asked for.
    fn export_formats(&self) -> Vec<ExportFormat> {
        let mut f = Vec::new();
        if self.export_ply {
            f.push(ExportFormat::Ply);
        }
        if self.export_spz {
            f.push(ExportFormat::Spz);
        }
        f
    }
}

/// Runs the main job.
///
/// # Errors
/// A bad scene, a process that could not start or failed, an unwritable output folder.
pub fn run(args: &RunArgs) -> Result<()> {
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    if args.in_process {
        if args.view.view {
            bail!("--view needs the server as a process: leave out --in-process");
        }
        if !args.export_formats().is_empty() {
            bail!("--export-ply and --export-spz read the recording: leave out --in-process");
        }
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

/// `objects.csv` in the run folder.
fn create_objects_csv(out: &Path, names: Vec<String>) -> Result<ObjectsCsv<BufWriter<File>>> {
    let path = out.join("objects.csv");
    let file = File::create(&path).with_context(|| format!("creating {}", path.display()))?;
    ObjectsCsv::new(BufWriter::new(file), names)
        .with_context(|| format!("writing {}", path.display()))
}

fn in_process(args: &RunArgs) -> Result<()> {
    if let Some(n) = args.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .context("setting --threads")?;
    }
    let (plan, mut scene) = RunPlan::new(args.scene.as_deref(), args.duration_s, None)?;
    let lod = level_of_detail::resolve(
        &mut scene,
        &args.lod,
        rayon::current_num_threads(),
        "splatphys run",
    )?;
    args.device.apply(&mut scene);
    let mut sim = WorldSim::new(&plan.name, &scene)
        .with_context(|| format!("building scene {:?}", plan.name))?;
    crate::device::attach(&mut sim.world, "splatphys run");
    let mut csv = create_objects_csv(&args.out, plan.object_names.clone())?;
    let mut objects = vec![ObjectState::default(); sim.object_count()];
    let mut write_rows = |sim: &WorldSim, csv: &mut ObjectsCsv<_>| -> Result<()> {
        sim.write_objects(&mut objects);
        csv.write_frame(sim.step(), sim.time_s(), &objects)
            .context("writing objects.csv")
    };
    write_rows(&sim, &mut csv)?;
    let pb = progress_bar(plan.total_frames);
    let started = Instant::now();
    let mut error = None;
    while !sim.is_finished() {
        if let Err(e) = sim.advance(&mut || true) {
            error = Some(e);
            break;
        }
        write_rows(&sim, &mut csv)?;
        pb.set_position(sim.step());
        pb.set_message(format!("t = {:.3} s", sim.time_s()));
    }
    pb.finish_and_clear();
    let rows = csv.rows();
    csv.finish().context("writing objects.csv")?;
    let wall_s = started.elapsed().as_secs_f64();
    let mut summary = RunSummary::from_world("in-process", &plan.name, &sim.world, wall_s);
    summary.objects_csv_rows = rows;
    summary.error = error.as_ref().map(ToString::to_string);
    summary.level_of_detail = lod;
    write_json(&args.out.join("summary.json"), &summary)?;
    if args.explain {
        explain(&args.out, &summary.explain)?;
    }
    eprintln!(
        "splatphys run: {} frames in {wall_s:.2} s; wrote {}",
        summary.frames,
        args.out.display()
    );
    level_of_detail::check_pace(
        summary.level_of_detail.as_ref(),
        summary.frames,
        wall_s,
        scene.simulation.duration_s,
        "splatphys run",
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

/// Writes the frames `--export-ply`/`--export-spz` ask for from the recording into
/// `OUT/export` (nothing when neither is given). A recording cut by a dead recorder is read up
/// to the cut.
fn export(args: &RunArgs, mcap: &Path) -> Result<()> {
    let formats = args.export_formats();
    if formats.is_empty() {
        return Ok(());
    }
    let dir = args.out.join("export");
    let opts = ExportOptions {
        every: args.export_every,
        steps: None,
        formats,
    };
    let pb = ProgressBar::new_spinner();
    let report = export_frames(Recording::open(mcap, true)?, mcap, &dir, &opts, |r| {
        pb.set_message(format!("exporting frame {}", r.frames));
        pb.tick();
    })?;
    pb.finish_and_clear();
    eprintln!(
        "splatphys run: exported {} frames ({} files) to {}",
        report.frames,
        report.files.len(),
        dir.display()
    );
    Ok(())
}

/// A sibling executable of this one (cargo puts every workspace binary in one folder): the
/// client processes of a run.
fn sibling(name: &str) -> Result<PathBuf> {
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

/// How long the server waits for the recorder to be ready (and the recorder and the renderer
/// for the server): a scene of millions of Gaussians takes seconds to build and to send.
const RECORDER_READY_TIMEOUT_S: u32 = 60;

/// How long a child has to exit after SIGTERM (a server removes its services, a recorder
/// finishes its file) before it is killed.
const TERM_GRACE: Duration = Duration::from_secs(5);

/// A child process of the run, stopped when dropped (so an early error leaves nothing behind):
/// SIGTERM first, SIGKILL after [`TERM_GRACE`].
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

    /// Exited with a failure status (not yet exited: `false`).
    fn failed(&mut self) -> bool {
        matches!(self.child.try_wait(), Ok(Some(status)) if !status.success())
    }

    /// Asks the process to stop (SIGTERM); it ends its work cleanly.
    fn sigterm(&self) {
        if let Some(pid) = i32::try_from(self.child.id())
            .ok()
            .and_then(rustix::process::Pid::from_raw)
        {
            let _ = rustix::process::kill_process(pid, rustix::process::Signal::TERM);
        }
    }

    /// Waits until `until` for the exit; `None` when still running then.
    fn wait_until(&mut self, until: Instant) -> Result<Option<bool>> {
        loop {
            if let Some(status) = self.child.try_wait()? {
                return Ok(Some(status.success()));
            }
            if Instant::now() >= until {
                return Ok(None);
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// SIGTERM, then SIGKILL when it is still running after [`TERM_GRACE`].
    fn stop(&mut self) {
        self.sigterm();
        if !matches!(self.wait_until(Instant::now() + TERM_GRACE), Ok(Some(_))) {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }

    /// Waits up to `timeout`; past it, stops the process ([`Proc::stop`]). Returns its exit
    /// success (`false` when it had to be stopped).
    fn wait(&mut self, timeout: Duration) -> Result<bool> {
        if let Some(ok) = self.wait_until(Instant::now() + timeout)? {
            return Ok(ok);
        }
        eprintln!(
            "splatphys run: {} did not exit within {:.0} s; stopping it (SIGTERM, then SIGKILL after {:.0} s)",
            self.name,
            timeout.as_secs_f64(),
            TERM_GRACE.as_secs_f64()
        );
        self.stop();
        Ok(false)
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            self.stop();
        }
    }
}

/// Reads the renderer's stdout in the background; its last JSON line is its report.
fn render_report(renderer: &mut Proc) -> std::thread::JoinHandle<Option<RenderReport>> {
    let out = renderer.child.stdout.take();
    std::thread::spawn(move || {
        let mut text = String::new();
        out?.read_to_string(&mut text).ok()?;
        RenderReport::from_stdout(&text)
    })
}

/// Follows the server's `status` until the server process exits, showing progress; ends the run
/// early with a clear message when a client dies. Returns whether the run was interrupted
/// (SIGINT/SIGTERM), in which case the server was asked to stop.
fn follow_server(
    plan: &RunPlan,
    server: &mut Proc,
    clients: &mut [&mut Proc],
    logs: &Path,
) -> Result<bool> {
    let pb = progress_bar(plan.total_frames);
    let mut opts = ClientOptions::new(&plan.prefix);
    opts.node_name = "splatphys-run".into();
    opts.frames = false;
    opts.objects = false;
    opts.commands = false;
    // Short: the loop retries while it watches the processes (a server that fails to start is
    // noticed when its process exits, not after a long connect).
    opts.connect_timeout = Duration::from_millis(500);
    let mut conn: Option<Connection> = None;
    let mut interrupted = false;
    loop {
        if server.child.try_wait()?.is_some() {
            break;
        }
        // SIGINT/SIGTERM to the run: the server is asked to stop, and the run ends as if the
        // server had finished (the recorder completes its file, the summary is written).
        if !interrupted
            && conn
                .as_ref()
                .is_some_and(|c| c.node().wait(Duration::ZERO).is_err())
        {
            interrupted = true;
            pb.suspend(|| eprintln!("splatphys run: interrupted; stopping the server"));
            server.sigterm();
        }
        for p in clients.iter_mut() {
            if p.failed() {
                pb.abandon();
                bail!(
                    "the {} exited with an error before the end; see {}/{}.log (files written so far are kept)",
                    p.name,
                    logs.display(),
                    p.name
                );
            }
        }
        if conn.is_none() {
            conn = Connection::connect(&opts).ok();
        }
        // A server that stops beating is reported when its process exits (below).
        if let Some(c) = conn.as_mut()
            && let Ok(Some(status)) = c.poll_status()
        {
            pb.set_position(status.step);
            pb.set_message(format!("t = {:.3} s", status.time_s));
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    pb.finish_and_clear();
    Ok(interrupted)
}

fn multi_process(args: &RunArgs) -> Result<()> {
    let (plan, mut scene) =
        RunPlan::new(args.scene.as_deref(), args.duration_s, args.prefix.clone())?;
    let threads = args.threads.unwrap_or_else(|| {
        std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get)
    });
    let lod = level_of_detail::resolve(&mut scene, &args.lod, threads, "splatphys run")?;
    let logs = args.out.join("logs");
    let frames = args.out.join("frames");
    std::fs::create_dir_all(&logs)?;
    std::fs::create_dir_all(&frames)?;
    let me = std::env::current_exe()?;
    let record_bin = sibling("splatphys-record")?;
    let render_bin = sibling("splatphys-render")?;
    let server_json = args.out.join("server.json");
    let _ = std::fs::remove_file(&server_json);

    let mut server_cmd = Command::new(&me);
    server_cmd.arg("serve");
    if let Some(s) = &plan.scene_path {
        server_cmd.arg(s);
    }
    // The recorder is the run's one lossless subscriber: the server publishes the first frame
    // once it is ready and stops once it took the last (the renderer and the viewer take what
    // they can; skipped frames are rendered from the recording afterwards).
    server_cmd
        .arg(opt("--prefix", &plan.prefix))
        .arg(opt("--wait-for-recorders", 1))
        .arg(opt("--wait-timeout-s", RECORDER_READY_TIMEOUT_S))
        .arg("--exit-at-end")
        .arg(opt_path("--report", &server_json))
        .stdout(Stdio::null());
    if let Some(d) = plan.duration_s {
        server_cmd.arg(opt("--duration-s", d));
    }
    if let Some(r) = &lod {
        // The server uses the level of detail chosen here rather than calibrating again.
        let path = args.out.join("level_of_detail.json");
        level_of_detail::write(&path, &r.chosen)?;
        server_cmd.arg(opt_path("--spacing-from", &path));
    }
    if let Some(device) = args.device.child_arg() {
        server_cmd.arg(device);
    }
    let mut server = Proc::spawn("server", server_cmd, &logs.join("server.log"), args.threads)?;
    let viewer = if args.view.view {
        let v = Viewer::start(&args.view, &plan.prefix, &plan.camera_args())?;
        v.announce("splatphys run");
        Some(v)
    } else {
        None
    };

    let mut rec_cmd = Command::new(&record_bin);
    rec_cmd
        .arg("record")
        .arg(opt("--prefix", &plan.prefix))
        .arg(opt("--connect-timeout-s", RECORDER_READY_TIMEOUT_S))
        .arg(opt_path("--out", &args.out.join("run.mcap")))
        .stdout(Stdio::null());
    let mut recorder = Proc::spawn("recorder", rec_cmd, &logs.join("recorder.log"), None)?;

    let camera_args = plan.camera_args();
    let mut ren_cmd = Command::new(&render_bin);
    ren_cmd
        .arg("live")
        .arg(opt("--prefix", &plan.prefix))
        .arg(opt("--timeout-s", RECORDER_READY_TIMEOUT_S))
        .arg(opt_path("--out-dir", &frames))
        .arg(opt_path("--gif", &args.out.join("animation.gif")))
        .args(&camera_args)
        .stdout(Stdio::piped());
    let mut renderer = Proc::spawn(
        "renderer",
        ren_cmd,
        &logs.join("renderer.log"),
        args.threads,
    )?;
    let live_report = render_report(&mut renderer);

    let started = Instant::now();
    let followed = follow_server(
        &plan,
        &mut server,
        &mut [&mut recorder, &mut renderer],
        &logs,
    );
    if followed.is_err() {
        server.stop();
    }
    let interrupted = followed?;
    let server_ok = server.wait(Duration::from_secs(30))?;
    let timeout = Duration::from_secs_f64(args.client_timeout_s.max(1.0));
    let recorder_ok = recorder.wait(timeout)?;
    let renderer_ok = renderer.wait(timeout)?;
    let wall_s = started.elapsed().as_secs_f64();
    if !server_ok {
        bail!("the server failed; see {}/server.log", logs.display());
    }
    let report: ServerJson = read_json(&server_json)
        .with_context(|| format!("the server's report (see {}/server.log)", logs.display()))?;
    let live = live_report.join().ok().flatten().unwrap_or_default();

    // objects.csv from the lossless recording, names from the plan; and which steps the file
    // holds (of generation 0 .. the last; the run has no reset).
    let mcap = args.out.join("run.mcap");
    let mut steps_in_file = std::collections::BTreeSet::new();
    let csv_rows = (|| -> Result<u64> {
        // One streamed pass (memory bounded by a chunk): the steps of the frames, the rows of
        // the objects. A file cut by a dead recorder is read up to the cut; the missing steps
        // are then counted as lost below.
        let msgs = Recording::open(&mcap, true)?.inspect(|m| {
            if let Ok(m) = m
                && m.topic == FRAME
                && let Ok(h) = frame_header(m, &mcap)
            {
                steps_in_file.insert(h.step);
            }
        });
        let path = args.out.join("objects.csv");
        let mut out = BufWriter::new(
            File::create(&path).with_context(|| format!("creating {}", path.display()))?,
        );
        Ok(objects_csv(
            msgs,
            &mcap,
            plan.object_names.clone(),
            &mut out,
        )?)
    })();
    // The live renderer shows the newest frame and skips when it is slower than the simulation
    // (or starts after the first frames); the animation left behind should hold every step, so
    // re-render from the lossless recording when it has frames the renderer did not draw (the
    // live figure stays in the summary).
    let mut rerendered = false;
    if recorder_ok && (live.frames_dropped > 0 || live.frames_rendered < steps_in_file.len() as u64)
    {
        let status = Command::new(&render_bin)
            .arg("mcap")
            .arg(&mcap)
            .arg(opt_path("--out-dir", &frames))
            .arg(opt_path("--gif", &args.out.join("animation.gif")))
            .args(&camera_args)
            .stdout(Stdio::null())
            .stderr(File::create(logs.join("render-mcap.log"))?)
            .status()
            .context("running splatphys-render mcap")?;
        rerendered = status.success();
    }
    let exported = export(args, &mcap);
    let last_step = report.last_step;
    let mut summary = RunSummary::from_server(&plan.name, &plan.prefix, report, wall_s);
    // Counted from what the file holds, not from the server's view.
    summary.frames_recorded = steps_in_file.len() as u64;
    summary.frames_lost_by_recorder = (0..=last_step)
        .filter(|s| !steps_in_file.contains(s))
        .count() as u64;
    summary.frames_rendered = live.frames_rendered;
    summary.frame_pngs = std::fs::read_dir(&frames)
        .map(|d| d.filter_map(Result::ok).count())
        .unwrap_or(0);
    summary.frames_dropped_by_renderer = live.frames_dropped;
    summary.frames_rerendered_from_recording = rerendered;
    summary.recorder_ok = recorder_ok;
    summary.renderer_ok = renderer_ok;
    summary.objects_csv_rows = *csv_rows.as_ref().unwrap_or(&0);
    summary.level_of_detail = lod;
    write_json(&args.out.join("summary.json"), &summary)?;
    if args.explain {
        explain(&args.out, &summary.explain)?;
    }
    eprintln!(
        "splatphys run: {} frames simulated, {} rendered, in {wall_s:.1} s; wrote {}",
        summary.frames,
        summary.frames_rendered,
        args.out.display()
    );
    if let Some(v) = viewer
        && !interrupted
    {
        eprintln!(
            "splatphys run: the viewer keeps showing the last frame at {} (Ctrl-C to end)",
            v.url
        );
        v.wait();
    }
    if interrupted {
        bail!(
            "interrupted at step {last_step}; everything up to it is in {}",
            args.out.display()
        );
    }
    if let Err(e) = &csv_rows {
        bail!("objects.csv could not be written from the recording: {e:#}");
    }
    if let Err(e) = exported {
        bail!("exporting frames from {}: {e:#}", mcap.display());
    }
    if summary.frames_lost_by_recorder > 0 {
        bail!(
            "the recording lost {} of {} steps ({} holds {}); see {}/recorder.log and \
             {}/server.log",
            summary.frames_lost_by_recorder,
            last_step + 1,
            mcap.display(),
            summary.frames_recorded,
            logs.display(),
            logs.display()
        );
    }
    if !(recorder_ok && renderer_ok) {
        bail!(
            "a client failed (recorder ok: {recorder_ok}, renderer ok: {renderer_ok}); see {}",
            logs.display()
        );
    }
    Ok(())
}

//! `--vs-taichi`: the Taichi reference implementations in `bench/taichi/` (pip package `taichi`,
//! CPU backend), run as a child process of this one in the same run with the same arguments.
//!
//! A missing script is an error (a broken checkout); a missing `python3` or a Python without
//! `taichi` is a skip: one line on stderr, exit 0, our own result already printed.
//!
//! Also `bench spheres`: the `mpm` baseline of `bench compare` (two elastic spheres head-on on one
//! shared grid) at one cell size, its throughput and rebound, against `mpm_spheres.py`.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use serde_json::{Value, json};
use splatphys_core::scene::Method;

/// Arguments of `bench spheres`.
#[derive(Args, Debug)]
pub struct SpheresArgs {
    /// Grid cell size (m); particle spacing is half of it (0.02 is `bench compare`'s first case).
    #[arg(long, default_value_t = 0.02)]
    pub dx_m: f64,
    /// Worker threads.
    #[arg(long, default_value_t = 2)]
    pub threads: usize,
    /// Seed of the particle jitter (the Taichi script draws its own jitter from it: the two
    /// particle sets differ by the jitter noise; vary it to see that noise).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Then run the Taichi reference (bench/taichi/mpm_spheres.py) with the same arguments;
    /// skipped with a message when Taichi is not installed.
    #[arg(long)]
    pub vs_taichi: bool,
    /// The Taichi script (default: bench/taichi/mpm_spheres.py, found as for `bench mpm`).
    #[arg(long, requires = "vs_taichi")]
    pub taichi_script: Option<PathBuf>,
    /// Python interpreter for --vs-taichi.
    #[arg(long, default_value = "python3", requires = "vs_taichi")]
    pub python: String,
}

/// `bench spheres`: the shared-grid sphere pair for 0.3 s, then optionally the Taichi reference.
///
/// # Errors
/// A bad cell size, a failed run, a missing script or a failed Taichi child.
pub fn spheres(a: &SpheresArgs) -> Result<()> {
    if !(a.dx_m.is_finite() && (0.002..=0.05).contains(&a.dx_m)) {
        bail!("--dx-m must be in [0.002, 0.05] m, got {}", a.dx_m);
    }
    let script = if a.vs_taichi {
        Some(find_script("mpm_spheres.py", a.taichi_script.as_deref())?)
    } else {
        None
    };
    let pool = crate::thread_pool(a.threads)?;
    let scene = crate::compare::sphere_pair(Method::Mpm, a.dx_m, 0.5).seed(a.seed);
    let mut w = crate::compare::world(&scene)?;
    let particles = w.particle_count();
    let seconds = pool.install(|| -> Result<f64> {
        let t = Instant::now();
        while !w.is_finished() {
            w.advance_frame()?;
        }
        Ok(t.elapsed().as_secs_f64())
    })?;
    let o = w.objects();
    let (v1, v2) = (o[0].velocity_m_s[0] as f64, o[1].velocity_m_s[0] as f64);
    let substeps = w.stats().substeps;
    let ours = json!({
        "bench": "spheres",
        "impl": "splatphys",
        "method": "mpm",
        "dx_m": a.dx_m,
        "seed": a.seed,
        "particles": particles,
        "threads": a.threads,
        "substeps": substeps,
        "wall_s": seconds,
        "particle_substeps_per_s": particles as f64 * substeps as f64 / seconds,
        "v1_m_s": v1,
        "v2_m_s": v2,
        "rebound_ratio": (v2 - v1) / 2.0,
    });
    println!("{ours}");
    let Some(script) = script else {
        return Ok(());
    };
    let args = [
        ("--dx-m", a.dx_m.to_string()),
        ("--threads", a.threads.to_string()),
        ("--seed", a.seed.to_string()),
    ];
    let Some(theirs) = run_reference(&a.python, &script, &args)? else {
        return Ok(());
    };
    let key = "particle_substeps_per_s";
    let (ours_rate, taichi_rate) = (
        number(&ours, key, "splatphys")?,
        number(&theirs, key, "Taichi")?,
    );
    let (ours_e, taichi_e) = (
        number(&ours, "rebound_ratio", "splatphys")?,
        number(&theirs, "rebound_ratio", "Taichi")?,
    );
    println!(
        "{}",
        json!({
            "bench": "spheres-vs-taichi",
            "dx_m": a.dx_m,
            "threads": a.threads,
            "splatphys_per_s": ours_rate,
            "taichi_per_s": taichi_rate,
            "ratio": ours_rate / taichi_rate,
            "splatphys_rebound_ratio": ours_e,
            "taichi_rebound_ratio": taichi_e,
            "rebound_ratio_diff": ours_e - taichi_e,
            "taichi_version": theirs["taichi_version"],
        })
    );
    Ok(())
}

/// Checks that `python` has Taichi, runs `script` with `args` and prints its result line.
/// `Ok(None)` when Taichi is missing (after one line on stderr saying so).
///
/// # Errors
/// As [`run_script`].
pub fn run_reference(
    python: &str,
    script: &Path,
    args: &[(&str, String)],
) -> Result<Option<Value>> {
    if let Err(why) = available(python) {
        eprintln!("{NOT_INSTALLED} ({why}); --vs-taichi skipped");
        return Ok(None);
    }
    let args: Vec<String> = args
        .iter()
        .flat_map(|(k, v)| [k.to_string(), v.clone()])
        .collect();
    let theirs = run_script(python, script, &args)?;
    println!("{theirs}");
    Ok(Some(theirs))
}

/// The message when Taichi cannot be run.
pub const NOT_INSTALLED: &str = "taichi is not installed: pip install taichi";

/// The script `name` (e.g. `mpm_cube.py`): `explicit` when given, else `bench/taichi/<name>` under
/// the current directory, the repository two levels above the executable (`target/release/`)
/// or the source tree this binary was built from.
///
/// # Errors
/// When the script is not a file, naming the places tried.
pub fn find_script(name: &str, explicit: Option<&Path>) -> Result<PathBuf> {
    crate::script::find("taichi", name, explicit, "--taichi-script", "Taichi")
}

/// Whether `python` runs and imports `taichi`; `Err` holds why not (for the skip message).
pub fn available(python: &str) -> std::result::Result<(), String> {
    match Command::new(python).args(["-c", "import taichi"]).output() {
        Err(e) => Err(format!("{python}: {e}")),
        Ok(o) if o.status.success() => Ok(()),
        Ok(o) => Err(format!(
            "{python} -c 'import taichi' failed: {}",
            last_line(&String::from_utf8_lossy(&o.stderr))
        )),
    }
}

/// Runs `python script args…` and returns its JSON result line (the last stdout line that is a
/// JSON object). Taichi's own output goes to stderr and is shown only on failure.
///
/// # Errors
/// When the child cannot start, exits non-zero or prints no JSON object; with its stderr tail.
pub fn run_script(python: &str, script: &Path, args: &[String]) -> Result<Value> {
    let out = Command::new(python)
        .arg(script)
        .args(args)
        .output()
        .with_context(|| format!("starting {python} {}", script.display()))?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    let tail = tail(&stderr, 20);
    if !out.status.success() {
        bail!(
            "{python} {} failed ({}); its stderr ends with:\n{tail}",
            script.display(),
            out.status
        );
    }
    stdout
        .lines()
        .rev()
        .filter_map(|l| serde_json::from_str::<Value>(l.trim()).ok())
        .find(Value::is_object)
        .with_context(|| {
            format!(
                "{python} {} printed no JSON result; its stderr ends with:\n{tail}",
                script.display()
            )
        })
}

/// The numeric field `key` of a result line.
///
/// # Errors
/// When it is missing or not a number.
pub fn number(v: &Value, key: &str, who: &str) -> Result<f64> {
    v[key]
        .as_f64()
        .with_context(|| format!("{who} result has no number {key:?}: {v}"))
}

fn last_line(s: &str) -> &str {
    s.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("")
}

fn tail(s: &str, lines: usize) -> String {
    let all: Vec<&str> = s.lines().collect();
    all[all.len().saturating_sub(lines)..].join("\n")
}

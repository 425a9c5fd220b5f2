//! Finding the Python reference scripts the benchmarks run as child processes
//! (`bench/taichi/`, `bench/mujoco/`).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};

/// The script `name` of folder `bench/<dir>/`: `explicit` when given (the value of option
/// `flag`), else `bench/<dir>/<name>` under the current directory, the repository two levels
/// above the executable (`target/release/`) or the source tree this binary was built from.
/// `what` names the scripts in the error ("Taichi", "MuJoCo").
///
/// # Errors
/// When the script is not a file, naming the places tried.
pub fn find(
    dir: &str,
    name: &str,
    explicit: Option<&Path>,
    flag: &str,
    what: &str,
) -> Result<PathBuf> {
    if let Some(p) = explicit {
        if !p.is_file() {
            bail!("{flag} {}: no such file", p.display());
        }
        return Ok(p.to_path_buf());
    }
    let rel = Path::new("bench").join(dir).join(name);
    let mut tried = vec![rel.clone()];
    if let Some(root) = std::env::current_exe()
        .ok()
        .and_then(|e| e.parent()?.parent()?.parent().map(Path::to_path_buf))
    {
        tried.push(root.join(&rel));
    }
    tried.push(Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(&rel));
    tried
        .iter()
        .find(|p| p.is_file())
        .cloned()
        .with_context(|| {
            format!(
                "the {what} script {name} was not found (tried {}); pass {flag} PATH",
                tried
                    .iter()
                    .map(|p| p.display().to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })
}

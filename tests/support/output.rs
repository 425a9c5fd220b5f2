//! What the processes wrote: JSON lines on stdout, CSV tables from `splatphys bench`, PNG frames.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use crate::bin;

/// Integer field `key` of the JSON on the last line of `text` (`i64::MIN` when absent).
///
/// # Panics
/// When the last line is not JSON.
pub fn json_field(text: &str, key: &str) -> i64 {
    let v: serde_json::Value = serde_json::from_str(text.lines().last().unwrap_or("{}")).unwrap();
    v[key].as_i64().unwrap_or(i64::MIN)
}

/// The last line of `stdout` as JSON (the summary line of the renderer and the probe).
///
/// # Panics
/// When it is not JSON.
pub fn summary(stdout: &str) -> serde_json::Value {
    let line = stdout.lines().last().unwrap_or("");
    serde_json::from_str(line).unwrap_or_else(|e| panic!("summary `{line}` is not JSON: {e}"))
}

/// Every line of `text` that starts with `{`, as JSON.
///
/// # Panics
/// When one of them is not JSON.
pub fn json_objects(text: &str) -> Vec<serde_json::Value> {
    text.lines()
        .filter(|l| l.starts_with('{'))
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("not JSON: {l:?}: {e}")))
        .collect()
}

/// Runs `splatphys-bench <args> --out-dir <out_dir>` and returns its stdout.
///
/// # Panics
/// When it fails (showing its stderr).
pub fn run_bench(args: &[&str], out_dir: &Path) -> String {
    let out = Command::new(bin("splatphys-bench"))
        .args(args)
        .arg("--out-dir")
        .arg(out_dir)
        .output()
        .unwrap_or_else(|e| panic!("run splatphys bench {args:?}: {e}"));
    assert!(
        out.status.success(),
        "splatphys bench {args:?}: exit {:?}\nstderr: {}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// One CSV row: column name -> field text.
pub type Row = HashMap<String, String>;

/// Every row of the CSV at `path` (RFC 4180 quoting, through the `csv` crate).
///
/// # Panics
/// Naming the file, when it cannot be read or a row's length differs from the header's.
pub fn read_csv(path: &Path) -> Vec<Row> {
    let mut r =
        csv::Reader::from_path(path).unwrap_or_else(|e| panic!("reading {}: {e}", path.display()));
    let header: Vec<String> = r
        .headers()
        .unwrap_or_else(|e| panic!("{}: header: {e}", path.display()))
        .iter()
        .map(str::to_string)
        .collect();
    r.records()
        .map(|rec| {
            let rec = rec.unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            header
                .iter()
                .cloned()
                .zip(rec.iter().map(str::to_string))
                .collect()
        })
        .collect()
}

/// Field `key` of `row` as a number.
///
/// # Panics
/// Naming the field, when it is not one.
pub fn num(row: &Row, key: &str) -> f64 {
    row[key]
        .parse()
        .unwrap_or_else(|_| panic!("{key} = {:?} is not a number", row[key]))
}

/// The PNGs in `dir`, sorted by name (none when `dir` does not exist).
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
///
/// # Panics
/// When it is not a readable image.
pub fn lit_pixels(png: &Path) -> usize {
    let img = image::open(png)
        .unwrap_or_else(|e| panic!("{}: {e}", png.display()))
        .into_rgb8();
    img.pixels().filter(|p| p.0 != [0, 0, 0]).count()
}

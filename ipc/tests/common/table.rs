//! `splatphys bench ...` run as a process, and the CSV files it writes read back as rows of
//! column -> text (RFC 4180 quoting, through the `csv` crate).

use std::collections::HashMap;
use std::path::Path;

/// Runs `splatphys bench <args> --out-dir <out_dir>` and returns its stdout; panics with its
/// stderr when it fails.
pub fn run_bench(args: &[&str], out_dir: &Path) -> String {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_splatphys"))
        .arg("bench")
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

/// Every row of the CSV at `path`; panics naming the file when it cannot be read or a row's
/// length differs from the header's.
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

/// Field `key` of `row` as a number; panics naming it when it is not one.
pub fn num(row: &Row, key: &str) -> f64 {
    row[key]
        .parse()
        .unwrap_or_else(|_| panic!("{key} = {:?} is not a number", row[key]))
}

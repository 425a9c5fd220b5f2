//! CSV files the bench commands write, read back as rows of column -> text (RFC 4180 quoting,
//! through the `csv` crate).

use std::collections::HashMap;
use std::path::Path;

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

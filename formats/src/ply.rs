//! INRIA 3DGS PLY, read and write (Kerbl et al. 2023, the `point_cloud.ply` a 3DGS trainer writes).
//!
//! Layout: one `vertex` element of scalar properties `x y z`, optional `nx ny nz`, `f_dc_0..2`,
//! `f_rest_0..f_rest_{n-1}` (n = 0, 9, 24 or 45 gives SH degree 0..3; channel-major),
//! `opacity` (logit), `scale_0..2` (log), `rot_0..3` (w x y z, raw). Any other scalar property
//! is kept by name in [`GaussianCloud::extra`].
//!
//! The header and body are parsed by the `ply-rs-bw` crate; this module only maps properties.
//! Values are kept exactly (f32 bits), so reading then [`write_ply`] reproduces every property
//! bit for bit, and a file in the standard property order with the same comments byte for byte.
//! Before parsing a body the byte count the header promises is checked against the file size, so
//! a lying header fails fast instead of allocating.

use std::io::{Cursor, Write};
use std::path::{Path, PathBuf};

use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{
    Addable, ElementDef, Encoding, Header, Property, PropertyAccess, PropertyAccessResult,
    PropertyDef, PropertyType, ScalarType,
};

use super::{FormatError, read_bytes};
use crate::gaussians::GaussianCloud;

thread_local! {
    /// Capacity hint for [`Row::new`], set to the element's property count before a body is read.
    static ROW_CAPACITY: std::cell::Cell<usize> = const { std::cell::Cell::new(16) };
}

/// One parsed element row: its scalar property values in header order, widened to f64
/// (exact for every PLY scalar type). List properties are skipped.
struct Row(Vec<f64>);

impl PropertyAccess for Row {
    fn new() -> Self {
        Row(Vec::with_capacity(ROW_CAPACITY.with(|c| c.get())))
    }
    fn set_property(&mut self, _name: &str, _property: Property) -> PropertyAccessResult {
        PropertyAccessResult::Ignored
    }
    fn set_char(&mut self, _: &str, v: i8) -> PropertyAccessResult {
        self.0.push(f64::from(v));
        PropertyAccessResult::Set
    }
    fn set_uchar(&mut self, _: &str, v: u8) -> PropertyAccessResult {
        self.0.push(f64::from(v));
        PropertyAccessResult::Set
    }
    fn set_short(&mut self, _: &str, v: i16) -> PropertyAccessResult {
        self.0.push(f64::from(v));
        PropertyAccessResult::Set
    }
    fn set_ushort(&mut self, _: &str, v: u16) -> PropertyAccessResult {
        self.0.push(f64::from(v));
        PropertyAccessResult::Set
    }
    fn set_int(&mut self, _: &str, v: i32) -> PropertyAccessResult {
        self.0.push(f64::from(v));
        PropertyAccessResult::Set
    }
    fn set_uint(&mut self, _: &str, v: u32) -> PropertyAccessResult {
        self.0.push(f64::from(v));
        PropertyAccessResult::Set
    }
    fn set_float(&mut self, _: &str, v: f32) -> PropertyAccessResult {
        self.0.push(f64::from(v));
        PropertyAccessResult::Set
    }
    fn set_double(&mut self, _: &str, v: f64) -> PropertyAccessResult {
        self.0.push(v);
        PropertyAccessResult::Set
    }
}

/// One element of a parsed PLY: its scalar properties and rows.
pub(crate) struct RawElement {
    /// Element name.
    pub name: String,
    /// Scalar properties in header order with their types.
    pub props: Vec<(String, ScalarType)>,
    /// `[count][props.len()]` values widened to f64.
    pub rows: Vec<Vec<f64>>,
}

impl RawElement {
    /// Column index of property `name`.
    pub fn col(&self, name: &str) -> Option<usize> {
        self.props.iter().position(|(n, _)| n == name)
    }

    /// Column index of a property that must exist.
    pub fn require(&self, path: &Path, name: &str) -> Result<usize, FormatError> {
        self.col(name).ok_or_else(|| FormatError::MissingProperty {
            path: path.to_path_buf(),
            element: self.name.clone(),
            property: name.to_string(),
        })
    }
}

/// A parsed PLY file: header comments and the elements read.
pub(crate) struct RawPly {
    /// Header `comment` lines (without the `comment ` prefix).
    pub comments: Vec<String>,
    /// Elements in file order, up to and including the last one asked for.
    pub elements: Vec<RawElement>,
}

impl RawPly {
    /// The element called `name`.
    pub fn element(&self, path: &Path, name: &str) -> Result<&RawElement, FormatError> {
        self.elements
            .iter()
            .find(|e| e.name == name)
            .ok_or_else(|| FormatError::MissingElement {
                path: path.to_path_buf(),
                element: name.to_string(),
            })
    }
}

fn scalar_size(t: &ScalarType) -> u64 {
    match t {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    }
}

/// Parses the header and the bodies of every element up to the last one named in `wanted`
/// (elements after it are not read). Binary encodings only.
pub(crate) fn parse_raw(path: &Path, bytes: &[u8], wanted: &[&str]) -> Result<RawPly, FormatError> {
    let mut reader = Reader::new(Cursor::new(bytes));
    let parser = Parser::<Row>::new();
    let header = parser
        .read_header(&mut reader)
        .map_err(|e| FormatError::Header {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
    match header.encoding {
        Encoding::BinaryLittleEndian | Encoding::BinaryBigEndian => {}
        Encoding::Ascii => {
            return Err(FormatError::UnsupportedEncoding {
                path: path.to_path_buf(),
                encoding: "ascii".into(),
            });
        }
    }
    check_duplicates(path, bytes, &header)?;
    let consumed = reader.get_ref().position() as usize;
    let mut available = (bytes.len() - consumed.min(bytes.len())) as u64;

    let last_wanted = header
        .elements
        .values()
        .rposition(|e| wanted.contains(&e.name.as_str()));
    let Some(last_wanted) = last_wanted else {
        return Err(FormatError::MissingElement {
            path: path.to_path_buf(),
            element: wanted.first().copied().unwrap_or("vertex").to_string(),
        });
    };

    let mut elements = Vec::new();
    for (idx, def) in header.elements.values().enumerate() {
        if idx > last_wanted {
            break;
        }
        let mut min_row = 0u64;
        let mut props = Vec::new();
        for (name, p) in &def.properties {
            match &p.data_type {
                PropertyType::Scalar(t) => {
                    min_row += scalar_size(t);
                    props.push((name.clone(), t.clone()));
                }
                PropertyType::List(index, _) => min_row += scalar_size(index),
            }
        }
        if min_row == 0 && def.count > 0 {
            return Err(FormatError::Layout {
                path: path.to_path_buf(),
                element: def.name.clone(),
                problem: format!("{} rows declared but no properties", def.count),
            });
        }
        let needed = (def.count as u64).saturating_mul(min_row);
        if needed > available {
            return Err(FormatError::Truncated {
                path: path.to_path_buf(),
                element: def.name.clone(),
                needed_bytes: needed,
                available_bytes: available,
            });
        }
        available -= needed;
        ROW_CAPACITY.with(|c| c.set(props.len()));
        let rows = parser
            .read_payload_for_element(&mut reader, def, &header)
            .map_err(|e| {
                if e.kind() == std::io::ErrorKind::UnexpectedEof {
                    FormatError::Truncated {
                        path: path.to_path_buf(),
                        element: def.name.clone(),
                        needed_bytes: needed,
                        available_bytes: available,
                    }
                } else {
                    FormatError::Payload {
                        path: path.to_path_buf(),
                        element: def.name.clone(),
                        message: e.to_string(),
                    }
                }
            })?;
        elements.push(RawElement {
            name: def.name.clone(),
            props,
            rows: rows.into_iter().map(|r| r.0).collect(),
        });
    }
    Ok(RawPly {
        comments: header.comments.clone(),
        elements,
    })
}

/// The parser's header map keeps one entry per property name, so a repeated name would shift
/// every later column. Count the `property` lines of each element in the raw header instead.
fn check_duplicates(path: &Path, bytes: &[u8], header: &Header) -> Result<(), FormatError> {
    let end = bytes
        .windows(10)
        .position(|w| w == b"end_header")
        .unwrap_or(bytes.len());
    let text = String::from_utf8_lossy(&bytes[..end]);
    let mut current: Option<&ElementDef> = None;
    let mut seen = std::collections::HashSet::new();
    for line in text.lines() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("element") => {
                let name = words.next().unwrap_or("");
                current = header.elements.get(name);
                seen.clear();
            }
            Some("property") => {
                let name = line.split_whitespace().last().unwrap_or("");
                if !seen.insert(name.to_string()) {
                    return Err(FormatError::BadProperty {
                        path: path.to_path_buf(),
                        element: current.map(|e| e.name.clone()).unwrap_or_default(),
                        property: name.to_string(),
                        problem: "declared twice".into(),
                    });
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// A read INRIA PLY: the Gaussians plus the header comments (kept so a rewrite is byte-exact).
#[derive(Debug, Clone, PartialEq)]
pub struct PlyFile {
    /// The Gaussians, values exactly as stored.
    pub cloud: GaussianCloud,
    /// Header `comment` lines, without the `comment ` prefix.
    pub comments: Vec<String>,
}

/// Reads an INRIA 3DGS PLY file.
///
/// # Errors
/// [`FormatError`] for an unreadable file, a non-binary encoding, missing or duplicated
/// properties, a bad `f_rest_*` count, a truncated body or NaN/infinite values.
pub fn read_ply(path: impl AsRef<Path>) -> Result<PlyFile, FormatError> {
    let path = path.as_ref();
    let bytes = read_bytes(path)?;
    parse_ply(path, &bytes)
}

const CORE: [&str; 14] = [
    "x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1", "scale_2",
    "rot_0", "rot_1", "rot_2", "rot_3",
];

/// Parses INRIA PLY `bytes`; `path` only names the file in errors.
///
/// # Errors
/// As [`read_ply`].
pub fn parse_ply(path: &Path, bytes: &[u8]) -> Result<PlyFile, FormatError> {
    let raw = parse_raw(path, bytes, &["vertex"])?;
    let v = raw.element(path, "vertex")?;
    let mut core = [0usize; 14];
    for (slot, name) in core.iter_mut().zip(CORE) {
        *slot = v.require(path, name)?;
    }
    let normals = match (v.col("nx"), v.col("ny"), v.col("nz")) {
        (Some(a), Some(b), Some(c)) => Some([a, b, c]),
        _ => None,
    };
    let n_rest = v
        .props
        .iter()
        .filter(|(n, _)| n.starts_with("f_rest_"))
        .count();
    if ![0, 9, 24, 45].contains(&n_rest) {
        return Err(FormatError::BadShCount {
            path: path.to_path_buf(),
            count: n_rest,
        });
    }
    let mut rest_cols = Vec::with_capacity(n_rest);
    for j in 0..n_rest {
        rest_cols.push(
            v.col(&format!("f_rest_{j}"))
                .ok_or(FormatError::BadShCount {
                    path: path.to_path_buf(),
                    count: n_rest,
                })?,
        );
    }
    let mut used = vec![false; v.props.len()];
    for &c in core
        .iter()
        .chain(rest_cols.iter())
        .chain(normals.iter().flatten())
    {
        used[c] = true;
    }
    let extra_cols: Vec<usize> = (0..v.props.len()).filter(|&c| !used[c]).collect();

    // Every value must be finite.
    for (row_idx, row) in v.rows.iter().enumerate() {
        if let Some(c) = row.iter().position(|x| !x.is_finite()) {
            return Err(FormatError::NonFinite {
                path: path.to_path_buf(),
                element: "vertex".into(),
                property: v.props[c].0.clone(),
                row: row_idx,
                value: row[c],
            });
        }
    }

    let n = v.rows.len();
    let f = |row: &[f64], c: usize| row[c] as f32;
    let mut cloud = GaussianCloud {
        normals: normals.map(|_| Vec::with_capacity(n)),
        extra: extra_cols
            .iter()
            .map(|&c| (v.props[c].0.clone(), Vec::with_capacity(n)))
            .collect(),
        ..GaussianCloud::with_capacity(n, n_rest)
    };
    for row in &v.rows {
        let c = &core;
        cloud
            .positions
            .push([f(row, c[0]), f(row, c[1]), f(row, c[2])]);
        cloud.sh_dc.push([f(row, c[3]), f(row, c[4]), f(row, c[5])]);
        cloud.opacity_logit.push(f(row, c[6]));
        cloud
            .log_scales
            .push([f(row, c[7]), f(row, c[8]), f(row, c[9])]);
        cloud
            .rotations_wxyz
            .push([f(row, c[10]), f(row, c[11]), f(row, c[12]), f(row, c[13])]);
        if let (Some(ns), Some(out)) = (&normals, cloud.normals.as_mut()) {
            out.push([f(row, ns[0]), f(row, ns[1]), f(row, ns[2])]);
        }
        cloud.sh_rest.extend(rest_cols.iter().map(|&rc| f(row, rc)));
        for ((_, out), &ec) in cloud.extra.iter_mut().zip(&extra_cols) {
            out.push(f(row, ec));
        }
    }
    cloud.sh_degree = effective_sh_degree(&cloud.sh_rest, n_rest);
    Ok(PlyFile {
        cloud,
        comments: raw.comments,
    })
}

/// SH degree actually used: the highest band (1..=3) with a non-zero coefficient among
/// `[N][n_rest]` channel-major `f_rest` values, else 0. Files that store zero `f_rest_*` (the
/// 62-property layout of an SH-degree-0 scene) are degree 0; the zeros are kept for writing.
pub fn effective_sh_degree(sh_rest: &[f32], n_rest: usize) -> u8 {
    if n_rest == 0 {
        return 0;
    }
    let k = n_rest / 3; // coefficients per channel beyond DC
    let band = |j: usize| -> u8 {
        match j {
            0..=2 => 1,
            3..=7 => 2,
            _ => 3,
        }
    };
    let mut degree = 0u8;
    for row in sh_rest.chunks_exact(n_rest) {
        for (idx, v) in row.iter().enumerate() {
            if *v != 0.0 {
                degree = degree.max(band(idx % k));
            }
        }
        if degree == 3 {
            break;
        }
    }
    degree
}

/// Checks that every per-Gaussian field of `cloud` has the length `positions` implies.
pub(crate) fn check_cloud(path: &Path, cloud: &GaussianCloud) -> Result<(), FormatError> {
    let n = cloud.len();
    let bad = |field: &str, len: usize, expected: usize| FormatError::InconsistentCloud {
        path: path.to_path_buf(),
        field: field.to_string(),
        len,
        expected,
    };
    let checks = [
        ("sh_dc", cloud.sh_dc.len(), n),
        ("opacity_logit", cloud.opacity_logit.len(), n),
        ("log_scales", cloud.log_scales.len(), n),
        ("rotations_wxyz", cloud.rotations_wxyz.len(), n),
        ("sh_rest", cloud.sh_rest.len(), n * cloud.sh_rest_len),
    ];
    for (field, len, expected) in checks {
        if len != expected {
            return Err(bad(field, len, expected));
        }
    }
    if let Some(normals) = &cloud.normals
        && normals.len() != n
    {
        return Err(bad("normals", normals.len(), n));
    }
    for (name, values) in &cloud.extra {
        if values.len() != n {
            return Err(bad(&format!("extra:{name}"), values.len(), n));
        }
    }
    Ok(())
}

/// Property names in the order [`write_ply`] writes them.
pub fn property_names(cloud: &GaussianCloud) -> Vec<String> {
    let mut names: Vec<String> = ["x", "y", "z"].iter().map(|s| s.to_string()).collect();
    if cloud.normals.is_some() {
        names.extend(["nx", "ny", "nz"].iter().map(|s| s.to_string()));
    }
    names.extend(["f_dc_0", "f_dc_1", "f_dc_2"].iter().map(|s| s.to_string()));
    names.extend((0..cloud.sh_rest_len).map(|j| format!("f_rest_{j}")));
    names.extend(
        [
            "opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3",
        ]
        .iter()
        .map(|s| s.to_string()),
    );
    names.extend(cloud.extra.iter().map(|(n, _)| n.clone()));
    names
}

/// Writes `cloud` as a binary little-endian INRIA PLY to `out`: properties in the order of
/// [`property_names`] (all `float`), then the `comments`. `path` only names the destination in
/// errors. The header is written by `ply-rs-bw`; the body is the raw f32 values.
///
/// # Errors
/// [`FormatError::InconsistentCloud`] when field lengths disagree; [`FormatError::Io`] when
/// writing fails.
pub fn write_ply_to(
    path: &Path,
    cloud: &GaussianCloud,
    comments: &[String],
    out: &mut impl Write,
) -> Result<(), FormatError> {
    check_cloud(path, cloud)?;
    let io = |source: std::io::Error| FormatError::Io {
        path: path.to_path_buf(),
        source,
    };
    let names = property_names(cloud);
    let mut header = Header::new();
    header.encoding = Encoding::BinaryLittleEndian;
    header.comments = comments.to_vec();
    let mut vertex = ElementDef::new("vertex".to_string());
    vertex.count = cloud.len();
    for name in &names {
        vertex.properties.add(PropertyDef::new(
            name.clone(),
            PropertyType::Scalar(ScalarType::Float),
        ));
    }
    header.elements.add(vertex);
    ply_rs_bw::writer::Writer::<Row>::new()
        .write_header(out, &header)
        .map_err(io)?;

    let mut buf: Vec<u8> = Vec::with_capacity(names.len() * 4 * 4096);
    let mut row: Vec<f32> = Vec::with_capacity(names.len());
    for i in 0..cloud.len() {
        row.clear();
        row.extend_from_slice(&cloud.positions[i]);
        if let Some(nrm) = &cloud.normals {
            row.extend_from_slice(&nrm[i]);
        }
        row.extend_from_slice(&cloud.sh_dc[i]);
        let r = cloud.sh_rest_len;
        row.extend_from_slice(&cloud.sh_rest[i * r..(i + 1) * r]);
        row.push(cloud.opacity_logit[i]);
        row.extend_from_slice(&cloud.log_scales[i]);
        row.extend_from_slice(&cloud.rotations_wxyz[i]);
        row.extend(cloud.extra.iter().map(|(_, v)| v[i]));
        for v in &row {
            buf.extend_from_slice(&v.to_le_bytes());
        }
        if buf.len() >= 1 << 20 {
            out.write_all(&buf).map_err(io)?;
            buf.clear();
        }
    }
    out.write_all(&buf).map_err(io)?;
    Ok(())
}

/// Writes `cloud` to the file `path` (see [`write_ply_to`]).
///
/// # Errors
/// As [`write_ply_to`].
pub fn write_ply(
    path: impl AsRef<Path>,
    cloud: &GaussianCloud,
    comments: &[String],
) -> Result<(), FormatError> {
    let path: PathBuf = path.as_ref().to_path_buf();
    let file = std::fs::File::create(&path).map_err(|source| FormatError::Io {
        path: path.clone(),
        source,
    })?;
    let mut w = std::io::BufWriter::new(file);
    write_ply_to(&path, cloud, comments, &mut w)?;
    w.flush().map_err(|source| FormatError::Io { path, source })
}

/// Serialises `cloud` to an in-memory INRIA PLY (see [`write_ply_to`]).
///
/// # Errors
/// [`FormatError::InconsistentCloud`] when field lengths disagree.
pub fn to_ply_bytes(cloud: &GaussianCloud, comments: &[String]) -> Result<Vec<u8>, FormatError> {
    let mut out = Vec::new();
    write_ply_to(Path::new("<memory>"), cloud, comments, &mut out)?;
    Ok(out)
}

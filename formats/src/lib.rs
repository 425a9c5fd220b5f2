//! splatphys-formats: 3D Gaussian Splatting files and the Gaussians they hold, without the
//! simulation, so renderers, recorders and the engine share one reader.
//!
//! 3DGS file formats: INRIA PLY (Kerbl et al. 2023, read and write), antimatter15 `.splat`
//! and SuperSplat/PlayCanvas compressed PLY (read), and a file report for `splatphys inspect`;
//! [`gaussians`] is the cloud they read into, with the SH rotation that turns its colours.
//!
//! Every reader returns a [`GaussianCloud`] in the file's own frame and units with the values
//! exactly as the file stores them (log scales, opacity logits, raw quaternions). Bad input gives
//! a [`FormatError`] naming the file, element and property; no reader panics on input.

pub mod compressed;
pub mod gaussians;
pub mod inspect;
pub mod npy;
pub mod ply;
pub mod splat;

use std::path::{Path, PathBuf};

use crate::gaussians::GaussianCloud;

/// Everything that can go wrong reading or writing a 3DGS file.
#[derive(Debug, thiserror::Error)]
pub enum FormatError {
    /// The file could not be opened, read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating-system error.
        source: std::io::Error,
    },
    /// The PLY header could not be parsed (not a PLY file, bad line, missing `end_header`).
    #[error("{}: PLY header: {message}", path.display())]
    Header {
        /// The file.
        path: PathBuf,
        /// What the PLY parser reported.
        message: String,
    },
    /// The PLY encoding is not one this reader supports (only binary little/big endian).
    #[error("{}: PLY encoding {encoding} not supported (expected binary_little_endian)", path.display())]
    UnsupportedEncoding {
        /// The file.
        path: PathBuf,
        /// The encoding named in the header.
        encoding: String,
    },
    /// A required element is not declared in the header.
    #[error("{}: element {element} missing", path.display())]
    MissingElement {
        /// The file.
        path: PathBuf,
        /// The element name (`vertex`, `chunk`).
        element: String,
    },
    /// A required property is not declared for an element.
    #[error("{}: property {property} missing from element {element}", path.display())]
    MissingProperty {
        /// The file.
        path: PathBuf,
        /// The element name.
        element: String,
        /// The property name.
        property: String,
    },
    /// A property is declared twice, or with a type this reader cannot use.
    #[error("{}: element {element} property {property}: {problem}", path.display())]
    BadProperty {
        /// The file.
        path: PathBuf,
        /// The element name.
        element: String,
        /// The property name.
        property: String,
        /// What is wrong with it.
        problem: String,
    },
    /// The body is shorter than the header promises.
    #[error(
        "{}: element {element} truncated: needs at least {needed_bytes} bytes, {available_bytes} left",
        path.display()
    )]
    Truncated {
        /// The file.
        path: PathBuf,
        /// The element being read.
        element: String,
        /// Bytes the header's counts require.
        needed_bytes: u64,
        /// Bytes present after the header.
        available_bytes: u64,
    },
    /// The PLY parser failed inside an element's body.
    #[error("{}: element {element}: {message}", path.display())]
    Payload {
        /// The file.
        path: PathBuf,
        /// The element being read.
        element: String,
        /// What the PLY parser reported.
        message: String,
    },
    /// A value is NaN or infinite.
    #[error("{}: element {element} property {property} row {row}: non-finite value {value}", path.display())]
    NonFinite {
        /// The file.
        path: PathBuf,
        /// The element name.
        element: String,
        /// The property name.
        property: String,
        /// 0-based row (Gaussian index).
        row: usize,
        /// The offending value.
        value: f64,
    },
    /// The `f_rest_*` properties are not `f_rest_0..f_rest_{n-1}` with n in {0, 9, 24, 45}.
    #[error("{}: element vertex: {count} f_rest_* properties (expected 0, 9, 24 or 45, numbered from 0)", path.display())]
    BadShCount {
        /// The file.
        path: PathBuf,
        /// How many `f_rest_*` properties were found.
        count: usize,
    },
    /// A structural inconsistency in a format (a `.splat` size not a multiple of 32, chunk
    /// count not matching the vertex count, ...).
    #[error("{}: element {element}: {problem}", path.display())]
    Layout {
        /// The file.
        path: PathBuf,
        /// The element (or `body` for headerless formats).
        element: String,
        /// What is inconsistent.
        problem: String,
    },
    /// A [`GaussianCloud`] handed to a writer has fields of inconsistent lengths.
    #[error("{}: cannot write: field {field} has length {len}, expected {expected}", path.display())]
    InconsistentCloud {
        /// The destination.
        path: PathBuf,
        /// The field name (`sh_dc`, `extra:feat_0`, ...).
        field: String,
        /// Its length.
        len: usize,
        /// The length implied by `positions`.
        expected: usize,
    },
}

/// The formats [`read_gaussians`] recognises.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FileFormat {
    /// INRIA 3DGS PLY (float properties in one `vertex` element).
    InriaPly,
    /// SuperSplat/PlayCanvas compressed PLY (`chunk` + packed `vertex` elements).
    CompressedPly,
    /// antimatter15 `.splat`, 32 bytes per Gaussian, no header.
    Splat,
}

impl std::fmt::Display for FileFormat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::InriaPly => "INRIA PLY",
            Self::CompressedPly => "compressed PLY (SuperSplat)",
            Self::Splat => "antimatter15 .splat",
        })
    }
}

/// Reads a file into memory, mapping the error to [`FormatError::Io`].
pub(crate) fn read_bytes(path: &Path) -> Result<Vec<u8>, FormatError> {
    std::fs::read(path).map_err(|source| FormatError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Guesses the format of `bytes` (named `path`): a PLY magic number selects PLY (compressed when
/// it declares a `chunk` element), otherwise `.splat`.
pub fn detect_format(path: &Path, bytes: &[u8]) -> FileFormat {
    if bytes.starts_with(b"ply") {
        let head = &bytes[..bytes.len().min(64 * 1024)];
        let text = String::from_utf8_lossy(head);
        let header_end = text.find("end_header").unwrap_or(text.len());
        if text[..header_end]
            .lines()
            .any(|l| l.trim_start().starts_with("element chunk"))
        {
            FileFormat::CompressedPly
        } else {
            FileFormat::InriaPly
        }
    } else {
        let _ = path;
        FileFormat::Splat
    }
}

/// Reads any supported 3DGS file (format detected from its content) into a [`GaussianCloud`].
///
/// # Errors
/// [`FormatError`] naming the file, element and property for unreadable or malformed input.
pub fn read_gaussians(path: impl AsRef<Path>) -> Result<GaussianCloud, FormatError> {
    let path = path.as_ref();
    let bytes = read_bytes(path)?;
    parse_gaussians(path, &bytes).map(|(cloud, _)| cloud)
}

/// Parses `bytes` (reported as `path` in errors) in any supported format; returns the cloud and
/// the format found.
///
/// # Errors
/// [`FormatError`] for malformed input.
pub fn parse_gaussians(
    path: &Path,
    bytes: &[u8],
) -> Result<(GaussianCloud, FileFormat), FormatError> {
    let format = detect_format(path, bytes);
    let cloud = match format {
        FileFormat::InriaPly => ply::parse_ply(path, bytes)?.cloud,
        FileFormat::CompressedPly => compressed::parse_compressed_ply(path, bytes)?,
        FileFormat::Splat => splat::parse_splat(path, bytes)?,
    };
    Ok((cloud, format))
}

//! splatphys-formats: 3D Gaussian Splatting files and the Gaussians they hold, without the
//! simulation, so renderers, recorders and the engine share one reader.
//!
//! 3DGS file formats: INRIA PLY (Kerbl et al. 2023, read and write), Niantic SPZ (read and
//! write), antimatter15 `.splat`, SuperSplat/PlayCanvas compressed PLY, PlayCanvas SOG (folder,
//! `.sog` bundle, streamed level of detail) and glTF/GLB with `KHR_gaussian_splatting` (read),
//! and a file report for `splatphys inspect`; [`gaussians`] is the cloud they read into, with
//! the SH rotation that turns its colours; [`posed`] turns a simulated frame back into one.
//!
//! Every reader returns a [`GaussianCloud`] in the INRIA parameterisation (log scales, opacity
//! logits, quaternions w x y z) and in PLY's frame (COLMAP's: x right, y down, z forward):
//! formats whose convention differs (SPZ: y up, z back; glTF: y up, x left) are turned once, on
//! reading, by a proper rotation. Values a PLY stores are kept exactly as stored. Bad input gives
//! a [`FormatError`] naming the file, element and property; no reader panics on input.

pub mod compressed;
pub mod gaussians;
pub mod gltf;
pub mod inspect;
pub mod npy;
pub mod ply;
pub mod posed;
pub mod sog;
pub mod splat;
pub mod spz;

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
    /// PlayCanvas SOG: a folder with `meta.json` and WebP images, or its `meta.json`.
    Sog,
    /// PlayCanvas SOG bundled in one `.sog` ZIP.
    SogBundle,
    /// PlayCanvas streamed SOG (`lod-meta.json` and chunk folders), one level read.
    SogLod,
    /// Niantic SPZ (versions 1–4).
    Spz,
    /// glTF or GLB with `KHR_gaussian_splatting`.
    Gltf,
}

/// Choices a reader cannot take from the file alone.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub struct ReadOptions {
    /// Level of a streamed SOG to read, 0 the finest (the default).
    pub lod: Option<usize>,
    /// Frame of an SPZ's stored values ([`spz::SpzFrame::Rub`], the format's convention, by
    /// default).
    pub spz_frame: spz::SpzFrame,
}

impl std::fmt::Display for FileFormat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::InriaPly => "INRIA PLY",
            Self::CompressedPly => "compressed PLY (SuperSplat)",
            Self::Splat => "antimatter15 .splat",
            Self::Sog => "SOG (PlayCanvas)",
            Self::SogBundle => "bundled SOG (PlayCanvas .sog)",
            Self::SogLod => "streamed SOG (PlayCanvas lod-meta.json)",
            Self::Spz => "SPZ (Niantic)",
            Self::Gltf => "glTF KHR_gaussian_splatting",
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

/// Guesses the format of `bytes` (named `path`) from its content: a PLY magic number selects
/// PLY (compressed when it declares a `chunk` element), `PK` a SOG bundle, the gzip magic or
/// `NGSP` SPZ, `glTF` or a JSON object with `"asset"` glTF, a JSON object with `"means"` a SOG
/// `meta.json` and one with `"filenames"` and `"tree"` a streamed SOG; a file named `.splat`,
/// and anything else, `.splat` (which has no magic number).
pub fn detect_format(path: &Path, bytes: &[u8]) -> FileFormat {
    let named_splat = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("splat"));
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
    } else if named_splat {
        FileFormat::Splat
    } else if bytes.starts_with(b"PK\x03\x04") {
        FileFormat::SogBundle
    } else if bytes.starts_with(&spz::GZIP_MAGIC) || bytes.starts_with(b"NGSP") {
        FileFormat::Spz
    } else if bytes.starts_with(gltf::GLB_MAGIC) {
        FileFormat::Gltf
    } else if bytes.trim_ascii_start().starts_with(b"{") {
        let head = String::from_utf8_lossy(&bytes[..bytes.len().min(64 * 1024)]);
        if head.contains("\"filenames\"") && head.contains("\"tree\"") {
            FileFormat::SogLod
        } else if head.contains("\"means\"") {
            FileFormat::Sog
        } else if head.contains("\"asset\"") {
            FileFormat::Gltf
        } else {
            FileFormat::Splat
        }
    } else {
        FileFormat::Splat
    }
}

/// Reads any supported 3DGS file (format detected from its content) into a [`GaussianCloud`];
/// a folder is read as a SOG (or a streamed SOG when it holds `lod-meta.json`).
///
/// # Errors
/// [`FormatError`] naming the file, element and property for unreadable or malformed input.
pub fn read_gaussians(path: impl AsRef<Path>) -> Result<GaussianCloud, FormatError> {
    read_gaussians_with(path, &ReadOptions::default()).map(|(cloud, _)| cloud)
}

/// [`read_gaussians`] with the choices of [`ReadOptions`]; also returns the format found.
///
/// # Errors
/// As [`read_gaussians`].
pub fn read_gaussians_with(
    path: impl AsRef<Path>,
    options: &ReadOptions,
) -> Result<(GaussianCloud, FileFormat), FormatError> {
    read_gaussians_noted(path, options).map(|(cloud, format, _)| (cloud, format))
}

/// [`read_gaussians_with`], also returning what was read but not kept, for people (an SPZ's SH
/// degree 4 cut to 3, ...).
///
/// # Errors
/// As [`read_gaussians`].
pub fn read_gaussians_noted(
    path: impl AsRef<Path>,
    options: &ReadOptions,
) -> Result<(GaussianCloud, FileFormat, Vec<String>), FormatError> {
    let path = path.as_ref();
    if path.is_dir() {
        let format = if path.join(sog::LOD_META_JSON).is_file() {
            FileFormat::SogLod
        } else {
            FileFormat::Sog
        };
        return Ok((sog::read_sog(path, options.lod)?, format, Vec::new()));
    }
    let bytes = read_bytes(path)?;
    let format = detect_format(path, &bytes);
    let mut notes = Vec::new();
    let cloud = match format {
        FileFormat::Sog | FileFormat::SogBundle | FileFormat::SogLod => {
            sog::read_sog(path, options.lod)?
        }
        FileFormat::Spz => {
            let (cloud, degree) = spz::parse_spz_degree(path, &bytes, options.spz_frame)?;
            if degree > 3 {
                notes.push(format!(
                    "{}: SH degree {degree} cut to 3 (splatphys evaluates degrees 0 to 3)",
                    path.display()
                ));
            }
            cloud
        }
        FileFormat::Gltf => gltf::parse_gltf(path, &bytes)?,
        _ => parse_gaussians(path, &bytes)?.0,
    };
    Ok((cloud, format, notes))
}

/// Parses `bytes` (reported as `path` in errors) in any format held in one file without
/// companions (PLY, compressed PLY, `.splat`, SPZ, GLB, a `.sog` bundle); returns the cloud and
/// the format found. A SOG `meta.json`, a streamed SOG or a `.gltf` with external buffers need
/// their folder: use [`read_gaussians`].
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
        FileFormat::SogBundle => sog::parse_bundle(path, bytes)?,
        FileFormat::Spz => spz::parse_spz(path, bytes, spz::SpzFrame::default())?,
        FileFormat::Gltf => gltf::parse_gltf(path, bytes)?,
        FileFormat::Sog | FileFormat::SogLod => {
            return Err(FormatError::Layout {
                path: path.to_path_buf(),
                element: "body".into(),
                problem: format!("a {format} needs the files beside it: read it from its folder"),
            });
        }
    };
    Ok((cloud, format))
}

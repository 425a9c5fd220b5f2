//! Reading a recording, including one whose recorder was killed.
//!
//! A linear read with `IgnoreEndMagic` walks the data section chunk by chunk, so a file cut
//! off by a kill -9 still yields every chunk that was closed; the summary is lost then, which
//! only costs random access.

use std::path::Path;

use bytemuck::Pod;
use mcap::read::{MessageStream, Options};
use splatphys_ipc::wire::{FrameHeader, ObjectState};

use crate::channels::{FRAME, OBJECTS};
use crate::error::RecordError;

/// One message of a recording, owned.
#[derive(Debug, Clone)]
pub struct RecordedMessage {
    /// Topic.
    pub topic: String,
    /// Sequence number.
    pub sequence: u32,
    /// Wall time it was recorded, ns since the UNIX epoch.
    pub log_time_ns: u64,
    /// Simulated time, ns.
    pub publish_time_ns: u64,
    /// Raw bytes.
    pub data: Vec<u8>,
}

/// Reads the whole file into memory.
///
/// # Errors
/// I/O errors.
pub fn read_file(path: &Path) -> Result<Vec<u8>, RecordError> {
    std::fs::read(path).map_err(|source| RecordError::Io {
        path: path.display().to_string(),
        source,
    })
}

/// Every message in file order. With `recover`, a truncated file (killed recorder) yields the
/// messages of every closed chunk and stops quietly at the cut.
///
/// # Errors
/// MCAP errors (without `recover`, or before the first message).
pub fn messages(
    bytes: &[u8],
    path: &Path,
    recover: bool,
) -> Result<Vec<RecordedMessage>, RecordError> {
    let opts = if recover {
        Options::IgnoreEndMagic.into()
    } else {
        Default::default()
    };
    let stream =
        MessageStream::new_with_options(bytes, opts).map_err(|source| RecordError::Mcap {
            path: path.display().to_string(),
            source,
        })?;
    let mut out = Vec::new();
    for m in stream {
        match m {
            Ok(m) => out.push(RecordedMessage {
                topic: m.channel.topic.clone(),
                sequence: m.sequence,
                log_time_ns: m.log_time,
                publish_time_ns: m.publish_time,
                data: m.data.into_owned(),
            }),
            Err(_) if recover => break,
            Err(source) => {
                return Err(RecordError::Mcap {
                    path: path.display().to_string(),
                    source,
                });
            }
        }
    }
    Ok(out)
}

/// Splits a raw message into its header and payload elements (copied: MCAP data is unaligned).
///
/// # Errors
/// [`RecordError::BadMessage`] when the sizes do not fit.
pub fn split<H: Pod, T: Pod>(
    m: &RecordedMessage,
    path: &Path,
    what: &'static str,
) -> Result<(H, Vec<T>), RecordError> {
    let bad = || RecordError::BadMessage {
        path: path.display().to_string(),
        topic: m.topic.clone(),
        sequence: m.sequence,
        len: m.data.len(),
        what,
    };
    let hs = size_of::<H>();
    if m.data.len() < hs || !(m.data.len() - hs).is_multiple_of(size_of::<T>().max(1)) {
        return Err(bad());
    }
    let header: H = bytemuck::pod_read_unaligned(&m.data[..hs]);
    let n = (m.data.len() - hs) / size_of::<T>().max(1);
    let mut payload = vec![T::zeroed(); n];
    bytemuck::cast_slice_mut::<T, u8>(&mut payload).copy_from_slice(&m.data[hs..]);
    Ok((header, payload))
}

/// The frame headers in a recording, in order.
///
/// # Errors
/// As [`split`].
pub fn frame_headers(
    msgs: &[RecordedMessage],
    path: &Path,
) -> Result<Vec<FrameHeader>, RecordError> {
    msgs.iter()
        .filter(|m| m.topic == FRAME)
        .map(|m| {
            if m.data.len() < size_of::<FrameHeader>() {
                return Err(RecordError::BadMessage {
                    path: path.display().to_string(),
                    topic: m.topic.clone(),
                    sequence: m.sequence,
                    len: m.data.len(),
                    what: "frame",
                });
            }
            Ok(bytemuck::pod_read_unaligned(
                &m.data[..size_of::<FrameHeader>()],
            ))
        })
        .collect()
}

/// Writes the objects of every frame as CSV:
/// `step,time_s,object,x_m,y_m,z_m,vx_m_s,vy_m_s,vz_m_s,mass_kg`. Returns the rows written.
///
/// # Errors
/// As [`split`], and I/O errors of `out`.
pub fn objects_csv(
    msgs: &[RecordedMessage],
    path: &Path,
    out: &mut impl std::io::Write,
) -> Result<u64, RecordError> {
    let io = |source| RecordError::Io {
        path: path.display().to_string(),
        source,
    };
    writeln!(
        out,
        "step,time_s,object,x_m,y_m,z_m,vx_m_s,vy_m_s,vz_m_s,mass_kg"
    )
    .map_err(io)?;
    let mut rows = 0;
    for m in msgs.iter().filter(|m| m.topic == OBJECTS) {
        let (h, objs): (FrameHeader, Vec<ObjectState>) = split(m, path, "objects")?;
        for o in objs {
            let (p, v) = (o.position_m, o.velocity_m_s);
            writeln!(
                out,
                "{},{},{},{},{},{},{},{},{},{}",
                h.step, h.time_s, o.id, p[0], p[1], p[2], v[0], v[1], v[2], o.mass_kg
            )
            .map_err(io)?;
            rows += 1;
        }
    }
    Ok(rows)
}

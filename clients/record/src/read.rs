//! Reading a recording, including one whose recorder was killed.
//!
//! A linear read with `IgnoreEndMagic` walks the data section chunk by chunk, so a file cut
//! off by a kill -9 still yields every chunk that was closed; the summary is lost then, which
//! only costs random access.

use std::path::Path;

use bytemuck::Pod;
use mcap::read::{MessageStream, Options};
use splatphys_ipc::wire::{FrameHeader, ObjectName, ObjectState, SceneHeader, read_fixed_str};

use crate::channels::{FRAME, OBJECT_NAMES, OBJECTS, SCENE};
use crate::error::RecordError;
use crate::objects_csv::ObjectsCsv;

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

/// Object names of a recording (`names[id]`): every object's from the first `/object_names`
/// message, or, in a recording without one, the first scene header's (which names the first
/// [`MAX_NAMED_OBJECTS`](splatphys_ipc::wire::MAX_NAMED_OBJECTS) objects). Empty when the
/// recording holds neither.
pub fn object_names(msgs: &[RecordedMessage]) -> Vec<String> {
    if let Some(m) = msgs.iter().find(|m| m.topic == OBJECT_NAMES)
        && m.data.len() >= size_of::<FrameHeader>()
        && (m.data.len() - size_of::<FrameHeader>()).is_multiple_of(size_of::<ObjectName>())
    {
        return m.data[size_of::<FrameHeader>()..]
            .chunks_exact(size_of::<ObjectName>())
            .map(|c| bytemuck::pod_read_unaligned::<ObjectName>(c).text())
            .collect();
    }
    let Some(m) = msgs.iter().find(|m| m.topic == SCENE) else {
        return Vec::new();
    };
    if m.data.len() < size_of::<SceneHeader>() {
        return Vec::new();
    }
    let h: SceneHeader = bytemuck::pod_read_unaligned(&m.data[..size_of::<SceneHeader>()]);
    h.object_names
        .iter()
        .take(h.object_count as usize)
        .map(|n| read_fixed_str(n))
        .collect()
}

/// Writes the objects of every frame as `objects.csv` ([`crate::objects_csv`]), with `names`
/// for the `name` column. Returns the rows written.
///
/// # Errors
/// As [`split`], and I/O errors of `out`.
pub fn objects_csv(
    msgs: &[RecordedMessage],
    path: &Path,
    names: Vec<String>,
    out: &mut impl std::io::Write,
) -> Result<u64, RecordError> {
    let io = |source| RecordError::Io {
        path: path.display().to_string(),
        source,
    };
    let mut csv = ObjectsCsv::new(out, names).map_err(io)?;
    for m in msgs.iter().filter(|m| m.topic == OBJECTS) {
        let (h, objs): (FrameHeader, Vec<ObjectState>) = split(m, path, "objects")?;
        csv.write_frame(h.step, h.time_s, &objs).map_err(io)?;
    }
    let rows = csv.rows();
    csv.finish().map_err(io)?;
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use splatphys_ipc::wire::{MAX_NAMED_OBJECTS, write_fixed_str};

    use super::*;

    fn message(topic: &str, data: Vec<u8>) -> RecordedMessage {
        RecordedMessage {
            topic: topic.into(),
            sequence: 0,
            log_time_ns: 0,
            publish_time_ns: 0,
            data,
        }
    }

    #[test]
    fn names_come_from_object_names_for_every_object_else_from_the_scene_header() {
        let objects = MAX_NAMED_OBJECTS + 6;
        let mut header = SceneHeader {
            object_count: objects as u32,
            ..SceneHeader::default()
        };
        for (i, n) in header.object_names.iter_mut().enumerate() {
            write_fixed_str(n, &format!("obj{i}"));
        }
        let scene = message(SCENE, bytemuck::bytes_of(&header).to_vec());
        // Without `/object_names` (an older recording): the header's first 64.
        let from_header = object_names(std::slice::from_ref(&scene));
        assert_eq!(from_header.len(), MAX_NAMED_OBJECTS);
        assert_eq!(from_header[63], "obj63");
        // With it: every object.
        let mut data = bytemuck::bytes_of(&FrameHeader {
            count: objects as u32,
            ..FrameHeader::default()
        })
        .to_vec();
        for i in 0..objects {
            data.extend_from_slice(bytemuck::bytes_of(&ObjectName::new(&format!("obj{i}"))));
        }
        let all = object_names(&[scene, message(OBJECT_NAMES, data)]);
        assert_eq!(all.len(), objects);
        assert_eq!(all[objects - 1], format!("obj{}", objects - 1));
    }
}

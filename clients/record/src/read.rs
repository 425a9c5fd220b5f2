//! Reading a recording, including one whose recorder was killed.
//!
//! A linear read with `IgnoreEndMagic` walks the data section chunk by chunk, so a file cut
//! off by a kill -9 still yields every chunk that was closed; the summary is lost then, which
//! only costs random access.

use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use bytemuck::Pod;
use mcap::sans_io::LinearReaderOptions;
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

/// The messages of a recording in file order, read from disk one chunk at a time: memory is
/// bounded by the largest chunk (a few frames), not the file.
///
/// Without `recover` every chunk's CRC is checked before any of its messages is yielded, and a
/// truncated or corrupt file yields an error at the damage. With `recover` the stream ends
/// quietly at the first damage instead (a file whose recorder was killed keeps every chunk that
/// was closed); [`Self::damage`] then says what stopped it.
pub struct Recording {
    reader: mcap::io::MessageReader<BufReader<File>>,
    path: PathBuf,
    recover: bool,
    damage: Option<String>,
    done: bool,
}

impl Recording {
    /// Opens `path` for streaming (see [`Recording`]).
    ///
    /// # Errors
    /// [`RecordError::Io`] when the file cannot be opened.
    pub fn open(path: &Path, recover: bool) -> Result<Self, RecordError> {
        let file = File::open(path).map_err(|source| RecordError::Io {
            path: path.display().to_string(),
            source,
        })?;
        let options = LinearReaderOptions::default()
            .with_skip_end_magic(recover)
            .with_prevalidate_chunk_crcs(true)
            .with_validate_data_section_crc(!recover);
        Ok(Self {
            reader: mcap::io::MessageReader::new_with_options(
                BufReader::with_capacity(1 << 20, file),
                options,
            ),
            path: path.to_path_buf(),
            recover,
            damage: None,
            done: false,
        })
    }

    /// With `recover`: why the stream ended before the end of the file (a truncated last chunk,
    /// a bad CRC), or `None` when the file was whole.
    pub fn damage(&self) -> Option<&str> {
        self.damage.as_deref()
    }
}

impl Iterator for Recording {
    type Item = Result<RecordedMessage, RecordError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        match self.reader.next()? {
            Ok(m) => Some(Ok(RecordedMessage {
                topic: m.channel.topic.clone(),
                sequence: m.sequence,
                log_time_ns: m.log_time,
                publish_time_ns: m.publish_time,
                data: m.data.into_owned(),
            })),
            Err(source) => {
                self.done = true;
                if self.recover {
                    self.damage = Some(source.to_string());
                    None
                } else {
                    Some(Err(RecordError::Corrupt {
                        path: self.path.display().to_string(),
                        source,
                    }))
                }
            }
        }
    }
}

/// Checks that `path` is a whole MCAP file without reading its messages: the data section's
/// CRC, the footer and the end magic. Reads the file once at disk speed (chunks are not
/// decompressed), so a replay can refuse a damaged file before it publishes anything.
///
/// # Errors
/// [`RecordError::Io`] when the file cannot be read, [`RecordError::Corrupt`] when it is
/// truncated or its bytes do not match their CRCs.
pub fn verify(path: &Path) -> Result<(), RecordError> {
    let io = |source| RecordError::Io {
        path: path.display().to_string(),
        source,
    };
    let mut file = File::open(path).map_err(io)?;
    let mut reader = mcap::sans_io::LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_emit_chunks(true)
            .with_validate_data_section_crc(true)
            .with_validate_summary_section_crc(true),
    );
    while let Some(event) = reader.next_event() {
        match event {
            Ok(mcap::sans_io::LinearReadEvent::ReadRequest(need)) => {
                let n = std::io::Read::read(&mut file, reader.insert(need)).map_err(io)?;
                reader.notify_read(n);
            }
            Ok(mcap::sans_io::LinearReadEvent::Record { .. }) => {}
            Err(source) => {
                return Err(RecordError::Corrupt {
                    path: path.display().to_string(),
                    source,
                });
            }
        }
    }
    Ok(())
}

/// Every message of `path` in memory (see [`Recording`]; for small recordings and tests).
///
/// # Errors
/// As [`Recording`].
pub fn read_all(path: &Path, recover: bool) -> Result<Vec<RecordedMessage>, RecordError> {
    Recording::open(path, recover)?.collect()
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

/// The header of a `/frame` (or `/objects`) message.
///
/// # Errors
/// [`RecordError::BadMessage`] when the message is shorter than a header.
pub fn frame_header(m: &RecordedMessage, path: &Path) -> Result<FrameHeader, RecordError> {
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
}

/// The frame headers in a stream of messages (a [`Recording`]), in order.
///
/// # Errors
/// The stream's errors and [`frame_header`]'s.
pub fn frame_headers(
    msgs: impl IntoIterator<Item = Result<RecordedMessage, RecordError>>,
    path: &Path,
) -> Result<Vec<FrameHeader>, RecordError> {
    let mut out = Vec::new();
    for m in msgs {
        let m = m?;
        if m.topic == FRAME {
            out.push(frame_header(&m, path)?);
        }
    }
    Ok(out)
}

/// Object names of a recording (`names[id]`): every object's from the first `/object_names`
/// message (the stream is read only up to it), or, in a recording without one, the first scene
/// header's (which names the first [`MAX_NAMED_OBJECTS`](splatphys_ipc::wire::MAX_NAMED_OBJECTS)
/// objects). Empty when the recording holds neither.
///
/// # Errors
/// The stream's errors.
pub fn object_names(
    msgs: impl IntoIterator<Item = Result<RecordedMessage, RecordError>>,
) -> Result<Vec<String>, RecordError> {
    let mut from_scene = None;
    for m in msgs {
        let m = m?;
        if m.topic == OBJECT_NAMES
            && m.data.len() >= size_of::<FrameHeader>()
            && (m.data.len() - size_of::<FrameHeader>()).is_multiple_of(size_of::<ObjectName>())
        {
            return Ok(m.data[size_of::<FrameHeader>()..]
                .chunks_exact(size_of::<ObjectName>())
                .map(|c| bytemuck::pod_read_unaligned::<ObjectName>(c).text())
                .collect());
        }
        if m.topic == SCENE && from_scene.is_none() && m.data.len() >= size_of::<SceneHeader>() {
            let h: SceneHeader = bytemuck::pod_read_unaligned(&m.data[..size_of::<SceneHeader>()]);
            from_scene = Some(
                h.object_names
                    .iter()
                    .take(h.object_count as usize)
                    .map(|n| read_fixed_str(n))
                    .collect(),
            );
        }
    }
    Ok(from_scene.unwrap_or_default())
}

/// Writes the objects of every frame of a stream of messages (a [`Recording`]) as
/// `objects.csv` ([`crate::objects_csv`]), with `names` for the `name` column. Returns the rows
/// written.
///
/// # Errors
/// The stream's errors, as [`split`], and I/O errors of `out`.
pub fn objects_csv(
    msgs: impl IntoIterator<Item = Result<RecordedMessage, RecordError>>,
    path: &Path,
    names: Vec<String>,
    out: &mut impl std::io::Write,
) -> Result<u64, RecordError> {
    let io = |source| RecordError::Io {
        path: path.display().to_string(),
        source,
    };
    let mut csv = ObjectsCsv::new(out, names).map_err(io)?;
    for m in msgs {
        let m = m?;
        if m.topic == OBJECTS {
            let (h, objs): (FrameHeader, Vec<ObjectState>) = split(&m, path, "objects")?;
            csv.write_frame(h.step, h.time_s, &objs).map_err(io)?;
        }
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
        let from_header = object_names([Ok(scene.clone())]).unwrap();
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
        let all = object_names([Ok(scene), Ok(message(OBJECT_NAMES, data))]).unwrap();
        assert_eq!(all.len(), objects);
        assert_eq!(all[objects - 1], format!("obj{}", objects - 1));
    }
}

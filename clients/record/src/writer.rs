//! Writing a recording: chunked, compressed MCAP (zstd by default, lz4 as an option).
//!
//! The file is written unbuffered: every closed chunk is handed to the OS at once, so a killed
//! recorder (kill -9) loses at most the open chunk. [`RunWriter::flush`] closes the open chunk;
//! the recorder calls it about once a second.

use std::collections::BTreeMap;
use std::fs::File;
use std::path::Path;

use bytemuck::{Pod, bytes_of, cast_slice};
use mcap::{Compression, WriteOptions, Writer, records::MessageHeader};
use splatphys_ipc::wire::{
    CommandLogEntry, FrameGaussian, FrameHeader, ObjectName, ObjectState, SceneGaussian,
    SceneHeader, Status,
};

use crate::channels::{
    COMMANDS, FRAME, OBJECT_NAMES, OBJECTS, POD_ENCODING, POD_SCHEMA_ENCODING, POINTCLOUD,
    POINTCLOUD_SCHEMA, RAW_CHANNELS, SCENE, STATUS,
};
use crate::error::RecordError;
use crate::pointcloud::{colours, pointcloud_json};

/// Compression of the chunks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ChunkCompression {
    /// zstd (default).
    #[default]
    Zstd,
    /// lz4 (faster, larger).
    Lz4,
    /// None.
    None,
}

/// How to write.
#[derive(Debug, Clone, Copy)]
pub struct WriterOptions {
    /// Chunk compression.
    pub compression: ChunkCompression,
    /// Target uncompressed chunk size, bytes. Default 4 MiB.
    pub chunk_size_bytes: u64,
    /// Write a `/pointcloud` message every this many frames (0 = never). Default 1.
    pub pointcloud_every: u64,
}

impl Default for WriterOptions {
    fn default() -> Self {
        Self {
            compression: ChunkCompression::Zstd,
            chunk_size_bytes: 4 << 20,
            pointcloud_every: 1,
        }
    }
}

/// Messages written per topic.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct WriteCounts {
    /// `/scene` messages.
    pub scenes: u64,
    /// `/frame` messages.
    pub frames: u64,
    /// `/objects` messages.
    pub objects: u64,
    /// `/status` messages.
    pub statuses: u64,
    /// `/commands` messages.
    pub commands: u64,
    /// Command-log entries the server logged but the recording does not hold (overwritten in
    /// the log's buffer while the recorder was busy), counted from gaps in `log_index`.
    pub commands_lost: u64,
    /// `/pointcloud` messages.
    pub pointclouds: u64,
    /// `/object_names` messages.
    pub object_names: u64,
}

/// An MCAP file being written.
pub struct RunWriter {
    path: String,
    writer: Writer<File>,
    channels: BTreeMap<&'static str, u16>,
    sequence: u32,
    colours: Vec<[u8; 4]>,
    opts: WriterOptions,
    /// `log_index` of the first command-log entry received (those before it were logged before
    /// the recorder subscribed).
    log_base: Option<u64>,
    /// Frame index of the newest frame / objects written.
    last_frame: Option<u64>,
    last_objects: Option<u64>,
    /// Messages written so far.
    pub counts: WriteCounts,
}

impl std::fmt::Debug for RunWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RunWriter")
            .field("path", &self.path)
            .field("counts", &self.counts)
            .finish_non_exhaustive()
    }
}

fn concat<H: Pod, T: Pod>(header: &H, payload: &[T]) -> Vec<u8> {
    let mut v = Vec::with_capacity(size_of::<H>() + std::mem::size_of_val(payload));
    v.extend_from_slice(bytes_of(header));
    v.extend_from_slice(cast_slice(payload));
    v
}

fn now_ns() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as u64)
}

impl RunWriter {
    /// Creates `path` and declares every channel.
    ///
    /// # Errors
    /// I/O or MCAP errors.
    pub fn create(path: &Path, opts: WriterOptions) -> Result<Self, RecordError> {
        let p = path.display().to_string();
        let file = File::create(path).map_err(|source| RecordError::Io {
            path: p.clone(),
            source,
        })?;
        let mcap_err = |source| RecordError::Mcap {
            path: p.clone(),
            source,
        };
        let compression = match opts.compression {
            ChunkCompression::Zstd => Some(Compression::Zstd),
            ChunkCompression::Lz4 => Some(Compression::Lz4),
            ChunkCompression::None => None,
        };
        let mut writer = WriteOptions::new()
            .profile("splatphys")
            .compression(compression)
            .chunk_size(Some(opts.chunk_size_bytes))
            .create(file)
            .map_err(mcap_err)?;
        let mut channels = BTreeMap::new();
        let meta = BTreeMap::new();
        for (topic, schema, text) in RAW_CHANNELS {
            let sid = writer
                .add_schema(schema, POD_SCHEMA_ENCODING, text.as_bytes())
                .map_err(mcap_err)?;
            let cid = writer
                .add_channel(sid, topic, POD_ENCODING, &meta)
                .map_err(mcap_err)?;
            channels.insert(topic, cid);
        }
        let sid = writer
            .add_schema(
                "foxglove.PointCloud",
                "jsonschema",
                POINTCLOUD_SCHEMA.as_bytes(),
            )
            .map_err(mcap_err)?;
        let cid = writer
            .add_channel(sid, POINTCLOUD, "json", &meta)
            .map_err(mcap_err)?;
        channels.insert(POINTCLOUD, cid);
        Ok(Self {
            path: p,
            writer,
            channels,
            sequence: 0,
            colours: Vec::new(),
            opts,
            log_base: None,
            last_frame: None,
            last_objects: None,
            counts: WriteCounts::default(),
        })
    }

    fn write(
        &mut self,
        topic: &'static str,
        publish_time_s: f64,
        data: &[u8],
    ) -> Result<(), RecordError> {
        self.sequence = self.sequence.wrapping_add(1);
        let header = MessageHeader {
            channel_id: self.channels[topic],
            sequence: self.sequence,
            log_time: now_ns(),
            publish_time: (publish_time_s.max(0.0) * 1e9) as u64,
        };
        self.writer
            .write_to_known_channel(&header, data)
            .map_err(|source| RecordError::Mcap {
                path: self.path.clone(),
                source,
            })
    }

    /// Writes a scene and remembers its colours for `/pointcloud`.
    ///
    /// # Errors
    /// MCAP errors.
    pub fn scene(
        &mut self,
        header: &SceneHeader,
        payload: &[SceneGaussian],
    ) -> Result<(), RecordError> {
        self.colours = colours(payload);
        self.write(SCENE, 0.0, &concat(header, payload))?;
        self.counts.scenes += 1;
        Ok(())
    }

    /// Writes a frame (and a `/pointcloud` every `pointcloud_every` frames).
    ///
    /// # Errors
    /// MCAP errors.
    pub fn frame(
        &mut self,
        header: &FrameHeader,
        payload: &[FrameGaussian],
    ) -> Result<(), RecordError> {
        self.write(FRAME, header.time_s, &concat(header, payload))?;
        self.counts.frames += 1;
        self.last_frame = Some(header.frame_index);
        if self.opts.pointcloud_every > 0
            && header
                .frame_index
                .is_multiple_of(self.opts.pointcloud_every)
        {
            let pc = pointcloud_json(payload, &self.colours, header.time_s);
            self.write(POINTCLOUD, header.time_s, &pc)?;
            self.counts.pointclouds += 1;
        }
        Ok(())
    }

    /// Frame index of the newest frame written with its objects (what a recorder acknowledges
    /// to the server); `None` before the first.
    pub fn taken(&self) -> Option<u64> {
        Some(self.last_frame?.min(self.last_objects?))
    }

    /// Writes the objects of a frame.
    ///
    /// # Errors
    /// MCAP errors.
    pub fn objects(
        &mut self,
        header: &FrameHeader,
        payload: &[ObjectState],
    ) -> Result<(), RecordError> {
        self.write(OBJECTS, header.time_s, &concat(header, payload))?;
        self.counts.objects += 1;
        self.last_objects = Some(header.frame_index);
        Ok(())
    }

    /// Writes every object's name (once per generation).
    ///
    /// # Errors
    /// MCAP errors.
    pub fn object_names(
        &mut self,
        header: &FrameHeader,
        payload: &[ObjectName],
    ) -> Result<(), RecordError> {
        self.write(OBJECT_NAMES, 0.0, &concat(header, payload))?;
        self.counts.object_names += 1;
        Ok(())
    }

    /// Writes a status.
    ///
    /// # Errors
    /// MCAP errors.
    pub fn status(&mut self, s: &Status) -> Result<(), RecordError> {
        self.write(STATUS, s.time_s, bytes_of(s))?;
        self.counts.statuses += 1;
        Ok(())
    }

    /// Writes a command log entry.
    ///
    /// # Errors
    /// MCAP errors.
    pub fn command(&mut self, e: &CommandLogEntry) -> Result<(), RecordError> {
        self.write(COMMANDS, 0.0, bytes_of(e))?;
        let base = *self.log_base.get_or_insert(e.log_index);
        let expected = base + self.counts.commands + self.counts.commands_lost;
        self.counts.commands_lost += e.log_index.saturating_sub(expected);
        self.counts.commands += 1;
        Ok(())
    }

    /// Closes the open chunk so it reaches the file.
    ///
    /// # Errors
    /// MCAP errors.
    pub fn flush(&mut self) -> Result<(), RecordError> {
        self.writer.flush().map_err(|source| RecordError::Mcap {
            path: self.path.clone(),
            source,
        })
    }

    /// Writes the summary and closes the file.
    ///
    /// # Errors
    /// MCAP errors.
    pub fn finish(mut self) -> Result<WriteCounts, RecordError> {
        self.writer.finish().map_err(|source| RecordError::Mcap {
            path: self.path.clone(),
            source,
        })?;
        Ok(self.counts)
    }
}

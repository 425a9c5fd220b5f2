//! splatphys_record: records a splatphys run to MCAP, replays it, and exports it.
//!
//! - [`writer`]: chunked zstd/lz4 MCAP with raw POD channels and a `foxglove.PointCloud`;
//! - [`recorder`]: the lossless recording loop against a live server;
//! - [`read`]: reading (also files cut off by a killed recorder) and CSV export;
//! - [`objects_csv`]: the one `objects.csv` writer;
//! - [`export`]: chosen frames as INRIA PLY or SPZ files;
//! - [`replay`]: publishing a recording back onto the services.

pub mod channels;
pub mod cli;
pub mod error;
pub mod export;
pub mod objects_csv;
pub mod pointcloud;
pub mod read;
pub mod recorder;
pub mod replay;
pub mod writer;

pub use error::RecordError;

//! The shared-memory space check at server start.
//!
//! iceoryx2 maps its data segments from files in /dev/shm (a tmpfs). Their pages are backed
//! only when first written, so a segment larger than the free space maps fine and the process
//! dies of SIGBUS later, mid-run, when a write reaches a page tmpfs cannot back. The server
//! checks before creating anything that /dev/shm can hold what it will write in the common
//! case: the static scene twice (two generations in flight) and [`FRAMES_IN_FLIGHT`] frames
//! and object states (the publisher's own loans plus full buffers of a renderer, a recorder
//! and a viewer).

use std::path::Path;

use crate::error::IpcError;
use crate::wire::{FrameGaussian, FrameHeader, ObjectState, SceneGaussian};

/// Frames the check assumes in shared memory at once.
pub const FRAMES_IN_FLIGHT: usize = 16;

/// Where iceoryx2 keeps its shared memory on Linux.
pub const SHM_PATH: &str = "/dev/shm";

/// Bytes the server needs in shared memory for `gaussians` Gaussians and `objects` objects,
/// with a line saying how the figure is made up.
pub fn needed_bytes(gaussians: usize, objects: usize) -> (u64, String) {
    let scene = (gaussians * size_of::<SceneGaussian>()) as u64;
    let frame = (gaussians * size_of::<FrameGaussian>()
        + objects * size_of::<ObjectState>()
        + 2 * size_of::<FrameHeader>()) as u64;
    let needed = 2 * scene + FRAMES_IN_FLIGHT as u64 * frame;
    let mb = |b: u64| b as f64 / 1e6;
    let detail = format!(
        "the scene twice at {:.1} MB, {FRAMES_IN_FLIGHT} frames at {:.1} MB",
        mb(scene),
        mb(frame)
    );
    (needed, detail)
}

/// [`IpcError::SharedMemoryTooSmall`] when `path` has less free space than [`needed_bytes`].
/// A file system that cannot be asked (not Linux, no /dev/shm) passes: iceoryx2 then reports
/// what it finds.
///
/// # Errors
/// [`IpcError::SharedMemoryTooSmall`].
pub fn check_space(path: &Path, gaussians: usize, objects: usize) -> Result<(), IpcError> {
    let Ok(fs) = rustix::fs::statvfs(path) else {
        return Ok(());
    };
    let free = fs.f_bavail.saturating_mul(fs.f_frsize);
    let (needed, detail) = needed_bytes(gaussians, objects);
    if free >= needed {
        return Ok(());
    }
    Err(IpcError::SharedMemoryTooSmall {
        path: path.display().to_string(),
        free_mb: free as f64 / 1e6,
        needed_mb: needed as f64 / 1e6,
        gaussians,
        detail,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_million_gaussians_need_the_scene_twice_and_sixteen_frames() {
        let (b, detail) = needed_bytes(1_000_000, 2);
        let frame = 52_000_000 + 2 * 88 + 2 * 56;
        assert_eq!(b, 2 * 228_000_000 + 16 * frame);
        assert!(detail.contains("228.0 MB"), "{detail}");
    }

    #[test]
    fn too_little_space_is_a_clear_error_and_enough_passes() {
        // The current directory's file system has far less than an exabyte free.
        let err = check_space(Path::new("."), 1 << 40, 1).expect_err("too small");
        let text = err.to_string();
        assert!(text.contains("needs about"), "{text}");
        assert!(text.contains("--shm-size"), "{text}");
        check_space(Path::new("."), 10, 1).expect("ten Gaussians fit");
    }
}

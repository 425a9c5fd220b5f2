//! `mcap`: render every recorded frame of an MCAP recording made by `splatphys-record`.
//!
//! A recording cut off by a killed recorder is read up to the last closed chunk. Frames missing
//! from the recording (frame-index gaps) are counted as dropped.

use anyhow::{Context, Result};
use splatphys_ipc::wire::{FrameGaussian, FrameHeader, SceneGaussian, SceneHeader};
use splatphys_record::channels::{FRAME, SCENE};
use splatphys_record::read::{Recording, split};

use crate::sequence::{FrameRenderer, StaticScene};
pub use splatphys_render::cli::McapArgs;

/// Runs `mcap`; prints the JSON summary on stdout.
pub fn mcap(args: &McapArgs) -> Result<()> {
    let path = args.recording.as_path();
    // Streamed chunk by chunk; a file cut off by a killed recorder is read up to its last closed
    // chunk (with a note at the end).
    let mut msgs = Recording::open(path, true)?;
    let mut read = 0u64;
    let mut renderer = FrameRenderer::new(&args.seq)?;
    let mut scene: Option<StaticScene> = None;
    let mut bad = 0u64;
    for m in msgs.by_ref() {
        let m = &m.with_context(|| format!("reading {}", path.display()))?;
        read += 1;
        match m.topic.as_str() {
            SCENE => match split::<SceneHeader, SceneGaussian>(m, path, "scene") {
                Ok((h, payload)) => {
                    scene = Some(StaticScene::new(&h, &payload, args.seq.sh_degree));
                }
                Err(e) => {
                    eprintln!("splatphys-render: skipped a scene message: {e}");
                    bad += 1;
                }
            },
            FRAME => match split::<FrameHeader, FrameGaussian>(m, path, "frame") {
                Ok((h, payload)) => {
                    renderer.frame_mut().fill(&h, &payload);
                    renderer.offer(scene.as_ref())?;
                }
                Err(e) => {
                    if bad < 3 {
                        eprintln!("splatphys-render: skipped a frame message: {e}");
                    }
                    bad += 1;
                }
            },
            _ => {}
        }
    }
    renderer.render_pending(scene.as_ref())?;
    if let Some(damage) = msgs.damage() {
        eprintln!(
            "splatphys-render: {} is incomplete ({damage}); rendered the {read} messages before the cut",
            path.display()
        );
    }
    if renderer.frames_rendered() == 0 {
        eprintln!(
            "splatphys-render: {} holds no renderable frame ({} messages, {bad} unreadable)",
            path.display(),
            read
        );
    }
    let summary = renderer.finish()?;
    println!("{}", summary.json());
    Ok(())
}

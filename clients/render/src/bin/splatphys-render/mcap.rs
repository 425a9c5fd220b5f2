//! `mcap`: render every recorded frame of an MCAP recording made by `splatphys-record`.
//!
//! A recording cut off by a killed recorder is read up to the last closed chunk. Frames missing
//! from the recording (frame-index gaps) are counted as dropped.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::Args;
use splatphys_ipc::wire::{FrameGaussian, FrameHeader, SceneGaussian, SceneHeader};
use splatphys_record::channels::{FRAME, SCENE};
use splatphys_record::read::{RecordedMessage, messages, read_file, split};

use crate::sequence::{FrameRenderer, SequenceArgs, StaticScene};

/// Arguments of `mcap`.
#[derive(Args, Debug, Clone)]
pub struct McapArgs {
    /// The recording (`splatphys-record record --out RUN.mcap`).
    pub recording: PathBuf,
    #[command(flatten)]
    pub seq: SequenceArgs,
}

/// Runs `mcap`; prints the JSON summary on stdout.
pub fn mcap(args: &McapArgs) -> Result<()> {
    let path = args.recording.as_path();
    let msgs = read_messages(path)?;
    let mut renderer = FrameRenderer::new(&args.seq)?;
    let mut scene: Option<StaticScene> = None;
    let mut bad = 0u64;
    for m in &msgs {
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
    if renderer.frames_rendered() == 0 {
        eprintln!(
            "splatphys-render: {} holds no renderable frame ({} messages, {bad} unreadable)",
            path.display(),
            msgs.len()
        );
    }
    let summary = renderer.finish()?;
    println!("{}", summary.json());
    Ok(())
}

/// Every message of the recording; a file cut off by a killed recorder is recovered up to its
/// last closed chunk (with a note).
fn read_messages(path: &Path) -> Result<Vec<RecordedMessage>> {
    let bytes = read_file(path).with_context(|| format!("reading {}", path.display()))?;
    match messages(&bytes, path, false) {
        Ok(m) => Ok(m),
        Err(e) => {
            let m = messages(&bytes, path, true)
                .with_context(|| format!("reading the recording {}", path.display()))?;
            eprintln!(
                "splatphys-render: {} is incomplete ({e}); rendering the {} messages before the cut",
                path.display(),
                m.len()
            );
            Ok(m)
        }
    }
}

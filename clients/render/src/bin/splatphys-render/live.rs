//! `live`: subscribe to a running server and render the newest frame each time.
//!
//! The renderer takes the newest frame and skips the ones it is too slow for (counted as dropped
//! from the frame-index gaps). The frame service does not overflow: a full subscriber buffer
//! holds the oldest frames and the server drops the newer ones for it, so after finding its
//! buffer full the renderer waits briefly for a fresh frame. For the same reason the very last
//! frame of a run is lost when the server publishes it while the buffer is full. The scene (static part: SH, opacities) arrives once
//! per generation. On the server's clean shutdown every frame still buffered is drained, the
//! final frame rendered, and the animations written; when the server dies (no heartbeat) the
//! animations of what was rendered are still written and the command fails.

use std::time::Duration;

use anyhow::{Context, Result, anyhow};
use splatphys_ipc::IpcError;
use splatphys_ipc::client::{ClientOptions, Connection};

use crate::sequence::{FrameRenderer, StaticScene};
pub use splatphys_render::cli::{LiveArgs, SequenceArgs};

/// How the frame loop ended.
enum End {
    /// The server shut down cleanly and everything was received.
    ShutDown,
    /// The server stopped answering, or another fatal error.
    Failed(anyhow::Error),
    /// SIGINT or SIGTERM.
    Interrupted,
}

/// Frames our subscriber buffers.
const FRAME_BUFFER: usize = 2;
/// How long to wait for a fresh frame after finding the buffer full of older ones.
const FRESH_WAIT: Duration = Duration::from_millis(20);
/// How long a frame whose scene has not arrived yet waits for it.
const SCENE_WAIT: Duration = Duration::from_millis(500);

/// Runs `live`; prints the JSON summary on stdout.
pub fn live(args: &LiveArgs) -> Result<()> {
    if !(args.timeout_s.is_finite() && args.timeout_s >= 0.0) {
        anyhow::bail!(
            "--timeout-s must be a non-negative number, got {}",
            args.timeout_s
        );
    }
    let mut renderer = FrameRenderer::new(&args.seq)?;
    let mut opts = ClientOptions::new(&args.prefix);
    opts.node_name = "splatphys-render".into();
    opts.connect_timeout = Duration::from_secs_f64(args.timeout_s.min(1e6));
    opts.objects = false;
    opts.commands = false;
    opts.frame_buffer = FRAME_BUFFER;
    let mut conn = Connection::connect(&opts)
        .with_context(|| format!("connecting to the server under `{}`", args.prefix))?;
    eprintln!("splatphys-render: connected to `{}`", args.prefix);

    let mut scene: Option<StaticScene> = None;
    let end = loop {
        if let Err(e) = drain_scenes(&mut conn, &mut scene, args.seq.sh_degree) {
            break End::Failed(e.into());
        }
        match take_newest(&mut conn, &mut renderer) {
            Ok(taken) if taken > 0 => {
                if taken >= FRAME_BUFFER {
                    // The buffer was full, so newer frames were dropped: wait briefly for a
                    // fresh one rather than render a stale one (errors surface next round).
                    let _ = wait_fresh(&mut conn, &mut renderer);
                }
                let header = renderer.frame_mut().header;
                if scene
                    .as_ref()
                    .is_none_or(|s| s.generation != header.scene_generation)
                    && let Err(e) = wait_scene(&mut conn, &mut scene, &args.seq, header)
                {
                    break End::Failed(e.into());
                }
                if let Err(e) = renderer.offer(scene.as_ref()) {
                    break End::Failed(e);
                }
            }
            Ok(_) => {
                if conn.node().wait(Duration::from_millis(1)).is_err() {
                    break End::Interrupted;
                }
            }
            Err(IpcError::ServerShutDown { .. }) => break End::ShutDown,
            Err(IpcError::Interrupted) => break End::Interrupted,
            Err(e @ IpcError::ServerGone { .. }) => {
                break End::Failed(anyhow!(e).context("the server died before shutting down"));
            }
            Err(e) => break End::Failed(e.into()),
        }
    };
    // The last frame of the run, if `--every` skipped it.
    let pending = match end {
        End::ShutDown => renderer.render_pending(scene.as_ref()),
        _ => Ok(()),
    };
    let summary = renderer.finish();
    let summary = match (summary, pending) {
        (Ok(s), Ok(())) => s,
        (Err(e), _) | (Ok(_), Err(e)) => {
            return Err(match end {
                End::Failed(first) => first.context(format!("then: {e:#}")),
                _ => e,
            });
        }
    };
    println!("{}", summary.json());
    match end {
        End::ShutDown => Ok(()),
        End::Interrupted => Err(anyhow!(
            "interrupted after {} frames (animation of those written)",
            summary.frames_rendered
        )),
        End::Failed(e) => Err(e.context(format!(
            "stopped after {} frames (animation of those written to {})",
            summary.frames_rendered,
            args.seq.out_dir.display()
        ))),
    }
}

/// Copies every buffered frame in turn into the renderer's frame buffer (the frame service
/// lends one sample at a time), so the newest stays; returns how many were taken.
fn take_newest(conn: &mut Connection, renderer: &mut FrameRenderer) -> Result<usize, IpcError> {
    let mut taken = 0;
    loop {
        match conn.recv_frame() {
            Ok(Some(sample)) => {
                renderer
                    .frame_mut()
                    .fill(sample.user_header(), sample.payload());
                taken += 1;
            }
            Ok(None) => return Ok(taken),
            Err(IpcError::ServerShutDown { .. }) if taken > 0 => return Ok(taken),
            Err(e) => return Err(e),
        }
    }
}

/// Waits up to [`FRESH_WAIT`] for a frame newer than those just drained.
fn wait_fresh(conn: &mut Connection, renderer: &mut FrameRenderer) -> Result<(), IpcError> {
    let start = std::time::Instant::now();
    while take_newest(conn, renderer)? == 0 && start.elapsed() < FRESH_WAIT {
        conn.node()
            .wait(Duration::from_micros(500))
            .map_err(|_| IpcError::Interrupted)?;
    }
    Ok(())
}

/// Takes every scene sample buffered, keeping the newest.
fn drain_scenes(
    conn: &mut Connection,
    scene: &mut Option<StaticScene>,
    max_sh_degree: u8,
) -> Result<(), IpcError> {
    while let Some(s) = conn.recv_scene()? {
        let h = *s.user_header();
        *scene = Some(StaticScene::new(&h, s.payload(), max_sh_degree));
        eprintln!(
            "splatphys-render: scene generation {}: {} Gaussians, SH degree {}",
            h.scene_generation, h.gaussian_count, h.sh_degree
        );
    }
    Ok(())
}

/// Waits up to [`SCENE_WAIT`] for the scene of a frame's generation (it is published before the
/// generation's first frame, but the two services are read separately).
fn wait_scene(
    conn: &mut Connection,
    scene: &mut Option<StaticScene>,
    seq: &SequenceArgs,
    header: splatphys_ipc::wire::FrameHeader,
) -> Result<(), IpcError> {
    let start = std::time::Instant::now();
    loop {
        drain_scenes(conn, scene, seq.sh_degree)?;
        if scene
            .as_ref()
            .is_some_and(|s| s.generation == header.scene_generation)
            || start.elapsed() > SCENE_WAIT
        {
            return Ok(());
        }
        conn.node()
            .wait(Duration::from_millis(2))
            .map_err(|_| IpcError::Interrupted)?;
    }
}

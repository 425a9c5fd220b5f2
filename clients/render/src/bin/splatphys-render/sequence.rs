//! Rendering a sequence of simulation frames (from a live server or an MCAP recording): the
//! shared flags, the conversion of the wire PODs into renderer input, the choice of which frames
//! to render (`--every`, dropped-frame accounting by frame index), the fixed camera, the PNGs,
//! and at the end the GIF, the MP4 and the one-line JSON summary.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use glam::Vec3;
use splatphys_ipc::wire::{FrameGaussian, FrameHeader, SceneGaussian, SceneHeader};
use splatphys_render::{
    Bounds, Camera, ImageRgb8, RenderSettings, SplatView, output::ffmpeg_available, render_rgb8,
    write_gif, write_mp4, write_png,
};

pub use splatphys_render::cli::SequenceArgs;

/// Default view direction of the automatic framing, from the centre towards the camera.
const AUTO_VIEW_DIR: Vec3 = Vec3::new(1.0, -1.0, 0.6);
/// Fraction of Gaussians ignored at each end of each axis by the automatic framing.
const FRAMING_TRIM: f32 = 0.01;

/// Checks the values of `args` that clap cannot.
pub fn validate(args: &SequenceArgs) -> Result<()> {
    if args.every == 0 {
        bail!("--every must be at least 1");
    }
    if !(args.fps.is_finite() && args.fps > 0.0) {
        bail!("--fps must be a positive number, got {}", args.fps);
    }
    if args.sh_degree > 3 {
        bail!("--sh-degree must be 0 to 3, got {}", args.sh_degree);
    }
    if args.width == 0 || args.height == 0 {
        bail!("--width and --height must be positive");
    }
    if args.max_animation_frames == 0 {
        bail!("--max-animation-frames must be at least 1");
    }
    Ok(())
}

/// The static part of one scene generation, as renderer arrays.
#[derive(Debug, Clone)]
pub struct StaticScene {
    /// Scene generation.
    pub generation: u32,
    /// Opacities, `[N]`.
    pub opacities: Vec<f32>,
    /// SH coefficients `[N][K][3]`, coefficient-major, `K = (sh_degree + 1)²`.
    pub sh: Vec<[f32; 3]>,
    /// SH degree kept.
    pub sh_degree: u8,
}

impl StaticScene {
    /// Converts a `scene` sample, keeping SH up to `max_degree`.
    pub fn new(header: &SceneHeader, payload: &[SceneGaussian], max_degree: u8) -> Self {
        let degree = (header.sh_degree.min(3) as u8).min(max_degree.min(3));
        let k = (usize::from(degree) + 1).pow(2);
        let mut sh = Vec::with_capacity(payload.len() * k);
        for g in payload {
            sh.extend(g.sh.chunks_exact(3).take(k).map(|c| [c[0], c[1], c[2]]));
        }
        Self {
            generation: header.scene_generation,
            opacities: payload.iter().map(|g| g.opacity).collect(),
            sh,
            sh_degree: degree,
        }
    }

    /// Number of Gaussians.
    pub fn len(&self) -> usize {
        self.opacities.len()
    }
}

/// The dynamic part of one frame as renderer arrays (reused from frame to frame).
#[derive(Debug, Default)]
pub struct FrameArrays {
    /// Header of the frame held.
    pub header: FrameHeader,
    positions: Vec<[f32; 3]>,
    covariances: Vec<[f32; 6]>,
    rotations: Vec<[f32; 4]>,
}

impl FrameArrays {
    /// Copies a frame out of its sample (so the shared-memory sample can be released at once).
    pub fn fill(&mut self, header: &FrameHeader, payload: &[FrameGaussian]) {
        self.header = *header;
        self.positions.clear();
        self.covariances.clear();
        self.rotations.clear();
        self.positions.extend(payload.iter().map(|g| g.position_m));
        self.covariances
            .extend(payload.iter().map(|g| g.covariance_m2));
        self.rotations
            .extend(payload.iter().map(|g| g.rotation_wxyz));
    }

    /// Number of Gaussians held.
    pub fn len(&self) -> usize {
        self.positions.len()
    }
}

/// What to do with an offered frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Decision {
    /// Render it.
    Render,
    /// Skip it on purpose (`--every`); keep it in case it turns out to be the last one.
    Skip,
    /// Older than or equal to the last frame seen (a replayed or repeated index): ignore.
    Stale,
}

/// Chooses the frames to render and counts the dropped ones from frame-index gaps: with
/// `--every N`, one frame in N is wanted, so a gap of `g` indices between two rendered frames
/// drops `g / N - 1` wanted frames.
#[derive(Debug, Clone)]
pub struct Selector {
    every: u64,
    last_rendered: Option<(u32, u64)>,
    last_seen: Option<(u32, u64)>,
    /// Wanted frames that were never rendered.
    pub dropped: u64,
}

impl Selector {
    /// One frame in `every` (at least 1).
    pub fn new(every: u64) -> Self {
        Self {
            every: every.max(1),
            last_rendered: None,
            last_seen: None,
            dropped: 0,
        }
    }

    /// Decides for the frame `(generation, frame_index)`.
    pub fn offer(&mut self, generation: u32, index: u64) -> Decision {
        let key = (generation, index);
        if self.last_seen.is_some_and(|seen| key <= seen) {
            return Decision::Stale;
        }
        self.last_seen = Some(key);
        match self.last_rendered {
            Some((g, last)) if g == generation && index > last && index - last < self.every => {
                Decision::Skip
            }
            _ => Decision::Render,
        }
    }

    /// Records that `(generation, frame_index)` was rendered.
    pub fn rendered(&mut self, generation: u32, index: u64) {
        if let Some((g, last)) = self.last_rendered
            && g == generation
            && index > last
        {
            self.dropped += ((index - last) / self.every).saturating_sub(1);
        }
        self.last_rendered = Some((generation, index));
    }

    /// Counts a wanted frame that could not be rendered at all (no scene for it).
    pub fn lost(&mut self) {
        self.dropped += 1;
    }

    /// Whether `(generation, frame_index)` is newer than the last rendered frame.
    pub fn newer_than_rendered(&self, generation: u32, index: u64) -> bool {
        self.last_rendered.is_none_or(|r| (generation, index) > r)
    }
}

pub use splatphys_render::report::RenderReport as Summary;

/// Renders frames to PNG with a camera fixed at the first frame, and writes the animations.
pub struct FrameRenderer {
    args: SequenceArgs,
    camera: Option<(Camera, RenderSettings)>,
    written: Vec<PathBuf>,
    selector: Selector,
    frame: FrameArrays,
    pending: bool,
    warnings: u64,
    last_step: u64,
    started: Instant,
}

impl FrameRenderer {
    /// Creates the output folder.
    pub fn new(args: &SequenceArgs) -> Result<Self> {
        validate(args)?;
        std::fs::create_dir_all(&args.out_dir)
            .with_context(|| format!("creating {}", args.out_dir.display()))?;
        Ok(Self {
            args: args.clone(),
            camera: None,
            written: Vec::new(),
            selector: Selector::new(args.every),
            frame: FrameArrays::default(),
            pending: false,
            warnings: 0,
            last_step: 0,
            started: Instant::now(),
        })
    }

    /// The frame buffer to fill with [`FrameArrays::fill`] before [`FrameRenderer::offer`].
    pub fn frame_mut(&mut self) -> &mut FrameArrays {
        &mut self.frame
    }

    /// Renders the frame just filled in if it is wanted; a frame skipped by `--every` is held
    /// so that [`FrameRenderer::render_pending`] can render the final state.
    ///
    /// # Errors
    /// Rendering or PNG failures. A frame without a matching scene is counted as dropped.
    pub fn offer(&mut self, scene: Option<&StaticScene>) -> Result<()> {
        let h = self.frame.header;
        match self.selector.offer(h.scene_generation, h.frame_index) {
            Decision::Stale => Ok(()),
            Decision::Skip => {
                self.pending = true;
                Ok(())
            }
            Decision::Render => {
                self.pending = false;
                self.render_held(scene)
            }
        }
    }

    /// Renders a held frame skipped by `--every` (call at the end of the sequence).
    ///
    /// # Errors
    /// As [`FrameRenderer::offer`].
    pub fn render_pending(&mut self, scene: Option<&StaticScene>) -> Result<()> {
        let h = self.frame.header;
        if self.pending
            && self
                .selector
                .newer_than_rendered(h.scene_generation, h.frame_index)
        {
            self.pending = false;
            self.render_held(scene)?;
        }
        Ok(())
    }

    /// Renders the held frame to `OUT_DIR/frame_{step:05}.png` (generation > 0:
    /// `frame_g{generation}_{step:05}.png`).
    fn render_held(&mut self, scene: Option<&StaticScene>) -> Result<()> {
        let h = self.frame.header;
        let scene = match scene {
            Some(s) if s.generation == h.scene_generation && s.len() == self.frame.len() => s,
            other => {
                self.warnings += 1;
                if self.warnings <= 3 {
                    eprintln!(
                        "splatphys-render: skipped frame {} (step {}, generation {}, {} Gaussians): {}",
                        h.frame_index,
                        h.step,
                        h.scene_generation,
                        self.frame.len(),
                        match other {
                            None => "no scene received yet".to_owned(),
                            Some(s) => format!(
                                "the scene received is generation {} with {} Gaussians",
                                s.generation,
                                s.len()
                            ),
                        }
                    );
                }
                self.selector.lost();
                return Ok(());
            }
        };
        let (camera, settings) = match self.camera {
            Some(c) => c,
            None => {
                let c = fixed_camera(&self.args, &self.frame.positions)?;
                self.camera = Some(c);
                c
            }
        };
        let frame = &self.frame;
        let view = SplatView::new(
            &frame.positions,
            &frame.covariances,
            &scene.opacities,
            &scene.sh,
            scene.sh_degree,
            &frame.rotations,
        )?;
        let image = render_rgb8(&view, &camera, &settings)
            .with_context(|| format!("rendering step {}", h.step))?;
        let name = if h.scene_generation == 0 {
            format!("frame_{:05}.png", h.step)
        } else {
            format!("frame_g{}_{:05}.png", h.scene_generation, h.step)
        };
        let path = self.args.out_dir.join(name);
        write_png(&path, &image)?;
        self.written.push(path);
        self.selector.rendered(h.scene_generation, h.frame_index);
        self.last_step = h.step;
        Ok(())
    }

    /// Frames rendered so far.
    pub fn frames_rendered(&self) -> usize {
        self.written.len()
    }

    /// Writes the GIF (and the MP4 when ffmpeg exists) from the PNGs written, and returns the
    /// summary. With no frame rendered nothing is written.
    pub fn finish(&self) -> Result<Summary> {
        let summary = Summary {
            frames_rendered: self.written.len() as u64,
            frames_dropped: self.selector.dropped,
            last_step: self.last_step,
            seconds: self.started.elapsed().as_secs_f64(),
        };
        if self.written.is_empty() {
            eprintln!("splatphys-render: no frame rendered; no animation written");
            return Ok(summary);
        }
        let frames = self.animation_frames()?;
        let gif = self
            .args
            .gif
            .clone()
            .unwrap_or_else(|| self.args.out_dir.join("animation.gif"));
        write_gif(&gif, &frames, self.args.fps)?;
        eprintln!(
            "splatphys-render: wrote {} PNGs to {} and {} ({} frames)",
            self.written.len(),
            self.args.out_dir.display(),
            gif.display(),
            frames.len()
        );
        let mp4 = self
            .args
            .mp4
            .clone()
            .unwrap_or_else(|| self.args.out_dir.join("animation.mp4"));
        if ffmpeg_available() {
            if write_mp4(&mp4, &frames, self.args.fps)? {
                eprintln!("splatphys-render: wrote {}", mp4.display());
            }
        } else if self.args.mp4.is_some() {
            eprintln!(
                "splatphys-render: ffmpeg not found on PATH: skipped {}",
                mp4.display()
            );
        }
        Ok(summary)
    }

    /// Reads back (an even subsample of at most `--max-animation-frames` of) the PNGs written.
    fn animation_frames(&self) -> Result<Vec<ImageRgb8>> {
        let n = self.written.len();
        let m = n.min(self.args.max_animation_frames);
        let mut frames = Vec::with_capacity(m);
        for j in 0..m {
            // Evenly spread, first and last included.
            let i = if m == 1 { n - 1 } else { j * (n - 1) / (m - 1) };
            frames.push(read_png(&self.written[i])?);
        }
        Ok(frames)
    }
}

/// The run's camera, from the flags or framed on the first frame's `positions`, and the render
/// settings (near plane from the same bounds).
fn fixed_camera(a: &SequenceArgs, positions: &[[f32; 3]]) -> Result<(Camera, RenderSettings)> {
    let bounds = Bounds::of_points_trimmed(positions, FRAMING_TRIM).unwrap_or(Bounds {
        min: Vec3::splat(-1.0),
        max: Vec3::splat(1.0),
    });
    let camera = match a.camera_pos {
        Some(pos) => Camera::new(
            pos,
            a.look_at.unwrap_or_else(|| bounds.centre()),
            a.up,
            a.fov_deg,
            a.width,
            a.height,
        ),
        None => match a.look_at {
            Some(look_at) => {
                let b = Bounds {
                    min: bounds.min - bounds.centre() + look_at,
                    max: bounds.max - bounds.centre() + look_at,
                };
                b.frame(AUTO_VIEW_DIR, a.up, a.fov_deg, a.width, a.height)
            }
            None => bounds.frame(AUTO_VIEW_DIR, a.up, a.fov_deg, a.width, a.height),
        },
    }
    .context("setting up the camera")?;
    let settings = RenderSettings {
        background: a.background.to_array(),
        near_m: bounds.suggested_near_m(&camera),
        max_sh_degree: a.sh_degree,
    };
    eprintln!(
        "splatphys-render: camera at {:.3?} looking at {:.3?} (bounds {:.3?} .. {:.3?}), {}x{} px, near {:.3} m",
        camera.position.to_array(),
        camera.look_at.to_array(),
        bounds.min.to_array(),
        bounds.max.to_array(),
        a.width,
        a.height,
        settings.near_m
    );
    Ok((camera, settings))
}

/// Reads an 8-bit RGB PNG.
fn read_png(path: &Path) -> Result<ImageRgb8> {
    let img = image::open(path)
        .with_context(|| format!("reading back {}", path.display()))?
        .into_rgb8();
    Ok(ImageRgb8 {
        width: img.width(),
        height: img.height(),
        data: img.into_raw(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn selector_counts_gaps_as_dropped() {
        let mut s = Selector::new(1);
        for i in [0u64, 1, 4, 5] {
            assert_eq!(s.offer(0, i), Decision::Render);
            s.rendered(0, i);
        }
        assert_eq!(s.dropped, 2);
        assert_eq!(s.offer(0, 5), Decision::Stale);
    }

    #[test]
    fn selector_every_skips_on_purpose() {
        let mut s = Selector::new(3);
        assert_eq!(s.offer(0, 0), Decision::Render);
        s.rendered(0, 0);
        assert_eq!(s.offer(0, 1), Decision::Skip);
        assert_eq!(s.offer(0, 2), Decision::Skip);
        assert_eq!(s.offer(0, 3), Decision::Render);
        s.rendered(0, 3);
        // Frame 9 after 3: frame 6 was wanted and missed.
        assert_eq!(s.offer(0, 9), Decision::Render);
        s.rendered(0, 9);
        assert_eq!(s.dropped, 1);
        // A new generation restarts indices without counting drops.
        assert_eq!(s.offer(1, 0), Decision::Render);
        s.rendered(1, 0);
        assert_eq!(s.dropped, 1);
    }

    #[test]
    fn scene_conversion_keeps_requested_sh() {
        let header = SceneHeader {
            sh_degree: 3,
            ..SceneHeader::default()
        };
        let mut g = SceneGaussian::default();
        for (i, c) in g.sh.iter_mut().enumerate() {
            *c = i as f32;
        }
        let s = StaticScene::new(&header, &[g, g], 1);
        assert_eq!(s.sh_degree, 1);
        assert_eq!(s.sh.len(), 2 * 4);
        assert_eq!(s.sh[1], [3.0, 4.0, 5.0]);
        assert_eq!(s.sh[4], [0.0, 1.0, 2.0]);
    }
}

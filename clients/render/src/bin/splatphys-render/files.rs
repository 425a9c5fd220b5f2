//! `image` and `orbit`: rendering a 3DGS file (INRIA PLY, compressed PLY or .splat).
//!
//! The camera is framed automatically on the scene's bounds (trimmed of the outermost 1 % of
//! Gaussians per axis, so floaters do not shrink the object), seen from `--azimuth-deg` and
//! `--elevation-deg` about `--up`; or given explicitly with `--eye` (and `--look-at`).

use std::path::Path;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use splatphys_render::{
    Bounds, Camera, ImageRgb8, OrbitPath, RenderSettings, Splats, render_rgb8, write_gif,
    write_mp4, write_png,
};

pub use splatphys_render::cli::ViewArgs;

/// Loads a 3DGS file into renderer input, capped at `sh_degree`, and its trimmed bounds.
fn load(path: &Path, view: &ViewArgs) -> Result<(Splats, Bounds)> {
    let start = Instant::now();
    let cloud = splatphys_formats::read_gaussians(path)
        .with_context(|| format!("reading {}", path.display()))?;
    let mut splats = Splats::from_cloud(&cloud);
    splats.truncate_sh(view.sh_degree.min(3));
    let Some(bounds) = Bounds::of_points_trimmed(&splats.positions, view.trim) else {
        bail!("{}: no Gaussians with finite positions", path.display());
    };
    eprintln!(
        "{}: {} Gaussians, SH degree {} (rendered up to {}), loaded in {:.0} ms; bounds {:.3?} .. {:.3?} (trim {})",
        path.display(),
        splats.positions.len(),
        cloud.sh_degree,
        splats.sh_degree,
        start.elapsed().as_secs_f64() * 1e3,
        bounds.min.to_array(),
        bounds.max.to_array(),
        view.trim,
    );
    Ok((splats, bounds))
}

fn orbit_path(bounds: &Bounds, view: &ViewArgs) -> OrbitPath {
    let mut path = OrbitPath::around(bounds, view.up, view.fov_deg, view.width, view.height);
    path.elevation_deg = view.elevation_deg;
    path.start_azimuth_deg = view.azimuth_deg;
    if let Some(d) = view.distance_m {
        path.distance_m = d;
    }
    if let Some(c) = view.look_at {
        path.centre = c;
    }
    path
}

fn settings(bounds: &Bounds, camera: &Camera, view: &ViewArgs) -> RenderSettings {
    RenderSettings {
        background: view.background.to_array(),
        near_m: view
            .near_m
            .unwrap_or_else(|| bounds.suggested_near_m(camera)),
        max_sh_degree: view.sh_degree,
    }
}

/// `image`: one frame of `scene` to `out`, rendered `repeat` times for timing.
pub fn image(scene: &Path, out: &Path, view: &ViewArgs, repeat: usize) -> Result<()> {
    let (splats, bounds) = load(scene, view)?;
    let camera = match view.eye {
        Some(eye) => Camera::new(
            eye,
            view.look_at.unwrap_or_else(|| bounds.centre()),
            view.up,
            view.fov_deg,
            view.width,
            view.height,
        )?,
        None => orbit_path(&bounds, view)
            .cameras(1)?
            .pop()
            .context("no camera")?,
    };
    let settings = settings(&bounds, &camera, view);
    let input = splats.view()?;
    let mut times = Vec::with_capacity(repeat.max(1));
    let mut frame = None;
    for _ in 0..repeat.max(1) {
        let start = Instant::now();
        frame = Some(render_rgb8(&input, &camera, &settings)?);
        times.push(start.elapsed().as_secs_f64());
    }
    let frame = frame.context("no frame rendered")?;
    write_png(out, &frame)?;
    report_speed(&splats, &camera, &mut times);
    eprintln!(
        "camera at {:.3?} looking at {:.3?}, near {:.3} m -> {}",
        camera.position.to_array(),
        camera.look_at.to_array(),
        settings.near_m,
        out.display()
    );
    Ok(())
}

/// `orbit`: `n` frames around `scene` into `out_dir`, a GIF and optionally an MP4.
pub fn orbit(
    scene: &Path,
    out_dir: &Path,
    n: usize,
    fps: f32,
    mp4: bool,
    view: &ViewArgs,
) -> Result<()> {
    if n == 0 {
        bail!("--frames must be at least 1");
    }
    let (splats, bounds) = load(scene, view)?;
    let cameras = orbit_path(&bounds, view).cameras(n)?;
    std::fs::create_dir_all(out_dir).with_context(|| format!("creating {}", out_dir.display()))?;
    let input = splats.view()?;
    let mut frames: Vec<ImageRgb8> = Vec::with_capacity(n);
    let mut times = Vec::with_capacity(n);
    for (i, camera) in cameras.iter().enumerate() {
        let settings = settings(&bounds, camera, view);
        let start = Instant::now();
        let frame = render_rgb8(&input, camera, &settings)?;
        times.push(start.elapsed().as_secs_f64());
        write_png(&out_dir.join(format!("frame_{i:04}.png")), &frame)?;
        frames.push(frame);
    }
    report_speed(&splats, &cameras[0], &mut times);
    let gif = out_dir.join("orbit.gif");
    write_gif(&gif, &frames, fps)?;
    eprintln!("wrote {n} PNGs and {}", gif.display());
    if mp4 {
        let path = out_dir.join("orbit.mp4");
        if write_mp4(&path, &frames, fps)? {
            eprintln!("wrote {}", path.display());
        } else {
            eprintln!("ffmpeg not found on PATH: skipped {}", path.display());
        }
    }
    Ok(())
}

/// Prints the median frame time and frames/s to stdout.
fn report_speed(splats: &Splats, camera: &Camera, times: &mut [f64]) {
    times.sort_by(f64::total_cmp);
    let median = times[times.len() / 2];
    println!(
        "{} Gaussians at {}x{}: median {:.1} ms/frame over {} frames = {:.1} frames/s ({} threads)",
        splats.positions.len(),
        camera.width_px,
        camera.height_px,
        median * 1e3,
        times.len(),
        1.0 / median,
        rayon::current_num_threads(),
    );
}

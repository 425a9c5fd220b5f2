//! Writing frames: PNG (one frame), animated GIF (a sequence; each frame quantised to a
//! 256-colour palette by the `image` crate's NeuQuant encoder), and MP4 (H.264 through an
//! `ffmpeg` found on PATH; skipped when there is none).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use image::codecs::gif::{GifEncoder, Repeat};
use image::{Delay, ExtendedColorType, Frame, RgbaImage};

use crate::image::ImageRgb8;

/// A frame or an animation could not be written.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// Creating or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The image encoder failed.
    #[error("{path}: encoding failed: {source}")]
    Encode {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: image::ImageError,
    },
    /// An image with no pixels, or whose buffer does not match its size.
    #[error(
        "{path}: frame {index} is {width}x{height} px with {bytes} bytes; need a non-empty RGB8 image"
    )]
    BadFrame {
        /// The file.
        path: PathBuf,
        /// Index of the frame in the sequence.
        index: usize,
        /// Width, pixels.
        width: u32,
        /// Height, pixels.
        height: u32,
        /// Bytes in the buffer.
        bytes: usize,
    },
    /// Frames of an animation differ in size.
    #[error("{path}: frame {index} is {found:?} px but frame 0 is {expected:?} px")]
    FrameSize {
        /// The file.
        path: PathBuf,
        /// Index of the odd frame.
        index: usize,
        /// Size of frame 0.
        expected: [u32; 2],
        /// Size of this frame.
        found: [u32; 2],
    },
    /// No frames to write.
    #[error("{path}: no frames to write")]
    NoFrames {
        /// The file.
        path: PathBuf,
    },
    /// Frame rate not positive and finite.
    #[error("{path}: frame rate {fps} is not positive")]
    FrameRate {
        /// The file.
        path: PathBuf,
        /// The value given, frames per second.
        fps: f32,
    },
    /// ffmpeg ran but failed.
    #[error("{path}: ffmpeg failed ({status}): {stderr}")]
    Ffmpeg {
        /// The file.
        path: PathBuf,
        /// ffmpeg's exit status.
        status: std::process::ExitStatus,
        /// The end of ffmpeg's error output.
        stderr: String,
    },
}

/// Writes `image` as an 8-bit RGB PNG at `path`.
///
/// # Errors
/// [`OutputError`] for an empty or inconsistent image, or when the file cannot be written.
pub fn write_png(path: &Path, image: &ImageRgb8) -> Result<(), OutputError> {
    check_frame(path, 0, image)?;
    image::save_buffer_with_format(
        path,
        &image.data,
        image.width,
        image.height,
        ExtendedColorType::Rgb8,
        image::ImageFormat::Png,
    )
    .map_err(|source| OutputError::Encode {
        path: path.to_path_buf(),
        source,
    })
}

/// Writes `frames` as an animated GIF at `path` that loops forever, `fps` frames per second
/// (GIF delays are in hundredths of a second, so the rate is rounded to that).
///
/// # Errors
/// [`OutputError`] for no frames, frames of different sizes, a non-positive frame rate, or when
/// the file cannot be written.
pub fn write_gif(path: &Path, frames: &[ImageRgb8], fps: f32) -> Result<(), OutputError> {
    check_sequence(path, frames, fps)?;
    let file = File::create(path).map_err(|source| io_error(path, source))?;
    let mut encoder = GifEncoder::new_with_speed(BufWriter::new(file), 10);
    let encode = |source| OutputError::Encode {
        path: path.to_path_buf(),
        source,
    };
    encoder.set_repeat(Repeat::Infinite).map_err(encode)?;
    let delay_ms = (1000.0 / fps).round().max(10.0) as u32;
    for image in frames {
        let rgba: Vec<u8> = image
            .data
            .chunks_exact(3)
            .flat_map(|p| [p[0], p[1], p[2], 255])
            .collect();
        let Some(buffer) = RgbaImage::from_raw(image.width, image.height, rgba) else {
            return Err(OutputError::BadFrame {
                path: path.to_path_buf(),
                index: 0,
                width: image.width,
                height: image.height,
                bytes: image.data.len(),
            });
        };
        let frame = Frame::from_parts(buffer, 0, 0, Delay::from_numer_denom_ms(delay_ms, 1));
        encoder.encode_frame(frame).map_err(encode)?;
    }
    Ok(())
}

/// True when an `ffmpeg` executable on PATH answers `ffmpeg -version`.
pub fn ffmpeg_available() -> bool {
    Command::new("ffmpeg")
        .arg("-version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// Writes `frames` as an H.264 MP4 (yuv420p, sizes padded to even) at `path` through `ffmpeg`,
/// `fps` frames per second. Returns `Ok(false)` without writing anything when `ffmpeg` is not on
/// PATH, `Ok(true)` when the file was written.
///
/// # Errors
/// [`OutputError`] for bad frames (as [`write_gif`]) or when ffmpeg fails.
pub fn write_mp4(path: &Path, frames: &[ImageRgb8], fps: f32) -> Result<bool, OutputError> {
    check_sequence(path, frames, fps)?;
    if !ffmpeg_available() {
        return Ok(false);
    }
    let (w, h) = (frames[0].width, frames[0].height);
    let mut child = Command::new("ffmpeg")
        .args([
            "-y",
            "-loglevel",
            "error",
            "-f",
            "rawvideo",
            "-pix_fmt",
            "rgb24",
        ])
        .args([
            "-s",
            &format!("{w}x{h}"),
            "-r",
            &format!("{fps}"),
            "-i",
            "-",
        ])
        .args(["-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2"])
        .args([
            "-c:v",
            "libx264",
            "-pix_fmt",
            "yuv420p",
            "-movflags",
            "+faststart",
        ])
        .arg(path)
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|source| io_error(path, source))?;
    if let Some(mut stdin) = child.stdin.take() {
        for frame in frames {
            // A write error means ffmpeg exited; its status and stderr below say why.
            if stdin.write_all(&frame.data).is_err() {
                break;
            }
        }
    }
    let output = child
        .wait_with_output()
        .map_err(|source| io_error(path, source))?;
    if !output.status.success() {
        let stderr = String::from_utf8_lossy(&output.stderr);
        let tail: String = stderr
            .chars()
            .rev()
            .take(2000)
            .collect::<Vec<_>>()
            .into_iter()
            .rev()
            .collect();
        return Err(OutputError::Ffmpeg {
            path: path.to_path_buf(),
            status: output.status,
            stderr: tail,
        });
    }
    Ok(true)
}

fn io_error(path: &Path, source: std::io::Error) -> OutputError {
    OutputError::Io {
        path: path.to_path_buf(),
        source,
    }
}

fn check_frame(path: &Path, index: usize, image: &ImageRgb8) -> Result<(), OutputError> {
    let expected = image.width as usize * image.height as usize * 3;
    if image.width == 0 || image.height == 0 || image.data.len() != expected {
        return Err(OutputError::BadFrame {
            path: path.to_path_buf(),
            index,
            width: image.width,
            height: image.height,
            bytes: image.data.len(),
        });
    }
    Ok(())
}

fn check_sequence(path: &Path, frames: &[ImageRgb8], fps: f32) -> Result<(), OutputError> {
    let Some(first) = frames.first() else {
        return Err(OutputError::NoFrames {
            path: path.to_path_buf(),
        });
    };
    if !(fps > 0.0 && fps.is_finite()) {
        return Err(OutputError::FrameRate {
            path: path.to_path_buf(),
            fps,
        });
    }
    for (index, frame) in frames.iter().enumerate() {
        check_frame(path, index, frame)?;
        if [frame.width, frame.height] != [first.width, first.height] {
            return Err(OutputError::FrameSize {
                path: path.to_path_buf(),
                index,
                expected: [first.width, first.height],
                found: [frame.width, frame.height],
            });
        }
    }
    Ok(())
}

//! 2-D feature maps: one `.npy` array `[H'][W'][D]` (float16 or float32, C order) per training
//! view, at any resolution, sampled bilinearly at the centres of the rendered pixels.

use std::path::{Path, PathBuf};

/// Why a feature map could not be used.
#[derive(Debug, thiserror::Error)]
pub enum FeatureMapError {
    /// The file could not be read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// Not a usable array.
    #[error("{path}: {message}")]
    Malformed {
        /// The file.
        path: PathBuf,
        /// What is wrong (shape, dtype, values).
        message: String,
    },
}

/// A feature map `[height][width][dim]`, row-major, float32.
#[derive(Debug, Clone, PartialEq)]
pub struct FeatureMap {
    /// Rows H'.
    pub height: usize,
    /// Columns W'.
    pub width: usize,
    /// Channels D.
    pub dim: usize,
    /// `[H'][W'][D]` values.
    pub data: Vec<f32>,
}

impl FeatureMap {
    /// Reads a `.npy` feature map. Non-finite values are refused (they would enter every
    /// Gaussian that sees them).
    ///
    /// # Errors
    /// [`FeatureMapError`] for unreadable files, shapes other than 3-D, other dtypes, Fortran
    /// order or non-finite values (with the first offending index).
    pub fn read(path: &Path) -> Result<Self, FeatureMapError> {
        let malformed = |message: String| FeatureMapError::Malformed {
            path: path.to_path_buf(),
            message,
        };
        if !path.is_file() {
            return Err(FeatureMapError::Io {
                path: path.to_path_buf(),
                source: std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"),
            });
        }
        let npy = splatphys_core::formats::npy::read_npy_f32(path).map_err(malformed)?;
        let shape = npy.shape;
        if shape.len() != 3 || shape.contains(&0) {
            return Err(malformed(format!(
                "expected a non-empty [H][W][D] array, shape {shape:?}"
            )));
        }
        let data = npy.values;
        let map = Self {
            height: shape[0],
            width: shape[1],
            dim: shape[2],
            data,
        };
        if let Some(bad) = map.data.iter().position(|v| !v.is_finite()) {
            let (d, pixel) = (bad % map.dim, bad / map.dim);
            return Err(malformed(format!(
                "value at [{}][{}][{d}] is {}",
                pixel / map.width,
                pixel % map.width,
                map.data[bad]
            )));
        }
        Ok(map)
    }

    /// Writes the map as a float32 `.npy` `[H'][W'][D]`.
    ///
    /// # Errors
    /// [`FeatureMapError::Io`] when the file cannot be written.
    pub fn write(&self, path: &Path) -> Result<(), FeatureMapError> {
        use npyz::WriterBuilder;
        use std::io::Write;
        let io = |source: std::io::Error| FeatureMapError::Io {
            path: path.to_path_buf(),
            source,
        };
        let mut buf = std::io::BufWriter::new(std::fs::File::create(path).map_err(io)?);
        let mut w = npyz::WriteOptions::new()
            .default_dtype()
            .shape(&[self.height as u64, self.width as u64, self.dim as u64])
            .writer(&mut buf)
            .begin_nd()
            .map_err(io)?;
        w.extend(self.data.iter().copied()).map_err(io)?;
        w.finish().map_err(io)?;
        buf.flush().map_err(io)
    }

    /// Replaces every pixel's feature f by `basis · f` (`basis` `[k][D]` row-major).
    pub fn project(&mut self, basis: &[f32], k: usize) {
        let d = self.dim;
        let mut out = Vec::with_capacity(self.height * self.width * k);
        for f in self.data.chunks_exact(d) {
            out.extend(
                basis
                    .chunks_exact(d)
                    .map(|b| b.iter().zip(f).map(|(x, y)| x * y).sum::<f32>()),
            );
        }
        self.data = out;
        self.dim = k;
    }

    /// Writes the bilinear sample at the centre of pixel `(x, y)` of a `width × height` image into
    /// `out` (`[D]`): the map is stretched over the image (pixel centres align at both edges
    /// of the half-pixel convention) and clamped at its border.
    pub fn sample(&self, x: u32, y: u32, size_px: [u32; 2], out: &mut [f32]) {
        let u = ((x as f32 + 0.5) * self.width as f32 / size_px[0] as f32 - 0.5)
            .clamp(0.0, (self.width - 1) as f32);
        let v = ((y as f32 + 0.5) * self.height as f32 / size_px[1] as f32 - 0.5)
            .clamp(0.0, (self.height - 1) as f32);
        let (x0, y0) = (u as usize, v as usize);
        let (x1, y1) = ((x0 + 1).min(self.width - 1), (y0 + 1).min(self.height - 1));
        let (fx, fy) = (u - x0 as f32, v - y0 as f32);
        let d = self.dim;
        let at = |xx: usize, yy: usize| &self.data[(yy * self.width + xx) * d..][..d];
        let (a, b, c, e) = (at(x0, y0), at(x1, y0), at(x0, y1), at(x1, y1));
        let w = [
            (1.0 - fx) * (1.0 - fy),
            fx * (1.0 - fy),
            (1.0 - fx) * fy,
            fx * fy,
        ];
        for (i, o) in out.iter_mut().enumerate().take(d) {
            *o = w[0] * a[i] + w[1] * b[i] + w[2] * c[i] + w[3] * e[i];
        }
    }
}

//! Rendered images: linear float RGB straight from the blending (values may exceed 1, as in the
//! 3DGS reference) and 8-bit RGB for files (clamped to [0, 1], scaled by 255, rounded).

/// Float RGB image, row-major from the top-left pixel.
#[derive(Debug, Clone, PartialEq)]
pub struct ImageF32 {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// `[H][W][3]` colours, row-major, top row first.
    pub pixels: Vec<[f32; 3]>,
}

/// 8-bit RGB image, row-major from the top-left pixel.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ImageRgb8 {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// `[H][W][3]` bytes, row-major, top row first.
    pub data: Vec<u8>,
}

impl ImageF32 {
    /// Colour of pixel `(x, y)` (column, row). `None` outside the image.
    pub fn get(&self, x: u32, y: u32) -> Option<[f32; 3]> {
        if x < self.width && y < self.height {
            self.pixels
                .get(y as usize * self.width as usize + x as usize)
                .copied()
        } else {
            None
        }
    }

    /// Quantises to 8 bits: `round(clamp(v, 0, 1) · 255)` (NaN becomes 0).
    pub fn to_rgb8(&self) -> ImageRgb8 {
        let data = self.pixels.iter().flat_map(|p| p.map(quantise)).collect();
        ImageRgb8 {
            width: self.width,
            height: self.height,
            data,
        }
    }
}

impl ImageRgb8 {
    /// Colour of pixel `(x, y)` (column, row). `None` outside the image.
    pub fn get(&self, x: u32, y: u32) -> Option<[u8; 3]> {
        if x < self.width && y < self.height {
            let i = 3 * (y as usize * self.width as usize + x as usize);
            self.data.get(i..i + 3).map(|s| [s[0], s[1], s[2]])
        } else {
            None
        }
    }
}

/// One channel to 8 bits.
fn quantise(v: f32) -> u8 {
    if v.is_nan() {
        0
    } else {
        (v.clamp(0.0, 1.0) * 255.0).round() as u8
    }
}

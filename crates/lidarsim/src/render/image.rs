//! The RGB raster every picture is drawn on: pixels, filled rectangles,
//! straight lines, the page and ink colours, and PNG encoding.

use std::path::Path;

use crate::output::{WriteCause, WriteError};

/// An RGB raster.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Image {
    /// Width, px.
    pub width: usize,
    /// Height, px.
    pub height: usize,
    /// Row-major RGB bytes, top row first.
    pub rgb: Vec<u8>,
}

/// The page around maps and plots.
pub(super) const BACKGROUND: [u8; 3] = [255, 255, 255];
/// Text, axes and scale bars.
pub(super) const INK: [u8; 3] = [20, 20, 20];

impl Image {
    /// A `width × height` image filled with `color`.
    pub fn new(width: usize, height: usize, color: [u8; 3]) -> Self {
        Self {
            width,
            height,
            rgb: color.repeat(width * height),
        }
    }

    /// The colour at `(x, y)`.
    pub fn get(&self, x: usize, y: usize) -> [u8; 3] {
        let i = 3 * (y * self.width + x);
        [self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]]
    }

    /// Sets the colour at `(x, y)` (ignored outside).
    pub fn set(&mut self, x: usize, y: usize, c: [u8; 3]) {
        if x < self.width && y < self.height {
            let i = 3 * (y * self.width + x);
            self.rgb[i..i + 3].copy_from_slice(&c);
        }
    }

    /// Fills a rectangle.
    pub fn fill(&mut self, x0: usize, y0: usize, w: usize, h: usize, c: [u8; 3]) {
        for y in y0..y0 + h {
            for x in x0..x0 + w {
                self.set(x, y, c);
            }
        }
    }

    /// The image as an 8-bit RGB PNG.
    pub fn to_png(&self) -> Result<Vec<u8>, png::EncodingError> {
        let mut bytes = Vec::new();
        let mut enc = png::Encoder::new(&mut bytes, self.width as u32, self.height as u32);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        // The mark by which lidarsim knows its own pictures
        // (`output::own`): it replaces no other file.
        enc.add_text_chunk(
            "Software".to_string(),
            crate::output::own::PNG_SOFTWARE.to_string(),
        )?;
        let mut w = enc.write_header()?;
        w.write_image_data(&self.rgb)?;
        w.finish()?;
        Ok(bytes)
    }

    /// Saves as an 8-bit RGB PNG (written whole, then renamed into place),
    /// where no file is or over a picture lidarsim wrote
    /// ([`crate::output::own`]).
    pub fn save_png(&self, path: &Path) -> Result<(), WriteError> {
        crate::output::own::check_replaceable(path, crate::output::own::Mark::Png)?;
        let png = self
            .to_png()
            .map_err(|e| WriteError::new(path, WriteCause::Unsupported(e.to_string())))?;
        crate::output::write_atomic(path, &png)
    }
}

/// Draws a straight line (Bresenham).
pub(super) fn line(img: &mut Image, a: (i64, i64), b: (i64, i64), c: [u8; 3]) {
    let (mut x, mut y) = a;
    let (dx, dy) = ((b.0 - a.0).abs(), -(b.1 - a.1).abs());
    let (sx, sy) = (
        if a.0 < b.0 { 1 } else { -1 },
        if a.1 < b.1 { 1 } else { -1 },
    );
    let mut err = dx + dy;
    loop {
        if x >= 0 && y >= 0 {
            img.set(x as usize, y as usize, c);
        }
        if (x, y) == b {
            break;
        }
        let e2 = 2 * err;
        if e2 >= dy {
            err += dy;
            x += sx;
        }
        if e2 <= dx {
            err += dx;
            y += sy;
        }
    }
}

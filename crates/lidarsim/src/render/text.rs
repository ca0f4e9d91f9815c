//! Text set in an embedded open font, DejaVu Sans 2.37 (Bitstream Vera
//! licence, `crates/lidarsim/fonts/LICENSE-DejaVu.txt`), rasterised by
//! `ab_glyph`: the labels of the PNG pictures. In the report's SVG the
//! browser sets the same text in its own sans-serif font.

use std::sync::OnceLock;

use ab_glyph::{Font, FontRef, PxScale, ScaleFont};

use super::Image;

/// The font file, embedded.
const DEJAVU_SANS: &[u8] = include_bytes!("../../fonts/DejaVuSans.ttf");

/// The embedded font, parsed once.
fn font() -> &'static FontRef<'static> {
    static FONT: OnceLock<FontRef<'static>> = OnceLock::new();
    FONT.get_or_init(|| FontRef::try_from_slice(DEJAVU_SANS).expect("the embedded font parses"))
}

/// Height of the baseline below the top of a line of text, as a share of
/// the font size: where both the raster and the SVG put the baseline, so
/// that text placed by its top sits alike in both.
pub(super) const BASELINE: f64 = 0.8;

/// Width of `text` set at `size_px`, px (advances and kerning).
pub fn text_width(text: &str, size_px: f64) -> f64 {
    let f = font().as_scaled(PxScale::from(size_px as f32));
    let mut width = 0.0f32;
    let mut previous = None;
    for c in text.chars() {
        let id = f.glyph_id(c);
        if let Some(p) = previous {
            width += f.kern(p, id);
        }
        width += f.h_advance(id);
        previous = Some(id);
    }
    f64::from(width)
}

/// The coverage (0–1) of `text` set at `size_px` in a `w × h` grid, the
/// baseline [`BASELINE`]`· size` below its top, starting at its left.
fn coverage(text: &str, size_px: f64) -> (usize, usize, Vec<f32>) {
    let scale = PxScale::from(size_px as f32);
    let f = font().as_scaled(scale);
    let w = text_width(text, size_px).ceil() as usize + 2;
    let h = (size_px * 1.25).ceil() as usize;
    let mut cover = vec![0.0f32; w * h];
    let baseline = (BASELINE * size_px) as f32;
    let (mut x, mut previous) = (0.0f32, None);
    for c in text.chars() {
        let id = f.glyph_id(c);
        if let Some(p) = previous {
            x += f.kern(p, id);
        }
        let glyph = id.with_scale_and_position(scale, ab_glyph::point(x, baseline));
        if let Some(outline) = font().outline_glyph(glyph) {
            let b = outline.px_bounds();
            outline.draw(|gx, gy, v| {
                let (px, py) = (
                    b.min.x as i64 + i64::from(gx),
                    b.min.y as i64 + i64::from(gy),
                );
                if px >= 0 && py >= 0 && (px as usize) < w && (py as usize) < h {
                    let k = py as usize * w + px as usize;
                    cover[k] = (cover[k] + v).min(1.0);
                }
            });
        }
        x += f.h_advance(id);
        previous = Some(id);
    }
    (w, h, cover)
}

impl Image {
    /// Blends `color` into `(x, y)` by `alpha` (0–1; ignored outside).
    pub(super) fn blend(&mut self, x: i64, y: i64, color: [u8; 3], alpha: f32) {
        if x < 0 || y < 0 || x as usize >= self.width || y as usize >= self.height {
            return;
        }
        let old = self.get(x as usize, y as usize);
        let mix =
            |a: u8, b: u8| (f32::from(a) + (f32::from(b) - f32::from(a)) * alpha).round() as u8;
        let c = [
            mix(old[0], color[0]),
            mix(old[1], color[1]),
            mix(old[2], color[2]),
        ];
        self.set(x as usize, y as usize, c);
    }

    /// Sets `text` at `size_px` with its top-left corner at `(x, y)`, or,
    /// `vertical`, turned a quarter anticlockwise (reading upwards) with
    /// its bottom-left corner at `(x, y)` before the turn.
    pub(super) fn draw_text(
        &mut self,
        (x, y): (f64, f64),
        text: &str,
        size_px: f64,
        color: [u8; 3],
        vertical: bool,
    ) {
        let (w, h, cover) = coverage(text, size_px);
        let (x0, y0) = (x.round() as i64, y.round() as i64);
        for j in 0..h {
            for i in 0..w {
                let a = cover[j * w + i];
                if a <= 0.0 {
                    continue;
                }
                if vertical {
                    // Column i of the text becomes row −i above (x, y).
                    self.blend(x0 + j as i64, y0 - i as i64, color, a);
                } else {
                    self.blend(x0 + i as i64, y0 + j as i64, color, a);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Text in the embedded font covers pixels where it is set and widens
    /// with its length; the widths of a proportional font differ by letter.
    #[test]
    fn text_is_set_in_the_embedded_font() {
        assert!(text_width("iiii", 12.0) < text_width("MMMM", 12.0));
        assert!((text_width("range, m", 24.0) - 2.0 * text_width("range, m", 12.0)).abs() < 2.0);
        let mut img = Image::new(120, 30, [255; 3]);
        img.draw_text((5.0, 5.0), "Height, m", 14.0, [0, 0, 0], false);
        let inked = |x0: usize, x1: usize| {
            (x0..x1)
                .flat_map(|x| (0..30).map(move |y| (x, y)))
                .filter(|&(x, y)| img.get(x, y) != [255; 3])
                .count()
        };
        let width = text_width("Height, m", 14.0) as usize;
        assert!(inked(5, 5 + width) > 60, "the text's pixels");
        assert_eq!(inked(0, 4) + inked(5 + width + 2, 120), 0, "nothing beside");
    }
}

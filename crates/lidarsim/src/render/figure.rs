//! A picture as a list of marks — pixels, rectangles, lines and text — in
//! pixel coordinates (x right, y down), drawn once and then either
//! rasterised to an [`Image`] (the PNG files of `lidarsim render` and
//! `lidarsim waveform`, text in the embedded font) or written as SVG (the
//! report, where the browser sets the text and lines stay sharp when
//! zoomed). Dense data — map pixels, a cross-section's points, the dots of
//! a scan pattern — stays a raster inside either.

use std::fmt::Write as _;
use std::path::Path;

use super::Image;
use super::image::line;
use super::text::{BASELINE, text_width};
use crate::output::WriteError;

/// Font size of labels: ticks, legends, scale bars, px.
pub const LABEL_PX: f64 = 12.0;
/// Font size of titles: a panel's quantity, an axis's name, px.
pub const TITLE_PX: f64 = 13.0;

/// What a text's x refers to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Anchor {
    /// Its start (left).
    Start,
    /// Its middle.
    Middle,
    /// Its end (right).
    End,
}

/// One mark of a [`Figure`].
#[derive(Clone, Debug, PartialEq)]
pub enum Mark {
    /// Pixels drawn one to one with their top-left corner at `(x, y)`.
    Raster {
        /// Column of the left edge, px.
        x: usize,
        /// Row of the top edge, px.
        y: usize,
        /// The pixels.
        image: Image,
    },
    /// A filled rectangle covering `[x, x + w) × [y, y + h)`.
    Rect {
        /// Left, top, width and height, px.
        x: f64,
        /// Top, px.
        y: f64,
        /// Width, px.
        w: f64,
        /// Height, px.
        h: f64,
        /// Fill.
        color: [u8; 3],
    },
    /// A line through the centres of pixels, one pixel wide.
    Line {
        /// Its vertices, px.
        points: Vec<(f64, f64)>,
        /// Its colour.
        color: [u8; 3],
        /// Drawn as 6 px dashes 4 px apart.
        dashed: bool,
    },
    /// A line of text, placed by the top of its line box.
    Text {
        /// The anchor's column, px.
        x: f64,
        /// The top of the line box, px.
        y: f64,
        /// The text.
        text: String,
        /// Font size, px.
        size: f64,
        /// What `x` refers to.
        anchor: Anchor,
        /// Its colour.
        color: [u8; 3],
        /// Turned a quarter anticlockwise, reading upwards from `(x, y)`
        /// (an axis title beside a vertical axis).
        vertical: bool,
    },
}

/// A picture of `width × height` px: a background and marks drawn in order.
#[derive(Clone, Debug, PartialEq)]
pub struct Figure {
    /// Width, px.
    pub width: usize,
    /// Height, px.
    pub height: usize,
    /// The colour under every mark.
    pub background: [u8; 3],
    /// The marks, the later over the earlier.
    pub marks: Vec<Mark>,
}

/// `#rrggbb`.
fn hex(c: [u8; 3]) -> String {
    format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2])
}

/// `s` with the characters XML reserves escaped.
fn xml(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

impl Figure {
    /// An empty figure.
    pub fn new(width: usize, height: usize, background: [u8; 3]) -> Self {
        Self {
            width,
            height,
            background,
            marks: Vec::new(),
        }
    }

    /// Adds pixels drawn one to one at `(x, y)`.
    pub fn raster(&mut self, x: usize, y: usize, image: Image) {
        self.marks.push(Mark::Raster { x, y, image });
    }

    /// Adds a filled rectangle.
    pub fn rect(&mut self, x: f64, y: f64, w: f64, h: f64, color: [u8; 3]) {
        self.marks.push(Mark::Rect { x, y, w, h, color });
    }

    /// Adds a line through `points`.
    pub fn line(&mut self, points: Vec<(f64, f64)>, color: [u8; 3]) {
        self.marks.push(Mark::Line {
            points,
            color,
            dashed: false,
        });
    }

    /// Adds a dashed line through `points`.
    pub fn dashed(&mut self, points: Vec<(f64, f64)>, color: [u8; 3]) {
        self.marks.push(Mark::Line {
            points,
            color,
            dashed: true,
        });
    }

    /// Adds a line of text whose line box's top is at `y`.
    pub fn text(&mut self, x: f64, y: f64, text: &str, size: f64, anchor: Anchor, color: [u8; 3]) {
        self.marks.push(Mark::Text {
            x,
            y,
            text: text.to_string(),
            size,
            anchor,
            color,
            vertical: false,
        });
    }

    /// Adds a line of text reading upwards, its line box's left edge (the
    /// top of the letters) at column `x`, anchored at row `y`.
    pub fn vertical_text(&mut self, x: f64, y: f64, text: &str, size: f64, color: [u8; 3]) {
        self.marks.push(Mark::Text {
            x,
            y,
            text: text.to_string(),
            size,
            anchor: Anchor::Middle,
            color,
            vertical: true,
        });
    }

    /// Every mark of `other` moved by `(dx, dy)` and added to this one.
    pub fn place(&mut self, other: Figure, dx: usize, dy: usize) {
        let (fx, fy) = (dx as f64, dy as f64);
        for m in other.marks {
            self.marks.push(match m {
                Mark::Raster { x, y, image } => Mark::Raster {
                    x: x + dx,
                    y: y + dy,
                    image,
                },
                Mark::Rect { x, y, w, h, color } => Mark::Rect {
                    x: x + fx,
                    y: y + fy,
                    w,
                    h,
                    color,
                },
                Mark::Line {
                    points,
                    color,
                    dashed,
                } => Mark::Line {
                    points: points.iter().map(|&(x, y)| (x + fx, y + fy)).collect(),
                    color,
                    dashed,
                },
                Mark::Text { x, y, .. } => {
                    let mut t = m.clone();
                    if let Mark::Text { x: tx, y: ty, .. } = &mut t {
                        (*tx, *ty) = (x + fx, y + fy);
                    }
                    t
                }
            });
        }
    }

    /// The figure as pixels: lines without anti-aliasing (their colours
    /// stay exact), text in the embedded font.
    pub fn to_image(&self) -> Image {
        let mut img = Image::new(self.width, self.height, self.background);
        for m in &self.marks {
            match m {
                Mark::Raster { x, y, image } => img.paste(*x, *y, image),
                Mark::Rect { x, y, w, h, color } => {
                    let (x0, y0) = (x.round().max(0.0) as usize, y.round().max(0.0) as usize);
                    let (x1, y1) = (
                        (x + w).round().max(0.0) as usize,
                        (y + h).round().max(0.0) as usize,
                    );
                    img.fill(x0, y0, x1.saturating_sub(x0), y1.saturating_sub(y0), *color);
                }
                Mark::Line {
                    points,
                    color,
                    dashed,
                } => draw_polyline(&mut img, points, *color, *dashed),
                Mark::Text {
                    x,
                    y,
                    text,
                    size,
                    anchor,
                    color,
                    vertical,
                } => {
                    let shift = match anchor {
                        Anchor::Start => 0.0,
                        Anchor::Middle => 0.5 * text_width(text, *size),
                        Anchor::End => text_width(text, *size),
                    };
                    let at = if *vertical {
                        (*x, *y + shift)
                    } else {
                        (*x - shift, *y)
                    };
                    img.draw_text(at, text, *size, *color, *vertical);
                }
            }
        }
        img
    }

    /// The figure as an SVG element for inline use in HTML (which gives it
    /// its namespace: the page names no address), its rasters embedded as
    /// PNG, its text set by the viewer in a sans-serif font.
    pub fn to_svg(&self, label: &str) -> Result<String, png::EncodingError> {
        let (w, h) = (self.width, self.height);
        let mut s = format!(
            "<svg width=\"{w}\" height=\"{h}\" \
             viewBox=\"0 0 {w} {h}\" role=\"img\" aria-label=\"{}\" \
             font-family=\"DejaVu Sans, Verdana, sans-serif\"><rect width=\"{w}\" height=\"{h}\" \
             fill=\"{}\"/>",
            xml(label),
            hex(self.background)
        );
        for m in &self.marks {
            svg_mark(&mut s, m)?;
        }
        s.push_str("</svg>");
        Ok(s)
    }

    /// The figure as an 8-bit RGB PNG (see [`Image::to_png`]).
    pub fn to_png(&self) -> Result<Vec<u8>, png::EncodingError> {
        self.to_image().to_png()
    }

    /// Saves the figure as a PNG where no file is or over a picture
    /// lidarsim wrote (see [`Image::save_png`]).
    pub fn save_png(&self, path: &Path) -> Result<(), WriteError> {
        self.to_image().save_png(path)
    }
}

/// Draws a polyline pixel by pixel (dashes of 6 px every 10 px).
fn draw_polyline(img: &mut Image, points: &[(f64, f64)], color: [u8; 3], dashed: bool) {
    let px = |p: (f64, f64)| (p.0.round() as i64, p.1.round() as i64);
    if let [p] = points {
        let (x, y) = px(*p);
        if x >= 0 && y >= 0 {
            img.set(x as usize, y as usize, color);
        }
        return;
    }
    if !dashed {
        for w in points.windows(2) {
            line(img, px(w[0]), px(w[1]), color);
        }
        return;
    }
    // Dashed: the pattern runs on along the line, by segment length.
    let mut run = 0.0f64;
    for w in points.windows(2) {
        let (a, b) = (w[0], w[1]);
        let len = (b.0 - a.0).hypot(b.1 - a.1);
        let steps = len.ceil().max(1.0) as usize;
        for i in 0..steps {
            let t = i as f64 / steps as f64;
            if (run + t * len) % 10.0 < 6.0 {
                let (x, y) = px((a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1)));
                if x >= 0 && y >= 0 {
                    img.set(x as usize, y as usize, color);
                }
            }
        }
        run += len;
    }
}

/// Writes one mark as SVG.
fn svg_mark(s: &mut String, m: &Mark) -> Result<(), png::EncodingError> {
    match m {
        Mark::Raster { x, y, image } => {
            let _ = write!(
                s,
                "<image x=\"{x}\" y=\"{y}\" width=\"{}\" height=\"{}\" \
                 style=\"image-rendering:pixelated\" preserveAspectRatio=\"none\" \
                 href=\"data:image/png;base64,{}\"/>",
                image.width,
                image.height,
                super::image::base64(&image.to_png()?)
            );
        }
        Mark::Rect { x, y, w, h, color } => {
            let _ = write!(
                s,
                "<rect x=\"{x:.1}\" y=\"{y:.1}\" width=\"{w:.1}\" height=\"{h:.1}\" fill=\"{}\"/>",
                hex(*color)
            );
        }
        Mark::Line {
            points,
            color,
            dashed,
        } => {
            let _ = write!(
                s,
                "<polyline fill=\"none\" stroke=\"{}\" points=\"",
                hex(*color)
            );
            for (k, (x, y)) in points.iter().enumerate() {
                let sep = if k == 0 { "" } else { " " };
                // Pixel centres: a raster's pixel (x, y) spans x to x + 1.
                let _ = write!(s, "{sep}{:.1},{:.1}", x + 0.5, y + 0.5);
            }
            let dash = if *dashed {
                " stroke-dasharray=\"6 4\""
            } else {
                ""
            };
            let _ = write!(s, "\"{dash}/>");
        }
        Mark::Text {
            x,
            y,
            text,
            size,
            anchor,
            color,
            vertical,
        } => {
            let anchor = match anchor {
                Anchor::Start => "start",
                Anchor::Middle => "middle",
                Anchor::End => "end",
            };
            let turn = if *vertical {
                format!(" transform=\"rotate(-90 {x:.1} {y:.1})\"")
            } else {
                String::new()
            };
            let _ = write!(
                s,
                "<text x=\"{x:.1}\" y=\"{:.1}\" font-size=\"{size}\" text-anchor=\"{anchor}\" \
                 fill=\"{}\"{turn}>{}</text>",
                y + BASELINE * size,
                hex(*color),
                xml(text)
            );
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The same figure as pixels and as SVG: a rectangle where it is in
    /// both, the text set in the raster and written as text in the SVG.
    #[test]
    fn a_figure_is_drawn_alike_as_pixels_and_as_svg() {
        let mut f = Figure::new(100, 50, [255; 3]);
        f.rect(10.0, 10.0, 20.0, 5.0, [200, 0, 0]);
        f.line(vec![(0.0, 40.0), (99.0, 40.0)], [0, 0, 200]);
        f.text(50.0, 20.0, "a < b", 12.0, Anchor::Middle, [0; 3]);
        let img = f.to_image();
        assert_eq!(img.get(10, 10), [200, 0, 0]);
        assert_eq!(img.get(29, 14), [200, 0, 0]);
        assert_eq!(img.get(30, 15), [255; 3]);
        assert_eq!(img.get(50, 40), [0, 0, 200]);
        let inked = (30..70)
            .flat_map(|x| (20..35).map(move |y| (x, y)))
            .filter(|&(x, y)| img.get(x, y) != [255; 3])
            .count();
        assert!(inked > 20, "{inked}");
        let svg = f.to_svg("test").unwrap();
        assert!(svg.starts_with("<svg") && svg.ends_with("</svg>"));
        assert!(svg.contains(">a &lt; b</text>"), "{svg}");
        assert!(svg.contains(
            "<rect x=\"10.0\" y=\"10.0\" width=\"20.0\" height=\"5.0\" fill=\"#c80000\"/>"
        ));
        assert!(svg.contains("points=\"0.5,40.5 99.5,40.5\""));
    }
}

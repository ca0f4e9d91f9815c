//! The frame of a map: the "no data" hatching of pixels without points,
//! the legend panel to the right and the scale bar below.

use super::Image;
use super::figure::{Anchor, Figure, LABEL_PX};
use super::image::{BACKGROUND, INK};
use super::palette::Palette;
use super::text::text_width;

/// Colours of map pixels without points: a light grey with darker diagonal
/// hatching ([`no_data`]), unlike any data colour and unlike the white
/// page around the map.
pub const NO_DATA: [[u8; 3]; 2] = [[228, 228, 228], [188, 188, 188]];
/// Width of the legend panel right of a map, px.
pub(super) const LEGEND_WIDTH: usize = 150;
/// Height of the footer under a map that holds the scale bar, px.
pub(super) const FOOTER_HEIGHT: usize = 34;

/// The colour of map pixel `(x, y)` when it holds no point (see
/// [`NO_DATA`]).
pub fn no_data(x: usize, y: usize) -> [u8; 3] {
    NO_DATA[usize::from((x + y).is_multiple_of(6))]
}

/// A `w × h` px map with every pixel hatched as "no data", for the data
/// to be drawn over.
pub fn hatched(w: usize, h: usize) -> Image {
    let mut img = Image::new(w, h, NO_DATA[0]);
    for y in 0..h {
        for x in 0..w {
            img.set(x, y, no_data(x, y));
        }
    }
    img
}

/// Draws a scale bar of a round length under the map; returns the column
/// after its label.
pub(super) fn scale_bar(
    fig: &mut Figure,
    x0: usize,
    y: usize,
    map_width_px: usize,
    resolution_m: f64,
) -> f64 {
    let target = map_width_px as f64 * resolution_m / 4.0;
    let mag = 10f64.powf(target.log10().floor());
    let len = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|f| f * mag)
        .filter(|l| *l <= target)
        .fold(mag, f64::max);
    let px = (len / resolution_m).round();
    let (x, y) = (x0 as f64, y as f64);
    fig.rect(x, y, px, 4.0, INK);
    fig.rect(x, y - 4.0, 2.0, 8.0, INK);
    fig.rect(x + (px - 2.0).max(0.0), y - 4.0, 2.0, 8.0, INK);
    let label = format!("{} m", super::fixed(len, if len < 1.0 { 2 } else { 0 }));
    fig.text(x + px + 8.0, y - 5.0, &label, LABEL_PX, Anchor::Start, INK);
    x + px + 8.0 + text_width(&label, LABEL_PX)
}

/// A finished picture: the `map` (pixels), the palette's legend or colour
/// bar to its right and a scale bar below, for `resolution_m` per pixel.
pub fn framed(map: Image, palette: &Palette, resolution_m: f64) -> Figure {
    let (w, h) = (map.width, map.height);
    let mut fig = Figure::new(w + LEGEND_WIDTH, (h + FOOTER_HEIGHT).max(200), BACKGROUND);
    fig.raster(0, 0, map);
    palette.draw(&mut fig, w + 10, 0, h.max(200 - FOOTER_HEIGHT));
    scale_bar(&mut fig, 10, h + 18, w, resolution_m);
    fig
}

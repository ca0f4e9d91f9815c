//! The frame of a map: the "no data" hatching of pixels without points,
//! the legend panel to the right and the scale bar below.

use super::Image;
use super::image::{BACKGROUND, INK};
use super::palette::Palette;

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

/// Draws a scale bar of a round length under the map; returns the column
/// after its label.
pub(super) fn scale_bar(
    img: &mut Image,
    x0: usize,
    y: usize,
    map_width_px: usize,
    resolution_m: f64,
) -> usize {
    let target = map_width_px as f64 * resolution_m / 4.0;
    let mag = 10f64.powf(target.log10().floor());
    let len = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|f| f * mag)
        .filter(|l| *l <= target)
        .fold(mag, f64::max);
    let px = (len / resolution_m).round() as usize;
    img.fill(x0, y, px, 4, INK);
    img.fill(x0, y - 4, 2, 8, INK);
    img.fill(x0 + px.saturating_sub(2), y - 4, 2, 8, INK);
    let label = format!("{len} M");
    img.text(x0 + px + 8, y - 2, &label, INK);
    x0 + px + 8 + 6 * label.len()
}

/// An empty frame for a `w × h` px map: white, the map area hatched as
/// "no data", room for the legend to the right and the scale bar below.
pub(super) fn frame(w: usize, h: usize) -> Image {
    let mut img = Image::new(w + LEGEND_WIDTH, (h + FOOTER_HEIGHT).max(200), BACKGROUND);
    for y in 0..h {
        for x in 0..w {
            img.set(x, y, no_data(x, y));
        }
    }
    img
}

/// Draws the legend and the scale bar of a frame made by [`frame`].
pub(super) fn finish_frame(
    img: &mut Image,
    w: usize,
    h: usize,
    palette: &Palette,
    resolution_m: f64,
) {
    palette.draw(img, w + 10, 0, h.max(200 - FOOTER_HEIGHT));
    scale_bar(img, 10, h + 18, w, resolution_m);
}

/// A finished picture: the `map` (pixels), the palette's legend or colour
/// bar to its right and a scale bar below, for `resolution_m` per pixel.
pub fn framed(map: &Image, palette: &Palette, resolution_m: f64) -> Image {
    let (w, h) = (map.width, map.height);
    let mut img = Image::new(w + LEGEND_WIDTH, (h + FOOTER_HEIGHT).max(200), BACKGROUND);
    for y in 0..h {
        let row = 3 * y * w;
        let dst = 3 * y * img.width;
        img.rgb[dst..dst + 3 * w].copy_from_slice(&map.rgb[row..row + 3 * w]);
    }
    finish_frame(&mut img, w, h, palette, resolution_m);
    img
}

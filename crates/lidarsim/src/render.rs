//! Pictures of point clouds without system libraries: top views and
//! cross-sections rendered to RGB rasters and PNG files, with a legend or
//! colour bar and a scale bar (specification: "Ultimately the output is
//! visual").

use std::io;
use std::path::Path;

use crate::detection::Echo;
use crate::waveform::{Waveform, bin_to_range};

/// The attributes a picture can show of a point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderPoint {
    /// Position, m.
    pub x: f64,
    /// Position, m.
    pub y: f64,
    /// Height, m.
    pub z: f64,
    /// LAS intensity.
    pub intensity: u16,
    /// ASPRS class.
    pub classification: u8,
    /// Return number (1-based).
    pub return_number: u8,
    /// Number of returns of the pulse.
    pub number_of_returns: u8,
    /// Point source ID (flight line).
    pub source: u16,
}

/// What the colours show.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ColorBy {
    /// Height, on a colour bar over the robust range ([`ROBUST_QUANTILES`]).
    Height,
    /// Intensity, likewise.
    Intensity,
    /// ASPRS class, with the usual class colours.
    Class,
    /// Single, first, intermediate or last return.
    Return,
    /// Flight line.
    Strip,
}

impl ColorBy {
    /// Parses `height`, `intensity`, `class`, `return` or `strip`.
    pub fn from_name(s: &str) -> Option<Self> {
        match s {
            "height" | "z" => Some(ColorBy::Height),
            "intensity" => Some(ColorBy::Intensity),
            "class" | "classification" => Some(ColorBy::Class),
            "return" | "returns" => Some(ColorBy::Return),
            "strip" | "line" | "source" => Some(ColorBy::Strip),
            _ => None,
        }
    }
}

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

/// Background of a cross-section: air, where no point is expected.
pub const EMPTY: [u8; 3] = [235, 235, 235];
/// Colours of map pixels without points: a light grey with darker diagonal
/// hatching ([`no_data`]), unlike any data colour and unlike the white
/// page around the map.
pub const NO_DATA: [[u8; 3]; 2] = [[228, 228, 228], [188, 188, 188]];
const BACKGROUND: [u8; 3] = [255, 255, 255];
const INK: [u8; 3] = [20, 20, 20];
const LEGEND_WIDTH: usize = 150;
const FOOTER_HEIGHT: usize = 34;
/// Width of the height axis left of a cross-section, px.
pub const PROFILE_AXIS_PX: usize = 48;

/// Largest side of a picture's map (without legend and scale bar), px.
pub const MAX_SIDE_PX: usize = 8192;
/// Largest number of pixels of a picture's map: 16 million, about 200 MB
/// while a top view is drawn (a point index and a colour per pixel).
pub const MAX_MAP_PIXELS: usize = 16_000_000;

/// The colour of map pixel `(x, y)` when it holds no point (see
/// [`NO_DATA`]).
pub fn no_data(x: usize, y: usize) -> [u8; 3] {
    NO_DATA[usize::from((x + y).is_multiple_of(6))]
}

/// `v` with `decimals` decimals, never as "-0.0": a value that rounds to
/// zero is printed without a sign.
pub fn fixed(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    match s.strip_prefix('-') {
        Some(rest) if rest.bytes().all(|b| b == b'0' || b == b'.') => rest.to_string(),
        _ => s,
    }
}

/// A picture whose map would exceed [`MAX_SIDE_PX`] or [`MAX_MAP_PIXELS`]
/// at the pixel size asked for.
#[derive(Clone, Debug, PartialEq)]
pub struct TooLarge {
    /// The pixel size asked for, m.
    pub resolution_m: f64,
    /// Width of the map it would give, px (possibly huge or infinite).
    pub width_px: f64,
    /// Height of the map it would give, px.
    pub height_px: f64,
    /// The smallest pixel size that fits, rounded up to three significant
    /// digits, m; `None` when the points span too far for any.
    pub smallest_resolution_m: Option<f64>,
}

impl std::fmt::Display for TooLarge {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let px = |v: f64| {
            if v < 1e12 {
                format!("{v:.0}")
            } else {
                format!("{v:.2e}")
            }
        };
        write!(
            f,
            "a pixel size of {} m would make a picture of {} × {} px, over the limit of \
             {MAX_SIDE_PX} px a side and {MAX_MAP_PIXELS} pixels",
            self.resolution_m,
            px(self.width_px),
            px(self.height_px)
        )?;
        match self.smallest_resolution_m {
            Some(r) => write!(f, "; the smallest pixel size that fits is {r} m"),
            None => write!(f, "; the points span too far to be drawn at any pixel size"),
        }
    }
}

impl std::error::Error for TooLarge {}

/// Pixels along `len_m` at `res` m per pixel (as `f64`: it may not fit a
/// `usize`).
fn cells(len_m: f64, res: f64) -> f64 {
    (len_m / res).floor() + 1.0
}

/// Whether a `w × h` px map is within the limits.
fn fits(w: f64, h: f64) -> bool {
    w <= MAX_SIDE_PX as f64 && h <= MAX_SIDE_PX as f64 && w * h <= MAX_MAP_PIXELS as f64
}

/// The smallest pixel size, rounded up to three significant digits (so
/// that the printed value fits too), at which `w_m × h_m` fits.
fn smallest_fitting(w_m: f64, h_m: f64) -> Option<f64> {
    if !(w_m.is_finite() && h_m.is_finite()) {
        return None;
    }
    let ok = |r: f64| fits(cells(w_m, r), cells(h_m, r));
    // At a pixel as long as the longer side the map is at most 2 × 2 px.
    let mut hi = w_m.max(h_m).max(f64::MIN_POSITIVE);
    while !ok(hi) {
        hi *= 2.0;
    }
    let mut lo = hi;
    while ok(lo) {
        lo /= 2.0;
        if lo < f64::MIN_POSITIVE {
            return Some(hi);
        }
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if ok(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    let e = hi.log10().floor() as i32 - 2;
    let decimals = usize::try_from(-e).unwrap_or(0);
    let step = 10f64.powi(e);
    let mut k = (hi / step).ceil();
    loop {
        let text = format!("{:.decimals$}", k * step);
        if let Ok(r) = text.parse::<f64>()
            && ok(r)
        {
            return Some(r);
        }
        k += 1.0;
    }
}

/// The pixel size of a map of `w_m × h_m`: the one requested, if the map
/// fits the limits at it (else an error saying what would fit), or the
/// automatic one, coarsened as far as needed to fit.
fn fit_resolution(
    w_m: f64,
    h_m: f64,
    requested: Option<f64>,
    auto: impl FnOnce() -> f64,
) -> Result<f64, TooLarge> {
    let res = requested.unwrap_or_else(auto);
    let (w, h) = (cells(w_m, res), cells(h_m, res));
    if fits(w, h) {
        return Ok(res);
    }
    let smallest = smallest_fitting(w_m, h_m);
    match (requested, smallest) {
        (None, Some(s)) => Ok(s.max(res)),
        _ => Err(TooLarge {
            resolution_m: res,
            width_px: w,
            height_px: h,
            smallest_resolution_m: smallest,
        }),
    }
}

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

    /// Writes text in the built-in 5×7 font (upper case; 6 px per
    /// character, scale 1).
    pub fn text(&mut self, x: usize, y: usize, s: &str, c: [u8; 3]) {
        for (k, ch) in s.chars().enumerate() {
            let rows = glyph(ch.to_ascii_uppercase());
            for (r, row) in rows.iter().enumerate() {
                for (col, b) in row.bytes().enumerate() {
                    if b == b'#' {
                        self.set(x + 6 * k + col, y + r, c);
                    }
                }
            }
        }
    }

    /// The image as an 8-bit RGB PNG.
    pub fn to_png(&self) -> io::Result<Vec<u8>> {
        let mut bytes = Vec::new();
        let mut enc = png::Encoder::new(&mut bytes, self.width as u32, self.height as u32);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc.write_header().map_err(io::Error::other)?;
        w.write_image_data(&self.rgb).map_err(io::Error::other)?;
        w.finish().map_err(io::Error::other)?;
        Ok(bytes)
    }

    /// Saves as an 8-bit RGB PNG (written whole, then renamed into place).
    pub fn save_png(&self, path: &Path) -> io::Result<()> {
        crate::output::write_atomic(path, &self.to_png()?)
    }
}

/// A perceptually ordered colour ramp (anchors of matplotlib's viridis),
/// `v` in 0–1.
pub fn ramp(v: f64) -> [u8; 3] {
    const A: [[f64; 3]; 5] = [
        [68.0, 1.0, 84.0],
        [59.0, 82.0, 139.0],
        [33.0, 145.0, 140.0],
        [94.0, 201.0, 98.0],
        [253.0, 231.0, 37.0],
    ];
    let v = if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = v * 4.0;
    let i = (x.floor() as usize).min(3);
    let f = x - i as f64;
    std::array::from_fn(|k| (A[i][k] + f * (A[i + 1][k] - A[i][k])).round() as u8)
}

/// Colour and legend name of an ASPRS class.
pub fn class_color(class: u8) -> ([u8; 3], &'static str) {
    match class {
        2 => ([166, 118, 29], "ground"),
        3 => ([178, 223, 138], "low veg"),
        4 => ([102, 189, 99], "medium veg"),
        5 => ([26, 120, 50], "high veg"),
        6 => ([215, 48, 39], "building"),
        7 => ([255, 0, 255], "noise"),
        9 => ([49, 130, 189], "water"),
        11 => ([120, 120, 120], "road"),
        17 => ([253, 174, 97], "bridge"),
        _ => ([200, 200, 200], "other"),
    }
}

fn return_color(p: &RenderPoint) -> ([u8; 3], &'static str) {
    if p.number_of_returns <= 1 {
        ([90, 90, 90], "single")
    } else if p.return_number == 1 {
        ([31, 120, 180], "first")
    } else if p.return_number >= p.number_of_returns {
        ([227, 26, 28], "last")
    } else {
        ([51, 160, 44], "intermediate")
    }
}

fn strip_color(source: u16) -> [u8; 3] {
    const P: [[u8; 3]; 8] = [
        [31, 119, 180],
        [255, 127, 14],
        [44, 160, 44],
        [214, 39, 40],
        [148, 103, 189],
        [140, 86, 75],
        [227, 119, 194],
        [23, 190, 207],
    ];
    P[usize::from(source) % P.len()]
}

/// The percentiles that bound a colour bar's robust range: the 0.1st and
/// the 99.9th, so that a few stray points (a bird, a noise echo) do not
/// stretch the scale while a feature covering more than a thousandth of
/// the picture (a house in a field) keeps its colours.
pub const ROBUST_QUANTILES: (f64, f64) = (0.001, 0.999);

/// A value range between the [`ROBUST_QUANTILES`] of `v`.
pub(crate) fn robust_range(mut v: Vec<f64>) -> (f64, f64) {
    if v.is_empty() {
        return (0.0, 1.0);
    }
    v.sort_by(f64::total_cmp);
    let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    let (lo, hi) = (at(ROBUST_QUANTILES.0), at(ROBUST_QUANTILES.1));
    if hi > lo {
        (lo, hi)
    } else {
        (lo - 0.5, lo + 0.5)
    }
}

/// What the legend of a robust colour bar says about its range.
const ROBUST_NOTE: &str = "0.1-99.9 % RANGE";

/// The robust range of `values` (from a regular sample of at most about a
/// million of them) and whether values lie below or above it by more than
/// 1 % of its span (clamped visibly, not just the last fraction).
fn robust_bar(values: impl Iterator<Item = f64> + Clone) -> ((f64, f64), (bool, bool)) {
    let n = values.clone().count();
    let stride = n.div_ceil(1 << 20).max(1);
    let range = robust_range(values.clone().step_by(stride).collect());
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    let margin = 0.01 * (range.1 - range.0);
    (range, (lo < range.0 - margin, hi > range.1 + margin))
}

/// How each point is coloured, and the legend that explains it.
pub struct Palette {
    title: Option<&'static str>,
    by: ColorBy,
    range: (f64, f64),
    /// Whether values lie below and above the range (they take the end
    /// colours; arrows at the bar's ends say so).
    clipped: (bool, bool),
    /// What the range is, written under the bar.
    note: Option<&'static str>,
    entries: Vec<([u8; 3], String)>,
    /// Whether the legend explains the no-data hatching.
    no_data: bool,
}

impl Palette {
    /// A colour bar over `range` (height or intensity).
    pub fn bar(by: ColorBy, range: (f64, f64)) -> Self {
        Self {
            title: None,
            by,
            range,
            clipped: (false, false),
            note: None,
            entries: Vec::new(),
            no_data: false,
        }
    }

    /// A colour bar over the robust range of `values` ([`ROBUST_QUANTILES`]),
    /// the legend saying so and marking the ends beyond which values were
    /// clamped to the end colours.
    pub fn robust(by: ColorBy, values: impl Iterator<Item = f64> + Clone) -> Self {
        let (range, clipped) = robust_bar(values);
        Self {
            clipped,
            note: Some(ROBUST_NOTE),
            ..Self::bar(by, range)
        }
    }

    /// A legend of the given ASPRS classes.
    pub fn classes(classes: &[u8]) -> Self {
        Self {
            entries: classes
                .iter()
                .map(|c| {
                    let (col, name) = class_color(*c);
                    (col, format!("{c} {name}"))
                })
                .collect(),
            ..Self::bar(ColorBy::Class, (0.0, 1.0))
        }
    }

    /// The range of the colour bar.
    pub fn range(&self) -> (f64, f64) {
        self.range
    }

    /// The colour of a value on a colour bar.
    pub fn bar_color(&self, v: f64) -> [u8; 3] {
        ramp((v - self.range.0) / (self.range.1 - self.range.0))
    }

    /// The palette of `points` (the ones shown): colour bars over their
    /// robust range.
    fn new<'a>(points: impl Iterator<Item = &'a RenderPoint> + Clone, by: ColorBy) -> Self {
        match by {
            ColorBy::Height => Self::robust(by, points.map(|p| p.z)),
            ColorBy::Intensity => Self::robust(by, points.map(|p| f64::from(p.intensity))),
            ColorBy::Class => {
                let mut classes: Vec<u8> = points.map(|p| p.classification).collect();
                classes.sort_unstable();
                classes.dedup();
                Self::classes(&classes)
            }
            ColorBy::Return => {
                let mut entries: Vec<([u8; 3], String)> = Vec::new();
                for p in points {
                    let (c, n) = return_color(p);
                    if !entries.iter().any(|(_, e)| e == n) {
                        entries.push((c, n.to_string()));
                    }
                }
                Self {
                    entries,
                    ..Self::bar(by, (0.0, 1.0))
                }
            }
            ColorBy::Strip => {
                let mut s: Vec<u16> = points.map(|p| p.source).collect();
                s.sort_unstable();
                s.dedup();
                Self {
                    entries: s
                        .iter()
                        .map(|id| (strip_color(*id), format!("line {id}")))
                        .collect(),
                    ..Self::bar(by, (0.0, 1.0))
                }
            }
        }
    }

    /// The same palette with another title over its colour bar.
    pub fn titled(self, title: &'static str) -> Self {
        Self {
            title: Some(title),
            ..self
        }
    }

    /// The same palette with a "no data" swatch in its legend (for maps,
    /// whose empty pixels are hatched).
    pub fn with_no_data(self) -> Self {
        Self {
            no_data: true,
            ..self
        }
    }

    fn color(&self, p: &RenderPoint) -> [u8; 3] {
        let scale = |v: f64| (v - self.range.0) / (self.range.1 - self.range.0);
        match self.by {
            ColorBy::Height => ramp(scale(p.z)),
            ColorBy::Intensity => ramp(scale(f64::from(p.intensity))),
            ColorBy::Class => class_color(p.classification).0,
            ColorBy::Return => return_color(p).0,
            ColorBy::Strip => strip_color(p.source),
        }
    }

    /// The labels of the bar's ends: as many decimals as the range needs
    /// (at least one for heights), never "-0.0".
    fn end_labels(&self) -> (String, String) {
        let span = (self.range.1 - self.range.0).abs();
        let least = if self.by == ColorBy::Height { 1 } else { 0 };
        let decimals = if span > 0.0 && span.is_finite() {
            (1 - span.log10().floor() as i64).clamp(least, 4) as usize
        } else {
            least as usize
        };
        let unit = if self.by == ColorBy::Height { " M" } else { "" };
        (
            format!("{}{unit}", fixed(self.range.0, decimals)),
            format!("{}{unit}", fixed(self.range.1, decimals)),
        )
    }

    /// Draws the legend or colour bar in the panel starting at `x0`.
    fn draw(&self, img: &mut Image, x0: usize, top: usize, bottom: usize) {
        let below = match self.by {
            ColorBy::Height | ColorBy::Intensity => {
                let title = self.title.unwrap_or(if self.by == ColorBy::Height {
                    "HEIGHT"
                } else {
                    "INTENSITY"
                });
                img.text(x0, top + 4, title, INK);
                let (y0, y1) = (top + 24, bottom.saturating_sub(44).max(top + 64));
                for y in y0..y1 {
                    let v = 1.0 - (y - y0) as f64 / (y1 - y0 - 1).max(1) as f64;
                    img.fill(x0, y, 24, 1, ramp(v));
                }
                // Arrows beyond the ends where values were clamped.
                for r in 0..6 {
                    let half = 12 * r / 6;
                    if self.clipped.1 {
                        img.fill(x0 + 12 - half, y0 - 7 + r, 2 * half.max(1), 1, ramp(1.0));
                    }
                    if self.clipped.0 {
                        img.fill(x0 + 12 - half, y1 + 6 - r, 2 * half.max(1), 1, ramp(0.0));
                    }
                }
                let (lo, hi) = self.end_labels();
                img.text(x0 + 30, y0, &hi, INK);
                img.text(x0 + 30, y1 - 7, &lo, INK);
                if let Some(note) = self.note {
                    img.text(x0, y1 + 12, note, INK);
                }
                y1 + 26
            }
            _ => {
                for (k, (c, name)) in self.entries.iter().enumerate() {
                    let y = top + 6 + 16 * k;
                    img.fill(x0, y, 12, 10, *c);
                    img.text(x0 + 18, y + 2, name, INK);
                }
                top + 6 + 16 * self.entries.len()
            }
        };
        if self.no_data {
            for y in below..below + 10 {
                for x in x0..x0 + 12 {
                    img.set(x, y, no_data(x, y));
                }
            }
            img.text(x0 + 18, below + 2, "NO DATA", INK);
        }
    }
}

/// Pixel size for a top view of `w × h` m holding `n` points: about four
/// points per pixel on average, at most 1600 px on the longer side.
fn auto_resolution(w: f64, h: f64, n: usize) -> f64 {
    // About four points per pixel on average (scan lines leave gaps
    // finer than the mean spacing), at most 1600 px.
    let by_density = (w * h / (n.max(1) as f64) * 4.0).sqrt();
    by_density.max(w.max(h) / 1600.0).max(1e-3)
}

/// Draws a scale bar of a round length under the map; returns the column
/// after its label.
fn scale_bar(
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
fn frame(w: usize, h: usize) -> Image {
    let mut img = Image::new(w + LEGEND_WIDTH, (h + FOOTER_HEIGHT).max(200), BACKGROUND);
    for y in 0..h {
        for x in 0..w {
            img.set(x, y, no_data(x, y));
        }
    }
    img
}

/// Draws the legend and the scale bar of a frame made by [`frame`].
fn finish_frame(img: &mut Image, w: usize, h: usize, palette: &Palette, resolution_m: f64) {
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

/// The pixel whose colour an empty pixel `k` of a `w × h` grid takes: its
/// highest filled neighbour when at least four of its eight neighbours
/// hold points. This closes the one-pixel gaps left where scan lines lie
/// further apart than a pixel (at the swath edges of a zigzag pattern)
/// while the outer edge of the data, with at most three filled neighbours
/// along a straight edge, stays empty.
pub fn hole_source(
    w: usize,
    h: usize,
    k: usize,
    filled: impl Fn(usize) -> bool,
    z: impl Fn(usize) -> f64,
) -> Option<usize> {
    let (i, j) = (k % w, k / w);
    let mut best: Option<(f64, usize)> = None;
    let mut count = 0;
    for (di, dj) in [
        (-1i64, -1i64),
        (0, -1),
        (1, -1),
        (-1, 0),
        (1, 0),
        (-1, 1),
        (0, 1),
        (1, 1),
    ] {
        let (ni, nj) = (i as i64 + di, j as i64 + dj);
        if ni < 0 || nj < 0 || ni >= w as i64 || nj >= h as i64 {
            continue;
        }
        let n = nj as usize * w + ni as usize;
        if filled(n) {
            count += 1;
            let zn = z(n);
            if best.is_none_or(|b| zn > b.0) {
                best = Some((zn, n));
            }
        }
    }
    best.filter(|_| count >= 4).map(|b| b.1)
}

/// A top view: for every pixel the colour of its highest point; pixels
/// without points are hatched as "no data", except one-pixel holes inside
/// the data, which take a neighbour's colour ([`hole_source`]). Height and
/// intensity are coloured over the robust range of the pixels
/// shown. `resolution_m` is the pixel size (default: from the point
/// density, coarsened if needed to fit the limits); a requested one at
/// which the map would exceed [`MAX_SIDE_PX`] or [`MAX_MAP_PIXELS`] is an
/// error that says the smallest one that fits.
pub fn top_view(
    points: &[RenderPoint],
    by: ColorBy,
    resolution_m: Option<f64>,
) -> Result<Image, TooLarge> {
    let (mut x0, mut y0, mut x1, mut y1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
    for p in points {
        x0 = x0.min(p.x);
        y0 = y0.min(p.y);
        x1 = x1.max(p.x);
        y1 = y1.max(p.y);
    }
    if points.is_empty() {
        (x0, y0, x1, y1) = (0.0, 0.0, 1.0, 1.0);
    }
    let (ew, eh) = (x1 - x0, y1 - y0);
    let res = fit_resolution(ew, eh, resolution_m, || {
        auto_resolution(ew, eh, points.len())
    })?;
    let (w, h) = (cells(ew, res) as usize, cells(eh, res) as usize);
    // The highest point of each pixel (the first of equals).
    const NONE: usize = usize::MAX;
    let mut top = vec![NONE; w * h];
    for (n, p) in points.iter().enumerate() {
        let i = (((p.x - x0) / res) as usize).min(w - 1);
        // North up: row 0 is the largest y.
        let j = h - 1 - (((p.y - y0) / res) as usize).min(h - 1);
        let k = j * w + i;
        if top[k] == NONE || p.z > points[top[k]].z {
            top[k] = n;
        }
    }
    let shown = top.iter().filter(|&&n| n != NONE).map(|&n| &points[n]);
    let palette = Palette::new(shown, by).with_no_data();
    let mut img = frame(w, h);
    let filled = |k: usize| top[k] != NONE;
    let z = |k: usize| points[top[k]].z;
    for k in 0..w * h {
        let source = if filled(k) {
            Some(k)
        } else {
            hole_source(w, h, k, filled, z)
        };
        if let Some(s) = source {
            img.set(k % w, k / w, palette.color(&points[top[s]]));
        }
    }
    finish_frame(&mut img, w, h, &palette, res);
    Ok(img)
}

/// The points of a cross-section band, by distance along it.
struct Section<'a> {
    /// (distance along the segment, point).
    sel: Vec<(f64, &'a RenderPoint)>,
    /// Length of the segment, m.
    len: f64,
    /// Heights of the bottom and top of the picture, m (the points' range
    /// and 1 m more on each side).
    z0: f64,
    z1: f64,
}

impl<'a> Section<'a> {
    fn select(points: &'a [RenderPoint], a: (f64, f64), b: (f64, f64), width_m: f64) -> Self {
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let len = dx.hypot(dy).max(1e-9);
        let (ux, uy) = (dx / len, dy / len);
        let sel: Vec<(f64, &RenderPoint)> = points
            .iter()
            .filter_map(|p| {
                let (rx, ry) = (p.x - a.0, p.y - a.1);
                let along = rx * ux + ry * uy;
                let across = -rx * uy + ry * ux;
                ((0.0..=len).contains(&along) && across.abs() <= 0.5 * width_m)
                    .then_some((along, p))
            })
            .collect();
        let (z0, z1) = sel.iter().fold((f64::MAX, f64::MIN), |(lo, hi), (_, p)| {
            (lo.min(p.z), hi.max(p.z))
        });
        let (z0, z1) = if sel.is_empty() {
            (0.0, 1.0)
        } else {
            (z0 - 1.0, z1 + 1.0)
        };
        Self { sel, len, z0, z1 }
    }

    /// The picture at `res_h` m per pixel along the segment and `res_v` m
    /// per pixel in height: heights on an axis to the left, the legend to
    /// the right, a scale bar below (with the vertical exaggeration when
    /// the two differ).
    fn draw(&self, by: ColorBy, res_h: f64, res_v: f64) -> Image {
        let w = cells(self.len, res_h) as usize;
        let h = cells(self.z1 - self.z0, res_v) as usize;
        let palette = Palette::new(self.sel.iter().map(|(_, p)| *p), by);
        let left = PROFILE_AXIS_PX;
        let mut img = Image::new(
            left + w + LEGEND_WIDTH,
            (h + FOOTER_HEIGHT).max(200),
            BACKGROUND,
        );
        img.fill(left, 0, w, h, EMPTY);
        for (along, p) in &self.sel {
            let i = ((along / res_h) as usize).min(w - 1);
            let j = h - 1 - (((p.z - self.z0) / res_v) as usize).min(h - 1);
            img.set(left + i, j, palette.color(p));
        }
        // Height axis: ticks at round heights at least 30 px apart.
        let z_top = self.z0 + h as f64 * res_v;
        let (ticks, decimals) = nice_ticks(self.z0, z_top, (h / 30).max(2));
        for t in ticks {
            let j = h - 1 - (((t - self.z0) / res_v) as usize).min(h - 1);
            img.fill(left - 4, j, 4, 1, INK);
            let label = fixed(t, decimals);
            let x = (left - 6).saturating_sub(6 * label.len());
            img.text(x, j.saturating_sub(3).min(h.saturating_sub(7)), &label, INK);
        }
        img.fill(left - 1, 0, 1, h, INK);
        img.text(2, h + 16, "Z M", INK);
        palette.draw(&mut img, left + w + 10, 0, h.max(200 - FOOTER_HEIGHT));
        let end = scale_bar(&mut img, left + 10, h + 18, w, res_h);
        let exaggeration = res_h / res_v;
        if (exaggeration - 1.0).abs() > 0.01 {
            img.text(
                end + 18,
                h + 16,
                &format!("HEIGHTS X{}", fixed(exaggeration, 1)),
                INK,
            );
        }
        img
    }
}

/// Round values from `lo` to `hi`, at most `max_ticks` of them (steps of
/// 1, 2 or 5 times a power of ten), and the decimals their labels need.
pub(crate) fn nice_ticks(lo: f64, hi: f64, max_ticks: usize) -> (Vec<f64>, usize) {
    let span = hi - lo;
    if !(span > 0.0 && span.is_finite()) {
        return (vec![lo], 1);
    }
    let raw = span / max_ticks.max(1) as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|f| f * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    let decimals = usize::try_from(-(step.log10().floor() as i64)).unwrap_or(0);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    let ticks = (first..=last).map(|k| k as f64 * step).collect();
    (ticks, decimals)
}

/// A cross-section: the points within `width_m / 2` of the segment from
/// `a` to `b` (x, y), drawn by distance along it (horizontal) and height
/// (vertical), at `resolution_m` per pixel in both directions (default:
/// 1200 px along the segment, at least 5 cm, coarsened if needed to fit
/// the limits; a requested one at which the map would exceed them is an
/// error).
pub fn profile(
    points: &[RenderPoint],
    a: (f64, f64),
    b: (f64, f64),
    width_m: f64,
    by: ColorBy,
    resolution_m: Option<f64>,
) -> Result<Image, TooLarge> {
    let s = Section::select(points, a, b, width_m);
    let res = fit_resolution(s.len, s.z1 - s.z0, resolution_m, || {
        (s.len / 1200.0).max(0.05)
    })?;
    Ok(s.draw(by, res, res))
}

/// A cross-section like [`profile`] with its heights stretched (or
/// squeezed) to fill `height_px` rows, at `resolution_m` per pixel along
/// the segment (coarsened to at most [`MAX_SIDE_PX`] columns); the scale
/// bar states the vertical exaggeration.
pub fn profile_exaggerated(
    points: &[RenderPoint],
    a: (f64, f64),
    b: (f64, f64),
    width_m: f64,
    by: ColorBy,
    resolution_m: f64,
    height_px: usize,
) -> Image {
    let s = Section::select(points, a, b, width_m);
    let res_h = resolution_m.max(s.len / (MAX_SIDE_PX - 1) as f64);
    let rows = height_px.clamp(2, 2000);
    // A little under (z1 − z0) / (rows − 1), so that rounding never adds
    // a row.
    let res_v = (s.z1 - s.z0) / (rows as f64 - 0.5);
    s.draw(by, res_h, res_v)
}

/// The row of a profile image at height `z` for a profile whose points span
/// `[z_min, z_max]` at `resolution_m` (the inverse of the mapping above).
pub fn profile_row(z: f64, z_min: f64, z_max: f64, resolution_m: f64) -> usize {
    let (z0, z1) = (z_min - 1.0, z_max + 1.0);
    let h = cells(z1 - z0, resolution_m) as usize;
    h - 1 - (((z - z0) / resolution_m) as usize).min(h - 1)
}

/// Draws a straight line (Bresenham).
fn line(img: &mut Image, a: (i64, i64), b: (i64, i64), c: [u8; 3]) {
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

/// What a waveform plot shows, in amplitude units against range.
#[derive(Clone, Debug, Default)]
pub struct WaveformPlot {
    /// Range of each sample, m.
    pub ranges_m: Vec<f64>,
    /// The received signal (convolved, with atmosphere and noise).
    pub signal: Vec<f64>,
    /// The sub-ray returns placed on the time axis before convolution: the
    /// "sum of sub-ray returns" of specification Fig. 6.
    pub returns: Vec<f64>,
    /// Detection threshold of each sample (background + threshold).
    pub threshold: Vec<f64>,
    /// Detected echoes: range and fitted peak (above the background).
    pub echoes: Vec<(f64, f64)>,
}

/// Plot area of a waveform picture, px.
pub const PLOT_WIDTH: usize = 900;
/// Plot area height, px.
pub const PLOT_HEIGHT: usize = 360;
const PLOT_LEFT: usize = 60;
const PLOT_TOP: usize = 20;

impl WaveformPlot {
    /// The plot of one recorded pulse: its `waveform` (bins of `bin_s`
    /// seconds, with the sub-ray returns placed on the time axis and the
    /// expected background), the `echoes` detected in it and the
    /// detector's `threshold` above the background.
    pub fn new(waveform: &Waveform, echoes: &[Echo], bin_s: f64, threshold: f64) -> Self {
        let wf = waveform;
        let background_at = |bin: f64| {
            let i =
                (bin.round() as i64 - wf.first_bin).clamp(0, wf.background.len().max(1) as i64 - 1);
            wf.background_at(i as usize)
        };
        Self {
            ranges_m: (0..wf.samples.len())
                .map(|i| bin_to_range((wf.first_bin + i as i64) as f64, bin_s))
                .collect(),
            signal: wf.samples.clone(),
            returns: wf.impulses.clone(),
            threshold: (0..wf.samples.len())
                .map(|i| wf.background_at(i) + threshold)
                .collect(),
            echoes: echoes
                .iter()
                .map(|e| (e.range_m, e.peak_amplitude + background_at(e.bin)))
                .collect(),
        }
    }

    /// Largest value shown on the vertical axis.
    pub fn y_max(&self) -> f64 {
        let m = self
            .signal
            .iter()
            .chain(&self.returns)
            .chain(&self.threshold)
            .cloned()
            .fold(0.0, f64::max);
        if m > 0.0 { m * 1.1 } else { 1.0 }
    }

    /// Pixel column of a range and row of an amplitude.
    pub fn to_px(&self, range_m: f64, value: f64) -> (i64, i64) {
        let (r0, r1) = (self.ranges_m[0], self.ranges_m[self.ranges_m.len() - 1]);
        let x = PLOT_LEFT as f64 + (range_m - r0) / (r1 - r0).max(1e-9) * (PLOT_WIDTH - 1) as f64;
        let y = PLOT_TOP as f64 + (1.0 - value / self.y_max()) * (PLOT_HEIGHT - 1) as f64;
        (x.round() as i64, y.round() as i64)
    }

    /// The picture (specification Figs. 6 and 7): grey stems for the
    /// sub-ray returns, the received signal in blue, the threshold dashed
    /// in orange, echoes as red markers with their number.
    pub fn render(&self) -> Image {
        let mut img = Image::new(
            PLOT_LEFT + PLOT_WIDTH + 170,
            PLOT_TOP + PLOT_HEIGHT + 40,
            BACKGROUND,
        );
        if self.ranges_m.len() < 2 {
            img.text(10, 10, "NO SIGNAL", INK);
            return img;
        }
        // Axes.
        let (x0, y0) = (PLOT_LEFT as i64, (PLOT_TOP + PLOT_HEIGHT) as i64);
        line(&mut img, (x0, PLOT_TOP as i64), (x0, y0), INK);
        line(&mut img, (x0, y0), (x0 + PLOT_WIDTH as i64, y0), INK);
        let (r0, r1) = (self.ranges_m[0], self.ranges_m[self.ranges_m.len() - 1]);
        for k in 0..=4 {
            let r = r0 + (r1 - r0) * k as f64 / 4.0;
            let (x, _) = self.to_px(r, 0.0);
            line(&mut img, (x, y0), (x, y0 + 4), INK);
            img.text(
                (x - 20).max(0) as usize,
                (y0 + 8) as usize,
                &format!("{r:.1}"),
                INK,
            );
            let v = self.y_max() * k as f64 / 4.0;
            let (_, y) = self.to_px(r0, v);
            line(&mut img, (x0 - 4, y), (x0, y), INK);
            img.text(2, (y - 3).max(0) as usize, &format!("{v:.3}"), INK);
        }
        img.text(
            (x0 + PLOT_WIDTH as i64 / 2 - 30) as usize,
            (y0 + 22) as usize,
            "RANGE M",
            INK,
        );
        // Sub-ray returns as stems.
        for (r, v) in self.ranges_m.iter().zip(&self.returns) {
            if *v > 0.0 {
                line(
                    &mut img,
                    self.to_px(*r, 0.0),
                    self.to_px(*r, *v),
                    [150, 150, 150],
                );
            }
        }
        // Threshold, dashed.
        for (k, w) in self.ranges_m.windows(2).enumerate() {
            if k % 4 < 2 {
                let (a, b) = (
                    self.to_px(w[0], self.threshold[k]),
                    self.to_px(w[1], self.threshold[k + 1]),
                );
                line(&mut img, a, b, [230, 120, 0]);
            }
        }
        // Signal.
        for k in 0..self.ranges_m.len() - 1 {
            let a = self.to_px(self.ranges_m[k], self.signal[k].max(0.0));
            let b = self.to_px(self.ranges_m[k + 1], self.signal[k + 1].max(0.0));
            line(&mut img, a, b, [31, 90, 200]);
        }
        // Echoes.
        for (k, (r, v)) in self.echoes.iter().enumerate() {
            let (x, y) = self.to_px(*r, *v);
            img.fill(
                (x - 3).max(0) as usize,
                (y - 3).max(0) as usize,
                7,
                7,
                [215, 40, 40],
            );
            img.text(
                (x + 6) as usize,
                (y - 10).max(0) as usize,
                &format!("{}", k + 1),
                [215, 40, 40],
            );
        }
        // Legend.
        let lx = PLOT_LEFT + PLOT_WIDTH + 15;
        for (k, (c, name)) in [
            ([150, 150, 150], "SUB-RAYS"),
            ([31, 90, 200], "SIGNAL"),
            ([230, 120, 0], "THRESHOLD"),
            ([215, 40, 40], "ECHOES"),
        ]
        .iter()
        .enumerate()
        {
            img.fill(lx, PLOT_TOP + 16 * k, 12, 10, *c);
            img.text(lx + 18, PLOT_TOP + 16 * k + 2, name, INK);
        }
        img
    }
}

/// One quantity against time, a panel of [`time_panels`].
#[derive(Clone, Debug, Default)]
pub struct Series {
    /// Title written over the panel (quantity and unit).
    pub title: String,
    /// Colour of the curve.
    pub color: [u8; 3],
    /// Runs of (time s, value), each drawn as one curve: nothing is drawn
    /// between runs (between flight lines).
    pub runs: Vec<Vec<(f64, f64)>>,
}

/// Width of the plot area of a [`time_panels`] picture, px.
pub const SERIES_WIDTH: usize = 900;
/// Height of each panel of a [`time_panels`] picture, px.
pub const SERIES_HEIGHT: usize = 110;
const SERIES_LEFT: usize = 80;
const SERIES_GAP: usize = 30;

/// Stacked panels sharing one time axis, one per series, each with its own
/// vertical range (the data's, with a margin) and round ticks; the time
/// axis is labelled under the last panel.
pub fn time_panels(series: &[Series]) -> Image {
    let n = series.len().max(1);
    let mut img = Image::new(
        SERIES_LEFT + SERIES_WIDTH + 30,
        n * (SERIES_HEIGHT + SERIES_GAP) + 40,
        BACKGROUND,
    );
    let all = || series.iter().flat_map(|s| s.runs.iter().flatten());
    let (t0, t1) = all().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
        (a.min(p.0), b.max(p.0))
    });
    if !(t0.is_finite() && t1.is_finite()) {
        img.text(10, 10, "NO DATA", INK);
        return img;
    }
    let t1 = if t1 > t0 { t1 } else { t0 + 1.0 };
    let x_of = |t: f64| {
        SERIES_LEFT as i64 + ((t - t0) / (t1 - t0) * (SERIES_WIDTH - 1) as f64).round() as i64
    };
    let (t_ticks, t_dec) = nice_ticks(t0, t1, 10);
    for (k, s) in series.iter().enumerate() {
        let top = k * (SERIES_HEIGHT + SERIES_GAP) + SERIES_GAP;
        let bottom = top + SERIES_HEIGHT - 1;
        img.text(SERIES_LEFT, top - 14, &s.title, INK);
        let (mut lo, mut hi) = s
            .runs
            .iter()
            .flatten()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.1), b.max(p.1))
            });
        if !(lo.is_finite() && hi.is_finite()) {
            (lo, hi) = (0.0, 1.0);
        }
        let pad = if hi > lo {
            0.08 * (hi - lo)
        } else {
            (0.05 * lo.abs()).max(1e-3)
        };
        let (lo, hi) = (lo - pad, hi + pad);
        let y_of = |v: f64| {
            bottom as i64 - ((v - lo) / (hi - lo) * (SERIES_HEIGHT - 1) as f64).round() as i64
        };
        // Axes, a light line at zero, ticks.
        let (x0, x1) = (SERIES_LEFT as i64, (SERIES_LEFT + SERIES_WIDTH - 1) as i64);
        if lo < 0.0 && hi > 0.0 {
            line(&mut img, (x0, y_of(0.0)), (x1, y_of(0.0)), [200, 200, 200]);
        }
        line(&mut img, (x0, top as i64), (x0, bottom as i64), INK);
        line(&mut img, (x0, bottom as i64), (x1, bottom as i64), INK);
        let (ticks, dec) = nice_ticks(lo, hi, 4);
        for v in ticks {
            let y = y_of(v);
            line(&mut img, (x0 - 4, y), (x0 - 1, y), INK);
            let label = fixed(v, dec);
            let x = (SERIES_LEFT - 6).saturating_sub(6 * label.len());
            img.text(x, (y - 3).max(0) as usize, &label, INK);
        }
        for &t in &t_ticks {
            let x = x_of(t);
            line(&mut img, (x, bottom as i64), (x, bottom as i64 + 3), INK);
        }
        for run in &s.runs {
            for w in run.windows(2) {
                line(
                    &mut img,
                    (x_of(w[0].0), y_of(w[0].1)),
                    (x_of(w[1].0), y_of(w[1].1)),
                    s.color,
                );
            }
            if let [p] = run.as_slice() {
                img.set(x_of(p.0) as usize, y_of(p.1) as usize, s.color);
            }
        }
    }
    let bottom = n * (SERIES_HEIGHT + SERIES_GAP) - 1;
    for &t in &t_ticks {
        let label = fixed(t, t_dec);
        let x = (x_of(t) as usize).saturating_sub(3 * label.len());
        img.text(x, bottom + 7, &label, INK);
    }
    img.text(
        SERIES_LEFT + SERIES_WIDTH / 2 - 18,
        bottom + 22,
        "TIME S",
        INK,
    );
    img
}

/// 5×7 glyphs of the built-in font.
fn glyph(c: char) -> [&'static str; 7] {
    match c {
        '0' => [
            ".###.", "#...#", "#..##", "#.#.#", "##..#", "#...#", ".###.",
        ],
        '1' => [
            "..#..", ".##..", "..#..", "..#..", "..#..", "..#..", ".###.",
        ],
        '2' => [
            ".###.", "#...#", "....#", "...#.", "..#..", ".#...", "#####",
        ],
        '3' => [
            "####.", "....#", "....#", ".###.", "....#", "....#", "####.",
        ],
        '4' => [
            "...#.", "..##.", ".#.#.", "#..#.", "#####", "...#.", "...#.",
        ],
        '5' => [
            "#####", "#....", "####.", "....#", "....#", "#...#", ".###.",
        ],
        '6' => [
            ".###.", "#....", "#....", "####.", "#...#", "#...#", ".###.",
        ],
        '7' => [
            "#####", "....#", "...#.", "..#..", ".#...", ".#...", ".#...",
        ],
        '8' => [
            ".###.", "#...#", "#...#", ".###.", "#...#", "#...#", ".###.",
        ],
        '9' => [
            ".###.", "#...#", "#...#", ".####", "....#", "....#", ".###.",
        ],
        'A' => [
            ".###.", "#...#", "#...#", "#####", "#...#", "#...#", "#...#",
        ],
        'B' => [
            "####.", "#...#", "#...#", "####.", "#...#", "#...#", "####.",
        ],
        'C' => [
            ".###.", "#...#", "#....", "#....", "#....", "#...#", ".###.",
        ],
        'D' => [
            "####.", "#...#", "#...#", "#...#", "#...#", "#...#", "####.",
        ],
        'E' => [
            "#####", "#....", "#....", "####.", "#....", "#....", "#####",
        ],
        'F' => [
            "#####", "#....", "#....", "####.", "#....", "#....", "#....",
        ],
        'G' => [
            ".###.", "#...#", "#....", "#.###", "#...#", "#...#", ".###.",
        ],
        'H' => [
            "#...#", "#...#", "#...#", "#####", "#...#", "#...#", "#...#",
        ],
        'I' => [
            ".###.", "..#..", "..#..", "..#..", "..#..", "..#..", ".###.",
        ],
        'J' => [
            "..###", "...#.", "...#.", "...#.", "...#.", "#..#.", ".##..",
        ],
        'K' => [
            "#...#", "#..#.", "#.#..", "##...", "#.#..", "#..#.", "#...#",
        ],
        'L' => [
            "#....", "#....", "#....", "#....", "#....", "#....", "#####",
        ],
        'M' => [
            "#...#", "##.##", "#.#.#", "#.#.#", "#...#", "#...#", "#...#",
        ],
        'N' => [
            "#...#", "#...#", "##..#", "#.#.#", "#..##", "#...#", "#...#",
        ],
        'O' => [
            ".###.", "#...#", "#...#", "#...#", "#...#", "#...#", ".###.",
        ],
        'P' => [
            "####.", "#...#", "#...#", "####.", "#....", "#....", "#....",
        ],
        'Q' => [
            ".###.", "#...#", "#...#", "#...#", "#.#.#", "#..#.", ".##.#",
        ],
        'R' => [
            "####.", "#...#", "#...#", "####.", "#.#..", "#..#.", "#...#",
        ],
        'S' => [
            ".####", "#....", "#....", ".###.", "....#", "....#", "####.",
        ],
        'T' => [
            "#####", "..#..", "..#..", "..#..", "..#..", "..#..", "..#..",
        ],
        'U' => [
            "#...#", "#...#", "#...#", "#...#", "#...#", "#...#", ".###.",
        ],
        'V' => [
            "#...#", "#...#", "#...#", "#...#", "#...#", ".#.#.", "..#..",
        ],
        'W' => [
            "#...#", "#...#", "#...#", "#.#.#", "#.#.#", "#.#.#", ".#.#.",
        ],
        'X' => [
            "#...#", "#...#", ".#.#.", "..#..", ".#.#.", "#...#", "#...#",
        ],
        'Y' => [
            "#...#", "#...#", ".#.#.", "..#..", "..#..", "..#..", "..#..",
        ],
        'Z' => [
            "#####", "....#", "...#.", "..#..", ".#...", "#....", "#####",
        ],
        '.' => [
            ".....", ".....", ".....", ".....", ".....", ".##..", ".##..",
        ],
        '-' => [
            ".....", ".....", ".....", "#####", ".....", ".....", ".....",
        ],
        '/' => [
            "....#", "....#", "...#.", "..#..", ".#...", "#....", "#....",
        ],
        '%' => [
            "##...", "##..#", "...#.", "..#..", ".#...", "#..##", "...##",
        ],
        ':' => [
            ".....", ".##..", ".##..", ".....", ".##..", ".##..", ".....",
        ],
        ',' => [
            ".....", ".....", ".....", ".....", ".##..", "..#..", ".#...",
        ],
        '(' => [
            "...#.", "..#..", ".#...", ".#...", ".#...", "..#..", "...#.",
        ],
        ')' => [
            ".#...", "..#..", "...#.", "...#.", "...#.", "..#..", ".#...",
        ],
        '+' => [
            ".....", "..#..", "..#..", "#####", "..#..", "..#..", ".....",
        ],
        '=' => [
            ".....", ".....", "#####", ".....", "#####", ".....", ".....",
        ],
        '²' => [
            ".##..", "...#.", "..#..", ".###.", ".....", ".....", ".....",
        ],
        _ => [
            ".....", ".....", ".....", ".....", ".....", ".....", ".....",
        ],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pt(x: f64, y: f64, z: f64, class: u8) -> RenderPoint {
        RenderPoint {
            x,
            y,
            z,
            intensity: 100,
            classification: class,
            return_number: 1,
            number_of_returns: 1,
            source: 1,
        }
    }

    /// Position of a colour on the ramp (nearest of 1001 samples).
    fn ramp_position(c: [u8; 3]) -> f64 {
        (0..=1000)
            .map(|i| i as f64 / 1000.0)
            .min_by_key(|v| {
                let r = ramp(*v);
                (0..3)
                    .map(|k| (i32::from(r[k]) - i32::from(c[k])).pow(2))
                    .sum::<i32>()
            })
            .unwrap()
    }

    #[test]
    fn a_height_ramp_gives_a_monotonic_colour_ramp() {
        // A plane rising eastwards, 1 point per 0.5 m.
        let pts: Vec<RenderPoint> = (0..200)
            .flat_map(|i| {
                (0..40).map(move |j| pt(i as f64 * 0.5, j as f64 * 0.5, i as f64 * 0.1, 2))
            })
            .collect();
        let img = top_view(&pts, ColorBy::Height, Some(0.5)).unwrap();
        let row = 10;
        let pos: Vec<f64> = (0..200).map(|x| ramp_position(img.get(x, row))).collect();
        assert!(pos.windows(2).all(|w| w[1] >= w[0]), "not monotonic");
        assert!(pos[0] < 0.05 && pos[199] > 0.95);
    }

    #[test]
    fn two_classes_give_two_legend_colours_in_place() {
        // West half ground, east half building.
        let pts: Vec<RenderPoint> = (0..100)
            .flat_map(|i| {
                (0..50).map(move |j| {
                    let x = i as f64;
                    pt(x, j as f64, 0.0, if x < 50.0 { 2 } else { 6 })
                })
            })
            .collect();
        let img = top_view(&pts, ColorBy::Class, Some(1.0)).unwrap();
        let (ground, building) = (class_color(2).0, class_color(6).0);
        let mut seen = std::collections::BTreeSet::new();
        for y in 0..50 {
            for x in 0..100 {
                let c = img.get(x, y);
                seen.insert(c);
                assert_eq!(c, if x < 50 { ground } else { building }, "({x}, {y})");
            }
        }
        assert_eq!(seen.len(), 2);
        // The legend shows exactly those two swatches, in class order.
        assert_eq!(img.get(100 + 10 + 5, 6 + 5), ground);
        assert_eq!(img.get(100 + 10 + 5, 22 + 5), building);
    }

    #[test]
    fn waveform_plot_places_signal_threshold_and_echoes() {
        // A Gaussian echo of peak 0.8 at 500 m over a 10 m window.
        let ranges: Vec<f64> = (0..134).map(|i| 495.0 + i as f64 * 0.075).collect();
        let signal: Vec<f64> = ranges
            .iter()
            .map(|r| 0.8 * (-0.5 * ((r - 500.0) / 0.25f64).powi(2)).exp())
            .collect();
        let plot = WaveformPlot {
            threshold: vec![0.1; ranges.len()],
            returns: vec![0.0; ranges.len()],
            echoes: vec![(500.0, 0.8)],
            ranges_m: ranges,
            signal,
        };
        let img = plot.render();
        let (x, y) = plot.to_px(500.0, 0.8);
        assert_eq!(
            img.get(x as usize, y as usize),
            [215, 40, 40],
            "echo marker"
        );
        // The signal is drawn in blue through its peak column's top, and the
        // dashed threshold at its row near the left end.
        let (xl, yt) = plot.to_px(495.0, 0.1);
        assert_eq!(img.get(xl as usize + 1, yt as usize), [230, 120, 0]);
        let blue = (0..img.height)
            .filter(|&r| img.get(x as usize + 5, r) == [31, 90, 200])
            .count();
        assert!(blue > 0);
    }

    #[test]
    fn a_gabled_roof_profile_puts_the_roof_line_at_its_rows() {
        // Roof across x: eaves at x = ±10 (z = 6), ridge at x = 0 (z = 12).
        let pts: Vec<RenderPoint> = (-100..=100)
            .flat_map(|i| {
                let x = i as f64 * 0.1;
                (0..5).map(move |j| pt(x, j as f64 * 0.2, 12.0 - 0.6 * x.abs(), 6))
            })
            .collect();
        let res = 0.1;
        let img = profile(
            &pts,
            (-10.0, 0.4),
            (10.0, 0.4),
            2.0,
            ColorBy::Class,
            Some(res),
        )
        .unwrap();
        let ink = |x: usize| (0..img.height - FOOTER_HEIGHT).find(|&y| img.get(x, y) != EMPTY);
        for (x_m, z) in [(0.0, 12.0), (-5.0, 9.0), (5.0, 9.0), (-9.9, 6.06)] {
            let col = PROFILE_AXIS_PX + ((x_m + 10.0) / res) as usize;
            let want = profile_row(z, 6.0, 12.0, res);
            let got = ink(col).unwrap();
            assert!(got.abs_diff(want) <= 1, "x {x_m}: row {got} vs {want}");
        }
    }

    /// Points on a regular grid over `w_m × h_m` from the origin, every
    /// `step` m, at height 0.
    fn grid(w_m: f64, h_m: f64, step: f64) -> Vec<RenderPoint> {
        let (nx, ny) = ((w_m / step) as usize, (h_m / step) as usize);
        (0..=nx)
            .flat_map(|i| (0..=ny).map(move |j| pt(i as f64 * step, j as f64 * step, 0.0, 2)))
            .collect()
    }

    /// Map size at a pixel size, by the rule the module documents: one
    /// pixel per started `res` plus one.
    fn map_px(len_m: f64, res: f64) -> f64 {
        (len_m / res).floor() + 1.0
    }

    #[test]
    fn a_resolution_too_fine_is_refused_with_the_smallest_that_fits() {
        // 1000 m × 500 m: the pixel limit binds first, at
        // √(1000 · 500 / 16 000 000) = 0.1768 m (the side limit needs only
        // 1000 / 8191 = 0.122 m).
        let pts = grid(1000.0, 500.0, 25.0);
        for res in [1e-9, 1e-4, 0.1] {
            let e = top_view(&pts, ColorBy::Height, Some(res)).unwrap_err();
            assert_eq!(e.resolution_m, res);
            let s = e.smallest_resolution_m.unwrap();
            assert!(
                (0.1767..0.1790).contains(&s),
                "{s}: three significant digits, rounded up"
            );
            assert!(map_px(1000.0, s) * map_px(500.0, s) <= MAX_MAP_PIXELS as f64);
            let text = e.to_string();
            for words in [
                "8192 px a side",
                "16000000 pixels",
                &format!("fits is {s} m"),
            ] {
                assert!(text.contains(words), "{words}: {text}");
            }
            // The resolution offered works.
            let img = top_view(&pts, ColorBy::Height, Some(s)).unwrap();
            assert_eq!(img.width - LEGEND_WIDTH, map_px(1000.0, s) as usize);
        }
        // A long thin strip: the side limit binds, 20 000 / 8191 = 2.4417 m.
        let strip: Vec<RenderPoint> = (0..=200)
            .map(|i| pt(i as f64 * 100.0, 0.0, 0.0, 2))
            .collect();
        let e = top_view(&strip, ColorBy::Class, Some(0.5)).unwrap_err();
        let s = e.smallest_resolution_m.unwrap();
        assert!((2.4417..2.46).contains(&s), "{s}");
        assert!(map_px(20_000.0, s) <= MAX_SIDE_PX as f64);
        // A cross-section 10 000 km long at 1 cm per pixel.
        let e = profile(
            &pts,
            (0.0, 0.0),
            (1e7, 0.0),
            5.0,
            ColorBy::Class,
            Some(0.01),
        );
        let s = e.unwrap_err().smallest_resolution_m.unwrap();
        assert!((1e7 / 8191.0..1e7 / 8191.0 * 1.01).contains(&s), "{s}");
    }

    #[test]
    fn an_automatic_resolution_is_coarsened_to_fit() {
        // A 10 m section whose heights span 1000 km (an outlier): at the
        // automatic 5 cm the picture would be 20 million px tall.
        let mut pts = grid(10.0, 1.0, 0.5);
        pts.push(pt(5.0, 0.5, 1e6, 7));
        let img = profile(&pts, (0.0, 0.5), (10.0, 0.5), 2.0, ColorBy::Class, None).unwrap();
        assert!(img.height <= MAX_SIDE_PX + FOOTER_HEIGHT, "{}", img.height);
        // A top view 4000 km across.
        let far = [pt(0.0, 0.0, 0.0, 2), pt(4e6, 3e6, 10.0, 2)];
        let img = top_view(&far, ColorBy::Height, None).unwrap();
        assert!(img.width - LEGEND_WIDTH <= 1601 && img.height <= 1601 + FOOTER_HEIGHT);
    }

    #[test]
    fn one_pixel_gaps_between_scan_lines_are_filled_and_real_gaps_left_as_no_data() {
        // Rows of points along x every 0.1 m, the rows 1.5 m apart: at
        // 1 m pixels every third row of pixels holds no point. Between
        // x = 20 m and 25 m there are no points at all.
        let pts: Vec<RenderPoint> = (0..=20)
            .flat_map(|k| {
                (0..=500).filter_map(move |i| {
                    let x = i as f64 * 0.1;
                    (!(20.0..25.0).contains(&x)).then(|| pt(x, k as f64 * 1.5, 0.0, 2))
                })
            })
            .collect();
        let img = top_view(&pts, ColorBy::Class, Some(1.0)).unwrap();
        let (w, h) = (img.width - LEGEND_WIDTH, map_px(30.0, 1.0) as usize);
        assert_eq!(w, 51);
        let ground = class_color(2).0;
        let is_no_data = |x: usize, y: usize| NO_DATA.contains(&img.get(x, y));
        for y in 0..h {
            for x in 0..w {
                let xm = x as f64 + 0.5;
                if (21.0..24.0).contains(&xm) {
                    // Inside the 5 m gap, more than a pixel from its edges.
                    assert!(is_no_data(x, y), "({x}, {y}) should be empty");
                } else if !(20.0..25.0).contains(&xm) {
                    assert_eq!(img.get(x, y), ground, "({x}, {y})");
                }
            }
        }
        // The legend explains the hatching.
        assert!(is_no_data(w + 10 + 6, 6 + 16 + 5) || is_no_data(w + 10 + 5, 6 + 16 + 5));
    }

    #[test]
    fn labels_are_never_negative_zero() {
        assert_eq!(fixed(-0.04, 1), "0.0");
        assert_eq!(fixed(-0.0, 1), "0.0");
        assert_eq!(fixed(-0.004, 2), "0.00");
        assert_eq!(fixed(-0.06, 1), "-0.1");
        assert_eq!(fixed(-0.4, 0), "0");
        assert_eq!(fixed(12.25, 1), "12.2");
        let p = Palette::bar(ColorBy::Height, (-0.04, 20.9));
        assert_eq!(p.end_labels(), ("0.0 M".to_string(), "20.9 M".to_string()));
        let p = Palette::bar(ColorBy::Height, (-0.0004, 0.08));
        assert_eq!(
            p.end_labels(),
            ("0.000 M".to_string(), "0.080 M".to_string())
        );
    }

    #[test]
    fn the_robust_range_ignores_stray_points_but_keeps_a_feature() {
        // 10 000 values spread evenly over 0–1 m and 5 stray ones at 300 m.
        let mut v: Vec<f64> = (0..10_000).map(|i| i as f64 / 9_999.0).collect();
        v.extend([300.0; 5]);
        let p = Palette::robust(ColorBy::Height, v.iter().copied());
        let (lo, hi) = p.range();
        assert!(lo < 0.002 && (0.99..=1.0).contains(&hi), "{lo} {hi}");
        assert_eq!(p.clipped, (false, true));
        // A roof at 10 m over 1 % of the values keeps its colour.
        let mut v: Vec<f64> = (0..9_900).map(|i| i as f64 / 9_899.0).collect();
        v.extend([10.0; 100]);
        assert_eq!(
            Palette::robust(ColorBy::Height, v.into_iter()).range().1,
            10.0
        );
    }

    #[test]
    fn an_exaggerated_profile_fills_its_height() {
        // The gabled roof again, eaves at 6 m and ridge at 12 m: with 1 m
        // margins the picture spans 5–13 m over 300 rows.
        let pts: Vec<RenderPoint> = (-100..=100)
            .map(|i| {
                let x = i as f64 * 0.1;
                pt(x, 0.0, 12.0 - 0.6 * x.abs(), 6)
            })
            .collect();
        let img = profile_exaggerated(
            &pts,
            (-10.0, 0.0),
            (10.0, 0.0),
            2.0,
            ColorBy::Class,
            0.1,
            300,
        );
        let ink = |x: usize| (0..300).find(|&y| img.get(x, y) != EMPTY);
        let row = |z: f64| (13.0 - z) / 8.0 * 300.0;
        for (x_m, z) in [(0.0, 12.0), (-10.0, 6.0), (5.0, 9.0)] {
            let col = PROFILE_AXIS_PX + ((x_m + 10.0) / 0.1) as usize;
            let got = ink(col.min(PROFILE_AXIS_PX + 200)).unwrap() as f64;
            // Within 3 rows (1 %): a column may also hold the next point.
            assert!(
                (got - row(z)).abs() <= 3.0,
                "z {z}: row {got} vs {}",
                row(z)
            );
        }
        // Rows 300 and below are the footer.
        assert!((300..img.height).all(|y| img.get(PROFILE_AXIS_PX + 100, y) != EMPTY));
    }

    #[test]
    fn time_panels_draw_each_run_where_its_values_are() {
        // A straight rise from (0 s, 0) to (10 s, 1) and, after a gap, a
        // flat run at 0.5 from 20 s to 30 s.
        let rise: Vec<(f64, f64)> = (0..=100)
            .map(|i| (i as f64 * 0.1, i as f64 * 0.01))
            .collect();
        let flat: Vec<(f64, f64)> = (0..=10).map(|i| (20.0 + i as f64, 0.5)).collect();
        let c = [200, 0, 0];
        let img = time_panels(&[Series {
            title: "TEST".into(),
            color: c,
            runs: vec![rise, flat],
        }]);
        let column = |t: f64| SERIES_LEFT + (t / 30.0 * (SERIES_WIDTH - 1) as f64).round() as usize;
        let rows = |x: usize| {
            (0..img.height)
                .filter(|&y| img.get(x, y) == c)
                .collect::<Vec<_>>()
        };
        // Rising: the curve's row falls (the picture's y grows downward).
        let r: Vec<usize> = [1.0, 4.0, 7.0, 9.5]
            .iter()
            .map(|&t| rows(column(t))[0])
            .collect();
        assert!(r.windows(2).all(|w| w[1] < w[0]), "{r:?}");
        // Nothing between the runs; the flat run halfway between the ends.
        assert!(rows(column(15.0)).is_empty());
        let mid = rows(column(25.0))[0] as f64;
        let (top, bottom) = (rows(column(10.0))[0] as f64, rows(column(0.0))[0] as f64);
        assert!(
            (mid - 0.5 * (top + bottom)).abs() <= 1.0,
            "{mid} {top} {bottom}"
        );
    }
}

//! Colours: what they show ([`ColorBy`]), the colour scales (a ramp for
//! heights and intensities over a robust range, class, return and flight
//! line colours) and the [`Palette`] that colours points and draws the
//! legend or colour bar explaining them.

use super::Image;
use super::figure::{Anchor, Figure, LABEL_PX, TITLE_PX};
use super::frame::no_data;
use super::image::INK;
use super::labels::fixed;
use super::point::RenderPoint;

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
    /// GPS time, on a colour bar from the first point to the last: the
    /// order in which the scanner drew its pattern.
    Time,
}

impl ColorBy {
    /// Parses `height`, `intensity`, `class`, `return`, `strip` or `time`.
    pub fn from_name(s: &str) -> Option<Self> {
        match s {
            "height" | "z" => Some(ColorBy::Height),
            "intensity" => Some(ColorBy::Intensity),
            "class" | "classification" => Some(ColorBy::Class),
            "return" | "returns" => Some(ColorBy::Return),
            "strip" | "line" | "source" => Some(ColorBy::Strip),
            "time" | "gps_time" => Some(ColorBy::Time),
            _ => None,
        }
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
fn robust_range(mut v: Vec<f64>) -> (f64, f64) {
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
const ROBUST_NOTE: &str = "0.1–99.9 % range";

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
    pub(super) fn new<'a>(
        points: impl Iterator<Item = &'a RenderPoint> + Clone,
        by: ColorBy,
    ) -> Self {
        match by {
            ColorBy::Height => Self::robust(by, points.map(|p| p.z)),
            ColorBy::Intensity => Self::robust(by, points.map(|p| f64::from(p.intensity))),
            ColorBy::Time => {
                let (lo, hi) = points.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                    (lo.min(p.gps_time_s), hi.max(p.gps_time_s))
                });
                if lo.is_finite() && hi > lo {
                    Self::bar(by, (lo, hi))
                } else {
                    Self::bar(by, (lo.min(0.0), lo.max(0.0) + 1.0))
                }
            }
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

    pub(super) fn color(&self, p: &RenderPoint) -> [u8; 3] {
        let scale = |v: f64| (v - self.range.0) / (self.range.1 - self.range.0);
        match self.by {
            ColorBy::Height => ramp(scale(p.z)),
            ColorBy::Intensity => ramp(scale(f64::from(p.intensity))),
            ColorBy::Time => ramp(scale(p.gps_time_s)),
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
        let unit = if self.by == ColorBy::Height { " m" } else { "" };
        (
            format!("{}{unit}", fixed(self.range.0, decimals)),
            format!("{}{unit}", fixed(self.range.1, decimals)),
        )
    }

    /// Draws the legend or colour bar in the panel starting at `x0`,
    /// between rows `top` and `bottom`.
    pub(super) fn draw(&self, fig: &mut Figure, x0: usize, top: usize, bottom: usize) {
        let below = match self.by {
            ColorBy::Height | ColorBy::Intensity | ColorBy::Time => {
                self.draw_bar(fig, x0, top, bottom)
            }
            _ => {
                for (k, (c, name)) in self.entries.iter().enumerate() {
                    let y = (top + 6 + 16 * k) as f64;
                    fig.rect(x0 as f64, y, 12.0, 10.0, *c);
                    fig.text(
                        x0 as f64 + 18.0,
                        y - 2.0,
                        name,
                        LABEL_PX,
                        Anchor::Start,
                        INK,
                    );
                }
                top + 6 + 16 * self.entries.len()
            }
        };
        if self.no_data {
            // The hatching as the map has it at the swatch's place.
            let mut swatch = Image::new(12, 10, INK);
            for j in 0..10 {
                for i in 0..12 {
                    swatch.set(i, j, no_data(x0 + i, below + j));
                }
            }
            fig.raster(x0, below, swatch);
            let y = below as f64 - 2.0;
            fig.text(x0 as f64 + 18.0, y, "no data", LABEL_PX, Anchor::Start, INK);
        }
    }

    /// Draws a colour bar with its title, end labels, the arrows of values
    /// beyond its ends and its note; returns the row below it.
    fn draw_bar(&self, fig: &mut Figure, x0: usize, top: usize, bottom: usize) -> usize {
        let title = self.title.unwrap_or(match self.by {
            ColorBy::Height => "height",
            ColorBy::Time => "GPS time, s",
            _ => "intensity",
        });
        let x = x0 as f64;
        fig.text(x, top as f64 + 2.0, title, TITLE_PX, Anchor::Start, INK);
        let (y0, y1) = (top + 24, bottom.saturating_sub(44).max(top + 64));
        let mut bar = Image::new(24, y1 - y0, INK);
        for y in 0..y1 - y0 {
            let v = 1.0 - y as f64 / (y1 - y0 - 1).max(1) as f64;
            bar.fill(0, y, 24, 1, ramp(v));
        }
        fig.raster(x0, y0, bar);
        // Arrows beyond the ends where values were clamped.
        for r in 0..6 {
            let half = 12 * r / 6;
            let (left, width) = ((x0 + 12 - half) as f64, (2 * half.max(1)) as f64);
            if self.clipped.1 {
                fig.rect(left, (y0 - 7 + r) as f64, width, 1.0, ramp(1.0));
            }
            if self.clipped.0 {
                fig.rect(left, (y1 + 6 - r) as f64, width, 1.0, ramp(0.0));
            }
        }
        let (lo, hi) = self.end_labels();
        fig.text(x + 30.0, y0 as f64 - 2.0, &hi, LABEL_PX, Anchor::Start, INK);
        fig.text(
            x + 30.0,
            y1 as f64 - 12.0,
            &lo,
            LABEL_PX,
            Anchor::Start,
            INK,
        );
        if let Some(note) = self.note {
            fig.text(x, y1 as f64 + 9.0, note, LABEL_PX, Anchor::Start, INK);
        }
        y1 + 26
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Coloured by time, the first point takes the ramp's first colour and
    /// the last its last, whatever their heights.
    #[test]
    fn time_colours_run_from_the_first_point_to_the_last() {
        let mut a = crate::render::testing::pt(0.0, 0.0, 9.0, 2);
        let mut b = crate::render::testing::pt(1.0, 0.0, 1.0, 2);
        (a.gps_time_s, b.gps_time_s) = (100.0, 100.5);
        let p = Palette::new([a, b].iter(), ColorBy::Time);
        assert_eq!(p.range(), (100.0, 100.5));
        assert_eq!(p.color(&a), ramp(0.0));
        assert_eq!(p.color(&b), ramp(1.0));
        assert_eq!(ColorBy::from_name("time"), Some(ColorBy::Time));
    }

    #[test]
    fn bar_labels_are_never_negative_zero() {
        let p = Palette::bar(ColorBy::Height, (-0.04, 20.9));
        assert_eq!(p.end_labels(), ("0.0 m".to_string(), "20.9 m".to_string()));
        let p = Palette::bar(ColorBy::Height, (-0.0004, 0.08));
        assert_eq!(
            p.end_labels(),
            ("0.000 m".to_string(), "0.080 m".to_string())
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
}

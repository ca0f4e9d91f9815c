//! Quantities against time: stacked panels sharing one time axis, each
//! with its own vertical range.

use super::figure::{Anchor, Figure, LABEL_PX, TITLE_PX};
use super::image::{BACKGROUND, INK};
use super::labels::{fixed, nice_ticks};

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
/// vertical range (the data's, with a margin) and round ticks (steps of 1,
/// 2 or 5); the time axis is labelled under the last panel.
pub fn time_panels(series: &[Series]) -> Figure {
    let n = series.len().max(1);
    let mut fig = Figure::new(
        SERIES_LEFT + SERIES_WIDTH + 30,
        n * (SERIES_HEIGHT + SERIES_GAP) + 44,
        BACKGROUND,
    );
    let all = || series.iter().flat_map(|s| s.runs.iter().flatten());
    let (t0, t1) = all().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
        (a.min(p.0), b.max(p.0))
    });
    if !(t0.is_finite() && t1.is_finite()) {
        fig.text(10.0, 10.0, "no data", TITLE_PX, Anchor::Start, INK);
        return fig;
    }
    let t1 = if t1 > t0 { t1 } else { t0 + 1.0 };
    let x_of =
        |t: f64| SERIES_LEFT as f64 + ((t - t0) / (t1 - t0) * (SERIES_WIDTH - 1) as f64).round();
    let (t_ticks, t_dec) = nice_ticks(t0, t1, 10);
    for (k, s) in series.iter().enumerate() {
        let top = (k * (SERIES_HEIGHT + SERIES_GAP) + SERIES_GAP) as f64;
        let bottom = top + (SERIES_HEIGHT - 1) as f64;
        fig.text(
            SERIES_LEFT as f64,
            top - 18.0,
            &s.title,
            TITLE_PX,
            Anchor::Start,
            INK,
        );
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
        let y_of = |v: f64| bottom - ((v - lo) / (hi - lo) * (SERIES_HEIGHT - 1) as f64).round();
        // Axes, a light line at zero, ticks.
        let (x0, x1) = (SERIES_LEFT as f64, (SERIES_LEFT + SERIES_WIDTH - 1) as f64);
        if lo < 0.0 && hi > 0.0 {
            fig.line(vec![(x0, y_of(0.0)), (x1, y_of(0.0))], [200, 200, 200]);
        }
        fig.line(vec![(x0, top), (x0, bottom), (x1, bottom)], INK);
        let (ticks, dec) = nice_ticks(lo, hi, 4);
        for v in ticks {
            let y = y_of(v);
            fig.line(vec![(x0 - 4.0, y), (x0 - 1.0, y)], INK);
            fig.text(
                x0 - 7.0,
                y - 0.6 * LABEL_PX,
                &fixed(v, dec),
                LABEL_PX,
                Anchor::End,
                INK,
            );
        }
        for &t in &t_ticks {
            let x = x_of(t);
            fig.line(vec![(x, bottom), (x, bottom + 3.0)], INK);
        }
        for run in &s.runs {
            fig.line(
                run.iter().map(|&(t, v)| (x_of(t), y_of(v))).collect(),
                s.color,
            );
        }
    }
    let bottom = (n * (SERIES_HEIGHT + SERIES_GAP) - 1) as f64;
    for &t in &t_ticks {
        fig.text(
            x_of(t),
            bottom + 5.0,
            &fixed(t, t_dec),
            LABEL_PX,
            Anchor::Middle,
            INK,
        );
    }
    fig.text(
        (SERIES_LEFT + SERIES_WIDTH / 2) as f64,
        bottom + 22.0,
        "time since the survey's start, s",
        TITLE_PX,
        Anchor::Middle,
        INK,
    );
    fig
}

#[cfg(test)]
mod tests {
    use super::*;

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
            title: "test".into(),
            color: c,
            runs: vec![rise, flat],
        }])
        .to_image();
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

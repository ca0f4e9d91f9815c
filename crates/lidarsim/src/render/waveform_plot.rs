//! The plot of one pulse's waveform (specification Figs. 6 and 7): the
//! sub-ray returns, the received signal, the detection threshold and the
//! echoes, against range.

use super::figure::{Anchor, Figure, LABEL_PX, TITLE_PX};
use super::image::{BACKGROUND, INK};
use super::labels::{fixed, nice_ticks};
use crate::detection::Echo;
use crate::waveform::{Waveform, bin_to_range};

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
const PLOT_LEFT: usize = 80;
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
        let (x, y) = self.at(range_m, value);
        (x.round() as i64, y.round() as i64)
    }

    /// [`Self::to_px`] before rounding.
    fn at(&self, range_m: f64, value: f64) -> (f64, f64) {
        let (r0, r1) = (self.ranges_m[0], self.ranges_m[self.ranges_m.len() - 1]);
        let x = PLOT_LEFT as f64 + (range_m - r0) / (r1 - r0).max(1e-9) * (PLOT_WIDTH - 1) as f64;
        let y = PLOT_TOP as f64 + (1.0 - value / self.y_max()) * (PLOT_HEIGHT - 1) as f64;
        (x, y)
    }

    /// The picture (specification Figs. 6 and 7): grey stems for the
    /// sub-ray returns, the received signal in blue, the threshold dashed
    /// in orange, echoes as red markers with their number; both axes with
    /// round ticks (steps of 1, 2 or 5) and their quantity and unit.
    pub fn render(&self) -> Figure {
        let mut fig = Figure::new(
            PLOT_LEFT + PLOT_WIDTH + 170,
            PLOT_TOP + PLOT_HEIGHT + 48,
            BACKGROUND,
        );
        if self.ranges_m.len() < 2 {
            fig.text(10.0, 10.0, "no signal", TITLE_PX, Anchor::Start, INK);
            return fig;
        }
        let px = |r: f64, v: f64| {
            let (x, y) = self.to_px(r, v);
            (x as f64, y as f64)
        };
        // Axes.
        let (x0, y0) = (PLOT_LEFT as f64, (PLOT_TOP + PLOT_HEIGHT) as f64);
        let x1 = x0 + PLOT_WIDTH as f64;
        fig.line(vec![(x0, PLOT_TOP as f64), (x0, y0), (x1, y0)], INK);
        let (r0, r1) = (self.ranges_m[0], self.ranges_m[self.ranges_m.len() - 1]);
        let (ticks, decimals) = nice_ticks(r0, r1, 8);
        for r in ticks {
            let (x, _) = px(r, 0.0);
            fig.line(vec![(x, y0), (x, y0 + 4.0)], INK);
            fig.text(
                x,
                y0 + 7.0,
                &fixed(r, decimals),
                LABEL_PX,
                Anchor::Middle,
                INK,
            );
        }
        let (ticks, decimals) = nice_ticks(0.0, self.y_max(), 5);
        for v in ticks {
            let (_, y) = px(r0, v);
            fig.line(vec![(x0 - 4.0, y), (x0, y)], INK);
            fig.text(
                x0 - 7.0,
                y - 0.6 * LABEL_PX,
                &fixed(v, decimals),
                LABEL_PX,
                Anchor::End,
                INK,
            );
        }
        fig.text(
            x0 + PLOT_WIDTH as f64 / 2.0,
            y0 + 26.0,
            "range, m",
            TITLE_PX,
            Anchor::Middle,
            INK,
        );
        fig.vertical_text(
            4.0,
            PLOT_TOP as f64 + PLOT_HEIGHT as f64 / 2.0,
            "amplitude (received power, Eq. 2)",
            TITLE_PX,
            INK,
        );
        // Sub-ray returns as stems.
        for (r, v) in self.ranges_m.iter().zip(&self.returns) {
            if *v > 0.0 {
                fig.line(vec![px(*r, 0.0), px(*r, *v)], [150, 150, 150]);
            }
        }
        // Threshold, dashed; the signal.
        let curve = |values: &[f64]| {
            self.ranges_m
                .iter()
                .zip(values)
                .map(|(r, v)| px(*r, v.max(0.0)))
                .collect::<Vec<_>>()
        };
        fig.dashed(curve(&self.threshold), [230, 120, 0]);
        fig.line(curve(&self.signal), [31, 90, 200]);
        // Echoes.
        for (k, (r, v)) in self.echoes.iter().enumerate() {
            let (x, y) = px(*r, *v);
            fig.rect(x - 3.0, y - 3.0, 7.0, 7.0, [215, 40, 40]);
            fig.text(
                x + 6.0,
                y - 16.0,
                &format!("{}", k + 1),
                LABEL_PX,
                Anchor::Start,
                [215, 40, 40],
            );
        }
        // Legend.
        let lx = (PLOT_LEFT + PLOT_WIDTH + 15) as f64;
        for (k, (c, name)) in [
            ([150, 150, 150], "sub-ray returns"),
            ([31, 90, 200], "signal"),
            ([230, 120, 0], "threshold"),
            ([215, 40, 40], "echoes"),
        ]
        .iter()
        .enumerate()
        {
            let y = (PLOT_TOP + 18 * k) as f64;
            fig.rect(lx, y, 12.0, 10.0, *c);
            fig.text(lx + 18.0, y - 2.0, name, LABEL_PX, Anchor::Start, INK);
        }
        fig
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let img = plot.render().to_image();
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
}

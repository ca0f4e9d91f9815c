//! Echo detection in a sampled waveform.
//!
//! A real receiver "has to have certain minimum power received, before it
//! can be considered true" (specification, "Pulse – Target interaction").
//! We report maxima of the waveform that rise above a noise-based threshold
//! over the atmospheric background and stand out from their neighbours by
//! at least the same margin (topographic prominence), first in time first,
//! up to a maximum number of returns. Maxima narrower than half the emitted
//! pulse are noise spikes and are ignored. Each echo gets:
//!
//! * its range, refined to a fraction of a bin by fitting a Gaussian to
//!   the samples within half a pulse width of the maximum (Wagner et al.
//!   2006, ISPRS J. 60(2), decompose waveforms into Gaussians for the same
//!   purpose), corrected by the fit's bias on the emitted pulse itself so
//!   that asymmetric pulses range correctly;
//! * its peak amplitude;
//! * its width, the full width at half maximum in ns: that of the emitted
//!   pulse times the echo's energy amplitude over its fitted peak (both
//!   relative to the unit pulse). For an echo from a single surface at
//!   right angles this is the pulse's FWHM; an echo stretched in time or
//!   merged from several surfaces is as much wider as its energy is spread
//!   (the FWHM of the pulse-shaped echo of the same energy and peak), never
//!   narrower than the pulse without noise. Energy and fitted peak average
//!   many samples, whereas the first crossings of half the highest noisy
//!   sample lie too close to it on weak echoes;
//! * its *energy amplitude*: the echo's energy (sum of samples within two
//!   widths of the peak) divided by the energy of the emitted pulse of unit
//!   peak measured the same way. For an echo from a single surface at right
//!   angles this equals the peak amplitude; for an echo stretched in time
//!   (an oblique surface spreads the footprint over a range interval) it is
//!   the peak the same energy would have had unstretched. It is therefore
//!   exactly the Eq. 2 power summed over the footprint, and it is what the
//!   LAS intensity records.

mod fit;

use crate::kernels::{Side, for_each_maximum, lowest_before_higher};
use crate::waveform::{Receiver, Waveform, bin_to_range};
use fit::{energy, half_max_width, refine, width_at};

/// Which echoes a receiver keeps when a pulse has more than it records.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ReturnSelection {
    /// The first `max_returns − 1` and the last: the last echo is most
    /// often the ground, which a terrain model needs (the default).
    #[default]
    FirstAndLast,
    /// The first `max_returns` in time.
    First,
}

impl ReturnSelection {
    /// The rule named `name` in a survey file.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "first-and-last" => Some(Self::FirstAndLast),
            "first" => Some(Self::First),
            _ => None,
        }
    }

    /// Its name in a survey file.
    pub fn name(self) -> &'static str {
        match self {
            Self::FirstAndLast => "first-and-last",
            Self::First => "first",
        }
    }
}

/// How a receiver turns its waveform into returns.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum EchoDetection {
    /// A discrete-return receiver (the default): an echo triggers when the
    /// signal rises above the threshold, after which the receiver is blind
    /// for the minimum separation and re-arms only once the signal has
    /// fallen below the threshold again; what it does not re-arm for
    /// belongs to the echo before.
    #[default]
    Discrete,
    /// Online waveform processing: every maximum that stands out is an
    /// echo, apart from the minimum separation.
    Waveform,
}

impl EchoDetection {
    /// The mode named `name` in a survey file.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "discrete" => Some(Self::Discrete),
            "waveform" => Some(Self::Waveform),
            _ => None,
        }
    }

    /// Its name in a survey file.
    pub fn name(self) -> &'static str {
        match self {
            Self::Discrete => "discrete",
            Self::Waveform => "waveform",
        }
    }
}

/// Detection settings.
#[derive(Clone, Debug, PartialEq)]
pub struct DetectorConfig {
    /// Threshold as a multiple of the receiver noise σ.
    pub threshold_sigma: f64,
    /// Lowest echo amplitude accepted even without noise, amplitude units.
    pub min_amplitude: f64,
    /// Largest number of echoes reported per pulse.
    pub max_returns: usize,
    /// Which echoes are kept when there are more.
    pub selection: ReturnSelection,
    /// How echoes become returns.
    pub detection: EchoDetection,
    /// Least range between two returns of a pulse (the receiver's dead
    /// zone after an echo, its multi-target resolution), m.
    pub min_separation_m: f64,
}

/// One detected echo.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Echo {
    /// Fractional absolute bin of the echo's maximum (two-way time / bin).
    pub bin: f64,
    /// Range, m.
    pub range_m: f64,
    /// Fitted peak above the background, amplitude units.
    pub peak_amplitude: f64,
    /// The amplitude the receiver records: the energy amplitude (see the
    /// module documentation) with waveform processing, the fitted peak
    /// with a discrete-return receiver, whose intensity is the peak of the
    /// pulse it triggered on (Wagner 2010, ISPRS J. 65(6): 505–513).
    pub amplitude: f64,
    /// Full width at half maximum, ns: the emitted pulse's FWHM times the
    /// energy amplitude over the peak amplitude (see the module
    /// documentation).
    pub width_ns: f64,
    /// First absolute bin attributed to this echo.
    pub first_bin: i64,
    /// Last absolute bin attributed to this echo.
    pub last_bin: i64,
}

/// Finds echoes in waveforms of one receiver.
#[derive(Clone, Debug)]
pub struct Detector {
    config: DetectorConfig,
    threshold: f64,
    bin_s: f64,
    /// Error of the fitted peak position for the emitted pulse itself, as a
    /// function of the fractional part of the fitted position: pairs
    /// `(fraction, error)` sorted by fraction, in bins.
    bias: Vec<(f64, f64)>,
    /// Energy of the unit-peak pulse measured by the echo-energy rule.
    unit_energy: f64,
    /// Narrowest maximum accepted as an echo, bins.
    min_width_bins: f64,
    /// Half-width of the Gaussian fit window, bins (half the pulse FWHM).
    fit_half: usize,
    /// FWHM of the emitted pulse, ns.
    pulse_fwhm_ns: f64,
    /// The minimum separation of returns, bins.
    dead_bins: f64,
}

impl Detector {
    /// A detector matched to `receiver` (its noise level, bin width and
    /// pulse shape).
    pub fn new(config: DetectorConfig, receiver: &Receiver) -> Self {
        let rx = receiver.config();
        let threshold = config
            .min_amplitude
            .max(config.threshold_sigma * rx.noise_sigma);
        let (kernel, k0) = receiver.kernel();
        let width = half_max_width(kernel, k0, 0, kernel.len() - 1);
        let fit_half = ((0.5 * width).round() as usize).max(1);
        let bias = bias_table(receiver, fit_half);
        let unit_energy = energy(kernel, k0, width, 0, kernel.len() - 1);
        Self {
            threshold,
            bin_s: rx.bin_s,
            bias,
            unit_energy,
            min_width_bins: 0.5 * width,
            fit_half,
            pulse_fwhm_ns: rx.pulse.fwhm_s() * 1e9,
            dead_bins: crate::waveform::range_to_bin(config.min_separation_m, rx.bin_s),
            config,
        }
    }

    /// Fit error for a fitted position (periodic in the bin, interpolated).
    fn bias_at(&self, fitted: f64) -> f64 {
        let f = fitted - fitted.floor();
        let t = &self.bias;
        let i = t.partition_point(|(x, _)| *x < f);
        let (a, b) = if i == 0 {
            let (x, e) = t[t.len() - 1];
            ((x - 1.0, e), t[0])
        } else if i == t.len() {
            let (x, e) = t[0];
            (t[i - 1], (x + 1.0, e))
        } else {
            (t[i - 1], t[i])
        };
        if b.0 - a.0 <= 0.0 {
            return a.1;
        }
        a.1 + (b.1 - a.1) * (f - a.0) / (b.0 - a.0)
    }

    /// Amplitude an echo must exceed above the background.
    pub fn threshold(&self) -> f64 {
        self.threshold
    }

    /// Detects the echoes of `wf` into `out` (cleared first), in time order.
    pub fn detect(&self, wf: &Waveform, scratch: &mut DetectScratch, out: &mut Vec<Echo>) {
        out.clear();
        let DetectScratch {
            signal,
            peaks,
            valleys,
            widths,
            bounds,
        } = scratch;
        signal.clear();
        // Without atmosphere the background is zero and the samples are the
        // signal.
        let s = if wf.background.is_empty() {
            &wf.samples[..]
        } else {
            signal.extend(wf.samples.iter().zip(&wf.background).map(|(s, b)| s - b));
            &signal[..]
        };
        if s.len() < 3 {
            peaks.clear();
            return;
        }
        self.select(s, peaks, valleys, widths, bounds);
        for (k, &p) in peaks.iter().enumerate() {
            // The bins attributed to the peak: down to the lowest points
            // between it and its neighbouring echoes (kept or not), or to
            // the window's ends.
            let (lo, hi) = bounds[k];
            let (offset, peak_amplitude) = refine(s, p, self.fit_half, lo, hi);
            // The selection measured this width already when the peak's
            // base was zero and its bounds are still the same.
            let width = match widths.get(k) {
                Some(&(a, b, w)) if a == lo && b == hi && !w.is_nan() => w,
                _ => half_max_width(s, p, lo, hi),
            };
            let amplitude = energy(s, p, width, lo, hi) / self.unit_energy;
            let fitted = (wf.first_bin + p as i64) as f64 + offset;
            let bin = fitted - self.bias_at(fitted);
            let reach = (2.0 * width).ceil() as usize;
            // The width from the echo's energy and fitted peak, which noise
            // hardly biases; the half-maximum crossings if either is not
            // positive.
            let width_ns = if amplitude > 0.0 && peak_amplitude > 0.0 {
                amplitude / peak_amplitude * self.pulse_fwhm_ns
            } else {
                width * self.bin_s * 1e9
            };
            out.push(Echo {
                bin,
                range_m: bin_to_range(bin, self.bin_s),
                peak_amplitude,
                // A discrete receiver records the echo's peak; waveform
                // processing its energy.
                amplitude: match self.config.detection {
                    EchoDetection::Discrete => peak_amplitude,
                    EchoDetection::Waveform => amplitude,
                },
                width_ns,
                first_bin: wf.first_bin + lo.max(p.saturating_sub(reach)) as i64,
                last_bin: wf.first_bin + hi.min(p + reach) as i64,
            });
        }
    }

    /// The maxima of `s` (at least 3 samples) that are echoes, first in
    /// time first, at most `max_returns` of them chosen by the selection
    /// rule, into `peaks`; `bounds[k]` is the range of samples attributed
    /// to `peaks[k]`: from the lowest sample between it and the echo before
    /// it (kept or not; the window's start for the first) to the lowest
    /// between it and the echo after it (the window's end for the last).
    /// `widths[k]` is `(lo, hi, w)`: the bounds within which peak `k`'s
    /// width was measured and, when its base was zero (so that the level
    /// was half its maximum), that width, else NaN.
    ///
    /// This is `select_by_definition` of the tests (the rules in the order the module
    /// documentation gives them) in one scan per rule: the lowest points
    /// between neighbouring peaks are found once, and when a peak is dropped
    /// the two valleys around it merge into the lower one (the earlier of
    /// equals, as a scan would find it) instead of being searched again.
    fn select(
        &self,
        s: &[f64],
        peaks: &mut Vec<usize>,
        valleys: &mut Vec<usize>,
        widths: &mut Vec<(usize, usize, f64)>,
        bounds: &mut Vec<(usize, usize)>,
    ) {
        peaks.clear();
        valleys.clear();
        widths.clear();
        bounds.clear();
        let n = s.len();
        let thr = self.threshold;
        // Candidate maxima above the threshold that stand out by the
        // threshold: the higher of the two valleys separating a peak from
        // higher ground (or from the window edge) must lie at least the
        // threshold below it.
        // The prominence scans of the first and of the last peak also give
        // the lowest samples between them and the window's ends when they
        // reach those ends.
        let (mut first_left, mut last_right) = (None, None);
        for_each_maximum(s, thr, |i| {
            let (height, left_min, right_min) = prominence(s, i);
            if height >= thr {
                if peaks.is_empty() {
                    first_left = left_min;
                }
                last_right = right_min;
                peaks.push(i);
            }
        });
        let Some(&first) = peaks.first() else {
            return;
        };
        valleys.extend(peaks.windows(2).map(|w| argmin(s, w[0], w[1])));
        // The lowest samples between the window's ends and the outer peaks
        // (only their values matter below).
        let mut left = first_left.unwrap_or_else(|| s[argmin(s, 0, first)]);
        let right = last_right.unwrap_or_else(|| s[argmin(s, peaks[peaks.len() - 1], n - 1)]);
        // The earlier of two valleys, `a` before `b`, unless `b` is lower.
        let lower = |a: usize, b: usize| if s[a] <= s[b] { a } else { b };
        // An echo cannot be much narrower than the emitted pulse: a maximum
        // narrower than half of it is a noise spike, not a target. Its width
        // is measured halfway between its top and its base (the higher of
        // the valleys separating it from its neighbours), so that a spike
        // riding on the tail of a strong echo shows its own width.
        let mut k = 0;
        while k < peaks.len() {
            let last = peaks.len() - 1;
            let p = peaks[k];
            let (lo, left_min) = if k == 0 {
                (0, left)
            } else {
                (valleys[k - 1], s[valleys[k - 1]])
            };
            let (hi, right_min) = if k == last {
                (n - 1, right)
            } else {
                (valleys[k], s[valleys[k]])
            };
            let base = left_min.max(right_min).max(0.0);
            let level = 0.5 * (s[p] + base);
            let width = width_at(s, p, lo, hi, level);
            if width >= self.min_width_bins {
                // With a zero base the level is exactly half the maximum:
                // the echo's width, if its bounds stay the same.
                widths.push((lo, hi, if base == 0.0 { width } else { f64::NAN }));
                k += 1;
                continue;
            }
            // Dropping the last peak ends the scan: the lowest point after
            // its left neighbour is never needed.
            if k == last {
                valleys.pop();
            } else if k == 0 {
                let v = s[valleys.remove(0)];
                if v < left {
                    left = v;
                }
            } else {
                valleys[k - 1] = lower(valleys[k - 1], valleys.remove(k));
            }
            peaks.remove(k);
        }
        self.merge_unresolved(s, peaks, valleys, widths);
        // Every echo's bounds, then the ones the receiver keeps.
        bounds.extend((0..peaks.len()).map(|k| {
            let lo = if k == 0 { 0 } else { valleys[k - 1] };
            let hi = valleys.get(k).copied().unwrap_or(n - 1);
            (lo, hi)
        }));
        let m = self.config.max_returns;
        if peaks.len() > m {
            let keep_last = self.config.selection == ReturnSelection::FirstAndLast;
            let last = peaks.len() - 1;
            let first = if keep_last { m - 1 } else { m };
            let tail = (peaks[last], widths[last], bounds[last]);
            peaks.truncate(first);
            widths.truncate(first);
            bounds.truncate(first);
            if keep_last {
                peaks.push(tail.0);
                widths.push(tail.1);
                bounds.push(tail.2);
            }
        }
        valleys.clear();
    }
}

impl Detector {
    /// Merges each maximum the receiver cannot tell from the echo before
    /// it into that echo: one nearer than the minimum separation (its dead
    /// zone), and for a discrete receiver one it has not re-armed for (the
    /// signal did not fall below the threshold between them). The echo
    /// keeps its position (the receiver triggered on it) and takes the
    /// merged samples, so its energy holds theirs.
    fn merge_unresolved(
        &self,
        s: &[f64],
        peaks: &mut Vec<usize>,
        valleys: &mut Vec<usize>,
        widths: &mut Vec<(usize, usize, f64)>,
    ) {
        let discrete = self.config.detection == EchoDetection::Discrete;
        if !discrete && self.dead_bins <= 0.0 {
            return;
        }
        let mut k = 1;
        while k < peaks.len() {
            let rearmed = !discrete || s[valleys[k - 1]] < self.threshold;
            let apart = (peaks[k] - peaks[k - 1]) as f64 >= self.dead_bins;
            if rearmed && apart {
                k += 1;
                continue;
            }
            // The lowest point after the merged maximum now ends the echo.
            valleys.remove(k - 1);
            peaks.remove(k);
            widths.remove(k);
            widths[k - 1].2 = f64::NAN;
        }
    }
}

/// Scratch space of [`Detector::detect`], reused from pulse to pulse.
#[derive(Clone, Debug, Default)]
pub struct DetectScratch {
    /// Samples minus background (used only with an atmosphere).
    signal: Vec<f64>,
    /// Sample indices of the echoes.
    peaks: Vec<usize>,
    /// Lowest samples between neighbouring echoes.
    valleys: Vec<usize>,
    /// Widths measured by the selection, with their bounds.
    widths: Vec<(usize, usize, f64)>,
    /// Samples attributed to each echo kept.
    bounds: Vec<(usize, usize)>,
}

/// Calibrates the peak fit on the emitted pulse: for 256 sub-bin phases of
/// a single noise-free echo, the error of the fitted position, tabulated
/// against the fractional part of the fitted position (zero for symmetric
/// pulses; a few millimetres for the rise-tail pulse without it).
fn bias_table(receiver: &Receiver, fit_half: usize) -> Vec<(f64, f64)> {
    let (kernel, k0) = receiver.kernel();
    let n = kernel.len() + 3;
    let phases = 256;
    let mut table: Vec<(f64, f64)> = (0..phases)
        .map(|i| {
            // An impulse at 1 + phase, split between bins 1 and 2 as the
            // receiver places returns, convolved with the sampled pulse.
            let phase = i as f64 / phases as f64;
            let mut s = vec![0.0; n];
            for (j, &k) in kernel.iter().enumerate() {
                s[j + 1] += (1.0 - phase) * k;
                s[j + 2] += phase * k;
            }
            let truth = (k0 + 1) as f64 + phase;
            let p = (0..n).max_by(|&a, &b| s[a].total_cmp(&s[b])).unwrap_or(0);
            let fitted = p as f64 + refine(&s, p, fit_half, 0, n - 1).0;
            (fitted - fitted.floor(), fitted - truth)
        })
        .collect();
    table.sort_by(|a, b| a.0.total_cmp(&b.0));
    table
}

/// Topographic prominence of the maximum at `p`, and the lowest sample
/// in `s[..=p]` and in `s[p..]` when the search on that side reached the
/// end of `s` (no higher sample lies on that side).
fn prominence(s: &[f64], p: usize) -> (f64, Option<f64>, Option<f64>) {
    let h = s[p];
    let (left_min, left_end) = lowest_before_higher(&s[..p], h, Side::Before);
    let (right_min, right_end) = lowest_before_higher(&s[p + 1..], h, Side::After);
    (
        h - left_min.max(right_min),
        left_end.then_some(left_min),
        right_end.then_some(right_min),
    )
}

/// Index of the smallest sample in `a..=b` (the first of equals). Samples
/// are finite and never −0 (they are sums that start at +0), so `<` is the
/// total order of `f64` here.
fn argmin(s: &[f64], a: usize, b: usize) -> usize {
    let Some(window) = s.get(a..=b) else {
        return a;
    };
    let mut best = 0;
    let mut min = window[0];
    for (i, &v) in window.iter().enumerate().skip(1) {
        if v < min {
            best = i;
            min = v;
        }
    }
    a + best
}

#[cfg(test)]
mod tests;

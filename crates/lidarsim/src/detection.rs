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

use crate::kernels::{Side, for_each_maximum, lowest_before_higher};
use crate::waveform::{Receiver, Waveform, bin_to_range};

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
    /// Energy amplitude (see the module documentation).
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
            config,
            threshold,
            bin_s: rx.bin_s,
            bias,
            unit_energy,
            min_width_bins: 0.5 * width,
            fit_half,
            pulse_fwhm_ns: rx.pulse.fwhm_s() * 1e9,
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
                amplitude,
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

/// Sub-bin offset of the maximum and the fitted peak value: a Gaussian
/// fitted to the samples within `half` bins of `p` (bounded by
/// `[lo, hi]`), as a parabola in the logarithm of the samples by weighted
/// least squares with weights `s²` (the variance of `ln s` under additive
/// noise is `σ²/s²`; Caruana's algorithm as weighted by Guo, "A simple
/// algorithm for fitting a Gaussian function", IEEE SPM 2011). Falls back to
/// the sample itself when fewer than three positive samples are available.
fn refine(s: &[f64], p: usize, half: usize, lo: usize, hi: usize) -> (f64, f64) {
    let a = lo.max(p.saturating_sub(half));
    let b = hi.min(p + half).min(s.len() - 1);
    // Normal equations of the weighted fit ln s = c0 + c1 x + c2 x², with
    // x relative to p for conditioning.
    // The matrix is symmetric: Σw·x^(r+c) for r, c in 0..3, five sums.
    let mut mom = [0.0f64; 5];
    let mut v = [0.0f64; 3];
    let mut used = 0;
    // Small integers: stepping `x` by one is exact.
    let mut x = a as f64 - p as f64 - 1.0;
    for &y in s.get(a..=b).unwrap_or_default() {
        x += 1.0;
        if y <= 0.0 {
            continue;
        }
        let w = y * y;
        let wly = w * y.ln();
        let x2 = x * x;
        mom[0] += w;
        mom[1] += w * x;
        mom[2] += w * x2;
        mom[3] += w * x2 * x;
        mom[4] += w * x2 * x2;
        v[0] += wly;
        v[1] += wly * x;
        v[2] += wly * x2;
        used += 1;
    }
    let m = [
        [mom[0], mom[1], mom[2]],
        [mom[1], mom[2], mom[3]],
        [mom[2], mom[3], mom[4]],
    ];
    if used >= 3
        && let Some([c0, c1, c2]) = solve3(m, v)
        && c2 < 0.0
    {
        let d = -c1 / (2.0 * c2);
        if d.abs() <= half.max(1) as f64 {
            return (d, (c0 - c1 * c1 / (4.0 * c2)).exp());
        }
    }
    (0.0, s[p])
}

/// Solves a 3×3 linear system by Cramer's rule.
fn solve3(m: [[f64; 3]; 3], v: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(m);
    if d.abs() < 1e-300 || !d.is_finite() {
        return None;
    }
    let mut out = [0.0; 3];
    for (i, o) in out.iter_mut().enumerate() {
        let mut mi = m;
        for r in 0..3 {
            mi[r][i] = v[r];
        }
        *o = det(mi) / d;
    }
    Some(out)
}

/// Full width at half maximum of the peak at `p`, in bins, searching no
/// further than `[lo, hi]`; crossings interpolated linearly.
fn half_max_width(s: &[f64], p: usize, lo: usize, hi: usize) -> f64 {
    width_at(s, p, lo, hi, 0.5 * s[p])
}

/// Width of the peak at `p` where it crosses `level`, in bins, searching no
/// further than `[lo, hi]`; crossings interpolated linearly.
fn width_at(s: &[f64], p: usize, lo: usize, hi: usize, level: f64) -> f64 {
    let mut left = lo as f64;
    for i in (lo..p).rev() {
        if s[i] < level {
            left = i as f64 + (level - s[i]) / (s[i + 1] - s[i]);
            break;
        }
    }
    let mut right = hi as f64;
    for i in p + 1..=hi {
        if s[i] < level {
            right = (i - 1) as f64 + (s[i - 1] - level) / (s[i - 1] - s[i]);
            break;
        }
    }
    (right - left).max(1.0)
}

/// Sum of the samples within two widths of the peak, bounded by `[lo, hi]`.
fn energy(s: &[f64], p: usize, width: f64, lo: usize, hi: usize) -> f64 {
    let reach = (2.0 * width).ceil() as usize;
    let a = lo.max(p.saturating_sub(reach));
    let b = hi.min(p + reach);
    s[a..=b].iter().sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Purpose, Stream};
    use crate::waveform::{PulseShape, ReceiverConfig, Return};

    /// The peak selection as first written: each rule a separate pass,
    /// every extent searched afresh; the peaks kept and their bounds.
    fn select_by_definition(det: &Detector, s: &[f64]) -> (Vec<usize>, Vec<(usize, usize)>) {
        let extent = |peaks: &[usize], k: usize| {
            let p = peaks[k];
            let lo = if k == 0 {
                0
            } else {
                argmin(s, peaks[k - 1], p)
            };
            let hi = if k + 1 < peaks.len() {
                argmin(s, p, peaks[k + 1])
            } else {
                s.len() - 1
            };
            (lo, hi)
        };
        let thr = det.threshold;
        let mut peaks: Vec<usize> = s
            .windows(3)
            .enumerate()
            .filter(|(_, w)| w[1] > thr && w[1] > w[0] && w[1] >= w[2])
            .map(|(b, _)| b + 1)
            .collect();
        peaks.retain(|&p| prominence(s, p).0 >= thr);
        let mut k = 0;
        while k < peaks.len() {
            let (lo, hi) = extent(&peaks, k);
            let p = peaks[k];
            let base = s[argmin(s, lo, p)].max(s[argmin(s, p, hi)]).max(0.0);
            let level = 0.5 * (s[p] + base);
            if width_at(s, p, lo, hi, level) < det.min_width_bins {
                peaks.remove(k);
            } else {
                k += 1;
            }
        }
        let mut kept: Vec<usize> = (0..peaks.len()).collect();
        let m = det.config.max_returns;
        if kept.len() > m {
            let last = kept.len() - 1;
            match det.config.selection {
                ReturnSelection::First => kept.truncate(m),
                ReturnSelection::FirstAndLast => {
                    kept.truncate(m - 1);
                    kept.push(last);
                }
            }
        }
        let bounds = kept.iter().map(|&k| extent(&peaks, k)).collect();
        (kept.iter().map(|&k| peaks[k]).collect(), bounds)
    }

    #[test]
    fn prominence_in_lanes_is_the_prominence_one_by_one() {
        // The definition: both sides searched one sample at a time.
        let by_definition = |s: &[f64], p: usize| {
            let h = s[p];
            let side = |it: &mut dyn Iterator<Item = f64>| {
                let mut low = h;
                for v in it {
                    if v > h {
                        return (low, false);
                    }
                    low = low.min(v);
                }
                (low, true)
            };
            let (l, le) = side(&mut s[..p].iter().rev().copied());
            let (r, re) = side(&mut s[p + 1..].iter().copied());
            (h - l.max(r), le.then_some(l), re.then_some(r))
        };
        let mut rng = Stream::new(9, 0, 0, Purpose::Test);
        let (mut ends, mut stops) = (0, 0);
        for case in 0..20_000 {
            let n = 1 + case % 29;
            let s: Vec<f64> = (0..n)
                .map(|_| (rng.uniform() * 8.0).floor() * 0.25)
                .collect();
            let p = (rng.uniform() * n as f64) as usize;
            let want = by_definition(&s, p);
            assert_eq!(prominence(&s, p), want, "case {case}: {s:?} at {p}");
            ends += usize::from(want.1.is_some()) + usize::from(want.2.is_some());
            stops += usize::from(want.1.is_none()) + usize::from(want.2.is_none());
        }
        assert!(ends > 5000 && stops > 5000, "{ends} {stops}");
    }

    #[test]
    fn one_pass_selection_matches_the_definition() {
        // Clusters of returns (close enough to merge or to leave narrow
        // shoulders), noise from none to strong, with and without an
        // atmosphere, short and long return limits, and plateaus from
        // clipped samples.
        let mut rng = Stream::new(7, 0, 0, Purpose::Test);
        let mut scratch = DetectScratch::default();
        let mut multi = 0;
        let mut reused = 0;
        for case in 0..3000 {
            let noise = [0.0, 0.002, 0.01, 0.03][case % 4];
            let rx = Receiver::new(ReceiverConfig {
                bin_s: 500e-12,
                pulse: if case % 3 == 0 {
                    PulseShape::RiseTail { fwhm_s: 3e-9 }
                } else {
                    PulseShape::Gaussian { fwhm_s: 4e-9 }
                },
                noise_sigma: noise,
                atmosphere: if case % 5 == 0 { 0.02 } else { 0.0 },
                reference_range_m: 1000.0,
            });
            let det = Detector::new(
                DetectorConfig {
                    threshold_sigma: 4.0,
                    min_amplitude: 0.005,
                    max_returns: 1 + case % 6,
                    selection: if case % 2 == 0 {
                        ReturnSelection::FirstAndLast
                    } else {
                        ReturnSelection::First
                    },
                },
                &rx,
            );
            let returns: Vec<Return> = (0..1 + case % 7)
                .map(|_| Return {
                    range_m: 500.0 + 4.0 * rng.uniform(),
                    power: 0.3 * rng.uniform(),
                })
                .collect();
            let mut wf = Waveform::default();
            rx.synthesize(&returns, &mut rng, &mut wf);
            if case % 11 == 0 {
                let top = 0.05;
                for v in &mut wf.samples {
                    *v = v.min(top);
                }
            }
            let s: Vec<f64> = wf
                .samples
                .iter()
                .enumerate()
                .map(|(i, v)| v - wf.background_at(i))
                .collect();
            let (want, want_bounds) = select_by_definition(&det, &s);
            let mut out = Vec::new();
            det.detect(&wf, &mut scratch, &mut out);
            assert_eq!(scratch.peaks, want, "case {case}");
            assert_eq!(scratch.bounds, want_bounds, "case {case}");
            // Every width the selection kept for reuse is the half-maximum
            // width within the same bounds.
            for (&p, &(lo, hi, w)) in scratch.peaks.iter().zip(&scratch.widths) {
                if !w.is_nan() {
                    reused += 1;
                    assert_eq!(w, half_max_width(&s, p, lo, hi), "case {case}");
                }
            }
            multi += usize::from(want.len() > 1);
        }
        // The cases must exercise merging, not only single echoes.
        assert!(multi > 300, "{multi}");
        assert!(reused > 1000, "{reused}");
        // Arbitrary sequences: many maxima of every width and height, narrow
        // ones dropped next to each other and at both ends.
        let (_, det) = setup(PulseShape::Gaussian { fwhm_s: 4e-9 }, 0.01);
        let (mut peaks, mut valleys, mut widths, mut bounds) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for case in 0..20_000 {
            let n = 3 + case % 60;
            let mut level: f64 = 0.0;
            let s: Vec<f64> = (0..n)
                .map(|_| {
                    level = (level + 0.08 * (rng.uniform() - 0.5)).max(0.0);
                    level + if rng.uniform() < 0.1 { 0.1 } else { 0.0 }
                })
                .collect();
            det.select(&s, &mut peaks, &mut valleys, &mut widths, &mut bounds);
            let (want, want_bounds) = select_by_definition(&det, &s);
            assert_eq!((&peaks, &bounds), (&want, &want_bounds), "{s:?}");
        }
    }

    fn setup(pulse: PulseShape, noise: f64) -> (Receiver, Detector) {
        let rx = Receiver::new(ReceiverConfig {
            bin_s: 500e-12,
            pulse,
            noise_sigma: noise,
            atmosphere: 0.0,
            reference_range_m: 1000.0,
        });
        let det = Detector::new(
            DetectorConfig {
                threshold_sigma: 4.0,
                min_amplitude: 0.005,
                max_returns: 5,
                selection: ReturnSelection::default(),
            },
            &rx,
        );
        (rx, det)
    }

    fn echoes(rx: &Receiver, det: &Detector, returns: &[Return], seed: u64) -> Vec<Echo> {
        let mut rng = Stream::new(seed, 0, 0, Purpose::ReceiverNoise);
        let mut wf = Waveform::default();
        rx.synthesize(returns, &mut rng, &mut wf);
        let mut out = Vec::new();
        det.detect(&wf, &mut DetectScratch::default(), &mut out);
        out
    }

    #[test]
    fn single_echo_sub_bin_range_and_amplitude() {
        for pulse in [
            PulseShape::Gaussian { fwhm_s: 4e-9 },
            PulseShape::RiseTail { fwhm_s: 4e-9 },
        ] {
            let (rx, det) = setup(pulse, 0.0);
            for k in 0..50 {
                // Ranges spread over a bin (7.5 cm) in small steps.
                let range = 800.0 + k as f64 * 0.0031;
                let e = echoes(
                    &rx,
                    &det,
                    &[Return {
                        range_m: range,
                        power: 0.3,
                    }],
                    0,
                );
                assert_eq!(e.len(), 1);
                assert!(
                    (e[0].range_m - range).abs() < 0.002,
                    "{pulse:?} {range} {}",
                    e[0].range_m - range
                );
                assert!((e[0].amplitude - 0.3).abs() < 0.3 * 0.01);
                assert!((e[0].width_ns - 4.0).abs() < 0.15, "{}", e[0].width_ns);
            }
        }
    }

    /// A flat surface at right angles to the beam returns the emitted pulse
    /// (every sub-ray at the same range): its echo is as wide as the pulse,
    /// 4 ns FWHM by the pulse's definition, within a few percent, whether
    /// strong or weak (six, ten, forty and four hundred times the noise σ,
    /// the threshold being four), on average over many noise draws, for
    /// both pulse shapes; each of the strongest echoes on its own within
    /// 2.5 % (placing a return between two bins widens it by up to 1 %).
    #[test]
    fn an_echo_from_a_flat_surface_at_normal_incidence_is_as_wide_as_the_pulse() {
        const FWHM_NS: f64 = 4.0;
        for pulse in [
            PulseShape::Gaussian {
                fwhm_s: FWHM_NS * 1e-9,
            },
            PulseShape::RiseTail {
                fwhm_s: FWHM_NS * 1e-9,
            },
        ] {
            let noise = 0.005;
            let (rx, det) = setup(pulse, noise);
            for snr in [6.0, 10.0, 40.0, 400.0] {
                let peak = snr * noise;
                let mut widths = Vec::new();
                for seed in 0..600 {
                    // 19 sub-rays of equal energy at one range (at sub-bin
                    // phases that change from pulse to pulse).
                    let range = 400.0 + 0.0123 * seed as f64;
                    let returns: Vec<Return> = (0..19)
                        .map(|_| Return {
                            range_m: range,
                            power: peak / 19.0,
                        })
                        .collect();
                    let e = echoes(&rx, &det, &returns, seed);
                    if let [e] = e.as_slice() {
                        widths.push(e.width_ns);
                        if snr >= 400.0 {
                            assert!(
                                (e.width_ns - FWHM_NS).abs() < 0.025 * FWHM_NS,
                                "{pulse:?} seed {seed}: {} ns",
                                e.width_ns
                            );
                        }
                    }
                }
                assert!(widths.len() > 400, "{pulse:?} {snr}: {}", widths.len());
                let mean = widths.iter().sum::<f64>() / widths.len() as f64;
                assert!(
                    (mean - FWHM_NS).abs() < 0.05 * FWHM_NS,
                    "{pulse:?} at {snr} σ: mean width {mean:.3} ns"
                );
            }
        }
    }

    /// Without noise an echo is never narrower than the pulse, and one
    /// merged from two surfaces or stretched over a range interval is as
    /// wide as its shape: for a surface spread evenly over 3 m of range
    /// (20 ns), about 20 ns.
    #[test]
    fn merged_and_stretched_echoes_are_at_least_as_wide_as_the_pulse() {
        let (rx, det) = setup(PulseShape::Gaussian { fwhm_s: 4e-9 }, 0.0);
        for sep in [0.0, 0.1, 0.2, 0.3] {
            let e = echoes(
                &rx,
                &det,
                &[
                    Return {
                        range_m: 300.0,
                        power: 0.2,
                    },
                    Return {
                        range_m: 300.0 + sep,
                        power: 0.1,
                    },
                ],
                0,
            );
            assert_eq!(e.len(), 1);
            assert!(e[0].width_ns >= 0.995 * 4.0, "{sep}: {}", e[0].width_ns);
        }
        // 3 m of range is 2 × 3 / c = 20.0 ns of two-way time; the pulse
        // widens it by about its own width at the ends, so the FWHM of the
        // echo is close to 20 ns.
        let box_ns = 2.0 * 3.0 / crate::geometry::SPEED_OF_LIGHT_MPS * 1e9;
        let returns: Vec<Return> = (0..300)
            .map(|i| Return {
                range_m: 500.0 + i as f64 * 0.01,
                power: 0.002,
            })
            .collect();
        let e = echoes(&rx, &det, &returns, 0);
        assert_eq!(e.len(), 1);
        assert!(
            (e[0].width_ns - box_ns).abs() < 0.08 * box_ns,
            "{} vs {box_ns}",
            e[0].width_ns
        );
    }

    #[test]
    fn resolution_follows_pulse_length() {
        // Pulse length in range: c · FWHM / 2 = 0.6 m for 4 ns.
        let (rx, det) = setup(PulseShape::Gaussian { fwhm_s: 4e-9 }, 0.0);
        let two = |sep: f64| {
            echoes(
                &rx,
                &det,
                &[
                    Return {
                        range_m: 500.0,
                        power: 0.2,
                    },
                    Return {
                        range_m: 500.0 + sep,
                        power: 0.2,
                    },
                ],
                0,
            )
        };
        assert_eq!(two(1.2).len(), 2);
        assert_eq!(two(0.9).len(), 2);
        assert_eq!(two(0.4).len(), 1);
        assert_eq!(two(0.2).len(), 1);
        let e = two(1.2);
        assert!((e[0].range_m - 500.0).abs() < 0.02);
        assert!((e[1].range_m - 501.2).abs() < 0.02);
        // A merged echo carries the energy of both.
        let m = two(0.2);
        assert!((m[0].amplitude - 0.4).abs() < 0.4 * 0.02);
    }

    #[test]
    fn a_spike_on_the_tail_of_an_echo_is_not_an_echo() {
        // The detector expects noise σ = 0.01; the waveform itself is clean
        // so that the spike is the only disturbance.
        let (_, det) = setup(PulseShape::RiseTail { fwhm_s: 3e-9 }, 0.01);
        let (quiet, _) = setup(PulseShape::RiseTail { fwhm_s: 3e-9 }, 0.0);
        let mut wf = Waveform::default();
        let mut rng = Stream::new(0, 0, 0, Purpose::Test);
        quiet.synthesize(
            &[Return {
                range_m: 150.0,
                power: 2.0,
            }],
            &mut rng,
            &mut wf,
        );
        // A one-bin spike of 0.2 on the long tail, 8 bins after the peak,
        // where the tail is still above half the spike's top.
        let peak = (0..wf.samples.len())
            .max_by(|&a, &b| wf.samples[a].total_cmp(&wf.samples[b]))
            .unwrap();
        wf.samples[peak + 8] += 0.2;
        let mut out = Vec::new();
        det.detect(&wf, &mut DetectScratch::default(), &mut out);
        assert_eq!(out.len(), 1, "{out:?}");
    }

    #[test]
    fn noise_threshold_and_max_returns() {
        let (rx, det) = setup(PulseShape::Gaussian { fwhm_s: 4e-9 }, 0.01);
        assert!((det.threshold() - 0.04).abs() < 1e-15);
        // A weak echo (below threshold) is not reported; strong ones are,
        // without spurious extra echoes from the noise on their tops.
        let mut counts = [0usize; 4];
        for seed in 0..200 {
            let e = echoes(
                &rx,
                &det,
                &[
                    Return {
                        range_m: 300.0,
                        power: 0.005,
                    },
                    Return {
                        range_m: 310.0,
                        power: 0.5,
                    },
                ],
                seed,
            );
            counts[e.len().min(3)] += 1;
            if let Some(first) = e.first() {
                assert!((first.range_m - 310.0).abs() < 0.05, "{e:?}");
            }
        }
        assert!(counts[1] >= 196, "{counts:?}");
    }

    /// Four echoes 3 m apart, two recorded: "first-and-last" keeps the
    /// first and the last (the ground under a crown), "first" the first two;
    /// either way no kept echo's bins reach into a dropped echo's.
    #[test]
    fn max_returns_keeps_the_last_echo_by_default() {
        let (rx, mut det) = setup(PulseShape::Gaussian { fwhm_s: 4e-9 }, 0.0);
        det.config.max_returns = 2;
        let rs: Vec<Return> = (0..4)
            .map(|i| Return {
                range_m: 100.0 + 3.0 * i as f64,
                power: 0.1,
            })
            .collect();
        // 3 m apart are 40 bins of 500 ps: a dropped echo's peak is 20 bins
        // beyond the valley before it.
        let bin_of = |r: f64| 2.0 * r / crate::geometry::SPEED_OF_LIGHT_MPS / 500e-12;
        assert_eq!(det.config.selection, ReturnSelection::FirstAndLast);
        let e = echoes(&rx, &det, &rs, 0);
        assert_eq!(e.len(), 2);
        assert!((e[0].range_m - 100.0).abs() < 0.02, "{e:?}");
        assert!((e[1].range_m - 109.0).abs() < 0.02, "{e:?}");
        assert!((e[0].last_bin as f64) < bin_of(101.5) + 1.0, "{e:?}");
        assert!((e[1].first_bin as f64) > bin_of(107.5) - 1.0, "{e:?}");
        det.config.selection = ReturnSelection::First;
        let e = echoes(&rx, &det, &rs, 0);
        assert_eq!(e.len(), 2);
        assert!((e[1].range_m - 103.0).abs() < 0.02, "{e:?}");
        assert!((e[1].last_bin as f64) < bin_of(104.5) + 1.0, "{e:?}");
        // One recorded return: the last one, or the first.
        det.config.max_returns = 1;
        assert!((echoes(&rx, &det, &rs, 0)[0].range_m - 103.0 + 3.0).abs() < 0.02);
        det.config.selection = ReturnSelection::FirstAndLast;
        assert!((echoes(&rx, &det, &rs, 0)[0].range_m - 109.0).abs() < 0.02);
    }
}

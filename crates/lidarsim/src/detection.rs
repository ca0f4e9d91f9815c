//! Echo detection in a sampled waveform.
//!
//! A real receiver "has to have certain minimum power received, before it
//! can be considered true" (specification, "Pulse – Target interaction").
//! We report maxima of the waveform that rise above a noise-based threshold
//! over the atmospheric background and stand out from their neighbours by
//! at least the same margin (topographic prominence), first in time first,
//! up to a maximum number of returns. Each echo gets:
//!
//! * its range, refined to a fraction of a bin by fitting a Gaussian
//!   through the three samples around the maximum (the log-parabola
//!   estimator; Wagner et al. 2006, ISPRS J. 60(2), use Gaussian fits for
//!   the same purpose), corrected by the estimator's bias on the emitted
//!   pulse itself so that asymmetric pulses range correctly;
//! * its peak amplitude and its width (full width at half maximum);
//! * its *energy amplitude*: the echo's energy (sum of samples within two
//!   widths of the peak) divided by the energy of the emitted pulse of unit
//!   peak measured the same way. For an echo from a single surface at right
//!   angles this equals the peak amplitude; for an echo stretched in time
//!   (an oblique surface spreads the footprint over a range interval) it is
//!   the peak the same energy would have had unstretched. It is therefore
//!   exactly the Eq. 2 power summed over the footprint, and it is what the
//!   LAS intensity records.

use crate::waveform::{Receiver, Waveform, bin_to_range};

/// Detection settings.
#[derive(Clone, Debug, PartialEq)]
pub struct DetectorConfig {
    /// Threshold as a multiple of the receiver noise σ.
    pub threshold_sigma: f64,
    /// Lowest echo amplitude accepted even without noise, amplitude units.
    pub min_amplitude: f64,
    /// Largest number of echoes reported per pulse.
    pub max_returns: usize,
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
    /// Full width at half maximum, ns.
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
    /// Sub-bin offset the estimator reports for the emitted pulse itself.
    offset_bias: f64,
    /// Energy of the unit-peak pulse measured by the echo-energy rule.
    unit_energy: f64,
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
        let offset_bias = refine(kernel, k0).0;
        let width = half_max_width(kernel, k0, 0, kernel.len() - 1);
        let unit_energy = energy(kernel, k0, width, 0, kernel.len() - 1);
        Self {
            config,
            threshold,
            bin_s: rx.bin_s,
            offset_bias,
            unit_energy,
        }
    }

    /// Amplitude an echo must exceed above the background.
    pub fn threshold(&self) -> f64 {
        self.threshold
    }

    /// Detects the echoes of `wf` into `out` (cleared first), in time order.
    /// `signal` is scratch space.
    pub fn detect(&self, wf: &Waveform, signal: &mut Vec<f64>, out: &mut Vec<Echo>) {
        out.clear();
        signal.clear();
        signal.extend(wf.samples.iter().zip(&wf.background).map(|(s, b)| s - b));
        let s = &signal[..];
        let n = s.len();
        if n < 3 {
            return;
        }
        // Candidate maxima above the threshold.
        let mut peaks: Vec<usize> = (1..n - 1)
            .filter(|&b| s[b] > self.threshold && s[b] > s[b - 1] && s[b] >= s[b + 1])
            .collect();
        // Keep those that stand out by the threshold: the higher of the two
        // valleys separating a peak from higher ground (or from the window
        // edge) must lie at least the threshold below it.
        peaks.retain(|&p| prominence(s, p) >= self.threshold);
        peaks.truncate(self.config.max_returns);
        for (k, &p) in peaks.iter().enumerate() {
            // Extent: down to the lowest point between neighbouring echoes.
            let lo = if k == 0 {
                0
            } else {
                argmin(s, peaks[k - 1], p)
            };
            let hi = if k + 1 < peaks.len() {
                argmin(s, p, peaks[k + 1])
            } else {
                n - 1
            };
            let (offset, peak_amplitude) = refine(s, p);
            let width = half_max_width(s, p, lo, hi);
            let amplitude = energy(s, p, width, lo, hi) / self.unit_energy;
            let bin = (wf.first_bin + p as i64) as f64 + offset - self.offset_bias;
            let reach = (2.0 * width).ceil() as usize;
            out.push(Echo {
                bin,
                range_m: bin_to_range(bin, self.bin_s),
                peak_amplitude,
                amplitude,
                width_ns: width * self.bin_s * 1e9,
                first_bin: wf.first_bin + lo.max(p.saturating_sub(reach)) as i64,
                last_bin: wf.first_bin + hi.min(p + reach) as i64,
            });
        }
    }
}

/// Topographic prominence of the maximum at `p`.
fn prominence(s: &[f64], p: usize) -> f64 {
    let h = s[p];
    let mut left_min = h;
    for i in (0..p).rev() {
        if s[i] > h {
            break;
        }
        left_min = left_min.min(s[i]);
    }
    let mut right_min = h;
    for &v in &s[p + 1..] {
        if v > h {
            break;
        }
        right_min = right_min.min(v);
    }
    h - left_min.max(right_min)
}

fn argmin(s: &[f64], a: usize, b: usize) -> usize {
    (a..=b)
        .min_by(|&i, &j| s[i].total_cmp(&s[j]))
        .unwrap_or(a)
}

/// Sub-bin offset of the maximum and the fitted peak value: a Gaussian
/// (parabola in the logarithm) through the samples at `p−1, p, p+1`;
/// a plain parabola where a sample is not positive.
fn refine(s: &[f64], p: usize) -> (f64, f64) {
    if p == 0 || p + 1 >= s.len() {
        return (0.0, s[p]);
    }
    let (a, b, c) = (s[p - 1], s[p], s[p + 1]);
    if a > 0.0 && b > 0.0 && c > 0.0 {
        let (la, lb, lc) = (a.ln(), b.ln(), c.ln());
        let den = la - 2.0 * lb + lc;
        if den < 0.0 {
            let d = (0.5 * (la - lc) / den).clamp(-1.0, 1.0);
            let peak = (lb - 0.25 * (la - lc) * d).exp();
            return (d, peak);
        }
    }
    let den = a - 2.0 * b + c;
    if den < 0.0 {
        let d = (0.5 * (a - c) / den).clamp(-1.0, 1.0);
        (d, b - 0.25 * (a - c) * d)
    } else {
        (0.0, b)
    }
}

/// Full width at half maximum of the peak at `p`, in bins, searching no
/// further than `[lo, hi]`; crossings interpolated linearly.
fn half_max_width(s: &[f64], p: usize, lo: usize, hi: usize) -> f64 {
    let half = 0.5 * s[p];
    let mut left = lo as f64;
    for i in (lo..p).rev() {
        if s[i] < half {
            left = i as f64 + (half - s[i]) / (s[i + 1] - s[i]);
            break;
        }
    }
    let mut right = hi as f64;
    for i in p + 1..=hi {
        if s[i] < half {
            right = (i - 1) as f64 + (s[i - 1] - half) / (s[i - 1] - s[i]);
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
        det.detect(&wf, &mut Vec::new(), &mut out);
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
                assert!((e[0].range_m - range).abs() < 0.005, "{pulse:?} {range}");
                assert!((e[0].amplitude - 0.3).abs() < 0.3 * 0.01);
                assert!((e[0].width_ns - 4.0).abs() < 0.15, "{}", e[0].width_ns);
            }
        }
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
                        power: 0.02,
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
                assert!((first.range_m - 310.0).abs() < 0.05);
            }
        }
        assert!(counts[1] >= 196, "{counts:?}");
        // max_returns keeps the first ones in time.
        let (rx, mut det) = setup(PulseShape::Gaussian { fwhm_s: 4e-9 }, 0.0);
        det.config.max_returns = 2;
        let rs: Vec<Return> = (0..4)
            .map(|i| Return {
                range_m: 100.0 + 3.0 * i as f64,
                power: 0.1,
            })
            .collect();
        let e = echoes(&rx, &det, &rs, 0);
        assert_eq!(e.len(), 2);
        assert!((e[1].range_m - 103.0).abs() < 0.02);
    }
}

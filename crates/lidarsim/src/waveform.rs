//! The receiver: full waveform of one pulse.
//!
//! Specification, "Receiver" and Figs. 4, 6, 7: every sub-ray return is a
//! (distance, signal strength) pair; the receiver counts photons every
//! 500 ps; "the convolution with the transmitted pulse shows how the
//! photons actually arrive in the receiver ... Sumwave is what is stored".
//! Atmospheric path radiance and receiver noise are added on top (Fig. 4,
//! lower left).
//!
//! Units: time is the two-way travel time since emission; bin `b` covers the
//! instant `b · bin`. Amplitudes are in units of the transmitted power times
//! Eq. 2's factors: a level, perfectly white Lambertian surface at the
//! reference range, filling the whole beam, returns an echo of peak 1.

use crate::geometry::SPEED_OF_LIGHT_MPS;
use crate::rng::Stream;

/// Temporal shape of the emitted pulse, peak normalised to 1 at `t = 0`
/// (the instant the range clock refers to).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PulseShape {
    /// Gaussian with the given full width at half maximum, s.
    Gaussian {
        /// FWHM, s.
        fwhm_s: f64,
    },
    /// Fast rise and long tail (specification Fig. 4, upper left):
    /// `P(t) ∝ (t/τ)² exp(−t/τ)`, the emitted-pulse model of Carlsson,
    /// Steinvall & Letalick (2001, FOI-R--0163--SE), with τ chosen so that
    /// the FWHM is the given one; shifted so that its peak (at `2τ`) is at 0.
    RiseTail {
        /// FWHM, s.
        fwhm_s: f64,
    },
}

/// FWHM of `x² e^{−x}` in units of τ: the distance between the two roots
/// of `x² e^{−x} = 2 e^{−2}`.
fn rise_tail_fwhm_over_tau() -> f64 {
    let f = |x: f64| x * x * (-x).exp() - 2.0 * (-2.0f64).exp();
    let bisect = |mut lo: f64, mut hi: f64| {
        for _ in 0..100 {
            let mid = 0.5 * (lo + hi);
            if (f(lo) < 0.0) == (f(mid) < 0.0) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    };
    bisect(2.0, 20.0) - bisect(0.0, 2.0)
}

impl PulseShape {
    /// Full width at half maximum, s.
    pub fn fwhm_s(&self) -> f64 {
        match *self {
            PulseShape::Gaussian { fwhm_s } | PulseShape::RiseTail { fwhm_s } => fwhm_s,
        }
    }

    /// Power at `dt_s` relative to the peak (1 at `dt_s = 0`).
    pub fn value(&self, dt_s: f64) -> f64 {
        match *self {
            PulseShape::Gaussian { fwhm_s } => {
                let sigma = fwhm_s / (8.0 * 2f64.ln()).sqrt();
                (-0.5 * (dt_s / sigma).powi(2)).exp()
            }
            PulseShape::RiseTail { fwhm_s } => {
                let tau = fwhm_s / rise_tail_fwhm_over_tau();
                let x = dt_s / tau + 2.0;
                if x <= 0.0 {
                    0.0
                } else {
                    // Peak of x² e^{−x} is 4 e^{−2} at x = 2.
                    x * x * (-x).exp() / (4.0 * (-2.0f64).exp())
                }
            }
        }
    }

    /// Interval `[−before, after]` (s) outside which the shape is below
    /// 1e-4 of its peak.
    pub fn support_s(&self) -> (f64, f64) {
        match *self {
            PulseShape::Gaussian { fwhm_s } => {
                let sigma = fwhm_s / (8.0 * 2f64.ln()).sqrt();
                let half = sigma * (2.0 * 1e4f64.ln()).sqrt();
                (half, half)
            }
            PulseShape::RiseTail { fwhm_s } => {
                let tau = fwhm_s / rise_tail_fwhm_over_tau();
                // x² e^{−x} / (4 e^{−2}) = 1e-4 at x ≈ 15.1 on the tail.
                let mut x: f64 = 2.0;
                while x * x * (-x).exp() / (4.0 * (-2.0f64).exp()) > 1e-4 {
                    x += 0.01;
                }
                (2.0 * tau, (x - 2.0) * tau)
            }
        }
    }
}

/// Receiver settings.
#[derive(Clone, Debug, PartialEq)]
pub struct ReceiverConfig {
    /// Sampling interval, s (default 500 ps).
    pub bin_s: f64,
    /// Emitted pulse shape.
    pub pulse: PulseShape,
    /// Standard deviation of the receiver's white noise, amplitude units
    /// (0 = off).
    pub noise_sigma: f64,
    /// Atmospheric path radiance at the reference range, amplitude units:
    /// the background from range `R` is `atmosphere · (Rn/R)²` (volume
    /// backscatter falls with the square of the range). 0 = off.
    pub atmosphere: f64,
    /// Reference range `Rn`, m.
    pub reference_range_m: f64,
}

/// A sampled waveform: `samples[i]` is the signal of bin `first_bin + i`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Waveform {
    /// Absolute index of the first bin.
    pub first_bin: i64,
    /// Received signal (returns convolved with the pulse, plus atmosphere
    /// and noise).
    pub samples: Vec<f64>,
    /// Expected background (atmosphere) in each bin; empty without
    /// atmosphere, meaning zero everywhere ([`Waveform::background_at`]).
    /// Detection thresholds are set above it.
    pub background: Vec<f64>,
    /// The returns placed on the time axis before convolution (kept to
    /// reuse the allocation; also the noise-free "sum of sub-ray returns"
    /// of specification Fig. 6).
    pub impulses: Vec<f64>,
    /// Fractional absolute bin of each return, in the order given
    /// ([`range_to_bin`] of its range, computed once per pulse).
    pub return_bins: Vec<f64>,
    /// The smallest and the largest of `return_bins` (`(+∞, −∞)` when
    /// there are none).
    pub return_span: (f64, f64),
}

impl Waveform {
    /// Expected background in sample `i` (zero without atmosphere).
    #[inline]
    pub fn background_at(&self, i: usize) -> f64 {
        self.background.get(i).copied().unwrap_or(0.0)
    }
}

/// One sub-ray return on the time axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Return {
    /// Range to the surface, m.
    pub range_m: f64,
    /// Received power (Eq. 2), amplitude units.
    pub power: f64,
}

/// Converts a range to a fractional bin index.
#[inline]
pub fn range_to_bin(range_m: f64, bin_s: f64) -> f64 {
    2.0 * range_m / SPEED_OF_LIGHT_MPS / bin_s
}

/// Converts a fractional bin index to a range.
#[inline]
pub fn bin_to_range(bin: f64, bin_s: f64) -> f64 {
    bin * bin_s * SPEED_OF_LIGHT_MPS / 2.0
}

/// The receiver: turns sub-ray returns into a sampled waveform.
#[derive(Clone, Debug)]
pub struct Receiver {
    config: ReceiverConfig,
    /// Pulse shape sampled at bin spacing; `kernel[k0]` is the peak.
    kernel: Vec<f64>,
    k0: usize,
    /// `kernel` and zeros up to a multiple of [`KERNEL_STRIDE`] samples,
    /// for the convolution (the window's guard bins hold the zeros).
    padded: Vec<f64>,
}

/// Samples the convolution adds at a time: a 256-bit register of `f64`.
const KERNEL_STRIDE: usize = 4;

/// Bins of empty signal kept on both sides of a waveform window.
pub const GUARD_BINS: i64 = 4;
const _: () = assert!(GUARD_BINS as usize >= KERNEL_STRIDE - 1);

/// The spans of returns (in bins) whose occupied bins are marked while
/// the impulses are placed, so that the convolution visits only those: a
/// shorter span is scanned bin by bin at less cost, a wider one too (the
/// marks' bitmap lives on the stack).
const SCAN_BINS: usize = 16;
const OCCUPANCY_BINS: usize = 512;
const OCCUPANCY_WORDS: usize = OCCUPANCY_BINS / 64;

/// Places each return on the time axis (window from bin `first`), its
/// power split between the two nearest bins in proportion to its position;
/// `mark` is told the lower bin of each.
#[inline(always)]
fn place_impulses(
    returns: &[Return],
    bins: &[f64],
    first: i64,
    impulses: &mut [f64],
    mut mark: impl FnMut(usize),
) {
    for (r, &x) in returns.iter().zip(bins) {
        let b = x.floor();
        let f = x - b;
        let i = (b as i64 - first) as usize;
        impulses[i] += r.power * (1.0 - f);
        impulses[i + 1] += r.power * f;
        mark(i);
    }
}

impl Receiver {
    /// A receiver for the given settings.
    pub fn new(config: ReceiverConfig) -> Self {
        let (before, after) = config.pulse.support_s();
        let nb = (before / config.bin_s).ceil() as usize;
        let na = (after / config.bin_s).ceil() as usize;
        let kernel: Vec<f64> = (0..=nb + na)
            .map(|j| config.pulse.value((j as f64 - nb as f64) * config.bin_s))
            .collect();
        let mut padded = kernel.clone();
        padded.resize(kernel.len().next_multiple_of(KERNEL_STRIDE), 0.0);
        Self {
            config,
            kernel,
            k0: nb,
            padded,
        }
    }

    /// The settings.
    pub fn config(&self) -> &ReceiverConfig {
        &self.config
    }

    /// The pulse shape sampled at the bin spacing, and the index of its peak.
    pub fn kernel(&self) -> (&[f64], usize) {
        (&self.kernel, self.k0)
    }

    /// Synthesises the waveform of one pulse into `out`.
    ///
    /// Each return is placed on the time axis by splitting its power
    /// between the two nearest bins in proportion to its position (which
    /// keeps its centroid exactly), then the impulse train is convolved with
    /// the sampled pulse. Atmosphere and noise (drawn from `noise_rng`) are
    /// added over the window. `out` is left empty when there is no return.
    pub fn synthesize(&self, returns: &[Return], noise_rng: &mut Stream, out: &mut Waveform) {
        out.samples.clear();
        out.background.clear();
        out.impulses.clear();
        out.return_bins.clear();
        out.return_span = (f64::INFINITY, f64::NEG_INFINITY);
        if returns.is_empty() {
            return;
        }
        let bin_s = self.config.bin_s;
        out.return_bins
            .extend(returns.iter().map(|r| range_to_bin(r.range_m, bin_s)));
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for &x in &out.return_bins {
            // Comparisons rather than `f64::min`/`max`: bins are finite.
            if x < lo {
                lo = x;
            }
            if x > hi {
                hi = x;
            }
        }
        out.return_span = (lo, hi);
        let k0 = self.k0 as i64;
        let ka = self.kernel.len() as i64 - 1 - k0;
        let first = lo.floor() as i64 - k0 - GUARD_BINS;
        let last = hi.floor() as i64 + 1 + ka + GUARD_BINS;
        let n = (last - first + 1) as usize;
        // Only the bins from the earliest return to one past the latest can
        // hold an impulse. Over a long span the bins of the returns are
        // marked as they are placed, and the convolution visits those (and
        // the bin after each) instead of scanning the span.
        let touched =
            (lo.floor() as i64 - first) as usize..(hi.floor() as i64 - first + 2) as usize;
        let marked = (SCAN_BINS..=OCCUPANCY_BINS).contains(&touched.len());
        let mut occupied = [0u64; OCCUPANCY_WORDS];
        out.impulses.clear();
        out.impulses.resize(n, 0.0);
        let (impulses, bins) = (&mut out.impulses, &out.return_bins);
        if marked {
            place_impulses(returns, bins, first, impulses, |i| {
                let j = i - touched.start;
                occupied[(j / 64) % OCCUPANCY_WORDS] |= 1 << (j % 64);
            });
        } else {
            place_impulses(returns, bins, first, impulses, |_| {});
        }
        // Convolution: out[b] = Σ_i impulses[i] · kernel[b − i + k0].
        out.first_bin = first;
        out.samples.resize(n, 0.0);
        // The window has k0 + GUARD_BINS bins before the first impulse and
        // the kernel's tail + GUARD_BINS after the last, so the padded
        // kernel always fits. Impulses are added in bin order either way.
        let mut add = |i: usize| {
            let p = out.impulses[i];
            if p == 0.0 {
                return;
            }
            // Past the kernel's end `p · 0` adds nothing (samples are sums
            // from +0 of finite powers, never −0).
            let start = i - self.k0;
            let window = &mut out.samples[start..start + self.padded.len()];
            let kernel = self.padded.as_chunks::<KERNEL_STRIDE>().0;
            for (o, k) in window
                .as_chunks_mut::<KERNEL_STRIDE>()
                .0
                .iter_mut()
                .zip(kernel)
            {
                for j in 0..KERNEL_STRIDE {
                    o[j] += p * k[j];
                }
            }
        };
        if marked {
            // Each marked bin and the one after it, in order.
            let mut carry = 0;
            for (w, &word) in occupied.iter().enumerate() {
                let mut bits = word | (word << 1) | carry;
                carry = word >> 63;
                while bits != 0 {
                    add(touched.start + w * 64 + bits.trailing_zeros() as usize);
                    bits &= bits - 1;
                }
            }
        } else {
            touched.for_each(add);
        }
        // Atmosphere: path radiance falls with range squared.
        if self.config.atmosphere > 0.0 {
            out.background.resize(n, 0.0);
            for (i, bg) in out.background.iter_mut().enumerate() {
                let range = bin_to_range((first + i as i64) as f64, bin_s).max(1.0);
                *bg = self.config.atmosphere * (self.config.reference_range_m / range).powi(2);
            }
            for (s, bg) in out.samples.iter_mut().zip(&out.background) {
                *s += bg;
            }
        }
        if self.config.noise_sigma > 0.0 {
            for s in out.samples.iter_mut() {
                *s += self.config.noise_sigma * noise_rng.normal();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Purpose;

    fn receiver(pulse: PulseShape) -> Receiver {
        Receiver::new(ReceiverConfig {
            bin_s: 500e-12,
            pulse,
            noise_sigma: 0.0,
            atmosphere: 0.0,
            reference_range_m: 1000.0,
        })
    }

    fn half_max_width(f: impl Fn(f64) -> f64) -> f64 {
        // Numerical FWHM by fine scanning.
        let ts: Vec<f64> = (-4000..20000).map(|i| i as f64 * 1e-12).collect();
        let above: Vec<f64> = ts.iter().copied().filter(|&t| f(t) >= 0.5).collect();
        above.last().unwrap() - above.first().unwrap()
    }

    #[test]
    fn pulse_shapes_have_requested_fwhm_and_unit_peak() {
        for shape in [
            PulseShape::Gaussian { fwhm_s: 4e-9 },
            PulseShape::RiseTail { fwhm_s: 4e-9 },
        ] {
            assert!((shape.value(0.0) - 1.0).abs() < 1e-12);
            assert!(shape.value(1e-12) < 1.0 && shape.value(-1e-12) < 1.0);
            let w = half_max_width(|t| shape.value(t));
            assert!((w - 4e-9).abs() < 3e-12, "{shape:?}: {w}");
            let (b, a) = shape.support_s();
            assert!(shape.value(-b) <= 1.01e-4 && shape.value(a) <= 1.01e-4);
        }
        // The rise-tail shape rises faster than it falls.
        let rt = PulseShape::RiseTail { fwhm_s: 4e-9 };
        assert!(rt.value(-2e-9) < rt.value(2e-9));
    }

    #[test]
    fn energy_and_centroid_are_preserved() {
        let rx = receiver(PulseShape::Gaussian { fwhm_s: 4e-9 });
        let mut rng = Stream::new(0, 0, 0, Purpose::Test);
        let mut wf = Waveform::default();
        let range = 987.654_321;
        rx.synthesize(
            &[Return {
                range_m: range,
                power: 0.8,
            }],
            &mut rng,
            &mut wf,
        );
        let (kernel, _) = rx.kernel();
        let ksum: f64 = kernel.iter().sum();
        let total: f64 = wf.samples.iter().sum();
        assert!((total - 0.8 * ksum).abs() < 1e-9);
        let centroid = wf
            .samples
            .iter()
            .enumerate()
            .map(|(i, s)| (wf.first_bin + i as i64) as f64 * s)
            .sum::<f64>()
            / total;
        let want = range_to_bin(range, 500e-12);
        assert!((centroid - want).abs() < 1e-6, "{centroid} vs {want}");
        // The peak equals the power (unit-peak pulse) to within the
        // sampling of a 4 ns pulse at 0.5 ns.
        let peak = wf.samples.iter().cloned().fold(0.0, f64::max);
        assert!((peak - 0.8).abs() < 0.8 * 0.02);
    }

    #[test]
    fn atmosphere_background_and_noise_statistics() {
        let mut rx = receiver(PulseShape::Gaussian { fwhm_s: 4e-9 });
        rx.config.atmosphere = 0.01;
        rx.config.noise_sigma = 0.05;
        let mut wf = Waveform::default();
        let mut all = Vec::new();
        for k in 0..400 {
            let mut rng = Stream::new(1, 0, k, Purpose::ReceiverNoise);
            rx.synthesize(
                &[Return {
                    range_m: 2000.0,
                    power: 0.0,
                }],
                &mut rng,
                &mut wf,
            );
            for (s, bg) in wf.samples.iter().zip(&wf.background) {
                // Background at 2 km with Rn = 1 km is a quarter.
                assert!((bg - 0.0025).abs() < 0.0025 * 0.01);
                all.push(s - bg);
            }
        }
        let n = all.len() as f64;
        let mean = all.iter().sum::<f64>() / n;
        let sd = (all.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n).sqrt();
        assert!(mean.abs() < 5.0 * 0.05 / n.sqrt());
        assert!((sd - 0.05).abs() < 0.05 * 0.03);
    }
}

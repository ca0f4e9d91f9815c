//! Echo detection against definitions and analytic expectations.

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
    // The receiver's resolution: a maximum within the dead zone of the
    // last echo kept, or (discrete) without a fall below the threshold
    // since the maximum before it, belongs to that echo.
    // Each echo as (its maximum, the last maximum merged into it): its
    // samples run from the lowest point before its maximum to the lowest
    // point after the last one merged.
    let discrete = det.config.detection == EchoDetection::Discrete;
    let mut resolved: Vec<(usize, usize)> = Vec::new();
    for (k, &p) in peaks.iter().enumerate() {
        match resolved.last_mut() {
            Some((first, last))
                if !((s[argmin(s, peaks[k - 1], p)] < thr || !discrete)
                    && (p - *first) as f64 >= det.dead_bins) =>
            {
                *last = p;
            }
            _ => resolved.push((p, p)),
        }
    }
    let extent = |k: usize| {
        let lo = if k == 0 {
            0
        } else {
            argmin(s, resolved[k - 1].1, resolved[k].0)
        };
        let hi = match resolved.get(k + 1) {
            Some(next) => argmin(s, resolved[k].1, next.0),
            None => s.len() - 1,
        };
        (lo, hi)
    };
    let peaks: Vec<usize> = resolved.iter().map(|r| r.0).collect();
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
    let bounds = kept.iter().map(|&k| extent(k)).collect();
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
                detection: if case % 4 < 2 {
                    EchoDetection::Discrete
                } else {
                    EchoDetection::Waveform
                },
                min_separation_m: [0.0, 0.3, 1.0, 2.7][case % 5 % 4],
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
            detection: EchoDetection::Waveform,
            min_separation_m: 0.0,
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

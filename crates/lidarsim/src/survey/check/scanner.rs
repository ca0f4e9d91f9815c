//! `[scanner]` and `[receiver]`: the laser, the deflector, the beam, the
//! waveform's sampling and noise, and echo detection.

use super::{Bounds, Checker};
use crate::detection::{DetectorConfig, EchoDetection, ReturnSelection};
use crate::message::num;
use crate::sensor::beam::Fineness;
use crate::survey::preset::{self, PresetUse};
use crate::survey::raw::{RawReceiver, RawScanner};
use crate::survey::{
    KeyPath, MAX_PRF_HZ, MAX_PULSE_SAMPLES, MAX_RANGE_M, MAX_WINDOW_SAMPLES, MIN_PULSE_FWHM_NS,
    RawSurvey, ScannerSettings,
};
use crate::waveform::{PulseShape, ReceiverConfig, range_to_bin};

/// The dead zone of a discrete-return receiver that names none, m: 2.7 m,
/// "returns must be at least 2.7 m apart to be counted as independent"
/// for the Leica ALS50-II (NERC-ARF Data Analysis Node, sensor notes on
/// the Leica LIDAR), the one such figure published for an airborne
/// discrete-return scanner that we found.
pub const DEFAULT_DEAD_ZONE_M: f64 = 2.7;

/// The checked `[scanner]` and `[receiver]`.
pub(crate) struct Sensor {
    pub scanner: ScannerSettings,
    pub receiver: ReceiverConfig,
    pub detector: DetectorConfig,
    pub speckle_looks: Option<f64>,
    pub intensity_gain: f64,
    /// The instrument preset and the keys it set.
    pub preset: Option<PresetUse>,
    /// Settings beyond the preset instrument's datasheet.
    pub warnings: Vec<String>,
}

/// Checks `[scanner]` and `[receiver]`.
pub(crate) fn scanner(c: &mut Checker, raw: &RawSurvey) -> Sensor {
    let root = KeyPath::root();
    // [scanner]
    let sp = root.key("scanner");
    let (applied, preset) = apply_preset(c, raw, &sp);
    let s = applied.as_ref().unwrap_or(&raw.scanner);
    let prf_hz = prf(c, s, &sp);
    let deflector = super::deflector::deflector(c, s, &sp, prf_hz);
    let (divergence_mrad, divergence_along_mrad) = super::channel::divergence(
        c,
        &sp,
        s.divergence_mrad,
        s.divergence_along_mrad,
        (0.3, 0.3),
    );
    let subrays = c.count(sp.key("subrays"), s.subrays, 19, 1, 10_000) as usize;
    let edge_fineness = edge_fineness(c, s, &sp);
    let pulse = pulse(c, s, &sp);
    let detector = echoes(c, s, &sp);
    let ranges = ranges(c, s, &sp, detector.detection);
    let wavelength_nm = c.positive(sp.key("wavelength_nm"), s.wavelength_nm, 1064.0, " nm");
    let channels = super::channel::channels(
        c,
        s,
        &sp,
        (
            divergence_mrad * 1e-3,
            divergence_along_mrad * 1e-3,
            wavelength_nm,
        ),
    );
    // [receiver]
    let receiver = receiver(c, &raw.receiver, &root.key("receiver"));
    check_sampling(c, &root.key("receiver"), &pulse, receiver.bin_ps, &ranges);
    let warnings = match &preset {
        Some(u) => preset::limits(u.preset, prf_hz, &deflector),
        None => Vec::new(),
    };
    Sensor {
        scanner: ScannerSettings {
            prf_hz,
            deflector,
            channels,
            divergence_rad: divergence_mrad * 1e-3,
            divergence_along_rad: divergence_along_mrad * 1e-3,
            subrays,
            edge_fineness,
            min_range_m: ranges.min_range_m,
            max_range_m: ranges.max_range_m,
            wavelength_nm,
        },
        receiver: ReceiverConfig {
            bin_s: receiver.bin_ps * 1e-12,
            pulse: pulse.shape,
            noise_sigma: receiver.noise,
            atmosphere: receiver.atmosphere,
            reference_range_m: ranges.reference_range_m,
        },
        detector: DetectorConfig {
            threshold_sigma: receiver.threshold_sigma,
            min_amplitude: receiver.min_amplitude,
            max_returns: detector.max_returns,
            selection: detector.selection,
            detection: detector.detection,
            min_separation_m: ranges.min_separation_m,
        },
        speckle_looks: raw
            .receiver
            .speckle
            .unwrap_or(false)
            .then_some(receiver.speckle_looks),
        intensity_gain: receiver.intensity_gain,
        preset,
        warnings,
    }
}

/// The instrument preset named by `preset`, if any: `[scanner]` with the
/// keys it does not give taken from the preset, and what the preset set.
fn apply_preset(
    c: &mut Checker,
    raw: &RawSurvey,
    sp: &KeyPath,
) -> (Option<RawScanner>, Option<PresetUse>) {
    match raw.scanner.preset.as_deref() {
        None => (None, None),
        Some(id) => match preset::find(id) {
            Some(p) => {
                let (merged, set) = preset::apply(p, &raw.scanner);
                (Some(merged), Some(PresetUse { preset: p, set }))
            }
            None => {
                let ids: Vec<&str> = preset::PRESETS.iter().map(|p| p.id).collect();
                c.unknown_id(sp.key("preset"), "instrument", id, &ids);
                (None, None)
            }
        },
    }
}

/// `prf_hz`: positive and at most `MAX_PRF_HZ`.
fn prf(c: &mut Checker, s: &RawScanner, sp: &KeyPath) -> f64 {
    let prf_hz = c.positive(sp.key("prf_hz"), s.prf_hz, 100_000.0, " Hz");
    if prf_hz > MAX_PRF_HZ {
        c.err(
            sp.key("prf_hz"),
            format!(
                "must be at most {MAX_PRF_HZ} Hz (10 MHz, beyond any airborne scanner), \
                 got {prf_hz:e}"
            ),
        );
    }
    prf_hz
}

/// `edge_rays`: how finely a cell across a resolved discontinuity is
/// sampled (a `k × k` grid).
fn edge_fineness(c: &mut Checker, s: &RawScanner, sp: &KeyPath) -> Fineness {
    let rays = s.edge_rays.unwrap_or(16);
    let found = usize::try_from(rays).ok().and_then(Fineness::from_rays);
    found.unwrap_or_else(|| {
        c.err(
            sp.key("edge_rays"),
            format!(
                "must be 16 (the default), 64 or 256 (a 4 × 4, 8 × 8 or 16 × 16 grid), \
                 got {rays}"
            ),
        );
        Fineness::Rays16
    })
}

/// The laser pulse: its shape and width.
struct Pulse {
    shape: PulseShape,
    /// The width (the default when the key is wrong).
    fwhm_ns: f64,
    /// Whether `pulse_fwhm_ns` is usable, so the sampling can be checked
    /// against it.
    ok: bool,
}

/// `pulse_fwhm_ns` and `pulse_shape`.
fn pulse(c: &mut Checker, s: &RawScanner, sp: &KeyPath) -> Pulse {
    let pulse_fwhm_ns = match s.pulse_fwhm_ns {
        Some(v) if v > 0.0 && v < MIN_PULSE_FWHM_NS => {
            let hint = if v < 1e-6 {
                format!(
                    ": the key is in nanoseconds and {} looks like seconds ({} ns)",
                    num(v),
                    num(v * 1e9)
                )
            } else {
                String::new()
            };
            c.err(
                sp.key("pulse_fwhm_ns"),
                format!(
                    "must be at least {MIN_PULSE_FWHM_NS} ns (airborne pulses last 1 to 10 \
                     ns), got {}{hint}",
                    num(v)
                ),
            );
            None
        }
        other => Some(c.number(
            sp.key("pulse_fwhm_ns"),
            other,
            4.0,
            Bounds::above(0.0, " ns").at_most(1000.0),
        )),
    };
    let ok = pulse_fwhm_ns.is_some();
    let fwhm_ns = pulse_fwhm_ns.unwrap_or(4.0);
    let shape = match s.pulse_shape.as_deref() {
        None | Some("gaussian") => PulseShape::Gaussian {
            fwhm_s: fwhm_ns * 1e-9,
        },
        Some("rise-tail") | Some("rise_tail") => PulseShape::RiseTail {
            fwhm_s: fwhm_ns * 1e-9,
        },
        Some(other) => {
            c.err(
                sp.key("pulse_shape"),
                format!("unknown pulse shape '{other}'; expected \"gaussian\" or \"rise-tail\""),
            );
            PulseShape::Gaussian {
                fwhm_s: fwhm_ns * 1e-9,
            }
        }
    };
    Pulse { shape, fwhm_ns, ok }
}

/// Which echoes a pulse records.
struct Echoes {
    max_returns: usize,
    selection: ReturnSelection,
    detection: EchoDetection,
}

/// `max_returns`, `return_selection` and `echo_detection`.
fn echoes(c: &mut Checker, s: &RawScanner, sp: &KeyPath) -> Echoes {
    let max_returns = c.count(sp.key("max_returns"), s.max_returns, 5, 1, 15) as usize;
    let selection = match s.return_selection.as_deref() {
        None => ReturnSelection::default(),
        Some(name) => ReturnSelection::from_name(name).unwrap_or_else(|| {
            c.err(
                sp.key("return_selection"),
                format!(
                    "unknown rule '{name}'; expected \"first-and-last\" (the default: the \
                     first max_returns − 1 echoes and the last) or \"first\""
                ),
            );
            ReturnSelection::default()
        }),
    };
    let detection = match s.echo_detection.as_deref() {
        None => EchoDetection::default(),
        Some(name) => EchoDetection::from_name(name).unwrap_or_else(|| {
            c.err(
                sp.key("echo_detection"),
                format!(
                    "unknown detection '{name}'; expected \"discrete\" (the default: a \
                     discrete-return receiver) or \"waveform\" (online waveform processing)"
                ),
            );
            EchoDetection::default()
        }),
    };
    Echoes {
        max_returns,
        selection,
        detection,
    }
}

/// The scanner's distances, m.
struct Ranges {
    min_separation_m: f64,
    min_range_m: f64,
    max_range_m: f64,
    reference_range_m: f64,
}

/// `min_return_separation_m`, the range window and `reference_range_m`.
fn ranges(c: &mut Checker, s: &RawScanner, sp: &KeyPath, detection: EchoDetection) -> Ranges {
    // A discrete receiver's dead zone, by default the one published for
    // an airborne discrete-return scanner (the Leica ALS50-II's, NERC-ARF
    // sensor notes); online waveform processing resolves what its
    // waveform resolves.
    let min_separation_m = c.number(
        sp.key("min_return_separation_m"),
        s.min_return_separation_m,
        match detection {
            EchoDetection::Discrete => DEFAULT_DEAD_ZONE_M,
            EchoDetection::Waveform => 0.0,
        },
        Bounds::between(0.0, 100.0, " m"),
    );
    let min_range_m = c.number(
        sp.key("min_range_m"),
        s.min_range_m,
        1.0,
        Bounds::at_least(0.0, " m"),
    );
    let max_range_m = c.number(
        sp.key("max_range_m"),
        s.max_range_m,
        10_000.0,
        Bounds::above(0.0, " m").at_most(MAX_RANGE_M),
    );
    if max_range_m <= min_range_m {
        c.err(
            sp.key("max_range_m"),
            format!(
                "must be greater than min_range_m ({} m)",
                crate::message::num(min_range_m)
            ),
        );
    }
    let reference_range_m = c.number(
        sp.key("reference_range_m"),
        s.reference_range_m,
        1000.0,
        Bounds::between(1.0, MAX_RANGE_M, " m"),
    );
    Ranges {
        min_separation_m,
        min_range_m,
        max_range_m,
        reference_range_m,
    }
}

/// The checked numbers of `[receiver]`.
struct Receiver {
    bin_ps: f64,
    noise: f64,
    atmosphere: f64,
    speckle_looks: f64,
    threshold_sigma: f64,
    min_amplitude: f64,
    intensity_gain: f64,
}

/// `[receiver]`'s numbers, each in its range (`rp`).
fn receiver(c: &mut Checker, r: &RawReceiver, rp: &KeyPath) -> Receiver {
    let bin_ps = c.number(
        rp.key("bin_ps"),
        r.bin_ps,
        500.0,
        Bounds::above(0.0, " ps").at_most(1e6),
    );
    // Amplitudes are in units of the echo of a white plane filling the
    // beam at the reference range: a noise or path radiance above it
    // would hide every echo.
    let noise = c.number(rp.key("noise"), r.noise, 0.0, Bounds::between(0.0, 1.0, ""));
    let atmosphere = c.number(
        rp.key("atmosphere"),
        r.atmosphere,
        0.0,
        Bounds::between(0.0, 1.0, ""),
    );
    Receiver {
        bin_ps,
        noise,
        atmosphere,
        speckle_looks: c.positive(rp.key("speckle_looks"), r.speckle_looks, 1.0, ""),
        threshold_sigma: c.positive(rp.key("threshold_sigma"), r.threshold_sigma, 4.0, ""),
        min_amplitude: c.positive(rp.key("min_amplitude"), r.min_amplitude, 0.005, ""),
        intensity_gain: c.positive(rp.key("intensity_gain"), r.intensity_gain, 10_000.0, ""),
    }
}

/// `bin_ps` against the pulse: a bin at most the pulse's width, and few
/// enough samples. The work of a pulse grows with the samples of the
/// pulse shape (each return is convolved with it) and its memory with the
/// samples of the range window.
fn check_sampling(c: &mut Checker, rp: &KeyPath, pulse: &Pulse, bin_ps: f64, ranges: &Ranges) {
    if !pulse.ok {
        return;
    }
    let pulse_fwhm_ns = pulse.fwhm_ns;
    if bin_ps * 1e-3 > pulse_fwhm_ns {
        c.err(
            rp.key("bin_ps"),
            format!(
                "a {} ps bin cannot sample a {} ns pulse; use a bin at most the pulse width",
                num(bin_ps),
                num(pulse_fwhm_ns)
            ),
        );
    }
    let window_m = ranges.max_range_m - ranges.min_range_m;
    let (before, after) = pulse.shape.support_s();
    let shape_samples = (before + after) / (bin_ps * 1e-12);
    let window_samples = range_to_bin(window_m, bin_ps * 1e-12) + shape_samples;
    let finest = ((before + after) / MAX_PULSE_SAMPLES as f64 * 1e12)
        .max(range_to_bin(window_m, 1e-12) / MAX_WINDOW_SAMPLES as f64);
    if shape_samples > MAX_PULSE_SAMPLES as f64 {
        c.err(
            rp.key("bin_ps"),
            format!(
                "a {} ps bin samples the {} ns pulse (its shape spans {:.1} ns) with {} \
                 samples; at most {MAX_PULSE_SAMPLES}: use bin_ps of at least {:.2} ps",
                num(bin_ps),
                num(pulse_fwhm_ns),
                (before + after) * 1e9,
                num(shape_samples.round()),
                finest
            ),
        );
    } else if window_samples > MAX_WINDOW_SAMPLES as f64 {
        c.err(
            rp.key("bin_ps"),
            format!(
                "a {} ps bin needs {} samples for the range window from \
                 scanner.min_range_m to scanner.max_range_m ({} m); at most \
                 {MAX_WINDOW_SAMPLES}: use bin_ps of at least {:.2} ps or narrow the \
                 range window",
                num(bin_ps),
                num(window_samples.round()),
                num(window_m),
                finest
            ),
        );
    }
}

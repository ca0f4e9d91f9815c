//! `[platform]`: attitude sway, turbulence drift and the time between
//! lines.

use super::{Bounds, Checker};
use crate::sensor::platform::{DriftConfig, SwayConfig};
use crate::survey::platform_preset::{self, PlatformPresetUse};
use crate::survey::{KeyPath, MAX_SWAY_FREQUENCIES, RawSurvey};

/// The checked `[platform]` (its lines are [`super::lines`]').
pub(crate) struct Platform {
    pub sway: Option<SwayConfig>,
    pub turn_time_s: f64,
    /// Turbulence drift when it is on.
    pub drift: Option<DriftConfig>,
    /// The platform preset and the keys it set.
    pub preset: Option<PlatformPresetUse>,
}

/// Checks `[platform]`.
pub(crate) fn platform(c: &mut Checker, raw: &RawSurvey) -> Platform {
    let root = KeyPath::root();
    // [platform]
    let pp = root.key("platform");
    let (applied, preset) = match raw.platform.preset.as_deref() {
        None => (None, None),
        Some(id) => match platform_preset::find(id) {
            Some(p) => {
                let (merged, set) = platform_preset::apply(p, &raw.platform);
                (Some(merged), Some(PlatformPresetUse { preset: p, set }))
            }
            None => {
                let ids: Vec<&str> = platform_preset::PLATFORM_PRESETS
                    .iter()
                    .map(|p| p.id)
                    .collect();
                c.unknown_id(pp.key("preset"), "platform", id, &ids);
                (None, None)
            }
        },
    };
    let p = applied.as_ref().unwrap_or(&raw.platform);
    let sway_on = p.sway.unwrap_or(false);
    let d = SwayConfig::default();
    let roll = c.number(
        pp.key("roll_amplitude_deg"),
        p.roll_amplitude_deg,
        d.roll_amplitude_rad.to_degrees(),
        Bounds::between(0.0, 30.0, "°"),
    );
    let pitch = c.number(
        pp.key("pitch_amplitude_deg"),
        p.pitch_amplitude_deg,
        d.pitch_amplitude_rad.to_degrees(),
        Bounds::between(0.0, 30.0, "°"),
    );
    let yaw = c.number(
        pp.key("yaw_amplitude_deg"),
        p.yaw_amplitude_deg,
        d.yaw_amplitude_rad.to_degrees(),
        Bounds::between(0.0, 30.0, "°"),
    );
    let freqs = match &p.sway_frequencies_hz {
        None => d.frequencies_hz.clone(),
        Some(f)
            if f.is_empty()
                || f.len() > MAX_SWAY_FREQUENCIES
                || f.iter()
                    .any(|x| !(x.is_finite() && *x > 0.0 && *x <= 100.0)) =>
        {
            c.err(
                pp.key("sway_frequencies_hz"),
                format!(
                    "must be a list of 1 to {MAX_SWAY_FREQUENCIES} frequencies greater than 0 \
                     and at most 100 Hz (an aircraft sways at a few tenths of a hertz), got {} \
                     entries",
                    f.len()
                ),
            );
            d.frequencies_hz.clone()
        }
        Some(f) => f.clone(),
    };
    let sway = sway_on.then(|| SwayConfig {
        roll_amplitude_rad: roll.to_radians(),
        pitch_amplitude_rad: pitch.to_radians(),
        yaw_amplitude_rad: yaw.to_radians(),
        frequencies_hz: freqs,
    });
    let turn_time_s = c.number(
        pp.key("turn_time_s"),
        p.turn_time_s,
        30.0,
        Bounds::between(0.0, 1e7, " s"),
    );
    let drift = match &p.drift_m {
        None => None,
        Some(d) if d.len() == 2 && d.iter().all(|x| x.is_finite() && *x >= 0.0) => {
            Some([d[0], d[1]])
        }
        Some(_) => {
            c.err(
                pp.key("drift_m"),
                "must be [lateral, vertical] peak drift in metres, both at least 0",
            );
            None
        }
    };
    let drift_period_s = c.positive(pp.key("drift_period_s"), p.drift_period_s, 30.0, " s");
    Platform {
        sway,
        turn_time_s,
        drift: drift.map(|amplitude_m| DriftConfig {
            amplitude_m,
            period_s: drift_period_s,
        }),
        preset,
    }
}

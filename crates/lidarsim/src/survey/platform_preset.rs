//! Platform presets: `[platform] preset = "uav"` fills the `[platform]`
//! keys a survey does not give with the motion of a kind of aircraft, and
//! names its limits so that a line flown faster or higher than that
//! aircraft flies is warned.
//!
//! The one preset, `uav`, is a survey multicopter holding its line with
//! RTK positioning. Its figures, and how each was worked out, are in
//! `docs/survey.md` (Platform presets):
//! * drift ±0.1 m across and up — the hovering accuracy with RTK of the
//!   DJI Matrice 300/350 RTK datasheets — with a 10 s longest period (our
//!   choice: the position loop of a multicopter corrects within seconds);
//! * roll and pitch sway at the drift's frequencies, with the amplitude
//!   that drift needs: a multicopter moves sideways by tilting, so the
//!   peak acceleration `a` of the drift needs a tilt `atan(a / g)` (1.9°);
//! * no yaw sway (the heading is held; we found no figure for its noise);
//! * 7 s per turn: at 5 m/s, braking and speeding up at 2 m/s² and turning
//!   180° at 86°/s (HELIOS++ `quadcopter`);
//! * limits: 23 m/s (DJI Matrice 300/350 RTK datasheets) and 120 m above
//!   the ground (the ceiling of the EU open category, Regulation (EU)
//!   2019/947, and of FAA Part 107, 400 ft).

use crate::message::num;
use crate::survey::raw::RawPlatform;

/// A kind of aircraft.
#[derive(Clone, Debug, PartialEq)]
pub struct PlatformPreset {
    /// Survey id (`uav`).
    pub id: &'static str,
    /// What it is.
    pub name: &'static str,
    /// Where the values come from.
    pub source: &'static str,
    /// What the preset does not model.
    pub note: &'static str,
    /// `[platform]` keys it sets, as TOML.
    pub keys: &'static str,
    /// Fastest speed it flies, m/s.
    pub max_speed_mps: f64,
    /// Highest it may fly above the ground, m.
    pub max_height_above_ground_m: f64,
}

/// Every platform preset.
pub const PLATFORM_PRESETS: &[PlatformPreset] = &[PlatformPreset {
    id: "uav",
    name: "survey multicopter with RTK (DJI Matrice 300/350 RTK class)",
    source: "DJI Matrice 300 RTK and 350 RTK datasheets: hovering accuracy with RTK ±0.1 m \
             horizontal and vertical, 23 m/s top speed; HELIOS++ platforms.xml (quadcopter): \
             2 m/s² braking and speeding up, 85.94°/s yaw rate; Regulation (EU) 2019/947 and \
             FAA Part 107: 120 m (400 ft) above the ground",
    note: "the drift's 10 s period is a choice, not a measured figure; no yaw sway; the forward \
           pitch of a multicopter in flight (HELIOS++: 5°) and a gimbal's levelling are not \
           modelled (the scanner looks as mounted); the mount's lever arm is taken as known \
           (trajectories are the scanner's; its error is [boresight] lever_arm_m)",
    keys: r#"sway = true
roll_amplitude_deg = 1.9
pitch_amplitude_deg = 1.9
yaw_amplitude_deg = 0.0
sway_frequencies_hz = [0.1, 0.274, 0.563]
drift_m = [0.1, 0.1]
drift_period_s = 10.0
turn_time_s = 7.0"#,
    max_speed_mps: 23.0,
    max_height_above_ground_m: 120.0,
}];

/// The platform preset with this id.
pub fn find(id: &str) -> Option<&'static PlatformPreset> {
    PLATFORM_PRESETS.iter().find(|p| p.id == id)
}

/// A platform preset as a survey used it.
#[derive(Clone, Debug, PartialEq)]
pub struct PlatformPresetUse {
    /// The aircraft.
    pub preset: &'static PlatformPreset,
    /// The `[platform]` keys it set (`key = value`), those the survey did
    /// not give.
    pub set: Vec<String>,
}

/// `raw` with the keys it does not give taken from `preset`, and those
/// keys as `key = value` lines. A survey with a trajectory file takes
/// none: its recorded motion replaces sway, drift and turns.
pub fn apply(preset: &PlatformPreset, raw: &RawPlatform) -> (RawPlatform, Vec<String>) {
    if raw.trajectory_file.is_some() {
        return (raw.clone(), Vec::new());
    }
    crate::survey::preset::fill(raw, preset.keys, |_, _| false)
}

/// Warnings for a line beyond the aircraft's limits: `speed_mps` and the
/// height above the ground, for line `n` (numbered from 1).
pub fn limits(
    preset: &PlatformPreset,
    n: usize,
    speed_mps: f64,
    height_above_ground_m: f64,
) -> Vec<String> {
    let mut out = Vec::new();
    if speed_mps > preset.max_speed_mps {
        out.push(format!(
            "flight line {n}: {} m/s is faster than a {} flies ({} m/s, datasheet; \
             [platform] preset = \"{}\")",
            num(speed_mps),
            preset.name,
            num(preset.max_speed_mps),
            preset.id
        ));
    }
    if height_above_ground_m > preset.max_height_above_ground_m {
        out.push(format!(
            "flight line {n}: {height_above_ground_m:.1} m above the ground is higher than a \
             {} may fly ({} m in the EU open category and under FAA Part 107; \
             [platform] preset = \"{}\")",
            preset.name,
            num(preset.max_height_above_ground_m),
            preset.id
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn uav() -> &'static PlatformPreset {
        find("uav").unwrap()
    }

    fn keys() -> toml::Table {
        toml::from_str(uav().keys).unwrap()
    }

    fn f(t: &toml::Table, k: &str) -> f64 {
        t[k].as_float().unwrap()
    }

    /// The sway's roll and pitch are the tilt that moves a multicopter
    /// along the drift: a position `Σ A_j sin(2π f_j t + φ_j)` needs at
    /// most `a = Σ A_j (2π f_j)²`, and a thrust tilted by θ gives
    /// `g tan θ`. The drift's components are those `docs/survey.md` gives
    /// for `drift_m` (weights 1, 1/2, 1/3; f_j = (j+1)·1.37^j / P).
    #[test]
    fn the_sway_is_the_tilt_the_drift_needs() {
        let t = keys();
        let a_peak = t["drift_m"].as_array().unwrap()[0].as_float().unwrap();
        let p = f(&t, "drift_period_s");
        let w = [1.0, 0.5, 1.0 / 3.0];
        let sum_w: f64 = w.iter().sum();
        let mut accel = 0.0;
        for (j, wj) in w.iter().enumerate() {
            let fj = (j as f64 + 1.0) * 1.37f64.powi(j as i32) / p;
            accel += a_peak * wj / sum_w * (2.0 * std::f64::consts::PI * fj).powi(2);
        }
        let tilt_deg = (accel / 9.80665).atan().to_degrees();
        assert!((tilt_deg - 1.927).abs() < 0.005, "{tilt_deg}");
        for k in ["roll_amplitude_deg", "pitch_amplitude_deg"] {
            assert!((f(&t, k) - tilt_deg).abs() < 0.05, "{k}");
        }
        // The sway's frequencies are the drift's.
        let sf: Vec<f64> = t["sway_frequencies_hz"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_float().unwrap())
            .collect();
        for (j, s) in sf.iter().enumerate() {
            let fj = (j as f64 + 1.0) * 1.37f64.powi(j as i32) / p;
            assert!((s - fj).abs() < 5e-4, "{s} against {fj}");
        }
    }

    /// A turn at 5 m/s: brake to rest and speed up again at 2 m/s²
    /// (2.5 s each) and turn 180° at 85.94°/s (2.09 s).
    #[test]
    fn the_turn_is_braking_turning_and_speeding_up() {
        let turn = 2.0 * 5.0 / 2.0 + 180.0 / 85.94;
        assert!((f(&keys(), "turn_time_s") - turn).abs() < 0.2, "{turn}");
    }

    #[test]
    fn survey_keys_win_and_a_trajectory_file_takes_nothing() {
        let raw = RawPlatform {
            roll_amplitude_deg: Some(0.4),
            ..Default::default()
        };
        let (merged, set) = apply(uav(), &raw);
        assert_eq!(merged.roll_amplitude_deg, Some(0.4));
        assert_eq!(merged.sway, Some(true));
        assert_eq!(merged.drift_m, Some(vec![0.1, 0.1]));
        assert!(set.iter().all(|s| !s.starts_with("roll_amplitude_deg")));
        assert!(set.contains(&"turn_time_s = 7.0".to_string()), "{set:?}");
        let recorded = RawPlatform {
            trajectory_file: Some("track.csv".into()),
            ..Default::default()
        };
        let (merged, set) = apply(uav(), &recorded);
        assert!(set.is_empty() && merged.sway.is_none());
    }

    #[test]
    fn limits_name_the_figure() {
        assert!(limits(uav(), 1, 23.0, 120.0).is_empty());
        let w = limits(uav(), 2, 30.0, 150.0);
        assert_eq!(w.len(), 2);
        assert!(w[0].contains("flight line 2") && w[0].contains("23 m/s"));
        assert!(w[1].contains("150.0 m above the ground") && w[1].contains("120 m"));
    }
}

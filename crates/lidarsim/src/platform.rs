//! The aircraft: straight flight lines and attitude sway.
//!
//! Everything here is a pure function of time (`pose_at`), never a stepping
//! state machine. Specification, "Computing the trajectory and current
//! attitude of the LiDAR": `P(t) = P_start + v·dir·t` along a straight line,
//! and small attitude changes "using simple trigonometric functions with
//! randomized coefficients" (Fig. 10).

use crate::geometry::{Attitude, DVec3};
use crate::rng::{Purpose, Stream};

/// Position and attitude of the scanner at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Scanner position, world metres.
    pub position_m: DVec3,
    /// Attitude.
    pub attitude: Attitude,
}

/// Amplitudes and frequencies of the attitude sway.
#[derive(Clone, Debug, PartialEq)]
pub struct SwayConfig {
    /// Peak roll amplitude, rad (the sum of the components never exceeds it).
    pub roll_amplitude_rad: f64,
    /// Peak pitch amplitude, rad.
    pub pitch_amplitude_rad: f64,
    /// Peak yaw amplitude, rad.
    pub yaw_amplitude_rad: f64,
    /// Frequencies of the sinusoids summed for each angle, Hz.
    pub frequencies_hz: Vec<f64>,
}

impl Default for SwayConfig {
    fn default() -> Self {
        Self {
            roll_amplitude_rad: 0.5f64.to_radians(),
            pitch_amplitude_rad: 0.3f64.to_radians(),
            yaw_amplitude_rad: 0.2f64.to_radians(),
            frequencies_hz: vec![0.05, 0.13, 0.31],
        }
    }
}

/// One sinusoid of the sway: `amplitude · sin(2π f t + phase)`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Component {
    amplitude_rad: f64,
    frequency_hz: f64,
    phase_rad: f64,
}

/// Attitude sway of one flight line: for roll, pitch and yaw a sum of
/// sinusoids with seeded random phases. Component `j` gets the weight
/// `1/(j+1)` (slow motions are the larger ones), normalised so that the
/// weights sum to one and the angle never exceeds its amplitude.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Sway {
    axes: [Vec<Component>; 3],
}

impl Sway {
    /// Sway of flight line `line`, random phases drawn from the stream
    /// `(seed, line, 0, Sway)`.
    pub fn new(config: &SwayConfig, seed: u64, line: u32) -> Self {
        let mut rng = Stream::new(seed, line, 0, Purpose::Sway);
        let weights: Vec<f64> = (0..config.frequencies_hz.len())
            .map(|j| 1.0 / (j as f64 + 1.0))
            .collect();
        let total: f64 = weights.iter().sum();
        let amps = [
            config.roll_amplitude_rad,
            config.pitch_amplitude_rad,
            config.yaw_amplitude_rad,
        ];
        let axes = amps.map(|a| {
            config
                .frequencies_hz
                .iter()
                .zip(&weights)
                .map(|(&f, &w)| Component {
                    amplitude_rad: a * w / total,
                    frequency_hz: f,
                    phase_rad: rng.uniform() * std::f64::consts::TAU,
                })
                .collect()
        });
        Self { axes }
    }

    /// `(roll, pitch, yaw)` offsets at time `t_s` since the line start, rad.
    pub fn angles_at(&self, t_s: f64) -> [f64; 3] {
        self.axes.each_ref().map(|comps| {
            comps
                .iter()
                .map(|c| {
                    c.amplitude_rad
                        * (std::f64::consts::TAU * c.frequency_hz * t_s + c.phase_rad).sin()
                })
                .sum()
        })
    }
}

/// A straight flight line flown at constant speed.
#[derive(Clone, Debug, PartialEq)]
pub struct FlightLine {
    /// Line number (0-based); the LAS point source ID is this plus one.
    pub index: u32,
    /// Sensor position at the start, m.
    pub start_m: DVec3,
    /// Sensor position at the end, m.
    pub end_m: DVec3,
    /// Ground speed, m/s.
    pub speed_mps: f64,
    /// Time of the start of the line since the start of the flight, s.
    pub start_time_s: f64,
    /// Sway of this line (`None`: level, steady flight).
    pub sway: Option<Sway>,
    /// Correlated GNSS/IMU errors of this line (empty: none).
    pub nav_errors: crate::navigation::LineErrors,
}

impl FlightLine {
    /// Length, m.
    pub fn length_m(&self) -> f64 {
        (self.end_m - self.start_m).length()
    }

    /// Duration, s.
    pub fn duration_s(&self) -> f64 {
        self.length_m() / self.speed_mps
    }

    /// Heading (yaw) of the line: 0 = north, counter-clockwise positive, rad.
    pub fn heading_rad(&self) -> f64 {
        let d = self.end_m - self.start_m;
        (-d.x).atan2(d.y)
    }

    /// Pose at `t_s` seconds after the line start: position on the line,
    /// heading of the line, and the sway if any. The scanner is held level
    /// on a climbing or descending line (nominal roll and pitch zero).
    pub fn pose_at(&self, t_s: f64) -> Pose {
        let dir = (self.end_m - self.start_m) / self.length_m();
        let position_m = self.start_m + dir * (self.speed_mps * t_s);
        let [roll, pitch, yaw] = self.sway.as_ref().map_or([0.0; 3], |s| s.angles_at(t_s));
        Pose {
            position_m,
            attitude: Attitude {
                roll_rad: roll,
                pitch_rad: pitch,
                yaw_rad: self.heading_rad() + yaw,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(start: DVec3, end: DVec3) -> FlightLine {
        FlightLine {
            index: 0,
            start_m: start,
            end_m: end,
            speed_mps: 50.0,
            start_time_s: 0.0,
            sway: None,
            nav_errors: Default::default(),
        }
    }

    #[test]
    fn straight_line_positions_and_headings() {
        let l = line(
            DVec3::new(0.0, -500.0, 1000.0),
            DVec3::new(0.0, 500.0, 1000.0),
        );
        assert_eq!(l.duration_s(), 20.0);
        let p = l.pose_at(4.0);
        assert!((p.position_m - DVec3::new(0.0, -300.0, 1000.0)).length() < 1e-12);
        assert!(p.attitude.yaw_rad.abs() < 1e-15);
        let east = line(DVec3::ZERO, DVec3::new(100.0, 0.0, 0.0));
        assert!((east.heading_rad() + std::f64::consts::FRAC_PI_2).abs() < 1e-15);
        let sw = line(DVec3::ZERO, DVec3::new(-1.0, -1.0, 0.0));
        assert!((sw.heading_rad() - 0.75 * std::f64::consts::PI).abs() < 1e-15);
    }

    #[test]
    fn sway_is_bounded_seeded_and_moves() {
        let cfg = SwayConfig::default();
        let a = Sway::new(&cfg, 7, 0);
        assert_eq!(a, Sway::new(&cfg, 7, 0));
        assert_ne!(a, Sway::new(&cfg, 8, 0));
        assert_ne!(a, Sway::new(&cfg, 7, 1));
        let mut max = [0.0f64; 3];
        let mut min = [0.0f64; 3];
        for k in 0..20_000 {
            let ang = a.angles_at(k as f64 * 0.01);
            for i in 0..3 {
                max[i] = max[i].max(ang[i]);
                min[i] = min[i].min(ang[i]);
            }
        }
        let amp = [
            cfg.roll_amplitude_rad,
            cfg.pitch_amplitude_rad,
            cfg.yaw_amplitude_rad,
        ];
        for i in 0..3 {
            assert!(max[i] <= amp[i] + 1e-15 && min[i] >= -amp[i] - 1e-15);
            // Over 200 s the sum of sinusoids swings through most of its range.
            assert!(max[i] - min[i] > amp[i]);
        }
    }
}

//! The aircraft: straight flight lines and attitude sway.
//!
//! Everything here is a pure function of time (`pose_at`), never a stepping
//! state machine. Specification, "Computing the trajectory and current
//! attitude of the LiDAR": `P(t) = P_start + v·dir·t` along a straight line,
//! and small attitude changes "using simple trigonometric functions with
//! randomized coefficients" (Fig. 10).

use std::sync::Arc;

use glam::{DQuat, EulerRot};

use super::Pose;
use crate::geometry::{Attitude, DVec3, forward_of, right_of};
use crate::rng::{Purpose, Stream};

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
    pub nav_errors: crate::sensor::navigation::LineErrors,
    /// Slow lateral and vertical drift of the flown path (turbulence).
    pub drift: Option<Drift>,
    /// A recorded trajectory replacing the straight line (from a trajectory
    /// file); `start_m`, `end_m` and `speed_mps` then summarise it.
    pub track: Option<Arc<Track>>,
}

impl FlightLine {
    /// Length, m.
    pub fn length_m(&self) -> f64 {
        (self.end_m - self.start_m).length()
    }

    /// Duration, s.
    pub fn duration_s(&self) -> f64 {
        match &self.track {
            Some(track) => track.duration_s(),
            None => self.length_m() / self.speed_mps,
        }
    }

    /// Heading (yaw) of the line: 0 = north, counter-clockwise positive, rad.
    pub fn heading_rad(&self) -> f64 {
        let d = self.end_m - self.start_m;
        (-d.x).atan2(d.y)
    }

    /// The constants of the line's poses, for [`FlightLine::pose_in`].
    pub fn frame(&self) -> LineFrame {
        LineFrame {
            dir: (self.end_m - self.start_m) / self.length_m(),
            heading_rad: self.heading_rad(),
        }
    }

    /// Pose at `t_s` seconds after the line start: position on the line,
    /// heading of the line, and the sway if any. The scanner is held level
    /// on a climbing or descending line (nominal roll and pitch zero).
    pub fn pose_at(&self, t_s: f64) -> Pose {
        self.pose_in(&self.frame(), t_s)
    }

    /// [`FlightLine::pose_at`] with the line's [`FlightLine::frame`]
    /// computed beforehand (the same pose, to the bit).
    pub fn pose_in(&self, frame: &LineFrame, t_s: f64) -> Pose {
        if let Some(track) = &self.track {
            return track.pose_at(t_s);
        }
        let dir = frame.dir;
        let mut position_m = self.start_m + dir * (self.speed_mps * t_s);
        let heading = frame.heading_rad;
        if let Some(d) = &self.drift {
            let [lateral, vertical] = d.offsets_at(t_s);
            position_m += right_of(heading) * lateral + DVec3::Z * vertical;
        }
        let [roll, pitch, yaw] = self.sway.as_ref().map_or([0.0; 3], |s| s.angles_at(t_s));
        Pose {
            position_m,
            attitude: Attitude {
                roll_rad: roll,
                pitch_rad: pitch,
                yaw_rad: heading + yaw,
            },
        }
    }
}

/// The constants of a straight line's poses ([`FlightLine::frame`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineFrame {
    /// Unit direction from start to end.
    dir: DVec3,
    /// [`FlightLine::heading_rad`].
    heading_rad: f64,
}

/// The settings of turbulence drift (`[platform] drift_m`,
/// `drift_period_s`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriftConfig {
    /// Peak lateral and vertical drift, m.
    pub amplitude_m: [f64; 2],
    /// The longest period, s.
    pub period_s: f64,
}

/// Slow drift of the aircraft off its planned line (turbulence): lateral
/// and vertical offsets as sums of three long-period sinusoids with seeded
/// phases, weighted 1, 1/2, 1/3 and scaled to the peak amplitudes.
#[derive(Clone, Debug, PartialEq)]
pub struct Drift {
    components: [Vec<(f64, f64, f64)>; 2],
}

impl Drift {
    /// Drift of line `line` with peak amplitudes `[lateral, vertical]` (m)
    /// and longest period `period_s`, phases from `(seed, line, 1, Sway)`.
    pub fn new(amplitude_m: [f64; 2], period_s: f64, seed: u64, line: u32) -> Self {
        let mut rng = Stream::new(seed, line, 1, Purpose::Sway);
        let weights = [1.0, 0.5, 1.0 / 3.0];
        let total: f64 = weights.iter().sum();
        let components = amplitude_m.map(|a| {
            weights
                .iter()
                .enumerate()
                .map(|(j, w)| {
                    let f = (j as f64 + 1.0) * 1.37f64.powi(j as i32) / period_s;
                    (a * w / total, f, rng.uniform() * std::f64::consts::TAU)
                })
                .collect()
        });
        Self { components }
    }

    /// `[lateral, vertical]` offsets at `t_s`, m.
    pub fn offsets_at(&self, t_s: f64) -> [f64; 2] {
        self.components.each_ref().map(|c| {
            c.iter()
                .map(|(a, f, ph)| a * (std::f64::consts::TAU * f * t_s + ph).sin())
                .sum()
        })
    }
}

/// Interpolation of trajectory positions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    /// Straight between samples.
    Linear,
    /// Cubic Hermite with Catmull–Rom tangents from the neighbouring
    /// samples (non-uniform times): smooth velocity through the samples.
    Spline,
}

/// A recorded trajectory segment: positions and attitudes at times since
/// its start. Attitudes are interpolated by quaternion slerp.
#[derive(Clone, Debug, PartialEq)]
pub struct Track {
    times_s: Vec<f64>,
    positions_m: Vec<DVec3>,
    rotations: Vec<DQuat>,
    interpolation: Interpolation,
}

impl Track {
    /// A track from samples `(time since start, position, attitude)`
    /// sorted by time; at least two samples with increasing times.
    pub fn new(samples: &[(f64, DVec3, Attitude)], interpolation: Interpolation) -> Option<Self> {
        if samples.len() < 2 || samples.windows(2).any(|w| w[1].0 <= w[0].0) {
            return None;
        }
        let t0 = samples[0].0;
        Some(Self {
            times_s: samples.iter().map(|s| s.0 - t0).collect(),
            positions_m: samples.iter().map(|s| s.1).collect(),
            rotations: samples
                .iter()
                .map(|s| DQuat::from_mat3(&s.2.body_to_world()))
                .collect(),
            interpolation,
        })
    }

    /// Duration, s.
    pub fn duration_s(&self) -> f64 {
        self.times_s[self.times_s.len() - 1]
    }

    /// First and last position.
    pub fn ends(&self) -> (DVec3, DVec3) {
        (
            self.positions_m[0],
            self.positions_m[self.positions_m.len() - 1],
        )
    }

    /// Length along the samples, m.
    pub fn length_m(&self) -> f64 {
        self.positions_m
            .windows(2)
            .map(|w| (w[1] - w[0]).length())
            .sum()
    }

    /// Pose at `t_s` since the start (clamped to the track).
    pub fn pose_at(&self, t_s: f64) -> Pose {
        let n = self.times_s.len();
        let t = t_s.clamp(0.0, self.duration_s());
        let i = self.times_s.partition_point(|&x| x <= t).clamp(1, n - 1) - 1;
        let (t0, t1) = (self.times_s[i], self.times_s[i + 1]);
        let u = (t - t0) / (t1 - t0);
        let (p0, p1) = (self.positions_m[i], self.positions_m[i + 1]);
        let position_m = match self.interpolation {
            Interpolation::Linear => p0.lerp(p1, u),
            Interpolation::Spline => {
                // Catmull–Rom tangents (per second) at both ends, one-sided
                // at the track's ends.
                let tangent = |k: usize| {
                    let (a, b) = (k.saturating_sub(1), (k + 1).min(n - 1));
                    (self.positions_m[b] - self.positions_m[a])
                        / (self.times_s[b] - self.times_s[a])
                };
                let h = t1 - t0;
                let (m0, m1) = (tangent(i) * h, tangent(i + 1) * h);
                let (u2, u3) = (u * u, u * u * u);
                p0 * (2.0 * u3 - 3.0 * u2 + 1.0)
                    + m0 * (u3 - 2.0 * u2 + u)
                    + p1 * (-2.0 * u3 + 3.0 * u2)
                    + m1 * (u3 - u2)
            }
        };
        let q = self.rotations[i].slerp(self.rotations[i + 1], u);
        // Rz(yaw)·Rx(pitch)·Ry(roll) is glam's intrinsic ZXY order.
        let (yaw, pitch, roll) = q.to_euler(EulerRot::ZXY);
        Pose {
            position_m,
            attitude: Attitude {
                roll_rad: roll,
                pitch_rad: pitch,
                yaw_rad: yaw,
            },
        }
    }
}

/// The smallest and largest across-track coordinate of `area` for lines
/// flown at `heading_rad`.
fn across_extent(area: &[[f64; 2]], heading_rad: f64) -> (f64, f64) {
    let right = right_of(heading_rad);
    area.iter()
        .map(|p| p[0] * right.x + p[1] * right.y)
        .fold((f64::MAX, f64::MIN), |(lo, hi), u| (lo.min(u), hi.max(u)))
}

/// How many lines [`plan_lines`] gives for `area` at `heading_rad` and
/// `spacing_m` (a float, so that absurd spacings can be refused before
/// any line is made).
pub fn plan_line_count(area: &[[f64; 2]], heading_rad: f64, spacing_m: f64) -> f64 {
    let (u0, u1) = across_extent(area, heading_rad);
    ((u1 - u0) / spacing_m - 1e-9).ceil().max(1.0)
}

/// Straight, parallel flight lines covering an area, flown back and forth
/// (a boustrophedon). `heading_rad` uses the yaw convention (0 = north,
/// counter-clockwise); `spacing_m` is the distance between lines; lines
/// run `run_in_m` beyond the area at both ends. Returns `(start, end)` pairs
/// at height `z_m`.
pub fn plan_lines(
    area: &[[f64; 2]],
    heading_rad: f64,
    spacing_m: f64,
    run_in_m: f64,
    z_m: f64,
) -> Vec<(DVec3, DVec3)> {
    let (fwd, right) = (forward_of(heading_rad), right_of(heading_rad));
    let to_uv = |p: [f64; 2]| (p[0] * right.x + p[1] * right.y, p[0] * fwd.x + p[1] * fwd.y);
    let uv: Vec<(f64, f64)> = area.iter().map(|p| to_uv(*p)).collect();
    let (u0, u1) = across_extent(area, heading_rad);
    let n = plan_line_count(area, heading_rad, spacing_m) as usize;
    // Centre the lines on the area's across-track extent.
    let first = 0.5 * (u0 + u1) - 0.5 * (n as f64 - 1.0) * spacing_m;
    let mut lines = Vec::new();
    for k in 0..n {
        let u = first + k as f64 * spacing_m;
        // Along-track extent of the area at this u (edge crossings).
        let mut vs = Vec::new();
        for j in 0..uv.len() {
            let (a, b) = (uv[j], uv[(j + 1) % uv.len()]);
            if (a.0 - u) * (b.0 - u) <= 0.0 && a.0 != b.0 {
                vs.push(a.1 + (u - a.0) / (b.0 - a.0) * (b.1 - a.1));
            }
        }
        if vs.is_empty() {
            // Outside a concave or narrow area: fall back to the full extent.
            vs.extend(uv.iter().map(|p| p.1));
        }
        let v0 = vs.iter().cloned().fold(f64::MAX, f64::min) - run_in_m;
        let v1 = vs.iter().cloned().fold(f64::MIN, f64::max) + run_in_m;
        let at = |v: f64| {
            let p = right * u + fwd * v;
            DVec3::new(p.x, p.y, z_m)
        };
        let (s, e) = if k % 2 == 0 {
            (at(v0), at(v1))
        } else {
            (at(v1), at(v0))
        };
        lines.push((s, e));
    }
    lines
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A level line without sway, drift or errors, at 50 m/s.
    pub(crate) fn line(start: DVec3, end: DVec3) -> FlightLine {
        FlightLine {
            index: 0,
            start_m: start,
            end_m: end,
            speed_mps: 50.0,
            start_time_s: 0.0,
            sway: None,
            nav_errors: Default::default(),
            drift: None,
            track: None,
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
    fn track_interpolation_and_slerp() {
        let att = |r: f64, p: f64, y: f64| Attitude {
            roll_rad: r,
            pitch_rad: p,
            yaw_rad: y,
        };
        let samples = [
            (10.0, DVec3::new(0.0, 0.0, 100.0), att(0.0, 0.0, 0.0)),
            (11.0, DVec3::new(0.0, 10.0, 100.0), att(0.02, 0.0, 0.1)),
            (12.0, DVec3::new(0.0, 20.0, 100.0), att(0.04, 0.01, 0.2)),
            (13.0, DVec3::new(0.0, 30.0, 101.0), att(0.02, 0.0, 0.3)),
        ];
        let lin = Track::new(&samples, Interpolation::Linear).unwrap();
        assert_eq!(lin.duration_s(), 3.0);
        let p = lin.pose_at(0.5);
        assert!((p.position_m - DVec3::new(0.0, 5.0, 100.0)).length() < 1e-12);
        // Slerp between small rotations about one axis at a time: halfway.
        assert!((p.attitude.roll_rad - 0.01).abs() < 1e-4);
        assert!((p.attitude.yaw_rad - 0.05).abs() < 1e-4);
        // At the samples the attitude comes back exactly (ZXY round trip).
        let q = lin.pose_at(2.0);
        assert!((q.attitude.roll_rad - 0.04).abs() < 1e-12);
        assert!((q.attitude.pitch_rad - 0.01).abs() < 1e-12);
        assert!((q.attitude.yaw_rad - 0.2).abs() < 1e-12);
        // The spline passes through the samples and is smooth: on a
        // uniform straight run it equals the linear interpolation.
        let spl = Track::new(&samples, Interpolation::Spline).unwrap();
        for t in [0.0, 1.0, 2.0, 3.0] {
            assert!((spl.pose_at(t).position_m - lin.pose_at(t).position_m).length() < 1e-12);
        }
        assert!((spl.pose_at(0.5).position_m.y - 5.0).abs() < 1e-9);
        assert!(Track::new(&samples[..1], Interpolation::Linear).is_none());
    }

    #[test]
    fn planned_lines_cover_the_area() {
        let area = [[0.0, 0.0], [300.0, 0.0], [300.0, 200.0], [0.0, 200.0]];
        // Northbound lines 50 m apart over a 300 m wide area: 6 lines.
        let lines = plan_lines(&area, 0.0, 50.0, 20.0, 500.0);
        assert_eq!(lines.len(), 6);
        assert!((lines[0].0 - DVec3::new(25.0, -20.0, 500.0)).length() < 1e-9);
        assert!((lines[0].1 - DVec3::new(25.0, 220.0, 500.0)).length() < 1e-9);
        // Back and forth.
        assert!((lines[1].0 - DVec3::new(75.0, 220.0, 500.0)).length() < 1e-9);
        // Eastbound (yaw −90°): lines run along x, spaced in y.
        let east = plan_lines(&area, -std::f64::consts::FRAC_PI_2, 50.0, 0.0, 500.0);
        assert_eq!(east.len(), 4);
        assert!((east[0].1.x - east[0].0.x - 300.0).abs() < 1e-9);
    }

    #[test]
    fn drift_is_bounded_and_moves_the_path() {
        let d = Drift::new([3.0, 1.0], 20.0, 4, 0);
        let mut max = [0.0f64; 2];
        for k in 0..10_000 {
            let o = d.offsets_at(k as f64 * 0.01);
            max[0] = max[0].max(o[0].abs());
            max[1] = max[1].max(o[1].abs());
        }
        assert!(max[0] <= 3.0 + 1e-12 && max[0] > 1.0);
        assert!(max[1] <= 1.0 + 1e-12 && max[1] > 0.3);
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

//! Risley prisms (Livox Mid and Avia, DJI Zenmuse L1): two or three wedge
//! prisms turning about the optical axis at different rates. To first
//! order each prism turns the beam by its deviation `δ_i` towards its
//! current azimuth, and the deviations add as vectors: the beam's angular
//! offset from the axis is
//!
//! `a(t) = Σ_i δ_i (cos 2π f_i t, sin 2π f_i t)`,
//!
//! a rosette that fills the disk of radius `Σ δ_i` (the field of view is
//! twice that), with a hole of radius `|δ_1 − δ_2|` for two prisms of
//! unequal deviation. With rotor frequencies in a rational ratio the
//! pattern repeats after `1 / gcd(f_1, f_2)` seconds. (For thick prisms the
//! exact deviation of each follows from Snell's law; the deviations here
//! are the effective ones, set so that the field of view is the
//! instrument's.)

use crate::geometry::DVec3;
use std::f64::consts::TAU;

/// One prism.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prism {
    /// Deviation of the beam by the prism, rad.
    pub deviation_rad: f64,
    /// Turns per second, Hz; negative turns the other way.
    pub frequency_hz: f64,
}

/// A Risley prism scanner.
#[derive(Clone, Debug, PartialEq)]
pub struct Risley {
    /// The prisms, from the laser out (two or three).
    pub prisms: Vec<Prism>,
}

impl Risley {
    /// The beam's angular offset from the axis at `t_s`, rad (x, y).
    pub fn offset_at(&self, t_s: f64) -> [f64; 2] {
        self.prisms.iter().fold([0.0, 0.0], |[x, y], p| {
            let turns = p.frequency_hz * t_s;
            let (s, c) = (TAU * (turns - turns.floor())).sin_cos();
            [x + p.deviation_rad * c, y + p.deviation_rad * s]
        })
    }

    /// Unit beam direction at `t_s`: `|a|` from the axis towards the
    /// azimuth of `a`.
    pub fn direction_at(&self, t_s: f64) -> DVec3 {
        let [x, y] = self.offset_at(t_s);
        let r = x.hypot(y);
        if r == 0.0 {
            return DVec3::Z;
        }
        let s = r.sin() / r;
        DVec3::new(x * s, y * s, r.cos())
    }

    /// Half of the field of view, `Σ δ_i`, rad.
    pub fn half_field_of_view_rad(&self) -> f64 {
        self.prisms.iter().map(|p| p.deviation_rad).sum()
    }

    /// The rate at which the rosette's lobes pass a fixed azimuth,
    /// `|f_1 − f_2|`, Hz; rotors turning together trace a circle, which
    /// passes at their rate (as a Palmer scanner's does).
    pub fn lobe_rate_hz(&self) -> f64 {
        match self.prisms.as_slice() {
            [a, b, ..] if a.frequency_hz == b.frequency_hz => a.frequency_hz.abs(),
            [a, b, ..] => (a.frequency_hz - b.frequency_hz).abs(),
            [a] => a.frequency_hz.abs(),
            [] => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rotors at 300 and −200 Hz: the rosette repeats every
    /// 1/gcd(300, 200) = 10 ms, and not within half of that; the offset
    /// stays within [δ1 − δ2, δ1 + δ2] and its extremes are reached when
    /// the prisms line up (t = 0) and when they oppose (t = 1/1000 s:
    /// 300·t − (−200·t) = ½ turn).
    #[test]
    fn rosette_period_and_radii() {
        let r = Risley {
            prisms: vec![
                Prism {
                    deviation_rad: 0.3,
                    frequency_hz: 300.0,
                },
                Prism {
                    deviation_rad: 0.1,
                    frequency_hz: -200.0,
                },
            ],
        };
        let radius = |t: f64| {
            let [x, y] = r.offset_at(t);
            x.hypot(y)
        };
        for k in 0..500 {
            let t = k as f64 * 1.37e-5;
            let (a, b) = (r.direction_at(t), r.direction_at(t + 0.01));
            assert!(a.angle_between(b) < 1e-9, "{t}");
            assert!((0.2 - 1e-12..=0.4 + 1e-12).contains(&radius(t)));
        }
        assert!(r.direction_at(0.0).angle_between(r.direction_at(0.005)) > 0.1);
        assert!((radius(0.0) - 0.4).abs() < 1e-12);
        assert!((radius(0.001) - 0.2).abs() < 1e-12);
        // The beam's angle from the axis is the offset's length.
        assert!((r.direction_at(0.0).z - 0.4f64.cos()).abs() < 1e-12);
        assert!((r.half_field_of_view_rad() - 0.4).abs() < 1e-15);
    }
}

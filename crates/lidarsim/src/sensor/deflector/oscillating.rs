//! The oscillating mirror (the specification's scanner).
//!
//! Specification, "Mirror" and Fig. 8/9: the mirror turns about the scanner
//! `y` axis (flight direction), so the beam leaves the scanner in direction
//! `(sin θ, 0, cos θ)` for deflection θ (x left, z down). One mirror cycle is
//! middle → left → right → middle. Pulses leave at integer ticks
//! `t_k = t_0 + k / PRF` ("Time is described in ticks").

use crate::geometry::DVec3;

/// Mirror motion profile.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MirrorProfile {
    /// Constant angular speed between the turning points (a zig-zag):
    /// footprints evenly spaced in angle across the swath.
    Triangle,
    /// Sinusoidal motion: dense at the swath edges, sparse at nadir.
    Sine,
}

/// An oscillating mirror.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mirror {
    /// Motion profile.
    pub profile: MirrorProfile,
    /// Full mirror cycles per second, Hz.
    pub scan_frequency_hz: f64,
    /// Half of the angular range the beam sweeps, rad.
    pub scan_half_angle_rad: f64,
}

impl Mirror {
    /// Phase of the cycle in `[0, 1)` at time `t_s`.
    #[inline]
    fn phase(&self, t_s: f64) -> f64 {
        let p = (self.scan_frequency_hz * t_s).fract();
        if p < 0.0 { p + 1.0 } else { p }
    }

    /// Beam deflection θ at time `t_s`, rad; positive to the left.
    #[inline]
    pub fn angle_at(&self, t_s: f64) -> f64 {
        let p = self.phase(t_s);
        let shape = match self.profile {
            MirrorProfile::Triangle => {
                if p < 0.25 {
                    4.0 * p
                } else if p < 0.75 {
                    2.0 - 4.0 * p
                } else {
                    4.0 * p - 4.0
                }
            }
            MirrorProfile::Sine => (std::f64::consts::TAU * p).sin(),
        };
        self.scan_half_angle_rad * shape
    }

    /// True while the deflection is increasing (beam moving left).
    #[inline]
    pub fn moving_left_at(&self, t_s: f64) -> bool {
        let p = self.phase(t_s);
        match self.profile {
            MirrorProfile::Triangle => !(0.25..0.75).contains(&p),
            MirrorProfile::Sine => (std::f64::consts::TAU * p).cos() > 0.0,
        }
    }

    /// Unit beam direction in the scanner frame for deflection `theta_rad`.
    #[inline]
    pub fn beam_direction(theta_rad: f64) -> DVec3 {
        DVec3::new(theta_rad.sin(), 0.0, theta_rad.cos())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangle_mirror_profile() {
        let m = Mirror {
            profile: MirrorProfile::Triangle,
            scan_frequency_hz: 50.0,
            scan_half_angle_rad: 0.3,
        };
        let period = 1.0 / 50.0;
        assert_eq!(m.angle_at(0.0), 0.0);
        assert!((m.angle_at(period / 4.0) - 0.3).abs() < 1e-12);
        assert!((m.angle_at(period / 2.0)).abs() < 1e-12);
        assert!((m.angle_at(3.0 * period / 4.0) + 0.3).abs() < 1e-12);
        // Constant angular speed: 4 θmax f.
        let w = (m.angle_at(0.001) - m.angle_at(0.0)) / 0.001;
        assert!((w - 4.0 * 0.3 * 50.0).abs() < 1e-9);
        assert!(m.moving_left_at(0.001));
        assert!(!m.moving_left_at(period / 2.0));
    }

    #[test]
    fn sine_mirror_profile() {
        let m = Mirror {
            profile: MirrorProfile::Sine,
            scan_frequency_hz: 40.0,
            scan_half_angle_rad: 0.2,
        };
        for k in 0..100 {
            let t = k as f64 * 0.000731;
            let want = 0.2 * (std::f64::consts::TAU * 40.0 * t).sin();
            assert!((m.angle_at(t) - want).abs() < 1e-12);
        }
    }
}

//! The Palmer (conic) scanner (RIEGL VQ-880-G and VQ-840-G, bathymetric
//! and some topographic sensors): a mirror tilted by `γ` from
//! perpendicular to a shaft along the nadir axis. Turning the shaft swings
//! the reflected beam around a cone of half-angle `2γ`: a circle on flat
//! ground, or — with the mirror's geometry or an added wobble — an
//! ellipse of half-angles `β_x` across and `β_y` along the track.
//!
//! The beam's direction at azimuth `φ = 2π f t` (from the left, `x`,
//! towards the flight direction, `y`) is along
//! `(tan β_x cos φ, tan β_y sin φ, 1)`: over flat ground at height `H` its
//! spot lies on the ellipse of semi-axes `H tan β_x`, `H tan β_y` about the
//! nadir point. Every spot of the swath is passed twice: once by the
//! forward half of the turn (`sin φ > 0`) ahead of the aircraft and once by
//! the backward half behind it.

use crate::geometry::DVec3;
use std::f64::consts::TAU;

/// A Palmer scanner.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Palmer {
    /// Turns of the shaft per second, Hz.
    pub rotation_hz: f64,
    /// Half-angle of the cone across the track, `β_x`, rad.
    pub across_half_angle_rad: f64,
    /// Half-angle of the cone along the track, `β_y`, rad (`β_x` for a
    /// circle).
    pub along_half_angle_rad: f64,
}

impl Palmer {
    /// Azimuth of the beam at `t_s`, rad.
    fn azimuth(&self, t_s: f64) -> f64 {
        let x = self.rotation_hz * t_s;
        TAU * (x - x.floor())
    }

    /// Unit beam direction at `t_s`.
    pub fn direction_at(&self, t_s: f64) -> DVec3 {
        let (s, c) = self.azimuth(t_s).sin_cos();
        DVec3::new(
            self.across_half_angle_rad.tan() * c,
            self.along_half_angle_rad.tan() * s,
            1.0,
        )
        .normalize()
    }

    /// Whether the beam looks ahead of the aircraft at `t_s`.
    pub fn looking_forward_at(&self, t_s: f64) -> bool {
        self.azimuth(t_s) < TAU / 2.0
    }
}

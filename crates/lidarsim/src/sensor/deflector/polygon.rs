//! The rotating polygon mirror (RIEGL VQ and VUX series, Optech's
//! polygon units): a prism of `N` mirror facets turning at a constant
//! rate. Turning a mirror by `α` turns the reflected beam by `2α`, so while
//! one facet passes the beam the beam sweeps `Θ = 2 · 360°/N` across the
//! track; then the next facet takes over and the sweep starts again from
//! the same side. Scan lines are therefore parallel and all run the same
//! way, one per facet: `N · f_rot` lines per second.
//!
//! Only part of each sweep looks down into the field of view (the
//! effective scan angle `±θ_eff`); the laser fires only then, so
//! `2θ_eff / Θ` of the pulse slots carry pulses.

use std::f64::consts::TAU;

/// A rotating polygon mirror.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Polygon {
    /// Mirror facets `N`.
    pub facets: u32,
    /// Scan lines per second (`N` times the rotation rate), Hz.
    pub line_rate_hz: f64,
    /// Half of the effective scan angle, rad: pulses leave while the
    /// deflection is within `±` this.
    pub scan_half_angle_rad: f64,
}

impl Polygon {
    /// The beam's sweep per facet, `Θ = 2 · 2π/N`, rad.
    pub fn sweep_rad(&self) -> f64 {
        2.0 * TAU / f64::from(self.facets)
    }

    /// Index of the scan line (facet pass) at `t_s`.
    pub fn line_at(&self, t_s: f64) -> i64 {
        (self.line_rate_hz * t_s).floor() as i64
    }

    /// Deflection at `t_s`, rad, positive to the left: from `+Θ/2` (left)
    /// to `−Θ/2` (right) over each line, then back to `+Θ/2`.
    pub fn angle_at(&self, t_s: f64) -> f64 {
        let x = self.line_rate_hz * t_s;
        self.sweep_rad() * (0.5 - (x - x.floor()))
    }

    /// Whether the facet looks into the field of view at `t_s`.
    pub fn emits_at(&self, t_s: f64) -> bool {
        self.angle_at(t_s).abs() <= self.scan_half_angle_rad
    }

    /// Share of time the facet looks into the field of view.
    pub fn emitted_share(&self) -> f64 {
        (2.0 * self.scan_half_angle_rad / self.sweep_rad()).min(1.0)
    }
}

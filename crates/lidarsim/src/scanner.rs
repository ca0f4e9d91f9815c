//! The scanner: oscillating mirror, pulse timing and the beam's sub-rays.
//!
//! Specification, "Mirror" and Fig. 8/9: the mirror turns about the scanner
//! `y` axis (flight direction), so the beam leaves the scanner in direction
//! `(sin θ, 0, cos θ)` for deflection θ (x left, z down). One mirror cycle is
//! middle → left → right → middle. Pulses leave at integer ticks
//! `t_k = t_0 + k / PRF` ("Time is described in ticks").

use crate::geometry::{DMat3, DVec3};

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

/// How the energy of a pulse is spread over its sub-rays.
///
/// The beam has a Gaussian irradiance profile `I(r) ∝ exp(−2 r²/w²)` whose
/// `1/e²` radius `w` is half the full divergence angle times the range (a
/// 0.3 mrad beam has a 30 cm footprint at 1 km: specification, "What is a
/// LiDAR?"). Sub-rays are placed so that each carries the same energy: ring
/// radii follow the inverse of the enclosed-power function
/// `P(r) = 1 − exp(−2 r²/w²)` (truncated at `w`, which holds 86.5 % of the
/// power), azimuths follow the golden angle (a Vogel sunflower). The density
/// of sub-rays is therefore proportional to the irradiance, "more sub-rays
/// near the centre of the footprint" (specification, Fig. 5), and every
/// sub-ray carries `1/N` of the pulse energy.
#[derive(Clone, Debug, PartialEq)]
pub struct BeamPattern {
    /// Offsets of the sub-rays from the central ray, as tangents of the
    /// off-axis angle along the two axes perpendicular to the beam.
    offsets: Vec<[f64; 2]>,
    /// Energy share of each sub-ray; sums to 1.
    weights: Vec<f64>,
    /// Unit directions of the undeflected beam.
    base: Vec<DVec3>,
}

impl BeamPattern {
    /// A pattern of `n ≥ 1` sub-rays for a beam of full divergence
    /// `divergence_rad`. With `n = 1` the single ray is the central ray.
    pub fn new(n: usize, divergence_rad: f64) -> Self {
        let n = n.max(1);
        if n == 1 {
            return Self::from_offsets(vec![[0.0, 0.0]]);
        }
        let half = 0.5 * divergence_rad;
        let p_max = 1.0 - (-2.0f64).exp();
        let golden = std::f64::consts::PI * (3.0 - 5.0f64.sqrt());
        let offsets = (0..n)
            .map(|i| {
                let u = (i as f64 + 0.5) / n as f64 * p_max;
                let r = half * (-(1.0 - u).ln() / 2.0).sqrt();
                let a = golden * i as f64;
                let t = r.tan();
                [t * a.cos(), t * a.sin()]
            })
            .collect();
        Self::from_offsets(offsets)
    }

    /// The pattern of equal-energy rays at the given offsets (tangents of
    /// the off-axis angles across and along).
    fn from_offsets(offsets: Vec<[f64; 2]>) -> Self {
        let n = offsets.len();
        // Directions for an undeflected beam (θ = 0: along +z, "across"
        // along +x, "along" along +y).
        let base = offsets
            .iter()
            .map(|o| DVec3::new(o[0], o[1], 1.0).normalize())
            .collect();
        Self {
            offsets,
            weights: vec![1.0 / n as f64; n],
            base,
        }
    }

    /// Number of sub-rays.
    pub fn len(&self) -> usize {
        self.offsets.len()
    }

    /// Always false: a pattern has at least one ray.
    pub fn is_empty(&self) -> bool {
        self.offsets.is_empty()
    }

    /// Energy share of each sub-ray (sums to one).
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    /// Off-axis angle of each sub-ray, rad.
    pub fn off_axis_angles(&self) -> impl Iterator<Item = f64> + '_ {
        self.offsets.iter().map(|o| o[0].hypot(o[1]).atan())
    }

    /// Sub-ray directions in the scanner frame around the beam of
    /// deflection `theta_rad`, written into `out` (unit vectors).
    pub fn directions(&self, theta_rad: f64, out: &mut Vec<DVec3>) {
        let m = Self::deflection(theta_rad);
        out.clear();
        out.extend(self.base.iter().map(|d| m * *d));
    }

    /// Rotation of the undeflected pattern to the deflection `theta_rad`
    /// (about the scanner's y axis): it takes +z to the beam direction
    /// [`Mirror::beam_direction`] and +x to the across-scan perpendicular
    /// `(cos θ, 0, −sin θ)`; the along-track axis +y stays.
    pub fn deflection(theta_rad: f64) -> DMat3 {
        let (s, c) = theta_rad.sin_cos();
        DMat3::from_cols(DVec3::new(c, 0.0, -s), DVec3::Y, DVec3::new(s, 0.0, c))
    }

    /// Sub-ray directions of the undeflected beam (θ = 0), unit vectors:
    /// [`BeamPattern::directions`] at `θ` is [`BeamPattern::deflection`]
    /// applied to these.
    pub fn base_directions(&self) -> &[DVec3] {
        &self.base
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

    #[test]
    fn beam_pattern_follows_gaussian_profile() {
        let div = 0.5e-3;
        let p = BeamPattern::new(2000, div);
        assert!((p.weights().iter().sum::<f64>() - 1.0).abs() < 1e-12);
        let angles: Vec<f64> = p.off_axis_angles().collect();
        // All inside the 1/e² cone.
        assert!(angles.iter().all(|&a| a <= div / 2.0 * (1.0 + 1e-9)));
        // Equal-energy rays: the fraction of rays within radius r equals the
        // truncated enclosed power (1 − e^{−2 r²/w²}) / (1 − e^{−2}).
        let w = div / 2.0;
        for frac in [0.25, 0.5, 0.75] {
            let r = frac * w;
            let want = (1.0 - (-2.0 * frac * frac).exp()) / (1.0 - (-2.0f64).exp());
            let got = angles.iter().filter(|&&a| a < r).count() as f64 / angles.len() as f64;
            assert!((got - want).abs() < 0.002, "r={frac}w: {got} vs {want}");
        }
        // Centred: the mean offset vanishes.
        let mut dirs = Vec::new();
        p.directions(0.0, &mut dirs);
        let mean = dirs.iter().copied().sum::<DVec3>() / dirs.len() as f64;
        assert!(mean.x.abs() < 0.01 * div && mean.y.abs() < 0.01 * div);
    }

    #[test]
    fn single_ray_is_central() {
        let p = BeamPattern::new(1, 1e-3);
        let mut dirs = Vec::new();
        p.directions(0.2, &mut dirs);
        assert_eq!(dirs.len(), 1);
        assert!((dirs[0] - Mirror::beam_direction(0.2)).length() < 1e-15);
    }
}

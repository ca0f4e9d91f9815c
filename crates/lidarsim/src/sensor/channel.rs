//! Channels of a multi-channel scanner (RIEGL VQ-1560i: two beams looking
//! 14° forward and 14° backward through one polygon; Optech Titan: three
//! wavelengths): each channel is the deflector's beam turned by its own
//! mounting rotation, with its own divergence and wavelength, and the
//! channels fire in a fixed cycle ([`FiringOrder`]): channel `c` fires
//! `n_c` of every `Σn` pulses, its share of the PRF, spread as evenly as
//! the cycle allows (equal shares: pulse `k` on channel `k mod C`).

use crate::geometry::{DMat3, DVec3};

/// Longest firing cycle, pulses (the sum of the channels'
/// `pulses_per_cycle`).
pub const MAX_CYCLE: u32 = 256;

/// One beam of the head: its mounting in the scanner frame (x left, y
/// forward, z down), its divergence and wavelength, and its share of the
/// pulses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Channel {
    /// Tilt of the beam along the track, rad: positive looks forward (the
    /// nadir beam turns towards +y).
    pub along_tilt_rad: f64,
    /// Turn of the beam about the scanner's z axis, rad: positive turns
    /// the forward direction towards the left.
    pub yaw_rad: f64,
    /// Full divergence across the track (1/e² of the peak irradiance), rad.
    pub divergence_rad: f64,
    /// Full divergence along the track, rad (`divergence_rad` for a round
    /// beam).
    pub divergence_along_rad: f64,
    /// Laser wavelength, nm: the reflectance of a material with a spectrum
    /// is taken at it.
    pub wavelength_nm: f64,
    /// Pulses this channel fires in each firing cycle.
    pub pulses_per_cycle: u32,
}

impl Channel {
    /// The single channel of most scanners: it looks where the deflector
    /// points and fires every pulse.
    pub fn straight(divergence_rad: f64, divergence_along_rad: f64, wavelength_nm: f64) -> Self {
        Self {
            along_tilt_rad: 0.0,
            yaw_rad: 0.0,
            divergence_rad,
            divergence_along_rad,
            wavelength_nm,
            pulses_per_cycle: 1,
        }
    }

    /// Whether the mounting leaves the deflector's beam as it is.
    pub fn is_straight(&self) -> bool {
        self.along_tilt_rad == 0.0 && self.yaw_rad == 0.0
    }

    /// Rotation from the deflector's frame to the scanner frame: the tilt
    /// about x (nadir `+z` to `(0, sin α, cos α)`), then the yaw about z
    /// (`+y` to `(sin ψ, cos ψ, 0)`).
    pub fn mount(&self) -> DMat3 {
        let (sa, ca) = self.along_tilt_rad.sin_cos();
        let (sy, cy) = self.yaw_rad.sin_cos();
        let tilt = DMat3::from_cols(DVec3::X, DVec3::new(0.0, ca, -sa), DVec3::new(0.0, sa, ca));
        let yaw = DMat3::from_cols(DVec3::new(cy, -sy, 0.0), DVec3::new(sy, cy, 0.0), DVec3::Z);
        yaw * tilt
    }
}

/// Which channel fires each pulse: a cycle of `Σ n_c` pulses in which
/// channel `c` fires `n_c`, each channel's pulses spread through the cycle
/// (smooth weighted round robin: at each pulse every channel gains its
/// `n_c` of credit and the one with most credit fires, paying `Σ n`; ties
/// go to the lower channel). Equal shares give `k mod C`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FiringOrder {
    cycle: Vec<u8>,
}

impl FiringOrder {
    /// The order of `channels`, each firing its `pulses_per_cycle` (at
    /// least 1; the cycle at most [`MAX_CYCLE`], which the survey check
    /// keeps).
    pub fn new(channels: &[Channel]) -> Self {
        let weights: Vec<i64> = channels
            .iter()
            .map(|c| i64::from(c.pulses_per_cycle.max(1)))
            .collect();
        let total: i64 = weights.iter().sum::<i64>().max(1);
        let mut credit = vec![0i64; weights.len()];
        let mut cycle = Vec::with_capacity(total as usize);
        for _ in 0..total {
            for (c, w) in credit.iter_mut().zip(&weights) {
                *c += w;
            }
            let best = (0..credit.len())
                .rev()
                .max_by_key(|&i| credit[i])
                .unwrap_or(0);
            credit[best] -= total;
            cycle.push(best as u8);
        }
        if cycle.is_empty() {
            cycle.push(0);
        }
        Self { cycle }
    }

    /// The channel that fires pulse `k`.
    #[inline]
    pub fn channel_of(&self, k: u64) -> usize {
        usize::from(self.cycle[(k % self.cycle.len() as u64) as usize])
    }

    /// Pulses in one cycle.
    pub fn len(&self) -> usize {
        self.cycle.len()
    }

    /// Never true: a cycle has at least one pulse.
    pub fn is_empty(&self) -> bool {
        self.cycle.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn channel(along_tilt_deg: f64, yaw_deg: f64, pulses_per_cycle: u32) -> Channel {
        Channel {
            along_tilt_rad: along_tilt_deg.to_radians(),
            yaw_rad: yaw_deg.to_radians(),
            pulses_per_cycle,
            ..Channel::straight(3e-4, 3e-4, 1064.0)
        }
    }

    #[test]
    fn tilt_and_yaw_turn_the_nadir_beam_as_documented() {
        let fwd = channel(14.0, 0.0, 1);
        let d = fwd.mount() * DVec3::Z;
        assert!(
            (d - DVec3::new(0.0, 14f64.to_radians().sin(), 14f64.to_radians().cos())).length()
                < 1e-12
        );
        let turned = Channel {
            yaw_rad: 0.3,
            ..channel(0.0, 0.0, 1)
        };
        let y = turned.mount() * DVec3::Y;
        assert!((y - DVec3::new(0.3f64.sin(), 0.3f64.cos(), 0.0)).length() < 1e-12);
        for c in [fwd, turned] {
            let m = c.mount();
            assert!((m.determinant() - 1.0).abs() < 1e-12);
            assert!((m * m.transpose()).abs_diff_eq(DMat3::IDENTITY, 1e-12));
            assert!(!c.is_straight());
        }
        let straight = Channel::straight(3e-4, 3e-4, 1064.0);
        assert!(straight.is_straight());
        assert_eq!(straight.mount(), DMat3::IDENTITY);
    }

    #[test]
    fn equal_shares_fire_in_turn() {
        for n in 1..=4 {
            let order = FiringOrder::new(&vec![channel(0.0, 0.0, 1); n]);
            assert_eq!(order.len(), n);
            for k in 0..20u64 {
                assert_eq!(order.channel_of(k), (k % n as u64) as usize);
            }
        }
    }

    /// Each channel fires its share of every cycle, and of every stretch
    /// of pulses from the start to within one pulse: after `m` pulses
    /// channel `c` has fired `m·n_c/Σn` rounded up or down.
    #[test]
    fn unequal_shares_are_spread_through_the_cycle() {
        for weights in [vec![2, 1], vec![3, 1, 2], vec![1, 7], vec![5, 5, 1, 1]] {
            let chans: Vec<_> = weights.iter().map(|&w| channel(0.0, 0.0, w)).collect();
            let order = FiringOrder::new(&chans);
            let total: u32 = weights.iter().sum();
            assert_eq!(order.len(), total as usize);
            let mut fired = vec![0u32; weights.len()];
            for m in 1..=(3 * total as u64) {
                fired[order.channel_of(m - 1)] += 1;
                for (c, &w) in weights.iter().enumerate() {
                    let want = m as f64 * f64::from(w) / f64::from(total);
                    assert!(
                        (f64::from(fired[c]) - want).abs() < 1.0,
                        "{weights:?}: channel {c} fired {} of {m}, share {want}",
                        fired[c]
                    );
                }
            }
        }
    }
}

//! Channels of a multi-channel scanner (RIEGL VQ-1560i: two beams looking
//! 14° forward and 14° backward through one polygon): each channel is the
//! deflector's beam turned by its own mounting rotation, and the channels
//! fire in turn, pulse `k` on channel `k mod C`, so each fires at `PRF/C`.

use crate::geometry::{DMat3, DVec3};

/// One channel's mounting in the scanner frame (x left, y forward, z down).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Channel {
    /// Tilt of the beam along the track, rad: positive looks forward (the
    /// nadir beam turns towards +y).
    pub along_tilt_rad: f64,
    /// Turn of the beam about the scanner's z axis, rad: positive turns
    /// the forward direction towards the left.
    pub yaw_rad: f64,
}

impl Channel {
    /// The channel that looks where the deflector points.
    pub const STRAIGHT: Self = Self {
        along_tilt_rad: 0.0,
        yaw_rad: 0.0,
    };

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

/// The channel that fires pulse `k` of `channels` (one at a time, in
/// turn).
pub fn channel_of(k: u64, channels: usize) -> usize {
    (k % channels.max(1) as u64) as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tilt_and_yaw_turn_the_nadir_beam_as_documented() {
        let fwd = Channel {
            along_tilt_rad: 14f64.to_radians(),
            yaw_rad: 0.0,
        };
        let d = fwd.mount() * DVec3::Z;
        assert!(
            (d - DVec3::new(0.0, 14f64.to_radians().sin(), 14f64.to_radians().cos())).length()
                < 1e-12
        );
        let turned = Channel {
            along_tilt_rad: 0.0,
            yaw_rad: 0.3,
        };
        let y = turned.mount() * DVec3::Y;
        assert!((y - DVec3::new(0.3f64.sin(), 0.3f64.cos(), 0.0)).length() < 1e-12);
        for c in [fwd, turned] {
            let m = c.mount();
            assert!((m.determinant() - 1.0).abs() < 1e-12);
            assert!((m * m.transpose()).abs_diff_eq(DMat3::IDENTITY, 1e-12));
        }
        assert_eq!(Channel::STRAIGHT.mount(), DMat3::IDENTITY);
        assert_eq!(
            (0..5).map(|k| channel_of(k, 2)).collect::<Vec<_>>(),
            [0, 1, 0, 1, 0]
        );
    }
}

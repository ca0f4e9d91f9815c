//! The frames of the last pulse, kept while the next pulse's line and
//! attitude stay the same to the bit: the values are those computed afresh.

use crate::geometry::{Attitude, DMat3, SCANNER_TO_LEVEL_NORTH};
use crate::sensor::platform::{FlightLine, LineFrame};

/// The per-line and per-attitude constants of the last pulse, reused while
/// they stay the same to the bit (so the values are those computed afresh):
/// the line's direction and heading, and the rotations of its attitude.
#[derive(Default)]
pub(super) struct FrameCache {
    /// Bits of the line's start and end (all its frame depends on).
    line: Option<([u64; 6], LineFrame)>,
    /// Bits of roll, pitch, yaw and the boresight matrix; body-to-world
    /// rotation; scanner (with boresight) to world rotation.
    attitude: Option<([u64; 12], DMat3, DMat3)>,
}

impl FrameCache {
    /// [`FlightLine::frame`] of `line`.
    #[inline]
    pub(super) fn line(&mut self, line: &FlightLine) -> LineFrame {
        let (a, b) = (line.start_m, line.end_m);
        let key = [a.x, a.y, a.z, b.x, b.y, b.z];
        match self.line {
            Some((k, frame)) if same_bits(&k, &key) => frame,
            _ => {
                let frame = line.frame();
                self.line = Some((key.map(f64::to_bits), frame));
                frame
            }
        }
    }

    /// The body-to-world rotation of `attitude` and `body · boresight ·`
    /// [`SCANNER_TO_LEVEL_NORTH`].
    #[inline]
    pub(super) fn rotations(&mut self, attitude: &Attitude, boresight: DMat3) -> (DMat3, DMat3) {
        let b = boresight.to_cols_array();
        let key = [
            attitude.roll_rad,
            attitude.pitch_rad,
            attitude.yaw_rad,
            b[0],
            b[1],
            b[2],
            b[3],
            b[4],
            b[5],
            b[6],
            b[7],
            b[8],
        ];
        match self.attitude {
            Some((k, body, rot)) if same_bits(&k, &key) => (body, rot),
            _ => {
                let body = attitude.body_to_world();
                let rot = body * boresight * SCANNER_TO_LEVEL_NORTH;
                self.attitude = Some((key.map(f64::to_bits), body, rot));
                (body, rot)
            }
        }
    }
}

/// Whether `values` have the bits of `key`, compared one by one.
#[inline]
fn same_bits<const N: usize>(key: &[u64; N], values: &[f64; N]) -> bool {
    key.iter().zip(values).all(|(k, v)| *k == v.to_bits())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{DVec3, rot_x, rot_y, rot_z};

    fn line(index: u32, start: DVec3, end: DVec3) -> FlightLine {
        FlightLine {
            index,
            ..crate::sensor::platform::tests::line(start, end)
        }
    }

    #[test]
    fn frame_cache_answers_as_computed_afresh() {
        let mut cache = FrameCache::default();
        // Same number, other ends; the same end from another start; the same
        // start to another end; then back: each answer is that line's own.
        let p = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
        let lines = [
            line(0, p(-150.0, 0.0, 500.0), p(150.0, 0.0, 500.0)),
            line(0, p(-150.0, 50.0, 500.0), p(150.0, 0.0, 500.0)),
            line(0, p(-150.0, 50.0, 500.0), p(150.0, 80.0, 510.0)),
            line(0, p(0.0, -150.0, 500.0), p(0.0, 150.0, 500.0)),
            line(1, p(0.0, -150.0, 500.0), p(0.0, 150.0, 500.0)),
        ];
        for l in lines.iter().chain(&lines).chain(lines.iter().rev()) {
            assert_eq!(cache.line(l), l.frame());
            let (a, b) = (l.pose_in(&cache.line(l), 1.7), l.pose_at(1.7));
            assert_eq!((a.position_m, a.attitude), (b.position_m, b.attitude));
        }
        // Repeated and changing attitudes and boresights (a boresight change
        // alone must not return the old scanner rotation).
        let boresights = [DMat3::IDENTITY, rot_z(1e-3) * rot_x(-2e-3) * rot_y(5e-4)];
        let attitudes = [
            Attitude::default(),
            Attitude {
                roll_rad: 0.01,
                pitch_rad: -0.02,
                yaw_rad: 1.3,
            },
        ];
        for step in 0..12 {
            let att = attitudes[(step / 3) % 2];
            let bs = boresights[step % 2];
            let body = att.body_to_world();
            let want = (body, body * bs * SCANNER_TO_LEVEL_NORTH);
            assert_eq!(cache.rotations(&att, bs), want, "step {step}");
        }
    }
}

//! Density matching: the cloud of more pulses per m² thinned to the
//! other's pulse density, pulse by pulse — a pulse kept keeps all its
//! returns, so that the returns per pulse stay as they were (thinning by
//! return would drop later returns of kept pulses). Whether a pulse is
//! kept is a function of its GPS time, point source ID and the seed
//! ([`crate::rng::mix64`]), so the same call keeps the same pulses.

use super::prepare::pulses;
use crate::scan::ScanCloud;

/// Which of `cloud`'s points are kept when its pulses are kept with
/// probability `keep` (0 to 1).
pub fn thin_by_pulse(cloud: &ScanCloud, keep: f64, seed: u64) -> Vec<bool> {
    let mut kept = vec![false; cloud.len()];
    let threshold = (keep.clamp(0.0, 1.0) * u64::MAX as f64) as u64;
    for (n, pulse) in pulses(cloud).into_iter().enumerate() {
        let Some(&k) = pulse.first() else {
            continue;
        };
        // Keyed by what the pulse is (its time and line), not by its place
        // in a list; without times, by its rank in the file.
        let key = if cloud.has_gps_times() {
            cloud.gps_time[k].to_bits() ^ u64::from(cloud.point_source_id[k]).rotate_left(48)
        } else {
            n as u64
        };
        let draw = crate::rng::mix64(crate::rng::mix64(seed) ^ key);
        if draw <= threshold {
            for &j in &pulse {
                kept[j] = true;
            }
        }
    }
    kept
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A quarter of 40 000 two-return pulses kept: about 10 000, each whole.
    #[test]
    fn pulses_are_kept_whole_in_the_share_asked() {
        let n = 40_000;
        let c = ScanCloud {
            x: vec![0.0; 2 * n],
            y: vec![0.0; 2 * n],
            z: vec![0.0; 2 * n],
            gps_time: (0..2 * n).map(|i| (i / 2) as f64 * 1e-5).collect(),
            return_number: (0..2 * n).map(|i| (i % 2 + 1) as u8).collect(),
            number_of_returns: vec![2; 2 * n],
            point_source_id: vec![1; 2 * n],
            facts: crate::scan::ScanFacts {
                has_gps_time: true,
                ..Default::default()
            },
            ..ScanCloud::default()
        };
        let kept = thin_by_pulse(&c, 0.25, 9);
        let pulses_kept = kept.iter().step_by(2).filter(|&&k| k).count();
        // Binomial: sd = sqrt(40000 · 0.25 · 0.75) ≈ 87.
        assert!(
            (pulses_kept as f64 - 10_000.0).abs() < 4.0 * 87.0,
            "{pulses_kept}"
        );
        assert!(kept.chunks(2).all(|p| p[0] == p[1]));
        assert_eq!(kept, thin_by_pulse(&c, 0.25, 9));
        assert_ne!(kept, thin_by_pulse(&c, 0.25, 10));
    }
}

//! A cloud made ready for its metrics: its ground, each return's height
//! above it, which returns are ground, and, for each pulse, whether its
//! last return is ground — the returns of a pulse found by their shared
//! GPS time and point source ID (LAS 1.4 R15: all returns of a pulse carry
//! its time), or, without times, as the runs from one first return to the
//! next in file order.

use super::metrics::{GROUND_BAND_M, Prepared};
use crate::scan::ScanCloud;
use crate::scan::ground::{GROUND_CLASS, GroundModel, MIN_GROUND_POINTS};

/// `cloud` prepared over its own ground `ground`.
pub fn prepare<'a>(cloud: &'a ScanCloud, ground: &GroundModel) -> Prepared<'a> {
    let h = ground.heights(cloud);
    let classified = cloud
        .classification
        .iter()
        .filter(|&&c| c == GROUND_CLASS)
        .count()
        >= MIN_GROUND_POINTS;
    let is_ground: Vec<bool> = (0..cloud.len())
        .map(|k| {
            if classified {
                cloud.classification[k] == GROUND_CLASS
            } else {
                h[k].abs() < GROUND_BAND_M
            }
        })
        .collect();
    let last_is_ground = last_returns(cloud, &is_ground);
    Prepared {
        cloud,
        h,
        ground: is_ground,
        ground_by_class: classified,
        last_is_ground,
        first_only: cloud.first_returns_only(),
    }
}

/// The pulses of `cloud`, each as the indices of its returns.
pub fn pulses(cloud: &ScanCloud) -> Vec<Vec<usize>> {
    let mut order: Vec<usize> = (0..cloud.len()).collect();
    let timed = cloud.has_gps_times();
    if timed {
        order.sort_by(|&a, &b| {
            cloud.gps_time[a]
                .total_cmp(&cloud.gps_time[b])
                .then(cloud.point_source_id[a].cmp(&cloud.point_source_id[b]))
                .then(cloud.return_number[a].cmp(&cloud.return_number[b]))
        });
    }
    let mut out: Vec<Vec<usize>> = Vec::new();
    for &k in &order {
        let new = match out.last().and_then(|p| p.last()) {
            None => true,
            Some(&j) if timed => {
                cloud.gps_time[j] != cloud.gps_time[k]
                    || cloud.point_source_id[j] != cloud.point_source_id[k]
            }
            Some(_) => cloud.is_first(k),
        };
        if new {
            out.push(Vec::new());
        }
        if let Some(p) = out.last_mut() {
            p.push(k);
        }
    }
    out
}

/// For each first return, whether its pulse's last return (return number
/// = number of returns) is ground; `None` when the cloud does not hold
/// that return.
fn last_returns(cloud: &ScanCloud, ground: &[bool]) -> Vec<Option<bool>> {
    let mut out = vec![None; cloud.len()];
    for pulse in pulses(cloud) {
        let first = pulse.iter().copied().find(|&k| cloud.is_first(k));
        let last = pulse
            .iter()
            .copied()
            .find(|&k| cloud.return_number[k] >= cloud.number_of_returns[k].max(1));
        if let (Some(f), Some(l)) = (first, last) {
            out[f] = Some(ground[l]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Three pulses, the second's returns out of order in the file, the
    /// third of one return: each first return knows whether its pulse's
    /// last is ground.
    #[test]
    fn a_first_return_knows_its_pulses_last() {
        let mut c = ScanCloud {
            x: vec![0.0; 5],
            y: vec![0.0; 5],
            z: vec![0.0; 5],
            gps_time: vec![1.0, 2.0, 1.0, 2.0, 3.0],
            return_number: vec![1, 2, 2, 1, 1],
            number_of_returns: vec![2, 2, 2, 2, 1],
            classification: vec![5, 2, 5, 5, 2],
            point_source_id: vec![1; 5],
            facts: crate::scan::ScanFacts {
                has_gps_time: true,
                ..Default::default()
            },
            ..ScanCloud::default()
        };
        let ground: Vec<bool> = c.classification.iter().map(|&k| k == 2).collect();
        let last = last_returns(&c, &ground);
        assert_eq!(last, vec![Some(false), None, None, Some(true), Some(true)]);
        // Without times, the pulses are runs in file order.
        c.facts.has_gps_time = false;
        assert_eq!(pulses(&c), vec![vec![0, 1, 2], vec![3], vec![4]]);
    }
}

//! A scan's first returns split into strips, one per pass of the
//! aircraft: by point source ID when the file sets more than one (the
//! LAS field meant for the flight line), and within each, at pauses in
//! the GPS time longer than [`STRIP_GAP_S`] (an aircraft turning between
//! lines takes tens of seconds; within a pass the mirror leaves a tile
//! for milliseconds).

/// A pause in the GPS time longer than this ends a strip, s.
pub const STRIP_GAP_S: f64 = 2.0;

/// A strip: its first returns, by time.
#[derive(Clone, Debug)]
pub struct Strip {
    /// The point source ID its points share (0 when the file sets none).
    pub source_id: u16,
    /// Indices of its first returns in the cloud, by GPS time.
    pub points: Vec<usize>,
}

/// The strips of the first returns `first` with times `t` and point
/// source IDs `psid` (all of them in one group when they share one).
pub fn split_strips(first: &[usize], t: &[f64], psid: &[u16]) -> Vec<Strip> {
    let mut ids: Vec<u16> = first.iter().map(|&k| psid[k]).collect();
    ids.sort_unstable();
    ids.dedup();
    let by_id = ids.len() > 1;
    let mut groups: Vec<(u16, Vec<usize>)> = if by_id {
        ids.iter().map(|&id| (id, Vec::new())).collect()
    } else {
        vec![(ids.first().copied().unwrap_or(0), first.to_vec())]
    };
    if by_id {
        for &k in first {
            let g = ids.binary_search(&psid[k]).unwrap_or(0);
            groups[g].1.push(k);
        }
    }
    let mut strips = Vec::new();
    for (source_id, mut points) in groups {
        points.sort_by(|&a, &b| t[a].total_cmp(&t[b]).then(a.cmp(&b)));
        let mut start = 0;
        for i in 1..=points.len() {
            if i == points.len() || t[points[i]] - t[points[i - 1]] > STRIP_GAP_S {
                strips.push(Strip {
                    source_id,
                    points: points[start..i].to_vec(),
                });
                start = i;
            }
        }
    }
    strips.sort_by(|a, b| t[a.points[0]].total_cmp(&t[b.points[0]]));
    strips
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strips_split_at_pauses_and_by_source_id() {
        // Two passes 60 s apart, the first with a 0.5 s hole (a lake).
        let t: Vec<f64> = (0..40)
            .map(|i| {
                if i < 20 {
                    i as f64 * 0.1 + if i >= 10 { 0.5 } else { 0.0 }
                } else {
                    60.0 + i as f64 * 0.1
                }
            })
            .collect();
        let first: Vec<usize> = (0..40).rev().collect();
        let strips = split_strips(&first, &t, &[0; 40]);
        assert_eq!(strips.len(), 2);
        assert_eq!(strips[0].points, (0..20).collect::<Vec<_>>());
        // The same times under two source IDs, interleaved: split by ID.
        let psid: Vec<u16> = (0..40).map(|i| if i % 2 == 0 { 3 } else { 7 }).collect();
        let t2: Vec<f64> = (0..40).map(|i| i as f64 * 0.01).collect();
        let strips = split_strips(&first, &t2, &psid);
        assert_eq!(strips.len(), 2);
        assert!(strips.iter().all(|s| s.points.len() == 20));
        assert!(strips[0].points.iter().all(|&k| psid[k] == 3));
    }
}

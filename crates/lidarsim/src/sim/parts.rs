//! A survey's pulses split into parts that separate processes or machines
//! simulate apart. The pulses of all lines, line after line, are one
//! sequence; each part is a stretch of it, part `K` right after part
//! `K − 1`, so that the parts' points, one after the other, are the points
//! of the whole run in order. Every pulse is a pure function of its key
//! (seed, line, pulse), so a part simulates its pulses exactly as a whole
//! run would.
//!
//! Parts take whole flight lines when there are at least as many lines as
//! parts and whole lines balance them well enough (no part above
//! [`WHOLE_LINE_SLACK`] times the mean); otherwise each part takes an equal
//! share of the pulses, cutting lines where it must.

/// The most parts a survey is split into: enough for a job array of any
/// cluster, few enough that the parts' ranges and a merge's bookkeeping
/// stay small (a count read from a file or an argument is checked
/// against it before it sizes anything).
pub const MAX_PARTS: usize = 100_000;

/// How far above the mean a part of whole lines may go before the parts
/// cut lines instead: 1.25 times the mean number of pulses.
pub const WHOLE_LINE_SLACK: f64 = 1.25;

/// The pulses `start..end` of flight line `line` (0 for the first).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct PulseRange {
    /// Index of the flight line.
    pub line: usize,
    /// First pulse.
    pub start: u64,
    /// One past the last pulse.
    pub end: u64,
}

impl PulseRange {
    /// Pulses in the range.
    pub fn len(&self) -> u64 {
        self.end - self.start
    }

    /// Whether the range holds no pulse.
    pub fn is_empty(&self) -> bool {
        self.end <= self.start
    }
}

/// The pulse ranges of each of `n` parts (`1 ≤ n ≤ MAX_PARTS`; `n` is
/// clamped to that range) of lines of `pulses_per_line` pulses, in order:
/// part `k` of the result is part `k + 1` of `n`. A part may be empty when
/// there are fewer pulses than parts.
pub fn split(pulses_per_line: &[u64], n: usize) -> Vec<Vec<PulseRange>> {
    let n = n.clamp(1, MAX_PARTS);
    let total: u64 = pulses_per_line.iter().sum();
    let bounds = whole_line_bounds(pulses_per_line, n).unwrap_or_else(|| {
        // Equal shares: the k-th cut at round(k·T / n).
        (0..=n as u64)
            .map(|k| ((u128::from(k) * u128::from(total) + n as u128 / 2) / n as u128) as u64)
            .collect()
    });
    bounds
        .windows(2)
        .map(|w| ranges_between(pulses_per_line, w[0], w[1]))
        .collect()
}

/// Cuts at line ends, one per part, as near as they can be to equal
/// shares; `None` when there are fewer lines than parts or a part would
/// exceed [`WHOLE_LINE_SLACK`] times the mean.
fn whole_line_bounds(pulses_per_line: &[u64], n: usize) -> Option<Vec<u64>> {
    let lines = pulses_per_line.len();
    if lines < n {
        return None;
    }
    // The end of each line in the whole sequence.
    let ends: Vec<u64> = pulses_per_line
        .iter()
        .scan(0u64, |acc, &p| {
            *acc += p;
            Some(*acc)
        })
        .collect();
    let total = *ends.last()?;
    let mut bounds = vec![0u64];
    let mut last = 0usize; // lines taken so far
    for k in 1..n {
        let target = total as f64 * k as f64 / n as f64;
        // Each remaining part keeps at least one line.
        let (lo, hi) = (last + 1, lines - (n - k));
        let best = (lo..=hi)
            .min_by(|&a, &b| {
                let da = (ends[a - 1] as f64 - target).abs();
                let db = (ends[b - 1] as f64 - target).abs();
                da.total_cmp(&db)
            })
            .unwrap_or(lo);
        bounds.push(ends[best - 1]);
        last = best;
    }
    bounds.push(total);
    let mean = total as f64 / n as f64;
    let largest = bounds.windows(2).map(|w| w[1] - w[0]).max().unwrap_or(0);
    (largest as f64 <= WHOLE_LINE_SLACK * mean).then_some(bounds)
}

/// The ranges of the pulses `from..to` of the whole sequence.
fn ranges_between(pulses_per_line: &[u64], from: u64, to: u64) -> Vec<PulseRange> {
    let mut out = Vec::new();
    let mut offset = 0u64;
    for (line, &p) in pulses_per_line.iter().enumerate() {
        let (a, b) = (from.max(offset), to.min(offset + p));
        if a < b {
            out.push(PulseRange {
                line,
                start: a - offset,
                end: b - offset,
            });
        }
        offset += p;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pulses of the parts, in order, are every pulse once.
    fn check_cover(lines: &[u64], parts: &[Vec<PulseRange>]) {
        let flat: Vec<(usize, u64)> = parts
            .iter()
            .flatten()
            .flat_map(|r| (r.start..r.end).map(move |k| (r.line, k)))
            .collect();
        let want: Vec<(usize, u64)> = lines
            .iter()
            .enumerate()
            .flat_map(|(l, &p)| (0..p).map(move |k| (l, k)))
            .collect();
        assert_eq!(flat, want);
    }

    #[test]
    fn enough_lines_make_parts_of_whole_lines() {
        let lines = [1000, 1000, 1000, 1000, 900, 1100];
        for n in [1, 2, 3, 6] {
            let parts = split(&lines, n);
            assert_eq!(parts.len(), n);
            check_cover(&lines, &parts);
            for p in &parts {
                assert!(p.iter().all(|r| r.start == 0 && r.end == lines[r.line]));
            }
        }
        // Two parts of three lines each.
        assert_eq!(split(&lines, 2)[1][0].line, 3);
    }

    #[test]
    fn few_or_uneven_lines_are_cut_into_equal_shares() {
        // One line, seven parts: 10 000 pulses, 1429 or 1428 each.
        let one = [10_000];
        let parts = split(&one, 7);
        check_cover(&one, &parts);
        let sizes: Vec<u64> = parts
            .iter()
            .map(|p| p.iter().map(PulseRange::len).sum())
            .collect();
        assert!(sizes.iter().all(|&s| s == 1428 || s == 1429), "{sizes:?}");
        // Three equal lines in two parts: whole lines would give 2:1
        // (1.33 × the mean), so the middle line is cut.
        let three = [900, 900, 900];
        let parts = split(&three, 2);
        check_cover(&three, &parts);
        assert_eq!(parts[0].last().map(|r| (r.line, r.end)), Some((1, 450)));
        // A long and a short line in two parts: cut too.
        let uneven = [3000, 500];
        let parts = split(&uneven, 2);
        check_cover(&uneven, &parts);
        let sizes: Vec<u64> = parts
            .iter()
            .map(|p| p.iter().map(PulseRange::len).sum())
            .collect();
        assert_eq!(sizes, [1750, 1750]);
        // Fewer pulses than parts: some parts are empty.
        let tiny = [3];
        let parts = split(&tiny, 5);
        check_cover(&tiny, &parts);
        assert_eq!(parts.iter().filter(|p| p.is_empty()).count(), 2);
    }
}

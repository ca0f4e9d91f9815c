//! Ground truth of an echo: the surface that put the most energy into it.

use crate::geometry::DVec3;
use crate::waveform::Return;

/// Where a sub-ray return came from: the primitive it met and the surface
/// normal there (NaN for foliage, which has none).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReturnSource {
    /// Index of the primitive in the scene.
    pub prim: u32,
    /// Unit surface normal at the hit, NaN for foliage.
    pub normal: DVec3,
}

/// The surface that put the most energy into an echo: per primitive, the
/// powers of its sub-ray returns whose bin lies in `[lo, hi)`, added in ray
/// order; the first to reach the largest sum (in order of first
/// appearance). `span` holds the smallest and largest of `bins`: when the
/// echo's bins hold them all (the usual single echo), no return is tested.
/// `sums` is working storage.
#[inline]
pub(super) fn dominant_surface(
    returns: &[Return],
    sources: &[ReturnSource],
    bins: &[f64],
    span: (f64, f64),
    (lo, hi): (f64, f64),
    sums: &mut Vec<(u32, f64)>,
) -> Option<u32> {
    if lo <= span.0 && span.1 < hi {
        energy_leader(returns, sources, bins, |_| true, sums)
    } else {
        energy_leader(returns, sources, bins, |b| b >= lo && b < hi, sums)
    }
}

/// [`dominant_surface`] over the returns whose bin is `inside`.
#[inline(always)]
fn energy_leader(
    returns: &[Return],
    sources: &[ReturnSource],
    bins: &[f64],
    inside: impl Fn(f64) -> bool,
    sums: &mut Vec<(u32, f64)>,
) -> Option<u32> {
    sums.clear();
    // Neighbouring sub-rays mostly meet the same surface: its running sum
    // is kept in `open` (entry, energy) and stored when another comes.
    let mut open: Option<(usize, f64)> = None;
    for ((r, src), &b) in returns.iter().zip(sources).zip(bins) {
        if !inside(b) {
            continue;
        }
        let p = src.prim;
        if let Some((k, e)) = &mut open {
            if sums[*k].0 == p {
                *e += r.power;
                continue;
            }
            sums[*k].1 = *e;
        }
        open = Some(match sums.iter().position(|(q, _)| *q == p) {
            Some(k) => (k, sums[k].1 + r.power),
            None => {
                sums.push((p, r.power));
                (sums.len() - 1, r.power)
            }
        });
    }
    if let Some((k, e)) = open {
        sums[k].1 = e;
    }
    sums.iter()
        .copied()
        .reduce(|a, b| if b.1 > a.1 { b } else { a })
        .map(|(p, _)| p)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The dominant surface is the one of the largest sum, the sums taken
    /// one surface at a time over the returns in the echo's bins, the first
    /// surface of equal sums winning, for surfaces in runs and interleaved.
    #[test]
    fn dominant_surface_has_the_largest_energy() {
        let mut rng = crate::rng::Stream::new(4, 0, 0, crate::rng::Purpose::Test);
        let mut sums = Vec::new();
        let mut checked = 0;
        for case in 0..5000 {
            let n = 1 + (rng.uniform() * 30.0) as usize;
            let kinds = 1 + case % 4;
            let mut p = 0u32;
            let (mut returns, mut surfaces, mut bins) = (vec![], vec![], vec![]);
            for _ in 0..n {
                // Runs of one surface, sometimes broken.
                if rng.uniform() < 0.3 {
                    p = (rng.uniform() * kinds as f64) as u32;
                }
                // Powers from a few values, so that sums can tie.
                let power = [0.25, 0.5, 1.0][(rng.uniform() * 3.0) as usize];
                returns.push(Return {
                    range_m: 0.0,
                    power,
                });
                surfaces.push(ReturnSource {
                    prim: p,
                    normal: DVec3::Z,
                });
                bins.push(rng.uniform() * 10.0);
            }
            // Every fourth window holds all the returns.
            let (lo, hi) = if case % 4 == 3 {
                (-rng.uniform(), 10.0 + rng.uniform())
            } else {
                (rng.uniform() * 4.0, 4.0 + rng.uniform() * 6.0)
            };
            let span = bins
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                    (a.min(x), b.max(x))
                });
            let inside = |i: usize| bins[i] >= lo && bins[i] < hi;
            // Each surface's sum on its own, in ray order.
            let mut order: Vec<u32> = vec![];
            for i in (0..n).filter(|&i| inside(i)) {
                if !order.contains(&surfaces[i].prim) {
                    order.push(surfaces[i].prim);
                }
            }
            let sum_of = |q: u32| {
                (0..n)
                    .filter(|&i| inside(i) && surfaces[i].prim == q)
                    .fold(0.0, |s, i| s + returns[i].power)
            };
            let mut want: Option<(u32, f64)> = None;
            for q in order {
                let e = sum_of(q);
                if want.is_none_or(|(_, w)| e > w) {
                    want = Some((q, e));
                }
            }
            let got = dominant_surface(&returns, &surfaces, &bins, span, (lo, hi), &mut sums);
            assert_eq!(got, want.map(|(q, _)| q), "case {case}");
            checked += usize::from(got.is_some());
        }
        assert!(checked > 3000, "{checked}");
    }
}

//! The field's standard metrics of a point cloud over an area: pulse and
//! return densities, the shares of returns by return number and of pulses
//! by number of returns, ground shares, canopy cover, the heights of the
//! vegetation returns, the vertical profile and the vegetation-to-ground
//! intensity ratio (the area-based metrics of, e.g., lidR's `stdmetrics`
//! and FUSION's `GridMetrics`; cover as first returns above 2 m after
//! Korhonen et al. 2011, "Airborne discrete-return LIDAR data in the
//! estimation of vertical canopy cover", Remote Sensing of Environment 115).
//!
//! A pulse is counted by its first return; heights are above the cloud's
//! own ground; "vegetation" is a return at least [`VEGETATION_M`] above
//! it; "ground" a return of class 2 (or, in a cloud without class 2,
//! within [`GROUND_BAND_M`] of its ground).

use serde::Serialize;

use crate::scan::ScanCloud;

/// Returns at least this high are vegetation, m.
pub const VEGETATION_M: f64 = 2.0;

/// In a cloud without ground class, returns this close to the ground are
/// ground, m.
pub const GROUND_BAND_M: f64 = 0.5;

/// The height percentiles reported, %.
pub const PERCENTILES: [u8; 7] = [10, 25, 50, 75, 90, 95, 99];

/// A metric that is one number: its key (in `compare.json`), label, unit
/// and how it is shown.
#[derive(Clone, Copy, Debug)]
pub struct Scalar {
    /// Key.
    pub key: &'static str,
    /// In words.
    pub label: &'static str,
    /// Unit (`"%"` for a share shown in per cent, stored as 0–1).
    pub unit: &'static str,
    /// Whether it needs the returns after the first (not in a cloud of
    /// first returns only).
    pub later_returns: bool,
}

const fn s(key: &'static str, label: &'static str, unit: &'static str, later: bool) -> Scalar {
    Scalar {
        key,
        label,
        unit,
        later_returns: later,
    }
}

/// Every scalar metric, in the order of [`Values`].
pub const SCALARS: [Scalar; 27] = [
    s(
        "pulse_density_per_m2",
        "pulses (first returns) per m²",
        "/m²",
        false,
    ),
    s("return_density_per_m2", "returns per m²", "/m²", true),
    s("returns_per_pulse", "returns per pulse", "", false),
    s("single_return_share", "pulses with one return", "%", false),
    s("ground_share", "returns that are ground", "%", true),
    s(
        "first_ground_share",
        "first returns that are ground",
        "%",
        false,
    ),
    s(
        "last_ground_share",
        "last returns that are ground",
        "%",
        true,
    ),
    s(
        "canopy_cover",
        "canopy cover: first returns above 2 m",
        "%",
        false,
    ),
    s(
        "canopy_single_share",
        "canopy pulses ending in one return",
        "%",
        false,
    ),
    s(
        "canopy_ground_reach",
        "canopy pulses whose last return is ground",
        "%",
        true,
    ),
    s(
        "first_p10",
        "first-return vegetation height P10",
        "m",
        false,
    ),
    s(
        "first_p25",
        "first-return vegetation height P25",
        "m",
        false,
    ),
    s(
        "first_p50",
        "first-return vegetation height P50",
        "m",
        false,
    ),
    s(
        "first_p75",
        "first-return vegetation height P75",
        "m",
        false,
    ),
    s(
        "first_p90",
        "first-return vegetation height P90",
        "m",
        false,
    ),
    s(
        "first_p95",
        "first-return vegetation height P95",
        "m",
        false,
    ),
    s(
        "first_p99",
        "first-return vegetation height P99",
        "m",
        false,
    ),
    s("all_p10", "all-return vegetation height P10", "m", true),
    s("all_p25", "all-return vegetation height P25", "m", true),
    s("all_p50", "all-return vegetation height P50", "m", true),
    s("all_p75", "all-return vegetation height P75", "m", true),
    s("all_p90", "all-return vegetation height P90", "m", true),
    s("all_p95", "all-return vegetation height P95", "m", true),
    s("all_p99", "all-return vegetation height P99", "m", true),
    s(
        "intensity_vegetation",
        "mean intensity, first returns above 2 m",
        "",
        false,
    ),
    s(
        "intensity_ground",
        "mean intensity, first returns on the ground",
        "",
        false,
    ),
    s(
        "intensity_ratio",
        "vegetation-to-ground intensity ratio",
        "",
        false,
    ),
];

/// The scalar metrics, in the order of [`SCALARS`]; `None` where there
/// is nothing to measure.
pub type Values = [Option<f64>; 27];

/// A cloud prepared for its metrics: heights, ground flags and, for each
/// first return, whether its pulse's last return is ground.
pub struct Prepared<'a> {
    /// The cloud.
    pub cloud: &'a ScanCloud,
    /// Heights above its ground, m.
    pub h: Vec<f64>,
    /// Whether each return is ground.
    pub ground: Vec<bool>,
    /// Whether ground is class 2 (else the height band).
    pub ground_by_class: bool,
    /// For a first return: whether its pulse's last return is ground
    /// (`None` when the cloud does not hold it).
    pub last_is_ground: Vec<Option<bool>>,
    /// Whether it holds first returns only.
    pub first_only: bool,
}

/// The distributions of a cloud over an area.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Distributions {
    /// Share of returns with return number 1, 2, 3, 4, 5 or more.
    pub return_number: [f64; 5],
    /// Share of pulses with 1, 2, 3, 4, 5 or more returns.
    pub number_of_returns: [f64; 5],
    /// Share of all returns per metre of height (bin k: k to k + 1 m;
    /// below the ground in bin 0).
    pub profile_all: Vec<f64>,
    /// The same for first returns.
    pub profile_first: Vec<f64>,
}

/// The metrics of `p`'s points `idx` over `area_m2`.
pub fn values(p: &Prepared<'_>, idx: &[usize], area_m2: f64) -> Values {
    let c = p.cloud;
    let mut v: Values = [None; 27];
    let first: Vec<usize> = idx.iter().copied().filter(|&k| c.is_first(k)).collect();
    let share = |n: usize, of: usize| (of > 0).then(|| n as f64 / of as f64);
    let count = |set: &[usize], f: &dyn Fn(usize) -> bool| set.iter().filter(|&&k| f(k)).count();
    let later = !p.first_only;
    v[0] = (area_m2 > 0.0).then(|| first.len() as f64 / area_m2);
    v[1] = (later && area_m2 > 0.0).then(|| idx.len() as f64 / area_m2);
    v[2] = (!first.is_empty()).then(|| {
        first
            .iter()
            .map(|&k| f64::from(c.number_of_returns[k].max(1)))
            .sum::<f64>()
            / first.len() as f64
    });
    let single = |k: usize| c.number_of_returns[k] <= 1;
    v[3] = share(count(&first, &single), first.len());
    if later {
        v[4] = share(count(idx, &|k| p.ground[k]), idx.len());
        let last: Vec<usize> = idx.iter().copied().filter(|&k| c.is_last(k)).collect();
        v[6] = share(count(&last, &|k| p.ground[k]), last.len());
    }
    v[5] = share(count(&first, &|k| p.ground[k]), first.len());
    let canopy: Vec<usize> = first
        .iter()
        .copied()
        .filter(|&k| p.h[k] >= VEGETATION_M)
        .collect();
    v[7] = share(canopy.len(), first.len());
    v[8] = share(count(&canopy, &single), canopy.len());
    if later {
        let known: Vec<bool> = canopy.iter().filter_map(|&k| p.last_is_ground[k]).collect();
        v[9] = share(known.iter().filter(|&&g| g).count(), known.len());
    }
    let heights = |set: &[usize]| -> Vec<f64> {
        set.iter()
            .map(|&k| p.h[k])
            .filter(|&h| h >= VEGETATION_M)
            .collect()
    };
    for (i, q) in percentiles(heights(&first)).into_iter().enumerate() {
        v[10 + i] = q;
    }
    if later {
        for (i, q) in percentiles(heights(idx)).into_iter().enumerate() {
            v[17 + i] = q;
        }
    }
    let mean_intensity = |set: &[usize]| {
        (!set.is_empty())
            .then(|| set.iter().map(|&k| f64::from(c.intensity[k])).sum::<f64>() / set.len() as f64)
    };
    let ground_first: Vec<usize> = first.iter().copied().filter(|&k| p.ground[k]).collect();
    v[24] = mean_intensity(&canopy);
    v[25] = mean_intensity(&ground_first);
    v[26] = match (v[24], v[25]) {
        (Some(veg), Some(g)) if g > 0.0 => Some(veg / g),
        _ => None,
    };
    v
}

/// The height percentiles [`PERCENTILES`] of `h` (nearest rank); `None`
/// for fewer than 10 heights.
fn percentiles(mut h: Vec<f64>) -> [Option<f64>; 7] {
    if h.len() < 10 {
        return [None; 7];
    }
    h.sort_by(f64::total_cmp);
    PERCENTILES.map(|q| {
        let rank = (f64::from(q) / 100.0 * h.len() as f64).ceil() as usize;
        Some(h[rank.clamp(1, h.len()) - 1])
    })
}

/// The distributions of `p`'s points `idx`, the profiles over `bins`
/// metres.
pub fn distributions(p: &Prepared<'_>, idx: &[usize], bins: usize) -> Distributions {
    let c = p.cloud;
    let mut d = Distributions {
        profile_all: vec![0.0; bins],
        profile_first: vec![0.0; bins],
        ..Distributions::default()
    };
    let (mut n_first, mut n_all) = (0usize, 0usize);
    for &k in idx {
        n_all += 1;
        d.return_number[usize::from(c.return_number[k].clamp(1, 5)) - 1] += 1.0;
        let bin = (p.h[k].max(0.0) as usize).min(bins.saturating_sub(1));
        if bins > 0 {
            d.profile_all[bin] += 1.0;
        }
        if c.is_first(k) {
            n_first += 1;
            d.number_of_returns[usize::from(c.number_of_returns[k].clamp(1, 5)) - 1] += 1.0;
            if bins > 0 {
                d.profile_first[bin] += 1.0;
            }
        }
    }
    let scale = |v: &mut [f64], n: usize| v.iter_mut().for_each(|x| *x /= n.max(1) as f64);
    scale(&mut d.return_number, n_all);
    scale(&mut d.number_of_returns, n_first);
    scale(&mut d.profile_all, n_all);
    scale(&mut d.profile_first, n_first);
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Nearest-rank percentiles of 1..=100 are the ranks themselves.
    #[test]
    fn percentiles_are_nearest_ranks() {
        let p = percentiles((1..=100).map(f64::from).collect());
        let want = PERCENTILES.map(|q| Some(f64::from(q)));
        assert_eq!(p, want);
        assert_eq!(percentiles(vec![1.0; 9]), [None; 7]);
    }
}

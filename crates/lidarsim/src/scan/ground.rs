//! The ground of a scan, from which heights are measured: a digital
//! terrain model (DTM) from its ground-classified returns (ASPRS class 2)
//! — the mean height of the ground points per cell, empty cells filled
//! from their neighbours — or, in a cloud without ground class, from the
//! lowest return per coarser cell, cells standing clearly above their
//! neighbourhood dropped (under a closed canopy the lowest return may be
//! foliage). A DTM whose relief is under [`FLAT_RELIEF_M`] is a flat
//! ground: a height-normalised cloud (lidR's `normalize_height`, ground at
//! z = 0) is recognised that way.

use super::ScanCloud;
use super::grid::Grid;
use crate::message::num;

/// The ASPRS class of ground points (LAS 1.4 R15, Table 17).
pub const GROUND_CLASS: u8 = 2;

/// A DTM whose cells span less than this (1st to 99th percentile) is a
/// flat ground, m.
pub const FLAT_RELIEF_M: f64 = 0.5;

/// Ground points a DTM needs at least from class 2; with fewer, the
/// lowest returns make it.
pub const MIN_GROUND_POINTS: usize = 20;

/// Where a ground model comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum GroundSource {
    /// The points of class 2.
    Classified {
        /// How many.
        points: usize,
    },
    /// The lowest return per cell (no class 2 in the cloud).
    Lowest,
}

/// A scan's ground.
#[derive(Clone, Debug)]
pub struct GroundModel {
    /// The DTM (cell centres the nodes).
    pub dtm: Grid,
    /// Whether the DTM is flat within [`FLAT_RELIEF_M`]; then its height
    /// is [`GroundModel::flat_z_m`] everywhere.
    pub flat: bool,
    /// The DTM's median height, m (the flat ground's height).
    pub flat_z_m: f64,
    /// The span of the DTM's cells, 1st to 99th percentile, m.
    pub relief_m: f64,
    /// What it was made from.
    pub source: GroundSource,
}

impl GroundModel {
    /// The ground's height below `(x, y)`, m.
    pub fn z_at(&self, x: f64, y: f64) -> f64 {
        if self.flat {
            self.flat_z_m
        } else {
            self.dtm.bilinear(x, y)
        }
    }

    /// Every point's height above the ground, m.
    pub fn heights(&self, cloud: &ScanCloud) -> Vec<f64> {
        (0..cloud.len())
            .map(|i| cloud.z[i] - self.z_at(cloud.x[i], cloud.y[i]))
            .collect()
    }

    /// Whether the cloud looks height-normalised: flat, at z ≈ 0.
    pub fn normalised(&self) -> bool {
        self.flat && self.flat_z_m.abs() < FLAT_RELIEF_M
    }

    /// In words, for reports: "DTM of 1 m cells from 5820 ground points
    /// (relief 12.3 m)", "flat at z = 0 (height-normalised)".
    pub fn describe(&self) -> String {
        let from = match self.source {
            GroundSource::Classified { points } => format!("{points} ground points (class 2)"),
            GroundSource::Lowest => "the lowest return per cell (no class 2)".to_string(),
        };
        if self.normalised() {
            format!("flat at z = 0: the cloud is height-normalised (ground from {from})")
        } else if self.flat {
            format!(
                "flat at z = {} m (relief under {FLAT_RELIEF_M} m, from {from})",
                num((self.flat_z_m * 100.0).round() / 100.0)
            )
        } else {
            format!(
                "DTM of {} m cells from {from}, relief {} m",
                num(self.dtm.cell_m),
                num((self.relief_m * 10.0).round() / 10.0)
            )
        }
    }
}

/// The ground of `cloud`: from its class 2 points if it has at least
/// [`MIN_GROUND_POINTS`], else from its lowest returns. `None` for a
/// cloud too large an area to grid ([`super::grid::MAX_CELLS`]).
pub fn ground_model(cloud: &ScanCloud) -> Option<GroundModel> {
    let b = cloud.bounds();
    let area = ((b[2] - b[0]) * (b[3] - b[1])).max(1.0);
    let ground = |k: usize| cloud.classification[k] == GROUND_CLASS;
    let n_ground = (0..cloud.len()).filter(|&k| ground(k)).count();
    let (dtm, source) = if n_ground >= MIN_GROUND_POINTS {
        // About four ground points a cell (Thiessen-like support), 0.5–10 m.
        let cell = nice_cell((4.0 * area / n_ground as f64).sqrt().clamp(0.5, 10.0));
        let mut sum = Grid::covering(expand(b, cell), cell)?;
        let mut count = sum.filled_with(0.0);
        count.count((&cloud.x, &cloud.y), ground);
        sum.values.iter_mut().for_each(|v| *v = 0.0);
        for k in (0..cloud.len()).filter(|&k| ground(k)) {
            if let Some(i) = sum.cell_of(cloud.x[k], cloud.y[k]) {
                sum.values[i] += cloud.z[k];
            }
        }
        for (s, n) in sum.values.iter_mut().zip(&count.values) {
            *s = if *n > 0.0 { *s / n } else { f64::NAN };
        }
        (sum, GroundSource::Classified { points: n_ground })
    } else {
        (lowest_returns(cloud, area)?, GroundSource::Lowest)
    };
    Some(finish(dtm, source))
}

/// The DTM of the lowest returns: per cell of about 50 points (2–20 m)
/// the lowest, cells more than 1 m plus 30 % of a cell above the median
/// of their neighbourhood dropped (foliage under a closed canopy), gaps
/// filled.
fn lowest_returns(cloud: &ScanCloud, area: f64) -> Option<Grid> {
    let b = cloud.bounds();
    let cell = nice_cell((50.0 * area / cloud.len() as f64).sqrt().clamp(2.0, 20.0));
    let mut low = Grid::covering(expand(b, cell), cell)?;
    low.extreme((&cloud.x, &cloud.y, &cloud.z), |_| true, false);
    let keep: Vec<bool> = (0..low.values.len())
        .map(|i| {
            let mut around: Vec<f64> = low
                .neighbours(i)
                .map(|j| low.values[j])
                .filter(|v| !v.is_nan())
                .collect();
            if around.is_empty() {
                return true;
            }
            around.sort_by(f64::total_cmp);
            low.values[i] <= around[around.len() / 2] + 1.0 + 0.3 * cell
        })
        .collect();
    for (v, k) in low.values.iter_mut().zip(keep) {
        if !k {
            *v = f64::NAN;
        }
    }
    Some(low)
}

/// The DTM with its gaps filled, and whether it is flat.
fn finish(mut dtm: Grid, source: GroundSource) -> GroundModel {
    dtm.fill_gaps();
    let mut sorted: Vec<f64> = dtm
        .values
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .collect();
    sorted.sort_by(f64::total_cmp);
    let at = |q: f64| sorted[((sorted.len() - 1) as f64 * q).round() as usize];
    let (relief_m, flat_z_m) = if sorted.is_empty() {
        (0.0, 0.0)
    } else {
        (at(0.99) - at(0.01), at(0.5))
    };
    GroundModel {
        dtm,
        flat: relief_m < FLAT_RELIEF_M,
        flat_z_m,
        relief_m,
        source,
    }
}

/// `bounds` grown by `by` on every side.
pub fn expand(bounds: [f64; 4], by: f64) -> [f64; 4] {
    [
        bounds[0] - by,
        bounds[1] - by,
        bounds[2] + by,
        bounds[3] + by,
    ]
}

/// The size from 1, 2, 2.5, 5 × 10ⁿ nearest to `v` (a cell size a user
/// reads easily).
pub fn nice_cell(v: f64) -> f64 {
    let p = 10f64.powf(v.log10().floor());
    [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|m| m * p)
        .min_by(|a, b| (a - v).abs().total_cmp(&(b - v).abs()))
        .unwrap_or(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cloud of `n` × `n` points on a 1 m lattice: ground points (class
    /// 2) on `ground(x, y)` and, on every third, a canopy point 15 m above.
    fn cloud(n: usize, ground: impl Fn(f64, f64) -> f64, classified: bool) -> ScanCloud {
        let mut c = ScanCloud::default();
        for i in 0..n * n {
            let (x, y) = ((i % n) as f64 + 0.5, (i / n) as f64 + 0.5);
            for canopy in [false, true] {
                if canopy && i % 3 != 0 {
                    continue;
                }
                c.x.push(x);
                c.y.push(y);
                c.z.push(ground(x, y) + if canopy { 15.0 } else { 0.0 });
                c.classification
                    .push(if classified && !canopy { 2 } else { 1 });
            }
        }
        c
    }

    #[test]
    fn a_sloping_ground_gives_its_heights_back() {
        let slope = |x: f64, y: f64| 100.0 + 0.2 * x - 0.1 * y;
        for classified in [true, false] {
            let c = cloud(60, slope, classified);
            let g = ground_model(&c).unwrap();
            assert!(!g.flat && g.relief_m > 5.0, "{}", g.describe());
            for (x, y) in [(20.0, 20.0), (31.3, 12.7), (45.0, 40.0)] {
                let err = g.z_at(x, y) - slope(x, y);
                // The lowest return per cell lies up to half a cell downhill.
                let tol = if classified {
                    0.05
                } else {
                    0.25 * g.dtm.cell_m
                };
                assert!(err.abs() < tol, "{classified}: {err} at ({x}, {y})");
            }
        }
    }

    #[test]
    fn a_normalised_cloud_is_recognised_as_flat_ground_at_zero() {
        let c = cloud(40, |_, _| 0.0, true);
        let g = ground_model(&c).unwrap();
        assert!(g.normalised(), "{}", g.describe());
        let h = g.heights(&c);
        assert!(h.iter().all(|&h| h == 0.0 || h == 15.0));
        let raised = cloud(40, |_, _| 250.0, true);
        let g = ground_model(&raised).unwrap();
        assert!(g.flat && !g.normalised() && (g.flat_z_m - 250.0).abs() < 1e-9);
    }

    #[test]
    fn nice_cells_are_round_numbers() {
        assert_eq!(nice_cell(0.93), 1.0);
        assert_eq!(nice_cell(2.2), 2.0);
        assert_eq!(nice_cell(2.4), 2.5);
        assert_eq!(nice_cell(40.0), 50.0);
        assert_eq!(nice_cell(0.3), 0.25);
    }
}

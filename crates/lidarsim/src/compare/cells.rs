//! The metrics per grid cell, and how far the two clouds differ against
//! their cells' own spread.
//!
//! Every used cell gives a pair of values (the two clouds over the same
//! ground); their differences d = B − A have a mean d̄ and a standard
//! deviation s over the n cells. d̄ is set against its standard error
//! s/√n (the paired z: within ±2 the clouds agree within their sampling
//! spread) and against the spread of the first cloud's own cells, sd(A)
//! (how large the difference is against how the metric varies over the
//! ground).

use serde::Serialize;

use super::area::CommonArea;
use super::metrics::{Prepared, SCALARS, Values, values};

/// One metric over the cells.
#[derive(Clone, Debug, Serialize)]
pub struct CellMetric {
    /// Its key.
    pub key: &'static str,
    /// Each used cell's value of the first cloud, row by row from the
    /// south-west (`null` where it has none).
    pub a: Vec<Option<f64>>,
    /// The same of the second cloud.
    pub b: Vec<Option<f64>>,
    /// Cells where both have a value.
    pub pairs: usize,
    /// Mean of B − A over them.
    pub mean_difference: Option<f64>,
    /// Standard deviation of B − A.
    pub sd_difference: Option<f64>,
    /// Standard error of the mean difference, sd / √pairs.
    pub se_difference: Option<f64>,
    /// Mean difference over its standard error.
    pub z: Option<f64>,
    /// Standard deviation of the first cloud's cells.
    pub sd_a: Option<f64>,
    /// Standard deviation of the second cloud's cells.
    pub sd_b: Option<f64>,
}

/// The per-cell metrics of both clouds.
#[derive(Clone, Debug, Serialize)]
pub struct Cells {
    /// Edge of a cell, m.
    pub cell_m: f64,
    /// South-west corner of the grid, m.
    pub corner_m: [f64; 2],
    /// Cells per row.
    pub cols: usize,
    /// Rows.
    pub rows: usize,
    /// Whether each cell is used (at least half common area).
    pub used: Vec<bool>,
    /// Each metric.
    pub metrics: Vec<CellMetric>,
}

/// The points of `p` with `keep`, grouped by comparison cell.
fn by_cell(p: &Prepared<'_>, keep: &[bool], area: &CommonArea) -> Vec<Vec<usize>> {
    let mut out = vec![Vec::new(); area.cells.values.len()];
    for (k, &kept) in keep.iter().enumerate() {
        if kept && let Some(c) = area.cells.cell_of(p.cloud.x[k], p.cloud.y[k]) {
            out[c].push(k);
        }
    }
    out
}

/// The metrics of both clouds in every used cell of `area`.
pub fn cell_metrics(
    (a, keep_a): (&Prepared<'_>, &[bool]),
    (b, keep_b): (&Prepared<'_>, &[bool]),
    area: &CommonArea,
) -> Cells {
    let g = &area.cells;
    let used: Vec<bool> = (0..g.values.len()).map(|i| area.used(i)).collect();
    let (cells_a, cells_b) = (by_cell(a, keep_a, area), by_cell(b, keep_b, area));
    let per_cell = |p: &Prepared<'_>, cells: &[Vec<usize>]| -> Vec<Values> {
        (0..g.values.len())
            .filter(|&i| used[i])
            .map(|i| values(p, &cells[i], g.values[i]))
            .collect()
    };
    let (va, vb) = (per_cell(a, &cells_a), per_cell(b, &cells_b));
    let metrics = SCALARS
        .iter()
        .enumerate()
        .map(|(m, s)| {
            let col = |v: &[Values]| v.iter().map(|c| c[m]).collect::<Vec<_>>();
            paired(s.key, col(&va), col(&vb))
        })
        .collect();
    Cells {
        cell_m: g.cell_m,
        corner_m: g.corner_m,
        cols: g.cols,
        rows: g.rows,
        used,
        metrics,
    }
}

/// The paired statistics of one metric's cell values.
fn paired(key: &'static str, a: Vec<Option<f64>>, b: Vec<Option<f64>>) -> CellMetric {
    let d: Vec<f64> = a
        .iter()
        .zip(&b)
        .filter_map(|(x, y)| Some((*y)? - (*x)?))
        .collect();
    let mean = |v: &[f64]| (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64);
    let sd = |v: &[f64]| {
        let m = mean(v)?;
        (v.len() > 1)
            .then(|| (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt())
    };
    let flat = |v: &[Option<f64>]| v.iter().flatten().copied().collect::<Vec<f64>>();
    let mean_difference = mean(&d);
    let sd_difference = sd(&d);
    let se_difference = sd_difference.map(|s| s / (d.len() as f64).sqrt());
    let z = match (mean_difference, se_difference) {
        (Some(m), Some(se)) if se > 0.0 => Some(m / se),
        (Some(0.0), Some(_)) => Some(0.0),
        _ => None,
    };
    CellMetric {
        key,
        sd_a: sd(&flat(&a)),
        sd_b: sd(&flat(&b)),
        a,
        b,
        pairs: d.len(),
        mean_difference,
        sd_difference,
        se_difference,
        z,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paired_statistics_follow_their_definitions() {
        let a = vec![Some(1.0), Some(2.0), None, Some(4.0)];
        let b = vec![Some(2.0), Some(2.0), Some(9.0), Some(7.0)];
        let m = paired("x", a, b);
        // d = 1, 0, 3: mean 4/3, sd sqrt(((−1/3)² + (−4/3)² + (5/3)²)/2).
        assert_eq!(m.pairs, 3);
        assert!((m.mean_difference.unwrap() - 4.0 / 3.0).abs() < 1e-12);
        let sd = ((1.0f64 / 9.0 + 16.0 / 9.0 + 25.0 / 9.0) / 2.0).sqrt();
        assert!((m.sd_difference.unwrap() - sd).abs() < 1e-12);
        assert!((m.z.unwrap() - (4.0 / 3.0) / (sd / 3f64.sqrt())).abs() < 1e-12);
        let same = paired("x", vec![Some(1.0), Some(3.0)], vec![Some(1.0), Some(3.0)]);
        assert_eq!((same.mean_difference, same.z), (Some(0.0), Some(0.0)));
    }
}

//! Rasters over a scan's area: one value per square cell (NaN for none),
//! filled from the points (the highest, the lowest, the mean, a count)
//! and their gaps filled from their neighbours. Everything is one pass
//! over the points or a few over the cells: no search between points.

use crate::scene::terrain::HeightGrid;

/// A raster of square cells, row 0 the southernmost; cell `(col, row)`
/// covers `[x0 + col·c, x0 + (col + 1)·c) × [y0 + row·c, y0 + (row + 1)·c)`.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    /// South-west corner of cell (0, 0), m.
    pub corner_m: [f64; 2],
    /// Edge of a cell, m.
    pub cell_m: f64,
    /// Cells per row.
    pub cols: usize,
    /// Rows.
    pub rows: usize,
    /// Row-major values; NaN where a cell has none.
    pub values: Vec<f64>,
}

/// Most cells of a grid (4 GiB of `f64`s is beyond any scan's need).
pub const MAX_CELLS: usize = 200_000_000;

impl Grid {
    /// An empty grid of `cell_m` cells covering `bounds` (`[xmin, ymin,
    /// xmax, ymax]`), aligned to multiples of `cell_m` so that grids of
    /// one cell size line up. `None` when it would exceed [`MAX_CELLS`].
    pub fn covering(bounds: [f64; 4], cell_m: f64) -> Option<Self> {
        let x0 = (bounds[0] / cell_m).floor() * cell_m;
        let y0 = (bounds[1] / cell_m).floor() * cell_m;
        let cols = ((bounds[2] - x0) / cell_m).floor() as usize + 1;
        let rows = ((bounds[3] - y0) / cell_m).floor() as usize + 1;
        if cols.checked_mul(rows)? > MAX_CELLS {
            return None;
        }
        Some(Self {
            corner_m: [x0, y0],
            cell_m,
            cols,
            rows,
            values: vec![f64::NAN; cols * rows],
        })
    }

    /// The same grid with every cell `value`.
    pub fn filled_with(&self, value: f64) -> Self {
        Self {
            values: vec![value; self.values.len()],
            ..self.clone()
        }
    }

    /// The index of the cell holding `(x, y)`, if inside.
    #[inline]
    pub fn cell_of(&self, x: f64, y: f64) -> Option<usize> {
        let c = ((x - self.corner_m[0]) / self.cell_m).floor();
        let r = ((y - self.corner_m[1]) / self.cell_m).floor();
        (c >= 0.0 && r >= 0.0 && (c as usize) < self.cols && (r as usize) < self.rows)
            .then(|| r as usize * self.cols + c as usize)
    }

    /// The centre of cell `i`, m.
    pub fn centre(&self, i: usize) -> [f64; 2] {
        let (c, r) = (i % self.cols, i / self.cols);
        [
            self.corner_m[0] + (c as f64 + 0.5) * self.cell_m,
            self.corner_m[1] + (r as f64 + 0.5) * self.cell_m,
        ]
    }

    /// The largest (`max`) or smallest value per cell of the points at
    /// `(x[k], y[k])` with value `v[k]`, for the points `keep` accepts.
    pub fn extreme(
        &mut self,
        (x, y, v): (&[f64], &[f64], &[f64]),
        keep: impl Fn(usize) -> bool,
        max: bool,
    ) {
        for k in 0..x.len() {
            if !keep(k) {
                continue;
            }
            if let Some(i) = self.cell_of(x[k], y[k]) {
                let old = self.values[i];
                if old.is_nan() || (max && v[k] > old) || (!max && v[k] < old) {
                    self.values[i] = v[k];
                }
            }
        }
    }

    /// The number of points per cell (0 where none) of those `keep`
    /// accepts.
    pub fn count(&mut self, (x, y): (&[f64], &[f64]), keep: impl Fn(usize) -> bool) {
        self.values.iter_mut().for_each(|v| *v = 0.0);
        for k in 0..x.len() {
            if keep(k)
                && let Some(i) = self.cell_of(x[k], y[k])
            {
                self.values[i] += 1.0;
            }
        }
    }

    /// The value at `(x, y)`, interpolated bilinearly between the cell
    /// centres (held at the edge cells' beyond them); NaN where a
    /// neighbouring cell has none.
    pub fn bilinear(&self, x: f64, y: f64) -> f64 {
        let fx = ((x - self.corner_m[0]) / self.cell_m - 0.5).clamp(0.0, (self.cols - 1) as f64);
        let fy = ((y - self.corner_m[1]) / self.cell_m - 0.5).clamp(0.0, (self.rows - 1) as f64);
        let (c0, r0) = (fx.floor() as usize, fy.floor() as usize);
        let (c1, r1) = ((c0 + 1).min(self.cols - 1), (r0 + 1).min(self.rows - 1));
        let (tx, ty) = (fx - c0 as f64, fy - r0 as f64);
        let v = |c: usize, r: usize| self.values[r * self.cols + c];
        let south = v(c0, r0) * (1.0 - tx) + v(c1, r0) * tx;
        let north = v(c0, r1) * (1.0 - tx) + v(c1, r1) * tx;
        south * (1.0 - ty) + north * ty
    }

    /// Fills every empty cell from its neighbours, in layers outwards from
    /// the filled cells: each empty cell next to a filled one (of 8) takes
    /// their mean, then the cells next to those, and so on (one pass over
    /// the cells, however large the holes). A grid without any value is
    /// left as it is.
    pub fn fill_gaps(&mut self) {
        let mut layer: Vec<usize> = (0..self.values.len())
            .filter(|&i| self.values[i].is_nan() && self.neighbour_mean(i).is_some())
            .collect();
        let mut queued = vec![false; self.values.len()];
        for &i in &layer {
            queued[i] = true;
        }
        while !layer.is_empty() {
            let fills: Vec<f64> = layer
                .iter()
                .map(|&i| self.neighbour_mean(i).unwrap_or(f64::NAN))
                .collect();
            for (&i, &m) in layer.iter().zip(&fills) {
                self.values[i] = m;
            }
            let mut next = Vec::new();
            for &i in &layer {
                for j in self.neighbours(i) {
                    if self.values[j].is_nan() && !queued[j] {
                        queued[j] = true;
                        next.push(j);
                    }
                }
            }
            layer = next;
        }
    }

    /// The indices of the (up to eight) cells around cell `i`.
    pub fn neighbours(&self, i: usize) -> impl Iterator<Item = usize> + '_ {
        let (c, r) = ((i % self.cols) as isize, (i / self.cols) as isize);
        NEIGHBOURS.iter().filter_map(move |(dc, dr)| {
            let (cc, rr) = (c + dc, r + dr);
            (cc >= 0 && rr >= 0 && cc < self.cols as isize && rr < self.rows as isize)
                .then(|| rr as usize * self.cols + cc as usize)
        })
    }

    /// The mean of the filled cells among the eight around cell `i`.
    fn neighbour_mean(&self, i: usize) -> Option<f64> {
        let (mut sum, mut n) = (0.0, 0);
        for j in self.neighbours(i) {
            if !self.values[j].is_nan() {
                sum += self.values[j];
                n += 1;
            }
        }
        (n > 0).then(|| sum / n as f64)
    }

    /// The cells around cell `i` within `radius_m` of its centre (itself
    /// included), by index.
    pub fn within(&self, i: usize, radius_m: f64) -> impl Iterator<Item = usize> + '_ {
        let (c, r) = ((i % self.cols) as isize, (i / self.cols) as isize);
        let reach = (radius_m / self.cell_m).floor() as isize;
        let r2 = (radius_m / self.cell_m).powi(2);
        (-reach..=reach).flat_map(move |dr| {
            (-reach..=reach).filter_map(move |dc| {
                let (cc, rr) = (c + dc, r + dr);
                let inside =
                    cc >= 0 && rr >= 0 && cc < self.cols as isize && rr < self.rows as isize;
                (inside && (dc * dc + dr * dr) as f64 <= r2)
                    .then(|| rr as usize * self.cols + cc as usize)
            })
        })
    }

    /// The grid as a terrain height grid (its nodes at the cell centres),
    /// for a GeoTIFF.
    pub fn to_height_grid(&self) -> HeightGrid {
        HeightGrid {
            cols: self.cols,
            rows: self.rows,
            origin_m: [
                self.corner_m[0] + 0.5 * self.cell_m,
                self.corner_m[1] + 0.5 * self.cell_m,
            ],
            spacing_m: [self.cell_m, self.cell_m],
            z_offset_m: 0.0,
            heights: self.values.iter().map(|&v| v as f32).collect(),
        }
    }
}

/// Points sorted by cell: `order[start[i]..start[i + 1]]` are the points
/// of cell `i`.
pub struct CellIndex {
    /// The grid.
    pub grid: Grid,
    /// Point indices, cell by cell.
    pub order: Vec<u32>,
    /// Where each cell's points start in `order` (one more entry than
    /// cells).
    pub start: Vec<u32>,
}

impl CellIndex {
    /// The points `keep` accepts, by cell of `grid` (a counting sort).
    pub fn new(grid: Grid, x: &[f64], y: &[f64], keep: impl Fn(usize) -> bool) -> Self {
        let cell: Vec<Option<usize>> = (0..x.len())
            .map(|k| keep(k).then(|| grid.cell_of(x[k], y[k])).flatten())
            .collect();
        let mut start = vec![0u32; grid.values.len() + 1];
        for &c in cell.iter().flatten() {
            start[c + 1] += 1;
        }
        for i in 0..grid.values.len() {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut order = vec![0u32; start[grid.values.len()] as usize];
        for (k, c) in cell.iter().enumerate() {
            if let Some(c) = *c {
                order[fill[c] as usize] = k as u32;
                fill[c] += 1;
            }
        }
        Self { grid, order, start }
    }

    /// The points of cell `i`.
    pub fn points(&self, i: usize) -> &[u32] {
        &self.order[self.start[i] as usize..self.start[i + 1] as usize]
    }
}

/// The eight neighbours of a cell, as (column, row) steps.
pub const NEIGHBOURS: [(isize, isize); 8] = [
    (-1, -1),
    (0, -1),
    (1, -1),
    (-1, 0),
    (1, 0),
    (-1, 1),
    (0, 1),
    (1, 1),
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_hold_the_extremes_of_their_points() {
        let mut g = Grid::covering([0.0, 0.0, 3.9, 1.9], 2.0).unwrap();
        assert_eq!((g.cols, g.rows), (2, 1));
        let x = [0.5, 1.5, 2.5, 9.0];
        let y = [0.5, 1.0, 1.5, 0.0];
        let z = [3.0, 5.0, 1.0, 100.0];
        g.extreme((&x, &y, &z), |_| true, true);
        assert_eq!(g.values, vec![5.0, 1.0]);
        g.values = vec![f64::NAN; 2];
        g.extreme((&x, &y, &z), |k| k != 1, false);
        assert_eq!(g.values, vec![3.0, 1.0]);
        g.count((&x, &y), |_| true);
        assert_eq!(g.values, vec![2.0, 1.0]);
    }

    /// A plane sampled at the cell centres is reproduced between them, and
    /// a hole is filled with values between its neighbours'.
    #[test]
    fn bilinear_reproduces_a_plane_and_gaps_fill_from_neighbours() {
        let mut g = Grid::covering([0.0, 0.0, 9.9, 9.9], 1.0).unwrap();
        for i in 0..g.values.len() {
            let [x, y] = g.centre(i);
            g.values[i] = 2.0 * x - 0.5 * y + 1.0;
        }
        for (x, y) in [(3.3, 4.7), (0.5, 0.5), (9.5, 2.2)] {
            assert!((g.bilinear(x, y) - (2.0 * x - 0.5 * y + 1.0)).abs() < 1e-12);
        }
        let truth = g.values.clone();
        for i in [44, 45, 54, 55, 0] {
            g.values[i] = f64::NAN;
        }
        g.fill_gaps();
        for i in [44, 45, 54, 55, 0] {
            assert!((g.values[i] - truth[i]).abs() < 2.0, "{i}: {}", g.values[i]);
        }
        assert!(g.values.iter().all(|v| v.is_finite()));
    }

    #[test]
    fn within_gives_the_cells_of_a_disc() {
        let g = Grid::covering([0.0, 0.0, 9.9, 9.9], 1.0).unwrap();
        assert_eq!(g.within(55, 1.0).count(), 5);
        assert_eq!(g.within(55, 1.5).count(), 9);
        assert_eq!(g.within(0, 1.0).count(), 3);
    }
}

//! Tree tops: the points that are the highest within a circular window
//! whose diameter grows with their height — lidR's `locate_trees(las,
//! lmf(ws = f))` (Roussel et al. 2020) on the points, the variable window
//! of Popescu & Wynne (2004). The window's diameter is `a + b·h + c·h²`
//! ([`Window`]); the default is the lidR book's `3 + 0.1·h` (Roussel,
//! Goodbody & Tompalski, "The lidR package", chapter "Individual tree
//! detection"), Popescu & Wynne's combined conifer and deciduous fit is
//! `2.51503 + 0.00901·h²` (FUSION's CanopyMaxima default).
//!
//! Points are indexed by cell of a fine grid, so that a candidate is
//! tested against the few cells its window covers, and only the highest
//! point of each cell can be a top (a window is wider than a cell).

use rayon::prelude::*;

use crate::scan::grid::{CellIndex, Grid};

/// The window diameter of a height: `a + b·h + c·h²`, m.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Window {
    /// Constant, m.
    pub a_m: f64,
    /// Per metre of height.
    pub b: f64,
    /// Per square metre of height, 1/m.
    pub c_per_m: f64,
}

impl Window {
    /// The lidR book's variable window, `3 + 0.1·h` m.
    pub const LIDR_BOOK: Window = Window {
        a_m: 3.0,
        b: 0.1,
        c_per_m: 0.0,
    };

    /// Popescu & Wynne's (2004) combined model, `2.51503 + 0.00901·h²` m.
    pub const POPESCU_WYNNE: Window = Window {
        a_m: 2.51503,
        b: 0.0,
        c_per_m: 0.00901,
    };

    /// The diameter for height `h_m`, at least one cell's diagonal.
    pub fn diameter_m(&self, h_m: f64) -> f64 {
        self.a_m + self.b * h_m + self.c_per_m * h_m * h_m
    }
}

/// The indices of the points that are tree tops: at least `min_height_m`
/// above the ground (`h`), and higher than every other point within
/// half the window's diameter (of equal points, the first in the file).
pub fn locate_tops(
    (x, y, h): (&[f64], &[f64], &[f64]),
    window: Window,
    min_height_m: f64,
    grid: Grid,
) -> Vec<usize> {
    let index = CellIndex::new(grid, x, y, |k| h[k] >= min_height_m);
    // The highest point of each cell (the first of equals).
    let highest: Vec<Option<u32>> = (0..index.grid.values.len())
        .map(|i| {
            index
                .points(i)
                .iter()
                .copied()
                .reduce(|a, b| if beats(h, b, a) { b } else { a })
        })
        .collect();
    let cell_max: Vec<f64> = highest
        .iter()
        .map(|p| p.map_or(f64::NEG_INFINITY, |p| h[p as usize]))
        .collect();
    let mut tops: Vec<usize> = highest
        .par_iter()
        .flatten()
        .filter(|&&p| {
            let p = p as usize;
            let r = 0.5 * window.diameter_m(h[p]);
            let Some(home) = index.grid.cell_of(x[p], y[p]) else {
                return false;
            };
            // Cells whose square meets the window: centres within r plus
            // half a diagonal.
            let reach = r + index.grid.cell_m * std::f64::consts::FRAC_1_SQRT_2;
            index.grid.within(home, reach).all(|c| {
                cell_max[c] < h[p]
                    || index.points(c).iter().all(|&q| {
                        let q = q as usize;
                        q == p
                            || !beats(h, q as u32, p as u32)
                            || (x[q] - x[p]).hypot(y[q] - y[p]) > r
                    })
            })
        })
        .map(|&p| p as usize)
        .collect();
    tops.sort_unstable();
    tops
}

/// Whether point `a` ranks above point `b`: higher, or as high and first.
fn beats(h: &[f64], a: u32, b: u32) -> bool {
    let (ha, hb) = (h[a as usize], h[b as usize]);
    ha > hb || (ha == hb && a < b)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Tops found by testing every pair of points: the definition.
    fn brute(x: &[f64], y: &[f64], h: &[f64], window: Window, hmin: f64) -> Vec<usize> {
        (0..x.len())
            .filter(|&p| {
                h[p] >= hmin
                    && (0..x.len()).all(|q| {
                        q == p
                            || h[q] < hmin
                            || !beats(h, q as u32, p as u32)
                            || (x[q] - x[p]).hypot(y[q] - y[p]) > 0.5 * window.diameter_m(h[p])
                    })
            })
            .collect()
    }

    /// On a rough random canopy, the indexed search finds exactly the
    /// points the definition does, for both windows.
    #[test]
    fn the_indexed_search_finds_what_the_definition_does() {
        let mut s = crate::rng::Stream::new(4, 0, 0, crate::rng::Purpose::Test);
        let n = 3000;
        let x: Vec<f64> = (0..n).map(|_| 60.0 * s.uniform()).collect();
        let y: Vec<f64> = (0..n).map(|_| 60.0 * s.uniform()).collect();
        // Crowns as cones on a lattice, plus noise, some ground.
        let h: Vec<f64> = (0..n)
            .map(|k| {
                let (cx, cy) = ((x[k] / 7.0).round() * 7.0, (y[k] / 7.0).round() * 7.0);
                let d = (x[k] - cx).hypot(y[k] - cy);
                (20.0 + cx * 0.1 - 3.0 * d + 0.3 * s.uniform()).max(0.0)
            })
            .collect();
        for window in [Window::LIDR_BOOK, Window::POPESCU_WYNNE] {
            let grid = Grid::covering([0.0, 0.0, 60.0, 60.0], 0.5).unwrap();
            let fast = locate_tops((&x, &y, &h), window, 2.0, grid);
            assert_eq!(fast, brute(&x, &y, &h, window, 2.0));
            assert!(fast.len() > 40, "{}", fast.len());
        }
    }
}

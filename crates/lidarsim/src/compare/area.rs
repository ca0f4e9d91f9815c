//! The area two clouds have in common: within both their bounds (and the
//! user's rectangle), the cells of a fine grid in which both have first
//! returns; and the comparison grid of `cell_m` cells over it, each cell
//! used when at least half of it is common.

use crate::scan::ScanCloud;
use crate::scan::density::area_cell;
use crate::scan::grid::Grid;

/// A comparison cell is used when this share of it is common area.
pub const MIN_CELL_SHARE: f64 = 0.5;

/// The common area.
#[derive(Clone, Debug)]
pub struct CommonArea {
    /// Fine cells: 1 where both clouds have first returns, else 0.
    pub fine: Grid,
    /// The common area, m².
    pub area_m2: f64,
    /// The comparison grid; each cell's value the common area in it, m².
    pub cells: Grid,
}

impl CommonArea {
    /// Whether `(x, y)` lies in the common area.
    pub fn contains(&self, x: f64, y: f64) -> bool {
        self.fine
            .cell_of(x, y)
            .is_some_and(|i| self.fine.values[i] > 0.0)
    }

    /// Whether comparison cell `i` is used.
    pub fn used(&self, i: usize) -> bool {
        self.cells.values[i] >= MIN_CELL_SHARE * self.cells.cell_m * self.cells.cell_m
    }
}

/// The common area of `a` and `b` within `rect` (if given, `[xmin, ymin,
/// xmax, ymax]`, the maxima excluded), on fine cells
/// of about 50 first returns of the sparser cloud and comparison cells of
/// `cell_m`. `None` when they share no area.
pub fn common_area(
    a: &ScanCloud,
    b: &ScanCloud,
    rect: Option<[f64; 4]>,
    cell_m: f64,
) -> Option<CommonArea> {
    let (ba, bb) = (a.bounds(), b.bounds());
    let mut bounds = [
        ba[0].max(bb[0]),
        ba[1].max(bb[1]),
        ba[2].min(bb[2]),
        ba[3].min(bb[3]),
    ];
    if let Some(r) = rect {
        bounds = [
            bounds[0].max(r[0]),
            bounds[1].max(r[1]),
            bounds[2].min(r[2]),
            bounds[3].min(r[3]),
        ];
    }
    if !(bounds[2] > bounds[0] && bounds[3] > bounds[1]) {
        return None;
    }
    // Half-open, [xmin, xmax) × [ymin, ymax): a cell beyond the rectangle
    // holds no point of it.
    let inside = |c: &ScanCloud, k: usize| {
        c.is_first(k)
            && (bounds[0]..bounds[2]).contains(&c.x[k])
            && (bounds[1]..bounds[3]).contains(&c.y[k])
    };
    let area = (bounds[2] - bounds[0]) * (bounds[3] - bounds[1]);
    let density = |c: &ScanCloud| (0..c.len()).filter(|&k| inside(c, k)).count() as f64 / area;
    let fine_m = area_cell(density(a).min(density(b))).min(cell_m);
    let mut fa = Grid::covering(bounds, fine_m)?;
    let mut fb = fa.clone();
    fa.count((&a.x, &a.y), |k| inside(a, k));
    fb.count((&b.x, &b.y), |k| inside(b, k));
    let mut fine = fa;
    for (v, w) in fine.values.iter_mut().zip(&fb.values) {
        *v = if *v > 0.0 && *w > 0.0 { 1.0 } else { 0.0 };
    }
    let mut cells = Grid::covering(bounds, cell_m)?;
    cells.values.iter_mut().for_each(|v| *v = 0.0);
    let fine_area = fine_m * fine_m;
    let mut area_m2 = 0.0;
    for i in 0..fine.values.len() {
        if fine.values[i] > 0.0 {
            let [x, y] = fine.centre(i);
            if let Some(c) = cells.cell_of(x, y) {
                cells.values[c] += fine_area;
            }
            area_m2 += fine_area;
        }
    }
    (area_m2 > 0.0).then_some(CommonArea {
        fine,
        area_m2,
        cells,
    })
}

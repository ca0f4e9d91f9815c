//! Point density over the area a set of points covers: points per m² of
//! the cells that hold points, counted on the interior cells only (those
//! whose eight neighbours hold points too), so that the cells the area's
//! edge cuts do not count as whole cells. The cell is chosen to hold
//! about [`POINTS_PER_CELL`] points, so that a cell inside the area is
//! empty only where the area has a hole: a scan's points are not spread
//! as evenly as a Poisson process's (an oscillating mirror's scan lines
//! part at the swath's edges; a crown hides the ground behind it from a
//! slanted beam and takes its returns), and with smaller cells the cells
//! next to such gaps, left out, would be the sparse ones (on a simulated
//! strip, cells of 8 points overstated its density by 12 %).

use super::grid::Grid;
use super::ground::nice_cell;

/// Points an area cell is meant to hold.
pub const POINTS_PER_CELL: f64 = 50.0;

/// The density of a set of points and the area it was measured over.
#[derive(Clone, Debug, PartialEq)]
pub struct Density {
    /// Points per m².
    pub per_m2: f64,
    /// The area the points cover (all cells holding points), m².
    pub area_m2: f64,
    /// The cell, m.
    pub cell_m: f64,
    /// Cells counted.
    pub cells: usize,
    /// Whether they are interior cells (else the area has fewer than
    /// [`MIN_INTERIOR_CELLS`] and all cells holding points are counted:
    /// the density is then understated by the cells the edge cuts).
    pub interior: bool,
}

/// Interior cells a density needs to be measured on them alone.
pub const MIN_INTERIOR_CELLS: usize = 10;

/// The occupancy of the points `keep` accepts on a grid of `cell_m` over
/// `bounds`: per cell their count.
pub fn occupancy(
    (x, y): (&[f64], &[f64]),
    keep: impl Fn(usize) -> bool,
    bounds: [f64; 4],
    cell_m: f64,
) -> Option<Grid> {
    let mut g = Grid::covering(bounds, cell_m)?;
    g.count((x, y), keep);
    Some(g)
}

/// The cell for points of about `rough_per_m2`: [`POINTS_PER_CELL`] a
/// cell, 1 to 100 m.
pub fn area_cell(rough_per_m2: f64) -> f64 {
    nice_cell(
        (POINTS_PER_CELL / rough_per_m2.max(1e-6))
            .sqrt()
            .clamp(1.0, 100.0),
    )
}

/// The density of the points of `counts` (an [`occupancy`] grid).
pub fn density_of(counts: &Grid) -> Density {
    let cell_area = counts.cell_m * counts.cell_m;
    let occupied: Vec<usize> = (0..counts.values.len())
        .filter(|&i| counts.values[i] > 0.0)
        .collect();
    let interior: Vec<usize> = occupied
        .iter()
        .copied()
        .filter(|&i| {
            let n = counts
                .neighbours(i)
                .filter(|&j| counts.values[j] > 0.0)
                .count();
            n == 8
        })
        .collect();
    let inside = interior.len() >= MIN_INTERIOR_CELLS;
    let counted = if inside { &interior } else { &occupied };
    let points: f64 = counted.iter().map(|&i| counts.values[i]).sum();
    Density {
        per_m2: points / (counted.len().max(1) as f64 * cell_area),
        area_m2: occupied.len() as f64 * cell_area,
        cell_m: counts.cell_m,
        cells: counted.len(),
        interior: inside,
    }
}

/// The density of the points `keep` accepts, on cells chosen from their
/// number over the bounding box (a first guess that errs towards smaller
/// cells).
pub fn density((x, y): (&[f64], &[f64]), keep: impl Fn(usize) -> bool + Copy) -> Option<Density> {
    let mut b = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    let mut n = 0usize;
    for k in (0..x.len()).filter(|&k| keep(k)) {
        b = [
            b[0].min(x[k]),
            b[1].min(y[k]),
            b[2].max(x[k]),
            b[3].max(y[k]),
        ];
        n += 1;
    }
    if n == 0 {
        return None;
    }
    let rough = n as f64 / ((b[2] - b[0]) * (b[3] - b[1])).max(1.0);
    let counts = occupancy((x, y), keep, b, area_cell(rough))?;
    Some(density_of(&counts))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points on a lattice of 0.5 m (4 per m²) over an L-shaped area: the
    /// density is found whatever the shape, and the area is the L's.
    #[test]
    fn a_lattice_gives_its_density_over_an_irregular_area() {
        let (mut x, mut y) = (Vec::new(), Vec::new());
        for i in 0..200 {
            for j in 0..200 {
                let (px, py) = (i as f64 * 0.5 + 0.25, j as f64 * 0.5 + 0.25);
                if px < 50.0 || py < 50.0 {
                    x.push(px);
                    y.push(py);
                }
            }
        }
        let d = density((&x, &y), |_| true).unwrap();
        assert!((d.per_m2 - 4.0).abs() < 1e-9, "{d:?}");
        assert!((d.area_m2 - 7500.0).abs() < 0.1 * 7500.0, "{d:?}");
    }
}

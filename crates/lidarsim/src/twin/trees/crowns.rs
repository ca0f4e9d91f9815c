//! Crowns: each canopy cell of the canopy height model (CHM) given to its
//! tree, and each tree's crown sized from its cells.
//!
//! The segmentation is lidR's `silva2016` (Silva et al. 2016, "Imputation
//! of individual longleaf pine tree attributes from field and LiDAR
//! data", Canadian Journal of Remote Sensing 42(5)): a cell belongs to
//! its nearest top (a Voronoi tessellation of the tops) if it is within
//! `0.6 × H` of it and at least `0.3 × H` high, `H` the highest cell of
//! the top's tessellation cell — with one change: "nearest" is measured
//! in units of each top's height (distance / H, a multiplicatively
//! weighted Voronoi tessellation), as silva2016 measures a crown's reach.
//! With plain distances a short tree beside a tall one takes the tall
//! crown's near edge (on a simulated pine stand, a tenth of the crowns
//! came out twice their true radius or more).
//!
//! A disc of the segment's area (its equal-area radius) leaves a closed
//! canopy open: a segment is a polygon between its neighbours, and the
//! disc misses its corners (on lidR's MixedConifer example, discs of equal
//! area cover 74 % of the cells the CHM has above 2 m). A crown's radius
//! is therefore the radius of the top-centred disc that holds
//! [`COVER_SHARE`] of its segment's cells: crowns then overlap as real
//! interlocking crowns do (96 % of the canopy cells on that example), but
//! reach into the gaps too; the trees' module then scales every radius by
//! one factor so that the discs cover the canopy's area.

use rayon::prelude::*;

use crate::scan::grid::{CellIndex, Grid};

/// Segments more than this far from their top are cut (silva2016's
/// `max_cr_factor`): the crown radius at most this times the height.
pub const MAX_CROWN_FACTOR: f64 = 0.6;

/// Cells lower than this share of their tree's height are not its crown
/// (silva2016's `exclusion`).
pub const EXCLUSION: f64 = 0.3;

/// The share of its segment's cells a crown's disc holds.
pub const COVER_SHARE: f64 = 0.95;

/// A tree top on the CHM: its position and height.
#[derive(Clone, Copy, Debug)]
pub struct Top {
    /// Position, m.
    pub x_m: f64,
    /// Position, m.
    pub y_m: f64,
    /// Height above the ground, m.
    pub height_m: f64,
}

/// What the segmentation gives each top.
#[derive(Clone, Debug, Default)]
pub struct Segment {
    /// The CHM cells of the crown.
    pub cells: Vec<usize>,
    /// The radius of the top-centred disc holding [`COVER_SHARE`] of
    /// them, m.
    pub radius_m: f64,
    /// The radius of a disc of the segment's area, m.
    pub equal_area_radius_m: f64,
}

/// The crown segment of every top (in order) on `chm` (heights above
/// ground, every cell filled); cells below `min_height_m` are no crown.
pub fn segment(chm: &Grid, tops: &[Top], min_height_m: f64) -> Vec<Segment> {
    let owner = nearest_tops(chm, tops, min_height_m);
    // The highest cell of each top's tessellation cell.
    let mut hmax = vec![0.0f64; tops.len()];
    for (i, o) in owner.iter().enumerate() {
        if let Some((t, _)) = o {
            hmax[*t] = hmax[*t].max(chm.values[i]);
        }
    }
    let mut segments = vec![Segment::default(); tops.len()];
    for (i, o) in owner.iter().enumerate() {
        if let Some((t, d)) = *o
            && chm.values[i] >= EXCLUSION * hmax[t]
            && d <= MAX_CROWN_FACTOR * hmax[t]
        {
            segments[t].cells.push(i);
        }
    }
    let cell_area = chm.cell_m * chm.cell_m;
    segments.par_iter_mut().zip(tops).for_each(|(s, top)| {
        let mut d: Vec<f64> = s
            .cells
            .iter()
            .map(|&i| {
                let [cx, cy] = chm.centre(i);
                (cx - top.x_m).hypot(cy - top.y_m)
            })
            .collect();
        d.sort_by(f64::total_cmp);
        s.equal_area_radius_m = (s.cells.len() as f64 * cell_area / std::f64::consts::PI).sqrt();
        // The disc through the centre of the cell at the share, grown by
        // half a cell to hold that cell whole.
        s.radius_m = match d.len() {
            0 => 0.0,
            n => d[((n - 1) as f64 * COVER_SHARE).round() as usize] + 0.5 * chm.cell_m,
        };
    });
    segments
}

/// For every cell at least `min_height_m` high, the nearest top in units
/// of the top's height and its distance, m, within [`MAX_CROWN_FACTOR`]
/// times the highest top's height (tops bucketed in square cells,
/// searched outwards ring by ring).
fn nearest_tops(chm: &Grid, tops: &[Top], min_height_m: f64) -> Vec<Option<(usize, f64)>> {
    let tallest = tops.iter().map(|t| t.height_m).fold(0.0, f64::max);
    let reach = MAX_CROWN_FACTOR * tallest;
    let bucket_m = (2.0 * chm.cell_m).max(4.0);
    let Some(mut buckets) = Grid::covering(
        [
            chm.corner_m[0],
            chm.corner_m[1],
            chm.corner_m[0] + chm.cols as f64 * chm.cell_m,
            chm.corner_m[1] + chm.rows as f64 * chm.cell_m,
        ],
        bucket_m,
    ) else {
        return vec![None; chm.values.len()];
    };
    buckets.values.iter_mut().for_each(|v| *v = 0.0);
    let xs: Vec<f64> = tops.iter().map(|t| t.x_m).collect();
    let ys: Vec<f64> = tops.iter().map(|t| t.y_m).collect();
    let index = CellIndex::new(buckets, &xs, &ys, |_| true);
    let rings = (reach / bucket_m).ceil() as isize + 1;
    (0..chm.values.len())
        .into_par_iter()
        .map(|i| {
            if chm.values[i] < min_height_m {
                return None;
            }
            let [cx, cy] = chm.centre(i);
            let home = index.grid.cell_of(cx, cy)?;
            let (hc, hr) = (
                (home % index.grid.cols) as isize,
                (home / index.grid.cols) as isize,
            );
            // (top, distance / its height, distance).
            let mut best: Option<(usize, f64, f64)> = None;
            for ring in 0..=rings {
                // A top in ring k is at least (k − 1) buckets away, and no
                // top is taller than the tallest.
                let nearest = (ring - 1).max(0) as f64 * bucket_m / tallest;
                if best.is_some_and(|(_, w, _)| w < nearest) {
                    break;
                }
                for (c, r) in ring_cells(hc, hr, ring) {
                    if c < 0
                        || r < 0
                        || c >= index.grid.cols as isize
                        || r >= index.grid.rows as isize
                    {
                        continue;
                    }
                    for &t in index.points(r as usize * index.grid.cols + c as usize) {
                        let t = t as usize;
                        let d = (tops[t].x_m - cx).hypot(tops[t].y_m - cy);
                        let w = d / tops[t].height_m;
                        if best.is_none_or(|(bt, bw, _)| w < bw || (w == bw && t < bt)) {
                            best = Some((t, w, d));
                        }
                    }
                }
            }
            best.filter(|&(_, _, d)| d <= reach).map(|(t, _, d)| (t, d))
        })
        .collect()
}

/// The cells of the square ring `ring` around `(c, r)` (the cell itself
/// for ring 0).
fn ring_cells(c: isize, r: isize, ring: isize) -> impl Iterator<Item = (isize, isize)> {
    (-ring..=ring).flat_map(move |dr| {
        (-ring..=ring)
            .filter(move |dc| dr.abs() == ring || dc.abs() == ring)
            .map(move |dc| (c + dc, r + dr))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A CHM of two cones, one tall and one short, side by side.
    fn two_cones() -> (Grid, Vec<Top>) {
        let mut chm = Grid::covering([0.0, 0.0, 39.9, 19.9], 0.5).unwrap();
        let tops = vec![
            Top {
                x_m: 10.25,
                y_m: 10.25,
                height_m: 20.0,
            },
            Top {
                x_m: 25.25,
                y_m: 10.25,
                height_m: 12.0,
            },
        ];
        for i in 0..chm.values.len() {
            let [x, y] = chm.centre(i);
            chm.values[i] = tops
                .iter()
                .map(|t| t.height_m - 2.0 * (x - t.x_m).hypot(y - t.y_m))
                .fold(0.0, f64::max);
        }
        (chm, tops)
    }

    /// Each cell goes to the nearest top in units of the tops' heights;
    /// the crowns' radii are those of the discs that hold 95 % of their
    /// cells.
    #[test]
    fn cells_go_to_their_nearest_top_within_the_limits() {
        let (chm, tops) = two_cones();
        let s = segment(&chm, &tops, 2.0);
        for (t, seg) in s.iter().enumerate() {
            for &i in &seg.cells {
                let [x, y] = chm.centre(i);
                let d: Vec<f64> = tops.iter().map(|u| (x - u.x_m).hypot(y - u.y_m)).collect();
                let w = |u: usize| d[u] / tops[u].height_m;
                assert!(w(t) <= w(1 - t), "cell {i} of top {t}");
                assert!(chm.values[i] >= EXCLUSION * tops[t].height_m && chm.values[i] >= 2.0);
                assert!(d[t] <= MAX_CROWN_FACTOR * tops[t].height_m);
            }
        }
        // The tall cone reaches its own 0.3 × 20 = 6 m at 7 m, nearer than
        // the weighted boundary (15 m × 20/32 = 9.4 m away): a disc of 7 m.
        let tall = &s[0];
        let area = tall.cells.len() as f64 * 0.25;
        assert!((area - std::f64::consts::PI * 49.0).abs() < 6.0, "{area}");
        assert!((tall.radius_m - 7.0).abs() < 0.6, "{}", tall.radius_m);
        // The short one reaches 3.6 m (0.3 × 12) at 4.2 m.
        assert!((s[1].radius_m - 4.2).abs() < 0.6, "{}", s[1].radius_m);
        assert!(s[1].equal_area_radius_m < s[1].radius_m);
    }
}

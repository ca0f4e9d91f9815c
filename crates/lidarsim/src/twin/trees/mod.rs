//! The trees of a scan: tops located on the points ([`tops`]), a canopy
//! height model (CHM: the highest return per cell above the ground, gaps
//! filled from their neighbours), each top's crown segmented on it and
//! sized ([`crowns`]), and each tree's crown base from the heights of the
//! returns in its crown.
//!
//! Buildings and other objects that are not vegetation are not told apart:
//! whatever stands above the ground is taken for trees, so a scan of a
//! town gives trees where its houses are.

pub mod crowns;
pub mod tops;

use rayon::prelude::*;
use serde::Serialize;

pub use crowns::{COVER_SHARE, EXCLUSION, MAX_CROWN_FACTOR};
pub use tops::Window;

use crate::scan::ScanCloud;
use crate::scan::grid::Grid;
use crate::scan::ground::{GroundModel, nice_cell};
use crate::scene::Species;
use crate::scene::tree::MIN_TREE_HEIGHT_M;

/// How trees are found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TreeSettings {
    /// The variable window of the tops.
    pub window: Window,
    /// Lowest tree top, m (at least [`MIN_TREE_HEIGHT_M`]).
    pub min_height_m: f64,
    /// The species of every tree.
    pub species: Species,
    /// The CHM's cell, m (`None`: from the point density).
    pub chm_cell_m: Option<f64>,
}

impl Default for TreeSettings {
    fn default() -> Self {
        Self {
            window: Window::LIDR_BOOK,
            min_height_m: MIN_TREE_HEIGHT_M,
            species: Species::Pine,
            chm_cell_m: None,
        }
    }
}

/// A tree of the twin.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TwinTree {
    /// Stem position, m.
    pub x_m: f64,
    /// Stem position, m.
    pub y_m: f64,
    /// The ground's height at the stem, m.
    pub z_m: f64,
    /// Height of the top above the ground, m.
    pub height_m: f64,
    /// Crown base above the ground, m.
    pub crown_base_m: f64,
    /// Crown radius, m.
    pub crown_radius_m: f64,
    /// Diameter at breast height from the species' height curve, m.
    pub dbh_m: f64,
}

/// What the tree detection found, for `twin.json`.
#[derive(Clone, Debug, Serialize)]
pub struct TreeReport {
    /// The window of the tops.
    pub window: Window,
    /// Lowest tree top, m.
    pub min_height_m: f64,
    /// The CHM's cell, m.
    pub chm_cell_m: f64,
    /// Trees found.
    pub trees: usize,
    /// Trees per hectare of the scan's area.
    pub trees_per_ha: f64,
    /// The species given to every tree.
    pub species: String,
    /// Share of the scan's area whose CHM is at least 2 m.
    pub canopy_share: f64,
    /// Share of those canopy cells that the crowns' discs cover.
    pub crowns_cover_of_canopy: f64,
    /// Share of the cells below 2 m that the crowns' discs cover.
    pub crowns_cover_of_gaps: f64,
    /// Share of the canopy cells discs of each segment's area would cover.
    pub equal_area_cover_of_canopy: f64,
    /// Height percentiles 5, 50, 95, m.
    pub height_m: [f64; 3],
    /// Crown radius percentiles 5, 50, 95, m.
    pub crown_radius_m: [f64; 3],
    /// Crown length over height, percentiles 5, 50, 95.
    pub crown_ratio: [f64; 3],
    /// How each crown base was found.
    pub crown_base: String,
}

/// The trees of `cloud` (heights `h` above `ground`) over `area`, the
/// cells of a grid that hold points.
pub fn detect_trees(
    cloud: &ScanCloud,
    h: &[f64],
    ground: &GroundModel,
    area: &Grid,
    settings: &TreeSettings,
) -> (Vec<TwinTree>, TreeReport) {
    let area_m2 = area.values.iter().filter(|&&v| v > 0.0).count() as f64 * area.cell_m.powi(2);
    let first = (0..cloud.len()).filter(|&k| cloud.is_first(k)).count() as f64;
    let cell = settings
        .chm_cell_m
        .unwrap_or_else(|| nice_cell((area_m2 / first.max(1.0)).sqrt().clamp(0.25, 2.0)));
    let bounds = cloud.bounds();
    let grid = Grid::covering(bounds, cell).unwrap_or_else(|| area.clone());
    // A top's window holds its cell (the search's premise).
    let index_cell = (0.5f64)
        .min(settings.window.diameter_m(0.0) / 3.0)
        .max(0.05);
    let index = Grid::covering(bounds, index_cell).unwrap_or_else(|| grid.clone());
    let min_h = settings.min_height_m.max(MIN_TREE_HEIGHT_M);
    let top_points = tops::locate_tops((&cloud.x, &cloud.y, h), settings.window, min_h, index);
    let mut chm = grid;
    chm.extreme((&cloud.x, &cloud.y, h), |_| true, true);
    chm.fill_gaps();
    chm.values.iter_mut().for_each(|v| *v = v.max(0.0));
    let top_list: Vec<crowns::Top> = top_points
        .iter()
        .map(|&k| crowns::Top {
            x_m: cloud.x[k],
            y_m: cloud.y[k],
            height_m: h[k],
        })
        .collect();
    let segments = crowns::segment(&chm, &top_list, min_h);
    let bases = crown_bases(cloud, h, &chm, &segments, &top_list, settings.species);
    let trees: Vec<TwinTree> = top_list
        .iter()
        .zip(&segments)
        .zip(&bases)
        .map(|((t, s), &base)| twin_tree(t, s, base, ground, settings.species))
        .collect();
    let trees = close_as_the_scan(&chm, area, trees);
    let report = report(&chm, area, &trees, &segments, settings, area_m2);
    (trees, report)
}

/// The trees with their crown radii scaled by one factor so that their
/// discs cover as many cells of `area` as the CHM has canopy (at least
/// 2 m high): the twin's canopy closes as much as the scan's. Crowns'
/// envelopes block the beam near their edge as well as at their middle,
/// so discs that spread into the scan's gaps (each disc holding
/// [`crowns::COVER_SHARE`] of its segment covers most of the gaps between
/// crowns too) would close gaps the scan sees through.
fn close_as_the_scan(chm: &Grid, area: &Grid, mut trees: Vec<TwinTree>) -> Vec<TwinTree> {
    let inside: Vec<bool> = (0..chm.values.len())
        .map(|i| {
            let [x, y] = chm.centre(i);
            area.cell_of(x, y).is_some_and(|a| area.values[a] > 0.0)
        })
        .collect();
    let canopy = (0..chm.values.len())
        .filter(|&i| inside[i] && chm.values[i] >= 2.0)
        .count();
    if trees.is_empty() || canopy == 0 {
        return trees;
    }
    let covered = |scale: f64| {
        disc_cover(chm, &trees, &|t| trees[t].crown_radius_m * scale)
            .iter()
            .zip(&inside)
            .filter(|(c, i)| **c && **i)
            .count()
    };
    // The covered area grows with the scale: bisection on it.
    let (mut lo, mut hi) = (0.2, 2.0);
    for _ in 0..24 {
        let mid = 0.5 * (lo + hi);
        if covered(mid) < canopy {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let scale = 0.5 * (lo + hi);
    for t in &mut trees {
        t.crown_radius_m = (t.crown_radius_m * scale).clamp(0.25, MAX_CROWN_FACTOR * t.height_m);
    }
    trees
}

/// A tree from its top, segment and crown base.
fn twin_tree(
    top: &crowns::Top,
    segment: &crowns::Segment,
    crown_base_m: f64,
    ground: &GroundModel,
    species: Species,
) -> TwinTree {
    let dbh_m = species.dbh_or_nearest_m(top.height_m);
    let radius = if segment.cells.is_empty() {
        species.crown_radius_m(dbh_m)
    } else {
        segment.radius_m
    };
    TwinTree {
        x_m: top.x_m,
        y_m: top.y_m,
        z_m: ground.z_at(top.x_m, top.y_m),
        height_m: top.height_m,
        crown_base_m,
        crown_radius_m: radius.clamp(0.25, MAX_CROWN_FACTOR * top.height_m),
        dbh_m,
    }
}

/// Each tree's crown base: the 5th percentile of the heights of the
/// returns in its segment's cells above both 2 m and [`EXCLUSION`] times
/// its height (understorey below is not its crown), between 5 % and 90 %
/// of its height; the species' live crown ratio when its segment holds
/// fewer than 10 such returns.
fn crown_bases(
    cloud: &ScanCloud,
    h: &[f64],
    chm: &Grid,
    segments: &[crowns::Segment],
    tops: &[crowns::Top],
    species: Species,
) -> Vec<f64> {
    let mut owner = vec![u32::MAX; chm.values.len()];
    for (t, s) in segments.iter().enumerate() {
        for &c in &s.cells {
            owner[c] = t as u32;
        }
    }
    let mut heights: Vec<Vec<f32>> = vec![Vec::new(); tops.len()];
    for (k, &hk) in h.iter().enumerate() {
        if let Some(c) = chm.cell_of(cloud.x[k], cloud.y[k])
            && owner[c] != u32::MAX
        {
            let t = owner[c] as usize;
            if hk >= MIN_TREE_HEIGHT_M.max(EXCLUSION * tops[t].height_m) {
                heights[t].push(hk as f32);
            }
        }
    }
    heights
        .par_iter_mut()
        .zip(tops)
        .map(|(hs, top)| {
            let tall = top.height_m;
            if hs.len() < 10 {
                return tall * (1.0 - species.preset().crown_ratio);
            }
            hs.sort_by(f32::total_cmp);
            let p5 = f64::from(hs[(hs.len() - 1) / 20]);
            p5.clamp(0.05 * tall, 0.9 * tall)
        })
        .collect()
}

/// The report: canopy share, how much of it the crowns cover, and the
/// trees' sizes.
fn report(
    chm: &Grid,
    area: &Grid,
    trees: &[TwinTree],
    segments: &[crowns::Segment],
    settings: &TreeSettings,
    area_m2: f64,
) -> TreeReport {
    let inside: Vec<bool> = (0..chm.values.len())
        .map(|i| {
            let [x, y] = chm.centre(i);
            area.cell_of(x, y).is_some_and(|a| area.values[a] > 0.0)
        })
        .collect();
    let discs = |radius: &dyn Fn(usize) -> f64| disc_cover(chm, trees, radius);
    let crowns = discs(&|t| trees[t].crown_radius_m);
    let equal = discs(&|t| segments[t].equal_area_radius_m);
    let share = |covered: &[bool], canopy: bool| {
        let (mut n, mut c) = (0usize, 0usize);
        for i in 0..chm.values.len() {
            if inside[i] && (chm.values[i] >= 2.0) == canopy {
                n += 1;
                c += usize::from(covered[i]);
            }
        }
        c as f64 / n.max(1) as f64
    };
    let n_inside = inside.iter().filter(|&&b| b).count().max(1);
    let n_canopy = (0..chm.values.len())
        .filter(|&i| inside[i] && chm.values[i] >= 2.0)
        .count();
    let pct = |v: Vec<f64>| percentiles(v, [0.05, 0.5, 0.95]);
    TreeReport {
        window: settings.window,
        min_height_m: settings.min_height_m,
        chm_cell_m: chm.cell_m,
        trees: trees.len(),
        trees_per_ha: trees.len() as f64 / (area_m2 / 10_000.0).max(1e-9),
        species: settings.species.name().to_string(),
        canopy_share: n_canopy as f64 / n_inside as f64,
        crowns_cover_of_canopy: share(&crowns, true),
        crowns_cover_of_gaps: share(&crowns, false),
        equal_area_cover_of_canopy: share(&equal, true),
        height_m: pct(trees.iter().map(|t| t.height_m).collect()),
        crown_radius_m: pct(trees.iter().map(|t| t.crown_radius_m).collect()),
        crown_ratio: pct(trees
            .iter()
            .map(|t| 1.0 - t.crown_base_m / t.height_m)
            .collect()),
        crown_base: "5th percentile of the heights of the returns in the crown's cells above \
                     2 m and 0.3 × the tree's height; the species' live crown ratio with fewer \
                     than 10 such returns"
            .into(),
    }
}

/// Which cells of `chm` the trees' discs (radius `radius(t)`) cover.
fn disc_cover(chm: &Grid, trees: &[TwinTree], radius: &dyn Fn(usize) -> f64) -> Vec<bool> {
    let mut covered = vec![false; chm.values.len()];
    for (t, tree) in trees.iter().enumerate() {
        let Some(home) = chm.cell_of(tree.x_m, tree.y_m) else {
            continue;
        };
        let r = radius(t);
        for i in chm.within(home, r + chm.cell_m) {
            let [x, y] = chm.centre(i);
            if (x - tree.x_m).hypot(y - tree.y_m) <= r {
                covered[i] = true;
            }
        }
    }
    covered
}

/// The values at quantiles `q` (nearest rank); zeros for no values.
pub fn percentiles<const N: usize>(mut v: Vec<f64>, q: [f64; N]) -> [f64; N] {
    v.retain(|x| x.is_finite());
    if v.is_empty() {
        return [0.0; N];
    }
    v.sort_by(f64::total_cmp);
    q.map(|q| v[((v.len() - 1) as f64 * q).round() as usize])
}

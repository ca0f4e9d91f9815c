//! Stage 2's sampling of what lies in the beam's cone between the
//! sub-rays (beam.rs, "Cone sampling").
//!
//! The bundle traversal hands over the surfaces its cone may meet that no
//! sub-ray hit ([`PulseTrace::unseen`]). Each one's outline in the
//! pattern's plane — the hull of its corners (a polygon's or triangle's
//! vertices, the box of a stem or voxel) — is cut into the cells it
//! meets; where it may lie resolvably nearer than the cell's sub-ray hit
//! (or the sub-ray misses), that piece is a patch, sampled by its own
//! rays, which carry the Gaussian beam's energy over it. So is the piece
//! of the surface a sub-ray hit in its own cell when that cell is sampled
//! again across a discontinuity and the surface does not fill it: a
//! target smaller than a cell keeps its own samples whether a sub-ray hit
//! it or not. Within a cell the patches are sampled smallest first, each
//! leaving out the samples that fall in a smaller one, and the rest of the
//! cell — its sub-ray, or its fine samples outside every patch — carries
//! the cell's energy less the patches', so that nothing is counted twice.

use super::Simulator;
use crate::accel::PulseTrace;
use crate::geometry::{DMat3, DVec3};
use crate::scene::Shape;
use crate::sensor::beam::{BeamPattern, Fineness, Outline};

/// The least depth along the beam axis at which a surface's corners are
/// projected; the parts of a polygon nearer the scanner are cut off, m.
const NEAREST_M: f64 = 1e-3;

/// A piece of an unseen surface's outline within one cell.
#[derive(Clone, Debug, Default)]
struct Patch {
    /// The cell.
    cell: usize,
    /// Its outline.
    shape: Outline,
    /// Its area.
    area: f64,
}

/// Working storage of cone sampling, kept between pulses.
#[derive(Default)]
pub(super) struct ConeScratch {
    /// The outline of the surface at hand.
    outline: Outline,
    /// The patches of the pulse, the first `used` of them, by cell.
    patches: Vec<Patch>,
    /// Patches in use.
    used: usize,
    /// A surface's corners in the beam frame, and clipping storage.
    corners: Vec<DVec3>,
    work: Vec<DVec3>,
    /// The cells a surface gets patches in.
    cells: Vec<usize>,
    /// The surfaces the sub-rays of cells sampled again hit.
    hit: Vec<u32>,
}

/// The corners of `shape` relative to `origin` in the undeflected beam
/// frame (`from_world`), into `out`, and its plane there as `(n, c)`,
/// `n·q = c` with `c ≥ 0`, for a planar shape. `None` for shapes that are
/// not sampled: crowns (volumes) and terrain tiles (a height field is one
/// continuous surface with the tiles the sub-rays hit, its
/// discontinuities found by the sub-rays' own ranges).
fn corners_of(
    shape: &Shape,
    bounds: impl FnOnce() -> crate::geometry::Aabb,
    origin: DVec3,
    from_world: DMat3,
    out: &mut Vec<DVec3>,
) -> Option<Option<(DVec3, f64)>> {
    out.clear();
    let to_beam = |v: DVec3| from_world * (v - origin);
    let normal = match shape {
        Shape::Triangle(t) => {
            out.extend(t.vertices().map(to_beam));
            t.normal()
        }
        Shape::Polygon(p) => {
            out.extend(p.vertices().iter().map(|v| to_beam(*v)));
            p.normal()
        }
        Shape::Trunk(_) | Shape::Voxel(_) => {
            let b = bounds();
            for k in 0..8 {
                let pick = |bit: usize, lo: f64, hi: f64| if k & bit == 0 { lo } else { hi };
                let v = DVec3::new(
                    pick(1, b.min.x, b.max.x),
                    pick(2, b.min.y, b.max.y),
                    pick(4, b.min.z, b.max.z),
                );
                out.push(to_beam(v));
            }
            return Some(None);
        }
        Shape::Crown(_) | Shape::Terrain(_) => return None,
    };
    let n = from_world * normal;
    let c = n.dot(out[0]);
    Some(Some(if c < 0.0 { (-n, -c) } else { (n, c) }))
}

/// The planar polygon `poly` (beam frame) cut to `q.z ≥ NEAREST_M`
/// (Sutherland & Hodgman 1974), into `out`: its sides in order, the last
/// closing to the first.
fn cut_near(poly: &[DVec3], out: &mut Vec<DVec3>) {
    out.clear();
    let Some(&first) = poly.first() else {
        return;
    };
    let mut a = first;
    for &b in poly[1..].iter().chain([&first]) {
        let (da, db) = (a.z - NEAREST_M, b.z - NEAREST_M);
        if da >= 0.0 {
            out.push(a);
        }
        if (da < 0.0 && db > 0.0) || (da > 0.0 && db < 0.0) {
            out.push(a + (b - a) * (da / (da - db)));
        }
        a = b;
    }
}

impl ConeScratch {
    /// A patch of cell `cell`: `outline`'s part in it, kept when that part
    /// has an area and, for `whole_too` false, does not fill the cell.
    /// `holds`: whether the outline holds the cell's disk (so the whole
    /// cell). An outline the cell does not meet clips to nothing.
    fn add_patch(&mut self, pattern: &BeamPattern, cell: usize, whole_too: bool, holds: bool) {
        // An outline that holds the whole cell fills it, without clipping.
        if !whole_too && holds {
            return;
        }
        if self.used == self.patches.len() {
            self.patches.push(Patch::default());
        }
        let slot = &mut self.patches[self.used];
        slot.cell = cell;
        slot.shape.copy_from(&self.outline);
        pattern.clip_to_cell(cell, &mut slot.shape);
        slot.area = slot.shape.area();
        let fills = slot.area >= (1.0 - 1e-9) * pattern.cell_area(cell);
        if slot.area > 0.0 && (whole_too || !fills) {
            self.used += 1;
        }
    }
}

/// The pulse at hand: its pattern, where it left and its closest hits.
struct Pulse<'a> {
    pattern: &'a BeamPattern,
    origin: DVec3,
    from_world: DMat3,
    trace: &'a PulseTrace,
    /// The cells sampled again across a discontinuity (empty: none).
    marked: &'a [bool],
    /// The farthest closest hit, infinite when a sub-ray misses.
    farthest: f64,
}

impl Pulse<'_> {
    /// Distance to sub-ray `i`'s closest hit, infinite for a miss.
    fn range(&self, i: usize) -> f64 {
        self.trace
            .hit(i)
            .map_or(f64::INFINITY, |_| self.trace.range(i))
    }

    /// Whether cell `i` is sampled again across a discontinuity.
    fn marked(&self, i: usize) -> bool {
        self.marked.get(i).copied().unwrap_or(false)
    }
}

impl Simulator<'_> {
    /// The patches of the surfaces in `trace`'s cone that no sub-ray hit
    /// (pattern `pattern` from `origin`, undeflected beam frame to world
    /// `to_world`), and of those the sub-rays of the cells `marked` hit,
    /// into `cone`. Returns whether there is any.
    pub(super) fn find_patches(
        &self,
        (origin, to_world): (DVec3, DMat3),
        pattern: &BeamPattern,
        trace: &PulseTrace,
        marked: &[bool],
        cone: &mut ConeScratch,
    ) -> bool {
        cone.used = 0;
        let mut pulse = Pulse {
            pattern,
            origin,
            from_world: to_world.transpose(),
            trace,
            marked,
            farthest: 0.0,
        };
        pulse.farthest = (0..pattern.len())
            .map(|i| pulse.range(i))
            .fold(0.0, f64::max);
        for &p in trace.unseen() {
            self.patch_surface(p, &pulse, cone);
        }
        if !marked.is_empty() {
            let mut hit = std::mem::take(&mut cone.hit);
            hit.clear();
            hit.extend(
                (0..pattern.len())
                    .filter(|&i| pulse.marked(i))
                    .filter_map(|i| trace.hit(i).map(|h| h.prim)),
            );
            hit.sort_unstable();
            hit.dedup();
            for &p in &hit {
                self.patch_surface(p, &pulse, cone);
            }
            cone.hit = hit;
        }
        // By cell, the smallest first (a stable sort: the same order on
        // every run).
        cone.patches[..cone.used]
            .sort_by(|a, b| a.cell.cmp(&b.cell).then(a.area.total_cmp(&b.area)));
        cone.used > 0
    }

    /// The patches of surface `p` in `pulse`'s cells, into `cone`: in each
    /// cell its outline meets where it may lie resolvably nearer than the
    /// cell's closest hit, and in a cell sampled again whose sub-ray hit
    /// it, if it does not fill that cell.
    fn patch_surface(&self, p: u32, pulse: &Pulse, cone: &mut ConeScratch) {
        let prim = &self.caster.scene().primitives[p as usize];
        let pattern = pulse.pattern;
        let (origin, from_world) = (pulse.origin, pulse.from_world);
        let Some(plane) = corners_of(
            &prim.shape,
            || prim.bounds(),
            origin,
            from_world,
            &mut cone.corners,
        ) else {
            return;
        };
        let d = self.discontinuity_m;
        cone.outline.clear();
        if plane.is_some() {
            cut_near(&cone.corners, &mut cone.work);
            std::mem::swap(&mut cone.corners, &mut cone.work);
        } else if cone.corners.iter().any(|q| q.z < NEAREST_M) {
            // A box around the scanner: the whole beam.
            for q in [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]] {
                cone.outline.push(q);
            }
            cone.corners.retain(|q| q.z >= NEAREST_M);
        }
        // Its least depth along the axis: no point of it is nearer (a
        // range is at least the depth).
        let near = cone.corners.iter().fold(f64::INFINITY, |m, q| m.min(q.z));
        if near.is_nan() {
            return;
        }
        let hit_by = |i: usize| pulse.trace.hit(i).is_some_and(|h| h.prim == p);
        let own = |i: usize| pulse.marked(i) && hit_by(i);
        // The usual case first: a surface that lies nowhere in the beam
        // resolvably nearer than the farthest closest hit (the least depth
        // of its plane over the whole beam, for a plane), such as the
        // neighbours of a continuous surface.
        let mut lo_all = near;
        if let Some((n, c)) = plane {
            let (a, b) = pattern.normal_range(None, n);
            if a > 0.0 {
                lo_all = lo_all.max(c / b);
            }
        }
        if lo_all >= pulse.farthest - d && (pulse.marked.is_empty() || !(0..pattern.len()).any(own))
        {
            return;
        }
        // The cells where it may lie resolvably nearer than the closest hit
        // (the least depth of its plane over the cell, for a plane), or
        // that are sampled again and whose sub-ray hit it: cheap tests
        // first, so that the neighbours of a continuous surface cost no
        // outline.
        let mut cells = std::mem::take(&mut cone.cells);
        cells.clear();
        for i in 0..pattern.len() {
            let mut lo = near;
            if let Some((n, c)) = plane {
                let (a, b) = pattern.normal_range(Some(i), n);
                if a > 0.0 {
                    lo = lo.max(c / b);
                }
            }
            if lo < pulse.range(i) - d || own(i) {
                cells.push(i);
            }
        }
        if !cells.is_empty() {
            for q in &cone.corners {
                cone.outline.push(pattern.plane_point(*q));
            }
            pattern.close_outline(&mut cone.outline);
            if cone.outline.area() > 0.0 {
                for &i in &cells {
                    // A cell the outline holds meets it; one that may meet
                    // it is clipped, which leaves nothing where they are
                    // apart (cheaper than testing first: most that may
                    // meet do).
                    let holds = pattern.outline_holds_cell(i, &cone.outline);
                    if holds || pattern.cell_may_meet(i, &cone.outline) {
                        cone.add_patch(pattern, i, !hit_by(i), holds);
                    }
                }
            }
        }
        cone.cells = cells;
    }

    /// The fine samples of a pulse's cells into `fine`, with how many
    /// each cell has in `counts` (0: its sub-ray alone, carrying the
    /// returned share). The patches of `cone` are sampled on their own,
    /// smallest first, each without the samples in a smaller one; a cell
    /// marked in `marked` (across a discontinuity) and one whose sub-ray a
    /// patch covers are sampled at the fineness `edge`, without the samples
    /// in their patches; a patched cell's sub-ray
    /// otherwise carries what its patches do not. Returns the share of
    /// each sub-ray whose cell is neither marked nor patched: what the
    /// others leave of the pulse's energy.
    pub(super) fn sample_cells(
        pattern: &BeamPattern,
        edge: Fineness,
        marked: &[bool],
        cone: &ConeScratch,
        fine: &mut Vec<(DVec3, f64)>,
        counts: &mut Vec<u32>,
    ) -> f64 {
        let n = pattern.len();
        fine.clear();
        counts.clear();
        counts.resize(n, 0);
        let patches = &cone.patches[..cone.used];
        let (mut left, mut coarse) = (1.0, 0usize);
        let mut k = 0;
        for (i, count) in counts.iter_mut().enumerate() {
            let start = k;
            while k < patches.len() && patches[k].cell == i {
                k += 1;
            }
            let mine = &patches[start..k];
            let across = marked.get(i).copied().unwrap_or(false);
            if mine.is_empty() && !across {
                coarse += 1;
                continue;
            }
            let before = fine.len();
            let energy = pattern.cell_energy(i);
            let mut in_patches = 0.0;
            for (j, p) in mine.iter().enumerate() {
                let smaller = &mine[..j];
                let keep = |x| !smaller.iter().any(|q| q.shape.contains(x));
                in_patches += pattern.patch_samples(&p.shape, keep, fine);
            }
            // The patches' estimates hold at most the cell's energy.
            if in_patches > energy {
                for s in &mut fine[before..] {
                    s.1 *= energy / in_patches;
                }
                in_patches = energy;
            }
            let rest = energy - in_patches;
            let in_any = |x| mine.iter().any(|p| p.shape.contains(x));
            let patched = fine.len();
            if across || in_any(pattern.site(i)) {
                let kept = pattern.fine_samples_where(i, edge, |x| !in_any(x), rest, fine);
                if kept == 0 && in_patches > 0.0 {
                    // The patches cover every sample: they take the cell.
                    for s in &mut fine[before..patched] {
                        s.1 *= energy / in_patches;
                    }
                }
            } else {
                fine.push((pattern.base_directions()[i], rest));
            }
            if fine.len() == before {
                fine.push((pattern.base_directions()[i], energy));
            }
            *count = (fine.len() - before) as u32;
            left -= energy;
        }
        left.max(0.0) / coarse.max(1) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A square across the plane `z = NEAREST_M` keeps its corners in
    /// front and gains the two points where its sides cross the plane, in
    /// the order of its sides; one wholly in front is kept as it is, one
    /// wholly behind is cut away.
    #[test]
    fn cut_near_keeps_the_part_in_front() {
        let square = [
            DVec3::new(0.0, 0.0, -1.0),
            DVec3::new(1.0, 0.0, -1.0),
            DVec3::new(1.0, 0.0, 1.0),
            DVec3::new(0.0, 0.0, 1.0),
        ];
        let mut out = Vec::new();
        cut_near(&square, &mut out);
        let want = [
            DVec3::new(1.0, 0.0, NEAREST_M),
            DVec3::new(1.0, 0.0, 1.0),
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(0.0, 0.0, NEAREST_M),
        ];
        assert_eq!(out.len(), want.len(), "{out:?}");
        for (got, want) in out.iter().zip(want) {
            assert!((*got - want).length() < 1e-15, "{out:?}");
        }
        let ahead = square.map(|q| q + DVec3::new(0.0, 0.0, 2.0));
        cut_near(&ahead, &mut out);
        assert_eq!(out, ahead);
        let behind = square.map(|q| q - DVec3::new(0.0, 0.0, 2.0));
        cut_near(&behind, &mut out);
        assert!(out.is_empty());
    }
}

//! The sub-rays of the pulse march as columns of `f32`, eight to a
//! register, and the loops over them: each lane's optical depth in a
//! crown's cell at one level, and which lanes reach their threshold.
//!
//! Offsets from a stem are metres and the drifts a fraction of a metre, so
//! `f32` holds positions to micrometres, against a density that varies
//! over decimetres. The density loops are straight-line code over whole
//! registers (choices as selects, no early exit), which the compiler
//! vectorises; scalar and vector code give the same bits (no fused
//! operations), so a lane's depth computed alone ([`Lanes::cell_depth`])
//! is the one the loop added. The depths are added and compared with the
//! thresholds a register at a time by [`kernels::accumulate_depths`].

use crate::kernels;
use crate::scene::CrownLevel;
use crate::scene::foliage::{LevelField, clump_hash};

/// Sub-rays handled together: one 256-bit register of `f32`.
pub(super) const W: usize = kernels::LANES;

/// [`CrownLevel`] in `f32`, for the lanes.
#[derive(Clone, Copy, Debug)]
pub(super) struct Level32 {
    radius_sq: f32,
    inv_radius: f32,
    field: Field32,
}

/// [`LevelField`] in `f32`.
#[derive(Clone, Copy, Debug)]
enum Field32 {
    Uniform(f32),
    Specification {
        height_factor: f32,
        whorl_cos: f32,
        whorl_sin: f32,
    },
    Physical {
        inv_cell: f32,
        key: u32,
        below: u32,
        weight: f32,
        core_rc: f32,
    },
}

/// `floor(v)` as an integer for `|v| < 2³¹`, by truncation and a
/// correction below zero: one instruction each in the lanes, where a
/// `floor` without SSE4.1 would be a call.
#[inline(always)]
fn floor_i32(v: f32) -> i32 {
    let t = v as i32;
    t - i32::from((t as f32) > v)
}

impl Level32 {
    pub(super) fn new(l: &CrownLevel) -> Self {
        let field = match l.field {
            LevelField::Uniform(u) => Field32::Uniform(u as f32),
            LevelField::Specification {
                height_factor,
                whorl_cos,
                whorl_sin,
            } => Field32::Specification {
                height_factor: height_factor as f32,
                whorl_cos: whorl_cos as f32,
                whorl_sin: whorl_sin as f32,
            },
            LevelField::Physical {
                inv_cell,
                key,
                below,
                weight,
                core_rc,
            } => Field32::Physical {
                inv_cell: inv_cell as f32,
                key,
                below,
                weight: weight as f32,
                core_rc: core_rc as f32,
            },
        };
        Self {
            radius_sq: l.radius_sq as f32,
            inv_radius: l.inv_radius as f32,
            field,
        }
    }

    /// The specification's density in `f32` at horizontal offset
    /// `(dx, dy)` from the stem: its three factors, 0 outside the
    /// envelope.
    #[inline(always)]
    fn three_factors(&self, f: (f32, f32, f32), dx: f32, dy: f32) -> f32 {
        let (height_factor, whorl_cos, whorl_sin) = f;
        let d2 = dx * dx + dy * dy;
        let radius = 1.0 - d2.sqrt() * self.inv_radius;
        let (x2, y2) = (dx * dx - dy * dy, 2.0 * dx * dy);
        let (x3, y3) = (x2 * dx - y2 * dy, x2 * dy + y2 * dx);
        let (x6, y6) = (x3 * x3 - y3 * y3, 2.0 * x3 * y3);
        let d6 = d2 * d2 * d2;
        // Both sides computed, then chosen: no branch in the lanes.
        let off_axis = (x6 * whorl_cos - y6 * whorl_sin).abs() / d6;
        // Within a micrometre of the axis φ = 0, as in `density_at`.
        let theta = if d2 > 1e-12 {
            off_axis
        } else {
            whorl_cos.abs()
        };
        let rho = theta * height_factor * radius;
        if d2 <= self.radius_sq { rho } else { 0.0 }
    }

    /// The physical model's density in `f32`: `weight` in the shell's
    /// clump cells that hold foliage, 0 elsewhere and outside the
    /// envelope.
    #[inline(always)]
    fn clumped(&self, f: (f32, u32, u32, f32, f32), dx: f32, dy: f32) -> f32 {
        let (inv_cell, key, below, weight, core_rc) = f;
        let d2 = dx * dx + dy * dy;
        let rc = d2.sqrt() * self.inv_radius;
        let held = clump_hash(floor_i32(dx * inv_cell), floor_i32(dy * inv_cell), key) < below;
        if (d2 <= self.radius_sq) & held & (rc >= core_rc) {
            weight
        } else {
            0.0
        }
    }

    /// A constant density `u` inside the envelope, 0 outside.
    #[inline(always)]
    fn uniform(&self, u: f32, dx: f32, dy: f32) -> f32 {
        if dx * dx + dy * dy <= self.radius_sq {
            u
        } else {
            0.0
        }
    }

    /// The density at `(dx, dy)`, whatever the field (for one lane).
    #[inline(always)]
    fn density(&self, dx: f32, dy: f32) -> f32 {
        match self.field {
            Field32::Uniform(u) => self.uniform(u, dx, dy),
            Field32::Specification {
                height_factor,
                whorl_cos,
                whorl_sin,
            } => self.three_factors((height_factor, whorl_cos, whorl_sin), dx, dy),
            Field32::Physical {
                inv_cell,
                key,
                below,
                weight,
                core_rc,
            } => self.clumped((inv_cell, key, below, weight, core_rc), dx, dy),
        }
    }
}

/// A crown's cell at one level, as the lanes see it.
#[derive(Clone, Copy, Debug)]
pub(super) struct Cell {
    pub level: Level32,
    /// The pulse centre's offset from the stem at this level, m.
    pub centre: (f32, f32),
    /// Interception coefficient `k`, 1/m.
    pub k: f32,
    /// The level's height below the origin (negative), m.
    pub dz: f32,
}

/// The sub-rays still open in the march, one column each, padded to a
/// multiple of [`W`] with lanes that are never open.
#[derive(Clone, Debug, Default)]
pub(super) struct Lanes {
    /// Horizontal offset from the pulse's centre line per metre below the
    /// origin (x and y).
    sx: Vec<f32>,
    sy: Vec<f32>,
    /// Step length `Δs_i` along the sub-ray between levels, m.
    pub step: Vec<f32>,
    /// Heights relative to the origin between which the sub-ray is open:
    /// `bottom < z − o_z ≤ top`; `top` is −∞ once it is closed.
    top: Vec<f32>,
    bottom: Vec<f32>,
    /// Optical depth accumulated so far.
    pub depth: Vec<f32>,
    /// The threshold `E` the depth must reach.
    pub threshold: Vec<f32>,
    /// The current level's optical depth.
    pub level: Vec<f32>,
    /// The sub-ray (its index as pushed) of each lane; `u32::MAX` for
    /// padding.
    pub lane: Vec<u32>,
}

/// One sub-ray's column values.
pub(super) struct Lane {
    pub sx: f32,
    pub sy: f32,
    pub step: f32,
    pub top: f32,
    pub bottom: f32,
    pub threshold: f32,
}

impl Lanes {
    /// `n` lanes set by `lane(i)`, padded.
    pub(super) fn fill(&mut self, n: usize, lane: impl Fn(usize) -> Lane) {
        let padded = n.next_multiple_of(W);
        self.resize(padded);
        // Columns cut to `n` first, so that the loop needs no bounds checks.
        let (sx, sy, step) = (&mut self.sx[..n], &mut self.sy[..n], &mut self.step[..n]);
        let (top, bottom) = (&mut self.top[..n], &mut self.bottom[..n]);
        let (threshold, index) = (&mut self.threshold[..n], &mut self.lane[..n]);
        for i in 0..n {
            let l = lane(i);
            sx[i] = l.sx;
            sy[i] = l.sy;
            step[i] = l.step;
            top[i] = l.top;
            bottom[i] = l.bottom;
            threshold[i] = l.threshold;
            index[i] = i as u32;
        }
        self.depth[..padded].fill(0.0);
        self.level[..padded].fill(0.0);
        self.close_from(n);
    }

    fn resize(&mut self, n: usize) {
        for v in [
            &mut self.sx,
            &mut self.sy,
            &mut self.step,
            &mut self.top,
            &mut self.bottom,
            &mut self.depth,
            &mut self.threshold,
            &mut self.level,
        ] {
            v.resize(n, 0.0);
        }
        self.lane.resize(n, u32::MAX);
    }

    /// Makes the lanes from `n` on padding.
    fn close_from(&mut self, n: usize) {
        for i in n..self.len() {
            self.top[i] = f32::NEG_INFINITY;
            self.bottom[i] = f32::INFINITY;
            self.threshold[i] = f32::INFINITY;
            self.lane[i] = u32::MAX;
        }
    }

    pub(super) fn len(&self) -> usize {
        self.lane.len()
    }

    /// Closes lane `i` (intercepted).
    pub(super) fn close(&mut self, i: usize) {
        self.top[i] = f32::NEG_INFINITY;
    }

    /// Keeps the open lanes only (padded again).
    pub(super) fn compact(&mut self) {
        let mut kept = 0;
        for i in 0..self.len() {
            if self.top[i] == f32::NEG_INFINITY {
                continue;
            }
            self.sx[kept] = self.sx[i];
            self.sy[kept] = self.sy[i];
            self.step[kept] = self.step[i];
            self.top[kept] = self.top[i];
            self.bottom[kept] = self.bottom[i];
            self.depth[kept] = self.depth[i];
            self.threshold[kept] = self.threshold[i];
            self.lane[kept] = self.lane[i];
            kept += 1;
        }
        let padded = kept.next_multiple_of(W);
        self.resize(padded);
        self.close_from(kept);
        self.depth[kept..].fill(0.0);
        self.level.fill(0.0);
    }

    /// Sets each lane's level depth to its optical depth `k·ρ·Δs_i` in
    /// `cell` (0 for a lane not open).
    #[inline(always)]
    pub(super) fn set_cell(&mut self, cell: &Cell) {
        self.each_field(cell, |_, t| t);
    }

    /// Adds each open lane's optical depth `k·ρ·Δs_i` in `cell` to its
    /// level depth.
    #[inline(always)]
    pub(super) fn add_cell(&mut self, cell: &Cell) {
        self.each_field(cell, |a, t| a + t);
    }

    /// [`Lanes::with_cell`] with the loop specialised to the cell's field
    /// (chosen once, outside the loop).
    #[inline(always)]
    fn each_field(&mut self, cell: &Cell, combine: impl Fn(f32, f32) -> f32) {
        match cell.level.field {
            Field32::Uniform(u) => self.with_cell(cell, |l, dx, dy| l.uniform(u, dx, dy), combine),
            Field32::Specification {
                height_factor,
                whorl_cos,
                whorl_sin,
            } => {
                let f = (height_factor, whorl_cos, whorl_sin);
                self.with_cell(cell, |l, dx, dy| l.three_factors(f, dx, dy), combine)
            }
            Field32::Physical {
                inv_cell,
                key,
                below,
                weight,
                core_rc,
            } => {
                let f = (inv_cell, key, below, weight, core_rc);
                self.with_cell(cell, |l, dx, dy| l.clumped(f, dx, dy), combine)
            }
        }
    }

    /// Each lane's level depth `combine(level, tau)`, `tau` its depth in
    /// `cell` with density `rho`.
    #[inline(always)]
    fn with_cell(
        &mut self,
        cell: &Cell,
        rho: impl Fn(&Level32, f32, f32) -> f32,
        combine: impl Fn(f32, f32) -> f32,
    ) {
        let (px, py) = cell.centre;
        let (l, k, dz) = (&cell.level, cell.k, cell.dz);
        let n = self.len();
        let (sx, sy, step) = (&self.sx[..n], &self.sy[..n], &self.step[..n]);
        let (top, bottom) = (&self.top[..n], &self.bottom[..n]);
        let level = &mut self.level[..n];
        for i in 0..n {
            let (dx, dy) = (px + sx[i] * dz, py + sy[i] * dz);
            let open = (dz > bottom[i]) & (dz <= top[i]);
            let tau = k * rho(l, dx, dy) * step[i];
            level[i] = combine(level[i], if open { tau } else { 0.0 });
        }
    }

    /// Lane `i`'s depth in `cell` alone: the arithmetic of
    /// [`Lanes::add_cell`], to the bit.
    pub(super) fn cell_depth(&self, cell: &Cell, i: usize) -> f32 {
        let (px, py) = cell.centre;
        let (l, dz) = (&cell.level, cell.dz);
        let (dx, dy) = (px + self.sx[i] * dz, py + self.sy[i] * dz);
        let rho = l.density(dx, dy);
        let open = (dz > self.bottom[i]) & (dz <= self.top[i]);
        let tau = cell.k * rho * self.step[i];
        if open { tau } else { 0.0 }
    }

    /// Adds the level depths to the lanes' depths, except for the lanes
    /// whose depth would reach their threshold: those are listed in
    /// `reached` (cleared first), their depth unchanged.
    #[inline(always)]
    pub(super) fn advance(&mut self, reached: &mut Vec<usize>) {
        reached.clear();
        // The columns' lengths are multiples of W: no remainder.
        let registers = (self.depth.as_chunks_mut::<W>().0.iter_mut())
            .zip(self.level.as_chunks::<W>().0)
            .zip(self.threshold.as_chunks::<W>().0);
        for (c, ((depth, level), threshold)) in registers.enumerate() {
            let mut mask = kernels::accumulate_depths(depth, level, threshold);
            while mask != 0 {
                reached.push(c * W + mask.trailing_zeros() as usize);
                mask &= mask - 1;
            }
        }
    }

    /// The horizontal offset from the centre line per metre below the
    /// origin, of every lane: its largest length (the pulse's spread).
    #[cfg(test)]
    pub(super) fn drift(&self, i: usize) -> (f32, f32) {
        (self.sx[i], self.sy[i])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::DVec3;
    use crate::scene::{FoliageSettings, Species, TreeSpec};

    /// The lanes' `f32` density agrees with the crown's own `f64` density
    /// at points all over a crown, and a lane's depth alone is, to the
    /// bit, the one the register loop adds.
    #[test]
    fn lane_depths_are_the_crowns_density() {
        for foliage in [FoliageSettings::default(), FoliageSettings::specification()] {
            lane_depths_match(&foliage);
        }
    }

    fn lane_depths_match(foliage: &FoliageSettings) {
        let mut spec = TreeSpec::new(DVec3::new(3.0, -2.0, 1.0), Species::Pine, 0.3, 20.0, 6.0);
        spec.seed = 9;
        let crown = spec.crown(foliage);
        let cell_m = foliage.clump_m;
        let profile = crown.profile();
        let mut rng = crate::rng::Stream::new(1, 0, 0, crate::rng::Purpose::Test);
        let n = 19;
        let mut lanes = Lanes::default();
        let mut checked = 0;
        for _ in 0..500 {
            let z = 7.5 + rng.uniform() * 13.0;
            let (cx, cy) = (
                (rng.uniform() - 0.5) * 6.0 + 3.0,
                (rng.uniform() - 0.5) * 6.0 - 2.0,
            );
            let drifts: Vec<(f64, f64)> = (0..n)
                .map(|_| ((rng.uniform() - 0.5) * 1e-3, (rng.uniform() - 0.5) * 1e-3))
                .collect();
            lanes.fill(n, |i| Lane {
                sx: drifts[i].0 as f32,
                sy: drifts[i].1 as f32,
                step: 0.3,
                top: 0.0,
                bottom: -1000.0,
                threshold: 1.0,
            });
            let level = profile.level(z).expect("inside the crown's heights");
            let dz = -200.0;
            let cell = Cell {
                level: Level32::new(&level),
                centre: ((cx - 3.0) as f32, (cy + 2.0) as f32),
                k: 2.0,
                dz: dz as f32,
            };
            lanes.add_cell(&cell);
            for i in 0..n {
                let (sx, sy) = lanes.drift(i);
                let p = DVec3::new(cx + f64::from(sx) * dz, cy + f64::from(sy) * dz, z);
                let want = 2.0 * crown.density_at(p) * 0.3;
                let got = f64::from(lanes.level[i]);
                assert_eq!(lanes.cell_depth(&cell, i), lanes.level[i]);
                // Points within a millimetre of the envelope may fall
                // either side of it.
                let r = (p.x - 3.0).hypot(p.y + 2.0);
                if (r - level.radius).abs() < 1e-3 {
                    continue;
                }
                // So may points within a millimetre of a clump cell's side
                // (the lanes find the cell in f32).
                let near_side = |v: f64| {
                    let f = (v / cell_m).fract().abs();
                    f < 1e-3 / cell_m || f > 1.0 - 1e-3 / cell_m
                };
                if near_side(p.x - 3.0) || near_side(p.y + 2.0) {
                    continue;
                }
                assert!((got - want).abs() < 1e-4, "{got} vs {want} at {p}");
                checked += usize::from(r < level.radius);
            }
            lanes.level.fill(0.0);
        }
        assert!(checked > 1000, "{checked} lanes inside the crown");
    }
}

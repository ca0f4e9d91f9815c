//! The pulse march: all sub-rays of one pulse through the crowns together.
//!
//! The sub-rays of a pulse leave one point a fraction of a milliradian
//! apart, so at any height they lie within a few decimetres of each other.
//! The march steps through heights instead of distances: at levels
//! `z_j = z_0 − (j + u)·Δz`, one random phase `u` for the pulse and
//! `Δz = Δs·|d_z|` for the pulse's mean direction `d`, each sub-ray meets
//! the level after a step `Δs_i = Δz/|d_{i,z}|` of its own (≈ `Δs`). What
//! the foliage density depends on at a height — the envelope radius `r(χ)`,
//! the height factor and the whorl's rotation — is then computed once per
//! crown and level for all sub-rays ([`crate::scene::CrownLevel`]), and
//! only the horizontal offset from the stem is left to each, in a loop
//! over sub-rays without branches that the compiler vectorises. A crown
//! whose envelope the whole pulse misses at a level is skipped after one
//! test of the pulse's centre.
//!
//! Each sub-ray draws one threshold `E ~ Exp(1)` and is intercepted in the
//! cell around the first level where its accumulated optical depth
//! `Σ k·ρ·Δs_i` reaches `E`: the probability of crossing a cell of depth
//! `τ` is `exp(−τ)`, exactly the reference march's lottery at one step
//! (`reference.rs`), with one random number per sub-ray instead of one per
//! step. Within the cell the interception lies where the depth reaches `E`
//! (the cell's density taken as constant over it, `Δs_i` long and centred
//! on the level), not on the level itself, so the sub-rays' echoes are not
//! bunched on the pulse's shared levels; where crowns overlap in a cell
//! the one intercepting is chosen in proportion to its depth, from the
//! same threshold (`(1 − e^{−x})/(1 − e^{−τ})` is uniform for the depth
//! `x` it reaches into a cell of depth `τ`).
//!
//! Pulses with a sub-ray less steep than [`MIN_STEEPNESS`] (levels would
//! lie far apart along it) and surveys that ask for it
//! ([`Marching::SubRay`]) take the reference march, sub-ray by sub-ray.

use super::reference::march;
use super::{CanopyConfig, Fate, Marching};
use crate::accel::VolumeSpan;
use crate::geometry::{DVec3, Ray};
use crate::rng::Stream;
use crate::scene::{Crown, CrownLevel, Scene, Shape};

/// Smallest `−d_z` of a sub-ray for the pulse march (75.5° from nadir):
/// beyond it a step of `Δz` would be more than 4 `Δs` long along it.
pub const MIN_STEEPNESS: f64 = 0.25;

/// One crown met by the pulse.
#[derive(Clone, Copy, Debug)]
struct Met {
    prim: u32,
    z_top: f64,
    z_base: f64,
}

/// The sub-rays of one pulse and the working storage of their march
/// through the crowns, reused from pulse to pulse.
#[derive(Clone, Debug, Default)]
pub struct PulseMarch {
    dirs: Vec<DVec3>,
    t_start: Vec<f64>,
    t_stop: Vec<f64>,
    spans: Vec<VolumeSpan>,
    ranges: Vec<(u32, u32)>,
    // Per sub-ray, for the walk through heights.
    slope_x: Vec<f64>,
    slope_y: Vec<f64>,
    step: Vec<f64>,
    z_hi: Vec<f64>,
    z_lo: Vec<f64>,
    threshold: Vec<f64>,
    depth: Vec<f64>,
    transmission: Vec<f64>,
    level_depth: Vec<f64>,
    /// The sub-ray (its index as pushed) of each column above.
    lane: Vec<u32>,
    // Per crown open at a level: each sub-ray's optical depth in the cell.
    rows: Vec<f64>,
    /// Per row: the crown, its `k` and its top.
    row_crowns: Vec<(u32, f64, f64)>,
    met: Vec<Met>,
    prims: Vec<u32>,
    fates: Vec<Fate>,
}

impl PulseMarch {
    /// Forgets the sub-rays of the last pulse.
    pub fn clear(&mut self) {
        self.dirs.clear();
        self.t_start.clear();
        self.t_stop.clear();
        self.spans.clear();
        self.ranges.clear();
    }

    /// Adds a sub-ray of direction `dir` (unit) that may meet foliage
    /// between `t_start` and `t_stop` (its closest surface or the range
    /// limit) and whose way crosses the crowns of `spans` (sorted by
    /// entry, clipped to `t_stop`).
    pub fn push(&mut self, dir: DVec3, t_start: f64, t_stop: f64, spans: &[VolumeSpan]) {
        let a = self.spans.len() as u32;
        self.spans.extend_from_slice(spans);
        self.ranges.push((a, self.spans.len() as u32));
        self.dirs.push(dir);
        self.t_start.push(t_start);
        self.t_stop.push(t_stop);
    }

    /// The fates of the sub-rays, in the order they were pushed, after
    /// [`PulseMarch::run`].
    pub fn fates(&self) -> &[Fate] {
        &self.fates
    }

    /// Follows every sub-ray from `origin` through the crowns; random
    /// numbers from `rng` (taken only when some sub-ray meets a crown).
    pub fn run(&mut self, scene: &Scene, origin: DVec3, config: &CanopyConfig, rng: &mut Stream) {
        let n = self.dirs.len();
        self.fates.clear();
        self.fates.resize(n, Fate::Passed { transmission: 1.0 });
        if self.spans.is_empty() {
            return;
        }
        let steep = self.dirs.iter().all(|d| d.z <= -MIN_STEEPNESS);
        if !steep || config.marching == Marching::SubRay {
            for i in 0..n {
                let (a, b) = self.ranges[i];
                if a == b {
                    continue;
                }
                let ray = Ray {
                    origin,
                    dir: self.dirs[i],
                };
                let spans = &self.spans[a as usize..b as usize];
                self.fates[i] = march(scene, &ray, spans, config, rng);
            }
            return;
        }
        self.walk(scene, origin, config, rng);
    }

    /// The pulse march proper (module documentation).
    fn walk(&mut self, scene: &Scene, o: DVec3, config: &CanopyConfig, rng: &mut Stream) {
        let n = self.dirs.len();
        let crown_of = |prim: u32| -> &Crown {
            match &scene.primitives[prim as usize].shape {
                Shape::Crown(c) => c,
                _ => unreachable!("volume spans are crowns"),
            }
        };
        // The crowns the pulse meets, highest top first.
        self.prims.clear();
        self.prims.extend(self.spans.iter().map(|s| s.prim));
        self.prims.sort_unstable();
        self.prims.dedup();
        self.met.clear();
        self.met.extend(self.prims.iter().map(|&prim| {
            let (z_base, z_top) = crown_of(prim).z_range();
            Met {
                prim,
                z_top,
                z_base,
            }
        }));
        self.met.sort_by(|a, b| b.z_top.total_cmp(&a.z_top));

        // Per sub-ray: horizontal drift per metre of height, step length,
        // the heights it is open between, its threshold.
        let mean_dz = self.dirs.iter().map(|d| d.z).sum::<f64>() / n as f64;
        let level_step = config.step_m * -mean_dz;
        let (mut cx, mut cy) = (0.0, 0.0);
        for v in [
            &mut self.slope_x,
            &mut self.slope_y,
            &mut self.step,
            &mut self.z_hi,
            &mut self.z_lo,
            &mut self.threshold,
        ] {
            v.clear();
        }
        let phase = rng.uniform();
        for i in 0..n {
            let d = self.dirs[i];
            let (sx, sy) = (d.x / d.z, d.y / d.z);
            cx += sx;
            cy += sy;
            self.slope_x.push(sx);
            self.slope_y.push(sy);
            self.step.push(level_step / -d.z);
            let (a, b) = self.ranges[i];
            if a == b {
                // No crown on its way: never open.
                self.z_hi.push(f64::NEG_INFINITY);
                self.z_lo.push(f64::INFINITY);
                self.threshold.push(f64::INFINITY);
                continue;
            }
            self.z_hi.push(o.z + d.z * self.t_start[i]);
            self.z_lo.push(o.z + d.z * self.t_stop[i]);
            self.threshold.push(-(1.0 - rng.uniform()).ln());
        }
        let (cx, cy) = (cx / n as f64, cy / n as f64);
        // How far a sub-ray lies from the pulse's centre line per metre
        // of height below the origin.
        let spread = (0..n)
            .map(|i| {
                let (x, y) = (self.slope_x[i] - cx, self.slope_y[i] - cy);
                (x * x + y * y).sqrt()
            })
            .fold(0.0, f64::max);
        self.depth.clear();
        self.depth.resize(n, 0.0);
        self.transmission.clear();
        self.transmission.resize(n, 1.0);
        self.level_depth.clear();
        self.level_depth.resize(n, 0.0);
        self.lane.clear();
        self.lane.extend(0..n as u32);

        let z_first = self.met[0]
            .z_top
            .min(self.z_hi.iter().copied().fold(f64::MIN, f64::max));
        let z_last = self
            .met
            .iter()
            .map(|m| m.z_base)
            .fold(f64::MAX, f64::min)
            .max(self.z_lo.iter().copied().fold(f64::MAX, f64::min));
        // Only sub-rays that meet a crown take part.
        self.compact();
        let mut open = self.lane.len();
        let mut j = 0u64;
        let mut below = 0usize;
        while open > 0 {
            let z = z_first - (j as f64 + phase) * level_step;
            if z <= z_last {
                break;
            }
            j += 1;
            // Crowns whose top is at or above this level.
            while below < self.met.len() && self.met[below].z_top >= z {
                below += 1;
            }
            if !self.met[..below].iter().any(|m| m.z_base <= z) {
                // Between crowns: on to the first level under the next top.
                match self.met.get(below) {
                    Some(next) => {
                        let to = ((z_first - next.z_top) / level_step - phase).ceil();
                        j = j.max(to as u64);
                        continue;
                    }
                    None => break,
                }
            }
            if open * 2 <= self.lane.len() {
                self.compact();
            }
            let n = self.lane.len();
            let dz = z - o.z;
            let reach = spread * dz.abs();
            self.rows.clear();
            self.row_crowns.clear();
            self.level_depth.fill(0.0);
            for m in &self.met[..below] {
                if m.z_base > z {
                    continue;
                }
                let crown = crown_of(m.prim);
                let (ax, ay) = crown.axis();
                let (ex, ey) = (o.x - ax, o.y - ay);
                let (px, py) = (ex + cx * dz, ey + cy * dz);
                let centre = (px * px + py * py).sqrt();
                if centre - reach > crown.max_radius_m() {
                    continue;
                }
                let Some(level) = crown.level(z) else {
                    continue;
                };
                if centre - reach > level.radius {
                    continue;
                }
                let k = crown.extinction_per_m;
                let start = self.rows.len();
                self.rows.resize(start + n, 0.0);
                let lanes = Lanes {
                    slope_x: &self.slope_x,
                    slope_y: &self.slope_y,
                    step: &self.step,
                    z_lo: &self.z_lo,
                    z_hi: &self.z_hi,
                };
                cell_depths(
                    &level,
                    k,
                    (ex, ey, dz, z),
                    &lanes,
                    &mut self.rows[start..],
                    &mut self.level_depth,
                );
                self.row_crowns.push((m.prim, k, m.z_top));
            }
            for i in 0..n {
                let tau = self.level_depth[i];
                if tau <= 0.0 {
                    continue;
                }
                let reached = self.threshold[i] - self.depth[i];
                if reached > tau {
                    self.depth[i] += tau;
                    if config.partial_blocking > 0.0 {
                        self.transmission[i] *= (-config.partial_blocking * tau).exp();
                    }
                    continue;
                }
                // Intercepted in this cell, `reached` deep into it.
                let uniform = (-(-reached).exp_m1()) / (-(-tau).exp_m1());
                let mut pick = uniform * tau;
                let mut chosen = 0;
                for (c, _) in self.row_crowns.iter().enumerate() {
                    let x = self.rows[c * n + i];
                    chosen = c;
                    if x > 0.0 && pick < x {
                        break;
                    }
                    pick -= x;
                }
                let (prim, k, top) = self.row_crowns[chosen];
                let lane = self.lane[i] as usize;
                let d = self.dirs[lane];
                let t_level = dz / d.z;
                let t = (t_level + (reached / tau - 0.5) * self.step[i])
                    .max((top - o.z) / d.z)
                    .max(self.t_start[lane])
                    .min(self.t_stop[lane].next_down());
                self.fates[lane] = Fate::Intercepted {
                    t,
                    prim,
                    density: self.rows[chosen * n + i] / (k * self.step[i]),
                    transmission: self.transmission[i],
                };
                self.z_hi[i] = f64::NEG_INFINITY;
                open -= 1;
            }
        }
        for (&lane, &kept) in self.lane.iter().zip(&self.transmission) {
            if let Fate::Passed { transmission } = &mut self.fates[lane as usize] {
                *transmission = kept;
            }
        }
    }

    /// Drops the columns of sub-rays that are no longer open (intercepted,
    /// or meeting no crown), so that the loops run over the others only.
    fn compact(&mut self) {
        let mut kept = 0;
        for i in 0..self.lane.len() {
            if self.z_hi[i] == f64::NEG_INFINITY {
                continue;
            }
            self.slope_x[kept] = self.slope_x[i];
            self.slope_y[kept] = self.slope_y[i];
            self.step[kept] = self.step[i];
            self.z_hi[kept] = self.z_hi[i];
            self.z_lo[kept] = self.z_lo[i];
            self.threshold[kept] = self.threshold[i];
            self.depth[kept] = self.depth[i];
            self.transmission[kept] = self.transmission[i];
            self.lane[kept] = self.lane[i];
            kept += 1;
        }
        for v in [
            &mut self.slope_x,
            &mut self.slope_y,
            &mut self.step,
            &mut self.z_hi,
            &mut self.z_lo,
            &mut self.threshold,
            &mut self.depth,
            &mut self.transmission,
            &mut self.level_depth,
        ] {
            v.truncate(kept);
        }
        self.lane.truncate(kept);
    }
}

/// The per-sub-ray columns [`cell_depths`] reads.
struct Lanes<'a> {
    slope_x: &'a [f64],
    slope_y: &'a [f64],
    step: &'a [f64],
    z_lo: &'a [f64],
    z_hi: &'a [f64],
}

/// Each sub-ray's optical depth `k·ρ·Δs_i` in one crown's cell at height
/// `z` (0 where the sub-ray is not open there) into `row`, added to
/// `total`. `(ex, ey)` is the origin's offset from the stem axis and `dz`
/// the level's height below the origin (negative). Straight-line code
/// over equal-length slices, so that it vectorises.
#[inline(always)]
fn cell_depths(
    level: &CrownLevel,
    k: f64,
    (ex, ey, dz, z): (f64, f64, f64, f64),
    lanes: &Lanes,
    row: &mut [f64],
    total: &mut [f64],
) {
    let n = row.len();
    let (sx, sy, step) = (&lanes.slope_x[..n], &lanes.slope_y[..n], &lanes.step[..n]);
    let (z_lo, z_hi, total) = (&lanes.z_lo[..n], &lanes.z_hi[..n], &mut total[..n]);
    for i in 0..n {
        let dx = ex + sx[i] * dz;
        let dy = ey + sy[i] * dz;
        let tau = k * level.density(dx, dy) * step[i];
        let open = z > z_lo[i] && z <= z_hi[i];
        let tau = if open { tau } else { 0.0 };
        row[i] = tau;
        total[i] += tau;
    }
}

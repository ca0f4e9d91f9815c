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
//! over sub-rays without branches that the compiler vectorises, eight
//! sub-rays to a register in `f32` (offsets of metres from the stem, exact
//! to micrometres). A crown whose envelope the whole pulse misses at a
//! level is skipped after one test of the pulse's centre, and so is one
//! whose hollow core (the physical model's, inside its foliated shell)
//! holds the whole pulse there; above the depth
//! where its envelope first grows wide enough for the pulse to reach it
//! (worked out once per pulse, [`first_reach`]) it is not looked at, and a
//! level that no envelope can reach costs nothing more.
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
//! Random numbers: the phase is the stream's first number and sub-ray
//! `i`'s threshold comes from the stream's `i`-th substream.
//!
//! Pulses with a sub-ray less steep than [`MIN_STEEPNESS`] (levels would
//! lie far apart along it) and surveys that ask for it
//! ([`Marching::SubRay`]) take the reference march, sub-ray by sub-ray.

mod lanes;

use super::reference::march;
use super::{CanopyConfig, Fate, Marching};
use crate::accel::{VolumeSpan, spans_along};
use crate::geometry::{DVec3, Ray};
use crate::rng::Stream;
use crate::scene::foliage::LevelField;
use crate::scene::{Crown, CrownProfile, Scene, Shape};
use lanes::{Cell, Lane, Lanes, Level32, W};

/// Smallest `−d_z` of a sub-ray for the pulse march (75.5° from nadir):
/// beyond it a step of `Δz` would be more than 4 `Δs` long along it.
pub const MIN_STEEPNESS: f64 = 0.25;

/// One crown met by the pulse, between the heights where the pulse can
/// reach it.
#[derive(Clone, Copy, Debug)]
struct Met {
    prim: u32,
    profile: CrownProfile,
    z_top: f64,
    z_base: f64,
    /// The highest level where the pulse may reach the envelope (not only
    /// its bounding cylinder): above it the crown is not looked at.
    z_reach: f64,
}

/// A crown whose envelope the pulse reaches at the current level.
#[derive(Clone, Copy, Debug)]
struct Row {
    /// Index into the pulse's crowns.
    met: usize,
    cell: Cell,
}

/// The pulse's centre line and the sub-rays about it.
#[derive(Clone, Copy, Debug)]
struct CentreLine {
    /// The mean horizontal drift per metre of height, x and y.
    cx: f64,
    cy: f64,
    /// The farthest a sub-ray's drift strays from the mean, a little
    /// grown.
    spread: f64,
    /// The highest `d_z·t_start` and the lowest `d_z·t_stop` of the
    /// sub-rays: the heights, relative to the origin, they are open
    /// between.
    top_max: f64,
    bottom_min: f64,
}

/// The sub-rays of one pulse and the working storage of their march
/// through the crowns, reused from pulse to pulse.
#[derive(Clone, Debug, Default)]
pub struct PulseMarch {
    dirs: Vec<DVec3>,
    /// Each sub-ray's `(d_x/d_z, d_y/d_z)`.
    drifts: Vec<(f64, f64)>,
    t_start: Vec<f64>,
    t_stop: Vec<f64>,
    lanes: Lanes,
    /// Energy kept by each sub-ray (below 1 only with partial blocking).
    transmission: Vec<f64>,
    met: Vec<Met>,
    rows: Vec<Row>,
    /// The lanes that reach their threshold at a level.
    reached: Vec<usize>,
    spans: Vec<VolumeSpan>,
    fates: Vec<Fate>,
}

impl PulseMarch {
    /// Forgets the sub-rays of the last pulse.
    pub fn clear(&mut self) {
        self.dirs.clear();
        self.t_start.clear();
        self.t_stop.clear();
    }

    /// Adds a sub-ray of direction `dir` (unit) that may meet foliage
    /// between `t_start` and `t_stop` (its closest surface or the range
    /// limit).
    pub fn push(&mut self, dir: DVec3, t_start: f64, t_stop: f64) {
        self.dirs.push(dir);
        self.t_start.push(t_start);
        self.t_stop.push(t_stop);
    }

    /// The fates of the sub-rays, in the order they were pushed, after
    /// [`PulseMarch::run`].
    pub fn fates(&self) -> &[Fate] {
        &self.fates
    }

    /// Follows every sub-ray from `origin` through the crowns among
    /// `volumes` (the volume primitives the pulse may cross, each once);
    /// random numbers from `rng` (taken only when some sub-ray meets a
    /// crown).
    pub fn run(
        &mut self,
        scene: &Scene,
        origin: DVec3,
        volumes: &[u32],
        config: &CanopyConfig,
        rng: &mut Stream,
    ) {
        let n = self.dirs.len();
        self.fates.clear();
        self.fates.resize(n, Fate::Passed { transmission: 1.0 });
        if volumes.is_empty() || n == 0 {
            return;
        }
        let steep = self.dirs.iter().all(|d| d.z <= -MIN_STEEPNESS);
        if !steep || config.marching == Marching::SubRay {
            for i in 0..n {
                let ray = Ray {
                    origin,
                    dir: self.dirs[i],
                };
                spans_along(
                    scene,
                    volumes,
                    &ray,
                    self.t_start[i],
                    self.t_stop[i],
                    &mut self.spans,
                );
                if self.spans.is_empty() {
                    continue;
                }
                self.fates[i] = march(scene, &ray, &self.spans, config, rng);
            }
            return;
        }
        self.walk(scene, origin, volumes, config, rng);
    }

    /// The pulse march proper (module documentation).
    fn walk(
        &mut self,
        scene: &Scene,
        o: DVec3,
        volumes: &[u32],
        config: &CanopyConfig,
        rng: &mut Stream,
    ) {
        let n = self.dirs.len();
        // The levels' spacing from the pulse's mean steepness.
        let mean_dz = self.dirs.iter().map(|d| d.z).sum::<f64>() / n as f64;
        let level_step = config.step_m * -mean_dz;
        let centre = self.centre_line();
        self.meet_crowns(scene, o, volumes, &centre);
        if self.met.is_empty() {
            return;
        }
        let CentreLine {
            cx,
            cy,
            spread,
            top_max,
            bottom_min,
        } = centre;
        // The crowns met, highest top first.
        self.met
            .sort_by(|a, b| b.z_top.total_cmp(&a.z_top).then(a.prim.cmp(&b.prim)));
        let phase = rng.uniform();

        // Per sub-ray: its drift from the centre line, step, the heights it
        // is open between, and its threshold (from its own stream).
        let (dirs, drifts) = (&self.dirs[..n], &self.drifts[..n]);
        let (t_start, t_stop) = (&self.t_start[..n], &self.t_stop[..n]);
        let lane = |i: usize| {
            let d = dirs[i];
            let (rx, ry) = drifts[i];
            Lane {
                sx: (rx - cx) as f32,
                sy: (ry - cy) as f32,
                step: (level_step / -d.z) as f32,
                top: (d.z * t_start[i]) as f32,
                bottom: (d.z * t_stop[i]) as f32,
            }
        };
        let threshold = |i: usize| (rng.substream(i as u64).exp1() as f32).max(f32::MIN_POSITIVE);
        self.lanes.fill(n, lane, threshold);
        self.transmission.clear();
        self.transmission.resize(n, 1.0);

        let z_first = self.met[0].z_top.min(o.z + top_max);
        let z_last = self
            .met
            .iter()
            .map(|m| m.z_base)
            .fold(f64::MAX, f64::min)
            .max(o.z + bottom_min);
        let mut open = n;
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
            if !self.met[..below]
                .iter()
                .any(|m| m.z_base <= z && z <= m.z_reach)
            {
                // No envelope within reach: on to the first level under the
                // next height where one may be.
                let next = (self.met.iter().map(|m| m.z_reach))
                    .filter(|&r| r < z)
                    .fold(f64::NEG_INFINITY, f64::max);
                if next == f64::NEG_INFINITY {
                    break;
                }
                let to = ((z_first - next) / level_step - phase).ceil();
                j = j.max(to as u64);
                continue;
            }
            let dz = z - o.z;
            self.gather_rows(o, (cx, cy), z, below, spread * dz.abs());
            let Some((first, rest)) = self.rows.split_first() else {
                continue;
            };
            self.lanes.set_cell(&first.cell);
            for row in rest {
                self.lanes.add_cell(&row.cell);
            }
            if config.partial_blocking > 0.0 {
                let lanes = &self.lanes;
                for (i, &tau) in lanes.level.iter().enumerate() {
                    if tau > 0.0 && lanes.lane[i] != u32::MAX {
                        let l = lanes.lane[i] as usize;
                        self.transmission[l] *= (-config.partial_blocking * f64::from(tau)).exp();
                    }
                }
            }
            // Add the level's depths; the lanes that reach their threshold
            // are intercepted in this cell.
            self.lanes.advance(&mut self.reached);
            for k in 0..self.reached.len() {
                let i = self.reached[k];
                let lane = self.lanes.lane[i] as usize;
                self.fates[lane] = self.intercept(o, i, lane, dz);
                self.lanes.close(i);
                open -= 1;
            }
            if open * 2 <= self.lanes.len() && self.lanes.len() > W {
                self.lanes.compact();
            }
        }
        for (fate, &kept) in self.fates.iter_mut().zip(&self.transmission) {
            if let Fate::Passed { transmission } = fate {
                *transmission = kept;
            }
        }
    }

    /// The crowns among the first `below` met whose envelope the pulse
    /// from `o`, its centre line drifting `(cx, cy)` per metre, reaches at
    /// level `z` with its widest `reach` there, into `rows`: each with the
    /// cell the level cuts from its crown.
    #[inline]
    fn gather_rows(&mut self, o: DVec3, (cx, cy): (f64, f64), z: f64, below: usize, reach: f64) {
        let dz = z - o.z;
        self.rows.clear();
        for (mi, m) in self.met[..below].iter().enumerate() {
            if m.z_base > z || z > m.z_reach {
                continue;
            }
            let crown = m.profile.crown();
            let (ax, ay) = crown.axis();
            let (px, py) = (o.x - ax + cx * dz, o.y - ay + cy * dz);
            // Squared: is the centre farther than `radius + reach`?
            let centre_sq = px * px + py * py;
            let beyond = |radius: f64| centre_sq > (radius + reach) * (radius + reach);
            if beyond(crown.max_radius_m()) {
                continue;
            }
            let Some(envelope) = m.profile.envelope(z) else {
                continue;
            };
            if beyond(envelope.radius) {
                continue;
            }
            let level = m.profile.level_within(envelope);
            // A physical crown's hollow core that holds the whole
            // footprint adds no depth to any lane (each lies nearer the
            // stem than the shell, by a margin far above the lanes' `f32`
            // rounding): the row is left out.
            if let LevelField::Physical { core_rc, .. } = level.field
                && centre_sq.sqrt() + reach < core_rc * envelope.radius * (1.0 - 1e-5) - 1e-5
            {
                continue;
            }
            self.rows.push(Row {
                met: mi,
                cell: Cell {
                    level: Level32::new(&level),
                    centre: (px as f32, py as f32),
                    k: crown.extinction_per_m as f32,
                    dz: dz as f32,
                },
            });
        }
    }

    /// The pulse's centre line (the mean horizontal drift per metre of
    /// height) and how far the sub-rays stray from it, each sub-ray's
    /// drift kept in `drifts`.
    fn centre_line(&mut self) -> CentreLine {
        let n = self.dirs.len();
        // Each sub-ray's horizontal drift per metre of height.
        self.drifts.clear();
        self.drifts
            .extend(self.dirs.iter().map(|d| (d.x / d.z, d.y / d.z)));
        let (mut cx, mut cy) = (0.0, 0.0);
        for &(rx, ry) in &self.drifts {
            cx += rx;
            cy += ry;
        }
        let (cx, cy) = (cx / n as f64, cy / n as f64);
        let mut spread = 0.0f64;
        let (mut top_max, mut bottom_min) = (f64::NEG_INFINITY, f64::INFINITY);
        for i in 0..n {
            let d = self.dirs[i];
            let (rx, ry) = self.drifts[i];
            let (sx, sy) = (rx - cx, ry - cy);
            spread = spread.max((sx * sx + sy * sy).sqrt());
            top_max = top_max.max(d.z * self.t_start[i]);
            bottom_min = bottom_min.min(d.z * self.t_stop[i]);
        }
        CentreLine {
            cx,
            cy,
            // The f32 drifts differ from these by a relative 1e-7.
            spread: spread * (1.0 + 1e-6) + 1e-9,
            top_max,
            bottom_min,
        }
    }

    /// The crowns among `volumes` the pulse from `o` meets, into `met`
    /// (in the order of `volumes`), each between the heights where the
    /// pulse can reach its bounding cylinder: where the centre line
    /// `o + s·(−c_x, −c_y, −1)` comes within `spread·s` of it; and the
    /// highest level where it can reach the envelope itself.
    fn meet_crowns(&mut self, scene: &Scene, o: DVec3, volumes: &[u32], c: &CentreLine) {
        let line = Ray {
            origin: o,
            dir: DVec3::new(-c.cx, -c.cy, -1.0),
        };
        let depth_max = -c.bottom_min;
        self.met.clear();
        for &prim in volumes {
            let crown = crown_of(scene, prim);
            let reach = crown.bounds_cylinder().grown(c.spread * depth_max);
            let Some((s0, s1)) = reach.span(&line, -c.top_max, depth_max) else {
                continue;
            };
            let (z_base, z_top) = crown.z_range();
            let (z_base, z_top) = (z_base.max(o.z - s1), z_top.min(o.z - s0));
            if z_base < z_top {
                let profile = crown.profile();
                let z_reach = first_reach(&profile, o, (c.cx, c.cy), c.spread, (z_base, z_top));
                self.met.push(Met {
                    prim,
                    profile,
                    z_top,
                    z_base,
                    z_reach,
                });
            }
        }
    }

    /// The fate of lane `i` (sub-ray `lane`), whose depth reaches its
    /// threshold in the cell of the current level (`dz` below the origin
    /// `o`): where in the cell, and in which of the level's crowns.
    fn intercept(&self, o: DVec3, i: usize, lane: usize, dz: f64) -> Fate {
        let lanes = &self.lanes;
        let tau = f64::from(lanes.level[i]);
        let reached = f64::from(lanes.threshold[i]) - f64::from(lanes.depth[i]);
        let step = f64::from(lanes.step[i]);
        // Which crown: in proportion to each one's depth in the cell, from
        // the depth the threshold reaches into it.
        let (row, depth) = if self.rows.len() == 1 {
            (&self.rows[0], tau)
        } else {
            let uniform = (-(-reached).exp_m1()) / (-(-tau).exp_m1());
            let mut pick = uniform * tau;
            let mut chosen = (&self.rows[0], 0.0);
            for row in &self.rows {
                let x = f64::from(lanes.cell_depth(&row.cell, i));
                chosen = (row, x);
                if x > 0.0 && pick < x {
                    break;
                }
                pick -= x;
            }
            chosen
        };
        let m = &self.met[row.met];
        let d = self.dirs[lane];
        let t_level = dz / d.z;
        let t = (t_level + (reached / tau - 0.5) * step)
            .max((m.profile.crown().z_range().1 - o.z) / d.z)
            .max(self.t_start[lane])
            .min(self.t_stop[lane].next_down());
        Fate::Intercepted {
            t,
            prim: m.prim,
            density: depth / (f64::from(row.cell.k) * step),
            transmission: self.transmission[lane],
        }
    }
}

/// The height below which a pulse from `o` may reach the envelope of
/// `profile`'s crown between `heights` (lowest first), and above which it
/// cannot: where the envelope is narrower than the least horizontal
/// distance from the stem to the pulse's centre line (drifting by `drift`
/// per metre of height) less the pulse's widest reach there (`spread` per
/// metre below the origin). At levels above it the march's own test
/// (`beyond`) would find the envelope out of reach, by a margin far above
/// rounding.
fn first_reach(
    profile: &CrownProfile,
    o: DVec3,
    drift: (f64, f64),
    spread: f64,
    heights: (f64, f64),
) -> f64 {
    let crown = profile.crown();
    let (ax, ay) = crown.axis();
    let (px, py) = (o.x - ax, o.y - ay);
    let (cx, cy) = drift;
    let (dz_low, dz_high) = (heights.0 - o.z, heights.1 - o.z);
    // The centre line's nearest point to the stem within the heights.
    let c2 = cx * cx + cy * cy;
    let t = if c2 > 0.0 {
        (-(px * cx + py * cy) / c2).clamp(dz_low, dz_high)
    } else {
        dz_low
    };
    let nearest = (px + cx * t).hypot(py + cy * t);
    let narrower = nearest - spread * -dz_low - 1e-6 * (1.0 + nearest);
    let Some(chi) = profile.depth_narrower_than(narrower) else {
        return heights.1;
    };
    // Above z_top − χ_c·(z_top − z_base) the envelope is narrower.
    let (z_base, z_top) = crown.z_range();
    let depth = chi * (z_top - z_base) * (1.0 - 1e-9) - 1e-9;
    (z_top - depth.max(0.0)).min(heights.1)
}

/// The crown of volume primitive `prim`.
fn crown_of(scene: &Scene, prim: u32) -> &Crown {
    match &scene.primitives[prim as usize].shape {
        Shape::Crown(c) => c,
        _ => unreachable!("volume primitives are crowns"),
    }
}

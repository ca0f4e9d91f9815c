//! The beam of a pulse as sub-rays.
//!
//! A pulse leaves as a Gaussian beam: its irradiance at off-axis angle `r`
//! falls as `exp(−2r²/w²)`, `w` the 1/e² half-angle (half the divergence:
//! a 0.3 mrad beam has a 30 cm footprint at 1 km, specification "What is a
//! LiDAR?"). The beam is a bundle of N sub-rays of equal energy, denser
//! near the centre (specification, Figs. 3 and 5): sub-ray `i` sits at the
//! radius where the enclosed power `1 − exp(−2r²/w²)` reaches
//! `(i + ξᵢ)/N`, the tails beyond 1/e² (13.5 % of the energy) included
//! up to 99.9 % of it, at azimuth `α + i·golden angle`.
//!
//! **Jitter.** `ξᵢ` and `α` are drawn anew for each of [`VARIANTS`]
//! precomputed patterns, and each pulse uses one of them, chosen by the
//! pulse's [`crate::rng::Purpose::Beam`] stream. A fixed pattern would let
//! a target smaller than the sub-ray spacing be seen, or missed, depending
//! on where the fixed rays land.
//!
//! **Cells and refinement.** Each sub-ray stands for a cell of the beam:
//! its Voronoi cell among the sub-rays, within the disk that holds
//! 99.99 % of the energy (cells.rs), so that the cells tile the beam; a
//! cell's energy is the Gaussian's over it ([`BeamPattern::cell_energy`]).
//! Where two neighbouring sub-rays see a discontinuity the receiver can
//! resolve — closest hits more than the range resolution `c·FWHM/2`
//! apart, or one a hit and the other a miss — the cells of both are
//! sampled again by a jittered grid of rays mapped onto the cell area for
//! area and weighted by the irradiance there, the weights adding up to the
//! cell's energy ([`BeamPattern::fine_samples`]); the sub-rays of the
//! other cells share what is left.
//!
//! **Cone sampling.** A target between the sub-rays is found by the
//! bundle traversal, which tests boxes and triangles against the cone of
//! the sub-rays ([`crate::accel::PulseTrace::unseen`]); its outline in the
//! pattern's plane ([`Outline`]), cut into the cells it meets, gives
//! patches that are sampled by their own rays, each carrying its
//! stratum's area times the irradiance at the ray
//! ([`BeamPattern::patch_samples`]): the Gaussian beam's energy over the
//! patch, taken from the cell's, whose sub-ray (or fine samples outside
//! the patches) carries the rest (sim/cone.rs). A target smaller than a
//! cell then returns the energy it intercepts — its cross-section times
//! the irradiance, so `R⁻⁴` for a point target — in every pulse whose
//! cone holds it, while an extended surface keeps the `R⁻²` of Eq. 2.
//!
//! With N = 1 the single ray is the beam's axis, neither jittered nor
//! refined (the single-ray mode). Patterns of more than
//! [`MAX_REFINED_SUBRAYS`] sub-rays sample the beam finely themselves and
//! are not refined.

mod cells;
mod fine;

pub use cells::{Outline, PlanePoint};

use crate::geometry::{DMat3, DVec3};
use crate::rng::Stream;
use cells::Cell;
use fine::{FineSample, FineTables};

/// Precomputed jittered patterns (fewer for very large N, so that they take
/// at most about 2¹⁶ sub-rays in all).
pub const VARIANTS: usize = 64;

/// How finely a refined cell is sampled: by a `k × k` jittered grid
/// mapped onto it area for area.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Fineness {
    /// 4 × 4 rays: what a resolved discontinuity asks for by default.
    Rays16,
    /// 8 × 8 rays.
    Rays64,
    /// 16 × 16 rays: for targets much narrower than their cell.
    Rays256,
}

impl Fineness {
    /// Every fineness, coarsest first.
    pub const ALL: [Fineness; 3] = [Fineness::Rays16, Fineness::Rays64, Fineness::Rays256];

    /// The fineness of `rays` rays (`None`: no such grid).
    pub fn from_rays(rays: usize) -> Option<Self> {
        Self::ALL.into_iter().find(|f| f.rays() == rays)
    }

    /// Rays along each side of the grid.
    pub const fn side(self) -> usize {
        match self {
            Fineness::Rays16 => 4,
            Fineness::Rays64 => 8,
            Fineness::Rays256 => 16,
        }
    }

    /// Rays that sample the cell.
    pub const fn rays(self) -> usize {
        self.side() * self.side()
    }
}

/// Rays that sample a patch of a target between the sub-rays: a 2 × 2
/// grid. All of them fall on a target whose outline is exact (a polygon
/// or triangle), and four strata estimate the irradiance over a target
/// much smaller than the beam to a few per cent in each pulse.
pub const PATCH_RAYS: usize = 4;

/// Enclosed power of the disk the cells tile: beyond it lies 0.01 % of the
/// beam's energy (1/e² radius × 2.15).
const CELLS_POWER: f64 = 0.9999;

/// Largest pattern whose cells are refined.
pub const MAX_REFINED_SUBRAYS: usize = 256;

/// Neighbours of each sub-ray compared for discontinuities.
const NEIGHBOURS: usize = 6;

/// Enclosed power beyond which the outermost stratum is cut: its sub-ray
/// lies at most 1.86 `w` off axis, and the 0.1 % of the energy farther out
/// is left to the sub-rays inside (it would widen the bundle a ray caster
/// must follow for nothing measurable).
const TAIL_CUT: f64 = 0.999;

/// Rotation of the undeflected beam (along +z) to the mirror deflection
/// `theta_rad` about the scanner's y axis: +z goes to the beam direction
/// `(sin θ, 0, cos θ)`, +x to the across-scan perpendicular
/// `(cos θ, 0, −sin θ)`; the along-track axis +y stays.
pub fn deflection(theta_rad: f64) -> DMat3 {
    let (s, c) = theta_rad.sin_cos();
    DMat3::from_cols(DVec3::new(c, 0.0, -s), DVec3::Y, DVec3::new(s, 0.0, c))
}

/// One pattern of sub-rays around the undeflected beam axis (+z).
#[derive(Clone, Debug, PartialEq)]
pub struct BeamPattern {
    /// Offsets from the axis as tangents of the off-axis angle (x, y).
    offsets: Vec<[f64; 2]>,
    /// Unit directions.
    base: Vec<DVec3>,
    /// Energy share of each sub-ray (1/N).
    share: f64,
    /// Each sub-ray's cell (empty when the pattern is not refined).
    cells: Vec<Cell>,
    /// The share of the beam's energy within each cell (they add up to
    /// 1; each near `share`, but not equal to it).
    energy: Vec<f64>,
    /// Indices of each sub-ray's nearest neighbours (`u16::MAX`: none).
    neighbours: Vec<[u16; NEIGHBOURS]>,
    /// Per [`Fineness`], its jittered grid of the unit square (this
    /// pattern's own jitter), which the fine samples map onto a cell.
    grids: [Vec<[f64; 2]>; 3],
    /// Per [`Fineness`], every cell's fine samples, worked out when first
    /// asked for.
    fine: FineTables,
    /// The jittered 2 × 2 grid of the unit square that a patch's samples
    /// map onto it ([`BeamPattern::patch_samples`]).
    patch_grid: [[f64; 2]; PATCH_RAYS],
    /// Radius of the disk the cells tile (a tangent).
    reach: f64,
    /// The share of the beam's energy per unit of area of the pattern's
    /// plane times `exp(−2(X² + Y²)/w²)`: the scale of [`Self::energy`].
    norm: f64,
    /// 1/e² half-angle of the beam across (x), rad.
    w: f64,
    /// Ratio of the beam's along (y) to its across (x) divergence: the
    /// offsets and cells above are those of a round beam of half-angle
    /// `w`, and every direction is made from them with `y` stretched by
    /// this ratio. A Gaussian beam with different divergences along its
    /// two axes is that affine image of the round one, and the map keeps
    /// each sub-ray's and each fine sample's share of the energy.
    stretch_y: f64,
}

/// The sub-ray patterns of a beam, one of which each pulse uses.
#[derive(Clone, Debug, PartialEq)]
pub struct Beam {
    variants: Vec<BeamPattern>,
    /// Whether patterns are jittered and refined (N > 1).
    sampled: bool,
}

/// The radius where the enclosed power of a Gaussian beam of 1/e² radius
/// `w` is `u` (0 ≤ u < 1).
fn radius_of_power(u: f64, w: f64) -> f64 {
    w * (-(1.0 - u.min(TAIL_CUT)).ln() / 2.0).sqrt()
}

/// A SplitMix64 sequence for the fixed jitter of the precomputed patterns
/// (a table of the program, the same for every survey).
struct TableRng(u64);

impl TableRng {
    fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        (crate::rng::mix64(self.0) >> 11) as f64 / (1u64 << 53) as f64
    }
}

impl BeamPattern {
    /// A pattern of `n ≥ 2` equal-energy sub-rays of a beam of full
    /// divergence `divergence_rad` across and `stretch_y` times that along,
    /// jittered by `rng` (and its finer grids by `fine_rng`).
    fn jittered(
        n: usize,
        divergence_rad: f64,
        stretch_y: f64,
        rng: &mut TableRng,
        fine_rng: &mut TableRng,
    ) -> Self {
        let w = 0.5 * divergence_rad;
        let golden = std::f64::consts::PI * (3.0 - 5.0f64.sqrt());
        let turn = rng.uniform() * std::f64::consts::TAU;
        let offsets: Vec<[f64; 2]> = (0..n)
            .map(|i| {
                let r = radius_of_power((i as f64 + rng.uniform()) / n as f64, w);
                let a = turn + golden * i as f64;
                let t = r.tan();
                [t * a.cos(), t * a.sin()]
            })
            .collect();
        let base = offsets
            .iter()
            .map(|o| DVec3::new(o[0], stretch_y * o[1], 1.0).normalize())
            .collect();
        let share = 1.0 / n as f64;
        let refined = n <= MAX_REFINED_SUBRAYS;
        // The cells tile the disk that holds all but 0.01 % of the energy
        // (the sub-rays reach 1.86 w, TAIL_CUT).
        let reach = (w * (-(1.0 - CELLS_POWER).ln() / 2.0).sqrt()).tan();
        let mut neighbours = Vec::new();
        let mut cells = Vec::new();
        if refined {
            for (i, o) in offsets.iter().enumerate() {
                let mut near: Vec<(f64, usize)> = offsets
                    .iter()
                    .enumerate()
                    .filter(|&(j, _)| j != i)
                    .map(|(j, p)| ((p[0] - o[0]).hypot(p[1] - o[1]), j))
                    .collect();
                near.sort_by(|a, b| a.0.total_cmp(&b.0));
                let mut nb = [u16::MAX; NEIGHBOURS];
                for (slot, &(_, j)) in nb.iter_mut().zip(&near) {
                    *slot = j as u16;
                }
                neighbours.push(nb);
                cells.push(Cell::voronoi(&offsets, i, &near, reach));
            }
        }
        // Per fineness, k × k jittered points of the unit square, one in
        // each of its k × k squares. The coarsest takes its jitter from
        // `rng` (the same numbers as the disk points of earlier versions,
        // so the next pattern's sub-rays stay the same), the others from
        // `fine_rng`.
        let grid = |k: usize, rng: &mut TableRng| -> Vec<[f64; 2]> {
            (0..k * k)
                .map(|j| {
                    let a = ((j % k) as f64 + rng.uniform()) / k as f64;
                    let b = ((j / k) as f64 + rng.uniform()) / k as f64;
                    [a, b]
                })
                .collect()
        };
        let grids = [
            grid(Fineness::Rays16.side(), rng),
            grid(Fineness::Rays64.side(), fine_rng),
            grid(Fineness::Rays256.side(), fine_rng),
        ];
        // The patches' 2 × 2 grid takes the jitter of the first four
        // points of the coarsest grid, each within its own quarter.
        let patch_grid = std::array::from_fn(|j| {
            let [a, b] = grids[0][j];
            let side = Fineness::Rays16.side() as f64;
            let u = a * side - (j % Fineness::Rays16.side()) as f64;
            let v = b * side - (j / Fineness::Rays16.side()) as f64;
            [((j % 2) as f64 + u) / 2.0, ((j / 2) as f64 + v) / 2.0]
        });
        // Each cell's share of the energy: its area times the mean
        // irradiance over the finest grid's points, the shares scaled to
        // add up to 1 (the 0.01 % beyond the cells goes to them).
        let irradiance = |x: PlanePoint| (-2.0 * (x[0] * x[0] + x[1] * x[1]) / (w * w)).exp();
        let mut energy: Vec<f64> = cells
            .iter()
            .map(|c| {
                let sum: f64 = grids[2]
                    .iter()
                    .map(|&[a, b]| irradiance(c.sample(a, b)))
                    .sum();
                c.area() * sum / grids[2].len() as f64
            })
            .collect();
        let total: f64 = energy.iter().sum();
        for e in &mut energy {
            *e /= total;
        }
        let norm = if total > 0.0 { 1.0 / total } else { 0.0 };
        Self {
            offsets,
            base,
            share,
            cells,
            energy,
            neighbours,
            grids,
            fine: FineTables::default(),
            patch_grid,
            reach,
            norm,
            w,
            stretch_y,
        }
    }

    /// The single central ray.
    fn central() -> Self {
        Self {
            offsets: vec![[0.0, 0.0]],
            base: vec![DVec3::Z],
            share: 1.0,
            cells: Vec::new(),
            energy: Vec::new(),
            neighbours: Vec::new(),
            grids: [Vec::new(), Vec::new(), Vec::new()],
            fine: FineTables::default(),
            patch_grid: [[0.5; 2]; PATCH_RAYS],
            reach: 0.0,
            norm: 0.0,
            w: 0.0,
            stretch_y: 1.0,
        }
    }

    /// Number of sub-rays.
    pub fn len(&self) -> usize {
        self.base.len()
    }

    /// Always false: a pattern has at least one ray.
    pub fn is_empty(&self) -> bool {
        self.base.is_empty()
    }

    /// Energy share of every sub-ray.
    pub fn share(&self) -> f64 {
        self.share
    }

    /// Unit sub-ray directions of the undeflected beam (along +z).
    pub fn base_directions(&self) -> &[DVec3] {
        &self.base
    }

    /// Off-axis angle of each sub-ray, rad.
    pub fn off_axis_angles(&self) -> impl Iterator<Item = f64> + '_ {
        self.offsets
            .iter()
            .map(|o| o[0].hypot(self.stretch_y * o[1]).atan())
    }

    /// Whether this pattern's cells are refined.
    pub fn refined(&self) -> bool {
        !self.neighbours.is_empty()
    }

    /// The neighbours of sub-ray `i`.
    pub fn neighbours(&self, i: usize) -> impl Iterator<Item = usize> + '_ {
        self.neighbours[i]
            .iter()
            .filter(|&&j| j != u16::MAX)
            .map(|&j| usize::from(j))
    }

    /// The share of the beam's energy within the cell of sub-ray `i`.
    pub fn cell_energy(&self, i: usize) -> f64 {
        self.energy[i]
    }

    /// The rays sampling the cell of sub-ray `i` at `fineness`, as
    /// (undeflected unit direction, energy share) appended to `out`: spread
    /// evenly over the cell and weighted by the beam's irradiance at each,
    /// the shares adding up to the cell's energy
    /// ([`BeamPattern::cell_energy`]).
    pub fn fine_samples(&self, i: usize, fineness: Fineness, out: &mut Vec<(DVec3, f64)>) {
        let start = out.len();
        let mut sum = 0.0;
        for s in self.fine_table(i, fineness) {
            sum += s.weight;
            out.push((s.dir, s.weight));
        }
        let scale = self.energy[i] / sum;
        for s in &mut out[start..] {
            s.1 *= scale;
        }
    }

    /// The fine samples of cell `i` at `fineness`: its grid mapped onto
    /// the cell, each point's direction and irradiance.
    fn fine_table(&self, i: usize, fineness: Fineness) -> &[FineSample] {
        let grid = &self.grids[fineness as usize];
        self.fine.get(fineness as usize, i, grid.len(), || {
            (self.cells.iter())
                .flat_map(|cell| {
                    grid.iter().map(|&[a, b]| {
                        let x = cell.sample(a, b);
                        FineSample {
                            x,
                            dir: self.direction(x),
                            weight: self.irradiance(x),
                        }
                    })
                })
                .collect()
        })
    }

    /// The rays sampling the part of cell `i` where `keep` holds, as
    /// [`BeamPattern::fine_samples`] samples the whole cell but with the
    /// samples outside that part left out and the shares of the others
    /// adding up to `energy`. Returns how many it appended (none when no
    /// sample lies in the part).
    pub fn fine_samples_where(
        &self,
        i: usize,
        fineness: Fineness,
        keep: impl Fn(PlanePoint) -> bool,
        energy: f64,
        out: &mut Vec<(DVec3, f64)>,
    ) -> usize {
        let start = out.len();
        let mut sum = 0.0;
        for s in self.fine_table(i, fineness) {
            if !keep(s.x) {
                continue;
            }
            sum += s.weight;
            out.push((s.dir, s.weight));
        }
        if sum > 0.0 {
            let scale = energy / sum;
            for s in &mut out[start..] {
                s.1 *= scale;
            }
        }
        out.len() - start
    }

    /// The area of cell `i` in the pattern's plane.
    pub fn cell_area(&self, i: usize) -> f64 {
        self.cells[i].area()
    }

    /// The sub-ray of cell `i`, in the pattern's plane.
    pub fn site(&self, i: usize) -> PlanePoint {
        self.offsets[i]
    }

    /// The rays sampling the convex `patch` of the pattern's plane (within
    /// the cells, with an area), as (undeflected unit direction, energy
    /// share) appended to `out`: a 2 × 2 jittered grid (this pattern's)
    /// mapped onto it area for area, each ray carrying its stratum's area
    /// times the beam's irradiance at the ray — the Gaussian beam's energy
    /// over the patch, by stratified quadrature. The rays where `keep`
    /// fails are left out, so that their sum, which it returns, is that
    /// energy over the part of the patch where `keep` holds (in
    /// expectation over the jitter).
    pub fn patch_samples(
        &self,
        patch: &Outline,
        keep: impl Fn(PlanePoint) -> bool,
        out: &mut Vec<(DVec3, f64)>,
    ) -> f64 {
        let grid = &self.patch_grid;
        let stratum = patch.area() / grid.len() as f64 * self.norm;
        patch.with_fan(|fan| {
            let mut sum = 0.0;
            for &[a, b] in grid {
                let x = fan.sample(a, b);
                if !keep(x) {
                    continue;
                }
                let share = stratum * self.irradiance(x);
                sum += share;
                out.push((self.direction(x), share));
            }
            sum
        })
    }

    /// Makes `outline` its part within cell `i`.
    pub fn clip_to_cell(&self, i: usize, outline: &mut Outline) {
        outline.clip_to_cell(&self.cells[i]);
    }

    /// The beam's relative irradiance at `x`, 1 on the axis.
    #[inline]
    fn irradiance(&self, x: PlanePoint) -> f64 {
        (-2.0 * (x[0] * x[0] + x[1] * x[1]) / (self.w * self.w)).exp()
    }

    /// The undeflected unit direction through `x`.
    #[inline]
    fn direction(&self, x: PlanePoint) -> DVec3 {
        DVec3::new(x[0], self.stretch_y * x[1], 1.0).normalize()
    }

    /// The point of the pattern's plane where the undeflected beam frame's
    /// point `q` lies (`q.z > 0`): the sub-ray through it has direction
    /// `(X, stretch·Y, 1)`.
    #[inline]
    pub fn plane_point(&self, q: DVec3) -> PlanePoint {
        [q.x / q.z, q.y / (self.stretch_y * q.z)]
    }

    /// Makes `outline` the convex hull of the points pushed to it, within
    /// the square around the cells.
    pub fn close_outline(&self, outline: &mut Outline) {
        outline.close(self.reach);
    }

    /// Whether the convex `outline` holds the whole of cell `i` (a cheap
    /// test: `false` may still hold it).
    pub fn outline_holds_cell(&self, i: usize, outline: &Outline) -> bool {
        let (site, radius) = self.cells[i].disk();
        outline.holds_disk(site, radius)
    }

    /// Whether cell `i` may meet the convex `outline` (a cheap test:
    /// `false` is apart, `true` may still be: clipping to the cell then
    /// leaves nothing).
    pub fn cell_may_meet(&self, i: usize, outline: &Outline) -> bool {
        self.cells[i].may_meet(outline)
    }

    /// Lower and upper bounds of `n · (X, stretch·Y, 1)` over the points
    /// `(X, Y)` of cell `i` (`None`: over all cells), the directions of a
    /// plane's normal `n` times the beam's unnormalised directions there:
    /// a plane `n·q = c` of the beam frame lies at depth `q.z = c / (n ·
    /// (X, stretch·Y, 1))` along them.
    pub fn normal_range(&self, i: Option<usize>, n: DVec3) -> (f64, f64) {
        let (centre, radius) = match i {
            Some(i) => self.cells[i].disk(),
            None => ([0.0, 0.0], self.reach * std::f64::consts::SQRT_2),
        };
        let (gx, gy) = (n.x, n.y * self.stretch_y);
        let mid = gx * centre[0] + gy * centre[1] + n.z;
        let half = radius * gx.hypot(gy);
        (mid - half, mid + half)
    }
}

impl Beam {
    /// The beam of `n ≥ 1` sub-rays and full divergence `divergence_rad`.
    pub fn new(n: usize, divergence_rad: f64) -> Self {
        Self::elliptical(n, divergence_rad, divergence_rad)
    }

    /// The beam of `n ≥ 1` sub-rays with full divergence `across_rad` in
    /// the beam's x direction (across the scan of a mirror) and `along_rad`
    /// in its y direction (along the track): an elliptical footprint, the
    /// sub-rays filling the ellipse as they fill the round beam's disk.
    pub fn elliptical(n: usize, across_rad: f64, along_rad: f64) -> Self {
        let (divergence_rad, stretch_y) = if across_rad > 0.0 {
            (across_rad, along_rad / across_rad)
        } else {
            (across_rad, 1.0)
        };
        if n <= 1 {
            return Self {
                variants: vec![BeamPattern::central()],
                sampled: false,
            };
        }
        let count = (65_536 / n).clamp(1, VARIANTS);
        let mut rng = TableRng(0x6265_616D);
        let mut fine_rng = TableRng(0x6669_6E65);
        Self {
            variants: (0..count)
                .map(|_| {
                    BeamPattern::jittered(n, divergence_rad, stretch_y, &mut rng, &mut fine_rng)
                })
                .collect(),
            sampled: true,
        }
    }

    /// Number of sub-rays of a pulse.
    pub fn subrays(&self) -> usize {
        self.variants[0].len()
    }

    /// The pattern of a pulse, drawn from the pulse's beam stream (the
    /// central ray with one sub-ray: nothing is drawn).
    #[inline]
    pub fn for_pulse(&self, rng: impl FnOnce() -> Stream) -> &BeamPattern {
        if !self.sampled {
            return &self.variants[0];
        }
        let v = (rng().uniform() * self.variants.len() as f64) as usize;
        &self.variants[v.min(self.variants.len() - 1)]
    }

    /// Every precomputed pattern.
    pub fn patterns(&self) -> &[BeamPattern] {
        &self.variants
    }
}

#[cfg(test)]
mod tests;

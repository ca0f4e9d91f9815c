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

pub use cells::{Outline, PlanePoint};

use crate::geometry::{DMat3, DVec3};
use crate::rng::Stream;
use cells::Cell;

/// Precomputed jittered patterns (fewer for very large N, so that they take
/// at most about 2¹⁶ sub-rays in all).
pub const VARIANTS: usize = 64;

/// How finely a refined cell is sampled: by a `k × k` jittered grid
/// mapped onto it area for area.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Fineness {
    /// 4 × 4 rays: what a resolved discontinuity asks for.
    Rays16,
    /// 8 × 8 rays.
    Rays64,
    /// 16 × 16 rays: for targets much narrower than their cell.
    Rays256,
}

impl Fineness {
    /// Every fineness, coarsest first.
    pub const ALL: [Fineness; 3] = [Fineness::Rays16, Fineness::Rays64, Fineness::Rays256];

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
        let cell = &self.cells[i];
        let start = out.len();
        let mut sum = 0.0;
        for &[a, b] in &self.grids[fineness as usize] {
            let [x, y] = cell.sample(a, b);
            let weight = (-2.0 * (x * x + y * y) / (self.w * self.w)).exp();
            sum += weight;
            out.push((DVec3::new(x, self.stretch_y * y, 1.0).normalize(), weight));
        }
        let scale = self.energy[i] / sum;
        for s in &mut out[start..] {
            s.1 *= scale;
        }
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
        let cell = &self.cells[i];
        let start = out.len();
        let mut sum = 0.0;
        for &[a, b] in &self.grids[fineness as usize] {
            let x = cell.sample(a, b);
            if !keep(x) {
                continue;
            }
            let weight = self.irradiance(x);
            sum += weight;
            out.push((self.direction(x), weight));
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
        let mut sum = 0.0;
        for &[a, b] in grid {
            let x = patch.sample(a, b);
            if !keep(x) {
                continue;
            }
            let share = stratum * self.irradiance(x);
            sum += share;
            out.push((self.direction(x), share));
        }
        sum
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

    /// Whether cell `i` meets the convex `outline`.
    pub fn cell_meets(&self, i: usize, outline: &Outline) -> bool {
        self.cells[i].meets(outline)
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
mod tests {
    use super::*;

    /// Enclosed power of the Gaussian beam within off-axis angle `r`.
    fn enclosed(r: f64, w: f64) -> f64 {
        1.0 - (-2.0 * r * r / (w * w)).exp()
    }

    /// An elliptical beam (1 mrad across, 3 mrad along): the energy's
    /// spread along y is three times that across, for the sub-rays and for
    /// the fine samples of their cells (a Gaussian `exp(−2x²/wx² −
    /// 2y²/wy²)` has second moments `w²/4` on each axis).
    #[test]
    fn an_elliptical_beam_spreads_by_its_two_divergences() {
        let (across, along) = (1e-3, 3e-3);
        let beam = Beam::elliptical(64, across, along);
        let (mut xx, mut yy) = (0.0, 0.0);
        let (mut fxx, mut fyy, mut fsum) = (0.0, 0.0, 0.0);
        let mut fine = Vec::new();
        for p in beam.patterns() {
            for (i, d) in p.base_directions().iter().enumerate() {
                xx += d.x * d.x;
                yy += d.y * d.y;
                for fineness in Fineness::ALL {
                    fine.clear();
                    p.fine_samples(i, fineness, &mut fine);
                    for (f, share) in &fine {
                        fxx += share * f.x * f.x;
                        fyy += share * f.y * f.y;
                        fsum += share;
                    }
                }
            }
        }
        let n = (beam.patterns().len() * 64) as f64;
        let want = |w: f64| (w / 2.0).powi(2) / 4.0;
        // Each stratum's sub-ray lies inside it, and the tails beyond
        // 99.9 % of the energy are cut: the spread of a pattern is some
        // 10 % short of the whole Gaussian's, the same on both axes. The
        // fine samples, weighted by the irradiance over cells that tile the
        // beam, have the Gaussian's.
        for (got, w) in [(xx / n, across), (yy / n, along)] {
            assert!(
                (got / want(w) - 0.95).abs() < 0.1,
                "{got} against {}",
                want(w)
            );
        }
        for (got, w) in [(fxx / fsum, across), (fyy / fsum, along)] {
            assert!(
                (got / want(w) - 1.0).abs() < 0.02,
                "{got} against {}",
                want(w)
            );
        }
        assert!(
            ((yy / xx).sqrt() - 3.0).abs() < 0.03,
            "{}",
            (yy / xx).sqrt()
        );
        assert!(
            ((fyy / fxx).sqrt() - 3.0).abs() < 0.03,
            "{}",
            (fyy / fxx).sqrt()
        );
    }

    #[test]
    fn sub_rays_follow_the_gaussian_profile_with_its_tails() {
        let div = 0.5e-3;
        let w = div / 2.0;
        let beam = Beam::new(19, div);
        assert_eq!(beam.patterns().len(), VARIANTS);
        // Over all patterns, the share of sub-rays within radius r is the
        // enclosed power, tails beyond 1/e² included (to 99.9 %).
        let angles: Vec<f64> = beam
            .patterns()
            .iter()
            .flat_map(|p| p.off_axis_angles())
            .collect();
        for frac in [0.25, 0.5, 0.75, 1.0, 1.3] {
            let want = enclosed(frac * w, w);
            let got = angles.iter().filter(|&&a| a < frac * w).count() as f64 / angles.len() as f64;
            assert!((got - want).abs() < 0.02, "r = {frac} w: {got} vs {want}");
        }
        // 13.5 % of the energy lies beyond 1/e².
        let beyond = angles.iter().filter(|&&a| a > w).count() as f64 / angles.len() as f64;
        assert!((beyond - (-2.0f64).exp()).abs() < 0.02, "{beyond}");
        // Each pattern is stratified: one sub-ray per energy stratum.
        for p in beam.patterns() {
            let mut e: Vec<f64> = p.off_axis_angles().map(|a| enclosed(a, w)).collect();
            e.sort_by(f64::total_cmp);
            for (i, x) in e.iter().enumerate() {
                assert!(*x >= i as f64 / 19.0 - 1e-9 && *x <= (i + 1) as f64 / 19.0 + 1e-9);
            }
            assert!(p.off_axis_angles().all(|a| a <= 1.87 * w));
        }
    }

    /// The cells tile the disk of 99.99 % of the energy: their areas add
    /// up to the polygon around it, and every point of it lies in exactly
    /// one cell (two or three only on their shared edges).
    #[test]
    fn cells_tile_the_beam() {
        let beam = Beam::elliptical(19, 0.3e-3, 0.6e-3);
        let mut rng = TableRng(3);
        for p in beam.patterns().iter().take(8) {
            let step = std::f64::consts::PI / cells::RIM_CORNERS as f64;
            let rim = cells::RIM_CORNERS as f64 * p.reach * p.reach * step.tan();
            let area: f64 = p.cells.iter().map(|c| c.area()).sum();
            assert!((area / rim - 1.0).abs() < 1e-9, "{area} vs {rim}");
            for _ in 0..2000 {
                let (r, a) = (p.reach * rng.uniform().sqrt(), rng.uniform() * 7.0);
                let x = [r * a.cos(), r * a.sin()];
                let tol = 1e-9 * p.reach;
                let within = p.cells.iter().filter(|c| c.contains(x, tol)).count();
                let inside = p.cells.iter().filter(|c| c.contains(x, -tol)).count();
                assert!(within >= 1 && inside <= 1, "{x:?}: {within} {inside}");
            }
        }
    }

    #[test]
    fn fine_samples_carry_the_cell_share_inside_the_cell() {
        let beam = Beam::new(19, 0.3e-3);
        for p in beam.patterns().iter().take(4) {
            assert!(p.refined());
            let mut out = Vec::new();
            for i in 0..p.len() {
                for fineness in Fineness::ALL {
                    out.clear();
                    p.fine_samples(i, fineness, &mut out);
                    assert_eq!(out.len(), fineness.rays());
                    let total: f64 = out.iter().map(|s| s.1).sum();
                    assert!((total - p.cell_energy(i)).abs() < 1e-12);
                    for (d, _) in &out {
                        assert!((d.length() - 1.0).abs() < 1e-12);
                        let x = p.plane_point(*d);
                        assert!(p.cells[i].contains(x, 1e-9 * p.reach), "{x:?}");
                    }
                }
                assert_eq!(p.neighbours(i).count(), NEIGHBOURS);
            }
        }
    }

    /// Fine samples spread evenly over their cell: the finest grid's
    /// samples, unweighted, have the cell's centroid as their mean and
    /// split it in halves about any line through that centroid.
    #[test]
    fn fine_samples_cover_their_cell_evenly() {
        let beam = Beam::new(19, 0.3e-3);
        let p = &beam.patterns()[5];
        let mut out = Vec::new();
        for i in 0..p.len() {
            out.clear();
            p.fine_samples(i, Fineness::Rays256, &mut out);
            let pts: Vec<PlanePoint> = out.iter().map(|(d, _)| p.plane_point(*d)).collect();
            // The centroid from a fine grid over the cell's disk.
            let (c, r) = p.cells[i].disk();
            let (mut sx, mut sy, mut n) = (0.0, 0.0, 0.0);
            for a in 0..400 {
                for b in 0..400 {
                    let x = [
                        c[0] + r * ((a as f64 + 0.5) / 200.0 - 1.0),
                        c[1] + r * ((b as f64 + 0.5) / 200.0 - 1.0),
                    ];
                    if p.cells[i].contains(x, 0.0) {
                        (sx, sy, n) = (sx + x[0], sy + x[1], n + 1.0);
                    }
                }
            }
            let centroid = [sx / n, sy / n];
            let size = p.cells[i].area().sqrt();
            let mean = [
                pts.iter().map(|x| x[0]).sum::<f64>() / pts.len() as f64,
                pts.iter().map(|x| x[1]).sum::<f64>() / pts.len() as f64,
            ];
            assert!(
                (mean[0] - centroid[0]).hypot(mean[1] - centroid[1]) < 0.02 * size,
                "cell {i}: {mean:?} vs {centroid:?}"
            );
            for a in [0.0f64, 1.0, 2.0] {
                let left = pts
                    .iter()
                    .filter(|x| {
                        (x[0] - centroid[0]) * a.cos() + (x[1] - centroid[1]) * a.sin() < 0.0
                    })
                    .count();
                assert!(
                    left.abs_diff(128) <= 16,
                    "cell {i}, angle {a}: {left} of 256"
                );
            }
        }
    }

    /// A small square target anywhere in the core of the beam receives, from
    /// the refined cells it lies in, the Gaussian beam's energy over it:
    /// on average over positions and patterns, and some of it always (the
    /// cells tile the beam: no target falls between them).
    #[test]
    fn a_small_target_receives_the_beam_energy_it_covers() {
        let div = 0.3e-3;
        let w = div / 2.0;
        let beam = Beam::new(19, div);
        let h = 0.05 * w;
        let erf_share =
            |c: f64| (erf(2f64.sqrt() * (c + h) / w) - erf(2f64.sqrt() * (c - h) / w)) / 2.0;
        let mut rng = TableRng(9);
        let mut ratios = Vec::new();
        let mut fine = Vec::new();
        for p in beam.patterns() {
            for _ in 0..4 {
                let (r, a) = (0.5 * w * rng.uniform().sqrt(), rng.uniform() * 7.0);
                let c = [r * a.cos(), r * a.sin()];
                let mut got = 0.0;
                for i in 0..p.len() {
                    fine.clear();
                    p.fine_samples(i, Fineness::Rays256, &mut fine);
                    for (d, share) in &fine {
                        let x = p.plane_point(*d);
                        if (x[0] - c[0]).abs() <= h && (x[1] - c[1]).abs() <= h {
                            got += share;
                        }
                    }
                }
                ratios.push(got / (erf_share(c[0]) * erf_share(c[1])));
            }
        }
        let mean = ratios.iter().sum::<f64>() / ratios.len() as f64;
        ratios.sort_by(f64::total_cmp);
        let (least, low) = (ratios[0], ratios[ratios.len() / 20]);
        // Measured: mean 0.998, 5 % of targets below 0.77, least 0.40 (a
        // target 0.1 w wide meets some ten of a cell's 256 samples).
        assert!((mean - 1.0).abs() < 0.03, "mean {mean}");
        assert!(low > 0.7 && least > 0.3, "5 % below {low}, least {least}");
    }

    /// A small square target's pieces in the cells it meets, sampled as
    /// patches, carry the Gaussian beam's energy over it (the product of
    /// error functions), unbiased for any size and closely in each pulse
    /// for a small one, and every patch sample lies on it.
    #[test]
    fn patch_samples_carry_the_beam_energy_over_the_target() {
        let div = 0.3e-3;
        let w = div / 2.0;
        let beam = Beam::new(19, div);
        let mut rng = TableRng(11);
        let mut out = Vec::new();
        let (mut small_sq, mut ratios): (Vec<f64>, Vec<f64>) = (Vec::new(), Vec::new());
        for p in beam.patterns() {
            for k in 0..8 {
                // Half the targets up to 0.3 w wide (a 3 cm plate in a
                // 0.3 mrad beam at 1000 m is 0.2 w), half up to 1.4 w.
                let small = k % 2 == 0;
                let h = if small {
                    0.05 + 0.1 * rng.uniform()
                } else {
                    0.05 + 0.65 * rng.uniform()
                } * w;
                let (r, a) = (w * rng.uniform().sqrt(), rng.uniform() * 7.0);
                let c = [r * a.cos(), r * a.sin()];
                let mut square = Outline::default();
                for (dx, dy) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                    square.push([c[0] + dx * h, c[1] + dy * h]);
                }
                p.close_outline(&mut square);
                let mut got = 0.0;
                for i in 0..p.len() {
                    if !p.cell_meets(i, &square) {
                        continue;
                    }
                    let mut piece = Outline::default();
                    piece.copy_from(&square);
                    p.clip_to_cell(i, &mut piece);
                    if piece.area() == 0.0 {
                        continue;
                    }
                    out.clear();
                    let e = p.patch_samples(&piece, |_| true, &mut out);
                    assert_eq!(out.len(), PATCH_RAYS);
                    assert!((out.iter().map(|s| s.1).sum::<f64>() - e).abs() < 1e-15);
                    for (d, _) in &out {
                        let x = p.plane_point(*d);
                        let tol = 1e-9 * w;
                        assert!((x[0] - c[0]).abs() <= h + tol && (x[1] - c[1]).abs() <= h + tol);
                    }
                    got += e;
                }
                let side = |o: f64| {
                    (erf(2f64.sqrt() * (o + h) / w) - erf(2f64.sqrt() * (o - h) / w)) / 2.0
                };
                let want = side(c[0]) * side(c[1]);
                if small {
                    small_sq.push((got / want - 1.0).powi(2));
                }
                ratios.push(got / want);
            }
        }
        let mean = ratios.iter().sum::<f64>() / ratios.len() as f64;
        let sd =
            (ratios.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / ratios.len() as f64).sqrt();
        // Across a target 0.3 w wide within w of the axis ln I changes by
        // up to 4·w·0.3w/w² = 1.2, a factor 3.3, which four strata per
        // piece follow to some 25 % at worst and 5 % RMS (each pulse's
        // jitter differs, so that averages over pulses converge); over
        // 512 targets of all sizes the mean is within 4 standard errors
        // of 1.
        let rms = (small_sq.iter().sum::<f64>() / small_sq.len() as f64).sqrt();
        assert!(rms < 0.1, "RMS relative error {rms}");
        let se = sd / (ratios.len() as f64).sqrt();
        assert!((mean - 1.0).abs() < 4.0 * se, "mean {mean} ± {se}");
        eprintln!("small targets: RMS error {rms}; all: mean {mean} ± {se}");
    }

    /// The error function, to 1.2 × 10⁻⁷ (Numerical Recipes, `erfcc`).
    fn erf(x: f64) -> f64 {
        let t = 1.0 / (1.0 + 0.5 * x.abs());
        let poly = -1.265_512_23
            + t * (1.000_023_68
                + t * (0.374_091_96
                    + t * (0.096_784_18
                        + t * (-0.186_288_06
                            + t * (0.278_868_07
                                + t * (-1.135_203_98
                                    + t * (1.488_515_87
                                        + t * (-0.822_152_23 + t * 0.170_872_77))))))));
        let erfc = t * (-x * x + poly).exp();
        if x >= 0.0 { 1.0 - erfc } else { erfc - 1.0 }
    }

    #[test]
    fn one_sub_ray_is_the_axis_and_draws_nothing() {
        let beam = Beam::new(1, 1e-3);
        let p = beam.for_pulse(|| unreachable!("no random number is drawn"));
        assert_eq!(p.base_directions(), &[DVec3::Z]);
        assert!(!p.refined());
    }

    #[test]
    fn deflection_takes_the_axis_to_the_beam() {
        let m = deflection(0.3);
        let want = DVec3::new(0.3f64.sin(), 0.0, 0.3f64.cos());
        assert!((m * DVec3::Z - want).length() < 1e-15);
    }
}

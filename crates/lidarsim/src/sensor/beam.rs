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
//! the disk of solid angle `Ωᵢ = shareᵢ / I(rᵢ)` around it, `I` the beam's
//! irradiance per steradian (the disk at most as wide as the distance to
//! its neighbours). Where two neighbouring sub-rays see a discontinuity the
//! receiver can resolve — closest hits more than the range resolution
//! `c·FWHM/2` apart, or one a hit and the other a miss — the cells
//! of both are sampled again by [`FINE_PER_CELL`] rays each, stratified
//! over the disk and weighted by the irradiance there, the weights adding
//! up to the cell's share ([`BeamPattern::fine_samples`]). A target smaller
//! than a cell then returns power in proportion to the part of the cell it
//! covers — its cross-section times the irradiance, so `R⁻⁴` for a point
//! target — while an extended surface, whose cells are not refined, keeps
//! the `R⁻²` of Eq. 2. A target that no coarse sub-ray meets is missed (it
//! holds less than about one cell of the beam's energy); the jitter makes
//! that a matter of chance in proportion to its size, not of where fixed
//! rays fall.
//!
//! With N = 1 the single ray is the beam's axis, neither jittered nor
//! refined (the single-ray mode). Patterns of more than
//! [`MAX_REFINED_SUBRAYS`] sub-rays sample the beam finely themselves and
//! are not refined.

use crate::geometry::{DMat3, DVec3};
use crate::rng::Stream;

/// Precomputed jittered patterns (fewer for very large N, so that they take
/// at most about 2¹⁶ sub-rays in all).
pub const VARIANTS: usize = 64;

/// Rays that sample a refined cell.
pub const FINE_PER_CELL: usize = 16;

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
    /// Angular radius of each sub-ray's cell, rad.
    cell_radius: Vec<f64>,
    /// Indices of each sub-ray's nearest neighbours (`u16::MAX`: none).
    neighbours: Vec<[u16; NEIGHBOURS]>,
    /// Stratified points of the unit disk for the fine samples, this
    /// pattern's own jitter.
    disk: Vec<[f64; 2]>,
    /// The fine samples of every cell, [`FINE_PER_CELL`] a cell in
    /// sub-ray order (empty when cells are not refined): worked out once
    /// with the pattern, not for each pulse that refines a cell.
    fine: Vec<(DVec3, f64)>,
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
    /// jittered by `rng`.
    fn jittered(n: usize, divergence_rad: f64, stretch_y: f64, rng: &mut TableRng) -> Self {
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
        let mut neighbours = Vec::new();
        let mut cell_radius = Vec::new();
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
                // The disk of the cell's solid angle share / I(r), I the
                // irradiance per steradian 2/(π w²)·exp(−2r²/w²), at most as
                // wide as the distance to the nearest neighbour.
                let r = o[0].hypot(o[1]).atan();
                let irradiance =
                    2.0 / (std::f64::consts::PI * w * w) * (-2.0 * r * r / (w * w)).exp();
                let from_area = (share / irradiance / std::f64::consts::PI).sqrt();
                let spacing = near.first().map_or(w, |n| n.0);
                cell_radius.push(from_area.min(spacing));
            }
        }
        // FINE_PER_CELL stratified points of the unit disk: a 4 × 4 grid of
        // the square, jittered, mapped to the disk by Shirley and Chiu's
        // concentric map (equal areas to equal areas).
        let side = (FINE_PER_CELL as f64).sqrt() as usize;
        let disk = (0..side * side)
            .map(|k| {
                let a = 2.0 * ((k % side) as f64 + rng.uniform()) / side as f64 - 1.0;
                let b = 2.0 * ((k / side) as f64 + rng.uniform()) / side as f64 - 1.0;
                concentric(a, b)
            })
            .collect();
        let mut pattern = Self {
            offsets,
            base,
            share,
            cell_radius,
            neighbours,
            disk,
            fine: Vec::new(),
            w,
            stretch_y,
        };
        if refined {
            let mut fine = Vec::with_capacity(n * FINE_PER_CELL);
            for i in 0..n {
                pattern.work_out_fine_samples(i, &mut fine);
            }
            pattern.fine = fine;
        }
        pattern
    }

    /// The single central ray.
    fn central() -> Self {
        Self {
            offsets: vec![[0.0, 0.0]],
            base: vec![DVec3::Z],
            share: 1.0,
            cell_radius: Vec::new(),
            neighbours: Vec::new(),
            disk: Vec::new(),
            fine: Vec::new(),
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

    /// The [`FINE_PER_CELL`] rays sampling the cell of sub-ray `i`, as
    /// (undeflected unit direction, energy share) appended to `out`: spread
    /// evenly over the cell's disk and weighted by the beam's irradiance at
    /// each, the shares adding up to the sub-ray's.
    pub fn fine_samples(&self, i: usize, out: &mut Vec<(DVec3, f64)>) {
        out.extend_from_slice(&self.fine[i * FINE_PER_CELL..(i + 1) * FINE_PER_CELL]);
    }

    /// [`BeamPattern::fine_samples`] worked out, for the pattern's table.
    fn work_out_fine_samples(&self, i: usize, out: &mut Vec<(DVec3, f64)>) {
        let o = self.offsets[i];
        let rho = self.cell_radius[i];
        let start = out.len();
        let mut sum = 0.0;
        for d in &self.disk {
            let (x, y) = (o[0] + rho * d[0], o[1] + rho * d[1]);
            let r2 = x * x + y * y;
            let weight = (-2.0 * r2 / (self.w * self.w)).exp();
            sum += weight;
            out.push((DVec3::new(x, self.stretch_y * y, 1.0).normalize(), weight));
        }
        let scale = self.share / sum;
        for s in &mut out[start..] {
            s.1 *= scale;
        }
    }
}

/// Shirley and Chiu's concentric map of the square `[−1, 1]²` to the unit
/// disk ("A low distortion map between disk and square", 1997).
fn concentric(a: f64, b: f64) -> [f64; 2] {
    if a == 0.0 && b == 0.0 {
        return [0.0, 0.0];
    }
    let quarter = std::f64::consts::FRAC_PI_4;
    let (r, phi) = if a.abs() > b.abs() {
        (a, quarter * (b / a))
    } else {
        (b, 2.0 * quarter - quarter * (a / b))
    };
    [r * phi.cos(), r * phi.sin()]
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
        Self {
            variants: (0..count)
                .map(|_| BeamPattern::jittered(n, divergence_rad, stretch_y, &mut rng))
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
                fine.clear();
                p.fine_samples(i, &mut fine);
                for (f, share) in &fine {
                    fxx += share * f.x * f.x;
                    fyy += share * f.y * f.y;
                    fsum += share;
                }
            }
        }
        let n = (beam.patterns().len() * 64) as f64;
        let want = |w: f64| (w / 2.0).powi(2) / 4.0;
        // Each stratum's sub-ray lies inside it, and the tails beyond
        // 99.9 % of the energy are cut: the spread of a pattern is some
        // 10 % short of the whole Gaussian's, the same on both axes.
        for (got, w) in [
            (xx / n, across),
            (yy / n, along),
            (fxx / fsum, across),
            (fyy / fsum, along),
        ] {
            assert!(
                (got / want(w) - 0.95).abs() < 0.1,
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

    #[test]
    fn fine_samples_carry_the_cell_share_inside_the_cell() {
        let beam = Beam::new(19, 0.3e-3);
        for p in beam.patterns().iter().take(4) {
            assert!(p.refined());
            let mut out = Vec::new();
            for i in 0..p.len() {
                out.clear();
                p.fine_samples(i, &mut out);
                assert_eq!(out.len(), FINE_PER_CELL);
                let total: f64 = out.iter().map(|s| s.1).sum();
                assert!((total - p.share()).abs() < 1e-12);
                let centre = p.base_directions()[i];
                for (d, _) in &out {
                    assert!((d.length() - 1.0).abs() < 1e-12);
                    assert!(d.angle_between(centre) <= p.cell_radius[i] * 1.0001 + 1e-12);
                }
                assert_eq!(p.neighbours(i).count(), NEIGHBOURS);
            }
        }
    }

    #[test]
    fn one_sub_ray_is_the_axis_and_draws_nothing() {
        let beam = Beam::new(1, 1e-3);
        let p = beam.for_pulse(|| unreachable!("no random number is drawn"));
        assert_eq!(p.base_directions(), &[DVec3::Z]);
        assert!(!p.refined());
    }

    #[test]
    fn concentric_map_covers_the_disk_evenly() {
        // Equal areas of the square map to equal areas of the disk: the
        // share of a fine grid's images within radius r is r².
        let n = 200;
        let pts: Vec<[f64; 2]> = (0..n * n)
            .map(|k| {
                let a = 2.0 * ((k % n) as f64 + 0.5) / n as f64 - 1.0;
                let b = 2.0 * ((k / n) as f64 + 0.5) / n as f64 - 1.0;
                concentric(a, b)
            })
            .collect();
        for r in [0.3, 0.6, 0.9] {
            let got = pts.iter().filter(|p| p[0].hypot(p[1]) < r).count() as f64 / pts.len() as f64;
            assert!((got - r * r).abs() < 0.01, "{r}: {got}");
        }
        assert!(pts.iter().all(|p| p[0].hypot(p[1]) <= 1.0 + 1e-12));
    }

    #[test]
    fn deflection_takes_the_axis_to_the_beam() {
        let m = deflection(0.3);
        let want = DVec3::new(0.3f64.sin(), 0.0, 0.3f64.cos());
        assert!((m * DVec3::Z - want).length() < 1e-15);
    }
}

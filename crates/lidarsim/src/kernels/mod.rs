//! The SIMD kernels: every processor intrinsic of the simulator, behind a
//! safe API.
//!
//! Each kernel has a scalar twin in [`scalar`], its definition: plain
//! arithmetic in the order the vector form performs it, so that both give
//! the same results to the bit (the tests below check it on random
//! inputs). The workspace builds for x86-64-v3 (`.cargo/config.toml`),
//! where the AVX/AVX2 forms run; a build without those features
//! (`-C target-cpu=x86-64`, another architecture) runs the scalar twins,
//! and the test command flies the demo on that build and compares its
//! files with the x86-64-v3 build's, byte for byte
//! (`scripts/check_portable.sh`).
//!
//! The kernels:
//! - [`direction_bounds`]: per axis the bounds and the sum of a pulse's
//!   sub-ray directions;
//! - [`BundleSlabs::enters`]: a bundle of rays against eight boxes at once
//!   (a node of the eight-wide hierarchy);
//! - [`EdgeCone::edges`]: a triangle's three edge planes seen from a
//!   pulse's origin, and on which of them every ray of the pulse's cone
//!   has one sign;
//! - [`for_each_maximum`] and [`lowest_before_higher`]: the scans of
//!   echo detection over a waveform;
//! - [`accumulate_depths`]: eight sub-rays' optical depths of the pulse
//!   march, and which of them reach their thresholds.
//!
//! [`cpu`] asks the processor whether it has what the build was compiled
//! for, so that a program can refuse to start rather than die on its first
//! AVX2 instruction.

#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
mod avx;
pub mod cpu;
pub mod scalar;

use crate::geometry::DVec3;

/// Lanes of a box test: boxes tested at once.
pub const LANES: usize = 8;

/// Eight boxes as structure of arrays, `planes[row][slot]`: rows 0–2 the
/// lower bounds on x, y, z, rows 3–5 the upper ones. An empty slot (lower
/// bound +∞, upper −∞) is entered by no ray.
pub type Boxes = [[f32; LANES]; 6];

/// Per axis, the smallest and the largest component of a set of
/// directions, and their sum (added in order from zero).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectionBounds {
    /// Smallest component per axis.
    pub lo: [f64; 3],
    /// Largest component per axis.
    pub hi: [f64; 3],
    /// Sum of the directions.
    pub sum: DVec3,
}

/// Per axis the bounds and the sum of `dirs` (finite directions).
#[inline]
pub fn direction_bounds(dirs: &[DVec3]) -> DirectionBounds {
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    {
        avx::direction_bounds(dirs)
    }
    #[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
    {
        scalar::direction_bounds(dirs)
    }
}

/// How the direction components of a bundle lie around zero on one axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sign {
    /// All positive.
    Positive,
    /// All negative.
    Negative,
    /// Either.
    Straddles,
}

/// A bundle of rays from one origin, with per axis the sign of their
/// direction components and the reciprocals of the components' bounds:
/// what [`BundleSlabs::enters`] tests boxes with.
#[derive(Clone, Copy, Debug)]
pub struct BundleSlabs {
    /// The origin.
    pub o: [f32; 3],
    /// Per axis: how the direction components lie around zero.
    pub sign: [Sign; 3],
    /// Per axis: reciprocal of the lower bound of the components.
    pub inv_lo: [f32; 3],
    /// Per axis: reciprocal of the upper bound of the components.
    pub inv_hi: [f32; 3],
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    lanes: avx::SlabLanes,
}

impl BundleSlabs {
    /// The bundle from `o` with direction signs `sign` and reciprocal
    /// bounds `inv_lo`, `inv_hi` (finite, non-zero).
    pub fn new(o: [f32; 3], sign: [Sign; 3], inv_lo: [f32; 3], inv_hi: [f32; 3]) -> Self {
        Self {
            #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
            lanes: avx::SlabLanes::new(o, inv_lo, inv_hi),
            o,
            sign,
            inv_lo,
            inv_hi,
        }
    }

    /// The boxes some ray of the bundle can enter before `t_max`: bit
    /// `slot` of the mask set for each, and per slot a lower bound of the
    /// distance at which it does ([`scalar::enters_box`]).
    #[inline(always)]
    pub fn enters(&self, boxes: &Boxes, t_max: f32) -> (u32, [f32; LANES]) {
        #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
        {
            self.lanes.enters(boxes, self.sign, t_max)
        }
        #[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
        {
            scalar::enters(self, boxes, t_max)
        }
    }
}

/// The rays of a pulse as a cone: their common origin, the axis of their
/// directions and a spread that every direction lies within
/// (`|d − axis| ≤ spread`).
#[derive(Clone, Copy, Debug)]
pub struct EdgeCone {
    /// The rays' origin.
    pub origin: DVec3,
    /// The axis of the directions.
    pub axis: DVec3,
    /// The spread, squared.
    pub spread2: f64,
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    lanes: avx::ConeLanes,
}

/// A triangle's edge planes seen from a cone's origin
/// ([`EdgeCone::edges`]).
#[derive(Clone, Copy, Debug)]
pub struct Edges {
    /// Bit `i` set: every ray of the cone has one sign on edge `i` (`ab`,
    /// `bc`, `ca`).
    pub certain: u8,
    /// Bit `i` set: the edge's product at the axis is positive.
    pub positive: u8,
    normals: EdgeNormals,
}

#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
type EdgeNormals = avx::NormalLanes;
#[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
type EdgeNormals = [DVec3; 3];

impl Edges {
    /// The edge-plane normals `a×b`, `b×c`, `c×a` of the corners taken
    /// relative to the origin.
    #[inline(always)]
    pub fn normals(&self) -> [DVec3; 3] {
        #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
        {
            self.normals.get()
        }
        #[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
        {
            self.normals
        }
    }
}

impl EdgeCone {
    /// The cone from `origin` around `axis` with `spread`.
    pub fn new(origin: DVec3, axis: DVec3, spread: f64) -> Self {
        Self {
            origin,
            axis,
            spread2: spread * spread,
            #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
            lanes: avx::ConeLanes::new(origin, axis, spread),
        }
    }

    /// The edge planes of the triangle with `corners`, and on which of
    /// them every ray has one sign: an edge is certain when its product at
    /// the axis `w = axis·e` satisfies `w² > spread²·|e|²`
    /// ([`scalar::edges`]).
    #[inline(always)]
    pub fn edges(&self, corners: [DVec3; 3]) -> Edges {
        #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
        {
            self.lanes.edges(corners)
        }
        #[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
        {
            scalar::edges(self, corners)
        }
    }
}

/// Calls `f` with each `i` in `1..len − 1`, in order, where `s[i]` is above
/// `thr` and a maximum (above the sample before it, not below the one
/// after).
#[inline]
pub fn for_each_maximum(s: &[f64], thr: f64, f: impl FnMut(usize)) {
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    {
        avx::for_each_maximum(s, thr, f)
    }
    #[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
    {
        scalar::for_each_maximum(s, thr, f)
    }
}

/// Which side of a maximum [`lowest_before_higher`] searches.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// Samples before it, searched from the last back.
    Before,
    /// Samples after it, searched from the first on.
    After,
}

/// The lowest of `h` and the samples of `run` met before the first sample
/// above `h` (searching from the end of `run` next to the maximum), and
/// whether no sample was above `h`. The samples are finite and never −0,
/// so the lowest is the same whatever the order in which they are
/// compared.
#[inline]
pub fn lowest_before_higher(run: &[f64], h: f64, side: Side) -> (f64, bool) {
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    {
        avx::lowest_before_higher(run, h, side)
    }
    #[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
    {
        scalar::lowest_before_higher(run, h, side)
    }
}

/// Adds `level` to `depth` lane by lane, except in the lanes where the
/// sum reaches `threshold` (`depth + level >= threshold`): those keep
/// their depth and have their bit set in the mask returned. The values are
/// finite or `+∞`, never NaN.
#[inline(always)]
pub fn accumulate_depths(
    depth: &mut [f32; LANES],
    level: &[f32; LANES],
    threshold: &[f32; LANES],
) -> u32 {
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    {
        avx::accumulate_depths(depth, level, threshold)
    }
    #[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
    {
        scalar::accumulate_depths(depth, level, threshold)
    }
}

#[cfg(test)]
mod tests;

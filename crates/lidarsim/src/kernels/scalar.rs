//! The kernels one value at a time: their definitions, and what a build
//! without AVX2 runs.

use super::{Boxes, BundleSlabs, DirectionBounds, EdgeCone, Edges, LANES, Side, Sign};
use crate::geometry::DVec3;

/// [`super::direction_bounds`]: one component at a time. Plain
/// comparisons: the components are finite, so these are the bounds
/// `f64::min`/`max` give, without their NaN handling.
pub fn direction_bounds(dirs: &[DVec3]) -> DirectionBounds {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    let mut sum = DVec3::ZERO;
    for d in dirs {
        for a in 0..3 {
            if d[a] < lo[a] {
                lo[a] = d[a];
            }
            if d[a] > hi[a] {
                hi[a] = d[a];
            }
        }
        sum += *d;
    }
    DirectionBounds { lo, hi, sum }
}

/// [`BundleSlabs::enters`] one slot at a time.
pub fn enters(b: &BundleSlabs, boxes: &Boxes, t_max: f32) -> (u32, [f32; LANES]) {
    let mut mask = 0;
    let mut t = [0.0; LANES];
    for (slot, t) in t.iter_mut().enumerate() {
        let lo = [0, 1, 2].map(|a| boxes[a][slot]);
        let hi = [0, 1, 2].map(|a| boxes[3 + a][slot]);
        let (enters, t0) = enters_box(b, lo, hi, t_max);
        mask |= u32::from(enters) << slot;
        *t = t0;
    }
    (mask, t)
}

/// Whether some ray of the bundle can enter the box `[lo, hi]` before
/// `t_max`, and a lower bound of the distance at which it does.
///
/// On each axis a ray `o + t·d` (t ≥ 0) with `lo ≤ d ≤ hi` is inside the
/// slab `[min, max]` only if `t·hi ≥ min − o` and `t·lo ≤ max − o`; each
/// condition bounds `t` from below or above depending on the sign of `hi`
/// and `lo`. An empty box (`lo` = +∞, `hi` = −∞) is entered by no ray.
#[inline]
pub fn enters_box(b: &BundleSlabs, lo: [f32; 3], hi: [f32; 3], t_max: f32) -> (bool, f32) {
    let mut t0 = 0.0f32;
    let mut t1 = t_max;
    for a in 0..3 {
        let below = (lo[a] - b.o[a]) * b.inv_hi[a];
        let above = (hi[a] - b.o[a]) * b.inv_lo[a];
        match b.sign[a] {
            Sign::Positive => {
                t0 = t0.max(below);
                t1 = t1.min(above);
            }
            Sign::Negative => {
                t0 = t0.max(above);
                t1 = t1.min(below);
            }
            Sign::Straddles => {
                t0 = t0.max(below).max(above);
            }
        }
    }
    (t0 <= t1, t0)
}

/// [`EdgeCone::edges`]: edge `i` from corner `i` to the next, both taken
/// relative to the origin; its plane's normal is their cross product, `w`
/// its product with the axis.
#[inline]
pub fn edges(cone: &EdgeCone, corners: [DVec3; 3]) -> Edges {
    let p = corners.map(|v| v - cone.origin);
    let normals = [p[0].cross(p[1]), p[1].cross(p[2]), p[2].cross(p[0])];
    let (mut certain, mut positive) = (0u8, 0u8);
    for (i, e) in normals.iter().enumerate() {
        let w = cone.axis.dot(*e);
        if w * w > cone.spread2 * e.dot(*e) {
            certain |= 1 << i;
        }
        if w > 0.0 {
            positive |= 1 << i;
        }
    }
    Edges {
        certain,
        positive,
        #[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
        normals,
        #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
        normals: super::avx::NormalLanes::of(normals),
    }
}

/// [`super::for_each_maximum`], one sample at a time.
pub fn for_each_maximum(s: &[f64], thr: f64, f: impl FnMut(usize)) {
    maxima_from(s, thr, 1, f);
}

/// [`for_each_maximum`] from sample `i` on.
#[inline]
pub(super) fn maxima_from(s: &[f64], thr: f64, mut i: usize, mut f: impl FnMut(usize)) {
    let n = s.len();
    while i + 1 < n {
        let v = s[i];
        if v > thr && v > s[i - 1] && v >= s[i + 1] {
            f(i);
        }
        i += 1;
    }
}

/// [`super::lowest_before_higher`], one sample at a time.
pub fn lowest_before_higher(run: &[f64], h: f64, side: Side) -> (f64, bool) {
    lowest_from(run, h, h, side)
}

/// [`lowest_before_higher`] with the lowest so far `low`.
#[inline]
pub(super) fn lowest_from(run: &[f64], h: f64, mut low: f64, side: Side) -> (f64, bool) {
    let mut scan = |v: f64| {
        if v > h {
            return false;
        }
        if v < low {
            low = v;
        }
        true
    };
    let reached = match side {
        Side::Before => run.iter().rev().all(|&v| scan(v)),
        Side::After => run.iter().all(|&v| scan(v)),
    };
    (low, reached)
}

/// [`super::accumulate_depths`] one lane at a time.
pub fn accumulate_depths(
    depth: &mut [f32; LANES],
    level: &[f32; LANES],
    threshold: &[f32; LANES],
) -> u32 {
    let mut mask = 0;
    for l in 0..LANES {
        let sum = depth[l] + level[l];
        if sum >= threshold[l] {
            mask |= 1 << l;
        } else {
            depth[l] = sum;
        }
    }
    mask
}

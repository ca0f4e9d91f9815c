//! The kernels in AVX and AVX2 registers: the operations of their scalar
//! twins ([`super::scalar`]), lane by lane, in the same order.

use std::arch::x86_64::*;

use super::{Boxes, DirectionBounds, Edges, LANES, Side, Sign};
use crate::geometry::DVec3;

// SAFETY (all `unsafe` blocks of this module): the module is compiled only
// when the build enables AVX and AVX2 (`cfg` in `kernels/mod.rs`), so the
// intrinsics are available; every load and store names its bounds.

/// [`super::direction_bounds`] with the three components of a direction in
/// lanes 0–2: the same comparisons (`_mm256_min_pd(d, lo)` is
/// `d < lo ? d : lo`) and the same additions in the same order.
#[inline]
pub(super) fn direction_bounds(dirs: &[DVec3]) -> DirectionBounds {
    // SAFETY: see the module; each masked load reads the three `f64` of
    // one `DVec3` and nothing beyond.
    unsafe {
        let mask = _mm256_setr_epi64x(-1, -1, -1, 0);
        let mut lo = _mm256_set1_pd(f64::INFINITY);
        let mut hi = _mm256_set1_pd(f64::NEG_INFINITY);
        let mut sum = _mm256_setzero_pd();
        for d in dirs {
            let v = _mm256_maskload_pd(d as *const DVec3 as *const f64, mask);
            lo = _mm256_min_pd(v, lo);
            hi = _mm256_max_pd(v, hi);
            sum = _mm256_add_pd(sum, v);
        }
        let mut out = [[0.0f64; 4]; 3];
        _mm256_storeu_pd(out[0].as_mut_ptr(), lo);
        _mm256_storeu_pd(out[1].as_mut_ptr(), hi);
        _mm256_storeu_pd(out[2].as_mut_ptr(), sum);
        let [lo, hi, sum] = out;
        DirectionBounds {
            lo: [lo[0], lo[1], lo[2]],
            hi: [hi[0], hi[1], hi[2]],
            sum: DVec3::new(sum[0], sum[1], sum[2]),
        }
    }
}

/// A bundle's origin and reciprocal bounds, per axis, in all eight lanes.
#[derive(Clone, Copy, Debug)]
pub(super) struct SlabLanes {
    o: [__m256; 3],
    inv_lo: [__m256; 3],
    inv_hi: [__m256; 3],
}

impl SlabLanes {
    pub(super) fn new(o: [f32; 3], inv_lo: [f32; 3], inv_hi: [f32; 3]) -> Self {
        // SAFETY: see the module.
        let splat = |v: [f32; 3]| v.map(|x| unsafe { _mm256_set1_ps(x) });
        Self {
            o: splat(o),
            inv_lo: splat(inv_lo),
            inv_hi: splat(inv_hi),
        }
    }

    /// [`super::BundleSlabs::enters`]: per axis the products and the
    /// minima and maxima of [`super::scalar::enters_box`], in the same
    /// order, for the eight slots at once.
    #[inline(always)]
    pub(super) fn enters(&self, boxes: &Boxes, sign: [Sign; 3], t_max: f32) -> (u32, [f32; LANES]) {
        // SAFETY: see the module; each load reads one `[f32; 8]` row.
        unsafe {
            let mut t0 = _mm256_setzero_ps();
            let mut t1 = _mm256_set1_ps(t_max);
            for (a, sign) in sign.iter().enumerate() {
                let lo = _mm256_loadu_ps(boxes[a].as_ptr());
                let hi = _mm256_loadu_ps(boxes[3 + a].as_ptr());
                let below = _mm256_mul_ps(_mm256_sub_ps(lo, self.o[a]), self.inv_hi[a]);
                let above = _mm256_mul_ps(_mm256_sub_ps(hi, self.o[a]), self.inv_lo[a]);
                match sign {
                    Sign::Positive => {
                        t0 = _mm256_max_ps(t0, below);
                        t1 = _mm256_min_ps(t1, above);
                    }
                    Sign::Negative => {
                        t0 = _mm256_max_ps(t0, above);
                        t1 = _mm256_min_ps(t1, below);
                    }
                    Sign::Straddles => {
                        t0 = _mm256_max_ps(_mm256_max_ps(t0, below), above);
                    }
                }
            }
            // The operands are never NaN (the reciprocals are finite and
            // non-zero), so ordered and quiet is `<=`.
            let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t0, t1)) as u32;
            let mut t = [0.0f32; LANES];
            _mm256_storeu_ps(t.as_mut_ptr(), t0);
            (mask, t)
        }
    }
}

/// A cone's origin, axis and squared spread in all four lanes.
#[derive(Clone, Copy, Debug)]
pub(super) struct ConeLanes {
    o: [__m256d; 3],
    axis: [__m256d; 3],
    s2: __m256d,
}

/// The three edge-plane normals, one per lane (lane 3 unused), until
/// they are asked for.
#[derive(Clone, Copy, Debug)]
pub(super) struct NormalLanes([__m256d; 3]);

impl NormalLanes {
    /// The lanes of three normals.
    pub(super) fn of(normals: [DVec3; 3]) -> Self {
        let [a, b, c] = normals;
        // SAFETY: see the module.
        unsafe {
            Self([
                _mm256_setr_pd(a.x, b.x, c.x, 0.0),
                _mm256_setr_pd(a.y, b.y, c.y, 0.0),
                _mm256_setr_pd(a.z, b.z, c.z, 0.0),
            ])
        }
    }

    /// The three normals.
    #[inline(always)]
    pub(super) fn get(&self) -> [DVec3; 3] {
        let mut c = [[0.0f64; 4]; 3];
        // SAFETY: see the module; stores go to local arrays of four `f64`.
        unsafe {
            for (k, e) in self.0.iter().enumerate() {
                _mm256_storeu_pd(c[k].as_mut_ptr(), *e);
            }
        }
        let normal = |i: usize| DVec3::new(c[0][i], c[1][i], c[2][i]);
        [normal(0), normal(1), normal(2)]
    }
}

impl ConeLanes {
    pub(super) fn new(origin: DVec3, axis: DVec3, spread: f64) -> Self {
        // SAFETY: see the module.
        unsafe {
            Self {
                o: splat3(origin),
                axis: splat3(axis),
                s2: _mm256_set1_pd(spread * spread),
            }
        }
    }

    /// [`super::scalar::edges`] with the triangle's three edges in three
    /// lanes: lane `i` holds corner `i` relative to the origin and the next
    /// corner, their cross product, its product with the axis and its
    /// squared length, each by the operations of `DVec3::cross` and
    /// `DVec3::dot` in their order.
    #[inline(always)]
    pub(super) fn edges(&self, corners: [DVec3; 3]) -> Edges {
        let [v0, v1, v2] = corners;
        // SAFETY: see the module (the lane permutation needs AVX2).
        unsafe {
            let corners = [
                _mm256_setr_pd(v0.x, v1.x, v2.x, 0.0),
                _mm256_setr_pd(v0.y, v1.y, v2.y, 0.0),
                _mm256_setr_pd(v0.z, v1.z, v2.z, 0.0),
            ];
            let p = [0, 1, 2].map(|k| _mm256_sub_pd(corners[k], self.o[k]));
            // The next corner in each lane: b, c, a.
            let q = p.map(|r| _mm256_permute4x64_pd::<0b11_00_10_01>(r));
            let cross = |i: usize, j: usize| {
                _mm256_sub_pd(_mm256_mul_pd(p[i], q[j]), _mm256_mul_pd(q[i], p[j]))
            };
            let e = [cross(1, 2), cross(2, 0), cross(0, 1)];
            let w = dot4(&self.axis, &e);
            let len2 = dot4(&e, &e);
            let certain =
                _mm256_cmp_pd::<_CMP_GT_OQ>(_mm256_mul_pd(w, w), _mm256_mul_pd(self.s2, len2));
            let positive = _mm256_cmp_pd::<_CMP_GT_OQ>(w, _mm256_setzero_pd());
            Edges {
                certain: _mm256_movemask_pd(certain) as u8,
                positive: _mm256_movemask_pd(positive) as u8,
                normals: NormalLanes(e),
            }
        }
    }
}

/// The four lanes of `e` in three registers.
#[inline(always)]
fn splat3(e: DVec3) -> [__m256d; 3] {
    // SAFETY: see the module.
    unsafe {
        [
            _mm256_set1_pd(e.x),
            _mm256_set1_pd(e.y),
            _mm256_set1_pd(e.z),
        ]
    }
}

/// `DVec3::dot` of `d` with `e` lane by lane: the same products added in
/// the same order, `(d.x·e.x + d.y·e.y) + d.z·e.z`.
#[inline(always)]
fn dot4(d: &[__m256d; 3], e: &[__m256d; 3]) -> __m256d {
    // SAFETY: see the module.
    unsafe {
        _mm256_add_pd(
            _mm256_add_pd(_mm256_mul_pd(d[0], e[0]), _mm256_mul_pd(d[1], e[1])),
            _mm256_mul_pd(d[2], e[2]),
        )
    }
}

/// [`super::for_each_maximum`] four samples at a time (the same ordered
/// comparisons), so that only maxima cost a branch; the last few one at a
/// time.
#[inline]
pub(super) fn for_each_maximum(s: &[f64], thr: f64, mut f: impl FnMut(usize)) {
    let n = s.len();
    let mut i = 1;
    // SAFETY: see the module; while `i + 4 < n`, the loads read
    // `s[i − 1..i + 5]`, inside `s`.
    unsafe {
        let t = _mm256_set1_pd(thr);
        while i + 4 < n {
            let at = s.as_ptr().add(i);
            let v = _mm256_loadu_pd(at);
            let before = _mm256_loadu_pd(at.sub(1));
            let after = _mm256_loadu_pd(at.add(1));
            let up = _mm256_and_pd(
                _mm256_cmp_pd::<_CMP_GT_OQ>(v, t),
                _mm256_cmp_pd::<_CMP_GT_OQ>(v, before),
            );
            let mut mask =
                _mm256_movemask_pd(_mm256_and_pd(up, _mm256_cmp_pd::<_CMP_GE_OQ>(v, after))) as u32;
            while mask != 0 {
                f(i + mask.trailing_zeros() as usize);
                mask &= mask - 1;
            }
            i += 4;
        }
    }
    super::scalar::maxima_from(s, thr, i, f);
}

/// [`super::lowest_before_higher`] four samples at a time while none of
/// them is above `h`; the rest one at a time.
#[inline]
pub(super) fn lowest_before_higher(run: &[f64], h: f64, side: Side) -> (f64, bool) {
    let mut low = h;
    // The samples still to search: `run[..end]` before the maximum,
    // `run[start..]` after it.
    let (mut start, mut end) = (0, run.len());
    // SAFETY: see the module; each load reads four samples inside
    // `run[start..end]`.
    unsafe {
        let hv = _mm256_set1_pd(h);
        let mut lows = hv;
        while end - start >= 4 {
            let at = match side {
                Side::Before => end - 4,
                Side::After => start,
            };
            let v = _mm256_loadu_pd(run.as_ptr().add(at));
            let higher = _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_GT_OQ>(v, hv)) as u32;
            if higher != 0 {
                // The lanes between the maximum and the higher sample
                // nearest to it are left to the search one at a time,
                // which stops at that sample.
                break;
            }
            lows = _mm256_min_pd(lows, v);
            match side {
                Side::Before => end -= 4,
                Side::After => start += 4,
            }
        }
        let mut l = [0.0f64; 4];
        _mm256_storeu_pd(l.as_mut_ptr(), lows);
        for x in l {
            if x < low {
                low = x;
            }
        }
    }
    super::scalar::lowest_from(&run[start..end], h, low, side)
}

/// [`super::accumulate_depths`] in one register: the sums, their ordered
/// comparison with the thresholds, the kept depths blended in where it
/// holds.
#[inline(always)]
pub(super) fn accumulate_depths(
    depth: &mut [f32; LANES],
    level: &[f32; LANES],
    threshold: &[f32; LANES],
) -> u32 {
    // SAFETY: see the module; each load and the store cover one array of
    // `LANES` (eight) `f32`.
    unsafe {
        let d = _mm256_loadu_ps(depth.as_ptr());
        let sum = _mm256_add_ps(d, _mm256_loadu_ps(level.as_ptr()));
        let reached = _mm256_cmp_ps::<_CMP_GE_OQ>(sum, _mm256_loadu_ps(threshold.as_ptr()));
        _mm256_storeu_ps(depth.as_mut_ptr(), _mm256_blendv_ps(sum, d, reached));
        _mm256_movemask_ps(reached) as u32
    }
}

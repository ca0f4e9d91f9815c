//! The result of tracing a pulse: per sub-ray its closest hit and the
//! crown spans on its way.

use super::{Hit, VolumeSpan, bvh};
use crate::geometry::DVec3;

/// Closest hits and volume spans of all sub-rays of one pulse.
#[derive(Clone, Debug, Default)]
pub struct PulseTrace {
    /// Per sub-ray: its closest surface. Bundle traversals work in it
    /// directly, with a NaN normal until the end for surfaces other than
    /// triangles.
    pub(crate) hits: Vec<Nearest>,
    spans: Vec<VolumeSpan>,
    ranges: Vec<(u32, u32)>,
    /// Working storage of bundle traversals: volumes met by the bundle.
    pub(crate) volumes: Vec<u32>,
    /// Working storage of bundle traversals: the node stack.
    pub(crate) stack: Vec<bvh::Pending>,
}

/// A sub-ray's closest surface in a [`PulseTrace`] (so far, while a
/// traversal runs).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Nearest {
    /// Distance, m; the range limit while there is no hit.
    pub t: f64,
    /// The primitive, [`Nearest::NONE`] without a hit.
    prim: u32,
    /// Unit normal facing the ray (meaningful only for a hit).
    pub normal: DVec3,
}

impl Nearest {
    /// The primitive number of no hit (no scene holds `u32::MAX`
    /// primitives: their numbers are `u32` indices).
    const NONE: u32 = u32::MAX;

    /// No hit before `t`.
    #[inline]
    pub fn miss(t: f64) -> Self {
        Self {
            t,
            prim: Self::NONE,
            normal: DVec3::NAN,
        }
    }

    /// A hit on `prim` at `t` with `normal`.
    #[inline]
    pub fn hit(t: f64, prim: u32, normal: DVec3) -> Self {
        Self { t, prim, normal }
    }

    /// Forgets the hit, keeping the normal's storage: no hit before `t`.
    #[inline]
    pub fn reset(&mut self, t: f64) {
        self.t = t;
        self.prim = Self::NONE;
    }

    /// The primitive hit, if any.
    #[inline]
    pub fn prim(&self) -> Option<u32> {
        (self.prim != Self::NONE).then_some(self.prim)
    }

    /// True without a hit.
    #[inline]
    pub fn is_miss(&self) -> bool {
        self.prim == Self::NONE
    }
}

impl PulseTrace {
    /// Empties the trace for `n` sub-rays.
    pub fn clear(&mut self) {
        self.hits.clear();
        self.spans.clear();
        self.ranges.clear();
    }

    /// Records the result of the next sub-ray: its hit and the spans that
    /// [`crate::accel::RayCaster::trace`] left in `spans`.
    pub fn push(&mut self, hit: Option<Hit>, spans: &[VolumeSpan]) {
        self.push_spans(spans);
        self.hits.push(match hit {
            Some(h) => Nearest::hit(h.t, h.prim, h.normal),
            None => Nearest::miss(f64::INFINITY),
        });
    }

    /// Records the spans of the next sub-ray, whose hit the caller sets in
    /// `hits`.
    pub(crate) fn push_spans(&mut self, spans: &[VolumeSpan]) {
        let start = self.spans.len() as u32;
        self.spans.extend_from_slice(spans);
        self.ranges.push((start, self.spans.len() as u32));
    }

    /// Closest surface hit of sub-ray `i`.
    #[inline]
    pub fn hit(&self, i: usize) -> Option<Hit> {
        let h = self.hits[i];
        h.prim().map(|prim| Hit {
            t: h.t,
            prim,
            normal: h.normal,
        })
    }

    /// Distance to sub-ray `i`'s closest hit, infinite for a miss.
    #[inline]
    pub fn range(&self, i: usize) -> f64 {
        self.hits[i].t
    }

    /// The nearest and the farthest closest hit of the sub-rays (infinite
    /// for a miss).
    pub fn range_span(&self) -> (f64, f64) {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for h in &self.hits {
            // Comparisons rather than `f64::min`/`max`: ranges are never NaN.
            if h.t < lo {
                lo = h.t;
            }
            if h.t > hi {
                hi = h.t;
            }
        }
        (lo, hi)
    }

    /// True when no sub-ray has a volume span (no crown on its way).
    #[inline]
    pub fn has_no_spans(&self) -> bool {
        self.spans.is_empty()
    }

    /// Volume spans of sub-ray `i`, sorted by entry distance.
    pub fn spans_of(&self, i: usize) -> &[VolumeSpan] {
        match self.ranges.get(i) {
            Some(&(a, b)) => &self.spans[a as usize..b as usize],
            None => &[],
        }
    }
}

//! The result of tracing a pulse: per sub-ray its closest hit, the crowns
//! on the pulse's way, and the surfaces in the pulse's cone that no
//! sub-ray hit.

use super::{Hit, VolumeSpan, bvh};
use crate::geometry::DVec3;

/// Closest hits of all sub-rays of one pulse and the volumes (crowns) on
/// their way.
#[derive(Clone, Debug, Default)]
pub struct PulseTrace {
    /// Per sub-ray: its closest surface. Bundle traversals work in it
    /// directly, with a NaN normal until the end for surfaces other than
    /// triangles.
    pub(crate) hits: Vec<Nearest>,
    /// Every volume primitive some sub-ray may cross before its closest
    /// surface, each once: a superset of the crowns crossed (those whose
    /// bounds the traversal could not rule out), in no particular order.
    pub(crate) volumes: Vec<u32>,
    /// Every surface primitive the traversal found the cone of the
    /// sub-rays may meet but no sub-ray has as its closest hit, each once,
    /// in increasing order: a superset of those a ray within the cone
    /// meets before the farthest closest hit (bundle traversals only).
    pub(crate) unseen: Vec<u32>,
    /// Working storage of bundle traversals: the node stack.
    pub(crate) stack: Vec<bvh::Pending>,
    /// Working storage of ray-by-ray tracing: one sub-ray's spans.
    pub(crate) spans: Vec<VolumeSpan>,
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
}

impl PulseTrace {
    /// Empties the trace.
    pub fn clear(&mut self) {
        self.hits.clear();
        self.volumes.clear();
        self.unseen.clear();
    }

    /// Records the closest hit of the next sub-ray.
    pub fn push_hit(&mut self, hit: Option<Hit>) {
        self.hits.push(match hit {
            Some(h) => Nearest::hit(h.t, h.prim, h.normal),
            None => Nearest::miss(f64::INFINITY),
        });
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

    /// True when no sub-ray may cross a volume (no crown on any way).
    #[inline]
    pub fn has_no_volumes(&self) -> bool {
        self.volumes.is_empty()
    }

    /// The volume primitives some sub-ray may cross before its closest
    /// surface, each once (a superset of those crossed).
    pub fn volumes(&self) -> &[u32] {
        &self.volumes
    }

    /// The surfaces within the cone of the sub-rays that no sub-ray has as
    /// its closest hit, each once, in increasing order: a superset of the
    /// primitives that a ray within the cone (and within the sub-rays'
    /// direction bounds) meets nearer than the farthest closest hit, or
    /// anywhere in range when a sub-ray has no hit. Only a bundle
    /// traversal finds them ([`crate::accel::RayCaster::trace_pulse`] of a
    /// [`crate::accel::Bvh`], two sub-rays or more); tracing ray by ray
    /// leaves this empty.
    pub fn unseen(&self) -> &[u32] {
        &self.unseen
    }
}

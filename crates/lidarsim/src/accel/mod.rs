//! Acceleration structures: which surface does a ray meet first?
//!
//! The rest of the simulator sees only the [`RayCaster`] trait. It takes
//! whole pulses ([`RayCaster::trace_pulse`]) so that an implementation can
//! exploit the coherence of a pulse's sub-rays; the default implementation casts them one by one.
//!
//! Two implementations: [`Bvh`], a bounding-volume hierarchy built with the
//! surface-area heuristic (the default), and [`BruteForce`], which tests every
//! primitive and serves as the reference in tests.

mod bvh;

pub use bvh::{Bvh, BvhStats};

use crate::geometry::{DVec3, Ray};
use crate::scene::{Primitive, Scene};

/// The closest surface along a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance from the ray origin, m.
    pub t: f64,
    /// Index of the primitive in [`Scene::primitives`].
    pub prim: u32,
    /// Unit surface normal on the side facing the ray origin
    /// (specification: "If it is larger, the n is pointing in the wrong
    /// direction (and we need to choose [-a,-b,-c])").
    pub normal: DVec3,
}

/// The part of a ray inside the bounds of a volume primitive (a crown).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VolumeSpan {
    /// Index of the volume primitive.
    pub prim: u32,
    /// Where the ray enters the volume's bounds, m.
    pub t_in: f64,
    /// Where it leaves them (or meets the closest surface), m.
    pub t_out: f64,
}

/// Closest hits and volume spans of all sub-rays of one pulse.
#[derive(Clone, Debug, Default)]
pub struct PulseTrace {
    /// Per sub-ray: distance, primitive ([`NO_HIT`] for none) and unit
    /// normal facing the ray of its closest surface (meaningful only for a
    /// hit). Bundle traversals work in it directly, with a NaN normal until
    /// the end for surfaces other than triangles.
    pub(crate) hits: Vec<(f64, u32, DVec3)>,
    spans: Vec<VolumeSpan>,
    ranges: Vec<(u32, u32)>,
    /// Working storage of bundle traversals: volumes met by the bundle.
    pub(crate) volumes: Vec<u32>,
    /// Working storage of bundle traversals: the node stack.
    pub(crate) stack: Vec<bvh::Pending>,
}

/// The primitive number of a sub-ray without a hit in [`PulseTrace`].
pub(crate) const NO_HIT: u32 = u32::MAX;

impl PulseTrace {
    /// Empties the trace for `n` sub-rays.
    pub fn clear(&mut self) {
        self.hits.clear();
        self.spans.clear();
        self.ranges.clear();
    }

    /// Records the result of the next sub-ray: its hit and the spans that
    /// [`RayCaster::trace`] left in `spans`.
    pub fn push(&mut self, hit: Option<Hit>, spans: &[VolumeSpan]) {
        self.push_spans(spans);
        self.hits.push(match hit {
            Some(h) => (h.t, h.prim, h.normal),
            None => (f64::INFINITY, NO_HIT, DVec3::NAN),
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
        let (t, prim, normal) = self.hits[i];
        (prim != NO_HIT).then_some(Hit { t, prim, normal })
    }

    /// Distance to sub-ray `i`'s closest hit, infinite for a miss.
    #[inline]
    pub fn range(&self, i: usize) -> f64 {
        self.hits[i].0
    }

    /// The nearest and the farthest closest hit of the sub-rays (infinite
    /// for a miss).
    pub fn range_span(&self) -> (f64, f64) {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for h in &self.hits {
            // Comparisons rather than `f64::min`/`max`: ranges are never NaN.
            if h.0 < lo {
                lo = h.0;
            }
            if h.0 > hi {
                hi = h.0;
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

/// Answers closest-hit queries over a scene.
pub trait RayCaster: Send + Sync {
    /// The scene the structure was built over.
    fn scene(&self) -> &Scene;

    /// The closest surface hit within `(t_min, t_max)` whose primitive
    /// passes `accept` (for example: only ground surfaces). Volumes are
    /// passed through.
    fn closest_hit_where(
        &self,
        ray: &Ray,
        t_min: f64,
        t_max: f64,
        accept: &dyn Fn(&Primitive) -> bool,
    ) -> Option<Hit>;

    /// The closest surface hit within `(t_min, t_max)`.
    fn closest_hit(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
        self.closest_hit_where(ray, t_min, t_max, &|_| true)
    }

    /// The closest surface hit within `(t_min, t_max)`, and in `spans`
    /// (cleared first) every volume the ray passes before it, clipped to the
    /// hit and sorted by entry distance: the closest-first order in which
    /// the specification tests trees and surfaces.
    fn trace(&self, ray: &Ray, t_min: f64, t_max: f64, spans: &mut Vec<VolumeSpan>) -> Option<Hit>;

    /// [`RayCaster::trace`] for all sub-rays of one pulse, which share
    /// `origin`; results in `out` (cleared first), in the order of `dirs`.
    fn trace_pulse(
        &self,
        origin: DVec3,
        dirs: &[DVec3],
        t_min: f64,
        t_max: f64,
        spans: &mut Vec<VolumeSpan>,
        out: &mut PulseTrace,
    ) {
        self.trace_each(origin, dirs, t_min, t_max, spans, out);
    }

    /// [`RayCaster::trace_pulse`] by tracing each sub-ray on its own (the
    /// default, and the fallback of structures with a faster bundle path).
    fn trace_each(
        &self,
        origin: DVec3,
        dirs: &[DVec3],
        t_min: f64,
        t_max: f64,
        spans: &mut Vec<VolumeSpan>,
        out: &mut PulseTrace,
    ) {
        out.clear();
        for dir in dirs {
            let hit = self.trace(&Ray { origin, dir: *dir }, t_min, t_max, spans);
            out.push(hit, spans);
        }
    }
}

/// Builds the hit record for primitive `prim` at distance `t`, with the
/// surface normal turned towards the ray origin.
#[inline]
pub(crate) fn make_hit(scene: &Scene, prim: u32, ray: &Ray, t: f64) -> Hit {
    let n = scene.primitives[prim as usize].normal_at(ray.at(t));
    let normal = if n.dot(ray.dir) > 0.0 { -n } else { n };
    Hit { t, prim, normal }
}

/// Keeps the spans that begin before `t_hit`, clipped to it, in order of
/// entry.
pub(crate) fn finish_spans(spans: &mut Vec<VolumeSpan>, t_hit: f64) {
    spans.retain_mut(|s| {
        s.t_out = s.t_out.min(t_hit);
        s.t_in < s.t_out
    });
    spans.sort_by(|a, b| a.t_in.total_cmp(&b.t_in).then(a.prim.cmp(&b.prim)));
}

/// The span of a volume primitive along a ray, if any.
#[inline]
pub(crate) fn volume_span(
    prim: &Primitive,
    index: u32,
    ray: &Ray,
    t_min: f64,
    t_max: f64,
) -> Option<VolumeSpan> {
    match &prim.shape {
        crate::scene::Shape::Crown(c) => {
            c.span(ray, t_min, t_max).map(|(t_in, t_out)| VolumeSpan {
                prim: index,
                t_in,
                t_out,
            })
        }
        _ => None,
    }
}

/// Height of the ground below `p` (ground, road or water surfaces; any
/// surface if none of those lies below; `z = 0` if nothing does).
pub fn ground_below(caster: &dyn RayCaster, p: DVec3) -> f64 {
    let ray = Ray {
        origin: p,
        dir: -DVec3::Z,
    };
    let ground = |prim: &crate::scene::Primitive| prim.class.is_ground();
    caster
        .closest_hit_where(&ray, 0.0, f64::INFINITY, &ground)
        .or_else(|| caster.closest_hit(&ray, 0.0, f64::INFINITY))
        .map_or(0.0, |h| p.z - h.t)
}

/// Tests every primitive: slow, obviously correct, used as the reference.
#[derive(Debug)]
pub struct BruteForce {
    scene: Scene,
}

impl BruteForce {
    /// Wraps a scene.
    pub fn new(scene: Scene) -> Self {
        Self { scene }
    }
}

impl RayCaster for BruteForce {
    fn scene(&self) -> &Scene {
        &self.scene
    }

    fn closest_hit_where(
        &self,
        ray: &Ray,
        t_min: f64,
        t_max: f64,
        accept: &dyn Fn(&Primitive) -> bool,
    ) -> Option<Hit> {
        let mut best: Option<(f64, u32)> = None;
        for (i, p) in self.scene.primitives.iter().enumerate() {
            let limit = best.map_or(t_max, |b| b.0);
            if let Some(t) = p.intersect(ray, t_min, limit)
                && accept(p)
            {
                best = Some((t, i as u32));
            }
        }
        best.map(|(t, i)| make_hit(&self.scene, i, ray, t))
    }

    fn trace(&self, ray: &Ray, t_min: f64, t_max: f64, spans: &mut Vec<VolumeSpan>) -> Option<Hit> {
        let hit = self.closest_hit(ray, t_min, t_max);
        spans.clear();
        for (i, p) in self.scene.primitives.iter().enumerate() {
            if let Some(s) = volume_span(p, i as u32, ray, t_min, t_max) {
                spans.push(s);
            }
        }
        finish_spans(spans, hit.map_or(t_max, |h| h.t));
        hit
    }
}

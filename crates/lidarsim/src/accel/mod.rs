//! Acceleration structures: which surface does a ray meet first?
//!
//! The rest of the simulator sees only the [`RayCaster`] trait. It takes
//! whole pulses ([`RayCaster::trace_pulse`]) so that an implementation can
//! exploit the coherence of a pulse's sub-rays; the default implementation casts them one by one.
//!
//! Two implementations: [`Bvh`], a bounding-volume hierarchy built with the
//! surface-area heuristic (the default), and [`BruteForce`], which tests every
//! primitive and serves as the reference in tests.

mod brute;
mod bvh;
mod trace;

pub use brute::BruteForce;
pub use bvh::{Bvh, BvhStats};
pub(crate) use trace::Nearest;
pub use trace::PulseTrace;

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

    /// The closest hits of all sub-rays of one pulse, which share
    /// `origin`, in `out` (cleared first) in the order of `dirs`, with the
    /// volumes their ways may cross ([`PulseTrace::volumes`]; each
    /// sub-ray's spans through them are [`spans_along`] its way).
    fn trace_pulse(
        &self,
        origin: DVec3,
        dirs: &[DVec3],
        t_min: f64,
        t_max: f64,
        out: &mut PulseTrace,
    ) {
        self.trace_each(origin, dirs, t_min, t_max, out);
    }

    /// [`RayCaster::trace_pulse`] by tracing each sub-ray on its own (the
    /// default, and the fallback of structures with a faster bundle path):
    /// the volumes are those the sub-rays cross.
    fn trace_each(
        &self,
        origin: DVec3,
        dirs: &[DVec3],
        t_min: f64,
        t_max: f64,
        out: &mut PulseTrace,
    ) {
        out.clear();
        let mut spans = std::mem::take(&mut out.spans);
        for dir in dirs {
            let hit = self.trace(&Ray { origin, dir: *dir }, t_min, t_max, &mut spans);
            out.push_hit(hit);
            out.volumes.extend(spans.iter().map(|s| s.prim));
        }
        out.volumes.sort_unstable();
        out.volumes.dedup();
        out.spans = spans;
    }
}

/// The spans of `ray` through those of `volumes` it crosses within
/// `(t_min, t_hit)`, into `out` (cleared first): clipped to `t_hit` and
/// sorted by entry, as [`RayCaster::trace`] gives them when `volumes` holds
/// every volume the ray crosses.
pub fn spans_along(
    scene: &Scene,
    volumes: &[u32],
    ray: &Ray,
    t_min: f64,
    t_hit: f64,
    out: &mut Vec<VolumeSpan>,
) {
    out.clear();
    for &v in volumes {
        if let Some(s) = volume_span(&scene.primitives[v as usize], v, ray, t_min, t_hit) {
            out.push(s);
        }
    }
    finish_spans(out, t_hit);
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

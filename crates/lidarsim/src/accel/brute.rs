//! The reference ray caster: every primitive tested for every ray.

use super::{Hit, RayCaster, VolumeSpan, finish_spans, make_hit, volume_span};
use crate::geometry::Ray;
use crate::scene::{Primitive, Scene};

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

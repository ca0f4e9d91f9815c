//! Acceleration structures: which surface does a ray meet first?
//!
//! The rest of the simulator sees only the [`RayCaster`] trait. It takes
//! whole pulses ([`RayCaster::cast_pulse`]) so that an implementation can
//! exploit the coherence of a pulse's sub-rays (DESIGN.md, "Performance
//! stance"); the default implementation casts them one by one.
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

/// Answers closest-hit queries over a scene.
pub trait RayCaster: Send + Sync {
    /// The scene the structure was built over.
    fn scene(&self) -> &Scene;

    /// The closest primitive hit within `(t_min, t_max)` whose primitive
    /// passes `accept` (for example: only ground surfaces).
    fn closest_hit_where(
        &self,
        ray: &Ray,
        t_min: f64,
        t_max: f64,
        accept: &dyn Fn(&Primitive) -> bool,
    ) -> Option<Hit>;

    /// The closest primitive hit within `(t_min, t_max)`.
    fn closest_hit(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<Hit> {
        self.closest_hit_where(ray, t_min, t_max, &|_| true)
    }

    /// Closest hits of all sub-rays of one pulse, which share `origin`.
    /// `hits[i]` receives the hit of `dirs[i]` (unit vectors).
    fn cast_pulse(
        &self,
        origin: DVec3,
        dirs: &[DVec3],
        t_min: f64,
        t_max: f64,
        hits: &mut [Option<Hit>],
    ) {
        for (dir, hit) in dirs.iter().zip(hits.iter_mut()) {
            *hit = self.closest_hit(&Ray { origin, dir: *dir }, t_min, t_max);
        }
    }
}

/// Builds the hit record for primitive `prim` at distance `t`.
#[inline]
pub(crate) fn make_hit(scene: &Scene, prim: u32, ray: &Ray, t: f64) -> Hit {
    let n = scene.primitives[prim as usize].normal();
    let normal = if n.dot(ray.dir) > 0.0 { -n } else { n };
    Hit { t, prim, normal }
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
}

//! A pulse through the hierarchy at once: the sub-rays share their origin
//! and lie within a narrow cone, so the hierarchy is traversed once for the
//! whole bundle (a node is visited when any direction within the bundle's
//! per-axis direction bounds can meet its box, eight boxes per kernel call)
//! and every sub-ray is tested exactly, in `f64`, against the primitives of
//! the leaves reached; a triangle the whole cone misses costs only its
//! edge planes, one it covers skips the per-ray edge tests. The answers
//! are those of [`crate::accel::RayCaster::trace`] for each sub-ray.
//!
//! A surface that the cone may meet (its triangle's edge planes, its
//! stem's bounding cylinder or its box do not rule the cone out) but that
//! no sub-ray records, or that loses every sub-ray it recorded to a nearer
//! one, is kept as unseen ([`PulseTrace::unseen`]): a target between the
//! sub-rays, which the simulator samples finely. A flat scene whose
//! sub-rays all meet one surface keeps none, at the cost of a test.

use super::ray::nearest_on_top;
use super::{Bvh, Pending};
use crate::accel::{Nearest, PulseTrace};
use crate::geometry::{DVec3, Ray};
use crate::kernels::{BundleSlabs, DirectionBounds, EdgeCone, Sign, direction_bounds};
use crate::scene::{Coverage, EdgeTest, Shape, Straddle, Triangle, TriangleFan, bundle_cone};

impl Bvh {
    /// [`RayCaster::trace_pulse`] for two sub-rays or more over a hierarchy
    /// that is not empty.
    pub(super) fn trace_bundle(
        &self,
        origin: DVec3,
        dirs: &[DVec3],
        t_min: f64,
        t_max: f64,
        out: &mut PulseTrace,
    ) {
        // The previous pulse's hits are reset in place, distance and
        // primitive only: the normal is read only for a hit, and every hit
        // recorded writes it (NaN for surfaces other than triangles,
        // filled in at the end).
        let mut best = std::mem::take(&mut out.hits);
        out.clear();
        let (bundle, sum) = bundle(origin - self.origin, dirs);
        let (axis, spread) = bundle_cone(dirs, sum);
        let cone = EdgeCone::new(origin, axis, spread);
        let mut volumes = std::mem::take(&mut out.volumes);
        let mut unseen = std::mem::take(&mut out.unseen);
        best.resize(dirs.len(), Nearest::miss(t_max));
        for b in &mut best {
            b.reset(t_max);
        }
        volumes.clear();
        unseen.clear();
        let mut missing = dirs.len();
        // Whether a hit on a primitive other than a triangle (recorded
        // without its normal) was ever recorded.
        let mut normals_missing = false;
        let mut far = t_max;
        let slack = |t: f64| (t + self.pad) as f32 * (1.0 + 1e-6);
        // The traversal stack lives in the trace: sized once, never cleared
        // (every entry is written before it is read).
        let mut stack = std::mem::take(&mut out.stack);
        if stack.len() < self.stack_len {
            stack.resize(self.stack_len, Pending::default());
        }
        let mut sp = 0usize;
        // The root: an interior node.
        let (mut child, mut count) = (0u32, 0u32);
        'visit: loop {
            if count > 0 {
                let first = child as usize;
                for (p, prim) in
                    (child..).zip(&self.scene.primitives[first..first + count as usize])
                {
                    if prim.is_volume() {
                        volumes.push(p);
                        continue;
                    }
                    if let Shape::Triangle(tri) = &prim.shape {
                        missing -=
                            bundle_triangle(tri, p, dirs, &cone, t_min, &mut best, &mut unseen);
                        continue;
                    }
                    let (first, normal_less) = bundle_other(
                        prim,
                        p,
                        (origin, axis, spread),
                        dirs,
                        (t_min, far),
                        &mut best,
                        &mut unseen,
                    );
                    missing -= first;
                    normals_missing |= normal_less;
                }
                if missing == 0 {
                    far = best
                        .iter()
                        .fold(0.0f64, |m, b| if b.t > m { b.t } else { m });
                }
            } else {
                let n = &self.nodes[child as usize];
                let (mask, t) = bundle.enters(&n.planes, slack(far));
                // One child entered (the usual case on the way down): to
                // it directly, by a branch per slot, so that the processor
                // can run ahead into it.
                let only = match mask {
                    0b0000_0001 => Some(0),
                    0b0000_0010 => Some(1),
                    0b0000_0100 => Some(2),
                    0b0000_1000 => Some(3),
                    0b0001_0000 => Some(4),
                    0b0010_0000 => Some(5),
                    0b0100_0000 => Some(6),
                    0b1000_0000 => Some(7),
                    _ => None,
                };
                if let Some(slot) = only {
                    (child, count) = (n.child[slot], n.count[slot]);
                    continue 'visit;
                }
                // Two: the farther waits on the stack.
                if mask.count_ones() == 2 {
                    let i = mask.trailing_zeros() as usize;
                    let j = (mask & (mask - 1)).trailing_zeros() as usize;
                    let (near, farther) = if t[i] <= t[j] { (i, j) } else { (j, i) };
                    stack[sp] = Pending {
                        t: t[farther],
                        child: n.child[farther],
                        count: n.count[farther],
                    };
                    sp += 1;
                    (child, count) = (n.child[near], n.count[near]);
                    continue 'visit;
                }
                let base = sp;
                for (slot, &t) in t.iter().enumerate() {
                    if mask & (1 << slot) != 0 {
                        stack[sp] = Pending {
                            t,
                            child: n.child[slot],
                            count: n.count[slot],
                        };
                        sp += 1;
                    }
                }
                nearest_on_top(&mut stack[base..sp]);
            }
            while sp > 0 {
                sp -= 1;
                let next = stack[sp];
                if next.t <= slack(far) {
                    (child, count) = (next.child, next.count);
                    continue 'visit;
                }
            }
            break;
        }
        out.stack = stack;
        if normals_missing {
            self.fill_normals(origin, dirs, &mut best);
        }
        if !volumes.is_empty() {
            let cone = (axis, spread);
            self.keep_volumes_reached(origin, cone, t_min, &best, &mut volumes);
        }
        // The unseen: each once, none that some sub-ray hit in the end.
        if !unseen.is_empty() {
            unseen.sort_unstable();
            unseen.dedup();
            unseen.retain(|&p| best.iter().all(|b| b.prim() != Some(p)));
        }
        out.hits = best;
        out.volumes = volumes;
        out.unseen = unseen;
    }

    /// The normals of the hits recorded without one, facing the ray.
    /// Triangle hits carry their normal, already facing the ray, from the
    /// test; other sub-rays mostly hit the same flat primitive, whose
    /// normal is computed once.
    fn fill_normals(&self, origin: DVec3, dirs: &[DVec3], best: &mut [Nearest]) {
        let mut flat: Option<(u32, DVec3)> = None;
        for (dir, b) in dirs.iter().zip(best.iter_mut()) {
            let Some(p) = b.prim() else {
                continue;
            };
            if !b.normal.x.is_nan() {
                continue;
            }
            let n = match flat {
                Some((q, n)) if q == p => n,
                _ => {
                    let prim = &self.scene.primitives[p as usize];
                    let n = prim.normal_at(origin + *dir * b.t);
                    if prim.is_flat() {
                        flat = Some((p, n));
                    }
                    n
                }
            };
            b.normal = if n.dot(*dir) > 0.0 { -n } else { n };
        }
    }

    /// Keeps of `volumes` those the bundle (the cone of `(axis, spread)`
    /// from `origin`) may cross before its farthest hit in `best`.
    fn keep_volumes_reached(
        &self,
        origin: DVec3,
        (axis, spread): (DVec3, f64),
        t_min: f64,
        best: &[Nearest],
        volumes: &mut Vec<u32>,
    ) {
        let t_far = best
            .iter()
            .fold(t_min, |m, b| if b.t > m { b.t } else { m });
        let prims = &self.scene.primitives;
        volumes.retain(|&v| {
            prims[v as usize]
                .bounds_cylinder()
                .is_none_or(|c| c.may_meet_cone(origin, axis, spread, t_min, t_far))
        });
    }
}

/// Records primitive `p` (not a triangle nor a volume) for every ray of
/// `dirs` that meets it nearer than its best so far, within `(t_min,
/// far)`: a stem the whole cone from `origin` of `(axis, spread)` misses
/// costs one test.
/// The primitives whose records it takes go to `unseen`, and `p` itself
/// when it records none but the cone may meet it (a stem within its
/// cylinder's test, another surface within its box's). Returns how many
/// rays got their first hit, and whether it recorded any (without its
/// normal).
#[inline]
fn bundle_other(
    prim: &crate::scene::Primitive,
    p: u32,
    (origin, axis, spread): (DVec3, DVec3, f64),
    dirs: &[DVec3],
    (t_min, far): (f64, f64),
    best: &mut [Nearest],
    unseen: &mut Vec<u32>,
) -> (usize, bool) {
    let cylinder = prim.bounds_cylinder();
    if let Some(c) = cylinder
        && !c.may_meet_cone(origin, axis, spread, t_min, far)
    {
        return (0, false);
    }
    let (mut first, mut recorded) = (0, false);
    for (dir, b) in dirs.iter().zip(best.iter_mut()) {
        let ray = Ray { origin, dir: *dir };
        if let Some(t) = prim.intersect(&ray, t_min, b.t) {
            match b.prim() {
                Some(q) => unseen.push(q),
                None => first += 1,
            }
            *b = Nearest::hit(t, p, DVec3::NAN);
            recorded = true;
        }
    }
    if !recorded
        && (cylinder.is_some()
            || prim
                .bounds()
                .cone_interval(origin, axis, spread, t_min, far)
                .is_some())
    {
        unseen.push(p);
    }
    (first, recorded)
}

/// The fan of `tri` from the cone's origin with its edge planes only
/// ([`TriangleFan::edges`]) and what its coverage leaves to test per ray
/// (`None`: every ray passes the edge tests), unless the cone misses the
/// triangle: [`TriangleFan::coverage`] by the edge-plane kernel.
#[inline(always)]
pub(super) fn fan(cone: &EdgeCone, tri: &Triangle) -> Option<(TriangleFan, Option<Straddle>)> {
    let corners = tri.vertices();
    let edges = cone.edges(corners);
    let straddle = match Coverage::of_edges(edges.certain, edges.positive) {
        Coverage::None => return None,
        Coverage::All => None,
        Coverage::Some(straddle) => Some(straddle),
    };
    let fan = TriangleFan::from_edges(edges.normals(), corners[0] - cone.origin);
    Some((fan, straddle))
}

/// Tests all rays of a bundle against one triangle (the arithmetic of
/// [`Triangle::intersect`], its per-origin part done once), updating `best`
/// where the triangle is closer; returns how many rays got their first
/// hit. `cone` is the bundle's origin, axis and
/// spread: a triangle the whole bundle misses costs only its edge planes,
/// one it covers skips the per-ray edge tests, and for one it straddles
/// each ray is tested on the straddled edges only. A triangle the cone may
/// meet but no ray records goes to `unseen`, as does every primitive a
/// ray's record is taken from.
#[inline]
fn bundle_triangle(
    tri: &Triangle,
    p: u32,
    dirs: &[DVec3],
    cone: &EdgeCone,
    t_min: f64,
    best: &mut [Nearest],
    unseen: &mut Vec<u32>,
) -> usize {
    let Some((mut fan, straddle)) = fan(cone, tri) else {
        return 0;
    };
    fan.complete(tri);
    // One loop per kind of test, so that each runs without deciding again.
    let f = &fan;
    let u = unseen;
    match straddle.map(|s| fan.edge_test(s)) {
        None => record_hits(f, p, dirs, t_min, best, u, &|_| true),
        Some(EdgeTest::One(a)) => record_hits(f, p, dirs, t_min, best, u, &|d| d.dot(a) >= 0.0),
        Some(EdgeTest::Two(a, b)) => record_hits(f, p, dirs, t_min, best, u, &|d| {
            d.dot(a) >= 0.0 && d.dot(b) >= 0.0
        }),
        Some(EdgeTest::Three) => record_hits(f, p, dirs, t_min, best, u, &|d| f.passes(d)),
    }
}

/// Records `fan`'s triangle `p` for every ray that `passes` and meets it
/// closer than its best so far; returns how many rays got their first hit.
/// The primitives whose records it takes go to `unseen`, and `p` itself
/// when it records none.
#[inline(always)]
fn record_hits(
    fan: &TriangleFan,
    p: u32,
    dirs: &[DVec3],
    t_min: f64,
    best: &mut [Nearest],
    unseen: &mut Vec<u32>,
    passes: &impl Fn(DVec3) -> bool,
) -> usize {
    let mut first = 0;
    let mut recorded = false;
    for (d, slot) in dirs.iter().zip(best.iter_mut()) {
        if !passes(*d) {
            continue;
        }
        if let Some((t, normal)) = fan.hit(*d, t_min, slot.t) {
            match slot.prim() {
                Some(q) => unseen.push(q),
                None => first += 1,
            }
            *slot = Nearest::hit(t, p, normal);
            recorded = true;
        }
    }
    if !recorded {
        unseen.push(p);
    }
    first
}

/// The sub-rays of a pulse as one bundle for the box tests: their origin
/// relative to the hierarchy's origin and, per axis, the sign and the
/// reciprocal bounds of their direction components (widened a little so
/// that f32 rounding stays on the conservative side); and the sum of the
/// directions.
pub(super) fn bundle(o: DVec3, dirs: &[DVec3]) -> (BundleSlabs, DVec3) {
    let DirectionBounds { lo, hi, sum } = direction_bounds(dirs);
    let mut sign = [Sign::Straddles; 3];
    let mut inv_lo = [0.0f32; 3];
    let mut inv_hi = [0.0f32; 3];
    for a in 0..3 {
        let (l, h) = (lo[a] - 1e-6, hi[a] + 1e-6);
        let (l, h) = if l > 0.0 {
            sign[a] = Sign::Positive;
            (l, h)
        } else if h < 0.0 {
            sign[a] = Sign::Negative;
            (l, h)
        } else {
            (l.min(-1e-12), h.max(1e-12))
        };
        inv_lo[a] = (1.0 / l) as f32;
        inv_hi[a] = (1.0 / h) as f32;
    }
    let o = [o.x as f32, o.y as f32, o.z as f32];
    (BundleSlabs::new(o, sign, inv_lo, inv_hi), sum)
}

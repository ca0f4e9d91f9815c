//! One ray through the hierarchy: closest-first, nearest child on top of
//! the stack, f32 box tests, exact f64 primitive tests.

use super::{Bvh, Pending, STACK, WIDTH, WideNode};
use crate::accel::{Hit, VolumeSpan, finish_spans, make_hit, volume_span};
use crate::geometry::Ray;
use crate::scene::Primitive;

impl Bvh {
    /// Closest-first traversal: the closest accepted surface within
    /// `(t_min, t_max)`, and, when `spans` is given, the volumes whose
    /// bounds the ray enters before the closest surface.
    pub(super) fn traverse(
        &self,
        ray: &Ray,
        t_min: f64,
        t_max: f64,
        accept: &dyn Fn(&Primitive) -> bool,
        mut spans: Option<&mut Vec<VolumeSpan>>,
    ) -> Option<Hit> {
        if let Some(s) = spans.as_deref_mut() {
            s.clear();
        }
        if self.nodes.is_empty() {
            return None;
        }
        let o = ray.origin - self.origin;
        let o = [o.x as f32, o.y as f32, o.z as f32];
        let inv = [inv(ray.dir.x), inv(ray.dir.y), inv(ray.dir.z)];
        let mut best_t = t_max;
        let mut best: Option<u32> = None;
        let mut small = [Pending::default(); STACK];
        let mut big = Vec::new();
        let stack: &mut [Pending] = if self.stack_len <= STACK {
            &mut small
        } else {
            big.resize(self.stack_len, Pending::default());
            &mut big
        };
        let mut sp = 0usize;
        // The root: an interior node.
        let (mut child, mut count) = (0u32, 0u32);
        let slack = |t: f64| (t + self.pad) as f32 * (1.0 + 1e-6);
        loop {
            if count > 0 {
                let first = child as usize;
                for (p, prim) in
                    (child..).zip(&self.scene.primitives[first..first + count as usize])
                {
                    if prim.is_volume() {
                        if let Some(s) = spans.as_deref_mut()
                            && let Some(v) = volume_span(prim, p, ray, t_min, best_t)
                        {
                            s.push(v);
                        }
                    } else if let Some(t) = prim.intersect(ray, t_min, best_t)
                        && accept(prim)
                    {
                        best_t = t;
                        best = Some(p);
                    }
                }
            } else {
                let n = &self.nodes[child as usize];
                let limit = slack(best_t);
                let base = sp;
                for slot in 0..WIDTH {
                    if let Some(t) = slab(n, slot, &o, &inv, limit) {
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
            // Pop the next child still worth visiting.
            loop {
                if sp == 0 {
                    if let Some(s) = spans {
                        finish_spans(s, best_t);
                    }
                    return best.map(|p| make_hit(&self.scene, p, ray, best_t));
                }
                sp -= 1;
                let next = stack[sp];
                if next.t <= slack(best_t) {
                    (child, count) = (next.child, next.count);
                    break;
                }
            }
        }
    }
}

/// Orders the children just pushed on a traversal stack so that the
/// nearest is on top (last), the lower slot above among equally near ones.
/// A child popped later is visited only if its entry distance is still
/// within the closest hit: its box test then passes, as its exit was beyond
/// its entry when it was pushed.
#[inline]
pub(super) fn nearest_on_top(run: &mut [Pending]) {
    for i in 1..run.len() {
        let e = run[i];
        let mut j = i;
        while j > 0 && run[j - 1].t <= e.t {
            run[j] = run[j - 1];
            j -= 1;
        }
        run[j] = e;
    }
}

#[inline]
fn inv(d: f64) -> f32 {
    if d.abs() < 1e-20 {
        1e20f32.copysign(d as f32)
    } else {
        (1.0 / d) as f32
    }
}

/// Entry distance of the ray into the box of `slot` of `n` if it enters
/// before `t_max` (per axis the near plane by the sign of the reciprocal
/// direction, so that an empty box is entered by no ray).
#[inline]
fn slab(n: &WideNode, slot: usize, o: &[f32; 3], inv: &[f32; 3], t_max: f32) -> Option<f32> {
    let mut t0 = 0.0f32;
    let mut t1 = t_max;
    for a in 0..3 {
        let (near, far) = if inv[a] >= 0.0 {
            (n.planes[a][slot], n.planes[3 + a][slot])
        } else {
            (n.planes[3 + a][slot], n.planes[a][slot])
        };
        t0 = t0.max((near - o[a]) * inv[a]);
        t1 = t1.min((far - o[a]) * inv[a]);
    }
    (t0 <= t1).then_some(t0)
}

//! Bounding-volume hierarchy with the binned surface-area heuristic
//! (MacDonald & Booth 1990; Wald 2007, "On fast construction of SAH-based
//! bounding volume hierarchies").
//!
//! Nodes live in one flat array. Their boxes are `f32`, relative to a scene
//! origin, rounded outwards and padded so that they always contain the
//! `f64` primitives: a box test may let through a primitive that the exact
//! `f64` test then rejects, never the reverse.

mod build;
mod bundle;
mod collapse;
mod ray;

use build::stack_len;

use super::{Hit, PulseTrace, RayCaster, VolumeSpan};
use crate::geometry::{Aabb, DVec3, Ray};
use crate::kernels::{Boxes, LANES};
use crate::scene::{Primitive, Scene};

const MAX_LEAF: usize = 4;
/// Children of a node of the traversal hierarchy: one per lane of the box
/// test kernel.
const WIDTH: usize = LANES;
const BINS: usize = 16;
const STACK: usize = 96;
/// Levels of the hierarchy whose two halves are built in parallel.
const PARALLEL_DEPTH: usize = 4;
/// Smallest subtree worth a parallel split.
const PARALLEL_MIN: usize = 20_000;

#[derive(Clone, Copy, Debug)]
#[repr(C)]
struct Node {
    min: [f32; 3],
    /// Interior: index of the left child (the right one follows it).
    /// Leaf: position of its first primitive in the build order (its
    /// index once the scene's primitives are put in that order).
    left_or_first: u32,
    max: [f32; 3],
    /// 0 for an interior node, else the number of primitives.
    count: u32,
}

/// An interior node of the eight-wide hierarchy that the traversals use
/// (collapsed from the binary one the build makes): the boxes of up to
/// [`WIDTH`] children as structure of arrays, so that one AVX operation
/// tests one axis of all of them (a wide hierarchy is shallower: fewer
/// nodes, each loaded only after its parent's test, on the way to a leaf).
/// An unused slot holds an empty box (lower bound +∞, upper −∞), which no
/// box test enters.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct WideNode {
    /// The box planes, `planes[row][slot]`: rows 0–2 the lower bounds on
    /// x, y, z, rows 3–5 the upper ones.
    planes: Boxes,
    /// Interior child: its index in the node array. Leaf: the index of its
    /// first primitive (the scene's primitives are in leaf order).
    child: [u32; WIDTH],
    /// 0 for an interior child (or an unused slot), else the number of
    /// primitives of the leaf.
    count: [u32; WIDTH],
}

impl WideNode {
    /// No children: every slot empty.
    const EMPTY: Self = Self {
        planes: [
            [f32::INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
        ],
        child: [0; WIDTH],
        count: [0; WIDTH],
    };
}

/// A child waiting on a traversal stack: the distance at which the ray or
/// bundle enters its box, and the child as its parent's slot names it.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Pending {
    t: f32,
    child: u32,
    count: u32,
}

/// Size figures of a built hierarchy.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BvhStats {
    /// Number of (eight-wide) interior nodes.
    pub nodes: usize,
    /// Number of leaves.
    pub leaves: usize,
    /// Interior nodes on the longest path from the root to a leaf.
    pub max_depth: usize,
}

/// A bounding-volume hierarchy over all primitives of a scene.
#[derive(Debug)]
pub struct Bvh {
    scene: Scene,
    /// Eight-wide interior nodes; the root is the first.
    nodes: Vec<WideNode>,
    /// Traversal stack entries that the deepest path can need.
    stack_len: usize,
    origin: DVec3,
    /// Absolute padding of node boxes, m.
    pad: f64,
    /// The scene's exact bounds ([`Scene::bounds`]).
    bounds: Aabb,
}

impl Bvh {
    /// The scene's bounding box, [`Scene::bounds`] without a pass over its
    /// primitives (kept from the build).
    pub fn scene_bounds(&self) -> Aabb {
        self.bounds
    }

    /// Node count, leaf count and depth.
    pub fn stats(&self) -> BvhStats {
        let mut s = BvhStats {
            nodes: self.nodes.len(),
            leaves: 0,
            max_depth: 0,
        };
        if self.nodes.is_empty() {
            return s;
        }
        let mut stack = vec![(0usize, 1usize)];
        while let Some((i, d)) = stack.pop() {
            s.max_depth = s.max_depth.max(d);
            let n = &self.nodes[i];
            for slot in 0..WIDTH {
                if n.count[slot] > 0 {
                    s.leaves += 1;
                } else if n.planes[0][slot] <= n.planes[3][slot] {
                    stack.push((n.child[slot] as usize, d + 1));
                }
            }
        }
        s
    }

    /// Checks the structural invariants: every primitive in exactly one
    /// leaf, every primitive's box inside all boxes on its path, every node
    /// reached once, the stack deep enough. Returns a description of the
    /// first violation.
    pub fn validate(&self) -> Result<(), String> {
        let n = self.scene.primitives.len();
        let mut seen = vec![0u32; n];
        if self.nodes.is_empty() {
            return if n == 0 {
                Ok(())
            } else {
                Err("no nodes".into())
            };
        }
        let mut reached = vec![0u32; self.nodes.len()];
        // (node, the boxes of its ancestors' slots on the path to it)
        let mut stack = vec![(0usize, Vec::<Aabb>::new())];
        while let Some((i, path)) = stack.pop() {
            reached[i] += 1;
            if stack_len(path.len() + 1) > self.stack_len {
                return Err(format!("node {i} is deeper than the traversal stack"));
            }
            let node = self.nodes[i];
            for slot in 0..WIDTH {
                let lo = [0, 1, 2].map(|a| node.planes[a][slot] as f64);
                let hi = [0, 1, 2].map(|a| node.planes[3 + a][slot] as f64);
                if lo[0] > hi[0] {
                    if node.count[slot] > 0 {
                        return Err(format!("empty slot {slot} of node {i} holds a leaf"));
                    }
                    continue;
                }
                let slot_box = Aabb {
                    min: DVec3::from(lo) + self.origin,
                    max: DVec3::from(hi) + self.origin,
                };
                let mut path = path.clone();
                path.push(slot_box);
                if node.count[slot] == 0 {
                    let c = node.child[slot] as usize;
                    if c == 0 || c >= self.nodes.len() {
                        return Err(format!("node {i} names node {c}"));
                    }
                    stack.push((c, path));
                    continue;
                }
                let first = node.child[slot] as usize;
                let leaf = first..first + node.count[slot] as usize;
                if leaf.end > n {
                    return Err(format!("leaf in node {i} runs past the primitives"));
                }
                for p in leaf {
                    let b = self.scene.primitives[p].bounds();
                    if let Some(k) = path
                        .iter()
                        .position(|pb| !(pb.contains(b.min, 0.0) && pb.contains(b.max, 0.0)))
                    {
                        return Err(format!(
                            "primitive {p} sticks out of the box of its ancestor at depth {}",
                            k + 1
                        ));
                    }
                    seen[p] += 1;
                }
            }
        }
        if let Some(i) = reached.iter().position(|&c| c != 1) {
            return Err(format!("node {i} is reached {} times", reached[i]));
        }
        match seen.iter().position(|&c| c != 1) {
            Some(p) => Err(format!("primitive {p} is in {} leaves", seen[p])),
            None => Ok(()),
        }
    }
}

impl RayCaster for Bvh {
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
        self.traverse(ray, t_min, t_max, accept, None)
    }

    fn trace(&self, ray: &Ray, t_min: f64, t_max: f64, spans: &mut Vec<VolumeSpan>) -> Option<Hit> {
        self.traverse(ray, t_min, t_max, &|_| true, Some(spans))
    }

    /// The sub-rays of a pulse share their origin and lie within a narrow
    /// cone: the hierarchy is traversed once for the whole bundle
    /// (bundle.rs). The hits are those of [`RayCaster::trace`] for each
    /// sub-ray, and the volumes those the bundle's cone may cross.
    fn trace_pulse(
        &self,
        origin: DVec3,
        dirs: &[DVec3],
        t_min: f64,
        t_max: f64,
        out: &mut PulseTrace,
    ) {
        if self.nodes.is_empty() || dirs.len() < 2 {
            self.trace_each(origin, dirs, t_min, t_max, out);
            return;
        }
        self.trace_bundle(origin, dirs, t_min, t_max, out);
    }
}

#[cfg(test)]
mod tests;

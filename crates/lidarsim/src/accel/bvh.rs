//! Bounding-volume hierarchy with the binned surface-area heuristic
//! (MacDonald & Booth 1990; Wald 2007, "On fast construction of SAH-based
//! bounding volume hierarchies").
//!
//! Nodes live in one flat array. Their boxes are `f32`, relative to a scene
//! origin, rounded outwards and padded so that they always contain the
//! `f64` primitives: a box test may let through a primitive that the exact
//! `f64` test then rejects, never the reverse.

use super::{Hit, NO_HIT, PulseTrace, RayCaster, VolumeSpan, finish_spans, make_hit, volume_span};
use crate::geometry::{Aabb, DVec3, Ray};
use crate::kernels::{
    Boxes, BundleSlabs, DirectionBounds, EdgeCone, LANES, Sign, direction_bounds,
};
use crate::scene::{
    Coverage, EdgeTest, Primitive, Scene, Shape, Straddle, Triangle, TriangleFan, bundle_cone,
};
use rayon::prelude::*;

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
}

struct BuildPrim {
    bounds: Aabb,
}

impl BuildPrim {
    #[inline]
    fn centroid(&self) -> DVec3 {
        self.bounds.center()
    }
}

impl Bvh {
    /// Builds the hierarchy over `scene`, which it then owns with its
    /// primitives reordered so that each leaf's are adjacent: the primitive
    /// numbers of hits index [`RayCaster::scene`], not the scene given.
    pub fn build(scene: Scene) -> Self {
        // The primitives' boxes on all threads; the scene's box from them
        // ([`Scene::bounds`], the same unions in the same order).
        let prims: Vec<BuildPrim> = scene
            .primitives
            .par_iter()
            .map(|p| BuildPrim { bounds: p.bounds() })
            .collect();
        let bounds = prims.iter().fold(Aabb::EMPTY, |b, p| b.union(p.bounds));
        let origin = if bounds.is_empty() {
            DVec3::ZERO
        } else {
            bounds.center()
        };
        let size = if bounds.is_empty() {
            1.0
        } else {
            bounds.extent().max_element().max(1.0)
        };
        // f32 rounding of box corners and of ray origins far from the scene
        // origin: 1 mm plus a relative margin covers ranges up to ~100 km.
        let pad = 1e-3 + 1e-6 * size;
        let mut order: Vec<u32> = (0..prims.len() as u32).collect();
        let mut bvh = Self {
            scene: Scene::default(),
            nodes: Vec::new(),
            stack_len: 0,
            origin,
            pad,
        };
        // The binary tree: the root at 0, its descendants after it, each
        // subtree's within the room its primitive count bounds (a binary
        // tree over n primitives has at most 2n − 1 nodes), so that the
        // subtrees built in parallel write their own parts of one array.
        let mut nodes = zeroed_nodes((2 * prims.len()).saturating_sub(1));
        let mut used = 0;
        if let Some((root, desc)) = nodes.split_first_mut() {
            let (r, n) = bvh.subtree(&prims, &mut order, 0, 0, desc, 1);
            *root = r;
            used = 1 + n;
        }
        drop(prims);
        let (wide, depth) = collapse(&nodes, used);
        drop(nodes);
        let mut scene = scene;
        in_leaf_order(&mut scene.primitives, order);
        bvh.scene = scene;
        bvh.nodes = wide;
        bvh.stack_len = stack_len(depth);
        bvh
    }

    /// The box node over `order[at..at + count]`, a leaf whose first
    /// primitive is at `first + at` in the whole order.
    fn leaf_node(
        &self,
        prims: &[BuildPrim],
        order: &[u32],
        at: usize,
        count: usize,
        first: usize,
    ) -> Node {
        let b = order[at..at + count]
            .iter()
            .fold(Aabb::EMPTY, |b, &i| b.union(prims[i as usize].bounds));
        self.node_over(b, at, count, first)
    }

    /// The leaf node with box `b` over `count` primitives from `first + at`
    /// in the whole order.
    fn node_over(&self, b: Aabb, at: usize, count: usize, first: usize) -> Node {
        let lo = b.min - self.origin - DVec3::splat(self.pad);
        let hi = b.max - self.origin + DVec3::splat(self.pad);
        Node {
            min: [down(lo.x), down(lo.y), down(lo.z)],
            left_or_first: (first + at) as u32,
            max: [up(hi.x), up(hi.y), up(hi.z)],
            count: count as u32,
        }
    }

    /// Builds the subtree over `order` (whose first element is at `first`
    /// in the whole order). Returns its root and how many nodes it used in
    /// `desc`, which receives its other nodes (room for `2·len − 2`; its
    /// first element is node `base` of the whole array, child indices
    /// count from the start of that array). The two halves of the top
    /// levels are built in parallel into their own parts of `desc`; the
    /// tree is the same as a sequential build's.
    fn subtree(
        &self,
        prims: &[BuildPrim],
        order: &mut [u32],
        first: usize,
        depth: usize,
        desc: &mut [Node],
        base: usize,
    ) -> (Node, usize) {
        let count = order.len();
        let mut root = self.leaf_node(prims, order, 0, count, first);
        if depth >= PARALLEL_DEPTH || count < PARALLEL_MIN {
            let used = self.sequential(prims, order, first, &mut root, desc, base);
            return (root, used);
        }
        let Some((mid, _)) = split(prims, order) else {
            return (root, 0);
        };
        let (lo, hi) = order.split_at_mut(mid);
        // Layout: the two children, then room for the left's descendants,
        // then for the right's.
        let (pair, rest) = desc.split_at_mut(2);
        let (ldesc, rdesc) = rest.split_at_mut(2 * mid - 2);
        let (lbase, rbase) = (base + 2, base + 2 + ldesc.len());
        let ((lroot, lused), (rroot, rused)) = rayon::join(
            || self.subtree(prims, lo, first, depth + 1, ldesc, lbase),
            || self.subtree(prims, hi, first + mid, depth + 1, rdesc, rbase),
        );
        pair[0] = lroot;
        pair[1] = rroot;
        root.left_or_first = base as u32;
        root.count = 0;
        (root, 2 + lused + rused)
    }

    /// Sequential binned-SAH build below `root` (a leaf over all of
    /// `order`, which may become interior); descendants go to the front of
    /// `desc` (node `base` of the whole array). Returns how many.
    fn sequential(
        &self,
        prims: &[BuildPrim],
        order: &mut [u32],
        first: usize,
        root: &mut Node,
        desc: &mut [Node],
        base: usize,
    ) -> usize {
        let mut used = 0;
        // Work items: (node, None) for the root, (index in desc) otherwise.
        let mut work: Vec<Option<usize>> = vec![None];
        while let Some(item) = work.pop() {
            let node = match item {
                None => *root,
                Some(i) => desc[i],
            };
            let at = node.left_or_first as usize - first;
            let count = node.count as usize;
            if let Some((mid, halves)) = split(prims, &mut order[at..at + count]) {
                let left = used;
                let (l, r) = halves;
                desc[left] = self.node_over(l, at, mid, first);
                desc[left + 1] = self.node_over(r, at + mid, count - mid, first);
                used += 2;
                let parent = match item {
                    None => &mut *root,
                    Some(i) => &mut desc[i],
                };
                parent.left_or_first = (base + left) as u32;
                parent.count = 0;
                work.push(Some(left));
                work.push(Some(left + 1));
            }
        }
        used
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

/// Reorders `prims` in place so that the `i`-th is the one `order[i]` named
/// (following each cycle of the permutation, without a second copy): the
/// primitives of a leaf, and of neighbouring leaves, then lie next to each
/// other in memory, and a leaf names its primitives directly.
fn in_leaf_order<T>(prims: &mut [T], mut order: Vec<u32>) {
    const DONE: u32 = u32::MAX;
    for start in 0..order.len() {
        let mut at = start;
        while order[at] != DONE {
            let from = order[at] as usize;
            order[at] = DONE;
            if from == start {
                break;
            }
            prims.swap(at, from);
            at = from;
        }
    }
}

/// `n` binary nodes, all zero (empty leaves over nothing). Zeroed memory
/// from the allocator (fresh pages for an array this large) becomes
/// resident only where the build writes nodes: the room that subtrees
/// leave unused costs address space, not memory. `vec![node; n]` would
/// write every element.
fn zeroed_nodes(n: usize) -> Vec<Node> {
    if n == 0 {
        return Vec::new();
    }
    let layout = std::alloc::Layout::array::<Node>(n).expect("node array fits the address space");
    // SAFETY: the layout is non-empty (`n > 0`, `Node` is 32 bytes); all
    // zero bits are a valid `Node` (its fields are `f32` and `u32`); the
    // pointer comes from the global allocator with the layout of a
    // `Vec<Node>` of capacity `n`, all `n` elements initialised.
    unsafe {
        let p = std::alloc::alloc_zeroed(layout).cast::<Node>();
        if p.is_null() {
            std::alloc::handle_alloc_error(layout);
        }
        Vec::from_raw_parts(p, n, n)
    }
}

/// Traversal stack entries for a hierarchy `depth` nodes deep: each node
/// visited leaves at most `WIDTH − 1` of its children on the stack; the
/// last is visited next (pushed, then popped).
fn stack_len(depth: usize) -> usize {
    (WIDTH - 1) * depth + WIDTH
}

/// The eight-wide hierarchy of a binary one (root first, children of an
/// interior node adjacent) whose nodes reachable from the root number
/// `used`: each wide node takes a binary node's two children and, while it
/// has fewer than [`WIDTH`], replaces its interior child with the largest
/// box by that child's two children. Returns the nodes and the number of
/// them on the longest path from the root.
fn collapse(bin: &[Node], used: usize) -> (Vec<WideNode>, usize) {
    let mut wide = Vec::new();
    if used == 0 {
        return (wide, 0);
    }
    let area = |n: &Node| {
        let e = [0, 1, 2].map(|a| (n.max[a] - n.min[a]) as f64);
        e[0] * e[1] + e[1] * e[2] + e[2] * e[0]
    };
    wide.reserve_exact(used / (WIDTH - 1) + 1);
    wide.push(WideNode::EMPTY);
    let mut depth = 0;
    // (binary node, its wide node, depth)
    let mut work = vec![(0usize, 0usize, 1usize)];
    while let Some((b, w, d)) = work.pop() {
        depth = depth.max(d);
        let mut kids = [0usize; WIDTH];
        let mut len = if bin[b].count > 0 {
            // A root that is a leaf: the only child.
            kids[0] = b;
            1
        } else {
            let l = bin[b].left_or_first as usize;
            kids[..2].copy_from_slice(&[l, l + 1]);
            2
        };
        while len < WIDTH {
            let mut open: Option<(usize, f64)> = None;
            for (i, &k) in kids[..len].iter().enumerate() {
                if bin[k].count == 0 && open.is_none_or(|(_, a)| area(&bin[k]) > a) {
                    open = Some((i, area(&bin[k])));
                }
            }
            let Some((i, _)) = open else { break };
            let l = bin[kids[i]].left_or_first as usize;
            kids.copy_within(i + 1..len, i + 2);
            kids[i] = l;
            kids[i + 1] = l + 1;
            len += 1;
        }
        let mut node = WideNode::EMPTY;
        for (slot, &k) in kids[..len].iter().enumerate() {
            let n = &bin[k];
            for a in 0..3 {
                node.planes[a][slot] = n.min[a];
                node.planes[3 + a][slot] = n.max[a];
            }
            if n.count > 0 {
                node.child[slot] = n.left_or_first;
                node.count[slot] = n.count;
            } else {
                node.child[slot] = wide.len() as u32;
                work.push((k, wide.len(), d + 1));
                wide.push(WideNode::EMPTY);
            }
        }
        wide[w] = node;
    }
    (wide, depth)
}

/// Largest f32 not above `x`.
fn down(x: f64) -> f32 {
    let f = x as f32;
    if f as f64 > x { f.next_down() } else { f }
}

/// Smallest f32 not below `x`.
fn up(x: f64) -> f32 {
    let f = x as f32;
    if (f as f64) < x { f.next_up() } else { f }
}

/// Partitions `items` by the best binned-SAH plane; returns the size of the
/// left part and the bounds of the two parts (from the bins: the union of
/// their bins' boxes is the union of their primitives'), or `None` when the
/// node should stay a leaf.
fn split(prims: &[BuildPrim], items: &mut [u32]) -> Option<(usize, (Aabb, Aabb))> {
    let n = items.len();
    if n <= MAX_LEAF {
        return None;
    }
    // One pass for the bounds of the centroids and of the node, one for
    // the bins of all three axes.
    let (cb, nb) = items.iter().fold((Aabb::EMPTY, Aabb::EMPTY), |(c, b), &i| {
        let p = &prims[i as usize];
        (c.union_point(p.centroid()), b.union(p.bounds))
    });
    let node_area = nb.surface_area();
    let ext = cb.extent();
    let scale = [0, 1, 2].map(|a| {
        if ext[a] > 0.0 {
            BINS as f64 / ext[a]
        } else {
            0.0
        }
    });
    let mut boxes = [[Aabb::EMPTY; BINS]; 3];
    let mut counts = [[0usize; BINS]; 3];
    for &i in items.iter() {
        let p = &prims[i as usize];
        let c = p.centroid();
        for axis in 0..3 {
            let b = (((c[axis] - cb.min[axis]) * scale[axis]) as usize).min(BINS - 1);
            boxes[axis][b] = boxes[axis][b].union(p.bounds);
            counts[axis][b] += 1;
        }
    }
    let mut best: Option<(f64, usize, usize)> = None; // (cost, axis, bin)
    for axis in 0..3 {
        if ext[axis] <= 0.0 {
            continue;
        }
        let (boxes, counts) = (&boxes[axis], &counts[axis]);
        // Sweep from the right to get the right-hand areas and counts.
        let mut right_area = [0.0; BINS];
        let mut right_count = [0usize; BINS];
        let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
        for b in (1..BINS).rev() {
            acc = acc.union(boxes[b]);
            cnt += counts[b];
            right_area[b] = acc.surface_area();
            right_count[b] = cnt;
        }
        let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
        for b in 0..BINS - 1 {
            acc = acc.union(boxes[b]);
            cnt += counts[b];
            if cnt == 0 || right_count[b + 1] == 0 {
                continue;
            }
            let cost =
                acc.surface_area() * cnt as f64 + right_area[b + 1] * right_count[b + 1] as f64;
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, b));
            }
        }
    }
    match best {
        Some((cost, axis, bin)) => {
            // Traversal cost 1, intersection cost 1 per primitive.
            let leaf_cost = n as f64 * node_area;
            if cost >= leaf_cost && n <= 2 * MAX_LEAF {
                return None;
            }
            let scale = scale[axis];
            let goes_left = |i: &u32| {
                let c = prims[*i as usize].centroid()[axis];
                ((((c - cb.min[axis]) * scale) as usize).min(BINS - 1)) <= bin
            };
            let mid = partition(items, goes_left);
            let bins = &boxes[axis];
            let halves = (
                bins[..=bin].iter().fold(Aabb::EMPTY, |a, b| a.union(*b)),
                bins[bin + 1..].iter().fold(Aabb::EMPTY, |a, b| a.union(*b)),
            );
            (mid > 0 && mid < n).then_some((mid, halves))
        }
        // All centroids coincide: split the list in halves so that leaves
        // stay small.
        None => {
            let bounds = |part: &[u32]| {
                part.iter()
                    .fold(Aabb::EMPTY, |b, &i| b.union(prims[i as usize].bounds))
            };
            Some((n / 2, (bounds(&items[..n / 2]), bounds(&items[n / 2..]))))
        }
    }
}

fn partition(items: &mut [u32], pred: impl Fn(&u32) -> bool) -> usize {
    let mut i = 0;
    for j in 0..items.len() {
        if pred(&items[j]) {
            items.swap(i, j);
            i += 1;
        }
    }
    i
}

impl Bvh {
    /// Closest-first traversal: the closest accepted surface within
    /// `(t_min, t_max)`, and, when `spans` is given, the volumes whose
    /// bounds the ray enters before the closest surface.
    fn traverse(
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
fn nearest_on_top(run: &mut [Pending]) {
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
    /// cone: the hierarchy is traversed once for the whole bundle (a node is
    /// visited when any direction within the bundle's per-axis direction
    /// bounds can meet its box), and every sub-ray is tested exactly, in
    /// `f64`, against the primitives of the leaves reached. The answers are
    /// those of [`RayCaster::trace`] for each sub-ray.
    fn trace_pulse(
        &self,
        origin: DVec3,
        dirs: &[DVec3],
        t_min: f64,
        t_max: f64,
        spans: &mut Vec<VolumeSpan>,
        out: &mut PulseTrace,
    ) {
        if self.nodes.is_empty() || dirs.len() < 2 {
            self.trace_each(origin, dirs, t_min, t_max, spans, out);
            return;
        }
        // The previous pulse's hits are overwritten in place, field by
        // field: filling with the whole tuple (`resize`, `fill`) copies it
        // through a stack slot, each copy stalled on a load that partly
        // overlaps the store. The normal is left as it was: it is read only
        // for a hit, and every hit recorded writes it (NaN for surfaces
        // other than triangles, filled in at the end).
        let mut best = std::mem::take(&mut out.hits);
        out.clear();
        let (bundle, sum) = bundle(origin - self.origin, dirs);
        let (axis, spread) = bundle_cone(dirs, sum);
        let cone = EdgeCone::new(origin, axis, spread);
        let mut volumes = std::mem::take(&mut out.volumes);
        best.resize(dirs.len(), (t_max, NO_HIT, DVec3::NAN));
        for b in &mut best {
            b.0 = t_max;
            b.1 = NO_HIT;
        }
        volumes.clear();
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
                        missing -= bundle_triangle(tri, p, dirs, &cone, t_min, &mut best);
                        continue;
                    }
                    for (dir, b) in dirs.iter().zip(best.iter_mut()) {
                        let ray = Ray { origin, dir: *dir };
                        if let Some(t) = prim.intersect(&ray, t_min, b.0) {
                            if b.1 == NO_HIT {
                                missing -= 1;
                            }
                            *b = (t, p, DVec3::NAN);
                            normals_missing = true;
                        }
                    }
                }
                if missing == 0 {
                    far = best
                        .iter()
                        .fold(0.0f64, |m, b| if b.0 > m { b.0 } else { m });
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
        // Triangle hits carry their normal, already facing the ray, from the
        // test; other sub-rays mostly hit the same flat primitive, whose
        // normal is computed once.
        let mut flat: Option<(u32, DVec3)> = None;
        if volumes.is_empty() {
            if !normals_missing {
                out.hits = best;
                out.volumes = volumes;
                return;
            }
            for (dir, (t, p, normal)) in dirs.iter().zip(best.iter_mut()) {
                if *p == NO_HIT || !normal.x.is_nan() {
                    continue;
                }
                let n = match flat {
                    Some((q, n)) if q == *p => n,
                    _ => {
                        let prim = &self.scene.primitives[*p as usize];
                        let n = prim.normal_at(origin + *dir * *t);
                        if prim.is_flat() {
                            flat = Some((*p, n));
                        }
                        n
                    }
                };
                *normal = if n.dot(*dir) > 0.0 { -n } else { n };
            }
            out.hits = best;
            out.volumes = volumes;
            return;
        }
        for (dir, (t, p, normal)) in dirs.iter().zip(best.iter_mut()) {
            let ray = Ray { origin, dir: *dir };
            spans.clear();
            for &v in &volumes {
                if let Some(s) = volume_span(&self.scene.primitives[v as usize], v, &ray, t_min, *t)
                {
                    spans.push(s);
                }
            }
            finish_spans(spans, *t);
            out.push_spans(spans);
            if *p != NO_HIT && normal.x.is_nan() {
                *normal = make_hit(&self.scene, *p, &ray, *t).normal;
            }
        }
        out.hits = best;
        out.volumes = volumes;
    }
}

/// The fan of `tri` from the cone's origin with its edge planes only
/// ([`TriangleFan::edges`]) and what its coverage leaves to test per ray
/// (`None`: every ray passes the edge tests), unless the cone misses the
/// triangle: [`TriangleFan::coverage`] by the edge-plane kernel.
#[inline(always)]
fn fan(cone: &EdgeCone, tri: &Triangle) -> Option<(TriangleFan, Option<Straddle>)> {
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
/// (distance, primitive, normal) where the triangle is closer; returns how
/// many rays got their first hit. `cone` is the bundle's origin, axis and
/// spread: a triangle the whole bundle misses costs only its edge planes,
/// one it covers skips the per-ray edge tests, and for one it straddles
/// each ray is tested on the straddled edges only.
#[inline]
fn bundle_triangle(
    tri: &Triangle,
    p: u32,
    dirs: &[DVec3],
    cone: &EdgeCone,
    t_min: f64,
    best: &mut [(f64, u32, DVec3)],
) -> usize {
    let Some((mut fan, straddle)) = fan(cone, tri) else {
        return 0;
    };
    fan.complete(tri);
    // One loop per kind of test, so that each runs without deciding again.
    let f = &fan;
    match straddle.map(|s| fan.edge_test(s)) {
        None => record_hits(f, p, dirs, t_min, best, &|_| true),
        Some(EdgeTest::One(a)) => record_hits(f, p, dirs, t_min, best, &|d| d.dot(a) >= 0.0),
        Some(EdgeTest::Two(a, b)) => record_hits(f, p, dirs, t_min, best, &|d| {
            d.dot(a) >= 0.0 && d.dot(b) >= 0.0
        }),
        Some(EdgeTest::Three) => record_hits(f, p, dirs, t_min, best, &|d| f.passes(d)),
    }
}

/// Records `fan`'s triangle `p` for every ray that `passes` and meets it
/// closer than its best so far; returns how many rays got their first hit.
#[inline(always)]
fn record_hits(
    fan: &TriangleFan,
    p: u32,
    dirs: &[DVec3],
    t_min: f64,
    best: &mut [(f64, u32, DVec3)],
    passes: &impl Fn(DVec3) -> bool,
) -> usize {
    let mut first = 0;
    for (d, slot) in dirs.iter().zip(best.iter_mut()) {
        if !passes(*d) {
            continue;
        }
        if let Some((t, normal)) = fan.hit(*d, t_min, slot.0) {
            first += usize::from(slot.1 == NO_HIT);
            *slot = (t, p, normal);
        }
    }
    first
}

/// The sub-rays of a pulse as one bundle for the box tests: their origin
/// relative to the hierarchy's origin and, per axis, the sign and the
/// reciprocal bounds of their direction components (widened a little so
/// that f32 rounding stays on the conservative side); and the sum of the
/// directions.
fn bundle(o: DVec3, dirs: &[DVec3]) -> (BundleSlabs, DVec3) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::BruteForce;
    use crate::scene::{Material, Primitive, Shape, SurfaceClass, Triangle};
    use proptest::prelude::*;

    fn random_scene(seed: u64, n: usize) -> Scene {
        let mut s = crate::rng::Stream::new(seed, 0, 0, crate::rng::Purpose::Test);
        let mut scene = Scene::default();
        let m = scene.add_material(Material {
            name: "m".into(),
            reflectance: 0.5,
            incidence_exponent: 1.0,
        });
        let o = scene.add_object("soup");
        for _ in 0..n {
            let c = DVec3::new(
                s.uniform() * 200.0 - 100.0,
                s.uniform() * 200.0 - 100.0,
                s.uniform() * 30.0,
            );
            let r = |s: &mut crate::rng::Stream| {
                DVec3::new(s.uniform() - 0.5, s.uniform() - 0.5, s.uniform() - 0.5) * 8.0
            };
            if let Some(t) = Triangle::new(c + r(&mut s), c + r(&mut s), c + r(&mut s)) {
                scene.primitives.push(Primitive {
                    shape: Shape::Triangle(t),
                    material: m,
                    class: SurfaceClass::Unclassified,
                    object: o,
                });
            }
        }
        scene
    }

    #[test]
    fn valid_on_random_and_degenerate_scenes() {
        for n in [0, 1, 3, 5, 17, 1000] {
            let bvh = Bvh::build(random_scene(n as u64, n));
            bvh.validate().unwrap();
        }
        // Many identical triangles: centroids coincide.
        let mut scene = random_scene(1, 1);
        let p = scene.primitives[0].clone();
        scene.primitives = vec![p; 100];
        let bvh = Bvh::build(scene);
        bvh.validate().unwrap();
        assert!(bvh.stats().max_depth < STACK);
    }

    /// A scene large enough for the top levels to be built in parallel,
    /// each subtree in its own part of the node array: the hierarchy is
    /// valid and finds what testing every primitive finds.
    #[test]
    fn parallel_build_is_valid_and_finds_every_hit() {
        let n = 3 * PARALLEL_MIN;
        let bvh = Bvh::build(random_scene(11, n));
        bvh.validate().unwrap();
        let stats = bvh.stats();
        assert!(stats.leaves >= n / MAX_LEAF, "{stats:?}");
        let brute = BruteForce::new(bvh.scene().clone());
        let mut s = crate::rng::Stream::new(11, 1, 0, crate::rng::Purpose::Test);
        let mut hits = 0;
        for _ in 0..2000 {
            let o = DVec3::new(
                s.uniform() * 240.0 - 120.0,
                s.uniform() * 240.0 - 120.0,
                500.0,
            );
            let d = DVec3::new(s.uniform() - 0.5, s.uniform() - 0.5, -2.0);
            let ray = Ray::new(o, d);
            let (a, b) = (
                brute.closest_hit(&ray, 0.0, 1e9),
                bvh.closest_hit(&ray, 0.0, 1e9),
            );
            assert_eq!(a.map(|h| (h.prim, h.t)), b.map(|h| (h.prim, h.t)));
            hits += usize::from(a.is_some());
        }
        assert!(hits > 500, "{hits}");
    }

    /// A triangle soup with trees standing in it.
    /// Triangles, and horizontal rectangles (polygons, which carry no
    /// normal from the bundle test) at random heights, some of them tilted.
    fn scene_with_polygons(seed: u64) -> Scene {
        let mut scene = random_scene(seed, 200);
        let mut s = crate::rng::Stream::new(seed, 2, 0, crate::rng::Purpose::Test);
        let (m, o) = (0, 0);
        for _ in 0..30 {
            let c = DVec3::new(
                s.uniform() * 200.0 - 100.0,
                s.uniform() * 200.0 - 100.0,
                0.0,
            );
            let (w, z, tilt) = (
                5.0 + 20.0 * s.uniform(),
                40.0 * s.uniform(),
                s.uniform() - 0.5,
            );
            let corner = |x: f64, y: f64| c + DVec3::new(x * w, y * w, z + tilt * x * w);
            let poly = crate::scene::Polygon::new(vec![
                corner(-1.0, -1.0),
                corner(1.0, -1.0),
                corner(1.0, 1.0),
                corner(-1.0, 1.0),
            ])
            .expect("a planar rectangle");
            scene.primitives.push(Primitive {
                shape: Shape::Polygon(Box::new(poly)),
                material: m,
                class: SurfaceClass::Unclassified,
                object: o,
            });
        }
        scene
    }

    fn scene_with_trees(seed: u64) -> Scene {
        let mut scene = random_scene(seed, 300);
        let mut s = crate::rng::Stream::new(seed, 1, 0, crate::rng::Purpose::Test);
        for k in 0..40 {
            let base = DVec3::new(s.uniform() * 160.0 - 80.0, s.uniform() * 160.0 - 80.0, 0.0);
            let spec = crate::scene::TreeSpec::new(
                base,
                crate::scene::Species::Pine,
                0.3,
                15.0 + 10.0 * s.uniform(),
                6.0,
            );
            scene.add_tree(&spec, 0.3, format!("tree {k}"));
        }
        scene
    }

    /// The in-place reordering puts at `i` the item `order[i]` named, for
    /// permutations of every cycle structure.
    #[test]
    fn reordering_in_place_follows_the_order() {
        let mut s = crate::rng::Stream::new(3, 0, 0, crate::rng::Purpose::Test);
        for n in [0usize, 1, 2, 3, 10, 257] {
            for _ in 0..20 {
                let mut order: Vec<u32> = (0..n as u32).collect();
                // Fisher–Yates, sometimes stopped early (fixed points).
                let swaps = (s.uniform() * n as f64) as usize;
                for i in (1..n).rev().take(swaps) {
                    let j = (s.uniform() * (i + 1) as f64) as usize;
                    order.swap(i, j.min(i));
                }
                let items: Vec<u64> = (0..n as u64).map(|i| 1000 + i * i).collect();
                let want: Vec<u64> = order.iter().map(|&i| items[i as usize]).collect();
                let mut got = items.clone();
                in_leaf_order(&mut got, order);
                assert_eq!(got, want);
            }
        }
    }

    /// The bundle's box test never leaves out a box one of its rays
    /// enters before `t_max` (tested ray by ray with the f64 slab test),
    /// for bundles of every sign pattern; and the bundle's sum and cone are
    /// those of its directions.
    #[test]
    fn bundle_box_test_keeps_every_box_a_ray_enters() {
        let mut s = crate::rng::Stream::new(9, 0, 0, crate::rng::Purpose::Test);
        let mut u = move || s.uniform() - 0.5;
        let (mut entered, mut missed) = (0, 0);
        for case in 0..20_000 {
            let c = DVec3::new(u(), u(), u()).normalize();
            let spread = [1e-4, 0.05, 0.6][case % 3];
            let dirs: Vec<DVec3> = (0..7)
                .map(|_| (c + DVec3::new(u(), u(), u()) * spread).normalize())
                .collect();
            let o = DVec3::new(u(), u(), u()) * 50.0;
            let (slabs, sum) = bundle(o, &dirs);
            assert_eq!(sum, dirs.iter().fold(DVec3::ZERO, |s, d| s + *d));
            assert_eq!(bundle_cone(&dirs, sum), crate::scene::bundle_spread(&dirs));
            // Boxes near the bundle's axis, behind the origin or ahead of it,
            // in the slots of a node; the last slot of every third node is
            // left empty.
            let mut node = WideNode::EMPTY;
            for slot in 0..WIDTH - usize::from(case % 3 == 0) {
                let near = o + c * (u() * 200.0) + DVec3::new(u(), u(), u()) * 30.0;
                let size = DVec3::new(u() + 0.5, u() + 0.5, u() + 0.5)
                    * [0.0, 1.0, 20.0][(case + slot) % 3];
                let (a, b) = (near - size, near + size);
                for k in 0..3 {
                    node.planes[k][slot] = down(a[k]);
                    node.planes[3 + k][slot] = up(b[k]);
                }
            }
            let t_max = [1e3f32, 60.0][case % 2];
            let (mask, t) = slabs.enters(&node.planes, t_max);
            for (slot, &t_slot) in t.iter().enumerate() {
                let b = Aabb {
                    min: DVec3::from([0, 1, 2].map(|k| node.planes[k][slot] as f64)),
                    max: DVec3::from([0, 1, 2].map(|k| node.planes[3 + k][slot] as f64)),
                };
                let entering = (!b.is_empty())
                    .then_some(&dirs)
                    .into_iter()
                    .flatten()
                    .filter_map(|d| b.ray_interval(&Ray { origin: o, dir: *d }, 0.0, t_max as f64))
                    .map(|(t0, _)| t0)
                    .reduce(f64::min);
                if let Some(t0) = entering {
                    assert!(mask & (1 << slot) != 0, "case {case} slot {slot}");
                    assert!(t_slot as f64 <= t0 * (1.0 + 1e-5) + 1e-5, "case {case}");
                    entered += 1;
                } else {
                    missed += 1;
                }
                if b.is_empty() {
                    assert_eq!(
                        mask & (1 << slot),
                        0,
                        "case {case}: an empty slot is entered"
                    );
                }
            }
        }
        assert!(entered > 4000 && missed > 4000, "{entered} {missed}");
    }

    /// The edge planes and coverage the kernel gives are the scene's
    /// definition ([`TriangleFan::edges`], [`TriangleFan::coverage`]) to
    /// the bit, for bundles that miss, straddle and cover triangles (also
    /// degenerate and far ones).
    #[test]
    fn triangle_coverage_is_the_scenes_definition() {
        let mut s = crate::rng::Stream::new(12, 0, 0, crate::rng::Purpose::Test);
        let mut u = move || s.uniform() - 0.5;
        let mut seen = [0usize; 3];
        for case in 0..20_000 {
            let origin = DVec3::new(u(), u(), u()) * 1000.0 + DVec3::Z * 500.0;
            let axis = DVec3::new(u() * 0.8, u() * 0.8, -1.0).normalize();
            let spread = [0.0, 1e-4, 0.02, 0.3][case % 4];
            let cone = EdgeCone::new(origin, axis, spread);
            // Corners around the point the axis reaches 500 m away, from
            // centimetres to tens of metres apart.
            let at = origin + axis * 500.0;
            let size = [0.05, 1.0, 30.0][case % 3];
            let corner = |u: &mut dyn FnMut() -> f64| at + DVec3::new(u(), u(), u() * 0.2) * size;
            let (a, b) = (corner(&mut u), corner(&mut u));
            let c = if case % 7 == 0 {
                a + (b - a) * 0.5
            } else {
                corner(&mut u)
            };
            let Some(tri) = Triangle::new(a, b, c) else {
                continue;
            };
            let bits = |f: &Option<(TriangleFan, Option<Straddle>)>| {
                f.map(|(fan, straddle)| {
                    (
                        fan.edge_normals()
                            .map(|e| [e.x, e.y, e.z].map(f64::to_bits)),
                        straddle,
                    )
                })
            };
            let definition = TriangleFan::edges(&tri, origin);
            let want = match definition.coverage(axis, spread) {
                Coverage::None => None,
                Coverage::All => Some((definition, None)),
                Coverage::Some(straddle) => Some((definition, Some(straddle))),
            };
            assert_eq!(bits(&fan(&cone, &tri)), bits(&want), "case {case}");
            seen[match want {
                None => 0,
                Some((_, None)) => 1,
                Some((_, Some(_))) => 2,
            }] += 1;
        }
        assert!(seen.iter().all(|&n| n > 1000), "{seen:?}");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// The bundle traversal gives every sub-ray the hit and crown spans
        /// that tracing it alone over all primitives gives.
        #[test]
        fn pulse_bundles_match_single_rays(seed in 0u64..1000, ox in -120.0..120.0f64,
                                           oy in -120.0..120.0f64, dx in -0.5..0.5f64,
                                           dy in -0.5..0.5f64, spread in 1e-5..0.2f64) {
            // With crowns (per-ray spans), and with polygons but no
            // volumes (normals filled in after the traversal).
            for scene in [scene_with_trees(seed), scene_with_polygons(seed)] {
                // The hierarchy puts the primitives in leaf order: the
                // reference works on the same order.
                let bvh = Bvh::build(scene);
                let brute = BruteForce::new(bvh.scene().clone());
                let origin = DVec3::new(ox, oy, 300.0);
                let c = DVec3::new(dx, dy, -1.0).normalize();
                let u = c.any_orthonormal_vector();
                let v = c.cross(u);
                // A spiral of 19 directions around the central one.
                let dirs: Vec<DVec3> = (0..19)
                    .map(|i| {
                        let r = spread * (i as f64 / 18.0).sqrt();
                        let a = i as f64 * 2.399_963;
                        (c + u * (r * a.cos()) + v * (r * a.sin())).normalize()
                    })
                    .collect();
                let mut spans = Vec::new();
                let mut trace = crate::accel::PulseTrace::default();
                bvh.trace_pulse(origin, &dirs, 0.5, 1e4, &mut spans, &mut trace);
                for (i, d) in dirs.iter().enumerate() {
                    let ray = Ray { origin, dir: *d };
                    let want = brute.trace(&ray, 0.5, 1e4, &mut spans);
                    let got = trace.hit(i);
                    prop_assert_eq!(want.map(|h| h.prim), got.map(|h| h.prim));
                    // Same arithmetic: the same distances, to the bit.
                    prop_assert_eq!(want.map(|h| h.t), got.map(|h| h.t));
                    prop_assert_eq!(want.map(|h| h.normal), got.map(|h| h.normal));
                    prop_assert_eq!(&spans[..], trace.spans_of(i));
                }
            }
        }

        #[test]
        fn same_answers_as_brute_force(seed in 0u64..1000, ox in -150.0..150.0f64,
                                       oy in -150.0..150.0f64, dx in -0.5..0.5f64,
                                       dy in -0.5..0.5f64) {
            let scene = random_scene(seed, 300);
            let bvh = Bvh::build(scene);
            let brute = BruteForce::new(bvh.scene().clone());
            let ray = Ray::new(DVec3::new(ox, oy, 500.0), DVec3::new(dx, dy, -1.0));
            let a = brute.closest_hit(&ray, 0.0, 1e9);
            let b = bvh.closest_hit(&ray, 0.0, 1e9);
            prop_assert_eq!(a.map(|h| h.prim), b.map(|h| h.prim));
            if let (Some(a), Some(b)) = (a, b) {
                prop_assert!((a.t - b.t).abs() < 1e-9);
            }
        }
    }
}

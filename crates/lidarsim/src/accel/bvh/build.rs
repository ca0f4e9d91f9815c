//! Building the hierarchy: a binary tree by the binned surface-area
//! heuristic over the primitives' boxes in the nodes' `f32` frame (its top
//! levels in parallel), collapsed into the eight-wide nodes the traversals
//! use (`collapse.rs`); the scene's primitives put in leaf order.

use rayon::prelude::*;

use super::collapse::collapse;
use super::{BINS, Bvh, MAX_LEAF, Node, PARALLEL_DEPTH, PARALLEL_MIN, WIDTH};
use crate::geometry::{Aabb, DVec3};
use crate::scene::Scene;

/// A box in the hierarchy's frame: `f32`, relative to the scene origin.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Box32 {
    lo: [f32; 3],
    hi: [f32; 3],
}

/// The smaller of two `f32` that are not NaN (a plain comparison, which
/// compiles to one instruction, where `f32::min` also handles NaN).
#[inline(always)]
fn min32(a: f32, b: f32) -> f32 {
    if b < a { b } else { a }
}

/// The larger of two `f32` that are not NaN.
#[inline(always)]
fn max32(a: f32, b: f32) -> f32 {
    if b > a { b } else { a }
}

impl Box32 {
    /// The empty box (the identity of [`Box32::union`]).
    const EMPTY: Self = Self {
        lo: [f32::INFINITY; 3],
        hi: [f32::NEG_INFINITY; 3],
    };

    #[inline(always)]
    fn union(self, o: Self) -> Self {
        Self {
            lo: [0, 1, 2].map(|a| min32(self.lo[a], o.lo[a])),
            hi: [0, 1, 2].map(|a| max32(self.hi[a], o.hi[a])),
        }
    }

    /// This box grown to hold the point `p`.
    #[inline(always)]
    fn union_point(self, p: [f32; 3]) -> Self {
        Self {
            lo: [0, 1, 2].map(|a| min32(self.lo[a], p[a])),
            hi: [0, 1, 2].map(|a| max32(self.hi[a], p[a])),
        }
    }

    /// Half the surface area (the heuristic compares ratios of areas);
    /// 0 for the empty box.
    fn half_area(&self) -> f64 {
        let e = [0, 1, 2].map(|a| f64::from(self.hi[a]) - f64::from(self.lo[a]));
        if e.iter().any(|&x| x < 0.0) {
            return 0.0;
        }
        e[0] * e[1] + e[1] * e[2] + e[2] * e[0]
    }
}

/// A primitive's box in the hierarchy's frame — the `f64` box relative to
/// the origin, padded and rounded outwards ([`Bvh::frame_box`]) — and its
/// number in the scene. The build partitions these themselves, not
/// indices into them: each pass then reads memory in order, 28 bytes a
/// primitive.
#[derive(Clone, Copy, Debug)]
#[repr(C)]
struct BuildPrim {
    lo: [f32; 3],
    index: u32,
    hi: [f32; 3],
}

impl BuildPrim {
    #[inline(always)]
    fn bounds(&self) -> Box32 {
        Box32 {
            lo: self.lo,
            hi: self.hi,
        }
    }

    /// Twice the box's centre (the binning only compares centroids).
    #[inline(always)]
    fn centroid2(&self) -> [f32; 3] {
        [0, 1, 2].map(|a| self.lo[a] + self.hi[a])
    }
}

impl Bvh {
    /// Builds the hierarchy over `scene`, which it then owns with its
    /// primitives reordered so that each leaf's are adjacent: the primitive
    /// numbers of hits index [`crate::accel::RayCaster::scene`], not the scene given.
    pub fn build(scene: Scene) -> Self {
        // The scene's box ([`Scene::bounds`]: unions are exact, so their
        // order does not matter), then the primitives' boxes in the
        // frame it sets, both on all threads.
        let bounds = scene
            .primitives
            .par_iter()
            .map(|p| p.bounds())
            .reduce(|| Aabb::EMPTY, Aabb::union);
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
        let mut bvh = Self {
            scene: Scene::default(),
            nodes: Vec::new(),
            stack_len: 0,
            origin,
            pad,
            bounds,
        };
        let mut prims: Vec<BuildPrim> = scene
            .primitives
            .par_iter()
            .enumerate()
            .map(|(i, p)| {
                let b = bvh.frame_box(p.bounds());
                BuildPrim {
                    lo: b.lo,
                    index: i as u32,
                    hi: b.hi,
                }
            })
            .collect();
        // The binary tree: the root at 0, its descendants after it, each
        // subtree's within the room its primitive count bounds (a binary
        // tree over n primitives has at most 2n − 1 nodes), so that the
        // subtrees built in parallel write their own parts of one array.
        let mut nodes = zeroed_nodes((2 * prims.len()).saturating_sub(1));
        let mut used = 0;
        if let Some((root, desc)) = nodes.split_first_mut() {
            let (r, n) = subtree(&mut prims, 0, 0, desc, 1);
            *root = r;
            used = 1 + n;
        }
        let order: Vec<u32> = prims.iter().map(|p| p.index).collect();
        drop(prims);
        let (wide, depth) = collapse(&nodes, used);
        drop(nodes);
        let mut scene = scene;
        scene.primitives = in_leaf_order(std::mem::take(&mut scene.primitives), &order);
        bvh.scene = scene;
        bvh.nodes = wide;
        bvh.stack_len = stack_len(depth);
        bvh
    }

    /// The box `b` in the hierarchy's frame: relative to the origin,
    /// padded, rounded outwards to `f32`. A node's box is the union of its
    /// primitives' boxes in this frame, which is this of the union of
    /// their `f64` boxes (the subtraction and the rounding are monotone).
    fn frame_box(&self, b: Aabb) -> Box32 {
        let lo = b.min - self.origin - DVec3::splat(self.pad);
        let hi = b.max - self.origin + DVec3::splat(self.pad);
        Box32 {
            lo: [down(lo.x), down(lo.y), down(lo.z)],
            hi: [up(hi.x), up(hi.y), up(hi.z)],
        }
    }
}

/// The leaf node over all of `prims`, whose first primitive is at `first`
/// in the whole order.
fn leaf_node(prims: &[BuildPrim], first: usize) -> Node {
    let b = prims.iter().fold(Box32::EMPTY, |b, p| b.union(p.bounds()));
    node_over(b, 0, prims.len(), first)
}

/// The leaf node with box `b` over `count` primitives from `first + at` in
/// the whole order.
fn node_over(b: Box32, at: usize, count: usize, first: usize) -> Node {
    Node {
        min: b.lo,
        left_or_first: (first + at) as u32,
        max: b.hi,
        count: count as u32,
    }
}

/// Builds the subtree over `prims` (whose first element is at `first`
/// in the whole order), reordering them. Returns its root and how many nodes it used in
/// `desc`, which receives its other nodes (room for `2·len − 2`; its
/// first element is node `base` of the whole array, child indices
/// count from the start of that array). The two halves of the top
/// levels are built in parallel into their own parts of `desc`; the
/// tree is the same as a sequential build's.
fn subtree(
    prims: &mut [BuildPrim],
    first: usize,
    depth: usize,
    desc: &mut [Node],
    base: usize,
) -> (Node, usize) {
    let count = prims.len();
    let mut root = leaf_node(prims, first);
    if depth >= PARALLEL_DEPTH || count < PARALLEL_MIN {
        let used = sequential(prims, first, &mut root, desc, base);
        return (root, used);
    }
    let Some((mid, _)) = split(prims) else {
        return (root, 0);
    };
    let (lo, hi) = prims.split_at_mut(mid);
    // Layout: the two children, then room for the left's descendants,
    // then for the right's.
    let (pair, rest) = desc.split_at_mut(2);
    let (ldesc, rdesc) = rest.split_at_mut(2 * mid - 2);
    let (lbase, rbase) = (base + 2, base + 2 + ldesc.len());
    let ((lroot, lused), (rroot, rused)) = rayon::join(
        || subtree(lo, first, depth + 1, ldesc, lbase),
        || subtree(hi, first + mid, depth + 1, rdesc, rbase),
    );
    pair[0] = lroot;
    pair[1] = rroot;
    root.left_or_first = base as u32;
    root.count = 0;
    (root, 2 + lused + rused)
}

/// Sequential binned-SAH build below `root` (a leaf over all of
/// `prims`, which may become interior); descendants go to the front of
/// `desc` (node `base` of the whole array). Returns how many.
fn sequential(
    prims: &mut [BuildPrim],
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
        if let Some((mid, halves)) = split(&mut prims[at..at + count]) {
            let left = used;
            let (l, r) = halves;
            desc[left] = node_over(l, at, mid, first);
            desc[left + 1] = node_over(r, at + mid, count - mid, first);
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

/// `prims` in leaf order: the `i`-th of the result is `prims[order[i]]`
/// (the primitives of a leaf, and of neighbouring leaves, then lie next to
/// each other in memory, and a leaf names its primitives directly). Each
/// element is moved once, gathered on all threads into a new array: the
/// moves are random reads, and an in-place reordering, one cycle of the
/// permutation after another, waits for two of them at every step. The
/// array is held twice for a moment, after the binary tree and the build's
/// boxes are freed.
///
/// # Panics
/// If `order` is not a permutation of `0..prims.len()`.
pub(super) fn in_leaf_order<T: Send + Sync>(prims: Vec<T>, order: &[u32]) -> Vec<T> {
    let mut seen = vec![false; prims.len()];
    let permutation = order.len() == prims.len()
        && order.iter().all(|&i| {
            seen.get_mut(i as usize)
                .is_some_and(|s| !std::mem::replace(s, true))
        });
    assert!(
        permutation,
        "the leaf order is a permutation of the primitives"
    );
    drop(seen);
    let mut from = std::mem::ManuallyDrop::new(prims);
    let source = &from[..];
    let gathered: Vec<T> = order
        .par_iter()
        // SAFETY: `order` is a permutation of the indices (checked above),
        // so every element is read exactly once, and `from` is never
        // dropped with its elements: below, its buffer is freed alone. A
        // panic on the way would leak the elements, not drop them twice.
        .map(|&i| unsafe { std::ptr::read(&source[i as usize]) })
        .collect();
    // SAFETY: every element was moved out above; length 0 frees the buffer
    // without dropping them.
    unsafe { from.set_len(0) };
    drop(std::mem::ManuallyDrop::into_inner(from));
    gathered
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
pub(super) fn stack_len(depth: usize) -> usize {
    (WIDTH - 1) * depth + WIDTH
}

/// Largest f32 not above `x`.
pub(super) fn down(x: f64) -> f32 {
    let f = x as f32;
    if f as f64 > x { f.next_down() } else { f }
}

/// Smallest f32 not below `x`.
pub(super) fn up(x: f64) -> f32 {
    let f = x as f32;
    if (f as f64) < x { f.next_up() } else { f }
}

/// Partitions `items` by the best binned-SAH plane; returns the size of the
/// left part and the bounds of the two parts (from the bins: the union of
/// their bins' boxes is the union of their primitives'), or `None` when the
/// node should stay a leaf.
fn split(items: &mut [BuildPrim]) -> Option<(usize, (Box32, Box32))> {
    let n = items.len();
    if n <= MAX_LEAF {
        return None;
    }
    // One pass for the bounds of the centroids and of the node, one for
    // the bins of all three axes.
    let (cb, nb) = items
        .iter()
        .fold((Box32::EMPTY, Box32::EMPTY), |(c, b), p| {
            (c.union_point(p.centroid2()), b.union(p.bounds()))
        });
    let node_area = nb.half_area();
    let ext = [0, 1, 2].map(|a| cb.hi[a] - cb.lo[a]);
    let scale = ext.map(|e| if e > 0.0 { BINS as f32 / e } else { 0.0 });
    let bin_of = |c: f32, axis: usize| (((c - cb.lo[axis]) * scale[axis]) as usize).min(BINS - 1);
    let mut boxes = [[Box32::EMPTY; BINS]; 3];
    let mut counts = [[0u32; BINS]; 3];
    for p in items.iter() {
        let c = p.centroid2();
        for axis in 0..3 {
            let b = bin_of(c[axis], axis);
            boxes[axis][b] = boxes[axis][b].union(p.bounds());
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
        let mut right_count = [0u32; BINS];
        let (mut acc, mut cnt) = (Box32::EMPTY, 0);
        for b in (1..BINS).rev() {
            acc = acc.union(boxes[b]);
            cnt += counts[b];
            right_area[b] = acc.half_area();
            right_count[b] = cnt;
        }
        let (mut acc, mut cnt) = (Box32::EMPTY, 0);
        for b in 0..BINS - 1 {
            acc = acc.union(boxes[b]);
            cnt += counts[b];
            if cnt == 0 || right_count[b + 1] == 0 {
                continue;
            }
            let cost = acc.half_area() * f64::from(cnt)
                + right_area[b + 1] * f64::from(right_count[b + 1]);
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
            let mid = partition(items, |p| bin_of(p.centroid2()[axis], axis) <= bin);
            let bins = &boxes[axis];
            let halves = (
                bins[..=bin].iter().fold(Box32::EMPTY, |a, b| a.union(*b)),
                bins[bin + 1..]
                    .iter()
                    .fold(Box32::EMPTY, |a, b| a.union(*b)),
            );
            (mid > 0 && mid < n).then_some((mid, halves))
        }
        // All centroids coincide: split the list in halves so that leaves
        // stay small.
        None => {
            let bounds =
                |part: &[BuildPrim]| part.iter().fold(Box32::EMPTY, |b, p| b.union(p.bounds()));
            Some((n / 2, (bounds(&items[..n / 2]), bounds(&items[n / 2..]))))
        }
    }
}

fn partition(items: &mut [BuildPrim], pred: impl Fn(&BuildPrim) -> bool) -> usize {
    let mut i = 0;
    for j in 0..items.len() {
        if pred(&items[j]) {
            items.swap(i, j);
            i += 1;
        }
    }
    i
}

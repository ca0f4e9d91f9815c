//! The eight-wide hierarchy the traversals use, collapsed from the binary
//! one the build makes.

use super::{Node, WIDTH, WideNode};

/// The eight-wide hierarchy of a binary one (root first, children of an
/// interior node adjacent) whose nodes reachable from the root number
/// `used`: each wide node takes a binary node's two children and, while it
/// has fewer than [`WIDTH`], replaces its interior child with the largest
/// box by that child's two children. Returns the nodes and the number of
/// them on the longest path from the root.
pub(super) fn collapse(bin: &[Node], used: usize) -> (Vec<WideNode>, usize) {
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

//! The tree every traversal descends: the binary SAH tree collapsed so that
//! each node holds up to eight children, each of the six planes' eight values
//! stored together, so that one ray meets all eight children in one `f32x8`
//! (one AVX register, one load per plane). The binary tree's leaves stay the
//! leaves, so `Bvh::order` serves both trees.
//!
//! Which binary inner nodes become wide nodes is chosen by dynamic
//! programming so that the sum of their surface areas (the SAH cost of the
//! inner nodes) is least, as in Ylitie, Karras and Laine's compressed wide
//! BVH: a greedy collapse (open the largest child until the node is full)
//! left nodes near the bottom with few children. Where a full node could
//! make a descent hold more than `STACK` entries, the node takes fewer
//! children (`stack_bound.rs`).

use super::stack_bound::slots_within;
use super::traverse::fmin;
use super::Node;
use arrayvec::ArrayVec;

/// Children per node.
pub const WIDTH: usize = 8;

/// Up to `WIDTH` children's boxes, per axis and side (`bounds[2 * axis]` the
/// minima, `bounds[2 * axis + 1]` the maxima), and where each child is. An
/// unused slot has an empty box (`+inf..-inf`), which no ray enters: its
/// entry distance is `+inf` on every axis whatever the ray's signs. Each
/// plane's values lie together (one SIMD load); 256 bytes, four cache lines.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct WideNode {
    pub bounds: [[f32; WIDTH]; 6],
    /// Inner child: its node's index. Leaf child: its first slot in `Bvh::order`.
    pub child: [u32; WIDTH],
    /// Leaf child: its primitive count (> 0). Inner child or unused slot: 0.
    pub count: [u32; WIDTH],
}

impl WideNode {
    pub const EMPTY: WideNode = WideNode {
        bounds: [
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
        ],
        child: [0; WIDTH],
        count: [0; WIDTH],
    };
}

/// The binary tree `nodes` collapsed eight-wide with the fewest expected
/// node visits (see the module's comment), each node with as many children
/// as the traversals' stack allows. Deterministic: the same binary tree
/// gives the same wide tree.
pub fn collapse(nodes: &[Node]) -> Vec<WideNode> {
    collapse_within(nodes, super::traverse::STACK)
}

/// `collapse` for a stack of `stack` entries (`usize::MAX`: unbounded).
pub(super) fn collapse_within(nodes: &[Node], stack: usize) -> Vec<WideNode> {
    if nodes.is_empty() {
        return Vec::new();
    }
    // Children before their parents, whatever the layout.
    let mut order = Vec::with_capacity(nodes.len());
    let mut work = vec![0usize];
    while let Some(i) = work.pop() {
        order.push(i);
        if !nodes[i].is_leaf() {
            work.extend([nodes[i].first as usize, nodes[i].first as usize + 1]);
        }
    }
    // cost[n][i - 1]: the least cost of covering the subtree at `n` with at
    // most `i` children of a wide node (a leaf child costs nothing, a wide
    // node its area plus its own children's cost). height[n]: the binary
    // inner levels below `n` and `n` itself.
    let mut cost = vec![[0.0f32; WIDTH]; nodes.len()];
    let mut height = vec![0usize; nodes.len()];
    // The best split of `slots` children between `n`'s two children: its
    // cost and the left child's share.
    let split = |cost: &[[f32; WIDTH]], n: &Node, slots: usize| -> (f32, usize) {
        let (l, r) = (n.first as usize, n.first as usize + 1);
        let mut best = (f32::INFINITY, 1);
        for k in 1..slots {
            let c = cost[l][k - 1] + cost[r][slots - k - 1];
            if c < best.0 {
                best = (c, k);
            }
        }
        best
    };
    for &i in order.iter().rev() {
        let n = &nodes[i];
        if n.is_leaf() {
            continue;
        }
        let (l, r) = (n.first as usize, n.first as usize + 1);
        height[i] = 1 + height[l].max(height[r]);
        let keep = n.bounds().half_area() + split(&cost, n, WIDTH).0;
        let mut row = [keep; WIDTH];
        for (slots, c) in row.iter_mut().enumerate().skip(1) {
            *c = fmin(keep, split(&cost, n, slots + 1).0);
        }
        cost[i] = row;
    }
    collapse_by(nodes, |binary, above| {
        let slots = slots_within(stack, above, height[binary]);
        let mut kids: ArrayVec<usize, WIDTH> = ArrayVec::new();
        // Subtrees and the slots they may take, left to right.
        let mut open: ArrayVec<(usize, usize), WIDTH> = ArrayVec::new();
        open.push((binary, slots));
        while let Some((b, slots)) = open.pop() {
            let n = &nodes[b];
            let (split_cost, k) = if n.is_leaf() || slots == 1 {
                (f32::INFINITY, 0)
            } else {
                split(&cost, n, slots)
            };
            if n.is_leaf() || (b != binary && cost[b][0] <= split_cost) {
                kids.push(b);
            } else {
                open.push((n.first as usize + 1, slots - k));
                open.push((n.first as usize, k));
            }
        }
        kids
    })
}

/// The wide tree whose node at binary node `b`, with `above` entries on a
/// descent's stack when it stands there, has the children `kids_of(b,
/// above)` (binary nodes, left to right): those that are inner become wide
/// nodes in turn. A node's children are stored next to each other.
fn collapse_by(
    nodes: &[Node],
    mut kids_of: impl FnMut(usize, usize) -> ArrayVec<usize, WIDTH>,
) -> Vec<WideNode> {
    let mut out = Vec::with_capacity(nodes.len() / (WIDTH - 1) + 1);
    out.push(WideNode::EMPTY);
    // (binary node, wide node, entries above it)
    let mut work = vec![(0usize, 0usize, 0usize)];
    while let Some((binary, wide, above)) = work.pop() {
        let mut node = WideNode::EMPTY;
        let kids = kids_of(binary, above);
        // A descent that pops this node holds its siblings' entries and
        // pushes its children, all but the one it enters next.
        let below = above + kids.len() - 1;
        for (slot, k) in kids.into_iter().enumerate() {
            let n = &nodes[k];
            for axis in 0..3 {
                node.bounds[2 * axis][slot] = n.min[axis];
                node.bounds[2 * axis + 1][slot] = n.max[axis];
            }
            if n.is_leaf() {
                node.child[slot] = n.first;
                node.count[slot] = n.count();
            } else {
                node.child[slot] = out.len() as u32;
                work.push((k, out.len(), below));
                out.push(WideNode::EMPTY);
            }
        }
        out[wide] = node;
    }
    out
}

//! Why a traversal's fixed stack never overflows.
//!
//! Every descent keeps the children it will visit later on an `ArrayVec` of
//! `STACK` entries and, to stay branch-free, drops a push that finds it full
//! (`try_push`). A dropped entry is a subtree never searched: a wrong hit. So
//! no descent of the wide tree may need more than `STACK` entries.
//!
//! A descent pops a node and pushes at most all its children, so while it
//! stands at a node, the stack holds at most, for each node on the path from
//! the root, its children but the one on the path, and then the current
//! node's children: Σ (children − 1) over the path's nodes, plus one. A
//! binary tree of height `h` (inner levels) needs `h + 1`; its build bounds
//! the height (a median split past `MAX_SAH_DEPTH`: about 64 + log2 of the
//! count, well under `STACK`). An eight-wide node can add seven entries for
//! one binary level, so a deep, bushy tree (a spliced scene of instances, a
//! pathological mesh) collapsed with full nodes may pass `STACK`. The
//! collapse therefore gives a node only as many children as leave room for
//! the binary height below it (`slots_within`): near the budget its nodes
//! narrow, down to the binary tree's own two children, which always fit.

use super::WideNode;

/// The most children a wide node may take when a descent standing at it
/// holds `above` entries and the binary subtree it covers has `height`
/// inner levels, so that no descent below it needs more than `stack`
/// entries (at least two: the binary node's own children).
///
/// With `k` children, an inner child starts with `above + k - 1` entries and
/// covers at most `height - 1` levels, whose binary descent needs `height`
/// more: `above + k - 1 + height <= stack`. Every node chosen so keeps its
/// children within the same bound, and the root starts with `above = 0`.
pub(super) fn slots_within(stack: usize, above: usize, height: usize) -> usize {
    stack
        .saturating_sub(above + height)
        .saturating_add(1)
        .clamp(2, super::WIDTH)
}

/// The most stack entries a descent of the wide tree `nodes` can hold at once
/// (0 for an empty tree).
pub fn stack_need(nodes: &[WideNode]) -> usize {
    if nodes.is_empty() {
        return 0;
    }
    // Depth-first over inner nodes with the entries held above each one.
    let mut most = 0;
    let mut work = vec![(0usize, 0usize)];
    while let Some((at, above)) = work.pop() {
        let node = &nodes[at];
        let used = |c: usize| node.count[c] > 0 || node.bounds[0][c] <= node.bounds[1][c];
        let children = (0..super::WIDTH).filter(|&c| used(c)).count();
        most = most.max(above + children);
        let below = above + children.saturating_sub(1);
        for c in 0..super::WIDTH {
            if node.count[c] == 0 && used(c) {
                work.push((node.child[c] as usize, below));
            }
        }
    }
    most
}

#[cfg(test)]
mod tests {
    use super::super::collapse::collapse_within;
    use super::super::traverse::STACK;
    use super::super::{build, collapse, BuildOptions, Bvh, Node, Packet, TraversalStats, WIDTH};
    use super::*;
    use crate::math::{Aabb, Vec3};
    use crate::shapes::SurfaceHit;

    fn chain(levels: usize) -> Vec<WideNode> {
        (0..levels)
            .map(|i| {
                let mut n = WideNode::EMPTY;
                for c in 0..WIDTH {
                    n.bounds[0][c] = 0.0;
                    n.bounds[1][c] = 1.0;
                    n.child[c] = (WIDTH * i + c) as u32;
                    n.count[c] = 1;
                }
                if i + 1 < levels {
                    n.child[WIDTH - 1] = (i + 1) as u32;
                    n.count[WIDTH - 1] = 0;
                }
                n
            })
            .collect()
    }

    #[test]
    fn need_counts_the_siblings_along_the_deepest_path() {
        // Each level keeps 7 siblings; the last one pushes its 8 children.
        assert_eq!(stack_need(&chain(1)), 8);
        assert_eq!(stack_need(&chain(3)), 7 * 2 + 8);
        assert_eq!(stack_need(&[]), 0);
        // An empty slot pushes nothing.
        let mut half = chain(2);
        half[1].bounds[0][3] = f32::INFINITY;
        half[1].bounds[1][3] = f32::NEG_INFINITY;
        half[1].count[3] = 0;
        assert_eq!(stack_need(&half), 7 + 7);
        let mut one = WideNode::EMPTY;
        one.bounds[0][0] = 0.0;
        one.bounds[1][0] = 1.0;
        one.count[0] = 2;
        assert_eq!(stack_need(&[one]), 1);
    }

    /// A binary tree down a spine of `levels` nodes, children after their
    /// parents. Spine node `i` is a cube of side `4^-i` over a bush (a
    /// complete binary tree of eight leaves, the octants of a cube of half
    /// the side) in one corner and the next spine node in another: the
    /// bushes are large beside the spine below, so a full eight-wide node
    /// opens a bush into seven children and keeps one for the spine, seven
    /// entries on the stack for each binary level of the spine. Its own
    /// height is `levels + 3`.
    fn spine(levels: usize) -> Vec<Node> {
        let cube = |at: [f32; 3], side: f32, meta: u32| Node {
            min: at,
            first: 0,
            max: at.map(|a| a + side),
            meta,
        };
        // Makes node `at` an inner node over the octants of its cube, split
        // along x, then y, then z.
        fn bush(nodes: &mut Vec<Node>, at: usize, axis: usize) {
            let n = nodes[at];
            let first = nodes.len();
            for half in 0..2 {
                let mut c = n;
                let mid = 0.5 * (n.min[axis] + n.max[axis]);
                if half == 0 {
                    c.max[axis] = mid;
                } else {
                    c.min[axis] = mid;
                }
                c.meta = 1;
                nodes.push(c);
            }
            nodes[at].first = first as u32;
            nodes[at].meta = (axis as u32) << 30;
            if axis < 2 {
                bush(nodes, first, axis + 1);
                bush(nodes, first + 1, axis + 1);
            }
        }
        let mut nodes = vec![cube([0.0; 3], 1.0, 1)];
        let mut at = 0;
        for level in 0..levels {
            let side = 0.25f32.powi(level as i32);
            let first = nodes.len();
            nodes.push(cube([0.5 * side; 3], 0.5 * side, 1));
            nodes.push(cube([0.0; 3], 0.25 * side, 1));
            bush(&mut nodes, first, 0);
            nodes[at].first = first as u32;
            nodes[at].meta = 0;
            at = first + 1;
        }
        nodes
    }

    #[test]
    fn a_bushy_spine_collapses_within_the_stack() {
        let nodes = spine(20);
        // The premise: full nodes would overflow the stack, the binary tree not.
        let full = collapse_within(&nodes, usize::MAX);
        assert!(stack_need(&full) > STACK, "{}", stack_need(&full));
        let wide = collapse(&nodes);
        assert!(stack_need(&wide) <= STACK, "{}", stack_need(&wide));
        // Only the nodes near the budget narrowed.
        assert!(
            wide.len() < 2 * full.len(),
            "{} against {}",
            wide.len(),
            full.len()
        );
    }

    /// On a descent: a ray along the spine's diagonal, from just outside
    /// the root's corner, enters every bush, the deepest first; it meets the
    /// bushes' leaves (solid cubes) but not the spine's last leaf (a sliver
    /// in its cube's corner, which it enters first of all). Full nodes
    /// overflow the stack and drop the deepest bushes' children (stacked
    /// last, as the nearest), so the ray reports a farther hit: the premise,
    /// that the overflow is real and harmful. The narrowed nodes keep the
    /// nearest hit.
    #[test]
    fn the_narrowed_tree_keeps_the_nearest_hit_the_full_one_loses() {
        let mut nodes = spine(20);
        let mut boxes = Vec::new();
        for n in nodes.iter_mut().filter(|n| n.is_leaf()) {
            n.first = boxes.len() as u32;
            boxes.push(n.bounds());
        }
        // The spine's last leaf: the one cube at the origin.
        let sliver =
            (boxes.iter().position(|b| b.min == Vec3::ZERO)).expect("the spine's last leaf") as u32;
        let (o, d) = (Vec3::splat(-1e-13), Vec3::ONE);
        let test = |prim: u32, _: usize, t_max: f32| {
            let b = &boxes[prim as usize];
            let (t0, t1) = ((b.min - o).max_element(), (b.max - o).min_element());
            (prim != sliver && t0 <= t1 && t0 < t_max).then_some(SurfaceHit {
                t: t0,
                u: 0.0,
                v: 0.0,
            })
        };
        let nearest = (0..boxes.len() as u32)
            .filter_map(|p| test(p, 0, f32::INFINITY).map(|h| (p, h.t)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(p, _)| p);
        let traced = |wide: Vec<WideNode>| {
            let bvh = Bvh {
                order: (0..boxes.len() as u32).collect(),
                nodes: nodes.clone(),
                wide,
                ..Bvh::default()
            };
            let hits = bvh.closest(&Packet::ray(o, d), &mut TraversalStats::default(), test);
            hits.has_hit(0).then_some(hits.prim[0])
        };
        assert!(nearest.is_some());
        assert_ne!(traced(collapse_within(&nodes, usize::MAX)), nearest);
        assert_eq!(traced(collapse(&nodes)), nearest);
    }

    #[test]
    fn built_trees_collapse_with_full_nodes() {
        let mut rng = fastrand::Rng::with_seed(7);
        let boxes: Vec<Aabb> = (0..20_000)
            .map(|_| {
                let c = glam::Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 100.0;
                Aabb {
                    min: c,
                    max: c + glam::Vec3::splat(0.3),
                }
            })
            .collect();
        let bvh = build(&boxes, &BuildOptions::default());
        assert!(stack_need(&bvh.wide) <= STACK);
        assert_eq!(bvh.wide, collapse_within(&bvh.nodes, usize::MAX));
    }
}

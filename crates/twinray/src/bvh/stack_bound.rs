//! Why a traversal's fixed stack never overflows.
//!
//! Every descent keeps the children it will visit later on an `ArrayVec` of
//! `STACK` entries and, to stay branch-free, drops a push that finds it full
//! (`try_push`). A dropped entry is a subtree never searched: a wrong hit. So
//! a tree is only traversed if no descent can need more than `STACK` entries.
//!
//! A descent pops a node and pushes at most all its children, so while it
//! stands at a node, the stack holds at most, for each inner node on the path
//! from the root, its children but the one on the path, and then the current
//! node's children: Σ (children − 1) over the path's inner nodes, plus one.
//! The binary tree's depth is bounded by its build (a median split past
//! `MAX_SAH_DEPTH`, so about 64 + log2 of the count); a wide tree collapsed
//! from it can need up to W − 1 entries per level, and a deep, bushy tree
//! (a spliced scene of instances, or a pathological mesh) may pass `STACK`.
//! Such a tree is dropped: the traversals then use the next narrower tree
//! (eight-wide → four-wide → binary), which give the same hits.

use super::traverse::STACK;
use super::{Bvh, WideNode};

/// The most stack entries a descent of the wide tree `nodes` can hold at once
/// (0 for an empty tree).
pub fn stack_need<const W: usize>(nodes: &[WideNode<W>]) -> usize {
    if nodes.is_empty() {
        return 0;
    }
    // Depth-first over inner nodes with the entries held above each one.
    let mut most = 0;
    let mut work = vec![(0usize, 0usize)];
    while let Some((at, above)) = work.pop() {
        let node = &nodes[at];
        let children = (0..W)
            .filter(|&c| node.count[c] > 0 || node.bounds[0][c] <= node.bounds[1][c])
            .count();
        most = most.max(above + children);
        let below = above + children.saturating_sub(1);
        for c in 0..W {
            let inner = node.count[c] == 0 && node.bounds[0][c] <= node.bounds[1][c];
            if inner {
                work.push((node.child[c] as usize, below));
            }
        }
    }
    most
}

impl Bvh {
    /// Drops a wide tree whose descent could need more stack entries than
    /// the traversals hold (see the module's comment); the narrower trees
    /// then serve its rays with the same hits. Returns whether one was.
    pub fn drop_trees_beyond_stack(&mut self) -> bool {
        let mut dropped = false;
        if stack_need(&self.wide8) > STACK {
            self.wide8 = Vec::new();
            dropped = true;
        }
        if stack_need(&self.wide) > STACK {
            self.wide = Vec::new();
            dropped = true;
        }
        dropped
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::{build, BuildOptions, Node4, Node8};
    use crate::math::Aabb;

    fn chain8(levels: usize) -> Vec<Node8> {
        (0..levels)
            .map(|i| {
                let mut n = Node8::EMPTY;
                for c in 0..8 {
                    n.bounds[0][c] = 0.0;
                    n.bounds[1][c] = 1.0;
                    n.child[c] = (8 * i + c) as u32;
                    n.count[c] = 1;
                }
                if i + 1 < levels {
                    n.child[7] = (i + 1) as u32;
                    n.count[7] = 0;
                }
                n
            })
            .collect()
    }

    #[test]
    fn need_counts_the_siblings_along_the_deepest_path() {
        // Each level keeps 7 siblings; the last one pushes its 8 children.
        assert_eq!(stack_need(&chain8(1)), 8);
        assert_eq!(stack_need(&chain8(3)), 7 * 2 + 8);
        assert_eq!(stack_need::<4>(&[]), 0);
        // An empty slot pushes nothing.
        let mut half = chain8(2);
        half[1].bounds[0][3] = f32::INFINITY;
        half[1].bounds[1][3] = f32::NEG_INFINITY;
        half[1].count[3] = 0;
        assert_eq!(stack_need(&half), 7 + 7);
        let mut one = Node4::EMPTY;
        one.bounds[0][0] = 0.0;
        one.bounds[1][0] = 1.0;
        one.count[0] = 2;
        assert_eq!(stack_need(&[one]), 1);
    }

    #[test]
    fn built_trees_fit_and_a_deep_chain_is_dropped() {
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
        let mut bvh = build(&boxes, &BuildOptions::default());
        assert!(stack_need(&bvh.wide8) <= STACK && stack_need(&bvh.wide) <= STACK);
        assert!(!bvh.drop_trees_beyond_stack());
        assert!(!bvh.wide8.is_empty() && !bvh.wide.is_empty());
        bvh.wide8 = chain8(STACK / 7 + 1);
        assert!(bvh.drop_trees_beyond_stack());
        assert!(bvh.wide8.is_empty() && !bvh.wide.is_empty());
    }
}

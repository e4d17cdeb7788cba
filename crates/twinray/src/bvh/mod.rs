//! The bounding-volume hierarchy: a binned-SAH build (`build.rs`) of a
//! binary tree, collapsed eight-wide (`collapse.rs`), and the traversals the
//! renderer needs (`traverse.rs`, descending the wide tree as `descent.rs`
//! says): nearest hit for a packet of rays (one lane per view: the paper's
//! twin objects, realised as the views' rays traced as one), and any hit for
//! packets of shadow rays.
//!
//! The hierarchy holds boxes and a permutation of primitive indices, and asks
//! a `NearestTest` or `AnyHitTest` to test primitives; the one thing it keeps
//! of shapes is its leaves of triangles as SIMD blocks (`leaf.rs`), which a
//! caller attaches.

#[cfg(test)]
pub(crate) mod brute_force;
mod build;
mod collapse;
mod descent;
mod leaf;
mod region;
mod splice;
mod stack_bound;
mod traverse;

pub use build::{build_pieces, primitive_box, BuildOptions, PAD};
pub use collapse::{collapse, WideNode, WIDTH};
pub use descent::EYE_PACKET;
pub use region::Region;
pub use splice::{splice, Placed};
pub use stack_bound::stack_need;
pub use traverse::{
    segment_enters, AnyHit, AnyHitTest, NearestTest, Packet, PacketHits, SegmentPacket,
    TraversalStats,
};

use crate::math::Aabb;
use crate::shapes::LeafBlocks;

/// 32 bytes, two to a cache line. Inner nodes keep their children next to each
/// other at `first` and `first + 1`; leaves own `count` primitive slots
/// starting at `first`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub struct Node {
    pub min: [f32; 3],
    pub first: u32,
    pub max: [f32; 3],
    /// Leaf: primitive count (> 0). Inner: 0 in the low 30 bits and the split
    /// axis in the top two bits (the near child is chosen by the ray's sign on it).
    pub meta: u32,
}

impl Node {
    #[inline]
    pub fn is_leaf(&self) -> bool {
        self.meta & 0x3fff_ffff != 0
    }

    #[inline]
    pub fn count(&self) -> u32 {
        self.meta & 0x3fff_ffff
    }

    #[inline]
    pub fn axis(&self) -> usize {
        (self.meta >> 30) as usize
    }

    pub fn bounds(&self) -> Aabb {
        Aabb {
            min: self.min.into(),
            max: self.max.into(),
        }
    }
}

#[derive(Clone, Debug, Default)]
pub struct Bvh {
    pub nodes: Vec<Node>,
    /// Primitive indices in leaf order: leaf slots `first..first+count` index
    /// this. Slots between leaves hold `PAD` (a tree built for blocks).
    pub order: Vec<u32>,
    /// The same tree collapsed eight-wide (`collapse.rs`), which every
    /// traversal descends; empty only where `nodes` is, or for a tree that is
    /// never traversed (an instance's, before the splice).
    pub wide: Vec<WideNode>,
    /// The leaves made only of triangles as SIMD blocks, by slot
    /// (`Bvh::attach_blocks`); empty: every leaf is tested one by one.
    pub blocks: LeafBlocks,
}

/// Builds a hierarchy over primitives with the given boxes (`build.rs`'s
/// binned SAH), and its eight-wide form.
pub fn build(boxes: &[Aabb], opts: &BuildOptions) -> Bvh {
    build::build(boxes, opts)
}

/// `build` over `n` primitives whose bounds `bounds(i)` gives (called once
/// for each, on all threads), with the options `opts` returns once every
/// bound has been asked for: the same tree as `build` over those boxes.
pub fn build_by(
    n: usize,
    bounds: impl Fn(usize) -> Aabb + Sync,
    opts: impl FnOnce() -> BuildOptions,
) -> Bvh {
    build::build_by(n, bounds, opts)
}

impl Bvh {
    pub fn bounds(&self) -> Aabb {
        self.nodes
            .first()
            .map(|n| n.bounds())
            .unwrap_or(Aabb::EMPTY)
    }

    /// Depth of the deepest leaf (root = 1), for statistics.
    pub fn depth(&self) -> usize {
        fn walk(b: &Bvh, i: usize) -> usize {
            let n = &b.nodes[i];
            if n.is_leaf() {
                1
            } else {
                1 + walk(b, n.first as usize).max(walk(b, n.first as usize + 1))
            }
        }
        if self.nodes.is_empty() {
            0
        } else {
            walk(self, 0)
        }
    }

    /// The primitives of each leaf, as slices of `order`.
    pub fn leaves(&self) -> impl Iterator<Item = &[u32]> + '_ {
        self.nodes.iter().filter(|n| n.is_leaf()).map(|n| {
            let first = n.first as usize;
            &self.order[first..first + n.count() as usize]
        })
    }

    /// Each leaf's first slot and its primitives.
    pub fn leaf_slots(&self) -> impl Iterator<Item = (usize, &[u32])> + '_ {
        self.nodes.iter().filter(|n| n.is_leaf()).map(|n| {
            let first = n.first as usize;
            (first, &self.order[first..first + n.count() as usize])
        })
    }

    /// Primitives in the tree (the order's slots without the padding).
    pub fn primitive_count(&self) -> usize {
        self.order.iter().filter(|&&p| p != PAD).count()
    }

    /// Memory held by the hierarchy, in bytes.
    pub fn memory_bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<Node>()
            + self.wide.len() * std::mem::size_of::<WideNode>()
            + self.order.len() * 4
            + self.blocks.memory_bytes()
    }
}

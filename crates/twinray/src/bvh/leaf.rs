//! The leaf tests of every descent, nearest or any hit, a lane alone or in
//! a packet: a leaf's primitives one by one, or its
//! triangles as SIMD blocks (`shapes::Triangle4`) where the tree holds them;
//! a ray alone meets a leaf's blocks two at a time in one eight-wide test
//! (`Triangle4::intersect_two`) where its test takes them so.
//!
//! A leaf of triangles in a tree built for blocks (`BuildOptions::block`)
//! starts at a slot that is a multiple of `BLOCK`, so its blocks are found
//! from the node's first slot and count alone (`LeafBlocks::of_leaf`).
//!
//! Exactness: a block's lane `i` is `Triangle::intersect` of the leaf's
//! primitive `i`, bit for bit, and its hits are offered in index order with
//! the scalar path's rules, so a lane's nearest hit (ties to the lower
//! index) and the primitives an any-hit test meets (in order, up to the stop)
//! are what the one-by-one tests give.

use super::traverse::LaneHit;
use super::{AnyHit, AnyHitTest, Bvh, NearestTest, PacketHits, TraversalStats};
use crate::shapes::{BlockHits, LeafBlocks, Shape, Triangle4, BLOCK};
use wide::f32x8;

/// A leaf: its primitives, and their blocks if the tree holds them so (one
/// per `BLOCK` primitives, in order), else none.
#[derive(Clone, Copy)]
pub(super) struct Leaf<'a> {
    pub(super) prims: &'a [u32],
    pub(super) blocks: &'a [Triangle4],
}

impl<'a> Leaf<'a> {
    /// The primitives of block `k`.
    #[inline(always)]
    fn block_prims(&self, k: usize) -> &'a [u32] {
        let end = (BLOCK * (k + 1)).min(self.prims.len());
        &self.prims[BLOCK * k..end]
    }
}

impl Bvh {
    /// The leaf at slots `first..first + count`.
    #[inline(always)]
    pub(super) fn leaf(&self, first: u32, count: u32) -> Leaf<'_> {
        let (first, count) = (first as usize, count as usize);
        Leaf {
            prims: &self.order[first..first + count],
            blocks: self.blocks.of_leaf(first, count),
        }
    }

    /// Makes the blocks of the leaves of triangles (`shapes` indexed by the
    /// order's primitive indices); leaves that do not start a block, or hold
    /// another shape, keep the scalar tests.
    pub fn attach_blocks(&mut self, shapes: &[Shape]) {
        self.blocks = LeafBlocks::new(shapes, self.order.len(), self.leaf_slots());
    }
}

/// `b`'s hits on the primitives `prims` (the block's, at most `BLOCK`)
/// offered to `state`, in index order.
#[inline(always)]
fn offer_block(prims: &[u32], b: &BlockHits, state: &mut LaneHit) {
    for (i, h) in b.first(prims.len()) {
        state.offer(prims[i], h);
    }
}

/// One lane against a leaf, improving `state`. Blocks are tested with the
/// bound from before the leaf; `offer` then refuses what a smaller bound
/// found on the way would have refused, so the hit is the one the
/// primitives tested one by one give.
#[inline(always)]
pub(super) fn leaf_lane<T: NearestTest>(
    leaf: Leaf,
    lane: usize,
    state: &mut LaneHit,
    test: &mut T,
) {
    // next_up lets an equal distance through, for the index tie-break.
    let bound = state.best.next_up();
    // Two blocks at a time in one eight-wide test, where the test takes them.
    for (j, chunk) in leaf.blocks.chunks(2).enumerate() {
        if let Ok(two) = <&[Triangle4; 2]>::try_from(chunk) {
            if let Some(found) = test.test_two_blocks(two, lane, bound) {
                for (i, b) in found.iter().enumerate() {
                    offer_block(leaf.block_prims(2 * j + i), b, state);
                }
                continue;
            }
        }
        for (i, block) in chunk.iter().enumerate() {
            let prims = leaf.block_prims(2 * j + i);
            match test.test_block(block, lane, bound) {
                Some(b) => offer_block(prims, &b, state),
                None => scalar_lane(prims, lane, state, test),
            }
        }
    }
    if leaf.blocks.is_empty() {
        scalar_lane(leaf.prims, lane, state, test);
    }
}

/// The lanes `lanes` of a packet of eight against a leaf of spheres and
/// cones (no blocks), primitive by primitive, all the lanes at once where
/// the test takes them (`NearestTest::test_lanes`), each lane's nearest hit
/// improved in `best` and `out` as `leaf_lane` improves it: a lane meets the
/// primitives in the same order with the same bounds. Returns the lane
/// tests made together.
#[inline(always)]
pub(super) fn leaf_lanes_at_once<T: NearestTest>(
    prims: &[u32],
    lanes: u32,
    best: &mut [f32; 8],
    out: &mut PacketHits<8>,
    test: &mut T,
) -> u64 {
    let mut in_lanes = 0;
    for &prim in prims {
        let bounds = f32x8::from(best.map(f32::next_up));
        let found = test.test_lanes(prim, lanes, bounds);
        if found.is_some() {
            in_lanes += lanes.count_ones() as u64;
        }
        let mut each = lanes;
        while each != 0 {
            let l = each.trailing_zeros() as usize;
            each &= each - 1;
            let hit = match &found {
                Some(h) => h.hit(l),
                None => test.test(prim, l, best[l].next_up()),
            };
            if let Some(h) = hit {
                if h.t < best[l] || (h.t == best[l] && prim < out.prim[l]) {
                    best[l] = h.t;
                    out.prim[l] = prim;
                    out.hit[l] = h;
                }
            }
        }
    }
    in_lanes
}

#[inline(always)]
fn scalar_lane<T: NearestTest>(prims: &[u32], lane: usize, state: &mut LaneHit, test: &mut T) {
    for &prim in prims {
        if let Some(h) = test.test(prim, lane, state.best.next_up()) {
            state.offer(prim, h);
        }
    }
}

/// One segment (lane `lane`) against one block of a leaf (its primitives
/// `prims`): whether `test` said stop. The block's hits are met in index
/// order, up to the first stop, as one by one.
#[inline(always)]
fn block_lane<T: AnyHitTest>(block: &Triangle4, prims: &[u32], lane: usize, test: &mut T) -> bool {
    match test.test_block(block, prims, lane) {
        Some(a) => a == AnyHit::Stop,
        None => prims.iter().any(|&p| test.test(p, lane) == AnyHit::Stop),
    }
}

/// One segment (lane `lane`) against a leaf, until `test` says stop: returns
/// whether it did, and counts the primitives tested in `prims_tested`.
#[inline(always)]
pub(super) fn occlusion_lane<T: AnyHitTest>(
    leaf: Leaf,
    lane: usize,
    prims_tested: &mut u64,
    test: &mut T,
) -> bool {
    for (k, block) in leaf.blocks.iter().enumerate() {
        let prims = leaf.block_prims(k);
        *prims_tested += prims.len() as u64;
        if block_lane(block, prims, lane, test) {
            return true;
        }
    }
    if leaf.blocks.is_empty() {
        for &prim in leaf.prims {
            *prims_tested += 1;
            if test.test(prim, lane) == AnyHit::Stop {
                return true;
            }
        }
    }
    false
}

/// The lanes `mask` of a shadow packet (`pair`: of two lanes) against a
/// leaf; a lane leaves `live` when `test` says stop for it.
#[inline(always)]
pub(super) fn occlusion_leaf<T: AnyHitTest>(
    leaf: Leaf,
    pair: bool,
    mask: u32,
    live: &mut u32,
    stats: &mut TraversalStats,
    test: &mut T,
) {
    if leaf.blocks.is_empty() {
        occlusion_prims(leaf.prims, pair, mask, live, stats, test);
        return;
    }
    for (k, block) in leaf.blocks.iter().enumerate() {
        let prims = leaf.block_prims(k);
        let lanes = mask & *live;
        if lanes == 0 {
            return;
        }
        stats.prim_tests += (prims.len() * lanes.count_ones() as usize) as u64;
        if pair && lanes == 0b11 {
            if let Some(both) = test.test_block_pair(block, prims) {
                // Both segments of a stereo pair against the block at once.
                for (l, a) in both.into_iter().enumerate() {
                    if a == AnyHit::Stop {
                        *live &= !(1 << l);
                    }
                }
                continue;
            }
        }
        let mut each = lanes;
        while each != 0 {
            let l = each.trailing_zeros() as usize;
            each &= each - 1;
            if block_lane(block, prims, l, test) {
                *live &= !(1 << l);
            }
        }
    }
}

/// The live lanes of `mask` against `prims` one by one (a pair's both
/// lanes against each primitive at once, and more lanes too where the test
/// takes them, `test_lanes`), each test counted: a lane that stopped tests
/// no further primitive, as alone (`occlusion_lane`).
#[inline(always)]
fn occlusion_prims<T: AnyHitTest>(
    prims: &[u32],
    pair: bool,
    mask: u32,
    live: &mut u32,
    stats: &mut TraversalStats,
    test: &mut T,
) {
    for &prim in prims {
        let lanes = mask & *live;
        if lanes == 0 {
            return;
        }
        stats.prim_tests += lanes.count_ones() as u64;
        if pair && lanes == 0b11 {
            for (l, a) in test.test_pair(prim).into_iter().enumerate() {
                if a == AnyHit::Stop {
                    *live &= !(1 << l);
                }
            }
            continue;
        }
        if lanes & (lanes - 1) != 0 {
            // Two lanes or more: all at once where the test takes them.
            if let Some(stopped) = test.test_lanes(prim, lanes) {
                *live &= !stopped;
                stats.prim_tests_in_lanes += lanes.count_ones() as u64;
                continue;
            }
        }
        let mut each = lanes;
        while each != 0 {
            let l = each.trailing_zeros() as usize;
            each &= each - 1;
            if test.test(prim, l) == AnyHit::Stop {
                *live &= !(1 << l);
            }
        }
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::super::{build, BuildOptions, PAD};
    use super::*;
    use crate::math::{Aabb, Vec3};
    use crate::shapes::{Triangle, TriangleNormals};

    /// A wavy height field of `n` x `n` quads, two triangles each (also the
    /// descents' test scene).
    pub(in crate::bvh) fn terrain(n: usize) -> Vec<Shape> {
        let v = |i: usize, j: usize| {
            let (x, y) = (i as f32, j as f32);
            Vec3::new(x, y, (x * 0.37).sin() * (y * 0.23).cos())
        };
        let tri = |a: Vec3, b: Vec3, c: Vec3| {
            let nrm = (b - a).cross(c - a).normalize_or_zero();
            Shape::Triangle(Triangle::new(a, b, c, nrm, TriangleNormals::Flat))
        };
        (0..n * n)
            .flat_map(|k| {
                let (i, j) = (k % n, k / n);
                let (a, b, c, d) = (v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1));
                [tri(a, b, c), tri(a, c, d)]
            })
            .collect()
    }

    fn tree(shapes: &[Shape], opts: &BuildOptions) -> Bvh {
        let boxes: Vec<Aabb> = shapes.iter().map(Shape::bounds).collect();
        let mut bvh = build(&boxes, opts);
        bvh.attach_blocks(shapes);
        bvh
    }

    /// The SAH counted in blocks fills them: on a mesh, every triangle is in
    /// a block, blocks hold 3.5 triangles on average (per-primitive leaves:
    /// under 2.5), every leaf starts a block and holds at most two, and the
    /// tree with its blocks takes fewer bytes per triangle.
    #[test]
    fn leaves_costed_in_blocks_fill_them() {
        let shapes = terrain(120);
        let n = shapes.len();
        let blocked = tree(&shapes, &BuildOptions::triangle_blocks());
        let aligned = tree(&shapes, &BuildOptions::aligned());
        for bvh in [&blocked, &aligned] {
            assert_eq!(bvh.blocks.triangles(), n, "every triangle in a block");
            assert_eq!(bvh.primitive_count(), n);
            assert_eq!(bvh.order.len() % BLOCK, 0);
            for (first, prims) in bvh.leaf_slots() {
                assert_eq!(first % BLOCK, 0);
                assert!(!prims.contains(&PAD));
                assert_eq!(
                    bvh.blocks.of_leaf(first, prims.len()).len(),
                    prims.len().div_ceil(BLOCK)
                );
            }
        }
        assert!(blocked.leaf_slots().all(|(_, p)| p.len() <= 2 * BLOCK));
        let fill = |b: &Bvh| n as f64 / b.blocks.len() as f64;
        assert!(
            fill(&blocked) >= 3.5,
            "blocks hold {:.2} triangles",
            fill(&blocked)
        );
        assert!(fill(&aligned) < 2.5, "per primitive: {:.2}", fill(&aligned));
        let bytes = |b: &Bvh| b.memory_bytes() as f64 / n as f64;
        assert!(
            bytes(&blocked) < 0.6 * bytes(&aligned),
            "{:.1} against {:.1} bytes per triangle",
            bytes(&blocked),
            bytes(&aligned)
        );
        assert!(
            bytes(&blocked) < 100.0,
            "{:.1} bytes per triangle",
            bytes(&blocked)
        );
    }

    /// The tree (binary and wide) is the same whatever the
    /// number of threads: the images do not depend on it (ties go to the
    /// lower index of a leaf order).
    #[test]
    fn the_tree_is_the_same_on_one_two_and_five_threads() {
        let shapes = terrain(240);
        let boxes: Vec<Aabb> = shapes.iter().map(Shape::bounds).collect();
        assert!(
            boxes.len() > 100_000,
            "large enough to bin on several threads"
        );
        let on = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("thread pool");
            pool.install(|| build(&boxes, &BuildOptions::triangle_blocks()))
        };
        let one = on(1);
        assert!(one.wide.len() > 1000);
        for threads in [2, 5] {
            let other = on(threads);
            assert_eq!(other.nodes, one.nodes, "{threads} threads");
            assert_eq!(other.order, one.order, "{threads} threads");
            assert_eq!(other.wide, one.wide, "{threads} threads");
        }
    }
}

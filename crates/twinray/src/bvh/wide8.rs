//! The eight-wide hierarchy: the binary SAH tree collapsed so that each node
//! holds up to eight children (`collapse8`), each plane's eight values stored together, so
//! that one ray meets all eight children in one `f32x8` (one AVX register, one
//! load per plane). Rays traced alone take it: eye rays, secondary rays and
//! shadow segments of one lane, and each ray of a stereo pair's nearest-hit
//! packet, and each lane of wider packets (`Bvh::closest`). Shadow pairs go
//! down it in one descent (`wide8_pair.rs`), and so do eight eye rays
//! (`wide8_eye.rs`) and up to eight shadow segments toward one light
//! (`wide8_shadow.rs`) with the rays in the lanes; docs/benchmarks.md ("Issue 17,
//! fourth pass", "Issues 16 and 17, fifth pass", "Issue 17, sixth pass") has
//! the measurements.
//!
//! Exactness: as in `wide.rs`, a child's slab test is per register lane the
//! binary descent's, with its arithmetic (the planes picked by the ray's signs,
//! one multiply and one subtract per plane, then `maxps`/`minps` in the binary
//! test's order), on the binary tree's boxes. So culling is as conservative as
//! there (`CULL_SLACK`), a ray's nearest hit (ties to the lower primitive
//! index) is the one it gets on any tree, and a segment that `segment_enters`
//! a primitive's box reaches the primitive's leaf. Leaves are tested by
//! `leaf.rs`, as on the other trees.

use super::leaf::{leaf_lane, occlusion_lane};
use super::traverse::{LaneHit, SingleRay, CULL_SLACK, NO_SURFACE, ROBUST, STACK};
use super::wide::{collapse_sah, take_nearest, wide_ray, Entry, WideNode};
use super::TraversalStats;
use super::{AnyHitTest, Bvh, NearestTest, Node, Packet, PacketHits, SegmentPacket};
use crate::shapes::SurfaceHit;
use arrayvec::ArrayVec;
use wide::f32x8;

/// Children per node of the eight-wide tree.
pub const WIDTH8: usize = 8;

/// A node of the eight-wide tree (256 bytes: four cache lines).
pub type Node8 = WideNode<WIDTH8>;

/// The binary tree `nodes` collapsed eight-wide (`collapse_sah`: it fills
/// the nodes near the bottom better than the greedy collapse).
pub fn collapse8(nodes: &[Node]) -> Vec<Node8> {
    collapse_sah::<WIDTH8>(nodes)
}

// One ray prepared for the eight-wide slab test.
wide_ray!(Ray8, f32x8, WIDTH8);

impl Bvh {
    /// `closest` with each active lane traced alone on the eight-wide tree
    /// (which must exist): each lane's nearest hit, ties to the lower index.
    #[inline]
    pub fn closest_each_wide8<const K: usize>(
        &self,
        packet: &Packet<K>,
        stats: &mut TraversalStats,
        mut test: impl NearestTest,
    ) -> PacketHits<K> {
        let mut out = PacketHits::<K>::none();
        if self.wide8.is_empty() {
            return out;
        }
        let mut lanes = packet.mask & ((1u64 << K) - 1) as u32;
        while lanes != 0 {
            let l = lanes.trailing_zeros() as usize;
            lanes &= lanes - 1;
            let ray = SingleRay::new(packet.origins[l], packet.dirs[l], packet.t_min);
            let mut state = LaneHit {
                best: packet.t_max[l],
                prim: PacketHits::<K>::NO_HIT,
                hit: NO_SURFACE,
            };
            let root = Entry {
                child: 0,
                count: 0,
                tn: ray.t_min,
            };
            self.wide8_single(root, &ray, &mut state, stats, &mut test, l);
            out.prim[l] = state.prim;
            out.hit[l] = state.hit;
        }
        out
    }

    /// `closest_each_wide8` for a packet of one lane, for callers that trace
    /// rays one at a time (the mono eye pass): lane 0's nearest hit, or
    /// `None` when there is no eight-wide tree. Inlined, so the answer stays
    /// in registers: returned through memory, its reload stalled on the
    /// stores that wrote it (docs/benchmarks.md, "Issue 17, sixth pass").
    #[inline(always)]
    pub fn closest_one_wide8(
        &self,
        packet: &Packet<1>,
        stats: &mut TraversalStats,
        mut test: impl NearestTest,
    ) -> Option<(u32, SurfaceHit)> {
        if self.wide8.is_empty() {
            return None;
        }
        let mut state = LaneHit {
            best: packet.t_max[0],
            prim: PacketHits::<1>::NO_HIT,
            hit: NO_SURFACE,
        };
        if packet.mask & 1 != 0 {
            let ray = SingleRay::new(packet.origins[0], packet.dirs[0], packet.t_min);
            let root = Entry {
                child: 0,
                count: 0,
                tn: ray.t_min,
            };
            self.wide8_single(root, &ray, &mut state, stats, &mut test, 0);
        }
        Some((state.prim, state.hit))
    }

    /// One ray's nearest-hit descent of the eight-wide subtree at `start`
    /// (the root, or where a pair's descent hands over a lane), improving
    /// `state`: the nearest entered child next, the others stacked farthest
    /// first, each popped only if it is entered before the nearest hit so far.
    #[inline(always)]
    pub(super) fn wide8_single<T: NearestTest>(
        &self,
        start: Entry,
        ray: &SingleRay,
        state: &mut LaneHit,
        stats: &mut TraversalStats,
        test: &mut T,
        lane: usize,
    ) {
        let wray = Ray8::new(ray);
        let mut lh = *state;
        let (mut nodes, mut prims) = (0u64, 0u64);
        let mut inner = 0u64;
        let mut stack = ArrayVec::<Entry, STACK>::new();
        let mut current = (start.tn <= lh.best * CULL_SLACK).then_some(start);
        while let Some(Entry { child, count, .. }) = current {
            nodes += 1;
            if count > 0 {
                prims += count as u64;
                leaf_lane(self.leaf(child, count), lane, &mut lh, test);
            } else {
                let node = &self.wide8[child as usize];
                inner += 1;
                let (m, t) = wray.enter(node, lh.best);
                if m != 0 {
                    current = Some(take_nearest(&mut stack, m, &t, |c| Entry {
                        child: node.child[c],
                        count: node.count[c],
                        tn: t[c],
                    }));
                    continue;
                }
            }
            current = None;
            while let Some(e) = stack.pop() {
                if e.tn <= lh.best * CULL_SLACK {
                    current = Some(e);
                    break;
                }
            }
        }
        *state = lh;
        stats.nodes += nodes;
        stats.box_tests += inner * WIDTH8 as u64;
        stats.prim_tests += prims;
    }

    /// Any-hit per lane (see `occlusion_binary` for the contract) on the
    /// eight-wide tree (which must exist), each active lane's segment alone.
    pub fn occlusion_wide8<const K: usize>(
        &self,
        packet: &SegmentPacket<K>,
        stats: &mut TraversalStats,
        test: &mut impl AnyHitTest,
    ) {
        if self.wide8.is_empty() {
            return;
        }
        let mut lanes = packet.mask & ((1u64 << K) - 1) as u32;
        while lanes != 0 {
            let l = lanes.trailing_zeros() as usize;
            lanes &= lanes - 1;
            let ray = SingleRay::new(packet.origins[l], packet.dirs[l], 0.0);
            self.wide8_occlusion_single((0, 0), &ray, packet.t_max[l], stats, test, l);
        }
    }

    /// One segment's any-hit descent of the eight-wide subtree at `start`
    /// (`(child, count)`: the root `(0, 0)`, or where a pair's descent hands
    /// over a lane); returns whether `test` said stop. Children are visited
    /// in slot order.
    #[inline(always)]
    pub(super) fn wide8_occlusion_single<T: AnyHitTest>(
        &self,
        start: (u32, u32),
        ray: &SingleRay,
        t_max: f32,
        stats: &mut TraversalStats,
        test: &mut T,
        lane: usize,
    ) -> bool {
        let wray = Ray8::new(ray);
        let (mut nodes, mut inner, mut prims) = (0u64, 0u64, 0u64);
        let mut stopped = false;
        let mut stack = ArrayVec::<(u32, u32), STACK>::new();
        stack.push(start);
        while let Some((child, count)) = stack.pop() {
            nodes += 1;
            if count > 0 {
                if occlusion_lane(self.leaf(child, count), lane, &mut prims, test) {
                    stopped = true;
                    break;
                }
                continue;
            }
            let node = &self.wide8[child as usize];
            inner += 1;
            let mut m = wray.enters(node, t_max);
            while m != 0 {
                let c = 31 - m.leading_zeros() as usize;
                m &= !(1 << c);
                let _ = stack.try_push((node.child[c], node.count[c]));
            }
        }
        stats.nodes += nodes;
        stats.box_tests += inner * WIDTH8 as u64;
        stats.prim_tests += prims;
        stopped
    }
}

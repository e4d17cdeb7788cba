//! The descents of the eight-wide tree: a ray's nearest hit and a segment's
//! any hit, each alone; up to eight rays' nearest hits in one descent; and
//! several segments' any hits in one descent, a stereo pair's two or up to
//! eight (`Segments`: the node and leaf tests are what differ).
//!
//! A ray alone meets a node's eight children in one `f32x8` slab test
//! (`WideRay`), keeps the nearest entered child in hand and stacks the others
//! farthest first, sorted by their entry distances (`take_nearest`); a popped
//! entry is dropped if it begins beyond the nearest hit × `CULL_SLACK`. Any
//! hit pushes the entered children in slot order and stops at the test's
//! first `Stop`.
//!
//! Rays in one descent: neighbouring samples' rays leave one eye a fraction
//! of a pixel apart, and a group's shadow segments start a little apart and
//! end at one light, so they enter nearly the same nodes: a node is fetched
//! once for all of them. Up to eight rays sit in the lanes of one `f32x8`
//! (`RayLanes`) and each child is tested against all of them at once; a
//! stereo pair's two segments each meet the eight children in one register.
//! A child is stacked with the lanes that entered it (and, for nearest hits,
//! their entry distances); a lane leaves at a pop when its own nearest hit
//! is nearer than its own entry, or when its any-hit test said stop; a
//! subtree only one lane entered is finished by that lane's descent alone,
//! so the packet pays lane bookkeeping only where it shares a node. Leaves
//! are tested by `leaf.rs`: spheres and cones for all the lanes at once
//! where the test takes them (`test_lanes`), triangle blocks lane by lane,
//! a pair's two segments against a block in one register.
//!
//! Exactness: per lane, the slab test is the single ray's (`SingleRay`'s
//! numbers; the same planes, picked by direction signs all the lanes of a
//! packet share or the packet is refused; the same operations in the same
//! order, `plane * inv - org`, then `maxps`/`minps` as `fmax`/`fmin`), on the
//! binary tree's boxes. A lane is carried into a child only by its own test
//! and culled only as conservatively as alone, so its nearest hit (ties to
//! the lower index) is the one it gets alone, whatever the order a packet
//! visits nodes in; and a segment reaches every leaf it reaches alone: the
//! objects it meets are the same set, or an opaque one stops it.

use super::collapse::{WideNode, WIDTH};
use super::leaf::{leaf_lane, leaf_lanes_at_once, occlusion_lane, occlusion_leaf, Leaf};
use super::traverse::{LaneHit, SingleRay, CULL_SLACK, ROBUST, STACK};
use super::{AnyHitTest, Bvh, NearestTest, Packet, PacketHits, SegmentPacket, TraversalStats};
use arrayvec::ArrayVec;
use wide::f32x8;

/// Rays in a packet of one descent.
pub const EYE_PACKET: usize = 8;

/// Rays prepared for slab tests in one register: per axis, which of a
/// node's bound arrays is the entry plane and which the exit plane (picked
/// by the direction signs all the rays share), and per register lane a ray's
/// `SingleRay` numbers. One ray splatted meets a node's eight children at
/// once (`WideRay`); up to eight rays, one per lane, meet one child at once
/// (`RayLanes`).
#[derive(Clone, Copy)]
struct Slabs {
    near: [usize; 3],
    far: [usize; 3],
    inv: [f32x8; 3],
    org: [f32x8; 3],
    t_min: f32x8,
}

impl Slabs {
    /// For rays whose direction signs are `neg`, lane `l` of each register
    /// `lane(|r| ..)` picking ray `l`'s number.
    #[inline(always)]
    fn new(neg: [bool; 3], lane: impl Fn(&dyn Fn(&SingleRay) -> f32) -> f32x8) -> Slabs {
        let side = |a: usize| neg[a] as usize;
        Slabs {
            near: [0, 1, 2].map(|a| 2 * a + side(a)),
            far: [0, 1, 2].map(|a| 2 * a + 1 - side(a)),
            inv: [0, 1, 2].map(|a| lane(&|s| s.inv[a])),
            org: [0, 1, 2].map(|a| lane(&|s| s.origin[a])),
            t_min: lane(&|s| s.t_min),
        }
    }

    /// Entry and exit distances for the boxes whose bound arrays `plane(i)`
    /// gives per lane: per lane `SingleRay::slabs`' arithmetic.
    #[inline(always)]
    fn slabs(&self, plane: impl Fn(usize) -> f32x8) -> (f32x8, f32x8) {
        let at = |i: usize, a: usize| plane(i) * self.inv[a] - self.org[a];
        let (nx, ny, nz) = (
            at(self.near[0], 0),
            at(self.near[1], 1),
            at(self.near[2], 2),
        );
        let (fx, fy, fz) = (at(self.far[0], 0), at(self.far[1], 1), at(self.far[2], 2));
        // `fast_max(a, b)` is `maxps(a, b)`: `a > b ? a : b`, i.e. `fmax(a, b)`.
        let tn = nx.fast_max(ny).fast_max(nz.fast_max(self.t_min));
        let tf = fx.fast_min(fy).fast_min(fz) * f32x8::splat(ROBUST);
        (tn, tf)
    }
}

/// One ray against a node's eight children in one register.
#[derive(Clone, Copy)]
struct WideRay(Slabs);

impl WideRay {
    #[inline(always)]
    fn new(r: &SingleRay) -> WideRay {
        WideRay(Slabs::new(r.neg, |f| f32x8::splat(f(r))))
    }

    /// The children a ray enters before `best * CULL_SLACK`, as a bit mask,
    /// and their entry distances.
    #[inline(always)]
    fn enter(&self, node: &WideNode, best: f32) -> (u32, [f32; WIDTH]) {
        let (tn, tf) = self.0.slabs(|i| f32x8::from(node.bounds[i]));
        let bound = f32x8::splat(best * CULL_SLACK);
        let m = (tn.simd_le(tf) & tn.simd_le(bound)).to_bitmask();
        (m, tn.to_array())
    }

    /// The children a segment `0 < t < t_max` enters, as a bit mask
    /// (`segment_enters` per lane).
    #[inline(always)]
    fn enters(&self, node: &WideNode, t_max: f32) -> u32 {
        let (tn, tf) = self.0.slabs(|i| f32x8::from(node.bounds[i]));
        tn.simd_le(tf.fast_min(f32x8::splat(t_max))).to_bitmask()
    }
}

/// Up to eight rays, one per lane, against one child in one register.
struct RayLanes(Slabs);

impl RayLanes {
    /// `None` where the active lanes' direction signs differ.
    #[inline(always)]
    fn new(singles: &[SingleRay; EYE_PACKET], mask: u32) -> Option<RayLanes> {
        let neg = singles[mask.trailing_zeros() as usize].neg;
        let mut lanes = mask;
        while lanes != 0 {
            let l = lanes.trailing_zeros() as usize;
            lanes &= lanes - 1;
            if singles[l].neg != neg {
                return None;
            }
        }
        Some(RayLanes(Slabs::new(neg, |f| {
            f32x8::from(std::array::from_fn::<f32, EYE_PACKET, _>(
                |l| f(&singles[l]),
            ))
        })))
    }

    /// The rays that enter child `c` of `node` before `bound` (their
    /// nearest hits so far times `CULL_SLACK`, or their segments' ends), as
    /// a lane mask, and their entry distances.
    #[inline(always)]
    fn enter(&self, node: &WideNode, c: usize, bound: f32x8) -> (u32, f32x8) {
        let (tn, tf) = self.0.slabs(|i| f32x8::splat(node.bounds[i][c]));
        ((tn.simd_le(tf) & tn.simd_le(bound)).to_bitmask(), tn)
    }
}

/// A ray's stack entry: a child (`count` > 0: a leaf) entered at `tn`.
#[derive(Clone, Copy)]
pub(super) struct Entry {
    child: u32,
    count: u32,
    tn: f32,
}

impl Entry {
    /// The root, for `ray` (entered at its `t_min`).
    #[inline(always)]
    pub(super) fn root(ray: &SingleRay) -> Entry {
        Entry {
            child: 0,
            count: 0,
            tn: ray.t_min,
        }
    }
}

/// The children in `mask` by `key` (their entry distances): returns the
/// nearest's entry and stacks the others' so that they pop nearest first.
#[inline(always)]
fn take_nearest<E: Copy>(
    stack: &mut ArrayVec<E, STACK>,
    mask: u32,
    key: &[f32; WIDTH],
    entry: impl Fn(usize) -> E,
) -> E {
    let a = mask.trailing_zeros() as usize;
    let rest = mask & (mask - 1);
    if rest == 0 {
        return entry(a);
    }
    let b = rest.trailing_zeros() as usize;
    let rest = rest & (rest - 1);
    let (near, far) = if key[b] < key[a] { (b, a) } else { (a, b) };
    if rest == 0 {
        let _ = stack.try_push(entry(far));
        return entry(near);
    }
    // Three or more: sorted by insertion (nearest first), stacked farthest first.
    let mut sorted = [near; WIDTH];
    sorted[1] = far;
    let mut n = 2;
    let mut bits = rest;
    while bits != 0 {
        let c = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        let mut i = n;
        while i > 0 && key[sorted[i - 1]] > key[c] {
            sorted[i] = sorted[i - 1];
            i -= 1;
        }
        sorted[i] = c;
        n += 1;
    }
    for &c in sorted[1..n].iter().rev() {
        let _ = stack.try_push(entry(c));
    }
    entry(sorted[0])
}

/// A packet's stack entry: a child (`count` > 0: a leaf), the rays that
/// entered it and their entry distances.
#[derive(Clone, Copy)]
struct PacketEntry {
    tn: f32x8,
    child: u32,
    count: u32,
    lanes: u32,
}

impl Bvh {
    /// One ray's nearest-hit descent of the subtree at `start` (the root, or
    /// where a packet hands over its last lane), improving `state`: the
    /// nearest entered child next, the others stacked farthest first, each
    /// popped only if it is entered before the nearest hit so far.
    #[inline(always)]
    pub(super) fn closest_one<T: NearestTest>(
        &self,
        start: Entry,
        ray: &SingleRay,
        state: &mut LaneHit,
        stats: &mut TraversalStats,
        test: &mut T,
        lane: usize,
    ) {
        let wray = WideRay::new(ray);
        let mut lh = *state;
        let (mut nodes, mut inner, mut prims) = (0u64, 0u64, 0u64);
        let mut stack = ArrayVec::<Entry, STACK>::new();
        let mut current = (start.tn <= lh.best * CULL_SLACK).then_some(start);
        while let Some(Entry { child, count, .. }) = current {
            nodes += 1;
            if count > 0 {
                prims += count as u64;
                leaf_lane(self.leaf(child, count), lane, &mut lh, test);
            } else {
                let node = &self.wide[child as usize];
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
        stats.box_tests += inner * WIDTH as u64;
        stats.prim_tests += prims;
    }

    /// One segment's any-hit descent of the subtree at `start` (`(child,
    /// count)`: the root `(0, 0)`, or where a packet hands over its last
    /// live lane); returns whether `test` said stop. Children are visited in
    /// slot order.
    #[inline(always)]
    pub(super) fn occlusion_one<T: AnyHitTest>(
        &self,
        start: (u32, u32),
        ray: &SingleRay,
        t_max: f32,
        stats: &mut TraversalStats,
        test: &mut T,
        lane: usize,
    ) -> bool {
        let wray = WideRay::new(ray);
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
            let node = &self.wide[child as usize];
            inner += 1;
            let mut m = wray.enters(node, t_max);
            while m != 0 {
                let c = 31 - m.leading_zeros() as usize;
                m &= !(1 << c);
                let _ = stack.try_push((node.child[c], node.count[c]));
            }
        }
        stats.nodes += nodes;
        stats.box_tests += inner * WIDTH as u64;
        stats.prim_tests += prims;
        stopped
    }

    /// Nearest hit per lane of up to eight rays in one descent (see the
    /// module's comment); `None`, the test untouched, where the packet does
    /// not apply (no lane, or the active lanes' direction signs differ).
    /// Inlined into its callers: the eye rays' loop measured 5–10 % slower
    /// with the descent behind a call that took the prepared rays by
    /// reference.
    #[inline(always)]
    pub(super) fn closest_packet<T: NearestTest>(
        &self,
        packet: &Packet<EYE_PACKET>,
        stats: &mut TraversalStats,
        test: &mut T,
    ) -> Option<PacketHits<EYE_PACKET>> {
        let mask = packet.mask & 0xff;
        if self.wide.is_empty() || mask == 0 {
            return None;
        }
        let singles: [SingleRay; EYE_PACKET] = std::array::from_fn(|l| {
            SingleRay::new(packet.origins[l], packet.dirs[l], packet.t_min)
        });
        let rays = RayLanes::new(&singles, mask)?;
        let mut out = PacketHits::<EYE_PACKET>::none();
        let mut best = packet.t_max;
        let slack = f32x8::splat(CULL_SLACK);
        let mut bound = f32x8::from(best) * slack;
        let (mut nodes, mut boxes, mut prims, mut in_lanes) = (0u64, 0u64, 0u64, 0u64);
        let mut stack = ArrayVec::<PacketEntry, STACK>::new();
        let mut current = Some(PacketEntry {
            tn: rays.0.t_min,
            child: 0,
            count: 0,
            lanes: mask,
        });
        while let Some(e) = current.take() {
            // A ray whose nearest hit is now nearer than its entry skips it.
            let lanes = e.lanes & e.tn.simd_le(bound).to_bitmask();
            if lanes != 0 && lanes & (lanes - 1) == 0 {
                // One ray left in this subtree: finish it as a plain ray.
                let l = lanes.trailing_zeros() as usize;
                let start = Entry {
                    child: e.child,
                    count: e.count,
                    tn: e.tn.to_array()[l],
                };
                let mut state = LaneHit::of(l, &best, &out);
                self.closest_one(start, &singles[l], &mut state, stats, test, l);
                state.store(l, &mut best, &mut out);
                bound = f32x8::from(best) * slack;
            } else if lanes != 0 && e.count > 0 {
                nodes += 1;
                let leaf = self.leaf(e.child, e.count);
                if leaf.blocks.is_empty() {
                    // Spheres and cones: primitive by primitive, the lanes
                    // at once (`leaf_lanes_at_once`).
                    prims += (e.count * lanes.count_ones()) as u64;
                    in_lanes += leaf_lanes_at_once(leaf.prims, lanes, &mut best, &mut out, test);
                    bound = f32x8::from(best) * slack;
                    current = stack.pop();
                    continue;
                }
                let mut ls = lanes;
                while ls != 0 {
                    let l = ls.trailing_zeros() as usize;
                    ls &= ls - 1;
                    prims += e.count as u64;
                    let mut state = LaneHit::of(l, &best, &out);
                    leaf_lane(leaf, l, &mut state, test);
                    state.store(l, &mut best, &mut out);
                }
                bound = f32x8::from(best) * slack;
            } else if lanes != 0 {
                nodes += 1;
                let node = &self.wide[e.child as usize];
                boxes += (WIDTH as u64) * lanes.count_ones() as u64;
                let mut masks = [0u32; WIDTH];
                let mut tns = [f32x8::ZERO; WIDTH];
                let mut key = [0.0f32; WIDTH];
                let mut entered = 0u32;
                for c in 0..WIDTH {
                    if node.child[c] == 0 && node.count[c] == 0 {
                        continue; // an unused slot (no ray enters its empty box)
                    }
                    let (m, tn) = rays.enter(node, c, bound);
                    let m = m & lanes;
                    if m != 0 {
                        masks[c] = m;
                        tns[c] = tn;
                        key[c] = tn.to_array()[m.trailing_zeros() as usize];
                        entered |= 1 << c;
                    }
                }
                if entered != 0 {
                    current = Some(take_nearest(&mut stack, entered, &key, |c| PacketEntry {
                        tn: tns[c],
                        child: node.child[c],
                        count: node.count[c],
                        lanes: masks[c],
                    }));
                    continue;
                }
            }
            current = stack.pop();
        }
        stats.nodes += nodes;
        stats.box_tests += boxes;
        stats.prim_tests += prims;
        stats.prim_tests_in_lanes += in_lanes;
        Some(out)
    }

    /// Any hit per lane of a stereo pair's two segments (`K == 2`, both
    /// lanes active) in one descent.
    pub(super) fn occlusion_pair<const K: usize>(
        &self,
        packet: &SegmentPacket<K>,
        stats: &mut TraversalStats,
        test: &mut impl AnyHitTest,
    ) {
        let singles = [0, 1 % K].map(|l| SingleRay::new(packet.origins[l], packet.dirs[l], 0.0));
        let t_max = [packet.t_max[0], packet.t_max[1 % K]];
        let pair = PairSegments {
            rays: [WideRay::new(&singles[0]), WideRay::new(&singles[1])],
            t_max,
        };
        self.occlusion_lanes(&pair, (&singles, &t_max), 0b11, stats, test);
    }

    /// Any hit per lane of up to eight segments (`K <= 8`) in one descent.
    /// Returns `false`, having done nothing, where the packet does not apply
    /// (more than eight lanes, none active, or the active segments'
    /// direction signs differ): the caller traces the segments alone.
    pub(super) fn occlusion_packet<const K: usize>(
        &self,
        packet: &SegmentPacket<K>,
        stats: &mut TraversalStats,
        test: &mut impl AnyHitTest,
    ) -> bool {
        let mask = packet.mask & ((1u64 << K.min(32)) - 1) as u32;
        if K > EYE_PACKET || mask == 0 {
            return false;
        }
        let singles: [SingleRay; EYE_PACKET] = std::array::from_fn(|l| {
            let l = if l < K { l } else { 0 };
            SingleRay::new(packet.origins[l], packet.dirs[l], 0.0)
        });
        let Some(rays) = RayLanes::new(&singles, mask) else {
            return false;
        };
        let t_max: [f32; EYE_PACKET] =
            std::array::from_fn(|l| if l < K { packet.t_max[l] } else { 0.0 });
        let eight = EightSegments {
            rays,
            ends: f32x8::from(t_max),
        };
        self.occlusion_lanes(&eight, (&singles, &t_max), mask, stats, test);
        true
    }

    /// The segments `mask` of `segs` in one any-hit descent: a child is
    /// stacked with the live lanes whose segments enter it; a lane leaves
    /// when its test says stop. `alone`: each lane's segment prepared alone
    /// and its end, for a subtree one lane finishes by itself.
    #[inline(always)]
    fn occlusion_lanes<S: Segments, T: AnyHitTest>(
        &self,
        segs: &S,
        alone: (&[SingleRay], &[f32]),
        mask: u32,
        stats: &mut TraversalStats,
        test: &mut T,
    ) {
        let (mut nodes, mut boxes) = (0u64, 0u64);
        let mut live = mask;
        let mut stack = LaneStack::new();
        stack.push((0, 0, mask));
        while let Some((child, count, entered)) = stack.pop() {
            let lanes = entered & live;
            if lanes == 0 {
                continue;
            }
            if lanes & (lanes - 1) == 0 {
                // One live segment in this subtree: finish it alone.
                let l = lanes.trailing_zeros() as usize;
                let (ray, t_max) = (&alone.0[l], alone.1[l]);
                if self.occlusion_one((child, count), ray, t_max, stats, test, l) {
                    live &= !lanes;
                    if live == 0 {
                        break;
                    }
                }
                continue;
            }
            nodes += 1;
            if count > 0 {
                segments_leaf::<S, T>(self.leaf(child, count), lanes, &mut live, stats, test);
                if live == 0 {
                    break;
                }
                continue;
            }
            boxes += segs.push_entered(&self.wide[child as usize], lanes, &mut stack);
        }
        stats.nodes += nodes;
        stats.box_tests += boxes;
    }
}

/// An any-hit descent's stack of children (`count` > 0: a leaf) and the
/// lanes that entered each.
type LaneStack = ArrayVec<(u32, u32, u32), STACK>;

/// Segments that go down one any-hit descent together, one per lane: how a
/// node's children and a leaf meet them.
trait Segments {
    /// Stacks the children of `node` that the lanes `lanes` enter, each with
    /// the lanes that enter it, so that they pop in slot order; returns the
    /// box tests made.
    fn push_entered(&self, node: &WideNode, lanes: u32, stack: &mut LaneStack) -> u64;

    /// A stereo pair's two segments, which meet a leaf's triangle block at
    /// once (`AnyHitTest::test_block_pair`); otherwise a block meets the
    /// lanes one by one.
    const PAIR: bool;
}

/// The lanes `lanes` of `S` against a leaf; a lane whose test says stop
/// leaves `live`. Spheres and cones primitive by primitive, the lanes
/// together (a pair's two, or up to eight through `test_lanes`). Each lane
/// meets the primitives in the order it meets them alone.
#[inline(always)]
fn segments_leaf<S: Segments, T: AnyHitTest>(
    leaf: Leaf,
    lanes: u32,
    live: &mut u32,
    stats: &mut TraversalStats,
    test: &mut T,
) {
    if S::PAIR || leaf.blocks.is_empty() {
        occlusion_leaf(leaf, S::PAIR, lanes, live, stats, test);
        return;
    }
    let mut each = lanes;
    while each != 0 {
        let l = each.trailing_zeros() as usize;
        each &= each - 1;
        if occlusion_lane(leaf, l, &mut stats.prim_tests, test) {
            *live &= !(1 << l);
        }
    }
}

/// A stereo pair's two segments: each meets a node's eight children in one
/// register, and a leaf's block, or primitive, meets both at once.
struct PairSegments {
    rays: [WideRay; 2],
    t_max: [f32; 2],
}

impl Segments for PairSegments {
    const PAIR: bool = true;

    #[inline(always)]
    fn push_entered(&self, node: &WideNode, _lanes: u32, stack: &mut LaneStack) -> u64 {
        let m0 = self.rays[0].enters(node, self.t_max[0]);
        let m1 = self.rays[1].enters(node, self.t_max[1]);
        let mut any = m0 | m1;
        while any != 0 {
            let c = 31 - any.leading_zeros() as usize;
            any &= !(1 << c);
            let lanes = (m0 >> c) & 1 | ((m1 >> c) & 1) << 1;
            let _ = stack.try_push((node.child[c], node.count[c], lanes));
        }
        2 * WIDTH as u64
    }
}

/// Up to eight segments toward one light in the lanes of one register:
/// each child meets all of them at once.
struct EightSegments {
    rays: RayLanes,
    /// The segments' ends, per lane.
    ends: f32x8,
}

impl Segments for EightSegments {
    const PAIR: bool = false;

    #[inline(always)]
    fn push_entered(&self, node: &WideNode, lanes: u32, stack: &mut LaneStack) -> u64 {
        for c in (0..WIDTH).rev() {
            if node.child[c] == 0 && node.count[c] == 0 {
                continue; // an unused slot (no segment enters its empty box)
            }
            let (m, _) = self.rays.enter(node, c, self.ends);
            let m = m & lanes;
            if m != 0 {
                let _ = stack.try_push((node.child[c], node.count[c], m));
            }
        }
        WIDTH as u64 * lanes.count_ones() as u64
    }
}

#[cfg(test)]
mod tests {
    use super::super::brute_force::{met, occluders, random_packet, random_shapes, segments_of};
    use super::super::{build, primitive_box, AnyHit, BuildOptions};
    use super::*;
    use crate::math::{Aabb, Vec3};
    use crate::shapes::{Shape, Triangle, TriangleNormals};

    /// The leaf tests' wavy height field of `n` x `n` quads, with poles
    /// (thin upright triangles) standing on it.
    fn terrain(n: usize) -> Vec<Shape> {
        let height = |x: f32, y: f32| (x * 0.37).sin() * (y * 0.23).cos();
        let mut shapes = super::super::leaf::tests::terrain(n);
        for k in 0..n {
            let (x, y) = (k as f32, ((k * 7) % n) as f32);
            let foot = Vec3::new(x + 0.5, y + 0.5, height(x, y) - 0.5);
            let (b, c) = (
                foot + Vec3::new(0.01, 0.0, 0.0),
                foot + Vec3::new(0.0, 0.0, 4.0),
            );
            let nrm = (b - foot).cross(c - foot).normalize_or_zero();
            shapes.push(Shape::Triangle(Triangle::new(
                foot,
                b,
                c,
                nrm,
                TriangleNormals::Flat,
            )));
        }
        shapes
    }

    fn tree(shapes: &[Shape], opts: &BuildOptions) -> Bvh {
        let boxes: Vec<Aabb> = shapes.iter().map(Shape::bounds).collect();
        let mut bvh = build(&boxes, opts);
        bvh.attach_blocks(shapes);
        bvh
    }

    /// `K` segments, all lanes active: from points a little apart (the eyes
    /// of a group's views seeing one spot) to one light, each its own
    /// length; or grazing the corners of random primitives' boxes from near
    /// and far, some ending just past the corner; or random.
    fn segments<const K: usize>(rng: &mut fastrand::Rng, boxes: &[Aabb]) -> SegmentPacket<K> {
        let all = ((1u64 << K) - 1) as u32;
        match rng.u8(..4) {
            0 => SegmentPacket {
                mask: all,
                ..segments_of(&random_packet::<K>(rng))
            },
            1 => {
                let from = Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() + 0.2)
                    * [40.0, 200.0, 1e4][rng.usize(..3)];
                let b = primitive_box(&boxes[rng.usize(..boxes.len())]);
                let pick = |lo: f32, hi: f32, rng: &mut fastrand::Rng| {
                    if rng.bool() {
                        lo
                    } else {
                        hi
                    }
                };
                let corner = Vec3::new(
                    pick(b.min.x, b.max.x, rng),
                    pick(b.min.y, b.max.y, rng),
                    pick(b.min.z, b.max.z, rng),
                );
                let origins: [Vec3; K] =
                    std::array::from_fn(|l| from + Vec3::X * (0.05 * l as f32));
                let to = origins.map(|o| corner + Vec3::splat(1e-4) - o);
                SegmentPacket {
                    origins,
                    dirs: to.map(Vec3::normalize),
                    t_max: to.map(|t| t.length() * [1.0001, 0.5 + rng.f32()][rng.usize(..2)]),
                    mask: all,
                }
            }
            _ => {
                let spot = Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5) * 20.0;
                let light = Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32()) * 30.0;
                let step = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 0.05;
                let origins: [Vec3; K] = std::array::from_fn(|l| spot + step * l as f32);
                SegmentPacket {
                    origins,
                    dirs: origins.map(|o| (light - o).normalize()),
                    t_max: origins.map(|o| (light - o).length()),
                    mask: all,
                }
            }
        }
    }

    /// An any-hit test as the checks hand it to a descent.
    type Meets<'a> = dyn FnMut(u32, usize) -> AnyHit + 'a;

    /// `count` packets of `K` segments in one descent (`one`: `false`
    /// where it refused the packet) against each segment alone and against
    /// brute force: every lane meets every primitive on its segment, and,
    /// stopping at its first, is blocked exactly when one exists. Returns
    /// the lanes that met something and the packets refused.
    fn check<const K: usize>(
        shapes: &[Shape],
        bvh: &Bvh,
        seed: u64,
        count: usize,
        one: impl Fn(&SegmentPacket<K>, &mut Meets) -> bool,
    ) -> (usize, usize) {
        let boxes: Vec<Aabb> = shapes.iter().map(Shape::bounds).collect();
        let mut rng = fastrand::Rng::with_seed(seed);
        let (mut lanes_met, mut refused) = (0, 0);
        for n in 0..count {
            let segs = segments::<K>(&mut rng, &boxes);
            for stop in [false, true] {
                let mut applied = true;
                let got = met(shapes, &segs, stop, |test| applied = one(&segs, test));
                if !applied {
                    refused += 1;
                    continue;
                }
                let alone = met(shapes, &segs, stop, |mut test| {
                    for l in 0..K {
                        let ray = SingleRay::new(segs.origins[l], segs.dirs[l], 0.0);
                        let st = &mut TraversalStats::default();
                        bvh.occlusion_one((0, 0), &ray, segs.t_max[l], st, &mut test, l);
                    }
                });
                for l in 0..K {
                    let what = format!("{K} lanes, packet {n}, lane {l}, stop {stop}");
                    let all = occluders(shapes, &segs, l);
                    if stop {
                        // Which object stops a lane may depend on the
                        // order; whether one does may not.
                        assert_eq!(got[l].len(), usize::from(!all.is_empty()), "{what}");
                        assert_eq!(got[l].len(), alone[l].len(), "{what}");
                    } else {
                        assert_eq!(got[l], all, "{what}: brute force");
                        assert_eq!(got[l], alone[l], "{what}: alone");
                        lanes_met += usize::from(!all.is_empty());
                    }
                }
            }
        }
        (lanes_met, refused)
    }

    /// A stereo pair's segments in one descent, and packets of four and
    /// eight segments in one descent, meet lane by lane what each segment
    /// meets alone and what brute force says: on random shapes of every
    /// kind (scalar leaves) and on a mesh with poles (leaves as triangle
    /// blocks), toward a light, grazing boxes' corners and at random.
    #[test]
    fn segments_in_one_descent_meet_what_they_meet_alone_and_by_brute_force() {
        let mut rng = fastrand::Rng::with_seed(41);
        let shapes = random_shapes(&mut rng, 400);
        let mesh = terrain(24);
        for (shapes, bvh) in [
            (&shapes, tree(&shapes, &BuildOptions::default())),
            (&mesh, tree(&mesh, &BuildOptions::triangle_blocks())),
        ] {
            let pair = |s: &SegmentPacket<2>, mut t: &mut Meets| {
                bvh.occlusion_pair(s, &mut TraversalStats::default(), &mut t);
                true
            };
            let (met, _) = check(shapes, &bvh, 5, 600, pair);
            assert!(met > 200, "pairs: {met} lanes met something");
            check_packets::<4>(shapes, &bvh, 6, 600);
            check_packets::<8>(shapes, &bvh, 7, 300);
        }
    }

    /// `check` for `count` packets of `K` segments in one descent
    /// (`occlusion_packet`): enough lanes met something, and not every
    /// packet was refused.
    fn check_packets<const K: usize>(shapes: &[Shape], bvh: &Bvh, seed: u64, count: usize) {
        let one = |s: &SegmentPacket<K>, mut t: &mut Meets| {
            bvh.occlusion_packet(s, &mut TraversalStats::default(), &mut t)
        };
        let (met, refused) = check(shapes, bvh, seed, count, one);
        assert!(
            met > 200 && refused < count,
            "{K} lanes: {met} met, {refused} refused"
        );
    }

    /// Coherent segments share their nodes: a pair, and a packet of four,
    /// toward one light visit fewer nodes in one descent than alone.
    #[test]
    fn segments_in_one_descent_visit_fewer_nodes_than_alone() {
        let mesh = terrain(24);
        let bvh = tree(&mesh, &BuildOptions::triangle_blocks());
        let light = Vec3::new(30.0, -20.0, 40.0);
        let (mut pair, mut four, mut alone) = (
            TraversalStats::default(),
            TraversalStats::default(),
            TraversalStats::default(),
        );
        for k in 0..400 {
            let spot = Vec3::new((k % 20) as f32 + 0.3, (k / 20) as f32 + 0.6, 0.0);
            let origins: [Vec3; 4] = std::array::from_fn(|l| spot + Vec3::X * (0.01 * l as f32));
            let segs = SegmentPacket {
                origins,
                dirs: origins.map(|o| (light - o).normalize()),
                t_max: origins.map(|o| (light - o).length()),
                mask: 0b1111,
            };
            let mut go = |_: u32, _: usize| AnyHit::Continue;
            assert!(bvh.occlusion_packet(&segs, &mut four, &mut go));
            let two = SegmentPacket {
                origins: [origins[0], origins[1]],
                dirs: [segs.dirs[0], segs.dirs[1]],
                t_max: [segs.t_max[0], segs.t_max[1]],
                mask: 0b11,
            };
            bvh.occlusion_pair(&two, &mut pair, &mut go);
            for (l, &o) in origins.iter().enumerate() {
                let ray = SingleRay::new(o, segs.dirs[l], 0.0);
                bvh.occlusion_one((0, 0), &ray, segs.t_max[l], &mut alone, &mut go, l);
            }
        }
        assert!(
            pair.nodes * 2 < alone.nodes && four.nodes * 3 < alone.nodes,
            "nodes: pairs {}, fours {}, each of four alone {}",
            pair.nodes,
            four.nodes,
            alone.nodes
        );
    }
}

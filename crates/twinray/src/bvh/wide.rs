//! The four-wide hierarchy (traversed where there is no eight-wide tree:
//! every ray takes the eight-wide tree, `wide8.rs`, alone or, a stereo
//! pair's shadow segments, in one descent, `wide8_pair.rs`): the binary SAH tree
//! collapsed so that each node holds up to four children, their boxes in
//! structure-of-arrays layout, so that one ray meets all four in one SIMD
//! stream (`wide::f32x4`, SSE on x86-64). Children are visited nearest first.
//!
//! Exactness: a child's slab test is, per register lane, the binary descent's
//! test with its arithmetic (the entry and exit planes picked by the ray's
//! signs, then the same `max`/`min` in the same order, which `maxps`/`minps`
//! compute as `fmax`/`fmin` do), and the boxes are the binary tree's. So the
//! culling is as conservative as there (`CULL_SLACK`), a lane's nearest hit —
//! ties to the lower primitive index — is what it is alone or in any packet,
//! and a segment that `segment_enters` a primitive's box reaches the primitive
//! (the shadow cache relies on it).

use super::leaf::{leaf_lane, occlusion_lane, occlusion_leaf, test_leaf};
use super::traverse::{fmin, LaneHit, SingleRay, CULL_SLACK, NO_SURFACE, ROBUST, STACK};
use super::{
    AnyHitTest, Bvh, NearestTest, Packet, PacketHits, SegmentPacket, TraversalStats, EYE_PACKET,
};
use crate::math::Vec3;
use arrayvec::ArrayVec;
use wide::{f32x4, f32x8};

/// Children per node.
pub const WIDTH: usize = 4;

/// Up to `W` children's boxes, per axis and side (`bounds[2 * axis]` the
/// minima, `bounds[2 * axis + 1]` the maxima), and where each child is. An
/// unused slot has an empty box (`+inf..-inf`), which no ray enters: its entry
/// distance is `+inf` on every axis whatever the ray's signs. Each plane's
/// `W` values lie together (one SIMD load), the node on cache lines of its own.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct WideNode<const W: usize> {
    pub bounds: [[f32; W]; 6],
    /// Inner child: its node's index. Leaf child: its first slot in `Bvh::order`.
    pub child: [u32; W],
    /// Leaf child: its primitive count (> 0). Inner child or unused slot: 0.
    pub count: [u32; W],
}

/// A node of the four-wide tree (128 bytes).
pub type Node4 = WideNode<WIDTH>;

impl<const W: usize> WideNode<W> {
    pub(super) const EMPTY: WideNode<W> = WideNode {
        bounds: [
            [f32::INFINITY; W],
            [f32::NEG_INFINITY; W],
            [f32::INFINITY; W],
            [f32::NEG_INFINITY; W],
            [f32::INFINITY; W],
            [f32::NEG_INFINITY; W],
        ],
        child: [0; W],
        count: [0; W],
    };
}

/// The binary tree `nodes` collapsed four-wide (`collapse_to`).
pub fn collapse(nodes: &[super::Node]) -> Vec<Node4> {
    collapse_to::<WIDTH>(nodes)
}

/// The binary tree `nodes` collapsed `W`-wide: each wide node takes a binary
/// node's children and opens the largest (by surface area) inner one among
/// them until there are `W`. Leaves are the binary leaves, so `order` serves
/// every tree.
pub fn collapse_to<const W: usize>(nodes: &[super::Node]) -> Vec<WideNode<W>> {
    collapse_by(nodes, |binary| {
        let root = &nodes[binary];
        let mut kids: ArrayVec<usize, W> = ArrayVec::new();
        if root.is_leaf() {
            kids.push(binary);
        } else {
            kids.push(root.first as usize);
            kids.push(root.first as usize + 1);
        }
        while kids.len() < W {
            let open = kids
                .iter()
                .enumerate()
                .filter(|(_, &k)| !nodes[k].is_leaf())
                .max_by(|(_, &a), (_, &b)| {
                    let (a, b) = (nodes[a].bounds().half_area(), nodes[b].bounds().half_area());
                    a.total_cmp(&b)
                })
                .map(|(i, _)| i);
            let Some(i) = open else { break };
            let first = nodes[kids[i]].first as usize;
            kids[i] = first;
            kids.insert(i + 1, first + 1);
        }
        kids
    })
}

/// The binary tree `nodes` collapsed `W`-wide with the fewest expected node
/// visits: the binary leaves stay leaves, and which binary inner nodes become
/// wide nodes is chosen by dynamic programming to minimise the sum of their
/// surface areas (the surface-area heuristic's cost of the inner nodes; the
/// leaves' cost is the same in every collapse), as in Ylitie, Karras and
/// Laine's compressed wide BVH. The greedy `collapse_to` leaves nodes near
/// the bottom with few children. Deterministic: the same binary tree gives
/// the same wide tree.
pub fn collapse_sah<const W: usize>(nodes: &[super::Node]) -> Vec<WideNode<W>> {
    // cost[n][i - 1]: the least cost of covering the subtree at `n` with at
    // most `i` children of a wide node (a leaf child costs nothing, a wide
    // node its area plus its own children's cost). Children come after their
    // parent in `nodes`, so a reverse sweep sees them first (were they not,
    // the collapse would only be worse, never wrong).
    let mut cost = vec![[0.0f32; W]; nodes.len()];
    // The best split of `slots` children between `n`'s two children: its
    // cost and the left child's share.
    let split = |cost: &[[f32; W]], n: &super::Node, slots: usize| -> (f32, usize) {
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
    for i in (0..nodes.len()).rev() {
        let n = &nodes[i];
        if n.is_leaf() {
            continue;
        }
        let keep = n.bounds().half_area() + split(&cost, n, W).0;
        let mut row = [keep; W];
        for (slots, c) in row.iter_mut().enumerate().skip(1) {
            *c = fmin(keep, split(&cost, n, slots + 1).0);
        }
        cost[i] = row;
    }
    collapse_by(nodes, |binary| {
        let mut kids: ArrayVec<usize, W> = ArrayVec::new();
        // Subtrees and the slots they may take, left to right.
        let mut open: ArrayVec<(usize, usize), W> = ArrayVec::new();
        open.push((binary, W));
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

/// The wide tree whose node at binary node `b` has the children
/// `kids_of(b)` (binary nodes, left to right): those that are inner become
/// wide nodes in turn. A node's children are stored next to each other.
fn collapse_by<const W: usize>(
    nodes: &[super::Node],
    mut kids_of: impl FnMut(usize) -> ArrayVec<usize, W>,
) -> Vec<WideNode<W>> {
    if nodes.is_empty() {
        return Vec::new();
    }
    let mut out = Vec::with_capacity(nodes.len() / (W - 1) + 1);
    out.push(WideNode::EMPTY);
    let mut work = vec![(0usize, 0usize)];
    while let Some((binary, wide)) = work.pop() {
        let mut node = WideNode::EMPTY;
        for (slot, k) in kids_of(binary).into_iter().enumerate() {
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
                work.push((k, out.len()));
                out.push(WideNode::EMPTY);
            }
        }
        out[wide] = node;
    }
    out
}

/// One ray prepared for a `W`-wide slab test (`$name`, registers `$simd`, nodes
/// `WideNode<$w>`): per axis, which of a node's bound arrays is its entry plane
/// and which its exit plane, and its numbers splatted. A macro, so that the
/// four- and the eight-wide trees share one text of the test.
macro_rules! wide_ray {
    ($name:ident, $simd:ty, $w:expr) => {
        #[derive(Clone, Copy)]
        struct $name {
            near: [usize; 3],
            far: [usize; 3],
            inv: [$simd; 3],
            org: [$simd; 3],
            t_min: $simd,
        }

        impl $name {
            #[inline(always)]
            fn new(r: &SingleRay) -> $name {
                let side = |a: usize| r.neg[a] as usize;
                $name {
                    near: [0, 1, 2].map(|a| 2 * a + side(a)),
                    far: [0, 1, 2].map(|a| 2 * a + 1 - side(a)),
                    inv: r.inv.map(<$simd>::splat),
                    org: r.origin.map(<$simd>::splat),
                    t_min: <$simd>::splat(r.t_min),
                }
            }

            /// Entry and exit distances of the children: per lane, the
            /// binary descent's `entry` (and `segment_enters_node` with
            /// `t_min = 0`).
            #[inline(always)]
            fn slabs(&self, node: &WideNode<{ $w }>) -> ($simd, $simd) {
                let plane =
                    |i: usize, a: usize| <$simd>::from(node.bounds[i]) * self.inv[a] - self.org[a];
                let (nx, ny, nz) = (
                    plane(self.near[0], 0),
                    plane(self.near[1], 1),
                    plane(self.near[2], 2),
                );
                let (fx, fy, fz) = (
                    plane(self.far[0], 0),
                    plane(self.far[1], 1),
                    plane(self.far[2], 2),
                );
                // `fast_max(a, b)` is `maxps(a, b)`: `a > b ? a : b`, i.e. `fmax(a, b)`.
                let tn = nx.fast_max(ny).fast_max(nz.fast_max(self.t_min));
                let tf = fx.fast_min(fy).fast_min(fz) * <$simd>::splat(ROBUST);
                (tn, tf)
            }

            /// The children a ray enters before `best * CULL_SLACK`, as a
            /// bit mask, and their entry distances.
            #[inline(always)]
            fn enter(&self, node: &WideNode<{ $w }>, best: f32) -> (u32, [f32; $w]) {
                let (tn, tf) = self.slabs(node);
                let bound = <$simd>::splat(best * CULL_SLACK);
                let m = (tn.simd_le(tf) & tn.simd_le(bound)).to_bitmask();
                (m, tn.to_array())
            }

            /// The children a segment `0 < t < t_max` enters, as a bit mask.
            #[inline(always)]
            fn enters(&self, node: &WideNode<{ $w }>, t_max: f32) -> u32 {
                let (tn, tf) = self.slabs(node);
                tn.simd_le(tf.fast_min(<$simd>::splat(t_max))).to_bitmask()
            }
        }
    };
}
pub(super) use wide_ray;

wide_ray!(WideRay, f32x4, WIDTH);

/// Two rays (a stereo pair) prepared to meet a node's four children in one
/// eight-wide register: lanes 0-3 the first ray's, 4-7 the second's. Per lane,
/// `WideRay::slabs`'s arithmetic.
#[derive(Clone, Copy)]
struct WidePair {
    near: [[usize; 3]; 2],
    far: [[usize; 3]; 2],
    inv: [f32x8; 3],
    org: [f32x8; 3],
    t_min: f32x8,
}

/// `a` in register lanes 0-3 and `b` in 4-7.
#[inline(always)]
fn halves(a: [f32; 4], b: [f32; 4]) -> f32x8 {
    f32x8::from([a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3]])
}

impl WidePair {
    #[inline(always)]
    fn new(r: [&WideRay; 2]) -> WidePair {
        let both = |a: f32x4, b: f32x4| halves(a.to_array(), b.to_array());
        WidePair {
            near: [r[0].near, r[1].near],
            far: [r[0].far, r[1].far],
            inv: [0, 1, 2].map(|a| both(r[0].inv[a], r[1].inv[a])),
            org: [0, 1, 2].map(|a| both(r[0].org[a], r[1].org[a])),
            t_min: both(r[0].t_min, r[1].t_min),
        }
    }

    /// The children each segment `0 < t < t_max` enters: bits 0-3 the first
    /// segment's, 4-7 the second's;
    /// per lane `WideRay::enters`' arithmetic.
    #[inline(always)]
    fn enters(&self, node: &Node4, t_max: [f32; 2]) -> u32 {
        let (tn, tf) = self.slabs(node);
        tn.simd_le(tf.fast_min(halves([t_max[0]; 4], [t_max[1]; 4])))
            .to_bitmask()
    }

    /// Entry and exit distances, as `WideRay::slabs` per lane.
    #[inline(always)]
    fn slabs(&self, node: &Node4) -> (f32x8, f32x8) {
        let plane = |side: &[[usize; 3]; 2], a: usize| {
            halves(node.bounds[side[0][a]], node.bounds[side[1][a]]) * self.inv[a] - self.org[a]
        };
        let (nx, ny, nz) = (
            plane(&self.near, 0),
            plane(&self.near, 1),
            plane(&self.near, 2),
        );
        let (fx, fy, fz) = (
            plane(&self.far, 0),
            plane(&self.far, 1),
            plane(&self.far, 2),
        );
        let tn = nx.fast_max(ny).fast_max(nz.fast_max(self.t_min));
        let tf = fx.fast_min(fy).fast_min(fz) * f32x8::splat(ROBUST);
        (tn, tf)
    }
}

/// A stack entry: a child (`count` > 0: a leaf) entered at `tn`.
#[derive(Clone, Copy)]
pub(super) struct Entry {
    pub(super) child: u32,
    pub(super) count: u32,
    pub(super) tn: f32,
}

/// The children in `mask` by `key` (their entry distances): returns the
/// nearest's entry and stacks the others' so that they pop nearest first.
#[inline(always)]
pub(super) fn take_nearest<E: Copy, const W: usize>(
    stack: &mut ArrayVec<E, STACK>,
    mask: u32,
    key: &[f32; W],
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
    let mut sorted = [near; W];
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

/// A stereo pair's stack entry: a child, the pair's lanes that entered it
/// (bit 0: the first ray, bit 1: the second) and their entry distances.
#[derive(Clone, Copy)]
struct PairEntry {
    child: u32,
    count: u32,
    lanes: u32,
    tn: [f32; 2],
}

/// A packet's stack entry: a child, the lanes that entered it, their entry distances.
#[derive(Clone, Copy)]
struct PacketEntry<const K: usize> {
    child: u32,
    count: u32,
    mask: u32,
    tn: [f32; K],
}

impl Bvh {
    /// Nearest hit per lane (see `closest_binary` for the contract). Every
    /// active lane of a packet (a ray alone, a stereo pair, the views of a
    /// batch) descends the eight-wide tree alone when there is one; without
    /// it a pair descends the four-wide tree in one descent
    /// (`closest_pair_wide`), wider packets the binary tree. All give the
    /// same hits. Measured in docs/benchmarks.md ("Issue 17, fourth pass:
    /// eight-wide nodes": two eight-wide descents beat the four-wide pair
    /// descent; "Issues 16 and 17, fifth pass": lanes alone beat both the
    /// binary packets and one eight-wide descent for the packet at K = 2,
    /// 4 and 8; "Issue 17, sixth pass": the pair in one eight-wide descent,
    /// `closest_pair_wide8`, was not faster than its rays alone).
    #[inline]
    pub fn closest<const K: usize>(
        &self,
        packet: &Packet<K>,
        stats: &mut TraversalStats,
        test: impl NearestTest,
    ) -> PacketHits<K> {
        if self.wide.is_empty() {
            self.closest_binary(packet, stats, test)
        } else if self.wide8.is_empty() {
            if K == 2 && packet.mask == 0b11 {
                self.closest_pair_wide(packet, stats, test)
            } else if K <= 2 || packet.mask.count_ones() == 1 {
                self.closest_each_wide(packet, stats, test)
            } else {
                self.closest_binary(packet, stats, test)
            }
        } else if K == EYE_PACKET
            && packet.mask.count_ones() > 1
            && std::env::var_os("TR_NOSEC8").is_none()
        {
            // Eight rays (a mono row's or a pair's secondary rays): in one
            // descent where their direction signs agree, bit for bit alone.
            let mut eight = Packet::<EYE_PACKET> {
                origins: [Vec3::ZERO; EYE_PACKET],
                dirs: [Vec3::Z; EYE_PACKET],
                t_min: packet.t_min,
                t_max: [f32::INFINITY; EYE_PACKET],
                mask: packet.mask,
            };
            for l in 0..K {
                eight.origins[l] = packet.origins[l];
                eight.dirs[l] = packet.dirs[l];
                eight.t_max[l] = packet.t_max[l];
            }
            match self.eye_packet8(&eight) {
                Some((singles, rays)) => {
                    let hits = self.closest_rays8(&eight, &singles, &rays, stats, test);
                    let mut out = PacketHits::<K>::none();
                    for l in 0..K {
                        out.prim[l] = hits.prim[l];
                        out.hit[l] = hits.hit[l];
                    }
                    out
                }
                None => self.closest_each_wide8(packet, stats, test),
            }
        } else {
            self.closest_each_wide8(packet, stats, test)
        }
    }

    /// `closest` with each active lane traced alone on the four-wide tree
    /// (which must exist): lane by lane what `closest_wide` gives.
    #[inline]
    pub fn closest_each_wide<const K: usize>(
        &self,
        packet: &Packet<K>,
        stats: &mut TraversalStats,
        mut test: impl NearestTest,
    ) -> PacketHits<K> {
        let mut out = PacketHits::<K>::none();
        for l in 0..K {
            if packet.mask & (1 << l) == 0 {
                continue;
            }
            let ray = SingleRay::new(packet.origins[l], packet.dirs[l], packet.t_min);
            let mut state = LaneHit {
                best: packet.t_max[l],
                prim: PacketHits::<K>::NO_HIT,
                hit: NO_SURFACE,
            };
            let root = Entry {
                child: 0,
                count: 0,
                tn: packet.t_min,
            };
            self.wide_single(root, &ray, &mut state, stats, &mut test, l);
            out.prim[l] = state.prim;
            out.hit[l] = state.hit;
        }
        out
    }

    /// Any-hit per lane (see `occlusion_binary` for the contract): a
    /// segment alone on the eight-wide tree; a stereo pair's two segments in
    /// one descent of it (`occlusion_pair_wide8`: it measured faster than
    /// both in one `f32x8` on the four-wide tree, docs/benchmarks.md "Issue
    /// 17, sixth pass"); the live segments of a packet of three to eight
    /// lanes (a mono row's neighbouring samples, a group's views) in one
    /// descent with the segments in the lanes (`occlusion_packet8`), or,
    /// where their direction signs differ or there are more lanes, each
    /// alone. Without an eight-wide tree, the four-wide.
    pub fn occlusion<const K: usize>(
        &self,
        packet: &SegmentPacket<K>,
        stats: &mut TraversalStats,
        test: &mut impl AnyHitTest,
    ) {
        if self.wide.is_empty() {
            self.occlusion_binary(packet, stats, test)
        } else if self.wide8.is_empty() {
            self.occlusion_wide(packet, stats, test)
        } else if K == 2 && packet.mask == 0b11 {
            self.occlusion_pair_wide8(packet, stats, test)
        } else if !(K > 2
            && packet.mask.count_ones() > 1
            && self.occlusion_packet8(packet, stats, test))
        {
            self.occlusion_wide8(packet, stats, test)
        }
    }

    /// `closest` on the four-wide tree (which must exist).
    #[inline]
    pub fn closest_wide<const K: usize>(
        &self,
        packet: &Packet<K>,
        stats: &mut TraversalStats,
        mut test: impl NearestTest,
    ) -> PacketHits<K> {
        let mut out = PacketHits::<K>::none();
        if self.wide.is_empty() || packet.mask == 0 {
            return out;
        }
        if K == 1 || packet.mask.count_ones() == 1 {
            return self.closest_each_wide(packet, stats, test);
        }
        if K == 2 {
            return self.closest_pair_wide(packet, stats, test);
        }
        let rays: [SingleRay; K] = std::array::from_fn(|l| {
            SingleRay::new(packet.origins[l], packet.dirs[l], packet.t_min)
        });
        let wide_rays: [WideRay; K] = std::array::from_fn(|l| WideRay::new(&rays[l]));
        let mut best = packet.t_max;
        let mut stack = ArrayVec::<PacketEntry<K>, STACK>::new();
        stack.push(PacketEntry {
            child: 0,
            count: 0,
            mask: packet.mask,
            tn: [packet.t_min; K],
        });
        while let Some(PacketEntry {
            child,
            count,
            mut mask,
            tn,
        }) = stack.pop()
        {
            for (l, t) in tn.iter().enumerate() {
                if mask & (1 << l) != 0 && *t > best[l] * CULL_SLACK {
                    mask &= !(1 << l);
                }
            }
            if mask == 0 {
                continue;
            }
            if mask & (mask - 1) == 0 {
                // One lane left in this subtree: finish it as a plain ray.
                let l = mask.trailing_zeros() as usize;
                let start = Entry {
                    child,
                    count,
                    tn: tn[l],
                };
                self.finish_lane(start, &rays[l], l, &mut best, &mut out, stats, &mut test);
                continue;
            }
            stats.nodes += 1;
            if count > 0 {
                test_leaf(
                    self.leaf(child, count),
                    mask,
                    &mut best,
                    &mut out,
                    stats,
                    &mut test,
                );
                continue;
            }
            let node = &self.wide[child as usize];
            let mut lanes_in = [0u32; WIDTH];
            let mut tn_in = [[0.0f32; K]; WIDTH];
            let mut key = [f32::INFINITY; WIDTH];
            // Each lane against the four children in one register.
            let mut lanes = mask;
            while lanes != 0 {
                let l = lanes.trailing_zeros() as usize;
                lanes &= lanes - 1;
                stats.box_tests += WIDTH as u64;
                let (m, t) = wide_rays[l].enter(node, best[l]);
                for c in 0..WIDTH {
                    if m & (1 << c) != 0 {
                        lanes_in[c] |= 1 << l;
                        tn_in[c][l] = t[c];
                        key[c] = fmin(key[c], t[c]);
                    }
                }
            }
            // Nearest first: by the nearest entry among a child's lanes.
            let mut order: ArrayVec<usize, WIDTH> = ArrayVec::new();
            for c in 0..WIDTH {
                if lanes_in[c] != 0 {
                    let at = order
                        .iter()
                        .position(|&o| key[o] < key[c])
                        .unwrap_or(order.len());
                    order.insert(at, c);
                }
            }
            for c in order {
                let _ = stack.try_push(PacketEntry {
                    child: node.child[c],
                    count: node.count[c],
                    mask: lanes_in[c],
                    tn: tn_in[c],
                });
            }
        }
        out
    }

    /// `closest` for a stereo pair (`K == 2`, both lanes active) on the
    /// four-wide tree (which must exist), in one descent: a node's four
    /// children are tested for each ray (an outer loop over the two rays,
    /// each testing the four children in one register), a child is stacked
    /// if either ray enters it before its own
    /// nearest hit so far, with the lanes that did (a lane is carried into a
    /// child only by its own box test, and dropped at a pop when its own
    /// nearest hit is nearer than its own entry). Children go nearest first
    /// by the nearer of the two rays' entries. A subtree that only one ray
    /// enters is finished by that ray's single descent. Per lane the slab and leaf
    /// arithmetic is the single ray's, so each lane's hit is the one it gets
    /// alone (culling is conservative, ties go to the lower index).
    #[inline]
    pub(super) fn closest_pair_wide<const K: usize>(
        &self,
        packet: &Packet<K>,
        stats: &mut TraversalStats,
        mut test: impl NearestTest,
    ) -> PacketHits<K> {
        debug_assert!(K == 2 && packet.mask == 0b11);
        let mut out = PacketHits::<K>::none();
        let (a, b) = (0, 1 % K);
        let rays = [a, b].map(|l| SingleRay::new(packet.origins[l], packet.dirs[l], packet.t_min));
        let wide_rays = [WideRay::new(&rays[0]), WideRay::new(&rays[1])];
        let mut best = packet.t_max;
        let slack = |best: &[f32; K], l: usize| best[l] * CULL_SLACK;
        let mut lanes = 0;
        for (bit, l) in [(1, a), (2, b)] {
            if packet.t_min <= slack(&best, l) {
                lanes |= bit;
            }
        }
        let (mut nodes, mut boxes) = (0u64, 0u64);
        let mut stack = ArrayVec::<PairEntry, STACK>::new();
        let mut current = (lanes != 0).then_some(PairEntry {
            child: 0,
            count: 0,
            lanes,
            tn: [packet.t_min; 2],
        });
        while let Some(PairEntry {
            child,
            count,
            lanes,
            tn,
        }) = current
        {
            if lanes != 0b11 {
                // One lane left in this subtree: finish it as a plain ray.
                let i = lanes.trailing_zeros() as usize;
                let start = Entry {
                    child,
                    count,
                    tn: tn[i],
                };
                let l = [a, b][i];
                self.finish_lane(start, &rays[i], l, &mut best, &mut out, stats, &mut test);
            } else if count > 0 {
                nodes += 1;
                // Lane bits are packet lanes 0 and 1 for K == 2.
                test_leaf(
                    self.leaf(child, count),
                    lanes,
                    &mut best,
                    &mut out,
                    stats,
                    &mut test,
                );
            } else {
                nodes += 1;
                let node = &self.wide[child as usize];
                boxes += 2 * WIDTH as u64;
                // Each ray against the four children in one four-wide
                // register, one ray after the other: this measured faster
                // than both rays in one eight-wide register (`WidePair`).
                let (m0, t0) = wide_rays[0].enter(node, best[a]);
                let (m1, t1) = wide_rays[1].enter(node, best[b]);
                let any = m0 | m1;
                if any != 0 {
                    let entered = |m: u32, t: &[f32; WIDTH], c: usize| {
                        if m & (1 << c) != 0 {
                            t[c]
                        } else {
                            f32::INFINITY
                        }
                    };
                    let key: [f32; WIDTH] =
                        std::array::from_fn(|c| fmin(entered(m0, &t0, c), entered(m1, &t1, c)));
                    current = Some(take_nearest(&mut stack, any, &key, |c| PairEntry {
                        child: node.child[c],
                        count: node.count[c],
                        lanes: (m0 >> c) & 1 | ((m1 >> c) & 1) << 1,
                        tn: [t0[c], t1[c]],
                    }));
                    continue;
                }
            }
            current = None;
            while let Some(mut e) = stack.pop() {
                if e.lanes & 1 != 0 && e.tn[0] > slack(&best, a) {
                    e.lanes &= !1;
                }
                if e.lanes & 2 != 0 && e.tn[1] > slack(&best, b) {
                    e.lanes &= !2;
                }
                if e.lanes != 0 {
                    current = Some(e);
                    break;
                }
            }
        }
        stats.nodes += nodes;
        stats.box_tests += boxes;
        out
    }

    /// Packet lane `l` (ray `ray`) alone through the subtree at `start`: the
    /// packet descents' finish where one lane is left, improving its entry
    /// in `best` and `out`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn finish_lane<const K: usize, T: NearestTest>(
        &self,
        start: Entry,
        ray: &SingleRay,
        l: usize,
        best: &mut [f32; K],
        out: &mut PacketHits<K>,
        stats: &mut TraversalStats,
        test: &mut T,
    ) {
        let mut state = LaneHit {
            best: best[l],
            prim: out.prim[l],
            hit: out.hit[l],
        };
        self.wide_single(start, ray, &mut state, stats, test, l);
        (best[l], out.prim[l], out.hit[l]) = (state.best, state.prim, state.hit);
    }

    /// One ray's descent of the four-wide subtree at `start`, improving `state`.
    #[inline(always)]
    fn wide_single<T: NearestTest>(
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
        let (mut nodes, mut boxes, mut prims) = (0u64, 0u64, 0u64);
        let mut stack = ArrayVec::<Entry, STACK>::new();
        let mut current = (start.tn <= lh.best * CULL_SLACK).then_some(start);
        while let Some(Entry { child, count, .. }) = current {
            nodes += 1;
            if count > 0 {
                prims += count as u64;
                leaf_lane(self.leaf(child, count), lane, &mut lh, test);
            } else {
                let node = &self.wide[child as usize];
                boxes += WIDTH as u64;
                let (m, t) = wray.enter(node, lh.best);
                if m != 0 {
                    // The nearest child next, the others stacked farthest first.
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
        stats.box_tests += boxes;
        stats.prim_tests += prims;
    }

    /// `occlusion` on the four-wide tree (which must exist).
    pub fn occlusion_wide<const K: usize>(
        &self,
        packet: &SegmentPacket<K>,
        stats: &mut TraversalStats,
        test: &mut impl AnyHitTest,
    ) {
        if self.wide.is_empty() || packet.mask == 0 {
            return;
        }
        let rays: [SingleRay; K] =
            std::array::from_fn(|l| SingleRay::new(packet.origins[l], packet.dirs[l], 0.0));
        let t_max = &packet.t_max;
        if K == 1 || packet.mask.count_ones() == 1 {
            let l = if K == 1 {
                0
            } else {
                packet.mask.trailing_zeros() as usize
            };
            self.wide_occlusion_single((0, 0), &rays[l], t_max[l], stats, test, l);
            return;
        }
        let wide_rays: [WideRay; K] = std::array::from_fn(|l| WideRay::new(&rays[l]));
        let pair = (K == 2).then(|| WidePair::new([&wide_rays[0], &wide_rays[1 % K]]));
        let mut live = packet.mask;
        let mut stack = ArrayVec::<(u32, u32, u32), STACK>::new();
        stack.push((0, 0, live));
        while let Some((child, count, m)) = stack.pop() {
            let mask = m & live;
            if mask == 0 {
                continue;
            }
            if mask & (mask - 1) == 0 {
                let l = mask.trailing_zeros() as usize;
                if self.wide_occlusion_single((child, count), &rays[l], t_max[l], stats, test, l) {
                    live &= !(1 << l);
                }
                continue;
            }
            stats.nodes += 1;
            if count > 0 {
                occlusion_leaf(
                    self.leaf(child, count),
                    K == 2,
                    mask,
                    &mut live,
                    stats,
                    test,
                );
                if live == 0 {
                    return;
                }
                continue;
            }
            let node = &self.wide[child as usize];
            let mut lanes_in = [0u32; WIDTH];
            let mut lanes = mask;
            if let Some(pair) = &pair {
                // A stereo pair (both lanes live here): one eight-wide test.
                stats.box_tests += 2 * WIDTH as u64;
                let m = pair.enters(node, [t_max[0], t_max[1 % K]]);
                for (c, lc) in lanes_in.iter_mut().enumerate() {
                    *lc = (m >> c) & 1 | ((m >> (c + WIDTH)) & 1) << 1;
                }
                lanes = 0;
            }
            while lanes != 0 {
                let l = lanes.trailing_zeros() as usize;
                lanes &= lanes - 1;
                stats.box_tests += WIDTH as u64;
                let m = wide_rays[l].enters(node, t_max[l]);
                for (c, lc) in lanes_in.iter_mut().enumerate() {
                    *lc |= ((m >> c) & 1) << l;
                }
            }
            for c in (0..WIDTH).rev() {
                if lanes_in[c] != 0 {
                    let _ = stack.try_push((node.child[c], node.count[c], lanes_in[c]));
                }
            }
        }
    }

    /// One segment's any-hit descent of the four-wide subtree at `start`
    /// (`(child, count)`); returns whether `test` said stop.
    #[inline(always)]
    fn wide_occlusion_single<T: AnyHitTest>(
        &self,
        start: (u32, u32),
        ray: &SingleRay,
        t_max: f32,
        stats: &mut TraversalStats,
        test: &mut T,
        lane: usize,
    ) -> bool {
        let wray = WideRay::new(ray);
        let (mut nodes, mut boxes, mut prims) = (0u64, 0u64, 0u64);
        let mut stopped = false;
        let mut stack = ArrayVec::<(u32, u32), STACK>::new();
        stack.push(start);
        'descent: while let Some((child, count)) = stack.pop() {
            nodes += 1;
            if count > 0 {
                if occlusion_lane(self.leaf(child, count), lane, &mut prims, test) {
                    stopped = true;
                    break 'descent;
                }
                continue;
            }
            let node = &self.wide[child as usize];
            boxes += WIDTH as u64;
            let mut m = wray.enters(node, t_max);
            while m != 0 {
                let c = 31 - m.leading_zeros() as usize;
                m &= !(1 << c);
                let _ = stack.try_push((node.child[c], node.count[c]));
            }
        }
        stats.nodes += nodes;
        stats.box_tests += boxes;
        stats.prim_tests += prims;
        stopped
    }
}

//! Traversals: nearest hit per lane for a packet of rays, and any-hit per
//! lane for a packet of segments (shadow rays).
//!
//! A packet carries one ray per view — the paper's twin objects realised as
//! rays: view `v`'s ray through the shared world is the same as one ray through
//! view `v`'s translated twins. One descent serves every lane; each lane keeps
//! its own nearest distance and is carried into a node only if its own box test
//! passes. The lanes of a packet may have different directions (the twin method
//! pairs the views' rays that see one surface point, see `render`).
//!
//! Exactness: every lane's box and primitive tests use that lane's own numbers,
//! with the operations the single-ray descent uses; culling is conservative
//! (`CULL_SLACK`), so the nearest hit — ties in distance go to the lower
//! primitive index — does not depend on the order in which nodes are visited:
//! a lane in any packet gets what the same ray traced alone gets.

use super::leaf::{leaf_lane, occlusion_lane, occlusion_leaf, test_leaf};
use super::{Bvh, Node};
use crate::math::{Aabb, Vec3};
use crate::shapes::{BlockHits, EightHits, SurfaceHit, Triangle4};
use arrayvec::ArrayVec;
use wide::{f32x4, f32x8};

/// Rays `origins[l] + t * dirs[l]`, `t_min < t < t_max[l]`, one per active
/// lane. Lanes not in `mask` are ignored.
#[derive(Clone, Copy, Debug)]
pub struct Packet<const K: usize> {
    pub origins: [Vec3; K],
    pub dirs: [Vec3; K],
    pub t_min: f32,
    pub t_max: [f32; K],
    pub mask: u32,
}

impl Packet<1> {
    /// One ray from `origin` along `dir`, `0 < t`, as a packet of one.
    pub fn ray(origin: Vec3, dir: Vec3) -> Packet<1> {
        Packet {
            origins: [origin],
            dirs: [dir],
            t_min: 0.0,
            t_max: [f32::INFINITY],
            mask: 1,
        }
    }
}

impl<const K: usize> Packet<K> {
    /// Lane `l`'s ray as a packet of its own (active whatever `mask` says).
    pub fn lane(&self, l: usize) -> Packet<1> {
        Packet {
            origins: [self.origins[l]],
            dirs: [self.dirs[l]],
            t_min: self.t_min,
            t_max: [self.t_max[l]],
            mask: 1,
        }
    }
}

/// Segments `origins[l] + t * dirs[l]`, `0 < t < t_max[l]`, one per active lane.
#[derive(Clone, Copy, Debug)]
pub struct SegmentPacket<const K: usize> {
    pub origins: [Vec3; K],
    pub dirs: [Vec3; K],
    pub t_max: [f32; K],
    pub mask: u32,
}

impl<const K: usize> SegmentPacket<K> {
    /// A packet with no lane in it yet.
    pub fn empty() -> SegmentPacket<K> {
        SegmentPacket {
            origins: [Vec3::ZERO; K],
            dirs: [Vec3::Z; K],
            t_max: [0.0; K],
            mask: 0,
        }
    }
}

/// The nearest hit of each lane (`prim == NO_HIT` where there is none).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PacketHits<const K: usize> {
    pub prim: [u32; K],
    pub hit: [SurfaceHit; K],
}

/// A lane's hit before it meets any primitive: infinitely far.
pub(crate) const NO_SURFACE: SurfaceHit = SurfaceHit {
    t: f32::INFINITY,
    u: 0.0,
    v: 0.0,
};

impl<const K: usize> PacketHits<K> {
    pub const NO_HIT: u32 = u32::MAX;

    /// No lane has a hit yet: where both nearest-hit traversals start.
    pub(crate) fn none() -> PacketHits<K> {
        PacketHits {
            prim: [Self::NO_HIT; K],
            hit: [NO_SURFACE; K],
        }
    }

    #[inline]
    pub fn has_hit(&self, lane: usize) -> bool {
        self.prim[lane] != Self::NO_HIT
    }
}

/// What an any-hit test tells the traversal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AnyHit {
    Continue,
    Stop,
}

/// Work done, for statistics. Counting is one add per event: cheap next to the tests.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, derive_more::AddAssign)]
pub struct TraversalStats {
    /// Nodes popped and processed (one per node per packet, whatever its lanes).
    pub nodes: u64,
    /// Box tests, one per lane and node.
    pub box_tests: u64,
    /// Primitive tests, one per lane and primitive.
    pub prim_tests: u64,
    /// Of `prim_tests`, those made with other lanes in one eight-lane test
    /// (`test_lanes`: a packet's lanes in a leaf of spheres and cones).
    pub prim_tests_in_lanes: u64,
}

/// The primitive test of a nearest-hit traversal.
pub trait NearestTest {
    /// Intersects primitive `prim` with lane `lane`'s ray: a hit with `t < t_max`, or `None`.
    fn test(&mut self, prim: u32, lane: usize, t_max: f32) -> Option<SurfaceHit>;

    /// Lanes 0 and 1 against one primitive at once (a stereo pair in a leaf).
    /// Must return what two calls of `test` return.
    #[inline(always)]
    fn test_pair(&mut self, prim: u32, t_max: [f32; 2]) -> [Option<SurfaceHit>; 2] {
        [self.test(prim, 0, t_max[0]), self.test(prim, 1, t_max[1])]
    }

    /// The lanes `lanes` of a packet of eight against primitive `prim` at
    /// once, lane `l` with the bound `t_max[l]`: bit `l` and `t[l]` are what
    /// `test` returns for lane `l` (a sphere's or a cone's hit, whose `u`
    /// and `v` are 0). `None`: the traversal tests the lanes one by one.
    #[inline(always)]
    fn test_lanes(&mut self, _prim: u32, _lanes: u32, _t_max: f32x8) -> Option<EightHits> {
        None
    }

    /// Lane `lane` against a block of a leaf's triangles at once
    /// (`shapes::Triangle4`): bit `i` and lane `i` are what `test` returns
    /// for the block's primitive `i`. `None`: the traversal tests the block's
    /// primitives one by one.
    #[inline(always)]
    fn test_block(&mut self, _block: &Triangle4, _lane: usize, _t_max: f32) -> Option<BlockHits> {
        None
    }

    /// Lane `lane` against two blocks of a leaf at once
    /// (`Triangle4::intersect_two`): what two calls of `test_block` return.
    #[inline(always)]
    fn test_two_blocks(
        &mut self,
        blocks: &[Triangle4; 2],
        lane: usize,
        t_max: f32,
    ) -> Option<[BlockHits; 2]> {
        Some([
            self.test_block(&blocks[0], lane, t_max)?,
            self.test_block(&blocks[1], lane, t_max)?,
        ])
    }

    /// Lanes 0 and 1 against a block at once: what two calls of `test_block`
    /// return.
    #[inline(always)]
    fn test_block_pair(&mut self, block: &Triangle4, t_max: [f32; 2]) -> Option<[BlockHits; 2]> {
        Some([
            self.test_block(block, 0, t_max[0])?,
            self.test_block(block, 1, t_max[1])?,
        ])
    }
}

impl<F: FnMut(u32, usize, f32) -> Option<SurfaceHit>> NearestTest for F {
    #[inline(always)]
    fn test(&mut self, prim: u32, lane: usize, t_max: f32) -> Option<SurfaceHit> {
        self(prim, lane, t_max)
    }
}

/// The primitive test of an any-hit traversal.
pub trait AnyHitTest {
    /// Primitive `prim` met by lane `lane`'s segment (or not: the test decides).
    fn test(&mut self, prim: u32, lane: usize) -> AnyHit;

    /// Lanes 0 and 1 at once; must do what two calls of `test` do.
    #[inline(always)]
    fn test_pair(&mut self, prim: u32) -> [AnyHit; 2] {
        [self.test(prim, 0), self.test(prim, 1)]
    }

    /// Lane `lane` against a block of triangles (`shapes::Triangle4`) whose
    /// lanes hold the primitives `prims`: must do what `test` on each of
    /// `prims` in order does, up to the first `Stop` (which it returns).
    /// `None`: the traversal tests them one by one.
    #[inline(always)]
    fn test_block(&mut self, _block: &Triangle4, _prims: &[u32], _lane: usize) -> Option<AnyHit> {
        None
    }

    /// The lanes `lanes` (of a packet of at most eight) against primitive
    /// `prim` at once: must do for each lane what `test` does, and returns
    /// the lanes it stopped. `None`: the traversal tests them one by one.
    #[inline(always)]
    fn test_lanes(&mut self, _prim: u32, _lanes: u32) -> Option<u32> {
        None
    }

    /// Lanes 0 and 1 against a block at once: what two calls of
    /// `test_block` do.
    #[inline(always)]
    fn test_block_pair(&mut self, block: &Triangle4, prims: &[u32]) -> Option<[AnyHit; 2]> {
        Some([
            self.test_block(block, prims, 0)?,
            self.test_block(block, prims, 1)?,
        ])
    }
}

impl<F: FnMut(u32, usize) -> AnyHit> AnyHitTest for F {
    #[inline(always)]
    fn test(&mut self, prim: u32, lane: usize) -> AnyHit {
        self(prim, lane)
    }
}

pub(super) const STACK: usize = 128;
/// A box is skipped when its entry lies beyond the nearest hit so far by more
/// than this factor. The slack covers the rounding of a primitive's hit
/// distance against its box's entry distance (a floor polygon lies in its
/// box's face), so that no traversal order can skip a hit another would find:
/// the nearest hit is then the same for a lane traced alone or in any packet.
pub(super) const CULL_SLACK: f32 = 1.0 + 1.0 / 4096.0;
/// Ize's robust slab test: widen the exit distance by 1 + 2*gamma(3).
pub(super) const ROBUST: f32 =
    1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// `min` and `max` without the NaN rules of `f32::min` (one instruction each):
/// the slab test never produces NaN, since `safe_inverse` keeps 1/d finite.
#[inline(always)]
pub(super) fn fmin(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}

#[inline(always)]
pub(super) fn fmax(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

/// The planes through which a ray with direction signs `neg` enters and leaves
/// `node`, per axis: `(near, far)`.
#[inline(always)]
fn slab_planes(node: &Node, neg: &[bool; 3]) -> ([f32; 3], [f32; 3]) {
    let (min, max) = (&node.min, &node.max);
    let pick = |a: usize| {
        if neg[a] {
            (max[a], min[a])
        } else {
            (min[a], max[a])
        }
    };
    let ((nx, fx), (ny, fy), (nz, fz)) = (pick(0), pick(1), pick(2));
    ([nx, ny, nz], [fx, fy, fz])
}

/// 1/d with zero components replaced by a huge finite value of the right sign,
/// so that the slab test never computes 0 * inf.
#[inline]
fn safe_inverse(d: Vec3) -> Vec3 {
    let fix = |c: f32| {
        if c.abs() < 1e-30 {
            1e30f32.copysign(c)
        } else {
            1.0 / c
        }
    };
    Vec3::new(fix(d.x), fix(d.y), fix(d.z))
}

/// One ray prepared for slab tests (see `Lanes` for the same per lane).
#[derive(Clone, Copy)]
pub(super) struct SingleRay {
    pub(super) inv: [f32; 3],
    pub(super) neg: [bool; 3],
    /// The origin scaled by `inv`.
    pub(super) origin: [f32; 3],
    pub(super) t_min: f32,
}

impl SingleRay {
    pub(super) fn new(origin: Vec3, dir: Vec3, t_min: f32) -> SingleRay {
        let inv = safe_inverse(dir);
        SingleRay {
            inv: [inv.x, inv.y, inv.z],
            neg: [inv.x < 0.0, inv.y < 0.0, inv.z < 0.0],
            origin: [origin.x * inv.x, origin.y * inv.y, origin.z * inv.z],
            t_min,
        }
    }

    /// Entry and (robustly widened) exit distance of the ray for `node`.
    #[inline(always)]
    pub(super) fn slabs(&self, node: &Node) -> (f32, f32) {
        let ([ix, iy, iz], [ox, oy, oz]) = (self.inv, self.origin);
        let ([nx, ny, nz], [fx, fy, fz]) = slab_planes(node, &self.neg);
        let tn = fmax(
            fmax(nx * ix - ox, ny * iy - oy),
            fmax(nz * iz - oz, self.t_min),
        );
        let tf = fmin(fmin(fx * ix - ox, fy * iy - oy), fz * iz - oz) * ROBUST;
        (tn, tf)
    }
}

/// The any-hit slab test, written once for `Bvh::occlusion`'s descent and for
/// `segment_enters`, which must agree with it bit for bit: whether the segment
/// `0 < t < t_max` of a ray with inverse direction `inv`, origin scaled by it
/// `org` and direction signs `neg` enters `node`. A macro: as an inline
/// function it made the descent's code slower (6% more instructions rendering
/// `shelf.nff`).
macro_rules! segment_enters_node {
    ($inv:expr, $org:expr, $neg:expr, $node:expr, $t_max:expr) => {{
        let ([ix, iy, iz], [ox, oy, oz]) = ($inv, $org);
        let ([nx, ny, nz], [fx, fy, fz]) = slab_planes($node, $neg);
        let tn = fmax(fmax(nx * ix - ox, ny * iy - oy), fmax(nz * iz - oz, 0.0));
        let tf = fmin(fmin(fx * ix - ox, fy * iy - oy), fz * iz - oz) * ROBUST;
        tn <= fmin(tf, $t_max)
    }};
}

/// Whether `Bvh::occlusion` carries the segment `origin + t * dir`, `0 < t <
/// t_max`, into a node whose box is `b` (its slab test, with its arithmetic).
/// The test is monotone in the box, since rounding keeps order: a segment that
/// enters a primitive's `primitive_box` enters every node above it, so the
/// occlusion traversal tests that primitive. Unless the origin scaled by the
/// inverse direction is not finite (`inf - inf` is NaN, which breaks the
/// order): `false` then.
pub fn segment_enters(b: &Aabb, origin: Vec3, dir: Vec3, t_max: f32) -> bool {
    let ray = SingleRay::new(origin, dir, 0.0);
    if !ray.origin.iter().all(|o| o.is_finite()) {
        return false;
    }
    let node = Node {
        min: b.min.into(),
        first: 0,
        max: b.max.into(),
        meta: 0,
    };
    segment_enters_node!(ray.inv, ray.origin, &ray.neg, &node, t_max)
}

/// One lane's nearest hit so far.
#[derive(Clone, Copy)]
pub(super) struct LaneHit {
    pub(super) best: f32,
    pub(super) prim: u32,
    pub(super) hit: SurfaceHit,
}

impl LaneHit {
    /// Takes hit `h` on `prim` if it is nearer, or as near on a lower index.
    #[inline(always)]
    pub(super) fn offer(&mut self, prim: u32, h: SurfaceHit) {
        if h.t < self.best || (h.t == self.best && prim < self.prim) {
            self.best = h.t;
            self.prim = prim;
            self.hit = h;
        }
    }
}

/// The lanes of a packet prepared for slab tests, as structure of arrays: each
/// lane's inverse direction and its origin scaled by it.
struct Lanes<const K: usize> {
    ix: [f32; K],
    iy: [f32; K],
    iz: [f32; K],
    ox: [f32; K],
    oy: [f32; K],
    oz: [f32; K],
    /// Two lanes (a stereo pair) twice over, `[l0, l1, l0, l1]`: both children of
    /// a node are tested for both lanes in one register. Unused for K != 2.
    pair: [f32x4; 6],
    /// Direction signs of the first active lane, which order the descent.
    neg: [bool; 3],
    t_min: f32,
}

/// Lanes `[a0, a1, b0, b1]` of a pair test split into child `a`'s and child
/// `b`'s two-lane masks.
#[inline(always)]
fn split_pair(bits: u32) -> (u32, u32) {
    (bits & 0b11, bits >> 2)
}

impl<const K: usize> Lanes<K> {
    fn new(origins: &[Vec3; K], dirs: &[Vec3; K], mask: u32, t_min: f32) -> Lanes<K> {
        let inv: [Vec3; K] = std::array::from_fn(|l| safe_inverse(dirs[l]));
        let lead = (mask.trailing_zeros() as usize).min(K - 1);
        let neg = [inv[lead].x < 0.0, inv[lead].y < 0.0, inv[lead].z < 0.0];
        let mut lanes = Lanes {
            ix: std::array::from_fn(|l| inv[l].x),
            iy: std::array::from_fn(|l| inv[l].y),
            iz: std::array::from_fn(|l| inv[l].z),
            ox: std::array::from_fn(|l| origins[l].x * inv[l].x),
            oy: std::array::from_fn(|l| origins[l].y * inv[l].y),
            oz: std::array::from_fn(|l| origins[l].z * inv[l].z),
            pair: [f32x4::ZERO; 6],
            neg,
            t_min,
        };
        if K == 2 {
            let twice = |a: &[f32; K]| f32x4::from([a[0], a[1 % K], a[0], a[1 % K]]);
            lanes.pair = [
                twice(&lanes.ix),
                twice(&lanes.iy),
                twice(&lanes.iz),
                twice(&lanes.ox),
                twice(&lanes.oy),
                twice(&lanes.oz),
            ];
        }
        lanes
    }

    /// Lane `l` as a ray of its own, for the single-ray descent.
    fn single(&self, l: usize) -> SingleRay {
        let (ix, iy, iz) = (self.ix[l], self.iy[l], self.iz[l]);
        SingleRay {
            inv: [ix, iy, iz],
            neg: [ix < 0.0, iy < 0.0, iz < 0.0],
            origin: [self.ox[l], self.oy[l], self.oz[l]],
            t_min: self.t_min,
        }
    }

    /// Entry and (robustly widened) exit distances of the lanes `inv`, `org`
    /// (scaled origins) for the boxes `min`, `max` given per register lane.
    ///
    /// Per lane these are the values `SingleRay::slabs` computes: it picks the
    /// entry plane by the direction's sign, here the min/max of both planes is
    /// taken, and the two agree because scaling and shifting preserve order
    /// under rounding; min and max are exact, so their order does not matter.
    #[inline(always)]
    fn slabs4(
        min: [f32x4; 3],
        max: [f32x4; 3],
        inv: &[f32x4],
        org: &[f32x4],
        t_min: f32,
    ) -> (f32x4, f32x4) {
        let x0 = min[0] * inv[0] - org[0];
        let x1 = max[0] * inv[0] - org[0];
        let y0 = min[1] * inv[1] - org[1];
        let y1 = max[1] * inv[1] - org[1];
        let z0 = min[2] * inv[2] - org[2];
        let z1 = max[2] * inv[2] - org[2];
        let tn = x0
            .fast_min(x1)
            .fast_max(y0.fast_min(y1))
            .fast_max(z0.fast_min(z1).fast_max(f32x4::splat(t_min)));
        let tf = x0
            .fast_max(x1)
            .fast_min(y0.fast_max(y1))
            .fast_min(z0.fast_max(z1))
            * f32x4::splat(ROBUST);
        (tn, tf)
    }

    /// Every lane's entry and exit distance for `node` (see `slabs4`).
    #[inline(always)]
    fn slabs(&self, node: &Node) -> ([f32; K], [f32; K]) {
        let (mut tn, mut tf) = ([0.0f32; K], [0.0f32; K]);
        if K <= 4 {
            let pad = |a: &[f32; K]| {
                let mut v = [0.0f32; 4];
                v[..K].copy_from_slice(a);
                f32x4::from(v)
            };
            let inv = [pad(&self.ix), pad(&self.iy), pad(&self.iz)];
            let org = [pad(&self.ox), pad(&self.oy), pad(&self.oz)];
            let splat = |p: &[f32; 3]| p.map(f32x4::splat);
            let (n, f) = Self::slabs4(splat(&node.min), splat(&node.max), &inv, &org, self.t_min);
            tn.copy_from_slice(&n.to_array()[..K]);
            tf.copy_from_slice(&f.to_array()[..K]);
            return (tn, tf);
        }
        for l in 0..K {
            let (near, far) = self.single(l).slabs(node);
            tn[l] = near;
            tf[l] = far;
        }
        (tn, tf)
    }

    /// Both children `a` and `b` of a node, for a pair of lanes: the entry
    /// distances `[a0, a1, b0, b1]` and the exit distances.
    #[inline(always)]
    fn pair_slabs(&self, a: &Node, b: &Node) -> (f32x4, f32x4) {
        let both = |x: f32, y: f32| f32x4::from([x, x, y, y]);
        let min = [0, 1, 2].map(|i| both(a.min[i], b.min[i]));
        let max = [0, 1, 2].map(|i| both(a.max[i], b.max[i]));
        Self::slabs4(min, max, &self.pair[..3], &self.pair[3..], self.t_min)
    }

    /// The lanes of `mask` that enter `a` and `b` before their nearest hits so
    /// far, with each lane's entry distances.
    #[inline(always)]
    fn enter_children(
        &self,
        a: &Node,
        b: &Node,
        mask: u32,
        best: &[f32; K],
    ) -> ((u32, [f32; K]), (u32, [f32; K])) {
        if K == 2 {
            let (tn, tf) = self.pair_slabs(a, b);
            let bound = f32x4::from([best[0], best[1 % K], best[0], best[1 % K]])
                * f32x4::splat(CULL_SLACK);
            let (ma, mb) = split_pair((tn.simd_le(tf) & tn.simd_le(bound)).to_bitmask());
            let t = tn.to_array();
            let (mut ta, mut tb) = ([0.0; K], [0.0; K]);
            ta[..2].copy_from_slice(&t[..2]);
            tb[..2].copy_from_slice(&t[2..]);
            return ((ma & mask, ta), (mb & mask, tb));
        }
        (self.enter(a, mask, best), self.enter(b, mask, best))
    }

    /// The lanes of `mask` that enter `node` before their nearest hits so far,
    /// with each lane's entry distance.
    #[inline(always)]
    fn enter(&self, node: &Node, mask: u32, best: &[f32; K]) -> (u32, [f32; K]) {
        let (tn, tf) = self.slabs(node);
        let mut hit = 0;
        for l in 0..K {
            if tn[l] <= tf[l] && tn[l] <= best[l] * CULL_SLACK {
                hit |= 1 << l;
            }
        }
        (hit & mask, tn)
    }

    /// The lanes of `mask` whose segments `t_min < t < t_max` enter `a`, and `b`.
    #[inline(always)]
    fn enters_children(&self, a: &Node, b: &Node, mask: u32, t_max: &[f32; K]) -> (u32, u32) {
        if K == 2 {
            let (tn, tf) = self.pair_slabs(a, b);
            let limit = f32x4::from([t_max[0], t_max[1 % K], t_max[0], t_max[1 % K]]);
            let (ma, mb) = split_pair(tn.simd_le(tf.fast_min(limit)).to_bitmask());
            return (ma & mask, mb & mask);
        }
        (self.enters(a, mask, t_max), self.enters(b, mask, t_max))
    }

    /// The lanes of `mask` whose segments enter `node`.
    #[inline(always)]
    fn enters(&self, node: &Node, mask: u32, t_max: &[f32; K]) -> u32 {
        let (tn, tf) = self.slabs(node);
        let mut hit = 0;
        for l in 0..K {
            if tn[l] <= fmin(tf[l], t_max[l]) {
                hit |= 1 << l;
            }
        }
        hit & mask
    }
}

impl Bvh {
    /// Nearest hit per lane, on the binary tree. `test(prim, lane, t_max)`
    /// intersects one primitive with one lane's ray and returns a hit with
    /// `t < t_max` or `None`.
    #[inline]
    pub fn closest_binary<const K: usize>(
        &self,
        packet: &Packet<K>,
        stats: &mut TraversalStats,
        mut test: impl NearestTest,
    ) -> PacketHits<K> {
        let mut out = PacketHits::<K>::none();
        if self.nodes.is_empty() || packet.mask == 0 {
            return out;
        }
        if K == 1 || packet.mask.count_ones() == 1 {
            // A ray alone: the same tests in the same order, without lane bookkeeping.
            // (A constant lane for K = 1 lets the test closure fold its indexing.)
            let l = if K == 1 {
                0
            } else {
                packet.mask.trailing_zeros() as usize
            };
            let ray = SingleRay::new(packet.origins[l], packet.dirs[l], packet.t_min);
            let mut state = LaneHit {
                best: packet.t_max[l],
                prim: PacketHits::<K>::NO_HIT,
                hit: NO_SURFACE,
            };
            self.descend_single(None, &ray, &mut state, stats, &mut test, l);
            out.prim[l] = state.prim;
            out.hit[l] = state.hit;
            return out;
        }
        let mut best = packet.t_max;
        let rays = Lanes::<K>::new(&packet.origins, &packet.dirs, packet.mask, packet.t_min);
        let neg = rays.neg;

        let mut stack = ArrayVec::<(u32, u32, [f32; K]), STACK>::new();
        stats.box_tests += packet.mask.count_ones() as u64;
        let (root_mask, tn_root) = rays.enter(&self.nodes[0], packet.mask, &best);
        if root_mask == 0 {
            return out;
        }
        stack.push((0, root_mask, tn_root));

        while let Some((index, mut mask, tnear)) = stack.pop() {
            // A lane whose nearest hit is now closer than this box skips it.
            for (l, tn) in tnear.iter().enumerate() {
                if mask & (1 << l) != 0 && *tn > best[l] * CULL_SLACK {
                    mask &= !(1 << l);
                }
            }
            if mask == 0 {
                continue;
            }
            if mask.count_ones() == 1 && K != 2 {
                // One lane left in this subtree: finish it as a plain ray. (Not for
                // a pair: its test of both children in one register measured
                // faster than the single-ray descent, docs/benchmarks.md.)
                let l = mask.trailing_zeros() as usize;
                let mut state = LaneHit {
                    best: best[l],
                    prim: out.prim[l],
                    hit: out.hit[l],
                };
                let ray = rays.single(l);
                self.descend_single(
                    Some((index, tnear[l])),
                    &ray,
                    &mut state,
                    stats,
                    &mut test,
                    l,
                );
                (best[l], out.prim[l], out.hit[l]) = (state.best, state.prim, state.hit);
                continue;
            }
            stats.nodes += 1;
            let node = &self.nodes[index as usize];
            if node.is_leaf() {
                test_leaf(
                    self.leaf(node.first, node.count()),
                    mask,
                    &mut best,
                    &mut out,
                    stats,
                    &mut test,
                );
                continue;
            }
            let (a, b) = (node.first as usize, node.first as usize + 1);
            let (near, far) = if neg[node.axis()] { (b, a) } else { (a, b) };
            stats.box_tests += 2 * mask.count_ones() as u64;
            let ((m_near, tn_near), (m_far, tn_far)) =
                rays.enter_children(&self.nodes[near], &self.nodes[far], mask, &best);
            if m_far != 0 {
                let _ = stack.try_push((far as u32, m_far, tn_far));
            }
            if m_near != 0 {
                let _ = stack.try_push((near as u32, m_near, tn_near));
            }
        }
        out
    }

    /// Any-hit for a packet of segments with their own origins and directions
    /// (shadow rays of several views toward one light). `test(prim, lane)` is
    /// called for every primitive whose boxes lane `lane`'s segment enters, until
    /// it answers `Stop` for that lane. Which primitives a lane visits does not
    /// depend on the other lanes, but the order may: callers must make their
    /// result independent of the order (see `shading::Transmittance`).
    pub fn occlusion_binary<const K: usize>(
        &self,
        packet: &SegmentPacket<K>,
        stats: &mut TraversalStats,
        test: &mut impl AnyHitTest,
    ) {
        if self.nodes.is_empty() || packet.mask == 0 {
            return;
        }
        if K == 1 || packet.mask.count_ones() == 1 {
            let l = if K == 1 {
                0
            } else {
                packet.mask.trailing_zeros() as usize
            };
            let ray = SingleRay::new(packet.origins[l], packet.dirs[l], 0.0);
            self.descend_occlusion(None, &ray, packet.t_max[l], stats, test, l);
            return;
        }
        let segments = Lanes::<K>::new(&packet.origins, &packet.dirs, packet.mask, 0.0);
        let neg = segments.neg;
        let t_max = &packet.t_max;
        let mut live = packet.mask;
        stats.box_tests += live.count_ones() as u64;
        let root_mask = segments.enters(&self.nodes[0], live, t_max);
        if root_mask == 0 {
            return;
        }
        let mut stack = ArrayVec::<(u32, u32), STACK>::new();
        stack.push((0, root_mask));
        while let Some((index, m)) = stack.pop() {
            let mask = m & live;
            if mask == 0 {
                continue;
            }
            if mask.count_ones() == 1 && K != 2 {
                // One live lane left in this subtree: finish it as a plain segment
                // (a pair keeps it, as in `closest`).
                let l = mask.trailing_zeros() as usize;
                let ray = segments.single(l);
                if self.descend_occlusion(Some(index), &ray, t_max[l], stats, test, l) {
                    live &= !(1 << l);
                }
                continue;
            }
            stats.nodes += 1;
            let node = &self.nodes[index as usize];
            if node.is_leaf() {
                occlusion_leaf(
                    self.leaf(node.first, node.count()),
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
            let (a, b) = (node.first as usize, node.first as usize + 1);
            let (near, far) = if neg[node.axis()] { (b, a) } else { (a, b) };
            stats.box_tests += 2 * mask.count_ones() as u64;
            let (m_near, m_far) =
                segments.enters_children(&self.nodes[near], &self.nodes[far], mask, t_max);
            if m_far != 0 {
                let _ = stack.try_push((far as u32, m_far));
            }
            if m_near != 0 {
                let _ = stack.try_push((near as u32, m_near));
            }
        }
    }

    /// One ray's depth-first descent of the subtree at `start` (entered at
    /// `tn_start`; `None`: the root), improving `state`. A packet hands a lane
    /// over to this when it is the only lane left in a subtree: depth-first order
    /// visits that whole subtree next either way. A ray traced alone starts here.
    #[inline(always)]
    fn descend_single<T: NearestTest>(
        &self,
        start: Option<(u32, f32)>,
        ray: &SingleRay,
        state: &mut LaneHit,
        stats: &mut TraversalStats,
        test: &mut T,
        lane: usize,
    ) {
        let ([ix, iy, iz], [ox, oy, oz]) = (ray.inv, ray.origin);
        let (neg, t_min) = (ray.neg, ray.t_min);
        let mut lh = *state;
        let entry = |node: &Node, best: f32| -> Option<f32> {
            let ([nx, ny, nz], [fx, fy, fz]) = slab_planes(node, &neg);
            let tn = fmax(fmax(nx * ix - ox, ny * iy - oy), fmax(nz * iz - oz, t_min));
            let tf = fmin(fmin(fx * ix - ox, fy * iy - oy), fz * iz - oz) * ROBUST;
            (tn <= tf && tn <= best * CULL_SLACK).then_some(tn)
        };
        let (mut nodes, mut boxes, mut prims) = (0u64, 0u64, 0u64);
        let start = match start {
            Some(s) => s,
            None => {
                stats.box_tests += 1;
                match entry(&self.nodes[0], lh.best) {
                    Some(tn) => (0, tn),
                    None => return,
                }
            }
        };
        let mut stack = ArrayVec::<(u32, f32), STACK>::new();
        stack.push(start);
        while let Some((index, tnear)) = stack.pop() {
            if tnear > lh.best * CULL_SLACK {
                continue;
            }
            nodes += 1;
            let node = &self.nodes[index as usize];
            if node.is_leaf() {
                prims += node.count() as u64;
                leaf_lane(self.leaf(node.first, node.count()), lane, &mut lh, test);
                continue;
            }
            let (a, b) = (node.first as usize, node.first as usize + 1);
            let (near, far) = if neg[node.axis()] { (b, a) } else { (a, b) };
            boxes += 2;
            let t_near = entry(&self.nodes[near], lh.best);
            if let Some(tn) = entry(&self.nodes[far], lh.best) {
                let _ = stack.try_push((far as u32, tn));
            }
            if let Some(tn) = t_near {
                let _ = stack.try_push((near as u32, tn));
            }
        }
        *state = lh;
        stats.nodes += nodes;
        stats.box_tests += boxes;
        stats.prim_tests += prims;
    }

    /// One segment's (`t_min < t < t_max` of `ray`) any-hit descent of the subtree
    /// at `start` (`None`: the root); returns whether `test` said stop. A shadow
    /// packet hands a lane over to this when it is the only live lane in a subtree.
    #[inline(always)]
    fn descend_occlusion<T: AnyHitTest>(
        &self,
        start: Option<u32>,
        ray: &SingleRay,
        t_max: f32,
        stats: &mut TraversalStats,
        test: &mut T,
        lane: usize,
    ) -> bool {
        let ([ix, iy, iz], [ox, oy, oz]) = (ray.inv, ray.origin);
        let neg = ray.neg;
        let enters =
            |node: &Node| segment_enters_node!([ix, iy, iz], [ox, oy, oz], &neg, node, t_max);
        let (mut nodes, mut boxes, mut prims) = (0u64, 0u64, 0u64);
        let mut stopped = false;
        let start = match start {
            Some(s) => s,
            None => {
                stats.box_tests += 1;
                if !enters(&self.nodes[0]) {
                    return false;
                }
                0
            }
        };
        let mut stack = ArrayVec::<u32, STACK>::new();
        stack.push(start);
        'descent: while let Some(index) = stack.pop() {
            nodes += 1;
            let node = &self.nodes[index as usize];
            if node.is_leaf() {
                if occlusion_lane(self.leaf(node.first, node.count()), lane, &mut prims, test) {
                    stopped = true;
                    break 'descent;
                }
                continue;
            }
            let (a, b) = (node.first as usize, node.first as usize + 1);
            let (near, far) = if neg[node.axis()] { (b, a) } else { (a, b) };
            boxes += 2;
            let near_in = enters(&self.nodes[near]);
            if enters(&self.nodes[far]) {
                let _ = stack.try_push(far as u32);
            }
            if near_in {
                let _ = stack.try_push(near as u32);
            }
        }
        stats.nodes += nodes;
        stats.box_tests += boxes;
        stats.prim_tests += prims;
        stopped
    }
}

#[cfg(test)]
mod tests {
    use super::super::brute_force;
    use super::super::{build, primitive_box, BuildOptions};
    use super::*;
    use crate::math::{Aabb, Ray};
    use crate::shapes::{Shape, Sphere};

    fn spheres(n: usize) -> Vec<Sphere> {
        let mut rng = fastrand::Rng::with_seed(7);
        let mut next = || rng.f32();
        (0..n)
            .map(|_| Sphere {
                center: Vec3::new(
                    next() * 20.0 - 10.0,
                    next() * 20.0 - 10.0,
                    next() * 20.0 + 5.0,
                ),
                radius: 0.2 + next(),
                inside: false,
            })
            .collect()
    }

    fn brute(sph: &[Sphere], ray: &Ray) -> Option<(u32, f32)> {
        let mut best: Option<(u32, f32)> = None;
        for (i, s) in sph.iter().enumerate() {
            if let Some(h) = s.intersect(ray, 0.0, f32::INFINITY) {
                if best.is_none_or(|(_, t)| h.t < t) {
                    best = Some((i as u32, h.t));
                }
            }
        }
        best
    }

    #[test]
    fn nearest_hit_matches_brute_force_for_every_lane() {
        let sph = spheres(500);
        let boxes: Vec<Aabb> = sph.iter().map(|s| s.bounds()).collect();
        let bvh = build(&boxes, &BuildOptions::default());
        let mut stats = TraversalStats::default();
        let mut rng = fastrand::Rng::with_seed(3);
        for _ in 0..2000 {
            let (a, b) = (rng.f32(), rng.f32());
            let dir = Vec3::new(a - 0.5, b - 0.5, 1.0).normalize();
            let origins = [
                Vec3::new(-0.3, 0.0, 0.0),
                Vec3::new(0.3, 0.0, 0.0),
                Vec3::new(1.7, 0.1, 0.0),
            ];
            // The third lane's direction differs: lanes need not be parallel.
            let dirs = [dir, dir, (dir + Vec3::new(0.05, -0.02, 0.0)).normalize()];
            let packet = Packet {
                origins,
                dirs,
                t_min: 0.0,
                t_max: [f32::INFINITY; 3],
                mask: 0b111,
            };
            let hits = bvh.closest(&packet, &mut stats, |p: u32, l: usize, tmax: f32| {
                sph[p as usize].intersect(&Ray::new(origins[l], dirs[l]), 0.0, tmax)
            });
            // And as a pair (the stereo case, both children tested at once).
            let pair = Packet {
                origins: [origins[0], origins[2]],
                dirs: [dirs[0], dirs[2]],
                t_min: 0.0,
                t_max: [f32::INFINITY; 2],
                mask: 0b11,
            };
            let pair_hits = bvh.closest(&pair, &mut stats, |p: u32, l: usize, tmax: f32| {
                sph[p as usize].intersect(&Ray::new(pair.origins[l], pair.dirs[l]), 0.0, tmax)
            });
            assert_eq!(pair_hits.prim, [hits.prim[0], hits.prim[2]]);
            assert_eq!(pair_hits.hit, [hits.hit[0], hits.hit[2]]);
            for (l, (&o, &dir)) in origins.iter().zip(&dirs).enumerate() {
                let expect = brute(&sph, &Ray::new(o, dir));
                let got = hits.has_hit(l).then(|| (hits.prim[l], hits.hit[l].t));
                assert_eq!(got, expect, "lane {l}");
                // Alone, as a packet of one, the lane gets the same answer.
                let single = Packet::ray(o, dir);
                let h1 = bvh.closest(&single, &mut stats, |p: u32, _: usize, tmax: f32| {
                    sph[p as usize].intersect(&Ray::new(o, dir), 0.0, tmax)
                });
                assert_eq!(h1.prim[0], hits.prim[l]);
                assert_eq!(h1.hit[0], hits.hit[l]);
            }
        }
        assert!(stats.nodes > 0);
    }

    #[test]
    fn masked_lanes_are_not_traced() {
        let sph = spheres(50);
        let boxes: Vec<Aabb> = sph.iter().map(|s| s.bounds()).collect();
        let bvh = build(&boxes, &BuildOptions::default());
        let packet = Packet {
            origins: [Vec3::ZERO; 2],
            dirs: [Vec3::Z; 2],
            t_min: 0.0,
            t_max: [f32::INFINITY; 2],
            mask: 0b01,
        };
        let mut stats = TraversalStats::default();
        let hits = bvh.closest(&packet, &mut stats, |p: u32, l: usize, tmax: f32| {
            assert_eq!(l, 0);
            sph[p as usize].intersect(&Ray::new(Vec3::ZERO, Vec3::Z), 0.0, tmax)
        });
        assert!(!hits.has_hit(1));
    }

    #[test]
    fn occlusion_finds_every_occluder_on_the_segment() {
        let sph = spheres(300);
        let boxes: Vec<Aabb> = sph.iter().map(|s| s.bounds()).collect();
        let bvh = build(&boxes, &BuildOptions::default());
        let mut stats = TraversalStats::default();
        for i in 0..200 {
            let dirs = [
                Vec3::new(
                    (i as f32 * 0.37).sin() * 0.4,
                    (i as f32 * 0.11).cos() * 0.4,
                    1.0,
                )
                .normalize(),
                Vec3::new(
                    (i as f32 * 0.23).cos() * 0.4,
                    (i as f32 * 0.31).sin() * -0.4,
                    1.0,
                )
                .normalize(),
            ];
            let origins = [Vec3::ZERO, Vec3::new(0.5, 0.0, 0.0)];
            for t_max in [5.0, 12.0, 40.0] {
                let packet = SegmentPacket {
                    origins,
                    dirs,
                    t_max: [t_max; 2],
                    mask: 0b11,
                };
                let mut found = [Vec::new(), Vec::new()];
                bvh.occlusion(&packet, &mut stats, &mut |p: u32, l: usize| {
                    if sph[p as usize]
                        .intersect(&Ray::new(origins[l], dirs[l]), 0.0, t_max)
                        .is_some()
                    {
                        found[l].push(p);
                    }
                    AnyHit::Continue
                });
                for l in 0..2 {
                    let ray = Ray::new(origins[l], dirs[l]);
                    let mut expect: Vec<u32> = (0..sph.len() as u32)
                        .filter(|&p| sph[p as usize].intersect(&ray, 0.0, t_max).is_some())
                        .collect();
                    found[l].sort();
                    expect.sort();
                    assert_eq!(found[l], expect, "lane {l}");
                }
            }
        }
    }

    /// The primitives `occlusion` tests for each lane of a packet of segments.
    fn tested<const K: usize>(bvh: &Bvh, segs: [(Vec3, Vec3, f32); K]) -> [Vec<u32>; K] {
        let packet = SegmentPacket {
            origins: segs.map(|s| s.0),
            dirs: segs.map(|s| s.1),
            t_max: segs.map(|s| s.2),
            mask: (1 << K) - 1,
        };
        let mut seen: [Vec<u32>; K] = std::array::from_fn(|_| Vec::new());
        let mut stats = TraversalStats::default();
        bvh.occlusion(&packet, &mut stats, &mut |p: u32, l: usize| {
            seen[l].push(p);
            AnyHit::Continue
        });
        seen
    }

    #[test]
    fn a_segment_entering_a_primitives_box_reaches_the_primitive() {
        // The shadow cache trusts a primitive only where `segment_enters` says
        // the traversal tests it too, for a lane alone, in a pair or in a packet.
        // Segments start near and very far (1e8, where a primitive's own test
        // can report hits outside its box) and graze the boxes' corners.
        let sph = spheres(300);
        let boxes: Vec<Aabb> = sph.iter().map(|s| s.bounds()).collect();
        let bvh = build(&boxes, &BuildOptions::default());
        let mut rng = fastrand::Rng::with_seed(5);
        let mut entered = 0;
        for _ in 0..300 {
            let segs: [(Vec3, Vec3, f32); 3] = std::array::from_fn(|_| {
                let far = [1.0, 30.0, 1e5, 1e8][rng.usize(..4)];
                let origin = Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5) * far;
                let b = &boxes[rng.usize(..boxes.len())];
                let pick =
                    |lo: f32, hi: f32, rng: &mut fastrand::Rng| if rng.bool() { lo } else { hi };
                let corner = Vec3::new(
                    pick(b.min.x, b.max.x, &mut rng),
                    pick(b.min.y, b.max.y, &mut rng),
                    pick(b.min.z, b.max.z, &mut rng),
                );
                let aim = corner + Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 1e-3;
                let dir = (aim - origin).normalize();
                (origin, dir, (aim - origin).length() * (0.5 + rng.f32()))
            });
            let [s0, s1, s2] = segs;
            let runs: [(Vec<usize>, Vec<Vec<u32>>); 6] = [
                (vec![0], tested(&bvh, [s0]).to_vec()),
                (vec![1], tested(&bvh, [s1]).to_vec()),
                (vec![2], tested(&bvh, [s2]).to_vec()),
                (vec![0, 1], tested(&bvh, [s0, s1]).to_vec()),
                (vec![1, 2], tested(&bvh, [s1, s2]).to_vec()),
                (vec![0, 1, 2], tested(&bvh, segs).to_vec()),
            ];
            for (lanes, seen) in &runs {
                for (k, &l) in lanes.iter().enumerate() {
                    let (o, d, t) = segs[l];
                    for (p, b) in boxes.iter().enumerate() {
                        if segment_enters(&primitive_box(b), o, d, t) {
                            entered += 1;
                            assert!(
                                seen[k].contains(&(p as u32)),
                                "lanes {lanes:?}: segment {l} enters primitive {p}'s box, untested"
                            );
                        }
                    }
                }
            }
        }
        assert!(entered > 1000, "{entered}");
    }

    /// The tracer's nearest test: a pair of lanes through `intersect_pair`.
    struct PacketTest<'a, const K: usize> {
        shapes: &'a [Shape],
        packet: &'a Packet<K>,
    }

    impl<const K: usize> NearestTest for PacketTest<'_, K> {
        fn test(&mut self, prim: u32, lane: usize, t_max: f32) -> Option<SurfaceHit> {
            let ray = Ray::new(self.packet.origins[lane], self.packet.dirs[lane]);
            self.shapes[prim as usize].intersect(&ray, self.packet.t_min, t_max)
        }

        fn test_pair(&mut self, prim: u32, t_max: [f32; 2]) -> [Option<SurfaceHit>; 2] {
            let p = self.packet;
            let rays = [0, 1 % K].map(|l| Ray::new(p.origins[l], p.dirs[l]));
            self.shapes[prim as usize].intersect_pair(&rays, p.t_min, t_max)
        }
    }

    fn hit_bits(h: &SurfaceHit) -> [u32; 3] {
        [h.t.to_bits(), h.u.to_bits(), h.v.to_bits()]
    }

    /// `packets` random packets of `K` lanes: every lane's nearest hit and
    /// every primitive its segment meets equal the brute-force answers.
    fn check_against_brute_force<const K: usize>(
        shapes: &[Shape],
        bvh: &Bvh,
        rng: &mut fastrand::Rng,
        packets: usize,
    ) -> usize {
        let mut stats = TraversalStats::default();
        let mut hits_seen = 0;
        for n in 0..packets {
            let packet = brute_force::random_packet::<K>(rng);
            let expect = brute_force::closest_hits(shapes, &packet);
            let got = bvh.closest(
                &packet,
                &mut stats,
                PacketTest {
                    shapes,
                    packet: &packet,
                },
            );
            for l in 0..K {
                let what = format!("K={K}, packet {n}, lane {l}: {packet:?}");
                assert_eq!(got.prim[l], expect.prim[l], "{what}");
                if expect.has_hit(l) {
                    hits_seen += 1;
                    assert_eq!(hit_bits(&got.hit[l]), hit_bits(&expect.hit[l]), "{what}");
                }
            }
            // Any-hit: every primitive on each lane's segment is met, and a
            // lane that stops at its first is blocked exactly when one exists.
            let segments = brute_force::segments_of(&packet);
            let mut met: [Vec<u32>; K] = std::array::from_fn(|_| Vec::new());
            bvh.occlusion(&segments, &mut stats, &mut |p: u32, l: usize| {
                let ray = Ray::new(segments.origins[l], segments.dirs[l]);
                if shapes[p as usize]
                    .intersect(&ray, 0.0, segments.t_max[l])
                    .is_some()
                {
                    met[l].push(p);
                }
                AnyHit::Continue
            });
            let mut blocked = 0u32;
            bvh.occlusion(&segments, &mut stats, &mut |p: u32, l: usize| {
                let ray = Ray::new(segments.origins[l], segments.dirs[l]);
                if shapes[p as usize]
                    .intersect(&ray, 0.0, segments.t_max[l])
                    .is_some()
                {
                    blocked |= 1 << l;
                    return AnyHit::Stop;
                }
                AnyHit::Continue
            });
            for (l, met) in met.iter_mut().enumerate() {
                let expect = brute_force::occluders(shapes, &segments, l);
                met.sort_unstable();
                assert_eq!(*met, expect, "K={K}, packet {n}, lane {l}: occluders");
                assert_eq!(
                    blocked & (1 << l) != 0,
                    !expect.is_empty(),
                    "K={K}, lane {l}"
                );
            }
        }
        hits_seen
    }

    #[test]
    fn packets_of_every_width_match_brute_force_on_random_shapes_and_rays() {
        // Spheres, triangles (slivers and coplanar ones), cones, inside-out
        // shapes; lanes with their own origins, directions, t_max and masks.
        let mut rng = fastrand::Rng::with_seed(17);
        let shapes = brute_force::random_shapes(&mut rng, 300);
        let boxes: Vec<Aabb> = shapes.iter().map(Shape::bounds).collect();
        let bvh = build(&boxes, &BuildOptions::default());
        let hits = check_against_brute_force::<1>(&shapes, &bvh, &mut rng, 400)
            + check_against_brute_force::<2>(&shapes, &bvh, &mut rng, 400)
            + check_against_brute_force::<3>(&shapes, &bvh, &mut rng, 200)
            + check_against_brute_force::<4>(&shapes, &bvh, &mut rng, 200)
            + check_against_brute_force::<8>(&shapes, &bvh, &mut rng, 100)
            + check_against_brute_force::<32>(&shapes, &bvh, &mut rng, 40);
        // The rays found something to disagree about.
        assert!(hits > 1000, "{hits} lanes hit");
    }
}

//! The traversals' contract and their entry points: nearest hit per lane for
//! a packet of rays (`Bvh::closest`, and for the eye pass `closest_ray` and
//! `closest_packet8`), and any hit per lane for a packet of segments (shadow
//! rays, `Bvh::occlusion`). Each descends the eight-wide tree
//! (`collapse.rs`); `descent.rs` holds the descents.
//!
//! A packet carries one ray per view — the paper's twin objects realised as
//! rays: view `v`'s ray through the shared world is the same as one ray through
//! view `v`'s translated twins. The lanes of a packet may have different
//! origins and directions (the twin method pairs the views' rays that see one
//! surface point, see `render`).
//!
//! Exactness: every lane's box and primitive tests use that lane's own numbers,
//! with the operations the single-ray descent uses; culling is conservative
//! (`CULL_SLACK`), so the nearest hit — ties in distance go to the lower
//! primitive index — does not depend on the order in which nodes are visited:
//! a lane in any packet gets what the same ray traced alone gets.

use super::descent::{Entry, EYE_PACKET};
use super::{Bvh, Node};
use crate::math::{Aabb, Vec3};
use crate::shapes::{BlockHits, EightHits, SurfaceHit, Triangle4};
use wide::f32x8;

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

    /// No lane has a hit yet: where the nearest-hit descents start.
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
    /// Nodes popped and processed (one per node per descent, whatever its lanes).
    pub nodes: u64,
    /// Box tests, one per lane and child slot of a node tested.
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

/// Entries a descent's stack holds (`stack_bound.rs` says why it is enough).
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

/// `min` without the NaN rules of `f32::min` (one instruction, `minps`'s
/// `a < b ? a : b`): the slab test never produces NaN, since `safe_inverse`
/// keeps 1/d finite.
#[inline(always)]
pub(super) fn fmin(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}

/// `max` likewise (`maxps`'s `a > b ? a : b`).
#[inline(always)]
pub(super) fn fmax(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
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

/// One ray prepared for slab tests: the numbers every descent splats into
/// its registers (`descent.rs`), so that a ray's entry and exit distances
/// for a box are the same bits in every descent.
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

    /// Entry and (robustly widened) exit distance of the ray for `node`'s
    /// box: per lane what the descents' slab tests compute (the planes
    /// picked by the ray's signs, `plane * inv - origin`, then `max` and
    /// `min` in this order).
    #[inline(always)]
    pub(super) fn slabs(&self, node: &Node) -> (f32, f32) {
        let ([ix, iy, iz], [ox, oy, oz]) = (self.inv, self.origin);
        let pick = |a: usize| {
            if self.neg[a] {
                (node.max[a], node.min[a])
            } else {
                (node.min[a], node.max[a])
            }
        };
        let ((nx, fx), (ny, fy), (nz, fz)) = (pick(0), pick(1), pick(2));
        let tn = fmax(
            fmax(nx * ix - ox, ny * iy - oy),
            fmax(nz * iz - oz, self.t_min),
        );
        let tf = fmin(fmin(fx * ix - ox, fy * iy - oy), fz * iz - oz) * ROBUST;
        (tn, tf)
    }
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
    let (tn, tf) = ray.slabs(&node);
    tn <= fmin(tf, t_max)
}

/// One lane's nearest hit so far.
#[derive(Clone, Copy)]
pub(super) struct LaneHit {
    pub(super) best: f32,
    pub(super) prim: u32,
    pub(super) hit: SurfaceHit,
}

impl LaneHit {
    /// No hit yet, nearer than `t_max`.
    #[inline(always)]
    pub(super) fn within(t_max: f32) -> LaneHit {
        LaneHit {
            best: t_max,
            prim: PacketHits::<1>::NO_HIT,
            hit: NO_SURFACE,
        }
    }

    /// Lane `l` of a packet's hits so far (`best`, `out`).
    #[inline(always)]
    pub(super) fn of<const K: usize>(l: usize, best: &[f32; K], out: &PacketHits<K>) -> LaneHit {
        LaneHit {
            best: best[l],
            prim: out.prim[l],
            hit: out.hit[l],
        }
    }

    /// Writes this lane back as lane `l` of a packet's hits so far.
    #[inline(always)]
    pub(super) fn store<const K: usize>(
        &self,
        l: usize,
        best: &mut [f32; K],
        out: &mut PacketHits<K>,
    ) {
        (best[l], out.prim[l], out.hit[l]) = (self.best, self.prim, self.hit);
    }

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

impl Bvh {
    /// Nearest hit per lane: `test(prim, lane, t_max)` intersects one
    /// primitive with one lane's ray and returns a hit with `t < t_max` or
    /// `None`; each active lane gets the nearest primitive its ray meets
    /// (`t_min < t < t_max[lane]`), ties to the lower index, bit for bit
    /// what it gets alone. Every lane descends the tree alone (a ray alone,
    /// a stereo pair, the views of a batch), but for a packet of eight (a
    /// shading packet's secondary rays), which goes down in one descent
    /// where its lanes' direction signs agree (`closest_packet8`).
    /// docs/benchmarks.md has the measurements: two rays of a pair alone
    /// beat one descent for the pair; eight secondary rays in one descent
    /// beat them alone.
    #[inline]
    pub fn closest<const K: usize>(
        &self,
        packet: &Packet<K>,
        stats: &mut TraversalStats,
        mut test: impl NearestTest,
    ) -> PacketHits<K> {
        if K != EYE_PACKET || packet.mask.count_ones() < 2 {
            return self.closest_each(packet, stats, test);
        }
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
        let hits = match self.closest_packet(&eight, stats, &mut test) {
            Some(hits) => hits,
            None => self.closest_each(&eight, stats, test),
        };
        let mut out = PacketHits::<K>::none();
        for l in 0..K {
            out.prim[l] = hits.prim[l];
            out.hit[l] = hits.hit[l];
        }
        out
    }

    /// `closest` for a packet of one, for callers that trace rays one at a
    /// time (the eye pass): lane 0's nearest hit and its primitive
    /// (`NO_HIT` for none). Inlined, so the answer stays in registers:
    /// returned through memory, its reload stalled on the stores that wrote
    /// it (docs/benchmarks.md).
    #[inline(always)]
    pub fn closest_ray(
        &self,
        packet: &Packet<1>,
        stats: &mut TraversalStats,
        mut test: impl NearestTest,
    ) -> (u32, SurfaceHit) {
        let mut state = LaneHit::within(packet.t_max[0]);
        if packet.mask & 1 != 0 && !self.wide.is_empty() {
            let ray = SingleRay::new(packet.origins[0], packet.dirs[0], packet.t_min);
            self.closest_one(Entry::root(&ray), &ray, &mut state, stats, &mut test, 0);
        }
        (state.prim, state.hit)
    }

    /// Nearest hit per lane of up to eight rays (the lanes of
    /// `packet.mask`: eye rays of neighbouring samples, or a shading
    /// packet's secondary rays) in one descent: each lane's hit bit for bit
    /// its own descent's. `None` where the packet does not apply (no lane,
    /// or the active lanes' direction signs differ): the caller traces its
    /// rays alone.
    #[inline]
    pub fn closest_packet8(
        &self,
        packet: &Packet<EYE_PACKET>,
        stats: &mut TraversalStats,
        mut test: impl NearestTest,
    ) -> Option<PacketHits<EYE_PACKET>> {
        self.closest_packet(packet, stats, &mut test)
    }

    /// Each active lane of `packet` alone.
    #[inline]
    fn closest_each<const K: usize>(
        &self,
        packet: &Packet<K>,
        stats: &mut TraversalStats,
        mut test: impl NearestTest,
    ) -> PacketHits<K> {
        let mut out = PacketHits::<K>::none();
        if self.wide.is_empty() {
            return out;
        }
        let mut lanes = packet.mask & ((1u64 << K) - 1) as u32;
        while lanes != 0 {
            let l = lanes.trailing_zeros() as usize;
            lanes &= lanes - 1;
            let ray = SingleRay::new(packet.origins[l], packet.dirs[l], packet.t_min);
            let mut state = LaneHit::within(packet.t_max[l]);
            self.closest_one(Entry::root(&ray), &ray, &mut state, stats, &mut test, l);
            out.prim[l] = state.prim;
            out.hit[l] = state.hit;
        }
        out
    }

    /// Any hit per lane, for a packet of segments with their own origins and
    /// directions (shadow rays of several views toward one light).
    /// `test(prim, lane)` is called for every primitive whose boxes lane
    /// `lane`'s segment enters, until it answers `Stop` for that lane. Which
    /// primitives a lane visits does not depend on the other lanes, but the
    /// order may: callers must make their result independent of the order
    /// (see `shading::Transmittance`).
    ///
    /// A stereo pair's two segments go down in one descent; so do the live
    /// segments of a packet of three to eight lanes (a mono row's
    /// neighbouring samples, a group's views) where their direction signs
    /// agree; any other segment alone (docs/benchmarks.md has the
    /// measurements).
    pub fn occlusion<const K: usize>(
        &self,
        packet: &SegmentPacket<K>,
        stats: &mut TraversalStats,
        test: &mut impl AnyHitTest,
    ) {
        if self.wide.is_empty() {
            return;
        }
        let mask = packet.mask & ((1u64 << K.min(32)) - 1) as u32;
        if K == 2 && mask == 0b11 {
            self.occlusion_pair(packet, stats, test);
        } else if !(K > 2 && mask.count_ones() > 1 && self.occlusion_packet(packet, stats, test)) {
            let mut lanes = mask;
            while lanes != 0 {
                let l = lanes.trailing_zeros() as usize;
                lanes &= lanes - 1;
                let ray = SingleRay::new(packet.origins[l], packet.dirs[l], 0.0);
                self.occlusion_one((0, 0), &ray, packet.t_max[l], stats, test, l);
            }
        }
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

    /// `spheres(n)`, their boxes and their hierarchy.
    fn sphere_tree(n: usize) -> (Vec<Sphere>, Vec<Aabb>, Bvh) {
        let sph = spheres(n);
        let boxes: Vec<Aabb> = sph.iter().map(|s| s.bounds()).collect();
        let bvh = build(&boxes, &BuildOptions::default());
        (sph, boxes, bvh)
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
        let (sph, _, bvh) = sphere_tree(500);
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
        let (sph, _, bvh) = sphere_tree(50);
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
        let (sph, _, bvh) = sphere_tree(300);
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
        let (_, boxes, bvh) = sphere_tree(300);
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

    /// A packet's rays against shapes, one lane and one primitive at a time.
    struct PacketTest<'a, const K: usize> {
        shapes: &'a [Shape],
        packet: &'a Packet<K>,
    }

    impl<const K: usize> NearestTest for PacketTest<'_, K> {
        fn test(&mut self, prim: u32, lane: usize, t_max: f32) -> Option<SurfaceHit> {
            let ray = Ray::new(self.packet.origins[lane], self.packet.dirs[lane]);
            self.shapes[prim as usize].intersect(&ray, self.packet.t_min, t_max)
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
            let [all, first] = [false, true].map(|stop| {
                brute_force::met(shapes, &segments, stop, |mut test| {
                    bvh.occlusion(&segments, &mut stats, &mut test)
                })
            });
            for l in 0..K {
                let expect = brute_force::occluders(shapes, &segments, l);
                assert_eq!(all[l], expect, "K={K}, packet {n}, lane {l}: occluders");
                assert_eq!(first[l].is_empty(), expect.is_empty(), "K={K}, lane {l}");
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

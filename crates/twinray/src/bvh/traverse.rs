//! Traversals: nearest hit per lane for a packet of rays with one direction,
//! and any-hit along one ray.
//!
//! A packet is the paper's "one eye ray, the nearest hit of every view": lane
//! `v` is view `v`'s ray (origin offset along the interocular line, direction
//! shared), which is the same as tracing one ray through view `v`'s twin
//! objects. One descent serves every lane; each lane keeps its own nearest
//! distance and is carried into a node only if its own box test passes.
//!
//! Exactness: the order in which nodes are visited depends only on the shared
//! direction, and every lane's box and primitive tests use that lane's own
//! numbers, so a lane sees the same sequence of tests as the same ray traced
//! alone (a packet of one). Ties in distance go to the lower primitive index.

use super::{Bvh, Node};
use crate::math::Vec3;
use crate::shapes::SurfaceHit;
use wide::f32x4;

/// Rays sharing `dir`, one per active lane. Lanes not in `mask` are ignored.
#[derive(Clone, Copy, Debug)]
pub struct Packet<const K: usize> {
    pub origins: [Vec3; K],
    pub dir: Vec3,
    pub t_min: f32,
    pub t_max: [f32; K],
    pub mask: u32,
}

/// Segments `origins[l] + t * dirs[l]`, `0 < t < t_max[l]`, one per active lane.
#[derive(Clone, Copy, Debug)]
pub struct SegmentPacket<const K: usize> {
    pub origins: [Vec3; K],
    pub dirs: [Vec3; K],
    pub t_max: [f32; K],
    pub mask: u32,
}

/// The nearest hit of each lane (`prim == NO_HIT` where there is none).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PacketHits<const K: usize> {
    pub prim: [u32; K],
    pub hit: [SurfaceHit; K],
}

impl<const K: usize> PacketHits<K> {
    pub const NO_HIT: u32 = u32::MAX;

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
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TraversalStats {
    /// Nodes popped and processed (one per node per packet, whatever its lanes).
    pub nodes: u64,
    /// Box tests, one per lane and node.
    pub box_tests: u64,
    /// Primitive tests, one per lane and primitive.
    pub prim_tests: u64,
}

impl TraversalStats {
    pub fn add(&mut self, o: &TraversalStats) {
        self.nodes += o.nodes;
        self.box_tests += o.box_tests;
        self.prim_tests += o.prim_tests;
    }
}

const STACK: usize = 128;
/// A box is skipped when its entry lies beyond the nearest hit so far by more
/// than this factor. The slack covers the rounding of a primitive's hit
/// distance against its box's entry distance (a floor polygon lies in its
/// box's face), so that no traversal order can skip a hit another would find:
/// the nearest hit is then the same for a lane traced alone or in any packet.
const CULL_SLACK: f32 = 1.0 + 1.0 / 4096.0;
/// Ize's robust slab test: widen the exit distance by 1 + 2*gamma(3).
const ROBUST: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// `min` and `max` without the NaN rules of `f32::min` (one instruction each):
/// the slab test never produces NaN, since `safe_inverse` keeps 1/d finite.
#[inline(always)]
fn fmin(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}

#[inline(always)]
fn fmax(a: f32, b: f32) -> f32 {
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

/// One ray prepared for slab tests (see `RayLanes` for the same per lane).
#[derive(Clone, Copy)]
struct SingleRay {
    inv: Vec3,
    neg: [bool; 3],
    /// The origin scaled by `inv`.
    origin: [f32; 3],
    t_min: f32,
}

/// One segment prepared for slab tests (a shadow ray).
#[derive(Clone, Copy)]
struct SingleSegment {
    inv: [f32; 3],
    neg: [bool; 3],
    /// The origin scaled by `inv`.
    origin: [f32; 3],
    t_max: f32,
}

/// One lane's nearest hit so far.
struct LaneHit {
    best: f32,
    prim: u32,
    hit: SurfaceHit,
}

/// The lanes of a `Packet` prepared for slab tests: the shared direction's
/// inverse and signs, and the origins scaled by it, as structure of arrays.
struct RayLanes<const K: usize> {
    inv: Vec3,
    neg: [bool; 3],
    ox: [f32; K],
    oy: [f32; K],
    oz: [f32; K],
    t_min: f32,
}

impl<const K: usize> RayLanes<K> {
    /// The lanes of `mask` that enter `node` before their nearest hit so far;
    /// writes each lane's entry distance to `tnear`.
    #[inline(always)]
    fn enter(&self, node: &Node, mask: u32, best: &[f32; K], tnear: &mut [f32; K]) -> u32 {
        // The direction is shared: every lane enters through the same planes.
        let ([nx, ny, nz], [fx, fy, fz]) = slab_planes(node, &self.neg);
        let (nx, fx) = (nx * self.inv.x, fx * self.inv.x);
        let (ny, fy) = (ny * self.inv.y, fy * self.inv.y);
        let (nz, fz) = (nz * self.inv.z, fz * self.inv.z);
        if K > 1 && K <= 4 {
            // Up to four lanes in one SSE register: the same IEEE operations as
            // the scalar path below, lane by lane, so the results are identical.
            let pad = |a: &[f32; K]| {
                let mut v = [0.0f32; 4];
                v[..K].copy_from_slice(a);
                f32x4::from(v)
            };
            let (ox, oy, oz) = (pad(&self.ox), pad(&self.oy), pad(&self.oz));
            let tn = (f32x4::splat(nx) - ox)
                .fast_max(f32x4::splat(ny) - oy)
                .fast_max((f32x4::splat(nz) - oz).fast_max(f32x4::splat(self.t_min)));
            let tf = (f32x4::splat(fx) - ox)
                .fast_min(f32x4::splat(fy) - oy)
                .fast_min(f32x4::splat(fz) - oz)
                * f32x4::splat(ROBUST);
            let bound = pad(best) * f32x4::splat(CULL_SLACK);
            let hit = tn.simd_le(tf) & tn.simd_le(bound);
            tnear.copy_from_slice(&tn.to_array()[..K]);
            return hit.to_bitmask() & mask;
        }
        let mut hit_mask = 0;
        for l in 0..K {
            let tn = fmax(
                fmax(nx - self.ox[l], ny - self.oy[l]),
                fmax(nz - self.oz[l], self.t_min),
            );
            let tf = fmin(fmin(fx - self.ox[l], fy - self.oy[l]), fz - self.oz[l]) * ROBUST;
            tnear[l] = tn;
            if tn <= tf && tn <= best[l] * CULL_SLACK {
                hit_mask |= 1 << l;
            }
        }
        hit_mask & mask
    }
}

/// The lanes of a `SegmentPacket` prepared for slab tests.
struct SegmentLanes<const K: usize> {
    ix: [f32; K],
    iy: [f32; K],
    iz: [f32; K],
    ox: [f32; K],
    oy: [f32; K],
    oz: [f32; K],
    t_max: [f32; K],
    /// Direction signs of the first lane, which order the descent.
    neg: [bool; 3],
    /// Every active lane has the signs `neg`.
    same_signs: bool,
}

impl<const K: usize> SegmentLanes<K> {
    /// The lanes of `mask` whose segments enter `node`.
    #[inline(always)]
    fn enters(&self, node: &Node, mask: u32) -> u32 {
        let (min, max) = (&node.min, &node.max);
        let mut m = 0;
        if self.same_signs && K > 1 && K <= 4 {
            // As in `RayLanes::enter`: four lanes at once, the same operations.
            let pad = |a: &[f32; K]| {
                let mut v = [0.0f32; 4];
                v[..K].copy_from_slice(a);
                f32x4::from(v)
            };
            let ([nx, ny, nz], [fx, fy, fz]) = slab_planes(node, &self.neg);
            let (ix, iy, iz) = (pad(&self.ix), pad(&self.iy), pad(&self.iz));
            let (ox, oy, oz) = (pad(&self.ox), pad(&self.oy), pad(&self.oz));
            let tn = (f32x4::splat(nx) * ix - ox)
                .fast_max(f32x4::splat(ny) * iy - oy)
                .fast_max((f32x4::splat(nz) * iz - oz).fast_max(f32x4::splat(0.0)));
            let tf = (f32x4::splat(fx) * ix - ox)
                .fast_min(f32x4::splat(fy) * iy - oy)
                .fast_min(f32x4::splat(fz) * iz - oz)
                * f32x4::splat(ROBUST);
            let hit = tn.simd_le(tf.fast_min(pad(&self.t_max)));
            return hit.to_bitmask() & mask;
        }
        if self.same_signs {
            let ([nx, ny, nz], [fx, fy, fz]) = slab_planes(node, &self.neg);
            for l in 0..K {
                let tn = fmax(
                    fmax(nx * self.ix[l] - self.ox[l], ny * self.iy[l] - self.oy[l]),
                    fmax(nz * self.iz[l] - self.oz[l], 0.0),
                );
                let tf = fmin(
                    fmin(fx * self.ix[l] - self.ox[l], fy * self.iy[l] - self.oy[l]),
                    fz * self.iz[l] - self.oz[l],
                ) * ROBUST;
                if tn <= fmin(tf, self.t_max[l]) {
                    m |= 1 << l;
                }
            }
            return m & mask;
        }
        for l in 0..K {
            let (x0, x1) = (
                min[0] * self.ix[l] - self.ox[l],
                max[0] * self.ix[l] - self.ox[l],
            );
            let (y0, y1) = (
                min[1] * self.iy[l] - self.oy[l],
                max[1] * self.iy[l] - self.oy[l],
            );
            let (z0, z1) = (
                min[2] * self.iz[l] - self.oz[l],
                max[2] * self.iz[l] - self.oz[l],
            );
            let tn = fmax(fmax(fmin(x0, x1), fmin(y0, y1)), fmax(fmin(z0, z1), 0.0));
            let tf = fmin(fmin(fmax(x0, x1), fmax(y0, y1)), fmax(z0, z1)) * ROBUST;
            if tn <= fmin(tf, self.t_max[l]) {
                m |= 1 << l;
            }
        }
        m & mask
    }
}

impl Bvh {
    /// Nearest hit per lane. `test(prim, lane, t_max)` intersects one primitive with
    /// one lane's ray and returns a hit with `t < t_max` or `None`.
    #[inline]
    pub fn closest<const K: usize>(
        &self,
        packet: &Packet<K>,
        stats: &mut TraversalStats,
        mut test: impl FnMut(u32, usize, f32) -> Option<SurfaceHit>,
    ) -> PacketHits<K> {
        let none = SurfaceHit {
            t: f32::INFINITY,
            u: 0.0,
            v: 0.0,
        };
        let mut out = PacketHits {
            prim: [PacketHits::<K>::NO_HIT; K],
            hit: [none; K],
        };
        if self.nodes.is_empty() || packet.mask == 0 {
            return out;
        }
        if K == 1 {
            // A ray alone: the same tests in the same order, without lane bookkeeping.
            let (prim, hit) = self.closest_single(
                packet.origins[0],
                packet.dir,
                packet.t_min,
                packet.t_max[0],
                stats,
                |p, t| test(p, 0, t),
            );
            out.prim[0] = prim;
            out.hit[0] = hit;
            return out;
        }
        let mut best = packet.t_max;
        let inv = safe_inverse(packet.dir);
        let neg = [inv.x < 0.0, inv.y < 0.0, inv.z < 0.0];
        // Lanes share the direction, so the entry and exit planes of every box are
        // the same for all of them: pick them once (no min/max per lane), and keep
        // the lanes' origins scaled by 1/d in structure-of-arrays form.
        let rays = RayLanes::<K> {
            inv,
            neg,
            ox: std::array::from_fn(|l| packet.origins[l].x * inv.x),
            oy: std::array::from_fn(|l| packet.origins[l].y * inv.y),
            oz: std::array::from_fn(|l| packet.origins[l].z * inv.z),
            t_min: packet.t_min,
        };

        let mut stack: [(u32, u32, [f32; K]); STACK] = [(0, 0, [0.0; K]); STACK];
        let mut top = 0usize;
        let mut tn_root = [0.0; K];
        stats.box_tests += packet.mask.count_ones() as u64;
        let root_mask = rays.enter(&self.nodes[0], packet.mask, &best, &mut tn_root);
        if root_mask == 0 {
            return out;
        }
        stack[0] = (0, root_mask, tn_root);
        top += 1;

        while top > 0 {
            top -= 1;
            let (index, mut mask, tnear) = stack[top];
            // A lane whose nearest hit is now closer than this box skips it.
            for (l, tn) in tnear.iter().enumerate() {
                if mask & (1 << l) != 0 && *tn > best[l] * CULL_SLACK {
                    mask &= !(1 << l);
                }
            }
            if mask == 0 {
                continue;
            }
            if mask.count_ones() == 1 {
                // One lane left in this subtree: finish it as a plain ray.
                let l = mask.trailing_zeros() as usize;
                let ray = SingleRay {
                    inv,
                    neg,
                    origin: [rays.ox[l], rays.oy[l], rays.oz[l]],
                    t_min: packet.t_min,
                };
                let mut state = LaneHit {
                    best: best[l],
                    prim: out.prim[l],
                    hit: out.hit[l],
                };
                self.descend_single(Some((index, tnear[l])), &ray, &mut state, stats, |p, t| {
                    test(p, l, t)
                });
                (best[l], out.prim[l], out.hit[l]) = (state.best, state.prim, state.hit);
                continue;
            }
            stats.nodes += 1;
            let node = &self.nodes[index as usize];
            if node.is_leaf() {
                let first = node.first as usize;
                for &prim in &self.order[first..first + node.count() as usize] {
                    let mut lanes = mask;
                    while lanes != 0 {
                        let l = lanes.trailing_zeros() as usize;
                        lanes &= lanes - 1;
                        stats.prim_tests += 1;
                        // next_up lets an equal distance through, for the index tie-break.
                        if let Some(h) = test(prim, l, best[l].next_up()) {
                            if h.t < best[l] || (h.t == best[l] && prim < out.prim[l]) {
                                best[l] = h.t;
                                out.prim[l] = prim;
                                out.hit[l] = h;
                            }
                        }
                    }
                }
                continue;
            }
            let (a, b) = (node.first as usize, node.first as usize + 1);
            let (near, far) = if neg[node.axis()] { (b, a) } else { (a, b) };
            stats.box_tests += 2 * mask.count_ones() as u64;
            let mut tn_near = [0.0; K];
            let mut tn_far = [0.0; K];
            let m_near = rays.enter(&self.nodes[near], mask, &best, &mut tn_near);
            let m_far = rays.enter(&self.nodes[far], mask, &best, &mut tn_far);
            if m_far != 0 && top < STACK {
                stack[top] = (far as u32, m_far, tn_far);
                top += 1;
            }
            if m_near != 0 && top < STACK {
                stack[top] = (near as u32, m_near, tn_near);
                top += 1;
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
    pub fn occlusion<const K: usize>(
        &self,
        packet: &SegmentPacket<K>,
        stats: &mut TraversalStats,
        mut test: impl FnMut(u32, usize) -> AnyHit,
    ) {
        if self.nodes.is_empty() || packet.mask == 0 {
            return;
        }
        if K == 1 {
            self.occlusion_single(
                packet.origins[0],
                packet.dirs[0],
                packet.t_max[0],
                stats,
                |p| test(p, 0),
            );
            return;
        }
        let inv: [Vec3; K] = std::array::from_fn(|l| safe_inverse(packet.dirs[l]));
        let lead = packet.mask.trailing_zeros() as usize;
        let neg = [inv[lead].x < 0.0, inv[lead].y < 0.0, inv[lead].z < 0.0];
        // Shadow rays toward one light from nearby points nearly always agree in
        // the signs of their directions: then the entry and exit planes of a box
        // are the same for every lane and need no min/max.
        let same_signs = (0..K).filter(|&l| packet.mask & (1 << l) != 0).all(|l| {
            (inv[l].x < 0.0) == neg[0] && (inv[l].y < 0.0) == neg[1] && (inv[l].z < 0.0) == neg[2]
        });
        let segments = SegmentLanes::<K> {
            ix: std::array::from_fn(|l| inv[l].x),
            iy: std::array::from_fn(|l| inv[l].y),
            iz: std::array::from_fn(|l| inv[l].z),
            ox: std::array::from_fn(|l| packet.origins[l].x * inv[l].x),
            oy: std::array::from_fn(|l| packet.origins[l].y * inv[l].y),
            oz: std::array::from_fn(|l| packet.origins[l].z * inv[l].z),
            t_max: packet.t_max,
            neg,
            same_signs,
        };
        let mut live = packet.mask;
        stats.box_tests += live.count_ones() as u64;
        let root_mask = segments.enters(&self.nodes[0], live);
        if root_mask == 0 {
            return;
        }
        let mut stack = [(0u32, 0u32); STACK];
        stack[0] = (0, root_mask);
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let (index, m) = stack[top];
            let mask = m & live;
            if mask == 0 {
                continue;
            }
            if mask.count_ones() == 1 {
                // One live lane left in this subtree: finish it as a plain segment.
                let l = mask.trailing_zeros() as usize;
                let (ix, iy, iz) = (segments.ix[l], segments.iy[l], segments.iz[l]);
                let segment = SingleSegment {
                    inv: [ix, iy, iz],
                    neg: [ix < 0.0, iy < 0.0, iz < 0.0],
                    origin: [segments.ox[l], segments.oy[l], segments.oz[l]],
                    t_max: segments.t_max[l],
                };
                if self.descend_occlusion(Some(index), &segment, stats, |p| test(p, l)) {
                    live &= !(1 << l);
                }
                continue;
            }
            stats.nodes += 1;
            let node = &self.nodes[index as usize];
            if node.is_leaf() {
                let first = node.first as usize;
                for &prim in &self.order[first..first + node.count() as usize] {
                    let mut lanes = mask & live;
                    while lanes != 0 {
                        let l = lanes.trailing_zeros() as usize;
                        lanes &= lanes - 1;
                        stats.prim_tests += 1;
                        if test(prim, l) == AnyHit::Stop {
                            live &= !(1 << l);
                        }
                    }
                }
                if live == 0 {
                    return;
                }
                continue;
            }
            let (a, b) = (node.first as usize, node.first as usize + 1);
            let (near, far) = if neg[node.axis()] { (b, a) } else { (a, b) };
            stats.box_tests += 2 * mask.count_ones() as u64;
            let m_far = segments.enters(&self.nodes[far], mask);
            let m_near = segments.enters(&self.nodes[near], mask);
            if m_far != 0 && top < STACK {
                stack[top] = (far as u32, m_far);
                top += 1;
            }
            if m_near != 0 && top < STACK {
                stack[top] = (near as u32, m_near);
                top += 1;
            }
        }
    }

    /// `closest` for a packet of one lane, without lane bookkeeping. Its boxes
    /// are tested with the very operations `RayLanes::enter` uses for a lane, in
    /// the same order, so a lane alone and a lane in a packet see the same tests.
    #[inline(always)]
    fn closest_single(
        &self,
        origin: Vec3,
        dir: Vec3,
        t_min: f32,
        t_max: f32,
        stats: &mut TraversalStats,
        test: impl FnMut(u32, f32) -> Option<SurfaceHit>,
    ) -> (u32, SurfaceHit) {
        let inv = safe_inverse(dir);
        let ray = SingleRay {
            inv,
            neg: [inv.x < 0.0, inv.y < 0.0, inv.z < 0.0],
            origin: [origin.x * inv.x, origin.y * inv.y, origin.z * inv.z],
            t_min,
        };
        let mut state = LaneHit {
            best: t_max,
            prim: PacketHits::<1>::NO_HIT,
            hit: SurfaceHit {
                t: f32::INFINITY,
                u: 0.0,
                v: 0.0,
            },
        };
        // The root is entered like any child: the descent re-tests nothing.
        self.descend_single(None, &ray, &mut state, stats, test);
        (state.prim, state.hit)
    }

    /// One ray's depth-first descent of the subtree at `start` (entered at
    /// `tn_start`), improving `state`. A packet hands a lane over to this when it
    /// is the only lane left in a subtree: depth-first order visits that whole
    /// subtree next either way, so the lane's sequence of tests is unchanged.
    /// (Written like `closest_single`, with the ray's numbers in locals.)
    #[inline(always)]
    fn descend_single(
        &self,
        start: Option<(u32, f32)>,
        ray: &SingleRay,
        state: &mut LaneHit,
        stats: &mut TraversalStats,
        mut test: impl FnMut(u32, f32) -> Option<SurfaceHit>,
    ) {
        let (inv, neg, t_min) = (ray.inv, ray.neg, ray.t_min);
        let [ox, oy, oz] = ray.origin;
        let (mut best, mut prim_hit, mut hit) = (state.best, state.prim, state.hit);
        let entry = |node: &Node, best: f32| -> Option<f32> {
            let ([nx, ny, nz], [fx, fy, fz]) = slab_planes(node, &neg);
            let (nx, fx) = (nx * inv.x, fx * inv.x);
            let (ny, fy) = (ny * inv.y, fy * inv.y);
            let (nz, fz) = (nz * inv.z, fz * inv.z);
            let tn = fmax(fmax(nx - ox, ny - oy), fmax(nz - oz, t_min));
            let tf = fmin(fmin(fx - ox, fy - oy), fz - oz) * ROBUST;
            (tn <= tf && tn <= best * CULL_SLACK).then_some(tn)
        };
        let (mut nodes, mut boxes, mut prims) = (0u64, 0u64, 0u64);
        // From a packet's hand-over: a node already entered; alone: the root.
        let start = match start {
            Some(s) => s,
            None => {
                stats.box_tests += 1;
                match entry(&self.nodes[0], best) {
                    Some(tn) => (0, tn),
                    None => return,
                }
            }
        };
        let mut stack = [(0u32, 0f32); STACK];
        stack[0] = start;
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let (index, tnear) = stack[top];
            if tnear > best * CULL_SLACK {
                continue;
            }
            nodes += 1;
            let node = &self.nodes[index as usize];
            if node.is_leaf() {
                let first = node.first as usize;
                for &prim in &self.order[first..first + node.count() as usize] {
                    prims += 1;
                    if let Some(h) = test(prim, best.next_up()) {
                        if h.t < best || (h.t == best && prim < prim_hit) {
                            best = h.t;
                            prim_hit = prim;
                            hit = h;
                        }
                    }
                }
                continue;
            }
            let (a, b) = (node.first as usize, node.first as usize + 1);
            let (near, far) = if neg[node.axis()] { (b, a) } else { (a, b) };
            boxes += 2;
            let t_near = entry(&self.nodes[near], best);
            if let Some(tn) = entry(&self.nodes[far], best) {
                if top < STACK {
                    stack[top] = (far as u32, tn);
                    top += 1;
                }
            }
            if let Some(tn) = t_near {
                if top < STACK {
                    stack[top] = (near as u32, tn);
                    top += 1;
                }
            }
        }
        (state.best, state.prim, state.hit) = (best, prim_hit, hit);
        stats.nodes += nodes;
        stats.box_tests += boxes;
        stats.prim_tests += prims;
    }

    /// `occlusion` for one segment, without lane bookkeeping.
    #[inline(always)]
    fn occlusion_single(
        &self,
        origin: Vec3,
        dir: Vec3,
        t_max: f32,
        stats: &mut TraversalStats,
        test: impl FnMut(u32) -> AnyHit,
    ) {
        let inv = safe_inverse(dir);
        let segment = SingleSegment {
            inv: [inv.x, inv.y, inv.z],
            neg: [inv.x < 0.0, inv.y < 0.0, inv.z < 0.0],
            origin: [origin.x * inv.x, origin.y * inv.y, origin.z * inv.z],
            t_max,
        };
        self.descend_occlusion(None, &segment, stats, test);
    }

    /// One segment's any-hit descent of the subtree at `start`; returns whether
    /// `test` said stop. A shadow packet hands a lane over to this when it is the
    /// only live lane in a subtree.
    #[inline(always)]
    fn descend_occlusion(
        &self,
        start: Option<u32>,
        segment: &SingleSegment,
        stats: &mut TraversalStats,
        mut test: impl FnMut(u32) -> AnyHit,
    ) -> bool {
        let ([ix, iy, iz], [ox, oy, oz]) = (segment.inv, segment.origin);
        let (neg, t_max) = (segment.neg, segment.t_max);
        let enters = |node: &Node| -> bool {
            let ([nx, ny, nz], [fx, fy, fz]) = slab_planes(node, &neg);
            let tn = fmax(fmax(nx * ix - ox, ny * iy - oy), fmax(nz * iz - oz, 0.0));
            let tf = fmin(fmin(fx * ix - ox, fy * iy - oy), fz * iz - oz) * ROBUST;
            tn <= fmin(tf, t_max)
        };
        let (mut nodes, mut boxes, mut prims) = (0u64, 0u64, 0u64);
        let mut stopped = false;
        // From a packet's hand-over: a node already entered; alone: the root.
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
        let mut stack = [0u32; STACK];
        stack[0] = start;
        let mut top = 1usize;
        'descent: while top > 0 {
            top -= 1;
            nodes += 1;
            let node = &self.nodes[stack[top] as usize];
            if node.is_leaf() {
                let first = node.first as usize;
                for &prim in &self.order[first..first + node.count() as usize] {
                    prims += 1;
                    if test(prim) == AnyHit::Stop {
                        stopped = true;
                        break 'descent;
                    }
                }
                continue;
            }
            let (a, b) = (node.first as usize, node.first as usize + 1);
            let (near, far) = if neg[node.axis()] { (b, a) } else { (a, b) };
            boxes += 2;
            let near_in = enters(&self.nodes[near]);
            if enters(&self.nodes[far]) && top < STACK {
                stack[top] = far as u32;
                top += 1;
            }
            if near_in && top < STACK {
                stack[top] = near as u32;
                top += 1;
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
    use super::super::{build, BuildOptions};
    use super::*;
    use crate::math::{Aabb, Ray};
    use crate::shapes::Sphere;

    fn spheres(n: usize) -> Vec<Sphere> {
        let mut s = 7u64;
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 40) as f32) / (1u64 << 24) as f32
        };
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
        let mut seed = 3u64;
        for _ in 0..2000 {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1);
            let a = (seed >> 33) as f32 / (1u64 << 31) as f32;
            let b = (seed >> 13 & 0xfffff) as f32 / (1u64 << 20) as f32;
            let dir = Vec3::new(a - 0.5, b - 0.5, 1.0).normalize();
            let origins = [
                Vec3::new(-0.3, 0.0, 0.0),
                Vec3::new(0.3, 0.0, 0.0),
                Vec3::new(1.7, 0.1, 0.0),
            ];
            let packet = Packet {
                origins,
                dir,
                t_min: 0.0,
                t_max: [f32::INFINITY; 3],
                mask: 0b111,
            };
            let hits = bvh.closest(&packet, &mut stats, |p, l, tmax| {
                sph[p as usize].intersect(&Ray::new(origins[l], dir), 0.0, tmax)
            });
            for (l, &o) in origins.iter().enumerate() {
                let expect = brute(&sph, &Ray::new(o, dir));
                let got = hits.has_hit(l).then(|| (hits.prim[l], hits.hit[l].t));
                assert_eq!(got, expect, "lane {l}");
                // Alone, as a packet of one, the lane gets the same answer.
                let single = Packet {
                    origins: [o],
                    dir,
                    t_min: 0.0,
                    t_max: [f32::INFINITY],
                    mask: 1,
                };
                let h1 = bvh.closest(&single, &mut stats, |p, _, tmax| {
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
            dir: Vec3::Z,
            t_min: 0.0,
            t_max: [f32::INFINITY; 2],
            mask: 0b01,
        };
        let mut stats = TraversalStats::default();
        let hits = bvh.closest(&packet, &mut stats, |p, l, tmax| {
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
                bvh.occlusion(&packet, &mut stats, |p, l| {
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
}

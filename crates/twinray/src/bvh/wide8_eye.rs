//! Eight neighbouring eye rays in one descent of the eight-wide tree
//! (`wide8.rs`): the mono row's rays of eight consecutive samples leave
//! one eye a fraction of a pixel apart, so they enter nearly the same
//! nodes. The rays sit in the lanes of one `f32x8`; a node is fetched once
//! for the packet and each of its children is tested against every ray at
//! once (one slab test per child, the child's planes broadcast), which
//! gives the child's ray mask directly. A child is stacked with the rays
//! that entered it and their entry distances, the children visited nearest
//! first (by the entry of the first ray that entered each); a ray is
//! dropped at a pop when its own nearest hit is nearer than its own entry
//! (`CULL_SLACK`), and a subtree only one ray entered is finished by that
//! ray's single descent (`wide8_single`). Leaves of triangle blocks are
//! tested ray by ray (`leaf_lane`, the single descent's leaf test); leaves
//! of spheres and cones primitive by primitive, each for all the rays that
//! entered the leaf in one eight-lane test (`leaf_lanes_at_once`, `test_lanes`),
//! each lane bit for bit its own test. The same descent serves
//! the secondary rays of a shading packet of eight (`Bvh::closest`, through
//! `closest_packet8_or_each`), whose lanes start from eight points.
//!
//! Exactness: per lane, the slab test is the single ray's (`Ray8`): the
//! same planes (all rays of a packet share their direction signs, or the
//! packet is refused), the same operations in the same order
//! (`plane * inv - org`, then `maxps`/`minps` as there), so each ray's
//! entry and exit distances for a child are bit for bit the ones its
//! single descent computes. A ray is carried into a child only where its
//! own test entered it, and culled only as conservatively as alone, so its
//! nearest hit (ties to the lower index) is the one it gets alone, whatever
//! the order the packet visits nodes in (see `traverse.rs`).

use super::leaf::{leaf_lane, leaf_lanes_at_once};
use super::traverse::{LaneHit, SingleRay, CULL_SLACK, ROBUST, STACK};
use super::wide::{take_nearest, Entry};
use super::wide8::{Node8, WIDTH8};
use super::{Bvh, NearestTest, Packet, PacketHits, TraversalStats};
use arrayvec::ArrayVec;
use wide::f32x8;

/// Rays in a packet of eye rays.
pub const EYE_PACKET: usize = 8;

/// The packet's rays prepared for the slab test, one ray per lane: each
/// lane `SingleRay::new`'s numbers, the planes picked by the signs all
/// lanes share.
pub(super) struct Rays8 {
    near: [usize; 3],
    far: [usize; 3],
    inv: [f32x8; 3],
    org: [f32x8; 3],
    t_min: f32x8,
}

impl Rays8 {
    /// `None` where the active lanes' direction signs differ.
    #[inline(always)]
    pub(super) fn new(singles: &[SingleRay; EYE_PACKET], mask: u32) -> Option<Rays8> {
        let lead = mask.trailing_zeros() as usize;
        let neg = singles[lead].neg;
        let mut lanes = mask;
        while lanes != 0 {
            let l = lanes.trailing_zeros() as usize;
            lanes &= lanes - 1;
            if singles[l].neg != neg {
                return None;
            }
        }
        let side = |a: usize| neg[a] as usize;
        let lane = |f: &dyn Fn(&SingleRay) -> f32| {
            f32x8::from(std::array::from_fn::<f32, EYE_PACKET, _>(
                |l| f(&singles[l]),
            ))
        };
        Some(Rays8 {
            near: [0, 1, 2].map(|a| 2 * a + side(a)),
            far: [0, 1, 2].map(|a| 2 * a + 1 - side(a)),
            inv: [0, 1, 2].map(|a| lane(&|s| s.inv[a])),
            org: [0, 1, 2].map(|a| lane(&|s| s.origin[a])),
            t_min: lane(&|s| s.t_min),
        })
    }

    /// The rays that enter child `c` of `node` before `bound` (their
    /// nearest hits so far times `CULL_SLACK`), as a lane mask, and their
    /// entry distances: per lane `Ray8::enter`'s arithmetic for that child.
    #[inline(always)]
    pub(super) fn enter(&self, node: &Node8, c: usize, bound: f32x8) -> (u32, f32x8) {
        let plane =
            |i: usize, a: usize| f32x8::splat(node.bounds[i][c]) * self.inv[a] - self.org[a];
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
        let tn = nx.fast_max(ny).fast_max(nz.fast_max(self.t_min));
        let tf = fx.fast_min(fy).fast_min(fz) * f32x8::splat(ROBUST);
        ((tn.simd_le(tf) & tn.simd_le(bound)).to_bitmask(), tn)
    }
}

/// A packet's stack entry: a child (`count` > 0: a leaf), the rays that
/// entered it and their entry distances.
#[derive(Clone, Copy)]
struct EyeEntry {
    tn: f32x8,
    child: u32,
    count: u32,
    lanes: u32,
}

impl Bvh {
    /// Nearest hit per lane (see `closest_binary` for the contract) of up
    /// to eight eye rays (lanes of `packet.mask`) in one descent of the
    /// eight-wide tree: each lane's hit bit for bit its single descent's
    /// (`closest_one_wide8`). `None` where the packet does not apply (no
    /// eight-wide tree, no active lane, or the active lanes' direction
    /// signs differ): the caller traces its rays alone.
    #[inline]
    pub fn closest_eye_packet8(
        &self,
        packet: &Packet<EYE_PACKET>,
        stats: &mut TraversalStats,
        mut test: impl NearestTest,
    ) -> Option<PacketHits<EYE_PACKET>> {
        self.closest_packet8(packet, stats, &mut test)
    }

    /// Nearest hit per lane of up to eight rays from anywhere (a shading
    /// packet's secondary rays): in one descent where their direction signs
    /// agree (`closest_eye_packet8`), else each alone. Each lane's hit is
    /// bit for bit its single descent's. The eight-wide tree must exist.
    ///
    /// Splitting a packet by its lanes' signs, each part in a descent of its
    /// own, measured no faster (docs/benchmarks.md, "Issues 16 and 17, tenth
    /// pass").
    #[inline]
    pub fn closest_packet8_or_each(
        &self,
        packet: &Packet<EYE_PACKET>,
        stats: &mut TraversalStats,
        mut test: impl NearestTest,
    ) -> PacketHits<EYE_PACKET> {
        match self.closest_packet8(packet, stats, &mut test) {
            Some(hits) => hits,
            None => self.closest_each_wide8(packet, stats, test),
        }
    }

    /// `closest_eye_packet8`'s descent, the test borrowed (`None`, the test
    /// untouched, where the packet does not apply). Inlined into both
    /// callers: the eye rays' loop measured 5–10 % slower with the descent
    /// behind a call that took the prepared rays by reference.
    #[inline(always)]
    fn closest_packet8<T: NearestTest>(
        &self,
        packet: &Packet<EYE_PACKET>,
        stats: &mut TraversalStats,
        test: &mut T,
    ) -> Option<PacketHits<EYE_PACKET>> {
        let mask = packet.mask & 0xff;
        if self.wide8.is_empty() || mask == 0 {
            return None;
        }
        let singles: [SingleRay; EYE_PACKET] = std::array::from_fn(|l| {
            SingleRay::new(packet.origins[l], packet.dirs[l], packet.t_min)
        });
        let rays = Rays8::new(&singles, mask)?;
        let mut out = PacketHits::<EYE_PACKET>::none();
        let mut best = packet.t_max;
        let slack = f32x8::splat(CULL_SLACK);
        let mut bound = f32x8::from(best) * slack;
        let (mut nodes, mut boxes, mut prims, mut in_lanes) = (0u64, 0u64, 0u64, 0u64);
        let mut stack = ArrayVec::<EyeEntry, STACK>::new();
        let mut current = Some(EyeEntry {
            tn: rays.t_min,
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
                let mut state = LaneHit {
                    best: best[l],
                    prim: out.prim[l],
                    hit: out.hit[l],
                };
                self.wide8_single(start, &singles[l], &mut state, stats, test, l);
                (best[l], out.prim[l], out.hit[l]) = (state.best, state.prim, state.hit);
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
                    let mut state = LaneHit {
                        best: best[l],
                        prim: out.prim[l],
                        hit: out.hit[l],
                    };
                    leaf_lane(leaf, l, &mut state, test);
                    (best[l], out.prim[l], out.hit[l]) = (state.best, state.prim, state.hit);
                }
                bound = f32x8::from(best) * slack;
            } else if lanes != 0 {
                nodes += 1;
                let node = &self.wide8[e.child as usize];
                boxes += (WIDTH8 as u64) * lanes.count_ones() as u64;
                let mut masks = [0u32; WIDTH8];
                let mut tns = [f32x8::ZERO; WIDTH8];
                let mut key = [0.0f32; WIDTH8];
                let mut entered = 0u32;
                for c in 0..WIDTH8 {
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
                    current = Some(take_nearest(&mut stack, entered, &key, |c| EyeEntry {
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
}

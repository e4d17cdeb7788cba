//! A stereo pair's two rays in one descent of the eight-wide tree
//! (`wide8.rs`): both eyes' rays through one sample, or the two lanes of a
//! twin group's shadow segments toward one light, are nearly coherent, so a
//! node both enter is fetched once. Per node, one `f32x8` slab test per lane
//! (the single ray's, `Pair8`), a child stacked with the lanes whose own
//! test entered it and their entry distances, the children visited nearest
//! first by the nearer of the two entries. A lane is dropped at a pop when
//! its own nearest hit is nearer than its own entry (`CULL_SLACK`); a
//! subtree only one lane entered is finished by that lane's single descent
//! (`wide8_single`), so a pair pays lane bookkeeping only where it shares a
//! node. Leaves both lanes reach are tested for both in one register
//! (`test_leaf`, `occlusion_leaf`). Shadow pairs (any hit) the same way,
//! without the order, a lane leaving the descent at its first stop.
//!
//! The renderer takes the any-hit descent for a pair's shadow segments
//! (`Bvh::occlusion`). The nearest-hit descent is not its path: a pair's eye
//! and secondary rays measured no faster in it than alone
//! (docs/benchmarks.md, "Issue 17, sixth pass"); it is kept, tested, for
//! `wide_vs_binary --packets8`. It replaced a K-lane descent of this tree,
//! slower than lanes alone at every K (docs/decisions.md).
//!
//! Exactness: per lane, the slab test is the single ray's, leaves are tested
//! by `leaf.rs`, and culling is as conservative as a lane alone: so each
//! lane's nearest hit (ties to the lower index) is the one it gets alone,
//! whatever the order the pair visits nodes in; and a segment that
//! `segment_enters` a primitive's box reaches the primitive's leaf.

use super::leaf::{occlusion_leaf, test_leaf};
use super::traverse::{fmin, LaneHit, SingleRay, CULL_SLACK, ROBUST, STACK};
use super::wide::{take_nearest, wide_ray, Entry, WideNode};
use super::wide8::WIDTH8;
use super::{AnyHitTest, Bvh, NearestTest, Packet, PacketHits, SegmentPacket, TraversalStats};
use arrayvec::ArrayVec;
use wide::f32x8;

// One lane of a pair prepared for the eight-wide slab test.
wide_ray!(Pair8, f32x8, WIDTH8);

/// A pair's stack entry: a child (`count` > 0: a leaf), the lanes that
/// entered it (bit 0: lane 0, bit 1: lane 1) and their entry distances.
#[derive(Clone, Copy)]
struct PairEntry {
    child: u32,
    count: u32,
    lanes: u32,
    tn: [f32; 2],
}

impl Bvh {
    /// Nearest hit per lane (see `closest_binary` for the contract) of a
    /// stereo pair (`K == 2`, both lanes active) on the eight-wide tree
    /// (which must exist), in one descent.
    #[inline]
    pub fn closest_pair_wide8<const K: usize>(
        &self,
        packet: &Packet<K>,
        stats: &mut TraversalStats,
        mut test: impl NearestTest,
    ) -> PacketHits<K> {
        debug_assert!(K == 2 && packet.mask == 0b11);
        let mut out = PacketHits::<K>::none();
        if self.wide8.is_empty() {
            return out;
        }
        let (a, b) = (0, 1 % K);
        let singles =
            [a, b].map(|l| SingleRay::new(packet.origins[l], packet.dirs[l], packet.t_min));
        let rays = [Pair8::new(&singles[0]), Pair8::new(&singles[1])];
        let mut best = packet.t_max;
        let (mut nodes, mut boxes) = (0u64, 0u64);
        let mut stack = ArrayVec::<PairEntry, STACK>::new();
        let mut current = Some(PairEntry {
            child: 0,
            count: 0,
            lanes: 0b11,
            tn: [packet.t_min; 2],
        });
        while let Some(mut e) = current.take() {
            // A lane whose nearest hit is now nearer than its entry skips it.
            if e.lanes & 1 != 0 && e.tn[0] > best[a] * CULL_SLACK {
                e.lanes &= !1;
            }
            if e.lanes & 2 != 0 && e.tn[1] > best[b] * CULL_SLACK {
                e.lanes &= !2;
            }
            if e.lanes == 0b11 {
                nodes += 1;
                if e.count > 0 {
                    // Lane bits are packet lanes 0 and 1 for K == 2.
                    test_leaf(
                        self.leaf(e.child, e.count),
                        0b11,
                        &mut best,
                        &mut out,
                        stats,
                        &mut test,
                    );
                } else {
                    let node = &self.wide8[e.child as usize];
                    boxes += 2 * WIDTH8 as u64;
                    let (m0, t0) = rays[0].enter(node, best[a]);
                    let (m1, t1) = rays[1].enter(node, best[b]);
                    let any = m0 | m1;
                    if any != 0 {
                        // Nearest first, by the nearer entry of the lanes that enter.
                        let mut key = t0;
                        let mut bits = m1;
                        while bits != 0 {
                            let c = bits.trailing_zeros() as usize;
                            bits &= bits - 1;
                            key[c] = if m0 & (1 << c) != 0 {
                                fmin(t0[c], t1[c])
                            } else {
                                t1[c]
                            };
                        }
                        current = Some(take_nearest(&mut stack, any, &key, |c| PairEntry {
                            child: node.child[c],
                            count: node.count[c],
                            lanes: (m0 >> c) & 1 | ((m1 >> c) & 1) << 1,
                            tn: [t0[c], t1[c]],
                        }));
                        continue;
                    }
                }
            } else if e.lanes != 0 {
                // One lane left in this subtree: finish it as a plain ray.
                let i = e.lanes.trailing_zeros() as usize;
                let l = [a, b][i];
                let start = Entry {
                    child: e.child,
                    count: e.count,
                    tn: e.tn[i],
                };
                let mut state = LaneHit {
                    best: best[l],
                    prim: out.prim[l],
                    hit: out.hit[l],
                };
                self.wide8_single(start, &singles[i], &mut state, stats, &mut test, l);
                (best[l], out.prim[l], out.hit[l]) = (state.best, state.prim, state.hit);
            }
            current = stack.pop();
        }
        stats.nodes += nodes;
        stats.box_tests += boxes;
        out
    }

    /// Any-hit per lane (see `occlusion_binary` for the contract) of a
    /// stereo pair's two segments (`K == 2`, both lanes active) on the
    /// eight-wide tree (which must exist), in one descent: a child is
    /// stacked with the live lanes whose segments enter it.
    pub fn occlusion_pair_wide8<const K: usize>(
        &self,
        packet: &SegmentPacket<K>,
        stats: &mut TraversalStats,
        test: &mut impl AnyHitTest,
    ) {
        debug_assert!(K == 2 && packet.mask == 0b11);
        if self.wide8.is_empty() {
            return;
        }
        let (a, b) = (0, 1 % K);
        let singles = [a, b].map(|l| SingleRay::new(packet.origins[l], packet.dirs[l], 0.0));
        let rays = [Pair8::new(&singles[0]), Pair8::new(&singles[1])];
        let t_max = [packet.t_max[a], packet.t_max[b]];
        let mut live = 0b11u32;
        let (mut nodes, mut boxes) = (0u64, 0u64);
        let mut stack = ArrayVec::<(u32, u32, u32), STACK>::new();
        stack.push((0, 0, live));
        while let Some((child, count, m)) = stack.pop() {
            let lanes = m & live;
            if lanes == 0 {
                continue;
            }
            if lanes != 0b11 {
                // One live lane in this subtree: finish it as a plain segment.
                let i = lanes.trailing_zeros() as usize;
                let l = [a, b][i];
                if self.wide8_occlusion_single(
                    (child, count),
                    &singles[i],
                    t_max[i],
                    stats,
                    test,
                    l,
                ) {
                    live &= !lanes;
                    if live == 0 {
                        break;
                    }
                }
                continue;
            }
            nodes += 1;
            if count > 0 {
                occlusion_leaf(self.leaf(child, count), true, 0b11, &mut live, stats, test);
                if live == 0 {
                    break;
                }
                continue;
            }
            let node = &self.wide8[child as usize];
            boxes += 2 * WIDTH8 as u64;
            let m0 = rays[0].enters(node, t_max[0]);
            let m1 = rays[1].enters(node, t_max[1]);
            let mut any = m0 | m1;
            // Pushed last slot first, so that they pop in slot order.
            while any != 0 {
                let c = 31 - any.leading_zeros() as usize;
                any &= !(1 << c);
                let lanes = (m0 >> c) & 1 | ((m1 >> c) & 1) << 1;
                let _ = stack.try_push((node.child[c], node.count[c], lanes));
            }
        }
        stats.nodes += nodes;
        stats.box_tests += boxes;
    }
}

#[cfg(test)]
mod tests {
    use super::super::brute_force::{random_packet, random_shapes, segments_of};
    use super::super::{build, primitive_box, AnyHit, BuildOptions};
    use super::*;
    use crate::math::{Aabb, Ray, Vec3};
    use crate::shapes::{BlockHits, Shape, SurfaceHit, Triangle, Triangle4, TriangleNormals};

    /// A packet's rays against shapes, leaves of triangles as blocks.
    struct Shapes<'a, const K: usize> {
        shapes: &'a [Shape],
        packet: &'a Packet<K>,
    }

    impl<const K: usize> Shapes<'_, K> {
        fn ray(&self, lane: usize) -> Ray {
            Ray::new(self.packet.origins[lane], self.packet.dirs[lane])
        }
    }

    impl<const K: usize> NearestTest for Shapes<'_, K> {
        fn test(&mut self, prim: u32, lane: usize, t_max: f32) -> Option<SurfaceHit> {
            self.shapes[prim as usize].intersect(&self.ray(lane), self.packet.t_min, t_max)
        }

        fn test_block(&mut self, block: &Triangle4, lane: usize, t_max: f32) -> Option<BlockHits> {
            Some(block.intersect(&self.ray(lane), self.packet.t_min, t_max))
        }
    }

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

    fn hit_bits(h: &SurfaceHit) -> [u32; 3] {
        [h.t.to_bits(), h.u.to_bits(), h.v.to_bits()]
    }

    /// `K` rays grazing the corners of random primitives' boxes, from near
    /// and far, each lane its own `t_max` (some just past the corner), some
    /// lanes masked off.
    fn grazing_packet<const K: usize>(rng: &mut fastrand::Rng, boxes: &[Aabb]) -> Packet<K> {
        let centre = Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() + 0.2)
            * [40.0, 200.0, 1e4][rng.usize(..3)];
        let origins: [Vec3; K] = std::array::from_fn(|l| centre + Vec3::X * (0.05 * l as f32));
        let mut reach = [f32::INFINITY; K];
        let dirs = std::array::from_fn(|l| {
            let b = primitive_box(&boxes[rng.usize(..boxes.len())]);
            let pick = |lo: f32, hi: f32, rng: &mut fastrand::Rng| if rng.bool() { lo } else { hi };
            let corner = Vec3::new(
                pick(b.min.x, b.max.x, rng),
                pick(b.min.y, b.max.y, rng),
                pick(b.min.z, b.max.z, rng),
            );
            let to = corner + Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 1e-4 - origins[l];
            reach[l] = to.length();
            to.normalize()
        });
        let t_max = std::array::from_fn(|l| match rng.u8(..3) {
            0 => f32::INFINITY,
            1 => reach[l] * 1.0001,
            _ => reach[l] * (0.5 + rng.f32()),
        });
        let all = ((1u64 << K) - 1) as u32;
        Packet {
            origins,
            dirs,
            t_min: 0.0,
            t_max,
            mask: if rng.bool() {
                all
            } else {
                (rng.u32(..) & all).max(1)
            },
        }
    }

    /// Each lane of `packet` (both lanes active) in the pair's descent
    /// equals, bit for bit, the lane alone on the eight-wide tree (nearest
    /// hit), and its segment meets the same primitives (any hit, with and
    /// without a stop).
    fn check(shapes: &[Shape], bvh: &Bvh, packet: &Packet<2>) -> usize {
        let packet = &Packet {
            mask: 0b11,
            ..*packet
        };
        let mut stats = TraversalStats::default();
        let test = || Shapes { shapes, packet };
        let got = bvh.closest_pair_wide8(packet, &mut stats, test());
        let alone = bvh.closest_each_wide8(packet, &mut stats, test());
        let mut hits = 0;
        for l in 0..2 {
            let what = format!("lane {l}: {packet:?}");
            assert_eq!(got.prim[l], alone.prim[l], "{what}");
            assert_eq!(hit_bits(&got.hit[l]), hit_bits(&alone.hit[l]), "{what}");
            hits += got.has_hit(l) as usize;
        }
        let segments = segments_of(packet);
        let occluders = |one_descent: bool, stop: bool| {
            let mut met: [Vec<u32>; 2] = std::array::from_fn(|_| Vec::new());
            let mut test = |p: u32, l: usize| {
                let ray = Ray::new(segments.origins[l], segments.dirs[l]);
                let hit = shapes[p as usize].intersect(&ray, 0.0, segments.t_max[l]);
                if hit.is_some() {
                    met[l].push(p);
                    if stop {
                        return AnyHit::Stop;
                    }
                }
                AnyHit::Continue
            };
            let mut stats = TraversalStats::default();
            if one_descent {
                bvh.occlusion_pair_wide8(&segments, &mut stats, &mut test);
            } else {
                bvh.occlusion_wide8(&segments, &mut stats, &mut test);
            }
            met.map(|mut m| {
                m.sort_unstable();
                m
            })
        };
        for stop in [false, true] {
            let (got, alone) = (occluders(true, stop), occluders(false, stop));
            for l in 0..2 {
                if stop {
                    // Which occluder stops a lane may depend on the order;
                    // whether one does may not.
                    assert_eq!(got[l].len(), alone[l].len(), "lane {l}: blocked");
                } else {
                    assert_eq!(got[l], alone[l], "lane {l}: occluders");
                }
            }
        }
        hits
    }

    fn check_many(shapes: &[Shape], bvh: &Bvh, seed: u64, count: usize) -> usize {
        let mut rng = fastrand::Rng::with_seed(seed);
        let boxes: Vec<Aabb> = shapes.iter().map(Shape::bounds).collect();
        (0..count)
            .map(|_| {
                check(shapes, bvh, &random_packet::<2>(&mut rng))
                    + check(shapes, bvh, &grazing_packet::<2>(&mut rng, &boxes))
            })
            .sum()
    }

    /// A pair in one descent gives each lane what it gets alone, on random
    /// shapes of every kind (scalar leaves) and on a mesh with poles (leaves
    /// as triangle blocks), for random and grazing rays, each lane with its
    /// own `t_max`.
    #[test]
    fn a_pair_descent_equals_its_lanes_alone_bit_for_bit() {
        let mut rng = fastrand::Rng::with_seed(41);
        let shapes = random_shapes(&mut rng, 400);
        let bvh = tree(&shapes, &BuildOptions::default());
        let hits = check_many(&shapes, &bvh, 5, 1500);
        assert!(hits > 2000, "{hits} lanes hit");
        let mesh = terrain(24);
        let bvh = tree(&mesh, &BuildOptions::triangle_blocks());
        assert!(!bvh.blocks.is_empty());
        let hits = check_many(&mesh, &bvh, 6, 1500);
        assert!(hits > 2000, "{hits} lanes hit");
    }

    /// The work of a pair of eye rays through each pixel of a camera over
    /// the mesh, eyes `b` apart: in one descent, and each lane alone.
    fn pair_work(bvh: &Bvh, shapes: &[Shape], b: f32) -> [TraversalStats; 2] {
        let mut work = [TraversalStats::default(); 2];
        for j in 0..24 {
            for i in 0..24 {
                let target = Vec3::new(i as f32 + 0.3, j as f32 + 0.6, 0.0);
                let origins: [Vec3; 2] =
                    std::array::from_fn(|l| Vec3::new(12.0 + b * l as f32, -10.0, 9.0));
                let packet = Packet {
                    origins,
                    dirs: origins.map(|o| (target - o).normalize()),
                    t_min: 0.0,
                    t_max: [f32::INFINITY; 2],
                    mask: 0b11,
                };
                let test = || Shapes {
                    shapes,
                    packet: &packet,
                };
                let one = bvh.closest_pair_wide8(&packet, &mut work[0], test());
                let each = bvh.closest_each_wide8(&packet, &mut work[1], test());
                assert_eq!(one, each);
            }
        }
        work
    }

    /// On coherent rays (two eyes through one pixel) the pair's descent
    /// visits fewer nodes than its lanes alone; two copies of one ray visit
    /// exactly the nodes the ray alone visits (the order is the single
    /// ray's: nearest first), with two box and primitive tests for each of
    /// its. A descent that visits children in another order than nearest
    /// first fails here, though its hits are right.
    #[test]
    fn a_pair_descent_visits_fewer_nodes_than_its_lanes_alone() {
        let shapes = terrain(24);
        let bvh = tree(&shapes, &BuildOptions::triangle_blocks());
        let [one, each] = pair_work(&bvh, &shapes, 0.02);
        assert!(
            (one.nodes as f64) < 0.7 * each.nodes as f64,
            "{} nodes in one descent, {} alone",
            one.nodes,
            each.nodes
        );
        let [same, each] = pair_work(&bvh, &shapes, 0.0);
        assert_eq!(same.nodes * 2, each.nodes, "copies of one ray");
        assert_eq!(same.box_tests, each.box_tests, "copies of one ray");
        assert_eq!(same.prim_tests, each.prim_tests, "copies of one ray");
    }
}

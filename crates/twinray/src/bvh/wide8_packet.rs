//! Packets of K rays (the N views' batches, a stereo pair) in one descent of
//! the eight-wide tree (`wide8.rs`). Not the renderer's path: each lane
//! alone on the eight-wide tree (`closest_each_wide8`, `occlusion_wide8`)
//! measured faster at K = 2, 4 and 8, for eye rays and shadow segments,
//! though this descent visits a third fewer nodes (docs/benchmarks.md,
//! "Issues 16 and 17, fifth pass"); kept, tested, for that comparison
//! (`wide_vs_binary --packets8`). Per node, one `f32x8` slab test per
//! active lane (each lane against the node's eight children), the children
//! any lane enters taken in the union of the lanes' child masks, and visited
//! nearest first by the smallest entry distance over the lanes that enter
//! them. A lane is carried into a child only by its own box test against its
//! own nearest hit so far, and dropped at a pop when its own nearest hit is
//! nearer than its own entry (`CULL_SLACK`). Shadow packets (any hit) the
//! same way, without the order.
//!
//! Exactness: per lane, the slab test is `Ray8`'s (the single ray's), leaves
//! are tested by `leaf.rs`, and culling is as conservative as a lane alone:
//! so each lane's nearest hit (ties to the lower index) is the one it gets
//! alone, whatever the order the packet visits nodes in; and a segment that
//! `segment_enters` a primitive's box reaches the primitive's leaf.

use super::leaf::{occlusion_leaf, test_leaf};
use super::traverse::{fmin, SingleRay, CULL_SLACK, ROBUST, STACK};
use super::wide::{take_nearest, wide_ray, WideNode};
use super::wide8::WIDTH8;
use super::{AnyHitTest, Bvh, NearestTest, Packet, PacketHits, SegmentPacket, TraversalStats};
use arrayvec::ArrayVec;
use wide::f32x8;

// One lane prepared for the eight-wide slab test.
wide_ray!(Lane8, f32x8, WIDTH8);

/// A packet's stack entry: a child (`count` > 0: a leaf), the lanes that
/// entered it, and their entry distances.
#[derive(Clone, Copy)]
struct Entry8<const K: usize> {
    child: u32,
    count: u32,
    mask: u32,
    tn: [f32; K],
}

/// The active lanes of a packet of `K` (bits above `K` cleared).
#[inline(always)]
fn lanes_of<const K: usize>(mask: u32) -> u32 {
    if K >= 32 {
        mask
    } else {
        mask & ((1u32 << K) - 1)
    }
}

impl Bvh {
    /// Nearest hit per lane (see `closest_binary` for the contract) on the
    /// eight-wide tree (which must exist), the active lanes in one descent.
    #[inline]
    pub fn closest_packet_wide8<const K: usize>(
        &self,
        packet: &Packet<K>,
        stats: &mut TraversalStats,
        mut test: impl NearestTest,
    ) -> PacketHits<K> {
        let mut out = PacketHits::<K>::none();
        if self.wide8.is_empty() {
            return out;
        }
        let rays: [Lane8; K] = std::array::from_fn(|l| {
            Lane8::new(&SingleRay::new(
                packet.origins[l],
                packet.dirs[l],
                packet.t_min,
            ))
        });
        let mut best = packet.t_max;
        let (mut nodes, mut boxes) = (0u64, 0u64);
        let mut stack = ArrayVec::<Entry8<K>, STACK>::new();
        let mut current = Some(Entry8 {
            child: 0,
            count: 0,
            mask: lanes_of::<K>(packet.mask),
            tn: [packet.t_min; K],
        });
        while let Some(Entry8 {
            child,
            count,
            mut mask,
            tn,
        }) = current.take()
        {
            // A lane whose nearest hit is now nearer than its entry skips it.
            let mut lanes = mask;
            while lanes != 0 {
                let l = lanes.trailing_zeros() as usize;
                lanes &= lanes - 1;
                if tn[l] > best[l] * CULL_SLACK {
                    mask &= !(1 << l);
                }
            }
            if mask != 0 {
                nodes += 1;
                if count > 0 {
                    test_leaf(
                        self.leaf(child, count),
                        mask,
                        &mut best,
                        &mut out,
                        stats,
                        &mut test,
                    );
                } else {
                    let node = &self.wide8[child as usize];
                    let mut lanes_in = [0u32; WIDTH8];
                    let mut tn_in = [[0.0f32; K]; WIDTH8];
                    let mut key = [f32::INFINITY; WIDTH8];
                    let mut union = 0u32;
                    let mut lanes = mask;
                    while lanes != 0 {
                        let l = lanes.trailing_zeros() as usize;
                        lanes &= lanes - 1;
                        boxes += WIDTH8 as u64;
                        let (m, t) = rays[l].enter(node, best[l]);
                        union |= m;
                        let mut kids = m;
                        while kids != 0 {
                            let c = kids.trailing_zeros() as usize;
                            kids &= kids - 1;
                            lanes_in[c] |= 1 << l;
                            tn_in[c][l] = t[c];
                            key[c] = fmin(key[c], t[c]);
                        }
                    }
                    if union != 0 {
                        // Nearest first, by the nearest entry among a child's lanes.
                        current = Some(take_nearest(&mut stack, union, &key, |c| Entry8 {
                            child: node.child[c],
                            count: node.count[c],
                            mask: lanes_in[c],
                            tn: tn_in[c],
                        }));
                        continue;
                    }
                }
            }
            current = stack.pop();
        }
        stats.nodes += nodes;
        stats.box_tests += boxes;
        out
    }

    /// Any-hit per lane (see `occlusion_binary` for the contract) on the
    /// eight-wide tree (which must exist), the live lanes in one descent:
    /// a child is stacked with the live lanes whose segments enter it.
    pub fn occlusion_packet_wide8<const K: usize>(
        &self,
        packet: &SegmentPacket<K>,
        stats: &mut TraversalStats,
        test: &mut impl AnyHitTest,
    ) {
        if self.wide8.is_empty() {
            return;
        }
        let rays: [Lane8; K] = std::array::from_fn(|l| {
            Lane8::new(&SingleRay::new(packet.origins[l], packet.dirs[l], 0.0))
        });
        let t_max = &packet.t_max;
        let mut live = lanes_of::<K>(packet.mask);
        let (mut nodes, mut boxes) = (0u64, 0u64);
        let mut stack = ArrayVec::<(u32, u32, u32), STACK>::new();
        stack.push((0, 0, live));
        while let Some((child, count, m)) = stack.pop() {
            let mask = m & live;
            if mask == 0 {
                continue;
            }
            nodes += 1;
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
                    break;
                }
                continue;
            }
            let node = &self.wide8[child as usize];
            let mut lanes_in = [0u32; WIDTH8];
            let mut lanes = mask;
            while lanes != 0 {
                let l = lanes.trailing_zeros() as usize;
                lanes &= lanes - 1;
                boxes += WIDTH8 as u64;
                let mut kids = rays[l].enters(node, t_max[l]);
                while kids != 0 {
                    let c = kids.trailing_zeros() as usize;
                    kids &= kids - 1;
                    lanes_in[c] |= 1 << l;
                }
            }
            for c in (0..WIDTH8).rev() {
                if lanes_in[c] != 0 {
                    let _ = stack.try_push((node.child[c], node.count[c], lanes_in[c]));
                }
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

    /// A wavy height field of `n` x `n` quads, two triangles each, with
    /// poles (thin upright triangles) standing on it.
    fn terrain(n: usize) -> Vec<Shape> {
        let v = |i: usize, j: usize| {
            let (x, y) = (i as f32, j as f32);
            Vec3::new(x, y, (x * 0.37).sin() * (y * 0.23).cos())
        };
        let tri = |a: Vec3, b: Vec3, c: Vec3| {
            let nrm = (b - a).cross(c - a).normalize_or_zero();
            Shape::Triangle(Triangle::new(a, b, c, nrm, TriangleNormals::Flat))
        };
        let mut shapes: Vec<Shape> = (0..n * n)
            .flat_map(|k| {
                let (i, j) = (k % n, k / n);
                let (a, b, c, d) = (v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1));
                [tri(a, b, c), tri(a, c, d)]
            })
            .collect();
        for k in 0..n {
            let foot = v(k, (k * 7) % n) + Vec3::new(0.5, 0.5, -0.5);
            shapes.push(tri(
                foot,
                foot + Vec3::new(0.01, 0.0, 0.0),
                foot + Vec3::new(0.0, 0.0, 4.0),
            ));
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

    /// Each lane of `packet` in one eight-wide descent equals, bit for bit,
    /// the lane alone on the eight-wide tree (nearest hit), and its segment
    /// meets the same primitives (any hit, with and without a stop).
    fn check<const K: usize>(shapes: &[Shape], bvh: &Bvh, packet: &Packet<K>) -> usize {
        let mut stats = TraversalStats::default();
        let test = || Shapes { shapes, packet };
        let got = bvh.closest_packet_wide8(packet, &mut stats, test());
        let alone = bvh.closest_each_wide8(packet, &mut stats, test());
        let mut hits = 0;
        for l in 0..K {
            let what = format!("K={K}, lane {l}: {packet:?}");
            assert_eq!(got.prim[l], alone.prim[l], "{what}");
            assert_eq!(hit_bits(&got.hit[l]), hit_bits(&alone.hit[l]), "{what}");
            if packet.mask & (1 << l) == 0 {
                assert!(!got.has_hit(l), "{what}: masked lane");
            }
            hits += got.has_hit(l) as usize;
        }
        let segments = segments_of(packet);
        let occluders = |one_descent: bool, stop: bool| {
            let mut met: [Vec<u32>; K] = std::array::from_fn(|_| Vec::new());
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
                bvh.occlusion_packet_wide8(&segments, &mut stats, &mut test);
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
            for l in 0..K {
                if stop {
                    // Which occluder stops a lane may depend on the order;
                    // whether one does may not.
                    assert_eq!(got[l].len(), alone[l].len(), "K={K}, lane {l}: blocked");
                } else {
                    assert_eq!(got[l], alone[l], "K={K}, lane {l}: occluders");
                }
            }
        }
        hits
    }

    fn check_many<const K: usize>(
        shapes: &[Shape],
        bvh: &Bvh,
        rng: &mut fastrand::Rng,
        count: usize,
    ) -> usize {
        let boxes: Vec<Aabb> = shapes.iter().map(Shape::bounds).collect();
        (0..count)
            .map(|_| {
                check::<K>(shapes, bvh, &random_packet::<K>(rng))
                    + check::<K>(shapes, bvh, &grazing_packet::<K>(rng, &boxes))
            })
            .sum()
    }

    fn check_widths(shapes: &[Shape], bvh: &Bvh, seed: u64) -> usize {
        let mut rng = fastrand::Rng::with_seed(seed);
        check_many::<2>(shapes, bvh, &mut rng, 150)
            + check_many::<3>(shapes, bvh, &mut rng, 120)
            + check_many::<4>(shapes, bvh, &mut rng, 120)
            + check_many::<5>(shapes, bvh, &mut rng, 80)
            + check_many::<6>(shapes, bvh, &mut rng, 80)
            + check_many::<7>(shapes, bvh, &mut rng, 60)
            + check_many::<8>(shapes, bvh, &mut rng, 60)
            + check_many::<32>(shapes, bvh, &mut rng, 10)
    }

    /// K = 2..8 (and 32) lanes in one descent give each lane what it gets
    /// alone, on random shapes of every kind (scalar leaves) and on a mesh
    /// with poles (leaves as triangle blocks), for random and grazing rays.
    #[test]
    fn a_packet_descent_equals_its_lanes_alone_bit_for_bit() {
        let mut rng = fastrand::Rng::with_seed(41);
        let shapes = random_shapes(&mut rng, 400);
        let bvh = tree(&shapes, &BuildOptions::default());
        let hits = check_widths(&shapes, &bvh, 5);
        assert!(hits > 2000, "{hits} lanes hit");
        let mesh = terrain(24);
        let bvh = tree(&mesh, &BuildOptions::triangle_blocks());
        assert!(!bvh.blocks.is_empty());
        let hits = check_widths(&mesh, &bvh, 6);
        assert!(hits > 2000, "{hits} lanes hit");
    }

    /// The work of `K` views' eye rays through one pixel of a camera over
    /// the mesh, eyes `b` apart: in one descent, and each lane alone.
    fn views_work<const K: usize>(bvh: &Bvh, shapes: &[Shape], b: f32) -> [TraversalStats; 2] {
        let mut work = [TraversalStats::default(); 2];
        for j in 0..24 {
            for i in 0..24 {
                let target = Vec3::new(i as f32 + 0.3, j as f32 + 0.6, 0.0);
                let origins: [Vec3; K] =
                    std::array::from_fn(|l| Vec3::new(12.0 + b * l as f32, -10.0, 9.0));
                let packet = Packet {
                    origins,
                    dirs: origins.map(|o| (target - o).normalize()),
                    t_min: 0.0,
                    t_max: [f32::INFINITY; K],
                    mask: ((1u64 << K) - 1) as u32,
                };
                let test = || Shapes {
                    shapes,
                    packet: &packet,
                };
                let one = bvh.closest_packet_wide8(&packet, &mut work[0], test());
                let each = bvh.closest_each_wide8(&packet, &mut work[1], test());
                assert_eq!(one, each);
            }
        }
        work
    }

    /// On coherent rays (neighbouring views through one pixel) one descent
    /// visits fewer nodes than its lanes alone; K copies of one ray visit
    /// exactly the nodes the ray alone visits (the order is the single
    /// ray's: nearest first), with K box tests for each of its.
    #[test]
    fn a_shared_descent_visits_fewer_nodes_than_its_lanes_alone() {
        let shapes = terrain(24);
        let bvh = tree(&shapes, &BuildOptions::triangle_blocks());
        let [one, each] = views_work::<4>(&bvh, &shapes, 0.02);
        assert!(
            (one.nodes as f64) < 0.5 * each.nodes as f64,
            "4 views: {} nodes in one descent, {} alone",
            one.nodes,
            each.nodes
        );
        let [one, each] = views_work::<8>(&bvh, &shapes, 0.02);
        assert!(
            (one.nodes as f64) < 0.3 * each.nodes as f64,
            "8 views: {} nodes in one descent, {} alone",
            one.nodes,
            each.nodes
        );
        let [same, each] = views_work::<4>(&bvh, &shapes, 0.0);
        assert_eq!(same.nodes * 4, each.nodes, "copies of one ray");
        assert_eq!(same.box_tests, each.box_tests, "copies of one ray");
        assert_eq!(same.prim_tests, each.prim_tests, "copies of one ray");
    }
}

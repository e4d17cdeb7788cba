//! Up to eight shadow segments toward one light in one any-hit descent of
//! the eight-wide tree: a mono row's eight neighbouring samples, or a twin
//! group's views of one surface point, start their segments a little apart
//! and end them together, so they enter nearly the same nodes. As for eye
//! packets (`wide8_eye.rs`, whose `Rays8` prepares the segments here too),
//! the segments sit in the lanes of one `f32x8`:
//! a node is fetched once and each child is tested against every segment at
//! once; a child is stacked with the segments that entered it; a segment
//! leaves the descent when its test says stop (an opaque object: full
//! shadow); a subtree only one segment entered is finished by that segment's
//! own descent (`wide8_occlusion_single`). A leaf of spheres and cones is
//! tested primitive by primitive for all the segments that entered it, in
//! one eight-lane test each where the test takes them (`test_lanes`); a leaf
//! of triangle blocks segment by segment.
//!
//! Exactness: per lane, the slab test is the single segment's (the same
//! planes, the same operations in the same order, `tn <= min(tf, t_max)`
//! written as `tn <= tf && tn <= t_max`, which is the same for numbers that
//! are never NaN), so a segment reaches the leaves it reaches alone, and its
//! answer is what it is alone: the objects it meets are the same set (the
//! transmittance is their sorted product), or an opaque one stops it.

use super::leaf::{occlusion_lane, occlusion_leaf};
use super::traverse::{SingleRay, STACK};
use super::wide8::WIDTH8;
use super::wide8_eye::{Rays8, EYE_PACKET};
use super::{AnyHitTest, Bvh, SegmentPacket, TraversalStats};
use arrayvec::ArrayVec;
use wide::f32x8;

impl Bvh {
    /// Any-hit per lane (see `occlusion_binary` for the contract) of up to
    /// eight segments (`K <= 8`) in one descent of the eight-wide tree.
    /// Returns `false`, having done nothing, where the packet does not apply
    /// (no eight-wide tree, more than eight lanes, or the active segments'
    /// direction signs differ): the caller traces the segments alone.
    pub fn occlusion_packet8<const K: usize>(
        &self,
        packet: &SegmentPacket<K>,
        stats: &mut TraversalStats,
        test: &mut impl AnyHitTest,
    ) -> bool {
        let mask = packet.mask & ((1u64 << K.min(32)) - 1) as u32;
        if self.wide8.is_empty() || K > EYE_PACKET || mask == 0 {
            return false;
        }
        let singles: [SingleRay; EYE_PACKET] = std::array::from_fn(|l| {
            let l = if l < K { l } else { 0 };
            SingleRay::new(packet.origins[l], packet.dirs[l], 0.0)
        });
        let Some(rays) = Rays8::new(&singles, mask) else {
            return false;
        };
        let t_max = f32x8::from(std::array::from_fn::<f32, EYE_PACKET, _>(|l| {
            if l < K {
                packet.t_max[l]
            } else {
                0.0
            }
        }));
        let (mut nodes, mut boxes, mut prims) = (0u64, 0u64, 0u64);
        let mut live = mask;
        let mut stack = ArrayVec::<(u32, u32, u32), STACK>::new();
        stack.push((0, 0, mask));
        while let Some((child, count, entered)) = stack.pop() {
            let lanes = entered & live;
            if lanes == 0 {
                continue;
            }
            if lanes & (lanes - 1) == 0 {
                // One live segment in this subtree: finish it alone.
                let l = lanes.trailing_zeros() as usize;
                let start = (child, count);
                if self.wide8_occlusion_single(start, &singles[l], packet.t_max[l], stats, test, l)
                {
                    live &= !lanes;
                    if live == 0 {
                        break;
                    }
                }
                continue;
            }
            nodes += 1;
            if count > 0 {
                let leaf = self.leaf(child, count);
                if leaf.blocks.is_empty() {
                    // Primitive by primitive, the lanes that entered the leaf
                    // together (`test_lanes`): each lane meets the primitives
                    // in the order it meets them alone.
                    occlusion_leaf(leaf, false, lanes, &mut live, stats, test);
                    if live == 0 {
                        break;
                    }
                    continue;
                }
                let mut each = lanes;
                while each != 0 {
                    let l = each.trailing_zeros() as usize;
                    each &= each - 1;
                    if occlusion_lane(leaf, l, &mut prims, test) {
                        live &= !(1 << l);
                    }
                }
                if live == 0 {
                    break;
                }
                continue;
            }
            let node = &self.wide8[child as usize];
            boxes += WIDTH8 as u64 * lanes.count_ones() as u64;
            // Pushed last slot first, so that they pop in slot order.
            for c in (0..WIDTH8).rev() {
                if node.child[c] == 0 && node.count[c] == 0 {
                    continue; // an unused slot (no segment enters its empty box)
                }
                let (m, _) = rays.enter(node, c, t_max);
                let m = m & lanes;
                if m != 0 {
                    let _ = stack.try_push((node.child[c], node.count[c], m));
                }
            }
        }
        stats.nodes += nodes;
        stats.box_tests += boxes;
        stats.prim_tests += prims;
        true
    }
}

#[cfg(test)]
mod tests {
    use super::super::brute_force::{random_packet, random_shapes, segments_of};
    use super::super::{build, AnyHit, BuildOptions};
    use super::*;
    use crate::math::{Aabb, Ray, Vec3};
    use crate::shapes::Shape;

    fn tree(shapes: &[Shape], opts: &BuildOptions) -> Bvh {
        let boxes: Vec<Aabb> = shapes.iter().map(Shape::bounds).collect();
        let mut bvh = build(&boxes, opts);
        bvh.attach_blocks(shapes);
        bvh
    }

    /// `K` segments from points a little apart (eyes of a group's views
    /// seeing one spot) to one light, each lane its own length; or random.
    fn toward_light<const K: usize>(rng: &mut fastrand::Rng) -> SegmentPacket<K> {
        if rng.u8(..4) == 0 {
            return segments_of(&random_packet::<K>(rng));
        }
        let spot = Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5) * 20.0;
        let light = Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32()) * 30.0;
        let step = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 0.05;
        let origins: [Vec3; K] = std::array::from_fn(|l| spot + step * l as f32);
        SegmentPacket {
            origins,
            dirs: origins.map(|o| (light - o).normalize()),
            t_max: origins.map(|o| (light - o).length()),
            mask: rng.u32(1..(1u32 << K)),
        }
    }

    /// What each lane's segment meets (sorted), in one descent or each
    /// alone; with `stop`, a lane stops at its first object.
    fn occluders<const K: usize>(
        shapes: &[Shape],
        bvh: &Bvh,
        segments: &SegmentPacket<K>,
        one_descent: bool,
        stop: bool,
        stats: &mut TraversalStats,
    ) -> Option<[Vec<u32>; K]> {
        let mut met: [Vec<u32>; K] = std::array::from_fn(|_| Vec::new());
        let mut test = |p: u32, l: usize| {
            let ray = Ray::new(segments.origins[l], segments.dirs[l]);
            if shapes[p as usize]
                .intersect(&ray, 0.0, segments.t_max[l])
                .is_some()
            {
                met[l].push(p);
                if stop {
                    return AnyHit::Stop;
                }
            }
            AnyHit::Continue
        };
        if one_descent {
            if !bvh.occlusion_packet8(segments, stats, &mut test) {
                return None;
            }
        } else {
            bvh.occlusion_wide8(segments, stats, &mut test);
        }
        Some(met.map(|mut m| {
            m.sort_unstable();
            m
        }))
    }

    /// Checks `count` packets of `K` lanes; returns the lanes that met
    /// something and the packets refused (mixed direction signs).
    fn check<const K: usize>(
        shapes: &[Shape],
        bvh: &Bvh,
        seed: u64,
        count: usize,
    ) -> (usize, usize) {
        let mut rng = fastrand::Rng::with_seed(seed);
        let (mut met, mut refused) = (0, 0);
        for n in 0..count {
            let segments = toward_light::<K>(&mut rng);
            for stop in [false, true] {
                let mut stats = TraversalStats::default();
                let alone = occluders(shapes, bvh, &segments, false, stop, &mut stats)
                    .expect("lanes alone always apply");
                let Some(got) = occluders(shapes, bvh, &segments, true, stop, &mut stats) else {
                    refused += 1;
                    continue;
                };
                for l in 0..K {
                    let what = format!("packet {n}, lane {l}, stop {stop}");
                    if segments.mask & (1 << l) == 0 {
                        assert!(got[l].is_empty(), "{what}: masked off");
                    } else if stop {
                        // Which object stops a lane may depend on the
                        // order; whether one does may not.
                        assert_eq!(got[l].len(), alone[l].len(), "{what}: blocked");
                    } else {
                        assert_eq!(got[l], alone[l], "{what}: objects met");
                    }
                    met += usize::from(!stop && !alone[l].is_empty());
                }
            }
        }
        (met, refused)
    }

    /// Segments toward a light in one descent meet, lane by lane, what each
    /// meets alone: every object (without a stop), or one (with), on
    /// random shapes of every kind and on a mesh (triangle blocks), for
    /// packets of four and eight lanes with lanes masked off.
    #[test]
    fn a_shadow_packet_meets_what_its_segments_meet_alone() {
        let mut rng = fastrand::Rng::with_seed(17);
        let shapes = random_shapes(&mut rng, 400);
        let bvh = tree(&shapes, &BuildOptions::default());
        let (met, refused) = check::<4>(&shapes, &bvh, 3, 1500);
        assert!(
            met > 500 && refused < 750,
            "{met} lanes met something, {refused} refused"
        );
        let (met, _) = check::<8>(&shapes, &bvh, 4, 800);
        assert!(met > 500, "{met}");
        let mesh = super::super::leaf::tests::terrain(24);
        let bvh = tree(&mesh, &BuildOptions::triangle_blocks());
        assert!(!bvh.blocks.is_empty());
        let (met, _) = check::<4>(&mesh, &bvh, 5, 1500);
        assert!(met > 200, "{met}");
    }

    /// Coherent segments share their nodes: a packet visits fewer nodes
    /// than its lanes alone.
    #[test]
    fn a_shadow_packet_visits_fewer_nodes_than_its_segments_alone() {
        let mut rng = fastrand::Rng::with_seed(29);
        let shapes = random_shapes(&mut rng, 400);
        let bvh = tree(&shapes, &BuildOptions::default());
        let (mut packed, mut alone) = (TraversalStats::default(), TraversalStats::default());
        let mut segments_traced = 0;
        for _ in 0..500 {
            let mut segments = toward_light::<4>(&mut rng);
            segments.mask = 0b1111;
            let mut p = TraversalStats::default();
            if occluders(&shapes, &bvh, &segments, true, false, &mut p).is_none() {
                continue;
            }
            segments_traced += 4;
            packed += p;
            occluders(&shapes, &bvh, &segments, false, false, &mut alone);
        }
        assert!(segments_traced > 1000, "{segments_traced}");
        assert!(
            packed.nodes * 2 < alone.nodes,
            "packet {} nodes, alone {}",
            packed.nodes,
            alone.nodes
        );
    }
}

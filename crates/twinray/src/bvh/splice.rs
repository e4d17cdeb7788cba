//! A two-level hierarchy laid out as one tree: a small tree over the root
//! boxes of instances' own trees, with every instance's tree spliced in below
//! it (children and primitive slots re-indexed). The traversals then see one
//! ordinary [`Bvh`]; an animation keeps the trees of the instances that did not
//! move and builds only the moving ones' again (`world/two_level.rs`).
//!
//! Instances are not transformed at traversal time: their primitives are in
//! world space. The joined tree may differ from a build over all primitives
//! at once, but it bounds every primitive, so the nearest hit of a ray (where
//! only one primitive is nearest) is the same.

use super::{build, collapse, BuildOptions, Bvh, Node, PAD};
use crate::math::Aabb;
use crate::shapes::BLOCK;

/// One instance's tree, over primitive slots `offset..offset + bvh.order.len()`
/// of the joined order.
#[derive(Clone, Copy)]
pub struct Placed<'a> {
    pub bvh: &'a Bvh,
    pub offset: u32,
}

/// Where a node of the joined tree comes from.
enum Source<'a> {
    /// Node `.0` of the tree over the instances' root boxes.
    Top(usize),
    /// A leaf of that tree holding several instances: an inner node over the
    /// first and the rest.
    Several(&'a [u32]),
    /// Node `.1` of instance `.0`'s tree.
    Instance(usize, usize),
}

/// The instances' trees joined under a tree over their root boxes. Slot `s`
/// of instance `i` becomes slot `b_i + s` (`b_i`: the slots of the instances
/// before it, rounded up to a block), holding primitive `offset + order[s]`
/// (padding stays `PAD`). Instances without primitives are left out.
pub fn splice(parts: &[Placed]) -> Bvh {
    let kept: Vec<usize> = (0..parts.len())
        .filter(|&i| !parts[i].bvh.nodes.is_empty())
        .collect();
    if kept.is_empty() {
        return Bvh::default();
    }
    // Each instance's slots start at a block, so that its leaves that start
    // one still do.
    let mut base = Vec::with_capacity(parts.len());
    let mut slots = 0usize;
    for p in parts {
        slots = slots.next_multiple_of(BLOCK);
        base.push(slots as u32);
        slots += p.bvh.order.len();
    }
    let mut order = vec![PAD; slots.next_multiple_of(BLOCK)];
    for (p, &b) in parts.iter().zip(&base) {
        for (s, &o) in p.bvh.order.iter().enumerate() {
            if o != PAD {
                order[b as usize + s] = p.offset + o;
            }
        }
    }
    let roots: Vec<Aabb> = kept.iter().map(|&i| parts[i].bvh.bounds()).collect();
    let top = build(&roots, &BuildOptions::default());
    let total: usize = kept.iter().map(|&i| parts[i].bvh.nodes.len()).sum();
    let mut nodes = Vec::with_capacity(top.nodes.len() + total + kept.len());
    nodes.push(top.nodes[0]);
    let mut work = vec![(Source::Top(0), 0usize)];
    // Two adjacent slots for the children of the node at `at`.
    let children = |nodes: &mut Vec<Node>, at: usize| {
        let first = nodes.len();
        nodes[at].first = first as u32;
        nodes.extend_from_slice(&[top.nodes[0]; 2]);
        first
    };
    while let Some((source, at)) = work.pop() {
        match source {
            Source::Top(i) => {
                let n = top.nodes[i];
                if n.is_leaf() {
                    let members = &top.order[n.first as usize..(n.first + n.count()) as usize];
                    work.push((Source::Several(members), at));
                    continue;
                }
                nodes[at] = n;
                let first = children(&mut nodes, at);
                work.push((Source::Top(n.first as usize + 1), first + 1));
                work.push((Source::Top(n.first as usize), first));
            }
            Source::Several(&[one]) => {
                work.push((Source::Instance(kept[one as usize], 0), at));
            }
            Source::Several(members) => {
                let bounds = members
                    .iter()
                    .fold(Aabb::EMPTY, |b, &m| b.union(roots[m as usize]));
                nodes[at] = Node {
                    min: bounds.min.into(),
                    first: 0,
                    max: bounds.max.into(),
                    // Inner, split along x: the axis only orders the visit.
                    meta: 0,
                };
                let first = children(&mut nodes, at);
                work.push((Source::Several(&members[1..]), first + 1));
                work.push((Source::Instance(kept[members[0] as usize], 0), first));
            }
            Source::Instance(p, i) => {
                let n = parts[p].bvh.nodes[i];
                nodes[at] = n;
                if n.is_leaf() {
                    nodes[at].first = n.first + base[p];
                    continue;
                }
                let first = children(&mut nodes, at);
                work.push((Source::Instance(p, n.first as usize + 1), first + 1));
                work.push((Source::Instance(p, n.first as usize), first));
            }
        }
    }
    let wide = collapse(&nodes);
    Bvh {
        nodes,
        order,
        wide,
        ..Bvh::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::{brute_force, TraversalStats};
    use crate::math::Ray;
    use crate::shapes::Shape;

    /// Random shapes cut into instances of random sizes (some empty, some
    /// of one primitive), each with its own tree, joined.
    fn joined(seed: u64, count: usize) -> (Vec<Shape>, Bvh, usize) {
        let mut rng = fastrand::Rng::with_seed(seed);
        let shapes = brute_force::random_shapes(&mut rng, count);
        let mut cuts = vec![0, shapes.len()];
        for _ in 0..rng.usize(1..40) {
            cuts.push(rng.usize(0..=shapes.len()));
        }
        cuts.sort_unstable();
        let trees: Vec<(Bvh, u32)> = cuts
            .windows(2)
            .map(|w| {
                let boxes: Vec<Aabb> = shapes[w[0]..w[1]].iter().map(Shape::bounds).collect();
                (build(&boxes, &BuildOptions::default()), w[0] as u32)
            })
            .collect();
        let parts: Vec<Placed> = trees
            .iter()
            .map(|(bvh, offset)| Placed {
                bvh,
                offset: *offset,
            })
            .collect();
        (shapes, splice(&parts), cuts.len() - 1)
    }

    #[test]
    fn every_primitive_is_in_one_leaf_and_boxes_nest() {
        for seed in 0..6 {
            let (shapes, bvh, _) = joined(seed, 400);
            let mut seen = vec![0u32; shapes.len()];
            let mut stack = vec![0usize];
            while let Some(i) = stack.pop() {
                let n = bvh.nodes[i];
                let b = n.bounds();
                if n.is_leaf() {
                    for slot in n.first..n.first + n.count() {
                        let p = bvh.order[slot as usize] as usize;
                        seen[p] += 1;
                        let sb = shapes[p].bounds();
                        assert!(b.min.cmple(sb.min).all() && b.max.cmpge(sb.max).all());
                    }
                } else {
                    for c in [n.first as usize, n.first as usize + 1] {
                        let cb = bvh.nodes[c].bounds();
                        assert!(b.min.cmple(cb.min).all() && b.max.cmpge(cb.max).all());
                        stack.push(c);
                    }
                }
            }
            assert!(seen.iter().all(|&s| s == 1), "seed {seed}: {seen:?}");
            assert_eq!(bvh.wide, collapse(&bvh.nodes));
        }
    }

    #[test]
    fn nearest_and_any_hits_equal_brute_force() {
        let mut hits = 0;
        for seed in 0..4 {
            let (shapes, bvh, instances) = joined(100 + seed, 300);
            assert!(instances > 1);
            let mut rng = fastrand::Rng::with_seed(seed);
            let mut stats = TraversalStats::default();
            for n in 0..300 {
                let packet = brute_force::random_packet::<4>(&mut rng);
                let expect = brute_force::closest_hits(&shapes, &packet);
                // The traversal hands the test primitive indices (the
                // order's entries), and ties go to the lower one: the joined
                // tree must give exactly what testing every primitive gives.
                let got = bvh.closest(&packet, &mut stats, |p: u32, l: usize, t_max: f32| {
                    let ray = Ray::new(packet.origins[l], packet.dirs[l]);
                    shapes[p as usize].intersect(&ray, packet.t_min, t_max)
                });
                for l in 0..4 {
                    assert_eq!(
                        got.prim[l], expect.prim[l],
                        "seed {seed}, packet {n}, lane {l}"
                    );
                    if expect.has_hit(l) {
                        hits += 1;
                        assert_eq!(got.hit[l].t.to_bits(), expect.hit[l].t.to_bits());
                    }
                }
                let segments = brute_force::segments_of(&packet);
                let met = brute_force::met(&shapes, &segments, false, |mut test| {
                    bvh.occlusion(&segments, &mut stats, &mut test)
                });
                for (l, met) in met.iter().enumerate() {
                    assert_eq!(*met, brute_force::occluders(&shapes, &segments, l));
                }
            }
        }
        assert!(hits > 500, "{hits}");
    }
}

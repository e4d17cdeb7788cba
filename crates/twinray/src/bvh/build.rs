//! Binned surface-area-heuristic build, parallel over subtrees with rayon.

use super::{Bvh, Node};
use crate::math::{Aabb, Vec3};

#[derive(Clone, Copy, Debug)]
pub struct BuildOptions {
    /// SAH bins per axis.
    pub bins: usize,
    /// Largest leaf the builder makes when splitting stops paying.
    pub max_leaf: usize,
    /// Cost of one box test relative to one primitive test.
    pub traversal_cost: f32,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions {
            bins: 16,
            max_leaf: 4,
            traversal_cost: 1.0,
        }
    }
}

/// Subtrees smaller than this are built on the current thread.
const PARALLEL_THRESHOLD: usize = 8192;

/// Builds a hierarchy over primitives with the given boxes. Boxes are padded so
/// that the slab test stays conservative under rounding.
pub fn build(boxes: &[Aabb], opts: &BuildOptions) -> Bvh {
    if boxes.is_empty() {
        return Bvh::default();
    }
    let refs: Vec<PrimRef> = boxes
        .iter()
        .enumerate()
        .map(|(i, b)| {
            let b = primitive_box(b);
            PrimRef {
                bounds: b,
                centroid: b.center(),
                index: i as u32,
            }
        })
        .collect();
    let mut refs = refs;
    let tree = build_subtree(&mut refs, opts);
    let mut bvh = Bvh {
        nodes: Vec::with_capacity(2 * boxes.len()),
        order: refs.iter().map(|r| r.index).collect(),
        wide: Vec::new(),
    };
    flatten(&tree, &mut bvh.nodes, 0);
    bvh.wide = super::collapse(&bvh.nodes);
    bvh
}

/// The box a primitive with bounds `b` is filed under: `b` padded so that the
/// slab test stays conservative under rounding (an empty `b`: the origin). The
/// boxes of the nodes above it are unions of such boxes, so they contain it
/// exactly.
pub fn primitive_box(b: &Aabb) -> Aabb {
    if b.is_empty() {
        Aabb {
            min: Vec3::ZERO,
            max: Vec3::ZERO,
        }
    } else {
        b.padded()
    }
}

#[derive(Clone, Copy)]
struct PrimRef {
    bounds: Aabb,
    centroid: Vec3,
    index: u32,
}

/// The tree as built, before it is laid out flat.
enum BuildNode {
    Leaf {
        bounds: Aabb,
        first: usize,
        count: usize,
    },
    Inner {
        bounds: Aabb,
        axis: usize,
        children: Box<[BuildNode; 2]>,
    },
}

impl BuildNode {
    fn bounds(&self) -> Aabb {
        match self {
            BuildNode::Leaf { bounds, .. } | BuildNode::Inner { bounds, .. } => *bounds,
        }
    }
}

/// Past this depth the builder splits at the median, which bounds the depth of any
/// tree (and so the traversal stack) by about this plus log2 of the count.
const MAX_SAH_DEPTH: usize = 64;

fn build_subtree(refs: &mut [PrimRef], opts: &BuildOptions) -> BuildNode {
    build_range(refs, 0, 0, opts)
}

fn build_range(
    refs: &mut [PrimRef],
    offset: usize,
    depth: usize,
    opts: &BuildOptions,
) -> BuildNode {
    let bounds = refs.iter().fold(Aabb::EMPTY, |b, r| b.union(r.bounds));
    let leaf = || BuildNode::Leaf {
        bounds,
        first: offset,
        count: refs.len(),
    };
    if refs.len() <= 2 {
        return leaf();
    }
    let centroid_bounds = refs.iter().fold(Aabb::EMPTY, |b, r| b.grow(r.centroid));
    if depth >= MAX_SAH_DEPTH {
        return median_split(refs, offset, depth, bounds, &centroid_bounds, opts);
    }
    let Some(split) = best_split(refs, &bounds, &centroid_bounds, opts) else {
        return if refs.len() <= opts.max_leaf {
            leaf()
        } else {
            median_split(refs, offset, depth, bounds, &centroid_bounds, opts)
        };
    };
    let leaf_cost = refs.len() as f32;
    if split.cost >= leaf_cost && refs.len() <= opts.max_leaf {
        return leaf();
    }
    let mid = partition(refs, |r| {
        bin_of(
            r.centroid[split.axis],
            &centroid_bounds,
            split.axis,
            opts.bins,
        ) < split.bin
    });
    if mid == 0 || mid == refs.len() {
        return median_split(refs, offset, depth, bounds, &centroid_bounds, opts);
    }
    split_and_recurse(refs, offset, depth, mid, bounds, split.axis, opts)
}

fn split_and_recurse(
    refs: &mut [PrimRef],
    offset: usize,
    depth: usize,
    mid: usize,
    bounds: Aabb,
    axis: usize,
    opts: &BuildOptions,
) -> BuildNode {
    let (left, right) = refs.split_at_mut(mid);
    let (l, r) = if left.len() + right.len() > PARALLEL_THRESHOLD {
        rayon::join(
            || build_range(left, offset, depth + 1, opts),
            || build_range(right, offset + mid, depth + 1, opts),
        )
    } else {
        (
            build_range(left, offset, depth + 1, opts),
            build_range(right, offset + mid, depth + 1, opts),
        )
    };
    BuildNode::Inner {
        bounds,
        axis,
        children: Box::new([l, r]),
    }
}

/// Fallback when binning cannot separate the centroids (all equal, or all in one bin).
fn median_split(
    refs: &mut [PrimRef],
    offset: usize,
    depth: usize,
    bounds: Aabb,
    centroid_bounds: &Aabb,
    opts: &BuildOptions,
) -> BuildNode {
    let axis = centroid_bounds.extent().max_position();
    let mid = refs.len() / 2;
    refs.select_nth_unstable_by(mid, |a, b| a.centroid[axis].total_cmp(&b.centroid[axis]));
    split_and_recurse(refs, offset, depth, mid, bounds, axis, opts)
}

struct Split {
    axis: usize,
    bin: usize,
    cost: f32,
}

#[inline]
fn bin_of(c: f32, cb: &Aabb, axis: usize, bins: usize) -> usize {
    let lo = cb.min[axis];
    let ext = cb.max[axis] - lo;
    let b = ((c - lo) / ext * bins as f32) as usize;
    b.min(bins - 1)
}

fn best_split(refs: &[PrimRef], bounds: &Aabb, cb: &Aabb, opts: &BuildOptions) -> Option<Split> {
    let n = opts.bins;
    let mut best: Option<Split> = None;
    let parent_area = bounds.half_area().max(f32::MIN_POSITIVE);
    for axis in 0..3 {
        if cb.max[axis] <= cb.min[axis] || cb.max[axis].is_nan() {
            continue;
        }
        let mut bin_box = vec![Aabb::EMPTY; n];
        let mut bin_count = vec![0u32; n];
        for r in refs {
            let b = bin_of(r.centroid[axis], cb, axis, n);
            bin_box[b] = bin_box[b].union(r.bounds);
            bin_count[b] += 1;
        }
        // Sweep from the right, then from the left.
        let mut right_area = vec![0f32; n];
        let mut right_count = vec![0u32; n];
        let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
        for i in (1..n).rev() {
            acc = acc.union(bin_box[i]);
            cnt += bin_count[i];
            right_area[i] = acc.half_area();
            right_count[i] = cnt;
        }
        let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
        for i in 1..n {
            acc = acc.union(bin_box[i - 1]);
            cnt += bin_count[i - 1];
            if cnt == 0 || right_count[i] == 0 {
                continue;
            }
            let cost = opts.traversal_cost
                + (acc.half_area() * cnt as f32 + right_area[i] * right_count[i] as f32)
                    / parent_area;
            if best.as_ref().is_none_or(|b| cost < b.cost) {
                best = Some(Split { axis, bin: i, cost });
            }
        }
    }
    best
}

/// In-place partition; returns the number of elements for which `pred` holds.
fn partition(refs: &mut [PrimRef], pred: impl Fn(&PrimRef) -> bool) -> usize {
    let mut i = 0;
    for j in 0..refs.len() {
        if pred(&refs[j]) {
            refs.swap(i, j);
            i += 1;
        }
    }
    i
}

/// Lays the tree out depth-first with siblings adjacent.
fn flatten(node: &BuildNode, nodes: &mut Vec<Node>, _depth: usize) {
    nodes.push(to_node(node, 0));
    let mut queue = vec![(node, 0usize)];
    while let Some((n, index)) = queue.pop() {
        if let BuildNode::Inner { children, .. } = n {
            let first = nodes.len();
            nodes[index].first = first as u32;
            nodes.push(to_node(&children[0], 0));
            nodes.push(to_node(&children[1], 0));
            queue.push((&children[1], first + 1));
            queue.push((&children[0], first));
        }
    }
}

fn to_node(n: &BuildNode, first: u32) -> Node {
    let b = n.bounds();
    match n {
        BuildNode::Leaf {
            first: f, count, ..
        } => Node {
            min: b.min.into(),
            first: *f as u32,
            max: b.max.into(),
            meta: *count as u32,
        },
        BuildNode::Inner { axis, .. } => Node {
            min: b.min.into(),
            first,
            max: b.max.into(),
            meta: (*axis as u32) << 30,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn random_boxes(n: usize, seed: u64) -> Vec<Aabb> {
        let mut rng = fastrand::Rng::with_seed(seed);
        let mut next = || rng.f32();
        (0..n)
            .map(|_| {
                let c = Vec3::new(next(), next(), next()) * 100.0;
                let e = Vec3::new(next(), next(), next());
                Aabb {
                    min: c - e,
                    max: c + e,
                }
            })
            .collect()
    }

    fn check(bvh: &Bvh, boxes: &[Aabb]) {
        let mut seen = vec![false; boxes.len()];
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let n = bvh.nodes[i];
            let nb = n.bounds();
            if n.is_leaf() {
                for slot in n.first..n.first + n.count() {
                    let p = bvh.order[slot as usize] as usize;
                    assert!(!seen[p]);
                    seen[p] = true;
                    let b = boxes[p];
                    assert!(nb.min.cmple(b.min).all() && nb.max.cmpge(b.max).all());
                }
            } else {
                for c in [n.first as usize, n.first as usize + 1] {
                    let cb = bvh.nodes[c].bounds();
                    assert!(nb.min.cmple(cb.min).all() && nb.max.cmpge(cb.max).all());
                    stack.push(c);
                }
            }
        }
        assert!(
            seen.iter().all(|&s| s),
            "every primitive in exactly one leaf"
        );
    }

    #[test]
    fn every_primitive_once_and_boxes_nest() {
        for n in [1, 2, 3, 17, 1000, 20000] {
            let boxes = random_boxes(n, n as u64);
            let bvh = build(&boxes, &BuildOptions::default());
            check(&bvh, &boxes);
        }
    }

    #[test]
    fn identical_boxes_do_not_recurse_forever() {
        let boxes = vec![
            Aabb {
                min: Vec3::ZERO,
                max: Vec3::ONE
            };
            1000
        ];
        let bvh = build(&boxes, &BuildOptions::default());
        check(&bvh, &boxes);
        assert!(bvh.depth() < 40);
    }

    #[test]
    fn empty_input() {
        let bvh = build(&[], &BuildOptions::default());
        assert!(bvh.nodes.is_empty());
    }
}

//! Binned surface-area-heuristic build, parallel over subtrees with rayon.

use super::{Bvh, Node};
use crate::math::{Aabb, Vec3};
use crate::shapes::BLOCK;
use wide::{bytemuck, f32x4, i32x4};

#[derive(Clone, Copy, Debug)]
pub struct BuildOptions {
    /// SAH bins per axis (2 to 16).
    pub bins: usize,
    /// Largest leaf the builder makes when splitting stops paying.
    pub max_leaf: usize,
    /// Cost of one box test relative to one primitive test (with
    /// `cost_in_blocks`: to one block test).
    pub traversal_cost: f32,
    /// Every leaf starts at a slot that is a multiple of this, the order
    /// padded with `PAD` between leaves, so that a leaf's triangle blocks
    /// (`shapes::LeafBlocks`) are found from its first slot. 1: no padding.
    pub block: usize,
    /// The SAH counts a leaf's cost in blocks of `block` primitives, which are
    /// tested at once: it then prefers leaves that fill their blocks.
    pub cost_in_blocks: bool,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions {
            bins: 16,
            max_leaf: 4,
            traversal_cost: 1.0,
            block: 1,
            cost_in_blocks: false,
        }
    }
}

impl BuildOptions {
    /// For primitives that are all triangles, tested four at a time: leaves
    /// of up to two full blocks, aligned to blocks, the SAH counting blocks.
    pub fn triangle_blocks() -> BuildOptions {
        BuildOptions {
            max_leaf: 2 * BLOCK,
            block: BLOCK,
            cost_in_blocks: true,
            ..BuildOptions::default()
        }
    }

    /// For any primitives: today's leaves, aligned to blocks so that those
    /// made only of triangles can be tested four at a time.
    pub fn aligned() -> BuildOptions {
        BuildOptions {
            block: BLOCK,
            ..BuildOptions::default()
        }
    }

    /// What the SAH charges for testing `n` primitives in a leaf.
    #[inline(always)]
    fn leaf_cost(&self, n: u32) -> f32 {
        if self.cost_in_blocks {
            // The blocks of a power of two by a shift: the sweep asks for
            // two leaf costs per bin, and a division took longer than the
            // rest of the bin.
            let block = self.block.max(1) as u32;
            let blocks = if block.is_power_of_two() {
                (n >> block.trailing_zeros()) + (n & (block - 1) != 0) as u32
            } else {
                n.div_ceil(block)
            };
            blocks as f32
        } else {
            n as f32
        }
    }
}

/// An order slot that holds no primitive: the padding before a leaf that
/// starts a block.
pub const PAD: u32 = u32::MAX;

/// Subtrees smaller than this are built on the current thread.
const PARALLEL_THRESHOLD: usize = 8192;
/// Nodes with more primitives than this are binned by several threads.
const PARALLEL_BINNING: usize = 65536;
/// Nodes with at least this many primitives are binned into two sets of
/// bins (`Bins::of`).
const TWO_SETS: usize = 256;
/// Most SAH bins per axis (`BuildOptions::bins` is clamped to it), so that
/// the bins live on the stack. The default's 16: with room for 32, a node's
/// bins were 3.4 KB, set to empty and copied for every node, though no
/// caller asks for more than 16.
const MAX_BINS: usize = 16;

/// Builds a hierarchy over primitives with the given boxes, and its
/// eight-wide form. Boxes are padded so that the slab test stays
/// conservative under rounding.
pub fn build(boxes: &[Aabb], opts: &BuildOptions) -> Bvh {
    build_by(boxes.len(), |i| boxes[i], || *opts)
}

/// `build` over `n` primitives, the bounds of primitive `i` given by
/// `bounds(i)` (called once for each, on all threads, in no given order),
/// and the options by `opts`, called once they all have been: so a caller
/// that reads its primitives for their bounds decides the options in the
/// same pass, and no array of boxes is made.
pub fn build_by(
    n: usize,
    bounds: impl Fn(usize) -> Aabb + Sync,
    opts: impl FnOnce() -> BuildOptions,
) -> Bvh {
    if n == 0 {
        return Bvh::default();
    }
    use rayon::prelude::*;
    let mut refs: Vec<PrimRef> = (0..n)
        .into_par_iter()
        .map(|i| PrimRef::new(&primitive_box(&bounds(i)), i as u32))
        .collect();
    let opts = &opts();
    let tree = build_subtree(&mut refs, opts);
    let (nodes, order) = flatten(&tree, &refs, opts.block.max(1));
    finish(nodes, order, (tree, refs))
}

/// `build` over pieces of primitives: piece `i` has the box `pieces[i].1` and
/// belongs to primitive `pieces[i].0`. A long tilted shape filed under the
/// boxes of its pieces is met by fewer rays that miss it than under its own
/// box. A leaf names each of its primitives once (its first piece's slot);
/// a primitive whose pieces fell in several leaves is in each of them.
pub fn build_pieces(pieces: &[(u32, Aabb)], opts: &BuildOptions) -> Bvh {
    if pieces.is_empty() {
        return Bvh::default();
    }
    use rayon::prelude::*;
    let mut refs: Vec<PrimRef> = pieces
        .par_iter()
        .enumerate()
        .map(|(i, (_, b))| PrimRef::new(&primitive_box(b), i as u32))
        .collect();
    let tree = build_subtree(&mut refs, opts);
    let (mut nodes, mut order) = flatten(&tree, &refs, opts.block.max(1));
    for o in order.iter_mut().filter(|o| **o != PAD) {
        *o = pieces[*o as usize].0;
    }
    for n in nodes.iter_mut().filter(|n| n.is_leaf()) {
        let first = n.first as usize;
        let slots = &mut order[first..first + n.count() as usize];
        let mut kept = 0;
        for i in 0..slots.len() {
            if !slots[..kept].contains(&slots[i]) {
                slots[kept] = slots[i];
                kept += 1;
            }
        }
        slots[kept..].fill(PAD);
        n.meta = (n.meta & !0x3fff_ffff) | kept as u32;
    }
    finish(nodes, order, (tree, refs))
}

/// The hierarchy of `nodes` and `order` with its wide form; `built` is the
/// build's own tree, freed beside it.
fn finish(nodes: Vec<Node>, order: Vec<u32>, built: (BuildNode, Vec<PrimRef>)) -> Bvh {
    // The collapse (serial) on one thread and the build's own tree freed on
    // another, off its path.
    let (wide, ()) = rayon::join(|| super::collapse(&nodes), || drop(built));
    Bvh {
        nodes,
        order,
        wide,
        ..Bvh::default()
    }
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

/// A box in two SIMD registers: the minima and the maxima of x, y and z in
/// lanes 0 to 2. Lane 3 is no part of the box (a `PrimRef` keeps its index
/// in `hi`'s): unions carry it along and nothing reads it.
///
/// Exactness: `union` and `grow` give, lane for lane, `Aabb::union`'s and
/// `Aabb::grow`'s numbers, NaN and signed zeros included: glam's
/// `min`/`max` are `if a < b { a } else { b }`, which is what
/// `minps`/`maxps` compute with the operands in the same order. So the
/// tree is the one the scalar `Aabb` arithmetic built (`tests/all/bvh_build.rs`).
#[derive(Clone, Copy)]
struct Box4 {
    lo: f32x4,
    hi: f32x4,
}

impl Box4 {
    const EMPTY: Box4 = Box4 {
        lo: f32x4::splat(f32::INFINITY),
        hi: f32x4::splat(f32::NEG_INFINITY),
    };

    /// `self` where the mask `m` is set (all lanes alike), else `other`.
    #[inline(always)]
    fn or_else(self, m: f32x4, other: Box4) -> Box4 {
        Box4 {
            lo: m.select(self.lo, other.lo),
            hi: m.select(self.hi, other.hi),
        }
    }

    #[inline(always)]
    fn union(self, o: Box4) -> Box4 {
        Box4 {
            lo: self.lo.fast_min(o.lo),
            hi: self.hi.fast_max(o.hi),
        }
    }

    #[inline(always)]
    fn grow(self, p: f32x4) -> Box4 {
        Box4 {
            lo: self.lo.fast_min(p),
            hi: self.hi.fast_max(p),
        }
    }

    fn aabb(self) -> Aabb {
        let (lo, hi) = (self.lo.to_array(), self.hi.to_array());
        Aabb {
            min: Vec3::new(lo[0], lo[1], lo[2]),
            max: Vec3::new(hi[0], hi[1], hi[2]),
        }
    }

    #[inline(always)]
    fn half_area(self) -> f32 {
        self.aabb().half_area()
    }
}

/// Lanes 0 to 2 of a register, lane 3 cleared.
const XYZ: f32x4 = f32x4::new([
    f32::from_bits(u32::MAX),
    f32::from_bits(u32::MAX),
    f32::from_bits(u32::MAX),
    0.0,
]);

/// A primitive's padded box (32 bytes: half a cache line), its index in the
/// fourth lane of `hi`.
#[derive(Clone, Copy)]
struct PrimRef(Box4);

impl PrimRef {
    fn new(b: &Aabb, index: u32) -> PrimRef {
        PrimRef(Box4 {
            lo: f32x4::new([b.min.x, b.min.y, b.min.z, 0.0]),
            hi: f32x4::new([b.max.x, b.max.y, b.max.z, f32::from_bits(index)]),
        })
    }

    #[inline(always)]
    fn bounds(&self) -> Box4 {
        self.0
    }

    /// `Aabb::center` of the box, lane for lane (lane 3: 0).
    #[inline(always)]
    fn centroid(&self) -> f32x4 {
        (self.0.lo + (self.0.hi & XYZ)) * f32x4::splat(0.5)
    }

    #[inline(always)]
    fn index(&self) -> u32 {
        bytemuck::cast::<f32x4, [u32; 4]>(self.0.hi)[3]
    }
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
        /// Nodes in the subtree, and the order slots its leaves take (each
        /// leaf's count rounded up to a block): where `flatten` puts it.
        nodes: usize,
        slots: usize,
    },
}

impl BuildNode {
    /// Nodes in the subtree.
    fn nodes(&self) -> usize {
        match self {
            BuildNode::Leaf { .. } => 1,
            BuildNode::Inner { nodes, .. } => *nodes,
        }
    }

    /// Order slots of the subtree's leaves, each starting a block.
    fn slots(&self, block: usize) -> usize {
        match self {
            BuildNode::Leaf { count, .. } => count.next_multiple_of(block),
            BuildNode::Inner { slots, .. } => *slots,
        }
    }

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
    build_range(refs, 0, 0, None, opts)
}

/// The subtree over `refs` (slots from `offset`); `known`: the bounds and
/// centroid bounds of `refs` if the parent's partition found them.
fn build_range(
    refs: &mut [PrimRef],
    offset: usize,
    depth: usize,
    known: Option<(Box4, Box4)>,
    opts: &BuildOptions,
) -> BuildNode {
    let (bounds4, centroid_bounds) = known.unwrap_or_else(|| bounds_of(refs));
    let bounds = bounds4.aabb();
    let leaf = || BuildNode::Leaf {
        bounds,
        first: offset,
        count: refs.len(),
    };
    if refs.len() <= 2 || (opts.cost_in_blocks && refs.len() <= opts.block.min(opts.max_leaf)) {
        // (One block: splitting adds a box test and saves no block test.)
        return leaf();
    }
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
    let leaf_cost = opts.leaf_cost(refs.len() as u32);
    if split.cost >= leaf_cost && refs.len() <= opts.max_leaf {
        return leaf();
    }
    let (mid, sides) = partition(refs, |c| split.binning.left_of(c, split.axis, split.bin));
    if mid == 0 || mid == refs.len() {
        return median_split(refs, offset, depth, bounds, &centroid_bounds, opts);
    }
    split_and_recurse(
        refs,
        offset,
        depth,
        mid,
        Some(sides),
        bounds,
        split.axis,
        opts,
    )
}

/// The union of the boxes of `refs` and the bounds of their centroids, in
/// one pass (on several threads for large nodes).
fn bounds_of(refs: &[PrimRef]) -> (Box4, Box4) {
    let fold = |c: &[PrimRef]| {
        c.iter().fold((Box4::EMPTY, Box4::EMPTY), |(b, cb), r| {
            (b.union(r.bounds()), cb.grow(r.centroid()))
        })
    };
    if refs.len() > PARALLEL_BINNING {
        use rayon::prelude::*;
        refs.par_chunks(PARALLEL_BINNING / 4).map(fold).reduce(
            || (Box4::EMPTY, Box4::EMPTY),
            |a, b| (a.0.union(b.0), a.1.union(b.1)),
        )
    } else {
        fold(refs)
    }
}

/// `sides`: the bounds and centroid bounds of `refs[..mid]` and
/// `refs[mid..]`, if known.
#[allow(clippy::too_many_arguments)]
fn split_and_recurse(
    refs: &mut [PrimRef],
    offset: usize,
    depth: usize,
    mid: usize,
    sides: Option<[(Box4, Box4); 2]>,
    bounds: Aabb,
    axis: usize,
    opts: &BuildOptions,
) -> BuildNode {
    let (left, right) = refs.split_at_mut(mid);
    let (kl, kr) = (sides.map(|s| s[0]), sides.map(|s| s[1]));
    let (l, r) = if left.len() + right.len() > PARALLEL_THRESHOLD {
        rayon::join(
            || build_range(left, offset, depth + 1, kl, opts),
            || build_range(right, offset + mid, depth + 1, kr, opts),
        )
    } else {
        (
            build_range(left, offset, depth + 1, kl, opts),
            build_range(right, offset + mid, depth + 1, kr, opts),
        )
    };
    let block = opts.block.max(1);
    BuildNode::Inner {
        bounds,
        axis,
        nodes: 1 + l.nodes() + r.nodes(),
        slots: l.slots(block) + r.slots(block),
        children: Box::new([l, r]),
    }
}

/// Fallback when binning cannot separate the centroids (all equal, or all in one bin).
fn median_split(
    refs: &mut [PrimRef],
    offset: usize,
    depth: usize,
    bounds: Aabb,
    centroid_bounds: &Box4,
    opts: &BuildOptions,
) -> BuildNode {
    let axis = centroid_bounds.aabb().extent().max_position();
    let mid = refs.len() / 2;
    let key = |r: &PrimRef| r.centroid().to_array()[axis];
    refs.select_nth_unstable_by(mid, |a, b| key(a).total_cmp(&key(b)));
    split_and_recurse(refs, offset, depth, mid, None, bounds, axis, opts)
}

struct Split {
    axis: usize,
    bin: usize,
    cost: f32,
    binning: Binning,
}

/// Which of `bins` equal slices of the centroid bounds, per axis, a
/// centroid falls in: one subtract and one multiply per axis, all three axes
/// in one register (the binning and the partition use this same function,
/// so they agree on every primitive).
#[derive(Clone, Copy)]
struct Binning {
    lo: f32x4,
    scale: f32x4,
    last: i32x4,
}

impl Binning {
    fn new(cb: &Aabb, bins: usize) -> Binning {
        let scale = |a: usize| {
            let ext = cb.max[a] - cb.min[a];
            if ext > 0.0 {
                bins as f32 / ext
            } else {
                0.0
            }
        };
        Binning {
            lo: f32x4::new([cb.min.x, cb.min.y, cb.min.z, 0.0]),
            scale: f32x4::new([scale(0), scale(1), scale(2), 0.0]),
            last: i32x4::splat(bins as i32 - 1),
        }
    }

    /// The bin on each axis (lane 3: 0): `(c - lo) * scale` truncated as
    /// `as usize` does (NaN and negatives to 0, +inf to the top), then at
    /// most the last bin.
    #[inline(always)]
    fn bins(&self, c: f32x4) -> [i32; 4] {
        ((c - self.lo) * self.scale)
            .trunc_int()
            .max(i32x4::ZERO)
            .min(self.last)
            .to_array()
    }

    /// Whether `bins(c)[axis] < bin`, from a mask (no trip through memory).
    #[inline(always)]
    fn left_of(&self, c: f32x4, axis: usize, bin: usize) -> bool {
        let k = ((c - self.lo) * self.scale)
            .trunc_int()
            .max(i32x4::ZERO)
            .min(self.last);
        (k.simd_lt(i32x4::splat(bin as i32)).to_bitmask() >> axis) & 1 != 0
    }
}

/// Per axis and bin, the union of the boxes and the count of primitives
/// whose centroids fall there.
#[derive(Clone, Copy)]
struct Bins {
    bounds: [[Box4; MAX_BINS]; 3],
    count: [[u32; MAX_BINS]; 3],
    /// Whether some centroid has a NaN coordinate (every box with a NaN
    /// coordinate gives one): the sweep then takes every boundary.
    nan: bool,
}

impl Bins {
    const EMPTY: Bins = Bins {
        bounds: [[Box4::EMPTY; MAX_BINS]; 3],
        count: [[0; MAX_BINS]; 3],
        nan: false,
    };

    /// All three axes in one pass over `refs`. A large node's first and
    /// second halves are binned side by side into two sets of bins, merged
    /// after: two elements in a row often fall in the same bins, and one
    /// set made each union wait for the store of the one before it.
    ///
    /// Exactness: a bin's union over the first half, united with its union
    /// over the second, is its union over all in order, NaN aside: `minps`
    /// (`a < b ? a : b`) folded over a sequence gives the last of its least
    /// values (by `<`, so `-0`/`+0` included), however the sequence is cut.
    /// With a NaN the cut changes the result; so if any centroid has a NaN
    /// lane (which every box with a NaN coordinate gives) the node is binned
    /// again in one set.
    fn of(refs: &[PrimRef], binning: &Binning) -> Bins {
        if refs.len() < TWO_SETS {
            return Bins::of_in_one(refs, binning);
        }
        let (first, second) = refs.split_at(refs.len() / 2);
        let (mut a, mut b) = (Bins::EMPTY, Bins::EMPTY);
        let mut nan = f32x4::ZERO;
        for (ra, rb) in first.iter().zip(second) {
            nan |= a.add(ra, binning);
            nan |= b.add(rb, binning);
        }
        for r in &second[first.len()..] {
            nan |= b.add(r, binning);
        }
        if nan.any() {
            return Bins::of_in_one(refs, binning);
        }
        a.merge(&b)
    }

    /// `of` in one set of bins, element after element.
    fn of_in_one(refs: &[PrimRef], binning: &Binning) -> Bins {
        let mut b = Bins::EMPTY;
        let mut nan = f32x4::ZERO;
        for r in refs {
            nan |= b.add(r, binning);
        }
        b.nan = nan.any();
        b
    }

    /// Adds `r` to its bins; returns the lanes where its centroid is NaN.
    #[inline(always)]
    fn add(&mut self, r: &PrimRef, binning: &Binning) -> f32x4 {
        let c = r.centroid();
        let bins = binning.bins(c);
        for (axis, &i) in bins[..3].iter().enumerate() {
            let i = i as usize;
            self.bounds[axis][i] = self.bounds[axis][i].union(r.bounds());
            self.count[axis][i] += 1;
        }
        c.simd_ne(c)
    }

    fn merge(mut self, o: &Bins) -> Bins {
        for axis in 0..3 {
            for i in 0..MAX_BINS {
                self.bounds[axis][i] = self.bounds[axis][i].union(o.bounds[axis][i]);
                self.count[axis][i] += o.count[axis][i];
            }
        }
        self.nan |= o.nan;
        self
    }
}

fn best_split(refs: &[PrimRef], bounds: &Aabb, cb: &Box4, opts: &BuildOptions) -> Option<Split> {
    let n = opts.bins.clamp(2, MAX_BINS);
    let cb = &cb.aabb();
    let binning = Binning::new(cb, n);
    let bins = if refs.len() > PARALLEL_BINNING {
        use rayon::prelude::*;
        refs.par_chunks(PARALLEL_BINNING / 4)
            .map(|c| Bins::of(c, &binning))
            .reduce(|| Bins::EMPTY, |a, b| a.merge(&b))
    } else {
        Bins::of(refs, &binning)
    };
    let mut best: Option<Split> = None;
    let parent_area = bounds.half_area().max(f32::MIN_POSITIVE);
    let sweep = Sweep {
        n,
        parent_area,
        opts,
        binning,
    };
    for axis in 0..3 {
        if cb.max[axis] <= cb.min[axis] || cb.max[axis].is_nan() {
            continue;
        }
        let (boxes, counts) = (&bins.bounds[axis], &bins.count[axis]);
        if bins.nan {
            sweep.every_bin(&mut best, axis, boxes, counts);
        } else {
            sweep.filled_bins(&mut best, axis, boxes, counts);
        }
    }
    best
}

/// The SAH sweep of one axis's bins: the cost of each boundary between
/// bins, the first least cost over the axes in order kept in `best`.
struct Sweep<'a> {
    n: usize,
    parent_area: f32,
    opts: &'a BuildOptions,
    binning: Binning,
}

impl Sweep<'_> {
    #[inline(always)]
    fn cost(&self, left: Box4, left_count: u32, right_area: f32, right_count: u32) -> f32 {
        let opts = self.opts;
        opts.traversal_cost
            + (left.half_area() * opts.leaf_cost(left_count)
                + right_area * opts.leaf_cost(right_count))
                / self.parent_area
    }

    #[inline(always)]
    fn offer(&self, best: &mut Option<Split>, axis: usize, bin: usize, cost: f32) {
        if best.as_ref().is_none_or(|b| cost < b.cost) {
            *best = Some(Split {
                axis,
                bin,
                cost,
                binning: self.binning,
            });
        }
    }

    /// Every boundary `1..n`: from the right, then from the left.
    fn every_bin(
        &self,
        best: &mut Option<Split>,
        axis: usize,
        bin_box: &[Box4; MAX_BINS],
        bin_count: &[u32; MAX_BINS],
    ) {
        let n = self.n;
        let mut right_area = [0f32; MAX_BINS];
        let mut right_count = [0u32; MAX_BINS];
        let (mut acc, mut cnt) = (Box4::EMPTY, 0);
        for i in (1..n).rev() {
            acc = acc.union(bin_box[i]);
            cnt += bin_count[i];
            right_area[i] = acc.half_area();
            right_count[i] = cnt;
        }
        let (mut acc, mut cnt) = (Box4::EMPTY, 0);
        for i in 1..n {
            acc = acc.union(bin_box[i - 1]);
            cnt += bin_count[i - 1];
            if cnt == 0 || right_count[i] == 0 {
                continue;
            }
            let cost = self.cost(acc, cnt, right_area[i], right_count[i]);
            self.offer(best, axis, i, cost);
        }
    }

    /// `every_bin`'s choice, from the boundaries that follow a bin that
    /// holds primitives. Only for bins without a NaN coordinate: an empty
    /// bin's box is `Box4::EMPTY`, whose union with a box without NaN is
    /// that box, bit for bit (`minps(a, +inf)` is `a`, `-0` and `±inf`
    /// included), so a boundary after an empty bin has the unions, the
    /// counts and so the cost of the boundary before that bin, and the
    /// first least cost is never one of them (a boundary with no primitive
    /// on one side is skipped by both). A small node fills few of its bins,
    /// and the sweep was about a third of the build.
    fn filled_bins(
        &self,
        best: &mut Option<Split>,
        axis: usize,
        bin_box: &[Box4; MAX_BINS],
        bin_count: &[u32; MAX_BINS],
    ) {
        let mut filled = [0u8; MAX_BINS];
        let mut m = 0;
        for (i, &c) in bin_count[..self.n].iter().enumerate() {
            filled[m] = i as u8;
            m += (c != 0) as usize;
        }
        if m < 2 {
            return;
        }
        let filled = &filled[..m];
        // `right_area[k]`: the half area of the bins `filled[k..]`.
        let mut right_area = [0f32; MAX_BINS];
        let mut acc = Box4::EMPTY;
        let mut total = 0;
        for k in (1..m).rev() {
            acc = acc.union(bin_box[filled[k] as usize]);
            right_area[k] = acc.half_area();
        }
        for &b in filled {
            total += bin_count[b as usize];
        }
        let (mut acc, mut cnt) = (Box4::EMPTY, 0);
        for k in 0..m - 1 {
            let b = filled[k] as usize;
            acc = acc.union(bin_box[b]);
            cnt += bin_count[b];
            let cost = self.cost(acc, cnt, right_area[k + 1], total - cnt);
            self.offer(best, axis, b + 1, cost);
        }
    }
}

/// In-place partition; returns the number of elements whose centroids
/// `left` holds for, and the bounds and centroid bounds of both sides (found
/// on the way, which saves the children a pass over their primitives).
/// Lomuto's: element `j` goes to slot `i` when `left`, as a swap that
/// writes both slots either way (no branch to mispredict). Both sides'
/// bounds stay in registers: each element's unions with both are made, and
/// a blend keeps the one of its side (the other side's bounds unchanged), so
/// every side's bounds are the same unions in the same order as before, and
/// no union waits on the store of the one before it.
fn partition(refs: &mut [PrimRef], left: impl Fn(f32x4) -> bool) -> (usize, [(Box4, Box4); 2]) {
    let (mut l, mut lc) = (Box4::EMPTY, Box4::EMPTY);
    let (mut r, mut rc) = (Box4::EMPTY, Box4::EMPTY);
    let mut i = 0;
    for j in 0..refs.len() {
        let p = refs[j];
        let c = p.centroid();
        let left = left(c);
        let m = f32x4::splat(f32::from_bits(0u32.wrapping_sub(left as u32)));
        let (lu, lg) = (l.union(p.bounds()), lc.grow(c));
        let (ru, rg) = (r.union(p.bounds()), rc.grow(c));
        l = lu.or_else(m, l);
        lc = lg.or_else(m, lc);
        r = r.or_else(m, ru);
        rc = rc.or_else(m, rg);
        // The swap as blends on the same mask (a branch on `left` would be
        // taken at random). Slot `j` is written first: slot `i` may then be
        // `j` itself, so the compiler cannot make the write to `i` a masked
        // store (which the next element's load of slot `i` would wait on).
        let a = refs[i];
        let (p, a) = (p.bounds(), a.bounds());
        refs[j] = PrimRef(a.or_else(m, p));
        refs[i] = PrimRef(p.or_else(m, a));
        i += left as usize;
    }
    (i, [(l, lc), (r, rc)])
}

/// Lays the tree out depth-first with siblings adjacent, and the
/// primitives in leaf order, each leaf starting at a multiple of `block`
/// (`PAD` in the slots between).
///
/// The layout (the one a depth-first walk that places both children of a
/// node when it reaches the node makes): a node's two children next to each
/// other, then the left child's descendants, then the right child's; in the
/// order, the node's children that are leaves (left, right), then the left
/// child's subtree, then the right child's. So each subtree fills a range of
/// the nodes and one of the order that its sizes (`BuildNode::nodes`,
/// `slots`) give, and the two subtrees of a large node are laid out on two
/// threads.
fn flatten(root: &BuildNode, refs: &[PrimRef], block: usize) -> (Vec<Node>, Vec<u32>) {
    let blank = Node {
        min: [0.0; 3],
        first: 0,
        max: [0.0; 3],
        meta: 0,
    };
    let mut nodes = vec![blank; root.nodes()];
    let mut order = vec![PAD; root.slots(block)];
    let (first, rest) = nodes.split_at_mut(1);
    first[0] = lay_out(root, (rest, 1), (&mut order, 0), refs, block);
    (nodes, order)
}

/// Writes the descendants of `n` to `desc` (node `at` onwards) and the
/// primitives of its leaves to `slots` (slot `at` onwards); returns `n`'s
/// own node.
fn lay_out(
    n: &BuildNode,
    (desc, desc_at): (&mut [Node], usize),
    (slots, slot_at): (&mut [u32], usize),
    refs: &[PrimRef],
    block: usize,
) -> Node {
    match n {
        BuildNode::Leaf { first, count, .. } => {
            for (s, r) in slots.iter_mut().zip(&refs[*first..first + count]) {
                *s = r.index();
            }
            to_node(n, slot_at as u32)
        }
        BuildNode::Inner { children, .. } => {
            let [l, r] = &**children;
            let (pair, rest) = desc.split_at_mut(2);
            let (left_desc, right_desc) = rest.split_at_mut(l.nodes() - 1);
            // The right child's slots come first if it is a leaf and the
            // left one is not.
            let right_first = r.nodes() == 1 && l.nodes() > 1;
            let (left_slots, right_slots, right_slot_at) = if right_first {
                let (rs, ls) = slots.split_at_mut(r.slots(block));
                (ls, rs, slot_at)
            } else {
                let (ls, rs) = slots.split_at_mut(l.slots(block));
                (ls, rs, slot_at + l.slots(block))
            };
            let left_slot_at = if right_first {
                slot_at + r.slots(block)
            } else {
                slot_at
            };
            let right_at = (desc_at + 1 + l.nodes(), right_slot_at);
            let mut left = move || {
                lay_out(
                    l,
                    (left_desc, desc_at + 2),
                    (left_slots, left_slot_at),
                    refs,
                    block,
                )
            };
            let mut right = move || {
                lay_out(
                    r,
                    (right_desc, right_at.0),
                    (right_slots, right_at.1),
                    refs,
                    block,
                )
            };
            let (ln, rn) = if n.nodes() > PARALLEL_THRESHOLD / 2 {
                rayon::join(left, right)
            } else {
                (left(), right())
            };
            pair[0] = ln;
            pair[1] = rn;
            to_node(n, desc_at as u32)
        }
    }
}

/// `n`'s node; `first`: its first slot (a leaf) or its first child.
fn to_node(n: &BuildNode, first: u32) -> Node {
    let b = n.bounds();
    match n {
        BuildNode::Leaf { count, .. } => Node {
            min: b.min.into(),
            first,
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

    /// `Bins::of`'s two sets of bins give, bit for bit, the bounds and
    /// counts of one set: odd and even counts, ties between `-0` and `+0`
    /// (the least x of every bin is a zero of either sign, so the last one
    /// decides), and a NaN in the second half (where cutting the sequence
    /// would change the unions, so the node is binned again in one set).
    #[test]
    fn two_sets_of_bins_are_one_set_bit_for_bit() {
        for (n, nan) in [
            (TWO_SETS, false),
            (1001, false),
            (4096, false),
            (1001, true),
        ] {
            let mut boxes = random_boxes(n, n as u64);
            for (k, b) in boxes.iter_mut().enumerate() {
                b.min.x = if k % 3 == 0 { 0.0 } else { 2.0 };
                if k % 6 == 3 {
                    b.min.x = -0.0;
                }
            }
            if nan {
                boxes[2 * n / 3].min.y = f32::NAN;
            }
            let refs: Vec<PrimRef> = boxes
                .iter()
                .enumerate()
                .map(|(i, b)| PrimRef::new(b, i as u32))
                .collect();
            let (_, cb) = bounds_of(&refs);
            let binning = Binning::new(&cb.aabb(), 16);
            let (two, one) = (Bins::of(&refs, &binning), Bins::of_in_one(&refs, &binning));
            let bits = |b: &Bins| {
                let mut v = Vec::new();
                for axis in 0..3 {
                    for i in 0..MAX_BINS {
                        let (lo, hi) = (b.bounds[axis][i].lo, b.bounds[axis][i].hi);
                        v.extend(
                            lo.to_array()
                                .iter()
                                .chain(&hi.to_array()[..3])
                                .map(|f| f.to_bits()),
                        );
                        v.push(b.count[axis][i]);
                    }
                }
                v
            };
            assert_eq!(bits(&two), bits(&one), "{n} boxes, NaN: {nan}");
        }
    }

    /// The sweep over the filled bins chooses, bit for bit, what the sweep
    /// over every boundary chooses (axis, bin and cost), on bins without
    /// NaN: most of them empty, boxes of small integers (so that costs tie
    /// between boundaries and between axes), signed zeros and infinite
    /// bounds, one to three axes swept into one `best`, costs counted in
    /// primitives and in blocks.
    #[test]
    fn the_filled_bins_sweep_is_every_bin_sweep() {
        let mut rng = fastrand::Rng::with_seed(17);
        let coord = |rng: &mut fastrand::Rng| match rng.u32(0..12) {
            0 => f32::INFINITY,
            1 => f32::NEG_INFINITY,
            2 => -0.0,
            3 => 0.0,
            _ => rng.u32(0..6) as f32,
        };
        let mut ties = 0;
        for round in 0..20_000 {
            let n = rng.usize(2..=MAX_BINS);
            let mut bins = Bins::EMPTY;
            let full = rng.u32(0..4) == 0;
            for axis in 0..3 {
                for i in 0..n {
                    if !full && rng.u32(0..3) != 0 {
                        continue;
                    }
                    let (a, b) = (
                        [0; 3].map(|_| coord(&mut rng)),
                        [0; 3].map(|_| coord(&mut rng)),
                    );
                    let lo = f32x4::new([a[0].min(b[0]), a[1].min(b[1]), a[2].min(b[2]), 0.0]);
                    let hi = f32x4::new([a[0].max(b[0]), a[1].max(b[1]), a[2].max(b[2]), 0.0]);
                    bins.bounds[axis][i] = Box4 { lo, hi };
                    bins.count[axis][i] = rng.u32(1..20);
                }
            }
            let opts = if round % 2 == 0 {
                BuildOptions::triangle_blocks()
            } else {
                BuildOptions::default()
            };
            let cb = Aabb {
                min: Vec3::ZERO,
                max: Vec3::ONE,
            };
            let sweep = Sweep {
                n,
                parent_area: [1.0, 7.0, 0.3][round % 3],
                opts: &opts,
                binning: Binning::new(&cb, n),
            };
            let (mut every, mut filled) = (None, None);
            for axis in 0..rng.usize(1..=3) {
                let (b, c) = (&bins.bounds[axis], &bins.count[axis]);
                sweep.every_bin(&mut every, axis, b, c);
                sweep.filled_bins(&mut filled, axis, b, c);
            }
            let key = |s: &Option<Split>| s.as_ref().map(|s| (s.axis, s.bin, s.cost.to_bits()));
            assert_eq!(key(&every), key(&filled), "round {round}, {n} bins");
            // The rounds where two axes' least costs tie (the first axis
            // must win).
            let least = |axis: usize| {
                let mut one = None;
                sweep.every_bin(&mut one, axis, &bins.bounds[axis], &bins.count[axis]);
                one.map(|s| s.cost.to_bits())
            };
            ties += (least(0).is_some() && least(0) == least(1)) as usize;
        }
        assert!(ties > 100, "{ties} ties between axes");
    }

    /// `best_split` (which sweeps the filled bins unless a centroid is NaN)
    /// chooses what sweeping every boundary chooses, on small nodes of boxes
    /// with small integer, infinite and NaN coordinates: with a NaN the
    /// unions with empty bins are not the identity, which is why such a node
    /// sweeps every boundary.
    #[test]
    fn best_split_is_every_bin_sweep_with_nan_and_infinite_boxes() {
        let mut rng = fastrand::Rng::with_seed(23);
        let mut nan_nodes = 0;
        for round in 0..20_000 {
            let len = rng.usize(3..60);
            let boxes: Vec<Aabb> = (0..len)
                .map(|_| {
                    let mut c = [0; 6].map(|_| rng.u32(0..8) as f32);
                    match rng.u32(0..10) {
                        0 => c[rng.usize(0..6)] = f32::NAN,
                        1 => c[rng.usize(0..3)] = f32::NEG_INFINITY,
                        2 => c[3 + rng.usize(0..3)] = f32::INFINITY,
                        _ => {}
                    }
                    Aabb {
                        min: Vec3::new(c[0], c[1], c[2]),
                        max: Vec3::new(c[0].max(c[3]), c[1].max(c[4]), c[2].max(c[5])),
                    }
                })
                .collect();
            let refs: Vec<PrimRef> = boxes
                .iter()
                .enumerate()
                .map(|(i, b)| PrimRef::new(b, i as u32))
                .collect();
            let opts = if round % 2 == 0 {
                BuildOptions::triangle_blocks()
            } else {
                BuildOptions::default()
            };
            let (b4, cb4) = bounds_of(&refs);
            let (bounds, cb) = (b4.aabb(), cb4.aabb());
            let got = best_split(&refs, &bounds, &cb4, &opts);
            // Every boundary of every axis, as before the filled-bins sweep.
            let n = opts.bins.clamp(2, MAX_BINS);
            let binning = Binning::new(&cb, n);
            let bins = Bins::of(&refs, &binning);
            nan_nodes += bins.nan as usize;
            let sweep = Sweep {
                n,
                parent_area: bounds.half_area().max(f32::MIN_POSITIVE),
                opts: &opts,
                binning,
            };
            let mut want = None;
            for axis in 0..3 {
                if cb.max[axis] <= cb.min[axis] || cb.max[axis].is_nan() {
                    continue;
                }
                sweep.every_bin(&mut want, axis, &bins.bounds[axis], &bins.count[axis]);
            }
            let key = |s: &Option<Split>| s.as_ref().map(|s| (s.axis, s.bin, s.cost.to_bits()));
            assert_eq!(key(&got), key(&want), "round {round}, {len} boxes");
        }
        assert!(nan_nodes > 1000, "{nan_nodes} nodes with a NaN");
    }

    #[test]
    fn empty_input() {
        let bvh = build(&[], &BuildOptions::default());
        assert!(bvh.nodes.is_empty());
    }
}

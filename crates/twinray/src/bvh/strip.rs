//! One descent for many parallel rays (issue 16, "one descent for many views").
//!
//! The views of a rig sit on one line with parallel axes and whole-pixel
//! shifts, so the views' rays along one camera column are parallel: direction
//! `d`, origins `E + s·R` (`R` the camera's right axis, `s` the view's offset).
//! That is a one-parameter family of rays, and the family's geometric tests
//! cost the same whatever the number of rays:
//!
//! * a box: per axis the entry and exit distances are linear in `s`, so the
//!   rays that enter the box (entry ≤ exit, exit ≥ `t_min`) are an interval of
//!   `s`: the intersection of twelve half-lines (`box_interval`);
//! * a triangle: Möller–Trumbore's `u` and `v` are linear in `s` too, so the
//!   rays it may cover are an interval (`FamilyTest::cover` of the caller);
//! * a sphere: the distance of the ray's line from the centre is quadratic in
//!   `s`, again an interval.
//!
//! Exactness is by construction, never by the family's arithmetic: the family
//! tests only *exclude* rays, conservatively (boxes padded, intervals widened
//! by a bound on the single-ray routine's rounding). A ray that remains at a
//! leaf enters it only if the single-ray descent's own slab test of the leaf's
//! box, with the ray's own nearest hit so far, lets it in (a box holds its
//! ancestors' tests, which are monotone in the box); then it is tested with
//! the ordinary single-ray routine (`FamilyTest::exact`) and its hits offered
//! with the single-ray rule (nearer, or as near on a lower primitive index).
//! The descent visits the nodes in the single-ray descent's order (near child
//! first, by the direction's sign, which every ray shares), so each ray meets
//! the same leaves with the same nearest hit so far as when traced alone on
//! the binary tree: its `prim`, `t`, `u` and `v` are that descent's.
//!
//! The descent runs over the binary tree (`Bvh::nodes`); its stack entries
//! carry the interval (a range of ray indices) still alive in the node, which
//! is trimmed at both ends by the rays' own nearest hits.

use super::traverse::{LaneHit, SingleRay, CULL_SLACK, NO_SURFACE};
use super::{Bvh, Node};
use crate::math::Vec3;
use crate::shapes::SurfaceHit;
use glam::DVec3;

/// Unit roundoff of `f32` times a safety factor: the relative rounding that
/// the family tests allow the single-ray routines (a few dozen operations).
pub const FAMILY_EPS: f64 = 256.0 * f32::EPSILON as f64 * 0.5;

/// The family `E + s_k·R + t·d`, `t > t_min`, for ascending `s_k`, in double
/// precision, with the per-ray data the exact tests need.
#[derive(Clone, Default)]
pub struct Family {
    pub dir: DVec3,
    pub base: DVec3,
    pub step: DVec3,
    /// The rays' parameters, ascending.
    pub s: Vec<f64>,
    pub t_min: f64,
    /// Padding of every box and every point: a bound on how far the rays'
    /// single-precision origins and hit points may lie from the family's.
    pub pad: f64,
    /// Largest `|s|·|R| + |E|`: the scale of the origins' rounding.
    pub origin_scale: f64,
    /// Each ray as the single-ray descent sees it (its own origin).
    rays: Vec<SingleRay>,
    origins: Vec<Vec3>,
    dir32: Vec3,
    t_min32: f32,
    slopes: SlabSlopes,
}

impl Family {
    /// The family for ray parameters `s` (ascending), base `base`, step
    /// `step` and direction `dir`; `scene_scale`: the largest coordinate of
    /// the scene's bounds (for the padding).
    /// Adds the ray with parameter `s` (not below the last one's) and
    /// single-precision origin `origin` (what the single-ray methods use).
    pub fn push(&mut self, s: f32, origin: Vec3) {
        self.s.push(s as f64);
        self.origins.push(origin);
    }

    /// Starts a family anew (its rays `push`ed next, then `finish`).
    pub fn reset(&mut self, base: Vec3, step: Vec3, dir: Vec3, t_min: f32, scene_scale: f32) {
        self.dir = dir.as_dvec3();
        self.base = base.as_dvec3();
        self.step = step.as_dvec3();
        self.t_min = t_min as f64;
        self.s.clear();
        self.origins.clear();
        self.dir32 = dir;
        self.t_min32 = t_min;
        self.pad = scene_scale as f64;
    }

    /// Computes the padding once the parameters are in.
    pub fn finish(&mut self) {
        let smax = self.s.iter().fold(0.0f64, |m, &x| m.max(x.abs()));
        self.origin_scale =
            smax * self.step.length() + self.base.abs().max_element() * 3.0_f64.sqrt();
        let scale = self.pad.max(self.origin_scale);
        self.pad = FAMILY_EPS * (scale + 1e-6);
        self.slopes = SlabSlopes::new(self);
        let (dir, t_min) = (self.dir32, self.t_min32);
        self.rays.clear();
        self.rays
            .extend(self.origins.iter().map(|&o| SingleRay::new(o, dir, t_min)));
    }

    /// The ray `k`'s origin in the family's arithmetic.
    pub fn origin(&self, k: usize) -> DVec3 {
        self.base + self.step * self.s[k]
    }

    /// The rays `lo..hi` whose parameter lies in `[a, b]`.
    fn indices(&self, lo: usize, hi: usize, a: f64, b: f64) -> (usize, usize) {
        let s = &self.s[lo..hi];
        let first = lo + s.partition_point(|&x| x < a);
        let last = lo + s.partition_point(|&x| x <= b);
        (first, last.max(first))
    }
}

/// The values of `s` where `k·s ≤ r` holds, intersected into `[lo, hi]`.
#[derive(Clone, Copy, Debug)]
pub struct Interval {
    pub lo: f64,
    pub hi: f64,
}

impl Interval {
    pub const ALL: Interval = Interval {
        lo: f64::NEG_INFINITY,
        hi: f64::INFINITY,
    };

    /// Keeps the `s` with `k·s ≤ r`. A NaN bound keeps every `s` (the tests
    /// only ever exclude what they are sure of).
    #[inline(always)]
    pub fn le(&mut self, k: f64, r: f64) {
        if k > 0.0 {
            self.hi = self.hi.min(r / k);
        } else if k < 0.0 {
            self.lo = self.lo.max(r / k);
        } else if r < 0.0 {
            self.hi = f64::NEG_INFINITY;
        }
    }

    /// `le` with `1/k` given (0 when `k` is 0).
    #[inline(always)]
    fn le_inv(&mut self, k: f64, inv_k: f64, r: f64) {
        if k > 0.0 {
            self.hi = self.hi.min(r * inv_k);
        } else if k < 0.0 {
            self.lo = self.lo.max(r * inv_k);
        } else if r < 0.0 {
            self.hi = f64::NEG_INFINITY;
        }
    }

    pub fn is_empty(&self) -> bool {
        self.lo > self.hi
    }
}

/// Which rays of the family a primitive may meet.
#[derive(Clone, Copy, Debug)]
pub enum Cover {
    /// None of them.
    Miss,
    /// At most those whose parameter lies in the interval.
    Interval(Interval),
    /// The family's arithmetic cannot bound it (cones, triangles parallel
    /// to the rays): every ray alive in the leaf is tested on its own.
    Unbounded,
}

/// The primitive tests of a family descent.
pub trait FamilyTest {
    /// The rays of `family` primitive `prim` may hit: a superset of those for
    /// which `exact` gives a hit.
    fn cover(&mut self, prim: u32, family: &Family) -> Cover;
    /// Ray `k` against `prim`, with the ordinary single-ray routine (`t >
    /// t_min`, any distance).
    fn exact(&mut self, prim: u32, k: usize) -> Option<SurfaceHit>;
}

/// Work done by family descents, for statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, derive_more::AddAssign)]
pub struct StripStats {
    /// Descents (one per family).
    pub descents: u64,
    /// Nodes visited (one per node per family, whatever its rays).
    pub nodes: u64,
    /// Family tests of primitives.
    pub covers: u64,
    /// Of those, primitives the family's arithmetic could not bound.
    pub unbounded: u64,
    /// Single-ray tests of a ray against a primitive, and those that hit.
    pub exact_tests: u64,
    pub exact_hits: u64,
}

/// A descent's buffers, kept from family to family.
#[derive(Default)]
pub struct StripScratch {
    stack: Vec<(u32, u32, u32)>,
    best: Vec<LaneHit>,
    /// Per ray, at the current leaf: not asked yet, enters, or does not.
    enters: Vec<Entry>,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Entry {
    Unknown,
    In,
    Out,
}

/// The lines `t = a + b·s` through which the family enters and leaves a box.
struct Slabs {
    /// Entry lines: `t_min`, then one per axis (unused where the rays are
    /// parallel to it); exit lines, one per axis.
    entry: [(f64, f64); 4],
    exit: [(f64, f64); 3],
    /// Constraints on `s` from the axes the rays are parallel to.
    inside: Interval,
}

/// What every box test of a family shares, per axis: `1/d`, the slope
/// `-R/d` of its entry and exit lines, and for each pair of an entry line
/// and an exit line the difference of their slopes and its inverse.
#[derive(Clone, Copy, Default)]
struct SlabSlopes {
    inv: [f64; 3],
    slope: [f64; 3],
    parallel: [bool; 3],
    /// `[entry line][exit axis]`: (slope difference, its inverse).
    pairs: [[(f64, f64); 3]; 4],
}

impl SlabSlopes {
    fn new(f: &Family) -> SlabSlopes {
        let mut s = SlabSlopes::default();
        for a in 0..3 {
            s.parallel[a] = f.dir[a] == 0.0;
            if !s.parallel[a] {
                s.inv[a] = 1.0 / f.dir[a];
                s.slope[a] = -f.step[a] * s.inv[a];
            }
        }
        for i in 0..4 {
            let entry_slope = if i == 0 { 0.0 } else { s.slope[i - 1] };
            for j in 0..3 {
                let k = entry_slope - s.slope[j];
                s.pairs[i][j] = (k, if k == 0.0 { 0.0 } else { 1.0 / k });
            }
        }
        s
    }
}

impl Slabs {
    #[inline(always)]
    fn new(f: &Family, node: &Node) -> Slabs {
        let sl = &f.slopes;
        let mut s = Slabs {
            entry: [(f.t_min - f.pad, 0.0); 4],
            exit: [(0.0, 0.0); 3],
            inside: Interval::ALL,
        };
        for a in 0..3 {
            let (lo, hi) = (node.min[a] as f64 - f.pad, node.max[a] as f64 + f.pad);
            let (e, r) = (f.base[a], f.step[a]);
            if sl.parallel[a] {
                // lo <= e + r s <= hi
                s.inside.le(r, hi - e);
                s.inside.le(-r, e - lo);
                continue;
            }
            let inv = sl.inv[a];
            let (near, far) = if inv < 0.0 { (hi, lo) } else { (lo, hi) };
            s.entry[a + 1] = ((near - e) * inv, sl.slope[a]);
            s.exit[a] = ((far - e) * inv, sl.slope[a]);
        }
        s
    }

    /// The parameters of the rays that enter the box (conservatively).
    #[inline(always)]
    fn interval(&self, sl: &SlabSlopes) -> Interval {
        let mut iv = self.inside;
        for (i, &(a, _)) in self.entry.iter().enumerate() {
            if i > 0 && sl.parallel[i - 1] {
                continue;
            }
            for (j, &(c, _)) in self.exit.iter().enumerate() {
                if sl.parallel[j] {
                    continue;
                }
                // a + b s <= c + d s, that is (b - d) s <= c - a
                let (k, inv_k) = sl.pairs[i][j];
                iv.le_inv(k, inv_k, c - a);
            }
        }
        iv
    }

    /// The entry distance of the ray with parameter `s`.
    #[inline(always)]
    fn entry_at(&self, s: f64, sl: &SlabSlopes) -> f64 {
        let mut m = self.entry[0].0;
        for (a, &(c, b)) in self.entry[1..].iter().enumerate() {
            if !sl.parallel[a] {
                m = m.max(c + b * s);
            }
        }
        m
    }
}

impl Bvh {
    /// The nearest hit of every ray of `family` (`out[k]`: ray `k`'s primitive
    /// and hit, or `None`), in one descent of the binary tree: what each ray
    /// traced alone gets, bit for bit (see the module's notes).
    pub fn closest_strip<T: FamilyTest>(
        &self,
        family: &Family,
        test: &mut T,
        scratch: &mut StripScratch,
        stats: &mut StripStats,
        out: &mut Vec<Option<(u32, SurfaceHit)>>,
    ) {
        let n = family.s.len();
        out.clear();
        out.resize(n, None);
        if self.nodes.is_empty() || n == 0 {
            return;
        }
        stats.descents += 1;
        let enters = &mut scratch.enters;
        enters.clear();
        enters.resize(n, Entry::Unknown);
        let best = &mut scratch.best;
        best.clear();
        best.resize(
            n,
            LaneHit {
                best: f32::INFINITY,
                prim: u32::MAX,
                hit: NO_SURFACE,
            },
        );
        let stack = &mut scratch.stack;
        stack.clear();
        stack.push((0, 0, n as u32));
        let culled = |slabs: &Slabs, k: usize, best: &[LaneHit]| {
            let bound = best[k].best * CULL_SLACK;
            slabs.entry_at(family.s[k], &family.slopes) > bound as f64 + family.pad
        };
        while let Some((index, lo, hi)) = stack.pop() {
            let node = &self.nodes[index as usize];
            let slabs = Slabs::new(family, node);
            let iv = slabs.interval(&family.slopes);
            if iv.is_empty() {
                continue;
            }
            let (mut lo, mut hi) = family.indices(lo as usize, hi as usize, iv.lo, iv.hi);
            // Rays whose own nearest hit is nearer than the box leave it (at the
            // ends of the interval: the rays in between stay, which is safe).
            while lo < hi && culled(&slabs, lo, best) {
                lo += 1;
            }
            while lo < hi && culled(&slabs, hi - 1, best) {
                hi -= 1;
            }
            if lo == hi {
                continue;
            }
            stats.nodes += 1;
            if node.is_leaf() {
                let first = node.first as usize;
                enters[lo..hi].fill(Entry::Unknown);
                for &prim in &self.order[first..first + node.count() as usize] {
                    stats.covers += 1;
                    let (a, b) = match test.cover(prim, family) {
                        Cover::Miss => continue,
                        Cover::Interval(iv) => family.indices(lo, hi, iv.lo, iv.hi),
                        Cover::Unbounded => {
                            stats.unbounded += 1;
                            (lo, hi)
                        }
                    };
                    for (k, state) in best.iter_mut().enumerate().take(b).skip(a) {
                        // The single-ray descent's test of the leaf, with the
                        // ray's nearest hit from before the leaf.
                        if enters[k] == Entry::Unknown {
                            let (tn, tf) = family.rays[k].slabs(node);
                            let inside = tn <= tf && tn <= state.best * CULL_SLACK;
                            enters[k] = if inside { Entry::In } else { Entry::Out };
                        }
                        if enters[k] == Entry::Out {
                            continue;
                        }
                        stats.exact_tests += 1;
                        if let Some(h) = test.exact(prim, k) {
                            stats.exact_hits += 1;
                            state.offer(prim, h);
                        }
                    }
                }
                continue;
            }
            let (a, b) = (node.first, node.first + 1);
            let (near, far) = if family.dir[node.axis()].is_sign_negative() {
                (b, a)
            } else {
                (a, b)
            };
            stack.push((far, lo as u32, hi as u32));
            stack.push((near, lo as u32, hi as u32));
        }
        for (slot, state) in out.iter_mut().zip(best.iter()) {
            if state.prim != u32::MAX {
                *slot = Some((state.prim, state.hit));
            }
        }
    }
}

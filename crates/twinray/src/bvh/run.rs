//! Eye runs (issue 16, `--eye-runs`): the nearest hits of a family of
//! parallel eye rays found by tracing a few of them and proving the rest.
//!
//! Re-indexed by camera column (`render/strip.rs`), the views' eye rays
//! through one sample are a family: one direction `d`, origins `o_k` on the
//! camera line, ascending in the views' offsets. Take two rays `a < b` of it,
//! traced alone, that hit at distances `t_a`, `t_b` (or both miss, then `t_a
//! = t_b = T`, beyond the scene's bounds). Every ray `k` between them, with
//! `t_line(k)` the distance interpolated linearly in the offset, runs from
//! its origin to `o_k + t_line(k)·d` inside the planar quadrilateral `(o_a,
//! o_b, h_b, h_a)`, `h = o + t·d` (a trapezoid: its far side is the chord of
//! the two hits). A `RunRegion` is that quadrilateral lengthened past the
//! hits by `RUN_REACH·t + margin`, and `Bvh::run_is_free` proves, in one
//! descent with a separating-axis test of boxes against it (grown by the
//! margin), that no primitive but the hit one may meet it.
//!
//! Why that gives each ray between exactly its independent hit:
//!
//! * The independent traversal (the four-wide or the binary tree, one ray)
//!   returns the nearest of the hits `Shape::intersect` reports over all the
//!   primitives, ties to the lower index: its culling is conservative by
//!   `CULL_SLACK`, whose premise (`bvh/traverse.rs`) is that a hit reported at
//!   `t` has `t·CULL_SLACK` at least the ray's slab entry distance into the
//!   primitive's padded box; the leaf tests pass `best.next_up()` so that a
//!   tie reaches the index rule. That is the premise on which every method's
//!   hits are order-independent and equal to `--method independent`'s.
//! * A primitive box the lengthened region (grown by the margin, which bounds
//!   the rounding of the origins and of the slab test) does not meet is
//!   entered by ray `k`, if at all, beyond `t_line(k)·(1 + RUN_REACH) +
//!   margin`; by the premise its primitive's reported hit is then farther
//!   than `t_line(k)·(1 + FILL_REACH) + margin/2`.
//! * A primitive whose box does meet it is judged by the caller's leaf test
//!   (`render/strip.rs`): with the family's own bounds on what the
//!   single-ray routine may report (`triangle_cover`, `sphere_cover`: no ray
//!   between `a` and `b` gets a hit, or every hit it may get lies beyond that
//!   same distance), else it counts as met.
//! * The caller then computes ray `k`'s hit on the hit primitive `P` with
//!   `Shape::intersect`, the arithmetic of the traversal's own test, and keeps
//!   it only if it lies within `t_line(k)·(1 + FILL_REACH) + margin/2` and the
//!   ray's slab test of `P`'s box lets it in before it (so the traversal,
//!   whose boxes above `P` contain that box, tests `P`). Every other
//!   primitive reports no hit, or a farther one: `P`'s hit is the nearest,
//!   bit for bit what the ray traced alone gets. For a triangle the kept
//!   hit is the interpolation (its plane is cut by parallel rays at
//!   distances linear in the offset; a convex polygon holds the segment
//!   between two of its points); for a sphere seen from outside, in front of
//!   the chord (the ball holds the chord); anything else is traced.
//! * Both ends missing, the region reaches past the scene's bounds: no box
//!   it does not meet can be entered by a ray between, so none of them hits.
//!
//! Any doubt (a cone, a primitive the family's arithmetic cannot bound, a
//! stack deeper than expected) counts as met: the caller traces the middle
//! ray and tries both halves.

use super::traverse::{SingleRay, CULL_SLACK};
use super::{Bvh, Node};
use crate::math::{Aabb, Vec3};
use glam::DVec3;

/// How far past the chord of the two hits the region reaches, relative to
/// the distance: four times `CULL_SLACK - 1`, so that a primitive box it
/// does not meet is entered only beyond a kept hit, culling slack included.
pub const RUN_REACH: f64 = 1.0 / 1024.0;
/// How far past the chord a kept hit may lie, relative to the distance (with
/// half the margin): the rounding of the hit's distance, far below it.
pub const FILL_REACH: f64 = 1.0 / 4096.0;

/// Separating axes a region may have: its normal and four edges times the
/// three box axes.
const AXES: usize = 13;

/// The region that holds the segments of the rays between two rays of a
/// family, grown by `margin` (see the module's notes).
#[derive(Clone, Debug)]
pub struct RunRegion {
    /// `o_a`, `o_b`, far end of `b`, far end of `a`.
    corners: [DVec3; 4],
    lo: DVec3,
    hi: DVec3,
    /// The quadrilateral's normal and its edges crossed with the box's axes
    /// (unit vectors), and its extent along each.
    axes: [DVec3; AXES],
    spans: [(f64, f64); AXES],
    count: usize,
    /// The margin plus the slack of the f64 arithmetic here.
    grow: f64,
    pub margin: f64,
}

impl RunRegion {
    /// The region between the ray from `o_a` hitting at `t_a` and the ray
    /// from `o_b` hitting at `t_b`, both along `dir` (unit), lengthened and
    /// grown as the module's notes say; `None` for non-finite input.
    pub fn new(o_a: Vec3, o_b: Vec3, dir: Vec3, t_a: f64, t_b: f64, margin: f64) -> Option<Self> {
        let (a, b, d) = (o_a.as_dvec3(), o_b.as_dvec3(), dir.as_dvec3());
        let reach = |t: f64| t * (1.0 + RUN_REACH) + margin;
        let corners = [a, b, b + d * reach(t_b), a + d * reach(t_a)];
        // Two sides are parallel (`d`): three edge directions.
        let far_side = corners[3] - corners[2];
        RunRegion::from_corners(corners, &[b - a, d, far_side], (b - a).cross(d), margin)
    }

    /// The planar quadrilateral `corners` (in order round it), grown by
    /// `margin`: any four points, for regions whose rays are not parallel
    /// (the key views of `render/view_synthesis.rs`); `None` for non-finite
    /// input.
    pub fn quad(corners: [Vec3; 4], margin: f64) -> Option<Self> {
        let c = corners.map(|p| p.as_dvec3());
        let edges = [c[1] - c[0], c[2] - c[1], c[3] - c[2], c[0] - c[3]];
        // The larger of the two triangles' normals: the other may be degenerate.
        let n1 = (c[1] - c[0]).cross(c[3] - c[0]);
        let n2 = (c[2] - c[1]).cross(c[3] - c[1]);
        let normal = if n1.length_squared() >= n2.length_squared() {
            n1
        } else {
            n2
        };
        RunRegion::from_corners(c, &edges, normal, margin)
    }

    /// The region with these corners, tested on the axes of the boxes, the
    /// normal, and each edge direction crossed with the boxes' axes. Any
    /// axis is a valid separating test (the spans are the corners' own), so
    /// the region is the corners' convex hull whatever their order.
    fn from_corners(
        corners: [DVec3; 4],
        edges: &[DVec3],
        normal: DVec3,
        margin: f64,
    ) -> Option<Self> {
        if !corners.iter().all(|c| c.is_finite()) || margin.is_nan() || margin < 0.0 {
            return None;
        }
        let lo = corners.iter().fold(corners[0], |m, c| m.min(*c));
        let hi = corners.iter().fold(corners[0], |m, c| m.max(*c));
        let scale = lo.abs().max(hi.abs()).max_element().max(1e-6);
        let mut region = RunRegion {
            corners,
            lo,
            hi,
            axes: [DVec3::ZERO; AXES],
            spans: [(0.0, 0.0); AXES],
            count: 0,
            grow: margin + scale * 1e-9,
            margin,
        };
        region.add_axis(normal);
        for &e in edges {
            for axis in [DVec3::X, DVec3::Y, DVec3::Z] {
                region.add_axis(e.cross(axis));
            }
        }
        Some(region)
    }

    /// The corners, in the order given.
    pub fn corners(&self) -> [DVec3; 4] {
        self.corners
    }

    fn add_axis(&mut self, axis: DVec3) {
        if self.count == AXES {
            return;
        }
        let len = axis.length();
        if len.is_nan() || len <= 1e-12 * (1.0 + axis.abs().max_element()) {
            return;
        }
        let axis = axis / len;
        let p = self.corners.map(|c| axis.dot(c));
        let span = (
            p[0].min(p[1]).min(p[2]).min(p[3]),
            p[0].max(p[1]).max(p[2]).max(p[3]),
        );
        self.axes[self.count] = axis;
        self.spans[self.count] = span;
        self.count += 1;
    }

    /// Whether the region, grown by the margin, may meet box `b` (separating
    /// axes: the box's, the quadrilateral's normal, its edges × the box's).
    pub fn may_meet_box(&self, b: &Aabb) -> bool {
        let (min, max) = (b.min.as_dvec3(), b.max.as_dvec3());
        let g = self.grow;
        if (min - self.hi).max_element() > g || (self.lo - max).max_element() > g {
            return false;
        }
        let centre = (min + max) * 0.5;
        let half = (max - min) * 0.5;
        for (axis, &(lo, hi)) in self.axes[..self.count].iter().zip(&self.spans) {
            let p = axis.dot(centre);
            let r = half.dot(axis.abs()) + g;
            if p - r > hi || p + r < lo {
                return false;
            }
        }
        true
    }
}

/// Whether ray `origin + t·dir` enters box `b` by the single-ray descent's
/// slab test (its arithmetic, `t > t_min`) no later than `t·CULL_SLACK`: then
/// the descent, whose boxes above a primitive contain its box, tests the
/// primitive for that ray whatever nearer hit it holds (none nearer than `t`).
pub fn ray_reaches(b: &Aabb, origin: Vec3, dir: Vec3, t_min: f32, t: f32) -> bool {
    let ray = SingleRay::new(origin, dir, t_min);
    let node = Node {
        min: b.min.into(),
        first: 0,
        max: b.max.into(),
        meta: 0,
    };
    let (tn, tf) = ray.slabs(&node);
    tn <= tf && tn <= t * CULL_SLACK
}

/// What eye runs did, for statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, derive_more::AddAssign)]
pub struct RunStats {
    /// Families (a camera column's views through one sample).
    pub families: u64,
    /// Rays traced alone (the ends, the middles of subdivided runs, and
    /// those whose kept-hit check failed).
    pub traced: u64,
    /// Rays given their hit (or miss) by a proof.
    pub filled: u64,
    /// Rays of a proved run whose own test of the primitive did not give a
    /// hit within the region (rounding at an edge): traced.
    pub fill_refused: u64,
    /// Region proofs tried, and those that found something (subdivided).
    pub proofs: u64,
    pub proofs_failed: u64,
    /// Nodes and primitives the proofs visited.
    pub proof_nodes: u64,
    pub proof_prims: u64,
}

/// Stack entries of a proof's descent; a deeper tree counts as met.
const STACK: usize = 128;

impl Bvh {
    /// Whether no primitive but `except` may meet `region`: one descent of
    /// the binary nodes whose boxes the region may meet; at the leaves,
    /// `may_meet(prim)` judges each other primitive (it must be
    /// conservative: `false` only where proved, see the module's notes).
    pub fn run_is_free(
        &self,
        region: &RunRegion,
        except: u32,
        stats: &mut RunStats,
        mut may_meet: impl FnMut(u32) -> bool,
    ) -> bool {
        self.visit_region(region, except, stats, |prim| !may_meet(prim))
    }

    /// Gives `visit` every primitive but `except` of the leaves whose boxes
    /// the region may meet, until it returns `false`. Returns whether every
    /// such primitive was visited (`false` too where the tree is deeper than
    /// the descent's stack: then some were not).
    pub fn visit_region(
        &self,
        region: &RunRegion,
        except: u32,
        stats: &mut RunStats,
        mut visit: impl FnMut(u32) -> bool,
    ) -> bool {
        let Some(root) = self.nodes.first() else {
            return true;
        };
        if !region.may_meet_box(&root.bounds()) {
            return true;
        }
        let mut stack = [0u32; STACK];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top] as usize];
            stats.proof_nodes += 1;
            if node.is_leaf() {
                let first = node.first as usize;
                for &prim in &self.order[first..first + node.count() as usize] {
                    if prim == except || prim == super::PAD {
                        continue;
                    }
                    stats.proof_prims += 1;
                    if !visit(prim) {
                        return false;
                    }
                }
                continue;
            }
            for child in [node.first, node.first + 1] {
                if region.may_meet_box(&self.nodes[child as usize].bounds()) {
                    if top == STACK {
                        return false;
                    }
                    stack[top] = child;
                    top += 1;
                }
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_box(at: Vec3) -> Aabb {
        Aabb {
            min: at - Vec3::splat(0.5),
            max: at + Vec3::splat(0.5),
        }
    }

    /// A region from x = 0..4 on the camera line toward +z, hitting at 10:
    /// boxes inside, beside, behind, and just past its far side.
    #[test]
    fn region_meets_the_boxes_it_should() {
        let r = RunRegion::new(
            Vec3::ZERO,
            Vec3::new(4.0, 0.0, 0.0),
            Vec3::Z,
            10.0,
            10.0,
            1e-4,
        )
        .expect("finite");
        assert!(r.may_meet_box(&unit_box(Vec3::new(2.0, 0.0, 5.0))));
        // Beside (x beyond 4.5), above (y beyond 0.5): not met.
        assert!(!r.may_meet_box(&unit_box(Vec3::new(4.6, 0.0, 5.0))));
        assert!(!r.may_meet_box(&unit_box(Vec3::new(2.0, 0.6, 5.0))));
        // Behind the hits, beyond the reach: not met; within it: met.
        assert!(!r.may_meet_box(&unit_box(Vec3::new(2.0, 0.0, 10.52))));
        assert!(r.may_meet_box(&unit_box(Vec3::new(2.0, 0.0, 10.505))));
        // A slanted far side (hits at 2 and 10): a box behind the chord's
        // middle (z 6) but in front of its deep end is missed by a box test
        // on the region's bounding box alone, not by the edge axes.
        let s = RunRegion::new(
            Vec3::ZERO,
            Vec3::new(4.0, 0.0, 0.0),
            Vec3::Z,
            2.0,
            10.0,
            1e-4,
        )
        .expect("finite");
        assert!(!s.may_meet_box(&Aabb {
            min: Vec3::new(0.0, -0.1, 7.0),
            max: Vec3::new(1.0, 0.1, 8.0),
        }));
        assert!(s.may_meet_box(&Aabb {
            min: Vec3::new(3.0, -0.1, 7.0),
            max: Vec3::new(4.0, 0.1, 8.0),
        }));
    }

    /// The single-ray slab test of a box: in front of the hit, not behind.
    #[test]
    fn ray_reaches_a_box_before_its_hit() {
        let b = unit_box(Vec3::new(0.0, 0.0, 5.0));
        assert!(ray_reaches(&b, Vec3::ZERO, Vec3::Z, 0.0, 4.5));
        assert!(!ray_reaches(&b, Vec3::ZERO, Vec3::Z, 0.0, 4.4));
        assert!(!ray_reaches(
            &b,
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::Z,
            0.0,
            9.0
        ));
    }
}

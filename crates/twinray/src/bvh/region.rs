//! A region of space as a planar quadrilateral, and the primitives whose
//! boxes it may meet, in one descent (`Bvh::visit_region`): the epipolar
//! rows of the fast method gather a row's primitives with it
//! (`render/fast/epipolar`). The box test is a separating-axis test, grown
//! by a margin that bounds the rounding of the region's corners, so a box
//! it refuses cannot be met.

use super::Bvh;
use crate::math::{Aabb, Vec3};
use glam::DVec3;

/// Separating axes a region may have: its normal and its four edges'
/// normals within its plane.
const AXES: usize = 5;

/// A planar quadrilateral grown by `margin`.
#[derive(Clone, Debug)]
pub struct Region {
    /// The corners, in order round the quadrilateral.
    corners: [DVec3; 4],
    lo: DVec3,
    hi: DVec3,
    /// The quadrilateral's normal and its edges' normals within its plane
    /// (unit vectors), and its extent along each.
    axes: [DVec3; AXES],
    spans: [(f64, f64); AXES],
    count: usize,
    /// The margin plus the slack of the f64 arithmetic here.
    grow: f64,
}

impl Region {
    /// The planar quadrilateral `corners` (in order round it), grown by
    /// `margin`; `None` for non-finite input.
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
        Region::from_corners(c, &edges, normal, margin)
    }

    /// The region with these corners, tested on the axes of the boxes, the
    /// normal, and each edge's normal within the plane. Any
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
        let mut region = Region {
            corners,
            lo,
            hi,
            axes: [DVec3::ZERO; AXES],
            spans: [(0.0, 0.0); AXES],
            count: 0,
            grow: margin + scale * 1e-9,
        };
        region.add_axis(normal);
        for &e in edges {
            region.add_axis(normal.cross(e));
        }
        Some(region)
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
    /// axes: the box's, the quadrilateral's normal, its edges' normals in its
    /// plane).
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

/// Stack entries of the descent; a deeper tree is not visited whole.
const STACK: usize = 128;

impl Bvh {
    /// Gives `visit` every primitive of the leaves whose boxes the region
    /// may meet (a primitive filed under several leaves once per leaf),
    /// until it returns `false`. Returns whether every such primitive was
    /// visited (`false` too where the tree is deeper than the descent's
    /// stack: then some were not).
    pub fn visit_region(&self, region: &Region, mut visit: impl FnMut(u32) -> bool) -> bool {
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
            if node.is_leaf() {
                let first = node.first as usize;
                for &prim in &self.order[first..first + node.count() as usize] {
                    if prim == super::PAD {
                        continue;
                    }
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

    /// A quadrilateral from x = 0..4 on the x axis toward +z, its far side at
    /// z 2 (left) and 10 (right): boxes inside, beside, above, beyond it, and
    /// behind the slanted far side's shallow end, which a test on the
    /// region's bounding box alone would not see apart.
    #[test]
    fn a_region_meets_the_boxes_it_should() {
        let corners = [
            Vec3::ZERO,
            Vec3::new(4.0, 0.0, 0.0),
            Vec3::new(4.0, 0.0, 10.0),
            Vec3::new(0.0, 0.0, 2.0),
        ];
        let r = Region::quad(corners, 1e-4).expect("finite");
        assert!(r.may_meet_box(&unit_box(Vec3::new(2.0, 0.0, 3.0))));
        assert!(!r.may_meet_box(&unit_box(Vec3::new(4.6, 0.0, 5.0))));
        assert!(!r.may_meet_box(&unit_box(Vec3::new(2.0, 0.6, 5.0))));
        assert!(!r.may_meet_box(&unit_box(Vec3::new(2.0, 0.0, 10.6))));
        assert!(!r.may_meet_box(&Aabb {
            min: Vec3::new(0.0, -0.1, 7.0),
            max: Vec3::new(1.0, 0.1, 8.0),
        }));
        assert!(r.may_meet_box(&Aabb {
            min: Vec3::new(3.0, -0.1, 7.0),
            max: Vec3::new(4.0, 0.1, 8.0),
        }));
        assert!(Region::quad([Vec3::splat(f32::NAN); 4], 1e-4).is_none());
    }
}

//! The paper's section 2.3, cuts in the object tree: objects entirely
//! beyond a depth are not twinned. The world builds them into a hierarchy of
//! their own (`World::with_cut`); the twin method's rows see them as the
//! rig's centre does (`render/twin/cut.rs`); the plan places the cut, at a
//! depth or at a disparity error in pixels (`job/plan.rs`,
//! `Rig::cut_depth_for_parallax`).

use crate::math::{Aabb, Vec3};

/// The paper's section 2.3: objects farther than `depth` along the camera's
/// view direction from the rig's centre `eye` are not twinned.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cut {
    pub eye: Vec3,
    /// Unit view direction.
    pub forward: Vec3,
    pub depth: f32,
}

impl Cut {
    /// A cut `depth` in front of `eye` (the rig's centre) along `forward`
    /// (the camera's unit view direction).
    pub fn at_depth(eye: Vec3, forward: Vec3, depth: f32) -> Cut {
        Cut {
            eye,
            forward,
            depth,
        }
    }

    /// Whether all of box `b` lies at a depth of at least `self.depth`.
    pub fn beyond(&self, b: &Aabb) -> bool {
        if b.is_empty() {
            return false;
        }
        let (lo, hi) = (b.min - self.eye, b.max - self.eye);
        let f = self.forward;
        let nearest = (lo.x * f.x).min(hi.x * f.x)
            + (lo.y * f.y).min(hi.y * f.y)
            + (lo.z * f.z).min(hi.z * f.z);
        nearest >= self.depth
    }
}

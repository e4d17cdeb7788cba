//! Stereo window violations and the floating window that cures them.
//!
//! The frame of the screen is a window the viewer looks through. An object in
//! front of it (negative parallax) that the frame's edge cuts is seen by one
//! eye only near that edge: the brain is told "in front" by the disparity and
//! "behind the frame" by the occlusion, a *window violation*. At the left edge
//! it is the left view that shows what the right view does not (the right
//! view's image of the point lies left of its frame); at the right edge the
//! right view.
//!
//! A sample of the leftmost view at column `x` whose point has disparity
//! `p < 0` towards the rightmost view is a violation when its image there,
//! `x + p`, lies off the frame (`< −0.5`); likewise a sample of the rightmost
//! view when `x − p` lies beyond the right edge. The disparity used is the
//! outer views' (for a pair, the pair's), the largest in the set.
//!
//! The cure stereographers use is a *floating window*: black masks on the left
//! edge of the left view and the right edge of the right view move the frame's
//! edges in front of the screen, by the masks' widths in pixels of disparity.
//! Masks as wide as the violating disparity put the window's edge at the
//! object's depth. With N views, view `v` gets the left mask scaled by
//! `(N − 1 − v)/(N − 1)` and the right one by `v/(N − 1)`, so that adjacent
//! views see the window's edges with the same disparity.

use serde::Serialize;

use super::depth_pass::DepthPass;
use super::{pair_disparity, Camera, Rig};

/// A frame edge.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Edge {
    Left,
    Right,
}

impl Edge {
    pub fn name(self) -> &'static str {
        match self {
            Edge::Left => "left",
            Edge::Right => "right",
        }
    }
}

/// Objects in front of the screen cut by one edge of the frame.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct WindowViolation {
    pub edge: Edge,
    /// The view in which the monocular part shows (0 at the left edge, the
    /// last view at the right edge).
    pub view: usize,
    /// The image rows of the violating samples (inclusive), top first.
    pub first_row: u32,
    pub last_row: u32,
    /// How many samples of the depth pass violate.
    pub samples: usize,
    /// The nearest of their depths.
    pub nearest_depth: f32,
    /// The most negative outer-view disparity among them, in pixels.
    pub disparity_px: f64,
    /// Columns a floating window masks at this edge of that view.
    pub mask_px: u32,
}

/// Finds the window violations in the depth passes of a rig's outer views:
/// `left` of `rig.views[0]`, `right` of the last view.
pub fn find_violations(
    camera: &Camera,
    rig: &Rig,
    left: &DepthPass,
    right: &DepthPass,
) -> Vec<WindowViolation> {
    let (Some(&first), Some(&last)) = (rig.views.first(), rig.views.last()) else {
        return Vec::new();
    };
    if rig.views.len() < 2 {
        return Vec::new();
    }
    let width = f64::from(camera.width);
    let mut out = Vec::new();
    for (edge, pass, view) in [
        (Edge::Left, left, 0),
        (Edge::Right, right, rig.views.len() - 1),
    ] {
        let mut found: Option<WindowViolation> = None;
        for (x, y, z) in pass.samples() {
            if !z.is_finite() {
                continue;
            }
            let p = pair_disparity(camera, first, last, f64::from(z));
            if p >= 0.0 {
                continue;
            }
            // Where the point lies in the other outer view.
            let elsewhere = match edge {
                Edge::Left => f64::from(x) + p,
                Edge::Right => f64::from(x) - p,
            };
            let off_frame = elsewhere < -0.5 || elsewhere > width - 0.5;
            if !off_frame {
                continue;
            }
            let v = found.get_or_insert(WindowViolation {
                edge,
                view,
                first_row: y,
                last_row: y,
                samples: 0,
                nearest_depth: z,
                disparity_px: p,
                mask_px: 0,
            });
            v.first_row = v.first_row.min(y);
            v.last_row = v.last_row.max(y);
            v.samples += 1;
            v.nearest_depth = v.nearest_depth.min(z);
            v.disparity_px = v.disparity_px.min(p);
        }
        if let Some(mut v) = found {
            v.mask_px = ((-v.disparity_px).ceil() as u32).clamp(1, camera.width);
            out.push(v);
        }
    }
    out
}

/// The masks of a floating window, in pixels of the outer views.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct FloatingWindow {
    /// Columns masked at the left edge of the leftmost view.
    pub left_px: u32,
    /// Columns masked at the right edge of the rightmost view.
    pub right_px: u32,
}

impl FloatingWindow {
    /// The masks that cure `violations` (none where there is none).
    pub fn for_violations(violations: &[WindowViolation]) -> FloatingWindow {
        let mut w = FloatingWindow::default();
        for v in violations {
            match v.edge {
                Edge::Left => w.left_px = w.left_px.max(v.mask_px),
                Edge::Right => w.right_px = w.right_px.max(v.mask_px),
            }
        }
        w
    }

    pub fn is_empty(&self) -> bool {
        self.left_px == 0 && self.right_px == 0
    }

    /// Columns masked at the (left, right) edges of view `view` of `views`.
    pub fn masks(&self, view: usize, views: usize) -> (u32, u32) {
        if views < 2 {
            return (0, 0);
        }
        let gaps = (views - 1) as f64;
        let scale = |px: u32, share: usize| (f64::from(px) * share as f64 / gaps).round() as u32;
        (
            scale(self.left_px, views - 1 - view.min(views - 1)),
            scale(self.right_px, view.min(views - 1)),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn masks_share_the_window_between_the_views() {
        let w = FloatingWindow {
            left_px: 12,
            right_px: 6,
        };
        assert_eq!(w.masks(0, 2), (12, 0));
        assert_eq!(w.masks(1, 2), (0, 6));
        assert_eq!(w.masks(0, 4), (12, 0));
        assert_eq!(w.masks(1, 4), (8, 2));
        assert_eq!(w.masks(2, 4), (4, 4));
        assert_eq!(w.masks(3, 4), (0, 6));
        assert_eq!(w.masks(0, 1), (0, 0));
        assert!(FloatingWindow::default().is_empty());
    }
}

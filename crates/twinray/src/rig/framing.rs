//! Framing a scene that has no camera: the viewpoint's direction kept, its
//! distance chosen so that the scene's bounding box, seen from there, fills
//! a given share of the image (80 % by default: the share of the shorter
//! side for a model that is about as wide as tall).
//!
//! The loader frames a file without a camera before the image size is known
//! (`Scene::frame_bounds`, a bounding sphere in a 45° field of view: often
//! 7–23 % of the frame); the job fits the distance here once the size is
//! known.

use crate::math::{Aabb, Vec3};
use crate::scene::{AngleSpan, Viewpoint};

/// Share of the image the bounding box fills in its tighter direction.
pub const FILL: f32 = 0.8;

/// `vp` moved so that the corners of every box of `boxes` (the scene's
/// shapes' bounds: tight for triangles) project within `fill` of the image
/// (a `width`×`height` image, `vp`'s vertical field of view): the direction
/// of view is kept, the camera slides across it to centre the projection
/// (perspective makes the near side loom larger) and along it to fit.
/// `vp` unchanged for no finite box.
pub fn fit_bounds(
    vp: &Viewpoint,
    boxes: impl IntoIterator<Item = Aabb> + Clone,
    width: u32,
    height: u32,
    fill: f32,
) -> Viewpoint {
    let back = (vp.from - vp.at).normalize_or_zero();
    if width == 0 || height == 0 || back == Vec3::ZERO {
        return vp.clone();
    }
    let right = vp.up.cross(back).normalize_or_zero();
    let right = if right == Vec3::ZERO {
        back.any_orthonormal_vector()
    } else {
        right
    };
    let up = back.cross(right);
    // Half the image at unit distance, vertically and horizontally.
    let half_v = match vp.angle_span {
        AngleSpan::ImageHeight => (vp.angle_deg.to_radians() * 0.5).tan(),
        // NFF's angle spans the shorter side's edge pixels' centres: near enough.
        AngleSpan::EdgePixelCentres => {
            (vp.angle_deg.to_radians() * 0.5).tan() * height as f32 / width.min(height) as f32
        }
    };
    let half_h = half_v * width as f32 / height as f32;
    let frame = Frame {
        back,
        right,
        up,
        kh: half_h * fill,
        kv: half_v * fill,
    };
    let mut at = vp.at;
    let mut fitted = None;
    // Fit, centre, fit again: each pass halves what is left off centre.
    for _ in 0..4 {
        let Some(fit) = frame.fit(at, boxes.clone()) else {
            break;
        };
        at += (right * fit.centre_h + up * fit.centre_v) * fit.distance;
        fitted = frame.fit(at, boxes.clone());
    }
    let Some(fit) = fitted else {
        return vp.clone();
    };
    Viewpoint {
        from: at + back * fit.distance,
        at,
        hither: (fit.nearest * 1e-3).max(fit.distance * 1e-5),
        ..vp.clone()
    }
}

/// The view's axes and the slopes the image allows.
struct Frame {
    back: Vec3,
    right: Vec3,
    up: Vec3,
    kh: f32,
    kv: f32,
}

/// A distance that fits, and where the projection's centre lies (slopes).
struct Fit {
    distance: f32,
    nearest: f32,
    centre_h: f32,
    centre_v: f32,
}

/// The eight corners of `b`.
pub(crate) fn box_corners(b: Aabb) -> impl Iterator<Item = Vec3> {
    (0..8).map(move |i| {
        Vec3::new(
            if i & 1 == 0 { b.min.x } else { b.max.x },
            if i & 2 == 0 { b.min.y } else { b.max.y },
            if i & 4 == 0 { b.min.z } else { b.max.z },
        )
    })
}

impl Frame {
    fn fit(&self, at: Vec3, boxes: impl IntoIterator<Item = Aabb> + Clone) -> Option<Fit> {
        let finite = |b: &Aabb| b.min.is_finite() && b.max.is_finite() && b.min.x <= b.max.x;
        let points = || {
            boxes
                .clone()
                .into_iter()
                .filter(finite)
                .flat_map(box_corners)
                .map(move |p| p - at)
        };
        // A corner's depth is distance − corner·back; it must be at least
        // its offset across the view over the allowed slope.
        let mut distance: f32 = 0.0;
        let mut toward_max = f32::NEG_INFINITY;
        for c in points() {
            let toward = c.dot(self.back);
            toward_max = toward_max.max(toward);
            distance = distance
                .max(toward + c.dot(self.right).abs() / self.kh)
                .max(toward + c.dot(self.up).abs() / self.kv);
        }
        if !(distance.is_finite() && distance > 0.0) {
            return None;
        }
        let (mut h, mut v) = ((f32::MAX, f32::MIN), (f32::MAX, f32::MIN));
        for c in points() {
            let depth = distance - c.dot(self.back);
            let (sh, sv) = (c.dot(self.right) / depth, c.dot(self.up) / depth);
            h = (h.0.min(sh), h.1.max(sh));
            v = (v.0.min(sv), v.1.max(sv));
        }
        Some(Fit {
            distance,
            nearest: distance - toward_max,
            centre_h: (h.0 + h.1) * 0.5,
            centre_v: (v.0 + v.1) * 0.5,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn front(angle: f32) -> Viewpoint {
        Viewpoint {
            from: Vec3::new(0.0, 0.0, 50.0),
            at: Vec3::ZERO,
            up: Vec3::Y,
            angle_deg: angle,
            angle_span: AngleSpan::ImageHeight,
            hither: 0.0,
            width: 100,
            height: 100,
        }
    }

    /// The largest |x|/z and |y|/z of the box's corners seen from `vp`.
    fn slopes(vp: &Viewpoint, b: Aabb) -> (f32, f32) {
        let mut s: (f32, f32) = (0.0, 0.0);
        for x in [b.min.x, b.max.x] {
            for y in [b.min.y, b.max.y] {
                for z in [b.min.z, b.max.z] {
                    let depth = vp.from.z - z;
                    s.0 = s.0.max(x.abs() / depth);
                    s.1 = s.1.max(y.abs() / depth);
                }
            }
        }
        s
    }

    #[test]
    fn a_flat_square_fills_eighty_percent_of_a_square_image() {
        let b = Aabb {
            min: Vec3::new(-1.0, -1.0, 0.0),
            max: Vec3::new(1.0, 1.0, 0.0),
        };
        let vp = fit_bounds(&front(90.0), [b], 100, 100, FILL);
        // tan 45° = 1: the square's half side over the distance is 0.8.
        assert!((vp.from.z - 1.25).abs() < 1e-5, "{}", vp.from.z);
        assert!(vp.at.length() < 1e-6, "{}", vp.at);
    }

    #[test]
    fn the_tighter_direction_decides_and_depth_counts() {
        let b = Aabb {
            min: Vec3::new(-4.0, -1.0, -1.0),
            max: Vec3::new(4.0, 1.0, 1.0),
        };
        let vp = fit_bounds(&front(40.0), [b], 200, 100, FILL);
        let half_v = (20.0f32).to_radians().tan();
        let (sx, sy) = slopes(&vp, b);
        // Wide box in a 2:1 image: the width is the limit, exactly 80 %
        // (the box is symmetric about the line of sight).
        assert!((sx - 2.0 * half_v * FILL).abs() < 1e-4, "{sx}");
        assert!(sy < half_v * FILL);
    }
}

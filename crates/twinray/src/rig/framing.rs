//! Framing a scene that has no camera: the viewpoint's direction kept, its
//! distance chosen so that the scene's bounding box, seen from there, fills
//! a given share of the image (80 % by default: the share of the shorter
//! side for a model that is about as wide as tall).
//!
//! The loader frames a file without a camera before the image size is known
//! (`Scene::frame_bounds`, a bounding sphere in a 45° field of view: often
//! 7–23 % of the frame); the job fits the distance here once the size is
//! known.

use rayon::prelude::*;

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
    boxes: impl IntoIterator<Item = Aabb>,
    width: u32,
    height: u32,
    fill: f32,
) -> Viewpoint {
    // The finite boxes once (a model's shapes compute theirs on each call);
    // each fit below reads them twice.
    let finite = |b: &Aabb| b.min.is_finite() && b.max.is_finite() && b.min.x <= b.max.x;
    let boxes: Vec<Aabb> = boxes.into_iter().filter(finite).collect();
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
        let Some(fit) = frame.fit(at, &boxes) else {
            break;
        };
        at += (right * fit.centre_h + up * fit.centre_v) * fit.distance;
        fitted = frame.fit(at, &boxes);
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

/// The corners of `boxes` relative to `at`.
fn corners_from(boxes: &[Aabb], at: Vec3) -> impl Iterator<Item = Vec3> + '_ {
    boxes
        .iter()
        .flat_map(move |&b| box_corners(b).map(move |p| p - at))
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
    /// The distance that fits every corner of `boxes` (finite) around `at`,
    /// and the centre of their projection from there. Each pass is a maximum
    /// or minimum over the corners, reduced on the thread pool: the same
    /// floats in any order (a million-triangle model has eight million).
    fn fit(&self, at: Vec3, boxes: &[Aabb]) -> Option<Fit> {
        const CHUNK: usize = 4096;
        let corners = |chunk| corners_from(chunk, at);
        // A corner's depth is distance − corner·back; it must be at least
        // its offset across the view over the allowed slope.
        let (distance, toward_max) = boxes
            .par_chunks(CHUNK)
            .map(|chunk| {
                let mut distance: f32 = 0.0;
                let mut toward_max = f32::NEG_INFINITY;
                for c in corners(chunk) {
                    let toward = c.dot(self.back);
                    toward_max = toward_max.max(toward);
                    distance = distance
                        .max(toward + c.dot(self.right).abs() / self.kh)
                        .max(toward + c.dot(self.up).abs() / self.kv);
                }
                (distance, toward_max)
            })
            .reduce(
                || (0.0, f32::NEG_INFINITY),
                |a, b| (a.0.max(b.0), a.1.max(b.1)),
            );
        if !(distance.is_finite() && distance > 0.0) {
            return None;
        }
        let none = ((f32::MAX, f32::MIN), (f32::MAX, f32::MIN));
        let (h, v) = boxes
            .par_chunks(CHUNK)
            .map(|chunk| {
                let (mut h, mut v) = none;
                for c in corners(chunk) {
                    let depth = distance - c.dot(self.back);
                    let (sh, sv) = (c.dot(self.right) / depth, c.dot(self.up) / depth);
                    h = (h.0.min(sh), h.1.max(sh));
                    v = (v.0.min(sv), v.1.max(sv));
                }
                (h, v)
            })
            .reduce(
                || none,
                |a, b| {
                    (
                        (a.0 .0.min(b.0 .0), a.0 .1.max(b.0 .1)),
                        (a.1 .0.min(b.1 .0), a.1 .1.max(b.1 .1)),
                    )
                },
            );
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

    /// Many boxes (more than one chunk of the parallel reduction), the one
    /// that decides the frame last: it is seen, the frame is the same on one
    /// thread and on three, and a box that is not finite is left out.
    #[test]
    fn many_boxes_frame_alike_on_any_number_of_threads() {
        let mut rng = fastrand::Rng::with_seed(7);
        let mut boxes: Vec<Aabb> = (0..20_000)
            .map(|_| {
                let c = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 2.0 - 1.0;
                Aabb {
                    min: c - 0.01,
                    max: c + 0.01,
                }
            })
            .collect();
        boxes.push(Aabb {
            min: Vec3::new(f32::NEG_INFINITY, 0.0, 0.0),
            max: Vec3::ZERO,
        });
        let far = Aabb {
            min: Vec3::new(5.0, -0.5, -0.5),
            max: Vec3::new(6.0, 0.5, 0.5),
        };
        boxes.push(far);
        let frame = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("a thread pool");
            pool.install(|| fit_bounds(&front(60.0), boxes.clone(), 100, 100, FILL))
        };
        let (one, three) = (frame(1), frame(3));
        assert_eq!(
            (one.from.to_array(), one.at.to_array(), one.hither.to_bits()),
            (
                three.from.to_array(),
                three.at.to_array(),
                three.hither.to_bits()
            )
        );
        // Every corner within the frame, and the far box at its edge: the
        // largest slope across is 80 % of the half field of view.
        let half = (30.0f32).to_radians().tan();
        let across = |vp: &Viewpoint, b: Aabb| {
            box_corners(b)
                .map(|p| {
                    let c = p - vp.from;
                    let back = (vp.from - vp.at).normalize();
                    let right = vp.up.cross(back).normalize();
                    (c.dot(right) / -c.dot(back)).abs()
                })
                .fold(0.0f32, f32::max)
        };
        let widest = boxes[..20_000]
            .iter()
            .map(|&b| across(&one, b))
            .fold(across(&one, far), f32::max);
        assert!((widest - half * FILL).abs() < 1e-3, "{widest}");
        assert!(across(&one, far) >= widest - 1e-6, "the far box decides");
    }
}

//! The view rig: a list of views on the camera's right axis.
//!
//! Mono is one view; stereo is two (left at `-interaxial/2`, right at
//! `+interaxial/2`); a
//! multi-view display takes N. Every view has parallel lens axes; convergence
//! is a horizontal image translation by a whole number of pixels, so pixel
//! `x` of view `v` sees along camera column `x + shift`: pixels of different
//! views with equal camera columns see along parallel rays.

pub mod budget;
pub mod camera;
pub mod camera_overrides;
pub mod choice;
pub mod depth_pass;
pub mod framing;
pub mod histogram;
pub mod panorama_rig;
pub mod projection;
pub mod report;
pub mod up_axis;
pub mod window;

pub use camera::Camera;
pub use camera_overrides::CameraOverrides;
pub use projection::{PoleMerge, Projection, ProjectionName};

use crate::{Error, Result};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    /// Displacement of the eye along the camera's right axis, in scene units.
    pub offset: f32,
    /// Camera column seen by image column 0.
    pub shift: i32,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Rig {
    pub views: Vec<View>,
    /// Convergence asked for (`None` = infinity, parallel cameras).
    pub convergence: Option<f64>,
    /// The zero-parallax distance the whole-pixel shifts give between the outer views.
    pub effective_convergence: Option<f64>,
}

impl Rig {
    /// The views as (index, offset, shift), by ascending offset: their order
    /// along the camera line, which the row passes of many views walk.
    pub fn views_by_offset(&self) -> Vec<(usize, f32, i32)> {
        let mut order: Vec<(usize, f32, i32)> = self
            .views
            .iter()
            .enumerate()
            .map(|(v, view)| (v, view.offset, view.shift))
            .collect();
        order.sort_by(|a, b| a.1.total_cmp(&b.1));
        order
    }

    pub fn mono() -> Rig {
        Rig {
            views: vec![View {
                offset: 0.0,
                shift: 0,
            }],
            convergence: None,
            effective_convergence: None,
        }
    }

    /// Two eyes `interaxial` apart, converging at `convergence` (None = infinity).
    /// Fails like [`Rig::multi_view`].
    pub fn stereo(camera: &Camera, interaxial: f32, convergence: Option<f64>) -> Result<Rig> {
        Rig::multi_view(camera, 2, interaxial, convergence)
    }

    /// `count` views, `interaxial` apart (between neighbours), centred on the camera, left to right.
    /// The shift of each view is rounded to whole pixels (relative to the leftmost
    /// view), then the set is centred: points at the convergence distance land on
    /// the same pixel in every view, up to the rounding, which is reported as the
    /// effective convergence distance.
    ///
    /// Refused (`Error::Invalid`): an interaxial or convergence that is not a finite
    /// number >= 0 (> 0 for the convergence), and a rig whose outer views are
    /// shifted by the image width or more (they would show nothing the camera
    /// frames; a convergence of 4e-9 asked for a shift of 1e10 pixels).
    pub fn multi_view(
        camera: &Camera,
        count: usize,
        interaxial: f32,
        convergence: Option<f64>,
    ) -> Result<Rig> {
        let count = count.max(1);
        if !(interaxial.is_finite() && interaxial >= 0.0) {
            return Err(Error::Invalid(format!(
                "the interaxial distance must be a finite distance >= 0, got {interaxial}"
            )));
        }
        if let Some(c) = convergence {
            if !(c.is_finite() && c > 0.0) {
                return Err(Error::Invalid(format!(
                    "the convergence distance must be a finite distance > 0, got {c}"
                )));
            }
        }
        let offsets: Vec<f32> = (0..count)
            .map(|i| (i as f32 - (count as f32 - 1.0) * 0.5) * interaxial)
            .collect();
        let f = camera.focal_pixels();
        // In f64 until the range is known to be safe: the outer views are
        // shifted by half the rounded parallax of the whole span, which must stay
        // below the image width (so that every view still shows part of what the
        // camera frames, and every shift fits an i32).
        let disparity = |offset_from_first: f64| match convergence {
            Some(c) => (f * offset_from_first / c).round(),
            None => 0.0,
        };
        let span = (count - 1) as f64 * interaxial as f64;
        let total = disparity(span);
        let width = f64::from(camera.width).min(f64::from(i32::MAX));
        let largest_shift = (total / 2.0).ceil();
        if !(largest_shift.is_finite() && largest_shift < width) {
            let c = convergence.unwrap_or(f64::INFINITY);
            return Err(Error::Invalid(format!(
                "views {interaxial} apart converging at {c} need an image shift of {largest_shift} \
                 pixels, more than the image is wide ({} pixels): the outer views would show \
                 nothing of what the camera frames (use a larger convergence distance or a \
                 smaller interaxial)",
                camera.width
            )));
        }
        let total = total as i64;
        let centre = total / 2;
        let views = offsets
            .iter()
            .enumerate()
            .map(|(i, &offset)| View {
                offset,
                // |centre - d| <= ceil(total / 2) < width <= i32::MAX: no overflow.
                shift: (centre - disparity(i as f64 * interaxial as f64) as i64) as i32,
            })
            .collect();
        let effective_convergence = if total == 0 || span == 0.0 {
            None
        } else {
            Some(f * span / total as f64)
        };
        Ok(Rig {
            views,
            convergence,
            effective_convergence,
        })
    }

    /// The depth beyond which an object may be cut from the twinning (the
    /// paper's section 2.3) with its disparity off by at most `pixels`.
    ///
    /// A cut object is seen by every view as the rig's centre sees it: its
    /// image in view `v` is where the centre's image puts it, `f·o_v/z` pixels
    /// from where it belongs (`f` the focal length in pixels, `o_v` the view's
    /// offset, `z` the depth; the whole-pixel convergence shifts move cut and
    /// uncut objects alike). Between the two outermost views the disparity is
    /// off by `f·(o_max − o_min)/z`, at most `pixels` from depth
    /// `f·(o_max − o_min)/pixels` on. `None` for a single view or no interaxial
    /// (nothing to cut from).
    pub fn cut_depth_for_parallax(&self, camera: &Camera, pixels: f64) -> Option<f64> {
        let lo = self
            .views
            .iter()
            .map(|v| v.offset)
            .fold(f32::INFINITY, f32::min);
        let hi = self
            .views
            .iter()
            .map(|v| v.offset)
            .fold(f32::NEG_INFINITY, f32::max);
        let span = (hi - lo) as f64;
        (span > 0.0 && pixels > 0.0).then(|| camera.focal_pixels() * span / pixels)
    }

    /// The range of camera columns that some view's image (or sample grid) of
    /// `width` columns needs.
    pub fn column_range(&self, width: u32) -> (i32, i32) {
        let lo = self.views.iter().map(|v| v.shift).min().unwrap_or(0);
        let hi = self.views.iter().map(|v| v.shift).max().unwrap_or(0);
        let hi = hi.saturating_add(i32::try_from(width).unwrap_or(i32::MAX) - 1);
        (lo, hi)
    }
}

/// The disparity `x_b − x_a` of a point at `depth` between views `a` and `b`.
pub fn pair_disparity(camera: &Camera, a: View, b: View, depth: f64) -> f64 {
    f64::from(a.shift)
        - f64::from(b.shift)
        - camera.focal_pixels() * f64::from(b.offset - a.offset) / depth
}

/// The rig tests' camera: at the origin looking along +y, 60 degrees,
/// 201 x 101 pixels.
#[cfg(test)]
pub(crate) fn test_camera() -> Camera {
    let vp = crate::scene::Viewpoint {
        from: crate::math::Vec3::ZERO,
        at: crate::math::Vec3::Y,
        up: crate::math::Vec3::Z,
        angle_deg: 60.0,
        angle_span: Default::default(),
        hither: 0.0,
        width: 201,
        height: 101,
    };
    Camera::new(&vp, 201, 101)
}

#[cfg(test)]
mod tests {
    use super::test_camera as camera;
    use super::*;

    #[test]
    fn stereo_offsets_are_symmetric() {
        let rig = Rig::stereo(&camera(), 0.5, None).unwrap();
        assert_eq!(rig.views[0].offset, -0.25);
        assert_eq!(rig.views[1].offset, 0.25);
        assert_eq!(rig.views[0].shift, 0);
        assert_eq!(rig.views[1].shift, 0);
        assert_eq!(rig.effective_convergence, None);
    }

    #[test]
    fn shifts_put_the_convergence_plane_at_zero_parallax() {
        let cam = camera();
        let c = 4.0;
        let rig = Rig::stereo(&cam, 0.5, Some(c)).unwrap();
        let d = (cam.focal_pixels() * 0.5 / c).round() as i32;
        assert_eq!(rig.views[0].shift - rig.views[1].shift, d);
        let eff = rig.effective_convergence.unwrap();
        assert!((eff - cam.focal_pixels() * 0.5 / d as f64).abs() < 1e-9);
        assert!((eff - c).abs() / c < 0.05);
    }

    #[test]
    fn column_range_covers_every_view() {
        let cam = camera();
        let rig = Rig::stereo(&cam, 0.5, Some(2.0)).unwrap();
        let (lo, hi) = rig.column_range(cam.width);
        for v in &rig.views {
            assert!(lo <= v.shift && v.shift + cam.width as i32 - 1 <= hi);
        }
    }

    #[test]
    fn shifts_beyond_the_image_are_refused() {
        // The attack: a convergence of 4e-9 gave a shift of ~1e10 pixels, truncated
        // to i32 (and a 23 GB allocation or "capacity overflow" panics).
        let cam = camera();
        for (interaxial, c) in [
            (0.3, Some(4e-9)),
            (0.3, Some(1e-300)),
            (f32::MAX, Some(1.0)),
        ] {
            let err = Rig::stereo(&cam, interaxial, c).unwrap_err();
            assert!(
                err.to_string().contains("more than the image is wide"),
                "{err}"
            );
        }
        // The largest accepted shift is one pixel less than the width (201).
        let f = cam.focal_pixels();
        let rig = Rig::stereo(&cam, 0.5, Some(f * 0.5 / 400.0)).unwrap();
        assert_eq!(rig.views[0].shift - rig.views[1].shift, 400);
        assert_eq!(rig.views[0].shift, 200);
        assert!(Rig::stereo(&cam, 0.5, Some(f * 0.5 / 401.0)).is_err());
        assert!(Rig::stereo(&cam, -1.0, None).is_err());
        assert!(Rig::stereo(&cam, f32::NAN, None).is_err());
        assert!(Rig::stereo(&cam, 1.0, Some(0.0)).is_err());
    }
}

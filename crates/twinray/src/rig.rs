//! The view rig: a list of views on the camera's right axis.
//!
//! Mono is one view; stereo is two (left at `-b/2`, right at `+b/2`); a
//! multi-view display takes N. Every view has parallel lens axes; convergence
//! is a horizontal image translation by a whole number of pixels, so pixel
//! `x` of view `v` sees along camera column `x + shift`: pixels of different
//! views with equal camera columns see along parallel rays.

use crate::camera::Camera;

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
    pub fn stereo(camera: &Camera, interaxial: f32, convergence: Option<f64>) -> Rig {
        Rig::multi_view(camera, 2, interaxial, convergence)
    }

    /// `count` views, `spacing` apart, centred on the camera, left to right.
    /// The shift of each view is rounded to whole pixels (relative to the leftmost
    /// view), then the set is centred: points at the convergence distance land on
    /// the same pixel in every view, up to the rounding, which is reported as the
    /// effective convergence distance.
    pub fn multi_view(
        camera: &Camera,
        count: usize,
        spacing: f32,
        convergence: Option<f64>,
    ) -> Rig {
        let count = count.max(1);
        let offsets: Vec<f32> = (0..count)
            .map(|i| (i as f32 - (count as f32 - 1.0) * 0.5) * spacing)
            .collect();
        let f = camera.focal_pixels();
        let disparity = |offset_from_first: f64| match convergence {
            Some(c) => (f * offset_from_first / c).round() as i64,
            None => 0,
        };
        let total = disparity(((count - 1) as f64) * spacing as f64);
        let centre = total / 2;
        let views = offsets
            .iter()
            .enumerate()
            .map(|(i, &offset)| View {
                offset,
                shift: (centre - disparity(i as f64 * spacing as f64)) as i32,
            })
            .collect();
        let span = (count - 1) as f64 * spacing as f64;
        let effective_convergence = if total == 0 || span == 0.0 {
            None
        } else {
            Some(f * span / total as f64)
        };
        Rig {
            views,
            convergence,
            effective_convergence,
        }
    }

    /// The range of camera columns that some view's image (or sample grid) of
    /// `width` columns needs.
    pub fn column_range(&self, width: u32) -> (i32, i32) {
        let lo = self.views.iter().map(|v| v.shift).min().unwrap_or(0);
        let hi = self.views.iter().map(|v| v.shift).max().unwrap_or(0) + width as i32 - 1;
        (lo, hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;
    use crate::scene::Viewpoint;

    fn camera() -> Camera {
        let vp = Viewpoint {
            from: Vec3::ZERO,
            at: Vec3::Y,
            up: Vec3::Z,
            angle_deg: 60.0,
            angle_span: Default::default(),
            hither: 0.0,
            width: 201,
            height: 101,
        };
        Camera::new(&vp, 201, 101)
    }

    #[test]
    fn stereo_offsets_are_symmetric() {
        let rig = Rig::stereo(&camera(), 0.5, None);
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
        let rig = Rig::stereo(&cam, 0.5, Some(c));
        let d = (cam.focal_pixels() * 0.5 / c).round() as i32;
        assert_eq!(rig.views[0].shift - rig.views[1].shift, d);
        let eff = rig.effective_convergence.unwrap();
        assert!((eff - cam.focal_pixels() * 0.5 / d as f64).abs() < 1e-9);
        assert!((eff - c).abs() / c < 0.05);
    }

    #[test]
    fn column_range_covers_every_view() {
        let cam = camera();
        let rig = Rig::stereo(&cam, 0.5, Some(2.0));
        let (lo, hi) = rig.column_range(cam.width);
        for v in &rig.views {
            assert!(lo <= v.shift && v.shift + cam.width as i32 - 1 <= hi);
        }
    }
}

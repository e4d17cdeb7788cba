//! The pinhole camera with NFF's viewpoint semantics.
//!
//! NFF's `angle` spans the centres of the edge pixels (not the outer edges).
//! For non-square images the angle applies to the shorter side and pixels stay
//! square. Every ray direction is a function of a *camera column* and row, so
//! that two views whose image shifts differ by whole pixels generate bit-equal
//! directions for the same camera column: the twin method depends on it.

use super::projection::{Frame, Projection};
use crate::math::{Ray, Vec3};
use crate::scene::{AngleSpan, Viewpoint};

#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub eye: Vec3,
    /// Unit view direction.
    pub forward: Vec3,
    /// Unit right axis, `normalize(cross(forward, up))`: the line the views'
    /// eyes lie on, the interaxial's direction.
    pub right: Vec3,
    /// Unit up axis of the image plane.
    pub up: Vec3,
    pub width: u32,
    pub height: u32,
    /// Pixel pitch on the image plane at distance 1.
    pub pixel_size: f32,
    /// Near clipping distance (NFF `hither`), along the ray.
    pub hither: f32,
    /// How image positions become rays: the plane above, or a panorama
    /// (`rig::projection`), which leaves `pixel_size` and `direction` unused.
    pub projection: Projection,
}

impl Camera {
    /// A camera for `vp` rendering `width` x `height` pixels.
    pub fn new(vp: &Viewpoint, width: u32, height: u32) -> Camera {
        // Scaled before normalising: `at - from` of 1e-25 or an `up` of 1e-30
        // would square to zero (and a length of 1e20 to infinity).
        let forward = unit(vp.at - vp.from);
        let right = unit(forward.cross(unit(vp.up)));
        let up = right.cross(forward);
        let half_angle = (vp.angle_deg.to_radians() * 0.5) as f64;
        let pixel_size = match vp.angle_span {
            AngleSpan::EdgePixelCentres => {
                let spanned = width.min(height).max(2) - 1;
                (2.0 * half_angle.tan() / spanned as f64) as f32
            }
            AngleSpan::ImageHeight => (2.0 * half_angle.tan() / height.max(1) as f64) as f32,
        };
        Camera {
            eye: vp.from,
            forward,
            right,
            up,
            width,
            height,
            pixel_size,
            hither: vp.hither.max(0.0),
            projection: Projection::Pinhole,
        }
    }

    /// This camera with another projection. A panorama's `pixel_size` is
    /// the angle of a pixel at the image centre, in radians.
    pub fn with_projection(mut self, projection: Projection) -> Camera {
        if projection.is_panorama() {
            let (span, _) = projection.span_deg();
            self.pixel_size = (span.to_radians() / self.width.max(1) as f64) as f32;
        }
        self.projection = projection;
        self
    }

    /// The frame a panorama is laid out in.
    #[inline]
    pub fn frame(&self) -> Frame {
        Frame {
            eye: self.eye,
            forward: self.forward,
            right: self.right,
            up: self.up,
            width: self.width,
            height: self.height,
        }
    }

    /// The eye ray of the view at `offset` through (`column`, `row`), of any
    /// projection: its origin and unit direction, or `None` where the image
    /// has no ray (outside a fisheye's circle: black).
    #[inline]
    pub fn view_ray(&self, offset: f32, column: f32, row: f32) -> Option<(Vec3, Vec3)> {
        match self.projection {
            Projection::Pinhole => Some((self.eye_at(offset), self.direction(column, row))),
            p => p.ray(&self.frame(), offset, column, row),
        }
    }

    /// Focal length in pixels: the distance to the image plane where one pixel is
    /// one unit. The parallax of a point at depth `z` is `f * b / z`.
    pub fn focal_pixels(&self) -> f64 {
        1.0 / self.pixel_size as f64
    }

    /// The unit direction through image position (`column`, `row`) in pixel units,
    /// pixel centres at integers. Columns may lie outside `0..width` (other views'
    /// image shifts); the arithmetic only depends on the values passed in.
    #[inline]
    pub fn direction(&self, column: f32, row: f32) -> Vec3 {
        let cx = (self.width as f32 - 1.0) * 0.5;
        let cy = (self.height as f32 - 1.0) * 0.5;
        let x = (column - cx) * self.pixel_size;
        let y = (cy - row) * self.pixel_size;
        (self.forward + self.right * x + self.up * y).normalize()
    }

    /// `direction` of eight image positions at once (`columns[i]`,
    /// `rows[i]`), in the lanes of `f32x8` registers: per lane the same IEEE
    /// operations in the same order (the sums left to right, the square root
    /// and the division rounded as the scalar ones are), so each direction
    /// is `direction`'s, bit for bit. One vector square root and division
    /// for eight rays instead of eight of each (docs/benchmarks.md, "Issue
    /// 17, seventh pass").
    #[inline]
    pub fn directions8(&self, columns: [f32; 8], rows: [f32; 8]) -> [Vec3; 8] {
        use wide::f32x8;
        let sp = f32x8::splat;
        let cx = (self.width as f32 - 1.0) * 0.5;
        let cy = (self.height as f32 - 1.0) * 0.5;
        let x = (f32x8::from(columns) - sp(cx)) * sp(self.pixel_size);
        let y = (sp(cy) - f32x8::from(rows)) * sp(self.pixel_size);
        let axis = |a: usize| sp(self.forward[a]) + sp(self.right[a]) * x + sp(self.up[a]) * y;
        let (dx, dy, dz) = (axis(0), axis(1), axis(2));
        // `normalize`: the vector times the reciprocal of its length.
        let recip = sp(1.0) / (dx * dx + dy * dy + dz * dz).sqrt();
        let (dx, dy, dz) = (
            (dx * recip).to_array(),
            (dy * recip).to_array(),
            (dz * recip).to_array(),
        );
        std::array::from_fn(|i| Vec3::new(dx[i], dy[i], dz[i]))
    }

    /// The eye position of a view displaced by `offset` along the right axis.
    #[inline]
    pub fn eye_at(&self, offset: f32) -> Vec3 {
        if offset == 0.0 {
            self.eye
        } else {
            self.eye + self.right * offset
        }
    }

    /// The ray of a view at `offset` through (`column`, `row`).
    #[inline]
    pub fn ray(&self, offset: f32, column: f32, row: f32) -> Ray {
        Ray::new(self.eye_at(offset), self.direction(column, row))
    }

    /// Camera-space depth (along `forward`) of a world point seen from the eye at `offset`.
    pub fn depth_of(&self, p: Vec3, offset: f32) -> f32 {
        (p - self.eye_at(offset)).dot(self.forward)
    }

    /// Where a world point projects, in pixel units (column, row), for the view at `offset`.
    pub fn project(&self, p: Vec3, offset: f32) -> Option<(f64, f64)> {
        if self.projection.is_panorama() {
            return self.projection.project(&self.frame(), p, offset);
        }
        let rel = p - self.eye_at(offset);
        let z = rel.dot(self.forward) as f64;
        if z <= 0.0 {
            return None;
        }
        let f = self.focal_pixels();
        let cx = (self.width as f64 - 1.0) * 0.5;
        let cy = (self.height as f64 - 1.0) * 0.5;
        Some((
            cx + f * rel.dot(self.right) as f64 / z,
            cy - f * rel.dot(self.up) as f64 / z,
        ))
    }
}

/// `v` divided by its largest component, then normalised: no underflow or
/// overflow of the squared length for any finite non-zero `v`.
fn unit(v: Vec3) -> Vec3 {
    (v / v.abs().max_element()).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiny_and_huge_viewpoint_vectors_give_the_same_axes() {
        // The attack: `from 0 -1e-25 1`, `at 0 0 1` and `up 0 0 1e-30` passed the
        // parser and gave NaN axes (a garbage image).
        let reference = Camera::new(&vp(), 5, 5);
        for (from, at, up) in [
            (
                Vec3::new(0.0, -1e-25, 0.0),
                Vec3::ZERO,
                Vec3::new(0.0, 0.0, 1e-30),
            ),
            (
                Vec3::new(0.0, -1e20, 0.0),
                Vec3::new(0.0, 1e20, 0.0),
                Vec3::Z * 3e38,
            ),
        ] {
            let c = Camera::new(
                &Viewpoint {
                    from,
                    at,
                    up,
                    ..vp()
                },
                5,
                5,
            );
            for (a, b) in [
                (c.forward, reference.forward),
                (c.right, reference.right),
                (c.up, reference.up),
            ] {
                assert!((a - b).length() < 1e-6, "{a} vs {b}");
            }
        }
    }

    fn vp() -> Viewpoint {
        Viewpoint {
            from: Vec3::new(0.0, 0.0, 0.0),
            at: Vec3::new(0.0, 1.0, 0.0),
            up: Vec3::Z,
            angle_deg: 90.0,
            angle_span: AngleSpan::EdgePixelCentres,
            hither: 0.0,
            width: 5,
            height: 5,
        }
    }

    /// Eight directions at once are `direction`'s, bit for bit: random
    /// cameras (odd sizes, narrow and wide angles, either angle span) and
    /// image positions inside the image and beyond it (other views' shifts).
    #[test]
    fn eight_directions_are_the_scalar_ones_bit_for_bit() {
        let mut g = fastrand::Rng::with_seed(41);
        let mut r = |s: f32| (g.f32() - 0.5) * s;
        let mut lanes = 0;
        for round in 0..400 {
            let view = Viewpoint {
                from: Vec3::new(r(20.0), r(20.0), r(20.0)),
                at: Vec3::new(r(4.0), r(4.0), r(4.0)),
                up: Vec3::new(r(1.0), r(1.0), 1.0),
                angle_deg: 1.0 + (r(1.0) + 0.5) * 120.0,
                angle_span: if round % 2 == 0 {
                    AngleSpan::EdgePixelCentres
                } else {
                    AngleSpan::ImageHeight
                },
                ..vp()
            };
            let (w, h) = (1 + round % 97 * 13, 1 + round % 61 * 17);
            let c = Camera::new(&view, w, h);
            let columns: [f32; 8] =
                std::array::from_fn(|_| (r(1.0) + 0.5) * 1.4 * w as f32 - 0.2 * w as f32);
            let rows: [f32; 8] = std::array::from_fn(|_| (r(1.0) + 0.5) * h as f32);
            let eight = c.directions8(columns, rows);
            for i in 0..8 {
                let one = c.direction(columns[i], rows[i]);
                assert_eq!(
                    eight[i].to_array().map(f32::to_bits),
                    one.to_array().map(f32::to_bits),
                    "round {round}, lane {i}"
                );
                lanes += 1;
            }
        }
        assert_eq!(lanes, 3200);
    }

    #[test]
    fn centre_pixel_looks_at_the_target() {
        let c = Camera::new(&vp(), 5, 5);
        assert!((c.direction(2.0, 2.0) - Vec3::Y).length() < 1e-6);
    }

    #[test]
    fn angle_spans_the_centres_of_the_edge_pixels() {
        let c = Camera::new(&vp(), 5, 5);
        let left = c.direction(0.0, 2.0);
        let right = c.direction(4.0, 2.0);
        let angle = left.dot(right).acos().to_degrees();
        assert!((angle - 90.0).abs() < 1e-4, "{angle}");
        let top = c.direction(2.0, 0.0);
        let bottom = c.direction(2.0, 4.0);
        assert!((top.dot(bottom).acos().to_degrees() - 90.0).abs() < 1e-4);
    }

    #[test]
    fn right_axis_and_image_orientation() {
        let c = Camera::new(&vp(), 5, 5);
        // Looking along +y with z up, the right axis is +x.
        assert!((c.right - Vec3::X).length() < 1e-6);
        assert!(c.direction(4.0, 2.0).x > 0.0);
        assert!(c.direction(2.0, 0.0).z > 0.0, "row 0 is the top");
    }

    #[test]
    fn wide_images_keep_square_pixels() {
        let c = Camera::new(&vp(), 9, 5);
        let top = c.direction(4.0, 0.0);
        let bottom = c.direction(4.0, 4.0);
        assert!((top.dot(bottom).acos().to_degrees() - 90.0).abs() < 1e-4);
        let l = c.direction(0.0, 2.0);
        let r = c.direction(8.0, 2.0);
        assert!(l.dot(r).acos().to_degrees() > 90.0);
    }

    #[test]
    fn image_height_angle_spans_the_outer_edges() {
        let mut v = vp();
        v.angle_span = AngleSpan::ImageHeight;
        let c = Camera::new(&v, 8, 4);
        // The top edge of the image is half a pixel above row 0's centre.
        let top = c.direction(3.5, -0.5);
        let bottom = c.direction(3.5, 3.5);
        assert!((top.dot(bottom).acos().to_degrees() - 90.0).abs() < 1e-4);
    }

    #[test]
    fn projection_inverts_direction() {
        let c = Camera::new(&vp(), 64, 48);
        let p = c.eye + c.direction(10.0, 7.0) * 3.7;
        let (x, y) = c.project(p, 0.0).unwrap();
        assert!((x - 10.0).abs() < 1e-3 && (y - 7.0).abs() < 1e-3, "{x} {y}");
    }
}

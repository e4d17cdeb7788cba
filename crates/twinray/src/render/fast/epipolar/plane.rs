//! A row's plane and the primitives' sections by it: the geometry of the
//! fast method's epipolar rows.
//!
//! The rays of every view through one image row lie in one plane: through
//! the camera line, spanned by the right axis `R` and `W = F + U·y`. A point
//! of it has coordinates `(a, b)` (along `R` and `W`); the view at offset `u`
//! sees it in the column whose slope is `(a − u)/b`, at distance `b·L` along
//! a ray whose unnormalised direction `R·x + W` has length `L`.

use glam::DVec3;

use crate::rig::Camera;
use crate::shapes::Shape;

use crate::render::sampler::SampleRow;

/// A primitive's section by the row's plane, in plane coordinates `(a, b)`.
#[derive(Clone, Copy, Debug)]
pub(super) enum Section {
    /// The plane misses it.
    None,
    /// A triangle's: a segment, clipped to `b ≥ b_min`.
    /// `inv`: one over the squared length (0 for a point).
    Segment {
        a0: f64,
        b0: f64,
        a1: f64,
        b1: f64,
        inv: f64,
    },
    /// A sphere's: a circle.
    Circle { a: f64, b: f64, r: f64 },
    /// Any other shape's (or a triangle lying in the plane): within a box.
    Bounds { a0: f64, b0: f64, a1: f64, b1: f64 },
    /// One that reaches the camera line: any sample may meet it.
    Whole,
}

impl Section {
    /// The segment from `(a0, b0)` to `(a1, b1)`.
    fn segment(a0: f64, b0: f64, a1: f64, b1: f64) -> Section {
        let len2 = (a1 - a0).powi(2) + (b1 - b0).powi(2);
        let inv = if len2 > 0.0 { 1.0 / len2 } else { 0.0 };
        Section::Segment {
            a0,
            b0,
            a1,
            b1,
            inv,
        }
    }

    /// The least `b` of its points (`None`: the plane misses it).
    pub(super) fn nearest_b(&self) -> Option<f64> {
        match *self {
            Section::None => None,
            Section::Segment { b0, b1, .. } => Some(b0.min(b1)),
            Section::Circle { b, r, .. } => Some(b - r),
            Section::Bounds { b0, .. } => Some(b0),
            Section::Whole => Some(0.0),
        }
    }

    /// Where on the section a point `(a, b)` of it lies: a segment's
    /// fraction, a circle's angle, and for other sections the angle around
    /// their box's centre (a cone's section is convex, so the box's centre
    /// sees each of its points at its own angle); `None` for sections
    /// through the eyes.
    pub(super) fn param(&self, a: f64, b: f64) -> Option<f64> {
        match *self {
            Section::Segment {
                a0,
                b0,
                a1,
                b1,
                inv,
            } => (inv > 0.0).then_some(((a - a0) * (a1 - a0) + (b - b0) * (b1 - b0)) * inv),
            Section::Circle { a: ca, b: cb, .. } => Some((b - cb).atan2(a - ca)),
            Section::Bounds { a0, b0, a1, b1 } => {
                Some((b - (b0 + b1) * 0.5).atan2(a - (a0 + a1) * 0.5))
            }
            Section::None | Section::Whole => None,
        }
    }
}

/// How far below a section's nearest `b` its rays' hits may lie, relative:
/// the rays leave the plane by their rounding (some millionths).
pub(super) const NEAR_SLACK: f64 = 1e-4;

/// Margin of a section's samples, in samples.
const EDGE: f64 = 1e-2;

/// The row's plane: origin (the rig's centre eye), axes, and the samples'
/// columns.
pub(super) struct Plane {
    eye: DVec3,
    right: DVec3,
    w: DVec3,
    /// `W·W`, and the plane's unit normal.
    pub(super) ww: f64,
    normal: DVec3,
    /// Camera column of sample 0 without shift, the image's centre column,
    /// and the pixel size: the slope of a column `c` is `(c − cx)·ps`.
    c0: f64,
    pub(super) cx: f64,
    pub(super) ps: f64,
    /// Plane points nearer the camera line than this are met by no ray.
    b_min: f64,
}

impl Plane {
    /// The plane of `row` seen by views shifted by `shifts`; `margin` is the
    /// rounding of the scene's coordinates.
    pub(super) fn of_row(
        camera: &Camera,
        row: &SampleRow,
        shifts: impl Iterator<Item = i32>,
        margin: f64,
    ) -> Plane {
        let (c0, y) = row.camera_point(0, 0);
        let (cx, cy) = (
            (camera.width as f64 - 1.0) * 0.5,
            (camera.height as f64 - 1.0) * 0.5,
        );
        let ps = camera.pixel_size as f64;
        let right = camera.right.as_dvec3();
        let w = camera.forward.as_dvec3() + camera.up.as_dvec3() * ((cy - y as f64) * ps);
        let ww = w.length_squared();
        // No ray meets a point nearer than `hither` from its eye; every
        // ray's direction (unnormalised `R·x + W`) is at most this long.
        let widest = shifts
            .flat_map(|shift| [0.0, (row.len() as f64 - 1.0)].map(|i| c0 as f64 + i + shift as f64))
            .map(|c| ((c - cx) * ps).powi(2))
            .fold(0.0, f64::max);
        let b_min = (camera.hither as f64 / (widest + ww).sqrt() * 0.5).max(margin);
        Plane {
            eye: camera.eye.as_dvec3(),
            right,
            w,
            ww,
            normal: right.cross(w).normalize(),
            c0: c0 as f64,
            cx,
            ps,
            b_min,
        }
    }

    /// `(a, b, h)`: the point's plane coordinates and its distance from the plane.
    pub(super) fn coords(&self, p: DVec3) -> (f64, f64, f64) {
        let d = p - self.eye;
        (
            d.dot(self.right),
            d.dot(self.w) / self.ww,
            d.dot(self.normal),
        )
    }

    /// The (fractional) sample of the view at `offset` (shift `shift`)
    /// whose ray meets plane point `(a, b)`, `b > 0` (`Reach` computes it
    /// without the division; the tests compare the two).
    #[cfg(test)]
    pub(super) fn sample_of(&self, a: f64, b: f64, offset: f64, shift: i32) -> f64 {
        (a - offset) / b / self.ps + self.cx - self.c0 - shift as f64
    }

    /// `sample_of` for a point given by `a` and `1/(b·ps)`, which shade
    /// points keep: no division per look-up.
    pub(super) fn sample_of_scaled(&self, a: f64, inv_bps: f64, offset: f64, shift: i32) -> f64 {
        (a - offset) * inv_bps + self.cx - self.c0 - shift as f64
    }

    /// The section of `shape` by the plane; `tol`: how near the plane a
    /// vertex or box corner counts as on it.
    pub(super) fn section(&self, shape: &Shape, tol: f64) -> Section {
        match shape {
            Shape::Triangle(t) => {
                let p = [t.v0, t.v0 + t.e1, t.v0 + t.e2].map(|p| p.as_dvec3() - self.eye);
                // The distances from the plane first: most triangles whose
                // boxes meet the row's region lie on one side of it.
                let h = p.map(|d| d.dot(self.normal));
                if h.iter().all(|&h| h > tol) || h.iter().all(|&h| h < -tol) {
                    return Section::None;
                }
                let v: [(f64, f64, f64); 3] = std::array::from_fn(|i| {
                    (p[i].dot(self.right), p[i].dot(self.w) / self.ww, h[i])
                });
                if v.iter().any(|p| p.2.abs() <= tol) {
                    // Near the plane: within the vertices' box.
                    return self.bounds_section(v.iter().map(|p| (p.0, p.1)));
                }
                // Exactly two edges change sign.
                let mut ends = [(0.0, 0.0); 2];
                let mut k = 0;
                for (i, j) in [(0, 1), (1, 2), (2, 0)] {
                    let (p, q) = (v[i], v[j]);
                    if (p.2 > 0.0) != (q.2 > 0.0) && k < 2 {
                        let f = p.2 / (p.2 - q.2);
                        ends[k] = (p.0 + (q.0 - p.0) * f, p.1 + (q.1 - p.1) * f);
                        k += 1;
                    }
                }
                let [(a0, b0), (a1, b1)] = ends;
                self.clip_segment(a0, b0, a1, b1)
            }
            Shape::Sphere(s) => {
                let (a, b, h) = self.coords(s.center.as_dvec3());
                let r = s.radius as f64 + tol;
                if h.abs() > r {
                    return Section::None;
                }
                let r = (r * r - h * h).sqrt();
                if b - r < self.b_min {
                    return Section::Whole;
                }
                Section::Circle { a, b, r }
            }
            shape => {
                let bx = shape.bounds();
                let corners: [(f64, f64, f64); 8] = std::array::from_fn(|i| {
                    let pick = |bit: usize, lo: f32, hi: f32| if i & bit == 0 { lo } else { hi };
                    self.coords(DVec3::new(
                        pick(1, bx.min.x, bx.max.x) as f64,
                        pick(2, bx.min.y, bx.max.y) as f64,
                        pick(4, bx.min.z, bx.max.z) as f64,
                    ))
                });
                if corners.iter().all(|p| p.2 > tol) || corners.iter().all(|p| p.2 < -tol) {
                    return Section::None;
                }
                self.bounds_section(corners.iter().map(|p| (p.0, p.1)))
            }
        }
    }

    /// Where every view sees `section`'s ends (a segment's) or its box's
    /// corners (a circle's, any other's): `Reach::samples` gives a view's
    /// samples without a division.
    pub(super) fn reach(&self, section: &Section) -> Reach {
        let mut reach = Reach {
            points: [(0.0, 0.0); 4],
            count: 0,
            whole: false,
        };
        let corners = |a0, b0, a1, b1| [(a0, b0), (a0, b1), (a1, b0), (a1, b1)];
        let points: &[(f64, f64)] = match *section {
            Section::None => &[],
            Section::Whole => {
                reach.whole = true;
                &[]
            }
            Section::Segment { a0, b0, a1, b1, .. } => &[(a0, b0), (a1, b1)],
            Section::Circle { a, b, r } => &corners(a - r, b - r, a + r, b + r),
            Section::Bounds { a0, b0, a1, b1 } => &corners(a0, b0, a1, b1),
        };
        for (slot, &(a, b)) in reach.points.iter_mut().zip(points) {
            // `sample_of` is `a·inv − offset·inv + cx − c0 − shift`.
            let inv = 1.0 / (b * self.ps);
            *slot = (a * inv + self.cx - self.c0, inv);
        }
        reach.count = points.len();
        reach
    }

    /// Box section of points `(a, b)`, or the whole row where it reaches the
    /// camera line.
    fn bounds_section(&self, points: impl Iterator<Item = (f64, f64)>) -> Section {
        let (mut a0, mut b0, mut a1, mut b1) = (
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        );
        for (a, b) in points {
            a0 = a0.min(a);
            a1 = a1.max(a);
            b0 = b0.min(b);
            b1 = b1.max(b);
        }
        if b1 < self.b_min {
            Section::None
        } else if b0 < self.b_min || !(a0.is_finite() && a1.is_finite()) {
            Section::Whole
        } else {
            Section::Bounds { a0, b0, a1, b1 }
        }
    }

    /// A triangle's segment clipped to `b ≥ b_min`.
    fn clip_segment(&self, a0: f64, b0: f64, a1: f64, b1: f64) -> Section {
        let m = self.b_min;
        match (b0 >= m, b1 >= m) {
            (false, false) => Section::None,
            (true, true) => Section::segment(a0, b0, a1, b1),
            (keeps_first, _) => {
                let f = (m - b0) / (b1 - b0);
                let (a, b) = (a0 + (a1 - a0) * f, m);
                if keeps_first {
                    Section::segment(a0, b0, a, b)
                } else {
                    Section::segment(a, b, a1, b1)
                }
            }
        }
    }
}

/// A section's ends or corners as `Plane::reach` gives them: per point, its
/// column at offset 0 without shift, and how far it moves per unit of offset.
pub(super) struct Reach {
    points: [(f64, f64); 4],
    count: usize,
    /// The section reaches the camera line: every sample.
    whole: bool,
}

impl Reach {
    /// Samples `lo..hi` of `n` of the view at `offset` (shift `shift`) whose
    /// rays may meet the section. The columns differ from `sample_of`'s by
    /// their rounding (far below a millionth of a sample), within `EDGE`.
    pub(super) fn samples(&self, offset: f64, shift: i32, n: usize) -> (usize, usize) {
        if self.whole {
            return (0, n);
        }
        if self.count == 0 {
            return (0, 0);
        }
        let mut lo = f64::INFINITY;
        let mut hi = f64::NEG_INFINITY;
        for &(at, inv) in &self.points[..self.count] {
            let s = at - offset * inv - shift as f64;
            lo = lo.min(s);
            hi = hi.max(s);
        }
        clamp_samples(lo, hi, n)
    }
}

/// Samples from `lo` to `hi` (fractional), and `EDGE` of a sample beyond
/// (the rays' rounding off the plane is some millionths of a pixel), within
/// `0..n`.
fn clamp_samples(lo: f64, hi: f64, n: usize) -> (usize, usize) {
    // NaN bounds (a degenerate section) give every sample.
    if lo
        .partial_cmp(&hi)
        .is_none_or(|o| o == std::cmp::Ordering::Greater)
    {
        return (0, n);
    }
    let lo = (lo - EDGE).ceil().clamp(0.0, n as f64) as usize;
    let hi = ((hi + EDGE).floor() + 1.0).clamp(0.0, n as f64) as usize;
    (lo, hi.max(lo))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A segment's samples are those whose columns lie within a hundredth
    /// of a sample of its ends; a NaN end gives every sample.
    #[test]
    fn a_sections_samples_reach_a_hundredth_past_its_ends() {
        assert_eq!(clamp_samples(2.005, 4.995, 10), (2, 6));
        assert_eq!(clamp_samples(2.02, 4.98, 10), (3, 5));
        assert_eq!(clamp_samples(-3.0, 20.0, 10), (0, 10));
        assert_eq!(clamp_samples(f64::NAN, 1.0, 10), (0, 10));
    }

    /// `Reach` puts a section's ends and corners in the columns `sample_of`
    /// gives, to their rounding, for every view.
    #[test]
    fn a_reach_puts_points_where_sample_of_does() {
        let plane = Plane {
            eye: DVec3::ZERO,
            right: DVec3::X,
            w: DVec3::Y,
            ww: 1.0,
            normal: DVec3::Z,
            c0: 3.0,
            cx: 209.5,
            ps: 0.002,
            b_min: 0.01,
        };
        let mut rng = fastrand::Rng::with_seed(7);
        let mut f = |lo: f64, hi: f64| lo + (hi - lo) * rng.f64();
        for _ in 0..1000 {
            let (a0, b0, a1, b1) = (f(-2.0, 2.0), f(0.5, 9.0), f(-2.0, 2.0), f(0.5, 9.0));
            let sections = [
                (Section::segment(a0, b0, a1, b1), vec![(a0, b0), (a1, b1)]),
                (
                    Section::Circle {
                        a: a0,
                        b: b0,
                        r: 0.3,
                    },
                    vec![
                        (a0 - 0.3, b0 - 0.3),
                        (a0 - 0.3, b0 + 0.3),
                        (a0 + 0.3, b0 - 0.3),
                        (a0 + 0.3, b0 + 0.3),
                    ],
                ),
            ];
            for (section, points) in sections {
                let reach = plane.reach(&section);
                assert_eq!(reach.count, points.len());
                let (offset, shift) = (f(-0.5, 0.5), f(-60.0, 60.0) as i32);
                for (&(at, inv), &(a, b)) in reach.points.iter().zip(&points) {
                    let column = at - offset * inv - shift as f64;
                    let exact = plane.sample_of(a, b, offset, shift);
                    assert!((column - exact).abs() < 1e-6, "{column} against {exact}");
                }
                // (No column of these lies within a millionth of a bound.)
                let columns = points
                    .iter()
                    .map(|&(a, b)| plane.sample_of(a, b, offset, shift));
                let (lo, hi) = columns.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), c| {
                    (l.min(c), h.max(c))
                });
                assert_eq!(
                    reach.samples(offset, shift, 420),
                    clamp_samples(lo, hi, 420)
                );
            }
        }
        let whole = plane.reach(&Section::Whole);
        assert_eq!(whole.samples(0.1, 4, 30), (0, 30));
        assert_eq!(plane.reach(&Section::None).samples(0.1, 4, 30), (0, 0));
    }
}

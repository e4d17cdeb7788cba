use super::SurfaceHit;
use crate::math::{Aabb, Ray, Vec3};

/// NFF's truncated cone (a cylinder when both radii are equal): open, no caps.
/// `inside` is NFF's negative radii: the normal points toward the axis.
#[derive(Clone, Debug, PartialEq)]
pub struct Cone {
    pub base: Vec3,
    pub base_radius: f32,
    pub apex: Vec3,
    pub apex_radius: f32,
    /// Unit vector from base to apex.
    axis: Vec3,
    height: f32,
    /// Radius change per unit of height.
    slope: f32,
    pub inside: bool,
}

impl Cone {
    /// `None` when the cone is degenerate (zero height, or both radii zero).
    pub fn new(
        base: Vec3,
        base_radius: f32,
        apex: Vec3,
        apex_radius: f32,
        inside: bool,
    ) -> Option<Cone> {
        let d = apex - base;
        let height = d.length();
        let (rb, ra) = (base_radius.abs(), apex_radius.abs());
        if height.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) || (rb == 0.0 && ra == 0.0)
        {
            return None;
        }
        Some(Cone {
            base,
            base_radius: rb,
            apex,
            apex_radius: ra,
            axis: d / height,
            height,
            slope: (ra - rb) / height,
            inside,
        })
    }

    #[inline(always)]
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<SurfaceHit> {
        let w = self.axis;
        let k = self.slope;
        // The components across the axis are formed explicitly: |x|^2 - (x.w)^2
        // cancels badly for a ray that starts on the surface (shadow acne).
        let co = ray.origin - self.base;
        let dw = ray.dir.dot(w);
        let cw = co.dot(w);
        let dp = ray.dir - w * dw;
        let cp = co - w * cw;
        let r0 = self.base_radius + k * cw;
        let a = dp.length_squared() - k * k * dw * dw;
        let b = cp.dot(dp) - k * dw * r0; // half of the linear coefficient
        let c = cp.length_squared() - r0 * r0;
        let accept = |t: f32| -> bool {
            if !(t > t_min && t < t_max) {
                return false;
            }
            let s = cw + t * dw;
            // Inside the height range, and on the nappe with a non-negative radius.
            (0.0..=self.height).contains(&s) && self.base_radius + k * s >= 0.0
        };
        if a.abs() < 1e-12 {
            // Ray parallel to a generating line: one root of the linear equation.
            if b == 0.0 {
                return None;
            }
            let t = -c / (2.0 * b);
            return accept(t).then_some(SurfaceHit { t, u: 0.0, v: 0.0 });
        }
        let disc = b * b - a * c;
        if disc < 0.0 {
            return None;
        }
        let sq = disc.sqrt();
        // Numerically stable pair of roots.
        let q = -(b + sq.copysign(b));
        let (mut t0, mut t1) = (q / a, if q != 0.0 { c / q } else { q / a });
        if t0 > t1 {
            std::mem::swap(&mut t0, &mut t1);
        }
        for t in [t0, t1] {
            if accept(t) {
                return Some(SurfaceHit { t, u: 0.0, v: 0.0 });
            }
        }
        None
    }

    pub fn bounds(&self) -> Aabb {
        // Each end is a disc: its extent along world axis i is r * sqrt(1 - axis_i^2).
        let disc = |c: Vec3, r: f32| {
            let e = (Vec3::ONE - self.axis * self.axis).max(Vec3::ZERO);
            let e = Vec3::new(e.x.sqrt(), e.y.sqrt(), e.z.sqrt()) * r;
            Aabb {
                min: c - e,
                max: c + e,
            }
        };
        disc(self.base, self.base_radius).union(disc(self.apex, self.apex_radius))
    }

    #[inline]
    pub fn normal(&self, point: Vec3) -> Vec3 {
        let rel = point - self.base;
        let radial = (rel - self.axis * rel.dot(self.axis)).normalize_or_zero();
        let n = (radial - self.axis * self.slope).normalize_or_zero();
        if self.inside {
            -n
        } else {
            n
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cylinder_hit_and_normal() {
        let c = Cone::new(Vec3::ZERO, 1.0, Vec3::new(0.0, 0.0, 2.0), 1.0, false).unwrap();
        let ray = Ray::new(Vec3::new(-5.0, 0.0, 1.0), Vec3::X);
        let h = c.intersect(&ray, 0.0, f32::INFINITY).unwrap();
        assert!((h.t - 4.0).abs() < 1e-5);
        let n = c.normal(ray.at(h.t));
        assert!((n - (-Vec3::X)).length() < 1e-5);
        // Open: a ray along the axis passes through.
        let along = Ray::new(Vec3::new(0.0, 0.0, -1.0), Vec3::Z);
        assert!(c.intersect(&along, 0.0, f32::INFINITY).is_none());
        // Outside the height range.
        let above = Ray::new(Vec3::new(-5.0, 0.0, 2.5), Vec3::X);
        assert!(c.intersect(&above, 0.0, f32::INFINITY).is_none());
    }

    #[test]
    fn cone_radius_varies_along_axis() {
        // Radius 1 at z=0, 0 at z=2: at z=1 the radius is 0.5.
        let c = Cone::new(Vec3::ZERO, 1.0, Vec3::new(0.0, 0.0, 2.0), 0.0, false).unwrap();
        let ray = Ray::new(Vec3::new(-5.0, 0.0, 1.0), Vec3::X);
        let h = c.intersect(&ray, 0.0, f32::INFINITY).unwrap();
        assert!((h.t - 4.5).abs() < 1e-5);
        // Outward normal leans up the axis, toward the apex.
        let n = c.normal(ray.at(h.t));
        let expect = Vec3::new(-1.0, 0.0, 0.5).normalize();
        assert!((n - expect).length() < 1e-5, "{n}");
    }

    #[test]
    fn second_root_from_inside() {
        let c = Cone::new(Vec3::ZERO, 1.0, Vec3::new(0.0, 0.0, 2.0), 1.0, true).unwrap();
        let ray = Ray::new(Vec3::new(0.0, 0.0, 1.0), Vec3::X);
        let h = c.intersect(&ray, 0.0, f32::INFINITY).unwrap();
        assert!((h.t - 1.0).abs() < 1e-5);
        // Negative radius: normal toward the axis.
        assert!((c.normal(ray.at(h.t)) - (-Vec3::X)).length() < 1e-5);
    }

    #[test]
    fn degenerate_cones_are_refused() {
        assert!(Cone::new(Vec3::ZERO, 1.0, Vec3::ZERO, 1.0, false).is_none());
        assert!(Cone::new(Vec3::ZERO, 0.0, Vec3::Z, 0.0, false).is_none());
    }

    #[test]
    fn bounds_of_tilted_cylinder() {
        let c = Cone::new(Vec3::ZERO, 1.0, Vec3::new(0.0, 0.0, 2.0), 1.0, false).unwrap();
        let b = c.bounds();
        assert!((b.min - Vec3::new(-1.0, -1.0, 0.0)).length() < 1e-6);
        assert!((b.max - Vec3::new(1.0, 1.0, 2.0)).length() < 1e-6);
    }
}

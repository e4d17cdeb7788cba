use super::{RayPair, SurfaceHit};
use crate::math::{Aabb, Ray, Vec3};
use wide::f32x4;

/// A sphere; `inside` is NFF's negative radius: the normal points inward.
#[derive(Clone, Debug, PartialEq)]
pub struct Sphere {
    pub center: Vec3,
    pub radius: f32,
    pub inside: bool,
}

impl Sphere {
    #[inline(always)]
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<SurfaceHit> {
        // Geometric form: project the centre on the ray, then step back by the half
        // chord. Better conditioned than the quadratic formula for distant spheres.
        // Every ray twinray traces has a unit direction, so |d|^2 = 1 is not divided out.
        let oc = self.center - ray.origin;
        let tc = oc.dot(ray.dir);
        let closest = oc - ray.dir * tc;
        let d2 = closest.length_squared();
        let r2 = self.radius * self.radius;
        if d2 > r2 {
            return None;
        }
        let half_chord = (r2 - d2).sqrt();
        let t0 = tc - half_chord;
        if t0 > t_min && t0 < t_max {
            return Some(SurfaceHit {
                t: t0,
                u: 0.0,
                v: 0.0,
            });
        }
        let t1 = tc + half_chord;
        if t1 > t_min && t1 < t_max {
            return Some(SurfaceHit {
                t: t1,
                u: 0.0,
                v: 0.0,
            });
        }
        None
    }

    /// `intersect` for two rays at once, in the lanes of one SSE register, with
    /// the same IEEE operations in the same order (bit for bit the single answers).
    #[inline(always)]
    pub fn intersect_pair(
        &self,
        rays: &RayPair,
        t_min: f32,
        t_max: [f32; 2],
    ) -> [Option<SurfaceHit>; 2] {
        let ([dx, dy, dz], [ox, oy, oz]) = (rays.dir, rays.origin);
        let ocx = f32x4::splat(self.center.x) - ox;
        let ocy = f32x4::splat(self.center.y) - oy;
        let ocz = f32x4::splat(self.center.z) - oz;
        let tc = ocx * dx + ocy * dy + ocz * dz;
        let (cx, cy, cz) = (ocx - dx * tc, ocy - dy * tc, ocz - dz * tc);
        let d2 = cx * cx + cy * cy + cz * cz;
        let r2 = f32x4::splat(self.radius * self.radius);
        let misses = d2.simd_gt(r2).to_bitmask();
        let half = (r2 - d2).sqrt();
        let (t0, t1) = (tc - half, tc + half);
        let lo = f32x4::splat(t_min);
        let hi = f32x4::from([t_max[0], t_max[1], 0.0, 0.0]);
        let in0 = (t0.simd_gt(lo) & t0.simd_lt(hi)).to_bitmask();
        let in1 = (t1.simd_gt(lo) & t1.simd_lt(hi)).to_bitmask();
        let (t0, t1) = (t0.to_array(), t1.to_array());
        std::array::from_fn(|l| {
            let bit = 1 << l;
            let t = if misses & bit != 0 {
                return None;
            } else if in0 & bit != 0 {
                t0[l]
            } else if in1 & bit != 0 {
                t1[l]
            } else {
                return None;
            };
            Some(SurfaceHit { t, u: 0.0, v: 0.0 })
        })
    }

    pub fn bounds(&self) -> Aabb {
        let r = Vec3::splat(self.radius);
        Aabb {
            min: self.center - r,
            max: self.center + r,
        }
    }

    #[inline]
    pub fn normal(&self, point: Vec3) -> Vec3 {
        let n = (point - self.center).normalize();
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

    fn unit() -> Sphere {
        Sphere {
            center: Vec3::new(0.0, 0.0, 5.0),
            radius: 1.0,
            inside: false,
        }
    }

    #[test]
    fn hits_front_then_back() {
        let s = unit();
        let ray = Ray::new(Vec3::ZERO, Vec3::Z);
        let h = s.intersect(&ray, 0.0, f32::INFINITY).unwrap();
        assert!((h.t - 4.0).abs() < 1e-6);
        let h2 = s.intersect(&ray, 4.5, f32::INFINITY).unwrap();
        assert!((h2.t - 6.0).abs() < 1e-6);
        assert!(s.intersect(&ray, 0.0, 3.9).is_none());
    }

    #[test]
    fn misses_beside() {
        let ray = Ray::new(Vec3::new(1.01, 0.0, 0.0), Vec3::Z);
        assert!(unit().intersect(&ray, 0.0, f32::INFINITY).is_none());
    }

    #[test]
    fn normal_outward_or_inward() {
        let mut s = unit();
        assert!((s.normal(Vec3::new(0.0, 0.0, 4.0)) - (-Vec3::Z)).length() < 1e-6);
        s.inside = true;
        assert!((s.normal(Vec3::new(0.0, 0.0, 4.0)) - Vec3::Z).length() < 1e-6);
    }

    #[test]
    fn bounds_enclose() {
        let b = unit().bounds();
        assert_eq!(b.min, Vec3::new(-1.0, -1.0, 4.0));
        assert_eq!(b.max, Vec3::new(1.0, 1.0, 6.0));
    }
}

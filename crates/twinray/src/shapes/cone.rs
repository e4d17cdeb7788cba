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
    pub(super) axis: Vec3,
    pub(super) height: f32,
    /// Radius change per unit of height.
    pub(super) slope: f32,
    pub inside: bool,
    /// `slope * slope`, computed once: the only factor of a test that does
    /// not depend on the ray (the same product, so the same bits).
    pub(super) slope_squared: f32,
}

/// See `Cone::pieces`.
const MAX_PIECES: u32 = 8;
const PIECE_CHARGE: f32 = 0.2;

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
        let slope = (ra - rb) / height;
        Some(Cone {
            base,
            base_radius: rb,
            apex,
            apex_radius: ra,
            axis: d / height,
            height,
            slope,
            inside,
            slope_squared: slope * slope,
        })
    }

    #[inline(always)]
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<SurfaceHit> {
        let w = self.axis;
        let k = self.slope;
        // The quadratic is solved from the point of the ray nearest the base,
        // `shift` along it, not from the origin: from afar, |cp|² − r0²
        // subtracts two numbers of the size of the distance squared, which
        // drowns a thin cone's radius (a branch of the SPD tree, 0.003 wide
        // from 5 away, was hit 0.002 off its surface and outside its box, so
        // that traversals in different orders disagreed).
        let shift = (self.base - ray.origin).dot(ray.dir);
        let origin = ray.origin + ray.dir * shift;
        // The components across the axis are formed explicitly: |x|^2 - (x.w)^2
        // cancels badly for a ray that starts on the surface (shadow acne).
        let co = origin - self.base;
        let dw = ray.dir.dot(w);
        let cw = co.dot(w);
        let dp = ray.dir - w * dw;
        let cp = co - w * cw;
        let r0 = self.base_radius + k * cw;
        let a = dp.length_squared() - self.slope_squared * dw * dw;
        let b = cp.dot(dp) - k * dw * r0; // half of the linear coefficient
        let c = cp.length_squared() - r0 * r0;
        // `t` is from the shifted origin; the hit's distance is `shift + t`.
        let accept = |t: f32| -> bool {
            let along = shift + t;
            if !(along > t_min && along < t_max) {
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
            return accept(t).then_some(SurfaceHit {
                t: shift + t,
                u: 0.0,
                v: 0.0,
            });
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
                return Some(SurfaceHit {
                    t: shift + t,
                    u: 0.0,
                    v: 0.0,
                });
            }
        }
        None
    }

    pub fn bounds(&self) -> Aabb {
        self.bounds_between(self.disc_extent(), 0.0, 1.0)
    }

    /// How many pieces along its height the hierarchy files the cone under
    /// (`piece_boxes`): a long tilted cylinder's box is mostly empty, and
    /// rays through that emptiness test it for nothing. The count, up to
    /// `MAX_PIECES`, whose boxes' summed surface area is least once each
    /// piece past the first is charged `PIECE_CHARGE` more (a box test and
    /// a place in a leaf).
    pub fn pieces(&self) -> u32 {
        let area = |b: Aabb| {
            let d = b.max - b.min;
            d.x * d.y + d.y * d.z + d.z * d.x
        };
        // The discs' extent once for every count (three square roots).
        let extent = self.disc_extent();
        let cost = |k: u32| {
            let sum: f32 = self.boxes_of_pieces(extent, k).map(area).sum();
            sum * (1.0 + PIECE_CHARGE * (k - 1) as f32)
        };
        let mut best = (cost(1), 1);
        for k in 2..=MAX_PIECES {
            let c = cost(k);
            if c < best.0 {
                best = (c, k);
            }
        }
        best.1
    }

    /// The bounds of `k` equal pieces of the cone's height, base first:
    /// together they cover the cone (neighbours meet at the same disc).
    pub fn piece_boxes(&self, k: u32) -> impl Iterator<Item = Aabb> + '_ {
        self.boxes_of_pieces(self.disc_extent(), k)
    }

    /// `piece_boxes`, given the discs' `disc_extent`.
    fn boxes_of_pieces(&self, extent: Vec3, k: u32) -> impl Iterator<Item = Aabb> + '_ {
        (0..k).map(move |j| {
            self.bounds_between(extent, j as f32 / k as f32, (j + 1) as f32 / k as f32)
        })
    }

    /// A disc of radius 1 across the axis reaches `sqrt(1 - axis_i^2)` along
    /// world axis `i`.
    fn disc_extent(&self) -> Vec3 {
        let e = (Vec3::ONE - self.axis * self.axis).max(Vec3::ZERO);
        Vec3::new(e.x.sqrt(), e.y.sqrt(), e.z.sqrt())
    }

    /// The bounds of the part of the cone between fractions `from` and `to`
    /// of its height (0: the base, 1: the apex): those of its two end discs.
    fn bounds_between(&self, extent: Vec3, from: f32, to: f32) -> Aabb {
        let disc = |f: f32| {
            let (c, r) = if f == 0.0 {
                (self.base, self.base_radius)
            } else if f == 1.0 {
                (self.apex, self.apex_radius)
            } else {
                (
                    self.base + (self.apex - self.base) * f,
                    self.base_radius + (self.apex_radius - self.base_radius) * f,
                )
            };
            Aabb {
                min: c - extent * r,
                max: c + extent * r,
            }
        };
        disc(from).union(disc(to))
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

    /// A branch of the SPD tree, 0.003 wide, seen from 5.7 away: the hit is
    /// where double precision puts it (found by sampling the ray), on the
    /// surface; and its twin branch from the same base, which the ray
    /// passes, is missed. Solved from the ray's origin, the first was hit
    /// 0.0018 too far and the second 0.0005 off its surface, outside its box.
    #[test]
    fn a_thin_cone_far_away_is_hit_on_its_surface() {
        let ray = Ray::new(
            Vec3::new(4.502656, 0.3701178, 2.0),
            Vec3::new(-0.99401027, -0.039903007, 0.10174145),
        );
        let base = Vec3::new(-1.18409, 0.138545, 2.57946);
        let hit = Cone::new(
            base,
            0.00273426,
            Vec3::new(-1.20492, 0.150756, 2.58267),
            0.00183195,
            false,
        )
        .expect("a cone")
        .intersect(&ray, 0.0, f32::INFINITY)
        .expect("the ray meets the branch");
        assert!((hit.t - 5.724337).abs() < 2e-5, "{}", hit.t);
        let twin = Cone::new(
            base,
            0.00273426,
            Vec3::new(-1.19309, 0.139672, 2.60017),
            0.00183195,
            false,
        )
        .expect("a cone");
        assert_eq!(twin.intersect(&ray, 0.0, f32::INFINITY), None);
    }

    /// Thin cones at distances up to 1000: every hit lies on the surface
    /// (its distance from the axis is the radius there, within 1 % of the
    /// radius and 1e-6 of the distance: 16 ulp, the rounding of a point so
    /// far) and in the cone's box grown by 1e-5 of the distance.
    #[test]
    fn thin_cones_from_afar_are_hit_on_their_surface() {
        let mut seed = 7u32;
        let mut next = || {
            seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
            (seed >> 8) as f32 / (1u32 << 24) as f32
        };
        let mut hits = 0;
        for i in 0..4000 {
            let far = [1.0f32, 10.0, 100.0, 1000.0][i % 4];
            let base = Vec3::new(next(), next(), next()) * far;
            let axis = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize();
            let r = 0.001 + 0.01 * next();
            let apex = base + axis * (10.0 * r * (0.5 + next()));
            let Some(cone) = Cone::new(base, r, apex, r * next(), false) else {
                continue;
            };
            // Aimed at a point near the cone's middle, from the origin.
            let aim =
                (base + apex) * 0.5 + Vec3::new(next(), next(), next()) * r - Vec3::splat(r * 0.5);
            let ray = Ray::new(Vec3::ZERO, aim.normalize());
            let Some(hit) = cone.intersect(&ray, 0.0, f32::INFINITY) else {
                continue;
            };
            hits += 1;
            let p =
                (ray.origin.as_dvec3() + ray.dir.as_dvec3() * f64::from(hit.t)) - base.as_dvec3();
            let w = cone.axis.as_dvec3();
            let s = p.dot(w);
            let radial = (p - w * s).length();
            let expect = f64::from(cone.base_radius) + f64::from(cone.slope) * s;
            assert!(
                (radial - expect).abs() <= 0.01 * f64::from(r) + 1e-6 * f64::from(hit.t),
                "cone {i}: {radial} against {expect}"
            );
            let b = cone.bounds();
            let pad = 1e-5 * f64::from(hit.t);
            let q = p + base.as_dvec3();
            for a in 0..3 {
                assert!(
                    q[a] >= f64::from(b.min[a]) - pad && q[a] <= f64::from(b.max[a]) + pad,
                    "cone {i}: outside its box"
                );
            }
        }
        assert!(hits > 1000, "{hits}");
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

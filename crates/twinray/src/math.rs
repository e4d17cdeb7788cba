//! Vectors (from `glam`), rays and axis-aligned boxes.

pub use glam::Vec3;

/// RGB colour, linear, one `f32` per channel.
pub type Color = Vec3;

/// A ray `origin + t * dir`. Sphere intersection assumes a unit `dir`;
/// every ray twinray generates has one, so that `t` is a distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
}

impl Ray {
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Ray { origin, dir }
    }

    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }
}

/// Axis-aligned bounding box. An empty box has `min > max`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    pub fn from_points(points: &[Vec3]) -> Aabb {
        points.iter().fold(Aabb::EMPTY, |b, &p| b.grow(p))
    }

    pub fn grow(self, p: Vec3) -> Aabb {
        Aabb {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    pub fn union(self, o: Aabb) -> Aabb {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    pub fn extent(&self) -> Vec3 {
        (self.max - self.min).max(Vec3::ZERO)
    }

    /// Surface area (half of it: the SAH only needs ratios).
    pub fn half_area(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let e = self.extent();
        e.x * e.y + e.y * e.z + e.z * e.x
    }

    /// The box grown by a relative margin so that it stays conservative under the
    /// rounding of the slab test (a primitive's hit never falls outside its boxes).
    pub fn padded(self) -> Aabb {
        let scale = self.min.abs().max(self.max.abs()).max_element().max(1e-6);
        let pad = Vec3::splat(scale * 4.0 * f32::EPSILON);
        Aabb {
            min: self.min - pad,
            max: self.max + pad,
        }
    }
}

/// Mirror reflection of the incoming direction `d` about the normal `n` (unit).
#[inline]
pub fn reflect(d: Vec3, n: Vec3) -> Vec3 {
    d - n * (2.0 * d.dot(n))
}

/// Snell refraction of the unit direction `d` through a surface whose unit normal `n`
/// faces against `d`, with `eta` = n_incident / n_transmitted. `None` on total internal
/// reflection.
#[inline]
pub fn refract(d: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = -d.dot(n);
    let k = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
    if k < 0.0 {
        None
    } else {
        Some((d * eta + n * (eta * cos_i - k.sqrt())).normalize())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reflect_flips_the_normal_component() {
        let r = reflect(Vec3::new(1.0, -1.0, 0.0), Vec3::Y);
        assert_eq!(r, Vec3::new(1.0, 1.0, 0.0));
    }

    #[test]
    fn refraction_obeys_snell() {
        let d = Vec3::new(0.6, -0.8, 0.0); // sin(theta_i) = 0.6
        let t = refract(d, Vec3::Y, 1.0 / 1.5).unwrap();
        let sin_t = t.x;
        assert!((sin_t - 0.6 / 1.5).abs() < 1e-6);
        assert!((t.length() - 1.0).abs() < 1e-6);
        assert!(t.y < 0.0);
    }

    #[test]
    fn normal_incidence_passes_straight() {
        let t = refract(-Vec3::Y, Vec3::Y, 1.0 / 1.5).unwrap();
        assert!((t - (-Vec3::Y)).length() < 1e-6);
    }

    #[test]
    fn total_internal_reflection_past_the_critical_angle() {
        // From glass (1.5) to air: critical angle asin(1/1.5) = 41.8 degrees.
        let at_50 = Vec3::new(50f32.to_radians().sin(), -50f32.to_radians().cos(), 0.0);
        assert!(refract(at_50, Vec3::Y, 1.5).is_none());
        let at_40 = Vec3::new(40f32.to_radians().sin(), -40f32.to_radians().cos(), 0.0);
        assert!(refract(at_40, Vec3::Y, 1.5).is_some());
    }

    #[test]
    fn padded_box_contains_original() {
        let b = Aabb::from_points(&[Vec3::new(1.0, 2.0, 3.0), Vec3::new(-4.0, 5.0, 6.0)]);
        let p = b.padded();
        assert!(p.min.cmple(b.min).all() && p.max.cmpge(b.max).all());
        assert!(p.min.cmplt(b.min).all());
    }
}

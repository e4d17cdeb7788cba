use super::{RayPair, SurfaceHit};
use crate::math::{Aabb, Ray, Vec3};
use std::ops::{Add, Div, Mul, Neg, Sub};
use wide::f32x4;

/// `Triangle::intersect`'s arithmetic on SIMD registers (`f32x4`, `f32x8`),
/// lane by lane: the same IEEE operations in the same order (glam's `dot` and
/// `cross` written out, no fused multiply-add), so each lane is bit for bit
/// the scalar test. Rays `dir`, `org` and triangles `v0`, `e1`, `e2`, plane
/// normal `n`, per axis; returns `det`, `u`, `v`, `t`.
#[inline(always)]
pub(super) fn intersect_lanes<V>(dir: [V; 3], org: [V; 3], tri: [[V; 3]; 4], one: V) -> [V; 4]
where
    V: Copy
        + Add<Output = V>
        + Sub<Output = V>
        + Mul<Output = V>
        + Div<Output = V>
        + Neg<Output = V>,
{
    let ([dx, dy, dz], [ox, oy, oz]) = (dir, org);
    let [[v0x, v0y, v0z], [e1x, e1y, e1z], [e2x, e2y, e2z], [nx, ny, nz]] = tri;
    // p = dir x e2
    let px = dy * e2z - e2y * dz;
    let py = dz * e2x - e2z * dx;
    let pz = dx * e2y - e2x * dy;
    let det = e1x * px + e1y * py + e1z * pz;
    let inv = one / det;
    let (sx, sy, sz) = (ox - v0x, oy - v0y, oz - v0z);
    let u = (sx * px + sy * py + sz * pz) * inv;
    // q = s x e1
    let qx = sy * e1z - e1y * sz;
    let qy = sz * e1x - e1z * sx;
    let qz = sx * e1y - e1x * sy;
    let v = (dx * qx + dy * qy + dz * qz) * inv;
    let t = -(nx * sx + ny * sy + nz * sz) / (nx * dx + ny * dy + nz * dz);
    [det, u, v, t]
}

/// The lanes of `intersect_lanes`' answer that `Triangle::intersect` keeps,
/// (`[det, u, v, t]`), as a bit mask: the scalar tests lane by lane (NaN fails
/// `contains` and the t range, passes the v test, as there). `$lo`, `$hi`: the
/// t range per lane.
macro_rules! kept_lanes {
    ($ty:ty, $found:expr, $lo:expr, $hi:expr) => {{
        let (zero, one) = (<$ty>::ZERO, <$ty>::ONE);
        let [det, u, v, t]: [$ty; 4] = $found;
        !det.simd_eq(zero).to_bitmask()
            & (u.simd_ge(zero) & u.simd_le(one)).to_bitmask()
            & !(v.simd_lt(zero) | (u + v).simd_gt(one)).to_bitmask()
            & (t.simd_gt($lo) & t.simd_lt($hi)).to_bitmask()
    }};
}
pub(super) use kept_lanes;

/// Texture coordinates of a point on a surface.
pub type Uv = glam::Vec2;

/// Attributes of a triangle's three corners (`TriangleNormals::Patch` indexes
/// them): normals for smooth shading, texture coordinates. They belong to the
/// geometry; the scene keeps them in one table (`Scene::corners`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Corners {
    pub normals: Option<[Vec3; 3]>,
    pub uv: Option<[Uv; 3]>,
}

/// Where a triangle's shading normal comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TriangleNormals {
    /// Flat: the face normal of the polygon the triangle was cut from.
    Flat,
    /// Index into the scene's per-corner attributes (`Scene::corners`): normals
    /// of a smooth triangle (NFF `pp`, OBJ `vn`, glTF `NORMAL`), texture coordinates.
    Patch(u32),
}

/// A triangle stored for Möller–Trumbore: one vertex and two edges.
#[derive(Clone, Debug, PartialEq)]
pub struct Triangle {
    pub v0: Vec3,
    pub e1: Vec3,
    pub e2: Vec3,
    /// Unit normal of the source polygon, orientation from its vertex order.
    pub face_normal: Vec3,
    pub normals: TriangleNormals,
    /// Unit normal of this triangle's own plane, computed in double precision
    /// from the vertices: a well-conditioned distance even on thin slivers
    /// (see `intersect`).
    pub plane_normal: Vec3,
}

impl Triangle {
    pub fn new(a: Vec3, b: Vec3, c: Vec3, face_normal: Vec3, normals: TriangleNormals) -> Self {
        let (a64, b64, c64) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
        let plane_normal = (b64 - a64)
            .cross(c64 - a64)
            .try_normalize()
            .map_or(face_normal, |n| n.as_vec3());
        Triangle {
            v0: a,
            e1: b - a,
            e2: c - a,
            face_normal,
            normals,
            plane_normal,
        }
    }

    #[inline(always)]
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<SurfaceHit> {
        let p = ray.dir.cross(self.e2);
        let det = self.e1.dot(p);
        if det == 0.0 {
            return None;
        }
        let inv = 1.0 / det;
        let s = ray.origin - self.v0;
        let u = s.dot(p) * inv;
        if !(0.0..=1.0).contains(&u) {
            return None;
        }
        let q = s.cross(self.e1);
        let v = ray.dir.dot(q) * inv;
        if v < 0.0 || u + v > 1.0 {
            return None;
        }
        // The distance from the plane, not Möller–Trumbore's `e2·q / det`: on
        // the thin slivers a many-vertex polygon is cut into, that loses its
        // precision (a hit point off the plane by more than the offset of the
        // shadow ray, or a hit behind the origin) and the polygon shadowed
        // itself. The plane's normal was computed in double precision.
        let t = -self.plane_normal.dot(s) / self.plane_normal.dot(ray.dir);
        if t > t_min && t < t_max {
            Some(SurfaceHit { t, u, v })
        } else {
            None
        }
    }

    /// `intersect` for two rays at once, in the lanes of one SSE register: the
    /// same IEEE operations in the same order as `intersect` (glam's `dot` and
    /// `cross` written out), so each lane's answer is bit for bit the single one.
    #[inline(always)]
    pub fn intersect_pair(
        &self,
        rays: &RayPair,
        t_min: f32,
        t_max: [f32; 2],
    ) -> [Option<SurfaceHit>; 2] {
        let sp = |v: Vec3| [v.x, v.y, v.z].map(f32x4::splat);
        let tri = [self.v0, self.e1, self.e2, self.plane_normal].map(sp);
        let found = intersect_lanes(rays.dir, rays.origin, tri, f32x4::ONE);
        let hi = f32x4::from([t_max[0], t_max[1], 0.0, 0.0]);
        let keep = kept_lanes!(f32x4, found, f32x4::splat(t_min), hi);
        let [_, u, v, t] = found;
        let (t, u, v) = (t.to_array(), u.to_array(), v.to_array());
        std::array::from_fn(|l| {
            (keep & (1 << l) != 0).then_some(SurfaceHit {
                t: t[l],
                u: u[l],
                v: v[l],
            })
        })
    }

    pub fn bounds(&self) -> Aabb {
        Aabb::from_points(&[self.v0, self.v0 + self.e1, self.v0 + self.e2])
    }

    #[inline]
    pub fn normal(&self, hit: &SurfaceHit, corners: &[Corners]) -> Vec3 {
        match self.normals {
            TriangleNormals::Flat => self.face_normal,
            TriangleNormals::Patch(i) => {
                let Some([n0, n1, n2]) = corners[i as usize].normals else {
                    return self.face_normal;
                };
                let n = n0 * (1.0 - hit.u - hit.v) + n1 * hit.u + n2 * hit.v;
                let n = n.normalize_or_zero();
                if n == Vec3::ZERO {
                    self.face_normal
                } else {
                    n
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri() -> Triangle {
        Triangle::new(
            Vec3::new(0.0, 0.0, 2.0),
            Vec3::new(1.0, 0.0, 2.0),
            Vec3::new(0.0, 1.0, 2.0),
            Vec3::new(0.0, 0.0, 1.0),
            TriangleNormals::Flat,
        )
    }

    #[test]
    fn hits_inside_with_barycentrics() {
        let ray = Ray::new(Vec3::new(0.25, 0.5, 0.0), Vec3::Z);
        let h = tri().intersect(&ray, 0.0, f32::INFINITY).unwrap();
        assert!((h.t - 2.0).abs() < 1e-6);
        assert!((h.u - 0.25).abs() < 1e-6 && (h.v - 0.5).abs() < 1e-6);
    }

    #[test]
    fn hits_from_behind_too() {
        let ray = Ray::new(Vec3::new(0.25, 0.25, 4.0), -Vec3::Z);
        assert!(tri().intersect(&ray, 0.0, f32::INFINITY).is_some());
    }

    #[test]
    fn misses_outside_and_parallel() {
        let ray = Ray::new(Vec3::new(0.75, 0.75, 0.0), Vec3::Z);
        assert!(tri().intersect(&ray, 0.0, f32::INFINITY).is_none());
        let par = Ray::new(Vec3::new(-1.0, 0.2, 2.0), Vec3::X);
        assert!(tri().intersect(&par, 0.0, f32::INFINITY).is_none());
    }

    #[test]
    fn respects_interval() {
        let ray = Ray::new(Vec3::new(0.25, 0.25, 0.0), Vec3::Z);
        assert!(tri().intersect(&ray, 0.0, 1.9).is_none());
        assert!(tri().intersect(&ray, 2.1, 9.0).is_none());
    }

    #[test]
    fn patch_normals_interpolate() {
        let mut t = tri();
        t.normals = TriangleNormals::Patch(0);
        let normals = [Corners {
            normals: Some([Vec3::X, Vec3::Y, Vec3::Z]),
            uv: None,
        }];
        let h = SurfaceHit {
            t: 1.0,
            u: 0.0,
            v: 0.0,
        };
        assert!((t.normal(&h, &normals) - Vec3::X).length() < 1e-6);
        let h = SurfaceHit {
            t: 1.0,
            u: 0.5,
            v: 0.5,
        };
        let expect = Vec3::new(0.0, 1.0, 1.0).normalize();
        assert!((t.normal(&h, &normals) - expect).length() < 1e-6);
    }
}

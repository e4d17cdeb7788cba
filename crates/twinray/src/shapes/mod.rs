//! The geometric primitives NFF describes, dispatched over a closed set.
//!
//! Polygons and polygonal patches become triangles when the scene is built
//! (see `scene.rs`); a triangle keeps the normal of the polygon it came from,
//! or the per-vertex normals of its patch, so shading never sees the split.

mod cone;
mod lanes8;
mod sphere;
mod triangle;
mod triangle4;

pub use cone::Cone;
pub use lanes8::{EightHits, EightRays};
pub use sphere::Sphere;
pub use triangle::{Corners, Triangle, TriangleNormals, Uv};
pub use triangle4::{BlockHits, LeafBlocks, Triangle4, BLOCK};

use crate::math::{Aabb, Ray, Vec3};
use wide::f32x4;

/// Two rays in lanes 0 and 1 of SSE registers, component by component: the
/// form the pair tests work on.
#[derive(Clone, Copy, Debug)]
pub struct RayPair {
    pub origin: [f32x4; 3],
    pub dir: [f32x4; 3],
}

impl RayPair {
    #[inline(always)]
    pub fn new(rays: &[Ray; 2]) -> RayPair {
        let lanes = |f: fn(&Ray) -> f32| f32x4::from([f(&rays[0]), f(&rays[1]), 0.0, 0.0]);
        RayPair {
            origin: [
                lanes(|r| r.origin.x),
                lanes(|r| r.origin.y),
                lanes(|r| r.origin.z),
            ],
            dir: [lanes(|r| r.dir.x), lanes(|r| r.dir.y), lanes(|r| r.dir.z)],
        }
    }
}

/// Where a ray met a primitive: the distance and the surface coordinates the
/// normal needs (barycentrics for triangles, unused otherwise).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceHit {
    pub t: f32,
    pub u: f32,
    pub v: f32,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    Sphere(Sphere),
    Triangle(Triangle),
    Cone(Cone),
}

impl Shape {
    /// The nearest intersection with `t_min < t < t_max`.
    #[inline(always)]
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<SurfaceHit> {
        match self {
            Shape::Sphere(s) => s.intersect(ray, t_min, t_max),
            Shape::Triangle(t) => t.intersect(ray, t_min, t_max),
            Shape::Cone(c) => c.intersect(ray, t_min, t_max),
        }
    }

    /// `intersect` for eight rays at once (`shapes::lanes8`), bit for bit
    /// the single answers; `None` for a triangle (its leaves have blocks).
    #[inline(always)]
    pub fn intersect8(
        &self,
        rays: &EightRays,
        t_min: f32,
        t_max: wide::f32x8,
    ) -> Option<EightHits> {
        match self {
            Shape::Sphere(s) => Some(s.intersect8(rays, t_min, t_max)),
            Shape::Cone(c) => Some(c.intersect8(rays, t_min, t_max)),
            Shape::Triangle(_) => None,
        }
    }

    /// `intersect` for two rays at once: the same answers, cheaper for the
    /// shapes that test both in one register.
    #[inline(always)]
    pub fn intersect_pair(
        &self,
        rays: &[Ray; 2],
        t_min: f32,
        t_max: [f32; 2],
    ) -> [Option<SurfaceHit>; 2] {
        match self {
            Shape::Sphere(s) => s.intersect_pair(&RayPair::new(rays), t_min, t_max),
            Shape::Triangle(t) => t.intersect_pair(&RayPair::new(rays), t_min, t_max),
            Shape::Cone(c) => {
                // Both rays in one eight-lane test (lanes 2-7 repeat ray 0).
                let eight = EightRays::of_packet(2, |l| rays[l]);
                let far = std::array::from_fn(|l| if l < 2 { t_max[l] } else { t_max[0] });
                let hits = c.intersect8(&eight, t_min, wide::f32x8::from(far));
                [hits.hit(0), hits.hit(1)]
            }
        }
    }

    pub fn bounds(&self) -> Aabb {
        match self {
            Shape::Sphere(s) => s.bounds(),
            Shape::Triangle(t) => t.bounds(),
            Shape::Cone(c) => c.bounds(),
        }
    }

    /// The oriented unit normal at `point` (outward, or inward for NFF's negative
    /// radii), and for patches the interpolated shading normal.
    pub fn normal(&self, point: Vec3, hit: &SurfaceHit, corners: &[Corners]) -> Vec3 {
        match self {
            Shape::Sphere(s) => s.normal(point),
            Shape::Triangle(t) => t.normal(hit, corners),
            Shape::Cone(c) => c.normal(point),
        }
    }

    /// The geometric normal (for triangles the face normal, even for patches):
    /// tells on which side of the surface a point lies.
    pub fn geometric_normal(&self, point: Vec3) -> Vec3 {
        match self {
            Shape::Sphere(s) => s.normal(point),
            Shape::Triangle(t) => t.face_normal,
            Shape::Cone(c) => c.normal(point),
        }
    }

    /// Whether a ray along `dir` meets the surface at `point` on its front,
    /// against the geometric normal: entering a closed shape, or seeing the
    /// face a triangle's normal points out of. Views either side of a
    /// surface's plane meet its two faces.
    #[inline]
    pub fn met_from_front(&self, point: Vec3, dir: Vec3) -> bool {
        self.geometric_normal(point).dot(dir) < 0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn vec(g: &mut fastrand::Rng, scale: f32) -> Vec3 {
        Vec3::new(g.f32() - 0.5, g.f32() - 0.5, g.f32() - 0.5) * scale
    }

    fn bits(h: &Option<SurfaceHit>) -> Option<[u32; 3]> {
        h.map(|h| [h.t.to_bits(), h.u.to_bits(), h.v.to_bits()])
    }

    /// The pair test is what two single tests give, bit for bit, including rays
    /// aimed at edges and vertices and rays starting on the surface.
    #[test]
    fn pair_tests_equal_single_tests() {
        let mut g = fastrand::Rng::with_seed(11);
        let (mut hits, mut cases) = (0, 0);
        for _ in 0..400 {
            let (a, b, c) = (vec(&mut g, 4.0), vec(&mut g, 4.0), vec(&mut g, 4.0));
            let face = (b - a).cross(c - a).normalize_or_zero();
            let shapes = [
                Shape::Sphere(Sphere {
                    center: vec(&mut g, 4.0),
                    radius: 0.2 + g.f32(),
                    inside: false,
                }),
                Shape::Triangle(Triangle::new(a, b, c, face, TriangleNormals::Flat)),
                Shape::Cone(
                    Cone::new(a, 0.5 + g.f32(), b, 0.1 * g.f32(), false)
                        .unwrap_or_else(|| panic!("cone")),
                ),
            ];
            for shape in &shapes {
                for k in 0..30 {
                    // Aim at a vertex, an edge point or a random point of the shape's box.
                    let bounds = shape.bounds();
                    let target = match k % 3 {
                        0 => a,
                        1 => a + (b - a) * g.f32(),
                        _ => bounds.min + (bounds.max - bounds.min) * g.f32(),
                    };
                    let o0 = vec(&mut g, 20.0);
                    let o1 = if k % 2 == 0 {
                        o0 + vec(&mut g, 0.2)
                    } else {
                        target
                    };
                    let rays = [o0, o1].map(|o| Ray::new(o, (target - o).normalize_or(Vec3::Z)));
                    let t_max = [f32::INFINITY, 5.0 + 20.0 * g.f32()];
                    let pair = shape.intersect_pair(&rays, 1e-4, t_max);
                    for l in 0..2 {
                        let single = shape.intersect(&rays[l], 1e-4, t_max[l]);
                        assert_eq!(bits(&pair[l]), bits(&single), "{shape:?} {:?}", rays[l]);
                        hits += single.is_some() as u32;
                        cases += 1;
                    }
                }
            }
        }
        // The rays must actually hit often for the comparison to mean something.
        assert!(hits > cases / 4, "{hits} hits of {cases}");
    }
}

//! The geometric primitives NFF describes, dispatched over a closed set.
//!
//! Polygons and polygonal patches become triangles when the scene is built
//! (see `scene.rs`); a triangle keeps the normal of the polygon it came from,
//! or the per-vertex normals of its patch, so shading never sees the split.

mod cone;
mod sphere;
mod triangle;

pub use cone::Cone;
pub use sphere::Sphere;
pub use triangle::{Triangle, TriangleNormals};

use crate::math::{Aabb, Ray, Vec3};

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

    pub fn bounds(&self) -> Aabb {
        match self {
            Shape::Sphere(s) => s.bounds(),
            Shape::Triangle(t) => t.bounds(),
            Shape::Cone(c) => c.bounds(),
        }
    }

    /// The oriented unit normal at `point` (outward, or inward for NFF's negative
    /// radii), and for patches the interpolated shading normal.
    pub fn normal(&self, point: Vec3, hit: &SurfaceHit, patch_normals: &[[Vec3; 3]]) -> Vec3 {
        match self {
            Shape::Sphere(s) => s.normal(point),
            Shape::Triangle(t) => t.normal(hit, patch_normals),
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
}

//! A leaf's spheres and cones four to a block, component by component, so
//! that one ray culls the four in one SIMD stream (`wide::f32x4`) before the
//! exact tests.
//!
//! Exactness: a lane is culled only where the scalar test (`Sphere::intersect`,
//! `Cone::intersect`) would return `None` by its first rejection. Each lane
//! computes that test's quantities with its IEEE operations in the same order
//! (glam's `dot` written out, no fused multiply-add: Rust never fuses on its
//! own), so the sphere's `d2 > r2` and the cone's `disc < 0` (outside its
//! parallel-ray branch) are bit for bit the scalar comparisons. A lane that
//! passes, or that holds another shape, is tested by the scalar routine, which
//! alone gives the hit: the answers are those of the one-by-one tests.

use super::{Shape, BLOCK};
use crate::math::Ray;
use wide::f32x4;

/// Up to four spheres and cones: per lane a sphere's centre and squared
/// radius, or a cone's base, unit axis, slope and base radius. 128 bytes and
/// the two lane masks.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct Quadric4 {
    /// Sphere: centre. Cone: base.
    p: [f32x4; 3],
    /// Cone: unit axis (zero in sphere lanes).
    w: [f32x4; 3],
    /// Cone: radius change per unit of height.
    k: f32x4,
    /// Sphere: radius squared. Cone: base radius.
    r: f32x4,
    /// Bit `i`: lane `i` holds a sphere.
    spheres: u8,
    /// Bit `i`: lane `i` holds a cone.
    cones: u8,
}

impl Quadric4 {
    /// The block of `shapes` (at most `BLOCK`); lanes of other shapes are
    /// never culled.
    pub fn new(shapes: &[&Shape]) -> Quadric4 {
        assert!(shapes.len() <= BLOCK, "{} shapes in a block", shapes.len());
        let mut lanes = [[0.0f32; 8]; BLOCK];
        let (mut spheres, mut cones) = (0u8, 0u8);
        for (i, shape) in shapes.iter().enumerate() {
            match shape {
                Shape::Sphere(s) => {
                    let c = s.center;
                    // `Sphere::intersect`'s r2, the same product.
                    lanes[i] = [c.x, c.y, c.z, 0.0, 0.0, 0.0, 0.0, s.radius * s.radius];
                    spheres |= 1 << i;
                }
                Shape::Cone(c) => {
                    let (w, k) = c.axis_and_slope();
                    let b = c.base;
                    lanes[i] = [b.x, b.y, b.z, w.x, w.y, w.z, k, c.base_radius];
                    cones |= 1 << i;
                }
                Shape::Triangle(_) => {}
            }
        }
        let field = |f: usize| f32x4::from(std::array::from_fn::<f32, BLOCK, _>(|i| lanes[i][f]));
        Quadric4 {
            p: [field(0), field(1), field(2)],
            w: [field(3), field(4), field(5)],
            k: field(6),
            r: field(7),
            spheres,
            cones,
        }
    }

    /// Whether the block holds any sphere or cone (else it culls nothing).
    pub fn culls(&self) -> bool {
        self.spheres | self.cones != 0
    }

    /// The lanes `ray` may hit: bit `i` clear only where lane `i`'s scalar
    /// test rejects `ray` whatever its `t` range (set for other shapes and
    /// unused lanes).
    #[inline(always)]
    pub fn may_hit(&self, ray: &Ray) -> u32 {
        let sp = f32x4::splat;
        let d = [ray.dir.x, ray.dir.y, ray.dir.z].map(sp);
        let o = [ray.origin.x, ray.origin.y, ray.origin.z].map(sp);
        let dot = |a: &[f32x4; 3], b: &[f32x4; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let mut missed = 0u32;
        if self.spheres != 0 {
            // Sphere::intersect: oc, tc, closest, d2 > r2.
            let oc = [0, 1, 2].map(|a| self.p[a] - o[a]);
            let tc = dot(&oc, &d);
            let closest = [0, 1, 2].map(|a| oc[a] - d[a] * tc);
            let d2 = dot(&closest, &closest);
            missed |= d2.simd_gt(self.r).to_bitmask() & self.spheres as u32;
        }
        if self.cones != 0 {
            // Cone::intersect up to its discriminant, lane by lane the same
            // operations; the parallel branch (|a| < 1e-12) is never culled.
            let (w, k) = (&self.w, self.k);
            let co = [0, 1, 2].map(|a| o[a] - self.p[a]);
            let dw = dot(&d, w);
            let cw = dot(&co, w);
            let dp = [0, 1, 2].map(|a| d[a] - w[a] * dw);
            let cp = [0, 1, 2].map(|a| co[a] - w[a] * cw);
            let r0 = self.r + k * cw;
            let a = dot(&dp, &dp) - k * k * dw * dw;
            let b = dot(&cp, &dp) - k * dw * r0;
            let c = dot(&cp, &cp) - r0 * r0;
            let disc = b * b - a * c;
            let parallel = a.abs().simd_lt(sp(1e-12));
            let culled = disc.simd_lt(sp(0.0)) & !parallel;
            missed |= culled.to_bitmask() & self.cones as u32;
        }
        !missed & 0xf
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;
    use crate::shapes::{Cone, Sphere, Triangle, TriangleNormals};

    fn vec(g: &mut fastrand::Rng, scale: f32) -> Vec3 {
        Vec3::new(g.f32() - 0.5, g.f32() - 0.5, g.f32() - 0.5) * scale
    }

    fn sphere(center: Vec3, radius: f32) -> Shape {
        Shape::Sphere(Sphere {
            center,
            radius,
            inside: false,
        })
    }

    /// The whole line's hits: `intersect` over every finite `t`.
    fn meets(shape: &Shape, ray: &Ray) -> bool {
        shape.intersect(ray, f32::MIN, f32::MAX).is_some()
    }

    /// A random sphere, cone or triangle near the origin, with radius-0,
    /// huge and tiny spheres and cylinders among them.
    fn shape(g: &mut fastrand::Rng, round: usize) -> Shape {
        let c = vec(g, 6.0);
        match g.usize(0..9) {
            0 => sphere(c, 0.0),
            1 => sphere(c, 1e4),
            2 | 3 => sphere(c, 0.05 + 2.0 * g.f32()),
            4 => Shape::Triangle(Triangle::new(
                c,
                c + Vec3::X,
                c + Vec3::Y,
                Vec3::Z,
                TriangleNormals::Flat,
            )),
            k => {
                let top = c + vec(g, 4.0);
                let (rb, ra) = match k {
                    5 => (0.3, 0.3),
                    6 => (0.8 * g.f32(), 0.0),
                    _ => (g.f32(), g.f32()),
                };
                Cone::new(c, rb, top, ra, round.is_multiple_of(2))
                    .map(Shape::Cone)
                    .unwrap_or_else(|| sphere(c, 1.0))
            }
        }
    }

    /// A lane is culled only where its scalar test misses the whole line, and
    /// a sphere lane is culled exactly where it misses (the scalar's own
    /// `d2 > r2`): random spheres (radius 0, huge), cones, cylinders and
    /// triangles in every lane, rays from outside and from inside, rays aimed
    /// at the centre, at the surface and past it.
    #[test]
    fn culls_only_what_the_scalar_test_misses() {
        let mut g = fastrand::Rng::with_seed(31);
        let (mut culled, mut met, mut cases) = (0, 0, 0);
        for round in 0..20_000 {
            let n = 1 + round % BLOCK;
            let shapes: Vec<Shape> = (0..n).map(|_| shape(&mut g, round)).collect();
            let refs: Vec<&Shape> = shapes.iter().collect();
            let block = Quadric4::new(&refs);
            let aim = &shapes[g.usize(0..n)];
            let b = aim.bounds();
            let target = match round % 4 {
                0 => b.center(),
                1 => b.min + (b.max - b.min) * g.f32(),
                2 => b.max,
                _ => vec(&mut g, 8.0),
            };
            let origin = if round % 5 == 0 {
                b.center() // inside a sphere, or on a cone's axis
            } else {
                vec(&mut g, 40.0)
            };
            let ray = Ray::new(origin, (target - origin).normalize_or(Vec3::Z));
            let live = block.may_hit(&ray);
            assert_eq!(live >> n, 0xf >> n, "unused lanes are never culled");
            for (i, s) in shapes.iter().enumerate() {
                let kept = live & (1 << i) != 0;
                let hit = meets(s, &ray);
                cases += 1;
                met += hit as u32;
                if !kept {
                    culled += 1;
                    assert!(
                        !hit,
                        "round {round}, lane {i}: culled a hit of {s:?} by {ray:?}"
                    );
                    assert!(s.intersect(&ray, 1e-4, f32::INFINITY).is_none());
                }
                match s {
                    Shape::Sphere(_) => assert_eq!(kept, hit, "round {round}, lane {i}: {s:?}"),
                    Shape::Triangle(_) => assert!(kept, "triangles are never culled"),
                    Shape::Cone(_) => {}
                }
            }
        }
        assert!(culled > cases / 3, "{culled} culled of {cases}");
        assert!(met > cases / 5, "{met} met of {cases}");
    }

    /// A ray tangent to a sphere (the scalar's `d2 == r2`, a hit) is kept in
    /// every lane, and the same ray just past the sphere is culled.
    #[test]
    fn a_tangent_ray_is_kept_in_every_lane() {
        let s = sphere(Vec3::new(0.0, 0.0, 5.0), 1.0);
        let tangent = Ray::new(Vec3::new(1.0, 0.0, 0.0), Vec3::Z);
        let past = Ray::new(Vec3::new(1.0f32.next_up(), 0.0, 0.0), Vec3::Z);
        assert!(meets(&s, &tangent) && !meets(&s, &past));
        let far = sphere(Vec3::new(50.0, 0.0, 0.0), 1.0);
        for lane in 0..BLOCK {
            let mut refs = vec![&far; BLOCK];
            refs[lane] = &s;
            let block = Quadric4::new(&refs);
            assert_eq!(block.may_hit(&tangent), 1 << lane, "lane {lane}");
            assert_eq!(block.may_hit(&past), 0, "lane {lane}");
        }
    }

    /// A cone lane keeps a ray parallel to a generating line (the scalar's
    /// linear branch), and culls a ray that passes beside the cone.
    #[test]
    fn cone_lanes_keep_parallel_rays_and_cull_rays_beside() {
        let cone =
            Shape::Cone(Cone::new(Vec3::ZERO, 1.0, Vec3::new(0.0, 0.0, 2.0), 0.0, false).unwrap());
        // Parallel to the generating line from (1, 0, 0) to the apex.
        let along = Ray::new(
            Vec3::new(3.0, 0.0, -4.0),
            Vec3::new(-1.0, 0.0, 2.0).normalize(),
        );
        let beside = Ray::new(Vec3::new(-5.0, 3.0, 1.0), Vec3::X);
        let through = Ray::new(Vec3::new(-5.0, 0.0, 1.0), Vec3::X);
        for lane in 0..BLOCK {
            let other = sphere(Vec3::new(50.0, 50.0, 50.0), 1.0);
            let mut refs = vec![&other; BLOCK];
            refs[lane] = &cone;
            let block = Quadric4::new(&refs);
            assert_eq!(block.may_hit(&along), 1 << lane, "lane {lane}");
            assert_eq!(block.may_hit(&beside), 0, "lane {lane}");
            assert_eq!(block.may_hit(&through), 1 << lane, "lane {lane}");
            assert!(meets(&cone, &through) && !meets(&cone, &beside));
        }
    }
}

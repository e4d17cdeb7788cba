//! Eight rays against one sphere or one cone at once, a ray in each lane of
//! an AVX register (`wide::f32x8`): the test of a leaf's primitive for the
//! eight segments of a shadow packet, which start a fraction of a pixel apart
//! and mostly enter the same leaves. A primitive test is a chain of dependent
//! operations (products, a square root, divisions), so eight side by side
//! take about the time of one.
//!
//! Exactness: each lane does the scalar test's IEEE operations in the same
//! order (glam's `dot` written out as `x + y + z`, no fused multiply-add:
//! Rust never fuses on its own; `sqrt` and division are correctly rounded in
//! SIMD as in scalar; `copysign` is a sign-bit copy), and its branches become
//! per-lane selections that pick what the scalar branch returns. So lane `l`
//! hits, at the same `t` bit for bit, exactly when `Sphere::intersect` or
//! `Cone::intersect` of ray `l` does.

use super::{Cone, Sphere, SurfaceHit};
use crate::math::{Ray, Vec3};
use wide::f32x8;

/// Eight rays, component by component (lane `l`: ray `l`).
#[derive(Clone, Copy, Debug)]
pub struct EightRays {
    pub origin: [f32x8; 3],
    pub dir: [f32x8; 3],
}

/// What a test of eight rays found: bit `l` of `mask` set where ray `l`
/// hits, at distance `t[l]`.
#[derive(Clone, Copy, Debug)]
pub struct EightHits {
    pub mask: u32,
    pub t: [f32; 8],
}

impl EightHits {
    /// Lane `l`'s hit, as the single test returns it (a sphere's or a
    /// cone's `u` and `v` are 0).
    #[inline(always)]
    pub fn hit(&self, l: usize) -> Option<SurfaceHit> {
        (self.mask & (1 << l) != 0).then_some(SurfaceHit {
            t: self.t[l],
            u: 0.0,
            v: 0.0,
        })
    }
}

impl EightRays {
    /// The first `count` lanes are `ray(l)`; the lanes past them repeat
    /// lane 0 (a packet of fewer than eight rays).
    #[inline(always)]
    pub fn of_packet(count: usize, ray: impl Fn(usize) -> Ray) -> EightRays {
        EightRays::new(|l| ray(if l < count { l } else { 0 }))
    }

    /// Lane `l` is `ray(l)`.
    #[inline(always)]
    pub fn new(ray: impl Fn(usize) -> Ray) -> EightRays {
        let rays: [Ray; 8] = std::array::from_fn(ray);
        let lanes = |f: &dyn Fn(&Ray) -> f32| {
            f32x8::from(std::array::from_fn::<f32, 8, _>(|l| f(&rays[l])))
        };
        EightRays {
            origin: [
                lanes(&|r| r.origin.x),
                lanes(&|r| r.origin.y),
                lanes(&|r| r.origin.z),
            ],
            dir: [
                lanes(&|r| r.dir.x),
                lanes(&|r| r.dir.y),
                lanes(&|r| r.dir.z),
            ],
        }
    }
}

/// `v` in every lane, per component.
#[inline(always)]
fn splat3(v: Vec3) -> [f32x8; 3] {
    [f32x8::splat(v.x), f32x8::splat(v.y), f32x8::splat(v.z)]
}

/// glam's `a.dot(b)`: `(a.x * b.x) + (a.y * b.y) + (a.z * b.z)`.
#[inline(always)]
fn dot(a: &[f32x8; 3], b: &[f32x8; 3]) -> f32x8 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `a - b * s` per component, as glam's `a - b * s`.
#[inline(always)]
fn minus_scaled(a: &[f32x8; 3], b: &[f32x8; 3], s: f32x8) -> [f32x8; 3] {
    [a[0] - b[0] * s, a[1] - b[1] * s, a[2] - b[2] * s]
}

/// `f32::copysign(magnitude, sign)` per lane: the sign bit of `sign` on the
/// magnitude of `magnitude`.
#[inline(always)]
fn copysign(magnitude: f32x8, sign: f32x8) -> f32x8 {
    let bit = f32x8::splat(-0.0);
    (magnitude & !bit) | (sign & bit)
}

impl Sphere {
    /// `intersect` for eight rays, each lane bit for bit the single test's
    /// answer (`t_min` shared, `t_max` per lane).
    #[inline(always)]
    pub fn intersect8(&self, rays: &EightRays, t_min: f32, t_max: f32x8) -> EightHits {
        let c = splat3(self.center);
        let oc = [
            c[0] - rays.origin[0],
            c[1] - rays.origin[1],
            c[2] - rays.origin[2],
        ];
        let tc = dot(&oc, &rays.dir);
        let closest = minus_scaled(&oc, &rays.dir, tc);
        let d2 = dot(&closest, &closest);
        let r2 = f32x8::splat(self.radius * self.radius);
        let near = d2.simd_le(r2);
        let half = (r2 - d2).sqrt();
        let (t0, t1) = (tc - half, tc + half);
        let lo = f32x8::splat(t_min);
        let in0 = t0.simd_gt(lo) & t0.simd_lt(t_max);
        let in1 = t1.simd_gt(lo) & t1.simd_lt(t_max);
        let mask = (near & (in0 | in1)).to_bitmask();
        EightHits {
            mask,
            t: in0.select(t0, t1).to_array(),
        }
    }
}

impl Cone {
    /// `intersect` for eight rays, each lane bit for bit the single test's
    /// answer (`t_min` shared, `t_max` per lane).
    #[inline(always)]
    pub fn intersect8(&self, rays: &EightRays, t_min: f32, t_max: f32x8) -> EightHits {
        let sp = f32x8::splat;
        let w = splat3(self.axis);
        let base = splat3(self.base);
        let k = sp(self.slope);
        let d = &rays.dir;
        let to_base = [
            base[0] - rays.origin[0],
            base[1] - rays.origin[1],
            base[2] - rays.origin[2],
        ];
        let shift = dot(&to_base, d);
        let co = [
            (rays.origin[0] + d[0] * shift) - base[0],
            (rays.origin[1] + d[1] * shift) - base[1],
            (rays.origin[2] + d[2] * shift) - base[2],
        ];
        let dw = dot(d, &w);
        let cw = dot(&co, &w);
        let dp = minus_scaled(d, &w, dw);
        let cp = minus_scaled(&co, &w, cw);
        let r0 = sp(self.base_radius) + k * cw;
        let a = dot(&dp, &dp) - sp(self.slope_squared) * dw * dw;
        let b = dot(&cp, &dp) - k * dw * r0;
        let c = dot(&cp, &cp) - r0 * r0;
        let (lo, height, radius) = (sp(t_min), sp(self.height), sp(self.base_radius));
        let accept = |t: f32x8| {
            let along = shift + t;
            let s = cw + t * dw;
            along.simd_gt(lo)
                & along.simd_lt(t_max)
                & s.simd_ge(f32x8::ZERO)
                & s.simd_le(height)
                & (radius + k * s).simd_ge(f32x8::ZERO)
        };
        // A ray parallel to a generating line: one root of the linear equation.
        let linear = (a & !sp(-0.0)).simd_lt(sp(1e-12));
        let t_linear = -c / (sp(2.0) * b);
        let linear_hit = linear & b.simd_ne(f32x8::ZERO) & accept(t_linear);
        // Otherwise the numerically stable pair of roots, nearer first.
        let disc = b * b - a * c;
        let sq = disc.sqrt();
        let q = -(b + copysign(sq, b));
        let q_over_a = q / a;
        let (r0, r1) = (q_over_a, q.simd_ne(f32x8::ZERO).select(c / q, q_over_a));
        let swap = r0.simd_gt(r1);
        let (t0, t1) = (swap.select(r1, r0), swap.select(r0, r1));
        let (in0, in1) = (accept(t0), accept(t1));
        let roots = !linear & disc.simd_ge(f32x8::ZERO);
        let quadratic_hit = roots & (in0 | in1);
        let t = linear.select(t_linear, in0.select(t0, t1));
        EightHits {
            mask: (linear_hit | quadratic_hit).to_bitmask(),
            t: (shift + t).to_array(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn vec(g: &mut fastrand::Rng, scale: f32) -> Vec3 {
        Vec3::new(g.f32() - 0.5, g.f32() - 0.5, g.f32() - 0.5) * scale
    }

    fn bits(h: Option<SurfaceHit>) -> Option<u32> {
        h.map(|h| h.t.to_bits())
    }

    fn lanes(h: &EightHits) -> [Option<u32>; 8] {
        std::array::from_fn(|l| bits(h.hit(l)))
    }

    /// Eight rays of one of several kinds: toward the shape from afar, from
    /// points on its surface outward (shadow segments), along its axis, and
    /// parallel to a cone's generating line (the linear case).
    fn rays_at(g: &mut fastrand::Rng, target: Vec3, on: &[Vec3], axis: Vec3) -> [Ray; 8] {
        let kind = g.u8(..4);
        std::array::from_fn(|l| {
            let (origin, dir) = match kind {
                0 => {
                    let o = vec(g, 12.0);
                    (o, (target + vec(g, 2.0) - o).normalize())
                }
                1 => {
                    let o = on[l % on.len()];
                    (o, vec(g, 2.0).normalize())
                }
                2 => (target - axis * 5.0 + vec(g, 0.2), axis),
                _ => (vec(g, 6.0), (axis + vec(g, 1e-3)).normalize()),
            };
            Ray::new(origin, dir)
        })
    }

    /// Lane by lane what the scalar tests give, bit for bit, on random
    /// spheres and cones (cylinders, cones, cones past their apex), with
    /// random and edge-case rays and segment lengths.
    #[test]
    fn eight_lanes_equal_eight_single_tests() {
        let mut g = fastrand::Rng::with_seed(17);
        let (mut hits, mut misses, mut linear) = (0, 0, 0);
        for _ in 0..20_000 {
            let base = vec(&mut g, 4.0);
            let apex = base + vec(&mut g, 6.0);
            let rb = g.f32() * 1.5;
            let ra = match g.u8(..3) {
                0 => rb,
                1 => g.f32() * 1.5,
                _ => 0.0,
            };
            let Some(cone) = Cone::new(base, rb, apex, ra, g.bool()) else {
                continue;
            };
            let sphere = Sphere {
                center: base,
                radius: rb.max(0.01),
                inside: g.bool(),
            };
            let axis = (apex - base).normalize();
            let on: Vec<Vec3> = (0..8)
                .map(|_| {
                    let r = rays_at(&mut g, base, &[base], axis)[0];
                    cone.intersect(&r, 0.0, 1e30).map_or(base, |h| r.at(h.t))
                })
                .collect();
            let rays = rays_at(&mut g, base, &on, axis);
            let t_max: [f32; 8] = std::array::from_fn(|_| match g.u8(..3) {
                0 => f32::INFINITY,
                1 => g.f32() * 20.0,
                _ => g.f32() * 2.0,
            });
            let t_min = if g.bool() { 0.0 } else { 1e-4 };
            let packed = EightRays::new(|l| rays[l]);
            let found = [
                lanes(&cone.intersect8(&packed, t_min, f32x8::from(t_max))),
                lanes(&sphere.intersect8(&packed, t_min, f32x8::from(t_max))),
            ];
            for l in 0..8 {
                let single = [
                    bits(cone.intersect(&rays[l], t_min, t_max[l])),
                    bits(sphere.intersect(&rays[l], t_min, t_max[l])),
                ];
                assert_eq!(found[0][l], single[0], "cone {cone:?} ray {:?}", rays[l]);
                assert_eq!(
                    found[1][l], single[1],
                    "sphere {sphere:?} ray {:?}",
                    rays[l]
                );
                for s in single {
                    if s.is_some() {
                        hits += 1;
                    } else {
                        misses += 1;
                    }
                }
                let dp = rays[l].dir - axis * rays[l].dir.dot(axis);
                let a = dp.length_squared() - cone.slope_squared * rays[l].dir.dot(axis).powi(2);
                if a.abs() < 1e-12 {
                    linear += 1;
                }
            }
        }
        assert!(
            hits > 50_000 && misses > 50_000,
            "{hits} hits, {misses} misses"
        );
        assert!(linear > 100, "{linear} rays along a generating line");
    }

    /// Rays along the axes from points exactly on a sphere or a cylinder,
    /// or ending exactly on it: roots exactly at `t_min` or `t_max`, where
    /// only the same comparisons give the same answer.
    #[test]
    fn eight_lanes_equal_single_tests_at_the_ends_of_segments() {
        let axes = [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z];
        let sphere = Sphere {
            center: Vec3::new(1.0, -2.0, 3.0),
            radius: 2.0,
            inside: false,
        };
        let Some(cylinder) = Cone::new(Vec3::ZERO, 1.0, Vec3::new(0.0, 0.0, 4.0), 1.0, false)
        else {
            panic!("a cylinder");
        };
        // Points on the sphere and on the cylinder's side.
        let mut origins: Vec<Vec3> = axes.iter().map(|&a| sphere.center + a * 2.0).collect();
        origins.extend([Vec3::X, Vec3::Y, -Vec3::X, -Vec3::Y].map(|a| a + Vec3::Z * 2.0));
        for origin in origins {
            let rays: [Ray; 8] = std::array::from_fn(|l| Ray::new(origin, axes[l % 6]));
            for t_max in [1.0, 2.0, 4.0, f32::INFINITY] {
                for t_min in [-1.0, 0.0, 1e-4] {
                    let packed = EightRays::new(|l| rays[l]);
                    let t8 = f32x8::splat(t_max);
                    let found = [
                        lanes(&sphere.intersect8(&packed, t_min, t8)),
                        lanes(&cylinder.intersect8(&packed, t_min, t8)),
                    ];
                    for l in 0..8 {
                        let single = [
                            bits(sphere.intersect(&rays[l], t_min, t_max)),
                            bits(cylinder.intersect(&rays[l], t_min, t_max)),
                        ];
                        let at = format!("ray {:?}, t in ({t_min}, {t_max})", rays[l]);
                        assert_eq!(found[0][l], single[0], "sphere, {at}");
                        assert_eq!(found[1][l], single[1], "cylinder, {at}");
                    }
                }
            }
        }
        // The roots do land on the ends: a ray leaving the sphere's surface
        // inward meets it at 0 exactly, which `t > t_min` refuses at 0.
        let inward = Ray::new(sphere.center + Vec3::X * 2.0, -Vec3::X);
        let t = |t_min: f32| sphere.intersect(&inward, t_min, 4.0).map(|h| h.t);
        assert_eq!((t(-1.0), t(0.0)), (Some(0.0), None));
        let across = Ray::new(Vec3::new(1.0, 0.0, 2.0), -Vec3::X);
        let c = |t_min: f32, t_max: f32| cylinder.intersect(&across, t_min, t_max).map(|h| h.t);
        assert_eq!(
            (c(-1.0, 3.0), c(0.0, 3.0), c(0.0, 2.0)),
            (Some(0.0), Some(2.0), None)
        );
    }
}

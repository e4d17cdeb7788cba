//! Whether a fan of shadow segments toward one point light meets anything,
//! answered by one descent of the hierarchy for the whole fan (issue 16:
//! shared light for a run of views or samples).
//!
//! The segments `origins[l] → light` of a run of hits that lie nearly on a
//! line (consecutive views' hits on one primitive: their rays are parallel,
//! their origins on the camera line) all lie within `margin` of the triangle
//! (first origin, farthest origin, light). The descent visits the nodes whose
//! boxes, grown by the margin, overlap that triangle (a separating-axis test);
//! each primitive in their leaves is then tested against every segment,
//! conservatively: a sphere farther than its radius from each segment, a
//! triangle whose plane has every origin and the light strictly on one side,
//! miss; anything else (a cone, a triangle the fan crosses, a sphere it
//! grazes) counts as met. So "free" proves that no segment meets any
//! primitive, whatever arithmetic a shadow ray's own test does: the caller
//! may set each segment's transmittance to 1 and trace nothing, bit for bit
//! what the shadow rays would give. Anything met: the caller traces the
//! segments one by one, as before.

use super::Bvh;
use crate::math::{Aabb, Vec3};
use crate::shapes::Shape;

/// Relative slack added to every distance, for the rounding of the tests
/// here and of the segments' own (the hierarchy's boxes are padded by
/// 4 ulp of their coordinates; this is ~1000 times that).
const SLACK: f32 = 5e-4;

/// A fan of shadow segments from `origins` to one point `light`.
#[derive(Clone, Debug)]
pub struct ShadowFan<'a> {
    origins: &'a [Vec3],
    light: Vec3,
    /// The covering triangle and how far the segments may lie from it.
    tri: [Vec3; 3],
    margin: f32,
    /// Rounding scale of the fan's coordinates.
    eps: f32,
    /// The fan stands for every segment from a point within the margin of
    /// the origins' line too (`spanning`), not only the origins' own.
    spanning: bool,
}

/// Distance from `p` to the segment `a`–`b`.
pub fn distance_to_segment(p: Vec3, a: Vec3, b: Vec3) -> f32 {
    distance_squared_to_segment(p, a, b).sqrt()
}

/// Distance from `p` to the triangle `a`, `b`, `c` (its closest point by
/// the triangle's regions, Ericson's *Real-Time Collision Detection* 5.1.5).
pub fn distance_to_triangle(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> f32 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return ap.length();
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return bp.length();
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return distance_to_segment(p, a, b);
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return cp.length();
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return distance_to_segment(p, a, c);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return distance_to_segment(p, b, c);
    }
    let denom = va + vb + vc;
    if denom.abs() <= 0.0 || denom.is_nan() {
        // Degenerate: the nearest of its sides.
        return distance_to_segment(p, a, b)
            .min(distance_to_segment(p, a, c))
            .min(distance_to_segment(p, b, c));
    }
    let (v, w) = (vb / denom, vc / denom);
    (p - (a + ab * v + ac * w)).length()
}

/// The square of `distance_to_segment`.
fn distance_squared_to_segment(p: Vec3, a: Vec3, b: Vec3) -> f32 {
    let ab = b - a;
    let len2 = ab.length_squared();
    let s = if len2 > 0.0 {
        ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p - (a + ab * s)).length_squared()
}

impl<'a> ShadowFan<'a> {
    /// The fan of `origins` (at least one) toward `light`, each segment
    /// ending within `end_error` of the light (the rounding of `origin + dir
    /// × distance`). `None` for no origins or non-finite coordinates.
    pub fn new(origins: &'a [Vec3], light: Vec3, end_error: f32) -> Option<ShadowFan<'a>> {
        let first = *origins.first()?;
        let far = origins
            .iter()
            .copied()
            .max_by(|p, q| {
                (*p - first)
                    .length_squared()
                    .total_cmp(&(*q - first).length_squared())
            })
            .unwrap_or(first);
        // One square root for the largest distance (the same value: the
        // square root is monotonic and correctly rounded).
        let off_line = origins
            .iter()
            .map(|&p| distance_squared_to_segment(p, first, far))
            .fold(0.0f32, f32::max)
            .sqrt();
        let scale = origins
            .iter()
            .chain(std::iter::once(&light))
            .map(|p| p.abs().max_element())
            .fold(1e-3f32, f32::max);
        if !scale.is_finite() || !end_error.is_finite() {
            return None;
        }
        let eps = scale * SLACK;
        Some(ShadowFan {
            origins,
            light,
            tri: [first, far, light],
            margin: off_line + end_error + eps,
            eps,
            spanning: false,
        })
    }

    /// The fan of two ends that stands for the segments of every point
    /// between them too (key views, interpolated views: the hits of the
    /// views between lie on the line of the ends' hits, within `end_error`).
    /// A triangle's plane that has both ends and the light strictly on one
    /// side has every point between there too; a sphere is met wherever it
    /// comes within its radius of the covering triangle (no segment that
    /// leaves it is excused: a sphere between the two ends' segments meets
    /// a segment between them).
    pub fn spanning(ends: &'a [Vec3], light: Vec3, end_error: f32) -> Option<ShadowFan<'a>> {
        let fan = ShadowFan::new(ends, light, end_error)?;
        Some(ShadowFan {
            spanning: true,
            ..fan
        })
    }

    /// Whether the covering triangle, grown by the margin, may meet the box
    /// (the separating-axis test of a triangle against a box, with the box
    /// grown by the margin: a superset of the triangle's neighbourhood).
    pub fn may_meet_box(&self, b: &Aabb) -> bool {
        let half = (b.max - b.min) * 0.5 + Vec3::splat(self.margin);
        let centre = (b.max + b.min) * 0.5;
        let v = self.tri.map(|p| p - centre);
        let project = |axis: Vec3| -> bool {
            // true: separated along `axis`
            let p = [axis.dot(v[0]), axis.dot(v[1]), axis.dot(v[2])];
            let r = half.x * axis.x.abs() + half.y * axis.y.abs() + half.z * axis.z.abs();
            let slack = self.eps * (axis.abs().element_sum() + 1.0);
            p[0].min(p[1]).min(p[2]) > r + slack || p[0].max(p[1]).max(p[2]) < -r - slack
        };
        // The box's own axes.
        for axis in [Vec3::X, Vec3::Y, Vec3::Z] {
            if project(axis) {
                return false;
            }
        }
        let edges = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
        // The triangle's normal.
        let normal = edges[0].cross(edges[1]);
        if normal.length_squared() > 0.0 && project(normal) {
            return false;
        }
        // Edge × box axis.
        for e in edges {
            for axis in [Vec3::X, Vec3::Y, Vec3::Z] {
                let a = e.cross(axis);
                if a.length_squared() > 0.0 && project(a) {
                    return false;
                }
            }
        }
        true
    }

    /// Whether some segment of the fan may meet `shape` (conservative: a
    /// `false` is proved, with room for rounding).
    pub fn may_meet_shape(&self, shape: &Shape) -> bool {
        if !self.may_meet_box(&shape.bounds()) {
            return false;
        }
        match shape {
            Shape::Sphere(s) if self.spanning => {
                let [a, b, c] = self.tri;
                distance_to_triangle(s.center, a, b, c) <= s.radius.abs() + self.margin + self.eps
            }
            Shape::Sphere(s) => {
                let r = s.radius.abs();
                let reach = r + self.eps;
                self.origins.iter().any(|&o| {
                    // A segment that starts outside the sphere and leaves it
                    // (the surface the run lies on, lit) misses it: its
                    // nearest point to the centre is its start. Else, by
                    // distance.
                    let out = o - s.center;
                    let round = 16.0
                        * f32::EPSILON
                        * (o.abs().max_element() + s.center.abs().max_element() + r);
                    let leaves = out.length() > r + round
                        && (self.light - o).dot(out) > round * out.length();
                    !leaves && distance_to_segment(s.center, o, self.light) <= reach
                })
            }
            Shape::Triangle(t) => {
                let n = t.plane_normal;
                if !(n.length_squared() > 0.5 && n.is_finite()) {
                    return true;
                }
                // The signed distance of `p` from the plane, as computed,
                // and two bounds on its rounding: `loose`, 16 ulp of the
                // coordinates involved; `tight`, twice the first-order bound
                // of a dot product of a difference, 2ε Σ|n_i||d_i| (the
                // same for this computation and the shadow ray's, in any
                // order of operations, fused or not), small where the plane
                // is nearly axis-aligned however far the vertex is.
                let side = |p: Vec3| {
                    let d = p - t.v0;
                    let loose = 16.0
                        * f32::EPSILON
                        * (p.abs().max(t.v0.abs()).max_element() + d.abs().max_element());
                    let tight = 4.4 * f32::EPSILON * n.abs().dot(d.abs()) + f32::MIN_POSITIVE;
                    (n.dot(d), loose, tight)
                };
                let (light, light_loose, _) = side(self.light);
                if light.abs() <= light_loose {
                    return true;
                }
                let sign = light.signum();
                let light = light * sign;
                !self.origins.iter().all(|&o| {
                    let (h, loose, tight) = side(o);
                    let h = h * sign;
                    // Every triangle routine computes t = −n·(o − v0) / n·dir
                    // (`shapes::triangle::intersect_lanes`, `Triangle::intersect`).
                    // With n·(o − v0) computed on the light's side (`tight`)
                    // and the light farther from the plane than the origin
                    // by more than the origin's offset from its hit point
                    // (within `margin`) and the rounding of `dir`, n·dir is
                    // computed on that side too: t < 0, no hit, wherever
                    // the segment crosses the triangle's extent. Else the
                    // loose bound, as the origins' side alone.
                    let reach = 8.0 * f32::EPSILON * ((self.light - o).length() + self.margin);
                    h > loose
                        || (h > tight && light - light_loose > h + tight + self.margin + reach)
                })
            }
            Shape::Cone(_) => true,
        }
    }
}

/// What a fan's descent did, for the counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FanWork {
    pub nodes: u64,
    pub primitives: u64,
}

impl Bvh {
    /// Whether no segment of `fan` may meet any primitive of the tree (one
    /// descent of its binary nodes); `shapes` holds the scene's shapes,
    /// indexed as the tree's primitives.
    pub fn fan_is_free(&self, fan: &ShadowFan, shapes: &[Shape], work: &mut FanWork) -> bool {
        let Some(root) = self.nodes.first() else {
            return true;
        };
        if !fan.may_meet_box(&root.bounds()) {
            return true;
        }
        let mut stack = [0u32; 64];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top] as usize];
            work.nodes += 1;
            if node.is_leaf() {
                let first = node.first as usize;
                for &prim in &self.order[first..first + node.count() as usize] {
                    work.primitives += 1;
                    if fan.may_meet_shape(&shapes[prim as usize]) {
                        return false;
                    }
                }
                continue;
            }
            for child in [node.first, node.first + 1] {
                if fan.may_meet_box(&self.nodes[child as usize].bounds()) {
                    if top == stack.len() {
                        return false; // deeper than any tree built here: say "met"
                    }
                    stack[top] = child;
                    top += 1;
                }
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::{build, primitive_box, BuildOptions};
    use crate::math::Ray;
    use crate::shapes::{Cone, Sphere, Triangle, TriangleNormals};

    fn sphere(center: Vec3, radius: f32) -> Shape {
        Shape::Sphere(Sphere {
            center,
            radius,
            inside: false,
        })
    }

    fn triangle(a: Vec3, b: Vec3, c: Vec3) -> Shape {
        let n = (b - a).cross(c - a).normalize();
        Shape::Triangle(Triangle::new(a, b, c, n, TriangleNormals::Flat))
    }

    fn pole(base: Vec3, apex: Vec3, radius: f32) -> Shape {
        Shape::Cone(Cone::new(base, radius, apex, radius, false).expect("a cone"))
    }

    fn random_shapes(rng: &mut fastrand::Rng, count: usize) -> Vec<Shape> {
        let mut p = || {
            Vec3::new(
                rng.f32() * 10.0 - 5.0,
                rng.f32() * 10.0 - 5.0,
                rng.f32() * 4.0,
            )
        };
        (0..count)
            .map(|n| match n % 3 {
                0 => sphere(p(), 0.05 + 0.3 * (n % 7) as f32 / 7.0),
                1 => {
                    let a = p();
                    triangle(
                        a,
                        a + Vec3::new(0.4, 0.1, 0.3),
                        a + Vec3::new(-0.2, 0.5, 0.1),
                    )
                }
                _ => {
                    let a = p();
                    pole(a, a + Vec3::Z, 0.05)
                }
            })
            .collect()
    }

    fn tree(shapes: &[Shape]) -> Bvh {
        let boxes: Vec<Aabb> = shapes.iter().map(|s| primitive_box(&s.bounds())).collect();
        build(&boxes, &BuildOptions::default())
    }

    fn segment_blocked(shapes: &[Shape], o: Vec3, light: Vec3) -> bool {
        let d = light - o;
        let dist = d.length();
        let ray = Ray::new(o, d / dist);
        shapes
            .iter()
            .any(|s| s.intersect(&ray, 0.0, dist).is_some())
    }

    /// A run of points on a line on the floor (z = 0), as consecutive views'
    /// hits on one primitive are.
    fn run(rng: &mut fastrand::Rng, len: usize) -> Vec<Vec3> {
        let start = Vec3::new(rng.f32() * 8.0 - 4.0, rng.f32() * 8.0 - 4.0, 1e-3);
        let step = Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, 0.0) * 0.3;
        (0..len).map(|i| start + step * i as f32).collect()
    }

    /// Never "free" where a segment is blocked, on random scenes of spheres,
    /// triangles and cones; and "free" often enough to be worth a descent.
    #[test]
    fn a_free_fan_has_no_blocked_segment() {
        let mut rng = fastrand::Rng::with_seed(16);
        let (mut free, mut blocked, mut fans) = (0, 0, 0);
        for scene in 0..40 {
            let shapes = random_shapes(&mut rng, 10 + scene * 3);
            let bvh = tree(&shapes);
            for _ in 0..200 {
                let len = 1 + rng.usize(..12);
                let origins = run(&mut rng, len);
                let light = Vec3::new(rng.f32() * 20.0 - 10.0, rng.f32() * 20.0 - 10.0, 8.0);
                let fan = ShadowFan::new(&origins, light, 0.0).expect("finite");
                let any = origins.iter().any(|&o| segment_blocked(&shapes, o, light));
                let is_free = bvh.fan_is_free(&fan, &shapes, &mut FanWork::default());
                assert!(
                    !(is_free && any),
                    "scene {scene}: free, yet a segment is blocked"
                );
                fans += 1;
                free += usize::from(is_free);
                blocked += usize::from(any);
            }
        }
        assert!(blocked > fans / 10, "{blocked} of {fans} fans blocked");
        assert!(free > fans / 4, "{free} of {fans} fans free");
    }

    /// A pole (a thin cone, a thin sphere, a sliver triangle) between two
    /// segments of the fan, touching neither end's segment: the fan is met.
    #[test]
    fn a_thin_occluder_between_the_ends_is_met() {
        let origins: Vec<Vec3> = (0..8)
            .map(|i| Vec3::new(i as f32 * 0.2, 0.0, 0.0))
            .collect();
        let light = Vec3::new(0.7, 0.0, 10.0);
        let middle = Vec3::new(0.75, 0.0, 5.0);
        let fan = ShadowFan::new(&origins, light, 0.0).expect("finite");
        let occluders = |at: Vec3| {
            [
                pole(at - Vec3::Y, at + Vec3::Y, 0.01),
                sphere(at, 0.01),
                triangle(at - Vec3::Y, at + Vec3::Y, at + Vec3::new(0.001, 0.0, 0.01)),
            ]
        };
        for (kind, (between, aside)) in occluders(middle)
            .into_iter()
            .zip(occluders(middle + Vec3::new(0.0, 0.0, 20.0)))
            .enumerate()
        {
            let shapes = vec![between];
            assert!(
                !tree(&shapes).fan_is_free(&fan, &shapes, &mut FanWork::default()),
                "occluder {kind}"
            );
            // Moved above the light, clear of the fan: free.
            let shapes = vec![aside];
            assert!(
                tree(&shapes).fan_is_free(&fan, &shapes, &mut FanWork::default()),
                "occluder {kind} aside"
            );
        }
    }

    /// A small sphere between the segments of a fan's two ends, touching
    /// neither: the ends' own fan is free, their spanning fan (which stands
    /// for the points between) is met; moved above the light, both free.
    #[test]
    fn a_sphere_between_two_ends_meets_their_spanning_fan() {
        let ends = [Vec3::ZERO, Vec3::new(1.4, 0.0, 0.0)];
        let light = Vec3::new(0.7, 0.0, 10.0);
        let free = |fan: &ShadowFan, at: Vec3| {
            let shapes = vec![sphere(at, 0.01)];
            tree(&shapes).fan_is_free(fan, &shapes, &mut FanWork::default())
        };
        let own = ShadowFan::new(&ends, light, 0.0).expect("finite");
        let spanning = ShadowFan::spanning(&ends, light, 0.0).expect("finite");
        let between = Vec3::new(0.3, 0.0, 2.0);
        assert!(free(&own, between), "the ends' own segments miss it");
        assert!(!free(&spanning, between));
        let above = between + Vec3::new(0.0, 0.0, 20.0);
        assert!(free(&own, above) && free(&spanning, above));
        // Beside the covering triangle by more than its radius: free.
        assert!(free(&spanning, between + Vec3::new(0.0, 0.05, 0.0)));
    }

    /// A floor triangle a hundred units wide, the origins on it moved off by
    /// the shading's own offset (2e-5 of their scale, less than the loose
    /// bound of a dot product with a far vertex): its plane separates them
    /// from the light, level or tilted (the tight bound); the points on the
    /// plane itself, not moved off, are met.
    #[test]
    fn a_wide_floor_does_not_meet_the_runs_on_it() {
        let floor = |tilt: f32| {
            triangle(
                Vec3::new(-100.0, -100.0, -100.0 * tilt),
                Vec3::new(100.0, -100.0, -100.0 * tilt),
                Vec3::new(0.0, 100.0, 100.0 * tilt),
            )
        };
        let light = Vec3::new(3.0, 2.0, 10.0);
        for (tilt, off, free) in [
            (0.0, true, true),
            (1e-3, true, true),
            (0.3, true, true),
            (0.0, false, false),
            (0.3, false, false),
        ] {
            let shapes = vec![floor(tilt)];
            let Shape::Triangle(t) = &shapes[0] else {
                unreachable!()
            };
            let n = t.plane_normal;
            let origins: Vec<Vec3> = (0..8)
                .map(|i| {
                    let x = Vec3::new(0.5 + i as f32 * 0.01, 1.0, 0.0);
                    let p = x - n * n.dot(x - t.v0);
                    if off {
                        crate::shading::offset_point(p, n * n.z.signum(), 8.0)
                    } else {
                        p
                    }
                })
                .collect();
            let fan = ShadowFan::new(&origins, light, 1e-3).expect("finite");
            let got = tree(&shapes).fan_is_free(&fan, &shapes, &mut FanWork::default());
            assert_eq!(got, free, "tilt {tilt}, moved off {off}");
        }
    }

    /// Runs on wide triangles at random tilts, their origins moved off by
    /// the shading's offset or by less, their shadow rays built as the
    /// shading builds them (from the hit point toward the light, from the
    /// moved origin): a fan proved free has no segment the triangle's own
    /// routine hits, and the tight bound proves many.
    #[test]
    fn runs_on_wide_triangles_are_free_only_where_no_ray_hits() {
        let mut rng = fastrand::Rng::with_seed(1616);
        let (mut free, mut fans) = (0, 0);
        for _ in 0..3000 {
            let size = 1.0 + rng.f32() * 200.0;
            let centre = Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5) * 20.0;
            let mut corner = || {
                centre + Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, (rng.f32() - 0.5) * 0.4) * size
            };
            let shapes = vec![triangle(corner(), corner(), corner())];
            let Shape::Triangle(t) = &shapes[0] else {
                unreachable!()
            };
            let n = t.plane_normal;
            let light =
                centre + n * (rng.f32() * 20.0 + 1e-3) + Vec3::new(rng.f32(), rng.f32(), 0.0);
            let scale = [1.0, 0.1, 0.01][rng.usize(..3)];
            let start = t.v0 + t.e1 * rng.f32() * 0.5 + t.e2 * rng.f32() * 0.4;
            let step = t.e1 * (rng.f32() * 0.01);
            let points: Vec<(Vec3, Vec3)> = (0..6)
                .map(|i| {
                    let p = start + step * i as f32;
                    let dist_along = rng.f32() * 20.0;
                    let full = crate::shading::offset_point(p, n, dist_along);
                    (p, p + (full - p) * scale)
                })
                .collect();
            let origins: Vec<Vec3> = points.iter().map(|x| x.1).collect();
            let end_error = points
                .iter()
                .map(|(p, o)| {
                    (*o - *p).length() * 1.01 + 8.0 * f32::EPSILON * (light - *p).length()
                })
                .fold(0.0, f32::max);
            let Some(fan) = ShadowFan::new(&origins, light, end_error) else {
                continue;
            };
            let is_free = tree(&shapes).fan_is_free(&fan, &shapes, &mut FanWork::default());
            let hit = points.iter().any(|&(p, o)| {
                let to = light - p;
                let dist = to.length();
                let ray = Ray::new(o, to / dist);
                shapes[0].intersect(&ray, 0.0, dist).is_some()
            });
            assert!(
                !(is_free && hit),
                "free, yet a ray hits: {shapes:?} {origins:?}"
            );
            fans += 1;
            free += usize::from(is_free);
        }
        assert!(free > fans / 3, "{free} of {fans} free");
    }

    /// The floor the origins lie on (a triangle, its plane below them, the
    /// light above) does not count as met: its own plane separates it; nor
    /// does a ball whose lit side they lie on.
    #[test]
    fn the_surface_the_run_lies_on_is_not_met() {
        let ball = sphere(Vec3::ZERO, 2.0);
        let shapes = vec![ball];
        let on: Vec<Vec3> = (0..5)
            .map(|i| Vec3::new(i as f32 * 0.05, 0.0, 2.0 + 1e-4))
            .collect();
        let fan = ShadowFan::new(&on, Vec3::new(0.0, 0.0, 10.0), 0.0).expect("finite");
        assert!(tree(&shapes).fan_is_free(&fan, &shapes, &mut FanWork::default()));
        // Its far side, toward the same light: met.
        let behind: Vec<Vec3> = on.iter().map(|p| Vec3::new(p.x, p.y, -p.z)).collect();
        let fan = ShadowFan::new(&behind, Vec3::new(0.0, 0.0, 10.0), 0.0).expect("finite");
        assert!(!tree(&shapes).fan_is_free(&fan, &shapes, &mut FanWork::default()));
        let floor = triangle(
            Vec3::new(-10.0, -10.0, 0.0),
            Vec3::new(10.0, -10.0, 0.0),
            Vec3::new(0.0, 10.0, 0.0),
        );
        let shapes = vec![floor];
        let bvh = tree(&shapes);
        let origins: Vec<Vec3> = (0..8)
            .map(|i| Vec3::new(i as f32 * 0.2, 0.0, 1e-2))
            .collect();
        let fan = ShadowFan::new(&origins, Vec3::new(0.0, 0.0, 10.0), 0.0).expect("finite");
        assert!(bvh.fan_is_free(&fan, &shapes, &mut FanWork::default()));
    }
}

//! Leaves of spheres and cones culled four at a time (`shapes::Quadric4`)
//! against brute force and against the same leaves tested one by one: on
//! scenes of rings (spheres at the joints of cylinders, as SPD's rings), with
//! duplicated spheres (ties), spheres of radius 0, a huge sphere around
//! everything (every ray starts inside it), triangles in the same leaves, and
//! rays tangent to spheres, every lane's nearest hit is bit for bit brute
//! force's, for one ray, a stereo pair and a packet of four, on the four-wide
//! and the binary tree; any-hit meets the same primitives and stops at the
//! same one; and culling spares most scalar tests.

mod common;

use std::cell::Cell;

use common::brute;
use twinray::bvh::{
    build, AnyHit, AnyHitTest, BuildOptions, Bvh, NearestTest, Packet, SegmentPacket,
    TraversalStats,
};
use twinray::math::{Aabb, Ray, Vec3};
use twinray::shapes::{Cone, Shape, Sphere, SurfaceHit, Triangle, TriangleNormals};

fn sphere(center: Vec3, radius: f32) -> Shape {
    Shape::Sphere(Sphere {
        center,
        radius,
        inside: false,
    })
}

/// Rings of `joints` spheres joined by cylinders, tilted at random, with a
/// duplicate sphere now and then (ties), spheres of radius 0, small triangles
/// among them and (with `huge`) one sphere of radius 1000 around it all.
fn rings(count: usize, seed: u64, huge: bool) -> Vec<Shape> {
    let mut g = fastrand::Rng::with_seed(seed);
    let mut shapes = Vec::new();
    let r = 0.07;
    for ring in 0..count {
        let centre = Vec3::new(g.f32() - 0.5, g.f32() - 0.5, g.f32() - 0.5) * 12.0;
        let (u, v) = (
            Vec3::new(g.f32() - 0.5, g.f32() - 0.5, g.f32() - 0.5).normalize(),
            Vec3::new(g.f32() - 0.5, g.f32() - 0.5, g.f32() - 0.5).normalize(),
        );
        let v = (v - u * u.dot(v)).normalize();
        let joint = |k: usize| {
            let a = k as f32 / 5.0 * std::f32::consts::TAU;
            centre + (u * a.cos() + v * a.sin()) * 1.2
        };
        for k in 0..5 {
            let (a, b) = (joint(k), joint(k + 1));
            if let Some(c) = Cone::new(a, r, b, r, false) {
                shapes.push(Shape::Cone(c));
            }
            shapes.push(sphere(a, r));
            if k == 0 && ring % 3 == 0 {
                shapes.push(sphere(a, r)); // the same sphere twice: a tie
            }
            if k == 2 && ring % 4 == 0 {
                shapes.push(sphere(a, 0.0));
            }
        }
        if ring % 2 == 0 {
            let c = centre;
            shapes.push(Shape::Triangle(Triangle::new(
                c,
                c + u * 0.5,
                c + v * 0.5,
                u.cross(v),
                TriangleNormals::Flat,
            )));
        }
    }
    if huge {
        shapes.push(sphere(Vec3::ZERO, 1000.0));
    }
    shapes
}

fn tree(shapes: &[Shape]) -> Bvh {
    let boxes: Vec<Aabb> = shapes.iter().map(Shape::bounds).collect();
    let mut bvh = build(&boxes, &BuildOptions::aligned());
    bvh.attach_blocks(shapes);
    bvh
}

/// The renderer's nearest test, culling (`lane_ray`) or not, counting its
/// scalar tests.
struct Nearest<'a, const K: usize> {
    shapes: &'a [Shape],
    packet: &'a Packet<K>,
    cull: bool,
    tests: &'a Cell<u64>,
}

impl<const K: usize> NearestTest for Nearest<'_, K> {
    fn test(&mut self, prim: u32, lane: usize, t_max: f32) -> Option<SurfaceHit> {
        self.tests.set(self.tests.get() + 1);
        let p = self.packet;
        self.shapes[prim as usize].intersect(
            &Ray::new(p.origins[lane], p.dirs[lane]),
            p.t_min,
            t_max,
        )
    }

    fn lane_ray(&self, lane: usize) -> Option<Ray> {
        let p = self.packet;
        self.cull.then(|| Ray::new(p.origins[lane], p.dirs[lane]))
    }
}

type Found = Option<(u32, u32)>;

/// Every lane's nearest hit (primitive and distance bits) on the four-wide
/// (`wide`) or the binary tree, and the scalar tests made.
fn nearest<const K: usize>(
    shapes: &[Shape],
    bvh: &Bvh,
    p: &Packet<K>,
    cull: bool,
    wide: bool,
) -> ([Found; K], u64) {
    let tests = Cell::new(0);
    let test = Nearest {
        shapes,
        packet: p,
        cull,
        tests: &tests,
    };
    let mut st = TraversalStats::default();
    let got = if wide {
        bvh.closest(p, &mut st, test)
    } else {
        bvh.closest_binary(p, &mut st, test)
    };
    let found = std::array::from_fn(|l| {
        got.has_hit(l)
            .then(|| (got.prim[l], got.hit[l].t.to_bits()))
    });
    (found, tests.get())
}

/// Rays from around the scene toward a random joint (at its centre, on its
/// surface, or tangent to it), jittered per lane as a stereo pair's are.
fn packet<const K: usize>(g: &mut fastrand::Rng, shapes: &[Shape], k: usize) -> Packet<K> {
    let aim = loop {
        if let Shape::Sphere(s) = &shapes[g.usize(0..shapes.len())] {
            if s.radius < 1.0 {
                break s.clone();
            }
        }
    };
    let from = aim.center + Vec3::new(g.f32() - 0.5, g.f32() - 0.5, g.f32() - 0.5) * 40.0;
    let d = (aim.center - from).normalize();
    let side = d.cross(Vec3::Z).normalize_or(Vec3::X);
    let to = match k % 3 {
        0 => aim.center,
        1 => aim.center + side * aim.radius, // tangent
        _ => aim.center + side * aim.radius * g.f32(),
    };
    let origins: [Vec3; K] = std::array::from_fn(|l| from + side * (0.01 * l as f32));
    Packet {
        origins,
        dirs: std::array::from_fn(|l| (to - origins[l]).normalize()),
        t_min: 1e-4,
        t_max: std::array::from_fn(|l| if l == 1 { 35.0 } else { f32::INFINITY }),
        mask: (1 << K) - 1,
    }
}

fn check<const K: usize>(shapes: &[Shape], bvh: &Bvh, rounds: usize, seed: u64) -> (u64, u64, u64) {
    let mut g = fastrand::Rng::with_seed(seed);
    let (mut culled_tests, mut all_tests, mut hits) = (0, 0, 0);
    for k in 0..rounds {
        let p = packet::<K>(&mut g, shapes, k);
        for wide in [true, false] {
            let (culled, n_culled) = nearest(shapes, bvh, &p, true, wide);
            let (all, n_all) = nearest(shapes, bvh, &p, false, wide);
            assert_eq!(culled, all, "round {k}, {K} lanes, wide {wide}");
            for (l, found) in culled.iter().enumerate() {
                let ray = Ray::new(p.origins[l], p.dirs[l]);
                let expect =
                    brute(shapes, &ray, p.t_min, p.t_max[l]).map(|(i, h)| (i, h.t.to_bits()));
                assert_eq!(*found, expect, "round {k}, lane {l} of {K}, wide {wide}");
                hits += expect.is_some() as u64;
            }
            culled_tests += n_culled;
            all_tests += n_all;
        }
    }
    (culled_tests, all_tests, hits)
}

/// Nearest hits with culled leaves are brute force's, bit for bit, for one
/// ray, a pair and four lanes, on both trees; and culling leaves fewer than
/// half of the scalar tests (these rays all aim at a joint: most leaves they
/// reach hold what they hit).
#[test]
fn culled_leaves_give_brute_forces_nearest_hits() {
    for (seed, huge) in [(1, false), (2, true)] {
        let shapes = rings(150, seed, huge);
        let bvh = tree(&shapes);
        assert!(
            bvh.blocks.quadric_blocks() > 100,
            "{}",
            bvh.blocks.quadric_blocks()
        );
        let (c1, a1, h1) = check::<1>(&shapes, &bvh, 600, seed);
        let (c2, a2, h2) = check::<2>(&shapes, &bvh, 400, seed + 10);
        let (c4, a4, h4) = check::<4>(&shapes, &bvh, 200, seed + 20);
        for (lanes, c, a, h) in [(1, c1, a1, h1), (2, c2, a2, h2), (4, c4, a4, h4)] {
            assert!(h > a / 200, "{lanes} lanes: {h} hits");
            assert!(
                2 * c < a,
                "{lanes} lanes: {c} scalar tests culled against {a} one by one (huge {huge})"
            );
        }
    }
}

/// Any-hit test recording what each lane meets: every `stop_every`-th
/// primitive stops it.
struct Recorder<'a, const K: usize> {
    shapes: &'a [Shape],
    segments: &'a SegmentPacket<K>,
    cull: bool,
    met: [Vec<u32>; K],
}

impl<const K: usize> AnyHitTest for Recorder<'_, K> {
    fn test(&mut self, prim: u32, lane: usize) -> AnyHit {
        let s = self.segments;
        let ray = Ray::new(s.origins[lane], s.dirs[lane]);
        match self.shapes[prim as usize].intersect(&ray, 0.0, s.t_max[lane]) {
            None => AnyHit::Continue,
            Some(_) => {
                self.met[lane].push(prim);
                if prim.is_multiple_of(7) {
                    AnyHit::Stop
                } else {
                    AnyHit::Continue
                }
            }
        }
    }

    fn lane_ray(&self, lane: usize) -> Option<Ray> {
        let s = self.segments;
        self.cull.then(|| Ray::new(s.origins[lane], s.dirs[lane]))
    }
}

fn any_hit<const K: usize>(
    shapes: &[Shape],
    bvh: &Bvh,
    p: &Packet<K>,
    cull: bool,
    wide: bool,
) -> [Vec<u32>; K] {
    let seg = SegmentPacket {
        origins: p.origins,
        dirs: p.dirs,
        t_max: std::array::from_fn(|l| p.t_max[l].min(60.0)),
        mask: p.mask,
    };
    let mut r = Recorder {
        shapes,
        segments: &seg,
        cull,
        met: std::array::from_fn(|_| Vec::new()),
    };
    let mut st = TraversalStats::default();
    if wide {
        bvh.occlusion(&seg, &mut st, &mut r);
    } else {
        bvh.occlusion_binary(&seg, &mut st, &mut r);
    }
    r.met
}

/// Any-hit with culled leaves meets the same primitives, in the same order,
/// and stops at the same one, as one by one, for one, two and four lanes.
#[test]
fn culled_any_hit_meets_what_one_by_one_meets() {
    let shapes = rings(150, 3, true);
    let bvh = tree(&shapes);
    let mut g = fastrand::Rng::with_seed(4);
    let mut met = 0;
    for k in 0..300 {
        macro_rules! go {
            ($k:literal) => {{
                let p = packet::<$k>(&mut g, &shapes, k);
                for wide in [true, false] {
                    let culled = any_hit(&shapes, &bvh, &p, true, wide);
                    assert_eq!(
                        culled,
                        any_hit(&shapes, &bvh, &p, false, wide),
                        "round {k}, {} lanes",
                        $k
                    );
                    met += culled.iter().map(Vec::len).sum::<usize>();
                }
            }};
        }
        go!(1);
        go!(2);
        go!(4);
    }
    assert!(met > 1000, "{met} primitives met");
}

//! Rays in one nearest-hit descent (`Bvh::closest_packet8`: up to eight
//! lanes): the packet shares the nodes its rays enter, so it visits fewer
//! nodes than its rays' single descents, with no more box or primitive tests
//! per lane; and it keeps each lane's own mask and `t_max`: a lane is carried
//! into a child only by its own box test, and pruned only by its own nearest
//! hit. Every hit is checked against brute force and against the lane traced
//! alone.

use crate::common;

use common::brute;
use twinray::bvh::{build, BuildOptions, Bvh, Packet, PacketHits, TraversalStats};
use twinray::math::{Aabb, Ray, Vec3};
use twinray::shapes::{Shape, Sphere, Triangle, TriangleNormals};

fn hierarchy(shapes: &[Shape]) -> Bvh {
    let boxes: Vec<Aabb> = shapes.iter().map(|s| s.bounds()).collect();
    build(&boxes, &BuildOptions::default())
}

fn sphere(center: Vec3, radius: f32) -> Shape {
    Shape::Sphere(Sphere {
        center,
        radius,
        inside: false,
    })
}

/// A wavy terrain of `n` x `n` cells (two triangles each) over x, z in
/// [-10, 10], at heights within [-1, 1]: a generated mesh with a deep tree.
fn terrain(n: usize) -> Vec<Shape> {
    let p = |i: usize, j: usize| {
        let (x, z) = (
            -10.0 + 20.0 * i as f32 / n as f32,
            -10.0 + 20.0 * j as f32 / n as f32,
        );
        Vec3::new(x, (x * 0.7).sin() * (z * 0.5).cos(), z)
    };
    let tri = |a: Vec3, b: Vec3, c: Vec3| {
        let nrm = (b - a).cross(c - a).normalize_or_zero();
        Shape::Triangle(Triangle::new(a, b, c, nrm, TriangleNormals::Flat))
    };
    let mut out = Vec::with_capacity(2 * n * n);
    for i in 0..n {
        for j in 0..n {
            out.push(tri(p(i, j), p(i + 1, j), p(i, j + 1)));
            out.push(tri(p(i + 1, j), p(i + 1, j + 1), p(i, j + 1)));
        }
    }
    out
}

/// The packet's hits in one descent, checked lane by lane against brute
/// force and against the lane traced alone (lanes off: no hit); with the
/// work of the one descent and of the lanes' single descents. `None` where
/// the descent refused the packet (its lanes' direction signs differ).
fn together<const K: usize>(
    shapes: &[Shape],
    bvh: &Bvh,
    p: &Packet<K>,
) -> Option<(PacketHits<8>, [TraversalStats; 2])> {
    let mut eight = Packet {
        origins: [Vec3::ZERO; 8],
        dirs: [Vec3::Z; 8],
        t_min: p.t_min,
        t_max: [f32::INFINITY; 8],
        mask: p.mask,
    };
    eight.origins[..K].copy_from_slice(&p.origins);
    eight.dirs[..K].copy_from_slice(&p.dirs);
    eight.t_max[..K].copy_from_slice(&p.t_max);
    let test = |prim: u32, l: usize, t_max: f32| {
        shapes[prim as usize].intersect(
            &Ray::new(eight.origins[l], eight.dirs[l]),
            eight.t_min,
            t_max,
        )
    };
    let mut one = TraversalStats::default();
    let hits = bvh.closest_packet8(&eight, &mut one, test)?;
    let mut alone = TraversalStats::default();
    for l in 0..8 {
        if p.mask & (1 << l) == 0 {
            assert!(!hits.has_hit(l), "lane {l} is off");
            continue;
        }
        let each = bvh.closest(&eight.lane(l), &mut alone, |prim: u32, _: usize, t: f32| {
            test(prim, l, t)
        });
        let ray = Ray::new(eight.origins[l], eight.dirs[l]);
        let expect = brute(shapes, &ray, eight.t_min, eight.t_max[l]);
        let got = hits.has_hit(l).then(|| (hits.prim[l], hits.hit[l]));
        assert_eq!(got, expect, "lane {l} of {p:?}");
        assert_eq!(hits.prim[l], each.prim[0]);
        assert_eq!(hits.hit[l].t.to_bits(), each.hit[0].t.to_bits());
    }
    Some((hits, [one, alone]))
}

/// Two rays in lanes 0 and 1.
fn packet(origins: [Vec3; 2], dirs: [Vec3; 2], t_max: [f32; 2]) -> Packet<2> {
    Packet {
        origins,
        dirs,
        t_min: 0.0,
        t_max,
        mask: 0b11,
    }
}

/// `together` for a packet the descent must take.
fn pair(shapes: &[Shape], bvh: &Bvh, p: &Packet<2>) -> (PacketHits<8>, [TraversalStats; 2]) {
    together(shapes, bvh, p).expect("the lanes' signs agree")
}

#[test]
fn a_packet_shares_its_descent_and_tests_no_more_per_lane_than_alone() {
    let shapes = terrain(48);
    let bvh = hierarchy(&shapes);
    // A camera above the terrain: for each of 32 x 4 pixels, the rays of
    // eight neighbouring pixels of a row, as the eye pass packs them.
    let eye = Vec3::new(0.0, 8.0, -14.0);
    let (mut shared, mut alone) = (TraversalStats::default(), TraversalStats::default());
    let mut hit = 0;
    for j in 0..32 {
        for i in 0..4 {
            let dirs: [Vec3; 8] = std::array::from_fn(|k| {
                let x = (8 * i + k) as f32 - 15.5;
                Vec3::new(x / 40.0, -0.45 - j as f32 / 80.0, 1.0).normalize()
            });
            let p = Packet {
                origins: [eye; 8],
                dirs,
                t_min: 0.0,
                t_max: [f32::INFINITY; 8],
                mask: 0xff,
            };
            let (h, [t, a]) = together(&shapes, &bvh, &p).expect("one octant");
            hit += (0..8).filter(|&l| h.has_hit(l)).count();
            shared += t;
            alone += a;
        }
    }
    assert!(hit > 950, "{hit} of 1024 rays hit the terrain");
    println!("packet {shared:?}, each alone {alone:?}");
    // One descent for all: a node several rays enter is visited once.
    assert!(
        (shared.nodes as f64) < 0.4 * alone.nodes as f64,
        "packet {shared:?}, each alone {alone:?}"
    );
    // Each lane is carried only where its own box test takes it: no more
    // box or primitive tests than alone (a little slack: the packet's order,
    // by its first lane's entries, may reach another lane's hit later).
    assert!(
        (shared.box_tests as f64) < 1.05 * alone.box_tests as f64,
        "packet {shared:?}, each alone {alone:?}"
    );
    assert!(
        (shared.prim_tests as f64) < 1.1 * alone.prim_tests as f64,
        "packet {shared:?}, each alone {alone:?}"
    );
}

/// Spheres in a row along x (a deep tree) with two targets at its ends.
fn row_with_targets() -> Vec<Shape> {
    let mut shapes: Vec<Shape> = (0..64)
        .map(|i| sphere(Vec3::new(-32.0 + i as f32, 5.0, 20.0), 0.3))
        .collect();
    shapes.push(sphere(Vec3::new(-40.0, 0.0, 2.0), 0.5)); // 64: lane 0's near target
    shapes.push(sphere(Vec3::new(40.0, 0.0, 60.0), 0.5)); // 65: lane 1's far target
    shapes
}

#[test]
fn lanes_that_want_different_children_each_find_their_own_hit() {
    // Lane 0 looks at the left end, lane 1 at the right end: after the root
    // they share no node, so each child carries one lane only.
    let shapes = row_with_targets();
    let bvh = hierarchy(&shapes);
    let p = packet(
        [Vec3::new(-40.0, 0.0, 0.0), Vec3::new(40.0, 0.0, 0.0)],
        [Vec3::Z; 2],
        [f32::INFINITY; 2],
    );
    let (h, [shared, alone]) = pair(&shapes, &bvh, &p);
    assert_eq!(h.prim[..2], [64, 65]);
    // Lanes apart: no more work than the two descents.
    assert!(shared.box_tests <= alone.box_tests, "{shared:?} {alone:?}");
    // And with each ray's direction toward the other's target, crossing:
    // their x signs differ, so the descent refuses them (the caller traces
    // them alone), and each alone finds the other's target.
    let (o0, o1) = (Vec3::new(0.0, 0.0, -1.0), Vec3::new(0.5, 0.0, -1.0));
    let to = |o: Vec3, s: u32| match &shapes[s as usize] {
        Shape::Sphere(s) => (s.center - o).normalize(),
        _ => unreachable!(),
    };
    let p = packet([o0, o1], [to(o0, 65), to(o1, 64)], [f32::INFINITY; 2]);
    assert!(together(&shapes, &bvh, &p).is_none());
    let test = |prim: u32, l: usize, t_max: f32| {
        shapes[prim as usize].intersect(&Ray::new(p.origins[l], p.dirs[l]), 0.0, t_max)
    };
    let h = bvh.closest(&p, &mut TraversalStats::default(), test);
    assert_eq!(h.prim, [65, 64]);
}

#[test]
fn one_lanes_near_hit_does_not_prune_the_other_lane() {
    // Both rays start side by side; lane 0 meets a sphere at t = 1.5 and lane
    // 1 passes beside it to a sphere at t = 58. Once lane 0 has its hit,
    // every box beyond t = 1.5 is pruned for lane 0 only.
    let mut shapes = row_with_targets();
    shapes[64] = sphere(Vec3::new(0.0, 0.0, 2.0), 0.5);
    shapes[65] = sphere(Vec3::new(2.0, 0.0, 60.0), 0.5);
    // Neighbours above each target (out of both rays' way), so that the
    // targets sit in separate subtrees: lane 1's is stacked behind lane 0's.
    for k in 0..8 {
        let up = Vec3::new(0.4 * k as f32 - 1.4, 2.0, 0.0);
        shapes.push(sphere(Vec3::new(0.0, 0.0, 2.0) + up, 0.2));
        shapes.push(sphere(Vec3::new(2.0, 0.0, 60.0) + up, 0.2));
    }
    let bvh = hierarchy(&shapes);
    let p = packet(
        [Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0)],
        [Vec3::Z; 2],
        [f32::INFINITY; 2],
    );
    let (h, _) = pair(&shapes, &bvh, &p);
    assert_eq!(h.prim[..2], [64, 65]);
    assert!((h.hit[0].t - 1.5).abs() < 1e-4 && (h.hit[1].t - 59.5).abs() < 1e-3);
    // Each lane's own t_max, given: lane 0's bound must not cut lane 1's
    // hit, nor lane 1's bound lane 0's.
    let p = packet(
        [Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0)],
        [Vec3::Z; 2],
        [1.0, 100.0],
    );
    let (h, _) = pair(&shapes, &bvh, &p);
    assert!(!h.has_hit(0));
    assert_eq!(h.prim[1], 65);
    let p = packet(
        [Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0)],
        [Vec3::Z; 2],
        [100.0, 30.0],
    );
    let (h, _) = pair(&shapes, &bvh, &p);
    assert_eq!(h.prim[0], 64);
    assert!(!h.has_hit(1));
}

#[test]
fn random_packets_match_brute_force_and_their_lanes_alone() {
    let shapes = terrain(24);
    let mut shapes = shapes;
    let mut rng = fastrand::Rng::with_seed(7);
    for i in 0..200 {
        let c = Vec3::new(rng.f32() - 0.5, rng.f32() * 0.2, rng.f32() - 0.5) * 20.0;
        shapes.push(sphere(c + Vec3::Y * 1.5, 0.2 + 0.3 * (i % 3) as f32));
    }
    let bvh = hierarchy(&shapes);
    let mut refused = 0;
    for _ in 0..2000 {
        let o = Vec3::new(rng.f32() - 0.5, rng.f32(), rng.f32() - 0.5) * 30.0;
        let at = Vec3::new(rng.f32() - 0.5, 0.0, rng.f32() - 0.5) * 20.0;
        let d0 = (at - o).normalize();
        let (o1, d1) = if rng.bool() {
            // A twin: nearby origin, nearly the same direction.
            (
                o + Vec3::new(0.1, 0.0, 0.0),
                (d0 + Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 0.02).normalize(),
            )
        } else {
            let o1 = Vec3::new(rng.f32() - 0.5, rng.f32(), rng.f32() - 0.5) * 30.0;
            let at1 = Vec3::new(rng.f32() - 0.5, 0.0, rng.f32() - 0.5) * 20.0;
            (o1, (at1 - o1).normalize())
        };
        let t_max = [0, 1].map(|_| {
            if rng.bool() {
                f32::INFINITY
            } else {
                2.0 + rng.f32() * 40.0
            }
        });
        let mut p = packet([o, o1], [d0, d1], t_max);
        p.t_min = if rng.bool() { 0.0 } else { 1e-3 };
        refused += usize::from(together(&shapes, &bvh, &p).is_none());
        // Eight lanes: the two rays and six between them, some lanes off.
        let eight = Packet::<8> {
            origins: std::array::from_fn(|l| o.lerp(o1, l as f32 / 7.0)),
            dirs: std::array::from_fn(|l| d0.lerp(d1, l as f32 / 7.0).normalize()),
            t_min: p.t_min,
            t_max: std::array::from_fn(|l| t_max[l % 2]),
            mask: rng.u32(1..256),
        };
        refused += usize::from(together(&shapes, &bvh, &eight).is_none());
    }
    assert!(refused < 2000, "{refused} of 4000 packets refused");
}

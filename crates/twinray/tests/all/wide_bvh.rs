//! The eight-wide hierarchy against brute force: on random scenes of
//! triangles and spheres and random rays, the nearest hit of every lane of a
//! packet (K = 1, 2, 3, 4, 8 lanes, each with its own direction and `t_max`;
//! eight lanes go down in one descent where their signs agree) is the nearest
//! of all primitives — ties to the lower index — bit for bit what the lane
//! gets alone; any-hit (a segment alone, a pair in one descent, a packet in
//! one descent) reaches every primitive a segment meets, and stops as brute
//! force says. Nearest-first order is checked by counting the primitive tests
//! on a ray down a row of objects, and the collapse by counting the nodes an
//! eye ray visits.
//!
//! Leaves of triangles tested four at a time (`Bvh::blocks`, the renderer's
//! leaf test) give the same hits, bit for bit: on the random scenes, and on
//! meshes whose rays land exactly on shared edges and vertices, with
//! degenerate and edge-on triangles among them.

use crate::common;

use common::brute;

/// Brute force's answer for lane `l` of `p`: `None` for a lane masked off.
fn brute_lane<const K: usize>(
    shapes: &[Shape],
    p: &Packet<K>,
    l: usize,
) -> Option<(u32, SurfaceHit)> {
    (p.mask & (1 << l) != 0)
        .then(|| {
            brute(
                shapes,
                &Ray::new(p.origins[l], p.dirs[l]),
                p.t_min,
                p.t_max[l],
            )
        })
        .flatten()
}
use twinray::bvh::{
    build, AnyHit, BuildOptions, Bvh, NearestTest, Packet, SegmentPacket, TraversalStats, WideNode,
    WIDTH,
};
use twinray::math::{Aabb, Ray, Vec3};
use twinray::shapes::{BlockHits, Shape, Sphere, SurfaceHit, Triangle, Triangle4, TriangleNormals};

/// A random scene: small triangles and spheres in a 20-unit cube, some
/// triangles sharing a plane (ties in distance), a few large ones.
fn scene(n: usize, seed: u64) -> Vec<Shape> {
    let mut rng = fastrand::Rng::with_seed(seed);
    let v = |s: f32, rng: &mut fastrand::Rng| {
        Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5) * s
    };
    (0..n)
        .map(|i| {
            let c = v(20.0, &mut rng);
            if i % 5 == 0 {
                Shape::Sphere(Sphere {
                    center: c,
                    radius: 0.1 + rng.f32() * 0.8,
                    inside: false,
                })
            } else {
                let size = if i % 37 == 0 { 12.0 } else { 1.5 };
                let (mut a, mut b, mut d) = (c + v(size, &mut rng), c + v(size, &mut rng), c);
                if i % 7 == 0 {
                    // On the plane z = 2: hits at equal distances.
                    (a.z, b.z, d.z) = (2.0, 2.0, 2.0);
                }
                let nrm = (b - a).cross(d - a).normalize_or_zero();
                Shape::Triangle(Triangle::new(a, b, d, nrm, TriangleNormals::Flat))
            }
        })
        .collect()
}

fn hierarchy(shapes: &[Shape]) -> Bvh {
    let boxes: Vec<Aabb> = shapes.iter().map(|s| s.bounds()).collect();
    build(&boxes, &BuildOptions::default())
}

/// The hierarchy the renderer builds: leaves of up to two blocks costed in
/// blocks when all are triangles, else today's leaves aligned to blocks; the
/// leaves of triangles held as blocks.
fn blocked(shapes: &[Shape]) -> Bvh {
    let boxes: Vec<Aabb> = shapes.iter().map(|s| s.bounds()).collect();
    let opts = if shapes.iter().all(|s| matches!(s, Shape::Triangle(_))) {
        BuildOptions::triangle_blocks()
    } else {
        BuildOptions::aligned()
    };
    let mut bvh = build(&boxes, &opts);
    bvh.attach_blocks(shapes);
    bvh
}

fn random_ray(rng: &mut fastrand::Rng) -> (Vec3, Vec3) {
    let o = Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5) * 40.0;
    let target = Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5) * 16.0;
    let mut d = (target - o).normalize();
    if rng.u32(..8) == 0 {
        // Axis-parallel directions (zero components) too.
        d = [Vec3::X, Vec3::NEG_Y, Vec3::Z][rng.usize(..3)];
    }
    (o, d)
}

/// A twin packet: lanes from nearby origins (the views) toward nearby points,
/// sometimes unrelated rays; per-lane `t_max` finite or infinite; a random mask.
fn packet<const K: usize>(rng: &mut fastrand::Rng) -> Packet<K> {
    let (o, d) = random_ray(rng);
    let twin = rng.bool();
    let lanes: [(Vec3, Vec3); K] = std::array::from_fn(|l| {
        if twin {
            let shift = Vec3::new(0.3 * l as f32, 0.0, 0.0);
            (
                o + shift,
                (d + Vec3::new(rng.f32(), rng.f32(), 0.0) * 0.01).normalize(),
            )
        } else {
            random_ray(rng)
        }
    });
    let mut mask = rng.u32(1..(1u32 << K));
    if rng.bool() {
        mask = (1 << K) - 1;
    }
    Packet {
        origins: lanes.map(|l| l.0),
        dirs: lanes.map(|l| l.1),
        t_min: if rng.bool() { 0.0 } else { 1e-3 },
        t_max: std::array::from_fn(|_| {
            if rng.bool() {
                f32::INFINITY
            } else {
                5.0 + rng.f32() * 40.0
            }
        }),
        mask,
    }
}

fn check_closest<const K: usize>(shapes: &[Shape], bvh: &Bvh, p: &Packet<K>) -> u64 {
    let test = |prim: u32, l: usize, t_max: f32| {
        shapes[prim as usize].intersect(&Ray::new(p.origins[l], p.dirs[l]), p.t_min, t_max)
    };
    let mut st = TraversalStats::default();
    let got = bvh.closest(p, &mut st, test);
    let mut hits = 0;
    for l in 0..K {
        let found = got.has_hit(l).then(|| (got.prim[l], got.hit[l]));
        let expect = brute_lane(shapes, p, l);
        assert_eq!(found, expect, "lane {l} of {K}, mask {:b}", p.mask);
        // Alone, as a packet of one, the lane gets the same answer, bit for
        // bit (f32 compared as bits).
        if p.mask & (1 << l) != 0 {
            let one = p.lane(l);
            let alone = bvh.closest(&one, &mut st, |prim: u32, _: usize, t: f32| {
                test(prim, l, t)
            });
            assert_eq!(alone.prim[0], got.prim[l], "lane {l} of {K}");
            let bits = |h: &SurfaceHit| [h.t, h.u, h.v].map(f32::to_bits);
            assert_eq!(bits(&alone.hit[0]), bits(&got.hit[l]), "lane {l} of {K}");
        }
        hits += found.is_some() as u64;
    }
    hits
}

fn check_occlusion<const K: usize>(shapes: &[Shape], bvh: &Bvh, p: &Packet<K>) {
    let segs = SegmentPacket {
        origins: p.origins,
        dirs: p.dirs,
        t_max: p.t_max.map(|t| t.min(60.0)),
        mask: p.mask,
    };
    let meets = |prim: u32, l: usize| {
        shapes[prim as usize]
            .intersect(&Ray::new(segs.origins[l], segs.dirs[l]), 0.0, segs.t_max[l])
            .is_some()
    };
    for together in [true, false] {
        let any_hit = |test: &mut dyn FnMut(u32, usize) -> AnyHit| {
            let st = &mut TraversalStats::default();
            let mut test = |prim: u32, l: usize| test(prim, l);
            if together {
                // A pair (both lanes) or a packet whose signs agree in one
                // descent, other packets lane by lane.
                bvh.occlusion(&segs, st, &mut test);
            } else {
                for l in (0..K).filter(|&l| segs.mask & (1 << l) != 0) {
                    let one = SegmentPacket {
                        origins: [segs.origins[l]],
                        dirs: [segs.dirs[l]],
                        t_max: [segs.t_max[l]],
                        mask: 1,
                    };
                    bvh.occlusion(&one, st, &mut |prim: u32, _: usize| test(prim, l));
                }
            }
        };
        // Without early exit: every primitive the segment meets is tested.
        let mut seen: [Vec<u32>; K] = std::array::from_fn(|_| Vec::new());
        any_hit(&mut |prim: u32, l: usize| {
            assert!(segs.mask & (1 << l) != 0, "masked lane {l} traced");
            seen[l].push(prim);
            AnyHit::Continue
        });
        // With early exit: stops for a lane at its first blocker, and no
        // lane is tested after it stopped.
        let mut stopped = [false; K];
        any_hit(&mut |prim: u32, l: usize| {
            assert!(!stopped[l], "lane {l} tested after it stopped");
            if meets(prim, l) {
                stopped[l] = true;
                AnyHit::Stop
            } else {
                AnyHit::Continue
            }
        });
        check_met(shapes.len(), &segs, &meets, &seen, &stopped);
    }
}

/// Every primitive a lane's segment meets was `seen`, and the lane `stopped`
/// if there was one.
fn check_met<const K: usize>(
    shapes_len: usize,
    segs: &SegmentPacket<K>,
    meets: &dyn Fn(u32, usize) -> bool,
    seen: &[Vec<u32>; K],
    stopped: &[bool; K],
) {
    for l in 0..K {
        let expect: Vec<u32> = (0..shapes_len as u32)
            .filter(|&prim| segs.mask & (1 << l) != 0 && meets(prim, l))
            .collect();
        for prim in &expect {
            assert!(
                seen[l].contains(prim),
                "lane {l}: occluder {prim} not tested"
            );
        }
        assert_eq!(stopped[l], !expect.is_empty(), "lane {l}");
    }
}

fn run<const K: usize>(shapes: &[Shape], bvh: &Bvh, rays: usize, seed: u64) -> u64 {
    let mut rng = fastrand::Rng::with_seed(seed);
    let mut hits = 0;
    for _ in 0..rays {
        let p = packet::<K>(&mut rng);
        hits += check_closest(shapes, bvh, &p);
        check_occlusion(shapes, bvh, &p);
    }
    hits
}

#[test]
fn nearest_and_any_hit_match_brute_force_for_packets_of_every_width() {
    for (n, seed) in [(1, 1), (3, 2), (9, 3), (300, 4), (2000, 5)] {
        let shapes = scene(n, seed);
        let bvh = hierarchy(&shapes);
        assert!(!bvh.wide.is_empty());
        let mut hits = 0;
        hits += run::<1>(&shapes, &bvh, 300, seed);
        hits += run::<2>(&shapes, &bvh, 300, seed + 10);
        hits += run::<3>(&shapes, &bvh, 150, seed + 20);
        hits += run::<4>(&shapes, &bvh, 150, seed + 30);
        hits += run::<8>(&shapes, &bvh, 60, seed + 40);
        if n >= 300 {
            assert!(hits > 100, "{n} shapes: only {hits} hits");
        }
    }
}

/// The wide tree `nodes`' shape: every node has 2..=8 children, used slots
/// first and the rest empty (a box no ray enters); its leaves hold every
/// primitive once. Returns the children counted over all nodes.
fn check_shape(nodes: &[WideNode], bvh: &Bvh, primitives: usize) -> usize {
    let mut seen = vec![0u32; primitives];
    let mut reached = vec![false; nodes.len()];
    let mut stack = vec![0usize];
    let mut children = 0;
    while let Some(i) = stack.pop() {
        // A tree: every node is some node's child once (none is the root).
        assert!(!reached[i], "node {i} reached twice");
        reached[i] = true;
        let node = &nodes[i];
        let used = (0..WIDTH)
            .filter(|&c| node.bounds[0][c] <= node.bounds[1][c])
            .count();
        assert!(used >= 2, "node {i}: {used} children");
        // Used slots first; the rest empty on every axis.
        for c in used..WIDTH {
            assert_eq!(node.count[c], 0);
            for axis in 0..3 {
                assert_eq!(node.bounds[2 * axis][c], f32::INFINITY, "slot {c}");
                assert_eq!(node.bounds[2 * axis + 1][c], f32::NEG_INFINITY);
            }
        }
        children += used;
        for c in 0..used {
            if node.count[c] > 0 {
                let first = node.child[c] as usize;
                for &p in &bvh.order[first..first + node.count[c] as usize] {
                    seen[p as usize] += 1;
                }
            } else {
                stack.push(node.child[c] as usize);
            }
        }
    }
    assert!(seen.iter().all(|&s| s == 1));
    assert!(reached.iter().all(|&r| r), "nodes no node points to");
    children
}

#[test]
fn every_node_has_up_to_eight_children_and_leaves_cover_every_primitive_once() {
    let shapes = scene(5000, 9);
    let bvh = hierarchy(&shapes);
    let children = check_shape(&bvh.wide, &bvh, shapes.len());
    // Collapsing by surface area (`collapse`) fills the nodes: under a
    // fourth of the binary tree's inner nodes, with more than five children
    // on average (647 nodes over 2973 binary inner nodes, 5.6 children; a
    // greedy collapse, the largest child opened first, made 892 nodes of 4.3).
    let inner = bvh.nodes.iter().filter(|n| !n.is_leaf()).count();
    let wide = bvh.wide.len();
    assert!(
        4 * wide < inner && children > 5 * wide,
        "{wide} wide nodes, {children} children, {inner} binary inner nodes"
    );
    assert_eq!(bvh.wide, twinray::bvh::collapse(&bvh.nodes));
}

/// Eye rays onto a generated mesh visit few inner nodes of the eight-wide
/// tree: 3.95 per ray when this was written, where a greedy collapse (the
/// largest child opened first) made 4.55. Each inner node costs one
/// eight-wide box test.
#[test]
fn eye_rays_visit_few_inner_nodes() {
    let (shapes, _) = mesh(60);
    let bvh = blocked(&shapes);
    let mut rng = fastrand::Rng::with_seed(8);
    let eye = Vec3::new(30.0, -20.0, 40.0);
    let mut st = TraversalStats::default();
    let rays = 2000;
    let mut hits = 0;
    for _ in 0..rays {
        let to = Vec3::new(rng.f32() * 60.0, rng.f32() * 60.0, 0.5);
        let p = Packet::ray(eye, (to - eye).normalize());
        let test = |prim: u32, _: usize, t: f32| {
            shapes[prim as usize].intersect(&Ray::new(p.origins[0], p.dirs[0]), 0.0, t)
        };
        hits += bvh.closest(&p, &mut st, test).has_hit(0) as u32;
    }
    assert!(hits > rays / 2, "{hits} hits");
    let inner = (st.box_tests / WIDTH as u64) as f64 / rays as f64;
    assert!(
        inner < 4.3,
        "{inner:.2} inner nodes per ray (a greedy collapse: 4.55)"
    );
}

#[test]
fn nearest_child_first_stops_a_ray_at_the_first_of_a_row() {
    // 256 spheres in a row along z; a ray down the row hits the first. Nearest
    // first, the traversal tests a handful of them; in any other order the
    // boxes behind would not be culled.
    let shapes: Vec<Shape> = (0..256)
        .map(|i| {
            Shape::Sphere(Sphere {
                center: Vec3::new(0.0, 0.0, 3.0 * i as f32),
                radius: 1.0,
                inside: false,
            })
        })
        .collect();
    let bvh = hierarchy(&shapes);
    for (o, d, first) in [
        (Vec3::new(0.1, 0.0, -10.0), Vec3::Z, 0u32),
        (Vec3::new(0.0, 0.1, 1000.0), Vec3::NEG_Z, 255),
    ] {
        // One ray alone, and eight copies of it in one descent.
        let test =
            |prim: u32, _: usize, t: f32| shapes[prim as usize].intersect(&Ray::new(o, d), 0.0, t);
        let mut st = TraversalStats::default();
        assert_eq!(
            bvh.closest(&Packet::ray(o, d), &mut st, test).prim[0],
            first
        );
        assert!(
            st.prim_tests <= 8,
            "alone: {} primitive tests",
            st.prim_tests
        );
        let p = Packet {
            origins: [o; 8],
            dirs: [d; 8],
            t_min: 0.0,
            t_max: [f32::INFINITY; 8],
            mask: 0xff,
        };
        let mut st = TraversalStats::default();
        let h = bvh.closest_packet8(&p, &mut st, test);
        assert_eq!(h.map(|h| h.prim), Some([first; 8]));
        assert!(
            st.prim_tests <= 64,
            "eight: {} primitive tests",
            st.prim_tests
        );
    }
}

/// The renderer's nearest test: a leaf of triangles held as a SIMD block is
/// tested four at a time, the rest one by one. Counts the blocks it tested.
struct BlockTest<'a, const K: usize> {
    shapes: &'a [Shape],
    packet: &'a Packet<K>,
    blocks_tested: &'a std::cell::Cell<u64>,
}

impl<const K: usize> NearestTest for BlockTest<'_, K> {
    fn test(&mut self, prim: u32, lane: usize, t_max: f32) -> Option<SurfaceHit> {
        let p = self.packet;
        self.shapes[prim as usize].intersect(
            &Ray::new(p.origins[lane], p.dirs[lane]),
            p.t_min,
            t_max,
        )
    }

    fn test_block(&mut self, block: &Triangle4, lane: usize, t_max: f32) -> Option<BlockHits> {
        self.blocks_tested.set(self.blocks_tested.get() + 1);
        let p = self.packet;
        Some(block.intersect(&Ray::new(p.origins[lane], p.dirs[lane]), p.t_min, t_max))
    }
}

/// Every lane's nearest hit with block leaves (each lane alone, or eight
/// lanes in one descent): brute force's, bit for bit. Returns (lanes hit;
/// blocks tested).
fn check_blocks<const K: usize>(shapes: &[Shape], bvh: &Bvh, p: &Packet<K>) -> (u64, u64) {
    let tested = std::cell::Cell::new(0);
    let mut hits = 0;
    let test = BlockTest {
        shapes,
        packet: p,
        blocks_tested: &tested,
    };
    let got = bvh.closest(p, &mut TraversalStats::default(), test);
    for l in 0..K {
        let expect = brute_lane(shapes, p, l);
        let bits = |h: Option<(u32, SurfaceHit)>| {
            h.map(|(prim, h)| (prim, h.t.to_bits(), h.u.to_bits(), h.v.to_bits()))
        };
        let found = got.has_hit(l).then(|| (got.prim[l], got.hit[l]));
        assert_eq!(
            bits(found),
            bits(expect),
            "lane {l} of {K}, mask {:b}: {p:?}",
            p.mask
        );
        hits += found.is_some() as u64;
    }
    (hits, tested.get())
}

fn run_blocks<const K: usize>(
    shapes: &[Shape],
    bvh: &Bvh,
    packets: impl Iterator<Item = Packet<K>>,
) -> (u64, u64) {
    packets.fold((0, 0), |acc, p| {
        let (h, t) = check_blocks(shapes, bvh, &p);
        (acc.0 + h, acc.1 + t)
    })
}

#[test]
fn block_leaves_give_brute_force_hits_for_packets_of_every_width() {
    for (n, seed) in [(3, 2), (300, 4), (2000, 5)] {
        let shapes = scene(n, seed);
        let bvh = blocked(&shapes);
        assert!(!bvh.blocks.is_empty());
        let mut rng = fastrand::Rng::with_seed(seed + 100);
        let (mut hits, mut tested) = (0, 0);
        for (h, t) in [
            run_blocks(&shapes, &bvh, (0..300).map(|_| packet::<1>(&mut rng))),
            run_blocks(&shapes, &bvh, (0..300).map(|_| packet::<2>(&mut rng))),
            run_blocks(&shapes, &bvh, (0..150).map(|_| packet::<3>(&mut rng))),
            run_blocks(&shapes, &bvh, (0..100).map(|_| packet::<8>(&mut rng))),
        ] {
            hits += h;
            tested += t;
        }
        if n >= 300 {
            assert!(hits > 100, "{n} shapes: only {hits} hits");
            assert!(tested > 1000, "{n} shapes: only {tested} blocks tested");
        }
    }
}

/// A height-field mesh of `n` x `n` quads (two triangles each, sharing the
/// diagonal and the quads' edges), plus a few degenerate triangles (a point,
/// a segment) and triangles standing edge-on to rays along z.
fn mesh(n: usize) -> (Vec<Shape>, Vec<Vec3>) {
    let height = |i: usize, j: usize| ((i * 7 + j * 3) % 5) as f32 * 0.25;
    let vertex = |i: usize, j: usize| Vec3::new(i as f32, j as f32, height(i, j));
    let tri = |a: Vec3, b: Vec3, c: Vec3| {
        let nrm = (b - a).cross(c - a).normalize_or_zero();
        Shape::Triangle(Triangle::new(a, b, c, nrm, TriangleNormals::Flat))
    };
    let mut shapes = Vec::new();
    let mut points = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let (a, b, c, d) = (
                vertex(i, j),
                vertex(i + 1, j),
                vertex(i + 1, j + 1),
                vertex(i, j + 1),
            );
            shapes.push(tri(a, b, c));
            shapes.push(tri(a, c, d));
            // Exactly on the vertices, the shared diagonal and the quad edges.
            points.extend([
                a,
                (a + c) * 0.5,
                (a + b) * 0.5,
                (a + d) * 0.5,
                a + (c - a) * 0.25,
            ]);
        }
    }
    for k in 0..n {
        let p = vertex(k, k) + Vec3::Z;
        shapes.push(tri(p, p, p));
        shapes.push(tri(p, p + Vec3::X, p + Vec3::X * 2.0));
        // Edge-on to a vertical ray: a wall in the plane x = k + 0.5.
        let w = Vec3::new(k as f32 + 0.5, k as f32, 0.0);
        shapes.push(tri(w, w + Vec3::Y, w + Vec3::Z * 3.0));
        points.push(w + Vec3::new(0.0, 0.25, 0.5));
    }
    (shapes, points)
}

#[test]
fn block_leaves_agree_on_shared_edges_vertices_and_degenerate_triangles() {
    let (shapes, points) = mesh(24);
    let bvh = blocked(&shapes);
    assert!(
        bvh.blocks.len() * 2 > bvh.leaves().count(),
        "most leaves are blocks"
    );
    let mut rng = fastrand::Rng::with_seed(77);
    // Rays straight down onto the points (edge-on to the walls), and slanted
    // ones from random origins, alone and as twin packets with per-lane
    // t_max (some ending right at the surface) and masks.
    let rays: Vec<(Vec3, Vec3)> = points
        .iter()
        .flat_map(|&pt| {
            let from = pt + Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, 1.0) * 10.0;
            [
                (pt + Vec3::Z * 5.0, Vec3::NEG_Z),
                (from, (pt - from).normalize()),
            ]
        })
        .collect();
    let singles = rays.iter().map(|&(o, d)| Packet::ray(o, d));
    let (hits, tested) = run_blocks(&shapes, &bvh, singles);
    // Nearly every ray hits the mesh: there is something to compare.
    assert!(
        hits as usize * 10 > rays.len() * 9,
        "{hits} hits of {} rays",
        rays.len()
    );
    assert!(tested as usize > rays.len());
    let quads = rays.chunks_exact(4).map(|c| {
        let t_max = [f32::INFINITY, 5.0, 4.0 + rng.f32() * 2.0, 100.0];
        Packet {
            origins: std::array::from_fn(|l| c[l].0),
            dirs: std::array::from_fn(|l| c[l].1),
            t_min: 1e-3,
            t_max,
            mask: rng.u32(1..16),
        }
    });
    run_blocks(&shapes, &bvh, quads);
    let pairs = rays.chunks_exact(2).map(|c| Packet {
        origins: [c[0].0, c[1].0],
        dirs: [c[0].1, c[1].1],
        t_min: 0.0,
        t_max: [f32::INFINITY, 7.0],
        mask: 0b11,
    });
    run_blocks(&shapes, &bvh, pairs);
}

/// Clusters of four triangles over one another, too close for the builder to
/// split (leaves of four: every lane of a block in use), each cluster in a
/// random order of height, so that the nearest is sometimes in the last lane.
#[test]
fn every_lane_of_a_full_block_can_give_the_nearest_hit() {
    let mut rng = fastrand::Rng::with_seed(41);
    let mut shapes = Vec::new();
    for c in 0..200 {
        let base = Vec3::new((c % 20) as f32 * 3.0, (c / 20) as f32 * 3.0, 0.0);
        let mut heights = [0.0f32, 0.01, 0.02, 0.03];
        rng.shuffle(&mut heights);
        for h in heights {
            let a = base + Vec3::new(0.0, 0.0, h);
            let (b, d) = (a + Vec3::X * 2.0, a + Vec3::Y * 2.0);
            let nrm = (b - a).cross(d - a).normalize();
            shapes.push(Shape::Triangle(Triangle::new(
                a,
                b,
                d,
                nrm,
                TriangleNormals::Flat,
            )));
        }
    }
    let bvh = blocked(&shapes);
    let full = bvh.leaves().filter(|l| l.len() == 4).count();
    assert!(full >= 100, "{full} leaves of four");
    // Per lane of a block: how often the nearest hit came from it.
    let mut from_lane = [0u32; 4];
    for c in 0..200 {
        let at = Vec3::new(
            (c % 20) as f32 * 3.0 + 0.4,
            (c / 20) as f32 * 3.0 + 0.3,
            0.0,
        );
        let p = Packet::ray(at + Vec3::Z * 5.0, Vec3::NEG_Z);
        let (hits, tested) = check_blocks(&shapes, &bvh, &p);
        assert_eq!((hits, tested > 0), (1, true), "cluster {c}");
        let prim = brute(
            &shapes,
            &Ray::new(p.origins[0], p.dirs[0]),
            0.0,
            f32::INFINITY,
        )
        .map(|(prim, _)| prim);
        if let Some(leaf) = bvh.leaves().find(|l| prim.is_some_and(|p| l.contains(&p))) {
            if leaf.len() == 4 {
                from_lane[leaf.iter().position(|&q| Some(q) == prim).unwrap_or(0)] += 1;
            }
        }
    }
    assert!(
        from_lane.iter().all(|&n| n > 0),
        "nearest hits per lane {from_lane:?}"
    );
}

/// Two rays in one leaf, each with its own t_max: the first ray's ends short
/// of the triangle, the second's does not. Each must be bounded by its own.
#[test]
fn a_pair_in_a_block_keeps_each_rays_own_t_max() {
    // Two large slanted triangles (their boxes begin at z = 1, the rays meet
    // them near z = 10.5 and 15.5) in one leaf, and small ones elsewhere.
    let tri = |z: f32| {
        let a = Vec3::new(-50.0, -50.0, 1.0);
        let (b, d) = (Vec3::new(50.0, -50.0, 1.0), Vec3::new(-50.0, 50.0, 2.0 * z));
        let nrm = (b - a).cross(d - a).normalize();
        Shape::Triangle(Triangle::new(a, b, d, nrm, TriangleNormals::Flat))
    };
    let mut shapes = vec![tri(20.0), tri(30.0)];
    shapes.extend((0..30).map(|i| {
        let a = Vec3::new(200.0 + i as f32 * 3.0, 0.0, 0.0);
        Shape::Triangle(Triangle::new(
            a,
            a + Vec3::X,
            a + Vec3::Y,
            Vec3::Z,
            TriangleNormals::Flat,
        ))
    }));
    let bvh = blocked(&shapes);
    for (t0, t1) in [
        (5.0, f32::INFINITY),
        (12.0, 30.0),
        (f32::INFINITY, 5.0),
        (45.0, 12.0),
    ] {
        let p = Packet {
            origins: [Vec3::new(-10.0, 0.0, 0.0), Vec3::new(-9.5, 0.0, 0.0)],
            dirs: [Vec3::Z, Vec3::Z],
            t_min: 0.0,
            t_max: [t0, t1],
            mask: 0b11,
        };
        let (hits, tested) = check_blocks(&shapes, &bvh, &p);
        assert!(tested > 0 && hits > 0, "t_max {t0}, {t1}");
    }
}

/// An any-hit test that records, per lane, every primitive it meets (in
/// order) and stops a lane at the first primitive `opaque` says blocks;
/// with `blocks`, leaves of triangles are tested as SIMD blocks.
struct Recorder<'a, const K: usize> {
    shapes: &'a [Shape],
    segments: &'a SegmentPacket<K>,
    blocks: bool,
    met: [Vec<u32>; K],
}

impl<const K: usize> Recorder<'_, K> {
    fn opaque(prim: u32) -> bool {
        prim.is_multiple_of(3)
    }

    fn meet(&mut self, prim: u32, lane: usize) -> AnyHit {
        self.met[lane].push(prim);
        if Self::opaque(prim) {
            AnyHit::Stop
        } else {
            AnyHit::Continue
        }
    }

    fn ray(&self, l: usize) -> Ray {
        Ray::new(self.segments.origins[l], self.segments.dirs[l])
    }
}

impl<const K: usize> twinray::bvh::AnyHitTest for Recorder<'_, K> {
    fn test(&mut self, prim: u32, lane: usize) -> AnyHit {
        let ray = self.ray(lane);
        match self.shapes[prim as usize].intersect(&ray, 0.0, self.segments.t_max[lane]) {
            Some(_) => self.meet(prim, lane),
            None => AnyHit::Continue,
        }
    }

    fn test_block(&mut self, block: &Triangle4, prims: &[u32], lane: usize) -> Option<AnyHit> {
        if !self.blocks {
            return None;
        }
        let hits = block.intersect(&self.ray(lane), 0.0, self.segments.t_max[lane]);
        let mut m = hits.mask & ((1 << prims.len()) - 1);
        while m != 0 {
            let i = m.trailing_zeros() as usize;
            m &= m - 1;
            if self.meet(prims[i], lane) == AnyHit::Stop {
                return Some(AnyHit::Stop);
            }
        }
        Some(AnyHit::Continue)
    }
}

/// Any-hit with SIMD block leaves meets the same primitives in the same
/// order, and stops at the same one, as testing them one by one: for
/// segments alone, in pairs (one block test for both) and in
/// packets of four, on a mesh and on a mixed scene.
#[test]
fn block_any_hit_meets_what_one_by_one_meets_and_stops_there() {
    let mut rng = fastrand::Rng::with_seed(5);
    let (mesh_shapes, points) = mesh(20);
    let mixed = scene(1500, 9);
    let (mut met_total, mut stopped) = (0, 0);
    for shapes in [&mesh_shapes, &mixed] {
        let bvh = blocked(shapes);
        assert!(!bvh.blocks.is_empty());
        // Segments of a packet start and end near one another (as a stereo
        // pair's do), so that they meet leaves together.
        let seg = |rng: &mut fastrand::Rng, to: Vec3, from: Vec3| {
            let jitter = Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5);
            let (to, from) = (to + jitter * 0.2, from + jitter * 0.5);
            let d = (to - from).normalize();
            (from - d * 5.0, d, (to - from).length() + 10.0 * rng.f32())
        };
        for k in 0..400 {
            let to = if std::ptr::eq(shapes, &mesh_shapes) {
                points[rng.usize(0..points.len())]
            } else {
                Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5) * 20.0
            };
            let from = to + Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32()) * 30.0;
            let s: [(Vec3, Vec3, f32); 4] = std::array::from_fn(|_| seg(&mut rng, to, from));
            let run = |blocks: bool, width: usize| {
                let mut out: Vec<Vec<u32>> = Vec::new();
                let mut st = TraversalStats::default();
                macro_rules! go {
                    ($k:literal) => {{
                        let p = SegmentPacket::<$k> {
                            origins: std::array::from_fn(|l| s[l].0),
                            dirs: std::array::from_fn(|l| s[l].1),
                            t_max: std::array::from_fn(|l| s[l].2),
                            mask: (1 << $k) - 1,
                        };
                        let mut r = Recorder {
                            shapes,
                            segments: &p,
                            blocks,
                            met: std::array::from_fn(|_| Vec::new()),
                        };
                        bvh.occlusion(&p, &mut st, &mut r);
                        out.extend(r.met);
                    }};
                }
                match width {
                    1 => go!(1),
                    2 => go!(2),
                    _ => go!(4),
                }
                out
            };
            let width = [1, 2, 4][k % 3];
            let one_by_one = run(false, width);
            let in_blocks = run(true, width);
            assert_eq!(in_blocks, one_by_one, "segment set {k}");
            for (l, met) in one_by_one.iter().enumerate() {
                met_total += met.len();
                // A lane stops at its first opaque primitive; one that
                // meets none has met every primitive on its segment.
                let opaque = met.iter().filter(|&&p| Recorder::<1>::opaque(p)).count();
                let stops = met.last().is_some_and(|&p| Recorder::<1>::opaque(p));
                assert_eq!(opaque, stops as usize, "set {k}, lane {l}: {met:?}");
                stopped += stops as usize;
                if !stops {
                    let ray = Ray::new(s[l].0, s[l].1);
                    let all: Vec<u32> = (0..shapes.len() as u32)
                        .filter(|&p| shapes[p as usize].intersect(&ray, 0.0, s[l].2).is_some())
                        .collect();
                    let mut met = met.clone();
                    met.sort_unstable();
                    assert_eq!(met, all, "set {k}, lane {l}");
                }
            }
        }
    }
    assert!(
        met_total > 1000 && stopped > 300,
        "{met_total} met, {stopped} stopped"
    );
}

/// Leaves costed in blocks make an eye ray's descent shorter: on a mesh
/// seen from above, fewer box tests per ray than per-primitive leaves, for
/// the same hits (30.8 against 36.6 eight-wide box tests per ray).
#[test]
fn blocks_cut_the_box_tests_of_an_eye_ray() {
    let (shapes, _) = mesh(60);
    let shapes: Vec<Shape> = shapes
        .into_iter()
        .filter(|s| s.bounds().max.z - s.bounds().min.z < 2.0)
        .collect();
    let boxes: Vec<Aabb> = shapes.iter().map(|s| s.bounds()).collect();
    let mut per_prim = build(&boxes, &BuildOptions::aligned());
    per_prim.attach_blocks(&shapes);
    let in_blocks = blocked(&shapes);
    let mut rng = fastrand::Rng::with_seed(3);
    let eye = Vec3::new(30.0, -20.0, 40.0);
    let (mut a, mut b) = (TraversalStats::default(), TraversalStats::default());
    let rays = 2000;
    for _ in 0..rays {
        let to = Vec3::new(rng.f32() * 60.0, rng.f32() * 60.0, 0.5);
        let p = Packet::ray(eye, (to - eye).normalize());
        let ha = check(&per_prim, &shapes, &p, &mut a);
        let hb = check(&in_blocks, &shapes, &p, &mut b);
        assert_eq!(ha, hb);
    }
    let per_ray = |s: &TraversalStats| s.box_tests as f64 / rays as f64;
    assert!(
        per_ray(&b) < 0.9 * per_ray(&a),
        "box tests per ray: {:.1} in blocks, {:.1} per primitive",
        per_ray(&b),
        per_ray(&a)
    );
}

fn check(
    bvh: &Bvh,
    shapes: &[Shape],
    p: &Packet<1>,
    st: &mut TraversalStats,
) -> Option<(u32, u32)> {
    let tested = std::cell::Cell::new(0);
    let test = BlockTest {
        shapes,
        packet: p,
        blocks_tested: &tested,
    };
    let got = bvh.closest(p, st, test);
    got.has_hit(0)
        .then(|| (got.prim[0], got.hit[0].t.to_bits()))
}

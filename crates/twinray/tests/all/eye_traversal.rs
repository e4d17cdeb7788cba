//! The eye ray's descent of the eight-wide tree:
//! leaves of five to eight triangles tested as two blocks in one eight-wide
//! register (`Triangle4::intersect_two`, through
//! `NearestTest::test_two_blocks`), and children of three or more sorted as
//! integers (`take_nearest`). Both must leave every hit as it was: on
//! generated scenes and random, axis-parallel and grazing rays, the nearest
//! hit of a ray traced alone is brute force's, bit for bit (ties to the lower
//! index), with and without the two-block test; and the counts show the
//! intended effect: leaves of two blocks take one register test, not two.

use crate::common;

use common::brute;
use std::cell::Cell;
use twinray::bvh::{build, BuildOptions, Bvh, NearestTest, Packet, PacketHits, TraversalStats};
use twinray::math::{Aabb, Ray, Vec3};
use twinray::shapes::{BlockHits, Shape, SurfaceHit, Triangle, Triangle4, TriangleNormals};

/// The renderer's nearest test for a packet, counting its block tests: one
/// block alone (`single`) and two at once (`two`); `pairs_off` makes it
/// refuse two at once (the default trait method: two single tests).
struct Counting<'a, const K: usize> {
    shapes: &'a [Shape],
    packet: &'a Packet<K>,
    single: &'a Cell<u64>,
    two: &'a Cell<u64>,
    two_off: bool,
}

impl<'a, const K: usize> Counting<'a, K> {
    /// The test for `packet`'s rays, two blocks at once allowed.
    fn new(
        shapes: &'a [Shape],
        packet: &'a Packet<K>,
        single: &'a Cell<u64>,
        two: &'a Cell<u64>,
    ) -> Self {
        Counting {
            shapes,
            packet,
            single,
            two,
            two_off: false,
        }
    }

    fn ray(&self, lane: usize) -> Ray {
        Ray::new(self.packet.origins[lane], self.packet.dirs[lane])
    }
}

impl<const K: usize> NearestTest for Counting<'_, K> {
    fn test(&mut self, prim: u32, lane: usize, t_max: f32) -> Option<SurfaceHit> {
        self.shapes[prim as usize].intersect(&self.ray(lane), self.packet.t_min, t_max)
    }

    fn test_block(&mut self, block: &Triangle4, lane: usize, t_max: f32) -> Option<BlockHits> {
        self.single.set(self.single.get() + 1);
        Some(block.intersect(&self.ray(lane), self.packet.t_min, t_max))
    }

    fn test_two_blocks(
        &mut self,
        blocks: &[Triangle4; 2],
        lane: usize,
        t_max: f32,
    ) -> Option<[BlockHits; 2]> {
        if self.two_off {
            return Some([
                self.test_block(&blocks[0], lane, t_max)?,
                self.test_block(&blocks[1], lane, t_max)?,
            ]);
        }
        self.two.set(self.two.get() + 1);
        let ray = self.ray(lane);
        Some(Triangle4::intersect_two(
            blocks,
            &ray,
            self.packet.t_min,
            t_max,
        ))
    }
}

fn tri(a: Vec3, b: Vec3, c: Vec3) -> Shape {
    let n = (b - a).cross(c - a).normalize_or_zero();
    Shape::Triangle(Triangle::new(a, b, c, n, TriangleNormals::Flat))
}

/// Triangles only: small random ones in a 20-unit cube, every seventh on
/// the plane z = 2 (ties in distance, grazing rays along it), a few large
/// ones, a few degenerate (a point, a segment), and a flat grid of quads on
/// z = -3 whose shared edges and vertices rays hit exactly.
fn scene(n: usize, seed: u64) -> Vec<Shape> {
    let mut rng = fastrand::Rng::with_seed(seed);
    let mut v = |s: f32| Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5) * s;
    let mut shapes = Vec::new();
    for i in 0..n {
        let c = v(20.0);
        let size = if i % 37 == 0 { 12.0 } else { 1.5 };
        let (mut a, mut b, mut d) = (c + v(size), c + v(size), c);
        if i % 7 == 0 {
            (a.z, b.z, d.z) = (2.0, 2.0, 2.0);
        }
        shapes.push(match i % 53 {
            0 => tri(a, a, a),
            1 => tri(a, b, a + (b - a) * 0.5),
            _ => tri(a, b, d),
        });
    }
    for i in 0..12 {
        for j in 0..12 {
            let p = |x: usize, y: usize| Vec3::new(x as f32 - 6.0, y as f32 - 6.0, -3.0);
            shapes.push(tri(p(i, j), p(i + 1, j), p(i + 1, j + 1)));
            shapes.push(tri(p(i, j), p(i + 1, j + 1), p(i, j + 1)));
        }
    }
    shapes
}

fn hierarchy(shapes: &[Shape], opts: &BuildOptions) -> Bvh {
    let boxes: Vec<Aabb> = shapes.iter().map(|s| s.bounds()).collect();
    let mut bvh = build(&boxes, opts);
    bvh.attach_blocks(shapes);
    bvh
}

/// Random rays through the cube; axis-parallel ones; rays along the plane
/// z = 2 (grazing its triangles); rays straight down onto the grid's
/// vertices and edges.
fn rays(count: usize, seed: u64) -> Vec<(Vec3, Vec3)> {
    let mut rng = fastrand::Rng::with_seed(seed);
    let mut v = |s: f32| Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5) * s;
    (0..count)
        .map(|i| {
            let o = v(40.0);
            match i % 5 {
                0 => (o, [Vec3::X, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_Z][i % 4]),
                1 => {
                    let o = Vec3::new(o.x, o.y, 2.0);
                    let to = Vec3::new(v(16.0).x, v(16.0).y, 2.0);
                    (o, (to - o).normalize_or(Vec3::X))
                }
                2 => {
                    let k = (i / 5) % 13;
                    let x = k as f32 - 6.0 + [0.0, 0.5, 0.25][i % 3];
                    (Vec3::new(x, x * 0.5, 30.0), Vec3::NEG_Z)
                }
                _ => (o, (v(16.0) - o).normalize()),
            }
        })
        .collect()
}

/// Traces every ray alone on the eight-wide tree with the counting test;
/// each hit must be brute force's, bit for bit. Returns (hits, single block
/// tests, two-block tests, primitive slots in the leaves visited).
fn trace(shapes: &[Shape], bvh: &Bvh, rays: &[(Vec3, Vec3)], two_off: bool) -> [u64; 4] {
    let (single, two) = (Cell::new(0), Cell::new(0));
    let mut stats = TraversalStats::default();
    let mut hits = 0;
    for (i, &(o, d)) in rays.iter().enumerate() {
        let p = Packet {
            origins: [o],
            dirs: [d],
            t_min: if i % 2 == 0 { 0.0 } else { 1e-3 },
            t_max: [if i % 3 == 0 { 25.0 } else { f32::INFINITY }],
            mask: 1,
        };
        let test = Counting {
            shapes,
            packet: &p,
            single: &single,
            two: &two,
            two_off,
        };
        let got = bvh.closest(&p, &mut stats, test);
        let expect = brute(shapes, &Ray::new(o, d), p.t_min, p.t_max[0]);
        let bits = |h: Option<(u32, SurfaceHit)>| {
            h.map(|(prim, h)| (prim, h.t.to_bits(), h.u.to_bits(), h.v.to_bits()))
        };
        let found = got.has_hit(0).then(|| (got.prim[0], got.hit[0]));
        assert_eq!(bits(found), bits(expect), "ray {i}: {o} {d}");
        hits += found.is_some() as u64;
    }
    [hits, single.get(), two.get(), stats.prim_tests]
}

/// Leaves of two blocks (the build for meshes) take one eight-wide test:
/// the same hits as brute force, and as two four-wide tests each, with
/// half the register tests on those leaves.
#[test]
fn two_block_leaves_give_brute_force_hits_in_one_test() {
    for (n, seed) in [(40, 1), (700, 2), (3000, 3)] {
        let shapes = scene(n, seed);
        let bvh = hierarchy(&shapes, &BuildOptions::triangle_blocks());
        let rays = rays(3000, seed + 10);
        let [hits, single, two, slots] = trace(&shapes, &bvh, &rays, false);
        let [hits_off, single_off, two_off, slots_off] = trace(&shapes, &bvh, &rays, true);
        assert_eq!((hits, slots), (hits_off, slots_off));
        assert!(hits > 600, "{n} triangles: {hits} hits");
        assert_eq!(two_off, 0);
        // Without the two-block test every block is tested alone; with it,
        // each two-block leaf's pair of single tests becomes one test (here
        // random triangles make many one-block leaves too).
        assert_eq!(single + 2 * two, single_off, "{n} triangles");
        assert!(
            two > 1000 && (single + two) * 10 < single_off * 9,
            "{n} triangles: {single} single and {two} two-block tests, {single_off} without"
        );
    }
}

/// Leaves of more than two blocks (the build for mixed scenes, all of
/// whose primitives here are triangles) are tested two blocks at a time and
/// the last alone: still brute force's hits.
#[test]
fn leaves_of_any_number_of_blocks_keep_brute_force_hits() {
    let shapes = scene(2000, 9);
    let opts = BuildOptions {
        max_leaf: 12,
        // Box tests dear: the SAH stops splitting early, leaves are large.
        traversal_cost: 10.0,
        ..BuildOptions::aligned()
    };
    let bvh = hierarchy(&shapes, &opts);
    let blocks_per_leaf = bvh
        .leaf_slots()
        .map(|(first, prims)| bvh.blocks.of_leaf(first, prims.len()).len())
        .max();
    assert!(blocks_per_leaf >= Some(3), "{blocks_per_leaf:?}");
    let [hits, single, two, _] = trace(&shapes, &bvh, &rays(3000, 19), false);
    assert!(hits > 600 && single > 0 && two > 0, "{hits} {single} {two}");
}

/// A street of 64 separate clusters along x, 4 apart, each of 8 upright
/// triangles (so that a ray along the street enters the root's children
/// together).
fn street_of_clusters() -> Vec<Shape> {
    let mut shapes = Vec::new();
    for c in 0..64 {
        let x = c as f32 * 4.0;
        for k in 0..8 {
            let y = k as f32 * 0.1;
            shapes.push(tri(
                Vec3::new(x, y - 1.0, -1.0),
                Vec3::new(x, y + 1.0, -1.0),
                Vec3::new(x, y, 1.0),
            ));
        }
    }
    shapes
}

/// Nearest child first, three or more children at a node: rays down a
/// street of separate clusters (so that the root's children are entered
/// together) stop in the first cluster after few primitive tests; visited
/// farthest first they would test all of them.
#[test]
fn sorted_children_stop_a_ray_in_the_nearest_cluster() {
    let shapes = street_of_clusters();
    let bvh = hierarchy(&shapes, &BuildOptions::triangle_blocks());
    let (single, two) = (Cell::new(0), Cell::new(0));
    for (origin, dir, first) in [
        (Vec3::new(-5.0, 0.35, 0.0), Vec3::X, 0u32),
        (Vec3::new(300.0, 0.35, 0.0), Vec3::NEG_X, 63 * 8),
    ] {
        let p = Packet::ray(origin, dir);
        let mut st = TraversalStats::default();
        let test = Counting::new(&shapes, &p, &single, &two);
        let got = bvh.closest(&p, &mut st, test);
        // Eight triangles at one distance: the lowest index wins.
        assert!(
            got.has_hit(0) && got.prim[0] == first,
            "{dir}: hit {}, not {first}",
            got.prim[0]
        );
        assert!(
            st.prim_tests <= 16,
            "{dir}: {} primitive tests (a cluster has 8)",
            st.prim_tests
        );
    }
}

/// `scene`'s triangles, then copies of every fifth (exact ties in distance
/// on a higher index, often in another leaf) and of the grid's first row
/// moved to the front (exact ties on a lower index).
fn scene_with_ties(n: usize, seed: u64) -> Vec<Shape> {
    let base = scene(n, seed);
    let grid_row: Vec<Shape> = base[n..n + 24].to_vec();
    let mut shapes = grid_row;
    shapes.extend(base.iter().cloned());
    shapes.extend(base.iter().step_by(5).cloned());
    shapes
}

/// Packets of eight neighbouring eye rays, as the mono row makes them: one
/// origin, the directions of eight consecutive samples of a row (a pixel
/// step of `step` apart, some rows aimed at the grid's vertices and edges,
/// some along the plane z = 2), each lane its own `t_max` (most infinite,
/// some short), some lanes masked off.
fn eye_packets(count: usize, seed: u64) -> Vec<Packet<8>> {
    let mut rng = fastrand::Rng::with_seed(seed);
    (0..count)
        .map(|i| {
            let mut v = || Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5);
            let (origin, aim, step) = match i % 4 {
                // Down onto the grid (z = -3): its vertices and edges.
                0 => {
                    let o = Vec3::new(0.25, -0.5, 30.0);
                    let k = (i / 4) % 12;
                    let aim = Vec3::new(k as f32 - 6.0, (k as f32 * 0.5).floor() - 3.0, -3.0);
                    (o, aim, Vec3::new(0.25, 0.0, 0.0))
                }
                // Along the plane z = 2 of many triangles.
                1 => {
                    let o = Vec3::new(v().x * 40.0, -30.0, 2.0);
                    (
                        o,
                        Vec3::new(v().x * 16.0, 0.0, 2.0),
                        Vec3::new(0.1, 0.0, 0.0),
                    )
                }
                // From anywhere at anything, rows of near-parallel rays.
                _ => {
                    let o = v() * 40.0;
                    (o, v() * 16.0, v() * 0.05)
                }
            };
            let dirs = std::array::from_fn(|l| (aim + step * l as f32 - origin).normalize());
            let t_max = std::array::from_fn(|_| {
                if rng.u8(..4) == 0 {
                    rng.f32() * 40.0
                } else {
                    f32::INFINITY
                }
            });
            Packet {
                origins: [origin; 8],
                dirs,
                t_min: if i % 3 == 0 { 1e-3 } else { 0.0 },
                t_max,
                mask: if i % 5 == 0 { rng.u32(1..256) } else { 0xff },
            }
        })
        .collect()
}

/// Each lane of an eye packet, alone on the eight-wide tree (the single
/// descent the packet must equal) and by brute force.
fn alone_and_brute(
    shapes: &[Shape],
    bvh: &Bvh,
    p: &Packet<8>,
    l: usize,
    stats: &mut TraversalStats,
) -> [Option<(u32, [u32; 3])>; 2] {
    let one = p.lane(l);
    let (single, two) = (Cell::new(0), Cell::new(0));
    let test = Counting {
        shapes,
        packet: &one,
        single: &single,
        two: &two,
        two_off: false,
    };
    let alone = bvh.closest(&one, stats, test);
    let bits = |h: SurfaceHit| [h.t, h.u, h.v].map(f32::to_bits);
    let brute = brute(
        shapes,
        &Ray::new(p.origins[l], p.dirs[l]),
        p.t_min,
        p.t_max[l],
    );
    [
        alone
            .has_hit(0)
            .then(|| (alone.prim[0], bits(alone.hit[0]))),
        brute.map(|(prim, h)| (prim, bits(h))),
    ]
}

/// Asserts that every active lane of packet `p` got (`got`) the hit it gets
/// alone and by brute force, bit for bit, and that lanes off got none;
/// returns the lanes with a hit.
fn each_lane_as_alone(
    shapes: &[Shape],
    bvh: &Bvh,
    p: &Packet<8>,
    got: &PacketHits<8>,
    stats: &mut TraversalStats,
    label: &str,
) -> u64 {
    let mut hits = 0;
    for l in 0..8 {
        let found = got.has_hit(l).then(|| {
            let h = got.hit[l];
            (got.prim[l], [h.t, h.u, h.v].map(f32::to_bits))
        });
        if p.mask & (1 << l) == 0 {
            assert_eq!(found, None, "{label}: lane {l} is off");
            continue;
        }
        let [alone, brute] = alone_and_brute(shapes, bvh, p, l, stats);
        assert_eq!(found, alone, "{label}, lane {l}: {p:?}");
        assert_eq!(found, brute, "{label}, lane {l}: {p:?}");
        hits += u64::from(found.is_some());
    }
    hits
}

/// Eight neighbouring eye rays in one descent (`closest_packet8`, the
/// mono row's): every active lane's hit is, bit for bit, the one the ray
/// gets alone and brute force's, on scenes of ties (copies of triangles,
/// shared edges and vertices, a plane of triangles grazed), with per-lane
/// `t_max` and masks; lanes off stay without a hit; a packet whose lanes'
/// direction signs differ is refused (traced alone by the caller).
#[test]
fn an_eye_packet_gives_each_ray_its_single_descents_hit() {
    let (mut packets, mut refused, mut hits) = (0, 0, 0);
    for (n, seed) in [(60, 4), (700, 5), (3000, 6)] {
        let shapes = scene_with_ties(n, seed);
        let bvh = hierarchy(&shapes, &BuildOptions::triangle_blocks());
        let mut stats = TraversalStats::default();
        for (i, p) in eye_packets(1200, seed + 20).iter().enumerate() {
            let (single, two) = (Cell::new(0), Cell::new(0));
            let test = Counting::new(&shapes, p, &single, &two);
            let signs = |l: usize| p.dirs[l].to_array().map(f32::is_sign_negative);
            let lanes: Vec<usize> = (0..8).filter(|&l| p.mask & (1 << l) != 0).collect();
            let agree = lanes.iter().all(|&l| signs(l) == signs(lanes[0]));
            let Some(got) = bvh.closest_packet8(p, &mut stats, test) else {
                assert!(
                    !agree,
                    "{n} triangles, packet {i}: refused, yet its signs agree"
                );
                refused += 1;
                continue;
            };
            packets += 1;
            let label = format!("{n} triangles, packet {i}");
            hits += each_lane_as_alone(&shapes, &bvh, p, &got, &mut stats, &label);
        }
    }
    assert!(
        packets > 2500 && refused > 30,
        "{packets} packets, {refused} refused"
    );
    assert!(hits > 8000, "{hits} hits");
}

/// A packet visits children nearest first too: eight rays down the street
/// of clusters stop in the first cluster (each ray tests at most its two
/// blocks there), where farthest first would test them all.
#[test]
fn an_eye_packet_stops_in_the_nearest_cluster() {
    let shapes = street_of_clusters();
    let bvh = hierarchy(&shapes, &BuildOptions::triangle_blocks());
    for (origin, towards, first) in [
        (Vec3::new(-5.0, 0.35, 0.0), 1.0f32, 0u32),
        (Vec3::new(300.0, 0.35, 0.0), -1.0, 63 * 8),
    ] {
        let p = Packet {
            origins: [origin; 8],
            dirs: std::array::from_fn(|l| {
                Vec3::new(towards, 1e-4 * l as f32, 2e-4 * l as f32).normalize()
            }),
            t_min: 0.0,
            t_max: [f32::INFINITY; 8],
            mask: 0xff,
        };
        let (single, two) = (Cell::new(0), Cell::new(0));
        let test = Counting::new(&shapes, &p, &single, &two);
        let mut st = TraversalStats::default();
        let got = bvh
            .closest_packet8(&p, &mut st, test)
            .expect("the rays' signs agree");
        // Eight triangles at one distance: the lowest index wins.
        assert_eq!(got.prim, [first; 8], "towards {towards}");
        assert!(
            st.prim_tests <= 8 * 16,
            "towards {towards}: {} primitive tests for 8 rays (a cluster has 8)",
            st.prim_tests
        );
    }
}

/// Packets of eight secondary rays, as a shading packet of eight spawns
/// them: each lane from its own point (points a little apart on a surface),
/// directions near one another (coherent) or anywhere (their signs mixed),
/// per-lane `t_max`, some lanes off.
fn secondary_packets(count: usize, seed: u64) -> Vec<Packet<8>> {
    let mut rng = fastrand::Rng::with_seed(seed);
    (0..count)
        .map(|i| {
            let mut v = || Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5);
            let base = v() * 30.0;
            let along = v() * 0.2;
            let aim = v() * 16.0;
            let spread = if i % 3 == 0 { 8.0 } else { 0.05 };
            let jitter: [Vec3; 8] = std::array::from_fn(|_| v() * spread);
            let origins = std::array::from_fn(|l| base + along * l as f32);
            let dirs = std::array::from_fn(|l| (aim + jitter[l] - base).normalize());
            let t_max = std::array::from_fn(|_| match rng.u8(..4) {
                0 => rng.f32() * 40.0,
                _ => f32::INFINITY,
            });
            Packet {
                origins,
                dirs,
                t_min: 0.0,
                t_max,
                mask: if i % 5 == 0 { rng.u32(1..256) } else { 0xff },
            }
        })
        .collect()
}

/// A packet of eight rays through `Bvh::closest` (the secondary rays of a
/// mono row's or a pair's shading packet): one descent where the lanes'
/// direction signs agree, each lane alone where they do not. Either way
/// every active lane's hit is, bit for bit, its own descent's and brute
/// force's. The coherent packets visit fewer nodes than their rays alone.
#[test]
fn secondary_packets_of_eight_give_each_ray_its_own_hit() {
    let (mut packet_nodes, mut alone_nodes, mut hits) = (0u64, 0u64, 0);
    for (n, seed) in [(60, 7), (700, 8), (3000, 9)] {
        let shapes = scene_with_ties(n, seed);
        let bvh = hierarchy(&shapes, &BuildOptions::triangle_blocks());
        for (i, p) in secondary_packets(900, seed + 30).iter().enumerate() {
            let (single, two) = (Cell::new(0), Cell::new(0));
            let test = Counting::new(&shapes, p, &single, &two);
            let mut stats = TraversalStats::default();
            let got = bvh.closest(p, &mut stats, test);
            let mut alone_stats = TraversalStats::default();
            let label = format!("{n} triangles, packet {i}");
            hits += each_lane_as_alone(&shapes, &bvh, p, &got, &mut alone_stats, &label);
            if i % 3 != 0 && p.mask == 0xff {
                packet_nodes += stats.nodes;
                alone_nodes += alone_stats.nodes;
            }
        }
    }
    assert!(hits > 3000, "{hits} hits");
    assert!(
        packet_nodes * 10 < alone_nodes * 7,
        "coherent packets visited {packet_nodes} nodes, their rays alone {alone_nodes}"
    );
}

//! The hierarchy build's output, pinned: on generated scenes (random boxes,
//! a triangle terrain large enough to be binned and partitioned on several
//! threads, and degenerate boxes: equal, flat, points, infinite and NaN), the
//! binary tree, the leaf order and the eight-wide tree are, word for word,
//! the ones the build made when the traversals were tuned (its fingerprints
//! are written below), on 1, 2 and 5 threads. The build may get faster; the
//! trees the traversals are tuned on must not change.

use twinray::bvh::{build, BuildOptions, Bvh};
use twinray::math::{Aabb, Vec3};

/// FNV-1a over 32-bit words.
struct Fnv(u64);

impl Fnv {
    fn word(&mut self, w: u32) {
        for b in w.to_le_bytes() {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x100_0000_01b3);
        }
    }

    fn floats(&mut self, f: &[f32]) {
        for x in f {
            self.word(x.to_bits());
        }
    }
}

/// Fingerprints of the binary tree, the order and the eight-wide tree, and
/// their sizes (to say which differs, and by how much).
fn fingerprint(bvh: &Bvh) -> [(usize, u64); 3] {
    let mut h = [Fnv(0xcbf2_9ce4_8422_2325), Fnv(0), Fnv(0)];
    for f in &mut h[1..] {
        f.0 = 0xcbf2_9ce4_8422_2325;
    }
    for n in &bvh.nodes {
        h[0].floats(&n.min);
        h[0].floats(&n.max);
        h[0].word(n.first);
        h[0].word(n.meta);
    }
    for &o in &bvh.order {
        h[1].word(o);
    }
    for n in &bvh.wide {
        for plane in &n.bounds {
            h[2].floats(plane);
        }
        n.child.iter().chain(&n.count).for_each(|&w| h[2].word(w));
    }
    [
        (bvh.nodes.len(), h[0].0),
        (bvh.order.len(), h[1].0),
        (bvh.wide.len(), h[2].0),
    ]
}

/// A small LCG, so that the scenes do not depend on a crate's generator.
struct Lcg(u64);

impl Lcg {
    fn f32(&mut self) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((self.0 >> 40) as f32) / (1u64 << 24) as f32
    }
}

fn random_boxes(n: usize, seed: u64) -> Vec<Aabb> {
    let mut rng = Lcg(seed);
    (0..n)
        .map(|_| {
            let c = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 100.0;
            let e = Vec3::new(rng.f32(), rng.f32(), rng.f32());
            Aabb {
                min: c - e,
                max: c + e,
            }
        })
        .collect()
}

/// The boxes of an `n` x `n`-cell terrain of two triangles per cell, heights
/// from the LCG (no trigonometry: the same numbers on every platform).
fn terrain_boxes(n: usize, seed: u64) -> Vec<Aabb> {
    let mut rng = Lcg(seed);
    let h: Vec<f32> = (0..(n + 1) * (n + 1)).map(|_| rng.f32() * 0.3).collect();
    let v = |i: usize, j: usize| Vec3::new(i as f32, h[j * (n + 1) + i], j as f32);
    (0..n * n)
        .flat_map(|k| {
            let (i, j) = (k % n, k / n);
            let (a, b, c, d) = (v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1));
            [Aabb::from_points(&[a, b, c]), Aabb::from_points(&[a, c, d])]
        })
        .collect()
}

/// Boxes that the binning must survive: many equal ones, flat ones, points,
/// tiny extents (a scale that overflows), empty, infinite and NaN ones.
fn degenerate_boxes() -> Vec<Aabb> {
    let mut boxes = random_boxes(3000, 7);
    let unit = Aabb {
        min: Vec3::ZERO,
        max: Vec3::ONE,
    };
    boxes.extend(std::iter::repeat_n(unit, 500));
    let mut rng = Lcg(11);
    for i in 0..500 {
        let p = Vec3::new(rng.f32(), rng.f32(), 0.0) * 10.0;
        boxes.push(Aabb { min: p, max: p });
        let q = Vec3::new(1e-39 * i as f32, 5.0, 5.0);
        boxes.push(Aabb { min: q, max: q });
    }
    boxes.push(Aabb::EMPTY);
    boxes.push(Aabb {
        min: Vec3::splat(f32::NEG_INFINITY),
        max: Vec3::splat(f32::INFINITY),
    });
    boxes.push(Aabb {
        min: Vec3::new(f32::NAN, 0.0, 0.0),
        max: Vec3::new(1.0, f32::NAN, 1.0),
    });
    boxes
}

fn on_threads(threads: usize, boxes: &[Aabb], opts: &BuildOptions) -> Bvh {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool")
        .install(|| build(boxes, opts))
}

fn check(name: &str, boxes: &[Aabb], opts: &BuildOptions, expected: [(usize, u64); 3]) {
    for threads in [1, 2, 5] {
        let got = fingerprint(&on_threads(threads, boxes, opts));
        for (what, (g, e)) in ["binary tree", "order", "eight-wide tree"]
            .iter()
            .zip(got.iter().zip(&expected))
        {
            assert_eq!(g, e, "{name}, {threads} threads: the {what} changed");
        }
    }
}

#[test]
fn random_boxes_build_the_pinned_trees() {
    check(
        "random boxes",
        &random_boxes(20_000, 3),
        &BuildOptions::default(),
        [
            (23763, 1396718233271190432),
            (20000, 11579139894679059029),
            (2788, 2409794244437805682),
        ],
    );
}

#[test]
fn a_terrain_builds_the_pinned_trees() {
    let boxes = terrain_boxes(200, 5);
    assert!(boxes.len() > 65_536, "binned and partitioned on threads");
    check(
        "terrain",
        &boxes,
        &BuildOptions::triangle_blocks(),
        [
            (26845, 16705722564054609182),
            (80304, 7195851947421864853),
            (2363, 18369775261303742892),
        ],
    );
}

#[test]
fn degenerate_boxes_build_the_pinned_trees() {
    check(
        "degenerate boxes",
        &degenerate_boxes(),
        &BuildOptions::aligned(),
        [
            (4659, 15624299634807097899),
            (9320, 10468124754423306285),
            (580, 2058841354310760623),
        ],
    );
}

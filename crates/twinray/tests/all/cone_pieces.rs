//! Long tilted cones filed in the hierarchy under the boxes of their pieces
//! (`Cone::pieces`, `bvh::build_pieces`; issue 17, thirteenth pass). A
//! tilted cylinder's own box is mostly empty; filed in pieces, fewer rays
//! that miss it test it. The hits must stay brute force's, bit for bit, for
//! rays and for shadow segments, and a glass cone must stay whole, so that a
//! shadow segment meets it once.

use crate::common;

use common::{brute, camera, difference, nff_world, options, rings, run};
use twinray::bvh::{self, AnyHit, Packet, SegmentPacket, TraversalStats};
use twinray::math::{Ray, Vec3};
use twinray::render::{Sampling, ViewMethod};
use twinray::rig::Rig;
use twinray::shading::shadow_packet;
use twinray::shapes::{Cone, Shape};
use twinray::World;

/// Rays from around the rings (`rings`' region) toward points among them.
fn random_rays(n: usize, seed: u64) -> Vec<(Vec3, Vec3)> {
    let mut rng = fastrand::Rng::with_seed(seed);
    let mut v = || Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5);
    (0..n)
        .map(|_| {
            let o = v() * 24.0;
            let at = v() * Vec3::new(11.0, 11.0, 4.0) + Vec3::Z * 1.5;
            (o, (at - o).normalize_or(Vec3::Z))
        })
        .collect()
}

/// The nearest hit of each ray traced alone, checked against brute force
/// bit for bit; returns the primitive tests the descents made.
fn nearest_tests(world: &World, tree: &bvh::Bvh, rays: &[(Vec3, Vec3)]) -> u64 {
    let shapes = &world.scene.shapes;
    let mut stats = TraversalStats::default();
    for (i, &(o, d)) in rays.iter().enumerate() {
        let p = Packet::ray(o, d);
        let ray = Ray::new(o, d);
        let got = tree.closest(&p, &mut stats, |prim: u32, _: usize, t_max: f32| {
            shapes[prim as usize].intersect(&ray, 0.0, t_max)
        });
        let found = got
            .has_hit(0)
            .then(|| (got.prim[0], got.hit[0].t.to_bits()));
        let expect = brute(shapes, &ray, 0.0, f32::INFINITY).map(|(p, h)| (p, h.t.to_bits()));
        assert_eq!(found, expect, "ray {i}: {o} {d}");
    }
    stats.prim_tests
}

/// The same shapes filed whole (one box each), for comparison.
fn filed_whole(world: &World) -> bvh::Bvh {
    let boxes: Vec<_> = world.scene.shapes.iter().map(Shape::bounds).collect();
    bvh::build(&boxes, &bvh::BuildOptions::aligned())
}

#[test]
fn a_tilted_cone_is_filed_in_pieces_that_cover_it() {
    let tilted = Cone::new(Vec3::ZERO, 0.05, Vec3::new(1.0, 0.8, 0.3), 0.05, false).unwrap();
    let k = tilted.pieces();
    assert!(k > 1, "a long tilted cylinder is filed in {k} piece(s)");
    // Along an axis the pieces' boxes only add up: one box.
    let upright = Cone::new(Vec3::ZERO, 0.05, Vec3::new(0.0, 0.0, 1.5), 0.05, false).unwrap();
    assert_eq!(upright.pieces(), 1);
    let squat = Cone::new(Vec3::ZERO, 1.0, Vec3::new(0.3, 0.2, 0.1), 0.5, false).unwrap();
    assert_eq!(squat.pieces(), 1);
    // Every hit on the cone lies in the box of some piece, and the pieces
    // lie within the cone's box.
    let whole = tilted.bounds();
    let pieces: Vec<_> = tilted.piece_boxes(k).collect();
    assert_eq!(pieces.len(), k as usize);
    for b in &pieces {
        assert!(whole.min.cmple(b.min).all() && b.max.cmple(whole.max).all());
    }
    let mut hits = 0;
    let mut rng = fastrand::Rng::with_seed(7);
    for _ in 0..5000 {
        // From anywhere around, toward a point near the axis.
        let o = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 6.0 - Vec3::splat(3.0);
        let at = Vec3::new(1.0, 0.8, 0.3) * rng.f32()
            + Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 0.12
            - Vec3::splat(0.06);
        let d = (at - o).normalize();
        if let Some(h) = tilted.intersect(&Ray::new(o, d), 0.0, f32::INFINITY) {
            hits += 1;
            let p = o + d * h.t;
            let inside = |b: &twinray::math::Aabb| {
                (b.min - Vec3::splat(1e-5)).cmple(p).all()
                    && p.cmple(b.max + Vec3::splat(1e-5)).all()
            };
            assert!(pieces.iter().any(inside), "hit {p} in no piece");
        }
    }
    assert!(hits > 1000, "{hits} hits");
}

#[test]
fn rays_find_brute_forces_hits_through_the_pieces_with_fewer_tests() {
    let world = nff_world(&rings(60, 3));
    let cones = world
        .scene
        .shapes
        .iter()
        .filter(|s| matches!(s, Shape::Cone(_)));
    assert_eq!(cones.count(), 300);
    let filed: usize = (0..world.scene.shapes.len() as u32)
        .map(|p| world.filed_boxes(p).count())
        .sum();
    assert!(filed > world.scene.shapes.len() + 200, "{filed} boxes");
    // A leaf names a primitive once, and a primitive is in no more leaves
    // than it has pieces (the pieces follow the shapes into leaf order).
    let mut leaves = vec![0; world.scene.shapes.len()];
    for leaf in world.bvh.leaves() {
        let mut prims: Vec<u32> = leaf.iter().copied().filter(|&p| p != bvh::PAD).collect();
        let n = prims.len();
        prims.sort_unstable();
        prims.dedup();
        assert_eq!(prims.len(), n, "a leaf names a primitive twice: {leaf:?}");
        for p in prims {
            leaves[p as usize] += 1;
        }
    }
    for (p, &n) in leaves.iter().enumerate() {
        assert!(
            n >= 1 && n <= world.filed_boxes(p as u32).count(),
            "primitive {p}: {n} leaves"
        );
    }
    assert!(leaves.iter().any(|&n| n > 1));
    let rays = random_rays(4000, 11);
    let pieces = nearest_tests(&world, &world.bvh, &rays);
    let whole = nearest_tests(&world, &filed_whole(&world), &rays);
    assert!(
        (pieces as f64) < 0.8 * whole as f64,
        "primitive tests: {pieces} in pieces, {whole} whole"
    );
}

#[test]
fn shadow_segments_are_blocked_as_brute_force_says() {
    let world = nff_world(&rings(60, 5));
    let shapes = &world.scene.shapes;
    let mut stats = TraversalStats::default();
    let mut blocked = 0;
    let points = random_rays(3000, 13);
    for (i, w) in points.windows(2).enumerate() {
        let (a, b) = (w[0].0 * 0.3, w[1].0 * 0.3);
        let d = (b - a).normalize();
        let t = (b - a).length();
        let seg = SegmentPacket {
            origins: [a],
            dirs: [d],
            t_max: [t],
            mask: 1,
        };
        let mut met = false;
        world
            .bvh
            .occlusion(&seg, &mut stats, &mut |prim: u32, _: usize| {
                if shapes[prim as usize]
                    .intersect(&Ray::new(a, d), 0.0, t)
                    .is_some()
                {
                    met = true;
                    AnyHit::Stop
                } else {
                    AnyHit::Continue
                }
            });
        let expect = shapes
            .iter()
            .any(|s| s.intersect(&Ray::new(a, d), 0.0, t).is_some());
        assert_eq!(met, expect, "segment {i}: {a} → {b}");
        blocked += met as usize;
    }
    assert!(blocked > 300 && blocked < 2700, "{blocked} blocked");
}

/// A glass cone is filed whole: a segment through both its ends meets it
/// once, so its transmittance counts once.
#[test]
fn a_glass_cone_stays_whole_and_its_light_counts_once() {
    let text = "v\nfrom 0 -8 0\nat 0 0 0\nup 0 0 1\nangle 40\nhither 0.01\nresolution 8 8\n\
                b 0 0 0\nl 0 0 9\nf 1 1 1 0.5 0 1 0.6 1\nc -2 -0.3 -1.2 0.3 2 0.3 1.2 0.3\n\
                f 1 1 1 1 0 1 0 1\nc -2 4 -1.2 0.3 2 4.6 1.2 0.3\n";
    let world = nff_world(text);
    let glass = (0..2u32).find(|&p| world.transmission_of(p) > 0.0).unwrap();
    let opaque = 1 - glass;
    assert_eq!(world.filed_boxes(glass).count(), 1);
    assert!(world.filed_boxes(opaque).count() > 1);
    // From inside one end, out through the wall at the other.
    let (a, b) = (Vec3::new(-1.8, -0.28, -1.0), Vec3::new(2.5, 0.6, 1.0));
    let d = (b - a).normalize();
    let seg = SegmentPacket {
        origins: [a],
        dirs: [d],
        t_max: [(b - a).length()],
        mask: 1,
    };
    let shape = &world.scene.shapes[glass as usize];
    assert!(shape
        .intersect(&Ray::new(a, d), 0.0, seg.t_max[0])
        .is_some());
    let (through, _) = shadow_packet(&world, &seg, &mut TraversalStats::default());
    assert_eq!(through[0], 0.6);
}

/// The twin method on a tree with cones in pieces: every view bit for bit
/// the independent renders', for a pair (its shadow segments in one
/// descent) and four views (eight-ray packets), both convergences.
#[test]
fn twin_views_equal_independent_renders_with_cones_in_pieces() {
    let world = nff_world(&rings(40, 9));
    assert!((0..world.scene.shapes.len() as u32).any(|p| world.filed_boxes(p).count() > 1));
    let cam = camera(&world, 64, 48);
    for (views, convergence) in [(2, None), (2, Some(12.0)), (4, Some(12.0))] {
        let rig = Rig::multi_view(&cam, views, 0.3, convergence).unwrap();
        let reference = run(
            &world,
            &cam,
            &rig,
            &options(ViewMethod::Independent, Sampling::Centers),
        );
        let twin = run(
            &world,
            &cam,
            &rig,
            &options(ViewMethod::twin(), Sampling::Centers),
        );
        let (worst, differ) = difference(&reference, &twin);
        assert_eq!(differ, 0, "{views} views, {convergence:?}: max {worst}");
        assert_eq!(reference.counts.rays, twin.counts.rays);
        assert!(twin.counts.rays.reflected > 0 && twin.counts.rays.shadow > 0);
    }
}

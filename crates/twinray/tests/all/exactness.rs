//! The paper's claim, tested: the twin method gives the same pixels as two
//! (or N) independent renders — bit for bit in float, so identically in 8-bit —
//! for every shipped scene (mirrors, glass, smooth patches, cones, floors and
//! walls parallel to the eyes), interaxial distances from 0 to large, and
//! convergence finite and infinite.

use crate::common;

use common::*;
use twinray::render::{RenderOptions, Sampling, ViewMethod};
use twinray::rig::Rig;
use twinray::Image;

fn assert_same_pixels(a: &Image, b: &Image, what: &str) {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let mut worst = 0.0f32;
    let mut differing = 0;
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        let d = (*p - *q).abs().max_element();
        if d > 0.0 || p.to_array().map(f32::to_bits) != q.to_array().map(f32::to_bits) {
            differing += 1;
        }
        worst = worst.max(d);
    }
    // The bound the issue allows is 1e-5; the implementation gives bit equality.
    assert!(worst <= 1e-5, "{what}: max difference {worst}");
    assert_eq!(
        differing, 0,
        "{what}: {differing} pixels differ in their bits (max {worst})"
    );
    // 8-bit output identical follows from bit equality; check it anyway.
    let to8 = |c: f32| (c.clamp(0.0, 1.0) * 255.0).round() as u8;
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        assert_eq!(
            p.to_array().map(to8),
            q.to_array().map(to8),
            "{what}: 8-bit"
        );
    }
}

/// The independent and the twin renders of `rig`, centre sampling.
fn independent_and_twin(
    world: &twinray::World,
    cam: &twinray::rig::Camera,
    rig: &Rig,
) -> (twinray::render::RenderOutput, twinray::render::RenderOutput) {
    let reference = run(
        world,
        cam,
        rig,
        &options(ViewMethod::Independent, Sampling::Centers),
    );
    let twin = run(
        world,
        cam,
        rig,
        &options(ViewMethod::twin(), Sampling::Centers),
    );
    (reference, twin)
}

fn check_scene(name: &str, width: u32, height: u32, interaxials: &[f32], sampling: Sampling) {
    let world = world(name);
    let cam = camera(&world, width, height);
    let conv = default_convergence(&world);
    for &interaxial in interaxials {
        for convergence in [None, Some(conv), Some(conv * 0.4)] {
            let rig = Rig::stereo(&cam, interaxial, convergence).unwrap();
            let reference = run(
                &world,
                &cam,
                &rig,
                &options(ViewMethod::Independent, sampling),
            );
            let twin = run(&world, &cam, &rig, &options(ViewMethod::twin(), sampling));
            for v in 0..2 {
                let what =
                    format!("{name} interaxial={interaxial} convergence={convergence:?} view {v} {sampling:?}");
                assert_same_pixels(&reference.images[v], &twin.images[v], &what);
            }
            // Same rays traced; each eye-ray descent serves both views (a
            // packet holds a few samples' rays of both eyes), so at most one
            // descent per sample, and no more than two mono renders make
            // (their packets hold neighbouring samples of one eye).
            assert_eq!(
                reference.counts.rays, twin.counts.rays,
                "{name} interaxial={interaxial}: ray counts"
            );
            assert!(
                2 * twin.counts.eye_traversals <= twin.counts.rays.eye
                    && twin.counts.eye_traversals <= reference.counts.eye_traversals,
                "{name} interaxial={interaxial}: {} descents for {} eye rays, independent {}",
                twin.counts.eye_traversals,
                twin.counts.rays.eye,
                reference.counts.eye_traversals
            );
        }
    }
}

#[test]
fn example_scene_twin_equals_independent() {
    // Mirror wall and floor parallel to the eyes, glass, cones, torus patches, a gear polygon.
    check_scene(
        "example.nff",
        96,
        72,
        &[0.0, 0.05, 0.3, 1.5],
        Sampling::Centers,
    );
}

#[test]
fn shelf_scene_twin_equals_independent() {
    // Many small objects: the views' hits are often on different objects.
    check_scene(
        "shelf.nff",
        80,
        60,
        &[0.0, 0.1, 0.8, 4.0],
        Sampling::Centers,
    );
}

#[test]
fn probe_scene_twin_equals_independent() {
    check_scene("probe.nff", 129, 65, &[0.0, 0.065, 0.5], Sampling::Centers);
}

#[test]
fn spd_corner_sampling_twin_equals_independent() {
    check_scene("example.nff", 48, 48, &[0.2], Sampling::Corners);
}

#[test]
fn interaxial_zero_gives_identical_eyes() {
    let world = world("example.nff");
    let cam = camera(&world, 64, 48);
    let rig = Rig::stereo(&cam, 0.0, None).unwrap();
    let out = run(
        &world,
        &cam,
        &rig,
        &options(ViewMethod::twin(), Sampling::Centers),
    );
    assert_same_pixels(&out.images[0], &out.images[1], "interaxial 0");
}

#[test]
fn multi_view_twin_equals_independent() {
    let world = world("example.nff");
    let cam = camera(&world, 64, 48);
    for count in [3, 5, 8] {
        let rig = Rig::multi_view(&cam, count, 0.12, Some(default_convergence(&world))).unwrap();
        let (reference, twin) = independent_and_twin(&world, &cam, &rig);
        for v in 0..count {
            assert_same_pixels(
                &reference.images[v],
                &twin.images[v],
                &format!("{count} views, view {v}"),
            );
        }
        // One descent serves the eye rays of every view of a batch through a
        // sample, or of two samples (batches of 4 neighbouring views by
        // default, eight rays a descent): at most one per sample and batch.
        let batches = count.div_ceil(RenderOptions::default().views_per_batch(count)) as u64;
        assert!(
            twin.counts.eye_traversals * count as u64 <= twin.counts.rays.eye * batches,
            "{count} views: at most one eye-ray descent per sample and batch"
        );
    }
}

#[test]
fn views_samples_of_one_point_are_shaded_together() {
    // Nearly every sample that hits the scene is seen by both eyes here: the
    // samples of one point are grouped, and their reflected rays (floor, mirror
    // wall, spheres) traced as one packet, four groups' rays to a packet of
    // eight (`TwinBatch::shade_groups_packed`).
    let world = world("example.nff");
    let cam = camera(&world, 96, 72);
    let rig = Rig::stereo(&cam, 0.3, None).unwrap();
    let twin = run(
        &world,
        &cam,
        &rig,
        &options(ViewMethod::twin(), Sampling::Centers),
    );
    assert!(twin.counts.shared_secondary > 0);
    assert!(
        twin.counts.shared_secondary_rays > 4 * twin.counts.shared_secondary,
        "{} secondary rays in {} packets",
        twin.counts.shared_secondary_rays,
        twin.counts.shared_secondary
    );
    let hits = twin.counts.rays.eye_hit;
    assert!(
        twin.counts.grouped_samples * 10 > hits * 8,
        "{} of {hits} hit samples grouped",
        twin.counts.grouped_samples
    );
    let reference = run(
        &world,
        &cam,
        &rig,
        &options(ViewMethod::Independent, Sampling::Centers),
    );
    assert_eq!(reference.counts.shared_secondary, 0);
    assert_eq!(reference.counts.grouped_samples, 0);
}

/// A thicket of thin branches (cones 0.002–0.004 wide, two from each fork,
/// like the SPD tree's twigs) seen from about 18 away: a thin cone's hit
/// computed from so far lost its radius to rounding, landed outside its
/// box, and a twin packet and a single ray, descending the tree in
/// different orders, then found different branches in a few pixels.
#[test]
fn thin_far_branches_twin_equals_independent() {
    use twinray::math::{Color, Vec3};
    use twinray::scene::{Light, Material, Viewpoint};
    let mut scene = twinray::Scene::new();
    scene.viewpoint = Viewpoint {
        from: Vec3::new(18.0, 1.6, 3.5),
        at: Vec3::new(0.0, 0.0, 1.5),
        up: Vec3::Z,
        angle_deg: 3.5,
        hither: 0.0,
        width: 160,
        height: 160,
        ..Viewpoint::default()
    };
    scene.background = Color::new(0.1, 0.4, 0.8);
    scene
        .lights
        .push(Light::point(Vec3::new(3.0, -4.0, 6.0), Some(Color::ONE)));
    scene.add_material(Material {
        color: Color::new(0.5, 0.35, 0.2),
        ..Material::default()
    });
    let mut seed = 11u32;
    let mut next = || {
        seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
        (seed >> 8) as f32 / (1u32 << 24) as f32
    };
    for _ in 0..3000 {
        let fork = Vec3::new(next() - 0.5, next() - 0.5, 1.2 + 0.6 * next());
        let r = 0.002 + 0.001 * next();
        for _ in 0..2 {
            let dir = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize();
            let tip = fork + dir * (0.015 + 0.015 * next());
            scene.add_cone(fork, r, tip, r * 0.67, "twig");
        }
    }
    let world = twinray::World::new(scene);
    let cam = camera(&world, 160, 160);
    let rig = Rig::multi_view(&cam, 8, 0.02, Some(18.0)).unwrap();
    let (reference, twin) = independent_and_twin(&world, &cam, &rig);
    for v in 0..8 {
        assert_same_pixels(
            &reference.images[v],
            &twin.images[v],
            &format!("thin branches, view {v}"),
        );
    }
}

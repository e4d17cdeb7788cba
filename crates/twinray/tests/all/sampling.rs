//! Anti-aliasing (the Sampler and the Film) and the paper's image coherence
//! (section 2.6): sample positions locked across views, the twin method equal
//! to the independent method for every sampling, the adaptive refinement
//! where it belongs (each view's own), renders independent of the thread
//! count, and views beyond one packet in batches.

use crate::common;

use std::path::Path;

use common::*;
use twinray::loaders::nff::parse_nff;
use twinray::loaders::LoadOptions;
use twinray::render::{Filter, RenderOptions, RenderOutput, Sampling, ViewMethod};
use twinray::rig::Camera;
use twinray::rig::Rig;
use twinray::World;

const FOUR_GAUSSIAN: Sampling = Sampling::Stratified {
    samples: 4,
    filter: Filter::Gaussian,
    seed: 0,
};
const ADAPTIVE: Sampling = Sampling::Adaptive {
    threshold: Sampling::DEFAULT_THRESHOLD,
    max_samples: 16,
};

fn with_sampling(method: ViewMethod, sampling: Sampling) -> RenderOptions {
    RenderOptions {
        sampling,
        ..options(method, Sampling::Centers)
    }
}

fn assert_equal(a: &RenderOutput, b: &RenderOutput, what: &str) {
    assert_eq!(a.images.len(), b.images.len());
    for (v, (p, q)) in a.images.iter().zip(&b.images).enumerate() {
        let differing = p
            .pixels
            .iter()
            .zip(&q.pixels)
            .filter(|(x, y)| x.to_array().map(f32::to_bits) != y.to_array().map(f32::to_bits))
            .count();
        assert_eq!(differing, 0, "{what}: view {v}, {differing} pixels differ");
    }
}

/// Twin and independent renders of `world` under `rig`, every sampling.
fn check_exact(world: &World, cam: &Camera, rig: &Rig, what: &str) {
    for sampling in [FOUR_GAUSSIAN, ADAPTIVE] {
        let reference = run(
            world,
            cam,
            rig,
            &with_sampling(ViewMethod::Independent, sampling),
        );
        let twin = run(
            world,
            cam,
            rig,
            &with_sampling(ViewMethod::twin(), sampling),
        );
        assert_equal(&reference, &twin, &format!("{what} {sampling:?}"));
        assert_eq!(
            reference.counts.rays, twin.counts.rays,
            "{what} {sampling:?}: the same rays"
        );
        assert_eq!(reference.samples_per_view, twin.samples_per_view);
        assert_eq!(reference.refined_pixels, twin.refined_pixels);
    }
}

#[test]
fn twin_equals_independent_for_every_sampling_on_the_shipped_scenes() {
    for (name, w, h) in [
        ("example.nff", 40, 30),
        ("shelf.nff", 40, 30),
        ("probe.nff", 65, 33),
    ] {
        let world = world(name);
        let cam = camera(&world, w, h);
        let conv = default_convergence(&world);
        for (interaxial, convergence) in [(0.1, Some(conv)), (0.4, None), (0.25, Some(conv * 0.4))]
        {
            let rig = Rig::stereo(&cam, interaxial, convergence).expect("rig");
            check_exact(
                &world,
                &cam,
                &rig,
                &format!("{name} interaxial={interaxial} c={convergence:?}"),
            );
        }
    }
}

/// A random scene: spheres and triangles of random materials (mirrors and
/// glass among them) over a floor, two lights.
fn random_scene(rng: &mut fastrand::Rng) -> String {
    let mut s = String::from(
        "b 0.1 0.2 0.3\nv\nfrom 0 -6 1.5\nat 0 0 0.5\nup 0 0 1\nangle 40\nhither 0.01\n\
         resolution 32 24\nl -3 -4 6\nl 4 -2 5 0.6 0.6 0.6\n\
         f 0.8 0.8 0.8 0.7 0.3 20 0 1\np 4 -6 -6 0 6 -6 0 6 6 0 -6 6 0\n",
    );
    let mut f = |lo: f32, hi: f32| lo + rng.f32() * (hi - lo);
    for _ in 0..6 {
        let (kd, ks, t) = (f(0.2, 0.9), f(0.0, 0.8), f(0.0, 0.6));
        s += &format!(
            "f {} {} {} {kd} {ks} {} {t} 1.{}\n",
            f(0.1, 1.0),
            f(0.1, 1.0),
            f(0.1, 1.0),
            f(1.0, 60.0),
            (f(1.0, 9.0)) as u32
        );
        if f(0.0, 1.0) < 0.6 {
            s += &format!(
                "s {} {} {} {}\n",
                f(-2.0, 2.0),
                f(-2.0, 3.0),
                f(0.2, 1.5),
                f(0.1, 0.8)
            );
        } else {
            let (x, y, z) = (f(-2.0, 2.0), f(-2.0, 3.0), f(0.1, 1.5));
            s += &format!(
                "p 3 {x} {y} {z} {} {} {} {} {} {}\n",
                x + f(-1.0, 1.0),
                y + f(-1.0, 1.0),
                z + f(0.0, 1.0),
                x + f(-1.0, 1.0),
                y + f(-1.0, 1.0),
                z + f(0.0, 1.0)
            );
        }
    }
    s
}

#[test]
fn twin_equals_independent_for_every_sampling_on_random_scenes() {
    let mut rng = fastrand::Rng::with_seed(2026);
    for n in 0..6 {
        let text = random_scene(&mut rng);
        let scene = parse_nff(&text, Path::new("random.nff"), &LoadOptions::default())
            .unwrap_or_else(|e| panic!("random scene {n}: {e}\n{text}"));
        let world = World::new(scene);
        let cam = camera(&world, 32, 24);
        let interaxial = 0.05 + rng.f32() * 0.4;
        let convergence = [None, Some(3.0), Some(8.0)][n % 3];
        let rig = Rig::stereo(&cam, interaxial, convergence).expect("rig");
        check_exact(&world, &cam, &rig, &format!("random scene {n}:\n{text}\n"));
    }
}

#[test]
fn every_view_samples_the_same_positions_of_its_pixels() {
    // Eyes at one point (interaxial 0) see the same image only if each view's
    // pixel is sampled at the same points: a pattern that depended on the
    // view would give two different images of one scene.
    let world = world("example.nff");
    let cam = camera(&world, 48, 36);
    let rig = Rig::multi_view(&cam, 3, 0.0, None).expect("rig");
    for sampling in [FOUR_GAUSSIAN, ADAPTIVE] {
        let out = run(
            &world,
            &cam,
            &rig,
            &with_sampling(ViewMethod::twin(), sampling),
        );
        assert_eq!(out.images[0], out.images[1], "{sampling:?}");
        assert_eq!(out.images[0], out.images[2], "{sampling:?}");
    }
    // And a seed changes the pattern (so the test above could fail).
    let mono = |seed| {
        let sampling = Sampling::Stratified {
            samples: 4,
            filter: Filter::Box,
            seed,
        };
        run(
            &world,
            &cam,
            &Rig::mono(),
            &with_sampling(ViewMethod::twin(), sampling),
        )
        .images
    };
    assert_ne!(mono(0), mono(1));
}

#[test]
fn more_samples_approach_the_many_samples_image() {
    // Anti-aliasing does what it is for: at an edge-rich scene, the error
    // against a 64-sample render (another seed) falls as the samples grow.
    let world = world("example.nff");
    let cam = camera(&world, 48, 36);
    let render = |sampling| {
        let out = run(
            &world,
            &cam,
            &Rig::mono(),
            &with_sampling(ViewMethod::twin(), sampling),
        );
        out.images.into_iter().next().expect("one view")
    };
    let reference = render(Sampling::Stratified {
        samples: 64,
        filter: Filter::Box,
        seed: 9,
    });
    let error = |sampling| {
        twinray::output::compare(&reference, &render(sampling))
            .expect("sizes")
            .psnr_db
    };
    let one = error(Sampling::Centers);
    let sixteen = error(Sampling::Stratified {
        samples: 16,
        filter: Filter::Box,
        seed: 0,
    });
    let adaptive = error(ADAPTIVE);
    assert!(
        sixteen > one + 6.0,
        "16 samples {sixteen} dB, 1 sample {one} dB"
    );
    assert!(
        adaptive > one + 6.0,
        "adaptive {adaptive} dB, 1 sample {one} dB"
    );
}

#[test]
fn adaptive_sampling_refines_edges_only() {
    // A white square on black, its edges inside pixels: the pixels it covers
    // wholly or not at all are not refined; those its edges cross are.
    let text = "b 0 0 0\nv\nfrom 0 0 10\nat 0 0 0\nup 0 1 0\nangle 20\nhither 0.01\n\
                resolution 32 32\nl 0 0 10\nf 1 1 1 1 0 1 0 1\n\
                p 4 -1.03 -1.03 0 1.03 -1.03 0 1.03 1.03 0 -1.03 1.03 0\n";
    let scene = parse_nff(text, Path::new("square.nff"), &LoadOptions::default()).expect("scene");
    let world = World::new(scene);
    let cam = camera(&world, 32, 32);
    let out = run(
        &world,
        &cam,
        &Rig::mono(),
        &with_sampling(ViewMethod::twin(), ADAPTIVE),
    );
    // The square spans 2.06 / (2 tan 10°) x 32 = 18.7 pixels: its outline
    // crosses 4 x 19 pixels, give or take the corners.
    let refined = out.refined_pixels;
    assert!((72..=84).contains(&refined), "{refined} pixels refined");
    let img = &out.images[0];
    let at = |x: usize, y: usize| img.pixels[y * 32 + x].x;
    assert_eq!(at(0, 0), 0.0, "the black corner is black");
    assert!(at(16, 16) > 0.5, "the square's middle is lit");
    // Edge pixels lie strictly between: covered in part.
    let edge: Vec<f32> = (0..32)
        .map(|x| at(x, 16))
        .filter(|&v| v > 0.0 && v < at(16, 16) * 0.99)
        .collect();
    assert_eq!(
        edge.len(),
        2,
        "one partly covered pixel each side: {edge:?}"
    );
    // Flat pixels take their four corners only: far fewer rays than 16 a pixel.
    assert!(
        out.samples_per_view < 32 * 32 * 4,
        "{} samples",
        out.samples_per_view
    );
    // An edge pixel is split twice (more than the 9 points of one split),
    // but only its cells that the edge crosses: fewer than all 25 points.
    let most = out.max_samples_per_pixel;
    assert!(most > 9 && most < 25, "{most} samples in the busiest pixel");
}

#[test]
fn same_images_for_any_thread_count_with_every_sampling() {
    let world = world("example.nff");
    let cam = camera(&world, 40, 30);
    let rig = Rig::stereo(&cam, 0.3, Some(default_convergence(&world))).expect("rig");
    for sampling in [FOUR_GAUSSIAN, ADAPTIVE] {
        for method in [ViewMethod::Independent, ViewMethod::twin()] {
            let opts = with_sampling(method, sampling);
            let render_with = |threads| run_on_threads(threads, &world, &cam, &rig, &opts);
            let one = render_with(1);
            for threads in [2, 5] {
                let many = render_with(threads);
                assert_eq!(
                    one.images, many.images,
                    "{sampling:?} {method:?} {threads} threads"
                );
                assert_eq!(one.counts.rays, many.counts.rays);
            }
        }
    }
}

#[test]
fn more_samples_keep_the_views_grouped() {
    // Each sample row is a row of the twin method: with 4 samples per pixel
    // the views' samples of one point are still shaded together.
    let world = world("example.nff");
    let cam = camera(&world, 48, 36);
    let rig = Rig::stereo(&cam, 0.3, None).expect("rig");
    let out = run(
        &world,
        &cam,
        &rig,
        &with_sampling(ViewMethod::twin(), FOUR_GAUSSIAN),
    );
    let hits = out.counts.rays.eye_hit;
    assert!(
        out.counts.grouped_samples * 10 > hits * 8,
        "{} of {hits} hit samples grouped",
        out.counts.grouped_samples
    );
    // Every descent serves both eyes' rays (of one sample or a few).
    assert!(out.counts.eye_traversals * 2 <= out.counts.rays.eye);
}

#[test]
fn views_beyond_one_packet_are_traced_in_batches_and_stay_exact() {
    let world = world("example.nff");
    let cam = camera(&world, 24, 18);
    let conv = default_convergence(&world);
    for (count, batch) in [(40, 0), (8, 3)] {
        let rig = Rig::multi_view(&cam, count, 0.02, Some(conv)).expect("rig");
        let reference = run(
            &world,
            &cam,
            &rig,
            &options(ViewMethod::Independent, Sampling::Centers),
        );
        let twin_opts = RenderOptions {
            views_per_batch: batch,
            ..options(ViewMethod::twin(), Sampling::Centers)
        };
        let twin = run(&world, &cam, &rig, &twin_opts);
        assert_eq!(twin.images.len(), count);
        assert_equal(
            &reference,
            &twin,
            &format!("{count} views in batches of {batch}"),
        );
        // At most one eye-ray descent per sample and batch (a descent
        // serves every view of its batch, for one sample or a few).
        let size = twin_opts.views_per_batch(count);
        let batches = count.div_ceil(size) as u64;
        assert!(
            twin.counts.eye_traversals <= batches * u64::from(cam.width * cam.height),
            "{count} views, batches of {size}: {} descents",
            twin.counts.eye_traversals
        );
    }
}

#[test]
fn adaptive_stereo_refines_each_view_as_it_would_alone() {
    // Each view refines its own edges: a pair's view traces the samples
    // its mono render does (the pair's figures are the views' means), and
    // the points both views refine go down the hierarchy together.
    let world = world("example.nff");
    let cam = camera(&world, 48, 36);
    let rig = Rig::stereo(&cam, 0.3, Some(default_convergence(&world))).expect("rig");
    let pair = run(
        &world,
        &cam,
        &rig,
        &with_sampling(ViewMethod::twin(), ADAPTIVE),
    );
    let alone: Vec<RenderOutput> = rig
        .views
        .iter()
        .map(|view| {
            let one = Rig {
                views: vec![*view],
                ..rig.clone()
            };
            run(
                &world,
                &cam,
                &one,
                &with_sampling(ViewMethod::twin(), ADAPTIVE),
            )
        })
        .collect();
    let sum = |f: fn(&RenderOutput) -> u64| alone.iter().map(f).sum::<u64>();
    assert_eq!(pair.counts.rays.eye, sum(|o| o.counts.rays.eye));
    assert_eq!(pair.samples_per_view, sum(|o| o.samples_per_view) / 2);
    assert_eq!(pair.refined_pixels, sum(|o| o.refined_pixels) / 2);
    // The views' refinements differ (the eyes see the edges at different
    // pixels), so the test above could fail under a joint refinement.
    assert_ne!(alone[0].samples_per_view, alone[1].samples_per_view);
    assert!(
        pair.counts.eye_traversals < sum(|o| o.counts.eye_traversals),
        "pair {} descents, views alone {}",
        pair.counts.eye_traversals,
        sum(|o| o.counts.eye_traversals)
    );
    for (v, one) in alone.iter().enumerate() {
        assert_eq!(pair.images[v], one.images[0], "view {v}");
    }
}

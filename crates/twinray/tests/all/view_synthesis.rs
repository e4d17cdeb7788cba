//! Key-view synthesis (`--synthesize-views`, issue 16): every K-th view is
//! traced; the views between take, row by row, the colours their nearest key
//! view saw, moved by their disparity, where the surface is plain, the
//! colour linear within E and the region between the key view's rays and
//! theirs proved free; the rest is traced. Key views are exact; every view
//! stays within E of the independent renders on scenes where that holds
//! (diffuse, no detail finer than a pixel); a pole only one view sees, a
//! shadow edge, a mirror and a small ball's shadow are kept; the images do
//! not depend on the threads.

use crate::common;

use common::*;
use twinray::render::{
    Approximations, Method, RenderOptions, RenderOutput, Sampling, SynthesisStats, ViewSynthesis,
};
use twinray::rig::{Camera, Rig};
use twinray::World;

const WIDTH: u32 = 40;
const HEIGHT: u32 = 30;
const INTERAXIAL: f32 = 0.01;
const E: f32 = 0.01;

fn synthesizing(spacing: usize, tolerance: f32, sampling: Sampling) -> RenderOptions {
    RenderOptions {
        approx: Approximations {
            synthesize_views: Some(ViewSynthesis { spacing, tolerance }),
            ..Approximations::default()
        },
        ..options(Method::Twin, sampling)
    }
}

/// `world`'s `views` views independently and synthesized (key view every
/// `spacing`, on `threads` threads): the largest difference, the pixels
/// that differ, and the synthesized render.
fn against_exact(
    world: &World,
    camera: &Camera,
    views: usize,
    spacing: usize,
    threads: usize,
) -> (f32, usize, RenderOutput) {
    let rig = Rig::multi_view(camera, views, INTERAXIAL, None).expect("rig");
    let exact = run(
        world,
        camera,
        &rig,
        &options(Method::Independent, Sampling::Centers),
    );
    let out = run_on_threads(
        threads,
        world,
        camera,
        &rig,
        &synthesizing(spacing, E, Sampling::Centers),
    );
    let (worst, differ) = difference(&exact, &out);
    (worst, differ, out)
}

fn independent(world: &World, camera: &Camera, rig: &Rig) -> RenderOutput {
    run(
        world,
        camera,
        rig,
        &options(Method::Independent, Sampling::Centers),
    )
}

fn camera(world: &World) -> Camera {
    Camera::new(&world.scene.viewpoint, WIDTH, HEIGHT)
}

/// On an open diffuse floor most samples of the views between are
/// synthesized, each within E of the independent render; the key views
/// (every 8th and the last) are the independent renders bit for bit, and
/// every sample is counted once.
#[test]
fn a_diffuse_open_floor_is_synthesized_within_the_tolerance() {
    let world = nff_world(OPEN_FLOOR);
    let camera = camera(&world);
    for views in [3, 9, 48] {
        let (worst, differ, out) = against_exact(&world, &camera, views, 8, 1);
        let y = out.counts.synthesis;
        let per_view = (WIDTH * HEIGHT) as u64;
        let keys = views.div_ceil(8) as u64 + u64::from((views - 1) % 8 != 0);
        assert!(worst <= E, "{views} views: {worst}, {y:?}");
        assert_eq!(y.key_samples, keys * per_view, "{views} views: {y:?}");
        assert_eq!(
            y.synthesized + y.traced,
            (views as u64 - keys) * per_view,
            "{views} views: {y:?}"
        );
        assert!(y.synthesized * 2 > y.traced, "{views} views: {y:?}");
        assert!(differ as u64 <= y.synthesized, "{views} views");
        // Fewer eye rays than samples: the point of the mode.
        assert_eq!(out.counts.rays.eye, y.key_samples + y.traced);
    }
}

/// The key views are exact: the same pixels as the independent renders.
#[test]
fn key_views_are_the_independent_renders() {
    let ball = "f 0.9 0.2 0.2 0.9 0 0 0 1\ns 0 0 0.6 0.5\n";
    let world = nff_world(&format!("{OPEN_FLOOR}{ball}"));
    let camera = camera(&world);
    let rig = Rig::multi_view(&camera, 17, INTERAXIAL, None).expect("rig");
    let exact = independent(&world, &camera, &rig);
    let out = run(
        &world,
        &camera,
        &rig,
        &synthesizing(4, E, Sampling::Centers),
    );
    for v in [0, 4, 8, 12, 16] {
        assert!(
            exact.images[v].pixels == out.images[v].pixels,
            "key view {v}"
        );
    }
    assert!(out.counts.synthesis.synthesized > 0);
}

/// A pole 0.003 wide in front of the floor: in a row only one or two of 48
/// views see it, and no key view does. The region between the key view's
/// rays and those views' is not free, so they trace it: kept. (The light
/// stands above it: its shadow, as thin, would be detail finer than the key
/// view's samples on the floor, which the synthesis does not see.)
#[test]
fn a_pole_seen_by_one_view_only_is_kept() {
    let above = OPEN_FLOOR.replace("l 3 2 10", "l 0.2015 0 50");
    let pole = "f 0.1 0.9 0.1 0.9 0 0 0 1\np 4\n0.2 0 0\n0.203 0 0\n0.203 0 2\n0.2 0 2\n";
    let world = nff_world(&format!("{above}{pole}"));
    let bare = nff_world(&above);
    let camera = camera(&world);
    let rig = Rig::multi_view(&camera, 48, INTERAXIAL, None).expect("rig");
    let exact = independent(&world, &camera, &rig);
    let without = independent(&bare, &camera, &rig);
    let sees = |v: usize| exact.images[v].pixels != without.images[v].pixels;
    let seeing: Vec<usize> = (0..48).filter(|&v| sees(v)).collect();
    assert!(!seeing.is_empty(), "the pole is in some view");
    assert!(seeing.len() < 48, "not in every view: {seeing:?}");
    let (worst, _, out) = against_exact(&world, &camera, 48, 8, 1);
    assert!(worst <= E, "{worst}, {:?}", out.counts.synthesis);
    assert!(out.counts.synthesis.refused_region > 0);
}

/// A bar out of the frame, between the light and the floor, casts a shadow
/// a few pixels wide: its edges bend the key view's colours, so the views
/// between trace them.
#[test]
fn a_shadow_edge_is_kept() {
    let bar = "f 0.5 0.5 0.5 0.9 0 0 0 1\nc\n2 -20 6 0.15\n2 20 6 0.15\n";
    let world = nff_world(&format!("{OPEN_FLOOR}{bar}"));
    let camera = camera(&world);
    for views in [8, 48] {
        let (worst, _, out) = against_exact(&world, &camera, views, 8, 1);
        let y = out.counts.synthesis;
        assert!(worst <= E, "{views} views: {worst}, {y:?}");
        assert!(y.refused_surface > 0, "{views} views: {y:?}");
        assert!(y.synthesized > 0, "{views} views: {y:?}");
    }
}

/// A small ball between the light and the floor: its round shadow on the
/// floor, and the ball itself, are kept in every view.
#[test]
fn a_small_balls_shadow_is_kept() {
    let ball = "f 0.5 0.5 0.5 0.9 0 0 0 1\ns 1.5 1 1 0.3\n";
    let world = nff_world(&format!("{OPEN_FLOOR}{ball}"));
    let camera = camera(&world);
    let (worst, _, out) = against_exact(&world, &camera, 24, 8, 1);
    let y = out.counts.synthesis;
    assert!(worst <= E, "{worst}, {y:?}");
    assert!(y.refused_edge > 0, "the ball's silhouette: {y:?}");
}

/// A mirror floor reflecting a thin dark pole against a bright sky: what it
/// shows changes from view to view, so every sample on it is traced (a
/// mirror weight above E), and the views equal the independent renders.
#[test]
fn a_mirror_whose_reflection_changes_between_views_is_traced() {
    let world = nff_world(MIRROR_FLOOR_AND_POLE);
    let camera = camera(&world);
    let (worst, _, out) = against_exact(&world, &camera, 48, 8, 1);
    let y = out.counts.synthesis;
    assert!(y.refused_material > 0, "{y:?}");
    assert!(worst <= E, "{worst}, {y:?}");
    // The floor fills the lower rows: their samples are all traced, so the
    // only synthesized ones are the sky's.
    let rig = Rig::multi_view(&camera, 48, INTERAXIAL, None).expect("rig");
    let exact = independent(&world, &camera, &rig);
    let bottom = ((HEIGHT - 1) * WIDTH) as usize..(HEIGHT * WIDTH) as usize;
    for v in 0..48 {
        assert!(
            exact.images[v].pixels[bottom.clone()] == out.images[v].pixels[bottom.clone()],
            "view {v}: the mirror's bottom row"
        );
    }
}

/// Samplings whose rows lie in no epipolar plane (N samples per pixel) are
/// traced exactly in every view.
#[test]
fn other_samplings_are_traced_exactly() {
    let world = nff_world(OPEN_FLOOR);
    let camera = camera(&world);
    let rig = Rig::multi_view(&camera, 5, INTERAXIAL, None).expect("rig");
    let sampling = Sampling::Stratified {
        samples: 2,
        filter: twinray::render::Filter::Box,
        seed: 0,
    };
    let exact = run(
        &world,
        &camera,
        &rig,
        &options(Method::Independent, sampling),
    );
    let out = run(&world, &camera, &rig, &synthesizing(2, E, sampling));
    assert_eq!(difference(&exact, &out), (0.0, 0));
    let y: SynthesisStats = out.counts.synthesis;
    assert!(y.rows_exact > 0 && y.synthesized == 0, "{y:?}");
}

/// The same images and counts on 1, 2 and 5 threads.
#[test]
fn one_two_and_five_threads_give_the_same_images() {
    let bar = "f 0.5 0.5 0.5 0.9 0 0 0 1\nc\n2 -20 6 0.01\n2 20 6 0.01\n";
    let world = nff_world(&format!("{OPEN_FLOOR}{bar}"));
    let camera = camera(&world);
    let (_, _, one) = against_exact(&world, &camera, 24, 8, 1);
    for threads in [2, 5] {
        let (_, _, other) = against_exact(&world, &camera, 24, 8, threads);
        assert_eq!(
            one.counts.synthesis, other.counts.synthesis,
            "{threads} threads"
        );
        for (a, b) in one.images.iter().zip(&other.images) {
            assert!(a.pixels == b.pixels, "{threads} threads");
        }
    }
}

/// A diffuse ball near the camera over the floor, the views 0.2 apart
/// (pixels of parallax between them): floor that a key view saw is hidden
/// by the ball in the views between, and floor it did not see appears. Each
/// view stays within E of its independent render. (Which bracket covers a
/// hidden sample decides only why it is traced: the floor's region would
/// meet the ball. Covering with the farthest bracket instead of the nearest
/// gives the same images, so no test can fail on that rule.)
#[test]
fn the_nearest_surface_covers_the_views_between() {
    let above = OPEN_FLOOR.replace("l 3 2 10", "l 0 0 50");
    let ball = "f 0.9 0.2 0.2 0.9 0 0 0 1\ns 0 -3 2.5 0.3\n";
    let world = nff_world(&format!("{above}{ball}"));
    let camera = camera(&world);
    let rig = Rig::multi_view(&camera, 9, 0.2, None).expect("rig");
    let exact = independent(&world, &camera, &rig);
    let out = run(
        &world,
        &camera,
        &rig,
        &synthesizing(8, E, Sampling::Centers),
    );
    let y = out.counts.synthesis;
    let (worst, _) = difference(&exact, &out);
    assert!(worst <= E, "{worst}, {y:?}");
    assert!(y.synthesized > 0 && y.holes > 0, "{y:?}");
}

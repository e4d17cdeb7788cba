//! Epipolar rows (the fast method's first stage, alone): every view's eye hits of a
//! row found at once from the primitives that cross the row's plane, and a
//! diffuse surface's colour shaded once and taken by the views after, between
//! two shade points within a pixel and a half whose colours differ by at most
//! E. Every view stays within E of the independent renders on scenes where
//! that holds (no detail finer than a pixel); a pole only one view sees, a
//! shadow edge and a mirror are kept; the images do not depend on the
//! threads.

use crate::common;

use common::*;
use twinray::render::{
    EpipolarCounts, FastStages, RenderOptions, RenderOutput, Sampling, ViewMethod,
};
use twinray::rig::{Camera, Rig};
use twinray::World;

const WIDTH: u32 = 40;
const HEIGHT: u32 = 30;
const INTERAXIAL: f32 = 0.01;
const E: f32 = 0.01;

/// The fast method's epipolar rows alone: the rows they do not take are
/// traced exactly (no shading cache, no merged rays, no cut).
fn epipolar(tolerance: f32, sampling: Sampling) -> RenderOptions {
    RenderOptions {
        fast_stages: Some(FastStages {
            epipolar_rows: true,
            shared_cache: false,
            tolerance,
        }),
        ..options(ViewMethod::Fast { tolerance }, sampling)
    }
}

fn camera(world: &World) -> Camera {
    Camera::new(&world.scene.viewpoint, WIDTH, HEIGHT)
}

fn independent(world: &World, camera: &Camera, rig: &Rig) -> RenderOutput {
    run(
        world,
        camera,
        rig,
        &options(ViewMethod::Independent, Sampling::Centers),
    )
}

/// `views` views of `world`, independently and by epipolar rows (on
/// `threads` threads, `interaxial` apart): the largest difference, the
/// pixels that differ, and the epipolar render.
fn against_exact(
    world: &World,
    views: usize,
    interaxial: f32,
    threads: usize,
) -> (f32, usize, RenderOutput) {
    let camera = camera(world);
    let rig = Rig::multi_view(&camera, views, interaxial, None).expect("rig");
    let exact = independent(world, &camera, &rig);
    let out = run_on_threads(
        threads,
        world,
        &camera,
        &rig,
        &epipolar(E, Sampling::Centers),
    );
    let (worst, differ) = difference(&exact, &out);
    (worst, differ, out)
}

/// On an open diffuse floor most samples take their colour from shade
/// points, each within E of the independent render; every sample is
/// counted once; the middle view (visited first) is traced whole.
#[test]
fn a_diffuse_open_floor_is_shaded_once_within_the_tolerance() {
    let world = nff_world(OPEN_FLOOR);
    for views in [3, 9, 48] {
        let (worst, differ, out) = against_exact(&world, views, INTERAXIAL, 1);
        let e = out.counts.fast.epipolar;
        let per_view = (WIDTH * HEIGHT) as u64;
        assert!(worst <= E, "{views} views: {worst}, {e:?}");
        assert_eq!(e.rows, HEIGHT as u64, "{views} views: {e:?}");
        assert_eq!(
            e.taken + e.light_taken + e.light_partly_taken + e.traced + e.misses,
            views as u64 * per_view,
            "{views} views: {e:?}"
        );
        assert!(e.taken > e.traced, "{views} views: {e:?}");
        assert!(
            e.traced >= per_view - e.misses / views as u64,
            "{views} views: {e:?}"
        );
        assert!(differ as u64 <= e.taken, "{views} views");
        // No eye ray is traced: the views' hits come from the rows' planes,
        // and are counted per view.
        assert_eq!(out.counts.rays.eye, 0, "{views} views");
        let hits: u64 = out.counts.per_view_hits.0[..views].iter().sum();
        assert_eq!(hits, views as u64 * per_view - e.misses, "{views} views");
    }
}

/// A pole 0.003 wide in front of the floor, which only one or a few of 48
/// views see, and not the middle view: the row's plane holds it, so the
/// views that see it trace it, and the others do not show it.
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
    let (worst, _, out) = against_exact(&world, 48, INTERAXIAL, 1);
    assert!(worst <= E, "{worst}, {:?}", out.counts.fast.epipolar);
    for &v in &seeing {
        assert!(
            out.images[v].pixels != without.images[v].pixels,
            "view {v} shows the pole"
        );
    }
}

/// A bar out of the frame, between the light and the floor, casts a shadow
/// a few pixels wide: at its edges the shade points' colours are apart, so
/// the samples between them are traced.
#[test]
fn a_shadow_edge_is_kept() {
    let bar = "f 0.5 0.5 0.5 0.9 0 0 0 1\nc\n2 -20 6 0.15\n2 20 6 0.15\n";
    let world = nff_world(&format!("{OPEN_FLOOR}{bar}"));
    for views in [8, 48] {
        let (worst, _, out) = against_exact(&world, views, INTERAXIAL, 1);
        let e = out.counts.fast.epipolar;
        assert!(worst <= E, "{views} views: {worst}, {e:?}");
        assert!(e.refused_colour > 0, "{views} views: {e:?}");
        assert!(e.taken > 0, "{views} views: {e:?}");
    }
}

/// Two lights, each casting the bar's shadow at its own place: next to one
/// light's shadow edge the shade points saw the other light alike, so a
/// sample there takes that light and traces its own shadow ray toward the
/// first only; every view stays within E (a light taken where the edge
/// passes would be off by its whole contribution).
#[test]
fn next_to_one_lights_shadow_edge_only_that_light_is_traced() {
    let lights = OPEN_FLOOR.replace("l 3 2 10", "l 3 2 10\nl -4 1 9");
    let bar = "f 0.5 0.5 0.5 0.9 0 0 0 1\nc\n2 -20 6 0.15\n2 20 6 0.15\n";
    let world = nff_world(&format!("{lights}{bar}"));
    for views in [8, 48] {
        let (worst, _, out) = against_exact(&world, views, INTERAXIAL, 1);
        let e = out.counts.fast.epipolar;
        assert!(worst <= E, "{views} views: {worst}, {e:?}");
        assert!(e.light_partly_taken > 0, "{views} views: {e:?}");
        // One of the two lights traced, never both.
        assert_eq!(
            e.lights_traced, e.light_partly_taken,
            "{views} views: {e:?}"
        );
    }
}

/// A diffuse ball near the camera over the floor, the views 0.2 apart
/// (pixels of parallax between them): floor hidden from the middle view
/// appears in the others, and their samples there find no shade point on
/// one side; every view stays within E, and the ball's sphere shares its
/// colour too.
#[test]
fn floor_behind_a_ball_is_traced_where_no_view_shaded_it() {
    let above = OPEN_FLOOR.replace("l 3 2 10", "l 0 0 50");
    let ball = "f 0.9 0.2 0.2 0.9 0 0 0 1\ns 0 -3 2.5 0.3\n";
    let world = nff_world(&format!("{above}{ball}"));
    let (worst, _, out) = against_exact(&world, 9, 0.2, 1);
    let e = out.counts.fast.epipolar;
    assert!(worst <= E, "{worst}, {e:?}");
    assert!(e.taken > 0 && e.no_bracket > 0, "{e:?}");
    // The ball's colour turns faster than E a pixel: its samples take the
    // light of their shade points and shade themselves.
    assert!(e.light_taken > 0, "{e:?}");
}

/// A mirror floor reflecting a thin dark pole against a bright sky: what it
/// shows changes from view to view, so every sample on it is traced, and
/// the floor's pixels are the independent renders'.
#[test]
fn a_mirror_whose_reflection_changes_between_views_is_traced() {
    let world = nff_world(MIRROR_FLOOR_AND_POLE);
    let camera = camera(&world);
    let (worst, _, out) = against_exact(&world, 48, INTERAXIAL, 1);
    let e = out.counts.fast.epipolar;
    assert!(e.refused_material > 0, "{e:?}");
    assert!(worst <= E, "{worst}, {e:?}");
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

/// A wall whose plane passes between the views (the middle view sees it
/// edge-on), lit on one face: the views on either side see their own face,
/// lit or dark, and take no colour or light from shade points of the other.
#[test]
fn a_wall_between_the_views_shows_each_view_its_own_face() {
    let world = nff_world(WALL_BETWEEN_VIEWS);
    let (worst, _, out) = against_exact(&world, 9, 0.5, 1);
    let e = out.counts.fast.epipolar;
    assert!(worst <= E, "{worst}, {e:?}");
    assert!(e.taken > 0 && e.refused_face > 0, "{e:?}");
}

/// Samplings whose rows lie in no plane (N samples per pixel) are traced
/// exactly in every view.
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
        &options(ViewMethod::Independent, sampling),
    );
    let out = run(&world, &camera, &rig, &epipolar(E, sampling));
    assert_eq!(difference(&exact, &out), (0.0, 0));
    let e: EpipolarCounts = out.counts.fast.epipolar;
    assert!(e.rows_exact > 0 && e.taken == 0, "{e:?}");
}

/// The same images and counts on 1, 2 and 5 threads.
#[test]
fn one_two_and_five_threads_give_the_same_images() {
    let bar = "f 0.5 0.5 0.5 0.9 0 0 0 1\nc\n2 -20 6 0.05\n2 20 6 0.05\n";
    let ball = "f 0.9 0.2 0.2 0.9 0 0 0 1\ns 0 -3 2.5 0.3\n";
    let world = nff_world(&format!("{OPEN_FLOOR}{bar}{ball}"));
    let (_, _, one) = against_exact(&world, 24, 0.05, 1);
    assert!(one.counts.fast.epipolar.taken > 0);
    for threads in [2, 5] {
        let (_, _, other) = against_exact(&world, 24, 0.05, threads);
        assert_eq!(
            one.counts.fast.epipolar, other.counts.fast.epipolar,
            "{threads} threads"
        );
        for (a, b) in one.images.iter().zip(&other.images) {
            assert!(a.pixels == b.pixels, "{threads} threads");
        }
    }
}

/// A floor of small flat triangles (a few pixels each) under one light:
/// `light` is the NFF light line.
fn tiled_floor(light: &str) -> World {
    let mut text = OPEN_FLOOR
        .replace("l 3 2 10", light)
        .split("f 0.8")
        .next()
        .expect("the view")
        .to_string();
    text.push_str("f 0.8 0.8 0.7 0.9 0 0 0 1\n");
    let step = 0.5;
    for i in -10..10 {
        for j in -10..10 {
            let (x, y) = (f64::from(i) * step, f64::from(j) * step);
            let (x1, y1) = (x + step, y + step);
            text.push_str(&format!("p 3\n{x} {y} 0\n{x1} {y} 0\n{x1} {y1} 0\n"));
            text.push_str(&format!("p 3\n{x} {y} 0\n{x1} {y1} 0\n{x} {y1} 0\n"));
        }
    }
    nff_world(&text)
}

/// 24 views of `tiled_floor(light)` by epipolar rows, each within E of the
/// independent render; what the rows did.
fn tiled_floor_within_e(light: &str) -> EpipolarCounts {
    let (worst, _, out) = against_exact(&tiled_floor(light), 24, INTERAXIAL, 1);
    let e = out.counts.fast.epipolar;
    assert!(worst <= E, "{light}: {worst}, {e:?}");
    e
}

/// On small flat triangles the few shade points of a primitive seldom have
/// neighbours on both sides, which the bend test needs; a flat triangle's
/// bend is bounded by its light's distance instead, so its samples take
/// their colour: few are refused, and every view stays within E.
#[test]
fn small_flat_triangles_take_their_colour_without_neighbours() {
    let e = tiled_floor_within_e("l 3 2 10");
    assert!(e.refused_colour * 50 < e.taken, "{e:?}");
}

/// A light just above the floor of small triangles: the light's term peaks
/// beneath it, over a few pixels, where the bound refuses to interpolate and
/// the bend test must judge; every view stays within E.
#[test]
fn a_light_close_to_flat_triangles_bends_their_colour() {
    let e = tiled_floor_within_e("l 0.03 0.2 0.05");
    assert!(e.taken > 0 && e.refused_colour > 0, "{e:?}");
}

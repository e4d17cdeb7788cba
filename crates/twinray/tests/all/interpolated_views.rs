//! Interpolated views (`--interpolate-views`, issue 16): on a span of a
//! camera column's views that the eye runs prove to see one primitive, the
//! views between two shaded ones take the interpolated colour where that is
//! provably within the tolerance E. Every view must stay within E of the
//! independent renders; the samples the pass does not interpolate are shaded
//! exactly; a pole only some views see, a thin shadow between two views'
//! hits, a mirror whose reflection changes between them and a textured floor
//! are kept.

use crate::common;

use common::*;
use serde_json::json;
use twinray::loaders::{load_scene, LoadOptions};
use twinray::math::{Color, Vec3};
use twinray::render::{
    Approximations, InterpStats, InterpolateViews, Method, RenderOptions, RenderOutput, Sampling,
};
use twinray::rig::{Camera, Rig};
use twinray::scene::{AngleSpan, Light, Viewpoint};
use twinray::World;

const WIDTH: u32 = 40;
const HEIGHT: u32 = 30;
const INTERAXIAL: f32 = 0.01;
const E: f32 = 0.01;

fn interpolating(tolerance: f32) -> RenderOptions {
    RenderOptions {
        approx: Approximations {
            interpolate_views: Some(InterpolateViews { tolerance }),
            ..Approximations::default()
        },
        ..options(Method::Twin, Sampling::Centers)
    }
}

/// `world`'s views by the independent renders and interpolated (on
/// `threads` threads): the largest difference of any view, the number of
/// pixels that differ at all, and the interpolated render.
fn against_exact(
    world: &World,
    camera: &Camera,
    views: usize,
    tolerance: f32,
    threads: usize,
) -> (f32, usize, RenderOutput) {
    let rig = Rig::multi_view(camera, views, INTERAXIAL, None).expect("rig");
    let exact = run(
        world,
        camera,
        &rig,
        &options(Method::Independent, Sampling::Centers),
    );
    let out = run_on_threads(threads, world, camera, &rig, &interpolating(tolerance));
    let (mut worst, mut differ) = (0.0f32, 0);
    for (a, b) in exact.images.iter().zip(&out.images) {
        for (p, q) in a.pixels.iter().zip(&b.pixels) {
            let d = (*p - *q).abs().max_element();
            worst = worst.max(d);
            differ += usize::from(p != q);
        }
    }
    (worst, differ, out)
}

fn floor_camera(world: &World) -> Camera {
    Camera::new(&world.scene.viewpoint, WIDTH, HEIGHT)
}

/// A diffuse, unoccluded floor: most samples are interpolated, every view
/// stays within E of the independent renders, and no more pixels differ
/// from them than were interpolated (the rest are shaded exactly).
#[test]
fn a_diffuse_open_floor_is_interpolated_within_the_tolerance() {
    let world = nff_world(OPEN_FLOOR);
    let camera = floor_camera(&world);
    for views in [3, 8, 48] {
        let (worst, differ, out) = against_exact(&world, &camera, views, E, 1);
        let i = out.counts.interp;
        let samples = (views as u32 * WIDTH * HEIGHT) as u64;
        assert!(worst <= E, "{views} views: {worst}");
        assert!(differ as u64 <= i.interpolated, "{views} views: {i:?}");
        let ends = 2 * (WIDTH * HEIGHT) as u64;
        assert!(i.interpolated * 2 > samples - ends, "{views} views: {i:?}");
        assert_eq!(i.interpolated + i.shaded, samples, "{views} views: {i:?}");
        assert_eq!(i.spans_refused_material + i.spans_refused_surface, 0);
        // Fewer samples shaded than views: the point of the mode.
        assert_eq!(out.counts.rays.shadow, i.shaded, "{views} views: one light");
    }
}

/// With E = 0 nothing may be interpolated but where the ends' colours are
/// the same and the light has no curvature: here nothing is, and the views
/// are the independent renders' bit for bit (the pass's shading is exact).
#[test]
fn with_no_tolerance_the_views_are_exact() {
    let world = nff_world(OPEN_FLOOR);
    let camera = floor_camera(&world);
    let (worst, differ, out) = against_exact(&world, &camera, 8, 0.0, 1);
    assert_eq!((worst, differ), (0.0, 0), "{:?}", out.counts.interp);
    assert_eq!(out.counts.interp.interpolated, 0);
    assert!(out.counts.interp.shaded > 0);
}

/// A pole 0.003 wide in front of the floor: in a camera column only one or
/// two of 48 views see it. The eye runs' proof refuses the spans across it,
/// so it is kept in every view that sees it.
#[test]
fn a_pole_seen_by_one_view_only_is_kept() {
    let pole = "f 0.1 0.9 0.1 0.9 0 0 0 1\nc\n0.2 0 0 0.0015\n0.2 0 2 0.0015\n";
    let world = nff_world(&format!("{OPEN_FLOOR}{pole}"));
    let bare = nff_world(OPEN_FLOOR);
    let camera = floor_camera(&world);
    let rig = Rig::multi_view(&camera, 48, INTERAXIAL, None).expect("rig");
    let with = run(&world, &camera, &rig, &interpolating(E));
    let without = run(&bare, &camera, &rig, &interpolating(E));
    let seen = with
        .images
        .iter()
        .zip(&without.images)
        .filter(|(a, b)| a.pixels != b.pixels)
        .count();
    assert!(seen > 0, "the pole is in some view");
    let (worst, _, _) = against_exact(&world, &camera, 48, E, 1);
    assert!(worst <= E, "{worst}");
}

/// A thin bar out of the frame, between the light and the floor, casts a
/// shadow narrower than a span of views' hits: kept (the shadow fan of the
/// span's ends toward the light is met, or their colours disagree). The
/// colour check refuses some pairs before any fan is asked.
#[test]
fn a_thin_shadow_between_two_views_hits_is_kept() {
    let bar = "f 0.5 0.5 0.5 0.9 0 0 0 1\nc\n2 -20 6 0.01\n2 20 6 0.01\n";
    let world = nff_world(&format!("{OPEN_FLOOR}{bar}"));
    for views in [8, 48] {
        let i = kept_within_e(&world, views);
        assert!(i.refused_colour > 0, "{views} views: {i:?}");
        assert!(i.refused_light > 0, "{views} views: {i:?}");
    }
}

/// `world`'s `views` views interpolated: within E of the independent
/// renders, some samples interpolated; what the pass did.
fn kept_within_e(world: &World, views: usize) -> InterpStats {
    let camera = floor_camera(world);
    let (worst, _, out) = against_exact(world, &camera, views, E, 1);
    let i = out.counts.interp;
    assert!(worst <= E, "{views} views: {worst}, {i:?}");
    assert!(i.interpolated > 0, "{views} views: {i:?}");
    i
}

/// A small ball between the light and the floor: its round shadow falls
/// between the hits of a span's end views, whose own shadow rays pass
/// beside it. Kept: a span's fan stands for the segments of every hit
/// between its ends (`ShadowFan::spanning`), not only theirs.
#[test]
fn a_small_balls_shadow_between_two_views_hits_is_kept() {
    // A far light: the floor's light varies by less than E across a span,
    // so only the shadow can refuse it.
    // A narrow view: the shadow, 0.2 wide, spans several rows and lies
    // within 48 views' spans (0.47 wide).
    let far = OPEN_FLOOR
        .replace("l 3 2 10", "l 30 20 100")
        .replace("angle 45", "angle 8");
    let ball = "f 0.5 0.5 0.5 0.9 0 0 0 1\ns 1.5 1 5 0.1\n";
    let world = nff_world(&format!("{far}{ball}"));
    kept_within_e(&world, 8);
    // 48 views' spans are wider than the shadow: it falls between two ends.
    let i = kept_within_e(&world, 48);
    assert!(i.refused_light > 0, "{i:?}");
}

/// A mirror floor (unlit: the light is below it) reflecting a thin dark pole
/// against a bright sky: the span's end views see the sky in it, views
/// between see the pole. Their colours and chains agree; only rule 1 (a
/// mirror weight above E) refuses the span.
#[test]
fn a_mirror_whose_reflection_changes_between_views_is_refused() {
    let world = nff_world(MIRROR_FLOOR_AND_POLE);
    let camera = floor_camera(&world);
    let (worst, differ, out) = against_exact(&world, &camera, 48, E, 1);
    let i = out.counts.interp;
    assert!(worst <= E, "{worst}, {i:?}");
    assert_eq!(differ, 0);
    assert!(i.spans_refused_material > 0, "{i:?}");
    assert_eq!(i.interpolated, 0, "{i:?}");
}

/// A textured floor (a stripe map on a glTF quad): refused by rule 2, and
/// the stripes are kept.
#[test]
fn a_textured_floor_is_refused() {
    let dir = tempfile::tempdir().expect("temp dir");
    image::RgbImage::from_fn(64, 64, |x, _| {
        if (x / 3) % 2 == 0 {
            image::Rgb([240, 240, 240])
        } else {
            image::Rgb([20, 20, 20])
        }
    })
    .save(dir.path().join("stripes.png"))
    .expect("png");
    let material = json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": 0},
                          "metallicFactor": 0, "roughnessFactor": 1}});
    let path = gltf_quad(dir.path(), material, &["stripes.png"]);
    let mut scene = load_scene(&path, &LoadOptions::default()).expect("quad loads");
    scene
        .lights
        .push(Light::point(Vec3::new(0.5, 0.5, 4.0), Some(Color::ONE)));
    let world = World::new(scene);
    let vp = Viewpoint {
        from: Vec3::new(0.0, 0.0, 3.0),
        at: Vec3::ZERO,
        up: Vec3::Y,
        angle_deg: 30.0,
        angle_span: AngleSpan::ImageHeight,
        hither: 0.0,
        width: WIDTH,
        height: HEIGHT,
    };
    let camera = Camera::new(&vp, WIDTH, HEIGHT);
    let (worst, differ, out) = against_exact(&world, &camera, 16, 0.5, 1);
    let i = out.counts.interp;
    assert!(i.spans_refused_surface > 0, "{i:?}");
    assert_eq!(i.interpolated, 0, "{i:?}");
    assert_eq!((worst, differ), (0.0, 0));
}

/// The same images, and the same counts, on 1, 2 and 5 threads.
#[test]
fn one_two_and_five_threads_give_the_same_images() {
    let bar = "f 0.5 0.5 0.5 0.9 0 0 0 1\nc\n2 -20 6 0.01\n2 20 6 0.01\n";
    let world = nff_world(&format!("{OPEN_FLOOR}{bar}"));
    let camera = floor_camera(&world);
    let (_, _, one) = against_exact(&world, &camera, 24, E, 1);
    for threads in [2, 5] {
        let (_, _, other) = against_exact(&world, &camera, 24, E, threads);
        assert_eq!(one.counts.interp, other.counts.interp, "{threads} threads");
        for (a, b) in one.images.iter().zip(&other.images) {
            assert!(a.pixels == b.pixels, "{threads} threads");
        }
    }
}

//! The fast method's shading cache shared by the views, alone, on scenes built
//! here whose answer is known: exact where it provably is (diffuse, nothing
//! between the surfaces and the light), within its tolerance where secondary
//! light is shared, thin features kept (a pole one view sees, a shadow edge
//! between the views' samples, a mirror), and the same image for any number
//! of threads.

use crate::common;

use common::*;
use twinray::lights::LightKind;
use twinray::math::{Color, Vec3};
use twinray::output::compare;
use twinray::render::{FastStages, RenderOptions, RenderOutput, Sampling, ViewMethod};
use twinray::rig::{Camera, Rig};
use twinray::scene::{Light, Material, Viewpoint};
use twinray::{Image, Scene, World};

fn diffuse(color: Color) -> Material {
    Material {
        color,
        kd: 0.8,
        ..Material::default()
    }
}

/// A camera at the origin looking along +y (z up), 96×64 pixels.
fn viewpoint() -> Viewpoint {
    Viewpoint {
        from: Vec3::ZERO,
        at: Vec3::Y,
        up: Vec3::Z,
        angle_deg: 50.0,
        hither: 0.0,
        width: 96,
        height: 64,
        ..Viewpoint::default()
    }
}

fn quad(scene: &mut Scene, corners: [Vec3; 4], name: &str) {
    scene.add_polygon(&corners, name);
}

/// A wall at depth about 10, tilted so that its shading varies across the
/// image, and a floor of another colour below it (a seam between two
/// primitives), lit by one light with nothing in between.
fn open_scene() -> Scene {
    let mut scene = Scene::new();
    scene.viewpoint = viewpoint();
    scene.background = Color::new(0.1, 0.2, 0.3);
    scene
        .lights
        .push(Light::point(Vec3::new(-3.0, 2.0, 6.0), Some(Color::ONE)));
    scene.add_material(diffuse(Color::new(0.8, 0.7, 0.6)));
    quad(
        &mut scene,
        [
            Vec3::new(-20.0, 6.0, -2.0),
            Vec3::new(20.0, 14.0, -2.0),
            Vec3::new(20.0, 14.0, 20.0),
            Vec3::new(-20.0, 6.0, 20.0),
        ],
        "wall",
    );
    scene.add_material(diffuse(Color::new(0.3, 0.6, 0.9)));
    quad(
        &mut scene,
        [
            Vec3::new(-20.0, 0.5, -2.0),
            Vec3::new(20.0, 0.5, -2.0),
            Vec3::new(20.0, 14.0, -2.0),
            Vec3::new(-20.0, 6.0, -2.0),
        ],
        "floor",
    );
    scene
}

/// The fast method's batches sharing the shading cache alone (no epipolar
/// rows, merged rays or cut).
fn shared(tolerance: f32) -> RenderOptions {
    RenderOptions {
        fast_stages: Some(FastStages {
            epipolar_rows: false,
            shared_cache: true,
            tolerance,
        }),
        ..options(ViewMethod::Fast { tolerance }, Sampling::Centers)
    }
}

/// `views` views `spacing` apart, converged at `convergence`.
fn rig(world: &World, views: usize, spacing: f32, convergence: Option<f64>) -> (Camera, Rig) {
    let vp = &world.scene.viewpoint;
    let cam = Camera::new(vp, vp.width, vp.height);
    let rig = Rig::multi_view(&cam, views, spacing, convergence).expect("rig");
    (cam, rig)
}

/// The default tolerance, and what the tests allow beyond it (rounding).
const E: f32 = ViewMethod::DEFAULT_TOLERANCE;
const ROUNDING: f32 = 1e-6;

/// The exact twin render and the shared-shading one (default tolerance).
fn exact_and_shared(world: &World, cam: &Camera, rig: &Rig) -> (RenderOutput, RenderOutput) {
    let exact = run(
        world,
        cam,
        rig,
        &options(ViewMethod::twin(), Sampling::Centers),
    );
    let shared = run(world, cam, rig, &shared(E));
    (exact, shared)
}

/// A thin feature is kept: with light shared only (tolerance 0) every view
/// equals the exact one; with colours taken whole too (the default
/// tolerance), each is within the tolerance of it. The default run's output.
fn assert_kept(world: &World, cam: &Camera, rig: &Rig, what: &str) -> RenderOutput {
    let exact = run(
        world,
        cam,
        rig,
        &options(ViewMethod::twin(), Sampling::Centers),
    );
    let light_only = run(world, cam, rig, &shared(0.0));
    for (v, (a, b)) in exact.images.iter().zip(&light_only.images).enumerate() {
        assert!(max_diff(a, b) <= ROUNDING, "view {v}, tolerance 0: {what}");
    }
    let out = run(world, cam, rig, &shared(E));
    for (v, (a, b)) in exact.images.iter().zip(&out.images).enumerate() {
        let d = max_diff(a, b);
        assert!(d <= E + ROUNDING, "view {v}: {what}, {d} off");
    }
    assert!(out.counts.fast.cache.hits > 0, "{what}: nothing shared");
    out
}

fn max_diff(a: &Image, b: &Image) -> f32 {
    compare(a, b).expect("same size").max_abs
}

#[test]
fn diffuse_light_with_nothing_in_its_way_is_shared_exactly() {
    // Every sample sees a diffuse surface, lit, unshadowed: the light's
    // visibility a sample takes is its own, its ambient and diffuse terms are
    // computed at its own point, so the image is the independent render's.
    // Tolerance 0 shares light only (no colour is taken whole).
    let world = World::new(open_scene());
    for (views, spacing, convergence) in [(2, 0.4, None), (8, 0.1, Some(10.0)), (12, 0.05, None)] {
        let (cam, rig) = rig(&world, views, spacing, convergence);
        let reference = run(
            &world,
            &cam,
            &rig,
            &options(ViewMethod::Independent, Sampling::Centers),
        );
        let out = run(&world, &cam, &rig, &shared(0.0));
        assert_eq!(out.images, reference.images, "{views} views");
        assert_eq!(out.counts.fast.cache.colour_hits, 0);
        // Every view but the first could take view 0's light.
        let samples = (96 * 64 * (views - 1)) as u64;
        assert!(
            out.counts.fast.cache.hits * 10 >= samples * 8,
            "{views} views: {} of {samples} samples took a kept sample's light",
            out.counts.fast.cache.hits
        );
        // About one view's shadow rays, not one per view.
        assert!(
            out.counts.rays.shadow * views as u64 <= reference.counts.rays.shadow * 2,
            "{views} views: {} shadow rays against {}",
            out.counts.rays.shadow,
            reference.counts.rays.shadow
        );
    }
}

/// The open scene lit by parallel light (from above, left and behind the
/// camera): on each flat, untextured, diffuse surface the colour is the same
/// at every point, so a colour taken whole is the sample's own.
fn parallel_light_scene() -> Scene {
    let mut scene = open_scene();
    scene.lights[0] = Light {
        kind: LightKind::Directional {
            direction: Vec3::new(0.3, 0.6, -0.7).normalize(),
        },
        color: Some(Color::ONE),
    };
    scene
}

#[test]
fn colours_taken_whole_are_exact_where_the_colour_is_constant() {
    let world = World::new(parallel_light_scene());
    for (views, spacing, convergence) in [(2, 0.4, None), (8, 0.1, Some(10.0)), (12, 0.05, None)] {
        let (cam, rig) = rig(&world, views, spacing, convergence);
        let reference = run(
            &world,
            &cam,
            &rig,
            &options(ViewMethod::Independent, Sampling::Centers),
        );
        let out = run(&world, &cam, &rig, &shared(E));
        assert_eq!(out.images, reference.images, "{views} views");
        // Nearly every other view's sample took a colour and computed nothing.
        let samples = (96 * 64 * (views - 1)) as u64;
        assert!(
            out.counts.fast.cache.colour_hits * 10 >= samples * 8,
            "{views} views: {} of {samples} samples took a colour whole",
            out.counts.fast.cache.colour_hits
        );
    }
}

#[test]
fn colours_taken_whole_stay_within_the_tolerance() {
    // A point light near a tilted wall: the diffuse term varies across every
    // pixel; a sample that takes its neighbour's colour is off by at most the
    // spread between the kept sample and its row neighbours (checked ≤ E).
    let world = World::new(open_scene());
    let (cam, rig) = rig(&world, 8, 0.1, Some(10.0));
    let exact = run(
        &world,
        &cam,
        &rig,
        &options(ViewMethod::twin(), Sampling::Centers),
    );
    for tolerance in [0.002, E, 0.05] {
        let out = run(&world, &cam, &rig, &shared(tolerance));
        assert!(
            out.counts.fast.cache.colour_hits > 0,
            "tolerance {tolerance}"
        );
        let mut differing = 0;
        for (v, (a, b)) in exact.images.iter().zip(&out.images).enumerate() {
            let d = compare(a, b).expect("same size");
            assert!(
                d.max_abs <= tolerance + ROUNDING,
                "view {v}, tolerance {tolerance}: {d:?}"
            );
            differing += d.differing_pixels;
        }
        assert!(
            differing > 0,
            "tolerance {tolerance}: colours were taken whole"
        );
    }
}

/// The open scene with a broad highlight on the wall (weight 0.6, far above
/// the tolerance): it moves across the wall from view to view.
fn highlight_scene() -> Scene {
    let mut scene = open_scene();
    scene.materials[0].ks = 0.6;
    scene.materials[0].shine = 4.0;
    scene.materials[0].specular_color = Color::ONE;
    scene
}

#[test]
fn a_highlight_is_each_views_own() {
    // The wall's light may be shared, its colour may not be taken whole: each
    // view computes its own highlight.
    let world = World::new(highlight_scene());
    let (cam, rig) = rig(&world, 8, 0.3, Some(10.0));
    let out = assert_kept(&world, &cam, &rig, "the wall's highlight");
    assert!(out.counts.fast.cache.colour_hits > 0, "the floor's colours");
}

/// The open scene with a faintly mirroring floor (weight `mirror`) facing
/// the wall, and a red ball above it that the floor reflects.
fn faint_mirror_scene(mirror: f32) -> Scene {
    let mut scene = open_scene();
    let floor = scene.materials.len() - 1;
    scene.materials[floor].mirror = mirror;
    scene.add_material(diffuse(Color::new(1.0, 0.0, 0.0)));
    scene.add_sphere(Vec3::new(1.5, 5.0, 1.5), 0.8, "ball");
    scene
}

#[test]
fn shared_secondary_light_stays_within_the_tolerance() {
    // The floor's reflection differs from view to view; it weighs `mirror`,
    // and every radiance here is at most 1, so a view that takes another's
    // secondary colour is off by at most `mirror`, within the tolerance; a
    // colour taken whole adds at most the tolerance (its neighbours' spread).
    let world = World::new(faint_mirror_scene(0.008));
    let (cam, rig) = rig(&world, 8, 0.15, Some(8.0));
    let exact = run(
        &world,
        &cam,
        &rig,
        &options(ViewMethod::twin(), Sampling::Centers),
    );
    let tolerance = 0.01;
    let out = run(&world, &cam, &rig, &shared(tolerance));
    assert!(out.counts.fast.cache.hits > 0);
    let mut differing = 0;
    for (v, (a, b)) in exact.images.iter().zip(&out.images).enumerate() {
        let d = max_diff(a, b);
        assert!(
            d <= 0.008 + tolerance + 1e-5,
            "view {v}: max difference {d} beyond the mirror weight and the tolerance"
        );
        differing += compare(a, b).expect("same size").differing_pixels;
    }
    assert!(differing > 0, "the floor's reflection was shared");
    // Below the floor's weight, the floor is shaded exactly, every view: what
    // differs is colours taken whole, within the tolerance; with light shared
    // only (tolerance 0), nothing.
    for strict in [0.005, 0.0] {
        let out = run(&world, &cam, &rig, &shared(strict));
        for (v, (a, b)) in exact.images.iter().zip(&out.images).enumerate() {
            assert!(
                max_diff(a, b) <= strict + ROUNDING,
                "view {v} with tolerance {strict}"
            );
        }
    }
}

#[test]
fn a_mirror_is_traced_by_every_view() {
    // A strong mirror: its reflection of the ball changes from view to view
    // (and between any key views); no view takes another's.
    let world = World::new(faint_mirror_scene(0.7));
    let (cam, rig) = rig(&world, 8, 0.15, Some(8.0));
    assert_kept(&world, &cam, &rig, "the mirror's reflection");
}

/// The open scene with a thin red pole near the camera at the right edge of
/// the picture, in the shadow of a roof out of the picture: the rightmost
/// views see it, the leftmost do not (it is out of their frame).
fn pole_scene() -> Scene {
    let mut scene = open_scene();
    scene.add_material(diffuse(Color::new(1.0, 0.0, 0.0)));
    scene.add_cone(
        Vec3::new(1.45, 2.0, -5.0),
        0.05,
        Vec3::new(1.45, 2.0, 5.0),
        0.05,
        "pole",
    );
    scene.lights[0] = Light::point(Vec3::new(1.45, -10.0, 30.0), Some(Color::ONE));
    scene.add_material(diffuse(Color::splat(0.5)));
    quad(
        &mut scene,
        [
            Vec3::new(1.2, -1.0, 6.0),
            Vec3::new(1.7, -1.0, 6.0),
            Vec3::new(1.7, 0.5, 6.0),
            Vec3::new(1.2, 0.5, 6.0),
        ],
        "roof",
    );
    scene
}

fn red_pixels(img: &Image) -> usize {
    img.pixels
        .iter()
        .filter(|p| p.x > 0.02 && p.y < 0.01 && p.z < 0.01)
        .count()
}

#[test]
fn a_pole_seen_by_some_views_only_keeps_its_own_shading() {
    let world = World::new(pole_scene());
    let (cam, rig) = rig(&world, 8, 0.12, None);
    let exact = run(
        &world,
        &cam,
        &rig,
        &options(ViewMethod::twin(), Sampling::Centers),
    );
    let seen: Vec<usize> = exact.images.iter().map(red_pixels).collect();
    assert_eq!(seen[0], 0, "view 0 does not see the pole: {seen:?}");
    assert!(seen[7] >= 32, "view 7 sees it: {seen:?}");
    assert_kept(&world, &cam, &rig, "the pole in shadow");
}

/// The open scene with a vertical bar between the light and the wall: its
/// shadow on the wall is a stripe a few pixels wide, whose edges fall at a
/// different place between the samples of each view.
fn shadow_edge_scene() -> Scene {
    let mut scene = open_scene();
    scene.add_material(diffuse(Color::splat(0.4)));
    quad(
        &mut scene,
        [
            Vec3::new(-2.2, 4.0, 1.0),
            Vec3::new(-2.0, 4.0, 1.0),
            Vec3::new(-2.0, 4.0, 9.0),
            Vec3::new(-2.2, 4.0, 9.0),
        ],
        "bar",
    );
    scene.lights[0] = Light::point(Vec3::new(-2.5, 0.0, 5.0), Some(Color::ONE));
    scene
}

#[test]
fn a_shadow_edge_between_the_views_samples_is_kept() {
    let world = World::new(shadow_edge_scene());
    let (cam, rig) = rig(&world, 8, 0.07, Some(10.0));
    let out = assert_kept(&world, &cam, &rig, "the shadow stripe");
    assert!(
        out.counts.fast.cache.edge_refusals > 0,
        "the edges are seen"
    );
}

/// A wall whose plane passes between the views (the middle view sees it
/// edge-on), lit on one face: a view takes no light from an entry of the
/// other face, so each shows its own face, lit or dark. What is left is the
/// floor along the wall's foot, lit on one side and hidden from the leaders
/// of the other: a pixel or two a view, within the budget's share of
/// pixels off by more than 16/255.
#[test]
fn a_wall_between_the_views_shows_each_view_its_own_face() {
    let world = nff_world(WALL_BETWEEN_VIEWS);
    let (cam, rig) = rig(&world, 9, 0.5, None);
    let (exact, shared) = exact_and_shared(&world, &cam, &rig);
    for (v, (a, b)) in exact.images.iter().zip(&shared.images).enumerate() {
        let off = (a.pixels.iter().zip(&b.pixels))
            .filter(|(p, q)| (**p - **q).abs().max_element() > 16.0 / 255.0)
            .count();
        assert!(off * 200 <= a.pixels.len(), "view {v}: {off} pixels off");
    }
    assert!(shared.counts.fast.cache.hits > 0, "nothing shared");
}

#[test]
fn the_same_image_for_1_2_and_5_threads() {
    let world = World::new(shadow_edge_scene());
    let (cam, rig) = rig(&world, 9, 0.07, Some(10.0));
    for sampling in [
        Sampling::Centers,
        Sampling::Stratified {
            samples: 4,
            filter: twinray::render::Filter::Box,
            seed: 0,
        },
    ] {
        let opts = RenderOptions {
            sampling,
            ..shared(ViewMethod::DEFAULT_TOLERANCE)
        };
        let one = run_on_threads(1, &world, &cam, &rig, &opts);
        for threads in [2, 5] {
            let many = run_on_threads(threads, &world, &cam, &rig, &opts);
            assert_eq!(one.images, many.images, "{threads} threads, {sampling:?}");
            assert_eq!(one.counts.fast.cache.hits, many.counts.fast.cache.hits);
            assert_eq!(
                one.counts.fast.cache.colour_hits,
                many.counts.fast.cache.colour_hits
            );
            assert!(one.counts.fast.cache.colour_hits > 0);
        }
    }
}

/// Shadows of two lights, a mirror ball, a glass ball and diffuse balls over
/// the diffuse floor and wall.
fn busy_scene() -> Scene {
    let mut scene = faint_mirror_scene(0.0);
    scene.lights.push(Light::point(
        Vec3::new(4.0, 1.0, 3.0),
        Some(Color::splat(0.5)),
    ));
    scene.add_material(Material {
        color: Color::splat(0.9),
        kd: 0.2,
        ks: 0.7,
        mirror: 0.7,
        shine: 40.0,
        ..Material::default()
    });
    scene.add_sphere(Vec3::new(-1.5, 6.0, -1.0), 0.9, "mirror ball");
    scene.add_material(Material {
        color: Color::splat(0.9),
        kd: 0.1,
        ks: 0.1,
        t: 0.8,
        ior: 1.5,
        shine: 40.0,
        ..Material::default()
    });
    scene.add_sphere(Vec3::new(0.2, 4.0, -1.3), 0.5, "glass ball");
    scene.add_material(diffuse(Color::new(0.2, 0.9, 0.3)));
    for k in 0..5 {
        let x = -3.0 + 1.4 * k as f32;
        scene.add_sphere(Vec3::new(x, 8.0, -1.6), 0.35, "small ball");
    }
    scene
}

#[test]
fn a_scene_with_shadows_mirrors_and_glass_stays_close() {
    let world = World::new(busy_scene());
    let (cam, rig) = rig(&world, 12, 0.06, Some(7.0));
    let (exact, out) = exact_and_shared(&world, &cam, &rig);
    assert!(out.counts.fast.cache.hits > 0 && out.counts.fast.cache.edge_refusals > 0);
    assert!(out.counts.rays.shadow < exact.counts.rays.shadow);
    for (v, (a, b)) in exact.images.iter().zip(&out.images).enumerate() {
        let d = compare(a, b).expect("same size");
        assert!(d.psnr_db >= 40.0, "view {v}: {d:?}");
    }
}

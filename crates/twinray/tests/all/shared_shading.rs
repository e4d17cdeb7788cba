//! The multi-view shading cache (`--share-shading`, issue 16) on scenes built
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
use twinray::render::{
    Approximations, Method, RenderOptions, RenderOutput, Sampling, SharedShading,
};
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

fn shared(tolerance: f32) -> RenderOptions {
    RenderOptions {
        approx: Approximations {
            shared_shading: Some(SharedShading { tolerance }),
            ..Approximations::default()
        },
        ..options(Method::Twin, Sampling::Centers)
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
const E: f32 = SharedShading::DEFAULT_TOLERANCE;
const ROUNDING: f32 = 1e-6;

/// The exact twin render and the shared-shading one (default tolerance).
fn exact_and_shared(world: &World, cam: &Camera, rig: &Rig) -> (RenderOutput, RenderOutput) {
    let exact = run(world, cam, rig, &options(Method::Twin, Sampling::Centers));
    let shared = run(world, cam, rig, &shared(E));
    (exact, shared)
}

/// A thin feature is kept: with light shared only (tolerance 0) every view
/// equals the exact one; with colours taken whole too (the default
/// tolerance), each is within the tolerance of it. The default run's output.
fn assert_kept(world: &World, cam: &Camera, rig: &Rig, what: &str) -> RenderOutput {
    let exact = run(world, cam, rig, &options(Method::Twin, Sampling::Centers));
    let light_only = run(world, cam, rig, &shared(0.0));
    for (v, (a, b)) in exact.images.iter().zip(&light_only.images).enumerate() {
        assert!(max_diff(a, b) <= ROUNDING, "view {v}, tolerance 0: {what}");
    }
    let out = run(world, cam, rig, &shared(E));
    for (v, (a, b)) in exact.images.iter().zip(&out.images).enumerate() {
        let d = max_diff(a, b);
        assert!(d <= E + ROUNDING, "view {v}: {what}, {d} off");
    }
    assert!(out.counts.cache_hits > 0, "{what}: nothing shared");
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
            &options(Method::Independent, Sampling::Centers),
        );
        let out = run(&world, &cam, &rig, &shared(0.0));
        assert_eq!(out.images, reference.images, "{views} views");
        assert_eq!(out.counts.cache_colour_hits, 0);
        // Every view but the first could take view 0's light.
        let samples = (96 * 64 * (views - 1)) as u64;
        assert!(
            out.counts.cache_hits * 10 >= samples * 8,
            "{views} views: {} of {samples} samples took a kept sample's light",
            out.counts.cache_hits
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
            &options(Method::Independent, Sampling::Centers),
        );
        let out = run(&world, &cam, &rig, &shared(E));
        assert_eq!(out.images, reference.images, "{views} views");
        // Nearly every other view's sample took a colour and computed nothing.
        let samples = (96 * 64 * (views - 1)) as u64;
        assert!(
            out.counts.cache_colour_hits * 10 >= samples * 8,
            "{views} views: {} of {samples} samples took a colour whole",
            out.counts.cache_colour_hits
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
        &options(Method::Twin, Sampling::Centers),
    );
    for tolerance in [0.002, E, 0.05] {
        let out = run(&world, &cam, &rig, &shared(tolerance));
        assert!(out.counts.cache_colour_hits > 0, "tolerance {tolerance}");
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
    assert!(out.counts.cache_colour_hits > 0, "the floor's colours");
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
        &options(Method::Twin, Sampling::Centers),
    );
    let tolerance = 0.01;
    let out = run(&world, &cam, &rig, &shared(tolerance));
    assert!(out.counts.cache_hits > 0);
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
        &options(Method::Twin, Sampling::Centers),
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
    assert!(out.counts.cache_edge_refusals > 0, "the edges are seen");
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
            ..shared(SharedShading::DEFAULT_TOLERANCE)
        };
        let one = run_on_threads(1, &world, &cam, &rig, &opts);
        for threads in [2, 5] {
            let many = run_on_threads(threads, &world, &cam, &rig, &opts);
            assert_eq!(one.images, many.images, "{threads} threads, {sampling:?}");
            assert_eq!(one.counts.cache_hits, many.counts.cache_hits);
            assert_eq!(one.counts.cache_colour_hits, many.counts.cache_colour_hits);
            assert!(one.counts.cache_colour_hits > 0);
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
    assert!(out.counts.cache_hits > 0 && out.counts.cache_edge_refusals > 0);
    assert!(out.counts.rays.shadow < exact.counts.rays.shadow);
    for (v, (a, b)) in exact.images.iter().zip(&out.images).enumerate() {
        let d = compare(a, b).expect("same size");
        assert!(d.psnr_db >= 40.0, "view {v}: {d:?}");
    }
}

/// The shadow-stripe scene with a strong mirror for a floor, and a thin pole
/// standing on it: its reflection, and the stripe's, move from view to view
/// and fall between key views.
fn mirror_floor_scene() -> Scene {
    let mut scene = shadow_edge_scene();
    let floor = scene.materials.len() - 2;
    scene.materials[floor].mirror = 0.8;
    scene.materials[floor].kd = 0.2;
    scene.add_material(diffuse(Color::new(1.0, 0.1, 0.1)));
    scene.add_cone(
        Vec3::new(0.5, 5.0, -2.0),
        0.04,
        Vec3::new(0.5, 5.0, 3.0),
        0.04,
        "pole",
    );
    scene
}

/// A strong mirror floor reflecting the wall, on which a light with an
/// inverse-square falloff, close to it, makes a bright spot.
fn spot_on_the_wall_in_a_mirror() -> Scene {
    let mut scene = open_scene();
    let floor = scene.materials.len() - 1;
    scene.materials[floor].mirror = 0.8;
    scene.materials[floor].kd = 0.2;
    scene.lights.push(Light {
        kind: LightKind::Point {
            position: Vec3::new(0.0, 9.6, 0.0),
            inverse_square: true,
            range: None,
        },
        color: Some(Color::splat(0.2)),
    });
    scene
}

/// A strong mirror floor reflecting a red ball with a sharp highlight.
fn shiny_ball_in_a_mirror() -> Scene {
    let mut scene = faint_mirror_scene(0.8);
    let ball = scene.materials.len() - 1;
    scene.materials[ball].ks = 0.9;
    scene.materials[ball].shine = 300.0;
    scene
}

/// `shared(tolerance)` in batches of `per_batch` views, key views every
/// `spacing`-th (1: no key views, every view traces its own).
fn keyed(tolerance: f32, per_batch: usize, spacing: usize) -> RenderOptions {
    RenderOptions {
        views_per_batch: per_batch,
        approx: Approximations {
            key_spacing: spacing,
            ..shared(tolerance).approx
        },
        ..shared(tolerance)
    }
}

/// Key views on the mirror floor: views between two key views take their
/// reflection, interpolated, only where it is close. The pole's reflection
/// and the stripe's, narrower than the key views' spacing, are kept: the
/// probe sees the pole, the shadow fan the bar. Against the same render
/// without key views (spacing 1: every view traces its own) a view
/// differs only by interpolation: within twice the tolerance (the two key
/// views' colours agree within it). With tolerance 0 nothing is interpolated
/// and every view is exact.
#[test]
fn views_between_key_views_keep_what_their_own_reflection_shows() {
    // (scene, views, batch, whether a probe or a fan must refuse somewhere)
    for (scene, views, per_batch, refusals) in [
        (mirror_floor_scene(), 8, 4, true),
        (mirror_floor_scene(), 16, 8, true),
        // The reflection of a red ball with a sharp highlight: it moves
        // across the ball from view to view, which only the key views'
        // colours (not their chains) tell apart.
        (shiny_ball_in_a_mirror(), 16, 8, false),
        // The spot's reflection: both key views may see it dim and the views
        // between bright; the bound on the light's curvature refuses.
        (spot_on_the_wall_in_a_mirror(), 16, 8, false),
    ] {
        let world = World::new(scene);
        let (cam, rig) = rig(&world, views, 0.1, Some(8.0));
        let exact = run(
            &world,
            &cam,
            &rig,
            &options(Method::Twin, Sampling::Centers),
        );
        let every = run(&world, &cam, &rig, &keyed(E, per_batch, 1));
        assert_eq!(every.counts.interpolated_samples, 0);
        for spacing in [0, 2] {
            let out = run(&world, &cam, &rig, &keyed(E, per_batch, spacing));
            let c = &out.counts;
            let what = format!("{views} views, batches of {per_batch}, spacing {spacing}");
            assert!(
                c.key_view_samples > 0 && c.interpolated_samples > 0,
                "{what}: {c:?}"
            );
            assert!(
                !refusals || c.key_view_fallbacks > 0 && c.fan_queries > c.fan_free,
                "{what}: {c:?}"
            );
            assert!(c.rays.reflected < every.counts.rays.reflected, "{what}");
            for (v, (a, b)) in every.images.iter().zip(&out.images).enumerate() {
                let d = max_diff(a, b);
                assert!(
                    d <= 2.0 * E + ROUNDING,
                    "{what}, view {v}: {d} from every view keyed"
                );
                let d = compare(&exact.images[v], b).expect("same size");
                assert!(d.psnr_db >= 40.0, "{what}, view {v}: {d:?}");
            }
        }
        // Tolerance 0: no key views, every mirror sample traced by its view.
        let strict = run(&world, &cam, &rig, &keyed(0.0, per_batch, 0));
        assert_eq!(strict.counts.key_view_samples, 0);
        assert_eq!(strict.counts.interpolated_samples, 0);
        assert_eq!(strict.counts.rays.reflected, exact.counts.rays.reflected);
    }
}

/// Key views give the same image for any number of threads.
#[test]
fn key_views_give_the_same_image_for_1_2_and_5_threads() {
    let world = World::new(mirror_floor_scene());
    let (cam, rig) = rig(&world, 8, 0.1, Some(8.0));
    let opts = keyed(E, 4, 0);
    let one = run_on_threads(1, &world, &cam, &rig, &opts);
    assert!(one.counts.interpolated_samples > 0);
    for threads in [2, 5] {
        let many = run_on_threads(threads, &world, &cam, &rig, &opts);
        assert_eq!(one.images, many.images, "{threads} threads");
        assert_eq!(
            one.counts.interpolated_samples,
            many.counts.interpolated_samples
        );
    }
}

/// A mirror ball, alone under an environment of eight vertical black and
/// white stripes (45° each): every view's reflection leaves the scene, and
/// the stripe it sees changes from view to view near the ball's rim.
fn mirror_ball_under_stripes() -> Scene {
    let mut scene = Scene::new();
    scene.viewpoint = viewpoint();
    scene
        .lights
        .push(Light::point(Vec3::new(-3.0, 2.0, 6.0), Some(Color::ONE)));
    let texels = (0..128)
        .map(|i| Color::splat(if (i % 64) / 8 % 2 == 0 { 1.0 } else { 0.0 }))
        .collect();
    let env = twinray::environment::Environment::from_texels(64, 2, texels, true);
    scene.environment = Some(std::sync::Arc::new(env));
    scene.add_material(Material {
        mirror: 0.9,
        kd: 0.1,
        ..diffuse(Color::new(0.8, 0.8, 0.8))
    });
    scene.add_sphere(Vec3::new(0.0, 8.0, 0.0), 2.5, "ball");
    scene
}

/// A curved mirror under an environment image: the key views' reflections
/// leave the scene in directions that differ, and the stripe each sees can
/// change between them (and change back: the key views' colours may agree
/// across two edges). So a view between takes the key views' reflection
/// only where they look the same way; every view stays within twice the
/// tolerance of its own traced reflection (interpolated across a stripe,
/// it was off by the whole contrast, 0.9).
#[test]
fn a_curved_mirror_under_an_environment_is_not_interpolated_across_stripes() {
    let world = World::new(mirror_ball_under_stripes());
    let (cam, rig) = rig(&world, 16, 0.1, Some(8.0));
    let every = run(&world, &cam, &rig, &keyed(E, 8, 1));
    for spacing in [0, 2] {
        let out = run(&world, &cam, &rig, &keyed(E, 8, spacing));
        let c = &out.counts;
        assert!(c.interpolated_samples > 0, "spacing {spacing}: {c:?}");
        for (v, (a, b)) in every.images.iter().zip(&out.images).enumerate() {
            let d = max_diff(a, b);
            assert!(
                d <= 2.0 * E + ROUNDING,
                "spacing {spacing}, view {v}: {d} from every view keyed"
            );
        }
    }
}

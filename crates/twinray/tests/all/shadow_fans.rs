//! Shared shadows (`--shadow-fans`, issue 16): the shadow rays of a run of
//! views' hits on one primitive toward a point light are proved free by one
//! shadow fan, not traced. The images must be the independent renders', bit
//! for bit, and the rays not traced counted: on an open floor (every fan
//! free), under a thin pole whose shadow crosses runs, with an occluder on
//! one view's shadow segment only, and with spheres grazing a view's segment.

use crate::common;

use common::*;
use twinray::loaders::nff::parse_nff;
use twinray::loaders::LoadOptions;
use twinray::math::Vec3;
use twinray::render::{Method, RenderOptions, RenderOutput, Sampling};
use twinray::rig::{Camera, Rig};
use twinray::World;

const WIDTH: u32 = 40;
const HEIGHT: u32 = 30;
const INTERAXIAL: f32 = 0.01;

/// Looking down on a floor that fills the frame: one triangle, so that every
/// view's hits in a camera column lie on one primitive.
const FLOOR: &str = "b 0.1 0.1 0.2\nv\nfrom 0 -6 5\nat 0 0 0\nup 0 0 1\nangle 45\nhither 0.01\n\
    resolution 40 30\n\
    f 0.8 0.8 0.7 0.7 0.2 20 0 1\np 3\n-100 -100 0\n100 -100 0\n0 100 0\n";

/// The lights: one, or two.
const LIGHTS: [&str; 2] = ["l 3 2 10\n", "l 3 2 10\nl -4 -1 8\n"];

/// A pole 0.2 wide standing on the floor: its shadows cross the columns'
/// runs.
const POLE: &str = "f 0.9 0.3 0.2 0.8 0 10 0 1\nc\n0.3 0.5 0 0.1\n0.3 0.5 3 0.1\n";

fn parse(text: &str) -> World {
    let scene = parse_nff(
        text,
        std::path::Path::new("fans.nff"),
        &LoadOptions::default(),
    )
    .expect("generated scene");
    World::new(scene)
}

fn camera_rig(world: &World, views: usize, convergence: Option<f64>) -> (Camera, Rig) {
    let camera = Camera::new(&world.scene.viewpoint, WIDTH, HEIGHT);
    let rig = Rig::multi_view(&camera, views, INTERAXIAL, convergence).expect("rig");
    (camera, rig)
}

fn bits(img: &twinray::Image) -> Vec<[u32; 3]> {
    img.pixels
        .iter()
        .map(|p| p.to_array().map(f32::to_bits))
        .collect()
}

/// `world` by the independent renders and by the twin method with shared
/// shadows (with the strip pass or the batches' eye passes): every view the
/// same bit for bit, the same rays but for the shadow rays proved free.
/// Returns the shared render.
fn exact(world: &World, views: usize, convergence: Option<f64>, strip: bool) -> RenderOutput {
    exact_on(1, world, views, convergence, strip)
}

fn exact_on(
    threads: usize,
    world: &World,
    views: usize,
    convergence: Option<f64>,
    strip: bool,
) -> RenderOutput {
    let (camera, rig) = camera_rig(world, views, convergence);
    let reference = run(
        world,
        &camera,
        &rig,
        &options(Method::Independent, Sampling::Centers),
    );
    let opts = RenderOptions {
        shadow_fans: true,
        shadow_fan_min_run: 2,
        strip,
        ..options(Method::Twin, Sampling::Centers)
    };
    let fans = run_on_threads(threads, world, &camera, &rig, &opts);
    let what = format!("{views} views, convergence {convergence:?}, strip {strip}");
    assert_eq!(reference.images.len(), fans.images.len(), "{what}");
    for (v, (a, b)) in reference.images.iter().zip(&fans.images).enumerate() {
        let (a, b) = (bits(a), bits(b));
        let differ = a.iter().zip(&b).filter(|(p, q)| p != q).count();
        assert_eq!(differ, 0, "{what}: view {v} differs in {differ} pixels");
    }
    let (r, f) = (reference.counts.rays, fans.counts.rays);
    assert_eq!(
        (r.eye, r.eye_hit, r.reflected, r.refracted),
        (f.eye, f.eye_hit, f.reflected, f.refracted),
        "{what}"
    );
    assert_eq!(
        f.shadow + fans.counts.shadow_rays_proved,
        r.shadow,
        "{what}: shadow rays traced and proved"
    );
    assert_eq!(reference.counts.shadow_rays_proved, 0);
    fans
}

/// An open floor: every run's fan is free, so no eye hit in a run traces a
/// shadow ray; with parallel views (no image shift) every camera column
/// holds every view, so no shadow ray at all is traced.
#[test]
fn on_an_open_floor_every_fan_is_free_and_no_shadow_ray_is_traced() {
    for lights in LIGHTS {
        let world = parse(&format!("{FLOOR}{lights}"));
        for views in [2, 5, 8, 48] {
            for strip in [false, true] {
                let out = exact(&world, views, None, strip);
                let c = &out.counts;
                assert!(c.fan_queries > 0, "{views} views");
                assert_eq!(c.fan_queries, c.fan_free, "{views} views: {c:?}");
                assert_eq!(c.rays.shadow, 0, "{views} views, strip {strip}");
                assert_eq!(
                    c.shadow_rays_proved,
                    (views * (WIDTH * HEIGHT) as usize * world.scene.lights.len()) as u64
                );
            }
            // Converged views: the columns at the row's ends hold fewer views.
            let out = exact(&world, views, Some(7.0), false);
            assert!(out.counts.shadow_rays_proved > out.counts.rays.shadow);
        }
    }
}

/// A thin pole's shadow crosses the runs: some fans are met (their rays are
/// traced), the others free; the shadow is there, as the reference has it.
#[test]
fn a_shadow_edge_crossing_a_run_is_kept() {
    for lights in LIGHTS {
        let world = parse(&format!("{FLOOR}{lights}{POLE}"));
        for views in [2, 5, 8, 48] {
            for convergence in [None, Some(7.0)] {
                let out = exact(&world, views, convergence, views % 2 == 0);
                let c = &out.counts;
                assert!(c.fan_free > 0 && c.fan_free < c.fan_queries, "{c:?}");
                assert!(c.rays.shadow > 0 && c.shadow_rays_proved > 0, "{c:?}");
            }
        }
        // The pole's shadow shows on the floor (its image differs from the
        // open floor's beyond the pixels that see the pole).
        let open = parse(&format!("{FLOOR}{lights}"));
        let (camera, rig) = camera_rig(&world, 2, None);
        let opts = options(Method::Independent, Sampling::Centers);
        let with = run(&world, &camera, &rig, &opts);
        let without = run(&open, &camera, &rig, &opts);
        let darker = with.images[0]
            .pixels
            .iter()
            .zip(&without.images[0].pixels)
            .filter(|(a, b)| a.max_element() < b.max_element() * 0.7)
            .count();
        assert!(darker > 5, "{darker} pixels darker");
    }
}

/// Where view `view`'s shadow ray through pixel `(x, y)` starts (about: the
/// floor point) toward the first light.
fn segment(camera: &Camera, rig: &Rig, view: usize, x: i32, y: f32, light: Vec3) -> (Vec3, Vec3) {
    let v = &rig.views[view];
    let origin = camera.eye_at(v.offset);
    let dir = camera.direction((x + v.shift) as f32, y);
    let point = origin + dir * (-origin.z / dir.z);
    (point, light)
}

/// A sphere a tenth of the views' spacing wide on one view's shadow segment:
/// its run's fan is met, that view's sample alone is in shadow.
#[test]
fn an_occluder_on_one_views_segment_only() {
    let light = Vec3::new(3.0, 2.0, 10.0);
    for lights in LIGHTS {
        for views in [2, 5, 8, 48] {
            for convergence in [None, Some(7.0)] {
                let open = parse(&format!("{FLOOR}{lights}"));
                let (camera, rig) = camera_rig(&open, views, convergence);
                let k = views / 2;
                let (x, y) = (17, 21);
                let (p, l) = segment(&camera, &rig, k, x, y as f32, light);
                // A third of the way up, the segments are 2/3 of a spacing apart.
                let c = p + (l - p) * (1.0 / 3.0);
                let text = format!(
                    "{FLOOR}{lights}f 0.2 0.2 0.9 0.8 0 10 0 1\ns {:?} {:?} {:?} {:?}\n",
                    c.x,
                    c.y,
                    c.z,
                    INTERAXIAL * 0.1
                );
                let world = parse(&text);
                let out = exact(&world, views, convergence, views % 2 == 1);
                assert!(out.counts.fan_free < out.counts.fan_queries);
                // The reference: view k's pixel is in that light's shadow,
                // its neighbours' pixels in the same column are not.
                let opts = options(Method::Independent, Sampling::Centers);
                let without = run(&open, &camera, &rig, &opts);
                let at =
                    |img: &twinray::Image, px: i32| img.pixels[(y * WIDTH + px as u32) as usize];
                let shade = |v: usize| {
                    let px = x + rig.views[k].shift - rig.views[v].shift;
                    (at(&out.images[v], px), at(&without.images[v], px))
                };
                let (a, b) = shade(k);
                assert!(a.max_element() < b.max_element(), "{views} views: view {k}");
                for v in [k.wrapping_sub(1), k + 1] {
                    if v < views {
                        let (a, b) = shade(v);
                        assert_eq!(a, b, "{views} views: view {v} beside {k}");
                    }
                }
            }
        }
    }
}

/// Spheres grazing one view's shadow segment from above the fan, by a
/// thousandth of their radius inside or outside, or well clear: exact
/// whichever way the fans decide.
#[test]
fn spheres_grazing_a_fan() {
    let light = Vec3::new(3.0, 2.0, 10.0);
    for lights in LIGHTS {
        for views in [2, 5, 8, 48] {
            let open = parse(&format!("{FLOOR}{lights}"));
            let (camera, rig) = camera_rig(&open, views, Some(7.0));
            let k = views / 2;
            let mut text = format!("{FLOOR}{lights}f 0.2 0.9 0.2 0.8 0 10 0 1\n");
            let radius = 0.05f32;
            for (x, gap) in [(8, -1e-3f32), (16, 1e-3), (24, 0.5), (32, -0.3)] {
                let (p, l) = segment(&camera, &rig, k, x, 12.0, light);
                let along = (l - p).normalize();
                // Out of the fan's plane (which holds the camera's right axis).
                let out_of_plane = along.cross(camera.right).normalize();
                let c = p + (l - p) * 0.5 + out_of_plane * (radius * (1.0 + gap));
                text += &format!("s {:?} {:?} {:?} {:?}\n", c.x, c.y, c.z, radius);
            }
            let world = parse(&text);
            let out = exact(&world, views, Some(7.0), views > 4);
            let c = &out.counts;
            assert!(c.fan_free > 0 && c.fan_free < c.fan_queries, "{c:?}");
        }
    }
}

/// The same images and counts on 1, 2 and 5 threads.
#[test]
fn the_same_on_one_two_and_five_threads() {
    let world = parse(&format!("{FLOOR}{}{POLE}", LIGHTS[1]));
    let one = exact_on(1, &world, 8, Some(7.0), false);
    for threads in [2, 5] {
        let many = exact_on(threads, &world, 8, Some(7.0), false);
        for (a, b) in one.images.iter().zip(&many.images) {
            assert_eq!(bits(a), bits(b), "{threads} threads");
        }
        assert_eq!(one.counts.rays, many.counts.rays, "{threads} threads");
        assert_eq!(
            one.counts.shadow_rays_proved, many.counts.shadow_rays_proved,
            "{threads} threads"
        );
    }
}

/// By default (`shadow_fan_min_run` 0) runs of fewer than 8 hits trace their
/// rays: 5 parallel views ask no fan, 8 do.
#[test]
fn by_default_runs_of_fewer_than_eight_hits_ask_no_fan() {
    let world = parse(&format!("{FLOOR}{}", LIGHTS[0]));
    for (views, asked) in [(5, false), (8, true)] {
        let (camera, rig) = camera_rig(&world, views, None);
        let opts = RenderOptions {
            shadow_fans: true,
            ..options(Method::Twin, Sampling::Centers)
        };
        let out = run(&world, &camera, &rig, &opts);
        assert_eq!(out.counts.fan_queries > 0, asked, "{views} views");
        assert_eq!(out.counts.shadow_rays_proved > 0, asked, "{views} views");
    }
}

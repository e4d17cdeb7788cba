//! Whole renders: radiance known in closed form, committed reference images,
//! the same image for any thread count, and the SPD ray-count rules.
//!
//! Reference images are regression guards: `TWINRAY_BLESS=1 cargo test --test
//! render` rewrites them after an intended change of the images.

use crate::common;

use std::path::{Path, PathBuf};

use common::*;
use twinray::loaders::nff::parse_nff;
use twinray::loaders::LoadOptions;
use twinray::output::{compare, read_image, write_image, WriteOptions};
use twinray::render::{Sampling, ViewMethod};
use twinray::rig::Camera;
use twinray::rig::Rig;
use twinray::World;

fn reference_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/reference")
}

fn world_from(text: &str) -> World {
    World::new(parse_nff(text, Path::new("inline.nff"), &LoadOptions::default()).expect("parses"))
}

#[test]
fn diffuse_square_facing_a_head_on_light_has_the_closed_form_radiance() {
    // Kd = 0.6, colour (1, 0.5, 0.25), one white light straight behind the eye:
    // at the centre N·L = 1, so I = ambient·C + Kd·C = (1 − 0.6)·C + 0.6·C = C.
    let w = world_from(
        "b 0 0 0\nv\nfrom 0 0 10\nat 0 0 0\nup 0 1 0\nangle 30\nhither 0.01\nresolution 33 33\n\
         l 0 0 1000 1 1 1\nf 1 0.5 0.25 0.6 0 1 0 1\np 4\n-5 -5 0\n5 -5 0\n5 5 0\n-5 5 0\n",
    );
    let cam = Camera::new(&w.scene.viewpoint, 33, 33);
    let out = run(
        &w,
        &cam,
        &Rig::mono(),
        &options(ViewMethod::Independent, Sampling::Centers),
    );
    let c = out.images[0].get(16, 16);
    assert!(
        (c - twinray::math::Vec3::new(1.0, 0.5, 0.25))
            .abs()
            .max_element()
            < 1e-5,
        "{c}"
    );
    // Off centre the cosine falls: N·L = cos of the angle to the light, nearly 1 here.
    let edge = out.images[0].get(0, 16);
    assert!(edge.x < c.x && edge.x > 0.95, "{edge}");
}

#[test]
fn shadow_of_an_opaque_sphere_is_ambient_only_and_glass_lets_t_through() {
    // Light far away at 45 degrees: the sphere at height 2 shadows the floor around
    // (-2, 0, 0), which the eye (straight above) sees past the sphere.
    let scene = |t: f32| {
        format!(
            "b 0 0 0\nv\nfrom 0 0 10\nat 0 0 0\nup 0 1 0\nangle 40\nhither 0.01\nresolution 41 41\n\
             l 100000 0 100000 1 1 1\nf 1 1 1 0.5 0 1 0 1\np 4\n-5 -5 0\n5 -5 0\n5 5 0\n-5 5 0\n\
             f 1 1 1 0 0 1 {t} 1\ns 0 0 2 0.5\n"
        )
    };
    let opaque = world_from(&scene(0.0));
    let glass = world_from(&scene(0.5));
    let cam = Camera::new(&opaque.scene.viewpoint, 41, 41);
    let o = run(
        &opaque,
        &cam,
        &Rig::mono(),
        &options(ViewMethod::Independent, Sampling::Centers),
    );
    let g = run(
        &glass,
        &cam,
        &Rig::mono(),
        &options(ViewMethod::Independent, Sampling::Centers),
    );
    let pixel = |p: twinray::math::Vec3| {
        let (x, y) = cam.project(p, 0.0).expect("visible");
        (x.round() as u32, y.round() as u32)
    };
    let cos45 = std::f32::consts::FRAC_1_SQRT_2;
    // Lit floor: ambient (1 − Kd) + Kd·cos 45°.
    let (lx, ly) = pixel(twinray::math::Vec3::new(2.0, 0.0, 0.0));
    assert!((o.images[0].get(lx, ly).x - (0.5 + 0.5 * cos45)).abs() < 1e-3);
    // In the shadow: ambient only; behind glass of T = 0.5: half the light gets through.
    let (sx, sy) = pixel(twinray::math::Vec3::new(-2.0, 0.0, 0.0));
    let shadowed = o.images[0].get(sx, sy).x;
    assert!((shadowed - 0.5).abs() < 1e-4, "opaque shadow: {shadowed}");
    let filtered = g.images[0].get(sx, sy).x;
    assert!(
        (filtered - (0.5 + 0.5 * cos45 * 0.5)).abs() < 1e-3,
        "glass shadow: {filtered}"
    );
}

fn check_reference(name: &str, scene: &str, width: u32, height: u32, sampling: Sampling) {
    let world = world(scene);
    let cam = camera(&world, width, height);
    let out = run(
        &world,
        &cam,
        &Rig::mono(),
        &options(ViewMethod::Independent, sampling),
    );
    let path = reference_dir().join(format!("{name}.png"));
    if std::env::var_os("TWINRAY_BLESS").is_some() {
        std::fs::create_dir_all(reference_dir()).expect("mkdir");
        write_image(&path, &out.images[0], &WriteOptions::default()).expect("bless");
        return;
    }
    let reference = read_image(&path).expect("reference image (bless with TWINRAY_BLESS=1)");
    // Quantise the render like the reference was (8-bit PNG), then compare.
    let quantised: Vec<_> = out.images[0]
        .pixels
        .iter()
        .map(|c| {
            (c.clamp(twinray::math::Vec3::ZERO, twinray::math::Vec3::ONE) * 255.0).round() / 255.0
        })
        .collect();
    let img = twinray::Image {
        width,
        height,
        pixels: quantised,
    };
    let d = compare(&img, &reference).expect("same size");
    // Tolerance: the renderer is deterministic, but libm's powf may differ across
    // platforms by an ulp, which can move a value across an 8-bit step: allow
    // 1/255 on up to 0.5 % of pixels, nothing larger.
    let allowed = (width * height) as usize / 200;
    assert!(
        d.max_abs <= 1.0 / 255.0 + 1e-6,
        "{name}: max difference {} (PSNR {:.1} dB)",
        d.max_abs,
        d.psnr_db
    );
    assert!(
        d.differing_pixels <= allowed,
        "{name}: {} pixels differ",
        d.differing_pixels
    );
}

#[test]
fn example_matches_its_reference_image() {
    check_reference("example-96x72", "example.nff", 96, 72, Sampling::Centers);
}

#[test]
fn shelf_matches_its_reference_image() {
    check_reference("shelf-80x60", "shelf.nff", 80, 60, Sampling::Centers);
}

#[test]
fn spd_procedure_matches_its_reference_image() {
    check_reference("example-spd-32", "example.nff", 32, 32, Sampling::Corners);
}

#[test]
fn same_image_for_any_thread_count() {
    let world = world("example.nff");
    let cam = camera(&world, 80, 60);
    let rig = Rig::stereo(&cam, 0.3, Some(default_convergence(&world))).unwrap();
    for method in [ViewMethod::Independent, ViewMethod::twin()] {
        let opts = options(method, Sampling::Centers);
        let render_with = |threads| run_on_threads(threads, &world, &cam, &rig, &opts);
        let one = render_with(1);
        for threads in [2, 3, 7] {
            let many = render_with(threads);
            assert_eq!(one.images, many.images, "{method:?}, {threads} threads");
            // Everything counted but the passes' clock times.
            let counts = |c: &twinray::render::TraceCounts| twinray::render::TraceCounts {
                eye_pass_ns: 0,
                shading_pass_ns: 0,
                ..*c
            };
            assert_eq!(
                counts(&one.counts),
                counts(&many.counts),
                "{method:?}, {threads} threads: counts"
            );
        }
    }
}

#[test]
fn spd_procedure_spawns_every_secondary_ray() {
    // A transmitting, non-reflecting sphere (Ks = 0): the SPD rules still spawn a
    // reflected ray at every hit on it, and a refracted one unless totally reflected.
    let w = world_from(
        "b 0 0 0\nv\nfrom 0 0 10\nat 0 0 0\nup 0 1 0\nangle 20\nhither 0.01\nresolution 16 16\n\
         l 0 5 10\nf 1 1 1 0.5 0 1 0.9 1.5\ns 0 0 0 1\n",
    );
    let cam = Camera::new(&w.scene.viewpoint, 16, 16);
    let spd = run(
        &w,
        &cam,
        &Rig::mono(),
        &options(ViewMethod::Independent, Sampling::Corners),
    );
    let r = spd.counts.rays;
    assert_eq!(r.eye, 17 * 17);
    assert!(r.eye_hit > 0);
    // Every hit of a level below 5 on this material spawns a reflected ray.
    assert!(r.reflected >= r.eye_hit);
    assert!(r.refracted > 0 && r.refracted <= r.reflected);
    // The normal mode skips the zero-weight reflections.
    let normal = run(
        &w,
        &cam,
        &Rig::mono(),
        &options(ViewMethod::Independent, Sampling::Centers),
    );
    assert!(normal.counts.rays.reflected < normal.counts.rays.eye_hit);
}

#[test]
fn polygons_are_shaded_from_the_side_the_ray_comes_from() {
    // The rule: an opaque surface is lit from whichever side the eye sees, so a
    // polygon's vertex order does not matter; a light on the far side leaves
    // the seen side with its ambient term only.
    let scene = |order: &str, light_z: f32| {
        format!(
            "b 0 0 0\nv\nfrom 0 0 10\nat 0 0 0\nup 0 1 0\nangle 30\nhither 0.01\nresolution 9 9\n\
             l 0 0 {light_z} 1 1 1\nf 1 1 1 0.6 0 1 0 1\np 4\n{order}"
        )
    };
    let ccw = "-5 -5 0\n5 -5 0\n5 5 0\n-5 5 0\n";
    let cw = "-5 5 0\n5 5 0\n5 -5 0\n-5 -5 0\n";
    let centre = |text: String| {
        let w = world_from(&text);
        let cam = Camera::new(&w.scene.viewpoint, 9, 9);
        run(
            &w,
            &cam,
            &Rig::mono(),
            &options(ViewMethod::Independent, Sampling::Centers),
        )
        .images[0]
            .get(4, 4)
    };
    let front = centre(scene(ccw, 100.0));
    let back = centre(scene(cw, 100.0));
    assert_eq!(front, back, "vertex order must not matter");
    assert!(
        (front.x - 1.0).abs() < 1e-5,
        "lit: ambient 0.4 + 0.6: {front}"
    );
    let behind = centre(scene(ccw, -100.0));
    assert!(
        (behind.x - 0.4).abs() < 1e-6,
        "light behind: ambient only: {behind}"
    );
}

#[test]
fn hits_are_counted_and_reported_for_every_one_of_48_views() {
    // A quilt has 48 views; the counts once kept only 32 (views 32..47 were
    // dropped from `--stats` without a word).
    let world = world("example.nff");
    let cam = camera(&world, 32, 24);
    let rig = Rig::multi_view(&cam, 48, 0.05, None).unwrap();
    let twin = run(
        &world,
        &cam,
        &rig,
        &options(ViewMethod::twin(), Sampling::Centers),
    );
    let mut report = twinray::stats::Report::default();
    report.fill_counts(&twin.counts, rig.views.len(), ViewMethod::twin());
    assert_eq!(report.hits_per_view.len(), 48);
    for (v, view) in rig.views.iter().enumerate() {
        // Each view's hits are those of the view rendered alone.
        let alone = Rig {
            views: vec![*view],
            convergence: None,
            effective_convergence: None,
        };
        let mono = run(
            &world,
            &cam,
            &alone,
            &options(ViewMethod::Independent, Sampling::Centers),
        );
        assert!(mono.counts.rays.eye_hit > 0);
        assert_eq!(
            report.hits_per_view[v], mono.counts.rays.eye_hit,
            "view {v}"
        );
    }
    assert_eq!(
        report.hits_per_view.iter().sum::<u64>(),
        twin.counts.rays.eye_hit
    );
}

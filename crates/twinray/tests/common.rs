//! Helpers shared by the integration tests: the project's own scenes, rendered small.
#![allow(dead_code)]

use std::path::PathBuf;

use twinray::loaders::{load_scene, LoadOptions};
use twinray::render::{render, Method, RenderOptions, RenderOutput, Sampling, TraceSettings};
use twinray::rig::Camera;
use twinray::rig::Rig;
use twinray::{Image, World};

pub fn scene_path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes")
        .join(name)
}

pub fn world(name: &str) -> World {
    let scene =
        load_scene(&scene_path(name), &LoadOptions::default()).expect("shipped scene loads");
    World::new(scene)
}

pub fn camera(world: &World, width: u32, height: u32) -> Camera {
    Camera::new(&world.scene.viewpoint, width, height)
}

pub fn options(method: Method, sampling: Sampling) -> RenderOptions {
    RenderOptions {
        trace: TraceSettings {
            spd: sampling == Sampling::Corners,
            min_weight: if sampling == Sampling::Corners {
                0.0
            } else {
                1.0 / 256.0
            },
            ..TraceSettings::default()
        },
        method,
        sampling,
        ..RenderOptions::default()
    }
}

pub fn run(world: &World, camera: &Camera, rig: &Rig, opts: &RenderOptions) -> RenderOutput {
    render(world, camera, rig, opts, &|_, _| {}).expect("render")
}

/// `run` on a pool of `threads` worker threads.
pub fn run_on_threads(
    threads: usize,
    world: &World,
    camera: &Camera,
    rig: &Rig,
    opts: &RenderOptions,
) -> RenderOutput {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("pool");
    pool.install(|| run(world, camera, rig, opts))
}

/// One mono image of `world` by the reference method, pixel centres.
pub fn mono(world: &World, width: u32, height: u32) -> twinray::Image {
    let cam = camera(world, width, height);
    let out = run(
        world,
        &cam,
        &Rig::mono(),
        &options(Method::Independent, Sampling::Centers),
    );
    out.images.into_iter().next().expect("one view")
}

/// The distance from the eye to the NFF `at` point: the default convergence.
pub fn default_convergence(world: &World) -> f64 {
    (world.scene.viewpoint.at - world.scene.viewpoint.from).length() as f64
}

/// Intensity-weighted centroid of the blob around `(x, y)` (pixel units),
/// within `radius` + 3 pixels.
pub fn centroid(img: &Image, x: f64, y: f64, radius: f64) -> Option<(f64, f64)> {
    let (mut sw, mut sx, mut sy) = (0.0, 0.0, 0.0);
    let r = radius.ceil() as i64 + 3;
    for j in (y.round() as i64 - r)..=(y.round() as i64 + r) {
        for i in (x.round() as i64 - r)..=(x.round() as i64 + r) {
            if i < 0 || j < 0 || i >= img.width as i64 || j >= img.height as i64 {
                continue;
            }
            let w = img.get(i as u32, j as u32).element_sum() as f64;
            sw += w;
            sx += w * i as f64;
            sy += w * j as f64;
        }
    }
    (sw > 0.0).then(|| (sx / sw, sy / sw))
}

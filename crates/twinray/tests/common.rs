//! Helpers shared by the integration tests: the project's own scenes, rendered small.
#![allow(dead_code)]

use std::path::PathBuf;

use twinray::camera::Camera;
use twinray::loaders::{load_scene, LoadOptions};
use twinray::render::{render, Method, RenderOptions, RenderOutput, Sampling, TraceSettings};
use twinray::rig::Rig;
use twinray::World;

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

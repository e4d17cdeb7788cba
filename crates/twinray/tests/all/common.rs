//! Helpers shared by the integration tests: the project's own scenes, rendered small.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use base64::Engine as _;
use serde_json::json;

use twinray::loaders::{load_scene, LoadOptions};
use twinray::render::{render, RenderOptions, RenderOutput, Sampling, TraceSettings, ViewMethod};
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

/// Looking down on a diffuse floor (one triangle, no highlight or mirror),
/// 40 x 30 pixels: the scene of the multi-view approximations' tests.
pub const OPEN_FLOOR: &str =
    "b 0.1 0.1 0.2\nv\nfrom 0 -6 5\nat 0 0 0\nup 0 0 1\nangle 45\nhither 0.01\n\
    resolution 40 30\nl 3 2 10\n\
    f 0.8 0.8 0.7 0.9 0 0 0 1\np 3\n-100 -100 0\n100 -100 0\n0 100 0\n";

/// `OPEN_FLOOR`'s view of a mirror floor (unlit: the light is below it)
/// reflecting a thin dark pole against a bright sky: what the mirror shows
/// changes from view to view.
pub const MIRROR_FLOOR_AND_POLE: &str =
    "b 0.8 0.8 0.9\nv\nfrom 0 -6 5\nat 0 0 0\nup 0 0 1\nangle 45\nhither 0.01\n\
    resolution 40 30\nl 0 0 -10\n\
    f 0.8 0.8 0.7 0.5 0.5 20 0 1\np 3\n-100 -100 0\n100 -100 0\n0 100 0\n\
    f 0.05 0.05 0.05 0 0 0 0 1\nc\n0.1 3 0 0.01\n0.1 3 4 0.01\n";

/// A wall in the plane x = 0, lit on its +x face, over a floor: its plane
/// passes through the middle view's eye of a rig on the x axis, so the
/// views either side of it see its two faces, one lit and one dark.
pub const WALL_BETWEEN_VIEWS: &str =
    "b 0.1 0.2 0.3\nv\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 45\nhither 0.01\n\
    resolution 40 30\nl 3 1 1\n\
    f 0.8 0.8 0.8 0.9 0 0 0 1\np 4\n0 -2 -3\n0 2 -3\n0 2 3\n0 -2 3\n\
    f 0.7 0.3 0.2 0.9 0 0 0 1\np 4\n-6 -1.5 -8\n6 -1.5 -8\n6 -1.5 4\n-6 -1.5 4\n";

/// The world of an NFF scene given as text.
pub fn nff_world(text: &str) -> World {
    let scene =
        twinray::loaders::nff::parse_nff(text, Path::new("test.nff"), &LoadOptions::default())
            .expect("generated scene");
    World::new(scene)
}

pub fn camera(world: &World, width: u32, height: u32) -> Camera {
    Camera::new(&world.scene.viewpoint, width, height)
}

pub fn options(method: ViewMethod, sampling: Sampling) -> RenderOptions {
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
        &options(ViewMethod::Independent, Sampling::Centers),
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

/// The quad −1..1 at z = 0 as two triangles with texture coordinates (v = 0 at the top).
pub fn quad_buffer() -> String {
    let corners: [([f32; 3], [f32; 2]); 4] = [
        ([-1.0, -1.0, 0.0], [0.0, 1.0]),
        ([1.0, -1.0, 0.0], [1.0, 1.0]),
        ([1.0, 1.0, 0.0], [1.0, 0.0]),
        ([-1.0, 1.0, 0.0], [0.0, 0.0]),
    ];
    let mut bytes = Vec::new();
    for i in [0, 1, 2, 0, 2, 3] {
        for v in corners[i].0 {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    for i in [0, 1, 2, 0, 2, 3] {
        for v in corners[i].1 {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&bytes)
    )
}

/// A glTF quad with `material`; `images` are file names beside it.
pub fn gltf_quad(dir: &Path, material: serde_json::Value, images: &[&str]) -> PathBuf {
    let doc = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "material": 0}]}],
        "materials": [material],
        "textures": (0..images.len()).map(|i| json!({"source": i})).collect::<Vec<_>>(),
        "images": images.iter().map(|u| json!({"uri": u})).collect::<Vec<_>>(),
        "buffers": [{"byteLength": 6 * 20, "uri": quad_buffer()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 72},
            {"buffer": 0, "byteOffset": 72, "byteLength": 48}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 6, "type": "VEC3",
             "min": [-1.0, -1.0, 0.0], "max": [1.0, 1.0, 0.0]},
            {"bufferView": 1, "componentType": 5126, "count": 6, "type": "VEC2"}
        ]
    });
    let path = dir.join("quad.gltf");
    std::fs::write(&path, doc.to_string()).unwrap();
    path
}

/// The nearest hit among all `shapes` with `t_min < t <= t_max` (the
/// traversals' contract: an equal distance goes to the lower index): the
/// reference the hierarchies' tests compare against.
pub fn brute(
    shapes: &[twinray::shapes::Shape],
    ray: &twinray::math::Ray,
    t_min: f32,
    t_max: f32,
) -> Option<(u32, twinray::shapes::SurfaceHit)> {
    let mut best: Option<(u32, twinray::shapes::SurfaceHit)> = None;
    for (i, s) in shapes.iter().enumerate() {
        if let Some(h) = s.intersect(ray, t_min, t_max.next_up()) {
            if best.is_none_or(|(_, b)| h.t < b.t) {
                best = Some((i as u32, h));
            }
        }
    }
    best
}

/// A render's views against the independent renders: the largest difference
/// of any view and the number of pixels that differ at all.
pub fn difference(exact: &RenderOutput, out: &RenderOutput) -> (f32, usize) {
    let (mut worst, mut differ) = (0.0f32, 0);
    for (a, b) in exact.images.iter().zip(&out.images) {
        for (p, q) in a.pixels.iter().zip(&b.pixels) {
            worst = worst.max((*p - *q).abs().max_element());
            differ += usize::from(p != q);
        }
    }
    (worst, differ)
}

/// Rings of tilted cylinders joined by spheres (SPD rings' shape), opaque,
/// over a floor; one light.
pub fn rings(count: usize, seed: u64) -> String {
    let mut rng = fastrand::Rng::with_seed(seed);
    let mut text = String::from(
        "v\nfrom 0 -12 4\nat 0 0 0\nup 0 0 1\nangle 40\nhither 0.01\nresolution 64 64\n\
         b 0.1 0.2 0.3\nl 4 -6 9\nf 0.8 0.8 0.8 0.7 0.2 20 0 1\n\
         p 4\n-9 -9 -2\n9 -9 -2\n9 9 -2\n-9 9 -2\nf 0.9 0.2 0.2 0.5 0.5 30 0 1\n",
    );
    for _ in 0..count {
        let c = twinray::math::Vec3::new(
            rng.f32() * 10.0 - 5.0,
            rng.f32() * 10.0 - 5.0,
            rng.f32() * 3.0,
        );
        let (a, b) = (rng.f32() * 6.3, rng.f32() * 1.5);
        let (u, v) = (
            twinray::math::Vec3::new(a.cos(), a.sin(), 0.0),
            twinray::math::Vec3::new(-a.sin() * b.cos(), a.cos() * b.cos(), b.sin()),
        );
        let corner = |k: usize| {
            let t = k as f32 * std::f32::consts::TAU / 5.0;
            c + (u * t.cos() + v * t.sin()) * 0.6
        };
        for k in 0..5 {
            let (p, q) = (corner(k), corner(k + 1));
            text += &format!(
                "c {} {} {} 0.05 {} {} {} 0.05\ns {} {} {} 0.05\n",
                p.x, p.y, p.z, q.x, q.y, q.z, p.x, p.y, p.z
            );
        }
    }
    text
}

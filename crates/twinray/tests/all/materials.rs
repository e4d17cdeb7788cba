//! Materials of real-world files, each checked with a file made here: an
//! emissive-textured glTF quad, glTF emissive strength, occlusion and metal
//! tint, and an OBJ material of `Ns 0` (Blender's export of a rough surface).

use crate::common;

use std::path::{Path, PathBuf};

use serde_json::json;
use twinray::loaders::{load_scene, LoadOptions};
use twinray::math::{Color, Vec3};
use twinray::rig::{Camera, Rig};
use twinray::scene::{AngleSpan, Light, Viewpoint};
use twinray::{Image, Scene, World};

const SIZE: u32 = 8;

/// A camera 3 units in front of the unit quad (−1..1 in x and y, at z = 0),
/// which fills its view.
fn front_camera() -> Camera {
    let vp = Viewpoint {
        from: Vec3::new(0.0, 0.0, 3.0),
        at: Vec3::ZERO,
        up: Vec3::Y,
        angle_deg: 30.0,
        angle_span: AngleSpan::ImageHeight,
        hither: 0.0,
        width: SIZE,
        height: SIZE,
    };
    Camera::new(&vp, SIZE, SIZE)
}

fn render(scene: Scene) -> Image {
    let world = World::new(scene);
    let opts = common::options(
        twinray::render::ViewMethod::Independent,
        twinray::render::Sampling::Centers,
    );
    let out = common::run(&world, &front_camera(), &Rig::mono(), &opts);
    out.images.into_iter().next().expect("one view")
}

fn png(path: &Path, width: u32, height: u32, pixels: &[[u8; 3]]) {
    let img = image::RgbImage::from_fn(width, height, |x, y| {
        image::Rgb(pixels[(y * width + x) as usize])
    });
    img.save(path).unwrap();
}

/// A glTF quad with `material`; `images` are file names beside it.
fn gltf_quad(dir: &Path, material: serde_json::Value, images: &[&str]) -> PathBuf {
    common::gltf_quad(dir, material, images)
}

fn load(path: &Path) -> Scene {
    load_scene(path, &LoadOptions::default()).expect("loads")
}

fn close(a: Color, b: Color) -> bool {
    (a - b).abs().max_element() < 1e-3
}

/// Left half red, right half green: the emissive texture of the quad.
fn red_green(dir: &Path) {
    let (r, g) = ([255, 0, 0], [0, 255, 0]);
    png(&dir.join("emit.png"), 4, 1, &[r, r, g, g]);
}

#[test]
fn emissive_texture_multiplies_the_emissive_factor() {
    let dir = tempfile::tempdir().unwrap();
    red_green(dir.path());
    let file = gltf_quad(
        dir.path(),
        json!({"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]},
               "emissiveFactor": [1, 1, 1], "emissiveTexture": {"index": 0}}),
        &["emit.png"],
    );
    // No lights: what the camera sees is the light the quad emits.
    let img = render(load(&file));
    let (left, right) = (img.get(1, SIZE / 2), img.get(SIZE - 2, SIZE / 2));
    assert!(close(left, Color::new(1.0, 0.0, 0.0)), "left {left}");
    assert!(close(right, Color::new(0.0, 1.0, 0.0)), "right {right}");
}

#[test]
fn emissive_strength_scales_the_emission() {
    let dir = tempfile::tempdir().unwrap();
    red_green(dir.path());
    let file = gltf_quad(
        dir.path(),
        json!({"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]},
               "emissiveFactor": [0.5, 0.5, 0.5], "emissiveTexture": {"index": 0},
               "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}}}),
        &["emit.png"],
    );
    let img = render(load(&file));
    let left = img.get(1, SIZE / 2);
    assert!(close(left, Color::new(2.0, 0.0, 0.0)), "left {left}");
}

#[test]
fn occlusion_darkens_the_ambient_term_and_metals_tint_their_highlight() {
    let dir = tempfile::tempdir().unwrap();
    // Occlusion 0 on the left, 0.502 on the right (data: not sRGB-decoded).
    let (black, half) = ([0, 0, 0], [128, 128, 128]);
    png(
        &dir.path().join("ao.png"),
        4,
        1,
        &[black, black, half, half],
    );
    let file = gltf_quad(
        dir.path(),
        json!({"pbrMetallicRoughness": {"baseColorFactor": [1, 0.5, 0.25, 1],
                                        "metallicFactor": 1.0, "roughnessFactor": 0.5},
               "occlusionTexture": {"index": 0, "strength": 1.0}}),
        &["ao.png"],
    );
    let mut scene = load(&file);
    assert_eq!(
        scene.materials[0].specular_color,
        Color::new(1.0, 0.5, 0.25)
    );
    // A metallic-roughness material has no Whitted ambient of its own
    // (kd + ks fill it): give it some to see the occlusion act.
    scene.materials[0].kd = 0.5;
    scene.materials[0].ks = 0.0;
    let ambient = scene.materials[0].ambient();
    assert_eq!(ambient, 0.5);
    let img = render(scene);
    let (left, right) = (img.get(1, SIZE / 2), img.get(SIZE - 2, SIZE / 2));
    assert!(close(left, Color::ZERO), "fully occluded: {left}");
    let want = Color::new(1.0, 0.5, 0.25) * ambient * (128.0 / 255.0);
    assert!(close(right, want), "half occluded: {right}, want {want}");
}

/// An OBJ quad facing +z with the MTL material `mtl`, lit from the camera.
fn obj_quad(dir: &Path, name: &str, mtl: &str) -> Scene {
    std::fs::write(
        dir.join(format!("{name}.mtl")),
        format!("newmtl m\n{mtl}\n"),
    )
    .unwrap();
    let obj =
        format!("mtllib {name}.mtl\nusemtl m\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3 4\n");
    let path = dir.join(format!("{name}.obj"));
    std::fs::write(&path, obj).unwrap();
    let mut scene = load(&path);
    scene
        .lights
        .push(Light::point(Vec3::new(0.5, 0.5, 4.0), Some(Color::ONE)));
    scene
}

#[test]
fn obj_ns_0_is_a_rough_surface_without_highlight() {
    let dir = tempfile::tempdir().unwrap();
    // Blender writes Ns 0 with Ks 0.5 for a fully rough surface.
    let rough = obj_quad(
        dir.path(),
        "rough",
        "Kd 0.5 0.5 0.5\nKs 0.5 0.5 0.5\nNs 0\nillum 2",
    );
    let matte = obj_quad(dir.path(), "matte", "Kd 0.5 0.5 0.5\nKs 0 0 0\nillum 2");
    assert_eq!(rough.materials[0].ks, 0.0);
    let (a, b) = (render(rough), render(matte));
    assert_eq!(a.pixels, b.pixels, "Ns 0 renders as the matte surface");
}

#[test]
fn obj_ns_sets_a_highlight_that_narrows_as_ns_grows() {
    let dir = tempfile::tempdir().unwrap();
    let soft = obj_quad(
        dir.path(),
        "soft",
        "Kd 0.5 0.5 0.5\nKs 0.5 0.5 0.5\nNs 100\nillum 2",
    );
    let sharp = obj_quad(
        dir.path(),
        "sharp",
        "Kd 0.5 0.5 0.5\nKs 0.5 0.5 0.5\nNs 900\nillum 2",
    );
    let (s, h) = (&soft.materials[0], &sharp.materials[0]);
    assert!(s.ks > 0.0 && h.ks > s.ks && h.shine > s.shine);
    // Blender: roughness 1 − √(Ns/1000).
    assert!((s.ks - 0.5 * 0.1f32.sqrt()).abs() < 1e-6, "{}", s.ks);
}

#[test]
fn metallic_roughness_texture_scales_the_factors_by_its_mean() {
    let dir = tempfile::tempdir().unwrap();
    // Blue (metallic) 0, green (roughness) 0.5: a smooth-ish dielectric,
    // whatever the factors of 1 say alone (a fully rough metal).
    png(
        &dir.path().join("mr.png"),
        2,
        1,
        &[[0, 128, 0], [0, 128, 0]],
    );
    let file = gltf_quad(
        dir.path(),
        json!({"pbrMetallicRoughness": {"baseColorFactor": [1, 0, 0, 1],
               "metallicFactor": 1.0, "roughnessFactor": 1.0,
               "metallicRoughnessTexture": {"index": 0}}}),
        &["mr.png"],
    );
    let m = &load(&file).materials[0];
    assert_eq!(
        m.specular_color,
        Color::ONE,
        "a dielectric's highlight is white"
    );
    assert!(m.ks > 0.0 && m.kd > 0.9, "{m:?}");
}

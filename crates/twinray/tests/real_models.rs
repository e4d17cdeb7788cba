//! Real files written by other tools (tests/data/models/README.md): pybullet's
//! textured torus as Blender wrote it, and obj2gltf's .glb and .gltf of it.

mod common;

use std::path::PathBuf;

use common::*;
use twinray::loaders::{load_scene, LoadOptions};
use twinray::{Scene, World};

fn model(name: &str) -> Scene {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/models")
        .join(name);
    load_scene(&path, &LoadOptions::default()).expect("real model loads")
}

fn render(mut scene: Scene) -> Vec<[u32; 3]> {
    scene.add_headlight_if_dark();
    let img = mono(&World::new(scene), 40, 30);
    (0..30)
        .flat_map(|y| (0..40).map(move |x| (x, y)))
        .map(|(x, y)| img.get(x, y).to_array().map(f32::to_bits))
        .collect()
}

#[test]
fn blender_torus_obj_loads_with_its_texture() {
    let s = model("pybullet/torus/torus_textured.obj");
    assert_eq!(s.shapes.len(), 1002, "1002 triangles in the file");
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert_eq!(s.textures.len(), 1, "map_Kd ../cube.png");
    assert_eq!((s.textures[0].width, s.textures[0].height), (256, 256));
    let m = &s.materials[0];
    // Blender wrote `Ks 0.8` with `Ns 0`: a fully rough surface, no
    // highlight (as a Phong exponent of 0, it whitened the whole torus).
    assert_eq!((m.texture, m.kd, m.ks, m.mirror), (Some(0), 0.8, 0.0, 0.0));
    assert!(
        !s.corners.is_empty()
            && s.corners
                .iter()
                .all(|c| c.normals.is_some() && c.uv.is_some())
    );
}

#[test]
fn obj2gltf_glb_and_gltf_hold_the_same_torus() {
    let obj = model("pybullet/torus/torus_textured.obj");
    let glb = model("gltf/torus.glb");
    let gltf = model("gltf/torus.gltf");
    for s in [&glb, &gltf] {
        assert_eq!(s.shapes.len(), obj.shapes.len());
        assert!(s.warnings.is_empty(), "{:?}", s.warnings);
        assert_eq!(s.textures.len(), 1);
        let (a, b) = (s.bounds(), obj.bounds());
        assert!((a.min - b.min).abs().max_element() < 1e-5, "{a:?} {b:?}");
        assert!((a.max - b.max).abs().max_element() < 1e-5, "{a:?} {b:?}");
    }
    // The same data in two containers renders the same, bit for bit.
    assert!(render(glb) == render(gltf));
}

#[test]
fn the_texture_shows_in_the_render() {
    let textured = model("gltf/torus.glb");
    let mut plain = textured.clone();
    plain.materials[0].texture = None;
    let (a, b) = (render(textured), render(plain));
    let background = a[0];
    let torus = a.iter().filter(|&&p| p != background).count();
    assert!(
        torus > 100,
        "the framed torus is in the image: {torus} pixels"
    );
    let differing = a.iter().zip(&b).filter(|(p, q)| p != q).count();
    assert!(
        differing > torus / 2,
        "{differing} of {torus} pixels change"
    );
}

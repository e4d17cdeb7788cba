//! Real files written by other tools (tests/data/models/README.md): pybullet's
//! textured torus as Blender wrote it, and obj2gltf's .glb and .gltf of it.

use crate::common;

use std::path::PathBuf;

use common::*;
use twinray::loaders::{load_scene, LoadOptions};
use twinray::{Scene, World};

fn models() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/models")
}

/// The model `name`, which may read the files of `tests/data/models` (the
/// torus's MTL names `../cube.png`, beside its own folder).
fn model(name: &str) -> Scene {
    let opts = LoadOptions {
        allow_dirs: vec![models()],
        ..LoadOptions::default()
    };
    load_scene(&models().join(name), &opts).expect("real model loads")
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

/// Without `--allow-dir`, the texture beside the model's folder is not
/// read: a warning says so, and the material keeps its colour.
#[test]
fn a_texture_outside_the_models_folder_needs_its_folder_allowed() {
    let path = models().join("pybullet/torus/torus_textured.obj");
    let s = load_scene(&path, &LoadOptions::default()).expect("loads");
    assert!(s.textures.is_empty());
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    let w = &s.warnings[0];
    assert!(
        w.contains("texture '../cube.png' is outside the scene's folder")
            && w.contains("--allow-dir"),
        "{w}"
    );
    assert_eq!(s.shapes.len(), 1002);
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

#[test]
fn webxr_hand_renders_with_shading_that_reads() {
    use twinray::job::{CancelToken, Job, JobSpec};
    let path = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/models/webxr/generic-hand-left.glb");
    let dir = tempfile::tempdir().unwrap();
    let mut spec = JobSpec::new(&path, dir.path().join("hand.png"));
    spec.camera.size = Some([64, 48]);
    spec.sampling.samples = Some(1);
    let job = Job::check(spec).unwrap();
    let loaded = job.load().unwrap();
    assert!(
        loaded.scene.warnings.is_empty(),
        "{:?}",
        loaded.scene.warnings
    );
    assert!(loaded.scene.shapes.len() > 1000);
    let plan = job.plan(&loaded).unwrap();
    let out = job.render(&plan, &|_, _| {}, &CancelToken::new()).unwrap();
    // The hand's pixels: many, and not one flat shade (std of luma > 0.02).
    let luma: Vec<f32> = out.output.images[0]
        .pixels
        .iter()
        .filter(|c| c.max_element() > 0.0)
        .map(|c| 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z)
        .collect();
    assert!(luma.len() > 200, "{} pixels", luma.len());
    let mean = luma.iter().sum::<f32>() / luma.len() as f32;
    let var = luma.iter().map(|l| (l - mean).powi(2)).sum::<f32>() / luma.len() as f32;
    assert!(var.sqrt() > 0.02, "flat: mean {mean}, std {}", var.sqrt());
}

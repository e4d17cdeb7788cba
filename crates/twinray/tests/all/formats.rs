//! The same geometry given as NFF, OBJ and glTF renders to the same image,
//! bit for bit, where the materials mean the same.

use crate::common;

use std::fmt::Write as _;
use std::path::Path;

use base64::Engine as _;
use common::*;
use serde_json::json;
use twinray::loaders::nff::parse_nff;
use twinray::loaders::{load_scene, LoadOptions};
use twinray::render::{Sampling, ViewMethod};
use twinray::rig::Rig;
use twinray::{Scene, World};

/// A floor, a box and a smooth-shaded triangle.
struct Model {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    /// Triangles: vertex indices and material (0 or 1).
    triangles: Vec<([u32; 3], usize)>,
}

fn model() -> Model {
    let mut positions = vec![
        [-4.0, 0.0, -4.0],
        [4.0, 0.0, -4.0],
        [4.0, 0.0, 4.0],
        [-4.0, 0.0, 4.0],
    ];
    let mut triangles = vec![([0, 2, 1], 0), ([0, 3, 2], 0)];
    // A box from (-1, 0, -1) to (1, 1.5, 1), turned a little.
    let (c, s) = (0.5f32.cos(), 0.5f32.sin());
    for k in 0..8u32 {
        let x = if k & 1 == 0 { -1.0 } else { 1.0 };
        let y = if k & 2 == 0 { 0.0 } else { 1.5 };
        let z = if k & 4 == 0 { -1.0 } else { 1.0 };
        positions.push([c * x - s * z - 0.5, y, s * x + c * z]);
    }
    for [a, b, cc, d] in [
        [0, 1, 3, 2],
        [4, 6, 7, 5],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 5, 7, 3],
    ] {
        triangles.push(([4 + a, 4 + b, 4 + cc], 1));
        triangles.push(([4 + a, 4 + cc, 4 + d], 1));
    }
    // A smooth triangle with bent normals.
    positions.extend([[1.5, 0.2, 1.0], [3.0, 0.2, 1.5], [2.0, 2.0, 0.5]]);
    triangles.push(([12, 13, 14], 1));
    let mut normals = vec![[0.0, 1.0, 0.0]; 12];
    normals.extend([[-0.3, 0.2, 1.0], [0.4, 0.1, 1.0], [0.0, 0.6, 0.8]]);
    Model {
        positions,
        normals,
        triangles,
    }
}

const VIEW: &str = "v\nfrom 1 5 9\nat 0 0.5 0\nup 0 1 0\nangle 40\nhither 0.01\nresolution 48 36\n\
                    b 0.1 0.2 0.3\nl -3 8 6\n";

/// NFF: triangles, the smooth one as a patch.
fn as_nff(m: &Model, materials: [&str; 2]) -> String {
    let mut out = VIEW.to_string();
    let mut current = usize::MAX;
    for (tri, mat) in &m.triangles {
        if *mat != current {
            writeln!(out, "f {}", materials[*mat]).unwrap();
            current = *mat;
        }
        let smooth = tri[0] >= 12;
        writeln!(out, "{} 3", if smooth { "pp" } else { "p" }).unwrap();
        for &i in tri {
            let [x, y, z] = m.positions[i as usize];
            let [a, b, c] = m.normals[i as usize];
            if smooth {
                writeln!(out, "{x} {y} {z} {a} {b} {c}").unwrap();
            } else {
                writeln!(out, "{x} {y} {z}").unwrap();
            }
        }
    }
    out
}

fn as_obj(m: &Model) -> String {
    let mut out = "mtllib m.mtl\n".to_string();
    for [x, y, z] in &m.positions {
        writeln!(out, "v {x} {y} {z}").unwrap();
    }
    for [x, y, z] in &m.normals {
        writeln!(out, "vn {x} {y} {z}").unwrap();
    }
    for (tri, mat) in &m.triangles {
        writeln!(out, "usemtl m{mat}").unwrap();
        let [a, b, c] = tri.map(|i| i + 1);
        if tri[0] >= 12 {
            writeln!(out, "f {a}//{a} {b}//{b} {c}//{c}").unwrap();
        } else {
            writeln!(out, "f {a} {b} {c}").unwrap();
        }
    }
    out
}

/// glTF: the flat triangles in one primitive per material, the smooth one in
/// its own with NORMAL; one data-URI buffer.
fn as_gltf(m: &Model, materials: serde_json::Value) -> String {
    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut accessors = Vec::new();
    let mut push = |bytes: Vec<u8>, count: usize, kind: &str, component: u32| {
        views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len()}));
        let mut a = json!({"bufferView": views.len() - 1, "componentType": component,
                           "count": count, "type": kind});
        if kind == "VEC3" && accessors.is_empty() {
            a["min"] = json!([-10, -10, -10]);
            a["max"] = json!([10, 10, 10]);
        }
        accessors.push(a);
        bin.extend(bytes);
        accessors.len() - 1
    };
    let floats = |v: &[[f32; 3]]| v.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
    let pos = push(floats(&m.positions), m.positions.len(), "VEC3", 5126);
    let nor = push(floats(&m.normals), m.normals.len(), "VEC3", 5126);
    let mut primitives = Vec::new();
    for (mat, smooth) in [(0, false), (1, false), (1, true)] {
        let idx: Vec<u32> = m
            .triangles
            .iter()
            .filter(|(t, mm)| *mm == mat && (t[0] >= 12) == smooth)
            .flat_map(|(t, _)| *t)
            .collect();
        if idx.is_empty() {
            continue;
        }
        let bytes = idx.iter().flat_map(|i| i.to_le_bytes()).collect();
        let a = push(bytes, idx.len(), "SCALAR", 5125);
        let mut attributes = json!({"POSITION": pos});
        if smooth {
            attributes["NORMAL"] = json!(nor);
        }
        primitives.push(json!({"attributes": attributes, "indices": a, "material": mat}));
    }
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&bin)
    );
    json!({
        "asset": {"version": "2.0"},
        "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": primitives}],
        "materials": materials,
        "buffers": [{"byteLength": bin.len(), "uri": uri}],
        "bufferViews": views,
        "accessors": accessors
    })
    .to_string()
}

fn render_bits(scene: Scene, method: ViewMethod, views: usize) -> Vec<Vec<u32>> {
    let world = World::new(scene);
    let cam = camera(&world, 48, 36);
    let rig = if views == 1 {
        Rig::mono()
    } else {
        Rig::multi_view(&cam, views, 0.3, Some(default_convergence(&world))).expect("rig")
    };
    let out = run(&world, &cam, &rig, &options(method, Sampling::Centers));
    out.images
        .iter()
        .map(|img| {
            (0..36)
                .flat_map(|y| (0..48).map(move |x| (x, y)))
                .flat_map(|(x, y)| img.get(x, y).to_array().map(f32::to_bits))
                .collect()
        })
        .collect()
}

/// The other format's scene with NFF's camera, light and background (OBJ and
/// glTF files here carry none).
fn with_view_of(mut s: Scene, nff: &Scene) -> Scene {
    s.viewpoint = nff.viewpoint.clone();
    s.lights = nff.lights.clone();
    s.background = nff.background;
    s
}

fn load(dir: &Path, name: &str, text: &str) -> Scene {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    load_scene(&path, &LoadOptions::default()).expect("loads")
}

#[test]
fn matte_model_as_nff_obj_and_gltf_renders_the_same() {
    let m = model();
    let nff_text = as_nff(&m, ["1 0 0 1 0 0 0 1", "0.25 0.5 1 1 0 0 0 1"]);
    let nff = parse_nff(&nff_text, Path::new("m.nff"), &LoadOptions::default()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("m.mtl"),
        "newmtl m0\nKd 1 0 0\nKs 0 0 0\nillum 1\nnewmtl m1\nKd 0.25 0.5 1\nillum 1\n",
    )
    .unwrap();
    let obj = with_view_of(load(dir.path(), "m.obj", &as_obj(&m)), &nff);
    let pbr = |c: [f32; 3]| {
        json!({"pbrMetallicRoughness": {"baseColorFactor": [c[0], c[1], c[2], 1.0],
                                        "metallicFactor": 0.0, "roughnessFactor": 1.0}})
    };
    let gltf_text = as_gltf(&m, json!([pbr([1.0, 0.0, 0.0]), pbr([0.25, 0.5, 1.0])]));
    let gltf = with_view_of(load(dir.path(), "m.gltf", &gltf_text), &nff);
    assert_eq!(obj.shapes.len(), nff.shapes.len());
    assert_eq!(gltf.shapes.len(), nff.shapes.len());

    let reference = render_bits(nff.clone(), ViewMethod::Independent, 1);
    let lit = reference[0]
        .chunks(3)
        .filter(|p| p.iter().any(|&b| b != 0))
        .count();
    assert!(lit > 48 * 36 / 2, "the model fills the image");
    assert!(
        reference == render_bits(obj, ViewMethod::Independent, 1),
        "OBJ differs from NFF"
    );
    assert!(
        reference == render_bits(gltf.clone(), ViewMethod::Independent, 1),
        "glTF differs from NFF"
    );
    assert!(
        render_bits(nff, ViewMethod::twin(), 2) == render_bits(gltf, ViewMethod::twin(), 2),
        "stereo pairs differ"
    );
}

#[test]
fn mirror_and_glass_as_nff_and_obj_render_the_same() {
    let m = model();
    // Kd 0.5 splits into colour (1, 0.5, 0.25) and kd 0.5; Ks 0.3 with illum 7
    // is highlight and mirror, at their full weight and the largest exponent
    // for Ns 1000 (roughness 0 as Blender reads Ns); d 0.75 is T 0.25.
    let nff_text = as_nff(
        &m,
        ["1 0.5 0.25 0.5 0.3 10000 0.25 1.5", "0.25 0.5 1 1 0 0 0 1"],
    );
    let nff = parse_nff(&nff_text, Path::new("m.nff"), &LoadOptions::default()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("m.mtl"),
        "newmtl m0\nKd 0.5 0.25 0.125\nKs 0.3 0.3 0.3\nNs 1000\nd 0.75\nNi 1.5\nillum 7\n\
         newmtl m1\nKd 0.25 0.5 1\nillum 1\n",
    )
    .unwrap();
    let obj = with_view_of(load(dir.path(), "m.obj", &as_obj(&m)), &nff);
    assert_eq!(obj.materials[0], nff.materials[0]);
    assert!(
        render_bits(nff, ViewMethod::Independent, 1)
            == render_bits(obj, ViewMethod::Independent, 1),
        "OBJ differs from NFF"
    );
}

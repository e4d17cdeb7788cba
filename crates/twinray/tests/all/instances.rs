//! An animated glTF file's frames through the two-level hierarchy: the file
//! read once, the nodes that did not move kept (their triangles and their
//! trees), only the moving node's triangles made and built again, and each
//! frame's image equal, bit for bit, to a still of a fresh load at the
//! frame's time, whose hierarchy is built whole.

use std::path::{Path, PathBuf};

use base64::Engine as _;
use serde_json::{json, Value};
use twinray::animation::Animation;
use twinray::job::{CancelToken, Job, JobSpec};
use twinray::loaders::gltf::{parse_gltf, GltfFile};
use twinray::loaders::LoadOptions;
use twinray::scene::Scene;

/// A glTF document and its one buffer, built up accessor by accessor.
#[derive(Default)]
struct Doc {
    bytes: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Doc {
    fn floats(&mut self, data: &[f32], kind: &str) -> usize {
        let width = match kind {
            "SCALAR" => 1,
            "VEC3" => 3,
            _ => 4,
        };
        let offset = self.bytes.len();
        self.bytes.extend(data.iter().flat_map(|f| f.to_le_bytes()));
        self.views
            .push(json!({"buffer": 0, "byteOffset": offset, "byteLength": data.len() * 4}));
        let (mut min, mut max) = (vec![f32::MAX; width], vec![f32::MIN; width]);
        for c in data.chunks(width) {
            for k in 0..width {
                min[k] = min[k].min(c[k]);
                max[k] = max[k].max(c[k]);
            }
        }
        self.accessors.push(
            json!({"bufferView": self.views.len() - 1, "componentType": 5126,
            "count": data.len() / width, "type": kind, "min": min, "max": max}),
        );
        self.accessors.len() - 1
    }

    fn indices(&mut self, data: &[u32]) -> usize {
        let offset = self.bytes.len();
        self.bytes.extend(data.iter().flat_map(|i| i.to_le_bytes()));
        self.views
            .push(json!({"buffer": 0, "byteOffset": offset, "byteLength": data.len() * 4}));
        self.accessors.push(
            json!({"bufferView": self.views.len() - 1, "componentType": 5125,
            "count": data.len(), "type": "SCALAR"}),
        );
        self.accessors.len() - 1
    }
}

/// A height field of `n` x `n` cells over [-4, 4]^2 (y up), two triangles
/// a cell, flat shaded.
fn terrain(doc: &mut Doc, n: u32) -> Value {
    let mut pos = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (x, z) = (
                i as f32 / n as f32 * 8.0 - 4.0,
                j as f32 / n as f32 * 8.0 - 4.0,
            );
            pos.extend([x, 0.3 * (x * 0.9).sin() * (z * 0.7).cos(), z]);
        }
    }
    let w = n + 1;
    let mut idx = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let a = j * w + i;
            idx.extend([a, a + w, a + 1, a + 1, a + w, a + w + 1]);
        }
    }
    let p = doc.floats(&pos, "VEC3");
    let i = doc.indices(&idx);
    json!({"primitives": [{"attributes": {"POSITION": p}, "indices": i, "material": 0}]})
}

/// A cube of half-side 0.4 with smooth normals (per-corner attributes).
fn cube(doc: &mut Doc) -> Value {
    let mut pos = Vec::new();
    let mut nor = Vec::new();
    for k in 0..8 {
        let c = [k & 1, (k >> 1) & 1, (k >> 2) & 1].map(|b| if b == 1 { 0.4f32 } else { -0.4 });
        pos.extend(c);
        nor.extend(c.map(|v| v / (3.0f32 * 0.16).sqrt()));
    }
    let idx = [
        0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6,
        1, 3, 5, 3, 7, 5,
    ];
    let p = doc.floats(&pos, "VEC3");
    let n = doc.floats(&nor, "VEC3");
    let i = doc.indices(&idx);
    json!({"primitives": [{"attributes": {"POSITION": p, "NORMAL": n}, "indices": i, "material": 1}]})
}

const TERRAIN_CELLS: u32 = 16;
const CUBE_TRIANGLES: usize = 12;

/// Terrain (node 0), a still cube (node 1), a cube sliding along x over
/// one second and shrinking to nothing by the second second (node 2), and
/// another still cube (node 3), after the moving one in the walk.
fn animated_scene() -> Value {
    let mut doc = Doc::default();
    let meshes = vec![terrain(&mut doc, TERRAIN_CELLS), cube(&mut doc)];
    let times = doc.floats(&[0.0, 1.0, 2.0], "SCALAR");
    let slide = doc.floats(&[-2.0, 0.9, 0.0, 2.0, 0.9, 0.5, 2.0, 0.9, 0.5], "VEC3");
    let shrink = doc.floats(&[1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0], "VEC3");
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&doc.bytes)
    );
    json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 3]}],
        "nodes": [
            {"mesh": 0, "name": "terrain"},
            {"mesh": 1, "name": "still", "translation": [1.5, 0.9, -1.5]},
            {"mesh": 1, "name": "moving"},
            {"mesh": 1, "name": "still too", "translation": [-1.5, 0.9, 1.5], "rotation": [0.0, 0.38268343, 0.0, 0.9238795]}
        ],
        "meshes": meshes,
        "materials": [
            {"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.6, 0.3, 1], "metallicFactor": 0, "roughnessFactor": 1}},
            {"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.2, 0.2, 1], "metallicFactor": 0, "roughnessFactor": 0.4}}
        ],
        "buffers": [{"byteLength": doc.bytes.len(), "uri": uri}],
        "bufferViews": doc.views,
        "accessors": doc.accessors,
        "animations": [{
            "name": "slide",
            "samplers": [
                {"input": times, "output": slide, "interpolation": "LINEAR"},
                {"input": times, "output": shrink, "interpolation": "LINEAR"}
            ],
            "channels": [
                {"sampler": 0, "target": {"node": 2, "path": "translation"}},
                {"sampler": 1, "target": {"node": 2, "path": "scale"}}
            ]
        }]
    })
}

fn write_scene(dir: &Path) -> PathBuf {
    let path = dir.join("animated.gltf");
    std::fs::write(&path, animated_scene().to_string()).unwrap();
    path
}

/// The first place two lists differ, for a readable failure.
fn assert_same<T: PartialEq + std::fmt::Debug>(a: &[T], b: &[T], what: &str) {
    assert_eq!(a.len(), b.len(), "{what}: lengths");
    if let Some(i) = (0..a.len()).find(|&i| a[i] != b[i]) {
        panic!("{what}: element {i}: {:?} != {:?}", a[i], b[i]);
    }
}

/// Every part of a scene the renderer reads.
fn assert_same_scene(a: &Scene, b: &Scene, what: &str) {
    assert_same(&a.shapes, &b.shapes, &format!("{what}: shapes"));
    assert_same(
        &a.shape_material,
        &b.shape_material,
        &format!("{what}: materials"),
    );
    assert_same(&a.shape_group, &b.shape_group, &format!("{what}: groups"));
    assert_same(&a.corners, &b.corners, &format!("{what}: corners"));
    assert_eq!(a.warnings, b.warnings, "{what}: warnings");
    assert_eq!(a.materials, b.materials, "{what}: material table");
    assert_eq!(a.lights, b.lights, "{what}: lights");
    assert_eq!(a.cameras, b.cameras, "{what}: cameras");
    assert_eq!(a.viewpoint, b.viewpoint, "{what}: viewpoint");
}

#[test]
fn a_posed_scene_equals_a_fresh_load_at_its_time() {
    let bytes = animated_scene().to_string();
    let file = Path::new("animated.gltf");
    let opts = LoadOptions::default();
    let gltf = GltfFile::read(bytes.as_bytes(), file, &opts).unwrap();
    // In an order that moves the cube, keeps it, shrinks it to nothing (its
    // triangles skipped with warnings: the still cube after it moves down the
    // shape and corner tables) and brings it back.
    let mut previous = None;
    let mut made = Vec::new();
    for time in [0.0, 0.5, 0.5, 2.0, 2.5, 0.25, 1.0] {
        let posed = gltf
            .pose(
                Some(time),
                previous
                    .as_ref()
                    .map(|(s, p): &(Scene, Vec<_>)| (s, &p[..])),
            )
            .unwrap();
        let fresh = parse_gltf(
            bytes.as_bytes(),
            file,
            &LoadOptions {
                animation_time: Some(time),
                ..LoadOptions::default()
            },
        )
        .unwrap();
        assert_same_scene(&posed.scene, &fresh, &format!("time {time}"));
        made.push(posed.made_triangles);
        previous = Some((posed.scene, posed.instances));
    }
    let all = (2 * TERRAIN_CELLS * TERRAIN_CELLS) as usize + 3 * CUBE_TRIANGLES;
    // First pose: everything; then only the moving cube (none of it while it
    // is shrunk to nothing; nothing at all when the time is the same, or when
    // it stays shrunk: 2.0 and 2.5 both hold the last key).
    assert_eq!(
        made,
        [all, CUBE_TRIANGLES, 0, 0, 0, CUBE_TRIANGLES, CUBE_TRIANGLES]
    );
    assert!(previous.unwrap().0.warnings.is_empty());
}

fn spec(scene: &Path, output: &Path) -> JobSpec {
    let mut spec = JobSpec::new(scene, output);
    spec.camera.size = Some([64, 48]);
    spec.camera.from = Some([0.5, 5.0, 7.0]);
    spec.camera.at = Some([0.0, 0.0, 0.0]);
    spec.rig.stereo = true;
    spec.rig.interaxial = Some("0.2".into());
    spec.rig.convergence = Some("6".into());
    spec.sampling.samples = Some(1);
    spec
}

#[test]
fn only_the_moving_node_is_built_again() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(dir.path());
    let mut s = spec(&scene, &dir.path().join("f.png"));
    s.animation.frames = Some("0..7".into());
    s.animation.fps = 4.0;
    let animation = Animation::check(s).unwrap();
    let counts = |frame: u32| {
        let loaded = animation.loaded_at(frame).unwrap().expect("animated");
        loaded
            .built_world()
            .and_then(|w| w.instances)
            .expect("a two-level hierarchy")
    };
    let terrain = (2 * TERRAIN_CELLS * TERRAIN_CELLS) as usize;
    let all = terrain + 3 * CUBE_TRIANGLES;
    let first = counts(0);
    assert_eq!(
        (first.instances, first.rebuilt_instances),
        (4, 4),
        "{first:?}"
    );
    assert_eq!(
        (
            first.primitives,
            first.rebuilt_primitives,
            first.made_primitives
        ),
        (all, all, all)
    );
    for frame in 1..4 {
        let c = counts(frame);
        assert_eq!(c.instances, 4);
        assert_eq!(c.rebuilt_instances, 1, "frame {frame}: {c:?}");
        assert_eq!(c.rebuilt_primitives, CUBE_TRIANGLES, "frame {frame}");
        assert_eq!(c.made_primitives, CUBE_TRIANGLES, "frame {frame}");
    }
    // The same frame again: nothing moved.
    let again = counts(3);
    assert_eq!((again.rebuilt_instances, again.made_primitives), (0, 0));
}

#[test]
fn frames_equal_stills_of_a_fresh_load_at_their_time() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(dir.path());
    let mut s = spec(&scene, &dir.path().join("f_####.png"));
    s.animation.frames = Some("0..5".into());
    s.animation.fps = 4.0;
    s.output.layout = twinray::job::LayoutSpec::Sbs;
    let animation = Animation::check(s).unwrap();
    let loaded = animation.load().unwrap();
    let mut written = Vec::new();
    animation
        .run(
            &loaded,
            &|_| {},
            &mut |r| written.push((r.frame, r.written)),
            &CancelToken::new(),
        )
        .unwrap();
    assert_eq!(written.len(), 6);
    let mut differ = 0;
    for (frame, files) in written {
        // The still: the frame's spec, the file read afresh at the frame's
        // time, its hierarchy built whole.
        let own = animation.loaded_at(frame).unwrap().unwrap();
        let mut still = animation.frame_spec(&own, frame, None).unwrap();
        still.output.path = dir.path().join(format!("still_{frame}.png"));
        let job = Job::check(still).unwrap();
        let fresh = job.load_at(Some(frame as f32 / 4.0)).unwrap();
        let plan = job.plan(&fresh).unwrap();
        assert!(plan.world.instances.is_none(), "a whole build");
        let rendered = job.render(&plan, &|_, _| {}, &CancelToken::new()).unwrap();
        let stills = job.write(&fresh, &plan, &rendered).unwrap();
        assert_eq!(files.len(), stills.len());
        for (a, b) in files.iter().zip(&stills) {
            let (a, b) = (std::fs::read(a).unwrap(), std::fs::read(b).unwrap());
            assert!(
                a == b,
                "frame {frame}: {} differs from the still",
                files[0].display()
            );
        }
        if frame > 0 {
            let prev = dir.path().join(format!("f_{:04}.png", frame - 1));
            differ +=
                usize::from(std::fs::read(prev).unwrap() != std::fs::read(&files[0]).unwrap());
        }
    }
    assert!(differ >= 4, "the cube moves: frames differ ({differ})");
}

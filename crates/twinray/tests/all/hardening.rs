//! Regression tests of the attacks on twinray: pathological scenes that
//! crashed it or gave silently wrong pixels, and scene files that read
//! files they should not, took memory without counting it, or brought
//! infinite light. Each scene is generated here and rendered small.

use crate::common;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use twinray::loaders::nff::parse_nff;
use twinray::loaders::{load_scene, LoadOptions};
use twinray::render::{render, RenderOptions, Sampling, TraceSettings, ViewMethod, MAX_DEPTH};
use twinray::rig::Camera;
use twinray::rig::Rig;
use twinray::{Image, World};

fn world(nff: &str) -> World {
    let scene = parse_nff(nff, Path::new("generated.nff"), &LoadOptions::default())
        .expect("generated scene parses");
    World::new(scene)
}

fn render_views(world: &World, views: usize, method: ViewMethod, max_depth: u32) -> Vec<Image> {
    let vp = &world.scene.viewpoint;
    let camera = Camera::new(vp, vp.width, vp.height);
    let rig = if views == 1 {
        Rig::mono()
    } else {
        Rig::multi_view(&camera, views, 0.001, None).expect("rig")
    };
    let opts = RenderOptions {
        trace: TraceSettings {
            max_depth,
            ..TraceSettings::default()
        },
        method,
        sampling: Sampling::Centers,
        ..RenderOptions::default()
    };
    render(world, &camera, &rig, &opts, &|_, _| {})
        .expect("render")
        .images
}

const VIEW_DOWN: &str =
    "v\nfrom 0 0 3\nat 0 0 0\nup 0 1 0\nangle 45\nhither 0\nresolution 32 32\nb 0.5 0.5 0.5\n";

/// A closed box of mirrors with the camera and a light inside.
fn mirror_box() -> String {
    let mut s = String::from(
        "v\nfrom 0 0 0\nat 0 1 0\nup 0 0 1\nangle 60\nhither 0\nresolution 8 6\n\
         l 0 0 0.5\nf 1 1 1 0 1 50 0 1\n",
    );
    let faces = [
        [[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1]],
        [[-1, -1, 1], [-1, 1, 1], [1, 1, 1], [1, -1, 1]],
        [[-1, -1, -1], [-1, 1, -1], [-1, 1, 1], [-1, -1, 1]],
        [[1, -1, -1], [1, -1, 1], [1, 1, 1], [1, 1, -1]],
        [[-1, -1, -1], [-1, -1, 1], [1, -1, 1], [1, -1, -1]],
        [[-1, 1, -1], [1, 1, -1], [1, 1, 1], [-1, 1, 1]],
    ];
    for face in faces {
        s.push_str("p 4\n");
        for [x, y, z] in face {
            let _ = writeln!(s, "{x} {y} {z}");
        }
    }
    s
}

#[test]
fn mirror_box_at_the_depth_cap_does_not_overflow_the_stack() {
    // The attack: --max-depth 1693 and up aborted with a stack overflow (32
    // views: from about 180). The cap is checked, and the deepest accepted
    // depth runs on the default worker stacks for 1, 2 and 32 views.
    let world = world(&mirror_box());
    for views in [1, 2, 32] {
        let images = render_views(&world, views, ViewMethod::twin(), MAX_DEPTH);
        assert_eq!(images.len(), views);
    }
    let vp = &world.scene.viewpoint;
    let camera = Camera::new(vp, vp.width, vp.height);
    for max_depth in [0, MAX_DEPTH + 1, u32::MAX] {
        let opts = RenderOptions {
            trace: TraceSettings {
                max_depth,
                ..TraceSettings::default()
            },
            ..RenderOptions::default()
        };
        let err = render(&world, &camera, &Rig::mono(), &opts, &|_, _| {})
            .err()
            .expect("refused");
        assert!(err.to_string().contains("between 1"), "{err}");
    }
}

/// `count` spheres of transmission `t` stacked on the shadow ray from the
/// floor point the camera looks at (the image centre) to the light above it;
/// the camera sees that point past them.
fn glass_stack(count: usize, t: f32) -> String {
    let mut s = String::from(
        "v\nfrom 0 -6 3\nat 0 0 0\nup 0 0 1\nangle 30\nhither 0\nresolution 33 33\n\
         l 0 0 60\nf 1 1 1 1 0 0 0 1\np 4\n-3 -3 0\n3 -3 0\n3 3 0\n-3 3 0\n",
    );
    let _ = writeln!(s, "f 1 1 1 0 0 0 {t} 1");
    for i in 0..count {
        let _ = writeln!(s, "s 0 0 {} 0.2", 1.0 + 2.0 * i as f32);
    }
    s
}

#[test]
fn shadow_transmittance_keeps_multiplying_past_sixteen_objects() {
    // The attack: 17 spheres with T = 1 between a floor and its light gave a
    // black shadow (the product stopped at 16 factors).
    let centre =
        |nff: &str| render_views(&world(nff), 1, ViewMethod::Independent, 5)[0].get(16, 16);
    let lit = centre(&glass_stack(0, 1.0));
    assert!(lit.x > 0.5, "{lit}");
    assert_eq!(centre(&glass_stack(17, 1.0)), lit);
    let dimmed = centre(&glass_stack(20, 0.9));
    let expected = lit.x * 0.9f32.powi(20);
    assert!((dimmed.x - expected).abs() < 1e-5, "{dimmed} vs {expected}");
    // Past 16 factors the product is still independent of the traversal
    // order: the twin method's packets give the same bits.
    let world = world(&glass_stack(20, 0.9));
    let independent = render_views(&world, 2, ViewMethod::Independent, 5);
    let twin = render_views(&world, 2, ViewMethod::twin(), 5);
    assert_eq!(independent, twin);
}

/// A regular `n`-gon in the plane z = 0 (or tilted), lit from above.
fn regular_polygon(n: usize, tilt: f32) -> String {
    let mut s = format!("{VIEW_DOWN}l 0.3 0.2 5\nf 1 1 1 1 0 0 0 1\np {n}\n");
    for i in 0..n {
        let a = std::f64::consts::TAU * i as f64 / n as f64;
        let (x, y) = (a.cos() as f32, a.sin() as f32);
        let _ = writeln!(s, "{x} {y} {}", x * tilt);
    }
    s
}

/// Pixels of the polygon (not background) that are black: in its own shadow.
fn self_shadowed(images: &[Image]) -> (usize, usize) {
    let polygon: Vec<_> = images[0]
        .pixels
        .iter()
        .filter(|c| (c.x - 0.5).abs() > 1e-6)
        .collect();
    let black = polygon.iter().filter(|c| c.x == 0.0).count();
    (black, polygon.len())
}

#[test]
fn many_vertex_flat_polygons_do_not_shadow_themselves() {
    // The attack: a regular 2000-gon lit from above had 6 % of its pixels in
    // its own shadow, 39 % at 20,000 vertices (thin slivers of the
    // triangulation "hit" behind the shadow ray's origin).
    for n in [2000, 20_000] {
        for tilt in [0.0, 0.3] {
            let world = world(&regular_polygon(n, tilt));
            let independent = render_views(&world, 1, ViewMethod::Independent, 5);
            let (black, total) = self_shadowed(&independent);
            assert!(total > 400, "{n}-gon covers {total} pixels");
            assert_eq!(
                black, 0,
                "{n}-gon tilt {tilt}: {black} of {total} pixels self-shadowed"
            );
            let pair_independent = render_views(&world, 2, ViewMethod::Independent, 5);
            let pair_twin = render_views(&world, 2, ViewMethod::twin(), 5);
            assert_eq!(pair_independent, pair_twin, "{n}-gon: twin = independent");
        }
    }
}

// ---------------------------------------------------------------------------
// The files a scene names: confined to its folder, regular, bounded.

/// A scene folder `root/scene` and a secret beside it, `root/secret/x.png`
/// (a red image: if it is read, the render shows it).
struct Tree {
    root: tempfile::TempDir,
}

impl Tree {
    fn new() -> Tree {
        let root = tempfile::tempdir().expect("tmp");
        std::fs::create_dir_all(root.path().join("scene")).unwrap();
        std::fs::create_dir_all(root.path().join("secret")).unwrap();
        red_png(&root.path().join("secret/x.png"));
        Tree { root }
    }

    fn scene(&self) -> PathBuf {
        self.root.path().join("scene")
    }

    fn secret(&self) -> PathBuf {
        self.root.path().join("secret")
    }
}

fn red_png(path: &Path) {
    image::RgbImage::from_pixel(4, 4, image::Rgb([255, 0, 0]))
        .save(path)
        .unwrap();
}

fn load(path: &Path) -> twinray::Result<twinray::Scene> {
    load_scene(path, &LoadOptions::default())
}

fn load_allowing(path: &Path, dirs: &[PathBuf]) -> twinray::Result<twinray::Scene> {
    load_scene(
        path,
        &LoadOptions {
            allow_dirs: dirs.to_vec(),
            ..LoadOptions::default()
        },
    )
}

/// The attack: glTF image URIs of `../secret/x.png`, `%2E%2E/...` and an
/// absolute path were read, and the outside image showed in the render.
#[test]
fn gltf_images_outside_the_scenes_folder_are_not_read() {
    let tree = Tree::new();
    let secret = tree.secret().join("x.png");
    let material = serde_json::json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}});
    for uri in [
        "../secret/x.png".to_string(),
        "%2E%2E/secret/x.png".to_string(),
        "%2e%2e%2Fsecret%2Fx.png".to_string(),
        "..\\secret\\x.png".to_string(),
        secret.display().to_string(),
    ] {
        let path = common::gltf_quad(&tree.scene(), material.clone(), &[&uri]);
        let scene = load(&path).unwrap();
        assert!(
            scene.textures.is_empty(),
            "{uri}: the outside image was read"
        );
        assert!(
            scene
                .warnings
                .iter()
                .any(|w| w.contains("images[0]") && w.contains("is outside the scene's folder")),
            "{uri}: {:?}",
            scene.warnings
        );
        assert_eq!(
            scene.inputs.len(),
            1,
            "only the scene itself: {:?}",
            scene.inputs
        );
        // Allowed by the user, the same image is read.
        let allowed = load_allowing(&path, &[tree.secret()]).unwrap();
        assert_eq!(allowed.textures.len(), 1, "{uri}");
        assert!(allowed.inputs.iter().any(|p| p.ends_with("secret/x.png")));
    }
}

/// The attack: `buffers[].uri: "/etc/passwd"` was accepted, and an
/// unreadable file's size leaked: "651 bytes, but its byteLength says
/// 99999999" for /etc/shadow.
#[test]
fn gltf_buffers_outside_the_folder_are_refused_without_describing_them() {
    let tree = Tree::new();
    for uri in [
        "/etc/passwd",
        "/etc/shadow",
        "../secret/x.png",
        "%2E%2E/secret/x.png",
    ] {
        let mut doc: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(common::gltf_quad(&tree.scene(), serde_json::json!({}), &[]))
                .unwrap(),
        )
        .unwrap();
        doc["buffers"][0]["uri"] = serde_json::json!(uri);
        doc["buffers"][0]["byteLength"] = serde_json::json!(99_999_999);
        let path = tree.scene().join("b.gltf");
        std::fs::write(&path, doc.to_string()).unwrap();
        let e = load(&path).unwrap_err().to_string();
        assert!(e.contains("buffers[0]: '"), "{e}");
        assert!(e.contains("is outside the scene's folder"), "{uri}: {e}");
        assert!(
            !e.contains("bytes") && !e.contains("byteLength"),
            "{uri}: {e}"
        );
    }
}

/// The attack: OBJ `mtllib /etc/passwd` was read without a word, and
/// `map_Kd ..\secret\x.png` had its backslashes turned and loaded.
#[test]
fn obj_material_libraries_and_maps_outside_the_folder_are_not_read() {
    let tree = Tree::new();
    std::fs::write(
        tree.secret().join("m.mtl"),
        "newmtl m\nKd 1 1 1\nmap_Kd x.png\n",
    )
    .unwrap();
    let quad = "v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nusemtl m\nf 1/1 2/2 3/3\n";
    let obj = tree.scene().join("a.obj");
    for mtllib in ["/etc/passwd", "../secret/m.mtl", "..\\secret\\m.mtl"] {
        std::fs::write(&obj, format!("mtllib {mtllib}\n{quad}")).unwrap();
        let s = load(&obj).unwrap();
        assert!(
            s.warnings
                .iter()
                .any(|w| w.contains("material library") && w.contains("outside the scene's folder")),
            "{mtllib}: {:?}",
            s.warnings
        );
        assert!(s.textures.is_empty());
        assert_eq!(s.inputs.len(), 1, "{:?}", s.inputs);
    }
    std::fs::write(
        tree.scene().join("m.mtl"),
        "newmtl m\nKd 1 1 1\nmap_Kd ..\\secret\\x.png\n",
    )
    .unwrap();
    std::fs::write(&obj, format!("mtllib m.mtl\n{quad}")).unwrap();
    let s = load(&obj).unwrap();
    assert!(s.textures.is_empty(), "the map outside was read");
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("texture '..\\secret\\x.png' is outside")),
        "{:?}",
        s.warnings
    );
    assert_eq!(s.inputs.len(), 2, "the OBJ and its MTL: {:?}", s.inputs);
    let allowed = load_allowing(&obj, &[tree.secret()]).unwrap();
    assert_eq!(allowed.textures.len(), 1);
}

#[cfg(unix)]
fn mkfifo(path: &Path) {
    let status = std::process::Command::new("mkfifo")
        .arg(path)
        .status()
        .expect("mkfifo");
    assert!(status.success());
}

/// Loads `path`, which may also read `/dev`, on another thread; fails if
/// it takes more than 20 s (a FIFO opened for reading waits for a writer
/// forever).
fn load_within_20_s(path: &Path) -> twinray::Result<twinray::Scene> {
    let (tx, rx) = std::sync::mpsc::channel();
    let p = path.to_path_buf();
    std::thread::spawn(move || {
        let _ = tx.send(load_allowing(&p, &[PathBuf::from("/dev")]));
    });
    rx.recv_timeout(std::time::Duration::from_secs(20))
        .unwrap_or_else(|_| panic!("{}: the load hangs", path.display()))
}

/// The attack: a buffer, image, `map_Kd`, `mtllib` or scene that is
/// `/dev/zero` or `/dev/urandom` was read without bound (2.1 GB, then out
/// of memory); a FIFO hung forever.
#[cfg(unix)]
#[test]
fn devices_and_fifos_are_not_read() {
    let tree = Tree::new();
    let dir = tree.scene();
    std::os::unix::fs::symlink("/dev/zero", dir.join("zero.bin")).unwrap();
    std::os::unix::fs::symlink("/dev/urandom", dir.join("random.png")).unwrap();
    mkfifo(&dir.join("fifo.mtl"));
    mkfifo(&dir.join("fifo.png"));
    // Named by the scene, in its folder or one allowed (`/dev`, so that
    // the links into it pass the folder check): refused as files that are
    // not regular.
    let material = serde_json::json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}});
    for image in ["random.png", "fifo.png", "/dev/zero"] {
        let path = common::gltf_quad(&dir, material.clone(), &[image]);
        let s = load_within_20_s(&path).unwrap();
        assert!(
            s.warnings.iter().any(|w| w.contains("not a regular file")),
            "{image}: {:?}",
            s.warnings
        );
    }
    let mut doc: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(common::gltf_quad(&dir, serde_json::json!({}), &[])).unwrap(),
    )
    .unwrap();
    doc["buffers"][0]["uri"] = serde_json::json!("zero.bin");
    std::fs::write(dir.join("z.gltf"), doc.to_string()).unwrap();
    let e = load_within_20_s(&dir.join("z.gltf"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("buffers[0]: 'zero.bin' is not a regular file"),
        "{e}"
    );
    std::fs::write(
        dir.join("f.obj"),
        "mtllib fifo.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    let s = load_within_20_s(&dir.join("f.obj")).unwrap();
    assert!(
        s.warnings.iter().any(|w| w.contains("not a regular file")),
        "{:?}",
        s.warnings
    );
    // Named by the user: the same.
    std::os::unix::fs::symlink("/dev/zero", dir.join("zero.obj")).unwrap();
    mkfifo(&dir.join("fifo.gltf"));
    for scene in ["zero.obj", "fifo.gltf"] {
        let e = load_within_20_s(&dir.join(scene)).unwrap_err().to_string();
        assert!(e.contains("not a regular file"), "{scene}: {e}");
    }
    let e = load(&dir).unwrap_err().to_string();
    assert!(e.contains("directory") || e.contains("extension"), "{e}");
}

// ---------------------------------------------------------------------------
// Memory counted before it is spent.

/// A PNG that says it is `width` x `height` (its header only: its pixel
/// data is a stub): what a load must count before decoding it.
fn png_header(width: u32, height: u32) -> Vec<u8> {
    fn crc32(bytes: &[u8]) -> u32 {
        let mut crc = !0u32;
        for &b in bytes {
            crc ^= u32::from(b);
            for _ in 0..8 {
                crc = if crc & 1 == 1 {
                    (crc >> 1) ^ 0xEDB8_8320
                } else {
                    crc >> 1
                };
            }
        }
        !crc
    }
    let chunk = |kind: &[u8], data: &[u8]| {
        let mut c = (data.len() as u32).to_be_bytes().to_vec();
        let mut body = kind.to_vec();
        body.extend_from_slice(data);
        c.extend_from_slice(&body);
        c.extend_from_slice(&crc32(&body).to_be_bytes());
        c
    };
    let mut ihdr = width.to_be_bytes().to_vec();
    ihdr.extend_from_slice(&height.to_be_bytes());
    ihdr.extend_from_slice(&[8, 2, 0, 0, 0]);
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    png.extend(chunk(b"IHDR", &ihdr));
    png.extend(chunk(b"IDAT", &[0x78, 0x9c, 0x03, 0x00]));
    png.extend(chunk(b"IEND", &[]));
    png
}

fn data_uri(mime: &str, bytes: &[u8]) -> String {
    use base64::Engine as _;
    format!(
        "data:{mime};base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bytes)
    )
}

/// The attack: a 3.1 MB glTF of 12 data-URI PNGs, each 8192×8192 (under the
/// per-image cap), reached 7.5 GB and aborted. The texels are counted from
/// each image's header, before it is decoded.
#[test]
fn textures_are_counted_from_their_headers_before_they_are_decoded() {
    let dir = tempfile::tempdir().unwrap();
    let png = data_uri("image/png", &png_header(8192, 8192));
    let images: Vec<&str> = vec![&png; 12];
    let mut doc: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(common::gltf_quad(
            dir.path(),
            serde_json::json!({}),
            &images,
        ))
        .unwrap(),
    )
    .unwrap();
    // Twelve materials, each with its own image.
    doc["materials"] = (0..12)
        .map(|i| serde_json::json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": i}}}))
        .collect();
    let path = dir.path().join("twelve.gltf");
    std::fs::write(&path, doc.to_string()).unwrap();
    let opts = LoadOptions {
        memory_limit: Some(4_000_000_000),
        ..LoadOptions::default()
    };
    let e = load_scene(&path, &opts).unwrap_err().to_string();
    // 805 MB a texture, as much again while it decodes: the fourth does not
    // fit beside three.
    assert!(
        e.ends_with(
            "images[3]: a 8192x8192 texture: needs about 1.6 GB of memory beside the 2.4 GB \
             taken before, but only 4.0 GB is available"
        ),
        "{e}"
    );
}

/// A glTF file of one mesh of `triangles` triangles (all one triangle)
/// instanced by `instances` nodes side by side.
fn instanced_gltf(triangles: usize, instances: usize) -> String {
    let positions: [[f32; 3]; 3] = [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.]];
    let mut bin: Vec<u8> = positions
        .iter()
        .flatten()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    bin.extend(std::iter::repeat_n([0u8, 1, 2], triangles).flatten());
    serde_json::json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": (0..instances).collect::<Vec<_>>()}],
        "nodes": (0..instances)
            .map(|i| serde_json::json!({"mesh": 0, "translation": [i as f32 * 2.0, 0, 0]}))
            .collect::<Vec<_>>(),
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "buffers": [{"byteLength": bin.len(), "uri": data_uri("application/octet-stream", &bin)}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": 36, "byteLength": triangles * 3}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5121, "count": triangles * 3, "type": "SCALAR"}
        ]
    })
    .to_string()
}

/// The attack: a 6 MB GLB instancing a 1M-triangle mesh 40 times (under
/// the triangle limit) aborted: "memory allocation of ... failed". The
/// instances' triangles are counted before they are made. (Here 40
/// instances of 10,000 triangles against a limit of 16 MB; the command
/// line's test runs the attack's own GLB under `ulimit -v`.)
#[test]
fn instances_are_counted_before_their_triangles_are_made() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("forty.gltf");
    std::fs::write(&path, instanced_gltf(10_000, 40)).unwrap();
    let opts = |limit| LoadOptions {
        memory_limit: Some(limit),
        ..LoadOptions::default()
    };
    let e = load_scene(&path, &opts(16_000_000))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("forty.gltf: 400000 triangles: needs about"),
        "{e}"
    );
    assert!(e.ends_with("but only 16 MB is available"), "{e}");
    let scene = load_scene(&path, &opts(100_000_000)).unwrap();
    assert_eq!(scene.shapes.len(), 400_000);
}

// ---------------------------------------------------------------------------
// Values: every material input clamped, no pixel infinite.

/// The pixels of `scene` rendered as a job would (its lights and camera),
/// 16 x 12, at pixel centres.
fn job_pixels(scene: &Path) -> Vec<twinray::math::Color> {
    use twinray::job::{CancelToken, Job, JobSpec};
    let dir = tempfile::tempdir().unwrap();
    let mut spec = JobSpec::new(scene, dir.path().join("out.exr"));
    spec.camera.size = Some([16, 12]);
    spec.sampling.samples = Some(1);
    let job = Job::check(spec).expect("job");
    let loaded = job.load().expect("load");
    let plan = job.plan(&loaded).expect("plan");
    let rendered = job
        .render(&plan, &|_, _| {}, &CancelToken::new())
        .expect("render");
    rendered
        .output
        .images
        .into_iter()
        .flat_map(|i| i.pixels)
        .collect()
}

/// The attack: MTL `Kd 0.8 0.8 3.4e38`, glTF `emissiveFactor` 1e38 and
/// `KHR_materials_emissive_strength` 1e38 gave infinite pixels, silently
/// (the clamp applied to NFF only).
#[test]
fn mtl_and_gltf_materials_are_clamped_with_a_warning_and_pixels_stay_finite() {
    let dir = tempfile::tempdir().unwrap();
    let quad = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nusemtl m\nf 1 2 3 4\n";
    for (mtl, says) in [
        (
            "Kd 0.8 0.8 3.4e38",
            "Kd 0.8 0.8 340000000000000000000000000000000000000 clamped to 0.8 0.8 1",
        ),
        ("Ke 1e38 1e38 1e38", "clamped to 1000000 1000000 1000000"),
        (
            "Ks 1e38 0 0\nNs 1e38\nillum 3",
            "Ns 100000000000000000000000000000000000000 clamped to 1000",
        ),
        ("d -5\nNi 0", "d -5 clamped to 0"),
    ] {
        std::fs::write(dir.path().join("m.mtl"), format!("newmtl m\n{mtl}\n")).unwrap();
        let obj = dir.path().join("m.obj");
        std::fs::write(&obj, format!("mtllib m.mtl\n{quad}")).unwrap();
        let scene = load(&obj).unwrap();
        assert!(
            scene
                .warnings
                .iter()
                .any(|w| w.contains("material 'm'") && w.contains(says)),
            "{mtl}: {:?}",
            scene.warnings
        );
        assert!(
            job_pixels(&obj).iter().all(|c| c.is_finite()),
            "{mtl}: a pixel is not finite"
        );
    }
    for (material, says) in [
        (
            serde_json::json!({"emissiveFactor": [1e38, 1e38, 1e38]}),
            "emissiveFactor",
        ),
        (
            serde_json::json!({"emissiveFactor": [1, 1, 1],
                "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 1e38}}}),
            "emissiveStrength 100000000000000000000000000000000000000 clamped to 1000000",
        ),
        (
            serde_json::json!({"pbrMetallicRoughness": {"baseColorFactor": [3.4e38, 1, 1, 1]}}),
            "baseColorFactor",
        ),
    ] {
        let path = common::gltf_quad(dir.path(), material.clone(), &[]);
        let scene = load(&path).unwrap();
        assert!(
            scene
                .warnings
                .iter()
                .any(|w| w.contains("materials[0]") && w.contains(says)),
            "{material}: {:?}",
            scene.warnings
        );
        let m = &scene.materials[0];
        assert!(
            m.emission.max_element() <= twinray::scene::MAX_RADIANCE,
            "{material}"
        );
        assert!(
            job_pixels(&path).iter().all(|c| c.is_finite()),
            "{material}: a pixel is not finite"
        );
    }
}

// ---------------------------------------------------------------------------
// Mesh files that hold nothing to render.

/// The attack: 1 GB of NULs as `.obj` or `.stl` rendered an empty scene
/// with exit 0, and an empty OBJ a black image. They are errors now. (A
/// sparse file of 64 MB of NULs here; the size does not matter.)
#[test]
fn nul_empty_and_faceless_mesh_files_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["nul.obj", "nul.stl"] {
        let path = dir.path().join(name);
        std::fs::File::create(&path)
            .unwrap()
            .set_len(64 << 20)
            .unwrap();
        let e = load(&path).unwrap_err().to_string();
        assert!(
            e.contains("not a text file (a NUL byte)") || e.contains("no triangles to render"),
            "{name}: {e}"
        );
    }
    for (name, text, says) in [
        ("empty.obj", "", "no faces to render"),
        (
            "points.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\n",
            "no faces to render",
        ),
        (
            "flat.obj",
            "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n",
            "every face was skipped",
        ),
        ("empty.stl", "solid x\nendsolid x\n", "not a valid STL file"),
    ] {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        let e = load(&path).unwrap_err().to_string();
        assert!(e.contains(name) && e.contains(says), "{name}: {e}");
    }
    let header_only = [vec![0u8; 80], 0u32.to_le_bytes().to_vec()].concat();
    std::fs::write(dir.path().join("zero.stl"), header_only).unwrap();
    let e = load(&dir.path().join("zero.stl")).unwrap_err().to_string();
    assert!(e.contains("no triangles to render"), "{e}");
}

/// The attack: a PLY parse error quoted the whole first line: 100 MB of
/// NULs gave a 100 MB message.
#[test]
fn ply_errors_quote_a_short_excerpt() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("nul.ply");
    std::fs::File::create(&path)
        .unwrap()
        .set_len(100 << 20)
        .unwrap();
    let e = load(&path).unwrap_err().to_string();
    assert!(
        e.starts_with(&format!("{}: not a valid PLY file", path.display())),
        "{}",
        &e[..e.len().min(300)]
    );
    assert!(
        e.len() < 400 + path.display().to_string().len(),
        "{} bytes",
        e.len()
    );
    let mut text =
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n".to_vec();
    text.extend(std::iter::repeat_n(b'7', 10 << 20));
    std::fs::write(&path, text).unwrap();
    let e = load(&path).unwrap_err().to_string();
    assert!(e.len() < 600, "{} bytes: {}", e.len(), &e[..300]);
}

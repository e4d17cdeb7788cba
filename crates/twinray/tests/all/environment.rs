//! `--env`: an equirectangular environment image seen where rays leave the
//! scene and lighting surfaces as ambient light; and metals' mirrors tinted
//! by their base colour. Every image here is made by the test: a sky whose
//! top half is red and bottom half blue.

use std::path::{Path, PathBuf};

use serde_json::json;
use twinray::job::{CancelToken, Job, JobSpec, MethodName, UpAxisSpec};
use twinray::math::Vec3;
use twinray::Image;

const W: u32 = 64;
const H: u32 = 48;

/// An equirectangular OpenEXR image, top half red, bottom half blue.
fn red_over_blue(dir: &Path) -> PathBuf {
    let path = dir.join("sky.exr");
    exr::prelude::write_rgb_file(&path, 64, 32, |_, y| {
        if y < 16 {
            (1.0f32, 0.0f32, 0.0f32)
        } else {
            (0.0, 0.0, 1.0)
        }
    })
    .unwrap();
    path
}

/// NFF: a sphere of radius 1 at the origin seen from +z, horizontally, of
/// material `f` (NFF's `f r g b Kd Ks Shine T ior`; Ks is the mirror too).
fn sphere_scene(dir: &Path, f: &str) -> PathBuf {
    let path = dir.join("sphere.nff");
    let text = format!(
        "v\nfrom 0 0 6\nat 0 0 0\nup 0 1 0\nangle 30\nhither 0.01\nresolution {W} {H}\n\
         f {f}\ns 0 0 0 1\n"
    );
    std::fs::write(&path, text).unwrap();
    path
}

fn render(spec: JobSpec) -> Vec<Image> {
    let job = Job::check(spec).unwrap();
    let loaded = job.load().unwrap();
    let plan = job.plan(&loaded).unwrap();
    job.render(&plan, &|_, _| {}, &CancelToken::new())
        .unwrap()
        .output
        .images
}

fn spec(scene: &Path, env: Option<&Path>) -> JobSpec {
    let mut spec = JobSpec::new(scene, scene.with_extension("exr"));
    spec.sampling.samples = Some(1);
    spec.studio.env = env.map(Path::to_path_buf);
    spec
}

fn red(c: Vec3) -> bool {
    c.x > 0.5 && c.z < 0.1 * c.x
}

fn blue(c: Vec3) -> bool {
    c.z > 0.5 && c.x < 0.1 * c.z
}

#[test]
fn the_sky_is_red_above_the_horizon_and_a_mirror_sphere_reflects_it() {
    let dir = tempfile::tempdir().unwrap();
    let sky = red_over_blue(dir.path());
    // A perfect mirror: no diffuse, Ks 1.
    let scene = sphere_scene(dir.path(), "1 1 1 0 1 1000 0 1");
    let img = &render(spec(&scene, Some(&sky)))[0];
    // The background: the top rows look above the horizon, the bottom below.
    for x in [0, W / 2, W - 1] {
        assert!(red(img.get(x, 0)), "top {x}: {}", img.get(x, 0));
        assert!(blue(img.get(x, H - 1)), "bottom {x}: {}", img.get(x, H - 1));
    }
    // The sphere fills the middle (radius 1 at 6 in a 30° view: ±14 rows).
    // Its upper half faces up, and reflects the red sky; its lower half the
    // blue ground; near the edges it reflects what is behind it.
    let (cx, cy) = (W / 2, H / 2);
    assert!(red(img.get(cx, cy - 6)), "upper: {}", img.get(cx, cy - 6));
    assert!(blue(img.get(cx, cy + 6)), "lower: {}", img.get(cx, cy + 6));
    // Without the environment, a black background: the mirror is black.
    let plain = &render(spec(&scene, None))[0];
    assert_eq!(plain.get(cx, cy - 6), Vec3::ZERO);
    assert_eq!(plain.get(0, 0), Vec3::ZERO);
}

#[test]
fn the_environment_lights_a_diffuse_surface_from_where_it_faces() {
    let dir = tempfile::tempdir().unwrap();
    let sky = red_over_blue(dir.path());
    // White, fully diffuse; no light in the file: only the sky lights it.
    let scene = sphere_scene(dir.path(), "1 1 1 1 0 0 0 1");
    let img = &render(spec(&scene, Some(&sky)))[0];
    let (cx, cy) = (W / 2, H / 2);
    let (top, bottom, middle) = (img.get(cx, cy - 12), img.get(cx, cy + 12), img.get(cx, cy));
    assert!(top.x > 2.0 * top.z, "top: {top}");
    assert!(bottom.z > 2.0 * bottom.x, "bottom: {bottom}");
    // Facing the horizon, half of each (nine harmonics: within a few per cent).
    assert!(
        (middle.x - 0.5).abs() < 0.03 && (middle.z - 0.5).abs() < 0.03,
        "{middle}"
    );
    // Without it: no light at all, a black sphere.
    let plain = &render(spec(&scene, None))[0];
    assert_eq!(plain.get(cx, cy), Vec3::ZERO);
}

#[test]
fn twin_and_independent_views_are_the_same_under_an_environment() {
    let dir = tempfile::tempdir().unwrap();
    let sky = red_over_blue(dir.path());
    // A mirror sphere and a diffuse one beside it, so that both reflected
    // rays and the ambient term see the sky in both views.
    let path = dir.path().join("two.nff");
    std::fs::write(
        &path,
        format!(
            "v\nfrom 0 0.5 6\nat 0 0 0\nup 0 1 0\nangle 35\nhither 0.01\nresolution {W} {H}\n\
             l 3 4 5\nf 1 1 1 0 1 1000 0 1\ns -0.8 0 0 0.7\nf 0.9 0.8 0.7 0.7 0.3 20 0 1\ns 0.9 0 -0.5 0.7\n"
        ),
    )
    .unwrap();
    let run = |method| {
        let mut s = spec(&path, Some(&sky));
        s.rig.stereo = true;
        s.rig.interaxial = Some("0.4".into());
        s.rig.convergence = Some("6".into());
        s.method.name = method;
        render(s)
    };
    let (twin, independent) = (run(MethodName::Twin), run(MethodName::Independent));
    assert_eq!(twin.len(), 2);
    for v in 0..2 {
        assert!(
            twin[v] == independent[v],
            "view {v}: twin and independent differ"
        );
    }
    // The two views differ (they are not one image twice).
    assert!(twin[0] != twin[1]);
}

#[test]
fn the_environment_turns_with_the_up_axis() {
    let dir = tempfile::tempdir().unwrap();
    let sky = red_over_blue(dir.path());
    // A cube, framed without a camera: above and below it, the sky.
    let obj = dir.path().join("cube.obj");
    std::fs::write(
        &obj,
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
         f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n",
    )
    .unwrap();
    for up in [UpAxisSpec::Y, UpAxisSpec::Z] {
        let mut s = spec(&obj, Some(&sky));
        s.camera.size = Some([W, H]);
        // The default view looks down at the model by 25°: a lens of 90°
        // sees above the horizon at the top.
        s.camera.fov = Some(90.0);
        s.studio.up_axis = up;
        let img = &render(s)[0];
        assert!(red(img.get(W / 2, 0)), "{up:?} top: {}", img.get(W / 2, 0));
        assert!(
            blue(img.get(W / 2, H - 1)),
            "{up:?} bottom: {}",
            img.get(W / 2, H - 1)
        );
    }
}

#[test]
fn an_hdr_file_reads_as_the_exr_does() {
    let dir = tempfile::tempdir().unwrap();
    let exr = red_over_blue(dir.path());
    let hdr = dir.path().join("sky.hdr");
    let pixels: Vec<image::Rgb<f32>> = (0..64 * 32)
        .map(|i| {
            if i / 64 < 16 {
                image::Rgb([1.0, 0.0, 0.0])
            } else {
                image::Rgb([0.0, 0.0, 1.0])
            }
        })
        .collect();
    let file = std::io::BufWriter::new(std::fs::File::create(&hdr).unwrap());
    image::codecs::hdr::HdrEncoder::new(file)
        .encode(&pixels, 64, 32)
        .unwrap();
    let scene = sphere_scene(dir.path(), "1 1 1 0 1 1000 0 1");
    assert!(render(spec(&scene, Some(&hdr)))[0] == render(spec(&scene, Some(&exr)))[0]);
}

#[test]
fn background_and_env_conflict_and_a_bad_env_names_its_file() {
    let dir = tempfile::tempdir().unwrap();
    let sky = red_over_blue(dir.path());
    let scene = sphere_scene(dir.path(), "1 1 1 1 0 0 0 1");
    let mut s = spec(&scene, Some(&sky));
    s.studio.background = Some([1.0, 1.0, 1.0]);
    let msg = Job::check(s).err().expect("refused").to_string();
    assert!(
        msg.contains("--background") && msg.contains("--env"),
        "{msg}"
    );

    for (name, bytes) in [
        ("broken.hdr", &b"#?RADIANCE\nnot an image"[..]),
        ("sky.png", b""),
    ] {
        let bad = dir.path().join(name);
        std::fs::write(&bad, bytes).unwrap();
        let job = Job::check(spec(&scene, Some(&bad))).unwrap();
        let msg = job.load().err().expect("refused").to_string();
        assert!(msg.contains(name) && msg.contains("--env"), "{msg}");
    }
    let job = Job::check(spec(&scene, Some(&dir.path().join("missing.exr")))).unwrap();
    let msg = job.load().err().expect("refused").to_string();
    assert!(msg.contains("missing.exr"), "{msg}");
}

/// A glTF quad (−1..1 in x and y, facing +z) of one material.
fn gltf_quad(dir: &Path, material: serde_json::Value) -> PathBuf {
    let mut bytes = Vec::new();
    for p in [
        [-1.0f32, -1.0, 0.0],
        [1.0, -1.0, 0.0],
        [1.0, 1.0, 0.0],
        [-1.0, -1.0, 0.0],
        [1.0, 1.0, 0.0],
        [-1.0, 1.0, 0.0],
    ] {
        for v in p {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    use base64::Engine as _;
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&bytes)
    );
    let doc = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "material": 0}]}],
        "materials": [material],
        "buffers": [{"byteLength": 72, "uri": uri}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 72}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 6, "type": "VEC3",
                       "min": [-1.0, -1.0, 0.0], "max": [1.0, 1.0, 0.0]}]
    });
    let path = dir.join("quad.gltf");
    std::fs::write(&path, doc.to_string()).unwrap();
    path
}

#[test]
fn a_metal_mirror_takes_its_base_colour_and_a_dielectric_stays_white() {
    let dir = tempfile::tempdir().unwrap();
    let gold = [1.0, 0.6, 0.2];
    let quad = |metallic: f64| {
        gltf_quad(
            dir.path(),
            json!({"pbrMetallicRoughness": {"baseColorFactor": [gold[0], gold[1], gold[2], 1.0],
                                            "metallicFactor": metallic, "roughnessFactor": 0.0}}),
        )
    };
    // A white world around the quad, and no lights (so no highlight): what
    // the centre shows is its mirror alone.
    let look = |path: &Path| {
        let mut s = spec(path, None);
        s.camera.size = Some([16, 16]);
        s.studio.background = Some([1.0; 3]);
        s.studio.lights = vec![twinray::job::LightSpec {
            position: [0.0, 0.0, -100.0],
            color: [0.0; 3],
        }];
        render(s)[0].get(8, 8)
    };
    let metal = look(&quad(1.0));
    assert!(
        (metal - Vec3::from(gold.map(|c| c as f32)))
            .abs()
            .max_element()
            < 0.02,
        "metal mirror: {metal}"
    );
    // A dielectric reflects 4 % of the white world, untinted (its diffuse
    // gold gets no light).
    let plastic = look(&quad(0.0));
    assert!(
        (plastic - Vec3::splat(0.04)).abs().max_element() < 1e-3,
        "dielectric mirror: {plastic}"
    );
}

/// A BLEND surface of coverage a under an environment shows a of its own
/// light, the environment's ambient term included, and 1 − a of what is
/// behind it: the pixel is linear in a between the empty and opaque quads.
#[test]
fn a_blended_surface_takes_the_environment_light_by_its_coverage() {
    let dir = tempfile::tempdir().unwrap();
    let sky = red_over_blue(dir.path());
    let pixel = |alpha: f64| {
        let quad = gltf_quad(
            dir.path(),
            json!({"alphaMode": "BLEND",
                   "pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.9, 0.3, alpha],
                                            "metallicFactor": 0.0, "roughnessFactor": 1.0}}),
        );
        let mut s = spec(&quad, Some(&sky));
        s.camera.size = Some([16, 16]);
        // No light of the file's default rig: the environment alone lights it.
        s.studio.lights = vec![twinray::job::LightSpec {
            position: [0.0, 0.0, 100.0],
            color: [0.0; 3],
        }];
        render(s)[0].get(8, 5)
    };
    let (behind, opaque, half) = (pixel(0.0), pixel(1.0), pixel(0.5));
    // The quad's albedo under the sky's ambient light shows (dimmer than
    // the sky: at most 0.3 of it), and the sky behind it is full red or blue.
    assert!(
        opaque.max_element() > 0.05 && opaque.max_element() < 0.35,
        "opaque: {opaque}"
    );
    // Coverage 0: the sky alone, pure red or pure blue, none of the quad.
    assert!(
        [Vec3::X, Vec3::Z]
            .iter()
            .any(|sky| (behind - *sky).abs().max_element() < 1e-6),
        "behind: {behind}"
    );
    let mixed = opaque * 0.5 + behind * 0.5;
    assert!(
        (half - mixed).abs().max_element() < 2e-3,
        "half coverage {half}, half of opaque and behind {mixed}"
    );
}

/// The environment image is read once per job: an animation readies a
/// scene per frame, and every frame shares the first one's image.
#[test]
fn a_job_reads_its_environment_once() {
    let dir = tempfile::tempdir().unwrap();
    let sky = red_over_blue(dir.path());
    let scene = sphere_scene(dir.path(), "1 1 1 1 0 0 0 1");
    let job = Job::check(spec(&scene, Some(&sky))).unwrap();
    let (first, second) = (job.load().unwrap(), job.load().unwrap());
    let (a, b) = (
        first.scene.environment.as_ref().expect("an environment"),
        second.scene.environment.as_ref().expect("an environment"),
    );
    assert!(std::sync::Arc::ptr_eq(a, b), "read twice");
}

/// The epipolar rows (`--epipolar-views`) take a sample that hits nothing
/// from the environment toward its own ray, as the exact views do: the sky
/// behind a diffuse sphere is red above the horizon and blue below in every
/// view, and each view is the independent render's within the tolerance.
#[test]
fn epipolar_views_see_the_environment_where_they_hit_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let sky = red_over_blue(dir.path());
    let scene = sphere_scene(dir.path(), "0.9 0.8 0.7 1 0 0 0 1");
    let run = |epipolar| {
        let mut s = spec(&scene, Some(&sky));
        s.rig.views = Some(5);
        s.rig.interaxial = Some("0.05".into());
        s.method.name = if epipolar {
            MethodName::Fast
        } else {
            MethodName::Independent
        };
        render(s)
    };
    let (rows, exact) = (run(true), run(false));
    assert_eq!(rows.len(), 5);
    for (v, (a, b)) in rows.iter().zip(&exact).enumerate() {
        for x in [0, W / 2, W - 1] {
            assert!(red(a.get(x, 0)), "view {v}, top {x}: {}", a.get(x, 0));
            assert!(blue(a.get(x, H - 1)), "view {v}, bottom {x}");
        }
        let worst = (0..H)
            .flat_map(|y| (0..W).map(move |x| (x, y)))
            .map(|(x, y)| (a.get(x, y) - b.get(x, y)).abs().max_element())
            .fold(0.0f32, f32::max);
        assert!(worst <= 0.01, "view {v}: {worst}");
    }
}

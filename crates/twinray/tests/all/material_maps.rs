//! A material's maps beyond colour, each with a file made here: alpha cut-outs
//! (MASK: OBJ `map_d`, glTF `alphaMode`) for eye, reflected and shadow rays,
//! partial transparency (BLEND: OBJ `d`), normal and height maps (OBJ `norm`,
//! `map_Bump`; glTF `normalTexture`) and OBJ `map_Ke`. The twin method must
//! still give what independent renders give, bit for bit.

use crate::common;

use std::path::Path;

use serde_json::json;
use twinray::loaders::{load_scene, LoadOptions};
use twinray::math::{Color, Vec3};
use twinray::render::{render, RenderOptions, Sampling, ViewMethod};
use twinray::rig::{Camera, Rig};
use twinray::scene::{AngleSpan, Light, Material, Viewpoint};
use twinray::{Image, Scene, World};

const SIZE: u32 = 16;
const BLUE: Color = Color::new(0.0, 0.0, 1.0);

fn camera(from: Vec3, at: Vec3, angle_deg: f32) -> Camera {
    let vp = Viewpoint {
        from,
        at,
        up: Vec3::Y,
        angle_deg,
        angle_span: AngleSpan::ImageHeight,
        hither: 0.0,
        width: SIZE,
        height: SIZE,
    };
    Camera::new(&vp, SIZE, SIZE)
}

/// 3 units in front of the quad (−1..1 at z = 0), which fills the view.
fn front() -> Camera {
    camera(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, 30.0)
}

/// Between the quad and the wall behind it (z = −1), looking at the wall:
/// the quad is behind this camera.
fn between() -> Camera {
    camera(Vec3::new(0.0, 0.0, -0.2), Vec3::new(0.0, 0.0, -1.0), 90.0)
}

fn options(method: ViewMethod) -> RenderOptions {
    RenderOptions {
        method,
        sampling: Sampling::Centers,
        ..RenderOptions::default()
    }
}

fn render_with(scene: &Scene, camera: &Camera, rig: &Rig, method: ViewMethod) -> Vec<Image> {
    let world = World::new(scene.clone());
    render(&world, camera, rig, &options(method), &|_, _| {})
        .expect("render")
        .images
}

fn mono(scene: &Scene, camera: &Camera) -> Image {
    render_with(scene, camera, &Rig::mono(), ViewMethod::Independent).remove(0)
}

fn centre(img: &Image) -> Color {
    img.get(SIZE / 2, SIZE / 2)
}

fn edge(img: &Image) -> Color {
    img.get(1, SIZE / 2)
}

fn close(a: Color, b: Color, tol: f32) -> bool {
    (a - b).abs().max_element() < tol
}

/// An RGBA image: `alpha(x, y)` over an opaque green.
fn rgba_png(path: &Path, size: u32, alpha: impl Fn(u32, u32) -> u8) {
    image::RgbaImage::from_fn(size, size, |x, y| image::Rgba([0, 200, 0, alpha(x, y)]))
        .save(path)
        .unwrap();
}

/// An 8×8 leaf: opaque, with a hole of 4×4 texels in the middle (the quad's
/// −0.5..0.5 in x and y).
fn leaf_png(path: &Path) {
    rgba_png(path, 8, |x, y| {
        if (2..6).contains(&x) && (2..6).contains(&y) {
            0
        } else {
            255
        }
    });
}

/// The OBJ quad −1..1 at z = 0, facing +z, with texture coordinates, and
/// MTL material `mtl`; `normal` gives its corners that normal.
fn obj_quad(dir: &Path, name: &str, mtl: &str, normal: Option<Vec3>) -> Scene {
    std::fs::write(
        dir.join(format!("{name}.mtl")),
        format!("newmtl m\n{mtl}\n"),
    )
    .unwrap();
    let (vn, f) = match normal {
        Some(n) => (
            format!("vn {} {} {}\n", n.x, n.y, n.z),
            "f 1/1/1 2/2/1 3/3/1 4/4/1",
        ),
        None => (String::new(), "f 1/1 2/2 3/3 4/4"),
    };
    let obj = format!(
        "mtllib {name}.mtl\nusemtl m\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n\
         vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n{vn}{f}\n"
    );
    let path = dir.join(format!("{name}.obj"));
    std::fs::write(&path, obj).unwrap();
    let mut scene = load_scene(&path, &LoadOptions::default()).expect("loads");
    scene.background = BLUE;
    scene
}

/// Adds a wall at z = −1, 8 wide, of `material`, and a light at (0, 0, 4).
fn with_wall(mut scene: Scene, material: Material) -> Scene {
    scene.add_material(material);
    let c = [(-4.0, -4.0), (4.0, -4.0), (4.0, 4.0), (-4.0, 4.0)];
    let wall: Vec<Vec3> = c.iter().map(|&(x, y)| Vec3::new(x, y, -1.0)).collect();
    scene.add_polygon(&wall, "wall");
    scene
        .lights
        .push(Light::point(Vec3::new(0.0, 0.0, 4.0), Some(Color::ONE)));
    scene
}

fn white_wall() -> Material {
    Material {
        kd: 0.8,
        ..Material::default()
    }
}

fn mirror_wall() -> Material {
    Material {
        color: Color::ZERO,
        kd: 0.0,
        mirror: 1.0,
        ..Material::default()
    }
}

const LEAF: &str = "Kd 1 1 1\nKs 0 0 0\nillum 1\nmap_Kd leaf.png\nmap_d leaf.png";
const LEAF_OPAQUE: &str = "Kd 1 1 1\nKs 0 0 0\nillum 1\nmap_Kd leaf.png";

#[test]
fn a_masked_leaf_shows_what_is_behind_its_hole() {
    let dir = tempfile::tempdir().unwrap();
    leaf_png(&dir.path().join("leaf.png"));
    let leaf = obj_quad(dir.path(), "leaf", LEAF, None);
    let mut lit_leaf = leaf.clone();
    lit_leaf
        .lights
        .push(Light::point(Vec3::new(0.0, 0.0, 4.0), Some(Color::ONE)));
    let img = mono(&lit_leaf, &front());
    assert_eq!(centre(&img), BLUE, "the background through the hole");
    let green = edge(&img);
    assert!(green.y > 0.3 && green.x < 0.05, "the leaf itself: {green}");

    // Behind the hole, the lit wall; the same leaf without its alpha hides it.
    let lit = mono(&with_wall(leaf, white_wall()), &front());
    assert!(
        close(centre(&lit), Color::splat(1.0), 0.05),
        "{}",
        centre(&lit)
    );
    let opaque = obj_quad(dir.path(), "opaque", LEAF_OPAQUE, None);
    let hidden = mono(&with_wall(opaque, white_wall()), &front());
    // (The leaf's texel behind the hole, lit at a slightly other angle.)
    assert!(close(centre(&hidden), green, 0.02), "{}", centre(&hidden));
}

#[test]
fn a_masked_leaf_casts_a_shadow_with_a_hole() {
    let dir = tempfile::tempdir().unwrap();
    leaf_png(&dir.path().join("leaf.png"));
    // Light at z = 4: the leaf's shadow on the wall is 1.25 times the leaf,
    // its hole |x|, |y| < 0.625; this camera sees the wall to |x| < 0.8.
    let scene = with_wall(obj_quad(dir.path(), "leaf", LEAF, None), white_wall());
    let img = mono(&scene, &between());
    let (lit, shadow) = (centre(&img), edge(&img));
    assert!(lit.x > 0.5, "light through the hole: {lit}");
    // In shadow: the ambient term alone (1 − Kd).
    let ambient = Color::splat(0.2);
    assert!(close(shadow, ambient, 1e-5), "the leaf's shadow: {shadow}");
    let opaque = with_wall(obj_quad(dir.path(), "op", LEAF_OPAQUE, None), white_wall());
    let hidden = centre(&mono(&opaque, &between()));
    assert!(
        close(hidden, ambient, 1e-5),
        "no hole without alpha: {hidden}"
    );
}

#[test]
fn a_mirror_shows_the_leaf_with_its_hole() {
    let dir = tempfile::tempdir().unwrap();
    leaf_png(&dir.path().join("leaf.png"));
    // The camera looks at the mirror; the reflected rays go back through the
    // leaf (behind the camera): its hole shows the background.
    let scene = with_wall(obj_quad(dir.path(), "leaf", LEAF, None), mirror_wall());
    let img = mono(&scene, &between());
    assert_eq!(
        centre(&img),
        BLUE,
        "the background through the mirrored hole"
    );
    // Off the hole (x = 0.35 on the mirror, 0.8 on the leaf): the leaf's
    // back, unlit, hides the background.
    let leaf = img.get(11, SIZE / 2);
    assert_eq!(leaf, Color::ZERO, "the leaf in the mirror");
}

#[test]
fn gltf_mask_cuts_where_alpha_is_below_the_cutoff() {
    let dir = tempfile::tempdir().unwrap();
    // Alpha 0.4 in the middle, 1 elsewhere: cut at a cutoff of 0.5, not at 0.3.
    rgba_png(&dir.path().join("leaf.png"), 8, |x, y| {
        if (2..6).contains(&x) && (2..6).contains(&y) {
            102
        } else {
            255
        }
    });
    let centre_of = |cutoff: f32| {
        let material = json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}},
                              "alphaMode": "MASK", "alphaCutoff": cutoff});
        let mut scene =
            load_scene(&gltf_quad(dir.path(), material), &LoadOptions::default()).expect("loads");
        scene.background = BLUE;
        centre(&mono(&scene, &front()))
    };
    assert_eq!(centre_of(0.5), BLUE);
    assert_ne!(centre_of(0.3), BLUE);
}

#[test]
fn blend_mixes_the_surface_with_what_is_straight_behind() {
    let dir = tempfile::tempdir().unwrap();
    let solid = obj_quad(
        dir.path(),
        "solid",
        "Kd 0.2 0.9 0.2\nKs 0 0 0\nillum 1",
        None,
    );
    let glassy = obj_quad(
        dir.path(),
        "glassy",
        "Kd 0.2 0.9 0.2\nKs 0 0 0\nillum 1\nd 0.25",
        None,
    );
    let tr = obj_quad(
        dir.path(),
        "tr",
        "Kd 0.2 0.9 0.2\nKs 0 0 0\nillum 1\nTr 0.75",
        None,
    );
    let lights = |mut s: Scene| {
        s.lights
            .push(Light::point(Vec3::new(1.0, 1.0, 4.0), Some(Color::ONE)));
        s
    };
    let c = centre(&mono(&lights(solid.clone()), &front()));
    let want = c * 0.25 + BLUE * 0.75;
    let got = centre(&mono(&lights(glassy.clone()), &front()));
    assert!(close(got, want, 1e-5), "{got}, want {want}");
    let got = centre(&mono(&lights(tr), &front()));
    assert!(close(got, want, 1e-5), "Tr = 1 − d: {got}");

    // Shadow rays keep 1 − alpha of the light.
    let cam = between();
    let no_leaf = {
        let mut s = with_wall(Scene::new(), white_wall());
        s.background = BLUE;
        s
    };
    let full = centre(&mono(&no_leaf, &cam));
    let dark = centre(&mono(&with_wall(solid, white_wall()), &cam));
    let half = centre(&mono(&with_wall(glassy, white_wall()), &cam));
    let want = dark + (full - dark) * 0.75;
    assert!(
        dark.x < full.x * 0.5,
        "the opaque leaf's shadow: {dark} vs {full}"
    );
    assert!(close(half, want, 1e-4), "{half}, want {want}");
}

/// The masked leaf, a partly transparent quad behind it, the wall and a
/// mirror: every way a ray meets alpha.
fn alpha_scene(dir: &Path) -> Scene {
    leaf_png(&dir.join("leaf.png"));
    let mut scene = with_wall(obj_quad(dir, "leaf", LEAF, None), white_wall());
    scene.add_material(Material {
        color: Color::new(0.9, 0.3, 0.3),
        alpha_mode: twinray::scene::AlphaMode::Blend,
        alpha: 0.5,
        ..Material::default()
    });
    let sq = [(-0.3, -0.9), (0.9, -0.9), (0.9, 0.3), (-0.3, 0.3)];
    let behind: Vec<Vec3> = sq.iter().map(|&(x, y)| Vec3::new(x, y, -0.5)).collect();
    scene.add_polygon(&behind, "blend");
    scene.add_material(Material {
        kd: 0.1,
        mirror: 0.8,
        ..Material::default()
    });
    scene.add_sphere(Vec3::new(-0.4, 0.4, -0.6), 0.25, "mirror ball");
    scene.lights.push(Light::point(
        Vec3::new(-2.0, 3.0, 2.0),
        Some(Color::splat(0.6)),
    ));
    scene
}

#[test]
fn with_cut_outs_and_blending_twin_equals_independent() {
    let dir = tempfile::tempdir().unwrap();
    let scene = alpha_scene(dir.path());
    for (cam, interaxial) in [(front(), 0.3), (front(), 0.05), (between(), 0.2)] {
        for views in [2, 5] {
            let rig = Rig::multi_view(&cam, views, interaxial, Some(2.0)).unwrap();
            let twin = render_with(&scene, &cam, &rig, ViewMethod::twin());
            let independent = render_with(&scene, &cam, &rig, ViewMethod::Independent);
            for (v, (a, b)) in twin.iter().zip(&independent).enumerate() {
                let bits = |i: &Image| -> Vec<u32> {
                    i.pixels
                        .iter()
                        .flat_map(|c| c.to_array().map(f32::to_bits))
                        .collect()
                };
                assert_eq!(bits(a), bits(b), "view {v} of {views}");
            }
        }
    }
    // The scene does show through the hole.
    let img = mono(&scene, &front());
    assert_ne!(centre(&img), edge(&img));
}

/// A constant tangent-space normal map encoding `n` (OpenGL convention).
fn normal_png(path: &Path, n: Vec3) {
    let n = n.normalize();
    let byte = |x: f32| ((x * 0.5 + 0.5) * 255.0).round() as u8;
    image::RgbImage::from_pixel(4, 4, image::Rgb([byte(n.x), byte(n.y), byte(n.z)]))
        .save(path)
        .unwrap();
}

/// Lights on three sides, so that a normal tilted any way shows.
fn three_lights(mut s: Scene) -> Scene {
    for (p, c) in [
        (Vec3::new(3.0, 0.5, 2.0), Color::new(0.6, 0.0, 0.0)),
        (Vec3::new(-0.5, 3.0, 2.0), Color::new(0.0, 0.6, 0.0)),
        (Vec3::new(-2.0, -2.0, 3.0), Color::new(0.0, 0.0, 0.6)),
    ] {
        s.lights.push(Light::point(p, Some(c)));
    }
    s
}

#[test]
fn a_normal_map_lights_a_flat_quad_like_the_tilted_normal_it_encodes() {
    let dir = tempfile::tempdir().unwrap();
    let tilt = Vec3::new(0.35, -0.25, 1.0);
    normal_png(&dir.path().join("n.png"), tilt);
    let mtl = "Kd 1 1 1\nKs 0 0 0\nillum 1";
    let mapped = three_lights(obj_quad(
        dir.path(),
        "mapped",
        &format!("{mtl}\nnorm n.png"),
        None,
    ));
    let tilted = three_lights(obj_quad(dir.path(), "tilted", mtl, Some(tilt)));
    let flat = three_lights(obj_quad(dir.path(), "flat", mtl, None));
    let (a, b, f) = (
        mono(&mapped, &front()),
        mono(&tilted, &front()),
        mono(&flat, &front()),
    );
    let worst = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .map(|(p, q)| (*p - *q).abs().max_element())
        .fold(0.0, f32::max);
    assert!(worst < 0.01, "normal map vs tilted normals: {worst}");
    assert!(
        !close(centre(&a), centre(&f), 0.05),
        "the map changes the light"
    );

    // map_Bump with a bluish image is read as a normal map too (Blender
    // writes normal maps there), and glTF's normalTexture the same way.
    let bump = three_lights(obj_quad(
        dir.path(),
        "bump",
        &format!("{mtl}\nmap_Bump n.png"),
        None,
    ));
    assert!(close(centre(&mono(&bump, &front())), centre(&b), 0.01));
    let material = json!({"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1],
                                                  "metallicFactor": 0, "roughnessFactor": 1},
                          "normalTexture": {"index": 0}});
    std::fs::copy(dir.path().join("n.png"), dir.path().join("leaf.png")).unwrap();
    let gltf = load_scene(&gltf_quad(dir.path(), material), &LoadOptions::default()).unwrap();
    let g = mono(&three_lights(gltf), &front());
    let worst = g
        .pixels
        .iter()
        .zip(&b.pixels)
        .map(|(p, q)| (*p - *q).abs().max_element())
        .fold(0.0, f32::max);
    assert!(worst < 0.01, "glTF normal map vs tilted normals: {worst}");
}

#[test]
fn a_grey_map_bump_is_a_height_map() {
    let dir = tempfile::tempdir().unwrap();
    // Height rising to the right: the surface faces a little left.
    image::GrayImage::from_fn(64, 4, |x, _| image::Luma([(x * 4) as u8]))
        .save(dir.path().join("h.png"))
        .unwrap();
    let mtl = "Kd 1 1 1\nKs 0 0 0\nillum 1";
    let light = |mut s: Scene, x: f32| {
        s.lights
            .push(Light::point(Vec3::new(x, 0.0, 1.5), Some(Color::ONE)));
        s
    };
    let bumped = obj_quad(
        dir.path(),
        "b",
        &format!("{mtl}\nmap_Bump -bm 3 h.png"),
        None,
    );
    assert_eq!(
        bumped.materials[0].normal_map.map(|m| m.kind),
        Some(twinray::scene::NormalMapKind::Height)
    );
    let flat = obj_quad(dir.path(), "f", mtl, None);
    let from_left = centre(&mono(&light(bumped.clone(), -3.0), &front())).x;
    let flat_left = centre(&mono(&light(flat.clone(), -3.0), &front())).x;
    let from_right = centre(&mono(&light(bumped, 3.0), &front())).x;
    let flat_right = centre(&mono(&light(flat, 3.0), &front())).x;
    assert!(from_left > flat_left * 1.05, "{from_left} vs {flat_left}");
    assert!(
        from_right < flat_right * 0.95,
        "{from_right} vs {flat_right}"
    );
}

#[test]
fn map_ke_multiplies_ke() {
    let dir = tempfile::tempdir().unwrap();
    let (r, g) = ([255, 0, 0], [0, 255, 0]);
    let px = [r, r, g, g];
    image::RgbImage::from_fn(4, 1, |x, _| image::Rgb(px[x as usize]))
        .save(dir.path().join("ke.png"))
        .unwrap();
    let scene = obj_quad(
        dir.path(),
        "glow",
        "Kd 0 0 0\nKs 0 0 0\nillum 1\nKe 0.5 0.5 0.5\nmap_Ke ke.png",
        None,
    );
    // No lights: the camera sees the light the quad emits.
    let img = mono(&scene, &front());
    assert!(
        close(edge(&img), Color::new(0.5, 0.0, 0.0), 1e-3),
        "{}",
        edge(&img)
    );
    let right = img.get(SIZE - 2, SIZE / 2);
    assert!(close(right, Color::new(0.0, 0.5, 0.0), 1e-3), "{right}");
}

/// A glTF quad like the OBJ one with `material` and one image, leaf.png.
fn gltf_quad(dir: &Path, material: serde_json::Value) -> std::path::PathBuf {
    common::gltf_quad(dir, material, &["leaf.png"])
}

/// The glTF quad with NORMAL (+z) and TANGENT (`tangent`, the same at
/// every corner) attributes, in a second buffer.
fn gltf_quad_with_tangents(dir: &Path, material: serde_json::Value, tangent: [f32; 4]) -> Scene {
    use base64::Engine as _;
    let path = gltf_quad(dir, material);
    let mut doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    let mut bytes = Vec::new();
    for _ in 0..6 {
        for v in [0.0f32, 0.0, 1.0] {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    for _ in 0..6 {
        for v in tangent {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&bytes)
    );
    doc["buffers"]
        .as_array_mut()
        .unwrap()
        .push(json!({"byteLength": bytes.len(), "uri": uri}));
    let views = doc["bufferViews"].as_array_mut().unwrap();
    views.push(json!({"buffer": 1, "byteOffset": 0, "byteLength": 72}));
    views.push(json!({"buffer": 1, "byteOffset": 72, "byteLength": 96}));
    let accessors = doc["accessors"].as_array_mut().unwrap();
    accessors.push(json!({"bufferView": 2, "componentType": 5126, "count": 6, "type": "VEC3"}));
    accessors.push(json!({"bufferView": 3, "componentType": 5126, "count": 6, "type": "VEC4"}));
    let attributes = &mut doc["meshes"][0]["primitives"][0]["attributes"];
    attributes["NORMAL"] = json!(2);
    attributes["TANGENT"] = json!(3);
    std::fs::write(&path, doc.to_string()).unwrap();
    load_scene(&path, &LoadOptions::default()).expect("loads")
}

/// glTF `TANGENT` sets the normal map's frame (bitangent = normal × tangent
/// × w): along +u it gives the frame the uv would; turned a quarter turn
/// (tangent +y), the map's tilt turns with it; w = −1 mirrors the bitangent.
#[test]
fn gltf_tangents_set_the_normal_maps_frame() {
    let dir = tempfile::tempdir().unwrap();
    let tilt = Vec3::new(0.35, -0.25, 1.0);
    normal_png(&dir.path().join("leaf.png"), tilt);
    let material = json!({"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1],
                                                  "metallicFactor": 0, "roughnessFactor": 1},
                          "normalTexture": {"index": 0}});
    let mtl = "Kd 1 1 1\nKs 0 0 0\nillum 1";
    let worst = |a: &Image, b: &Image| {
        a.pixels
            .iter()
            .zip(&b.pixels)
            .map(|(p, q)| (*p - *q).abs().max_element())
            .fold(0.0, f32::max)
    };
    let lit = |s: Scene| mono(&three_lights(s), &front());
    let tilted = |n: Vec3, name: &str| lit(obj_quad(dir.path(), name, mtl, Some(n)));
    let with = |t: [f32; 4]| lit(gltf_quad_with_tangents(dir.path(), material.clone(), t));

    // Tangent +x, w = 1: the uv's own frame (tangent-space x, y = world x, y).
    let along_u = with([1.0, 0.0, 0.0, 1.0]);
    let same = tilted(tilt, "same");
    assert!(worst(&along_u, &same) < 0.01, "{}", worst(&along_u, &same));
    // Tangent +y: x → +y and y → normal × tangent = −x.
    let turned = with([0.0, 1.0, 0.0, 1.0]);
    let expect = tilted(Vec3::new(-tilt.y, tilt.x, tilt.z), "turned");
    assert!(
        worst(&turned, &expect) < 0.01,
        "{}",
        worst(&turned, &expect)
    );
    assert!(worst(&turned, &same) > 0.05, "the tangent changed nothing");
    // w = −1: the bitangent flips, y → −y.
    let mirrored = with([1.0, 0.0, 0.0, -1.0]);
    let expect = tilted(Vec3::new(tilt.x, -tilt.y, tilt.z), "mirrored");
    assert!(
        worst(&mirrored, &expect) < 0.01,
        "{}",
        worst(&mirrored, &expect)
    );
}

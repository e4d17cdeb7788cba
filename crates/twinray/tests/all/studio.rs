//! `--light` and `--ground`: lights and a floor the command line adds around
//! a model file.

use twinray::job::{CancelToken, Job, JobSpec, LightSpec, Plan};
use twinray::math::Vec3;
use twinray::scene::LightKind;

/// A unit cube standing on y = 0, centred on the y axis, as an OBJ file.
const CUBE: &str = "v -0.5 0 -0.5\nv 0.5 0 -0.5\nv 0.5 1 -0.5\nv -0.5 1 -0.5\n\
v -0.5 0 0.5\nv 0.5 0 0.5\nv 0.5 1 0.5\nv -0.5 1 0.5\n\
f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";

const W: u32 = 160;
const H: u32 = 100;

struct Render {
    pixels: Vec<Vec3>,
    plan_camera: twinray::rig::Camera,
}

impl Render {
    fn at(&self, x: u32, y: u32) -> Vec3 {
        self.pixels[(y * W + x) as usize]
    }
}

fn light(x: f32, y: f32, z: f32) -> LightSpec {
    LightSpec {
        position: [x, y, z],
        color: [1.0; 3],
    }
}

/// Renders the cube with `edit` applied to its spec.
fn render(edit: impl FnOnce(&mut JobSpec)) -> Render {
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("cube.obj");
    std::fs::write(&obj, CUBE).unwrap();
    let mut spec = JobSpec::new(&obj, dir.path().join("cube.exr"));
    spec.camera.size = Some([W, H]);
    spec.sampling.samples = Some(1);
    edit(&mut spec);
    let job = Job::check(spec).unwrap();
    let loaded = job.load().unwrap();
    let plan: Plan = job.plan(&loaded).unwrap();
    let out = job.render(&plan, &|_, _| {}, &CancelToken::new()).unwrap();
    let img = &out.output.images[0];
    let mut pixels = Vec::new();
    for y in 0..H {
        for x in 0..W {
            pixels.push(img.get(x, y));
        }
    }
    Render {
        pixels,
        plan_camera: plan.camera.clone(),
    }
}

/// Which pixels show the cube: those that differ from a red background.
fn cube_mask() -> Vec<bool> {
    let r = render(|s| s.studio.background = Some([1.0, 0.0, 0.0]));
    r.pixels
        .iter()
        .map(|p| *p != Vec3::new(1.0, 0.0, 0.0))
        .collect()
}

/// Mean brightness of the cube's pixels left and right of the cube's middle column.
fn halves(r: &Render, mask: &[bool]) -> (f32, f32) {
    let xs: Vec<u32> = (0..W * H)
        .filter(|&i| mask[i as usize])
        .map(|i| i % W)
        .collect();
    let mid = (xs.iter().min().unwrap() + xs.iter().max().unwrap()) / 2;
    let (mut sum, mut n) = ([0.0f32; 2], [0u32; 2]);
    for i in 0..W * H {
        if mask[i as usize] {
            let side = usize::from(i % W > mid);
            sum[side] += r.pixels[i as usize].element_sum();
            n[side] += 1;
        }
    }
    (sum[0] / n[0] as f32, sum[1] / n[1] as f32)
}

#[test]
fn a_light_replaces_the_rig_and_its_position_matters() {
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("cube.obj");
    std::fs::write(&obj, CUBE).unwrap();
    let mut spec = JobSpec::new(&obj, dir.path().join("cube.exr"));
    spec.studio.lights = vec![LightSpec {
        position: [-4.0, 0.5, 2.0],
        color: [0.5, 0.25, 1.0],
    }];
    let loaded = Job::check(spec).unwrap().load().unwrap();
    assert_eq!(loaded.scene.lights.len(), 1, "the rig is replaced");
    let l = &loaded.scene.lights[0];
    assert!(
        matches!(l.kind, LightKind::Point { position, .. } if position == Vec3::new(-4.0, 0.5, 2.0))
    );
    assert_eq!(l.color, Some(Vec3::new(0.5, 0.25, 1.0)));

    let mask = cube_mask();
    let rig = render(|_| {});
    let left = render(|s| s.studio.lights = vec![light(-4.0, 0.5, 1.0)]);
    let right = render(|s| s.studio.lights = vec![light(4.0, 0.5, 1.0)]);
    assert_ne!(left.pixels, rig.pixels, "--light changes the image");
    let (l_left, l_right) = halves(&left, &mask);
    let (r_left, r_right) = halves(&right, &mask);
    assert!(
        l_left > 1.2 * l_right,
        "a light on the left lights the left more: {l_left} vs {l_right}"
    );
    assert!(
        r_right > 1.2 * r_left,
        "a light on the right lights the right more: {r_right} vs {r_left}"
    );
    // Two lights: both add.
    let both = render(|s| s.studio.lights = vec![light(-4.0, 0.5, 1.0), light(4.0, 0.5, 1.0)]);
    let (b_left, b_right) = halves(&both, &mask);
    assert!(b_left > l_left && b_right > r_right);
}

#[test]
fn the_ground_shows_lit_floor_and_the_cubes_shadow_and_keeps_the_framing() {
    let mask = cube_mask();
    // Above, to the left and a little in front of the cube.
    let plain = render(|s| s.studio.lights = vec![light(-2.0, 4.0, 1.0)]);
    let ground = render(|s| {
        s.studio.lights = vec![light(-2.0, 4.0, 1.0)];
        s.studio.ground = true;
    });
    // Framing fits the cube, not the floor: the same camera.
    assert_eq!(plain.plan_camera, ground.plan_camera);
    // The image's lower left corner, far from the cube: floor, lit and grey.
    let (p, far) = (plain.at(1, H - 2), ground.at(1, H - 2));
    assert_eq!(p, Vec3::ZERO, "no floor without --ground");
    assert!(
        far.x > 0.05 && far.x == far.y && far.y == far.z,
        "lit grey floor: {far}"
    );
    // The cube's lowest row of pixels, and the floor beside it a few pixels
    // out: the light is on the left, so the right is in the cube's shadow.
    let y = (0..H)
        .filter(|&y| (0..W).any(|x| mask[(y * W + x) as usize]))
        .max()
        .unwrap()
        - 2;
    let row: Vec<u32> = (0..W).filter(|&x| mask[(y * W + x) as usize]).collect();
    let (x0, x1) = (row[0], *row.last().unwrap());
    let lit = ground.at(x0 - 4, y);
    let shadow = ground.at(x1 + 4, y);
    assert!(lit.x > 0.05, "the floor left of the cube is lit: {lit}");
    assert!(
        shadow.x < 0.5 * lit.x,
        "the floor right of the cube is in its shadow: {shadow} vs {lit}"
    );
    assert!(far.x > 2.0 * shadow.x, "{far} vs {shadow}");
}

#[test]
fn the_ground_lies_below_the_model_along_the_up_axis() {
    for (up, axis) in [
        (twinray::job::UpAxisSpec::Y, 1),
        (twinray::job::UpAxisSpec::Z, 2),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let obj = dir.path().join("cube.obj");
        std::fs::write(&obj, CUBE).unwrap();
        let mut spec = JobSpec::new(&obj, dir.path().join("cube.exr"));
        spec.studio.up_axis = up;
        spec.studio.ground = true;
        let loaded = Job::check(spec).unwrap().load().unwrap();
        let scene = &loaded.scene;
        let floor = &scene.shapes[12..];
        assert_eq!(floor.len(), 2, "two triangles after the cube's twelve");
        let model = scene.shapes[..12]
            .iter()
            .fold(twinray::math::Aabb::EMPTY, |b, s| b.union(s.bounds()));
        let f = floor
            .iter()
            .fold(twinray::math::Aabb::EMPTY, |b, s| b.union(s.bounds()));
        let (lo, hi) = (model.min.to_array(), model.max.to_array());
        let (flo, fhi) = (f.min.to_array(), f.max.to_array());
        // Flat, just below the model, and several times wider.
        assert!(fhi[axis] - flo[axis] < 1e-5);
        assert!(fhi[axis] < lo[axis] && fhi[axis] > lo[axis] - 0.01);
        for other in (0..3).filter(|&a| a != axis) {
            assert!(fhi[other] - flo[other] > 4.0 * (hi[other] - lo[other]));
        }
    }
}

#[test]
fn bad_lights_are_refused_naming_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("cube.obj");
    std::fs::write(&obj, CUBE).unwrap();
    for l in [
        LightSpec {
            position: [f32::NAN, 0.0, 0.0],
            color: [1.0; 3],
        },
        LightSpec {
            position: [0.0, f32::INFINITY, 0.0],
            color: [1.0; 3],
        },
        LightSpec {
            position: [0.0; 3],
            color: [1.0, -0.5, 1.0],
        },
    ] {
        let mut spec = JobSpec::new(&obj, dir.path().join("cube.exr"));
        spec.studio.lights = vec![l];
        let Err(e) = Job::check(spec) else {
            panic!("accepted a bad light")
        };
        assert!(e.to_string().contains("--light"), "{e}");
    }
    // A saved job names lights as data; the colour defaults to white.
    let spec: JobSpec = serde_json::from_str(
        r#"{"scene": "cube.obj", "studio": {"lights": [{"position": [1, 2, 3]}], "ground": true}}"#,
    )
    .unwrap();
    assert_eq!(spec.studio.lights, vec![light(1.0, 2.0, 3.0)]);
    assert!(spec.studio.ground);
}

/// The cube as dark as a camera body: its vertices coloured 0.04 (OBJ's
/// `v x y z r g b`) over the white default material.
fn dark_cube(edit: impl FnOnce(&mut JobSpec)) -> Render {
    render(|s| {
        let dark: String = CUBE
            .lines()
            .map(|l| {
                if l.starts_with("v ") {
                    format!("{l} 0.04 0.04 0.04\n")
                } else {
                    format!("{l}\n")
                }
            })
            .collect();
        std::fs::write(&s.scene, dark).unwrap();
        edit(s)
    })
}

fn mean(r: &Render, mask: &[bool], on: bool) -> f32 {
    let picked: Vec<f32> = r
        .pixels
        .iter()
        .zip(mask)
        .filter(|(_, m)| **m == on)
        .map(|(p, _)| p.element_sum() / 3.0)
        .collect();
    picked.iter().sum::<f32>() / picked.len() as f32
}

#[test]
fn a_model_without_lights_stands_in_a_grey_studio() {
    let mask = cube_mask();
    let studio = dark_cube(|_| {});
    // The background is the studio's mid grey, brighter above than below,
    // not black.
    let background = mean(&studio, &mask, false);
    assert!(background > 0.15 && background < 0.5, "{background}");
    let (top, bottom) = (studio.at(2, 1), studio.at(2, H - 2));
    assert!(
        top.x > bottom.x && top.x == top.y && top.y == top.z,
        "{top} {bottom}"
    );
    // A dark model is lit by the studio too: brighter than under the rig alone
    // (a black background gives no ambient light), and still darker than its
    // background, against which it stands out.
    let rig_alone = dark_cube(|s| s.studio.background = Some([0.0; 3]));
    let (lit, unlit) = (mean(&studio, &mask, true), mean(&rig_alone, &mask, true));
    assert!(
        lit > 1.5 * unlit,
        "studio {lit} against the rig alone {unlit}"
    );
    assert!(lit < 0.5 * background, "{lit} against {background}");
    // --background, --env or lights in the file replace it: the given
    // background is what misses see.
    assert_eq!(rig_alone.at(2, 1), Vec3::ZERO);
}

//! A model without a camera is framed so that it fills about 80 % of the
//! image, whatever the image's shape.

use twinray::job::{CancelToken, Job, JobSpec, UpAxisSpec};

/// A unit cube centred off the origin, as an OBJ file.
const CUBE: &str = "v 2 0 0\nv 3 0 0\nv 3 1 0\nv 2 1 0\nv 2 0 1\nv 3 0 1\nv 3 1 1\nv 2 1 1\n\
f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";

/// The share of the width and of the height that the model's pixels span.
fn fill(width: u32, height: u32) -> (f32, f32) {
    fill_of(CUBE, width, height, UpAxisSpec::Y)
}

/// `fill` of the OBJ text `obj` with an up axis.
fn fill_of(obj_text: &str, width: u32, height: u32, up: UpAxisSpec) -> (f32, f32) {
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("cube.obj");
    std::fs::write(&obj, obj_text).unwrap();
    let mut spec = JobSpec::new(&obj, dir.path().join("cube.exr"));
    spec.camera.size = Some([width, height]);
    spec.studio.up_axis = up;
    // Black around the model, not the grey studio: the cube is what is lit.
    spec.studio.background = Some([0.0; 3]);
    spec.sampling.samples = Some(1);
    let job = Job::check(spec).unwrap();
    let loaded = job.load().unwrap();
    let plan = job.plan(&loaded).unwrap();
    let out = job.render(&plan, &|_, _| {}, &CancelToken::new()).unwrap();
    let img = &out.output.images[0];
    let (mut x0, mut x1, mut y0, mut y1) = (u32::MAX, 0, u32::MAX, 0);
    for y in 0..height {
        for x in 0..width {
            if img.get(x, y).max_element() > 0.0 {
                (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
            }
        }
    }
    assert!(x1 >= x0, "the cube is not in view");
    // Nothing touches the edges.
    assert!(x0 > 0 && y0 > 0 && x1 < width - 1 && y1 < height - 1);
    (
        (x1 - x0 + 1) as f32 / width as f32,
        (y1 - y0 + 1) as f32 / height as f32,
    )
}

#[test]
fn a_model_without_camera_fills_eighty_percent_of_the_frame() {
    for (w, h) in [(160, 120), (120, 160), (100, 100)] {
        let (fw, fh) = fill(w, h);
        let tight = fw.max(fh);
        assert!((0.77..=0.83).contains(&tight), "{w}x{h}: {fw:.3} x {fh:.3}");
    }
}

#[test]
fn a_model_without_lights_gets_a_key_a_fill_and_a_rim_light() {
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("cube.obj");
    std::fs::write(&obj, CUBE).unwrap();
    let job = Job::check(JobSpec::new(&obj, dir.path().join("cube.png"))).unwrap();
    let loaded = job.load().unwrap();
    let lights = &loaded.scene.lights;
    assert_eq!(lights.len(), 3);
    let vp = &loaded.scene.viewpoint;
    let back = (vp.from - vp.at).normalize();
    let right = vp.up.cross(back).normalize();
    let toward = |i: usize| match lights[i].kind {
        twinray::scene::LightKind::Directional { direction } => -direction,
        _ => panic!("directional"),
    };
    // Key: above left, in front; fill: right, in front; rim: behind.
    assert!(toward(0).dot(right) < 0.0 && toward(0).dot(back) > 0.0);
    assert!(toward(1).dot(right) > 0.0 && toward(1).dot(back) > 0.0);
    assert!(toward(2).dot(back) < 0.0);
    // The cube's three visible faces are lit differently: the shape reads.
    let plan = job.plan(&loaded).unwrap();
    let out = job.render(&plan, &|_, _| {}, &CancelToken::new()).unwrap();
    let img = &out.output.images[0];
    let mut shades: Vec<u32> = img
        .pixels
        .iter()
        .filter(|c| c.max_element() > 0.0)
        .map(|c| (c.x * 64.0) as u32)
        .collect();
    shades.sort_unstable();
    shades.dedup();
    assert!(shades.len() >= 3, "{shades:?}");
}

#[test]
fn up_axis_z_stands_a_z_up_model_upright() {
    // A post 4 units tall along z, 0.5 wide.
    let post =
        "v 0 0 0\nv 0.5 0 0\nv 0.5 0.5 0\nv 0 0.5 0\nv 0 0 4\nv 0.5 0 4\nv 0.5 0.5 4\nv 0 0.5 4\n\
f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
    let (w, h) = fill_of(post, 100, 100, UpAxisSpec::Z);
    assert!(h > 2.0 * w, "z up: {w:.2} wide, {h:.2} tall");
    // Read as y-up, the post lies along the line of sight's depth axis, not upright.
    let (w, h) = fill_of(post, 100, 100, UpAxisSpec::Y);
    assert!(h < 2.0 * w, "y up: {w:.2} wide, {h:.2} tall");
}

//! STL (binary, ASCII) and PLY (ASCII, binary) files holding the same model as
//! an OBJ render the same silhouette through the job API; truncated or
//! malformed files are errors naming the file.

use std::fmt::Write as _;
use std::path::Path;

use twinray::job::{CancelToken, Job, JobSpec};

/// An open model, so that every triangle shows in the silhouette: four
/// blades of a pinwheel in the z = 0 plane and a slanted triangle in front.
fn model() -> (Vec<[f32; 3]>, Vec<[usize; 3]>) {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for k in 0..4 {
        let a = k as f32 * std::f32::consts::FRAC_PI_2;
        let (c, s) = (a.cos(), a.sin());
        let rot = |x: f32, y: f32| [c * x - s * y, s * x + c * y, 0.0];
        let i = positions.len();
        positions.extend([rot(0.2, 0.0), rot(1.5, 0.1), rot(1.2, 0.6)]);
        triangles.push([i, i + 1, i + 2]);
    }
    let i = positions.len();
    positions.extend([[-0.4, -0.3, 0.8], [0.5, -0.2, 0.5], [0.0, 0.6, 1.0]]);
    triangles.push([i, i + 1, i + 2]);
    (positions, triangles)
}

fn obj(p: &[[f32; 3]], t: &[[usize; 3]]) -> Vec<u8> {
    let mut s = String::new();
    for v in p {
        writeln!(s, "v {} {} {}", v[0], v[1], v[2]).unwrap();
    }
    for f in t {
        writeln!(s, "f {} {} {}", f[0] + 1, f[1] + 1, f[2] + 1).unwrap();
    }
    s.into_bytes()
}

fn stl_binary(p: &[[f32; 3]], t: &[[usize; 3]]) -> Vec<u8> {
    // A header starting with "solid", as some exporters write: still binary.
    let mut out = b"solid written by the stl_ply test".to_vec();
    out.resize(80, 0);
    out.extend((t.len() as u32).to_le_bytes());
    for f in t {
        out.extend([0u8; 12]); // a zero normal, as many exporters write
        for &i in f {
            for c in p[i] {
                out.extend(c.to_le_bytes());
            }
        }
        out.extend([0u8; 2]);
    }
    out
}

fn stl_ascii(p: &[[f32; 3]], t: &[[usize; 3]]) -> Vec<u8> {
    let mut s = String::from("solid\n");
    for f in t {
        s += "  facet normal 0 0 0\n    outer loop\n";
        for &i in f {
            writeln!(s, "      vertex {} {} {}", p[i][0], p[i][1], p[i][2]).unwrap();
        }
        s += "    endloop\n  endfacet\n";
    }
    s += "endsolid\n";
    s.into_bytes()
}

fn ply_ascii(p: &[[f32; 3]], t: &[[usize; 3]]) -> Vec<u8> {
    let mut s = format!(
        "ply\nformat ascii 1.0\ncomment no colours\nelement vertex {}\nproperty float x\n\
         property float y\nproperty float z\nelement face {}\n\
         property list uchar int vertex_indices\nend_header\n",
        p.len(),
        t.len()
    );
    for v in p {
        writeln!(s, "{} {} {}", v[0], v[1], v[2]).unwrap();
    }
    for f in t {
        writeln!(s, "3 {} {} {}", f[0], f[1], f[2]).unwrap();
    }
    s.into_bytes()
}

/// Binary little-endian, with red vertex colours.
fn ply_binary(p: &[[f32; 3]], t: &[[usize; 3]]) -> Vec<u8> {
    let mut out = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\n\
         property float y\nproperty float z\nproperty uchar red\nproperty uchar green\n\
         property uchar blue\nelement face {}\nproperty list uchar uint vertex_indices\n\
         end_header\n",
        p.len(),
        t.len()
    )
    .into_bytes();
    for v in p {
        for c in v {
            out.extend(c.to_le_bytes());
        }
        out.extend([230u8, 20, 20]);
    }
    for f in t {
        out.push(3);
        for &i in f {
            out.extend((i as u32).to_le_bytes());
        }
    }
    out
}

/// Renders `file` at 64x48 with the defaults; returns which pixels differ
/// from the background, and the image.
fn silhouette(file: &Path) -> (Vec<bool>, twinray::Image) {
    let mut spec = JobSpec::new(file, file.with_extension("exr"));
    // Black around the model, not the grey studio, so the silhouette is
    // every pixel that is not the background.
    spec.studio.background = Some([0.0; 3]);
    spec.camera.size = Some([64, 48]);
    spec.sampling.samples = Some(1);
    let job = Job::check(spec).unwrap();
    let loaded = job
        .load()
        .unwrap_or_else(|e| panic!("{}: {e}", file.display()));
    let background = loaded.scene.background;
    assert!(
        loaded.scene.lights.len() >= 3,
        "{}: lit like an OBJ",
        file.display()
    );
    let plan = job.plan(&loaded).unwrap();
    let out = job.render(&plan, &|_, _| {}, &CancelToken::new()).unwrap();
    let img = out.output.images[0].clone();
    let mask = img.pixels.iter().map(|&c| c != background).collect();
    (mask, img)
}

#[test]
fn stl_and_ply_render_the_same_silhouette_as_obj() {
    let (p, t) = model();
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, bytes: Vec<u8>| {
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        path
    };
    let (reference, _) = silhouette(&write("model.obj", obj(&p, &t)));
    let covered = reference.iter().filter(|&&b| b).count();
    assert!(
        covered > 64 * 48 / 20 && covered < 64 * 48 / 2,
        "{covered} model pixels"
    );
    for (name, bytes) in [
        ("binary.stl", stl_binary(&p, &t)),
        ("ascii.STL", stl_ascii(&p, &t)),
        ("ascii.ply", ply_ascii(&p, &t)),
        ("binary.ply", ply_binary(&p, &t)),
    ] {
        let (mask, img) = silhouette(&write(name, bytes));
        let differ = mask.iter().zip(&reference).filter(|(a, b)| a != b).count();
        assert_eq!(
            differ, 0,
            "{name}: {differ} pixels differ from the OBJ's silhouette"
        );
        if name == "binary.ply" {
            // The red vertex colours: the model's pixels are red.
            let red = img
                .pixels
                .iter()
                .zip(&mask)
                .filter(|&(c, &m)| m && c.x > 2.0 * c.y && c.x > 2.0 * c.z)
                .count();
            assert!(red * 10 > covered * 9, "{red} of {covered} pixels red");
        }
    }
}

#[test]
fn truncated_stl_and_malformed_ply_are_errors_naming_the_file() {
    let (p, t) = model();
    let dir = tempfile::tempdir().unwrap();
    let check = |name: &str, bytes: &[u8], says: &str| {
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        let job = Job::check(JobSpec::new(&path, dir.path().join("out.png"))).unwrap();
        let Err(e) = job.load() else {
            panic!("{name} loaded")
        };
        let msg = e.to_string();
        assert!(msg.contains(name) && msg.contains(says), "{name}: {msg}");
    };
    let stl = stl_binary(&p, &t);
    check("cut.stl", &stl[..stl.len() - 30], "truncated");
    check("header.stl", &stl[..40], "header");
    let ply = String::from_utf8(ply_ascii(&p, &t)).unwrap();
    check(
        "words.ply",
        ply.replace("3 0 1 2", "3 0 one 2").as_bytes(),
        "PLY",
    );
    check(
        "index.ply",
        ply.replace("3 0 1 2", "3 0 1 99").as_bytes(),
        "vertex 99",
    );
    let bin = ply_binary(&p, &t);
    check("short.ply", &bin[..bin.len() - 5], "PLY");
    check("empty.ply", b"", "PLY");
}

#[test]
fn ply_vertex_colours_are_interpolated_across_a_face() {
    // One quad facing +z: red on its left side, blue on its right.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("gradient.ply");
    std::fs::write(
        &path,
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
         property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n\
         element face 1\nproperty list uchar int vertex_indices\nend_header\n\
         -1 -1 0 255 0 0\n1 -1 0 0 0 255\n1 1 0 0 0 255\n-1 1 0 255 0 0\n4 0 1 2 3\n",
    )
    .unwrap();
    let mut spec = JobSpec::new(&path, dir.path().join("gradient.exr"));
    spec.camera.size = Some([64, 64]);
    spec.camera.from = Some([0.0, 0.0, 4.0]);
    spec.camera.at = Some([0.0, 0.0, 0.0]);
    spec.camera.up = Some([0.0, 1.0, 0.0]);
    spec.camera.fov = Some(40.0);
    spec.sampling.samples = Some(1);
    let job = Job::check(spec).unwrap();
    let loaded = job.load().unwrap();
    let plan = job.plan(&loaded).unwrap();
    let img = &job
        .render(&plan, &|_, _| {}, &CancelToken::new())
        .unwrap()
        .output
        .images[0];
    // Along the middle row, across the quad: red falls and blue rises
    // steadily, with many shades between (not one flat face colour, and not
    // two: the quad is cut into two triangles along a diagonal).
    let row: Vec<_> = (12..52).map(|x| img.get(x, 32)).collect();
    let share = |c: twinray::math::Vec3| c.z / (c.x + c.z);
    let shares: Vec<f32> = row.iter().map(|&c| share(c)).collect();
    assert!(
        shares[0] < 0.2 && shares[shares.len() - 1] > 0.8,
        "{shares:?}"
    );
    assert!(
        shares.windows(2).all(|w| w[1] >= w[0]),
        "not a gradient: {shares:?}"
    );
    let mut distinct: Vec<u32> = shares.iter().map(|s| (s * 1000.0) as u32).collect();
    distinct.dedup();
    assert!(distinct.len() > 20, "{} shades", distinct.len());
}

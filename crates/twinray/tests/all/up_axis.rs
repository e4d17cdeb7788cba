//! The up axis of a model file that does not say (OBJ, STL, PLY), guessed
//! from its base when `--up-axis` is not given, with a note; glTF is y-up.

use std::path::{Path, PathBuf};

use twinray::job::{CancelToken, Job, JobSpec, Level, UpAxisSpec};
use twinray::Image;

/// A rover, z up: a low body on four wheels, long in x, wide in y.
fn rover_z_up(dir: &Path) -> PathBuf {
    let boxes = [
        ([0.0, 0.0, 0.2], [4.0, 2.0, 0.8]),
        ([0.3, 0.0, 0.0], [0.9, 0.3, 0.5]),
        ([0.3, 1.7, 0.0], [0.9, 2.0, 0.5]),
        ([3.1, 0.0, 0.0], [3.7, 0.3, 0.5]),
        ([3.1, 1.7, 0.0], [3.7, 2.0, 0.5]),
    ];
    let mut text = String::new();
    for (b, (lo, hi)) in boxes.iter().enumerate() {
        for i in 0..8 {
            let pick = |k: usize, bit: usize| if i & bit == 0 { lo[k] } else { hi[k] };
            text += &format!("v {} {} {}\n", pick(0, 1), pick(1, 2), pick(2, 4));
        }
        let o = b * 8 + 1;
        for f in [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ] {
            text += &format!("f {} {} {} {}\n", o + f[0], o + f[1], o + f[2], o + f[3]);
        }
    }
    let path = dir.join("rover.obj");
    std::fs::write(&path, text).unwrap();
    path
}

fn husky() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/models/pybullet/husky/base_link.stl")
}

/// The image and the notes of a render of `scene` with `up`.
fn render(scene: &Path, up: UpAxisSpec) -> (Image, Vec<String>) {
    let mut spec = JobSpec::new(scene, "unused.exr");
    spec.camera.size = Some([48, 36]);
    spec.sampling.samples = Some(1);
    spec.studio.up_axis = up;
    let job = Job::check(spec).unwrap();
    let loaded = job.load().unwrap();
    let notes = loaded
        .messages
        .iter()
        .filter(|m| m.level == Level::Note)
        .map(|m| m.text.clone())
        .collect();
    let plan = job.plan(&loaded).unwrap();
    let out = job.render(&plan, &|_, _| {}, &CancelToken::new()).unwrap();
    (out.output.images.into_iter().next().unwrap(), notes)
}

#[test]
fn a_z_up_model_made_here_is_stood_on_its_wheels_with_a_note() {
    let dir = tempfile::tempdir().unwrap();
    let rover = rover_z_up(dir.path());
    let (auto, notes) = render(&rover, UpAxisSpec::Auto);
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(
        notes[0].contains("up axis z") && notes[0].contains("--up-axis y to override"),
        "{notes:?}"
    );
    let (z, z_notes) = render(&rover, UpAxisSpec::Z);
    let (y, _) = render(&rover, UpAxisSpec::Y);
    assert!(auto == z, "auto is not the z-up render");
    assert!(auto != y);
    // Given, the axis is not guessed: no note.
    assert!(z_notes.is_empty(), "{z_notes:?}");
}

#[test]
fn pybullets_husky_chassis_is_z_up() {
    let (auto, notes) = render(&husky(), UpAxisSpec::Auto);
    assert!(
        notes.len() == 1 && notes[0].contains("up axis z"),
        "{notes:?}"
    );
    assert!(auto == render(&husky(), UpAxisSpec::Z).0);
}

#[test]
fn gltf_is_y_up_without_a_guess() {
    let torus = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/models/gltf/torus.glb");
    let (auto, notes) = render(&torus, UpAxisSpec::Auto);
    assert!(notes.is_empty(), "{notes:?}");
    assert!(auto == render(&torus, UpAxisSpec::Y).0);
}

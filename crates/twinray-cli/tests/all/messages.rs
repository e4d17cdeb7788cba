//! What a newcomer reads: a mistake named in its own words, progress in a
//! log, and no warning that blames a flag the user did not set.

use std::process::Output;

// The video tests' helpers: the example scene, a path as text, and the binary
// run with its stderr a pipe.
use crate::video::{example, run, s};

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn a_video_without_frames_says_it_needs_frames() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["x.mp4", "x.mkv", "x.MOV"] {
        let out = dir.path().join(name);
        let r = run(&["render", s(&example()), "-o", s(&out)], &[]);
        let err = stderr(&r);
        assert!(!r.status.success(), "{err}");
        assert!(err.contains("a video needs --frames"), "{err}");
        assert!(!err.contains("unsupported output format"), "{err}");
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(!out.exists());
    }
    // Any other unknown extension is still just unknown.
    let r = run(
        &["render", s(&example()), "-o", s(&dir.path().join("x.gif"))],
        &[],
    );
    assert!(
        stderr(&r).contains("unsupported output format '.gif'"),
        "{}",
        stderr(&r)
    );
}

#[test]
fn a_directory_as_the_scene_says_it_is_a_directory() {
    let dir = tempfile::tempdir().unwrap();
    let scenes = dir.path().join("scenes.nff");
    std::fs::create_dir(&scenes).unwrap();
    for scene in [dir.path(), scenes.as_path()] {
        let r = run(
            &["render", s(scene), "-o", s(&dir.path().join("x.png"))],
            &[],
        );
        let err = stderr(&r);
        assert!(!r.status.success(), "{err}");
        assert!(err.contains("is a directory"), "{err}");
        assert!(!err.contains("file extension"), "{err}");
    }
}

#[test]
fn a_render_logged_to_a_file_prints_progress_lines() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("p.png");
    let scene = example();
    // Long enough for several lines at a tenth of a second each.
    let args = [
        "render",
        s(&scene),
        "-o",
        s(&out),
        "--size",
        "320x240",
        "--samples",
        "16",
        "--threads",
        "1",
    ];
    let every = [("TWINRAY_PROGRESS_SECONDS", "0.1")];
    let r = run(&args, &every);
    let err = stderr(&r);
    assert!(r.status.success(), "{err}");
    let lines: Vec<_> = err
        .lines()
        .filter(|l| l.starts_with("twinray: rendering"))
        .collect();
    assert!(!lines.is_empty(), "no progress line: {err}");
    assert!(
        lines.iter().all(|l| l.contains('%') && l.contains("eta")),
        "{lines:?}"
    );
    // No bar drawing on a file: no carriage returns, no escape sequences.
    assert!(!err.contains('\r') && !err.contains('\u{1b}'), "{err:?}");
    // -q: none.
    let mut quiet = args.to_vec();
    quiet.push("-q");
    let r = run(&quiet, &every);
    assert!(
        r.status.success() && stderr(&r).is_empty(),
        "{}",
        stderr(&r)
    );
}

#[test]
fn an_animation_logged_to_a_file_prints_progress_lines_with_the_frame() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("f_###.png");
    let r = run(
        &[
            "render",
            s(&example()),
            "-o",
            s(&out),
            "--frames",
            "0..3",
            "--orbit",
            "40",
            "--size",
            "160x120",
            "--samples",
            "4",
            "--threads",
            "1",
        ],
        &[("TWINRAY_PROGRESS_SECONDS", "0.05")],
    );
    let err = stderr(&r);
    assert!(r.status.success(), "{err}");
    assert!(
        err.lines()
            .any(|l| l.starts_with("twinray: frame ") && l.contains('%')),
        "no progress line: {err}"
    );
}

#[test]
fn the_automatic_rig_of_a_shot_does_not_blame_the_interaxial() {
    // 48 frames of a turntable: the shot's one rig is fitted to 16 of them
    // and goes beyond the budget on a few between (measured: 2).
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("f_##.png");
    let scene = example();
    let args = [
        "render",
        s(&scene),
        "-o",
        s(&out),
        "--frames",
        "0..47",
        "--orbit",
        "360",
        "--stereo",
        "--size",
        "64x48",
        "--samples",
        "1",
    ];
    let r = run(&args, &[]);
    let err = stderr(&r);
    assert!(r.status.success(), "{err}");
    assert!(!err.contains("warning"), "{err}");
    assert!(!err.contains("--interaxial"), "{err}");
    let notes: Vec<_> = err
        .lines()
        .filter(|l| l.contains("the shot's one rig"))
        .collect();
    assert_eq!(notes.len(), 1, "{err}");
    assert!(
        notes[0].contains("of 48 frames") && notes[0].contains("--rig per-frame"),
        "{err}"
    );
    // With the interaxial given, a frame beyond the budget is the user's to
    // change, and the warning says how.
    let mut given = args.to_vec();
    given.extend(["--interaxial", "0.6"]);
    let err = stderr(&run(&given, &[]));
    assert!(
        err.contains("warning: the rig's disparities")
            && err.contains("--interaxial auto fits them"),
        "{err}"
    );
}

#[test]
fn the_default_quilts_far_points_are_a_note_said_once() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("q.png");
    let r = run(
        &[
            "render",
            s(&example()),
            "-o",
            s(&out),
            "--layout",
            "quilt",
            "--quilt",
            "4x2",
            "--size",
            "120x160",
            "--samples",
            "1",
        ],
        &[],
    );
    let err = stderr(&r);
    assert!(r.status.success(), "{err}");
    assert!(!err.contains("warning"), "{err}");
    let notes: Vec<_> = err.lines().filter(|l| l.contains("far points")).collect();
    assert_eq!(notes.len(), 1, "{err}");
    assert!(
        notes[0].starts_with("twinray: note:") && notes[0].contains("Looking Glass"),
        "{err}"
    );
}

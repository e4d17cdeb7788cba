//! Animation through the command line: frames equal the stills their specs
//! describe, the rig of a shot holds still, path files report file:line,
//! and tiles of a still merge into the one-machine image bit for bit.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use tempfile::TempDir;
use twinray::animation::motion::orbit;
use twinray::job::{Job, JobSpec};

fn example() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes/example.nff")
}

fn run(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_twinray"))
        .args(args)
        .output()
        .expect("the binary runs")
}

/// Runs the binary; panics with its stderr unless it exits 0. Returns stderr.
fn twinray(args: &[&str]) -> String {
    let out = run(args);
    assert!(
        out.status.success(),
        "twinray {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Runs the binary and checks that it fails saying `says`.
fn assert_refused(args: &[&str], says: &str) {
    let r = run(args);
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(!r.status.success() && err.contains(says), "{args:?}: {err}");
}

fn bytes(p: &Path) -> Vec<u8> {
    std::fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn an_orbit_equals_stills_from_the_orbits_positions() {
    let dir = TempDir::new().unwrap();
    let scene = example();
    let pattern = dir.path().join("orbit_####.png");
    let common = [
        "--size",
        "64x48",
        "--stereo",
        "--interaxial",
        "0.2",
        "--layout",
        "sbs",
        "-q",
    ];
    let mut args = vec!["render", s(&scene), "-o", s(&pattern)];
    args.extend(["--frames", "0..7", "--orbit", "360"]);
    args.extend(common);
    twinray(&args);

    // The positions of a turntable: frame i of 8 turned by 45 i degrees
    // about the scene's up axis through its 'at' point.
    let job = Job::check(JobSpec::new(&scene, dir.path().join("x.png"))).unwrap();
    let vp = job.load().unwrap().scene.viewpoint.clone();
    let mut froms = Vec::new();
    for i in 0..8u32 {
        let from = orbit(&vp, 45.0 * f64::from(i));
        let from = format!("{},{},{}", from.x, from.y, from.z);
        let still = dir.path().join(format!("still_{i}.png"));
        let from_flag = format!("--from={from}");
        let mut args = vec!["render", s(&scene), "-o", s(&still), &from_flag];
        args.extend(common);
        twinray(&args);
        let frame = dir.path().join(format!("orbit_{i:04}.png"));
        assert_eq!(bytes(&frame), bytes(&still), "frame {i} (from {from})");
        froms.push(from);
    }
    // The camera did move: eight different frames.
    let mut frames: Vec<Vec<u8>> = (0..8)
        .map(|i| bytes(&dir.path().join(format!("orbit_{i:04}.png"))))
        .collect();
    frames.sort();
    frames.dedup();
    assert_eq!(frames.len(), 8, "{froms:?}");
    assert!(!dir.path().join("orbit_0008.png").exists());
}

/// The interaxial of each frame, from the `-v` rig lines.
fn interaxials(stderr: &str) -> Vec<String> {
    stderr
        .lines()
        .filter_map(|l| l.strip_prefix("rig: 2 views, interaxial "))
        .map(|l| l.split(',').next().unwrap_or("").to_string())
        .collect()
}

#[test]
fn the_automatic_rig_is_chosen_once_per_shot_unless_asked_per_frame() {
    let dir = TempDir::new().unwrap();
    let scene = example();
    let out = dir.path().join("f.png");
    let mut args = vec!["render", s(&scene), "-o", s(&out), "-v", "-q"];
    args.extend(["--frames", "0..5", "--orbit", "150", "--stereo"]);
    args.extend(["--size", "48x36", "--samples", "1"]);
    let per_shot = interaxials(&twinray(&args));
    assert_eq!(per_shot.len(), 6, "{per_shot:?}");
    assert!(per_shot.iter().all(|b| *b == per_shot[0]), "{per_shot:?}");

    args.extend(["--rig", "per-frame"]);
    let per_frame = interaxials(&twinray(&args));
    assert_eq!(per_frame.len(), 6);
    let mut distinct = per_frame.clone();
    distinct.sort();
    distinct.dedup();
    assert!(
        distinct.len() > 1,
        "per-frame rigs all equal: {per_frame:?}"
    );
    // The shot's rig fits every sampled frame: no larger than the smallest
    // per-frame choice (within the f32 printing).
    let shot: f32 = per_shot[0].parse().unwrap();
    let least = per_frame
        .iter()
        .map(|b| b.parse::<f32>().unwrap())
        .fold(f32::INFINITY, f32::min);
    assert!(
        shot <= least * (1.0 + 1e-5),
        "shot {shot}, frames {per_frame:?}"
    );
    assert!(dir.path().join("f_0005_R.png").exists());
}

#[test]
fn a_path_file_moves_the_camera_and_its_errors_name_file_and_line() {
    let dir = TempDir::new().unwrap();
    let scene = example();
    let path = dir.path().join("cam.path");
    std::fs::write(
        &path,
        "# keyframes\n0 from 0,-8,2 at 0,0,0 up 0,0,1\n4 from 8,0,2 at 0,0,0 up 0,0,1\n",
    )
    .unwrap();
    let out = dir.path().join("p_{frame}.png");
    let mut args = vec!["render", s(&scene), "-o", s(&out), "-q"];
    args.extend(["--frames", "0..4", "--path", s(&path), "--size", "32x24"]);
    twinray(&args);
    // Keyframe 4 is a still from its own camera.
    let still = dir.path().join("still.png");
    let mut sargs = vec![
        "render",
        s(&scene),
        "-o",
        s(&still),
        "-q",
        "--size",
        "32x24",
    ];
    sargs.extend(["--from", "8,0,2", "--at", "0,0,0", "--up", "0,0,1"]);
    twinray(&sargs);
    assert_eq!(bytes(&dir.path().join("p_4.png")), bytes(&still));
    assert_ne!(
        bytes(&dir.path().join("p_0.png")),
        bytes(&dir.path().join("p_2.png"))
    );

    std::fs::write(&path, "0 from 0,-8,2 at 0,0,0\n\n3 from 1,2 at 0,0,0\n").unwrap();
    let bad = run(&args);
    assert!(!bad.status.success());
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(
        err.contains(&format!("{}:3:", path.display())) && err.contains("X,Y,Z"),
        "{err}"
    );
}

#[test]
fn frame_flags_are_checked() {
    let scene = example();
    let dir = TempDir::new().unwrap();
    let out = dir.path().join("f.png");
    for (extra, says) in [
        (vec!["--frames", "5..2"], "before the first"),
        (vec!["--frames", "0..3", "--fps", "0"], "--fps"),
        (vec!["--orbit", "90"], "--frames"),
        (vec!["--frames", "0..1", "--stats", "s.json"], "--stats"),
        (vec!["--frames", "0..1", "--tiles", "2"], "--tiles"),
        (
            vec!["--frames", "0..1", "--animation", "Walk"],
            "has no glTF animations",
        ),
    ] {
        let mut args = vec!["render", s(&scene), "-o", s(&out), "-q"];
        args.extend(extra.iter().copied());
        assert_refused(&args, says);
    }
}

#[test]
fn skip_existing_renders_only_the_missing_frames() {
    let dir = TempDir::new().unwrap();
    let scene = example();
    let out = dir.path().join("r_##.png");
    let mut args = vec!["render", s(&scene), "-o", s(&out)];
    args.extend(["--frames", "0..2", "--orbit", "30", "--size", "24x18"]);
    twinray(&args);
    std::fs::write(dir.path().join("r_00.png"), b"not rendered again").unwrap();
    std::fs::remove_file(dir.path().join("r_02.png")).unwrap();
    args.push("--skip-existing");
    let said = twinray(&args);
    assert!(said.contains("frame 0: done already"), "{said}");
    assert_eq!(bytes(&dir.path().join("r_00.png")), b"not rendered again");
    assert!(dir.path().join("r_02.png").exists());
    assert!(!said.contains("r_00.png"), "{said}");
    assert!(said.contains("r_02.png"), "{said}");
}

/// Renders `flags` whole and in `tiles` tiles, merges, and compares bytes.
fn tiles_merge_to_the_whole(flags: &[&str], tiles: u32, names: &[&str]) {
    let dir = TempDir::new().unwrap();
    let scene = example();
    let whole = dir.path().join("whole.png");
    let mut args = vec!["render", s(&scene), "-o", s(&whole), "-q"];
    args.extend(flags);
    twinray(&args);

    let tiled = dir.path().join("t.png");
    let n = tiles.to_string();
    let mut args = vec!["render", s(&scene), "-o", s(&tiled), "-q", "--tiles", &n];
    args.extend(flags);
    twinray(&args);
    for suffix in names {
        let mut inputs: Vec<PathBuf> = (0..tiles)
            .rev()
            .map(|k| dir.path().join(format!("t_tile{k}of{tiles}{suffix}.png")))
            .collect();
        inputs
            .iter()
            .for_each(|p| assert!(p.exists(), "{}", p.display()));
        let merged = dir.path().join(format!("merged{suffix}.png"));
        let mut margs = vec!["merge", "-o", s(&merged)];
        margs.extend(inputs.iter().map(|p| s(p)));
        twinray(&margs);
        let expected = dir.path().join(format!("whole{suffix}.png"));
        assert_eq!(bytes(&merged), bytes(&expected), "{flags:?} {suffix}");
        // An incomplete set is refused.
        inputs.pop();
        let mut margs = vec!["merge", "-o", s(&merged)];
        margs.extend(inputs.iter().map(|p| s(p)));
        let r = run(&margs);
        assert!(!r.status.success());
    }
}

#[test]
fn tiles_merge_into_the_one_machine_image() {
    // Adaptive (the default), a wide filter whose samples reach across the
    // tiles' edges, the SPD corners, pixel centres; stereo layouts.
    tiles_merge_to_the_whole(&["--size", "61x45"], 3, &[""]);
    tiles_merge_to_the_whole(
        &["--size", "50x40", "--samples", "4", "--filter", "gaussian"],
        4,
        &[""],
    );
    tiles_merge_to_the_whole(&["--size", "40x33", "--spd"], 2, &[""]);
    tiles_merge_to_the_whole(
        &["--size", "40x32", "--stereo", "--layout", "sbs"],
        4,
        &[""],
    );
    tiles_merge_to_the_whole(
        &["--size", "40x32", "--stereo", "--samples", "1"],
        2,
        &["_L", "_R"],
    );
}

#[test]
fn one_tile_alone_and_tile_errors() {
    let dir = TempDir::new().unwrap();
    let scene = example();
    let out = dir.path().join("one.png");
    let mut args = vec!["render", s(&scene), "-o", s(&out), "-q"];
    args.extend(["--size", "40x40", "--tiles", "3", "--tile", "1"]);
    twinray(&args);
    let files: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(files, vec!["one_tile1of3.png".to_string()]);
    for (extra, says) in [
        (vec!["--tiles", "3", "--tile", "3"], "numbered 0 to N-1"),
        (vec!["--tiles", "9"], "at most 5 tiles"),
        (
            vec!["--tiles", "2", "--stereo", "--layout", "tb"],
            "--layout tb",
        ),
    ] {
        let mut args = vec!["render", s(&scene), "-o", s(&out), "-q", "--size", "40x40"];
        args.extend(extra.iter().copied());
        assert_refused(&args, says);
    }
}

#[test]
fn a_share_of_the_frames_equals_those_frames_of_the_whole_shot() {
    // The automatic stereo rig of the shot and the orbit's angles are those
    // of the whole range, whichever frames a machine renders.
    let (whole, share) = (TempDir::new().unwrap(), TempDir::new().unwrap());
    let scene = example();
    let flags = [
        "--frames", "0..5", "--orbit", "120", "--stereo", "--layout", "sbs", "--size", "40x30",
        "-q",
    ];
    let out = whole.path().join("f_#.png");
    let mut args = vec!["render", s(&scene), "-o", s(&out)];
    args.extend(flags);
    twinray(&args);
    let out = share.path().join("f_#.png");
    let mut args = vec!["render", s(&scene), "-o", s(&out), "--only", "4..5"];
    args.extend(flags);
    twinray(&args);
    for f in [4, 5] {
        let name = format!("f_{f}.png");
        assert_eq!(
            bytes(&share.path().join(&name)),
            bytes(&whole.path().join(&name)),
            "{name}"
        );
    }
    assert!(!share.path().join("f_3.png").exists());
    let mut args = vec!["render", s(&scene), "-o", s(&out), "--only", "4..9"];
    args.extend(flags);
    let r = run(&args);
    assert!(String::from_utf8_lossy(&r.stderr).contains("not within"));
}

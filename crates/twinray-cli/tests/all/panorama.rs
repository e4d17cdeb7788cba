//! Panoramas through the command line: `--projection` and its layouts,
//! the flags refused with it, the job spec, the `-v` report of the angular
//! disparities, and the metadata players read back (exiftool: GPano and
//! the VR180 photo's right eye; ffprobe: the MP4's spherical and stereo
//! side data).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;
use tempfile::TempDir;

use crate::video::probe;

fn example() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes/example.nff")
}

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

fn run(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_twinray"))
        .args(args)
        .output()
        .expect("the binary runs")
}

fn ok(args: &[&str]) -> String {
    let r = run(args);
    let stderr = String::from_utf8_lossy(&r.stderr).into_owned();
    assert!(r.status.success(), "{args:?}: {stderr}");
    stderr
}

/// A failure of one `twinray: ...` line; returns it.
fn refused(args: &[&str]) -> String {
    let r = run(args);
    let stderr = String::from_utf8_lossy(&r.stderr).into_owned();
    assert!(!r.status.success(), "{args:?} was accepted");
    assert!(!stderr.contains("panicked"), "{stderr}");
    stderr
}

fn size_of(path: &Path) -> (u32, u32) {
    let img = twinray::output::encode::read_image(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    (img.width, img.height)
}

const INSIDE: [&str; 4] = ["--from", "0,-2.2,1.0", "--at", "0,0,0.8"];

#[test]
fn ods_top_bottom_and_vr180_side_by_side_have_their_sizes() {
    let dir = TempDir::new().unwrap();
    let ods = dir.path().join("ods_TB.png");
    let scene = example();
    let mut args = vec!["render", s(&scene), "-o", s(&ods), "-q"];
    args.extend([
        "--projection",
        "ods",
        "--stereo",
        "--layout",
        "tb",
        "--size",
        "64x32",
    ]);
    args.extend(INSIDE);
    ok(&args);
    assert_eq!(size_of(&ods), (64, 64));
    for projection in ["vr180", "vr180-fisheye"] {
        let out = dir.path().join(format!("{projection}_LR.png"));
        let mut args = vec!["render", s(&scene), "-o", s(&out), "-q"];
        args.extend(["--projection", projection, "--stereo", "--layout", "sbs"]);
        args.extend(["--size", "32x32"]);
        ok(&args);
        assert_eq!(size_of(&out), (64, 32));
    }
    // Without --size: the scene's height (480), twice it across for 360°.
    let out = dir.path().join("mono.png");
    ok(&[
        "render",
        s(&scene),
        "-o",
        s(&out),
        "-q",
        "--projection",
        "equirect",
        "--samples",
        "1",
    ]);
    assert_eq!(size_of(&out), (960, 480));
}

#[test]
fn flags_of_flat_rigs_are_refused_with_panoramas() {
    let scene = example();
    let base = [
        "render",
        s(&scene),
        "-o",
        "/nonexistent/x.png",
        "--size",
        "16x8",
    ];
    for (extra, says) in [
        (&["--projection", "ods", "--stereo", "--fast"][..], "--fast"),
        (
            &["--projection", "ods", "--stereo", "--convergence", "3"],
            "--convergence",
        ),
        (
            &["--projection", "ods", "--views", "3"],
            "one view or a stereo pair",
        ),
        (
            &["--projection", "equirect", "--stereo"],
            "--projection ods",
        ),
        (
            &[
                "--projection",
                "vr180",
                "--stereo",
                "--depth-budget",
                "-1%,2%",
            ],
            "--angular-budget",
        ),
        (
            &["--projection", "vr180", "--pole-merge", "50,70"],
            "--projection ods",
        ),
        (&["--angular-budget", "1", "--stereo"], "panoramas"),
        (
            &["--projection", "ods", "--stereo", "--angular-budget", "45"],
            "at most 10",
        ),
        (
            &["--projection", "ods", "--stereo", "--pole-merge", "80,70"],
            "FROM <= TO",
        ),
    ] {
        let mut args = base.to_vec();
        args.extend(extra);
        let err = refused(&args);
        assert!(err.contains(says), "{extra:?}: {err}");
    }
}

#[test]
fn the_job_spec_carries_the_projection_and_the_report_gives_the_angles() {
    let dir = TempDir::new().unwrap();
    let scene = example();
    let job = dir.path().join("job.json");
    let out = dir.path().join("pano.png");
    let mut args = vec!["render", s(&scene), "-o", s(&out), "--print-job"];
    args.extend([
        "--projection",
        "ods",
        "--stereo",
        "--layout",
        "tb",
        "--size",
        "64x32",
    ]);
    args.extend([
        "--pole-merge",
        "55,70",
        "--angular-budget",
        "0.5",
        "--units",
        "m",
    ]);
    args.extend(INSIDE);
    let r = run(&args);
    assert!(r.status.success());
    let spec: Value = serde_json::from_slice(&r.stdout).expect("JSON");
    assert_eq!(spec["camera"]["projection"], "ods");
    assert_eq!(
        spec["camera"]["pole_merge"],
        serde_json::json!([55.0, 70.0])
    );
    assert_eq!(spec["rig"]["angular_budget"], 0.5);
    assert_eq!(spec["rig"]["units"], "m");
    std::fs::write(&job, &r.stdout).unwrap();
    let report = ok(&["render", "--job", s(&job), "-v"]);
    assert_eq!(size_of(&out), (64, 64));
    assert!(report.contains("panorama (ods): 2 eyes, IPD"), "{report}");
    assert!(
        report.contains("angular disparity: near 0.500°"),
        "{report}"
    );
    assert!(report.contains("scene unit m (given)"), "{report}");
    // The eyes' 64 mm at a scene in metres, far from everything: the
    // budget is not reached.
    let far = ["--from", "0,-40,1", "--at", "0,0,0.8"];
    let mut args = vec![
        "render",
        s(&scene),
        "-o",
        s(&out),
        "-v",
        "--projection",
        "ods",
    ];
    args.extend([
        "--stereo", "--layout", "tb", "--size", "64x32", "--units", "m",
    ]);
    args.extend(far);
    let report = ok(&args);
    assert!(
        report.contains("IPD 0.064000 = 64.0 mm (the eyes' 64 mm"),
        "{report}"
    );
}

#[test]
#[cfg_attr(
    missing_exiftool,
    ignore = "needs exiftool on PATH (apt-get install libimage-exiftool-perl)"
)]
fn jpeg_panoramas_carry_gpano_and_the_vr180_right_eye() {
    let dir = TempDir::new().unwrap();
    let scene = example();
    let out = dir.path().join("vr.jpg");
    let mut args = vec![
        "render",
        s(&scene),
        "-o",
        s(&out),
        "-q",
        "--projection",
        "vr180",
    ];
    args.extend(["--stereo", "--size", "48x48"]);
    args.extend(INSIDE);
    ok(&args);
    let (left, right) = (dir.path().join("vr_L.jpg"), dir.path().join("vr_R.jpg"));
    let exif = Command::new("exiftool")
        .args(["-j", "-XMP-GPano:all", "-XMP-GImage:ImageMimeType"])
        .arg(&left)
        .output()
        .unwrap();
    let v: Value = serde_json::from_slice(&exif.stdout).expect("exiftool -j prints JSON");
    let tags = &v[0];
    assert_eq!(tags["ProjectionType"], "equirectangular", "{tags}");
    assert_eq!(tags["FullPanoWidthPixels"], 96, "{tags}");
    assert_eq!(tags["CroppedAreaImageWidthPixels"], 48, "{tags}");
    assert_eq!(tags["CroppedAreaLeftPixels"], 24, "{tags}");
    // The right eye comes back whole from the left eye's file.
    let data = Command::new("exiftool")
        .args(["-b", "-XMP-GImage:ImageData"])
        .arg(&left)
        .output()
        .unwrap();
    let right_bytes = std::fs::read(&right).unwrap();
    assert!(
        data.stdout == right_bytes,
        "the right eye read back: {} bytes, the file {} bytes",
        data.stdout.len(),
        right_bytes.len()
    );
    // The right eye's own file: GPano alone.
    let exif = Command::new("exiftool")
        .args(["-j", "-XMP-GPano:all"])
        .arg(&right)
        .output()
        .unwrap();
    let v: Value = serde_json::from_slice(&exif.stdout).unwrap();
    assert_eq!(v[0]["ProjectionType"], "equirectangular");
    // An equirect mono JPEG: the whole panorama.
    let mono = dir.path().join("mono.jpg");
    ok(&[
        "render",
        s(&scene),
        "-o",
        s(&mono),
        "-q",
        "--projection",
        "equirect",
        "--size",
        "64x32",
    ]);
    let exif = Command::new("exiftool")
        .args(["-j", "-XMP-GPano:all"])
        .arg(&mono)
        .output()
        .unwrap();
    let v: Value = serde_json::from_slice(&exif.stdout).unwrap();
    assert_eq!(v[0]["FullPanoWidthPixels"], 64);
    assert_eq!(v[0]["CroppedAreaImageHeightPixels"], 32);
}

#[test]
#[cfg_attr(
    missing_ffmpeg,
    ignore = "needs ffmpeg and ffprobe on PATH (apt-get install ffmpeg)"
)]
fn panorama_videos_carry_spherical_and_stereo_side_data() {
    let dir = TempDir::new().unwrap();
    let scene = example();
    // ffprobe names a cropped equirectangular panorama "tiled", and gives
    // its bounds in pixels of the whole frame.
    for (projection, layout, size, stereo, kind) in [
        (
            "ods",
            "tb",
            "64x32",
            Some("top and bottom"),
            "equirectangular",
        ),
        (
            "vr180",
            "sbs",
            "32x32",
            Some("side by side"),
            "tiled equirectangular",
        ),
        ("equirect", "separate", "64x32", None, "equirectangular"),
    ] {
        let out = dir.path().join(format!("{projection}.mp4"));
        let mut args = vec![
            "render",
            s(&scene),
            "-o",
            s(&out),
            "-q",
            "--projection",
            projection,
        ];
        args.extend([
            "--size",
            size,
            "--frames",
            "0..2",
            "--orbit",
            "10",
            "--samples",
            "1",
        ]);
        if stereo.is_some() {
            args.extend(["--stereo", "--layout", layout]);
        }
        ok(&args);
        let p = probe(&out);
        assert!(
            p.contains("side_data_type=Spherical Mapping"),
            "{projection}: {p}"
        );
        assert!(
            p.contains(&format!("projection={kind}\n")),
            "{projection}: {p}"
        );
        if projection == "vr180" {
            // A 64-pixel frame is the middle half of a 128-pixel panorama
            // (ffprobe's fixed-point arithmetic rounds the sides apart by one).
            let bound = |key: &str| -> i64 {
                let line = p.lines().find_map(|l| l.strip_prefix(key)).unwrap_or("");
                line.parse().unwrap_or_else(|_| panic!("no {key} in {p}"))
            };
            let (left, right) = (bound("bound_left="), bound("bound_right="));
            assert!(
                left + right == 64 && (left - 32).abs() <= 1,
                "{left}, {right}"
            );
        }
        match stereo {
            Some(kind) => {
                assert!(p.contains("side_data_type=Stereo 3D"), "{projection}: {p}");
                assert!(p.contains(&format!("type={kind}")), "{projection}: {p}");
            }
            None => assert!(!p.contains("Stereo 3D"), "{projection}: {p}"),
        }
        assert!(p.contains("nb_frames=3"), "{projection}: {p}");
    }
}

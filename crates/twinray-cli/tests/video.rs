//! Video outputs through ffmpeg: ffprobe reads the frame count, the size
//! and the stereo metadata; a failed encode leaves no file. Without ffmpeg
//! the tests that need it print a notice and skip, except under CI
//! (CI=true), which installs it (.ci/run).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use tempfile::TempDir;

fn example() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes/example.nff")
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn run(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_twinray"));
    cmd.args(args);
    for (k, v) in env {
        cmd.env(k, v);
    }
    cmd.output().expect("the binary runs")
}

/// Whether ffmpeg and ffprobe can run; under CI their absence fails.
fn ffmpeg_present() -> bool {
    let runs = |p: &str| {
        Command::new(p)
            .arg("-version")
            .output()
            .is_ok_and(|o| o.status.success())
    };
    if runs("ffmpeg") && runs("ffprobe") {
        return true;
    }
    assert!(
        std::env::var("CI").as_deref() != Ok("true"),
        "ffmpeg/ffprobe missing under CI: .ci/run installs them"
    );
    eprintln!("notice: ffmpeg or ffprobe not found: video test skipped (apt-get install ffmpeg)");
    false
}

/// Renders an animation to `out` with `flags`; panics on failure.
fn render_video(out: &Path, flags: &[&str]) {
    let scene = example();
    let mut args = vec!["render", s(&scene), "-o", s(out), "-q"];
    args.extend(flags);
    let r = run(&args, &[]);
    assert!(
        r.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&r.stderr)
    );
}

/// What ffprobe says of the video stream: `key=value` lines.
fn probe(path: &Path) -> String {
    let out = Command::new("ffprobe")
        .args(["-v", "error", "-count_frames", "-select_streams", "v:0"])
        .args(["-show_streams", "-show_format"])
        .arg(path)
        .output()
        .expect("ffprobe runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn value<'a>(probe: &'a str, key: &str) -> &'a str {
    probe
        .lines()
        .find_map(|l| l.strip_prefix(key).and_then(|r| r.strip_prefix('=')))
        .unwrap_or_else(|| panic!("no {key} in\n{probe}"))
}

/// No file but the expected ones in `dir` (no temporary left behind).
fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

const STEREO: [&str; 7] = [
    "--frames", "0..5", "--orbit", "60", "--stereo", "--size", "64x48",
];

#[test]
fn side_by_side_mp4_has_its_frames_size_and_st3d() {
    if !ffmpeg_present() {
        return;
    }
    let dir = TempDir::new().unwrap();
    let out = dir.path().join("sbs.mp4");
    let mut flags = STEREO.to_vec();
    flags.extend(["--layout", "sbs", "--fps", "30"]);
    render_video(&out, &flags);
    let p = probe(&out);
    assert_eq!(value(&p, "nb_read_frames"), "6", "{p}");
    assert_eq!(value(&p, "width"), "128");
    assert_eq!(value(&p, "height"), "48");
    assert_eq!(value(&p, "codec_name"), "h264");
    // Remuxed from Matroska, the frames keep its millisecond timestamps:
    // 30 fps within them.
    let rate = value(&p, "avg_frame_rate");
    let (num, den) = rate.split_once('/').unwrap();
    let fps = num.parse::<f64>().unwrap() / den.parse::<f64>().unwrap();
    assert!((fps - 30.0).abs() < 0.3, "{rate}");
    assert_eq!(value(&p, "side_data_type"), "Stereo 3D", "{p}");
    assert_eq!(value(&p, "type"), "side by side");
    // The box itself, as players that read MP4 stereo metadata look for it.
    let bytes = std::fs::read(&out).unwrap();
    assert!(bytes.windows(4).any(|w| w == b"st3d"), "no st3d box");
    assert_eq!(files_in(dir.path()), vec!["sbs.mp4"]);
}

#[test]
fn top_bottom_mkv_has_stereo_mode() {
    if !ffmpeg_present() {
        return;
    }
    let dir = TempDir::new().unwrap();
    let out = dir.path().join("tb.mkv");
    let mut flags = STEREO.to_vec();
    flags.extend(["--layout", "tb"]);
    render_video(&out, &flags);
    let p = probe(&out);
    assert_eq!(value(&p, "width"), "64");
    assert_eq!(value(&p, "height"), "96");
    assert_eq!(value(&p, "TAG:stereo_mode"), "top_bottom", "{p}");
    assert_eq!(value(&p, "type"), "top and bottom");
    // Matroska counts frames only by decoding them.
    assert_eq!(value(&p, "nb_read_frames"), "6");
}

#[test]
fn anaglyph_and_quilt_videos_are_plain_pictures() {
    if !ffmpeg_present() {
        return;
    }
    let dir = TempDir::new().unwrap();
    let out = dir.path().join("ana.mp4");
    let mut flags = STEREO.to_vec();
    flags.extend(["--layout", "anaglyph"]);
    render_video(&out, &flags);
    let p = probe(&out);
    assert_eq!(value(&p, "width"), "64");
    assert!(!p.contains("Stereo 3D"), "{p}");
    assert!(!std::fs::read(&out)
        .unwrap()
        .windows(4)
        .any(|w| w == b"st3d"));

    let out = dir.path().join("quilt.mp4");
    render_video(
        &out,
        &[
            "--frames", "0..2", "--orbit", "20", "--layout", "quilt", "--quilt", "2x2", "--size",
            "16x24",
        ],
    );
    let p = probe(&out);
    assert_eq!(value(&p, "nb_read_frames"), "3");
    assert_eq!((value(&p, "width"), value(&p, "height")), ("32", "48"));
}

#[test]
fn a_failed_encode_leaves_no_file_and_says_why() {
    // A stand-in ffmpeg that answers -version, reads a little and fails.
    let dir = TempDir::new().unwrap();
    let fake = dir.path().join("fake-ffmpeg");
    std::fs::write(
        &fake,
        "#!/bin/sh\n[ \"$1\" = -version ] && exit 0\nhead -c 100 >/dev/null\necho 'encoder exploded' >&2\nexit 1\n",
    )
    .unwrap();
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&fake, std::fs::Permissions::from_mode(0o755)).unwrap();
    }
    let videos = dir.path().join("out");
    std::fs::create_dir(&videos).unwrap();
    let out = videos.join("v.mp4");
    let scene = example();
    let mut args = vec!["render", s(&scene), "-o", s(&out), "-q"];
    args.extend(STEREO);
    args.extend(["--layout", "sbs"]);
    let r = run(&args, &[("TWINRAY_FFMPEG", s(&fake))]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(!r.status.success());
    assert!(err.contains("encoder exploded"), "{err}");
    assert!(files_in(&videos).is_empty(), "{:?}", files_in(&videos));

    let r = run(&args, &[("TWINRAY_FFMPEG", "/nonexistent/ffmpeg")]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(!r.status.success() && err.contains("needs ffmpeg"), "{err}");
    assert!(files_in(&videos).is_empty());
}

#[test]
fn a_video_needs_one_picture_a_frame() {
    let dir = TempDir::new().unwrap();
    let out = dir.path().join("v.mp4");
    let scene = example();
    let mut args = vec!["render", s(&scene), "-o", s(&out), "-q"];
    args.extend(STEREO);
    let r = run(&args, &[]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(
        !r.status.success() && err.contains("one picture a frame"),
        "{err}"
    );
}

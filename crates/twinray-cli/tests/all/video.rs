//! Video outputs through ffmpeg: ffprobe reads the frame count, the size
//! and the stereo metadata; a failed encode leaves no file. Where ffmpeg or
//! ffprobe is missing, the tests that need them are ignored with the reason
//! (the package's build.rs looks), except under CI (CI=true), which
//! installs them (.ci/run) and fails without them.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use tempfile::TempDir;

pub(crate) fn example() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes/example.nff")
}

pub(crate) fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

pub(crate) fn run(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_twinray"));
    cmd.args(args);
    for (k, v) in env {
        cmd.env(k, v);
    }
    cmd.output().expect("the binary runs")
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

/// What ffprobe says of the video stream, side data included: `key=value`
/// lines.
pub(crate) fn probe(path: &Path) -> String {
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

/// Checks a side-by-side MP4 of `STEREO` (6 frames, 64x48 a view) made
/// with `codec`: frames, size, the Stereo 3D side data and the `st3d` box
/// itself, as players that read MP4 stereo metadata look for it. Returns
/// what ffprobe said.
fn assert_side_by_side_mp4(out: &Path, codec: &str) -> String {
    let p = probe(out);
    assert_eq!(value(&p, "codec_name"), codec, "{p}");
    assert_eq!(value(&p, "nb_read_frames"), "6", "{p}");
    assert_eq!((value(&p, "width"), value(&p, "height")), ("128", "48"));
    assert_eq!(value(&p, "side_data_type"), "Stereo 3D", "{p}");
    assert_eq!(value(&p, "type"), "side by side");
    let bytes = std::fs::read(out).unwrap();
    assert!(bytes.windows(4).any(|w| w == b"st3d"), "no st3d box");
    p
}

/// Checks a top-bottom Matroska file of `STEREO` made with `codec`.
fn assert_top_bottom_mkv(out: &Path, codec: &str) {
    let p = probe(out);
    assert_eq!(value(&p, "codec_name"), codec, "{p}");
    assert_eq!((value(&p, "width"), value(&p, "height")), ("64", "96"));
    assert_eq!(value(&p, "TAG:stereo_mode"), "top_bottom", "{p}");
    assert_eq!(value(&p, "type"), "top and bottom");
    // Matroska counts frames only by decoding them.
    assert_eq!(value(&p, "nb_read_frames"), "6");
}

#[test]
#[cfg_attr(
    missing_ffmpeg,
    ignore = "needs ffmpeg and ffprobe on PATH (apt-get install ffmpeg)"
)]
fn side_by_side_mp4_has_its_frames_size_and_st3d() {
    let dir = TempDir::new().unwrap();
    let out = dir.path().join("sbs.mp4");
    let mut flags = STEREO.to_vec();
    flags.extend(["--layout", "sbs", "--fps", "30"]);
    render_video(&out, &flags);
    let p = assert_side_by_side_mp4(&out, "h264");
    // Remuxed from Matroska, the frames keep its millisecond timestamps:
    // 30 fps within them.
    let rate = value(&p, "avg_frame_rate");
    let (num, den) = rate.split_once('/').unwrap();
    let fps = num.parse::<f64>().unwrap() / den.parse::<f64>().unwrap();
    assert!((fps - 30.0).abs() < 0.3, "{rate}");
    assert_eq!(files_in(dir.path()), vec!["sbs.mp4"]);
}

#[test]
#[cfg_attr(
    missing_ffmpeg,
    ignore = "needs ffmpeg and ffprobe on PATH (apt-get install ffmpeg)"
)]
fn top_bottom_mkv_has_stereo_mode() {
    let dir = TempDir::new().unwrap();
    let out = dir.path().join("tb.mkv");
    let mut flags = STEREO.to_vec();
    flags.extend(["--layout", "tb"]);
    render_video(&out, &flags);
    assert_top_bottom_mkv(&out, "h264");
}

#[test]
#[cfg_attr(
    missing_ffmpeg,
    ignore = "needs ffmpeg and ffprobe on PATH (apt-get install ffmpeg)"
)]
fn anaglyph_and_quilt_videos_are_plain_pictures() {
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

    // A quilt video is named with its grid and the views' aspect, which
    // Looking Glass software reads from the name: 16x24 views, 0.6667.
    let quilt = [
        "--frames", "0..2", "--orbit", "20", "--layout", "quilt", "--quilt", "2x2", "--size",
        "16x24",
    ];
    render_video(&dir.path().join("quilt.mp4"), &quilt);
    let out = dir.path().join("quilt_qs2x2a0.6667.mp4");
    let p = probe(&out);
    assert_eq!(value(&p, "nb_read_frames"), "3");
    assert_eq!((value(&p, "width"), value(&p, "height")), ("32", "48"));
    assert_eq!(
        files_in(dir.path()),
        vec!["ana.mp4", "quilt_qs2x2a0.6667.mp4"]
    );
    // A name that carries the suffix already keeps it once; a device preset
    // gives its own grid (Looking Glass Go: 11x6 views of aspect 0.5625).
    render_video(&out, &quilt);
    render_video(
        &dir.path().join("go.mkv"),
        &[
            "--frames", "0..1", "--layout", "quilt", "--quilt", "go", "--size", "18x32",
        ],
    );
    assert_eq!(
        files_in(dir.path()),
        vec!["ana.mp4", "go_qs11x6a0.5625.mkv", "quilt_qs2x2a0.6667.mp4"]
    );
    let p = probe(&dir.path().join("go_qs11x6a0.5625.mkv"));
    assert_eq!((value(&p, "width"), value(&p, "height")), ("198", "192"));
}

#[test]
fn a_failed_encode_leaves_no_file_and_says_why() {
    // A stand-in ffmpeg that answers -version, reads a little and fails.
    let dir = TempDir::new().unwrap();
    let fake = dir.path().join("fake-ffmpeg");
    std::fs::write(
        &fake,
        "#!/bin/sh\n[ \"$1\" = -version ] && exit 0\n[ \"$2\" = -encoders ] && echo ' V....D libx264  H.264' && exit 0\nhead -c 100 >/dev/null\necho 'encoder exploded' >&2\nexit 1\n",
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

    // An ffmpeg without libx265 (the stand-in lists libx264 only): --codec
    // hevc is refused before anything is rendered, naming the encoder.
    args.extend(["--codec", "hevc"]);
    let r = run(&args, &[("TWINRAY_FFMPEG", s(&fake))]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(
        !r.status.success() && err.contains("libx265 encoder") && err.contains("--codec h264"),
        "{err}"
    );
    assert!(!err.contains("exploded"), "it rendered: {err}");
    assert!(files_in(&videos).is_empty());
}

#[test]
#[cfg_attr(
    missing_ffmpeg,
    ignore = "needs ffmpeg and ffprobe on PATH (apt-get install ffmpeg)"
)]
fn hevc_videos_have_their_codec_frames_size_and_stereo_metadata() {
    let dir = TempDir::new().unwrap();
    let out = dir.path().join("sbs.mp4");
    let mut flags = STEREO.to_vec();
    flags.extend(["--layout", "sbs", "--codec", "hevc"]);
    render_video(&out, &flags);
    let p = assert_side_by_side_mp4(&out, "hevc");
    // hvc1: the parameter sets in the sample entry, as Apple's players need.
    assert_eq!(value(&p, "codec_tag_string"), "hvc1");

    let out = dir.path().join("tb.mkv");
    let mut flags = STEREO.to_vec();
    flags.extend(["--layout", "tb", "--codec", "hevc", "--crf", "28"]);
    render_video(&out, &flags);
    assert_top_bottom_mkv(&out, "hevc");
    assert_eq!(files_in(dir.path()), vec!["sbs.mp4", "tb.mkv"]);
}

#[test]
#[cfg_attr(
    missing_ffmpeg,
    ignore = "needs ffmpeg and ffprobe on PATH (apt-get install ffmpeg)"
)]
fn hevc_lossless_frames_show_what_the_stills_show() {
    let dir = TempDir::new().unwrap();
    let flags = [
        "--frames",
        "0..1",
        "--orbit",
        "30",
        "--stereo",
        "--size",
        "64x48",
        "--layout",
        "sbs",
        "--exposure=0.5",
    ];
    let video = dir.path().join("v.mkv");
    let mut coded = flags.to_vec();
    coded.extend(["--codec", "hevc", "--crf", "0"]);
    render_video(&video, &coded);
    render_video(&dir.path().join("v_####.png"), &flags);
    let (mean, max) = difference(
        &decoded_rgb(&video, 1),
        &decoded_rgb(&dir.path().join("v_0001.png"), 0),
    );
    assert!(mean <= 0.25 && max <= 4, "mean {mean:.2}, largest {max}");
}

#[test]
fn a_rate_factor_beyond_the_scale_is_refused() {
    let dir = TempDir::new().unwrap();
    let out = dir.path().join("v.mp4");
    let scene = example();
    let mut args = vec!["render", s(&scene), "-o", s(&out), "-q"];
    args.extend(STEREO);
    args.extend(["--layout", "sbs", "--crf", "52"]);
    let r = run(&args, &[]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(!r.status.success() && err.contains("--crf"), "{err}");
    assert!(!out.exists());
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

/// Frame `index` of a video, or a still image, as ffmpeg decodes it to
/// 8-bit RGB. A still is taken through yuv420p first, as a video's frames
/// are on their way in (the chroma of 2x2 pixels averaged).
fn decoded_rgb(path: &Path, index: u32) -> Vec<u8> {
    let still = path.extension().is_some_and(|e| e == "png");
    let out = Command::new("ffmpeg")
        .args(["-hide_banner", "-loglevel", "error", "-nostdin", "-i"])
        .arg(path)
        .arg("-vf")
        .arg(if still {
            "format=yuv420p".to_string()
        } else {
            format!("select=eq(n\\,{index})")
        })
        .args(["-frames:v", "1", "-f", "rawvideo", "-pix_fmt", "rgb24", "-"])
        .output()
        .expect("ffmpeg runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out.stdout
}

/// Mean and largest absolute difference of two RGB byte strings.
fn difference(a: &[u8], b: &[u8]) -> (f64, u8) {
    assert_eq!(a.len(), b.len(), "different sizes");
    let sum: u64 = a
        .iter()
        .zip(b)
        .map(|(x, y)| u64::from(x.abs_diff(*y)))
        .sum();
    let max = a
        .iter()
        .zip(b)
        .map(|(x, y)| x.abs_diff(*y))
        .max()
        .unwrap_or(0);
    (sum as f64 / a.len().max(1) as f64, max)
}

/// The pixels of a video's frames are those of the frames written as PNG
/// stills with the same flags: exposure, tone curve and the sRGB encoding
/// are applied to video frames as to images. At `--crf 0` x264 is lossless
/// in YUV; the still goes through the same RGB → yuv420p conversion, so what
/// is left is rounding: the mean difference must be ≤ 0.25 levels of 255
/// and the largest ≤ 4 (measured: 0 and 0 with Debian 12's ffmpeg 5.1; a
/// frame without the display transform differs by tens of levels).
#[test]
#[cfg_attr(
    missing_ffmpeg,
    ignore = "needs ffmpeg and ffprobe on PATH (apt-get install ffmpeg)"
)]
fn video_frames_show_what_the_stills_show() {
    let dir = TempDir::new().unwrap();
    for (layout, exposure) in [("sbs", "--exposure=0.7"), ("anaglyph", "--exposure=-0.6")] {
        let flags = [
            "--frames", "0..2", "--orbit", "40", "--stereo", "--size", "96x64", "--layout", layout,
            exposure,
        ];
        let video = dir.path().join(format!("{layout}.mp4"));
        let mut with_crf = flags.to_vec();
        with_crf.extend(["--crf", "0"]);
        render_video(&video, &with_crf);
        let stills = dir.path().join(format!("{layout}_####.png"));
        render_video(&stills, &flags);
        for frame in [0u32, 2] {
            let png = dir.path().join(format!("{layout}_{frame:04}.png"));
            let (mean, max) = difference(&decoded_rgb(&video, frame), &decoded_rgb(&png, 0));
            eprintln!("{layout} frame {frame}: mean difference {mean:.3}, largest {max}");
            assert!(
                mean <= 0.25 && max <= 4,
                "{layout} frame {frame}: the video's pixels differ from the still's by {mean:.2} levels on average (largest {max})"
            );
        }
    }
}

//! End-to-end tests of the `twinray` binary: outputs and their sizes, the stats
//! file, one-line errors for bad scenes and bad parameters (with no output left
//! behind), every stereo layout, determinism across thread counts, and twin
//! versus independent stereo through the command line.
//!
//! Renders are tiny (48x36) so the whole file runs in seconds.

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;
use tempfile::TempDir;

const W: u32 = 48;
const H: u32 = 36;
const SIZE: &str = "48x36";

// ---------------------------------------------------------------------------
// Running the binary
// ---------------------------------------------------------------------------

struct Run {
    args: Vec<String>,
    code: Option<i32>,
    stdout: String,
    stderr: String,
}

impl Run {
    /// Exit 0, and no panic on stderr.
    fn ok(&self) -> &Run {
        assert_eq!(
            self.code,
            Some(0),
            "twinray {:?} failed\nstdout: {}\nstderr: {}",
            self.args,
            self.stdout,
            self.stderr
        );
        self.no_panic();
        self
    }

    fn no_panic(&self) {
        assert!(
            !self.stderr.contains("panicked") && !self.stderr.contains("RUST_BACKTRACE"),
            "twinray {:?} panicked: {}",
            self.args,
            self.stderr
        );
        assert_ne!(
            self.code,
            Some(101),
            "twinray {:?}: {}",
            self.args,
            self.stderr
        );
    }

    /// A failure reported as exactly one `twinray: ...` line on stderr; returns it.
    fn one_line_error(&self) -> &str {
        assert!(
            self.code.is_some_and(|c| c != 0),
            "twinray {:?} should fail (exit {:?})\nstderr: {}",
            self.args,
            self.code,
            self.stderr
        );
        self.no_panic();
        let lines: Vec<&str> = self.stderr.lines().collect();
        assert_eq!(
            lines.len(),
            1,
            "twinray {:?}: expected one line on stderr, got:\n{}",
            self.args,
            self.stderr
        );
        assert!(
            lines[0].starts_with("twinray: "),
            "twinray {:?}: {}",
            self.args,
            lines[0]
        );
        lines[0]
    }
}

fn twinray(args: &[&str]) -> Run {
    let out = Command::new(env!("CARGO_BIN_EXE_twinray"))
        .args(args)
        .env_remove("RUST_BACKTRACE")
        .env_remove("RUST_LIB_BACKTRACE")
        .output()
        .expect("cannot start the twinray binary");
    Run {
        args: args.iter().map(|s| s.to_string()).collect(),
        code: out.status.code(),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

/// `twinray render SCENE -o OUT --quiet EXTRA...`
fn render(scene: &Path, out: &Path, extra: &[&str]) -> Run {
    let mut args = vec!["render", s(scene), "-o", s(out), "--quiet"];
    args.extend_from_slice(extra);
    twinray(&args)
}

/// A shipped scene (in the repository's `scenes/`).
fn scene(name: &str) -> PathBuf {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes")
        .join(name);
    assert!(p.is_file(), "missing shipped scene {}", p.display());
    p
}

fn s(p: &Path) -> &str {
    p.to_str().expect("temporary paths are UTF-8")
}

fn tmp() -> TempDir {
    tempfile::tempdir().expect("cannot make a temporary directory")
}

/// Every entry of `dir` (hidden ones included), sorted.
fn entries(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

fn assert_empty(dir: &Path, what: &str) {
    let left = entries(dir);
    assert!(left.is_empty(), "{what}: files left behind: {left:?}");
}

fn read(p: &Path) -> Vec<u8> {
    std::fs::read(p).unwrap_or_else(|e| panic!("cannot read {}: {e}", p.display()))
}

// ---------------------------------------------------------------------------
// Reading outputs back without an image crate
// ---------------------------------------------------------------------------

fn png_size(p: &Path) -> (u32, u32) {
    let b = read(p);
    assert!(
        b.len() > 24 && b.starts_with(b"\x89PNG\r\n\x1a\n") && &b[12..16] == b"IHDR",
        "{} is not a PNG",
        p.display()
    );
    let be = |i: usize| u32::from_be_bytes(b[i..i + 4].try_into().unwrap());
    (be(16), be(20))
}

fn exr_size(p: &Path) -> (u32, u32) {
    let b = read(p);
    assert!(
        b.starts_with(&[0x76, 0x2f, 0x31, 0x01]),
        "{} is not an OpenEXR file",
        p.display()
    );
    let key = b"dataWindow\0box2i\0";
    let at = b
        .windows(key.len())
        .position(|w| w == key)
        .unwrap_or_else(|| panic!("{}: no dataWindow", p.display()));
    let le = |i: usize| i32::from_le_bytes(b[i..i + 4].try_into().unwrap());
    let v = at + key.len();
    assert_eq!(le(v), 16, "box2i attribute size");
    let (x0, y0, x1, y1) = (le(v + 4), le(v + 8), le(v + 12), le(v + 16));
    ((x1 - x0 + 1) as u32, (y1 - y0 + 1) as u32)
}

/// A colour PFM, rows top to bottom.
struct Pfm {
    width: usize,
    height: usize,
    pixels: Vec<[f32; 3]>,
}

impl Pfm {
    fn get(&self, x: usize, y: usize) -> [f32; 3] {
        self.pixels[y * self.width + x]
    }
}

fn read_pfm(p: &Path) -> Pfm {
    let b = read(p);
    let mut pos = 0;
    let mut fields = Vec::new();
    while fields.len() < 4 {
        while b[pos].is_ascii_whitespace() {
            pos += 1;
        }
        let start = pos;
        while !b[pos].is_ascii_whitespace() {
            pos += 1;
        }
        fields.push(std::str::from_utf8(&b[start..pos]).unwrap().to_string());
    }
    pos += 1; // the single whitespace character ending the header
    assert_eq!(fields[0], "PF", "{}: not a colour PFM", p.display());
    let width: usize = fields[1].parse().unwrap();
    let height: usize = fields[2].parse().unwrap();
    let scale: f32 = fields[3].parse().unwrap();
    let data = &b[pos..];
    assert_eq!(
        data.len(),
        width * height * 12,
        "{}: data size",
        p.display()
    );
    let value = |i: usize| {
        let bytes: [u8; 4] = data[i * 4..i * 4 + 4].try_into().unwrap();
        if scale < 0.0 {
            f32::from_le_bytes(bytes)
        } else {
            f32::from_be_bytes(bytes)
        }
    };
    let mut pixels = Vec::with_capacity(width * height);
    for y in 0..height {
        let row = height - 1 - y; // PFM rows run bottom to top
        for x in 0..width {
            let i = (row * width + x) * 3;
            pixels.push([value(i), value(i + 1), value(i + 2)]);
        }
    }
    Pfm {
        width,
        height,
        pixels,
    }
}

fn image_size(p: &Path) -> (u32, u32) {
    match p.extension().and_then(|e| e.to_str()) {
        Some("png") => png_size(p),
        Some("exr") => exr_size(p),
        Some("pfm") => {
            let img = read_pfm(p);
            (img.width as u32, img.height as u32)
        }
        other => panic!("no size reader for {other:?}"),
    }
}

/// The PSNR printed by `twinray compare A B` (`inf` for identical images).
fn psnr(a: &Path, b: &Path) -> f64 {
    let run = twinray(&["compare", s(a), s(b)]);
    run.ok();
    let field = run
        .stdout
        .split_whitespace()
        .skip_while(|w| *w != "psnr_db")
        .nth(1)
        .unwrap_or_else(|| panic!("no psnr_db in {:?}", run.stdout));
    field
        .parse()
        .unwrap_or_else(|_| panic!("bad psnr '{field}'"))
}

fn stats(p: &Path) -> Value {
    serde_json::from_slice(&read(p)).expect("the stats file is JSON")
}

fn count(v: &Value, pointer: &str) -> u64 {
    v.pointer(pointer)
        .unwrap_or_else(|| panic!("no {pointer} in {v}"))
        .as_u64()
        .unwrap_or_else(|| panic!("{pointer} is not a count in {v}"))
}

// ---------------------------------------------------------------------------
// Scene files written by the tests
// ---------------------------------------------------------------------------

/// A viewpoint on lines 1-7 and a light on line 8: the first entity a test
/// appends is on line 9.
const HEADER: &str =
    "v\nfrom 0 -5 1\nat 0 0 0\nup 0 0 1\nangle 40\nhither 0.01\nresolution 32 24\n\
                      l 2 -3 4\n";

fn write_scene(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

/// Deterministic pseudo-random bytes.
fn noise(n: usize, seed: u64) -> Vec<u8> {
    let mut rng = fastrand::Rng::with_seed(seed);
    (0..n).map(|_| rng.u8(..)).collect()
}

// ---------------------------------------------------------------------------
// Mono renders and the stats file
// ---------------------------------------------------------------------------

#[test]
fn mono_png_exr_pfm_have_the_requested_size() {
    let dir = tmp();
    for ext in ["png", "exr", "pfm"] {
        let out = dir.path().join(format!("mono.{ext}"));
        render(&scene("example.nff"), &out, &["--size", SIZE]).ok();
        assert!(out.is_file(), "{} not written", out.display());
        assert_eq!(image_size(&out), (W, H), "{}", out.display());
        assert_eq!(psnr(&out, &out), f64::INFINITY);
    }
    // Both float formats hold the same linear values.
    assert_eq!(
        psnr(&dir.path().join("mono.exr"), &dir.path().join("mono.pfm")),
        f64::INFINITY
    );
    // Nothing but the three images (no temporary files).
    assert_eq!(entries(dir.path()), ["mono.exr", "mono.pfm", "mono.png"]);
}

#[test]
fn stats_file_counts_eye_rays() {
    let dir = tmp();
    let out = dir.path().join("s.png");
    let json = dir.path().join("s.json");
    let pixels = u64::from(W * H);

    render(
        &scene("example.nff"),
        &out,
        &["--size", SIZE, "--samples", "1", "--stats", s(&json)],
    )
    .ok();
    let v = stats(&json);
    for key in [
        "/rays/eye",
        "/rays/eye_hit",
        "/rays/reflected",
        "/rays/refracted",
        "/rays/shadow",
    ] {
        count(&v, key);
    }
    for key in ["/time/load_s", "/time/build_s", "/time/render_s"] {
        let t = v
            .pointer(key)
            .and_then(Value::as_f64)
            .unwrap_or_else(|| panic!("no {key} in {v}"));
        assert!(t.is_finite() && t >= 0.0, "{key} = {t}");
    }
    assert_eq!(count(&v, "/rays/eye"), pixels);
    assert!(count(&v, "/rays/eye_hit") <= pixels);
    assert!(
        count(&v, "/rays/eye_hit") > 0,
        "the example scene is visible"
    );

    for method in ["twin", "independent"] {
        render(
            &scene("example.nff"),
            &out,
            &[
                "--size",
                SIZE,
                "--stereo",
                "--interaxial",
                "0.4",
                "--method",
                method,
                "--samples",
                "1",
                "--stats",
                s(&json),
            ],
        )
        .ok();
        let v = stats(&json);
        assert_eq!(count(&v, "/rays/eye"), 2 * pixels, "{method}");
        assert_eq!(count(&v, "/views"), 2, "{method}");
    }

    let spd = dir.path().join("spd.png");
    render(
        &scene("example.nff"),
        &spd,
        &["--spd", "--size", "16x16", "--stats", s(&json)],
    )
    .ok();
    assert_eq!(count(&stats(&json), "/rays/eye"), 17 * 17);
    assert_eq!(png_size(&spd), (16, 16));

    // The default, adaptive sampling: the corners, plus the points of the
    // pixels it refined, as the report says.
    render(
        &scene("example.nff"),
        &out,
        &["--size", SIZE, "--stats", s(&json)],
    )
    .ok();
    let v = stats(&json);
    let corners = u64::from((W + 1) * (H + 1));
    let eye = count(&v, "/rays/eye");
    assert_eq!(count(&v, "/samples_per_view"), eye);
    assert!(eye > corners, "{eye} eye rays, {corners} corners");
    assert!(count(&v, "/sampling/refined_pixels") > 0);
    let mean = v
        .pointer("/sampling/eye_samples_per_pixel_mean")
        .and_then(Value::as_f64)
        .unwrap_or_default();
    assert!((mean - eye as f64 / pixels as f64).abs() < 1e-9, "{mean}");
    assert_eq!(count(&v, "/sampling/eye_samples_per_pixel_max"), 25);
    let mode = v
        .pointer("/sampling/mode")
        .and_then(Value::as_str)
        .unwrap_or_default();
    assert!(mode.starts_with("adaptive"), "{mode}");

    // --samples 4: four per pixel.
    render(
        &scene("example.nff"),
        &out,
        &[
            "--size",
            SIZE,
            "--samples",
            "4",
            "--filter",
            "tent",
            "--stats",
            s(&json),
        ],
    )
    .ok();
    let v = stats(&json);
    assert_eq!(count(&v, "/rays/eye"), 4 * pixels);
    assert_eq!(count(&v, "/sampling/eye_samples_per_pixel_max"), 4);
}

#[test]
fn bad_sampling_values_are_refused_with_the_flag_named() {
    let dir = tmp();
    let out = dir.path().join("bad.png");
    let example = scene("example.nff");
    for (flags, says) in [
        (vec!["--samples", "0"], "--samples"),
        (vec!["--samples", "70000"], "--samples"),
        (vec!["--adaptive", "-0.1"], "--adaptive"),
        (vec!["--adaptive", "NaN"], "--adaptive"),
        (vec!["--adaptive", "inf"], "--adaptive"),
        (vec!["--max-samples", "8"], "--max-samples"),
        (vec!["--samples", "4", "--adaptive"], "--adaptive"),
        (vec!["--spd", "--samples", "4"], "--spd"),
        (vec!["--samples", "1", "--filter", "gaussian"], "--filter"),
    ] {
        let mut args = vec!["render", s(&example), "-o", s(&out), "--size", "8x8"];
        args.extend(flags.iter().copied());
        let r = twinray(&args);
        assert_ne!(r.code, Some(0), "{flags:?} accepted");
        assert!(r.stderr.contains(says), "{flags:?}: {}", r.stderr);
        assert!(!out.exists(), "{flags:?} wrote an image");
    }
}

// ---------------------------------------------------------------------------
// Bad scene files
// ---------------------------------------------------------------------------

/// Each case: exit != 0, one `twinray: FILE:LINE: ...` line, no output at all.
#[test]
fn bad_scene_files_fail_with_one_line_naming_file_and_line() {
    let scenes = tmp();
    let mut garbage = format!("{HEADER}s 0 0 0 1\n").into_bytes();
    garbage.push(0xff);
    garbage.extend(noise(512, 7));
    let mut png_as_scene = b"\x89PNG\r\n\x1a\n".to_vec();
    png_as_scene.extend(noise(256, 11));
    let cases: Vec<(&str, Vec<u8>, usize, &str)> = vec![
        (
            "truncated.nff",
            format!("{HEADER}s 0 0 0 1\np 3\n0 0 0\n1 0").into_bytes(),
            10,
            "end of file",
        ),
        (
            "vertex_count.nff",
            format!("{HEADER}p 4\n0 0 0\n1 0 0\n1 1 0\ns 0 0 0 1\n").into_bytes(),
            13,
            "vertex 4 of 4",
        ),
        (
            "nan.nff",
            format!("{HEADER}s 0 0\nnan 1\n").into_bytes(),
            10,
            "nan",
        ),
        (
            "negative_count.nff",
            format!("{HEADER}s 0 0 0 1\np -3\n0 0 0\n1 0 0\n1 1 0\n").into_bytes(),
            10,
            "-3",
        ),
        (
            "unknown.nff",
            format!("{HEADER}s 0 0 0 1\n\nsphere 0 0 0 1\n").into_bytes(),
            11,
            "sphere",
        ),
        ("garbage.nff", garbage, 10, "not a text file"),
        ("png_as_scene.nff", png_as_scene, 1, "not a text file"),
        (
            "huge.nff",
            HEADER
                .replace("resolution 32 24", "resolution 100000 100000")
                .into_bytes(),
            7,
            "--max-resolution",
        ),
    ];
    for (name, bytes, line, fragment) in &cases {
        let path = write_scene(scenes.path(), name, bytes);
        for ext in ["png", "exr"] {
            let out = tmp();
            let run = render(
                &path,
                &out.path().join(format!("x.{ext}")),
                &["--stats", s(&out.path().join("x.json"))],
            );
            let msg = run.one_line_error();
            let location = format!("twinray: {}:{line}: ", path.display());
            assert!(msg.starts_with(&location), "{name}: {msg}");
            assert!(msg.contains(fragment), "{name}: {msg}");
            assert_empty(out.path(), name);
        }
    }

    // The limit can be raised; the size on the command line is what is rendered.
    let huge = scenes.path().join("huge.nff");
    let out = tmp();
    let png = out.path().join("h.png");
    render(
        &huge,
        &png,
        &["--max-resolution", "200000", "--size", "8x8"],
    )
    .ok();
    assert_eq!(png_size(&png), (8, 8));
}

#[test]
fn polygon_vertex_limit_names_its_option() {
    let dir = tmp();
    let path = write_scene(
        dir.path(),
        "pentagon.nff",
        format!("{HEADER}\np 5\n0 0 0\n1 0 0\n1.5 0 1\n0.5 0 1.5\n-0.5 0 1\n").as_bytes(),
    );
    let out = tmp();
    let png = out.path().join("p.png");
    let run = render(&path, &png, &["--max-vertices", "4"]);
    let msg = run.one_line_error();
    assert!(
        msg.starts_with(&format!("twinray: {}:10: ", path.display())),
        "{msg}"
    );
    assert!(msg.contains("--max-vertices"), "{msg}");
    assert_empty(out.path(), "vertex limit");
    render(&path, &png, &["--max-vertices", "5"]).ok();
    assert_eq!(png_size(&png), (32, 24));
}

#[test]
fn missing_scene_file_is_one_line() {
    let dir = tmp();
    let missing = dir.path().join("nope.nff");
    let run = render(&missing, &dir.path().join("x.png"), &[]);
    let msg = run.one_line_error();
    assert!(msg.contains(s(&missing)), "{msg}");
    assert_empty(dir.path(), "missing scene");
}

#[test]
fn degenerate_geometry_warns_and_renders() {
    let dir = tmp();
    let path = write_scene(
        dir.path(),
        "degenerate.nff",
        format!("{HEADER}s 0 0 0 0\np 3\n0 0 0\n1 0 0\n2 0 0\ns 0 0 0 1\n").as_bytes(),
    );
    let out = dir.path().join("d.png");
    let run = render(&path, &out, &[]);
    run.ok();
    assert_eq!(png_size(&out), (32, 24));
    let warnings: Vec<&str> = run
        .stderr
        .lines()
        .filter(|l| l.contains("warning"))
        .collect();
    for line in [9, 10] {
        let location = format!("{}:{line}:", path.display());
        assert!(
            warnings.iter().any(|w| w.contains(&location)),
            "no warning naming {location}: {:?}",
            run.stderr
        );
    }
    assert!(
        warnings.iter().any(|w| w.contains("sphere")),
        "{warnings:?}"
    );
    assert!(
        warnings.iter().any(|w| w.contains("polygon")),
        "{warnings:?}"
    );
}

// ---------------------------------------------------------------------------
// Parameter errors
// ---------------------------------------------------------------------------

#[test]
fn parameter_errors_are_one_line_and_write_nothing() {
    let stereo = ["--stereo", "--interaxial", "0.4"];
    let cases: Vec<(&str, Vec<&str>, &str)> = vec![
        (
            "x.png",
            vec!["--stereo", "--interaxial", "abc"],
            "--interaxial",
        ),
        (
            "x.png",
            vec!["--stereo", "--depth-budget", "1%,2%"],
            "depth budget",
        ),
        (
            "x.png",
            vec!["--stereo", "--depth-budget=-1%"],
            "depth budget",
        ),
        (
            "x.png",
            vec!["--stereo", "--convergence", "far"],
            "--convergence",
        ),
        ("x.png", vec!["--floating-window"], "--floating-window"),
        ("x.png", vec!["--depth-budget=-1%,2%"], "--depth-budget"),
        ("x.png", vec!["--view-cone", "35"], "--view-cone"),
        (
            "x.png",
            vec!["--stereo", "--view-cone", "35", "--interaxial", "0.1"],
            "--view-cone",
        ),
        (
            "x.png",
            vec!["--stereo", "--view-cone", "35", "--convergence", "inf"],
            "--view-cone",
        ),
        (
            "x.png",
            vec!["--stereo", "--view-cone", "190"],
            "--view-cone",
        ),
        (
            "x.png",
            vec!["--stereo", "--screen-width", "0"],
            "--screen-width",
        ),
        ("x.png", vec!["--stereo", "--quilt", "2x1"], "--quilt"),
        ("x.png", vec!["--layout", "quilt"], "--quilt"),
        (
            "x.png",
            vec!["--layout", "quilt", "--quilt", "0x2"],
            "--quilt",
        ),
        (
            "x.png",
            vec!["--layout", "quilt", "--quilt", "2x2", "--views", "5"],
            "do not fit",
        ),
        ("x.png", vec!["--stereo", "--depth"], "--depth"),
        (
            "x.exr",
            vec!["--stereo", "--depth", "--layout", "sbs"],
            "--depth",
        ),
        (
            "x.png",
            vec!["--stereo", "--interaxial", "-1"],
            "--interaxial",
        ),
        (
            "x.png",
            vec!["--views", "3", "--interaxial", "nan"],
            "--interaxial",
        ),
        (
            "x.png",
            [&stereo[..], &["--convergence", "0"]].concat(),
            "--convergence",
        ),
        (
            "x.png",
            [&stereo[..], &["--convergence", "-2"]].concat(),
            "--convergence",
        ),
        (
            "x.png",
            [&stereo[..], &["--convergence", "abc"]].concat(),
            "--convergence",
        ),
        ("x.png", vec!["--convergence", "0"], "--convergence"),
        ("x.png", [&stereo[..], &["--layout", "mpo"]].concat(), "mpo"),
        (
            "x.png",
            [&stereo[..], &["--layout", "multiview"]].concat(),
            ".exr",
        ),
        ("x.mpo", stereo.to_vec(), "mpo"),
        ("x.png", vec!["--layout", "sbs"], "--stereo"),
        (
            "x.png",
            vec!["--views", "4", "--interaxial", "0.1", "--layout", "sbs"],
            "two views",
        ),
        (
            "x.png",
            vec!["--stereo", "--views", "3", "--interaxial", "0.1"],
            "--views",
        ),
        ("x.png", vec!["--views", "0"], "--views"),
        ("x.png", vec!["--threads", "0"], "--threads"),
        ("x.png", vec!["--size", "0x5"], "--size"),
        ("x.png", vec!["--size", "5"], "--size"),
        ("x.png", vec!["--size", "100000x10"], "--max-resolution"),
        ("x.bmp", vec![], ".bmp"),
        ("x", vec![], "x"),
        ("x.bmp", stereo.to_vec(), ".bmp"),
        ("x.png", vec!["--layout", "hologram"], "--layout"),
        ("x.png", vec!["--no-such-option"], "--no-such-option"),
    ];
    for (name, extra, fragment) in &cases {
        let out = tmp();
        let json = out.path().join("stats.json");
        let mut args = extra.clone();
        args.extend(["--stats", s(&json)]);
        if !extra.contains(&"--size") {
            args.extend(["--size", SIZE]);
        }
        let run = render(&scene("example.nff"), &out.path().join(name), &args);
        let msg = run.one_line_error();
        assert!(msg.contains(fragment), "{extra:?} -> {name}: {msg}");
        assert_empty(out.path(), &format!("{extra:?} -> {name}"));
    }
}

#[test]
fn failing_render_keeps_an_existing_output() {
    let dir = tmp();
    let bad = write_scene(
        dir.path(),
        "bad.nff",
        format!("{HEADER}s 0 0 0\n").as_bytes(),
    );
    let out = tmp();
    let png = out.path().join("out.png");
    let original = b"precious bytes, not a PNG".to_vec();
    std::fs::write(&png, &original).unwrap();

    render(&bad, &png, &[]).one_line_error();
    render(&scene("example.nff"), &png, &["--threads", "0"]).one_line_error();
    render(
        &scene("example.nff"),
        &png,
        &["--stereo", "--interaxial", "0.4", "--layout", "mpo"],
    )
    .one_line_error();
    assert_eq!(read(&png), original);
    assert_eq!(entries(out.path()), ["out.png"]);

    // A successful render replaces it.
    render(&scene("example.nff"), &png, &["--size", SIZE]).ok();
    assert_eq!(png_size(&png), (W, H));
    assert_eq!(entries(out.path()), ["out.png"]);
}

// ---------------------------------------------------------------------------
// Stereo layouts and multi-view sets
// ---------------------------------------------------------------------------

fn stereo_render(out: &Path, extra: &[&str]) -> Run {
    let mut args = vec!["--size", SIZE, "--stereo", "--interaxial", "0.4"];
    args.extend_from_slice(extra);
    let run = render(&scene("example.nff"), out, &args);
    run.ok();
    run
}

#[test]
fn separate_layout_writes_two_eyes() {
    let dir = tmp();
    stereo_render(&dir.path().join("pair.png"), &["--layout", "separate"]);
    assert_eq!(entries(dir.path()), ["pair_L.png", "pair_R.png"]);
    for eye in ["pair_L.png", "pair_R.png"] {
        assert_eq!(png_size(&dir.path().join(eye)), (W, H));
    }
    // The eyes see different images.
    let p = psnr(
        &dir.path().join("pair_L.png"),
        &dir.path().join("pair_R.png"),
    );
    assert!(p.is_finite(), "left and right are identical");
}

#[test]
fn packed_layouts_hold_both_eyes() {
    let dir = tmp();
    let d = |name: &str| dir.path().join(name);
    stereo_render(&d("pair.pfm"), &[]);
    let (l, r) = (read_pfm(&d("pair_L.pfm")), read_pfm(&d("pair_R.pfm")));
    let (w, h) = (W as usize, H as usize);

    stereo_render(&d("sbs.pfm"), &["--layout", "sbs"]);
    stereo_render(&d("cross.pfm"), &["--layout", "cross"]);
    stereo_render(&d("tb.pfm"), &["--layout", "tb"]);
    let (sbs, cross, tb) = (
        read_pfm(&d("sbs.pfm")),
        read_pfm(&d("cross.pfm")),
        read_pfm(&d("tb.pfm")),
    );
    assert_eq!((sbs.width, sbs.height), (2 * w, h));
    assert_eq!((cross.width, cross.height), (2 * w, h));
    assert_eq!((tb.width, tb.height), (w, 2 * h));
    for y in 0..h {
        for x in 0..w {
            assert_eq!(sbs.get(x, y), l.get(x, y), "sbs left ({x},{y})");
            assert_eq!(sbs.get(w + x, y), r.get(x, y), "sbs right ({x},{y})");
            assert_eq!(cross.get(x, y), r.get(x, y), "cross right ({x},{y})");
            assert_eq!(cross.get(w + x, y), l.get(x, y), "cross left ({x},{y})");
            assert_eq!(tb.get(x, y), l.get(x, y), "tb top ({x},{y})");
            assert_eq!(tb.get(x, h + y), r.get(x, y), "tb bottom ({x},{y})");
        }
    }

    for layout in ["sbs", "cross", "tb"] {
        let out = d(&format!("{layout}_squeezed.png"));
        stereo_render(&out, &["--layout", layout, "--squeeze"]);
        assert_eq!(png_size(&out), (W, H), "{layout} --squeeze");
        let out = d(&format!("{layout}.png"));
        stereo_render(&out, &["--layout", layout]);
        let full = if layout == "tb" {
            (W, 2 * H)
        } else {
            (2 * W, H)
        };
        assert_eq!(png_size(&out), full, "{layout}");
    }

    // Even rows / columns / x + y from the left eye.
    for mode in ["rows", "columns", "checker"] {
        let from_left = |x: usize, y: usize| match mode {
            "rows" => y.is_multiple_of(2),
            "columns" => x.is_multiple_of(2),
            _ => (x + y).is_multiple_of(2),
        };
        let out = d(&format!("interlace_{mode}.pfm"));
        stereo_render(&out, &["--layout", "interlace", "--interlace", mode]);
        let img = read_pfm(&out);
        assert_eq!((img.width, img.height), (w, h), "{mode}");
        for y in 0..h {
            for x in 0..w {
                let want = if from_left(x, y) {
                    l.get(x, y)
                } else {
                    r.get(x, y)
                };
                assert_eq!(img.get(x, y), want, "interlace {mode} ({x},{y})");
            }
        }
        let png = d(&format!("interlace_{mode}.png"));
        stereo_render(&png, &["--layout", "interlace", "--interlace", mode]);
        assert_eq!(png_size(&png), (W, H));
    }
}

#[test]
fn anaglyph_methods() {
    let dir = tmp();
    let mut seen: Vec<Vec<u8>> = Vec::new();
    for method in ["dubois", "color", "gray", "green-magenta", "yellow-blue"] {
        let out = dir.path().join(format!("ana_{method}.png"));
        stereo_render(&out, &["--layout", "anaglyph", "--anaglyph", method]);
        assert_eq!(png_size(&out), (W, H), "{method}");
        let bytes = read(&out);
        assert!(
            !seen.contains(&bytes),
            "{method} is the same as another method"
        );
        seen.push(bytes);
    }
    // The default method is Dubois.
    let default = dir.path().join("ana_default.png");
    stereo_render(&default, &["--layout", "anaglyph"]);
    assert_eq!(read(&default), read(&dir.path().join("ana_dubois.png")));
}

#[test]
fn mpo_holds_two_jpegs() {
    let dir = tmp();
    let out = dir.path().join("pair.mpo");
    stereo_render(&out, &["--layout", "mpo"]);
    assert_eq!(entries(dir.path()), ["pair.mpo"]);
    let b = read(&out);
    assert!(b.starts_with(&[0xff, 0xd8]), "not a JPEG start");
    assert!(
        b[2..].windows(3).any(|w| w == [0xff, 0xd8, 0xff]),
        "no second JPEG in the MPO"
    );
}

/// Ignored where exiftool is missing (build.rs), never under CI.
#[test]
#[cfg_attr(
    missing_exiftool,
    ignore = "needs exiftool on PATH (apt-get install libimage-exiftool-perl)"
)]
fn exiftool_reads_the_mpo_as_two_images() {
    let dir = tmp();
    let out = dir.path().join("pair.mpo");
    stereo_render(&out, &["--layout", "mpo"]);
    let exif = Command::new("exiftool")
        .arg("-j")
        .arg(&out)
        .output()
        .expect("exiftool runs (CI installs it: .ci/run)");
    assert!(exif.status.success(), "exiftool failed: {exif:?}");
    let v: Value = serde_json::from_slice(&exif.stdout).expect("exiftool -j prints JSON");
    let tags = &v[0];
    assert_eq!(tags["NumberOfImages"].as_u64(), Some(2), "{tags}");
    assert_eq!(tags["FileType"].as_str(), Some("MPO"), "{tags}");
    assert_eq!(tags["ImageWidth"].as_u64(), Some(u64::from(W)), "{tags}");
    assert_eq!(tags["ImageHeight"].as_u64(), Some(u64::from(H)), "{tags}");
}

#[test]
fn multiview_exr_holds_the_pair() {
    let dir = tmp();
    let out = dir.path().join("pair.exr");
    stereo_render(&out, &["--layout", "multiview"]);
    assert_eq!(entries(dir.path()), ["pair.exr"]);
    assert_eq!(exr_size(&out), (W, H));
    let b = read(&out);
    let has = |needle: &[u8]| b.windows(needle.len()).any(|w| w == needle);
    assert!(has(b"multiView\0"), "no multiView attribute");
    assert!(
        has(b"left") && has(b"right"),
        "views not named left and right"
    );
    // Its default (first) view is the left eye.
    let sep = tmp();
    stereo_render(&sep.path().join("pair.exr"), &["--layout", "separate"]);
    assert_eq!(psnr(&out, &sep.path().join("pair_L.exr")), f64::INFINITY);
}

#[test]
fn views_write_numbered_files() {
    let dir = tmp();
    render(
        &scene("example.nff"),
        &dir.path().join("v.png"),
        &["--size", SIZE, "--views", "4", "--interaxial", "0.1"],
    )
    .ok();
    assert_eq!(
        entries(dir.path()),
        ["v_0.png", "v_1.png", "v_2.png", "v_3.png"]
    );
    for i in 0..4 {
        assert_eq!(png_size(&dir.path().join(format!("v_{i}.png"))), (W, H));
    }
    assert!(psnr(&dir.path().join("v_0.png"), &dir.path().join("v_3.png")).is_finite());
}

// ---------------------------------------------------------------------------
// Determinism and twin = independent
// ---------------------------------------------------------------------------

#[test]
fn thread_count_does_not_change_the_files() {
    let cases: [(&str, &[&str], &[&str]); 2] = [
        ("mono", &[], &[""]),
        (
            "twin",
            &["--stereo", "--interaxial", "0.4", "--method", "twin"],
            &["_L", "_R"],
        ),
    ];
    for (what, extra, suffixes) in cases {
        for ext in ["png", "pfm"] {
            let mut files: Vec<Vec<Vec<u8>>> = Vec::new();
            for threads in ["1", "2"] {
                let dir = tmp();
                let mut args = vec!["--size", SIZE, "--threads", threads];
                args.extend_from_slice(extra);
                render(
                    &scene("example.nff"),
                    &dir.path().join(format!("t.{ext}")),
                    &args,
                )
                .ok();
                files.push(
                    suffixes
                        .iter()
                        .map(|sfx| read(&dir.path().join(format!("t{sfx}.{ext}"))))
                        .collect(),
                );
            }
            assert!(
                files[0] == files[1],
                "{what} .{ext}: --threads 1 and --threads 2 differ"
            );
        }
    }
}

#[test]
fn twin_equals_independent() {
    for name in ["example.nff", "shelf.nff"] {
        for convergence in [None, Some("inf")] {
            let mut eyes: Vec<(Vec<u8>, Vec<u8>)> = Vec::new();
            for method in ["twin", "independent"] {
                let dir = tmp();
                let mut args = vec![
                    "--size",
                    SIZE,
                    "--stereo",
                    "--interaxial",
                    "0.4",
                    "--method",
                    method,
                    "--layout",
                    "separate",
                ];
                if let Some(c) = convergence {
                    args.extend(["--convergence", c]);
                }
                render(&scene(name), &dir.path().join("e.pfm"), &args).ok();
                eyes.push((
                    read(&dir.path().join("e_L.pfm")),
                    read(&dir.path().join("e_R.pfm")),
                ));
            }
            assert!(
                eyes[0].0 == eyes[1].0,
                "{name} (convergence {convergence:?}): left eyes differ between twin and independent"
            );
            assert!(
                eyes[0].1 == eyes[1].1,
                "{name} (convergence {convergence:?}): right eyes differ between twin and independent"
            );
        }
    }
}

// ---------------------------------------------------------------------------
// compare, help
// ---------------------------------------------------------------------------

#[test]
fn compare_prints_psnr_and_writes_a_difference() {
    let dir = tmp();
    let d = |name: &str| dir.path().join(name);
    render(&scene("example.nff"), &d("a.png"), &["--size", SIZE]).ok();
    render(
        &scene("example.nff"),
        &d("b.png"),
        &["--size", SIZE, "--max-depth", "1"],
    )
    .ok();

    let same = twinray(&["compare", s(&d("a.png")), s(&d("a.png"))]);
    same.ok();
    assert!(same.stdout.starts_with("psnr_db inf"), "{}", same.stdout);

    let p = psnr(&d("a.png"), &d("b.png"));
    assert!(p.is_finite() && p > 0.0, "psnr {p}");

    twinray(&[
        "compare",
        s(&d("a.png")),
        s(&d("b.png")),
        "--diff",
        s(&d("diff.png")),
    ])
    .ok();
    assert_eq!(png_size(&d("diff.png")), (W, H));

    // Images of different sizes, or a missing file: one line, no diff written.
    render(&scene("example.nff"), &d("small.png"), &["--size", "8x8"]).ok();
    let run = twinray(&[
        "compare",
        s(&d("a.png")),
        s(&d("small.png")),
        "--diff",
        s(&d("diff2.png")),
    ]);
    run.one_line_error();
    let run = twinray(&["compare", s(&d("a.png")), s(&d("missing.png"))]);
    assert!(
        run.one_line_error().contains("missing.png"),
        "{}",
        run.stderr
    );
    assert!(!d("diff2.png").exists());
}

#[test]
fn help_and_version_exit_zero() {
    for args in [
        &["--help"][..],
        &["render", "--help"],
        &["compare", "--help"],
        &["help", "render"],
        &["--version"],
    ] {
        let run = twinray(args);
        run.ok();
        assert!(!run.stdout.trim().is_empty(), "{args:?}: no output");
    }
    let run = twinray(&["render", "--help"]);
    for option in ["--interaxial", "--layout", "--stats", "--max-resolution"] {
        assert!(run.stdout.contains(option), "render --help lacks {option}");
    }
}

/// `render --help` is for users: its flags in named groups, no section
/// numbers of the paper, no method's history; `render -h` fits a screen.
#[test]
fn render_help_is_in_groups_for_users() {
    let long = twinray(&["render", "--help"]);
    long.ok();
    for group in [
        "Output:",
        "Camera:",
        "Views and rig:",
        "Sampling",
        "Speed",
        "Colour",
        "Animation",
        "Surroundings:",
        "Limits:",
    ] {
        assert!(
            long.stdout.lines().any(|l| l.starts_with(group)),
            "render --help has no group {group}"
        );
    }
    for text in ["Section 2.", "section 2", "Twin method:", "issue", "pass"] {
        assert!(!long.stdout.contains(text), "render --help says {text:?}");
    }
    for flag in ["--fast", "--tolerance", "--reproject", "--merge-secondary"] {
        assert!(long.stdout.contains(flag), "render --help lacks {flag}");
    }
    let short = twinray(&["render", "-h"]);
    short.ok();
    let lines = short.stdout.lines().count();
    assert!(lines <= 52, "render -h is {lines} lines:\n{}", short.stdout);
    assert!(short.stdout.contains("--fast") && short.stdout.contains("--stereo"));
}

/// A flag that was removed is refused with what replaced it, in one line,
/// before anything is read or written; a saved job with a removed field
/// too.
#[test]
fn removed_flags_are_refused_with_their_replacement() {
    let dir = tmp();
    let out = dir.path().join("x.png");
    for (args, replacement) in [
        (vec!["--stereo", "--strip"], "--fast"),
        (vec!["--stereo", "--eye-runs"], "--fast"),
        (vec!["--stereo", "--shadow-fans"], "--fast"),
        (
            vec!["--views", "8", "--views-per-batch", "8"],
            "batches of 4",
        ),
        (vec!["--stereo", "--interpolate-views"], "--fast"),
        (vec!["--views", "4", "--synthesize-views"], "--fast"),
        (vec!["--views", "4", "--synthesis-spacing=2"], "--fast"),
        (vec!["--stereo", "--key-spacing", "0"], "--fast"),
        (vec!["--stereo", "--share-shading"], "--fast"),
        (vec!["--stereo", "--epipolar-views"], "--fast"),
        (vec!["--stereo", "--share-tolerance", "0.02"], "--tolerance"),
    ] {
        let run = render(&scene("example.nff"), &out, &args);
        let line = run.one_line_error();
        assert!(
            line.contains("was removed") && line.contains(replacement),
            "{args:?}: {line}"
        );
        assert_eq!(run.code, Some(2), "{args:?}");
    }
    assert_empty(dir.path(), "removed flags");
    let job = dir.path().join("old.json");
    std::fs::write(&job, r#"{"rig": {"stereo": true, "strip": true}}"#).unwrap();
    let run = twinray(&[
        "render",
        "--job",
        s(&job),
        s(&scene("example.nff")),
        "-o",
        s(&out),
    ]);
    let line = run.one_line_error();
    assert!(line.contains("rig.strip was removed"), "{line}");
}

// ---------------------------------------------------------------------------
// OBJ and glTF scenes, camera and light from the command line
// ---------------------------------------------------------------------------

fn model(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../twinray/tests/data/models")
        .join(name)
}

#[test]
fn obj_and_glb_render_framed_and_lit_saying_so_in_one_verbose_line() {
    let dir = tmp();
    // The torus's MTL names `../cube.png`, beside its folder.
    let textures = model("pybullet");
    for name in ["pybullet/torus/torus_textured.obj", "gltf/torus.glb"] {
        let out = dir.path().join("m.png");
        // The defaults at work are nothing to warn about: silence.
        let run = twinray(&[
            "render",
            s(&model(name)),
            "-o",
            s(&out),
            "--size",
            SIZE,
            "--allow-dir",
            s(&textures),
        ]);
        run.ok();
        assert_eq!(png_size(&out), (W, H));
        assert!(!run.stderr.contains("no camera"), "{}", run.stderr);
        assert!(!run.stderr.contains("warning"), "{}", run.stderr);
        // -v says what the job supplied, in one line.
        let run = render(
            &model(name),
            &out,
            &["--size", SIZE, "-v", "--allow-dir", s(&textures)],
        );
        run.ok();
        let lines: Vec<&str> = run
            .stderr
            .lines()
            .filter(|l| l.contains("no camera") || l.contains("no lights"))
            .collect();
        assert_eq!(lines.len(), 1, "{}", run.stderr);
        assert!(
            lines[0].contains("no camera") && lines[0].contains("no lights: added"),
            "{}",
            lines[0]
        );
        std::fs::remove_file(&out).unwrap();
    }
}

#[test]
fn background_replaces_the_files() {
    let dir = tmp();
    let out = dir.path().join("bg.png");
    let model = model("gltf/torus.glb");
    render(
        &model,
        &out,
        &["--size", "16x12", "--background", "0.5,0.5,0.5"],
    )
    .ok();
    // The corner is background: linear 0.5, sRGB-encoded (read back as byte / 255).
    let corner = twinray::output::read_image(&out).unwrap().get(0, 0) * 255.0;
    assert_eq!(corner.round().to_array(), [188.0; 3]);
    render(&model, &out, &["--background", "1,-1,0"]).one_line_error();
}

#[test]
fn quiet_silences_notes_not_warnings() {
    let dir = tmp();
    let example = scene("example.nff");
    // `render` adds --quiet itself: these runs spell out what they pass.
    let run = |out: &Path, extra: &[&str]| {
        let mut args = vec!["render", s(&example), "-o", s(out), "--size", "8x6"];
        args.extend_from_slice(extra);
        let run = twinray(&args);
        run.ok();
        run.stderr.clone()
    };
    let (png, exr) = (dir.path().join("n.png"), dir.path().join("n.exr"));
    let stderr = run(&png, &["--srgb"]);
    assert!(stderr.contains("note: --srgb is the default"), "{stderr}");
    let stderr = run(&png, &["--srgb", "-q"]);
    assert!(!stderr.contains("note:"), "{stderr}");
    // Warnings stay.
    let stderr = run(&exr, &["-q", "--exposure", "1"]);
    assert!(stderr.contains("warning: --exposure"), "{stderr}");
}

#[test]
fn repeated_warnings_are_counted_and_opaque_ior_0_is_not_one() {
    let dir = tmp();
    // Ten uses of a glass material of index 0 (warned: once, with a count),
    // and an opaque material of index 0 (the SPD write it: not warned).
    let mut nff = String::from(HEADER);
    for i in 0..10 {
        nff += &format!("f 1 1 1 0.5 0 0 0.5 0\ns {i} 0 0 0.3\n");
    }
    nff += "f 1 1 1 1 0 0 0 0\ns 0 0 2 0.3\n";
    let scene = write_scene(dir.path(), "glass.nff", nff.as_bytes());
    let out = dir.path().join("g.png");
    let run = render(&scene, &out, &[]);
    run.ok();
    let warnings: Vec<&str> = run
        .stderr
        .lines()
        .filter(|l| l.contains("warning"))
        .collect();
    assert_eq!(warnings.len(), 1, "{}", run.stderr);
    assert!(
        warnings[0].contains("glass.nff:9: material index of refraction 0 replaced by 1")
            && warnings[0].contains("(and 9 more lines like it)"),
        "{}",
        warnings[0]
    );
}

#[test]
fn quilt_defaults_do_not_warn_about_their_own_rig() {
    let dir = tmp();
    let out = dir.path().join("q.png");
    let quilt = |extra: &[&str]| {
        let mut args = vec![
            "render", "--layout", "quilt", "--quilt", "4x2", "--size", "24x32",
        ];
        let example = scene("example.nff");
        args.extend_from_slice(&[s(&example), "-o", s(&out), "--samples", "1"]);
        args.extend_from_slice(extra);
        let run = twinray(&args);
        run.ok();
        run.stderr.clone()
    };
    let stderr = quilt(&[]);
    assert!(!stderr.contains("depth budget"), "{stderr}");
    // Asked for, the budget is checked and its excess warned about.
    let stderr = quilt(&["--view-cone", "35"]);
    assert!(stderr.contains("exceed the depth budget"), "{stderr}");
}

#[test]
fn camera_options_move_the_view() {
    let dir = tmp();
    let scene = model("gltf/torus.glb");
    let (a, b) = (dir.path().join("a.pfm"), dir.path().join("b.pfm"));
    render(&scene, &a, &["--size", SIZE]).ok();
    let moved = [
        "--size",
        SIZE,
        "--from",
        "0.3,2,0.5",
        "--at",
        "0,0,0",
        "--up",
        "0,0,1",
        "--fov",
        "50",
    ];
    render(&scene, &b, &moved).ok();
    assert!(psnr(&a, &b) < 30.0, "a different view");
    // The same view twice is the same image.
    let c = dir.path().join("c.pfm");
    render(&scene, &c, &moved).ok();
    assert!(read(&b) == read(&c));
}

#[test]
fn bad_camera_options_and_bad_meshes_are_one_line_and_write_nothing() {
    let dir = tmp();
    let out = dir.path().join("x.png");
    let glb = model("gltf/torus.glb");
    for (args, expect) in [
        (vec!["--camera", "main"], "no cameras"),
        (vec!["--from", "1,2"], "X,Y,Z"),
        (vec!["--fov", "0"], "--fov"),
        (vec!["--from", "0,0,0", "--at", "0,0,0"], "same point"),
        (vec!["--max-triangles", "100"], "exceed the limit"),
    ] {
        let msg = render(&glb, &out, &args).one_line_error().to_string();
        assert!(msg.contains(expect), "{args:?}: {msg}");
    }
    let bad_obj = write_scene(
        dir.path(),
        "bad.obj",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n",
    );
    let msg = render(&bad_obj, &out, &[]).one_line_error().to_string();
    assert!(msg.contains(&format!("{}:4:", bad_obj.display())), "{msg}");
    let bad_gltf = write_scene(
        dir.path(),
        "bad.gltf",
        br#"{"asset": {"version": "2.0"}, "meshes": [{"primitives": [{"attributes": {"POSITION": 3}}]}]}"#,
    );
    let msg = render(&bad_gltf, &out, &[]).one_line_error().to_string();
    assert!(msg.contains("meshes[0].primitives[0].attributes"), "{msg}");
    assert!(!out.exists());
    let entries: Vec<String> = entries(dir.path());
    assert_eq!(entries, vec!["bad.gltf".to_string(), "bad.obj".to_string()]);
}

// ---------------------------------------------------------------------------
// Depth budget, automatic rig, floating window, depth channels, quilts
// ---------------------------------------------------------------------------

fn number(v: &Value, pointer: &str) -> f64 {
    v.pointer(pointer)
        .unwrap_or_else(|| panic!("no {pointer} in {v}"))
        .as_f64()
        .unwrap_or_else(|| panic!("{pointer} is not a number in {v}"))
}

#[test]
fn stereo_without_an_interaxial_fits_the_depth_budget() {
    let dir = tmp();
    let json = dir.path().join("s.json");
    let run = render(
        &scene("example.nff"),
        &dir.path().join("pair.png"),
        &["--size", "160x120", "--stereo", "-v", "--stats", s(&json)],
    );
    run.ok();
    for line in [
        "rig choice: ",
        "depth: nearest",
        "disparity: ",
        "budget -1%,+2%",
    ] {
        assert!(run.stderr.contains(line), "no '{line}' in:\n{}", run.stderr);
    }
    assert!(!run.stderr.contains("warning"), "{}", run.stderr);
    let st = stats(&json);
    assert_eq!(st["rig_choice"]["interaxial_from"], "auto");
    assert_eq!(st["rig_choice"]["convergence_from"], "auto");
    assert_eq!(st["disparity"]["within_budget"], true);
    let near = number(&st, "/disparity/adjacent_percent/near");
    let far = number(&st, "/disparity/adjacent_percent/far");
    assert!((-1.01..=-0.9).contains(&near), "near {near} %");
    assert!(far <= 2.01 && far > 1.0, "far {far} %");
    assert!(number(&st, "/interaxial") > 0.0);
    assert!(number(&st, "/time/depth_s") >= 0.0);
    // A render with -v lists the window violations it found, or none.
    assert!(run.stderr.contains("window violation"), "{}", run.stderr);
}

#[test]
fn an_explicit_rig_beyond_the_budget_is_warned_about_and_rendered() {
    let dir = tmp();
    let out = dir.path().join("pair.png");
    let run = render(
        &scene("example.nff"),
        &out,
        &["--size", SIZE, "--stereo", "--interaxial", "3"],
    );
    run.ok();
    assert!(
        run.stderr
            .contains("twinray: warning: the rig's disparities")
            && run.stderr.contains("exceed the depth budget -1%,+2%"),
        "{}",
        run.stderr
    );
    assert!(run.stderr.contains("far points diverge"), "{}", run.stderr);
    assert_eq!(entries(dir.path()), ["pair_L.png", "pair_R.png"]);
    // Inside the budget: no warning.
    let run = render(
        &scene("example.nff"),
        &out,
        &["--size", SIZE, "--stereo", "--interaxial", "0.02"],
    );
    run.ok();
    assert!(!run.stderr.contains("warning"), "{}", run.stderr);
}

#[test]
fn floating_window_masks_the_violating_edges() {
    let dir = tmp();
    let d = |name: &str| dir.path().join(name);
    let common = ["--size", "64x48", "--stereo", "--depth-budget=-4%,+4%"];
    let json = d("s.json");
    let mut args = common.to_vec();
    args.extend(["--floating-window", "--stats", s(&json)]);
    render(&scene("example.nff"), &d("f.pfm"), &args).ok();
    render(&scene("example.nff"), &d("plain.pfm"), &common).ok();
    let st = stats(&json);
    let left = count(&st, "/disparity/floating_window/left_px") as usize;
    let right = count(&st, "/disparity/floating_window/right_px") as usize;
    assert!(
        left > 0 && right > 0,
        "the floor at the bottom corners violates: {st}"
    );
    let (l, r) = (read_pfm(&d("f_L.pfm")), read_pfm(&d("f_R.pfm")));
    let plain = read_pfm(&d("plain_L.pfm"));
    let black_column = |img: &Pfm, x: usize| (0..img.height).all(|y| img.get(x, y) == [0.0; 3]);
    for x in 0..left {
        assert!(black_column(&l, x), "left view, column {x} not masked");
    }
    for x in r.width - right..r.width {
        assert!(black_column(&r, x), "right view, column {x} not masked");
    }
    // Only there: the left view's right edge and the right view's left edge
    // are not masked, and without the flag nothing is.
    assert!(!black_column(&l, left));
    assert!(!black_column(&l, l.width - 1));
    assert!(!black_column(&r, 0));
    assert!(!black_column(&plain, 0));
}

#[test]
fn quilt_holds_the_views_bottom_left_to_top_right() {
    let dir = tmp();
    let d = |name: &str| dir.path().join(name);
    let rig = [
        "--size",
        "32x24",
        "--interaxial",
        "0.1",
        "--convergence",
        "6",
    ];
    let mut args = rig.to_vec();
    args.extend(["--layout", "quilt", "--quilt", "3x2"]);
    render(&scene("example.nff"), &d("q.pfm"), &args).ok();
    let mut args = rig.to_vec();
    args.extend(["--views", "6"]);
    render(&scene("example.nff"), &d("v.pfm"), &args).ok();
    let quilt = read_pfm(&d("q_qs3x2a1.3333.pfm"));
    assert_eq!((quilt.width, quilt.height), (96, 48));
    for v in 0..6 {
        let view = read_pfm(&d(&format!("v_{v}.pfm")));
        let (x0, y0) = ((v % 3) * 32, (1 - v / 3) * 24);
        for y in 0..24 {
            for x in 0..32 {
                assert_eq!(
                    quilt.get(x0 + x, y0 + y),
                    view.get(x, y),
                    "view {v} ({x}, {y})"
                );
            }
        }
    }
    // A preset names the file after the device's grid; fewer views than
    // tiles leave the last tiles black.
    let run = render(
        &scene("example.nff"),
        &d("p.png"),
        &[
            "--layout", "quilt", "--quilt", "portrait", "--views", "4", "--size", "6x8",
        ],
    );
    run.ok();
    assert_eq!(png_size(&d("p_qs8x6a0.75.png")), (48, 48));
}

#[test]
fn depth_adds_z_and_disparity_channels_to_exr_outputs() {
    let dir = tmp();
    let d = |name: &str| dir.path().join(name);
    let pair = ["--size", SIZE, "--stereo", "--interaxial", "0.2"];
    let mut args = pair.to_vec();
    args.push("--depth");
    render(&scene("example.nff"), &d("d.exr"), &args).ok();
    render(&scene("example.nff"), &d("plain.exr"), &pair).ok();
    let has = |p: &Path, name: &str| {
        let key = format!("{name}\0");
        read(p).windows(key.len()).any(|w| w == key.as_bytes())
    };
    for eye in ["d_L.exr", "d_R.exr"] {
        assert!(has(&d(eye), "Z") && has(&d(eye), "disparity"), "{eye}");
    }
    assert!(!has(&d("plain_L.exr"), "disparity"));
    // The colours are the same with and without the channels.
    assert_eq!(psnr(&d("d_L.exr"), &d("plain_L.exr")), f64::INFINITY);
    args.extend(["--layout", "multiview"]);
    render(&scene("example.nff"), &d("mv.exr"), &args).ok();
    assert!(has(&d("mv.exr"), "right.disparity") && has(&d("mv.exr"), "right.Z"));
}

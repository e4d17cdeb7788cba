//! Regression tests of the attack on the `twinray` command (issue 11): every
//! abuse is refused at once with one `twinray: ...` line and nothing written,
//! files are never clobbered, and the messages a new user meets say what to do.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use tempfile::TempDir;

const SIZE: &str = "24x18";

fn twinray_in(shell_prefix: Option<&str>, args: &[&str]) -> Output {
    let bin = env!("CARGO_BIN_EXE_twinray");
    let mut command = match shell_prefix {
        // `sh -c 'ulimit ...; exec twinray "$@"' sh ARGS...`
        Some(prefix) => {
            let mut c = Command::new("sh");
            c.arg("-c")
                .arg(format!("{prefix}; exec \"$0\" \"$@\""))
                .arg(bin);
            c
        }
        None => Command::new(bin),
    };
    command
        .args(args)
        .env_remove("RUST_BACKTRACE")
        .output()
        .expect("cannot start the twinray binary")
}

fn twinray(args: &[&str]) -> Output {
    twinray_in(None, args)
}

/// Fails with exactly one `twinray: ` line containing `fragment`; returns it.
fn refused(out: &Output, fragment: &str) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "should fail: {stderr}");
    assert_ne!(out.status.code(), Some(101), "panicked: {stderr}");
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(lines.len(), 1, "one line expected:\n{stderr}");
    assert!(lines[0].starts_with("twinray: "), "{stderr}");
    assert!(lines[0].contains(fragment), "'{fragment}' not in: {stderr}");
    lines[0].to_string()
}

fn succeeded(out: &Output) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "failed: {stderr}");
    stderr
}

fn scene() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/example.nff")
}

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

fn entries(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .expect("dir")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// `twinray render example.nff -o DIR/out.png --size 24x18 EXTRA...`
fn render_in(dir: &TempDir, out: &str, extra: &[&str]) -> Output {
    let out = dir.path().join(out);
    let scene = scene();
    let mut args = vec!["render", s(&scene), "-o", s(&out), "--size", SIZE];
    args.extend_from_slice(extra);
    twinray(&args)
}

fn write_scene(dir: &TempDir, name: &str, text: &str) -> PathBuf {
    let path = dir.path().join(name);
    std::fs::write(&path, text).expect("write scene");
    path
}

const VIEW: &str = "v\nfrom 0 -5 1\nat 0 0 0\nup 0 0 1\nangle 40\nhither 0\nresolution 24 18\n";

#[test]
fn huge_stereo_shifts_are_refused_with_why() {
    // The attack: a capacity-overflow panic printed ~35 times, or a 23 GB
    // allocation aborting.
    let dir = TempDir::new().expect("tmp");
    let out = render_in(
        &dir,
        "o.png",
        &["--stereo", "--interaxial", "0.3", "--convergence", "4e-9"],
    );
    refused(&out, "more than the image is wide");
    let narrow = write_scene(
        &dir,
        "narrow.nff",
        &format!("{}s 0 0 0 1\n", VIEW.replace("angle 40", "angle 1e-7")),
    );
    let out_png = dir.path().join("o.png");
    let out = twinray(&[
        "render",
        s(&narrow),
        "-o",
        s(&out_png),
        "--stereo",
        "--interaxial",
        "0.3",
    ]);
    refused(&out, "more than the image is wide");
    assert_eq!(entries(dir.path()), vec!["narrow.nff".to_string()]);
}

#[test]
fn depth_threads_and_weights_out_of_range_are_refused_at_once() {
    // The attack: --max-depth 1693 and up overflowed the stack, 4294967295 was
    // accepted, 0 and --min-weight nan silently coerced, --threads 10000 failed
    // after 13 s.
    let dir = TempDir::new().expect("tmp");
    for (extra, fragment) in [
        (&["--max-depth", "1693"][..], "--max-depth"),
        (&["--max-depth", "4294967295"], "between 1"),
        (&["--max-depth", "0"], "--max-depth"),
        (&["--min-weight", "nan"], "--min-weight"),
        (&["--min-weight=-1"], "--min-weight"),
        (&["--threads", "10000"], "--threads"),
        (&["--spd", "--min-weight", "0.1"], "--spd"),
    ] {
        refused(&render_in(&dir, "o.png", extra), fragment);
    }
    assert!(entries(dir.path()).is_empty());
    succeeded(&render_in(&dir, "o.png", &["--max-depth", "64", "--quiet"]));
}

#[test]
fn ignored_flag_combinations_are_refused() {
    let dir = TempDir::new().expect("tmp");
    let stereo = ["--stereo", "--interaxial", "0.1"];
    for (extra, fragment) in [
        (vec!["--interaxial", "0.1"], "--interaxial needs --stereo"),
        (vec!["--views", "1", "--interaxial", "0.1"], "--interaxial"),
        (
            [&stereo[..], &["--layout", "anaglyph", "--squeeze"]].concat(),
            "--squeeze",
        ),
        (
            [&stereo[..], &["--anaglyph", "gray"]].concat(),
            "--anaglyph",
        ),
        (
            [&stereo[..], &["--layout", "sbs", "--interlace", "checker"]].concat(),
            "--interlace",
        ),
    ] {
        refused(&render_in(&dir, "o.png", &extra), fragment);
    }
    assert!(entries(dir.path()).is_empty());
    let scene = scene();
    for (extra, fragment) in [
        (&["--sizes", "0"][..], "--sizes"),
        (&["--interaxial=-1"], "--interaxial"),
        (&["--threads", "10000"], "--threads"),
    ] {
        let mut args = vec!["bench-stereo", s(&scene), "--runs", "1"];
        args.extend_from_slice(extra);
        refused(&twinray(&args), fragment);
    }
}

#[test]
fn jobs_larger_than_the_memory_are_refused_before_rendering() {
    // The attack: --size 16384x16384 peaked at 9 GB and aborted under an 8 GB
    // limit after 17 s; --views 32 --size 4096x4096 after 39 s;
    // bench-stereo --sizes 100000 aborted. Here under a 3 GB address-space limit.
    let dir = TempDir::new().expect("tmp");
    let limit = Some("ulimit -v 3000000");
    let scene = scene();
    let out = dir.path().join("o.png");
    let run = |extra: &[&str]| {
        let mut args = vec!["render", s(&scene), "-o", s(&out)];
        args.extend_from_slice(extra);
        twinray_in(limit, &args)
    };
    refused(&run(&["--size", "16384x16384"]), "of memory");
    refused(
        &run(&[
            "--size",
            "4096x4096",
            "--views",
            "32",
            "--interaxial",
            "0.01",
        ]),
        "needs about",
    );
    let bench = twinray_in(limit, &["bench-stereo", s(&scene), "--sizes", "100000"]);
    refused(&bench, "of memory");
    assert!(entries(dir.path()).is_empty());
}

#[test]
fn stats_and_outputs_never_overwrite_inputs_or_each_other() {
    // The attack: `--stats scene.nff` overwrote the scene with JSON and exited
    // 0; `--stats out.png` overwrote the image.
    let dir = TempDir::new().expect("tmp");
    let original = std::fs::read_to_string(scene()).expect("scene");
    let scene = write_scene(&dir, "scene.nff", &original);
    let out = dir.path().join("out.png");
    let render = |extra: &[&str]| {
        let mut args = vec!["render", s(&scene), "-o", s(&out), "--size", SIZE];
        args.extend_from_slice(extra);
        twinray(&args)
    };
    refused(
        &render(&["--stats", s(&scene)]),
        "would overwrite the input",
    );
    refused(&render(&["--stats", s(&out)]), "written twice");
    let out_nff = dir.path().join("./scene.nff");
    refused(
        &twinray(&["render", s(&scene), "-o", s(&out_nff)]),
        "scene.nff",
    );
    assert_eq!(std::fs::read_to_string(&scene).expect("scene"), original);
    assert_eq!(entries(dir.path()), vec!["scene.nff".to_string()]);
    // --stats to a device is written through: /dev/null stays a device.
    succeeded(&render(&["--stats", "/dev/null", "--quiet"]));
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let meta = std::fs::metadata("/dev/null").expect("/dev/null");
        assert!(meta.file_type().is_char_device());
    }
}

#[cfg(unix)]
#[test]
fn read_only_and_impossible_outputs_are_refused_before_rendering() {
    // The attack: a missing directory found after 8.8 s, an MPO interaxial over
    // 4000 after 19 s, a JPEG over 65,535 px after the render; a read-only
    // file replaced by the rename.
    use std::os::unix::fs::PermissionsExt;
    let read_only_file = |path: &Path, bytes: &[u8]| {
        std::fs::write(path, bytes).expect("write");
        std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o444)).expect("chmod");
    };
    let dir = TempDir::new().expect("tmp");
    let locked = dir.path().join("locked.png");
    read_only_file(&locked, b"keep me");
    refused(
        &render_in(&dir, "locked.png", &[]),
        "locked.png: is read-only",
    );
    assert_eq!(std::fs::read(&locked).expect("read"), b"keep me");
    let msg = refused(&render_in(&dir, "no/such/dir/o.png", &[]), "no directory");
    assert!(
        msg.contains("no/such/dir/o.png"),
        "names the user's path: {msg}"
    );
    let stereo = ["--stereo", "--interaxial", "4001"];
    refused(
        &render_in(
            &dir,
            "o.mpo",
            &[&stereo[..], &["--layout", "mpo", "--convergence", "inf"]].concat(),
        ),
        "an MPO stores an interaxial",
    );
    let scene = scene();
    let wide = dir.path().join("wide.jpg");
    let args = ["render", s(&scene), "-o", s(&wide), "--size", "70000x1"];
    refused(
        &twinray(&[&args[..], &["--max-resolution", "70000"]].concat()),
        "at most 65535",
    );
    // One view of a set that cannot be written: nothing of the set is.
    read_only_file(&dir.path().join("v_2.png"), b"old");
    refused(
        &render_in(&dir, "v.png", &["--views", "4", "--interaxial", "0.01"]),
        "v_2.png",
    );
    std::fs::create_dir(dir.path().join("pair_R.png")).expect("mkdir");
    refused(
        &render_in(&dir, "pair.png", &["--stereo", "--interaxial", "0.1"]),
        "pair_R.png: is a directory",
    );
    assert_eq!(
        entries(dir.path()),
        vec![
            "locked.png".to_string(),
            "pair_R.png".into(),
            "v_2.png".into()
        ]
    );
}

#[cfg(unix)]
#[test]
fn symlinked_outputs_stay_symlinks() {
    let dir = TempDir::new().expect("tmp");
    let real = dir.path().join("real.png");
    std::fs::write(&real, b"old").expect("write");
    std::os::unix::fs::symlink(&real, dir.path().join("link.png")).expect("symlink");
    succeeded(&render_in(&dir, "link.png", &["--quiet"]));
    let link = std::fs::symlink_metadata(dir.path().join("link.png")).expect("link");
    assert!(link.file_type().is_symlink());
    assert!(std::fs::read(&real).expect("read").starts_with(b"\x89PNG"));
}

#[test]
fn materials_out_of_range_are_clamped_with_a_warning() {
    // The attack: `f 1 1 1 0.7 0.3 -1e20 0 1` gave infinite pixels.
    let dir = TempDir::new().expect("tmp");
    let scene = write_scene(
        &dir,
        "bad.nff",
        &format!("{VIEW}l 0 -5 5\nf 1 1 1 0.7 0.3 -1e20 0 1\ns 0 0 0 1\n"),
    );
    let out = dir.path().join("o.pfm");
    let stderr = succeeded(&twinray(&["render", s(&scene), "-o", s(&out), "--quiet"]));
    assert!(
        stderr.contains("bad.nff:9: material Shine -100000000000000000000 clamped to 0"),
        "{stderr}"
    );
    let bytes = std::fs::read(&out).expect("pfm");
    let data = &bytes[bytes.len() - 24 * 18 * 12..];
    assert!(data
        .chunks_exact(4)
        .all(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]).is_finite()));
}

#[test]
fn written_files_are_listed_unless_quiet() {
    let dir = TempDir::new().expect("tmp");
    let stderr = succeeded(&render_in(
        &dir,
        "pair.png",
        &["--stereo", "--interaxial", "0.1"],
    ));
    let l = dir.path().join("pair_L.png");
    let r = dir.path().join("pair_R.png");
    assert!(
        stderr.contains(&format!("wrote {}\nwrote {}", l.display(), r.display())),
        "{stderr}"
    );
    let quiet = succeeded(&render_in(&dir, "o.png", &["--quiet"]));
    assert!(quiet.is_empty(), "{quiet}");
}

#[test]
fn compare_exits_non_zero_beyond_its_thresholds() {
    let dir = TempDir::new().expect("tmp");
    succeeded(&render_in(&dir, "a.png", &["--quiet"]));
    succeeded(&render_in(&dir, "b.png", &["--quiet", "--max-depth", "1"]));
    let (a, b) = (dir.path().join("a.png"), dir.path().join("b.png"));
    let compare = |extra: &[&str]| {
        let mut args = vec!["compare", s(&a), s(&b)];
        args.extend_from_slice(extra);
        twinray(&args)
    };
    succeeded(&compare(&[]));
    succeeded(&compare(&["--max-diff", "1", "--min-psnr", "1"]));
    let out = compare(&["--max-diff", "0"]);
    assert_eq!(out.status.code(), Some(1));
    refused(&out, "more than --max-diff 0");
    refused(&compare(&["--min-psnr", "1000"]), "below --min-psnr 1000");
    refused(&compare(&["--diff", s(&a)]), "would overwrite the input");
    let missing = dir.path().join("missing.png");
    refused(&twinray(&["compare", s(&a), s(&missing)]), "input ");
}

#[test]
fn help_describes_layout_options_and_formats() {
    let help = String::from_utf8_lossy(&twinray(&["render", "--help"]).stdout).into_owned();
    for text in [
        "dubois",
        "checker",
        ".jpg",
        "--interlace",
        "1 to 64",
        "1 to 1024",
    ] {
        assert!(help.contains(text), "render --help lacks {text}");
    }
    let help = String::from_utf8_lossy(&twinray(&["compare", "--help"]).stdout).into_owned();
    for text in ["gain", "--max-diff", "--min-psnr", "input"] {
        assert!(help.contains(text), "compare --help lacks {text}");
    }
}

#[cfg(unix)]
#[test]
fn sigterm_leaves_no_temporary_file() {
    // The attack: SIGINT/SIGTERM while writing left `.twinray-*.tmp`. The
    // signal lands during the render or the write; either way the process
    // exits 130 and leaves nothing behind.
    let dir = TempDir::new().expect("tmp");
    let out = dir.path().join("big.exr");
    let scene = scene();
    let mut child = Command::new(env!("CARGO_BIN_EXE_twinray"))
        .args([
            "render",
            s(&scene),
            "-o",
            s(&out),
            "--size",
            "2000x2000",
            "--quiet",
        ])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("spawn");
    std::thread::sleep(std::time::Duration::from_millis(700));
    let killed = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .expect("kill");
    assert!(killed.success());
    let status = child.wait().expect("wait");
    assert_eq!(status.code(), Some(130), "{status:?}");
    assert!(entries(dir.path()).is_empty(), "{:?}", entries(dir.path()));
}

//! Regression tests of the attacks on the `twinray` command: every abuse is
//! refused at once with one `twinray: ...` line and nothing written, files
//! are never clobbered (no output replaces an input), and the messages a
//! new user meets say what to do.

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
    // Notes printed before the refusal (the up axis guessed, how frames
    // are named) are not part of the error.
    let lines: Vec<&str> = stderr
        .lines()
        .filter(|l| !l.starts_with("twinray: note: "))
        .collect();
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

/// A glTF quad in `dir` whose buffer is the file `g/model.bin` and whose
/// material's texture is `tex.png`, with an MTL-textured OBJ beside it.
fn model_tree(dir: &TempDir) -> (PathBuf, PathBuf) {
    let d = dir.path();
    std::fs::create_dir_all(d.join("g")).expect("mkdir");
    let positions: [f32; 9] = [-1., -1., 0., 1., -1., 0., 0., 1., 0.];
    let bytes: Vec<u8> = positions.iter().flat_map(|x| x.to_le_bytes()).collect();
    std::fs::write(d.join("g/model.bin"), &bytes).expect("bin");
    let gltf = d.join("model.gltf");
    std::fs::write(
        &gltf,
        r#"{"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
            "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
            "buffers": [{"byteLength": 36, "uri": "g/model.bin"}],
            "bufferViews": [{"buffer": 0, "byteLength": 36}],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                           "min": [-1, -1, 0], "max": [1, 1, 0]}]}"#,
    )
    .expect("gltf");
    std::fs::write(d.join("m.mtl"), "newmtl m\nKd 1 0 0\n").expect("mtl");
    let obj = d.join("m.obj");
    std::fs::write(
        &obj,
        "mtllib m.mtl\nv -1 -1 0\nv 1 -1 0\nv 0 1 0\nusemtl m\nf 1 2 3\n",
    )
    .expect("obj");
    (gltf, obj)
}

#[test]
fn outputs_never_overwrite_what_the_scene_read() {
    // The attack: `--stats g/model.bin` replaced a glTF's buffer with JSON,
    // `--stats` over the MTL replaced the MTL, `--env env.exr -o env.exr`
    // replaced the environment image; all with exit 0.
    let dir = TempDir::new().expect("tmp");
    let (gltf, obj) = model_tree(&dir);
    let d = dir.path();
    let out = d.join("o.png");
    let (bin, mtl) = (d.join("g/model.bin"), d.join("m.mtl"));
    let before: Vec<Vec<u8>> = [&gltf, &obj, &bin, &mtl]
        .iter()
        .map(|p| std::fs::read(p).expect("read"))
        .collect();
    let render = |scene: &Path, out: &Path, extra: &[&str]| {
        let mut args = vec!["render", s(scene), "-o", s(out), "--size", SIZE];
        args.extend_from_slice(extra);
        twinray(&args)
    };
    let line = refused(
        &render(&gltf, &out, &["--stats", s(&bin)]),
        "would overwrite the input",
    );
    assert!(line.contains("model.bin"), "{line}");
    refused(
        &render(&obj, &out, &["--stats", s(&mtl)]),
        "would overwrite the input",
    );
    // The same file by another name: a hard link, a symbolic link.
    std::fs::hard_link(&mtl, d.join("hard.json")).expect("link");
    refused(
        &render(&obj, &out, &["--stats", s(&d.join("hard.json"))]),
        "would overwrite the input",
    );
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(&bin, d.join("soft.json")).expect("symlink");
        refused(
            &render(&gltf, &out, &["--stats", s(&d.join("soft.json"))]),
            "would overwrite the input",
        );
    }
    // Tiles: the tile's own file name is checked.
    let tile = d.join("g/t_tile0of2.png");
    std::fs::copy(&bin, &tile).expect("copy");
    let mut doc = std::fs::read_to_string(&gltf).expect("gltf");
    doc = doc.replace("g/model.bin", "g/t_tile0of2.png");
    let tiled = d.join("tiled.gltf");
    std::fs::write(&tiled, doc).expect("write");
    refused(
        &render(&tiled, &d.join("g/t.png"), &["--tiles", "2", "--tile", "0"]),
        "would overwrite the input",
    );
    // The environment image, and a job file.
    let env = d.join("env.exr");
    succeeded(&render(&gltf, &env, &["--quiet"]));
    let env_before = std::fs::read(&env).expect("env");
    refused(
        &render(&gltf, &env, &["--env", s(&env)]),
        "would overwrite the input",
    );
    assert_eq!(std::fs::read(&env).expect("env"), env_before);
    let job = d.join("job.png");
    let spec = twinray(&["render", s(&gltf), "-o", s(&out), "--print-job"]);
    std::fs::write(&job, &spec.stdout).expect("job");
    refused(
        &twinray(&["render", "--job", s(&job), "-o", s(&job)]),
        "would overwrite the input",
    );
    assert_eq!(std::fs::read(&job).expect("job"), spec.stdout);
    let after: Vec<Vec<u8>> = [&gltf, &obj, &bin, &mtl]
        .iter()
        .map(|p| std::fs::read(p).expect("read"))
        .collect();
    assert_eq!(before, after);
}

#[test]
fn a_camera_path_is_never_a_frames_output() {
    let dir = TempDir::new().expect("tmp");
    let path = dir.path().join("cam_0000.png");
    std::fs::write(&path, "0 from 0,-5,1 at 0,0,0\n1 from 1,-5,1 at 0,0,0\n").expect("path");
    let scene = scene();
    let pattern = dir.path().join("cam_####.png");
    let out = twinray(&[
        "render",
        s(&scene),
        "-o",
        s(&pattern),
        "--size",
        SIZE,
        "--frames",
        "0..1",
        "--path",
        s(&path),
    ]);
    refused(&out, "would overwrite the input");
}

#[test]
fn scenes_read_only_their_folder_unless_allowed() {
    // The attack: `map_Kd ..\secret\x.png` and `mtllib /etc/passwd` were read.
    let dir = TempDir::new().expect("tmp");
    std::fs::create_dir_all(dir.path().join("scene")).expect("mkdir");
    std::fs::create_dir_all(dir.path().join("secret")).expect("mkdir");
    std::fs::write(dir.path().join("secret/m.mtl"), "newmtl m\nKd 1 0 0\n").expect("mtl");
    let obj = dir.path().join("scene/a.obj");
    std::fs::write(
        &obj,
        "mtllib ../secret/m.mtl\nv -1 -1 0\nv 1 -1 0\nv 0 1 0\nusemtl m\nf 1 2 3\n",
    )
    .expect("obj");
    let out = dir.path().join("o.png");
    let stderr = succeeded(&twinray(&[
        "render",
        s(&obj),
        "-o",
        s(&out),
        "--size",
        SIZE,
    ]));
    assert!(
        stderr.contains("warning: ") && stderr.contains("is outside the scene's folder"),
        "{stderr}"
    );
    assert!(stderr.contains("--allow-dir"), "{stderr}");
    let allowed = succeeded(&twinray(&[
        "render",
        s(&obj),
        "-o",
        s(&out),
        "--size",
        SIZE,
        "--allow-dir",
        s(&dir.path().join("secret")),
    ]));
    assert!(!allowed.contains("outside"), "{allowed}");
    // The folders allowed are part of the job.
    let job = twinray(&[
        "render",
        s(&obj),
        "-o",
        s(&out),
        "--allow-dir",
        s(&dir.path().join("secret")),
        "--print-job",
    ]);
    let text = String::from_utf8_lossy(&job.stdout);
    assert!(
        text.contains("\"allow_dirs\"") && text.contains("secret"),
        "{text}"
    );
}

#[cfg(unix)]
#[test]
fn devices_fifos_and_folders_named_by_the_user_are_refused_at_once() {
    // The attack: a scene of /dev/zero grew to 2.1 GB, then "out of memory";
    // a FIFO hung forever.
    let dir = TempDir::new().expect("tmp");
    let fifo = dir.path().join("fifo.nff");
    assert!(Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .expect("mkfifo")
        .success());
    std::os::unix::fs::symlink("/dev/zero", dir.path().join("zero.glb")).expect("symlink");
    std::os::unix::fs::symlink("/dev/zero", dir.path().join("zero.hdr")).expect("symlink");
    let out = dir.path().join("o.png");
    let start = std::time::Instant::now();
    for (args, says) in [
        (
            vec!["render", s(&fifo), "-o", s(&out)],
            "not a regular file",
        ),
        (
            vec!["render", s(&dir.path().join("zero.glb")), "-o", s(&out)],
            "not a regular file",
        ),
        (
            vec![
                "render",
                s(&scene()),
                "-o",
                s(&out),
                "--env",
                s(&dir.path().join("zero.hdr")),
            ],
            "not a regular file",
        ),
        (
            vec!["render", "--job", "/dev/zero", "-o", s(&out)],
            "not a regular file",
        ),
        (
            vec![
                "render",
                s(&scene()),
                "-o",
                s(&out),
                "--frames",
                "0..1",
                "--path",
                "/dev/zero",
            ],
            "not a regular file",
        ),
        (
            vec![
                "render",
                s(&dir.path().join("zero.glb")),
                "-o",
                s(&out),
                "--frames",
                "0..1",
            ],
            "not a regular file",
        ),
    ] {
        refused(&twinray(&args), says);
    }
    assert!(start.elapsed().as_secs() < 60, "{:?}", start.elapsed());
    let folder = dir.path().join("folder.obj");
    std::fs::create_dir(&folder).expect("mkdir");
    refused(
        &twinray(&["render", s(&folder), "-o", s(&out)]),
        "is a directory",
    );
}

/// A GLB of one mesh of `triangles` triangles (all one triangle) instanced
/// by `instances` nodes side by side.
fn instanced_glb(triangles: usize, instances: usize) -> Vec<u8> {
    let positions: [f32; 9] = [0., 0., 0., 1., 0., 0., 0., 1., 0.];
    let mut bin: Vec<u8> = positions.iter().flat_map(|x| x.to_le_bytes()).collect();
    bin.extend(std::iter::repeat_n([0u8, 1, 2], triangles).flatten());
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let nodes: Vec<String> = (0..instances)
        .map(|i| format!(r#"{{"mesh": 0, "translation": [{}, 0, 0]}}"#, 2 * i))
        .collect();
    let roots: Vec<String> = (0..instances).map(|i| i.to_string()).collect();
    let mut json = format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [{}]}}],
            "nodes": [{}],
            "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1}}]}}],
            "buffers": [{{"byteLength": {}}}],
            "bufferViews": [{{"buffer": 0, "byteLength": 36}},
                            {{"buffer": 0, "byteOffset": 36, "byteLength": {}}}],
            "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                            "min": [0, 0, 0], "max": [1, 1, 0]}},
                          {{"bufferView": 1, "componentType": 5121, "count": {}, "type": "SCALAR"}}]}}"#,
        roots.join(", "),
        nodes.join(", "),
        bin.len(),
        triangles * 3,
        triangles * 3
    )
    .into_bytes();
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let mut out = b"glTF".to_vec();
    out.extend(2u32.to_le_bytes());
    out.extend(((12 + 8 + json.len() + 8 + bin.len()) as u32).to_le_bytes());
    out.extend((json.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(json);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(bin);
    out
}

#[test]
fn a_scene_larger_than_the_memory_is_refused_before_it_is_made() {
    // The attack: a GLB instancing a 1M-triangle mesh 40 times (under the
    // triangle limit) aborted with "memory allocation of ... failed" and a
    // backtrace. Here under a 3 GB address-space limit.
    let dir = TempDir::new().expect("tmp");
    let glb = dir.path().join("forty.glb");
    std::fs::write(&glb, instanced_glb(1_000_000, 40)).expect("glb");
    let out = dir.path().join("o.png");
    let run = twinray_in(
        Some("ulimit -v 3000000"),
        &["render", s(&glb), "-o", s(&out)],
    );
    let line = refused(&run, "forty.glb: 40000000 triangles: needs about");
    assert!(line.contains("is available"), "{line}");
    assert!(!String::from_utf8_lossy(&run.stderr).contains("memory allocation"));
    assert_eq!(entries(dir.path()), vec!["forty.glb".to_string()]);
}

#[test]
fn small_items_are_refused_with_why() {
    // The attack: --tiles 0 exited 0 having done nothing; a --job of size
    // [0, 0] reached "rows 0..0 of a 0-row image"; --frames 0..4294967295
    // was accepted; f_##_##.png replaced only its last run of #.
    let dir = TempDir::new().expect("tmp");
    let scene = scene();
    let out = dir.path().join("o.png");
    refused(
        &twinray(&["render", s(&scene), "-o", s(&out), "--tiles", "0"]),
        "--tiles",
    );
    let spec = twinray(&["render", s(&scene), "-o", s(&out), "--print-job"]);
    let text = String::from_utf8_lossy(&spec.stdout).replace("\"size\": null", "\"size\": [0, 0]");
    assert!(text.contains("[0, 0]"), "{text}");
    let job = dir.path().join("job.json");
    std::fs::write(&job, text).expect("job");
    refused(
        &twinray(&["render", "--job", s(&job)]),
        "--size 0x0: width and height must be at least 1",
    );
    refused(
        &twinray(&[
            "render",
            s(&scene),
            "-o",
            s(&out),
            "--frames",
            "0..4294967295",
        ]),
        "at most 1000000",
    );
    let two_runs = dir.path().join("f_##_##.png");
    refused(
        &twinray(&[
            "render",
            s(&scene),
            "-o",
            s(&two_runs),
            "--frames",
            "0..1",
            "--size",
            SIZE,
        ]),
        "the frame number goes in one place",
    );
    assert_eq!(entries(dir.path()), vec!["job.json".to_string()]);
}

//! The command line is a front end of `twinray::job`: the same job through
//! the binary and through the library writes the same bytes, and a job
//! printed by `--print-job` and run by `--job` renders the same image.

use std::path::{Path, PathBuf};
use std::process::Command;

use tempfile::TempDir;
use twinray::job::{CancelToken, Job, JobSpec, LayoutSpec};

fn example() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes/example.nff")
}

/// Runs the binary; panics with its stderr unless it exits 0. Returns stdout.
fn twinray(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_twinray"))
        .args(args)
        .output()
        .expect("the binary runs");
    assert!(
        out.status.success(),
        "twinray {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn bytes(p: &Path) -> Vec<u8> {
    std::fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// The flags of a small anti-aliased stereo pair side by side (the default
/// automatic rig: a depth pass, then the render).
const PAIR_FLAGS: [&str; 6] = ["--size", "64x48", "--stereo", "--layout", "sbs", "-q"];

#[test]
fn the_cli_and_the_library_write_the_same_bytes() {
    let dir = TempDir::new().unwrap();
    let (by_cli, by_library) = (dir.path().join("cli.png"), dir.path().join("lib.png"));
    let scene = example();
    let mut args = vec!["render", scene.to_str().unwrap(), "-o"];
    args.push(by_cli.to_str().unwrap());
    args.extend(PAIR_FLAGS);
    twinray(&args);

    let mut spec = JobSpec::new(&scene, &by_library);
    spec.camera.size = Some([64, 48]);
    spec.rig.stereo = true;
    spec.output.layout = LayoutSpec::Sbs;
    let (written, _) = Job::run(spec, &|_, _| {}, &CancelToken::new()).unwrap();
    assert_eq!(written, vec![by_library.clone()]);
    assert_eq!(bytes(&by_cli), bytes(&by_library));
}

#[test]
fn print_job_then_job_renders_the_same_image() {
    let dir = TempDir::new().unwrap();
    let direct = dir.path().join("direct.png");
    let scene = example();
    let mut args = vec!["render", scene.to_str().unwrap(), "-o"];
    args.push(direct.to_str().unwrap());
    args.extend(PAIR_FLAGS);
    args.extend(["--interaxial", "0.3", "--samples", "4", "--filter", "tent"]);
    twinray(&args);

    let printed = twinray(&[args.as_slice(), &["--print-job"]].concat());
    let spec = JobSpec::from_json(&printed).unwrap();
    assert_eq!(spec.rig.interaxial.as_deref(), Some("0.3"));
    assert_eq!(spec.sampling.samples, Some(4));
    assert_eq!(spec.output.path, direct);
    assert!(
        !direct.with_file_name("direct_L.png").exists(),
        "--print-job rendered nothing"
    );

    let saved = dir.path().join("job.json");
    std::fs::write(&saved, &printed).unwrap();
    let again = dir.path().join("again.png");
    twinray(&[
        "render",
        "--job",
        saved.to_str().unwrap(),
        "-o",
        again.to_str().unwrap(),
        "-q",
    ]);
    assert_eq!(bytes(&direct), bytes(&again));
}

#[test]
fn job_refuses_other_flags_and_bad_files() {
    let dir = TempDir::new().unwrap();
    let saved = dir.path().join("job.json");
    std::fs::write(
        &saved,
        r#"{"scene": "x.nff", "rig": {"stereo": true, "bogus": 1}}"#,
    )
    .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_twinray"))
        .args(["render", "--job", saved.to_str().unwrap(), "-o", "x.png"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("unknown field `bogus`"), "{err}");

    std::fs::write(&saved, JobSpec::new(example(), "x.png").to_json()).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_twinray"))
        .args(["render", "--job", saved.to_str().unwrap(), "--stereo"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("--job takes every setting"), "{err}");
}

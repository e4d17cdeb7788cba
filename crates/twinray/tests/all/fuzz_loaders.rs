//! A mutation fuzzer over real files: every loader must answer any mutant with
//! a scene or a one-line error naming the file, never a panic; a scene that
//! loads renders with finite pixels. The glTF's URIs are also replaced by
//! hostile ones (outside the folder, escaped, absolute, devices, a FIFO, a
//! link out): every load ends, and reads nothing outside the scene's folder.
//!
//! The default run is a few seconds. A longer run: `scripts/fuzz.sh`, or
//! `TWINRAY_FUZZ_ITERS=20000 TWINRAY_FUZZ_SEED=7 cargo test --release -p twinray --test all fuzz_loaders::`

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

use twinray::job::{CancelToken, Job, JobSpec};
use twinray::loaders::{load_scene, LoadOptions};
use twinray::Scene;

fn models() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/models")
}

fn env_or(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// Interesting replacements: numbers at the edges of what parsers take.
const TOKENS: &[&[u8]] = &[
    b"0",
    b"-1",
    b"1e39",
    b"nan",
    b"-0",
    b"4294967295",
    b"99999999999",
    b"1/",
    b"//",
    b"\"",
    b"{",
    b"}",
    b"[",
    b"]",
    b",",
    b":",
    b"null",
    b"\n",
    b" ",
    b"\x00",
    b"\xff",
];

fn mutate(rng: &mut fastrand::Rng, data: &[u8]) -> Vec<u8> {
    let mut d = data.to_vec();
    for _ in 0..rng.usize(1..=4) {
        if d.is_empty() {
            d.extend_from_slice(TOKENS[rng.usize(..TOKENS.len())]);
            continue;
        }
        let at = rng.usize(..d.len());
        match rng.u8(..7) {
            0 => d[at] ^= 1 << rng.u8(..8),
            1 => d[at] = rng.u8(..),
            2 => {
                let end = (at + rng.usize(1..64)).min(d.len());
                d.drain(at..end);
            }
            3 => {
                let end = (at + rng.usize(1..256)).min(d.len());
                let chunk = d[at..end].to_vec();
                let to = rng.usize(..=d.len());
                d.splice(to..to, chunk);
            }
            4 => {
                let t = TOKENS[rng.usize(..TOKENS.len())];
                d.splice(at..at, t.iter().copied());
            }
            5 => {
                // Replace the next run of digits (an index, a count, an
                // offset) with an extreme number.
                let Some(start) = d[at..].iter().position(u8::is_ascii_digit) else {
                    continue;
                };
                let start = at + start;
                let mut end = start;
                while end < d.len() && d[end].is_ascii_digit() {
                    end += 1;
                }
                let t = TOKENS[rng.usize(..6)];
                d.splice(start..end, t.iter().copied());
            }
            _ => d.truncate(at),
        }
    }
    d
}

/// Fuzzes `target` (a file among `files`, all copied to a scratch directory
/// together so that references between them resolve); `scene` is loaded.
/// Renders `scene` as a job would (its lights and camera) at 6 x 4, pixel
/// centres; `Err` names a pixel that is not finite.
fn finite_pixels(scene: Scene, path: &Path) -> Result<(), String> {
    let mut spec = JobSpec::new(path, path.with_extension("exr"));
    spec.camera.size = Some([6, 4]);
    spec.sampling.samples = Some(1);
    spec.trace.threads = Some(1);
    let job = Job::check(spec).map_err(|e| e.to_string())?;
    // A scene the job refuses (a camera it cannot use) is not a failure.
    let Ok(loaded) = job.prepare(scene) else {
        return Ok(());
    };
    let Ok(plan) = job.plan(&loaded) else {
        return Ok(());
    };
    let rendered = job
        .render(&plan, &|_, _| {}, &CancelToken::new())
        .map_err(|e| e.to_string())?;
    for (v, image) in rendered.output.images.iter().enumerate() {
        if let Some(i) = image.pixels.iter().position(|c| !c.is_finite()) {
            return Err(format!("view {v}, pixel {i}: {}", image.pixels[i]));
        }
    }
    Ok(())
}

fn fuzz(files: &[&str], target: &str, scene: &str, seed_offset: u64) {
    let iters = env_or("TWINRAY_FUZZ_ITERS", 150);
    let seed = env_or("TWINRAY_FUZZ_SEED", 1) + seed_offset;
    let dir = tempfile::tempdir().unwrap();
    for f in files {
        let from = models().join(f);
        let to = dir.path().join(Path::new(f).file_name().unwrap());
        std::fs::copy(&from, &to).unwrap();
    }
    let target_path = dir.path().join(target);
    let original = std::fs::read(&target_path).unwrap();
    let scene_path = dir.path().join(scene);
    let mut rng = fastrand::Rng::with_seed(seed);
    let (mut ok, mut errors) = (0, 0);
    for i in 0..iters {
        let mutant = mutate(&mut rng, &original);
        std::fs::write(&target_path, &mutant).unwrap();
        let result = catch_unwind(AssertUnwindSafe(|| {
            load_scene(&scene_path, &LoadOptions::default())
        }));
        match result {
            Err(_) => {
                let keep = std::env::temp_dir().join(format!("twinray-fuzz-crash-{target}"));
                std::fs::write(&keep, &mutant).unwrap();
                panic!(
                    "{target}: mutant {i} (seed {seed}) panicked the loader; kept as {}",
                    keep.display()
                );
            }
            Ok(Ok(loaded)) => {
                if let Err(e) = finite_pixels(loaded, &scene_path) {
                    let keep = std::env::temp_dir().join(format!("twinray-fuzz-nan-{target}"));
                    std::fs::write(&keep, &mutant).unwrap();
                    panic!(
                        "{target}: mutant {i} (seed {seed}): {e}; kept as {}",
                        keep.display()
                    );
                }
                ok += 1
            }
            Ok(Err(e)) => {
                let msg = e.to_string();
                assert!(
                    !msg.contains('\n'),
                    "{target}: mutant {i}: not one line: {msg}"
                );
                assert!(
                    msg.contains(target) || msg.contains(scene),
                    "{target}: mutant {i}: error does not name the file: {msg}"
                );
                errors += 1;
            }
        }
    }
    eprintln!("{target}: {iters} mutants, {ok} loaded, {errors} refused, no panic");
}

// The OBJ's MTL names `../cube.png`, outside the scratch directory: a
// warning, so mutants still reach the geometry.
#[test]
fn obj_mutants() {
    let files = [
        "pybullet/torus/torus_textured.obj",
        "pybullet/torus/torus_textured.mtl",
    ];
    fuzz(&files, "torus_textured.obj", "torus_textured.obj", 0);
}

#[test]
fn mtl_mutants() {
    let files = [
        "pybullet/torus/torus_textured.obj",
        "pybullet/torus/torus_textured.mtl",
    ];
    fuzz(&files, "torus_textured.mtl", "torus_textured.obj", 100);
}

#[test]
fn glb_mutants() {
    fuzz(&["gltf/torus.glb"], "torus.glb", "torus.glb", 200);
}

#[test]
fn gltf_json_mutants() {
    let files = [
        "gltf/torus.gltf",
        "gltf/torus_textured.bin",
        "gltf/cube.png",
    ];
    fuzz(&files, "torus.gltf", "torus.gltf", 300);
}

#[test]
fn gltf_buffer_mutants() {
    let files = [
        "gltf/torus.gltf",
        "gltf/torus_textured.bin",
        "gltf/cube.png",
    ];
    fuzz(&files, "torus_textured.bin", "torus.gltf", 400);
}

#[test]
fn texture_mutants() {
    let files = [
        "gltf/torus.gltf",
        "gltf/torus_textured.bin",
        "gltf/cube.png",
    ];
    fuzz(&files, "cube.png", "torus.gltf", 500);
}

/// URIs a hostile glTF file may give a buffer or an image: outside the
/// folder (plainly, escaped, with backslashes, absolute, through a link),
/// devices, a FIFO, a folder, network and broken data URIs.
const HOSTILE_URIS: &[&str] = &[
    "../secret.bin",
    "%2E%2E/secret.bin",
    "%2e%2e%2fsecret.bin",
    "..\\secret.bin",
    "sub/../../secret.bin",
    "/etc/passwd",
    "/etc/shadow",
    "/dev/zero",
    "/dev/urandom",
    "/proc/self/environ",
    "fifo.bin",
    "link-out.bin",
    "link-zero.bin",
    ".",
    "sub",
    "file:///etc/passwd",
    "http://example.invalid/x.bin",
    "data:application/octet-stream;base64,!!!",
    "data:image/png;base64,",
    "",
    "%00",
    "torus_textured.bin%00.png",
];

/// The torus glTF with its buffer's and its image's URIs replaced by
/// hostile ones, one or both at a time: every load must end (a FIFO must
/// not block it), never panic, and read nothing outside the folder; an
/// error is one line naming the file.
#[test]
fn gltf_uri_mutants() {
    let iters = env_or("TWINRAY_FUZZ_ITERS", 150);
    let seed = env_or("TWINRAY_FUZZ_SEED", 1) + 600;
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("scene");
    std::fs::create_dir_all(dir.join("sub")).unwrap();
    for f in [
        "gltf/torus.gltf",
        "gltf/torus_textured.bin",
        "gltf/cube.png",
    ] {
        let from = models().join(f);
        std::fs::copy(&from, dir.join(Path::new(f).file_name().unwrap())).unwrap();
    }
    // The secret: a valid buffer and image outside the folder.
    std::fs::copy(
        dir.join("torus_textured.bin"),
        root.path().join("secret.bin"),
    )
    .unwrap();
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(root.path().join("secret.bin"), dir.join("link-out.bin"))
            .unwrap();
        std::os::unix::fs::symlink("/dev/zero", dir.join("link-zero.bin")).unwrap();
        let fifo = std::process::Command::new("mkfifo")
            .arg(dir.join("fifo.bin"))
            .status()
            .unwrap();
        assert!(fifo.success());
    }
    let original: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("torus.gltf")).unwrap()).unwrap();
    let scene_path = dir.join("torus.gltf");
    let canonical_dir = std::fs::canonicalize(&dir).unwrap();
    let mut rng = fastrand::Rng::with_seed(seed);
    let (mut ok, mut errors) = (0, 0);
    for i in 0..iters {
        let mut doc = original.clone();
        let pick = |rng: &mut fastrand::Rng| HOSTILE_URIS[rng.usize(..HOSTILE_URIS.len())];
        let (buffer, image) = match rng.u8(..3) {
            0 => (Some(pick(&mut rng)), None),
            1 => (None, Some(pick(&mut rng))),
            _ => (Some(pick(&mut rng)), Some(pick(&mut rng))),
        };
        if let Some(uri) = buffer {
            doc["buffers"][0]["uri"] = serde_json::json!(uri);
        }
        if let Some(uri) = image {
            doc["images"][0]["uri"] = serde_json::json!(uri);
        }
        std::fs::write(&scene_path, doc.to_string()).unwrap();
        let (tx, rx) = std::sync::mpsc::channel();
        let p = scene_path.clone();
        std::thread::spawn(move || {
            let result = catch_unwind(AssertUnwindSafe(|| load_scene(&p, &LoadOptions::default())));
            let _ = tx.send(result);
        });
        let what = format!("mutant {i} (seed {seed}): buffer {buffer:?}, image {image:?}");
        let result = rx
            .recv_timeout(std::time::Duration::from_secs(30))
            .unwrap_or_else(|_| panic!("{what}: the load hangs"));
        match result {
            Err(_) => panic!("{what}: panicked the loader"),
            Ok(Ok(scene)) => {
                for input in &scene.inputs {
                    assert!(
                        input.starts_with(&canonical_dir),
                        "{what}: read {}",
                        input.display()
                    );
                }
                if let Err(e) = finite_pixels(scene, &scene_path) {
                    panic!("{what}: {e}");
                }
                ok += 1;
            }
            Ok(Err(e)) => {
                let msg = e.to_string();
                assert!(!msg.contains('\n'), "{what}: not one line: {msg}");
                assert!(
                    msg.contains("torus.gltf"),
                    "{what}: error does not name the file: {msg}"
                );
                // A short data URI may be described; no file is: every
                // hostile URI that is not data names one it must not read.
                let data = buffer.is_some_and(|u| u.starts_with("data:"));
                assert!(
                    data || !msg.contains("byteLength says"),
                    "{what}: describes a file: {msg}"
                );
                errors += 1;
            }
        }
    }
    eprintln!(
        "gltf URIs: {iters} mutants, {ok} loaded, {errors} refused, no panic, nothing read outside"
    );
}

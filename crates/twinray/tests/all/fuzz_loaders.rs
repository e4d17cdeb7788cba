//! A mutation fuzzer over real files: every loader must answer any mutant with
//! a scene or a one-line error naming the file, never a panic.
//!
//! The default run is a few seconds. A longer run:
//! `TWINRAY_FUZZ_ITERS=20000 TWINRAY_FUZZ_SEED=7 cargo test --release -p twinray --test all fuzz_loaders::`

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

use twinray::loaders::{load_scene, LoadOptions};

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
            Ok(Ok(_)) => ok += 1,
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

// The OBJ's MTL names `../cube.png`; in the scratch directory the texture is
// missing, which is a warning, so mutants still reach the geometry.
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

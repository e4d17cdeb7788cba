//! Which external programs the command's tests can run: a test that needs
//! ffmpeg and ffprobe (video outputs) or exiftool (MPO files) is compiled as
//! ignored, with the reason, where the program is missing, so that
//! `cargo test` lists it as ignored instead of passing it unchecked. Under CI
//! (`CI=true`, where `.ci/run` installs them) nothing is ignored: a missing
//! program fails its tests there.
//!
//! The cfgs, `missing_ffmpeg` and `missing_exiftool`, are set for this
//! package's targets only; the binary does not read them.

use std::env;
use std::path::Path;

fn main() {
    println!("cargo::rustc-check-cfg=cfg(missing_ffmpeg)");
    println!("cargo::rustc-check-cfg=cfg(missing_exiftool)");
    println!("cargo::rerun-if-changed=build.rs");
    println!("cargo::rerun-if-env-changed=CI");
    println!("cargo::rerun-if-env-changed=PATH");
    let path = env::var_os("PATH").unwrap_or_default();
    let dirs: Vec<_> = env::split_paths(&path).filter(|d| d.is_dir()).collect();
    // A program installed later (apt-get install ffmpeg) changes its folder.
    for dir in &dirs {
        println!("cargo::rerun-if-changed={}", dir.display());
    }
    if env::var("CI").as_deref() == Ok("true") {
        return;
    }
    let on_path = |name: &str| dirs.iter().any(|d| is_program(&d.join(name)));
    if !(on_path("ffmpeg") && on_path("ffprobe")) {
        println!("cargo::rustc-cfg=missing_ffmpeg");
    }
    if !on_path("exiftool") {
        println!("cargo::rustc-cfg=missing_exiftool");
    }
}

/// A file the user may run.
fn is_program(path: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        path.metadata()
            .is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
    }
    #[cfg(not(unix))]
    {
        path.with_extension("exe").is_file() || path.is_file()
    }
}

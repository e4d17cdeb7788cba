//! Scene loaders: turn a scene file into a [`Scene`].
//!
//! Only NFF (Eric Haines' Neutral File Format, the format of the Standard
//! Procedural Databases) for now; [`load_scene`] picks the loader by extension.

use std::path::Path;

use crate::error::{Error, Result};
use crate::scene::Scene;

pub mod nff;

/// Limits on what a scene may ask for (absurd resolutions are refused unless raised).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LoadOptions {
    /// Largest accepted image width and height, in pixels.
    pub max_resolution: u32,
    /// Largest accepted number of vertices of one polygon or patch.
    pub max_vertices: usize,
}

impl Default for LoadOptions {
    fn default() -> Self {
        LoadOptions {
            max_resolution: 16384,
            max_vertices: 1_000_000,
        }
    }
}

/// Load a scene, choosing the format by file extension (`.nff`, any case).
pub fn load_scene(path: &Path, opts: &LoadOptions) -> Result<Scene> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    match ext.as_deref() {
        Some("nff") => nff::load_nff(path, opts),
        Some(other) => Err(Error::Invalid(format!(
            "{}: unknown scene format '.{other}' (supported: .nff)",
            path.display()
        ))),
        None => Err(Error::Invalid(format!(
            "{}: cannot tell the scene format without a file extension (supported: .nff)",
            path.display()
        ))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_extension_is_invalid() {
        let e = load_scene(Path::new("scene.obj"), &LoadOptions::default()).unwrap_err();
        let Error::Invalid(msg) = &e else {
            panic!("{e:?}")
        };
        assert!(msg.contains("unknown scene format '.obj'"), "{msg}");
        assert!(msg.contains(".nff"), "{msg}");
        let e = load_scene(Path::new("scene"), &LoadOptions::default()).unwrap_err();
        assert!(matches!(e, Error::Invalid(_)), "{e:?}");
    }

    #[test]
    fn nff_extension_is_case_insensitive_and_missing_file_is_io() {
        let e = load_scene(
            Path::new("/nonexistent/twinray/scene.NFF"),
            &LoadOptions::default(),
        )
        .unwrap_err();
        let Error::Io { path, .. } = &e else {
            panic!("{e:?}")
        };
        assert_eq!(path, Path::new("/nonexistent/twinray/scene.NFF"));
    }

    #[test]
    fn loads_a_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("tiny.nff");
        std::fs::write(
            &path,
            "v\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 40\nhither 0.1\nresolution 64 48\n\
             s 0 0 0 1\n",
        )
        .unwrap();
        let scene = load_scene(&path, &LoadOptions::default()).unwrap();
        assert_eq!(scene.shapes.len(), 1);
        assert_eq!(scene.viewpoint.width, 64);
    }
}

//! Scene loaders: turn a scene file into a [`Scene`].
//!
//! NFF (Eric Haines' Neutral File Format, the format of the Standard
//! Procedural Databases), Wavefront OBJ with its MTL materials, and glTF 2.0
//! (`.gltf`, `.glb`), STL (`.stl`, binary or ASCII) and PLY (`.ply`);
//! [`load_scene`] picks the loader by extension.

use std::path::Path;

use crate::error::{Error, Result};
use crate::math::Color;
use crate::scene::{Material, Scene};

pub mod gltf;
pub mod material_model;
pub mod nff;
pub mod obj;
pub mod ply;
pub mod stl;

const SUPPORTED: &str = ".nff, .obj, .gltf, .glb, .stl, .ply";

/// Limits on what a scene may ask for (absurd resolutions are refused unless raised).
#[derive(Clone, Debug, PartialEq)]
pub struct LoadOptions {
    /// Largest accepted image width and height, in pixels.
    pub max_resolution: u32,
    /// Largest accepted number of vertices of one polygon or patch.
    pub max_vertices: usize,
    /// Largest accepted number of triangles of a mesh file (OBJ, glTF):
    /// refused before the memory for them is taken.
    pub max_triangles: u64,
    /// glTF: the animations' node transforms at this time in seconds
    /// (`None`: the nodes' own transforms).
    pub animation_time: Option<f32>,
    /// glTF: the one animation that plays, by name or index (`None`: all of
    /// them at once).
    pub animation: Option<String>,
}

impl Default for LoadOptions {
    fn default() -> Self {
        LoadOptions {
            max_resolution: 16384,
            max_vertices: 1_000_000,
            max_triangles: 100_000_000,
            animation_time: None,
            animation: None,
        }
    }
}

/// Load a scene, choosing the format by file extension (any case).
pub fn load_scene(path: &Path, opts: &LoadOptions) -> Result<Scene> {
    if path.is_dir() {
        return Err(Error::Invalid(format!(
            "{}: is a directory; give a scene file in it ({SUPPORTED})",
            path.display()
        )));
    }
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    match ext.as_deref() {
        Some("nff") => nff::load_nff(path, opts),
        Some("obj") => obj::load_obj(path, opts),
        Some("gltf") | Some("glb") => gltf::load_gltf(path, opts),
        Some("stl") => stl::load_stl(path, opts),
        Some("ply") => ply::load_ply(path, opts),
        Some(other) => Err(Error::Invalid(format!(
            "{}: unknown scene format '.{other}' (supported: {SUPPORTED})",
            path.display()
        ))),
        None => Err(Error::Invalid(format!(
            "{}: cannot tell the scene format without a file extension (supported: {SUPPORTED})",
            path.display()
        ))),
    }
}

/// Reads a whole file, naming it in the error.
fn read_file(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// The grey material of mesh faces that name none (OBJ faces without
/// `usemtl`, STL, PLY without vertex colours).
fn default_mesh_material() -> Material {
    Material {
        color: Color::splat(0.8),
        ..Material::default()
    }
}

/// Refuses a mesh file of more than `opts.max_triangles` triangles, before
/// taking their memory; reserves it otherwise (corner records too when the
/// mesh has normals or texture coordinates).
fn reserve_triangles(
    scene: &mut Scene,
    triangles: u64,
    with_corners: bool,
    file: &Path,
    opts: &LoadOptions,
) -> Result<()> {
    if triangles > opts.max_triangles {
        return Err(Error::Invalid(format!(
            "{}: {triangles} triangles exceed the limit of {}",
            file.display(),
            opts.max_triangles
        )));
    }
    scene.shapes.reserve(triangles as usize);
    if with_corners {
        scene.corners.reserve(triangles as usize);
    }
    Ok(())
}

/// A mesh file's warnings past the first `keep` folded into one line, so that
/// a scanned model with thousands of slivers does not flood the terminal.
fn fold_warnings(scene: &mut Scene, from: usize, keep: usize) {
    let extra = scene.warnings.len().saturating_sub(from + keep);
    if extra > 0 {
        scene.warnings.truncate(from + keep);
        scene
            .warnings
            .push(format!("... and {extra} more warnings like these"));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_extension_is_invalid() {
        let e = load_scene(Path::new("scene.3ds"), &LoadOptions::default()).unwrap_err();
        let Error::Invalid(msg) = &e else {
            panic!("{e:?}")
        };
        assert!(msg.contains("unknown scene format '.3ds'"), "{msg}");
        assert!(msg.contains(".nff, .obj, .gltf, .glb, .stl, .ply"), "{msg}");
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

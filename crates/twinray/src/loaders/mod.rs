//! Scene loaders: turn a scene file into a [`Scene`].
//!
//! NFF (Eric Haines' Neutral File Format, the format of the Standard
//! Procedural Databases), Wavefront OBJ with its MTL materials, and glTF 2.0
//! (`.gltf`, `.glb`), STL (`.stl`, binary or ASCII) and PLY (`.ply`);
//! [`load_scene`] picks the loader by extension.
//!
//! Every load reads its files through [`files::SceneFiles`] (confined to
//! the scene's folder, regular files only, each read bounded) and counts
//! what it keeps against a [`Budget`] of memory before allocating it.

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::math::Color;
use crate::memory::Budget;
use crate::scene::{Material, Scene};

pub mod files;
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
    /// Folders beside the scene's own whose files the scene may name
    /// (textures kept elsewhere); each with what is below it.
    pub allow_dirs: Vec<PathBuf>,
    /// Most memory the load may take, in bytes (`None`: what the machine
    /// has available when it begins).
    pub memory_limit: Option<u64>,
}

impl Default for LoadOptions {
    fn default() -> Self {
        LoadOptions {
            max_resolution: 16384,
            max_vertices: 1_000_000,
            max_triangles: 100_000_000,
            animation_time: None,
            animation: None,
            allow_dirs: Vec::new(),
            memory_limit: None,
        }
    }
}

/// What one load reads and takes: the files a scene may name, and the
/// memory it may keep.
pub(crate) struct LoadContext {
    pub files: files::SceneFiles,
    pub memory: Budget,
}

impl LoadContext {
    /// The context of a load of `scene` (a file, or bytes said to be one).
    pub fn new(scene: &Path, opts: &LoadOptions) -> LoadContext {
        LoadContext {
            files: files::SceneFiles::new(scene, &opts.allow_dirs),
            memory: match opts.memory_limit {
                Some(limit) => Budget::new(Some(limit)),
                None => Budget::of_this_machine(),
            },
        }
    }

    /// The scene loaded: the files read are recorded as its inputs.
    pub fn finish(&self, mut scene: Scene) -> Scene {
        scene.inputs = self.files.inputs();
        scene
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

/// `text` as a message quotes what a file holds: at most `max` bytes
/// (then `...`), control characters escaped (a 100 MB line of NULs is not
/// a message).
pub(crate) fn excerpt(text: &str, max: usize) -> String {
    let mut out = String::new();
    for c in text.chars() {
        let piece: String = if c.is_control() {
            c.escape_default().collect()
        } else {
            c.to_string()
        };
        if out.len() + piece.len() > max {
            out.push_str("...");
            break;
        }
        out.push_str(&piece);
    }
    out
}

/// The grey material of mesh faces that name none (OBJ faces without
/// `usemtl`, STL, PLY without vertex colours).
fn default_mesh_material() -> Material {
    Material {
        color: Color::splat(0.8),
        ..Material::default()
    }
}

/// Bytes a triangle of a mesh file keeps in the scene: its shape, material
/// and group, and its corner record when the mesh has normals or texture
/// coordinates.
pub(crate) fn triangle_bytes(with_corners: bool) -> u64 {
    let shape = std::mem::size_of::<crate::shapes::Shape>() + 2 * std::mem::size_of::<u32>();
    let corners = if with_corners {
        std::mem::size_of::<crate::scene::Corners>()
    } else {
        0
    };
    (shape + corners) as u64
}

/// Refuses a mesh file of more than `opts.max_triangles` triangles, or of
/// more than the memory left, before taking their memory; reserves it
/// otherwise (corner records too when the mesh has normals or texture
/// coordinates). `what` says where the triangles come from (a glTF file's
/// node instances) for the message.
fn reserve_triangles(
    scene: &mut Scene,
    triangles: u64,
    with_corners: bool,
    file: &Path,
    opts: &LoadOptions,
    cx: &LoadContext,
) -> Result<()> {
    if triangles > opts.max_triangles {
        return Err(Error::Invalid(format!(
            "{}: {triangles} triangles exceed the limit of {}",
            file.display(),
            opts.max_triangles
        )));
    }
    let what = || format!("{}: {triangles} triangles", file.display());
    cx.memory.take(
        triangles.saturating_mul(triangle_bytes(with_corners)),
        &what,
    )?;
    let n = triangles as usize;
    crate::memory::try_reserve(&mut scene.shapes, n, &what)?;
    crate::memory::try_reserve(&mut scene.shape_material, n, &what)?;
    crate::memory::try_reserve(&mut scene.shape_group, n, &what)?;
    if with_corners {
        crate::memory::try_reserve(&mut scene.corners, n, &what)?;
    }
    Ok(())
}

/// Decodes an image a scene names into texels of `kind`, its memory
/// counted from its header before it is decoded: `Ok(Err(why))` when the
/// image cannot be had (a warning: the material goes without it), `Err`
/// when it does not fit in the memory left (the load fails).
fn decode_texture(
    bytes: &[u8],
    what: &str,
    kind: crate::texture::Texels,
    cx: &LoadContext,
) -> Result<std::result::Result<crate::texture::Texture, String>> {
    use crate::texture::Texture;
    let (w, h) = match Texture::dimensions(bytes, what) {
        Ok(size) => size,
        Err(why) => return Ok(Err(why)),
    };
    let texture = || format!("{what}: a {w}x{h} texture");
    cx.memory.check(
        Texture::kept_bytes(w, h) + Texture::decoding_bytes(w, h),
        &texture,
    )?;
    cx.memory.take(Texture::kept_bytes(w, h), &texture)?;
    Ok(Texture::decode_as(bytes, what, kind))
}

/// Refuses a scene without one triangle to render (an empty or faceless
/// mesh file, or one whose faces were all degenerate), naming the file.
fn refuse_empty(scene: &Scene, file: &Path, what: &str) -> Result<()> {
    if !scene.shapes.is_empty() {
        return Ok(());
    }
    let skipped = match scene.warnings.first() {
        None => String::new(),
        Some(w) => format!(" (every face was skipped; the first: {})", excerpt(w, 200)),
    };
    Err(Error::Invalid(format!(
        "{}: no {what} to render{skipped}",
        file.display()
    )))
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
    fn excerpts_are_short_and_escaped() {
        assert_eq!(excerpt("abc", 10), "abc");
        assert_eq!(excerpt("abcdef", 4), "abcd...");
        let nuls = excerpt(&"\0".repeat(1000), 200);
        assert!(nuls.len() <= 203 && nuls.starts_with("\\u{0}"), "{nuls}");
        assert_eq!(excerpt("a\nb", 10), "a\\nb");
    }

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

//! STL (binary and ASCII), read with `stl_io`.
//!
//! STL is a soup of flat triangles with no materials, camera or lights: every
//! triangle gets one grey default material (as an OBJ face without `usemtl`),
//! the whole file is one group, and the job frames and lights it as it does an
//! OBJ. The facet normals the file stores are ignored: the winding gives the
//! normal, as in every other mesh format (many exporters write zero normals).

use std::io::Cursor;
use std::path::Path;

use super::{refuse_empty, reserve_triangles, LoadContext, LoadOptions};
use crate::error::{Error, Result};
use crate::math::Vec3;
use crate::scene::{MeshPolygon, Scene, SceneFormat};

/// Read and parse an STL file.
pub fn load_stl(path: &Path, opts: &LoadOptions) -> Result<Scene> {
    let cx = LoadContext::new(path, opts);
    let bytes = cx.files.read_scene(&cx.memory)?;
    stl_scene(&bytes, path, opts, &cx)
}

/// Parse STL bytes (binary or ASCII); `file` names it in messages.
pub fn parse_stl(bytes: &[u8], file: &Path, opts: &LoadOptions) -> Result<Scene> {
    stl_scene(bytes, file, opts, &LoadContext::new(file, opts))
}

fn stl_scene(bytes: &[u8], file: &Path, opts: &LoadOptions, cx: &LoadContext) -> Result<Scene> {
    let invalid = |what: String| {
        Error::Invalid(format!(
            "{}: not a valid STL file: {}",
            file.display(),
            super::excerpt(&what, 200)
        ))
    };
    // A binary STL says how many triangles follow; check it against the size
    // first, so that a truncated file is named as such (and no memory is
    // taken for a count the file cannot hold).
    let binary = !looks_ascii(bytes);
    let mut announced = 0;
    if binary {
        let Some(count) = bytes.get(80..84) else {
            return Err(invalid(format!(
                "{} bytes, shorter than a binary STL header (84 bytes)",
                bytes.len()
            )));
        };
        let count = u32::from_le_bytes([count[0], count[1], count[2], count[3]]) as u64;
        let needed = 84 + count * 50;
        if (bytes.len() as u64) < needed {
            return Err(invalid(format!(
                "truncated: the header announces {count} triangles ({needed} bytes) but the file has {} bytes",
                bytes.len()
            )));
        }
        announced = count;
    } else {
        // An ASCII facet takes more text than its triangle takes memory.
        cx.memory.check(bytes.len() as u64, &|| {
            format!("parsing {}", file.display())
        })?;
    }
    // stl_io takes a file for ASCII exactly when its first line starts with
    // "solid ": give it the first line it expects either way (a binary
    // header's text means nothing; an ASCII `solid` line may lack a name or
    // follow blank lines).
    let fixed: Vec<u8>;
    let input = if binary && bytes.starts_with(b"solid") {
        fixed = [b"SOLID", &bytes[5..]].concat();
        &fixed[..]
    } else if !binary && !bytes.starts_with(b"solid ") {
        let start = bytes
            .iter()
            .position(|b| !b.is_ascii_whitespace())
            .unwrap_or(0);
        let rest = &bytes[start..];
        let line_end = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
        fixed = [b"solid twinray", &rest[line_end..]].concat();
        &fixed[..]
    } else {
        bytes
    };
    let mut cursor = Cursor::new(input);
    let reader = stl_io::create_stl_reader(&mut cursor).map_err(|e| invalid(e.to_string()))?;
    let mut scene = Scene::new();
    scene.format = SceneFormat::Stl;
    let material = scene.add_material(super::default_mesh_material());
    let group = scene.new_group();
    if binary {
        reserve_triangles(&mut scene, announced, false, file, opts, cx)?;
    }
    let first_warning = scene.warnings.len();
    for (i, triangle) in reader.enumerate() {
        let triangle = triangle.map_err(|e| invalid(format!("triangle {}: {e}", i + 1)))?;
        if !binary && scene.shapes.len() as u64 >= opts.max_triangles {
            return Err(Error::Invalid(format!(
                "{}: more than {} triangles",
                file.display(),
                opts.max_triangles
            )));
        }
        let vertices = triangle.vertices.map(|v| Vec3::from(v.0));
        scene.add_mesh_polygon(
            &MeshPolygon {
                vertices: &vertices,
                normals: None,
                uv: None,
                material,
                group,
            },
            &|| format!("{}: triangle {}", file.display(), i + 1),
        );
    }
    super::fold_warnings(&mut scene, first_warning, 10);
    refuse_empty(&scene, file, "triangles")?;
    scene.frame_bounds();
    Ok(cx.finish(scene))
}

/// Whether `bytes` are an ASCII STL: they start with `solid` and hold a
/// `facet` keyword (binary headers often start with `solid` too), and they
/// are not exactly the size a binary STL of their triangle count would be.
fn looks_ascii(bytes: &[u8]) -> bool {
    let text_start = bytes
        .iter()
        .position(|b| !b.is_ascii_whitespace())
        .map_or(&[][..], |i| &bytes[i..]);
    if !text_start.starts_with(b"solid") {
        return false;
    }
    if let Some(c) = bytes.get(80..84) {
        let count = u32::from_le_bytes([c[0], c[1], c[2], c[3]]) as u64;
        if bytes.len() as u64 == 84 + count * 50 {
            return false;
        }
    }
    let head = &bytes[..bytes.len().min(4096)];
    head.windows(5).any(|w| w == b"facet")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn binary(triangles: &[[[f32; 3]; 3]], header: &[u8]) -> Vec<u8> {
        let mut out = vec![0u8; 80];
        out[..header.len()].copy_from_slice(header);
        out.extend((triangles.len() as u32).to_le_bytes());
        for t in triangles {
            out.extend([0u8; 12]);
            for v in t {
                for c in v {
                    out.extend(c.to_le_bytes());
                }
            }
            out.extend([0u8; 2]);
        }
        out
    }

    const TRI: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

    #[test]
    fn binary_with_a_solid_header_is_binary() {
        let bytes = binary(&[TRI, TRI], b"solid made by an exporter that says facet");
        let scene = parse_stl(&bytes, Path::new("a.stl"), &LoadOptions::default()).unwrap();
        assert_eq!(scene.shapes.len(), 2);
        assert_eq!(scene.format, SceneFormat::Stl);
    }

    #[test]
    fn ascii_loads_and_garbage_is_an_error_naming_the_file() {
        let text = "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n\
                    vertex 0 1 0\nendloop\nendfacet\nendsolid t\n";
        let scene =
            parse_stl(text.as_bytes(), Path::new("a.stl"), &LoadOptions::default()).unwrap();
        assert_eq!(scene.shapes.len(), 1);
        let bad = text.replace("vertex 1 0 0", "vertex 1 zero 0");
        let e = parse_stl(
            bad.as_bytes(),
            Path::new("bad.stl"),
            &LoadOptions::default(),
        )
        .unwrap_err();
        assert!(e.to_string().contains("bad.stl"), "{e}");
    }

    #[test]
    fn too_many_triangles_are_refused() {
        let bytes = binary(&[TRI, TRI, TRI], b"");
        let opts = LoadOptions {
            max_triangles: 2,
            ..LoadOptions::default()
        };
        let e = parse_stl(&bytes, Path::new("big.stl"), &opts).unwrap_err();
        assert!(e.to_string().contains("exceed the limit"), "{e}");
    }
}

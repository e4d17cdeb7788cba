//! PLY (ASCII and binary, either byte order), read with `ply-rs-bw`.
//!
//! The `vertex` element's `x`, `y`, `z` and the `face` element's
//! `vertex_indices` (or `vertex_index`) list are read; faces of more than three
//! vertices are cut into triangles as OBJ's are. Like STL, PLY carries no
//! materials, camera or lights: the job frames and lights it as an OBJ.
//!
//! Vertex colours (`red`, `green`, `blue`: 0–255 integers, or 0–1 floats)
//! are taken as sRGB, as scanners and Meshlab write them, made linear, and
//! interpolated across each triangle (`Scene::corner_colors`) over a white
//! material: a face whose vertices differ shows a gradient.
//! Without colours, faces get the same grey default material as OBJ faces
//! without `usemtl`.

use std::path::Path;

use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{Property, PropertyAccess, PropertyAccessResult};

use super::{reserve_triangles, LoadContext, LoadOptions};
use crate::error::{Error, Result};
use crate::math::{Color, Vec3};
use crate::scene::{Material, MeshPolygon, Scene, SceneFormat};

/// Read and parse a PLY file.
pub fn load_ply(path: &Path, opts: &LoadOptions) -> Result<Scene> {
    let cx = LoadContext::new(path, opts);
    let bytes = cx.files.read_scene(&cx.memory)?;
    ply_scene(&bytes, path, opts, &cx)
}

/// Parse PLY bytes; `file` names it in messages.
pub fn parse_ply(bytes: &[u8], file: &Path, opts: &LoadOptions) -> Result<Scene> {
    ply_scene(bytes, file, opts, &LoadContext::new(file, opts))
}

/// Bytes a face of the file may hold while it is read: its record and its
/// list of three or more indices.
const FACE_BYTES: u64 = (std::mem::size_of::<PlyFace>() + 4 * std::mem::size_of::<usize>()) as u64;

fn ply_scene(bytes: &[u8], file: &Path, opts: &LoadOptions, cx: &LoadContext) -> Result<Scene> {
    // The parser's errors quote the line they stopped on: of a file of
    // NULs, the whole file.
    let invalid = |what: String| {
        Error::Invalid(format!(
            "{}: not a valid PLY file: {}",
            file.display(),
            super::excerpt(&what, 200)
        ))
    };
    // Elements are read in the header's order, each into a type of ours
    // that keeps only what twinray uses (not ply-rs-bw's map of named
    // properties per element, five times slower: docs/decisions.md).
    let mut reader = Reader::new(bytes);
    let header = Parser::<PlyVertex>::new()
        .read_header(&mut reader)
        .map_err(|e| invalid(e.to_string()))?;
    // Every element takes at least a byte of the file: what the header
    // announces is bounded by the size before its memory is counted.
    let count = |name: &str| {
        header
            .elements
            .values()
            .filter(|e| e.name == name)
            .map(|e| (e.count as u64).min(bytes.len() as u64))
            .sum::<u64>()
    };
    let payload = count("vertex")
        .saturating_mul(std::mem::size_of::<PlyVertex>() as u64 + 12)
        .saturating_add(count("face").saturating_mul(FACE_BYTES));
    cx.memory.check(payload, &|| {
        format!("reading the elements of {}", file.display())
    })?;
    let (mut vertices, mut faces) = (None, Vec::new());
    for element in header.elements.values() {
        match element.name.as_str() {
            "vertex" => {
                vertices = Some(
                    Parser::<PlyVertex>::new()
                        .read_payload_for_element(&mut reader, element, &header)
                        .map_err(|e| invalid(e.to_string()))?,
                )
            }
            "face" => {
                faces = Parser::<PlyFace>::new()
                    .read_payload_for_element(&mut reader, element, &header)
                    .map_err(|e| invalid(e.to_string()))?
            }
            // Read past (every property ignored).
            _ => {
                Parser::<PlyFace>::new()
                    .read_payload_for_element(&mut reader, element, &header)
                    .map_err(|e| invalid(e.to_string()))?;
            }
        }
    }
    let vertices = vertices.ok_or_else(|| invalid("no 'vertex' element".into()))?;
    if faces.is_empty() {
        return Err(invalid(
            "no faces (a point cloud has no surface to render)".into(),
        ));
    }

    let mut positions = Vec::with_capacity(vertices.len());
    let mut colors = Vec::new();
    let has_color = header.elements.values().any(|e| {
        e.name == "vertex"
            && ["red", "green", "blue"]
                .iter()
                .all(|k| e.properties.contains_key(*k))
    });
    for (i, v) in vertices.iter().enumerate() {
        let coord = |k: usize| {
            v.xyz[k]
                .ok_or_else(|| invalid(format!("vertex {i}: no number '{}'", ["x", "y", "z"][k])))
        };
        positions.push(Vec3::new(coord(0)?, coord(1)?, coord(2)?));
        if has_color {
            let channel = |k: usize| srgb_to_linear(v.rgb[k].unwrap_or(0.0));
            colors.push(Color::new(channel(0), channel(1), channel(2)));
        }
    }

    let mut scene = Scene::new();
    scene.format = SceneFormat::Ply;
    let group = scene.new_group();
    let material = if has_color {
        scene.add_material(Material {
            color: Color::ONE,
            ..super::default_mesh_material()
        })
    } else {
        scene.add_material(super::default_mesh_material())
    };
    let first_warning = scene.warnings.len();
    let mut polygon = Vec::new();
    let mut polygon_colors = Vec::new();
    for (f, face) in faces.iter().enumerate() {
        let indices = face
            .indices
            .as_ref()
            .ok_or_else(|| invalid(format!("face {f}: no integer list 'vertex_indices'")))?;
        polygon.clear();
        polygon_colors.clear();
        for &i in indices {
            let p = positions.get(i).ok_or_else(|| {
                invalid(format!(
                    "face {f} refers to vertex {i}, but there are {} vertices",
                    positions.len()
                ))
            })?;
            polygon.push(*p);
            if has_color {
                polygon_colors.push(colors[i]);
            }
        }
        if polygon.len() < 3 {
            scene.warnings.push(format!(
                "{}: face {f} of fewer than 3 vertices skipped",
                file.display()
            ));
            continue;
        }
        if f == 0 {
            let triangles = faces.len() as u64 * (polygon.len() as u64 - 2);
            reserve_triangles(&mut scene, triangles, false, file, opts, cx)?;
        } else if scene.shapes.len() as u64 >= opts.max_triangles {
            return Err(Error::Invalid(format!(
                "{}: more than {} triangles",
                file.display(),
                opts.max_triangles
            )));
        }
        scene.add_colored_mesh_polygon(
            &MeshPolygon {
                vertices: &polygon,
                normals: None,
                uv: None,
                material,
                group,
            },
            has_color.then_some(&polygon_colors[..]),
            &|| format!("{}: face {f}", file.display()),
        );
    }
    super::fold_warnings(&mut scene, first_warning, 10);
    super::refuse_empty(&scene, file, "faces")?;
    scene.frame_bounds();
    Ok(cx.finish(scene))
}

/// A vertex as read: its position and colour channels, where the file has them.
#[derive(Default)]
struct PlyVertex {
    xyz: [Option<f32>; 3],
    rgb: [Option<f32>; 3],
}

impl PropertyAccess for PlyVertex {
    fn new() -> Self {
        PlyVertex::default()
    }

    fn set_property(&mut self, name: &str, p: Property) -> PropertyAccessResult {
        let (slot, value) = match name {
            "x" => (&mut self.xyz[0], scalar(&p).map(|x| x as f32)),
            "y" => (&mut self.xyz[1], scalar(&p).map(|x| x as f32)),
            "z" => (&mut self.xyz[2], scalar(&p).map(|x| x as f32)),
            "red" => (&mut self.rgb[0], color_channel(&p)),
            "green" => (&mut self.rgb[1], color_channel(&p)),
            "blue" => (&mut self.rgb[2], color_channel(&p)),
            _ => return PropertyAccessResult::Ignored,
        };
        *slot = value;
        PropertyAccessResult::Set
    }
}

/// A face as read: its vertex indices (`vertex_indices`, or `vertex_index`).
#[derive(Default)]
struct PlyFace {
    indices: Option<Vec<usize>>,
}

impl PropertyAccess for PlyFace {
    fn new() -> Self {
        PlyFace::default()
    }

    fn set_property(&mut self, name: &str, p: Property) -> PropertyAccessResult {
        let preferred = name == "vertex_indices";
        if preferred || (name == "vertex_index" && self.indices.is_none()) {
            self.indices = index_list(&p);
            PropertyAccessResult::Set
        } else {
            PropertyAccessResult::Ignored
        }
    }
}

/// A scalar property as a number.
fn scalar(p: &Property) -> Option<f64> {
    Some(match *p {
        Property::Char(x) => x.into(),
        Property::UChar(x) => x.into(),
        Property::Short(x) => x.into(),
        Property::UShort(x) => x.into(),
        Property::Int(x) => x.into(),
        Property::UInt(x) => x.into(),
        Property::Float(x) => x.into(),
        Property::Double(x) => x,
        _ => return None,
    })
}

/// A colour channel in 0–1: integers are 8-bit, floats already 0–1.
fn color_channel(p: &Property) -> Option<f32> {
    let v = match *p {
        Property::Float(x) => x,
        Property::Double(x) => x as f32,
        Property::UShort(x) => f32::from(x) / 65535.0,
        ref other => scalar(other)? as f32 / 255.0,
    };
    Some(v.clamp(0.0, 1.0))
}

/// A list property as vertex indices (negative ones refused).
fn index_list(p: &Property) -> Option<Vec<usize>> {
    fn all<T: Copy>(v: &[T], f: impl Fn(T) -> Option<usize>) -> Option<Vec<usize>> {
        v.iter().map(|&x| f(x)).collect()
    }
    match p {
        Property::ListChar(v) => all(v, |x| usize::try_from(x).ok()),
        Property::ListUChar(v) => all(v, |x| Some(x.into())),
        Property::ListShort(v) => all(v, |x| usize::try_from(x).ok()),
        Property::ListUShort(v) => all(v, |x| Some(x.into())),
        Property::ListInt(v) => all(v, |x| usize::try_from(x).ok()),
        Property::ListUInt(v) => all(v, |x| usize::try_from(x).ok()),
        _ => None,
    }
}

/// The sRGB transfer function undone: an encoded value in 0–1 to a linear one.
fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const QUAD: &str = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n\
        property float y\nproperty float z\nproperty uchar red\nproperty uchar green\n\
        property uchar blue\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
        0 0 0 255 0 0\n1 0 0 255 0 0\n1 1 0 255 0 0\n0 1 0 255 0 0\n4 0 1 2 3\n";

    #[test]
    fn a_coloured_quad_is_two_triangles_with_red_corners() {
        let scene =
            parse_ply(QUAD.as_bytes(), Path::new("q.ply"), &LoadOptions::default()).unwrap();
        assert_eq!(scene.shapes.len(), 2);
        let m = &scene.materials[scene.shape_material[0] as usize];
        assert_eq!(m.color, Color::ONE);
        assert_eq!(scene.corner_colors, vec![[Color::X; 3]; 2]);
    }

    #[test]
    fn a_face_past_the_vertices_is_an_error_naming_the_file() {
        let bad = QUAD.replace("4 0 1 2 3", "4 0 1 2 7");
        let e = parse_ply(
            bad.as_bytes(),
            Path::new("bad.ply"),
            &LoadOptions::default(),
        )
        .unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("bad.ply") && msg.contains("vertex 7"), "{msg}");
    }

    #[test]
    fn srgb_decoding_matches_the_standard() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert_eq!(srgb_to_linear(1.0), 1.0);
        assert!((srgb_to_linear(188.0 / 255.0) - 0.5029).abs() < 1e-3);
    }
}

//! Wavefront OBJ with MTL materials, read with `tobj`.
//!
//! * Objects (`o`) and groups (`g`) become scene groups (one id per name).
//! * Polygons of any size are cut into triangles exactly as NFF's are.
//! * `vn` normals give smooth shading, `vt` texture coordinates feed `map_Kd`.
//! * Vertex colours (`v x y z r g b`, as MeshLab and scanners write them) are
//!   interpolated across each triangle and multiply the material's colour;
//!   faces without `usemtl` are then white under them, not the default grey.
//! * MTL `Kd`, `Ks`, `Ns`, `d`/`Tr`, `Ni`, `Ke`, `illum`, `map_Kd`, `map_d`,
//!   `map_Ke`, `norm` and `map_Bump` map to twinray's Whitted material as
//!   docs/formats.md explains.
//!
//! A malformed OBJ or MTL line is an error naming the file and the line (tobj
//! reads line by line; a counting reader tells which line it stopped on). A
//! missing MTL file or texture is a warning: the default material, or the
//! material's colour, stands in.

use std::cell::RefCell;
use std::collections::HashMap;
use std::io::{BufRead, Read};
use std::path::Path;

use super::material_model::Inputs;
use super::material_model::{phong_from_roughness, roughness_from_ns};
use super::{
    decode_texture, fold_warnings, refuse_empty, reserve_triangles, LoadContext, LoadOptions,
};
use crate::error::{Error, Result};
use crate::math::{Color, Vec3};
use crate::scene::{
    AlphaMode, Material, MeshPolygon, NormalMap, NormalMapKind, Scene, SceneFormat, Uv,
    MAX_RADIANCE,
};
use crate::texture::{Texels, Wrap};

/// Read and parse an OBJ file and the MTL files it names.
pub fn load_obj(path: &Path, opts: &LoadOptions) -> Result<Scene> {
    let cx = LoadContext::new(path, opts);
    let bytes = cx.files.read_scene(&cx.memory)?;
    obj_scene(&bytes, path, opts, &cx)
}

/// A `BufRead` that counts the lines handed out, so that a parse error can
/// name the line the parser stopped on.
struct LineCounter<R> {
    inner: R,
    newlines: usize,
    ends_line: bool,
}

impl<R> LineCounter<R> {
    fn new(inner: R) -> Self {
        LineCounter {
            inner,
            newlines: 0,
            ends_line: true,
        }
    }

    /// 1-based line of the last byte consumed.
    fn line(&self) -> usize {
        if self.ends_line {
            self.newlines.max(1)
        } else {
            self.newlines + 1
        }
    }
}

impl<R: BufRead> Read for LineCounter<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = {
            let data = self.fill_buf()?;
            let n = data.len().min(buf.len());
            buf[..n].copy_from_slice(&data[..n]);
            n
        };
        self.consume(n);
        Ok(n)
    }
}

impl<R: BufRead> BufRead for LineCounter<R> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        self.inner.fill_buf()
    }

    fn consume(&mut self, amt: usize) {
        if let Ok(data) = self.inner.fill_buf() {
            let taken = &data[..amt.min(data.len())];
            self.newlines += taken.iter().filter(|&&b| b == b'\n').count();
            if let Some(&last) = taken.last() {
                self.ends_line = last == b'\n';
            }
        }
        self.inner.consume(amt);
    }
}

/// What tobj's error means, for a user.
fn explain(e: tobj::LoadError) -> String {
    use tobj::LoadError as E;
    match e {
        E::ReadError => "not a text file (invalid UTF-8)".into(),
        E::PositionParseError => "vertex 'v' needs 3 numbers (x y z [w])".into(),
        E::NormalParseError => "normal 'vn' needs 3 numbers".into(),
        E::TexcoordParseError => "texture coordinate 'vt' needs 1 to 3 numbers".into(),
        E::FaceParseError => "face 'f' needs vertex indices (v, v/vt, v//vn or v/vt/vn)".into(),
        E::FaceVertexOutOfBounds => "face refers to a vertex that does not exist".into(),
        E::FaceTexCoordOutOfBounds => {
            "face refers to a texture coordinate that does not exist".into()
        }
        E::FaceNormalOutOfBounds => "face refers to a normal that does not exist".into(),
        E::InvalidPolygon => "face with fewer than 3 vertices".into(),
        other => other.to_string(),
    }
}

/// Parse OBJ bytes; `file` names it in messages and locates its MTL files and
/// textures.
pub fn parse_obj(bytes: &[u8], file: &Path, opts: &LoadOptions) -> Result<Scene> {
    obj_scene(bytes, file, opts, &LoadContext::new(file, opts))
}

/// Bytes tobj's arrays may hold per byte of OBJ text while it is parsed
/// (`v 0 0 0` is 8 bytes of text and 12 of floats).
const PARSE_BYTES_PER_BYTE: u64 = 2;

fn obj_scene(bytes: &[u8], file: &Path, opts: &LoadOptions, cx: &LoadContext) -> Result<Scene> {
    // A NUL is in no text file: a gigabyte of them was read as one
    // unknown statement and rendered as an empty scene.
    if let Some(at) = bytes.iter().position(|&b| b == 0) {
        return Err(Error::Parse {
            file: file.to_path_buf(),
            line: 1 + bytes[..at].iter().filter(|&&b| b == b'\n').count(),
            message: "not a text file (a NUL byte)".into(),
        });
    }
    cx.memory.check(
        (bytes.len() as u64).saturating_mul(PARSE_BYTES_PER_BYTE),
        &|| format!("parsing {}", file.display()),
    )?;
    let warnings = RefCell::new(Vec::<String>::new());
    let mtl_error = RefCell::new(None::<Error>);
    let material_loader = |name: &Path| -> tobj::MTLLoadResult {
        let name = name.to_string_lossy();
        let mtl_path = file.with_file_name(name.as_ref());
        let mtl_bytes = match cx.files.read_named(&name, &cx.memory) {
            Ok(b) => b,
            Err(why) => {
                warnings.borrow_mut().push(format!(
                    "{}: material library {why}; default materials used",
                    file.display(),
                ));
                return Err(tobj::LoadError::OpenFileFailed);
            }
        };
        let mtl_bytes = match normalize_mtl_colors(&mtl_bytes) {
            Ok(b) => b,
            Err((line, message)) => {
                *mtl_error.borrow_mut() = Some(Error::Parse {
                    file: mtl_path.clone(),
                    line,
                    message,
                });
                return Err(tobj::LoadError::MaterialParseError);
            }
        };
        let mut reader = LineCounter::new(&mtl_bytes[..]);
        tobj::load_mtl_buf(&mut reader).inspect_err(|&e| {
            *mtl_error.borrow_mut() = Some(Error::Parse {
                file: mtl_path.clone(),
                line: reader.line(),
                message: explain(e),
            });
        })
    };
    let mut reader = LineCounter::new(bytes);
    let load = tobj::LoadOptions {
        single_index: false,
        triangulate: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let parsed = tobj::load_obj_buf(&mut reader, &load, material_loader);
    if let Some(e) = mtl_error.into_inner() {
        return Err(e);
    }
    let (models, materials) = parsed.map_err(|e| Error::Parse {
        file: file.to_path_buf(),
        line: reader.line(),
        message: explain(e),
    })?;
    let materials = materials.unwrap_or_default();

    let mut scene = Scene::new();
    scene.format = SceneFormat::Obj;
    scene.warnings = warnings.into_inner();
    let mut textures = TextureCache::new(cx);
    for m in &materials {
        let maps = MtlTextures::load(m, &mut textures, &mut scene, file)?;
        let (material, changed) = material_from_mtl(m, maps);
        if !changed.is_empty() {
            scene.warnings.push(format!(
                "{}: material '{}': {}",
                file.display(),
                super::excerpt(&m.name, 200),
                changed.join(", ")
            ));
        }
        scene.add_material(material);
    }
    // Faces without `usemtl`: the default material, after the file's; white
    // under vertex colours, which then are the surface's colour.
    let colored = models.iter().any(|m| vertex_colors(&m.mesh).is_some());
    let default_material = scene.add_material(Material {
        color: Color::splat(if colored { 1.0 } else { 0.8 }),
        ..Material::default()
    });

    let triangles: u64 = models.iter().map(|m| face_triangles(&m.mesh)).sum::<u64>();
    let with_corners = colored
        || models
            .iter()
            .any(|m| !m.mesh.normals.is_empty() || !m.mesh.texcoords.is_empty());
    reserve_triangles(&mut scene, triangles, with_corners, file, opts, cx)?;

    let given = FaceAttributes::of(bytes);
    let total_faces: usize = models.iter().map(|m| face_count(&m.mesh)).sum();
    let mut given = (given.0.len() == total_faces).then_some(given);
    let first_warning = scene.warnings.len();
    let mut groups: HashMap<&str, u32> = HashMap::new();
    for model in &models {
        let group = *groups
            .entry(model.name.as_str())
            .or_insert_with(|| scene.new_group());
        let material = model
            .mesh
            .material_id
            .filter(|&i| i < materials.len())
            .map_or(default_material, |i| i as u32);
        let faces = face_count(&model.mesh);
        let given_here = given.as_mut().map(|g| g.take(faces));
        add_mesh(
            &mut scene,
            model,
            material,
            group,
            file,
            opts,
            given_here.as_deref(),
        )?;
    }
    fold_warnings(&mut scene, first_warning, 10);
    refuse_empty(&scene, file, "faces")?;
    scene.frame_bounds();
    Ok(cx.finish(scene))
}

/// MTL colour statements (`Ka`, `Kd`, `Ks`, `Ke`) as tobj takes them: three
/// numbers. One number is a grey and is repeated; two are an error (tobj
/// would panic on them). Returns the 1-based line and message of an error.
fn normalize_mtl_colors(bytes: &[u8]) -> std::result::Result<Vec<u8>, (usize, String)> {
    let mut out = Vec::with_capacity(bytes.len() + 64);
    for (i, line) in bytes.split_inclusive(|&b| b == b'\n').enumerate() {
        let text = String::from_utf8_lossy(line);
        let mut words = text.split_whitespace();
        let key = words.next().unwrap_or("");
        if matches!(key, "Ka" | "Kd" | "Ks" | "Ke") {
            let values: Vec<&str> = words.collect();
            match values.len() {
                1 => {
                    let v = values[0];
                    out.extend(format!("{key} {v} {v} {v}\n").bytes());
                    continue;
                }
                0 | 2 => {
                    return Err((
                        i + 1,
                        format!("colour '{key}' needs 3 numbers (r g b), or 1 for a grey"),
                    ))
                }
                _ => {}
            }
        }
        out.extend_from_slice(line);
    }
    Ok(out)
}

/// Which faces of an OBJ file name texture coordinates and normals for all
/// their vertices, in file order: tobj makes up indices for vertices without
/// them, which must not turn a flat face smooth.
struct FaceAttributes(Vec<(bool, bool)>, usize);

impl FaceAttributes {
    fn of(bytes: &[u8]) -> FaceAttributes {
        let mut faces = Vec::new();
        for line in bytes.split(|&b| b == b'\n') {
            let mut words = line
                .split(|b| b.is_ascii_whitespace())
                .filter(|w| !w.is_empty());
            if words.next() != Some(b"f") {
                continue;
            }
            let (mut count, mut vt, mut vn) = (0, true, true);
            for v in words {
                let mut parts = v.split(|&b| b == b'/').skip(1);
                vt &= parts.next().is_some_and(|p| !p.is_empty());
                vn &= parts.next().is_some_and(|p| !p.is_empty());
                count += 1;
            }
            if count >= 3 {
                faces.push((vt, vn)); // points and lines: tobj drops them too
            }
        }
        FaceAttributes(faces, 0)
    }

    /// The next `n` faces' flags.
    fn take(&mut self, n: usize) -> Vec<(bool, bool)> {
        let start = self.1.min(self.0.len());
        self.1 += n;
        self.0[start..self.1.min(self.0.len())].to_vec()
    }
}

fn face_count(mesh: &tobj::Mesh) -> usize {
    if mesh.face_arities.is_empty() {
        mesh.indices.len() / 3
    } else {
        mesh.face_arities.len()
    }
}

/// Triangles the faces of `mesh` will become (before degenerate ones are dropped).
fn face_triangles(mesh: &tobj::Mesh) -> u64 {
    if mesh.face_arities.is_empty() {
        mesh.indices.len() as u64 / 3
    } else {
        mesh.face_arities
            .iter()
            .map(|&n| (n as u64).saturating_sub(2))
            .sum()
    }
}

fn add_mesh(
    scene: &mut Scene,
    model: &tobj::Model,
    material: u32,
    group: u32,
    file: &Path,
    opts: &LoadOptions,
    given: Option<&[(bool, bool)]>,
) -> Result<()> {
    let mesh = &model.mesh;
    let n = mesh.indices.len();
    let has_normals = mesh.normal_indices.len() == n && !mesh.normals.is_empty();
    let has_uv = mesh.texcoord_indices.len() == n && !mesh.texcoords.is_empty();
    let position = |i: u32| vec3_at(&mesh.positions, i);
    let normal = |i: u32| vec3_at(&mesh.normals, i);
    let colors = vertex_colors(mesh);
    let color = |i: u32| colors.as_ref().and_then(|c| c.get(i as usize).copied());
    let uv = |i: u32| {
        let i = i as usize * 2;
        let (u, v) = (mesh.texcoords.get(i)?, mesh.texcoords.get(i + 1)?);
        // OBJ's v runs up the image; the texture's rows run down.
        Some(Uv::new(*u, 1.0 - *v))
    };
    let arities: Box<dyn Iterator<Item = usize>> = if mesh.face_arities.is_empty() {
        Box::new(std::iter::repeat_n(3, n / 3))
    } else {
        Box::new(mesh.face_arities.iter().map(|&a| a as usize))
    };
    let (mut vertices, mut normals, mut uvs, mut corner_colors) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut start = 0;
    for (face, arity) in arities.enumerate() {
        let end = start + arity;
        let out_of_range = || {
            Error::Invalid(format!(
                "{}: object '{}', face {}: index out of range",
                file.display(),
                model.name,
                face + 1
            ))
        };
        if end > n {
            return Err(out_of_range());
        }
        if arity > opts.max_vertices {
            return Err(Error::Invalid(format!(
                "{}: object '{}', face {}: {arity} vertices exceed the limit of {}",
                file.display(),
                model.name,
                face + 1,
                opts.max_vertices
            )));
        }
        vertices.clear();
        normals.clear();
        uvs.clear();
        corner_colors.clear();
        for k in start..end {
            vertices.push(position(mesh.indices[k]).ok_or_else(out_of_range)?);
            if colors.is_some() {
                corner_colors.push(color(mesh.indices[k]).ok_or_else(out_of_range)?);
            }
            if has_normals {
                normals.push(normal(mesh.normal_indices[k]).ok_or_else(out_of_range)?);
            }
            if has_uv {
                uvs.push(uv(mesh.texcoord_indices[k]).ok_or_else(out_of_range)?);
            }
        }
        start = end;
        let face_has = |k: usize| {
            given
                .and_then(|g| g.get(face))
                .is_none_or(|f| [f.0, f.1][k])
        };
        if vertices.iter().any(|v| !v.is_finite()) {
            return Err(Error::Invalid(format!(
                "{}: object '{}', face {}: vertex coordinate is not a finite number",
                file.display(),
                model.name,
                face + 1
            )));
        }
        scene.add_colored_mesh_polygon(
            &MeshPolygon {
                vertices: &vertices,
                normals: (has_normals && face_has(1)).then_some(&normals[..]),
                uv: (has_uv && face_has(0)).then_some(&uvs[..]),
                material,
                group,
            },
            colors.is_some().then_some(&corner_colors[..]),
            &|| {
                format!(
                    "{}: object '{}', face {}",
                    file.display(),
                    model.name,
                    face + 1
                )
            },
        );
    }
    Ok(())
}

/// A mesh's vertex colours, one per position, where the file gives them
/// (tobj keeps them beside the positions). Values in 0–1 as written; a file
/// with any channel above 1 is read as 8-bit (0–255). Channels that are not
/// finite, or negative, are black.
fn vertex_colors(mesh: &tobj::Mesh) -> Option<Vec<Color>> {
    let values = &mesh.vertex_color;
    if values.is_empty() || values.len() != mesh.positions.len() {
        return None;
    }
    // Divided, not multiplied by 1/255: 51 is then exactly 0.2.
    let scale = if values.iter().any(|&v| v > 1.0 && v.is_finite()) {
        255.0
    } else {
        1.0
    };
    let channel = |v: f32| {
        if v.is_finite() {
            (v / scale).clamp(0.0, 1.0)
        } else {
            0.0
        }
    };
    Some(
        values
            .chunks_exact(3)
            .map(|c| Color::new(channel(c[0]), channel(c[1]), channel(c[2])))
            .collect(),
    )
}

fn vec3_at(values: &[f32], i: u32) -> Option<Vec3> {
    let i = i as usize * 3;
    Some(Vec3::new(
        *values.get(i)?,
        *values.get(i + 1)?,
        *values.get(i + 2)?,
    ))
}

/// How an MTL material maps to twinray's Whitted material (docs/formats.md):
/// `Kd` splits into a colour and a diffuse weight (its largest component);
/// `Ks`'s largest component is the specular reflectance, `Ns` a roughness
/// (`1 − √(Ns/1000)`, as Blender's importer reads it), and the two give the
/// Phong highlight from `illum` 2 on and the mirror weight from `illum` 3 on
/// ([`phong_from_roughness`]); `d` (or `1 − Tr`) below 1 is a BLEND alpha (a
/// straight-through transmission), except under `illum` 6 and 7 (the MTL
/// spec's refraction models), where `1 − d` refracts with index `Ni`;
/// `map_d` makes a cut-out (MASK at 0.5) when `d` is 1, else scales the
/// BLEND alpha; `Ke` (× `map_Ke`) is emitted light; `norm` and `map_Bump`
/// bend the shading normal ([`MtlTextures`]).
pub fn material_from_mtl(m: &tobj::Material, maps: MtlTextures) -> (Material, Vec<String>) {
    let mut inputs = Inputs::default();
    let kd_rgb = inputs.clamp_all("Kd", m.diffuse.unwrap_or([0.8; 3]), 0.0, 1.0);
    let kd = kd_rgb.iter().copied().fold(0.0, f32::max);
    let color = if kd > 0.0 {
        Color::from(kd_rgb) / kd
    } else {
        Color::ZERO
    };
    let ks_max = inputs
        .clamp_all("Ks", m.specular.unwrap_or([0.0; 3]), 0.0, 1.0)
        .iter()
        .copied()
        .fold(0.0, f32::max);
    let illum = m.illumination_model.unwrap_or(2);
    let opacity = match (m.dissolve, m.unknown_param.get("Tr")) {
        (Some(d), _) => inputs.clamp("d", d, 0.0, 1.0),
        (None, Some(tr)) => {
            let tr = tr.trim().parse::<f32>().unwrap_or(0.0);
            1.0 - inputs.clamp("Tr", tr, 0.0, 1.0)
        }
        (None, None) => 1.0,
    };
    let refracts = matches!(illum, 6 | 7);
    let t = if refracts { 1.0 - opacity } else { 0.0 };
    let alpha = if refracts { 1.0 } else { opacity };
    let alpha_mode = match (maps.alpha.is_some(), alpha < 1.0) {
        (_, true) => AlphaMode::Blend,
        (true, false) => AlphaMode::Mask { cutoff: 0.5 },
        (false, false) => AlphaMode::Opaque,
    };
    // `map_Ke` without `Ke`: the texture is the emitted light.
    let ke = match (m.emissive, maps.emission) {
        (Some(ke), _) => inputs.clamp_all("Ke", ke, 0.0, MAX_RADIANCE),
        (None, Some(_)) => [1.0; 3],
        (None, None) => [0.0; 3],
    };
    let ior = match m.optical_density {
        Some(n) if !(n.is_finite() && n > 0.0) => {
            inputs.changed.push(format!("Ni {n} replaced by 1"));
            1.0
        }
        Some(n) => n,
        None => 1.0,
    };
    // Blender's importer: Ns is a roughness; absent, it is 0 (fully rough).
    let ns = inputs.clamp("Ns", m.shininess.unwrap_or(0.0), 0.0, 1000.0);
    let phong = phong_from_roughness(ks_max, roughness_from_ns(ns));
    inputs.finish(Material {
        color,
        kd,
        ks: if illum >= 2 { phong.ks } else { 0.0 },
        shine: phong.shine,
        t,
        ior,
        mirror: if illum >= 3 { phong.mirror } else { 0.0 },
        emission: Color::from(ke),
        texture: maps.diffuse,
        emission_texture: maps.emission,
        alpha_mode,
        alpha,
        alpha_texture: maps.alpha,
        normal_map: maps.normal,
        ..Material::default()
    })
}

/// The textures of an MTL material, as indices into `Scene::textures`.
#[derive(Clone, Copy, Debug, Default)]
pub struct MtlTextures {
    /// `map_Kd`.
    pub diffuse: Option<u32>,
    /// `map_d`: its alpha channel, or its red channel if it has none.
    pub alpha: Option<u32>,
    /// `map_Ke`.
    pub emission: Option<u32>,
    /// `norm` (a tangent-space normal map), else `map_Bump` / `bump`: a
    /// normal map if its image is bluish (mean blue above mean red and green
    /// by more than [`NORMAL_MAP_BLUE`], as tangent-space normal maps are),
    /// else a height map (a grey image: what the MTL spec means by a bump
    /// map); `-bm` scales either.
    pub normal: Option<NormalMap>,
}

/// How much bluer than red and green on average an image must be to be
/// taken for a tangent-space normal map (flat texels are (0.5, 0.5, 1)).
pub const NORMAL_MAP_BLUE: f32 = 0.2;

impl MtlTextures {
    fn load(
        m: &tobj::Material,
        cache: &mut TextureCache,
        scene: &mut Scene,
        file: &Path,
    ) -> Result<MtlTextures> {
        let mut get = |spec: Option<&str>, kind: Texels| match spec {
            Some(spec) => cache.get(scene, spec, kind, &m.name, file),
            None => Ok(None),
        };
        let unknown = |key: &str| m.unknown_param.get(key).map(String::as_str);
        let diffuse = get(m.diffuse_texture.as_deref(), Texels::Colour)?;
        let alpha = get(m.dissolve_texture.as_deref(), Texels::Coverage)?;
        let emission = get(unknown("map_Ke"), Texels::Colour)?;
        let norm = unknown("norm");
        let bump = m.normal_texture.as_deref();
        let spec = norm.or(bump);
        let normal = get(spec, Texels::Data)?.map(|texture| {
            let t = &scene.textures[texture as usize];
            let mean: Color =
                t.texels.iter().copied().sum::<Color>() / t.texels.len().max(1) as f32;
            let bluish = mean.z - mean.x.max(mean.y) > NORMAL_MAP_BLUE;
            let kind = if norm.is_some() || bluish {
                NormalMapKind::Tangent
            } else {
                NormalMapKind::Height
            };
            let scale = spec
                .and_then(|s| texture_option(s, "-bm"))
                .filter(|b| b.is_finite())
                .unwrap_or(1.0)
                .clamp(-100.0, 100.0);
            NormalMap {
                texture,
                scale,
                kind,
            }
        });
        Ok(MtlTextures {
            diffuse,
            alpha,
            emission,
            normal,
        })
    }
}

/// The first number after option `name` in a texture statement's options
/// (`-bm 0.5 file.png`).
fn texture_option(spec: &str, name: &str) -> Option<f32> {
    let mut words = spec.split_whitespace();
    words.find(|w| *w == name)?;
    words.next()?.parse().ok()
}

/// Textures by name, each decoded once however many materials use it.
struct TextureCache<'a> {
    cx: &'a LoadContext,
    loaded: HashMap<(String, Texels), Option<u32>>,
}

impl<'a> TextureCache<'a> {
    fn new(cx: &'a LoadContext) -> Self {
        TextureCache {
            cx,
            loaded: HashMap::new(),
        }
    }

    /// The texture of a `map_Kd` (`map_d`, ...) statement (options, then
    /// the file name), decoded as `kind`; `None`, with a warning, when it
    /// cannot be read; an error when it does not fit in memory.
    fn get(
        &mut self,
        scene: &mut Scene,
        spec: &str,
        kind: Texels,
        material: &str,
        file: &Path,
    ) -> Result<Option<u32>> {
        let (name, wrap) = texture_file_name(spec);
        let key = (name, kind);
        if let Some(&index) = self.loaded.get(&key) {
            return Ok(index);
        }
        let name = &key.0;
        let decoded = match self.cx.files.read_named(name, &self.cx.memory) {
            Ok(bytes) => {
                let what = format!("'{}'", super::excerpt(name, 200));
                decode_texture(&bytes, &what, kind, self.cx)?
            }
            Err(why) => Err(why),
        };
        let index = match decoded {
            Ok(mut tex) => {
                tex.wrap_s = wrap;
                tex.wrap_t = wrap;
                scene.textures.push(tex);
                Some((scene.textures.len() - 1) as u32)
            }
            Err(e) => {
                scene.warnings.push(format!(
                    "{}: material '{}': texture {e}; the material's colour is used",
                    file.display(),
                    super::excerpt(material, 200)
                ));
                None
            }
        };
        self.loaded.insert(key, index);
        Ok(index)
    }
}

/// The file name of a `map_Kd` argument, after its options (`-clamp on`,
/// `-s 1 1 1`, ...), and the wrap mode `-clamp` asks for.
fn texture_file_name(spec: &str) -> (String, Wrap) {
    let words: Vec<&str> = spec.split_whitespace().collect();
    let mut wrap = Wrap::Repeat;
    let mut i = 0;
    while i < words.len() && words[i].starts_with('-') && words.len() - i > 1 {
        let option = words[i];
        i += 1;
        // Arguments run until the next option or the last word (the file).
        let mut args = Vec::new();
        while i < words.len() - 1 && !words[i].starts_with('-') {
            args.push(words[i]);
            i += 1;
        }
        if option == "-clamp" && args.first() == Some(&"on") {
            wrap = Wrap::ClampToEdge;
        }
    }
    (
        words[i.min(words.len().saturating_sub(1))..].join(" "),
        wrap,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes::{Shape, TriangleNormals};

    /// One face, so that a file of materials has something to render.
    const TRIANGLE: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

    fn load(dir: &Path, name: &str, text: &str) -> Result<Scene> {
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        load_obj(&path, &LoadOptions::default())
    }

    #[test]
    fn objects_polygons_normals_uv_and_materials() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("m.mtl"),
            "newmtl red\nKd 0.8 0 0\nKs 0.5 0.5 0.5\nNs 1000\nillum 7\nd 0.75\nNi 1.3\n\
             newmtl tex\nKd 1 1 1\nillum 1\nmap_Kd -clamp on missing.png\n",
        )
        .unwrap();
        let s = load(
            dir.path(),
            "a.obj",
            "mtllib m.mtl\n\
             v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
             vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\n\
             o quad\nusemtl red\nf 1//1 2//1 3//1 4//1\n\
             o tri\nusemtl tex\nf 1/1 2/2 3/3\n\
             o plain\nf 1 3 4\n",
        )
        .unwrap();
        assert_eq!(s.shapes.len(), 4, "a quad, a triangle, a triangle");
        let red = &s.materials[0];
        assert_eq!(red.color, Color::new(1.0, 0.0, 0.0));
        assert!((red.kd - 0.8).abs() < 1e-6);
        // Ns 1000: roughness 0 (Blender's reading), full highlight and mirror.
        assert_eq!((red.ks, red.mirror, red.shine), (0.5, 0.5, 10_000.0));
        assert!((red.t - 0.25).abs() < 1e-6 && red.ior == 1.3);
        // `usemtl` holds across objects, as in every OBJ reader.
        assert_eq!(s.shape_material, vec![0, 0, 1, 1]);
        // One group per object, the quad's two triangles together.
        assert_eq!(s.shape_group[0], s.shape_group[1]);
        assert!(s.shape_group[1] != s.shape_group[2] && s.shape_group[2] != s.shape_group[3]);
        let Shape::Triangle(quad) = &s.shapes[0] else {
            panic!()
        };
        let TriangleNormals::Patch(i) = quad.normals else {
            panic!("smooth")
        };
        assert_eq!(s.corners[i as usize].normals, Some([Vec3::Z; 3]));
        let Shape::Triangle(tri) = &s.shapes[2] else {
            panic!()
        };
        let TriangleNormals::Patch(i) = tri.normals else {
            panic!("textured")
        };
        // v flipped: OBJ's (1, 1) is the texture's top-right corner.
        assert_eq!(s.corners[i as usize].uv.unwrap()[2], Uv::new(1.0, 0.0));
        let Shape::Triangle(plain) = &s.shapes[3] else {
            panic!()
        };
        assert_eq!(plain.normals, TriangleNormals::Flat);
        // The missing texture is a warning; the material keeps its colour.
        assert_eq!(s.materials[1].texture, None);
        assert!(
            s.warnings.iter().any(|w| w.contains("missing.png")),
            "{:?}",
            s.warnings
        );
        assert!(!s.viewpoint_given, "no camera in OBJ: framed");
    }

    #[test]
    fn texture_is_loaded_and_sampled() {
        let dir = tempfile::tempdir().unwrap();
        image::RgbImage::from_fn(2, 1, |x, _| {
            image::Rgb(if x == 0 { [255, 0, 0] } else { [0, 0, 255] })
        })
        .save(dir.path().join("t.png"))
        .unwrap();
        std::fs::write(
            dir.path().join("m.mtl"),
            "newmtl t\nKd 1 1 1\nmap_Kd t.png\n",
        )
        .unwrap();
        let s = load(
            dir.path(),
            "t.obj",
            "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.25 0.5\nvt 0.25 0.5\nvt 0.25 0.5\n\
             usemtl t\nf 1/1 2/2 3/3\n",
        )
        .unwrap();
        assert_eq!(s.textures.len(), 1);
        let hit = crate::shapes::SurfaceHit {
            t: 1.0,
            u: 0.2,
            v: 0.2,
        };
        let sample = s.surface_at(0, &hit, Vec3::ZERO);
        assert_eq!(sample.color, Color::new(1.0, 0.0, 0.0), "left texel");
    }

    #[test]
    fn errors_name_the_file_and_line() {
        let dir = tempfile::tempdir().unwrap();
        let cases = [
            (
                "v.obj",
                "v 0 0 0\nv 1 0 0\nv 1 x 0\nf 1 2 3\n",
                3,
                "'v' needs 3 numbers",
            ),
            (
                "f.obj",
                "v 0 0 0\nv 1 0 0\nv 1 1 0\n\nf 1 2 9\n",
                5,
                "does not exist",
            ),
            ("g.obj", "# c\nv 0 0 0\nf 1/a 2 3\n", 3, "face 'f'"),
        ];
        for (name, text, line, what) in cases {
            let e = load(dir.path(), name, text).unwrap_err();
            let msg = e.to_string();
            assert!(msg.contains(&format!("{name}:{line}: ")), "{msg}");
            assert!(msg.contains(what), "{msg}");
        }
        for (mtl, line) in [("newmtl a\nKd 1 1\n", 2), ("newmtl a\n\nNs x\n", 3)] {
            std::fs::write(dir.path().join("bad.mtl"), mtl).unwrap();
            let e = load(dir.path(), "m.obj", "mtllib bad.mtl\nv 0 0 0\n").unwrap_err();
            assert!(e.to_string().contains(&format!("bad.mtl:{line}: ")), "{e}");
        }
        std::fs::write(dir.path().join("grey.mtl"), "newmtl a\nKd 0.5\n").unwrap();
        let s = load(dir.path(), "g.obj", &format!("mtllib grey.mtl\n{TRIANGLE}")).unwrap();
        assert_eq!(s.materials[0].kd, 0.5);
    }

    #[test]
    fn dissolve_is_blend_map_d_is_a_cut_out_and_illum_6_refracts() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("a.png"),
            crate::texture::tests::png(2, 2, [255, 255, 255]),
        )
        .unwrap();
        std::fs::write(
            dir.path().join("m.mtl"),
            "newmtl half\nd 0.5\nillum 2\nnewmtl tr\nTr 0.25\n\
             newmtl leaf\nmap_d a.png\nnewmtl both\nd 0.5\nmap_d a.png\n\
             newmtl glass\nd 0.2\nNi 1.5\nillum 6\nnewmtl glow\nmap_Ke a.png\n",
        )
        .unwrap();
        let s = load(dir.path(), "a.obj", &format!("mtllib m.mtl\n{TRIANGLE}")).unwrap();
        let m = &s.materials;
        assert_eq!(
            (m[0].alpha_mode, m[0].alpha, m[0].t),
            (AlphaMode::Blend, 0.5, 0.0)
        );
        assert_eq!((m[1].alpha_mode, m[1].alpha), (AlphaMode::Blend, 0.75));
        assert_eq!(m[2].alpha_mode, AlphaMode::Mask { cutoff: 0.5 });
        assert!(m[2].alpha_texture.is_some());
        assert_eq!(m[3].alpha_mode, AlphaMode::Blend);
        assert!(m[3].alpha_texture.is_some());
        assert_eq!((m[4].alpha_mode, m[4].alpha), (AlphaMode::Opaque, 1.0));
        assert!((m[4].t - 0.8).abs() < 1e-6 && m[4].ior == 1.5);
        // map_Ke without Ke: the texture is the light emitted.
        assert_eq!(m[5].emission, Color::ONE);
        assert!(m[5].emission_texture.is_some());
    }

    #[test]
    fn missing_mtl_warns() {
        let dir = tempfile::tempdir().unwrap();
        let s = load(
            dir.path(),
            "n.obj",
            "mtllib nope.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl x\nf 1 2 3\n",
        )
        .unwrap();
        assert_eq!(s.shapes.len(), 1);
        assert!(s.warnings[0].contains("nope.mtl"), "{:?}", s.warnings);
    }

    #[test]
    fn map_kd_options() {
        assert_eq!(
            texture_file_name("a b.png"),
            ("a b.png".into(), Wrap::Repeat)
        );
        assert_eq!(
            texture_file_name("-clamp on -s 1 1 1 t.png"),
            ("t.png".into(), Wrap::ClampToEdge)
        );
        assert_eq!(
            texture_file_name("-bm 0.5 t.jpg"),
            ("t.jpg".into(), Wrap::Repeat)
        );
    }

    #[test]
    fn vertex_colours_are_the_corners_colours_over_a_white_default() {
        let dir = tempfile::tempdir().unwrap();
        // MeshLab's `v x y z r g b`: a red, a green and a blue corner, and
        // a quad of 8-bit colours (any channel above 1).
        let s = load(
            dir.path(),
            "c.obj",
            "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nf 1 2 3\n",
        )
        .unwrap();
        assert_eq!(s.materials[s.shape_material[0] as usize].color, Color::ONE);
        assert_eq!(s.corner_colors, vec![[Color::X, Color::Y, Color::Z]]);
        let bytes = load(
            dir.path(),
            "b.obj",
            "v 0 0 0 255 51 0\nv 1 0 0 255 51 0\nv 1 1 0 255 51 0\nv 0 1 0 255 51 0\nf 1 2 3 4\n",
        )
        .unwrap();
        assert_eq!(bytes.corner_colors.len(), 2);
        assert_eq!(bytes.corner_colors[1][0], Color::new(1.0, 0.2, 0.0));
        // Without colours: the grey default and no corner colours.
        let plain = load(dir.path(), "p.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        assert!(plain.corner_colors.is_empty());
        assert_eq!(plain.materials[0].color, Color::splat(0.8));
    }
}

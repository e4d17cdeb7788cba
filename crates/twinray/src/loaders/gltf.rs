//! glTF 2.0, `.gltf` (JSON with external or `data:` URI buffers) and `.glb`,
//! parsed and validated by the `gltf` crate.
//!
//! * The default scene's node hierarchy is walked with its transforms; every
//!   instance of a mesh is flattened into its own triangles (a mesh used by n
//!   nodes costs n times its triangles), and each node instance is one group.
//! * Primitives of mode TRIANGLES, indexed or not: positions, `NORMAL` (smooth
//!   shading), the texture coordinates the base-colour texture names.
//! * Metallic-roughness materials with `baseColorTexture`,
//!   `KHR_materials_transmission`, `KHR_materials_ior`, `emissiveFactor`,
//!   `emissiveTexture`, `KHR_materials_emissive_strength`,
//!   `occlusionTexture`, `normalTexture` and `alphaMode` (MASK cut-outs,
//!   BLEND) map to twinray's Whitted material as docs/formats.md explains.
//! * `KHR_lights_punctual` point, spot and directional lights; perspective
//!   cameras (`Scene::cameras`, the first one in use).
//!
//! Accessors are read here, not through the crate's readers, so that every
//! offset, stride and count is checked against its buffer before a byte is
//! read: a bad file is a one-line error naming the file and the JSON path or
//! accessor index, never a panic. Missing or unreadable images are warnings.

use std::collections::HashMap;
use std::path::Path;

use base64::Engine as _;
use glam::{Mat3, Mat4};
use gltf::accessor::{DataType, Dimensions};
use gltf::khr_lights_punctual::Kind as LightType;

use super::material_model::{phong_from_roughness, Inputs};
use super::{decode_texture, fold_warnings, reserve_triangles, LoadContext, LoadOptions};
use crate::error::{Error, Result};
use crate::lights::{Light, LightKind};
use crate::math::{Color, Vec3};
use crate::scene::{
    AlphaMode, AngleSpan, Material, MeshPolygon, NamedCamera, NormalMap, NormalMapKind, Scene,
    SceneFormat, Uv, Viewpoint, MAX_RADIANCE,
};
use crate::shapes::{Shape, TriangleNormals};
use crate::texture::{Texels, Texture, Wrap};

/// Deepest node hierarchy accepted (deeper means a cycle or a hostile file).
const MAX_DEPTH: usize = 256;
/// Most node instances visited (a DAG of shared children can explode).
const MAX_NODE_VISITS: usize = 1 << 20;

/// Read and parse a `.gltf` or `.glb` file.
pub mod animation;

pub fn load_gltf(path: &Path, opts: &LoadOptions) -> Result<Scene> {
    Ok(GltfFile::open(path, opts)?
        .pose(opts.animation_time, None)?
        .scene)
}

/// Parse glTF or GLB bytes; `file` names it in messages and locates its
/// external buffers and images.
pub fn parse_gltf(bytes: &[u8], file: &Path, opts: &LoadOptions) -> Result<Scene> {
    Ok(GltfFile::read(bytes, file, opts)?
        .pose(opts.animation_time, None)?
        .scene)
}

/// A glTF file read, with its materials and textures made: what an
/// animation keeps between frames, posed at each frame's time by
/// [`GltfFile::pose`] without reading the file again.
pub struct GltfFile {
    doc: gltf::Document,
    buffers: Vec<Vec<u8>>,
    file: std::path::PathBuf,
    opts: LoadOptions,
    /// The scene before the node walk: materials, textures, their warnings.
    base: Scene,
    default_material: u32,
    /// The animation `LoadOptions::animation` chose (`None`: all of them).
    clip: Option<usize>,
}

/// A glTF file's scene at one time, and where each mesh instance's
/// triangles are in it.
pub struct Posed {
    pub scene: Scene,
    pub instances: Vec<PosedInstance>,
    /// Triangles made from the file's buffers for this pose; the others were
    /// copied from the previous pose's unchanged instances.
    pub made_triangles: usize,
}

/// One mesh instance (a node of the walk) of a [`Posed`] scene.
#[derive(Clone, Debug)]
pub struct PosedInstance {
    /// What its triangles are made from: node, mesh, world transform and
    /// morph weights, as bits. Equal keys give equal triangles.
    pub key: Vec<u32>,
    pub shapes: std::ops::Range<usize>,
    corners: std::ops::Range<usize>,
    warnings: Vec<String>,
}

impl GltfFile {
    /// Reads a `.gltf` or `.glb` file, its buffers, materials and textures.
    pub fn open(path: &Path, opts: &LoadOptions) -> Result<GltfFile> {
        let cx = LoadContext::new(path, opts);
        let bytes = cx.files.read_scene(&cx.memory)?;
        GltfFile::read_in(&bytes, path, opts, &cx)
    }

    /// Reads the document, its buffers, materials and textures.
    pub fn read(bytes: &[u8], file: &Path, opts: &LoadOptions) -> Result<GltfFile> {
        GltfFile::read_in(bytes, file, opts, &LoadContext::new(file, opts))
    }

    fn read_in(
        bytes: &[u8],
        file: &Path,
        opts: &LoadOptions,
        cx: &LoadContext,
    ) -> Result<GltfFile> {
        let mut gltf =
            gltf::Gltf::from_slice_without_validation(bytes).map_err(|e| gltf_error(file, e))?;
        validate(&gltf, file)?;
        let doc = &gltf.document;
        let loader = Loader {
            file,
            opts,
            doc,
            cx,
        };
        // The binary chunk is the first buffer's, moved rather than copied.
        let mut blob = gltf.blob.take();
        let mut buffers = Vec::new();
        for b in doc.buffers() {
            buffers.push(loader.buffer(&b, &mut blob)?);
        }
        let (scene, default_material) = loader.materials(&buffers)?;
        let clip = loader.chosen_animation()?;
        Ok(GltfFile {
            doc: gltf.document,
            buffers,
            file: file.to_path_buf(),
            opts: opts.clone(),
            base: cx.finish(scene),
            default_material,
            clip,
        })
    }

    /// Whether the file has animations.
    pub fn is_animated(&self) -> bool {
        self.doc.animations().next().is_some()
    }

    /// The scene with the animations at `time` seconds (`None`: the nodes'
    /// own transforms). The triangles of a mesh instance whose key is that of
    /// the same instance in `previous` (a pose of this file and its scene,
    /// or that scene with more after it) are copied from it, not made again.
    pub fn pose(
        &self,
        time: Option<f32>,
        previous: Option<(&Scene, &[PosedInstance])>,
    ) -> Result<Posed> {
        // A budget of the memory left now: the file's buffers and textures
        // are taken already.
        let cx = LoadContext::new(&self.file, &self.opts);
        let loader = Loader {
            file: &self.file,
            opts: &self.opts,
            doc: &self.doc,
            cx: &cx,
        };
        let doc = &self.doc;
        let buffers = &self.buffers;
        let file = self.file.as_path();
        let opts = &self.opts;
        let default_material = self.default_material;
        let mut scene = self.base.clone();
        let pose = match time {
            Some(t) => loader.animated_pose(doc, buffers, t, self.clip)?,
            None => animation::Pose::default(),
        };
        let instances = loader.node_instances(doc, &pose.locals)?;
        let triangles = instances
            .iter()
            .filter_map(|(node, _)| node.mesh())
            .flat_map(|mesh| mesh.primitives())
            .map(|p| primitive_triangles(&p))
            .fold(0u64, u64::saturating_add);
        let with_corners = doc.meshes().flat_map(|m| m.primitives()).any(|p| {
            p.get(&gltf::Semantic::Normals).is_some()
                || p.get(&gltf::Semantic::TexCoords(0)).is_some()
        });
        reserve_triangles(&mut scene, triangles, with_corners, file, opts, &cx)?;

        let first_warning = scene.warnings.len();
        let mut cameras = Vec::new();
        let mut posed: Vec<PosedInstance> = Vec::new();
        let mut made_triangles = 0;
        for (node, world) in &instances {
            if let Some(mesh) = node.mesh() {
                let group = scene.new_group();
                let weights = pose.weights_of(node, &mesh);
                let key = instance_key(node, &mesh, world, &weights);
                let start = (
                    scene.shapes.len(),
                    scene.corners.len(),
                    scene.warnings.len(),
                );
                let same = previous
                    .and_then(|(s, p)| p.get(posed.len()).filter(|q| q.key == key).map(|q| (s, q)));
                match same {
                    Some((s, q)) => copy_instance(&mut scene, s, q, group),
                    None => {
                        for prim in mesh.primitives() {
                            let material = prim
                                .material()
                                .index()
                                .map_or(default_material, |i| i as u32);
                            loader.primitive(
                                &mut scene, &mesh, &prim, world, material, group, buffers, &weights,
                            )?;
                        }
                        made_triangles += scene.shapes.len() - start.0;
                    }
                }
                posed.push(PosedInstance {
                    key,
                    shapes: start.0..scene.shapes.len(),
                    corners: start.1..scene.corners.len(),
                    warnings: scene.warnings[start.2..].to_vec(),
                });
            }
            if let Some(camera) = node.camera() {
                match loader.camera(&camera, node, world) {
                    Some(c) => cameras.push((camera.index(), c)),
                    None => scene.warnings.push(format!(
                        "{}: cameras[{}]: orthographic cameras are not supported, skipped",
                        file.display(),
                        camera.index()
                    )),
                }
            }
            if let Some(light) = node.light() {
                let (l, changed) = light_at(&light, world);
                if !changed.is_empty() {
                    loader.warn(
                        &mut scene,
                        format!(
                            "KHR_lights_punctual lights[{}]: {}",
                            light.index(),
                            changed.join(", ")
                        ),
                    );
                }
                scene.lights.push(l);
            }
        }
        fold_warnings(&mut scene, first_warning, 10);
        cameras.sort_by_key(|(index, _)| *index);
        scene.cameras = cameras.into_iter().map(|(_, c)| c).collect();
        // A glTF camera has a direction, not a target: put `at` level with the
        // scene's centre, the default zero-parallax distance of a stereo pair.
        let bounds = scene.bounds();
        if bounds.min.x <= bounds.max.x {
            let center = (bounds.min + bounds.max) * 0.5;
            for c in &mut scene.cameras {
                let vp = &mut c.viewpoint;
                let forward = vp.at - vp.from;
                let depth = (center - vp.from).dot(forward);
                if depth > 0.0 && depth.is_finite() {
                    vp.at = vp.from + forward * depth;
                }
            }
        }
        match scene.cameras.first() {
            Some(c) => {
                scene.viewpoint = c.viewpoint.clone();
                scene.viewpoint_given = true;
            }
            None => scene.frame_bounds(),
        }
        Ok(Posed {
            scene,
            instances: posed,
            made_triangles,
        })
    }
}

/// What a mesh instance's triangles are made from, as bits: its node and
/// mesh, its world transform and its morph weights.
fn instance_key(node: &gltf::Node, mesh: &gltf::Mesh, world: &Mat4, weights: &[f32]) -> Vec<u32> {
    let mut key = vec![node.index() as u32, mesh.index() as u32];
    key.extend(world.to_cols_array().map(f32::to_bits));
    key.extend(weights.iter().map(|w| w.to_bits()));
    key
}

/// Instance `q` of the previous pose's scene `from`, appended to `scene`
/// as group `group`: its triangles (their corner indices moved to where
/// the corners now start) and the warnings making them gave.
fn copy_instance(scene: &mut Scene, from: &Scene, q: &PosedInstance, group: u32) {
    let (old, new) = (q.corners.start as u32, scene.corners.len() as u32);
    scene
        .corners
        .extend_from_slice(&from.corners[q.corners.clone()]);
    for i in q.shapes.clone() {
        let mut shape = from.shapes[i].clone();
        if let Shape::Triangle(t) = &mut shape {
            if let TriangleNormals::Patch(c) = &mut t.normals {
                *c = *c - old + new;
            }
        }
        scene.shapes.push(shape);
        scene.shape_material.push(from.shape_material[i]);
        scene.shape_group.push(group);
    }
    scene.warnings.extend(q.warnings.iter().cloned());
}

/// The crate's schema validation, after a check it lacks: gltf-json 1.4.1's
/// validation indexes the accessors with a primitive's POSITION index
/// unchecked, and panics when it is out of range.
/// Compressed-geometry extensions twinray cannot decode (no maintained
/// pure-Rust Draco decoder; meshopt is not read yet), and what undoes them.
const COMPRESSED_GEOMETRY: [&str; 3] = [
    "KHR_draco_mesh_compression",
    "EXT_meshopt_compression",
    "KHR_meshopt_compression",
];

/// A file whose meshes need a compression extension is refused in one line
/// that names it and the command that decompresses it (without this, the
/// accessors with no data of their own fail validation by the dozen).
fn refuse_compressed(root: &gltf::json::Root, file: &Path) -> Result<()> {
    let needs = |ext: &str| {
        root.extensions_required.iter().any(|e| e == ext)
            || (root.extensions_used.iter().any(|e| e == ext)
                && root.accessors.iter().any(|a| a.buffer_view.is_none()))
    };
    match COMPRESSED_GEOMETRY.into_iter().find(|ext| needs(ext)) {
        Some(ext) => Err(Error::Invalid(format!(
            "{}: meshes compressed with {ext}, which twinray does not decode; decompress them first: \
             npx @gltf-transform/cli copy {} uncompressed.glb",
            file.display(),
            file.display()
        ))),
        None => Ok(()),
    }
}

fn validate(gltf: &gltf::Gltf, file: &Path) -> Result<()> {
    use gltf::json::validation::{Checked, Validate};
    let root = gltf.document.as_json();
    refuse_compressed(root, file)?;
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let position = prim
                .attributes
                .get(&Checked::Valid(gltf::Semantic::Positions));
            if let Some(a) = position.filter(|a| a.value() >= root.accessors.len()) {
                return Err(Error::Invalid(format!(
                    "{}: meshes[{m}].primitives[{p}].attributes[\"POSITION\"]: accessor {} does not exist ({} accessors)",
                    file.display(),
                    a.value(),
                    root.accessors.len()
                )));
            }
        }
    }
    let mut errors = Vec::new();
    root.validate(root, gltf::json::Path::new, &mut |path, error| {
        errors.push((path(), error))
    });
    if errors.is_empty() {
        Ok(())
    } else {
        Err(gltf_error(file, gltf::Error::Validation(errors)))
    }
}

/// The crate's error as one line: JSON syntax errors with their line, schema
/// errors with their JSON path.
fn gltf_error(file: &Path, e: gltf::Error) -> Error {
    match e {
        gltf::Error::Deserialize(e) => Error::Parse {
            file: file.to_path_buf(),
            line: e.line().max(1),
            message: format!("not valid glTF JSON: {e}"),
        },
        gltf::Error::Validation(errors) => {
            let (path, error) = &errors[0];
            let more = match errors.len() {
                1 => String::new(),
                n => format!(" (and {} more problems)", n - 1),
            };
            Error::Invalid(format!("{}: {path}: {error}{more}", file.display()))
        }
        gltf::Error::Binary(e) => {
            Error::Invalid(format!("{}: not a valid GLB file: {e}", file.display()))
        }
        other => Error::Invalid(format!("{}: {other}", file.display())),
    }
}

/// The file being loaded. Images and cameras are read from the document's
/// JSON (`doc.as_json()`): the crate's `Image::source` and
/// `Camera::projection` unwrap fields its validation does not require (an
/// image with neither `uri` nor `bufferView`, a perspective camera described
/// as orthographic) and panic; the fuzzer found the first.
struct Loader<'a> {
    file: &'a Path,
    opts: &'a LoadOptions,
    doc: &'a gltf::Document,
    cx: &'a LoadContext,
}

/// A morph target with its weight: displacements of positions and normals.
struct MorphTarget<'a> {
    weight: f32,
    positions: Option<AccessorView<'a>>,
    normals: Option<AccessorView<'a>>,
}

/// Checked view of an accessor's elements in a buffer.
struct AccessorView<'a> {
    bytes: &'a [u8],
    stride: usize,
    count: usize,
    kind: DataType,
    normalized: bool,
}

impl AccessorView<'_> {
    /// Component `k` of element `i`, as a float (normalized integers mapped to [0, 1]).
    fn float(&self, i: usize, k: usize) -> f32 {
        let at = i * self.stride + k * self.kind.size();
        let b = &self.bytes[at..];
        match self.kind {
            DataType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            DataType::U8 if self.normalized => b[0] as f32 / 255.0,
            DataType::U16 if self.normalized => u16::from_le_bytes([b[0], b[1]]) as f32 / 65535.0,
            _ => self.index(i) as f32,
        }
    }

    /// Element `i` of a scalar integer accessor.
    fn index(&self, i: usize) -> u32 {
        let b = &self.bytes[i * self.stride..];
        match self.kind {
            DataType::U8 => b[0] as u32,
            DataType::U16 => u16::from_le_bytes([b[0], b[1]]) as u32,
            DataType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            DataType::I8 => b[0] as i8 as u32,
            DataType::I16 => i16::from_le_bytes([b[0], b[1]]) as u32,
            DataType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as u32,
        }
    }

    fn vec3(&self, i: usize) -> Vec3 {
        Vec3::new(self.float(i, 0), self.float(i, 1), self.float(i, 2))
    }
}

impl Loader<'_> {
    /// The file's materials and their textures, and a default material
    /// after them (its index returned) for primitives without one.
    fn materials(&self, buffers: &[Vec<u8>]) -> Result<(Scene, u32)> {
        let (loader, doc) = (self, self.doc);
        let mut scene = Scene::new();
        scene.format = SceneFormat::Gltf;
        let mut textures = HashMap::new();
        for m in doc.materials() {
            let mut texture = |t: Option<gltf::Texture>, kind: Texels| match t {
                Some(t) => loader.texture(&mut scene, &mut textures, &t, kind, buffers),
                None => Ok(None),
            };
            let base_texture = || {
                m.pbr_metallic_roughness()
                    .base_color_texture()
                    .map(|i| i.texture())
            };
            let uses_alpha = m.alpha_mode() != gltf::material::AlphaMode::Opaque;
            let alpha = texture(base_texture().filter(|_| uses_alpha), Texels::Alpha)?;
            let normal = texture(m.normal_texture().map(|n| n.texture()), Texels::Data)?;
            let maps = MaterialTextures {
                base: texture(base_texture(), Texels::Colour)?,
                emission: texture(m.emissive_texture().map(|i| i.texture()), Texels::Colour)?,
                occlusion: texture(m.occlusion_texture().map(|o| o.texture()), Texels::Data)?,
                metal_rough_mean: texture(
                    m.pbr_metallic_roughness()
                        .metallic_roughness_texture()
                        .map(|i| i.texture()),
                    Texels::Data,
                )?
                .map(|t| mean_texel(&scene.textures[t as usize])),
                alpha,
                normal,
            };
            let (material, changed) = material_from_pbr(&m, maps);
            if !changed.is_empty() {
                let index = m.index().map_or("default".into(), |i| i.to_string());
                loader.warn(
                    &mut scene,
                    format!("materials[{index}]: {}", changed.join(", ")),
                );
            }
            scene.add_material(material);
        }
        let default_material = scene.add_material(Material {
            kd: 0.8,
            ..Material::default()
        });
        Ok((scene, default_material))
    }

    fn err(&self, message: String) -> Error {
        Error::Invalid(format!("{}: {message}", self.file.display()))
    }

    fn warn(&self, scene: &mut Scene, message: String) {
        scene
            .warnings
            .push(format!("{}: {message}", self.file.display()));
    }

    /// The bytes of a buffer: the GLB's binary chunk (taken from `blob`:
    /// one buffer holds it), a `data:` URI, or a file in the scene's folder.
    fn buffer(&self, b: &gltf::Buffer, blob: &mut Option<Vec<u8>>) -> Result<Vec<u8>> {
        let what = format!("buffers[{}]", b.index());
        let data = match b.source() {
            gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                self.err(format!(
                    "{what}: the file has no binary chunk (or another buffer took it)"
                ))
            })?,
            gltf::buffer::Source::Uri(uri) => self
                .uri_bytes(uri, &what)?
                .map_err(|why| self.err(format!("{what}: {why}")))?,
        };
        if data.len() < b.length() {
            return Err(self.err(format!(
                "{what}: {} bytes, but its byteLength says {}",
                data.len(),
                b.length()
            )));
        }
        Ok(data)
    }

    /// The bytes a URI names: a `data:` URI's, or a file's in the scene's
    /// folder (`files::SceneFiles`: after its `%xx` escapes are decoded).
    /// `Ok(Err(why))` when they cannot be had; `Err` when they do not fit
    /// in the memory left.
    fn uri_bytes(&self, uri: &str, what: &str) -> Result<std::result::Result<Vec<u8>, String>> {
        if let Some(rest) = uri.strip_prefix("data:") {
            let Some((_, payload)) = rest.split_once(";base64,") else {
                return Ok(Err("data URI is not base64".into()));
            };
            let engine = &base64::engine::general_purpose::STANDARD;
            let estimate = base64::decoded_len_estimate(payload.len());
            let room = || format!("{}: {what}: a data URI", self.file.display());
            self.cx.memory.take(estimate as u64, &room)?;
            let mut bytes = Vec::new();
            crate::memory::try_reserve(&mut bytes, estimate, &room)?;
            return Ok(match engine.decode_vec(payload, &mut bytes) {
                Ok(()) => Ok(bytes),
                Err(e) => Err(format!("bad base64 in data URI ({e})")),
            });
        }
        if uri.contains("://") {
            return Ok(Err(format!(
                "'{}' is not a local file (network URIs are not fetched)",
                super::excerpt(uri, 200)
            )));
        }
        Ok(self
            .cx
            .files
            .read_named(&percent_decode(uri), &self.cx.memory))
    }

    /// Checks an accessor against its buffer view and buffer; refuses sparse
    /// accessors and types other than those listed.
    fn accessor<'b>(
        &self,
        a: &gltf::Accessor,
        buffers: &'b [Vec<u8>],
        dims: Dimensions,
        kinds: &[DataType],
    ) -> Result<AccessorView<'b>> {
        let what = format!("accessors[{}]", a.index());
        if a.sparse().is_some() {
            return Err(self.err(format!("{what}: sparse accessors are not supported")));
        }
        if a.dimensions() != dims || !kinds.contains(&a.data_type()) {
            return Err(self.err(format!(
                "{what}: {:?} of {:?} where {dims:?} of {kinds:?} is expected",
                a.dimensions(),
                a.data_type()
            )));
        }
        let Some(view) = a.view() else {
            return Err(self.err(format!("{what}: has no bufferView")));
        };
        let buffer = &buffers[view.buffer().index()];
        let element = a.data_type().size() * a.dimensions().multiplicity();
        let stride = view.stride().unwrap_or(element);
        let bad = || {
            self.err(format!(
                "{what}: {} elements of {element} bytes (stride {stride}) at offset {} do not fit bufferViews[{}] of {} bytes at offset {} in a buffer of {} bytes",
                a.count(),
                a.offset(),
                view.index(),
                view.length(),
                view.offset(),
                buffer.len()
            ))
        };
        let view_end = view
            .offset()
            .checked_add(view.length())
            .filter(|&e| e <= buffer.len())
            .ok_or_else(bad)?;
        let start = view.offset().checked_add(a.offset()).ok_or_else(bad)?;
        let end = match a.count() {
            0 => start,
            n => (n - 1)
                .checked_mul(stride)
                .and_then(|x| x.checked_add(element))
                .and_then(|x| x.checked_add(start))
                .ok_or_else(bad)?,
        };
        if stride < element || end > view_end {
            return Err(bad());
        }
        Ok(AccessorView {
            bytes: &buffer[start..end.max(start)],
            stride,
            count: a.count(),
            kind: a.data_type(),
            normalized: a.normalized(),
        })
    }

    /// Every node of the default scene (or the first, or else every root
    /// node) with its world transform, parents before children; `animated`
    /// replaces the local transforms of the nodes it holds.
    fn node_instances<'d>(
        &self,
        doc: &'d gltf::Document,
        animated: &HashMap<usize, Mat4>,
    ) -> Result<Vec<(gltf::Node<'d>, Mat4)>> {
        let roots: Vec<gltf::Node> = match doc.default_scene().or_else(|| doc.scenes().next()) {
            Some(s) => s.nodes().collect(),
            None => {
                let mut is_child = vec![false; doc.nodes().len()];
                for n in doc.nodes() {
                    for c in n.children() {
                        is_child[c.index()] = true;
                    }
                }
                doc.nodes().filter(|n| !is_child[n.index()]).collect()
            }
        };
        let mut out = Vec::new();
        let mut stack: Vec<(gltf::Node, Mat4, usize)> = roots
            .into_iter()
            .rev()
            .map(|n| (n, Mat4::IDENTITY, 0))
            .collect();
        while let Some((node, parent, depth)) = stack.pop() {
            if depth > MAX_DEPTH || out.len() >= MAX_NODE_VISITS {
                return Err(self.err(format!(
                    "nodes[{}]: node hierarchy deeper than {MAX_DEPTH} levels or with more than {MAX_NODE_VISITS} instances (a cycle?)",
                    node.index()
                )));
            }
            let local = match animated.get(&node.index()) {
                Some(m) => *m,
                None => Mat4::from_cols_array_2d(&node.transform().matrix()),
            };
            let world = parent * local;
            let children: Vec<gltf::Node> = node.children().collect();
            for child in children.into_iter().rev() {
                stack.push((child, world, depth + 1));
            }
            out.push((node, world));
        }
        Ok(out)
    }

    /// The morph targets of `prim` with a weight other than 0 (glTF:
    /// position = base + sum of weight × target displacement; so the
    /// normal).
    fn morph_targets<'b>(
        &self,
        prim: &gltf::Primitive,
        weights: &[f32],
        buffers: &'b [Vec<u8>],
        what: &str,
    ) -> Result<Vec<MorphTarget<'b>>> {
        let read = |a: Option<gltf::Accessor>| {
            a.map(|a| self.accessor(&a, buffers, Dimensions::Vec3, &[DataType::F32]))
                .transpose()
        };
        let mut out = Vec::new();
        for (t, &weight) in prim.morph_targets().zip(weights) {
            if weight == 0.0 {
                continue;
            }
            if !weight.is_finite() {
                return Err(self.err(format!("{what}: morph weight {weight} is not finite")));
            }
            out.push(MorphTarget {
                weight,
                positions: read(t.positions())?,
                normals: read(t.normals())?,
            });
        }
        Ok(out)
    }

    #[allow(clippy::too_many_arguments)]
    fn primitive(
        &self,
        scene: &mut Scene,
        mesh: &gltf::Mesh,
        prim: &gltf::Primitive,
        world: &Mat4,
        material: u32,
        group: u32,
        buffers: &[Vec<u8>],
        weights: &[f32],
    ) -> Result<()> {
        let what = format!("meshes[{}].primitives[{}]", mesh.index(), prim.index());
        if prim.mode() != gltf::mesh::Mode::Triangles {
            self.warn(
                scene,
                format!("{what}: mode {:?} is not TRIANGLES, skipped", prim.mode()),
            );
            return Ok(());
        }
        let Some(pos) = prim.get(&gltf::Semantic::Positions) else {
            self.warn(scene, format!("{what}: no POSITION attribute, skipped"));
            return Ok(());
        };
        let positions = self.accessor(&pos, buffers, Dimensions::Vec3, &[DataType::F32])?;
        let normals = prim
            .get(&gltf::Semantic::Normals)
            .map(|a| self.accessor(&a, buffers, Dimensions::Vec3, &[DataType::F32]))
            .transpose()?;
        // Tangents serve only a normal map, and need normals (glTF's rule).
        let tangents = prim
            .get(&gltf::Semantic::Tangents)
            .filter(|_| normals.is_some() && prim.material().normal_texture().is_some())
            .map(|a| self.accessor(&a, buffers, Dimensions::Vec4, &[DataType::F32]))
            .transpose()?;
        let uv_set = prim
            .material()
            .pbr_metallic_roughness()
            .base_color_texture()
            .map_or(0, |t| t.tex_coord());
        let uvs = prim
            .get(&gltf::Semantic::TexCoords(uv_set))
            .map(|a| {
                self.accessor(
                    &a,
                    buffers,
                    Dimensions::Vec2,
                    &[DataType::F32, DataType::U8, DataType::U16],
                )
            })
            .transpose()?;
        let indices = prim
            .indices()
            .map(|a| {
                self.accessor(
                    &a,
                    buffers,
                    Dimensions::Scalar,
                    &[DataType::U8, DataType::U16, DataType::U32],
                )
            })
            .transpose()?;
        let n = positions.count;
        let targets = self.morph_targets(prim, weights, buffers, &what)?;
        for (name, count) in [
            ("NORMAL", normals.as_ref().map(|a| a.count)),
            ("TEXCOORD", uvs.as_ref().map(|a| a.count)),
            ("TANGENT", tangents.as_ref().map(|a| a.count)),
        ]
        .into_iter()
        .chain(targets.iter().flat_map(|t| {
            [
                ("target POSITION", t.positions.as_ref().map(|a| a.count)),
                ("target NORMAL", t.normals.as_ref().map(|a| a.count)),
            ]
        })) {
            if count.is_some_and(|c| c != n) {
                return Err(self.err(format!(
                    "{what}: {name} has {} elements, POSITION {n}",
                    count.unwrap_or(0)
                )));
            }
        }
        let linear = Mat3::from_mat4(*world);
        let normal_matrix = linear.inverse().transpose();
        // A mirroring transform turns the bitangent's side too.
        let handedness = linear.determinant().signum();
        let corner_count = indices.as_ref().map_or(n, |a| a.count);
        let corner = |c: usize| -> Result<usize> {
            let i = indices.as_ref().map_or(c, |a| a.index(c) as usize);
            if i >= n {
                let a = prim.indices().map_or(0, |a| a.index());
                return Err(self.err(format!(
                    "accessors[{a}]: index {i} at element {c} is out of range ({n} vertices)"
                )));
            }
            Ok(i)
        };
        let mut vertices = [Vec3::ZERO; 3];
        let mut ns = [Vec3::ZERO; 3];
        let mut ts = [Uv::ZERO; 3];
        let mut tangent = [[0.0f32; 4]; 3];
        for tri in 0..corner_count / 3 {
            for k in 0..3 {
                let i = corner(tri * 3 + k)?;
                let mut p = positions.vec3(i);
                for t in &targets {
                    if let Some(d) = &t.positions {
                        p += d.vec3(i) * t.weight;
                    }
                }
                vertices[k] = world.transform_point3(p);
                if let Some(a) = &normals {
                    let mut normal = a.vec3(i);
                    for t in &targets {
                        if let Some(d) = &t.normals {
                            normal += d.vec3(i) * t.weight;
                        }
                    }
                    ns[k] = normal_matrix * normal;
                }
                if let Some(a) = &uvs {
                    ts[k] = Uv::new(a.float(i, 0), a.float(i, 1));
                }
                if let Some(a) = &tangents {
                    let t = linear * a.vec3(i);
                    let w = if a.float(i, 3) < 0.0 { -1.0 } else { 1.0 };
                    tangent[k] = [t.x, t.y, t.z, w * handedness];
                }
            }
            if vertices.iter().any(|v| !v.is_finite()) {
                return Err(self.err(format!(
                    "accessors[{}]: vertex coordinate is not a finite number",
                    pos.index()
                )));
            }
            scene.add_tangent_mesh_polygon(
                &MeshPolygon {
                    vertices: &vertices,
                    normals: normals.is_some().then_some(&ns[..]),
                    uv: uvs.is_some().then_some(&ts[..]),
                    material,
                    group,
                },
                tangents.is_some().then_some(&tangent[..]),
                &|| format!("{}: {what}, triangle {tri}", self.file.display()),
            );
        }
        Ok(())
    }

    /// A texture of a material: decoded once per image, sampler and
    /// kind of texels (colour, non-colour data such as occlusion, alpha);
    /// `None`, with a warning, when its image cannot be had.
    fn texture(
        &self,
        scene: &mut Scene,
        cache: &mut HashMap<(usize, Wrap, Wrap, Texels), Option<u32>>,
        texture: &gltf::Texture,
        kind: Texels,
        buffers: &[Vec<u8>],
    ) -> Result<Option<u32>> {
        let image = texture.source();
        let sampler = texture.sampler();
        let key = (
            image.index(),
            wrap(sampler.wrap_s()),
            wrap(sampler.wrap_t()),
            kind,
        );
        if let Some(&t) = cache.get(&key) {
            return Ok(t);
        }
        let what = format!("images[{}]", image.index());
        let json = &self.doc.as_json().images[image.index()];
        let view = json
            .buffer_view
            .and_then(|v| self.doc.views().nth(v.value()));
        let owned;
        let bytes: std::result::Result<&[u8], String> = match (view, &json.uri) {
            (Some(view), _) => {
                let buffer = &buffers[view.buffer().index()];
                view.offset()
                    .checked_add(view.length())
                    .and_then(|end| buffer.get(view.offset()..end))
                    .ok_or_else(|| {
                        format!(
                            "{what}: bufferViews[{}] is outside its buffer",
                            view.index()
                        )
                    })
            }
            (None, Some(uri)) => match self.uri_bytes(uri, &what)? {
                Ok(b) => {
                    owned = b;
                    Ok(&owned[..])
                }
                Err(why) => Err(format!("{what}: {why}")),
            },
            (None, None) => Err(format!("{what} has neither a uri nor a bufferView")),
        };
        let decoded = match bytes {
            Ok(b) => decode_texture(b, &what, kind, self.cx)?,
            Err(e) => Err(e),
        };
        let index = match decoded {
            Ok(mut tex) => {
                (tex.wrap_s, tex.wrap_t) = (key.1, key.2);
                scene.textures.push(tex);
                Some((scene.textures.len() - 1) as u32)
            }
            Err(e) => {
                self.warn(scene, format!("{e}; the material's factors are used"));
                None
            }
        };
        cache.insert(key, index);
        Ok(index)
    }

    fn camera(
        &self,
        camera: &gltf::Camera,
        node: &gltf::Node,
        world: &Mat4,
    ) -> Option<NamedCamera> {
        let p = self.doc.as_json().cameras[camera.index()]
            .perspective
            .as_ref()?;
        let from = world.transform_point3(Vec3::ZERO);
        let forward = world.transform_vector3(-Vec3::Z).normalize_or(-Vec3::Z);
        let up = world.transform_vector3(Vec3::Y).normalize_or(Vec3::Y);
        let height = 480u32;
        let width = p
            .aspect_ratio
            .filter(|a| a.is_finite() && *a > 0.0)
            .map_or(640, |a| {
                ((height as f32 * a).round() as u32).clamp(1, self.opts.max_resolution)
            });
        let name = camera
            .name()
            .or(node.name())
            .map_or_else(|| format!("camera {}", camera.index()), str::to_string);
        Some(NamedCamera {
            name,
            viewpoint: Viewpoint {
                from,
                at: from + forward,
                up,
                angle_deg: if p.yfov.is_finite() {
                    p.yfov.to_degrees().clamp(1e-3, 179.0)
                } else {
                    45.0
                },
                angle_span: AngleSpan::ImageHeight,
                hither: p.znear.max(0.0),
                width,
                height,
            },
        })
    }
}

/// Triangles a primitive will give (before degenerate ones are dropped).
fn primitive_triangles(p: &gltf::Primitive) -> u64 {
    if p.mode() != gltf::mesh::Mode::Triangles {
        return 0;
    }
    let corners = match p.indices() {
        Some(a) => a.count(),
        None => p.get(&gltf::Semantic::Positions).map_or(0, |a| a.count()),
    };
    corners as u64 / 3
}

fn wrap(mode: gltf::texture::WrappingMode) -> Wrap {
    match mode {
        gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
        gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        gltf::texture::WrappingMode::ClampToEdge => Wrap::ClampToEdge,
    }
}

/// `%xx` escapes of a relative URI decoded (file names with spaces).
fn percent_decode(uri: &str) -> String {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        if b[i] == b'%' && i + 2 < b.len() {
            if let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// The textures of a material, as indices into `Scene::textures`.
#[derive(Clone, Copy, Debug, Default)]
pub struct MaterialTextures {
    pub base: Option<u32>,
    pub emission: Option<u32>,
    pub occlusion: Option<u32>,
    /// The mean texel of `metallicRoughnessTexture` (green: roughness,
    /// blue: metallic), which scales the factors: the texture is not
    /// sampled per hit, and its factors are usually 1 (the texture decides).
    pub metal_rough_mean: Option<Color>,
    /// The base colour texture's alpha channel (MASK and BLEND materials only).
    pub alpha: Option<u32>,
    /// `normalTexture`, as data.
    pub normal: Option<u32>,
}

/// The mean of a texture's texels.
fn mean_texel(t: &Texture) -> Color {
    let sum: Color = t.texels.iter().copied().sum();
    sum / t.texels.len().max(1) as f32
}

/// How a metallic-roughness material maps to twinray's Whitted material
/// (docs/formats.md): the base colour is the colour; the diffuse weight is
/// what metal and transmission leave, plus a rough metal's scattered share
/// (metal × roughness: a very rough metal looks like a coloured matte
/// surface); the Phong highlight and the mirror carry the specular
/// reflectance at normal incidence (0.04 for dielectrics, 1 for metals) as
/// [`phong_from_roughness`] spreads it, and a metal's highlight takes its
/// base colour. Emission is `emissiveFactor` × `emissiveTexture` ×
/// `KHR_materials_emissive_strength`; the occlusion texture darkens the
/// ambient term.
pub fn material_from_pbr(m: &gltf::Material, maps: MaterialTextures) -> (Material, Vec<String>) {
    let pbr = m.pbr_metallic_roughness();
    let mut inputs = Inputs::default();
    let [r, g, b, alpha] = inputs.clamp_all("baseColorFactor", pbr.base_color_factor(), 0.0, 1.0);
    let mean = maps.metal_rough_mean.unwrap_or(Color::ONE);
    let metal = inputs.clamp("metallicFactor", pbr.metallic_factor(), 0.0, 1.0) * mean.z;
    let rough = inputs.clamp("roughnessFactor", pbr.roughness_factor(), 0.0, 1.0) * mean.y;
    let transmission = match m.transmission() {
        Some(t) => inputs.clamp("transmissionFactor", t.transmission_factor(), 0.0, 1.0),
        None => 0.0,
    };
    let ior = match m.ior() {
        Some(n) if !(n.is_finite() && n >= 1.0) => {
            inputs.changed.push(format!("ior {n} replaced by 1.5"));
            1.5
        }
        Some(n) => n,
        None => 1.5,
    };
    let phong = phong_from_roughness(0.04 + 0.96 * metal, rough);
    let strength = match m.emissive_strength() {
        Some(s) => inputs.clamp("emissiveStrength", s, 0.0, MAX_RADIANCE),
        None => 1.0,
    };
    let emissive = inputs.clamp_all("emissiveFactor", m.emissive_factor(), 0.0, 1.0);
    let occlusion_strength = match m.occlusion_texture() {
        Some(o) => inputs.clamp("occlusionTexture.strength", o.strength(), 0.0, 1.0),
        None => 1.0,
    };
    let alpha_mode = match m.alpha_mode() {
        gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
        gltf::material::AlphaMode::Mask => AlphaMode::Mask {
            cutoff: inputs.clamp("alphaCutoff", m.alpha_cutoff().unwrap_or(0.5), 0.0, 1.0),
        },
        gltf::material::AlphaMode::Blend => AlphaMode::Blend,
    };
    let normal_scale = match m.normal_texture() {
        Some(n) => inputs.clamp("normalTexture.scale", n.scale(), -100.0, 100.0),
        None => 1.0,
    };
    let color = Color::new(r, g, b);
    inputs.finish(Material {
        color,
        kd: (1.0 - metal) * (1.0 - transmission) + metal * rough,
        ks: phong.ks,
        shine: phong.shine,
        t: (1.0 - metal) * transmission,
        ior,
        mirror: phong.mirror,
        emission: Color::from(emissive) * strength,
        texture: maps.base,
        specular_color: Color::ONE.lerp(color, metal),
        emission_texture: maps.emission,
        occlusion_texture: maps.occlusion,
        occlusion_strength,
        alpha_mode,
        alpha,
        alpha_texture: maps.alpha,
        normal_map: maps.normal.map(|texture| NormalMap {
            texture,
            scale: normal_scale,
            kind: NormalMapKind::Tangent,
        }),
    })
}

/// A glTF light placed by its node: position from the node's origin, direction
/// its −z axis; colour times intensity (at most [`MAX_RADIANCE`]); and what
/// was clamped, for a warning.
fn light_at(light: &gltf::khr_lights_punctual::Light, world: &Mat4) -> (Light, Vec<String>) {
    let position = world.transform_point3(Vec3::ZERO);
    let direction = world.transform_vector3(-Vec3::Z).normalize_or(-Vec3::Z);
    let mut inputs = Inputs::default();
    let color = inputs.clamp_all("color", light.color(), 0.0, 1.0);
    let intensity = inputs.clamp("intensity", light.intensity(), 0.0, MAX_RADIANCE);
    let range = light.range().filter(|r| r.is_finite() && *r > 0.0);
    let kind = match light.kind() {
        LightType::Directional => LightKind::Directional { direction },
        LightType::Point => LightKind::Point {
            position,
            inverse_square: true,
            range,
        },
        LightType::Spot {
            inner_cone_angle,
            outer_cone_angle,
        } => LightKind::Spot {
            position,
            direction,
            cos_inner: inner_cone_angle.cos(),
            cos_outer: outer_cone_angle.cos(),
            range,
        },
    };
    let light = Light {
        kind,
        color: Some(Color::from(color) * intensity),
    };
    (light, inputs.changed)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use serde_json::json;

    /// A buffer as a base64 data URI.
    pub fn data_uri(bytes: &[u8]) -> String {
        format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(bytes)
        )
    }

    /// Little-endian bytes of f32 positions followed by u32 indices.
    pub fn mesh_bytes(positions: &[[f32; 3]], indices: &[u32]) -> Vec<u8> {
        let mut b: Vec<u8> = positions
            .iter()
            .flatten()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        b.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
        b
    }

    /// A glTF document with one indexed mesh in one buffer given by `uri`.
    pub fn one_mesh(positions: &[[f32; 3]], indices: &[u32], uri: &str) -> serde_json::Value {
        let pos_len = positions.len() * 12;
        json!({
            "asset": {"version": "2.0"},
            "scene": 0,
            "scenes": [{"nodes": [0]}],
            "nodes": [{"mesh": 0, "name": "thing"}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
            "buffers": [{"byteLength": pos_len + indices.len() * 4, "uri": uri}],
            "bufferViews": [
                {"buffer": 0, "byteOffset": 0, "byteLength": pos_len},
                {"buffer": 0, "byteOffset": pos_len, "byteLength": indices.len() * 4}
            ],
            "accessors": [
                {"bufferView": 0, "componentType": 5126, "count": positions.len(), "type": "VEC3",
                 "min": [0, 0, 0], "max": [1, 1, 1]},
                {"bufferView": 1, "componentType": 5125, "count": indices.len(), "type": "SCALAR"}
            ]
        })
    }

    const QUAD: [[f32; 3]; 4] = [[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]];
    const QUAD_INDICES: [u32; 6] = [0, 1, 2, 0, 2, 3];

    /// A unit square of two triangles in a data-URI buffer.
    fn quad() -> serde_json::Value {
        one_mesh(
            &QUAD,
            &QUAD_INDICES,
            &data_uri(&mesh_bytes(&QUAD, &QUAD_INDICES)),
        )
    }

    fn parse(doc: &serde_json::Value) -> Result<Scene> {
        parse_gltf(
            doc.to_string().as_bytes(),
            Path::new("t.gltf"),
            &LoadOptions::default(),
        )
    }

    #[test]
    fn nodes_transforms_cameras_lights_and_materials() {
        let mut doc = quad();
        doc["nodes"] = json!([
            {"children": [1, 2, 3], "translation": [10, 0, 0]},
            {"mesh": 0, "scale": [2, 2, 2], "name": "big"},
            {"camera": 0, "translation": [0, 0, 5], "name": "eye"},
            {"extensions": {"KHR_lights_punctual": {"light": 0}}, "translation": [0, 3, 0]}
        ]);
        doc["scenes"] = json!([{"nodes": [0]}]);
        doc["cameras"] = json!([{"type": "perspective", "name": "main",
            "perspective": {"yfov": 0.5, "znear": 0.1, "aspectRatio": 2.0}}]);
        doc["extensionsUsed"] = json!([
            "KHR_lights_punctual",
            "KHR_materials_transmission",
            "KHR_materials_ior"
        ]);
        doc["extensions"] = json!({"KHR_lights_punctual": {"lights": [
            {"type": "point", "color": [1, 0.5, 0.5], "intensity": 2.0}]}});
        doc["materials"] = json!([{"pbrMetallicRoughness": {"baseColorFactor": [1, 0, 0, 1],
            "metallicFactor": 0.0, "roughnessFactor": 1.0},
            "extensions": {"KHR_materials_transmission": {"transmissionFactor": 0.5},
                           "KHR_materials_ior": {"ior": 1.33}}}]);
        doc["meshes"][0]["primitives"][0]["material"] = json!(0);
        let s = parse(&doc).unwrap();
        assert_eq!(s.shapes.len(), 2);
        let b = s.bounds();
        assert_eq!(
            (b.min, b.max),
            (Vec3::new(10., 0., 0.), Vec3::new(12., 2., 0.))
        );
        assert_eq!(s.shape_group[0], s.shape_group[1]);
        let m = &s.materials[s.shape_material[0] as usize];
        assert_eq!(m.color, Color::new(1.0, 0.0, 0.0));
        assert_eq!((m.kd, m.t, m.ior, m.mirror), (0.5, 0.5, 1.33, 0.0));
        assert_eq!(s.cameras.len(), 1);
        assert_eq!(s.cameras[0].name, "main");
        let vp = &s.viewpoint;
        assert!(s.viewpoint_given);
        assert_eq!(vp.from, Vec3::new(10.0, 0.0, 5.0));
        assert_eq!(vp.at, Vec3::new(10.0, 0.0, 0.0), "level with the centre");
        assert_eq!((vp.width, vp.height), (960, 480));
        assert_eq!(vp.angle_span, AngleSpan::ImageHeight);
        assert!((vp.angle_deg - 0.5f32.to_degrees()).abs() < 1e-4);
        assert_eq!(s.lights.len(), 1);
        assert_eq!(s.lights[0].position(), Some(Vec3::new(10.0, 3.0, 0.0)));
        assert_eq!(s.lights[0].color, Some(Color::new(2.0, 1.0, 1.0)));
    }

    #[test]
    fn glb_with_binary_chunk() {
        let bin = mesh_bytes(&QUAD, &QUAD_INDICES);
        let mut doc = one_mesh(&QUAD, &QUAD_INDICES, "");
        doc["buffers"][0].as_object_mut().unwrap().remove("uri");
        let glb = glb(&doc, &bin);
        let s = parse_gltf(&glb, Path::new("t.glb"), &LoadOptions::default()).unwrap();
        assert_eq!(s.shapes.len(), 2);
        assert!(!s.viewpoint_given, "no camera: framed");
    }

    /// A GLB container: header, JSON chunk, BIN chunk.
    pub fn glb(doc: &serde_json::Value, bin: &[u8]) -> Vec<u8> {
        let mut json = doc.to_string().into_bytes();
        while !json.len().is_multiple_of(4) {
            json.push(b' ');
        }
        let mut bin = bin.to_vec();
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let total = 12 + 8 + json.len() + 8 + bin.len();
        let mut out = Vec::new();
        out.extend(b"glTF");
        out.extend(2u32.to_le_bytes());
        out.extend((total as u32).to_le_bytes());
        out.extend((json.len() as u32).to_le_bytes());
        out.extend(b"JSON");
        out.extend(json);
        out.extend((bin.len() as u32).to_le_bytes());
        out.extend(b"BIN\0");
        out.extend(bin);
        out
    }

    #[test]
    fn alpha_modes_and_their_alpha() {
        let mut doc = one_mesh(
            &QUAD,
            &QUAD_INDICES,
            &data_uri(&mesh_bytes(&QUAD, &QUAD_INDICES)),
        );
        doc["materials"] = json!([
            {"alphaMode": "BLEND", "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 0.25]}},
            {"alphaMode": "MASK"},
            {"alphaMode": "MASK", "alphaCutoff": 0.8},
            {"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 0.25]}}
        ]);
        let s = parse(&doc).unwrap();
        let m = &s.materials;
        assert_eq!((m[0].alpha_mode, m[0].alpha), (AlphaMode::Blend, 0.25));
        assert_eq!(m[1].alpha_mode, AlphaMode::Mask { cutoff: 0.5 });
        assert_eq!(m[2].alpha_mode, AlphaMode::Mask { cutoff: 0.8 });
        assert_eq!(m[3].alpha_mode, AlphaMode::Opaque, "OPAQUE ignores alpha");
        assert!(s.has_alpha());
    }

    #[test]
    fn textured_material_samples_its_image() {
        let png = crate::texture::tests::png(2, 2, [0, 255, 0]);
        let uv: [[f32; 2]; 4] = [[0., 0.], [1., 0.], [1., 1.], [0., 1.]];
        let mut bytes = mesh_bytes(&QUAD, &QUAD_INDICES);
        let uv_offset = bytes.len();
        bytes.extend(uv.iter().flatten().flat_map(|x| x.to_le_bytes()));
        let mut doc = one_mesh(&QUAD, &QUAD_INDICES, &data_uri(&bytes));
        doc["buffers"][0]["byteLength"] = json!(bytes.len());
        doc["bufferViews"]
            .as_array_mut()
            .unwrap()
            .push(json!({"buffer": 0, "byteOffset": uv_offset, "byteLength": 32}));
        doc["accessors"]
            .as_array_mut()
            .unwrap()
            .push(json!({"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"}));
        doc["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(2);
        doc["meshes"][0]["primitives"][0]["material"] = json!(0);
        doc["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}},
                                  {"pbrMetallicRoughness": {"baseColorTexture": {"index": 1}}}]);
        doc["textures"] = json!([{"source": 0}, {"source": 1}]);
        doc["images"] = json!([{"uri": format!("data:image/png;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&png))}, {"uri": "missing.png"}]);
        let s = parse(&doc).unwrap();
        assert_eq!(s.textures.len(), 1);
        let hit = crate::shapes::SurfaceHit {
            t: 1.0,
            u: 0.3,
            v: 0.3,
        };
        assert_eq!(
            s.surface_at(0, &hit, Vec3::ZERO).color,
            Color::new(0.0, 1.0, 0.0)
        );
        assert_eq!(s.materials[1].texture, None);
        assert!(
            s.warnings.iter().any(|w| w.contains("images[1]")),
            "{:?}",
            s.warnings
        );
    }

    #[test]
    fn bad_files_name_the_place() {
        let good = quad();
        let mut index_out_of_range = good.clone();
        index_out_of_range["buffers"][0]["uri"] =
            json!(data_uri(&mesh_bytes(&QUAD, &[0, 1, 2, 0, 2, 7])));
        let mut view_too_short = good.clone();
        view_too_short["accessors"][0]["count"] = json!(400);
        let mut missing_accessor = good.clone();
        missing_accessor["meshes"][0]["primitives"][0]["indices"] = json!(9);
        let mut missing_position = good.clone();
        missing_position["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(5);
        let mut short_buffer = good.clone();
        short_buffer["buffers"][0]["byteLength"] = json!(4000);
        short_buffer["bufferViews"][1]["byteLength"] = json!(3000);
        let cases = [
            (index_out_of_range, "accessors[1]: index 7"),
            (view_too_short, "accessors[0]: 400 elements"),
            (missing_accessor, "meshes[0].primitives[0].indices"),
            (
                missing_position,
                "attributes[\"POSITION\"]: accessor 5 does not exist",
            ),
            (short_buffer, "buffers[0]"),
        ];
        for (doc, expected) in cases {
            let e = parse(&doc).unwrap_err().to_string();
            assert!(e.starts_with("t.gltf: "), "{e}");
            assert!(e.contains(expected), "{e} lacks {expected}");
        }
        let e = parse_gltf(
            b"{\n\"asset\": \n",
            Path::new("t.gltf"),
            &LoadOptions::default(),
        )
        .unwrap_err()
        .to_string();
        assert!(e.starts_with("t.gltf:"), "{e}");
    }

    /// What the fuzzer found (seed 307, mutant 3767): an image with neither
    /// `uri` nor `bufferView`, which the gltf crate's `Image::source` unwraps.
    /// Also a perspective camera holding only orthographic numbers.
    #[test]
    fn image_without_source_and_camera_without_projection_do_not_panic() {
        let mut doc = quad();
        doc["meshes"][0]["primitives"][0]["material"] = json!(0);
        doc["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
        doc["textures"] = json!([{"source": 0}]);
        doc["images"] = json!([{"name": "nothing"}]);
        doc["cameras"] = json!([{"type": "perspective",
            "orthographic": {"xmag": 1, "ymag": 1, "znear": 0.1, "zfar": 10}}]);
        doc["nodes"] = json!([{"mesh": 0}, {"camera": 0}]);
        doc["scenes"] = json!([{"nodes": [0, 1]}]);
        let s = parse(&doc).unwrap();
        assert_eq!(s.materials[0].texture, None);
        assert!(
            s.warnings.iter().any(|w| w.contains("neither a uri")),
            "{:?}",
            s.warnings
        );
        assert!(s.cameras.is_empty() && !s.viewpoint_given);
    }

    #[test]
    fn absurd_triangle_counts_are_refused_before_reading() {
        let mut doc = quad();
        doc["accessors"][1]["count"] = json!(3_000_000_000u64);
        let e = parse(&doc).unwrap_err().to_string();
        assert!(e.contains("exceed the limit"), "{e}");
    }
}

//! The loaded scene: primitives with their materials, per-corner attributes
//! and groups, textures, lights, and the cameras a file describes.
//!
//! Loaders call the `add_*` methods; they turn polygons into triangles and skip
//! degenerate geometry with a warning instead of failing. The tracer asks the
//! scene one thing about a hit: its shading normal, colour and material
//! ([`Scene::surface_at`]).

use crate::math::{Aabb, Color, Vec3};
use crate::shapes::{Cone, Shape, Sphere, SurfaceHit, Triangle, TriangleNormals};
use crate::texture::Texture;

pub use crate::lights::{Light, LightKind};
pub use crate::surface_maps::{AlphaMode, NormalMap, NormalMapKind};

/// Texture coordinates (u, v), v = 0 at the top row of the image.
pub use crate::shapes::{Corners, Uv};

/// Whitted's material, NFF's `f` and what OBJ and glTF materials map to (see
/// docs/formats.md): colour, diffuse `kd`, Phong highlight `ks` and exponent
/// `shine`, mirror weight `mirror` (NFF: equal to `ks`), transmission `t` and
/// index of refraction, light emitted, and a texture for the colour.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub color: Color,
    pub kd: f32,
    pub ks: f32,
    pub shine: f32,
    pub t: f32,
    pub ior: f32,
    pub mirror: f32,
    /// Added to the colour of every hit, whatever the light (glTF `emissive`).
    pub emission: Color,
    /// Index into `Scene::textures`: multiplies `color` where a triangle has
    /// texture coordinates.
    pub texture: Option<u32>,
    /// Colour of the Phong highlight (white; a metal's base colour).
    pub specular_color: Color,
    /// Multiplies `emission` where a triangle has texture coordinates (glTF
    /// `emissiveTexture`).
    pub emission_texture: Option<u32>,
    /// Scales the ambient term by its red channel (glTF `occlusionTexture`,
    /// non-colour data), blended by `occlusion_strength`.
    pub occlusion_texture: Option<u32>,
    pub occlusion_strength: f32,
    /// How the surface's alpha is used: ignored, a cut-out, or a partial
    /// straight-through transmission (docs/shading.md).
    pub alpha_mode: AlphaMode,
    /// Coverage: glTF `baseColorFactor`'s alpha, OBJ `d` (or `1 − Tr`).
    pub alpha: f32,
    /// Index into `Scene::textures` of a texture whose channels hold the
    /// alpha that multiplies `alpha` (the base colour's alpha; OBJ `map_d`).
    pub alpha_texture: Option<u32>,
    /// A normal or height map that bends the shading normal (glTF
    /// `normalTexture`, OBJ `norm` / `map_Bump`).
    pub normal_map: Option<NormalMap>,
}

impl Material {
    /// The ratio of refractive indices a ray crosses the surface with: into
    /// the material when `entering`, out of it otherwise (an `ior` of 0 is 1).
    pub fn eta(&self, entering: bool) -> f32 {
        let ior = if self.ior > 0.0 { self.ior } else { 1.0 };
        if entering {
            1.0 / ior
        } else {
            ior
        }
    }

    /// The material with every value in the range the shading model is defined
    /// for, and what was changed (for a warning): `kd`, `ks`, `t`, `mirror`,
    /// `alpha` and the colour and highlight colour components in 0..=1,
    /// `shine` >= 0, the emission's components in 0..=[`MAX_RADIANCE`],
    /// `ior` > 0 (else 1); NaN becomes the lower bound. (A colour of 3.4e38,
    /// found by the fuzzer, gave infinite pixels, as did an MTL `Ke` or a
    /// glTF emission of 1e38.) Out of range, they gave infinite pixels (a
    /// negative Phong exponent) or light from nowhere (`kd` -1: ambient 2).
    pub fn clamped(mut self) -> (Material, Vec<String>) {
        let mut changed = Vec::new();
        for (name, value, lo, hi) in [
            ("Kd", &mut self.kd, 0.0, 1.0),
            ("Ks", &mut self.ks, 0.0, 1.0),
            ("T", &mut self.t, 0.0, 1.0),
            ("Shine", &mut self.shine, 0.0, f32::MAX),
            ("red", &mut self.color.x, 0.0, 1.0),
            ("green", &mut self.color.y, 0.0, 1.0),
            ("blue", &mut self.color.z, 0.0, 1.0),
            ("mirror", &mut self.mirror, 0.0, 1.0),
            ("alpha", &mut self.alpha, 0.0, 1.0),
            ("highlight red", &mut self.specular_color.x, 0.0, 1.0),
            ("highlight green", &mut self.specular_color.y, 0.0, 1.0),
            ("highlight blue", &mut self.specular_color.z, 0.0, 1.0),
            ("emission red", &mut self.emission.x, 0.0, MAX_RADIANCE),
            ("emission green", &mut self.emission.y, 0.0, MAX_RADIANCE),
            ("emission blue", &mut self.emission.z, 0.0, MAX_RADIANCE),
            ("occlusion strength", &mut self.occlusion_strength, 0.0, 1.0),
        ] {
            let fixed = if value.is_nan() {
                lo
            } else {
                value.clamp(lo, hi)
            };
            if fixed != *value || value.is_nan() {
                changed.push(format!("{name} {value} clamped to {fixed}"));
                *value = fixed;
            }
        }
        if !(self.ior > 0.0 && self.ior.is_finite()) {
            // Only a transmitting material refracts: an opaque one's index
            // means nothing (the SPD write 0 there), so no warning.
            if self.t > 0.0 {
                changed.push(format!("index of refraction {} replaced by 1", self.ior));
            }
            self.ior = 1.0;
        }
        (self, changed)
    }

    /// Ambient coefficient: what `kd`, `ks` and `t` leave of one, the convention of
    /// the SPD's own POV-Ray exporter (balls' floor: 1 - 0.8 = 0.2; glass: 0).
    pub fn ambient(&self) -> f32 {
        (1.0 - self.kd - self.ks - self.t).max(0.0)
    }
}

impl Default for Material {
    fn default() -> Self {
        Material {
            color: Color::ONE,
            kd: 1.0,
            ks: 0.0,
            shine: 0.0,
            t: 0.0,
            ior: 1.0,
            mirror: 0.0,
            emission: Color::ZERO,
            texture: None,
            specular_color: Color::ONE,
            emission_texture: None,
            occlusion_texture: None,
            occlusion_strength: 1.0,
            alpha_mode: AlphaMode::Opaque,
            alpha: 1.0,
            alpha_texture: None,
            normal_map: None,
        }
    }
}

/// Which angle `Viewpoint::angle_deg` measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum AngleSpan {
    /// NFF: between the centres of the edge pixels of the shorter side.
    #[default]
    EdgePixelCentres,
    /// glTF `yfov` and `--fov`: the image's full height, top edge to bottom edge.
    ImageHeight,
}

/// Where the camera is and what it sees: NFF `v`, a glTF camera, or the
/// command line's `--from/--at/--up/--fov`.
#[derive(Clone, Debug, PartialEq)]
pub struct Viewpoint {
    pub from: Vec3,
    pub at: Vec3,
    pub up: Vec3,
    pub angle_deg: f32,
    pub angle_span: AngleSpan,
    pub hither: f32,
    pub width: u32,
    pub height: u32,
}

impl Default for Viewpoint {
    fn default() -> Self {
        Viewpoint {
            from: Vec3::new(0.0, 0.0, 1.0),
            at: Vec3::ZERO,
            up: Vec3::Y,
            angle_deg: 45.0,
            angle_span: AngleSpan::EdgePixelCentres,
            hither: 0.0,
            // Every model format's size without a camera that gives one.
            width: 640,
            height: 480,
        }
    }
}

/// A camera a scene file describes, by name (glTF cameras).
#[derive(Clone, Debug, PartialEq)]
pub struct NamedCamera {
    pub name: String,
    pub viewpoint: Viewpoint,
}

/// The file format a scene came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum SceneFormat {
    #[default]
    Nff,
    Obj,
    Gltf,
    Stl,
    Ply,
}

#[derive(Clone, Debug, Default)]
pub struct Scene {
    pub format: SceneFormat,
    /// The camera in use: NFF's `v`, the chosen glTF camera, or one framing the
    /// scene's bounds.
    pub viewpoint: Viewpoint,
    /// Whether `viewpoint` was given by the file (else it frames the bounds).
    pub viewpoint_given: bool,
    /// Every camera of the file (glTF), in file order.
    pub cameras: Vec<NamedCamera>,
    pub background: Color,
    pub lights: Vec<Light>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub shapes: Vec<Shape>,
    /// Material index of each shape.
    pub shape_material: Vec<u32>,
    /// Group of each shape: an OBJ object or group, a glTF node, an NFF entity.
    /// Object-tree cuts (§2.3) treat a group as one object.
    pub shape_group: Vec<u32>,
    /// Per-corner attributes of smooth or textured triangles (`TriangleNormals::Patch`).
    pub corners: Vec<Corners>,
    /// Degenerate geometry skipped and missing textures, with where they were.
    pub warnings: Vec<String>,
    next_group: u32,
    /// An environment image (`--env`): what rays leaving the scene see, and
    /// ambient light; `background` is unused with it.
    pub environment: Option<std::sync::Arc<crate::environment::Environment>>,
    /// Per-corner colours (PLY vertex colours, linear), multiplying the
    /// material's colour: entry `i` belongs to `corners[i]`. Empty for a
    /// scene without them (no cost), and only as long as the last coloured
    /// record: corner records past its end have none.
    pub corner_colors: Vec<[Color; 3]>,
    /// Per-corner tangents of normal maps (glTF `TANGENT`: xyz in world
    /// space, w = ±1 the bitangent's sign), aligned with `corners` as
    /// `corner_colors` is. Without them a normal map's frame comes from the
    /// triangle's uv.
    pub corner_tangents: Vec<[[f32; 4]; 3]>,
    /// The files the load read (canonical paths): the scene file, and the
    /// buffers, images and material libraries it names. No output may
    /// replace one of them.
    pub inputs: Vec<std::path::PathBuf>,
}

/// What the tracer needs of a hit: the unit shading normal (not yet turned
/// toward the ray), the colour there (material colour times texture) and the
/// material.
pub struct SurfaceSample<'a> {
    pub normal: Vec3,
    pub color: Color,
    pub material: &'a Material,
    /// Light emitted here: the material's, times its emission texture.
    pub emission: Color,
    /// Ambient occlusion here, 1 = none.
    pub occlusion: f32,
    /// The share of the surface that is there (a BLEND material's alpha);
    /// 1 for opaque and cut-out materials.
    pub coverage: f32,
    /// The unit normal before a normal map bent it (equal to `normal`
    /// without one): secondary rays leave the surface along it.
    pub offset_normal: Vec3,
}

impl SurfaceSample<'_> {
    /// The ambient term under an environment image, seen with unit normal
    /// `facing`: the colour times the occlusion times (the ambient
    /// coefficient × the image's mean + `Kd` × its diffuse light there),
    /// plus the light emitted.
    pub fn ambient_under(&self, env: &crate::environment::Environment, facing: Vec3) -> Color {
        let m = self.material;
        let light = env.mean() * m.ambient() + env.diffuse(facing) * m.kd;
        self.color * light * self.occlusion + self.emission
    }

    /// The ambient term here, with the light emitted: Whitted's ambient
    /// (colour × the material's ambient coefficient) darkened by the
    /// occlusion texture.
    pub fn ambient(&self) -> Color {
        let a = self.color * (self.material.ambient() * self.occlusion);
        if self.emission == Color::ZERO {
            a
        } else {
            a + self.emission
        }
    }
}

/// A triangle of a mesh as the OBJ and glTF loaders hand it over.
pub struct MeshPolygon<'a> {
    pub vertices: &'a [Vec3],
    pub normals: Option<&'a [Vec3]>,
    pub uv: Option<&'a [Uv]>,
    pub material: u32,
    pub group: u32,
}

impl Scene {
    pub fn new() -> Scene {
        Scene::default()
    }

    /// Makes `m` the material of the shapes that follow; returns its index.
    pub fn add_material(&mut self, m: Material) -> u32 {
        self.materials.push(m);
        (self.materials.len() - 1) as u32
    }

    fn current_material(&mut self) -> u32 {
        if self.materials.is_empty() {
            self.materials.push(Material::default());
        }
        (self.materials.len() - 1) as u32
    }

    /// Bytes held by the shapes, their materials and groups, corner
    /// attributes, materials and textures.
    pub fn memory_bytes(&self) -> usize {
        use std::mem::size_of;
        self.shapes.len() * size_of::<Shape>()
            + self.shape_material.len() * 4
            + self.shape_group.len() * 4
            + self.corners.len() * size_of::<Corners>()
            + self.corner_colors.len() * size_of::<[Color; 3]>()
            + self.corner_tangents.len() * size_of::<[[f32; 4]; 3]>()
            + self.materials.len() * size_of::<Material>()
            + self
                .textures
                .iter()
                .map(Texture::memory_bytes)
                .sum::<usize>()
    }

    /// A new group id for the shapes that follow.
    pub fn new_group(&mut self) -> u32 {
        self.next_group += 1;
        self.next_group - 1
    }

    fn push(&mut self, s: Shape) {
        let m = self.current_material();
        let g = self.new_group();
        self.push_with(s, m, g);
    }

    fn push_with(&mut self, s: Shape, material: u32, group: u32) {
        if self.materials.is_empty() {
            self.materials.push(Material::default());
        }
        self.shapes.push(s);
        self.shape_material.push(material);
        self.shape_group.push(group);
    }

    /// The normal map's tangent at a hit on a triangle with given tangents:
    /// its corners' interpolated, and the bitangent's sign; `None` where the
    /// file gave none (w = 0).
    fn tangent_at(&self, prim: usize, hit: &SurfaceHit) -> Option<(Vec3, f32)> {
        let Shape::Triangle(t) = &self.shapes[prim] else {
            return None;
        };
        let TriangleNormals::Patch(i) = t.normals else {
            return None;
        };
        let [a, b, c] = self.corner_tangents.get(i as usize)?;
        if a[3] == 0.0 {
            return None;
        }
        let xyz = |t: &[f32; 4]| Vec3::new(t[0], t[1], t[2]);
        let tangent = xyz(a) * (1.0 - hit.u - hit.v) + xyz(b) * hit.u + xyz(c) * hit.v;
        Some((tangent, a[3].signum()))
    }

    /// The shading normal, colour and material where a ray met primitive `prim`.
    #[inline]
    pub fn surface_at(&self, prim: usize, hit: &SurfaceHit, point: Vec3) -> SurfaceSample<'_> {
        self.sample_at(prim, hit, Some(point))
    }

    /// [`Scene::surface_at`] without the normal (`normal` and
    /// `offset_normal` are zero, no normal map is read): the colour, the
    /// light emitted, occlusion and coverage, for a hit whose shading reads
    /// no normal (no light, environment or secondary ray needs it).
    #[inline]
    pub fn surface_colour_at(&self, prim: usize, hit: &SurfaceHit) -> SurfaceSample<'_> {
        self.sample_at(prim, hit, None)
    }

    /// `surface_at`, with the normal only when given the `point`.
    #[inline(always)]
    fn sample_at(&self, prim: usize, hit: &SurfaceHit, point: Option<Vec3>) -> SurfaceSample<'_> {
        let shape = &self.shapes[prim];
        let material = &self.materials[self.shape_material[prim] as usize];
        let normal = point.map_or(Vec3::ZERO, |point| shape.normal(point, hit, &self.corners));
        let mut sample = SurfaceSample {
            normal,
            color: material.color,
            material,
            emission: material.emission,
            occlusion: 1.0,
            coverage: 1.0,
            offset_normal: normal,
        };
        // Per-corner colours (PLY) on a triangle with a corner record (a
        // scene without any does not read the shape: a lean sample reads
        // none of it).
        let patch = match shape {
            _ if self.corner_colors.is_empty() => None,
            Shape::Triangle(t) => match t.normals {
                TriangleNormals::Patch(i) => Some(i),
                _ => None,
            },
            _ => None,
        };
        if let Some([a, b, c]) = patch.and_then(|i| self.corner_colors.get(i as usize)) {
            sample.color *= *a * (1.0 - hit.u - hit.v) + *b * hit.u + *c * hit.v;
        }
        let blend = material.alpha_mode == AlphaMode::Blend;
        if blend {
            sample.coverage = material.alpha;
        }
        let textured = material.texture.is_some()
            || material.emission_texture.is_some()
            || material.occlusion_texture.is_some()
            || (material.normal_map.is_some() && point.is_some())
            || (blend && material.alpha_texture.is_some());
        if !textured {
            return sample;
        }
        let Some((t, corners, uv)) = self.uv_at(prim, hit) else {
            return sample;
        };
        let texel = |tex: u32| self.textures[tex as usize].sample(uv.x, uv.y);
        if let (Some(map), true) = (&material.normal_map, point.is_some()) {
            let texture = &self.textures[map.texture as usize];
            let tangent = self.tangent_at(prim, hit);
            sample.normal =
                crate::surface_maps::mapped_normal(t, corners, uv, normal, tangent, map, texture);
        }
        if let (true, Some(tex)) = (blend, material.alpha_texture) {
            sample.coverage *= texel(tex).x;
        }
        if let Some(tex) = material.texture {
            sample.color *= texel(tex);
        }
        if let Some(tex) = material.emission_texture {
            sample.emission *= texel(tex);
        }
        if let Some(tex) = material.occlusion_texture {
            // glTF: occlusion = 1 + strength × (texel.r − 1).
            sample.occlusion = 1.0 + material.occlusion_strength * (texel(tex).x - 1.0);
        }
        sample
    }

    /// What a ray going along `dir` that hits nothing sees: the background
    /// colour, or the environment image.
    #[inline]
    pub fn background_toward(&self, dir: Vec3) -> Color {
        match &self.environment {
            None => self.background,
            Some(env) => env.radiance(dir),
        }
    }

    /// Bounds of every shape (empty for an empty scene).
    pub fn bounds(&self) -> Aabb {
        self.shapes
            .iter()
            .fold(Aabb::EMPTY, |b, s| b.union(s.bounds()))
    }

    /// `where_` locates the entity for the warning (e.g. "scene.nff:12").
    pub fn add_sphere(&mut self, center: Vec3, radius: f32, where_: &str) {
        if radius == 0.0 || !radius.is_finite() {
            self.warnings
                .push(format!("{where_}: sphere of radius 0 skipped"));
            return;
        }
        if !within_range(&[center, Vec3::splat(radius)]) {
            self.warnings.push(out_of_range("sphere", where_));
            return;
        }
        self.push(Shape::Sphere(Sphere {
            center,
            radius: radius.abs(),
            inside: radius < 0.0,
        }));
    }

    pub fn add_cone(
        &mut self,
        base: Vec3,
        base_radius: f32,
        apex: Vec3,
        apex_radius: f32,
        where_: &str,
    ) {
        if !within_range(&[base, apex, Vec3::new(base_radius, apex_radius, 0.0)]) {
            self.warnings.push(out_of_range("cone", where_));
            return;
        }
        let inside = base_radius < 0.0 || apex_radius < 0.0;
        match Cone::new(base, base_radius, apex, apex_radius, inside) {
            Some(c) => self.push(Shape::Cone(c)),
            None => self.warnings.push(format!(
                "{where_}: degenerate cone (zero height or zero radii) skipped"
            )),
        }
    }

    /// A planar polygon, convex or not, any number of vertices.
    pub fn add_polygon(&mut self, vertices: &[Vec3], where_: &str) {
        self.add_polygon_with_normals(vertices, None, where_);
    }

    /// A polygonal patch: per-vertex normals interpolated over each triangle.
    pub fn add_patch(&mut self, vertices: &[Vec3], normals: &[Vec3], where_: &str) {
        self.add_polygon_with_normals(vertices, Some(normals), where_);
    }

    fn add_polygon_with_normals(
        &mut self,
        vertices: &[Vec3],
        normals: Option<&[Vec3]>,
        where_: &str,
    ) {
        // The current material (created by `push_with` if there is none yet).
        let material = self.materials.len().saturating_sub(1) as u32;
        let group = self.new_group();
        self.add_mesh_polygon(
            &MeshPolygon {
                vertices,
                normals,
                uv: None,
                material,
                group,
            },
            &|| where_.to_string(),
        );
    }

    /// A polygon of a mesh (OBJ face, glTF triangle) with its own material and
    /// group, per-vertex normals and texture coordinates when it has them. It is
    /// cut into triangles exactly as NFF's polygons are.
    /// `where_` locates the polygon for a warning (made only when one is given).
    pub fn add_mesh_polygon(&mut self, poly: &MeshPolygon, where_: &dyn Fn() -> String) {
        self.add_colored_mesh_polygon(poly, None, where_);
    }

    /// [`Scene::add_mesh_polygon`] with a linear colour per vertex
    /// (`colors[i]` for `poly.vertices[i]`), interpolated across each
    /// triangle and multiplying the material's colour.
    pub fn add_colored_mesh_polygon(
        &mut self,
        poly: &MeshPolygon,
        colors: Option<&[Color]>,
        where_: &dyn Fn() -> String,
    ) {
        self.add_mesh_polygon_with(poly, colors, None, where_);
    }

    /// [`Scene::add_mesh_polygon`] with a normal map's tangent per vertex
    /// (`tangents[i]` for `poly.vertices[i]`: xyz in world space, w = ±1),
    /// interpolated across each triangle (see `corner_tangents`).
    pub fn add_tangent_mesh_polygon(
        &mut self,
        poly: &MeshPolygon,
        tangents: Option<&[[f32; 4]]>,
        where_: &dyn Fn() -> String,
    ) {
        self.add_mesh_polygon_with(poly, None, tangents, where_);
    }

    fn add_mesh_polygon_with(
        &mut self,
        poly: &MeshPolygon,
        colors: Option<&[Color]>,
        tangents: Option<&[[f32; 4]]>,
        where_: &dyn Fn() -> String,
    ) {
        let vertices = poly.vertices;
        if !within_range(vertices) {
            self.warnings.push(out_of_range("polygon", &where_()));
            return;
        }
        let face_normal = newell_normal(vertices);
        let Some(face_normal) = face_normal else {
            self.warnings
                .push(format!("{}: polygon of zero area skipped", where_()));
            return;
        };
        // A triangle is its own triangulation: no allocation for mesh triangles.
        // Small polygons keep ear clipping (its triangles, so the images do not
        // change); past the cap, only convex ones are taken, as a fan.
        let cut;
        let triangles: &[[usize; 3]] = if vertices.len() == 3 {
            &[[0, 1, 2]]
        } else {
            let plane = project_to_plane(vertices, face_normal);
            let large = vertices.len() > MAX_NONCONVEX_VERTICES;
            let convex = large && is_convex(&plane);
            if large && !convex {
                self.warnings.push(format!(
                    "{}: non-convex polygon of {} vertices skipped: ear clipping beyond \
                     {MAX_NONCONVEX_VERTICES} vertices could take minutes (split it into smaller polygons)",
                    where_(),
                    vertices.len()
                ));
                return;
            }
            cut = if convex {
                fan(vertices.len())
            } else {
                ear_clip(&plane)
            };
            &cut
        };
        if triangles.is_empty() {
            self.warnings.push(format!(
                "{}: polygon could not be triangulated, skipped",
                where_()
            ));
            return;
        }
        for &[a, b, c] in triangles {
            let (pa, pb, pc) = (vertices[a], vertices[b], vertices[c]);
            if (pb - pa).cross(pc - pa).length_squared() == 0.0 {
                continue; // a sliver from collinear vertices; the rest covers the area
            }
            let normals = poly.normals.map(|ns| {
                let pick = |i: usize| {
                    let n = ns[i].normalize_or_zero();
                    if n == Vec3::ZERO || !n.is_finite() {
                        face_normal
                    } else {
                        n
                    }
                };
                [pick(a), pick(b), pick(c)]
            });
            let uv = poly.uv.map(|uv| [uv[a], uv[b], uv[c]]);
            let corner_colors = colors.map(|cs| [cs[a], cs[b], cs[c]]);
            let corner_tangents = tangents.map(|ts| [ts[a], ts[b], ts[c]]);
            let tri_normals = if normals.is_none() && uv.is_none() && corner_colors.is_none() {
                TriangleNormals::Flat
            } else {
                self.corners.push(Corners { normals, uv });
                if let Some(cs) = corner_colors {
                    // Records before this one without colours: white.
                    self.corner_colors
                        .resize(self.corners.len() - 1, [Color::ONE; 3]);
                    self.corner_colors.push(cs);
                }
                if let Some(ts) = corner_tangents {
                    // Records before this one without tangents: none (w = 0).
                    self.corner_tangents
                        .resize(self.corners.len() - 1, [[0.0; 4]; 3]);
                    self.corner_tangents.push(ts);
                }
                TriangleNormals::Patch((self.corners.len() - 1) as u32)
            };
            self.push_with(
                Shape::Triangle(Triangle::new(pa, pb, pc, face_normal, tri_normals)),
                poly.material,
                poly.group,
            );
        }
    }

    /// Gives colourless lights the SPD intensity 1/sqrt(number of lights).
    pub fn finish(&mut self) {
        let n = self.lights.len().max(1) as f32;
        let default = Color::splat(1.0 / n.sqrt());
        for l in &mut self.lights {
            if l.color.is_none() {
                l.color = Some(default);
            }
        }
    }

    /// Adds a white point light at the camera (a headlight) for a scene that
    /// has none, so that a model without lights is seen; returns whether it did.
    pub fn add_headlight_if_dark(&mut self) -> bool {
        if !self.lights.is_empty() {
            return false;
        }
        self.lights
            .push(Light::point(self.viewpoint.from, Some(Color::ONE)));
        true
    }

    /// Points the camera at the whole scene: from the front (+z, y up), raised
    /// and turned a little so that a flat model is not seen edge-on, at a
    /// distance that fits the bounding sphere in a 45° field of view.
    pub fn frame_bounds(&mut self) {
        let b = self.bounds();
        let (center, radius) = if b.min.x <= b.max.x {
            ((b.min + b.max) * 0.5, ((b.max - b.min) * 0.5).length())
        } else {
            (Vec3::ZERO, 1.0)
        };
        let radius = if radius > 0.0 && radius.is_finite() {
            radius
        } else {
            1.0
        };
        let fov_deg: f32 = 45.0;
        let distance = radius / (fov_deg.to_radians() * 0.5).sin() * 1.05;
        self.viewpoint = Viewpoint {
            from: center + Vec3::new(0.35, 0.5, 1.0).normalize() * distance,
            at: center,
            up: Vec3::Y,
            angle_deg: fov_deg,
            angle_span: AngleSpan::ImageHeight,
            hither: distance * 1e-4,
            width: self.viewpoint.width,
            height: self.viewpoint.height,
        };
        self.viewpoint_given = false;
    }
}

/// Largest coordinate or radius a shape may have: intersection tests square
/// distances in single precision, which overflows past about 1.8e19 (a sphere
/// of radius 2e19 vanished).
pub const MAX_COORDINATE: f32 = 1e18;

/// Largest light a file may give: a light's colour, a material's emission
/// (what their products and sums stay far from overflowing `f32` with).
pub const MAX_RADIANCE: f32 = 1e6;

fn within_range(points: &[Vec3]) -> bool {
    points
        .iter()
        .all(|p| p.abs().max_element() <= MAX_COORDINATE)
}

fn out_of_range(what: &str, where_: &str) -> String {
    format!("{where_}: {what} skipped: a coordinate or radius beyond {MAX_COORDINATE:e}")
}

/// Unit normal of a polygon by Newell's method (robust for non-convex and
/// nearly collinear vertices); `None` for zero area.
fn newell_normal(v: &[Vec3]) -> Option<Vec3> {
    if v.len() < 3 {
        return None;
    }
    let mut n = Vec3::ZERO;
    for i in 0..v.len() {
        let (a, b) = (v[i], v[(i + 1) % v.len()]);
        n += Vec3::new(
            (a.y - b.y) * (a.z + b.z),
            (a.z - b.z) * (a.x + b.x),
            (a.x - b.x) * (a.y + b.y),
        );
    }
    let len = n.length();
    (len > 0.0 && len.is_finite()).then(|| n / len)
}

/// Most vertices of a non-convex polygon: ear clipping grows faster than
/// the square of the count on adversarial shapes (a comb of 40,000 vertices
/// took 1.8 s, 400,000 took 389 s; docs/reliability.md). Larger convex
/// polygons are cut as a fan, in linear time.
pub const MAX_NONCONVEX_VERTICES: usize = 50_000;

/// The polygon in the plane of its dominant normal axis, in double precision.
fn project_to_plane(v: &[Vec3], normal: Vec3) -> Vec<[f64; 2]> {
    let a = normal.abs();
    let (i, j) = if a.x >= a.y && a.x >= a.z {
        (1, 2)
    } else if a.y >= a.z {
        (2, 0)
    } else {
        (0, 1)
    };
    v.iter().map(|p| [p[i] as f64, p[j] as f64]).collect()
}

/// Every turn goes the same way and the boundary winds around once (a star
/// turns one way too, but winds more than once). A dent smaller than the
/// rounding of single-precision coordinates (1e-6 of the polygon's extent)
/// counts as straight: a 200,000-vertex circle read from a file has such dents.
fn is_convex(p: &[[f64; 2]]) -> bool {
    let n = p.len();
    let extent = p
        .iter()
        .fold(0.0f64, |m, q| m.max(q[0].abs()).max(q[1].abs()));
    let tolerance = 1e-6 * extent;
    let (mut sign, mut winding) = (0.0f64, 0.0f64);
    for k in 0..n {
        let (a, b, c) = (p[k], p[(k + 1) % n], p[(k + 2) % n]);
        let (e, f) = ([b[0] - a[0], b[1] - a[1]], [c[0] - b[0], c[1] - b[1]]);
        let cross = e[0] * f[1] - e[1] * f[0];
        // Distance of `b` from the line through `a` and `c`.
        let chord = ((c[0] - a[0]).powi(2) + (c[1] - a[1]).powi(2)).sqrt();
        let dent = if chord > 0.0 {
            cross.abs() / chord
        } else {
            0.0
        };
        if dent > tolerance {
            if sign * cross < 0.0 {
                return false;
            }
            sign = cross;
        }
        winding += cross.atan2(e[0] * f[0] + e[1] * f[1]);
    }
    (winding.abs() - std::f64::consts::TAU).abs() < 1e-6
}

/// A triangle fan from vertex 0 (for convex polygons).
fn fan(n: usize) -> Vec<[usize; 3]> {
    (1..n - 1).map(|k| [0, k, k + 1]).collect()
}

/// Ear clipping (the `earcut` crate) for non-convex polygons.
fn ear_clip(flat: &[[f64; 2]]) -> Vec<[usize; 3]> {
    if flat.len() == 3 {
        return vec![[0, 1, 2]];
    }
    let mut earcut = earcut::Earcut::new();
    let mut out: Vec<u32> = Vec::new();
    earcut.earcut(flat.iter().copied(), &[], &mut out);
    out.chunks_exact(3)
        .map(|t| [t[0] as usize, t[1] as usize, t[2] as usize])
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn square_becomes_two_triangles_with_face_normal() {
        let mut s = Scene::new();
        let sq = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        s.add_polygon(&sq, "t:1");
        assert_eq!(s.shapes.len(), 2);
        for sh in &s.shapes {
            let Shape::Triangle(t) = sh else { panic!() };
            assert_eq!(t.face_normal, Vec3::Z);
        }
    }

    #[test]
    fn non_convex_polygon_area_is_preserved() {
        // An L shape of area 3.
        let l = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(2.0, 1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(1.0, 2.0, 0.0),
            Vec3::new(0.0, 2.0, 0.0),
        ];
        let mut s = Scene::new();
        s.add_polygon(&l, "t:1");
        let area: f32 = s
            .shapes
            .iter()
            .map(|sh| match sh {
                Shape::Triangle(t) => t.e1.cross(t.e2).length() / 2.0,
                _ => 0.0,
            })
            .sum();
        assert!((area - 3.0).abs() < 1e-5, "area {area}");
    }

    #[test]
    fn degenerate_geometry_warns() {
        let mut s = Scene::new();
        s.add_polygon(&[Vec3::ZERO, Vec3::X, Vec3::X * 2.0], "f.nff:3");
        s.add_sphere(Vec3::ZERO, 0.0, "f.nff:4");
        s.add_cone(Vec3::ZERO, 1.0, Vec3::ZERO, 1.0, "f.nff:5");
        assert!(s.shapes.is_empty());
        assert_eq!(s.warnings.len(), 3);
        assert!(s.warnings[0].starts_with("f.nff:3"));
    }

    #[test]
    fn spd_light_intensity() {
        let mut s = Scene::new();
        for _ in 0..4 {
            s.lights.push(Light::point(Vec3::ZERO, None));
        }
        s.finish();
        assert_eq!(s.lights[0].color, Some(Color::splat(0.5)));
    }

    #[test]
    fn convex_polygons_are_fans_and_huge_non_convex_ones_skipped() {
        let circle = |n: usize| -> Vec<Vec3> {
            (0..n)
                .map(|k| {
                    let a = std::f32::consts::TAU * k as f32 / n as f32;
                    Vec3::new(a.cos(), a.sin(), 0.0)
                })
                .collect()
        };
        let plane = project_to_plane(&circle(100), Vec3::Z);
        assert!(is_convex(&plane));
        let star: Vec<Vec3> = (0..5)
            .map(|k| {
                let a = std::f32::consts::TAU * (2 * k) as f32 / 5.0;
                Vec3::new(a.cos(), a.sin(), 0.0)
            })
            .collect();
        assert!(!is_convex(&project_to_plane(&star, Vec3::Z)));
        let l_shape = [
            [0.0, 0.0],
            [2.0, 0.0],
            [2.0, 1.0],
            [1.0, 1.0],
            [1.0, 2.0],
            [0.0, 2.0],
        ];
        assert!(!is_convex(&l_shape));
        // A convex polygon of 200,000 vertices: a fan, at once.
        let mut s = Scene::new();
        s.add_polygon(&circle(200_000), "f.nff:2");
        assert!(s.shapes.len() > 199_900, "{}", s.shapes.len()); // less zero-area slivers
                                                                 // The attack's comb (non-convex) beyond the cap: skipped with a warning.
        let teeth = MAX_NONCONVEX_VERTICES / 4 + 1;
        let mut comb = Vec::new();
        for t in 0..teeth {
            let x = t as f32;
            comb.extend([
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x, 1.0, 0.0),
                Vec3::new(x + 0.5, 1.0, 0.0),
                Vec3::new(x + 0.5, 0.1, 0.0),
            ]);
        }
        comb.extend([
            Vec3::new(teeth as f32, 0.0, 0.0),
            Vec3::new(teeth as f32, -1.0, 0.0),
            Vec3::new(0.0, -1.0, 0.0),
        ]);
        let mut s = Scene::new();
        s.add_polygon(&comb, "f.nff:3");
        assert!(s.shapes.is_empty());
        assert!(
            s.warnings[0].contains("non-convex polygon of 50007 vertices skipped"),
            "{:?}",
            s.warnings
        );
    }

    #[test]
    fn huge_shapes_are_skipped_with_a_warning() {
        // The attack: a sphere of radius 2e19 silently vanished (its squared
        // radius overflows).
        let mut s = Scene::new();
        s.add_sphere(Vec3::ZERO, 2e19, "f.nff:2");
        s.add_sphere(Vec3::ZERO, 1e18, "f.nff:3");
        s.add_polygon(&[Vec3::ZERO, Vec3::X * 1e19, Vec3::Y], "f.nff:4");
        assert_eq!(s.shapes.len(), 1);
        assert_eq!(s.warnings.len(), 2, "{:?}", s.warnings);
        assert!(s.warnings[0].starts_with("f.nff:2: sphere skipped"));
    }

    #[test]
    fn materials_are_clamped_with_what_changed() {
        // The attack: Shine -1e20 gave infinite pixels, Kd -1 an ambient of 2.
        let (m, changed) = Material {
            kd: -1.0,
            shine: -1e20,
            ..Material::default()
        }
        .clamped();
        assert_eq!((m.kd, m.shine), (0.0, 0.0));
        assert_eq!(changed.len(), 2, "{changed:?}");
        assert!(changed[0].contains("Kd -1 clamped to 0"), "{changed:?}");
        assert!(m.ambient() <= 1.0);
        let (same, none) = Material::default().clamped();
        assert_eq!((same, none.len()), (Material::default(), 0));
    }

    #[test]
    fn ambient_convention() {
        let m = Material {
            kd: 0.8,
            ..Material::default()
        };
        assert!((m.ambient() - 0.2).abs() < 1e-6);
        let glass = Material {
            kd: 0.1,
            ks: 0.1,
            t: 0.9,
            ..Material::default()
        };
        assert_eq!(glass.ambient(), 0.0);
    }
}

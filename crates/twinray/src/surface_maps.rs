//! What a material's maps do at a hit, beyond colour: its alpha (cut-outs
//! and partial transparency) and its normal or height map (the shading
//! normal bent by a texture). The model is in docs/shading.md.
//!
//! Alpha is a property of a hit, not of a primitive, so cut-outs are not a
//! traversal's business: the tracer continues a ray past a cut-away hit
//! (`render::tracer`), and shadow rays ask [`Scene::shadow_factor`] what a
//! primitive lets through where they meet it.

use crate::math::Vec3;
use crate::scene::Scene;
use crate::shapes::{Shape, SurfaceHit, Triangle, TriangleNormals, Uv};
use crate::texture::Texture;

/// How a material's alpha (its `alpha` times its alpha texture) is used.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum AlphaMode {
    /// Ignored: the surface is opaque (glTF `OPAQUE`, OBJ without `d` < 1 or `map_d`).
    #[default]
    Opaque,
    /// A cut-out: where alpha < `cutoff` the surface is not there at all, for
    /// eye, reflected, refracted and shadow rays alike; elsewhere it is opaque
    /// (glTF `MASK` with `alphaCutoff`; OBJ `map_d` at 0.5).
    Mask { cutoff: f32 },
    /// Partial transparency: alpha of the surface's own colour, and 1 − alpha
    /// of what lies straight behind it (no refraction); shadow rays keep
    /// 1 − alpha (glTF `BLEND`; OBJ `d` < 1).
    Blend,
}

/// A texture that bends the shading normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NormalMap {
    /// Index into `Scene::textures` (decoded as data, not sRGB).
    pub texture: u32,
    /// glTF `normalTexture.scale` (scales the map's x and y), OBJ `-bm`.
    pub scale: f32,
    pub kind: NormalMapKind,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NormalMapKind {
    /// Tangent-space normals, OpenGL convention (green = up the image), as
    /// glTF and Blender write them.
    Tangent,
    /// A height map (its red channel): the surface raised by `scale` ×
    /// height × [`HEIGHT_UNIT`] of the texture's width, its normal bent to match.
    Height,
}

/// A height map's full range (0 to 1) lifts the surface by this fraction of
/// the texture's width in the scene (times `-bm`).
pub const HEIGHT_UNIT: f32 = 0.01;

impl Scene {
    /// Whether any material's alpha matters (MASK or BLEND): only such scenes
    /// pay for continuing rays past cut-outs and for alpha in shadow rays.
    pub fn has_alpha(&self) -> bool {
        self.materials
            .iter()
            .any(|m| m.alpha_mode != AlphaMode::Opaque)
    }

    /// The triangle hit, its corners' texture coordinates and the hit's.
    #[inline]
    pub(crate) fn uv_at(&self, prim: usize, hit: &SurfaceHit) -> Option<(&Triangle, [Uv; 3], Uv)> {
        let Shape::Triangle(t) = &self.shapes[prim] else {
            return None;
        };
        let TriangleNormals::Patch(i) = t.normals else {
            return None;
        };
        let [a, b, c] = self.corners[i as usize].uv?;
        Some((
            t,
            [a, b, c],
            a * (1.0 - hit.u - hit.v) + b * hit.u + c * hit.v,
        ))
    }

    /// The material's alpha at a hit: its `alpha` times its alpha texture
    /// there (where the primitive has texture coordinates).
    pub fn alpha_at(&self, prim: usize, hit: &SurfaceHit) -> f32 {
        let m = &self.materials[self.shape_material[prim] as usize];
        match (m.alpha_texture, self.uv_at(prim, hit)) {
            (Some(tex), Some((_, _, uv))) => {
                m.alpha * self.textures[tex as usize].sample(uv.x, uv.y).x
            }
            _ => m.alpha,
        }
    }

    /// Whether a hit lands on a cut-away part of a MASK material: a ray goes
    /// on as if the primitive were not there.
    #[inline]
    pub fn cut_away(&self, prim: usize, hit: &SurfaceHit) -> bool {
        let m = &self.materials[self.shape_material[prim] as usize];
        match m.alpha_mode {
            AlphaMode::Mask { cutoff } => self.alpha_at(prim, hit) < cutoff,
            _ => false,
        }
    }

    /// What of a light a shadow ray keeps where it meets `prim` at `hit`:
    /// `None` where the hit is cut away (the primitive is not there), else the
    /// material's `T`, and for BLEND the uncovered share besides:
    /// (1 − alpha) + alpha × T.
    #[inline]
    pub fn shadow_factor(&self, prim: usize, hit: &SurfaceHit) -> Option<f32> {
        let m = &self.materials[self.shape_material[prim] as usize];
        match m.alpha_mode {
            AlphaMode::Opaque => Some(m.t),
            AlphaMode::Mask { cutoff } => (self.alpha_at(prim, hit) >= cutoff).then_some(m.t),
            AlphaMode::Blend => {
                let a = self.alpha_at(prim, hit).clamp(0.0, 1.0);
                Some((1.0 - a) + a * m.t)
            }
        }
    }
}

/// The shading normal `normal` (unit) bent by `map` at `uv` on triangle `t`
/// whose corners have texture coordinates `corners`. The tangent frame is the
/// file's where it gave tangents (`given_tangent`: the tangent and the
/// bitangent's sign, glTF `TANGENT`), else the triangle's own, from its
/// edges and texture coordinates (tangent along +u, bitangent up the image,
/// i.e. along −v since v runs down the rows). Unchanged where the frame is
/// degenerate (all corners at one u or v) and the file gave no tangent.
pub(crate) fn mapped_normal(
    t: &Triangle,
    corners: [Uv; 3],
    uv: Uv,
    normal: Vec3,
    given_tangent: Option<(Vec3, f32)>,
    map: &NormalMap,
    texture: &Texture,
) -> Vec3 {
    let [a, b, c] = corners;
    let (d1, d2) = (b - a, c - a);
    let r = d1.x * d2.y - d2.x * d1.y;
    // p(u, v) is linear over the triangle: e1 = dpdu·d1.u + dpdv·d1.v, and
    // the same for e2; no such frame where the uv is degenerate.
    let uv_frame = (r != 0.0 && r.is_finite()).then(|| {
        (
            (t.e1 * d2.y - t.e2 * d1.y) / r,
            (t.e2 * d1.x - t.e1 * d2.x) / r,
        )
    });
    let bent = match map.kind {
        NormalMapKind::Tangent => {
            let (tangent, bitangent) = match (given_tangent, uv_frame) {
                // glTF's rule: bitangent = normal × tangent × w.
                (Some((t, w)), _) => {
                    let tangent = (t - normal * normal.dot(t)).normalize_or_zero();
                    (tangent, normal.cross(tangent) * w)
                }
                (None, None) => return normal,
                // The triangle's own frame: u to the right, v down the image
                // (glTF's and OBJ's texture convention), so up is −v.
                (None, Some((dpdu, dpdv))) => {
                    let tangent = (dpdu - normal * normal.dot(dpdu)).normalize_or_zero();
                    let up = -dpdv;
                    let bitangent = (up - normal * normal.dot(up) - tangent * tangent.dot(up))
                        .normalize_or_zero();
                    (tangent, bitangent)
                }
            };
            if tangent == Vec3::ZERO || bitangent == Vec3::ZERO {
                return normal;
            }
            let m = texture.sample(uv.x, uv.y) * 2.0 - 1.0;
            tangent * (m.x * map.scale) + bitangent * (m.y * map.scale) + normal * m.z
        }
        NormalMapKind::Height => {
            let Some((dpdu, dpdv)) = uv_frame else {
                return normal;
            };
            let (du, dv) = (1.0 / texture.width as f32, 1.0 / texture.height as f32);
            let h = |u: f32, v: f32| texture.sample(u, v).x;
            let hu = (h(uv.x + du, uv.y) - h(uv.x - du, uv.y)) / (2.0 * du);
            let hv = (h(uv.x, uv.y + dv) - h(uv.x, uv.y - dv)) / (2.0 * dv);
            // The surface p + normal × lift × h: its partial derivatives'
            // cross product, on the side of `normal` (whatever the uv handedness).
            let lift = map.scale * HEIGHT_UNIT * dpdu.length();
            let n = (dpdu + normal * (lift * hu)).cross(dpdv + normal * (lift * hv));
            if n.dot(normal) < 0.0 {
                -n
            } else {
                n
            }
        }
    };
    let bent = bent.normalize_or_zero();
    if bent == Vec3::ZERO || !bent.is_finite() {
        normal
    } else {
        bent
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Color;
    use crate::texture::Wrap;

    /// A one-texel tangent-space map that tilts the normal toward +tangent.
    fn tilting_map() -> (NormalMap, Texture) {
        let map = NormalMap {
            texture: 0,
            scale: 1.0,
            kind: NormalMapKind::Tangent,
        };
        // (0.8, 0.5, 0.8) decodes to (0.6, 0, 0.6): tangent and normal equally.
        let texture = Texture {
            width: 1,
            height: 1,
            texels: vec![Color::new(0.8, 0.5, 0.8)],
            wrap_s: Wrap::Repeat,
            wrap_t: Wrap::Repeat,
        };
        (map, texture)
    }

    /// A file's tangent frames the map even where the texture coordinates
    /// give none (every corner at one uv); without it the normal is kept.
    #[test]
    fn a_given_tangent_bends_the_normal_on_degenerate_texture_coordinates() {
        let (map, texture) = tilting_map();
        let z = Vec3::Z;
        let t = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y, z, TriangleNormals::Flat);
        let same = [Uv::new(0.5, 0.5); 3];
        let uv = Uv::new(0.5, 0.5);
        let bent = mapped_normal(&t, same, uv, z, Some((Vec3::Y, 1.0)), &map, &texture);
        let expect = Vec3::new(0.0, 1.0, 1.0).normalize();
        assert!((bent - expect).length() < 1e-3, "{bent}");
        let kept = mapped_normal(&t, same, uv, z, None, &map, &texture);
        assert_eq!(kept, z);
        // A proper uv frame without a tangent: +u is +x.
        let corners = [Uv::new(0.0, 1.0), Uv::new(1.0, 1.0), Uv::new(0.0, 0.0)];
        let own = mapped_normal(&t, corners, uv, z, None, &map, &texture);
        let expect = Vec3::new(1.0, 0.0, 1.0).normalize();
        assert!((own - expect).length() < 1e-3, "{own}");
    }
}

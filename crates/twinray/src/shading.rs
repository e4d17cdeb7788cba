//! Whitted's local illumination, shared by every rendering method: ambient,
//! Lambert diffuse and Phong highlight for each point light not in shadow.
//!
//! The model (see docs/shading.md):
//!   I = ambient·C + Σ_lights S_l · I_l · (Kd·C·max(0, N·L) + Ks·max(0, R·V)^Shine)
//!       + Ks·I_reflected + T·I_transmitted
//! with `ambient = max(0, 1 − Kd − Ks − T)`, `N` the shading normal turned to
//! face the incoming ray, and `S_l` the light's transmittance: 0 behind an
//! opaque object, the product of `T` over the transmitting objects in between.
//! No shadow ray is cast where the normal faces away from the light.

use crate::bvh::{AnyHit, TraversalStats};
use crate::math::{Color, Ray, Vec3};
use crate::scene::Material;
use crate::world::World;

/// Distance a secondary ray's origin is moved off the surface, relative to the
/// magnitude of the coordinates involved (rounding of the hit point grows with it).
const OFFSET_RELATIVE: f32 = 2e-5;

/// `p` moved off the surface along `n` (unit) by a margin that covers the
/// rounding of a hit point computed at distance `t`.
#[inline]
pub fn offset_point(p: Vec3, n: Vec3, t: f32) -> Vec3 {
    let scale = p.abs().max_element() + t.abs();
    p + n * (OFFSET_RELATIVE * scale.max(1e-3))
}

/// What the tracer knows of a hit when it shades it.
pub struct SurfacePoint<'a> {
    pub point: Vec3,
    /// Unit shading normal turned to face the incoming ray.
    pub normal: Vec3,
    /// Distance along the incoming ray (for the offset margin).
    pub t: f32,
    pub material: &'a Material,
}

/// Fraction of a light's energy that reaches `origin` along `dir` over `dist`.
pub fn transmittance(world: &World, origin: Vec3, dir: Vec3, dist: f32, stats: &mut TraversalStats) -> f32 {
    let ray = Ray::new(origin, dir);
    let mut through = 1.0f32;
    let shapes = &world.scene.shapes;
    let mats = &world.scene.shape_material;
    let materials = &world.scene.materials;
    world.bvh.any_hit(origin, dir, 0.0, dist, stats, |prim| {
        if shapes[prim as usize].intersect(&ray, 0.0, dist).is_none() {
            return AnyHit::Continue;
        }
        let t = materials[mats[prim as usize] as usize].t;
        through *= t;
        if through <= 0.0 {
            AnyHit::Stop
        } else {
            AnyHit::Continue
        }
    });
    through.max(0.0)
}

/// Ambient plus every light's diffuse and highlight at `sp`, seen along `view_dir`.
/// Returns the colour and the number of shadow rays cast.
pub fn direct_light(world: &World, sp: &SurfacePoint, view_dir: Vec3, stats: &mut TraversalStats) -> (Color, u64) {
    let m = sp.material;
    let mut color = m.color * m.ambient();
    let mut shadow_rays = 0;
    if m.kd <= 0.0 && m.ks <= 0.0 {
        return (color, 0);
    }
    let origin = offset_point(sp.point, sp.normal, sp.t);
    for (i, light) in world.scene.lights.iter().enumerate() {
        let to_light = light.position - sp.point;
        let dist = to_light.length();
        if dist <= 0.0 {
            continue;
        }
        let l = to_light / dist;
        let n_dot_l = sp.normal.dot(l);
        if n_dot_l <= 0.0 {
            continue;
        }
        shadow_rays += 1;
        let s = transmittance(world, origin, l, dist, stats);
        if s <= 0.0 {
            continue;
        }
        let mut c = m.color * (m.kd * n_dot_l);
        if m.ks > 0.0 {
            let r = crate::math::reflect(-l, sp.normal);
            let r_dot_v = r.dot(-view_dir);
            if r_dot_v > 0.0 {
                c += Color::splat(m.ks * r_dot_v.powf(m.shine));
            }
        }
        color += c * world.scene.light_color(i) * s;
    }
    (color, shadow_rays)
}

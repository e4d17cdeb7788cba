//! Light sources: NFF's point light, and glTF's (`KHR_lights_punctual`) point,
//! spot and directional lights.
//!
//! The tracer asks a light one thing: from a surface point, in which direction,
//! how far, and with what colour does it arrive ([`Light::toward`]). NFF lights
//! keep the same intensity at any distance (the SPD convention); glTF point and
//! spot lights fall off with the inverse square of the distance, as the glTF
//! specification says, windowed by their `range`.

use crate::environment::Environment;
use crate::math::{Color, Vec3};

#[derive(Clone, Debug, PartialEq)]
pub enum LightKind {
    /// A point light. `inverse_square`: glTF's falloff; NFF's lights have none.
    Point {
        position: Vec3,
        inverse_square: bool,
        range: Option<f32>,
    },
    /// A glTF spot light: a point light limited to a cone around `direction`
    /// (unit, the way the light shines), full inside `cos_inner`, dark outside
    /// `cos_outer`, smooth in between.
    Spot {
        position: Vec3,
        direction: Vec3,
        cos_inner: f32,
        cos_outer: f32,
        range: Option<f32>,
    },
    /// Parallel light shining along `direction` (unit), from infinitely far.
    Directional { direction: Vec3 },
}

#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    pub kind: LightKind,
    /// `None` when the file gave no colour: intensity then follows the SPD
    /// convention, 1/sqrt(number of lights), fixed by `Scene::finish`.
    pub color: Option<Color>,
}

/// How far a directional light's shadow rays go.
const FAR: f32 = f32::MAX;

impl Light {
    /// NFF's point light: no falloff.
    pub fn point(position: Vec3, color: Option<Color>) -> Light {
        Light {
            kind: LightKind::Point {
                position,
                inverse_square: false,
                range: None,
            },
            color,
        }
    }

    /// The position of a light that has one (not directional lights).
    pub fn position(&self) -> Option<Vec3> {
        match self.kind {
            LightKind::Point { position, .. } | LightKind::Spot { position, .. } => Some(position),
            LightKind::Directional { .. } => None,
        }
    }

    /// From `point`: the unit direction to the light, the distance a shadow ray
    /// must cover, and the colour arriving; `None` when no light arrives (the
    /// point is the light's position, outside its cone or beyond its range).
    /// Inlined, with `shading::toward_light`, into `Tracer::direct_light`:
    /// returned through memory, the answer's reload stalled on the stores
    /// that wrote it (docs/benchmarks.md, "Issue 17, seventh pass").
    #[inline(always)]
    pub fn toward(&self, point: Vec3) -> Option<(Vec3, f32, Color)> {
        let color = self.color.unwrap_or(Color::ONE);
        match self.kind {
            LightKind::Point {
                position,
                inverse_square,
                range,
            } => {
                let (dir, dist) = direction_to(position, point)?;
                if !inverse_square {
                    return Some((dir, dist, color));
                }
                Some((dir, dist, color * falloff(dist, range)?))
            }
            LightKind::Spot {
                position,
                direction,
                cos_inner,
                cos_outer,
                range,
            } => {
                let (dir, dist) = direction_to(position, point)?;
                // glTF's reference: a smooth step in cos(angle), squared.
                let cos_angle = direction.dot(-dir);
                let scale = 1.0 / (cos_inner - cos_outer).max(1e-3);
                let cone = ((cos_angle - cos_outer) * scale).clamp(0.0, 1.0);
                if cone <= 0.0 {
                    return None;
                }
                Some((dir, dist, color * (cone * cone * falloff(dist, range)?)))
            }
            LightKind::Directional { direction } => Some((-direction, FAR, color)),
        }
    }
}

#[inline(always)]
fn direction_to(position: Vec3, point: Vec3) -> Option<(Vec3, f32)> {
    let to_light = position - point;
    let dist = to_light.length();
    if dist <= 0.0 {
        return None;
    }
    Some((to_light / dist, dist))
}

/// glTF's recommended attenuation: inverse square, faded to zero at `range`.
fn falloff(dist: f32, range: Option<f32>) -> Option<f32> {
    let window = match range {
        Some(r) if r > 0.0 => (1.0 - (dist / r).powi(4)).clamp(0.0, 1.0),
        _ => 1.0,
    };
    let f = window / (dist * dist);
    (f > 0.0 && f.is_finite()).then_some(f)
}

/// The lights twinray adds to a model file without any: a key light above
/// and to the left of the camera, a dimmer fill from the right and a rim
/// light from behind and above, all directional and white, placed in the
/// frame of the viewpoint looking from `from` to `at` with `up`, so that
/// shapes read (the sides differ) and shadows fall beside the model rather
/// than behind it, as a headlight's do.
pub fn three_point_rig(from: Vec3, at: Vec3, up: Vec3) -> Vec<Light> {
    let back = (from - at).normalize_or(Vec3::Z);
    let right = up.cross(back).normalize_or(back.any_orthonormal_vector());
    let up = back.cross(right);
    // (toward the light in the camera's frame: right, up, back), brightness.
    let rig = [
        ((-0.55, 0.65, 0.55), 0.8),
        ((0.75, 0.1, 0.65), 0.35),
        ((0.25, 0.6, -0.75), 0.5),
    ];
    rig.iter()
        .map(|&((r, u, b), brightness)| {
            let toward = (right * r + up * u + back * b).normalize();
            Light {
                kind: LightKind::Directional { direction: -toward },
                color: Some(Color::splat(brightness)),
            }
        })
        .collect()
}

/// Radiance of the studio around a model file without lights, linear: above
/// (the zenith), at the horizon and below (the nadir).
pub const STUDIO_ZENITH: f32 = 0.5;
pub const STUDIO_HORIZON: f32 = 0.3;
pub const STUDIO_NADIR: f32 = 0.12;

/// The surroundings twinray adds to a model file without lights, beside
/// [`three_point_rig`]: a soft grey studio, brighter above than below, as an
/// environment. Surfaces take it as ambient light, so that a dark material's
/// shape still reads where the rig leaves it in shadow; eye rays that miss
/// see it as the background, a mid grey that a black object stands out
/// against (and a white one too), and mirrors reflect it. Grey, so that it
/// tints nothing; `z_up` turns it for a z-up model.
pub fn studio_environment(z_up: bool) -> Environment {
    // Only the vertical gradient matters: a narrow image holds it exactly
    // enough for the nine spherical harmonics and for the background.
    let (width, height) = (8u32, 64u32);
    let texels = (0..height)
        .flat_map(|row| {
            let elevation = std::f32::consts::FRAC_PI_2
                - std::f32::consts::PI * (row as f32 + 0.5) / height as f32;
            let s = elevation.sin();
            let radiance = if s >= 0.0 {
                STUDIO_HORIZON + (STUDIO_ZENITH - STUDIO_HORIZON) * s
            } else {
                STUDIO_HORIZON + (STUDIO_NADIR - STUDIO_HORIZON) * -s
            };
            std::iter::repeat_n(Color::splat(radiance), width as usize)
        })
        .collect();
    Environment::from_texels(width, height, texels, z_up)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nff_point_light_has_no_falloff() {
        let l = Light::point(Vec3::new(0.0, 10.0, 0.0), Some(Color::splat(0.5)));
        let (dir, dist, c) = l.toward(Vec3::ZERO).unwrap();
        assert_eq!(dir, Vec3::Y);
        assert_eq!(dist, 10.0);
        assert_eq!(c, Color::splat(0.5));
        assert!(l.toward(Vec3::new(0.0, 10.0, 0.0)).is_none());
    }

    #[test]
    fn gltf_point_light_falls_off_with_the_square_and_its_range() {
        let mut l = Light::point(Vec3::new(0.0, 2.0, 0.0), Some(Color::ONE));
        l.kind = LightKind::Point {
            position: Vec3::new(0.0, 2.0, 0.0),
            inverse_square: true,
            range: None,
        };
        let (_, _, c) = l.toward(Vec3::ZERO).unwrap();
        assert!((c.x - 0.25).abs() < 1e-6, "{c}");
        l.kind = LightKind::Point {
            position: Vec3::new(0.0, 2.0, 0.0),
            inverse_square: true,
            range: Some(1.5),
        };
        assert!(l.toward(Vec3::ZERO).is_none(), "beyond its range");
    }

    #[test]
    fn spot_light_cone() {
        let l = Light {
            kind: LightKind::Spot {
                position: Vec3::new(0.0, 1.0, 0.0),
                direction: -Vec3::Y,
                cos_inner: 0.9,
                cos_outer: 0.8,
                range: None,
            },
            color: Some(Color::ONE),
        };
        let (_, _, c) = l.toward(Vec3::ZERO).unwrap();
        assert!((c.x - 1.0).abs() < 1e-6, "inside the inner cone: {c}");
        assert!(l.toward(Vec3::new(5.0, 0.0, 0.0)).is_none(), "outside");
        let (_, _, c) = l.toward(Vec3::new(0.7, 0.0, 0.0)).unwrap();
        assert!(c.x > 0.0 && c.x < 1.0 / 1.49, "in the penumbra: {c}");
    }

    #[test]
    fn directional_light_arrives_from_against_its_direction() {
        let l = Light {
            kind: LightKind::Directional {
                direction: -Vec3::Z,
            },
            color: Some(Color::ONE),
        };
        let (dir, dist, _) = l.toward(Vec3::new(3.0, 4.0, 5.0)).unwrap();
        assert_eq!(dir, Vec3::Z);
        assert!(dist > 1e30);
    }

    #[test]
    fn the_studio_is_grey_brighter_above_and_turns_with_the_up_axis() {
        for (z_up, up) in [(false, Vec3::Y), (true, Vec3::Z)] {
            let env = studio_environment(z_up);
            let (above, below) = (env.radiance(up), env.radiance(-up));
            let side = env.radiance(up.any_orthonormal_vector());
            assert!(
                above.x > side.x && side.x > below.x,
                "{above} {side} {below}"
            );
            assert!((above.x - STUDIO_ZENITH).abs() < 0.02, "{above}");
            assert!((side.x - STUDIO_HORIZON).abs() < 0.03, "{side}");
            assert!(above.x == above.y && above.y == above.z, "grey: {above}");
            // Light from above reaches a surface facing up more than one
            // facing down: shapes keep their top and bottom.
            assert!(env.diffuse(up).x > env.diffuse(-up).x);
        }
    }
}

//! What the job adds around a model: point lights (`--light`), a
//! shadow-catching floor (`--ground`), and for a model file without lights
//! (and without `--light`, `--env` or `--background`) a grey studio around it.
//!
//! The floor is added by [`Job::prepare`](super::Job::prepare) after the
//! viewpoint and the light rig are chosen from the model alone, and it is
//! appended after the model's shapes, so that auto-framing
//! ([`Job::plan`](super::Job::plan)) fits only the shapes before it: the
//! model, not the floor, fills the frame.

use crate::error::{Error, Result};
use crate::math::{Aabb, Color, Vec3};
use crate::scene::{Light, Material, MeshPolygon, Scene};

use super::spec::LightSpec;
use crate::environment::Environment;
use crate::rig::up_axis::UpAxis;

/// What `-v` says of [`surroundings`].
pub(super) const SURROUNDINGS: &str =
    "a grey studio around it for ambient light and background (--light, --background or --env replace it)";

/// The studio around a model file without lights
/// ([`crate::lights::studio_environment`]), turned for its up axis.
pub(super) fn surroundings(up: UpAxis) -> std::sync::Arc<Environment> {
    std::sync::Arc::new(crate::lights::studio_environment(up == UpAxis::Z))
}

/// Grey of the floor (linear): light enough for shadows to read, neutral so
/// that it does not tint the model's reflections.
const GROUND_GREY: f32 = 0.5;
/// Half the floor's side, in extents of the model (its largest side).
const GROUND_HALF_SIDE: f32 = 5.0;
/// Gap below the model, in extents, so that a base lying on the floor does
/// not fight it for the same depth.
const GROUND_GAP: f32 = 1e-3;

/// Refuses lights that are not finite or have a negative colour.
pub(super) fn check_lights(lights: &[LightSpec]) -> Result<()> {
    for l in lights {
        if !l.position.iter().all(|v| v.is_finite()) {
            return Err(Error::Invalid(format!(
                "--light takes a finite position X,Y,Z, got {:?}",
                l.position
            )));
        }
        if !l.color.iter().all(|v| v.is_finite() && *v >= 0.0) {
            return Err(Error::Invalid(format!(
                "--light takes a colour R,G,B of finite values >= 0, got {:?}",
                l.color
            )));
        }
    }
    Ok(())
}

/// The scene's point lights for `--light`: white by default, no falloff
/// (NFF's convention), in scene units.
pub(super) fn point_lights(lights: &[LightSpec]) -> Vec<Light> {
    lights
        .iter()
        .map(|l| Light::point(Vec3::from(l.position), Some(Color::from(l.color))))
        .collect()
}

/// Appends a square grey floor just below `model` along the up axis, a few
/// times the model's extent across, centred under it. Returns the number of
/// shapes (triangles) added; none for an empty model.
pub(super) fn add_ground(scene: &mut Scene, model: Aabb, up: UpAxis) -> usize {
    if model.min.x > model.max.x {
        return 0;
    }
    let extent = (model.max - model.min).max_element().max(f32::MIN_POSITIVE);
    let center = (model.min + model.max) * 0.5;
    let half = extent * GROUND_HALF_SIDE;
    let gap = extent * GROUND_GAP;
    // Two axes across the floor, in counter-clockwise order seen from above.
    let (height, across, along) = match up {
        UpAxis::Y => (
            Vec3::new(center.x, model.min.y - gap, center.z),
            Vec3::Z,
            Vec3::X,
        ),
        UpAxis::Z => (
            Vec3::new(center.x, center.y, model.min.z - gap),
            Vec3::X,
            Vec3::Y,
        ),
    };
    let corner = |a: f32, b: f32| height + across * (a * half) + along * (b * half);
    let vertices = [
        corner(-1.0, -1.0),
        corner(-1.0, 1.0),
        corner(1.0, 1.0),
        corner(1.0, -1.0),
    ];
    let material = scene.add_material(Material {
        color: Color::splat(GROUND_GREY),
        ..Material::default()
    });
    let group = scene.new_group();
    let before = scene.shapes.len();
    scene.add_mesh_polygon(
        &MeshPolygon {
            vertices: &vertices,
            normals: None,
            uv: None,
            material,
            group,
        },
        &|| "--ground".to_string(),
    );
    scene.shapes.len() - before
}

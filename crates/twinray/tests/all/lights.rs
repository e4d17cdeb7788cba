//! glTF's light kinds in whole renders: a directional light casts a shadow
//! (its shadow rays run to "infinity"), a spot light lights its cone only,
//! and a glTF point light falls off with the square of the distance.

use crate::common;

use common::*;
use twinray::lights::{Light, LightKind};
use twinray::math::{Color, Vec3};
use twinray::scene::{Material, Scene, Viewpoint};
use twinray::World;

/// A white matte floor at y = 0 (kd 1, so unlit means black), a small square
/// occluder above the centre at y = 1, seen from straight above.
fn scene(light: LightKind) -> Scene {
    let mut s = Scene::new();
    s.add_material(Material::default());
    let sq = |h: f32, r: f32| {
        [
            Vec3::new(-r, h, -r),
            Vec3::new(r, h, -r),
            Vec3::new(r, h, r),
            Vec3::new(-r, h, r),
        ]
    };
    s.add_polygon(&sq(0.0, 10.0), "floor");
    s.add_polygon(&sq(1.0, 0.5), "occluder");
    s.viewpoint = Viewpoint {
        from: Vec3::new(0.0, 20.0, 0.0),
        at: Vec3::ZERO,
        up: Vec3::Z,
        angle_deg: 40.0,
        ..Viewpoint::default()
    };
    s.lights.push(Light {
        kind: light,
        color: Some(Color::ONE),
    });
    s
}

/// Brightness in the middle column at rows 20 (the occluder's top), 30 (the
/// floor at z ≈ -3.64) and 40 (z ≈ -7.3): the image's top is +z.
fn render(s: Scene) -> (f32, f32, f32) {
    let img = mono(&World::new(s), 41, 41);
    (img.get(20, 20).x, img.get(20, 30).x, img.get(20, 40).x)
}

#[test]
fn directional_light_casts_a_shadow_below_the_occluder() {
    // Slanted so that the occluder's shadow falls beside it, on x = -2..-1.
    let dir = Vec3::new(-1.5, -1.0, 0.0).normalize();
    let world = World::new(scene(LightKind::Directional { direction: dir }));
    let cam = camera(&world, 41, 41);
    let img = mono(&world, 41, 41);
    // The columns over the floor at x = -1.5 (shadow) and x = 3 (lit).
    let column = |x: f32| {
        (0..41)
            .min_by(|&a, &b| {
                let p = |c: u32| {
                    let d = cam.direction(c as f32, 20.0);
                    (cam.eye + d * (cam.eye.y / -d.y)).x
                };
                (p(a) - x).abs().total_cmp(&(p(b) - x).abs())
            })
            .unwrap()
    };
    let shadow = img.get(column(-1.5), 20).x;
    let lit = img.get(column(3.0), 20).x;
    assert_eq!(shadow, 0.0, "in the shadow");
    assert!(
        (lit - (-dir.y)).abs() < 1e-5,
        "lit: N·L = {}, got {lit}",
        -dir.y
    );
}

#[test]
fn spot_light_lights_its_cone_only() {
    let (_, inside, outside) = render(scene(LightKind::Spot {
        position: Vec3::new(0.0, 5.0, -3.64),
        direction: -Vec3::Y,
        cos_inner: 0.95,
        cos_outer: 0.9,
        range: None,
    }));
    assert!(inside > 0.0, "under the spot: {inside}");
    assert_eq!(outside, 0.0, "outside the cone");
}

#[test]
fn gltf_point_light_falls_off_with_the_square() {
    let at = |h: f32| {
        render(scene(LightKind::Point {
            position: Vec3::new(0.0, h, -3.64),
            inverse_square: true,
            range: None,
        }))
        .1
    };
    // The pixel at row 30 sees the floor right below the light.
    let (near, far) = (at(2.0), at(4.0));
    assert!((near / far - 4.0).abs() < 0.1, "{near} / {far}");
}

//! The stereo rig measured on rendered images: screen parallax against
//! `x_R − x_L = f·b·(1/C − 1/Z)`, no vertical parallax, eye order.

use crate::common;

use common::*;
use twinray::math::Vec3;
use twinray::render::{Sampling, ViewMethod};
use twinray::rig::Camera;
use twinray::rig::Rig;
use twinray::shapes::Shape;
use twinray::World;

struct Probe {
    center: Vec3,
    radius: f32,
}

fn probes(world: &World) -> Vec<Probe> {
    world
        .scene
        .shapes
        .iter()
        .filter_map(|s| match s {
            Shape::Sphere(sp) => Some(Probe {
                center: sp.center,
                radius: sp.radius,
            }),
            _ => None,
        })
        .collect()
}

/// Where a probe appears in view `v`'s image (its projection, less the image shift).
fn expected(cam: &Camera, rig: &Rig, v: usize, p: Vec3) -> (f64, f64) {
    let view = rig.views[v];
    let (x, y) = cam.project(p, view.offset).expect("in front");
    (x - view.shift as f64, y)
}

struct Measured {
    depth: f64,
    parallax: f64,
    vertical: f64,
}

fn measure(b: f32, convergence: Option<f64>) -> (Vec<Measured>, Rig, Camera) {
    let world = world("probe.nff");
    let cam = camera(&world, 257, 129);
    let rig = Rig::stereo(&cam, b, convergence).unwrap();
    let out = run(
        &world,
        &cam,
        &rig,
        &options(ViewMethod::twin(), Sampling::Centers),
    );
    let mut m = Vec::new();
    for p in probes(&world) {
        let radius_px = cam.focal_pixels() * p.radius as f64 / cam.depth_of(p.center, 0.0) as f64;
        let (xl, yl) = expected(&cam, &rig, 0, p.center);
        let (xr, yr) = expected(&cam, &rig, 1, p.center);
        let (Some(l), Some(r)) = (
            centroid(&out.images[0], xl, yl, radius_px),
            centroid(&out.images[1], xr, yr, radius_px),
        ) else {
            panic!("probe at {:?} not seen", p.center)
        };
        m.push(Measured {
            depth: cam.depth_of(p.center, 0.0) as f64,
            parallax: r.0 - l.0,
            vertical: r.1 - l.1,
        });
    }
    (m, rig, cam)
}

#[test]
fn parallax_follows_the_formula_within_half_a_pixel() {
    for b in [0.1f32, 0.3] {
        for convergence in [Some(3.0), Some(6.0), None] {
            let (measured, rig, cam) = measure(b, convergence);
            assert_eq!(measured.len(), 6);
            let f = cam.focal_pixels();
            // The shifts are whole pixels: the formula holds for the effective distance,
            // which is within half a pixel of parallax of the one asked for.
            let inv_c = rig.effective_convergence.map_or(0.0, |c| 1.0 / c);
            if let Some(c) = convergence {
                assert!((f * b as f64 * (inv_c - 1.0 / c)).abs() <= 0.5 + 1e-9);
            }
            for m in &measured {
                let expect = f * b as f64 * (inv_c - 1.0 / m.depth);
                assert!(
                    (m.parallax - expect).abs() < 0.5,
                    "b={b} C={convergence:?} Z={}: measured {:.3} px, formula {:.3} px",
                    m.depth,
                    m.parallax,
                    expect
                );
                if let Some(c) = convergence {
                    let with_asked = f * b as f64 * (1.0 / c - 1.0 / m.depth);
                    assert!((m.parallax - with_asked).abs() < 1.0);
                }
            }
        }
    }
}

#[test]
fn no_vertical_parallax() {
    let (measured, _, _) = measure(0.3, Some(4.0));
    for m in &measured {
        assert!(
            m.vertical.abs() < 0.01,
            "Z={}: vertical parallax {}",
            m.depth,
            m.vertical
        );
    }
}

#[test]
fn eyes_are_in_order_near_objects_in_front_of_the_screen() {
    // Convergence at 5: the probe at depth 2 is in front of the screen (negative
    // parallax: the right eye sees it further left), the one at 15 behind it.
    // Swapped eyes would flip both signs.
    let (measured, _, _) = measure(0.3, Some(5.0));
    let near = measured
        .iter()
        .find(|m| (m.depth - 2.0).abs() < 1e-3)
        .expect("probe at 2");
    let far = measured
        .iter()
        .find(|m| (m.depth - 15.0).abs() < 1e-3)
        .expect("probe at 15");
    assert!(near.parallax < -5.0, "near parallax {}", near.parallax);
    assert!(far.parallax > 3.0, "far parallax {}", far.parallax);
    // Parallel cameras: everything in front of the screen.
    let (parallel, rig, _) = measure(0.3, None);
    assert_eq!(rig.effective_convergence, None);
    assert!(parallel.iter().all(|m| m.parallax < 0.0));
}

#[test]
fn interaxial_moves_the_eyes_along_the_right_axis() {
    let world = world("probe.nff");
    let cam = camera(&world, 64, 32);
    let rig = Rig::stereo(&cam, 0.5, None).unwrap();
    let left = cam.eye_at(rig.views[0].offset);
    let right = cam.eye_at(rig.views[1].offset);
    assert!(((right - left).length() - 0.5).abs() < 1e-6);
    assert!((right - left).normalize().dot(cam.right) > 0.999_999);
    assert!((right - left).dot(cam.forward).abs() < 1e-7);
}

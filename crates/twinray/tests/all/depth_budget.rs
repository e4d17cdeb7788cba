//! The depth budget measured on rendered images: the automatic rig puts the
//! probe spheres' disparities inside the budget, window violations are found
//! where planted and nowhere else, quilt tiles are the views rendered alone,
//! and the depth channels agree with the images.

use crate::common;

use common::*;
use twinray::math::Vec3;
use twinray::output::{compose_quilt, DepthChannels, QuiltLayout};
use twinray::render::{Sampling, ViewMethod};
use twinray::rig::budget::DepthBudget;
use twinray::rig::choice::{plan_rig, Convergence, InteraxialRequest, PlannedRig, RigRequest};
use twinray::rig::depth_pass::stride_for;
use twinray::rig::depth_pass::{OuterPasses, REPORT_COLUMNS};
use twinray::rig::report as disparity;
use twinray::rig::window::Edge;
use twinray::rig::Camera;
use twinray::rig::{Rig, View};
use twinray::scene::{Scene, Viewpoint};
use twinray::shapes::Shape;
use twinray::World;

/// The probe spheres: (centre, radius).
fn spheres(world: &World) -> Vec<(Vec3, f32)> {
    world
        .scene
        .shapes
        .iter()
        .filter_map(|s| match s {
            Shape::Sphere(sp) => Some((sp.center, sp.radius)),
            _ => None,
        })
        .collect()
}

/// Measured disparity (adjacent views: outer views' over the gaps) of each
/// probe sphere, by centroids in the rendered outer views; with its depth.
fn measured_disparities(world: &World, cam: &Camera, rig: &Rig) -> Vec<(f64, f64)> {
    let out = run(
        world,
        cam,
        rig,
        &options(ViewMethod::twin(), Sampling::Centers),
    );
    let last = rig.views.len() - 1;
    let seen = |v: usize, p: Vec3, r: f64| {
        let view = rig.views[v];
        let (x, y) = cam.project(p, view.offset).expect("in front");
        centroid(&out.images[v], x - view.shift as f64, y, r).expect("probe seen")
    };
    spheres(world)
        .into_iter()
        .map(|(c, r)| {
            let depth = cam.depth_of(c, 0.0) as f64;
            let radius_px = cam.focal_pixels() * r as f64 / depth;
            let (x0, _) = seen(0, c, radius_px);
            let (x1, _) = seen(last, c, radius_px);
            (depth, (x1 - x0) / last as f64)
        })
        .collect()
}

fn request(views: usize, convergence: Convergence, budget: &str) -> RigRequest {
    RigRequest {
        views,
        interaxial: InteraxialRequest::Auto,
        convergence,
        budget: budget.parse().expect("budget"),
        fallback_distance: 4.0,
    }
}

#[test]
fn auto_rig_puts_the_nearest_and_farthest_probes_on_the_budget() {
    let world = world("probe.nff");
    let cam = camera(&world, 257, 129);
    let stride = stride_for(cam.width, REPORT_COLUMNS);
    for views in [2, 5] {
        for budget in ["-1%,+2%", "-4%,+6%", "-5px,3px"] {
            let req = request(views, Convergence::Auto, budget);
            let PlannedRig { rig, .. } = plan_rig(&world, &cam, &req, stride).expect("rig");
            let (near, far) = req.budget.pixels(cam.width);
            let measured = measured_disparities(&world, &cam, &rig);
            let at = |z: f64| {
                measured
                    .iter()
                    .find(|m| (m.0 - z).abs() < 1e-3)
                    .expect("probe")
                    .1
            };
            // The nearest probe (depth 2) on the near end, the farthest (15)
            // on the far end, each within a pixel; every probe inside.
            assert!(
                (at(2.0) - near).abs() <= 1.0,
                "{views} {budget}: near {} vs {near}",
                at(2.0)
            );
            assert!(
                (at(15.0) - far).abs() <= 1.0,
                "{views} {budget}: far {} vs {far}",
                at(15.0)
            );
            for &(z, d) in &measured {
                assert!(
                    d >= near - 1.0 && d <= far + 1.0,
                    "{views} {budget}: z {z}: {d}"
                );
            }
        }
    }
}

#[test]
fn convergence_near_puts_the_nearest_probe_on_the_screen() {
    let world = world("probe.nff");
    let cam = camera(&world, 257, 129);
    let req = request(2, Convergence::Nearest, "-1%,+2%");
    let PlannedRig { rig, .. } = plan_rig(&world, &cam, &req, 2).expect("rig");
    let measured = measured_disparities(&world, &cam, &rig);
    let (_, far) = req.budget.pixels(cam.width);
    for &(z, d) in &measured {
        if (z - 2.0).abs() < 1e-3 {
            assert!(d.abs() <= 0.5, "nearest probe at {d} px");
        }
        assert!(d > -0.5 && d <= far + 1.0, "z {z}: {d}");
    }
    // And the far one uses the budget: within a pixel of its end.
    let farthest = measured
        .iter()
        .find(|m| (m.0 - 15.0).abs() < 1e-3)
        .expect("probe");
    assert!((farthest.1 - far).abs() <= 1.0, "far {}", farthest.1);
}

/// A sphere at `(depth, column, row, radius)`: on the camera's ray through
/// that pixel.
type Planted = (f32, f32, f32, f32);

/// Spheres planted, and the violations expected: (edge, a row they cover).
type Case<'a> = (&'a [Planted], &'a [(Edge, f32)]);

/// A scene 160x90 looking along +y from the origin, black background, the
/// `spheres`.
fn planted(spheres: &[Planted]) -> (World, Camera) {
    let mut scene = Scene::new();
    scene.viewpoint = Viewpoint {
        from: Vec3::ZERO,
        at: Vec3::Y,
        up: Vec3::Z,
        angle_deg: 50.0,
        angle_span: Default::default(),
        hither: 0.0,
        width: 160,
        height: 90,
    };
    let cam = Camera::new(&scene.viewpoint, 160, 90);
    for &(depth, column, row, radius) in spheres {
        let d = cam.direction(column, row);
        scene.add_sphere(d * (depth / d.dot(cam.forward)), radius, "planted");
    }
    (World::new(scene), cam)
}

#[test]
fn window_violations_are_found_where_planted_and_nowhere_else() {
    // Converged at 5: depth 2 is in front of the screen, 12 behind it.
    let near_left = (2.0, 0.0, 30.0, 0.15);
    let near_right = (2.0, 159.0, 60.0, 0.15);
    let near_middle = (2.0, 80.0, 45.0, 0.15);
    let far_left = (12.0, 0.0, 70.0, 0.5);
    let far_right = (12.0, 159.0, 20.0, 0.5);
    let cases: [Case; 4] = [
        (&[near_left, near_middle, far_right], &[(Edge::Left, 30.0)]),
        (&[near_right, near_middle, far_left], &[(Edge::Right, 60.0)]),
        (
            &[near_left, near_right],
            &[(Edge::Left, 30.0), (Edge::Right, 60.0)],
        ),
        (&[near_middle, far_left, far_right], &[]),
    ];
    for (spheres, expected) in cases {
        let (world, cam) = planted(spheres);
        for views in [2, 4] {
            let rig = Rig::multi_view(&cam, views, 0.1, Some(5.0)).unwrap();
            let passes = OuterPasses::measure(&world, &cam, &rig, 1);
            let report = disparity::report(&cam, &rig, &DepthBudget::default(), 1.2, &passes);
            let found: Vec<(Edge, u32, u32)> = report
                .window_violations
                .iter()
                .map(|v| (v.edge, v.first_row, v.last_row))
                .collect();
            assert_eq!(found.len(), expected.len(), "{views} views: {found:?}");
            for (&(edge, row), v) in expected.iter().zip(&report.window_violations) {
                assert_eq!(v.edge, edge);
                assert_eq!(v.view, if edge == Edge::Left { 0 } else { views - 1 });
                // The planted sphere's rows: its centre row, and no more than
                // its diameter (0.15 at depth 2 is 12 px across).
                assert!(
                    (v.first_row as f32) < row && row < v.last_row as f32,
                    "{edge:?}: rows {}-{} miss {row}",
                    v.first_row,
                    v.last_row
                );
                assert!(v.last_row - v.first_row <= 14, "{edge:?}: {v:?}");
                // The mask covers the violating disparity: the window's edge
                // comes in front of the sphere.
                assert!(f64::from(v.mask_px) >= -v.disparity_px, "{v:?}");
                assert!(v.disparity_px < -1.0, "{v:?}");
            }
        }
    }
}

#[test]
fn quilt_tiles_are_the_views_rendered_alone_in_order() {
    let world = world("example.nff");
    let (w, h) = (24, 18);
    let cam = camera(&world, w, h);
    let rig = Rig::multi_view(&cam, 6, 0.15, Some(6.0)).unwrap();
    let out = run(
        &world,
        &cam,
        &rig,
        &options(ViewMethod::twin(), Sampling::Centers),
    );
    let layout = QuiltLayout {
        columns: 3,
        rows: 2,
    };
    let quilt = compose_quilt(&out.images, layout).unwrap();
    assert_eq!((quilt.width, quilt.height), (3 * w, 2 * h));
    for (v, view) in rig.views.iter().enumerate() {
        // The view alone: a mono render of its own camera.
        let alone = Rig {
            views: vec![View {
                offset: view.offset,
                shift: view.shift,
            }],
            convergence: None,
            effective_convergence: None,
        };
        let single = run(
            &world,
            &cam,
            &alone,
            &options(ViewMethod::Independent, Sampling::Centers),
        );
        // View 0 bottom-left, filled left to right, then upwards.
        let (x0, y0) = ((v as u32 % 3) * w, (1 - v as u32 / 3) * h);
        for y in 0..h {
            for x in 0..w {
                assert_eq!(
                    quilt.get(x0 + x, y0 + y).to_array().map(f32::to_bits),
                    single.images[0].get(x, y).to_array().map(f32::to_bits),
                    "view {v} at ({x}, {y})"
                );
            }
        }
    }
}

#[test]
fn depth_channels_agree_with_the_rendered_disparities() {
    let world = world("probe.nff");
    let cam = camera(&world, 257, 129);
    let rig = Rig::stereo(&cam, 0.2, Some(4.0)).unwrap();
    let measured = measured_disparities(&world, &cam, &rig);
    for (v, view) in rig.views.iter().enumerate() {
        let channels = DepthChannels::measure(&world, &cam, &rig, v);
        assert_eq!(channels.z.len(), (cam.width * cam.height) as usize);
        for (c, r) in spheres(&world) {
            let depth = cam.depth_of(c, 0.0) as f64;
            let (x, y) = cam.project(c, view.offset).expect("in front");
            let (px, py) = ((x - view.shift as f64).round(), y.round());
            let i = (py as u32 * cam.width + px as u32) as usize;
            // Z: the sphere's near surface, along the view direction.
            let z = f64::from(channels.z[i]);
            assert!(
                z > depth - r as f64 * 1.01 && z < depth,
                "view {v}: Z {z}, centre {depth}"
            );
            // Disparity: the measured one of this probe, within half a pixel.
            let d = f64::from(channels.disparity[i]);
            let m = measured
                .iter()
                .find(|m| (m.0 - depth).abs() < 1e-3)
                .expect("probe")
                .1;
            assert!(
                (d - m).abs() < 0.5,
                "view {v}, depth {depth}: channel {d}, measured {m}"
            );
        }
        // The background: nothing hit, the disparity of infinity.
        assert_eq!(channels.z[0], f32::INFINITY);
        let d = f64::from(rig.views[0].shift - rig.views[1].shift);
        assert_eq!(f64::from(channels.disparity[0]), d);
    }
}

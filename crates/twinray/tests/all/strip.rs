//! The strip eye pass (`--strip`, issue 16): one descent per camera column for
//! every view. Its images must be, bit for bit, the independent renders', on
//! scenes made to trouble a family of rays: triangles whose edges and corners
//! lie exactly on sample rays, coincident triangles (ties in distance), a quad
//! split along a shared edge, triangles parallel to the rays, a pole so thin
//! that one view at most sees it in a column, spheres and a cone. The same
//! for eye runs (`--eye-runs`), and their counts on a bare wall and with the
//! pole in front of it.

use crate::common;

use common::*;
use twinray::loaders::nff::parse_nff;
use twinray::loaders::LoadOptions;
use twinray::math::Vec3;
use twinray::render::{Method, RenderOptions, RenderOutput, Sampling};
use twinray::rig::{Camera, Rig};
use twinray::World;

const WIDTH: u32 = 48;
const HEIGHT: u32 = 36;

/// Camera, lights, a floor, spheres, a cone; a pole 0.003 wide one unit in
/// front of the eyes (the views are 0.01 apart: at most one sees it per
/// column); a wall in the plane x = 0 and a quad at eye height, which the
/// centre view's rays run along; two coincident triangles of different colours
/// (exact ties: the lower index must win).
const BASE: &str = "b 0.1 0.1 0.2\nv\nfrom 0 -8 2\nat 0 0 2\nup 0 0 1\nangle 45\nhither 0.01\n\
    resolution 48 36\n\
    l -5 -5 6 0.6 0.6 0.6\nl 5 -4 5 0.4 0.4 0.4\n\
    f 0.8 0.8 0.7 0.6 0.3 20 0 1\np 4\n-6 -6 0\n6 -6 0\n6 6 0\n-6 6 0\n\
    f 0.9 0.2 0.2 0.7 0.2 30 0 1\ns -1.5 0 1 0.8\ns 1.2 2 2.5 0.6\n\
    f 0.3 0.4 0.9 0.7 0.2 30 0 1\nc\n2.5 -1.5 0 0.6\n2.5 -1.5 2 0.1\n\
    f 0.2 0.9 0.9 0.8 0 10 0 1\np 4\n0 -3 0.2\n0 3 0.2\n0 3 1.4\n0 -3 1.4\n\
    f 0.9 0.5 0.1 0.8 0 10 0 1\np 4\n-3 -2 2\n3 -2 2\n3 4 2\n-3 4 2\n\
    f 0.5 0.9 0.5 0.8 0 10 0 1\np 3\n-2 1 3\n-0.5 1 4\n-2.5 1 4.5\n\
    f 0.9 0.5 0.9 0.8 0 10 0 1\np 3\n-2 1 3\n-0.5 1 4\n-2.5 1 4.5\n";

/// The pole: 0.003 wide, one unit in front of the eyes.
const POLE: &str = "f 0.9 0.9 0.2 0.8 0 10 0 1\np 4\n-0.0015 -7 0.5\n0.0015 -7 0.5\n0.0015 -7 3.5\n-0.0015 -7 3.5\n";

fn scene(views: usize, convergence: Option<f64>) -> (World, Camera, Rig) {
    scene_from(views, convergence, &format!("{BASE}{POLE}"))
}

/// `base`, with fans of triangles whose shared corner is the point of a view's
/// sample ray at some depth (computed as the renderer computes the ray), and
/// quads split along a shared edge that runs through such points: rays that
/// graze edges and corners by less than a rounding error.
fn scene_from(views: usize, convergence: Option<f64>, base_text: &str) -> (World, Camera, Rig) {
    let parse = |text: &str| {
        parse_nff(
            text,
            std::path::Path::new("strip.nff"),
            &LoadOptions::default(),
        )
        .expect("generated scene")
    };
    let base = parse(base_text);
    let camera = Camera::new(&base.viewpoint, WIDTH, HEIGHT);
    let rig = Rig::multi_view(&camera, views, 0.01, convergence).expect("rig");
    let mut text = String::from(base_text);
    let mut rng = fastrand::Rng::with_seed(16);
    let v3 = |p: Vec3| format!("{:?} {:?} {:?}\n", p.x, p.y, p.z);
    for k in 0..24 {
        let view = &rig.views[rng.usize(..rig.views.len())];
        let (x, y) = (rng.i32(0..WIDTH as i32), rng.i32(0..HEIGHT as i32));
        let origin = camera.eye_at(view.offset);
        let dir = camera.direction((x + view.shift) as f32, y as f32);
        let depth = 3.0 + 6.0 * rng.f32();
        let corner = origin + dir * depth;
        text += &format!(
            "f {} {} 0.3 0.7 0 5 0 1\n",
            rng.f32(),
            0.2 + 0.1 * (k % 8) as f32
        );
        if k % 2 == 0 {
            // A fan of six triangles around the corner.
            let r = 0.05 + 0.2 * rng.f32();
            let ring: Vec<Vec3> = (0..6)
                .map(|j| {
                    let a = std::f32::consts::TAU * (j as f32 + rng.f32() * 0.5) / 6.0;
                    corner
                        + camera.right * (r * a.cos())
                        + camera.up * (r * a.sin())
                        + camera.forward * (0.1 * (rng.f32() - 0.5))
                })
                .collect();
            for j in 0..6 {
                text += &format!(
                    "p 3\n{}{}{}",
                    v3(corner),
                    v3(ring[j]),
                    v3(ring[(j + 1) % 6])
                );
            }
        } else {
            // Two triangles sharing the edge from `corner` to another ray's point.
            let dir2 = camera.direction((x + view.shift + 1) as f32, y as f32 + 1.0);
            let other = origin + dir2 * (depth + 0.3 * rng.f32());
            let side = camera.right * 0.15 - camera.up * 0.1;
            text += &format!("p 3\n{}{}{}", v3(corner), v3(other), v3(corner + side));
            text += &format!("p 3\n{}{}{}", v3(other), v3(corner), v3(corner - side));
        }
    }
    (World::new(parse(&text)), camera, rig)
}

fn render(world: &World, camera: &Camera, rig: &Rig, method: Method, strip: bool) -> RenderOutput {
    let opts = RenderOptions {
        strip,
        ..options(method, Sampling::Centers)
    };
    run(world, camera, rig, &opts)
}

/// The twin method with eye runs (`--eye-runs`).
fn runs_options() -> RenderOptions {
    RenderOptions {
        eye_runs: true,
        ..options(Method::Twin, Sampling::Centers)
    }
}

fn render_runs(world: &World, camera: &Camera, rig: &Rig) -> RenderOutput {
    run(world, camera, rig, &runs_options())
}

fn bits(img: &twinray::Image) -> Vec<[u32; 3]> {
    img.pixels
        .iter()
        .map(|p| p.to_array().map(f32::to_bits))
        .collect()
}

/// Every view of `strip` is `reference`'s, bit for bit.
fn assert_same_views(reference: &RenderOutput, strip: &RenderOutput, what: &str) {
    assert_eq!(reference.images.len(), strip.images.len(), "{what}");
    for (v, (a, b)) in reference.images.iter().zip(&strip.images).enumerate() {
        let (a, b) = (bits(a), bits(b));
        let differ = a.iter().zip(&b).filter(|(p, q)| p != q).count();
        assert_eq!(differ, 0, "{what}: view {v} differs in {differ} pixels");
    }
}

/// Bit for bit the independent renders, for 2 to 48 views, converged at
/// infinity and at 6 units; the strip did the eye pass (one descent per camera
/// column, fewer than the views' rays) and met what it is made for.
#[test]
fn strip_renders_equal_independent_renders() {
    for views in [2, 5, 8, 16, 48] {
        for convergence in [None, Some(6.0)] {
            let (world, camera, rig) = scene(views, convergence);
            let reference = render(&world, &camera, &rig, Method::Independent, false);
            let strip = render(&world, &camera, &rig, Method::Twin, true);
            let what = format!("{views} views, convergence {convergence:?}");
            assert_same_views(&reference, &strip, &what);
            assert_eq!(reference.counts.rays, strip.counts.rays, "{views} views");
            let s = strip.counts.strip;
            let columns = WIDTH as u64 * HEIGHT as u64;
            assert!(s.descents >= columns, "{views} views: {s:?}");
            assert_eq!(strip.counts.eye_traversals, s.descents);
            if views >= 8 && convergence.is_none() {
                assert!(s.descents * 4 <= strip.counts.rays.eye, "{s:?}");
            }
            // The wall at x = 0 and the quad at eye height run along rays: not bounded.
            assert!(s.unbounded > 0, "{views} views: {s:?}");
            // Rays on shared edges are tested against both sides, and miss one.
            assert!(s.exact_tests > s.exact_hits, "{views} views: {s:?}");
        }
    }
}

/// The thin pole is there to be missed: some views see it and others do not
/// (the images with and without it differ in some views only).
#[test]
fn the_thin_pole_is_seen_by_some_views_only() {
    let (world, camera, rig) = scene(16, None);
    let with = render(&world, &camera, &rig, Method::Twin, true);
    let (world, _, _) = scene_from(16, None, BASE);
    let without = render(&world, &camera, &rig, Method::Twin, true);
    let seen = (0..16)
        .filter(|&v| bits(&with.images[v]) != bits(&without.images[v]))
        .count();
    assert!(seen > 0 && seen < 16, "{seen} of 16 views see the pole");
}

/// A forest of thin cones and spheres, branches as the SPD tree draws them:
/// the cone routine may find a hit a hair outside the cone's box, which the
/// single-ray descent never tests; the strip must not find it either (it
/// applies the single-ray descent's own test of each leaf's box).
#[test]
fn thin_cones_and_spheres_as_the_single_ray_descent_sees_them() {
    let mut text = String::from(
        "b 0.078 0.361 0.753\nv\nfrom 4.5 0.4 2\nat 0 0 1.5\nup 0 0 1\nangle 45\nhither 1\n\
         resolution 64 64\nl -5 5 50\nl 30 -30 30\n\
         f 0.55 0.4 0.2 1 0 100000 0 0\n",
    );
    let mut rng = fastrand::Rng::with_seed(7);
    let mut stack = vec![(Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 1.0), 0.12f32)];
    while let Some((base, axis, r)) = stack.pop() {
        let len = 0.2 + 0.5 * r / 0.12;
        let tip = base + axis * len;
        let r2 = r * 0.67;
        text += &format!(
            "c\n{:?} {:?} {:?} {:?}\n{:?} {:?} {:?} {:?}\ns {:?} {:?} {:?} {:?}\n",
            base.x, base.y, base.z, r, tip.x, tip.y, tip.z, r2, tip.x, tip.y, tip.z, r2
        );
        if r2 > 0.012 {
            for _ in 0..2 {
                let bend = Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() * 0.5);
                stack.push((tip, (axis + bend).normalize(), r2));
            }
        }
    }
    let scene = parse_nff(
        &text,
        std::path::Path::new("cones.nff"),
        &LoadOptions::default(),
    )
    .expect("generated scene");
    let world = World::new(scene);
    let camera = Camera::new(&world.scene.viewpoint, 105, 140);
    for (views, convergence) in [(8, None), (8, Some(4.0)), (48, None)] {
        let rig = Rig::multi_view(&camera, views, 0.02, convergence).expect("rig");
        let reference = render(&world, &camera, &rig, Method::Independent, false);
        let strip = render(&world, &camera, &rig, Method::Twin, true);
        assert_same_views(&reference, &strip, &format!("{views} views"));
        assert!(
            strip.counts.strip.unbounded > 0,
            "cones are tested view by view"
        );
        let runs = render_runs(&world, &camera, &rig);
        assert_same_views(&reference, &runs, &format!("{views} views, eye runs"));
        assert!(runs.counts.runs.filled > 0, "{:?}", runs.counts.runs);
    }
}

/// Spheres that the centre ray of a view grazes exactly, at the face of the
/// sphere's box: whether the sphere routine finds a hit and whether the
/// single-ray descent's slab test enters the box are each a matter of a
/// rounding. The strip must do what the single-ray descent does. (Neither this
/// scene nor the cones above made the strip without the single-ray leaf test
/// differ; the SPD tree did, see docs/benchmarks.md.)
#[test]
fn rays_grazing_a_box_face_are_decided_by_the_single_ray_slab_test() {
    let (w, h) = (49, 37);
    let mut text = String::from(
        "b 0.1 0.1 0.2\nv\nfrom 0 -8 2\nat 0 0 2\nup 0 0 1\nangle 45\nhither 0.01\n\
         resolution 49 37\nl -5 -5 6 0.6 0.6 0.6\nf 0.9 0.2 0.2 0.7 0.2 30 0 1\n",
    );
    let base = parse_nff(
        &text,
        std::path::Path::new("g.nff"),
        &LoadOptions::default(),
    )
    .expect("generated scene");
    let camera = Camera::new(&base.viewpoint, w, h);
    let rig = Rig::multi_view(&camera, 48, 0.013, None).expect("rig");
    let mut rng = fastrand::Rng::with_seed(3);
    for (v, view) in rig.views.iter().enumerate() {
        let x = camera.eye_at(view.offset).x;
        for side in [-1.0f32, 1.0] {
            let r = 0.01 + 0.05 * rng.f32();
            let y = -6.0 + 0.1 * v as f32 + 0.05 * (side + 1.0);
            text += &format!("s {:?} {:?} 2 {:?}\n", x + side * r, y, r);
        }
    }
    let scene = parse_nff(
        &text,
        std::path::Path::new("g.nff"),
        &LoadOptions::default(),
    )
    .expect("generated scene");
    let world = World::new(scene);
    let reference = render(&world, &camera, &rig, Method::Independent, false);
    let strip = render(&world, &camera, &rig, Method::Twin, true);
    assert_same_views(&reference, &strip, "grazing spheres");
    let runs = render_runs(&world, &camera, &rig);
    assert_same_views(&reference, &runs, "grazing spheres, eye runs");
}

/// Eye runs (`--eye-runs`): bit for bit the independent renders, for 2 to 48
/// views, converged at infinity and at 6 units, on the scene of grazed edges
/// and corners, ties, rays along polygons, spheres, a cone and the thin pole;
/// the same rays counted; and runs did fill views between traced ones.
#[test]
fn eye_runs_equal_independent_renders() {
    for views in [2, 5, 8, 16, 48] {
        for convergence in [None, Some(6.0)] {
            let (world, camera, rig) = scene(views, convergence);
            let reference = render(&world, &camera, &rig, Method::Independent, false);
            let runs = render_runs(&world, &camera, &rig);
            let what = format!("{views} views, convergence {convergence:?}");
            assert_same_views(&reference, &runs, &what);
            assert_eq!(reference.counts.rays, runs.counts.rays, "{what}");
            let r = runs.counts.runs;
            assert_eq!(r.traced + r.filled, runs.counts.rays.eye, "{what}: {r:?}");
            assert_eq!(runs.counts.eye_traversals, r.traced, "{what}: {r:?}");
            if views >= 8 {
                assert!(r.filled > r.traced, "{what}: {r:?}");
                assert!(r.proofs_failed > 0, "{what}: {r:?}");
            }
        }
    }
}

/// The shipped example scene (spheres, a cone, polygons): eye runs give the
/// independent renders, bit for bit.
#[test]
fn eye_runs_on_the_example_scene() {
    let world = world("example.nff");
    let camera = camera(&world, 64, 48);
    for (views, convergence) in [
        (2, None),
        (5, Some(8.0)),
        (8, None),
        (16, Some(8.0)),
        (48, None),
    ] {
        let rig = Rig::multi_view(&camera, views, 0.05, convergence).expect("rig");
        let reference = render(&world, &camera, &rig, Method::Independent, false);
        let runs = render_runs(&world, &camera, &rig);
        assert_same_views(&reference, &runs, &format!("example.nff, {views} views"));
    }
}

/// Eye runs give the same images on 1, 2 and 5 threads.
#[test]
fn eye_runs_do_not_depend_on_threads() {
    let (world, camera, rig) = scene(16, Some(6.0));
    let one = run_on_threads(1, &world, &camera, &rig, &runs_options());
    for threads in [2, 5] {
        let many = run_on_threads(threads, &world, &camera, &rig, &runs_options());
        assert_eq!(one.images, many.images, "{threads} threads");
    }
}

/// One large triangle facing the eyes, filling the image, and optionally a
/// pole 0.003 wide in front of it (at most one of views 0.01 apart sees it
/// per column; the outer views' rays pass beside it onto the wall).
fn wall(pole: bool) -> (World, Camera, Rig) {
    let mut text = String::from(
        "b 0.1 0.1 0.2\nv\nfrom 0 -8 2\nat 0 0 2\nup 0 0 1\nangle 30\nhither 0.01\n\
         resolution 48 36\nl -5 -5 6 0.6 0.6 0.6\n\
         f 0.8 0.8 0.7 0.6 0.3 20 0 1\np 3\n-40 0 -30\n40 0 -30\n0 0 40\n",
    );
    if pole {
        text += POLE;
    }
    let scene = parse_nff(
        &text,
        std::path::Path::new("wall.nff"),
        &LoadOptions::default(),
    )
    .expect("generated scene");
    let world = World::new(scene);
    let camera = Camera::new(&world.scene.viewpoint, WIDTH, HEIGHT);
    let rig = Rig::multi_view(&camera, 48, 0.01, None).expect("rig");
    (world, camera, rig)
}

/// A wall seen by 48 views, nothing in front: every family (a camera column,
/// its 48 views at infinite convergence) is its two end views traced and one
/// proof that fills the 46 between.
#[test]
fn a_bare_wall_is_two_traced_views_and_one_proof_per_family() {
    let (world, camera, rig) = wall(false);
    let runs = render_runs(&world, &camera, &rig);
    let r = runs.counts.runs;
    let families = WIDTH as u64 * HEIGHT as u64;
    assert_eq!(r.families, families, "{r:?}");
    assert_eq!(r.traced, 2 * families, "{r:?}");
    assert_eq!(r.proofs, families, "{r:?}");
    assert_eq!(r.proofs_failed, 0, "{r:?}");
    assert_eq!(r.filled, 46 * families, "{r:?}");
    let reference = render(&world, &camera, &rig, Method::Independent, false);
    assert_same_views(&reference, &runs, "bare wall");
}

/// The 0.003-wide pole in front of the wall, between the end views of many
/// families whose ends both hit the wall: the proofs find it, subdivision
/// traces down to it, and every view that sees it (some do, not all) shows it.
#[test]
fn a_pole_between_two_views_on_one_wall_is_found() {
    let (world, camera, rig) = wall(true);
    let runs = render_runs(&world, &camera, &rig);
    let reference = render(&world, &camera, &rig, Method::Independent, false);
    assert_same_views(&reference, &runs, "pole before a wall");
    let r = runs.counts.runs;
    assert!(r.proofs_failed > 0, "{r:?}");
    let (bare, _, _) = wall(false);
    let without = render_runs(&bare, &camera, &rig);
    let seen = (0..48)
        .filter(|&v| bits(&runs.images[v]) != bits(&without.images[v]))
        .count();
    assert!(seen > 0 && seen < 48, "{seen} of 48 views see the pole");
}

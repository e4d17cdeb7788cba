//! Regression tests of the attack on twinray (issue 11): pathological scenes
//! that crashed it or gave silently wrong pixels. Each scene is generated here
//! and rendered small.

use std::fmt::Write as _;
use std::path::Path;

use twinray::loaders::nff::parse_nff;
use twinray::loaders::LoadOptions;
use twinray::render::{render, Method, RenderOptions, Sampling, TraceSettings, MAX_DEPTH};
use twinray::rig::Camera;
use twinray::rig::Rig;
use twinray::{Image, World};

fn world(nff: &str) -> World {
    let scene = parse_nff(nff, Path::new("generated.nff"), &LoadOptions::default())
        .expect("generated scene parses");
    World::new(scene)
}

fn render_views(world: &World, views: usize, method: Method, max_depth: u32) -> Vec<Image> {
    let vp = &world.scene.viewpoint;
    let camera = Camera::new(vp, vp.width, vp.height);
    let rig = if views == 1 {
        Rig::mono()
    } else {
        Rig::multi_view(&camera, views, 0.001, None).expect("rig")
    };
    let opts = RenderOptions {
        trace: TraceSettings {
            max_depth,
            ..TraceSettings::default()
        },
        method,
        sampling: Sampling::Centers,
        ..RenderOptions::default()
    };
    render(world, &camera, &rig, &opts, &|_, _| {})
        .expect("render")
        .images
}

const VIEW_DOWN: &str =
    "v\nfrom 0 0 3\nat 0 0 0\nup 0 1 0\nangle 45\nhither 0\nresolution 32 32\nb 0.5 0.5 0.5\n";

/// A closed box of mirrors with the camera and a light inside.
fn mirror_box() -> String {
    let mut s = String::from(
        "v\nfrom 0 0 0\nat 0 1 0\nup 0 0 1\nangle 60\nhither 0\nresolution 8 6\n\
         l 0 0 0.5\nf 1 1 1 0 1 50 0 1\n",
    );
    let faces = [
        [[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1]],
        [[-1, -1, 1], [-1, 1, 1], [1, 1, 1], [1, -1, 1]],
        [[-1, -1, -1], [-1, 1, -1], [-1, 1, 1], [-1, -1, 1]],
        [[1, -1, -1], [1, -1, 1], [1, 1, 1], [1, 1, -1]],
        [[-1, -1, -1], [-1, -1, 1], [1, -1, 1], [1, -1, -1]],
        [[-1, 1, -1], [1, 1, -1], [1, 1, 1], [-1, 1, 1]],
    ];
    for face in faces {
        s.push_str("p 4\n");
        for [x, y, z] in face {
            let _ = writeln!(s, "{x} {y} {z}");
        }
    }
    s
}

#[test]
fn mirror_box_at_the_depth_cap_does_not_overflow_the_stack() {
    // The attack: --max-depth 1693 and up aborted with a stack overflow (32
    // views: from about 180). The cap is checked, and the deepest accepted
    // depth runs on the default worker stacks for 1, 2 and 32 views.
    let world = world(&mirror_box());
    for views in [1, 2, 32] {
        let images = render_views(&world, views, Method::Twin, MAX_DEPTH);
        assert_eq!(images.len(), views);
    }
    let vp = &world.scene.viewpoint;
    let camera = Camera::new(vp, vp.width, vp.height);
    for max_depth in [0, MAX_DEPTH + 1, u32::MAX] {
        let opts = RenderOptions {
            trace: TraceSettings {
                max_depth,
                ..TraceSettings::default()
            },
            ..RenderOptions::default()
        };
        let err = render(&world, &camera, &Rig::mono(), &opts, &|_, _| {})
            .err()
            .expect("refused");
        assert!(err.to_string().contains("between 1"), "{err}");
    }
}

/// `count` spheres of transmission `t` stacked on the shadow ray from the
/// floor point the camera looks at (the image centre) to the light above it;
/// the camera sees that point past them.
fn glass_stack(count: usize, t: f32) -> String {
    let mut s = String::from(
        "v\nfrom 0 -6 3\nat 0 0 0\nup 0 0 1\nangle 30\nhither 0\nresolution 33 33\n\
         l 0 0 60\nf 1 1 1 1 0 0 0 1\np 4\n-3 -3 0\n3 -3 0\n3 3 0\n-3 3 0\n",
    );
    let _ = writeln!(s, "f 1 1 1 0 0 0 {t} 1");
    for i in 0..count {
        let _ = writeln!(s, "s 0 0 {} 0.2", 1.0 + 2.0 * i as f32);
    }
    s
}

#[test]
fn shadow_transmittance_keeps_multiplying_past_sixteen_objects() {
    // The attack: 17 spheres with T = 1 between a floor and its light gave a
    // black shadow (the product stopped at 16 factors).
    let centre = |nff: &str| render_views(&world(nff), 1, Method::Independent, 5)[0].get(16, 16);
    let lit = centre(&glass_stack(0, 1.0));
    assert!(lit.x > 0.5, "{lit}");
    assert_eq!(centre(&glass_stack(17, 1.0)), lit);
    let dimmed = centre(&glass_stack(20, 0.9));
    let expected = lit.x * 0.9f32.powi(20);
    assert!((dimmed.x - expected).abs() < 1e-5, "{dimmed} vs {expected}");
    // Past 16 factors the product is still independent of the traversal
    // order: the twin method's packets give the same bits.
    let world = world(&glass_stack(20, 0.9));
    let independent = render_views(&world, 2, Method::Independent, 5);
    let twin = render_views(&world, 2, Method::Twin, 5);
    assert_eq!(independent, twin);
}

/// A regular `n`-gon in the plane z = 0 (or tilted), lit from above.
fn regular_polygon(n: usize, tilt: f32) -> String {
    let mut s = format!("{VIEW_DOWN}l 0.3 0.2 5\nf 1 1 1 1 0 0 0 1\np {n}\n");
    for i in 0..n {
        let a = std::f64::consts::TAU * i as f64 / n as f64;
        let (x, y) = (a.cos() as f32, a.sin() as f32);
        let _ = writeln!(s, "{x} {y} {}", x * tilt);
    }
    s
}

/// Pixels of the polygon (not background) that are black: in its own shadow.
fn self_shadowed(images: &[Image]) -> (usize, usize) {
    let polygon: Vec<_> = images[0]
        .pixels
        .iter()
        .filter(|c| (c.x - 0.5).abs() > 1e-6)
        .collect();
    let black = polygon.iter().filter(|c| c.x == 0.0).count();
    (black, polygon.len())
}

#[test]
fn many_vertex_flat_polygons_do_not_shadow_themselves() {
    // The attack: a regular 2000-gon lit from above had 6 % of its pixels in
    // its own shadow, 39 % at 20,000 vertices (thin slivers of the
    // triangulation "hit" behind the shadow ray's origin).
    for n in [2000, 20_000] {
        for tilt in [0.0, 0.3] {
            let world = world(&regular_polygon(n, tilt));
            let independent = render_views(&world, 1, Method::Independent, 5);
            let (black, total) = self_shadowed(&independent);
            assert!(total > 400, "{n}-gon covers {total} pixels");
            assert_eq!(
                black, 0,
                "{n}-gon tilt {tilt}: {black} of {total} pixels self-shadowed"
            );
            let pair_independent = render_views(&world, 2, Method::Independent, 5);
            let pair_twin = render_views(&world, 2, Method::Twin, 5);
            assert_eq!(pair_independent, pair_twin, "{n}-gon: twin = independent");
        }
    }
}

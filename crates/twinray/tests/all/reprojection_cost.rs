//! What the safe reprojection (`--reproject`) spares the second eye, in
//! counts: on a diffuse scene nearly every sample of the right eye takes
//! the left eye's light and traces no shadow ray, so the pair traces the
//! shadow rays of the left eye alone and those of the samples refused; and
//! it groups no samples of the views (each eye's samples go eight
//! neighbours to a packet, as a mono render's do).

use crate::common;

use common::*;
use twinray::render::{
    PaperTechniques, RenderOptions, RenderOutput, ReprojectMode, Reprojection, Sampling, ViewMethod,
};
use twinray::rig::Rig;
use twinray::World;

/// Matte spheres of many sizes on a matte floor under three lights (no
/// highlight, mirror or glass): `bench/diffuse_scene.py`'s kind of scene.
fn diffuse_scene() -> World {
    let mut text = String::from(
        "v\nfrom 0 -14 6\nat 0 0 0.5\nup 0 0 1\nangle 40\nhither 0.01\nresolution 160 120\n\
         b 0.1 0.12 0.15\nl -8 -10 12\nl 9 -6 10\nl 0 8 14\n\
         f 0.7 0.7 0.65 0.9 0 0 0 1\np 4\n-30 -30 0\n30 -30 0\n30 30 0\n-30 30 0\n",
    );
    let mut g = fastrand::Rng::with_seed(44);
    for _ in 0..60 {
        let r = 0.3 + 0.5 * g.f32();
        text += &format!(
            "f {} {} {} 0.8 0 0 0 1\ns {} {} {r} {r}\n",
            g.f32(),
            g.f32(),
            g.f32(),
            -9.0 + 18.0 * g.f32(),
            -6.0 + 20.0 * g.f32(),
        );
    }
    nff_world(&text)
}

fn reproject() -> RenderOptions {
    let paper = PaperTechniques {
        merge_secondary: false,
        reproject: Some(Reprojection {
            mode: ReprojectMode::Safe,
            threshold: Reprojection::DEFAULT_THRESHOLD,
        }),
    };
    options(ViewMethod::Twin { paper }, Sampling::Centers)
}

/// The pair with `--reproject`, its left eye rendered alone, and the exact pair.
fn renders() -> (World, RenderOutput, RenderOutput, RenderOutput) {
    let world = diffuse_scene();
    let cam = camera(&world, 160, 120);
    let pair = Rig::stereo(&cam, 0.2, None).expect("rig");
    let left = Rig {
        views: vec![pair.views[0]],
        ..pair.clone()
    };
    let exact = options(ViewMethod::twin(), Sampling::Centers);
    let reprojected = run(&world, &cam, &pair, &reproject());
    let alone = run(&world, &cam, &left, &exact);
    let exact_pair = run(&world, &cam, &pair, &exact);
    (world, reprojected, alone, exact_pair)
}

#[test]
fn the_second_eye_traces_shadow_rays_only_for_the_samples_refused() {
    let (world, pair, alone, exact) = renders();
    let lights = world.scene.lights.len() as u64;
    let paper = pair.counts.paper;
    let right_hits = pair.counts.per_view_hits.0[1];
    // Every hit of the right eye either took the left eye's light or was
    // shaded exactly (no hit of the left eye on this scene gives nothing).
    assert_eq!(paper.reprojected + paper.reproject_rejected, right_hits);
    assert!(
        paper.reprojected * 5 >= right_hits * 4,
        "{} of {right_hits} samples reprojected",
        paper.reprojected
    );
    // The left eye is shaded as it is alone; of the right eye, only the
    // refused samples cast shadow rays (at most one per light).
    assert!(alone.counts.rays.shadow > 0);
    let second = pair.counts.rays.shadow - alone.counts.rays.shadow;
    assert!(
        second <= lights * paper.reproject_rejected,
        "the second eye cast {second} shadow rays for {} refused samples and {lights} lights",
        paper.reproject_rejected
    );
    assert!(
        pair.counts.rays.shadow * 10 < exact.counts.rays.shadow * 6,
        "shadow rays: {} with reprojection, {} exact",
        pair.counts.rays.shadow,
        exact.counts.rays.shadow
    );
    assert_eq!(pair.images[0], exact.images[0], "the left eye is exact");
}

#[test]
fn the_reprojected_pair_groups_no_samples_of_the_views() {
    let (_, pair, _, exact) = renders();
    assert!(exact.counts.grouped_samples > 0, "the exact pair groups");
    assert_eq!(pair.counts.grouped_samples, 0);
}

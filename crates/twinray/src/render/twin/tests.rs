//! The twin rows' stages against each other: the mono row and the staged
//! row, flat materials, packed approximations and packets of one lane,
//! grouping under convergence, groups four to a packet.

use super::batch::{RowScratch, Shading, Sharing, TwinBatch};
use crate::bvh::PacketHits;
use crate::math::{Color, Vec3};
use crate::render::batch::RenderInputs;
use crate::render::cancel::CancelToken;
use crate::render::options::{RenderOptions, Reprojection};
use crate::render::sampler::{Pattern, SampleRow};
use crate::render::tracer::{SecondaryRays, Tracer};
use crate::rig::{Camera, Rig};
use crate::world::World;

/// The exact twin method's shading.
const EXACT: Shading = Shading {
    sharing: Sharing::Exact,
    secondary: SecondaryRays::Own,
};

/// A render's inputs with nobody told of progress.
fn quiet_inputs<'a>(
    world: &'a World,
    camera: &'a Camera,
    rig: &'a Rig,
    opts: &'a RenderOptions,
    cancel: &'a CancelToken,
) -> RenderInputs<'a> {
    fn no_progress(_: u64, _: u64) {}
    RenderInputs {
        world,
        camera,
        rig,
        opts,
        progress: &no_progress,
        cancel,
    }
}

/// The example scene at 64×48, one view, default options.
fn example_mono() -> (World, Camera, Rig, RenderOptions, CancelToken) {
    let world = World::new(crate::render::example_scene());
    let camera = Camera::new(&world.scene.viewpoint, 64, 48);
    (
        world,
        camera,
        Rig::mono(),
        RenderOptions::default(),
        CancelToken::new(),
    )
}

/// A batch of one view takes `trace_mono_row` (no grouping: the groups
/// stay empty), and its colours and counts are, bit for bit, those of
/// the staged path it replaces (eye pass, grouping, shading of groups of
/// one), on rows of pixel centres, of corners and of Sobol samples
/// (both take the eye rays eight to a descent; the mono row shades
/// eight samples a packet, so its descents and shadow cache differ).
#[test]
fn a_mono_row_is_the_staged_row_bit_for_bit() {
    let (world, camera, rig, opts, cancel) = example_mono();
    let job = quiet_inputs(&world, &camera, &rig, &opts, &cancel);
    let batch = TwinBatch::<1>::new(&job, rig.clone(), 0, EXACT);
    let width = camera.width as usize;
    let (mut fast, mut staged) = (RowScratch::<1>::default(), RowScratch::<1>::default());
    let mut fast_tracer = Tracer::new(&world, opts.trace);
    let mut staged_tracer = Tracer::new(&world, opts.trace);
    assert!(fast_tracer.eye_hit_applies());
    let mut hits = 0;
    for y in 0..camera.height {
        for pattern in [
            Pattern::Fixed {
                dx: 0.0,
                y: y as f32,
            },
            Pattern::Fixed {
                dx: -0.5,
                y: y as f32 - 0.5,
            },
            Pattern::Sobol {
                row: y,
                index: 3,
                seed: 1,
            },
        ] {
            let row = SampleRow::full(width, pattern);
            let mut a = vec![vec![Color::ZERO; width]];
            let mut b = vec![vec![Color::ZERO; width]];
            batch.trace_row(&mut fast_tracer, &row, &mut fast, &mut a);
            assert!(fast.groups.is_empty(), "the mono row grouped its samples");
            batch.eye_pass(&mut staged_tracer, &row, &mut staged);
            batch.group(&row, &mut staged);
            batch.shade_groups(&mut staged_tracer, &staged, &mut b);
            for (i, (ca, cb)) in a[0].iter().zip(&b[0]).enumerate() {
                let bits = |c: &Color| c.to_array().map(f32::to_bits);
                assert_eq!(bits(ca), bits(cb), "row {y}, sample {i}, {pattern:?}");
            }
            hits += staged.hits[0]
                .iter()
                .filter(|h| h.0 != PacketHits::<1>::NO_HIT)
                .count();
        }
    }
    assert!(hits > width * camera.height as usize, "{hits} hits");
    let (mut a, mut b) = (fast_tracer.finish(), staged_tracer.finish());
    (
        a.eye_pass_ns,
        a.shading_pass_ns,
        b.eye_pass_ns,
        b.shading_pass_ns,
    ) = (0, 0, 0, 0);
    // Both trace their eye rays eight to a descent where their signs
    // agree (the staged path's batch of one view takes eight samples a
    // packet, as the mono row does): the same packets, rays and hits.
    assert!(
        a.eye_packet_rays * 10 > a.rays.eye * 9 && a.eye_packets * 8 >= a.eye_packet_rays,
        "{} of {} eye rays in {} packets",
        a.eye_packet_rays,
        a.rays.eye,
        a.eye_packets
    );
    // The mono row shades eight neighbouring samples as one packet, the
    // staged path eight groups of one sample that hit something
    // (`shade_groups_packed`): the same rays, other descents and
    // secondary packets, and a shadow cache per lane.
    assert!(a.shared_secondary_rays > a.rays.reflected / 2, "{a:?}");
    assert!(b.shared_secondary_rays > b.rays.reflected / 2, "{b:?}");
    assert_eq!((a.grouped_samples, b.grouped_samples), (0, 0));
    for c in [&mut a, &mut b] {
        (c.shared_secondary, c.shared_secondary_rays) = (0, 0);
        (c.nodes, c.box_tests, c.prim_tests, c.prim_tests_in_lanes) = (0, 0, 0, 0);
        (
            c.closest_traversals,
            c.shadow_cache_tests,
            c.shadow_cache_hits,
        ) = (0, 0, 0);
    }
    assert_eq!(a, b);
}

/// Materials whose eye hits all shade to one colour are shaded once per
/// row worker and copied (`TwinBatch::flat`): the mono rows' colours and
/// counts are, bit for bit, those of shading every hit, on a scene
/// without lights (matte floor, sphere and cone: flat; a textured quad:
/// not), the same with an emissive and a pure-ambient material, and with
/// lights (only the pure-ambient material is flat). Each condition of
/// `shades_flat` left out fails here: a texture, a light, a mirror's ray,
/// BLEND coverage, corner colours.
#[test]
fn flat_materials_shade_as_every_hit_does() {
    use crate::render::tracer::{test_scene, unlit_test_scene};
    use crate::scene::{AlphaMode, MeshPolygon};
    let lit = test_scene();
    let unlit = unlit_test_scene(test_scene());
    let mut glowing = unlit.clone();
    glowing.materials[1].emission = Color::new(0.3, 0.1, 0.0);
    glowing.materials[0].kd = 0.0;
    let mut ambient_lit = lit.clone();
    let cone = &mut ambient_lit.materials[2];
    (cone.kd, cone.ks, cone.mirror) = (0.0, 0.0, 0.0);
    let mut mirror = unlit.clone();
    mirror.materials[1].mirror = 0.5;
    let mut blend = unlit.clone();
    (blend.materials[2].alpha_mode, blend.materials[2].alpha) = (AlphaMode::Blend, 0.5);
    let mut coloured = unlit.clone();
    let group = coloured.new_group();
    let quad = [
        Vec3::new(-2.2, -2.0, 0.2),
        Vec3::new(-0.2, -2.0, 0.2),
        Vec3::new(-0.2, -2.0, 2.2),
        Vec3::new(-2.2, -2.0, 2.2),
    ];
    let corners = [
        Color::new(1.0, 0.0, 0.0),
        Color::ONE,
        Color::new(0.0, 0.0, 1.0),
        Color::ONE,
    ];
    coloured.add_colored_mesh_polygon(
        &MeshPolygon {
            vertices: &quad,
            normals: None,
            uv: None,
            material: 0,
            group,
        },
        Some(&corners),
        &|| "quad".into(),
    );
    let mut flat_in = Vec::new();
    for (what, scene) in [
        ("no light", unlit),
        ("emission", glowing),
        ("lights, one pure ambient material", ambient_lit),
        ("lights", lit),
        ("a mirror", mirror),
        ("BLEND", blend),
        ("corner colours", coloured),
    ] {
        let world = World::new(scene);
        let camera = Camera::new(&world.scene.viewpoint, 48, 36);
        let rig = Rig::mono();
        let opts = RenderOptions::default();
        let cancel = CancelToken::new();
        let job = quiet_inputs(&world, &camera, &rig, &opts, &cancel);
        let fast = TwinBatch::<1>::new(&job, rig.clone(), 0, EXACT);
        let mut every = TwinBatch::<1>::new(&job, rig.clone(), 0, EXACT);
        every.flat.iter_mut().for_each(|f| *f = false);
        flat_in.push((what, fast.flat.iter().filter(|&&f| f).count()));
        let width = camera.width as usize;
        let (mut a_scratch, mut b_scratch) = (RowScratch::default(), RowScratch::default());
        let mut a_tracer = Tracer::new(&world, opts.trace);
        let mut b_tracer = Tracer::new(&world, opts.trace);
        let mut colours = std::collections::HashSet::new();
        for y in 0..camera.height {
            let row = SampleRow::centres(width, y);
            let mut a = vec![vec![Color::ZERO; width]];
            let mut b = vec![vec![Color::ZERO; width]];
            fast.trace_row(&mut a_tracer, &row, &mut a_scratch, &mut a);
            every.trace_row(&mut b_tracer, &row, &mut b_scratch, &mut b);
            for (i, (ca, cb)) in a[0].iter().zip(&b[0]).enumerate() {
                let bits = |c: &Color| c.to_array().map(f32::to_bits);
                assert_eq!(bits(ca), bits(cb), "{what}: row {y}, sample {i}");
                colours.insert(bits(cb));
            }
        }
        assert!(colours.len() > 20, "{what}: {} colours", colours.len());
        let (mut a, mut b) = (a_tracer.finish(), b_tracer.finish());
        (
            a.eye_pass_ns,
            a.shading_pass_ns,
            b.eye_pass_ns,
            b.shading_pass_ns,
        ) = (0, 0, 0, 0);
        assert_eq!(a, b, "{what}");
    }
    // Floor, sphere and cone; with an emissive sphere and a floor of no
    // diffuse term too; under lights the pure-ambient cone alone; then
    // the mirror sphere, the BLEND cone and the corner colours' scene
    // lose theirs.
    let expected = [
        ("no light", 3),
        ("emission", 3),
        ("lights, one pure ambient material", 1),
        ("lights", 0),
        ("a mirror", 2),
        ("BLEND", 2),
        ("corner colours", 0),
    ];
    assert_eq!(flat_in, expected);
}

/// The approximate pair paths shade their donors, the samples that take
/// a donor's light, and their exact groups eight lanes to a packet
/// (`packed`): their rows are, bit for bit, those of packets of one
/// lane (where each donor is lane 0 of its packet; each exact group is
/// shaded by `shade_group`, as a packet of its own), under the safe reprojection and the shared shading, each
/// with and without merged secondary rays, on a scene of shadows, faint
/// mirrors (their secondary colours differ from donor to donor; under
/// the shared shading with highlights, so that the colours are not taken
/// whole but shaded from the light), a mirror sphere and a mirror wall
/// (merged rays from exact groups, which a packet must not split).
#[test]
fn packed_approximations_are_the_one_lane_rows_bit_for_bit() {
    let text = "b 0.1 0.1 0.2\nv\nfrom 0 -8 3\nat 0 0 1\nup 0 0 1\nangle 45\n\
        hither 0.01\nresolution 64 48\nl -5 -5 6\nl 4 -3 5 0.6 0.5 0.4\n\
        f 0.8 0.8 0.7 0.8 0.05 20 0 1\np 4\n-6 -6 0\n6 -6 0\n6 6 0\n-6 6 0\n\
        f 0.9 0.2 0.2 0.9 0 1 0 1\ns -1.2 0 1 0.8\n\
        f 0.2 0.8 0.3 0.8 0.08 10 0 1\ns 1.2 0.5 0.9 0.7\n\
        f 0.9 0.9 0.9 0.1 0.8 100 0 1\ns 0 2 1.2 0.6\n\
        f 0.9 0.9 0.9 0.1 0.6 100 0 1\np 4\n-6 5 0\n6 5 0\n6 5 5\n-6 5 5\n";
    let base = crate::loaders::nff::parse_nff(
        text,
        std::path::Path::new("t.nff"),
        &crate::loaders::LoadOptions::default(),
    )
    .expect("test scene");
    let camera = Camera::new(&base.viewpoint, 96, 72);
    let rig = Rig::stereo(&camera, 0.3, None).expect("rig");
    let safe = Sharing::Reproject {
        threshold: Reprojection::DEFAULT_THRESHOLD,
    };
    let shared = Sharing::Cache { tolerance: 0.06 };
    for (what, sharing, merge) in [
        ("reprojection", safe, false),
        ("reprojection, merged rays", safe, true),
        ("shared shading", shared, false),
        ("shared shading, merged rays", shared, true),
    ] {
        let mut scene = base.clone();
        if sharing == shared {
            for m in scene.materials.iter_mut().filter(|m| m.mirror == 0.05) {
                m.ks = 0.4;
            }
        }
        let world = World::new(scene);
        let opts = RenderOptions::default();
        let shading = Shading {
            sharing,
            secondary: match merge {
                true => SecondaryRays::MergedOnPlanes,
                false => SecondaryRays::Own,
            },
        };
        let cancel = CancelToken::new();
        let job = quiet_inputs(&world, &camera, &rig, &opts, &cancel);
        let packed = TwinBatch::<2>::new(&job, rig.clone(), 0, shading);
        let mut one = TwinBatch::<2>::new(&job, rig.clone(), 0, shading);
        one.packet_lanes = 1;
        let (mut a_scratch, mut b_scratch) = (RowScratch::default(), RowScratch::default());
        let mut a_tracer = Tracer::new(&world, opts.trace);
        let mut b_tracer = Tracer::new(&world, opts.trace);
        let width = camera.width as usize;
        for y in 0..camera.height {
            let row = SampleRow::centres(width, y);
            let mut a = vec![vec![Color::ZERO; width]; 2];
            let mut b = vec![vec![Color::ZERO; width]; 2];
            packed.trace_row(&mut a_tracer, &row, &mut a_scratch, &mut a);
            one.trace_row(&mut b_tracer, &row, &mut b_scratch, &mut b);
            for v in 0..2 {
                for (i, (ca, cb)) in a[v].iter().zip(&b[v]).enumerate() {
                    let bits = |c: &Color| c.to_array().map(f32::to_bits);
                    assert_eq!(bits(ca), bits(cb), "{what}: row {y}, view {v}, sample {i}");
                }
            }
        }
        let (a, b) = (a_tracer.finish(), b_tracer.finish());
        let taken = a.paper.reprojected + a.fast.cache.hits - a.fast.cache.colour_hits;
        assert!(taken > 1000, "{what}: {taken} samples took a donor's light");
        assert_eq!(
            (
                a.paper.reprojected,
                a.fast.cache.hits,
                a.fast.cache.colour_hits,
                a.paper.merged_rays
            ),
            (
                b.paper.reprojected,
                b.fast.cache.hits,
                b.fast.cache.colour_hits,
                b.paper.merged_rays
            ),
            "{what}"
        );
        assert_eq!(
            a.paper.merged_rays > 0,
            merge,
            "{what}: {} merged rays",
            a.paper.merged_rays
        );
        assert!(
            a.closest_traversals < b.closest_traversals,
            "{what}: descents shared"
        );
    }
}

/// Under a strongly converged rig (image shifts of many pixels), the
/// samples the grouping puts together see the same surface point: the
/// projection into the other view, shift included, is right. A wrong sign
/// on the shift still groups samples that hit something, only of points
/// far apart (its cost shows only in node visits).
#[test]
fn grouped_samples_see_the_same_point_under_a_converged_rig() {
    let scene = crate::render::example_scene();
    let distance = (scene.viewpoint.at - scene.viewpoint.from).length() as f64;
    let world = World::new(scene);
    let camera = Camera::new(&world.scene.viewpoint, 96, 72);
    let rig = Rig::stereo(&camera, 0.3, Some(distance * 0.4)).expect("rig");
    assert!(
        rig.views[0].shift - rig.views[1].shift >= 4,
        "{:?}",
        rig.views
    );
    let world_ref = &world;
    let opts = RenderOptions::default();
    let cancel = CancelToken::new();
    let job = quiet_inputs(world_ref, &camera, &rig, &opts, &cancel);
    let batch = TwinBatch::<2>::new(&job, rig.clone(), 0, EXACT);
    let width = camera.width as usize;
    let mut scratch = RowScratch::<2>::default();
    let mut tracer = Tracer::new(&world, RenderOptions::default().trace);
    let (mut pairs, mut same) = (0, 0);
    for y in 0..camera.height {
        let row = SampleRow::centres(width, y);
        batch.eye_pass(&mut tracer, &row, &mut scratch);
        batch.group(&row, &mut scratch);
        for group in &scratch.groups {
            if let [Some(i), Some(k)] = *group {
                pairs += 1;
                if batch.same_point(&scratch, i, 1, k) {
                    same += 1;
                }
            }
        }
    }
    assert!(pairs > width * camera.height as usize / 2, "{pairs} pairs");
    assert!(
        same * 100 >= pairs * 95,
        "{same} of {pairs} pairs see one point"
    );
}

/// A pair's groups are shaded four to a packet of eight lanes
/// (`shade_groups_packed`): every sample's colour is, bit for bit, the
/// one its group gets shaded alone (`shade_group`), and the secondary
/// rays go down in packets of more lanes than a group has (two).
#[test]
fn a_pairs_groups_are_shaded_four_to_a_packet() {
    let world = World::new(crate::render::example_scene());
    let camera = Camera::new(&world.scene.viewpoint, 96, 72);
    let rig = Rig::stereo(&camera, 0.2, None).expect("rig");
    let opts = RenderOptions::default();
    let cancel = CancelToken::new();
    let job = quiet_inputs(&world, &camera, &rig, &opts, &cancel);
    let batch = TwinBatch::<2>::new(&job, rig.clone(), 0, EXACT);
    let width = camera.width as usize;
    let mut scratch = RowScratch::<2>::default();
    let mut eye = Tracer::new(&world, opts.trace);
    let mut packed = Tracer::new(&world, opts.trace);
    let mut alone = Tracer::new(&world, opts.trace);
    let mut shaded = 0;
    for y in 0..camera.height {
        let row = SampleRow::centres(width, y);
        batch.eye_pass(&mut eye, &row, &mut scratch);
        batch.group(&row, &mut scratch);
        let mut a = vec![vec![Color::ZERO; width]; 2];
        let mut b = vec![vec![Color::ZERO; width]; 2];
        batch.shade_groups(&mut packed, &scratch, &mut a);
        for group in &scratch.groups {
            batch.shade_group(&mut alone, &scratch, group, &mut b);
        }
        for v in 0..2 {
            for (i, (ca, cb)) in a[v].iter().zip(&b[v]).enumerate() {
                let bits = |c: &Color| c.to_array().map(f32::to_bits);
                assert_eq!(bits(ca), bits(cb), "row {y}, view {v}, sample {i}");
            }
        }
        shaded += scratch.groups.len();
    }
    assert!(shaded > width * camera.height as usize, "{shaded} groups");
    let (a, b) = (packed.finish(), alone.finish());
    assert_eq!(
        (a.rays, a.grouped_samples),
        (b.rays, b.grouped_samples),
        "the same rays, the same groups"
    );
    assert!(a.rays.reflected > 1000 && a.grouped_samples > 0, "{a:?}");
    // Lanes per packet of secondary rays: at most two alone.
    let lanes = |c: &crate::render::counts::TraceCounts| {
        c.shared_secondary_rays as f64 / c.shared_secondary.max(1) as f64
    };
    assert!(lanes(&b) <= 2.0, "alone: {}", lanes(&b));
    assert!(
        lanes(&a) > 4.0,
        "packed: {} lanes a secondary packet",
        lanes(&a)
    );
}

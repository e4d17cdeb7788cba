//! The oracle: view `v` of a stereo or multi-view render by the twin method
//! equals, bit for bit, a mono render of a rig that holds view `v` alone.
//!
//! The other exactness tests compare the twin method with `--method
//! independent`, which runs through the same driver, film, refiner and
//! tracer set-up with all the views of the rig. Here the reference is a
//! render of ONE view: a camera whose eye is moved by the view's offset
//! (computed here), a one-view rig with the view's whole-pixel image shift,
//! the reference method. Nothing of the multi-view machinery (batches of
//! views, packets of lanes, grouping, shared shading, the shadow cache's
//! history across lanes) takes part in it.
//!
//! The scenes are generated, different for every seed, in the style of the
//! hidden scenes that found earlier bugs: mirrors (walls parallel to the eyes,
//! floors), glass spheres, cones and cylinders, smooth patches, many coloured
//! lights, objects close to the eyes that the views see differently, and an
//! enclosing sphere hundreds of millions of units wide (where a primitive's
//! own test reports hits outside its box).
//!
//! At pixel centres a second reference leaves out the renderer's driver,
//! rows and film too: each pixel's ray traced by `Tracer::trace_eye` alone,
//! one tracer for the whole image.
//!
//! What is exact under each sampling (README, docs/stereo.md):
//! every sampling: pixel centres, the SPD corners, `--samples N` (stratified,
//! any filter) and the adaptive refinement (the default), where each view
//! refines its own pixels. Every view equals its own mono render (tests
//! named `..._equals_its_mono_render`).

use std::fmt::Write as _;
use std::path::Path;

use twinray::bvh::Packet;
use twinray::loaders::nff::parse_nff;
use twinray::loaders::LoadOptions;
use twinray::render::{
    render, Filter, RenderOptions, RenderOutput, Sampling, TraceSettings, Tracer, ViewMethod,
};
use twinray::rig::{Camera, Rig, View};
use twinray::{Image, World};

/// A random scene as NFF text, `width` x `height` pixels.
fn random_scene(seed: u64, width: u32, height: u32, huge_sphere: bool) -> String {
    let mut rng = fastrand::Rng::with_seed(seed);
    let mut r = |lo: f32, hi: f32| lo + (hi - lo) * rng.f32();
    let mut nff = String::new();
    let w = &mut nff;
    let _ = writeln!(
        w,
        "b {:.3} {:.3} {:.3}",
        r(0.0, 0.3),
        r(0.0, 0.3),
        r(0.1, 0.4)
    );
    let _ = writeln!(
        w,
        "v\nfrom {:.3} {:.3} {:.3}\nat {:.3} {:.3} {:.3}\nup 0 0 1\nangle {:.1}\nhither 0.01\nresolution {width} {height}",
        r(-1.0, 1.0),
        r(-9.0, -6.0),
        r(1.0, 3.0),
        r(-0.5, 0.5),
        r(-0.5, 0.5),
        r(0.3, 1.2),
        r(35.0, 55.0)
    );
    // Many lights, coloured, some low and grazing.
    for _ in 0..(5 + (seed % 4)) {
        let _ = writeln!(
            w,
            "l {:.3} {:.3} {:.3} {:.3} {:.3} {:.3}",
            r(-8.0, 8.0),
            r(-8.0, 4.0),
            r(0.3, 9.0),
            r(0.2, 0.6),
            r(0.2, 0.6),
            r(0.2, 0.6)
        );
    }
    // Materials: f r g b Kd Ks Shine T ior.
    let diffuse = |r: &mut dyn FnMut(f32, f32) -> f32| {
        format!(
            "f {:.3} {:.3} {:.3} {:.3} {:.3} {:.1} 0 1",
            r(0.2, 1.0),
            r(0.2, 1.0),
            r(0.2, 1.0),
            r(0.4, 0.9),
            r(0.0, 0.3),
            r(5.0, 60.0)
        )
    };
    let mirror = |r: &mut dyn FnMut(f32, f32) -> f32| {
        format!(
            "f {:.3} {:.3} {:.3} {:.3} {:.3} {:.1} 0 1",
            r(0.6, 1.0),
            r(0.6, 1.0),
            r(0.6, 1.0),
            r(0.0, 0.3),
            r(0.6, 0.95),
            r(30.0, 200.0)
        )
    };
    let glass = |r: &mut dyn FnMut(f32, f32) -> f32| {
        format!(
            "f {:.3} {:.3} {:.3} {:.3} {:.3} {:.1} {:.3} {:.3}",
            r(0.7, 1.0),
            r(0.7, 1.0),
            r(0.7, 1.0),
            r(0.0, 0.2),
            r(0.1, 0.5),
            r(30.0, 200.0),
            r(0.5, 0.9),
            r(1.2, 1.7)
        )
    };
    // A checkered floor, slightly reflective: coplanar tiles, parallel to the eyes.
    let tiles = [diffuse(&mut r), mirror(&mut r)];
    for i in -3..3 {
        for j in -2..4 {
            let _ = writeln!(w, "{}", tiles[((i + j) & 1) as usize]);
            let (x, y) = (i as f32 * 2.0, j as f32 * 2.0);
            let _ = writeln!(
                w,
                "p 4\n{x} {y} 0\n{} {y} 0\n{} {} 0\n{x} {} 0",
                x + 2.0,
                x + 2.0,
                y + 2.0,
                y + 2.0
            );
        }
    }
    // A mirror back wall facing the eyes.
    let _ = writeln!(w, "{}", mirror(&mut r));
    let _ = writeln!(w, "p 4\n-6 8 0\n6 8 0\n6 8 5\n-6 8 5");
    // Spheres of every kind, some close to the eyes.
    for k in 0..(6 + seed % 5) {
        let m = match k % 3 {
            0 => diffuse(&mut r),
            1 => mirror(&mut r),
            _ => glass(&mut r),
        };
        let near = k % 4 == 3;
        let (y, radius) = if near {
            (r(-6.0, -4.5), r(0.1, 0.3))
        } else {
            (r(-3.0, 6.0), r(0.3, 1.2))
        };
        let _ = writeln!(
            w,
            "{m}\ns {:.3} {y:.3} {:.3} {radius:.3}",
            r(-4.0, 4.0),
            r(0.2, 2.5)
        );
    }
    // Cones and cylinders, upright and tilted, one open cone seen from inside.
    for k in 0..(3 + seed % 3) {
        let m = if k % 2 == 0 {
            diffuse(&mut r)
        } else {
            glass(&mut r)
        };
        let (x, y) = (r(-4.0, 4.0), r(-2.0, 5.0));
        let top_radius = if k == 2 { 0.0 } else { r(0.0, 0.6) };
        let base_radius = if k == 1 { -r(0.3, 0.8) } else { r(0.2, 0.8) };
        let top_radius = if k == 1 { -top_radius } else { top_radius };
        let _ = writeln!(
            w,
            "{m}\nc\n{x:.3} {y:.3} 0 {base_radius:.3}\n{:.3} {:.3} {:.3} {top_radius:.3}",
            x + r(-0.8, 0.8),
            y + r(-0.8, 0.8),
            r(0.8, 2.5)
        );
    }
    // Smooth patches: triangles with per-corner normals.
    for _ in 0..3 {
        let m = mirror(&mut r);
        let (x, y, z) = (r(-3.0, 3.0), r(-1.0, 4.0), r(0.5, 2.5));
        let _ = writeln!(
            w,
            "{m}\npp 3\n{x:.3} {y:.3} {z:.3} -0.3 -1 0.2\n{:.3} {y:.3} {:.3} 0.3 -1 0.2\n{:.3} {:.3} {:.3} 0 -1 -0.3",
            x + 1.0,
            z + 0.2,
            x + 0.5,
            y + 0.3,
            z + 1.0
        );
    }
    if huge_sphere {
        // Encloses the eyes and the scene: its wall is lit from inside, and the
        // shadow rays from it, 1e8 away, pass the cones and spheres.
        let _ = writeln!(w, "f 0.5 0.6 0.7 0.3 0.1 10 0.85 1\ns 0 0 0 99999999");
    }
    nff
}

fn world(seed: u64, width: u32, height: u32, huge_sphere: bool) -> World {
    let text = random_scene(seed, width, height, huge_sphere);
    let scene = parse_nff(&text, Path::new("random.nff"), &LoadOptions::default())
        .unwrap_or_else(|e| panic!("seed {seed}: the generated scene loads: {e}\n{text}"));
    World::new(scene)
}

fn options(method: ViewMethod, sampling: Sampling, views_per_batch: usize) -> RenderOptions {
    RenderOptions {
        trace: TraceSettings::default(),
        method,
        sampling,
        views_per_batch,
        ..RenderOptions::default()
    }
}

fn run(world: &World, camera: &Camera, rig: &Rig, opts: &RenderOptions) -> RenderOutput {
    render(world, camera, rig, opts, &|_, _| {}).expect("render")
}

/// View `view` alone: the camera's eye moved by its offset along the right
/// axis, a one-view rig with its image shift, rendered by the reference method.
fn mono_render_of(world: &World, camera: &Camera, view: View, sampling: Sampling) -> Image {
    let mut moved = camera.clone();
    if view.offset != 0.0 {
        moved.eye = camera.eye + camera.right * view.offset;
    }
    let one_view = Rig {
        views: vec![View {
            offset: 0.0,
            shift: view.shift,
        }],
        convergence: None,
        effective_convergence: None,
    };
    let out = run(
        world,
        &moved,
        &one_view,
        &options(ViewMethod::Independent, sampling, 0),
    );
    out.images.into_iter().next().expect("one view")
}

/// The first pixel whose bits differ, and how many do.
fn differences(a: &Image, b: &Image) -> Option<(usize, usize, usize)> {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let bits = |c: &twinray::math::Color| c.to_array().map(f32::to_bits);
    let differing: Vec<usize> = (0..a.pixels.len())
        .filter(|&i| bits(&a.pixels[i]) != bits(&b.pixels[i]))
        .collect();
    let w = a.width as usize;
    differing.first().map(|&i| (i % w, i / w, differing.len()))
}

/// The rigs of one check: views, interaxial, convergence.
struct RigCase {
    views: usize,
    interaxial: f32,
    /// Times the distance to the scene's `at` point; `None`: parallel.
    convergence: Option<f64>,
}

/// For every rig of `cases` on the scene of `seed`: every view of the twin
/// render equals its mono render. Returns the number of views checked.
fn check_views_against_mono(
    seed: u64,
    (width, height): (u32, u32),
    huge_sphere: bool,
    cases: &[RigCase],
    sampling: Sampling,
    views_per_batch: usize,
) -> usize {
    let world = world(seed, width, height, huge_sphere);
    let camera = Camera::new(&world.scene.viewpoint, width, height);
    let at = (world.scene.viewpoint.at - world.scene.viewpoint.from).length() as f64;
    let mut checked = 0;
    for case in cases {
        let convergence = case.convergence.map(|c| c * at);
        let rig = Rig::multi_view(&camera, case.views, case.interaxial, convergence)
            .expect("rig fits the image");
        let twin = run(
            &world,
            &camera,
            &rig,
            &options(ViewMethod::twin(), sampling, views_per_batch),
        );
        assert_eq!(twin.images.len(), case.views);
        for (v, view) in rig.views.iter().enumerate() {
            let mono = mono_render_of(&world, &camera, *view, sampling);
            if let Some((x, y, count)) = differences(&twin.images[v], &mono) {
                panic!(
                    "seed {seed} {width}x{height}{}, {} views {} apart, convergence {convergence:?}, \
                     {sampling:?}, batches of {views_per_batch}: view {v} (offset {}, shift {}) \
                     differs from its mono render in {count} pixels, first at ({x}, {y}): {:?} vs {:?}",
                    if huge_sphere { " in a huge sphere" } else { "" },
                    case.views,
                    case.interaxial,
                    view.offset,
                    view.shift,
                    twin.images[v].pixels[y * width as usize + x],
                    mono.pixels[y * width as usize + x],
                );
            }
            checked += 1;
        }
        // The scene is not empty: the views saw something to disagree about.
        assert!(twin.counts.rays.eye_hit > 0 && twin.counts.rays.shadow > 0);
    }
    checked
}

const STEREO: [RigCase; 3] = [
    RigCase {
        views: 2,
        interaxial: 0.3,
        convergence: None,
    },
    RigCase {
        views: 2,
        interaxial: 0.45,
        convergence: Some(0.6),
    },
    RigCase {
        views: 2,
        interaxial: 1.2,
        convergence: Some(1.0),
    },
];

const MULTI_VIEW: [RigCase; 2] = [
    RigCase {
        views: 5,
        interaxial: 0.12,
        convergence: None,
    },
    RigCase {
        views: 6,
        interaxial: 0.2,
        convergence: Some(0.8),
    },
];

#[test]
fn every_stereo_view_at_pixel_centres_equals_its_mono_render() {
    let mut checked = 0;
    for seed in 0..2 {
        checked +=
            check_views_against_mono(seed, (256, 256), false, &STEREO[1..2], Sampling::Centers, 0);
    }
    for seed in 2..8 {
        checked +=
            check_views_against_mono(seed, (96, 64), seed % 2 == 0, &STEREO, Sampling::Centers, 0);
    }
    assert_eq!(checked, 2 * 2 + 6 * 6);
}

#[test]
fn every_view_of_n_views_at_pixel_centres_equals_its_mono_render() {
    let mut checked = 0;
    // Batches of 4 (the default: 5 views are a packet of 4 and one of 1), of
    // 3 (two packets of 3 lanes padded to 4), and all in one packet of 8.
    for (seed, batch) in [(10, 0), (11, 3), (12, 8)] {
        checked += check_views_against_mono(
            seed,
            (80, 60),
            seed == 11,
            &MULTI_VIEW,
            Sampling::Centers,
            batch,
        );
    }
    assert_eq!(checked, 3 * 11);
}

#[test]
fn every_view_with_4_stratified_samples_equals_its_mono_render() {
    let four = |filter| Sampling::Stratified {
        samples: 4,
        filter,
        seed: 0,
    };
    let mut checked =
        check_views_against_mono(20, (256, 256), false, &STEREO[2..3], four(Filter::Box), 0);
    checked += check_views_against_mono(21, (72, 48), true, &STEREO, four(Filter::Gaussian), 0);
    checked += check_views_against_mono(22, (64, 48), false, &MULTI_VIEW, four(Filter::Tent), 0);
    assert_eq!(checked, 2 + 6 + 11);
}

#[test]
fn every_view_with_spd_corners_equals_its_mono_render() {
    let checked = check_views_against_mono(30, (64, 48), true, &STEREO, Sampling::Corners, 0);
    assert_eq!(checked, 6);
}

#[test]
fn every_view_under_adaptive_sampling_equals_its_mono_render() {
    // Each view refines its cells from its own corners: its pixels, and the
    // points traced for it, are those of the view rendered alone, whether a
    // point goes as the batch (every view of it refines there) or alone.
    let sampling = Sampling::Adaptive {
        threshold: Sampling::DEFAULT_THRESHOLD,
        max_samples: 16,
    };
    let mut checked = check_views_against_mono(40, (96, 64), true, &STEREO, sampling, 0);
    checked += check_views_against_mono(41, (48, 32), false, &MULTI_VIEW, sampling, 0);
    // Batches of two: six views are three pairs.
    checked += check_views_against_mono(42, (48, 32), false, &MULTI_VIEW[1..], sampling, 2);
    let deeper = Sampling::Adaptive {
        threshold: 0.01,
        max_samples: 64,
    };
    checked += check_views_against_mono(43, (64, 48), false, &STEREO[1..2], deeper, 0);
    assert_eq!(checked, 6 + 11 + 6 + 2);
}

/// View `view` at pixel centres without the renderer's driver, sampler or
/// film: one ray per pixel through one tracer (whose shadow cache carries
/// over the whole image, unlike the renderer's, fresh for every row).
fn traced_one_by_one(world: &World, camera: &Camera, view: View) -> Image {
    let eye = if view.offset != 0.0 {
        camera.eye + camera.right * view.offset
    } else {
        camera.eye
    };
    let mut tracer = Tracer::new(world, TraceSettings::default());
    let mut image = Image::new(camera.width, camera.height);
    for y in 0..camera.height {
        for x in 0..camera.width {
            let column = (x as i32 + view.shift) as f32;
            let packet = Packet {
                origins: [eye],
                dirs: [camera.direction(column, y as f32)],
                t_min: camera.hither,
                t_max: [f32::INFINITY],
                mask: 1,
            };
            image.pixels[(y * camera.width + x) as usize] = tracer.trace_eye(&packet, &[0])[0];
        }
    }
    image
}

#[test]
fn every_view_at_pixel_centres_equals_its_rays_traced_one_by_one() {
    // The most independent reference: no driver, rows, film or batches.
    for (seed, case) in [(50, &STEREO[1]), (51, &MULTI_VIEW[1])] {
        let world = world(seed, 80, 60, seed == 51);
        let camera = Camera::new(&world.scene.viewpoint, 80, 60);
        let at = (world.scene.viewpoint.at - world.scene.viewpoint.from).length() as f64;
        let rig = Rig::multi_view(
            &camera,
            case.views,
            case.interaxial,
            case.convergence.map(|c| c * at),
        )
        .expect("rig");
        let twin = run(
            &world,
            &camera,
            &rig,
            &options(ViewMethod::twin(), Sampling::Centers, 0),
        );
        for (v, view) in rig.views.iter().enumerate() {
            let traced = traced_one_by_one(&world, &camera, *view);
            assert_eq!(
                differences(&twin.images[v], &traced),
                None,
                "seed {seed}, view {v}: (x, y, differing pixels)"
            );
        }
    }
}

//! `ToArgs::to_args` is the inverse of the `render` command's flags: the
//! arguments it gives, passed to `twinray render --print-job`, describe the
//! same spec (the preview shows them as the command reproducing its view).

use std::process::Command;

use twinray::job::{
    AnaglyphSpec, CutSpec, InterlaceSpec, JobSpec, LayoutSpec, LightSpec, MethodName, ShotRigSpec,
    TileSpec, TonemapSpec, UpAxisSpec,
};
use twinray::render::{Filter, ReprojectMode};
use twinray::video::Codec;
use twinray_args::ToArgs;

/// The spec `twinray render ARGS --print-job` prints.
fn printed(args: &[String]) -> JobSpec {
    let out = Command::new(env!("CARGO_BIN_EXE_twinray"))
        .arg("render")
        .args(args)
        .arg("--print-job")
        .output()
        .expect("the binary runs");
    assert!(
        out.status.success(),
        "twinray render {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    JobSpec::from_json(&String::from_utf8_lossy(&out.stdout)).unwrap()
}

fn specs() -> Vec<JobSpec> {
    let base = JobSpec::new("scenes/example.nff", "out dir/pair.png");
    let mut stereo = base.clone();
    stereo.camera.size = Some([480, 270]);
    stereo.camera.from = Some([-1.5, 2.25, 4.0]);
    stereo.camera.at = Some([0.0, -0.5, 0.1]);
    stereo.camera.up = Some([0.0, 1.0, 0.0]);
    stereo.camera.fov = Some(37.5);
    stereo.rig.stereo = true;
    stereo.rig.interaxial = Some("0.123".into());
    stereo.rig.convergence = Some("near".into());
    stereo.rig.depth_budget = Some("-0.5%,+1.5%".into());
    stereo.rig.floating_window = true;
    stereo.rig.screen_width = 2.5;
    stereo.output.layout = LayoutSpec::Anaglyph;
    stereo.output.anaglyph = Some(AnaglyphSpec::GreenMagenta);
    stereo.output.srgb = true;
    stereo.sampling.samples = Some(4);
    stereo.sampling.filter = Some(Filter::Gaussian);
    stereo.sampling.seed = Some(7);
    stereo.method.name = MethodName::Fast;
    stereo.method.tolerance = Some(0.005);
    stereo.trace.max_depth = 3;
    stereo.trace.min_weight = Some(0.01);
    stereo.trace.threads = Some(2);

    let mut views = base.clone();
    views.rig.views = Some(8);
    views.rig.view_cone = Some(20.0);
    views.method.name = MethodName::Independent;
    views.output.layout = LayoutSpec::Quilt;
    views.output.quilt = Some("4x2".into());
    views.sampling.adaptive = Some(0.02);
    views.sampling.max_samples = Some(64);
    views.limits.max_resolution = 4096;
    views.limits.max_vertices = 99;
    views.limits.max_triangles = 12345;
    views.output.stats = Some("stats.json".into());

    let mut interlaced = base.clone();
    interlaced.rig.stereo = true;
    interlaced.rig.convergence = Some("-2".into()); // refused by check, not by the flags' parser
    interlaced.output.layout = LayoutSpec::Interlace;
    interlaced.output.interlace = Some(InterlaceSpec::Checker);
    interlaced.sampling.spd = true;
    interlaced.method.cut = Some(CutSpec::Distance(12.5));
    interlaced.camera.camera = Some("Camera.001".into());

    let mut depth = base.clone();
    depth.output.path = "d.exr".into();
    depth.output.depth = true;
    depth.rig.stereo = true;
    depth.output.layout = LayoutSpec::Sbs;
    depth.output.squeeze = true;
    depth.method.merge_secondary = true;
    depth.method.cut = Some(CutSpec::Parallax(0.75));
    depth.method.reproject = Some(ReprojectMode::Paper);
    depth.method.reproject_threshold = Some(0.25);

    // The look of the render and the surroundings.
    let mut studio = base.clone();
    studio.rig.views = Some(6);
    studio.method.reproject = Some(ReprojectMode::Safe);
    studio.output.linear = true;
    studio.output.exposure = -1.5;
    studio.output.tonemap = TonemapSpec::Agx;
    studio.studio.background = Some([0.25, 0.5, 1.0]);
    studio.studio.up_axis = UpAxisSpec::Z;
    studio.studio.lights = vec![
        LightSpec {
            position: [-4.0, 2.0, 1.0],
            color: [1.0; 3],
        },
        LightSpec {
            position: [1.0, 2.0, 3.0],
            color: [0.5, 0.25, 1.0],
        },
    ];
    studio.studio.ground = true;

    let mut env = base.clone();
    env.studio.env = Some("sky dome.hdr".into());
    env.output.tonemap = TonemapSpec::Aces;

    // An animation shared across machines, and a tile of a still.
    let mut shot = base.clone();
    shot.output.path = "shot.mp4".into();
    shot.animation.frames = Some("0..47".into());
    shot.animation.fps = 30.0;
    shot.animation.orbit = Some(-90.0);
    shot.animation.rig = ShotRigSpec::PerFrame;
    shot.animation.skip_existing = true;
    shot.animation.only = Some("12..23".into());
    shot.animation.clip = Some("Walk".into());
    shot.animation.codec = Codec::Hevc;
    shot.animation.crf = Some(24);

    let mut path = base.clone();
    path.animation.frames = Some("1..10".into());
    path.animation.path = Some("keys.txt".into());

    let mut tile = base.clone();
    tile.tile = Some(TileSpec { index: 2, count: 5 });

    vec![
        base, stereo, views, interlaced, depth, studio, env, shot, path, tile,
    ]
}

#[test]
fn to_args_gives_the_flags_of_the_spec() {
    for spec in specs() {
        let args = spec.to_args();
        assert_eq!(printed(&args), spec, "{args:?}");
    }
}

#[test]
fn defaults_are_left_out_and_negative_values_joined() {
    let base = JobSpec::new("a.nff", "b.png");
    assert_eq!(base.to_args(), vec!["a.nff", "-o", "b.png"]);
    let mut spec = base;
    spec.rig.stereo = true;
    spec.rig.depth_budget = Some("-6px,12px".into());
    spec.camera.from = Some([-1.0, 0.0, 2.0]);
    let args = spec.to_args();
    assert!(
        args.contains(&"--depth-budget=-6px,12px".to_string()),
        "{args:?}"
    );
    assert!(args.contains(&"--from=-1,0,2".to_string()), "{args:?}");
}

/// A vector whose first number is negative (`--from -4.9,0,1`) is the
/// flag's value, not a flag of its own, as `--from=-4.9,0,1` is.
#[test]
fn negative_vectors_are_values_not_flags() {
    let args: Vec<String> = [
        "scenes/example.nff",
        "-o",
        "x.png",
        "--from",
        "-4.9,0,1",
        "--at",
        "-1,-2.5,-3",
        "--up",
        "-0,-1,0",
        "--light",
        "-4,2,1:1,0.5,0.25",
        "--light",
        "-1e1,-2,-3",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let spec = printed(&args);
    assert_eq!(spec.camera.from, Some([-4.9, 0.0, 1.0]));
    assert_eq!(spec.camera.at, Some([-1.0, -2.5, -3.0]));
    assert_eq!(spec.camera.up, Some([-0.0, -1.0, 0.0]));
    let lights: Vec<[f32; 3]> = spec.studio.lights.iter().map(|l| l.position).collect();
    assert_eq!(lights, vec![[-4.0, 2.0, 1.0], [-10.0, -2.0, -3.0]]);
    assert_eq!(spec.studio.lights[0].color, [1.0, 0.5, 0.25]);
    // The `=` form gives the same spec.
    let joined: Vec<String> = [
        "scenes/example.nff",
        "-o",
        "x.png",
        "--from=-4.9,0,1",
        "--at=-1,-2.5,-3",
        "--up=-0,-1,0",
        "--light=-4,2,1:1,0.5,0.25",
        "--light=-1e1,-2,-3",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    assert_eq!(printed(&joined), spec);
}

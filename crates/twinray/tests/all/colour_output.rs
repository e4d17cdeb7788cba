//! The colour of output files: 8-bit outputs are sRGB-encoded by default,
//! `linear` stores the values as rendered, exposure and tone curves apply to
//! 8-bit outputs only, and float outputs keep the rendered values.

use std::path::{Path, PathBuf};

use twinray::job::{CancelToken, Job, JobSpec, LayoutSpec, TonemapSpec};

/// A scene that is its background, linear grey 0.5, everywhere in view
/// (its one sphere is behind the camera).
const GREY: &str = "b 0.5 0.5 0.5\nv\nfrom 0 -5 1\nat 0 0 0\nup 0 0 1\nangle 40\nhither 0.01\n\
resolution 4 4\nl 2 -3 4\nf 1 1 1 1 0 0 0 1\ns 0 -50 1 1\n";

/// sRGB-encoded 0.5: 1.055 · 0.5^(1/2.4) − 0.055 = 0.7354 → 188 of 255.
const SRGB_HALF: u8 = 188;
/// 0.5 stored as it is: 127.5 → 128.
const LINEAR_HALF: u8 = 128;

struct Setup {
    _dir: tempfile::TempDir,
    scene: PathBuf,
    out: PathBuf,
}

fn setup() -> Setup {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("grey.nff");
    std::fs::write(&scene, GREY).unwrap();
    let out = dir.path().to_path_buf();
    Setup {
        _dir: dir,
        scene,
        out,
    }
}

fn run(spec: JobSpec) -> Vec<PathBuf> {
    let (written, _) = Job::run(spec, &|_, _| {}, &CancelToken::new()).expect("renders");
    written
}

fn spec(s: &Setup, name: &str) -> JobSpec {
    let mut spec = JobSpec::new(&s.scene, s.out.join(name));
    spec.sampling.samples = Some(1);
    spec
}

/// Every 8-bit value of the file's pixels.
fn bytes(path: &Path) -> Vec<u8> {
    image::open(path).expect("8-bit image").to_rgb8().into_raw()
}

fn all_equal(path: &Path, want: u8, tolerance: u8) {
    let b = bytes(path);
    assert!(!b.is_empty());
    for &v in &b {
        assert!(
            v.abs_diff(want) <= tolerance,
            "{}: {v}, expected {want}",
            path.display()
        );
    }
}

#[test]
fn png_of_linear_grey_has_the_srgb_code_value() {
    let s = setup();
    let written = run(spec(&s, "grey.png"));
    all_equal(&written[0], SRGB_HALF, 0);
}

#[test]
fn linear_opts_out_and_srgb_is_still_accepted() {
    let s = setup();
    let mut linear = spec(&s, "linear.png");
    linear.output.linear = true;
    all_equal(&run(linear)[0], LINEAR_HALF, 0);
    let mut old = spec(&s, "old.png");
    old.output.srgb = true;
    all_equal(&run(old)[0], SRGB_HALF, 0);
    let mut both = spec(&s, "both.png");
    both.output.srgb = true;
    both.output.linear = true;
    assert!(Job::check(both).is_err());
}

#[test]
fn every_8bit_layout_is_srgb_encoded() {
    let s = setup();
    // JPEG: lossy, but a flat grey stays within a step or two.
    all_equal(&run(spec(&s, "grey.jpg"))[0], SRGB_HALF, 2);
    let mut stereo = spec(&s, "ana.png");
    stereo.rig.stereo = true;
    stereo.rig.interaxial = Some("0.1".into());
    stereo.output.layout = LayoutSpec::Anaglyph;
    stereo.output.anaglyph = Some(twinray::job::AnaglyphSpec::Gray);
    // Gray anaglyph of grey eyes: grey luma in every channel.
    all_equal(&run(stereo.clone())[0], SRGB_HALF, 0);
    stereo.output.layout = LayoutSpec::Sbs;
    stereo.output.anaglyph = None;
    stereo.output.path = s.out.join("sbs.png");
    all_equal(&run(stereo.clone())[0], SRGB_HALF, 0);
    stereo.output.layout = LayoutSpec::Mpo;
    stereo.output.path = s.out.join("pair.mpo");
    let mpo = run(stereo)[0].clone();
    // The first picture of an MPO is a plain JPEG.
    let first = image::load_from_memory_with_format(
        &std::fs::read(&mpo).unwrap(),
        image::ImageFormat::Jpeg,
    )
    .unwrap()
    .to_rgb8()
    .into_raw();
    assert!(
        first.iter().all(|v| v.abs_diff(SRGB_HALF) <= 2),
        "{first:?}"
    );
    let mut quilt = spec(&s, "q.png");
    quilt.output.layout = LayoutSpec::Quilt;
    quilt.output.quilt = Some("2x1".into());
    all_equal(&run(quilt)[0], SRGB_HALF, 0);
}

#[test]
fn exposure_and_tone_curves_apply_to_8bit_outputs_only() {
    let s = setup();
    let mut darker = spec(&s, "darker.png");
    darker.output.exposure = -1.0;
    // 0.25 linear: sRGB 0.5371 → 137.
    all_equal(&run(darker)[0], 137, 0);
    let mut aces = spec(&s, "aces.png");
    aces.output.tonemap = TonemapSpec::Aces;
    // ACES fit of 0.5: 0.5·1.285 / (0.5·1.805 + 0.14) = 0.6163 → sRGB 0.8073 → 206.
    all_equal(&run(aces)[0], 206, 0);
    let mut exr = spec(&s, "grey.exr");
    exr.output.exposure = 2.0;
    let written = run(exr);
    let img = twinray::output::read_image(&written[0]).unwrap();
    assert!(img
        .pixels
        .iter()
        .all(|c| c.x == 0.5 && c.y == 0.5 && c.z == 0.5));
}

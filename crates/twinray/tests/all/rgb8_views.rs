//! Views kept as 8-bit pixels (`Job::render_for_writing`): the files are
//! those written from the float views, byte for byte, and the renderer keeps
//! 8-bit pixels only where every file shows the views as rendered.

use crate::common;

use std::path::{Path, PathBuf};

use twinray::job::{
    estimate_render_memory, CancelToken, InterlaceSpec, Job, JobSpec, LayoutSpec, TonemapSpec,
    ViewsKeptAs,
};
use twinray::render::Sampling;

/// A job on the bundled example scene (SPD tetra for quilts), 40x30 pixel
/// centres, writing `name` (and the stats) into `dir`.
fn spec(dir: &Path, name: &str, views: usize) -> JobSpec {
    let mut spec = JobSpec::new(common::scene_path("example.nff"), dir.join(name));
    spec.camera.size = Some([40, 30]);
    if views > 1 {
        spec.rig.views = Some(views);
        spec.rig.interaxial = Some("0.2".into());
    }
    spec.sampling.samples = Some(1);
    spec
}

/// Every file in `dir`, by name, with its bytes.
fn files(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out: Vec<(PathBuf, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let path = e.unwrap().path();
            let bytes = std::fs::read(&path).unwrap();
            (PathBuf::from(path.file_name().unwrap()), bytes)
        })
        .collect();
    out.sort();
    out
}

/// Writes `make(dir)`'s files once from the float views (`Job::render`) and
/// once through `Job::render_for_writing`; checks they are the same files,
/// byte for byte, and returns whether the second render kept 8-bit pixels.
fn kept_as_rgb8(make: impl Fn(&Path) -> JobSpec) -> bool {
    let (float_dir, rgb8_dir) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let mut kept = false;
    for (dir, writing) in [(float_dir.path(), false), (rgb8_dir.path(), true)] {
        let job = Job::check(make(dir)).unwrap();
        let loaded = job.load().unwrap();
        let plan = job.plan(&loaded).unwrap();
        let cancel = CancelToken::new();
        let rendered = if writing {
            job.render_for_writing(&plan, &|_, _| {}, &cancel)
        } else {
            job.render(&plan, &|_, _| {}, &cancel)
        }
        .unwrap();
        let out = &rendered.output;
        // One of the two, never both.
        assert_ne!(out.images.is_empty(), out.rgb8.is_empty());
        if writing {
            kept = !out.rgb8.is_empty();
            assert!(out.rgb8.iter().all(|v| (v.width, v.height) == (40, 30)));
        }
        job.write(&loaded, &plan, &rendered).unwrap();
    }
    // The statistics say how the views were kept (their timings differ).
    let stats = rgb8_dir.path().join("stats.json");
    if let Ok(text) = std::fs::read_to_string(&stats) {
        let json: serde_json::Value = serde_json::from_str(&text).unwrap();
        let said = if kept { "rgb8" } else { "float" };
        assert_eq!(json["views_kept_as"], said);
        std::fs::remove_file(&stats).unwrap();
        std::fs::remove_file(float_dir.path().join("stats.json")).unwrap();
    }
    let (a, b) = (files(float_dir.path()), files(rgb8_dir.path()));
    let names = |f: &[(PathBuf, Vec<u8>)]| f.iter().map(|x| x.0.clone()).collect::<Vec<_>>();
    assert_eq!(names(&a), names(&b), "the same files");
    assert!(!a.is_empty());
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        assert!(x == y, "{} differs", name.display());
    }
    kept
}

#[test]
fn images_of_the_views_as_rendered_are_written_from_8_bit_pixels() {
    // One view, a pair of separate files, 5 views: PNG (sRGB or linear) and JPEG.
    assert!(kept_as_rgb8(|d| spec(d, "mono.png", 1)));
    assert!(kept_as_rgb8(|d| {
        let mut s = spec(d, "lin.png", 1);
        s.output.linear = true;
        s
    }));
    assert!(kept_as_rgb8(|d| spec(d, "pair.png", 2)));
    assert!(kept_as_rgb8(|d| spec(d, "five.jpg", 5)));
    // A pair whose frame only moves the eyes' pixels.
    for layout in [
        LayoutSpec::Sbs,
        LayoutSpec::Cross,
        LayoutSpec::Tb,
        LayoutSpec::Interlace,
    ] {
        assert!(kept_as_rgb8(|d| {
            let mut s = spec(d, "frame.png", 2);
            s.output.layout = layout;
            s
        }));
    }
    assert!(kept_as_rgb8(|d| {
        let mut s = spec(d, "checker.png", 2);
        s.output.layout = LayoutSpec::Interlace;
        s.output.interlace = Some(InterlaceSpec::Checker);
        s
    }));
    // A quilt of 12 views, by the twin method and by the epipolar rows.
    for epipolar in [false, true] {
        assert!(kept_as_rgb8(|d| {
            let mut s = spec(d, "q.png", 12);
            s.scene = common::scene_path("deep.nff");
            s.output.layout = LayoutSpec::Quilt;
            s.output.quilt = Some("4x3".into());
            if epipolar {
                s.method.name = twinray::job::MethodName::Fast;
            }
            s.output.stats = Some(d.join("stats.json"));
            s
        }));
    }
}

#[test]
fn views_that_are_composed_mapped_or_stored_in_floats_stay_floats() {
    let pair = |d: &Path, layout: LayoutSpec| {
        let mut s = spec(d, "pair.png", 2);
        s.output.layout = layout;
        s
    };
    assert!(!kept_as_rgb8(|d| {
        let mut s = pair(d, LayoutSpec::Sbs);
        s.output.squeeze = true;
        s
    }));
    assert!(!kept_as_rgb8(|d| pair(d, LayoutSpec::Anaglyph)));
    assert!(!kept_as_rgb8(|d| {
        let mut s = spec(d, "exposed.png", 1);
        s.output.exposure = 1.0;
        s.output.stats = Some(d.join("stats.json"));
        s
    }));
    assert!(!kept_as_rgb8(|d| {
        let mut s = spec(d, "agx.png", 3);
        s.output.tonemap = TonemapSpec::Agx;
        s
    }));
    assert!(!kept_as_rgb8(|d| {
        let mut s = spec(d, "window.png", 2);
        s.rig.floating_window = true;
        s.rig.interaxial = Some("0.6".into());
        s
    }));
    assert!(!kept_as_rgb8(|d| spec(d, "float.pfm", 2)));
    // The SPD procedure's corners give floats.
    assert!(!kept_as_rgb8(|d| {
        let mut s = spec(d, "spd.png", 1);
        s.sampling.samples = None;
        s.sampling.spd = true;
        s
    }));
}

#[test]
fn adaptive_and_stratified_samples_are_kept_as_bytes_too() {
    // The default adaptive sampling (its rows quantised as they are
    // refined), a pair and a quilt; four stratified samples (the film's
    // sums quantised).
    let sampled = |d: &Path, name: &str, views: usize, samples: Option<u32>| {
        let mut s = spec(d, name, views);
        s.sampling.samples = samples;
        s.output.stats = Some(d.join("stats.json"));
        s
    };
    assert!(kept_as_rgb8(|d| sampled(d, "aa.png", 1, None)));
    assert!(kept_as_rgb8(|d| sampled(d, "aa-pair.jpg", 2, None)));
    assert!(kept_as_rgb8(|d| {
        let mut s = sampled(d, "aa-q.png", 6, None);
        s.output.layout = LayoutSpec::Quilt;
        s.output.quilt = Some("3x2".into());
        s
    }));
    assert!(kept_as_rgb8(|d| sampled(d, "four.png", 2, Some(4))));
}

/// The plan's memory check counts the views as `render_for_writing` keeps
/// them: the 8-bit pixels for PNG files of pixel centres (a quarter of the
/// floats' memory or less), floats for PFM files and anaglyphs.
#[test]
fn the_memory_check_counts_the_views_as_they_will_be_kept() {
    let dir = tempfile::tempdir().unwrap();
    // The second plan of a scene: the first also counts the hierarchy it
    // builds.
    let memory = |spec: JobSpec| {
        let job = Job::check(spec).unwrap();
        let loaded = job.load().unwrap();
        let first = job.plan(&loaded).unwrap().memory;
        let again = job.plan(&loaded).unwrap().memory;
        assert!(first > again, "{first} against {again}");
        again
    };
    let estimate = |kept| estimate_render_memory(40, 30, 2, Sampling::Centers, kept);
    let png = memory(spec(dir.path(), "pair.png", 2));
    assert_eq!(png, estimate(ViewsKeptAs::Bytes));
    let pfm = memory(spec(dir.path(), "pair.pfm", 2));
    assert_eq!(pfm, estimate(ViewsKeptAs::Floats));
    let mut anaglyph = spec(dir.path(), "anaglyph.png", 2);
    anaglyph.output.layout = LayoutSpec::Anaglyph;
    assert_eq!(memory(anaglyph), estimate(ViewsKeptAs::Floats));
    assert!(4 * png <= pfm, "{png} against {pfm}");
}

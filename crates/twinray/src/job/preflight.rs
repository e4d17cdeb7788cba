//! The job checked before it runs: what can be known to fail (too many
//! threads, more memory than the machine gives) is refused before the scene is
//! built or the first ray traced, with a message that says why.
//!
//! The other checks live with what they check: the rig's shifts in
//! [`Rig::multi_view`](crate::rig::Rig::multi_view), the ray depth and cut-off
//! in [`TraceSettings::validate`](crate::render::TraceSettings::validate), the
//! output paths and format limits in [`output::check_image_target`](crate::output::check_image_target) and [`output::check_stereo_targets`](crate::output::check_stereo_targets).
//! docs/reliability.md lists them all.

pub use crate::memory::{available_memory, human_bytes};
use crate::render::Sampling;
use crate::{Error, Result};

/// Most worker threads accepted: far beyond any core count, low enough that a
/// typo (`--threads 10000`) is refused at once rather than after spawning them.
pub const MAX_THREADS: usize = 1024;

/// Refuses a thread count of 0 or above [`MAX_THREADS`].
pub fn check_threads(threads: usize) -> Result<()> {
    if !(1..=MAX_THREADS).contains(&threads) {
        return Err(Error::Invalid(format!(
            "{threads} worker threads: use 1 to {MAX_THREADS}"
        )));
    }
    Ok(())
}

/// Lights beyond which a render warns: every shaded point casts one shadow ray
/// per light (there is no light hierarchy), so the time grows in proportion
/// (200,000 lights took 28 s at 32x32).
pub const MANY_LIGHTS: usize = 1000;

/// A warning for scenes with more than [`MANY_LIGHTS`] lights.
pub fn lights_warning(lights: usize) -> Option<String> {
    (lights > MANY_LIGHTS).then(|| {
        format!(
            "{lights} lights: every shaded point casts one shadow ray per light, so rendering \
             takes about {lights} times as long as with one"
        )
    })
}

/// Bytes of one colour (three `f32`).
const COLOR_BYTES: u64 = 12;

/// Bytes of one pixel kept as the file's 8-bit RGB.
const RGB8_BYTES: u64 = 3;

/// Bytes of one pixel of a stratified film: its sum and its weight.
const FILM_BYTES: u64 = COLOR_BYTES + 4;

/// How a render keeps its views while it runs (`render::ViewStorage`): as
/// floats ([`Job::render`](super::Job::render)), or as the 8-bit pixels the
/// files hold ([`Job::render_for_writing`](super::Job::render_for_writing)).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ViewsKeptAs {
    Floats,
    Bytes,
}

/// The peak memory of rendering `views` images of `width` x `height` and
/// writing them, in bytes, not counting the scene: `floats_estimate` or,
/// for views kept as bytes with any sampling but the SPD's corners (which
/// keeps floats), `bytes_estimate` (each says what it counts).
///
/// An estimate from the buffers the renderer allocates (docs/reliability.md
/// compares it with measured peaks); saturates instead of overflowing.
pub fn estimate_render_memory(
    width: u32,
    height: u32,
    views: usize,
    sampling: Sampling,
    kept: ViewsKeptAs,
) -> u64 {
    let (w, h) = (u64::from(width), u64::from(height));
    let views = views as u64;
    if kept == ViewsKeptAs::Bytes && !matches!(sampling, Sampling::Corners) {
        bytes_estimate(w, h, views, sampling)
    } else {
        floats_estimate(w, h, views, sampling)
    }
}

/// Views kept as floats: the larger of
/// * rendering: each view's samples twice (the rows as traced, then joined;
///   a stratified film's sums and weights), and for a lattice (adaptive, the
///   SPD's corners) the rows refined or averaged beside it, a third of an
///   image;
/// * writing: the images, plus for a pair a composed frame of both eyes, its
///   8-bit copy and the encoder's buffers (a single image: its 8-bit copy).
fn floats_estimate(w: u64, h: u64, views: u64, sampling: Sampling) -> u64 {
    let pixels = w.saturating_mul(h);
    let lattice = (w + 1).saturating_mul(h + 1);
    let (samples, beside) = match sampling {
        Sampling::Centers => (pixels.saturating_mul(COLOR_BYTES), 0),
        Sampling::Stratified { .. } => (pixels.saturating_mul(FILM_BYTES), 0),
        // Measured: a 2048² PFM peaked 7 % above twice its lattice.
        Sampling::Corners | Sampling::Adaptive { .. } => (
            lattice.saturating_mul(COLOR_BYTES),
            pixels.saturating_mul(4),
        ),
    };
    let rendering = samples
        .saturating_mul(2)
        .saturating_add(beside)
        .saturating_mul(views);
    let image = pixels.saturating_mul(COLOR_BYTES);
    let extra = if views > 1 {
        // Measured (docs/reliability.md): a side-by-side pair of 2048² peaked
        // at 328 MB, the two images plus about four more of composition and
        // encoding.
        image
            .saturating_mul(4)
            .saturating_add(pixels.saturating_mul(8))
    } else {
        pixels.saturating_mul(4)
    };
    let writing = image.saturating_mul(views).saturating_add(extra);
    rendering.max(writing)
}

/// Views kept as the files' bytes: the larger of
/// * rendering: each view's 8-bit pixels twice (rows, then joined), plus what
///   its sampling keeps in floats while it runs (the adaptive sampling's
///   corner lattice; the stratified film's sums and weights, twice: the
///   bands' and the film's);
/// * writing: the views, plus for a pair its composed frame and the
///   encoder's output (a single image: the encoder's).
fn bytes_estimate(w: u64, h: u64, views: u64, sampling: Sampling) -> u64 {
    let pixels = w.saturating_mul(h);
    let floats = match sampling {
        Sampling::Centers => 0,
        Sampling::Stratified { .. } => pixels.saturating_mul(2 * FILM_BYTES),
        Sampling::Corners | Sampling::Adaptive { .. } => {
            (w + 1).saturating_mul(h + 1).saturating_mul(COLOR_BYTES)
        }
    };
    let rendering = pixels
        .saturating_mul(2 * RGB8_BYTES)
        .saturating_add(floats)
        .saturating_mul(views);
    let frames = if views > 1 { 3 } else { 1 };
    let writing = pixels.saturating_mul(RGB8_BYTES.saturating_mul(views + frames));
    rendering.max(writing)
}

/// Bytes a scene's hierarchy takes per primitive beyond the scene: its
/// binary and eight-wide trees, leaf order and blocks, and the
/// build's working arrays (docs/reliability.md has the measurements).
pub const HIERARCHY_BYTES_PER_PRIMITIVE: u64 = 160;

/// The memory building a hierarchy over `scene` takes, in bytes: the copy
/// of the scene that the hierarchy keeps, and the hierarchy.
pub fn build_memory(scene: &crate::Scene) -> u64 {
    (scene.memory_bytes() as u64)
        .saturating_add((scene.shapes.len() as u64).saturating_mul(HIERARCHY_BYTES_PER_PRIMITIVE))
}

/// Refuses a job of `needed` bytes when `available` is known and smaller.
/// `what` describes the job for the message (e.g. "2 views of 4096x4096").
pub fn check_memory(needed: u64, available: Option<u64>, what: &str) -> Result<()> {
    match available {
        Some(available) if needed > available => Err(Error::Invalid(format!(
            "{what} needs about {} of memory, but only {} is available: use a smaller \
             size or fewer views",
            human_bytes(needed),
            human_bytes(available)
        ))),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::Filter;

    #[test]
    fn thread_counts() {
        assert!(check_threads(1).is_ok());
        assert!(check_threads(MAX_THREADS).is_ok());
        assert!(check_threads(0).is_err());
        let err = check_threads(10_000).unwrap_err().to_string();
        assert!(err.contains("1 to 1024"), "{err}");
    }

    #[test]
    fn many_lights_warn() {
        assert!(lights_warning(MANY_LIGHTS).is_none());
        let w = lights_warning(200_000).unwrap();
        assert!(w.starts_with("200000 lights"), "{w}");
    }

    #[test]
    fn memory_estimates() {
        // One 16384² view: the samples twice (6.4 GB), the attack's 9 GB peak
        // less the copy the renderer no longer makes.
        let floats = |w, h, views, sampling| {
            estimate_render_memory(w, h, views, sampling, ViewsKeptAs::Floats)
        };
        let mono = floats(16384, 16384, 1, Sampling::Centers);
        assert_eq!(mono, 2 * 16384 * 16384 * 12);
        // 32 views of 4096²: 13 GB.
        let many = floats(4096, 4096, 32, Sampling::Centers);
        assert_eq!(many, 2 * 32 * 4096 * 4096 * 12);
        // A pair's output frame counts when it is the larger.
        let pair = floats(10, 10, 2, Sampling::Centers);
        assert_eq!(pair, 2 * 1200 + 4 * 1200 + 800);
        assert!(floats(10, 10, 1, Sampling::Corners) > 2 * 1200);
        // A stratified film: each pixel's sum and weight, twice.
        let stratified = Sampling::Stratified {
            samples: 4,
            filter: Filter::default(),
            seed: 0,
        };
        assert_eq!(floats(10, 10, 1, stratified), 2 * 100 * 16);
        // A refined sampling: its lattice twice and its refinement's rows.
        let adaptive = Sampling::Adaptive {
            threshold: 0.1,
            max_samples: 16,
        };
        assert_eq!(floats(10, 10, 1, adaptive), 2 * 11 * 11 * 12 + 400);
        assert_eq!(floats(u32::MAX, u32::MAX, 32, Sampling::Corners), u64::MAX);
    }

    /// Views kept as the files' bytes: 3 bytes a pixel, twice, plus the
    /// floats the sampling keeps while it runs; the SPD's corners keep floats.
    #[test]
    fn memory_estimates_of_views_kept_as_bytes() {
        let bytes = |w, h, views, sampling| {
            estimate_render_memory(w, h, views, sampling, ViewsKeptAs::Bytes)
        };
        assert_eq!(
            bytes(4096, 4096, 32, Sampling::Centers),
            32 * 4096 * 4096 * 6
        );
        let adaptive = Sampling::Adaptive {
            threshold: 0.1,
            max_samples: 16,
        };
        // A pair's composed frame and its encoding, when that is the larger.
        assert_eq!(bytes(10, 10, 2, Sampling::Centers), (2 + 3) * 300);
        assert_eq!(bytes(10, 10, 2, adaptive), 2 * (600 + 11 * 11 * 12));
        let stratified = Sampling::Stratified {
            samples: 4,
            filter: Filter::default(),
            seed: 0,
        };
        assert_eq!(bytes(10, 10, 1, stratified), 600 + 2 * 100 * 16);
        assert_eq!(
            bytes(10, 10, 2, Sampling::Corners),
            estimate_render_memory(10, 10, 2, Sampling::Corners, ViewsKeptAs::Floats)
        );
        assert_eq!(bytes(u32::MAX, u32::MAX, 32, adaptive), u64::MAX);
    }

    #[test]
    fn memory_check_names_the_job_and_the_sizes() {
        assert!(check_memory(10, None, "x").is_ok());
        assert!(check_memory(10, Some(10), "x").is_ok());
        let err = check_memory(13_000_000_000, Some(8_000_000_000), "32 views of 4096x4096")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("32 views of 4096x4096 needs about 13.0 GB"),
            "{err}"
        );
        assert!(err.contains("only 8.0 GB"), "{err}");
    }
}

//! Rendering the views of a rig: the public face of the renderer.
//!
//! How the views are computed is one closed choice, [`ViewMethod`]:
//!
//! * `Independent` (`independent.rs`): the paper's "traditional algorithm"
//!   and the reference every exactness test compares with: every view a
//!   mono render of its own camera.
//! * `Twin` (`twin/`), the default: the paper's twin objects. One descent of
//!   the hierarchy returns the nearest hit of every view's eye ray through a
//!   sample; the views' samples that see one surface point are shaded as one
//!   packet, whose shadow, reflected and refracted rays share their
//!   descents. The images equal the reference bit for bit. The paper's
//!   techniques are its options ([`PaperTechniques`]): merged secondary rays
//!   (`tracer/merged_rays.rs`) and reprojection (`twin/reprojection.rs`);
//!   its cut of the object tree is the world's (`world/cut.rs`), seen by
//!   the twin rows in `twin/cut.rs`.
//! * `Fast` (`fast/`): the one approximate pipeline, within a tolerance;
//!   its stages are decided in one place, `fast::stages`.
//!
//! Where the rays go and how they become pixels is the same for every
//! method: the sampler (`sampler.rs`: pixel centres, the SPD's corners, N
//! stratified samples, or the paper's adaptive refinement in `adaptive.rs`)
//! gives rows of sample positions, the same in every view; the method
//! traces a row for its views (`batch.rs`); the film (`film.rs`) filters
//! the samples into pixels. The driver (`driver/`) runs the rows as tasks
//! and keeps the views; the tracer (`tracer/`) shades packets of rays;
//! `counts.rs` counts what every method does, and each method what it alone
//! does.

mod adaptive;
mod batch;
mod cancel;
mod counts;
mod driver;
mod fast;
mod film;
mod independent;
mod options;
mod panorama;
pub mod sampler;
mod tracer;
mod twin;

pub use cancel::CancelToken;
pub use counts::{HitsPerView, RayCounts, TraceCounts};
pub use driver::{
    render, render_cancellable, render_rows, render_rows_as, RenderOutput, ViewStorage,
    TILE_ROW_ALIGNMENT,
};
pub use fast::counts::{CacheCounts, EpipolarCounts, FastCounts};
pub use fast::{stages as fast_stages, FastStages, SceneTraits};
pub use options::{
    PaperTechniques, RenderOptions, ReprojectMode, Reprojection, TraceSettings, ViewMethod,
    DEFAULT_VIEWS_PER_BATCH, MAX_DEPTH, MAX_LANES, MAX_VIEWS,
};
pub use panorama::MAX_PANORAMA_VIEWS;
pub use sampler::{Filter, SampleRow, Sampling};
pub(crate) use tracer::NearestShape;
pub use tracer::Tracer;
pub use twin::counts::PaperCounts;

/// The shipped example scene (spheres, a cone, polygons), loaded for the
/// render stages' unit tests.
#[cfg(test)]
fn example_scene() -> crate::Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/example.nff");
    crate::loaders::load_scene(&path, &crate::loaders::LoadOptions::default())
        .expect("shipped scene")
}

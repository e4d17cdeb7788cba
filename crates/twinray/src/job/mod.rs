//! One render, from a [`JobSpec`] to files, in stages a front end runs one
//! by one (the command line, the preview server, a distributed driver),
//! each in a file of its own:
//!
//! 1. [`Job::check`] (`check.rs`): the spec's values and combinations, the
//!    view method and its options, the threads: what can be known to fail
//!    before anything is read.
//! 2. [`Job::load`] (`load.rs`): the scene file (or [`Job::prepare`] for a
//!    scene already in memory); its hierarchy is built at the first plan
//!    and kept, so one [`Loaded`] scene serves many plans (a preview
//!    re-plans on every change).
//! 3. [`Job::plan`] (`plan.rs`): one way, each decision once: the image
//!    size and camera, the memory, the hierarchy, the depth pass and the
//!    rig (and its disparity report), the output files, the cut of the
//!    object tree, the world the render traces.
//! 4. [`Job::render`] (`rendering.rs`): the views in memory, with a progress
//!    callback and a [`CancelToken`].
//! 5. [`Job::write`] (`rendering.rs`): the files, composed in the layout
//!    and written atomically as a set; the statistics (`report.rs`).
//!
//! The stages print nothing: what a user should be told comes back as
//! [`Message`]s (notes and warnings, and the details a verbose front end
//! shows, `report.rs`), for the front end to print or display. The types
//! the stages take and give are in `stages.rs`.
//!
//! Error messages name the command line's flags (`--interaxial`), the names a
//! spec's fields have on the command line (`rig.interaxial`).

mod check;
mod load;
mod outputs;
mod panorama;
mod plan;
pub mod preflight;
mod preview;
mod rendering;
mod repeats;
mod report;
pub mod spec;
mod stages;
mod studio;
pub mod tiles;

pub use check::sampling;

pub use outputs::{display_transform, job_inputs, numbered, write_options};
pub use preflight::{
    available_memory, check_memory, check_threads, estimate_render_memory, human_bytes,
    lights_warning, ViewsKeptAs, MANY_LIGHTS, MAX_THREADS,
};
pub use preview::Pass;
pub use spec::{
    AnaglyphSpec, AnimationSpec, CameraSpec, CutSpec, InterlaceSpec, JobSpec, LayoutSpec,
    LightSpec, LimitSpec, MethodName, MethodSpec, OutputSpec, RigSpec, SamplingSpec, SceneUnits,
    ShotRigSpec, StudioSpec, TileSpec, TonemapSpec, TraceSpec, UpAxisSpec,
};
pub use stages::{Job, Level, Loaded, Message, Plan, Rendered};

pub use crate::render::CancelToken;

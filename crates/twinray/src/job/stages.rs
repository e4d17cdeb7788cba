//! What the stages of a job take and give: the checked [`Job`], the
//! [`Loaded`] scene, the [`Plan`], the [`Rendered`] views, and the
//! [`Message`]s each says to the user.

use crate::rig::panorama_rig::PanoramaRig;
use crate::rig::Projection;
use std::path::PathBuf;
use std::sync::{Arc, OnceLock};

use super::spec::{CutSpec, JobSpec};
use crate::environment::Environment;
use crate::output::{DepthChannels, QuiltSpec};
use crate::render::{RenderOptions, RenderOutput};
use crate::rig::budget::DepthBudget;
use crate::rig::choice::Interaxial;
use crate::rig::report::Settled;
use crate::rig::up_axis::UpAxis;
use crate::rig::{Camera, Rig};
use crate::scene::Scene;
use crate::world::{Cut, World};
use crate::{Error, Result};

/// How much a message matters to the person at the front end.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Level {
    /// Details for a verbose front end (`-v`): the scene, the rig, timings.
    Info,
    /// Something the job chose for the user that they may want to change.
    Note,
    /// Something likely wrong that did not stop the job.
    Warning,
}

/// Something a stage has to tell the user.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Message {
    pub level: Level,
    pub text: String,
}

impl Message {
    pub(super) fn info(text: impl Into<String>) -> Message {
        Message {
            level: Level::Info,
            text: text.into(),
        }
    }
    pub(super) fn note(text: impl Into<String>) -> Message {
        Message {
            level: Level::Note,
            text: text.into(),
        }
    }
    pub(super) fn warning(text: impl Into<String>) -> Message {
        Message {
            level: Level::Warning,
            text: text.into(),
        }
    }
}

/// A checked job: the spec and what was derived from it.
pub struct Job {
    pub(super) spec: JobSpec,
    /// Views to render (1, 2, N, or a quilt's tiles).
    pub(super) views: usize,
    pub(super) quilt: Option<QuiltSpec>,
    pub(super) budget: Option<DepthBudget>,
    pub(super) interaxial: Option<Interaxial>,
    pub(super) options: RenderOptions,
    /// The paper's cut of the object tree, asked for (the twin method).
    pub(super) cut: Option<CutSpec>,
    /// The camera's projection (`--projection`).
    pub(super) projection: Projection,
    pub(super) pool: Arc<rayon::ThreadPool>,
    pub(super) messages: Vec<Message>,
    /// `--env` as read, for y up and z up: an animation readies a scene
    /// per frame, and decoding a large HDR image each time would cost more
    /// than some frames' rendering.
    pub(super) environments: std::sync::Mutex<[Option<Arc<Environment>>; 2]>,
}

/// A scene read and ready to plan: its hierarchy is built by the first plan
/// that needs it and kept for the next ones.
pub struct Loaded {
    /// The scene as loaded (its own viewpoint, a headlight where it had no lights).
    pub scene: Arc<Scene>,
    pub(super) world: OnceLock<Arc<World>>,
    pub load_seconds: f64,
    pub messages: Vec<Message>,
    /// How many of the scene's shapes are the model's: those after them are
    /// the `--ground` floor, which framing leaves out.
    pub(super) model_shapes: usize,
    /// The model's up axis: `--up-axis`, or detected.
    pub(super) up: UpAxis,
}

impl Loaded {
    /// The scene with its whole hierarchy (no cut), built once.
    pub fn world(&self, pool: &rayon::ThreadPool) -> Arc<World> {
        self.world
            .get_or_init(|| Arc::new(pool.install(|| World::new((*self.scene).clone()))))
            .clone()
    }

    /// The hierarchy if a plan has built it (or it was given).
    pub fn built_world(&self) -> Option<&Arc<World>> {
        self.world.get()
    }

    /// Gives the scene its hierarchy, built elsewhere (an animation's
    /// two-level one); the plans use it instead of building their own.
    pub(crate) fn set_world(&mut self, world: Arc<World>) {
        self.world = OnceLock::from(world);
    }
}

/// Everything decided before rendering.
pub struct Plan {
    pub width: u32,
    pub height: u32,
    pub camera: Camera,
    pub rig: Rig,
    /// The rig's interaxial (0 for one view) and the convergence asked for.
    pub interaxial: f32,
    pub convergence: Option<f64>,
    /// The rig fitted to the scene's depths and its disparity report (several views).
    pub settled: Option<Settled>,
    /// A panorama's pair: its IPD and angular disparities.
    pub panorama: Option<PanoramaRig>,
    pub cut: Option<Cut>,
    /// The scene with the hierarchy the render traces (cut or whole).
    pub world: Arc<World>,
    /// The files the job will write, checked.
    pub files: Vec<PathBuf>,
    pub build_seconds: f64,
    pub messages: Vec<Message>,
    /// The pixel rows rendered: all of them, or a tile's.
    pub rows: std::ops::Range<u32>,
    /// The memory the render and the writing need, in bytes, as estimated
    /// and checked against what the machine has, with the views kept as
    /// [`Job::render_for_writing`] keeps them ([`Job::render`], which keeps
    /// floats, checks again).
    pub memory: u64,
}

/// The views rendered, in memory.
pub struct Rendered {
    pub output: RenderOutput,
    /// Each view's depth and disparity channels (`output.depth`).
    pub depth: Option<Vec<DepthChannels>>,
    pub messages: Vec<Message>,
}

impl Job {
    pub fn spec(&self) -> &JobSpec {
        &self.spec
    }

    /// What checking the spec found worth telling (no errors: those refused it).
    pub fn messages(&self) -> &[Message] {
        &self.messages
    }

    /// The options the renderer gets (sampling, method, approximations, limits).
    pub fn render_options(&self) -> &RenderOptions {
        &self.options
    }

    /// Views the job renders.
    pub fn views(&self) -> usize {
        self.views
    }

    /// The worker threads every stage runs on.
    pub fn pool(&self) -> &rayon::ThreadPool {
        &self.pool
    }
}

/// The worker threads of a job: `threads` of them (default: every core),
/// with stacks of 8 MiB (reserved, not used): room beyond the depth cap.
pub(super) fn worker_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    let mut pool = rayon::ThreadPoolBuilder::new().stack_size(8 << 20);
    if let Some(n) = threads {
        pool = pool.num_threads(n);
    }
    pool.build()
        .map_err(|e| Error::Invalid(format!("cannot start worker threads: {e}")))
}

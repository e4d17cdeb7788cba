//! One render, from a [`JobSpec`] to files, in stages a front end runs one
//! by one (the command line, the preview server, a distributed driver):
//!
//! 1. [`Job::check`]: the spec's values and combinations, the threads: what
//!    can be known to fail before anything is read.
//! 2. [`Job::load`]: the scene file (or [`Job::prepare`] for a scene already
//!    in memory); its hierarchy is built at the first plan and kept, so one
//!    [`Loaded`] scene serves many plans (a preview re-plans on every change).
//! 3. [`Job::plan`]: the image size and camera, the rig (a depth pass where
//!    the rig is automatic, and the disparity report), the cut of the object
//!    tree, the output files and the memory, all checked before rendering.
//! 4. [`Job::render`]: the views in memory, with a progress callback and a
//!    [`CancelToken`].
//! 5. [`Job::write`]: the files, composed in the layout and written
//!    atomically as a set; the statistics.
//!
//! The stages print nothing: what a user should be told comes back as
//! [`Message`]s (notes and warnings, and the details a verbose front end
//! shows), for the front end to print or display.
//!
//! Error messages name the command line's flags (`--interaxial`), the names a
//! spec's fields have on the command line (`rig.interaxial`).

mod command;
mod outputs;
pub mod preflight;
mod preview;
mod repeats;
pub mod spec;
mod studio;
pub mod tiles;

pub use outputs::numbered;
pub use preflight::{
    available_memory, check_memory, check_threads, estimate_render_memory, human_bytes,
    lights_warning, ViewsKeptAs, MANY_LIGHTS, MAX_THREADS,
};
pub use preview::Pass;
pub use spec::{
    AnaglyphSpec, ApproximationSpec, CameraSpec, FilterSpec, InterlaceSpec, JobSpec, LayoutSpec,
    LightSpec, LimitSpec, MethodSpec, OutputSpec, ReprojectModeSpec, RigSpec, SamplingSpec,
    StudioSpec, TonemapSpec, TraceSpec, UpAxisSpec,
};
pub use spec::{AnimationSpec, ShotRigSpec, TileSpec};

pub use crate::render::CancelToken;

use std::path::PathBuf;
use std::sync::{Arc, OnceLock};
use std::time::Instant;

use crate::environment::Environment;
use crate::loaders::{load_scene, LoadOptions};
use crate::math::Vec3;
use crate::output::{self, DepthChannels, QuiltSpec};
use crate::render::{
    self, Approximations, Filter, Method, RenderOptions, RenderOutput, ReprojectMode, Reprojection,
    Sampling, SharedShading, TraceSettings, ViewStorage,
};
use crate::rig::budget::DepthBudget;
use crate::rig::camera_overrides::{self as view, CameraOverrides};
use crate::rig::choice::RigRequest;
use crate::rig::choice::{self as rig_choice, Interaxial, RigFlags};
use crate::rig::framing;
use crate::rig::report::{self as rig_report, Settled};
use crate::rig::up_axis::{self, UpAxis};
use crate::rig::Camera;
use crate::rig::Rig;
use crate::scene::{SceneFormat, Viewpoint};
use crate::stats::{Report, SamplingFacts, SceneFacts, Timings};
use crate::world::Cut;
use crate::{Error, Result, Scene, World};
use outputs::Targets;

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
    fn info(text: impl Into<String>) -> Message {
        Message {
            level: Level::Info,
            text: text.into(),
        }
    }
    fn note(text: impl Into<String>) -> Message {
        Message {
            level: Level::Note,
            text: text.into(),
        }
    }
    fn warning(text: impl Into<String>) -> Message {
        Message {
            level: Level::Warning,
            text: text.into(),
        }
    }
}

/// `--fast`'s cut: half a pixel of disparity.
const FAST_CUT_PARALLAX: f64 = 0.5;

/// A checked job: the spec and what was derived from it.
pub struct Job {
    spec: JobSpec,
    /// Views to render (1, 2, N, or a quilt's tiles).
    views: usize,
    quilt: Option<QuiltSpec>,
    budget: Option<DepthBudget>,
    interaxial: Option<Interaxial>,
    options: RenderOptions,
    pool: Arc<rayon::ThreadPool>,
    messages: Vec<Message>,
    /// `--env` as read, for y up and z up: an animation readies a scene
    /// per frame, and decoding a large HDR image each time would cost more
    /// than some frames' rendering.
    environments: std::sync::Mutex<[Option<Arc<Environment>>; 2]>,
}

/// A scene read and ready to plan: its hierarchy is built by the first plan
/// that needs it and kept for the next ones.
pub struct Loaded {
    /// The scene as loaded (its own viewpoint, a headlight where it had no lights).
    pub scene: Arc<Scene>,
    world: OnceLock<Arc<World>>,
    pub load_seconds: f64,
    pub messages: Vec<Message>,
    /// How many of the scene's shapes are the model's: those after them are
    /// the `--ground` floor, which framing leaves out.
    model_shapes: usize,
    /// The model's up axis: `--up-axis`, or detected.
    up: UpAxis,
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
    /// Checks the spec: every value and combination that can be refused
    /// before the scene is read, and the worker threads.
    pub fn check(spec: JobSpec) -> Result<Job> {
        Job::checked(spec, None)
    }

    /// Checks the spec as [`Job::check`] does, for a job that runs on
    /// `pool` (whose threads replace the spec's `threads`): a front end that
    /// checks a spec per change (the preview) keeps one pool.
    pub fn check_in(spec: JobSpec, pool: Arc<rayon::ThreadPool>) -> Result<Job> {
        Job::checked(spec, Some(pool))
    }

    /// [`Job::check`] with the worker threads of `other` (the frames of an
    /// animation share one pool instead of starting threads per frame).
    pub fn check_sharing_threads(spec: JobSpec, other: &Job) -> Result<Job> {
        Job::checked(spec, Some(Arc::clone(&other.pool)))
    }

    fn checked(mut spec: JobSpec, pool: Option<Arc<rayon::ThreadPool>>) -> Result<Job> {
        if spec.animation.frames.is_some() {
            return Err(invalid(
                "a spec with frames is an animation: run it with twinray::animation::Animation",
            ));
        }
        if let Some(tile) = spec.tile {
            tiles::check(&spec, tile)?;
            // The tile's files are named after it: NAME_tileKofN.ext.
            spec.output.path = tiles::tile_path(&spec.output.path, tile);
        }
        let checked = Checked::of(&spec)?;
        let pool = match pool {
            Some(pool) => pool,
            None => Arc::new(worker_pool(spec.trace.threads)?),
        };
        let mut messages = outputs::check_display(&spec.output)?;
        let a = &spec.approximations;
        let sharing = a.share_shading || (a.fast && a.reproject_mode == ReprojectModeSpec::Safe);
        if a.key_spacing != ApproximationSpec::default().key_spacing && !sharing {
            messages.push(Message::warning(
                "--key-spacing does nothing without --share-shading (or --fast): key views are part of the shared shading",
            ));
        }
        if spec.rig.method == MethodSpec::Independent {
            for (flag, on) in [
                ("--eye-runs", spec.rig.eye_runs),
                ("--shadow-fans", spec.rig.shadow_fans),
            ] {
                if on {
                    messages.push(Message::warning(format!(
                        "{flag} does nothing with --method independent: it shares work between the twin method's views"
                    )));
                }
            }
        }
        if let Some(bg) = spec.studio.background {
            if !bg.iter().all(|v| v.is_finite() && *v >= 0.0) {
                return Err(invalid(format!(
                    "--background takes three finite values >= 0 (linear RGB), got {bg:?}"
                )));
            }
        }
        studio::check_lights(&spec.studio.lights)?;
        if let (Some(_), Some(env)) = (spec.studio.background, &spec.studio.env) {
            return Err(invalid(format!(
                "--background and --env {} conflict: the environment image is the background (give one of them)",
                env.display()
            )));
        }
        Ok(Job {
            spec,
            views: checked.views,
            quilt: checked.quilt,
            budget: checked.budget,
            interaxial: checked.interaxial,
            options: checked.options,
            pool,
            messages,
            environments: Default::default(),
        })
    }

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

    /// Reads the scene file.
    pub fn load(&self) -> Result<Loaded> {
        self.load_at(None)
    }

    /// Reads the scene file with a glTF file's animations at `time` seconds.
    pub fn load_at(&self, time: Option<f32>) -> Result<Loaded> {
        let start = Instant::now();
        let scene = load_scene(&self.spec.scene, &self.load_options(time))?;
        let load_seconds = start.elapsed().as_secs_f64();
        let mut loaded = self.prepare(scene)?;
        loaded.load_seconds = load_seconds;
        Ok(loaded)
    }

    /// What the loaders are given: the spec's limits, the time of a glTF
    /// file's animations and the one that plays.
    pub fn load_options(&self, time: Option<f32>) -> LoadOptions {
        let limits = &self.spec.limits;
        LoadOptions {
            max_resolution: limits.max_resolution,
            max_vertices: limits.max_vertices,
            max_triangles: limits.max_triangles,
            animation_time: time,
            animation: self.spec.animation.clip.clone(),
        }
    }

    /// Readies a scene already in memory (as [`Job::load`] does after reading
    /// it): its warnings become messages; a mesh file without lights gets a
    /// headlight at the camera the spec asks for.
    pub fn prepare(&self, mut scene: Scene) -> Result<Loaded> {
        let mut messages: Vec<Message> = repeats::fold_repeated(&scene.warnings)
            .iter()
            .chain(&lights_warning(scene.lights.len()))
            .map(|w| Message::warning(w.clone()))
            .collect();
        let (viewpoint, given) = view::resolve(&scene, &self.view_overrides())?;
        let path = self.spec.scene.display();
        // What the file leaves out and the job supplies: one line for -v.
        let mut supplied = Vec::new();
        if !given && self.spec.camera.from.is_none() {
            supplied.push("no camera: framed the whole scene from the front (--from, --at, --up, --fov set one)");
        }
        let up = self.resolve_up_axis(&scene, given, &mut messages);
        let viewpoint = if given {
            viewpoint
        } else {
            self.up_axis(viewpoint, up)
        };
        let given_lights = &self.spec.studio.lights;
        let unlit = scene.format != SceneFormat::Nff && scene.lights.is_empty();
        if unlit && given_lights.is_empty() {
            scene.lights =
                crate::lights::three_point_rig(viewpoint.from, viewpoint.at, viewpoint.up);
            supplied.push("no lights: added a key, a fill and a rim light around the camera");
        }
        scene.lights.extend(studio::point_lights(given_lights));
        let model_shapes = scene.shapes.len();
        if self.spec.studio.ground {
            let model = scene.bounds();
            studio::add_ground(&mut scene, model, up);
        }
        if let Some(rgb) = self.spec.studio.background {
            scene.background = Vec3::from(rgb);
        }
        if let Some(path) = &self.spec.studio.env {
            scene.environment = Some(self.environment(path, up)?);
        } else if unlit && given_lights.is_empty() && self.spec.studio.background.is_none() {
            scene.environment = Some(studio::surroundings(up));
            supplied.push(studio::SURROUNDINGS);
        }
        if !supplied.is_empty() {
            messages.push(Message::info(format!("{path}: {}", supplied.join("; "))));
        }
        Ok(Loaded {
            scene: Arc::new(scene),
            world: OnceLock::new(),
            load_seconds: 0.0,
            messages,
            model_shapes,
            up,
        })
    }

    /// The environment image `path` turned for `up`, read once per job.
    fn environment(&self, path: &std::path::Path, up: UpAxis) -> Result<Arc<Environment>> {
        let z_up = up == UpAxis::Z;
        // A poisoned lock only means another thread panicked mid-read: read again.
        let mut read = self
            .environments
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Some(env) = &read[z_up as usize] {
            return Ok(Arc::clone(env));
        }
        let env = Arc::new(Environment::load(path, z_up)?);
        read[z_up as usize] = Some(Arc::clone(&env));
        Ok(env)
    }

    /// The up axis of a file without a camera: `--up-axis`, glTF's y, or
    /// for OBJ, STL and PLY the model's base (`rig::up_axis`), with a note
    /// saying what was chosen.
    fn resolve_up_axis(&self, scene: &Scene, given: bool, messages: &mut Vec<Message>) -> UpAxis {
        match self.spec.studio.up_axis {
            UpAxisSpec::Y => return UpAxis::Y,
            UpAxisSpec::Z => return UpAxis::Z,
            UpAxisSpec::Auto => {}
        }
        let guessed = matches!(
            scene.format,
            SceneFormat::Obj | SceneFormat::Stl | SceneFormat::Ply
        );
        if given || !guessed {
            return UpAxis::Y;
        }
        let d = up_axis::detect(scene, scene.shapes.len());
        let other = match d.axis {
            UpAxis::Y => UpAxis::Z,
            UpAxis::Z => UpAxis::Y,
        };
        messages.push(Message::note(format!(
            "{}: up axis {} ({}); --up-axis {} to override",
            self.spec.scene.display(),
            d.axis.name(),
            d.reason(),
            other.name()
        )));
        d.axis
    }

    /// The framing of a file without a camera turned for `--up-axis z`: the
    /// loader frames y-up models, so (x, y, z) becomes (x, −z, y) about the
    /// target, and z is up (unless `--up` says otherwise).
    fn up_axis(&self, vp: Viewpoint, up: UpAxis) -> Viewpoint {
        if up == UpAxis::Y {
            return vp;
        }
        let turn = |v: Vec3| Vec3::new(v.x, -v.z, v.y);
        let from = if self.spec.camera.from.is_some() {
            vp.from
        } else {
            vp.at + turn(vp.from - vp.at)
        };
        let up = if self.spec.camera.up.is_some() {
            vp.up
        } else {
            Vec3::Z
        };
        Viewpoint { from, up, ..vp }
    }

    pub(crate) fn view_overrides(&self) -> CameraOverrides {
        let c = &self.spec.camera;
        CameraOverrides {
            camera: c.camera.clone(),
            from: c.from.map(Vec3::from),
            at: c.at.map(Vec3::from),
            up: c.up.map(Vec3::from),
            fov_deg: c.fov,
        }
    }

    /// The image size: the spec's, the SPD procedure's, a quilt preset's or
    /// the scene's.
    fn size(&self, viewpoint: &Viewpoint) -> Result<(u32, u32)> {
        let preset = self.quilt.and_then(|q| q.preset);
        let (width, height) = match (self.spec.camera.size, self.spec.sampling.spd, preset) {
            (Some([w, h]), _, _) => (w, h),
            (None, _, Some(p)) => (p.view_width, p.view_height),
            (None, true, None) => (512, 512),
            (None, false, None) => (viewpoint.width, viewpoint.height),
        };
        let max = self.spec.limits.max_resolution;
        if width > max || height > max {
            return Err(Error::Invalid(format!(
                "--size {width}x{height} exceeds the limit of {max} per side (raise it with --max-resolution)"
            )));
        }
        Ok((width, height))
    }

    /// Decides everything before rendering: size, camera, rig, cut, files.
    pub fn plan(&self, loaded: &Loaded) -> Result<Plan> {
        let (viewpoint, given) = view::resolve(&loaded.scene, &self.view_overrides())?;
        let (width, height) = self.size(&viewpoint)?;
        // A scene without a camera: its bounds fill 80 % of this image.
        let camera_spec = &self.spec.camera;
        let viewpoint = if given {
            viewpoint
        } else {
            self.up_axis(viewpoint, loaded.up)
        };
        let viewpoint = if given || camera_spec.from.is_some() || camera_spec.at.is_some() {
            viewpoint
        } else {
            let model = &loaded.scene.shapes[..loaded.model_shapes];
            let boxes = model.iter().map(|s| s.bounds());
            framing::fit_bounds(&viewpoint, boxes, width, height, framing::FILL)
        };
        let camera = Camera::new(&viewpoint, width, height);
        let at_distance = f64::from((viewpoint.at - viewpoint.from).length());
        let request = self.rig_request(at_distance)?;
        // The rig, or with an automatic interaxial or convergence a stand-in
        // until the depth pass on the built scene.
        let (mut rig, explicit) = match &request {
            None => (Rig::mono(), None),
            Some(r) => rig_choice::rig_before_depths(&camera, r)?,
        };
        let (mut interaxial, mut convergence) = explicit
            .as_ref()
            .map_or((0.0, None), |c| (c.interaxial, c.convergence));
        let rows = match self.spec.tile {
            Some(t) => tiles::tile_rows(height, t)?,
            None => 0..height,
        };
        let written = (width, rows.len() as u32);
        let mut files = self
            .targets(&rig, interaxial)
            .plan(written, &self.spec.scene)?;
        // As `render_for_writing` keeps the views (`Job::render`, which keeps
        // floats, checks again).
        let memory = self.check_memory(width, height, self.kept_for_writing(&rig, interaxial))?;

        let mut build_seconds = 0.0;
        // `--fast` cuts the object tree only where the epipolar rows cannot
        // take the views (alpha, instances): they need the whole tree, and
        // find the views' hits without eye rays anyway.
        let epipolar = self.options.approx.epipolar_views.is_some()
            && !loaded.scene.has_alpha()
            && loaded.built_world().is_none_or(|w| w.instances.is_none());
        let mut cut = self.cut(&camera, &rig, epipolar)?;
        let mut world = self.world_for(loaded, cut, &mut build_seconds);
        let settled =
            match &request {
                Some(r) => Some(self.pool.install(|| {
                    rig_report::settle(&world, &camera, r, self.spec.rig.screen_width)
                })?),
                None => None,
            };
        if let (Some(s), None) = (&settled, &explicit) {
            // The rig fitted to the depths: its outputs checked again (an
            // MPO's interaxial), and the cut that depends on it made now.
            rig = s.rig.clone();
            (interaxial, convergence) = (s.choice.interaxial, s.choice.convergence);
            files = self
                .targets(&rig, interaxial)
                .plan(written, &self.spec.scene)?;
            let fitted = self.cut(&camera, &rig, epipolar)?;
            if fitted.is_some() {
                cut = fitted;
                world = self.world_for(loaded, cut, &mut build_seconds);
            }
        }
        let mut plan = Plan {
            width,
            height,
            camera,
            rig,
            interaxial,
            convergence,
            settled,
            cut,
            world,
            files,
            build_seconds,
            messages: Vec::new(),
            rows,
            memory,
        };
        let rig = &self.spec.rig;
        let rig_by_default = self.quilt.is_some()
            && rig.interaxial.is_none()
            && rig.view_cone.is_none()
            && rig.depth_budget.is_none();
        // Only an interaxial the user gave is theirs to change.
        let interaxial_given = rig
            .interaxial
            .as_deref()
            .is_some_and(|i| !i.eq_ignore_ascii_case("auto"));
        plan.messages = plan_messages(&plan, rig_by_default, interaxial_given);
        Ok(plan)
    }

    /// The rig request of a job of several views.
    pub(crate) fn rig_request(&self, at_distance: f64) -> Result<Option<RigRequest>> {
        if self.views < 2 {
            return Ok(None);
        }
        let flags = RigFlags {
            interaxial: self.interaxial,
            convergence: self.spec.rig.convergence.as_deref(),
            view_cone: self.spec.rig.view_cone,
            budget: self.budget,
        };
        rig_choice::rig_request(&flags, self.quilt.is_some(), self.views, at_distance).map(Some)
    }

    fn targets(&self, rig: &Rig, interaxial: f32) -> Targets<'_> {
        Targets {
            output: &self.spec.output,
            quilt: self.quilt.as_ref(),
            views: self.views,
            interaxial,
            effective_convergence: rig.effective_convergence,
        }
    }

    /// How `render_for_writing` keeps the views of `rig`: as the files'
    /// bytes where they only show them (`Targets::storage`), but in floats
    /// under a floating window, which masks the views after the render.
    fn storage_for_writing(&self, rig: &Rig, interaxial: f32) -> ViewStorage {
        if self.spec.rig.floating_window {
            ViewStorage::Float
        } else {
            self.targets(rig, interaxial).storage()
        }
    }

    /// `storage_for_writing`, as the memory check counts it.
    fn kept_for_writing(&self, rig: &Rig, interaxial: f32) -> ViewsKeptAs {
        match self.storage_for_writing(rig, interaxial) {
            ViewStorage::Float => ViewsKeptAs::Floats,
            ViewStorage::Rgb8(_) => ViewsKeptAs::Bytes,
        }
    }

    /// The memory a render needs with its views kept as `kept` (bytes);
    /// refused where the machine has less.
    fn check_memory(&self, width: u32, height: u32, kept: ViewsKeptAs) -> Result<u64> {
        let quilt_tiles = self.quilt.map_or(0, |q| q.layout.tiles());
        let needed = estimate_render_memory(width, height, self.views, self.options.sampling, kept)
            .saturating_add(outputs::extra_memory(
                width,
                height,
                self.views,
                quilt_tiles,
                outputs::quilt_pixel_bytes(&self.spec.output.path),
                self.spec.output.depth,
            ));
        check_memory(
            needed,
            available_memory(),
            &format!("rendering {} view(s) of {width}x{height}", self.views),
        )?;
        Ok(needed)
    }

    /// The loaded scene's whole hierarchy, or a new one with `cut`.
    fn world_for(&self, loaded: &Loaded, cut: Option<Cut>, seconds: &mut f64) -> Arc<World> {
        let start = Instant::now();
        let world = match cut {
            None => loaded.world(&self.pool),
            Some(cut) => Arc::new(
                self.pool
                    .install(|| World::with_cut((*loaded.scene).clone(), Some(cut))),
            ),
        };
        *seconds += if cut.is_none() {
            world.build_seconds
        } else {
            start.elapsed().as_secs_f64()
        };
        world
    }

    /// Where to cut the object tree, if asked (the parallax bound depends on
    /// the interaxial); `--fast` cuts it unless the `epipolar` rows take the
    /// views.
    fn cut(&self, camera: &Camera, rig: &Rig, epipolar: bool) -> Result<Option<Cut>> {
        let a = &self.spec.approximations;
        let fast_cut = a.fast && !(epipolar && rig.views.len() >= 2);
        let parallax = a.cut_parallax.or(fast_cut.then_some(FAST_CUT_PARALLAX));
        let depth = match (a.cut_distance, parallax) {
            (Some(d), _) => f64::from(d),
            (None, Some(px)) => match rig.cut_depth_for_parallax(camera, px) {
                Some(d) => d,
                None => return Ok(None),
            },
            (None, None) => return Ok(None),
        };
        Ok(Some(Cut::at_depth(camera, depth as f32)))
    }

    /// Renders the views. `progress(done, total)` is called from worker
    /// threads; raising `cancel` stops the render with [`Error::Cancelled`].
    pub fn render(
        &self,
        plan: &Plan,
        progress: &(dyn Fn(u64, u64) + Sync),
        cancel: &CancelToken,
    ) -> Result<Rendered> {
        // The plan checked the memory for views kept as bytes where the
        // files allow it; floats take up to four times as much.
        if self.kept_for_writing(&plan.rig, plan.interaxial) == ViewsKeptAs::Bytes {
            self.check_memory(plan.width, plan.height, ViewsKeptAs::Floats)?;
        }
        self.render_with(plan, &self.options, ViewStorage::Float, progress, cancel)
    }

    /// [`Job::render`] for a caller that only writes the files
    /// ([`Job::write`]): where every file is an 8-bit image of views as
    /// rendered whose pixels it only moves (separate files, a quilt, a pair
    /// side by side, crossed, top-bottom or interlaced; no exposure, tone
    /// curve, floating window or depth channels: `Targets::storage`) and
    /// the sampling is not the SPD's corners, the views come back as the
    /// 8-bit pixels the files hold (`output.rgb8`, and `output.images`
    /// empty): a quarter of the memory, quantised as the rows are traced.
    /// The files are the same, byte for byte. A caller that shows, composes or measures the images uses
    /// [`Job::render`].
    pub fn render_for_writing(
        &self,
        plan: &Plan,
        progress: &(dyn Fn(u64, u64) + Sync),
        cancel: &CancelToken,
    ) -> Result<Rendered> {
        let storage = self.storage_for_writing(&plan.rig, plan.interaxial);
        self.render_with(plan, &self.options, storage, progress, cancel)
    }

    /// [`Job::render`] with other render options (a preview's coarse passes).
    fn render_with(
        &self,
        plan: &Plan,
        options: &RenderOptions,
        storage: ViewStorage,
        progress: &(dyn Fn(u64, u64) + Sync),
        cancel: &CancelToken,
    ) -> Result<Rendered> {
        let mut output = self.pool.install(|| {
            render::render_rows_as(
                &plan.world,
                &plan.camera,
                &plan.rig,
                options,
                plan.rows.clone(),
                storage,
                progress,
                cancel,
            )
        })?;
        let mut messages = Vec::new();
        if let (Some(s), true) = (&plan.settled, self.spec.rig.floating_window) {
            output::apply_floating_window(&mut output.images, &s.report.floating_window);
            let w = s.report.floating_window;
            messages.push(Message::info(format!(
                "floating window: {} px masked at the left edge, {} px at the right",
                w.left_px, w.right_px
            )));
        }
        let depth = self.spec.output.depth.then(|| {
            self.pool
                .install(|| outputs::measure_depth(&plan.world, &plan.camera, &plan.rig))
        });
        messages.extend(self.render_messages(plan, options, &output));
        Ok(Rendered {
            output,
            depth,
            messages,
        })
    }

    fn render_messages(&self, plan: &Plan, o: &RenderOptions, r: &RenderOutput) -> Vec<Message> {
        let pixels = f64::from(plan.width) * f64::from(plan.height);
        let mut m = vec![
            Message::info(format!(
                "rendered {} view(s) {}x{} by {} in {:.3} s; eye rays {}, traversals per eye ray {:.3}",
                plan.rig.views.len(),
                plan.width,
                plan.height,
                o.method.name(),
                r.seconds,
                r.counts.rays.eye,
                r.counts.eye_traversals as f64 / r.counts.rays.eye.max(1) as f64
            )),
            Message::info(format!(
                "sampling: {}; eye samples per pixel {:.2} (most {}), pixels refined {}",
                o.sampling.describe(),
                r.samples_per_view as f64 / pixels,
                r.max_samples_per_pixel,
                r.refined_pixels
            )),
        ];
        if o.shadow_fans {
            let c = &r.counts;
            m.push(Message::info(format!(
                "shared shadows: fans asked {}, free {}; shadow rays proved (not traced) {}, traced {}",
                c.fan_queries, c.fan_free, c.shadow_rays_proved, c.rays.shadow
            )));
        }
        if self.is_approximate() {
            let c = &r.counts;
            m.push(Message::info(format!(
                "approximations: samples cut {}, secondary rays merged {}, samples reprojected {}, refused {}, traced as holes {}",
                c.samples_cut, c.merged_rays, c.reprojected, c.reproject_rejected, c.hole_samples
            )));
            if o.approx.shared_shading.is_some() {
                m.push(Message::info(format!(
                    "shared shading: cache entries {} (refused at a shadow edge {}), samples that took an entry's light {} (its whole colour {}), exact fall-backs {}",
                    c.cache_entries, c.cache_edge_refusals, c.cache_hits, c.cache_colour_hits, c.cache_fallbacks
                )));
                m.push(Message::info(format!(
                    "key views: samples traced as key views {}, interpolated samples {}, fall-backs {} (probe rays {}), groups traced whole after a miss {}; shadow fans {} ({} lit whole)",
                    c.key_view_samples, c.interpolated_samples, c.key_view_fallbacks, c.key_view_probes, c.key_view_skipped_groups, c.fan_queries, c.fan_free
                )));
            }
            if o.approx.synthesize_views.is_some() {
                let y = &c.synthesis;
                m.push(Message::info(format!(
                    "view synthesis: key-view samples {}, synthesized {}, traced {} (no key surface {}, mirror, glass or highlight {}, two surfaces {}, colour edge {}, region not free {}); region proofs {} ({} found something, {} nodes)",
                    y.key_samples, y.synthesized, y.traced, y.holes, y.refused_material, y.refused_edge, y.refused_surface, y.refused_region, y.proofs, y.proofs_failed, y.proof_nodes
                )));
            }
            if o.approx.epipolar_views.is_some() {
                let e = &c.epipolar;
                m.push(Message::info(format!(
                    "epipolar rows: {} in their planes ({} traced exactly), primitives gathered {}, visibility tests {}; samples: colour taken {}, light taken {}, light partly taken {} ({} shadow rays), shaded exactly {} (no shade point {}, colours and light apart {}, shade points apart {}, mirror, glass or highlight {}, shape {}), background {}; shade points {}",
                    e.rows, e.rows_exact, e.primitives, e.tests, e.taken, e.light_taken, e.light_partly_taken, e.lights_traced, e.traced, e.no_bracket, e.refused_colour, e.refused_wide, e.refused_material, e.refused_shape, e.misses, e.shade_points
                )));
            }
            if o.approx.interpolate_views.is_some() {
                let i = &c.interp;
                m.push(Message::info(format!(
                    "interpolated views: proved spans {} (refused for the material {}, the surface {}), samples interpolated {}, shaded {}; pairs judged {}, refused: shading tree {}, colours apart {}, light or shadow {}",
                    i.spans, i.spans_refused_material, i.spans_refused_surface, i.interpolated, i.shaded, i.pairs, i.refused_tree, i.refused_colour, i.refused_light
                )));
            }
        }
        m
    }

    fn is_approximate(&self) -> bool {
        let a = &self.spec.approximations;
        !self.options.approx.is_exact()
            || a.fast
            || a.cut_distance.is_some()
            || a.cut_parallax.is_some()
    }

    /// The rendered views composed as one picture (a video frame: see
    /// [`Animation`](crate::animation::Animation)), as an 8-bit file shows
    /// it (exposure and tone curve applied; encode with
    /// [`Job::write_options`]), and how its eyes are packed.
    pub fn compose_frame(
        &self,
        rendered: &Rendered,
    ) -> Result<(crate::Image, crate::video::FramePacking)> {
        let shown = outputs::displayed(&self.spec.output, &rendered.output.images);
        outputs::compose_frame(&self.spec.output, self.quilt.as_ref(), &shown)
    }

    /// The file a video of this job's frames is written to: `out`, or for a
    /// quilt `NAME_qsCOLSxROWSaASPECT.ext`, the grid and the views' aspect
    /// that Looking Glass software reads from the name (as a quilt still's).
    pub fn video_path(&self, out: &std::path::Path, plan: &Plan) -> PathBuf {
        match (self.spec.output.layout, self.quilt) {
            (LayoutSpec::Quilt, Some(q)) => {
                output::quilt_path(out, q.layout, plan.width, plan.height)
            }
            _ => out.to_path_buf(),
        }
    }

    /// Writes the files (all or none) and the statistics; returns the files
    /// written. `loaded` and the seconds of writing feed the statistics.
    pub fn write(&self, loaded: &Loaded, plan: &Plan, rendered: &Rendered) -> Result<Vec<PathBuf>> {
        let start = Instant::now();
        let targets = self.targets(&plan.rig, plan.interaxial);
        let mut written = self.pool().install(|| {
            if rendered.output.rgb8.is_empty() {
                targets.write(
                    &rendered.output.images,
                    rendered.depth.as_deref(),
                    &plan.files,
                )
            } else {
                targets.write_rgb8(&rendered.output.rgb8, &plan.files)
            }
        })?;
        let write_s = start.elapsed().as_secs_f64();
        if let Some(path) = &self.spec.output.stats {
            let report = self.report(loaded, plan, rendered, write_s);
            output::write_text(path, &report.to_json())?;
            written.push(path.clone());
        }
        Ok(written)
    }

    /// The `--stats` report of a finished job.
    pub fn report(
        &self,
        loaded: &Loaded,
        plan: &Plan,
        rendered: &Rendered,
        write_s: f64,
    ) -> Report {
        let (width, height) = (plan.width, plan.height);
        let result = &rendered.output;
        let world = &plan.world;
        let views = plan.rig.views.len();
        let mut report = Report {
            time: Timings {
                load_s: loaded.load_seconds,
                build_s: plan.build_seconds,
                render_s: result.seconds,
                write_s,
                ..Timings::default()
            },
            scene: SceneFacts {
                primitives: world.scene.shapes.len(),
                lights: world.scene.lights.len(),
                materials: world.scene.materials.len(),
                bvh_nodes: world.bvh.nodes.len(),
                bvh_depth: world.bvh.depth(),
                memory_bytes: world.memory_bytes(),
                warnings: world.scene.warnings.len(),
            },
            width,
            height,
            views,
            method: if views == 1 {
                "mono".into()
            } else {
                self.options.method.name().to_string()
            },
            views_kept_as: if result.rgb8.is_empty() {
                "float"
            } else {
                "rgb8"
            }
            .into(),
            samples_per_view: result.samples_per_view,
            sampling: SamplingFacts {
                mode: self.options.sampling.describe(),
                eye_samples_per_pixel_mean: result.samples_per_view as f64
                    / (f64::from(width) * f64::from(height)),
                eye_samples_per_pixel_max: result.max_samples_per_pixel,
                refined_pixels: result.refined_pixels,
            },
            ..Report::default()
        };
        report.fill_counts(&result.counts, views);
        report.cut_depth = plan.cut.map(|c| c.depth);
        if let Some(s) = &plan.settled {
            report.time.depth_s = Some(s.depth_seconds);
            report.rig_choice = Some(s.choice.clone());
            report.disparity = Some(s.report.clone());
        }
        report.cut_primitives = world.cut_primitives();
        if self.views > 1 {
            report.interaxial = Some(plan.interaxial);
            report.convergence = plan.convergence;
            report.effective_convergence = plan.rig.effective_convergence;
        }
        report
    }

    /// Every stage in order, for a caller with nothing to show in between:
    /// returns the files written and every message.
    pub fn run(
        spec: JobSpec,
        progress: &(dyn Fn(u64, u64) + Sync),
        cancel: &CancelToken,
    ) -> Result<(Vec<PathBuf>, Vec<Message>)> {
        let job = Job::check(spec)?;
        let loaded = job.load()?;
        let plan = job.plan(&loaded)?;
        let rendered = job.render_for_writing(&plan, progress, cancel)?;
        let written = job.write(&loaded, &plan, &rendered)?;
        let messages = [
            job.messages(),
            &loaded.messages,
            &plan.messages,
            &rendered.messages,
        ]
        .concat();
        Ok((written, messages))
    }
}

/// The worker threads of a job: `threads` of them (default: every core),
/// with stacks of 8 MiB (reserved, not used): room beyond the depth cap.
fn worker_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    let mut pool = rayon::ThreadPoolBuilder::new().stack_size(8 << 20);
    if let Some(n) = threads {
        pool = pool.num_threads(n);
    }
    pool.build()
        .map_err(|e| Error::Invalid(format!("cannot start worker threads: {e}")))
}

/// The verbose account of a plan: scene, rig, the rig's choice and report,
/// the cut; and the report's warnings.
fn plan_messages(plan: &Plan, rig_by_default: bool, interaxial_given: bool) -> Vec<Message> {
    let world = &plan.world;
    let mut m = vec![Message::info(format!(
        "scene: {} primitives, {} lights, hierarchy {} nodes (depth {}), built in {:.3} s",
        world.scene.shapes.len(),
        world.scene.lights.len(),
        world.bvh.nodes.len(),
        world.bvh.depth(),
        plan.build_seconds
    ))];
    m.push(Message::info(format!(
        "memory: about {} for the views and the files (the scene aside)",
        human_bytes(plan.memory)
    )));
    if plan.rig.views.len() > 1 {
        let conv = match plan.convergence {
            Some(c) => format!("{c}"),
            None => "infinity".into(),
        };
        let eff = match plan.rig.effective_convergence {
            Some(c) => format!("{c:.6}"),
            None => "infinity (parallel)".into(),
        };
        m.push(Message::info(format!(
            "rig: {} views, interaxial {}, focal length {:.3} px, convergence asked {}, effective {}",
            plan.rig.views.len(),
            plan.interaxial,
            plan.camera.focal_pixels(),
            conv,
            eff
        )));
        for (i, v) in plan.rig.views.iter().enumerate() {
            m.push(Message::info(format!(
                "  view {i}: offset {:+.6} along the right axis, image shift {:+} px",
                v.offset, v.shift
            )));
        }
    }
    if let Some(s) = &plan.settled {
        m.extend(s.report_lines().into_iter().map(Message::info));
    }
    if let Some(c) = plan.cut {
        m.push(Message::info(format!(
            "cut (section 2.3): {} of {} primitives beyond depth {:.3}",
            world.cut_primitives(),
            world.scene.shapes.len(),
            c.depth
        )));
    }
    if let Some(s) = &plan.settled {
        // The defaults' own choice (a quilt's 35° view cone) is not warned
        // about: the user asked for nothing the budget could contradict.
        let budget = if rig_by_default {
            Message::info
        } else {
            Message::warning
        };
        let advice = if interaxial_given {
            "; --interaxial auto fits them"
        } else {
            ""
        };
        m.extend(
            s.report
                .budget_warning()
                .map(|w| budget(format!("{w}{advice}"))),
        );
        if rig_by_default {
            m.extend(s.report.quilt_divergence_note().map(Message::note));
        } else {
            m.extend(s.report.divergence_warning().map(Message::warning));
        }
    }
    m
}

/// What [`Job::check`] derives from a spec.
struct Checked {
    views: usize,
    quilt: Option<QuiltSpec>,
    budget: Option<DepthBudget>,
    interaxial: Option<Interaxial>,
    options: RenderOptions,
}

fn invalid(message: impl Into<String>) -> Error {
    Error::Invalid(message.into())
}

impl Checked {
    fn of(spec: &JobSpec) -> Result<Checked> {
        let (rig, out) = (&spec.rig, &spec.output);
        let quilt_layout = out.layout == LayoutSpec::Quilt;
        let several_views =
            rig.stereo || rig.views.is_some_and(|n| n > 1) || (quilt_layout && rig.views.is_none());
        check_combinations(spec, several_views)?;
        let interaxial = rig
            .interaxial
            .as_deref()
            .map(|s| {
                s.parse::<Interaxial>()
                    .map_err(|e| invalid(format!("--interaxial {e}")))
            })
            .transpose()?;
        let budget = rig
            .depth_budget
            .as_deref()
            .map(|s| s.parse::<DepthBudget>())
            .transpose()?;
        check_rig_flags(spec, several_views || quilt_layout, quilt_layout)?;
        let quilt = out
            .quilt
            .as_deref()
            .map(str::parse::<QuiltSpec>)
            .transpose()?;
        if out.depth {
            outputs::check_depth_output(
                &out.path,
                matches!(out.layout, LayoutSpec::Separate | LayoutSpec::Multiview),
            )?;
        }
        if let Some(n) = spec.trace.threads {
            check_threads(n).map_err(|e| invalid(format!("--threads: {e}")))?;
        }
        let sampling = sampling(&spec.sampling)?;
        if let Some(n) = rig.views_per_batch {
            if !(1..=render::MAX_LANES).contains(&n) {
                return Err(invalid(format!(
                    "--views-per-batch must be 1 to {}, got {n}",
                    render::MAX_LANES
                )));
            }
        }
        let trace = trace_settings(spec);
        trace.validate().map_err(|e| {
            let flag = if (1..=render::MAX_DEPTH).contains(&spec.trace.max_depth) {
                "--min-weight"
            } else {
                "--max-depth"
            };
            invalid(format!("{flag}: {e}"))
        })?;
        let views = view_count(spec, quilt.filter(|_| quilt_layout))?;
        if views > 1 {
            // The request's own checks (convergence, view cone), on a stand-in
            // distance: the scene's is known only once it is loaded.
            let flags = RigFlags {
                interaxial,
                convergence: rig.convergence.as_deref(),
                view_cone: rig.view_cone,
                budget,
            };
            rig_choice::rig_request(&flags, quilt_layout, views, 1.0)?;
        }
        let approx = approximations(&spec.approximations, sampling)?;
        check_cut(&spec.approximations)?;
        let method = match rig.method {
            MethodSpec::Independent => Method::Independent,
            MethodSpec::Twin => Method::Twin,
        };
        let a = &spec.approximations;
        let approximate =
            !approx.is_exact() || a.fast || a.cut_distance.is_some() || a.cut_parallax.is_some();
        if approximate && (views == 1 || method == Method::Independent) {
            return Err(invalid("the approximations (--fast, --merge-secondary, --reproject, --share-shading, --cut-*) need --stereo or --views and the twin method"));
        }
        Ok(Checked {
            views,
            quilt: quilt.filter(|_| quilt_layout),
            budget,
            interaxial,
            options: RenderOptions {
                trace,
                method,
                sampling,
                approx,
                views_per_batch: rig.views_per_batch.unwrap_or(0),
                strip: rig.strip,
                eye_runs: rig.eye_runs,
                shadow_fans: rig.shadow_fans,
                shadow_fan_min_run: 0,
            },
        })
    }
}

/// Flag combinations that would be silently ignored or coerced.
fn check_combinations(spec: &JobSpec, several_views: bool) -> Result<()> {
    let (rig, out) = (&spec.rig, &spec.output);
    if !several_views {
        if rig.interaxial.is_some() {
            return Err(invalid("--interaxial needs --stereo or --views N (N > 1)"));
        }
        if rig.convergence.is_some() {
            return Err(invalid("--convergence needs --stereo or --views N (N > 1)"));
        }
    }
    if out.squeeze
        && !matches!(
            out.layout,
            LayoutSpec::Sbs | LayoutSpec::Cross | LayoutSpec::Tb
        )
    {
        return Err(invalid(
            "--squeeze applies to --layout sbs, cross or tb only",
        ));
    }
    if out.anaglyph.is_some() && out.layout != LayoutSpec::Anaglyph {
        return Err(invalid(
            "--anaglyph chooses the colours of --layout anaglyph; add it or drop --anaglyph",
        ));
    }
    if out.interlace.is_some() && out.layout != LayoutSpec::Interlace {
        return Err(invalid(
            "--interlace chooses the pattern of --layout interlace; add it or drop --interlace",
        ));
    }
    if spec.sampling.spd && spec.trace.min_weight.is_some() {
        return Err(invalid(
            "--spd traces every ray (no cut-off): --min-weight does not apply",
        ));
    }
    Ok(())
}

/// The depth-budget, window and quilt settings against the rest.
fn check_rig_flags(spec: &JobSpec, several_views: bool, quilt_layout: bool) -> Result<()> {
    let rig = &spec.rig;
    if !several_views {
        if rig.floating_window {
            return Err(invalid(
                "--floating-window needs --stereo or --views N (N > 1)",
            ));
        }
        if rig.view_cone.is_some() {
            return Err(invalid(
                "--view-cone needs --stereo, --views N (N > 1) or --layout quilt",
            ));
        }
        if rig.depth_budget.is_some() {
            return Err(invalid(
                "--depth-budget needs --stereo, --views N (N > 1) or --layout quilt",
            ));
        }
    }
    if rig.view_cone.is_some() && rig.interaxial.is_some() {
        return Err(invalid(
            "--view-cone and --interaxial both set the interaxial: give one",
        ));
    }
    if !(rig.screen_width.is_finite() && rig.screen_width > 0.0) {
        return Err(invalid(format!(
            "--screen-width must be a width in metres > 0, got {}",
            rig.screen_width
        )));
    }
    match (quilt_layout, spec.output.quilt.is_some()) {
        (true, false) => Err(invalid(
            "--layout quilt needs --quilt COLSxROWS or a preset (portrait, go, legacy)",
        )),
        (false, true) => Err(invalid(
            "--quilt sets the grid of --layout quilt; add it or drop --quilt",
        )),
        _ => Ok(()),
    }
}

/// How many views: checked against the layout and the quilt.
fn view_count(spec: &JobSpec, quilt: Option<QuiltSpec>) -> Result<usize> {
    let (rig, out) = (&spec.rig, &spec.output);
    let count = match (rig.stereo, rig.views) {
        (true, Some(n)) if n != 2 => {
            return Err(invalid(format!(
                "--stereo renders 2 views; use --views {n} alone for a multi-view set"
            )))
        }
        (_, Some(0)) => return Err(invalid("--views must be at least 1")),
        (_, Some(n)) if n > render::MAX_VIEWS => {
            return Err(invalid(format!(
                "--views {n}: at most {} views",
                render::MAX_VIEWS
            )))
        }
        (_, Some(n)) => n,
        (true, None) => 2,
        (false, None) => quilt.map_or(1, |q| q.layout.tiles()),
    };
    if let Some(q) = quilt {
        let (c, r) = (q.layout.columns, q.layout.rows);
        if count > render::MAX_VIEWS {
            return Err(invalid(format!(
                "--quilt {c}x{r} takes {count} views: at most {} views (--views N renders fewer, the other tiles black)",
                render::MAX_VIEWS
            )));
        }
        if count > q.layout.tiles() {
            return Err(invalid(format!(
                "--views {count} do not fit a {c}x{r} quilt ({} tiles)",
                q.layout.tiles()
            )));
        }
    }
    if count == 1 && out.layout != LayoutSpec::Separate {
        return Err(invalid("--layout needs --stereo (or --views)"));
    }
    if count != 2
        && !matches!(
            out.layout,
            LayoutSpec::Separate | LayoutSpec::Multiview | LayoutSpec::Quilt
        )
    {
        return Err(invalid(format!(
            "--layout {} takes exactly two views",
            out.layout.name()
        )));
    }
    outputs::check_layout_format(out.layout, &out.path)?;
    Ok(count)
}

fn trace_settings(spec: &JobSpec) -> TraceSettings {
    TraceSettings {
        max_depth: spec.trace.max_depth,
        min_weight: match (spec.sampling.spd, spec.trace.min_weight) {
            (true, _) => 0.0,
            (false, Some(w)) => w,
            (false, None) => TraceSettings::default().min_weight,
        },
        spd: spec.sampling.spd,
    }
}

/// The sampling asked for, checked; the SPD procedure (the pixel corners)
/// takes none of the other settings.
pub fn sampling(s: &SamplingSpec) -> Result<Sampling> {
    let given = s.samples.is_some() || s.adaptive.is_some() || s.max_samples.is_some();
    if s.spd {
        if given {
            return Err(invalid("--spd samples the pixel corners: --samples, --adaptive and --max-samples do not apply"));
        }
        return Ok(Sampling::Corners);
    }
    if s.samples.is_some() && (s.adaptive.is_some() || s.max_samples.is_some()) {
        return Err(invalid(
            "--samples N takes fixed samples: --adaptive and --max-samples do not apply",
        ));
    }
    if s.samples.is_none() && (s.filter.is_some() || s.seed.is_some()) {
        return Err(invalid("--filter and --seed need --samples N"));
    }
    let sampling = match (s.samples, s.adaptive) {
        (Some(0), _) => return Err(invalid("--samples must be at least 1")),
        (Some(1), _) if s.filter.is_some_and(|f| f != FilterSpec::Box) => {
            return Err(invalid(
                "--samples 1 traces the pixel centre alone: a --filter needs more samples",
            ))
        }
        (Some(1), _) if s.seed.is_some() => {
            return Err(invalid(
                "--samples 1 traces the pixel centre: --seed needs more samples",
            ))
        }
        (Some(1), _) => Sampling::Centers,
        (Some(samples), _) => Sampling::Stratified {
            samples,
            seed: s.seed.unwrap_or(0),
            filter: match s.filter.unwrap_or(FilterSpec::Box) {
                FilterSpec::Box => Filter::Box,
                FilterSpec::Tent => Filter::Tent,
                FilterSpec::Gaussian => Filter::Gaussian,
            },
        },
        // The default: the paper's adaptive refinement (section 2.6) —
        // anti-aliased edges for about one ray per pixel where the image is
        // smooth (docs/benchmarks.md#anti-aliasing compares it with --samples N).
        (None, threshold) => Sampling::Adaptive {
            threshold: threshold.unwrap_or(Sampling::DEFAULT_THRESHOLD),
            max_samples: s.max_samples.unwrap_or(Sampling::DEFAULT_MAX_SAMPLES),
        },
    };
    sampling.validate().map_err(|e| {
        let flag = match sampling {
            Sampling::Adaptive { threshold, .. }
                if !(threshold.is_finite() && threshold >= 0.0) =>
            {
                "--adaptive"
            }
            Sampling::Adaptive { .. } => "--max-samples",
            _ => "--samples",
        };
        invalid(format!("{flag}: {e}"))
    })?;
    Ok(sampling)
}

/// The approximations asked for, checked (`sampling`: what `--fast` takes
/// depends on it).
fn approximations(a: &ApproximationSpec, sampling: Sampling) -> Result<Approximations> {
    let threshold = a.reproject_threshold;
    if !(threshold.is_finite() && threshold >= 0.0) {
        return Err(invalid(format!(
            "--reproject-threshold must be a coefficient >= 0, got {threshold}"
        )));
    }
    let reproject = (a.reproject || a.fast).then_some(Reprojection {
        mode: match a.reproject_mode {
            ReprojectModeSpec::Safe => ReprojectMode::Safe,
            ReprojectModeSpec::Paper => ReprojectMode::Paper,
        },
        threshold,
    });
    let tolerance = a.share_tolerance;
    if a.synthesize_views && a.synthesis_spacing < 2 {
        return Err(invalid(format!(
            "--synthesis-spacing must be at least 2 (a key view every K views), got {}",
            a.synthesis_spacing
        )));
    }
    if !(tolerance.is_finite() && tolerance >= 0.0) {
        return Err(invalid(format!(
            "--share-tolerance must be an image value >= 0, got {tolerance}"
        )));
    }
    let shared_shading = (a.share_shading
        || (a.fast && a.reproject_mode == ReprojectModeSpec::Safe))
        .then_some(SharedShading { tolerance });
    Ok(Approximations {
        merge_secondary: a.merge_secondary || a.fast,
        reproject,
        shared_shading,
        key_spacing: a.key_spacing,
        // Not under `fast`: on the SPD scenes the interpolation costs more
        // than the shading it spares (benchmarks.md, "Issue 16, eighth pass").
        interpolate_views: a
            .interpolate_views
            .then_some(crate::render::InterpolateViews { tolerance }),
        synthesize_views: a.synthesize_views.then_some(crate::render::ViewSynthesis {
            spacing: a.synthesis_spacing,
            tolerance,
        }),
        // Under `fast` too where every row of samples lies in one plane
        // (pixel centres, the SPD's corners): there they measured faster
        // than its other approximations, and closer to the exact views; with
        // the adaptive sampling's refined rows traced view by view, slower
        // (benchmarks.md, "Issue 16, twelfth pass").
        epipolar_views: (a.epipolar_views
            || (a.fast && matches!(sampling, Sampling::Centers | Sampling::Corners)))
        .then_some(crate::render::EpipolarViews { tolerance }),
    })
}

/// The cut's values, checked before anything is loaded.
fn check_cut(a: &ApproximationSpec) -> Result<()> {
    if a.cut_distance.is_some() && a.cut_parallax.is_some() {
        return Err(invalid(
            "--cut-distance and --cut-parallax both place the cut: give one",
        ));
    }
    if let Some(d) = a.cut_distance {
        if !(d.is_finite() && d > 0.0) {
            return Err(invalid(format!(
                "--cut-distance must be a distance > 0, got {d}"
            )));
        }
    }
    if let Some(px) = a.cut_parallax {
        if !(px.is_finite() && px > 0.0) {
            return Err(invalid(format!(
                "--cut-parallax must be a number of pixels > 0, got {px}"
            )));
        }
    }
    Ok(())
}

//! Animation: a range of frames (`--frames A..B`) rendered as stills of one
//! loaded scene, the camera moved per frame (a turntable, `--orbit`, or
//! keyframes, `--path`), written as numbered images or streamed to a video.
//!
//! Every frame is a [`JobSpec`] of its own — the spec with the frame's camera
//! (`--from/--at/--up/--fov`) and output name — run through the job's stages
//! against one [`Loaded`] scene, so a frame is, bit for bit, the still that
//! its spec renders ([`Animation::frame_spec`]), and nothing of a frame is
//! kept once it is written: memory stays flat over a long shot.
//!
//! **The rig over a shot.** An automatic rig (interaxial or convergence
//! `auto`) fitted to each frame's depths would change from frame to frame,
//! and a rig that jumps is a known source of discomfort. By default
//! ([`ShotRigSpec::PerShot`]) the rig is chosen once: depth passes over up to
//! [`SHOT_SAMPLES`] frames spread over the shot, their depth ranges joined,
//! the rig fitted to that range with the first frame's camera and then given
//! to every frame as an explicit interaxial and convergence.
//! `--rig per-frame` fits each frame on its own.

pub mod frames;
pub mod motion;
mod posing;

pub use frames::{FramePattern, FrameRange};
pub use motion::{CameraPath, FrameCamera, Motion};

use crate::rig::Projection;
use crate::video::Spherical;
use std::path::PathBuf;
use std::sync::Mutex;

use crate::job::{
    AnimationSpec, CancelToken, Job, JobSpec, LayoutSpec, Level, Loaded, Message, ShotRigSpec,
};
use crate::output::encode::to_rgb8;
use crate::rig::camera_overrides as view;
use crate::rig::choice as rig_choice;
use crate::rig::depth_pass::DepthRange;
use crate::scene::Viewpoint;
use crate::video::{Codec, Container, VideoSpec, VideoWriter};
use crate::{Error, Result};

/// Most frames whose depths the per-shot rig is fitted to.
pub const SHOT_SAMPLES: u32 = 16;

/// Where the frames go.
#[derive(Clone, Debug, PartialEq)]
enum FrameOutput {
    /// Image files, one set a frame.
    Images(FramePattern),
    /// One video file (.mp4, .mkv).
    Video(PathBuf),
}

/// A checked animation.
pub struct Animation {
    /// The spec of every frame before its camera, rig and name are set.
    spec: JobSpec,
    /// The first frame's job: checks the spec, loads the scene.
    base: Job,
    frames: FrameRange,
    fps: f64,
    motion: Motion,
    rig: ShotRigSpec,
    skip_existing: bool,
    /// The frames rendered (all, or a machine's share).
    only: FrameRange,
    /// A glTF file with animations: posed for every frame, its nodes at the
    /// frame's time (frame / fps seconds).
    animated: bool,
    output: FrameOutput,
    messages: Vec<Message>,
    /// A video's codec and constant rate factor.
    codec: Codec,
    crf: u32,
    /// An animated file, read at the first frame and kept: what did not
    /// move between frames is kept with it.
    posing: Mutex<Option<posing::Posing>>,
}

/// The rig chosen once for a shot.
#[derive(Clone, Debug, PartialEq)]
pub struct ShotRig {
    pub interaxial: f32,
    /// `None`: parallel.
    pub convergence: Option<f64>,
    /// The joined depth range of the sampled frames.
    pub range: DepthRange,
    /// The frames whose depth passes it was fitted to.
    pub sampled: Vec<u32>,
}

/// Where a render stands: frame `index` of `count` (number `frame`), and
/// the frame's own progress.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameProgress {
    pub frame: u32,
    pub index: u32,
    pub count: u32,
    pub done: u64,
    pub total: u64,
}

/// One frame finished.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameReport {
    pub frame: u32,
    /// Its files (none when it is part of a video).
    pub written: Vec<PathBuf>,
    /// Its files were there already (`skip_existing`): nothing rendered.
    pub skipped: bool,
    pub messages: Vec<Message>,
}

impl Animation {
    /// Checks an animation spec: the frames, rate, motion and output, and
    /// the first frame's job.
    pub fn check(spec: JobSpec) -> Result<Animation> {
        let a = spec.animation.clone();
        let frames: FrameRange = a
            .frames
            .as_deref()
            .ok_or_else(|| Error::Invalid("an animation needs --frames A..B".into()))?
            .parse()?;
        if !(a.fps.is_finite() && a.fps > 0.0) {
            return Err(Error::Invalid(format!(
                "--fps must be a rate > 0, got {}",
                a.fps
            )));
        }
        let only: FrameRange = match a.only.as_deref() {
            Some(text) => text.parse().map_err(|_| {
                Error::Invalid(format!("--only '{text}': give C..D, frames of --frames"))
            })?,
            None => frames,
        };
        if only.first < frames.first || only.last > frames.last {
            return Err(Error::Invalid(format!(
                "--only {}..{} is not within --frames {}..{}",
                only.first, only.last, frames.first, frames.last
            )));
        }
        let motion = match (a.orbit, &a.path) {
            (Some(_), Some(_)) => {
                return Err(Error::Invalid(
                    "--orbit and --path both move the camera: give one".into(),
                ))
            }
            (Some(d), None) if !d.is_finite() => {
                return Err(Error::Invalid(format!(
                    "--orbit must be a finite angle in degrees, got {d}"
                )))
            }
            (Some(degrees), None) => Motion::Orbit { degrees },
            (None, Some(p)) => Motion::Path(CameraPath::read(p)?),
            (None, None) => Motion::Still,
        };
        if spec.tile.is_some() {
            return Err(Error::Invalid(
                "--tiles splits one still: not with --frames".into(),
            ));
        }
        if spec.output.stats.is_some() {
            return Err(Error::Invalid(
                "--stats writes one still's statistics: not with --frames (-v prints each frame's)"
                    .into(),
            ));
        }
        let mut messages = Vec::new();
        let output = match Container::of(&spec.output.path) {
            Some(_) => {
                if a.skip_existing || a.only.is_some() {
                    return Err(Error::Invalid(
                        "--skip-existing and --only share frames written as images, not a video"
                            .into(),
                    ));
                }
                if spec.output.depth {
                    return Err(Error::Invalid(
                        "--depth writes EXR channels: not into a video".into(),
                    ));
                }
                // Refused before anything is rendered when it cannot run.
                crate::video::find_encoder(a.codec)?;
                if a.crf.is_some_and(|c| c > crate::video::MAX_CRF) {
                    return Err(Error::Invalid(format!(
                        "--crf must be 0 (lossless) to {}, got {}",
                        crate::video::MAX_CRF,
                        a.crf.unwrap_or_default()
                    )));
                }
                FrameOutput::Video(spec.output.path.clone())
            }
            None => {
                let (pattern, added) = FramePattern::new(&spec.output.path)?;
                if added {
                    messages.push(Message {
                        level: Level::Note,
                        text: format!(
                            "frames are written as {} (a name with ####, or {{frame}}, says where the number goes)",
                            pattern.path(frames.first).display()
                        ),
                    });
                }
                FrameOutput::Images(pattern)
            }
        };
        let animated = is_animated(&spec.scene);
        if let (Some(clip), false) = (&a.clip, animated) {
            return Err(Error::Invalid(format!(
                "--animation '{clip}': {} has no glTF animations",
                spec.scene.display()
            )));
        }
        let mut still = spec.clone();
        // The frames' stills play the chosen animation (a still job ignores
        // it but checks that the file has it).
        still.animation = AnimationSpec {
            clip: a.clip.clone(),
            ..AnimationSpec::default()
        };
        still.read_files.extend(a.path.iter().cloned());
        let first = frame_still(&still, &output, frames.first, FrameCamera::default(), None);
        let mut animation = Animation {
            spec: still,
            base: Job::check(first)?,
            frames,
            fps: a.fps,
            motion,
            rig: a.rig,
            skip_existing: a.skip_existing,
            only,
            animated,
            output,
            messages,
            codec: a.codec,
            crf: a.crf.unwrap_or(a.codec.default_crf()),
            posing: Mutex::new(None),
        };
        if let FrameOutput::Video(_) = animation.output {
            let views = animation.base.views();
            let layout = animation.spec.output.layout;
            let composable = match views {
                1 => true,
                2 => !matches!(
                    layout,
                    LayoutSpec::Separate | LayoutSpec::Mpo | LayoutSpec::Multiview
                ),
                _ => layout == LayoutSpec::Quilt,
            };
            if !composable {
                return Err(Error::Invalid(format!(
                    "a video shows one picture a frame: {views} views in --layout {} are not one (use sbs, tb, anaglyph, cross, interlace, or quilt for many views)",
                    layout.name()
                )));
            }
        }
        animation
            .messages
            .extend_from_slice(animation.base.messages());
        Ok(animation)
    }

    /// What checking found worth telling.
    pub fn messages(&self) -> &[Message] {
        &self.messages
    }

    pub fn frames(&self) -> FrameRange {
        self.frames
    }

    /// Reads the scene (once for the whole shot).
    pub fn load(&self) -> Result<Loaded> {
        self.base.load()
    }

    /// The scene of `frame`: `None` where the shared one serves (the file is
    /// not animated), else the file posed at the frame's time, with a
    /// two-level hierarchy in which only what moved since the frame asked
    /// for before was made and built again. It equals the scene a fresh
    /// load at that time gives (`Job::load_at`), shape for shape.
    pub fn loaded_at(&self, frame: u32) -> Result<Option<Loaded>> {
        if !self.animated {
            return Ok(None);
        }
        let time = (f64::from(frame) / self.fps) as f32;
        let mut posing = self.posing.lock().unwrap_or_else(|e| e.into_inner());
        let posing = match &mut *posing {
            Some(p) => p,
            None => posing.insert(posing::Posing::open(&self.base)?),
        };
        posing.loaded_at(&self.base, time).map(Some)
    }

    /// The scene's viewpoint with the spec's camera flags: what the motion
    /// moves.
    pub fn base_viewpoint(&self, loaded: &Loaded) -> Result<Viewpoint> {
        Ok(view::resolve(&loaded.scene, &self.base.view_overrides())?.0)
    }

    /// The still of `frame` (a frame of the range): the spec with the
    /// frame's camera, the shot's rig if one was chosen, and the frame's
    /// output name (a video's frames get the video's name as a .png, unused).
    pub fn frame_spec(
        &self,
        loaded: &Loaded,
        frame: u32,
        shot: Option<&ShotRig>,
    ) -> Result<JobSpec> {
        if !(self.frames.first..=self.frames.last).contains(&frame) {
            return Err(Error::Invalid(format!(
                "frame {frame} is outside --frames {}..{}",
                self.frames.first, self.frames.last
            )));
        }
        let base = self.base_viewpoint(loaded)?;
        let camera =
            self.motion
                .camera(&base, frame, frame - self.frames.first, self.frames.count());
        Ok(self.spec_with(frame, camera, shot))
    }

    fn spec_with(&self, frame: u32, camera: FrameCamera, shot: Option<&ShotRig>) -> JobSpec {
        frame_still(&self.spec, &self.output, frame, camera, shot)
    }

    /// The rig of the whole shot ([`ShotRigSpec::PerShot`]): `None` where
    /// nothing is automatic, one view, one frame, per-frame rigs, or nothing
    /// visible in the sampled frames.
    pub fn shot_rig(&self, loaded: &Loaded) -> Result<Option<ShotRig>> {
        if self.rig == ShotRigSpec::PerFrame || self.frames.count() < 2 || self.base.views() < 2 {
            return Ok(None);
        }
        let own = self.loaded_at(self.frames.first)?;
        let at_first = own.as_ref().unwrap_or(loaded);
        let first = Job::check_sharing_threads(
            self.frame_spec(at_first, self.frames.first, None)?,
            &self.base,
        )?;
        let vp = view::resolve(&at_first.scene, &first.view_overrides())?.0;
        let Some(request) = first.rig_request(f64::from((vp.at - vp.from).length()))? else {
            return Ok(None);
        };
        if !request.needs_depth() {
            return Ok(None);
        }
        let n = self.frames.count().min(SHOT_SAMPLES);
        let sampled: Vec<u32> = (0..n)
            .map(|i| {
                let span = u64::from(self.frames.count() - 1);
                self.frames.first + (span * u64::from(i) / u64::from((n - 1).max(1))) as u32
            })
            .collect();
        let mut range: Option<DepthRange> = None;
        let mut camera = None;
        for &f in &sampled {
            let own = self.loaded_at(f)?;
            let loaded = own.as_ref().unwrap_or(loaded);
            let job = Job::check_sharing_threads(self.frame_spec(loaded, f, None)?, &self.base)?;
            let plan = job.plan(loaded)?;
            let fitted = plan.settled.as_ref().and_then(|s| s.choice.fitted_to);
            if let Some(r) = fitted {
                range = Some(match range {
                    None => r,
                    Some(u) => DepthRange {
                        near: u.near.min(r.near),
                        far: u.far.max(r.far),
                    },
                });
            }
            camera.get_or_insert(plan.camera);
        }
        let (Some(range), Some(camera)) = (range, camera) else {
            return Ok(None);
        };
        let choice = rig_choice::choose_rig(&camera, &request, Some(range))?;
        Ok(Some(ShotRig {
            interaxial: choice.interaxial,
            convergence: choice.convergence,
            range,
            sampled,
        }))
    }

    /// Renders every frame, in order: `progress` as each frame's rows
    /// complete (from worker threads), `on_frame` as each is written.
    /// Returns the files written (a video: its one file) and the messages of
    /// the shot (the rig chosen for it).
    pub fn run(
        &self,
        loaded: &Loaded,
        progress: &(dyn Fn(FrameProgress) + Sync),
        on_frame: &mut dyn FnMut(FrameReport),
        cancel: &CancelToken,
    ) -> Result<(Vec<PathBuf>, Vec<Message>)> {
        let mut messages = Vec::new();
        let shot = self.shot_rig(loaded)?;
        if let Some(s) = &shot {
            messages.push(Message {
                level: Level::Info,
                text: format!(
                    "rig of the shot: interaxial {}, convergence {}, fitted to depths {:.4}..{:.4} over frames {:?}",
                    s.interaxial,
                    s.convergence.map_or("infinity".into(), |c| format!("{c:.6}")),
                    s.range.near,
                    s.range.far,
                    s.sampled
                ),
            });
        }
        let mut video: Option<VideoWriter> = None;
        let mut written = Vec::new();
        let mut beyond = BeyondTheRig::default();
        let count = self.frames.count();
        for (index, frame) in self.frames.iter().enumerate() {
            if cancel.is_cancelled() {
                return Err(Error::Cancelled);
            }
            if !(self.only.first..=self.only.last).contains(&frame) {
                continue;
            }
            let own = self.loaded_at(frame)?;
            let loaded = own.as_ref().unwrap_or(loaded);
            let job = Job::check_sharing_threads(
                self.frame_spec(loaded, frame, shot.as_ref())?,
                &self.base,
            )?;
            let plan = job.plan(loaded)?;
            if let (FrameOutput::Video(path), None) = (&self.output, &video) {
                // The video is no frame's file: checked here, before the
                // first frame is rendered, against what the job reads.
                let inputs = crate::job::job_inputs(job.spec(), &loaded.scene);
                let inputs: Vec<&std::path::Path> = inputs.iter().map(PathBuf::as_path).collect();
                crate::output::check_distinct(&[job.video_path(path, &plan)], &inputs)?;
            }
            if self.skip_existing && plan.files.iter().all(|f| f.exists()) {
                on_frame(FrameReport {
                    frame,
                    written: plan.files.clone(),
                    skipped: true,
                    messages: Vec::new(),
                });
                continue;
            }
            let index = index as u32;
            let frame_progress = |done: u64, total: u64| {
                progress(FrameProgress {
                    frame,
                    index,
                    count,
                    done,
                    total,
                })
            };
            // Frames written as images need only the files' 8-bit pixels.
            let rendered = match &self.output {
                FrameOutput::Images(_) => job.render_for_writing(&plan, &frame_progress, cancel)?,
                FrameOutput::Video(_) => job.render(&plan, &frame_progress, cancel)?,
            };
            let mut frame_messages = plan.messages.clone();
            if shot.is_some() {
                beyond.take(frame, &plan, &mut frame_messages);
            }
            if let Some(c) = plan.world.instances {
                frame_messages.push(Message {
                    level: Level::Info,
                    text: format!(
                        "frame {frame}: hierarchy of {} instances, {} of them built again ({} of {} primitives; {} made from the file)",
                        c.instances, c.rebuilt_instances, c.rebuilt_primitives, c.primitives, c.made_primitives
                    ),
                });
            }
            frame_messages.extend(rendered.messages.iter().cloned());
            let files = match &self.output {
                FrameOutput::Images(_) => job.write(loaded, &plan, &rendered)?,
                FrameOutput::Video(path) => {
                    let (picture, packing) = job.compose_frame(&rendered)?;
                    let writer = match &mut video {
                        Some(w) => w,
                        None => video.insert(VideoWriter::start(VideoSpec {
                            path: job.video_path(path, &plan),
                            width: picture.width,
                            height: picture.height,
                            fps: self.fps,
                            packing,
                            crf: self.crf,
                            codec: self.codec,
                            spherical: match plan.camera.projection {
                                Projection::Equirect | Projection::Ods(_) => Spherical::Equirect360,
                                Projection::Vr180 => Spherical::Equirect180,
                                _ => Spherical::None,
                            },
                        })?),
                    };
                    let bytes = job
                        .pool()
                        .install(|| to_rgb8(&picture, &job.write_options()));
                    writer.push(&bytes)?;
                    Vec::new()
                }
            };
            written.extend(files.iter().cloned());
            on_frame(FrameReport {
                frame,
                written: files,
                skipped: false,
                messages: frame_messages,
            });
        }
        if let Some(v) = video {
            written.push(v.finish()?);
        }
        messages.extend(beyond.note(count));
        Ok((written, messages))
    }
}

/// The frames where the shot's one rig, fitted to the depths of a few of
/// them, exceeds the depth budget or makes far points diverge. The rig is
/// the automatic one, so each frame's warning would blame a choice the user
/// did not make: they become one note for the shot.
#[derive(Default)]
struct BeyondTheRig {
    frames: Vec<u32>,
    /// The widest disparities between adjacent views, in per cent of the width.
    near: f64,
    far: f64,
}

impl BeyondTheRig {
    /// Takes the rig's own warnings out of a frame's `messages`.
    fn take(&mut self, frame: u32, plan: &crate::job::Plan, messages: &mut Vec<Message>) {
        let Some(settled) = &plan.settled else {
            return;
        };
        let report = &settled.report;
        let own: Vec<String> = report
            .budget_warning()
            .into_iter()
            .chain(report.divergence_warning())
            .collect();
        if own.is_empty() {
            return;
        }
        messages.retain(|m| {
            m.level != Level::Warning || !own.iter().any(|w| m.text.starts_with(w.as_str()))
        });
        self.frames.push(frame);
        if let Some(p) = report.adjacent_percent {
            self.near = self.near.min(p.near);
            self.far = self.far.max(p.far);
        }
    }

    fn note(&self, count: u32) -> Option<Message> {
        let first = self.frames.first()?;
        Some(Message {
            level: Level::Note,
            text: format!(
                "the shot's one rig, fitted to a few of its frames, goes beyond the depth budget \
                 (or makes far points diverge) on {} of {count} frames from frame {first} on, \
                 with disparities of {:+.2}% to {:+.2}% of the width; --rig per-frame fits each \
                 frame on its own",
                self.frames.len(),
                self.near,
                self.far
            ),
        })
    }
}

/// The still of `frame`: `spec` with the frame's camera, output name and the
/// shot's rig.
fn frame_still(
    spec: &JobSpec,
    output: &FrameOutput,
    frame: u32,
    camera: FrameCamera,
    shot: Option<&ShotRig>,
) -> JobSpec {
    let mut s = spec.clone();
    let c = &mut s.camera;
    if let Some(v) = camera.from {
        c.from = Some(v.to_array());
    }
    if let Some(v) = camera.at {
        c.at = Some(v.to_array());
    }
    if let Some(v) = camera.up {
        c.up = Some(v.to_array());
    }
    if let Some(f) = camera.fov {
        c.fov = Some(f);
    }
    s.output.path = match output {
        FrameOutput::Images(p) => p.path(frame),
        FrameOutput::Video(v) => v.with_extension("png"),
    };
    if let Some(r) = shot {
        s.rig.interaxial = Some(r.interaxial.to_string());
        s.rig.convergence = Some(r.convergence.map_or("inf".into(), |c| c.to_string()));
        s.rig.view_cone = None;
    }
    s
}

/// Whether `scene` is a glTF file with animations.
fn is_animated(scene: &std::path::Path) -> bool {
    let ext = scene
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    matches!(ext.as_deref(), Some("gltf" | "glb"))
        && crate::loaders::files::read_user_file(scene, crate::loaders::files::MAX_FILE_BYTES)
            .is_ok_and(|b| crate::loaders::gltf::animation::has_animations(&b))
}

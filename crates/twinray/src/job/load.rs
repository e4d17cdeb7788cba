//! The second stage: the scene read (or one in memory readied), with what
//! a file leaves out supplied: a framing camera, lights, a floor, the
//! background or environment, the up axis of a mesh file.

use std::sync::{Arc, OnceLock};
use std::time::Instant;

use super::preflight::lights_warning;
use super::spec::UpAxisSpec;
use super::stages::{Job, Loaded, Message};
use super::{repeats, studio};
use crate::environment::Environment;
use crate::loaders::{load_scene, LoadOptions};
use crate::math::Vec3;
use crate::rig::camera_overrides::{self as view, CameraOverrides};
use crate::rig::up_axis::{self, UpAxis};
use crate::scene::{Scene, SceneFormat, Viewpoint};
use crate::Result;

impl Job {
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
            allow_dirs: limits.allow_dirs.clone(),
            memory_limit: None,
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
    pub(super) fn up_axis(&self, vp: Viewpoint, up: UpAxis) -> Viewpoint {
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
}

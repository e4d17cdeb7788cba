//! The third stage: everything decided before rendering, one way: the
//! image size and camera, the memory, the hierarchy (built once per loaded
//! scene), the depth pass and the rig, the files, the paper's cut of the
//! object tree (or the fast method's), and the world the render traces
//! (the whole one, or built once more with the cut).

use std::sync::Arc;
use std::time::Instant;

use super::outputs::{self, Targets};
use super::panorama;
use super::preflight::{
    available_memory, build_memory, check_memory, estimate_render_memory, ViewsKeptAs,
};
use super::report::plan_messages;
use super::spec::CutSpec;
use super::stages::Message;
use super::stages::{Job, Loaded, Plan};
use super::tiles;
use crate::render::{ViewMethod, ViewStorage};
use crate::rig::camera_overrides as view;
use crate::rig::choice::{self as rig_choice, RigFlags, RigRequest};
use crate::rig::framing;
use crate::rig::panorama_rig::PanoramaRig;
use crate::rig::report::{self as rig_report, Settled};
use crate::rig::{Camera, Rig};
use crate::scene::Viewpoint;
use crate::world::{Cut, World};
use crate::{Error, Result};

/// The rig a plan settled on.
struct RigPlan {
    rig: Rig,
    /// The rig's interaxial (0 for one view) and the convergence asked for.
    interaxial: f32,
    convergence: Option<f64>,
    settled: Option<Settled>,
    panorama: Option<PanoramaRig>,
}

impl Job {
    /// The image size: the spec's, the SPD procedure's, a quilt preset's or
    /// the scene's.
    pub(super) fn size(&self, viewpoint: &Viewpoint) -> Result<(u32, u32)> {
        let preset = self.quilt.and_then(|q| q.preset);
        let (width, height) = match (self.spec.camera.size, self.spec.sampling.spd, preset) {
            (Some([w, h]), _, _) => (w, h),
            (None, _, Some(p)) => (p.view_width, p.view_height),
            (None, true, None) => (512, 512),
            (None, false, None) if self.projection.is_panorama() => {
                panorama::default_size(self.projection, viewpoint.height)
            }
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

    /// Decides everything before rendering, in the order each decision
    /// needs the one before: camera, memory, hierarchy, depth pass and rig,
    /// files, cut, the world the render traces. Each is made once.
    pub fn plan(&self, loaded: &Loaded) -> Result<Plan> {
        let (camera, at_distance) = self.camera(loaded)?;
        let (width, height) = (camera.width, camera.height);
        let rows = match self.spec.tile {
            Some(t) => tiles::tile_rows(height, t)?,
            None => 0..height,
        };
        // The hierarchy built for this plan (the whole one at the first
        // plan of a scene, again with a cut) counts: its copy of the scene
        // and its nodes.
        let may_cut = !matches!(self.options.method, ViewMethod::Independent)
            && (self.cut.is_some() || matches!(self.options.method, ViewMethod::Fast { .. }));
        let building = if loaded.built_world().is_none() || may_cut {
            build_memory(&loaded.scene)
        } else {
            0
        };
        let memory = self.check_memory(width, height, self.kept_for_writing(), building)?;
        let mut build_seconds = 0.0;
        let whole = self.world_for(loaded, None, &mut build_seconds);
        let rig = self.rig(&whole, &camera, at_distance)?;
        let written = (width, rows.len() as u32);
        let inputs = outputs::job_inputs(&self.spec, &loaded.scene);
        let files = self
            .targets(&rig.rig, rig.interaxial)
            .plan(written, &inputs)?;
        let cut = self.cut(&camera, &rig.rig)?;
        let world = match cut {
            None => whole,
            Some(_) => self.world_for(loaded, cut, &mut build_seconds),
        };
        let mut plan = Plan {
            width,
            height,
            camera,
            rig: rig.rig,
            interaxial: rig.interaxial,
            convergence: rig.convergence,
            settled: rig.settled,
            panorama: rig.panorama,
            cut,
            world,
            files,
            build_seconds,
            messages: Vec::new(),
            rows,
            memory,
        };
        let r = &self.spec.rig;
        let rig_by_default = self.quilt.is_some()
            && r.interaxial.is_none()
            && r.view_cone.is_none()
            && r.depth_budget.is_none();
        let interaxial_given = r
            .interaxial
            .as_deref()
            .is_some_and(|i| !i.eq_ignore_ascii_case("auto"));
        plan.messages = plan_messages(&plan, rig_by_default, interaxial_given);
        if let Some(p) = &plan.panorama {
            plan.messages
                .extend(p.report_lines().into_iter().map(Message::info));
            plan.messages
                .extend(p.budget_warning().map(Message::warning));
        }
        Ok(plan)
    }

    /// The camera of the plan (a scene without one framed so that its
    /// bounds fill 80 % of the image), and the distance to its target.
    fn camera(&self, loaded: &Loaded) -> Result<(Camera, f64)> {
        let (viewpoint, given) = view::resolve(&loaded.scene, &self.view_overrides())?;
        let (width, height) = self.size(&viewpoint)?;
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
        let at_distance = f64::from((viewpoint.at - viewpoint.from).length());
        let camera = Camera::new(&viewpoint, width, height).with_projection(self.projection);
        Ok((camera, at_distance))
    }

    /// The rig of several views, from the depth pass on the whole
    /// hierarchy (`rig_report::settle`: fitted to the visible depths where
    /// the interaxial or convergence is automatic, and the disparity
    /// report); one view's rig.
    fn rig(&self, world: &World, camera: &Camera, at_distance: f64) -> Result<RigPlan> {
        if camera.projection.is_panorama() && self.views == 2 {
            let (rig, settled) = self.pool.install(|| {
                panorama::pair(&self.spec, self.interaxial, world, camera, at_distance)
            })?;
            return Ok(RigPlan {
                interaxial: settled.ipd as f32,
                rig,
                convergence: None,
                settled: None,
                panorama: Some(settled),
            });
        }
        let Some(request) = self.rig_request(at_distance)? else {
            return Ok(RigPlan {
                rig: Rig::mono(),
                interaxial: 0.0,
                convergence: None,
                settled: None,
                panorama: None,
            });
        };
        let screen = self.spec.rig.screen_width;
        let settled = self
            .pool
            .install(|| rig_report::settle(world, camera, &request, screen))?;
        Ok(RigPlan {
            rig: settled.rig.clone(),
            interaxial: settled.choice.interaxial,
            convergence: settled.choice.convergence,
            settled: Some(settled),
            panorama: None,
        })
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

    pub(super) fn targets(&self, rig: &Rig, interaxial: f32) -> Targets<'_> {
        Targets {
            output: &self.spec.output,
            quilt: self.quilt.as_ref(),
            views: self.views,
            interaxial,
            effective_convergence: rig.effective_convergence,
        }
    }

    /// How `render_for_writing` keeps the views: as the files' bytes where
    /// they only show them (`Targets::storage`, which depends on the
    /// outputs, not on the rig), but in floats under a floating window,
    /// which masks the views after the render.
    pub(super) fn storage_for_writing(&self) -> ViewStorage {
        if self.spec.rig.floating_window {
            ViewStorage::Float
        } else {
            self.targets(&Rig::mono(), 0.0).storage()
        }
    }

    /// `storage_for_writing`, as the memory check counts it.
    pub(super) fn kept_for_writing(&self) -> ViewsKeptAs {
        match self.storage_for_writing() {
            ViewStorage::Float => ViewsKeptAs::Floats,
            ViewStorage::Rgb8(_) => ViewsKeptAs::Bytes,
        }
    }

    /// The memory a render needs with its views kept as `kept` (bytes);
    /// refused where the machine has less. `building`: the bytes of a
    /// hierarchy still to build.
    pub(super) fn check_memory(
        &self,
        width: u32,
        height: u32,
        kept: ViewsKeptAs,
        building: u64,
    ) -> Result<u64> {
        let quilt_tiles = self.quilt.map_or(0, |q| q.layout.tiles());
        let needed = estimate_render_memory(width, height, self.views, self.options.sampling, kept)
            .saturating_add(outputs::extra_memory(
                width,
                height,
                self.views,
                quilt_tiles,
                outputs::quilt_pixel_bytes(&self.spec.output.path),
                self.spec.output.depth,
            ))
            .saturating_add(building);
        let build = if building > 0 {
            "building the scene's hierarchy and "
        } else {
            ""
        };
        check_memory(
            needed,
            available_memory(),
            &format!(
                "{build}rendering {} view(s) of {width}x{height}",
                self.views
            ),
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

    /// Where to cut the object tree: where the twin method's spec asks (the
    /// parallax bound depends on the rig); none otherwise.
    fn cut(&self, camera: &Camera, rig: &Rig) -> Result<Option<Cut>> {
        let asked = match self.options.method {
            ViewMethod::Twin { .. } => self.cut,
            ViewMethod::Fast { .. } | ViewMethod::Independent => None,
        };
        let depth = match asked {
            Some(CutSpec::Distance(d)) => f64::from(d),
            Some(CutSpec::Parallax(px)) => match rig.cut_depth_for_parallax(camera, px) {
                Some(d) => d,
                None => return Ok(None),
            },
            None => return Ok(None),
        };
        Ok(Some(Cut::at_depth(
            camera.eye,
            camera.forward,
            depth as f32,
        )))
    }
}

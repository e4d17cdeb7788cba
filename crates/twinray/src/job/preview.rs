//! What a live preview needs of a job beyond the command line's stages:
//! the plan at a fraction of its size (the coarse frames of a progressive
//! render), a render with other sampling (one ray per pixel before the
//! anti-aliased pass), and the layout composed in memory instead of files.
//!
//! A reduced plan keeps the full plan's decisions: the same camera, views
//! and cut, the views' whole-pixel convergence shifts divided by the factor
//! (rounded), so that a coarse frame shows the rig the full one will.

use std::sync::Arc;

use super::{outputs, Job, Loaded, Plan, Rendered};
use crate::image::Image;
use crate::output::WriteOptions;
use crate::render::{Sampling, ViewStorage};
use crate::rig::camera_overrides as view;
use crate::rig::{Camera, Rig, View};
use crate::scene::Viewpoint;
use crate::Result;

use super::CancelToken;

/// One pass of a progressive render: the image at `1/divisor` of the
/// plan's size, sampled as `sampling` (`None`: the job's own sampling).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pass {
    pub divisor: u32,
    pub sampling: Option<Sampling>,
}

impl Job {
    /// The passes of a progressive render of a `width`-pixel plan: one ray
    /// per pixel centre at 1/8, 1/4, 1/2 and the full size (those at least
    /// 8 pixels wide), then the job's own sampling at the full size when it
    /// is not already one ray per pixel centre.
    pub fn progressive_passes(&self, width: u32) -> Vec<Pass> {
        let mut passes: Vec<Pass> = [8, 4, 2, 1]
            .into_iter()
            .filter(|&d| d == 1 || width / d >= 8)
            .map(|divisor| Pass {
                divisor,
                sampling: Some(Sampling::Centers),
            })
            .collect();
        if self.options.sampling != Sampling::Centers {
            passes.push(Pass {
                divisor: 1,
                sampling: None,
            });
        }
        passes
    }

    /// The viewpoint the job looks from: the scene's with the spec's
    /// camera settings on top (what [`Job::plan`] uses).
    pub fn viewpoint(&self, loaded: &Loaded) -> Result<Viewpoint> {
        Ok(view::resolve(&loaded.scene, &self.view_overrides())?.0)
    }

    /// The size of the job's images: the spec's, the SPD procedure's, a
    /// quilt preset's or the scene's (checked against the limit).
    pub fn image_size(&self, loaded: &Loaded) -> Result<(u32, u32)> {
        self.size(&self.viewpoint(loaded)?)
    }

    /// `plan` at `1/divisor` of its size (rounded up): the same viewpoint,
    /// views, cut and rig report, the convergence shifts and the floating
    /// window divided by `divisor`. A divisor of 1 (or 0) gives the plan
    /// itself.
    pub fn reduced_plan(&self, loaded: &Loaded, plan: &Plan, divisor: u32) -> Result<Plan> {
        let d = divisor.max(1);
        let viewpoint = self.viewpoint(loaded)?;
        let (width, height) = (plan.width.div_ceil(d), plan.height.div_ceil(d));
        let camera = if d == 1 {
            plan.camera.clone()
        } else {
            Camera::new(&viewpoint, width, height).with_projection(plan.camera.projection)
        };
        let scale = |px: f64| px / f64::from(d);
        let rig = Rig {
            views: plan
                .rig
                .views
                .iter()
                .map(|v| View {
                    offset: v.offset,
                    shift: scale(f64::from(v.shift)).round() as i32,
                })
                .collect(),
            convergence: plan.rig.convergence,
            effective_convergence: plan.rig.effective_convergence,
        };
        let settled = plan.settled.clone().map(|mut s| {
            let w = &mut s.report.floating_window;
            w.left_px = w.left_px.div_ceil(d);
            w.right_px = w.right_px.div_ceil(d);
            s.rig = rig.clone();
            s
        });
        Ok(Plan {
            width,
            height,
            camera,
            rig,
            interaxial: plan.interaxial,
            convergence: plan.convergence,
            settled,
            panorama: plan.panorama.clone(),
            cut: plan.cut,
            world: Arc::clone(&plan.world),
            files: plan.files.clone(),
            // A tile's rows, scaled as the image is.
            rows: plan.rows.start / d..plan.rows.end.div_ceil(d).min(height),
            build_seconds: 0.0,
            messages: Vec::new(),
            // At most the full plan's.
            memory: plan.memory,
        })
    }

    /// Renders `plan` as [`Job::render`] does, sampled as `sampling`
    /// instead of the job's sampling where it is given.
    pub fn render_sampled(
        &self,
        plan: &Plan,
        sampling: Option<Sampling>,
        progress: &(dyn Fn(u64, u64) + Sync),
        cancel: &CancelToken,
    ) -> Result<Rendered> {
        let mut options = self.options;
        if let Some(s) = sampling {
            options.sampling = s;
        }
        self.render_with(plan, &options, ViewStorage::Float, progress, cancel)
    }

    /// The images the job's layout delivers, composed in memory as an 8-bit
    /// file shows them (what [`Job::write`] would encode: exposure and tone
    /// curve applied; encode them with [`Job::write_options`]): one frame
    /// for side-by-side, cross, top-bottom, anaglyph, interlaced and quilt
    /// layouts, the views themselves otherwise.
    pub fn compose(&self, plan: &Plan, rendered: &Rendered) -> Result<Vec<Image>> {
        let shown = outputs::displayed(&self.spec.output, &rendered.output.images);
        self.targets(&plan.rig, plan.interaxial).compose(&shown)
    }

    /// How the job's 8-bit images are encoded (sRGB unless `--linear`).
    pub fn write_options(&self) -> WriteOptions {
        outputs::write_options(&self.spec.output)
    }
}

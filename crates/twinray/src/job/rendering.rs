//! The fourth and fifth stages: the views rendered, in memory (as floats,
//! or as the bytes of the files that will hold them), then composed in
//! their layout and written, all files or none; and every stage in order.

use std::path::PathBuf;
use std::time::Instant;

use super::outputs;
use super::preflight::ViewsKeptAs;
use super::spec::{JobSpec, LayoutSpec};
use super::stages::{Job, Loaded, Message, Plan, Rendered};
use crate::output;
use crate::render::{self, CancelToken, RenderOptions, ViewStorage};
use crate::Result;

impl Job {
    /// Renders the views. `progress(done, total)` is called from worker
    /// threads; raising `cancel` stops the render with [`Error::Cancelled`](crate::Error::Cancelled).
    pub fn render(
        &self,
        plan: &Plan,
        progress: &(dyn Fn(u64, u64) + Sync),
        cancel: &CancelToken,
    ) -> Result<Rendered> {
        // The plan checked the memory for views kept as bytes where the
        // files allow it; floats take up to four times as much.
        if self.kept_for_writing() == ViewsKeptAs::Bytes {
            self.check_memory(plan.width, plan.height, ViewsKeptAs::Floats, 0)?;
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
        let storage = self.storage_for_writing();
        self.render_with(plan, &self.options, storage, progress, cancel)
    }

    /// [`Job::render`] with other render options (a preview's coarse passes).
    pub(super) fn render_with(
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
        if plan.camera.projection.is_panorama() {
            super::panorama::tag_jpegs(&self.spec, plan, self.views)?;
        }
        let write_s = start.elapsed().as_secs_f64();
        if let Some(path) = &self.spec.output.stats {
            let report = self.report(loaded, plan, rendered, write_s);
            output::write_text(path, &report.to_json())?;
            written.push(path.clone());
        }
        Ok(written)
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

//! A spec as the `twinray render` arguments that describe it: the inverse
//! of the command line's flags (what `--print-job` shows), for a front end
//! that lets its user copy the command reproducing what they see (the
//! preview). Values at their defaults are left out.

use std::path::Path;

use serde::Serialize;

use super::spec::{
    AnimationSpec, ApproximationSpec, JobSpec, LayoutSpec, LimitSpec, MethodSpec,
    ReprojectModeSpec, RigSpec, TonemapSpec, UpAxisSpec,
};

impl JobSpec {
    /// The arguments of `twinray render` (after `render`) that give this
    /// spec: the scene, `-o`, then every setting that differs from the
    /// default. A value that starts with `-` is joined to its flag with `=`
    /// so that it cannot read as a flag.
    pub fn to_args(&self) -> Vec<String> {
        let mut a = Args(Vec::new());
        a.0.push(path(&self.scene));
        if !self.output.path.as_os_str().is_empty() {
            a.value("-o", path(&self.output.path));
        }
        let c = &self.camera;
        if let Some([w, h]) = c.size {
            a.value("--size", format!("{w}x{h}"));
        }
        a.maybe("--camera", c.camera.clone());
        for (flag, v) in [("--from", c.from), ("--at", c.at), ("--up", c.up)] {
            a.maybe(flag, v.map(triple));
        }
        a.maybe("--fov", c.fov);
        self.rig_args(&mut a);
        let s = &self.sampling;
        a.flag("--spd", s.spd);
        a.maybe("--samples", s.samples);
        a.maybe("--filter", s.filter.map(name));
        a.maybe("--seed", s.seed);
        a.maybe("--adaptive", s.adaptive);
        a.maybe("--max-samples", s.max_samples);
        let x = &self.approximations;
        a.flag("--fast", x.fast);
        a.flag("--merge-secondary", x.merge_secondary);
        a.flag("--reproject", x.reproject);
        if x.reproject_mode != ReprojectModeSpec::Safe {
            a.value("--reproject-mode", name(x.reproject_mode));
        }
        if x.reproject_threshold != crate::render::Reprojection::DEFAULT_THRESHOLD {
            a.value("--reproject-threshold", x.reproject_threshold);
        }
        a.maybe("--cut-distance", x.cut_distance);
        a.maybe("--cut-parallax", x.cut_parallax);
        a.flag("--share-shading", x.share_shading);
        a.flag("--interpolate-views", x.interpolate_views);
        a.flag("--synthesize-views", x.synthesize_views);
        a.flag("--epipolar-views", x.epipolar_views);
        if x.synthesis_spacing != crate::render::ViewSynthesis::DEFAULT_SPACING {
            a.value("--synthesis-spacing", x.synthesis_spacing);
        }
        if x.share_tolerance != ApproximationSpec::default().share_tolerance {
            a.value("--share-tolerance", x.share_tolerance);
        }
        let t = &self.trace;
        if t.max_depth != super::spec::TraceSpec::default().max_depth {
            a.value("--max-depth", t.max_depth);
        }
        a.maybe("--min-weight", t.min_weight);
        a.maybe("--threads", t.threads);
        let o = &self.output;
        if o.layout != LayoutSpec::Separate {
            a.value("--layout", o.layout.name());
        }
        a.flag("--squeeze", o.squeeze);
        a.maybe("--anaglyph", o.anaglyph.map(name));
        a.maybe("--interlace", o.interlace.map(name));
        a.flag("--srgb", o.srgb);
        a.flag("--depth", o.depth);
        a.maybe("--quilt", o.quilt.clone());
        a.maybe("--stats", o.stats.as_deref().map(path));
        a.flag("--linear", o.linear);
        if o.exposure != 0.0 {
            a.value("--exposure", o.exposure);
        }
        if o.tonemap != TonemapSpec::Clamp {
            a.value("--tonemap", name(o.tonemap));
        }
        self.studio_args(&mut a);
        self.animation_args(&mut a);
        if let Some(tile) = self.tile {
            a.value("--tiles", tile.count);
            a.value("--tile", tile.index);
        }
        let (l, d) = (&self.limits, LimitSpec::default());
        if l.max_resolution != d.max_resolution {
            a.value("--max-resolution", l.max_resolution);
        }
        if l.max_vertices != d.max_vertices {
            a.value("--max-vertices", l.max_vertices);
        }
        if l.max_triangles != d.max_triangles {
            a.value("--max-triangles", l.max_triangles);
        }
        for dir in &l.allow_dirs {
            a.value("--allow-dir", path(dir));
        }
        a.0
    }

    fn rig_args(&self, a: &mut Args) {
        let (r, d) = (&self.rig, RigSpec::default());
        a.flag("--stereo", r.stereo);
        a.maybe("--views", r.views);
        a.maybe("--interaxial", r.interaxial.clone());
        a.maybe("--convergence", r.convergence.clone());
        a.maybe("--depth-budget", r.depth_budget.clone());
        a.maybe("--view-cone", r.view_cone);
        if r.screen_width != d.screen_width {
            a.value("--screen-width", r.screen_width);
        }
        a.flag("--floating-window", r.floating_window);
        if r.method != MethodSpec::Twin {
            a.value("--method", name(r.method));
        }
        a.maybe("--views-per-batch", r.views_per_batch);
        a.flag("--strip", r.strip);
        a.flag("--eye-runs", r.eye_runs);
        a.flag("--shadow-fans", r.shadow_fans);
    }

    fn studio_args(&self, a: &mut Args) {
        let s = &self.studio;
        a.maybe("--background", s.background.map(triple));
        if s.up_axis != UpAxisSpec::Auto {
            a.value("--up-axis", name(s.up_axis));
        }
        for light in &s.lights {
            let position = triple(light.position);
            if light.color == [1.0; 3] {
                a.value("--light", position);
            } else {
                a.value("--light", format!("{position}:{}", triple(light.color)));
            }
        }
        a.flag("--ground", s.ground);
        a.maybe("--env", s.env.as_deref().map(path));
    }

    fn animation_args(&self, a: &mut Args) {
        let (n, d) = (&self.animation, AnimationSpec::default());
        a.maybe("--frames", n.frames.clone());
        if n.fps != d.fps {
            a.value("--fps", n.fps);
        }
        a.maybe("--orbit", n.orbit);
        a.maybe("--path", n.path.as_deref().map(path));
        if n.rig != d.rig {
            a.value("--rig", name(n.rig));
        }
        a.flag("--skip-existing", n.skip_existing);
        a.maybe("--only", n.only.clone());
        a.maybe("--animation", n.clip.clone());
        if n.codec != d.codec {
            a.value("--codec", name(n.codec));
        }
        a.maybe("--crf", n.crf);
    }
}

fn triple([x, y, z]: [f32; 3]) -> String {
    format!("{x},{y},{z}")
}

struct Args(Vec<String>);

impl Args {
    fn flag(&mut self, flag: &str, on: bool) {
        if on {
            self.0.push(flag.into());
        }
    }

    fn value(&mut self, flag: &str, value: impl ToString) {
        let value = value.to_string();
        if value.starts_with('-') {
            self.0.push(format!("{flag}={value}"));
        } else {
            self.0.push(flag.into());
            self.0.push(value);
        }
    }

    fn maybe<T: ToString>(&mut self, flag: &str, value: Option<T>) {
        if let Some(v) = value {
            self.value(flag, v);
        }
    }
}

fn path(p: &Path) -> String {
    p.to_string_lossy().into_owned()
}

/// The command line's name of an enum value: its serde name (both kebab-case).
fn name(v: impl Serialize) -> String {
    match serde_json::to_value(v) {
        Ok(serde_json::Value::String(s)) => s,
        _ => String::new(),
    }
}

//! A spec as the `twinray render` arguments that describe it: the inverse
//! of [`RenderArgs::spec`](crate::RenderArgs::spec), for a front end that
//! lets its user copy the command reproducing what they see (the preview).
//! Values at their defaults are left out.

use std::path::Path;

use twinray::job::{
    AnimationSpec, CutSpec, JobSpec, LayoutSpec, LimitSpec, MethodName, RigSpec, TonemapSpec,
    TraceSpec, UpAxisSpec,
};
use twinray::render::ReprojectMode;
use twinray::rig::ProjectionName;

/// The arguments of `twinray render` that give a spec.
pub trait ToArgs {
    /// The arguments after `render`: the scene, `-o`, then every setting
    /// that differs from the default. A value that starts with `-` is joined
    /// to its flag with `=` so that it cannot read as a flag.
    fn to_args(&self) -> Vec<String>;
}

impl ToArgs for JobSpec {
    fn to_args(&self) -> Vec<String> {
        let mut a = Args(Vec::new());
        a.0.push(path(&self.scene));
        if !self.output.path.as_os_str().is_empty() {
            a.value("-o", path(&self.output.path));
        }
        camera_args(self, &mut a);
        rig_args(&self.rig, &mut a);
        let s = &self.sampling;
        a.flag("--spd", s.spd);
        a.maybe("--samples", s.samples);
        a.maybe("--filter", s.filter);
        a.maybe("--seed", s.seed);
        a.maybe("--adaptive", s.adaptive);
        a.maybe("--max-samples", s.max_samples);
        method_args(self, &mut a);
        let t = &self.trace;
        if t.max_depth != TraceSpec::default().max_depth {
            a.value("--max-depth", t.max_depth);
        }
        a.maybe("--min-weight", t.min_weight);
        a.maybe("--threads", t.threads);
        output_args(self, &mut a);
        studio_args(self, &mut a);
        animation_args(&self.animation, &mut a);
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
}

fn camera_args(spec: &JobSpec, a: &mut Args) {
    let c = &spec.camera;
    if let Some([w, h]) = c.size {
        a.value("--size", format!("{w}x{h}"));
    }
    a.maybe("--camera", c.camera.clone());
    for (flag, v) in [("--from", c.from), ("--at", c.at), ("--up", c.up)] {
        a.maybe(flag, v.map(triple));
    }
    a.maybe("--fov", c.fov);
    if c.projection != ProjectionName::Pinhole {
        a.value("--projection", c.projection);
    }
    a.maybe(
        "--pole-merge",
        c.pole_merge.map(|[f, t]| format!("{f},{t}")),
    );
}

fn rig_args(r: &RigSpec, a: &mut Args) {
    let d = RigSpec::default();
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
    a.maybe("--angular-budget", r.angular_budget);
    a.maybe("--units", r.units);
}

fn method_args(spec: &JobSpec, a: &mut Args) {
    let m = &spec.method;
    match m.name {
        MethodName::Twin => {}
        MethodName::Fast => a.flag("--fast", true),
        MethodName::Independent => a.value("--method", m.name),
    }
    a.maybe("--tolerance", m.tolerance);
    a.flag("--merge-secondary", m.merge_secondary);
    if let Some(mode) = m.reproject {
        a.flag("--reproject", true);
        if mode != ReprojectMode::Safe {
            a.value("--reproject-mode", mode);
        }
    }
    a.maybe("--reproject-threshold", m.reproject_threshold);
    match m.cut {
        Some(CutSpec::Distance(d)) => a.value("--cut-distance", d),
        Some(CutSpec::Parallax(px)) => a.value("--cut-parallax", px),
        None => {}
    }
}

fn output_args(spec: &JobSpec, a: &mut Args) {
    let o = &spec.output;
    if o.layout != LayoutSpec::Separate {
        a.value("--layout", o.layout);
    }
    a.flag("--squeeze", o.squeeze);
    a.maybe("--anaglyph", o.anaglyph);
    a.maybe("--interlace", o.interlace);
    a.flag("--srgb", o.srgb);
    a.flag("--depth", o.depth);
    a.maybe("--quilt", o.quilt.clone());
    a.maybe("--stats", o.stats.as_deref().map(path));
    a.flag("--linear", o.linear);
    if o.exposure != 0.0 {
        a.value("--exposure", o.exposure);
    }
    if o.tonemap != TonemapSpec::Clamp {
        a.value("--tonemap", o.tonemap);
    }
}

fn studio_args(spec: &JobSpec, a: &mut Args) {
    let s = &spec.studio;
    a.maybe("--background", s.background.map(triple));
    if s.up_axis != UpAxisSpec::Auto {
        a.value("--up-axis", s.up_axis);
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

fn animation_args(n: &AnimationSpec, a: &mut Args) {
    let d = AnimationSpec::default();
    a.maybe("--frames", n.frames.clone());
    if n.fps != d.fps {
        a.value("--fps", n.fps);
    }
    a.maybe("--orbit", n.orbit);
    a.maybe("--path", n.path.as_deref().map(path));
    if n.rig != d.rig {
        a.value("--rig", n.rig);
    }
    a.flag("--skip-existing", n.skip_existing);
    a.maybe("--only", n.only.clone());
    a.maybe("--animation", n.clip.clone());
    if n.codec != d.codec {
        a.value(
            "--codec",
            match n.codec {
                twinray::video::Codec::H264 => "h264",
                twinray::video::Codec::Hevc => "hevc",
            },
        );
    }
    a.maybe("--crf", n.crf);
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

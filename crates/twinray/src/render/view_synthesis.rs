//! Key-view synthesis (issue 16, `--synthesize-views`): N views for the price
//! of a few. An approximation; off unless asked for.
//!
//! The views of a rig lie on the camera's right axis with parallel lens axes,
//! so one image row of every view lies in one plane through the camera line
//! (the row's epipolar plane): a surface point seen by one view in row `y`
//! is seen by every other view in row `y` too, `f·Δoffset/z` pixels to the
//! side. So a row of a few *key views* (every `spacing`-th view by offset,
//! and the last), traced and shaded exactly, holds what the views between
//! them see in that row, wherever the key view saw it. Each view between
//! takes its samples from its nearest key view:
//!
//! 1. Every pair of neighbouring samples of the key view (a *bracket*) is
//!    warped into the view by its two depths; the bracket covers the view's
//!    samples that fall between its ends, at the depth interpolated there.
//!    Where brackets overlap, the nearest covers (a z-buffer in one
//!    dimension): an occluder the key view saw hides what lies behind it.
//! 2. A covered sample takes the bracket's colour, interpolated, when the
//!    bracket is *plain*: both ends hit surfaces whose shading is
//!    view-independent within the tolerance `E` (mirror, highlight and
//!    transmission weights at most `E`) or both miss; the step in depth
//!    between them is small (no silhouette between); and the colours around
//!    it are linear within `E` (half the second difference at either end: a
//!    shadow or texture edge between the two ends shows there).
//! 3. The region the views' rays sweep on their way to the bracket, the
//!    quadrilateral (key eye, farthest served view's eye, the bracket's two
//!    hits pulled toward the key eye by `PULL` of their distance), must be
//!    free of every primitive (`Bvh::run_is_free` with `RunRegion::quad`):
//!    something the key view's samples missed (a pole thinner than a pixel,
//!    an object hidden from the key view) would cross it. Brackets on one
//!    plane are proved in one region per run, halved where it fails.
//! 4. Every other sample is traced and shaded exactly, by the view itself
//!    (a hole the key view did not see, a silhouette, a mirror or glass
//!    surface, an edge, a failed proof).
//!
//! What is exact and what is not: key views are exact, and so is every
//! sample of step 4. A synthesized sample's colour is that of the surface the
//! key view saw around it, interpolated: for a view-independent shading it
//! differs from the exact colour by the interpolation error of the colour
//! between two neighbouring key-view samples, which step 2 bounds by `E`
//! where the colour has no detail finer than the samples, plus the
//! view-dependent terms up to `E` the material threshold lets through. Detail
//! finer than the key view's samples (a shadow sliver between two samples)
//! is not seen. Only rows whose samples all share one image row (the pixel
//! centres, `--samples 1`; the SPD's corners) have an epipolar plane; rows of
//! other samplings are traced exactly in every view.

use serde::Serialize;

use super::sampler::{Pattern, RowColors, SampleRow};
use super::strip::StripRow;
use super::{RowWorker, Tracer};
use crate::bvh::{distance_to_triangle, RunRegion, RunStats};
use crate::math::{Color, Vec3};
use crate::rig::{Camera, Rig};
use crate::shapes::Shape;
use crate::world::World;

/// Key-view synthesis, as asked for (see the module's notes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewSynthesis {
    /// Every `spacing`-th view by offset (and the last) is a key view; at
    /// least 2.
    pub spacing: usize,
    /// `E`: the largest mirror, highlight or transmission weight of a surface
    /// whose colour is synthesized, and the largest interpolation error the
    /// colour test lets through, in image values (1 = white).
    pub tolerance: f32,
}

impl ViewSynthesis {
    /// Views from one key view to the next.
    pub const DEFAULT_SPACING: usize = 8;
}

/// What the synthesis did (`--stats`, `-v`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, derive_more::AddAssign)]
pub struct SynthesisStats {
    /// Samples of key views (traced and shaded exactly).
    pub key_samples: u64,
    /// Samples of the views between that took a key view's colour.
    pub synthesized: u64,

    /// Samples of the views between traced and shaded exactly, and why: no
    /// bracket reached them (`holes`), their bracket's surface is a mirror,
    /// glass or highlight (`refused_material`), its ends lie on two surfaces
    /// (`refused_edge`: two primitives, a step in depth, a silhouette), it
    /// has a colour edge or folds over in the view (`refused_surface`), or
    /// its region held something (`refused_region`).
    pub traced: u64,
    pub holes: u64,
    pub refused_material: u64,
    pub refused_edge: u64,
    pub refused_surface: u64,
    pub refused_region: u64,
    /// Region proofs, those that found something, and the nodes visited.
    pub proofs: u64,
    pub proofs_failed: u64,
    pub proof_nodes: u64,
    /// Rows whose samples lie in no epipolar plane (other samplings), traced
    /// exactly in every view.
    pub rows_exact: u64,
}

/// How far toward the key eye a bracket's hits are pulled before its region
/// is proved free, relative to their distance: the surface they lie on (or
/// its plane's neighbours) must not count as met.
const PULL: f64 = 1.0 / 1024.0;

/// Largest step in depth between a bracket's two hits, relative to the
/// nearer: beyond it the two lie on different surfaces (a silhouette).
const DEPTH_STEP: f64 = 0.05;

/// What a render's synthesis shares between rows.
pub(super) struct SynthesisPass<'a> {
    world: &'a World,
    camera: &'a Camera,
    /// The views by offset: (rig index, offset, shift).
    order: Vec<(usize, f32, i32)>,
    /// Key views, as positions in `order`, ascending.
    keys: Vec<usize>,
    /// Per key view: the farthest position it serves on its left and on its
    /// right (itself where none).
    serves: Vec<(usize, usize)>,
    tolerance: f32,
    focal: f64,
    /// Margin of the regions (the rounding of the scene's coordinates).
    margin: f64,
    /// A distance past the whole scene from every eye: where a missing
    /// ray's region ends.
    beyond: f32,
    /// Per material: shading independent of the view within the tolerance.
    plain: Vec<bool>,
}

/// A key view's sample: its hit and its colour.
#[derive(Clone, Copy, Debug)]
struct KeySample {
    /// Primitive hit, `u32::MAX` for none.
    prim: u32,
    /// Distance along the ray, and camera-space depth (infinite for none).
    t: f32,
    z: f64,
    dir: Vec3,
    color: Color,
}

/// What a bracket's views between may take from it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Verdict {
    /// One smooth surface (or the background): the colour interpolated.
    Plain,
    /// Two surfaces (two primitives not of one plane, a step in depth, or a
    /// hit and a miss): traced (where a view's ray goes between them is
    /// not known).
    Edge,
    /// A mirror, glass or highlight at an end: traced.
    Material,
    /// A colour edge on one surface (a shadow's, a texture's): traced.
    Surface,
}

/// One thread's scratch space, reused from row to row.
#[derive(Default)]
pub(super) struct SynthScratch {
    strip: StripRow,
    /// Per key view (index into `keys`), per sample.
    samples: Vec<Vec<KeySample>>,
    /// Image column of each sample.
    xs: Vec<f64>,
    /// Per bracket of the current key view: verdict, the run of coplanar
    /// plain brackets it belongs to (first bracket), and the proof's answer
    /// for the current side (0 unknown, 1 free, 2 met).
    verdicts: Vec<Verdict>,
    run_start: Vec<u32>,
    run_end: Vec<u32>,
    proved: Vec<u8>,
    /// Per sample of the view being synthesized: the nearest bracket
    /// covering it (depth, bracket, where between its ends, folded).
    cover: Vec<Cover>,
    pending: Vec<usize>,
    one: Vec<RowColors>,
}

#[derive(Clone, Copy, Debug)]
struct Cover {
    z: f64,
    bracket: u32,
    s: f64,
    folded: bool,
}

const UNCOVERED: Cover = Cover {
    z: f64::INFINITY,
    bracket: u32::MAX,
    s: 0.0,
    folded: false,
};

/// For the row passes over the views by offset `order`: the margin of the
/// rows' rounding (a millionth of the larger of the scene's and the eyes'
/// coordinates), and how far a ray must reach to cross the scene from any
/// eye (the farthest eye's distance to the scene's centre, plus its
/// diagonal).
pub(super) fn rig_extent(
    world: &World,
    camera: &Camera,
    order: &[(usize, f32, i32)],
) -> (f64, f32) {
    let bounds = world.bvh.bounds();
    let scene_scale = bounds.min.abs().max(bounds.max.abs()).max_element();
    let origins: Vec<Vec3> = order.iter().map(|v| camera.eye_at(v.1)).collect();
    let origin_scale = origins
        .iter()
        .fold(0.0f32, |m, o| m.max(o.abs().max_element()));
    let size = (bounds.max - bounds.min).length();
    let far = bounds.center();
    let beyond = origins
        .iter()
        .map(|o| (*o - far).length())
        .fold(0.0f32, f32::max);
    (
        1e-6 * scene_scale.max(origin_scale).max(1e-3) as f64,
        beyond + size,
    )
}

/// Per material: whether its shading is independent of the view within
/// `tol` (mirror, highlight and transmission weights at most `tol`).
pub(super) fn plain_materials(world: &World, tol: f32) -> Vec<bool> {
    world
        .scene
        .materials
        .iter()
        .map(|m| m.ks.max(m.mirror) <= tol && m.t <= tol)
        .collect()
}

impl<'a> SynthesisPass<'a> {
    /// The pass for `rig`, or `None` where the synthesis does not apply (fewer
    /// than three views, no view between two key views, a cut of the object
    /// tree, materials whose alpha matters).
    pub(super) fn new(
        world: &'a World,
        camera: &'a Camera,
        rig: &Rig,
        synthesis: ViewSynthesis,
    ) -> Option<SynthesisPass<'a>> {
        let n = rig.views.len();
        let spacing = synthesis.spacing;
        if n < 3 || spacing < 2 || world.far.is_some() || world.has_alpha {
            return None;
        }
        let order = rig.views_by_offset();
        let mut keys: Vec<usize> = (0..n).step_by(spacing).collect();
        if keys.last() != Some(&(n - 1)) {
            keys.push(n - 1);
        }
        // Position p is served by its nearest key view (ties to the left).
        let mut serves: Vec<(usize, usize)> = keys.iter().map(|&k| (k, k)).collect();
        for p in 0..n {
            let k = nearest_key(&keys, p);
            let (left, right) = &mut serves[k];
            if p < keys[k] {
                *left = (*left).min(p);
            } else {
                *right = (*right).max(p);
            }
        }
        let (margin, reach) = rig_extent(world, camera, &order);
        let tol = synthesis.tolerance;
        Some(SynthesisPass {
            world,
            camera,
            order,
            keys,
            serves,
            tolerance: tol,
            focal: camera.focal_pixels(),
            margin,
            beyond: reach * 1.01,
            plain: plain_materials(world, tol),
        })
    }

    /// Every view's colours through the samples of `row` into `out` (rig
    /// order), `workers[v]` tracing view `v` alone.
    pub(super) fn trace_row(
        &self,
        workers: &mut [(usize, Box<dyn RowWorker + '_>)],
        tracer: &mut Tracer,
        row: &SampleRow,
        s: &mut SynthScratch,
        out: &mut [RowColors],
    ) {
        let Pattern::Fixed { .. } = row.pattern else {
            tracer.counts.synthesis.rows_exact += 1;
            return trace_all(workers, tracer, row, out);
        };
        let n = row.len();
        s.xs.clear();
        s.xs.extend((0..n).map(|i| row.pixels[i] as f64 + row.offsets[i].0 as f64));
        // 1. The key views, exactly: their eye hits, then their shading.
        s.strip.traced = true;
        s.strip.hits.resize_with(self.order.len(), Vec::new);
        s.samples.resize_with(self.keys.len(), Vec::new);
        for (k, &p) in self.keys.iter().enumerate() {
            let (v, _, shift) = self.order[p];
            let worker = &mut workers[v].1;
            // One pass where the worker keeps its hits (the mono row), else
            // the eye pass and then the shading given its hits.
            if !worker.trace_keeping_hits(tracer, row, &mut out[v..v + 1], &mut s.strip.hits[v]) {
                if !worker.eye_hits(tracer, row, &mut s.strip.hits[v..v + 1]) {
                    return trace_all(workers, tracer, row, out);
                }
                worker.trace_with_hits(tracer, row, &s.strip, &mut out[v..v + 1]);
            }
            let samples = &mut s.samples[k];
            samples.clear();
            for (i, (&(prim, hit), &color)) in s.strip.hits[v].iter().zip(&out[v]).enumerate() {
                let (column, y) = row.camera_point(i, shift);
                let dir = self.camera.direction(column, y);
                let z = if prim == u32::MAX {
                    f64::INFINITY
                } else {
                    hit.t as f64 * dir.dot(self.camera.forward) as f64
                };
                samples.push(KeySample {
                    prim,
                    t: hit.t,
                    z,
                    dir,
                    color,
                });
            }
            tracer.counts.synthesis.key_samples += n as u64;
        }
        // 2. Each key view's brackets judged, then its views synthesized.
        for k in 0..self.keys.len() {
            let samples = std::mem::take(&mut s.samples[k]);
            self.judge_brackets(&samples, s);
            s.samples[k] = samples;
            let (left, right) = self.serves[k];
            let key = self.keys[k];
            for (lo, hi) in [(left, key), (key + 1, right + 1)] {
                if lo >= hi {
                    continue;
                }
                let far = if lo < key { lo } else { hi - 1 };
                s.proved.clear();
                s.proved.resize(n.saturating_sub(1), 0);
                for p in lo..hi {
                    self.synthesize(workers, tracer, row, k, far, p, s, out);
                }
            }
        }
    }

    /// The verdict on each bracket of a key view's row, and its runs of
    /// plain brackets on one plane (proved in one region).
    fn judge_brackets(&self, samples: &[KeySample], s: &mut SynthScratch) {
        let n = samples.len();
        let brackets = n.saturating_sub(1);
        s.verdicts.clear();
        s.run_start.clear();
        s.run_end.clear();
        let color = |i: usize| samples[i].color;
        // Half the second difference at `m` (its neighbours' mean against it),
        // or the step to the other end where `m` is a row's end.
        let bend = |m: usize, other: usize| -> f32 {
            if m == 0 || m + 1 >= n {
                return largest(color(other) - color(m));
            }
            largest((color(m - 1) + color(m + 1) - color(m) * 2.0) * 0.5)
        };
        // Half the second difference at either end, where the bracket on
        // that side is of the same surface: a colour edge between the two
        // ends shows there; the step between them where neither is.
        let smooth: Vec<bool> = (0..brackets)
            .map(|i| self.continuous(&samples[i], &samples[i + 1]))
            .collect();
        let bend = |i: usize| -> f32 {
            let left = (i > 0 && smooth[i - 1]).then(|| bend(i, i + 1));
            let right = (i + 2 < n && smooth[i + 1]).then(|| bend(i + 1, i));
            match (left, right) {
                (None, None) => largest(color(i + 1) - color(i)),
                (l, r) => l.unwrap_or(0.0).max(r.unwrap_or(0.0)),
            }
        };
        for i in 0..brackets {
            let (a, b) = (&samples[i], &samples[i + 1]);
            let plain = |x: &KeySample| x.prim == u32::MAX || self.is_plain(x.prim);
            let verdict = if !(plain(a) && plain(b)) {
                Verdict::Material
            } else if !smooth[i] {
                Verdict::Edge
            } else if bend(i) > self.tolerance {
                Verdict::Surface
            } else {
                Verdict::Plain
            };
            s.verdicts.push(verdict);
        }
        // Runs: plain brackets whose hits all lie on one plane (or all miss).
        let mut i = 0;
        while i < brackets {
            let mut j = i + 1;
            if s.verdicts[i] == Verdict::Plain {
                while j < brackets
                    && s.verdicts[j] == Verdict::Plain
                    && self.same_plane(&samples[i], &samples[j + 1])
                {
                    j += 1;
                }
            }
            for _ in i..j {
                s.run_start.push(i as u32);
                s.run_end.push(j as u32);
            }
            i = j;
        }
    }

    /// Whether a bracket's two ends may lie on one surface: both miss, or
    /// both hit with no step in depth between (on two primitives, a
    /// tessellated surface; a ridge between them meets the bracket's region,
    /// a crease in the colour its colour test).
    fn continuous(&self, a: &KeySample, b: &KeySample) -> bool {
        match (a.prim == u32::MAX, b.prim == u32::MAX) {
            (true, true) => true,
            (false, false) => (a.z - b.z).abs() <= DEPTH_STEP * a.z.min(b.z),
            _ => false,
        }
    }

    fn is_plain(&self, prim: u32) -> bool {
        let m = self.world.scene.shape_material[prim as usize] as usize;
        self.plain[m]
    }

    /// Whether two key samples lie on one flat surface (or both miss): the
    /// region of a run between them then holds the rays to every hit
    /// between.
    fn same_plane(&self, a: &KeySample, b: &KeySample) -> bool {
        match (a.prim == u32::MAX, b.prim == u32::MAX) {
            (true, true) => true,
            (false, false) => {
                a.prim == b.prim
                    && matches!(self.world.scene.shapes[a.prim as usize], Shape::Triangle(_))
                    || self.world.coplanar(a.prim, b.prim)
            }
            _ => false,
        }
    }

    /// View at position `p` (served by key view `k`, whose farthest served
    /// view on that side is at `far`): its samples synthesized or traced.
    #[allow(clippy::too_many_arguments)]
    fn synthesize(
        &self,
        workers: &mut [(usize, Box<dyn RowWorker + '_>)],
        tracer: &mut Tracer,
        row: &SampleRow,
        k: usize,
        far: usize,
        p: usize,
        s: &mut SynthScratch,
        out: &mut [RowColors],
    ) {
        let n = row.len();
        let (_, key_offset, key_shift) = self.order[self.keys[k]];
        let (v, offset, shift) = self.order[p];
        let samples = &s.samples[k];
        // Where each key sample lands in this view's row.
        let shift_by = (key_shift - shift) as f64;
        let parallax = self.focal * (offset - key_offset) as f64;
        let land = |i: usize| {
            let z = samples[i].z;
            let disparity = if z.is_finite() { parallax / z } else { 0.0 };
            s.xs[i] + shift_by - disparity
        };
        s.cover.clear();
        s.cover.resize(n, UNCOVERED);
        let xs = &s.xs;
        // The first sample at or right of image column `w`: by arithmetic
        // where the row's samples are one per column (its pixels contiguous).
        let contiguous = n > 0 && (row.pixels[n - 1] - row.pixels[0]) as usize + 1 == n;
        let first_at = |w: f64| {
            if contiguous {
                (w - xs[0]).ceil().clamp(0.0, n as f64) as usize
            } else {
                xs.partition_point(|&x| x < w)
            }
        };
        let mut w0 = if n > 0 { land(0) } else { 0.0 };
        for i in 0..n.saturating_sub(1) {
            let w1 = land(i + 1);
            let (a, b) = (&samples[i], &samples[i + 1]);
            let folded = w1 < w0;
            let (from, to) = if folded { (w1, w0) } else { (w0, w1) };
            let (first, end) = (first_at(from), first_at(to));
            for (j, &x) in xs.iter().enumerate().take(end).skip(first) {
                let t = if to > from {
                    (x - from) / (to - from)
                } else {
                    0.0
                };
                let t = if folded { 1.0 - t } else { t };
                let z = match (a.z.is_finite(), b.z.is_finite()) {
                    (true, true) if !folded => a.z + (b.z - a.z) * t,
                    (true, true) => a.z.min(b.z),
                    (true, false) => a.z,
                    (false, true) => b.z,
                    (false, false) => f64::MAX,
                };
                if z < s.cover[j].z {
                    s.cover[j] = Cover {
                        z,
                        bracket: i as u32,
                        s: t,
                        folded,
                    };
                }
            }
            w0 = w1;
        }
        // Take the covered samples' colours; list the rest. (By index: the
        // region proofs below need the scratch space mutably.)
        s.pending.clear();
        #[allow(clippy::needless_range_loop)]
        for j in 0..n {
            let c = s.cover[j];
            let stats = &mut tracer.counts.synthesis;
            if c.bracket == u32::MAX {
                stats.holes += 1;
                s.pending.push(j);
                continue;
            }
            let i = c.bracket as usize;
            match s.verdicts[i] {
                Verdict::Plain if c.folded => {
                    stats.refused_surface += 1;
                    s.pending.push(j);
                    continue;
                }
                Verdict::Material => {
                    stats.refused_material += 1;
                    s.pending.push(j);
                    continue;
                }
                Verdict::Surface => {
                    stats.refused_surface += 1;
                    s.pending.push(j);
                    continue;
                }
                Verdict::Edge => {
                    stats.refused_edge += 1;
                    s.pending.push(j);
                    continue;
                }
                Verdict::Plain => {}
            }
            if !self.region_free(tracer, k, far, i, s) {
                tracer.counts.synthesis.refused_region += 1;
                s.pending.push(j);
                continue;
            }
            let samples = &s.samples[k];
            let (a, b) = (samples[i].color, samples[i + 1].color);
            out[v][j] = a + (b - a) * c.s as f32;
            tracer.counts.synthesis.synthesized += 1;
        }
        // 4. The rest traced exactly by the view itself.
        if s.pending.is_empty() {
            return;
        }
        tracer.counts.synthesis.traced += s.pending.len() as u64;
        let pixels = s.pending.iter().map(|&j| row.pixels[j]).collect();
        let sub = SampleRow::new(pixels, row.pattern);
        s.one.resize_with(1, Vec::new);
        s.one[0].clear();
        s.one[0].resize(sub.len(), Color::ZERO);
        workers[v].1.trace(tracer, &sub, &mut s.one[..1]);
        for (m, &j) in s.pending.iter().enumerate() {
            out[v][j] = s.one[0][m];
        }
    }

    /// Whether bracket `i` of key view `k` is proved free for the views out
    /// to position `far`: its run's region first, halved toward `i` where it
    /// holds something. Answers are kept per bracket for the side.
    fn region_free(
        &self,
        tracer: &mut Tracer,
        k: usize,
        far: usize,
        i: usize,
        s: &mut SynthScratch,
    ) -> bool {
        match s.proved[i] {
            1 => return true,
            2 => return false,
            _ => {}
        }
        let (mut lo, mut hi) = (s.run_start[i] as usize, s.run_end[i] as usize);
        loop {
            let free = self.prove(tracer, k, far, lo, hi, &s.samples[k]);
            if free {
                s.proved[lo..hi].fill(1);
                return true;
            }
            if hi - lo == 1 {
                s.proved[i] = 2;
                return false;
            }
            // Split the run where it failed, for the brackets asked next.
            let mid = (lo + hi) / 2;
            s.run_end[lo..mid].fill(mid as u32);
            s.run_start[mid..hi].fill(mid as u32);
            if i < mid {
                hi = mid;
            } else {
                lo = mid;
            }
        }
    }

    /// Whether nothing meets the region of brackets `lo..hi` of key view `k`
    /// toward the view at position `far`.
    fn prove(
        &self,
        tracer: &mut Tracer,
        k: usize,
        far: usize,
        lo: usize,
        hi: usize,
        samples: &[KeySample],
    ) -> bool {
        let key_eye = self.camera.eye_at(self.order[self.keys[k]].1);
        let far_eye = self.camera.eye_at(self.order[far].1);
        // The eyes left to right: the rays of the views between leave from
        // that segment.
        let (left, right) = if self.keys[k] <= far {
            (key_eye, far_eye)
        } else {
            (far_eye, key_eye)
        };
        let (a, b) = (&samples[lo], &samples[hi]);
        // Round the region in order (it is convex): the eyes left to right,
        // then the far side right to left. A run that hits ends at its hits
        // (pulled toward the key eye): every view's ray to a point of the
        // chord between them lies in it. A run of misses: each view's rays
        // are parallel to the key view's through the same camera column, so
        // the far side runs from the left eye's first ray to the right eye's
        // last, past the whole scene.
        let corners = if a.prim == u32::MAX {
            [
                left,
                right,
                right + b.dir * self.beyond,
                left + a.dir * self.beyond,
            ]
        } else {
            let end =
                |sample: &KeySample| key_eye + sample.dir * (sample.t as f64 * (1.0 - PULL)) as f32;
            [left, right, end(b), end(a)]
        };
        let stats = &mut tracer.counts.synthesis;
        stats.proofs += 1;
        let Some(region) = RunRegion::quad(corners, self.margin) else {
            stats.proofs_failed += 1;
            return false;
        };
        let shapes = &self.world.scene.shapes;
        let mut run_stats = RunStats::default();
        let eps = (self.margin * 4.0) as f32;
        let free = self
            .world
            .bvh
            .run_is_free(&region, u32::MAX, &mut run_stats, |prim| {
                shape_may_meet_quad(&shapes[prim as usize], &region, &corners, eps)
            });
        stats.proof_nodes += run_stats.proof_nodes;
        if !free {
            stats.proofs_failed += 1;
        }
        free
    }
}

/// The key view nearest to position `p` (an index into `keys`), ties to the
/// left.
fn nearest_key(keys: &[usize], p: usize) -> usize {
    let right = keys.partition_point(|&k| k < p).min(keys.len() - 1);
    if right > 0 && p - keys[right - 1] <= keys[right].abs_diff(p) {
        right - 1
    } else {
        right
    }
}

/// Every view traced exactly.
pub(super) fn trace_all(
    workers: &mut [(usize, Box<dyn RowWorker + '_>)],
    tracer: &mut Tracer,
    row: &SampleRow,
    out: &mut [RowColors],
) {
    let mut first = 0;
    for (n, worker) in workers.iter_mut() {
        worker.trace(tracer, row, &mut out[first..first + *n]);
        first += *n;
    }
}

/// The largest channel's magnitude.
pub(super) fn largest(c: Color) -> f32 {
    c.x.abs().max(c.y.abs()).max(c.z.abs())
}

/// Whether `shape` may meet the convex planar quadrilateral `corners`
/// (conservative: `false` only where proved). A triangle misses it when its
/// box does, when it lies strictly on one side of the quadrilateral's plane,
/// or when the segment in which it crosses that plane lies outside the
/// quadrilateral; a sphere when its centre is farther than its radius from
/// both halves; anything else meets it where its box does.
fn shape_may_meet_quad(shape: &Shape, region: &RunRegion, corners: &[Vec3; 4], eps: f32) -> bool {
    if !region.may_meet_box(&shape.bounds()) {
        return false;
    }
    match shape {
        Shape::Triangle(t) => {
            let verts = [t.v0, t.v0 + t.e1, t.v0 + t.e2];
            triangle_may_meet_quad(&verts, corners, eps)
        }
        Shape::Sphere(sp) => {
            let d = distance_to_triangle(sp.center, corners[0], corners[1], corners[2]).min(
                distance_to_triangle(sp.center, corners[0], corners[2], corners[3]),
            );
            d <= sp.radius.abs() + eps
        }
        _ => true,
    }
}

/// A triangle against a convex planar quadrilateral: the segment where the
/// triangle crosses the quadrilateral's plane, against the quadrilateral's
/// edges (grown by `eps`). A triangle in the plane, or a degenerate
/// quadrilateral, counts as met.
fn triangle_may_meet_quad(verts: &[Vec3; 3], corners: &[Vec3; 4], eps: f32) -> bool {
    let q = quad_normal(corners);
    if q == Vec3::ZERO {
        return true;
    }
    let d = verts.map(|v| q.dot(v - corners[0]));
    if d.iter().all(|&x| x > eps) || d.iter().all(|&x| x < -eps) {
        return false;
    }
    if d.iter().all(|&x| x.abs() <= eps) {
        return true;
    }
    // The crossing segment: vertices in the plane, and edges that cross it.
    let mut ends = [Vec3::ZERO; 3];
    let mut count = 0;
    for e in 0..3 {
        let (a, b) = (e, (e + 1) % 3);
        if d[a].abs() <= eps {
            ends[count.min(2)] = verts[a];
            count += 1;
        } else if d[b].abs() > eps && (d[a] > 0.0) != (d[b] > 0.0) {
            let s = d[a] / (d[a] - d[b]);
            ends[count.min(2)] = verts[a] + (verts[b] - verts[a]) * s;
            count += 1;
        }
    }
    if count == 0 {
        return false;
    }
    let (p, r) = (ends[0], ends[count.min(2) - 1]);
    // Outside an edge's line (on the far side from the quadrilateral's
    // inside, by more than eps) at both ends: separated.
    let centre = (corners[0] + corners[1] + corners[2] + corners[3]) * 0.25;
    for e in 0..4 {
        let (a, b) = (corners[e], corners[(e + 1) % 4]);
        let mut out = q.cross(b - a).normalize_or_zero();
        if out.dot(centre - a) > 0.0 {
            out = -out;
        }
        if out.dot(p - a) > eps && out.dot(r - a) > eps {
            return false;
        }
    }
    true
}

/// The unit normal of a planar quadrilateral (its larger half's), zero if
/// degenerate.
fn quad_normal(c: &[Vec3; 4]) -> Vec3 {
    let n1 = (c[1] - c[0]).cross(c[3] - c[0]);
    let n2 = (c[2] - c[1]).cross(c[3] - c[1]);
    let n = if n1.length_squared() >= n2.length_squared() {
        n1
    } else {
        n2
    };
    n.normalize_or_zero()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_view_takes_its_nearest_key_view() {
        let keys = [0, 8, 16, 23];
        let nearest: Vec<usize> = (0..24).map(|p| nearest_key(&keys, p)).collect();
        assert_eq!(&nearest[0..5], &[0, 0, 0, 0, 0]);
        assert_eq!(&nearest[5..13], &[1, 1, 1, 1, 1, 1, 1, 1]);
        assert_eq!(nearest[19], 2, "ties go to the left");
        assert_eq!(nearest[20], 3);
        assert_eq!(nearest[23], 3);
    }

    #[test]
    fn a_triangle_on_one_side_of_the_quad_misses_it() {
        let quad = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 5.0),
            Vec3::new(0.0, 0.0, 5.0),
        ];
        let region = RunRegion::quad(quad, 1e-6).expect("finite");
        let tri = |a: Vec3, b: Vec3, c: Vec3| {
            Shape::Triangle(crate::shapes::Triangle::new(
                a,
                b,
                c,
                (b - a).cross(c - a).normalize(),
                crate::shapes::TriangleNormals::Flat,
            ))
        };
        // A floor below the quad (y = -0.01): missed.
        let floor = tri(
            Vec3::new(-5.0, -0.01, -5.0),
            Vec3::new(5.0, -0.01, -5.0),
            Vec3::new(0.0, -0.01, 10.0),
        );
        assert!(!shape_may_meet_quad(&floor, &region, &quad, 1e-5));
        // A pole through it: met.
        let pole = tri(
            Vec3::new(0.5, -1.0, 2.0),
            Vec3::new(0.51, -1.0, 2.0),
            Vec3::new(0.5, 1.0, 2.0),
        );
        assert!(shape_may_meet_quad(&pole, &region, &quad, 1e-5));
        // The same pole beside it (x = 3): its plane crosses the quad's, but
        // the crossing lies outside the quad.
        let beside = tri(
            Vec3::new(3.0, -1.0, 2.0),
            Vec3::new(3.01, -1.0, 2.0),
            Vec3::new(3.0, 1.0, 2.0),
        );
        assert!(!shape_may_meet_quad(&beside, &region, &quad, 1e-5));
        // A sphere above the quad, and one touching it.
        let sphere = Shape::Sphere(crate::shapes::Sphere {
            center: Vec3::new(0.5, 0.2, 2.0),
            radius: 0.1,
            inside: false,
        });
        assert!(!shape_may_meet_quad(&sphere, &region, &quad, 1e-5));
        let touching = Shape::Sphere(crate::shapes::Sphere {
            center: Vec3::new(0.5, 0.09, 2.0),
            radius: 0.1,
            inside: false,
        });
        assert!(shape_may_meet_quad(&touching, &region, &quad, 1e-5));
    }
}

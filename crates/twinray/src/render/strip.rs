//! The strip eye pass (issue 16, `--strip`): the nearest hit of every view's
//! eye ray through a row of samples, one descent per camera column for all
//! the views at once.
//!
//! The rig's views sit on the camera's right axis with parallel axes and
//! whole-pixel shifts, so view `v`'s sample in pixel `p` looks along camera
//! column `p + shift_v`. Re-indexed by camera column, the views' rays are
//! parallel (one direction, `Camera::direction(column, y)`) with origins on
//! the camera line, `eye + offset_v · right`: one family of rays, which
//! `Bvh::closest_strip` traces in one descent, every ray's hit exactly what
//! the ray traced alone gets. Rows whose samples do not share one offset in
//! their pixels (a Sobol pattern) give no such family and are traced by the
//! twin batches as before; so are worlds with a cut or cut-out materials.

use super::sampler::SampleRow;
use super::Tracer;
use crate::bvh::{
    primitive_box, ray_reaches, Cover, Family, FamilyTest, Interval, Packet, RunRegion,
    StripScratch, FAMILY_EPS, FILL_REACH,
};
use crate::math::{Ray, Vec3};
use crate::rig::{Camera, Rig};
use crate::shapes::{Shape, Sphere, SurfaceHit, Triangle};
use crate::world::World;
use glam::DVec3;

/// No hit (as `PacketHits::NO_HIT`, with an infinitely far hit).
pub(super) const NO_HIT: (u32, SurfaceHit) = (
    u32::MAX,
    SurfaceHit {
        t: f32::INFINITY,
        u: 0.0,
        v: 0.0,
    },
);

/// What every row of a render's strip pass shares.
pub(super) struct StripEyePass<'a> {
    world: &'a World,
    camera: &'a Camera,
    /// The rig's views by ascending offset: (view, offset, shift).
    views: Vec<(usize, f32, i32)>,
    /// Every view's eye, as the other methods compute it.
    origins: Vec<Vec3>,
    min_shift: i32,
    max_shift: i32,
    scene_scale: f32,
    /// `--eye-runs`: each family's hits by eye runs (`bvh/run.rs`) instead
    /// of the family descent.
    runs: bool,
    /// Eye runs: the rounding margin of their regions, and a distance past
    /// the scene's bounds from any eye.
    margin: f64,
    beyond: f64,
}

/// A row's eye hits for every view of the rig, and the strip's buffers.
#[derive(Default)]
pub(super) struct StripRow {
    /// Whether the strip traced this row (else the batches trace it).
    pub traced: bool,
    /// `hits[v][i]`: view `v`'s nearest hit through sample `i`.
    pub hits: Vec<Vec<(u32, SurfaceHit)>>,
    index_of: Vec<u32>,
    members: Vec<(usize, usize)>,
    member_origins: Vec<Vec3>,
    family: Family,
    found: Vec<Option<(u32, SurfaceHit)>>,
    scratch: StripScratch,
    /// Every single-ray primitive test the strip made: (view, sample, prim).
    #[cfg(test)]
    tested: Vec<(usize, usize, u32)>,
    /// Eye runs: spans of members (ends traced) still to resolve, those of
    /// the next round, and the members to trace before it.
    spans: Vec<(usize, usize)>,
    next_spans: Vec<(usize, usize)>,
    pending: Vec<usize>,
    /// Eye runs: every span of the row proved free (`interpolated_views`
    /// shades the views between its ends): its primitive (`u32::MAX`: a
    /// miss) and its members, ends included, in offset order, as
    /// `proved_members[start..start + len]` (view, sample).
    pub proved: Vec<ProvedSpan>,
    pub proved_members: Vec<(usize, usize)>,
}

/// A span of a family proved free by an eye run (see `StripRow::proved`).
#[derive(Clone, Copy, Debug)]
pub(super) struct ProvedSpan {
    pub prim: u32,
    pub start: usize,
    pub len: usize,
}

impl<'a> StripEyePass<'a> {
    /// The strip pass of `rig`, or `None` where the world's eye rays need more
    /// than the nearest hit of the near hierarchy (a cut, cut-out materials).
    pub(super) fn new(world: &'a World, camera: &'a Camera, rig: &Rig) -> Option<Self> {
        if world.far.is_some() || world.has_alpha || rig.views.len() < 2 {
            return None;
        }
        let views = rig.views_by_offset();
        let bounds = world.bvh.bounds();
        let scene_scale = bounds.min.abs().max(bounds.max.abs()).max_element();
        let origins: Vec<Vec3> = rig.views.iter().map(|v| camera.eye_at(v.offset)).collect();
        let origin_scale = origins
            .iter()
            .fold(0.0f32, |m, o| m.max(o.abs().max_element()));
        let size = (bounds.max - bounds.min).length() as f64;
        let far = bounds.center().as_dvec3();
        let beyond = origins
            .iter()
            .map(|o| (o.as_dvec3() - far).length())
            .fold(0.0f64, f64::max);
        Some(StripEyePass {
            world,
            camera,
            origins,
            runs: false,
            margin: RUN_MARGIN * scene_scale.max(origin_scale).max(1e-3) as f64,
            beyond: (beyond + size) * 1.01,
            min_shift: views.iter().map(|v| v.2).min().unwrap_or(0),
            max_shift: views.iter().map(|v| v.2).max().unwrap_or(0),
            views,
            scene_scale: if scene_scale.is_finite() {
                scene_scale
            } else {
                0.0
            },
        })
    }

    /// Every view's nearest hits through the samples of `row`, into `out`
    /// (`out.traced` false when the row's samples give no family).
    pub(super) fn trace_row(&self, tracer: &mut Tracer, row: &SampleRow, out: &mut StripRow) {
        out.traced = false;
        out.proved.clear();
        out.proved_members.clear();
        let (Some(&first), Some(&last), Some(&offset)) =
            (row.pixels.first(), row.pixels.last(), row.offsets.first())
        else {
            return;
        };
        let same = |o: &(f32, f32)| o.0.to_bits() == offset.0.to_bits() && o.1 == offset.1;
        if !row.offsets.iter().all(same) {
            return;
        }
        out.traced = true;
        let (dx, y) = offset;
        out.hits.resize_with(self.origins.len(), Vec::new);
        for h in out.hits.iter_mut() {
            h.clear();
            h.resize(row.len(), NO_HIT);
        }
        out.index_of.clear();
        out.index_of.resize((last - first + 1) as usize, u32::MAX);
        for (i, &p) in row.pixels.iter().enumerate() {
            out.index_of[(p - first) as usize] = i as u32;
        }
        let shapes = &self.world.scene.shapes;
        for column in first + self.min_shift..=last + self.max_shift {
            out.members.clear();
            out.member_origins.clear();
            let dir = self.camera.direction(column as f32 + dx, y);
            out.family.reset(
                self.camera.eye,
                self.camera.right,
                dir,
                self.camera.hither,
                self.scene_scale,
            );
            for &(v, offset, shift) in &self.views {
                let p = column - shift;
                if p < first || p > last {
                    continue;
                }
                let i = out.index_of[(p - first) as usize];
                if i != u32::MAX {
                    out.members.push((v, i as usize));
                    out.member_origins.push(self.origins[v]);
                    out.family.push(offset, self.origins[v]);
                }
            }
            if out.members.is_empty() {
                continue;
            }
            out.family.finish();
            if self.runs {
                self.trace_runs(tracer, dir, out);
                for (&(v, i), found) in out.members.iter().zip(&out.found) {
                    if let Some(hit) = found {
                        out.hits[v][i] = *hit;
                    }
                }
                continue;
            }
            let mut test = ShapeFamily {
                shapes,
                origins: &out.member_origins,
                dir,
                t_min: self.camera.hither,
                #[cfg(test)]
                tested: Vec::new(),
            };
            self.world.bvh.closest_strip(
                &out.family,
                &mut test,
                &mut out.scratch,
                &mut tracer.counts.strip,
                &mut out.found,
            );
            #[cfg(test)]
            out.tested.extend(test.tested.iter().map(|&(k, prim)| {
                let (v, i) = out.members[k];
                (v, i, prim)
            }));
            let counts = &mut tracer.counts;
            counts.eye_traversals += 1;
            for (&(v, i), found) in out.members.iter().zip(&out.found) {
                counts.rays.eye += 1;
                if let Some(hit) = found {
                    out.hits[v][i] = *hit;
                    counts.rays.eye_hit += 1;
                    if let Some(h) = counts.per_view_hits.0.get_mut(v) {
                        *h += 1;
                    }
                }
            }
        }
    }
}

/// Eye runs' regions are grown by this much of the scene's scale: it bounds
/// the rounding of the eyes, of the slab tests and of the region's tests.
const RUN_MARGIN: f64 = 3e-5;

impl StripEyePass<'_> {
    /// The pass with every family's hits found by eye runs (`--eye-runs`).
    pub(super) fn with_runs(mut self) -> Self {
        self.runs = true;
        self
    }

    /// The family's hits (`out.found`, by member) by eye runs: its two end
    /// rays traced, then round by round each span between traced rays
    /// either proved (`prove_run`) or split at its middle ray, the round's
    /// middle rays traced together (`bvh/run.rs`).
    fn trace_runs(&self, tracer: &mut Tracer, dir: Vec3, out: &mut StripRow) {
        let n = out.members.len();
        out.found.clear();
        out.found.resize(n, None);
        tracer.counts.runs.families += 1;
        out.pending.clear();
        out.pending.push(0);
        if n > 1 {
            out.pending.push(n - 1);
        }
        out.spans.clear();
        if n > 2 {
            out.spans.push((0, n - 1));
        }
        loop {
            self.trace_pending(tracer, dir, out);
            if out.spans.is_empty() {
                break;
            }
            let mut spans = std::mem::take(&mut out.spans);
            out.next_spans.clear();
            for &(a, b) in &spans {
                if b - a < 2 || self.prove_run(tracer, dir, out, a, b) {
                    continue;
                }
                let m = (a + b) / 2;
                out.pending.push(m);
                out.next_spans.push((a, m));
                out.next_spans.push((m, b));
            }
            spans.clear();
            out.spans = std::mem::replace(&mut out.next_spans, spans);
        }
    }

    /// The members `out.pending` traced, each alone, by the independent
    /// method's routine (a one-lane packet: the four-wide tree's single-ray
    /// descent). Not four to a packet: wider packets descend the binary
    /// tree, whose hits differed from the single ray's in one pixel of the
    /// SPD tree (docs/benchmarks.md, "Issue 16, fourth pass").
    fn trace_pending(&self, tracer: &mut Tracer, dir: Vec3, out: &mut StripRow) {
        let pending = std::mem::take(&mut out.pending);
        for k in pending.chunks(1) {
            self.trace_lanes::<1>(tracer, dir, out, k);
        }
        out.pending = pending;
        out.pending.clear();
    }

    /// Members `ks` (at most `K`) traced as one packet.
    fn trace_lanes<const K: usize>(
        &self,
        tracer: &mut Tracer,
        dir: Vec3,
        out: &mut StripRow,
        ks: &[usize],
    ) {
        let lane = |l: usize| ks[l.min(ks.len() - 1)];
        let packet = Packet {
            origins: std::array::from_fn(|l| out.member_origins[lane(l)]),
            dirs: [dir; K],
            t_min: self.camera.hither,
            t_max: [f32::INFINITY; K],
            mask: (1u32 << ks.len()) - 1,
        };
        let views: [usize; K] = std::array::from_fn(|l| out.members[lane(l)].0);
        let h = tracer.eye_hits(&packet, &views);
        for (l, &k) in ks.iter().enumerate() {
            out.found[k] = h.has_hit(l).then_some((h.prim[l], h.hit[l]));
        }
        tracer.counts.runs.traced += ks.len() as u64;
    }

    /// Whether the members strictly between `a` and `b` (both traced) are
    /// given their hits by a proof: both ends on one primitive, or both
    /// missing, and nothing else in the region between (`Bvh::run_is_free`).
    /// Then each is filled with its own test of that primitive, or traced
    /// where that test does not give a hit inside the region.
    fn prove_run(
        &self,
        tracer: &mut Tracer,
        dir: Vec3,
        out: &mut StripRow,
        a: usize,
        b: usize,
    ) -> bool {
        let prim_of = |f: &Option<(u32, SurfaceHit)>| f.map_or(u32::MAX, |h| h.0);
        let (pa, pb) = (prim_of(&out.found[a]), prim_of(&out.found[b]));
        let (sa, sb) = (out.family.s[a], out.family.s[b]);
        if pa != pb || sb <= sa {
            return false;
        }
        let t_of = |f: &Option<(u32, SurfaceHit)>| f.map_or(self.beyond, |h| h.1.t as f64);
        let (ta, tb) = (t_of(&out.found[a]), t_of(&out.found[b]));
        let (oa, ob) = (out.member_origins[a], out.member_origins[b]);
        let Some(region) = RunRegion::new(oa, ob, dir, ta, tb, self.margin) else {
            return false;
        };
        // How far a kept hit may lie at parameter `s` (see `bvh/run.rs`).
        let bound = |s: f64| {
            let w = (s - sa) / (sb - sa);
            (ta + (tb - ta) * w) * (1.0 + FILL_REACH) + self.margin * 0.5
        };
        let shapes = &self.world.scene.shapes;
        let hit_prim = ((pa as usize) < shapes.len()).then_some(pa);
        let runs = &mut tracer.counts.runs;
        runs.proofs += 1;
        let family = &out.family;
        let free = self.world.bvh.run_is_free(&region, pa, runs, |prim| {
            may_meet(&shapes[prim as usize], &region, family, (sa, sb), &bound)
        });
        if !free {
            runs.proofs_failed += 1;
            return false;
        }
        for k in a + 1..b {
            let (v, _) = out.members[k];
            if let Some(pa) = hit_prim {
                let (origin, s) = (out.member_origins[k], out.family.s[k]);
                let hither = self.camera.hither;
                let kept = shapes[pa as usize]
                    .intersect(&Ray::new(origin, dir), hither, f32::INFINITY)
                    .filter(|h| {
                        (h.t as f64) <= bound(s)
                            && self
                                .world
                                .filed_boxes(pa)
                                .any(|b| ray_reaches(&b, origin, dir, hither, h.t))
                    });
                let Some(hit) = kept else {
                    tracer.counts.runs.fill_refused += 1;
                    out.pending.push(k);
                    continue;
                };
                out.found[k] = Some((pa, hit));
            } else {
                out.found[k] = None;
            }
            let counts = &mut tracer.counts;
            counts.runs.filled += 1;
            counts.rays.eye += 1;
            if pa != u32::MAX {
                counts.rays.eye_hit += 1;
                if let Some(h) = counts.per_view_hits.0.get_mut(v) {
                    *h += 1;
                }
            }
        }
        out.proved.push(ProvedSpan {
            prim: pa,
            start: out.proved_members.len(),
            len: b - a + 1,
        });
        let members = &out.members[a..=b];
        out.proved_members.extend_from_slice(members);
        true
    }
}

/// Whether `shape` (not the run's primitive) may give some ray of `family`
/// with parameter in `span` a hit no farther than `bound` (conservative:
/// `false` only where proved; see `bvh/run.rs`). Its box outside the region:
/// no. Else the family's bounds on the single-ray routine: the rays it may
/// hit, and for those the nearest distance it may report.
fn may_meet(
    shape: &Shape,
    region: &RunRegion,
    family: &Family,
    span: (f64, f64),
    bound: &impl Fn(f64) -> f64,
) -> bool {
    if !region.may_meet_box(&primitive_box(&shape.bounds())) {
        return false;
    }
    let cover = match shape {
        Shape::Triangle(t) => triangle_cover(t, family),
        Shape::Sphere(s) => sphere_cover(s, family),
        Shape::Cone(_) => return true,
    };
    let iv = match cover {
        Cover::Miss => return false,
        Cover::Unbounded => return true,
        Cover::Interval(iv) => iv,
    };
    let (lo, hi) = (iv.lo.max(span.0), iv.hi.min(span.1));
    if lo > hi {
        return false;
    }
    // The nearest distance the routine may report is bounded below by a
    // linear function of the parameter: beyond `bound` at both ends, beyond
    // it everywhere between.
    let beyond = |s: f64| nearest_report(shape, family, s).is_some_and(|t| t > bound(s));
    !(beyond(lo) && beyond(hi))
}

/// A lower bound, linear in `s`, on the distance of any hit the single-ray
/// routine may report for the family's ray with parameter `s` on `shape`;
/// `None` where the family's arithmetic cannot bound it.
fn nearest_report(shape: &Shape, f: &Family, s: f64) -> Option<f64> {
    let o = f.base + f.step * s;
    let d = f.dir;
    match shape {
        Shape::Triangle(t) => {
            // Triangle::intersect's distance from the plane, -n·(o - v0) / n·d.
            let (n, v0) = (t.plane_normal.as_dvec3(), t.v0.as_dvec3());
            let nd = n.dot(d);
            let (ln, ld) = (n.length(), d.length());
            if nd.is_nan() || nd.abs() <= FAMILY_EPS * 16.0 * ln * ld {
                return None;
            }
            let w = o - v0;
            let t = -n.dot(w) / nd;
            let m = w.length() + f.origin_scale + v0.length();
            let tol = FAMILY_EPS * (4.0 * m * ln / nd.abs() + t.abs() * 4.0 * ln * ld / nd.abs());
            Some(t - tol)
        }
        Shape::Sphere(sp) => {
            // Sphere::intersect: the centre's projection on the ray, less the
            // half chord (at most the radius, up to the rounding of its square).
            let c = sp.center.as_dvec3();
            let r = sp.radius.abs() as f64;
            let x = c - o;
            let reach = x.length() + f.origin_scale + c.length() + r;
            let tol = FAMILY_EPS * reach * reach;
            Some(x.dot(d) / d.length_squared() - r - tol.sqrt() - FAMILY_EPS * reach * 4.0)
        }
        Shape::Cone(_) => None,
    }
}

/// The scene's shapes against a family of parallel eye rays.
struct ShapeFamily<'s> {
    shapes: &'s [Shape],
    /// Ray `k`'s origin, as the single-ray methods compute it.
    origins: &'s [Vec3],
    dir: Vec3,
    t_min: f32,
    /// The (ray, primitive) pairs `exact` tested.
    #[cfg(test)]
    tested: Vec<(usize, u32)>,
}

impl FamilyTest for ShapeFamily<'_> {
    #[inline]
    fn cover(&mut self, prim: u32, family: &Family) -> Cover {
        match &self.shapes[prim as usize] {
            Shape::Triangle(t) => triangle_cover(t, family),
            Shape::Sphere(s) => sphere_cover(s, family),
            Shape::Cone(_) => Cover::Unbounded,
        }
    }

    #[inline]
    fn exact(&mut self, prim: u32, k: usize) -> Option<SurfaceHit> {
        #[cfg(test)]
        self.tested.push((k, prim));
        let ray = Ray::new(self.origins[k], self.dir);
        self.shapes[prim as usize].intersect(&ray, self.t_min, f32::INFINITY)
    }
}

/// The rays of `f` that `Triangle::intersect` may find on `t`: Möller–Trumbore's
/// `u` and `v` are linear in the family's parameter; the bounds `0 ≤ u ≤ 1`,
/// `v ≥ 0`, `u + v ≤ 1` are widened by a bound on the routine's rounding.
/// Triangles nearly parallel to the rays are not bounded.
fn triangle_cover(t: &Triangle, f: &Family) -> Cover {
    let (v0, e1, e2) = (t.v0.as_dvec3(), t.e1.as_dvec3(), t.e2.as_dvec3());
    let d = f.dir;
    let p = d.cross(e2);
    let det = e1.dot(p);
    let (ld, l1, l2) = (d.length(), e1.length(), e2.length());
    let scale = l1 * ld * l2;
    if det.is_nan() || det.abs() <= FAMILY_EPS * 16.0 * scale {
        return Cover::Unbounded;
    }
    let w = f.base - v0;
    // Bounds the origin's offset from the vertex and the origins' rounding.
    let m = w.length() + f.origin_scale + v0.length();
    let tol_u = FAMILY_EPS * (m * ld * l2 + 4.0 * scale) / det.abs();
    let tol_v = FAMILY_EPS * (m * ld * l1 + 4.0 * scale) / det.abs();
    let (u0, u1) = (w.dot(p) / det, f.step.dot(p) / det);
    let (v0c, v1) = (d.dot(w.cross(e1)) / det, d.dot(f.step.cross(e1)) / det);
    let mut iv = Interval::ALL;
    iv.le(-u1, u0 + tol_u);
    iv.le(u1, 1.0 + tol_u - u0);
    iv.le(-v1, v0c + tol_v);
    iv.le(u1 + v1, 1.0 + tol_u + tol_v - u0 - v0c);
    if iv.is_empty() {
        Cover::Miss
    } else {
        Cover::Interval(iv)
    }
}

/// The rays of `f` whose line passes within the radius of `s`'s centre (a
/// quadratic in the parameter), widened by a bound on `Sphere::intersect`'s
/// rounding of the squared distance.
fn sphere_cover(s: &Sphere, f: &Family) -> Cover {
    let c = s.center.as_dvec3();
    let r = s.radius as f64;
    let d = f.dir;
    let proj = |x: DVec3| x - d * (x.dot(d) / d.dot(d));
    let x = f.base - c;
    let (w0, w1) = (proj(x), proj(f.step));
    let reach = x.length() + f.origin_scale + c.length() + r;
    let tol = FAMILY_EPS * reach * reach;
    let (a, b, cc) = (w1.dot(w1), 2.0 * w0.dot(w1), w0.dot(w0) - r * r - tol);
    let mut iv = Interval::ALL;
    if a <= f64::MIN_POSITIVE {
        iv.le(b, -cc);
    } else {
        let disc = b * b - 4.0 * a * cc;
        if disc < 0.0 {
            return Cover::Miss;
        }
        let root = disc.sqrt();
        let (s0, s1) = ((-b - root) / (2.0 * a), (-b + root) / (2.0 * a));
        let widen = 1e-9 * (s0.abs() + s1.abs()) + f64::MIN_POSITIVE;
        iv.lo = s0 - widen;
        iv.hi = s1 + widen;
    }
    if iv.is_empty() {
        Cover::Miss
    } else {
        Cover::Interval(iv)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::{Packet, StripStats, TraversalStats};
    use crate::render::TraceSettings;

    /// Every view's hit through every sample of the shipped example scene
    /// (spheres, a cone, polygons), 16 views under a converged rig: the
    /// strip's `prim`, `t`, `u`, `v` are those of the binary tree's single-ray
    /// descent, bit for bit, and the strip visits far fewer nodes than the 16
    /// views' rays traced one by one. A view tests only primitives its own
    /// single-ray descent tests too: it enters a leaf only by that descent's
    /// box test with its own nearest hit, the condition the strip's exactness
    /// rests on (the family's widened interval alone admits more leaves).
    #[test]
    fn strip_hits_are_single_ray_hits_with_fewer_node_visits() {
        let world = World::new(crate::render::example_scene());
        let camera = Camera::new(&world.scene.viewpoint, 64, 48);
        let views = 16;
        let rig = Rig::multi_view(&camera, views, 0.05, Some(8.0)).expect("rig");
        let pass = StripEyePass::new(&world, &camera, &rig).expect("no cut, no cut-outs");
        let mut tracer = Tracer::new(&world, TraceSettings::default());
        let mut row_hits = StripRow::default();
        let mut single = TraversalStats::default();
        let (mut compared, mut hits, mut checked) = (0, 0, 0);
        for y in 0..camera.height {
            row_hits.tested.clear();
            let mut alone_tested = std::collections::HashSet::new();
            let row = SampleRow::centres(camera.width as usize, y);
            pass.trace_row(&mut tracer, &row, &mut row_hits);
            assert!(row_hits.traced);
            for (v, view) in rig.views.iter().enumerate() {
                for i in 0..row.len() {
                    let (column, y) = row.camera_point(i, view.shift);
                    let ray = camera.ray(view.offset, column, y);
                    let packet = Packet::<1> {
                        origins: [ray.origin],
                        dirs: [ray.dir],
                        t_min: camera.hither,
                        t_max: [f32::INFINITY],
                        mask: 1,
                    };
                    let shapes = &world.scene.shapes;
                    let alone = world.bvh.closest(
                        &packet,
                        &mut single,
                        |prim: u32, _: usize, t_max: f32| {
                            alone_tested.insert((v, i, prim));
                            shapes[prim as usize].intersect(&ray, camera.hither, t_max)
                        },
                    );
                    let (prim, hit) = row_hits.hits[v][i];
                    assert_eq!(prim, alone.prim[0], "view {v} sample {i} row {y}");
                    if prim != u32::MAX {
                        let b = |h: &SurfaceHit| [h.t, h.u, h.v].map(f32::to_bits);
                        assert_eq!(b(&hit), b(&alone.hit[0]), "view {v} sample {i} row {y}");
                        hits += 1;
                    }
                    compared += 1;
                }
            }
            for t in &row_hits.tested {
                assert!(
                    alone_tested.contains(t),
                    "row {y}: (view, sample, prim) {t:?}"
                );
                checked += 1;
            }
        }
        assert!(checked > compared / 2, "{checked} strip tests checked");
        assert!(hits * 2 > compared, "{hits} hits of {compared}");
        let s: StripStats = tracer.counts.strip;
        assert!(
            s.nodes * 4 < single.nodes,
            "strip {} nodes, single rays {} nodes",
            s.nodes,
            single.nodes
        );
    }
}

//! Epipolar rows, the fast method's first stage: every view's eye hits of an
//! image row found from the primitives that cross the row's plane, and a
//! surface point's view-independent colour shaded once for all the views
//! that see it, within the fast method's tolerance `E`: its first stage,
//! where every row lies in one plane (`fast::stages`).
//!
//! The rig's views lie on the camera's right axis `R` with parallel axes, so
//! the rays of every view through one image row lie in one plane: the one
//! through the camera line spanned by `R` and `W = F + U·y` (`y` the row's
//! height on the image plane). In that plane a point has coordinates `(a,
//! b)` (along `R` and `W`), and the view at offset `u` sees it in the column
//! whose slope is `(a − u)/b`. So a row is one 2-D scene, the plane's
//! section of each primitive, seen by N cameras on a line:
//!
//! 1. **Visibility, exactly.** The primitives whose boxes meet the row's
//!    region (the quadrilateral every view's rays of the row sweep) are
//!    gathered in one descent. Each one's section (a triangle's segment, a
//!    sphere's circle, any other shape's box) gives, per view, the samples
//!    whose rays may meet it, a hundredth of a sample beyond its ends'
//!    columns; each of those rays is tested against the primitive with the
//!    single-ray routine (nearest sections first; a ray whose hit so far
//!    lies before a section skips it), and the nearest hit is kept, ties to
//!    the lower primitive index, as the hierarchy keeps them. A sample's hit is
//!    therefore the one its own ray finds (the tests compare every sample
//!    with the hierarchy's), no eye ray is traced, and no view misses a
//!    pole the others do not see.
//! 2. **Shading, once per surface point.** Views are visited middle first,
//!    then the outermost, then halfway between visited ones. A visited
//!    view's sample that hits a diffuse surface (mirror, highlight and
//!    transmission weights at most `E`) looks for the two *shade points* of
//!    its primitive on either side of its own hit along the section (earlier
//!    views' samples shaded exactly). They must lie within one and a half of
//!    this view's pixels of each other, on either side of the sample, at its
//!    depth, seen on its face (views either side of a surface's plane see
//!    its two faces, lit apart). It takes their colour, interpolated along
//!    the section, if their colours differ by at most `E` per channel and
//!    each lies within `E/2` of the line through its neighbours' colours
//!    (a peak of the diffuse
//!    term between them, as at a sphere's brightest point, bends it; a
//!    neighbour must be there). On a flat triangle without maps under
//!    lights without falloff, the bend is bounded by the lights' distance
//!    instead (`flat_curvature`), and no neighbour is needed: a small
//!    triangle seldom has shade points on both sides of the two. Else, if
//!    the two and their outer neighbours saw each light alike (the same
//!    transmittance), it takes that light and its secondary colour between
//!    theirs, and computes its own ambient, diffuse and highlight terms: no
//!    ray. Where they saw only some lights
//!    alike, it takes those and traces its own shadow rays toward the
//!    others, and becomes a shade point. Every other sample (no shade point
//!    on one side, colour and every light apart, a mirror or glass) is
//!    shaded exactly, eight to a packet, and becomes a shade point; a sample
//!    that hits nothing takes the background, as its ray would.
//!
//! **The bound.** A taken colour lies between two exact colours of the same
//! surface at most a pixel and a half apart that differ by at most `E`: if
//! the colour varies monotonically between them, it is off by at most `E`
//! per channel. Where it does not (a smooth peak), the bend test bounds the
//! curvature: for a parabolic profile the interpolation's error is a quarter
//! of the half second difference, so at most `E/8`; on a flat triangle the
//! lights' distance bounds it, `κ·h² ≤ E/2` (`flat_curvature`). Add the
//! view-dependent terms the material threshold lets through (`E` of the
//! highlight and mirror weights). A sample that takes the light is exact where the light
//! is what its shade points saw, with its secondary light off by at most `E`
//! times what its rays would bring. The assumption is that no feature
//! narrower than the shade points' spacing lies between them. A shadow or
//! texture edge between the two shows as a step in their colours or their
//! light and is shaded exactly; a sliver narrower than the shade points'
//! spacing that falls between two of them is not seen (as the middle view's
//! own image misses it).
//!
//! Only rows of one fixed pattern in every pixel (`--samples 1`, the SPD's
//! and the adaptive sampling's corners) lie in one plane; other rows are
//! traced exactly in every view.

mod plane;

use plane::{Plane, Section, NEAR_SLACK};

use super::counts::EpipolarCounts;
use crate::bvh::{Packet, PacketHits, Region, EYE_PACKET};
use crate::lights::LightKind;
use crate::math::{Color, Ray, Vec3};
use crate::render::batch::{trace_all, RowWorker};
use crate::render::sampler::{Pattern, RowColors, SampleRow};
use crate::render::tracer::{Donors, SecondaryRays, Tracer, TRACE_LIGHT};
use crate::rig::{Camera, Rig};
use crate::shapes::{Shape, SurfaceHit, TriangleNormals};
use crate::world::World;

/// Largest distance between a sample's two shade points, in the view's
/// pixels.
const WIDEST: f64 = 1.5;

/// How far outside its two shade points' columns a sample may lie (their
/// rounding), in pixels.
const SLACK: f64 = 1e-3;

/// Largest difference between a sample's depth and its two shade points'
/// (interpolated), relative to its own: beyond it they are not the surface it
/// sees.
const DEPTH_STEP: f64 = 0.01;

/// What a render's epipolar rows share.
pub(in crate::render) struct EpipolarPass<'a> {
    world: &'a World,
    camera: &'a Camera,
    /// The views by offset: (rig index, offset, shift).
    order: Vec<(usize, f32, i32)>,
    /// Positions in `order`, in the order their rows are shaded.
    visit: Vec<usize>,
    /// The least and the greatest shift of the views.
    shifts: (i32, i32),
    /// Per position: the first of a row's camera columns that its view
    /// looks along (its shift less the least; see `EpiScratch::dirs`).
    first: Vec<usize>,
    tolerance: f32,
    /// Per material: shading independent of the view within the tolerance.
    plain: Vec<bool>,
    /// Per primitive: `flat_curvature`, once for every row.
    curvature: Vec<f64>,
    /// Margin of the region and of the sections (the rounding of the
    /// scene's coordinates).
    margin: f64,
    /// A distance past the whole scene from every eye.
    beyond: f32,
}

/// A sample shaded exactly: where on its primitive's section, its colour,
/// and what it took from the lights and its secondary rays.
#[derive(Clone, Copy, Debug)]
struct ShadePoint {
    /// Position along the section (a segment's fraction, a circle's angle).
    param: f64,
    a: f64,
    b: f64,
    /// `1/(b·ps)`: its column in a view is `(a − offset)` times this.
    inv_bps: f64,
    color: Color,
    /// Weighted colour of its reflected and refracted rays.
    secondary: Color,
    /// Its transmittance toward each light: `EpiScratch::light[light..]`.
    light: u32,
    /// The face its view saw: the front (against the geometric normal).
    front: bool,
}

/// Where a sample lies on its primitive's section: the primitive (an index
/// into the gathered ones), the position along it, and the plane point.
#[derive(Clone, Copy, Debug)]
struct OnSection {
    local: u32,
    param: f64,
    a: f64,
    b: f64,
    front: bool,
}

/// A sample to shade exactly; `keep`: where it lies, if its surface keeps
/// shade points.
#[derive(Clone, Copy, Debug)]
struct Donation {
    sample: usize,
    keep: Option<OnSection>,
}

/// A mirror, glass or highlight sample (view position `position`), shaded
/// once every view's are known, next to the samples of other views that see
/// its surface near it: by its primitive and place on the section.
#[derive(Clone, Copy, Debug)]
struct Deferred {
    local: u32,
    param: f64,
    position: u32,
    sample: u32,
}

impl Deferred {
    /// By primitive, then place on its section: the views' samples of one
    /// point of a surface next to each other.
    fn order(x: &Deferred, y: &Deferred) -> std::cmp::Ordering {
        (x.local.cmp(&y.local))
            .then(x.param.total_cmp(&y.param))
            .then(x.position.cmp(&y.position))
            .then(x.sample.cmp(&y.sample))
    }
}

/// A sample that takes its light from shade point `from`, but for the
/// lights in `trace` (bit `i`: light `i`), whose shadow rays it traces, and
/// its secondary colour between `from` and `to` at `w`. One that traces
/// some becomes a shade point, at `on`: it lies next to a shadow edge, where
/// the views after it need shade points close together.
#[derive(Clone, Copy, Debug)]
struct Taking {
    sample: usize,
    from: ShadePoint,
    to: ShadePoint,
    w: f32,
    trace: u64,
    on: OnSection,
}

/// One thread's scratch space, reused from row to row.
#[derive(Default)]
pub(in crate::render) struct EpiScratch {
    /// The row's primitives, in the order the descent met them.
    prims: Vec<u32>,
    /// A bit per primitive of the scene: taken by the row being gathered
    /// (all clear between rows).
    taken: Vec<u64>,
    sections: Vec<Section>,
    /// Per position, per sample: the nearest hit (index into `prims`,
    /// `u32::MAX` for none).
    best: Vec<(SurfaceHit, u32)>,
    /// Per camera column the row's views look along (the views' columns
    /// are one set shifted by whole pixels: view `p`'s sample `i` looks
    /// along column `i + EpipolarPass::first[p]`): the ray's direction, its
    /// length per unit of `b`, and its slope `x` (a point at `b` on it has
    /// `a = offset + x·b`).
    dirs: Vec<Vec3>,
    lens: Vec<f64>,
    slopes: Vec<f64>,
    /// The sections by their nearest `b`.
    near: Vec<(f64, u32)>,
    /// Per gathered primitive: its shade points by `param`.
    points: Vec<Vec<ShadePoint>>,
    /// The shade points' transmittances toward each light.
    light: Vec<f32>,
    /// A view's samples shaded exactly, and those that take a light.
    donations: Vec<Donation>,
    takings: Vec<Taking>,
    /// The row's mirror, glass and highlight samples, every view's.
    deferred: Vec<Deferred>,
    /// Primitives whose shade points came out of order since they were last
    /// put in order, each with the length of its list still in order.
    touched: Vec<(u32, u32)>,
    /// The points that came out of order, being put back.
    unsorted: Vec<ShadePoint>,
    /// Shade points kept since they were last put in order.
    kept: u64,
    donors: Donors,
    through: Vec<f32>,
}

impl<'a> EpipolarPass<'a> {
    /// The pass for `rig`, or `None` where it does not apply (one view, a
    /// cut of the object tree, materials whose alpha matters, instances).
    pub(in crate::render) fn new(
        world: &'a World,
        camera: &'a Camera,
        rig: &Rig,
        tolerance: f32,
    ) -> Option<EpipolarPass<'a>> {
        let n = rig.views.len();
        if n < 2 || world.far.is_some() || world.has_alpha || world.instances.is_some() {
            return None;
        }
        let order = rig.views_by_offset();
        let (margin, reach) = rig_extent(world, camera, &order);
        let shifts = order
            .iter()
            .fold((i32::MAX, i32::MIN), |(l, h), o| (l.min(o.2), h.max(o.2)));
        let first = order.iter().map(|o| (o.2 - shifts.0) as usize).collect();
        let tol = tolerance;
        Some(EpipolarPass {
            world,
            camera,
            visit: visit_order(n),
            shifts,
            first,
            order,
            tolerance: tol,
            plain: plain_materials(world, tol),
            curvature: (0..world.scene.shapes.len())
                .map(|p| flat_curvature(world, p))
                .collect(),
            margin,
            beyond: reach * 2.0,
        })
    }

    /// Every view's colours through the samples of `row` into `out` (rig
    /// order), `workers[v]` tracing view `v` alone.
    pub(in crate::render) fn trace_row(
        &self,
        workers: &mut [(usize, Box<dyn RowWorker + '_>)],
        tracer: &mut Tracer,
        row: &SampleRow,
        s: &mut EpiScratch,
        out: &mut [RowColors],
    ) {
        let n = row.len();
        let contiguous = n > 0 && (row.pixels[n - 1] - row.pixels[0]) as usize + 1 == n;
        if !matches!(row.pattern, Pattern::Fixed { .. }) || !contiguous {
            tracer.counts.fast.epipolar.rows_exact += 1;
            return trace_all(workers, tracer, row, out);
        }
        let plane = Plane::of_row(
            self.camera,
            row,
            self.order.iter().map(|o| o.2),
            self.margin,
        );
        if !self.gather(tracer, row, &plane, s) {
            tracer.counts.fast.epipolar.rows_exact += 1;
            return trace_all(workers, tracer, row, out);
        }
        tracer.counts.fast.epipolar.rows += 1;
        self.visibility(tracer, row, &plane, s);
        s.points.iter_mut().for_each(Vec::clear);
        s.points.resize_with(s.prims.len(), Vec::new);
        s.light.clear();
        s.deferred.clear();
        for &p in &self.visit {
            self.shade_view(tracer, row, &plane, p, s, out);
        }
        self.shade_deferred(tracer, n, s, out);
    }

    /// The row's mirror, glass and highlight samples of every view, shaded
    /// exactly, eight to a packet, ordered by primitive and place on it: the
    /// views that see one point of a mirror send reflected and shadow rays
    /// nearly alike, which go down the hierarchy together (eight neighbours
    /// of one view on a curved mirror reflect apart). Each lane's colour is
    /// what it gets alone, so the order changes no pixel.
    fn shade_deferred(
        &self,
        tracer: &mut Tracer,
        n: usize,
        s: &mut EpiScratch,
        out: &mut [RowColors],
    ) {
        s.deferred.sort_unstable_by(Deferred::order);
        for lanes in s.deferred.chunks(EYE_PACKET) {
            let mut packet = Packet {
                origins: [Vec3::ZERO; EYE_PACKET],
                dirs: [Vec3::Z; EYE_PACKET],
                t_min: self.camera.hither,
                t_max: [f32::INFINITY; EYE_PACKET],
                mask: (1u32 << lanes.len()) - 1,
            };
            let mut hits = PacketHits::<EYE_PACKET>::none();
            for (l, d) in lanes.iter().enumerate() {
                let p = d.position as usize;
                let k = p * n + d.sample as usize;
                let (hit, local) = s.best[k];
                packet.origins[l] = self.camera.eye_at(self.order[p].1);
                packet.dirs[l] = s.dirs[self.first[p] + d.sample as usize];
                hits.prim[l] = s.prims[local as usize];
                hits.hit[l] = hit;
            }
            let groups = std::array::from_fn(|l| l as u8);
            let colors = tracer.shade_eye_groups(&packet, &hits, SecondaryRays::Own, groups);
            for (l, d) in lanes.iter().enumerate() {
                out[self.order[d.position as usize].0][d.sample as usize] = colors[l];
            }
        }
    }

    /// The primitives that may meet the row's rays (each once), with their
    /// sections; `false` where the descent could not visit them all.
    fn gather(
        &self,
        tracer: &mut Tracer,
        row: &SampleRow,
        plane: &Plane,
        s: &mut EpiScratch,
    ) -> bool {
        let n = row.len();
        let (first, last) = (self.order[0], self.order[self.order.len() - 1]);
        let (lo_shift, hi_shift) = self.shifts;
        let (c_lo, y) = row.camera_point(0, lo_shift);
        let (c_hi, _) = row.camera_point(n - 1, hi_shift);
        let (left, right) = (self.camera.eye_at(first.1), self.camera.eye_at(last.1));
        let corners = [
            left,
            right,
            right + self.camera.direction(c_hi, y) * self.beyond,
            left + self.camera.direction(c_lo, y) * self.beyond,
        ];
        let Some(region) = Region::quad(corners, self.margin) else {
            return false;
        };
        s.prims.clear();
        // A primitive filed under several boxes is met once per leaf: a bit
        // per primitive keeps it once (no sort), cleared again after.
        s.taken
            .resize(self.world.scene.shapes.len().div_ceil(64), 0);
        let (prims, taken) = (&mut s.prims, &mut s.taken);
        let whole = self.world.bvh.visit_region(&region, |p| {
            let (word, bit) = (p as usize / 64, 1u64 << (p % 64));
            if let Some(w) = taken.get_mut(word).filter(|w| **w & bit == 0) {
                *w |= bit;
                prims.push(p);
            }
            true
        });
        for &p in &s.prims {
            s.taken[p as usize / 64] = 0;
        }
        if !whole {
            return false;
        }
        let shapes = &self.world.scene.shapes;
        // How near the plane a vertex or box corner counts as on it.
        let tol = self.margin * 16.0;
        s.sections.clear();
        s.sections.extend(
            s.prims
                .iter()
                .map(|&p| plane.section(&shapes[p as usize], tol)),
        );
        tracer.counts.fast.epipolar.primitives += s.prims.len() as u64;
        true
    }

    /// Every view's nearest hit through every sample of the row.
    fn visibility(&self, tracer: &mut Tracer, row: &SampleRow, plane: &Plane, s: &mut EpiScratch) {
        let n = row.len();
        let views = self.order.len();
        // Each camera column's ray direction, eight at a time (bit for bit
        // `direction`'s), and its length per unit of `b`: a point at plane
        // coordinate `b` lies at `t = b·L` along the ray of direction
        // `(R·x + W)/L`. The row's samples are contiguous pixels of one
        // pattern, so view `p`'s sample `i` looks along the column of sample
        // 0 shifted by `i + shift`: one set of columns serves every view
        // (once, not once per view).
        let (lo_shift, hi_shift) = self.shifts;
        let columns = n + (hi_shift - lo_shift) as usize;
        s.dirs.clear();
        s.lens.clear();
        s.slopes.clear();
        for first in (0..columns).step_by(8) {
            let point =
                |l: usize| row.camera_point(0, lo_shift + (first + l).min(columns - 1) as i32);
            let cols: [f32; 8] = std::array::from_fn(|l| point(l).0);
            let rows = std::array::from_fn(|l| point(l).1);
            let dirs = self.camera.directions8(cols, rows);
            let count = (columns - first).min(8);
            s.dirs.extend_from_slice(&dirs[..count]);
            for &c in &cols[..count] {
                let x = (c as f64 - plane.cx) * plane.ps;
                s.slopes.push(x);
                s.lens.push((x * x + plane.ww).sqrt());
            }
        }
        s.best.clear();
        s.best
            .resize(views * n, (PacketHits::<1>::none().hit[0], u32::MAX));
        // Nearest first, so that a primitive wholly behind a sample's hit
        // is skipped without its test.
        s.near.clear();
        s.near.extend(
            s.sections
                .iter()
                .enumerate()
                .filter_map(|(l, sec)| sec.nearest_b().map(|b| (b, l as u32))),
        );
        s.near
            .sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        let hither = self.camera.hither;
        let shapes = &self.world.scene.shapes;
        let mut tests = 0u64;
        for &(near, local) in &s.near {
            let section = &s.sections[local as usize];
            let prim = s.prims[local as usize];
            let shape = &shapes[prim as usize];
            // Below the section's nearest `b` by a margin for the rays'
            // rounding off the plane.
            let near = near * (1.0 - NEAR_SLACK);
            let reach = plane.reach(section);
            for (p, &(_, offset, shift)) in self.order.iter().enumerate() {
                let (lo, hi) = reach.samples(offset as f64, shift, n);
                let origin = self.camera.eye_at(offset);
                let (base, column) = (p * n, self.first[p]);
                for i in lo..hi {
                    let (k, c) = (base + i, column + i);
                    let (best, best_local) = s.best[k];
                    if near * s.lens[c] > best.t as f64 {
                        continue;
                    }
                    tests += 1;
                    let ray = Ray::new(origin, s.dirs[c]);
                    // A tie keeps the lower primitive index, as the hierarchy
                    // does.
                    if let Some(h) = shape.intersect(&ray, hither, best.t.next_up()) {
                        let lower = || s.prims.get(best_local as usize).is_none_or(|&q| prim < q);
                        if h.t < best.t || lower() {
                            s.best[k] = (h, local);
                        }
                    }
                }
            }
        }
        tracer.counts.fast.epipolar.tests += tests;
    }

    /// View at position `p`: its samples' colours taken from shade points
    /// where they may be, their light taken where it may be, the rest shaded
    /// exactly and kept as shade points for the views after it.
    fn shade_view(
        &self,
        tracer: &mut Tracer,
        row: &SampleRow,
        plane: &Plane,
        p: usize,
        s: &mut EpiScratch,
        out: &mut [RowColors],
    ) {
        let n = row.len();
        let (v, offset, shift) = self.order[p];
        let origin = self.camera.eye_at(offset);
        let offset = offset as f64;
        let lights = self.world.scene.lights.len();
        let mut stats = EpipolarCounts::default();
        s.donations.clear();
        s.takings.clear();
        let mut cursor: Option<(u32, usize)> = None;
        let column = self.first[p];
        let colors = &mut out[v][..n];
        // A plain background's colour, out of the loop (most samples of a
        // sparse scene's views hit nothing).
        let scene = &self.world.scene;
        let plain = scene.environment.is_none().then_some(scene.background);
        #[allow(clippy::needless_range_loop)] // `i` also indexes `best` and `dirs`
        for i in 0..n {
            let (k, c) = (p * n + i, column + i);
            let (hit, local) = s.best[k];
            if local == u32::MAX {
                colors[i] = plain.unwrap_or_else(|| scene.background_toward(s.dirs[c]));
                stats.misses += 1;
                continue;
            }
            let prim = s.prims[local as usize];
            let m = self.world.scene.shape_material[prim as usize] as usize;
            if !self.plain[m] {
                // Shaded after every view, with the other views' samples of
                // the same surface (`shade_deferred`).
                stats.refused_material += 1;
                stats.traced += 1;
                let b = hit.t as f64 / s.lens[c];
                let param = s.sections[local as usize].param(offset + s.slopes[c] * b, b);
                s.deferred.push(Deferred {
                    local,
                    param: param.unwrap_or(0.0),
                    position: p as u32,
                    sample: i as u32,
                });
                continue;
            }
            // The hit's plane coordinates from its distance: `t = b·L`.
            let b = hit.t as f64 / s.lens[c];
            let a = offset + s.slopes[c] * b;
            let section = &s.sections[local as usize];
            let Some(param) = section.param(a, b) else {
                stats.refused_shape += 1;
                s.donations.push(Donation {
                    sample: i,
                    keep: None,
                });
                continue;
            };
            // The face the view sees: views either side of a surface's plane
            // (a triangle nearly edge-on) see its two faces, lit apart.
            let d = s.dirs[c];
            let shape = &self.world.scene.shapes[prim as usize];
            let front = shape.met_from_front(origin + d * hit.t, d);
            let on = OnSection {
                local,
                param,
                a,
                b,
                front,
            };
            let keep = Some(on);
            let points = &s.points[local as usize];
            // A view's neighbouring samples on one primitive move along its
            // section: start from the last sample's place, else search.
            let at = match cursor {
                Some((l, at)) if l == local => seek(points, at, param),
                _ => points.partition_point(|q| q.param < param),
            };
            cursor = Some((local, at));
            if at == 0 || at == points.len() {
                stats.no_bracket += 1;
                s.donations.push(Donation { sample: i, keep });
                continue;
            }
            let (e0, e1) = (points[at - 1], points[at]);
            if e0.front != front || e1.front != front {
                stats.refused_face += 1;
                s.donations.push(Donation { sample: i, keep });
                continue;
            }
            // The two must lie within WIDEST of this view's pixels, on either
            // side of the sample, at its depth (not one on the surface's far
            // side, seen by another view).
            let column = |q: &ShadePoint| plane.sample_of_scaled(q.a, q.inv_bps, offset, shift);
            let (c0, c1) = (column(&e0), column(&e1));
            let w = if e1.param > e0.param {
                (param - e0.param) / (e1.param - e0.param)
            } else {
                0.0
            };
            let here = i as f64;
            let between = here >= c0.min(c1) - SLACK && here <= c0.max(c1) + SLACK;
            let depth = e0.b + (e1.b - e0.b) * w;
            if (c1 - c0).abs() > WIDEST || !between || (depth - b).abs() > DEPTH_STEP * b {
                stats.refused_wide += 1;
                s.donations.push(Donation { sample: i, keep });
                continue;
            }
            // The colour must be close between the two and straight through
            // them: a peak of the diffuse term between (a sphere's brightest
            // point) bends the line at their neighbours, which must be there.
            // On a flat triangle the bend is bounded without them (the
            // squared chord between the two: `R` is a unit vector normal to
            // `W`).
            let half = self.tolerance * 0.5;
            let flat = self.curvature[prim as usize];
            if largest(e1.color - e0.color) <= self.tolerance
                && (flat.is_finite()
                    && flat * ((e1.a - e0.a).powi(2) + plane.ww * (e1.b - e0.b).powi(2))
                        <= f64::from(half)
                    || at >= 2
                        && at + 1 < points.len()
                        && points[at - 2].front == front
                        && points[at + 1].front == front
                        && bend(&points[at - 2], &e0, &e1) <= half
                        && bend(&e0, &e1, &points[at + 1]) <= half)
            {
                colors[i] = e0.color + (e1.color - e0.color) * w as f32;
                stats.taken += 1;
                continue;
            }
            // Else its own shading, with the light the two saw, toward each
            // light that they and their neighbours saw alike: no shadow edge
            // of it passes near. (With the two alone, slivers of the thin
            // branches' shadows between them doubled the pixels off by more
            // than 0.05 on SPD tree.) Toward the others it traces its own
            // shadow rays; where they are all of them, it is shaded exactly.
            let light = |q: &ShadePoint, i: usize| s.light[q.light as usize + i];
            let outer = [
                Some(&e1),
                at.checked_sub(2).map(|j| &points[j]),
                points.get(at + 1),
            ];
            let trace = (0..lights.min(64)).fold(0u64, |trace, i| {
                let alike = outer
                    .iter()
                    .all(|q| q.is_some_and(|q| q.front == front && light(q, i) == light(&e0, i)));
                trace | u64::from(!alike) << i
            });
            if lights <= 64 && trace.count_ones() < lights as u32 {
                if trace == 0 {
                    stats.light_taken += 1;
                } else {
                    stats.light_partly_taken += 1;
                    stats.lights_traced += u64::from(trace.count_ones());
                }
                s.takings.push(Taking {
                    sample: i,
                    from: e0,
                    to: e1,
                    w: w as f32,
                    trace,
                    on,
                });
                continue;
            }
            stats.refused_colour += 1;
            s.donations.push(Donation { sample: i, keep });
        }
        stats.traced += s.donations.len() as u64;
        // The view's hits, found in the plane (`--stats` `hits_per_view`).
        if let Some(h) = tracer.counts.per_view_hits.0.get_mut(v) {
            *h += n as u64 - stats.misses;
        }
        tracer.counts.fast.epipolar += stats;
        self.shade_donations(tracer, p, n, origin, s, &mut out[v]);
        self.shade_takings(tracer, p, n, origin, s, &mut out[v]);
    }

    /// A packet of eight of view `p`'s samples (`sample(l)` for lane `l`,
    /// `count` lanes), with their known hits.
    fn packet(
        &self,
        s: &EpiScratch,
        p: usize,
        n: usize,
        origin: Vec3,
        count: usize,
        sample: impl Fn(usize) -> usize,
    ) -> (Packet<EYE_PACKET>, PacketHits<EYE_PACKET>) {
        let mut packet = Packet {
            origins: [origin; EYE_PACKET],
            dirs: [Vec3::Z; EYE_PACKET],
            t_min: self.camera.hither,
            t_max: [f32::INFINITY; EYE_PACKET],
            mask: (1u32 << count) - 1,
        };
        let mut hits = PacketHits::<EYE_PACKET>::none();
        for l in 0..count {
            let k = p * n + sample(l);
            let (hit, local) = s.best[k];
            packet.dirs[l] = s.dirs[self.first[p] + sample(l)];
            hits.prim[l] = s.prims[local as usize];
            hits.hit[l] = hit;
        }
        (packet, hits)
    }

    /// The view's samples to shade exactly, eight to a packet (each lane's
    /// colour is what it gets alone); those on surfaces that keep shade
    /// points become shade points, with their light and secondary colour.
    fn shade_donations(
        &self,
        tracer: &mut Tracer,
        p: usize,
        n: usize,
        origin: Vec3,
        s: &mut EpiScratch,
        out: &mut RowColors,
    ) {
        let lights = self.world.scene.lights.len();
        s.touched.clear();
        for first in (0..s.donations.len()).step_by(EYE_PACKET) {
            let count = (s.donations.len() - first).min(EYE_PACKET);
            let (packet, hits) =
                self.packet(s, p, n, origin, count, |l| s.donations[first + l].sample);
            tracer.shade_donors(&packet, &hits, SecondaryRays::Own, &mut s.donors);
            for l in 0..count {
                let Donation { sample, keep } = s.donations[first + l];
                out[sample] = s.donors.colors[l];
                if let Some(on) = keep {
                    let light = s.light.len() as u32;
                    s.light.extend_from_slice(s.donors.through(l, lights));
                    self.keep(s, on, s.donors.colors[l], s.donors.secondary[l], light);
                }
            }
        }
        self.sort_points(tracer, s);
    }

    /// Keeps a shade point at `on` of `color`, `secondary` colour and
    /// transmittances at `light` in `s.light`.
    fn keep(&self, s: &mut EpiScratch, on: OnSection, color: Color, secondary: Color, light: u32) {
        let OnSection {
            local,
            param,
            a,
            b,
            front,
        } = on;
        let point = ShadePoint {
            param,
            a,
            b,
            inv_bps: 1.0 / (b * self.camera.pixel_size as f64),
            color,
            secondary,
            light,
            front,
        };
        let points = &mut s.points[local as usize];
        if points.last().is_some_and(|q| q.param > param) {
            s.touched.push((local, points.len() as u32));
        }
        points.push(point);
        s.kept += 1;
    }

    /// Puts the shade points kept since the last call in order (`merge_in`).
    fn sort_points(&self, tracer: &mut Tracer, s: &mut EpiScratch) {
        s.touched.sort_unstable();
        s.touched.dedup_by_key(|t| t.0);
        for &(local, sorted) in &s.touched {
            merge_in(
                &mut s.points[local as usize],
                sorted as usize,
                &mut s.unsorted,
            );
        }
        s.touched.clear();
        tracer.counts.fast.epipolar.shade_points += s.kept;
        s.kept = 0;
    }

    /// The view's samples that take their light from a shade point, eight
    /// to a packet: their own ambient, diffuse and highlight terms, no ray.
    fn shade_takings(
        &self,
        tracer: &mut Tracer,
        p: usize,
        n: usize,
        origin: Vec3,
        s: &mut EpiScratch,
        out: &mut RowColors,
    ) {
        let lights = self.world.scene.lights.len();
        for first in (0..s.takings.len()).step_by(EYE_PACKET) {
            let count = (s.takings.len() - first).min(EYE_PACKET);
            let (packet, hits) =
                self.packet(s, p, n, origin, count, |l| s.takings[first + l].sample);
            s.through.clear();
            s.through.resize(lights * EYE_PACKET, 0.0);
            let mut secondary = [Color::ZERO; EYE_PACKET];
            for (l, secondary) in secondary.iter_mut().enumerate().take(count) {
                let Taking {
                    from, to, w, trace, ..
                } = s.takings[first + l];
                let light = from.light as usize;
                let through = &mut s.through[l * lights..(l + 1) * lights];
                through.copy_from_slice(&s.light[light..light + lights]);
                for (i, t) in through.iter_mut().enumerate() {
                    if trace & (1 << i) != 0 {
                        *t = TRACE_LIGHT;
                    }
                }
                *secondary = from.secondary + (to.secondary - from.secondary) * w;
            }
            let colors = tracer.shade_from_donors(&packet, &hits, &mut s.through, &secondary);
            for l in 0..count {
                let taking = s.takings[first + l];
                out[taking.sample] = colors[l];
                if taking.trace != 0 {
                    let light = s.light.len() as u32;
                    s.light
                        .extend_from_slice(&s.through[l * lights..(l + 1) * lights]);
                    self.keep(s, taking.on, colors[l], secondary[l], light);
                }
            }
        }
        self.sort_points(tracer, s);
    }
}

/// For the row passes over the views by offset `order`: the margin of the
/// rows' rounding (a millionth of the larger of the scene's and the eyes'
/// coordinates), and how far a ray must reach to cross the scene from any
/// eye (the farthest eye's distance to the scene's centre, plus its
/// diagonal).
fn rig_extent(world: &World, camera: &Camera, order: &[(usize, f32, i32)]) -> (f64, f32) {
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

/// `κ` such that between two points `h` apart on primitive `prim`, lit
/// alike, its colour lies within `κ·h²` of the line between theirs
/// (each channel); infinite where no such bound is known. A flat
/// triangle of a material without maps has one normal `N` and one
/// ambient term, so its colour changes only with each light's diffuse
/// term `kd·c·l·(N·L̂)`. Along the surface, `N·L̂` has a second
/// derivative of at most `3/ρ²` (`ρ` the light's distance; a
/// directional light's is constant), so a chord `h` long is off by at
/// most `h²/8` of that. NFF's point lights keep their intensity with
/// distance; other falloffs and spot cones are not bounded here.
fn flat_curvature(world: &World, prim: usize) -> f64 {
    let scene = &world.scene;
    let Shape::Triangle(tri) = &scene.shapes[prim] else {
        return f64::INFINITY;
    };
    let m = &scene.materials[scene.shape_material[prim] as usize];
    let mapped = m.texture.is_some()
        || m.normal_map.is_some()
        || m.emission_texture.is_some()
        || m.occlusion_texture.is_some();
    if !matches!(tri.normals, TriangleNormals::Flat) || mapped {
        return f64::INFINITY;
    }
    let corners = [tri.v0, tri.v0 + tri.e1, tri.v0 + tri.e2].map(|v| v.as_dvec3());
    let centre = (corners[0] + corners[1] + corners[2]) / 3.0;
    let reach = corners
        .iter()
        .map(|&c| c.distance(centre))
        .fold(0.0, f64::max);
    let diffuse = f64::from(m.kd * m.color.max_element());
    scene.lights.iter().fold(0.0, |sum, light| {
        let l = f64::from(light.color.unwrap_or(Color::ONE).max_element());
        match light.kind {
            LightKind::Directional { .. } => sum,
            LightKind::Point {
                position,
                inverse_square: false,
                range: None,
            } => {
                let rho = position.as_dvec3().distance(centre) - reach;
                if rho > 0.0 {
                    sum + 3.0 * diffuse * l / (8.0 * rho * rho)
                } else {
                    f64::INFINITY
                }
            }
            _ => f64::INFINITY,
        }
    })
}

/// Per material: whether its shading is independent of the view within
/// `tol` (mirror, highlight and transmission weights at most `tol`).
fn plain_materials(world: &World, tol: f32) -> Vec<bool> {
    world
        .scene
        .materials
        .iter()
        .map(|m| m.ks.max(m.mirror) <= tol && m.t <= tol)
        .collect()
}

/// The largest channel's magnitude.
fn largest(c: Color) -> f32 {
    c.x.abs().max(c.y.abs()).max(c.z.abs())
}

/// Puts `points` in order by `param` where its first `sorted` are: the
/// others are sorted and merged in, as a stable sort of the whole would
/// place them (on a tie the earlier point first), at the cost of the few
/// new points; `scratch` holds them meanwhile.
fn merge_in(points: &mut [ShadePoint], sorted: usize, scratch: &mut Vec<ShadePoint>) {
    scratch.clear();
    scratch.extend_from_slice(&points[sorted..]);
    scratch.sort_by(|a, b| a.param.total_cmp(&b.param));
    // From the back: the greater of the two ends goes last, the new point
    // on a tie.
    let (mut i, mut j) = (sorted, scratch.len());
    while j > 0 {
        let new = scratch[j - 1];
        if i > 0 && points[i - 1].param.total_cmp(&new.param).is_gt() {
            points[i + j - 1] = points[i - 1];
            i -= 1;
        } else {
            points[i + j - 1] = new;
            j -= 1;
        }
    }
}

/// How far `m`'s colour lies off the line between its neighbours' (along
/// the section), largest channel.
fn bend(before: &ShadePoint, m: &ShadePoint, after: &ShadePoint) -> f32 {
    let span = after.param - before.param;
    let f = if span > 0.0 {
        ((m.param - before.param) / span) as f32
    } else {
        0.5
    };
    largest(m.color - (before.color + (after.color - before.color) * f))
}

/// The first of `points` (ascending) at or past `param`, searched from `at`:
/// a few steps either way, else by bisection.
fn seek(points: &[ShadePoint], at: usize, param: f64) -> usize {
    let mut at = at.min(points.len());
    for _ in 0..4 {
        if at > 0 && points[at - 1].param >= param {
            at -= 1;
        } else if at < points.len() && points[at].param < param {
            at += 1;
        } else {
            return at;
        }
    }
    points.partition_point(|q| q.param < param)
}

/// Positions `0..n` in the order their rows are shaded: the middle, the two
/// ends, then halfway between shaded ones, level by level.
fn visit_order(n: usize) -> Vec<usize> {
    let mut order = Vec::with_capacity(n);
    let mut seen = vec![false; n];
    let mut push = |p: usize, order: &mut Vec<usize>| {
        if !seen[p] {
            seen[p] = true;
            order.push(p);
        }
    };
    if n == 0 {
        return order;
    }
    push(n / 2, &mut order);
    push(0, &mut order);
    push(n - 1, &mut order);
    while order.len() < n {
        let mut done: Vec<usize> = order.clone();
        done.sort_unstable();
        for w in done.windows(2) {
            if w[1] - w[0] > 1 {
                push((w[0] + w[1]) / 2, &mut order);
            }
        }
    }
    order
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::{Packet, PacketHits};
    use crate::loaders::nff::parse_nff;
    use crate::loaders::LoadOptions;
    use crate::render::TraceSettings;

    /// The world of NFF `text`, called `name` in its errors.
    fn world_of(name: &str, text: &str) -> World {
        let path = std::path::Path::new(name);
        World::new(parse_nff(text, path, &LoadOptions::default()).expect("test scene"))
    }

    /// Every sample's nearest hit from the row's plane is the hierarchy's
    /// (the same primitive, the same distance and surface coordinates bit
    /// for bit, or both none), on the bundled scenes (triangles, spheres,
    /// cones, a floor reaching behind the camera) and on primitives given
    /// twice (ties), 9 converged views: a view's samples shifted by whole
    /// pixels, offsets both sides of the centre. Each row gathers each
    /// primitive once, a rod filed in pieces under several leaves too.
    #[test]
    fn every_views_hits_are_the_hierarchys() {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/");
        let bundled = |name: &str| std::fs::read_to_string(format!("{dir}{name}")).expect(name);
        // Ties: a floor and a ball each given twice, in other colours; the
        // lower index must win where both are hit at the same distance.
        let twice = "b 0.1 0.1 0.2\nv\nfrom 0 -6 5\nat 0 0 0\nup 0 0 1\nangle 45\nhither 0.01\n\
            resolution 40 30\nl 3 2 10\n\
            f 0.8 0.8 0.7 0.9 0 0 0 1\np 3\n-100 -100 0\n100 -100 0\n0 100 0\ns 0 0 1 0.8\n\
            f 0.2 0.8 0.7 0.9 0 0 0 1\np 3\n-100 -100 0\n100 -100 0\n0 100 0\ns 0 0 1 0.8\n";
        // A long tilted rod filed in pieces among balls on a floor: the
        // pieces fall in several leaves, where the descent meets the rod
        // more than once.
        let balls: String = (0..40)
            .map(|i| format!("s {} {} 0.3 0.2\n", i % 8 - 4, i / 8 - 2))
            .collect();
        let rod = format!(
            "b 0.1 0.1 0.2\nv\nfrom 0 -9 4\nat 0 0 0\nup 0 0 1\nangle 45\nhither 0.01\n\
             resolution 40 30\nl 3 2 10\nf 0.8 0.5 0.3 0.9 0 0 0 1\n\
             c\n-5 -3 0.2 0.1\n5 3 1.5 0.1\n{balls}p 4\n-20 -20 0\n20 -20 0\n20 20 0\n-20 20 0\n"
        );
        for (name, text, width, height, interaxial) in [
            ("rod", rod, 48, 36, 0.1),
            ("shelf.nff", bundled("shelf.nff"), 80, 60, 0.05),
            ("example.nff", bundled("example.nff"), 64, 48, 0.2),
            ("deep.nff", bundled("deep.nff"), 96, 54, 0.5),
            ("twice", twice.to_string(), 40, 30, 0.1),
        ] {
            let world = world_of(name, &text);
            let camera = Camera::new(&world.scene.viewpoint, width, height);
            let rig = Rig::multi_view(&camera, 9, interaxial, Some(8.0)).expect("rig");
            assert!(rig.views.iter().any(|v| v.shift != 0), "{name}: converged");
            let pass = EpipolarPass::new(&world, &camera, &rig, 0.01).expect("pass");
            let mut tracer = Tracer::new(&world, TraceSettings::default());
            let mut s = EpiScratch::default();
            let (mut hits, mut samples) = (0, 0);
            for y in 0..height {
                let row = SampleRow::centres(width as usize, y);
                let shifts = pass.order.iter().map(|o| o.2);
                let plane = Plane::of_row(&camera, &row, shifts, pass.margin);
                assert!(
                    pass.gather(&mut tracer, &row, &plane, &mut s),
                    "{name} row {y}"
                );
                // Each primitive once, though filed under several leaves.
                let mut once = s.prims.clone();
                once.sort_unstable();
                once.dedup();
                assert_eq!(once.len(), s.prims.len(), "{name} row {y}");
                pass.visibility(&mut tracer, &row, &plane, &mut s);
                let n = row.len();
                for (p, &(_, offset, shift)) in pass.order.iter().enumerate() {
                    for i in 0..n {
                        let k = p * n + i;
                        // The direction of the sample's own ray, not the pass's.
                        let (x, y) = row.camera_point(i, shift);
                        let packet = Packet::<1> {
                            origins: [camera.eye_at(offset)],
                            dirs: [camera.direction(x, y)],
                            t_min: camera.hither,
                            t_max: [f32::INFINITY],
                            mask: 1,
                        };
                        let (prim, hit) = tracer.eye_hit(&packet, 0);
                        let (mine_hit, local) = s.best[k];
                        let mine = if local == u32::MAX {
                            PacketHits::<1>::NO_HIT
                        } else {
                            s.prims[local as usize]
                        };
                        assert_eq!(mine, prim, "{name}: view {p}, row {y}, sample {i}");
                        if prim != PacketHits::<1>::NO_HIT {
                            let bits = |h: SurfaceHit| [h.t, h.u, h.v].map(f32::to_bits);
                            assert_eq!(
                                bits(mine_hit),
                                bits(hit),
                                "{name}: view {p}, row {y}, sample {i}"
                            );
                            hits += 1;
                        }
                        samples += 1;
                    }
                }
            }
            // Most rays hit something, and on the bundled scenes not all:
            // both kinds were compared (the twice-given floor fills the view).
            assert!(
                hits * 4 > samples && (hits < samples || name == "twice"),
                "{name}: {hits} of {samples}"
            );
        }
    }

    /// Three views' samples along one mirror primitive's section (each view
    /// sees the surface shifted by a sample): sorted, the views' samples of
    /// one place lie next to each other, so that a packet holds one point
    /// seen by several views; another primitive's come apart.
    #[test]
    fn deferred_samples_of_one_place_go_together() {
        let mut deferred: Vec<Deferred> = (0..3u32)
            .flat_map(|position| {
                (0..4u32).map(move |i| Deferred {
                    local: 7,
                    param: 0.1 * f64::from(i + position),
                    position,
                    sample: i + position,
                })
            })
            .chain([Deferred {
                local: 2,
                param: 0.25,
                position: 1,
                sample: 0,
            }])
            .collect();
        deferred.sort_unstable_by(Deferred::order);
        assert_eq!(deferred[0].local, 2);
        let places: Vec<f64> = deferred[1..].iter().map(|d| d.param).collect();
        assert!(places.windows(2).all(|w| w[0] <= w[1]), "{places:?}");
        // The place 0.2 is seen by all three views, in one run.
        let run: Vec<u32> = deferred
            .iter()
            .filter(|d| (d.param - 0.2).abs() < 1e-9)
            .map(|d| d.position)
            .collect();
        assert_eq!(run, [0, 1, 2]);
        let first = deferred.iter().position(|d| (d.param - 0.2).abs() < 1e-9);
        assert!(first.is_some_and(|f| deferred[f..f + 3]
            .iter()
            .all(|d| (d.param - 0.2).abs() < 1e-9)));
    }

    /// A flat triangle's bound: `3·kd·c·l/(8ρ²)`, `ρ` the light's distance
    /// less the triangle's reach from its centre; none (infinite) for a
    /// sphere, a smooth patch, or a light within that reach.
    #[test]
    fn a_flat_triangles_curvature_falls_with_its_lights_distance() {
        let view = "v\nfrom 0 -6 5\nat 0 0 0\nup 0 0 1\nangle 45\nhither 0.01\nresolution 8 6\n";
        let shapes = "f 0.5 0.4 0.2 0.6 0 0 0 1\np 3\n-1 0 0\n2 0 0\n-1 3 0\n\
            s 0 0 1 0.5\npp 3\n-1 0 0 0 0 1\n2 0 0 0 0 1\n-1 3 0 0 0 1\n";
        let curvatures = |light: &str| {
            let world = world_of("t.nff", &format!("{view}{light}{shapes}"));
            let camera = Camera::new(&world.scene.viewpoint, 8, 6);
            let rig = Rig::multi_view(&camera, 3, 0.1, None).expect("rig");
            let pass = EpipolarPass::new(&world, &camera, &rig, 0.01).expect("pass");
            // (flat triangle, sphere, patch), wherever the scene filed them.
            let of = |kind: fn(&Shape) -> bool| {
                let shapes = &world.scene.shapes;
                let p = shapes.iter().position(kind).expect("the shape");
                pass.curvature[p]
            };
            let flat =
                |s: &Shape| matches!(s, Shape::Triangle(t) if t.normals == TriangleNormals::Flat);
            let patch =
                |s: &Shape| matches!(s, Shape::Triangle(t) if t.normals != TriangleNormals::Flat);
            vec![of(flat), of(|s| matches!(s, Shape::Sphere(_))), of(patch)]
        };
        // Centre (0, 1, 0), reach √5; the light 10 above the centre.
        let k = curvatures("l 0 1 10\n");
        let rho = 10.0 - 5f64.sqrt();
        let expected = 3.0 * 0.6 * 0.5 / (8.0 * rho * rho);
        assert!((k[0] - expected).abs() < 1e-6 * expected, "{k:?}");
        assert_eq!(k[1..], [f64::INFINITY; 2], "a sphere and a patch");
        // Four times as far: a sixteenth (less the reach's share).
        let far = curvatures("l 0 1 40\n")[0];
        let rho_far = 40.0 - 5f64.sqrt();
        let expected_far = 3.0 * 0.6 * 0.5 / (8.0 * rho_far * rho_far);
        assert!((far - expected_far).abs() < 1e-6 * expected_far, "{far}");
        // A light within the triangle's reach: no bound.
        assert_eq!(curvatures("l 0 1 1\n")[0], f64::INFINITY);
    }

    /// New shade points merged into a list's ordered part land where a
    /// stable sort of the whole puts them, ties (told apart by `light`)
    /// included.
    #[test]
    fn new_shade_points_merge_as_a_stable_sort_places_them() {
        let mut rng = fastrand::Rng::with_seed(16);
        let mut scratch = Vec::new();
        for _ in 0..2000 {
            let point = |param: f64, light: u32| ShadePoint {
                param,
                a: 0.0,
                b: 1.0,
                inv_bps: 1.0,
                color: Color::ZERO,
                secondary: Color::ZERO,
                light,
                front: true,
            };
            // Params on a coarse grid, so that ties are common.
            let n = rng.usize(0..12);
            let sorted = rng.usize(0..=n);
            let mut points: Vec<ShadePoint> = (0..n as u32)
                .map(|l| point(f64::from(rng.u8(0..6)), l))
                .collect();
            points[..sorted].sort_by(|a, b| a.param.total_cmp(&b.param));
            let mut expected = points.clone();
            expected.sort_by(|a, b| a.param.total_cmp(&b.param));
            merge_in(&mut points, sorted, &mut scratch);
            let key = |p: &[ShadePoint]| p.iter().map(|q| (q.param, q.light)).collect::<Vec<_>>();
            assert_eq!(key(&points), key(&expected), "{sorted} of {n} in order");
        }
    }

    /// The middle view first, then the ends, then halfway between: each
    /// position once.
    #[test]
    fn views_are_visited_middle_first_then_halfway() {
        assert_eq!(visit_order(1), vec![0]);
        assert_eq!(visit_order(3), vec![1, 0, 2]);
        assert_eq!(visit_order(9), vec![4, 0, 8, 2, 6, 1, 3, 5, 7]);
        let mut all = visit_order(48);
        all.sort_unstable();
        assert_eq!(all, (0..48).collect::<Vec<_>>());
    }
}

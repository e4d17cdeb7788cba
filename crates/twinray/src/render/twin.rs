//! The twin-object method (the paper's sections 2–2.2, and its approximations
//! of sections 2.4–2.5 on request), row by row in named stages:
//!
//! The unit of work is a row of samples (`SampleRow`: one sub-pixel position
//! in each pixel of a row, the same in every view).
//!
//! 1. **Eye pass** (`eye_pass`): one packet per sample, lane `v` holding view
//!    `v`'s ray through it (camera column `x + shift_v` plus the sample's offset) — the
//!    paper's one eye ray through the twin objects, returning the nearest hit
//!    of every view.
//! 2. **Grouping** (`grouping::group_row`): each sample of view 0 that hit
//!    something is grouped with the sample of every other view that sees the
//!    same surface point (its hit projected into that view, rounded to the
//!    nearest sample of the same row: the rig's views differ along rows only).
//! 3. **Shading of groups** (`shade_groups`): a group is shaded in one packet,
//!    with its neighbours in the row up to eight lanes (`packed`: a pair's four
//!    groups). Their shadow rays start from nearly one point toward one light
//!    and their reflected rays from nearly one point, so the packet's lanes
//!    stay together down the hierarchy. Every lane's rays are its own view's
//!    (the grouping only decides which rays share a descent), so the images
//!    equal the independent renders bit for bit.
//! 4. **Sharing** (approximate, only when asked): `--merge-secondary` (section
//!    2.4) inside the tracer; reprojection (section 2.5) here, in `safe` mode
//!    (`share_groups`: a group's other samples take view 0's light visibility
//!    and secondary colour when they see the same surface point and its shading
//!    tree is diffuse) or as the paper published it (`reproject_forward`).

mod key_views;
mod packed;
mod shared_shading;

use std::time::Instant;

use super::grouping::{group_row, nearest_sample, Group};
use super::sampler::{RowColors, SampleRow};
use super::strip::StripRow;
use super::tracer::{flat_materials, Donor, Donors, SecondaryRays};
use super::{
    RenderInputs, ReprojectMode, Reprojection, RowWorker, SharedShading, Tracer, ViewBatch,
};
use crate::bvh::{Packet, PacketHits, EYE_PACKET};
use crate::math::{Color, Vec3};
use crate::rig::Camera;
use crate::rig::Rig;
use crate::shapes::SurfaceHit;
use crate::world::World;

const NONE: SurfaceHit = SurfaceHit {
    t: f32::INFINITY,
    u: 0.0,
    v: 0.0,
};

/// A twin batch: some neighbouring views of the rig traced together, one
/// packet lane per view, and what every row of them shares: the scene, the
/// batch's views (a rig of their own: its view 0 leads the groups) and their eyes.
pub(super) struct TwinBatch<'a, const K: usize> {
    world: &'a World,
    camera: &'a Camera,
    rig: Rig,
    views: usize,
    /// Index of the batch's view 0 in the whole rig (for the per-view counts).
    first_view: usize,
    origins: [Vec3; K],
    shifts: Vec<i32>,
    min_shift: i32,
    max_shift: i32,
    reproject: Option<Reprojection>,
    secondary: SecondaryRays,
    /// `--share-shading`: the rig's shading cache, and its tolerance.
    shared_shading: Option<SharedShading>,
    /// Key views' spacing under the shared shading (0: adaptive).
    key_spacing: usize,
    /// Per material, whether every eye hit on it shades to one colour
    /// (`tracer::flat_materials`): the mono row shades one and copies it.
    flat: Vec<bool>,
    /// Lanes per packet of donors, takers and exact groups (`packed`):
    /// `EYE_PACKET`, or 1 in the tests' reference.
    packet_lanes: usize,
}

/// Paper-mode reprojection: the depth of the nearest point of view 0 that
/// landed on a sample, and its colour if its shading tree is diffuse.
type Received = (f32, Option<Color>);

/// A row's eye rays and hits, kept per worker thread from row to row.
#[derive(Default)]
pub(super) struct RowScratch<const K: usize> {
    /// `dirs[v][i]`: view `v`'s eye ray direction through sample `i`.
    dirs: Vec<Vec<Vec3>>,
    /// `hits[v][i]`: the nearest hit of view `v`'s sample `i`.
    hits: Vec<Vec<(u32, SurfaceHit)>>,
    /// `points[v][i]`: where it is (`None` also for hits beyond a cut).
    points: Vec<Vec<Option<Vec3>>>,
    /// With a cut: `far[v][i]`, whether the hit lies beyond it; per camera
    /// column from `first_column`, the rig centre's ray along it, its
    /// nearest hit beyond the cut, and that hit's colour.
    far: Vec<Vec<bool>>,
    first_column: i32,
    far_rays: Vec<Option<(Vec3, u32, SurfaceHit)>>,
    far_colors: Vec<Option<Color>>,
    claimed: Vec<Vec<bool>>,
    groups: Vec<Group<K>>,
    donor: Donor,
    /// Donors and the samples that take their light, eight to a packet
    /// (`packed`).
    donors: packed::DonorPacket,
    takers: packed::TakerPacket,
    kept: KeptShading,
    /// Paper-mode reprojection: per view and sample, the depth of the nearest
    /// point of view 0 projected there so far, and its colour if it gives it.
    received: Vec<Vec<Option<Received>>>,
    /// Key views' chains and secondary colours (`key_views`).
    keys: key_views::KeyScratch,
    /// A batch of one view traced without grouping (`trace_mono_row`): per
    /// sample, its eye ray's direction and nearest hit.
    mono: Vec<(Vec3, u32, SurfaceHit)>,
    /// Per material whose eye hits shade to one colour (`TwinBatch::flat`),
    /// that colour once a hit on it was shaded.
    flat: Vec<Option<Color>>,
}

/// Sizes `v` to `views` rows of `len` copies of `fill`.
fn fit<T: Clone>(v: &mut Vec<Vec<T>>, views: usize, len: usize, fill: T) {
    v.resize_with(views, Vec::new);
    for row in v.iter_mut() {
        row.clear();
        row.resize(len, fill.clone());
    }
}

impl<const K: usize> RowScratch<K> {
    /// Sizes the buffers every mode uses for `views` views of a row of `len`
    /// samples; `far` (a cut) and `received` (the paper's reprojection) are
    /// sized by the stages that use them.
    fn reset(&mut self, views: usize, len: usize) {
        fit(&mut self.dirs, views, len, Vec3::Z);
        fit(&mut self.hits, views, len, (PacketHits::<K>::NO_HIT, NONE));
        fit(&mut self.points, views, len, None);
        fit(&mut self.claimed, views, len, false);
    }
}

impl<'a, const K: usize> TwinBatch<'a, K> {
    /// The twin batch of the views `first_view..first_view + rig.views.len()` of a
    /// job, `rig` holding just them.
    pub(super) fn new(job: &RenderInputs<'a>, rig: Rig, first_view: usize) -> TwinBatch<'a, K> {
        let camera = job.camera;
        let n = rig.views.len();
        let mut origins = [camera.eye; K];
        for (v, view) in rig.views.iter().enumerate() {
            origins[v] = camera.eye_at(view.offset);
        }
        let shifts: Vec<i32> = rig.views.iter().map(|v| v.shift).collect();
        TwinBatch {
            world: job.world,
            camera,
            views: n,
            first_view,
            origins,
            min_shift: shifts.iter().copied().min().unwrap_or(0),
            max_shift: shifts.iter().copied().max().unwrap_or(0),
            shifts,
            rig,
            reproject: job.opts.approx.reproject,
            secondary: if job.opts.approx.merge_secondary {
                SecondaryRays::MergedOnPlanes
            } else {
                SecondaryRays::Own
            },
            shared_shading: job.opts.approx.shared_shading,
            key_spacing: job.opts.approx.key_spacing,
            flat: flat_materials(&job.world.scene, &job.opts.trace),
            packet_lanes: EYE_PACKET,
        }
    }

    fn dir(&self, scratch: &RowScratch<K>, view: usize, sample: usize) -> Vec3 {
        scratch.dirs[view][sample]
    }

    fn has_hit(scratch: &RowScratch<K>, view: usize, sample: usize) -> bool {
        scratch.hits[view][sample].0 != PacketHits::<K>::NO_HIT
    }

    /// `f(i, direction)` for every sample `i` of `row`, in order, of the
    /// view of image shift `shift`: eight at a time (`Camera::directions8`:
    /// one vector square root and division for eight, each direction
    /// `Camera::direction`'s bit for bit).
    #[inline]
    fn row_dirs(&self, row: &SampleRow, shift: i32, mut f: impl FnMut(usize, Vec3)) {
        for first in (0..row.len()).step_by(8) {
            let n = (row.len() - first).min(8);
            let (mut columns, mut ys) = ([0.0f32; 8], [0.0f32; 8]);
            for k in 0..n {
                (columns[k], ys[k]) = row.camera_point(first + k, shift);
            }
            let dirs = self.camera.directions8(columns, ys);
            for (k, &dir) in dirs[..n].iter().enumerate() {
                f(first + k, dir);
            }
        }
    }

    /// Stage 1: the nearest hit of every view's sample of `row`, one descent
    /// for the views' rays through the same sample position. With a cut
    /// (section 2.3), the objects beyond it are tested once per camera column,
    /// by the ray of the rig's centre: every view sees them as the centre does
    /// (their parallax is that of objects at infinity). With `strip`, the
    /// strip pass (`--strip`, never with a cut) has found the hits already.
    fn eye_pass(
        &self,
        tracer: &mut Tracer,
        row: &SampleRow,
        scratch: &mut RowScratch<K>,
        strip: Option<&StripRow>,
    ) {
        let n = self.views;
        scratch.reset(n, row.len());
        for v in 0..n {
            let dirs = &mut scratch.dirs[v];
            self.row_dirs(row, self.shifts[v], |i, dir| dirs[i] = dir);
        }
        let cut = self.world.far.is_some();
        if cut {
            fit(&mut scratch.far, n, row.len(), false);
            scratch.first_column = row.pixels.first().copied().unwrap_or(0) + self.min_shift;
            let last = row.pixels.last().copied().unwrap_or(0) + self.max_shift;
            let columns = (last - scratch.first_column + 1).max(0) as usize;
            scratch.far_rays.clear();
            scratch.far_rays.resize(columns, None);
        }
        if strip.is_none() && !cut && tracer.eye_hit_applies() && n <= EYE_PACKET {
            return self.eye_pass_packed(tracer, row, scratch);
        }
        let all = if n == 32 { u32::MAX } else { (1u32 << n) - 1 };
        let view_of_lane: [usize; K] = std::array::from_fn(|l| self.first_view + l);
        for i in 0..row.len() {
            let mut packet = Packet {
                origins: self.origins,
                dirs: std::array::from_fn(|v| if v < n { scratch.dirs[v][i] } else { Vec3::Z }),
                t_min: self.camera.hither,
                t_max: [f32::INFINITY; K],
                mask: all,
            };
            let h = if let Some(strip) = strip {
                let found = |v: usize| match v < n {
                    true => strip.hits[self.first_view + v][i],
                    false => (PacketHits::<K>::NO_HIT, NONE),
                };
                PacketHits {
                    prim: std::array::from_fn(|v| found(v).0),
                    hit: std::array::from_fn(|v| found(v).1),
                }
            } else if cut {
                let mut far = [(PacketHits::<K>::NO_HIT, NONE); K];
                for (v, slot) in far.iter_mut().enumerate().take(n) {
                    let (_, prim, hit) = self.far_ray(tracer, row, scratch, v, i);
                    *slot = (prim, hit);
                    packet.t_max[v] = hit.t;
                }
                let mut h = tracer.eye_hits_split(&packet, true);
                for (v, &(prim, hit)) in far.iter().enumerate().take(n) {
                    scratch.far[v][i] = false;
                    if !h.has_hit(v) && prim != PacketHits::<K>::NO_HIT {
                        (h.prim[v], h.hit[v]) = (prim, hit);
                        scratch.far[v][i] = true;
                    }
                }
                tracer.count_eye_hits(&packet, &h, &view_of_lane);
                h
            } else {
                tracer.eye_hits(&packet, &view_of_lane)
            };
            for v in 0..n {
                scratch.hits[v][i] = (h.prim[v], h.hit[v]);
                scratch.points[v][i] = (h.has_hit(v) && !(cut && scratch.far[v][i]))
                    .then(|| self.origins[v] + packet.dirs[v] * h.hit[v].t);
            }
        }
    }

    /// `eye_pass` for a batch of at most eight views, without a cut or a
    /// strip, where `eye_hit_applies`: the views' rays of a few neighbouring
    /// samples (two for four views) in one eight-ray descent
    /// (`Tracer::eye_hits8`; lane `l` is view `l % n` of the chunk's sample
    /// `l / n`), each hit bit for bit the ray's alone; a packet refused (its
    /// rays' direction signs differ) traced sample by sample, as without
    /// packets. A packet counts as one traversal, as a batch's packet of
    /// views does.
    fn eye_pass_packed(&self, tracer: &mut Tracer, row: &SampleRow, scratch: &mut RowScratch<K>) {
        let n = self.views;
        let per = EYE_PACKET / n;
        let views: [usize; EYE_PACKET] = std::array::from_fn(|l| self.first_view + l % n);
        // One packet for the row, its lanes written in place (as in
        // `trace_mono_row`: a packet made whole and moved stalls on the
        // reload of its narrow stores).
        let mut packet = Packet {
            origins: std::array::from_fn(|l| self.origins[l % n]),
            dirs: [Vec3::Z; EYE_PACKET],
            t_min: self.camera.hither,
            t_max: [f32::INFINITY; EYE_PACKET],
            mask: 0,
        };
        for first in (0..row.len()).step_by(per) {
            let lanes = per.min(row.len() - first) * n;
            for (l, d) in packet.dirs.iter_mut().enumerate().take(lanes) {
                *d = scratch.dirs[l % n][first + l / n];
            }
            packet.mask = (1u32 << lanes) - 1;
            let hits = match lanes > 1 {
                true => tracer.eye_hits8(&packet, &views),
                false => None,
            };
            let Some(hits) = hits else {
                // Refused: each sample's views as one batch packet, as
                // without packets.
                for i in first..first + lanes / n {
                    let batch = Packet {
                        origins: self.origins,
                        dirs: std::array::from_fn(|v| match v < n {
                            true => scratch.dirs[v][i],
                            false => Vec3::Z,
                        }),
                        t_min: self.camera.hither,
                        t_max: [f32::INFINITY; K],
                        mask: (1u32 << n) - 1,
                    };
                    let h = tracer.eye_hits(&batch, &std::array::from_fn(|l| self.first_view + l));
                    for v in 0..n {
                        scratch.hits[v][i] = (h.prim[v], h.hit[v]);
                        scratch.points[v][i] = h
                            .has_hit(v)
                            .then(|| self.origins[v] + batch.dirs[v] * h.hit[v].t);
                    }
                }
                continue;
            };
            for l in 0..lanes {
                let (v, i, dir) = (l % n, first + l / n, packet.dirs[l]);
                let (prim, hit) = (hits.prim[l], hits.hit[l]);
                scratch.hits[v][i] = (prim, hit);
                scratch.points[v][i] =
                    (prim != PacketHits::<K>::NO_HIT).then(|| self.origins[v] + dir * hit.t);
            }
        }
    }

    /// With a cut: the rig centre's ray along the camera column of view `v`'s
    /// sample `i` (through the row's pattern in that column, as the centre's
    /// own sample), and its nearest hit beyond the cut; traced once per column.
    fn far_ray(
        &self,
        tracer: &mut Tracer,
        row: &SampleRow,
        scratch: &mut RowScratch<K>,
        v: usize,
        i: usize,
    ) -> (Vec3, u32, SurfaceHit) {
        let c = self.column(scratch, row, v, i);
        if let Some(known) = scratch.far_rays[c] {
            return known;
        }
        let (column, y) = row.centre_point(scratch.first_column + c as i32);
        let dir = self.camera.direction(column, y);
        let h = tracer.eye_hits_split(&self.centre_ray(dir), false);
        let known = (dir, h.prim[0], h.hit[0]);
        scratch.far_rays[c] = Some(known);
        known
    }

    /// Camera column (from `first_column`) that view `view`'s sample `i` looks along.
    fn column(&self, scratch: &RowScratch<K>, row: &SampleRow, view: usize, i: usize) -> usize {
        (row.pixels[i] + self.shifts[view] - scratch.first_column) as usize
    }

    /// With a cut: the samples whose nearest hit lies beyond it take the shading
    /// of the rig centre's ray along their camera column, computed once per
    /// column for all views (the paper's "one lane, one shading").
    fn shade_cut(
        &self,
        tracer: &mut Tracer,
        row: &SampleRow,
        scratch: &mut RowScratch<K>,
        out: &mut [RowColors],
    ) {
        if self.world.far.is_none() {
            return;
        }
        scratch.far_colors.clear();
        scratch.far_colors.resize(scratch.far_rays.len(), None);
        for (v, view_out) in out.iter_mut().enumerate().take(self.views) {
            for (i, sample_out) in view_out.iter_mut().enumerate() {
                if !scratch.far[v][i] {
                    continue;
                }
                let c = self.column(scratch, row, v, i);
                let color = match scratch.far_colors[c] {
                    Some(color) => color,
                    None => {
                        let Some((dir, prim, hit)) = scratch.far_rays[c] else {
                            continue; // not reached: a far sample traced its column
                        };
                        let centre = self.centre_ray(dir);
                        let hits = PacketHits {
                            prim: [prim],
                            hit: [hit],
                        };
                        let color = tracer.shade_eye(&centre, &hits, self.secondary)[0];
                        scratch.far_colors[c] = Some(color);
                        color
                    }
                };
                *sample_out = color;
                tracer.counts.samples_cut += 1;
            }
        }
    }

    /// Stage 2: the groups of samples that see one point.
    fn group(&self, row: &SampleRow, scratch: &mut RowScratch<K>) {
        let (camera, rig) = (self.camera, &self.rig);
        group_row(
            &scratch.points,
            |v, i, p| nearest_sample(camera, row, &rig.views[v], p, i),
            &mut scratch.claimed,
            &mut scratch.groups,
        );
    }

    /// The eye rays of a group's samples as one packet, with their known hits.
    fn group_packet(
        &self,
        scratch: &RowScratch<K>,
        group: &Group<K>,
    ) -> (Packet<K>, PacketHits<K>) {
        let mut packet = Packet {
            origins: self.origins,
            dirs: [Vec3::Z; K],
            t_min: self.camera.hither,
            t_max: [f32::INFINITY; K],
            mask: 0,
        };
        let mut hits = PacketHits {
            prim: [PacketHits::<K>::NO_HIT; K],
            hit: [NONE; K],
        };
        for (v, sample) in group.iter().enumerate() {
            if let Some(i) = *sample {
                packet.mask |= 1 << v;
                packet.dirs[v] = self.dir(scratch, v, i);
                (hits.prim[v], hits.hit[v]) = scratch.hits[v][i];
            }
        }
        (packet, hits)
    }

    /// One view's sample as a packet of one lane, with its known hit.
    fn sample_packet(
        &self,
        scratch: &RowScratch<K>,
        view: usize,
        i: usize,
    ) -> (Packet<1>, PacketHits<1>) {
        let (prim, hit) = scratch.hits[view][i];
        (
            self.eye_ray(self.origins[view], self.dir(scratch, view, i)),
            PacketHits {
                prim: [prim],
                hit: [hit],
            },
        )
    }

    /// The rig centre's eye ray along `dir` (what every view sees beyond a cut).
    fn centre_ray(&self, dir: Vec3) -> Packet<1> {
        self.eye_ray(self.camera.eye, dir)
    }

    /// An empty packet of eight eye rays from `origin` (the mono row's
    /// lanes: its directions and mask written in place).
    fn mono_packet(&self, origin: Vec3) -> Packet<EYE_PACKET> {
        Packet {
            origins: [origin; EYE_PACKET],
            dirs: [Vec3::Z; EYE_PACKET],
            t_min: self.camera.hither,
            t_max: [f32::INFINITY; EYE_PACKET],
            mask: 0,
        }
    }

    fn eye_ray(&self, origin: Vec3, dir: Vec3) -> Packet<1> {
        Packet {
            origins: [origin],
            dirs: [dir],
            t_min: self.camera.hither,
            t_max: [f32::INFINITY],
            mask: 1,
        }
    }

    /// Shades the lanes of `group` as one packet into `out` (exact). A group
    /// whose samples hit nothing takes the background without a shading call.
    fn shade_group(
        &self,
        tracer: &mut Tracer,
        scratch: &RowScratch<K>,
        group: &Group<K>,
        out: &mut [RowColors],
    ) {
        // Samples whose hit lies beyond a cut are shaded already (`shade_cut`).
        let mut group = *group;
        if self.world.far.is_some() {
            for (v, sample) in group.iter_mut().enumerate() {
                if sample.is_some_and(|i| scratch.far[v][i]) {
                    *sample = None;
                }
            }
        }
        let group = &group;
        let missed = group
            .iter()
            .enumerate()
            .all(|(v, sample)| sample.is_none_or(|i| !Self::has_hit(scratch, v, i)));
        if missed {
            for (v, sample) in group.iter().enumerate() {
                if let Some(i) = *sample {
                    out[v][i] = self.world.scene.background_toward(self.dir(scratch, v, i));
                }
            }
            return;
        }
        let (packet, hits) = self.group_packet(scratch, group);
        tracer.row_shadows.select(self.first_view, group);
        let colors = tracer.shade_eye(&packet, &hits, self.secondary);
        for (v, sample) in group.iter().enumerate() {
            if let Some(i) = *sample {
                out[v][i] = colors[v];
            }
        }
    }

    /// Stage 3: every group shaded as one packet (exact). Groups of up to
    /// eight views go together, as many whole groups as fill eight lanes
    /// (`shade_groups_packed`).
    fn shade_groups(&self, tracer: &mut Tracer, scratch: &RowScratch<K>, out: &mut [RowColors]) {
        if K <= EYE_PACKET {
            return self.shade_groups_packed(tracer, scratch, out);
        }
        for group in &scratch.groups {
            self.shade_group(tracer, scratch, group, out);
        }
    }

    /// `shade_group` for consecutive groups at once: their hit lanes in
    /// packets of eight (a pair's four groups, two of four views), each group
    /// whole in one packet, so that their shadow segments and secondary rays
    /// go down in the eight-lane descents, as a mono row's do (a group of two
    /// lanes took the pair descents: the pair cost 1.3 times two mono rows,
    /// now about as much, docs/benchmarks.md, "Issues 16 and 17, tenth
    /// pass"). Each lane's colour is its own ray's whatever packet it is in,
    /// so the colours are `shade_group`'s; a group's lanes are counted as
    /// grouped as there.
    fn shade_groups_packed(
        &self,
        tracer: &mut Tracer,
        scratch: &RowScratch<K>,
        out: &mut [RowColors],
    ) {
        let mut lanes = self.lanes();
        for group in &scratch.groups {
            self.push_group(tracer, scratch, group, &mut lanes, out);
        }
        self.shade_lanes(tracer, &mut lanes, out);
    }

    /// Whether view `v`'s sample `k` sees the surface point that view 0's
    /// sample `i` sees: the same primitive (or one plane of one material) and
    /// within one pixel's footprint on the surface.
    fn same_point(&self, scratch: &RowScratch<K>, i: usize, v: usize, k: usize) -> bool {
        let ((prim0, _), (prim, hit)) = (scratch.hits[0][i], scratch.hits[v][k]);
        let (Some(p0), Some(p)) = (scratch.points[0][i], scratch.points[v][k]) else {
            return false;
        };
        if prim != prim0 && !self.world.coplanar(prim0, prim) {
            return false;
        }
        let d = self.dir(scratch, v, k);
        let shape = &self.world.scene.shapes[prim as usize];
        let cos = shape.geometric_normal(p).dot(d).abs().max(0.05);
        let footprint = self.camera.pixel_size * hit.t / cos;
        (p - p0).length() <= footprint
    }

    /// Whether a sample's material may give its shading to other views.
    fn diffuse_hit(&self, scratch: &RowScratch<K>, view: usize, i: usize, threshold: f32) -> bool {
        Self::has_hit(scratch, view, i) && {
            let m = self.world.material_of(scratch.hits[view][i].0);
            m.ks.max(m.mirror) <= threshold && m.t <= threshold
        }
    }

    /// Stage 4, safe reprojection (section 2.5 with the eye pass's own hits as
    /// the visibility test), in two steps over the row:
    ///
    /// 1. View 0's sample of each group whose hit is diffuse (`threshold`) and
    ///    seen by another sample of the group is shaded as a donor, and its
    ///    light visibility and secondary colour kept; the other groups are
    ///    shaded exactly.
    /// 2. Each other sample of such a group takes them — and computes its own
    ///    ambient, diffuse and highlight terms — if it sees the same surface
    ///    point, every surface of the donor's shading tree is diffuse, and the
    ///    donor's neighbours in the row saw the lights as it did (no shadow
    ///    edge within a pixel). The samples refused are shaded exactly.
    ///
    /// Donors, takers and exact groups each go eight lanes to a packet
    /// (`packed`): each lane's colour is what it gets alone.
    fn share_groups(
        &self,
        tracer: &mut Tracer,
        scratch: &mut RowScratch<K>,
        threshold: f32,
        out: &mut [RowColors],
    ) {
        let lights = self.world.scene.lights.len();
        let width = scratch.hits[0].len();
        let mut donors = std::mem::take(&mut scratch.donors);
        let mut takers = std::mem::take(&mut scratch.takers);
        let mut kept = std::mem::take(&mut scratch.kept);
        kept.reset(width, lights);
        let mut exact = self.lanes();
        let keep = |donors: &mut packed::DonorPacket, kept: &mut KeptShading| {
            if let Some(lanes) = donors.lanes.as_mut() {
                for (l, _, i) in lanes.filled() {
                    kept.keep_lane(i, &donors.donors, l, threshold);
                }
                lanes.clear();
            }
        };
        for group in &scratch.groups {
            // A group none of whose other samples sees view 0's point keeps its
            // shared descents: it is shaded as one packet.
            let takers = |i: usize| {
                group
                    .iter()
                    .enumerate()
                    .skip(1)
                    .any(|(v, k)| k.is_some_and(|k| self.same_point(scratch, i, v, k)))
            };
            match group[0] {
                Some(i) if self.diffuse_hit(scratch, 0, i, threshold) && takers(i) => {
                    self.push_donor(scratch, &mut donors, i);
                    if donors.lanes.as_ref().is_some_and(packed::Lanes::is_full) {
                        self.shade_donor_packet(tracer, &mut donors, out);
                        keep(&mut donors, &mut kept);
                    }
                }
                _ => self.push_group(tracer, scratch, group, &mut exact, out),
            }
        }
        self.shade_donor_packet(tracer, &mut donors, out);
        keep(&mut donors, &mut kept);
        for group in &scratch.groups {
            let Some(i) = group[0] else { continue };
            if !kept.donor[i] {
                continue; // shaded as a whole group in step 1
            }
            let coherent = kept.diffuse[i] && kept.coherent(i);
            let mut rest: Group<K> = [None; K];
            for (v, sample) in group.iter().enumerate().skip(1) {
                let Some(k) = *sample else { continue };
                if coherent && self.same_point(scratch, i, v, k) {
                    let light = (kept.through(i), kept.secondary[i]);
                    self.push_taker(tracer, scratch, &mut takers, (v, k), light, out);
                    tracer.counts.reprojected += 1;
                } else {
                    rest[v] = Some(k);
                    tracer.counts.reproject_rejected += 1;
                }
            }
            if rest.iter().any(Option::is_some) {
                self.push_group(tracer, scratch, &rest, &mut exact, out);
            }
        }
        self.shade_takers(tracer, &mut takers, out);
        self.shade_lanes(tracer, &mut exact, out);
        scratch.donors = donors;
        scratch.takers = takers;
        scratch.kept = kept;
    }

    /// Stage 4, the paper's reprojection as published (eq. 2.1), without the
    /// other views' eye rays: view 0 is traced alone; each of its hits is
    /// projected into every other view, where the nearest point that lands on
    /// a sample wins it; a winner whose shading tree is diffuse (coefficients
    /// at most `threshold`) gives that sample its colour. Samples that receive
    /// nothing, or whose winner is not diffuse, are traced (holes). Nothing
    /// checks that the other view sees the point: a surface hidden from it by
    /// something view 0 did not see still shows (a ghost).
    fn reproject_forward(
        &self,
        tracer: &mut Tracer,
        row: &SampleRow,
        scratch: &mut RowScratch<K>,
        threshold: f32,
        out: &mut [RowColors],
    ) {
        let n = self.views;
        scratch.reset(n, row.len());
        fit(&mut scratch.received, n, row.len(), None);
        let mut donor = std::mem::take(&mut scratch.donor);
        for v in 0..n {
            let dirs = &mut scratch.dirs[v];
            self.row_dirs(row, self.shifts[v], |i, dir| dirs[i] = dir);
        }
        // View 0's eye rays, one at a time (a mono render of view 0).
        for (i, sample_out) in out[0].iter_mut().enumerate() {
            let packet = self.eye_ray(self.origins[0], scratch.dirs[0][i]);
            let hits = tracer.eye_hits(&packet, &[self.first_view]);
            scratch.hits[0][i] = (hits.prim[0], hits.hit[0]);
            if !hits.has_hit(0) {
                *sample_out = self.world.scene.background_toward(packet.dirs[0]);
                continue;
            }
            let diffuse = self.diffuse_hit(scratch, 0, i, threshold);
            let color = if diffuse {
                tracer.shade_donor(&packet, &hits, self.secondary, &mut donor);
                donor.color
            } else {
                tracer.shade_eye(&packet, &hits, self.secondary)[0]
            };
            *sample_out = color;
            let gives = diffuse && donor.tree_coefficient <= threshold;
            let point = packet.origins[0] + packet.dirs[0] * hits.hit[0].t;
            for v in 1..n {
                let view = &self.rig.views[v];
                let Some(k) = nearest_sample(self.camera, row, view, point, i) else {
                    continue;
                };
                let depth = self.camera.depth_of(point, view.offset);
                if scratch.received[v][k].is_none_or(|(d, _)| depth < d) {
                    scratch.received[v][k] = Some((depth, gives.then_some(color)));
                }
            }
        }
        // The other views: received colours, and eye rays for the holes.
        for (v, view_out) in out.iter_mut().enumerate().take(n).skip(1) {
            for (k, sample_out) in view_out.iter_mut().enumerate() {
                if let Some((_, Some(color))) = scratch.received[v][k] {
                    *sample_out = color;
                    tracer.counts.reprojected += 1;
                    continue;
                }
                let packet = self.eye_ray(self.origins[v], scratch.dirs[v][k]);
                let hits = tracer.eye_hits(&packet, &[self.first_view + v]);
                *sample_out = if hits.has_hit(0) {
                    tracer.shade_eye(&packet, &hits, self.secondary)[0]
                } else {
                    self.world.scene.background_toward(packet.dirs[0])
                };
                tracer.counts.hole_samples += 1;
            }
        }
        scratch.donor = donor;
    }

    /// A batch of one view with nothing to share (no strip pass, cut,
    /// reprojection or shared shading): the eye pass and the shading of
    /// `trace_row` without the grouping. Each sample is the group of one that
    /// `group_row` would make, shaded by the same calls in the same order
    /// (same packet, same hit), so the colours and counts are the same; what
    /// goes is the per-view buffers, the points and claims of the grouping,
    /// and the group packets' copies (docs/benchmarks.md, "Issue 17, sixth pass").
    fn trace_mono_row(
        &self,
        tracer: &mut Tracer,
        row: &SampleRow,
        scratch: &mut RowScratch<K>,
        out: &mut [RowColors],
    ) {
        let start = Instant::now();
        let (origin, shift) = (self.origins[0], self.shifts[0]);
        let mono = &mut scratch.mono;
        mono.clear();
        // The directions first, in a loop of their own.
        self.row_dirs(row, shift, |_, dir| {
            mono.push((dir, PacketHits::<1>::NO_HIT, NONE))
        });
        if tracer.eye_hit_applies() {
            // Eight neighbouring samples' rays in one descent where their
            // direction signs agree (each hit bit for bit `eye_hit`'s),
            // else one by one. One packet for the row, its directions
            // written lane by lane in place (a packet made whole for each
            // eight, then moved, was reloaded wide from the narrow stores
            // that wrote it: a store-forwarding stall).
            let mut packet = self.mono_packet(origin);
            for chunk in mono.chunks_mut(EYE_PACKET) {
                for (d, m) in packet.dirs.iter_mut().zip(chunk.iter()) {
                    *d = m.0;
                }
                packet.mask = (1u32 << chunk.len()) - 1;
                if chunk.len() > 1 {
                    if let Some(hits) = tracer.eye_hits8(&packet, &[self.first_view; EYE_PACKET]) {
                        for (l, (_, prim, hit)) in chunk.iter_mut().enumerate() {
                            (*prim, *hit) = (hits.prim[l], hits.hit[l]);
                        }
                        continue;
                    }
                }
                for (dir, prim, hit) in chunk.iter_mut() {
                    (*prim, *hit) = tracer.eye_hit(&self.eye_ray(origin, *dir), self.first_view);
                }
            }
        } else {
            for (dir, prim, hit) in mono.iter_mut() {
                let h = tracer.eye_hits(&self.eye_ray(origin, *dir), &[self.first_view]);
                (*prim, *hit) = (h.prim[0], h.hit[0]);
            }
        }
        let eye_pass = start.elapsed();
        let scene = &self.world.scene;
        let flat = &mut scratch.flat;
        flat.resize(scene.materials.len(), None);
        // Eight neighbouring samples shaded as one packet: their shadow
        // segments toward each light start a pixel apart and end together,
        // so they go down in one descent (`Bvh::occlusion_packet8`); each
        // lane's colour is what it gets alone.
        // One packet for the row, its lanes written in place (a packet and its
        // hits made whole for each eight cost 3 % of a matte render).
        let mut packet = self.mono_packet(origin);
        let mut hits = PacketHits::<EYE_PACKET>::none();
        let mut materials = [0usize; EYE_PACKET];
        for (chunk, colors) in mono.chunks(EYE_PACKET).zip(out[0].chunks_mut(EYE_PACKET)) {
            packet.mask = 0;
            for (l, (&(dir, prim, hit), color)) in chunk.iter().zip(colors.iter_mut()).enumerate() {
                if prim == PacketHits::<1>::NO_HIT {
                    *color = scene.background_toward(dir);
                    continue;
                }
                // A material whose hits all shade to one colour: the colour
                // of its first hit (shading it counts nothing, caches nothing).
                let material = scene.shape_material[prim as usize] as usize;
                if let Some(Some(c)) = flat.get(material) {
                    *color = *c;
                    continue;
                }
                packet.dirs[l] = dir;
                (hits.prim[l], hits.hit[l]) = (prim, hit);
                materials[l] = material;
                packet.mask |= 1 << l;
            }
            if packet.mask == 0 {
                continue;
            }
            let shaded = tracer.shade_eye_lanes(&packet, &hits, self.secondary);
            for (l, color) in colors.iter_mut().enumerate() {
                if packet.mask & (1 << l) != 0 {
                    *color = shaded[l];
                    let material = materials[l];
                    if self.flat.get(material) == Some(&true) && flat[material].is_none() {
                        flat[material] = Some(*color);
                    }
                }
            }
        }
        tracer.counts.eye_pass_ns += eye_pass.as_nanos() as u64;
        tracer.counts.shading_pass_ns += (start.elapsed() - eye_pass).as_nanos() as u64;
    }

    /// Whether the batch is one view with nothing to share, traced by
    /// `trace_mono_row`.
    fn is_mono(&self) -> bool {
        self.views == 1
            && self.world.far.is_none()
            && self.reproject.is_none()
            && self.shared_shading.is_none()
    }

    /// Every stage for one row of samples: `out[v][i]` is view `v`'s colour
    /// of sample `i`.
    fn trace_row(
        &self,
        tracer: &mut Tracer,
        row: &SampleRow,
        scratch: &mut RowScratch<K>,
        strip: Option<&StripRow>,
        out: &mut [RowColors],
    ) {
        if strip.is_none() && self.is_mono() {
            return self.trace_mono_row(tracer, row, scratch, out);
        }
        let start = Instant::now();
        let paper = matches!(self.reproject, Some(r) if r.mode == ReprojectMode::Paper);
        if !paper {
            self.eye_pass(tracer, row, scratch, strip);
        }
        let eye_pass = start.elapsed();
        self.shade_cut(tracer, row, scratch, out);
        match self.reproject {
            _ if !paper && self.shared_shading.is_some() => {
                let tolerance = self.shared_shading.map_or(0.0, |sh| sh.tolerance);
                self.group(row, scratch);
                self.share_shading(tracer, row, scratch, tolerance, out);
            }
            None => {
                self.group(row, scratch);
                self.shade_groups(tracer, scratch, out);
            }
            Some(Reprojection {
                mode: ReprojectMode::Safe,
                threshold,
            }) => {
                self.group(row, scratch);
                self.share_groups(tracer, scratch, threshold, out);
            }
            Some(Reprojection {
                mode: ReprojectMode::Paper,
                threshold,
            }) => self.reproject_forward(tracer, row, scratch, threshold, out),
        }
        tracer.counts.eye_pass_ns += eye_pass.as_nanos() as u64;
        tracer.counts.shading_pass_ns += (start.elapsed() - eye_pass).as_nanos() as u64;
    }
}

/// The twin method's worker: a twin batch and its scratch space.
struct TwinWorker<'s, 'a, const K: usize> {
    batch: &'s TwinBatch<'a, K>,
    scratch: RowScratch<K>,
}

impl<const K: usize> RowWorker for TwinWorker<'_, '_, K> {
    fn trace(&mut self, tracer: &mut Tracer, row: &SampleRow, out: &mut [RowColors]) {
        self.batch
            .trace_row(tracer, row, &mut self.scratch, None, out);
    }

    fn trace_with_hits(
        &mut self,
        tracer: &mut Tracer,
        row: &SampleRow,
        eye: &StripRow,
        out: &mut [RowColors],
    ) {
        self.batch
            .trace_row(tracer, row, &mut self.scratch, Some(eye), out);
    }

    fn trace_keeping_hits(
        &mut self,
        tracer: &mut Tracer,
        row: &SampleRow,
        out: &mut [RowColors],
        hits: &mut Vec<(u32, SurfaceHit)>,
    ) -> bool {
        if !self.batch.is_mono() {
            return false;
        }
        self.batch
            .trace_mono_row(tracer, row, &mut self.scratch, out);
        hits.clear();
        hits.extend(self.scratch.mono.iter().map(|&(_, prim, hit)| (prim, hit)));
        true
    }

    fn eye_hits(
        &mut self,
        tracer: &mut Tracer,
        row: &SampleRow,
        hits: &mut [Vec<(u32, SurfaceHit)>],
    ) -> bool {
        if self.batch.world.far.is_some() {
            return false; // hits beyond a cut are the centre ray's (`far_ray`)
        }
        self.batch.eye_pass(tracer, row, &mut self.scratch, None);
        for (out, found) in hits.iter_mut().zip(&self.scratch.hits) {
            out.clone_from(found);
        }
        true
    }
}

impl<const K: usize> ViewBatch for TwinBatch<'_, K> {
    fn view_count(&self) -> usize {
        self.views
    }

    fn worker(&self) -> Box<dyn RowWorker + '_> {
        Box::new(TwinWorker {
            batch: self,
            scratch: RowScratch::<K>::default(),
        })
    }
}

/// Per sample of view 0 in a row, what a donor kept for the other views
/// (safe reprojection).
#[derive(Default)]
struct KeptShading {
    lights: usize,
    /// Shaded alone as a donor in step 1.
    donor: Vec<bool>,
    /// A donor whose whole shading tree is diffuse.
    diffuse: Vec<bool>,
    /// Transmittance toward each light, `lights` per sample.
    through: Vec<f32>,
    secondary: Vec<Color>,
}

impl KeptShading {
    fn reset(&mut self, width: usize, lights: usize) {
        self.lights = lights;
        self.donor.clear();
        self.donor.resize(width, false);
        self.diffuse.clear();
        self.diffuse.resize(width, false);
        self.through.clear();
        self.through.resize(width * lights, 0.0);
        self.secondary.clear();
        self.secondary.resize(width, Color::ZERO);
    }

    /// Sample `i` was shaded as lane `l` of a packet of donors.
    fn keep_lane(&mut self, i: usize, donors: &Donors, l: usize, threshold: f32) {
        self.donor[i] = true;
        self.diffuse[i] = donors.tree_coefficients[l] <= threshold;
        let lights = self.lights;
        self.through[i * lights..(i + 1) * lights].copy_from_slice(donors.through(l, lights));
        self.secondary[i] = donors.secondary[l];
    }

    fn through(&self, i: usize) -> &[f32] {
        &self.through[i * self.lights..(i + 1) * self.lights]
    }

    /// Whether the row neighbours of sample `i` were donors that saw every
    /// light exactly as it did: no shadow edge passes within a pixel of it.
    fn coherent(&self, i: usize) -> bool {
        let width = self.diffuse.len();
        [i.wrapping_sub(1), i + 1]
            .into_iter()
            .filter(|&j| j < width)
            .all(|j| self.diffuse[j] && self.through(j) == self.through(i))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::sampler::Pattern;
    use crate::render::CancelToken;
    use crate::render::RenderOptions;

    /// A render's inputs with nobody told of progress.
    fn quiet_inputs<'a>(
        world: &'a World,
        camera: &'a Camera,
        rig: &'a Rig,
        opts: &'a RenderOptions,
        cancel: &'a super::super::CancelToken,
    ) -> RenderInputs<'a> {
        fn no_progress(_: u64, _: u64) {}
        RenderInputs {
            world,
            camera,
            rig,
            opts,
            progress: &no_progress,
            cancel,
        }
    }

    /// The example scene at 64×48, one view, default options.
    fn example_mono() -> (World, Camera, Rig, RenderOptions, CancelToken) {
        let world = World::new(crate::render::example_scene());
        let camera = Camera::new(&world.scene.viewpoint, 64, 48);
        (
            world,
            camera,
            Rig::mono(),
            RenderOptions::default(),
            CancelToken::new(),
        )
    }

    /// A batch of one view takes `trace_mono_row` (no grouping: the groups
    /// stay empty), and its colours and counts are, bit for bit, those of
    /// the staged path it replaces (eye pass, grouping, shading of groups of
    /// one), on rows of pixel centres, of corners and of Sobol samples
    /// (both take the eye rays eight to a descent; the mono row shades
    /// eight samples a packet, so its descents and shadow cache differ).
    #[test]
    fn a_mono_row_is_the_staged_row_bit_for_bit() {
        let (world, camera, rig, opts, cancel) = example_mono();
        let job = quiet_inputs(&world, &camera, &rig, &opts, &cancel);
        let batch = TwinBatch::<1>::new(&job, rig.clone(), 0);
        let width = camera.width as usize;
        let (mut fast, mut staged) = (RowScratch::<1>::default(), RowScratch::<1>::default());
        let mut fast_tracer = Tracer::new(&world, opts.trace);
        let mut staged_tracer = Tracer::new(&world, opts.trace);
        assert!(fast_tracer.eye_hit_applies());
        let mut hits = 0;
        for y in 0..camera.height {
            for pattern in [
                Pattern::Fixed {
                    dx: 0.0,
                    y: y as f32,
                },
                Pattern::Fixed {
                    dx: -0.5,
                    y: y as f32 - 0.5,
                },
                Pattern::Sobol {
                    row: y,
                    index: 3,
                    seed: 1,
                },
            ] {
                let row = SampleRow::full(width, pattern);
                let mut a = vec![vec![Color::ZERO; width]];
                let mut b = vec![vec![Color::ZERO; width]];
                batch.trace_row(&mut fast_tracer, &row, &mut fast, None, &mut a);
                assert!(fast.groups.is_empty(), "the mono row grouped its samples");
                batch.eye_pass(&mut staged_tracer, &row, &mut staged, None);
                batch.group(&row, &mut staged);
                batch.shade_groups(&mut staged_tracer, &staged, &mut b);
                for (i, (ca, cb)) in a[0].iter().zip(&b[0]).enumerate() {
                    let bits = |c: &Color| c.to_array().map(f32::to_bits);
                    assert_eq!(bits(ca), bits(cb), "row {y}, sample {i}, {pattern:?}");
                }
                hits += staged.hits[0]
                    .iter()
                    .filter(|h| h.0 != PacketHits::<1>::NO_HIT)
                    .count();
            }
        }
        assert!(hits > width * camera.height as usize, "{hits} hits");
        let (mut a, mut b) = (fast_tracer.finish(), staged_tracer.finish());
        (
            a.eye_pass_ns,
            a.shading_pass_ns,
            b.eye_pass_ns,
            b.shading_pass_ns,
        ) = (0, 0, 0, 0);
        // Both trace their eye rays eight to a descent where their signs
        // agree (the staged path's batch of one view takes eight samples a
        // packet, as the mono row does): the same packets, rays and hits.
        assert!(
            a.eye_packet_rays * 10 > a.rays.eye * 9 && a.eye_packets * 8 >= a.eye_packet_rays,
            "{} of {} eye rays in {} packets",
            a.eye_packet_rays,
            a.rays.eye,
            a.eye_packets
        );
        // The mono row shades eight neighbouring samples as one packet, the
        // staged path eight groups of one sample that hit something
        // (`shade_groups_packed`): the same rays, other descents and
        // secondary packets, and a shadow cache per lane.
        assert!(a.shared_secondary_rays > a.rays.reflected / 2, "{a:?}");
        assert!(b.shared_secondary_rays > b.rays.reflected / 2, "{b:?}");
        assert_eq!((a.grouped_samples, b.grouped_samples), (0, 0));
        for c in [&mut a, &mut b] {
            (c.shared_secondary, c.shared_secondary_rays) = (0, 0);
            (c.nodes, c.box_tests, c.prim_tests, c.prim_tests_in_lanes) = (0, 0, 0, 0);
            (
                c.closest_traversals,
                c.shadow_cache_tests,
                c.shadow_cache_hits,
            ) = (0, 0, 0);
        }
        assert_eq!(a, b);
    }

    /// A key view of the view synthesis traces its row once and keeps its
    /// hits (`RowWorker::trace_keeping_hits`): the colours of `trace`, and
    /// per sample the hit of the separate eye pass (`eye_hits`), bit for bit.
    #[test]
    fn a_key_view_keeps_the_hits_of_its_eye_pass() {
        let (world, camera, rig, opts, cancel) = example_mono();
        let job = quiet_inputs(&world, &camera, &rig, &opts, &cancel);
        let batch = TwinBatch::<1>::new(&job, rig.clone(), 0);
        let (mut keeping, mut separate) = (batch.worker(), batch.worker());
        let mut tracer = Tracer::new(&world, opts.trace);
        let width = camera.width as usize;
        let mut hit_samples = 0;
        for y in 0..camera.height {
            let row = SampleRow::centres(width, y);
            let (mut a, mut b) = (
                vec![vec![Color::ZERO; width]],
                vec![vec![Color::ZERO; width]],
            );
            let (mut kept, mut eye) = (Vec::new(), vec![Vec::new()]);
            assert!(keeping.trace_keeping_hits(&mut tracer, &row, &mut a, &mut kept));
            separate.trace(&mut tracer, &row, &mut b);
            assert!(separate.eye_hits(&mut tracer, &row, &mut eye));
            let bits = |c: &Color| c.to_array().map(f32::to_bits);
            assert_eq!(
                a[0].iter().map(bits).collect::<Vec<_>>(),
                b[0].iter().map(bits).collect::<Vec<_>>(),
                "row {y}"
            );
            let hit_bits = |h: &[(u32, SurfaceHit)]| {
                h.iter()
                    .map(|(p, s)| (*p, s.t.to_bits(), s.u.to_bits(), s.v.to_bits()))
                    .collect::<Vec<_>>()
            };
            assert_eq!(hit_bits(&kept), hit_bits(&eye[0]), "row {y}");
            hit_samples += kept
                .iter()
                .filter(|h| h.0 != PacketHits::<1>::NO_HIT)
                .count();
        }
        assert!(hit_samples > width, "{hit_samples} hits");
    }

    /// Materials whose eye hits all shade to one colour are shaded once per
    /// row worker and copied (`TwinBatch::flat`): the mono rows' colours and
    /// counts are, bit for bit, those of shading every hit, on a scene
    /// without lights (matte floor, sphere and cone: flat; a textured quad:
    /// not), the same with an emissive and a pure-ambient material, and with
    /// lights (only the pure-ambient material is flat). Each condition of
    /// `shades_flat` left out fails here: a texture, a light, a mirror's ray,
    /// BLEND coverage, corner colours.
    #[test]
    fn flat_materials_shade_as_every_hit_does() {
        use crate::render::tracer::{test_scene, unlit_test_scene};
        use crate::scene::{AlphaMode, MeshPolygon};
        let lit = test_scene();
        let unlit = unlit_test_scene(test_scene());
        let mut glowing = unlit.clone();
        glowing.materials[1].emission = Color::new(0.3, 0.1, 0.0);
        glowing.materials[0].kd = 0.0;
        let mut ambient_lit = lit.clone();
        let cone = &mut ambient_lit.materials[2];
        (cone.kd, cone.ks, cone.mirror) = (0.0, 0.0, 0.0);
        let mut mirror = unlit.clone();
        mirror.materials[1].mirror = 0.5;
        let mut blend = unlit.clone();
        (blend.materials[2].alpha_mode, blend.materials[2].alpha) = (AlphaMode::Blend, 0.5);
        let mut coloured = unlit.clone();
        let group = coloured.new_group();
        let quad = [
            Vec3::new(-2.2, -2.0, 0.2),
            Vec3::new(-0.2, -2.0, 0.2),
            Vec3::new(-0.2, -2.0, 2.2),
            Vec3::new(-2.2, -2.0, 2.2),
        ];
        let corners = [
            Color::new(1.0, 0.0, 0.0),
            Color::ONE,
            Color::new(0.0, 0.0, 1.0),
            Color::ONE,
        ];
        coloured.add_colored_mesh_polygon(
            &MeshPolygon {
                vertices: &quad,
                normals: None,
                uv: None,
                material: 0,
                group,
            },
            Some(&corners),
            &|| "quad".into(),
        );
        let mut flat_in = Vec::new();
        for (what, scene) in [
            ("no light", unlit),
            ("emission", glowing),
            ("lights, one pure ambient material", ambient_lit),
            ("lights", lit),
            ("a mirror", mirror),
            ("BLEND", blend),
            ("corner colours", coloured),
        ] {
            let world = World::new(scene);
            let camera = Camera::new(&world.scene.viewpoint, 48, 36);
            let rig = Rig::mono();
            let opts = RenderOptions::default();
            let cancel = super::super::CancelToken::new();
            let job = quiet_inputs(&world, &camera, &rig, &opts, &cancel);
            let fast = TwinBatch::<1>::new(&job, rig.clone(), 0);
            let mut every = TwinBatch::<1>::new(&job, rig.clone(), 0);
            every.flat.iter_mut().for_each(|f| *f = false);
            flat_in.push((what, fast.flat.iter().filter(|&&f| f).count()));
            let width = camera.width as usize;
            let (mut a_scratch, mut b_scratch) = (RowScratch::default(), RowScratch::default());
            let mut a_tracer = Tracer::new(&world, opts.trace);
            let mut b_tracer = Tracer::new(&world, opts.trace);
            let mut colours = std::collections::HashSet::new();
            for y in 0..camera.height {
                let row = SampleRow::centres(width, y);
                let mut a = vec![vec![Color::ZERO; width]];
                let mut b = vec![vec![Color::ZERO; width]];
                fast.trace_row(&mut a_tracer, &row, &mut a_scratch, None, &mut a);
                every.trace_row(&mut b_tracer, &row, &mut b_scratch, None, &mut b);
                for (i, (ca, cb)) in a[0].iter().zip(&b[0]).enumerate() {
                    let bits = |c: &Color| c.to_array().map(f32::to_bits);
                    assert_eq!(bits(ca), bits(cb), "{what}: row {y}, sample {i}");
                    colours.insert(bits(cb));
                }
            }
            assert!(colours.len() > 20, "{what}: {} colours", colours.len());
            let (mut a, mut b) = (a_tracer.finish(), b_tracer.finish());
            (
                a.eye_pass_ns,
                a.shading_pass_ns,
                b.eye_pass_ns,
                b.shading_pass_ns,
            ) = (0, 0, 0, 0);
            assert_eq!(a, b, "{what}");
        }
        // Floor, sphere and cone; with an emissive sphere and a floor of no
        // diffuse term too; under lights the pure-ambient cone alone; then
        // the mirror sphere, the BLEND cone and the corner colours' scene
        // lose theirs.
        let expected = [
            ("no light", 3),
            ("emission", 3),
            ("lights, one pure ambient material", 1),
            ("lights", 0),
            ("a mirror", 2),
            ("BLEND", 2),
            ("corner colours", 0),
        ];
        assert_eq!(flat_in, expected);
    }

    /// The approximate pair paths shade their donors, the samples that take
    /// a donor's light, and their exact groups eight lanes to a packet
    /// (`packed`): their rows are, bit for bit, those of packets of one
    /// lane (where each donor is lane 0 of its packet; each exact group is
    /// shaded by `shade_group`, as a packet of its own), under the safe reprojection and the shared shading, each
    /// with and without merged secondary rays, on a scene of shadows, faint
    /// mirrors (their secondary colours differ from donor to donor; under
    /// the shared shading with highlights, so that the colours are not taken
    /// whole but shaded from the light), a mirror sphere and a mirror wall
    /// (merged rays from exact groups, which a packet must not split).
    #[test]
    fn packed_approximations_are_the_one_lane_rows_bit_for_bit() {
        let text = "b 0.1 0.1 0.2\nv\nfrom 0 -8 3\nat 0 0 1\nup 0 0 1\nangle 45\n\
            hither 0.01\nresolution 64 48\nl -5 -5 6\nl 4 -3 5 0.6 0.5 0.4\n\
            f 0.8 0.8 0.7 0.8 0.05 20 0 1\np 4\n-6 -6 0\n6 -6 0\n6 6 0\n-6 6 0\n\
            f 0.9 0.2 0.2 0.9 0 1 0 1\ns -1.2 0 1 0.8\n\
            f 0.2 0.8 0.3 0.8 0.08 10 0 1\ns 1.2 0.5 0.9 0.7\n\
            f 0.9 0.9 0.9 0.1 0.8 100 0 1\ns 0 2 1.2 0.6\n\
            f 0.9 0.9 0.9 0.1 0.6 100 0 1\np 4\n-6 5 0\n6 5 0\n6 5 5\n-6 5 5\n";
        let base = crate::loaders::nff::parse_nff(
            text,
            std::path::Path::new("t.nff"),
            &crate::loaders::LoadOptions::default(),
        )
        .expect("test scene");
        let camera = Camera::new(&base.viewpoint, 96, 72);
        let rig = Rig::stereo(&camera, 0.3, None).expect("rig");
        let safe = Some(Reprojection {
            mode: ReprojectMode::Safe,
            threshold: Reprojection::DEFAULT_THRESHOLD,
        });
        let shared = Some(SharedShading { tolerance: 0.06 });
        for (what, reproject, shared_shading, merge) in [
            ("reprojection", safe, None, false),
            ("reprojection, merged rays", safe, None, true),
            ("shared shading", None, shared, false),
            ("shared shading, merged rays", None, shared, true),
        ] {
            let mut scene = base.clone();
            if shared_shading.is_some() {
                for m in scene.materials.iter_mut().filter(|m| m.mirror == 0.05) {
                    m.ks = 0.4;
                }
            }
            let world = World::new(scene);
            let mut opts = RenderOptions::default();
            opts.approx.reproject = reproject;
            opts.approx.shared_shading = shared_shading;
            opts.approx.merge_secondary = merge;
            let cancel = CancelToken::new();
            let job = quiet_inputs(&world, &camera, &rig, &opts, &cancel);
            let packed = TwinBatch::<2>::new(&job, rig.clone(), 0);
            let mut one = TwinBatch::<2>::new(&job, rig.clone(), 0);
            one.packet_lanes = 1;
            let (mut a_scratch, mut b_scratch) = (RowScratch::default(), RowScratch::default());
            let mut a_tracer = Tracer::new(&world, opts.trace);
            let mut b_tracer = Tracer::new(&world, opts.trace);
            let width = camera.width as usize;
            for y in 0..camera.height {
                let row = SampleRow::centres(width, y);
                let mut a = vec![vec![Color::ZERO; width]; 2];
                let mut b = vec![vec![Color::ZERO; width]; 2];
                packed.trace_row(&mut a_tracer, &row, &mut a_scratch, None, &mut a);
                one.trace_row(&mut b_tracer, &row, &mut b_scratch, None, &mut b);
                for v in 0..2 {
                    for (i, (ca, cb)) in a[v].iter().zip(&b[v]).enumerate() {
                        let bits = |c: &Color| c.to_array().map(f32::to_bits);
                        assert_eq!(bits(ca), bits(cb), "{what}: row {y}, view {v}, sample {i}");
                    }
                }
            }
            let (a, b) = (a_tracer.finish(), b_tracer.finish());
            let taken = a.reprojected + a.cache_hits - a.cache_colour_hits;
            assert!(taken > 1000, "{what}: {taken} samples took a donor's light");
            assert_eq!(
                (
                    a.reprojected,
                    a.cache_hits,
                    a.cache_colour_hits,
                    a.merged_rays
                ),
                (
                    b.reprojected,
                    b.cache_hits,
                    b.cache_colour_hits,
                    b.merged_rays
                ),
                "{what}"
            );
            assert_eq!(
                a.merged_rays > 0,
                merge,
                "{what}: {} merged rays",
                a.merged_rays
            );
            assert!(
                a.closest_traversals < b.closest_traversals,
                "{what}: descents shared"
            );
        }
    }

    /// Under a strongly converged rig (image shifts of many pixels), the
    /// samples the grouping puts together see the same surface point: the
    /// projection into the other view, shift included, is right. A wrong sign
    /// on the shift still groups samples that hit something, only of points
    /// far apart (its cost shows only in node visits).
    #[test]
    fn grouped_samples_see_the_same_point_under_a_converged_rig() {
        let scene = crate::render::example_scene();
        let distance = (scene.viewpoint.at - scene.viewpoint.from).length() as f64;
        let world = World::new(scene);
        let camera = Camera::new(&world.scene.viewpoint, 96, 72);
        let rig = Rig::stereo(&camera, 0.3, Some(distance * 0.4)).expect("rig");
        assert!(
            rig.views[0].shift - rig.views[1].shift >= 4,
            "{:?}",
            rig.views
        );
        let world_ref = &world;
        let opts = RenderOptions::default();
        let cancel = super::super::CancelToken::new();
        let job = quiet_inputs(world_ref, &camera, &rig, &opts, &cancel);
        let batch = TwinBatch::<2>::new(&job, rig.clone(), 0);
        let width = camera.width as usize;
        let mut scratch = RowScratch::<2>::default();
        let mut tracer = Tracer::new(&world, RenderOptions::default().trace);
        let (mut pairs, mut same) = (0, 0);
        for y in 0..camera.height {
            let row = SampleRow::centres(width, y);
            batch.eye_pass(&mut tracer, &row, &mut scratch, None);
            batch.group(&row, &mut scratch);
            for group in &scratch.groups {
                if let [Some(i), Some(k)] = *group {
                    pairs += 1;
                    if batch.same_point(&scratch, i, 1, k) {
                        same += 1;
                    }
                }
            }
        }
        assert!(pairs > width * camera.height as usize / 2, "{pairs} pairs");
        assert!(
            same * 100 >= pairs * 95,
            "{same} of {pairs} pairs see one point"
        );
    }

    /// A pair's groups are shaded four to a packet of eight lanes
    /// (`shade_groups_packed`): every sample's colour is, bit for bit, the
    /// one its group gets shaded alone (`shade_group`), and the secondary
    /// rays go down in packets of more lanes than a group has (two).
    #[test]
    fn a_pairs_groups_are_shaded_four_to_a_packet() {
        let world = World::new(crate::render::example_scene());
        let camera = Camera::new(&world.scene.viewpoint, 96, 72);
        let rig = Rig::stereo(&camera, 0.2, None).expect("rig");
        let opts = RenderOptions::default();
        let cancel = CancelToken::new();
        let job = quiet_inputs(&world, &camera, &rig, &opts, &cancel);
        let batch = TwinBatch::<2>::new(&job, rig.clone(), 0);
        let width = camera.width as usize;
        let mut scratch = RowScratch::<2>::default();
        let mut eye = Tracer::new(&world, opts.trace);
        let mut packed = Tracer::new(&world, opts.trace);
        let mut alone = Tracer::new(&world, opts.trace);
        let mut shaded = 0;
        for y in 0..camera.height {
            let row = SampleRow::centres(width, y);
            batch.eye_pass(&mut eye, &row, &mut scratch, None);
            batch.group(&row, &mut scratch);
            let mut a = vec![vec![Color::ZERO; width]; 2];
            let mut b = vec![vec![Color::ZERO; width]; 2];
            batch.shade_groups(&mut packed, &scratch, &mut a);
            for group in &scratch.groups {
                batch.shade_group(&mut alone, &scratch, group, &mut b);
            }
            for v in 0..2 {
                for (i, (ca, cb)) in a[v].iter().zip(&b[v]).enumerate() {
                    let bits = |c: &Color| c.to_array().map(f32::to_bits);
                    assert_eq!(bits(ca), bits(cb), "row {y}, view {v}, sample {i}");
                }
            }
            shaded += scratch.groups.len();
        }
        assert!(shaded > width * camera.height as usize, "{shaded} groups");
        let (a, b) = (packed.finish(), alone.finish());
        assert_eq!(
            (a.rays, a.grouped_samples),
            (b.rays, b.grouped_samples),
            "the same rays, the same groups"
        );
        assert!(a.rays.reflected > 1000 && a.grouped_samples > 0, "{a:?}");
        // Lanes per packet of secondary rays: at most two alone.
        let lanes = |c: &crate::stats::TraceCounts| {
            c.shared_secondary_rays as f64 / c.shared_secondary.max(1) as f64
        };
        assert!(lanes(&b) <= 2.0, "alone: {}", lanes(&b));
        assert!(
            lanes(&a) > 4.0,
            "packed: {} lanes a secondary packet",
            lanes(&a)
        );
    }
}

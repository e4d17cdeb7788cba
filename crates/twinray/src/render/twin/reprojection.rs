//! The paper's reprojection of a surface point's shading to the other
//! views: safe (`share_row`: the other views' samples take view 0's
//! light visibility and secondary colour when they see the same surface
//! point and its shading tree is diffuse) or as the paper published it
//! (`reproject_forward`, its eq. 2.1).

use super::batch::{fit, RowScratch, TwinBatch};
use super::grouping::{nearest_sample, Group};
use super::kept::KeptShading;
use super::lanes::{DonorPacket, Lanes};
use crate::render::sampler::{RowColors, SampleRow};
use crate::render::tracer::Tracer;

impl<const K: usize> TwinBatch<'_, K> {
    /// Whether a sample's material may give its shading to other views.
    pub(in crate::render) fn diffuse_hit(
        &self,
        scratch: &RowScratch<K>,
        view: usize,
        i: usize,
        threshold: f32,
    ) -> bool {
        Self::has_hit(scratch, view, i) && {
            let m = self.world.material_of(scratch.hits[view][i].0);
            m.ks.max(m.mirror) <= threshold && m.t <= threshold
        }
    }

    /// Stage 4, safe reprojection (section 2.5 with the eye pass's own hits as
    /// the visibility test), in two steps over the row, with no grouping of
    /// the views' samples:
    ///
    /// 1. Every hit of view 0 is shaded as a donor, eight neighbouring
    ///    samples to a packet as in a mono row, and its light visibility and
    ///    secondary colour kept. A hit whose material is not diffuse
    ///    (`threshold`) gives nothing: it takes the sample of each other view
    ///    it projects to, as `group_row` does, into an exact group, so that
    ///    their secondary rays go together (and merge, if asked).
    /// 2. Each other view's sample projects its own hit into view 0 and takes
    ///    what the nearest donor kept — computing its own ambient, diffuse
    ///    and highlight terms, no shadow ray — if it sees the same surface
    ///    point, the donor's whole shading tree is diffuse, and the donor's
    ///    neighbours in the row saw the lights as it did (no shadow edge
    ///    within a pixel): one sample at a time, as it traces no ray
    ///    (`Tracer::shade_taking`). The samples refused are shaded exactly,
    ///    eight to a packet.
    ///
    /// Each lane's colour is what it gets alone, whatever packet it is in.
    pub(in crate::render) fn share_row(
        &self,
        tracer: &mut Tracer,
        row: &SampleRow,
        scratch: &mut RowScratch<K>,
        threshold: f32,
        out: &mut [RowColors],
    ) {
        let lights = self.world.scene.lights.len();
        let width = row.len();
        let mut donors = std::mem::take(&mut scratch.donors);
        let mut kept = std::mem::take(&mut scratch.kept);
        kept.reset(width, lights);
        let mut exact = self.lanes();
        let keep = |donors: &mut DonorPacket, kept: &mut KeptShading| {
            if let Some(lanes) = donors.lanes.as_mut() {
                for (l, _, i) in lanes.filled() {
                    kept.keep_lane(i, &donors.donors, l, threshold);
                }
                lanes.clear();
            }
        };
        let cut = self.world.far.is_some();
        let background = |scratch: &RowScratch<K>, v: usize, i: usize| {
            self.world.scene.background_toward(scratch.dirs[v][i])
        };
        for i in 0..width {
            if cut && scratch.far[0][i] {
                continue; // shaded by `shade_cut`
            }
            if !Self::has_hit(scratch, 0, i) {
                out[0][i] = background(scratch, 0, i);
                continue;
            }
            if !self.diffuse_hit(scratch, 0, i, threshold) {
                let group = self.claim_group(row, scratch, i);
                self.push_group(tracer, scratch, &group, &mut exact, out);
                continue;
            }
            self.push_donor(scratch, &mut donors, i);
            if donors.lanes.as_ref().is_some_and(Lanes::is_full) {
                self.shade_donor_packet(tracer, &mut donors, out);
                keep(&mut donors, &mut kept);
            }
        }
        self.shade_donor_packet(tracer, &mut donors, out);
        keep(&mut donors, &mut kept);
        for v in 1..self.views {
            for k in 0..width {
                if (cut && scratch.far[v][k]) || scratch.claimed[v][k] {
                    continue; // shaded by `shade_cut`, or with view 0's sample
                }
                if !Self::has_hit(scratch, v, k) {
                    out[v][k] = background(scratch, v, k);
                    continue;
                }
                match self.donor_of(row, scratch, &kept, v, k) {
                    Some(i) => {
                        let (dir, hit) = (scratch.dirs[v][k], scratch.hits[v][k]);
                        let (through, secondary) = (kept.through(i), kept.secondary[i]);
                        out[v][k] =
                            tracer.shade_taking(self.origins[v], dir, hit, through, secondary);
                        tracer.counts.paper.reprojected += 1;
                    }
                    None => {
                        let mut alone: Group<K> = [None; K];
                        alone[v] = Some(k);
                        self.push_group(tracer, scratch, &alone, &mut exact, out);
                        tracer.counts.paper.reproject_rejected += 1;
                    }
                }
            }
        }
        self.shade_lanes(tracer, &mut exact, out);
        scratch.donors = donors;
        scratch.kept = kept;
    }

    /// View 0's sample `i` and the sample of each other view its hit
    /// projects to, where that sample hit something and is not claimed yet
    /// (`group_row`'s group), those claimed.
    fn claim_group(&self, row: &SampleRow, scratch: &mut RowScratch<K>, i: usize) -> Group<K> {
        let mut group: Group<K> = [None; K];
        group[0] = Some(i);
        let Some(point) = scratch.points[0][i] else {
            return group;
        };
        for (v, slot) in group.iter_mut().enumerate().take(self.views).skip(1) {
            let Some(k) = nearest_sample(self.camera, row, &self.rig.views[v], point, i) else {
                continue;
            };
            if !scratch.claimed[v][k] && scratch.points[v][k].is_some() {
                scratch.claimed[v][k] = true;
                *slot = Some(k);
            }
        }
        group
    }

    /// The donor whose light view `v`'s sample `k` takes: the sample of
    /// view 0 nearest to where its hit projects, if that donor's tree is
    /// diffuse, no shadow edge passes by it, and it sees the same point.
    fn donor_of(
        &self,
        row: &SampleRow,
        scratch: &RowScratch<K>,
        kept: &KeptShading,
        v: usize,
        k: usize,
    ) -> Option<usize> {
        let point = scratch.points[v][k]?;
        let i = nearest_sample(self.camera, row, &self.rig.views[0], point, k)?;
        (kept.donor[i] && kept.diffuse[i] && kept.coherent(i) && self.same_point(scratch, i, v, k))
            .then_some(i)
    }

    /// Stage 4, the paper's reprojection as published (eq. 2.1), without the
    /// other views' eye rays: view 0 is traced alone; each of its hits is
    /// projected into every other view, where the nearest point that lands on
    /// a sample wins it; a winner whose shading tree is diffuse (coefficients
    /// at most `threshold`) gives that sample its colour. Samples that receive
    /// nothing, or whose winner is not diffuse, are traced (holes). Nothing
    /// checks that the other view sees the point: a surface hidden from it by
    /// something view 0 did not see still shows (a ghost).
    pub(in crate::render) fn reproject_forward(
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
                tracer.shade_donor(&packet, &hits, self.shading.secondary, &mut donor);
                donor.color
            } else {
                tracer.shade_eye(&packet, &hits, self.shading.secondary)[0]
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
                    tracer.counts.paper.reprojected += 1;
                    continue;
                }
                let packet = self.eye_ray(self.origins[v], scratch.dirs[v][k]);
                let hits = tracer.eye_hits(&packet, &[self.first_view + v]);
                *sample_out = if hits.has_hit(0) {
                    tracer.shade_eye(&packet, &hits, self.shading.secondary)[0]
                } else {
                    self.world.scene.background_toward(packet.dirs[0])
                };
                tracer.counts.paper.hole_samples += 1;
            }
        }
        scratch.donor = donor;
    }
}

//! The paper's reprojection of a surface point's shading to the other
//! views: safe (`share_groups`: a group's other samples take view 0's
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
    pub(in crate::render) fn share_groups(
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
        let keep = |donors: &mut DonorPacket, kept: &mut KeptShading| {
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
                    if donors.lanes.as_ref().is_some_and(Lanes::is_full) {
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
                    tracer.counts.paper.reprojected += 1;
                } else {
                    rest[v] = Some(k);
                    tracer.counts.paper.reproject_rejected += 1;
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

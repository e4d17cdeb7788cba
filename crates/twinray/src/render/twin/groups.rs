//! The twin method's exact stages after the eye pass: the samples of the
//! views that see one surface point grouped (`grouping`), and each group
//! shaded as one packet, several groups to a packet of eight lanes
//! (`packed`). Every lane's rays are its own view's (the grouping only
//! decides which rays share a descent), so the images equal the
//! independent renders bit for bit.

use super::batch::{RowScratch, TwinBatch};
use super::grouping::{group_row, nearest_sample, Group};
use crate::bvh::EYE_PACKET;
use crate::render::sampler::{RowColors, SampleRow};
use crate::render::tracer::Tracer;

impl<const K: usize> TwinBatch<'_, K> {
    /// Stage 2: the groups of samples that see one point.
    pub(in crate::render) fn group(&self, row: &SampleRow, scratch: &mut RowScratch<K>) {
        let (camera, rig) = (self.camera, &self.rig);
        group_row(
            &scratch.points,
            |v, i, p| nearest_sample(camera, row, &rig.views[v], p, i),
            &mut scratch.claimed,
            &mut scratch.groups,
        );
    }

    /// Shades the lanes of `group` as one packet into `out` (exact). A group
    /// whose samples hit nothing takes the background without a shading call.
    pub(in crate::render) fn shade_group(
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
        let colors = tracer.shade_eye(&packet, &hits, self.shading.secondary);
        for (v, sample) in group.iter().enumerate() {
            if let Some(i) = *sample {
                out[v][i] = colors[v];
            }
        }
    }

    /// Stage 3: every group shaded as one packet (exact). Groups of up to
    /// eight views go together, as many whole groups as fill eight lanes
    /// (`shade_groups_packed`).
    pub(in crate::render) fn shade_groups(
        &self,
        tracer: &mut Tracer,
        scratch: &RowScratch<K>,
        out: &mut [RowColors],
    ) {
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
    /// now about as much, docs/benchmarks.md, the exact pair). Each lane's
    /// colour is its own ray's whatever packet it is in, so the colours are
    /// `shade_group`'s; a group's lanes are counted as grouped as there.
    pub(in crate::render) fn shade_groups_packed(
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
}

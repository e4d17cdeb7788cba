//! Samples of several groups shaded as one packet of eight lanes: the exact
//! groups (`shade_groups_packed`), and the approximate paths' donors, the
//! samples that take a donor's light, and the groups they shade exactly
//! (`share_row`, `share_shading`). A pair's group has two lanes; eight
//! lanes of neighbouring samples send their shadow segments and secondary
//! rays down the eight-lane descents (`Bvh::occlusion`,
//! `Bvh::closest_packet8`) instead of one or two at a time. Each lane's
//! colour is what it gets alone, so the packets change the speed, not the
//! images.

use super::batch::{RowScratch, TwinBatch};
use super::grouping::Group;
use super::lanes::{DonorPacket, Lanes, TakerPacket};
use crate::bvh::EYE_PACKET;
use crate::math::Color;
use crate::render::sampler::RowColors;
use crate::render::tracer::Tracer;

impl<const K: usize> TwinBatch<'_, K> {
    /// An empty packet of this batch's eye rays.
    pub(in crate::render) fn lanes(&self) -> Lanes {
        Lanes::new(self.camera.hither, self.packet_lanes)
    }

    /// `shade_group`'s work for `group`, its lanes added to `lanes` as a
    /// group of their own: samples beyond a cut are shaded already
    /// (`shade_cut`), those that missed take the background, as `surfaces`
    /// gives it; the group's lanes are counted as grouped as there. A group
    /// that does not fit in what is left of the packet goes in the next (the
    /// packet is shaded first): merged secondary rays (section 2.4) join
    /// only lanes of one group in one packet. Batches of more than eight
    /// views shade each group as a packet of its own (`shade_group`), and so
    /// does the tests' reference (packets of one lane).
    pub(in crate::render) fn push_group(
        &self,
        tracer: &mut Tracer,
        scratch: &RowScratch<K>,
        group: &Group<K>,
        lanes: &mut Lanes,
        out: &mut [RowColors],
    ) {
        if K > EYE_PACKET || self.packet_lanes == 1 {
            return self.shade_group(tracer, scratch, group, out);
        }
        let cut = self.world.far.is_some();
        let shaded = |v: usize, i: usize| !(cut && scratch.far[v][i]);
        let (mut count, mut hit) = (0u64, 0usize);
        for (v, sample) in group.iter().enumerate() {
            if let Some(i) = sample.filter(|&i| shaded(v, i)) {
                count += 1;
                hit += usize::from(Self::has_hit(scratch, v, i));
            }
        }
        if hit == 0 {
            for (v, sample) in group.iter().enumerate() {
                if let Some(i) = sample.filter(|&i| shaded(v, i)) {
                    out[v][i] = self.world.scene.background_toward(self.dir(scratch, v, i));
                }
            }
            return;
        }
        if count > 1 {
            tracer.counts.grouped_samples += count;
        }
        if lanes.n + hit > lanes.capacity {
            self.shade_lanes(tracer, lanes, out);
        }
        lanes.next_group();
        for (v, sample) in group.iter().enumerate() {
            let Some(i) = sample.filter(|&i| shaded(v, i)) else {
                continue;
            };
            if !Self::has_hit(scratch, v, i) {
                out[v][i] = self.world.scene.background_toward(self.dir(scratch, v, i));
                continue;
            }
            let hit = scratch.hits[v][i];
            lanes.push(self.origins[v], self.dir(scratch, v, i), hit, (v, i));
        }
    }

    /// Shades the lanes of `lanes` exactly into `out`, and empties it.
    pub(in crate::render) fn shade_lanes(
        &self,
        tracer: &mut Tracer,
        lanes: &mut Lanes,
        out: &mut [RowColors],
    ) {
        if lanes.n == 0 {
            return;
        }
        let colors = tracer.shade_eye_groups(
            &lanes.packet,
            &lanes.hits,
            self.shading.secondary,
            lanes.groups,
        );
        for (l, v, i) in lanes.filled() {
            out[v][i] = colors[l];
        }
        lanes.clear();
    }

    /// View 0's sample `i` added to the packet of donors (which must not be
    /// full).
    pub(in crate::render) fn push_donor(
        &self,
        scratch: &RowScratch<K>,
        donors: &mut DonorPacket,
        i: usize,
    ) {
        let lanes = donors.lanes.get_or_insert_with(|| self.lanes());
        lanes.push(
            self.origins[0],
            self.dir(scratch, 0, i),
            scratch.hits[0][i],
            (0, i),
        );
    }

    /// Shades the packet of donors (`Tracer::shade_donors`): their colours
    /// into `out`, what they keep into `donors.donors`. The caller reads
    /// that, lane by lane (`Lanes::filled`), then empties the packet.
    pub(in crate::render) fn shade_donor_packet(
        &self,
        tracer: &mut Tracer,
        donors: &mut DonorPacket,
        out: &mut [RowColors],
    ) {
        let Some(lanes) = donors.lanes.as_ref().filter(|l| l.n > 0) else {
            return;
        };
        tracer.shade_donors(
            &lanes.packet,
            &lanes.hits,
            self.shading.secondary,
            &mut donors.donors,
        );
        for (l, v, i) in lanes.filled() {
            out[v][i] = donors.donors.colors[l];
        }
    }

    /// View `v`'s sample `k` added to the packet of takers, with the light
    /// it takes (`through`, one per light, and `secondary`); the packet is
    /// shaded when full.
    pub(in crate::render) fn push_taker(
        &self,
        tracer: &mut Tracer,
        scratch: &RowScratch<K>,
        takers: &mut TakerPacket,
        (v, k): (usize, usize),
        (through, secondary): (&[f32], Color),
        out: &mut [RowColors],
    ) {
        let lanes = takers.lanes.get_or_insert_with(|| self.lanes());
        let l = lanes.n;
        lanes.push(
            self.origins[v],
            self.dir(scratch, v, k),
            scratch.hits[v][k],
            (v, k),
        );
        let lights = through.len();
        takers.through.resize(lights * EYE_PACKET, 0.0);
        takers.through[l * lights..(l + 1) * lights].copy_from_slice(through);
        takers.secondary[l] = secondary;
        if lanes.is_full() {
            self.shade_takers(tracer, takers, out);
        }
    }

    /// Shades the packet of takers (`Tracer::shade_from_donors`) into `out`,
    /// and empties it.
    pub(in crate::render) fn shade_takers(
        &self,
        tracer: &mut Tracer,
        takers: &mut TakerPacket,
        out: &mut [RowColors],
    ) {
        let Some(lanes) = takers.lanes.as_mut().filter(|l| l.n > 0) else {
            return;
        };
        let colors = tracer.shade_from_donors(
            &lanes.packet,
            &lanes.hits,
            &mut takers.through,
            &takers.secondary,
        );
        for (l, v, k) in lanes.filled() {
            out[v][k] = colors[l];
        }
        lanes.clear();
    }
}

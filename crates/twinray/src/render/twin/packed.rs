//! Samples of several groups shaded as one packet of eight lanes: the exact
//! groups (`shade_groups_packed`), and the approximate paths' donors, the
//! samples that take a donor's light, and the groups they shade exactly
//! (`share_groups`, `share_shading`). A pair's group has two lanes; eight
//! lanes of neighbouring samples send their shadow segments and secondary
//! rays down the eight-lane descents (`Bvh::occlusion_packet8`,
//! `closest_eye_packet8`) instead of one or two at a time. Each lane's
//! colour is what it gets alone, so the packets change the speed, not the
//! images.

use super::{RowScratch, TwinBatch};
use crate::bvh::{Packet, PacketHits, EYE_PACKET};
use crate::math::{Color, Vec3};
use crate::render::grouping::Group;
use crate::render::sampler::RowColors;
use crate::render::tracer::Donors;
use crate::render::Tracer;
use crate::shapes::SurfaceHit;

/// A packet of eight eye rays being filled, lane by lane, with known hits.
pub(super) struct Lanes {
    pub(super) packet: Packet<EYE_PACKET>,
    pub(super) hits: PacketHits<EYE_PACKET>,
    /// Lane `l` is view `at[l].0`'s sample `at[l].1`.
    pub(super) at: [(usize, usize); EYE_PACKET],
    /// Lane `l`'s group of views: merged secondary rays join only lanes of
    /// one group (`Tracer::shade_eye_groups`).
    groups: [u8; EYE_PACKET],
    /// Lanes filled (the first `n`).
    pub(super) n: usize,
    /// Lanes a packet of donors or takers is shaded at (`EYE_PACKET`; 1
    /// in the tests' reference, where each lane is lane 0 of its packet).
    capacity: usize,
    /// The group of the next lanes (counted round: a packet's at most
    /// eight groups are consecutive, so theirs differ).
    group: u8,
}

impl Lanes {
    /// An empty packet of eye rays starting `hither` from their eyes, shaded
    /// once `capacity` lanes (at most `EYE_PACKET`) are filled.
    pub(super) fn new(hither: f32, capacity: usize) -> Lanes {
        Lanes {
            packet: Packet {
                origins: [Vec3::ZERO; EYE_PACKET],
                dirs: [Vec3::Z; EYE_PACKET],
                t_min: hither,
                t_max: [f32::INFINITY; EYE_PACKET],
                mask: 0,
            },
            hits: PacketHits::none(),
            at: [(0, 0); EYE_PACKET],
            groups: [0; EYE_PACKET],
            n: 0,
            capacity: capacity.clamp(1, EYE_PACKET),
            group: 0,
        }
    }

    pub(super) fn is_full(&self) -> bool {
        self.n >= self.capacity
    }

    /// The lanes pushed from now on belong to a new group of views.
    fn next_group(&mut self) {
        self.group = self.group.wrapping_add(1);
    }

    /// View `at.0`'s sample `at.1`, its eye ray from `origin` along `dir`
    /// with its known hit, as the next lane (the packet is not full).
    pub(super) fn push(
        &mut self,
        origin: Vec3,
        dir: Vec3,
        hit: (u32, SurfaceHit),
        at: (usize, usize),
    ) {
        let l = self.n;
        self.packet.origins[l] = origin;
        self.packet.dirs[l] = dir;
        (self.hits.prim[l], self.hits.hit[l]) = hit;
        self.packet.mask |= 1 << l;
        self.at[l] = at;
        self.groups[l] = self.group;
        self.n += 1;
    }

    /// The filled lanes, as (lane, view, sample).
    pub(super) fn filled(&self) -> impl Iterator<Item = (usize, usize, usize)> + '_ {
        self.at[..self.n]
            .iter()
            .enumerate()
            .map(|(l, &(v, i))| (l, v, i))
    }

    /// Empties the packet (its lanes were shaded).
    pub(super) fn clear(&mut self) {
        self.packet.mask = 0;
        self.n = 0;
    }
}

/// Donors (view 0's samples whose light the group's other samples may
/// take) gathered into one packet, and what their shading kept.
#[derive(Default)]
pub(super) struct DonorPacket {
    pub(super) lanes: Option<Lanes>,
    pub(super) donors: Donors,
}

/// Samples that take a donor's light gathered into one packet, with it:
/// lane `l`'s transmittances at `through[l * lights..]`, and its
/// secondary colour.
#[derive(Default)]
pub(super) struct TakerPacket {
    pub(super) lanes: Option<Lanes>,
    through: Vec<f32>,
    secondary: [Color; EYE_PACKET],
}

impl<const K: usize> TwinBatch<'_, K> {
    /// An empty packet of this batch's eye rays.
    pub(super) fn lanes(&self) -> Lanes {
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
    pub(super) fn push_group(
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
    pub(super) fn shade_lanes(
        &self,
        tracer: &mut Tracer,
        lanes: &mut Lanes,
        out: &mut [RowColors],
    ) {
        if lanes.n == 0 {
            return;
        }
        let first_view = self.first_view;
        tracer
            .row_shadows
            .select_lanes(lanes.filled().map(|(l, v, i)| (l, first_view + v, i)));
        let colors =
            tracer.shade_eye_groups(&lanes.packet, &lanes.hits, self.secondary, lanes.groups);
        for (l, v, i) in lanes.filled() {
            out[v][i] = colors[l];
        }
        lanes.clear();
    }

    /// View 0's sample `i` added to the packet of donors (which must not be
    /// full).
    pub(super) fn push_donor(&self, scratch: &RowScratch<K>, donors: &mut DonorPacket, i: usize) {
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
    pub(super) fn shade_donor_packet(
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
            self.secondary,
            &mut donors.donors,
        );
        for (l, v, i) in lanes.filled() {
            out[v][i] = donors.donors.colors[l];
        }
    }

    /// View `v`'s sample `k` added to the packet of takers, with the light
    /// it takes (`through`, one per light, and `secondary`); the packet is
    /// shaded when full.
    pub(super) fn push_taker(
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
    pub(super) fn shade_takers(
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

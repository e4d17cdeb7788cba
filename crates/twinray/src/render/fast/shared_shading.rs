//! The fast method's batches, sharing their shading: the batches of a row
//! fill and read one [`ShadingCache`], so a surface point's shadow and
//! secondary rays are traced once for every view that sees it, not once per
//! batch (see `shading_cache` for the cell, the entry and the bound of the
//! tolerance).

use super::shading_cache::{Found, Kept, Seen, ShadingCache};
use crate::math::Vec3;
use crate::render::sampler::{RowColors, SampleRow};
use crate::render::tracer::Tracer;
use crate::render::twin::batch::{RowScratch, TwinBatch};
use crate::render::twin::lanes::{DonorPacket, Lanes, TakerPacket};

impl<const K: usize> TwinBatch<'_, K> {
    /// Whether view `v`'s sample `i` hit a surface (nearer than any cut) whose
    /// mirror and transmission weights leave at most `tolerance` to its
    /// reflected and refracted rays: it may give and take light.
    fn gives_light(&self, scratch: &RowScratch<K>, v: usize, i: usize, tolerance: f32) -> bool {
        scratch.points[v][i].is_some() && {
            let m = self.world.material_of(scratch.hits[v][i].0);
            m.mirror + m.t <= tolerance
        }
    }

    /// Whether view `v`'s sample `i`, which hit `prim` at `point`, sees the
    /// primitive's front (against its geometric normal).
    fn front(&self, scratch: &RowScratch<K>, v: usize, i: usize, prim: u32, point: Vec3) -> bool {
        let shape = &self.world.scene.shapes[prim as usize];
        shape.met_from_front(point, self.dir(scratch, v, i))
    }

    /// The cache's entry for view `v`'s sample `i`, if it may take one.
    fn look_up(
        &self,
        cache: &ShadingCache,
        row: &SampleRow,
        scratch: &RowScratch<K>,
        v: usize,
        i: usize,
    ) -> Option<Found> {
        let point = scratch.points[v][i]?;
        let (prim, hit) = scratch.hits[v][i];
        let seen = Seen {
            prim,
            point,
            front: self.front(scratch, v, i, prim, point),
            t: hit.t,
        };
        cache.find(self.camera, row, i, seen)
    }

    /// The leaders' samples of the packet of donors, shaded, kept in the
    /// cache in the order they were added (and the packet emptied).
    fn keep_donors(
        &self,
        tracer: &mut Tracer,
        cache: &mut ShadingCache,
        scratch: &RowScratch<K>,
        donors: &mut DonorPacket,
        tolerance: f32,
        out: &mut [RowColors],
    ) {
        self.shade_donor_packet(tracer, donors, out);
        let Some(lanes) = donors.lanes.as_mut() else {
            return;
        };
        let lights = self.world.scene.lights.len();
        let d = &donors.donors;
        for (l, _, i) in lanes.filled() {
            let point = scratch.points[0][i].unwrap_or_default();
            let (prim, hit) = scratch.hits[0][i];
            cache.keep(
                i,
                Kept {
                    seen: Seen {
                        prim,
                        point,
                        front: self.front(scratch, 0, i, prim, point),
                        t: hit.t,
                    },
                    through: d.through(l, lights),
                    secondary: d.secondary[l],
                    color: d.colors[l],
                    gives: true,
                    whole: d.tree_coefficients[l] <= tolerance,
                },
            );
            tracer.counts.fast.cache.entries += 1;
        }
        lanes.clear();
    }

    /// The batch's row with the rig's shading cache, in two steps:
    ///
    /// 1. The leader's (view 0's) samples: one that may take light and finds
    ///    an entry of an earlier leader points to it; one that may give and
    ///    finds none is shaded as a donor and kept; the others' groups are
    ///    shaded exactly. The leader's new entries are then judged
    ///    (`ShadingCache::settle`: no shadow edge next to them).
    /// 2. Every other sample (and the leader's pointing ones) takes the colour
    ///    of the entry it finds if that may be taken whole, else its light,
    ///    else is shaded exactly, the rest of its group as one group.
    ///
    /// Donors, takers and exact groups each go eight lanes to a packet
    /// (`packed`). A leader's look-up in step 1 finds no entry of its own
    /// leader (they are judged only by `settle`), so keeping the donors a
    /// packet late finds what keeping each at once did.
    pub(in crate::render) fn share_shading(
        &self,
        tracer: &mut Tracer,
        row: &SampleRow,
        scratch: &mut RowScratch<K>,
        tolerance: f32,
        out: &mut [RowColors],
    ) {
        let mut cache = std::mem::take(&mut tracer.shading_cache);
        if self.first_view == 0 {
            cache.start_row(self.world.scene.lights.len(), tolerance);
        }
        cache.begin_leader(self.rig.views[0], row.len());
        let groups = std::mem::take(&mut scratch.groups);
        let mut donors = std::mem::take(&mut scratch.donors);
        let mut takers = std::mem::take(&mut scratch.takers);
        let mut exact = self.lanes();
        // Per group: shaded whole in step 1; per leader sample: its entry, and
        // whether it was shaded alone (its colour is in `out` already).
        let mut whole = vec![false; groups.len()];
        let mut leader: Vec<Option<(Found, bool)>> = vec![None; row.len()];
        for (g, group) in groups.iter().enumerate() {
            let Some(i) = group[0] else { continue };
            if !self.gives_light(scratch, 0, i, tolerance) {
                self.push_group(tracer, scratch, group, &mut exact, out);
                whole[g] = true;
                continue;
            }
            if let Some(found) = self.look_up(&cache, row, scratch, 0, i) {
                cache.point_to(i, found);
                leader[i] = Some((found, false));
                continue;
            }
            self.push_donor(scratch, &mut donors, i);
            if donors.lanes.as_ref().is_some_and(Lanes::is_full) {
                self.keep_donors(tracer, &mut cache, scratch, &mut donors, tolerance, out);
            }
        }
        self.keep_donors(tracer, &mut cache, scratch, &mut donors, tolerance, out);
        tracer.counts.fast.cache.edge_refusals += cache.settle();
        for (g, group) in groups.iter().enumerate() {
            if whole[g] {
                continue;
            }
            let mut rest = [None; K];
            for (v, sample) in group.iter().enumerate() {
                let Some(k) = *sample else { continue };
                let at = (v, k);
                let Some(found) =
                    self.entry_of(tracer, &cache, row, scratch, &leader, tolerance, at)
                else {
                    continue; // a leader's sample shaded as a donor in step 1
                };
                match found {
                    Some(found) => self.take(tracer, &cache, scratch, &mut takers, found, at, out),
                    None => rest[v] = Some(k),
                }
            }
            if rest.iter().any(Option::is_some) {
                self.push_group(tracer, scratch, &rest, &mut exact, out);
            }
        }
        self.shade_takers(tracer, &mut takers, out);
        self.shade_lanes(tracer, &mut exact, out);
        scratch.groups = groups;
        scratch.donors = donors;
        scratch.takers = takers;
        tracer.shading_cache = cache;
    }

    /// Step 2's entry for view `v`'s sample `k`: `None` for a leader's
    /// sample shaded as a donor in step 1 (it is done), else the entry it
    /// finds, if any (a sample that may take light and finds none is a
    /// fall-back).
    #[allow(clippy::too_many_arguments)]
    fn entry_of(
        &self,
        tracer: &mut Tracer,
        cache: &ShadingCache,
        row: &SampleRow,
        scratch: &RowScratch<K>,
        leader: &[Option<(Found, bool)>],
        tolerance: f32,
        (v, k): (usize, usize),
    ) -> Option<Option<Found>> {
        if v == 0 {
            return match leader[k] {
                Some((found, false)) => Some(Some(found)),
                _ => None,
            };
        }
        if !self.gives_light(scratch, v, k, tolerance) {
            return Some(None);
        }
        let found = self.look_up(cache, row, scratch, v, k);
        tracer.counts.fast.cache.fallbacks += u64::from(found.is_none());
        Some(found)
    }

    /// View `v`'s sample `k` takes the entry it found: its colour whole if
    /// it may be taken so (a lookup, nothing else), else its light (the
    /// sample joins the packet of takers).
    #[allow(clippy::too_many_arguments)]
    fn take(
        &self,
        tracer: &mut Tracer,
        cache: &ShadingCache,
        scratch: &RowScratch<K>,
        takers: &mut TakerPacket,
        found: Found,
        (v, k): (usize, usize),
        out: &mut [RowColors],
    ) {
        tracer.counts.fast.cache.hits += 1;
        if let Some(color) = cache.finished(found) {
            tracer.counts.fast.cache.colour_hits += 1;
            out[v][k] = color;
        } else {
            let light = cache.light(found);
            self.push_taker(tracer, scratch, takers, (v, k), light, out);
        }
    }
}

//! Stage 4, shared shading across the rig (approximate, `--share-shading`):
//! the batches of a row fill and read one [`ShadingCache`], so a surface
//! point's shadow and secondary rays are traced once for every view that sees
//! it, not once per batch (see `shading_cache` for the cell, the entry and
//! the bound of the tolerance).

use super::packed::{DonorPacket, Lanes};
use super::{RowScratch, TwinBatch};
use crate::render::grouping::Group;
use crate::render::sampler::{RowColors, SampleRow};
use crate::render::shading_cache::{Found, Kept, ShadingCache};
use crate::render::Tracer;

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
        cache.find(self.camera, row, i, prim, point, hit.t)
    }

    /// `group` shaded exactly: with key views if they apply
    /// (`shade_with_key_views`), else its lanes join the packet `exact`.
    fn shade_exactly(
        &self,
        tracer: &mut Tracer,
        scratch: &mut RowScratch<K>,
        group: &Group<K>,
        tolerance: f32,
        exact: &mut Lanes,
        out: &mut [RowColors],
    ) {
        if tolerance > 0.0 && self.key_spacing != 1 {
            self.shade_with_key_views(tracer, scratch, group, tolerance, out);
        } else {
            self.push_group(tracer, scratch, group, exact, out);
        }
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
                    prim,
                    point,
                    t: hit.t,
                    through: d.through(l, lights),
                    secondary: d.secondary[l],
                    color: d.colors[l],
                    gives: true,
                    whole: d.tree_coefficients[l] <= tolerance,
                },
            );
            tracer.counts.cache_entries += 1;
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
    pub(super) fn share_shading(
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
        scratch.keys.start_row();
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
                self.shade_exactly(tracer, scratch, group, tolerance, &mut exact, out);
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
        tracer.counts.cache_edge_refusals += cache.settle();
        for (g, group) in groups.iter().enumerate() {
            if whole[g] {
                continue;
            }
            let mut rest = [None; K];
            for (v, sample) in group.iter().enumerate() {
                let Some(k) = *sample else { continue };
                let found = if v == 0 {
                    match leader[k] {
                        Some((found, false)) => Some(found),
                        _ => continue, // shaded as a donor in step 1
                    }
                } else if self.gives_light(scratch, v, k, tolerance) {
                    let found = self.look_up(&cache, row, scratch, v, k);
                    tracer.counts.cache_fallbacks += u64::from(found.is_none());
                    found
                } else {
                    None
                };
                // A sample that finds an entry takes its colour whole if it
                // may be taken so (a lookup, nothing else), else its light
                // (it joins the packet of takers).
                match found {
                    Some(found) => {
                        tracer.counts.cache_hits += 1;
                        if let Some(color) = cache.finished(found) {
                            tracer.counts.cache_colour_hits += 1;
                            out[v][k] = color;
                        } else {
                            let light = cache.light(found);
                            self.push_taker(tracer, scratch, &mut takers, (v, k), light, out);
                        }
                    }
                    None => rest[v] = Some(k),
                }
            }
            if rest.iter().any(Option::is_some) {
                self.shade_exactly(tracer, scratch, &rest, tolerance, &mut exact, out);
            }
        }
        self.shade_takers(tracer, &mut takers, out);
        self.shade_lanes(tracer, &mut exact, out);
        scratch.groups = groups;
        scratch.donors = donors;
        scratch.takers = takers;
        tracer.shading_cache = cache;
    }
}

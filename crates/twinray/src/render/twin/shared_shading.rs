//! Stage 4, shared shading across the rig (approximate, `--share-shading`):
//! the batches of a row fill and read one [`ShadingCache`], so a surface
//! point's shadow and secondary rays are traced once for every view that sees
//! it, not once per batch (see `shading_cache` for the cell, the entry and
//! the bound of the tolerance).

use super::{RowScratch, TwinBatch};
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

    /// View `v`'s sample `i` shaded with the cache's `found`: its colour
    /// whole if it may be taken so (a lookup, nothing else), else its light.
    fn shade_found(
        &self,
        tracer: &mut Tracer,
        cache: &ShadingCache,
        scratch: &mut RowScratch<K>,
        found: Found,
        (v, i): (usize, usize),
    ) -> crate::math::Color {
        tracer.counts.cache_hits += 1;
        if let Some(color) = cache.finished(found) {
            tracer.counts.cache_colour_hits += 1;
            return color;
        }
        let (through, secondary) = cache.light(found);
        scratch.donor.through.clear();
        scratch.donor.through.extend_from_slice(through);
        scratch.donor.secondary = secondary;
        let (packet, hits) = self.sample_packet(scratch, v, i);
        tracer.shade_from_donor(&packet, &hits, &scratch.donor)
    }

    /// The batch's row with the rig's shading cache, in two steps:
    ///
    /// 1. The leader's (view 0's) samples: one that may take light and finds
    ///    an entry of an earlier leader points to it; one that may give and
    ///    finds none is shaded alone and kept; the others' groups are shaded
    ///    as packets, exactly. The leader's new entries are then judged
    ///    (`ShadingCache::settle`: no shadow edge next to them).
    /// 2. Every other sample (and the leader's pointing ones) takes the colour
    ///    of the entry it finds if that may be taken whole, else its light,
    ///    else is shaded exactly, the rest of its group as one packet.
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
        // Per group: shaded whole in step 1; per leader sample: its entry, and
        // whether it was shaded alone (its colour is in `out` already).
        let mut whole = vec![false; groups.len()];
        let mut leader: Vec<Option<(Found, bool)>> = vec![None; row.len()];
        for (g, group) in groups.iter().enumerate() {
            let Some(i) = group[0] else { continue };
            if !self.gives_light(scratch, 0, i, tolerance) {
                self.shade_with_key_views(tracer, scratch, group, tolerance, out);
                whole[g] = true;
                continue;
            }
            if let Some(found) = self.look_up(&cache, row, scratch, 0, i) {
                cache.point_to(i, found);
                leader[i] = Some((found, false));
                continue;
            }
            let (packet, hits) = self.sample_packet(scratch, 0, i);
            let mut donor = std::mem::take(&mut scratch.donor);
            tracer.shade_donor(&packet, &hits, self.secondary, &mut donor);
            out[0][i] = donor.color;
            let point = scratch.points[0][i].unwrap_or_default();
            let (prim, hit) = scratch.hits[0][i];
            cache.keep(
                i,
                Kept {
                    prim,
                    point,
                    t: hit.t,
                    through: &donor.through,
                    secondary: donor.secondary,
                    color: donor.color,
                    gives: true,
                    whole: donor.tree_coefficient <= tolerance,
                },
            );
            scratch.donor = donor;
            tracer.counts.cache_entries += 1;
        }
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
                        _ => continue, // shaded alone in step 1
                    }
                } else if self.gives_light(scratch, v, k, tolerance) {
                    let found = self.look_up(&cache, row, scratch, v, k);
                    tracer.counts.cache_fallbacks += u64::from(found.is_none());
                    found
                } else {
                    None
                };
                match found {
                    Some(found) => {
                        out[v][k] = self.shade_found(tracer, &cache, scratch, found, (v, k))
                    }
                    None => rest[v] = Some(k),
                }
            }
            if rest.iter().any(Option::is_some) {
                self.shade_with_key_views(tracer, scratch, &rest, tolerance, out);
            }
        }
        scratch.groups = groups;
        tracer.shading_cache = cache;
    }
}

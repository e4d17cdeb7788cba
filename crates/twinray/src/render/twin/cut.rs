//! The paper's cut of the object tree as the twin batches see it: the
//! objects beyond the cut depth (`world::Cut`) are hit by the rig centre's
//! ray along each camera column, traced and shaded once for every view
//! ("one lane, one shading").

use super::batch::{RowScratch, TwinBatch};
use crate::bvh::PacketHits;
use crate::math::Vec3;
use crate::render::sampler::{RowColors, SampleRow};
use crate::render::tracer::Tracer;
use crate::shapes::SurfaceHit;

impl<const K: usize> TwinBatch<'_, K> {
    /// With a cut: the rig centre's ray along the camera column of view `v`'s
    /// sample `i` (through the row's pattern in that column, as the centre's
    /// own sample), and its nearest hit beyond the cut; traced once per column.
    pub(in crate::render) fn far_ray(
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
    pub(in crate::render) fn column(
        &self,
        scratch: &RowScratch<K>,
        row: &SampleRow,
        view: usize,
        i: usize,
    ) -> usize {
        (row.pixels[i] + self.shifts[view] - scratch.first_column) as usize
    }

    /// With a cut: the samples whose nearest hit lies beyond it take the shading
    /// of the rig centre's ray along their camera column, computed once per
    /// column for all views (the paper's "one lane, one shading").
    pub(in crate::render) fn shade_cut(
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
                        let color = tracer.shade_eye(&centre, &hits, self.shading.secondary)[0];
                        scratch.far_colors[c] = Some(color);
                        color
                    }
                };
                *sample_out = color;
                tracer.counts.paper.samples_cut += 1;
            }
        }
    }
}

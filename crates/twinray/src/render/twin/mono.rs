//! A batch of one view with nothing to share, traced without the grouping:
//! a mono render's row (eight samples to a packet, flat materials shaded
//! once).

use std::time::Instant;

use super::batch::Sharing;
use super::batch::{RowScratch, TwinBatch, NONE};
use crate::bvh::{PacketHits, EYE_PACKET};
use crate::math::Vec3;
use crate::render::sampler::{RowColors, SampleRow};
use crate::render::tracer::Tracer;
use crate::shapes::SurfaceHit;

impl<const K: usize> TwinBatch<'_, K> {
    /// A batch of one view with nothing to share (no cut, reprojection or shared shading): the eye pass and the shading of
    /// `trace_row` without the grouping. Each sample is the group of one that
    /// `group_row` would make, shaded by the same calls in the same order
    /// (same packet, same hit), so the colours and counts are the same; what
    /// goes is the per-view buffers, the points and claims of the grouping,
    /// and the group packets' copies (docs/benchmarks.md, the mono path).
    pub(in crate::render) fn trace_mono_row(
        &self,
        tracer: &mut Tracer,
        row: &SampleRow,
        scratch: &mut RowScratch<K>,
        out: &mut [RowColors],
    ) {
        let start = Instant::now();
        self.mono_eye_hits(tracer, row, &mut scratch.mono);
        let eye_pass = start.elapsed();
        self.shade_mono_row(tracer, scratch, out);
        tracer.counts.eye_pass_ns += eye_pass.as_nanos() as u64;
        tracer.counts.shading_pass_ns += (start.elapsed() - eye_pass).as_nanos() as u64;
    }

    /// The mono row's eye rays: per sample of `row`, its direction and
    /// nearest hit, into `mono`.
    #[inline]
    fn mono_eye_hits(
        &self,
        tracer: &mut Tracer,
        row: &SampleRow,
        mono: &mut Vec<(Vec3, u32, SurfaceHit)>,
    ) {
        let (origin, shift) = (self.origins[0], self.shifts[0]);
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
    }

    /// The mono row's hits shaded into `out[0]`, eight to a packet; a
    /// material whose hits all shade to one colour once.
    #[inline]
    fn shade_mono_row(
        &self,
        tracer: &mut Tracer,
        scratch: &mut RowScratch<K>,
        out: &mut [RowColors],
    ) {
        let origin = self.origins[0];
        let mono = &scratch.mono;
        let scene = &self.world.scene;
        let flat = &mut scratch.flat;
        flat.resize(scene.materials.len(), None);
        // Eight neighbouring samples shaded as one packet: their shadow
        // segments toward each light start a pixel apart and end together,
        // so they go down in one descent (`Bvh::occlusion`); each
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
            let shaded = tracer.shade_eye_lanes(&packet, &hits, self.shading.secondary);
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
    }

    /// Whether the batch is one view with nothing to share, traced by
    /// `trace_mono_row`.
    pub(in crate::render) fn is_mono(&self) -> bool {
        self.views == 1 && self.world.far.is_none() && self.shading.sharing == Sharing::Exact
    }
}

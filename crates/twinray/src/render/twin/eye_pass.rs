//! The eye pass of a twin batch: one packet per sample, lane `v` holding
//! view `v`'s ray through it (camera column `x + shift_v` plus the
//! sample's offset) — the paper's one eye ray through the twin objects,
//! returning the nearest hit of every view.

use super::batch::{fit, RowScratch, TwinBatch, NONE};
use crate::bvh::{Packet, PacketHits, EYE_PACKET};
use crate::math::Vec3;
use crate::render::sampler::SampleRow;
use crate::render::tracer::Tracer;

impl<const K: usize> TwinBatch<'_, K> {
    /// Stage 1: the nearest hit of every view's sample of `row`, one descent
    /// for the views' rays through the same sample position. With a cut
    /// (section 2.3), the objects beyond it are tested once per camera column,
    /// by the ray of the rig's centre: every view sees them as the centre does
    /// (their parallax is that of objects at infinity).
    pub(in crate::render) fn eye_pass(
        &self,
        tracer: &mut Tracer,
        row: &SampleRow,
        scratch: &mut RowScratch<K>,
    ) {
        let n = self.views;
        scratch.reset(n, row.len());
        for v in 0..n {
            let dirs = &mut scratch.dirs[v];
            self.row_dirs(row, self.shifts[v], |i, dir| dirs[i] = dir);
        }
        let cut = self.world.far.is_some();
        if cut {
            fit(&mut scratch.far, n, row.len(), false);
            scratch.first_column = row.pixels.first().copied().unwrap_or(0) + self.min_shift;
            let last = row.pixels.last().copied().unwrap_or(0) + self.max_shift;
            let columns = (last - scratch.first_column + 1).max(0) as usize;
            scratch.far_rays.clear();
            scratch.far_rays.resize(columns, None);
        }
        if !cut && tracer.eye_hit_applies() && n <= EYE_PACKET {
            return self.eye_pass_packed(tracer, row, scratch);
        }
        let all = if n == 32 { u32::MAX } else { (1u32 << n) - 1 };
        let view_of_lane: [usize; K] = std::array::from_fn(|l| self.first_view + l);
        for i in 0..row.len() {
            let mut packet = Packet {
                origins: self.origins,
                dirs: std::array::from_fn(|v| if v < n { scratch.dirs[v][i] } else { Vec3::Z }),
                t_min: self.camera.hither,
                t_max: [f32::INFINITY; K],
                mask: all,
            };
            let h = if cut {
                let mut far = [(PacketHits::<K>::NO_HIT, NONE); K];
                for (v, slot) in far.iter_mut().enumerate().take(n) {
                    let (_, prim, hit) = self.far_ray(tracer, row, scratch, v, i);
                    *slot = (prim, hit);
                    packet.t_max[v] = hit.t;
                }
                let mut h = tracer.eye_hits_split(&packet, true);
                for (v, &(prim, hit)) in far.iter().enumerate().take(n) {
                    scratch.far[v][i] = false;
                    if !h.has_hit(v) && prim != PacketHits::<K>::NO_HIT {
                        (h.prim[v], h.hit[v]) = (prim, hit);
                        scratch.far[v][i] = true;
                    }
                }
                tracer.count_eye_hits(&packet, &h, &view_of_lane);
                h
            } else {
                tracer.eye_hits(&packet, &view_of_lane)
            };
            for v in 0..n {
                scratch.hits[v][i] = (h.prim[v], h.hit[v]);
                scratch.points[v][i] = (h.has_hit(v) && !(cut && scratch.far[v][i]))
                    .then(|| self.origins[v] + packet.dirs[v] * h.hit[v].t);
            }
        }
    }

    /// `eye_pass` for a batch of at most eight views, without a cut, where `eye_hit_applies`: the views' rays of a few neighbouring
    /// samples (two for four views) in one eight-ray descent
    /// (`Tracer::eye_hits8`; lane `l` is view `l % n` of the chunk's sample
    /// `l / n`), each hit bit for bit the ray's alone; a packet refused (its
    /// rays' direction signs differ) traced sample by sample, as without
    /// packets. A packet counts as one traversal, as a batch's packet of
    /// views does.
    pub(in crate::render) fn eye_pass_packed(
        &self,
        tracer: &mut Tracer,
        row: &SampleRow,
        scratch: &mut RowScratch<K>,
    ) {
        let n = self.views;
        let per = EYE_PACKET / n;
        let views: [usize; EYE_PACKET] = std::array::from_fn(|l| self.first_view + l % n);
        // One packet for the row, its lanes written in place (as in
        // `trace_mono_row`: a packet made whole and moved stalls on the
        // reload of its narrow stores).
        let mut packet = Packet {
            origins: std::array::from_fn(|l| self.origins[l % n]),
            dirs: [Vec3::Z; EYE_PACKET],
            t_min: self.camera.hither,
            t_max: [f32::INFINITY; EYE_PACKET],
            mask: 0,
        };
        for first in (0..row.len()).step_by(per) {
            let lanes = per.min(row.len() - first) * n;
            for (l, d) in packet.dirs.iter_mut().enumerate().take(lanes) {
                *d = scratch.dirs[l % n][first + l / n];
            }
            packet.mask = (1u32 << lanes) - 1;
            let hits = match lanes > 1 {
                true => tracer.eye_hits8(&packet, &views),
                false => None,
            };
            let Some(hits) = hits else {
                // Refused: each sample's views as one batch packet, as
                // without packets.
                for i in first..first + lanes / n {
                    let batch = Packet {
                        origins: self.origins,
                        dirs: std::array::from_fn(|v| match v < n {
                            true => scratch.dirs[v][i],
                            false => Vec3::Z,
                        }),
                        t_min: self.camera.hither,
                        t_max: [f32::INFINITY; K],
                        mask: (1u32 << n) - 1,
                    };
                    let h = tracer.eye_hits(&batch, &std::array::from_fn(|l| self.first_view + l));
                    for v in 0..n {
                        scratch.hits[v][i] = (h.prim[v], h.hit[v]);
                        scratch.points[v][i] = h
                            .has_hit(v)
                            .then(|| self.origins[v] + batch.dirs[v] * h.hit[v].t);
                    }
                }
                continue;
            };
            for l in 0..lanes {
                let (v, i, dir) = (l % n, first + l / n, packet.dirs[l]);
                let (prim, hit) = (hits.prim[l], hits.hit[l]);
                scratch.hits[v][i] = (prim, hit);
                scratch.points[v][i] =
                    (prim != PacketHits::<K>::NO_HIT).then(|| self.origins[v] + dir * hit.t);
            }
        }
    }
}

//! The twin method for panoramas (`rig::projection`): the views' rays
//! through one sample traced in one descent and shaded as one packet.
//!
//! A panorama's eye rays do not come from one point per view (an ODS eye
//! sits on a circle, its origin turning with the pixel's direction), so
//! the flat rig's grouping by projection into the other view's row does
//! not apply. What does: the eyes' rays through one sample are parallel
//! (ODS: one direction; VR180: parallel cameras) from origins a few
//! centimetres apart, so they go down the hierarchy together, exactly as
//! a flat pair's. Lanes are (sample, view), sample-major: a packet of
//! eight holds both eyes of four neighbouring samples. Every lane's rays
//! are its own, so each colour is the independent render's bit for bit.

use super::batch::{RenderInputs, RowWorker, ViewBatch};
use super::sampler::{RowColors, SampleRow};
use super::tracer::{SecondaryRays, Tracer};
use crate::bvh::{Packet, PacketHits, EYE_PACKET};
use crate::math::{Color, Vec3};
use crate::rig::{Camera, Rig, View};
use crate::scene::Scene;
use crate::shapes::SurfaceHit;

/// Most views of a panorama: one eye, or a pair.
pub const MAX_PANORAMA_VIEWS: usize = 2;

/// Refuses what a panorama cannot be rendered with: more than two views,
/// or convergence shifts (a panorama's eyes converge at infinity).
pub(in crate::render) fn check(camera: &Camera, rig: &Rig) -> crate::Result<()> {
    let name = camera.projection.name();
    if rig.views.len() > MAX_PANORAMA_VIEWS {
        return Err(crate::Error::Invalid(format!(
            "{} views of a {name} panorama: one, or a stereo pair",
            rig.views.len()
        )));
    }
    if rig.views.iter().any(|v| v.shift != 0) {
        return Err(crate::Error::Invalid(format!(
            "a {name} panorama's eyes converge at infinity: no convergence shift"
        )));
    }
    Ok(())
}

/// Views of a panorama from `first_view` on, traced together.
pub(in crate::render) struct PanoramaTwin<'a> {
    camera: &'a Camera,
    scene: &'a Scene,
    views: Vec<View>,
    first_view: usize,
}

impl<'a> PanoramaTwin<'a> {
    /// Every view of the panorama.
    pub(in crate::render) fn new(job: &RenderInputs<'a>) -> PanoramaTwin<'a> {
        PanoramaTwin {
            camera: job.camera,
            scene: &job.world.scene,
            views: job.rig.views.clone(),
            first_view: 0,
        }
    }

    /// View `view` of the panorama alone.
    pub(in crate::render) fn solo(job: &RenderInputs<'a>, view: usize) -> PanoramaTwin<'a> {
        PanoramaTwin {
            views: vec![job.rig.views[view]],
            first_view: view,
            ..PanoramaTwin::new(job)
        }
    }
}

impl PanoramaTwin<'_> {
    /// A packet of eight eye rays, its lanes written in place.
    fn empty_packet(&self) -> Packet<EYE_PACKET> {
        Packet {
            origins: [self.camera.eye; EYE_PACKET],
            dirs: [Vec3::Z; EYE_PACKET],
            t_min: self.camera.hither,
            t_max: [f32::INFINITY; EYE_PACKET],
            mask: 0,
        }
    }
}

impl ViewBatch for PanoramaTwin<'_> {
    fn view_count(&self) -> usize {
        self.views.len()
    }

    fn worker(&self) -> Box<dyn RowWorker + '_> {
        Box::new(PanoramaWorker {
            batch: self,
            lanes: Vec::new(),
        })
    }
}

/// One (sample, view) of a row with a ray: where its colour goes, its ray
/// and its nearest hit.
#[derive(Clone, Copy)]
struct Lane {
    sample: u32,
    view: u32,
    origin: Vec3,
    dir: Vec3,
    prim: u32,
    hit: SurfaceHit,
}

struct PanoramaWorker<'s, 'a> {
    batch: &'s PanoramaTwin<'a>,
    lanes: Vec<Lane>,
}

const NO_HIT: u32 = PacketHits::<EYE_PACKET>::NO_HIT;

impl RowWorker for PanoramaWorker<'_, '_> {
    fn trace(&mut self, tracer: &mut Tracer, row: &SampleRow, out: &mut [RowColors]) {
        let batch = self.batch;
        let camera = batch.camera;
        let none = PacketHits::<1>::none().hit[0];
        self.lanes.clear();
        let frame = camera.frame();
        // Every view's shift is 0 (`check`): one image position per sample,
        // its direction computed once for the views.
        for i in 0..row.len() {
            let (column, y) = row.camera_point(i, 0);
            let ray = camera.projection.sample_ray(&frame, column, y);
            for (v, view) in batch.views.iter().enumerate() {
                match ray {
                    Some(r) => self.lanes.push(Lane {
                        sample: i as u32,
                        view: v as u32,
                        origin: r.origin(&frame, view.offset),
                        dir: r.dir,
                        prim: NO_HIT,
                        hit: none,
                    }),
                    None => {
                        if let Some(c) = out[v].get_mut(i) {
                            *c = Color::ZERO;
                        }
                    }
                }
            }
        }
        self.eye_pass(tracer);
        self.shade(tracer, out);
    }
}

impl PanoramaWorker<'_, '_> {
    /// The nearest hit of every lane, eight lanes (the eyes of neighbouring
    /// samples) to a descent.
    fn eye_pass(&mut self, tracer: &mut Tracer) {
        let mut packet = self.batch.empty_packet();
        let eight = tracer.eye_hit_applies();
        let mut views = [0usize; EYE_PACKET];
        for chunk in self.lanes.chunks_mut(EYE_PACKET) {
            for (l, lane) in chunk.iter().enumerate() {
                packet.origins[l] = lane.origin;
                packet.dirs[l] = lane.dir;
                views[l] = self.batch.first_view + lane.view as usize;
            }
            packet.mask = (1u32 << chunk.len()) - 1;
            let hits = match eight && chunk.len() > 1 {
                true => tracer.eye_hits8(&packet, &views),
                false => None,
            };
            // Refused (the lanes' direction signs differ) or not applicable:
            // the general descent of a packet, one for the chunk.
            let hits = hits.unwrap_or_else(|| tracer.eye_hits(&packet, &views));
            for (l, lane) in chunk.iter_mut().enumerate() {
                (lane.prim, lane.hit) = (hits.prim[l], hits.hit[l]);
            }
        }
    }

    /// The lanes' colours: a miss sees the background, hits are shaded
    /// eight to a packet.
    fn shade(&mut self, tracer: &mut Tracer, out: &mut [RowColors]) {
        let scene = self.batch.scene;
        let mut packet = self.batch.empty_packet();
        let mut hits = PacketHits::<EYE_PACKET>::none();
        let mut slots = [(0usize, 0usize); EYE_PACKET];
        let mut n = 0;
        let mut flush = |packet: &mut Packet<EYE_PACKET>,
                         hits: &PacketHits<EYE_PACKET>,
                         slots: &[(usize, usize)],
                         n: &mut usize,
                         out: &mut [RowColors]| {
            if *n == 0 {
                return;
            }
            packet.mask = (1u32 << *n) - 1;
            let shaded = tracer.shade_eye(packet, hits, SecondaryRays::Own);
            for (l, &(v, i)) in slots[..*n].iter().enumerate() {
                out[v][i] = shaded[l];
            }
            *n = 0;
        };
        for lane in &self.lanes {
            let (v, i) = (lane.view as usize, lane.sample as usize);
            if lane.prim == NO_HIT {
                out[v][i] = scene.background_toward(lane.dir);
                continue;
            }
            packet.origins[n] = lane.origin;
            packet.dirs[n] = lane.dir;
            (hits.prim[n], hits.hit[n]) = (lane.prim, lane.hit);
            slots[n] = (v, i);
            n += 1;
            if n == EYE_PACKET {
                flush(&mut packet, &hits, &slots, &mut n, out);
            }
        }
        flush(&mut packet, &hits, &slots, &mut n, out);
    }
}

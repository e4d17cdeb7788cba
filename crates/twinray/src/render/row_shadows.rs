//! Shared shadows (issue 16, `--shadow-fans`): the shadow rays of a run of
//! views' hits on one primitive toward one point light, proved free by one
//! shadow fan (`bvh::ShadowFan`) instead of one ray per view. Exact.
//!
//! Once a row's eye hits are known for every view (the strip pass, or every
//! batch's eye pass run before any shading), the views are re-indexed by
//! camera column: view `v`'s sample in pixel `p` looks along column
//! `p + shift_v`. Along a column, the consecutive views (by offset) whose hits
//! lie on one primitive form a run: parallel rays from the camera line, their
//! hits nearly on a line. For each run and each light with a position, the
//! segments are built as the shading builds its shadow rays (the hit point,
//! moved off the surface by `shading::offset_point` along the unbent normal
//! turned toward the eye, to the light) and asked of `Tracer::fan_is_free`.
//! A free fan proves that no primitive meets any of those segments, so each
//! of those shadow rays would find nothing and return transmittance 1 (and
//! leave the shadow cache as it is): the shading takes 1 without tracing
//! (`Tracer::light_transmittance`). A fan that is not free proves nothing;
//! its lanes trace their own shadow rays, as without the fans.

use super::sampler::SampleRow;
use super::strip::StripRow;
use super::Tracer;
use crate::bvh::PacketHits;
use crate::math::Vec3;
use crate::rig::{Camera, Rig};
use crate::shading::offset_point;
use crate::shapes::SurfaceHit;
use crate::world::World;

/// The fewest hits a fan is asked for: a run of one view has no ray to share.
pub(super) const MIN_RUN: usize = 2;

/// A run whose fan is met is split in two and each half asked once, if both
/// halves have at least `MIN_RUN` hits and the run at least this many.
const SPLIT_RUN: usize = 4;

/// What every row of a render's shared shadows shares: the views by
/// ascending offset and the lights a fan can express.
pub(super) struct RowShadowPass<'a> {
    world: &'a World,
    camera: &'a Camera,
    /// The rig's views by ascending offset: (view, shift).
    views: Vec<(usize, i32)>,
    /// Every view's eye, as the twin batches compute it.
    origins: Vec<Vec3>,
    /// (index, position) of every light with a position (point and spot
    /// lights; a directional light's rays are traced as before).
    lights: Vec<(usize, Vec3)>,
    min_shift: i32,
    max_shift: i32,
}

/// One row's proofs, kept in the tracer (a tracer serves one task, whose rows
/// are traced in order), and the lanes of the next eye shading they cover.
#[derive(Default)]
pub(crate) struct RowShadows {
    /// Samples in the row, and lights in the scene (0: no proofs this row).
    len: usize,
    lights: usize,
    /// `proved[(view * len + sample) * lights + light]`: that sample's shadow
    /// ray toward that light is proved to meet nothing.
    proved: Vec<bool>,
    /// Per light, the lanes of the next eye shading (`select`) proved lit.
    lanes: Vec<u32>,
    index_of: Vec<u32>,
    members: Vec<Member>,
    origins: Vec<Vec3>,
}

/// A view's sample along a camera column, its hit, and where its shadow rays
/// start.
#[derive(Clone, Copy)]
struct Member {
    view: usize,
    sample: usize,
    prim: u32,
    /// The hit point and the shadow rays' origin (`offset_point` of it).
    point: Vec3,
    origin: Vec3,
    /// The unbent normal turned toward the eye (the offset's direction).
    off: Vec3,
}

impl<'a> RowShadowPass<'a> {
    /// The shared shadows of `rig`, or `None` where there is nothing to share
    /// (one view, no light with a position) or the eye pass needs more than
    /// every view's nearest hit (a cut of the object tree).
    pub(super) fn new(world: &'a World, camera: &'a Camera, rig: &Rig) -> Option<Self> {
        let lights: Vec<(usize, Vec3)> = world
            .scene
            .lights
            .iter()
            .enumerate()
            .filter_map(|(i, l)| l.position().map(|p| (i, p)))
            .collect();
        if world.far.is_some() || rig.views.len() < MIN_RUN || lights.is_empty() {
            return None;
        }
        let mut order: Vec<(usize, f32, i32)> = rig
            .views
            .iter()
            .enumerate()
            .map(|(v, view)| (v, view.offset, view.shift))
            .collect();
        order.sort_by(|a, b| a.1.total_cmp(&b.1));
        Some(RowShadowPass {
            world,
            camera,
            min_shift: order.iter().map(|v| v.2).min().unwrap_or(0),
            max_shift: order.iter().map(|v| v.2).max().unwrap_or(0),
            views: order.iter().map(|&(v, _, shift)| (v, shift)).collect(),
            origins: rig.views.iter().map(|v| camera.eye_at(v.offset)).collect(),
            lights,
        })
    }

    /// Proves what it can of the shadow rays of `row`, whose eye hits
    /// `eye.hits[v][i]` are known for every view, into `tracer.row_shadows`.
    pub(super) fn prove_row(&self, tracer: &mut Tracer, row: &SampleRow, eye: &StripRow) {
        let mut rs = std::mem::take(&mut tracer.row_shadows);
        rs.prove(self, tracer, row, &eye.hits);
        tracer.row_shadows = rs;
    }
}

impl RowShadows {
    /// No proofs (a row the fans did not see).
    pub(super) fn clear(&mut self) {
        self.len = 0;
        self.lanes.clear();
    }

    fn prove(
        &mut self,
        pass: &RowShadowPass,
        tracer: &mut Tracer,
        row: &SampleRow,
        hits: &[Vec<(u32, SurfaceHit)>],
    ) {
        self.clear();
        let (Some(&first), Some(&last)) = (row.pixels.first(), row.pixels.last()) else {
            return;
        };
        let lights = pass.world.scene.lights.len();
        let views = pass.origins.len();
        if hits.len() < views || hits.iter().any(|h| h.len() < row.len()) {
            return;
        }
        self.len = row.len();
        self.lights = lights;
        self.proved.clear();
        self.proved.resize(views * row.len() * lights, false);
        self.index_of.clear();
        self.index_of.resize((last - first + 1) as usize, u32::MAX);
        for (i, &p) in row.pixels.iter().enumerate() {
            self.index_of[(p - first) as usize] = i as u32;
        }
        for column in first + pass.min_shift..=last + pass.max_shift {
            self.members.clear();
            for &(v, shift) in &pass.views {
                let p = column - shift;
                let i = if p < first || p > last {
                    u32::MAX
                } else {
                    self.index_of[(p - first) as usize]
                };
                // A view with no sample here, or no lit hit, ends a run.
                let member = (i != u32::MAX)
                    .then(|| pass.member(row, v, shift, i as usize, hits[v][i as usize]))
                    .flatten();
                match member {
                    Some(m) if self.members.last().is_none_or(|l| l.prim == m.prim) => {
                        self.members.push(m)
                    }
                    other => {
                        self.prove_run(pass, tracer);
                        self.members.clear();
                        self.members.extend(other);
                    }
                }
            }
            self.prove_run(pass, tracer);
        }
    }

    /// The fans of the run in `members` toward every light with a position.
    fn prove_run(&mut self, pass: &RowShadowPass, tracer: &mut Tracer) {
        if self.members.len() < MIN_RUN {
            return;
        }
        let members = std::mem::take(&mut self.members);
        for &(light, position) in &pass.lights {
            // A hit whose surface faces away from the light puts its segment
            // through its own primitive: the fan cannot be free.
            if members.iter().any(|m| m.off.dot(position - m.point) <= 0.0) {
                continue;
            }
            if !self.prove_fan(tracer, &members, light, position) && members.len() >= SPLIT_RUN {
                let (a, b) = members.split_at(members.len() / 2);
                self.prove_fan(tracer, a, light, position);
                self.prove_fan(tracer, b, light, position);
            }
        }
        self.members = members;
    }

    /// Asks the fan of `run`'s segments toward `position`; marks them lit if
    /// it is free.
    fn prove_fan(
        &mut self,
        tracer: &mut Tracer,
        run: &[Member],
        light: usize,
        position: Vec3,
    ) -> bool {
        self.origins.clear();
        self.origins.extend(run.iter().map(|m| m.origin));
        // A shadow ray ends at origin + dir × |light − point|: off the light
        // by the origin's offset, and by the rounding of dir and distance.
        let mut end_error = 0.0f32;
        for m in run {
            let dist = (position - m.point).length();
            let round = 8.0 * f32::EPSILON * (dist + position.abs().max_element());
            end_error = end_error.max((m.origin - m.point).length() * 1.01 + round);
        }
        if !tracer.fan_is_free(&self.origins, position, end_error) {
            return false;
        }
        for m in run {
            self.proved[(m.view * self.len + m.sample) * self.lights + light] = true;
        }
        true
    }

    /// Sets the lanes of the next eye shading: lane `v` is view
    /// `first_view + v`'s sample `group[v]`.
    pub(super) fn select(&mut self, first_view: usize, group: &[Option<usize>]) {
        self.lanes.clear();
        if self.len == 0 {
            return;
        }
        self.lanes.resize(self.lights, 0);
        for (v, sample) in group.iter().enumerate() {
            let Some(i) = *sample else { continue };
            let at = ((first_view + v) * self.len + i) * self.lights;
            let Some(proved) = self.proved.get(at..at + self.lights) else {
                continue;
            };
            for (mask, &p) in self.lanes.iter_mut().zip(proved) {
                *mask |= u32::from(p) << v;
            }
        }
    }

    /// The lanes of the current eye shading proved lit toward light `i`.
    pub(super) fn lanes(&self, i: usize) -> u32 {
        self.lanes.get(i).copied().unwrap_or(0)
    }

    /// Forgets the selected lanes (used once, by the eye hits' direct light).
    pub(super) fn done(&mut self) {
        self.lanes.clear();
    }
}

impl RowShadowPass<'_> {
    /// View `v`'s (image shift `shift`) sample `i` of `row` with hit `hit`, if it takes direct light:
    /// its point and shadow rays' origin, as `Tracer::surfaces` and
    /// `Tracer::direct_light` compute them.
    fn member(
        &self,
        row: &SampleRow,
        v: usize,
        shift: i32,
        i: usize,
        hit: (u32, SurfaceHit),
    ) -> Option<Member> {
        let (prim, hit) = hit;
        if prim == PacketHits::<1>::NO_HIT {
            return None;
        }
        let scene = &self.world.scene;
        let material = self.world.material_of(prim);
        if !(material.kd > 0.0 || material.ks > 0.0) {
            return None;
        }
        let (column, y) = row.camera_point(i, shift);
        let d = self.camera.direction(column, y);
        let point = self.origins[v] + d * hit.t;
        let unbent = scene.surface_at(prim as usize, &hit, point).offset_normal;
        let off = if unbent.dot(d) < 0.0 { unbent } else { -unbent };
        Some(Member {
            view: v,
            sample: i,
            prim,
            point,
            origin: offset_point(point, off, hit.t),
            off,
        })
    }
}

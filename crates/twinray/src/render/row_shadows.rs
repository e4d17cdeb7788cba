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

/// The fewest hits a fan is asked for by default (`RenderOptions::
/// shadow_fan_min_run` 0): a fan's descent costs a hundred or more shadow
/// rays in packets of 4 (docs/benchmarks.md, "Issue 16, fourth pass"); of
/// 2, 4, 8 and 16, 8 and 16 cost least, 8 shares more.
pub(super) const DEFAULT_MIN_RUN: usize = 8;

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
    /// The fewest hits a fan is asked for.
    min_run: usize,
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
    /// Every run asked about: (view, sample, primitive) of its members.
    #[cfg(test)]
    runs: Vec<Vec<(usize, usize, u32)>>,
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
    /// every view's nearest hit (a cut of the object tree). Runs of fewer than
    /// `min_run` hits (0: `DEFAULT_MIN_RUN`) trace their rays.
    pub(super) fn new(
        world: &'a World,
        camera: &'a Camera,
        rig: &Rig,
        min_run: usize,
    ) -> Option<Self> {
        let min_run = match min_run {
            0 => DEFAULT_MIN_RUN,
            n => n.max(MIN_RUN),
        };
        let lights: Vec<(usize, Vec3)> = world
            .scene
            .lights
            .iter()
            .enumerate()
            .filter_map(|(i, l)| l.position().map(|p| (i, p)))
            .collect();
        if world.far.is_some() || rig.views.len() < min_run || lights.is_empty() {
            return None;
        }
        let order = rig.views_by_offset();
        Some(RowShadowPass {
            world,
            camera,
            min_shift: order.iter().map(|v| v.2).min().unwrap_or(0),
            max_shift: order.iter().map(|v| v.2).max().unwrap_or(0),
            views: order.iter().map(|&(v, _, shift)| (v, shift)).collect(),
            origins: rig.views.iter().map(|v| camera.eye_at(v.offset)).collect(),
            lights,
            min_run,
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
        if self.members.len() < pass.min_run {
            return;
        }
        let members = std::mem::take(&mut self.members);
        #[cfg(test)]
        self.runs
            .push(members.iter().map(|m| (m.view, m.sample, m.prim)).collect());
        for &(light, position) in &pass.lights {
            // A hit whose surface faces away from the light puts its segment
            // through its own primitive: the fan cannot be free.
            if members.iter().any(|m| m.off.dot(position - m.point) <= 0.0) {
                continue;
            }
            // A fan that is met is not split and asked again: measured,
            // the halves' descents cost more than the rays they save.
            self.prove_fan(tracer, &members, light, position);
        }
        self.members = members;
    }

    /// Asks the fan of `run`'s segments toward `position`; marks them lit if
    /// it is free.
    fn prove_fan(&mut self, tracer: &mut Tracer, run: &[Member], light: usize, position: Vec3) {
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
            return;
        }
        for m in run {
            self.proved[(m.view * self.len + m.sample) * self.lights + light] = true;
        }
    }

    /// Sets the lanes of the next eye shading: lane `v` is view
    /// `first_view + v`'s sample `group[v]`.
    pub(super) fn select(&mut self, first_view: usize, group: &[Option<usize>]) {
        self.select_lanes(
            group
                .iter()
                .enumerate()
                .filter_map(|(v, sample)| sample.map(|i| (v, first_view + v, i))),
        );
    }

    /// Sets the lanes of the next eye shading: `(lane, view, sample)`, each
    /// lane that view's sample (views counted in the whole rig).
    pub(super) fn select_lanes(&mut self, lanes: impl Iterator<Item = (usize, usize, usize)>) {
        self.lanes.clear();
        if self.len == 0 {
            return;
        }
        self.lanes.resize(self.lights, 0);
        for (lane, view, i) in lanes {
            let at = (view * self.len + i) * self.lights;
            let Some(proved) = self.proved.get(at..at + self.lights) else {
                continue;
            };
            for (mask, &p) in self.lanes.iter_mut().zip(proved) {
                *mask |= u32::from(p) << lane;
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::loaders::nff::parse_nff;
    use crate::loaders::LoadOptions;
    use crate::render::strip::StripEyePass;
    use crate::render::TraceSettings;

    /// A floor of two triangles, spheres on it and a pole, 12 converged
    /// views: every run is a maximal sequence of consecutive views (by
    /// offset) along one camera column whose hits lie on one primitive that
    /// takes light, of at least `MIN_RUN`; and runs are found on several
    /// primitives.
    #[test]
    fn runs_are_maximal_and_on_one_primitive() {
        let text = "b 0.1 0.1 0.2\nv\nfrom 0 -6 5\nat 0 0 0\nup 0 0 1\nangle 45\nhither 0.01\n\
            resolution 32 24\nl 3 2 10\n\
            f 0.8 0.8 0.7 0.7 0 20 0 1\np 4\n-20 -20 0\n20 -20 0\n20 20 0\n-20 20 0\n\
            f 0.9 0.2 0.2 0.7 0 30 0 1\ns -1 0 0.5 0.5\ns 1 1 0.4 0.4\n\
            f 0.9 0.3 0.2 0.8 0 10 0 1\nc\n0.3 -1 0 0.05\n0.3 -1 2 0.05\n";
        let scene = parse_nff(text, std::path::Path::new("t.nff"), &LoadOptions::default())
            .expect("test scene");
        let world = World::new(scene);
        let camera = Camera::new(&world.scene.viewpoint, 32, 24);
        let rig = Rig::multi_view(&camera, 12, 0.05, Some(7.0)).expect("rig");
        let strip = StripEyePass::new(&world, &camera, &rig).expect("strip");
        let pass = RowShadowPass::new(&world, &camera, &rig, MIN_RUN).expect("fans");
        let mut tracer = Tracer::new(&world, TraceSettings::default());
        let mut eye = StripRow::default();
        let order: Vec<usize> = pass.views.iter().map(|v| v.0).collect();
        let (mut runs, mut prims) = (0, std::collections::HashSet::new());
        for y in 0..24 {
            let row = SampleRow::centres(32, y);
            strip.trace_row(&mut tracer, &row, &mut eye);
            tracer.row_shadows.runs.clear();
            pass.prove_row(&mut tracer, &row, &eye);
            let lit = |v: usize, i: usize| {
                let (prim, _) = eye.hits[v][i];
                (prim != PacketHits::<1>::NO_HIT && world.material_of(prim).kd > 0.0)
                    .then_some(prim)
            };
            // The sample of the view at position `k` (by offset) in the
            // column of the run's first member.
            let column_sample = |run: &[(usize, usize, u32)], k: usize| {
                let (v0, i0, _) = run[0];
                let column = i0 as i32 + rig.views[v0].shift;
                let i = column - rig.views[order[k]].shift;
                (0..32).contains(&i).then_some(i as usize)
            };
            for run in &tracer.row_shadows.runs {
                assert!(run.len() >= MIN_RUN, "row {y}: {run:?}");
                let prim = run[0].2;
                let k0 = order.iter().position(|&v| v == run[0].0).expect("a view");
                for (j, &(v, i, p)) in run.iter().enumerate() {
                    assert_eq!(p, prim, "row {y}: one primitive, {run:?}");
                    assert_eq!(order[k0 + j], v, "row {y}: consecutive views");
                    assert_eq!(column_sample(run, k0 + j), Some(i), "row {y}: one column");
                    assert_eq!(lit(v, i), Some(prim), "row {y}: the hit's primitive");
                }
                // Maximal: the views just before and after see something else.
                let k1 = k0 + run.len();
                for k in [k0.wrapping_sub(1), k1] {
                    if k < order.len() {
                        let other = column_sample(run, k).and_then(|i| lit(order[k], i));
                        assert_ne!(other, Some(prim), "row {y}: {run:?} not maximal");
                    }
                }
                runs += 1;
                prims.insert(prim);
            }
        }
        assert!(
            runs > 100 && prims.len() >= 4,
            "{runs} runs on {} primitives",
            prims.len()
        );
    }
}
